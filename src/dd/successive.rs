//! The DD solve: auxiliary problem by PCG1, then successive approximations (D05 4.37 / 6.1–6.3,
//! FGCS 3.25)
//!
//! ```text
//!   S U⁰ = F (tied, PCG1);    S0 U^k = F − S_CON(U^{k−1}) =: T-step (PCG2, warm start U^{k−1})
//! ```
//!
//! with S0 = Σ_{T} R_sᵀ S_s R_s (4.33) and F − S_CON(U) = F0 − Σ_c R_cᵀ (K_ΓI u_I(U) + K_ΓΓ U)
//! over the contact clusters (reference notes §2.11; F0 = f_Γ + Σ_T R_sᵀ g_s).
//!
//! PCG2 is warm-started from U^{k−1} and inexact: its relative tolerance follows the outer
//! residual (Eisenstat–Walker forcing, [`FORCING`]); convergence is only accepted after a T(U)
//! evaluated with the full `pcg2_tol`.
//!
//! Robustness beyond the papers: the contraction factor q_k = ‖U^{k+1} − U^k‖ / ‖U^k − U^{k−1}‖
//! is measured every step (Thm 7.1 predicts q ≤ 2β² < 1); when q ≥ 1 or the iteration stagnates,
//! the fixed point U = T(U) is accelerated by Anderson mixing on the interface trace; when Anderson
//! does not reduce the residual either, safeguarded semismooth Newton steps on
//! S0 U + S_CON(U) = F take over ([`super::newton`]: exact line search on the convex interface
//! energy, so the energy decreases at every step); if all that fails, the caller's direct solver
//! is used. Every such switch is recorded in the report.
//!
//! Depends on [`super::options`], [`super::report`] (which it fills), [`super::decomposition`],
//! [`super::coarse`], [`super::pcg`] and [`super::newton`]; none of them depends on this module.

use std::time::Instant;

use faer::Mat;
use rayon::prelude::*;

use super::coarse::Balancing;
use super::decomposition::Decomposition;
use super::dense::Cholesky;
use super::newton::{line_search, NewtonOperator};
use super::options::{CoarseKind, DdOptions, Pcg1Preconditioner};
use super::partition::Partition;
use super::pcg::pcg;
use super::report::{DdReport, Times};
use super::subdomain::rigid_candidates;
use super::{DdError, DdProblem};
use crate::contact::qp::WarmStart;

/// The answer of a direct solver: reduced displacement and per-pair (normal, tangential)
/// multipliers.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectAnswer {
    pub u: Vec<f64>,
    pub multipliers: Vec<[f64; 2]>,
}

/// A direct solver to fall back on.
pub type Fallback<'a> = &'a (dyn Fn() -> Result<DirectAnswer, String> + Sync);

/// The DD solution.
#[derive(Debug, Clone)]
pub struct DdSolution {
    /// Reduced displacement (all free DOFs).
    pub u: Vec<f64>,
    /// Per contact pair: (normal, tangential) multiplier.
    pub multipliers: Vec<[f64; 2]>,
    pub report: DdReport,
}

