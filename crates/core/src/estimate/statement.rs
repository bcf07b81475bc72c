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
//! whichever process solves a point: with a [`RefinedDispatch`] (worker processes sharing a job
//! store) each level's points are dealt to the live workers, which build the refined level
//! themselves, while this process builds it and solves its own share. Between points and levels
//! `stop` is polled (cancel, time limit).
//!
//! No failure is hidden (design §6): a refined solve that fails — or a refined mesh that cannot
//! be built — is listed in `failures` with the extrema at its data, the extremum's entry keeps
//! the error, [`AccuracyStatement::warnings`] says in plain words which value's discretisation
//! error is therefore unknown, and `complete` is false, as it is for a statement cut short.
//!
//! An imported mesh (`mesh.gmsh_file`, `mesh.inline`; design §2.5) is refined by uniform
//! subdivision (`mesh.subdivide` one higher per level), which halves h exactly as halving the
//! sizes of the built-in mesher does; a level that cannot be made (more subdivisions than
//! allowed) fails like any mesh that cannot be built.

use std::sync::OnceLock;
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::ladder::DirectLevel;
use super::richardson::extrapolate;
use crate::error::WsmError;
use crate::fault::{injected, FaultSite, SolveFault};
use crate::scene::params::{apply, Parameter};
use crate::scene::{CriterionSpec, Warning, WarningKind};
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
    /// Unknowns (free displacement DOFs) on this mesh (0: it could not be built, see
    /// `failures`).
    pub unknowns: usize,
    /// Triangles of this mesh (0: it could not be built).
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
    /// Why refined solves of this value failed, per failed refinement ("refinement 1: …"),
    /// joined by "; ".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// The statement for one criterion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct CriterionAccuracy {
    /// The criterion Φ1–Φ6 this entry is about.
    pub criterion: CriterionSpec,
    /// Accuracy of the worst (largest) value; `None` when the run found no worst value.
    pub worst: Option<ExtremumAccuracy>,
    /// Accuracy of the best (smallest) value; `None` when the run found no best value.
    pub best: Option<ExtremumAccuracy>,
}

/// A refined solve of the statement that failed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct RefinedFailure {
    /// The refinement: the run's mesh sizes halved this many times (its mesh is
    /// `meshes[level]`).
    pub level: u32,
    /// The uncertain data of the solve, in the order of the result's `parameters`.
    pub point: Vec<f64>,
    /// The criteria whose worst (largest) value lies at these data.
    pub worst_of: Vec<CriterionSpec>,
    /// The criteria whose best (smallest) value lies at these data.
    pub best_of: Vec<CriterionSpec>,
    /// Why it failed: the solver's error, or why the refined mesh could not be built.
    pub error: String,
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
    /// True exactly when every refined solve asked for ran and succeeded: none failed
    /// (`failures` is empty) and no cancel or time limit cut the statement short (every
    /// refinement asked for is in `meshes`). When false, some extremum's estimate rests on
    /// fewer meshes than asked, or is unknown; the result's `warnings` say which.
    pub complete: bool,
    /// The refined solves that failed, by refinement, then in the order of the extrema.
    #[serde(default)]
    pub failures: Vec<RefinedFailure>,
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

/// What became of one point's refined solve: its values (or why it failed), or `None` — not
/// solved, because the statement was stopped first (its level is then cut short).
pub type RefinedOutcome = Option<RefinedValues>;

/// Solves points (physical parameter values) on one refined level, in input order.
pub type RefinedSolve<'a> = dyn Fn(&[Vec<f64>]) -> Vec<RefinedOutcome> + Sync + 'a;

