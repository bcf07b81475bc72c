//! The shape of a JSON document against its serde model (design §5.2): objects only where the
//! model has an object, and serde's messages in plain words.
//!
//! serde's derived structs also read a JSON array, by position (`"rock": [1e10, 0.25]` would be
//! E and ν). [`objects_where_objects`] refuses that for any model: it writes the parsed model back
//! to JSON — where the model has an object, the written document has one — and compares it with
//! the document as given, naming the first array that stands where an object belongs; when serde
//! fails inside such an array, [`array_read_as_object`] names the array instead of its item.
//! [`plain_message`] rewrites serde's messages, which name Rust types (`expected struct
//! Material`, `expected f64`), into the JSON words a user reads (`expected an object`, `expected
//! a number`). The scene parser, the service's request bodies and the command line use both.

use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::Value;

use super::SceneError;

/// Refuse an array given where the model `typed` (parsed from `given`) has an object; the error
/// names the array's JSON path (`$` for the root).
pub fn objects_where_objects<T: Serialize>(given: &Value, typed: &T) -> Result<(), SceneError> {
    let written = serde_json::to_value(typed)
        .map_err(|e| SceneError::new("$", plain_message(&e.to_string())))?;
    compare(given, &written, &mut String::new())
}

/// The array given where the model wants an object, when serde failed inside it (reading the
/// array by position, `["top", null]` as a boundary condition fails at its second item): the
/// deepest array on the error's `path` is replaced by `{}` and the document read again — unless
/// serde then says it wanted something other than an object there (a list, a matrix), the array
/// stands where an object belongs and is named.
pub fn array_read_as_object<T: DeserializeOwned>(
    given: &Value,
    path: &serde_path_to_error::Path,
) -> Option<SceneError> {
    let mut node = given;
    let mut deepest = None;
    let mut written = String::new();
    let mut pointer = String::new();
    for segment in path.iter() {
        if node.is_array() {
            deepest = Some((pointer.clone(), written.clone()));
        }
        let next = match segment {
            serde_path_to_error::Segment::Seq { index } => {
                written.push_str(&format!("[{index}]"));
                pointer.push_str(&format!("/{index}"));
                node.get(*index)
            }
            serde_path_to_error::Segment::Map { key } => {
                if !written.is_empty() {
                    written.push('.');
                }
                written.push_str(key);
                pointer.push_str(&format!("/{}", key.replace('~', "~0").replace('/', "~1")));
                node.get(key)
            }
            _ => None,
        };
        node = next?;
    }
    if node.is_array() {
        deepest = Some((pointer, written));
    }
    let (pointer, written) = deepest?;
    let mut probe = given.clone();
    *probe.pointer_mut(&pointer)? = Value::Object(serde_json::Map::new());
    let wants_something_else = match serde_path_to_error::deserialize::<_, T>(probe) {
        Ok(_) => false,
        Err(e) => {
            e.path().to_string().trim_start_matches('.') == written
                && e.inner().to_string().starts_with("invalid type: map")
        }
    };
    (!wants_something_else).then(|| {
        SceneError::new(
            if written.is_empty() {
                "$".to_string()
            } else {
                written
            },
            "expected an object (with named members), got an array",
        )
    })
}

