//! Endpoints on stored jobs: list, status (with ETA), live status as server-sent events, result,
//! convergence history, evaluations (JSON or CSV, as `wsm worst --table`), cancel, and the fields
//! of a job's worst or best scenario for plotting (JSON, or VTU for ParaView).

use std::convert::Infallible;
use std::time::Duration;

use axum::extract::{Path, RawQuery, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::Json;
use futures_util::stream::Stream;
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::error::{ApiError, ErrorBody};
use super::schema::SceneDocument;
use super::{query, AppState};
use crate::jobs::{now, JobRecord, JobState, Page};
use wsm_core::run::{
    self, BestSoFar, CriterionOutcome, ParameterInfo, RunPhase, Scenario, ScenarioMissing,
    SolveOutput, SolveRequest, WorstOutcome,
};
use wsm_core::scene::{CriterionSpec, Scene};

/// What a job is doing.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema)]
pub struct JobStatus {
    pub id: String,
    pub state: JobState,
    /// The phase of a running job (`queued` before it starts, `finished` after).
    pub phase: RunPhase,
    pub scene: String,
    pub criteria: Vec<String>,
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
    pub budget: usize,
    /// Best value so far per objective (max and min of each criterion).
    pub best: Vec<BestSoFar>,
    /// Unix time \[s\].
    pub created_at: f64,
    pub started_at: Option<f64>,
    pub finished_at: Option<f64>,
    /// Since the job started (to its end when finished) \[s\].
    pub elapsed_seconds: f64,
    /// Estimated time left, from the evaluation rate so far \[s\].
    pub eta_seconds: Option<f64>,
    /// Leases taken (more than 1: the job was resumed after a restart).
    pub attempts: u32,
    pub cancel_requested: bool,
    /// Why a failed job failed.
    pub error: Option<String>,
    pub error_kind: Option<String>,
    /// The outcome's status once finished (`completed`, `budget_exhausted`, `time_limit`, …).
    pub outcome_status: Option<run::Status>,
}

impl JobStatus {
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
                .clone()
                .or_else(|| job.damaged.as_ref().map(|_| "damaged".to_string())),
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

async fn find(state: &AppState, id: &str) -> Result<JobRecord, ApiError> {
    state
        .store
        .get(id)
        .await?
        .ok_or_else(|| ApiError::not_found("job", id))
}

/// The scene document of a job, as submitted (for drawing its regions and contact zones).
#[utoipa::path(get, path = "/v1/jobs/{id}/scene", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, description = "The scene document", body = SceneDocument),
        (status = 401, description = "Token required", body = ErrorBody),
        (status = 404, body = ErrorBody)))]
pub async fn job_scene(
    State(state): State<AppState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    state.access.authorize_read(&headers)?;
    let job = find(&state, &id).await?;
    serde_json::from_str(&job.scene)
        .map(Json)
        .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", e.to_string()))
}

/// Listing filters.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ListQuery {
    /// Only jobs in this state.
    pub state: Option<JobState>,
    /// At most this many (1–500, default 50).
    pub limit: Option<usize>,
    /// Skip this many (newest first).
    pub offset: Option<usize>,
}

fn page(limit: Option<usize>, offset: Option<usize>, max: usize) -> Result<Page, ApiError> {
    let limit = limit.unwrap_or(50.min(max));
    if limit == 0 || limit > max {
        return Err(ApiError::invalid(
            "limit",
            format!("must be between 1 and {max}"),
        ));
    }
    Ok(Page {
        limit,
        offset: offset.unwrap_or(0),
    })
}

/// Jobs, newest first.
#[utoipa::path(get, path = "/v1/jobs", tag = "jobs", params(ListQuery),
    responses((status = 200, body = Vec<JobStatus>),
        (status = 401, description = "Token required", body = ErrorBody), (status = 422, body = ErrorBody)))]