/// Deals the statement's refined solves to other processes (the service's job store, with worker
/// processes behind it; the run's evaluation batches go the same way, `run::BatchDispatch`).
pub trait RefinedDispatch: Send + Sync {
    /// The solves of `points` on the run's mesh refined `level` times, in input order — this
    /// process's share solved with `local`, the others' by processes that build the refined
    /// level themselves; `None`: not dispatched (solve them all here).
    fn refined(
        &self,
        level: u32,
        points: &[Vec<f64>],
        local: &RefinedSolve<'_>,
    ) -> Result<Option<Vec<RefinedOutcome>>, WsmError>;
}

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
    criteria: &'a [CriterionSpec],
    level: u32,
    built: OnceLock<Result<DirectLevel, WsmError>>,
    fault: Option<&'a SolveFault>,
}

impl<'a> RefinedLevel<'a> {
    /// Refinement `level` of `scene`, for `criteria` at points of `params`.
    pub fn new(
        scene: &'a crate::scene::Scene,
        params: &'a [Parameter],
        criteria: &'a [CriterionSpec],
        level: u32,
    ) -> RefinedLevel<'a> {
        RefinedLevel {
            scene,
            params,
            criteria,
            level,
            built: OnceLock::new(),
            fault: None,
        }
    }

    /// Fail the solves where `fault` answers at [`FaultSite::Refined`] (tests of failure
    /// handling).
    pub fn with_fault(mut self, fault: Option<&'a SolveFault>) -> Self {
        self.fault = fault;
        self
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
    ) -> Vec<RefinedOutcome> {
        let level = match self.get() {
            Ok(level) => level,
            Err(e) => return points.iter().map(|_| Some(Err(e.to_string()))).collect(),
        };
        let problem = &level.problem;
        points
            .par_iter()
            .map(|p| {
                (!stop()).then(|| {
                    let site = FaultSite::Refined {
                        level: self.level,
                        point: p,
                    };
                    match injected(self.fault, site) {
                        Some(reason) => Err(WsmError::contact(reason)),
                        None => level.criteria_at(&apply(
                            &problem.scene,
                            &problem.nominal,
                            self.params,
                            p,
                        )),
                    }
                    .map_err(|e| e.to_string())
                })
            })
            .collect()
    }
}

/// How the statement's solves run: when they stop, where they are dealt out, where they fail
/// on purpose.
#[derive(Clone, Copy)]
pub struct StatementControl<'a> {
    /// Polled between meshes and points (a cancel, the time limit).
    pub stop: &'a (dyn Fn() -> bool + Sync),
    /// Deals each level's points to worker processes, when there are any.
    pub dispatch: Option<&'a dyn RefinedDispatch>,
    /// Fails the refined solves made in this process where it answers (tests).
    pub fault: Option<&'a SolveFault>,
    /// Why refinement `level` must not be built (its solve would need more memory than the
    /// run may use), checked before meshing it; `None` builds every level.
    pub refuse_level: Option<&'a (dyn Fn(u32) -> Option<String> + Sync)>,
}

/// The statement for `extrema` of `criteria` found on `problem`'s mesh, with `refinements`
/// refined meshes, run as `control` says. Every refinement is tried unless `control.stop` says
/// stop; a refined solve that fails (or a mesh that cannot be built) is a [`RefinedFailure`].
pub fn statement(
    problem: &StateProblem,
    params: &[Parameter],
    criteria: &[CriterionSpec],
    extrema: &Extrema,
    refinements: usize,
    control: StatementControl<'_>,
) -> Result<AccuracyStatement, WsmError> {
    let start = Instant::now();
    let points = distinct_points(extrema);
    let ladder = solve_ladder(problem, params, criteria, &points, refinements, control)?;
    let failures = refined_failures(criteria, extrema, &points, &ladder.values);
    let criteria = criterion_accuracies(criteria, extrema, &points, &ladder);
    Ok(AccuracyStatement {
        criteria,
        points: points.len(),
        seconds: start.elapsed().as_secs_f64(),
        complete: !ladder.cut_short && failures.is_empty(),
        failures,
        method: method(problem),
        meshes: ladder.meshes,
    })
}

