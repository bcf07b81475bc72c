//! The job queue of the service (design §5.4): worst-scenario jobs stored durably with their
//! lease, progress, every evaluation (stored chunk by chunk) and the outcome, behind the
//! [`JobStore`] trait, and the processes that work on them. The modules:
//!
//! - `sql`: the store, one sqlx implementation for SQLite (the embedded default) and PostgreSQL
//!   (scale-out);
//! - `health`: the background write probe behind `/healthz` (does the store still take writes?);
//! - `runner`: a worker process (`wsm serve`, `wsm worker`) — job slots that lease whole jobs and
//!   coordinate them (run the search), beside them the task loop of `task_worker` and the
//!   heartbeat that announces the process;
//! - `task_coordinator`: the coordinator's side of fanning out — a job's evaluation batches (and
//!   its accuracy statement's refined solves) posted as tasks, the coordinator's own share solved
//!   at once, abandoned tasks taken over, the results read back in input order;
//! - `task_worker`: the worker's side — the task loop of every worker process, which leases the
//!   tasks that other processes' coordinators posted, solves their points on a prepared model of
//!   the job and stores the results.
//!
//! A job's life: `queued` → `running` (leased by a worker, lease renewed by heartbeat) →
//! `succeeded` | `failed` | `cancelled`. A running job whose lease expired (its process died) is
//! leased again and resumed from its stored evaluations: none lost, none recomputed.
//!
//! Two levels of distribution (docs/scale-out.md, "Design"): a whole job goes to any free worker
//! process, which coordinates it (runs the search); when the store is shared by several processes,
//! the coordinator posts each evaluation batch as tasks that every worker leases, so one large job
//! uses all of them. Leases of jobs and tasks are renewed by heartbeat and expire by the database
//! clock; a task whose worker died is leased again, a job whose coordinator died is taken over.

pub mod health;
mod migrations;
pub mod runner;
pub mod sql;
pub mod task_coordinator;
pub mod task_worker;

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::error_code::ErrorCode;
use wsm_core::{
    CriterionSpec, Evaluation, ProgressEvent, RefinedOutcome, WorstOutcome, WorstRequest,
};

/// The state of a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    /// Waiting for a worker: new, or given back by a process shutting down.
    Queued,
    /// Leased by a worker, which coordinates the search and renews the lease by heartbeat.
    Running,
    /// The search ran to an outcome (completed, out of budget or out of time).
    Succeeded,
    /// Ended with an error (see the record's `error` and `error_kind`).
    Failed,
    /// Stopped on request; the partial outcome, if any, is kept.
    Cancelled,
}

impl JobState {
    /// Every state, in the order of a job's life.
    pub const ALL: [JobState; 5] = [
        JobState::Queued,
        JobState::Running,
        JobState::Succeeded,
        JobState::Failed,
        JobState::Cancelled,
    ];

    /// The state's name as stored in the database and shown by the API (`queued`, …).
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Succeeded => "succeeded",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
        }
    }

    /// The state named `text` (as written by [`JobState::as_str`]); `None` for an unknown name.
    pub fn parse(text: &str) -> Option<JobState> {
        JobState::ALL.into_iter().find(|s| s.as_str() == text)
    }

    /// Whether the job has ended: succeeded, failed or cancelled.
    pub fn is_finished(self) -> bool {
        matches!(
            self,
            JobState::Succeeded | JobState::Failed | JobState::Cancelled
        )
    }
}

/// A job to store: the validated scene and settings.
#[derive(Debug, Clone)]
pub struct NewJob {
    /// The job's id (a fresh UUID v4).
    pub id: String,
    /// The scene document (JSON text).
    pub scene: String,
    /// The search settings as submitted (resolved against the scene when the job runs).
    pub settings: WorstRequest,
    /// The scene's `name`, shown in listings.
    pub scene_name: String,
    /// The criteria searched (stored as their names: `phi3`, `phi3@crest`, …).
    pub criteria: Vec<CriterionSpec>,
    /// The most inner solves the search may spend.
    pub budget: usize,
    /// The run hash of the scene, criteria and target error (`wsm_core::run_hash`),
    /// which ties stored evaluations and tasks to this run.
    pub run_hash: String,
}

