//! Worst-scenario engine acceptance (issue "Worst-scenario engine"): known worst cases, a
//! two-parameter contact case against a dense grid, a thermal case that needs only the heat
//! solve, and bad admissible sets refused before any solve.

use std::sync::atomic::AtomicBool;

use serde_json::{json, Value};
use wsm::scenario::search::EvalCache;
use wsm::scenario::worst::{prepare, run, ScenarioEvaluator, WorstResult, WorstSettings};
use wsm::scene::params::Parameter;
use wsm::scene::{parse, Criterion};
use wsm::state::StateProblem;

/// Run the search on a prepared problem (fresh cache, never cancelled).
fn search(
    problem: &StateProblem,
    params: &[Parameter],
    criteria: &[Criterion],
    budget: usize,
    seed: u64,
) -> WorstResult {
    let settings = WorstSettings {
        criteria: criteria.to_vec(),
        budget,
        seed,
        max_seconds: None,
    };
    run(
        problem,
        params,
        &settings,
        &mut EvalCache::new(),
        &AtomicBool::new(false),
        &|_| {},
    )
    .unwrap()
}

/// Prepare and search; also return (heat solves, factorisations, elastic solves).
fn worst(
    scene: &Value,
    criteria: &[Criterion],
    budget: usize,
) -> (WorstResult, (usize, usize, usize)) {
    let scene = parse(&scene.to_string()).unwrap();
    let (problem, params) = prepare(scene).unwrap();
    let result = search(&problem, &params, criteria, budget, 7);
    (result, problem.counters.snapshot())
}

/// One clamped block under a top pressure p ∈ [1, 2] MPa with E ∈ [5, 10] GPa.
fn loaded_block() -> Value {
    json!({
        "version": 1, "name": "monotone block",
        "bodies": [{"name": "b", "zones": [{"name": "z", "material": "m", "polygon": [[0,0],[1,0],[1,1],[0,1]]}]}],
        "segments": {
            "bottom": {"body": "b", "from": [0,0], "to": [1,0]},
            "top": {"body": "b", "from": [1,1], "to": [0,1]}
        },
        "materials": {"m": {"E": 7.0e9, "nu": 0.3}},
        "boundary": [{"segment": "bottom", "displacement": [0, 0]}, {"segment": "top", "traction": [0, -1.5e6]}],
        "mesh": {"max_size": 0.2},
        "criteria": {"regions": [{"name": "top", "polygon": [[0.4,0.8],[0.6,0.8],[0.6,1.0],[0.4,1.0]], "normal": [0, -1]}]},
        "uncertain": [
            {"field": "boundary[1].traction[1]", "interval": [-2.0e6, -1.0e6], "name": "load"},
            {"field": "materials.m.E", "interval": [5.0e9, 1.0e10], "name": "E"}
        ]
    })
}

#[test]
fn monotone_displacement_criterion_worst_is_the_max_load_min_stiffness_vertex() {
    let (r, _) = worst(&loaded_block(), &[Criterion::Phi3], 40);
    let c = &r.criteria[0];
    assert_eq!(c.worst.data[0].1, -2.0e6, "{:?}", c.worst.data);
    assert_eq!(c.worst.data[1].1, 5.0e9, "{:?}", c.worst.data);
    assert_eq!(c.best.data[0].1, -1.0e6);
    assert_eq!(c.best.data[1].1, 1.0e10);
    assert!(c.worst.vertex_optimal && c.best.vertex_optimal);
    // Linear elasticity: Φ3 ∝ load / E, so worst/best = (2/5)/(1/10) = 4.
    let ratio = c.worst.value.unwrap() / c.best.value.unwrap();
    assert!((ratio - 4.0).abs() < 1e-9, "ratio {ratio}");
}

#[test]
fn monotone_stress_criterion_worst_is_the_max_load() {
    let (r, _) = worst(&loaded_block(), &[Criterion::Phi5], 40);
    let c = &r.criteria[0];
    assert_eq!(c.worst.data[0].1, -2.0e6);
    assert_eq!(c.best.data[0].1, -1.0e6);
    // Stress does not depend on E here (one material, force boundary data): I2² ∝ load².
    let ratio = c.worst.value.unwrap() / c.best.value.unwrap();
    assert!((ratio - 4.0).abs() < 1e-9, "ratio {ratio}");
}

