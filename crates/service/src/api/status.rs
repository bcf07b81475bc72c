//! What the API shows of a job ([`JobStatus`]): its state and phase, progress, best values so
//! far and ETA, read from its stored record — the answer of `GET /v1/jobs/{id}`, of each item of
//! the listing, of each server-sent event and of a cancel.

use serde::Serialize;
use utoipa::ToSchema;

use crate::error_code::ErrorCode;
use crate::jobs::{now, JobRecord, JobState};
use wsm_core::{BestSoFar, CriterionSpec, RunPhase, WorstOutcome};

/// What a job is doing.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema)]
pub struct JobStatus {
    /// The job's id (`/v1/jobs/{id}`).
    pub id: String,
    /// Queued, running, or how it ended.
    pub state: JobState,
    /// The phase of a running job (`queued` before it starts, `finished` after).
    pub phase: RunPhase,
    /// The scene's name.
    pub scene: String,
    /// The criteria searched (`phi3`, `phi3@crest`, …).
    pub criteria: Vec<CriterionSpec>,
    /// Distinct points evaluated so far (stored evaluations while running).
    pub evaluations: usize,
    /// Of `evaluations`, how many failed (listed in the result's `failures`).
    pub failures: usize,
    /// Refined solves of the accuracy statement that failed (0 until the job has a result;
    /// listed in the result's `accuracy.failures`): the discretisation error of the values at
    /// their data is unknown. Counted apart from the search's `failures`.
    pub accuracy_failures: usize,
    /// Warnings of the job's result (0 until it has one): things to read in the result's
    /// `warnings` before trusting its numbers — failed solves, unsettled or unproven extrema,
    /// locking, a target error not met.
    pub warnings: usize,
    /// Inner solves the search may spend.
    pub budget: usize,
    /// Best value so far per objective (max and min of each criterion).
    pub best: Vec<BestSoFar>,
    /// Unix time \[s\].
    pub created_at: f64,
    /// When a worker first leased it (Unix time \[s\]).
    pub started_at: Option<f64>,
    /// When it ended (Unix time \[s\]).
    pub finished_at: Option<f64>,
    /// Since the job started (to its end when finished) \[s\].
    pub elapsed_seconds: f64,
    /// Estimated time left, from the evaluation rate so far \[s\].
    pub eta_seconds: Option<f64>,
    /// Leases taken (more than 1: the job was resumed after a restart).
    pub attempts: u32,
    /// A cancel was requested (a running job stops within one evaluation batch).
    pub cancel_requested: bool,
    /// Why a failed job failed.
    pub error: Option<String>,
    /// The class of a failed job's error (`bad_input`, `solver`, `damaged`, …).
    pub error_kind: Option<ErrorCode>,
    /// The outcome's status once finished (`completed`, `budget_exhausted`, `time_limit`, …).
    pub outcome_status: Option<wsm_core::Status>,
}

impl JobStatus {
    /// The status of the stored record `job`.
    pub fn of(job: &JobRecord) -> JobStatus {
        let end = job.finished_at.unwrap_or_else(now);
        let elapsed = job.started_at.map_or(0.0, |s| (end - s).max(0.0));
        // Queued again (given back at a shutdown), or running under a lease that expired (its
        // worker died): waiting for a worker, whatever the last attempt's phase was.
        let waiting = job.state == JobState::Queued
            || (job.state == JobState::Running && job.lease_expires_at.is_some_and(|t| t < now()));
        let (phase, best) = match (&job.result, &job.progress) {
            (Some(outcome), _) => (RunPhase::Finished, outcome_best(outcome)),
            (None, Some(p)) if waiting => (RunPhase::Queued, p.best.clone()),
            (None, Some(p)) if !job.state.is_finished() => (p.phase, p.best.clone()),
            (None, _) if job.state.is_finished() => (RunPhase::Finished, Vec::new()),
            (None, _) => (RunPhase::Queued, Vec::new()),
        };
        let evaluations = job
            .result
            .as_ref()
            .map_or(job.evaluations, |o| o.evaluations);
        let failures = match (&job.result, &job.progress) {
            (Some(outcome), _) => outcome.failures.count,
            (None, Some(p)) => p.failures,
            (None, None) => 0,
        };
        let (accuracy_failures, warnings) = job.result.as_ref().map_or((0, 0), |o| {
            let statement = o.accuracy.as_ref();
            (statement.map_or(0, |a| a.failures.len()), o.warnings.len())
        });
        let eta = (job.state == JobState::Running && evaluations > 0)
            .then(|| elapsed * job.budget.saturating_sub(evaluations) as f64 / evaluations as f64);
        JobStatus {
            id: job.id.clone(),
            state: job.state,
            phase,
            scene: job.scene_name.clone(),
            criteria: job.criteria.clone(),
            evaluations,
            failures,
            accuracy_failures,
            warnings,
            budget: job.budget,
            best,
            created_at: job.created_at,
            started_at: job.started_at,
            finished_at: job.finished_at,
            elapsed_seconds: elapsed,
            eta_seconds: eta,
            attempts: job.attempts,
            cancel_requested: job.cancel_requested,
            error: job.error.clone().or_else(|| {
                (job.damaged.as_ref()).map(|why| format!("the stored job is damaged: {why}"))
            }),
            error_kind: job
                .error_kind
                .or_else(|| job.damaged.as_ref().map(|_| ErrorCode::Damaged)),
            outcome_status: job.result.as_ref().map(|o| o.status),
        }
    }
}

fn outcome_best(outcome: &WorstOutcome) -> Vec<BestSoFar> {
    outcome
        .criteria
        .iter()
        .flat_map(|c| [&c.worst, &c.best].map(|o| (c.criterion.clone(), o)))
        .map(|(criterion, o)| BestSoFar {
            criterion,
            sense: o.sense,
            value: o.value,
        })
        .collect()
}
