//! FEM verification (design §6, FEM part): patch tests, manufactured solutions with measured
//! convergence rates, the thick-walled cylinder (Lamé), free thermal expansion, heat across a
//! perfect thermal contact, floating bodies and conflicting constraints.

#[path = "../crates/core/tests/engine/solves.rs"]
mod solves;

use solves::{bc, data, linear_patch_solve, material, max_abs};

use std::f64::consts::PI;

use wsm_core::{
    fixtures::perturb_interior, fixtures::quarter_annulus, fixtures::rectangle, fixtures::rotate,
    fixtures::stacked_blocks, BoundaryData, BoundaryValue, Data, Elastic, ElasticProblem,
    Expansion, FemError, HeatProblem, MaterialData, Mesh, MeshSegment, Par, TriangleGradients,
};
use wsm_study::analytic::{field_errors, points, ExactField, LameCylinder, Manufactured};

// ---------- helpers ----------

fn lame(lambda: f64, mu: f64) -> MaterialData {
    material(Elastic::Lame { lambda, mu })
}

fn clamp_all(mesh: &Mesh) -> Vec<BoundaryData> {
    ["bottom", "left", "right", "top"]
        .iter()
        .map(|s| bc(mesh, s, BoundaryValue::Displacement([Some(0.0), Some(0.0)])))
        .collect()
}

fn sci(v: &[f64]) -> Vec<String> {
    v.iter().map(|x| format!("{x:.3e}")).collect()
}

fn rate(errors: &[f64]) -> Vec<f64> {
    errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect()
}

// ---------- patch tests ----------

#[test]
fn patch_test_linear_field_is_exact_on_perturbed_mesh() {
    let mut mesh = rectangle(0.0, 0.0, 2.0, 1.0, 10, 6);
    perturb_interior(&mut mesh, 0.04, 42);
    let d = data(vec![lame(3.0, 1.5)], clamp_all(&mesh));
    let (problem, u, field) = linear_patch_solve(&mesh, &d);
    let scale = max_abs(&field);
    for (n, (a, b)) in u.iter().zip(&field).enumerate() {
        for k in 0..2 {
            assert!(
                (a[k] - b[k]).abs() <= 1e-10 * scale,
                "node {n}: {a:?} vs {b:?}"
            );
        }
    }
    let stresses = problem.stresses(&d, &u, None).unwrap();
    // e11 = 0.02, e22 = 0.04, e12 = (−0.03 + 0.01)/2; τ = λ tr e I + 2μ e.
    let expected = [
        3.0 * 0.06 + 3.0 * 0.02,
        3.0 * 0.06 + 3.0 * 0.04,
        3.0 * -0.01,
        3.0 * 0.06,
    ];
    for s in &stresses {
        for k in 0..4 {
            assert!(
                (s.stress[k] - expected[k]).abs() < 1e-10,
                "{:?} vs {expected:?}",
                s.stress
            );
        }
    }
}

