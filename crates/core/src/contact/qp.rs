//! Dense box- and equality-constrained convex QP: the contact problem condensed on the contact
//! multipliers (design §3.1).
//!
//! # Formulation
//!
//! With the stiffness `K` factorised elsewhere and `B` the contact operator (one normal and one
//! tangential row per contact node pair), the dual of discrete Signorini + Tresca is
//!
//! ```text
//!     min ½ xᵀ C x − dᵀ x   s.t.   l ≤ x ≤ u,   G x = e,        C = B K⁺ Bᵀ,  d = B K⁺ f,
//! ```
//!
//! with `C` dense symmetric positive (semi)definite. Normal multipliers have `[0, ∞)`, tangential
//! ones `[−g w, g w]`, bilateral normals `(−∞, ∞)`, frictionless tangentials `[0, 0]`. The optional
//! equalities `G x = e` (rows `(B R)ᵀ` for the rigid modes `R` of floating bodies) express the
//! equilibrium of floating bodies; their multipliers `α` are the rigid-body amplitudes. With the
//! gradient `g = C x − d − Gᵀ α` (and the gap vector `w = −g`) the KKT conditions are
//!
//! ```text
//!     l_i < x_i < u_i ⇒ g_i = 0,   x_i = l_i < u_i ⇒ g_i ≥ 0,   x_i = u_i > l_i ⇒ g_i ≤ 0,   G x = e.
//! ```
//!
//! # Algorithm
//!
//! 1. **Scaling.** Symmetric Jacobi scaling `x = S y`, `S = diag(C)^{-1/2}`, and unit-norm rows of
//!    `G S`, so that tolerances and the complementarity constant do not depend on units (Pa vs
//!    GPa). All tolerances are relative (see [`KktResiduals`]).
//! 2. **Phase 1** (only with equalities): MPRGP on `min ½‖G x − e‖²` over the box. A positive
//!    minimum means the floating bodies cannot be balanced by contact and friction; the rows with a
//!    residual are returned in [`QpError::Infeasible`].
//! 3. **Semismooth Newton = primal–dual active set** (Hintermüller, Ito, Kunisch, SIAM J. Optim. 13
//!    (2003); Kunisch–Stadler for Tresca) on `y − P_[l,u](y − g̃(y, α)) = 0`. Each step fixes the
//!    predicted active variables at their bounds and solves the reduced saddle-point system
//!    `[C_FF −G_Fᵀ; G_F 0]` on the free set by an augmented-Lagrangian Cholesky factorisation of
//!    `C_FF + ρ G_FᵀG_F` and a pseudo-inverse of the small Schur complement, which gives the
//!    minimum-norm `α` in rigid directions that no free constraint fixes (counted in
//!    [`QpSolution::undetermined_modes`]). Iterative refinement restores machine precision.
//!    When the free set cannot meet the equalities (a floating body touching nothing in some rigid
//!    direction), `α` is moved along that direction until the first helpful bound is released
//!    (a dual ratio test), instead of leaving the prediction unchanged.
//! 4. **Globalisation.** PDAS converges locally superlinearly (finitely for QPs) but may cycle for
//!    non-M-matrices. When an active set repeats, the set stagnates, the KKT residual has not
//!    improved for 3 steps, or the step cap is hit, the
//!    solver falls back to MPRGP (Dostál, *Optimal Quadratic Programming Algorithms*, Springer
//!    2009; PERMON defaults Γ = 1, ᾱ ≈ 2/‖A‖) — wrapped in the SMALBE augmented Lagrangian when
//!    equalities are present — which converges for any convex problem, and then polishes its
//!    result with PDAS from the identified active set.
//!
//! Every exit is checked against the KKT conditions of the original (unscaled) problem; a failure
//! to reach `tol` is an error carrying the residuals, never a silent result.

mod mprgp;
mod pdas;
mod saddle;
mod scaled;

use faer::{Mat, MatRef};

use scaled::Scaled;