/// Solve `problem` by domain decomposition; `fallback` is used (and reported) when the
/// successive approximations cannot be made to converge.
pub fn solve(
    problem: &DdProblem,
    options: &DdOptions,
    fallback: Option<Fallback>,
) -> Result<DdSolution, DdError> {
    let t0 = Instant::now();
    let partition = Partition::new(problem, &options.partition)?;
    let dec = Decomposition::new(problem, partition)?;
    let mut report = DdReport::new(problem, &dec);
    let setup = t0.elapsed().as_secs_f64();
    match iterate(problem, &dec, options, &mut report) {
        Ok((u, multipliers, mut times)) => {
            times.setup = setup;
            times.total = t0.elapsed().as_secs_f64();
            report.times = times;
            Ok(DdSolution {
                u,
                multipliers,
                report,
            })
        }
        Err(err) => {
            let Some(direct) = fallback else {
                return Err(match err {
                    DdError::NotConverged { .. } | DdError::Cluster { .. } => DdError::Diverged {
                        reason: err.to_string(),
                    },
                    other => other,
                });
            };
            let answer = direct().map_err(DdError::Fallback)?;
            report.fallback = Some(format!("direct solver used after: {err}"));
            report.times.setup = setup;
            report.times.total = t0.elapsed().as_secs_f64();
            Ok(DdSolution {
                u: answer.u,
                multipliers: answer.multipliers,
                report,
            })
        }
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn gather(ids: &[usize], x: &[f64]) -> Vec<f64> {
    ids.iter().map(|&g| x[g]).collect()
}

/// The fixed-point map of the successive approximations, with warm starts.
struct Step<'a> {
    dec: &'a Decomposition,
    s0: Balancing<'a>,
    f0: Vec<f64>,
    options: &'a DdOptions,
    warm: Vec<Option<WarmStart>>,
    /// Multipliers of each cluster's last local solve (row order).
    multipliers: Vec<Vec<f64>>,
    /// F − S_CON(U) of the last T(U).
    b: Vec<f64>,
    pcg2_iterations: Vec<usize>,
    newton_steps: usize,
    newton_iterations: usize,
    coarse_residual: f64,
    qp_iterations: usize,
    scon_time: f64,
    pcg2_time: f64,
}

impl Step<'_> {
    /// F − S_CON(U): one local frictional solve per cluster (parallel, fixed summation order).
    fn rhs(&mut self, u: &[f64]) -> Result<Vec<f64>, DdError> {
        let t = Instant::now();
        let states: Vec<_> = self
            .dec
            .clusters
            .par_iter()
            .zip(&self.warm)
            .enumerate()
            .map(|(c, (cl, warm))| {
                cl.evaluate(&gather(&cl.gamma, u), warm.as_ref(), &self.options.qp)
                    .map_err(|reason| DdError::Cluster { cluster: c, reason })
            })
            .collect::<Result<_, _>>()?;
        let mut b = self.f0.clone();
        for (c, (cl, state)) in self.dec.clusters.iter().zip(states).enumerate() {
            for (&g, r) in cl.gamma.iter().zip(&state.reaction) {
                b[g] -= r;
            }
            self.qp_iterations += state.qp.iterations;
            self.warm[c] = Some(WarmStart::from(&state.qp));
            self.multipliers[c] = state.qp.x;
        }
        self.scon_time += t.elapsed().as_secs_f64();
        Ok(b)
    }

    /// T(U): solve S0 V = F − S_CON(U) from V = U to the relative residual `tol`.
    fn apply(&mut self, u: &[f64], tol: f64) -> Result<Vec<f64>, DdError> {
        let b = self.rhs(u)?;
        let t = Instant::now();
        let out = pcg(&self.s0, &b, u.to_vec(), tol, self.options.max_pcg, "PCG2")?;
        self.pcg2_time += t.elapsed().as_secs_f64();
        self.pcg2_iterations.push(out.iterations);
        self.coarse_residual = self.coarse_residual.max(out.coarse_residual);
        self.b = b;
        Ok(out.x)
    }

    /// A safeguarded semismooth Newton step from `u` ([`super::newton`]), right after T(u) was
    /// evaluated; `None` when no tangent is available (a floating cluster, dependent active rows)
    /// or the direction is not one of descent.
    fn newton(&mut self, u: &[f64], tol: f64) -> Result<Option<Vec<f64>>, DdError> {
        let t = Instant::now();
        let tangents: Option<Vec<_>> = self
            .dec
            .clusters
            .iter()
            .zip(&self.multipliers)
            .map(|(cl, x)| cl.tangent(x).map(|t| (cl, t)))
            .collect();
        let Some(tangents) = tangents else {
            return Ok(None);
        };
        let s0u = self.s0.apply(u);
        let mg: Vec<f64> = self.b.iter().zip(&s0u).map(|(b, s)| b - s).collect();
        let op = NewtonOperator::new(&self.s0, tangents)?;
        let Ok(out) = pcg(
            &op,
            &mg,
            vec![0.0; u.len()],
            tol,
            self.options.max_pcg,
            "Newton",
        ) else {
            return Ok(None);
        };
        drop(op);
        self.newton_iterations += out.iterations;
        self.coarse_residual = self.coarse_residual.max(out.coarse_residual);
        let delta = out.x;
        let s0d = self.s0.apply(&delta);
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let (d_s0u, d_s0d) = (dot(&delta, &s0u), dot(&delta, &s0d));
        let d0 = -dot(&delta, &mg);
        self.pcg2_time += t.elapsed().as_secs_f64();
        if d0.is_nan() || d0 >= 0.0 {
            return Ok(None);
        }
        let at = |t: f64| -> Vec<f64> { u.iter().zip(&delta).map(|(a, d)| a + t * d).collect() };
        // φ'(t) = δᵀ G(U + tδ) = δᵀ S0 U + t δᵀ S0 δ − δᵀ (F − S_CON(U + tδ)).
        let step = line_search(d0, LINE_SEARCH_REL, LINE_SEARCH_EVALS, |t| {
            self.rhs(&at(t))
                .map(|b| d_s0u + t * d_s0d - dot(&delta, &b))
        })?;
        self.newton_steps += 1;
        Ok(Some(at(step)))
    }
}

