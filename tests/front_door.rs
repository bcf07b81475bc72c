//! The front door (`wsm_core::run`) and the `wsm worst` command around it: cancellation and the time
//! limit return partial outcomes with their status, an evaluation log survives SIGKILL and a
//! resumed run ends bit-identical to an uninterrupted one, logs of other runs are refused, a
//! cut last line is redone, the CSV table has one row per evaluation, and the thread count does
//! not change the result.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::{json, Value};
use wsm_core::{
    parse_scene, Criterion, EvaluationLog, JsonLinesLog, LogMode, MemoryLog, RunControl, RunPhase,
    Scene, Status, WorstOutcome, WorstRequest, WsmError,
};

/// The block pushed on a base with a coarse mesh (fast solves).
fn block(max_size: f64) -> Scene {
    let mut v: Value = serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    v["mesh"] = json!({ "max_size": max_size });
    parse_scene(&v.to_string()).unwrap()
}

fn request(budget: usize, threads: usize) -> WorstRequest {
    WorstRequest {
        criteria: Some(vec![Criterion::Phi3.into(), Criterion::Phi6.into()]),
        budget: Some(budget),
        seed: Some(5),
        threads: Some(threads),
        ..WorstRequest::default()
    }
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wsm-front-door-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    path
}

#[test]
fn cancel_mid_search_returns_the_partial_result_with_its_best_values() {
    let control = RunControl::new();
    let cancel = control.cancel.clone();
    let phases = Arc::new(std::sync::Mutex::new(Vec::new()));
    let at_cancel = Arc::new(std::sync::Mutex::new(None));
    let (seen, at) = (phases.clone(), at_cancel.clone());
    let control = control.with_progress(move |e| {
        seen.lock().unwrap().push(e.phase);
        // Cancel during the swarm, after the screening batch.
        if e.phase == RunPhase::Swarm && !cancel.load(Ordering::SeqCst) {
            cancel.store(true, Ordering::SeqCst);
            *at.lock().unwrap() = Some(e.evaluations);
        }
    });
    // Without derivatives: the walk would certify this block before any swarm.
    let plain = WorstRequest {
        derivatives: Some(false),
        ..request(200, 1)
    };
    let outcome = wsm_core::worst(block(0.1), &plain, &control).unwrap();
    assert_eq!(outcome.status, Status::Cancelled);
    let at_cancel = at_cancel.lock().unwrap().expect("cancelled in the swarm");
    assert_eq!(
        outcome.evaluations, at_cancel,
        "no batch after the cancel request"
    );
    assert!(outcome.evaluations < 200);
    for c in &outcome.criteria {
        assert!(c.worst.value.is_some() && c.best.value.is_some());
        assert_eq!(c.worst.point.as_ref().unwrap().len(), 3);
    }
    let phases = phases.lock().unwrap();
    let order = [
        RunPhase::Meshing,
        RunPhase::AdmissibleCheck,
        RunPhase::NominalSolve,
        RunPhase::Screening,
    ];
    assert_eq!(&phases[..4], &order, "phases in order: {phases:?}");
    let json = serde_json::to_value(&outcome).unwrap();
    assert_eq!(json["status"], "cancelled");
}

#[test]
fn cancel_before_the_search_returns_an_unstarted_outcome() {
    let control = RunControl::new();
    let cancel = control.cancel.clone();
    let control = control.with_progress(move |e| {
        if e.phase == RunPhase::AdmissibleCheck {
            cancel.store(true, Ordering::SeqCst);
        }
    });
    let outcome = wsm_core::worst(block(0.1), &request(50, 1), &control).unwrap();
    assert_eq!(outcome.status, Status::Cancelled);
    assert_eq!(outcome.evaluations, 0);
    assert_eq!(outcome.criteria.len(), 2);
    assert!(outcome.criteria[0].worst.value.is_none());
}

#[test]
fn time_limit_returns_the_partial_result_with_status_time_limit() {
    // Derivative-free: with exact derivatives this search certifies both criteria within the
    // half second, and the time limit would never be reached.
    let mut req = request(100_000, 1);
    req.max_seconds = Some(0.5);
    req.derivatives = Some(false);
    let start = Instant::now();
    let outcome = wsm_core::worst(block(0.1), &req, &RunControl::new()).unwrap();
    assert_eq!(outcome.status, Status::TimeLimit);
    assert!(start.elapsed() < Duration::from_secs(10));
    assert!(outcome.evaluations > 0 && outcome.evaluations < 100_000);
    assert_eq!(
        serde_json::to_value(&outcome).unwrap()["status"],
        "time_limit"
    );
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let one = wsm_core::worst(block(0.1), &request(40, 1), &RunControl::new()).unwrap();
    let two = wsm_core::worst(block(0.1), &request(40, 2), &RunControl::new()).unwrap();
    assert_eq!(one.criteria, two.criteria);
    assert_eq!(one.run_hash, two.run_hash);
}