/// A stored job.
#[derive(Debug, Clone)]
pub struct JobRecord {
    /// The job's id (a UUID v4).
    pub id: String,
    /// Where the job is in its life.
    pub state: JobState,
    /// The scene document (JSON text); empty in listings, which do not read it.
    pub scene: String,
    /// The search settings as submitted.
    pub settings: WorstRequest,
    /// The scene's `name`.
    pub scene_name: String,
    /// The criteria searched.
    pub criteria: Vec<CriterionSpec>,
    /// The most inner solves the search may spend.
    pub budget: usize,
    /// The run hash of the scene, criteria and target error.
    pub run_hash: String,
    /// When the job was submitted (Unix seconds, database clock).
    pub created_at: f64,
    /// When it was first leased (Unix seconds, database clock); `None` until then.
    pub started_at: Option<f64>,
    /// When it ended (Unix seconds, database clock); `None` until then.
    pub finished_at: Option<f64>,
    /// Leases taken so far (more than 1: the job was resumed by another lease).
    pub attempts: u32,
    /// A cancel was requested; the running job's coordinator sees it at its next heartbeat.
    pub cancel_requested: bool,
    /// The last progress event its coordinator stored.
    pub progress: Option<ProgressEvent>,
    /// Evaluations stored so far.
    pub evaluations: usize,
    /// The outcome of a succeeded job, or the partial outcome of a cancelled one.
    pub result: Option<WorstOutcome>,
    /// Why a failed job failed, for a person.
    pub error: Option<String>,
    /// The failure's class: `bad_input`, `unsolvable`, `solver`, `io`, `panic`,
    /// `attempts_exhausted`, … (stored as the code's name).
    pub error_kind: Option<ErrorCode>,
    /// When the current lease ends (Unix seconds, database clock); `None` unless running.
    pub lease_expires_at: Option<f64>,
    /// Why part of the stored row could not be read (a damaged row is listed, never run).
    pub damaged: Option<String>,
}

/// How a job ended.
#[derive(Debug, Clone)]
pub enum JobEnd {
    /// The search ran (completed, out of budget or time: see the outcome's status).
    Succeeded(WorstOutcome),
    /// Cancelled: the partial outcome.
    Cancelled(Option<WorstOutcome>),
    /// The job failed; it is not retried.
    Failed {
        /// The failure's class (`bad_input`, `solver`, `panic`, …), stored as `error_kind`.
        kind: ErrorCode,
        /// What went wrong, for a person.
        error: String,
    },
}

/// What a heartbeat learns about its lease.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lease {
    /// Still `owner`'s; whether a cancel was requested.
    Held {
        /// A cancel of the job was requested.
        cancel_requested: bool,
    },
    /// Taken over by another worker, or the job ended.
    Lost,
}

/// A page of a listing.
#[derive(Debug, Clone, Copy)]
pub struct Page {
    /// At most this many items.
    pub limit: usize,
    /// Items skipped from the start of the listing.
    pub offset: usize,
}

/// A task: some points of one evaluation batch of a job.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct TaskKey {
    /// The job whose batch the task belongs to.
    pub job_id: String,
    /// The job's lease attempt whose coordinator posted it.
    pub attempt: u32,
    /// The batch's number within the coordinator's lease attempt (from 0, in posting order).
    pub batch: u64,
    /// The part's index within the batch (results are read back in part order).
    pub part: u32,
}

/// Which tasks a lease may take.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TaskScope<'a> {
    /// Tasks of jobs coordinated by someone else (a worker's task loop: a coordinator computes
    /// its own share in its job's pool).
    Others,
    /// The tasks of one batch (its coordinator taking over a part nobody has started or whose
    /// worker died).
    Batch {
        /// The job's id.
        job: &'a str,
        /// The lease attempt of the coordinator that posted the batch.
        attempt: u32,
        /// The batch's number within that attempt.
        batch: u64,
    },
}

/// What a task asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TaskKind {
    /// Evaluations of search points on the run's mesh (stored in the job's evaluations).
    Evaluate,
    /// The accuracy statement's solves on the run's mesh refined this many times (≥ 1).
    Refined(u32),
}

impl TaskKind {
    /// The stored `refinement` column: 0 for evaluations.
    pub fn refinement(self) -> u32 {
        match self {
            TaskKind::Evaluate => 0,
            TaskKind::Refined(level) => level,
        }
    }

    /// The kind of a stored `refinement` column.
    pub fn of_refinement(refinement: u32) -> TaskKind {
        match refinement {
            0 => TaskKind::Evaluate,
            level => TaskKind::Refined(level),
        }
    }
}

