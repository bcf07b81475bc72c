//! The MINI mixed element (`mesh.element: "mixed"`, design §2.7) at ν → ½: the Lamé thick
//! cylinder against the analytic solution where P1 locks, convergence rates on a divergence-free
//! manufactured solution, Hertz contact at ν = 0.499, the contact patch test (node-to-node and
//! mortar), a worst-scenario run with exact derivatives and its accuracy statement (the tibia
//! with marrow), and the refusals (DD, sparse contact, anisotropic material); thermal strain in
//! crates/core/tests/engine/mixed_thermal.rs.

#[path = "../crates/core/tests/engine/solves.rs"]
mod solves;

use solves::{bc, data, material};

use std::f64::consts::PI;

use serde_json::{json, Value};
use wsm_core::{
    fixtures::perturb_interior, fixtures::rectangle, parse_scene, worst, BoundaryValue, Elastic,
    ElasticProblem, Element, Mesh, Needs, Par, RunControl, Scene, Solution, SolveOptions,
    StateProblem, Status, WorstRequest,
};
use wsm_study::analytic::{field_errors, points, ExactField, LameCylinder};

fn rate(errors: &[f64]) -> Vec<f64> {
    errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
}

// ---------- Lamé thick cylinder ----------

/// The bundled `thick-cylinder` (a = 0.1 m, b = 0.2 m, p = 10 MPa, its default unstructured
/// mesh) at ν = 0.4999 with `element`: (max over the nodes of |u_r − u_r exact| / u_r(a), max over
/// ten rings of the area-weighted mean |σθθ − σθθ exact| / σθθ(a), the largest single-triangle
/// σθθ error / σθθ(a)), after checking KKT and equilibrium.
fn cylinder_errors(element: &str) -> [f64; 3] {
    let mut v: Value = serde_json::from_str(wsm_core::example("thick-cylinder").unwrap()).unwrap();
    v["materials"]["steel"]["nu"] = json!(0.4999);
    v["mesh"]["element"] = json!(element);
    let (problem, sol) = solve_value(&v).unwrap();
    assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
    let cyl = LameCylinder::from_scene(&problem.scene).unwrap();
    let mesh = problem.mesh();
    let u = &sol.displacement;
    let ua = cyl.radial_displacement(cyl.a);
    let u_err = mesh.nodes.iter().enumerate().fold(0.0f64, |m, (n, p)| {
        let rad = p[0].hypot(p[1]);
        let ur = (u[n][0] * p[0] + u[n][1] * p[1]) / rad;
        m.max((ur - cyl.radial_displacement(rad)).abs() / ua)
    });
    const RINGS: usize = 10;
    let sa = cyl.hoop_stress(cyl.a);
    let mut rings = [[0.0f64; 2]; RINGS];
    let mut single = 0.0f64;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let c = tri.iter().fold([0.0; 2], |s, &n| {
            [s[0] + mesh.nodes[n][0] / 3.0, s[1] + mesh.nodes[n][1] / 3.0]
        });
        let rad = c[0].hypot(c[1]);
        let et = [-c[1] / rad, c[0] / rad];
        let [s11, s22, s12, _] = sol.stresses[t].stress;
        let hoop = et[0] * et[0] * s11 + 2.0 * et[0] * et[1] * s12 + et[1] * et[1] * s22;
        let error = hoop - cyl.hoop_stress(rad);
        single = single.max(error.abs() / sa);
        let ring = (((rad - cyl.a) / (cyl.b - cyl.a) * RINGS as f64) as usize).min(RINGS - 1);
        let area = mesh.triangle_area(t);
        rings[ring][0] += area * error;
        rings[ring][1] += area;
    }
    let profile = rings
        .iter()
        .fold(0.0f64, |m, r| m.max((r[0] / r[1]).abs() / sa));
    [u_err, profile, single]
}