#[test]
fn a_log_of_another_run_is_refused_naming_the_hashes() {
    let path = temp("other.jsonl");
    let log = Arc::new(JsonLinesLog::new(&path, LogMode::Create));
    wsm_core::worst(
        block(0.1),
        &request(10, 1),
        &RunControl::new().with_log(log),
    )
    .unwrap();
    // Other criteria: another run.
    let mut other = request(10, 1);
    other.criteria = Some(vec![Criterion::Phi5.into()]);
    let log = Arc::new(JsonLinesLog::new(&path, LogMode::Resume));
    let err = wsm_core::worst(block(0.1), &other, &RunControl::new().with_log(log)).unwrap_err();
    assert!(matches!(err, WsmError::LogMismatch { .. }), "{err}");
    assert!(err.to_string().contains("hash"), "{err}");
    // Another scene.
    let log = Arc::new(JsonLinesLog::new(&path, LogMode::Resume));
    let err = wsm_core::worst(
        block(0.12),
        &request(10, 1),
        &RunControl::new().with_log(log),
    );
    assert!(matches!(err, Err(WsmError::LogMismatch { .. })));
    // A new log never overwrites one.
    let log = Arc::new(JsonLinesLog::new(&path, LogMode::Create));
    let err = wsm_core::worst(
        block(0.1),
        &request(10, 1),
        &RunControl::new().with_log(log),
    );
    assert!(matches!(err, Err(WsmError::Io { .. })));
}

/// Complete lines of a log file (header included).
fn complete_lines(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .matches('\n')
        .count()
}

/// Run `request` on `scene` with a log, cut the log after `kept` records and half of the next,
/// resume: the same result, with only the cut evaluations redone.
fn cut_and_resume(scene: Scene, request: &WorstRequest, kept: usize, name: &str) {
    let path = temp(name);
    let log = Arc::new(JsonLinesLog::new(&path, LogMode::Create));
    let full = wsm_core::worst(scene.clone(), request, &RunControl::new().with_log(log)).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines.len() > kept + 1, "{} evaluations", full.evaluations);
    // Keep the header and `kept` records, then half of the next.
    let mut cut = lines[..=kept].join("\n");
    cut.push('\n');
    cut.push_str(&lines[kept + 1][..lines[kept + 1].len() / 2]);
    std::fs::write(&path, cut).unwrap();
    let log = Arc::new(JsonLinesLog::new(&path, LogMode::Resume));
    let resumed =
        wsm_core::worst(scene, request, &RunControl::new().with_log(log.clone())).unwrap();
    assert_eq!(resumed.criteria, full.criteria);
    assert_eq!(resumed.new_evaluations, full.evaluations - kept);
    // The file is whole again: header + one line per evaluation.
    assert_eq!(complete_lines(&path), 1 + full.evaluations);
    assert_eq!(log.evaluations().len(), full.evaluations);
}

#[test]
fn a_cut_last_line_is_dropped_and_that_evaluation_redone() {
    let plain = WorstRequest {
        derivatives: Some(false),
        ..request(30, 1)
    };
    cut_and_resume(block(0.1), &plain, 10, "cut.jsonl");
}

/// With derivatives the log holds the gradients: the resumed walk, ascent and certificates
/// make the same decisions from the replayed slopes.
#[test]
fn a_resumed_run_with_derivatives_replays_the_gradients() {
    let tunnel = parse_scene(wsm_core::example("tunnel-fault").unwrap()).unwrap();
    let request = WorstRequest {
        budget: Some(120),
        seed: Some(1),
        threads: Some(2),
        accuracy_refinements: Some(0),
        ..WorstRequest::default()
    };
    cut_and_resume(tunnel, &request, 30, "cut-gradients.jsonl");
}

