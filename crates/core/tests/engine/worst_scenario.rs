//! Worst-scenario engine acceptance, through the front door (`wsm_core::worst`): known worst
//! cases, a two-parameter contact case against a dense grid, a thermal case that needs only the
//! heat solve, the bundled mortar examples against their matching twins, and bad admissible sets
//! refused before any solve.

use serde_json::{json, Value};
use wsm_core::{
    parse_scene, scene_parameters, Criterion, CriterionSpec, RunControl, ScenarioEvaluator,
    StateProblem, Status, StopRule, Verdict, WarningKind, WorstOutcome, WorstRequest,
};

/// Search a scene for the given criteria (fresh run, never cancelled, exact derivatives),
/// stopping each extremum at its first local certificate: these are the known-worst cases, whose
/// few evaluations show the local search; the global rule is tested on the dam below.
fn worst(scene: &Value, criteria: &[Criterion], budget: usize, seed: u64) -> WorstOutcome {
    worst_with(scene, criteria, budget, seed, true)
}

/// [`worst`], with or without exact derivatives.
fn worst_with(
    scene: &Value,
    criteria: &[Criterion],
    budget: usize,
    seed: u64,
    derivatives: bool,
) -> WorstOutcome {
    let scene = parse_scene(&scene.to_string()).unwrap();
    let request = WorstRequest {
        criteria: Some(criteria.iter().map(|&c| c.into()).collect()),
        budget: Some(budget),
        seed: Some(seed),
        derivatives: Some(derivatives),
        stop: Some(StopRule::FirstCertificate),
        ..WorstRequest::default()
    };
    wsm_core::worst(scene, &request, &RunControl::new()).unwrap()
}

/// Every extremum of the run is `locally_certified` by its certificate, with no warning but the
/// one that says nothing looked for other basins (`first_certificate`).
fn assert_all_certified(r: &WorstOutcome) {
    for c in &r.criteria {
        for o in [&c.worst, &c.best] {
            assert_eq!(
                o.status,
                Status::LocallyCertified,
                "{:?}: {:?}",
                c.criterion,
                o.certificate
            );
            let proof = o.certificate.as_ref().expect("a certificate");
            assert_eq!(proof.verdict, Verdict::LocallyCertified);
            assert!(proof.residual.unwrap() <= wsm_search_tol(), "{proof:?}");
        }
    }
    assert_eq!(r.status, Status::LocallyCertified);
    assert_eq!(r.warnings.len(), 1, "{:?}", r.warnings);
    assert!(
        r.warnings[0].kind == WarningKind::Unproven
            && r.warnings[0]
                .to_string()
                .starts_with("search.stop: first_certificate"),
        "{:?}",
        r.warnings
    );
}

