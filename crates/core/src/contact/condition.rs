//! The ∞-norm condition of the dual Hessian C = B K⁺ Bᵀ in the scaling the contact QP solves in
//! (Jacobi: S C S with S = diag(C)^(−1/2), design §3.1), which turns the QP's relative KKT
//! residual into the relative rounding level of its multipliers (design §3.4):
//! ‖δλ‖∞ / ‖λ‖∞ ≲ κ∞ × residual.
//!
//! κ∞ = ‖A‖∞ ‖A⁻¹‖∞ for A = S C S on the rows with stiffness (C_ii > 0; a row without any,
//! decided by prescribed displacements alone, is pinned by its bounds). ‖A⁻¹‖∞ (= ‖A⁻¹‖₁, A
//! being symmetric) is estimated by Hager's method (W. W. Hager, SIAM J. Sci. Stat. Comput. 5
//! (1984) 311–316; Higham, *Accuracy and Stability of Numerical Algorithms*, §15.3, LAPACK's
//! xLACON) from a Cholesky factor of A: a few solves, a lower bound that is in practice within
//! a small factor of the truth. The factorisation costs about one QP step of the free set.

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, Side};

/// Hager's iterations at most (the estimate usually settles in two or three).
const HAGER_STEPS: usize = 5;

/// κ∞ of the Jacobi-scaled `c` on its rows with a positive diagonal, or `None` when that matrix
/// is not numerically positive definite (its Cholesky factorisation fails) or has no row.
pub fn scaled_condition(c: MatRef<'_, f64>) -> Option<f64> {
    let rows: Vec<usize> = (0..c.nrows()).filter(|&i| c[(i, i)] > 0.0).collect();
    let n = rows.len();
    if n == 0 {
        return None;
    }
    let s: Vec<f64> = rows.iter().map(|&i| c[(i, i)].sqrt().recip()).collect();
    let a = Mat::from_fn(n, n, |i, j| c[(rows[i], rows[j])] * s[i] * s[j]);
    let norm = (0..n)
        .map(|i| (0..n).map(|j| a[(i, j)].abs()).sum::<f64>())
        .fold(0.0_f64, f64::max);
    let factor = a.llt(Side::Lower).ok()?;
    let solve = |v: &[f64]| {
        let x = factor.solve(Mat::from_fn(n, 1, |i, _| v[i]));
        (0..n).map(|i| x[(i, 0)]).collect::<Vec<f64>>()
    };
    let inverse_norm = hager_inverse_norm(n, solve);
    (inverse_norm.is_finite() && inverse_norm > 0.0).then_some(norm * inverse_norm)
}

/// Hager's estimate of ‖A⁻¹‖₁ for a symmetric n × n matrix A given by `solve` (v ↦ A⁻¹ v): a
/// lower bound, the 1-norm of A⁻¹ x at the best vertex x of the unit 1-ball found by
/// gradient steps of the convex function x ↦ ‖A⁻¹ x‖₁.
fn hager_inverse_norm(n: usize, solve: impl Fn(&[f64]) -> Vec<f64>) -> f64 {
    let mut x = vec![1.0 / n as f64; n];
    let mut estimate = 0.0;
    for step in 0..HAGER_STEPS {
        let y = solve(&x);
        let norm: f64 = y.iter().map(|v| v.abs()).sum();
        if step > 0 && norm <= estimate {
            break;
        }
        estimate = norm;
        let signs: Vec<f64> = y
            .iter()
            .map(|v| if *v < 0.0 { -1.0 } else { 1.0 })
            .collect();
        // The gradient of ‖A⁻¹ x‖₁ at x is A⁻ᵀ sign(A⁻¹ x) = A⁻¹ sign(A⁻¹ x).
        let z = solve(&signs);
        let (j, largest) = z.iter().enumerate().fold((0, 0.0_f64), |(j, m), (i, v)| {
            if v.abs() > m {
                (i, v.abs())
            } else {
                (j, m)
            }
        });
        let along_x: f64 = z.iter().zip(&x).map(|(a, b)| a * b).sum();
        if step > 0 && largest <= along_x {
            break;
        }
        x = vec![0.0; n];
        x[j] = 1.0;
    }
    estimate
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::linalg::solvers::DenseSolveCore;

    /// The exact ∞-norm condition of a small symmetric positive definite matrix.
    fn exact_condition(a: &Mat<f64>) -> f64 {
        let n = a.nrows();
        let inverse = a.llt(Side::Lower).unwrap().inverse();
        let norm = |m: &Mat<f64>| {
            (0..n)
                .map(|i| (0..n).map(|j| m[(i, j)].abs()).sum::<f64>())
                .fold(0.0_f64, f64::max)
        };
        norm(a) * norm(&inverse)
    }

    /// The 1D Laplacian (unit diagonal after scaling, κ∞ ≈ n²/2): Hager's estimate is a lower
    /// bound within a factor 3 of the exact value.
    #[test]
    fn estimate_brackets_the_exact_condition_of_a_laplacian() {
        let n = 60;
        let a = Mat::from_fn(n, n, |i, j| match i.abs_diff(j) {
            0 => 2.0,
            1 => -1.0,
            _ => 0.0,
        });
        let scaled = Mat::from_fn(n, n, |i, j| a[(i, j)] / 2.0);
        let exact = exact_condition(&scaled);
        let estimate = scaled_condition(a.as_ref()).unwrap();
        println!("1D Laplacian n = {n}: κ∞ estimate {estimate:.4e}, exact {exact:.4e}");
        assert!(exact > 1e3, "{exact}");
        assert!(
            estimate <= exact * (1.0 + 1e-12) && estimate >= exact / 3.0,
            "estimate {estimate}, exact {exact}"
        );
    }

    /// Jacobi scaling removes the units of a badly scaled diagonal, and rows without stiffness
    /// are left out; an indefinite matrix has no estimate.
    #[test]
    fn scaling_and_rows_without_stiffness() {
        let a = Mat::from_fn(3, 3, |i, j| match (i, j) {
            (0, 0) => 1e12,
            (1, 1) => 1e-6,
            _ => 0.0,
        });
        let kappa = scaled_condition(a.as_ref()).unwrap();
        assert!((kappa - 1.0).abs() <= 1e-15, "{kappa}");
        let indefinite = Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 2.0 });
        assert_eq!(scaled_condition(indefinite.as_ref()), None);
        assert_eq!(scaled_condition(Mat::<f64>::zeros(2, 2).as_ref()), None);
    }
}
