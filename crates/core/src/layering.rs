//! The pipeline order of `lib.rs`, kept by a test: no module of the engine uses a module that
//! comes later in the pipeline (design §1; `cargo test -p wsm-core layering`). Test code
//! (`#[cfg(test)] mod tests` at the end of a file, files named `tests.rs` or `*_tests.rs`) may use
//! anything.

/// Stages that are crates of their own (`scene` is `wsm-scene`, named `scene` at the root by a
/// `use`) have no source here: a crate boundary keeps them from using the engine.
const CRATES: [&str; 1] = ["scene"];

/// The pipeline, earliest first, as the crate documentation states it.
const PIPELINE: [&str; 17] = [
    "memo", "scene", "mesh", "fixtures", "fem", "error", "fault", "bundled", "contact", "dd",
    "regions", "state", "dynamics", "output", "estimate", "scenario", "run",
];

/// `crate::NAME` paths in the library code of one file (comments and test code skipped).
fn crate_paths(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let code = line.trim_start();
        if code.starts_with("#[cfg(test)]") {
            break;
        }
        if code.starts_with("//") {
            continue;
        }
        for (at, _) in code.match_indices("crate::") {
            let name: String = code[at + 7..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            out.push((number + 1, name));
        }
    }
    out
}

/// Every `.rs` file under `dir`, except test files.
fn sources(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("source dir").flatten() {
        let path = entry.path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs")
            && path
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| !n.ends_with("tests.rs"))
        {
            out.push(path);
        }
    }
}

#[test]
fn no_module_uses_a_later_stage_of_the_pipeline() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let rank = |name: &str| PIPELINE.iter().position(|m| *m == name);
    let mut violations = Vec::new();
    let mut checked = 0;
    for module in PIPELINE {
        if CRATES.contains(&module) {
            continue;
        }
        let mut files = Vec::new();
        let file = root.join(format!("{module}.rs"));
        if file.exists() {
            files.push(file);
        }
        let dir = root.join(module);
        if dir.is_dir() {
            sources(&dir, &mut files);
        }
        assert!(!files.is_empty(), "module {module} has no source");
        for path in files {
            let text = std::fs::read_to_string(&path).expect("readable");
            for (line, used) in crate_paths(&text) {
                checked += 1;
                match rank(&used) {
                    Some(r) if r <= rank(module).unwrap_or(0) => {}
                    Some(_) => violations.push(format!(
                        "{}:{line}: {module} uses crate::{used}, a later stage",
                        path.display()
                    )),
                    None => violations.push(format!(
                        "{}:{line}: crate::{used} is not a stage of the pipeline",
                        path.display()
                    )),
                }
            }
        }
    }
    // Every top-level module is a stage (a new one must be placed in the order).
    for entry in std::fs::read_dir(&root).expect("src").flatten() {
        let name = entry
            .file_name()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        if !["lib", "layering"].contains(&name.as_str()) {
            assert!(
                rank(&name).is_some(),
                "src/{name} is not placed in PIPELINE"
            );
        }
    }
    assert!(
        checked > 100,
        "only {checked} paths seen: the scan is broken"
    );
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn the_scan_sees_a_later_stage_and_skips_comments_and_tests() {
    let text = "use crate::scene::Scene;\n// crate::run in a comment\nfn f() { crate::run::x() }\n#[cfg(test)]\nmod tests { use crate::run; }\n";
    let seen: Vec<String> = crate_paths(text).into_iter().map(|(_, n)| n).collect();
    assert_eq!(seen, ["scene", "run"]);
}
