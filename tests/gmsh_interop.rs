//! Gmsh scenes on the command line (issue #48): a scene that imports a Gmsh mesh needs no
//! `mesh.max_size`, reads a relative `gmsh_file` from the scene file's directory whatever the
//! working directory, and `wsm worst` runs it with its defaults — the accuracy statement refines
//! the imported mesh by uniform subdivision (design §2.5). The block-on-base contact mesh written
//! by Gmsh itself (scripts/gmsh_block_on_base.py) in MSH 4.1 and 2.2, ASCII and binary, reads as
//! one mesh with one solve, and `wsm inline-mesh` turns its scene into an inline one with the
//! same results.

mod common;

use std::path::{Path, PathBuf};
use std::time::Duration;

use common::{extrema, post, temp_db, wait_finished, Server};
use std::process::{Command, Output};

use serde_json::{json, Value};

/// An MSH 4.1 ASCII mesh of the unit square, `n` × `n` cells of two triangles: physical surface
/// "z" (tag 3), physical curves "bottom" (tag 1, y = 0) and "top" (tag 2, y = 1).
fn square_msh(n: usize) -> String {
    let id = |i: usize, j: usize| j * (n + 1) + i + 1;
    let count = (n + 1) * (n + 1);
    let mut s = String::from(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n3\n1 1 \"bottom\"\n\
         1 2 \"top\"\n2 3 \"z\"\n$EndPhysicalNames\n$Entities\n0 2 1 0\n\
         1 0 0 0 1 0 0 1 1 0\n2 0 1 0 1 1 0 1 2 0\n1 0 0 0 1 1 0 1 3 0\n$EndEntities\n",
    );
    s += &format!("$Nodes\n1 {count} 1 {count}\n2 1 0 {count}\n");
    for k in 1..=count {
        s += &format!("{k}\n");
    }
    for j in 0..=n {
        for i in 0..=n {
            s += &format!("{} {} 0\n", i as f64 / n as f64, j as f64 / n as f64);
        }
    }
    let elements = 2 * n * n + 2 * n;
    s += &format!(
        "$EndNodes\n$Elements\n3 {elements} 1 {elements}\n2 1 2 {}\n",
        2 * n * n
    );
    let mut tag = 0;
    let mut next = || {
        tag += 1;
        tag
    };
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            s += &format!("{} {a} {b} {c}\n{} {a} {c} {d}\n", next(), next());
        }
    }
    s += &format!("1 1 1 {n}\n");
    for i in 0..n {
        s += &format!("{} {} {}\n", next(), id(i, 0), id(i + 1, 0));
    }
    s += &format!("1 2 1 {n}\n");
    for i in 0..n {
        s += &format!("{} {} {}\n", next(), id(i + 1, n), id(i, n));
    }
    s + "$EndElements\n"
}

/// A clamped square pulled sideways on top, meshed in Gmsh (`gmsh_file`), without `max_size`.
fn scene(gmsh_file: &str) -> Value {
    json!({
        "version": 1,
        "name": "gmsh square",
        "bodies": [{ "name": "b", "zones": [{ "name": "z", "material": "m",
            "polygon": [[0, 0], [1, 0], [1, 1], [0, 1]] }] }],
        "segments": { "bottom": { "body": "b" }, "top": { "body": "b" } },
        "materials": { "m": { "E": 1e9, "nu": 0.3 } },
        "boundary": [
            { "segment": "bottom", "displacement": [0, 0] },
            { "segment": "top", "traction": [1e5, -1e5] }
        ],
        "mesh": { "gmsh_file": gmsh_file },
        "criteria": { "regions": [{ "name": "all", "polygon": [[0, 0], [1, 0], [1, 1], [0, 1]] }] },
        "uncertain": [
            { "field": "materials.m.E", "interval": [8e8, 1.2e9] },
            { "field": "boundary[1].traction[0]", "interval": [5e4, 1.5e5] }
        ],
        "search": { "criteria": ["phi5"], "budget": 12, "seed": 1 }
    })
}

