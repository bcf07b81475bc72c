//! Query strings read strictly enough to name the parameter at fault: a value that does not
//! fit its parameter answers 422 with the parameter's name as the path (`limit`, `state`, …),
//! not a generic `query`.

use axum::extract::RawQuery;
use serde::de::DeserializeOwned;

use super::error::ApiError;

/// The query string as `T`; 422 naming the parameter whose value does not fit.
pub fn parse<T: DeserializeOwned>(RawQuery(query): RawQuery) -> Result<T, ApiError> {
    let text = query.unwrap_or_default();
    let pairs = form_urlencoded::parse(text.as_bytes());
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

    #[derive(Debug, Deserialize)]
    struct Q {
        limit: Option<usize>,
        offset: Option<usize>,
    }

    #[test]
    fn a_bad_value_is_named_by_its_parameter() {
        let q = |s: &str| parse::<Q>(RawQuery(Some(s.to_string())));
        let good = q("limit=3&offset=1").unwrap();
        assert_eq!((good.limit, good.offset), (Some(3), Some(1)));
        let e = q("offset=2&limit=abc").unwrap_err();
        assert_eq!(e.body.path.as_deref(), Some("limit"), "{:?}", e.body);
        let e = q("limit=-1").unwrap_err();
        assert_eq!(e.body.path.as_deref(), Some("limit"), "{:?}", e.body);
        assert!(parse::<Q>(RawQuery(None)).is_ok());
    }
}