#[test]
fn the_table_has_one_row_per_evaluation_with_the_right_columns() {
    let log = Arc::new(MemoryLog::new());
    let outcome = wsm_core::worst(
        block(0.1),
        &request(25, 1),
        &RunControl::new().with_log(log.clone() as Arc<dyn EvaluationLog>),
    )
    .unwrap();
    let evaluations = log.evaluations();
    assert_eq!(evaluations.len(), outcome.new_evaluations);
    let mut buffer = Vec::new();
    wsm_core::write_csv(
        &mut buffer,
        "memory",
        &outcome.parameters,
        &[Criterion::Phi3.into(), Criterion::Phi6.into()],
        &evaluations,
    )
    .unwrap();
    let text = String::from_utf8(buffer).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(
        rows[0],
        "id,materials.rock.E,boundary[2].traction[0],contacts[joint].slip_limit,phi3,phi6,max_kkt_residual,solve_seconds,error,\
         d(phi3)/d(materials.rock.E),d(phi3)/d(boundary[2].traction[0]),d(phi3)/d(contacts[joint].slip_limit),\
         d(phi6)/d(materials.rock.E),d(phi6)/d(boundary[2].traction[0]),d(phi6)/d(contacts[joint].slip_limit),\
         d(phi3)/d(materials.rock.E):left,d(phi3)/d(boundary[2].traction[0]):left,d(phi3)/d(contacts[joint].slip_limit):left,\
         d(phi6)/d(materials.rock.E):left,d(phi6)/d(boundary[2].traction[0]):left,d(phi6)/d(contacts[joint].slip_limit):left"
    );
    assert_eq!(rows.len(), 1 + evaluations.len());
    for (i, row) in rows[1..].iter().enumerate() {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells.len(), 21, "{row}");
        assert_eq!(cells[0], (i + 1).to_string());
        let e = &evaluations[i];
        for (k, x) in e.point.iter().enumerate() {
            assert_eq!(cells[1 + k].parse::<f64>().unwrap(), *x, "exact round trip");
        }
        let phi3: f64 = cells[4].parse().unwrap();
        assert_eq!(phi3, e.values.as_ref().unwrap()[0]);
        // ∂Φ/∂θ exact and numeric: the right derivative, and the left one only where it
        // differs.
        for (k, j) in [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)] {
            let slope = e.gradient[k][j];
            let (right, left) = (cells[9 + 3 * k + j], cells[15 + 3 * k + j]);
            assert_eq!(right.parse::<f64>().unwrap(), slope.right, "{row}");
            if slope.left == slope.right {
                assert_eq!(left, "", "{row}");
            } else {
                assert_eq!(left.parse::<f64>().unwrap(), slope.left, "{row}");
            }
        }
        assert!(
            cells[6].parse::<f64>().unwrap() < 1e-8,
            "KKT residual {}",
            cells[6]
        );
    }
}

fn wsm() -> Command {
    Command::new(env!("CARGO_BIN_EXE_wsm"))
}

fn worst_args(extra: &[&str]) -> Vec<String> {
    [
        "worst",
        "--example",
        "block-on-base",
        "--budget",
        "120",
        "--seed",
        "5",
        "--threads",
        "1",
        "--criteria",
        "phi3,phi6",
        // A long enough run to be killed in (the walk would certify this block in 3 solves).
        "--no-derivatives",
    ]
    .iter()
    .chain(extra)
    .map(|s| s.to_string())
    .collect()
}

