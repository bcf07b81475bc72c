//! What every request passes before a handler sees it (docs/service.md, "Robustness": timeouts and
//! the connection cap): at most one `Authorization` header (400: with two, which one decides would
//! be up to the reader), a declared `Content-Length` within the body limit (413 before any of the
//! body is read), and the whole body read within the body timeout (408: a client that sends its
//! body slowly holds its connection no longer than that). Refusals close the connection: the rest
//! of the body is never read.

use std::time::Duration;

use axum::body::{Body, Bytes};
use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, HeaderValue};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use futures_util::StreamExt;

use super::error::ApiError;
use crate::error_code::ErrorCode;

/// The limits the guard applies.
#[derive(Debug, Clone, Copy)]
pub struct BodyLimits {
    /// Largest body \[bytes\].
    pub max_bytes: usize,
    /// The whole body must arrive within this long of the request head.
    pub timeout: Duration,
}

/// The middleware (`axum::middleware::from_fn_with_state`).
pub async fn guard(State(limits): State<BodyLimits>, request: Request, next: Next) -> Response {
    if let Err(refusal) = check_head(request.headers(), limits.max_bytes) {
        return closing(refusal);
    }
    let (parts, body) = request.into_parts();
    let bytes = match tokio::time::timeout(limits.timeout, read(body, limits.max_bytes)).await {
        Ok(Ok(bytes)) => bytes,
        Ok(Err(refusal)) => return closing(refusal),
        Err(_) => {
            return closing(ApiError::new(
                ErrorCode::RequestTimeout,
                format!(
                    "the request body did not arrive within {} s",
                    limits.timeout.as_secs_f64()
                ),
            ))
        }
    };
    next.run(Request::from_parts(parts, Body::from(bytes)))
        .await
}

/// One `Authorization` header at most; a declared length within `max_bytes`.
fn check_head(headers: &HeaderMap, max_bytes: usize) -> Result<(), ApiError> {
    if headers.get_all(header::AUTHORIZATION).iter().count() > 1 {
        return Err(ApiError::new(
            ErrorCode::BadRequest,
            "more than one Authorization header; send one",
        ));
    }
    let declared = headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    match declared {
        Some(n) if n > max_bytes as u64 => Err(too_large(max_bytes)),
        _ => Ok(()),
    }
}

fn too_large(max_bytes: usize) -> ApiError {
    ApiError::new(
        ErrorCode::TooLarge,
        format!("the request body is larger than the server's limit of {max_bytes} bytes"),
    )
}

/// The body, up to `max_bytes` (413 beyond; 400 when the client breaks it off).
async fn read(body: Body, max_bytes: usize) -> Result<Bytes, ApiError> {
    let mut stream = body.into_data_stream();
    let mut bytes = Vec::new();
    while let Some(chunk) = stream.next().await {
        let chunk = chunk.map_err(|e| {
            ApiError::new(
                ErrorCode::MalformedBody,
                format!("the request body could not be read: {e}"),
            )
        })?;
        if bytes.len() + chunk.len() > max_bytes {
            return Err(too_large(max_bytes));
        }
        bytes.extend_from_slice(&chunk);
    }
    Ok(Bytes::from(bytes))
}

/// A refusal that also closes the connection.
pub(crate) fn closing(error: ApiError) -> Response {
    let mut response = error.into_response();
    response
        .headers_mut()
        .insert(header::CONNECTION, HeaderValue::from_static("close"));
    response
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::StatusCode;

    #[test]
    fn two_authorization_headers_or_a_declared_length_over_the_limit_are_refused() {
        let mut headers = HeaderMap::new();
        headers.append(header::AUTHORIZATION, "Bearer a".parse().unwrap());
        assert!(check_head(&headers, 10).is_ok());
        headers.append(header::AUTHORIZATION, "Bearer b".parse().unwrap());
        assert_eq!(
            check_head(&headers, 10).unwrap_err().status,
            StatusCode::BAD_REQUEST
        );
        let mut headers = HeaderMap::new();
        headers.insert(header::CONTENT_LENGTH, "11".parse().unwrap());
        assert_eq!(
            check_head(&headers, 10).unwrap_err().status,
            StatusCode::PAYLOAD_TOO_LARGE
        );
        headers.insert(header::CONTENT_LENGTH, "10".parse().unwrap());
        assert!(check_head(&headers, 10).is_ok());
    }
}
