//! The display names of the enums the API answers with (design §5.3) — criteria, run phases,
//! the derivatives' verdicts, job states, warning kinds and error codes — served once at
//! `GET /v1/labels`, so that the dashboard (and any client) shows them without a copy of the
//! tables. Each map is keyed by the value's JSON name.

use std::collections::BTreeMap;

use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::error_code::ErrorCode;
use crate::jobs::JobState;
use wsm_core::{Criterion, RunPhase, Verdict, WarningKind};

/// A criterion Φ1–Φ6 for a person: `{symbol}` is the mean `{quantity}` over `{over}` in
/// `{unit}`; bound to one region, the region's name takes the place of `over`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct CriterionLabel {
    /// Its symbol (`Φ3`).
    pub symbol: &'static str,
    /// What it is the mean of (`mean normal displacement`).
    pub quantity: &'static str,
    /// Where, when bound to no region: `a region` or `a boundary piece`.
    pub over: &'static str,
    /// The SI unit of its value.
    pub unit: &'static str,
}

/// The display names, each map keyed by the value's JSON name.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct Labels {
    /// The criteria `phi1` … `phi6` (a name that is none of them is a criterion the scene
    /// defines, in Pa).
    pub criteria: BTreeMap<String, CriterionLabel>,
    /// The phases of a run ([`RunPhase`]).
    pub phases: BTreeMap<String, &'static str>,
    /// What the exact derivatives prove about an extremum ([`Verdict`]).
    pub verdicts: BTreeMap<String, &'static str>,
    /// The states of a job ([`JobState`]).
    pub states: BTreeMap<String, &'static str>,
    /// What a warning is about ([`WarningKind`]).
    pub warning_kinds: BTreeMap<String, &'static str>,
    /// The error codes of answers and failed jobs ([`ErrorCode`]).
    pub error_codes: BTreeMap<String, &'static str>,
}

/// The display names of criteria, phases, verdicts, job states, warning kinds and error codes.
#[utoipa::path(get, path = "/v1/labels", tag = "labels",
    responses((status = 200, body = Labels)))]
pub async fn labels() -> Json<Labels> {
    Json(Labels::new())
}

impl Labels {
    /// Every variant of every labelled enum with its label.
    pub fn new() -> Labels {
        Labels {
            criteria: keyed(Criterion::ALL.map(|c| (c, criterion_label(c)))),
            phases: keyed(PHASES.map(|p| (p, phase_label(p)))),
            verdicts: keyed(VERDICTS.map(|v| (v, verdict_label(v)))),
            states: keyed(JobState::ALL.map(|s| (s, s.as_str()))),
            warning_kinds: keyed(WARNING_KINDS.map(|k| (k, warning_label(k)))),
            error_codes: keyed(ErrorCode::ALL.map(|c| (c, c.label()))),
        }
    }
}

impl Default for Labels {
    fn default() -> Labels {
        Labels::new()
    }
}

/// `(value, label)` pairs as a map from the value's JSON name.
fn keyed<T: Serialize, L>(pairs: impl IntoIterator<Item = (T, L)>) -> BTreeMap<String, L> {
    pairs
        .into_iter()
        .map(|(value, label)| (json_name(&value), label))
        .collect()
}

/// A unit variant's JSON name (`mesh_choice`).
fn json_name<T: Serialize>(value: &T) -> String {
    match serde_json::to_value(value) {
        Ok(serde_json::Value::String(name)) => name,
        other => unreachable!("a labelled enum serialises as a string, not {other:?}"),
    }
}

fn criterion_label(c: Criterion) -> CriterionLabel {
    let (quantity, over) = match c {
        Criterion::Phi1 => ("mean temperature", "a region"),
        Criterion::Phi2 => ("mean temperature", "a boundary piece"),
        Criterion::Phi3 => ("mean normal displacement", "a region"),
        Criterion::Phi4 => ("mean normal displacement", "a boundary piece"),
        Criterion::Phi5 => ("mean I2² (shear-stress intensity)", "a region"),
        Criterion::Phi6 => ("mean normal pressure −τn", "a region"),
        Criterion::Defined => ("mean of a quantity defined in the scene", "a region"),
    };
    CriterionLabel {
        symbol: c.symbol(),
        quantity,
        over,
        unit: c.unit(),
    }
}