#[test]
fn patch_test_uniform_tension_with_rollers_and_traction() {
    let mut mesh = rectangle(0.0, 0.0, 3.0, 2.0, 9, 7);
    perturb_interior(&mut mesh, 0.05, 3);
    let (e, nu, s) = (210.0, 0.3, 2.5);
    let boundary = vec![
        bc(&mesh, "left", BoundaryValue::Roller(None)),
        bc(&mesh, "bottom", BoundaryValue::Roller(None)),
        bc(&mesh, "right", BoundaryValue::Traction([s, 0.0])),
    ];
    let d = data(vec![material(Elastic::Young { e, nu })], boundary);
    let problem = ElasticProblem::new(&mesh, &d).unwrap();
    let factor = problem.factor(&d, Par::Seq).unwrap();
    let u = problem.solve(&factor, &d, None).unwrap();
    // Plane strain uniaxial stress: e11 = (1 − ν²) s / E, e22 = −ν(1 + ν) s / E.
    let (e11, e22) = ((1.0 - nu * nu) * s / e, -nu * (1.0 + nu) * s / e);
    for (p, ui) in mesh.nodes.iter().zip(&u) {
        assert!((ui[0] - e11 * p[0]).abs() < 1e-12 && (ui[1] - e22 * p[1]).abs() < 1e-12);
    }
    for st in problem.stresses(&d, &u, None).unwrap() {
        let t = st.stress;
        assert!((t[0] - s).abs() < 1e-10 * s && t[1].abs() < 1e-10 * s && t[2].abs() < 1e-10 * s);
        assert!((t[3] - nu * s).abs() < 1e-10 * s, "τ33 = ν τ11");
        let i2 = st.i2_squared();
        let dev = [
            s - (1.0 + nu) * s / 3.0,
            -(1.0 + nu) * s / 3.0,
            (2.0 * nu - 1.0) * s / 3.0,
        ];
        let expected = dev.iter().map(|x| x * x).sum::<f64>();
        assert!((i2 - expected).abs() < 1e-9 * expected);
    }
}

// ---------- manufactured solutions ----------

/// (L² error, energy error) of the elastic manufactured solution on an n × n unit square.
fn elastic_errors(ms: &Manufactured, n: usize) -> (f64, f64) {
    let mut mesh = rectangle(0.0, 0.0, 1.0, 1.0, n, n);
    perturb_interior(&mut mesh, 0.15 / n as f64, 11);
    let d = data(vec![lame(ms.lambda, ms.mu)], clamp_all(&mesh));
    let problem = ElasticProblem::new(&mesh, &d).unwrap();
    let exact: Vec<[f64; 2]> = mesh.nodes.iter().map(|&p| ms.u(p)).collect();
    let factor = problem.factor(&d, Par::Seq).unwrap();
    let u = problem
        .solve_with(
            &factor,
            &ms.loads(&mesh),
            &problem.dofs().fixed_values_from(&exact).unwrap(),
        )
        .unwrap();
    let e = field_errors(&mesh, &u, ms, &|_| (ms.lambda, ms.mu));
    (e.l2, e.energy)
}

#[test]
fn manufactured_elasticity_converges_at_optimal_rates() {
    let ms = Manufactured {
        lambda: 2.0,
        mu: 1.0,
    };
    let levels = [8, 16, 32, 64, 128];
    let (l2, en): (Vec<f64>, Vec<f64>) = levels.iter().map(|&n| elastic_errors(&ms, n)).unzip();
    let (rl2, ren) = (rate(&l2), rate(&en));
    println!("elastic L2 errors {:?} rates {rl2:.3?}", sci(&l2));
    println!("elastic energy errors {:?} rates {ren:.3?}", sci(&en));
    assert!(rl2.iter().skip(1).all(|&r| r >= 1.9), "L2 rates {rl2:?}");
    assert!(
        ren.iter().skip(1).all(|&r| r >= 0.95),
        "energy rates {ren:?}"
    );
}

