//! The job store's migrations (the repository's `migrations/sqlite` and `migrations/postgres`)
//! are embedded in the binary: this script lists each directory's `NNNN_description.sql` files
//! and writes a table of `(version, description, include_str!(file))` per backend into
//! `$OUT_DIR/migrations.rs`, which `jobs/migrations.rs` turns into sqlx's `Migrator`. It names the
//! files as `sqlx::migrate!` would (version before the first `_`, the rest the description with
//! `_` as spaces), without building sqlx's macro crate and a second SQLite for the host.
use std::fmt::Write as _;
use std::path::Path;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../migrations");
    // A directory is watched with everything in it: a migration added, changed or removed.
    println!("cargo:rerun-if-changed={}", root.display());
    let mut code = String::new();
    for (constant, backend) in [("SQLITE", "sqlite"), ("POSTGRES", "postgres")] {
        let dir = root.join(backend);
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
            .map(|entry| entry.expect("a directory entry").path())
            .filter(|path| path.extension().is_some_and(|e| e == "sql"))
            .collect();
        files.sort();
        writeln!(
            code,
            "/// `(version, description, SQL)` of every migration in `migrations/{backend}`, \
             in file order.\npub(super) const {constant}: &[(i64, &str, &str)] = &["
        )
        .expect("writing to a String");
        for path in files {
            let name = path
                .file_stem()
                .and_then(|stem| stem.to_str())
                .unwrap_or_else(|| panic!("{}: not a UTF-8 file name", path.display()));
            let (version, description) = name
                .split_once('_')
                .unwrap_or_else(|| panic!("{name}: expected NNNN_description.sql"));
            let version: i64 = version
                .parse()
                .unwrap_or_else(|_| panic!("{name}: the version before `_` is not an integer"));
            let description = description.replace('_', " ");
            let file = path.canonicalize().expect("an existing file");
            writeln!(
                code,
                "    ({version}, {description:?}, include_str!({:?})),",
                file.display().to_string()
            )
            .expect("writing to a String");
        }
        code.push_str("];\n");
    }
    let out =
        Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("migrations.rs");
    std::fs::write(&out, code).unwrap_or_else(|e| panic!("writing {}: {e}", out.display()));
}
