//! Safeguarded semismooth Newton steps for the interface problem (robustness beyond the papers).
//!
//! The successive approximations (D05 4.37) are the fixed-point form of
//!
//! ```text
//!   G(U) := S0 U − F0 + S_CON(U) = 0,
//! ```
//!
//! the gradient of the convex interface energy J(U) = ½UᵀS0U − F0ᵀU + Σ_c E_c(R_c U), E_c the
//! cluster's minimal local energy (frictional contact, D05 4.27–4.28) with trace R_c U, so that
//! S_CON = Σ R_cᵀ ∇E_c. When 2β² ≥ 1 (D05 Thm 7.1 / Cor 7.1 fail) the plain step diverges; then
//!
//! - a Newton direction solves (S0 + Σ R_cᵀ S_c' R_c) δ = −G(U), with S_c' the cluster's tangent
//!   ([`ContactCluster::tangent`]: the active rows tied, the Schur complement of D05 4.44–4.46),
//!   by PCG with the Neumann–Neumann sum of S0 and the coarse space V_0H of S0 taken A-orthogonal
//!   for A = S0 + Σ S_c' ([`NewtonOperator`]);
//! - the step length t minimises the convex φ(t) = J(U + tδ) (secant search on the monotone
//!   φ'(t) = δᵀ G(U + tδ), each value one S_CON evaluation), so that J decreases at every step and
//!   the active-set cycling of undamped Newton cannot occur.
//!
//! Depends on [`super::coarse`] (S0), [`super::coarse_space`], [`super::pair`] (the tangents)
//! and [`super::pcg`]; used by [`super::successive`].

use super::coarse::Balancing;
use super::coarse_space::{CoarseSpace, SparseColumns};
use super::pair::{ClusterTangent, ContactCluster};
use super::pcg::Interface;
use super::DdError;

/// A = S0 + Σ_c R_cᵀ S_c' R_c with its balancing preconditioner.
pub struct NewtonOperator<'a> {
    s0: &'a Balancing<'a>,
    tangents: Vec<(&'a ContactCluster, ClusterTangent)>,
    coarse: CoarseSpace,
}

impl<'a> NewtonOperator<'a> {
    pub fn new(
        s0: &'a Balancing<'a>,
        tangents: Vec<(&'a ContactCluster, ClusterTangent)>,
    ) -> Result<NewtonOperator<'a>, DdError> {
        let mut op = NewtonOperator {
            s0,
            tangents,
            coarse: CoarseSpace::new(SparseColumns::default(), SparseColumns::default(), 0)?,
        };
        // W and S0 W of the S0 coarse space (computed once with S0), plus the tangent part.
        let w = s0.coarse().basis().clone();
        let mut aw = s0.coarse().image().clone();
        let mut on_cluster = vec![false; w.n];
        for (cl, _) in &op.tangents {
            for &g in &cl.gamma {
                on_cluster[g] = true;
            }
        }
        for j in 0..w.ncols() {
            if !w.cols[j].iter().any(|&(g, _)| on_cluster[g]) {
                continue;
            }
            let mut col = aw.dense(j);
            for (c, v) in col.iter_mut().zip(op.tangent_part(&w.dense(j))) {
                *c += v;
            }
            aw.cols[j] = SparseColumns::sparsify(&col);
        }
        // The S0 basis is already free of dependent columns; all of it stays.
        let required = w.ncols();
        op.coarse = CoarseSpace::new(w, aw, required)?;
        Ok(op)
    }

    /// Σ_c R_cᵀ S_c' R_c x.
    fn tangent_part(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; x.len()];
        for (cl, t) in &self.tangents {
            let local: Vec<f64> = cl.gamma.iter().map(|&g| x[g]).collect();
            if local.iter().all(|&v| v == 0.0) {
                continue;
            }
            for (&g, v) in cl.gamma.iter().zip(cl.tangent_apply(t, &local)) {
                y[g] += v;
            }
        }
        y
    }
}

impl Interface for NewtonOperator<'_> {
    fn apply(&self, x: &[f64]) -> Vec<f64> {
        let mut y = self.s0.apply(x);
        for (a, b) in y.iter_mut().zip(self.tangent_part(x)) {
            *a += b;
        }
        y
    }

    /// The Neumann–Neumann sum of S0 (the tangent's cluster part is not preconditioned).
    fn neumann_sum(&self, r: &[f64]) -> Vec<f64> {
        self.s0.neumann_sum(r)
    }

    /// W of S0 with the Newton operator's own A W and G_A.
    fn coarse(&self) -> &CoarseSpace {
        &self.coarse
    }
}

/// Secant (Illinois) search for a zero of the nondecreasing φ' on [0, 1] given φ'(0) < 0:
/// returns t = 1 when φ'(1) ≤ 0, else t with |φ'(t)| ≤ `rel` |φ'(0)| (or the best of
/// `max_evals` evaluations). `dphi` may fail (a local solve); the error is passed on.
pub fn line_search<E>(
    d0: f64,
    rel: f64,
    max_evals: usize,
    mut dphi: impl FnMut(f64) -> Result<f64, E>,
) -> Result<f64, E> {
    let d1 = dphi(1.0)?;
    if d1 <= 0.0 {
        return Ok(1.0);
    }
    let (mut a, mut fa, mut b, mut fb) = (0.0, d0, 1.0, d1);
    let mut side = 0i8;
    let mut best = (0.0, d0.abs());
    for _ in 0..max_evals {
        let t = (a * fb - b * fa) / (fb - fa);
        let f = dphi(t)?;
        if f.abs() < best.1 {
            best = (t, f.abs());
        }
        if f.abs() <= rel * d0.abs() {
            return Ok(t);
        }
        if f < 0.0 {
            (a, fa) = (t, f);
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        } else {
            (b, fb) = (t, f);
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        }
    }
    Ok(best.0)
}

#[cfg(test)]
mod tests {
    use super::line_search;

    #[test]
    fn line_search_finds_the_kink_of_a_piecewise_linear_derivative() {
        // φ'(t) = t − 0.3 below 0.5, 3(t − 0.5) + 0.2 above: zero at t = 0.3.
        let dphi = |t: f64| -> Result<f64, ()> {
            Ok(if t < 0.5 {
                t - 0.3
            } else {
                3.0 * (t - 0.5) + 0.2
            })
        };
        let t = line_search(-0.3, 1e-10, 50, dphi).unwrap();
        assert!((t - 0.3).abs() < 1e-9, "{t}");
        let t = line_search(-1.0, 1e-10, 50, |t: f64| Ok::<_, ()>(t - 2.0)).unwrap();
        assert_eq!(t, 1.0);
    }
}
