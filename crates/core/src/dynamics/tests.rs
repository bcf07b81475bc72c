//! Verification of the dynamic solver against closed forms (design §3.5, verification.md):
//! a bar's longitudinal vibration (ν = 0, rollers: the 1D wave equation, c = √(E/ρ)),
//! Newmark's second order in Δt and exact energy balance, the paper's scheme's monotone
//! energy loss, Kelvin–Voigt creep, a block dropped on a base (free-fall time, no penetration,
//! no energy gain), and the static start as a fixed point. Every run goes through [`checked`]:
//! PDAS terminates on every step and the QP kernel gives the same step to 1e-10.

use serde_json::{json, Value};

use super::step::qp_check;
use super::{simulate, static_start, DynamicRun};
use crate::scene::parse;
use crate::state::StateProblem;

const E: f64 = 1e9;
const RHO: f64 = 1000.0;
/// c = √(E/ρ) = 1000 m/s; the bar is 1 m long.
const C: f64 = 1000.0;

pub(super) fn problem(scene: &Value) -> StateProblem {
    StateProblem::new(parse(&scene.to_string()).expect("valid scene")).expect("problem")
}

pub(super) fn run(scene: &Value) -> DynamicRun {
    checked(&problem(scene))
}

/// Simulate; PDAS must terminate on every step (no QP fallback) and agree with the QP kernel
/// run on the same step systems to 1e-10 (relative to the contact's effect on u).
pub(super) fn checked(p: &StateProblem) -> DynamicRun {
    qp_check::take();
    let run = simulate(p, &p.nominal).expect("dynamic run");
    let (steps, worst) = qp_check::take();
    let report = &run.history.report;
    eprintln!(
        "PDAS: {steps} steps with contact checked against the QP, max relative difference \
         {worst:.2e}, {} fallbacks, {} iterations over {} steps",
        report.pdas_fallbacks, report.qp_iterations, report.steps
    );
    assert_eq!(report.pdas_fallbacks, 0, "PDAS did not terminate on a step");
    assert!(worst <= 1e-10, "PDAS and the QP differ by {worst:e}");
    run
}

/// A plane-strain bar [0, 1] × [0, 0.05] with ν = 0, rollers on the long sides, the left end
/// held along x, the right end loaded by `traction` with `time_function`.
pub(super) fn bar(traction: f64, time_function: Value, dynamics: Value, viscosity: f64) -> Value {
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
        "materials": {"steel": {"E": E, "nu": 0.0, "density": RHO, "viscosity": viscosity}},
        "boundary": [
            {"segment": "left", "displacement": [0, null]},
            {"segment": "bottom", "roller": {}},
            {"segment": "top", "roller": {}},
            {"segment": "right", "traction": [traction, 0], "time_function": time_function}
        ],
        "mesh": {"max_size": 0.025},
        "receivers": [{"name": "tip", "point": [1.0, 0.025]}],
        "dynamics": dynamics
    })
}

fn tip(run: &DynamicRun) -> Vec<f64> {
    run.history.receivers["tip"]
        .displacement
        .iter()
        .map(|u| u[0])
        .collect()
}

