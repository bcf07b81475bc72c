//! The search driver (design §4.3, with the exact derivatives of §4.4): validates the problem, runs
//! the phases in order and splits the budget B between them. With k free parameters and m
//! objectives:
//!
//! - with derivatives from the evaluator, the vertex walk comes first; the objectives it settles
//!   (certified at a vertex, monotone along the walk) are done, and only the others — the
//!   unsettled ones — go through the phases below, which then need no reserve (R = 0);
//! - R = min(k·m, B/2) evaluations are reserved for the sensitivities (k per objective);
//! - screening (shared): the 2^k vertices and the centre if 2^k + 1 ≤ B/3, topped up with a
//!   Latin hypercube to B/5 points in all (never more than B − R);
//! - unsettled objective j (in order) gets the share (B − R − used) / (m' − j) of what is left
//!   (m' unsettled objectives), so whatever
//!   an objective leaves unused flows on to the next ones. Its swarm may use 40 % of the share;
//!   the polish uses the rest of the share (including what the swarm left):
//!   - coarse polishes (step 0.1 → 1e-3) from the basin tops of all points evaluated so far
//!     (nearest-better clustering, top half of the observed range of values): the best point,
//!     then up to two runner-ups, each allowed a third of what is left and stopped as soon as it
//!     joins the basin of an earlier end — this recovers a better basin the swarm abandoned;
//!   - fine polishes (step 1e-3 → 1e-8, or a flat poll) from the best coarse end, then from
//!     distinct ends (farther than 0.1 apart) within 1e-3 relative of it, so that several
//!     maximisers are refined to 1e-9 and reported;
//! - the sensitivities at every optimum come last, from what is left (at least R), or from the
//!   derivatives at no cost; so does the [`Certificate`](super::Certificate) of every extremum,
//!   whose verdict turns the status of a converged objective into `certified`.
//!
//! Cancellation and the time limit stop everything at the next batch; the partial result is
//! returned with that status.

use super::cache::EvalCache;
use super::certificate::{self, Certificate};
use super::global::{self, Global};
use super::optima::{self, OPTIMUM_TOL};
use super::random::stream;
use super::session::{Probe, Session};
use super::space::{is_vertex, Space};
use super::{
    polish::{self, Stage},
    pso, screening, sensitivity, vertex_walk, Evaluator, ObjectiveResult, Phase, SearchControl,
    SearchError, SearchProblem, SearchResult, Status, Verdict,
};
use std::collections::BTreeMap;

/// Fraction of an objective's share for the swarm.
const SWARM_FRACTION: f64 = 0.4;
/// Runner-up basin tops polished when budget remains, and the top fraction of the observed
/// range of values they must lie in.
const RUNNERS_UP: usize = 2;
const RUNNER_UP_GAP: f64 = 0.5;
/// Basin tops this close (relative) to the best after the coarse polish are all refined.
const TIE_TOL: f64 = 1e-3;

/// Local searches that end this close (unit box) to the reported point reached the same point.
const SAME_POINT: f64 = 1e-6;

/// Random stream ids.
const SCREENING_STREAM: u64 = 0;
const SWARM_STREAM: u64 = 1;

fn is_halt(status: Status) -> bool {
    matches!(status, Status::TimeLimit | Status::Cancelled)
}

/// Find the extrema of `problem.objectives` over `problem.bounds`, evaluating through `cache`
/// (pre-load it to resume a job; it holds every evaluation afterwards, in order).
pub fn search(
    problem: &SearchProblem,
    evaluator: &dyn Evaluator,
    cache: &mut EvalCache,
    control: SearchControl<'_>,
) -> Result<SearchResult, SearchError> {
    if problem.objectives.is_empty() {
        return Err(SearchError::NoObjectives);
    }
    let space = Space::new(&problem.bounds)?;
    let session = Session::new(
        &space,
        &problem.objectives,
        evaluator,
        control,
        problem.budget,
        problem.max_seconds,
        cache,
    );
    let derivatives = evaluator.gives_derivatives() && space.dim() > 0;
    let (statuses, global) = if derivatives {
        vertex_walk::run(&session);
        let mut global = Global::new(&session, problem.stop);
        let statuses = global.run(problem.seed);
        (statuses, Some(global))
    } else {
        (run_phases(&session, problem.seed)?, None)
    };
    let sensitivities = if derivatives {
        exact_sensitivities(&session)
    } else {
        sensitivity_phase(&session)
    };
    let objectives: Vec<ObjectiveResult> = statuses
        .into_iter()
        .zip(sensitivities)
        .enumerate()
        .map(|(k, (status, s))| {
            let mut result = objective_result(&session, k, status, s, &problem.names);
            result.global = match &global {
                Some(g) => g.evidence(
                    k,
                    session
                        .best_probe(k)
                        .as_ref()
                        .map(|p| (p.unit.as_slice(), p.value)),
                ),
                None => global::without_derivatives(&session, problem.stop),
            };
            result
        })
        .collect();
    let status = objectives
        .iter()
        .map(|o| o.status)
        .chain(session.halt())
        .max()
        .unwrap_or(Status::Completed);
    Ok(SearchResult {
        status,
        objectives,
        evaluations: session.evaluations(),
        new_evaluations: session.fresh_evaluations(),
        elapsed: session.elapsed(),
    })
}