fn compare(given: &Value, written: &Value, path: &mut String) -> Result<(), SceneError> {
    match (given, written) {
        (Value::Array(_), Value::Object(_)) => Err(SceneError::new(
            if path.is_empty() { "$" } else { path.as_str() },
            "expected an object (with named members), got an array",
        )),
        (Value::Object(given), Value::Object(written)) => {
            for (key, member) in written {
                if let Some(given) = given.get(key) {
                    let len = path.len();
                    if !path.is_empty() {
                        path.push('.');
                    }
                    path.push_str(key);
                    compare(given, member, path)?;
                    path.truncate(len);
                }
            }
            Ok(())
        }
        (Value::Array(given), Value::Array(written)) => {
            for (i, (given, item)) in given.iter().zip(written).enumerate() {
                let len = path.len();
                path.push_str(&format!("[{i}]"));
                compare(given, item, path)?;
                path.truncate(len);
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// A serde (or serde_json) message in JSON words: `invalid type: sequence, expected struct
/// Material` → `expected an object, got an array`; the position serde_json adds (` at line L
/// column C`) is kept. Messages that name no type (unknown or missing fields, unknown variants,
/// the wording of custom checks) pass unchanged.
pub fn plain_message(message: &str) -> String {
    let (message, position) = match message.find(" at line ") {
        Some(at) => message.split_at(at),
        None => (message, ""),
    };
    if message.starts_with("data did not match any variant of untagged enum ") {
        return format!("not one of the forms this field accepts{position}");
    }
    let Some((head, expected)) = message.split_once(", expected ") else {
        return format!("{message}{position}");
    };
    let got = if let Some(unexpected) = head.strip_prefix("invalid type: ") {
        plain_unexpected(unexpected)
    } else if let Some(unexpected) = head.strip_prefix("invalid value: ") {
        plain_unexpected(unexpected)
    } else if let Some(length) = head.strip_prefix("invalid length ") {
        format!("{length} items")
    } else {
        // `unknown field …, expected one of …` and the like: already in the user's words.
        return format!("{message}{position}");
    };
    format!("expected {}, got {got}{position}", plain_expected(expected))
}

/// What serde expected, in JSON words.
fn plain_expected(expected: &str) -> String {
    let word = expected.split_whitespace().next().unwrap_or("");
    let plain = match (word, expected) {
        ("struct", _) | (_, "a map") => "an object",
        ("tuple", _) | (_, "a sequence") => "an array",
        ("enum", _) => "one of the names this field accepts (a string)",
        ("f32" | "f64", _) => "a number",
        ("u8" | "u16" | "u32" | "u64" | "u128" | "usize", _) => "a non-negative whole number",
        ("i8" | "i16" | "i32" | "i64" | "i128" | "isize", _) => "a whole number",
        ("option", _) => "a value or null",
        ("unit", _) => "null",
        ("char", _) => "a single character",
        (_, "a borrowed string") => "a string",
        _ => expected,
    };
    plain.to_string()
}

/// What serde found, in JSON words.
fn plain_unexpected(unexpected: &str) -> String {
    match unexpected {
        "sequence" => "an array".to_string(),
        "map" => "an object".to_string(),
        "unit value" | "null" => "null".to_string(),
        other => other
            .strip_prefix("floating point ")
            .or_else(|| other.strip_prefix("integer "))
            .map(|n| format!("the number {}", n.trim_matches('`')))
            .or_else(|| {
                other
                    .strip_prefix("boolean ")
                    .map(|b| b.trim_matches('`').to_string())
            })
            .or_else(|| {
                other
                    .strip_prefix("string ")
                    .map(|s| format!("the string {s}"))
            })
            .unwrap_or_else(|| other.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Serialize, Deserialize)]
    struct Inner {
        #[serde(default)]
        a: Option<f64>,
        #[serde(default)]
        b: Option<f64>,
    }

    #[derive(Debug, Serialize, Deserialize)]
    struct Outer {
        items: Vec<Inner>,
        #[serde(default)]
        count: u32,
    }

    fn refusal(text: &str) -> Result<(), SceneError> {
        let given: Value = serde_json::from_str(text).unwrap();
        let typed: Outer = serde_json::from_value(given.clone()).unwrap();
        objects_where_objects(&given, &typed)
    }

    #[test]
    fn an_array_read_as_a_struct_is_named() {
        // serde itself reads the array by position: the check is what refuses it.
        let e = refusal(r#"{"items": [{"a": 1}, [1, 2]]}"#).unwrap_err();
        assert_eq!(e.path, "items[1]");
        assert!(e.reason.contains("expected an object"), "{e}");
        assert_eq!(refusal("[[[1]], 0]").unwrap_err().path, "$");
        assert!(refusal(r#"{"items": [{"a": 1, "b": 2}], "count": 3}"#).is_ok());
    }

    #[test]
    fn messages_name_json_kinds_not_rust_types() {
        let cases = [
            (
                "invalid type: sequence, expected struct Material",
                "expected an object, got an array",
            ),
            (
                "invalid type: map, expected u64",
                "expected a non-negative whole number, got an object",
            ),
            (
                "invalid type: string \"x\", expected f64 at line 1 column 9",
                "expected a number, got the string \"x\" at line 1 column 9",
            ),
            (
                "invalid length 1, expected struct WorstRequest with 10 elements",
                "expected an object, got 1 items",
            ),
            (
                "invalid type: floating point `1.5`, expected a sequence",
                "expected an array, got the number 1.5",
            ),
            (
                "data did not match any variant of untagged enum Conductivity",
                "not one of the forms this field accepts",
            ),
            ("missing field `bodies`", "missing field `bodies`"),
        ];
        for (serde, plain) in cases {
            assert_eq!(plain_message(serde), plain, "{serde}");
        }
    }

    #[test]
    fn real_serde_messages_lose_their_type_names() {
        let bad = [
            r#"{"items": 5}"#,
            r#"{"items": [5]}"#,
            r#"{"items": [], "count": {}}"#,
            r#"{"items": [], "count": -1}"#,
            r#"{"items": [{"a": "x"}]}"#,
            r#"[]"#,
            r#"7"#,
        ];
        for text in bad {
            let e = serde_json::from_str::<Outer>(text).unwrap_err().to_string();
            let plain = plain_message(&e);
            for name in ["Outer", "Inner", "struct", "u32", "f64", "sequence", "map"] {
                assert!(!plain.contains(name), "{text}: {e} → {plain}");
            }
        }
    }
}