/// The plane rigid motions on the interface of every non-contact subdomain (coarse enrichment,
/// [`CoarseKind::Rigid`]).
fn rigid_traces(problem: &DdProblem, dec: &Decomposition) -> Vec<Option<Mat<f64>>> {
    dec.blocks
        .iter()
        .map(|b| {
            let dofs: Vec<usize> = b.gamma.iter().map(|&g| dec.interface[g]).collect();
            Some(rigid_candidates(problem, &dofs, &vec![0; dofs.len()]))
        })
        .collect()
}

/// Line search of the Newton steps: |φ'(t)| ≤ LINE_SEARCH_REL |φ'(0)|, at most
/// LINE_SEARCH_EVALS S_CON evaluations besides t = 1.
const LINE_SEARCH_REL: f64 = 0.1;
const LINE_SEARCH_EVALS: usize = 12;

/// Anderson counts as stagnating when its best residual has not dropped by 10 % for this many
/// steps; the Newton steps take over.
const STALL: usize = 1;

/// PCG2 tolerance = FORCING × (relative outer residual of the previous step), at most FORCING_MAX.
pub const FORCING: f64 = 0.1;
const FORCING_MAX: f64 = 1e-2;

type Outcome = (Vec<f64>, Vec<[f64; 2]>, Times);

