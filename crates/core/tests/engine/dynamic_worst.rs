//! The worst scenario over time (design §3.5, issue 47 item 6): the criteria of a dynamic scene
//! as maxima over the time steps, their exact derivatives by forward differentiation through the
//! time loop against central differences of whole runs (a bar without contact, a block on a base
//! with contact and Tresca friction, both schemes), the uncertain dynamic data (density,
//! viscosity, absorbing damping), and `wsm worst` on a dynamic scene whose worst and best are
//! vertices, certified.

use serde_json::{json, Value};
use wsm_core::dynamics::solve_over_time;
use wsm_core::run::{worst, RunControl, Status, Verdict, WorstRequest};
use wsm_core::scene::params::{apply, parameters, stencil};
use wsm_core::scene::{parse, Criterion, StopRule};
use wsm_core::state::StateProblem;

fn problem(scene: &Value) -> StateProblem {
    StateProblem::new(parse(&scene.to_string()).expect("valid scene")).expect("problem")
}

/// A plane-strain bar [0, 1] × [0, 0.05] (rollers on the long sides, the left end held along x)
/// pulled at its right end by a Ricker pulse; criteria on a zone and the end piece; uncertain E,
/// ρ, τ_v, the pulse's amplitude and an absorbing layer's damping at the left end.
fn bar(scheme: &str) -> Value {
    json!({
        "version": 1,
        "bodies": [{"name": "bar", "zones": [{"name": "bar", "material": "steel",
            "polygon": [[0, 0], [1, 0], [1, 0.05], [0, 0.05]]}]}],
        "segments": {
            "left": {"body": "bar", "from": [0, 0.05], "to": [0, 0]},
            "bottom": {"body": "bar", "from": [0, 0], "to": [1, 0]},
            "right": {"body": "bar", "from": [1, 0], "to": [1, 0.05]},
            "top": {"body": "bar", "from": [1, 0.05], "to": [0, 0.05]}
        },
        "materials": {"steel": {"E": 1e9, "nu": 0.2, "density": 1000.0, "viscosity": 2e-6}},
        "boundary": [
            {"segment": "left", "displacement": [0, null]},
            {"segment": "bottom", "roller": {}},
            {"segment": "top", "roller": {}},
            {"segment": "right", "traction": [1e6, 0],
             "time_function": {"ricker": {"frequency": 2000.0, "delay": 6e-4}}}
        ],
        "absorbing": [{"segments": ["left"], "thickness": 0.2, "damping": 1e6}],
        "mesh": {"max_size": 0.05},
        "criteria": {
            "regions": [{"name": "near_end", "polygon": [[0.8, 0], [1, 0], [1, 0.05], [0.8, 0.05]],
                "normal_at": [1.0, 0.025]}],
            "boundary_pieces": [{"name": "end", "segment": "right", "from": [1, 0], "to": [1, 0.05]}]
        },
        "uncertain": [
            {"field": "materials.steel.E", "interval": [8e8, 1.2e9]},
            {"field": "materials.steel.density", "interval": [900.0, 1100.0]},
            {"field": "materials.steel.viscosity", "interval": [1e-6, 3e-6]},
            {"field": "boundary[3].traction[0]", "interval": [5e5, 2e6]},
            {"field": "absorbing[0].damping", "interval": [5e5, 2e6]},
            {"field": "materials.steel.nu", "interval": [0.1, 0.3]}
        ],
        "dynamics": {"t_end": 1.6e-3, "dt": 2e-5, "scheme": scheme}
    })
}

/// The bundled block on a base (Tresca joint, pressure on top, push on the side) as a dynamic
/// scene from rest: the loads arrive at t = 0 and the block rings on the joint.
fn block(scheme: &str) -> Value {
    let mut scene: Value =
        serde_json::from_str(wsm_core::bundled::find("block-on-base").expect("bundled"))
            .expect("json");
    scene["materials"]["rock"]["density"] = json!(2500.0);
    scene["materials"]["rock"]["viscosity"] = json!(1e-5);
    scene["mesh"] =
        json!({"max_size": 0.125, "refine": [{"segments": ["block_contact"], "max_size": 0.0625}]});
    scene["uncertain"] = json!([
        {"field": "materials.rock.E", "interval": [8e9, 12e9]},
        {"field": "materials.rock.density", "interval": [2000.0, 3000.0]},
        {"field": "boundary[2].traction[0]", "interval": [3e5, 4e5]},
        {"field": "contacts[joint].slip_limit", "interval": [2.5e5, 4e5]},
        {"field": "materials.rock.viscosity", "interval": [5e-6, 2e-5]}
    ]);
    scene["dynamics"] = json!({"t_end": 1e-3, "dt": 2e-5, "scheme": scheme});
    scene
}