fn read_outcome(path: &Path) -> WorstOutcome {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn a_run_killed_with_sigkill_and_resumed_ends_bit_identical() {
    let whole = temp("whole.json");
    let status = wsm()
        .args(worst_args(&["--out", whole.to_str().unwrap()]))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let whole = read_outcome(&whole);

    let log = temp("killed.jsonl");
    let mut child = wsm()
        .args(worst_args(&["--log", log.to_str().unwrap()]))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while complete_lines(&log) < 21 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    let status = child.wait().unwrap();
    assert!(!status.success(), "the run must be killed before it ends");
    let logged = complete_lines(&log) - 1;
    assert!(
        logged >= 20 && logged < whole.evaluations,
        "{logged} logged"
    );

    let resumed = temp("resumed.json");
    let output = wsm()
        .args(worst_args(&[
            "--resume",
            log.to_str().unwrap(),
            "--out",
            resumed.to_str().unwrap(),
        ]))
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let resumed = read_outcome(&resumed);
    assert_eq!(
        resumed.criteria, whole.criteria,
        "values and data bit-identical"
    );
    assert_eq!(resumed.status, whole.status);
    assert_eq!(resumed.evaluations, whole.evaluations);
    assert_eq!(resumed.new_evaluations, whole.evaluations - logged);
}

#[test]
fn the_command_line_writes_the_table_and_refuses_a_foreign_log() {
    let log = temp("cli.jsonl");
    let table = temp("cli.csv");
    let output = wsm()
        .args(worst_args(&[
            "--log",
            log.to_str().unwrap(),
            "--table",
            table.to_str().unwrap(),
        ]))
        .output()
        .unwrap();
    assert!(output.status.success());
    let printed: WorstOutcome = serde_json::from_slice(&output.stdout).unwrap();
    let rows = std::fs::read_to_string(&table).unwrap().lines().count();
    assert_eq!(rows, 1 + printed.evaluations);
    // Same log, other criteria: refused with exit code 5 and the hashes named.
    let output = wsm()
        .args([
            "worst",
            "--example",
            "block-on-base",
            "--budget",
            "10",
            "--criteria",
            "phi5",
            "--resume",
            log.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(5));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("belongs to another run") && stderr.contains("hash"),
        "{stderr}"
    );
    let mut f = std::fs::OpenOptions::new().append(true).open(&log).unwrap();
    writeln!(f, "not json").unwrap();
    let output = wsm()
        .args(worst_args(&["--resume", log.to_str().unwrap()]))
        .output()
        .unwrap();
    assert_eq!(
        output.status.code(),
        Some(5),
        "a corrupt complete line is an error"
    );
    // Unknown example: exit code 2 and its name.
    let output = wsm().args(["solve", "--example", "nope"]).output().unwrap();
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("'nope'"));
}

/// The service, the binary and the Python package reach the engine only through its front door:
/// the re-exports of `wsm_core`'s `run` (requests, outcomes, examples, cost), `scene` (the
/// document they pass in) and `error` (what comes back) — no engine stage (design §5). The door
/// is read from `crates/core/src/lib.rs` (every `pub use run::…`, `scene::…`, `error::…`
/// statement); every `wsm_core::` name in `src/`, `crates/service/src/` and `crates/python/src/`
/// must be one of its names.
#[test]
fn service_and_binary_use_only_the_front_door() {
    const DOOR: [&str; 3] = ["run", "scene", "error"];
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = std::fs::read_to_string(root.join("crates/core/src/lib.rs")).unwrap();
    let door = public_names(&lib, &DOOR);
    assert!(
        ["WorstRequest", "Scene", "WsmError", "parse_scene"]
            .iter()
            .all(|n| door.contains(*n)),
        "the door as read from lib.rs: {door:?}"
    );
    let mut files = Vec::new();
    let mut stack = vec![
        root.join("src"),
        root.join("crates/service/src"),
        root.join("crates/python/src"),
    ];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    assert!(files.len() > 10, "{} files", files.len());
    let mut violations = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let mut rest = text.as_str();
        while let Some(at) = rest.find("wsm_core::") {
            rest = &rest[at + "wsm_core::".len()..];
            // `wsm_core::{A, B as C}` lists are checked name by name.
            let names: Vec<&str> = match rest.strip_prefix('{') {
                Some(list) => list
                    .split('}')
                    .next()
                    .unwrap_or_default()
                    .split(',')
                    .map(|n| n.split_whitespace().next().unwrap_or_default())
                    .filter(|n| !n.is_empty())
                    .collect(),
                None => vec![rest
                    .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .next()
                    .unwrap_or_default()],
            };
            for name in names {
                if !door.contains(name) {
                    violations.push(format!("{}: wsm_core::{name}", file.display()));
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "past the front door:\n{}",
        violations.join("\n")
    );
}

/// The names `lib` re-exports from the modules `from` (`pub use m::{…};` and `pub use m::…;`
/// statements at the start of a line, `x as y` giving `y`).
fn public_names(lib: &str, from: &[&str]) -> std::collections::BTreeSet<String> {
    let mut names = std::collections::BTreeSet::new();
    for (at, _) in lib.match_indices("\npub use ") {
        let path = &lib[at + "\npub use ".len()..];
        let path = &path[..path.find(';').unwrap_or(path.len())];
        if !from.iter().any(|m| path.starts_with(&format!("{m}::"))) {
            continue;
        }
        let list = match path.find('{') {
            Some(open) => &path[open + 1..path.rfind('}').unwrap_or(path.len())],
            None => path.rsplit("::").next().unwrap_or_default(),
        };
        for item in list.split(',') {
            let item = item.trim();
            let name = item.rsplit(" as ").next().unwrap_or(item).trim();
            if !name.is_empty() {
                names.insert(name.to_string());
            }
        }
    }
    names
}
