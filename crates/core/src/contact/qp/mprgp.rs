//! MPRGP (modified proportioning with reduced gradient projections, Dostál 2009, ch. 8) for
//! `min ½ yᵀA y − bᵀy` on a box (Γ = 1, ᾱ = 1.9/‖A‖ as in PERMON), the SMALBE augmented
//! Lagrangian for the equalities (Dostál 2009, ch. 9), and the phase-1 feasibility check.
//!
//! SMALBE parameters differ from PERMON's defaults (M₀ = 100, ρ = 1.1‖A‖): in the scaled
//! variables `M₀ = 1` and `ρ = 10‖C‖` cut the outer iterations on the property-test problems from
//! hundreds (with stalls on nearly dependent rows of `G`) to tens; the fallback only needs moderate
//! accuracy before the Newton polish.

use faer::MatRef;

use super::scaled::Scaled;
use super::{
    add_gt, gemv_rows, inf_norm, residuals, symv, unscaled_kkt, BoxQp, QpError, QpOptions,
};

/// Proportioning constant Γ.
const GAMMA: f64 = 1.0;
/// Expansion step ᾱ = STEP / ‖A‖ (must be ≤ 2 / ‖A‖).
const STEP: f64 = 1.9;
/// Relative feasibility tolerance of phase 1.
const FEAS_TOL: f64 = 1e-9;
/// Cap on SMALBE outer iterations.
const MAX_OUTER: usize = 500;

/// `A = C + ρ GᵀG` (with `C` absent in phase 1).
struct Operator<'a> {
    c: Option<MatRef<'a, f64>>,
    g: MatRef<'a, f64>,
    rho: f64,
    tmp: Vec<f64>,
}

impl Operator<'_> {
    fn apply(&mut self, x: &[f64], out: &mut [f64]) {
        match self.c {
            Some(c) => symv(c, x, out),
            None => out.fill(0.0),
        }
        if self.rho != 0.0 && !self.tmp.is_empty() {
            gemv_rows(self.g, x, &mut self.tmp);
            add_gt(self.g, &self.tmp, self.rho, out);
        }
    }

    /// Power-method estimate of ‖A‖ (slightly enlarged).
    fn norm_estimate(&mut self, m: usize) -> f64 {
        let mut v: Vec<f64> = (0..m)
            .map(|i| 1.0 + 0.1 * ((i * 7919) % 13) as f64)
            .collect();
        let mut av = vec![0.0; m];
        let mut lambda = 0.0;
        for _ in 0..60 {
            let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            if norm == 0.0 {
                break;
            }
            v.iter_mut().for_each(|a| *a /= norm);
            self.apply(&v, &mut av);
            lambda = v.iter().zip(&av).map(|(a, b)| a * b).sum::<f64>();
            std::mem::swap(&mut v, &mut av);
        }
        1.05 * lambda.max(f64::MIN_POSITIVE)
    }
}

/// Box and the fixed-step length of one MPRGP run.
struct Box<'a> {
    lo: &'a [f64],
    hi: &'a [f64],
    abar: f64,
}

impl Box<'_> {
    fn is_free(&self, i: usize, x: f64) -> bool {
        self.lo[i] < x && x < self.hi[i]
    }

    /// Free gradient φ.
    fn free_grad(&self, x: &[f64], g: &[f64], out: &mut [f64]) {
        for i in 0..x.len() {
            out[i] = if self.is_free(i, x[i]) { g[i] } else { 0.0 };
        }
    }

    /// Chopped gradient β.
    fn chopped_grad(&self, x: &[f64], g: &[f64], out: &mut [f64]) {
        for i in 0..x.len() {
            out[i] = if self.lo[i] == self.hi[i] || self.is_free(i, x[i]) {
                0.0
            } else if x[i] <= self.lo[i] {
                g[i].min(0.0)
            } else {
                g[i].max(0.0)
            };
        }
    }

    /// `φ̃ · φ` with the reduced free gradient φ̃.
    fn reduced_dot(&self, x: &[f64], phi: &[f64]) -> f64 {
        (0..x.len())
            .map(|i| {
                let red = if phi[i] > 0.0 {
                    phi[i].min((x[i] - self.lo[i]) / self.abar)
                } else {
                    phi[i].max((x[i] - self.hi[i]) / self.abar)
                };
                red * phi[i]
            })
            .sum()
    }

    /// Largest feasible step `t` of `x − t p`.
    fn max_step(&self, x: &[f64], p: &[f64]) -> f64 {
        let mut t = f64::INFINITY;
        for i in 0..x.len() {
            if p[i] > 0.0 {
                t = t.min((x[i] - self.lo[i]) / p[i]);
            } else if p[i] < 0.0 {
                t = t.min((x[i] - self.hi[i]) / p[i]);
            }
        }
        t.max(0.0)
    }

    fn project(&self, x: &mut [f64]) {
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = xi.clamp(self.lo[i], self.hi[i]);
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    y.iter_mut().zip(x).for_each(|(yi, xi)| *yi += a * xi);
}

