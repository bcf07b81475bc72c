//! Query strings read strictly enough to name the parameter at fault: the extractor [`Query`]
//! reads them into a struct whose options are serde types (enums for a choice of words,
//! numbers for counts), and a value that does not fit its parameter answers 422 with the
//! parameter's name as the path (`limit`, `state`, `format`, …), not a generic `query` — axum's
//! own `Query` answers a plain-text 400 without it.

use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use serde::de::DeserializeOwned;

use super::error::ApiError;

/// The request's query string as `T`; 422 naming the parameter whose value does not fit.
#[derive(Debug, Clone)]
pub struct Query<T>(pub T);

impl<T: DeserializeOwned, S: Send + Sync> FromRequestParts<S> for Query<T> {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Query<T>, ApiError> {
        parse(parts.uri.query()).map(Query)
    }
}

/// `text` (a query string without its `?`) as `T`.
fn parse<T: DeserializeOwned>(text: Option<&str>) -> Result<T, ApiError> {
    let pairs = form_urlencoded::parse(text.unwrap_or_default().as_bytes());
    serde_path_to_error::deserialize(serde_urlencoded::Deserializer::new(pairs)).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." {
            "query".to_string()
        } else {
            path
        };
        ApiError::invalid(path, format!("in the query: {}", e.into_inner()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(rename_all = "snake_case")]
    enum Format {
        Json,
        Csv,
    }

    #[derive(Debug, Deserialize)]
    struct Q {
        limit: Option<usize>,
        offset: Option<usize>,
        format: Option<Format>,
    }

    #[test]
    fn a_bad_value_is_named_by_its_parameter() {
        let q = |s: &str| parse::<Q>(Some(s));
        let good = q("limit=3&offset=1&format=csv").unwrap();
        assert_eq!((good.limit, good.offset), (Some(3), Some(1)));
        assert_eq!(good.format, Some(Format::Csv));
        for (text, parameter) in [
            ("offset=2&limit=abc", "limit"),
            ("limit=-1", "limit"),
            ("format=xml", "format"),
            ("format=JSON", "format"),
        ] {
            let e = q(text).unwrap_err();
            assert_eq!(
                e.body.path.as_deref(),
                Some(parameter),
                "{text}: {:?}",
                e.body
            );
        }
        let e = q("format=xml").unwrap_err();
        assert!(e.body.detail.contains("`json` or `csv`"), "{:?}", e.body);
        assert!(parse::<Q>(None).is_ok());
    }
}
