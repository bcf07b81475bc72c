//! The solve-cost limit of the command line (design §3.1, issue #44): the probe's block-on-base
//! with `mesh.refine[0].max_size = 0.0002` (23 GB and an OOM kill before) is refused before
//! meshing, in well under a second, with exit status 2 and the refinement named; a solve that
//! fits goes through; a bad limit is refused naming the flag.

use std::io::Write;
use std::process::{Command, Output, Stdio};
use std::time::Instant;

fn probe_scene(refine: f64) -> String {
    let text = wsm_core::bundled::example("block-on-base").expect("bundled");
    let mut scene: serde_json::Value = serde_json::from_str(text).expect("json");
    scene["mesh"]["refine"][0]["max_size"] = serde_json::json!(refine);
    scene.to_string()
}

fn wsm(args: &[&str], scene: &str) -> Output {
    let dir = std::env::temp_dir().join(format!("wsm-solve-cost-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(format!("scene-{}.json", args.join("_").replace('/', "")));
    std::fs::File::create(&path)
        .and_then(|mut f| f.write_all(scene.as_bytes()))
        .expect("write scene");
    let mut full: Vec<&str> = args.to_vec();
    let p = path.to_string_lossy().to_string();
    full.push(&p);
    Command::new(env!("CARGO_BIN_EXE_wsm"))
        .args(&full)
        .stdin(Stdio::null())
        .output()
        .expect("runs")
}

#[test]
fn probe_case_refused_before_meshing() {
    let scene = probe_scene(0.0002);
    for command in ["solve", "worst", "evaluate"] {
        let start = Instant::now();
        let out = wsm(&[command, "--max-solve-memory", "12G"], &scene);
        let seconds = start.elapsed().as_secs_f64();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{command}: {stderr}");
        assert!(
            stderr.contains("mesh.refine[0].max_size") && stderr.contains("fits"),
            "{command}: {stderr}"
        );
        assert!(seconds < 1.0, "{command} took {seconds} s");
    }
}

#[test]
fn a_solve_that_fits_runs_and_a_bad_limit_is_named() {
    let scene = probe_scene(0.02);
    let out = wsm(&["solve", "--max-solve-memory", "2G"], &scene);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The same scene under a limit below its estimate is refused, naming the refinement.
    let out = wsm(&["solve", "--max-solve-memory", "10M"], &scene);
    assert_eq!(out.status.code(), Some(2));
    let bad = wsm(&["solve", "--max-solve-memory", "lots"], &scene);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--max-solve-memory"));
}
