//! The DD solve: auxiliary problem by PCG1, then successive approximations (D05 4.37 / 6.1–6.3,
//! FGCS 3.25)
//!
//! ```text
//!   S U⁰ = F (tied, PCG1);    S0 U^k = F − S_CON(U^{k−1}) =: T-step (PCG2, warm start U^{k−1})
//! ```
//!
//! with S0 = Σ_{T} R_sᵀ S_s R_s (4.33) and F − S_CON(U) = F0 − Σ_c R_cᵀ (K_ΓI u_I(U) + K_ΓΓ U) over
//! the contact clusters (D05 4.29–4.34 written with matrices, design §3.2; F0 = f_Γ + Σ_T R_sᵀ
//! g_s). F − S_CON does not depend on how the contact subdomains' interface data are extended
//! inside them, though F and S_CON each do.
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
use super::newton::{line_search, NewtonOperator};
use super::options::{CoarseKind, DdOptions, OuterIteration, Pcg1Preconditioner};
use super::partition::Partition;
use super::pcg::pcg;
use super::report::{DdReport, Times};
use super::subdomain::rigid_candidates;
use super::{DdError, DdProblem};
use crate::contact::anderson::{Anderson, Shift};
use crate::contact::pairs::{normal_row, tangential_row};
use crate::contact::qp::WarmStart;

/// The answer of a direct solver: reduced displacement and per-pair (normal, tangential)
/// multipliers.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectAnswer {
    /// Reduced displacement \[m\]: every free DOF in its node's rotated basis.
    pub u: Vec<f64>,
    /// Per contact pair: (normal, tangential) multiplier [N/m], in the pair order of the problem.
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
    /// What the solve did: sizes, iteration counts, contraction, switches and times.
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
    let dec = Decomposition::new(
        problem,
        partition,
        options.operators.as_deref(),
        options.weights,
    )?;
    let mut report = DdReport::new(problem, &dec);
    report.weights = options.weights;
    report.iteration = options.iteration;
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

impl<'a> Step<'a> {
    fn new(
        dec: &'a Decomposition,
        s0: Balancing<'a>,
        f0: Vec<f64>,
        options: &'a DdOptions,
    ) -> Step<'a> {
        Step {
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
        }
    }

    /// The PCG2 / Newton counts and the PCG2 coarse check into the report.
    fn record(&self, report: &mut DdReport) {
        report.newton_steps = self.newton_steps;
        report.newton_pcg_iterations = self.newton_iterations;
        report.pcg2_iterations = self.pcg2_iterations.iter().sum();
        report.pcg2_per_outer = self.pcg2_iterations.clone();
        report.coarse_residual[1] = self.coarse_residual;
    }
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

/// The solve on a decomposition, phase by phase (each timed): auxiliary problem by PCG1
/// ([`auxiliary`]), successive approximations ([`outer`]) and recovery ([`recover`]).
fn iterate(
    problem: &DdProblem,
    dec: &Decomposition,
    options: &DdOptions,
    report: &mut DdReport,
) -> Result<Outcome, DdError> {
    let mut times = Times::default();
    let t = Instant::now();
    let (f0, aux) = interface_loads(problem, dec);
    let enrich = match options.coarse {
        CoarseKind::Kernels => Vec::new(),
        CoarseKind::Rigid => rigid_traces(problem, dec),
    };
    let u0 = auxiliary(dec, options, &enrich, &aux, report)?;
    times.pcg1 = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let s0 = s0_operator(dec, &enrich, report)?;
    let mut step = Step::new(dec, s0, f0, options);
    let outcome = outer(&mut step, u0, options, report);
    // Counts are kept even when the iteration stops (a non-contracting plain run).
    step.record(report);
    let (u, converged) = outcome?;
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

    let t = Instant::now();
    let (full, multipliers) = recover(problem, dec, &step.warm, &u, options, report)?;
    report.qp_iterations = step.qp_iterations;
    times.recovery = t.elapsed().as_secs_f64();
    Ok((full, multipliers, times))
}