/// Per criterion and datum: (exact right derivative, central difference of whole runs with a
/// relative step of 1e-5, value). Smaller steps drown in the runs' rounding (at 3e-7 the
/// difference reaches 2e-6), larger ones in the truncation error.
fn gradient_check(
    scene: &Value,
    criteria: &[Criterion],
) -> Vec<(Criterion, String, f64, f64, f64)> {
    let p = problem(scene);
    let params = parameters(&p.scene).expect("parameters");
    let theta: Vec<f64> = params.iter().map(|q| 0.5 * (q.lo + q.hi)).collect();
    let stencils: Vec<_> = (0..params.len())
        .map(|i| stencil(&p.scene, &p.nominal, &params, &theta, i))
        .collect();
    let at = |theta: &[f64], stencils: &[_]| {
        let data = apply(&p.scene, &p.nominal, &params, theta);
        solve_over_time(&p, &data, criteria, stencils).expect("dynamic run")
    };
    let solution = at(&theta, &stencils);
    assert_eq!(
        solution.sensitivities.len(),
        params.len(),
        "{:?}",
        solution.report.warnings
    );
    let mut out = Vec::new();
    for (j, q) in params.iter().enumerate() {
        let h = 1e-5 * theta[j].abs();
        let mut plus = theta.clone();
        plus[j] += h;
        let mut minus = theta.clone();
        minus[j] -= h;
        let (up, down) = (at(&plus, &[]), at(&minus, &[]));
        for &c in criteria {
            let i = c as usize;
            let value = solution.criteria[i].expect("criterion value");
            let fd =
                (up.criteria[i].expect("value") - down.criteria[i].expect("value")) / (2.0 * h);
            let exact = solution.sensitivities[j][i].expect("derivative");
            assert!(
                (exact.right - exact.left).abs()
                    <= 1e-9 * exact.right.abs().max(value.abs() / theta[j].abs()),
                "{c:?} along {}: one-sided {exact:?} at a smooth point",
                q.name
            );
            out.push((c, q.name.clone(), exact.right, fd, value));
        }
    }
    out
}

/// |exact − central| within 1e-6 of the derivative's scale (the derivative itself, or Φ per
/// unit datum where the derivative is much smaller).
fn assert_close(rows: &[(Criterion, String, f64, f64, f64)], theta_scale: &dyn Fn(&str) -> f64) {
    let mut worst: f64 = 0.0;
    for (c, name, exact, fd, value) in rows {
        let scale = exact.abs().max(1e-3 * value.abs() / theta_scale(name));
        let error = (exact - fd).abs() / scale;
        worst = worst.max(error);
        assert!(
            error <= 1e-6,
            "{c:?} along {name}: exact {exact:e}, central {fd:e} (relative {error:e})"
        );
    }
    eprintln!(
        "largest relative difference exact vs central: {worst:.2e} over {} derivatives",
        rows.len()
    );
}

#[test]
fn gradients_over_time_match_central_differences_without_contact() {
    for scheme in ["paper", "newmark"] {
        let scene = bar(scheme);
        let rows = gradient_check(&scene, &[Criterion::Phi3, Criterion::Phi4, Criterion::Phi5]);
        let params = parameters(&parse(&scene.to_string()).unwrap()).unwrap();
        let scale = |name: &str| {
            let q = params.iter().find(|q| q.name == name).unwrap();
            0.5 * (q.lo + q.hi)
        };
        eprintln!("bar, {scheme}:");
        assert_close(&rows, &scale);
        // Every datum moves the criteria: nothing is differentiated by accident to zero.
        assert!(rows
            .iter()
            .filter(|r| r.0 == Criterion::Phi4)
            .all(|r| r.2 != 0.0));
    }
}

#[test]
fn gradients_over_time_match_central_differences_with_contact() {
    for scheme in ["paper", "newmark"] {
        let scene = block(scheme);
        let rows = gradient_check(&scene, &[Criterion::Phi3, Criterion::Phi5, Criterion::Phi6]);
        let params = parameters(&parse(&scene.to_string()).unwrap()).unwrap();
        let scale = |name: &str| {
            let q = params.iter().find(|q| q.name == name).unwrap();
            0.5 * (q.lo + q.hi)
        };
        eprintln!("block on base, {scheme}:");
        assert_close(&rows, &scale);
    }
}

