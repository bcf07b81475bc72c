//! Balancing Neumann–Neumann preconditioner (D05 §5, §6; D03 §4; Le Tallec / Mandel BDD).
//!
//! Over a set of [`LinearBlock`]s with interface restrictions R_s:
//! - S = Σ R_sᵀ S_s R_s (D05 4.33 / Def. 4.4), applied block-parallel with a fixed summation order;
//! - injections D_s = diag(ρ_s / Σ_{t ∋ dof} ρ_t) (D05 5.5–5.8); over the non-contact subdomains
//!   only this is the reduced D̊ of D05 6.4–6.6 with the cross-point fix of the reference notes
//!   (weight 1 where one non-contact subdomain carries a contact-pair interface DOF). Σ D_s R_s = I
//!   is checked ([`Balancing::partition_of_unity_error`]);
//! - coarse space V_H = span{D_s γ z : z ∈ Ker A_s} (D05 5.11 / 6.7), W its basis, G = WᵀSW;
//! - M⁻¹ r = (I − P_Z) Σ D_s S_s⁺ D_sᵀ r with P_Z v = W G⁻¹ (SW)ᵀ v, the S-orthogonal projection
//!   onto V_H (D05 5.12–5.14);
//! - the coarse start x ← x + W G⁻¹ Wᵀ (b − S x), which makes the residual orthogonal to V_H
//!   (D05 5.15, Lemma 5.1 / 6.1).

use faer::linalg::solvers::{Llt, Solve};
use faer::{Mat, Side};
use rayon::prelude::*;

use super::pcg::Interface;
use super::subdomain::LinearBlock;
use super::DdError;

/// Singular value of a block's weighted kernel traces (the kernel basis is orthonormal) below
/// which a direction is rounding of a motion that does not reach the interface.
const TRACE_TOL: f64 = 1e-10;

/// A coarse space W (orthonormal-ish columns) for an operator A, with A W and the coarse
/// matrix G = Wᵀ A W factored: the A-orthogonal projection and the coarse start of D05
/// 5.12–5.15, shared by [`Balancing`] and the Newton operator of [`super::newton`].
pub struct CoarseSpace {
    w: Mat<f64>,
    aw: Mat<f64>,
    llt: Option<Llt<f64>>,
}

impl CoarseSpace {
    /// `w` (n × d) and `aw` = A W.
    pub fn new(w: Mat<f64>, aw: Mat<f64>) -> Result<CoarseSpace, DdError> {
        let llt = if w.ncols() > 0 {
            let g = w.transpose() * &aw;
            let g = Mat::from_fn(g.nrows(), g.ncols(), |i, j| 0.5 * (g[(i, j)] + g[(j, i)]));

            Some(g.llt(Side::Lower).map_err(|_| {
                DdError::Coarse(
                    "WᵀSW is not positive definite: the interface operator is singular on the \
                     coarse space (a part of a body is held by nothing but contact)"
                        .into(),
                )
            })?)
        } else {
            None
        };
        Ok(CoarseSpace { w, aw, llt })
    }

    pub fn dim(&self) -> usize {
        self.w.ncols()
    }

    pub fn basis(&self) -> &Mat<f64> {
        &self.w
    }

    /// Mᵀ v for the columns of M.
    fn tdot(m: &Mat<f64>, v: &[f64]) -> Vec<f64> {
        (0..m.ncols())
            .map(|j| (0..m.nrows()).map(|i| m[(i, j)] * v[i]).sum())
            .collect()
    }

    fn solve(&self, rhs: Vec<f64>) -> Vec<f64> {
        match &self.llt {
            Some(llt) => {
                let b = Mat::from_fn(rhs.len(), 1, |i, _| rhs[i]);
                let x = llt.solve(&b);
                (0..rhs.len()).map(|i| x[(i, 0)]).collect()
            }
            None => rhs,
        }
    }

    /// z ← (I − P_Z) z, P_Z = W G⁻¹ (AW)ᵀ.
    pub fn project(&self, z: &mut [f64]) {
        if self.dim() == 0 {
            return;
        }
        let a = self.solve(Self::tdot(&self.aw, z));
        for (i, zi) in z.iter_mut().enumerate() {
            *zi -= (0..a.len()).map(|j| self.w[(i, j)] * a[j]).sum::<f64>();
        }
    }

