//! The accuracy statement of a worst-scenario result: the criteria at the worst and best data of
//! every criterion re-evaluated on refined meshes (all mesh sizes halved, and halved again when
//! affordable), the difference to the run's value reported as the discretisation-error estimate
//! of each Φ (with two refinements: against the Richardson extrapolation of the three values,
//! with the observed order). The values are those of the same data on finer meshes — the
//! statement estimates the discretisation error of the reported extremum, not the shift of the
//! maximiser.
//!
//! The refined solves are cold (no warm start) direct solves, sequential inside and parallel
//! over the points, so the statement is bit-identical on any thread count, after a resume and
//! whichever process solves a point: with a [`BatchDispatch`] (worker processes sharing a job
//! store) each level's points are dealt to the live workers, which build the refined level
//! themselves, while this process builds it and solves its own share. Between points and levels
//! `stop` is polled (cancel, time limit); a statement cut short says so in `complete`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::ladder::DirectLevel;
use super::richardson::extrapolate;
use crate::error::WsmError;
use crate::run::BatchDispatch;
use crate::scene::params::{apply, Parameter};
use crate::scene::Criterion;
use crate::state::StateProblem;

/// Refinements by default: two while 16 × the run's unknowns stay below this, else one.
pub const SECOND_REFINEMENT_UNKNOWNS: usize = 50_000;
/// No refinement when 4 × the run's unknowns exceed this.
pub const MAX_REFINED_UNKNOWNS: usize = 2_000_000;

/// One mesh of the statement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct StatementMesh {
    /// Mesh sizes relative to the run's mesh (1, 1/2, 1/4).
    pub size_factor: f64,
    /// Unknowns (free displacement DOFs) on this mesh.
    pub unknowns: usize,
    /// Triangles of this mesh.
    pub triangles: usize,
    /// Meshing, set-up and the solves on this mesh \[s\].
    pub seconds: f64,
}

/// The accuracy of one extremum (the worst or best value of a criterion).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct ExtremumAccuracy {
    /// The run's value (units of the criterion).
    pub value: f64,
    /// The same data on each refined mesh (`None` where that solve failed).
    pub refined: Vec<Option<f64>>,
    /// Estimated discretisation error of `value` (absolute): |value − refined| with one
    /// refinement, |value − extrapolated| with two and monotone convergence, else the largest
    /// difference.
    pub estimate: Option<f64>,
    /// `estimate / |value|`.
    pub relative: Option<f64>,
    /// The observed order in h (two refinements, monotone convergence).
    pub observed_order: Option<f64>,
    /// Richardson's value on an infinitely fine mesh (two refinements, monotone convergence).
    pub extrapolated: Option<f64>,
    /// Why a refined solve failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// The statement for one criterion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct CriterionAccuracy {
    /// The criterion Φ1–Φ6 this entry is about.
    pub criterion: Criterion,
    /// Accuracy of the worst (largest) value; `None` when the run found no worst value.
    pub worst: Option<ExtremumAccuracy>,
    /// Accuracy of the best (smallest) value; `None` when the run found no best value.
    pub best: Option<ExtremumAccuracy>,
}

/// The accuracy statement of a worst-scenario result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct AccuracyStatement {
    /// The run's mesh first, then the refined ones.
    pub meshes: Vec<StatementMesh>,
    /// One entry per requested criterion, in the run's criterion order.
    pub criteria: Vec<CriterionAccuracy>,
    /// Distinct worst/best data re-solved.
    pub points: usize,
    /// Extra wall time of the statement \[s\].
    pub seconds: f64,
    /// False when a cancel or the time limit cut it short (or the mesh is too large to refine).
    pub complete: bool,
    /// How the estimates were made, in words (which data, which meshes, which estimate).
    pub method: String,
}