/// Released from the uniform strain of a tip load, the tip of a fixed–free bar moves as a
/// triangle wave: from u_s through 0 at t = L/c to −u_s at 2L/c and back at 4L/c.
#[test]
fn released_bar_follows_the_triangle_wave() {
    let dt = 2e-6;
    let scene = bar(
        1e6,
        json!({"table": {"times": [0.0, dt], "values": [1.0, 0.0]}}),
        json!({"t_end": 4.0e-3, "dt": dt, "initial": "static", "scheme": "newmark"}),
        0.0,
    );
    let run = run(&scene);
    let u = tip(&run);
    let times = &run.history.times;
    let u_static = 1e6 / E; // uniform strain P/E over 1 m
    assert!(
        (u[0] - u_static).abs() < 1e-9 * u_static,
        "static start {}",
        u[0]
    );
    let crossing = (1..u.len())
        .find(|&i| u[i] < 0.0)
        .expect("the tip crosses 0");
    let t0 = times[crossing - 1] + dt * u[crossing - 1] / (u[crossing - 1] - u[crossing]);
    let at = |t: f64| u[(t / dt).round() as usize];
    let (quarter, half, full) = (1.0 / C, 2.0 / C, 4.0 / C);
    eprintln!(
        "released bar: zero at {t0:.6e} s (L/c = {quarter:e}), u(2L/c)/u_s = {:.4}, u(4L/c)/u_s = {:.4}",
        at(half) / u_static,
        at(full) / u_static
    );
    assert!((t0 - quarter).abs() < 0.01 * quarter, "first zero at {t0}");
    assert!(
        (at(half) + u_static).abs() < 0.05 * u_static,
        "half period {}",
        at(half)
    );
    assert!(
        (at(full) - u_static).abs() < 0.05 * u_static,
        "full period {}",
        at(full)
    );
    // Energy: after the release no load acts, so kinetic + strain stays at its value.
    let e = &run.history.energy;
    let total: Vec<f64> = e
        .kinetic
        .iter()
        .zip(&e.strain)
        .map(|(k, s)| k + s)
        .collect();
    let scale = total[0];
    for (i, t) in total.iter().enumerate().skip(1) {
        assert!(
            (t - total[1]).abs() < 1e-9 * scale,
            "energy at output {i}: {t}"
        );
        assert!(e.numerical[i].abs() < 1e-9 * scale);
    }
}

/// A Ricker pulse at the tip, from rest: Newmark's error at the tip against a run with Δt/16
/// falls as Δt², the paper's as Δt.
#[test]
fn observed_orders_in_dt() {
    let tip_at_end = |scheme: &str, dt: f64| {
        let scene = bar(
            1e6,
            json!({"ricker": {"frequency": 2000.0, "delay": 8e-4}}),
            json!({"t_end": 2.4e-3, "dt": dt, "scheme": scheme}),
            0.0,
        );
        *tip(&run(&scene)).last().expect("recorded")
    };
    for (scheme, expected) in [("newmark", 2.0), ("paper", 1.0)] {
        let reference = tip_at_end(scheme, 1e-6 / 16.0 * 8.0);
        let e1 = (tip_at_end(scheme, 8e-6) - reference).abs();
        let e2 = (tip_at_end(scheme, 4e-6) - reference).abs();
        let order = (e1 / e2).log2();
        eprintln!("{scheme}: tip errors {e1:.3e} (dt 8e-6), {e2:.3e} (dt 4e-6), order {order:.3}");
        assert!(
            (order - expected).abs() < 0.3,
            "{scheme}: errors {e1:e}, {e2:e}, order {order}"
        );
    }
}

/// The paper's scheme loses energy every step (its numerical dissipation is ≥ 0 and grows);
/// for a smooth pulse the loss falls as Δt.
#[test]
fn paper_scheme_energy_never_grows_and_loss_vanishes_with_dt() {
    let loss = |dt: f64| {
        let scene = bar(
            1e6,
            json!({"ricker": {"frequency": 2000.0, "delay": 8e-4}}),
            json!({"t_end": 2.4e-3, "dt": dt, "scheme": "paper"}),
            0.0,
        );
        let run = run(&scene);
        let e = &run.history.energy;
        let work = e.work.iter().fold(0.0_f64, |m, w| m.max(w.abs()));
        for i in 1..e.numerical.len() {
            assert!(
                e.numerical[i] >= e.numerical[i - 1] - 1e-12 * work,
                "the scheme gained energy at output {i}"
            );
        }
        e.numerical.last().expect("recorded") / work
    };
    // The pulse's energy decays as exp(−κ Δt t): −ln(1 − loss) is first order in Δt.
    let (coarse, fine) = (loss(4e-6), loss(1e-6));
    let ratio = (1.0 - fine).ln() / (1.0 - coarse).ln();
    eprintln!(
        "paper scheme: numerical dissipation {coarse:.4e} (dt 4e-6), {fine:.4e} (dt 1e-6) of \
         the work; ratio of the decay exponents {ratio:.3}"
    );
    assert!(
        fine > 0.0 && (ratio - 0.25).abs() < 0.08,
        "losses {coarse} and {fine}"
    );
}