/// The certificate's relative residual tolerance.
fn wsm_search_tol() -> f64 {
    1e-6
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

fn point(o: &wsm_core::ObjectiveResult) -> Vec<f64> {
    o.point.clone().expect("a best point")
}

#[test]
fn monotone_displacement_criterion_worst_is_the_max_load_min_stiffness_vertex() {
    let r = worst(&loaded_block(), &[Criterion::Phi3], 40, 7);
    let c = &r.criteria[0];
    assert_eq!(point(&c.worst), vec![-2.0e6, 5.0e9]);
    assert_eq!(point(&c.best), vec![-1.0e6, 1.0e10]);
    assert!(c.worst.vertex_optimal && c.best.vertex_optimal);
    assert_eq!(r.parameters[0].name, "load");
    assert_eq!(r.parameters[1].field, "materials.m.E");
    // Linear elasticity: Φ3 ∝ load / E, so worst/best = (2/5)/(1/10) = 4.
    let ratio = c.worst.value.unwrap() / c.best.value.unwrap();
    assert!((ratio - 4.0).abs() < 1e-9, "ratio {ratio}");
    // Certified at the exact vertices by the centre and one vertex each.
    assert_all_certified(&r);
    assert!(r.evaluations <= 3 * 2, "{} evaluations", r.evaluations);
    // The certificate holds each bound by the sign of its derivative: Φ3 falls with the load
    // (it is negative: more negative is a larger push) and with E.
    let proof = c.worst.certificate.as_ref().unwrap();
    assert_eq!(proof.active.len(), 2);
    assert!(proof.active.iter().all(|b| b.rate < 0.0), "{proof:?}");
    // The gradient is Φ3's: ∂Φ3/∂E = −Φ3/E exactly (Φ3 ∝ 1/E).
    let (value, e) = (c.worst.value.unwrap(), 5.0e9);
    let d_e = c.worst.gradient["materials.m.E"];
    // The result speaks in field paths: the worst data and gradient by the scene's names.
    assert_eq!(c.worst.data["materials.m.E"], 5.0e9);
    assert_eq!(c.worst.data["boundary[1].traction[1]"], -2.0e6);
    assert_eq!(c.worst.gradient.len(), 2);
    assert!((d_e.right + value / e).abs() <= 1e-6 * value / e, "{d_e:?}");
    // Without derivatives the same vertices are found, with no certificate.
    let plain = worst_with(&loaded_block(), &[Criterion::Phi3], 40, 7, false);
    assert_eq!(point(&plain.criteria[0].worst), vec![-2.0e6, 5.0e9]);
    assert_ne!(plain.criteria[0].worst.status, Status::LocallyCertified);
    assert!(plain.criteria[0].worst.gradient.is_empty());
}

#[test]
fn monotone_stress_criterion_worst_is_the_max_load() {
    let r = worst(&loaded_block(), &[Criterion::Phi5], 40, 7);
    let c = &r.criteria[0];
    assert_eq!(point(&c.worst)[0], -2.0e6);
    assert_eq!(point(&c.best)[0], -1.0e6);
    // Stress does not depend on E here (one material, force boundary data): I2² ∝ load².
    let ratio = c.worst.value.unwrap() / c.best.value.unwrap();
    assert!((ratio - 4.0).abs() < 1e-9, "ratio {ratio}");
    assert_all_certified(&r);
    assert!(r.evaluations <= 3 * 2, "{} evaluations", r.evaluations);
}

#[test]
fn two_parameter_contact_case_matches_a_dense_grid_with_a_fifth_of_the_evaluations() {
    let mut scene: Value =
        serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    scene["mesh"] = json!({"max_size": 0.1});
    scene["uncertain"] = json!([
        {"field": "boundary[2].traction[0]", "interval": [0.0, 4.0e5]},
        {"field": "materials.rock.E", "interval": [8.0e9, 1.2e10]}
    ]);
    let parsed = parse_scene(&scene.to_string()).unwrap();
    let params = scene_parameters(&parsed).unwrap();
    let problem = StateProblem::new(parsed).unwrap();
    let criteria = [Criterion::Phi6];
    let specs = criteria.map(CriterionSpec::from);
    let evaluator = ScenarioEvaluator::new(&problem, &params, &specs).unwrap();
    let mut grid_max = f64::NEG_INFINITY;
    for i in 0..41 {
        for j in 0..41 {
            let theta = [4.0e5 * i as f64 / 40.0, 8.0e9 + 4.0e9 * j as f64 / 40.0];
            grid_max = grid_max.max(evaluator.evaluate_one(&theta).values.unwrap()[0]);
        }
    }
    let budget = 1681 / 5;
    let r = worst(&scene, &criteria, budget, 3);
    let found = r.criteria[0].worst.value.unwrap();
    assert!(r.evaluations <= budget);
    assert!(
        found >= grid_max * (1.0 - 1e-6),
        "found {found}, grid {grid_max}"
    );
}

#[test]
fn thermal_criteria_use_the_heat_solve_only() {
    let scene: Value = serde_json::from_str(wsm_core::example("heated-plate").unwrap()).unwrap();
    let r = worst(&scene, &[Criterion::Phi1, Criterion::Phi2], 30, 7);
    assert!(r.inner.heat_solves > 0);
    assert_eq!(
        (r.inner.factorisations, r.inner.elastic_solves),
        (0, 0),
        "no elastic work for Φ1/Φ2"
    );
    // Φ1 grows with the heat source and the rim temperature and falls with conductivity.
    assert_eq!(point(&r.criteria[0].worst), vec![2.5e4, 2.5, 25.0]);
    assert_eq!(r.criteria[0].worst.status, Status::LocallyCertified);
    let thermal = worst(&scene, &[Criterion::Phi1], 30, 7);
    assert_all_certified(&thermal);
    assert!(thermal.evaluations <= 3 * 2, "{}", thermal.evaluations);
    assert_eq!(point(&thermal.criteria[0].worst), vec![2.5e4, 2.5, 25.0]);
}

#[test]
fn knee_is_certified_in_a_few_evaluations() {
    let scene: Value = serde_json::from_str(wsm_core::example("knee").unwrap()).unwrap();
    let r = worst(&scene, &[Criterion::Phi5, Criterion::Phi6], 150, 1);
    assert_all_certified(&r);
    assert!(r.evaluations <= 20, "{} evaluations", r.evaluations);
}

/// The acceptance case of the search issue: the tunnel's 2^8 vertices solved independently
/// (as `wsm solve` would) against the search at a budget of 120 — every extremum at least as
/// extreme as every vertex, each certified.
#[test]
fn tunnel_extrema_beat_every_vertex_and_are_certified_within_120_solves() {
    let text = wsm_core::example("tunnel-fault").unwrap();
    let scene: Value = serde_json::from_str(text).unwrap();
    let criteria = [
        Criterion::Phi3,
        Criterion::Phi4,
        Criterion::Phi5,
        Criterion::Phi6,
    ];
    let parsed = parse_scene(text).unwrap();
    let params = scene_parameters(&parsed).unwrap();
    assert_eq!(params.len(), 8);
    let problem = StateProblem::new(parsed).unwrap();
    let specs = criteria.map(CriterionSpec::from);
    let evaluator = ScenarioEvaluator::new(&problem, &params, &specs).unwrap();
    let vertices: Vec<Vec<f64>> = (0..1usize << params.len())
        .map(|mask| {
            params
                .iter()
                .enumerate()
                .map(|(i, p)| if mask >> i & 1 == 1 { p.hi } else { p.lo })
                .collect()
        })
        .collect();
    let values = solve_all(&evaluator, &vertices);
    let r = worst(&scene, &criteria, 120, 1);
    println!("tunnel: {} evaluations, {:?}", r.evaluations, r.status);
    assert!(r.evaluations <= 120);
    assert_all_certified(&r);
    assert_at_least_as_extreme(&r, &values, "vertex");
}

/// The bundled mortar examples (design §2.4.1: the bodies meshed on their own, coupled by dual
/// mortar) end like their node-coupled twins: every extremum locally certified, in the same
/// region, at the same end (or inside) of every data interval, and its value within the
/// discretisation difference: |Φ_twin − Φ_mortar| ≤ |Φ_twin − Φ| + |Φ_mortar − Φ|, each error
/// estimated, at its run's extremum, by twice the change when all mesh sizes are halved (an O(h)
/// criterion's error is about twice its change when h halves).
#[test]
fn mortar_examples_end_certified_like_their_matching_twins() {
    let cases: [(&str, &str, &[Criterion], usize); 2] = [
        (
            "hertz",
            "hertz-nonmatching",
            &[Criterion::Phi5, Criterion::Phi6],
            20,
        ),
        (
            "tunnel-fault",
            "tunnel-fault-nonmatching",
            &[
                Criterion::Phi3,
                Criterion::Phi4,
                Criterion::Phi5,
                Criterion::Phi6,
            ],
            120,
        ),
    ];
    for (twin, mortar, criteria, budget) in cases {
        let text = |name| wsm_core::example(name).unwrap();
        let run = |name| {
            worst(
                &serde_json::from_str(text(name)).unwrap(),
                criteria,
                budget,
                1,
            )
        };
        let (a, b) = (run(twin), run(mortar));
        println!(
            "{twin}: {} evaluations; {mortar}: {}",
            a.evaluations, b.evaluations
        );
        assert_all_certified(&a);
        assert_all_certified(&b);
        let params = scene_parameters(&parse_scene(text(twin)).unwrap()).unwrap();
        let specs: Vec<CriterionSpec> = criteria.iter().map(|&c| c.into()).collect();
        // Each run's extrema (in the order of the requested criteria, worst then best) on its
        // scene with all mesh sizes halved.
        let halved = |name, r: &WorstOutcome| {
            let extrema: Vec<Vec<f64>> = r
                .criteria
                .iter()
                .flat_map(|c| [point(&c.worst), point(&c.best)])
                .collect();
            let scene = parse_scene(text(name)).unwrap();
            let problem = StateProblem::new(wsm_core::scaled_scene(&scene, 0.5).unwrap()).unwrap();
            solve_all(
                &ScenarioEvaluator::new(&problem, &params, &specs).unwrap(),
                &extrema,
            )
        };
        let (half_a, half_b) = (halved(twin, &a), halved(mortar, &b));
        let ends = |o: &wsm_core::ObjectiveResult| -> Vec<&str> {
            point(o)
                .iter()
                .zip(&params)
                .map(|(&x, p)| match x {
                    _ if x == p.lo => "lower",
                    _ if x == p.hi => "upper",
                    _ => "inside",
                })
                .collect()
        };
        for (c, (ca, cb)) in a.criteria.iter().zip(&b.criteria).enumerate() {
            for (e, (oa, ob)) in [(&ca.worst, &cb.worst), (&ca.best, &cb.best)]
                .into_iter()
                .enumerate()
            {
                let (va, vb) = (oa.value.unwrap(), ob.value.unwrap());
                let i = 2 * c + e;
                let bound = 2.0 * ((half_a[i][c] - va).abs() + (half_b[i][c] - vb).abs());
                println!(
                    "  {:?} {:?}: {va:.6e} vs {vb:.6e}, {:.2e} relative (bound {:.2e})",
                    criteria[c],
                    oa.sense,
                    (va - vb).abs() / va.abs(),
                    bound / va.abs()
                );
                assert_eq!(oa.region, ob.region, "{mortar} {:?}", criteria[c]);
                assert_eq!(ends(oa), ends(ob), "{mortar} {:?}", criteria[c]);
                assert!(
                    (va - vb).abs() <= bound,
                    "{mortar} {:?} {:?}: {va} vs {vb}",
                    criteria[c],
                    oa.sense
                );
            }
        }
    }
}

/// The criteria at every one of `points`, solved independently of any search (each must solve).
fn solve_all(evaluator: &ScenarioEvaluator<'_>, points: &[Vec<f64>]) -> Vec<Vec<f64>> {
    evaluator
        .evaluate_batch(points)
        .into_iter()
        .zip(points)
        .map(|(e, p)| {
            e.values
                .unwrap_or_else(|| panic!("{p:?} does not solve: {:?}", e.error))
        })
        .collect()
}

/// Every extremum of `r` is at least as extreme (to 1e-9 relative) as the criteria `values`
/// (per point, in the order of `r.criteria`) found independently at some `kind` of point.
fn assert_at_least_as_extreme(r: &WorstOutcome, values: &[Vec<f64>], kind: &str) {
    for (c, outcome) in r.criteria.iter().enumerate() {
        let max = values
            .iter()
            .map(|v| v[c])
            .fold(f64::NEG_INFINITY, f64::max);
        let min = values.iter().map(|v| v[c]).fold(f64::INFINITY, f64::min);
        let worst = outcome.worst.value.unwrap();
        let best = outcome.best.value.unwrap();
        assert!(
            worst >= max - 1e-9 * max.abs(),
            "{:?} worst {worst} < {kind} {max}",
            outcome.criterion
        );
        assert!(
            best <= min + 1e-9 * min.abs(),
            "{:?} best {best} > {kind} {min}",
            outcome.criterion
        );
    }
}

#[test]
fn changing_only_loads_and_slip_limits_never_refactorises() {
    let mut scene: Value =
        serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    scene["mesh"] = json!({"max_size": 0.1});
    scene["uncertain"] = json!([
        {"field": "boundary[2].traction[0]", "interval": [3.0e5, 4.0e5]},
        {"field": "contacts[0].slip_limit", "interval": [2.5e5, 4.0e5]}
    ]);
    // Without derivatives, so that the search makes its 30 solves (the walk would certify in 3).
    let r = worst_with(&scene, &[Criterion::Phi6], 30, 7, false);
    assert!(r.inner.elastic_solves >= 20, "{:?}", r.inner);
    assert_eq!(
        r.inner.factorisations, 1,
        "one factorisation serves every load and slip-limit change"
    );
    assert!(r.inner.max_kkt_residual <= 1e-9);
}

#[test]
fn unbalanced_vertex_is_refused_before_any_solve() {
    // The block floats: at traction 6e5 Pa × 0.5 m = 3e5 N/m > g L = 2.5e5 N/m it slides away.
    let mut scene: Value =
        serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    scene["mesh"] = json!({"max_size": 0.1});
    scene["uncertain"] = json!([
        {"field": "boundary[2].traction[0]", "interval": [3.0e5, 6.0e5]},
        {"field": "contacts[0].slip_limit", "interval": [2.5e5, 4.0e5]}
    ]);
    let parsed = parse_scene(&scene.to_string()).unwrap();
    let err = wsm_core::worst(parsed, &WorstRequest::default(), &RunControl::new())
        .expect_err("must be refused");
    assert_eq!(err.kind(), wsm_core::ErrorKind::BadInput);
    let msg = err.to_string();
    assert!(
        msg.starts_with("uncertain") && msg.contains("block"),
        "{msg}"
    );
}

/// The slope-limited slip limit of `tunnel-fault-slip-profile` (FGCS 4.15, C = 4e4 Pa/m on the
/// 22 m zone: adjacent knots, 11 m apart, differ by at most 0.44 MPa) with only its three knots
/// uncertain: every extremum is at least as extreme as every point of a grid of the admissible
/// set (knot values 0.3, 0.5, …, 1.5 MPa with the slope bound), and the reported data are the
/// projected slip limit, which satisfies the bound.
#[test]
fn slope_limited_slip_limit_extrema_beat_an_enumeration_of_its_set() {
    let text = wsm_core::example("tunnel-fault-slip-profile").unwrap();
    let mut scene: Value = serde_json::from_str(text).unwrap();
    let knots = scene["uncertain"].as_array().unwrap()[..3].to_vec();
    scene["uncertain"] = Value::Array(knots);
    let max_step = 4e4 * 22.0 * 0.5;
    let criteria = [Criterion::Phi3, Criterion::Phi4, Criterion::Phi6];
    let parsed = parse_scene(&scene.to_string()).unwrap();
    let params = scene_parameters(&parsed).unwrap();
    let problem = StateProblem::new(parsed).unwrap();
    let specs = criteria.map(CriterionSpec::from);
    let evaluator = ScenarioEvaluator::new(&problem, &params, &specs).unwrap();
    let levels: Vec<f64> = (0..7).map(|i| 3e5 + 2e5 * i as f64).collect();
    let mut grid = Vec::new();
    for &a in &levels {
        for &b in &levels {
            for &c in &levels {
                if (b - a).abs() <= max_step && (c - b).abs() <= max_step {
                    grid.push(vec![a, b, c]);
                }
            }
        }
    }
    assert!(
        grid.len() < levels.len().pow(3),
        "the slope bound cuts the box"
    );
    let values = solve_all(&evaluator, &grid);
    let r = worst(&scene, &criteria, 200, 1);
    assert_at_least_as_extreme(&r, &values, "grid point");
    let mut projected = 0;
    for outcome in &r.criteria {
        for o in [&outcome.worst, &outcome.best] {
            let g: Vec<f64> = (0..3)
                .map(|k| o.data[&format!("contacts[fault_low].slip_limit.values[{k}]")])
                .collect();
            for k in 0..2 {
                assert!(
                    (g[k + 1] - g[k]).abs() <= max_step * (1.0 + 1e-9),
                    "{:?}: reported slip limit {g:?} breaks the slope bound",
                    outcome.criterion
                );
            }
            assert!(g.iter().all(|&v| (3e5 - 1e-6..=1.5e6 + 1e-6).contains(&v)));
            let point = o.point.as_ref().unwrap();
            projected += usize::from(g.iter().zip(point).any(|(a, b)| (a - b).abs() > 1.0));
        }
    }
    assert!(
        projected > 0,
        "some extremum lies where the search coordinates are projected"
    );
}
