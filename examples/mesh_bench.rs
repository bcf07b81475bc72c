//! Times the built-in mesher on a list of scenes and prints one JSON line per case (triangles,
//! nodes, minimum angle, angle histogram, median time). Input: a JSON array of
//! `{ "name": ..., "scene": <scene JSON> }`, as written by `scripts/mesh_bench.py`, which runs
//! Shewchuk's Triangle on the same inputs for comparison. Not part of the test suite.
//!
//! Usage: `cargo run --release --example mesh_bench -- cases.json [runs]`

use std::time::Instant;

use serde_json::{json, Value};
use wsm_core::{generate_mesh, mesh_stats, Mesh, Scene};

/// Smallest angle of every triangle, degrees.
fn min_angles(mesh: &Mesh) -> Vec<f64> {
    mesh.triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| mesh.nodes[i]);
            (0..3)
                .map(|k| {
                    let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
                    let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
                    (u[0] * v[1] - u[1] * v[0])
                        .abs()
                        .atan2(u[0] * v[0] + u[1] * v[1])
                        .to_degrees()
                })
                .fold(180.0, f64::min)
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: mesh_bench cases.json [runs]");
        std::process::exit(2);
    };
    let runs: usize = args.get(2).and_then(|r| r.parse().ok()).unwrap_or(3);
    let text = std::fs::read_to_string(path).expect("cannot read the cases file");
    let cases: Vec<Value> = serde_json::from_str(&text).expect("the cases file is not JSON");
    for case in cases {
        let name = case["name"].as_str().unwrap_or("?").to_string();
        let scene: Scene = match serde_json::from_value(case["scene"].clone()) {
            Ok(s) => s,
            Err(e) => {
                println!("{}", json!({ "name": name, "error": e.to_string() }));
                continue;
            }
        };
        let mut times = Vec::new();
        let mut result = None;
        for _ in 0..runs.max(1) {
            let t0 = Instant::now();
            let r = generate_mesh(&scene);
            times.push(t0.elapsed().as_secs_f64());
            result = Some(r);
        }
        times.sort_by(f64::total_cmp);
        let line = match result {
            Some(Ok(mesh)) => {
                let s = mesh_stats(&mesh);
                let angles = min_angles(&mesh);
                let below = |x: f64| angles.iter().filter(|&&a| a < x).count();
                json!({
                    "name": name,
                    "triangles": s.triangles,
                    "nodes": s.nodes,
                    "min_angle": s.min_angle_deg,
                    "below_20": below(20.0),
                    "below_28": below(28.0),
                    "below_30": below(30.0),
                    "below_40": below(40.0),
                    "seconds": times[times.len() / 2],
                })
            }
            Some(Err(e)) => json!({ "name": name, "error": e.to_string() }),
            None => json!({ "name": name, "error": "not run" }),
        };
        println!("{line}");
    }
}
