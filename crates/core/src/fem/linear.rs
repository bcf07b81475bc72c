//! Sparse direct solver: faer supernodal/simplicial Cholesky K = LLᵀ with the fill-reducing
//! ordering and symbolic analysis computed once per operator and shared (`Arc`) by every numeric
//! factorisation of a matrix with the same pattern (design §3.1: refactor numerically on a reused
//! symbolic factorisation; `Par::Seq` inside parallel evaluations).
//!
//! Schur complements: [`Symbolic::analyse_with_trailing`] orders a chosen set of DOFs c last
//! (after a fill-reducing ordering of the others) and forces a supernodal factor. Writing the
//! permuted K = [K₁₁ K₁c; K_c1 K_cc] = L Lᵀ with L = [L₁₁ 0; L_c1 L₂₂], the Schur complement
//! S = K_cc − K_c1 K₁₁⁻¹ K₁c equals L₂₂ L₂₂ᵀ, hence (K⁻¹)_cc = S⁻¹ = (L₂₂ L₂₂ᵀ)⁻¹ exactly.
//! [`Factor::trailing_block`] reads diagonal blocks of the dense L₂₂ from the supernodes.
//!
//! Symmetric quasi-definite matrices [[A, Bᵀ], [B, −C]] (A, C positive definite: the mixed u–p
//! element, design §2.7) are factorised as LDLᵀ without pivoting on the same symbolic analysis
//! ([`Symbolic::factorize_quasi_definite`]): every symmetric permutation of a quasi-definite
//! matrix has such a factorisation, with D > 0 on the pivots of A and D < 0 on those of C
//! (Vanderbei 1995, its Schur complements are quasi-definite again).

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::solvers::{LdltError, LltError};
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LdltRef, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatMut, Par, Side};

use super::FemError;

/// Symbolic Cholesky analysis (ordering, elimination tree, supernodes) of a lower-triangular
/// pattern; cheap to clone.
#[derive(Debug, Clone)]
pub struct Symbolic {
    inner: Arc<SymbolicCholesky<usize>>,
    /// Number of DOFs ordered last (0 for a plain AMD analysis).
    trailing: usize,
}

