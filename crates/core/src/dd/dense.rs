//! Dense kernels of the DD solver with explicitly sequential faer calls. `Mat::llt`,
//! `Mat::thin_svd` and `Mat * Mat` follow faer's global (rayon) parallelism, whose blocking and summation order depend
//! on the thread count; the DD results must be bit-for-bit independent of it (the parallelism of
//! the solver is over subdomains instead).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::{factor, solve};
use faer::linalg::matmul::matmul;
use faer::linalg::svd;
use faer::{Accum, Mat, MatMut, MatRef, Par};

/// A dense Cholesky factor L (lower) of a symmetric positive definite matrix.
#[derive(Debug, Clone)]
pub struct Cholesky {
    l: Mat<f64>,
}

impl Cholesky {
    /// Factorise the lower triangle of `a`; `None` when a pivot is not positive.
    pub fn new(a: MatRef<'_, f64>) -> Option<Cholesky> {
        let n = a.nrows();
        let mut l = a.to_owned();
        let mut buffer = MemBuffer::new(factor::cholesky_in_place_scratch::<f64>(
            n,
            Par::Seq,
            Default::default(),
        ));
        factor::cholesky_in_place(
            l.as_mut(),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut buffer),
            Default::default(),
        )
        .ok()?;
        for j in 0..n {
            for i in 0..j {
                l[(i, j)] = 0.0;
            }
        }
        Some(Cholesky { l })
    }

    /// The factor L.
    pub fn l(&self) -> MatRef<'_, f64> {
        self.l.as_ref()
    }

    /// Overwrite every column b of `rhs` with A⁻¹ b.
    pub fn solve_in_place(&self, rhs: MatMut<'_, f64>) {
        let mut buffer = MemBuffer::new(solve::solve_in_place_scratch::<f64>(
            self.l.nrows(),
            rhs.ncols(),
            Par::Seq,
        ));
        solve::solve_in_place(self.l.as_ref(), rhs, Par::Seq, MemStack::new(&mut buffer));
    }

    /// A⁻¹ B.
    pub fn solve(&self, rhs: MatRef<'_, f64>) -> Mat<f64> {
        let mut x = rhs.to_owned();
        self.solve_in_place(x.as_mut());
        x
    }

    /// A⁻¹ b for one vector.
    pub fn solve_vec(&self, b: &[f64]) -> Vec<f64> {
        let mut x = b.to_vec();
        self.solve_in_place(MatMut::from_column_major_slice_mut(&mut x, b.len(), 1));
        x
    }
}

/// A thin singular value decomposition A = U diag(s) Vᵀ.
#[derive(Debug, Clone)]
pub struct ThinSvd {
    /// All k singular values, non-increasing.
    pub s: Vec<f64>,
    pub u: Mat<f64>,
    pub v: Mat<f64>,
}

/// Thin SVD of an m × k matrix, sequentially. A wide matrix (m < k) is padded with zero rows
/// first (same s and V; U then has k rows, the last k − m of them zero).
pub fn thin_svd(a: MatRef<'_, f64>) -> Result<ThinSvd, String> {
    let k = a.ncols();
    let m = a.nrows().max(k);
    let a = Mat::from_fn(m, k, |i, j| if i < a.nrows() { a[(i, j)] } else { 0.0 });
    let a = a.as_ref();
    let mut s = Mat::<f64>::zeros(k, 1);
    let mut u = Mat::<f64>::zeros(m, k);
    let mut v = Mat::<f64>::zeros(k, k);
    let mut buffer = MemBuffer::new(svd::svd_scratch::<f64>(
        m,
        k,
        svd::ComputeSvdVectors::Thin,
        svd::ComputeSvdVectors::Thin,
        Par::Seq,
        Default::default(),
    ));
    svd::svd(
        a,
        s.as_mut().col_mut(0).as_diagonal_mut(),
        Some(u.as_mut()),
        Some(v.as_mut()),
        Par::Seq,
        MemStack::new(&mut buffer),
        Default::default(),
    )
    .map_err(|e| format!("SVD: {e:?}"))?;
    Ok(ThinSvd {
        s: (0..k).map(|i| s[(i, 0)]).collect(),
        u,
        v,
    })
}

/// A B, sequentially.
pub fn mul(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut c = Mat::<f64>::zeros(a.nrows(), b.ncols());
    matmul(c.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_and_refuses_indefinite_matrices() {
        let a = Mat::from_fn(3, 3, |i, j| if i == j { 4.0 } else { 1.0 });
        let chol = Cholesky::new(a.as_ref()).expect("SPD");
        let x = chol.solve_vec(&[1.0, 2.0, 3.0]);
        let ax = mul(a.as_ref(), Mat::from_fn(3, 1, |i, _| x[i]).as_ref());
        for (i, b) in [1.0, 2.0, 3.0].iter().enumerate() {
            assert!((ax[(i, 0)] - b).abs() < 1e-14);
        }
        let l = chol.l();
        assert_eq!(l[(0, 1)], 0.0);
        let indefinite = Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 2.0 });
        assert!(Cholesky::new(indefinite.as_ref()).is_none());
    }

    #[test]
    fn thin_svd_reconstructs_the_matrix() {
        let a = Mat::from_fn(5, 3, |i, j| ((i * 3 + j) as f64).sin());
        let ThinSvd { s, u, v } = thin_svd(a.as_ref()).expect("svd");
        let us = Mat::from_fn(5, 3, |i, j| u[(i, j)] * s[j]);
        let back = mul(us.as_ref(), v.transpose());
        for i in 0..5 {
            for j in 0..3 {
                assert!((back[(i, j)] - a[(i, j)]).abs() < 1e-13);
            }
        }
        assert!(s.windows(2).all(|w| w[0] >= w[1]));
    }
}
