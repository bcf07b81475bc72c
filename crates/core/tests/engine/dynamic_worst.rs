//! The worst scenario over time (design §3.5, issue 47 item 6): the criteria of a dynamic scene
//! as maxima over the time steps, their exact derivatives by forward differentiation through the
//! time loop against central differences of whole runs (a bar without contact, a block on a base
//! with contact and Tresca friction, both schemes), the uncertain dynamic data (density,
//! viscosity, absorbing damping), and `wsm worst` on a dynamic scene whose worst and best are
//! vertices, certified. The defined criteria over time likewise: a receiver's peak velocity
//! (against the receiver's history and by central differences), stress and contact means, and a
//! worst run that searches a peak velocity.

use serde_json::{json, Value};
use wsm_core::{
    apply_parameters, parameter_stencil, parse_scene, scene_parameters, solve_over_time, worst,
    Criterion, RunControl, StateProblem, Status, StopRule, Verdict, WorstOutcome, WorstRequest,
};

fn problem(scene: &Value) -> StateProblem {
    StateProblem::new(parse_scene(&scene.to_string()).expect("valid scene")).expect("problem")
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
        serde_json::from_str(wsm_core::find_example("block-on-base").expect("bundled"))
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

/// How the exact derivatives are checked: the difference formula of whole runs (offsets in
/// steps, weights per step), its relative step, and whether the point must be smooth (right =
/// left derivative; otherwise each is checked against the difference).
struct Check {
    taps: &'static [(f64, f64)],
    step: f64,
    smooth: bool,
}

/// The second-order central difference with a relative step of 1e-5, at smooth points. Smaller
/// steps drown in the runs' rounding (at 3e-7 the difference reaches 2e-6), larger ones in the
/// truncation error.
const CENTRAL: Check = Check {
    taps: &[(-1.0, -0.5), (1.0, 0.5)],
    step: 1e-5,
    smooth: true,
};

/// The fourth-order central difference with a relative step of 3e-5: its truncation error is
/// far below the second-order one's at that step, its rounding a third of it at 1e-5 (the runs
/// with contact and a static start or slip-rate friction leave 1e-6 between the two errors of
/// [`CENTRAL`]). One-sided derivatives are each checked.
const CENTRAL_4: Check = Check {
    taps: &[
        (-2.0, 1.0 / 12.0),
        (-1.0, -8.0 / 12.0),
        (1.0, 8.0 / 12.0),
        (2.0, -1.0 / 12.0),
    ],
    step: 3e-5,
    smooth: false,
};

/// Per criterion and datum: (exact right and left derivatives, the difference of whole runs
/// by `check`, value).
fn gradient_check(scene: &Value, criteria: &[Criterion], check: &Check) -> Vec<Row> {
    let p = problem(scene);
    let params = scene_parameters(&p.scene).expect("parameters");
    let theta: Vec<f64> = params.iter().map(|q| 0.5 * (q.lo + q.hi)).collect();
    let stencils: Vec<_> = (0..params.len())
        .map(|i| parameter_stencil(&p.scene, &p.nominal, &params, &theta, i))
        .collect();
    let at = |theta: &[f64], stencils: &[_]| {
        let data = apply_parameters(&p.scene, &p.nominal, &params, theta);
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
    let mut gap: f64 = 0.0;
    for (j, q) in params.iter().enumerate() {
        let h = check.step * theta[j].abs();
        let runs: Vec<_> = check
            .taps
            .iter()
            .map(|(offset, _)| {
                let mut at_point = theta.clone();
                at_point[j] += offset * h;
                at(&at_point, &[])
            })
            .collect();
        for &c in criteria {
            let i = c as usize;
            let value = solution.criteria[i].expect("criterion value");
            let fd = (check.taps.iter().zip(&runs))
                .map(|((_, w), run)| w * run.criteria[i].expect("value"))
                .sum::<f64>()
                / h;
            let exact = solution.sensitivities[j][i].expect("derivative");
            let scale = exact.right.abs().max(value.abs() / theta[j].abs());
            gap = gap.max((exact.right - exact.left).abs() / scale);
            assert!(
                !check.smooth || (exact.right - exact.left).abs() <= 1e-9 * scale,
                "{c:?} along {}: one-sided {exact:?} at a smooth point",
                q.name
            );
            out.push((c, q.name.clone(), exact.right, exact.left, fd, value));
        }
    }
    eprintln!("largest relative gap between right and left derivatives: {gap:.1e}");
    out
}

/// (criterion, datum, right, left, difference of runs, value).
type Row = (Criterion, String, f64, f64, f64, f64);

/// |exact − central| within 1e-6 of the derivative's scale (the derivative itself, or Φ per
/// unit datum where the derivative is much smaller, the datum at the middle of its interval in
/// `scene`), for the right and the left derivative; `label` names the case in the printout. A
/// row's datum may carry its criterion's name as a prefix (`criterion/datum`).
fn assert_close(scene: &Value, label: &str, rows: &[Row]) {
    let params = scene_parameters(&parse_scene(&scene.to_string()).unwrap()).unwrap();
    let theta_scale = |name: &str| {
        let datum = name.split_once('/').map_or(name, |(_, d)| d);
        let q = params.iter().find(|q| q.name == datum).unwrap();
        0.5 * (q.lo + q.hi)
    };
    eprintln!("{label}:");
    let mut worst: f64 = 0.0;
    for (c, name, right, left, fd, value) in rows {
        for exact in [right, left] {
            let scale = exact.abs().max(1e-3 * value.abs() / theta_scale(name));
            let error = (exact - fd).abs() / scale;
            worst = worst.max(error);
            assert!(
                error <= 1e-6,
                "{c:?} along {name}: exact {exact:e}, central {fd:e} (relative {error:e})"
            );
        }
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
        let rows = gradient_check(
            &scene,
            &[Criterion::Phi3, Criterion::Phi4, Criterion::Phi5],
            &CENTRAL,
        );
        assert_close(&scene, &format!("bar, {scheme}"), &rows);
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
        let rows = gradient_check(
            &scene,
            &[Criterion::Phi3, Criterion::Phi5, Criterion::Phi6],
            &CENTRAL,
        );
        assert_close(&scene, &format!("block on base, {scheme}"), &rows);
    }
}

/// [`block`] started from its static solution, with the push ramped from half to full over the
/// run (the static start holds the half push; the rest drives the block from there); uncertain
/// E, ρ, the push and the slip limit (τ_v, which the static start does not see and whose
/// derivative the run from rest checks, moves Φ by 1e-3 of its value per unit relative change:
/// its differences of runs are at the rounding's 1e-6 there).
fn block_from_static(scheme: &str) -> Value {
    let mut scene = block(scheme);
    if let Some(uncertain) = scene["uncertain"].as_array_mut() {
        uncertain.retain(|u| u["field"] != "materials.rock.viscosity");
    }
    scene["boundary"][2]["time_function"] =
        json!({"table": {"times": [0.0, 1e-3], "values": [0.5, 1.0]}});
    scene["dynamics"]["initial"] = json!("static");
    scene
}

/// [`block`] with a slip-rate-dependent Coulomb joint (F_s = 0.15, F_k = 0.08, v_c = 5 cm/s):
/// the full push Q h = 1.75e5 N/m exceeds F_s N ≈ 1.5e5 N/m, so the block slides, the friction
/// falling towards F_k with its slip rate; uncertain E, ρ, the push and F_s.
fn sliding_block(scheme: &str) -> Value {
    let mut scene = block(scheme);
    scene["contacts"][0] = json!({"name": "joint", "between": ["block_contact", "base_contact"],
        "friction_coefficient": 0.15, "friction_kinetic": 0.08, "slip_rate_scale": 0.05});
    scene["uncertain"] = json!([
        {"field": "materials.rock.E", "interval": [8e9, 12e9]},
        {"field": "materials.rock.density", "interval": [2000.0, 3000.0]},
        {"field": "boundary[2].traction[0]", "interval": [3e5, 4e5]},
        {"field": "contacts[joint].friction_coefficient", "interval": [0.13, 0.17]}
    ]);
    scene
}

/// The check of [`gradient_check`] on `scene` for both schemes, with Φ3, Φ5, Φ6 and the
/// fourth-order difference.
fn check_both_schemes(name: &str, scene: &dyn Fn(&str) -> Value) {
    for scheme in ["paper", "newmark"] {
        let scene = scene(scheme);
        let rows = gradient_check(
            &scene,
            &[Criterion::Phi3, Criterion::Phi5, Criterion::Phi6],
            &CENTRAL_4,
        );
        assert_close(&scene, &format!("{name}, {scheme}"), &rows);
    }
}

#[test]
fn gradients_over_time_from_the_static_start_match_central_differences() {
    check_both_schemes("block from its static solution", &block_from_static);
}

#[test]
fn gradients_over_time_with_slip_rate_friction_match_central_differences() {
    check_both_schemes("block sliding on a slip-rate joint", &sliding_block);
}

/// `wsm worst` on `scene` with exact derivatives, stopping at the first certificate.
fn worst_to_first_certificate(scene: &Value, budget: usize) -> WorstOutcome {
    let request = WorstRequest {
        budget: Some(budget),
        derivatives: Some(true),
        stop: Some(StopRule::FirstCertificate),
        ..WorstRequest::default()
    };
    worst(
        parse_scene(&scene.to_string()).unwrap(),
        &request,
        &RunControl::new(),
    )
    .expect("worst over time")
}

/// `wsm worst` on the sliding block started from its static solution (push ramped from half to
/// full, Φ3): the search ends with exact derivatives over time at both extrema — each carries a
/// certificate judged on them (`locally_certified` or `not_optimal`, never `no_derivatives`).
#[test]
fn worst_over_time_from_the_static_start_with_slip_rate_friction_uses_the_derivatives() {
    let mut scene = sliding_block("newmark");
    scene["boundary"][2]["time_function"] =
        json!({"table": {"times": [0.0, 1e-3], "values": [0.5, 1.0]}});
    scene["dynamics"]["initial"] = json!("static");
    scene["search"] = json!({"criteria": ["phi3"], "budget": 30, "seed": 1});
    let started = std::time::Instant::now();
    let outcome = worst_to_first_certificate(&scene, 30);
    let c = &outcome.criteria[0];
    eprintln!(
        "sliding block from static: worst {:?} at {:?} ({:?}), best {:?} at {:?} ({:?}); {} evaluations in {:.2} s; warnings {:?}",
        c.worst.value, c.worst.point, c.worst.certificate.as_ref().map(|p| p.verdict),
        c.best.value, c.best.point, c.best.certificate.as_ref().map(|p| p.verdict),
        outcome.evaluations,
        started.elapsed().as_secs_f64(),
        outcome.warnings
    );
    for o in [&c.worst, &c.best] {
        let proof = o.certificate.as_ref().expect("a certificate");
        assert_ne!(proof.verdict, Verdict::NoDerivatives, "{proof:?}");
    }
}

/// `wsm solve`'s history of a dynamic scene carries each criterion's maximum over time, when
/// and where it happens; a density in a static scene is refused naming the field.
#[test]
fn solve_reports_the_peaks_and_static_scenes_refuse_dynamic_data() {
    let scene = parse_scene(&bar("newmark").to_string()).unwrap();
    let output = wsm_core::solve(scene, &Default::default()).expect("solve");
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
        serde_json::from_str(wsm_core::find_example("block-on-base").unwrap()).unwrap();
    static_scene["materials"]["rock"]["density"] = json!(2500.0);
    static_scene["uncertain"][0] =
        json!({"field": "materials.rock.density", "interval": [2000.0, 3000.0]});
    let error = parse_scene(&static_scene.to_string()).map(|s| scene_parameters(&s));
    let message = format!("{error:?}");
    assert!(
        message.contains("uncertain[0].field") && message.contains("dynamics"),
        "{message}"
    );
}

/// A clamped unit block pulled up on its top by a traction p(t), ramped in over 0.5 ms and then
/// held (newmark, 2 ms), with E ∈ [5, 10] GPa and p ∈ [1, 2] MPa uncertain; no criteria yet.
fn lifted_block(name: &str) -> Value {
    json!({
        "version": 1, "name": name,
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
        "uncertain": [
            {"field": "materials.m.E", "interval": [5e9, 1e10]},
            {"field": "boundary[1].traction[1]", "interval": [1e6, 2e6]}
        ],
        "dynamics": {"t_end": 2e-3, "dt": 2.5e-5, "scheme": "newmark"}
    })
}

/// A clamped block pulled up on its top by p(t) (ramped in, then held) with E and p uncertain:
/// the largest mean lift of the top over time grows with p and falls with E, so the worst is
/// (E lo, p hi) and the best (E hi, p lo), each certified by the exact derivatives over time.
#[test]
fn worst_of_a_monotone_dynamic_block_is_certified_at_its_vertices() {
    let mut scene = lifted_block("dynamic monotone block");
    scene["criteria"] = json!({"boundary_pieces": [
        {"name": "top", "segment": "top", "from": [1,1], "to": [0,1]}
    ]});
    scene["search"] = json!({"criteria": ["phi4"], "budget": 60, "seed": 1});
    let started = std::time::Instant::now();
    let outcome = worst_to_first_certificate(&scene, 60);
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

/// Per defined criterion and datum: (exact right derivative, central difference of whole runs
/// with a relative step of 1e-5, value), as [`gradient_check`] for Φ1–Φ6; the defined
/// criteria are read by name from the region values and region derivatives.
fn defined_gradient_check(scene: &Value) -> Vec<Row> {
    const DEFINED: usize = Criterion::Defined as usize;
    let p = problem(scene);
    let params = scene_parameters(&p.scene).expect("parameters");
    let theta: Vec<f64> = params.iter().map(|q| 0.5 * (q.lo + q.hi)).collect();
    let stencils: Vec<_> = (0..params.len())
        .map(|i| parameter_stencil(&p.scene, &p.nominal, &params, &theta, i))
        .collect();
    let at = |theta: &[f64], stencils: &[_]| {
        let data = apply_parameters(&p.scene, &p.nominal, &params, theta);
        solve_over_time(&p, &data, &[Criterion::Defined], stencils).expect("dynamic run")
    };
    let solution = at(&theta, &stencils);
    let names: Vec<&str> = p
        .scene
        .criteria
        .defined
        .iter()
        .map(|d| d.name.as_str())
        .collect();
    assert_eq!(solution.region_values[DEFINED].len(), names.len());
    let mut out = Vec::new();
    for (j, q) in params.iter().enumerate() {
        let h = 1e-5 * theta[j].abs();
        let mut plus = theta.clone();
        plus[j] += h;
        let mut minus = theta.clone();
        minus[j] -= h;
        let (up, down) = (at(&plus, &[]), at(&minus, &[]));
        for (k, name) in names.iter().enumerate() {
            let value = solution.region_values[DEFINED][k];
            let fd = (up.region_values[DEFINED][k] - down.region_values[DEFINED][k]) / (2.0 * h);
            let exact = solution.region_sensitivities[j][DEFINED][k].expect("derivative");
            assert!(
                (exact.right - exact.left).abs()
                    <= 1e-9 * exact.right.abs().max(value.abs() / theta[j].abs()),
                "{name} along {}: one-sided {exact:?} at a smooth point",
                q.name
            );
            eprintln!(
                "{name} along {}: exact {:e}, central {fd:e}",
                q.name, exact.right
            );
            out.push((
                Criterion::Defined,
                format!("{name}/{}", q.name),
                exact.right,
                exact.left,
                fd,
                value,
            ));
        }
    }
    out
}

/// The bar of [`bar`] with a receiver near its loaded end: its peak velocity and the mean σxx
/// next to the end as defined criteria.
fn bar_with_receiver(scheme: &str) -> Value {
    let mut scene = bar(scheme);
    scene["receivers"] = json!([{"name": "near_tip", "point": [0.93, 0.02]}]);
    scene["criteria"]["defined"] = json!([
        {"name": "tip_speed", "receiver": "near_tip", "quantity": "peak_velocity"},
        {"name": "end_sxx", "region": "near_end", "quantity": "sigma_xx"}
    ]);
    scene
}

/// The largest speed over a receiver's velocity history.
fn history_peak(velocity: &[[f64; 2]], times: &[f64]) -> (f64, f64) {
    velocity
        .iter()
        .zip(times)
        .map(|(v, &t)| (v[0].hypot(v[1]), t))
        .fold(
            (f64::NEG_INFINITY, 0.0),
            |a, b| if b.0 > a.0 { b } else { a },
        )
}

/// A receiver's peak velocity is the largest |v| of its history when every step is an output
/// (`output_every` 1), reached at the same time; a stress mean as a defined criterion has its
/// maximum over time in the history too.
#[test]
fn peak_velocity_is_the_receiver_history_maximum() {
    for scheme in ["paper", "newmark"] {
        let scene = parse_scene(&bar_with_receiver(scheme).to_string()).expect("valid scene");
        let output = wsm_core::solve(scene, &Default::default()).expect("solve");
        let history = output.summary.history.expect("history");
        let receiver = &history.receivers["near_tip"];
        assert_eq!(receiver.velocity.len(), history.times.len());
        let (speed, time) = history_peak(&receiver.velocity, &history.times);
        let peak = &history.criteria["tip_speed"];
        eprintln!(
            "{scheme}: tip_speed {:.6e} m/s at {:.4e} s, history max {speed:.6e} at {time:.4e}",
            peak.value, peak.time
        );
        assert!(speed > 0.0);
        assert!(
            (peak.value - speed).abs() <= 1e-12 * speed,
            "{} vs {speed}",
            peak.value
        );
        assert_eq!(peak.time, time);
        assert_eq!(peak.region, "near_tip");
        let sxx = &history.criteria["end_sxx"];
        assert!(sxx.value > 0.0 && sxx.time > 0.0, "{sxx:?}");
        assert_eq!(sxx.region, "near_end");
    }
}

#[test]
fn defined_criteria_gradients_over_time_match_central_differences_without_contact() {
    for scheme in ["paper", "newmark"] {
        let scene = bar_with_receiver(scheme);
        let rows = defined_gradient_check(&scene);
        assert_close(&scene, &format!("bar with a receiver, {scheme}"), &rows);
        // The pulse's amplitude moves the peak speed (linearly: no contact).
        assert!(rows
            .iter()
            .any(|r| r.1.starts_with("tip_speed/") && r.2 != 0.0));
    }
}

#[test]
fn defined_criteria_gradients_over_time_match_central_differences_with_contact() {
    for scheme in ["paper", "newmark"] {
        let mut scene = block(scheme);
        scene["receivers"] = json!([{"name": "corner", "point": [1.4, 0.9]}]);
        scene["criteria"]["boundary_pieces"]
            .as_array_mut()
            .expect("pieces")
            .push(json!({"name": "mid", "segment": "block_contact", "from": [0.7, 0.5], "to": [1.3, 0.5]}));
        scene["criteria"]["defined"] = json!([
            {"name": "corner_speed", "receiver": "corner", "quantity": "peak_velocity"},
            {"name": "g1_von_mises", "region": "G1", "quantity": "von_mises"},
            {"name": "mid_pressure", "region": "mid", "quantity": "contact_pressure"}
        ]);
        let rows = defined_gradient_check(&scene);
        assert_close(
            &scene,
            &format!("block on base with defined criteria, {scheme}"),
            &rows,
        );
    }
}

/// `wsm worst` on a small dynamic scene searching a receiver's peak velocity: a clamped block
/// lifted on its top by a ramped traction p with E uncertain. Without contact the run is linear
/// in p, so the worst is at p's upper end and the best at its lower end; the extrema bound the
/// corners' values, name the receiver and a time within the run.
#[test]
fn worst_peak_velocity_of_a_dynamic_block() {
    let mut scene = lifted_block("dynamic block, peak velocity");
    scene["receivers"] = json!([{"name": "crest", "point": [0.5, 0.9]}]);
    scene["criteria"] = json!({"defined": [
        {"name": "crest_speed", "receiver": "crest", "quantity": "peak_velocity"}
    ]});
    scene["search"] = json!({"criteria": ["crest_speed"], "budget": 60, "seed": 1});
    let request = WorstRequest {
        budget: Some(60),
        derivatives: Some(true),
        ..WorstRequest::default()
    };
    let parsed = parse_scene(&scene.to_string()).unwrap();
    let outcome = worst(parsed.clone(), &request, &RunControl::new()).expect("worst over time");
    let c = &outcome.criteria[0];
    eprintln!(
        "crest_speed: worst {:?} at {:?} (t = {:?}, {:?}), best {:?} at {:?} (t = {:?}, {:?}); {} evaluations",
        c.worst.value, c.worst.point, c.worst.time, c.worst.status, c.best.value, c.best.point,
        c.best.time, c.best.status, outcome.evaluations
    );
    let p = StateProblem::new(parsed).unwrap();
    let params = scene_parameters(&p.scene).unwrap();
    let corner = |theta: &[f64]| {
        let data = apply_parameters(&p.scene, &p.nominal, &params, theta);
        solve_over_time(&p, &data, &[Criterion::Defined], &[])
            .expect("run")
            .region_values[Criterion::Defined as usize][0]
    };
    let corners: Vec<f64> = [[5e9, 1e6], [5e9, 2e6], [1e10, 1e6], [1e10, 2e6]]
        .iter()
        .map(|t| corner(t))
        .collect();
    let (worst_value, best_value) = (c.worst.value.unwrap(), c.best.value.unwrap());
    for v in &corners {
        assert!(
            worst_value >= v * (1.0 - 1e-9),
            "worst {worst_value} < corner {v}"
        );
        assert!(
            best_value <= v * (1.0 + 1e-9),
            "best {best_value} > corner {v}"
        );
    }
    for (o, p_end) in [(&c.worst, 2e6), (&c.best, 1e6)] {
        let point = o.point.as_ref().expect("a point");
        assert!((point[1] - p_end).abs() <= 1e-9 * p_end, "{point:?}");
        let t = o.time.expect("the time of the maximum");
        assert!(t > 0.0 && t <= 2e-3, "time {t}");
        assert_eq!(o.region.as_deref(), Some("crest"));
    }
}
