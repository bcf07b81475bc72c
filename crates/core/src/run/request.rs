//! What a caller asks of a run, as plain serde types: a single solve, or a worst-scenario search
//! with settings that override the scene's `search` block. Each request is checked against the
//! scene; a bad value is a [`SceneError`] naming the request field.

use serde::{Deserialize, Serialize};

use crate::error::WsmError;
use crate::estimate::mesh_choice::check_target;
use crate::scenario::worst::WorstSettings;
use crate::scene::{check_criteria_list, CriterionSpec, Scene, SceneError, SolverKind, StopRule};

/// A single state solve.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SolveRequest {
    /// Inner solver (default: the scene's `solver.kind`).
    #[serde(default)]
    pub solver: Option<SolverKind>,
    /// Also return the nodal and element fields.
    #[serde(default)]
    pub fields: bool,
    /// Also return a dynamic scene's nodal displacement at every output time (`frames`, design
    /// §3.5); refused on a static scene.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub frames: bool,
}

impl SolveRequest {
    /// Refuse what `scene` cannot answer: `frames` of a static scene (named `frames`).
    pub fn check(&self, scene: &Scene) -> Result<(), WsmError> {
        if self.frames && scene.dynamics.is_none() {
            return Err(SceneError::new(
                "frames",
                "the scene has no `dynamics`: a static solve has no frames over time",
            )
            .into());
        }
        Ok(())
    }
}

/// A worst-scenario search. Every field left out takes the scene's `search` value.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct WorstRequest {
    /// Criteria to maximise and minimise: `phi1` … `phi6`, or bound to one region as
    /// `phi3@NAME`.
    #[serde(default)]
    pub criteria: Option<Vec<CriterionSpec>>,
    /// Inner solves at most (≥ 1).
    #[serde(default)]
    pub budget: Option<usize>,
    /// Seed of every random choice of the search.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Wall-time limit of the whole run, meshing included \[s\] (> 0).
    #[serde(default)]
    pub max_seconds: Option<f64>,
    /// Threads of the run's own pool (default: rayon's global pool).
    #[serde(default)]
    pub threads: Option<usize>,
    /// Refined meshes of the accuracy statement (0, 1 or 2; default: 2 for small meshes, else
    /// 1 — see the outcome's `accuracy`). An imported Gmsh mesh is not refined: by default its
    /// statement says so, and 1 or 2 are refused.
    #[serde(default)]
    pub accuracy_refinements: Option<usize>,
    /// Relative error (0 < REL < 1) the run's mesh must meet: the run takes the coarsest mesh of
    /// a ladder (the scene's mesh sizes × 4, 2, 1, 1/2, …) whose estimated error of every
    /// criterion at the nominal data is within it (see the outcome's `mesh_choice`).
    #[serde(default)]
    pub target_error: Option<f64>,
    /// Exact derivatives on every evaluation (default: the scene's `search.derivatives`, true):
    /// they drive the vertex walk and the quasi-Newton polish and certify every extremum.
    /// `false` searches without them (finite-difference sensitivities, no certificates).
    #[serde(default)]
    pub derivatives: Option<bool>,
    /// When the search may stop before its budget is spent (default: the scene's `search.stop`,
    /// `global_rule`): `global_rule`, `first_certificate` or `budget`.
    #[serde(default)]
    pub stop: Option<StopRule>,
}

impl WorstRequest {
    /// The settings of the run on `scene`, checked. Errors name the request field
    /// (`criteria[1]`, `budget`, …), or the scene's own search block (`search.criteria[0]`) when
    /// its criteria are used and one is wrong; without criteria in either, the request's
    /// `criteria` (what the caller adds).
    pub fn settings(&self, scene: &Scene) -> Result<WorstSettings, WsmError> {
        let mut settings = WorstSettings::from_scene(scene);
        match &self.criteria {
            Some(criteria) if criteria.is_empty() => {
                return Err(SceneError::new("criteria", "give at least one criterion").into());
            }
            Some(criteria) => {
                check_criteria_list(scene, criteria, "criteria")?;
                settings.criteria = criteria.clone();
            }
            None => check_criteria_list(scene, &settings.criteria, "search.criteria")?,
        }
        if let Some(budget) = self.budget {
            if budget == 0 {
                return Err(SceneError::new("budget", "must be at least 1").into());
            }
            settings.budget = budget;
        }
        if let Some(seed) = self.seed {
            settings.seed = seed;
        }
        if let Some(limit) = self.max_seconds {
            if !(limit.is_finite() && limit > 0.0) {
                return Err(SceneError::new(
                    "max_seconds",
                    format!("must be a positive number of seconds (got {limit})"),
                )
                .into());
            }
            settings.max_seconds = Some(limit);
        }
        if let Some(r) = self.accuracy_refinements {
            if r > 2 {
                return Err(SceneError::new(
                    "accuracy_refinements",
                    format!("0, 1 or 2 refined meshes (got {r})"),
                )
                .into());
            }
            settings.accuracy_refinements = Some(r);
        }
        if let Some(target) = self.target_error {
            check_target(scene, target)?;
            settings.target_error = Some(target);
        }
        if let Some(derivatives) = self.derivatives {
            settings.derivatives = derivatives;
        }
        if let Some(stop) = self.stop {
            settings.stop = stop;
        }
        if self.threads == Some(0) {
            return Err(SceneError::new("threads", "must be at least 1").into());
        }
        if settings.criteria.is_empty() {
            return Err(SceneError::new(
                "criteria",
                "no criterion requested: give the criteria to search here, or in the scene's \
                 search.criteria",
            )
            .into());
        }
        Ok(settings)
    }
}
