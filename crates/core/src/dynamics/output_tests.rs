//! The outputs of a dynamic run (design §3.5, "Outputs") against closed forms and
//! independent readings: a block sliding against a Tresca slip limit (its mean velocity is its
//! momentum, the discrete momentum balance to rounding and the rigid-slide closed form; slip,
//! slip rate and the friction dissipation g ℓ × slip), the energy split of a viscous bar and of a
//! bar in an absorbing layer, the peak-over-time fields against the maxima over every step's
//! state, the progress reports and the cancel flag, and the VTU series (every output time
//! decoded back).

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};

use serde_json::{json, Value};

use super::tests::{bar, problem, pushed_block, run, PUSHED_RHO, PUSHED_SLIP_LIMIT};
use super::{simulate_with, Frame, Hooks};
use crate::error::WsmError;

/// The push of the sliding block \[Pa\]: Q h − g ℓ = 25 000 − 10 000 N/m drives it.
const PUSH: f64 = 1e5;
const HEIGHT: f64 = 0.25;
const LENGTH: f64 = 0.5;

/// The rigid block's slide under the ramped push Q(t) h = Q h min(t/τ, 1) (τ = 4 ms) against
/// g ℓ from rest: (velocity, displacement) at `t`, by integrating a = (Q(t) h − g ℓ)/m from
/// the onset t_s = τ g ℓ/(Q h).
fn rigid_slide(t: f64) -> (f64, f64) {
    let (tau, m) = (0.004, PUSHED_RHO * HEIGHT * LENGTH);
    let (qh, gl) = (PUSH * HEIGHT, PUSHED_SLIP_LIMIT * LENGTH);
    let ts = tau * gl / qh;
    // On the ramp a = k (s − t_s), k = Q h/(τ m); then a = (Q h − g ℓ)/m.
    let k = qh / (tau * m);
    let ramp = |s: f64| (0.5 * k * (s - ts).powi(2), k * (s - ts).powi(3) / 6.0);
    if t <= tau {
        ramp(t.max(ts))
    } else {
        let (v, x) = ramp(tau);
        let a = (qh - gl) / m;
        let d = t - tau;
        (v + a * d, x + v * d + 0.5 * a * d * d)
    }
}

#[test]
fn sliding_block_momentum_slip_and_friction_dissipation() {
    let scene = pushed_block(PUSH);
    let run = run(&scene);
    let h = &run.history;
    let (dt, n) = (5e-5, h.times.len() - 1);
    let mass = PUSHED_RHO * HEIGHT * LENGTH;
    let mean = &h.bodies["block"].mean_velocity;
    let zone = &h.contact_zones["joint"];
    // Discrete momentum balance in x (every step is an output): M(v_{n+1} − v_n) = Δt (b̄ − K ū
    // − Bᵀλ), summed over the block's nodes (K's rows sum to 0 along a translation): m v̄ =
    // Σ Δt (Q̄ h − T) with T the zone's tangential resultant (along t = +x here).
    let push = |t: f64| PUSH * HEIGHT * (t / 0.004).min(1.0);
    let mut impulse = 0.0;
    let mut worst: f64 = 0.0;
    for (k, step) in h.times.windows(2).enumerate() {
        impulse += dt * (0.5 * (push(step[0]) + push(step[1])) - zone.tangential_force[k + 1]);
        worst = worst.max((mass * mean[k + 1][0] - impulse).abs());
    }
    let (v_rigid, x_rigid) = rigid_slide(h.times[n]);
    let (v, slip, rate, friction) = (
        mean[n][0],
        zone.max_slip[n],
        zone.max_slip_rate[n],
        h.energy.friction[n],
    );
    let gl = PUSHED_SLIP_LIMIT * LENGTH;
    eprintln!(
        "sliding block at {:.3} ms: mean velocity {v:.5} m/s (rigid slide {v_rigid:.5}), momentum \
         balance |m v̄ − Σ Δt (Q̄h − T)| ≤ {worst:.2e} N s/m; max slip {slip:.5e} m (rigid \
         {x_rigid:.5e}), max slip rate {rate:.5} m/s; friction dissipation {friction:.5} J/m vs \
         g ℓ × slip {:.5}; contact {:.2e}, numerical {:.2e}",
        1e3 * h.times[n],
        gl * slip,
        h.energy.contact[n],
        h.energy.numerical[n],
    );
    assert!(worst <= 1e-9 * mass * v_rigid, "momentum balance {worst:e}");
    // The rigid slide's closed form holds for the elastic block to its strain and ringing at the
    // onset (1.2 % in v̄, 2.8 % in the slip at this resolution).
    assert!((v - v_rigid).abs() < 0.02 * v_rigid, "v̄ = {v}, {v_rigid}");
    assert!(mean[n][1].abs() < 0.01 * v_rigid, "v̄_y = {}", mean[n][1]);
    assert!(
        (slip - x_rigid).abs() < 0.04 * x_rigid,
        "slip {slip}, {x_rigid}"
    );
    assert!((rate - v).abs() < 0.03 * v, "slip rate {rate}");
    // Every pair slips at the bound g w: friction work g ℓ × slip (the pairs' slips differ by
    // the block's elastic strain only).
    assert!(
        (friction - gl * slip).abs() < 0.02 * gl * slip,
        "friction {friction}"
    );
    // Friction dissipates every step; the split leaves newmark's balance exact.
    let e = &h.energy;
    for i in 1..=n {
        assert!(e.friction[i] >= e.friction[i - 1] - 1e-12 * friction);
        assert!(
            e.numerical[i].abs() <= 1e-9 * e.work[n],
            "balance {}",
            e.numerical[i]
        );
        assert_eq!((e.viscous[i], e.absorbing[i]), (0.0, 0.0));
    }
}