/// y[gamma[i]] += values[i]: a block's local interface vector added into the global one.
fn scatter_add(y: &mut [f64], gamma: &[usize], values: impl IntoIterator<Item = f64>) {
    for (&g, v) in gamma.iter().zip(values) {
        y[g] += v;
    }
}

/// F0 = f_Γ + Σ_T (condensed loads of the non-contact subdomains), and the right-hand side of
/// the auxiliary problem: F0 plus the condensed loads of the tied clusters.
fn interface_loads(problem: &DdProblem, dec: &Decomposition) -> (Vec<f64>, Vec<f64>) {
    let mut f0: Vec<f64> = dec.interface.iter().map(|&d| problem.rhs[d]).collect();
    let loads: Vec<Vec<f64>> = dec.blocks.par_iter().map(|b| b.condensed_load()).collect();
    for (b, l) in dec.blocks.iter().zip(loads) {
        scatter_add(&mut f0, &b.gamma, l);
    }
    let mut aux = f0.clone();
    for tb in &dec.tied {
        scatter_add(&mut aux, &tb.gamma, tb.condensed_load());
    }
    (f0, aux)
}

/// The auxiliary problem S U⁰ = F (D05 4.48) by PCG1, S = S0 + Σ tied clusters, with the
/// preconditioner chosen by [`DdOptions::pcg1_preconditioner`]; returns U⁰.
fn auxiliary(
    dec: &Decomposition,
    options: &DdOptions,
    enrich: &[Option<Mat<f64>>],
    aux: &[f64],
    report: &mut DdReport,
) -> Result<Vec<f64>, DdError> {
    let n = dec.n_interface();
    let s_op = match options.pcg1_preconditioner {
        Pcg1Preconditioner::Full => Balancing::new(
            dec.blocks.iter().chain(&dec.tied).collect(),
            Vec::new(),
            enrich,
            n,
        )?,
        Pcg1Preconditioner::Reduced => Balancing::new(
            dec.blocks.iter().collect(),
            dec.tied.iter().collect(),
            enrich,
            n,
        )?,
    };
    report.pcg1_preconditioner = options.pcg1_preconditioner;
    report.coarse = options.coarse;
    report.coarse_dim_pcg1 = s_op.coarse_dim();
    report.partition_of_unity_error[0] = s_op.partition_of_unity_error();
    let first = pcg(
        &s_op,
        aux,
        vec![0.0; n],
        options.pcg1_tol,
        options.max_pcg,
        "PCG1",
    )?;
    report.pcg1_iterations = first.iterations;
    report.coarse_residual[0] = first.coarse_residual;
    Ok(first.x)
}

/// S0 = Σ_T R_sᵀ S_s R_s with its balancing preconditioner (D05 §6), for PCG2 and the Newton
/// steps.
fn s0_operator<'a>(
    dec: &'a Decomposition,
    enrich: &[Option<Mat<f64>>],
    report: &mut DdReport,
) -> Result<Balancing<'a>, DdError> {
    let s0 = Balancing::new(
        dec.blocks.iter().collect(),
        Vec::new(),
        enrich,
        dec.n_interface(),
    )?;
    report.coarse_dim_pcg2 = s0.coarse_dim();
    report.partition_of_unity_error[1] = s0.partition_of_unity_error();
    Ok(s0)
}

/// The loosest PCG2 tolerance: the first outer step and the cap of [`forcing_tol`].
fn loosest_pcg2_tol(options: &DdOptions) -> f64 {
    FORCING_MAX.max(options.pcg2_tol)
}

/// Inexact PCG2 (Eisenstat–Walker style): the inner tolerance follows the relative outer
/// residual r / scale of the previous step, never looser than FORCING_MAX nor tighter than
/// `pcg2_tol`.
fn forcing_tol(r: f64, scale: f64, options: &DdOptions) -> f64 {
    (FORCING * r / scale).clamp(options.pcg2_tol, loosest_pcg2_tol(options))
}

