//! What a DD solve did (design §3.2 "Report per solve"): sizes, coarse dimensions, PCG1 / outer /
//! PCG2 iteration counts, Newton steps, the observed contraction factors q_k vs the theory's 2β² < 1 (D05 Thm
//! 7.1, FGCS 3.37), the a-priori error bound of D05 Cor. 7.1 / FGCS 3.38
//! ‖U^k − U‖ ≤ q^k / (1 − q) ‖U⁰ − U¹‖ with the observed q, checks (partition of unity, residual
//! orthogonality to the coarse spaces), acceleration / fallback, and times per phase. For a
//! frictionless problem the D03 form of the bound (Thm 4.1: 2λ²P_c < 1 over P_c contact
//! clusters) is reported too ([`D03Bound`]).
//!
//! Depends on [`super::options`] (the recorded variants), [`super::decomposition`] (sizes) and
//! [`super::DdProblem`]; filled in by [`super::successive`], which depends on it, not the
//! other way round.

use std::fmt;

use super::decomposition::Decomposition;
use super::options::{CoarseKind, OuterIteration, Pcg1Preconditioner, Weights};
use super::DdProblem;

/// Wall-clock seconds per phase.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Times {
    /// Partition, local assembly and factorisations, condensed contact operators.
    pub setup: f64,
    /// Auxiliary problem (coarse operator + PCG1).
    pub pcg1: f64,
    /// Successive approximations in total (`scon` and `pcg2` are parts of it).
    pub outer: f64,
    /// Of `outer`: the evaluations of the contact Schur operator S_CON.
    pub scon: f64,
    /// Of `outer`: PCG2, with the Newton steps' PCG.
    pub pcg2: f64,
    /// Interior and multiplier recovery.
    pub recovery: f64,
    /// The whole solve.
    pub total: f64,
}

/// D03 Thm 4.1 for a frictionless problem with P_c contact clusters: T contracts in the S0
/// energy norm with factor 2λ²P_c if every cluster's energy |R*_j U|²_{a*j} ≤ λ² ‖U‖²_Q with
/// λ < 1/√(2P_c), and ‖U^k − U‖ ≤ (2λ²P_c)^k / (1 − 2λ²P_c) ‖U⁰ − T U⁰‖. wsm does not compute λ
/// a priori; it reports the λ that the observed contraction factor q = 2λ²P_c implies.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct D03Bound {
    /// P_c: the contact clusters (D03's Ω*_j).
    pub clusters: usize,
    /// The theorem's sufficient condition λ < 1/√(2P_c).
    pub lambda_limit: f64,
    /// λ = √(q / (2P_c)) implied by the observed contraction factor q.
    pub lambda_observed: f64,
    /// (2λ²P_c)^k / (1 − 2λ²P_c) ‖U⁰ − U¹‖ at the last step k, with 2λ²P_c = q (Euclidean norm
    /// of the interface trace in place of the theorem's Q-norm).
    pub bound: f64,
}

