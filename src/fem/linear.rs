//! Sparse direct solver: faer supernodal/simplicial Cholesky K = LLᵀ with the fill-reducing
//! ordering and symbolic analysis computed once per operator and shared (`Arc`) by every numeric
//! factorisation of a matrix with the same pattern (SPEC §3.1: refactor numerically on a reused
//! symbolic factorisation; `Par::Seq` inside parallel evaluations).

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::solvers::LltError;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatMut, Par, Side};

use super::FemError;

/// Symbolic Cholesky analysis (ordering, elimination tree, supernodes) of a lower-triangular
/// pattern; cheap to clone.
#[derive(Debug, Clone)]
pub struct Symbolic {
    inner: Arc<SymbolicCholesky<usize>>,
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
        })
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
        })
    }
}

/// Numeric Cholesky factor of a symmetric positive definite matrix: solves K x = b for one or
/// many right-hand sides.
#[derive(Debug, Clone)]
pub struct Factor {
    symbolic: Symbolic,
    values: Vec<f64>,
    par: Par,
}

impl Factor {
    /// Dimension of K.
    pub fn dim(&self) -> usize {
        self.symbolic.inner.nrows()
    }

    /// Parallelism used by the solves (`Par::Seq` when the caller parallelises itself).
    pub fn set_par(&mut self, par: Par) {
        self.par = par;
    }

    /// Overwrite each column b of `rhs` with K⁻¹ b.
    pub fn solve_in_place(&self, rhs: MatMut<'_, f64>) {
        let scratch = self
            .symbolic
            .inner
            .solve_in_place_scratch::<f64>(rhs.ncols(), self.par);
        let mut buffer = MemBuffer::new(scratch);
        LltRef::new(&self.symbolic.inner, &self.values).solve_in_place_with_conj(
            Conj::No,
            rhs,
            self.par,
            MemStack::new(&mut buffer),
        );
    }

    /// K⁻¹ b for one right-hand side.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x = Mat::<f64>::from_fn(b.len(), 1, |i, _| b[i]);
        self.solve_in_place(x.as_mut());
        x.col(0).iter().copied().collect()
    }
}