/// Work vectors of one MPRGP run.
struct Vectors {
    g: Vec<f64>,
    phi: Vec<f64>,
    beta: Vec<f64>,
    p: Vec<f64>,
    ap: Vec<f64>,
}

/// The progress check of one MPRGP run: the projected gradient must halve within `window`
/// iterations; `start` is the iterate when it last did (the base of the ray test).
struct Progress {
    window: usize,
    since: usize,
    reference: f64,
    start: Vec<f64>,
}

impl Progress {
    fn new(window: usize, x: &[f64]) -> Self {
        Self {
            window,
            since: 0,
            reference: f64::INFINITY,
            start: x.to_vec(),
        }
    }

    /// Records the projected gradient `gp` at iteration `its`; false when the window passed
    /// without halving it.
    fn advance(&mut self, its: usize, gp: f64, x: &[f64]) -> bool {
        if gp <= 0.5 * self.reference {
            self.reference = gp;
            self.since = its;
            self.start.copy_from_slice(x);
            return true;
        }
        its - self.since < self.window
    }
}

/// The MPRGP window of [`QpOptions::stagnation_window`] for `m` variables.
fn stagnation_window(opts: &QpOptions, m: usize) -> usize {
    opts.stagnation_window.unwrap_or((20 * m).max(2000))
}

/// Relative size of `A Δ` (to `‖A‖ ‖Δ‖∞`) below which a stalled run's drift Δ is a ray.
const RAY_TOL: f64 = 1e-6;

/// Why a run without progress stopped: [`QpError::Unbounded`] when the drift `Δ = x − start`
/// since the last progress is a ray (`A Δ ≈ 0`, `bᵀΔ > 0`, no finite bound in its way), else
/// [`QpError::Stagnated`].
fn stalled(
    op: &mut Operator<'_>,
    b: &[f64],
    bx: &Box<'_>,
    x: &[f64],
    progress: &Progress,
    its: usize,
    gp: f64,
) -> QpError {
    let delta: Vec<f64> = x.iter().zip(&progress.start).map(|(a, s)| a - s).collect();
    let size = inf_norm(&delta);
    let mut ad = vec![0.0; x.len()];
    op.apply(&delta, &mut ad);
    let norm = STEP / bx.abar;
    let unstopped = (0..x.len()).all(|i| {
        let moving = delta[i].abs() > 1e-8 * size;
        !moving
            || (delta[i] > 0.0 && bx.hi[i] == f64::INFINITY)
            || (delta[i] < 0.0 && bx.lo[i] == f64::NEG_INFINITY)
    });
    if size > 0.0 && unstopped && inf_norm(&ad) <= RAY_TOL * norm * size && dot(b, &delta) > 0.0 {
        let mut variables: Vec<usize> = (0..x.len())
            .filter(|&i| delta[i].abs() > 1e-8 * size)
            .collect();
        variables.sort_by(|&i, &j| delta[j].abs().total_cmp(&delta[i].abs()));
        variables.truncate(8);
        return QpError::Unbounded { variables };
    }
    QpError::Stagnated {
        iterations: its,
        window: progress.window,
        residual: gp / inf_norm(b).max(f64::MIN_POSITIVE),
    }
}

