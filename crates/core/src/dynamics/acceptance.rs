//! Acceptance tests of the dynamic solver (design §3.5, docs/verification.md "Dynamics"): wave
//! speeds, the bar impact (uses `initial_velocity`), energy over 10⁴ steps with contact, the
//! static limit of a damped run, slip-rate-dependent friction, point loads as exact P1 loads,
//! and the refusals of bad input. Every run goes through `tests::checked` (PDAS terminates on
//! every step and equals the QP kernel's step to 1e-10).

use std::time::Instant;

use serde_json::{json, Value};

use super::tests::{checked, problem, pushed_block, run, PUSHED_RHO};
use super::{static_start, DynamicRun};
use crate::scene::parse;
use crate::state::StateProblem;

/// A strip [0, length] × [0, 0.05] (E = 1 GPa, ρ = 1000 kg/m³, `nu`), the right end clamped,
/// the left end loaded by `traction` × a Ricker pulse (1 kHz, peak at 1.5 ms), the long sides
/// held by `sides`; receivers at x = 0.5 and 1.5.
fn strip(nu: f64, sides: Value, traction: [f64; 2], t_end: f64) -> Value {
    json!({
        "version": 1,
        "bodies": [{"name": "strip", "zones": [{"name": "strip", "material": "m",
            "polygon": [[0, 0], [2.5, 0], [2.5, 0.05], [0, 0.05]]}]}],
        "segments": {
            "left": {"body": "strip", "from": [0, 0.05], "to": [0, 0]},
            "bottom": {"body": "strip", "from": [0, 0], "to": [2.5, 0]},
            "right": {"body": "strip", "from": [2.5, 0], "to": [2.5, 0.05]},
            "top": {"body": "strip", "from": [2.5, 0.05], "to": [0, 0.05]}
        },
        "materials": {"m": {"E": 1e9, "nu": nu, "density": 1000.0}},
        "boundary": [
            {"segment": "right", "displacement": [0, 0]},
            {"segment": "bottom", "displacement": sides.clone()},
            {"segment": "top", "displacement": sides},
            {"segment": "left", "traction": traction,
             "time_function": {"ricker": {"frequency": 1000.0, "delay": 1.5e-3}}}
        ],
        "mesh": {"max_size": 0.025},
        "receivers": [
            {"name": "near", "point": [0.5, 0.025]},
            {"name": "far", "point": [1.5, 0.025]}
        ],
        "dynamics": {"t_end": t_end, "dt": 5e-6, "scheme": "newmark"}
    })
}

/// Time of the largest |v_c| at a receiver (parabola through the peak sample and its
/// neighbours).
fn peak_time(run: &DynamicRun, receiver: &str, c: usize) -> f64 {
    let v: Vec<f64> = run.history.receivers[receiver]
        .velocity
        .iter()
        .map(|v| v[c].abs())
        .collect();
    let i = (1..v.len() - 1)
        .max_by(|&a, &b| v[a].total_cmp(&v[b]))
        .expect("samples");
    let t = &run.history.times;
    let (a, b, c) = (v[i - 1], v[i], v[i + 1]);
    t[i] + 0.5 * (t[i + 1] - t[i]) * (a - c) / (a - 2.0 * b + c)
}

/// A P pulse (uniaxial strain: rollers on the long sides) and an S pulse (u_x = 0 on the long
/// sides: pure shear) travel from x = 0.5 to 1.5 at √((λ+2μ)/ρ) and √(μ/ρ) within 2 %.
#[test]
fn p_and_s_waves_arrive_at_their_speeds() {
    let (e, nu, rho): (f64, f64, f64) = (1e9, 0.25, 1000.0);
    let mu = e / (2.0 * (1.0 + nu));
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let cases = [
        (
            "P",
            json!([null, 0]),
            [1e5, 0.0],
            0,
            ((lambda + 2.0 * mu) / rho).sqrt(),
        ),
        ("S", json!([0, null]), [0.0, 1e5], 1, (mu / rho).sqrt()),
    ];
    for (name, sides, traction, c, speed) in cases {
        let run = run(&strip(nu, sides, traction, 4.6e-3));
        let measured = 1.0 / (peak_time(&run, "far", c) - peak_time(&run, "near", c));
        let error = measured / speed - 1.0;
        eprintln!(
            "{name} wave: {measured:.2} m/s vs {speed:.2} m/s ({:+.3} %)",
            100.0 * error
        );
        assert!(error.abs() < 0.02, "{name}: {measured} vs {speed}");
    }
}

