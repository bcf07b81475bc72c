//! The reduced saddle-point system of one Newton step on the free set `F` (active variables are
//! fixed at their bounds):
//!
//! ```text
//!     C_FF y_F − G_Fᵀ α = r_x := d_F − C_FA y_A,      G_F y_F = r_e := e − G_A y_A.
//! ```
//!
//! Solved by the augmented Lagrangian form `H = C_FF + ρ G_FᵀG_F` (SPD whenever `y_F` is unique,
//! even with a semidefinite `C_FF`), a Cholesky factor `H = L Lᵀ`, and the `k × k` Schur complement
//! `S = G_F H⁻¹ G_Fᵀ = WᵀW`, `W = L⁻¹ G_Fᵀ`, inverted by a spectral pseudo-inverse: directions of
//! `α` that `G_F` does not see get the minimum-norm value and are counted as undetermined. If `H`
//! is singular it is shifted by a tiny multiple of the identity and iterative refinement on the
//! unshifted system recovers the solution. Refinement is always applied until the residual stalls.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, MatMut, Par, Side};

use super::scaled::Scaled;
use super::symv;

/// Augmentation weight (the scaled `C` has unit diagonal, `G` unit rows).
const RHO: f64 = 1.0;
/// Relative shift of a singular `H`.
const SHIFT: f64 = 1e-10;

pub(super) struct Saddle {
    par: Par,
    /// Cholesky factor of `H` (leading `nf × nf` block).
    l: Mat<f64>,
    /// `G_Fᵀ` (leading `nf × k` block).
    gft: Mat<f64>,
    /// `L⁻¹ G_Fᵀ`.
    w: Mat<f64>,
    buf: MemBuffer,
    /// Eigenvectors of `S` (columns) and inverted eigenvalues (0 for null directions).
    s_vec: Mat<f64>,
    s_inv: Vec<f64>,
    nf: usize,
    // Scratch vectors.
    rx: Vec<f64>,
    re: Vec<f64>,
    full: Vec<f64>,
    dx: Vec<f64>,
    da: Vec<f64>,
    k_tmp: Vec<f64>,
}

/// What the solve found out about the system.
pub(super) struct SaddleInfo {
    /// Rank deficiency of `G_F`.
    pub undetermined: usize,
    /// Null directions `v` of `G_Fᵀ` along which `G_F y_F = r_e` cannot be met, with the missing
    /// amount `vᵀ(r_e − G_F y_F)`: the free set is too small for the equalities.
    pub inconsistent: Vec<(Vec<f64>, f64)>,
}

/// The equality-constrained system on the free set that one solve refines and checks:
/// `C_FF x_F − G_Fᵀ α = r_x`, `G_F x_F = r_e`, with `C`, `G` of the scaled problem `p`.
#[derive(Clone, Copy)]
struct FreeSystem<'a> {
    p: &'a Scaled,
    free: &'a [usize],
    rx: &'a [f64],
    re: &'a [f64],
}

/// `H` could not be factorised even after shifting: `C` is not positive semidefinite.
#[derive(Debug)]
pub(super) struct Indefinite;

impl Saddle {
    pub fn new(m: usize, k: usize, par: Par) -> Self {
        let req = llt::factor::cholesky_in_place_scratch::<f64>(m, par, Default::default());
        Self {
            par,
            l: Mat::zeros(m, m),
            gft: Mat::zeros(m, k),
            w: Mat::zeros(m, k),
            buf: MemBuffer::new(req),
            s_vec: Mat::zeros(k, k),
            s_inv: vec![0.0; k],
            nf: 0,
            rx: vec![0.0; m],
            re: vec![0.0; k],
            full: vec![0.0; m],
            dx: vec![0.0; m],
            da: vec![0.0; k],
            k_tmp: vec![0.0; k],
        }
    }

    /// Solves for `y_F` (written into `y` at the free indices) and `α`, with `y` holding the
    /// bound values at the active indices.
    pub fn solve(
        &mut self,
        p: &Scaled,
        free: &[usize],
        y: &mut [f64],
        alpha: &mut [f64],
    ) -> Result<SaddleInfo, Indefinite> {
        self.nf = free.len();
        self.right_hand_side(p, free, y);
        let shifted = self.factor(p, free)?;
        let undetermined = self.schur();
        let (rx, re) = (std::mem::take(&mut self.rx), std::mem::take(&mut self.re));
        let mut xf = vec![0.0; self.nf];
        self.apply_inverse(&rx, &re, &mut xf, alpha);
        let system = FreeSystem {
            p,
            free,
            rx: &rx,
            re: &re,
        };
        self.refine(&system, &mut xf, alpha, shifted);
        let inconsistent = self.inconsistent_directions(&system, &xf, alpha);
        self.rx = rx;
        self.re = re;
        for (a, &i) in free.iter().enumerate() {
            y[i] = xf[a];
        }
        Ok(SaddleInfo {
            undetermined,
            inconsistent,
        })
    }

