//! The PostgreSQL server of the tests: its URL (`.ci/run` sets `WSM_TEST_POSTGRES_URL`; the
//! PostgreSQL halves of the tests say they are skipped without it) and a fresh schema per test.
//! Shared by the root's tests (through `common`) and wsm-service's (by `#[path]`).

/// The PostgreSQL server of the tests (`.ci/run` sets `WSM_TEST_POSTGRES_URL`), if any.
pub fn postgres_url() -> Option<String> {
    std::env::var("WSM_TEST_POSTGRES_URL")
        .ok()
        .filter(|u| !u.is_empty())
}

/// A fresh schema on the test server, dropped with everything in it when this goes out of
/// scope; `url` points a connection at it.
pub struct PgSchema {
    pub url: String,
    server: String,
    name: String,
}

impl PgSchema {
    pub fn new(server: &str) -> PgSchema {
        let name = format!("wsm_test_{}", uuid::Uuid::new_v4().simple());
        run_sql(server, format!("CREATE SCHEMA {name}"));
        let separator = if server.contains('?') { '&' } else { '?' };
        PgSchema {
            url: format!("{server}{separator}options=-c%20search_path%3D{name}"),
            server: server.to_string(),
            name,
        }
    }
}

impl Drop for PgSchema {
    fn drop(&mut self) {
        run_sql(&self.server, format!("DROP SCHEMA {} CASCADE", self.name));
    }
}

/// One statement on its own thread and runtime (callable from sync and async code alike).
fn run_sql(url: &str, statement: String) {
    let url = url.to_string();
    std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        runtime.block_on(async {
            let pool = sqlx::PgPool::connect(&url).await.unwrap();
            sqlx::query(sqlx::AssertSqlSafe(statement))
                .execute(&pool)
                .await
                .unwrap();
            pool.close().await;
        })
    })
    .join()
    .unwrap();
}
