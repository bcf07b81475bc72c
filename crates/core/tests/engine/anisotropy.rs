//! Anisotropic elasticity (FGCS 2.7′, design §2.1) against analytic answers: an orthotropic
//! material with isotropic constants is the isotropic one; rotating an orthotropic block with its
//! load rotates the solution; uniaxial stress of an orthotropic plate at 0°, 30° and 90° gives the
//! plane-strain compliance; the patch test with a general matrix; free anisotropic thermal
//! expansion is stress-free.

use crate::solves;

use solves::{bc, data, linear_patch_solve, material, max_abs};

use wsm_core::{
    fixtures::perturb_interior, fixtures::rectangle, fixtures::rotate, BoundaryData, BoundaryValue,
    Data, Elastic, ElasticProblem, Expansion, Mesh, MeshSegment, Orthotropic, Par, PlaneStrainLaw,
};

/// Single-node segment (a point support) added to the mesh.
fn point_segment(mesh: &mut Mesh, name: &str, at: [f64; 2]) {
    let node = mesh
        .nodes
        .iter()
        .position(|p| (p[0] - at[0]).abs() < 1e-12 && (p[1] - at[1]).abs() < 1e-12)
        .expect("node at point");
    mesh.segments.push(MeshSegment {
        name: name.into(),
        body: 0,
        nodes: vec![node],
        edges: vec![],
    });
}

fn solve(mesh: &Mesh, d: &Data, temperature: Option<&[f64]>) -> Vec<[f64; 2]> {
    let problem = ElasticProblem::new(mesh, d).unwrap();
    let factor = problem.factor(d, Par::Seq).unwrap();
    problem.solve(&factor, d, temperature).unwrap()
}

/// Layered-rock-like constants: E1 = 20, E2 = 10, E3 = 12 GPa, ν12 = 0.22, ν13 = 0.2,
/// ν23 = 0.25, G12 = 4 GPa.
fn rock(angle: f64) -> Orthotropic {
    Orthotropic {
        young: [20e9, 10e9, 12e9],
        poisson: [0.22, 0.2, 0.25],
        shear: 4e9,
        angle,
    }
}

/// A clamped-left rectangle under a traction on the right, gravity and a body force.
fn loaded_boundary(mesh: &Mesh, traction: [f64; 2]) -> Vec<BoundaryData> {
    vec![
        bc(
            mesh,
            "left",
            BoundaryValue::Displacement([Some(0.0), Some(0.0)]),
        ),
        bc(mesh, "right", BoundaryValue::Traction(traction)),
        bc(mesh, "top", BoundaryValue::Pressure(2e6)),
    ]
}

#[test]
fn orthotropic_with_isotropic_constants_equals_isotropic() {
    let mut mesh = rectangle(0.0, 0.0, 2.0, 1.0, 12, 7);
    perturb_interior(&mut mesh, 0.03, 11);
    let (e, nu, alpha) = (30e9, 0.27, 1e-5);
    let mut iso = material(Elastic::Young { e, nu });
    iso.specific_weight = 2.5e4;
    iso.body_force = [1e4, 0.0];
    iso.expansion = Expansion::Alpha(alpha);
    let mut ortho = iso.clone();
    ortho.elastic = Elastic::Orthotropic(Orthotropic {
        young: [e; 3],
        poisson: [nu; 3],
        shear: e / (2.0 * (1.0 + nu)),
        angle: 37.0,
    });
    let boundary = loaded_boundary(&mesh, [1e6, -5e5]);
    let temperature: Vec<f64> = mesh
        .nodes
        .iter()
        .map(|p| 10.0 * p[0] + 5.0 * p[1])
        .collect();
    let (di, dor) = (
        data(vec![iso], boundary.clone()),
        data(vec![ortho], boundary),
    );
    let (ui, uo) = (
        solve(&mesh, &di, Some(&temperature)),
        solve(&mesh, &dor, Some(&temperature)),
    );
    let scale = max_abs(&ui);
    let diff = ui
        .iter()
        .zip(&uo)
        .flat_map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
        .fold(0.0f64, |m, x| m.max(x.abs()));
    println!(
        "iso-equivalence: max |u_ortho − u_iso| / max |u| = {:.3e}",
        diff / scale
    );
    assert!(diff <= 1e-12 * scale, "{:e}", diff / scale);
    let problem = ElasticProblem::new(&mesh, &di).unwrap();
    let si = problem.stresses(&di, &ui, Some(&temperature)).unwrap();
    let so = problem.stresses(&dor, &uo, Some(&temperature)).unwrap();
    let sscale = si
        .iter()
        .flat_map(|s| s.stress)
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let sdiff = si
        .iter()
        .zip(&so)
        .flat_map(|(a, b)| (0..4).map(move |k| a.stress[k] - b.stress[k]))
        .fold(0.0f64, |m, x| m.max(x.abs()));
    println!(
        "iso-equivalence: stresses (τ33 included) {:.3e}",
        sdiff / sscale
    );
    assert!(sdiff <= 1e-11 * sscale, "{:e}", sdiff / sscale);
}

