//! Failed evaluations are part of the answer (issue #22): with an injected fault that makes the
//! solver fail in one corner of the box, a run lists the failures in its result with the region
//! they cover and a plain warning, marks the extrema next to them unsettled, writes them to the
//! log and the CSV table, and a resumed run replays them as failures without recomputing; a run
//! in which most evaluations fail ends with an error instead of an empty-looking success.

use std::path::PathBuf;
use std::sync::Arc;

use serde_json::{json, Value};
use wsm_core::error::WsmError;
use wsm_core::run::{self, JsonLinesLog, LogMode, RunControl, Status, WorstRequest};
use wsm_core::scene::{parse, Criterion, Scene};

fn block() -> Scene {
    let mut v: Value =
        serde_json::from_str(wsm_core::bundled::example("block-on-base").unwrap()).unwrap();
    v["mesh"] = json!({ "max_size": 0.1 });
    parse(&v.to_string()).unwrap()
}

fn request() -> WorstRequest {
    WorstRequest {
        criteria: Some(vec![Criterion::Phi3, Criterion::Phi6]),
        budget: Some(60),
        seed: Some(5),
        threads: Some(1),
        accuracy_refinements: Some(0),
        ..WorstRequest::default()
    }
}

/// Fail where parameter `k` lies above `fraction` of its interval.
fn fault_above(scene: &Scene, k: usize, fraction: f64) -> RunControl {
    let [lo, hi] = scene.uncertain[k].interval;
    let threshold = lo + fraction * (hi - lo);
    RunControl::new().with_fault(Arc::new(move |theta: &[f64]| {
        (theta[k] > threshold)
            .then(|| format!("injected failure: θ{k} = {} > {threshold}", theta[k]))
    }))
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wsm-failed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    path
}

#[test]
fn failures_are_listed_warned_about_logged_tabled_and_replayed() {
    let scene = block();
    // The traction (parameter 1) drives the displacement Φ3: its worst lies at the upper end,
    // which fails here. The failing quarter of the box is screened like the rest (vertices,
    // random starts), so well under half of the evaluations fail.
    let [lo, hi] = scene.uncertain[1].interval;
    let threshold = lo + 0.75 * (hi - lo);
    let path = temp("failed.jsonl");
    let log = Arc::new(JsonLinesLog::new(&path, LogMode::Create));
    let control = fault_above(&scene, 1, 0.75).with_log(log.clone());
    let outcome = run::worst(scene.clone(), &request(), &control).unwrap();

    let failures = &outcome.failures;
    assert!(failures.count > 0, "{failures:?}");
    assert!(2 * failures.count <= outcome.evaluations);
    assert_eq!(failures.count, failures.listed.len().max(failures.count));
    assert!(failures.region[1][0] > threshold, "{:?}", failures.region);
    assert!(failures
        .listed
        .iter()
        .all(|f| f.error.contains("injected failure")));
    let warning = &outcome.warnings[0];
    assert!(
        warning.starts_with(&format!(
            "{} of {} evaluations failed",
            failures.count, outcome.evaluations
        )),
        "{warning}"
    );
    assert!(
        warning.contains("boundary[2].traction[0] in ["),
        "{warning}"
    );
    // The worst Φ3 sits next to the failures: not settled.
    let worst_phi3 = &outcome.criteria[0].worst;
    assert_eq!(worst_phi3.status, Status::Unsettled, "{worst_phi3:?}");
    assert!(worst_phi3.point.as_ref().unwrap()[1] <= threshold);
    // No reported extremum is a failed point.
    for c in &outcome.criteria {
        for o in [&c.worst, &c.best] {
            let point = o.point.as_ref().unwrap();
            assert!(!failures.listed.iter().any(|f| &f.point == point));
        }
    }

    // The log and the table hold every failure with its error.
    let logged = log.evaluations();
    let failed: Vec<_> = logged.iter().filter(|e| e.error.is_some()).collect();
    assert_eq!(failed.len(), failures.count);
    assert!(failed.iter().all(|e| e.values.is_none()));
    let mut table = Vec::new();
    run::write_csv(
        &mut table,
        "memory",
        &outcome.parameters,
        &[Criterion::Phi3, Criterion::Phi6],
        &logged,
    )
    .unwrap();
    let text = String::from_utf8(table).unwrap();
    let failed_rows = text
        .lines()
        .filter(|r| r.contains("injected failure"))
        .count();
    assert_eq!(failed_rows, failures.count);

    // A resumed run replays the failures (no fault now: they are not recomputed).
    let log = Arc::new(JsonLinesLog::new(&path, LogMode::Resume));
    let resumed = run::worst(scene, &request(), &RunControl::new().with_log(log)).unwrap();
    assert_eq!(resumed.new_evaluations, 0);
    assert_eq!(resumed.failures, outcome.failures);
    assert_eq!(resumed.criteria, outcome.criteria);
}

#[test]
fn a_run_where_most_evaluations_fail_ends_with_the_first_error() {
    // Seven of ten points fail, scattered over the whole box (a hash of the point's bits).
    let control = RunControl::new().with_fault(Arc::new(|theta: &[f64]| {
        let bits = theta.iter().fold(0u64, |h, x| {
            (h ^ x.to_bits()).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        });
        ((bits >> 32) % 10 < 7).then(|| "injected failure".to_string())
    }));
    match run::worst(block(), &request(), &control) {
        Err(WsmError::EvaluationsFailed {
            failed,
            evaluations,
            first,
        }) => {
            assert!(2 * failed > evaluations, "{failed} of {evaluations}");
            assert!(first.contains("injected failure"), "{first}");
        }
        other => panic!("expected EvaluationsFailed, got {other:?}"),
    }
}
