//! The job store on SQL, one implementation for both backends through sqlx's `Any` driver:
//! SQLite (the embedded default: one database file, WAL journal, `synchronous=NORMAL`, foreign
//! keys and a busy timeout on every pooled connection) and PostgreSQL (scale-out: many `wsm
//! worker` processes on many machines). Each backend has its own migrations
//! (`migrations/sqlite`, `migrations/postgres`), applied at start-up.
//!
//! The statements are shared (`$n` placeholders work on both); the backends differ only in
//! their clock expression, in how a lease locks a row (SQLite: the whole write inside `BEGIN
//! IMMEDIATE`, so two workers never take the same job; PostgreSQL: `FOR UPDATE SKIP LOCKED`, so
//! workers lease different rows at once) and in how waiting processes are woken (PostgreSQL:
//! `LISTEN/NOTIFY` across processes; SQLite: in-process notification plus polling). All lease
//! times come from the database clock, never from a worker's.

use std::str::FromStr;
use std::sync::Arc;
use std::time::Duration;

use sqlx::any::{AnyConnectOptions, AnyPoolOptions, AnyRow};
use sqlx::{AnyPool, Connection, Executor, Row};
use tokio::sync::watch;

use super::{
    JobEnd, JobInput, JobRecord, JobState, JobStore, Lease, NewJob, Page, Signal, StoreError,
    StoreResult, TaskKey, TaskKind, TaskRecord, TaskScope,
};
use crate::error_code::ErrorCode;
use wsm_core::{Evaluation, ProgressEvent, RefinedOutcome};

/// The database behind the store.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    /// A SQLite file: the embedded default, shared at most by processes on one machine.
    Sqlite,
    /// A PostgreSQL server: shared by workers on several machines (scale-out), with notifications.
    Postgres,
}

impl Backend {
    /// The backend of a database argument: a `postgres://` (or `postgresql://`) URL, else a
    /// SQLite file path (or `sqlite://` URL).
    pub fn of(db: &str) -> Backend {
        if db.starts_with("postgres://") || db.starts_with("postgresql://") {
            Backend::Postgres
        } else {
            Backend::Sqlite
        }
    }

    /// Now, in Unix seconds, by the database's clock.
    fn now(self) -> &'static str {
        match self {
            Backend::Sqlite => "((julianday('now') - 2440587.5) * 86400.0)",
            Backend::Postgres => "(extract(epoch from clock_timestamp())::double precision)",
        }
    }

    /// The transaction of a lease: SQLite takes the write lock at once (a deferred
    /// read-then-write transaction would fail with SQLITE_BUSY instead of waiting).
    /// The statement that opens a write transaction. Task bookkeeping (`relaxed`) need not wait
    /// for the disk on PostgreSQL: a server crash can only lose the last moments of task
    /// traffic, and a lost completion is recomputed (its evaluations and the task's state are in
    /// one transaction, so they are lost together or not at all). One round trip either way.
    fn begin_write(self, relaxed: bool) -> &'static str {
        match (self, relaxed) {
            (Backend::Sqlite, _) => "BEGIN IMMEDIATE",
            (Backend::Postgres, false) => "BEGIN",
            (Backend::Postgres, true) => "BEGIN; SET LOCAL synchronous_commit TO OFF",
        }
    }

    /// Appends to a job's evaluations lock its row (sequence numbers stay dense); SQLite's write
    /// transaction already holds the whole database.
    fn serialise_appends(self) -> &'static str {
        match self {
            Backend::Sqlite => "",
            Backend::Postgres => " FOR UPDATE",
        }
    }

    /// How the row a lease picks is locked against the other workers.
    fn lock_row(self) -> &'static str {
        match self {
            Backend::Sqlite => "",
            Backend::Postgres => " FOR UPDATE SKIP LOCKED",
        }
    }
}

/// Queued and running jobs.
const ACTIVE_COUNT: &str = "SELECT COUNT(*) FROM jobs WHERE state IN ('queued', 'running')";

/// The advisory lock (PostgreSQL) under which a submission counts the active jobs and inserts.
const SUBMISSION_LOCK: i64 = 0x0077_736d_0001; // "wsm" 1

/// What a listing reads: every column but the scene document (up to the body limit per job).
const LISTED_COLUMNS: &str = "id, state, '' AS scene, settings, scene_name, criteria, budget,
    run_hash, created_at, started_at, finished_at, attempts, cancel_requested, progress,
    evaluations, result, error, error_kind, lease_expires_at";

/// The notification channels on PostgreSQL.
const WORK_CHANNEL: &str = "wsm_work";
const RESULTS_CHANNEL: &str = "wsm_results";

/// The job store.
#[derive(Clone)]
pub struct SqlStore {
    pool: AnyPool,
    backend: Backend,
    /// Raised when a job or task may be waiting (a local write, or a notification).
    work: Arc<watch::Sender<u64>>,
    /// Raised when a task may have completed.
    results: Arc<watch::Sender<u64>>,
}

fn raise(signal: &watch::Sender<u64>) {
    signal.send_modify(|n| *n = n.wrapping_add(1));
}

fn db(operation: &'static str) -> impl Fn(sqlx::Error) -> StoreError {
    move |e| {
        let message = format!("{operation}: {e}");
        if unavailable(&e) {
            StoreError::unavailable(message)
        } else {
            StoreError::new(message)
        }
    }
}

/// Whether a database error may pass by itself: the database is locked past the timeout, full,
/// read-only, failing its I/O or unreachable (SQLite's primary result codes BUSY, LOCKED, NOMEM,
/// READONLY, INTERRUPT, IOERR, FULL, CANTOPEN, PROTOCOL; PostgreSQL's SQLSTATE classes 08
/// connection, 40 rollback, 53 resources, 57 operator intervention, 58 system, and lock
/// timeouts or a read-only transaction) — as opposed to a statement or row that fails again.
fn unavailable(e: &sqlx::Error) -> bool {
    match e {
        sqlx::Error::Io(_)
        | sqlx::Error::Tls(_)
        | sqlx::Error::Protocol(_)
        | sqlx::Error::PoolTimedOut
        | sqlx::Error::PoolClosed
        | sqlx::Error::WorkerCrashed
        | sqlx::Error::BeginFailed
        | sqlx::Error::InvalidSavePointStatement => true,
        sqlx::Error::Database(d) => match d.try_downcast_ref::<sqlx::postgres::PgDatabaseError>() {
            Some(pg) => {
                let code = pg.code();
                ["08", "40", "53", "57", "58"]
                    .iter()
                    .any(|class| code.starts_with(class))
                    || code == "55P03"
                    || code == "25006"
            }
            None => d
                .code()
                .and_then(|c| c.parse::<i32>().ok())
                .is_some_and(|c| matches!(c & 0xff, 5..=10 | 13..=15)),
        },
        _ => false,
    }
}

