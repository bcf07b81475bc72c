//! Requests that carry a scene: `POST /v1/jobs` (queue a worst-scenario search) and
//! `POST /v1/solve` (one synchronous solve of a small scene). The body is parsed field by field
//! so that a malformed document answers 400 and a bad field 422 with its JSON path; the scene is
//! validated, the settings checked and the service's limits applied before anything is queued.

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use utoipa::ToSchema;

use super::body::parse_body;
use super::error::{join_path, ApiError, ErrorBody};
use super::schema::SceneDocument;
use super::{blocking, AppState, CanWrite, Limits};
use crate::error_code::ErrorCode;
use crate::jobs::{JobState, NewJob};
use wsm_core::{dynamic_output_count, Scene, SolveOutput, SolveRequest, WorstRequest};

/// A scene given inline or by the name of a bundled example.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobSubmission {
    /// The scene document (the README's scene format, its JSON Schema `GET /v1/schema/scene`; SI
    /// units throughout). Give this or `example`.
    #[schema(value_type = Option<SceneDocument>)]
    #[serde(default)]
    pub scene: Option<Value>,
    /// The name of a bundled example scene (`GET /v1/examples`).
    #[serde(default)]
    pub example: Option<String>,
    /// Search settings; each one left out takes the scene's `search` value.
    #[serde(default)]
    pub settings: WorstRequest,
}

/// A synchronous solve.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SolveSubmission {
    /// The scene document. Give this or `example`.
    #[schema(value_type = Option<SceneDocument>)]
    #[serde(default)]
    pub scene: Option<Value>,
    /// The name of a bundled example scene.
    #[serde(default)]
    pub example: Option<String>,
    /// The solver and whether to return the fields.
    #[serde(default)]
    pub settings: SolveRequest,
}

/// The answer to a submission.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct Submitted {
    /// The new job's id.
    pub id: String,
    /// `queued`.
    pub state: JobState,
    /// Where the job's status is.
    pub location: String,
}

/// The scene of a submission, validated; the service refuses server-side mesh files.
fn scene_of(scene: Option<Value>, example: Option<String>) -> Result<(Scene, String), ApiError> {
    let text = match (scene, example) {
        (Some(v), None) => v.to_string(),
        (None, Some(name)) => run_example(&name)?,
        (Some(_), Some(_)) => {
            return Err(ApiError::invalid(
                "example",
                "give `scene` or `example`, not both",
            ))
        }
        (None, None) => return Err(ApiError::invalid("scene", "give `scene` or `example`")),
    };
    let scene = wsm_core::parse_scene(&text)
        .map_err(|e| ApiError::invalid(join_path("scene", &e.path), e.to_string()))?;
    if scene.mesh.gmsh_file.is_some() {
        return Err(ApiError::invalid(
            "scene.mesh.gmsh_file",
            "the service does not read files on the server: give the mesh inline (mesh.inline; \
             `wsm inline-mesh scene.json > inline.json` converts a Gmsh scene), or let wsm mesh the polygons",
        ));
    }
    Ok((scene, text))
}

fn run_example(name: &str) -> Result<String, ApiError> {
    wsm_core::find_example(name)
        .map(str::to_string)
        .map_err(|e| ApiError::invalid("example", e.to_string()))
}

/// The scene's solve cost estimated before meshing (design §3.1, `wsm_core::estimate_solve_cost`)
/// against the server's limits: at most `max_triangles` for `what`, and a peak memory of at
/// most `max_bytes`; a refusal names the mesh size to coarsen and the value that fits.
fn check_cost(
    scene: &Scene,
    max_triangles: usize,
    max_bytes: u64,
    what: &str,
) -> Result<wsm_core::SolveCost, ApiError> {
    let cost = wsm_core::estimate_solve_cost(scene).map_err(|e| ApiError::engine(e, "scene"))?;
    cost.check(max_bytes as f64)
        .map_err(|r| ApiError::invalid(format!("scene.{}", r.path), r.message))?;
    if cost.triangles > max_triangles as f64 {
        return Err(ApiError::invalid(
            format!("scene.{}", cost.size_field),
            format!(
                "about {:.0} triangles; this server accepts at most {max_triangles} for {what} (raise this size)",
                cost.triangles
            ),
        ));
    }
    Ok(cost)
}

fn check_limits(scene: &Scene, request: &WorstRequest, limits: &Limits) -> Result<(), ApiError> {
    check_cost(
        scene,
        limits.max_triangles,
        limits.max_solve_memory,
        "a job",
    )?;
    if scene.uncertain.len() > limits.max_parameters {
        return Err(ApiError::invalid(
            "scene.uncertain",
            format!(
                "{} uncertain parameters; this server accepts at most {}",
                scene.uncertain.len(),
                limits.max_parameters
            ),
        ));
    }
    let (budget, path) = match request.budget {
        Some(b) => (b, "settings.budget"),
        None => (scene.search_budget(), "scene.search.budget"),
    };
    if budget > limits.max_budget {
        return Err(ApiError::invalid(
            path,
            format!(
                "{budget} solves; this server accepts at most {}",
                limits.max_budget
            ),
        ));
    }
    if request.threads.is_some() {
        return Err(ApiError::invalid(
            "settings.threads",
            "the server sets the threads of a job (wsm serve --threads-per-job)",
        ));
    }
    Ok(())
}