fn iterate(
    problem: &DdProblem,
    dec: &Decomposition,
    options: &DdOptions,
    report: &mut DdReport,
) -> Result<Outcome, DdError> {
    let mut times = Times::default();
    let n = dec.n_interface();
    let t = Instant::now();
    // F0 = f_Γ + Σ_T (condensed loads).
    let mut f0: Vec<f64> = dec.interface.iter().map(|&d| problem.rhs[d]).collect();
    let loads: Vec<Vec<f64>> = dec.blocks.par_iter().map(|b| b.condensed_load()).collect();
    for (b, l) in dec.blocks.iter().zip(&loads) {
        for (&g, v) in b.gamma.iter().zip(l) {
            f0[g] += v;
        }
    }
    // Auxiliary problem (PCG1): S = S0 + Σ tied clusters.
    let mut aux = f0.clone();
    for tb in &dec.tied {
        for (&g, v) in tb.gamma.iter().zip(tb.condensed_load()) {
            aux[g] += v;
        }
    }
    let enrich = match options.coarse {
        CoarseKind::Kernels => Vec::new(),
        CoarseKind::Rigid => rigid_traces(problem, dec),
    };
    let s_op = match options.pcg1_preconditioner {
        Pcg1Preconditioner::Full => Balancing::new(
            dec.blocks.iter().chain(&dec.tied).collect(),
            Vec::new(),
            &enrich,
            n,
        )?,
        Pcg1Preconditioner::Reduced => Balancing::new(
            dec.blocks.iter().collect(),
            dec.tied.iter().collect(),
            &enrich,
            n,
        )?,
    };
    report.pcg1_preconditioner = options.pcg1_preconditioner;
    report.coarse = options.coarse;
    report.coarse_dim_pcg1 = s_op.coarse_dim();
    report.partition_of_unity_error[0] = s_op.partition_of_unity_error();
    let first = pcg(
        &s_op,
        &aux,
        vec![0.0; n],
        options.pcg1_tol,
        options.max_pcg,
        "PCG1",
    )?;
    report.pcg1_iterations = first.iterations;
    report.coarse_residual[0] = first.coarse_residual;
    drop(s_op);
    times.pcg1 = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let s0 = Balancing::new(dec.blocks.iter().collect(), Vec::new(), &enrich, n)?;
    report.coarse_dim_pcg2 = s0.coarse_dim();
    report.partition_of_unity_error[1] = s0.partition_of_unity_error();
    let mut step = Step {
        dec,
        s0,
        f0,
        options,
        warm: vec![None; dec.clusters.len()],
        multipliers: vec![Vec::new(); dec.clusters.len()],
        b: Vec::new(),
        pcg2_iterations: Vec::new(),
        newton_steps: 0,
        newton_iterations: 0,
        coarse_residual: 0.0,
        qp_iterations: 0,
        scon_time: 0.0,
        pcg2_time: 0.0,
    };
    let mut u = first.x;
    let mut anderson = Anderson::new(options.anderson_depth);
    let mut accelerated = options.force_acceleration && options.anderson_depth > 0;
    if accelerated {
        report.acceleration = Some("Anderson mixing from the first step (forced)".into());
    }
    let mut high = 0;
    let mut converged = false;
    let mut newton = false;
    let (mut best, mut best_k) = (f64::INFINITY, 0);
    // Inexact PCG2 (Eisenstat–Walker style): the inner tolerance follows the relative outer
    // residual of the previous step, never looser than FORCING_MAX nor tighter than pcg2_tol.
    let mut pcg2_tol = FORCING_MAX.max(options.pcg2_tol);
    for k in 0..options.max_outer {
        let used = pcg2_tol;
        let tu = step.apply(&u, used)?;
        let diff: Vec<f64> = tu.iter().zip(&u).map(|(a, b)| a - b).collect();
        let r = norm(&diff);
        let scale = norm(&tu).max(f64::MIN_POSITIVE);
        if let Some(&prev) = report.outer_residuals.last() {
            let q = if prev > 0.0 { r / prev } else { 0.0 };
            report.contraction.push(q);
            if !accelerated {
                high = if q >= 1.0 {
                    2
                } else if q > options.stagnation {
                    high + 1
                } else {
                    0
                };
                if high >= 2 && options.anderson_depth > 0 {
                    accelerated = true;
                    report.acceleration = Some(format!(
                        "Anderson mixing (depth {}) from outer step {k}: observed contraction {q:.3}",
                        options.anderson_depth
                    ));
                }
            }
        }
        report.outer_residuals.push(r);
        report.outer_iterations = k + 1;
        pcg2_tol = (FORCING * r / scale).clamp(options.pcg2_tol, FORCING_MAX.max(options.pcg2_tol));
        // Converged only if T(U) was evaluated with the full PCG2 accuracy; also when that PCG2
        // needed no iteration: S0 U − F + S_CON(U) is then below the inner tolerance and no
        // inner solve can tell U from T(U) (a tight outer_tol at the rounding floor).
        let exact = used <= options.pcg2_tol;
        if exact && step.pcg2_iterations.last() == Some(&0) {
            u = tu;
            converged = true;
            break;
        }
        if r <= options.outer_tol * scale {
            u = tu;
            if exact {
                converged = true;
                break;
            }
            pcg2_tol = options.pcg2_tol;
            continue;
        }
        if !r.is_finite() {
            break;
        }
        if accelerated && !newton {
            if r < 0.9 * best {
                (best, best_k) = (r, k);
            } else if k >= best_k + STALL {
                newton = true;
                let note = format!(
                    "; safeguarded semismooth Newton from outer step {k} (Anderson stagnated at {best:.3e})"
                );
                report
                    .acceleration
                    .get_or_insert_with(String::new)
                    .push_str(&note);
            }
        }
        let next = if newton {
            step.newton(&u, pcg2_tol)?
        } else {
            None
        };
        u = match next {
            Some(v) => v,
            None if accelerated => anderson.next(&u, &tu),
            None => tu,
        };
    }
    report.newton_steps = step.newton_steps;
    report.newton_pcg_iterations = step.newton_iterations;
    report.pcg2_iterations = step.pcg2_iterations.iter().sum();
    report.pcg2_per_outer = step.pcg2_iterations.clone();
    report.coarse_residual[1] = step.coarse_residual;
    report.finish_contraction();
    times.scon = step.scon_time;
    times.pcg2 = step.pcg2_time;
    times.outer = t.elapsed().as_secs_f64();
    if !converged {
        let last = report.outer_residuals.last().copied().unwrap_or(f64::NAN);
        return Err(DdError::NotConverged {
            solver: "successive approximations",
            iterations: report.outer_iterations,
            residual: last / norm(&u).max(f64::MIN_POSITIVE),
        });
    }

    // Recovery of interiors and multipliers at the converged trace.
    let t = Instant::now();
    let mut full = vec![0.0; problem.n_dofs()];
    for (&d, &v) in dec.interface.iter().zip(&u) {
        full[d] = v;
    }
    let interiors: Vec<Vec<f64>> = dec
        .blocks
        .par_iter()
        .map(|b| b.interior(&gather(&b.gamma, &u)))
        .collect();
    for (dofs, x) in dec.block_dofs.iter().zip(interiors) {
        for (&d, v) in dofs.interior.iter().zip(x) {
            full[d] = v;
        }
    }
    let mut multipliers = vec![[0.0; 2]; problem.pairs.len()];
    for (c, cl) in dec.clusters.iter().enumerate() {
        let state = cl
            .evaluate(&gather(&cl.gamma, &u), step.warm[c].as_ref(), &options.qp)
            .map_err(|reason| DdError::Cluster { cluster: c, reason })?;
        for (&d, &v) in dec.cluster_dofs[c].interior.iter().zip(&state.interior) {
            full[d] = v;
        }
        for (i, &p) in dec.cluster_pairs[c].iter().enumerate() {
            multipliers[p] = [state.qp.x[2 * i], state.qp.x[2 * i + 1]];
        }
        report.floating_modes += state.qp.alpha.len();
    }
    report.qp_iterations = step.qp_iterations;
    times.recovery = t.elapsed().as_secs_f64();
    Ok((full, multipliers, times))
}

