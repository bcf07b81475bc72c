//! The service's error codes (design §5.3): one enum for the `error` of every API error body,
//! the `error_kind` a failed job's record keeps, and — for the codes that come from the
//! engine's [`ErrorKind`] — the command line's exit status. Each code has its HTTP status and a
//! label for people (served by `GET /v1/labels`).
//!
//! Two vocabularies meet here and both stay as they were written: the API answers an engine
//! error of kind `bad_input` with `invalid_input` (422), while a job's record keeps the kind's
//! own name `bad_input` (so stored rows read back unchanged). [`ErrorCode::answer`] maps a
//! record's code to the code the API answers with.

use axum::http::StatusCode;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use wsm_core::ErrorKind;

/// A stable error code (JSON: its snake-case name).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    /// 400: the body is not JSON, or has repeated keys.
    MalformedJson,
    /// 400: the body could not be read off the connection.
    MalformedBody,
    /// 400: the request's head is malformed (e.g. two `Authorization` headers).
    BadRequest,
    /// 401: the bearer token is missing or wrong.
    Unauthorized,
    /// 404: no such job, example or route; a failed job's record: the engine's kind
    /// `not_found` (exit code 2).
    NotFound,
    /// 408: the body did not arrive within the server's timeout.
    RequestTimeout,
    /// 409: the request does not fit the current state (of a job), or the work was cancelled.
    Conflict,
    /// 413: the body is larger than the server's limit.
    TooLarge,
    /// 415: the body is not declared as JSON.
    UnsupportedMediaType,
    /// 422: a field of the scene, settings or query is wrong (the answer names its path).
    InvalidInput,
    /// 422: the scene is valid but has no solution (a body cannot be balanced); a failed job's
    /// record: the engine's kind `unsolvable` (exit code 3).
    Unsolvable,
    /// 500: a solver or the search failed on valid input.
    SolverFailure,
    /// 500: the server's own fault (a store or file error, a task that panicked).
    Internal,
    /// 503: as many jobs are queued or running as the server takes (`Retry-After`).
    QueueFull,
    /// 503: as many synchronous solves or connections as the server takes (`Retry-After`).
    Busy,
    /// 503: the database does not answer or take writes (`Retry-After`).
    StoreUnavailable,
    /// A failed job's record: the engine's kind `bad_input` (exit code 2).
    BadInput,
    /// A failed job's record: the engine's kind `solver` (exit code 4).
    Solver,
    /// A failed job's record: the engine's kind `cancelled` (exit code 6).
    Cancelled,
    /// A failed job's record: the engine's kind `io`, files and stores (exit code 5).
    Io,
    /// A failed job's record: the search's thread panicked.
    Panic,
    /// A failed job's record: the stored row could not be read.
    Damaged,
    /// A failed job's record: its lease expired as many times as the server allows.
    AttemptsExhausted,
}

impl ErrorCode {
    /// Every code, the API's first (in the order of their statuses), then the records' own.
    pub const ALL: [ErrorCode; 23] = [
        ErrorCode::MalformedJson,
        ErrorCode::MalformedBody,
        ErrorCode::BadRequest,
        ErrorCode::Unauthorized,
        ErrorCode::NotFound,
        ErrorCode::RequestTimeout,
        ErrorCode::Conflict,
        ErrorCode::TooLarge,
        ErrorCode::UnsupportedMediaType,
        ErrorCode::InvalidInput,
        ErrorCode::Unsolvable,
        ErrorCode::SolverFailure,
        ErrorCode::Internal,
        ErrorCode::QueueFull,
        ErrorCode::Busy,
        ErrorCode::StoreUnavailable,
        ErrorCode::BadInput,
        ErrorCode::Solver,
        ErrorCode::Cancelled,
        ErrorCode::Io,
        ErrorCode::Panic,
        ErrorCode::Damaged,
        ErrorCode::AttemptsExhausted,
    ];

    /// The code the API answers with for an error of this code: a record's code becomes the
    /// API's (`bad_input` → `invalid_input`, `solver` → `solver_failure`, `cancelled` →
    /// `conflict`, `io`, `panic`, `damaged`, `attempts_exhausted` → `internal`); an API code
    /// is its own answer.
    pub fn answer(self) -> ErrorCode {
        match self {
            ErrorCode::BadInput => ErrorCode::InvalidInput,
            ErrorCode::Solver => ErrorCode::SolverFailure,
            ErrorCode::Cancelled => ErrorCode::Conflict,
            ErrorCode::Io
            | ErrorCode::Panic
            | ErrorCode::Damaged
            | ErrorCode::AttemptsExhausted => ErrorCode::Internal,
            code => code,
        }
    }

    /// Whether the API answers with this code (else only job records keep it).
    pub fn is_answered(self) -> bool {
        self.answer() == self
    }

