//! `wsm serve` and `wsm worker`: open the job store (a SQLite file or a PostgreSQL URL), start
//! the worker side (job slots, task loop, heartbeat) and — for `serve` — the API and the
//! dashboard, until Ctrl-C or SIGTERM. On those signals the process gives its running jobs back
//! to the queue (resumed at once by any worker); jobs of a process that died are resumed by
//! another once their lease expires.

use std::sync::Arc;
use std::time::Duration;

use crate::api::{Access, AppState, Limits, SolveSlots};
use crate::http::ConnectionLimits;
use crate::jobs::health::{spawn_monitor, StoreHealth};
use crate::jobs::runner::{release_on_shutdown, spawn_workers, FaultRule, Live, RunnerConfig};
use crate::jobs::sql::SqlStore;
use crate::jobs::JobStore;
use wsm_core::WsmError;

/// Settings of `wsm serve`.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    /// The address the API listens on (`host:port`).
    pub addr: String,
    /// SQLite database file (created and migrated on start) or PostgreSQL URL.
    pub db: String,
    /// Jobs this process coordinates at once (0: it only serves, `wsm worker` processes do
    /// all the work).
    pub workers: usize,
    /// Threads of each job's pool and of the task loop (`None`: all cores).
    pub threads_per_job: Option<usize>,
    /// A job or task lease not renewed for this long is taken over \[s\].
    pub lease_seconds: f64,
    /// Limits on what the API accepts.
    pub limits: Limits,
    /// Limits on the HTTP connections: how many at once and how soon a request head must arrive.
    pub connections: ConnectionLimits,
    /// How long a store statement waits for another's lock before it fails.
    pub store_timeout: Duration,
    /// A job whose lease expired this many times is failed instead of leased again.
    pub max_attempts: u32,
    /// Who may do what (tokens from the environment; never logged).
    pub access: Access,
    /// Fail solves on purpose (tests of failure handling only).
    pub inject_failures: Vec<FaultRule>,
}

/// Settings of `wsm worker`.
#[derive(Debug, Clone)]
pub struct WorkerConfig {
    /// PostgreSQL URL (or a SQLite file shared by processes on one machine).
    pub db: String,
    /// Evaluation threads (default: all cores).
    pub threads: Option<usize>,
    /// Jobs coordinated at once.
    pub jobs: usize,
    /// A job or task lease not renewed for this long is taken over \[s\].
    pub lease_seconds: f64,
    /// How long a store statement waits for another's lock before it fails.
    pub store_timeout: Duration,
    /// A job whose lease expired this many times is failed instead of leased again.
    pub max_attempts: u32,
    /// Peak memory one solve may need \[bytes\] (design §3.1, cost estimate).
    pub max_solve_memory: u64,
}

/// A process's name in leases and evaluations: its role, host, process id and a random part.
fn owner_name(role: &str) -> String {
    let host = std::env::var("HOSTNAME")
        .ok()
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "localhost".into());
    let id = uuid::Uuid::new_v4().simple().to_string();
    format!("{role}-{host}-{}-{}", std::process::id(), &id[..8])
}

async fn open_store(db: &str, timeout: Duration) -> Result<Arc<dyn JobStore>, WsmError> {
    let store = SqlStore::open_with(db, timeout)
        .await
        .map_err(|e| WsmError::io(redact(db), e))?;
    Ok(Arc::new(store))
}

/// A database argument fit for messages: a URL's password is left out.
fn redact(db: &str) -> String {
    match (db.find("://"), db.rfind('@')) {
        (Some(scheme), Some(at)) if at > scheme => {
            let credentials = &db[scheme + 3..at];
            match credentials.find(':') {
                Some(colon) => format!(
                    "{}{}:***{}",
                    &db[..scheme + 3],
                    &credentials[..colon],
                    &db[at..]
                ),
                None => db.to_string(),
            }
        }
        _ => db.to_string(),
    }
}

/// Run a worker process (no HTTP) until a shutdown signal.
pub async fn worker(config: WorkerConfig) -> Result<(), WsmError> {
    let store = open_store(&config.db, config.store_timeout).await?;
    let owner = owner_name("worker");
    let live = Arc::new(Live::default());
    println!(
        "wsm: worker {owner} on {} ({} threads)",
        redact(&config.db),
        config.threads.map_or("all".into(), |n| n.to_string())
    );
    spawn_workers(
        store.clone(),
        live.clone(),
        RunnerConfig {
            workers: config.jobs,
            threads_per_job: config.threads,
            lease_seconds: config.lease_seconds,
            owner: owner.clone(),
            max_attempts: config.max_attempts,
            max_solve_memory: config.max_solve_memory,
            inject_failures: Vec::new(),
        },
    );
    shutdown().await;
    release_on_shutdown(&store, &live, &owner).await;
    Ok(())
}

/// Run the service until a shutdown signal.
pub async fn serve(config: ServeConfig) -> Result<(), WsmError> {
    if config.access.read_token.is_some() && config.access.token.is_none() {
        return Err(WsmError::io(
            "WSM_READ_TOKEN",
            "a read token needs WSM_API_TOKEN too (without it every endpoint is open anyway)",
        ));
    }
    crate::http::check_max_connections(config.connections.max_connections)
        .map_err(|why| WsmError::io("--max-connections", why))?;
    let store = open_store(&config.db, config.store_timeout).await?;
    let live = Arc::new(Live::default());
    let owner = owner_name("serve");
    let health = Arc::new(StoreHealth::default());
    spawn_monitor(store.clone(), health.clone());
    // With no job slots the server only serves: `wsm worker` processes do all the work.
    if config.workers > 0 {
        spawn_workers(
            store.clone(),
            live.clone(),
            RunnerConfig {
                workers: config.workers,
                threads_per_job: config.threads_per_job,
                lease_seconds: config.lease_seconds,
                owner: owner.clone(),
                max_attempts: config.max_attempts,
                max_solve_memory: config.limits.max_solve_memory,
                inject_failures: config.inject_failures.clone(),
            },
        );
    }
    let state = AppState {
        store: store.clone(),
        live: live.clone(),
        limits: Arc::new(config.limits.clone()),
        access: Arc::new(config.access.clone()),
        health,
        solves: SolveSlots::new(config.limits.max_concurrent_solves),
    };
    let app = crate::api::guarded(
        crate::api::router(state).merge(crate::web::router()),
        &config.limits,
    );
    let listener = tokio::net::TcpListener::bind(&config.addr)
        .await
        .map_err(|e| WsmError::io(&config.addr, e))?;
    let local = listener
        .local_addr()
        .map_err(|e| WsmError::io(&config.addr, e))?;
    println!(
        "wsm: serving http://{local}/ (dashboard), API at http://{local}/v1, database {}",
        redact(&config.db)
    );
    crate::http::serve(
        listener,
        app,
        config.connections.clone(),
        shutdown(),
        Duration::from_secs(10),
    )
    .await;
    release_on_shutdown(&store, &live, &owner).await;
    Ok(())
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