/// The data points of the extrema, each once, in the order of the extrema.
fn distinct_points(extrema: &Extrema) -> Vec<Vec<f64>> {
    let mut points: Vec<Vec<f64>> = Vec::new();
    for pair in extrema {
        for (_, p) in pair.iter().flatten() {
            if !points.contains(p) {
                points.push(p.clone());
            }
        }
    }
    points
}

/// The run's mesh and its refinements with the criteria at every point on each refinement.
struct Ladder {
    /// The run's mesh first, then one per refinement tried.
    meshes: Vec<StatementMesh>,
    /// values[level − 1][point][criterion].
    values: Vec<Vec<RefinedValues>>,
    /// Whether `control.stop` ended the ladder before its last refinement (or none was asked).
    cut_short: bool,
}

/// Solve `points` on `refinements` refined meshes of `problem`'s, as `control` says.
fn solve_ladder(
    problem: &StateProblem,
    params: &[Parameter],
    criteria: &[CriterionSpec],
    points: &[Vec<f64>],
    refinements: usize,
    control: StatementControl<'_>,
) -> Result<Ladder, WsmError> {
    let base = StatementMesh {
        size_factor: 1.0,
        unknowns: problem.elastic.dofs().n_free(),
        triangles: problem.mesh().triangles.len(),
        seconds: 0.0,
    };
    let mut ladder = Ladder {
        meshes: vec![base],
        values: Vec::new(),
        cut_short: refinements == 0,
    };
    for level in 1..=refinements as u32 {
        if (control.stop)() {
            ladder.cut_short = true;
            break;
        }
        if let Some(reason) = control.refuse_level.and_then(|refuse| refuse(level)) {
            // Not built: every solve on it failed with the reason (listed, warned, incomplete).
            ladder
                .values
                .push(points.iter().map(|_| Err(reason.clone())).collect());
            ladder.meshes.push(StatementMesh {
                size_factor: refinement_factor(level),
                unknowns: 0,
                triangles: 0,
                seconds: 0.0,
            });
            continue;
        }
        let t0 = Instant::now();
        let refined =
            RefinedLevel::new(&problem.scene, params, criteria, level).with_fault(control.fault);
        let Some(solved) = solve_level(&refined, points, control)? else {
            ladder.cut_short = true;
            break;
        };
        // A mesh that cannot be built failed every solve on it (with the reason).
        let (unknowns, triangles) = refined
            .get()
            .map_or((0, 0), |built| (built.unknowns(), built.triangles()));
        ladder.values.push(solved);
        ladder.meshes.push(StatementMesh {
            size_factor: refinement_factor(level),
            unknowns,
            triangles,
            seconds: t0.elapsed().as_secs_f64(),
        });
    }
    Ok(ladder)
}

/// Each criterion's worst and best value with its estimated discretisation error from the
/// ladder's refined values at its point.
fn criterion_accuracies(
    criteria: &[CriterionSpec],
    extrema: &Extrema,
    points: &[Vec<f64>],
    ladder: &Ladder,
) -> Vec<CriterionAccuracy> {
    let h: Vec<f64> = ladder
        .meshes
        .iter()
        .map(|m| (m.unknowns.max(1) as f64).powf(-0.5))
        .collect();
    let accuracy = |k: usize, extremum: &Option<(f64, Vec<f64>)>| {
        let (value, point) = extremum.as_ref()?;
        let index = points.iter().position(|q| q == point)?;
        let mut failures = Vec::new();
        let refined: Vec<Option<f64>> = ladder
            .values
            .iter()
            .zip(1..)
            .map(|(level, number)| match &level[index] {
                Ok(v) => v[k],
                Err(e) => {
                    failures.push(format!("refinement {number}: {e}"));
                    None
                }
            })
            .collect();
        let failure = (!failures.is_empty()).then(|| failures.join("; "));
        Some(extremum_accuracy(*value, refined, &h, failure))
    };
    criteria
        .iter()
        .zip(extrema)
        .enumerate()
        .map(|(k, (criterion, [worst, best]))| CriterionAccuracy {
            criterion: criterion.clone(),
            worst: accuracy(k, worst),
            best: accuracy(k, best),
        })
        .collect()
}