    /// `r_x = d_F − C_FA y_A`, `r_e = e − G_A y_A`.
    fn right_hand_side(&mut self, p: &Scaled, free: &[usize], y: &[f64]) {
        let m = p.dim();
        let mut y_act = y.to_vec();
        for &i in free {
            y_act[i] = 0.0;
        }
        symv(p.c.as_ref(), &y_act, &mut self.full[..m]);
        self.rx.clear();
        self.rx.extend(free.iter().map(|&i| p.d[i] - self.full[i]));
        let mut gy = vec![0.0; p.n_equalities()];
        super::gemv_rows(p.g.as_ref(), &y_act, &mut gy);
        self.re.clear();
        self.re.extend(p.e.iter().zip(&gy).map(|(e, g)| e - g));
    }

    /// Builds and factorises `H` (shifted if needed); returns whether it was shifted.
    fn factor(&mut self, p: &Scaled, free: &[usize]) -> Result<bool, Indefinite> {
        let nf = self.nf;
        for r in 0..p.n_equalities() {
            for (a, &i) in free.iter().enumerate() {
                self.gft[(a, r)] = p.g[(r, i)];
            }
        }
        for shift in [0.0, SHIFT] {
            self.fill_h(p, free, shift);
            let stack = MemStack::new(&mut self.buf);
            let l = self.l.as_mut().submatrix_mut(0, 0, nf, nf);
            let reg = LltRegularization {
                dynamic_regularization_delta: 0.0,
                dynamic_regularization_epsilon: 0.0,
            };
            if llt::factor::cholesky_in_place(l, reg, self.par, stack, Default::default()).is_ok() {
                return Ok(shift > 0.0);
            }
        }
        Err(Indefinite)
    }

    /// Lower triangle of `C_FF + ρ G_FᵀG_F + shift·(1 + max diag) I`.
    fn fill_h(&mut self, p: &Scaled, free: &[usize], shift: f64) {
        let (nf, k) = (self.nf, p.n_equalities());
        let mut max_diag = 0.0f64;
        for (b, &j) in free.iter().enumerate() {
            let col = p.c.col(j);
            for (a, &i) in free.iter().enumerate().skip(b) {
                let mut h = col[i];
                for r in 0..k {
                    h += RHO * self.gft[(a, r)] * self.gft[(b, r)];
                }
                self.l[(a, b)] = h;
            }
            max_diag = max_diag.max(self.l[(b, b)]);
        }
        if shift > 0.0 {
            for a in 0..nf {
                self.l[(a, a)] += shift * (1.0 + max_diag);
            }
        }
    }

    /// Forms `S = WᵀW` and its pseudo-inverse; returns the rank deficiency.
    fn schur(&mut self) -> usize {
        let (nf, k) = (self.nf, self.s_inv.len());
        if k == 0 {
            return 0;
        }
        let mut w = self.w.as_mut().submatrix_mut(0, 0, nf, k);
        w.copy_from(self.gft.as_ref().submatrix(0, 0, nf, k));
        solve_lower_triangular_in_place(self.l.as_ref().submatrix(0, 0, nf, nf), w, self.par);
        let w = self.w.as_ref().submatrix(0, 0, nf, k);
        let s = w.transpose() * w;
        let Ok(eig) = s.self_adjoint_eigen(Side::Lower) else {
            self.s_inv.fill(0.0);
            return k;
        };
        self.s_vec.copy_from(eig.U());
        let vals: Vec<f64> = (0..k).map(|i| eig.S()[i]).collect();
        let lmax = vals.iter().fold(0.0f64, |a, &b| a.max(b));
        let tol = (1e-12 * lmax).max(1e-14 / RHO);
        let mut deficient = 0;
        for (inv, &v) in self.s_inv.iter_mut().zip(&vals) {
            *inv = if v > tol {
                1.0 / v
            } else {
                deficient += 1;
                0.0
            };
        }
        deficient
    }