pub async fn list_jobs(
    State(state): State<AppState>,
    headers: HeaderMap,
    raw: RawQuery,
) -> Result<Json<Vec<JobStatus>>, ApiError> {
    state.access.authorize_read(&headers)?;
    let q: ListQuery = query::parse(raw)?;
    let jobs = state
        .store
        .list(q.state, page(q.limit, q.offset, 500)?)
        .await?;
    Ok(Json(jobs.iter().map(JobStatus::of).collect()))
}

/// A job's state, phase, progress, best values so far and ETA.
#[utoipa::path(get, path = "/v1/jobs/{id}", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, body = JobStatus),
        (status = 401, description = "Token required", body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn job_status(
    State(state): State<AppState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Json<JobStatus>, ApiError> {
    state.access.authorize_read(&headers)?;
    Ok(Json(JobStatus::of(&find(&state, &id).await?)))
}

/// Live status as server-sent events (`event: status`, data: a JobStatus), one event per change,
/// ending after the job finishes.
#[utoipa::path(get, path = "/v1/jobs/{id}/events", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, description = "text/event-stream of JobStatus", content_type = "text/event-stream"),
        (status = 401, description = "Token required", body = ErrorBody),
        (status = 404, body = ErrorBody)))]
pub async fn job_events(
    State(state): State<AppState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Sse<impl Stream<Item = Result<Event, Infallible>>>, ApiError> {
    state.access.authorize_read(&headers)?;
    let first = JobStatus::of(&find(&state, &id).await?);
    let stream = futures_util::stream::unfold(
        (state, id, Some(first), None::<JobStatus>),
        |(state, id, next, last)| async move {
            let mut next = next;
            loop {
                if let Some(status) = next.take() {
                    if last.as_ref() != Some(&status) {
                        let event = Event::default()
                            .event("status")
                            .json_data(&status)
                            .unwrap_or_else(|_| Event::default().event("status"));
                        return Some((Ok(event), (state, id, None, Some(status))));
                    }
                }
                if last.as_ref().is_some_and(|s| s.state.is_finished()) {
                    return None;
                }
                tokio::time::sleep(Duration::from_millis(250)).await;
                match state.store.get(&id).await {
                    Ok(Some(job)) => next = Some(JobStatus::of(&job)),
                    _ => return None,
                }
            }
        },
    );
    Ok(Sse::new(stream).keep_alive(KeepAlive::default()))
}

/// The outcome of a job that ran (succeeded, or cancelled with a partial outcome).
async fn outcome(state: &AppState, id: &str) -> Result<(JobRecord, WorstOutcome), ApiError> {
    let job = find(state, id).await?;
    match &job.result {
        Some(outcome) => {
            let outcome = outcome.clone();
            Ok((job, outcome))
        }
        None => Err(match job.state {
            JobState::Failed => ApiError::conflict(format!(
                "job {id} failed: {}",
                job.error.clone().unwrap_or_default()
            )),
            s => ApiError::conflict(format!("job {id} is {} and has no result yet", s.as_str())),
        }),
    }
}

/// The outcome: worst and best value and data per criterion, sensitivities, statistics.
#[utoipa::path(get, path = "/v1/jobs/{id}/result", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, body = WorstOutcome),
        (status = 401, description = "Token required", body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 409, description = "Not finished, or failed", body = ErrorBody)))]
pub async fn job_result(
    State(state): State<AppState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Json<WorstOutcome>, ApiError> {
    state.access.authorize_read(&headers)?;
    Ok(Json(outcome(&state, &id).await?.1))
}

/// Convergence history of one criterion.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct CriterionHistory {
    pub criterion: CriterionSpec,
    /// (evaluations so far, best max value so far) at every improvement.
    #[schema(value_type = Vec<Vec<f64>>)]
    pub worst: Vec<(usize, f64)>,
    /// The same for the min.
    #[schema(value_type = Vec<Vec<f64>>)]
    pub best: Vec<(usize, f64)>,
}

/// The convergence history of each criterion.
#[utoipa::path(get, path = "/v1/jobs/{id}/history", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, body = Vec<CriterionHistory>),
        (status = 401, description = "Token required", body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 409, body = ErrorBody)))]