/// A fresh directory `<temp>/wsm-gmsh-<pid>-<name>` with `case/square.msh` and
/// `case/scene.json` (its `gmsh_file` as given).
fn case(name: &str, gmsh_file: &str) -> PathBuf {
    let root = std::env::temp_dir().join(format!("wsm-gmsh-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(root.join("case")).unwrap();
    std::fs::write(root.join("case/square.msh"), square_msh(4)).unwrap();
    std::fs::write(root.join("case/scene.json"), scene(gmsh_file).to_string()).unwrap();
    root
}

/// `wsm ARGS` run in `dir`.
fn wsm(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wsm"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn a_relative_gmsh_file_is_read_beside_the_scene_file_without_a_max_size() {
    let root = case("relative", "square.msh");
    // From the scene's parent directory, from the scene's own and from elsewhere (absolute
    // scene path): the same mesh, beside the scene file.
    let runs = [
        (root.clone(), "case/scene.json".to_string()),
        (root.join("case"), "scene.json".to_string()),
        (
            PathBuf::from("/"),
            root.join("case/scene.json").display().to_string(),
        ),
    ];
    let mut summaries = Vec::new();
    for (dir, scene) in &runs {
        let output = wsm(dir, &["solve", scene]);
        assert!(output.status.success(), "{dir:?}: {}", stderr(&output));
        let summary: Value = serde_json::from_slice(&output.stdout).unwrap();
        assert_eq!(summary["mesh"]["triangles"], json!(32), "{summary}");
        summaries.push(summary["criteria"].clone());
    }
    assert!(summaries.windows(2).all(|w| w[0] == w[1]));
    // An absolute path is read as it stands.
    let absolute = root.join("case/square.msh").display().to_string();
    std::fs::write(root.join("case/scene.json"), scene(&absolute).to_string()).unwrap();
    let output = wsm(&root, &["solve", "case/scene.json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    // A missing file is bad input naming the field and the path tried.
    std::fs::write(
        root.join("case/scene.json"),
        scene("missing.msh").to_string(),
    )
    .unwrap();
    let output = wsm(&root, &["solve", "case/scene.json"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).starts_with("error: mesh.gmsh_file: cannot read 'case/missing.msh'"),
        "{}",
        stderr(&output)
    );
    std::fs::remove_dir_all(&root).unwrap();
}

/// Without `max_size` there is no mesh size to coarsen: a Gmsh mesh beyond the memory limit is
/// refused naming its file.
#[test]
fn a_gmsh_mesh_beyond_the_memory_limit_names_its_file() {
    let root = case("memory", "square.msh");
    let output = wsm(
        &root,
        &["solve", "case/scene.json", "--max-solve-memory", "1000"],
    );
    assert_eq!(output.status.code(), Some(2));
    let text = stderr(&output);
    assert!(
        text.starts_with("error: mesh.gmsh_file: about 32 triangles")
            && text.trim_end().ends_with("; make a coarser mesh in Gmsh"),
        "{text}"
    );
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn wsm_worst_runs_a_gmsh_scene_with_its_defaults_and_a_complete_statement() {
    let root = case("worst", "square.msh");
    let output = wsm(&root, &["worst", "case/scene.json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let outcome: Value = serde_json::from_slice(&output.stdout).unwrap();
    let accuracy = &outcome["accuracy"];
    assert_eq!(accuracy["complete"], json!(true), "{accuracy}");
    // Two uniform subdivisions of the 32 triangles: sizes halved twice.
    let meshes: Vec<(f64, u64)> = accuracy["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["size_factor"].as_f64().unwrap(),
                m["triangles"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(meshes, vec![(1.0, 32), (0.5, 128), (0.25, 512)]);
    assert_eq!(accuracy["failures"], json!([]));
    assert!(accuracy["method"].as_str().unwrap().contains("subdivided"));
    let worst = &outcome["criteria"][0]["worst"];
    assert!(worst["value"].as_f64().unwrap() > 0.0, "{worst}");
    let estimate = &accuracy["criteria"][0]["worst"];
    assert!(estimate["estimate"].as_f64().unwrap() > 0.0, "{estimate}");
    let warnings = outcome["warnings"].as_array().unwrap();
    assert!(
        !warnings.iter().any(|w| w["kind"] == "accuracy"),
        "{warnings:#?}"
    );
    // One refinement asked for explicitly: one subdivision.
    let output = wsm(
        &root,
        &["worst", "case/scene.json", "--accuracy-refinements", "1"],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let outcome: Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(outcome["accuracy"]["meshes"][1]["triangles"], json!(128));
    // None asked for: no statement at all, as for any scene.
    let output = wsm(
        &root,
        &["worst", "case/scene.json", "--accuracy-refinements", "0"],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let outcome: Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(outcome["accuracy"], Value::Null);
    std::fs::remove_dir_all(&root).unwrap();
}

/// The committed Gmsh meshes of the block-on-base contact scene, in `tests/data`.
const FORMATS: [&str; 4] = ["4.1-ascii", "4.1-binary", "2.2-ascii", "2.2-binary"];

fn data(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(file)
}

/// The block-on-base scene on the mesh in `format`, written into a fresh directory.
fn block_case(name: &str, format: &str) -> PathBuf {
    let root = std::env::temp_dir().join(format!("wsm-gmsh-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let mut scene: Value =
        serde_json::from_str(&std::fs::read_to_string(data("block-on-base-gmsh.json")).unwrap())
            .unwrap();
    scene["mesh"]["gmsh_file"] = json!(data(&format!("block-on-base-{format}.msh")));
    std::fs::write(root.join("scene.json"), scene.to_string()).unwrap();
    root
}

fn solve_json(dir: &Path, scene: &str) -> Value {
    let output = wsm(dir, &["solve", scene, "--out", "result.json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    serde_json::from_slice(&output.stdout).unwrap()
}

/// All four formats Gmsh writes give one mesh and one solve: identical for the two binary files
/// and for the two ASCII files (Gmsh writes the same numbers in 4.1 and 2.2), and the same to
/// the 16 digits ASCII keeps between ASCII and binary.
#[test]
fn every_msh_format_gives_the_same_mesh_and_solve() {
    let mut results = Vec::new();
    for format in FORMATS {
        let root = block_case(&format!("format-{format}"), format);
        let summary = solve_json(&root, "scene.json");
        let full: Value =
            serde_json::from_str(&std::fs::read_to_string(root.join("result.json")).unwrap())
                .unwrap();
        // The numbers, without the timings.
        let numbers = json!([
            summary["mesh"],
            summary["criteria"],
            summary["contact_zones"],
            full["fields"]
        ]);
        assert_eq!(
            summary["mesh"]["triangles"],
            json!(250),
            "{format}: {summary}"
        );
        assert_eq!(
            summary["mesh"]["contact_pairs"],
            json!(9),
            "{format}: {summary}"
        );
        results.push(numbers);
        std::fs::remove_dir_all(&root).unwrap();
    }
    assert!(results[0] == results[2], "4.1 and 2.2 ASCII differ");
    assert!(results[1] == results[3], "4.1 and 2.2 binary differ");
    assert!(
        results[0] != results[1],
        "ASCII keeps 16 digits: not bit for bit"
    );
    let criteria = |k: usize| results[k][1].as_object().unwrap().clone();
    for (name, ascii) in criteria(0) {
        let (Some(a), Some(b)) = (ascii.as_f64(), criteria(1)[&name].as_f64()) else {
            continue;
        };
        assert!((a - b).abs() <= 1e-12 * a.abs(), "{name}: {a} vs {b}");
    }
}

/// `wsm inline-mesh` gives a scene whose mesh is in the scene: the same worst-scenario result
/// as the Gmsh scene, number for number.
#[test]
fn an_inlined_gmsh_scene_gives_the_same_worst_scenario() {
    let root = block_case("inline", "2.2-binary");
    let output = wsm(&root, &["inline-mesh", "scene.json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let inline: Value = serde_json::from_slice(&output.stdout).unwrap();
    assert!(inline["mesh"].get("gmsh_file").is_none());
    assert_eq!(inline["mesh"]["inline"]["zones"], json!(["base", "block"]));
    std::fs::write(root.join("inline.json"), inline.to_string()).unwrap();
    let run = |scene: &str| {
        let output = wsm(&root, &["worst", scene]);
        assert!(output.status.success(), "{}", stderr(&output));
        let outcome: Value = serde_json::from_slice(&output.stdout).unwrap();
        assert_eq!(outcome["accuracy"]["complete"], json!(true), "{outcome}");
        let values = |a: &Value| {
            let mut a = a.clone();
            for m in a["meshes"].as_array_mut().unwrap() {
                m["seconds"] = json!(0);
            }
            a["seconds"] = json!(0);
            a
        };
        (outcome["criteria"].clone(), values(&outcome["accuracy"]))
    };
    assert_eq!(run("scene.json"), run("inline.json"));
    // A scene without a Gmsh file has nothing to inline.
    let output = wsm(&root, &["inline-mesh", "inline.json"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).starts_with("error: mesh.gmsh_file:"),
        "{}",
        stderr(&output)
    );
    std::fs::remove_dir_all(&root).unwrap();
}

/// The acceptance of imported meshes in the service: the Gmsh block-on-base scene given inline
/// through `POST /v1/jobs` gives the result of `wsm worst` on the Gmsh scene, number for number
/// (extrema and accuracy statement, refined by subdivision); a scene naming a Gmsh file is
/// refused with the way to inline it; an inline mesh beyond the body limit or the memory limit
/// is refused cleanly.
#[test]
fn the_service_takes_an_inline_mesh_and_gives_the_cli_result() {
    let root = block_case("service", "4.1-binary");
    let output = wsm(&root, &["inline-mesh", "scene.json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let inline: Value = serde_json::from_slice(&output.stdout).unwrap();
    let cli = wsm(&root, &["worst", "scene.json", "--threads", "1"]);
    assert!(cli.status.success(), "{}", stderr(&cli));
    let cli: Value = serde_json::from_slice(&cli.stdout).unwrap();
    let numbers = |outcome: &Value| {
        let mut accuracy = outcome["accuracy"].clone();
        for m in accuracy["meshes"].as_array_mut().unwrap() {
            m["seconds"] = json!(0);
        }
        accuracy["seconds"] = json!(0);
        (extrema(outcome), accuracy)
    };

    let db = temp_db("gmsh-inline.db");
    let server = Server::start(&db, &["--workers", "1"]);
    let addr = &server.addr;
    let reply = post(addr, "/v1/jobs", &json!({ "scene": inline }));
    let id = reply.accepted_id();
    let status = wait_finished(addr, &id, Duration::from_secs(300));
    assert_eq!(status["state"], "succeeded", "{status}");
    let result = common::get(addr, &format!("/v1/jobs/{id}/result")).json();
    assert_eq!(
        result["accuracy"]["complete"],
        json!(true),
        "{}",
        result["accuracy"]
    );
    assert_eq!(
        numbers(&result),
        numbers(&cli),
        "service (inline) = wsm worst (Gmsh file)"
    );

    // A Gmsh file is refused, saying how to inline it.
    let gmsh: Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("scene.json")).unwrap()).unwrap();
    let reply = post(addr, "/v1/jobs", &json!({ "scene": gmsh }));
    assert_eq!(reply.status, 422);
    let error = reply.json();
    assert_eq!(error["path"], json!("scene.mesh.gmsh_file"), "{error}");
    assert!(error.to_string().contains("wsm inline-mesh"), "{error}");

    drop(server);

    // On a server with small limits: a mesh beyond the memory limit of solves is refused naming
    // the inline mesh, and a body beyond the body limit before it is read.
    let db = temp_db("gmsh-inline-limits.db");
    let limits = [
        "--workers",
        "1",
        "--max-solve-memory",
        "1000",
        "--max-body-bytes",
        "200000",
    ];
    let server = Server::start(&db, &limits);
    let reply = post(&server.addr, "/v1/jobs", &json!({ "scene": inline }));
    assert_eq!(
        reply.status,
        422,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    let error = reply.json();
    assert_eq!(error["path"], json!("scene.mesh.inline"), "{error}");
    let mut huge = inline.clone();
    huge["mesh"]["inline"]["nodes"] = json!(vec![[0.123456789, 0.987654321]; 10_000]);
    let reply = post(&server.addr, "/v1/jobs", &json!({ "scene": huge }));
    assert_eq!(reply.status, 413);
    std::fs::remove_dir_all(&root).unwrap();
}
