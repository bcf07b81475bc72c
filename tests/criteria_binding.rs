//! Criteria bound to one region (design §4.2, "Which region"): `phi3@crest` is the mean over the
//! area `crest`, where `phi3` is the largest mean over all of Φ3's areas. Its value is that
//! region's value in the solve's `region_values`, its exact derivative matches central
//! differences whether or not the region is the one attaining the maximum, a worst-scenario run
//! reports for every extremum the region it comes from, a bad binding is refused naming the
//! criterion, and criteria a search would need do not block a solve.

use std::process::Command;

use serde_json::{json, Value};
use wsm_core::{
    parse_scene, scene_parameters, Criterion, CriterionSpec, RunControl, ScenarioEvaluator, Scene,
    SolveRequest, StateProblem, StopRule, WorstRequest,
};

fn spec(s: &str) -> CriterionSpec {
    CriterionSpec::parse(s).unwrap()
}

/// The bundled tunnel on a coarser mesh: areas `crown` and `fault`, both with a normal.
fn tunnel() -> Scene {
    wsm_study::bench::scaled_scene("tunnel-fault", 2.0).unwrap()
}

fn dam() -> Value {
    serde_json::from_str(include_str!("data/dam-coulomb-3data.json")).unwrap()
}

#[test]
fn a_criterion_reads_and_writes_as_a_name_or_an_object() {
    let bound: CriterionSpec = serde_json::from_value(json!("phi3@crest")).unwrap();
    assert_eq!(bound.criterion, Criterion::Phi3);
    assert_eq!(bound.region.as_deref(), Some("crest"));
    let object: CriterionSpec =
        serde_json::from_value(json!({"criterion": "phi3", "region": "crest"})).unwrap();
    assert_eq!(object, bound);
    assert_eq!(serde_json::to_value(&bound).unwrap(), json!("phi3@crest"));
    // Unbound criteria read and write as before, so stored jobs and run hashes are unchanged.
    assert_eq!(
        serde_json::to_value(CriterionSpec::from(Criterion::Phi5)).unwrap(),
        json!("phi5")
    );
    for bad in [
        json!("phi7"),
        json!("phi3@"),
        json!(3),
        json!({"criterion": "phi3", "zone": "x"}),
    ] {
        assert!(
            serde_json::from_value::<CriterionSpec>(bad.clone()).is_err(),
            "{bad}"
        );
    }
}

#[test]
fn a_bound_criterion_is_its_region_value_with_exact_derivatives() {
    let scene = tunnel();
    let params = scene_parameters(&scene).unwrap();
    let problem = StateProblem::new(scene).unwrap();
    let criteria: Vec<CriterionSpec> = [
        "phi3",
        "phi3@crown",
        "phi3@fault",
        "phi5",
        "phi5@crown",
        "phi5@fault",
    ]
    .map(spec)
    .to_vec();
    let evaluator = ScenarioEvaluator::new(&problem, &params, &criteria)
        .unwrap()
        .with_derivatives(true);
    let mid: Vec<f64> = params.iter().map(|p| 0.37 * p.lo + 0.63 * p.hi).collect();
    let at = evaluator.evaluate_one(&mid);
    let values = at.values.clone().expect("the point solves");
    // Each Φ is the largest of its bound versions, and both regions are genuinely different.
    for (all, pair) in [(0, [1, 2]), (3, [4, 5])] {
        let max = values[pair[0]].max(values[pair[1]]);
        assert_eq!(values[all], max);
        assert!(values[pair[0]] != values[pair[1]]);
    }
    // The solve's region values are the same numbers, by name.
    let data = wsm_core::apply_parameters(&problem.scene, &problem.nominal, &params, &mid);
    let options = wsm_core::SolveOptions {
        needs: wsm_core::Needs::all(&problem.scene),
        par: wsm_core::Par::Seq,
        warm: None,
    };
    let solution = problem.solve(&data, &options).unwrap();
    let summary = wsm_core::result_summary(&problem, &data, &solution);
    assert_eq!(summary.region_values["phi3"]["crown"], values[1]);
    assert_eq!(summary.region_values["phi5"]["fault"], values[5]);
    // Exact derivatives against central differences, for the region attaining the maximum and
    // the other one alike.
    let mut checked = 0;
    for (j, p) in params.iter().enumerate() {
        let h = 1e-4 * (p.hi - p.lo);
        let shifted = |d: f64| {
            let mut x = mid.clone();
            x[j] += d;
            evaluator.evaluate_one(&x).values.unwrap()
        };
        let (plus, minus) = (shifted(h), shifted(-h));
        let (plus2, minus2) = (shifted(h / 2.0), shifted(-h / 2.0));
        for c in [1, 2, 4, 5] {
            let exact = at.gradient[c][j];
            assert!(exact.is_differentiable(), "{} along {j}", criteria[c]);
            let fd = (plus[c] - minus[c]) / (2.0 * h);
            let fd2 = (plus2[c] - minus2[c]) / h;
            let scale = values[c].abs() / (p.hi - p.lo);
            if (fd - fd2).abs() > 1e-6 * scale {
                continue; // an active-set change within ±h: the difference straddles a kink
            }
            assert!(
                (exact.right - fd).abs() <= 1e-6 * scale.max(fd.abs()),
                "{} along {}: exact {} vs central difference {fd}",
                criteria[c],
                p.name,
                exact.right
            );
            checked += 1;
        }
    }
    assert!(checked >= 28, "only {checked} of 32 components were smooth");
}

