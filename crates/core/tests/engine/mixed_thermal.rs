//! Thermal strain on the MINI mixed element (`mesh.element: "mixed"`, design §2.7, "Thermal
//! stress"): a free and a clamped plate under a uniform ΔT against their closed forms, a thick
//! cylinder under a steady radial temperature against the plane-strain thermo-elastic solution
//! (mixed and P1 at ν = 0.3, mixed at ν = 0.4999 where P1 locks), the thermo-elastic contact
//! scene `thermo-contact-fault` solved on the mixed element (KKT, mixed vs P1), and the exact
//! derivatives of its criteria (adjoint = forward = central differences).

use crate::solves;

use serde_json::{json, Value};
use solves::{bc, data, material, relative_difference, solve};
use wsm_core::{
    apply_parameters, fixtures::perturb_interior, fixtures::rectangle, parameter_stencil,
    parse_scene, scene_parameters, BoundaryValue, Criterion, Data, DerivativeRoute, Elastic,
    ElasticProblem, Element, Expansion, Needs, Par, SolveOptions, SolverKind, StateProblem,
};

const ELEMENTS: [Element; 2] = [Element::P1, Element::Mixed];

/// (E, α, T0, ΔT) of the plates.
const PLATE: (f64, f64, f64, f64) = (200e9, 1.2e-5, 293.0, 50.0);

/// The 2 × 1 plate (perturbed 8 × 5 mesh) of Poisson's ratio `nu` with the conditions
/// `boundary` built from its mesh, its problem on `element` and the uniform temperature T0 + ΔT.
fn plate(
    nu: f64,
    element: Element,
    boundary: &dyn Fn(&wsm_core::Mesh) -> Vec<wsm_core::BoundaryData>,
) -> (ElasticProblem, Data, Vec<f64>) {
    let (e, alpha, t0, dt) = PLATE;
    let mut mesh = rectangle(0.0, 0.0, 2.0, 1.0, 8, 5);
    perturb_interior(&mut mesh, 0.03, 9);
    let mut m = material(Elastic::Young { e, nu });
    m.expansion = Expansion::Alpha(alpha);
    let mut d = data(vec![m], boundary(&mesh));
    d.reference_temperature = t0;
    let problem = ElasticProblem::with_element(&mesh, &d, element).unwrap();
    let temperature = vec![t0 + dt; mesh.nodes.len()];
    (problem, d, temperature)
}

/// Free expansion (rollers on the left and bottom sides: statically determinate) in plane
/// strain: e = α(1 + ν)ΔT I, so u = α(1 + ν)ΔT x, no in-plane stress and τ33 = −EαΔT (with
/// β = (3λ + 2μ)α: τ11 = λ tr e + 2μ e11 − βΔT = 0 since 2ν(λ + μ) = λ), no reactions.
#[test]
fn free_plate_expands_stress_free_on_both_elements() {
    let (e, alpha, _, dt) = PLATE;
    let rollers = |mesh: &wsm_core::Mesh| {
        vec![
            bc(mesh, "left", BoundaryValue::Roller(Some([1.0, 0.0]))),
            bc(mesh, "bottom", BoundaryValue::Roller(Some([0.0, 1.0]))),
        ]
    };
    for nu in [0.3, 0.4999] {
        for element in ELEMENTS {
            let (problem, d, t) = plate(nu, element, &rollers);
            let factor = problem.factor(&d, Par::Seq).unwrap();
            let u = problem.solve(&factor, &d, Some(&t)).unwrap();
            let strain = alpha * (1.0 + nu) * dt;
            let u_err = problem
                .mesh()
                .nodes
                .iter()
                .zip(&u)
                .map(|(p, ui)| {
                    (ui[0] - strain * p[0])
                        .abs()
                        .max((ui[1] - strain * p[1]).abs())
                })
                .fold(0.0, f64::max)
                / (2.0 * strain);
            let scale = e * alpha * dt;
            let stresses = problem.stresses(&d, &u, Some(&t)).unwrap();
            let in_plane = stresses
                .iter()
                .flat_map(|s| s.stress[..3].iter().map(|v| v.abs()))
                .fold(0.0, f64::max)
                / scale;
            let out_of_plane = stresses
                .iter()
                .map(|s| (s.stress[3] + scale).abs())
                .fold(0.0, f64::max)
                / scale;
            let reactions = problem
                .reactions(&d, &u, Some(&t))
                .unwrap()
                .iter()
                .map(|r| r[0].abs().max(r[1].abs()))
                .fold(0.0, f64::max)
                / scale;
            println!(
                "free plate ν = {nu} {element:?}: |u − u_exact| {u_err:.1e}, |τ_in-plane| \
                 {in_plane:.1e}, |τ33 + EαΔT| {out_of_plane:.1e}, reactions {reactions:.1e} \
                 (relative)"
            );
            assert!(u_err < 1e-9, "{nu} {element:?}: u {u_err}");
            assert!(in_plane < 1e-8 && out_of_plane < 1e-8, "{nu} {element:?}");
            assert!(reactions < 1e-8, "{nu} {element:?}: reactions {reactions}");
        }
    }
}