/// Runs MPRGP from `x` until `stop(x, ‖g^P‖∞)` or `max_it` Hessian multiplications, ending
/// with an error when the projected gradient does not halve within `window` iterations.
/// Returns the iteration count and whether `stop` fired.
fn mprgp(
    op: &mut Operator<'_>,
    b: &[f64],
    bx: &Box<'_>,
    x: &mut [f64],
    (max_it, window): (usize, usize),
    stop: &mut dyn FnMut(&[f64], f64) -> bool,
) -> Result<(usize, bool), QpError> {
    let m = x.len();
    bx.project(x);
    let mut v = Vectors {
        g: vec![0.0; m],
        phi: vec![0.0; m],
        beta: vec![0.0; m],
        p: vec![0.0; m],
        ap: vec![0.0; m],
    };
    exact_gradient(op, b, x, &mut v.g);
    bx.free_grad(x, &v.g, &mut v.p);
    let mut progress = Progress::new(window, x);
    let mut its = 0;
    loop {
        bx.free_grad(x, &v.g, &mut v.phi);
        bx.chopped_grad(x, &v.g, &mut v.beta);
        let gp = (0..m).fold(0.0f64, |a, i| a.max((v.phi[i] + v.beta[i]).abs()));
        if stop(x, gp) {
            return Ok((its, true));
        }
        if its >= max_it {
            return Ok((its, false));
        }
        if !progress.advance(its, gp, x) {
            return Err(stalled(op, b, bx, x, &progress, its, gp));
        }
        its += 1;
        if dot(&v.beta, &v.beta) <= GAMMA * GAMMA * bx.reduced_dot(x, &v.phi) {
            conjugate_or_expand(op, b, bx, x, &mut v)?;
        } else {
            proportion(op, bx, x, &mut v)?;
        }
        if its % 64 == 0 {
            exact_gradient(op, b, x, &mut v.g);
        }
    }
}

fn exact_gradient(op: &mut Operator<'_>, b: &[f64], x: &[f64], g: &mut [f64]) {
    op.apply(x, g);
    g.iter_mut().zip(b).for_each(|(gi, bi)| *gi -= bi);
}

/// The exact minimising step gᵀd / dᵀAd along `d` (∞ when dᵀAd ≤ 0) and dᵀAd; `ad` receives A d.
fn cg_step(op: &mut Operator<'_>, d: &[f64], ad: &mut [f64], g: &[f64]) -> (f64, f64) {
    op.apply(d, ad);
    let dad = dot(d, ad);
    let step = if dad > 0.0 {
        dot(g, d) / dad
    } else {
        f64::INFINITY
    };
    (step, dad)
}

/// CG step along `p` if it stays feasible, else a feasible half step and an expansion step.
fn conjugate_or_expand(
    op: &mut Operator<'_>,
    b: &[f64],
    bx: &Box<'_>,
    x: &mut [f64],
    v: &mut Vectors,
) -> Result<(), QpError> {
    let (acg, pap) = cg_step(op, &v.p, &mut v.ap, &v.g);
    let af = bx.max_step(x, &v.p);
    if acg.is_finite() && acg <= af {
        axpy(-acg, &v.p, x);
        axpy(-acg, &v.ap, &mut v.g);
        bx.free_grad(x, &v.g, &mut v.phi);
        let beta_cg = dot(&v.phi, &v.ap) / pap;
        for i in 0..x.len() {
            v.p[i] = v.phi[i] - beta_cg * v.p[i];
        }
        return Ok(());
    }
    if af == f64::INFINITY {
        return Err(unbounded_along(&v.p));
    }
    axpy(-af, &v.p, x);
    axpy(-af, &v.ap, &mut v.g);
    bx.free_grad(x, &v.g, &mut v.phi);
    axpy(-bx.abar, &v.phi, x);
    bx.project(x);
    exact_gradient(op, b, x, &mut v.g);
    bx.free_grad(x, &v.g, &mut v.p);
    Ok(())
}

/// [`QpError::Unbounded`] for an exact ray `−p` (zero curvature, no bound in the way).
fn unbounded_along(p: &[f64]) -> QpError {
    let mut variables: Vec<usize> = (0..p.len()).filter(|&i| p[i] != 0.0).collect();
    variables.sort_by(|&i, &j| p[j].abs().total_cmp(&p[i].abs()));
    variables.truncate(8);
    QpError::Unbounded { variables }
}

/// Proportioning step along the chopped gradient (releases variables from their bounds).
fn proportion(
    op: &mut Operator<'_>,
    bx: &Box<'_>,
    x: &mut [f64],
    v: &mut Vectors,
) -> Result<(), QpError> {
    let (acg, _) = cg_step(op, &v.beta, &mut v.ap, &v.g);
    let step = acg.min(bx.max_step(x, &v.beta));
    if step == f64::INFINITY {
        return Err(unbounded_along(&v.beta));
    }
    axpy(-step, &v.beta, x);
    axpy(-step, &v.ap, &mut v.g);
    bx.free_grad(x, &v.g, &mut v.p);
    Ok(())
}