#[test]
fn lame_cylinder_at_nu_04999_mixed_is_accurate_where_p1_locks() {
    let p1 = cylinder_errors("p1");
    let mixed = cylinder_errors("mixed");
    println!(
        "Lamé ν = 0.4999, bundled mesh: (u_r, ring-mean σθθ, single-triangle σθθ) errors \
         P1 {p1:.4?}, mixed {mixed:.4?}"
    );
    assert!(mixed[0] < 0.01 && mixed[1] < 0.01, "mixed: {mixed:?}");
    assert!(p1[0] > 0.1 && p1[1] > 0.1, "P1 should lock: {p1:?}");
}

// ---------- manufactured divergence-free solution ----------

/// u = curl ψ = (∂y ψ, −∂x ψ), ψ = S(x) S(y), S = sin² πx: div u = 0 (p = 0) and u = ∇u = 0 on
/// the boundary of the unit square; body force f = −μ Δu.
struct Solenoidal {
    mu: f64,
}

/// S and its first three derivatives.
fn s(x: f64) -> [f64; 4] {
    let (a, b) = ((2.0 * PI * x).sin(), (2.0 * PI * x).cos());
    [
        (PI * x).sin().powi(2),
        PI * a,
        2.0 * PI * PI * b,
        -4.0 * PI.powi(3) * a,
    ]
}

impl ExactField for Solenoidal {
    fn u(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let (sx, sy) = (s(x), s(y));
        [sx[0] * sy[1], -sx[1] * sy[0]]
    }

    fn grad(&self, [x, y]: [f64; 2]) -> [[f64; 2]; 2] {
        let (sx, sy) = (s(x), s(y));
        [
            [sx[1] * sy[1], sx[0] * sy[2]],
            [-sx[2] * sy[0], -sx[1] * sy[1]],
        ]
    }
}

impl Solenoidal {
    fn force(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let (sx, sy) = (s(x), s(y));
        let lap = [
            sx[2] * sy[1] + sx[0] * sy[3],
            -(sx[3] * sy[0] + sx[1] * sy[2]),
        ];
        [-self.mu * lap[0], -self.mu * lap[1]]
    }

    /// Nodal loads ∫ f φ_n by the quadrature of the error norms.
    fn loads(&self, mesh: &Mesh) -> Vec<[f64; 2]> {
        let mut f = vec![[0.0; 2]; mesh.nodes.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for (x, l, w) in points(mesh, t) {
                let fx = self.force(x);
                for (i, &n) in tri.iter().enumerate() {
                    f[n][0] += w * l[i] * fx[0];
                    f[n][1] += w * l[i] * fx[1];
                }
            }
        }
        f
    }
}

/// (L², energy) errors on an n × n perturbed unit square, clamped, at ν = 0.4999; the energy
/// norm is (∫ 2μ e:e)^½ (the exact divergence is 0).
fn solenoidal_errors(n: usize, element: Element) -> (f64, f64) {
    let (e, nu) = (1.0, 0.4999);
    let mu = e / (2.0 * (1.0 + nu));
    let ms = Solenoidal { mu };
    let mut mesh = rectangle(0.0, 0.0, 1.0, 1.0, n, n);
    perturb_interior(&mut mesh, 0.15 / n as f64, 11);
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
    let d = data(vec![material(Elastic::Young { e, nu })], boundary);
    let problem = ElasticProblem::with_element(&mesh, &d, element).unwrap();
    let factor = problem.factor(&d, Par::Seq).unwrap();
    let fixed = problem.fixed_values(&d).unwrap();
    let u = problem
        .solve_with(&factor, &ms.loads(&mesh), &fixed)
        .unwrap();
    let errors = field_errors(&mesh, &u, &ms, &|_| (0.0, mu));
    (
        errors.l2 / errors.l2_norm,
        errors.energy / errors.energy_norm,
    )
}