/// A leased task.
#[derive(Debug, Clone)]
pub struct TaskRecord {
    /// Which task: job, attempt, batch and part.
    pub key: TaskKey,
    /// Search evaluations or refined solves of the accuracy statement.
    pub kind: TaskKind,
    /// Physical parameter points, in the order their evaluations must be returned.
    pub points: Vec<Vec<f64>>,
    /// The job's run hash, which the worker's prepared model must match.
    pub run_hash: String,
}

/// What a worker needs to evaluate a job's points: the scene and the search settings.
#[derive(Debug, Clone)]
pub struct JobInput {
    /// The scene document (JSON text).
    pub scene: String,
    /// The search settings as submitted.
    pub settings: WorstRequest,
    /// The job's run hash.
    pub run_hash: String,
    /// The scene its coordinator chose for the target error, once it has (JSON).
    pub chosen_scene: Option<String>,
}

/// Store errors; the message names the operation. `unavailable` marks a failure of the
/// database itself (locked past the timeout, disk full or read-only, I/O error, connection
/// lost): it may pass, so the API answers 503 and a job is retried, never failed, by it.
#[derive(Debug, Clone, thiserror::Error)]
#[error("job store: {message}")]
pub struct StoreError {
    /// What failed, naming the operation.
    pub message: String,
    /// The database itself failed, which may pass (API 503, job retried), rather than the data.
    pub unavailable: bool,
}

impl StoreError {
    /// A failure that retrying will not cure (a damaged row, a value that does not encode).
    pub fn new(message: impl Into<String>) -> StoreError {
        StoreError {
            message: message.into(),
            unavailable: false,
        }
    }

    /// The database did not do what was asked of it, for now.
    pub fn unavailable(message: impl Into<String>) -> StoreError {
        StoreError {
            message: message.into(),
            unavailable: true,
        }
    }
}

/// The result of a job-store operation.
pub type StoreResult<T> = Result<T, StoreError>;