pub async fn job_history(
    State(state): State<AppState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Json<Vec<CriterionHistory>>, ApiError> {
    state.access.authorize_read(&headers)?;
    let (_, outcome) = outcome(&state, &id).await?;
    Ok(Json(
        outcome
            .criteria
            .iter()
            .map(|c: &CriterionOutcome| CriterionHistory {
                criterion: c.criterion.clone(),
                worst: c.worst.history.clone(),
                best: c.best.history.clone(),
            })
            .collect(),
    ))
}

/// Evaluations query.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct EvaluationsQuery {
    /// `json` (default) or `csv`.
    pub format: Option<String>,
    /// At most this many (1–10,000; default: all, which the job's budget bounds).
    pub limit: Option<usize>,
    pub offset: Option<usize>,
}

/// The largest page of evaluations.
const MAX_EVALUATIONS_PAGE: usize = 10_000;

fn scene_and_parameters(job: &JobRecord) -> Result<(Scene, Vec<ParameterInfo>), ApiError> {
    let scene = wsm_core::scene::parse(&job.scene)
        .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", e.to_string()))?;
    let info = wsm_core::run::parameter_info(&scene)
        .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", e.to_string()))?;
    Ok((scene, info))
}

/// Every stored evaluation of a job, in order of completion: JSON, or CSV with one row per
/// evaluation (id, parameters by field path, criteria, largest KKT residual, solve time).
#[utoipa::path(get, path = "/v1/jobs/{id}/evaluations", tag = "jobs",
    params(("id" = String, Path, description = "Job id"), EvaluationsQuery),
    responses((status = 200, body = Vec<run::Evaluation>),
        (status = 401, description = "Token required", body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 422, body = ErrorBody)))]
pub async fn job_evaluations(
    State(state): State<AppState>,
    headers: HeaderMap,
    Path(id): Path<String>,
    raw: RawQuery,
) -> Result<Response, ApiError> {
    state.access.authorize_read(&headers)?;
    let q: EvaluationsQuery = query::parse(raw)?;
    let page = match (q.limit, q.offset) {
        (None, None) => None,
        (None, Some(offset)) => Some(Page {
            limit: usize::MAX >> 1,
            offset,
        }),
        (limit, offset) => Some(page(limit, offset, MAX_EVALUATIONS_PAGE)?),
    };
    let job = find(&state, &id).await?;
    let evaluations = state.store.evaluations(&id, page).await?;
    match q.format.as_deref().unwrap_or("json") {
        "json" => Ok(Json(evaluations).into_response()),
        "csv" => {
            let (_, parameters) = scene_and_parameters(&job)?;
            let criteria: Vec<CriterionSpec> = job
                .criteria
                .iter()
                .filter_map(|c| CriterionSpec::parse(c).ok())
                .collect();
            let mut buffer = Vec::new();
            run::write_csv(
                &mut buffer,
                "evaluations",
                &parameters,
                &criteria,
                &evaluations,
            )
            .map_err(|e| ApiError::engine(e, ""))?;
            Ok((
                [
                    (header::CONTENT_TYPE, "text/csv; charset=utf-8".to_string()),
                    (
                        header::CONTENT_DISPOSITION,
                        format!("attachment; filename=\"{id}-evaluations.csv\""),
                    ),
                ],
                buffer,
            )
                .into_response())
        }
        other => Err(ApiError::invalid(
            "format",
            format!("'{other}' is not json or csv"),
        )),
    }
}

/// Stop a job: a queued job is cancelled at once (200); a running one stops within one
/// evaluation batch and keeps its partial outcome (202).
#[utoipa::path(post, path = "/v1/jobs/{id}/cancel", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, body = JobStatus), (status = 202, body = JobStatus),
        (status = 401, body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 409, description = "Already finished", body = ErrorBody)))]
pub async fn cancel_job(
    State(state): State<AppState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    state.access.authorize_write(&headers)?;
    let job = find(&state, &id).await?;
    if job.state.is_finished() {
        return Err(ApiError::conflict(format!(
            "job {id} is already {}",
            job.state.as_str()
        )));
    }
    let at_once = state.store.request_cancel(&id).await?;
    state.live.cancel(&id);
    let status = JobStatus::of(&find(&state, &id).await?);
    let code = if at_once {
        StatusCode::OK
    } else {
        StatusCode::ACCEPTED
    };
    Ok((code, Json(status)).into_response())
}