/// A plate clamped on its whole boundary under a uniform ΔT: u = 0, and in plane strain with
/// e = 0 every normal stress is −βΔT = −(3λ + 2μ)αΔT = −EαΔT/(1 − 2ν), τ12 = 0.
#[test]
fn clamped_plate_carries_the_full_thermal_stress_on_both_elements() {
    let (e, alpha, _, dt) = PLATE;
    let clamped = |mesh: &wsm_core::Mesh| {
        ["bottom", "left", "right", "top"]
            .iter()
            .map(|s| bc(mesh, s, BoundaryValue::Displacement([Some(0.0), Some(0.0)])))
            .collect()
    };
    for nu in [0.3, 0.4999] {
        let exact = -e * alpha * dt / (1.0 - 2.0 * nu);
        for element in ELEMENTS {
            let (problem, d, t) = plate(nu, element, &clamped);
            let factor = problem.factor(&d, Par::Seq).unwrap();
            let u = problem.solve(&factor, &d, Some(&t)).unwrap();
            let u_max = u
                .iter()
                .map(|ui| ui[0].abs().max(ui[1].abs()))
                .fold(0.0, f64::max)
                / (alpha * dt);
            let worst = problem
                .stresses(&d, &u, Some(&t))
                .unwrap()
                .iter()
                .map(|s| {
                    let [s11, s22, s12, s33] = s.stress;
                    [s11 - exact, s22 - exact, s12, s33 - exact]
                        .iter()
                        .fold(0.0f64, |m, v| m.max(v.abs()))
                })
                .fold(0.0, f64::max)
                / exact.abs();
            println!(
                "clamped plate ν = {nu} {element:?}: σ = {exact:.4e} Pa, max relative error \
                 {worst:.1e}, max |u| / αΔT {u_max:.1e}"
            );
            assert!(worst < 1e-9, "{nu} {element:?}: {worst}");
            assert!(u_max < 1e-9, "{nu} {element:?}: u {u_max}");
        }
    }
}

// ---------- thick cylinder under a radial temperature ----------

/// The plane-strain hollow cylinder a ≤ r ≤ b with free faces under the steady temperature
/// T(r) = T_a ln(r/b)/ln(a/b) (T0 = 0): the plane-stress disc solution (Timoshenko & Goodier
/// §150) with E' = E/(1 − ν²), ν' = ν/(1 − ν), α' = (1 + ν)α, I(r) = ∫_a^r T s ds:
/// u = α'/r [(1 + ν') I + ((1 − ν') r² + (1 + ν') a²) I(b)/(b² − a²)],
/// σθθ = α'E'/r² [(r² + a²) I(b)/(b² − a²) + I − T r²].
struct ThermalCylinder {
    a: f64,
    b: f64,
    t_a: f64,
    e: f64,
    nu: f64,
    alpha: f64,
}

