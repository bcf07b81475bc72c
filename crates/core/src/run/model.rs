//! A prepared model: the one way anything outside the engine builds what evaluations need — the
//! uncertain parameters of a scene, its mesh (after the target-error choice), the per-zone
//! operators and symbolic factorisations ([`StateProblem`]) — and evaluates points with it.
//! [`super::worst`] prepares one per run; the service's workers prepare one per job they help
//! with, from the scene the job's coordinator chose, so every process solves the same model.

use super::request::WorstRequest;
use super::run_scene;
use crate::contact::qp::WarmStart;
use crate::error::WsmError;
use crate::estimate::statement::RefinedLevel;
use crate::scenario::evaluator::ScenarioEvaluator;
use crate::scenario::solvability::check_admissible_box;
use crate::scenario::worst::ParameterInfo;
use crate::scene::params::{parameters, Parameter};
use crate::scene::{CriterionSpec, Scene};
use crate::state::StateProblem;

/// The uncertain parameters of `scene` as results report them (field path, interval, nominal),
/// after checking every `uncertain` entry (its field exists, its interval is admissible).
pub fn parameter_info(scene: &Scene) -> Result<Vec<ParameterInfo>, WsmError> {
    let params = parameters(scene)?;
    Ok(ParameterInfo::list(scene, &params))
}

/// The admissible-set checks a search makes before any evaluation, on the scene's own mesh:
/// every `uncertain` entry, the contact feasibility of the prescribed displacements on the whole
/// box, and the balance of floating bodies at the nominal data and over the box — the same
/// function a run calls (`check_admissible_box`). The service runs it on submission, so that a
/// job that cannot start is refused with the field instead of failing later.
pub fn check_admissible_set(scene: &Scene) -> Result<(), WsmError> {
    let params = parameters(scene)?;
    let problem = StateProblem::new(scene.clone())?;
    check_admissible_box(&problem, &params, &|| false)
}

/// A scene meshed and assembled for evaluations of the given criteria at points of its box.
pub struct PreparedModel {
    problem: StateProblem,
    params: Vec<Parameter>,
    criteria: Vec<CriterionSpec>,
    derivatives: bool,
}

impl PreparedModel {
    /// Mesh `scene` and build its operators (the solve-ready scene: a target-error choice has
    /// been made before).
    pub fn new(
        scene: Scene,
        params: Vec<Parameter>,
        criteria: Vec<CriterionSpec>,
    ) -> Result<Self, WsmError> {
        Ok(PreparedModel {
            problem: StateProblem::new(scene)?,
            params,
            criteria,
            derivatives: false,
        })
    }

    /// Evaluate with exact derivatives (see [`ScenarioEvaluator::with_derivatives`]).
    pub fn with_derivatives(mut self, derivatives: bool) -> Self {
        self.derivatives = derivatives;
        self
    }

    /// The model a worker evaluates for a job: the submitted scene text and settings, on the
    /// mesh the job's coordinator chose (`chosen_scene`; without one, chosen here the same way).
    pub fn for_job(
        scene_text: &str,
        request: &WorstRequest,
        chosen_scene: Option<&str>,
    ) -> Result<Self, WsmError> {
        let scene = crate::scene::parse(scene_text)?;
        let settings = request.settings(&scene)?;
        let params = parameters(&scene)?;
        let scene = match chosen_scene {
            Some(text) => crate::scene::parse(text)?,
            None => run_scene(scene, &settings, &|| false, None, None)?.0,
        };
        Ok(PreparedModel::new(scene, params, settings.criteria)?
            .with_derivatives(settings.derivatives))
    }

    /// The state problem (mesh, operators, nominal data).
    pub fn problem(&self) -> &StateProblem {
        &self.problem
    }

    /// Refinement `level` of this model's mesh for the accuracy statement's solves (built on
    /// its first solve): what a worker runs for a dispatched share of the statement.
    pub fn refined_level(&self, level: u32) -> RefinedLevel<'_> {
        RefinedLevel::new(&self.problem.scene, &self.params, &self.criteria, level)
    }

    /// The evaluator of this model: solves the nominal state once (its contact state
    /// warm-starts every later solve).
    pub fn evaluator(&self) -> Result<ScenarioEvaluator<'_>, WsmError> {
        Ok(
            ScenarioEvaluator::new(&self.problem, &self.params, &self.criteria)?
                .with_derivatives(self.derivatives),
        )
    }

    /// An evaluator of this model warm-started from `warm` (an earlier evaluator's
    /// [`ScenarioEvaluator::warm_start`]): no nominal solve.
    pub fn warmed_evaluator(
        &self,
        warm: Option<WarmStart>,
    ) -> Result<ScenarioEvaluator<'_>, WsmError> {
        Ok(
            ScenarioEvaluator::warmed(&self.problem, &self.params, &self.criteria, warm)?
                .with_derivatives(self.derivatives),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_json(model: &PreparedModel) -> serde_json::Value {
        serde_json::to_value(&model.problem().scene).unwrap()
    }

    /// A worker given the coordinator's chosen scene evaluates on exactly the scene it would
    /// have chosen itself, without choosing.
    #[test]
    fn a_stored_choice_is_the_scene_the_worker_would_choose() {
        let text = crate::bundled::example("tunnel-fault").unwrap();
        let scene = crate::scene::parse(text).unwrap();
        let request: WorstRequest = serde_json::from_value(serde_json::json!({
            "criteria": ["phi3"],
            "target_error": 0.05,
        }))
        .unwrap();
        let chosen = PreparedModel::for_job(text, &request, None).unwrap();
        let chosen_scene = chosen.problem().scene.clone();
        assert_ne!(
            chosen_scene.mesh.max_size, scene.mesh.max_size,
            "the 5 % target picks another mesh than the scene's own"
        );
        let stored = serde_json::to_string(&chosen_scene).unwrap();
        // What is stored is used as it is (another mesh than any choice, to tell them apart).
        let mut other = chosen_scene.clone();
        other.mesh.max_size = other.mesh.max_size.map(|h| h * 3.0);
        let other_text = serde_json::to_string(&other).unwrap();
        let used = PreparedModel::for_job(text, &request, Some(&other_text)).unwrap();
        assert_eq!(used.problem().scene.mesh.max_size, other.mesh.max_size);
        // And the stored choice round-trips to the same scene.
        let reused = PreparedModel::for_job(text, &request, Some(&stored)).unwrap();
        assert_eq!(scene_json(&reused), scene_json(&chosen));
    }
}
