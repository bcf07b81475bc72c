//! The HTTP API of `wsm serve` (design §5.3): axum routes over the job store and the front door,
//! documented as OpenAPI 3.1 by utoipa (served at `/openapi.json`, checked in as
//! `openapi/openapi.json`, the scene's JSON Schema among its components). Request bodies are
//! parsed here so that every bad field answers 422 with its JSON path, query strings likewise
//! (`query::Query`); job endpoints require the bearer token when one is configured
//! ([`Access`]), which a handler asks for with the extractor [`CanRead`] or [`CanWrite`].

mod access;
mod body;
mod error;
mod evaluations;
mod fields;
mod guard;
mod jobs;
mod labels;
mod misc;
mod query;
mod schema;
mod solves;
mod status;
mod submit;

pub use access::{Access, CanRead, CanWrite};
pub use error::{ApiError, ErrorBody};
pub(crate) use guard::closing;
pub use labels::{CriterionLabel, Labels};
pub use solves::SolveSlots;

use std::sync::Arc;
use std::time::Duration;

use axum::extract::DefaultBodyLimit;
use axum::Router;
use tower_http::trace::TraceLayer;
use utoipa::OpenApi;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use crate::jobs::health::StoreHealth;
use crate::jobs::runner::Live;
use crate::jobs::JobStore;

/// Limits on what the service accepts.
#[derive(Debug, Clone)]
pub struct Limits {
    /// Request bodies \[bytes\].
    pub max_body_bytes: usize,
    /// Estimated triangles of a job's mesh (area / (√3/4 · max_size²)).
    pub max_triangles: usize,
    /// Estimated triangles of a synchronous `POST /v1/solve`.
    pub max_solve_triangles: usize,
    /// Uncertain parameters of a submitted job's scene; beyond, 422.
    pub max_parameters: usize,
    /// Inner solves a job's search may spend (its budget); beyond, 422.
    pub max_budget: usize,
    /// Queued and running jobs at once; beyond, 503 with `Retry-After`.
    pub max_active_jobs: usize,
    /// Synchronous solves (`POST /v1/solve`, a job's fields) at once; beyond, 503 with
    /// `Retry-After`.
    pub max_concurrent_solves: usize,
    /// Triangles of the largest mesh whose fields a response carries.
    pub max_field_triangles: usize,
    /// Peak memory one solve may need \[bytes\]: beyond, a scene is refused (422 naming the
    /// mesh size to coarsen) before meshing (design §3.1, cost estimate).
    pub max_solve_memory: u64,
    /// A request's body must arrive within this long.
    pub body_timeout: Duration,
}

/// The default cap on synchronous solves: half the cores (at least 1, at most 4), so that
/// solves leave room for the job workers and the requests.
pub fn default_concurrent_solves() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (cores / 2).clamp(1, 4)
}

impl Default for Limits {
    fn default() -> Limits {
        Limits {
            max_body_bytes: 4 << 20,
            max_triangles: 2_000_000,
            max_solve_triangles: 200_000,
            max_parameters: 64,
            max_budget: 100_000,
            max_active_jobs: 1000,
            max_concurrent_solves: default_concurrent_solves(),
            max_field_triangles: 50_000,
            max_solve_memory: wsm_core::default_max_solve_memory(),
            body_timeout: Duration::from_secs(30),
        }
    }
}

/// What every handler shares.
#[derive(Clone)]
pub struct AppState {
    /// The durable job store (SQLite or PostgreSQL).
    pub store: Arc<dyn JobStore>,
    /// Jobs running in this process (their cancel flags), and whether it is stopping.
    pub live: Arc<Live>,
    /// Limits on what the service accepts.
    pub limits: Arc<Limits>,
    /// Who may do what: the API tokens and whether reads are open.
    pub access: Arc<Access>,
    /// Whether the store takes writes (probed in the background).
    pub health: Arc<StoreHealth>,
    /// Places for synchronous solves (`Limits::max_concurrent_solves`).
    pub solves: SolveSlots,
}

/// `work` on a blocking thread (meshing, solving, validating large scenes: the runtime's threads
/// must keep answering other requests); 500 `internal` if it panicked.
async fn blocking<T: Send + 'static>(
    work: impl FnOnce() -> T + Send + 'static,
) -> Result<T, ApiError> {
    tokio::task::spawn_blocking(work)
        .await
        .map_err(|e| ApiError::internal(e.to_string()))
}

#[derive(OpenApi)]
#[openapi(
    info(
        title = "wsm",
        description = "Worst-scenario analysis of multibody elastic contact with Tresca friction. Submit a scene with intervals for its uncertain data; a job finds the worst and best value of each criterion Φ1–Φ6 and the data that attain them. All quantities are SI: m, Pa, N/m³, K, W/(m K), W/m³, s."
    ),
    components(schemas(ErrorBody, crate::error_code::ErrorCode))
)]
struct ApiDoc;

/// The routes, with their OpenAPI description.
fn routes() -> OpenApiRouter<AppState> {
    OpenApiRouter::with_openapi(ApiDoc::openapi())
        .routes(routes!(submit::submit_job, jobs::list_jobs))
        .routes(routes!(jobs::job_status))
        .routes(routes!(jobs::job_events))
        .routes(routes!(jobs::job_scene))
        .routes(routes!(jobs::job_result))
        .routes(routes!(jobs::job_history))
        .routes(routes!(evaluations::job_evaluations))
        .routes(routes!(jobs::cancel_job))
        .routes(routes!(fields::job_fields))
        .routes(routes!(submit::solve))
        .routes(routes!(misc::list_examples))
        .routes(routes!(misc::get_example))
        .routes(routes!(labels::labels))
        .routes(routes!(misc::health))
        .routes(routes!(schema::scene_schema))
}

/// The service's router: the API, `/openapi.json`, and the body-size limit.
pub fn router(state: AppState) -> Router {
    let body_limit = state.limits.max_body_bytes;
    let (router, api) = routes().with_state(state).split_for_parts();
    let document = Arc::new(document(&api));
    router
        .route(
            "/openapi.json",
            axum::routing::get(move || {
                let document = Arc::clone(&document);
                async move { axum::Json(document.as_ref().clone()) }
            }),
        )
        .layer(DefaultBodyLimit::max(body_limit))
}

/// The request guard around a whole app (the API and the dashboard), inside tower-http's trace
/// layer: every request gets a `tracing` span (method, path) and its response an event with
/// status and latency (`debug`; server errors at `error`), refusals of the guard included.
pub fn guarded(app: Router, limits: &Limits) -> Router {
    let body = guard::BodyLimits {
        max_bytes: limits.max_body_bytes,
        timeout: limits.body_timeout,
    };
    app.layer(axum::middleware::from_fn_with_state(body, guard::guard))
        .layer(TraceLayer::new_for_http())
}

/// The OpenAPI document of `api` with the scene's JSON Schema among its components.
fn document(api: &utoipa::openapi::OpenApi) -> serde_json::Value {
    let document = serde_json::to_value(api).expect("the OpenAPI document is JSON");
    schema::with_scene_components(document)
}

/// The OpenAPI document as served and as checked in (`openapi/openapi.json`).
pub fn openapi_json() -> Result<String, serde_json::Error> {
    let (_, api) = routes().split_for_parts();
    serde_json::to_string_pretty(&document(&api)).map(|text| text + "\n")
}
