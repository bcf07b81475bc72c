//! The job store on SQLite (the embedded default): one database file, WAL journal,
//! `synchronous=NORMAL`, foreign keys and a busy timeout on every pooled connection, the schema
//! of `migrations/sqlite` applied at start-up. Jobs are leased inside `BEGIN IMMEDIATE`
//! transactions, so two workers never take the same job (a deferred read-then-write transaction
//! would fail with SQLITE_BUSY at once instead of waiting).

use std::str::FromStr;
use std::time::Duration;

use sqlx::sqlite::{SqliteConnectOptions, SqliteJournalMode, SqlitePoolOptions, SqliteSynchronous};
use sqlx::{Row, SqlitePool};

use super::{
    now, JobEnd, JobRecord, JobState, JobStore, Lease, NewJob, Page, StoreError, StoreResult,
};
use crate::run::{Evaluation, ProgressEvent};

/// The SQLite job store.
#[derive(Clone)]
pub struct SqliteStore {
    pool: SqlitePool,
}

fn db(operation: &'static str) -> impl Fn(sqlx::Error) -> StoreError {
    move |e| StoreError(format!("{operation}: {e}"))
}

fn json<T: serde::Serialize>(value: &T) -> StoreResult<String> {
    serde_json::to_string(value).map_err(|e| StoreError(format!("encoding: {e}")))
}

fn parse<T: serde::de::DeserializeOwned>(text: &str, what: &str) -> StoreResult<T> {
    serde_json::from_str(text).map_err(|e| StoreError(format!("decoding {what}: {e}")))
}

impl SqliteStore {
    /// Open (creating if needed) the database file and apply the migrations.
    pub async fn open(path: &str) -> StoreResult<SqliteStore> {
        let options = SqliteConnectOptions::from_str(&format!("sqlite://{path}"))
            .map_err(db("database path"))?
            .create_if_missing(true)
            .journal_mode(SqliteJournalMode::Wal)
            .synchronous(SqliteSynchronous::Normal)
            .foreign_keys(true)
            .busy_timeout(Duration::from_secs(10));
        let pool = SqlitePoolOptions::new()
            .max_connections(8)
            .connect_with(options)
            .await
            .map_err(db("opening the database"))?;
        sqlx::migrate!("./migrations/sqlite")
            .run(&pool)
            .await
            .map_err(|e| StoreError(format!("migrations: {e}")))?;
        Ok(SqliteStore { pool })
    }

    fn record(row: &sqlx::sqlite::SqliteRow) -> StoreResult<JobRecord> {
        let get_text = |name: &str| -> StoreResult<String> {
            row.try_get::<String, _>(name).map_err(db("reading a job"))
        };
        let opt_text = |name: &str| -> StoreResult<Option<String>> {
            row.try_get::<Option<String>, _>(name)
                .map_err(db("reading a job"))
        };
        let state = get_text("state")?;
        Ok(JobRecord {
            id: get_text("id")?,
            state: JobState::parse(&state)
                .ok_or_else(|| StoreError(format!("unknown job state '{state}'")))?,
            scene: get_text("scene")?,
            settings: parse(&get_text("settings")?, "settings")?,
            scene_name: get_text("scene_name")?,
            criteria: parse(&get_text("criteria")?, "criteria")?,
            budget: row
                .try_get::<i64, _>("budget")
                .map_err(db("reading a job"))? as usize,
            run_hash: get_text("run_hash")?,
            created_at: row.try_get("created_at").map_err(db("reading a job"))?,
            started_at: row.try_get("started_at").map_err(db("reading a job"))?,
            finished_at: row.try_get("finished_at").map_err(db("reading a job"))?,
            attempts: row
                .try_get::<i64, _>("attempts")
                .map_err(db("reading a job"))? as u32,
            cancel_requested: row
                .try_get::<i64, _>("cancel_requested")
                .map_err(db("reading a job"))?
                != 0,
            progress: opt_text("progress")?
                .map(|t| parse(&t, "progress"))
                .transpose()?,
            evaluations: row
                .try_get::<i64, _>("evaluations")
                .map_err(db("reading a job"))? as usize,
            result: opt_text("result")?
                .map(|t| parse(&t, "result"))
                .transpose()?,
            error: opt_text("error")?,
            error_kind: opt_text("error_kind")?,
        })
    }
}