/// Point loads at the three nodes of the loaded end with the traction's consistent nodal
/// forces (h/4, h/2, h/4 times the traction) give the traction's run to rounding: the point
/// load is the exact P1 load.
#[test]
fn point_loads_are_exact_p1_loads() {
    let sides = json!([null, 0]);
    let traction = strip(0.25, sides.clone(), [1e5, 0.0], 1e-3);
    let mut points = strip(0.25, sides, [0.0, 0.0], 1e-3);
    let pulse = json!({"ricker": {"frequency": 1000.0, "delay": 1.5e-3}});
    points["point_loads"] = json!([
        {"point": [0.0, 0.0], "force": [1250.0, 0.0], "time_function": pulse},
        {"point": [0.0, 0.025], "force": [2500.0, 0.0], "time_function": pulse},
        {"point": [0.0, 0.05], "force": [1250.0, 0.0], "time_function": pulse}
    ]);
    let (a, b) = (run(&traction), run(&points));
    let u = |r: &DynamicRun| r.history.receivers["near"].displacement.clone();
    let (ua, ub) = (u(&a), u(&b));
    let scale = ua.iter().fold(0.0_f64, |m, v| m.max(v[0].abs()));
    let worst = ua
        .iter()
        .zip(&ub)
        .fold(0.0_f64, |m, (p, q)| m.max((p[0] - q[0]).abs()));
    eprintln!(
        "point loads vs traction: max difference {:.2e} of the peak",
        worst / scale
    );
    assert!(
        scale > 0.0 && worst <= 1e-10 * scale,
        "{worst:e} of {scale:e}"
    );
}

/// A bar [0, 1] × [0, 0.05] (ν = 0, rollers on its long sides, E = 1 GPa, ρ = 1000 kg/m³:
/// c = 1000 m/s) at v0 = 1 m/s against a clamped wall; `gaps` the initial gaps at the right
/// (and, if given, a second wall at the left).
fn bar_impact(h: f64, dt: f64, t_end: f64, gaps: (f64, Option<f64>)) -> Value {
    let gap = |g: f64| json!({"piecewise_linear": {"knots": [0, 1], "values": [g, g]}});
    let mut scene = json!({
        "version": 1,
        "bodies": [
            {"name": "bar", "zones": [{"name": "bar", "material": "m",
                "polygon": [[0, 0], [1, 0], [1, 0.05], [0, 0.05]]}],
             "initial_velocity": [1.0, 0.0]},
            {"name": "wall", "zones": [{"name": "wall", "material": "m",
                "polygon": [[1, 0], [1.1, 0], [1.1, 0.05], [1, 0.05]]}]}
        ],
        "segments": {
            "bar_bottom": {"body": "bar", "from": [0, 0], "to": [1, 0]},
            "bar_top": {"body": "bar", "from": [1, 0.05], "to": [0, 0.05]},
            "bar_end": {"body": "bar", "from": [1, 0], "to": [1, 0.05]},
            "wall_face": {"body": "wall", "from": [1, 0.05], "to": [1, 0]},
            "wall_back": {"body": "wall", "from": [1.1, 0], "to": [1.1, 0.05]}
        },
        "materials": {"m": {"E": 1e9, "nu": 0.0, "density": 1000.0}},
        "boundary": [
            {"segment": "bar_bottom", "roller": {}},
            {"segment": "bar_top", "roller": {}},
            {"segment": "wall_face", "displacement": [0, 0]},
            {"segment": "wall_back", "displacement": [0, 0]}
        ],
        "contacts": [{"name": "impact", "between": ["bar_end", "wall_face"],
            "slip_limit": 0.0, "initial_gap": gap(gaps.0)}],
        "mesh": {"max_size": h},
        "dynamics": {"t_end": t_end, "dt": dt, "scheme": "newmark"}
    });
    if let Some(left) = gaps.1 {
        scene["bodies"].as_array_mut().expect("bodies").push(json!(
            {"name": "left_wall", "zones": [{"name": "left_wall", "material": "m",
                "polygon": [[-0.1, 0], [0, 0], [0, 0.05], [-0.1, 0.05]]}]}));
        let segments = scene["segments"].as_object_mut().expect("segments");
        segments.insert(
            "bar_start".into(),
            json!({"body": "bar", "from": [0, 0.05], "to": [0, 0]}),
        );
        segments.insert(
            "left_face".into(),
            json!({"body": "left_wall", "from": [0, 0], "to": [0, 0.05]}),
        );
        segments.insert(
            "left_back".into(),
            json!({"body": "left_wall", "from": [-0.1, 0.05], "to": [-0.1, 0]}),
        );
        let boundary = scene["boundary"].as_array_mut().expect("boundary");
        boundary.push(json!({"segment": "left_face", "displacement": [0, 0]}));
        boundary.push(json!({"segment": "left_back", "displacement": [0, 0]}));
        scene["contacts"]
            .as_array_mut()
            .expect("contacts")
            .push(json!(
            {"name": "rebound", "between": ["bar_start", "left_face"],
             "slip_limit": 0.0, "initial_gap": gap(left)}));
    }
    scene
}

