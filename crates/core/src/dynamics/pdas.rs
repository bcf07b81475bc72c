//! The paper's primal–dual active set method (PDAS paper (27), STEPs 1–4; design §3.5) on one
//! time step's contact problem, condensed on the multipliers.
//!
//! The step's problem (step.rs) is A u + Bᵀ Λ = F with, per pair p, Signorini on the normal
//! row and the given friction bound on the tangential row. Eliminating u = A⁻¹ F − W Λ
//! (W = A⁻¹ Bᵀ, C = B W) turns the constraints into conditions on the residual
//! r = d − C Λ (r_n the overlap B_n u + B_d u_d − g0, r_t the slip increment B_t (u − u_n)):
//! every multiplier row i has a box [l_i, u_i] (normal [0, ∞), tangential [−G_p, G_p]) and
//! - **free** (the paper's active contact set A_k, and stick): r_i = 0;
//! - **at the lower bound** (the paper's inactive set I_k: Λ_n = 0; slip backwards): Λ_i = l_i;
//! - **at the upper bound** (slip forwards): Λ_i = u_i.
//!
//! STEP 2 solves the linear problem (27) of the current sets exactly, as its Schur complement on
//! the multipliers: C_FF Λ_F = d_F − C_FB Λ_B (dense Cholesky). STEP 3 re-predicts every row from
//! y_i = Λ_i + c_i r_i: free when l_i ≤ y_i ≤ u_i, else at the bound it passes — for the normal
//! rows exactly the paper's A_{k+1} = {Λ_n + c1 (U_n − d) > 0}; for the tangential rows the
//! stick/slip sets of Hüeber–Stadler–Wohlmuth for the given (Tresca per step) friction. c_i =
//! 1 / C_ii (the paper's c1 ∈ (10³, 10⁴) is a constant in its units; 1/C_ii makes c r a force).
//! STEP 4 stops when the sets repeat; then every sign condition holds and Λ is the step's
//! solution (to the rounding of one Cholesky solve). A change smaller than 1e-12 of the scale
//! (a row whose prediction sits on its bound) does not count as a change, so rounding cannot
//! make the sets flip forever.
//!
//! Termination: PDAS is the semismooth Newton method for Λ − P_[l,u](Λ + c r) = 0 (Hintermüller,
//! Ito, Kunisch 2003); it terminates finitely for M-matrices and from a close start (here the
//! previous step's sets), but may cycle otherwise. A set that was already visited, a cap of
//! [`MAX_ITERATIONS`] or a C_FF that Cholesky refuses returns `None`: the caller falls back to the
//! QP kernel and counts it.

use std::collections::HashSet;

use faer::linalg::solvers::Solve;
use faer::Mat;

/// Where one multiplier row stands in the active-set prediction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Status {
    /// r_i = 0 (contact / stick).
    Free,
    /// Λ_i = l_i (open / backward slip).
    Lower,
    /// Λ_i = u_i (forward slip).
    Upper,
}

/// STEP 2–4 rounds allowed before the step falls back to the QP kernel.
pub const MAX_ITERATIONS: usize = 50;

/// Relative size below which a sign violation does not move a row (rounding).
const ROUNDING: f64 = 1e-12;

/// The result of a terminated PDAS run.
#[derive(Debug, Clone)]
pub struct PdasSolution {
    /// The multipliers Λ.
    pub x: Vec<f64>,
    /// The final sets (the next step's start).
    pub sets: Vec<Status>,
    /// STEP 2 solves.
    pub iterations: usize,
    /// Rows whose status changed over the run.
    pub changes: usize,
}

/// The sets a given Λ stands in (rows strictly inside their box are free).
pub fn sets_of(x: &[f64], lower: &[f64], upper: &[f64]) -> Vec<Status> {
    x.iter()
        .zip(lower.iter().zip(upper))
        .map(|(&x, (&l, &u))| {
            if x <= l {
                Status::Lower
            } else if x >= u {
                Status::Upper
            } else {
                Status::Free
            }
        })
        .collect()
}