#[async_trait::async_trait]
impl JobStore for SqliteStore {
    async fn insert(&self, job: NewJob) -> StoreResult<()> {
        sqlx::query(
            "INSERT INTO jobs (id, state, scene, settings, scene_name, criteria, budget, run_hash, created_at)
             VALUES (?, 'queued', ?, ?, ?, ?, ?, ?, ?)",
        )
        .bind(&job.id)
        .bind(&job.scene)
        .bind(json(&job.settings)?)
        .bind(&job.scene_name)
        .bind(json(&job.criteria)?)
        .bind(job.budget as i64)
        .bind(&job.run_hash)
        .bind(now())
        .execute(&self.pool)
        .await
        .map_err(db("inserting a job"))?;
        Ok(())
    }

    async fn get(&self, id: &str) -> StoreResult<Option<JobRecord>> {
        let row = sqlx::query("SELECT * FROM jobs WHERE id = ?")
            .bind(id)
            .fetch_optional(&self.pool)
            .await
            .map_err(db("reading a job"))?;
        row.as_ref().map(Self::record).transpose()
    }

    async fn list(&self, state: Option<JobState>, page: Page) -> StoreResult<Vec<JobRecord>> {
        let rows = sqlx::query(
            "SELECT * FROM jobs WHERE (?1 IS NULL OR state = ?1)
             ORDER BY created_at DESC, id LIMIT ?2 OFFSET ?3",
        )
        .bind(state.map(JobState::as_str))
        .bind(page.limit as i64)
        .bind(page.offset as i64)
        .fetch_all(&self.pool)
        .await
        .map_err(db("listing jobs"))?;
        rows.iter().map(Self::record).collect()
    }

    async fn active_count(&self) -> StoreResult<usize> {
        let n: i64 =
            sqlx::query_scalar("SELECT COUNT(*) FROM jobs WHERE state IN ('queued', 'running')")
                .fetch_one(&self.pool)
                .await
                .map_err(db("counting jobs"))?;
        Ok(n as usize)
    }

    async fn lease(&self, owner: &str, lease_seconds: f64) -> StoreResult<Option<JobRecord>> {
        let mut tx = self
            .pool
            .begin_with("BEGIN IMMEDIATE")
            .await
            .map_err(db("leasing a job"))?;
        let t = now();
        let id: Option<String> = sqlx::query_scalar(
            "SELECT id FROM jobs
             WHERE state = 'queued' OR (state = 'running' AND lease_expires_at < ?)
             ORDER BY created_at, id LIMIT 1",
        )
        .bind(t)
        .fetch_optional(&mut *tx)
        .await
        .map_err(db("leasing a job"))?;
        let Some(id) = id else {
            tx.commit().await.map_err(db("leasing a job"))?;
            return Ok(None);
        };
        sqlx::query(
            "UPDATE jobs SET state = 'running', lease_owner = ?, lease_expires_at = ?,
                 attempts = attempts + 1, started_at = COALESCE(started_at, ?)
             WHERE id = ?",
        )
        .bind(owner)
        .bind(t + lease_seconds)
        .bind(t)
        .bind(&id)
        .execute(&mut *tx)
        .await
        .map_err(db("leasing a job"))?;
        let row = sqlx::query("SELECT * FROM jobs WHERE id = ?")
            .bind(&id)
            .fetch_one(&mut *tx)
            .await
            .map_err(db("leasing a job"))?;
        tx.commit().await.map_err(db("leasing a job"))?;
        Self::record(&row).map(Some)
    }