/// Every run phase, in a run's order.
const PHASES: [RunPhase; 14] = [
    RunPhase::Queued,
    RunPhase::MeshChoice,
    RunPhase::Meshing,
    RunPhase::AdmissibleCheck,
    RunPhase::NominalSolve,
    RunPhase::VertexWalk,
    RunPhase::Screening,
    RunPhase::Swarm,
    RunPhase::Polish,
    RunPhase::Sensitivities,
    RunPhase::Multistart,
    RunPhase::Accuracy,
    RunPhase::TimeSteps,
    RunPhase::Finished,
];

fn phase_label(phase: RunPhase) -> &'static str {
    match phase {
        RunPhase::Queued => "queued",
        RunPhase::MeshChoice => "choosing the mesh for the target error",
        RunPhase::Meshing => "meshing",
        RunPhase::AdmissibleCheck => "checking the admissible set",
        RunPhase::NominalSolve => "nominal solve",
        RunPhase::VertexWalk => "vertex walk (gradients)",
        RunPhase::Screening => "screening vertices",
        RunPhase::Swarm => "swarm search",
        RunPhase::Polish => "polishing",
        RunPhase::Sensitivities => "sensitivities",
        RunPhase::Multistart => "looking for other local optima",
        RunPhase::Accuracy => "accuracy statement",
        RunPhase::TimeSteps => "time steps",
        RunPhase::Finished => "finished",
    }
}

/// Every verdict of the derivatives.
const VERDICTS: [Verdict; 3] = [
    Verdict::LocallyCertified,
    Verdict::NotOptimal,
    Verdict::NoDerivatives,
];

fn verdict_label(verdict: Verdict) -> &'static str {
    match verdict {
        Verdict::LocallyCertified => "locally certified",
        Verdict::NotOptimal => "not proven optimal",
        Verdict::NoDerivatives => "no derivatives",
    }
}

/// Every warning kind.
const WARNING_KINDS: [WarningKind; 12] = [
    WarningKind::DataPath,
    WarningKind::Units,
    WarningKind::Locking,
    WarningKind::RigidMotion,
    WarningKind::Sensitivities,
    WarningKind::SolverFallback,
    WarningKind::Derivatives,
    WarningKind::FailedEvaluations,
    WarningKind::Unproven,
    WarningKind::Accuracy,
    WarningKind::TargetError,
    WarningKind::Legacy,
];

fn warning_label(kind: WarningKind) -> &'static str {
    match kind {
        WarningKind::DataPath => "uncertain datum addressed by index",
        WarningKind::Units => "units",
        WarningKind::Locking => "locking",
        WarningKind::RigidMotion => "rigid motion",
        WarningKind::Sensitivities => "sensitivities",
        WarningKind::SolverFallback => "solver fallback",
        WarningKind::Derivatives => "derivatives",
        WarningKind::FailedEvaluations => "failed evaluations",
        WarningKind::Unproven => "unproven extremum",
        WarningKind::Accuracy => "accuracy statement",
        WarningKind::TargetError => "target error",
        WarningKind::Legacy => "warning",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each map has a non-empty label for every value the OpenAPI document lists for its enum
    /// (so a variant added to an enum without a label fails here), and no other key.
    #[test]
    fn every_variant_of_every_labelled_enum_has_a_label() {
        let document: serde_json::Value =
            serde_json::from_str(&super::super::openapi_json().unwrap()).unwrap();
        let labels = serde_json::to_value(Labels::new()).unwrap();
        let schemas = &document["components"]["schemas"];
        for (field, schema) in [
            ("phases", "RunPhase"),
            ("verdicts", "Verdict"),
            ("states", "JobState"),
            ("warning_kinds", "WarningKind"),
            ("error_codes", "ErrorCode"),
        ] {
            let mut variants: Vec<&str> = schemas[schema]["enum"]
                .as_array()
                .unwrap_or_else(|| panic!("{schema} is an enum of the document"))
                .iter()
                .map(|v| v.as_str().unwrap())
                .collect();
            variants.sort_unstable();
            let map = labels[field].as_object().unwrap();
            let keys: Vec<&str> = map.keys().map(String::as_str).collect();
            assert_eq!(keys, variants, "{field}");
            assert!(
                map.values().all(|l| !l.as_str().unwrap().is_empty()),
                "{field}"
            );
        }
        let criteria = labels["criteria"].as_object().unwrap();
        let names: Vec<&str> = criteria.keys().map(String::as_str).collect();
        assert_eq!(names, ["phi1", "phi2", "phi3", "phi4", "phi5", "phi6"]);
        assert_eq!(criteria["phi5"]["symbol"], "Φ5");
        assert_eq!(criteria["phi5"]["unit"], "Pa²");
    }
}
