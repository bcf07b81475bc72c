//! The physics behind the black box of the outer search (FGCS 4.35–4.36): Φ_i(θ) for the
//! requested criteria by one state solve at the data θ (only what the criteria need), with the
//! solve's largest KKT residual and its time, and inner-solver statistics over the run. With
//! derivatives on, the same solve also gives the exact one-sided dΦ_i/dθ_j along every
//! uncertain datum (`state::sensitivity`), which drive and certify the search.
//!
//! A dynamic scene's evaluation is one simulation at θ: the criteria are maxima over time and
//! their derivatives come by forward differentiation through the time loop
//! ([`crate::dynamics::solve_over_time`], design §3.5).
//!
//! Evaluations of a batch run in parallel (rayon, sequential factorisations inside); each
//! warm-starts its contact solve from the nominal solution, so results do not depend on the
//! thread count or the evaluation order. An observer sees every evaluation as it completes (the
//! evaluation log of a run).

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::contact::qp::WarmStart;
use crate::dynamics::solve_over_time;
use crate::error::WsmError;
use crate::fault::{injected, FaultSite, SolveFault};
use crate::fem::Par;
use crate::scene::params::{apply, stencil, Parameter, Stencil};
use crate::scene::{Criterion, CriterionSpec};
use crate::state::{Needs, Solution, SolveOptions, StateProblem, Target, Timings};
use wsm_search::{Answer, Evaluator, OneSided, Outcome};

/// One evaluation of the criteria at a point θ.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct Evaluation {
    /// Physical parameter values, in the order of the scene's `uncertain` list.
    pub point: Vec<f64>,
    /// The requested criteria, in request order (`None` when the point is infeasible).
    pub values: Option<Vec<f64>>,
    /// Why the point is infeasible (the inner solver's error).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Largest relative KKT residual of the contact solution (`None` without contact).
    pub max_kkt_residual: Option<f64>,
    /// Wall time of the state solve \[s\] (with its derivatives).
    pub solve_seconds: f64,
    /// `gradient[c][j]`: the one-sided derivatives of the c-th requested criterion along the
    /// j-th uncertain datum, in the criterion's unit per the datum's unit (empty without
    /// derivatives).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gradient: Vec<Vec<OneSided>>,
}

impl Evaluation {
    /// What the search sees: the criteria vector (and its derivatives) or the reason it is
    /// missing.
    pub fn outcome(&self) -> Outcome {
        match (&self.values, &self.error) {
            (Some(v), _) => Ok(Answer {
                values: v.clone(),
                slopes: self.gradient.clone(),
            }),
            (None, Some(e)) => Err(e.clone()),
            (None, None) => Err("no value recorded".into()),
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
    /// Phase times summed over the solves.
    phases: Mutex<Timings>,
}

/// Inner-solver statistics of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct InnerSummary {
    /// State solves of evaluations (failed ones included; the nominal solve not).
    pub solves: usize,
    /// Of `solves`, how many ended with an error instead of criteria values.
    pub failures: usize,
    /// Solves that reused a whole stiffness factorisation (same λ, μ as an earlier solve).
    pub reused_factorisations: usize,
    /// Semismooth Newton steps of the contact QP per solve, on average over this process's
    /// solves.
    pub mean_qp_iterations: f64,
    /// Summed over threads \[s\].
    pub solver_seconds: f64,
    /// Largest relative KKT residual of any contact solution (0 without contact).
    pub max_kkt_residual: f64,
    /// Heat solves, stiffness factorisations and elastic solves of the run, the nominal solve
    /// included (only what the criteria need is computed; factorisations are reused while λ, μ
    /// do not change).
    pub heat_solves: usize,
    /// Stiffness factors built (at least one body block factorised numerically), the nominal
    /// solve included.
    pub factorisations: usize,
    /// Elastic contact solves, the nominal solve included.
    pub elastic_solves: usize,
}

/// Sees the evaluations of every batch (the evaluation log of a run).
pub type Observer<'a> = dyn Fn(&[Evaluation]) + Sync + 'a;

/// The criteria of a scene as a black box for the search.
pub struct ScenarioEvaluator<'a> {
    problem: &'a StateProblem,
    params: &'a [Parameter],
    criteria: &'a [CriterionSpec],
    targets: Vec<Target>,
    needs: Needs,
    warm: Option<WarmStart>,
    stats: InnerStats,
    observer: Option<&'a Observer<'a>>,
    fault: Option<&'a SolveFault>,
    derivatives: bool,
}

