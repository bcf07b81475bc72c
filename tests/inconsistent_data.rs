//! Inconsistent data is refused at once with the reason (design §3.1, "Feasibility before
//! solving"): prescribed displacements that make two bodies overlap where both nodes of a contact
//! pair are fixed — the bundled tunnel's fault starts at (20, 0), a node of both bodies' fixed
//! bottoms — on one solve, on an admissible set, from the command line and over HTTP; a feasible
//! interval of the same datum solves.

mod common;

use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use common::{post, temp_db, Server};
use serde_json::{json, Value};

fn tunnel() -> Value {
    serde_json::from_str(wsm_core::example("tunnel-fault").unwrap()).unwrap()
}

/// The tunnel with the hanging wall's bottom pushed by `ux` (the footwall's stays 0.025 m).
fn pushed(ux: f64) -> Value {
    let mut scene = tunnel();
    scene["boundary"][0]["displacement"] = json!([ux, 0.0]);
    scene.as_object_mut().unwrap().remove("uncertain");
    scene
}

/// The tunnel's admissible set with `boundary[0].displacement[0]` in `[lo, hi]` as a ninth datum.
fn with_interval(lo: f64, hi: f64) -> Value {
    let mut scene = tunnel();
    scene["uncertain"]
        .as_array_mut()
        .unwrap()
        .push(json!({"field": "boundary[0].displacement[0]", "interval": [lo, hi]}));
    scene
}

fn write(name: &str, scene: &Value) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wsm-inconsistent-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, scene.to_string()).unwrap();
    path
}

/// Run `wsm` and return (exit code, stderr, elapsed).
fn wsm(args: &[&str]) -> (i32, String, Duration) {
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_wsm"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        start.elapsed(),
    )
}

#[test]
fn overlapping_bottoms_are_refused_by_wsm_solve_in_under_a_second_with_both_solvers() {
    let path = write("overlap.json", &pushed(0.035));
    for solver in ["direct", "dd"] {
        let (code, stderr, elapsed) = wsm(&["solve", path.to_str().unwrap(), "--solver", solver]);
        assert_eq!(code, 2, "{solver}: {stderr}");
        for needle in [
            "fault_low",
            "(20, 0)",
            "boundary[0].displacement[0]",
            "overlap by 6.000e-3 m",
            "≤ 0.025",
        ] {
            assert!(
                stderr.contains(needle),
                "{solver}: no {needle:?} in {stderr}"
            );
        }
        // Refused before the solve (a process start and the check): well under a second alone;
        // 5 s leaves room for a loaded 2-core machine.
        assert!(elapsed < Duration::from_secs(5), "{solver}: {elapsed:?}");
    }
    // Pulled back instead (the pair opens): a normal solve.
    let path = write("opening.json", &pushed(0.015));
    let (code, stderr, _) = wsm(&["solve", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
}

#[test]
fn an_admissible_set_with_overlapping_vertices_is_refused_before_any_evaluation() {
    let path = write("overlap-box.json", &with_interval(0.015, 0.035));
    let log = path.with_extension("log");
    let (code, stderr, elapsed) = wsm(&[
        "worst",
        path.to_str().unwrap(),
        "--log",
        log.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{stderr}");
    for needle in [
        "uncertain[8]",
        "boundary[0].displacement[0] = 0.035",
        "fault_low",
        "[0.015, 0.025]",
    ] {
        assert!(stderr.contains(needle), "no {needle:?} in {stderr}");
    }
    assert!(elapsed < Duration::from_secs(5), "{elapsed:?}"); // as above: room for a loaded machine
    let evaluations = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(
        evaluations.lines().count() <= 1,
        "evaluations were made: {evaluations}"
    );
    // The suggested interval is admissible as a whole.
    let feasible: wsm_core::Scene = serde_json::from_value(with_interval(0.015, 0.025)).unwrap();
    wsm_core::check_admissible_set(&feasible).unwrap();
}

/// POST `body` to `endpoint`, expect 422, and return the error body.
fn refused(addr: &str, endpoint: &str, body: &Value) -> Value {
    let reply = post(addr, endpoint, body);
    let text = String::from_utf8_lossy(&reply.body).into_owned();
    assert_eq!(reply.status, 422, "{endpoint}: {text}");
    reply.json()
}

#[test]
fn the_service_refuses_the_overlap_with_422_and_the_path() {
    let db = temp_db("inconsistent.db");
    let server = Server::start(&db, &["--workers", "1"]);
    let addr = &server.addr;
    let body = refused(addr, "/v1/solve", &json!({ "scene": pushed(0.035) }));
    assert_eq!(body["path"], "scene.boundary[0].displacement[0]", "{body}");
    assert!(
        body["detail"].as_str().unwrap().contains("fault_low"),
        "{body}"
    );

    let body = refused(
        addr,
        "/v1/jobs",
        &json!({ "scene": with_interval(0.015, 0.035) }),
    );
    assert_eq!(body["path"], "scene.uncertain[8]", "{body}");
    assert!(
        body["detail"].as_str().unwrap().contains("[0.015, 0.025]"),
        "{body}"
    );

    let reply = post(
        addr,
        "/v1/jobs",
        &json!({ "scene": with_interval(0.015, 0.025), "settings": {"budget": 20} }),
    );
    assert_eq!(
        reply.status,
        202,
        "{:?}",
        String::from_utf8_lossy(&reply.body)
    );
}

#[test]
fn a_bilateral_pair_pulled_apart_by_its_fixed_nodes_is_refused_and_a_consistent_one_solves() {
    let tied = |ux: f64| {
        let mut scene = pushed(ux);
        scene["contacts"][0]["kind"] = json!("bilateral");
        scene["contacts"][0]
            .as_object_mut()
            .unwrap()
            .remove("slip_limit"); // frictionless
        scene
    };
    let path = write("tied-apart.json", &tied(0.015));
    let (code, stderr, elapsed) = wsm(&["solve", path.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    for needle in [
        "fault_low",
        "pull the tied bodies apart by 6.000e-3 m",
        "boundary[1].displacement[0] = 0.015",
    ] {
        assert!(stderr.contains(needle), "no {needle:?} in {stderr}");
    }
    assert!(elapsed < Duration::from_secs(5), "{elapsed:?}"); // as above: room for a loaded machine
    let path = write("tied-together.json", &tied(0.025));
    let (code, stderr, _) = wsm(&["solve", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
}
