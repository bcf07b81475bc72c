//! The JSON Schema of the scene in the API (design §5.2, §5.3): `GET /v1/schema/scene` serves
//! it (open to anyone, like `/openapi.json`), and the OpenAPI document carries it as
//! components — the root as `Scene`, each of its `$defs` as `Scene.<name>` — so the scene of a
//! submission, of an example and of a job refers to it ([`SceneDocument`]).

use std::borrow::Cow;

use axum::Json;
use serde_json::Value;
use utoipa::openapi::{RefOr, Schema};

/// The component name of the scene's root schema.
const SCENE: &str = "Scene";

/// A scene document: in the OpenAPI document, a reference to the `Scene` component, which
/// [`with_scene_components`] fills with the scene's JSON Schema.
pub struct SceneDocument;

impl utoipa::PartialSchema for SceneDocument {
    fn schema() -> RefOr<Schema> {
        utoipa::openapi::Ref::from_schema_name(SCENE).into()
    }
}

impl utoipa::ToSchema for SceneDocument {
    fn name() -> Cow<'static, str> {
        SCENE.into()
    }
}

/// The JSON Schema (2020-12) of the scene document.
#[utoipa::path(get, path = "/v1/schema/scene", tag = "schema",
    responses((status = 200, description = "The JSON Schema (2020-12) of the scene document: \
        what `wsm schema` prints and openapi/scene.schema.json holds", body = Object)))]
pub async fn scene_schema() -> Json<Value> {
    Json(wsm_core::scene_schema())
}

/// `document` (an OpenAPI document) with the scene's JSON Schema as its components `Scene` and
/// `Scene.<name>`, the schema's references (`#/$defs/<name>`) rewritten to them.
pub fn with_scene_components(mut document: Value) -> Value {
    let mut root = wsm_core::scene_schema();
    let defs = root
        .as_object_mut()
        .and_then(|root| {
            // The dialect is the document's own (OpenAPI 3.1: JSON Schema 2020-12).
            root.remove("$schema");
            root.remove("$defs")
        })
        .unwrap_or_default();
    let mut components = vec![(SCENE.to_string(), root)];
    if let Value::Object(defs) = defs {
        components.extend(
            defs.into_iter()
                .map(|(name, def)| (format!("{SCENE}.{name}"), def)),
        );
    }
    let schemas = &mut document["components"]["schemas"];
    for (name, mut schema) in components {
        rewrite_refs(&mut schema);
        schemas[name] = schema;
    }
    document
}

/// Point every `"$ref": "#/$defs/<name>"` in `schema` at the component `Scene.<name>`.
fn rewrite_refs(schema: &mut Value) {
    match schema {
        Value::Object(members) => {
            for (key, member) in members.iter_mut() {
                match (key.as_str(), &member) {
                    ("$ref", Value::String(target)) => {
                        if let Some(name) = target.strip_prefix("#/$defs/") {
                            *member = format!("#/components/schemas/{SCENE}.{name}").into();
                        }
                    }
                    _ => rewrite_refs(member),
                }
            }
        }
        Value::Array(items) => items.iter_mut().for_each(rewrite_refs),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every reference of the scene components resolves to a component of the document.
    #[test]
    fn scene_components_refer_to_components() {
        let document = with_scene_components(serde_json::json!({"components": {"schemas": {}}}));
        let schemas = document["components"]["schemas"].as_object().unwrap();
        assert!(schemas.contains_key("Scene") && schemas.contains_key("Scene.Body"));
        let text = serde_json::to_string(&document).unwrap();
        assert!(
            !text.contains("#/$defs/"),
            "a reference was left unrewritten"
        );
        let mut targets = Vec::new();
        collect_refs(&document, &mut targets);
        assert!(!targets.is_empty());
        for target in targets {
            let name = target.strip_prefix("#/components/schemas/").unwrap();
            assert!(schemas.contains_key(name), "{target} does not resolve");
        }
    }

    fn collect_refs(value: &Value, into: &mut Vec<String>) {
        match value {
            Value::Object(members) => {
                for (key, member) in members {
                    match (key.as_str(), member) {
                        ("$ref", Value::String(t)) => into.push(t.clone()),
                        _ => collect_refs(member, into),
                    }
                }
            }
            Value::Array(items) => items.iter().for_each(|i| collect_refs(i, into)),
            _ => {}
        }
    }
}
