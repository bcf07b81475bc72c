//! Stiff and extreme cases (design §6 "Stability", issue 13): the catalogue of `wsm study
//! stability` — stiffness contrasts to 1e9, ν to 0.4999, slip limits 0 … 1e12, loads near
//! lift-off, floating bodies, aspect ratios to 1e3, units, a four-decade interval, each with the
//! direct and the DD solver — must pass case by case: solved with KKT residuals under the
//! tolerance (and the expected warnings), or refused with a reason naming the body or motion;
//! never a NaN or a success above tolerance.

use serde_json::json;
use wsm_core::{
    parse_scene, Criterion, Needs, RunControl, SolveOptions, StateProblem, Warning, WarningKind,
    WorstRequest,
};
use wsm_study::stability::{catalogue, pushed_block, run_catalogue};

#[test]
fn every_case_of_the_catalogue_passes_with_both_solvers() {
    let cases = catalogue();
    let results = run_catalogue(&cases);
    assert_eq!(results.len(), 2 * cases.len());
    let failed: Vec<String> = results
        .iter()
        .filter(|r| !r.passed)
        .map(|r| format!("{} / {} ({}): {:?}", r.group, r.name, r.solver, r.failure))
        .collect();
    assert!(failed.is_empty(), "{failed:#?}");
    for group in [
        "stiffness contrast",
        "Poisson's ratio",
        "slip limit",
        "near lift-off",
        "floating body",
        "aspect ratio",
        "units",
        "wide interval",
    ] {
        assert!(results.iter().any(|r| r.group == group), "{group}");
    }
    // Every solved row is finite and has its residual; every refusal has its reason.
    for r in &results {
        match r.outcome.as_str() {
            "solved" => assert!(r.max_kkt.is_some_and(f64::is_finite), "{r:?}"),
            _ => assert!(r.reason.as_ref().is_some_and(|s| !s.is_empty()), "{r:?}"),
        }
    }
    let refused = results.iter().filter(|r| r.outcome == "refused").count();
    assert_eq!(refused, 6, "three refusals, each with both solvers");
    // The 1e9 contrast is conditioned as such (the estimate is not a constant).
    let kappa = |name: &str| {
        results
            .iter()
            .find(|r| r.name == name && r.solver == "direct")
            .and_then(|r| r.condition)
            .unwrap()
    };
    assert!(kappa("E base / block = 1e9") > 1e5 * kappa("E base / block = 1e0"));
}

#[test]
fn near_lift_off_the_contact_carries_exactly_the_net_load() {
    // The block weighs 12250 N/m and is pulled up by 12240 N/m: 10 N/m stay on the contact.
    let mut v = pushed_block(1.0e10, 1.0e10, 0.25, 1.0e4, -12_240.0);
    v["materials"]["block"]["specific_weight"] = json!(2.45e4);
    let problem = StateProblem::new(parse_scene(&v.to_string()).unwrap()).unwrap();
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm_core::Par::Seq,
        warm: None,
    };
    let sol = problem.solve(&problem.nominal, &options).unwrap();
    let total: f64 = sol
        .contact
        .iter()
        .zip(&problem.contact.geometry.pairs)
        .map(|(c, p)| c.pressure * p.weight)
        .sum();
    assert!((total - 10.0).abs() < 1e-6, "net contact force {total} N/m");
}

#[test]
fn a_worst_scenario_result_warns_about_p1_locking() {
    let mut v = pushed_block(1.0e9, 1.0e9, 0.3, 1.0e5, 1.0e5);
    v["materials"]["block"]["nu"] = json!(0.49);
    v["uncertain"] = json!([{"field": "materials.block.nu", "interval": [0.49, 0.495]}]);
    let request = WorstRequest {
        criteria: Some(vec![Criterion::Phi3.into()]),
        budget: Some(8),
        accuracy_refinements: Some(0),
        ..WorstRequest::default()
    };
    let outcome = wsm_core::worst(
        parse_scene(&v.to_string()).unwrap(),
        &request,
        &RunControl::new(),
    )
    .unwrap();
    let locking: Vec<&Warning> = outcome
        .warnings
        .iter()
        .filter(|w| w.kind == WarningKind::Locking)
        .collect();
    assert_eq!(locking.len(), 1, "{:?}", outcome.warnings);
    assert!(locking[0].contains("'block'"), "{:?}", outcome.warnings);
    v["materials"]["block"]["nu"] = json!(0.3);
    v["uncertain"] = json!([{"field": "materials.block.nu", "interval": [0.3, 0.4]}]);
    let calm = wsm_core::worst(
        parse_scene(&v.to_string()).unwrap(),
        &request,
        &RunControl::new(),
    )
    .unwrap();
    assert!(
        !calm.warnings.iter().any(|w| w.kind == WarningKind::Locking),
        "{:?}",
        calm.warnings
    );
}
