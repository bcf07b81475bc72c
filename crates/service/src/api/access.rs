//! Who may do what (design §5.3, "Access"): the server's tokens ([`Access`]) and one axum
//! extractor per access level, so that a handler's signature says what it needs — [`CanRead`]
//! for the reads of job data, [`CanWrite`] for what changes something. An extractor that
//! refuses answers 401 `unauthorized` before the handler runs. Endpoints with neither (the
//! examples, the schema, `/healthz`) are open to anyone.

use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use axum::http::{header, HeaderMap};
use subtle::ConstantTimeEq;

use super::error::ApiError;
use super::AppState;
use crate::error_code::ErrorCode;

/// Who may do what. With a token, every request about jobs needs it — their scenes and results
/// are their submitters' data — except that a read-only token also opens the reads, and
/// `open_reads` (`wsm serve --open-reads`) leaves reads open to anyone. Without a token
/// everything is open (a server on loopback for one user). The examples, `/healthz`,
/// `/openapi.json` and the dashboard's files are always open.
#[derive(Debug, Clone, Default)]
pub struct Access {
    /// Bearer token for every job endpoint (`WSM_API_TOKEN`; `None`: open).
    pub token: Option<String>,
    /// Bearer token for the reads only (`WSM_READ_TOKEN`).
    pub read_token: Option<String>,
    /// Reads need no token.
    pub open_reads: bool,
}

/// A request that may read job data (the token, the read token, open reads, or no token set).
#[derive(Debug, Clone, Copy)]
pub struct CanRead;

/// A request that may change something: submit, solve, cancel (the token, or no token set).
#[derive(Debug, Clone, Copy)]
pub struct CanWrite;

impl FromRequestParts<AppState> for CanRead {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<CanRead, ApiError> {
        match state.access.may_read(bearer(&parts.headers)) {
            true => Ok(CanRead),
            false => Err(unauthorized("reading jobs")),
        }
    }
}

impl FromRequestParts<AppState> for CanWrite {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<CanWrite, ApiError> {
        match state.access.may_write(bearer(&parts.headers)) {
            true => Ok(CanWrite),
            false => Err(unauthorized("this endpoint")),
        }
    }
}

impl Access {
    /// Whether a request with bearer credentials `given` may change something.
    fn may_write(&self, given: &str) -> bool {
        self.token.is_none() || matches(given, &self.token)
    }

    /// Whether a request with bearer credentials `given` may read job data.
    fn may_read(&self, given: &str) -> bool {
        self.open_reads || self.may_write(given) || matches(given, &self.read_token)
    }
}

/// The bearer credentials of a request ("" when there are none); the scheme is
/// case-insensitive (RFC 9110 §11.1).
fn bearer(headers: &HeaderMap) -> &str {
    headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().split_once(' '))
        .filter(|(scheme, _)| scheme.eq_ignore_ascii_case("bearer"))
        .map_or("", |(_, credentials)| credentials.trim())
}

/// Constant-time comparison of given credentials with a configured token.
fn matches(given: &str, token: &Option<String>) -> bool {
    token
        .as_ref()
        .is_some_and(|t| bool::from(given.as_bytes().ct_eq(t.as_bytes())))
}

fn unauthorized(what: &str) -> ApiError {
    ApiError::new(
        ErrorCode::Unauthorized,
        format!("{what} needs the header 'Authorization: Bearer <token>' with the server's token"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn access(token: Option<&str>, read_token: Option<&str>, open_reads: bool) -> Access {
        Access {
            token: token.map(str::to_string),
            read_token: read_token.map(str::to_string),
            open_reads,
        }
    }

    /// (server, credentials given) → (may read, may write), every combination that differs.
    #[test]
    fn each_token_opens_what_it_should_and_no_more() {
        let open = access(None, None, false);
        let locked = access(Some("w"), Some("r"), false);
        let open_reads = access(Some("w"), None, true);
        let cases = [
            (&open, "", (true, true)),
            (&open, "anything", (true, true)),
            (&locked, "", (false, false)),
            (&locked, "w", (true, true)),
            (&locked, "r", (true, false)),
            (&locked, "w ", (false, false)),
            (&locked, "W", (false, false)),
            (&open_reads, "", (true, false)),
            (&open_reads, "w", (true, true)),
        ];
        for (server, given, expected) in cases {
            let got = (server.may_read(given), server.may_write(given));
            assert_eq!(got, expected, "{server:?} given {given:?}");
        }
    }

    #[test]
    fn the_bearer_scheme_is_case_insensitive_and_other_schemes_give_nothing() {
        let credentials = |value: &str| {
            let mut headers = HeaderMap::new();
            headers.insert(header::AUTHORIZATION, value.parse().unwrap());
            bearer(&headers).to_string()
        };
        assert_eq!(credentials("Bearer abc"), "abc");
        assert_eq!(credentials("bEaReR  abc "), "abc");
        assert_eq!(credentials("Basic abc"), "");
        assert_eq!(credentials("abc"), "");
        assert_eq!(bearer(&HeaderMap::new()), "");
    }
}
