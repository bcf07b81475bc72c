//! The worst-scenario engine (SPEC §4, FGCS 4.35–4.36): maps the admissible set U_ad of the
//! scene (`scene::params`) onto a box, evaluates the requested criteria Φ_i(θ) by state solves
//! (only what the criteria need; one solve serves all criteria), and runs the outer search for
//! max and min of each criterion.
//!
//! Evaluations of a generation run in parallel (rayon, sequential factorisations inside); each
//! warm-starts its contact solve from the nominal solution, so results do not depend on the
//! thread count or the evaluation order.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::admissible::check_balance_on_vertices;
use super::search::{
    search, ActiveBound, EvalCache, Evaluator, Objective, Progress, SearchControl, SearchProblem,
    Sense, Status,
};
use crate::contact::qp::WarmStart;
use crate::error::WsmError;
use crate::fem::Par;
use crate::scene::params::{apply, parameters, Parameter};
use crate::scene::{Criterion, Scene};
use crate::state::{Needs, SolveOptions, StateProblem};

/// Settings of one worst-scenario run (defaults from the scene's `search`).
#[derive(Debug, Clone)]
pub struct WorstSettings {
    pub criteria: Vec<Criterion>,
    pub budget: usize,
    pub seed: u64,
    pub max_seconds: Option<f64>,
}

impl WorstSettings {
    pub fn from_scene(scene: &Scene) -> WorstSettings {
        WorstSettings {
            criteria: scene.search.criteria.clone(),
            budget: scene.search.budget,
            seed: scene.search.seed,
            max_seconds: scene.search.max_seconds,
        }
    }
}

/// Inner-solver statistics accumulated over the evaluations.
#[derive(Debug, Default)]
struct InnerStats {
    solves: AtomicUsize,
    failures: AtomicUsize,
    reused_factorisations: AtomicUsize,
    qp_iterations: AtomicUsize,
    nanos: AtomicU64,
    max_kkt: Mutex<f64>,
}

/// The criteria of a scene as a black box for the search.
pub struct ScenarioEvaluator<'a> {
    problem: &'a StateProblem,
    params: &'a [Parameter],
    criteria: &'a [Criterion],
    needs: Needs,
    warm: Option<WarmStart>,
    stats: InnerStats,
}

impl<'a> ScenarioEvaluator<'a> {
    /// Prepare: the nominal solve gives the warm start of every contact solve.
    pub fn new(
        problem: &'a StateProblem,
        params: &'a [Parameter],
        criteria: &'a [Criterion],
    ) -> Result<ScenarioEvaluator<'a>, WsmError> {
        let needs = Needs::for_criteria(&problem.scene, criteria);
        let mut evaluator = ScenarioEvaluator {
            problem,
            params,
            criteria,
            needs,
            warm: None,
            stats: InnerStats::default(),
        };
        if needs.elastic && problem.contact.geometry.dim() > 0 {
            let nominal = problem.solve(&problem.nominal, &evaluator.options(Par::rayon(0)))?;
            evaluator.warm = nominal.warm_start;
        }
        Ok(evaluator)
    }

    fn options(&self, par: Par) -> SolveOptions {
        SolveOptions {
            needs: self.needs,
            par,
            warm: self.warm.clone(),
        }
    }

    /// The requested criteria at θ.
    pub fn evaluate_one(&self, theta: &[f64]) -> Result<Vec<f64>, String> {
        let start = Instant::now();
        let data = apply(
            &self.problem.scene,
            &self.problem.nominal,
            self.params,
            theta,
        );
        let result = self.problem.solve(&data, &self.options(Par::Seq));
        self.stats
            .nanos
            .fetch_add(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
        self.stats.solves.fetch_add(1, Ordering::Relaxed);
        let solution = result.map_err(|e| {
            self.stats.failures.fetch_add(1, Ordering::Relaxed);
            e.to_string()
        })?;
        let report = &solution.report;
        if report.reused_factorisation {
            self.stats
                .reused_factorisations
                .fetch_add(1, Ordering::Relaxed);
        }
        self.stats
            .qp_iterations
            .fetch_add(report.qp_iterations, Ordering::Relaxed);
        if let Ok(mut m) = self.stats.max_kkt.lock() {
            *m = m.max(report.kkt.max());
        }
        self.criteria
            .iter()
            .map(|c| {
                solution.criteria[*c as usize]
                    .ok_or_else(|| format!("{} is not defined for this scene", c.name()))
            })
            .collect()
    }
}

impl Evaluator for ScenarioEvaluator<'_> {
    fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Result<Vec<f64>, String>> {
        points.par_iter().map(|p| self.evaluate_one(p)).collect()
    }
}

/// One extremum of one criterion.
#[derive(Debug, Clone, Serialize)]
pub struct Extremum {
    pub value: Option<f64>,
    /// Parameter name → value.
    pub data: Vec<(String, f64)>,
    pub active_bounds: Vec<String>,
    pub sensitivities: Vec<Option<f64>>,
    pub at_vertex: bool,
    pub vertex_optimal: bool,
    pub several_optima: bool,
    pub status: String,
    /// (evaluation index, best value so far).
    pub history: Vec<(usize, f64)>,
}

/// Worst and best of one criterion.
#[derive(Debug, Clone, Serialize)]
pub struct CriterionResult {
    pub criterion: Criterion,
    pub worst: Extremum,
    pub best: Extremum,
}