/// T = sin πx sin πy + x², W = −div(κ∇T) = κ11 (π² sin πx sin πy − 2) − 2κ12 π² cos πx cos πy
/// + κ22 π² sin πx sin πy for the conductivity κ = (κ11, κ12, κ22); (L², H¹-seminorm) errors.
fn heat_errors(kappa: [f64; 3], n: usize) -> (f64, f64) {
    let exact = |[x, y]: [f64; 2]| (PI * x).sin() * (PI * y).sin() + x * x;
    let grad = |[x, y]: [f64; 2]| {
        [
            PI * (PI * x).cos() * (PI * y).sin() + 2.0 * x,
            PI * (PI * x).sin() * (PI * y).cos(),
        ]
    };
    let [k11, k12, k22] = kappa;
    let source = |[x, y]: [f64; 2]| {
        let sines = PI * PI * (PI * x).sin() * (PI * y).sin();
        k11 * (sines - 2.0) - 2.0 * k12 * PI * PI * (PI * x).cos() * (PI * y).cos() + k22 * sines
    };
    let mut mesh = rectangle(0.0, 0.0, 1.0, 1.0, n, n);
    perturb_interior(&mut mesh, 0.15 / n as f64, 5);
    let mut m = material(Elastic::Lame {
        lambda: 1.0,
        mu: 1.0,
    });
    m.conductivity = kappa;
    let boundary = ["bottom", "left", "right", "top"]
        .iter()
        .map(|s| bc(&mesh, s, BoundaryValue::Temperature(0.0)))
        .collect();
    let d = data(vec![m], boundary);
    let problem = HeatProblem::new(&mesh, &d).unwrap();
    let mut loads = vec![0.0; mesh.nodes.len()];
    for t in 0..mesh.triangles.len() {
        for (x, l, w) in points(&mesh, t) {
            for (i, &node) in mesh.triangles[t].iter().enumerate() {
                loads[node] += w * source(x) * l[i];
            }
        }
    }
    let nodal: Vec<f64> = mesh.nodes.iter().map(|&p| exact(p)).collect();
    let factor = problem.factor(&d, Par::Seq).unwrap();
    let temp = problem
        .solve_with(&factor, &loads, &problem.fixed_values_from(&nodal).unwrap())
        .unwrap();
    let (mut l2, mut h1) = (0.0, 0.0);
    for t in 0..mesh.triangles.len() {
        let tri = mesh.triangles[t];
        let g = TriangleGradients::of(&mesh, t);
        let gh = (0..3).fold([0.0; 2], |a, i| {
            [a[0] + g.dx[i] * temp[tri[i]], a[1] + g.dy[i] * temp[tri[i]]]
        });
        for (x, l, w) in points(&mesh, t) {
            let th: f64 = (0..3).map(|i| l[i] * temp[tri[i]]).sum();
            l2 += w * (exact(x) - th).powi(2);
            let ge = grad(x);
            h1 += w * ((ge[0] - gh[0]).powi(2) + (ge[1] - gh[1]).powi(2));
        }
    }
    (l2.sqrt(), h1.sqrt())
}

#[test]
fn manufactured_heat_converges_at_optimal_rates() {
    let levels = [8, 16, 32, 64, 128];
    // Isotropic κ = 2.5 and an anisotropic symmetric positive definite κ (FGCS 4.7).
    for kappa in [[2.5, 0.0, 2.5], [3.0, 1.2, 2.0]] {
        let (l2, h1): (Vec<f64>, Vec<f64>) = levels.iter().map(|&n| heat_errors(kappa, n)).unzip();
        let (rl2, rh1) = (rate(&l2), rate(&h1));
        println!(
            "heat κ = {kappa:?} L2 errors {:?} rates {rl2:.3?}",
            sci(&l2)
        );
        println!(
            "heat κ = {kappa:?} H1 errors {:?} rates {rh1:.3?}",
            sci(&h1)
        );
        assert!(rl2.iter().skip(1).all(|&r| r >= 1.9), "L2 rates {rl2:?}");
        assert!(rh1.iter().skip(1).all(|&r| r >= 0.95), "H1 rates {rh1:?}");
        assert!(l2[l2.len() - 1] < 1e-4, "L2 error {l2:?}");
    }
}

// ---------- thick-walled cylinder (Lamé) ----------