    async fn renew(&self, id: &str, owner: &str, lease_seconds: f64) -> StoreResult<Lease> {
        let cancel: Option<i64> = sqlx::query_scalar(
            "UPDATE jobs SET lease_expires_at = ?
             WHERE id = ? AND lease_owner = ? AND state = 'running'
             RETURNING cancel_requested",
        )
        .bind(now() + lease_seconds)
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
        sqlx::query("UPDATE jobs SET progress = ? WHERE id = ? AND state = 'running'")
            .bind(json(progress)?)
            .bind(id)
            .execute(&self.pool)
            .await
            .map_err(db("storing progress"))?;
        Ok(())
    }

    async fn append_evaluation(
        &self,
        id: &str,
        owner: &str,
        evaluation: &Evaluation,
    ) -> StoreResult<usize> {
        let mut tx = self
            .pool
            .begin_with("BEGIN IMMEDIATE")
            .await
            .map_err(db("storing an evaluation"))?;
        let seq: i64 = sqlx::query_scalar(
            "SELECT COALESCE(MAX(seq), 0) + 1 FROM evaluations WHERE job_id = ?",
        )
        .bind(id)
        .fetch_one(&mut *tx)
        .await
        .map_err(db("storing an evaluation"))?;
        sqlx::query(
            "INSERT INTO evaluations (job_id, seq, body, worker, created_at) VALUES (?, ?, ?, ?, ?)",
        )
        .bind(id)
        .bind(seq)
        .bind(json(evaluation)?)
        .bind(owner)
        .bind(now())
        .execute(&mut *tx)
        .await
        .map_err(db("storing an evaluation"))?;
        sqlx::query("UPDATE jobs SET evaluations = ? WHERE id = ?")
            .bind(seq)
            .bind(id)
            .execute(&mut *tx)
            .await
            .map_err(db("storing an evaluation"))?;
        tx.commit().await.map_err(db("storing an evaluation"))?;
        Ok(seq as usize)
    }

    async fn evaluations(&self, id: &str, page: Option<Page>) -> StoreResult<Vec<Evaluation>> {
        let page = page.unwrap_or(Page {
            limit: i64::MAX as usize,
            offset: 0,
        });
        let bodies: Vec<String> = sqlx::query_scalar(
            "SELECT body FROM evaluations WHERE job_id = ? ORDER BY seq LIMIT ? OFFSET ?",
        )
        .bind(id)
        .bind(page.limit.min(i64::MAX as usize) as i64)
        .bind(page.offset as i64)
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
            JobEnd::Failed { kind, error } => (JobState::Failed, None, Some(error), Some(kind)),
        };
        sqlx::query(
            "UPDATE jobs SET state = ?, result = ?, error = ?, error_kind = ?, finished_at = ?,
                 lease_owner = NULL, lease_expires_at = NULL
             WHERE id = ? AND lease_owner = ?",
        )
        .bind(state.as_str())
        .bind(result)
        .bind(error)
        .bind(kind)
        .bind(now())
        .bind(id)
        .bind(owner)
        .execute(&self.pool)
        .await
        .map_err(db("finishing a job"))?;
        Ok(())
    }

    async fn request_cancel(&self, id: &str) -> StoreResult<bool> {
        let mut tx = self
            .pool
            .begin_with("BEGIN IMMEDIATE")
            .await
            .map_err(db("cancelling a job"))?;
        let cancelled = sqlx::query(
            "UPDATE jobs SET state = 'cancelled', cancel_requested = 1, finished_at = ?
             WHERE id = ? AND state = 'queued'",
        )
        .bind(now())
        .bind(id)
        .execute(&mut *tx)
        .await
        .map_err(db("cancelling a job"))?
        .rows_affected()
            == 1;
        if !cancelled {
            sqlx::query("UPDATE jobs SET cancel_requested = 1 WHERE id = ? AND state = 'running'")
                .bind(id)
                .execute(&mut *tx)
                .await
                .map_err(db("cancelling a job"))?;
        }
        tx.commit().await.map_err(db("cancelling a job"))?;
        Ok(cancelled)
    }
}