/// Report of one DD solve.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct DdReport {
    /// Reduced DOFs of the whole problem.
    pub n_dofs: usize,
    /// Interface DOFs: the unknowns U of the interface problem.
    pub n_interface: usize,
    /// Subdomains of the partition.
    pub n_subdomains: usize,
    /// Contact subdomains: the thin bands around the contact zones and the floating bodies in
    /// contact.
    pub n_contact_subdomains: usize,
    /// Contact clusters: groups of contact subdomains linked by contact pairs, each one nonlinear
    /// local problem (D05 §4.1).
    pub n_clusters: usize,
    /// Contact node pairs.
    pub n_pairs: usize,
    /// The pairs tied in the auxiliary problem: those on the tied set Γc0 (D05 4.35,
    /// `solver.dd.tied_zones`) and the bilateral ones; `n_pairs` when Γc0 = Γc.
    pub n_tied_pairs: usize,
    /// Clusters whose auxiliary tie needed the tangential rows too (a sliding mode was left).
    pub auxiliary_full_stick: usize,
    /// The preconditioner PCG1 used.
    pub pcg1_preconditioner: Pcg1Preconditioner,
    /// The coarse space of all balancing preconditioners.
    pub coarse: CoarseKind,
    /// The injection weights ρ of the balancing preconditioners (D05 5.5).
    pub weights: Weights,
    /// The outer iteration (safeguarded, or the papers' plain successive approximations).
    pub iteration: OuterIteration,
    /// Whether every contact row is frictionless (D03's setting; the D03 bound applies).
    pub frictionless: bool,
    /// Dimension of the coarse space V_H of PCG1 after dropping dependent columns.
    pub coarse_dim_pcg1: usize,
    /// Dimension of the coarse space V_0H of PCG2 (S0) after dropping dependent columns.
    pub coarse_dim_pcg2: usize,
    /// PCG1 iterations of the auxiliary problem S U⁰ = F.
    pub pcg1_iterations: usize,
    /// Outer steps of the successive approximations (accelerated or Newton steps included).
    pub outer_iterations: usize,
    /// PCG2 iterations summed over all outer steps.
    pub pcg2_iterations: usize,
    /// PCG2 iterations of each outer step, in step order.
    pub pcg2_per_outer: Vec<usize>,
    /// ‖T(U^k) − U^k‖ per outer step (Euclidean norm of the interface trace).
    pub outer_residuals: Vec<f64>,
    /// q_k = r_k / r_{k−1}.
    pub contraction: Vec<f64>,
    /// Observed contraction factor q (largest of the last three q_k) when below 1.
    pub contraction_estimate: Option<f64>,
    /// Cor. 7.1 with the observed q: q^k / (1 − q) ‖U⁰ − U¹‖ at the last step.
    pub error_bound: Option<f64>,
    /// D03 Thm 4.1 with the observed q, for a frictionless problem whose unaccelerated
    /// iteration contracted.
    pub d03: Option<D03Bound>,
    /// max |Σ D_s R_s − 1| for PCG1 and PCG2 weights (D05 5.8, 6.6).
    pub partition_of_unity_error: [f64; 2],
    /// max |w_jᵀ r| / ‖b‖ over all PCG1 / PCG2 iterations (Lemma 5.1 / 6.1).
    pub coarse_residual: [f64; 2],
    /// Rigid modes of floating bodies handled inside the clusters.
    pub floating_modes: usize,
    /// QP iterations of the clusters' local contact problems (S_CON evaluations), summed over all
    /// outer steps.
    pub qp_iterations: usize,
    /// Safeguarded semismooth Newton steps taken after Anderson stagnated.
    pub newton_steps: usize,
    /// PCG iterations of the Newton steps in total.
    pub newton_pcg_iterations: usize,
    /// How the outer iteration was accelerated (Anderson mixing, then Newton steps) and from which
    /// step; `None` for the plain successive approximations.
    pub acceleration: Option<String>,
    /// Why the direct solver answered instead of DD; `None` when DD converged.
    pub fallback: Option<String>,
    /// Rayon threads available to the solve (the result does not depend on them).
    pub threads: usize,
    /// Wall-clock seconds per phase.
    pub times: Times,
}

impl DdReport {
    pub(crate) fn new(problem: &DdProblem, dec: &Decomposition) -> DdReport {
        DdReport {
            n_dofs: problem.n_dofs(),
            n_interface: dec.n_interface(),
            n_subdomains: dec.partition.n_subdomains,
            n_contact_subdomains: dec.partition.contact.iter().filter(|&&c| c).count(),
            n_clusters: dec.clusters.len(),
            n_pairs: problem.pairs.len(),
            n_tied_pairs: problem.pairs.iter().filter(|p| p.tied).count(),
            auxiliary_full_stick: dec.full_stick.iter().filter(|&&f| f).count(),
            frictionless: problem
                .pairs
                .iter()
                .all(|p| p.tangent.lower == 0.0 && p.tangent.upper == 0.0),
            threads: rayon::current_num_threads(),
            ..DdReport::default()
        }
    }

