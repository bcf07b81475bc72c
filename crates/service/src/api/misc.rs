//! Bundled example scenes and the health check.

use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::Json;
use serde::Serialize;
use serde_json::Value;
use utoipa::ToSchema;

use super::error::{ApiError, ErrorBody};
use super::schema::SceneDocument;
use super::AppState;

/// A bundled example scene.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ExampleInfo {
    /// Use it as `{"example": name}` in a submission.
    pub name: String,
    /// The scene's own name.
    pub title: String,
    /// Its uncertain parameters (field paths).
    pub uncertain: Vec<String>,
}

/// The bundled example scenes.
#[utoipa::path(get, path = "/v1/examples", tag = "examples",
    responses((status = 200, body = Vec<ExampleInfo>)))]
pub async fn list_examples() -> Json<Vec<ExampleInfo>> {
    Json(
        wsm_core::EXAMPLES
            .iter()
            .filter_map(|(name, text)| {
                let scene = wsm_core::parse_scene(text).ok()?;
                Some(ExampleInfo {
                    name: name.to_string(),
                    title: scene.name.clone(),
                    uncertain: scene.uncertain.iter().map(|u| u.field.clone()).collect(),
                })
            })
            .collect(),
    )
}

/// One bundled example scene (a starting point for your own).
#[utoipa::path(get, path = "/v1/examples/{name}", tag = "examples",
    params(("name" = String, Path, description = "Example name")),
    responses((status = 200, description = "The scene document", body = SceneDocument),
        (status = 404, body = ErrorBody)))]
pub async fn get_example(Path(name): Path<String>) -> Result<Json<Value>, ApiError> {
    let text = wsm_core::find_example(&name).map_err(|_| ApiError::not_found("example", &name))?;
    serde_json::from_str(text)
        .map(Json)
        .map_err(|e| ApiError::engine(wsm_core::WsmError::io("example", e), ""))
}

/// Service health.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct Health {
    /// `ok` when the store answers and takes writes, else `degraded` (with status 503).
    pub status: String,
    /// The version of `wsm`.
    pub version: String,
    /// Queued and running jobs (`None` when the store does not answer).
    pub active_jobs: Option<usize>,
    /// `ok`, or why the store cannot be read or written.
    pub store: String,
}

/// Health check: the store answers reads, and the last background probe could write.
#[utoipa::path(get, path = "/healthz", tag = "health",
    responses((status = 200, description = "Healthy", body = Health),
        (status = 503, description = "The store cannot be read or written", body = Health)))]
pub async fn health(State(state): State<AppState>) -> (StatusCode, Json<Health>) {
    let active = state.store.active_count().await;
    let problem = match (&active, state.health.write_failure()) {
        (Err(e), _) => Some(e.to_string()),
        (Ok(_), failure) => failure,
    };
    let code = if problem.is_some() {
        StatusCode::SERVICE_UNAVAILABLE
    } else {
        StatusCode::OK
    };
    let health = Health {
        status: if problem.is_some() { "degraded" } else { "ok" }.into(),
        version: env!("CARGO_PKG_VERSION").into(),
        active_jobs: active.ok(),
        store: problem.unwrap_or_else(|| "ok".into()),
    };
    (code, Json(health))
}