/// Solve the quarter cylinder rotated by `angle`; returns (max relative u_r error at the inner
/// radius, overall, max relative hoop-stress error at the inner ring, overall).
fn cylinder_errors(
    cyl: &LameCylinder,
    nr: usize,
    nt: usize,
    angle: f64,
    given_direction: bool,
) -> [f64; 4] {
    let mut mesh = quarter_annulus(cyl.a, cyl.b, nr, nt);
    rotate(&mut mesh, angle, [0.0, 0.0]);
    let x_axis_roller = if given_direction {
        // Normal of the rotated x-axis, given explicitly (and reversed: the sign is irrelevant).
        BoundaryValue::Roller(Some([-angle.sin(), angle.cos()]))
    } else {
        BoundaryValue::Roller(None)
    };
    let boundary = vec![
        bc(&mesh, "x_axis", x_axis_roller),
        bc(&mesh, "y_axis", BoundaryValue::Roller(None)),
        bc(&mesh, "inner", BoundaryValue::Pressure(cyl.p)),
    ];
    let d = data(
        vec![material(Elastic::Young {
            e: cyl.e,
            nu: cyl.nu,
        })],
        boundary,
    );
    let problem = ElasticProblem::new(&mesh, &d).unwrap();
    assert!(problem.floating_bodies().is_empty());
    let factor = problem.factor(&d, Par::Seq).unwrap();
    let u = problem.solve(&factor, &d, None).unwrap();

    // Equilibrium: residual ≈ 0 at free nodes, reactions normal to the rollers, total p·a.
    let r = problem.reactions(&d, &u, None).unwrap();
    let force_scale = cyl.p * cyl.a;
    let x_axis = &mesh.segments[mesh.segment_index("x_axis").unwrap()];
    let y_axis = &mesh.segments[mesh.segment_index("y_axis").unwrap()];
    for (n, ri) in r.iter().enumerate() {
        if !problem.dofs().is_constrained(n) {
            assert!(
                ri[0].hypot(ri[1]) < 1e-9 * force_scale,
                "residual at free node {n}: {ri:?}"
            );
        }
    }
    let tangent = [angle.cos(), angle.sin()];
    let total = x_axis.nodes.iter().fold([0.0; 2], |s, &n| {
        assert!((r[n][0] * tangent[0] + r[n][1] * tangent[1]).abs() < 1e-9 * force_scale);
        [s[0] + r[n][0], s[1] + r[n][1]]
    });
    assert!(
        (total[0].hypot(total[1]) - force_scale).abs() < 1e-9 * force_scale,
        "{total:?}"
    );
    assert!(y_axis
        .nodes
        .iter()
        .all(|&n| problem.dofs().is_constrained(n)));

    let ua = cyl.radial_displacement(cyl.a);
    let (mut inner_u, mut all_u) = (0.0f64, 0.0f64);
    for (n, p) in mesh.nodes.iter().enumerate() {
        let rad = p[0].hypot(p[1]);
        let ur = (u[n][0] * p[0] + u[n][1] * p[1]) / rad;
        let err = (ur - cyl.radial_displacement(rad)).abs() / ua;
        all_u = all_u.max(err);
        if (rad - cyl.a).abs() < 1e-9 {
            inner_u = inner_u.max(err);
        }
    }
    let stresses = problem.stresses(&d, &u, None).unwrap();
    let sa = cyl.hoop_stress(cyl.a);
    let (mut inner_s, mut all_s) = (0.0f64, 0.0f64);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let c = tri.iter().fold([0.0; 2], |s, &n| {
            [s[0] + mesh.nodes[n][0] / 3.0, s[1] + mesh.nodes[n][1] / 3.0]
        });
        let rad = c[0].hypot(c[1]);
        let et = [-c[1] / rad, c[0] / rad];
        let [s11, s22, s12, _] = stresses[t].stress;
        let hoop = et[0] * et[0] * s11 + 2.0 * et[0] * et[1] * s12 + et[1] * et[1] * s22;
        let err = (hoop - cyl.hoop_stress(rad)).abs() / sa;
        all_s = all_s.max(err);
        if tri
            .iter()
            .any(|&n| (mesh.nodes[n][0].hypot(mesh.nodes[n][1]) - cyl.a).abs() < 1e-9)
        {
            inner_s = inner_s.max(err);
        }
    }
    [inner_u, all_u, inner_s, all_s]
}