/// How the statement was made, in words for the result.
fn method(problem: &StateProblem) -> String {
    let meshes = if problem.scene.mesh.imported().is_some() {
        "on the run's imported mesh subdivided uniformly (every triangle into four, h halved; and \
         subdivided again when affordable)"
    } else {
        "on the run's mesh with every mesh size halved (and halved again when affordable)"
    };
    format!(
        "the worst and best data of each criterion re-solved (direct solver, cold) {meshes}; \
         estimate = |value − refined value|, or with two refinements |value − Richardson \
         extrapolation| when the three values converge monotonically"
    )
}

/// The solves of `points` on one refined level, dealt out through the dispatch when there is
/// one; `None` when `control.stop` stopped them.
fn solve_level(
    refined: &RefinedLevel<'_>,
    points: &[Vec<f64>],
    control: StatementControl<'_>,
) -> Result<Option<Vec<RefinedValues>>, WsmError> {
    let local = |points: &[Vec<f64>]| refined.solve(points, control.stop);
    let dispatched = match control.dispatch {
        Some(d) => d.refined(refined.level(), points, &local)?,
        None => None,
    };
    let solved = dispatched.unwrap_or_else(|| local(points));
    // One point not solved (stopped) leaves the level without an answer.
    Ok(solved.into_iter().collect())
}

/// The failed solves of `values` (by level, then point), with the extrema at their data.
fn refined_failures(
    criteria: &[CriterionSpec],
    extrema: &Extrema,
    points: &[Vec<f64>],
    values: &[Vec<RefinedValues>],
) -> Vec<RefinedFailure> {
    let at = |point: &Vec<f64>, side: usize| -> Vec<CriterionSpec> {
        criteria
            .iter()
            .zip(extrema)
            .filter(|(_, pair)| pair[side].as_ref().is_some_and(|(_, p)| p == point))
            .map(|(c, _)| c.clone())
            .collect()
    };
    values
        .iter()
        .zip(1..)
        .flat_map(|(level, number)| {
            points.iter().zip(level).filter_map(move |(point, v)| {
                let error = v.as_ref().err()?;
                Some(RefinedFailure {
                    level: number,
                    point: point.clone(),
                    worst_of: at(point, 0),
                    best_of: at(point, 1),
                    error: error.clone(),
                })
            })
        })
        .collect()
}

impl AccuracyStatement {
    /// The statement's warnings in plain words, for the result's `warnings`: one per refined
    /// mesh that could not be built; one per data whose refined solves failed (which extrema,
    /// which refinement and mesh, the error, and that the discretisation error of those values
    /// rests on fewer meshes or is unknown); one when fewer than the `asked` refinements were
    /// made (a cancel or the time limit).
    pub fn warnings(&self, asked: usize) -> Vec<Warning> {
        let built = |f: &&RefinedFailure| self.meshes[f.level as usize].unknowns > 0;
        let mut warnings = Vec::new();
        let mut unbuilt: Vec<u32> = Vec::new();
        for failure in self.failures.iter().filter(|f| !built(f)) {
            if !unbuilt.contains(&failure.level) {
                unbuilt.push(failure.level);
                warnings.push(accuracy(format!(
                    "the mesh of refinement {} (sizes × {}) could not be built: {}. No \
                     discretisation error can be estimated from it.",
                    failure.level, self.meshes[failure.level as usize].size_factor, failure.error
                )));
            }
        }
        let mut seen: Vec<&Vec<f64>> = Vec::new();
        for failure in self.failures.iter().filter(built) {
            if !seen.contains(&&failure.point) {
                seen.push(&failure.point);
                warnings.push(self.failure_warning(&failure.point));
            }
        }
        let made = self.meshes.len() - 1;
        if made < asked {
            let rest = if made == 0 {
                "the discretisation error of every worst and best value is unknown".to_string()
            } else {
                format!("the estimates rest on the {made} refined mesh(es) solved before")
            };
            warnings.push(accuracy(format!(
                "cut short by a cancel or the time limit after {made} of the {asked} refined \
                 meshes asked for; {rest}."
            )));
        }
        warnings
    }