#[test]
fn mixed_converges_at_optimal_rates_at_nu_04999() {
    let levels = [8, 16, 32, 64];
    let (l2, en): (Vec<f64>, Vec<f64>) = levels
        .iter()
        .map(|&n| solenoidal_errors(n, Element::Mixed))
        .unzip();
    let (rl2, ren) = (rate(&l2), rate(&en));
    println!("mixed ν = 0.4999 relative L2 errors {l2:.3?} rates {rl2:.3?}");
    println!("mixed ν = 0.4999 relative energy errors {en:.3?} rates {ren:.3?}");
    let (p1_l2, p1_en) = solenoidal_errors(64, Element::P1);
    println!("P1 at 64 × 64: relative L2 {p1_l2:.3e}, energy {p1_en:.3e}");
    assert!(rl2.iter().skip(1).all(|&r| r >= 1.8), "L2 rates {rl2:?}");
    assert!(
        ren.iter().skip(1).all(|&r| r >= 0.9),
        "energy rates {ren:?}"
    );
    assert!(p1_l2 > 10.0 * l2[3], "P1 locks: {p1_l2} vs mixed {}", l2[3]);
}

// ---------- contact and the scene path ----------

fn options(scene: &Scene) -> SolveOptions {
    SolveOptions {
        needs: Needs::all(scene),
        par: Par::Seq,
        warm: None,
    }
}

fn solve_value(v: &Value) -> Result<(StateProblem, Solution), wsm_core::WsmError> {
    let scene = parse_scene(&v.to_string())?;
    let problem = StateProblem::new(scene)?;
    let sol = problem.solve(&problem.nominal, &options(&problem.scene))?;
    Ok((problem, sol))
}

/// The bundled Hertz scene with both bodies at ν = 0.499, refined to `h` under the contact.
fn hertz_scene(element: &str, h: f64) -> Value {
    let mut v: Value = serde_json::from_str(wsm_core::example("hertz").unwrap()).unwrap();
    v["materials"]["steel"]["nu"] = json!(0.499);
    v["mesh"]["refine"][0]["max_size"] = json!(h);
    v["mesh"]["element"] = json!(element);
    v
}

#[test]
fn hertz_at_nu_0499_with_mixed_elements() {
    let nu: f64 = 0.499;
    let e_star = 2.0e11 / (2.0 * (1.0 - nu * nu));
    let a_exact = 2.0 * (solves::HERTZ_LOAD * 0.5 / (PI * e_star)).sqrt();
    let p0_exact = 2.0 * solves::HERTZ_LOAD / (PI * a_exact);
    for element in ["mixed", "p1"] {
        let (problem, sol) = solve_value(&hertz_scene(element, 0.004)).unwrap();
        let m = solves::hertz_measures(&problem, &sol);
        let (ea, ep) = (
            (m.half_width - a_exact).abs() / a_exact,
            (m.peak - p0_exact).abs() / p0_exact,
        );
        println!(
            "Hertz ν = 0.499 {element}: a = {:.5} (exact {a_exact:.5}, err {ea:.2e}), p0 = {:.4e} \
             (exact {p0_exact:.4e}, err {ep:.2e}), KKT {:.1e}, unknowns {}",
            m.half_width,
            m.peak,
            sol.report.kkt.max(),
            problem.elastic.operator().n_free()
        );
        assert!(
            (m.total - m.load).abs() <= 1e-8 * m.load,
            "total {} vs {}",
            m.total,
            m.load
        );
        assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
        if element == "mixed" {
            assert!(ea < 0.03 && ep < 0.03, "mixed errors a {ea}, p0 {ep}");
            assert!(
                !sol.report.warnings.iter().any(|w| w.contains("lock")),
                "{:?}",
                sol.report.warnings
            );
        }
    }
}

/// The bundled `hertz-nonmatching` (the bodies meshed on their own, dual mortar coupling, the
/// cylinder's contact side at `cylinder`, the flat's at `flat`) with both bodies at ν = 0.499.
fn hertz_mortar_scene(element: &str, cylinder: f64, flat: f64) -> Value {
    let mut v: Value =
        serde_json::from_str(wsm_core::example("hertz-nonmatching").unwrap()).unwrap();
    v["materials"]["steel"]["nu"] = json!(0.499);
    v["mesh"]["element"] = json!(element);
    v["mesh"]["refine"][0]["max_size"] = json!(cylinder);
    v["mesh"]["refine"][1]["max_size"] = json!(flat);
    v
}

