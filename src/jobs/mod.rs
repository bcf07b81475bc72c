//! The job queue of the service (SPEC §5.4): worst-scenario jobs stored durably with their
//! lease, progress, every evaluation as it completes and the outcome, behind the [`JobStore`]
//! trait (SQLite now: `sqlite`; PostgreSQL for scale-out later), and the workers that lease jobs
//! and run them through the front door (`runner`).
//!
//! A job's life: `queued` → `running` (leased by a worker, lease renewed by heartbeat) →
//! `succeeded` | `failed` | `cancelled`. A running job whose lease expired (its process died) is
//! leased again and resumed from its stored evaluations: none lost, none recomputed.

pub mod runner;
pub mod sqlite;

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::run::{Evaluation, ProgressEvent, WorstOutcome, WorstRequest};

/// The state of a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    Queued,
    Running,
    Succeeded,
    Failed,
    Cancelled,
}

impl JobState {
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Succeeded => "succeeded",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
        }
    }

    pub fn parse(text: &str) -> Option<JobState> {
        [
            JobState::Queued,
            JobState::Running,
            JobState::Succeeded,
            JobState::Failed,
            JobState::Cancelled,
        ]
        .into_iter()
        .find(|s| s.as_str() == text)
    }

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
    pub id: String,
    /// The scene document (JSON text).
    pub scene: String,
    pub settings: WorstRequest,
    pub scene_name: String,
    pub criteria: Vec<String>,
    pub budget: usize,
    pub run_hash: String,
}

/// A stored job.
#[derive(Debug, Clone)]
pub struct JobRecord {
    pub id: String,
    pub state: JobState,
    pub scene: String,
    pub settings: WorstRequest,
    pub scene_name: String,
    pub criteria: Vec<String>,
    pub budget: usize,
    pub run_hash: String,
    pub created_at: f64,
    pub started_at: Option<f64>,
    pub finished_at: Option<f64>,
    pub attempts: u32,
    pub cancel_requested: bool,
    pub progress: Option<ProgressEvent>,
    pub evaluations: usize,
    pub result: Option<WorstOutcome>,
    pub error: Option<String>,
    pub error_kind: Option<String>,
}

/// How a job ended.
#[derive(Debug, Clone)]
pub enum JobEnd {
    /// The search ran (completed, out of budget or time: see the outcome's status).
    Succeeded(WorstOutcome),
    /// Cancelled: the partial outcome.
    Cancelled(Option<WorstOutcome>),
    Failed {
        kind: String,
        error: String,
    },
}

/// What a heartbeat learns about its lease.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lease {
    /// Still `owner`'s; whether a cancel was requested.
    Held { cancel_requested: bool },
    /// Taken over by another worker, or the job ended.
    Lost,
}

/// A page of a listing.
#[derive(Debug, Clone, Copy)]
pub struct Page {
    pub limit: usize,
    pub offset: usize,
}

/// Store errors (database failures); the message names the operation.
#[derive(Debug, Clone, thiserror::Error)]
#[error("job store: {0}")]
pub struct StoreError(pub String);

pub type StoreResult<T> = Result<T, StoreError>;

/// Where jobs, their evaluations and results live.
#[async_trait::async_trait]
pub trait JobStore: Send + Sync + 'static {
    async fn insert(&self, job: NewJob) -> StoreResult<()>;
    async fn get(&self, id: &str) -> StoreResult<Option<JobRecord>>;
    /// Jobs, newest first, optionally in one state.
    async fn list(&self, state: Option<JobState>, page: Page) -> StoreResult<Vec<JobRecord>>;
    /// Queued and running jobs.
    async fn active_count(&self) -> StoreResult<usize>;
    /// Lease the oldest queued job, or a running job whose lease expired, for `owner`.
    async fn lease(&self, owner: &str, lease_seconds: f64) -> StoreResult<Option<JobRecord>>;
    /// Extend the lease and read the job's cancel flag.
    async fn renew(&self, id: &str, owner: &str, lease_seconds: f64) -> StoreResult<Lease>;
    async fn set_progress(&self, id: &str, progress: &ProgressEvent) -> StoreResult<()>;
    /// Store one evaluation; its 1-based sequence number.
    async fn append_evaluation(
        &self,
        id: &str,
        owner: &str,
        evaluation: &Evaluation,
    ) -> StoreResult<usize>;
    /// Evaluations of a job in order (`page` of them).
    async fn evaluations(&self, id: &str, page: Option<Page>) -> StoreResult<Vec<Evaluation>>;
    async fn finish(&self, id: &str, owner: &str, end: JobEnd) -> StoreResult<()>;
    /// Ask a job to stop: a queued job is cancelled at once (true), a running one is flagged.
    async fn request_cancel(&self, id: &str) -> StoreResult<bool>;
}

/// Seconds since the Unix epoch.
pub fn now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}