/// Without derivatives: screening, then swarm and polish per objective; the status of each.
/// Evaluations are reserved for the finite-difference sensitivities.
fn run_phases(session: &Session, seed: u64) -> Result<Vec<Status>, SearchError> {
    let budget = session.budget();
    let dim = session.space.dim();
    let m = session.objectives().len();
    let reserve = (dim * m).min(budget / 2);
    session.set_phase(Phase::Screening);
    let design = screening::design(
        dim,
        budget,
        budget - reserve,
        &mut stream(seed, SCREENING_STREAM),
    );
    // A refused screening batch can only be a halt, which every later phase sees too.
    let _ = session.evaluate(&design);

    let mut statuses = Vec::with_capacity(m);
    for k in 0..m {
        if let Some(halt) = session.check_halt() {
            statuses.push(halt);
            continue;
        }
        let used = session.evaluations();
        let share = budget.saturating_sub(reserve + used) / (m - k);
        let swarm_limit = used + (SWARM_FRACTION * share as f64) as usize;
        let polish_limit = used + share;

        session.set_phase(Phase::Global { objective: k });
        pso::run(
            session,
            k,
            swarm_limit,
            stream(seed, SWARM_STREAM + k as u64),
        )?;

        session.set_phase(Phase::Polish { objective: k });
        let status = polish_objective(session, k, polish_limit)?;
        statuses.push(session.halt().unwrap_or(status));
    }
    Ok(statuses)
}

/// Coarse polishes from the basin tops of the sample in the top half of its range of values
/// (best first; a runner-up may use at most a third of what is left), then fine polishes from the
/// distinct ends (farther than 0.1 apart) within 1e-3 relative of the best end — the best end
/// and its ties, possibly several maximisers. The status of the fine polish of the best end.
fn polish_objective(session: &Session, k: usize, limit: usize) -> Result<Status, SearchError> {
    let Some(tops) = basin_tops(session, k) else {
        return Ok(Status::BudgetExhausted);
    };
    if session.space.dim() == 0 {
        // The single point is the whole box.
        return Ok(Status::Completed);
    }
    // (point, cost) where each coarse polish ended.
    let mut ends: Vec<(Vec<f64>, f64)> = Vec::new();
    for (i, x) in tops.into_iter().enumerate() {
        let cap = runner_up_cap(session, i, limit);
        let finish = polish::run(session, k, x, Stage::Coarse, cap, &ends)?;
        if is_halt(finish.status) {
            return Ok(finish.status);
        }
        ends.extend(finish.best);
    }
    // Back to scores (larger is better), best first, for the clustering.
    let mut scored: Vec<(Vec<f64>, f64)> = ends.into_iter().map(|(x, c)| (x, -c)).collect();
    scored.sort_by(|a, b| b.1.total_cmp(&a.1));
    let ties = optima::representatives(&scored, TIE_TOL, 1 + RUNNERS_UP);
    // No end at all: nothing feasible to polish, or no budget for it.
    let mut status = Status::BudgetExhausted;
    for (i, x) in ties.into_iter().enumerate() {
        let cap = runner_up_cap(session, i, limit);
        let finish = polish::run(session, k, x, Stage::Fine, cap, &[])?;
        if is_halt(finish.status) {
            return Ok(finish.status);
        }
        if i == 0 {
            status = finish.status;
        }
    }
    Ok(status)
}

/// The starts of the local searches of objective `k`: the basin tops of all points evaluated so
/// far in the top half of their range of values, best first, at most 1 + `RUNNERS_UP` (`None`
/// while no point is feasible).
fn basin_tops(session: &Session, k: usize) -> Option<Vec<Vec<f64>>> {
    let ranked = session.ranked(k);
    let (Some((_, best)), Some((_, worst))) = (ranked.first(), ranked.last()) else {
        return None;
    };
    Some(optima::basin_tops(
        &ranked,
        best - RUNNER_UP_GAP * (best - worst),
        1 + RUNNERS_UP,
    ))
}

/// The evaluation limit of the `i`-th polish of a stage: the first may use everything up to
/// `limit`, the others a third of what is left.
fn runner_up_cap(session: &Session, i: usize, limit: usize) -> usize {
    let used = session.evaluations();
    if i == 0 {
        limit
    } else {
        used + limit.saturating_sub(used) / 3
    }
}