/// Phase 1: MPRGP on `½‖G y − e‖²` over the box. Returns the iterations, or
/// [`QpError::Infeasible`] when the minimum residual is not zero.
pub(super) fn phase_one(p: &Scaled, opts: &QpOptions) -> Result<usize, QpError> {
    let (m, k) = (p.dim(), p.n_equalities());
    let mut op = Operator {
        c: None,
        g: p.g.as_ref(),
        rho: 1.0,
        tmp: vec![0.0; k],
    };
    let mut b = vec![0.0; m];
    add_gt(p.g.as_ref(), &p.e, 1.0, &mut b);
    let bx = Box {
        lo: &p.lo,
        hi: &p.hi,
        abar: STEP / op.norm_estimate(m),
    };
    let mut y = vec![0.0; m];
    let mut r = vec![0.0; k];
    let mut feasible = false;
    let mut stop = |y: &[f64], gp: f64| {
        let (res, scale) = equality_residual(p, y, &mut r);
        feasible = res <= FEAS_TOL * scale;
        feasible || gp <= 1e-10 * res
    };
    let limits = (opts.max_fallback, stagnation_window(opts, m));
    let (its, stopped) = mprgp(&mut op, &b, &bx, &mut y, limits, &mut stop)?;
    if !stopped || feasible {
        return Ok(its);
    }
    let (_, scale) = equality_residual(p, &y, &mut r);
    let r_orig = p.unscale_equality(&r);
    let mut rows: Vec<usize> = (0..k).filter(|&i| r[i].abs() > FEAS_TOL * scale).collect();
    rows.sort_by(|&a, &b| r_orig[b].abs().total_cmp(&r_orig[a].abs()));
    Err(QpError::Infeasible {
        residuals: rows.iter().map(|&i| r_orig[i]).collect(),
        equality_rows: rows,
    })
}

/// `r = G y − e`; returns `(‖r‖∞, max(‖e‖∞, max_r Σ_j |G_rj y_j|))`.
fn equality_residual(p: &Scaled, y: &[f64], r: &mut [f64]) -> (f64, f64) {
    gemv_rows(p.g.as_ref(), y, r);
    let mut scale = inf_norm(&p.e);
    for (row, ri) in r.iter_mut().enumerate() {
        *ri -= p.e[row];
        let abs: f64 = (0..y.len()).map(|j| (p.g[(row, j)] * y[j]).abs()).sum();
        scale = scale.max(abs);
    }
    (inf_norm(r), scale)
}

/// SMALBE outer loop (plain MPRGP without equalities) from `(y, α̃)` until the KKT residual of
/// the original problem is below `tol`. Returns the MPRGP iterations.
pub(super) fn smalbe(
    problem: &BoxQp,
    p: &Scaled,
    y: &mut [f64],
    alpha: &mut [f64],
    tol: f64,
    opts: &QpOptions,
) -> Result<usize, QpError> {
    let (m, k) = (p.dim(), p.n_equalities());
    let mut op = Operator {
        c: Some(p.c.as_ref()),
        g: p.g.as_ref(),
        rho: 0.0,
        tmp: vec![0.0; k],
    };
    op.rho = if k > 0 {
        10.0 * op.norm_estimate(m)
    } else {
        0.0
    };
    let bx = Box {
        lo: &p.lo,
        hi: &p.hi,
        abar: STEP / op.norm_estimate(m),
    };
    let mut mu: Vec<f64> = alpha.iter().map(|a| -a).collect();
    let mut big_m = 1.0;
    let mut last_lagrangian = f64::NEG_INFINITY;
    let gradient_scale = scaled_gradient_scale(p, y, alpha);
    let eta = 0.1 * gradient_scale;
    let mut floor = tol * gradient_scale;
    let mut its = 0;
    let mut r = vec![0.0; k];
    for _ in 0..MAX_OUTER {
        if its >= opts.max_fallback {
            break;
        }
        let b = augmented_rhs(p, &mu, op.rho);
        let (feas, _) = equality_residual(p, y, &mut r);
        let inner_tol = if k > 0 {
            (big_m * feas).min(eta).max(floor)
        } else {
            floor
        };
        let mut stop = |_: &[f64], gp: f64| gp <= inner_tol;
        let limits = (opts.max_fallback - its, stagnation_window(opts, m));
        let (n, _) = mprgp(&mut op, &b, &bx, y, limits, &mut stop)?;
        its += n;
        equality_residual(p, y, &mut r);
        axpy(op.rho, &r, &mut mu);
        alpha.iter_mut().zip(&mu).for_each(|(a, u)| *a = -u);
        let kkt = unscaled_kkt(problem, p, y, alpha);
        if kkt.max() <= tol {
            return Ok(its);
        }
        if kkt.stationarity.max(kkt.complementarity) > tol {
            floor *= 0.1;
        }
        let lag = lagrangian(p, y, &mu, op.rho, &r);
        if lag < last_lagrangian + 0.5 * op.rho * dot(&r, &r) {
            big_m /= 2.0;
        }
        last_lagrangian = lag;
    }
    Ok(its)
}

