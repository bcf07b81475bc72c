//! Reading a JSON request body strictly: the media type must be JSON (415 otherwise), the body
//! must parse (400), no object may repeat a key (422 naming it: `serde_json` would silently
//! keep the last), the document and its `scene` and `settings` must be objects (422: serde
//! would read a struct from an array by position), and every field must fit its type (422 with
//! the field's JSON path, in JSON words: `expected a number`, never a Rust type name).

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::http::{header, HeaderMap, StatusCode};
use serde::de::DeserializeOwned;
use serde_json::Value;

use super::error::ApiError;
use crate::error_code::ErrorCode;
use wsm_core::{plain_message, strict_value, StrictError};

/// Members of a submission that must be JSON objects when given.
const OBJECT_MEMBERS: [&str; 2] = ["scene", "settings"];

/// Parse a JSON body: 413 over the limit, 415 not declared JSON, 400 not JSON, 422 a repeated
/// key or a bad field (with its path).
pub fn parse_body<T: DeserializeOwned>(
    headers: &HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<T, ApiError> {
    let bytes = body.map_err(|rejection| {
        if rejection.status() == StatusCode::PAYLOAD_TOO_LARGE {
            ApiError::new(
                ErrorCode::TooLarge,
                "the request body is larger than the server's limit",
            )
        } else {
            ApiError::new(ErrorCode::MalformedJson, rejection.body_text())
        }
    })?;
    check_media_type(headers)?;
    let value = strict_body(&bytes)?;
    let Value::Object(members) = &value else {
        return Err(ApiError::invalid("$", "the body must be a JSON object"));
    };
    for name in OBJECT_MEMBERS {
        if members
            .get(name)
            .is_some_and(|v| !v.is_object() && !v.is_null())
        {
            return Err(ApiError::invalid(name, "must be a JSON object"));
        }
    }
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { "$".to_string() } else { path };
        ApiError::invalid(path, plain_message(&e.into_inner().to_string()))
    })
}

/// 415 unless the body is declared `application/json` (or a `+json` type), parameters allowed.
fn check_media_type(headers: &HeaderMap) -> Result<(), ApiError> {
    let declared = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("");
    let essence = declared
        .split(';')
        .next()
        .unwrap_or("")
        .trim()
        .to_ascii_lowercase();
    if essence == "application/json"
        || (essence.starts_with("application/") && essence.ends_with("+json"))
    {
        return Ok(());
    }
    let given = if declared.is_empty() {
        "no Content-Type".to_string()
    } else {
        format!("Content-Type '{declared}'")
    };
    Err(ApiError::new(
        ErrorCode::UnsupportedMediaType,
        format!("the body must be JSON sent with 'Content-Type: application/json' (got {given})"),
    ))
}

/// The body as a JSON value; 400 when it is not JSON, 422 (with the key's path) when an object
/// repeats a key — the scene reader's strict JSON ([`strict_value`]), so a scene file and a
/// request body are refused alike.
fn strict_body(bytes: &[u8]) -> Result<Value, ApiError> {
    let not_json = |message: String| {
        ApiError::new(
            ErrorCode::MalformedJson,
            format!("the body is not valid JSON: {message}"),
        )
    };
    let mut reader = serde_json::Deserializer::from_slice(bytes);
    let value = strict_value(&mut reader).map_err(|e| match e {
        StrictError::Syntax { message, .. } => not_json(message),
        repeated => ApiError::invalid(repeated.path(), repeated.reason()),
    })?;
    reader.end().map_err(|e| not_json(e.to_string()))?;
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn json_headers() -> HeaderMap {
        let mut h = HeaderMap::new();
        h.insert(
            header::CONTENT_TYPE,
            "application/json; charset=utf-8".parse().unwrap(),
        );
        h
    }

    fn parse(text: &str) -> Result<Value, ApiError> {
        parse_body::<Value>(&json_headers(), Ok(Bytes::from(text.to_string())))
    }

    #[test]
    fn a_repeated_key_is_named_with_its_path() {
        let e = parse(r#"{"settings": {"budget": 10, "budget": 20}}"#).unwrap_err();
        assert_eq!(e.status, StatusCode::UNPROCESSABLE_ENTITY);
        assert_eq!(
            e.body.path.as_deref(),
            Some("settings.budget"),
            "{:?}",
            e.body
        );
        let e = parse(r#"{"a": 1, "a": 1}"#).unwrap_err();
        assert_eq!(e.body.path.as_deref(), Some("a"), "{:?}", e.body);
        let e = parse(r#"{"scene": {"bodies": [{"name": "x", "name": "y"}]}}"#).unwrap_err();
        assert_eq!(
            e.body.path.as_deref(),
            Some("scene.bodies[0].name"),
            "{:?}",
            e.body
        );
    }

    #[test]
    fn numbers_and_nesting_survive_the_strict_reading() {
        let text = r#"{"x": [1, -2, 0.1, 1e-300, 18446744073709551615, true, null, "s", {}]}"#;
        assert_eq!(
            parse(text).unwrap(),
            serde_json::from_str::<Value>(text).unwrap()
        );
    }

    #[test]
    fn settings_and_scene_must_be_objects_and_trailing_text_is_refused() {
        let e = parse(r#"{"settings": []}"#).unwrap_err();
        assert_eq!(e.status, StatusCode::UNPROCESSABLE_ENTITY);
        assert_eq!(e.body.path.as_deref(), Some("settings"));
        let e = parse(r#"{"scene": [1, 2]}"#).unwrap_err();
        assert_eq!(e.body.path.as_deref(), Some("scene"));
        let e = parse(r#"{"a": 1} x"#).unwrap_err();
        assert_eq!(e.status, StatusCode::BAD_REQUEST);
        let e = parse(r#"[1]"#).unwrap_err();
        assert_eq!(e.body.path.as_deref(), Some("$"));
    }

    #[test]
    fn the_body_must_be_declared_json() {
        let body = || Ok(Bytes::from_static(b"{}"));
        let mut form = HeaderMap::new();
        form.insert(
            header::CONTENT_TYPE,
            "application/x-www-form-urlencoded".parse().unwrap(),
        );
        for headers in [HeaderMap::new(), form] {
            let e = parse_body::<Value>(&headers, body()).unwrap_err();
            assert_eq!(e.status, StatusCode::UNSUPPORTED_MEDIA_TYPE, "{:?}", e.body);
        }
        let mut problem = HeaderMap::new();
        problem.insert(
            header::CONTENT_TYPE,
            "Application/Merge-Patch+JSON".parse().unwrap(),
        );
        assert!(parse_body::<Value>(&problem, body()).is_ok());
    }
}