    /// x ← x + W G⁻¹ Wᵀ r, r ← r − AW G⁻¹ Wᵀ r for the residual r = b − A x.
    pub fn start(&self, x: &mut [f64], r: &mut [f64]) {
        if self.dim() == 0 {
            return;
        }
        let a = self.solve(Self::tdot(&self.w, r));
        for i in 0..x.len() {
            let (mut dx, mut ds) = (0.0, 0.0);
            for (j, aj) in a.iter().enumerate() {
                dx += self.w[(i, j)] * aj;
                ds += self.aw[(i, j)] * aj;
            }
            x[i] += dx;
            r[i] -= ds;
        }
    }

    /// max_j |w_jᵀ r| (columns of W have unit norm).
    pub fn residual(&self, r: &[f64]) -> f64 {
        Self::tdot(&self.w, r)
            .iter()
            .map(|v| v.abs())
            .fold(0.0, f64::max)
    }
}

/// The interface operator and its balancing preconditioner over a set of blocks.
pub struct Balancing<'a> {
    /// Operator blocks; the first `preconditioning` of them also precondition.
    blocks: Vec<&'a LinearBlock>,
    preconditioning: usize,
    /// D_s diagonal per preconditioning block (local interface order).
    weights: Vec<Vec<f64>>,
    n: usize,
    coarse: CoarseSpace,
    unity_error: f64,
}

impl<'a> Balancing<'a> {
    /// Build the weights and the coarse problem on an interface of size `n`; every block both
    /// enters the operator and preconditions (D05 §5 for S, §6 for S0).
    pub fn new(blocks: Vec<&'a LinearBlock>, n: usize) -> Result<Balancing<'a>, DdError> {
        Balancing::with_operator_only(blocks, Vec::new(), n)
    }

    /// Like [`Balancing::new`], with `operator_only` blocks that enter the operator S but not
    /// the preconditioner: the reduced balancing preconditioner of D05 §6 (injections D̊, coarse
    /// space V_0H) applied to S = S0 + Σ tied clusters (see [`super::successive::Pcg1Preconditioner`]).
    pub fn with_operator_only(
        preconditioning: Vec<&'a LinearBlock>,
        operator_only: Vec<&'a LinearBlock>,
        n: usize,
    ) -> Result<Balancing<'a>, DdError> {
        let mut total = vec![0.0; n];
        for b in &preconditioning {
            for (&g, &r) in b.gamma.iter().zip(&b.rho) {
                total[g] += r;
            }
        }
        if let Some(g) = total.iter().position(|&t| t <= 0.0) {
            return Err(DdError::Coarse(format!(
                "interface DOF {g} belongs to none of the preconditioning blocks"
            )));
        }
        let weights: Vec<Vec<f64>> = preconditioning
            .iter()
            .map(|b| {
                b.gamma
                    .iter()
                    .zip(&b.rho)
                    .map(|(&g, &r)| r / total[g])
                    .collect()
            })
            .collect();
        let mut sum = vec![0.0; n];
        for (b, w) in preconditioning.iter().zip(&weights) {
            for (&g, &wi) in b.gamma.iter().zip(w) {
                sum[g] += wi;
            }
        }
        let unity_error = sum.iter().map(|s| (s - 1.0).abs()).fold(0.0, f64::max);
        let mut cols: Vec<Vec<f64>> = Vec::new();
        for (b, w) in preconditioning.iter().zip(&weights) {
            cols.extend(weighted_kernel_traces(b, w, n)?);
        }
        let w = Mat::from_fn(n, cols.len(), |i, j| cols[j][i]);
        let n_pre = preconditioning.len();
        let mut blocks = preconditioning;
        blocks.extend(operator_only);
        let mut bal = Balancing {
            blocks,
            preconditioning: n_pre,
            weights,
            n,
            coarse: CoarseSpace::new(Mat::zeros(n, 0), Mat::zeros(n, 0))?,
            unity_error,
        };
        let sw = bal.apply_mat(&w);
        bal.coarse = CoarseSpace::new(w, sw)?;
        Ok(bal)
    }

    /// Dimension of the coarse space.
    pub fn coarse_dim(&self) -> usize {
        self.coarse.dim()
    }

    /// The coarse basis W.
    pub fn coarse_basis(&self) -> &Mat<f64> {
        self.coarse.basis()
    }

    /// max |Σ_s D_s R_s − 1| over the interface DOFs (D05 5.8).
    pub fn partition_of_unity_error(&self) -> f64 {
        self.unity_error
    }

    fn gather(&self, b: &LinearBlock, x: &[f64]) -> Vec<f64> {
        b.gamma.iter().map(|&g| x[g]).collect()
    }

