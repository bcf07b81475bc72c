//! The job store's schema migrations (`migrations/sqlite`, `migrations/postgres`), embedded in the
//! binary by the crate's build script and applied by sqlx's `Migrator` at start-up (design §5.4).
//! Version, description, checksum and transaction mode are those `sqlx::migrate!` gives the same
//! files, so stores created by earlier builds accept them (a test compares with sqlx's own
//! reading of the directories).

use std::borrow::Cow;

use sqlx::migrate::{Migration, MigrationType, Migrator};
use sqlx::SqlSafeStr;

use super::sql::Backend;

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/migrations.rs"));
}

/// The migrator of a backend's store: every embedded migration, in version order.
pub(crate) fn migrator(backend: Backend) -> Migrator {
    let files = match backend {
        Backend::Sqlite => embedded::SQLITE,
        Backend::Postgres => embedded::POSTGRES,
    };
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
        for (backend, dir) in [(Backend::Sqlite, "sqlite"), (Backend::Postgres, "postgres")] {
            let read = Migrator::new(root.join(dir))
                .await
                .expect("sqlx reads the directory");
            let embedded = migrator(backend);
            assert!(embedded.iter().count() >= 5, "{dir}: migrations missing");
            assert_eq!(fields(&embedded), fields(&read), "{dir}");
        }
    }
}