#[test]
fn hertz_at_nu_0499_with_mortar_coupling_on_mixed_elements() {
    let nu: f64 = 0.499;
    let e_star = 2.0e11 / (2.0 * (1.0 - nu * nu));
    let a_exact = 2.0 * (solves::HERTZ_LOAD * 0.5 / (PI * e_star)).sqrt();
    let p0_exact = 2.0 * solves::HERTZ_LOAD / (PI * a_exact);
    for (element, cylinder, flat) in [
        ("mixed", 0.002, 0.004),
        ("mixed", 0.004, 0.002),
        ("p1", 0.002, 0.004),
    ] {
        let (problem, sol) = solve_value(&hertz_mortar_scene(element, cylinder, flat)).unwrap();
        let m = solves::hertz_measures(&problem, &sol);
        let (ea, ep) = (
            (m.half_width - a_exact).abs() / a_exact,
            (m.peak - p0_exact).abs() / p0_exact,
        );
        println!(
            "Hertz mortar ν = 0.499 {element} (cylinder side {cylinder}, flat side {flat}): \
             a = {:.5} (exact {a_exact:.5}, err {ea:.2e}), p0 = {:.4e} (exact {p0_exact:.4e}, \
             err {ep:.2e}), KKT {:.1e}",
            m.half_width,
            m.peak,
            sol.report.kkt.max(),
        );
        assert!(
            (m.total - m.load).abs() <= 1e-8 * m.load,
            "total {} vs {}",
            m.total,
            m.load
        );
        assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
        if element == "mixed" {
            assert!(ea < 0.03 && ep < 0.03, "mixed errors a {ea}, p0 {ep}");
        }
    }
}

#[test]
fn stacked_blocks_with_mixed_elements_transmit_uniform_pressure() {
    let p = 3.0e6;
    let mut matching = solves::stacked_blocks(p, 1.0e5, 0.1);
    matching["materials"]["m"]["nu"] = json!(0.4999);
    matching["mesh"]["element"] = json!("mixed");
    let mut mortar = solves::stacked_blocks_mortar(p, 1.0e5, 0.1, 1.7);
    mortar["materials"]["m"]["nu"] = json!(0.4999);
    mortar["mesh"]["element"] = json!("mixed");
    for (name, v) in [("node-to-node", matching), ("mortar", mortar)] {
        let (problem, sol) = solve_value(&v).unwrap();
        assert!(problem.contact.kernel_dim() >= 1, "the upper block floats");
        let worst = sol
            .contact
            .iter()
            .map(|c| (c.pressure - p).abs() / p)
            .fold(0.0, f64::max);
        println!(
            "stacked blocks ν = 0.4999 mixed, {name}: max |p − P|/P = {worst:.1e}, KKT {:.1e}",
            sol.report.kkt.max()
        );
        assert!(worst <= 1e-8, "{name}: {worst}");
        assert!(sol.report.kkt.max() <= 1e-9, "{name}: {:?}", sol.report.kkt);
    }
}

// ---------- exact derivatives in a worst-scenario run, the accuracy statement ----------