/// The QP `min ½ xᵀ C x − dᵀ x` s.t. `lower ≤ x ≤ upper`, `G x = e`.
#[derive(Clone, Debug)]
pub struct BoxQp {
    /// Hessian, `m × m`, symmetric positive semidefinite.
    pub c: Mat<f64>,
    /// Linear term, length `m`.
    pub d: Vec<f64>,
    /// Lower bounds, length `m`; `-∞` allowed.
    pub lower: Vec<f64>,
    /// Upper bounds, length `m`; `+∞` allowed; `lower[i] == upper[i]` fixes `x_i`.
    pub upper: Vec<f64>,
    /// Equality rows, `k × m` (`k` may be 0).
    pub g: Mat<f64>,
    /// Equality right-hand side, length `k`.
    pub e: Vec<f64>,
}

impl BoxQp {
    /// A problem without equality constraints.
    pub fn new(c: Mat<f64>, d: Vec<f64>, lower: Vec<f64>, upper: Vec<f64>) -> Self {
        let m = d.len();
        Self {
            c,
            d,
            lower,
            upper,
            g: Mat::zeros(0, m),
            e: Vec::new(),
        }
    }

    /// Adds the equality constraints `G x = e`.
    pub fn with_equalities(mut self, g: Mat<f64>, e: Vec<f64>) -> Self {
        self.g = g;
        self.e = e;
        self
    }

    /// Number of variables.
    pub fn dim(&self) -> usize {
        self.d.len()
    }

    /// Number of equality rows.
    pub fn n_equalities(&self) -> usize {
        self.e.len()
    }
}

/// A previous solution to start from (typically of a nearby problem).
#[derive(Clone, Debug, Default)]
pub struct WarmStart {
    /// Previous primal solution, length `m`.
    pub x: Vec<f64>,
    /// Previous equality multipliers, length `k` (empty = zeros).
    pub alpha: Vec<f64>,
}

impl From<&QpSolution> for WarmStart {
    fn from(s: &QpSolution) -> Self {
        Self {
            x: s.x.clone(),
            alpha: s.alpha.clone(),
        }
    }
}

/// Solver options.
#[derive(Clone, Debug)]
pub struct QpOptions {
    /// Required `KktResiduals::max()` (all residuals are relative).
    pub tol: f64,
    /// Cap on semismooth Newton (PDAS) steps per phase.
    pub max_newton: usize,
    /// Cap on MPRGP iterations (Hessian multiplications) in the fallback and in phase 1.
    pub max_fallback: usize,
    /// Relative tolerance of the symmetry check `|C_ij − C_ji| ≤ sym_tol · max|C|`.
    pub sym_tol: f64,
    /// Use rayon inside the dense factorisations (leave off when solving many QPs in parallel).
    pub parallel: bool,
    /// MPRGP iterations within which the projected gradient must halve; `None` chooses
    /// `max(2000, 20 m)` for `m` variables. A run without such progress ends with
    /// [`QpError::Stagnated`] (or [`QpError::Unbounded`] when the iterates follow a ray).
    pub stagnation_window: Option<usize>,
}

impl Default for QpOptions {
    fn default() -> Self {
        Self {
            tol: 1e-12,
            max_newton: 60,
            max_fallback: 200_000,
            sym_tol: 1e-10,
            parallel: false,
            stagnation_window: None,
        }
    }
}

/// Which algorithm produced the returned solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QpMethod {
    /// Semismooth Newton (PDAS) alone.
    Newton,
    /// MPRGP / SMALBE fallback, then polished by Newton.
    FallbackThenNewton,
    /// MPRGP / SMALBE fallback alone.
    Fallback,
}

/// Relative KKT residuals. `gradient_scale = max(‖d‖∞, max_i Σ_j |C_ij x_j|, max_i Σ_r |G_ri α_r|)`
/// normalises gradients, `x_scale = max(‖x‖∞, max_i |P_[l_i,u_i](0)|)` normalises multipliers and
/// `equality_scale = max(‖e‖∞, max_r Σ_j |G_rj x_j|)` normalises equality residuals.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct KktResiduals {
    /// `max |g_i| / gradient_scale` over strictly free variables (`l_i < x_i < u_i`).
    pub stationarity: f64,
    /// `max (l_i − x_i, x_i − u_i, 0) / x_scale`.
    pub bound_violation: f64,
    /// `max_i min(dist_i / x_scale, |g_i| / gradient_scale)`, where `dist_i` is the distance of
    /// `x_i` to the bound that the sign of `g_i` calls for (`l_i` if `g_i > 0`, `u_i` if `g_i < 0`).
    /// Zero exactly when every sign condition holds; includes stationarity of free variables.
    pub complementarity: f64,
    /// `max_r |G_r x − e_r| / equality_scale`.
    pub equality: f64,
    /// Gradient scale used above (units of `d`).
    pub gradient_scale: f64,
    /// Multiplier scale used above (units of `x`).
    pub x_scale: f64,
    /// Equality scale used above (units of `e`).
    pub equality_scale: f64,
}