    /// `(x_F, α)` for the right-hand side `(r_x, r_e)` with the current factorisation.
    fn apply_inverse(&mut self, rx: &[f64], re: &[f64], xf: &mut [f64], alpha: &mut [f64]) {
        let (nf, k) = (self.nf, re.len());
        // z = H⁻¹ (r_x + ρ G_Fᵀ r_e)
        for a in 0..nf {
            xf[a] = rx[a] + RHO * (0..k).map(|r| self.gft[(a, r)] * re[r]).sum::<f64>();
        }
        self.solve_h(xf);
        if k == 0 {
            return;
        }
        // t = r_e − G_F z, α = S⁺ t
        for (r, (t, e)) in self.k_tmp.iter_mut().zip(re).enumerate() {
            *t = e - (0..nf).map(|a| self.gft[(a, r)] * xf[a]).sum::<f64>();
        }
        for (r, ar) in alpha.iter_mut().enumerate() {
            *ar = (0..k)
                .map(|q| {
                    let proj: f64 = (0..k).map(|t| self.s_vec[(t, q)] * self.k_tmp[t]).sum();
                    self.s_vec[(r, q)] * self.s_inv[q] * proj
                })
                .sum();
        }
        // x_F = z + H⁻¹ G_Fᵀ α
        let mut corr: Vec<f64> = (0..nf)
            .map(|a| (0..k).map(|r| self.gft[(a, r)] * alpha[r]).sum())
            .collect();
        self.solve_h(&mut corr);
        for (x, c) in xf.iter_mut().zip(&corr) {
            *x += c;
        }
    }

    fn solve_h(&mut self, v: &mut [f64]) {
        let nf = self.nf;
        let stack = MemStack::new(&mut self.buf);
        let rhs = MatMut::from_column_major_slice_mut(&mut v[..nf], nf, 1);
        llt::solve::solve_in_place(
            self.l.as_ref().submatrix(0, 0, nf, nf),
            rhs,
            self.par,
            stack,
        );
    }

    /// Iterative refinement on the unshifted, unaugmented system until the residual stalls.
    fn refine(&mut self, system: &FreeSystem, xf: &mut [f64], alpha: &mut [f64], shifted: bool) {
        let passes = if shifted { 50 } else { 4 };
        let mut last = f64::INFINITY;
        for _ in 0..passes {
            let (res_x, res_e) = self.residual(system, xf, alpha);
            let norm = super::inf_norm(&res_x).max(super::inf_norm(&res_e));
            if norm == 0.0 || norm >= 0.5 * last {
                break;
            }
            last = norm;
            let mut dx = std::mem::take(&mut self.dx);
            let mut da = std::mem::take(&mut self.da);
            self.apply_inverse(&res_x, &res_e, &mut dx[..self.nf], &mut da);
            for (x, d) in xf.iter_mut().zip(&dx) {
                *x += d;
            }
            for (a, d) in alpha.iter_mut().zip(&da) {
                *a += d;
            }
            self.dx = dx;
            self.da = da;
        }
    }

    /// Null directions of `S` with a non-negligible equality residual.
    fn inconsistent_directions(
        &self,
        system: &FreeSystem,
        xf: &[f64],
        alpha: &[f64],
    ) -> Vec<(Vec<f64>, f64)> {
        let (p, re) = (system.p, system.re);
        let k = re.len();
        if !self.s_inv.contains(&0.0) {
            return Vec::new();
        }
        let (_, res_e) = self.residual(system, xf, alpha);
        let scale = super::inf_norm(&p.e)
            .max(super::inf_norm(re))
            .max(f64::MIN_POSITIVE);
        (0..k)
            .filter(|&q| self.s_inv[q] == 0.0)
            .filter_map(|q| {
                let v: Vec<f64> = (0..k).map(|r| self.s_vec[(r, q)]).collect();
                let missing: f64 = v.iter().zip(&res_e).map(|(a, b)| a * b).sum();
                (missing.abs() > 1e-10 * scale).then_some((v, missing))
            })
            .collect()
    }

    /// `(r_x − C_FF x_F + G_Fᵀ α, r_e − G_F x_F)`.
    fn residual(&self, system: &FreeSystem, xf: &[f64], alpha: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let FreeSystem { p, free, rx, re } = *system;
        let (nf, k) = (self.nf, re.len());
        let mut res_x = rx.to_vec();
        for (b, &j) in free.iter().enumerate() {
            let col = p.c.col(j);
            let xb = xf[b];
            for (a, &i) in free.iter().enumerate() {
                res_x[a] -= col[i] * xb;
            }
        }
        for (a, r) in res_x.iter_mut().enumerate() {
            *r += (0..k).map(|q| self.gft[(a, q)] * alpha[q]).sum::<f64>();
        }
        let res_e = (0..k)
            .map(|r| re[r] - (0..nf).map(|a| self.gft[(a, r)] * xf[a]).sum::<f64>())
            .collect();
        (res_x, res_e)
    }
}
