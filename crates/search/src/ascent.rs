//! Local search with exact derivatives (design §4.3): a projected quasi-Newton ascent of the
//! score in the unit box, L-BFGS-B-like in spirit for the small dimensions of a worst-scenario
//! box (a dense inverse-Hessian estimate).
//!
//! At each point the projected ascent direction d is read off the one-sided unit slopes
//! ([`ascent_direction`]: d_j is the slope into the box where moving u_j raises the score,
//! else 0). A datum on a bound whose slope holds
//! it there is *identified* as active and frozen; the others form the free set. The step is
//! p = H d with the BFGS inverse-Hessian estimate H of −score on the free set (reset to a scaled
//! identity whenever the free set changes or p is not an ascent direction), projected onto the
//! box and backtracked (by quarters, down to a trial 1e-6 from the point) until the Armijo condition s(y) ≥ s(x) + 1e-4 · d·(y − x) holds. It stops
//! as soon as the relative residual max|d| / |Φ| is below [`CERTIFY_TOL`] (locally certified), when no
//! backtracked step improves even from the identity (stagnated: a kink or the resolution of Φ),
//! after a few infeasible trial points (stagnated: the optimum borders a failure region), at
//! the evaluation `limit`, or on a halt. The ascents from several starts run in lockstep (one
//! trial point of each per batch), so their solves run in parallel.

use super::certificate::{ascent_direction, residual, unit_slopes, CERTIFY_TOL};
use super::session::{Probe, Session};
use super::space::BOUND_TOL;
use super::Status;

/// Armijo constant of the backtracking line search.
const ARMIJO: f64 = 1e-4;
/// A trial that does not improve shrinks the step by this factor ...
const BACKTRACK: f64 = 0.25;
/// ... until the trial lies this close to the current point (unit box, ∞-norm): then the line
/// search gives up (a kink of Φ, or its resolution). About ten trials from a whole-box step.
const MIN_TRIAL: f64 = 1e-6;
/// Iterations of one ascent.
const MAX_ITERATIONS: usize = 200;
/// Coordinates this close to a bound are put on it.
const SNAP: f64 = 1e-12;
/// After an infeasible trial point, every trial stays within this fraction of the distance
/// (unit box, ∞-norm) from the current point to the nearest infeasible point: the ascent closes
/// in on a failure region by halving its distance instead of probing it again ...
const FAILURE_APPROACH: f64 = 0.5;
/// ... until that distance is below this, or after this many infeasible trials: the ascent ends
/// unsettled — the optimum it heads for lies next to points the solver cannot answer, which no
/// derivative can certify.
const FAILURE_RESOLUTION: f64 = 1e-3;
const FAILED_TRIALS: usize = 8;

/// A point of the ascent: unit coordinates, score, projected ascent direction, free set.
struct Iterate {
    unit: Vec<f64>,
    value: f64,
    score: f64,
    direction: Vec<f64>,
    free: Vec<bool>,
}

impl Iterate {
    fn new(session: &Session, k: usize, probe: Probe) -> Option<Iterate> {
        let sense = session.objectives()[k].sense;
        let slopes = unit_slopes(session.space, sense, probe.slopes.as_deref()?);
        let direction = ascent_direction(&probe.unit, &slopes);
        let free = probe
            .unit
            .iter()
            .zip(&direction)
            .map(|(&u, &d)| d != 0.0 || (u > BOUND_TOL && u < 1.0 - BOUND_TOL))
            .collect();
        Some(Iterate {
            score: sense.score(probe.value),
            value: probe.value,
            unit: probe.unit,
            direction,
            free,
        })
    }

    /// Relative projected-gradient residual (the certificate's).
    fn residual(&self) -> f64 {
        residual(&self.direction, self.value)
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The inverse-Hessian estimate γ I.
fn scaled_identity(n: usize, gamma: f64) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| (0..n).map(|j| if i == j { gamma } else { 0.0 }).collect())
        .collect()
}