impl Symbolic {
    /// Analyse the lower triangle `pattern` of a symmetric matrix (AMD ordering).
    pub fn analyse(pattern: SymbolicSparseColMatRef<'_, usize>) -> Result<Symbolic, FemError> {
        let inner = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| FemError::Solver(format!("symbolic Cholesky: {e:?}")))?;
        Ok(Symbolic {
            inner: Arc::new(inner),
            trailing: 0,
        })
    }

    /// Analyse `pattern` (lower triangle) with the DOFs `trailing` eliminated last, in the
    /// given order, after an AMD ordering of the other DOFs (AMD of their submatrix), and a
    /// supernodal factor, so that `Factor::trailing_block` can read L₂₂ (module doc).
    pub fn analyse_with_trailing(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        trailing: &[usize],
    ) -> Result<Symbolic, FemError> {
        let n = pattern.ncols();
        let mut is_trailing = vec![false; n];
        for &d in trailing {
            match is_trailing.get_mut(d) {
                Some(t) if !*t => *t = true,
                _ => {
                    return Err(FemError::Input(format!(
                        "trailing DOF {d} repeated or outside 0..{n}"
                    )))
                }
            }
        }
        // Submatrix of the leading DOFs, renumbered in increasing order (stays lower, sorted).
        let lead: Vec<usize> = (0..n).filter(|&i| !is_trailing[i]).collect();
        let mut sub_index = vec![usize::MAX; n];
        for (k, &i) in lead.iter().enumerate() {
            sub_index[i] = k;
        }
        let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
        let mut sub_ptr = Vec::with_capacity(lead.len() + 1);
        let mut sub_rows = Vec::new();
        sub_ptr.push(0);
        for &c in &lead {
            sub_rows.extend(
                row_idx[col_ptr[c]..col_ptr[c + 1]]
                    .iter()
                    .filter(|&&r| !is_trailing[r])
                    .map(|&r| sub_index[r]),
            );
            sub_ptr.push(sub_rows.len());
        }
        let nl = lead.len();
        let solver =
            |e: &dyn std::fmt::Debug| FemError::Solver(format!("symbolic Cholesky: {e:?}"));
        let sub = SymbolicSparseColMat::new_checked(nl, nl, sub_ptr, None, sub_rows);
        // Two orders of the leading DOFs: AMD of their submatrix, and AMD of the whole pattern
        // with the trailing DOFs left out (it sees the couplings through them); the one with
        // the sparser factor is kept.
        let by_sub: Vec<usize> = amd_order(sub.as_ref())?
            .into_iter()
            .map(|k| lead[k])
            .collect();
        let by_full: Vec<usize> = amd_order(pattern)?
            .into_iter()
            .filter(|&i| !is_trailing[i])
            .collect();
        let mut best: Option<SymbolicCholesky<usize>> = None;
        for order in [by_sub, by_full] {
            // fwd[new] = old: the ordered leading DOFs, then the trailing ones.
            let fwd: Vec<usize> = order.into_iter().chain(trailing.iter().copied()).collect();
            let mut inv = vec![0usize; n];
            for (new, &old) in fwd.iter().enumerate() {
                inv[old] = new;
            }
            let perm = PermRef::new_checked(&fwd, &inv, n);
            let params = CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            };
            let candidate = factorize_symbolic_cholesky(
                pattern,
                Side::Lower,
                SymmetricOrdering::Custom(perm),
                params,
            )
            .map_err(|e| solver(&e))?;
            if best
                .as_ref()
                .is_none_or(|b| candidate.len_val() < b.len_val())
            {
                best = Some(candidate);
            }
        }
        let inner = best.ok_or_else(|| FemError::Solver("no ordering".into()))?;
        Ok(Symbolic {
            inner: Arc::new(inner),
            trailing: trailing.len(),
        })
    }

    /// Boundaries 0 = b₀ < b₁ < … < b_k = (number of trailing DOFs) of the finest diagonal blocks of L₂₂
    /// (structurally block diagonal: no nonzero below a block in the columns of that block;
    /// e.g. one block per body when K is block diagonal over bodies).
    pub fn trailing_blocks(&self) -> Vec<usize> {
        let t = self.trailing;
        let mut bounds = vec![0];
        let SymbolicCholeskyRaw::Supernodal(sn) = self.inner.raw() else {
            // Only a plain analysis (t = 0) may be simplicial.
            return bounds;
        };
        let start = sn.nrows() - t;
        // reach[j]: last row (trailing numbering) of a nonzero in column j of L₂₂.
        let mut reach = vec![0usize; t];
        for s in 0..sn.n_supernodes() {
            let (begin, end) = (sn.supernode_begin()[s], sn.supernode_end()[s]);
            if end <= start {
                continue;
            }
            let last = sn
                .supernode(s)
                .pattern()
                .iter()
                .fold(end - 1, |a, &r| a.max(r));
            for r in &mut reach[begin.max(start) - start..end - start] {
                *r = last - start;
            }
        }
        let mut furthest = 0;
        for (j, &r) in reach.iter().enumerate() {
            furthest = furthest.max(r);
            if furthest == j {
                bounds.push(j + 1);
            }
        }
        bounds
    }

    /// Number of nonzeros of the factor L.
    pub fn factor_nnz(&self) -> usize {
        self.inner.len_val()
    }

    /// Numeric factorisation of `matrix` (lower triangle, same pattern as analysed).
    pub fn factorize(
        &self,
        matrix: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> Result<Factor, FemError> {
        let mut values = vec![0.0; self.inner.len_val()];
        let scratch = self
            .inner
            .factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let mut buffer = MemBuffer::try_new(scratch)
            .map_err(|_| FemError::Solver("out of memory in numeric Cholesky".into()))?;
        self.inner
            .factorize_numeric_llt(
                &mut values,
                matrix,
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|e| match e {
                LltError::NonPositivePivot { index } => {
                    FemError::NotPositiveDefinite { pivot: index }
                }
            })?;
        Ok(Factor {
            symbolic: self.clone(),
            values,
            par,
            quasi_definite: false,
        })
    }

    /// Numeric LDLᵀ factorisation without pivoting of a symmetric quasi-definite `matrix` (lower
    /// triangle, same pattern as analysed; module doc). A zero pivot (the matrix is not
    /// quasi-definite) is an error.
    pub fn factorize_quasi_definite(
        &self,
        matrix: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> Result<Factor, FemError> {
        let mut values = vec![0.0; self.inner.len_val()];
        let scratch = self
            .inner
            .factorize_numeric_ldlt_scratch::<f64>(par, Default::default());
        let mut buffer = MemBuffer::try_new(scratch)
            .map_err(|_| FemError::Solver("out of memory in numeric LDLT".into()))?;
        self.inner
            .factorize_numeric_ldlt(
                &mut values,
                matrix,
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|e| match e {
                LdltError::ZeroPivot { index } => FemError::NotPositiveDefinite { pivot: index },
            })?;
        Ok(Factor {
            symbolic: self.clone(),
            values,
            par,
            quasi_definite: true,
        })
    }
}

/// y = A x for a symmetric A given by its lower triangle: `pattern` and its `values`.
pub fn symmetric_apply(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    values: &[f64],
    x: &[f64],
) -> Vec<f64> {
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    let mut y = vec![0.0; x.len()];
    for c in 0..pattern.ncols() {
        for p in col_ptr[c]..col_ptr[c + 1] {
            let r = row_idx[p];
            y[r] += values[p] * x[c];
            if r != c {
                y[c] += values[p] * x[r];
            }
        }
    }
    y
}

/// The AMD order (new → old) of the symmetric matrix with lower-triangular `pattern`.
fn amd_order(pattern: SymbolicSparseColMatRef<'_, usize>) -> Result<Vec<usize>, FemError> {
    let n = pattern.ncols();
    let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
    let mut buffer = MemBuffer::try_new(amd::order_scratch::<usize>(n, pattern.compute_nnz()))
        .map_err(|_| FemError::Solver("out of memory in AMD ordering".into()))?;
    amd::order(
        &mut fwd,
        &mut inv,
        pattern,
        amd::Control::default(),
        MemStack::new(&mut buffer),
    )
    .map_err(|e| FemError::Solver(format!("AMD ordering: {e:?}")))?;
    Ok(fwd)
}

/// Numeric Cholesky factor of a symmetric positive definite matrix (or LDLᵀ factor of a
/// quasi-definite one): solves K x = b for one or many right-hand sides.
#[derive(Debug, Clone)]
pub struct Factor {
    symbolic: Symbolic,
    values: Vec<f64>,
    par: Par,
    /// LDLᵀ of a quasi-definite matrix rather than LLᵀ.
    quasi_definite: bool,
}

impl Factor {
    /// Number of stored nonzeros of L.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Dimension of K.
    pub fn dim(&self) -> usize {
        self.symbolic.inner.nrows()
    }

    /// Overwrite each column b of `rhs` with K⁻¹ b.
    pub fn solve_in_place(&self, rhs: MatMut<'_, f64>) {
        let scratch = self
            .symbolic
            .inner
            .solve_in_place_scratch::<f64>(rhs.ncols(), self.par);
        let mut buffer = MemBuffer::new(scratch);
        let stack = MemStack::new(&mut buffer);
        if self.quasi_definite {
            LdltRef::new(&self.symbolic.inner, &self.values).solve_in_place_with_conj(
                Conj::No,
                rhs,
                self.par,
                stack,
            );
        } else {
            LltRef::new(&self.symbolic.inner, &self.values).solve_in_place_with_conj(
                Conj::No,
                rhs,
                self.par,
                stack,
            );
        }
    }

    /// The diagonal block L₂₂[range, range] (dense, lower triangular, zero above the diagonal)
    /// of the trailing block of L (of L D^½ for an LDLᵀ factor, whose trailing pivots must then
    /// be positive), `range` in the trailing numbering (the order given to
    /// [`Symbolic::analyse_with_trailing`]).
    pub fn trailing_block(&self, range: std::ops::Range<usize>) -> Result<Mat<f64>, FemError> {
        let t = self.symbolic.trailing;
        if range.start > range.end || range.end > t {
            return Err(FemError::Input(format!(
                "trailing block {range:?} outside 0..{t}"
            )));
        }
        let mut block = Mat::<f64>::zeros(range.len(), range.len());
        if range.is_empty() {
            return Ok(block);
        }
        let SymbolicCholeskyRaw::Supernodal(sn) = self.symbolic.inner.raw() else {
            return Err(FemError::Solver(
                "trailing block of a simplicial factor".into(),
            ));
        };
        let start = sn.nrows() - t;
        let (lo, hi) = (start + range.start, start + range.end);
        let llt = SupernodalLltRef::new(sn, &self.values);
        for s in 0..sn.n_supernodes() {
            let (begin, end) = (sn.supernode_begin()[s], sn.supernode_end()[s]);
            if end <= lo || begin >= hi {
                continue;
            }
            // Rows of the supernode: its own columns begin..end, then `pattern` (all ≥ end).
            let node = llt.supernode(s);
            let val = node.val();
            let rows = (begin..end).chain(node.pattern().iter().copied());
            for j in begin.max(lo)..end.min(hi) {
                for (k, r) in rows.clone().enumerate().skip(j - begin) {
                    if r < hi {
                        block[(r - lo, j - lo)] = val[(k, j - begin)];
                    }
                }
            }
        }
        if self.quasi_definite {
            // Unit L with D on the diagonal: the Cholesky factor of the trailing Schur
            // complement is L₂₂ D₂₂^½, D₂₂ > 0 when every negative pivot is eliminated earlier.
            for j in 0..range.len() {
                let d = block[(j, j)];
                if d.is_nan() || d <= 0.0 {
                    return Err(FemError::NotPositiveDefinite {
                        pivot: start + range.start + j,
                    });
                }
                let root = d.sqrt();
                block[(j, j)] = root;
                for r in j + 1..range.len() {
                    block[(r, j)] *= root;
                }
            }
        }
        Ok(block)
    }

    /// K⁻¹ b for one right-hand side.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x = Mat::<f64>::from_fn(b.len(), 1, |i, _| b[i]);
        self.solve_in_place(x.as_mut());
        x.col(0).iter().copied().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, Triplet};

    /// Lower triangle of two decoupled chains 0..4 and 4..8 (2 on the diagonal, −1 off it,
    /// plus i/10 on the diagonal to break symmetries).
    fn two_chains() -> SparseColMat<usize, f64> {
        let mut t = Vec::new();
        for i in 0..8 {
            t.push(Triplet::new(i, i, 2.0 + i as f64 / 10.0));
            if i % 4 != 3 {
                t.push(Triplet::new(i + 1, i, -1.0));
            }
        }
        SparseColMat::try_new_from_triplets(8, 8, &t).unwrap()
    }

    #[test]
    fn trailing_block_gives_the_inverse_on_the_trailing_dofs() {
        let k = two_chains();
        let trailing = [1, 2, 6];
        let symbolic = Symbolic::analyse_with_trailing(k.symbolic(), &trailing).unwrap();
        assert_eq!(
            symbolic.trailing_blocks(),
            vec![0, 2, 3],
            "one block per chain"
        );
        let factor = symbolic.factorize(k.as_ref(), Par::Seq).unwrap();
        let l = factor.trailing_block(0..3).unwrap();
        assert_eq!(l[(2, 0)], 0.0);
        // (K⁻¹)_cc (L₂₂ L₂₂ᵀ) = I.
        let s = &l * l.transpose();
        for (j, &dj) in trailing.iter().enumerate() {
            let mut e = vec![0.0; 8];
            e[dj] = 1.0;
            let x = factor.solve(&e);
            for i in 0..3 {
                let v: f64 = (0..3).map(|k| x[trailing[k]] * s[(k, i)]).sum();
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((v - expected).abs() < 1e-14, "({i}, {j}): {v}");
            }
        }
        assert!(factor.trailing_block(2..4).is_err());
        assert!(Symbolic::analyse_with_trailing(k.symbolic(), &[1, 1]).is_err());
    }
}
