//! PCG1 / PCG2 (D05 §5 algorithm PCG1, §6 PCG2; D03 §4): conjugate gradients on the interface
//! with the balancing preconditioner of [`super::coarse::Balancing`] (or, for the Newton steps,
//! of [`super::newton::NewtonOperator`]). The start vector is coarse-corrected (D05
//! 5.15 / 6.8), so every residual stays orthogonal to the coarse space (Lemma 5.1 / 6.1); the
//! largest coarse component seen is returned as a check.
//!
//! Depends only on [`super::coarse_space`] and [`super::DdError`]: the operators
//! ([`super::coarse::Balancing`], [`super::newton::NewtonOperator`]) implement [`Interface`]
//! in their own modules.

use super::coarse_space::CoarseSpace;
use super::DdError;

/// An SPD interface operator with a balancing preconditioner and a coarse space (D05 §5–6):
/// implementors give A, the Neumann–Neumann sum and the coarse space; the balanced
/// preconditioner, the coarse start and the coarse check follow from them.
pub trait Interface {
    /// A x.
    fn apply(&self, x: &[f64]) -> Vec<f64>;
    /// The one-level Neumann–Neumann sum Σ D_s S_s⁺ D_sᵀ r (D05 5.9).
    fn neumann_sum(&self, r: &[f64]) -> Vec<f64>;
    /// The coarse space with A W and the factored G = Wᵀ A W.
    fn coarse(&self) -> &CoarseSpace;

    /// M⁻¹ r = (I − P_Z) Σ D_s S_s⁺ D_sᵀ r for a residual r orthogonal to the coarse space
    /// (D05 5.14).
    fn precondition(&self, r: &[f64]) -> Vec<f64> {
        let mut z = self.neumann_sum(r);
        self.coarse().project(&mut z);
        z
    }

    /// The coarse-corrected start x (D05 5.15 / 6.8) and its residual b − A x.
    fn coarse_start(&self, mut x: Vec<f64>, b: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let ax = self.apply(&x);
        let mut r: Vec<f64> = b.iter().zip(&ax).map(|(b, s)| b - s).collect();
        self.coarse().start(&mut x, &mut r);
        (x, r)
    }

    /// max_j |w_jᵀ r| over the (unit) coarse basis vectors.
    fn coarse_residual(&self, r: &[f64]) -> f64 {
        self.coarse().residual(r)
    }
}

/// Result of one PCG solve.
#[derive(Debug, Clone)]
pub struct PcgOutcome {
    pub x: Vec<f64>,
    pub iterations: usize,
    /// max over iterations of max_j |w_jᵀ r| / ‖b‖ (Lemma 5.1: zero up to rounding).
    pub coarse_residual: f64,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Solve S x = b from `x0` to ‖r‖ ≤ tol ‖b‖.
pub fn pcg(
    op: &impl Interface,
    b: &[f64],
    x0: Vec<f64>,
    tol: f64,
    max_iter: usize,
    name: &'static str,
) -> Result<PcgOutcome, DdError> {
    let bnorm = dot(b, b).sqrt();
    if bnorm == 0.0 {
        return Ok(PcgOutcome {
            x: vec![0.0; b.len()],
            iterations: 0,
            coarse_residual: 0.0,
        });
    }
    let (mut x, mut r) = op.coarse_start(x0, b);
    let mut coarse_residual = op.coarse_residual(&r) / bnorm;
    let mut p = vec![0.0; b.len()];
    let mut rz_old = 0.0;
    let mut iterations = 0;
    loop {
        let res = dot(&r, &r).sqrt() / bnorm;
        if res <= tol {
            return Ok(PcgOutcome {
                x,
                iterations,
                coarse_residual,
            });
        }
        if iterations >= max_iter {
            return Err(DdError::NotConverged {
                solver: name,
                iterations,
                residual: res,
            });
        }
        let z = op.precondition(&r);
        let rz = dot(&r, &z);
        let beta = if iterations == 0 { 0.0 } else { rz / rz_old };
        p.iter_mut().zip(&z).for_each(|(p, z)| *p = z + beta * *p);
        let q = op.apply(&p);
        let pq = dot(&p, &q);
        if !(pq > 0.0 && rz > 0.0) {
            return Err(DdError::NotConverged {
                solver: name,
                iterations,
                residual: res,
            });
        }
        let alpha = rz / pq;
        x.iter_mut().zip(&p).for_each(|(x, p)| *x += alpha * p);
        r.iter_mut().zip(&q).for_each(|(r, q)| *r -= alpha * q);
        rz_old = rz;
        iterations += 1;
        coarse_residual = coarse_residual.max(op.coarse_residual(&r) / bnorm);
    }
}