/// Kelvin–Voigt creep under a step load with negligible inertia: u = u_s (1 − e^(−t/τ_v)).
#[test]
fn kelvin_voigt_creep() {
    let tau = 0.1;
    for scheme in ["newmark", "paper"] {
        let mut scene = bar(
            1e6,
            json!({"table": {"times": [0.0], "values": [1.0]}}),
            json!({"t_end": 0.3, "dt": 1e-3, "scheme": scheme}),
            tau,
        );
        // Inertia negligible: the bar's period 4L/c = 4 ms becomes 4 µs.
        scene["materials"]["steel"]["density"] = json!(RHO * 1e-6);
        let run = run(&scene);
        let u = tip(&run);
        let u_static = 1e6 / E;
        let worst = run
            .history
            .times
            .iter()
            .zip(&u)
            .map(|(t, u)| (u - u_static * (1.0 - (-t / tau).exp())).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "creep {scheme}: max error {:.3e} of u_static",
            worst / u_static
        );
        assert!(worst < 0.01 * u_static, "{scheme}: creep error {worst:e}");
    }
}

/// A block falling through a gap d onto a clamped base: it touches after √(2d/g), never
/// penetrates, and the energy kinetic + strain − work of gravity never grows (Newmark with the
/// contact impulse at the end of the step); the balance closes to rounding.
#[test]
fn dropped_block_lands_without_penetration_or_energy_gain() {
    let gap: f64 = 1e-4;
    let g: f64 = 9.8;
    let scene = json!({
        "version": 1,
        "bodies": [
            {"name": "base", "zones": [{"name": "base", "material": "rock",
                "polygon": [[0, 0], [1, 0], [1, 0.25], [0, 0.25]]}]},
            {"name": "block", "zones": [{"name": "block", "material": "rock",
                "polygon": [[0.25, 0.25], [0.75, 0.25], [0.75, 0.5], [0.25, 0.5]]}]}
        ],
        "segments": {
            "bottom": {"body": "base", "from": [0, 0], "to": [1, 0]},
            "base_top": {"body": "base", "from": [0.25, 0.25], "to": [0.75, 0.25]},
            "block_bottom": {"body": "block", "from": [0.25, 0.25], "to": [0.75, 0.25]}
        },
        "materials": {"rock": {"E": 1e10, "nu": 0.25, "density": 2500.0,
            "specific_weight": 2500.0 * g}},
        "boundary": [{"segment": "bottom", "displacement": [0, 0]}],
        "contacts": [{"name": "joint", "between": ["block_bottom", "base_top"],
            "slip_limit": 0.0,
            "initial_gap": {"piecewise_linear": {"knots": [0, 1], "values": [gap, gap]}}}],
        "mesh": {"max_size": 0.0625},
        "dynamics": {"t_end": 0.008, "dt": 5e-5, "scheme": "newmark"}
    });
    let run = run(&scene);
    let h = &run.history;
    let zone = &h.contact_zones["joint"];
    let first = zone
        .normal_force
        .iter()
        .position(|&f| f > 0.0)
        .expect("the block lands");
    let landing = (2.0 * gap / g).sqrt();
    assert!(
        (h.times[first] - landing).abs() <= 2.0 * 5e-5,
        "lands at {} (free fall {landing})",
        h.times[first]
    );
    let e = &h.energy;
    eprintln!(
        "dropped block: lands at {:.4e} s (free fall {landing:.4e}), max penetration {:.2e} m, \
         contact dissipation {:.4e} of work {:.4e}, |numerical| ≤ {:.2e}",
        h.times[first],
        zone.penetration.iter().fold(0.0_f64, |m, p| m.max(*p)),
        e.contact.last().expect("recorded"),
        e.work.last().expect("recorded"),
        e.numerical.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
    );
    let total: Vec<f64> = (0..h.times.len())
        .map(|i| e.kinetic[i] + e.strain[i] - e.work[i])
        .collect();
    let scale = e.work.iter().fold(0.0_f64, |m, w| m.max(w.abs()));
    for i in 1..total.len() {
        assert!(
            zone.penetration[i] <= 1e-12,
            "penetration {:e}",
            zone.penetration[i]
        );
        assert!(
            total[i] <= total[i - 1] + 1e-9 * scale,
            "energy grew at output {i}"
        );
        assert!(e.contact[i] >= e.contact[i - 1] - 1e-12 * scale);
        assert!(
            e.numerical[i].abs() <= 1e-9 * scale,
            "balance {:e}",
            e.numerical[i]
        );
    }
    assert!(
        e.contact.last().expect("recorded") > &0.0,
        "the impact dissipates"
    );
}