    /// Whether a failed job's record may keep this code: the engine's kinds and the service's
    /// own failures of a job (`panic`, `damaged`, `attempts_exhausted`).
    pub fn is_recorded(self) -> bool {
        self.kind().is_some()
            || matches!(
                self,
                ErrorCode::Panic | ErrorCode::Damaged | ErrorCode::AttemptsExhausted
            )
    }

    /// The HTTP status of the answer (of [`ErrorCode::answer`] for a record's code).
    pub fn status(self) -> StatusCode {
        match self.answer() {
            ErrorCode::MalformedJson | ErrorCode::MalformedBody | ErrorCode::BadRequest => {
                StatusCode::BAD_REQUEST
            }
            ErrorCode::Unauthorized => StatusCode::UNAUTHORIZED,
            ErrorCode::NotFound => StatusCode::NOT_FOUND,
            ErrorCode::RequestTimeout => StatusCode::REQUEST_TIMEOUT,
            ErrorCode::Conflict => StatusCode::CONFLICT,
            ErrorCode::TooLarge => StatusCode::PAYLOAD_TOO_LARGE,
            ErrorCode::UnsupportedMediaType => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ErrorCode::InvalidInput | ErrorCode::Unsolvable => StatusCode::UNPROCESSABLE_ENTITY,
            ErrorCode::QueueFull | ErrorCode::Busy | ErrorCode::StoreUnavailable => {
                StatusCode::SERVICE_UNAVAILABLE
            }
            _ => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// A job record's code for an engine error of `kind`: the kind's own name (`bad_input`,
    /// `unsolvable`, `solver`, `cancelled`, `not_found`, `io`).
    pub fn of_kind(kind: ErrorKind) -> ErrorCode {
        match kind {
            ErrorKind::BadInput => ErrorCode::BadInput,
            ErrorKind::Unsolvable => ErrorCode::Unsolvable,
            ErrorKind::Solver => ErrorCode::Solver,
            ErrorKind::Cancelled => ErrorCode::Cancelled,
            ErrorKind::NotFound => ErrorCode::NotFound,
            ErrorKind::Io => ErrorCode::Io,
        }
    }

    /// The engine's kind a record's code names (`None` for the codes of the API and the
    /// service's own failures).
    pub fn kind(self) -> Option<ErrorKind> {
        match self {
            ErrorCode::BadInput => Some(ErrorKind::BadInput),
            ErrorCode::Unsolvable => Some(ErrorKind::Unsolvable),
            ErrorCode::Solver => Some(ErrorKind::Solver),
            ErrorCode::Cancelled => Some(ErrorKind::Cancelled),
            ErrorCode::NotFound => Some(ErrorKind::NotFound),
            ErrorCode::Io => Some(ErrorKind::Io),
            _ => None,
        }
    }

    /// The command line's exit status of an engine error with this code
    /// ([`ErrorKind::exit_code`]); `None` when the code does not come from the engine.
    pub fn exit_code(self) -> Option<u8> {
        self.kind().map(ErrorKind::exit_code)
    }

    /// The code's name in JSON (`invalid_input`, `bad_input`, …).
    pub fn name(self) -> &'static str {
        match self {
            ErrorCode::MalformedJson => "malformed_json",
            ErrorCode::MalformedBody => "malformed_body",
            ErrorCode::BadRequest => "bad_request",
            ErrorCode::Unauthorized => "unauthorized",
            ErrorCode::NotFound => "not_found",
            ErrorCode::RequestTimeout => "request_timeout",
            ErrorCode::Conflict => "conflict",
            ErrorCode::TooLarge => "too_large",
            ErrorCode::UnsupportedMediaType => "unsupported_media_type",
            ErrorCode::InvalidInput => "invalid_input",
            ErrorCode::Unsolvable => "unsolvable",
            ErrorCode::SolverFailure => "solver_failure",
            ErrorCode::Internal => "internal",
            ErrorCode::QueueFull => "queue_full",
            ErrorCode::Busy => "busy",
            ErrorCode::StoreUnavailable => "store_unavailable",
            ErrorCode::BadInput => "bad_input",
            ErrorCode::Solver => "solver",
            ErrorCode::Cancelled => "cancelled",
            ErrorCode::Io => "io",
            ErrorCode::Panic => "panic",
            ErrorCode::Damaged => "damaged",
            ErrorCode::AttemptsExhausted => "attempts_exhausted",
        }
    }

    /// The code named `text` (as written by [`ErrorCode::name`]); `None` for an unknown name.
    pub fn parse(text: &str) -> Option<ErrorCode> {
        ErrorCode::ALL.into_iter().find(|c| c.name() == text)
    }

    /// What the code means, for a person (the dashboard's label).
    pub fn label(self) -> &'static str {
        match self {
            ErrorCode::MalformedJson => "malformed JSON",
            ErrorCode::MalformedBody => "unreadable request body",
            ErrorCode::BadRequest => "malformed request",
            ErrorCode::Unauthorized => "token missing or wrong",
            ErrorCode::NotFound => "not found",
            ErrorCode::RequestTimeout => "request body too slow",
            ErrorCode::Conflict => "not in this state",
            ErrorCode::TooLarge => "request body too large",
            ErrorCode::UnsupportedMediaType => "body not declared as JSON",
            ErrorCode::InvalidInput => "invalid input",
            ErrorCode::Unsolvable => "unsolvable",
            ErrorCode::SolverFailure => "solver failure",
            ErrorCode::Internal => "server error",
            ErrorCode::QueueFull => "job queue full",
            ErrorCode::Busy => "server busy",
            ErrorCode::StoreUnavailable => "job store unavailable",
            ErrorCode::BadInput => "bad input",
            ErrorCode::Solver => "solver failure",
            ErrorCode::Cancelled => "cancelled",
            ErrorCode::Io => "file or store error",
            ErrorCode::Panic => "internal fault",
            ErrorCode::Damaged => "damaged record",
            ErrorCode::AttemptsExhausted => "attempts exhausted",
        }
    }
}

