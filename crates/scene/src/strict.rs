//! Reading JSON strictly: no object may repeat a key. `serde_json` silently keeps the last of a
//! repeated key, so a scene file with two `"E"` in one material would run with the second; the
//! scene reader ([`super::parse`], which the command line uses) and the service's request bodies
//! both read through [`strict_value`] and refuse it, naming the key's JSON path.

use std::fmt;

use serde::de::{self, Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Value};

/// Why [`strict_value`] refused a text.
#[derive(Debug, Clone, PartialEq)]
pub enum StrictError {
    /// Not JSON.
    Syntax {
        /// JSON path reached when the parser failed (`$` at the root).
        path: String,
        /// The parser's message (with line and column).
        message: String,
    },
    /// An object repeats a key.
    RepeatedKey {
        /// JSON path of the repeated key (`settings.budget`, `bodies[0].name`).
        path: String,
        /// The key.
        key: String,
    },
}

impl StrictError {
    /// The JSON path of the error.
    pub fn path(&self) -> &str {
        match self {
            StrictError::Syntax { path, .. } | StrictError::RepeatedKey { path, .. } => path,
        }
    }

    /// Why the text was refused: the parser's message, or that the key appears more than once.
    pub fn reason(&self) -> String {
        match self {
            StrictError::Syntax { message, .. } => message.clone(),
            StrictError::RepeatedKey { key, .. } => {
                format!("the key '{key}' appears more than once in its object")
            }
        }
    }
}

/// The next JSON value of `de` (trailing text is left to the caller: `de.end()`), refused when
/// it is not JSON or when one of its objects repeats a key.
pub fn strict_value<'de, R: serde_json::de::Read<'de>>(
    de: &mut serde_json::Deserializer<R>,
) -> Result<Value, StrictError> {
    let Strict(value) = serde_path_to_error::deserialize(de).map_err(|e| {
        let message = e.inner().to_string();
        let parent = e.path().to_string();
        let parent = if parent == "." { "" } else { parent.as_str() };
        match message.strip_prefix(REPEATED) {
            Some(rest) => {
                let key = rest.split('\'').next().unwrap_or("").to_string();
                StrictError::RepeatedKey {
                    path: join(parent, &key),
                    key,
                }
            }
            None => StrictError::Syntax {
                path: if parent.is_empty() { "$" } else { parent }.to_string(),
                message,
            },
        }
    })?;
    Ok(value)
}

/// `bodies[0]` + `name` → `bodies[0].name`; the root's keys stand alone.
fn join(parent: &str, key: &str) -> String {
    match (parent.is_empty(), key) {
        (true, _) => key.to_string(),
        (false, "$" | "") => parent.to_string(),
        (false, k) if k.starts_with('[') => format!("{parent}{k}"),
        (false, k) => format!("{parent}.{k}"),
    }
}

/// The start of the error a repeated key raises (recognised by [`strict_value`]).
const REPEATED: &str = "repeated key '";

/// A JSON value whose objects have no repeated keys.
struct Strict(Value);

impl<'de> Deserialize<'de> for Strict {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Strict, D::Error> {
        deserializer.deserialize_any(StrictVisitor).map(Strict)
    }
}

struct StrictVisitor;

impl<'de> Visitor<'de> for StrictVisitor {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }

    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(Value::from(v))
    }

    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(Value::from(v))
    }

    fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
        Ok(Value::from(v))
    }

    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_string()))
    }

    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }

    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut items = Vec::new();
        while let Some(Strict(item)) = seq.next_element()? {
            items.push(item);
        }
        Ok(Value::Array(items))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut members = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            if members.contains_key(&key) {
                return Err(de::Error::custom(format!("{REPEATED}{key}'")));
            }
            let Strict(value) = map.next_value()?;
            members.insert(key, value);
        }
        Ok(Value::Object(members))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Value, StrictError> {
        strict_value(&mut serde_json::Deserializer::from_str(text))
    }

    #[test]
    fn a_repeated_key_is_named_with_its_path() {
        let e = read(r#"{"mesh": {"max_size": 1, "max_size": 2}}"#).unwrap_err();
        assert_eq!(e.path(), "mesh.max_size");
        assert_eq!(
            e.reason(),
            "the key 'max_size' appears more than once in its object"
        );
        assert_eq!(read(r#"{"a": 1, "a": 1}"#).unwrap_err().path(), "a");
        let e = read(r#"{"bodies": [{"name": "x", "name": "y"}]}"#).unwrap_err();
        assert_eq!(e.path(), "bodies[0].name");
    }

    #[test]
    fn values_are_those_serde_json_reads() {
        let text = r#"{"x": [1, -2, 0.1, 1e-300, 18446744073709551615, true, null, "s", {}]}"#;
        assert_eq!(
            read(text).unwrap(),
            serde_json::from_str::<Value>(text).unwrap()
        );
        let e = read(r#"{"x": [1, }"#).unwrap_err();
        assert!(matches!(e, StrictError::Syntax { .. }), "{e:?}");
        assert_eq!(e.path(), "x[1]");
    }
}