/// A statement assembled from constant pieces (the backend's clock and locking clauses).
fn sql(text: String) -> sqlx::AssertSqlSafe<String> {
    sqlx::AssertSqlSafe(text)
}

fn json<T: serde::Serialize>(value: &T) -> StoreResult<String> {
    serde_json::to_string(value).map_err(|e| StoreError::new(format!("encoding: {e}")))
}

fn parse<T: serde::de::DeserializeOwned>(text: &str, what: &str) -> StoreResult<T> {
    serde_json::from_str(text).map_err(|e| StoreError::new(format!("decoding {what}: {e}")))
}

/// How long a statement waits for a lock another connection or process holds before it fails
/// (unavailable): SQLite's busy timeout, PostgreSQL's `lock_timeout`.
pub const DEFAULT_LOCK_TIMEOUT: Duration = Duration::from_secs(10);

/// The settings of every pooled connection: on SQLite the journal, foreign keys and the busy
/// timeout, on PostgreSQL the lock timeout.
async fn prepare(
    conn: &mut sqlx::AnyConnection,
    backend: Backend,
    lock_timeout: Duration,
) -> Result<(), sqlx::Error> {
    let millis = lock_timeout.as_millis();
    let statement = match backend {
        Backend::Sqlite => format!(
            "PRAGMA journal_mode = WAL; PRAGMA synchronous = NORMAL;
             PRAGMA foreign_keys = ON; PRAGMA busy_timeout = {millis};"
        ),
        Backend::Postgres => format!("SET lock_timeout = {millis}"),
    };
    conn.execute(sqlx::AssertSqlSafe(statement)).await?;
    Ok(())
}

/// Whether a connection given back to the pool is fit to be lent again: its transaction, if
/// one failed, has been rolled back (the ping runs after the rollback its drop queued). A
/// connection still in a transaction — SQLite rolls a transaction back by itself after an I/O
/// error or a full disk, and sqlx's own ROLLBACK then fails and leaves its count at one — is
/// closed instead: lent again, its next `BEGIN` would fail ("begin_with at non-zero transaction
/// depth") for as long as the process lives.
async fn fit_for_reuse(conn: &mut sqlx::AnyConnection) -> Result<bool, sqlx::Error> {
    conn.ping().await?;
    Ok(!conn.is_in_transaction())
}

/// Refuse a file that exists but is not a SQLite database (SQLite itself would only say so on
/// the first statement).
fn check_sqlite_header(url: &str) -> StoreResult<()> {
    let path = url
        .trim_start_matches("sqlite://")
        .trim_start_matches("sqlite:");
    let path = path.split('?').next().unwrap_or(path);
    let Ok(mut file) = std::fs::File::open(path) else {
        return Ok(()); // created on open
    };
    let mut header = [0u8; 16];
    use std::io::Read;
    match file.read(&mut header) {
        Ok(0) => Ok(()), // an empty file becomes a new database
        Ok(n) if n == header.len() && &header == b"SQLite format 3\0" => Ok(()),
        Ok(_) => Err(StoreError::new(format!(
            "'{path}' is not a SQLite database (it does not start with the SQLite header); \
             give a new file name or the right file"
        ))),
        Err(e) => Err(StoreError::new(format!("reading '{path}': {e}"))),
    }
}

/// `PRAGMA quick_check` (SQLite): a damaged database is refused at start instead of being
/// written to.
async fn check_integrity(conn: &mut sqlx::AnyConnection) -> StoreResult<()> {
    let check = db("checking the database's integrity");
    let rows: Vec<String> = sqlx::query_scalar("PRAGMA quick_check")
        .fetch_all(&mut *conn)
        .await
        .map_err(&check)?;
    if rows.len() == 1 && rows[0] == "ok" {
        return Ok(());
    }
    let shown: Vec<&str> = rows.iter().take(3).map(String::as_str).collect();
    Err(StoreError::new(format!(
        "the database is damaged (PRAGMA quick_check: {}); restore it from a backup or start \
         with a new file",
        shown.join("; ")
    )))
}

/// A column of a job row, or `None` with the reason added to `damage`.
fn column<T>(row: &AnyRow, name: &str, damage: &mut Vec<String>) -> Option<T>
where
    T: for<'r> sqlx::Decode<'r, sqlx::Any> + sqlx::Type<sqlx::Any>,
{
    row.try_get(name)
        .map_err(|e| damage.push(format!("{name}: {e}")))
        .ok()
}

/// A JSON column of a job row (`T` = `Option<_>` for a nullable one), or `None` with the reason
/// added to `damage`.
fn json_column<T: serde::de::DeserializeOwned>(
    row: &AnyRow,
    name: &str,
    damage: &mut Vec<String>,
) -> Option<T> {
    let text: Option<String> = column(row, name, damage)?;
    let text = text.unwrap_or_else(|| "null".into());
    serde_json::from_str(&text)
        .map_err(|e| damage.push(format!("{name}: not the JSON it should be ({e})")))
        .ok()
}

/// The `error_kind` column of a job row: the code's name as [`ErrorCode::name`] writes it;
/// `None` when there is none, or (with the reason added to `damage`) when it names no code.
fn error_code_column(row: &AnyRow, damage: &mut Vec<String>) -> Option<ErrorCode> {
    let text: String = column::<Option<String>>(row, "error_kind", damage).flatten()?;
    let code = ErrorCode::parse(&text);
    if code.is_none() {
        damage.push(format!("error_kind: unknown error code '{text}'"));
    }
    code
}

impl SqlStore {
    /// Open the database (a SQLite file, created if needed, or a PostgreSQL URL) and apply the
    /// backend's migrations.
    pub async fn open(db_arg: &str) -> StoreResult<SqlStore> {
        SqlStore::open_with(db_arg, DEFAULT_LOCK_TIMEOUT).await
    }