impl ThermalCylinder {
    fn temperature(&self, r: f64) -> f64 {
        self.t_a * (r / self.b).ln() / (self.a / self.b).ln()
    }

    /// I(r) = ∫_a^r T s ds with ∫ s ln(s/b) ds = s²/2 ln(s/b) − s²/4.
    fn integral(&self, r: f64) -> f64 {
        let f = |s: f64| s * s / 2.0 * (s / self.b).ln() - s * s / 4.0;
        self.t_a / (self.a / self.b).ln() * (f(r) - f(self.a))
    }

    /// (ν', α', E') of the plane-stress equivalent.
    fn equivalent(&self) -> (f64, f64, f64) {
        let nu = self.nu;
        (
            nu / (1.0 - nu),
            (1.0 + nu) * self.alpha,
            self.e / (1.0 - nu * nu),
        )
    }

    fn radial_displacement(&self, r: f64) -> f64 {
        let (nu, alpha, _) = self.equivalent();
        let (a2, b2) = (self.a * self.a, self.b * self.b);
        alpha / r
            * ((1.0 + nu) * self.integral(r)
                + ((1.0 - nu) * r * r + (1.0 + nu) * a2) * self.integral(self.b) / (b2 - a2))
    }

    fn hoop_stress(&self, r: f64) -> f64 {
        let (_, alpha, e) = self.equivalent();
        let (a2, b2) = (self.a * self.a, self.b * self.b);
        alpha * e / (r * r)
            * ((r * r + a2) * self.integral(self.b) / (b2 - a2) + self.integral(r)
                - self.temperature(r) * r * r)
    }
}

/// The bundled `thick-cylinder` quarter (a = 0.1, b = 0.2, rollers on both axes, its default
/// unstructured mesh) without its pressure, of Poisson's ratio `nu`, under the temperature of
/// [`ThermalCylinder`] (T_a = 100 K, α = 1.2e-5) on `element`: (max nodal |u_r error| / max u_r,
/// max over ten rings of the area-weighted mean |σθθ error| / max |σθθ|).
fn thermal_cylinder_errors(nu: f64, element: &str) -> [f64; 2] {
    let mut v: Value = serde_json::from_str(wsm_core::example("thick-cylinder").unwrap()).unwrap();
    v["materials"]["steel"]["nu"] = json!(nu);
    v["mesh"]["element"] = json!(element);
    let problem = StateProblem::new(parse_scene(&v.to_string()).unwrap()).unwrap();
    let cyl = ThermalCylinder {
        a: 0.1,
        b: 0.2,
        t_a: 100.0,
        e: 2.1e11,
        nu,
        alpha: 1.2e-5,
    };
    let mut d = problem.nominal.clone();
    d.materials[0].expansion = Expansion::Alpha(cyl.alpha);
    d.boundary[2].value = BoundaryValue::Pressure(0.0);
    let mesh = problem.mesh();
    let radius = |p: [f64; 2]| p[0].hypot(p[1]);
    let t: Vec<f64> = mesh
        .nodes
        .iter()
        .map(|&p| cyl.temperature(radius(p)))
        .collect();
    let elastic = &problem.elastic;
    let factor = elastic.factor(&d, Par::Seq).unwrap();
    let u = elastic.solve(&factor, &d, Some(&t)).unwrap();
    let u_scale = cyl
        .radial_displacement(cyl.a)
        .max(cyl.radial_displacement(cyl.b));
    let u_err = mesh.nodes.iter().zip(&u).fold(0.0f64, |m, (&p, ui)| {
        let r = radius(p);
        let ur = (ui[0] * p[0] + ui[1] * p[1]) / r;
        m.max((ur - cyl.radial_displacement(r)).abs() / u_scale)
    });
    let s_scale = cyl
        .hoop_stress(cyl.a)
        .abs()
        .max(cyl.hoop_stress(cyl.b).abs());
    const RINGS: usize = 10;
    let mut rings = [[0.0f64; 2]; RINGS];
    for (k, s) in elastic
        .stresses(&d, &u, Some(&t))
        .unwrap()
        .iter()
        .enumerate()
    {
        let c = mesh.triangles[k].iter().fold([0.0; 2], |s, &n| {
            [s[0] + mesh.nodes[n][0] / 3.0, s[1] + mesh.nodes[n][1] / 3.0]
        });
        let r = radius(c);
        let et = [-c[1] / r, c[0] / r];
        let [s11, s22, s12, _] = s.stress;
        let hoop = et[0] * et[0] * s11 + 2.0 * et[0] * et[1] * s12 + et[1] * et[1] * s22;
        let ring = (((r - cyl.a) / (cyl.b - cyl.a) * RINGS as f64) as usize).min(RINGS - 1);
        let area = mesh.triangle_area(k);
        rings[ring][0] += area * (hoop - cyl.hoop_stress(r));
        rings[ring][1] += area;
    }
    let hoop_err = rings
        .iter()
        .fold(0.0f64, |m, r| m.max((r[0] / r[1]).abs() / s_scale));
    [u_err, hoop_err]
}