impl KktResiduals {
    /// The largest of the four relative residuals.
    pub fn max(&self) -> f64 {
        self.stationarity
            .max(self.bound_violation)
            .max(self.complementarity)
            .max(self.equality)
    }
}

/// A solution with its certificate.
#[derive(Clone, Debug)]
pub struct QpSolution {
    /// The multipliers (contact forces), length `m`.
    pub x: Vec<f64>,
    /// Equality multipliers (rigid-body amplitudes), length `k`.
    pub alpha: Vec<f64>,
    /// Gap / velocity vector `w = d − C x + Gᵀ α`.
    pub w: Vec<f64>,
    /// Semismooth Newton steps (each one dense saddle-point solve).
    pub iterations: usize,
    /// MPRGP iterations spent in phase 1 and in the fallback.
    pub fallback_iterations: usize,
    /// Total number of variables that changed active-set status over the Newton steps.
    pub active_set_changes: usize,
    /// KKT residuals of the returned point.
    pub kkt: KktResiduals,
    /// Equality directions whose multiplier the final free set does not determine (rank deficiency
    /// of `G_F`); `alpha` is minimum-norm in those directions, in the metric of the scaled
    /// multipliers `‖(G S)_r‖ α_r` (so zero when the direction is a single undetermined row).
    pub undetermined_modes: usize,
    /// Which algorithm produced the solution.
    pub method: QpMethod,
}

/// Why no solution was returned.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum QpError {
    /// Malformed problem (sizes, NaN, `l > u`, asymmetric `C`, negative diagonal).
    #[error("invalid QP input: {reason}")]
    InvalidInput {
        /// What is wrong.
        reason: String,
    },
    /// `G x = e` cannot be met inside the box: the floating bodies cannot be balanced.
    #[error("equality rows {equality_rows:?} cannot be satisfied within the bounds (residuals {residuals:?})")]
    Infeasible {
        /// Offending rows, largest residual first.
        equality_rows: Vec<usize>,
        /// `G_r x − e_r` at the point of the box closest to feasibility, for those rows.
        residuals: Vec<f64>,
    },
    /// The objective is unbounded below on the feasible set: a direction `p` with `C p = 0`,
    /// `G p = 0`, `dᵀp > 0` that no bound stops. For the contact dual this is a Farkas
    /// certificate that the primal constraints cannot be met (the bodies must overlap).
    #[error("QP objective is unbounded below along variables {variables:?} (for the contact dual: the non-penetration constraints cannot all be met)")]
    Unbounded {
        /// The variables the ray moves, largest component first (at most 8).
        variables: Vec<usize>,
    },
    /// MPRGP made no progress: its projected gradient did not halve in a window of
    /// [`QpOptions::stagnation_window`] iterations, and the iterates do not follow a ray of
    /// unboundedness (so the cause is conditioning, not the data).
    #[error("QP solver stagnated: no progress in {window} MPRGP iterations (after {iterations}; projected gradient {residual:e} relative)")]
    Stagnated {
        /// MPRGP iterations of the run that stagnated.
        iterations: usize,
        /// The window without progress.
        window: usize,
        /// Relative projected gradient `‖g^P‖∞ / ‖d‖∞` (scaled variables) when it stopped.
        residual: f64,
    },
    /// Iteration caps reached (or precision stalled) before `tol`.
    #[error("QP solver did not converge after {iterations} Newton and {fallback_iterations} MPRGP iterations (KKT residual {})", residuals.max())]
    NotConverged {
        /// Newton steps taken.
        iterations: usize,
        /// MPRGP iterations taken.
        fallback_iterations: usize,
        /// Residuals of the best point found.
        residuals: KktResiduals,
    },
}