    /// [`SqlStore::open`] with a lock timeout other than [`DEFAULT_LOCK_TIMEOUT`].
    pub async fn open_with(db_arg: &str, lock_timeout: Duration) -> StoreResult<SqlStore> {
        sqlx::any::install_default_drivers();
        let backend = Backend::of(db_arg);
        let url = match backend {
            Backend::Postgres => db_arg.to_string(),
            Backend::Sqlite if db_arg.starts_with("sqlite:") => db_arg.to_string(),
            Backend::Sqlite => format!("sqlite://{db_arg}?mode=rwc"),
        };
        if backend == Backend::Sqlite {
            check_sqlite_header(&url)?;
        }
        let options = AnyConnectOptions::from_str(&url).map_err(db("database address"))?;
        // One connection first: a damaged file answers with its own error at once (a pool
        // would retry the connection until its timeout and report only that).
        let mut first = sqlx::AnyConnection::connect_with(&options)
            .await
            .map_err(db("opening the database"))?;
        prepare(&mut first, backend, lock_timeout)
            .await
            .map_err(db("opening the database"))?;
        if backend == Backend::Sqlite {
            check_integrity(&mut first).await?;
        }
        first.close().await.map_err(db("opening the database"))?;
        let pool = AnyPoolOptions::new()
            .max_connections(8)
            .acquire_timeout(Duration::from_secs(15))
            .after_connect(move |conn, _| Box::pin(prepare(conn, backend, lock_timeout)))
            .after_release(|conn, _| Box::pin(fit_for_reuse(conn)))
            .connect_with(options)
            .await
            .map_err(db("opening the database"))?;
        let migrator = match backend {
            Backend::Sqlite => super::migrations::sqlite(),
            Backend::Postgres => super::migrations::postgres(),
        };
        migrator
            .run(&pool)
            .await
            .map_err(|e| StoreError::new(format!("migrations: {e}")))?;
        let store = SqlStore {
            pool,
            backend,
            work: Arc::new(watch::channel(0).0),
            results: Arc::new(watch::channel(0).0),
        };
        store.check_writable().await?;
        if backend == Backend::Postgres {
            store.listen(&url).await?;
        }
        Ok(store)
    }

    /// The database behind this store.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// Turn PostgreSQL notifications into local wake-ups (reconnecting after a lost connection;
    /// waiters also poll, so a missed notification only delays them).
    async fn listen(&self, url: &str) -> StoreResult<()> {
        let mut listener = sqlx::postgres::PgListener::connect(url)
            .await
            .map_err(db("listening for notifications"))?;
        listener
            .listen_all([WORK_CHANNEL, RESULTS_CHANNEL])
            .await
            .map_err(db("listening for notifications"))?;
        let (work, results) = (self.work.clone(), self.results.clone());
        tokio::spawn(async move {
            loop {
                match listener.recv().await {
                    Ok(n) if n.channel() == RESULTS_CHANNEL => raise(&results),
                    Ok(_) => raise(&work),
                    Err(_) => tokio::time::sleep(Duration::from_millis(200)).await,
                }
            }
        });
        Ok(())
    }

    /// Tell waiting workers (here and, on PostgreSQL, in other processes) about new work.
    async fn announce(&self, channel: &'static str) {
        let local = if channel == RESULTS_CHANNEL {
            &self.results
        } else {
            &self.work
        };
        raise(local);
        if self.backend == Backend::Postgres {
            let _ = sqlx::query("SELECT pg_notify($1, '')")
                .bind(channel)
                .execute(&self.pool)
                .await;
        }
    }

    /// A write transaction (`Backend::begin_write`); `relaxed` for task traffic
    /// (`Backend::relaxed_commit`).
    async fn begin_write(
        &self,
        relaxed: bool,
        error: &impl Fn(sqlx::Error) -> StoreError,
    ) -> StoreResult<sqlx::Transaction<'static, sqlx::Any>> {
        self.pool
            .begin_with(self.backend.begin_write(relaxed))
            .await
            .map_err(error)
    }

    /// A job row. Only its id must be readable: a column that does not decode (a damaged row)
    /// leaves its field empty and is named in `damaged`, so that one bad row never hides the
    /// others in a listing (and is never run: the runner fails it at once).
    fn record(row: &AnyRow) -> StoreResult<JobRecord> {
        let id: String = row.try_get("id").map_err(db("reading a job"))?;
        let mut damage = Vec::new();
        let d = &mut damage;
        let state_text: Option<String> = column(row, "state", d);
        let state = match state_text.as_deref().map(|t| (t, JobState::parse(t))) {
            Some((_, Some(state))) => state,
            Some((text, None)) => {
                d.push(format!("state: unknown job state '{text}'"));
                JobState::Failed
            }
            None => JobState::Failed,
        };
        let int = |name: &str, d: &mut Vec<String>| column::<i64>(row, name, d).unwrap_or(0);
        let record = JobRecord {
            state,
            scene: column(row, "scene", d).unwrap_or_default(),
            settings: json_column(row, "settings", d).unwrap_or_default(),
            scene_name: column(row, "scene_name", d).unwrap_or_default(),
            criteria: json_column(row, "criteria", d).unwrap_or_default(),
            budget: int("budget", d).max(0) as usize,
            run_hash: column(row, "run_hash", d).unwrap_or_default(),
            created_at: column(row, "created_at", d).unwrap_or(0.0),
            started_at: column(row, "started_at", d).flatten(),
            finished_at: column(row, "finished_at", d).flatten(),
            attempts: int("attempts", d).clamp(0, u32::MAX as i64) as u32,
            cancel_requested: int("cancel_requested", d) != 0,
            progress: json_column(row, "progress", d).flatten(),
            evaluations: int("evaluations", d).max(0) as usize,
            result: json_column(row, "result", d).flatten(),
            error: column(row, "error", d).flatten(),
            error_kind: error_code_column(row, d),
            lease_expires_at: column(row, "lease_expires_at", d).flatten(),
            damaged: None,
            id,
        };
        Ok(JobRecord {
            damaged: (!damage.is_empty()).then(|| damage.join("; ")),
            ..record
        })
    }

    /// The results of a batch's tasks, concatenated in part order, once every part is done
    /// (`None` before).
    async fn done_parts<T: serde::de::DeserializeOwned>(
        &self,
        id: &str,
        attempt: u32,
        batch: u64,
    ) -> StoreResult<Option<Vec<T>>> {
        let rows = sqlx::query(
            "SELECT state, results FROM tasks
             WHERE job_id = $1 AND attempt = $2 AND batch = $3 ORDER BY part",
        )
        .bind(id)
        .bind(attempt as i64)
        .bind(batch as i64)
        .fetch_all(&self.pool)
        .await
        .map_err(db("reading a batch"))?;
        if rows.is_empty() {
            return Err(StoreError::new(format!(
                "reading a batch: the tasks of job {id} batch {batch} are gone"
            )));
        }
        let read = db("reading a batch");
        let mut results = Vec::new();
        for row in &rows {
            let text: Option<String> = row.try_get("results").map_err(&read)?;
            match text {
                Some(text) if row.try_get::<String, _>("state").map_err(&read)? == "done" => {
                    results.extend(parse::<Vec<T>>(&text, "task results")?)
                }
                _ => return Ok(None),
            }
        }
        Ok(Some(results))
    }

    /// Append evaluations to a job's log inside `tx` (sequence numbers continue the job's).
    async fn append_in(
        tx: &mut sqlx::AnyConnection,
        now: &str,
        id: &str,
        worker: &str,
        evaluations: &[Evaluation],
    ) -> StoreResult<()> {
        let store = db("storing an evaluation");
        let mut seq: i64 =
            sqlx::query_scalar("SELECT COALESCE(MAX(seq), 0) FROM evaluations WHERE job_id = $1")
                .bind(id)
                .fetch_one(&mut *tx)
                .await
                .map_err(&store)?;
        // One statement for the whole list: rows (job, seq, body) after the shared worker.
        if !evaluations.is_empty() {
            let rows: Vec<String> = (0..evaluations.len())
                .map(|i| format!("($1, ${}, ${}, $2, {now})", 3 + 2 * i, 4 + 2 * i))
                .collect();
            let statement = format!(
                "INSERT INTO evaluations (job_id, seq, body, worker, created_at) VALUES {}",
                rows.join(", ")
            );
            let mut insert = sqlx::query(sql(statement)).bind(id).bind(worker);
            for evaluation in evaluations {
                seq += 1;
                insert = insert.bind(seq).bind(json(evaluation)?);
            }
            insert.execute(&mut *tx).await.map_err(&store)?;
        }
        sqlx::query("UPDATE jobs SET evaluations = $1 WHERE id = $2")
            .bind(seq)
            .bind(id)
            .execute(&mut *tx)
            .await
            .map_err(&store)?;
        Ok(())
    }
}