/// How many refinements the statement makes by default for a run on `unknowns` unknowns.
pub fn default_refinements(unknowns: usize) -> usize {
    if 16 * unknowns <= SECOND_REFINEMENT_UNKNOWNS {
        2
    } else if 4 * unknowns <= MAX_REFINED_UNKNOWNS {
        1
    } else {
        0
    }
}

/// The extremum values of a run, per criterion (worst, best): (value, point).
pub type Extrema = Vec<[Option<(f64, Vec<f64>)>; 2]>;

/// The criteria of one refined solve (in the run's criterion order; `None` where a criterion is
/// not defined), or why the solve failed.
pub type RefinedValues = Result<Vec<Option<f64>>, String>;

/// Solves points (physical parameter values) on one refined level, in input order.
pub type RefinedSolve<'a> = dyn Fn(&[Vec<f64>]) -> Vec<RefinedValues> + Sync + 'a;

/// The mesh size factor of refinement `level` (sizes halved `level` times).
pub fn refinement_factor(level: u32) -> f64 {
    0.5_f64.powi(level as i32)
}

/// The refined level of `scene` and the solves on it: what the accuracy statement runs in this
/// process and what a worker process runs for a dispatched share. The level is built on the
/// first solve, so a coordinator builds its own while the workers build theirs.
pub struct RefinedLevel<'a> {
    scene: &'a crate::scene::Scene,
    params: &'a [Parameter],
    criteria: &'a [Criterion],
    level: u32,
    built: OnceLock<Result<DirectLevel, WsmError>>,
}

impl<'a> RefinedLevel<'a> {
    /// Refinement `level` of `scene`, for `criteria` at points of `params`.
    pub fn new(
        scene: &'a crate::scene::Scene,
        params: &'a [Parameter],
        criteria: &'a [Criterion],
        level: u32,
    ) -> RefinedLevel<'a> {
        RefinedLevel {
            scene,
            params,
            criteria,
            level,
            built: OnceLock::new(),
        }
    }

    /// The refinement level (mesh sizes halved this many times).
    pub fn level(&self) -> u32 {
        self.level
    }

    /// The level's problem, built on first use (or why meshing or set-up failed).
    pub fn get(&self) -> Result<&DirectLevel, WsmError> {
        self.built
            .get_or_init(|| {
                DirectLevel::new(self.scene, refinement_factor(self.level), self.criteria)
            })
            .as_ref()
            .map_err(Clone::clone)
    }

    /// The criteria at `points`, solved in parallel over the current pool's threads; a point
    /// for which `stop` answers true is not solved (`None`).
    pub fn solve(
        &self,
        points: &[Vec<f64>],
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Vec<Option<RefinedValues>> {
        let level = match self.get() {
            Ok(level) => level,
            Err(e) => return points.iter().map(|_| Some(Err(e.to_string()))).collect(),
        };
        let problem = &level.problem;
        points
            .par_iter()
            .map(|p| {
                (!stop()).then(|| {
                    level.criteria_at(&apply(&problem.scene, &problem.nominal, self.params, p))
                })
            })
            .collect()
    }
}

