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
//! Robustness beyond the papers: the contraction factor q_k = ‖U^{k+1} − U^k‖ / ‖U^k − U^{k−1}‖
//! is measured every step (Thm 7.1 predicts q ≤ 2β² < 1); when q ≥ 1 or the iteration stagnates
//! (the contraction condition of Cor. 7.1 fails, e.g. long contact zones whose clusters are not
//! "small"), the interface equation S0 U + S_CON(U) = F is solved instead by a primal–dual
//! active-set (semismooth Newton) iteration: S_CON is linearised at the current local contact
//! solutions ([`super::pair::ContactCluster::linearised`]: closed/sticking rows tied, rows at a
//! bound carry their multiplier as a load) and the linear interface problem is solved by the
//! PCG1 machinery (balancing NN with the linearised clusters). It stops when the active set
//! repeats (then U is exact up to the PCG tolerance). If that fails too, the caller's direct
//! solver is used. Every such switch is recorded in the report.

use std::time::Instant;

use rayon::prelude::*;

use super::coarse::Balancing;
use super::decomposition::Decomposition;
use super::partition::{Partition, PartitionRequest};
use super::pcg::pcg;
use super::report::{DdReport, Times};
use super::{DdError, DdProblem};
use crate::contact::qp::{QpOptions, WarmStart};

/// Solver options.
#[derive(Debug, Clone)]
pub struct DdOptions {
    pub partition: PartitionRequest,
    /// Relative residual of PCG1 (auxiliary) and PCG2 (per outer step).
    pub pcg1_tol: f64,
    pub pcg2_tol: f64,
    pub max_pcg: usize,
    /// Stop when ‖U^k − U^{k−1}‖ ≤ outer_tol ‖U^k‖.
    pub outer_tol: f64,
    pub max_outer: usize,
    /// Switch to active-set Newton when q ≥ 1, or when q > `stagnation` twice in a row.
    pub stagnation: f64,
    /// Allow the active-set Newton recovery (false: plain successive approximations only).
    pub newton: bool,
    /// Active-set Newton from the first step (for tests and comparisons).
    pub force_acceleration: bool,
    pub qp: QpOptions,
}

impl Default for DdOptions {
    fn default() -> Self {
        DdOptions {
            partition: PartitionRequest::Automatic {
                subdomains: 12,
                contact_layers: super::partition::CONTACT_LAYERS,
            },
            pcg1_tol: 1e-10,
            pcg2_tol: 1e-12,
            max_pcg: 500,
            outer_tol: 1e-10,
            max_outer: 200,
            stagnation: 0.95,
            newton: true,
            force_acceleration: false,
            qp: QpOptions::default(),
        }
    }
}

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
    let mut report = DdReport::default();
    let mut setup = 0.0;
    let result = Partition::new(problem, &options.partition)
        .and_then(|partition| Decomposition::new(problem, partition))
        .and_then(|dec| {
            report = DdReport::new(problem, &dec);
            setup = t0.elapsed().as_secs_f64();
            iterate(problem, &dec, options, &mut report)
        });
    report.times.setup = setup;
    match result {
        Ok((u, multipliers, times)) => {
            report.times = Times {
                setup,
                total: t0.elapsed().as_secs_f64(),
                ..times
            };
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
    pcg2_iterations: Vec<usize>,
    newton_iterations: Vec<usize>,
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
        for ((cl, state), warm) in self.dec.clusters.iter().zip(states).zip(&mut self.warm) {
            for (&g, r) in cl.gamma.iter().zip(&state.reaction) {
                b[g] -= r;
            }
            self.qp_iterations += state.qp.iterations;
            *warm = Some(WarmStart::from(&state.qp));
        }
        self.scon_time += t.elapsed().as_secs_f64();
        Ok(b)
    }

    /// T(U): solve S0 V = F − S_CON(U) from V = U.
    fn apply(&mut self, u: &[f64]) -> Result<Vec<f64>, DdError> {
        let b = self.rhs(u)?;
        let t = Instant::now();
        let out = pcg(
            &self.s0,
            &b,
            u.to_vec(),
            self.options.pcg2_tol,
            self.options.max_pcg,
            "PCG2",
        )?;
        self.pcg2_time += t.elapsed().as_secs_f64();
        self.pcg2_iterations.push(out.iterations);
        self.coarse_residual = self.coarse_residual.max(out.coarse_residual);
        Ok(out.x)
    }
}