/// A task still leased by a given owner: its key as `$1`…`$4`, the owner as `$5` (bound by
/// [`bind_task_key`]; further parameters start at `$6`).
const HELD_TASK: &str = "job_id = $1 AND attempt = $2 AND batch = $3 AND part = $4
    AND lease_owner = $5 AND state = 'running'";

/// Bind a task's key and its lease owner as `$1`…`$5` (see [`HELD_TASK`]).
fn bind_task_key<'q>(
    query: sqlx::query::Query<'q, sqlx::Any, sqlx::any::AnyArguments>,
    key: &'q TaskKey,
    owner: &'q str,
) -> sqlx::query::Query<'q, sqlx::Any, sqlx::any::AnyArguments> {
    query
        .bind(&key.job_id)
        .bind(key.attempt as i64)
        .bind(key.batch as i64)
        .bind(key.part as i64)
        .bind(owner)
}

/// Mark a task `owner` still holds done with its `results` (JSON), in a transaction or alone.
fn finish_task<'q>(
    backend: Backend,
    key: &'q TaskKey,
    owner: &'q str,
    results: String,
) -> sqlx::query::Query<'q, sqlx::Any, sqlx::any::AnyArguments> {
    bind_task_key(
        sqlx::query(sql(format!(
            "UPDATE tasks SET state = 'done', results = $6, finished_at = {},
                 lease_expires_at = NULL
             WHERE {HELD_TASK}",
            backend.now()
        ))),
        key,
        owner,
    )
    .bind(results)
}

#[async_trait::async_trait]
impl JobStore for SqlStore {
    async fn insert(&self, job: NewJob, max_active: usize) -> StoreResult<bool> {
        let insert = db("inserting a job");
        let mut tx = self.begin_write(false, &insert).await?;
        if self.backend == Backend::Postgres {
            // Submissions take turns (SQLite's write transaction already serialises them).
            sqlx::query(sql(format!(
                "SELECT pg_advisory_xact_lock({SUBMISSION_LOCK})"
            )))
            .execute(&mut *tx)
            .await
            .map_err(&insert)?;
        }
        let active: i64 = sqlx::query_scalar(ACTIVE_COUNT)
            .fetch_one(&mut *tx)
            .await
            .map_err(&insert)?;
        if active as usize >= max_active {
            tx.rollback().await.map_err(&insert)?;
            return Ok(false);
        }
        sqlx::query(sql(format!(
            "INSERT INTO jobs (id, state, scene, settings, scene_name, criteria, budget, run_hash, created_at)
             VALUES ($1, 'queued', $2, $3, $4, $5, $6, $7, {})",
            self.backend.now()
        )))
        .bind(&job.id)
        .bind(&job.scene)
        .bind(json(&job.settings)?)
        .bind(&job.scene_name)
        .bind(json(&job.criteria)?)
        .bind(job.budget as i64)
        .bind(&job.run_hash)
        .execute(&mut *tx)
        .await
        .map_err(&insert)?;
        tx.commit().await.map_err(&insert)?;
        self.announce(WORK_CHANNEL).await;
        Ok(true)
    }

    async fn get(&self, id: &str) -> StoreResult<Option<JobRecord>> {
        let row = sqlx::query("SELECT * FROM jobs WHERE id = $1")
            .bind(id)
            .fetch_optional(&self.pool)
            .await
            .map_err(db("reading a job"))?;
        row.as_ref().map(Self::record).transpose()
    }

    async fn list(&self, state: Option<JobState>, page: Page) -> StoreResult<Vec<JobRecord>> {
        let rows = sqlx::query(sql(format!(
            "SELECT {LISTED_COLUMNS} FROM jobs WHERE ($1 = '' OR state = $1)
             ORDER BY created_at DESC, id LIMIT $2 OFFSET $3"
        )))
        .bind(state.map(JobState::as_str).unwrap_or(""))
        .bind(page.limit.min(i64::MAX as usize) as i64)
        .bind(page.offset.min(i64::MAX as usize) as i64)
        .fetch_all(&self.pool)
        .await
        .map_err(db("listing jobs"))?;
        // A row whose very id cannot be read is left out (and logged), never the whole list.
        Ok(rows
            .iter()
            .filter_map(|row| {
                Self::record(row)
                    .map_err(|e| tracing::warn!(error = %e, "listing jobs: a row left out"))
                    .ok()
            })
            .collect())
    }