#[test]
fn thermal_cylinder_mixed_matches_the_analytic_solution_where_p1_locks() {
    let p1 = thermal_cylinder_errors(0.3, "p1");
    let mixed = thermal_cylinder_errors(0.3, "mixed");
    let p1_locked = thermal_cylinder_errors(0.4999, "p1");
    let mixed_incompressible = thermal_cylinder_errors(0.4999, "mixed");
    let sci = |e: [f64; 2]| format!("({:.2e}, {:.2e})", e[0], e[1]);
    println!(
        "thermal cylinder (u_r, ring-mean σθθ) relative errors: ν = 0.3 P1 {}, mixed {}; \
         ν = 0.4999 P1 {}, mixed {}",
        sci(p1),
        sci(mixed),
        sci(p1_locked),
        sci(mixed_incompressible)
    );
    for errors in [p1, mixed, mixed_incompressible] {
        assert!(errors[0] < 0.01 && errors[1] < 0.01, "{errors:?}");
    }
    assert!(
        p1_locked[0] > 0.1 || p1_locked[1] > 0.1,
        "P1 should lock at ν = 0.4999: {p1_locked:?}"
    );
}

// ---------- thermo-elastic contact ----------

fn thermo_contact(element: &str) -> Value {
    let mut v: Value =
        serde_json::from_str(wsm_core::find_example("thermo-contact-fault").unwrap()).unwrap();
    v["mesh"]["element"] = json!(element);
    v
}

/// FGCS's thermo-elastic contact model (heat, Duhamel–Neumann, Tresca contact on the fault) on
/// the mixed element: KKT ≤ 1e-9, and its displacement and fault pressures agree with P1's to
/// the discretisation error at ν = 0.18 / 0.34.
#[test]
fn thermo_elastic_contact_solves_on_the_mixed_element() {
    let (_, p1) = solve(&thermo_contact("p1"), SolverKind::Direct);
    let (problem, mixed) = solve(&thermo_contact("mixed"), SolverKind::Direct);
    let difference = relative_difference(&p1, &mixed);
    let resultant = |s: &wsm_core::Solution| {
        s.contact
            .iter()
            .zip(&problem.contact.geometry.pairs)
            .map(|(c, pair)| c.pressure * pair.weight)
            .sum::<f64>()
    };
    let (f_p1, f_mixed) = (resultant(&p1), resultant(&mixed));
    println!(
        "thermo-contact-fault: KKT mixed {:.1e} (P1 {:.1e}); ‖u_mixed − u_P1‖/‖u_P1‖ = \
         {difference:.2e}; fault normal force mixed {f_mixed:.5e} N/m, P1 {f_p1:.5e} N/m",
        mixed.report.kkt.max(),
        p1.report.kkt.max()
    );
    assert!(mixed.report.kkt.max() <= 1e-9, "{:?}", mixed.report.kkt);
    assert!(mixed.temperature.is_some(), "the heat problem was solved");
    assert!(difference < 0.02, "mixed vs P1 {difference}");
    assert!(
        (f_mixed - f_p1).abs() < 0.02 * f_p1.abs(),
        "{f_mixed} vs {f_p1}"
    );
}