impl Step<'_> {
    /// One active-set Newton step from U: the clusters linearised at their local solutions for
    /// U (from [`Step::rhs`]), then (S0 + Σ linearised) V = F0 + Σ linearised loads by PCG.
    fn newton(&mut self, u: &[f64]) -> Result<Vec<f64>, DdError> {
        self.rhs(u)?;
        let t = Instant::now();
        let dec = self.dec;
        let linear: Vec<_> = dec
            .clusters
            .par_iter()
            .zip(&self.warm)
            .enumerate()
            .map(|(c, (cl, warm))| {
                let x = warm.as_ref().map(|w| w.x.as_slice()).unwrap_or_default();
                cl.linearised(
                    x,
                    dec.cluster_rho[c].clone(),
                    dec.cluster_candidates[c].as_ref(),
                )
                .map_err(|reason| DdError::Cluster { cluster: c, reason })
            })
            .collect::<Result<_, _>>()?;
        let mut b = self.f0.clone();
        for lb in &linear {
            for (&g, v) in lb.gamma.iter().zip(lb.condensed_load()) {
                b[g] += v;
            }
        }
        let op = Balancing::new(dec.blocks.iter().chain(&linear).collect(), b.len())?;
        let out = pcg(
            &op,
            &b,
            u.to_vec(),
            self.options.pcg1_tol,
            self.options.max_pcg,
            "PCG (active-set Newton)",
        )?;
        self.newton_iterations.push(out.iterations);
        self.pcg2_time += t.elapsed().as_secs_f64();
        Ok(out.x)
    }
}

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
    let s: Vec<_> = dec.blocks.iter().chain(&dec.tied).collect();
    let s_op = Balancing::new(s, n)?;
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
    let s0 = Balancing::new(dec.blocks.iter().collect(), n)?;
    report.coarse_dim_pcg2 = s0.coarse_dim();
    report.partition_of_unity_error[1] = s0.partition_of_unity_error();
    let mut step = Step {
        dec,
        s0,
        f0,
        options,
        warm: vec![None; dec.clusters.len()],
        pcg2_iterations: Vec::new(),
        newton_iterations: Vec::new(),
        coarse_residual: 0.0,
        qp_iterations: 0,
        scon_time: 0.0,
        pcg2_time: 0.0,
    };
    let mut u = first.x;
    let mut newton = options.force_acceleration && options.newton;
    if newton {
        report.acceleration = Some("active-set Newton from the first step (forced)".into());
    }
    let mut high = 0;
    let mut converged = false;
    for k in 0..options.max_outer {
        let mut switched = false;
        let tu = if newton {
            step.newton(&u)?
        } else {
            step.apply(&u)?
        };
        let diff: Vec<f64> = tu.iter().zip(&u).map(|(a, b)| a - b).collect();
        let r = norm(&diff);
        let scale = norm(&tu).max(f64::MIN_POSITIVE);
        if let Some(&prev) = report.outer_residuals.last() {
            let q = if prev > 0.0 { r / prev } else { 0.0 };
            report.contraction.push(q);
            if !newton {
                high = if q >= 1.0 {
                    2
                } else if q > options.stagnation {
                    high + 1
                } else {
                    0
                };
                if high >= 2 && options.newton {
                    newton = true;
                    switched = true;
                    report.acceleration = Some(format!(
                        "active-set Newton from outer step {k}: observed contraction {q:.3} (the contraction condition 2β² < 1 of D05 Cor. 7.1 fails)"
                    ));
                }
            }
        }
        report.outer_residuals.push(r);
        report.outer_iterations = k + 1;
        if r <= options.outer_tol * scale {
            u = tu;
            converged = true;
            break;
        }
        if !r.is_finite() {
            break;
        }
        // The step that revealed divergence is not taken: Newton starts from the last iterate.
        if !switched {
            u = tu;
        }
    }
    report.newton_pcg_iterations = step.newton_iterations.clone();
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
