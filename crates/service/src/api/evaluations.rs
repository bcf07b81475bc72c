//! `GET /v1/jobs/{id}/evaluations`: every stored evaluation of a job, in order of completion, as
//! JSON or as the CSV table of `wsm worst --table` (design §5.4), a page at a time on request.

use axum::extract::{Path, State};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Deserialize;
use utoipa::{IntoParams, ToSchema};

use super::error::{ApiError, ErrorBody};
use super::jobs::{attachment, find, page, stored_scene};
use super::query::Query;
use super::{AppState, CanRead};
use crate::jobs::{JobRecord, Page};
use wsm_core::Evaluation;

/// How the evaluations are written.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum EvaluationsFormat {
    /// A JSON array of evaluations.
    #[default]
    Json,
    /// CSV, one row per evaluation: id, parameters by field path, criteria, largest KKT
    /// residual, solve time.
    Csv,
}

/// Evaluations query.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct EvaluationsQuery {
    /// `json` (default) or `csv`.
    #[param(inline)]
    pub format: Option<EvaluationsFormat>,
    /// At most this many (1–10,000; default: all, which the job's budget bounds).
    pub limit: Option<usize>,
    /// Skip this many (in order of completion).
    pub offset: Option<usize>,
}

/// The largest page of evaluations.
const MAX_EVALUATIONS_PAGE: usize = 10_000;

impl EvaluationsQuery {
    /// The page asked for: none (all) without `limit` and `offset`, all after `offset` without
    /// `limit`.
    fn page(&self) -> Result<Option<Page>, ApiError> {
        match (self.limit, self.offset) {
            (None, None) => Ok(None),
            (None, Some(offset)) => Ok(Some(Page {
                limit: usize::MAX >> 1,
                offset,
            })),
            (limit, offset) => page(limit, offset, MAX_EVALUATIONS_PAGE).map(Some),
        }
    }
}

/// Every stored evaluation of a job, in order of completion: JSON, or CSV with one row per
/// evaluation (id, parameters by field path, criteria, largest KKT residual, solve time).
#[utoipa::path(get, path = "/v1/jobs/{id}/evaluations", tag = "jobs",
    params(("id" = String, Path, description = "Job id"), EvaluationsQuery),
    responses((status = 200, body = Vec<wsm_core::Evaluation>),
        (status = 401, description = "Token required", body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 422, body = ErrorBody)))]
pub async fn job_evaluations(
    _: CanRead,
    State(state): State<AppState>,
    Path(id): Path<String>,
    Query(q): Query<EvaluationsQuery>,
) -> Result<Response, ApiError> {
    let page = q.page()?;
    let job = find(&state, &id).await?;
    let evaluations = state.store.evaluations(&id, page).await?;
    match q.format.unwrap_or_default() {
        EvaluationsFormat::Json => Ok(Json(evaluations).into_response()),
        EvaluationsFormat::Csv => Ok(attachment(
            "text/csv; charset=utf-8",
            &format!("{id}-evaluations.csv"),
            csv_table(&job, &evaluations)?,
        )),
    }
}

/// The CSV table of `evaluations` of `job` (`wsm_core::write_csv`, as `wsm worst --table`).
fn csv_table(job: &JobRecord, evaluations: &[Evaluation]) -> Result<Vec<u8>, ApiError> {
    let parameters = wsm_core::parameter_info(&stored_scene(job)?)
        .map_err(|e| ApiError::internal(e.to_string()))?;
    let mut buffer = Vec::new();
    wsm_core::write_csv(
        &mut buffer,
        "evaluations",
        &parameters,
        &job.criteria,
        evaluations,
    )
    .map_err(|e| ApiError::engine(e, ""))?;
    Ok(buffer)
}