/// A bar: Kelvin–Voigt viscosity dissipates as `viscous`, an absorbing layer as `absorbing`;
/// each is zero without its cause, and newmark's balance holds with the split.
#[test]
fn viscous_and_absorbing_dissipation_are_split() {
    let dynamics = json!({"t_end": 2e-3, "dt": 1e-5, "scheme": "newmark"});
    let ricker = json!({"ricker": {"frequency": 2000.0, "delay": 6e-4}});
    let viscous = bar(1e6, ricker.clone(), dynamics.clone(), 2e-6);
    let mut absorbing = bar(1e6, ricker, dynamics, 0.0);
    absorbing["absorbing"] = json!([{"segments": ["left"], "thickness": 0.3, "damping": 2e6}]);
    for (scene, name) in [(viscous, "viscous"), (absorbing, "absorbing")] {
        let run = run(&scene);
        let e = &run.history.energy;
        let n = e.work.len() - 1;
        let scale = e.work.iter().fold(0.0_f64, |m, w| m.max(w.abs()));
        let (own, other) = if name == "viscous" {
            (&e.viscous, &e.absorbing)
        } else {
            (&e.absorbing, &e.viscous)
        };
        eprintln!(
            "{name} bar: viscous {:.4e}, absorbing {:.4e} of peak work {scale:.4e} J/m, \
             |numerical| ≤ {:.2e}",
            e.viscous[n],
            e.absorbing[n],
            e.numerical.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
        );
        assert!(own[n] > 0.01 * scale, "{name}: {} of {scale}", own[n]);
        assert!(other.iter().all(|&x| x == 0.0), "{name}: the other term");
        for i in 1..=n {
            assert!(own[i] >= own[i - 1], "{name} dissipation decreased");
            assert!(
                e.numerical[i].abs() <= 1e-9 * scale,
                "balance {}",
                e.numerical[i]
            );
        }
    }
}

/// The peak fields and their summary equal the maxima over every step's state as the frames
/// show it (output every step), and each frame's peaks bound its own state.
#[test]
fn peaks_are_the_maxima_over_every_step() {
    let scene = pushed_block(PUSH);
    let p = problem(&scene);
    let geometry = &p.contact.geometry;
    let mesh = p.mesh();
    let seen = RefCell::new((
        vec![0.0_f64; mesh.nodes.len()],
        vec![0.0_f64; mesh.triangles.len()],
        vec![0.0_f64; geometry.pairs.len()],
        Vec::new(),
    ));
    let mut frames = |f: &Frame| -> Result<(), WsmError> {
        let mut s = seen.borrow_mut();
        for (k, u) in f.displacement.iter().enumerate() {
            let norm = u[0].hypot(u[1]);
            assert!(f.peaks.displacement[k] >= norm);
            s.0[k] = s.0[k].max(norm);
        }
        for (k, e) in f.stresses.iter().enumerate() {
            assert!(f.peaks.i2_squared[k] >= e.i2_squared());
            s.1[k] = s.1[k].max(e.i2_squared());
        }
        for (m, pair) in geometry.pairs.iter().enumerate() {
            let pressure = f.forces[2 * m] / pair.weight;
            assert!(f.peaks.contact_pressure[m] >= pressure);
            s.2[m] = s.2[m].max(pressure);
        }
        s.3.push(f.t);
        Ok(())
    };
    let run = simulate_with(
        &p,
        &p.nominal,
        &mut Hooks {
            frames: Some(&mut frames),
            ..Hooks::default()
        },
    )
    .expect("run");
    let (u, i2, pressure, times) = seen.into_inner();
    assert_eq!(times, run.history.times, "a frame per output time");
    assert_eq!(run.peaks.displacement, u);
    assert_eq!(run.peaks.i2_squared, i2);
    assert_eq!(run.peaks.contact_pressure, pressure);
    let s = &run.history.peaks;
    let largest = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(*x));
    assert_eq!(s.displacement.value, largest(&u));
    assert_eq!(s.i2_squared.value, largest(&i2));
    assert_eq!(s.contact_pressure.value, largest(&pressure));
    assert!(times.contains(&s.contact_pressure.time));
    // The block slides away: the largest displacement is at the end, on the block.
    assert_eq!(s.displacement.time, *times.last().expect("times"));
    assert!(
        s.displacement.point[1] >= 0.25,
        "{:?}",
        s.displacement.point
    );
    eprintln!(
        "peaks: |u| {:.4e} m at t = {:.2e} s, I2² {:.4e} Pa² at {:?}, contact pressure {:.4e} \
         Pa at t = {:.2e} s",
        s.displacement.value,
        s.displacement.time,
        s.i2_squared.value,
        s.i2_squared.point,
        s.contact_pressure.value,
        s.contact_pressure.time
    );
}