/// Normalised sensitivities at every objective's best point (`None` where not evaluated).
fn sensitivity_phase(session: &Session) -> Vec<Vec<Option<f64>>> {
    session.set_phase(Phase::Sensitivity);
    let n = session.space.len();
    (0..session.objectives().len())
        .map(|k| {
            let Some((x, value)) = session.best(k) else {
                return vec![None; n];
            };
            let values = session
                .values(&sensitivity::steps(&x), k)
                .unwrap_or_else(|_| vec![None; x.len()]);
            sensitivity::normalised(session.space, &x, value, &values)
        })
        .collect()
}

/// Normalised sensitivities from the derivatives at every objective's best point: the mean of
/// both one-sided slopes times the range over |Φ| (`None` for fixed data, Φ = 0, or no slopes).
fn exact_sensitivities(session: &Session) -> Vec<Vec<Option<f64>>> {
    let space = session.space;
    (0..session.objectives().len())
        .map(|k| {
            let mut s = vec![None; space.len()];
            let Some(probe) = session.best_probe(k) else {
                return s;
            };
            let Some(slopes) = probe.slopes.filter(|_| probe.value != 0.0) else {
                return s;
            };
            for j in 0..space.dim() {
                let (i, width) = space.free_param(j);
                s[i] = Some(slopes[i].mean() * width / probe.value.abs());
            }
            s
        })
        .collect()
}

/// The certificate of objective `k`'s best point, and its status: a converged (or settled)
/// objective whose best point is certified is `certified`; one that claims convergence without
/// that proof is `completed` (the caller says it is unproven).
fn certified(
    session: &Session,
    k: usize,
    probe: Option<&Probe>,
    status: Status,
) -> (Option<Certificate>, Status) {
    let Some(probe) = probe else {
        return (None, status);
    };
    let sense = session.objectives()[k].sense;
    let mut proof = certificate::certify(
        session.space,
        sense,
        &probe.unit,
        probe.value,
        probe.slopes.as_deref(),
    );
    proof.starts = session.ends_near(k, &probe.unit, SAME_POINT);
    if let (Verdict::NotOptimal, Some(slopes)) = (proof.verdict, probe.slopes.as_deref()) {
        let neighbours = session.neighbours(k, &probe.unit, certificate::KINK_RADIUS);
        proof.kink = certificate::kink(
            session.space,
            sense,
            (&probe.unit, probe.value, slopes),
            &neighbours,
        );
    }
    let status = match (status, proof.verdict) {
        (
            Status::LocallyCertified
            | Status::Completed
            | Status::BudgetExhausted
            | Status::Stagnated,
            Verdict::LocallyCertified,
        ) => Status::LocallyCertified,
        (Status::LocallyCertified, _) => Status::Completed,
        (status, _) => status,
    };
    (Some(proof), status)
}

/// Per-parameter `values` keyed by the parameters' `names` (`θ<index>` for an unnamed one).
fn by_name<T>(names: &[String], values: Vec<T>) -> BTreeMap<String, T> {
    values
        .into_iter()
        .enumerate()
        .map(|(i, v)| (names.get(i).cloned().unwrap_or_else(|| format!("θ{i}")), v))
        .collect()
}

fn objective_result(
    session: &Session,
    k: usize,
    status: Status,
    sensitivities: Vec<Option<f64>>,
    names: &[String],
) -> ObjectiveResult {
    let objective = session.objectives()[k];
    let space = session.space;
    let best = session.best_probe(k);
    let (certificate, status) = certified(session, k, best.as_ref(), status);
    let best_point = best.as_ref().map(|p| space.to_physical(&p.unit));
    let gradient = by_name(
        names,
        best.as_ref()
            .and_then(|p| p.slopes.clone())
            .unwrap_or_default(),
    );
    let data = by_name(names, best_point.clone().unwrap_or_default());
    let ranked = session.ranked(k);
    let optima: Vec<Vec<f64>> = optima::representatives(&ranked, OPTIMUM_TOL, usize::MAX)
        .iter()
        .map(|x| space.to_physical(x))
        .collect();
    ObjectiveResult {
        criterion: objective.criterion,
        sense: objective.sense,
        value: best.as_ref().map(|p| p.value),
        point: best_point,
        region: None,
        time: None,
        status,
        at_vertex: best.as_ref().is_some_and(|p| is_vertex(&p.unit)),
        vertex_optimal: optima::vertex_optimal(&ranked),
        several_optima: optima.len() > 1,
        optima,
        active_bounds: best
            .as_ref()
            .map_or_else(Vec::new, |p| space.active_bounds(&p.unit)),
        sensitivities,
        data,
        gradient,
        certificate,
        global: Default::default(),
        history: session.history(k),
    }
}
