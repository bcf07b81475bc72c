//! Phase 3, local polish (design §4.3 item 3): a bounded compass (coordinate pattern) search,
//! written as an argmin `Solver` because argmin has no bounded derivative-free local method.
//!
//! Each iteration polls x ± s·e_i for every coordinate i, projected onto the unit box (a poll
//! point that projects back onto x is dropped), as one `bulk_cost` batch of at most 2k points.
//! The best poll point replaces x if it is strictly better; otherwise s is halved. A polish
//! started from a runner-up stops as soon as it comes within 0.1 of a known, no worse end of an
//! earlier polish: it has joined that basin. The search
//! has converged when s falls below 1e-8 (of the unit box), or earlier when a failed poll is
//! flat: every poll value within 1e-9 relative of Φ(x). At a smooth interior optimum the poll
//! values differ from Φ(x) by O(s²), so Φ(x) is then within about 1e-9 of the local optimum
//! and halving on would only refine the position.

use super::cost::ObjectiveCost;
use super::guard::{self, Finish, Guard};
use super::optima::SEPARATION;
use super::session::Session;
use super::space::distance;
use super::SearchError;
use argmin::core::{
    CostFunction, Error, IterState, Problem, Solver, State, TerminationReason, TerminationStatus,
    KV,
};

/// First poll step (unit box).
const INITIAL_STEP: f64 = 0.1;
/// The coarse stage ends below this step (unit box).
const COARSE_STEP: f64 = 1e-3;
/// Converged below this step (unit box).
const MIN_STEP: f64 = 1e-8;
/// Converged when a failed poll has every value within this relative distance of Φ(x).
const FLAT_TOL: f64 = 1e-9;
/// Poll coordinates this close to a bound are put on it, so that rounding in x ± s cannot
/// leave the search a few ulps inside the box (far below `MIN_STEP`).
const SNAP: f64 = 1e-12;
/// Iterations without relative improvement above 1e-9 before giving up. Halving alone takes at
/// most ⌈log2(1e-3 / 1e-8)⌉ = 17 iterations in a stage, so a clean convergence is never
/// mistaken for a stall.
const STALL_ITERATIONS: usize = 30;

type Point = IterState<Vec<f64>, (), (), (), (), f64>;

pub(super) struct CompassSearch {
    step: f64,
    min_step: f64,
    /// Ends (point, cost) of earlier polishes: reaching one's basin ends this one.
    known: Vec<(Vec<f64>, f64)>,
    /// The last poll failed and was flat.
    flat: bool,
}

impl CompassSearch {
    pub(super) fn new(step: f64, min_step: f64, known: Vec<(Vec<f64>, f64)>) -> Self {
        CompassSearch {
            step,
            min_step,
            known,
            flat: false,
        }
    }

    /// Poll points around `x`, projected onto [0, 1]^k (and snapped onto a bound closer than
    /// `SNAP`), without those equal to `x`.
    fn poll(&self, x: &[f64]) -> Vec<Vec<f64>> {
        let mut points = Vec::with_capacity(2 * x.len());
        for i in 0..x.len() {
            for sign in [1.0, -1.0] {
                let mut y = x.to_vec();
                y[i] = match x[i] + sign * self.step {
                    t if t <= SNAP => 0.0,
                    t if t >= 1.0 - SNAP => 1.0,
                    t => t,
                };
                if y[i] != x[i] {
                    points.push(y);
                }
            }
        }
        points
    }
}