/// The static contact solution is a fixed point of both schemes: a scene started from it with
/// constant loads stays there.
#[test]
fn static_start_reproduces_the_static_solve() {
    let mut scene: Value =
        serde_json::from_str(crate::bundled::find("block-on-base").expect("bundled"))
            .expect("json");
    scene["materials"]["rock"]["density"] = json!(2500.0);
    scene["uncertain"] = json!([]);
    scene["search"] = json!({});
    for scheme in ["paper", "newmark"] {
        scene["dynamics"] =
            json!({"t_end": 1e-3, "dt": 1e-4, "initial": "static", "scheme": scheme});
        let p = problem(&scene);
        let start = static_start(&p, &p.nominal).expect("static solve");
        let run = checked(&p);
        let scale = start
            .displacement
            .iter()
            .fold(0.0_f64, |m, u| m.max(u[0].abs()).max(u[1].abs()));
        let worst = run
            .displacement
            .iter()
            .zip(&start.displacement)
            .map(|(a, b)| (a[0] - b[0]).abs().max((a[1] - b[1]).abs()))
            .fold(0.0, f64::max);
        eprintln!(
            "static start {scheme}: moved by {:.2e} of the displacement",
            worst / scale
        );
        assert!(
            worst <= 1e-9 * scale,
            "{scheme}: moved by {worst:e} of {scale:e}"
        );
        let zone = &run.history.contact_zones["joint"];
        assert!(zone.normal_force.iter().all(|&f| f > 0.0));
    }
}