#[test]
fn rotating_block_and_load_rotates_the_solution() {
    let (phi, center) = (0.6_f64, [0.3, -0.2]);
    let (s, c) = phi.sin_cos();
    let rot = |v: [f64; 2]| [c * v[0] - s * v[1], s * v[0] + c * v[1]];
    let mut mesh = rectangle(0.0, 0.0, 2.0, 1.0, 12, 7);
    perturb_interior(&mut mesh, 0.03, 4);
    let mut m = material(Elastic::Orthotropic(rock(25.0)));
    m.body_force = [3e4, -2e4];
    let traction = [1e6, -4e5];
    let d = data(vec![m.clone()], loaded_boundary(&mesh, traction));
    let u = solve(&mesh, &d, None);

    let mut turned = mesh.clone();
    rotate(&mut turned, phi, center);
    let mut mr = m;
    mr.elastic = Elastic::Orthotropic(rock(25.0 + phi.to_degrees()));
    mr.body_force = rot([3e4, -2e4]);
    let dr = data(vec![mr], loaded_boundary(&turned, rot(traction)));
    let ur = solve(&turned, &dr, None);
    let scale = max_abs(&u);
    let diff = u
        .iter()
        .zip(&ur)
        .flat_map(|(a, b)| {
            let ra = rot(*a);
            [ra[0] - b[0], ra[1] - b[1]]
        })
        .fold(0.0f64, |m, x| m.max(x.abs()));
    println!(
        "rotation: max |R u − u_rotated| / max |u| = {:.3e}",
        diff / scale
    );
    assert!(diff <= 1e-10 * scale, "{:e}", diff / scale);
}

/// Uniaxial stress τ11 = σ of an orthotropic plate (pinned at a corner, a roller at the other,
/// tractions ±σ on the ends): uniform strain e = S̄(θ) (σ, 0, 0), S̄ the plane-strain compliance
/// S̄_ij = S_ij − S_i3 S_j3 / S33 in material axes, rotated; τ33 = −(S13 σ'11 + S23 σ'22)/S33.
#[test]
fn uniaxial_stress_matches_plane_strain_compliance() {
    let sigma = 5e6;
    for angle in [0.0_f64, 30.0, 90.0] {
        let o = rock(angle);
        let mut mesh = rectangle(0.0, 0.0, 3.0, 1.0, 12, 5);
        perturb_interior(&mut mesh, 0.04, 2);
        point_segment(&mut mesh, "pin", [0.0, 0.0]);
        point_segment(&mut mesh, "slide", [3.0, 0.0]);
        let boundary = vec![
            bc(&mesh, "left", BoundaryValue::Traction([-sigma, 0.0])),
            bc(&mesh, "right", BoundaryValue::Traction([sigma, 0.0])),
            bc(
                &mesh,
                "pin",
                BoundaryValue::Displacement([Some(0.0), Some(0.0)]),
            ),
            bc(&mesh, "slide", BoundaryValue::Roller(Some([0.0, 1.0]))),
        ];
        let d = data(vec![material(Elastic::Orthotropic(o))], boundary);
        let u = solve(&mesh, &d, None);
        let problem = ElasticProblem::new(&mesh, &d).unwrap();
        // Analytic: the stress in material axes, the reduced compliance, the strain rotated back.
        let [e1, e2, e3] = o.young;
        let [n12, n13, n23] = o.poisson;
        let sm = [
            [1.0 / e1, -n12 / e1, -n13 / e1],
            [-n12 / e1, 1.0 / e2, -n23 / e2],
            [-n13 / e1, -n23 / e2, 1.0 / e3],
        ];
        let reduced = |i: usize, j: usize| sm[i][j] - sm[i][2] * sm[j][2] / sm[2][2];
        let (sn, cs) = angle.to_radians().sin_cos();
        let (s11, s22, s12) = (sigma * cs * cs, sigma * sn * sn, -sigma * cs * sn);
        let eps11 = reduced(0, 0) * s11 + reduced(0, 1) * s22;
        let eps22 = reduced(0, 1) * s11 + reduced(1, 1) * s22;
        let gam12 = s12 / o.shear;
        let exact = [
            cs * cs * eps11 + sn * sn * eps22 - cs * sn * gam12,
            sn * sn * eps11 + cs * cs * eps22 + cs * sn * gam12,
            // Tensor shear e12 = ½ γ12.
            cs * sn * (eps11 - eps22) + 0.5 * (cs * cs - sn * sn) * gam12,
        ];
        let tau33 = -(sm[0][2] * s11 + sm[1][2] * s22) / sm[2][2];
        let strain_scale = exact.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut worst = (0.0f64, 0.0f64);
        for st in problem.stresses(&d, &u, None).unwrap() {
            for (a, b) in st.strain.iter().zip(exact) {
                worst.0 = worst.0.max((a - b).abs() / strain_scale);
            }
            for (a, b) in st.stress.iter().zip([sigma, 0.0, 0.0, tau33]) {
                worst.1 = worst.1.max((a - b).abs() / sigma);
            }
        }
        println!(
            "uniaxial {angle}°: E_x = {:.4e} Pa, strain error {:.3e}, stress error {:.3e}",
            sigma / exact[0],
            worst.0,
            worst.1
        );
        assert!(worst.0 < 1e-9 && worst.1 < 1e-9, "{angle}°: {worst:?}");
    }
}