impl<O> Solver<O, Point> for CompassSearch
where
    O: CostFunction<Param = Vec<f64>, Output = f64>,
{
    fn name(&self) -> &str {
        "Bounded compass search"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: Point,
    ) -> Result<(Point, Option<KV>), Error> {
        let x = state
            .get_param()
            .ok_or_else(|| Error::msg("compass search needs a starting point"))?;
        let cost = problem.cost(x)?;
        Ok((state.cost(cost), None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        mut state: Point,
    ) -> Result<(Point, Option<KV>), Error> {
        let x = state
            .take_param()
            .ok_or_else(|| Error::msg("compass search lost its point"))?;
        let fx = state.get_cost();
        let polls = self.poll(&x);
        let costs = problem.bulk_cost(&polls)?;
        self.flat = costs.iter().all(|c| (c - fx).abs() <= FLAT_TOL * fx.abs());
        // The first strictly smallest cost wins, so ties are broken by poll order.
        let best =
            polls
                .into_iter()
                .zip(costs)
                .fold(None, |best: Option<(Vec<f64>, f64)>, (y, c)| match best {
                    Some((_, b)) if b <= c => best,
                    _ => Some((y, c)),
                });
        Ok(match best {
            Some((y, c)) if c < fx => {
                self.flat = false;
                (state.param(y).cost(c), None)
            }
            _ => {
                self.step *= 0.5;
                (state.param(x).cost(fx), None)
            }
        })
    }

    fn terminate(&mut self, state: &Point) -> TerminationStatus {
        let joined = state.get_param().is_some_and(|x| {
            self.known
                .iter()
                .any(|(y, c)| *c <= state.get_cost() && distance(x, y) <= SEPARATION)
        });
        if self.flat || self.step < self.min_step || joined {
            TerminationStatus::Terminated(TerminationReason::SolverConverged)
        } else {
            TerminationStatus::NotTerminated
        }
    }
}

/// How far a polish refines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Stage {
    /// Step 0.1 down to 1e-3: climbs to the top of a basin cheaply.
    Coarse,
    /// Step 1e-3 down to 1e-8 (or a flat poll): refines the best basin.
    Fine,
}

/// Polish objective `k` from the evaluated unit point `start` until the stage's last step, a
/// flat poll, a stall, the basin of one of the `known` (point, cost) at no better cost, or the
/// run's evaluation count would pass `limit`; the best point and cost reached are in the
/// [`Finish`].
pub(super) fn run(
    session: &Session,
    k: usize,
    start: Vec<f64>,
    stage: Stage,
    limit: usize,
    known: &[(Vec<f64>, f64)],
) -> Result<Finish<Vec<f64>>, SearchError> {
    let dim = start.len();
    let cost = ObjectiveCost {
        session,
        objective: k,
    };
    let solver = match stage {
        Stage::Coarse => CompassSearch::new(INITIAL_STEP, COARSE_STEP, known.to_vec()),
        Stage::Fine => CompassSearch::new(COARSE_STEP, MIN_STEP, known.to_vec()),
    };
    let guard = Guard::new(solver, session, limit, 2 * dim, STALL_ITERATIONS);
    guard::run(cost, guard, Point::new().param(start))
}

#[cfg(test)]
mod tests {
    use super::*;
    use argmin::core::Executor;

    #[test]
    fn poll_projects_and_drops_the_centre() {
        let c = CompassSearch::new(0.25, 1e-8, Vec::new());
        assert_eq!(
            c.poll(&[1.0, 0.1]),
            vec![vec![0.75, 0.1], vec![1.0, 0.35], vec![1.0, 0.0]]
        );
    }

    /// On its own (plain argmin `Executor`), the solver converges onto a bound.
    #[test]
    fn converges_to_a_bounded_minimum() {
        struct Bowl;
        impl CostFunction for Bowl {
            type Param = Vec<f64>;
            type Output = f64;
            fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
                Ok((x[0] - 0.3).powi(2) + (x[1] + 2.0).powi(2))
            }
        }
        let done = Executor::new(Bowl, CompassSearch::new(0.1, 1e-10, Vec::new()))
            .configure(|s| s.param(vec![0.9, 0.9]).max_iters(10_000))
            .ctrlc(false)
            .run()
            .unwrap();
        let best = done.state().get_best_param().unwrap();
        // Stopped by the flat poll: |Φ(x ± s) − Φ(x)| ≈ s² ≤ 4e-9 once s ≈ 6e-5.
        assert!((best[0] - 0.3).abs() < 1e-4, "{best:?}");
        assert_eq!(best[1], 0.0);
        assert_eq!(
            done.state().get_termination_reason(),
            Some(&TerminationReason::SolverConverged)
        );
    }
}