/// BFGS update of the inverse-Hessian estimate `h` with the step `s` and gradient change `y`
/// (of the function minimised, −score): H ← (I − ρ s yᵀ) H (I − ρ y sᵀ) + ρ s sᵀ, ρ = 1 / yᵀs.
/// Skipped unless the curvature yᵀs is clearly positive.
fn bfgs_update(h: &mut [Vec<f64>], s: &[f64], y: &[f64]) {
    let sy = dot(s, y);
    if sy <= 1e-12 * dot(s, s).sqrt() * dot(y, y).sqrt() || sy <= 0.0 {
        return;
    }
    let rho = 1.0 / sy;
    let n = s.len();
    let hy: Vec<f64> = h.iter().map(|row| dot(row, y)).collect();
    let yhy = dot(y, &hy);
    for i in 0..n {
        for j in 0..n {
            h[i][j] += -rho * (hy[i] * s[j] + s[i] * hy[j]) + (rho * rho * yhy + rho) * s[i] * s[j];
        }
    }
}

/// The backtracking line search of one iteration: ascent direction g on the free set, step
/// p = H g and the current step length.
struct LineSearch {
    g: Vec<f64>,
    /// The scale of the identity step.
    gamma: f64,
    p: Vec<f64>,
    step: f64,
}

/// One ascent: where it is, its inverse-Hessian estimate and line search, and why it ended.
struct Ascent {
    x: Iterate,
    h: Option<Vec<Vec<f64>>>,
    line: Option<LineSearch>,
    iterations: usize,
    /// The infeasible trial points so far.
    failed: Vec<Vec<f64>>,
    /// The trial point under evaluation.
    trial: Vec<f64>,
    end: Option<Status>,
}

impl Ascent {
    fn new(x: Iterate) -> Ascent {
        Ascent {
            x,
            h: None,
            line: None,
            iterations: 0,
            failed: Vec::new(),
            trial: Vec::new(),
            end: None,
        }
    }

    /// How far (unit box, ∞-norm) a trial may lie from the current point: a fraction of the
    /// distance to the nearest infeasible point seen (unbounded before any).
    fn reach(&self) -> f64 {
        self.failed
            .iter()
            .map(|f| FAILURE_APPROACH * linf_distance(f, &self.x.unit))
            .fold(f64::INFINITY, f64::min)
    }

    /// The next point to evaluate, or `None` once the ascent has ended (`self.end` says why).
    fn propose(&mut self) -> Option<Vec<f64>> {
        while self.end.is_none() {
            let reach = self.reach();
            if reach <= FAILURE_APPROACH * FAILURE_RESOLUTION || self.failed.len() >= FAILED_TRIALS
            {
                self.end = Some(Status::Unsettled);
                break;
            }
            if self.line.is_none() {
                if self.x.residual() <= CERTIFY_TOL {
                    self.end = Some(Status::LocallyCertified);
                    break;
                }
                if self.iterations >= MAX_ITERATIONS {
                    self.end = Some(Status::Stagnated);
                    break;
                }
                self.iterations += 1;
                self.line = Some(self.line_search());
            }
            let line = self.line.as_mut().expect("a line search is under way");
            let mut y = trial_point(&self.x.unit, &line.p, line.step);
            while linf_distance(&y, &self.x.unit) > reach {
                line.step *= 0.5;
                y = trial_point(&self.x.unit, &line.p, line.step);
            }
            if linf_distance(&y, &self.x.unit) >= MIN_TRIAL {
                self.trial = y.clone();
                return Some(y);
            }
            self.give_up_line();
        }
        None
    }

    /// The line search from the current point: the step H g, from the scaled identity when no
    /// estimate exists or H g is no ascent direction.
    fn line_search(&mut self) -> LineSearch {
        let x = &self.x;
        let g: Vec<f64> = (0..x.unit.len())
            .map(|j| if x.free[j] { x.direction[j] } else { 0.0 })
            .collect();
        let gamma = last_breakpoint(&x.unit, &g);
        let mut p: Vec<f64> = match &self.h {
            Some(h) => h.iter().map(|row| dot(row, &g)).collect(),
            None => g.iter().map(|d| gamma * d).collect(),
        };
        if dot(&p, &g) <= 0.0 {
            self.h = None;
            p = g.iter().map(|d| gamma * d).collect();
        }
        LineSearch {
            g,
            gamma,
            p,
            step: 1.0,
        }
    }