/// The plan of a submitted job — the record to queue — once the submission passed every check,
/// in this order: the scene itself ([`scene_of`]), the server's limits, the search settings, the
/// uncertain parameters, the admissible set (`wsm_core::check_admissible_set`: the checks a search
/// makes before its first evaluation, so that a job that cannot start is refused with the field)
/// and the run's log header, whose hash the record keeps. Runs on a blocking thread:
/// validation can take a while for large polygons (bounded by the scene's vertex limit).
fn plan_job(submission: JobSubmission, limits: &Limits) -> Result<NewJob, ApiError> {
    let (scene, text) = scene_of(submission.scene, submission.example)?;
    let request = submission.settings;
    check_limits(&scene, &request, limits)?;
    let settings = request.settings(&scene).map_err(ApiError::settings)?;
    let in_scene = |e| ApiError::engine(e, "scene");
    wsm_core::parameter_info(&scene).map_err(in_scene)?;
    wsm_core::check_admissible_set(&scene).map_err(in_scene)?;
    let header = wsm_core::log_header(&scene, &settings).map_err(in_scene)?;
    Ok(NewJob {
        id: uuid::Uuid::new_v4().to_string(),
        scene: text,
        settings: request,
        scene_name: scene.name.clone(),
        criteria: settings.criteria.clone(),
        budget: settings.budget,
        run_hash: header.run_hash,
    })
}

/// Queue `job` unless `max_active` jobs are queued or running already (503 `queue_full` with
/// `Retry-After`).
async fn enqueue(state: &AppState, job: NewJob) -> Result<(), ApiError> {
    let max_active = state.limits.max_active_jobs;
    if state.store.insert(job, max_active).await? {
        return Ok(());
    }
    Err(ApiError::new(
        ErrorCode::QueueFull,
        format!("{max_active} jobs are queued or running; try again later"),
    )
    .retry_after(10))
}

/// Queue a worst-scenario search.
#[utoipa::path(
    post,
    path = "/v1/jobs",
    tag = "jobs",
    request_body = JobSubmission,
    responses(
        (status = 202, description = "Queued", body = Submitted,
            headers(("Location" = String, description = "The job's status URL"))),
        (status = 400, description = "Not JSON", body = ErrorBody),
        (status = 401, description = "Token required", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 415, description = "Body not declared as JSON", body = ErrorBody),
        (status = 422, description = "Invalid scene or settings (with the JSON path)", body = ErrorBody),
        (status = 503, description = "Queue full, or the store unavailable (see Retry-After)", body = ErrorBody),
    )
)]
pub async fn submit_job(
    _: CanWrite,
    State(state): State<AppState>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let submission: JobSubmission = parse_body(&headers, body)?;
    let limits = state.limits.clone();
    let job = blocking(move || plan_job(submission, &limits)).await??;
    let id = job.id.clone();
    enqueue(&state, job).await?;
    let location = format!("/v1/jobs/{id}");
    Ok((
        StatusCode::ACCEPTED,
        [(header::LOCATION, location.clone())],
        Json(Submitted {
            id,
            state: JobState::Queued,
            location,
        }),
    )
        .into_response())
}

/// Solve the nominal data of a submitted scene within the server's limits for a synchronous
/// solve (validation, cost estimate, meshing and the solve: a blocking thread's work).
fn solve_now(submission: SolveSubmission, limits: &Limits) -> Result<SolveOutput, ApiError> {
    let (scene, _) = scene_of(submission.scene, submission.example)?;
    let settings = submission.settings;
    settings.check(&scene).map_err(ApiError::settings)?;
    let cost = check_cost(
        &scene,
        limits.max_solve_triangles,
        limits.max_solve_memory,
        "a synchronous solve (submit a job)",
    )?;
    if let (true, Some(dynamics)) = (settings.frames, &scene.dynamics) {
        super::solves::check_frames(
            dynamic_output_count(dynamics),
            cost.triangles.round() as usize,
            limits.max_field_triangles,
            "about ",
        )?;
    }
    wsm_core::solve(scene, &settings).map_err(|e| ApiError::engine(e, "scene"))
}

/// Solve one small scene now (its nominal data) and return the summary (and fields on request).
/// A dynamic scene's summary carries its time histories (`summary.history`: times, receivers,
/// contact zones, bodies, energy); with `settings.frames` the response also carries the nodal
/// displacement at every output time (`frames`), refused with 422 at `settings.frames` when
/// output times × triangles exceed the server's field cap (`--max-field-triangles`).
#[utoipa::path(
    post,
    path = "/v1/solve",
    tag = "solve",
    request_body = SolveSubmission,
    responses(
        (status = 200, description = "Solved", body = SolveOutput),
        (status = 400, description = "Not JSON", body = ErrorBody),
        (status = 401, description = "Token required", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 415, description = "Body not declared as JSON", body = ErrorBody),
        (status = 422, description = "Invalid scene, too large (fields or frames beyond the server's cap), or unsolvable", body = ErrorBody),
        (status = 503, description = "As many solves running as the server runs at once (see Retry-After)", body = ErrorBody),
    )
)]
pub async fn solve(
    _: CanWrite,
    State(state): State<AppState>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Json<SolveOutput>, ApiError> {
    let place = state.solves.take()?;
    let submission: SolveSubmission = parse_body(&headers, body)?;
    let limits = state.limits.clone();
    let output = blocking(move || {
        let _place = place;
        solve_now(submission, &limits)
    })
    .await??;
    super::solves::check_fields(
        &output,
        state.limits.max_field_triangles,
        "settings.fields",
        "ask without fields for the summary, or coarsen scene.mesh.max_size",
    )?;
    Ok(Json(output))
}
