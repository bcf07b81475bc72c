//! Gmsh scenes on the command line (issue #48): a scene that imports a Gmsh mesh needs no
//! `mesh.max_size`, reads a relative `gmsh_file` from the scene file's directory whatever the
//! working directory, and `wsm worst` runs it with its defaults — the accuracy statement, which
//! cannot refine an imported mesh, makes no refined solve, is incomplete and says so in one
//! warning.

use std::path::{Path, PathBuf};
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
fn wsm_worst_runs_a_gmsh_scene_with_its_defaults_and_an_incomplete_statement() {
    let root = case("worst", "square.msh");
    let output = wsm(&root, &["worst", "case/scene.json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let outcome: Value = serde_json::from_slice(&output.stdout).unwrap();
    let accuracy = &outcome["accuracy"];
    assert_eq!(accuracy["complete"], json!(false), "{accuracy}");
    assert_eq!(
        accuracy["meshes"].as_array().unwrap().len(),
        1,
        "no refined mesh: {accuracy}"
    );
    assert_eq!(
        accuracy["failures"],
        json!([]),
        "no refined solve: {accuracy}"
    );
    assert!(accuracy["unrefinable"]
        .as_str()
        .unwrap()
        .contains("mesh.gmsh_file"));
    let statement: Vec<&str> = outcome["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .filter(|w| w.starts_with("accuracy statement"))
        .collect();
    assert_eq!(statement.len(), 1, "{statement:#?}");
    assert!(
        statement[0].contains("needs refinable meshes") && statement[0].contains("in Gmsh"),
        "{}",
        statement[0]
    );
    let worst = &outcome["criteria"][0]["worst"];
    assert!(worst["value"].as_f64().unwrap() > 0.0, "{worst}");
    // Refinements asked for explicitly are refused at once, naming the option and the mesh.
    let output = wsm(
        &root,
        &["worst", "case/scene.json", "--accuracy-refinements", "1"],
    );
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).starts_with(
            "error: accuracy_refinements: an imported Gmsh mesh (mesh.gmsh_file) cannot be \
             refined by wsm"
        ),
        "{}",
        stderr(&output)
    );
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