/// `thermo-contact-fault` on the mixed element on a coarse mesh, with the rock's Young's
/// modulus, Poisson's ratio and the top-left pressure uncertain besides its conductivity κ,
/// source W, boundary temperature T1, expansion α and slip limit g, and the top right side as a
/// boundary piece; then `edit`.
fn coarse_thermo_contact_mixed(edit: impl Fn(&mut Value)) -> StateProblem {
    let mut v = thermo_contact("mixed");
    v["mesh"]["max_size"] = json!(2.0);
    v["mesh"]["refine"][0]["max_size"] = json!(1.0);
    // A boundary piece off Γu for Φ2 (heat flux) and Φ4 (normal displacement).
    v["criteria"]["boundary_pieces"] = json!([{"name": "top", "segment": "top_right"}]);
    let uncertain = v["uncertain"].as_array_mut().unwrap();
    uncertain.push(json!({"name": "E", "field": "materials.rock.E", "interval": [4.6e9, 5.8e9]}));
    uncertain.push(json!({"name": "nu", "field": "materials.rock.nu", "interval": [0.15, 0.21]}));
    uncertain.push(json!({
        "name": "p", "field": "boundary[top left].pressure", "interval": [4e6, 6e6]
    }));
    edit(&mut v);
    StateProblem::new(parse_scene(&v.to_string()).unwrap()).unwrap()
}