/// ∫ ρ v_x over the bar / its mass: the bar's mean velocity (P1: each triangle's mean of its
/// nodal values).
fn bar_velocity(p: &StateProblem, run: &DynamicRun) -> f64 {
    let mesh = p.elastic.mesh();
    let (mut momentum, mut area) = (0.0, 0.0);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if mesh.node_body[tri[0]] != 0 {
            continue;
        }
        let a = mesh.triangle_area(t);
        momentum += a * tri.iter().map(|&n| run.velocity[n][0]).sum::<f64>() / 3.0;
        area += a;
    }
    momentum / area
}

/// The bar impact: contact for 2L/c = 2 ms, contact stress ρ c v0 = 1 MPa, the bar leaves at
/// −v0; within 3 % at h = L/80, Δt = h/c, and every error smaller at h = L/160.
#[test]
fn bar_impact_lasts_2l_over_c_at_rho_c_v0_and_rebounds_at_v0() {
    let errors = |h: f64| {
        let dt = h / 1000.0;
        let p = problem(&bar_impact(h, dt, 3e-3, (0.0, None)));
        let run = checked(&p);
        let force = &run.history.contact_zones["impact"].normal_force;
        let touching: Vec<usize> = (0..force.len()).filter(|&i| force[i] > 0.0).collect();
        let duration = touching.len() as f64 * dt;
        let (first, last) = (touching[0], touching[touching.len() - 1]);
        let middle = &force[first + (last - first) / 4..=first + 3 * (last - first) / 4];
        let stress = middle.iter().sum::<f64>() / middle.len() as f64 / 0.05;
        let v = bar_velocity(&p, &run);
        let e = [duration / 2e-3 - 1.0, stress / 1e6 - 1.0, -v - 1.0];
        eprintln!(
            "bar impact h = {h}: contact {duration:.4e} s, stress {stress:.4e} Pa, exit velocity \
             {v:.4} m/s; relative errors {:+.3e} {:+.3e} {:+.3e}",
            e[0], e[1], e[2]
        );
        e
    };
    let (coarse, fine) = (errors(1.0 / 80.0), errors(1.0 / 160.0));
    for (c, f) in coarse.iter().zip(&fine) {
        assert!(c.abs() < 0.03, "{coarse:?}");
        assert!(
            f.abs() <= c.abs() + 1e-3,
            "not converging: {coarse:?} then {fine:?}"
        );
    }
}

/// Frictionless, no damping, no load: a bar bouncing between two clamped walls (gaps 0.5 mm)
/// for 10⁴ Newmark steps; kinetic + strain energy never increases.
#[test]
fn energy_never_increases_over_ten_thousand_steps_of_impacts() {
    let started = Instant::now();
    let run = run(&bar_impact(0.05, 2e-5, 0.2, (5e-4, Some(5e-4))));
    let e = &run.history.energy;
    let total: Vec<f64> = e
        .kinetic
        .iter()
        .zip(&e.strain)
        .map(|(k, s)| k + s)
        .collect();
    let impacts = run.history.contact_zones["impact"]
        .normal_force
        .windows(2)
        .filter(|w| w[0] == 0.0 && w[1] > 0.0)
        .count();
    eprintln!(
        "energy over {} steps: {impacts} impacts on the right wall, energy {:.4e} → {:.4e} J/m, \
         {:.1} s",
        run.history.report.steps,
        total[0],
        total[total.len() - 1],
        started.elapsed().as_secs_f64()
    );
    assert_eq!(run.history.report.steps, 10_000);
    assert!(impacts >= 10, "only {impacts} impacts");
    for i in 1..total.len() {
        assert!(
            total[i] <= total[i - 1] * (1.0 + 1e-12),
            "energy grew at step {i}: {} → {}",
            total[i - 1],
            total[i]
        );
    }
}