/// Inner-solver statistics of a run.
#[derive(Debug, Clone, Serialize)]
pub struct InnerSummary {
    pub solves: usize,
    pub failures: usize,
    pub reused_factorisations: usize,
    pub mean_qp_iterations: f64,
    pub solver_seconds: f64,
    pub max_kkt_residual: f64,
}

/// The result of `wsm worst`.
#[derive(Debug, Clone, Serialize)]
pub struct WorstResult {
    pub scene: String,
    pub parameters: Vec<ParameterInfo>,
    pub criteria: Vec<CriterionResult>,
    pub status: String,
    pub evaluations: usize,
    pub new_evaluations: usize,
    pub wall_seconds: f64,
    pub evaluations_per_second: f64,
    /// Share of the wall time spent in inner solves (summed over threads / wall / threads).
    pub inner_time_share: f64,
    pub setup_seconds: f64,
    pub inner: InnerSummary,
}

/// A parameter of the admissible set.
#[derive(Debug, Clone, Serialize)]
pub struct ParameterInfo {
    pub name: String,
    pub interval: [f64; 2],
}

/// Validate the admissible set and build the state problem.
pub fn prepare(scene: Scene) -> Result<(StateProblem, Vec<Parameter>), WsmError> {
    let params = parameters(&scene)?;
    let problem = StateProblem::new(scene)?;
    check_balance_on_vertices(&problem, &params)?;
    Ok((problem, params))
}

/// Run the search for max and min of each requested criterion.
pub fn run(
    problem: &StateProblem,
    params: &[Parameter],
    settings: &WorstSettings,
    cache: &mut EvalCache,
    cancel: &AtomicBool,
    on_progress: &(dyn Fn(&Progress) + Sync),
) -> Result<WorstResult, WsmError> {
    if settings.criteria.is_empty() {
        return Err(
            crate::scene::SceneError::new("search.criteria", "no criterion requested").into(),
        );
    }
    let start = Instant::now();
    let evaluator = ScenarioEvaluator::new(problem, params, &settings.criteria)?;
    let objectives: Vec<Objective> = (0..settings.criteria.len())
        .flat_map(|criterion| [Sense::Max, Sense::Min].map(|sense| Objective { criterion, sense }))
        .collect();
    let search_problem = SearchProblem {
        bounds: params.iter().map(|p| [p.lo, p.hi]).collect(),
        objectives,
        budget: settings.budget,
        max_seconds: settings.max_seconds,
        seed: settings.seed,
    };
    let control = SearchControl {
        cancel,
        on_progress,
    };
    let result = search(&search_problem, &evaluator, cache, control)
        .map_err(|e| WsmError::Contact(format!("search: {e}")))?;
    if cancel.load(Ordering::Relaxed) && result.status == Status::Cancelled {
        return Err(WsmError::Cancelled);
    }
    let extremum = |k: usize| {
        let o = &result.objectives[k];
        Extremum {
            value: o.best_value,
            data: o
                .best_point
                .as_ref()
                .map(|p| {
                    params
                        .iter()
                        .zip(p)
                        .map(|(q, v)| (q.name.clone(), *v))
                        .collect()
                })
                .unwrap_or_default(),
            active_bounds: o
                .active_bounds
                .iter()
                .map(|b| match b {
                    ActiveBound::None => "interior",
                    ActiveBound::Lower => "lower",
                    ActiveBound::Upper => "upper",
                    ActiveBound::Fixed => "fixed",
                })
                .map(str::to_string)
                .collect(),
            sensitivities: o.sensitivities.clone(),
            at_vertex: o.at_vertex,
            vertex_optimal: o.vertex_optimal,
            several_optima: o.several_optima,
            status: format!("{:?}", o.status),
            history: o.history.clone(),
        }
    };
    let criteria = settings
        .criteria
        .iter()
        .enumerate()
        .map(|(i, &criterion)| CriterionResult {
            criterion,
            worst: extremum(2 * i),
            best: extremum(2 * i + 1),
        })
        .collect();
    let wall = start.elapsed().as_secs_f64();
    let stats = &evaluator.stats;
    let solves = stats.solves.load(Ordering::Relaxed);
    let solver_seconds = stats.nanos.load(Ordering::Relaxed) as f64 * 1e-9;
    Ok(WorstResult {
        scene: problem.scene.name.clone(),
        parameters: params
            .iter()
            .map(|p| ParameterInfo {
                name: p.name.clone(),
                interval: [p.lo, p.hi],
            })
            .collect(),
        criteria,
        status: format!("{:?}", result.status),
        evaluations: result.evaluations,
        new_evaluations: result.new_evaluations,
        wall_seconds: wall,
        evaluations_per_second: result.new_evaluations as f64 / wall.max(1e-9),
        inner_time_share: solver_seconds / (wall.max(1e-9) * rayon::current_num_threads() as f64),
        setup_seconds: problem.setup_seconds,
        inner: InnerSummary {
            solves,
            failures: stats.failures.load(Ordering::Relaxed),
            reused_factorisations: stats.reused_factorisations.load(Ordering::Relaxed),
            mean_qp_iterations: stats.qp_iterations.load(Ordering::Relaxed) as f64
                / solves.max(1) as f64,
            solver_seconds,
            max_kkt_residual: stats.max_kkt.lock().map(|m| *m).unwrap_or(0.0),
        },
    })
}
