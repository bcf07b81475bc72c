//! The worst-scenario loop with the DD solver against the direct one (docs/benchmarks.md,
//! "Inner-loop speed"; design §3.2), on coarse versions of the tunnel, the knee and the heated
//! plate (a thermal scene): the same worst and best values (to 1e-8 relative) at the same data,
//! independent of the thread count; and the value at a point does not depend on what was evaluated
//! before it in the process (cached factorisations give the same bits as fresh ones; a warm-started
//! solve equals a cold one to the solver tolerance).

use wsm_core::{
    scene_parameters, RunControl, ScenarioEvaluator, Scene, SolverKind, StateProblem, WorstOutcome,
    WorstRequest,
};
use wsm_study::bench::scaled_scene;

fn scene(example: &str, coarsen: f64, kind: SolverKind) -> Scene {
    let mut scene = scaled_scene(example, coarsen).unwrap();
    scene.solver.kind = kind;
    scene.solver.tolerance = 1e-12;
    scene
}

fn worst(scene: Scene, budget: usize, threads: usize) -> WorstOutcome {
    let request = WorstRequest {
        budget: Some(budget),
        seed: Some(3),
        threads: Some(threads),
        ..WorstRequest::default()
    };
    wsm_core::worst(scene, &request, &RunControl::new()).unwrap()
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}

/// DD and direct find the same extremes at the same points; DD does not depend on the threads.
fn compare(example: &str, coarsen: f64, budget: usize) {
    let direct = worst(scene(example, coarsen, SolverKind::Direct), budget, 2);
    let dd = worst(scene(example, coarsen, SolverKind::Dd), budget, 2);
    assert_eq!(dd.inner.failures, 0, "{example}: DD failures");
    assert_eq!(direct.criteria.len(), dd.criteria.len());
    for (a, b) in direct.criteria.iter().zip(&dd.criteria) {
        for (x, y) in [(&a.worst, &b.worst), (&a.best, &b.best)] {
            let (vx, vy) = (x.value.unwrap(), y.value.unwrap());
            let rel = relative(vx, vy);
            println!(
                "{example} {:?}: direct {vx:e}, DD {vy:e}, relative {rel:.1e}",
                a.criterion
            );
            assert!(rel <= 1e-8, "{example} {:?}: {vx} vs {vy}", a.criterion);
            assert_eq!(x.point, y.point, "{example}: same worst data");
        }
    }
    let dd_one = worst(scene(example, coarsen, SolverKind::Dd), budget, 1);
    assert_eq!(
        dd.criteria, dd_one.criteria,
        "{example}: DD on 1 and 2 threads"
    );
}

#[test]
fn tunnel_worst_case_with_dd_equals_direct() {
    compare("tunnel-fault", 3.0, 12);
}

#[test]
fn knee_worst_case_with_dd_equals_direct() {
    compare("knee", 2.0, 12);
}

#[test]
fn thermal_worst_case_with_dd_equals_direct() {
    compare("heated-plate", 2.0, 12);
}

/// Points spread over the admissible box (deterministic).
fn points(problem: &StateProblem, count: usize) -> Vec<Vec<f64>> {
    let params = scene_parameters(&problem.scene).unwrap();
    (0..count)
        .map(|k| {
            params
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let t = ((k * 7 + i * 3) % 11) as f64 / 10.0;
                    p.lo + t * (p.hi - p.lo)
                })
                .collect()
        })
        .collect()
}

/// The value at a point is a function of (scene, point): the same bits whether the process
/// evaluated other points first (cached body factors and DD partition reused) or not.
#[test]
fn an_evaluation_does_not_depend_on_the_ones_before_it() {
    for kind in [SolverKind::Direct, SolverKind::Dd] {
        let scene = scene("tunnel-fault", 3.0, kind);
        let criteria = scene.search.criteria.clone();
        let busy = StateProblem::new(scene.clone()).unwrap();
        let params = scene_parameters(&busy.scene).unwrap();
        let all = points(&busy, 4);
        let mut last = all[3].clone();
        // A point that shares the Lamé coefficients of an earlier one (only loads and slip
        // limits differ): its factors come from the cache.
        last[..4].copy_from_slice(&all[0][..4]);
        let evaluator = ScenarioEvaluator::new(&busy, &params, &criteria).unwrap();
        for p in &all[..3] {
            assert!(evaluator.evaluate_one(p).values.is_some());
        }
        let factorisations = || {
            busy.counters
                .body_factorisations
                .load(std::sync::atomic::Ordering::Relaxed)
        };
        let before = factorisations();
        let after = evaluator.evaluate_one(&last);
        let fresh_problem = StateProblem::new(scene).unwrap();
        let fresh = ScenarioEvaluator::new(&fresh_problem, &params, &criteria).unwrap();
        let cold = fresh.evaluate_one(&last);
        assert!(after.values.is_some(), "{kind:?}: {:?}", after.error);
        assert_eq!(after.values, cold.values, "{kind:?}: bit-identical values");
        if kind == SolverKind::Direct {
            assert_eq!(
                factorisations(),
                before,
                "the last point's body factors came from the cache"
            );
        }
    }
}

/// A contact solve warm-started from the nominal solution equals a cold one to the solver
/// tolerance.
#[test]
fn a_warm_started_solve_equals_a_cold_one() {
    use wsm_core::{Needs, SolveOptions};
    for kind in [SolverKind::Direct, SolverKind::Dd] {
        let problem = StateProblem::new(scene("tunnel-fault", 3.0, kind)).unwrap();
        let params = scene_parameters(&problem.scene).unwrap();
        let options = |warm| SolveOptions {
            needs: Needs::all(&problem.scene),
            par: wsm_core::Par::Seq,
            warm,
        };
        let nominal = problem.solve(&problem.nominal, &options(None)).unwrap();
        for theta in points(&problem, 3) {
            let data =
                wsm_core::apply_parameters(&problem.scene, &problem.nominal, &params, &theta);
            let warm = problem
                .solve(&data, &options(nominal.warm_start.clone()))
                .unwrap();
            let cold = problem.solve(&data, &options(None)).unwrap();
            for (c, (a, b)) in warm.criteria.iter().zip(&cold.criteria).enumerate() {
                if let (Some(a), Some(b)) = (a, b) {
                    assert!(relative(*a, *b) <= 1e-9, "{kind:?} Φ{}: {a} vs {b}", c + 1);
                }
            }
        }
    }
}