    /// No step of the line search improved: retry from the identity, or end (stagnated).
    fn give_up_line(&mut self) {
        self.line = None;
        if self.h.take().is_none() {
            self.end = Some(Status::Stagnated);
        }
    }

    /// The trial point's iterate (`None` if infeasible or without slopes): accept it (Armijo),
    /// backtrack, or end after too many infeasible trials.
    fn take(&mut self, z: Option<Iterate>) {
        let line = self
            .line
            .as_mut()
            .expect("a trial belongs to a line search");
        let moved: Vec<f64> = self
            .trial
            .iter()
            .zip(&self.x.unit)
            .map(|(a, b)| a - b)
            .collect();
        match z {
            Some(z) if z.score > self.x.score + ARMIJO * dot(&line.g, &moved) => {
                let gamma = line.gamma;
                self.line = None;
                self.accept(z, &moved, gamma);
            }
            Some(_) => line.step *= BACKTRACK,
            None => self.failed.push(self.trial.clone()),
        }
    }

    /// Move to the accepted iterate `z` (reached by the step `moved`), updating the estimate
    /// on the free set (reset when the free set changed; a new estimate starts from the
    /// secant scale, else `gamma`).
    fn accept(&mut self, z: Iterate, moved: &[f64], gamma: f64) {
        let x = &self.x;
        if z.free != x.free {
            self.h = None;
        } else {
            let change: Vec<f64> = (0..x.unit.len())
                .map(|j| {
                    if z.free[j] {
                        x.direction[j] - z.direction[j]
                    } else {
                        0.0
                    }
                })
                .collect();
            let sy = dot(moved, &change);
            let yy = dot(&change, &change);
            let estimate = self.h.get_or_insert_with(|| {
                let scale = if sy > 0.0 && yy > 0.0 { sy / yy } else { gamma };
                scaled_identity(x.unit.len(), scale)
            });
            bfgs_update(estimate, moved, &change);
        }
        self.x = z;
    }
}

/// The scale γ of the identity step γ g: the last breakpoint of the projected path x + γ g,
/// where every coordinate that moves has reached its bound. The first trial of a line search
/// from the identity is then the vertex (or face) the slopes point to — from which the search
/// halves back when it does not improve — so a monotone criterion is climbed in one step.
fn last_breakpoint(x: &[f64], g: &[f64]) -> f64 {
    x.iter()
        .zip(g)
        .filter(|(_, &d)| d != 0.0)
        .map(|(&u, &d)| if d > 0.0 { (1.0 - u) / d } else { u / -d })
        .fold(0.0_f64, f64::max)
}

/// max_j |a_j − b_j|.
fn linf_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

/// `x + step · p`, projected onto the unit box, coordinates within [`SNAP`] of a bound put on it.
fn trial_point(x: &[f64], p: &[f64], step: f64) -> Vec<f64> {
    x.iter()
        .zip(p)
        .map(|(&u, &d)| {
            let u = (u + step * d).clamp(0.0, 1.0);
            if u < SNAP {
                0.0
            } else if u > 1.0 - SNAP {
                1.0
            } else {
                u
            }
        })
        .collect()
}

/// Where an ascent ended: unit point and score.
pub(super) type End = (Vec<f64>, f64);

/// Where a local search starts: the objective it ascends, its unit point, and whether the point
/// is from a space-filling design (a uniform random start) rather than directed.
pub(super) struct Start {
    pub(super) objective: usize,
    pub(super) unit: Vec<f64>,
    pub(super) random: bool,
}