/// A block pressed onto a clamped base by ten times its weight, held along x at its top,
/// frictionless contact, Kelvin–Voigt damping: from rest under the constant load both schemes
/// converge to the static contact solution of the scene to 1e-8.
#[test]
fn damped_run_converges_to_the_static_contact_solution() {
    for scheme in ["newmark", "paper"] {
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
                "block_bottom": {"body": "block", "from": [0.25, 0.25], "to": [0.75, 0.25]},
                "block_top": {"body": "block", "from": [0.75, 0.5], "to": [0.25, 0.5]}
            },
            "materials": {"rock": {"E": 1e10, "nu": 0.25, "density": 2500.0,
                "specific_weight": 245000.0, "viscosity": 2.5e-4}},
            "boundary": [
                {"segment": "bottom", "displacement": [0, 0]},
                {"segment": "block_top", "displacement": [0, null]}
            ],
            "contacts": [{"name": "joint", "between": ["block_bottom", "base_top"],
                "slip_limit": 0.0}],
            "mesh": {"max_size": 0.0625},
            "dynamics": {"t_end": 0.1, "dt": 1e-4, "scheme": scheme, "output_every": 100}
        });
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
            .fold(0.0_f64, |m, (a, b)| {
                m.max((a[0] - b[0]).abs()).max((a[1] - b[1]).abs())
            });
        eprintln!(
            "static limit {scheme}: {:.2e} of the static displacement",
            worst / scale
        );
        assert!(worst <= 1e-8 * scale, "{scheme}: {worst:e} of {scale:e}");
    }
}

/// Slip-rate-dependent Coulomb friction (F_s = 0.6, F_k = 0.4, v_c = 1 cm/s), started from
/// the static solution: a push between F_k N and F_s N holds (static friction), one above F_s N
/// slides at (Q h − F_k N)/m within 2 % (kinetic friction).
#[test]
fn static_friction_holds_and_kinetic_friction_drives_the_slide() {
    let (rho, weight) = (PUSHED_RHO, 245000.0);
    let (height, length) = (0.25, 0.5);
    let (f_s, f_k) = (0.6, 0.4);
    // The pushed block of `tests`, its joint Coulomb with a slip-rate-dependent coefficient,
    // started from its static solution.
    let scene = |push: f64| {
        let mut scene = pushed_block(push);
        scene["contacts"][0] = json!({"name": "joint", "between": ["block_bottom", "base_top"],
            "friction_coefficient": f_s, "friction_kinetic": f_k, "slip_rate_scale": 1e-2});
        scene["dynamics"]["initial"] = json!("static");
        scene
    };
    let mass = rho * height * length;
    let normal = weight * height * length;
    // Q h = 0.5 N (between F_k N and F_s N) and 1.0 N.
    for push in [0.5 * normal / height, normal / height] {
        let run = run(&scene(push));
        let h = &run.history;
        let u: Vec<f64> = h.receivers["centre"]
            .displacement
            .iter()
            .map(|u| u[0])
            .collect();
        let n = u.len() - 1;
        let quarter = (h.times[n] - h.times[n / 2]) / 2.0;
        let a = (u[n] - 2.0 * u[3 * n / 4] + u[n / 2]) / (quarter * quarter);
        let drive = push * height - f_k * normal;
        eprintln!(
            "slip-rate friction, Q h = {:.3} N: a = {a:.4} m/s² (kinetic prediction {:.4})",
            push * height / normal,
            drive / mass
        );
        if push * height < f_s * normal {
            let late = u[n / 2..].iter().fold(0.0_f64, |m, x| m.max(x.abs()));
            assert!(
                late < 1e-4 && a.abs() < 0.02 * push * height / mass,
                "the block moves: {late:e} m, a = {a:e}"
            );
        } else {
            let expected = drive / mass;
            assert!(
                (a - expected).abs() < 0.02 * expected,
                "a = {a}, expected {expected}"
            );
        }
    }
}