#[test]
fn thick_walled_cylinder_matches_lame_solution() {
    let cyl = LameCylinder {
        a: 1.0,
        b: 2.0,
        p: 1.0e6,
        e: 2.0e9,
        nu: 0.3,
    };
    let coarse = cylinder_errors(&cyl, 8, 16, 0.0, false);
    let fine = cylinder_errors(&cyl, 128, 128, 0.0, false);
    println!(
        "Lamé axis-aligned errors coarse {:?} fine {:?}",
        sci(&coarse),
        sci(&fine)
    );
    assert!(fine.iter().all(|&e| e < 0.01), "{fine:?}");
    assert!(
        fine[1] < coarse[1] / 8.0,
        "u_r error must drop ~h²: {coarse:?} → {fine:?}"
    );
    // Rotated by 30°: oblique roller normals (one from the segment, one given) → rotated DOFs.
    let rotated = cylinder_errors(&cyl, 128, 128, PI / 6.0, true);
    println!("Lamé rotated 30° errors {:?}", sci(&rotated));
    for k in 0..4 {
        assert!(
            (rotated[k] - fine[k]).abs() < 1e-8,
            "rotation changed the solution: {rotated:?} vs {fine:?}"
        );
    }
}

// ---------- free thermal expansion ----------

/// Single-node segment (a point support) added to the mesh.
fn point_segment(mesh: &mut Mesh, name: &str, at: [f64; 2]) {
    let node = mesh
        .nodes
        .iter()
        .position(|p| *p == at)
        .expect("node at point");
    mesh.segments.push(MeshSegment {
        name: name.into(),
        body: 0,
        nodes: vec![node],
        edges: vec![],
    });
}

#[test]
fn free_thermal_expansion_is_stress_free() {
    let mut mesh = rectangle(0.0, 0.0, 2.0, 1.0, 8, 5);
    perturb_interior(&mut mesh, 0.03, 9);
    point_segment(&mut mesh, "pin", [0.0, 0.0]);
    point_segment(&mut mesh, "slide", [2.0, 0.0]);
    let (e, nu, alpha, t0, dt) = (200e9, 0.3, 1.2e-5, 293.0, 50.0);
    let mut m = material(Elastic::Young { e, nu });
    m.expansion = Expansion::Alpha(alpha);
    let beta = m.beta().unwrap()[0];
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
    let problem = ElasticProblem::new(&mesh, &d).unwrap();
    assert!(
        problem.floating_bodies().is_empty(),
        "pin + roller hold the body"
    );
    let temperature = vec![t0 + dt; mesh.nodes.len()];
    let factor = problem.factor(&d, Par::Seq).unwrap();
    let u = problem.solve(&factor, &d, Some(&temperature)).unwrap();
    // Zero in-plane stress: e = β ΔT / (2(λ + μ)) I = α (1 + ν) ΔT I; τ33 = −μβΔT/(λ+μ) = −E α ΔT.
    let strain = alpha * (1.0 + nu) * dt;
    for (p, ui) in mesh.nodes.iter().zip(&u) {
        assert!(
            (ui[0] - strain * p[0]).abs() < 1e-12 * strain
                && (ui[1] - strain * p[1]).abs() < 1e-12 * strain
        );
    }
    for s in problem.stresses(&d, &u, Some(&temperature)).unwrap() {
        for k in 0..3 {
            assert!(s.stress[k].abs() <= 1e-8 * beta * dt, "{:?}", s.stress);
        }
        assert!((s.stress[3] + e * alpha * dt).abs() <= 1e-8 * beta * dt);
    }
    let r = problem.reactions(&d, &u, Some(&temperature)).unwrap();
    assert!(
        max_abs(&r) < 1e-8 * beta * dt,
        "statically determinate: no reactions"
    );
}

// ---------- heat across a perfect thermal contact ----------

