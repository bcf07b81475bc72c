//! Primal–dual active set (semismooth Newton) iteration with cycle/stagnation detection, and the
//! driver that falls back to MPRGP/SMALBE and polishes the result with Newton.

use std::collections::HashSet;
use std::hash::{DefaultHasher, Hash, Hasher};

use faer::Par;

use super::saddle::Saddle;
use super::scaled::Scaled;
use super::{
    mprgp, residuals, unscaled_kkt, BoxQp, ProblemRef, QpError, QpMethod, QpOptions, QpSolution,
};

/// Counters accumulated over all phases.
#[derive(Default)]
pub(super) struct Stats {
    pub iterations: usize,
    pub fallback_iterations: usize,
    pub active_set_changes: usize,
}

#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
enum Status {
    Free,
    Lower,
    Upper,
}

/// How a Newton run ended.
#[derive(PartialEq, Debug)]
enum Outcome {
    Converged,
    /// Cycle, stagnation, step cap or an indefinite reduced matrix: needs the fallback.
    Stuck,
}

/// Newton steps allowed without a new best KKT residual before switching to the fallback.
const PATIENCE: usize = 3;

/// The best iterate of a Newton run (PDAS is not monotone in any merit function).
struct Best {
    kkt: f64,
    y: Vec<f64>,
    alpha: Vec<f64>,
    since: usize,
}

impl Best {
    fn new(y: &[f64], alpha: &[f64]) -> Self {
        Self {
            kkt: f64::INFINITY,
            y: y.to_vec(),
            alpha: alpha.to_vec(),
            since: 0,
        }
    }

    /// Records the iterate if it is the best so far; false when patience is exhausted.
    fn update(&mut self, kkt: f64, y: &[f64], alpha: &[f64]) -> bool {
        if kkt < self.kkt {
            self.kkt = kkt;
            self.y.copy_from_slice(y);
            self.alpha.copy_from_slice(alpha);
            self.since = 0;
        } else {
            self.since += 1;
        }
        self.since < PATIENCE
    }

    fn restore(&self, y: &mut [f64], alpha: &mut [f64]) {
        y.copy_from_slice(&self.y);
        alpha.copy_from_slice(&self.alpha);
    }
}

/// The Newton iteration state (scaled variables).
struct Newton<'a> {
    problem: &'a BoxQp,
    p: &'a Scaled,
    saddle: Saddle,
    status: Vec<Status>,
    free: Vec<usize>,
    undetermined: usize,
    tol: f64,
}

/// Solves from the scaled start `(y, α̃)`: Newton first, the fallback when Newton is stuck.
pub(super) fn solve(
    problem: &BoxQp,
    p: &Scaled,
    mut y: Vec<f64>,
    mut alpha: Vec<f64>,
    opts: &QpOptions,
    mut stats: Stats,
) -> Result<QpSolution, QpError> {
    let par = if opts.parallel {
        Par::rayon(0)
    } else {
        Par::Seq
    };
    let mut newton = Newton {
        problem,
        p,
        saddle: Saddle::new(p.dim(), p.n_equalities(), par),
        status: vec![Status::Free; p.dim()],
        free: Vec::with_capacity(p.dim()),
        undetermined: 0,
        tol: opts.tol,
    };
    if newton.run(&mut y, &mut alpha, opts, &mut stats) == Outcome::Converged {
        return newton.finish(y, alpha, stats, QpMethod::Newton);
    }
    // Fallback to a moderate accuracy, then polish by Newton from the identified active set.
    if y.iter().chain(&alpha).any(|v| !v.is_finite()) {
        (y, alpha) = p.start(None);
    }
    p.project(&mut y);
    let coarse = opts.tol.max(1e-8);
    stats.fallback_iterations += mprgp::smalbe(problem, p, &mut y, &mut alpha, coarse, opts)?;
    if unscaled_kkt(problem, p, &y, &alpha).max() > coarse {
        // Newton's multipliers can be far off (e.g. after releases along rigid directions):
        // restart the augmented Lagrangian from the cold start.
        (y, alpha) = p.start(None);
        stats.fallback_iterations += mprgp::smalbe(problem, p, &mut y, &mut alpha, coarse, opts)?;
    }
    let (mut y2, mut a2) = (y.clone(), alpha.clone());
    if newton.run(&mut y2, &mut a2, opts, &mut stats) == Outcome::Converged {
        return newton.finish(y2, a2, stats, QpMethod::FallbackThenNewton);
    }
    stats.fallback_iterations += mprgp::smalbe(problem, p, &mut y, &mut alpha, opts.tol, opts)?;
    newton.classify_from_point(&y, &alpha);
    newton.undetermined = newton.count_undetermined(&y);
    newton.finish(y, alpha, stats, QpMethod::Fallback)
}