/// Anderson mixing (type II) for U = T(U): U_{k+1} = T(U_k) − ΔT γ, γ = argmin ‖f_k − ΔF γ‖,
/// f = T(U) − U (Walker & Ni, SIAM J. Numer. Anal. 49 (2011)).
struct Anderson {
    depth: usize,
    u: Vec<Vec<f64>>,
    t: Vec<Vec<f64>>,
}

impl Anderson {
    fn new(depth: usize) -> Anderson {
        Anderson {
            depth,
            u: Vec::new(),
            t: Vec::new(),
        }
    }

    fn next(&mut self, u: &[f64], tu: &[f64]) -> Vec<f64> {
        self.u.push(u.to_vec());
        self.t.push(tu.to_vec());
        if self.u.len() > self.depth + 1 {
            self.u.remove(0);
            self.t.remove(0);
        }
        let m = self.u.len() - 1;
        if m == 0 {
            return tu.to_vec();
        }
        let f = |i: usize| -> Vec<f64> {
            self.t[i]
                .iter()
                .zip(&self.u[i])
                .map(|(a, b)| a - b)
                .collect()
        };
        let fk = f(m);
        let df: Vec<Vec<f64>> = (0..m)
            .map(|i| f(i + 1).iter().zip(f(i)).map(|(a, b)| a - b).collect())
            .collect();
        // Normal equations with a relative Tikhonov term (the columns may be nearly dependent).
        let a = Mat::from_fn(m, m, |i, j| {
            let v: f64 = df[i].iter().zip(&df[j]).map(|(x, y)| x * y).sum();
            if i == j {
                v * (1.0 + 1e-10)
            } else {
                v
            }
        });
        let rhs = Mat::from_fn(m, 1, |i, _| df[i].iter().zip(&fk).map(|(x, y)| x * y).sum());
        let Some(gamma) = Cholesky::new(a.as_ref()).map(|c| c.solve(rhs.as_ref())) else {
            return tu.to_vec();
        };
        let mut next = tu.to_vec();
        for i in 0..m {
            let g = gamma[(i, 0)];
            for (j, x) in next.iter_mut().enumerate() {
                *x -= g * (self.t[i + 1][j] - self.t[i][j]);
            }
        }
        next
    }
}
