//! The worst-scenario engine (design §4, FGCS 4.35–4.36): runs the outer search for the max and
//! min of each requested criterion Φ_i over the box of the admissible set U_ad (`scene::params`),
//! with the physics evaluator of `evaluator`, and assembles the outcome: worst and best value and
//! data per criterion, sensitivities, history, and the inner-solver statistics.
//!
//! The phases before the search (meshing, the admissible-set checks of `solvability`, the nominal
//! solve) are run by the caller (`crate::run`), which reports them as progress.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::evaluator::InnerSummary;
use super::failures::FailureSummary;
use crate::error::WsmError;
use crate::estimate::mesh_choice::MeshChoice;
use crate::estimate::statement::{AccuracyStatement, Extrema};
use crate::fem::Par;
use crate::scene::params::{applied_values, apply, Parameter};
use crate::scene::{Criterion, CriterionSpec, Scene, SceneError};
use crate::state::{family, region_name, Needs, Solution, SolveOptions, StateProblem};
use rayon::prelude::*;
use wsm_search::{
    search, EvalCache, Evaluator, Objective, ObjectiveResult, SearchControl, SearchProblem, Sense,
    Status, StopRule,
};

/// Settings of one worst-scenario run (defaults from the scene's `search`).
#[derive(Debug, Clone, PartialEq)]
pub struct WorstSettings {
    /// The criteria whose max and min are searched, in request order.
    pub criteria: Vec<CriterionSpec>,
    /// Total number of distinct points evaluated (state solves), all phases and objectives.
    pub budget: usize,
    /// Seed of every random choice of the search.
    pub seed: u64,
    /// Wall-time limit of the search \[s\] (`None`: no limit).
    pub max_seconds: Option<f64>,
    /// Refined meshes of the accuracy statement (`None`: by the mesh size, see
    /// `crate::estimate::statement::default_refinements`).
    pub accuracy_refinements: Option<usize>,
    /// Relative error the run's mesh must meet at the nominal data (`None`: the scene's mesh;
    /// see `crate::estimate::mesh_choice`).
    pub target_error: Option<f64>,
    /// Exact derivatives on every evaluation (vertex walk, quasi-Newton polish, certificates).
    pub derivatives: bool,
    /// When the search may stop before its budget is spent.
    pub stop: StopRule,
}

impl WorstSettings {
    /// The scene's `search` settings, with the scene's mesh and the default accuracy statement.
    pub fn from_scene(scene: &Scene) -> WorstSettings {
        WorstSettings {
            criteria: scene.search.criteria.clone(),
            budget: scene.search_budget(),
            seed: scene.search.seed,
            max_seconds: scene.search.max_seconds,
            accuracy_refinements: None,
            target_error: None,
            derivatives: scene.search.derivatives,
            stop: scene.search.stop,
        }
    }

    /// The objectives of the search: max then min of each criterion, in request order.
    pub fn objectives(&self) -> Vec<Objective> {
        (0..self.criteria.len())
            .flat_map(|criterion| {
                [Sense::Max, Sense::Min].map(|sense| Objective { criterion, sense })
            })
            .collect()
    }
}

/// Worst (max) and best (min) of one criterion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct CriterionOutcome {
    /// The criterion Φ1–Φ6.
    pub criterion: CriterionSpec,
    /// The maximum: the worst scenario A0_i = argmax Φ_i over U_ad (FGCS 4.35–4.36).
    pub worst: ObjectiveResult,
    /// The minimum over U_ad: the best scenario.
    pub best: ObjectiveResult,
}

/// A parameter of the admissible set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct ParameterInfo {
    /// The parameter's name (the scene's `uncertain[i].name`, else its field path).
    pub name: String,
    /// The JSON path of the scene number it varies.
    pub field: String,
    /// Admissible interval \[lo, hi\] (units of the field).
    pub interval: [f64; 2],
}

impl ParameterInfo {
    /// One entry per uncertain parameter, in the order of the scene's `uncertain` list.
    pub fn list(scene: &Scene, params: &[Parameter]) -> Vec<ParameterInfo> {
        params
            .iter()
            .zip(&scene.uncertain)
            .map(|(p, u)| ParameterInfo {
                name: p.name.clone(),
                field: u.field.clone(),
                interval: [p.lo, p.hi],
            })
            .collect()
    }
}

