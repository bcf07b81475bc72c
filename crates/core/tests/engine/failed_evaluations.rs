//! Failed evaluations are part of the answer (design §4.3, "Failed evaluations"): with an injected
//! fault that makes the solver fail in one corner of the box, a run lists the failures in its
//! result with the region they cover and a plain warning, marks the extrema next to them unsettled,
//! writes them to the log and the CSV table, and a resumed run replays them as failures without
//! recomputing; a run in which most evaluations fail ends with an error instead of an empty-looking
//! success.
//!
//! No failure is hidden beyond the search either (design §6, "No failure hidden"): a failed refined
//! solve of the accuracy statement is listed, warned about and makes the statement incomplete, and
//! a mesh of the target-error ladder that fails is warned about while the run goes on with those
//! that solved.

use std::path::PathBuf;
use std::sync::Arc;

use serde_json::{json, Value};
use wsm_core::{
    parse_scene, Criterion, FaultSite, JsonLinesLog, LogMode, RunControl, Scene, Status, Warning,
    WarningKind, WorstRequest, WsmError,
};

fn block() -> Scene {
    let mut v: Value = serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    v["mesh"] = json!({ "max_size": 0.1 });
    parse_scene(&v.to_string()).unwrap()
}

fn request() -> WorstRequest {
    WorstRequest {
        criteria: Some(vec![Criterion::Phi3.into(), Criterion::Phi6.into()]),
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
    RunControl::new().with_fault(Arc::new(move |site: &FaultSite<'_>| match site {
        FaultSite::Evaluation { point } => (point[k] > threshold)
            .then(|| format!("injected failure: θ{k} = {} > {threshold}", point[k])),
        _ => None,
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
    let outcome = wsm_core::worst(scene.clone(), &request(), &control).unwrap();

    let failures = &outcome.failures;
    assert!(failures.count > 0, "{failures:?}");
    assert!(2 * failures.count <= outcome.evaluations);
    assert_eq!(failures.count, failures.listed.len().max(failures.count));
    assert!(failures.region[1][0] > threshold, "{:?}", failures.region);
    assert!(failures
        .listed
        .iter()
        .all(|f| f.error.contains("injected failure")));
    assert_eq!(outcome.warnings[0].kind, WarningKind::FailedEvaluations);
    let warning = outcome.warnings[0].to_string();
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
    wsm_core::write_csv(
        &mut table,
        "memory",
        &outcome.parameters,
        &[Criterion::Phi3.into(), Criterion::Phi6.into()],
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
    let resumed = wsm_core::worst(scene, &request(), &RunControl::new().with_log(log)).unwrap();
    assert_eq!(resumed.new_evaluations, 0);
    assert_eq!(resumed.failures, outcome.failures);
    assert_eq!(resumed.criteria, outcome.criteria);
}

#[test]
fn a_run_where_most_evaluations_fail_ends_with_the_first_error() {
    // Seven of ten points fail, scattered over the whole box (a hash of the point's bits).
    let control = RunControl::new().with_fault(Arc::new(|site: &FaultSite<'_>| {
        let FaultSite::Evaluation { point } = site else {
            return None;
        };
        let bits = point.iter().fold(0u64, |h, x| {
            (h ^ x.to_bits()).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        });
        ((bits >> 32) % 10 < 7).then(|| "injected failure".to_string())
    }));
    match wsm_core::worst(block(), &request(), &control) {
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

/// The extremum of `outcome` that `[worst, best][side]` of criterion `k` names: its point.
fn extremum_point(outcome: &wsm_core::WorstOutcome, k: usize, side: usize) -> Vec<f64> {
    outcome.extrema()[k][side].clone().unwrap().1
}

#[test]
fn failed_refined_solves_are_warned_about_and_leave_the_statement_incomplete() {
    let scene = block();
    let request = WorstRequest {
        accuracy_refinements: Some(2),
        ..request()
    };
    // Refinement 1 fails where the traction (parameter 1) lies in the upper half of its
    // interval, refinement 2 everywhere (with the same error); the search's evaluations solve as
    // usual.
    let [lo, hi] = scene.uncertain[1].interval;
    let threshold = lo + 0.5 * (hi - lo);
    let fault = RunControl::new().with_fault(Arc::new(move |site: &FaultSite<'_>| match site {
        FaultSite::Refined { level, point } if *level == 2 || point[1] > threshold => {
            Some(format!("injected failure: traction {}", point[1]))
        }
        _ => None,
    }));
    let plain = wsm_core::worst(scene.clone(), &request, &RunControl::new()).unwrap();
    let faulty = wsm_core::worst(scene, &request, &fault).unwrap();
    assert_eq!(faulty.criteria, plain.criteria, "the search is untouched");
    let (a, p) = (faulty.accuracy.clone().unwrap(), plain.accuracy.unwrap());
    assert!(p.complete && p.failures.is_empty(), "{p:#?}");
    assert!(!a.complete);
    let sizes = |meshes: &[wsm_core::StatementMesh]| -> Vec<(usize, usize)> {
        meshes.iter().map(|m| (m.unknowns, m.triangles)).collect()
    };
    assert_eq!(
        sizes(&a.meshes),
        sizes(&p.meshes),
        "every refined mesh was built"
    );

    let (mut unknown, mut one_mesh) = (Vec::new(), Vec::new());
    for (k, (c, pc)) in a.criteria.iter().zip(&p.criteria).enumerate() {
        for (side, (entry, plain_entry)) in [(&c.worst, &pc.worst), (&c.best, &pc.best)]
            .into_iter()
            .enumerate()
        {
            let (e, pe) = (entry.as_ref().unwrap(), plain_entry.as_ref().unwrap());
            let point = extremum_point(&faulty, k, side);
            let failure = e.failure.as_deref().unwrap();
            let error = format!("contact solver: injected failure: traction {}", point[1]);
            if point[1] > threshold {
                // Both refined solves failed: no estimate at all.
                assert_eq!(e.refined, vec![None, None]);
                assert_eq!((e.estimate, e.relative), (None, None));
                assert_eq!(
                    failure,
                    format!("refinement 1: {error}; refinement 2: {error}")
                );
                unknown.push(point);
            } else {
                // Refinement 1 solved, bit for bit as without the fault: the estimate rests on it.
                assert_eq!(e.refined, vec![pe.refined[0], None]);
                assert_eq!(e.estimate, Some((e.value - pe.refined[0].unwrap()).abs()));
                assert_eq!(failure, format!("refinement 2: {error}"));
                one_mesh.push(point);
            }
        }
    }
    assert!(
        !unknown.is_empty() && !one_mesh.is_empty(),
        "both kinds of extremum occur"
    );
    let distinct = a.points;
    assert_eq!(
        distinct_count(&unknown) + distinct_count(&one_mesh),
        distinct
    );

    // Every failed solve is listed once, with the extrema at its data.
    assert_eq!(a.failures.len(), distinct + distinct_count(&unknown));
    for f in &a.failures {
        assert!(f.level == 2 || f.point[1] > threshold, "{f:?}");
        for (k, criterion) in [Criterion::Phi3, Criterion::Phi6].into_iter().enumerate() {
            for (side, listed) in [&f.worst_of, &f.best_of].into_iter().enumerate() {
                let here = extremum_point(&faulty, k, side) == f.point;
                assert_eq!(listed.contains(&criterion.into()), here, "{f:?}");
            }
        }
    }

    // One warning per failed data, in plain words; the other warnings are the plain run's.
    let (statement, others): (Vec<&Warning>, Vec<&Warning>) = faulty
        .warnings
        .iter()
        .partition(|w| w.kind == WarningKind::Accuracy);
    assert_eq!(others, plain.warnings.iter().collect::<Vec<_>>());
    assert_eq!(statement.len(), distinct, "{statement:#?}");
    let on = |level: usize| {
        let mesh = &a.meshes[level];
        format!(
            "refinement {level} (mesh sizes × {}, {} unknowns)",
            mesh.size_factor, mesh.unknowns
        )
    };
    for w in &statement {
        // The same error on both refinements is said once.
        let both = format!(
            "failed on {} and {}: contact solver: injected failure",
            on(1),
            on(2)
        );
        let second = format!("failed on {}: contact solver: injected failure", on(2));
        if w.contains(&both) {
            assert!(
                w.message
                    .ends_with("The discretisation error of this value is unknown.")
                    || w.message
                        .ends_with("The discretisation error of these values is unknown."),
                "{w}"
            );
        } else {
            assert!(w.contains(&second), "{w}");
            assert!(w.message.ends_with("rests on refinement 1 alone."), "{w}");
        }
    }
    let worst_phi3 = extremum_point(&faulty, 0, 0);
    assert!(
        worst_phi3[1] > threshold,
        "the traction drives the worst Φ3 up"
    );
    assert!(statement
        .iter()
        .any(|w| w.contains("the worst data of Φ3") && w.message.ends_with("is unknown.")));
}

fn distinct_count(points: &[Vec<f64>]) -> usize {
    let mut seen: Vec<&Vec<f64>> = Vec::new();
    for p in points {
        if !seen.contains(&p) {
            seen.push(p);
        }
    }
    seen.len()
}

#[test]
fn a_target_error_run_goes_on_past_a_ladder_mesh_that_fails() {
    let fault = RunControl::new().with_fault(Arc::new(|site: &FaultSite<'_>| match site {
        FaultSite::MeshChoice { size_factor } if *size_factor == 2.0 => {
            Some("injected failure on the ladder".to_string())
        }
        _ => None,
    }));
    let request = WorstRequest {
        target_error: Some(0.02),
        ..request()
    };
    let outcome = wsm_core::worst(block(), &request, &fault).unwrap();
    let choice = outcome.mesh_choice.as_ref().unwrap();
    let failed = &choice.candidates[1];
    assert_eq!(failed.size_factor, 2.0);
    assert_eq!(
        failed.failure.as_deref(),
        Some("contact solver: injected failure on the ladder")
    );
    assert!(failed.values.iter().all(Option::is_none) && !failed.meets_target);
    // The coarsest level's estimate needed the failed one: not met either.
    assert!(!choice.candidates[0].meets_target);
    assert_eq!(choice.candidates[0].relative_errors, vec![None, None]);
    // The run went on with a level that solved and met the target.
    assert!(choice.met && choice.size_factor <= 1.0, "{choice:#?}");
    let chosen = choice
        .candidates
        .iter()
        .find(|c| c.size_factor == choice.size_factor)
        .unwrap();
    assert!(chosen.failure.is_none() && chosen.meets_target);
    assert!(outcome.extrema().iter().flatten().all(Option::is_some));
    let warning = format!(
        "target_error: the solve at the nominal data on the ladder's mesh with sizes × 2 ({} \
         unknowns) failed: contact solver: injected failure on the ladder. That mesh cannot be \
         chosen, and the error of the mesh with sizes × 4 cannot be estimated with it.",
        failed.unknowns
    );
    assert!(
        outcome.warnings.iter().any(|w| w.to_string() == warning),
        "{:#?}",
        outcome.warnings
    );
}