/// The bundled tibia with marrow (marrow at ν = 0.49, bilateral contact) with the mixed element,
/// run with its own settings (Φ3 and Φ5, budget 40, exact derivatives) and one refinement of
/// the accuracy statement: every extremum is certified by its derivatives (the certificate has a
/// first-order residual, which only derivatives give), and the statement is complete, its
/// refined values those of independent mixed solves on the halved mesh at the same data.
#[test]
fn a_worst_scenario_run_on_the_mixed_tibia_is_certified_with_its_accuracy_statement() {
    let mut v: Value = serde_json::from_str(wsm_core::example("tibia-marrow").unwrap()).unwrap();
    v["mesh"]["element"] = json!("mixed");
    let scene = parse_scene(&v.to_string()).unwrap();
    let request = WorstRequest {
        accuracy_refinements: Some(1),
        ..WorstRequest::default()
    };
    let start = std::time::Instant::now();
    let r = worst(scene.clone(), &request, &RunControl::new()).unwrap();
    eprintln!(
        "mixed tibia-marrow: {} evaluations, {:.1} s, status {:?}",
        r.evaluations,
        start.elapsed().as_secs_f64(),
        r.status
    );
    for c in &r.criteria {
        for (sense, o) in [("worst", &c.worst), ("best", &c.best)] {
            eprintln!(
                "{} {sense}: {:?} at {:?}, certificate {:?}",
                c.criterion.name(),
                o.value,
                o.point,
                o.certificate
            );
            assert_eq!(o.status, Status::LocallyCertified, "{:?}", o.certificate);
            let residual = o.certificate.as_ref().and_then(|c| c.residual);
            assert!(residual.is_some(), "no derivatives: {:?}", o.certificate);
        }
    }
    assert!(
        !r.warnings
            .iter()
            .any(|w| w.message.contains("sensitivities")),
        "{:?}",
        r.warnings
    );
    let statement = r.accuracy.as_ref().expect("an accuracy statement");
    assert!(statement.complete, "{:?}", statement.failures);
    let fine = StateProblem::new(wsm_core::scaled_scene(&scene, 0.5).unwrap()).unwrap();
    assert_eq!(fine.elastic.element(), Element::Mixed);
    let params = wsm_core::scene_parameters(&scene).unwrap();
    for (c, a) in r.criteria.iter().zip(&statement.criteria) {
        let target = fine.targets(std::slice::from_ref(&c.criterion)).unwrap()[0];
        for (o, e) in [(&c.worst, &a.worst), (&c.best, &a.best)] {
            let point = o.point.as_ref().unwrap();
            let e = e.as_ref().unwrap();
            let data = wsm_core::apply_parameters(&scene, &fine.nominal, &params, point);
            let solution = fine.solve(&data, &options(&fine.scene)).unwrap();
            let independent = solution.value(target).unwrap();
            let refined = e.refined[0].unwrap();
            eprintln!(
                "{}: value {:.6e}, refined {refined:.6e} (independent {independent:.6e}), \
                 estimate {:?} ({:?} relative)",
                c.criterion.name(),
                e.value,
                e.estimate,
                e.relative
            );
            assert!(
                (refined - independent).abs() <= 1e-9 * independent.abs(),
                "{refined} vs {independent}"
            );
        }
    }
}

#[test]
fn mixed_scenes_refuse_what_they_do_not_support() {
    let base = solves::stacked_blocks(3.0e6, 1.0e5, 0.1);
    let refused = |edit: &dyn Fn(&mut Value), path: &str, words: &str| {
        let mut v = base.clone();
        v["mesh"]["element"] = json!("mixed");
        edit(&mut v);
        let err = parse_scene(&v.to_string()).expect_err("must be refused");
        assert_eq!(err.path, path, "{err}");
        assert!(err.to_string().contains(words), "{err}");
    };
    refused(
        &|v| v["solver"] = json!({"kind": "dd"}),
        "mesh.element",
        "dd",
    );
    refused(
        &|v| v["solver"] = json!({"contact": "sparse"}),
        "mesh.element",
        "sparse",
    );
    refused(
        &|v| {
            v["materials"]["m"] = json!({
                "E1": 2e10, "E2": 1e10, "E3": 1e10, "nu12": 0.3, "nu13": 0.3, "nu23": 0.3,
                "G12": 5e9
            })
        },
        "materials.m",
        "isotropic",
    );
    // The default stays P1 and P1 scenes are unchanged.
    let scene = parse_scene(&base.to_string()).unwrap();
    assert_eq!(scene.mesh.element, Element::P1);
    // The DD element matrices are refused by the FEM layer.
    let mut v = base.clone();
    v["mesh"]["element"] = json!("mixed");
    let problem = StateProblem::new(parse_scene(&v.to_string()).unwrap()).unwrap();
    let coefficients = problem.elastic.coefficients(&problem.nominal).unwrap();
    let err = problem
        .elastic
        .element_matrix(0, &coefficients)
        .unwrap_err();
    assert!(err.to_string().contains("mixed"), "{err}");
}