/// `wsm solve`'s history of a dynamic scene carries each criterion's maximum over time, when
/// and where it happens; a density in a static scene is refused naming the field.
#[test]
fn solve_reports_the_peaks_and_static_scenes_refuse_dynamic_data() {
    let scene = parse(&bar("newmark").to_string()).unwrap();
    let output = wsm_core::run::solve(scene, &Default::default()).expect("solve");
    let history = output.summary.history.expect("history");
    let peak = &history.criteria["phi4"];
    eprintln!(
        "bar: phi4 peaks at {:.4e} m at t = {:.4e} s ({})",
        peak.value, peak.time, peak.region
    );
    // The pulse peaks at 0.6 ms at the end it loads.
    assert!(
        peak.value > 0.0 && (4e-4..1.2e-3).contains(&peak.time),
        "{peak:?}"
    );
    assert_eq!(peak.region, "end");

    let mut static_scene: Value =
        serde_json::from_str(wsm_core::bundled::find("block-on-base").unwrap()).unwrap();
    static_scene["materials"]["rock"]["density"] = json!(2500.0);
    static_scene["uncertain"][0] =
        json!({"field": "materials.rock.density", "interval": [2000.0, 3000.0]});
    let error = parse(&static_scene.to_string()).map(|s| parameters(&s));
    let message = format!("{error:?}");
    assert!(
        message.contains("uncertain[0].field") && message.contains("dynamics"),
        "{message}"
    );
}

/// A clamped block pulled up on its top by p(t) (ramped in, then held) with E and p uncertain:
/// the largest mean lift of the top over time grows with p and falls with E, so the worst is
/// (E lo, p hi) and the best (E hi, p lo), each certified by the exact derivatives over time.
#[test]
fn worst_of_a_monotone_dynamic_block_is_certified_at_its_vertices() {
    let scene = json!({
        "version": 1, "name": "dynamic monotone block",
        "bodies": [{"name": "b", "zones": [{"name": "z", "material": "m",
            "polygon": [[0,0],[1,0],[1,1],[0,1]]}]}],
        "segments": {
            "bottom": {"body": "b", "from": [0,0], "to": [1,0]},
            "top": {"body": "b", "from": [1,1], "to": [0,1]}
        },
        "materials": {"m": {"E": 7.0e9, "nu": 0.3, "density": 2500.0, "viscosity": 1e-4}},
        "boundary": [
            {"segment": "bottom", "displacement": [0, 0]},
            {"segment": "top", "traction": [0, 1.5e6],
             "time_function": {"table": {"times": [0.0, 5e-4], "values": [0.0, 1.0]}}}
        ],
        "mesh": {"max_size": 0.25},
        "criteria": {"boundary_pieces": [{"name": "top", "segment": "top", "from": [1,1], "to": [0,1]}]},
        "uncertain": [
            {"field": "materials.m.E", "interval": [5e9, 1e10]},
            {"field": "boundary[1].traction[1]", "interval": [1e6, 2e6]}
        ],
        "search": {"criteria": ["phi4"], "budget": 60, "seed": 1},
        "dynamics": {"t_end": 2e-3, "dt": 2.5e-5, "scheme": "newmark"}
    });
    let request = WorstRequest {
        budget: Some(60),
        derivatives: Some(true),
        stop: Some(StopRule::FirstCertificate),
        ..WorstRequest::default()
    };
    let started = std::time::Instant::now();
    let outcome = worst(
        parse(&scene.to_string()).unwrap(),
        &request,
        &RunControl::new(),
    )
    .expect("worst over time");
    let c = &outcome.criteria[0];
    eprintln!(
        "dynamic block: worst {:?} at {:?} (t = {:?}), best {:?} at {:?} (t = {:?}); {} evaluations in {:.2} s",
        c.worst.value, c.worst.point, c.worst.time, c.best.value, c.best.point, c.best.time,
        outcome.evaluations,
        started.elapsed().as_secs_f64()
    );
    for (o, point) in [(&c.worst, [5e9, 2e6]), (&c.best, [1e10, 1e6])] {
        assert_eq!(o.status, Status::LocallyCertified, "{:?}", o.certificate);
        let proof = o.certificate.as_ref().expect("a certificate");
        assert_eq!(proof.verdict, Verdict::LocallyCertified);
        let found = o.point.as_ref().expect("a point");
        for (x, y) in found.iter().zip(point) {
            assert!((x - y).abs() <= 1e-9 * y, "{found:?} vs {point:?}");
        }
        let t = o.time.expect("the time of the maximum");
        assert!(t > 0.0 && t <= 2e-3, "time {t}");
        assert_eq!(o.region.as_deref(), Some("top"));
    }
}