/// Ascend from each of `starts` at once — every round evaluates the next trial point of every
/// ascent still running in one batch (points shared by several ascents are solved once), so that
/// the batches are as wide as the starts — while the run's evaluation count stays within `limit`
/// (when a round does not fit, the ascents listed last end first). Per start: why its ascent
/// stopped (`LocallyCertified` when the residual is below [`CERTIFY_TOL`]) and the unit point
/// where it ended with its score (`None` if the start gave no derivatives).
pub(super) fn run(session: &Session, starts: &[Start], limit: usize) -> Vec<(Status, Option<End>)> {
    let first: Vec<(usize, Vec<f64>)> = starts
        .iter()
        .map(|s| (s.objective, s.unit.clone()))
        .collect();
    let iterates = match visit(session, &first) {
        Ok(iterates) => iterates,
        Err(stop) => return starts.iter().map(|_| (stop, None)).collect(),
    };
    let mut ascents: Vec<Option<Ascent>> =
        iterates.into_iter().map(|x| x.map(Ascent::new)).collect();
    loop {
        let mut round: Vec<(usize, Vec<f64>)> = ascents
            .iter_mut()
            .enumerate()
            .filter_map(|(i, a)| Some((i, a.as_mut()?.propose()?)))
            .collect();
        if round.is_empty() {
            break;
        }
        let room = limit.saturating_sub(session.evaluations());
        let points: Vec<(usize, Vec<f64>)> = round
            .iter()
            .map(|(i, y)| (starts[*i].objective, y.clone()))
            .collect();
        let fitting = fitting_prefix(session, &points, room);
        for (i, _) in round.iter().skip(fitting) {
            if let Some(a) = ascents[*i].as_mut() {
                a.end = Some(Status::BudgetExhausted);
            }
        }
        round.truncate(fitting);
        if round.is_empty() {
            break;
        }
        match visit(session, &points[..fitting]) {
            Ok(iterates) => {
                for ((i, _), z) in round.iter().zip(iterates) {
                    if let Some(a) = ascents[*i].as_mut() {
                        a.take(z);
                    }
                }
            }
            Err(stop) => {
                for (i, _) in &round {
                    if let Some(a) = ascents[*i].as_mut() {
                        a.end = Some(stop);
                    }
                }
                break;
            }
        }
    }
    ascents
        .into_iter()
        .map(|a| match a {
            Some(a) => (
                a.end.unwrap_or(Status::Stagnated),
                Some((a.x.unit, a.x.score)),
            ),
            None => (Status::Stagnated, None),
        })
        .collect()
}

/// How many of the first `points` fit in `room` new evaluations (points evaluated before, or
/// repeated within the batch, cost nothing).
fn fitting_prefix(session: &Session, points: &[(usize, Vec<f64>)], room: usize) -> usize {
    let mut new = std::collections::HashSet::new();
    for (n, (_, unit)) in points.iter().enumerate() {
        if !session.has_seen(unit)
            && new.insert(unit.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
            && new.len() > room
        {
            return n;
        }
    }
    points.len()
}

/// Evaluate the unit points of `(objective, point)` pairs in one batch (`None` where infeasible
/// or without slopes).
fn visit(session: &Session, points: &[(usize, Vec<f64>)]) -> Result<Vec<Option<Iterate>>, Status> {
    let units: Vec<&[f64]> = points.iter().map(|(_, u)| u.as_slice()).collect();
    let indices = session.indices(&units).map_err(|stop| stop.0)?;
    Ok(indices
        .into_iter()
        .zip(points)
        .map(|(index, (k, _))| {
            session
                .probe(*k, index)
                .and_then(|probe| Iterate::new(session, *k, probe))
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bfgs_update_satisfies_the_secant_equation() {
        let mut h = scaled_identity(2, 1.0);
        let (s, y) = ([0.3, -0.1], [1.0, 0.5]);
        bfgs_update(&mut h, &s, &y);
        let hy: Vec<f64> = h.iter().map(|row| dot(row, &y)).collect();
        assert!((hy[0] - s[0]).abs() < 1e-15 && (hy[1] - s[1]).abs() < 1e-15);
        assert!((h[0][1] - h[1][0]).abs() < 1e-15);
        // Negative curvature leaves the estimate alone.
        let before = h.clone();
        bfgs_update(&mut h, &s, &[-1.0, 0.0]);
        assert_eq!(h, before);
    }
}