/// Bad input of the new fields is refused naming the field; 10⁸ steps are refused in
/// milliseconds; a static start that has no solution is refused naming `dynamics.initial`.
#[test]
fn bad_input_of_the_new_fields_names_the_field() {
    let base = bar_impact(0.05, 1e-5, 1e-4, (0.0, None));
    let refused = |scene: &Value| parse(&scene.to_string()).expect_err("refused").path;
    let mut s = base.clone();
    s["dynamics"] = json!({"t_end": 100.0, "dt": 1e-6});
    let started = Instant::now();
    assert_eq!(refused(&s), "dynamics.dt");
    let seconds = started.elapsed().as_secs_f64();
    eprintln!("10⁸ steps refused in {:.2} ms", 1e3 * seconds);
    assert!(seconds < 1.0);
    let mut s = base.clone();
    s.as_object_mut().expect("scene").remove("dynamics");
    assert_eq!(refused(&s), "bodies[0].initial_velocity");
    s["bodies"][0]
        .as_object_mut()
        .expect("body")
        .remove("initial_velocity");
    s["point_loads"] = json!([{"point": [0.5, 0.02], "force": [1, 0]}]);
    assert_eq!(refused(&s), "point_loads[0]");
    let mut s = base.clone();
    s["point_loads"] = json!([{"point": [0.5, 0.02], "force": [1, 0],
        "time_function": {"table": {"times": [1.0, 0.0], "values": [1.0, 0.0]}}}]);
    assert_eq!(refused(&s), "point_loads[0].time_function.table.times[1]");
    s["point_loads"] = json!([{"point": [5.0, 0.02], "force": [1, 0]}]);
    let p = problem(&s);
    let err = super::simulate(&p, &p.nominal).expect_err("outside");
    assert!(err.to_string().contains("point_loads[0].point"), "{err}");
    let mut s = base.clone();
    s["contacts"][0]["friction_kinetic"] = json!(0.3);
    assert_eq!(refused(&s), "contacts[0].slip_rate_scale");
    s["contacts"][0]["slip_rate_scale"] = json!(1e-3);
    assert_eq!(refused(&s), "contacts[0].friction_kinetic");
    s["contacts"][0]["slip_limit"] = json!(0.0);
    s["contacts"][0]["friction_coefficient"] = json!(0.5);
    s["contacts"][0]["slip_rate_scale"] = json!(0.0);
    assert_eq!(refused(&s), "contacts[0].slip_rate_scale");
    // The block of block-on-base pushed far beyond its friction limit cannot stand still.
    let mut s: Value =
        serde_json::from_str(crate::bundled::find("block-on-base").expect("bundled"))
            .expect("json");
    s["materials"]["rock"]["density"] = json!(2500.0);
    s["uncertain"] = json!([]);
    s["search"] = json!({});
    s["boundary"][2]["traction"] = json!([4e6, 0]);
    s["dynamics"] = json!({"t_end": 1e-3, "dt": 1e-4, "initial": "static"});
    let p = problem(&s);
    let err = super::simulate(&p, &p.nominal).expect_err("infeasible");
    eprintln!("infeasible static start: {err}");
    assert!(err.to_string().contains("dynamics.initial"), "{err}");
}

/// `contact_solver: "qp"` runs the QP kernel alone: the same history as PDAS to 1e-10.
#[test]
fn the_qp_solver_gives_the_pdas_run() {
    let scene = bar_impact(0.025, 2.5e-5, 3e-3, (0.0, None));
    let pdas = run(&scene);
    let mut qp = scene.clone();
    qp["dynamics"]["contact_solver"] = json!("qp");
    let qp = run(&qp);
    assert!(qp.history.report.qp_iterations > 0);
    let (a, b) = (
        &pdas.history.contact_zones["impact"].normal_force,
        &qp.history.contact_zones["impact"].normal_force,
    );
    let scale = a.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let worst = a
        .iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
    eprintln!(
        "qp vs pdas: normal force histories differ by {:.2e}; iterations {} vs {}",
        worst / scale,
        pdas.history.report.qp_iterations,
        qp.history.report.qp_iterations
    );
    assert!(worst <= 1e-10 * scale);
}