/// The exact derivatives of the criteria of `problem` at an interior point of its box: every
/// computed Φ's derivative by the adjoint equals the forward tangent's to 1e-9 and central
/// differences of whole solves to 1e-6 relative where the state is smooth (the difference with
/// step h agreeing with the one of step h/2); some Φ is compared along each datum of `along`
/// and Φ3–Φ6 are computed.
fn check_derivatives(label: &str, problem: &StateProblem, along: &[&str]) {
    let params = scene_parameters(&problem.scene).unwrap();
    let theta: Vec<f64> = params.iter().map(|p| p.lo + 0.37 * (p.hi - p.lo)).collect();
    let d = apply_parameters(&problem.scene, &problem.nominal, &params, &theta);
    let stencils: Vec<_> = (0..params.len())
        .map(|j| parameter_stencil(&problem.scene, &problem.nominal, &params, &theta, j))
        .collect();
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: Par::Seq,
        warm: None,
    };
    let by = |route| {
        problem
            .solve_with_sensitivities_by(&d, &options, &stencils, route)
            .unwrap()
    };
    let (adjoint, forward) = (by(DerivativeRoute::Adjoint), by(DerivativeRoute::Forward));
    assert_eq!(
        adjoint.sensitivities.len(),
        params.len(),
        "{:?}",
        adjoint.report.warnings
    );
    assert!(adjoint.report.kkt.max() <= 1e-9);
    let criteria_at = |j: usize, h: f64| {
        let mut at = theta.clone();
        at[j] += h;
        let data = apply_parameters(&problem.scene, &problem.nominal, &params, &at);
        problem.solve(&data, &options).unwrap().criteria
    };
    let (mut compared, mut worst, mut worst_routes, mut kinks) = (0, 0.0_f64, 0.0_f64, 0);
    let mut compared_along = Vec::new();
    for (j, p) in params.iter().enumerate() {
        let h = 1e-4 * (p.hi - p.lo);
        let (plus, minus) = (criteria_at(j, h), criteria_at(j, -h));
        let (plus2, minus2) = (criteria_at(j, 0.5 * h), criteria_at(j, -0.5 * h));
        for c in Criterion::ALL {
            let i = c as usize;
            let Some(value) = adjoint.criteria[i] else {
                continue;
            };
            let (a, f) = (
                adjoint.sensitivities[j][i].unwrap(),
                forward.sensitivities[j][i].unwrap(),
            );
            let scale = (value.abs() / (p.hi - p.lo)).max(f.right.abs());
            let routes = (a.right - f.right).abs().max((a.left - f.left).abs()) / scale;
            assert!(
                routes <= 1e-9,
                "d{c:?}/d{}: adjoint {a:?}, forward {f:?}",
                p.name
            );
            worst_routes = worst_routes.max(routes);
            let coarse = (plus[i].unwrap() - minus[i].unwrap()) / (2.0 * h);
            let fine = (plus2[i].unwrap() - minus2[i].unwrap()) / h;
            if a.left != a.right || (coarse - fine).abs() > 1e-5 * scale {
                kinks += 1;
                continue;
            }
            let error = (a.right - fine).abs() / scale;
            println!(
                "d{c:?}/d{}: exact {:.9e}, central difference {fine:.9e} (relative {error:.1e})",
                p.name, a.right
            );
            assert!(
                error <= 1e-6,
                "d{c:?}/d{}: exact {} vs central difference {fine} (relative {error:.1e})",
                p.name,
                a.right
            );
            compared += 1;
            worst = worst.max(error);
            compared_along.push(p.name.clone());
        }
    }
    println!(
        "{label}: {compared} derivatives compared, worst relative {worst:.1e}, \
         adjoint vs forward {worst_routes:.1e}, {kinks} skipped at kinks; adjoint gave {} of {} \
         directions",
        adjoint.report.adjoint_directions,
        params.len()
    );
    for c in [
        Criterion::Phi3,
        Criterion::Phi4,
        Criterion::Phi5,
        Criterion::Phi6,
    ] {
        assert!(adjoint.criteria[c as usize].is_some(), "{c:?} computed");
    }
    for name in along {
        assert!(
            compared_along.iter().any(|n| n == name),
            "nothing compared along {name}"
        );
    }
}

/// The exact derivatives of a thermo-elastic mixed scene (the temperature enters the pressure
/// rows, design §2.7 "Derivatives", item 4) on `thermo-contact-fault`: along the elastic data E
/// and ν (along which γ = β33/λ of the pressure rows changes), the expansion α, the thermal data
/// κ, W and T1, a load and the slip limit.
#[test]
fn derivatives_of_a_thermo_elastic_mixed_scene_equal_central_differences() {
    let problem = coarse_thermo_contact_mixed(|_| {});
    check_derivatives(
        "thermo-contact-fault mixed",
        &problem,
        &["E", "nu", "beta", "kappa", "W", "T1", "p"],
    );
}

/// The same with a canister of anisotropic Voigt β (β_d ≠ 0: the displacement rows and the
/// stresses carry the deviatoric thermal part) and the reference temperature T0 uncertain.
#[test]
fn derivatives_with_a_voigt_beta_and_an_uncertain_reference_temperature() {
    let problem = coarse_thermo_contact_mixed(|v| {
        let canister = &mut v["materials"]["canister"];
        canister.as_object_mut().unwrap().remove("expansion");
        canister["beta"] = json!([6.5e6, 5.0e6, 0.8e6, 5.8e6]);
        v["uncertain"].as_array_mut().unwrap().push(json!({
            "name": "T0", "field": "thermal.reference_temperature", "interval": [15.0, 25.0]
        }));
    });
    check_derivatives(
        "thermo-contact-fault mixed, Voigt β",
        &problem,
        &["T0", "kappa", "W", "T1", "E", "nu"],
    );
}
