//! API errors: every failure answers JSON `{error, detail, path?}` with the status that says
//! what went wrong (400 malformed JSON, 401 missing token, 404 unknown id, 409 wrong state,
//! 413 too large, 422 invalid scene or settings with the JSON path, 503 queue full, busy or
//! store unavailable with `Retry-After`, 500 anything else).

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::error_code::ErrorCode;
use crate::jobs::StoreError;
use wsm_core::WsmError;

/// The body of every error response.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ErrorBody {
    /// A stable code (`malformed_json`, `invalid_input`, `not_found`, …; the README's table
    /// lists them with their statuses).
    pub error: ErrorCode,
    /// What is wrong, for a person.
    pub detail: String,
    /// The JSON path of the offending field, where there is one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub path: Option<String>,
}

/// An error response.
#[derive(Debug, Clone)]
pub struct ApiError {
    /// The HTTP status of the answer.
    pub status: StatusCode,
    /// The JSON body: stable code, detail and, where there is one, the field's path.
    pub body: ErrorBody,
    /// Seconds sent in a `Retry-After` header (503 answers: the condition may pass).
    pub retry_after: Option<u32>,
}

impl ApiError {
    /// An error with the stable code `error` (its status) and `detail`; no path, no
    /// `Retry-After`.
    pub fn new(error: ErrorCode, detail: impl Into<String>) -> ApiError {
        ApiError {
            status: error.status(),
            body: ErrorBody {
                error,
                detail: detail.into(),
                path: None,
            },
            retry_after: None,
        }
    }

    /// The same error with `Retry-After: seconds` (a 503 whose condition may pass).
    pub fn retry_after(mut self, seconds: u32) -> ApiError {
        self.retry_after = Some(seconds);
        self
    }

    /// The same error naming `path`, the JSON path of the offending field.
    pub fn at(mut self, path: impl Into<String>) -> ApiError {
        self.body.path = Some(path.into());
        self
    }

    /// 422 for a field.
    pub fn invalid(path: impl Into<String>, detail: impl Into<String>) -> ApiError {
        ApiError::new(ErrorCode::InvalidInput, detail).at(path)
    }

    /// 404 `not_found`: there is no `what` (a job, an example, …) with id `id`.
    pub fn not_found(what: &str, id: &str) -> ApiError {
        ApiError::new(ErrorCode::NotFound, format!("no {what} '{id}'"))
    }

    /// 500 `internal`: the server's own fault (a stored record it cannot read, a task that
    /// panicked).
    pub fn internal(detail: impl Into<String>) -> ApiError {
        ApiError::new(ErrorCode::Internal, detail)
    }

    /// 409 `conflict`: the request does not fit the current state (e.g. of a job).
    pub fn conflict(detail: impl Into<String>) -> ApiError {
        ApiError::new(ErrorCode::Conflict, detail)
    }

    /// An engine error, answered with the code of its kind ([`ErrorCode::of_kind`],
    /// [`ErrorCode::answer`]); bad-input paths get `prefix` (the request field holding the
    /// scene), an unsolvable scene's the body's path.
    pub fn engine(error: WsmError, prefix: &str) -> ApiError {
        let code = ErrorCode::of_kind(error.kind()).answer();
        let path = error.path().map(|p| join_path(prefix, &p));
        let answer = ApiError::new(code, error.to_string());
        match (code, path) {
            (ErrorCode::InvalidInput, path) => {
                answer.at(path.unwrap_or_else(|| prefix.to_string()))
            }
            (ErrorCode::Unsolvable, Some(path)) => answer.at(path),
            _ => answer,
        }
    }
}

impl ApiError {
    /// An error of a run's settings ([`wsm_core::WorstRequest::settings`]): a path under
    /// `search.` names the scene's own search block (`scene.search.criteria[0]`), any other a
    /// field of the request's `settings` (`settings.budget`).
    pub fn settings(error: WsmError) -> ApiError {
        let prefix = match error.path() {
            Some(path) if path.starts_with("search.") => "scene",
            _ => "settings",
        };
        ApiError::engine(error, prefix)
    }
}

/// `scene` + `materials.rock.E` → `scene.materials.rock.E`; `$` is the root.
pub fn join_path(prefix: &str, path: &str) -> String {
    match (prefix.is_empty(), path) {
        (true, _) => path.to_string(),
        (false, "$" | "") => prefix.to_string(),
        (false, p) if p.starts_with('[') => format!("{prefix}{p}"),
        (false, p) => format!("{prefix}.{p}"),
    }
}

impl From<StoreError> for ApiError {
    /// An unavailable database is 503 with `Retry-After` (it may pass: ask again), anything
    /// else 500.
    fn from(e: StoreError) -> ApiError {
        if e.unavailable {
            ApiError::new(ErrorCode::StoreUnavailable, format!("{e}; try again later"))
                .retry_after(5)
        } else {
            ApiError::internal(e.to_string())
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let mut response = (self.status, Json(self.body)).into_response();
        if let Some(seconds) = self.retry_after {
            response
                .headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from(seconds));
        }
        response
    }
}