    async fn active_count(&self) -> StoreResult<usize> {
        let n: i64 = sqlx::query_scalar(ACTIVE_COUNT)
            .fetch_one(&self.pool)
            .await
            .map_err(db("counting jobs"))?;
        Ok(n as usize)
    }

    async fn check_writable(&self) -> StoreResult<()> {
        // Committed: a write rolled back never reaches the disk, so it would pass on a database
        // whose files can no longer be written.
        sqlx::query(sql(format!(
            "INSERT INTO store_probe (id, probed_at) VALUES (1, {now})
             ON CONFLICT (id) DO UPDATE SET probed_at = {now}",
            now = self.backend.now()
        )))
        .execute(&self.pool)
        .await
        .map_err(db("the database does not take writes"))?;
        Ok(())
    }

    async fn release_all(&self, owner: &str) -> StoreResult<usize> {
        let release = db("giving leases back");
        let mut tx = self.begin_write(false, &release).await?;
        let jobs = sqlx::query(
            "UPDATE jobs SET state = 'queued', lease_owner = NULL, lease_expires_at = NULL
             WHERE lease_owner = $1 AND state = 'running'",
        )
        .bind(owner)
        .execute(&mut *tx)
        .await
        .map_err(&release)?
        .rows_affected();
        sqlx::query(
            "UPDATE tasks SET state = 'queued', lease_owner = NULL, lease_expires_at = NULL
             WHERE lease_owner = $1 AND state = 'running'",
        )
        .bind(owner)
        .execute(&mut *tx)
        .await
        .map_err(&release)?;
        tx.commit().await.map_err(&release)?;
        self.announce(WORK_CHANNEL).await;
        Ok(jobs as usize)
    }

    async fn lease(
        &self,
        owner: &str,
        lease_seconds: f64,
        max_attempts: u32,
    ) -> StoreResult<Option<JobRecord>> {
        let now = self.backend.now();
        let lease = db("leasing a job");
        let mut tx = self.begin_write(false, &lease).await?;
        let id = loop {
            let row = sqlx::query(sql(format!(
                "SELECT id, state, lost_leases FROM jobs
                 WHERE state = 'queued' OR (state = 'running' AND lease_expires_at < {now})
                 ORDER BY created_at, id LIMIT 1{}",
                self.backend.lock_row()
            )))
            .fetch_optional(&mut *tx)
            .await
            .map_err(&lease)?;
            let Some(row) = row else {
                tx.commit().await.map_err(&lease)?;
                return Ok(None);
            };
            let id: String = row.try_get("id").map_err(&lease)?;
            let state: String = row.try_get("state").map_err(&lease)?;
            if state == "queued" {
                break id;
            }
            // Its worker died or hung: counted, and after `max_attempts` of them not run again.
            let lost = row.try_get::<i64, _>("lost_leases").map_err(&lease)? + 1;
            if lost < i64::from(max_attempts) {
                sqlx::query("UPDATE jobs SET lost_leases = $1 WHERE id = $2")
                    .bind(lost)
                    .bind(&id)
                    .execute(&mut *tx)
                    .await
                    .map_err(&lease)?;
                break id;
            }
            let error = format!(
                "the job's worker stopped without finishing it {lost} times (its lease expired \
                 each time: the process was killed, for example for lack of memory, or hung); \
                 not run again (wsm serve --max-attempts {max_attempts})"
            );
            sqlx::query(sql(format!(
                "UPDATE jobs SET state = 'failed', lost_leases = $1, error = $2,
                     error_kind = $3, finished_at = {now},
                     lease_owner = NULL, lease_expires_at = NULL
                 WHERE id = $4"
            )))
            .bind(lost)
            .bind(error)
            .bind(ErrorCode::AttemptsExhausted.name())
            .bind(&id)
            .execute(&mut *tx)
            .await
            .map_err(&lease)?;
            delete_tasks(&mut tx, &id).await.map_err(&lease)?;
        };
        let row = sqlx::query(sql(format!(
            "UPDATE jobs SET state = 'running', lease_owner = $1, lease_expires_at = {now} + $2,
                 attempts = attempts + 1, started_at = COALESCE(started_at, {now})
             WHERE id = $3 RETURNING *"
        )))
        .bind(owner)
        .bind(lease_seconds)
        .bind(&id)
        .fetch_one(&mut *tx)
        .await
        .map_err(&lease)?;
        // The tasks of an earlier attempt belong to a coordinator that is gone.
        delete_tasks(&mut tx, &id).await.map_err(&lease)?;
        tx.commit().await.map_err(&lease)?;
        // Idle workers prepare the job's model ahead of its first fanned-out batch.
        self.announce(WORK_CHANNEL).await;
        Self::record(&row).map(Some)
    }

    async fn renew(&self, id: &str, owner: &str, lease_seconds: f64) -> StoreResult<Lease> {
        let cancel: Option<i64> = sqlx::query_scalar(sql(format!(
            "UPDATE jobs SET lease_expires_at = {} + $1
             WHERE id = $2 AND lease_owner = $3 AND state = 'running'
             RETURNING cancel_requested",
            self.backend.now()
        )))
        .bind(lease_seconds)
        .bind(id)
        .bind(owner)
        .fetch_optional(&self.pool)
        .await
        .map_err(db("renewing a lease"))?;
        Ok(match cancel {
            Some(flag) => Lease::Held {
                cancel_requested: flag != 0,
            },
            None => Lease::Lost,
        })
    }

    async fn set_progress(&self, id: &str, progress: &ProgressEvent) -> StoreResult<()> {
        sqlx::query("UPDATE jobs SET progress = $1 WHERE id = $2 AND state = 'running'")
            .bind(json(progress)?)
            .bind(id)
            .execute(&self.pool)
            .await
            .map_err(db("storing progress"))?;
        Ok(())
    }

    async fn append_evaluations(
        &self,
        id: &str,
        owner: &str,
        evaluations: &[Evaluation],
    ) -> StoreResult<usize> {
        let store = db("storing an evaluation");
        let mut tx = self.begin_write(false, &store).await?;
        // Lock the job row: appends of one job are serialised (sequence numbers stay dense).
        let held: Option<String> = sqlx::query_scalar(sql(format!(
            "SELECT id FROM jobs WHERE id = $1 AND lease_owner = $2{}",
            self.backend.serialise_appends()
        )))
        .bind(id)
        .bind(owner)
        .fetch_optional(&mut *tx)
        .await
        .map_err(&store)?;
        if held.is_none() {
            return Err(StoreError::new(format!(
                "storing an evaluation: job {id} is no longer leased by this worker"
            )));
        }
        Self::append_in(&mut tx, self.backend.now(), id, owner, evaluations).await?;
        let seq: i64 = sqlx::query_scalar("SELECT evaluations FROM jobs WHERE id = $1")
            .bind(id)
            .fetch_one(&mut *tx)
            .await
            .map_err(&store)?;
        tx.commit().await.map_err(&store)?;
        Ok(seq as usize)
    }