impl Newton<'_> {
    /// PDAS steps until the KKT residual of the original problem is below `tol`.
    fn run(
        &mut self,
        y: &mut [f64],
        alpha: &mut [f64],
        opts: &QpOptions,
        stats: &mut Stats,
    ) -> Outcome {
        let mut seen = HashSet::new();
        let mut best = Best::new(y, alpha);
        for step in 0..=opts.max_newton {
            let kkt = unscaled_kkt(self.problem, self.p, y, alpha).max();
            if kkt <= opts.tol {
                if step == 0 {
                    // Converged without a step: still identify the free set and the rank of G_F.
                    self.classify_from_point(y, alpha);
                    self.undetermined = self.count_undetermined(y);
                }
                return Outcome::Converged;
            }
            if !best.update(kkt, y, alpha) {
                break;
            }
            let changes = self.classify_from_point(y, alpha);
            if (step > 0 && changes == 0) || !seen.insert(self.fingerprint()) {
                break;
            }
            stats.active_set_changes += if step > 0 { changes } else { 0 };
            if self.step(y, alpha).is_err() {
                break;
            }
            stats.iterations += 1;
        }
        best.restore(y, alpha);
        Outcome::Stuck
    }

    /// One Newton step for the current active set.
    fn step(&mut self, y: &mut [f64], alpha: &mut [f64]) -> Result<(), super::saddle::Indefinite> {
        for (i, s) in self.status.iter().enumerate() {
            match s {
                Status::Lower => y[i] = self.p.lo[i],
                Status::Upper => y[i] = self.p.hi[i],
                Status::Free => {}
            }
        }
        let info = self.saddle.solve(self.p, &self.free, y, alpha)?;
        self.undetermined = info.undetermined;
        for (v, missing) in &info.inconsistent {
            self.release_along(y, alpha, v, *missing);
        }
        Ok(())
    }

    /// The free set cannot meet the equalities in direction `v` (`vᵀ(e − G y) = missing`): a
    /// floating body that touches nothing in that direction. Moves `α` along `±v` (the rigid
    /// motion) just far enough that the next prediction frees the first active variable that can
    /// supply the missing amount — the first contact that closes (a dual ratio test).
    fn release_along(&self, y: &[f64], alpha: &mut [f64], v: &[f64], missing: f64) {
        let p = self.p;
        let m = p.dim();
        let mut q = vec![0.0; m];
        super::add_gt(p.g.as_ref(), v, 1.0, &mut q);
        let mut grad = vec![0.0; m];
        super::symv(p.c.as_ref(), y, &mut grad);
        for (gi, di) in grad.iter_mut().zip(&p.d) {
            *gi -= di;
        }
        super::add_gt(p.g.as_ref(), alpha, -1.0, &mut grad);
        let sign = missing.signum();
        // Along α += sign·τ·v the prediction y_j − g_j moves by sign·τ·q_j.
        let tau = (0..m)
            .filter_map(|j| {
                let rate = sign * q[j];
                match self.status[j] {
                    Status::Lower if p.lo[j] < p.hi[j] && rate > 0.0 => Some(grad[j] / rate),
                    Status::Upper if p.lo[j] < p.hi[j] && rate < 0.0 => Some(grad[j] / rate),
                    _ => None,
                }
            })
            .fold(f64::INFINITY, f64::min);
        if tau.is_finite() {
            let step = sign * (tau.max(0.0) * (1.0 + 1e-9) + 1e-12 * (1.0 + tau.abs()));
            for (a, vr) in alpha.iter_mut().zip(v) {
                *a += step * vr;
            }
        }
    }

    /// Active-set prediction `y − g̃ ∉ (l, u)` (complementarity constant 1 in scaled variables);
    /// returns how many statuses changed.
    fn classify_from_point(&mut self, y: &[f64], alpha: &[f64]) -> usize {
        let p = self.p;
        let m = p.dim();
        let mut grad = vec![0.0; m];
        super::symv(p.c.as_ref(), y, &mut grad);
        for (gi, di) in grad.iter_mut().zip(&p.d) {
            *gi -= di;
        }
        super::add_gt(p.g.as_ref(), alpha, -1.0, &mut grad);
        self.free.clear();
        let mut changes = 0;
        for i in 0..m {
            let z = y[i] - grad[i];
            let s = if p.lo[i] == p.hi[i] || z <= p.lo[i] {
                Status::Lower
            } else if z >= p.hi[i] {
                Status::Upper
            } else {
                self.free.push(i);
                Status::Free
            };
            changes += usize::from(s != self.status[i]);
            self.status[i] = s;
        }
        changes
    }

    fn fingerprint(&self) -> u64 {
        let mut h = DefaultHasher::new();
        self.status.hash(&mut h);
        h.finish()
    }

    /// Rank deficiency of `G_F` for the current free set (one saddle solve, result discarded).
    fn count_undetermined(&mut self, y: &[f64]) -> usize {
        if self.p.n_equalities() == 0 {
            return 0;
        }
        let mut yc = y.to_vec();
        let mut ac = vec![0.0; self.p.n_equalities()];
        match self.saddle.solve(self.p, &self.free, &mut yc, &mut ac) {
            Ok(info) => info.undetermined,
            Err(_) => 0,
        }
    }

    /// Unscales, certifies and packages the result.
    fn finish(
        &self,
        y: Vec<f64>,
        alpha: Vec<f64>,
        stats: Stats,
        method: QpMethod,
    ) -> Result<QpSolution, QpError> {
        let (x, a) = self.p.unscale(&y, &alpha);
        let m = x.len();
        let mut grad = vec![0.0; m];
        let kkt = residuals(
            ProblemRef::of(self.problem),
            &x,
            &a,
            &mut grad,
            &mut vec![0.0; m],
        );
        if kkt.max() > self.tol || x.iter().chain(&a).any(|v| !v.is_finite()) {
            return Err(QpError::NotConverged {
                iterations: stats.iterations,
                fallback_iterations: stats.fallback_iterations,
                residuals: kkt,
            });
        }
        Ok(QpSolution {
            w: grad.iter().map(|g| -g).collect(),
            x,
            alpha: a,
            iterations: stats.iterations,
            fallback_iterations: stats.fallback_iterations,
            active_set_changes: stats.active_set_changes,
            kkt,
            undetermined_modes: self.undetermined,
            method,
        })
    }
}
