//! A new user's first model (docs/verification.md, "A user's data"; design §4.1): a gravity dam on
//! rock with a Coulomb joint, three uncertain data (`tests/data/dam-coulomb-3data.json`). Its data
//! are checked for what they mean: a datum addressed by name stays on its entry when entries are
//! inserted (an index moves), an index to a named entry is answered with a warning first in
//! `wsm solve`'s and `wsm worst`'s warnings, a nominal value outside its own interval is refused by
//! every front door, and the crest piece (4 m, as long as an element or shorter on coarse meshes)
//! is measured on any mesh.

use std::path::PathBuf;
use std::process::Command;

use serde_json::{json, Value};
use wsm_core::{
    parse_scene, Criterion, RunControl, Scene, SolveRequest, StateProblem, WarningKind,
    WorstRequest, WsmError,
};

fn dam() -> Value {
    serde_json::from_str(include_str!("data/dam-coulomb-3data.json")).unwrap()
}

/// The dam with its upstream pressures named after their segments (`up1` … `up7`).
fn named_dam() -> Value {
    let mut v = dam();
    for bc in v["boundary"].as_array_mut().unwrap() {
        let segment = bc["segment"].clone();
        if segment.as_str().unwrap().starts_with("up") {
            bc["name"] = segment;
        }
    }
    v
}

fn scene(v: &Value) -> Scene {
    parse_scene(&v.to_string()).unwrap()
}

/// Criteria Φ1..Φ6 of one solve at the data `point` (in the order of `uncertain`).
fn criteria_at(v: &Value, point: &[f64]) -> [Option<f64>; 6] {
    let output = wsm_core::solve_at(scene(v), Some(point), &SolveRequest::default()).unwrap();
    let c = output.summary.criteria;
    [c.phi1, c.phi2, c.phi3, c.phi4, c.phi5, c.phi6]
}

fn write(name: &str, v: &Value) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wsm-dam-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, v.to_string()).unwrap();
    path
}