    async fn evaluations(&self, id: &str, page: Option<Page>) -> StoreResult<Vec<Evaluation>> {
        let page = page.unwrap_or(Page {
            limit: i64::MAX as usize,
            offset: 0,
        });
        let bodies: Vec<String> = sqlx::query_scalar(
            "SELECT body FROM evaluations WHERE job_id = $1 ORDER BY seq LIMIT $2 OFFSET $3",
        )
        .bind(id)
        .bind(page.limit.min(i64::MAX as usize) as i64)
        .bind(page.offset.min(i64::MAX as usize) as i64)
        .fetch_all(&self.pool)
        .await
        .map_err(db("reading evaluations"))?;
        bodies.iter().map(|b| parse(b, "an evaluation")).collect()
    }

    async fn finish(&self, id: &str, owner: &str, end: JobEnd) -> StoreResult<()> {
        let (state, result, error, kind) = match end {
            JobEnd::Succeeded(outcome) => (JobState::Succeeded, Some(json(&outcome)?), None, None),
            JobEnd::Cancelled(outcome) => (
                JobState::Cancelled,
                outcome.as_ref().map(json).transpose()?,
                None,
                None,
            ),
            JobEnd::Failed { kind, error } => {
                (JobState::Failed, None, Some(error), Some(kind.name()))
            }
        };
        let finish = db("finishing a job");
        let mut tx = self.pool.begin().await.map_err(&finish)?;
        sqlx::query(sql(format!(
            "UPDATE jobs SET state = $1, result = $2, error = $3, error_kind = $4,
                 finished_at = {}, lease_owner = NULL, lease_expires_at = NULL
             WHERE id = $5 AND lease_owner = $6",
            self.backend.now()
        )))
        .bind(state.as_str())
        .bind(result)
        .bind(error)
        .bind(kind)
        .bind(id)
        .bind(owner)
        .execute(&mut *tx)
        .await
        .map_err(&finish)?;
        delete_tasks(&mut tx, id).await.map_err(&finish)?;
        tx.commit().await.map_err(&finish)?;
        Ok(())
    }

    async fn request_cancel(&self, id: &str) -> StoreResult<bool> {
        let cancel = db("cancelling a job");
        let mut tx = self.begin_write(false, &cancel).await?;
        let cancelled = sqlx::query(sql(format!(
            "UPDATE jobs SET state = 'cancelled', cancel_requested = 1, finished_at = {}
             WHERE id = $1 AND state = 'queued'",
            self.backend.now()
        )))
        .bind(id)
        .execute(&mut *tx)
        .await
        .map_err(&cancel)?
        .rows_affected()
            == 1;
        if !cancelled {
            sqlx::query("UPDATE jobs SET cancel_requested = 1 WHERE id = $1 AND state = 'running'")
                .bind(id)
                .execute(&mut *tx)
                .await
                .map_err(&cancel)?;
        }
        tx.commit().await.map_err(&cancel)?;
        Ok(cancelled)
    }

    async fn job_input(&self, id: &str) -> StoreResult<Option<JobInput>> {
        let row =
            sqlx::query("SELECT scene, settings, run_hash, chosen_scene FROM jobs WHERE id = $1")
                .bind(id)
                .fetch_optional(&self.pool)
                .await
                .map_err(db("reading a job"))?;
        let Some(row) = row else { return Ok(None) };
        let read = db("reading a job");
        Ok(Some(JobInput {
            scene: row.try_get("scene").map_err(&read)?,
            settings: parse(
                &row.try_get::<String, _>("settings").map_err(&read)?,
                "settings",
            )?,
            run_hash: row.try_get("run_hash").map_err(&read)?,
            chosen_scene: row.try_get("chosen_scene").map_err(&read)?,
        }))
    }

    async fn record_chosen_scene(&self, id: &str, owner: &str, scene: &str) -> StoreResult<bool> {
        let done = sqlx::query(
            "UPDATE jobs SET chosen_scene = $3
             WHERE id = $1 AND lease_owner = $2 AND state = 'running'",
        )
        .bind(id)
        .bind(owner)
        .bind(scene)
        .execute(&self.pool)
        .await
        .map_err(db("storing the chosen scene"))?;
        Ok(done.rows_affected() == 1)
    }

    async fn post_tasks(
        &self,
        id: &str,
        owner: &str,
        attempt: u32,
        batch: u64,
        kind: TaskKind,
        parts: &[Vec<Vec<f64>>],
    ) -> StoreResult<()> {
        let post = db("posting tasks");
        let now = self.backend.now();
        let mut tx = self.begin_write(true, &post).await?;
        let held: Option<i64> = sqlx::query_scalar(
            "SELECT attempts FROM jobs WHERE id = $1 AND lease_owner = $2 AND state = 'running'",
        )
        .bind(id)
        .bind(owner)
        .fetch_optional(&mut *tx)
        .await
        .map_err(&post)?;
        if held != Some(attempt as i64) {
            return Err(StoreError::new(format!(
                "posting tasks: job {id} is no longer coordinated by this worker"
            )));
        }
        // One statement for the whole batch: rows (part, points) after the shared key.
        if !parts.is_empty() {
            let rows: Vec<String> = (0..parts.len())
                .map(|i| {
                    format!(
                        "($1, $2, $3, $4, ${}, ${}, 'queued', {now})",
                        5 + 2 * i,
                        6 + 2 * i
                    )
                })
                .collect();
            let statement = format!(
                "INSERT INTO tasks (job_id, attempt, batch, refinement, part, points, state, created_at)
                 VALUES {}",
                rows.join(", ")
            );
            let mut insert = sqlx::query(sql(statement))
                .bind(id)
                .bind(attempt as i64)
                .bind(batch as i64)
                .bind(kind.refinement() as i64);
            for (part, points) in parts.iter().enumerate() {
                insert = insert.bind(part as i64).bind(json(points)?);
            }
            insert.execute(&mut *tx).await.map_err(&post)?;
        }
        tx.commit().await.map_err(&post)?;
        self.announce(WORK_CHANNEL).await;
        Ok(())
    }