/// Solves the QP; see the module documentation for the algorithm.
pub fn solve_box_qp(
    problem: &BoxQp,
    warm: Option<&WarmStart>,
    opts: &QpOptions,
) -> Result<QpSolution, QpError> {
    validate(problem, opts)?;
    if let Some(w) = warm {
        validate_warm(problem, w)?;
    }
    decoupled_rays(problem)?;
    let scaled = Scaled::new(problem);
    let mut stats = pdas::Stats::default();
    if problem.n_equalities() > 0 {
        stats.fallback_iterations += mprgp::phase_one(&scaled, opts)?;
    }
    let (y0, a0) = scaled.start(warm);
    pdas::solve(problem, &scaled, y0, a0, opts, stats)
}

/// Push `|d_i|` (relative to `‖d‖∞`) of a decoupled variable still read as rounding.
const DECOUPLED_TOL: f64 = 1e-11;

/// The exact test for the rays that data make: a variable whose column of `C` and `G` is zero
/// (a contact pair whose DOFs are all prescribed) has the objective `−d_i x_i` alone, unbounded
/// when `d_i` pushes it towards an infinite bound. Other rays are caught by MPRGP's progress check.
fn decoupled_rays(problem: &BoxQp) -> Result<(), QpError> {
    let decoupled = |i: usize| {
        problem.c.col(i).iter().all(|&v| v == 0.0) && problem.g.col(i).iter().all(|&v| v == 0.0)
    };
    // A push below rounding of the other entries is harmless: the KKT test accepts x_i at its
    // start there (and the contact layer's exact check has decided such pairs already).
    let threshold = DECOUPLED_TOL * inf_norm(&problem.d);
    let mut rays: Vec<usize> = (0..problem.dim())
        .filter(|&i| {
            let d = problem.d[i];
            ((d > threshold && problem.upper[i] == f64::INFINITY)
                || (d < -threshold && problem.lower[i] == f64::NEG_INFINITY))
                && decoupled(i)
        })
        .collect();
    if rays.is_empty() {
        return Ok(());
    }
    rays.sort_by(|&a, &b| problem.d[b].abs().total_cmp(&problem.d[a].abs()));
    rays.truncate(8);
    Err(QpError::Unbounded { variables: rays })
}

/// KKT residuals of `(x, alpha)` for `problem` (see [`KktResiduals`]). `alpha` may be empty when
/// there are no equalities. Mismatched lengths are treated as missing entries (zeros).
pub fn kkt_residuals(problem: &BoxQp, x: &[f64], alpha: &[f64]) -> KktResiduals {
    let m = problem.dim();
    let k = problem.n_equalities();
    let mut xv = vec![0.0; m];
    let mut av = vec![0.0; k];
    copy_prefix(&mut xv, x);
    copy_prefix(&mut av, alpha);
    let mut grad = vec![0.0; m];
    residuals(
        ProblemRef::of(problem),
        &xv,
        &av,
        &mut grad,
        &mut vec![0.0; m],
    )
}

/// Residuals of the original problem at the scaled point `(y, α̃)`.
fn unscaled_kkt(problem: &BoxQp, p: &Scaled, y: &[f64], alpha: &[f64]) -> KktResiduals {
    let (x, a) = p.unscale(y, alpha);
    let m = x.len();
    residuals(
        ProblemRef::of(problem),
        &x,
        &a,
        &mut vec![0.0; m],
        &mut vec![0.0; m],
    )
}

fn copy_prefix(dst: &mut [f64], src: &[f64]) {
    let n = dst.len().min(src.len());
    dst[..n].copy_from_slice(&src[..n]);
}

/// Borrowed view of the data of a QP (original or scaled).
#[derive(Clone, Copy)]
pub(crate) struct ProblemRef<'a> {
    pub c: MatRef<'a, f64>,
    pub d: &'a [f64],
    pub lo: &'a [f64],
    pub hi: &'a [f64],
    pub g: MatRef<'a, f64>,
    pub e: &'a [f64],
}