/// The outcome of a worst-scenario run (complete or partial: see `status`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct WorstOutcome {
    /// The scene's `name`.
    pub scene: String,
    /// Stable hash of everything that determines an evaluation's value (scene and criteria).
    pub run_hash: String,
    /// How the search ended: the greatest of its objectives' statuses, or `cancelled` /
    /// `time_limit` for a run stopped early.
    pub status: Status,
    /// The uncertain parameters, in the order of every point's coordinates.
    pub parameters: Vec<ParameterInfo>,
    /// Per criterion; the `point` of each extremum is aligned with `parameters`.
    pub criteria: Vec<CriterionOutcome>,
    /// The run's evaluation budget (distinct points).
    pub budget: usize,
    /// Distinct points used, including those replayed from a log.
    pub evaluations: usize,
    /// Points solved by this run.
    pub new_evaluations: usize,
    /// Wall time of the search \[s\].
    pub wall_seconds: f64,
    /// Meshing and operator set-up \[s\].
    pub setup_seconds: f64,
    /// Points solved by this run per second of search wall time \[1/s\].
    pub evaluations_per_second: f64,
    /// Share of the wall time spent in inner solves (summed over threads / wall / threads).
    pub inner_time_share: f64,
    /// Inner-solver statistics over the run's evaluations.
    pub inner: InnerSummary,
    /// The discretisation-error estimate of every worst and best value (absent for a run cut
    /// short by a cancel or its time limit, or with `accuracy_refinements: 0`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accuracy: Option<AccuracyStatement>,
    /// How the mesh was chosen for the request's `target_error` (absent without one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh_choice: Option<MeshChoice>,
    /// The evaluations without a state solution: count, the part of the box they cover, the
    /// first of them with their errors.
    #[serde(default)]
    pub failures: FailureSummary,
    /// Warnings about the results: failed evaluations, P1 locking at worst or best data with
    /// ν ≥ 0.49, a target error not met.
    #[serde(default)]
    pub warnings: Vec<crate::scene::Warning>,
}

impl WorstOutcome {
    /// The outcome as `wsm worst` prints it: the convergence histories are left out (they stay
    /// in the full outcome, `--out`).
    pub fn without_histories(mut self) -> WorstOutcome {
        for c in &mut self.criteria {
            c.worst.history.clear();
            c.best.history.clear();
        }
        self
    }

    /// A run that stopped (cancel or time limit) before its search began: no values yet.
    pub fn unstarted(
        scene: &Scene,
        params: &[Parameter],
        settings: &WorstSettings,
        status: Status,
    ) -> WorstOutcome {
        let n = params.len();
        let objective = |criterion, sense| ObjectiveResult::empty(criterion, sense, status, n);
        WorstOutcome {
            scene: scene.name.clone(),
            run_hash: String::new(),
            status,
            parameters: ParameterInfo::list(scene, params),
            criteria: settings
                .criteria
                .iter()
                .enumerate()
                .map(|(i, criterion)| CriterionOutcome {
                    criterion: criterion.clone(),
                    worst: objective(i, Sense::Max),
                    best: objective(i, Sense::Min),
                })
                .collect(),
            budget: settings.budget,
            evaluations: 0,
            new_evaluations: 0,
            wall_seconds: 0.0,
            setup_seconds: 0.0,
            evaluations_per_second: 0.0,
            inner_time_share: 0.0,
            inner: InnerSummary {
                solves: 0,
                failures: 0,
                reused_factorisations: 0,
                mean_qp_iterations: 0.0,
                solver_seconds: 0.0,
                max_kkt_residual: 0.0,
                heat_solves: 0,
                factorisations: 0,
                elastic_solves: 0,
            },
            accuracy: None,
            mesh_choice: None,
            failures: FailureSummary::default(),
            warnings: Vec::new(),
        }
    }

    /// Per criterion, the (value, point) of its worst and best.
    pub fn extrema(&self) -> Extrema {
        let pick = |o: &ObjectiveResult| o.value.zip(o.point.clone());
        self.criteria
            .iter()
            .map(|c| [pick(&c.worst), pick(&c.best)])
            .collect()
    }
}

/// Run the search for max and min of each requested criterion, evaluating through `cache`
/// (pre-loaded to resume); `inner` gives the inner-solver statistics of the evaluations. A
/// cancelled or timed-out search returns its partial outcome.
pub fn run(
    problem: &StateProblem,
    params: &[Parameter],
    settings: &WorstSettings,
    evaluator: &dyn Evaluator,
    inner: &dyn Fn() -> InnerSummary,
    cache: &mut EvalCache,
    control: SearchControl<'_>,
) -> Result<WorstOutcome, WsmError> {
    if settings.criteria.is_empty() {
        return Err(SceneError::new("search.criteria", "no criterion requested").into());
    }
    let start = Instant::now();
    let search_problem = SearchProblem {
        bounds: params.iter().map(|p| [p.lo, p.hi]).collect(),
        objectives: settings.objectives(),
        budget: settings.budget,
        max_seconds: settings.max_seconds,
        seed: settings.seed,
        names: problem
            .scene
            .uncertain
            .iter()
            .map(|u| u.field.clone())
            .collect(),
        stop: settings.stop,
    };
    let result = search(&search_problem, evaluator, cache, control)?;
    let mut objectives = result.objectives.into_iter();
    let mut criteria: Vec<CriterionOutcome> = settings
        .criteria
        .iter()
        .filter_map(|criterion| {
            Some(CriterionOutcome {
                criterion: criterion.clone(),
                worst: objectives.next()?,
                best: objectives.next()?,
            })
        })
        .collect();
    for outcome in &mut criteria {
        for extremum in [&mut outcome.worst, &mut outcome.best] {
            report_applied_data(problem, params, extremum);
        }
    }
    name_regions(problem, params, &mut criteria);
    let failures = FailureSummary::from_cache(cache);
    FailureSummary::unsettle(
        cache,
        criteria
            .iter_mut()
            .flat_map(|c| [&mut c.worst, &mut c.best]),
        &search_problem.bounds,
        settings.budget,
    );
    let wall = start.elapsed().as_secs_f64();
    let inner = inner();
    Ok(WorstOutcome {
        scene: problem.scene.name.clone(),
        run_hash: String::new(),
        status: result.status,
        parameters: ParameterInfo::list(&problem.scene, params),
        criteria,
        budget: settings.budget,
        evaluations: result.evaluations,
        new_evaluations: result.new_evaluations,
        wall_seconds: wall,
        evaluations_per_second: result.new_evaluations as f64 / wall.max(1e-9),
        inner_time_share: inner.solver_seconds
            / (wall.max(1e-9) * rayon::current_num_threads() as f64),
        setup_seconds: problem.setup_seconds,
        inner,
        accuracy: None,
        mesh_choice: None,
        failures,
        warnings: Vec::new(),
    })
}