    async fn coordinated_elsewhere(&self, owner: &str) -> StoreResult<Option<(String, String)>> {
        let row = sqlx::query(sql(format!(
            "SELECT id, run_hash FROM jobs
             WHERE state = 'running' AND COALESCE(lease_owner, '') <> $1
               AND lease_expires_at >= {}
             ORDER BY started_at DESC, id LIMIT 1",
            self.backend.now()
        )))
        .bind(owner)
        .fetch_optional(&self.pool)
        .await
        .map_err(db("looking for running jobs"))?;
        let read = db("reading a running job");
        row.map(|row| {
            Ok((
                row.try_get("id").map_err(&read)?,
                row.try_get("run_hash").map_err(&read)?,
            ))
        })
        .transpose()
    }

    async fn lease_task(
        &self,
        owner: &str,
        lease_seconds: f64,
        scope: TaskScope<'_>,
    ) -> StoreResult<Option<TaskRecord>> {
        let now = self.backend.now();
        let lease = db("leasing a task");
        let mut tx = self.begin_write(true, &lease).await?;
        let filter = match scope {
            TaskScope::Others => "COALESCE(j.lease_owner, '') <> $1",
            TaskScope::Batch { .. } => "t.job_id = $3 AND t.attempt = $4 AND t.batch = $5",
        };
        // Pick and lease in one statement.
        let statement = sql(format!(
            "UPDATE tasks SET state = 'running', lease_owner = $1, lease_expires_at = {now} + $2
             WHERE (job_id, attempt, batch, part) = (
                 SELECT t.job_id, t.attempt, t.batch, t.part
                 FROM tasks t JOIN jobs j ON j.id = t.job_id
                 WHERE (t.state = 'queued' OR (t.state = 'running' AND t.lease_expires_at < {now}))
                   AND {filter}
                 ORDER BY t.created_at, t.job_id, t.batch, t.part LIMIT 1{})
             RETURNING job_id, attempt, batch, part, refinement, points,
                 (SELECT run_hash FROM jobs WHERE jobs.id = tasks.job_id) AS run_hash",
            match self.backend {
                Backend::Sqlite => "",
                Backend::Postgres => " FOR UPDATE OF t SKIP LOCKED",
            }
        ));
        let query = sqlx::query(statement).bind(owner).bind(lease_seconds);
        let query = match scope {
            TaskScope::Others => query,
            TaskScope::Batch {
                job,
                attempt,
                batch,
            } => query.bind(job).bind(attempt as i64).bind(batch as i64),
        };
        let row = query.fetch_optional(&mut *tx).await.map_err(&lease)?;
        tx.commit().await.map_err(&lease)?;
        let Some(row) = row else {
            return Ok(None);
        };
        let key = TaskKey {
            job_id: row.try_get("job_id").map_err(&lease)?,
            attempt: row.try_get::<i64, _>("attempt").map_err(&lease)? as u32,
            batch: row.try_get::<i64, _>("batch").map_err(&lease)? as u64,
            part: row.try_get::<i64, _>("part").map_err(&lease)? as u32,
        };
        let points = parse(
            &row.try_get::<String, _>("points").map_err(&lease)?,
            "points",
        )?;
        let refinement = row.try_get::<i64, _>("refinement").map_err(&lease)?;
        Ok(Some(TaskRecord {
            key,
            kind: TaskKind::of_refinement(refinement.clamp(0, u32::MAX as i64) as u32),
            points,
            run_hash: row.try_get("run_hash").map_err(&lease)?,
        }))
    }

    async fn release_task(&self, key: &TaskKey, owner: &str) -> StoreResult<bool> {
        let n = bind_task_key(
            sqlx::query(sql(format!(
                "UPDATE tasks SET state = 'queued', lease_owner = NULL, lease_expires_at = NULL
                 WHERE {HELD_TASK}"
            ))),
            key,
            owner,
        )
        .execute(&self.pool)
        .await
        .map_err(db("releasing a task"))?
        .rows_affected();
        // Its coordinator waits on results and takes over what is queued; workers on work.
        self.announce(RESULTS_CHANNEL).await;
        self.announce(WORK_CHANNEL).await;
        Ok(n == 1)
    }

    async fn renew_task(
        &self,
        key: &TaskKey,
        owner: &str,
        lease_seconds: f64,
    ) -> StoreResult<bool> {
        let n = bind_task_key(
            sqlx::query(sql(format!(
                "UPDATE tasks SET lease_expires_at = {} + $6 WHERE {HELD_TASK}",
                self.backend.now()
            ))),
            key,
            owner,
        )
        .bind(lease_seconds)
        .execute(&self.pool)
        .await
        .map_err(db("renewing a task"))?
        .rows_affected();
        Ok(n == 1)
    }

    async fn complete_task(
        &self,
        key: &TaskKey,
        owner: &str,
        evaluations: &[Evaluation],
    ) -> StoreResult<bool> {
        let complete = db("completing a task");
        let now = self.backend.now();
        let mut tx = self.begin_write(true, &complete).await?;
        // Lock the job row first (appends of one job are serialised), then claim the task.
        sqlx::query(sql(format!(
            "SELECT id FROM jobs WHERE id = $1{}",
            self.backend.serialise_appends()
        )))
        .bind(&key.job_id)
        .fetch_optional(&mut *tx)
        .await
        .map_err(&complete)?;
        let claimed = finish_task(self.backend, key, owner, json(&evaluations)?)
            .execute(&mut *tx)
            .await
            .map_err(&complete)?
            .rows_affected()
            == 1;
        if !claimed {
            tx.rollback().await.map_err(&complete)?;
            return Ok(false);
        }
        Self::append_in(&mut tx, now, &key.job_id, owner, evaluations).await?;
        tx.commit().await.map_err(&complete)?;
        self.announce(RESULTS_CHANNEL).await;
        Ok(true)
    }

    async fn batch_results(
        &self,
        id: &str,
        attempt: u32,
        batch: u64,
    ) -> StoreResult<Option<Vec<Evaluation>>> {
        self.done_parts(id, attempt, batch).await
    }

    async fn complete_refined_task(
        &self,
        key: &TaskKey,
        owner: &str,
        values: &[RefinedOutcome],
    ) -> StoreResult<bool> {
        let complete = db("completing a task");
        let claimed = finish_task(self.backend, key, owner, json(&values)?)
            .execute(&self.pool)
            .await
            .map_err(&complete)?
            .rows_affected()
            == 1;
        if claimed {
            self.announce(RESULTS_CHANNEL).await;
        }
        Ok(claimed)
    }