impl<'a> ProblemRef<'a> {
    pub(crate) fn of(p: &'a BoxQp) -> Self {
        Self {
            c: p.c.as_ref(),
            d: &p.d,
            lo: &p.lower,
            hi: &p.upper,
            g: p.g.as_ref(),
            e: &p.e,
        }
    }
}

/// `out = C x` for a dense column-major `C`.
pub(crate) fn symv(c: MatRef<'_, f64>, x: &[f64], out: &mut [f64]) {
    gemv_rows(c, x, out);
}

/// `out = G x` for the `k × m` matrix `G` (column by column; contiguous columns as slices, so
/// that the update vectorises).
pub(crate) fn gemv_rows(g: MatRef<'_, f64>, x: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    for (j, &xj) in x.iter().enumerate() {
        if xj != 0.0 {
            match g.col(j).try_as_col_major() {
                Some(col) => axpy(xj, col.as_slice(), out),
                None => {
                    for (o, &grj) in out.iter_mut().zip(g.col(j).iter()) {
                        *o += grj * xj;
                    }
                }
            }
        }
    }
}

/// `out += a · x` over slices.
fn axpy(a: f64, x: &[f64], out: &mut [f64]) {
    for (o, &xi) in out.iter_mut().zip(x) {
        *o += a * xi;
    }
}

/// `out += s · Gᵀ a`.
pub(crate) fn add_gt(g: MatRef<'_, f64>, a: &[f64], s: f64, out: &mut [f64]) {
    if a.is_empty() {
        return;
    }
    for (j, o) in out.iter_mut().enumerate() {
        let dot: f64 = g.col(j).iter().zip(a).map(|(gr, ar)| gr * ar).sum();
        *o += s * dot;
    }
}

/// Residuals of `(x, alpha)`; writes the gradient `C x − d − Gᵀα` into `grad` (`tmp`: scratch).
pub(crate) fn residuals(
    p: ProblemRef<'_>,
    x: &[f64],
    alpha: &[f64],
    grad: &mut [f64],
    tmp: &mut [f64],
) -> KktResiduals {
    let m = x.len();
    let mut gradient_scale = inf_norm(p.d);
    for (j, t) in tmp.iter_mut().enumerate() {
        *t = match p.c.col(j).try_as_col_major() {
            Some(col) => col
                .as_slice()
                .iter()
                .zip(x)
                .map(|(c, xi)| (c * xi).abs())
                .sum(),
            None => p.c.col(j).iter().zip(x).map(|(c, xi)| (c * xi).abs()).sum(),
        };
    }
    gradient_scale = gradient_scale.max(inf_norm(tmp));
    symv(p.c, x, grad);
    for (gi, di) in grad.iter_mut().zip(p.d) {
        *gi -= di;
    }
    if !alpha.is_empty() {
        for j in 0..m {
            let s: f64 =
                p.g.col(j)
                    .iter()
                    .zip(alpha)
                    .map(|(g, a)| (g * a).abs())
                    .sum();
            gradient_scale = gradient_scale.max(s);
        }
        add_gt(p.g, alpha, -1.0, grad);
    }
    let x_scale = (0..m)
        .map(|i| x[i].abs().max(0.0f64.clamp(p.lo[i], p.hi[i]).abs()))
        .fold(0.0, f64::max);
    let gs = positive(gradient_scale);
    let xs = positive(x_scale);
    let mut r = KktResiduals {
        gradient_scale,
        x_scale,
        ..KktResiduals::default()
    };
    for i in 0..m {
        let (lo, hi, xi, gi) = (p.lo[i], p.hi[i], x[i], grad[i]);
        r.bound_violation = r.bound_violation.max((lo - xi).max(xi - hi).max(0.0) / xs);
        if lo < xi && xi < hi {
            r.stationarity = r.stationarity.max(gi.abs() / gs);
        }
        if lo < hi {
            let dist = if gi > 0.0 { xi - lo } else { hi - xi };
            r.complementarity = r
                .complementarity
                .max((dist.max(0.0) / xs).min(gi.abs() / gs));
        }
    }
    equality_residual(p, x, &mut r);
    r
}