/// Progress reports every step (k of N); a raised cancel flag stops the run before the next
/// step with `Cancelled`.
#[test]
fn progress_reports_every_step_and_cancel_stops_the_run() {
    let scene = pushed_block(PUSH);
    let p = problem(&scene);
    let cancel = AtomicBool::new(false);
    let reports = RefCell::new(Vec::new());
    let progress = |step: usize, steps: usize| {
        reports.borrow_mut().push((step, steps));
        if step == 10 {
            cancel.store(true, Ordering::SeqCst);
        }
    };
    let outcome = simulate_with(
        &p,
        &p.nominal,
        &mut Hooks {
            cancel: Some(&cancel),
            progress: Some(&progress),
            frames: None,
        },
    );
    assert!(matches!(outcome, Err(WsmError::Cancelled)), "{outcome:?}");
    let expected: Vec<(usize, usize)> = (1..=10).map(|k| (k, 200)).collect();
    assert_eq!(*reports.borrow(), expected);
}

/// `run::solve_watched` writes one VTU per output time: every document decodes, with the
/// displacement, velocity and peak arrays of its time, and the series' index lists the times.
#[test]
fn vtu_series_has_every_output_time() {
    use crate::output::vtu::tests::decoded;
    use crate::run::{solve_watched, write_pvd, RunControl, SeriesEntry, SolveRequest};
    let mut scene: Value = pushed_block(PUSH);
    scene["dynamics"]["output_every"] = json!(50);
    let scene = crate::scene::parse(&scene.to_string()).expect("scene");
    let mut files = Vec::new();
    let mut sink = |index: usize, t: f64, text: String| -> Result<(), WsmError> {
        files.push((index, t, text));
        Ok(())
    };
    let output = solve_watched(
        scene,
        None,
        &SolveRequest::default(),
        &RunControl::new(),
        Some(&mut sink),
    )
    .expect("solve");
    let history = output.summary.history.expect("history");
    assert_eq!(files.len(), 5, "t = 0 and every 50th of 200 steps");
    let p = problem(&pushed_block(PUSH));
    let points = p.mesh().nodes.len();
    for (k, (index, t, text)) in files.iter().enumerate() {
        assert_eq!((*index, *t), (k, history.times[k]));
        let (_, scenario) = decoded(text, "scenario");
        assert_eq!(
            String::from_utf8(scenario).expect("UTF-8"),
            format!("nominal at t = {t:e} s")
        );
        for (name, components) in [
            ("displacement", 3),
            ("velocity", 3),
            ("peak_displacement", 1),
        ] {
            let (bytes, payload) = decoded(text, name);
            assert_eq!(bytes as usize, payload.len());
            // The mesh nodes and the contact lines' midpoints.
            assert!(payload.len() >= 8 * components * points, "{name}");
        }
        for name in [
            "peak_i2_squared",
            "peak_contact_pressure",
            "contact_pressure",
        ] {
            let (bytes, payload) = decoded(text, name);
            assert_eq!(bytes as usize, payload.len(), "{name}");
        }
        // The receiver's velocity in the history is the P1 interpolation of the nodal one.
        let (_, v) = decoded(text, "velocity");
        let vx: Vec<f64> = v
            .chunks(8)
            .step_by(3)
            .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
            .collect();
        let fastest = vx.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let centre = history.receivers["centre"].velocity[k][0].abs();
        assert!(
            centre <= fastest * (1.0 + 1e-12) + 1e-300,
            "{centre} > {fastest}"
        );
    }
    let entries: Vec<SeriesEntry> = files
        .iter()
        .map(|(k, t, _)| SeriesEntry {
            file: format!("run-{k:05}.vtu"),
            title: format!("t = {t:e} s"),
            time: Some(*t),
        })
        .collect();
    let index = write_pvd(&entries);
    assert!(index.contains(&format!(
        "<DataSet timestep=\"{:e}\" group=\"\" part=\"0\" file=\"run-00004.vtu\"/>",
        history.times[4]
    )));
}
