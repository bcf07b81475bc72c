//! `wsm serve`: opens the job store, starts the workers and serves the API (and the dashboard)
//! until Ctrl-C or SIGTERM. Jobs left running by a stopped server are resumed by the next one
//! once their lease expires.

use std::sync::Arc;

use tokio::sync::Notify;

use crate::api::{AppState, Limits};
use crate::error::WsmError;
use crate::jobs::runner::{spawn_workers, Live, RunnerConfig};
use crate::jobs::sqlite::SqliteStore;
use crate::jobs::JobStore;

/// Settings of `wsm serve`.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    pub addr: String,
    /// SQLite database file (created and migrated on start).
    pub db: String,
    pub workers: usize,
    pub threads_per_job: Option<usize>,
    pub lease_seconds: f64,
    pub limits: Limits,
    /// Bearer token for mutating endpoints (from the environment; never logged).
    pub token: Option<String>,
}

/// Run the service until a shutdown signal.
pub async fn serve(config: ServeConfig) -> Result<(), WsmError> {
    let store: Arc<dyn JobStore> = Arc::new(
        SqliteStore::open(&config.db)
            .await
            .map_err(|e| WsmError::io(&config.db, e))?,
    );
    let live = Arc::new(Live::default());
    let wake = Arc::new(Notify::new());
    let owner = format!("serve-{}-{}", std::process::id(), uuid::Uuid::new_v4());
    spawn_workers(
        store.clone(),
        live.clone(),
        RunnerConfig {
            workers: config.workers,
            threads_per_job: config.threads_per_job,
            lease_seconds: config.lease_seconds,
            owner,
        },
        wake.clone(),
    );
    let state = AppState {
        store,
        live,
        wake,
        limits: Arc::new(config.limits.clone()),
        token: config.token.clone().map(Arc::new),
    };
    let app = crate::api::router(state).merge(crate::web::router());
    let listener = tokio::net::TcpListener::bind(&config.addr)
        .await
        .map_err(|e| WsmError::io(&config.addr, e))?;
    let local = listener
        .local_addr()
        .map_err(|e| WsmError::io(&config.addr, e))?;
    println!(
        "wsm: serving http://{local}/ (dashboard), API at http://{local}/v1, database {}",
        config.db
    );
    axum::serve(listener, app)
        .with_graceful_shutdown(shutdown())
        .await
        .map_err(|e| WsmError::io(local, e))
}

async fn shutdown() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        if let Ok(mut s) = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        {
            s.recv().await;
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = term => {}
    }
}