    /// Sum block contributions in block order (bit-for-bit independent of the thread count);
    /// `parts` may cover only the leading blocks.
    fn accumulate(&self, parts: Vec<Vec<f64>>) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        for (b, part) in self.blocks.iter().zip(parts) {
            for (&g, v) in b.gamma.iter().zip(part) {
                y[g] += v;
            }
        }
        y
    }

    /// S x = Σ R_sᵀ S_s R_s x.
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let parts: Vec<Vec<f64>> = self
            .blocks
            .par_iter()
            .map(|b| b.schur(&self.gather(b, x)))
            .collect();
        self.accumulate(parts)
    }

    /// S X for the columns of X (only the columns touching a block are solved there).
    pub fn apply_mat(&self, x: &Mat<f64>) -> Mat<f64> {
        let parts: Vec<(Vec<usize>, Mat<f64>)> = self
            .blocks
            .par_iter()
            .map(|b| {
                let cols: Vec<usize> = (0..x.ncols())
                    .filter(|&j| b.gamma.iter().any(|&g| x[(g, j)] != 0.0))
                    .collect();
                let local =
                    Mat::from_fn(b.gamma.len(), cols.len(), |i, j| x[(b.gamma[i], cols[j])]);
                (cols, b.schur_mat(local.as_ref()))
            })
            .collect();
        let mut y = Mat::<f64>::zeros(self.n, x.ncols());
        for (b, (cols, s)) in self.blocks.iter().zip(parts) {
            for (jl, &j) in cols.iter().enumerate() {
                for (i, &g) in b.gamma.iter().enumerate() {
                    y[(g, j)] += s[(i, jl)];
                }
            }
        }
        y
    }

    /// The Neumann–Neumann sum Σ D_s S_s⁺ D_sᵀ r (D05 5.9).
    pub fn neumann_sum(&self, r: &[f64]) -> Vec<f64> {
        let parts: Vec<Vec<f64>> = self.blocks[..self.preconditioning]
            .par_iter()
            .zip(&self.weights)
            .map(|(b, w)| {
                let g: Vec<f64> = b.gamma.iter().zip(w).map(|(&i, wi)| wi * r[i]).collect();
                b.neumann(&g).iter().zip(w).map(|(x, wi)| x * wi).collect()
            })
            .collect();
        self.accumulate(parts)
    }
}

/// Orthonormal basis of the weighted interface traces {D_s γ z : z ∈ Ker A_s} of one block,
/// scattered to the interface of size `n` (D05 5.11). Rank-revealing: a kernel motion that does
/// not reach the interface (a floating part inside a cluster) makes the traces dependent, and
/// only singular directions above [`TRACE_TOL`] (the kernel basis is orthonormal) are kept.
fn weighted_kernel_traces(
    b: &LinearBlock,
    weights: &[f64],
    n: usize,
) -> Result<Vec<Vec<f64>>, DdError> {
    let z = b.kernel();
    if z.ncols() == 0 {
        return Ok(Vec::new());
    }
    let ng = b.gamma.len();
    let trace = Mat::from_fn(ng.max(z.ncols()), z.ncols(), |i, j| {
        if i < ng {
            weights[i] * z[(b.n_interior + i, j)]
        } else {
            0.0
        }
    });
    let svd = trace
        .thin_svd()
        .map_err(|e| DdError::Coarse(format!("coarse trace SVD: {e:?}")))?;
    let (s, u) = (svd.S().column_vector(), svd.U());
    Ok((0..z.ncols())
        .filter(|&c| s[c] > TRACE_TOL)
        .map(|c| {
            let mut col = vec![0.0; n];
            for (i, &g) in b.gamma.iter().enumerate() {
                col[g] = u[(i, c)];
            }
            col
        })
        .collect())
}

impl Interface for Balancing<'_> {
    fn apply(&self, x: &[f64]) -> Vec<f64> {
        Balancing::apply(self, x)
    }

    /// M⁻¹ r = (I − P_Z) Σ D_s S_s⁺ D_sᵀ r, for r ⊥ V_H.
    fn precondition(&self, r: &[f64]) -> Vec<f64> {
        let mut z = self.neumann_sum(r);
        self.coarse.project(&mut z);
        z
    }

    fn coarse_start(&self, mut x: Vec<f64>, b: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let sx = self.apply(&x);
        let mut r: Vec<f64> = b.iter().zip(&sx).map(|(b, s)| b - s).collect();
        self.coarse.start(&mut x, &mut r);
        (x, r)
    }

    fn coarse_residual(&self, r: &[f64]) -> f64 {
        self.coarse.residual(r)
    }
}