fn two_block_heat_data(mesh: &Mesh, top_condition: BoundaryValue) -> Data {
    let mut lower = lame(1.0, 1.0);
    let mut upper = lame(1.0, 1.0);
    lower.conductivity = [1.0, 0.0, 1.0];
    upper.conductivity = [3.0, 0.0, 3.0];
    data(
        vec![lower, upper],
        vec![
            bc(mesh, "lower_bottom", BoundaryValue::Temperature(0.0)),
            bc(mesh, "upper_top", top_condition),
        ],
    )
}

#[test]
fn heat_crosses_contact_linearly_and_continuously() {
    let mut mesh = stacked_blocks(1.5, 1.0, 1.0, 5, 4, 3);
    perturb_interior(&mut mesh, 0.03, 1);
    let d = two_block_heat_data(&mesh, BoundaryValue::Temperature(4.0));
    let problem = HeatProblem::new(&mesh, &d).unwrap();
    let factor = problem.factor(&d, Par::Seq).unwrap();
    let t = problem.solve(&factor, &d).unwrap();
    // Flux continuity κ1 T_i = κ2 (4 − T_i) → T_i = 3: T = 3y below, 3 + (y − 1) above.
    for (n, p) in mesh.nodes.iter().enumerate() {
        let exact = if mesh.node_body[n] == 0 {
            3.0 * p[1]
        } else {
            3.0 + (p[1] - 1.0)
        };
        assert!(
            (t[n] - exact).abs() < 1e-12,
            "node {n} at {p:?}: {} vs {exact}",
            t[n]
        );
    }
    for &[a, b] in &mesh.contacts[0].pairs {
        assert_eq!(t[a], t[b]);
    }
    // Inward flux q on top instead: T = q y / κ1 below, continuous, slope q / κ2 above.
    let q = 6.0;
    let d = two_block_heat_data(&mesh, BoundaryValue::HeatFlux(q));
    let problem = HeatProblem::new(&mesh, &d).unwrap();
    let t = problem
        .solve(&problem.factor(&d, Par::Seq).unwrap(), &d)
        .unwrap();
    for (n, p) in mesh.nodes.iter().enumerate() {
        let exact = if mesh.node_body[n] == 0 {
            q * p[1]
        } else {
            q + q / 3.0 * (p[1] - 1.0)
        };
        assert!(
            (t[n] - exact).abs() < 1e-11,
            "flux case node {n}: {} vs {exact}",
            t[n]
        );
    }
}

#[test]
fn heat_without_temperature_on_a_component_is_refused() {
    let mut mesh = stacked_blocks(1.0, 1.0, 1.0, 3, 2, 2);
    let d = two_block_heat_data(&mesh, BoundaryValue::HeatFlux(1.0));
    mesh.contacts.clear();
    match HeatProblem::new(&mesh, &d) {
        Err(FemError::NoTemperature { body, .. }) => assert_eq!(body, "upper"),
        other => panic!("expected NoTemperature, got {other:?}"),
    }
}

// ---------- floating bodies, conflicts, bad data ----------

#[test]
fn floating_body_is_reported_with_its_rigid_modes() {
    let mesh = rectangle(0.0, 0.0, 2.0, 1.0, 6, 3);
    let d = data(
        vec![lame(1.0, 1.0)],
        vec![bc(&mesh, "right", BoundaryValue::Traction([1.0, 0.0]))],
    );
    let problem = ElasticProblem::new(&mesh, &d).unwrap();
    assert_eq!(problem.floating_bodies(), [0]);
    match problem.factor(&d, Par::Seq) {
        Err(e @ FemError::FloatingBody { .. }) => assert!(e.to_string().contains("'body'")),
        other => panic!("expected FloatingBody, got {other:?}"),
    }
    let modes = problem.rigid_modes(0).unwrap();
    assert_eq!(
        modes.coefficients,
        vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    );
    assert!((modes.centroid[0] - 1.0).abs() < 1e-14 && (modes.centroid[1] - 0.5).abs() < 1e-14);
    let op = problem.operator();
    let values = op.assemble(&problem.coefficients(&d).unwrap()).unwrap();
    for k in 0..3 {
        let col: Vec<f64> = modes.modes.col(k).iter().copied().collect();
        let kx = op.apply(&values, &col);
        assert!(
            kx.iter().all(|v| v.abs() < 1e-12),
            "mode {k} not in the kernel"
        );
    }
    // A bottom roller leaves only the x translation.
    let d = data(
        vec![lame(1.0, 1.0)],
        vec![bc(&mesh, "bottom", BoundaryValue::Roller(None))],
    );
    let problem = ElasticProblem::new(&mesh, &d).unwrap();
    let modes = problem.rigid_modes(0).unwrap();
    assert_eq!(modes.coefficients.len(), 1);
    let c = modes.coefficients[0];
    assert!((c[0].abs() - 1.0).abs() < 1e-12 && c[1].abs() < 1e-12 && c[2].abs() < 1e-12);
}