    /// The warning about the failed solves at `point` on the meshes that were built.
    fn failure_warning(&self, point: &[f64]) -> Warning {
        let at_point: Vec<&RefinedFailure> =
            self.failures.iter().filter(|f| f.point == point).collect();
        let first = at_point[0];
        let symbols = |criteria: &[CriterionSpec]| -> String {
            let names: Vec<String> = criteria.iter().map(|c| c.symbol()).collect();
            names.join(", ")
        };
        let mut which = Vec::new();
        if !first.worst_of.is_empty() {
            which.push(format!("the worst data of {}", symbols(&first.worst_of)));
        }
        if !first.best_of.is_empty() {
            which.push(format!("the best data of {}", symbols(&first.best_of)));
        }
        // The refinements (on built meshes) by error, in order: one error said once.
        let mut by_error: Vec<(&str, Vec<String>)> = Vec::new();
        for f in &at_point {
            let mesh = &self.meshes[f.level as usize];
            if mesh.unknowns == 0 {
                continue;
            }
            let on = format!(
                "refinement {} (mesh sizes × {}, {} unknowns)",
                f.level, mesh.size_factor, mesh.unknowns
            );
            match by_error.iter_mut().find(|(e, _)| *e == f.error) {
                Some((_, levels)) => levels.push(on),
                None => by_error.push((&f.error, vec![on])),
            }
        }
        let how: Vec<String> = by_error
            .iter()
            .map(|(error, levels)| format!("on {}: {error}", levels.join(" and ")))
            .collect();
        let values = if first.worst_of.len() + first.best_of.len() == 1 {
            "this value"
        } else {
            "these values"
        };
        let solved: Vec<String> = (1..self.meshes.len() as u32)
            .filter(|level| !at_point.iter().any(|f| f.level == *level))
            .map(|level| format!("refinement {level}"))
            .collect();
        let meaning = if solved.is_empty() {
            format!("The discretisation error of {values} is unknown.")
        } else {
            format!(
                "The discretisation-error estimate of {values} rests on {} alone.",
                solved.join(" and ")
            )
        };
        accuracy(format!(
            "the refined solve at {} failed {}. {meaning}",
            which.join(" and "),
            how.join("; ")
        ))
    }
}

