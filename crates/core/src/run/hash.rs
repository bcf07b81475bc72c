//! The run hash: a stable SHA-256 of everything that determines an evaluation's value — the
//! scene (geometry, data, mesh and solver settings, admissible set) and the requested criteria —
//! and the target error when one is requested (it decides the mesh) —
//! computed on canonical JSON (object keys sorted, numbers in their shortest round-trip form), so
//! it is identical across runs, threads and machines. The search settings (budget, seed, time
//! limit) are left out: they decide which points are visited, not their values, so a log can be
//! resumed with a larger budget.

use serde_json::Value;
use sha2::{Digest, Sha256};

use crate::error::WsmError;
use crate::scene::{CriterionSpec, Scene};

/// Canonical JSON text of a value: keys sorted at every level, no whitespace.
pub fn canonical_json(value: &Value) -> String {
    fn sorted(value: &Value) -> Value {
        match value {
            Value::Object(map) => {
                let mut entries: Vec<(&String, &Value)> = map.iter().collect();
                entries.sort_by(|a, b| a.0.cmp(b.0));
                Value::Object(
                    entries
                        .into_iter()
                        .map(|(k, v)| (k.clone(), sorted(v)))
                        .collect(),
                )
            }
            Value::Array(items) => Value::Array(items.iter().map(sorted).collect()),
            other => other.clone(),
        }
    }
    sorted(value).to_string()
}

/// The run hash of a scene, criteria and target error (64 hex digits). A target error enters
/// the hash because it decides the mesh (`crate::estimate::mesh_choice`); without one the hash is
/// that of the scene and criteria alone.
pub fn run_hash(
    scene: &Scene,
    criteria: &[CriterionSpec],
    target_error: Option<f64>,
) -> Result<String, WsmError> {
    let encode = |e: serde_json::Error| WsmError::io("run hash", e);
    let mut scene = serde_json::to_value(scene).map_err(encode)?;
    if let Value::Object(map) = &mut scene {
        map.remove("search");
    }
    let mut document = serde_json::json!({
        "scene": scene,
        "criteria": serde_json::to_value(criteria).map_err(encode)?,
    });
    if let Some(target) = target_error {
        document["target_error"] = serde_json::json!(target);
    }
    let digest = Sha256::digest(canonical_json(&document).as_bytes());
    Ok(digest.iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Criterion;

    #[test]
    fn canonical_form_ignores_key_order_and_whitespace() {
        let a: Value =
            serde_json::from_str(r#"{"b": [1, {"y": 2, "x": 1.5e10}], "a": null}"#).unwrap();
        let b: Value =
            serde_json::from_str(r#"{"a":null,"b":[1,{"x":15000000000.0,"y":2}]}"#).unwrap();
        assert_eq!(canonical_json(&a), canonical_json(&b));
        assert_eq!(
            canonical_json(&a),
            r#"{"a":null,"b":[1,{"x":15000000000.0,"y":2}]}"#
        );
    }

    #[test]
    fn hash_depends_on_scene_and_criteria_not_on_search_settings() {
        let text = crate::bundled::find("block-on-base").unwrap();
        let scene = crate::scene::parse(text).unwrap();
        let h = run_hash(&scene, &[Criterion::Phi3.into()], None).unwrap();
        assert_eq!(h.len(), 64);
        assert_eq!(
            h,
            run_hash(&scene.clone(), &[Criterion::Phi3.into()], None).unwrap()
        );
        assert_ne!(
            h,
            run_hash(&scene, &[Criterion::Phi5.into()], None).unwrap()
        );
        let mut other = scene.clone();
        other.search.budget = Some(other.search_budget() + 7);
        other.search.seed += 1;
        assert_eq!(
            h,
            run_hash(&other, &[Criterion::Phi3.into()], None).unwrap()
        );
        let mut value: Value = serde_json::from_str(text).unwrap();
        value["materials"]["rock"]["E"] = serde_json::json!(1.1e10);
        let changed = crate::scene::parse(&value.to_string()).unwrap();
        assert_ne!(
            h,
            run_hash(&changed, &[Criterion::Phi3.into()], None).unwrap()
        );
        let targeted = run_hash(&scene, &[Criterion::Phi3.into()], Some(0.01)).unwrap();
        assert_ne!(h, targeted);
        assert_ne!(
            targeted,
            run_hash(&scene, &[Criterion::Phi3.into()], Some(0.001)).unwrap()
        );
    }
}