impl<'a> ScenarioEvaluator<'a> {
    /// Prepare: the nominal solve gives the warm start of every contact solve.
    pub fn new(
        problem: &'a StateProblem,
        params: &'a [Parameter],
        criteria: &'a [CriterionSpec],
    ) -> Result<ScenarioEvaluator<'a>, WsmError> {
        let mut evaluator = ScenarioEvaluator::warmed(problem, params, criteria, None)?;
        // A dynamic run starts from its own initial state: no static warm start.
        let dynamic = problem.scene.dynamics.is_some();
        if evaluator.needs.elastic && problem.contact.geometry.dim() > 0 && !dynamic {
            let nominal = problem.solve(&problem.nominal, &evaluator.options(Par::rayon(0)))?;
            evaluator.warm = nominal.warm_start;
        }
        Ok(evaluator)
    }

    /// [`Self::new`] with the warm start given ([`Self::warm_start`] of an earlier evaluator of
    /// the same problem and criteria): no nominal solve here.
    pub fn warmed(
        problem: &'a StateProblem,
        params: &'a [Parameter],
        criteria: &'a [CriterionSpec],
        warm: Option<WarmStart>,
    ) -> Result<ScenarioEvaluator<'a>, WsmError> {
        let targets = problem.targets(criteria)?;
        let needs = Needs::for_targets(&problem.scene, &targets);
        Ok(ScenarioEvaluator {
            problem,
            params,
            criteria,
            targets,
            needs,
            warm,
            stats: InnerStats::default(),
            observer: None,
            fault: None,
            derivatives: false,
        })
    }

    /// The warm start of every contact solve: the nominal contact state.
    pub fn warm_start(&self) -> Option<&WarmStart> {
        self.warm.as_ref()
    }

    /// Call `observer` with the evaluations of every batch, in input order, once it is done.
    pub fn observed_by(mut self, observer: &'a Observer<'a>) -> Self {
        self.observer = Some(observer);
        self
    }

    /// Fail the evaluations where `fault` answers at [`FaultSite::Evaluation`] (tests of
    /// failure handling).
    pub fn with_fault(mut self, fault: Option<&'a SolveFault>) -> Self {
        self.fault = fault;
        self
    }

    /// Also compute the exact derivatives of the criteria along every uncertain datum at each
    /// evaluation (off by default; never for a Coulomb state on the sparse contact path, nor for
    /// a dynamic run without them, `crate::dynamics::derivatives_unavailable`).
    pub fn with_derivatives(mut self, derivatives: bool) -> Self {
        let scene = &self.problem.scene;
        let coulomb_sparse = self.problem.contact.is_sparse()
            && self.needs.elastic
            && self.problem.nominal.has_coulomb()
            && scene.dynamics.is_none();
        let over_time_unavailable =
            crate::dynamics::derivatives_unavailable(self.problem).is_some();
        self.derivatives = derivatives && !coulomb_sparse && !over_time_unavailable;
        self
    }

    fn options(&self, par: Par) -> SolveOptions {
        SolveOptions {
            needs: self.needs.clone(),
            par,
            warm: self.warm.clone(),
        }
    }

    /// [`Self::evaluate_one`] at every point, in parallel in the current pool, in input order
    /// (not reported to the observer).
    pub fn evaluate_batch(&self, points: &[Vec<f64>]) -> Vec<Evaluation> {
        points.par_iter().map(|p| self.evaluate_one(p)).collect()
    }

    /// The requested criteria at θ, with the solve's residual and time.
    pub fn evaluate_one(&self, theta: &[f64]) -> Evaluation {
        let start = Instant::now();
        let data = apply(
            &self.problem.scene,
            &self.problem.nominal,
            self.params,
            theta,
        );
        let result = match injected(self.fault, FaultSite::Evaluation { point: theta }) {
            Some(reason) => Err(WsmError::contact(reason)),
            None if self.problem.scene.dynamics.is_some() => {
                let kinds: Vec<Criterion> = self.targets.iter().map(|t| t.criterion).collect();
                solve_over_time(self.problem, &data, &kinds, &self.stencils(theta))
            }
            None => self.problem.solve_with_sensitivities(
                &data,
                &self.options(Par::Seq),
                &self.stencils(theta),
            ),
        };
        let seconds = start.elapsed().as_secs_f64();
        self.stats
            .nanos
            .fetch_add((seconds * 1e9) as u64, Ordering::Relaxed);
        self.stats.solves.fetch_add(1, Ordering::Relaxed);
        let mut evaluation = Evaluation {
            point: theta.to_vec(),
            values: None,
            error: None,
            max_kkt_residual: None,
            solve_seconds: seconds,
            gradient: Vec::new(),
        };
        let solution = match result {
            Ok(s) => s,
            Err(e) => {
                self.stats.failures.fetch_add(1, Ordering::Relaxed);
                evaluation.error = Some(e.to_string());
                return evaluation;
            }
        };
        let report = &solution.report;
        if let Ok(mut p) = self.stats.phases.lock() {
            p.add(&report.timings);
        }
        if report.reused_factorisation {
            self.stats
                .reused_factorisations
                .fetch_add(1, Ordering::Relaxed);
        }
        self.stats
            .qp_iterations
            .fetch_add(report.qp_iterations, Ordering::Relaxed);
        if report.contact_pairs > 0 {
            let kkt = report.kkt.max();
            evaluation.max_kkt_residual = Some(kkt);
            if let Ok(mut m) = self.stats.max_kkt.lock() {
                *m = m.max(kkt);
            }
        }
        let values: Result<Vec<f64>, String> = self
            .criteria
            .iter()
            .zip(&self.targets)
            .map(|(c, &t)| {
                solution
                    .value(t)
                    .ok_or_else(|| format!("{} is not defined for this scene", c.name()))
            })
            .collect();
        match values {
            Ok(v) => {
                evaluation.values = Some(v);
                evaluation.gradient = self.gradient(&solution);
            }
            Err(e) => evaluation.error = Some(e),
        }
        evaluation
    }

    /// The derivative stencils of every datum at θ (none without derivatives).
    fn stencils(&self, theta: &[f64]) -> Vec<Stencil> {
        if !self.derivatives {
            return Vec::new();
        }
        let (scene, nominal) = (&self.problem.scene, &self.problem.nominal);
        (0..self.params.len())
            .map(|i| stencil(scene, nominal, self.params, theta, i))
            .collect()
    }

    /// The requested criteria's derivatives along every datum, or nothing when one is missing
    /// (not requested, or the sensitivities could not be computed: the solve's warning says so).
    fn gradient(&self, solution: &Solution) -> Vec<Vec<OneSided>> {
        if solution.sensitivities.len() != self.params.len() {
            return Vec::new();
        }
        self.targets
            .iter()
            .map(|&t| {
                (0..self.params.len())
                    .map(|j| solution.derivative(t, j))
                    .collect::<Option<Vec<OneSided>>>()
            })
            .collect::<Option<Vec<_>>>()
            .unwrap_or_default()
    }

    /// Phase times of the evaluations so far, summed over threads \[s\].
    pub fn phase_seconds(&self) -> Timings {
        self.stats.phases.lock().map(|p| *p).unwrap_or_default()
    }

    /// Statistics of the evaluations so far.
    pub fn summary(&self) -> InnerSummary {
        let stats = &self.stats;
        let solves = stats.solves.load(Ordering::Relaxed);
        let (heat_solves, factorisations, elastic_solves) = self.problem.counters.snapshot();
        InnerSummary {
            solves,
            failures: stats.failures.load(Ordering::Relaxed),
            reused_factorisations: stats.reused_factorisations.load(Ordering::Relaxed),
            mean_qp_iterations: stats.qp_iterations.load(Ordering::Relaxed) as f64
                / solves.max(1) as f64,
            solver_seconds: stats.nanos.load(Ordering::Relaxed) as f64 * 1e-9,
            max_kkt_residual: stats.max_kkt.lock().map(|m| *m).unwrap_or(0.0),
            heat_solves,
            factorisations,
            elastic_solves,
        }
    }
}

impl Evaluator for ScenarioEvaluator<'_> {
    fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Outcome> {
        let evaluations = self.evaluate_batch(points);
        if let Some(observe) = self.observer {
            observe(&evaluations);
        }
        evaluations.iter().map(Evaluation::outcome).collect()
    }

    fn gives_derivatives(&self) -> bool {
        self.derivatives
    }
}