    async fn refined_results(
        &self,
        id: &str,
        attempt: u32,
        batch: u64,
    ) -> StoreResult<Option<Vec<RefinedOutcome>>> {
        self.done_parts(id, attempt, batch).await
    }

    async fn register_worker(&self, owner: &str, threads: usize) -> StoreResult<()> {
        let now = self.backend.now();
        sqlx::query(sql(format!(
            "INSERT INTO workers (owner, threads, started_at, last_seen) VALUES ($1, $2, {now}, {now})
             ON CONFLICT (owner) DO UPDATE SET threads = $2, last_seen = {now}"
        )))
        .bind(owner)
        .bind(threads as i64)
        .execute(&self.pool)
        .await
        .map_err(db("registering a worker"))?;
        Ok(())
    }

    async fn live_threads(&self, seconds: f64) -> StoreResult<usize> {
        let n: i64 = sqlx::query_scalar(sql(format!(
            "SELECT CAST(COALESCE(SUM(threads), 0) AS BIGINT) FROM workers WHERE last_seen >= {} - $1",
            self.backend.now()
        )))
        .bind(seconds)
        .fetch_one(&self.pool)
        .await
        .map_err(db("counting workers"))?;
        Ok(n.max(0) as usize)
    }

    fn work_signal(&self) -> Signal {
        self.work.subscribe()
    }

    fn results_signal(&self) -> Signal {
        self.results.subscribe()
    }
}

/// Drop a job's fan-out tasks (those of an earlier attempt, or of a job that ended).
async fn delete_tasks(
    tx: &mut sqlx::Transaction<'static, sqlx::Any>,
    job_id: &str,
) -> Result<(), sqlx::Error> {
    sqlx::query("DELETE FROM tasks WHERE job_id = $1")
        .bind(job_id)
        .execute(&mut **tx)
        .await
        .map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;
    use wsm_core::{Criterion, CriterionSpec};

    /// A fresh SQLite store in the temporary folder.
    async fn store() -> SqlStore {
        let dir = std::env::temp_dir().join(format!("wsm-sql-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("{}.db", uuid::Uuid::new_v4()));
        SqlStore::open(path.to_str().unwrap()).await.unwrap()
    }

    fn job(id: &str) -> NewJob {
        NewJob {
            id: id.into(),
            scene: "{}".into(),
            settings: Default::default(),
            scene_name: "s".into(),
            criteria: vec![Criterion::Phi3.into()],
            budget: 1,
            run_hash: "h".into(),
        }
    }

    /// A failed job's row as earlier versions wrote it — criteria and error kind as plain
    /// names — reads back typed; a job ended now writes the same text again, and a kind no
    /// version wrote marks the row damaged (listed with the reason, never run).
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn rows_written_with_names_read_back_typed_and_are_written_the_same() {
        let store = store().await;
        let old_row = |id: String, kind: &'static str| {
            let store = &store;
            async move {
                sqlx::query(
                    r#"INSERT INTO jobs (id, state, scene, settings, scene_name, criteria, budget,
                         run_hash, created_at, error, error_kind)
                     VALUES ($1, 'failed', '{}', '{}', 's', '["phi3","phi6@G1","peak"]', 1, 'h', 0,
                         'why', $2)"#,
                )
                .bind(id.clone())
                .bind(kind)
                .execute(&store.pool)
                .await
                .unwrap();
                store.get(&id).await.unwrap().unwrap()
            }
        };
        for kind in [
            "bad_input",
            "solver",
            "panic",
            "damaged",
            "attempts_exhausted",
        ] {
            let record = old_row(format!("old-{kind}"), kind).await;
            assert_eq!(record.damaged, None, "{kind}");
            assert_eq!(record.error_kind.map(ErrorCode::name), Some(kind));
            let names: Vec<String> = record.criteria.iter().map(|c| c.name()).collect();
            assert_eq!(names, ["phi3", "phi6@G1", "peak"]);
            assert_eq!(record.criteria[2], CriterionSpec::defined("peak"));
        }
        let record = old_row("old-unknown".into(), "bogus").await;
        assert_eq!(record.error_kind, None);
        assert!(record
            .damaged
            .unwrap()
            .contains("error_kind: unknown error code 'bogus'"));

        let mut new = job("new");
        new.criteria = vec![
            Criterion::Phi3.into(),
            CriterionSpec::parse("phi6@G1").unwrap(),
            CriterionSpec::defined("peak"),
        ];
        assert!(store.insert(new, 10).await.unwrap());
        store.lease("w", 60.0, 3).await.unwrap().unwrap();
        let end = JobEnd::Failed {
            kind: ErrorCode::of_kind(wsm_core::ErrorKind::BadInput),
            error: "why".into(),
        };
        store.finish("new", "w", end).await.unwrap();
        let (criteria, kind): (String, String) =
            sqlx::query_as("SELECT criteria, error_kind FROM jobs WHERE id = 'new'")
                .fetch_one(&store.pool)
                .await
                .unwrap();
        assert_eq!(criteria, r#"["phi3","phi6@G1","peak"]"#);
        assert_eq!(kind, "bad_input");
    }

    /// SQLite ends a transaction by itself after an I/O error or a full disk; sqlx's ROLLBACK on
    /// drop then fails and its transaction count stays at one. Such a connection must not be
    /// lent again: every later write transaction on it would fail ("begin_with at non-zero
    /// transaction depth"). Reproduced by ending the transaction behind sqlx's back.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_connection_whose_transaction_ended_behind_sqlx_is_not_lent_again() {
        let store = store().await;
        for _ in 0..3 {
            let mut tx = store.pool.begin().await.unwrap();
            sqlx::query("ROLLBACK").execute(&mut *tx).await.unwrap();
            drop(tx);
        }
        // More write transactions than the pool has connections: every one must begin.
        for k in 0..20 {
            store
                .insert(job(&format!("j{k}")), usize::MAX)
                .await
                .unwrap_or_else(|e| panic!("insert {k}: {e}"));
        }
        assert_eq!(store.active_count().await.unwrap(), 20);
    }

    #[test]
    fn locks_and_lost_disks_are_unavailable_and_a_missing_row_is_not() {
        assert!(unavailable(&sqlx::Error::PoolTimedOut));
        assert!(unavailable(&sqlx::Error::InvalidSavePointStatement));
        assert!(!unavailable(&sqlx::Error::RowNotFound));
    }
}