impl std::fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The JSON name is the serde name, and `parse` reads it back, for every code.
    #[test]
    fn names_are_the_serde_names_and_parse_back() {
        for code in ErrorCode::ALL {
            let json = serde_json::to_value(code).unwrap();
            assert_eq!(json, serde_json::json!(code.name()), "{code:?}");
            assert_eq!(ErrorCode::parse(code.name()), Some(code));
            let back: ErrorCode = serde_json::from_value(json).unwrap();
            assert_eq!(back, code);
        }
        assert_eq!(ErrorCode::parse("bogus"), None);
    }

    /// A record keeps the engine kind's own name, with the kind's exit code; the API answers
    /// it with a code it answers, of the same status class as the kind's documented one.
    #[test]
    fn engine_kinds_keep_their_names_and_exit_codes() {
        let kinds = [
            ErrorKind::BadInput,
            ErrorKind::Unsolvable,
            ErrorKind::Solver,
            ErrorKind::Cancelled,
            ErrorKind::NotFound,
            ErrorKind::Io,
        ];
        for kind in kinds {
            let code = ErrorCode::of_kind(kind);
            assert_eq!(code.name(), kind.name());
            assert_eq!(code.kind(), Some(kind));
            assert_eq!(code.exit_code(), Some(kind.exit_code()));
            assert!(code.answer().is_answered());
        }
        let answered = |kind| ErrorCode::of_kind(kind).answer().status().as_u16();
        assert_eq!(answered(ErrorKind::BadInput), 422);
        assert_eq!(answered(ErrorKind::Cancelled), 409);
        assert_eq!(answered(ErrorKind::NotFound), 404);
        let codes_with_kind = ErrorCode::ALL.iter().filter(|c| c.kind().is_some()).count();
        assert_eq!(codes_with_kind, kinds.len());
    }

    /// The README's table of error codes is this enum's: code, status (a record's code: the
    /// status and code of its answer), where it is used, exit code and label, in `ALL`'s order.
    #[test]
    fn the_readme_table_lists_every_code() {
        let readme = include_str!("../../../README.md");
        let mut rows = vec![
            "| code | HTTP status | used in | exit code | label |".to_string(),
            "|---|---|---|---|---|".to_string(),
        ];
        for code in ErrorCode::ALL {
            let status = match code.is_answered() {
                true => code.status().as_u16().to_string(),
                false => format!("{} as `{}`", code.status().as_u16(), code.answer()),
            };
            let used: Vec<&str> = [
                (code.is_answered(), "answers"),
                (code.is_recorded(), "job records"),
            ]
            .into_iter()
            .filter_map(|(used, place)| used.then_some(place))
            .collect();
            let exit = code.exit_code().map_or(String::new(), |e| e.to_string());
            rows.push(format!(
                "| `{code}` | {status} | {} | {exit} | {} |",
                used.join(", "),
                code.label()
            ));
        }
        let table = rows.join("\n");
        assert!(
            readme.contains(&table),
            "the README's table should read:\n{table}"
        );
    }

    /// `ALL` lists each code once, and every code has a label.
    #[test]
    fn every_code_is_listed_once_with_a_label() {
        let names: std::collections::BTreeSet<_> = ErrorCode::ALL.map(ErrorCode::name).into();
        assert_eq!(names.len(), ErrorCode::ALL.len());
        for code in ErrorCode::ALL {
            assert!(!code.label().is_empty(), "{code:?}");
        }
    }
}
