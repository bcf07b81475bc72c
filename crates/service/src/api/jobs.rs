//! Endpoints on stored jobs: list, status (with ETA), live status as server-sent events, scene,
//! result, convergence history and cancel; the evaluations and the fields of a scenario have
//! modules of their own (`evaluations`, `fields`). Each handler names the access it needs
//! ([`CanRead`], [`CanWrite`]) in its signature.

use std::convert::Infallible;
use std::time::Duration;

use axum::extract::{Path, State};
use axum::http::{header, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::Json;
use futures_util::stream::Stream;
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::error::{ApiError, ErrorBody};
use super::query::Query;
use super::schema::SceneDocument;
use super::status::JobStatus;
use super::{AppState, CanRead, CanWrite};
use crate::jobs::{JobRecord, JobState, Page};
use wsm_core::{CriterionOutcome, CriterionSpec, Scene, WorstOutcome};

/// The stored record of job `id`; 404 when there is none.
pub(super) async fn find(state: &AppState, id: &str) -> Result<JobRecord, ApiError> {
    state
        .store
        .get(id)
        .await?
        .ok_or_else(|| ApiError::not_found("job", id))
}

/// The outcome of a job that ran (succeeded, or cancelled with a partial outcome).
pub(super) async fn outcome(
    state: &AppState,
    id: &str,
) -> Result<(JobRecord, WorstOutcome), ApiError> {
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

/// The scene a job was submitted with, read back from its record (validated at submission; a
/// stored scene that no longer reads is the server's fault: 500).
pub(super) fn stored_scene(job: &JobRecord) -> Result<Scene, ApiError> {
    wsm_core::parse_scene(&job.scene).map_err(|e| ApiError::internal(e.to_string()))
}

/// A page of at most `max` items: `limit` (default 50, at most `max`) after `offset`.
pub(super) fn page(
    limit: Option<usize>,
    offset: Option<usize>,
    max: usize,
) -> Result<Page, ApiError> {
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

/// A file download: `body` as `content_type`, saved as `file` by a browser.
pub(super) fn attachment(content_type: &str, file: &str, body: Vec<u8>) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type.to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{file}\""),
            ),
        ],
        body,
    )
        .into_response()
}

/// The scene document of a job, as submitted (for drawing its regions and contact zones).
#[utoipa::path(get, path = "/v1/jobs/{id}/scene", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, description = "The scene document", body = SceneDocument),
        (status = 401, description = "Token required", body = ErrorBody),
        (status = 404, body = ErrorBody)))]
pub async fn job_scene(
    _: CanRead,
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let job = find(&state, &id).await?;
    serde_json::from_str(&job.scene)
        .map(Json)
        .map_err(|e| ApiError::internal(e.to_string()))
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

/// Jobs, newest first.
#[utoipa::path(get, path = "/v1/jobs", tag = "jobs", params(ListQuery),
    responses((status = 200, body = Vec<JobStatus>),
        (status = 401, description = "Token required", body = ErrorBody), (status = 422, body = ErrorBody)))]
pub async fn list_jobs(
    _: CanRead,
    State(state): State<AppState>,
    Query(q): Query<ListQuery>,
) -> Result<Json<Vec<JobStatus>>, ApiError> {
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
    _: CanRead,
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<JobStatus>, ApiError> {
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
    _: CanRead,
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Sse<impl Stream<Item = Result<Event, Infallible>>>, ApiError> {
    let first = JobStatus::of(&find(&state, &id).await?);
    Ok(Sse::new(status_changes(state, id, first)).keep_alive(KeepAlive::default()))
}

/// `first`, then the job's status each time it changes (polled every 250 ms), ending after
/// the job finishes or when its record cannot be read.
fn status_changes(
    state: AppState,
    id: String,
    first: JobStatus,
) -> impl Stream<Item = Result<Event, Infallible>> {
    futures_util::stream::unfold(
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
    )
}

/// The outcome: worst and best value and data per criterion, sensitivities, statistics.
#[utoipa::path(get, path = "/v1/jobs/{id}/result", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, body = WorstOutcome),
        (status = 401, description = "Token required", body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 409, description = "Not finished, or failed", body = ErrorBody)))]
pub async fn job_result(
    _: CanRead,
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<WorstOutcome>, ApiError> {
    Ok(Json(outcome(&state, &id).await?.1))
}

/// Convergence history of one criterion.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct CriterionHistory {
    /// The criterion.
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
    _: CanRead,
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Vec<CriterionHistory>>, ApiError> {
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

/// Stop a job: a queued job is cancelled at once (200); a running one stops within one
/// evaluation batch and keeps its partial outcome (202).
#[utoipa::path(post, path = "/v1/jobs/{id}/cancel", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, body = JobStatus), (status = 202, body = JobStatus),
        (status = 401, body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 409, description = "Already finished", body = ErrorBody)))]
pub async fn cancel_job(
    _: CanWrite,
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
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
