//! Options of the DD solve (design §3.2 solver settings): the partition request, the PCG1
//! preconditioner (D05 §5 as printed or the reduced one of §6), the coarse space of the balancing
//! preconditioners (D05 5.11 / 6.7 kernels, or rigid-motion enrichment), tolerances and
//! iteration limits of PCG1 / PCG2 / the successive approximations (D05 4.37 / 6.1–6.3), the
//! injection weights ρ (D05 5.5), the tied set Γc0 of the auxiliary problem (D05 4.35), the outer iteration (wsm's safeguarded one or the papers' plain
//! successive approximations), Anderson acceleration and the local QP options.
//!
//! Depends only on [`super::partition`] and [`crate::contact::qp`]; read by
//! [`super::successive`] and recorded in [`super::report`].

use std::sync::Arc;

use super::partition::{PartitionRequest, CONTACT_LAYERS};
use super::subdomain::OperatorCache;
use crate::contact::qp::QpOptions;

/// Default PCG1 tolerance: the auxiliary solution U⁰ (D05 4.48) is only the start of the
/// successive approximations / Newton steps, whose result does not depend on it (tunnel: 84
/// instead of 136 PCG1 iterations against 1e-10, the same outer iterations).
pub const PCG1_TOL: f64 = 1e-6;

/// Which balancing preconditioner PCG1 uses for the tied auxiliary operator S = S0 + Σ S0^{kl}.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Pcg1Preconditioner {
    /// D05 §5 as printed: Neumann solves on the non-contact subdomains AND the tied contact
    /// clusters, ρ-weighted injections over all of them, coarse space with the cluster kernels.
    /// A contact cluster is a band along its whole contact zone; when the zone spans many
    /// subdomains the band's Neumann inverse (a long thin floating strip: compliance growing like
    /// (length / width)³ for bending) wrecks the condition number (two-block benchmark: 13 / 32 /
    /// 88 PCG1 iterations at 5 / 13 / 48 subdomains).
    Full,
    /// The reduced preconditioner of D05 §6 (injections D̊ with the cross-point fix, coarse space
    /// V_0H of the non-contact subdomains) on the full operator S with the S-orthogonal coarse
    /// projection. It is a balancing preconditioner for S0 ≤ S, so
    /// κ ≤ κ_BNN(S0) · λ_max(S0⁻¹ S) where λ_max − 1 is the energy ratio β² of D05 Assumption 7.1
    /// (contact bands against their neighbours): local, bounded in the subdomain count.
    #[default]
    Reduced,
}

/// The coarse space of the balancing preconditioners (PCG1, PCG2 and the Newton steps).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CoarseKind {
    /// D05 5.11 / 6.7: the weighted traces of the floating subdomains' kernels (the balancing
    /// minimum). A subdomain that touches the Dirichlet boundary along a short piece only is
    /// nearly floating; its soft rigid motions stay in the one-level part and the iteration
    /// count grows with the number of subdomains.
    Kernels,
    /// The weighted traces of the plane rigid motions of EVERY non-contact subdomain (which
    /// contain the kernels, so the balancing of D05 Lemma 5.1 / 6.1 still holds): piecewise
    /// rigid coarse functions at the subdomain scale, the classical remedy for nearly floating
    /// subdomains, 3 coarse unknowns per subdomain.
    #[default]
    Rigid,
}

/// The stiffness measure ρ_s of the injections D_s = diag(ρ_s / Σ_{t∋dof} ρ_t) (D05 5.5–5.8).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Weights {
    /// The mean diagonal of the subdomain's stiffness matrix (wsm's default; it follows the
    /// element size as well as the material).
    #[default]
    Stiffness,
    /// The area-weighted mean Young's modulus of the subdomain's elements, the papers' example
    /// (D05 5.5: "ρ … e.g. the average Young modulus").
    MeanYoung,
}

/// The outer iteration on S0 U + S_CON(U) = F.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OuterIteration {
    /// Successive approximations monitored by their contraction factor, switching to Anderson
    /// mixing and then safeguarded Newton steps when they do not contract (design §3.2).
    #[default]
    Safeguarded,
    /// The papers' plain successive approximations (D05 4.37 / 6.1, D03 (52)): no acceleration,
    /// no Newton steps; the solve stops with [`super::DdError::NotContracting`] as soon as the
    /// observed contraction factor is ≥ 1 on two consecutive steps.
    Plain,
}

/// Solver options.
#[derive(Debug, Clone)]
pub struct DdOptions {
    /// How the bodies are cut into subdomains (automatic by count or size, explicit, or reused).
    pub partition: PartitionRequest,
    /// The balancing preconditioner of PCG1 (default: the reduced one of D05 §6).
    pub pcg1_preconditioner: Pcg1Preconditioner,
    /// The coarse space of the balancing preconditioners (default: rigid-motion enrichment).
    pub coarse: CoarseKind,
    /// The stiffness measure ρ of the injections (default: mean stiffness diagonal).
    pub weights: Weights,
    /// The outer iteration (default: safeguarded; `Plain` ignores `anderson_depth`,
    /// `stagnation` and `force_acceleration`).
    pub iteration: OuterIteration,
    /// The tied set Γc0 of the auxiliary problem (D05 4.35): the contact zones (scene indices)
    /// whose rows are tied there; the other unilateral zones carry no traction in it. `None`:
    /// every zone (Γc0 = Γc). Bilateral rows are always tied.
    pub tied_zones: Option<Vec<usize>>,
    /// Relative residual of PCG1 (auxiliary problem). U⁰ only starts the outer iteration, so
    /// PCG1 need not be tight (`PCG1_TOL`).
    pub pcg1_tol: f64,
    /// Relative residual of PCG2 at full accuracy, the tightest of the inexact per-step
    /// tolerances (see `successive::FORCING`); convergence is accepted only after a step solved
    /// to it.
    pub pcg2_tol: f64,
    /// Iteration limit of every PCG run (PCG1, PCG2 and the Newton steps' PCG).
    pub max_pcg: usize,
    /// Stop when ‖U^k − U^{k−1}‖ ≤ outer_tol ‖U^k‖.
    pub outer_tol: f64,
    /// Limit on the outer steps of the successive approximations (including accelerated and Newton
    /// steps).
    pub max_outer: usize,
    /// Switch to Anderson acceleration when q ≥ 1, or when q > `stagnation` twice in a row.
    pub stagnation: f64,
    /// Anderson memory (0 disables acceleration).
    pub anderson_depth: usize,
    /// Always accelerate from the first step (for tests and comparisons).
    pub force_acceleration: bool,
    /// Options of the QP solver of the clusters' local contact problems.
    pub qp: QpOptions,
    /// Subdomain operators kept across solves of one scene (none: built every solve).
    pub operators: Option<Arc<OperatorCache>>,
}

impl Default for DdOptions {
    fn default() -> Self {
        DdOptions {
            partition: PartitionRequest::Automatic {
                subdomains: 12,
                contact_layers: CONTACT_LAYERS,
            },
            pcg1_preconditioner: Pcg1Preconditioner::Reduced,
            coarse: CoarseKind::Rigid,
            weights: Weights::Stiffness,
            iteration: OuterIteration::Safeguarded,
            tied_zones: None,
            pcg1_tol: PCG1_TOL,
            pcg2_tol: 1e-12,
            max_pcg: 500,
            outer_tol: 1e-10,
            max_outer: 200,
            stagnation: 0.95,
            anderson_depth: 20,
            force_acceleration: false,
            qp: QpOptions::default(),
            operators: None,
        }
    }
}
