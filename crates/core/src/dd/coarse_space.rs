//! Coarse spaces of the balancing preconditioners (D05 5.12–5.15): a sparse basis W of unit
//! columns, its image A W and the factored coarse matrix G = Wᵀ A W, giving the A-orthogonal
//! projection P_Z = W G⁻¹ (AW)ᵀ (5.12–5.14), the coarse start x ← x + W G⁻¹ Wᵀ (b − A x) (5.15,
//! Lemma 5.1 / 6.1) and the coarse-residual check. Dependent enrichment columns are dropped by a
//! pivoted Cholesky.
//!
//! Depends only on [`super::dense`] and [`super::DdError`]; used by [`super::pcg`] (the
//! [`super::pcg::Interface`] trait), [`super::coarse`] (balancing) and [`super::newton`].

use faer::Mat;
use rayon::prelude::*;

use super::dense::Cholesky;
use super::DdError;

/// Columns of an n-row matrix stored sparse (sorted row indices): coarse bases and their images
/// are supported on one subdomain's interface (and its neighbours'), so dense storage would
/// grow like n × (3 · subdomains).
#[derive(Debug, Clone, Default)]
pub struct SparseColumns {
    pub n: usize,
    pub cols: Vec<SparseColumn>,
}

/// One sparse column: (row, value) with sorted rows.
pub type SparseColumn = Vec<(usize, f64)>;

impl SparseColumns {
    pub fn ncols(&self) -> usize {
        self.cols.len()
    }

    /// The nonzeros of a dense column.
    pub fn sparsify(v: &[f64]) -> SparseColumn {
        v.iter()
            .enumerate()
            .filter(|(_, x)| **x != 0.0)
            .map(|(i, &x)| (i, x))
            .collect()
    }

    pub fn dense(&self, j: usize) -> Vec<f64> {
        let mut v = vec![0.0; self.n];
        for &(i, x) in &self.cols[j] {
            v[i] = x;
        }
        v
    }

    fn dot(col: &[(usize, f64)], v: &[f64]) -> f64 {
        col.iter().map(|&(i, x)| x * v[i]).sum()
    }

    /// Mᵀ v.
    fn tdot(&self, v: &[f64]) -> Vec<f64> {
        self.cols.iter().map(|c| Self::dot(c, v)).collect()
    }

    /// y −= M a.
    fn sub_mul(&self, a: &[f64], y: &mut [f64]) {
        for (col, &aj) in self.cols.iter().zip(a) {
            for &(i, x) in col {
                y[i] -= x * aj;
            }
        }
    }
}

/// Smallest Cholesky pivot of the coarse matrix, relative to its diagonal entry, accepted as
/// nonsingular.
const PIVOT_TOL: f64 = 1e-10;

/// A coarse space W (unit columns) for an operator A, with A W and the coarse matrix
/// G = Wᵀ A W factored: the A-orthogonal projection and the coarse start of D05 5.12–5.15,
/// shared by [`super::coarse::Balancing`] and the Newton operator of [`super::newton`].
pub struct CoarseSpace {
    w: SparseColumns,
    aw: SparseColumns,
    /// Factor of G = WᵀAW (`None` for an empty coarse space).
    llt: Option<Cholesky>,
}

impl CoarseSpace {
    /// `w` (n × d) and `aw` = A W; the first `required` columns must stay (the floating kernels
    /// that balance the Neumann problems), the others (enrichment) are dropped where they depend
    /// on earlier ones (e.g. the rigid traces of the middle subdomain of a chain).
    pub fn new(
        w: SparseColumns,
        aw: SparseColumns,
        required: usize,
    ) -> Result<CoarseSpace, DdError> {
        let g = Self::gram(&w, &aw);
        if let Some(llt) = Self::factor(&g) {
            return Ok(CoarseSpace { w, aw, llt });
        }
        let keep = independent_columns(&g);
        if (0..required).any(|j| !keep.contains(&j)) {
            return Err(DdError::Coarse(
                "WᵀSW is not positive definite: the interface operator is singular on the \
                 coarse space (a part of a body held by nothing but contact, or a subdomain \
                 floating in the non-contact part)"
                    .into(),
            ));
        }
        let pick = |m: SparseColumns| SparseColumns {
            n: m.n,
            cols: keep.iter().map(|&j| m.cols[j].clone()).collect(),
        };
        let (w, aw) = (pick(w), pick(aw));
        let g = Mat::from_fn(keep.len(), keep.len(), |i, j| g[(keep[i], keep[j])]);
        let llt = Self::factor(&g).ok_or_else(|| {
            DdError::Coarse(
                "the coarse matrix stays singular after dropping dependent columns".into(),
            )
        })?;
        Ok(CoarseSpace { w, aw, llt })
    }

