//! Phase 2, global search for one objective (design §4.3 item 2): argmin's `ParticleSwarm`
//! (SPSO 2011 weights; positions clamped to the box after every move) on the unit box.
//!
//! Seeding: argmin's swarm accepts a ready population (`PopulationState::population`) in place
//! of its own random one, so [`SeededSwarm`] builds that population in its `init` — the best
//! points evaluated so far (the screening, plus earlier objectives' searches) fill up to half of
//! the swarm, uniform random points the rest, velocities uniform in [−x, 1 − x] per coordinate
//! (SPSO 2011) — evaluates it as one batch with `bulk_cost` and hands it to
//! `ParticleSwarm::init`; every generation after that is argmin's own `next_iter`, one batch.

use super::cost::ObjectiveCost;
use super::guard::{self, Guard};
use super::random::{uniform, Rng};
use super::session::Session;
use super::SearchError;
use argmin::core::{CostFunction, Error, PopulationState, Problem, Solver, State, KV};
use argmin::solver::particleswarm::{Particle, ParticleSwarm};

/// Generations without relative improvement above 1e-9 after which the swarm is stopped.
const STALL_GENERATIONS: usize = 8;
/// A swarm smaller than this is not worth running: the share goes to the polish.
const MIN_SWARM: usize = 4;

type Swarm = PopulationState<Particle<Vec<f64>, f64>, f64>;

/// SPSO 2006's swarm size 10 + ⌊2√k⌋, reduced so that the initial population and at least three
/// generations fit in `evaluations`.
pub(super) fn swarm_size(dim: usize, evaluations: usize) -> usize {
    (10 + (2.0 * (dim as f64).sqrt()) as usize).min(evaluations / 4)
}

struct SeededSwarm {
    swarm: ParticleSwarm<Vec<f64>, f64, Rng>,
    /// (position, velocity) of every particle.
    start: Vec<(Vec<f64>, Vec<f64>)>,
}

impl<O> Solver<O, Swarm> for SeededSwarm
where
    O: CostFunction<Param = Vec<f64>, Output = f64>,
{
    fn name(&self) -> &str {
        "Particle Swarm Optimization (seeded)"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: Swarm,
    ) -> Result<(Swarm, Option<KV>), Error> {
        let positions: Vec<Vec<f64>> = self.start.iter().map(|(p, _)| p.clone()).collect();
        let costs = problem.bulk_cost(&positions)?;
        let particles = self
            .start
            .drain(..)
            .zip(costs)
            .map(|((position, velocity), cost)| Particle::new(position, cost, velocity))
            .collect();
        self.swarm.init(problem, state.population(particles))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        state: Swarm,
    ) -> Result<(Swarm, Option<KV>), Error> {
        self.swarm.next_iter(problem, state)
    }
}

/// The initial swarm: the `size / 2` best points so far, then random ones.
fn initial_particles(
    best: Vec<Vec<f64>>,
    size: usize,
    dim: usize,
    rng: &mut Rng,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut positions: Vec<Vec<f64>> = best.into_iter().take(size / 2).collect();
    while positions.len() < size {
        positions.push((0..dim).map(|_| uniform(rng)).collect());
    }
    positions
        .into_iter()
        .map(|x| {
            let v = x.iter().map(|&xj| uniform(rng) - xj).collect();
            (x, v)
        })
        .collect()
}

/// Run the swarm for objective `k` until the run's evaluation count would pass `limit` (or a
/// halt or stagnation), with random stream `rng`.
pub(super) fn run(
    session: &Session,
    k: usize,
    limit: usize,
    mut rng: Rng,
) -> Result<(), SearchError> {
    let dim = session.space.dim();
    let size = swarm_size(dim, limit.saturating_sub(session.evaluations()));
    if dim == 0 || size < MIN_SWARM {
        return Ok(());
    }
    let best = session.ranked(k).into_iter().map(|(u, _)| u).collect();
    let start = initial_particles(best, size, dim, &mut rng);
    let swarm = ParticleSwarm::new((vec![0.0; dim], vec![1.0; dim]), size).with_rng_generator(rng);
    let solver = SeededSwarm { swarm, start };
    let cost = ObjectiveCost {
        session,
        objective: k,
    };
    let guard = Guard::new(solver, session, limit, size, STALL_GENERATIONS);
    guard::run(cost, guard, Swarm::new()).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::super::random::stream;
    use super::*;

    #[test]
    fn seeds_fill_half_the_swarm_and_velocities_stay_in_the_box() {
        let best = vec![
            vec![1.0, 0.0],
            vec![0.5, 0.5],
            vec![0.0, 0.0],
            vec![0.2, 0.2],
        ];
        let p = initial_particles(best, 5, 2, &mut stream(1, 1));
        assert_eq!(p.len(), 5);
        assert_eq!(p[0].0, vec![1.0, 0.0]);
        assert_eq!(p[1].0, vec![0.5, 0.5]);
        assert_ne!(p[2].0, vec![0.0, 0.0]);
        for (x, v) in &p {
            for (xj, vj) in x.iter().zip(v) {
                assert!((0.0..=1.0).contains(&(xj + vj)));
            }
        }
        assert_eq!(swarm_size(2, 1000), 12);
        assert_eq!(swarm_size(2, 20), 5);
    }
}