#[test]
fn two_parameter_contact_case_matches_a_dense_grid_with_a_fifth_of_the_evaluations() {
    let mut scene: Value =
        serde_json::from_str(wsm::examples::example("block-on-base").unwrap()).unwrap();
    scene["mesh"] = json!({"max_size": 0.1});
    scene["uncertain"] = json!([
        {"field": "boundary[2].traction[0]", "interval": [0.0, 4.0e5]},
        {"field": "materials.rock.E", "interval": [8.0e9, 1.2e10]}
    ]);
    let parsed = parse(&scene.to_string()).unwrap();
    let (problem, params) = prepare(parsed).unwrap();
    let criteria = [Criterion::Phi6];
    let evaluator = ScenarioEvaluator::new(&problem, &params, &criteria).unwrap();
    let mut grid_max = f64::NEG_INFINITY;
    for i in 0..41 {
        for j in 0..41 {
            let theta = [4.0e5 * i as f64 / 40.0, 8.0e9 + 4.0e9 * j as f64 / 40.0];
            grid_max = grid_max.max(evaluator.evaluate_one(&theta).unwrap()[0]);
        }
    }
    let budget = 1681 / 5;
    let r = search(&problem, &params, &criteria, budget, 3);
    let found = r.criteria[0].worst.value.unwrap();
    assert!(r.evaluations <= budget);
    assert!(
        found >= grid_max * (1.0 - 1e-6),
        "found {found}, grid {grid_max}"
    );
}

#[test]
fn thermal_criteria_use_the_heat_solve_only() {
    let scene: Value =
        serde_json::from_str(wsm::examples::example("heated-plate").unwrap()).unwrap();
    let (r, (heat, factorisations, elastic)) =
        worst(&scene, &[Criterion::Phi1, Criterion::Phi2], 30);
    assert!(heat > 0);
    assert_eq!(
        (factorisations, elastic),
        (0, 0),
        "no elastic work for Φ1/Φ2"
    );
    // Φ1 grows with the heat source and the rim temperature and falls with conductivity.
    let w = &r.criteria[0].worst.data;
    assert_eq!(w[0].1, 2.5e4);
    assert_eq!(w[1].1, 2.5);
    assert_eq!(w[2].1, 25.0);
}

#[test]
fn changing_only_loads_and_slip_limits_never_refactorises() {
    let mut scene: Value =
        serde_json::from_str(wsm::examples::example("block-on-base").unwrap()).unwrap();
    scene["mesh"] = json!({"max_size": 0.1});
    scene["uncertain"] = json!([
        {"field": "boundary[2].traction[0]", "interval": [3.0e5, 4.0e5]},
        {"field": "contacts[0].slip_limit", "interval": [2.5e5, 4.0e5]}
    ]);
    let (r, (_, factorisations, elastic)) = worst(&scene, &[Criterion::Phi6], 30);
    assert!(elastic >= 20, "{elastic} solves");
    assert_eq!(
        factorisations, 1,
        "one factorisation serves every load and slip-limit change"
    );
    assert!(r.inner.max_kkt_residual <= 1e-9);
}

#[test]
fn unbalanced_vertex_is_refused_before_any_solve() {
    // The block floats: at traction 6e5 Pa × 0.5 m = 3e5 N/m > g L = 2.5e5 N/m it slides away.
    let mut scene: Value =
        serde_json::from_str(wsm::examples::example("block-on-base").unwrap()).unwrap();
    scene["mesh"] = json!({"max_size": 0.1});
    scene["uncertain"] = json!([
        {"field": "boundary[2].traction[0]", "interval": [3.0e5, 6.0e5]},
        {"field": "contacts[0].slip_limit", "interval": [2.5e5, 4.0e5]}
    ]);
    let parsed = parse(&scene.to_string()).unwrap();
    let err = prepare(parsed).err().expect("must be refused");
    let msg = err.to_string();
    assert!(
        msg.starts_with("uncertain") && msg.contains("block"),
        "{msg}"
    );
}