/// What the stopping test says after an outer step.
enum Stop {
    /// T(U) is the answer.
    Converged,
    /// The step is small but T(U) was computed with a loose PCG2: take it and evaluate again
    /// with the full accuracy.
    Tighten,
    /// The residual is not finite.
    Diverged,
    Continue,
}

/// The stopping test of an outer step with residual r = ‖T(U) − U‖, scale ‖T(U)‖ and PCG2
/// tolerance `used`. Converged only if T(U) was evaluated with the full PCG2 accuracy; also when
/// that PCG2 needed no iteration: S0 U − F + S_CON(U) is then below the inner tolerance and no
/// inner solve can tell U from T(U) (a tight outer_tol at the rounding floor).
fn stop_test(r: f64, scale: f64, used: f64, step: &Step, options: &DdOptions) -> Stop {
    let exact = used <= options.pcg2_tol;
    if exact && step.pcg2_iterations.last() == Some(&0) {
        return Stop::Converged;
    }
    if r <= options.outer_tol * scale {
        return if exact {
            Stop::Converged
        } else {
            Stop::Tighten
        };
    }
    if !r.is_finite() {
        return Stop::Diverged;
    }
    Stop::Continue
}

/// The switches away from plain successive approximations, each recorded in the report:
/// Anderson mixing when the contraction is lost, safeguarded Newton steps when Anderson
/// stagnates.
struct Switches {
    accelerated: bool,
    /// Consecutive steps with q > `stagnation` (2 once q ≥ 1).
    high: usize,
    newton: bool,
    /// Best accelerated residual and its step.
    best: f64,
    best_k: usize,
}

impl Switches {
    fn new(options: &DdOptions, report: &mut DdReport) -> Switches {
        let accelerated = options.force_acceleration
            && options.anderson_depth > 0
            && options.iteration == OuterIteration::Safeguarded;
        if accelerated {
            report.acceleration = Some("Anderson mixing from the first step (forced)".into());
        }
        Switches {
            accelerated,
            high: 0,
            newton: false,
            best: f64::INFINITY,
            best_k: 0,
        }
    }

    /// Record r_k and the contraction factor q_k = r_k / r_{k−1} (Thm 7.1: q ≤ 2β² < 1);
    /// switch to Anderson when q ≥ 1, or when q > `stagnation` twice in a row. The plain
    /// iteration never switches: q ≥ 1 on two consecutive steps ends it as not contracting.
    fn record_residual(
        &mut self,
        k: usize,
        r: f64,
        options: &DdOptions,
        report: &mut DdReport,
    ) -> Result<(), DdError> {
        if let Some(&prev) = report.outer_residuals.last() {
            let q = if prev > 0.0 { r / prev } else { 0.0 };
            report.contraction.push(q);
            if options.iteration == OuterIteration::Plain {
                self.high = if q >= 1.0 { self.high + 1 } else { 0 };
                if self.high >= 2 {
                    report.outer_residuals.push(r);
                    report.outer_iterations = k + 1;
                    return Err(DdError::NotContracting { step: k, q });
                }
            } else if !self.accelerated {
                self.high = if q >= 1.0 {
                    2
                } else if q > options.stagnation {
                    self.high + 1
                } else {
                    0
                };
                if self.high >= 2 && options.anderson_depth > 0 {
                    self.accelerated = true;
                    report.acceleration = Some(format!(
                        "Anderson mixing (depth {}) from outer step {k}: observed contraction {q:.3}",
                        options.anderson_depth
                    ));
                }
            }
        }
        report.outer_residuals.push(r);
        report.outer_iterations = k + 1;
        Ok(())
    }