/// `b = d − Gᵀμ + ρ Gᵀe`.
fn augmented_rhs(p: &Scaled, mu: &[f64], rho: f64) -> Vec<f64> {
    let mut b = p.d.clone();
    add_gt(p.g.as_ref(), mu, -1.0, &mut b);
    add_gt(p.g.as_ref(), &p.e, rho, &mut b);
    b
}

/// `L(y, μ, ρ) = ½yᵀCy − dᵀy + μᵀr + ½ρ‖r‖²`, `r = G y − e`.
fn lagrangian(p: &Scaled, y: &[f64], mu: &[f64], rho: f64, r: &[f64]) -> f64 {
    let mut cy = vec![0.0; y.len()];
    symv(p.c.as_ref(), y, &mut cy);
    0.5 * dot(y, &cy) - dot(&p.d, y) + dot(mu, r) + 0.5 * rho * dot(r, r)
}

fn scaled_gradient_scale(p: &Scaled, y: &[f64], alpha: &[f64]) -> f64 {
    let m = y.len();
    let s = residuals(p.view(), y, alpha, &mut vec![0.0; m], &mut vec![0.0; m]).gradient_scale;
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use faer::Mat;

    use super::*;

    /// A Hilbert matrix (condition number ~1e16 at m = 12) with an interior solution.
    fn hilbert(m: usize, bound: f64) -> BoxQp {
        let c = Mat::from_fn(m, m, |i, j| 1.0 / ((i + j + 1) as f64));
        let x: Vec<f64> = (0..m)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let mut d = vec![0.0; m];
        symv(c.as_ref(), &x, &mut d);
        BoxQp::new(c, d, vec![-bound; m], vec![bound; m])
    }

    #[test]
    fn smalbe_without_progress_stops_after_one_window_with_stagnated() {
        let problem = hilbert(12, 10.0);
        let p = Scaled::new(&problem);
        let (mut y, mut alpha) = p.start(None);
        let opts = QpOptions {
            stagnation_window: Some(10),
            ..QpOptions::default()
        };
        match smalbe(&problem, &p, &mut y, &mut alpha, 1e-12, &opts) {
            Err(QpError::Stagnated {
                iterations, window, ..
            }) => {
                assert_eq!(window, 10);
                assert!(iterations < 200, "{iterations}");
            }
            other => panic!("expected Stagnated, got {other:?}"),
        }
    }

    #[test]
    fn mprgp_following_a_ray_reports_unbounded_with_the_ray_variables() {
        // C = e₀e₀ᵀ + v vᵀ with v = (0, 1, 1): the kernel is spanned by (0, 1, −1), d pushes
        // along it and the bounds x₁ ≥ 0, x₂ ≤ 0 let it run. From a start off the kernel the run
        // must end Unbounded (by the infinite-step test or by the progress window), not grind.
        let inf = f64::INFINITY;
        let c = Mat::from_fn(3, 3, |i, j| {
            let vv = if i > 0 && j > 0 { 1.0 } else { 0.0 };
            vv + if i == 0 && j == 0 { 1.0 } else { 0.0 }
        });
        let problem = BoxQp::new(
            c,
            vec![1.0, 1.0, -1.0],
            vec![-1.0, 0.0, -inf],
            vec![1.0, inf, 0.0],
        );
        let p = Scaled::new(&problem);
        let mut y = vec![0.3, 0.2, -0.1];
        let mut alpha = Vec::new();
        let opts = QpOptions {
            stagnation_window: Some(50),
            max_fallback: 100_000,
            ..QpOptions::default()
        };
        match smalbe(&problem, &p, &mut y, &mut alpha, 1e-12, &opts) {
            Err(QpError::Unbounded { variables }) => {
                assert!(
                    variables.contains(&1) && variables.contains(&2),
                    "{variables:?}"
                );
            }
            other => panic!("expected Unbounded, got {other:?}"),
        }
    }
}
