//! The search driver (SPEC §4.3): validates the problem, runs the phases in order and splits the
//! budget B between them. With k free parameters and m objectives:
//!
//! - R = min(k·m, B/2) evaluations are reserved for the sensitivities (k per objective);
//! - screening: the vertices and the centre if 2^k + 1 ≤ B/3, else a Latin hypercube of B/5
//!   points (never more than B − R);
//! - objective j (in order) gets the share (B − R − used) / (m − j) of what is left, so whatever
//!   an objective leaves unused flows on to the next ones: its swarm may use 60 % of the share,
//!   the polish of the best point the rest of the share (including what the swarm left); what
//!   the polish leaves polishes up to two runner-up points (within 10 % of the best, farther than
//!   0.1 away) so that a second maximiser is found and reported;
//! - the sensitivities at every optimum come last, from what is left (at least R).
//!
//! Cancellation and the time limit stop everything at the next batch; the partial result is
//! returned with that status.

use super::cache::EvalCache;
use super::optima::{self, OPTIMUM_TOL};
use super::random::stream;
use super::session::Session;
use super::space::{is_vertex, Space};
use super::{
    polish, pso, screening, sensitivity, Evaluator, ObjectiveResult, Phase, SearchControl,
    SearchError, SearchProblem, SearchResult, Status,
};

/// Fraction of an objective's share for the swarm.
const SWARM_FRACTION: f64 = 0.6;
/// Runner-up points polished when budget remains, and how close to the best they must be.
const EXTRA_POLISHES: usize = 2;
const RUNNER_UP_TOL: f64 = 0.1;

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
    let statuses = run_phases(&session, problem.seed)?;
    let sensitivities = sensitivity_phase(&session);
    let objectives: Vec<ObjectiveResult> = statuses
        .into_iter()
        .zip(sensitivities)
        .enumerate()
        .map(|(k, (status, s))| objective_result(&session, k, status, s))
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

/// Screening, then swarm and polish per objective; the status of each objective.
fn run_phases(session: &Session, seed: u64) -> Result<Vec<Status>, SearchError> {
    let budget = session.budget();
    let dim = session.space.dim();
    let m = session.objectives().len();
    let reserve = (dim * m).min(budget / 2);
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
        let status = match session.best(k) {
            Some((x, _)) => polish::run(session, k, x, polish_limit)?,
            None => Status::BudgetExhausted,
        };
        if !is_halt(status) {
            polish_runners_up(session, k, polish_limit)?;
        }
        statuses.push(session.halt().unwrap_or(status));
    }
    Ok(statuses)
}

/// Polish the best points of other near-optimal clusters with what the objective's share left.
fn polish_runners_up(session: &Session, k: usize, limit: usize) -> Result<(), SearchError> {
    let ranked = session.ranked(k);
    let runners_up = optima::representatives(&ranked, RUNNER_UP_TOL, 1 + EXTRA_POLISHES);
    for x in runners_up.into_iter().skip(1) {
        if is_halt(polish::run(session, k, x, limit)?) {
            break;
        }
    }
    Ok(())
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

fn objective_result(
    session: &Session,
    k: usize,
    status: Status,
    sensitivities: Vec<Option<f64>>,
) -> ObjectiveResult {
    let objective = session.objectives()[k];
    let space = session.space;
    let best = session.best(k);
    let ranked = session.ranked(k);
    let optima: Vec<Vec<f64>> = optima::representatives(&ranked, OPTIMUM_TOL, usize::MAX)
        .iter()
        .map(|x| space.to_physical(x))
        .collect();
    ObjectiveResult {
        criterion: objective.criterion,
        sense: objective.sense,
        best_value: best.as_ref().map(|(_, v)| *v),
        best_point: best.as_ref().map(|(x, _)| space.to_physical(x)),
        status,
        at_vertex: best.as_ref().is_some_and(|(x, _)| is_vertex(x)),
        vertex_optimal: optima::vertex_optimal(&ranked),
        several_optima: optima.len() > 1,
        optima,
        active_bounds: best
            .as_ref()
            .map_or_else(Vec::new, |(x, _)| space.active_bounds(x)),
        sensitivities,
        history: session.history(k),
    }
}