fn equality_residual(p: ProblemRef<'_>, x: &[f64], r: &mut KktResiduals) {
    let k = p.e.len();
    if k == 0 {
        return;
    }
    let mut gx = vec![0.0; k];
    gemv_rows(p.g, x, &mut gx);
    let mut scale = inf_norm(p.e);
    for (row, e_r) in p.e.iter().enumerate() {
        let abs_sum: f64 = (0..x.len()).map(|j| (p.g[(row, j)] * x[j]).abs()).sum();
        scale = scale.max(abs_sum);
        r.equality = r.equality.max((gx[row] - e_r).abs());
    }
    r.equality /= positive(scale);
    r.equality_scale = scale;
}

fn positive(s: f64) -> f64 {
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

pub(crate) fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |a, &b| a.max(b.abs()))
}

fn invalid(reason: impl Into<String>) -> QpError {
    QpError::InvalidInput {
        reason: reason.into(),
    }
}

fn validate(p: &BoxQp, opts: &QpOptions) -> Result<(), QpError> {
    let m = p.dim();
    let k = p.n_equalities();
    if p.c.nrows() != m || p.c.ncols() != m {
        return Err(invalid(format!(
            "C is {}x{}, expected {m}x{m}",
            p.c.nrows(),
            p.c.ncols()
        )));
    }
    if p.lower.len() != m || p.upper.len() != m {
        return Err(invalid("bounds must have the length of d"));
    }
    if p.g.nrows() != k || (k > 0 && p.g.ncols() != m) {
        return Err(invalid(format!(
            "G is {}x{}, expected {k}x{m}",
            p.g.nrows(),
            p.g.ncols()
        )));
    }
    if !(opts.tol > 0.0 && opts.sym_tol >= 0.0) {
        return Err(invalid("tolerances must be positive"));
    }
    validate_values(p)?;
    validate_symmetry(p, opts.sym_tol)
}

fn validate_values(p: &BoxQp) -> Result<(), QpError> {
    let m = p.dim();
    if (0..m).any(|j| p.c.col(j).iter().any(|v| !v.is_finite())) {
        return Err(invalid("C has a non-finite entry"));
    }
    if p.d.iter().chain(&p.e).any(|v| !v.is_finite()) {
        return Err(invalid("d or e has a non-finite entry"));
    }
    if (0..p.g.ncols()).any(|j| p.g.col(j).iter().any(|v| !v.is_finite())) {
        return Err(invalid("G has a non-finite entry"));
    }
    for i in 0..m {
        let (lo, hi) = (p.lower[i], p.upper[i]);
        if lo.is_nan() || hi.is_nan() || lo == f64::INFINITY || hi == f64::NEG_INFINITY {
            return Err(invalid(format!(
                "bounds of x[{i}] are invalid: [{lo}, {hi}]"
            )));
        }
        if lo > hi {
            return Err(invalid(format!("lower > upper for x[{i}]: {lo} > {hi}")));
        }
    }
    Ok(())
}

fn validate_symmetry(p: &BoxQp, sym_tol: f64) -> Result<(), QpError> {
    let m = p.dim();
    let cmax = (0..m)
        .flat_map(|j| p.c.col(j).iter().copied())
        .fold(0.0, |a: f64, b| a.max(b.abs()));
    for j in 0..m {
        if p.c[(j, j)] < -sym_tol * cmax {
            return Err(invalid(format!(
                "C[{j},{j}] < 0: C is not positive semidefinite"
            )));
        }
        for i in 0..j {
            if (p.c[(i, j)] - p.c[(j, i)]).abs() > sym_tol * cmax {
                return Err(invalid(format!("C is not symmetric at ({i},{j})")));
            }
        }
    }
    Ok(())
}

fn validate_warm(p: &BoxQp, w: &WarmStart) -> Result<(), QpError> {
    if w.x.len() != p.dim() || !(w.alpha.is_empty() || w.alpha.len() == p.n_equalities()) {
        return Err(invalid("warm start has the wrong size"));
    }
    if w.x.iter().chain(&w.alpha).any(|v| !v.is_finite()) {
        return Err(invalid("warm start has a non-finite entry"));
    }
    Ok(())
}