/// The extremum's `data` as the solve used it: slope-limited slip-limit knots take their
/// projected values (`point` keeps the search coordinates).
fn report_applied_data(
    problem: &StateProblem,
    params: &[Parameter],
    extremum: &mut ObjectiveResult,
) {
    let Some(point) = &extremum.point else {
        return;
    };
    let values = applied_values(&problem.scene, &problem.nominal, params, point);
    for (u, v) in problem.scene.uncertain.iter().zip(values) {
        if let Some(slot) = extremum.data.get_mut(&u.field) {
            *slot = v;
        }
    }
}

/// Name the region where each extremum is attained (design §4.2): a bound criterion's own region;
/// a criterion with one region in its family, that one; else the region of its family where the
/// criterion is largest at the extremum's data — one solve without derivatives per distinct
/// point, in parallel (a point that does not solve again leaves the region unnamed). For a
/// dynamic scene the solve is the run's criteria over time, which also give the time of the
/// extremum (design §3.5).
fn name_regions(problem: &StateProblem, params: &[Parameter], criteria: &mut [CriterionOutcome]) {
    let mut points: Vec<Vec<f64>> = Vec::new();
    for c in criteria.iter() {
        let members = family(&problem.criteria, c.criterion.criterion).len();
        if (c.criterion.region.is_some() || members < 2) && problem.scene.dynamics.is_none() {
            continue;
        }
        for point in [&c.worst.point, &c.best.point].into_iter().flatten() {
            if !points.contains(point) {
                points.push(point.clone());
            }
        }
    }
    let kinds: Vec<Criterion> = criteria.iter().map(|c| c.criterion.criterion).collect();
    let options = SolveOptions {
        needs: Needs::for_criteria(&problem.scene, &kinds),
        par: Par::Seq,
        warm: None,
    };
    let solutions: Vec<Option<Solution>> = points
        .par_iter()
        .map(|point| {
            let data = apply(&problem.scene, &problem.nominal, params, point);
            match problem.scene.dynamics {
                Some(_) => crate::dynamics::solve_over_time(problem, &data, &kinds, &[]).ok(),
                None => problem.solve(&data, &options).ok(),
            }
        })
        .collect();
    for c in criteria.iter_mut() {
        let spec = c.criterion.clone();
        let members = family(&problem.criteria, spec.criterion).len();
        for extremum in [&mut c.worst, &mut c.best] {
            let solution = extremum
                .point
                .as_ref()
                .and_then(|point| points.iter().position(|p| p == point))
                .and_then(|i| solutions[i].as_ref());
            // The bound region, or the one where the criterion is largest.
            let attained = |s: &Solution| match &spec.region {
                Some(_) => problem
                    .targets(std::slice::from_ref(&spec))
                    .ok()
                    .and_then(|t| t.first().and_then(|t| t.region)),
                None => crate::state::attaining(&s.region_values[spec.criterion as usize]),
            };
            extremum.time = solution.and_then(|s| {
                let r = attained(s)?;
                s.peak_times[spec.criterion as usize].get(r).copied()
            });
            extremum.region = match (&spec.region, &extremum.point) {
                // A defined criterion's region is the area or piece it averages over (the
                // receiver it reads).
                (Some(name), _) if spec.criterion == Criterion::Defined => problem
                    .scene
                    .criteria
                    .defined
                    .iter()
                    .find(|d| &d.name == name)
                    .map(|d| d.place().to_string()),
                (Some(region), _) => Some(region.clone()),
                (None, Some(_)) if members == 1 => {
                    Some(region_name(&problem.criteria, spec.criterion, 0).to_string())
                }
                (None, Some(point)) => points
                    .iter()
                    .position(|p| p == point)
                    .and_then(|i| solutions[i].as_ref())
                    .and_then(|s| problem.attaining_region(s, spec.criterion))
                    .map(str::to_string),
                (None, None) => None,
            };
        }
    }
}
