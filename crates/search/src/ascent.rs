//! Local polish with exact derivatives (issue #24 item 2): a projected quasi-Newton ascent of the
//! score in the unit box, L-BFGS-B-like in spirit for the small dimensions of a worst-scenario
//! box (a dense inverse-Hessian estimate).
//!
//! At each point the projected ascent direction d is read off the one-sided unit slopes
//! ([`ascent_direction`]: d_j is the slope into the box where moving u_j raises the score,
//! else 0). A datum on a bound whose slope holds
//! it there is *identified* as active and frozen; the others form the free set. The step is
//! p = H d with the BFGS inverse-Hessian estimate H of −score on the free set (reset to a scaled
//! identity whenever the free set changes or p is not an ascent direction), projected onto the
//! box and backtracked until the Armijo condition s(y) ≥ s(x) + 1e-4 · d·(y − x) holds. It stops
//! as soon as the relative residual max|d| / |Φ| is below [`CERTIFY_TOL`] (certified), when no
//! backtracked step improves even from the identity (stagnated: a kink or the resolution of Φ),
//! after a few infeasible trial points (stagnated: the optimum borders a failure region), at
//! the evaluation `limit`, or on a halt. One point per evaluation.

use super::certificate::{ascent_direction, residual, unit_slopes, CERTIFY_TOL};
use super::session::{Probe, Session};
use super::space::BOUND_TOL;
use super::Status;

/// Largest first step (unit box), along the steepest ascent.
const FIRST_STEP: f64 = 0.1;
/// Armijo constant of the backtracking line search.
const ARMIJO: f64 = 1e-4;
/// Halvings of a step before the line search gives up.
const BACKTRACKS: usize = 20;
/// Iterations of one ascent.
const MAX_ITERATIONS: usize = 200;
/// Coordinates this close to a bound are put on it.
const SNAP: f64 = 1e-12;
/// An infeasible trial point shrinks the step by this factor (a failure region is not worth
/// probing at half steps) ...
const FAILED_SHRINK: f64 = 0.1;
/// ... and after this many infeasible trials the ascent ends: the optimum it heads for lies
/// next to points the solver cannot answer, which no derivative can certify.
const FAILED_TRIALS: usize = 2;

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

/// Evaluate the unit point `unit` for objective `k` (`None` if infeasible or without slopes).
fn visit(session: &Session, k: usize, unit: Vec<f64>) -> Result<Option<Iterate>, Status> {
    let index = session.indices(&[unit]).map_err(|stop| stop.0)?;
    Ok(session
        .probe(k, index[0])
        .and_then(|probe| Iterate::new(session, k, probe)))
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

/// Ascend objective `k` from the evaluated unit point `start` while the run's evaluation count
/// stays within `limit`; the status says why it stopped (`Certified` when the residual is below
/// [`CERTIFY_TOL`]), with the unit point where the ascent ended (`None` if the start gave no
/// derivatives).
pub(super) fn run(
    session: &Session,
    k: usize,
    start: Vec<f64>,
    limit: usize,
) -> (Status, Option<Vec<f64>>) {
    let mut x = match visit(session, k, start) {
        Ok(Some(x)) => x,
        Ok(None) => return (Status::Stagnated, None),
        Err(stop) => return (stop, None),
    };
    let status = climb(session, k, &mut x, limit);
    (status, Some(x.unit))
}

/// The iterations of [`run`] from the evaluated iterate `x`, which ends where the ascent did.
fn climb(session: &Session, k: usize, x: &mut Iterate, limit: usize) -> Status {
    let n = x.unit.len();
    let mut h: Option<Vec<Vec<f64>>> = None;
    let mut failed_trials = 0;
    for _ in 0..MAX_ITERATIONS {
        if x.residual() <= CERTIFY_TOL {
            return Status::Certified;
        }
        let g: Vec<f64> = (0..n)
            .map(|j| if x.free[j] { x.direction[j] } else { 0.0 })
            .collect();
        let gamma = FIRST_STEP / g.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
        let mut p = match &h {
            Some(h) => h.iter().map(|row| dot(row, &g)).collect(),
            None => g.iter().map(|d| gamma * d).collect::<Vec<f64>>(),
        };
        if dot(&p, &g) <= 0.0 {
            h = None;
            p = g.iter().map(|d| gamma * d).collect();
        }
        let mut step = 1.0;
        let mut accepted = None;
        for _ in 0..BACKTRACKS {
            let y: Vec<f64> = (0..n)
                .map(|j| {
                    let u = (x.unit[j] + step * p[j]).clamp(0.0, 1.0);
                    if u < SNAP {
                        0.0
                    } else if u > 1.0 - SNAP {
                        1.0
                    } else {
                        u
                    }
                })
                .collect();
            let moved: Vec<f64> = y.iter().zip(&x.unit).map(|(a, b)| a - b).collect();
            if moved.iter().all(|&d| d == 0.0) {
                break;
            }
            if session.evaluations() >= limit {
                return Status::BudgetExhausted;
            }
            match visit(session, k, y) {
                Err(stop) => return stop,
                Ok(Some(z)) if z.score > x.score + ARMIJO * dot(&g, &moved) => {
                    accepted = Some((z, moved));
                    break;
                }
                Ok(Some(_)) => step *= 0.5,
                Ok(None) => {
                    failed_trials += 1;
                    if failed_trials >= FAILED_TRIALS {
                        return Status::Stagnated;
                    }
                    step *= FAILED_SHRINK;
                }
            }
        }
        let Some((z, moved)) = accepted else {
            if h.take().is_some() {
                // Retry from the identity before giving up.
                continue;
            }
            return Status::Stagnated;
        };
        if z.free != x.free {
            h = None;
        } else {
            let change: Vec<f64> = (0..n)
                .map(|j| {
                    if z.free[j] {
                        x.direction[j] - z.direction[j]
                    } else {
                        0.0
                    }
                })
                .collect();
            let sy = dot(&moved, &change);
            let estimate = h.get_or_insert_with(|| {
                let yy = dot(&change, &change);
                scaled_identity(n, if sy > 0.0 && yy > 0.0 { sy / yy } else { gamma })
            });
            bfgs_update(estimate, &moved, &change);
        }
        *x = z;
    }
    Status::Stagnated
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