/// Where jobs, their evaluations and results live.
#[async_trait::async_trait]
pub trait JobStore: Send + Sync + 'static {
    /// Queue a job unless `max_active` jobs are already queued or running (false: not
    /// inserted). The count and the insert are one transaction: concurrent submissions cannot
    /// pass the limit together.
    async fn insert(&self, job: NewJob, max_active: usize) -> StoreResult<bool>;
    /// The job `id` with its scene document (`None`: no such job).
    async fn get(&self, id: &str) -> StoreResult<Option<JobRecord>>;
    /// Jobs, newest first, optionally in one state; without their scene documents (`scene` is
    /// empty: a listing reads only what a status shows).
    async fn list(&self, state: Option<JobState>, page: Page) -> StoreResult<Vec<JobRecord>>;
    /// Queued and running jobs.
    async fn active_count(&self) -> StoreResult<usize>;
    /// Whether the store takes writes (a write in a transaction that is rolled back).
    async fn check_writable(&self) -> StoreResult<()>;
    /// Give back every job and task `owner` holds (a process shutting down): its running jobs
    /// are queued again at once for any worker, their evaluations kept; the number of jobs.
    async fn release_all(&self, owner: &str) -> StoreResult<usize>;
    /// Lease the oldest queued job, or a running job whose lease expired, for `owner`. A job
    /// whose lease expires for the `max_attempts`-th time (its worker died or hung each time)
    /// is failed instead, with the reason, and the next one is looked at.
    async fn lease(
        &self,
        owner: &str,
        lease_seconds: f64,
        max_attempts: u32,
    ) -> StoreResult<Option<JobRecord>>;
    /// Extend the lease and read the job's cancel flag.
    async fn renew(&self, id: &str, owner: &str, lease_seconds: f64) -> StoreResult<Lease>;
    /// Store a running job's latest progress event (ignored once the job is no longer running).
    async fn set_progress(&self, id: &str, progress: &ProgressEvent) -> StoreResult<()>;
    /// Store evaluations in order, in one transaction; the 1-based sequence number of the last.
    async fn append_evaluations(
        &self,
        id: &str,
        owner: &str,
        evaluations: &[Evaluation],
    ) -> StoreResult<usize>;
    /// Evaluations of a job in order (`page` of them).
    async fn evaluations(&self, id: &str, page: Option<Page>) -> StoreResult<Vec<Evaluation>>;
    /// Record how job `id` ended (state, outcome or error, finish time) and release its lease,
    /// provided `owner` still holds it; the job's tasks are dropped.
    async fn finish(&self, id: &str, owner: &str, end: JobEnd) -> StoreResult<()>;
    /// Ask a job to stop: a queued job is cancelled at once (true), a running one is flagged.
    async fn request_cancel(&self, id: &str) -> StoreResult<bool>;

    /// The scene and settings of a job (what a worker needs to evaluate its points).
    async fn job_input(&self, id: &str) -> StoreResult<Option<JobInput>>;
    /// Record the scene the coordinator chose for the job's target error (JSON), for the
    /// workers; false when `owner` no longer holds the job's lease.
    async fn record_chosen_scene(&self, id: &str, owner: &str, scene: &str) -> StoreResult<bool>;
    /// Post one batch of job `id` (whose lease `owner` holds) as tasks of `kind`, one per part;
    /// tasks of the job's earlier attempts are dropped (their coordinator is gone).
    async fn post_tasks(
        &self,
        id: &str,
        owner: &str,
        attempt: u32,
        batch: u64,
        kind: TaskKind,
        parts: &[Vec<Vec<f64>>],
    ) -> StoreResult<()>;
    /// The newest running job whose live lease another process holds, as (id, run hash): its
    /// coordinator may fan batches out to this process soon, so an idle worker prepares its
    /// model ahead of the first task.
    async fn coordinated_elsewhere(&self, owner: &str) -> StoreResult<Option<(String, String)>>;
    /// Lease the oldest queued task in `scope`, or a running one whose lease expired.
    async fn lease_task(
        &self,
        owner: &str,
        lease_seconds: f64,
        scope: TaskScope<'_>,
    ) -> StoreResult<Option<TaskRecord>>;
    /// Give a leased task back, queued for anyone (a worker whose model is not prepared yet);
    /// false when it is no longer `owner`'s.
    async fn release_task(&self, key: &TaskKey, owner: &str) -> StoreResult<bool>;
    /// Extend a task's lease; false when it is no longer `owner`'s.
    async fn renew_task(&self, key: &TaskKey, owner: &str, lease_seconds: f64)
        -> StoreResult<bool>;
    /// Store a task's evaluations (in the job's evaluations too) and mark it done, atomically;
    /// false (and nothing stored) when the task is no longer `owner`'s.
    async fn complete_task(
        &self,
        key: &TaskKey,
        owner: &str,
        evaluations: &[Evaluation],
    ) -> StoreResult<bool>;
    /// The evaluations of a batch in part order once every part is done (`None` before).
    async fn batch_results(
        &self,
        id: &str,
        attempt: u32,
        batch: u64,
    ) -> StoreResult<Option<Vec<Evaluation>>>;
    /// Store the refined solves of a [`TaskKind::Refined`] task and mark it done (not in the
    /// job's evaluations: they are not search points; a point its coordinator's stop left
    /// unsolved is stored as `null`); false (and nothing stored) when the task is no longer
    /// `owner`'s.
    async fn complete_refined_task(
        &self,
        key: &TaskKey,
        owner: &str,
        values: &[RefinedOutcome],
    ) -> StoreResult<bool>;
    /// The refined solves of a batch in part order once every part is done (`None` before).
    async fn refined_results(
        &self,
        id: &str,
        attempt: u32,
        batch: u64,
    ) -> StoreResult<Option<Vec<RefinedOutcome>>>;
    /// Announce a worker process with its evaluation threads (a heartbeat).
    async fn register_worker(&self, owner: &str, threads: usize) -> StoreResult<()>;
    /// Evaluation threads of the workers seen within the last `seconds`.
    async fn live_threads(&self, seconds: f64) -> StoreResult<usize>;
    /// Changes whenever new work (a job or a task) may be there. Mark it seen before looking
    /// for work, then [`wait`] on it: no announcement is missed in between.
    fn work_signal(&self) -> Signal;
    /// Changes whenever a task may have completed (used the same way).
    fn results_signal(&self) -> Signal;
}

/// A counter raised by announcements (local writes, or notifications from other processes).
pub type Signal = tokio::sync::watch::Receiver<u64>;

/// Wait until `signal` changes after it was last seen, or `timeout` (waiters also poll, so a
/// lost notification only delays them).
pub async fn wait(signal: &mut Signal, timeout: std::time::Duration) {
    let _ = tokio::time::timeout(timeout, signal.changed()).await;
}

/// Seconds since the Unix epoch.
pub fn now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}