#[test]
fn conflicting_and_invalid_data_give_errors() {
    let mesh = rectangle(0.0, 0.0, 1.0, 1.0, 4, 4);
    let boundary = |left: f64| {
        vec![
            bc(
                &mesh,
                "bottom",
                BoundaryValue::Displacement([Some(0.0), Some(0.0)]),
            ),
            bc(
                &mesh,
                "left",
                BoundaryValue::Displacement([Some(left), None]),
            ),
        ]
    };
    let ok = data(vec![lame(1.0, 1.0)], boundary(0.0));
    let problem = ElasticProblem::new(&mesh, &ok).unwrap();
    let factor = problem.factor(&ok, Par::Seq).unwrap();
    assert!(problem.solve(&factor, &ok, None).is_ok());
    let bad = data(vec![lame(1.0, 1.0)], boundary(0.1));
    match problem.solve(&factor, &bad, None) {
        Err(FemError::ConflictingConstraints { x, y, .. }) => assert_eq!((x, y), (0.0, 0.0)),
        other => panic!("expected a conflict at the corner, got {other:?}"),
    }
    let soft = data(vec![lame(1.0, -1.0)], boundary(0.0));
    assert!(matches!(
        problem.factor(&soft, Par::Seq),
        Err(FemError::InvalidMaterial { material: 0, .. })
    ));
    let other = data(vec![lame(2.0, 1.0)], boundary(0.0));
    assert!(matches!(
        problem.solve(&factor, &other, None),
        Err(FemError::Input(_))
    ));
}

// ---------- benchmark (run with --ignored --nocapture) ----------

#[test]
#[ignore]
fn benchmark_direct_pipeline() {
    for (nx, ny) in [(100, 50), (320, 160)] {
        for (name, par) in [("seq", Par::Seq), ("rayon", Par::rayon(0))] {
            let t = wsm_core::bench::elastic_benchmark(nx, ny, 5, par).unwrap();
            println!(
                "{nx}x{ny} {name}: {} free DOFs, nnz(L) {}, assembly {:.4}s, symbolic {:.4}s, numeric {:.4}s, solve {:.4}s, (numeric+solve)/first = {:.3}",
                t.free_dofs, t.factor_nnz, t.assembly, t.symbolic, t.numeric, t.solve, t.refactor_ratio
            );
            assert!(t.refactor_ratio < 1.0);
        }
    }
}

#[test]
fn fully_prescribed_mesh_has_an_empty_system() {
    let mesh = rectangle(0.0, 0.0, 1.0, 1.0, 1, 1);
    let d = data(vec![lame(1.0, 1.0)], clamp_all(&mesh));
    let problem = ElasticProblem::new(&mesh, &d).unwrap();
    assert_eq!(problem.dofs().n_free(), 0);
    let u = problem
        .solve(&problem.factor(&d, Par::Seq).unwrap(), &d, None)
        .unwrap();
    assert_eq!(u, vec![[0.0; 2]; 4]);
}