#[test]
fn a_search_reports_where_each_extremum_comes_from() {
    let scene = parse_scene(&dam().to_string()).unwrap();
    let request = WorstRequest {
        criteria: Some(["phi3@crest", "phi5", "phi6@heel"].map(spec).to_vec()),
        accuracy_refinements: Some(0),
        stop: Some(StopRule::FirstCertificate),
        ..WorstRequest::default()
    };
    let outcome = wsm_core::worst(scene.clone(), &request, &RunControl::new()).unwrap();
    let names: Vec<String> = outcome
        .criteria
        .iter()
        .map(|c| c.criterion.name())
        .collect();
    assert_eq!(names, ["phi3@crest", "phi5", "phi6@heel"]);
    let crest = &outcome.criteria[0];
    assert_eq!(crest.worst.region.as_deref(), Some("crest"));
    assert_eq!(crest.best.region.as_deref(), Some("crest"));
    assert_eq!(outcome.criteria[2].worst.region.as_deref(), Some("heel"));
    // Φ5's region is where the solve at its data is largest, and the value is that region's.
    for o in [&outcome.criteria[1].worst, &outcome.criteria[1].best] {
        let point = o.point.clone().unwrap();
        let solved =
            wsm_core::solve_at(scene.clone(), Some(&point), &SolveRequest::default()).unwrap();
        let region = o.region.as_deref().expect("a region");
        assert_eq!(solved.summary.attained_in["phi5"], region);
        assert_eq!(
            solved.summary.region_values["phi5"][region],
            o.value.unwrap()
        );
    }
    // The bound crest is the crest's own value at its data, not the largest Φ3 (the heel's).
    let point = crest.worst.point.clone().unwrap();
    let solved = wsm_core::solve_at(scene, Some(&point), &SolveRequest::default()).unwrap();
    assert_eq!(
        solved.summary.region_values["phi3"]["crest"],
        crest.worst.value.unwrap()
    );
    assert_ne!(solved.summary.attained_in["phi3"], "crest");
}

#[test]
fn a_bad_binding_is_refused_and_unused_search_criteria_do_not_block_a_solve() {
    let scene = parse_scene(&dam().to_string()).unwrap();
    let refused = |criteria: &str| {
        let request = WorstRequest {
            criteria: Some(vec![spec(criteria)]),
            ..WorstRequest::default()
        };
        request.settings(&scene).unwrap_err().to_string()
    };
    let e = refused("phi3@nowhere");
    assert!(
        e.contains("criteria[0]") && e.contains("crest, toe, heel"),
        "{e}"
    );
    let e = refused("phi6@crest");
    assert!(e.contains("'crest' touches none"), "{e}");
    let e = refused("phi4@crest");
    assert!(e.contains("no boundary piece"), "{e}");
    // A scene whose own search criteria cannot be searched still solves; `wsm worst` refuses.
    let mut v = dam();
    v["search"]["criteria"] = json!(["phi6@crest"]);
    let dir = std::env::temp_dir().join(format!("wsm-binding-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("dam.json");
    std::fs::write(&path, v.to_string()).unwrap();
    let wsm = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_wsm"))
            .args(args)
            .output()
            .unwrap()
    };
    let solve = wsm(&["solve", path.to_str().unwrap()]);
    assert!(
        solve.status.success(),
        "{}",
        String::from_utf8_lossy(&solve.stderr)
    );
    let worst = wsm(&["worst", path.to_str().unwrap(), "--budget", "5"]);
    assert_eq!(worst.status.code(), Some(2));
    let err = String::from_utf8_lossy(&worst.stderr);
    assert!(
        err.contains("search.criteria[0]") && err.contains("touches none"),
        "{err}"
    );
}