#[test]
fn patch_test_with_a_general_matrix() {
    let mut mesh = rectangle(0.0, 0.0, 2.0, 1.0, 10, 6);
    perturb_interior(&mut mesh, 0.04, 42);
    let law = PlaneStrainLaw {
        d: [[7.0, 2.0, 0.8], [2.0, 5.0, -0.6], [0.8, -0.6, 3.0]],
        out_of_plane: [1.5, 1.1, 0.3],
    };
    let boundary = ["bottom", "left", "right", "top"]
        .iter()
        .map(|s| {
            bc(
                &mesh,
                s,
                BoundaryValue::Displacement([Some(0.0), Some(0.0)]),
            )
        })
        .collect();
    let d = data(vec![material(Elastic::Matrix(law))], boundary);
    let (problem, u, field) = linear_patch_solve(&mesh, &d);
    let scale = max_abs(&field);
    let err = u
        .iter()
        .zip(&field)
        .flat_map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
        .fold(0.0f64, |m, x| m.max(x.abs()));
    // e = (0.02, 0.04, γ = −0.02); τ = D e, τ33 = c·e.
    let e = [0.02, 0.04, -0.02];
    let row = |r: [f64; 3]| r[0] * e[0] + r[1] * e[1] + r[2] * e[2];
    let expected = [
        row(law.d[0]),
        row(law.d[1]),
        row(law.d[2]),
        row(law.out_of_plane),
    ];
    let mut stress_err = 0.0f64;
    for s in problem.stresses(&d, &u, None).unwrap() {
        for (a, b) in s.stress.iter().zip(expected) {
            stress_err = stress_err.max((a - b).abs());
        }
    }
    println!(
        "general-matrix patch: displacement {:.3e}, stress {stress_err:.3e}",
        err / scale
    );
    assert!(
        err <= 1e-10 * scale && stress_err < 1e-10,
        "{err:e} {stress_err:e}"
    );
}

/// A pinned orthotropic plate heated uniformly with an isotropic expansion α: no in-plane stress;
/// in material axes ε'_i = αΔT (1 + ν_i3 E3/E_i) (ε33 = 0 forces τ33 = −E3 α ΔT), rotated.
#[test]
fn free_anisotropic_thermal_expansion_is_stress_free() {
    let (alpha, t0, dt) = (8e-6, 283.0, 40.0);
    let o = rock(30.0);
    let mut mesh = rectangle(0.0, 0.0, 2.0, 1.0, 8, 5);
    perturb_interior(&mut mesh, 0.03, 9);
    point_segment(&mut mesh, "pin", [0.0, 0.0]);
    point_segment(&mut mesh, "slide", [2.0, 0.0]);
    let mut m = material(Elastic::Orthotropic(o));
    m.expansion = Expansion::Alpha(alpha);
    let beta = m.beta().unwrap();
    // The same material as a matrix with its Voigt β.
    let mut as_matrix = material(Elastic::Matrix(o.law().unwrap()));
    as_matrix.expansion = Expansion::Voigt(beta);
    let [e1, e2, e3] = o.young;
    let (local1, local2) = (
        alpha * dt * (1.0 + o.poisson[1] * e3 / e1),
        alpha * dt * (1.0 + o.poisson[2] * e3 / e2),
    );
    let (sn, cs) = o.angle.to_radians().sin_cos();
    let exact = [
        cs * cs * local1 + sn * sn * local2,
        sn * sn * local1 + cs * cs * local2,
        cs * sn * (local1 - local2),
    ];
    for m in [m, as_matrix] {
        let boundary = vec![
            bc(
                &mesh,
                "pin",
                BoundaryValue::Displacement([Some(0.0), Some(0.0)]),
            ),
            bc(&mesh, "slide", BoundaryValue::Roller(Some([0.0, 1.0]))),
        ];
        let mut d = data(vec![m], boundary);
        d.reference_temperature = t0;
        let temperature = vec![t0 + dt; mesh.nodes.len()];
        let u = solve(&mesh, &d, Some(&temperature));
        let problem = ElasticProblem::new(&mesh, &d).unwrap();
        let stress_scale = beta[0].abs() * dt;
        let (mut stress_err, mut strain_err, mut t33_err) = (0.0f64, 0.0f64, 0.0f64);
        for s in problem.stresses(&d, &u, Some(&temperature)).unwrap() {
            for k in 0..3 {
                stress_err = stress_err.max(s.stress[k].abs() / stress_scale);
                strain_err = strain_err.max((s.strain[k] - exact[k]).abs() / exact[0].abs());
            }
            t33_err = t33_err.max((s.stress[3] + e3 * alpha * dt).abs() / stress_scale);
        }
        println!(
            "free expansion: in-plane stress {stress_err:.3e}, strain {strain_err:.3e}, τ33 {t33_err:.3e}"
        );
        assert!(stress_err < 1e-10 && strain_err < 1e-10 && t33_err < 1e-10);
    }
}
