//! Accuracy as a product output (design §6, issue 13): `wsm study accuracy` measures the orders
//! theory predicts (≈ 2 in L², ≈ 1 in energy for the smooth manufactured solution, ≈ 1 in energy
//! for the Lamé cylinder; Hertz errors shrinking with h) and DD rows equal to direct ones; the
//! accuracy statement of a worst-scenario result is deterministic, refines the mesh and stops
//! with the run.

use serde_json::{json, Value};
use wsm_core::{parse_scene, Criterion, Ladder, RunControl, Scene, Status, WorstRequest};
use wsm_study::accuracy::{run as study, AccuracyOptions, AccuracyStudy, Case, Reference};

fn options(coarsest: f64, ratio: f64, levels: usize, dd: Vec<f64>) -> AccuracyOptions {
    AccuracyOptions {
        ladder: Ladder::new(coarsest, ratio, levels).unwrap(),
        dd_tolerances: dd,
        repeats: 1,
        threads: 1,
    }
}

fn quantity(s: &AccuracyStudy, name: &str) -> usize {
    s.quantities.iter().position(|q| q.name == name).unwrap()
}

fn direct_errors(s: &AccuracyStudy, k: usize) -> Vec<f64> {
    s.rows
        .iter()
        .filter(|r| r.solver == "direct")
        .map(|r| r.errors[k].unwrap())
        .collect()
}

#[test]
fn manufactured_solution_converges_at_order_two_in_l2_and_one_in_energy() {
    // n = 8, 16, 32, 64 cells a side.
    let s = study(
        &Case::example("manufactured").unwrap(),
        &options(2.0, 2.0, 4, vec![1e-8]),
    )
    .unwrap();
    let (l2, energy) = (quantity(&s, "L2"), quantity(&s, "energy"));
    let p_l2 = s.quantities[l2].observed_order.unwrap();
    let p_energy = s.quantities[energy].observed_order.unwrap();
    assert!((1.85..2.2).contains(&p_l2), "L² order {p_l2}");
    assert!((0.9..1.15).contains(&p_energy), "energy order {p_energy}");
    let e = direct_errors(&s, l2);
    assert!(e.windows(2).all(|w| w[1] < w[0] / 3.0), "{e:?}");
    // The DD rows solve the same discrete problem.
    for pair in s.rows.chunks(2) {
        let (d, dd) = (&pair[0], &pair[1]);
        assert_eq!(
            (d.solver.as_str(), dd.solver.as_str()),
            ("direct", "dd 1e-8")
        );
        for k in [l2, energy] {
            let (a, b) = (d.errors[k].unwrap(), dd.errors[k].unwrap());
            assert!((a - b).abs() <= 1e-5 * a, "{a} vs {b}");
        }
    }
    let markdown = wsm_study::report::markdown(&s, "test");
    assert!(markdown.contains("| L² | exact field |"), "{markdown}");
    let csv = wsm_study::report::csv(&s).unwrap();
    assert_eq!(csv.lines().count(), 1 + s.rows.len());
    assert!(wsm_study::report::plot(&s).contains("<polyline"));
}

#[test]
fn lame_cylinder_energy_error_is_first_order_and_criteria_are_extrapolated() {
    let s = study(
        &Case::example("thick-cylinder").unwrap(),
        &options(2.0, std::f64::consts::SQRT_2, 5, vec![]),
    )
    .unwrap();
    let energy = quantity(&s, "energy");
    let p = s.quantities[energy].observed_order.unwrap();
    assert!((0.85..1.25).contains(&p), "energy order {p}");
    let phi3 = quantity(&s, "phi3");
    let Reference::Richardson(e) = &s.quantities[phi3].reference else {
        panic!("Φ3 has no exact value: {:?}", s.quantities[phi3]);
    };
    // Φ3 is a mean displacement: its extrapolated limit is the analytic mean (u_r < 0 of the
    // inward normal at the inner rim) to far better than the coarse error.
    let errors = direct_errors(&s, phi3);
    assert!(
        errors[errors.len() - 1] < errors[0] / 4.0,
        "{errors:?} ({e:?})"
    );
}

#[test]
fn hertz_errors_shrink_with_the_mesh() {
    let s = study(
        &Case::example("hertz").unwrap(),
        &options(2.0, std::f64::consts::SQRT_2, 4, vec![]),
    )
    .unwrap();
    for name in ["half_width", "peak_pressure"] {
        let k = quantity(&s, name);
        assert!(matches!(
            s.quantities[k].reference,
            Reference::Analytic { .. }
        ));
        let e = direct_errors(&s, k);
        assert!(e[3] < e[0] / 2.0, "{name}: {e:?}");
        assert!(e[3] < 0.01, "{name}: {e:?}");
    }
    let a = direct_errors(&s, quantity(&s, "half_width"));
    assert!(a.windows(2).all(|w| w[1] < w[0]), "half-width errors {a:?}");
}