/// `wsm ARGS`: exit code, stdout, stderr.
fn wsm(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_wsm"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The bug recalled in design §4.1 ("a user's dam run once answered for another segment"):
/// inserting a boundary entry moved `boundary[4].pressure` from `up1` onto `reservoir_bed`, still
/// inside its interval, and the run answered other numbers without a word. By name the datum stays
/// on `up1`: the same results, bit for bit (the inserted entry is a zero pressure, which adds
/// nothing).
#[test]
fn a_named_datum_stays_on_its_entry_when_entries_are_inserted() {
    let mut by_name = named_dam();
    by_name["uncertain"][2]["field"] = json!("boundary[up1].pressure");
    let mut by_index = named_dam();
    by_index["uncertain"][2]["field"] = json!("boundary[4].pressure");
    let point = [5.0e9, 0.7, 2.7e5];
    let before = criteria_at(&by_name, &point);
    assert_eq!(before, criteria_at(&by_index, &point));

    let zero_load = json!({ "segment": "crest", "pressure": 0.0 });
    for v in [&mut by_name, &mut by_index] {
        v["boundary"]
            .as_array_mut()
            .unwrap()
            .insert(0, zero_load.clone());
    }
    assert_eq!(criteria_at(&by_name, &point), before);
    let moved = criteria_at(&by_index, &point);
    assert_ne!(moved, before, "the index now points at the reservoir bed");
    // The parameter keeps the path as written.
    let info = wsm_core::parameter_info(&scene(&by_name)).unwrap();
    assert_eq!(info[2].field, "boundary[up1].pressure");
}

/// An index path to a named entry is answered with a warning that names the entry, first in
/// the warnings of `wsm solve` (in-process and on stderr) and of `wsm worst`.
#[test]
fn an_index_to_a_named_entry_is_warned_first_by_solve_and_worst() {
    let v = named_dam();
    let expected = "uncertain[2].field: boundary[4] is the entry named 'up1'; refer to it as \
                    boundary[up1] so that inserting entries cannot move the datum";
    let solved = wsm_core::solve(scene(&v), &SolveRequest::default()).unwrap();
    let warnings = &solved.summary.report.warnings;
    // In the order of `uncertain`: the contact zone's index path (entry 1) first.
    assert!(warnings.iter().all(|w| w.kind == WarningKind::DataPath));
    assert!(
        warnings[0].to_string().starts_with(
            "uncertain[1].field: contacts[0] is the entry named 'dam_foundation_joint'; refer to \
             it as contacts[dam_foundation_joint]"
        ),
        "{warnings:?}"
    );
    assert_eq!(warnings[1].to_string(), expected);

    let request = WorstRequest {
        criteria: Some(vec![Criterion::Phi3.into()]),
        budget: Some(3),
        accuracy_refinements: Some(0),
        ..WorstRequest::default()
    };
    let outcome = wsm_core::worst(scene(&v), &request, &RunControl::new()).unwrap();
    assert_eq!(
        outcome.warnings[1].to_string(),
        expected,
        "{:?}",
        outcome.warnings
    );

    let path = write("indexed.json", &v);
    let (code, _, stderr) = wsm(&["solve", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains(&format!("warning: {expected}")), "{stderr}");

    // By name: no warning at all (the dam's magnitudes are plausible).
    let mut by_name = v.clone();
    by_name["uncertain"][1]["field"] = json!("contacts[dam_foundation_joint].friction_coefficient");
    by_name["uncertain"][2]["field"] = json!("boundary[up1].pressure");
    let solved = wsm_core::solve(scene(&by_name), &SolveRequest::default()).unwrap();
    assert!(
        solved.summary.report.warnings.is_empty(),
        "{:?}",
        solved.summary.report.warnings
    );
}

/// A nominal value outside its own interval is refused, naming the entry, the field and both
/// numbers: by the scene's validation (which the CLI and the service parse with) and by the
/// front door itself for a scene that skipped it.
#[test]
fn a_nominal_value_outside_its_interval_is_refused_by_every_front_door() {
    let mut v = dam();
    v["contacts"][0]["friction_coefficient"] = json!(0.9);
    let reason = "the nominal value 0.9 of contacts[0].friction_coefficient lies outside its \
                  interval [0.5, 0.8]";

    let error = parse_scene(&v.to_string()).unwrap_err();
    assert_eq!(error.path, "uncertain[1]");
    assert!(error.reason.starts_with(reason), "{}", error.reason);

    // A scene deserialised without validation meets the same rule at the front door.
    let unchecked: Scene = serde_json::from_value(v.clone()).unwrap();
    let refused = |result: Result<(), WsmError>| {
        let text = result.unwrap_err().to_string();
        assert!(text.contains(&format!("uncertain[1]: {reason}")), "{text}");
    };
    refused(wsm_core::solve(unchecked.clone(), &SolveRequest::default()).map(drop));
    refused(
        wsm_core::worst(
            unchecked.clone(),
            &WorstRequest::default(),
            &RunControl::new(),
        )
        .map(drop),
    );
    refused(wsm_core::parameter_info(&unchecked).map(drop));

    let path = write("outside.json", &v);
    for command in ["solve", "worst"] {
        let (code, _, stderr) = wsm(&[command, path.to_str().unwrap()]);
        assert_eq!(code, 2, "{command}: {stderr}");
        assert!(
            stderr.contains(&format!("uncertain[1]: {reason}")),
            "{command}: {stderr}"
        );
    }
}

/// The crest piece lies on a segment drawn clockwise around the dam, over one or two edges on
/// coarse meshes: it is measured on the mesh at every size (it was refused as "zero length"
/// at twice the mesh size and coarser), its length is the crest's 4 m, and √Φ5 is reported
/// beside Φ5.
#[test]
fn the_crest_piece_is_measured_on_every_mesh() {
    for factor in [1.0, 2.0, 4.0, 8.0] {
        let mut v = dam();
        v["mesh"]["max_size"] = json!(4.0 * factor);
        for r in v["mesh"]["refine"].as_array_mut().unwrap() {
            r["max_size"] = json!(r["max_size"].as_f64().unwrap() * factor);
        }
        let problem = StateProblem::new(scene(&v)).unwrap();
        let crest = &problem.criteria.pieces[0];
        assert!(
            (crest.length - 4.0).abs() < 1e-12,
            "×{factor}: {}",
            crest.length
        );
        let summary = wsm_core::solve(scene(&v), &SolveRequest::default())
            .unwrap()
            .summary;
        let phi4 = summary.criteria.phi4.unwrap();
        // The crest moves downstream and down: its outward normal (0, 1) sees a settlement.
        assert!(phi4 < 0.0 && phi4.is_finite(), "×{factor}: {phi4}");
        let phi5 = summary.criteria.phi5.unwrap();
        assert_eq!(summary.criteria.phi5_equivalent_stress, Some(phi5.sqrt()));
    }
}