/// Which scenario's fields to compute.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct FieldsQuery {
    /// `worst` (default), `best` or `nominal` (the scene's own data).
    pub scenario: Option<String>,
    /// The criterion whose worst or best data to use (default: the first requested; not used
    /// for `nominal`).
    pub criterion: Option<String>,
    /// `json` (default: mesh, fields and summary) or `vtu` (a binary VTU file for ParaView,
    /// PyVista and meshio, naming the scenario and its data in its field data).
    pub format: Option<String>,
}

/// The mesh and fields (displacement \[m\], temperature \[K\], stresses \[Pa\], I2² \[Pa²\],
/// contact pressure \[Pa\] and slip \[m\]) of a job's nominal, worst or best scenario, solved on
/// the job's mesh.
#[utoipa::path(get, path = "/v1/jobs/{id}/fields", tag = "jobs",
    params(("id" = String, Path, description = "Job id"), FieldsQuery),
    responses((status = 200, body = SolveOutput),
        (status = 401, description = "Token required", body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 409, body = ErrorBody), (status = 422, body = ErrorBody)))]
pub async fn job_fields(
    State(state): State<AppState>,
    headers: HeaderMap,
    Path(id): Path<String>,
    raw: RawQuery,
) -> Result<Response, ApiError> {
    state.access.authorize_read(&headers)?;
    let q: FieldsQuery = query::parse(raw)?;
    let (job, outcome) = outcome(&state, &id).await?;
    let scenario_name = q.scenario.as_deref().unwrap_or("worst");
    let criterion = || -> Result<CriterionSpec, ApiError> {
        match &q.criterion {
            Some(name) => {
                CriterionSpec::parse(name).map_err(|why| ApiError::invalid("criterion", why))
            }
            None => outcome
                .criteria
                .first()
                .map(|c| c.criterion.clone())
                .ok_or_else(|| ApiError::conflict("the job has no criteria")),
        }
    };
    let scenario = match scenario_name {
        "nominal" => Scenario::Nominal,
        "worst" => Scenario::Worst(criterion()?),
        "best" => Scenario::Best(criterion()?),
        other => {
            return Err(ApiError::invalid(
                "scenario",
                format!("'{other}' is not nominal, worst or best"),
            ))
        }
    };
    scenario.point(&outcome).map_err(|missing| match missing {
        ScenarioMissing::NotSearched(_) => ApiError::invalid("criterion", missing.to_string()),
        ScenarioMissing::NoPoint(_) => ApiError::conflict(missing.to_string()),
    })?;
    let vtu = match q.format.as_deref().unwrap_or("json") {
        "json" => false,
        "vtu" => true,
        other => {
            return Err(ApiError::invalid(
                "format",
                format!("'{other}' is not json or vtu"),
            ))
        }
    };
    let (scene, _) = scene_and_parameters(&job)?;
    let request = SolveRequest {
        solver: None,
        fields: true,
    };
    let place = state.solves.take()?;
    let file = format!("{id}-{}.vtu", scenario.file_stem());
    let output = tokio::task::spawn_blocking(move || {
        let _place = place;
        run::scenario_solve(scene, &outcome, &scenario, &request)
    })
    .await
    .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", e.to_string()))?
    .map_err(|e| ApiError::engine(e, "scene"))?;
    if vtu {
        Ok((
            [
                (header::CONTENT_TYPE, "application/xml".to_string()),
                (
                    header::CONTENT_DISPOSITION,
                    format!("attachment; filename=\"{file}\""),
                ),
            ],
            output.vtu.unwrap_or_default(),
        )
            .into_response())
    } else {
        super::solves::check_fields(
            &output,
            state.limits.max_field_triangles,
            "format",
            "download them as format=vtu for ParaView",
        )?;
        Ok(Json(output).into_response())
    }
}