    /// G = Wᵀ A W, symmetrised; column by column: scatter (AW)_j once, dot with every column of W.
    fn gram(w: &SparseColumns, aw: &SparseColumns) -> Mat<f64> {
        let d = w.ncols();
        let cols: Vec<Vec<f64>> = (0..d)
            .into_par_iter()
            .map(|j| {
                let awj = aw.dense(j);
                w.cols.iter().map(|c| SparseColumns::dot(c, &awj)).collect()
            })
            .collect();
        Mat::from_fn(d, d, |i, j| 0.5 * (cols[j][i] + cols[i][j]))
    }

    /// Cholesky of G, `None` when a pivot is not positive or lost all but [`PIVOT_TOL`] of its
    /// diagonal (numerically singular: it would wreck the projection). Empty G: an empty factor.
    fn factor(g: &Mat<f64>) -> Option<Option<Cholesky>> {
        if g.nrows() == 0 {
            return Some(None);
        }
        let llt = Cholesky::new(g.as_ref())?;
        let l = llt.l();
        let ok = (0..g.nrows()).all(|i| l[(i, i)] * l[(i, i)] >= PIVOT_TOL * g[(i, i)]);
        ok.then_some(Some(llt))
    }

    pub fn dim(&self) -> usize {
        self.w.ncols()
    }

    pub fn basis(&self) -> &SparseColumns {
        &self.w
    }

    /// A W.
    pub fn image(&self) -> &SparseColumns {
        &self.aw
    }

    fn solve(&self, rhs: Vec<f64>) -> Vec<f64> {
        match &self.llt {
            Some(llt) => llt.solve_vec(&rhs),
            None => rhs,
        }
    }

    /// z ← (I − P_Z) z, P_Z = W G⁻¹ (AW)ᵀ.
    pub fn project(&self, z: &mut [f64]) {
        if self.dim() == 0 {
            return;
        }
        let a = self.solve(self.aw.tdot(z));
        self.w.sub_mul(&a, z);
    }

    /// x ← x + W G⁻¹ Wᵀ r, r ← r − AW G⁻¹ Wᵀ r for the residual r = b − A x.
    pub fn start(&self, x: &mut [f64], r: &mut [f64]) {
        if self.dim() == 0 {
            return;
        }
        let a = self.solve(self.w.tdot(r));
        let minus: Vec<f64> = a.iter().map(|v| -v).collect();
        self.w.sub_mul(&minus, x);
        self.aw.sub_mul(&a, r);
    }

    /// max_j |w_jᵀ r| (columns of W have unit norm).
    pub fn residual(&self, r: &[f64]) -> f64 {
        self.w.tdot(r).iter().map(|v| v.abs()).fold(0.0, f64::max)
    }
}

/// Columns of the symmetric positive semidefinite G kept by a Cholesky factorisation that skips
/// every column whose pivot falls below [`PIVOT_TOL`] times its diagonal (it depends on the
/// columns kept before it). O(d³) in plain loops: only used when the fast factorisation fails.
fn independent_columns(g: &Mat<f64>) -> Vec<usize> {
    let d = g.nrows();
    let mut l = Mat::<f64>::zeros(d, d);
    let mut keep = Vec::with_capacity(d);
    for j in 0..d {
        let mut col: Vec<f64> = (j..d).map(|i| g[(i, j)]).collect();
        for &k in &keep {
            let ljk = l[(j, k)];
            if ljk != 0.0 {
                for (c, i) in col.iter_mut().zip(j..d) {
                    *c -= l[(i, k)] * ljk;
                }
            }
        }
        if col[0] < PIVOT_TOL * g[(j, j)] || col[0] <= 0.0 {
            continue;
        }
        let p = col[0].sqrt();
        for (c, i) in col.iter().zip(j..d) {
            l[(i, j)] = c / p;
        }
        keep.push(j);
    }
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dependent_coarse_columns_are_dropped_in_order() {
        // Columns 0, 1 independent; column 2 = column 0 + column 1; column 3 independent.
        let v = [
            [1.0, 0.0, 1.0, 0.0],
            [0.0, 1.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [1.0, 1.0, 2.0, 1.0],
        ];
        let a = Mat::from_fn(4, 4, |i, j| v[i][j]);
        let g = a.transpose() * &a;
        assert_eq!(independent_columns(&g), vec![0, 1, 3]);
    }
}