/// A [`WarningKind::Accuracy`] warning about the accuracy statement.
fn accuracy(message: String) -> Warning {
    Warning::new(WarningKind::Accuracy, "accuracy statement", message)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Criterion;

    /// The block on its base, coarse, and the extrema of Φ3 at two corners of its box.
    fn block() -> (StateProblem, Vec<Parameter>, Extrema) {
        let mut scene =
            crate::scene::parse(crate::bundled::find("block-on-base").unwrap()).unwrap();
        scene.mesh.max_size = Some(0.2);
        scene.mesh.refine.clear();
        let params = crate::scene::params::parameters(&scene).unwrap();
        let problem = StateProblem::new(scene).unwrap();
        let low: Vec<f64> = params.iter().map(|p| p.lo).collect();
        let high: Vec<f64> = params.iter().map(|p| p.hi).collect();
        (problem, params, vec![[Some((2.0, high)), Some((1.0, low))]])
    }

    fn run(
        problem: &StateProblem,
        params: &[Parameter],
        extrema: &Extrema,
        refinements: usize,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> AccuracyStatement {
        let control = StatementControl {
            stop,
            dispatch: None,
            fault: None,
            refuse_level: None,
        };
        statement(
            problem,
            params,
            &[Criterion::Phi3.into()],
            extrema,
            refinements,
            control,
        )
        .unwrap()
    }

    #[test]
    fn a_refined_mesh_that_cannot_be_built_fails_its_solves_in_one_warning() {
        let (mut problem, params, extrema) = block();
        // Sizes far too small for the domain: every refined level fails to build.
        problem.scene.mesh.max_size = Some(1e-6);
        let a = run(&problem, &params, &extrema, 2, &|| false);
        assert!(!a.complete);
        assert_eq!(a.meshes.len(), 3, "both refinements were tried");
        assert!(a.meshes[1..].iter().all(|m| m.unknowns == 0));
        assert_eq!(
            a.failures.len(),
            4,
            "2 points × 2 levels: {:#?}",
            a.failures
        );
        assert!(a.failures.iter().all(|f| f
            .error
            .starts_with("mesh.max_size: too small for the domain")));
        assert_eq!(
            a.failures[0].worst_of,
            vec![CriterionSpec::from(Criterion::Phi3)]
        );
        assert!(a.failures[0].best_of.is_empty());
        assert_eq!(
            a.failures[1].best_of,
            vec![CriterionSpec::from(Criterion::Phi3)]
        );
        let worst = a.criteria[0].worst.as_ref().unwrap();
        assert_eq!(worst.refined, vec![None, None]);
        assert!(worst.estimate.is_none());
        let failure = worst.failure.as_ref().unwrap();
        assert!(
            failure.starts_with("refinement 1: mesh.max_size"),
            "{failure}"
        );
        assert!(
            failure.contains("; refinement 2: mesh.max_size"),
            "{failure}"
        );
        let warnings: Vec<String> = a.warnings(2).iter().map(ToString::to_string).collect();
        assert_eq!(warnings.len(), 2, "one per unbuilt mesh: {warnings:#?}");
        assert!(warnings[0].starts_with(
            "accuracy statement: the mesh of refinement 1 (sizes × 0.5) could not be built: \
             mesh.max_size"
        ));
        assert!(warnings[1].contains("refinement 2 (sizes × 0.25)"));
    }

    #[test]
    fn a_statement_cut_short_says_how_far_it_came() {
        let (problem, params, extrema) = block();
        let stopped = run(&problem, &params, &extrema, 2, &|| true);
        assert!(!stopped.complete && stopped.failures.is_empty());
        assert_eq!(stopped.meshes.len(), 1);
        let texts: Vec<String> = stopped
            .warnings(2)
            .iter()
            .map(ToString::to_string)
            .collect();
        assert_eq!(
            texts,
            vec![
                "accuracy statement: cut short by a cancel or the time limit after 0 of the 2 \
                  refined meshes asked for; the discretisation error of every worst and best \
                  value is unknown."
                    .to_string()
            ]
        );
        // Stopped inside a level: the points solved before the stop do not make the level an
        // answer, and the points not solved are no failures.
        let asked = std::sync::atomic::AtomicUsize::new(0);
        let after_one_point = || asked.fetch_add(1, std::sync::atomic::Ordering::SeqCst) >= 2;
        let inside = run(&problem, &params, &extrema, 2, &after_one_point);
        assert!(
            inside.points >= 2,
            "a level with a point solved and one stopped"
        );
        assert!(
            !inside.complete && inside.failures.is_empty(),
            "{inside:#?}"
        );
        assert_eq!(inside.meshes.len(), 1);
        let whole = run(&problem, &params, &extrema, 1, &|| false);
        assert!(whole.complete && whole.warnings(1).is_empty(), "{whole:#?}");
        assert_eq!(
            whole.warnings(2)[0].to_string(),
            "accuracy statement: cut short by a cancel or the time limit after 1 of the 2 \
             refined meshes asked for; the estimates rest on the 1 refined mesh(es) solved before."
        );
    }
}
