//! Balancing Neumann–Neumann preconditioner (D05 §5, §6; D03 §4; Le Tallec / Mandel BDD).
//!
//! Over a set of [`LinearBlock`]s with interface restrictions R_s:
//! - S = Σ R_sᵀ S_s R_s (D05 4.33 / Def. 4.4), applied block-parallel with a fixed summation order;
//!   blocks may enter S only (the tied clusters under the reduced PCG1 preconditioner,
//!   [`Balancing::new`]);
//! - injections D_s = diag(ρ_s / Σ_{t ∋ dof} ρ_t) over the preconditioning blocks (D05 5.5–5.8);
//!   over the non-contact subdomains only this is the reduced D̊ of D05 6.4–6.6 (weight 1 on a
//!   contact-pair interface DOF), except at a cross point: where several non-contact subdomains
//!   share such a DOF, weight 1 each would break the partition of unity, so the weight stays
//!   ρ_s over the sum of theirs (1 where only one carries it). Σ D_s R_s = I is checked
//!   ([`Balancing::partition_of_unity_error`]);
//! - coarse space V_H = span{D_s γ z : z ∈ Ker A_s} (D05 5.11 / 6.7), optionally enriched with the
//!   weighted rigid-motion traces of every preconditioning block (dependent enrichment dropped),
//!   W its sparse basis, G = WᵀSW;
//! - M⁻¹ r = (I − P_Z) Σ D_s S_s⁺ D_sᵀ r with P_Z v = W G⁻¹ (SW)ᵀ v, the S-orthogonal projection
//!   onto V_H (D05 5.12–5.14);
//! - the coarse start x ← x + W G⁻¹ Wᵀ (b − S x), which makes the residual orthogonal to V_H
//!   (D05 5.15, Lemma 5.1 / 6.1).
//!
//! Depends on [`super::coarse_space`] (W, A W, G and the projections), [`super::pcg`] (it
//! implements [`Interface`]), [`super::subdomain`] (the blocks) and [`super::dense`]; nothing
//! in those modules depends on this one.

use faer::{Mat, MatRef};
use rayon::prelude::*;

use super::coarse_space::{CoarseSpace, SparseColumn, SparseColumns};
use super::dense::{thin_svd, ThinSvd};
use super::pcg::Interface;
use super::subdomain::LinearBlock;
use super::DdError;

/// Singular value of a block's weighted coarse traces, relative to the largest, below which a
/// direction is rounding of a motion that does not reach the interface.
const TRACE_TOL: f64 = 1e-10;

/// The interface operator and its balancing preconditioner over a set of blocks.
pub struct Balancing<'a> {
    /// Operator blocks; the first `preconditioning` of them also precondition.
    blocks: Vec<&'a LinearBlock>,
    preconditioning: usize,
    /// D_s diagonal per preconditioning block (local interface order).
    weights: Vec<Vec<f64>>,
    n: usize,
    /// Blocks (in order) holding each interface DOF.
    dof_blocks: Vec<Vec<usize>>,
    coarse: CoarseSpace,
    unity_error: f64,
}

impl<'a> Balancing<'a> {
    /// The operator S = Σ R_sᵀ S_s R_s over `preconditioning` and `operator_only` blocks, with the
    /// weights and the coarse problem on an interface of size `n`. The `preconditioning` blocks
    /// carry the Neumann–Neumann part (D05 §5 for S, §6 for S0); `operator_only` blocks enter S
    /// but not the preconditioner: the reduced balancing preconditioner of D05 §6 (injections D̊,
    /// coarse space V_0H) applied to S = S0 + Σ tied clusters (see
    /// [`super::options::Pcg1Preconditioner`]). `enrich[s]`, when given, adds the weighted
    /// traces of these local interface vectors of preconditioning block s (n_Γ,s × k) to the
    /// coarse space.
    pub fn new(
        preconditioning: Vec<&'a LinearBlock>,
        operator_only: Vec<&'a LinearBlock>,
        enrich: &[Option<Mat<f64>>],
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
        let mut cols: Vec<SparseColumn> = Vec::new();
        let mut optional: Vec<SparseColumn> = Vec::new();
        for (s, (b, w)) in preconditioning.iter().zip(&weights).enumerate() {
            let extra = enrich.get(s).and_then(|e| e.as_ref());
            let (req, opt) = weighted_traces(b, extra, w)?;
            cols.extend(req);
            optional.extend(opt);
        }
        let required = cols.len();
        cols.extend(optional);
        let w = SparseColumns { n, cols };
        let n_pre = preconditioning.len();
        let mut blocks = preconditioning;
        blocks.extend(operator_only);
        let mut dof_blocks = vec![Vec::new(); n];
        for (s, b) in blocks.iter().enumerate() {
            for &g in &b.gamma {
                dof_blocks[g].push(s);
            }
        }
        let mut bal = Balancing {
            blocks,
            preconditioning: n_pre,
            weights,
            n,
            dof_blocks,
            coarse: CoarseSpace::new(SparseColumns::default(), SparseColumns::default(), 0)?,
            unity_error,
        };
        let sw = bal.apply_mat(&w);
        bal.coarse = CoarseSpace::new(w, sw, required)?;
        Ok(bal)
    }