/// The block pushed on a base with a coarse mesh.
fn block() -> Scene {
    let mut v: Value = serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    v["mesh"] = json!({ "max_size": 0.2 });
    parse_scene(&v.to_string()).unwrap()
}

fn request(threads: usize, refinements: Option<usize>) -> WorstRequest {
    WorstRequest {
        criteria: Some(vec![Criterion::Phi3.into(), Criterion::Phi6.into()]),
        budget: Some(40),
        seed: Some(3),
        threads: Some(threads),
        accuracy_refinements: refinements,
        ..WorstRequest::default()
    }
}

#[test]
fn the_accuracy_statement_refines_twice_and_is_the_same_on_any_thread_count() {
    let one = wsm_core::worst(block(), &request(1, None), &RunControl::new()).unwrap();
    let two = wsm_core::worst(block(), &request(2, None), &RunControl::new()).unwrap();
    let (a, b) = (one.accuracy.unwrap(), two.accuracy.unwrap());
    assert!(a.complete && a.meshes.len() == 3, "{a:?}");
    assert!(a
        .meshes
        .windows(2)
        .all(|m| m[1].unknowns > 2 * m[0].unknowns));
    assert_eq!(a.criteria, b.criteria, "bit-identical on 1 and 2 threads");
    for c in &a.criteria {
        for extremum in [&c.worst, &c.best] {
            let x = extremum.as_ref().unwrap();
            assert_eq!(x.refined.len(), 2);
            assert!(x.refined.iter().all(|v| v.is_some_and(f64::is_finite)));
            let estimate = x.estimate.unwrap();
            assert!(estimate.is_finite() && estimate >= 0.0);
            assert!(x.relative.unwrap() < 0.5, "{x:?}");
        }
    }
    // The run's values are the ones the statement starts from.
    assert_eq!(
        a.criteria[0].worst.as_ref().unwrap().value,
        one.criteria[0].worst.value.unwrap()
    );
    let none = wsm_core::worst(block(), &request(1, Some(0)), &RunControl::new()).unwrap();
    assert!(none.accuracy.is_none());
    assert!(WorstRequest {
        accuracy_refinements: Some(3),
        ..request(1, None)
    }
    .settings(&block())
    .is_err());
}

#[test]
fn a_cancelled_run_has_no_accuracy_statement() {
    let control = RunControl::new();
    control
        .cancel
        .store(true, std::sync::atomic::Ordering::SeqCst);
    let outcome = wsm_core::worst(block(), &request(1, Some(2)), &control).unwrap();
    assert_eq!(outcome.status, Status::Cancelled);
    assert!(outcome.accuracy.is_none());
}

#[test]
fn a_target_error_runs_on_the_chosen_mesh_and_says_so() {
    let targeted = WorstRequest {
        target_error: Some(0.02),
        accuracy_refinements: Some(1),
        ..request(2, None)
    };
    let a = wsm_core::worst(block(), &targeted, &RunControl::new()).unwrap();
    let choice = a.mesh_choice.clone().expect("a mesh choice");
    assert_eq!(choice.target_error, 0.02);
    let chosen = choice
        .candidates
        .iter()
        .find(|c| c.size_factor == choice.size_factor)
        .unwrap();
    assert!(choice.met && chosen.meets_target, "{choice:#?}");
    assert!(chosen.relative_errors.iter().all(|r| r.unwrap() <= 0.02));
    // The same run as one on the chosen mesh without a target, bit for bit; a different hash.
    let plain = wsm_core::worst(
        wsm_core::scaled_scene(&block(), choice.size_factor).unwrap(),
        &WorstRequest {
            accuracy_refinements: Some(1),
            ..request(1, None)
        },
        &RunControl::new(),
    )
    .unwrap();
    assert!(plain.mesh_choice.is_none());
    assert_ne!(a.run_hash, plain.run_hash);
    for (x, y) in a.criteria.iter().zip(&plain.criteria) {
        assert_eq!(x.worst.value, y.worst.value);
        assert_eq!(x.worst.point, y.worst.point);
        assert_eq!(x.best.value, y.best.value);
    }
    let (sa, sp) = (a.accuracy.unwrap(), plain.accuracy.unwrap());
    for (x, y) in sa.criteria.iter().zip(&sp.criteria) {
        assert_eq!(
            x.worst.as_ref().unwrap().refined,
            y.worst.as_ref().unwrap().refined
        );
    }
    // Bad targets name the field.
    for bad in [0.0, 1.5, f64::NAN] {
        let e = wsm_core::worst(
            block(),
            &WorstRequest {
                target_error: Some(bad),
                ..request(1, None)
            },
            &RunControl::new(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("target_error"), "{e}");
    }
}
