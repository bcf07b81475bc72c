//! Anderson mixing (type II, Walker & Ni, SIAM J. Numer. Anal. 49 (2011) 1715–1735) of a
//! fixed-point iteration x ↦ G(x): from the last m + 1 pairs (x_i, G(x_i)) with residuals
//! f_i = G(x_i) − x_i, the next iterate is
//!
//! ```text
//!   x⁺ = G(x_k) − ΔG γ,   γ = argmin ‖f_k − ΔF γ‖₂,
//! ```
//!
//! where the columns of ΔF and ΔG are the differences of consecutive residuals and images. The
//! least-squares problem (m ≤ a few columns) is solved by its normal equations (faer's
//! Cholesky) with a small Tikhonov shift ([`Shift`]), so that nearly dependent differences (an
//! iteration that has almost converged) give a small γ instead of a blow-up. Used by the Coulomb
//! fixed point (design §3.4), where x is the vector of normal forces on Coulomb pairs, and by the
//! papers' domain decomposition when its successive approximations stop contracting (design
//! §3.3), where x is the interface trace.

use std::collections::VecDeque;

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

/// The Tikhonov shift added to the normal equations' diagonal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shift {
    /// `factor` times the trace of the normal matrix on every diagonal entry (the Coulomb fixed
    /// point: 1e-12).
    OfTrace(f64),
    /// Each diagonal entry times (1 + `factor`) (the domain decomposition's trace: 1e-10).
    OfDiagonal(f64),
}

/// The history of an Anderson-mixed fixed-point iteration.
#[derive(Debug, Clone)]
pub struct Anderson {
    depth: usize,
    shift: Shift,
    /// (x_i, G(x_i)), oldest first, at most depth + 1.
    history: VecDeque<(Vec<f64>, Vec<f64>)>,
}

impl Anderson {
    /// A mixer keeping `depth` differences (0 = plain iteration), its normal equations shifted
    /// by `shift`.
    pub fn new(depth: usize, shift: Shift) -> Anderson {
        Anderson {
            depth,
            shift,
            history: VecDeque::with_capacity(depth + 1),
        }
    }

    /// Forget the history (after a mixed step that made the residual grow).
    pub fn restart(&mut self) {
        self.history.clear();
    }

    /// Record the pair (x, G(x)) and return the next iterate: the mixed one when there is a
    /// history, G(x) otherwise.
    pub fn next(&mut self, x: &[f64], g: &[f64]) -> Vec<f64> {
        if self.depth == 0 {
            return g.to_vec();
        }
        if self.history.len() == self.depth + 1 {
            self.history.pop_front();
        }
        self.history.push_back((x.to_vec(), g.to_vec()));
        let m = self.history.len() - 1;
        if m == 0 {
            return g.to_vec();
        }
        // ΔF: differences of consecutive residuals f_i = G(x_i) − x_i, one column each.
        let residual = |i: usize, r: usize| self.history[i].1[r] - self.history[i].0[r];
        let df = Mat::from_fn(g.len(), m, |r, j| residual(j + 1, r) - residual(j, r));
        let f = Mat::from_fn(g.len(), 1, |r, _| residual(m, r));
        let mut gram = df.transpose() * &df;
        let trace: f64 = (0..m).map(|i| gram[(i, i)]).sum();
        if trace <= 0.0 {
            return g.to_vec();
        }
        for i in 0..m {
            gram[(i, i)] = match self.shift {
                Shift::OfTrace(factor) => gram[(i, i)] + factor * trace,
                Shift::OfDiagonal(factor) => gram[(i, i)] * (1.0 + factor),
            };
        }
        let Ok(factor) = gram.llt(Side::Lower) else {
            return g.to_vec();
        };
        let gamma = factor.solve(df.transpose() * &f);
        let mut next = g.to_vec();
        for j in 0..m {
            let (g_new, g_old) = (&self.history[j + 1].1, &self.history[j].1);
            for (v, (a, b)) in next.iter_mut().zip(g_new.iter().zip(g_old)) {
                *v -= gamma[(j, 0)] * (a - b);
            }
        }
        next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear contraction x ↦ A x + c with a slow mode (0.98) and a fast one: plain
    /// iteration needs hundreds of steps to 1e-12, Anderson with depth 2 a handful (it is
    /// GMRES-equivalent on linear maps).
    #[test]
    fn anderson_accelerates_a_slow_linear_contraction() {
        let map = |x: &[f64]| vec![0.98 * x[0] + 0.1 * x[1] + 1.0, 0.2 * x[1] - 2.0];
        let fixed = {
            let x1 = -2.0 / 0.8;
            [(1.0 + 0.1 * x1) / 0.02, x1]
        };
        let steps = |depth: usize| {
            let mut mixer = Anderson::new(depth, Shift::OfTrace(1e-12));
            let mut x = vec![0.0, 0.0];
            for k in 1..=2000 {
                let g = map(&x);
                if (g[0] - fixed[0]).abs().max((g[1] - fixed[1]).abs()) <= 1e-12 * fixed[0].abs() {
                    return k;
                }
                x = mixer.next(&x, &g);
            }
            usize::MAX
        };
        let (plain, mixed) = (steps(0), steps(2));
        assert!(plain > 500 && plain < 2000, "plain {plain}");
        assert!(mixed <= 6, "anderson {mixed}");
    }

    #[test]
    fn restart_falls_back_to_the_plain_step() {
        let mut mixer = Anderson::new(3, Shift::OfDiagonal(1e-10));
        assert_eq!(mixer.next(&[0.0], &[1.0]), vec![1.0]);
        mixer.restart();
        assert_eq!(mixer.next(&[1.0], &[1.5]), vec![1.5]);
    }
}
