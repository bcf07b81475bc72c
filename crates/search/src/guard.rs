//! Stopping rules for any argmin solver of a phase (design §4.3 item 4): a [`Guard`] wraps the
//! solver and, before every iteration, stops it on cancellation, wall time, the phase's share of
//! the budget (an iteration is only started if a whole batch of `batch` new points still fits),
//! or stagnation (no relative improvement above 1e-9 of the best cost in `stall_window`
//! iterations). [`run`] drives a guarded solver with argmin's `Executor` and says why it stopped
//! and where it ended.

use super::session::{Session, Stop};
use super::{SearchError, Status};
use argmin::core::{
    CostFunction, Error, Executor, Problem, Solver, State, TerminationReason, TerminationStatus, KV,
};

/// Relative improvement below which an iteration counts as stagnant.
pub(super) const STALL_TOL: f64 = 1e-9;

pub(super) struct Guard<'s, 'a, S> {
    inner: S,
    session: &'s Session<'a>,
    /// The phase may use evaluations up to this count.
    limit: usize,
    /// Most new points one iteration can ask for.
    batch: usize,
    stall_window: usize,
    best_seen: f64,
    stalled_for: usize,
    /// Why the guard (or the inner solver, `Completed`) stopped the run.
    stop: Option<Status>,
}

impl<'s, 'a, S> Guard<'s, 'a, S> {
    pub(super) fn new(
        inner: S,
        session: &'s Session<'a>,
        limit: usize,
        batch: usize,
        stall_window: usize,
    ) -> Self {
        Guard {
            inner,
            session,
            limit,
            batch,
            stall_window,
            best_seen: f64::INFINITY,
            stalled_for: 0,
            stop: None,
        }
    }

    fn check(&mut self, best: f64) -> Option<Status> {
        if let Some(halt) = self.session.check_halt() {
            return Some(halt);
        }
        if self.session.evaluations() + self.batch > self.limit {
            return Some(Status::BudgetExhausted);
        }
        let improved = if self.best_seen.is_finite() {
            self.best_seen - best > STALL_TOL * self.best_seen.abs()
        } else {
            best < self.best_seen
        };
        if improved {
            self.best_seen = best;
            self.stalled_for = 0;
        } else {
            self.stalled_for += 1;
        }
        (self.stalled_for >= self.stall_window).then_some(Status::Stagnated)
    }
}

impl<O, I, S> Solver<O, I> for Guard<'_, '_, S>
where
    I: State<Float = f64>,
    S: Solver<O, I>,
{
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn init(&mut self, problem: &mut Problem<O>, state: I) -> Result<(I, Option<KV>), Error> {
        self.inner.init(problem, state)
    }

    fn next_iter(&mut self, problem: &mut Problem<O>, state: I) -> Result<(I, Option<KV>), Error> {
        self.inner.next_iter(problem, state)
    }

    fn terminate(&mut self, state: &I) -> TerminationStatus {
        let own = self.inner.terminate(state);
        let stop = if own.terminated() {
            Some(Status::Completed)
        } else {
            self.check(state.get_best_cost())
        };
        match stop {
            Some(status) => {
                self.stop = Some(status);
                if own.terminated() {
                    own
                } else {
                    TerminationStatus::Terminated(TerminationReason::SolverExit(format!(
                        "{status:?}"
                    )))
                }
            }
            None => TerminationStatus::NotTerminated,
        }
    }
}

/// How a guarded run ended: why, and its best parameter and cost (`None` if a batch was refused
/// mid-iteration, which loses argmin's state).
pub(super) struct Finish<P> {
    pub(super) status: Status,
    pub(super) best: Option<(P, f64)>,
}

/// Run a guarded solver from `state` with argmin's `Executor`.
pub(super) fn run<O, I, S>(
    cost: O,
    guard: Guard<'_, '_, S>,
    state: I,
) -> Result<Finish<I::Param>, SearchError>
where
    O: CostFunction,
    I: State<Float = f64>,
    I::Param: Clone,
    S: Solver<O, I>,
{
    let result = Executor::new(cost, guard)
        .configure(|_| state)
        .ctrlc(false)
        .run();
    match result {
        Ok(done) => Ok(Finish {
            status: done.solver().stop.unwrap_or(Status::BudgetExhausted),
            best: done
                .state()
                .get_best_param()
                .map(|p| (p.clone(), done.state().get_best_cost())),
        }),
        Err(e) => match e.downcast_ref::<Stop>() {
            Some(Stop(status)) => Ok(Finish {
                status: *status,
                best: None,
            }),
            None => Err(SearchError::Solver(e.to_string())),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cache::EvalCache;
    use crate::space::Space;
    use crate::{Evaluator, Objective, Outcome, SearchControl, Sense};
    use std::sync::atomic::{AtomicBool, Ordering};

    struct Constant;
    impl Evaluator for Constant {
        fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Outcome> {
            points.iter().map(|_| Ok(vec![1.0].into())).collect()
        }
    }

    #[test]
    fn stops_on_stall_budget_and_cancel() {
        let space = Space::new(&[[0.0, 1.0]]).unwrap();
        let objectives = [Objective {
            criterion: 0,
            sense: Sense::Max,
        }];
        let cancel = AtomicBool::new(false);
        let control = SearchControl {
            cancel: &cancel,
            on_progress: &|_| {},
        };
        let mut cache = EvalCache::new();
        let session = Session::new(
            &space,
            &objectives,
            &Constant,
            control,
            10,
            None,
            &mut cache,
        );
        session.evaluate(&[vec![0.5], vec![0.25]]).unwrap();

        let mut guard = Guard::new((), &session, 10, 4, 3);
        assert_eq!(guard.check(-1.0), None, "first finite cost improves on ∞");
        assert_eq!(guard.check(-2.0), None);
        // Gains of 1e-10 relative do not count.
        assert_eq!(guard.check(-2.0 - 2e-10), None);
        assert_eq!(guard.check(-2.0 - 4e-10), None);
        assert_eq!(guard.check(-2.0 - 6e-10), Some(Status::Stagnated));

        // 2 evaluations used: a batch of 4 fits under 6, not under 5.
        assert_eq!(Guard::new((), &session, 6, 4, 3).check(0.0), None);
        assert_eq!(
            Guard::new((), &session, 5, 4, 3).check(0.0),
            Some(Status::BudgetExhausted)
        );
        cancel.store(true, Ordering::SeqCst);
        assert_eq!(
            Guard::new((), &session, 6, 4, 3).check(0.0),
            Some(Status::Cancelled)
        );
    }
}