/// Bad dynamic input is refused naming the field.
#[test]
fn bad_dynamic_input_names_the_field() {
    let ok = json!({"t_end": 1e-3, "dt": 1e-5});
    let cases = [
        ("dynamics.dt", json!({"t_end": 1e-3, "dt": 0.0})),
        ("dynamics.dt", json!({"t_end": 1e-3, "dt": 2e-3})),
        ("dynamics.dt", json!({"t_end": 1e3, "dt": 1e-6})),
        ("dynamics.t_end", json!({"t_end": -1.0, "dt": 1e-6})),
        (
            "dynamics.output_every",
            json!({"t_end": 1.0, "dt": 1e-6, "output_every": 1}),
        ),
    ];
    for (path, dynamics) in cases {
        let scene = bar(
            1.0,
            json!({"table": {"times": [0.0], "values": [1.0]}}),
            dynamics,
            0.0,
        );
        let err = parse(&scene.to_string()).expect_err("refused");
        assert_eq!(err.path, path, "{err}");
    }
    let mut scene = bar(
        1.0,
        json!({"table": {"times": [0.0], "values": [1.0]}}),
        ok,
        0.0,
    );
    scene["materials"]["steel"]["density"] = json!(-1.0);
    assert_eq!(
        parse(&scene.to_string()).expect_err("refused").path,
        "materials.steel.density"
    );
    scene["materials"]["steel"]
        .as_object_mut()
        .expect("object")
        .remove("density");
    assert_eq!(
        parse(&scene.to_string()).expect_err("refused").path,
        "materials.steel.density"
    );
    scene["materials"]["steel"]["density"] = json!(RHO);
    // A receiver's peak velocity: the receiver must exist, be named in `receiver` (not
    // `region`), and only `peak_velocity` reads one.
    for (defined, path) in [
        (
            json!({"name": "v", "receiver": "nowhere", "quantity": "peak_velocity"}),
            "criteria.defined[0].receiver",
        ),
        (
            json!({"name": "v", "quantity": "peak_velocity"}),
            "criteria.defined[0].receiver",
        ),
        (
            json!({"name": "v", "region": "tip", "quantity": "peak_velocity"}),
            "criteria.defined[0].region",
        ),
        (
            json!({"name": "v", "receiver": "tip", "quantity": "sigma_xx"}),
            "criteria.defined[0].receiver",
        ),
    ] {
        scene["criteria"]["defined"] = json!([defined]);
        let err = parse(&scene.to_string()).expect_err("refused");
        assert_eq!(err.path, path, "{err}");
    }
    scene["criteria"]["defined"] =
        json!([{"name": "v", "receiver": "tip", "quantity": "peak_velocity"}]);
    parse(&scene.to_string()).expect("a receiver's peak velocity in a dynamic scene");
    let mut static_scene = scene.clone();
    static_scene
        .as_object_mut()
        .expect("object")
        .remove("dynamics");
    static_scene
        .as_object_mut()
        .expect("object")
        .remove("receivers");
    static_scene["boundary"][3]
        .as_object_mut()
        .expect("object")
        .remove("time_function");
    assert_eq!(
        parse(&static_scene.to_string()).expect_err("refused").path,
        "criteria.defined[0].quantity"
    );
    scene["criteria"]
        .as_object_mut()
        .expect("object")
        .remove("defined");
    scene["boundary"][0]["time_function"] = json!({"ricker": {"frequency": 1.0, "delay": 0.0}});
    assert_eq!(
        parse(&scene.to_string()).expect_err("refused").path,
        "boundary[0].time_function"
    );
    scene["boundary"][0]
        .as_object_mut()
        .expect("object")
        .remove("time_function");
    scene["boundary"][3]["time_function"] =
        json!({"table": {"times": [0.0, 0.0], "values": [1.0, 0.0]}});
    assert_eq!(
        parse(&scene.to_string()).expect_err("refused").path,
        "boundary[3].time_function.table.times[1]"
    );
    scene["boundary"][3]["time_function"] = json!({"table": {"times": [0.0], "values": [1.0]}});
    scene["receivers"][0]["point"] = json!([2.0, 0.0]);
    let p = problem(&scene);
    let err = simulate(&p, &p.nominal).expect_err("outside");
    assert!(err.to_string().contains("receivers[0].point"), "{err}");
    scene.as_object_mut().expect("object").remove("dynamics");
    assert_eq!(
        parse(&scene.to_string()).expect_err("refused").path,
        "boundary[3].time_function"
    );
}

/// Density of [`pushed_block`] \[kg/m³\].
pub(super) const PUSHED_RHO: f64 = 2500.0;
/// The Tresca slip limit g of [`pushed_block`]'s joint \[Pa\].
pub(super) const PUSHED_SLIP_LIMIT: f64 = 2e4;