    /// Dimension of the coarse space.
    pub fn coarse_dim(&self) -> usize {
        self.coarse.dim()
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

    /// S X for the sparse columns of X: each block solves only the columns that touch it; the
    /// contributions are summed in block order (bit-for-bit independent of the thread count).
    pub fn apply_mat(&self, x: &SparseColumns) -> SparseColumns {
        let mut block_cols: Vec<Vec<usize>> = vec![Vec::new(); self.blocks.len()];
        for (j, col) in x.cols.iter().enumerate() {
            let mut touched: Vec<usize> = col
                .iter()
                .flat_map(|&(g, _)| self.dof_blocks[g].iter().copied())
                .collect();
            touched.sort_unstable();
            touched.dedup();
            for s in touched {
                block_cols[s].push(j);
            }
        }
        let parts: Vec<Mat<f64>> = self
            .blocks
            .par_iter()
            .zip(&block_cols)
            .map(|(b, cols)| {
                let local: std::collections::HashMap<usize, usize> =
                    b.gamma.iter().enumerate().map(|(i, &g)| (g, i)).collect();
                let mut m = Mat::<f64>::zeros(b.gamma.len(), cols.len());
                for (jl, &j) in cols.iter().enumerate() {
                    for &(g, v) in &x.cols[j] {
                        if let Some(&i) = local.get(&g) {
                            m[(i, jl)] = v;
                        }
                    }
                }
                b.schur_mat(m.as_ref())
            })
            .collect();
        let mut out: Vec<Vec<(usize, f64)>> = vec![Vec::new(); x.ncols()];
        for ((b, cols), s) in self.blocks.iter().zip(&block_cols).zip(parts) {
            for (jl, &j) in cols.iter().enumerate() {
                out[j].extend(b.gamma.iter().enumerate().map(|(i, &g)| (g, s[(i, jl)])));
            }
        }
        let cols = out
            .into_par_iter()
            .map(|mut col| {
                col.sort_by_key(|e| e.0);
                let mut merged: Vec<(usize, f64)> = Vec::with_capacity(col.len());
                for (g, v) in col {
                    match merged.last_mut() {
                        Some(last) if last.0 == g => last.1 += v,
                        _ => merged.push((g, v)),
                    }
                }
                merged
            })
            .collect();
        SparseColumns { n: self.n, cols }
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

/// The weighted interface traces of one block as sparse interface columns: an orthonormal basis
/// of {D_s γ z : z ∈ Ker A_s} (D05 5.11; required for the balancing), and an orthonormal basis of
/// the part of D_s × (columns of `extra`) orthogonal to it (optional enrichment). Rank-revealing:
/// a kernel motion that does not reach the interface (a floating part inside a cluster) makes
/// the traces dependent; only singular directions above [`TRACE_TOL`] (relative to the largest
/// of their group) are kept.
fn weighted_traces(
    b: &LinearBlock,
    extra: Option<&Mat<f64>>,
    weights: &[f64],
) -> Result<(Vec<SparseColumn>, Vec<SparseColumn>), DdError> {
    let z = b.kernel();
    let ng = b.gamma.len();
    let kernel = Mat::from_fn(ng, z.ncols(), |i, j| weights[i] * z[(b.n_interior + i, j)]);
    let required = orthonormal_range(kernel.as_ref(), 0.0)?;
    let optional = match extra {
        Some(e) => {
            let mut t = Mat::from_fn(ng, e.ncols(), |i, j| weights[i] * e[(i, j)]);
            let scale = t
                .col_iter()
                .map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt())
                .fold(0.0, f64::max);
            // Remove the kernel directions (twice, for rounding).
            for _ in 0..2 {
                for q in required.col_iter() {
                    for mut c in t.col_iter_mut() {
                        let d: f64 = (0..ng).map(|i| q[i] * c[i]).sum();
                        for i in 0..ng {
                            c[i] -= d * q[i];
                        }
                    }
                }
            }
            orthonormal_range(t.as_ref(), scale)?
        }
        None => Mat::zeros(ng, 0),
    };
    let scatter = |m: &Mat<f64>| -> Vec<SparseColumn> {
        m.col_iter()
            .map(|c| {
                let mut col: Vec<(usize, f64)> = b
                    .gamma
                    .iter()
                    .enumerate()
                    .map(|(i, &g)| (g, c[i]))
                    .collect();
                col.sort_by_key(|e| e.0);
                col
            })
            .collect()
    };
    Ok((scatter(&required), scatter(&optional)))
}

/// Orthonormal basis of the range of `a` (n × k): left singular vectors with singular values
/// above [`TRACE_TOL`] times the largest or times `scale` (the size of `a` before a projection
/// removed its known part), whichever is larger.
fn orthonormal_range(a: MatRef<'_, f64>, scale: f64) -> Result<Mat<f64>, DdError> {
    let (n, k) = (a.nrows(), a.ncols());
    if k == 0 {
        return Ok(Mat::zeros(n, 0));
    }
    let ThinSvd { s, u, .. } = thin_svd(a).map_err(DdError::Coarse)?;
    let top = (0..k).map(|c| s[c]).fold(scale, f64::max);
    let keep: Vec<usize> = (0..k).filter(|&c| s[c] > TRACE_TOL * top).collect();
    Ok(Mat::from_fn(n, keep.len(), |i, j| u[(i, keep[j])]))
}

impl Interface for Balancing<'_> {
    fn apply(&self, x: &[f64]) -> Vec<f64> {
        Balancing::apply(self, x)
    }

    fn neumann_sum(&self, r: &[f64]) -> Vec<f64> {
        Balancing::neumann_sum(self, r)
    }

    fn coarse(&self) -> &CoarseSpace {
        &self.coarse
    }
}