/// The statement for `extrema` of `criteria` found on `problem`'s mesh, with `refinements`
/// refined meshes, their solves dealt out through `dispatch` when there is one. `stop` is polled
/// between meshes and points.
pub fn statement(
    problem: &StateProblem,
    params: &[Parameter],
    criteria: &[Criterion],
    extrema: &Extrema,
    refinements: usize,
    stop: &(dyn Fn() -> bool + Sync),
    dispatch: Option<&dyn BatchDispatch>,
) -> Result<AccuracyStatement, WsmError> {
    let start = Instant::now();
    let mut points: Vec<Vec<f64>> = Vec::new();
    for pair in extrema {
        for (_, p) in pair.iter().flatten() {
            if !points.contains(p) {
                points.push(p.clone());
            }
        }
    }
    let base = StatementMesh {
        size_factor: 1.0,
        unknowns: problem.elastic.dofs().n_free(),
        triangles: problem.mesh().triangles.len(),
        seconds: 0.0,
    };
    let mut meshes = vec![base];
    // values[level][point][criterion]
    let mut values: Vec<Vec<RefinedValues>> = Vec::new();
    let mut complete = true;
    for level in 1..=refinements {
        if stop() {
            complete = false;
            break;
        }
        let t0 = Instant::now();
        let refined = RefinedLevel::new(&problem.scene, params, criteria, level as u32);
        let stopped = AtomicBool::new(false);
        let local = |points: &[Vec<f64>]| -> Vec<RefinedValues> {
            refined
                .solve(points, stop)
                .into_iter()
                .map(|v| {
                    v.unwrap_or_else(|| {
                        stopped.store(true, Ordering::SeqCst);
                        Err("stopped".into())
                    })
                })
                .collect()
        };
        let dispatched = match dispatch {
            Some(d) => d.refined(level as u32, &points, &local)?,
            None => None,
        };
        let solved = dispatched.unwrap_or_else(|| local(&points));
        if stopped.load(Ordering::SeqCst) {
            complete = false;
            break;
        }
        let built = refined.get()?;
        values.push(solved);
        meshes.push(StatementMesh {
            size_factor: refinement_factor(level as u32),
            unknowns: built.unknowns(),
            triangles: built.triangles(),
            seconds: t0.elapsed().as_secs_f64(),
        });
    }
    if refinements == 0 {
        complete = false;
    }
    let h: Vec<f64> = meshes
        .iter()
        .map(|m| (m.unknowns.max(1) as f64).powf(-0.5))
        .collect();
    let accuracy = |k: usize, extremum: &Option<(f64, Vec<f64>)>| {
        let (value, point) = extremum.as_ref()?;
        let index = points.iter().position(|q| q == point)?;
        let mut failure = None;
        let refined: Vec<Option<f64>> = values
            .iter()
            .map(|level| match &level[index] {
                Ok(v) => v[k],
                Err(e) => {
                    failure.get_or_insert_with(|| e.clone());
                    None
                }
            })
            .collect();
        Some(extremum_accuracy(*value, refined, &h, failure))
    };
    let criteria = criteria
        .iter()
        .zip(extrema)
        .enumerate()
        .map(|(k, (&criterion, [worst, best]))| CriterionAccuracy {
            criterion,
            worst: accuracy(k, worst),
            best: accuracy(k, best),
        })
        .collect();
    Ok(AccuracyStatement {
        meshes,
        criteria,
        points: points.len(),
        seconds: start.elapsed().as_secs_f64(),
        complete,
        method: "the worst and best data of each criterion re-solved (direct solver, cold) on the run's mesh with every mesh size halved (and halved again when affordable); estimate = |value − refined value|, or with two refinements |value − Richardson extrapolation| when the three values converge monotonically".into(),
    })
}

pub(crate) fn extremum_accuracy(
    value: f64,
    refined: Vec<Option<f64>>,
    h: &[f64],
    failure: Option<String>,
) -> ExtremumAccuracy {
    let differences: Vec<f64> = refined
        .iter()
        .flatten()
        .map(|r| (value - r).abs())
        .collect();
    let mut out = ExtremumAccuracy {
        value,
        estimate: differences.iter().copied().reduce(f64::max),
        relative: None,
        observed_order: None,
        extrapolated: None,
        failure,
        refined,
    };
    if let [Some(a), Some(b)] = out.refined[..] {
        let sequence = [value, a, b];
        if let Some(e) = extrapolate(&h[..3], &sequence).filter(|e| e.monotone && !e.at_bound) {
            out.estimate = Some((value - e.value).abs());
            out.observed_order = e.order;
            out.extrapolated = Some(e.value);
        }
    }
    out.relative = out.estimate.map(|e| e / value.abs().max(f64::MIN_POSITIVE));
    out
}