/// PDAS on min ½ Λᵀ C Λ − dᵀ Λ, l ≤ Λ ≤ u from the sets `start`; `None` when it does not
/// terminate (cycle, cap, C_FF not positive definite).
pub fn solve(
    c: &Mat<f64>,
    d: &[f64],
    lower: &[f64],
    upper: &[f64],
    start: &[Status],
) -> Option<PdasSolution> {
    let m = d.len();
    let fixed = |i: usize| lower[i] == upper[i];
    // A start at an infinite bound (or at a bound of a fixed row) is read as its nearest
    // meaningful set.
    let mut sets: Vec<Status> = (0..m)
        .map(|i| match start[i] {
            _ if fixed(i) => Status::Lower,
            Status::Lower if lower[i] == f64::NEG_INFINITY => Status::Free,
            Status::Upper if upper[i] == f64::INFINITY => Status::Free,
            s => s,
        })
        .collect();
    let bound_scale = lower
        .iter()
        .chain(upper)
        .filter(|b| b.is_finite())
        .fold(0.0_f64, |s, b| s.max(b.abs()));
    let d_scale = d.iter().fold(0.0_f64, |s, x| s.max(x.abs()));
    let mut seen = HashSet::new();
    let mut changes = 0;
    for iteration in 1..=MAX_ITERATIONS {
        if !seen.insert(sets.clone()) {
            return None;
        }
        let x = step_solve(c, d, lower, upper, &sets)?;
        let r: Vec<f64> = (0..m)
            .map(|i| d[i] - (0..m).map(|j| c[(i, j)] * x[j]).sum::<f64>())
            .collect();
        let x_scale = x.iter().fold(bound_scale, |s, v| s.max(v.abs()));
        let r_scale = (0..m).fold(d_scale, |s, i| s.max((d[i] - r[i]).abs()));
        let (x_tol, r_tol) = (ROUNDING * x_scale, ROUNDING * r_scale);
        let next: Vec<Status> = (0..m)
            .map(|i| {
                if fixed(i) {
                    return Status::Lower;
                }
                match sets[i] {
                    // y = Λ_i: inside its box (to rounding) it stays free.
                    Status::Free if x[i] < lower[i] - x_tol => Status::Lower,
                    Status::Free if x[i] > upper[i] + x_tol => Status::Upper,
                    Status::Free => Status::Free,
                    // y = l + c r (resp. u + c r): the row leaves its bound when r pulls
                    // it inside, to the bound the prediction reaches.
                    Status::Lower | Status::Upper => {
                        let y = x[i] + r[i] / c[(i, i)];
                        let stays = match sets[i] {
                            Status::Lower => r[i] <= r_tol,
                            _ => r[i] >= -r_tol,
                        };
                        if stays {
                            sets[i]
                        } else if y < lower[i] {
                            Status::Lower
                        } else if y > upper[i] {
                            Status::Upper
                        } else {
                            Status::Free
                        }
                    }
                }
            })
            .collect();
        let changed = next.iter().zip(&sets).filter(|(a, b)| a != b).count();
        if changed == 0 {
            // Rows free to rounding outside their box are put on it.
            let x = x
                .iter()
                .zip(lower.iter().zip(upper))
                .map(|(&x, (&l, &u))| x.clamp(l, u))
                .collect();
            return Some(PdasSolution {
                x,
                sets,
                iterations: iteration,
                changes,
            });
        }
        changes += changed;
        sets = next;
    }
    None
}

/// STEP 2: Λ_B at the bounds, C_FF Λ_F = d_F − C_FB Λ_B; `None` if C_FF is not positive
/// definite.
fn step_solve(
    c: &Mat<f64>,
    d: &[f64],
    lower: &[f64],
    upper: &[f64],
    sets: &[Status],
) -> Option<Vec<f64>> {
    let mut x: Vec<f64> = sets
        .iter()
        .enumerate()
        .map(|(i, s)| match s {
            Status::Lower => lower[i],
            Status::Upper => upper[i],
            Status::Free => 0.0,
        })
        .collect();
    let free: Vec<usize> = (0..x.len()).filter(|&i| sets[i] == Status::Free).collect();
    if free.is_empty() {
        return Some(x);
    }
    let bound: Vec<usize> = (0..x.len()).filter(|&i| sets[i] != Status::Free).collect();
    if bound.iter().any(|&i| !x[i].is_finite()) {
        return None;
    }
    let cff = Mat::<f64>::from_fn(free.len(), free.len(), |a, b| c[(free[a], free[b])]);
    let factor = cff.llt(faer::Side::Lower).ok()?;
    let mut rhs = Mat::<f64>::from_fn(free.len(), 1, |a, _| {
        let i = free[a];
        d[i] - bound.iter().map(|&j| c[(i, j)] * x[j]).sum::<f64>()
    });
    factor.solve_in_place(rhs.as_mut());
    for (a, &i) in free.iter().enumerate() {
        x[i] = rhs[(a, 0)];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions};

    /// A small contact-like QP (SPD C with positive off-diagonals, as B A⁻¹ Bᵀ has): PDAS from
    /// every start and the QP kernel agree.
    #[test]
    fn agrees_with_the_qp_kernel_from_any_start() {
        let m = 6;
        let c = Mat::<f64>::from_fn(m, m, |i, j| {
            if i == j {
                2.0 + i as f64 * 0.1
            } else {
                0.5 / (1.0 + (i as f64 - j as f64).abs())
            }
        });
        let d = vec![1.0, -0.5, 0.8, 2.0, -1.0, 0.3];
        let lower = vec![0.0, -0.2, 0.0, -0.4, 0.0, 0.0];
        let upper = vec![f64::INFINITY, 0.2, f64::INFINITY, 0.4, f64::INFINITY, 0.0];
        let qp = solve_box_qp(
            &BoxQp::new(c.clone(), d.clone(), lower.clone(), upper.clone()),
            None,
            &QpOptions::default(),
        )
        .expect("qp");
        for start in [Status::Free, Status::Lower, Status::Upper] {
            let s = solve(&c, &d, &lower, &upper, &vec![start; m]).expect("terminates");
            for (a, b) in s.x.iter().zip(&qp.x) {
                assert!((a - b).abs() < 1e-12, "{start:?}: {a} vs {b}");
            }
            // Started from its own answer it stops at once.
            let again = solve(&c, &d, &lower, &upper, &s.sets).expect("terminates");
            assert_eq!((again.iterations, again.changes), (1, 0));
        }
    }
}
