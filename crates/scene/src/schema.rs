//! The JSON Schema of the scene document (design §5.2, "JSON Schema of the scene"), derived
//! from the serde model by schemars in the JSON Schema 2020-12 dialect (the one OpenAPI 3.1
//! uses). The doc comments of the model become its descriptions; where the reader is written by
//! hand (a criterion's two forms, the slip limit refusing unknown members) the schema is too,
//! next to the reader in `model`. A new section of the model (a struct deriving `JsonSchema`)
//! enters the schema by itself.
//!
//! The command line prints it (`wsm schema`), the service serves it (`GET /v1/schema/scene`)
//! and its OpenAPI document refers to it; `openapi/scene.schema.json` is the checked-in copy.

use schemars::generate::SchemaSettings;

use super::Scene;

/// The dialect the schema declares in its `"$schema"`: JSON Schema 2020-12.
pub const SCENE_SCHEMA_DIALECT: &str = "https://json-schema.org/draft/2020-12/schema";

/// The JSON Schema of the scene document: the root describes a [`Scene`], the types it uses are
/// in `$defs`.
pub fn scene_schema() -> serde_json::Value {
    let mut settings = SchemaSettings::draft2020_12();
    settings.meta_schema = Some(SCENE_SCHEMA_DIALECT.into());
    let mut schema = settings.into_generator().into_root_schema_for::<Scene>();
    schema.insert("title".into(), "wsm scene".into());
    let mut schema = schema.to_value();
    plain_descriptions(&mut schema);
    schema
}

/// Every `description` in `schema` as an editor shows it: rustdoc's escaped brackets (`\[Pa\]`)
/// plain, the lines of a paragraph joined (paragraphs stay apart).
fn plain_descriptions(schema: &mut serde_json::Value) {
    match schema {
        serde_json::Value::Object(members) => {
            for (key, member) in members.iter_mut() {
                match (key.as_str(), &member) {
                    ("description", serde_json::Value::String(text)) => {
                        let text = text.replace("\\[", "[").replace("\\]", "]");
                        let paragraphs: Vec<String> = text
                            .split("\n\n")
                            .map(|p| p.split('\n').map(str::trim).collect::<Vec<_>>().join(" "))
                            .collect();
                        *member = paragraphs.join("\n\n").into();
                    }
                    _ => plain_descriptions(member),
                }
            }
        }
        serde_json::Value::Array(items) => items.iter_mut().for_each(plain_descriptions),
        _ => {}
    }
}

/// [`scene_schema`] as pretty JSON with a final newline: what `wsm schema` prints and
/// `openapi/scene.schema.json` holds.
pub fn scene_schema_json() -> String {
    let mut text = serde_json::to_string_pretty(&scene_schema()).expect("a JSON value prints");
    text.push('\n');
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::Value;

    #[test]
    fn the_schema_declares_draft_2020_12_and_plain_descriptions() {
        let schema = scene_schema();
        assert_eq!(schema["$schema"], SCENE_SCHEMA_DIALECT);
        assert_eq!(schema["type"], "object");
        assert!(schema["$defs"]["Material"].is_object());
        let e = schema["$defs"]["Material"]["properties"]["E"]["description"]
            .as_str()
            .unwrap();
        assert!(
            e.contains("[Pa]") && !e.contains('\\') && !e.contains('\n'),
            "{e}"
        );
        assert!(scene_schema_json().ends_with("}\n"));
    }

    /// The reader refuses unknown keys in every object of the scene (`deny_unknown_fields`, the
    /// slip limit by hand), so every object schema must be closed: a misspelt key is an error
    /// in an editor as it is in `wsm`. Maps keyed by name (`materials`, `segments`) are the
    /// only objects whose keys are free.
    #[test]
    fn every_object_with_named_members_is_closed() {
        fn walk(schema: &Value, path: &str, open: &mut Vec<String>) {
            match schema {
                Value::Object(members) => {
                    if members.contains_key("properties")
                        && members.get("additionalProperties") != Some(&Value::Bool(false))
                    {
                        open.push(path.to_string());
                    }
                    for (key, member) in members {
                        walk(member, &format!("{path}/{key}"), open);
                    }
                }
                Value::Array(items) => {
                    for (i, item) in items.iter().enumerate() {
                        walk(item, &format!("{path}/{i}"), open);
                    }
                }
                _ => {}
            }
        }
        let mut open = Vec::new();
        walk(&scene_schema(), "#", &mut open);
        assert!(open.is_empty(), "objects accepting unknown keys: {open:?}");
    }

    #[test]
    fn the_schema_key_is_accepted_and_ignored() {
        let schema = scene_schema();
        assert_eq!(schema["properties"]["$schema"]["type"][0], "string");
        let scene: Scene = serde_json::from_value(serde_json::json!({
            "$schema": "scene.schema.json", "version": 1, "bodies": [], "materials": {},
            "mesh": {"max_size": 1.0}
        }))
        .unwrap();
        let written = serde_json::to_value(&scene).unwrap();
        assert!(written.get("$schema").is_none(), "{written}");
    }
}