    /// Switch to Newton steps when Anderson's best residual has not dropped by 10 % for
    /// [`STALL`] steps.
    fn watch_anderson(&mut self, k: usize, r: f64, report: &mut DdReport) {
        if !self.accelerated || self.newton {
            return;
        }
        if r < 0.9 * self.best {
            (self.best, self.best_k) = (r, k);
        } else if k >= self.best_k + STALL {
            self.newton = true;
            let note = format!(
                "; safeguarded semismooth Newton from outer step {k} (Anderson stagnated at {:.3e})",
                self.best
            );
            report
                .acceleration
                .get_or_insert_with(String::new)
                .push_str(&note);
        }
    }
}

/// The successive approximations U^k = T(U^{k−1}) from U⁰ (D05 4.37 / 6.1–6.3) with contraction
/// monitoring, Anderson mixing and Newton steps ([`Switches`]); returns the last iterate and
/// whether it converged.
fn outer(
    step: &mut Step,
    mut u: Vec<f64>,
    options: &DdOptions,
    report: &mut DdReport,
) -> Result<(Vec<f64>, bool), DdError> {
    let mut anderson = Anderson::new(options.anderson_depth, Shift::OfDiagonal(1e-10));
    let mut switches = Switches::new(options, report);
    let mut pcg2_tol = loosest_pcg2_tol(options);
    for k in 0..options.max_outer {
        let used = pcg2_tol;
        let tu = step.apply(&u, used)?;
        let diff: Vec<f64> = tu.iter().zip(&u).map(|(a, b)| a - b).collect();
        let r = norm(&diff);
        let scale = norm(&tu).max(f64::MIN_POSITIVE);
        switches.record_residual(k, r, options, report)?;
        pcg2_tol = forcing_tol(r, scale, options);
        match stop_test(r, scale, used, step, options) {
            Stop::Converged => return Ok((tu, true)),
            Stop::Tighten => {
                u = tu;
                pcg2_tol = options.pcg2_tol;
                continue;
            }
            Stop::Diverged => break,
            Stop::Continue => {}
        }
        switches.watch_anderson(k, r, report);
        let next = if switches.newton {
            step.newton(&u, pcg2_tol)?
        } else {
            None
        };
        u = match next {
            Some(v) => v,
            None if switches.accelerated => anderson.next(&u, &tu),
            None => tu,
        };
    }
    Ok((u, false))
}

/// Recovery at the converged trace `u`: the full reduced displacement (the trace, the interiors
/// of the non-contact subdomains by K_II u_I = f_I − K_IΓ u (D05 4.24) and those of the contact
/// clusters from one more local frictional solve, warm-started from `warm`) and the per-pair
/// multipliers.
fn recover(
    problem: &DdProblem,
    dec: &Decomposition,
    warm: &[Option<WarmStart>],
    u: &[f64],
    options: &DdOptions,
    report: &mut DdReport,
) -> Result<(Vec<f64>, Vec<[f64; 2]>), DdError> {
    let mut full = vec![0.0; problem.n_dofs()];
    for (&d, &v) in dec.interface.iter().zip(u) {
        full[d] = v;
    }
    let interiors: Vec<Vec<f64>> = dec
        .blocks
        .par_iter()
        .map(|b| b.interior(&gather(&b.gamma, u)))
        .collect();
    for (dofs, x) in dec.block_dofs.iter().zip(interiors) {
        for (&d, v) in dofs.interior.iter().zip(x) {
            full[d] = v;
        }
    }
    let mut multipliers = vec![[0.0; 2]; problem.pairs.len()];
    for (c, cl) in dec.clusters.iter().enumerate() {
        let state = cl
            .evaluate(&gather(&cl.gamma, u), warm[c].as_ref(), &options.qp)
            .map_err(|reason| DdError::Cluster { cluster: c, reason })?;
        for (&d, &v) in dec.cluster_dofs[c].interior.iter().zip(&state.interior) {
            full[d] = v;
        }
        for (i, &p) in dec.cluster_pairs[c].iter().enumerate() {
            multipliers[p] = [state.qp.x[normal_row(i)], state.qp.x[tangential_row(i)]];
        }
        report.floating_modes += state.qp.alpha.len();
    }
    Ok((full, multipliers))
}