    /// Fill the contraction estimate and the Cor. 7.1 bound from the recorded steps.
    pub(crate) fn finish_contraction(&mut self) {
        let tail: Vec<f64> = self.contraction.iter().rev().take(3).copied().collect();
        let q = tail.iter().copied().fold(0.0, f64::max);
        if !tail.is_empty() && q < 1.0 && self.acceleration.is_none() {
            self.contraction_estimate = Some(q);
            let k = self.outer_residuals.len() as i32;
            if let Some(&r0) = self.outer_residuals.first() {
                let bound = q.powi(k) / (1.0 - q) * r0;
                self.error_bound = Some(bound);
                if self.frictionless && self.n_clusters > 0 {
                    let pc = self.n_clusters as f64;
                    self.d03 = Some(D03Bound {
                        clusters: self.n_clusters,
                        lambda_limit: 1.0 / (2.0 * pc).sqrt(),
                        lambda_observed: (q / (2.0 * pc)).sqrt(),
                        bound,
                    });
                }
            }
        }
    }
}

impl fmt::Display for DdReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "DD: {} DOFs, {} interface DOFs, {} subdomains ({} in contact, {} clusters, {} pairs), {} threads",
            self.n_dofs,
            self.n_interface,
            self.n_subdomains,
            self.n_contact_subdomains,
            self.n_clusters,
            self.n_pairs,
            self.threads
        )?;
        if self.n_tied_pairs < self.n_pairs {
            writeln!(
                f,
                "  auxiliary problem: the tied set Γc0 holds {} of the {} pairs (solver.dd.tied_zones)",
                self.n_tied_pairs, self.n_pairs
            )?;
        }
        writeln!(
            f,
            "  coarse dimension ({:?}): PCG1 {}, PCG2 {}; partition of unity error {:.1e} / {:.1e}; coarse residual {:.1e} / {:.1e}",
            self.coarse,
            self.coarse_dim_pcg1,
            self.coarse_dim_pcg2,
            self.partition_of_unity_error[0],
            self.partition_of_unity_error[1],
            self.coarse_residual[0],
            self.coarse_residual[1]
        )?;
        writeln!(
            f,
            "  iterations: PCG1 {} ({:?} preconditioner, {:?} weights), outer {} ({:?}), PCG2 total {} (paper, tunnel: 21 / 15 / 39); Newton steps {} ({} PCG iterations)",
            self.pcg1_iterations,
            self.pcg1_preconditioner,
            self.weights,
            self.outer_iterations,
            self.iteration,
            self.pcg2_iterations,
            self.newton_steps,
            self.newton_pcg_iterations
        )?;
        let qs: Vec<String> = self.contraction.iter().map(|q| format!("{q:.3}")).collect();
        writeln!(f, "  contraction q_k: [{}]", qs.join(", "))?;
        match (self.contraction_estimate, self.error_bound) {
            (Some(q), Some(b)) => writeln!(
                f,
                "  observed q = {q:.3} (theory: 2β² < 1); Cor. 7.1 bound q^k/(1−q)‖U⁰−U¹‖ = {b:.3e}"
            )?,
            _ => writeln!(
                f,
                "  no contraction estimate (accelerated or too few steps)"
            )?,
        }
        if let Some(d) = &self.d03 {
            writeln!(
                f,
                "  D03 Thm 4.1 (frictionless, P_c = {}): λ = √(q/2P_c) = {:.3} < 1/√(2P_c) = {:.3}; bound (2λ²P_c)^k/(1−2λ²P_c)‖U⁰−U¹‖ = {:.3e}",
                d.clusters, d.lambda_observed, d.lambda_limit, d.bound
            )?;
        }
        if self.auxiliary_full_stick > 0 {
            writeln!(
                f,
                "  auxiliary problem: {} cluster(s) tied in both directions (normal tie left a sliding mode)",
                self.auxiliary_full_stick
            )?;
        }
        if self.floating_modes > 0 {
            writeln!(
                f,
                "  floating-body modes fixed by contact inside clusters: {}",
                self.floating_modes
            )?;
        }
        if let Some(a) = &self.acceleration {
            writeln!(f, "  acceleration: {a}")?;
        }
        if let Some(fb) = &self.fallback {
            writeln!(f, "  FALLBACK: {fb}")?;
        }
        let t = &self.times;
        write!(
            f,
            "  times [s]: setup {:.3}, PCG1 {:.3}, outer {:.3} (S_CON {:.3}, PCG2 {:.3}), recovery {:.3}, total {:.3}",
            t.setup, t.pcg1, t.outer, t.scon, t.pcg2, t.recovery, t.total
        )
    }
}
