//! Anderson mixing (type II, Walker & Ni, SIAM J. Numer. Anal. 49 (2011) 1715–1735) of a
//! fixed-point iteration x ↦ G(x): from the last m + 1 pairs (x_i, G(x_i)) with residuals
//! f_i = G(x_i) − x_i, the next iterate is
//!
//! ```text
//!   x⁺ = G(x_k) − ΔG γ,   γ = argmin ‖f_k − ΔF γ‖₂,
//! ```
//!
//! where the columns of ΔF and ΔG are the differences of consecutive residuals and images. The
//! least-squares problem (m ≤ a few columns) is solved by its normal equations with a relative
//! Tikhonov shift of 1e-12 of their trace, so that nearly dependent differences (an iteration
//! that has almost converged) give a small γ instead of a blow-up. Used by the Coulomb fixed
//! point (design §3.4), where x is the vector of normal forces on Coulomb pairs.

use std::collections::VecDeque;

/// The history of an Anderson-mixed fixed-point iteration.
#[derive(Debug, Clone)]
pub struct Anderson {
    depth: usize,
    /// (x_i, G(x_i)), oldest first, at most depth + 1.
    history: VecDeque<(Vec<f64>, Vec<f64>)>,
}

impl Anderson {
    /// A mixer keeping `depth` differences (0 = plain iteration).
    pub fn new(depth: usize) -> Anderson {
        Anderson {
            depth,
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
        let residual = |i: usize| -> Vec<f64> {
            let (x, g) = &self.history[i];
            g.iter().zip(x).map(|(a, b)| a - b).collect()
        };
        let residuals: Vec<Vec<f64>> = (0..=m).map(residual).collect();
        let df: Vec<Vec<f64>> = (0..m)
            .map(|j| {
                residuals[j + 1]
                    .iter()
                    .zip(&residuals[j])
                    .map(|(a, b)| a - b)
                    .collect()
            })
            .collect();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let mut gram: Vec<Vec<f64>> = (0..m)
            .map(|i| (0..m).map(|j| dot(&df[i], &df[j])).collect())
            .collect();
        let trace: f64 = (0..m).map(|i| gram[i][i]).sum();
        if trace <= 0.0 {
            return g.to_vec();
        }
        for (i, row) in gram.iter_mut().enumerate() {
            row[i] += 1e-12 * trace;
        }
        let rhs: Vec<f64> = (0..m).map(|i| dot(&df[i], &residuals[m])).collect();
        let Some(gamma) = solve_spd(gram, rhs) else {
            return g.to_vec();
        };
        let mut next = g.to_vec();
        for (j, &c) in gamma.iter().enumerate() {
            let (g_new, g_old) = (&self.history[j + 1].1, &self.history[j].1);
            for (v, (a, b)) in next.iter_mut().zip(g_new.iter().zip(g_old)) {
                *v -= c * (a - b);
            }
        }
        next
    }
}

/// Solve the small symmetric positive definite system A y = b by Cholesky; None if A is not
/// numerically positive definite.
fn solve_spd(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for j in 0..n {
        let d = a[j][j] - (0..j).map(|k| a[j][k] * a[j][k]).sum::<f64>();
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        a[j][j] = d.sqrt();
        for i in j + 1..n {
            let s = a[i][j] - (0..j).map(|k| a[i][k] * a[j][k]).sum::<f64>();
            a[i][j] = s / a[j][j];
        }
    }
    for i in 0..n {
        b[i] = (b[i] - (0..i).map(|k| a[i][k] * b[k]).sum::<f64>()) / a[i][i];
    }
    for i in (0..n).rev() {
        b[i] = (b[i] - (i + 1..n).map(|k| a[k][i] * b[k]).sum::<f64>()) / a[i][i];
    }
    Some(b)
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
            let mut mixer = Anderson::new(depth);
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
        let mut mixer = Anderson::new(3);
        assert_eq!(mixer.next(&[0.0], &[1.0]), vec![1.0]);
        mixer.restart();
        assert_eq!(mixer.next(&[1.0], &[1.5]), vec![1.5]);
    }
}
