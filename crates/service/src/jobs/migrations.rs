//! The job store's schema migrations (`migrations/sqlite`, `migrations/postgres`), embedded in the
//! binary by the crate's build script and applied by sqlx's `Migrator` at start-up (design §5.4).
//! Version, description, checksum and transaction mode are those `sqlx::migrate!` gives the same
//! files, so stores created by earlier builds accept them (a test compares with sqlx's own
//! reading of the directories).

use std::borrow::Cow;

use sqlx::migrate::{Migration, MigrationType, Migrator};
use sqlx::SqlSafeStr;

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/migrations.rs"));
}

/// The migrator of a SQLite store: every migration of `migrations/sqlite`, in version order.
pub(crate) fn sqlite() -> Migrator {
    migrator(embedded::SQLITE)
}

/// The migrator of a PostgreSQL store: every migration of `migrations/postgres`, in version
/// order.
pub(crate) fn postgres() -> Migrator {
    migrator(embedded::POSTGRES)
}

/// A migrator of embedded `(version, description, SQL)` files.
fn migrator(files: &[(i64, &'static str, &'static str)]) -> Migrator {
    Migrator::with_migrations(
        files
            .iter()
            .map(|&(version, description, sql)| {
                Migration::new(
                    version,
                    Cow::Borrowed(description),
                    MigrationType::Simple,
                    sql.into_sql_str(),
                    sql.starts_with("-- no-transaction"),
                )
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What sqlx's resolver reads from a directory: the fields a store checks.
    fn fields(migrator: &Migrator) -> Vec<(i64, String, Vec<u8>, bool, bool)> {
        migrator
            .iter()
            .map(|m| {
                let reversible = m.migration_type.is_reversible();
                (
                    m.version,
                    m.description.to_string(),
                    m.checksum.to_vec(),
                    m.no_tx,
                    reversible,
                )
            })
            .collect()
    }

    #[tokio::test]
    async fn embedded_migrations_are_what_sqlx_reads_from_the_directories() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../migrations");
        for (embedded, dir) in [(sqlite(), "sqlite"), (postgres(), "postgres")] {
            let read = Migrator::new(root.join(dir))
                .await
                .expect("sqlx reads the directory");
            assert!(embedded.iter().count() >= 5, "{dir}: migrations missing");
            assert_eq!(fields(&embedded), fields(&read), "{dir}");
        }
    }
}