/// A 0.5 × 0.25 m block on a clamped base, joint with slip limit g, pushed on its left side by
/// `push` ramped in over 4 ms; 10 ms in steps of 50 µs (newmark).
pub(super) fn pushed_block(push: f64) -> Value {
    let (rho, g_limit) = (PUSHED_RHO, PUSHED_SLIP_LIMIT);
    json!({
        "version": 1,
        "bodies": [
            {"name": "base", "zones": [{"name": "base", "material": "rock",
                "polygon": [[0, 0], [1, 0], [1, 0.25], [0, 0.25]]}]},
            {"name": "block", "zones": [{"name": "block", "material": "rock",
                "polygon": [[0.25, 0.25], [0.75, 0.25], [0.75, 0.5], [0.25, 0.5]]}]}
        ],
        "segments": {
            "bottom": {"body": "base", "from": [0, 0], "to": [1, 0]},
            "base_top": {"body": "base", "from": [0.25, 0.25], "to": [0.75, 0.25]},
            "block_bottom": {"body": "block", "from": [0.25, 0.25], "to": [0.75, 0.25]},
            "push": {"body": "block", "from": [0.25, 0.5], "to": [0.25, 0.25]}
        },
        "materials": {"rock": {"E": 1e10, "nu": 0.25, "density": rho,
            "specific_weight": 245000.0}},
        "boundary": [
            {"segment": "bottom", "displacement": [0, 0]},
            {"segment": "push", "traction": [push, 0],
             "time_function": {"table": {"times": [0.0, 0.004], "values": [0.0, 1.0]}}}
        ],
        "contacts": [{"name": "joint", "between": ["block_bottom", "base_top"],
            "slip_limit": g_limit}],
        "mesh": {"max_size": 0.0625},
        "receivers": [{"name": "centre", "point": [0.5, 0.375]}],
        "dynamics": {"t_end": 0.01, "dt": 5e-5, "scheme": "newmark"}
    })
}

/// A block pushed along a clamped base against a Tresca slip limit g: it sticks while the push
/// Q h stays below g ℓ, and slides with acceleration (Q h − g ℓ)/m beyond (friction on each
/// step's slip, bound g w). A body force ten times the weight keeps the block flat (with its
/// weight alone the push on its side would tip it over).
#[test]
fn pushed_block_sticks_below_and_slides_at_the_predicted_acceleration_above() {
    let (rho, g_limit) = (PUSHED_RHO, PUSHED_SLIP_LIMIT);
    let (height, length) = (0.25, 0.5);
    let scene = pushed_block;
    let mass = rho * height * length;
    for push in [1e5, 3e4] {
        let run = run(&scene(push));
        let h = &run.history;
        let u: Vec<f64> = h.receivers["centre"]
            .displacement
            .iter()
            .map(|u| u[0])
            .collect();
        let n = u.len() - 1;
        // The push is ramped in over 4 ms (quasi-static: no dynamic overshoot of the friction
        // force); the acceleration over the second half, from u at T/2, 3T/4 and T (the elastic
        // ringing is far below ½ a t²).
        let quarter = (h.times[n] - h.times[n / 2]) / 2.0;
        let a = (u[n] - 2.0 * u[3 * n / 4] + u[n / 2]) / (quarter * quarter);
        let drive = push * height - g_limit * length;
        let zone = &h.contact_zones["joint"];
        let expected = drive.max(0.0) / mass;
        eprintln!(
            "pushed block, Q = {push:e} Pa: a = {a:.5} m/s² vs max(Q h − g ℓ, 0)/m = {expected:.5}"
        );
        if drive < 0.0 {
            // Stuck, the block only deforms elastically (~1e-5 m) and rings: no mean
            // acceleration (below 2 % of the push's Q h / m).
            let late = u[n / 2..].iter().fold(0.0_f64, |m, x| m.max(x.abs()));
            eprintln!("pushed block, stuck: peak |u| {late:.3e} m over the second half");
            assert!(
                late < 1e-4 && a.abs() < 0.02 * push * height / mass,
                "the block moves: {late:e} m, a = {a:e}"
            );
        } else {
            assert!(
                (a - expected).abs() < 0.02 * expected,
                "a = {a}, expected {expected}"
            );
            assert_eq!(zone.stick[n], 0, "every pair slips");
        }
    }
}
