//! What one state solve returns: fields, contact results with their KKT residuals, criteria
//! values and the solver report.

use serde::Serialize;

use crate::contact::coulomb::CoulombReport;
use crate::contact::direct::ContactSolution;
use crate::contact::pairs::{normal_row, tangential_row, ContactGeometry};
use crate::contact::qp::WarmStart;
use crate::fem::ElementStress;
use crate::scene::{Contact, ContactKind, Data};

/// Contact status of a node pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, utoipa::ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum ContactState {
    /// No normal force: the pair is separated or just touching (JSON `"open"`).
    Open,
    /// In contact with |tangential force| below the slip bound g w (Coulomb: F × normal force):
    /// no relative slip (JSON `"stick"`).
    Stick,
    /// In contact at the slip limit, or without friction (g = 0, and every bilateral pair): the
    /// pair may slip (JSON `"slip"`).
    Slip,
}

/// Results at one contact node pair.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct ContactNode {
    /// Index of the contact zone in the scene's `contacts` list.
    pub zone: usize,
    /// Undeformed position of the pair's nodes (x, y) \[m\].
    pub position: [f64; 2],
    /// Normal contact pressure \[Pa\] (≥ 0 in unilateral contact).
    pub pressure: f64,
    /// Tangential contact stress \[Pa\] along the tangent t = (−n_y, n_x).
    pub shear: f64,
    /// Normal separation \[m\] (≥ 0; 0 when closed).
    pub gap: f64,
    /// Relative tangential displacement t·(u^k − u^l) \[m\].
    pub slip: f64,
    /// The friction bound on |shear| \[Pa\]: the slip limit g (Tresca) or F × pressure
    /// (Coulomb); 0 where the pair is frictionless (g = 0, bilateral, or open under Coulomb).
    pub bound: f64,
    /// Open, stick or slip, by the multipliers and the friction bound.
    pub state: ContactState,
}

/// KKT residuals of the contact solution, each relative (forces to the largest multiplier,
/// displacements to the largest nodal displacement).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct ContactKkt {
    /// Largest penetration (B u)_n − g0 > 0 of a unilateral pair, or |(B u)_n − g0| of a
    /// bilateral one.
    pub penetration: f64,
    /// Largest negative normal force of a unilateral pair.
    pub negative_pressure: f64,
    /// Largest excess of |λ_t| over the slip bound g w (Tresca) or F λ_n (Coulomb).
    pub friction_excess: f64,
    /// Largest product |λ_n| · |(B u)_n − g0| of a unilateral pair (Signorini complementarity).
    pub complementarity: f64,
    /// Stick/slip consistency (Tresca and Coulomb): the largest slip of a sticking pair, or slip
    /// along its tangential force of a pair at the limit.
    pub stick_slip: f64,
    /// ‖K u − f + Bᵀλ‖ / ‖f‖.
    pub equilibrium: f64,
}

impl ContactKkt {
    /// The largest residual.
    pub fn max(&self) -> f64 {
        [
            self.penetration,
            self.negative_pressure,
            self.friction_excess,
            self.complementarity,
            self.stick_slip,
            self.equilibrium,
        ]
        .into_iter()
        .fold(0.0, f64::max)
    }
}

/// Timings \[s\] of the phases of a solve.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Timings {
    /// The temperature field: the heat solve, or its reuse from the memo.
    pub heat: f64,
    /// Loads, prescribed values and the right-hand side.
    pub assembly: f64,
    /// The stiffness factor with C (zero when it was reused whole).
    pub factor: f64,
    /// Of `factor`: numeric factorisations of the body blocks with their shares of C.
    pub numeric: f64,
    /// Of `factor`: assembly of C and the floating-body projection.
    pub hessian: f64,
    /// The contact solve (direct: condensation, QP, recovery; DD: the whole DD solve).
    pub contact: f64,
    /// Of `contact`: the QP (direct solver).
    pub qp: f64,
    /// Of `contact` (DD): local factorisations and condensed contact operators.
    pub dd_setup: f64,
    /// Of `contact` (DD): the auxiliary problem (coarse operator and PCG1).
    pub dd_pcg1: f64,
    /// Of `contact` (DD): the successive approximations (S0 coarse operator, S_CON
    /// evaluations, PCG2 and Newton PCG).
    pub dd_outer: f64,
    /// Of `contact` (DD): recovery of the subdomain interiors.
    pub dd_recovery: f64,
    /// Contact results, stresses and criteria.
    pub post: f64,
    /// The sensitivities of the criteria (when requested).
    pub sensitivities: f64,
    /// The whole solve, heat to criteria.
    pub total: f64,
}

impl Timings {
    /// Add `other` phase by phase.
    pub fn add(&mut self, other: &Timings) {
        self.heat += other.heat;
        self.assembly += other.assembly;
        self.factor += other.factor;
        self.numeric += other.numeric;
        self.hessian += other.hessian;
        self.contact += other.contact;
        self.qp += other.qp;
        self.dd_setup += other.dd_setup;
        self.dd_pcg1 += other.dd_pcg1;
        self.dd_outer += other.dd_outer;
        self.dd_recovery += other.dd_recovery;
        self.post += other.post;
        self.sensitivities += other.sensitivities;
        self.total += other.total;
    }
}

/// The inner solver that answered a solve (serialised as the readable names of the reports).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub enum SolverUsed {
    /// The direct solver on its dense contact path (design §3.1).
    #[default]
    #[serde(rename = "direct")]
    Direct,
    /// The direct solver on its sparse contact path (design §3.1).
    #[serde(rename = "direct (sparse contact)")]
    DirectSparse,
    /// The domain-decomposition solver (design §3.2).
    #[serde(rename = "dd")]
    Dd,
    /// The direct solver because DD could not answer (the report's warning says why).
    #[serde(rename = "direct (DD unavailable)")]
    DirectDdUnavailable,
}

impl SolverUsed {
    /// The name in reports.
    pub fn as_str(self) -> &'static str {
        match self {
            SolverUsed::Direct => "direct",
            SolverUsed::DirectSparse => "direct (sparse contact)",
            SolverUsed::Dd => "dd",
            SolverUsed::DirectDdUnavailable => "direct (DD unavailable)",
        }
    }
}

impl std::fmt::Display for SolverUsed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The solver report of one solve.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SolveReport {
    /// The solver that answered.
    pub solver: SolverUsed,
    /// Mesh nodes (a contact node counted once per body).
    pub nodes: usize,
    /// Mesh triangles.
    pub triangles: usize,
    /// Unknowns of the elastic problem (free displacement DOFs).
    pub unknowns: usize,
    /// Contact node pairs over all contact zones.
    pub contact_pairs: usize,
    /// Rigid motions of floating bodies fixed by contact (semi-coercive case).
    pub floating_modes: usize,
    /// Rigid motions that contact does not determine (reported with no displacement component
    /// along the motions no contact row sees).
    pub undetermined_modes: usize,
    /// Semismooth Newton steps of the contact QP (direct solver).
    pub qp_iterations: usize,
    /// MPRGP iterations of the contact QP in phase 1 and in the fallback (direct solver).
    pub qp_fallback_iterations: usize,
    /// Variables that changed active-set status over the Newton steps (direct solver).
    pub active_set_changes: usize,
    /// Active-set steps of the direct solver's sparse contact path (each one sparse
    /// factorisation; 0 on the dense path).
    pub sparse_steps: usize,
    /// KKT residuals of the contact solution (all zero without contact).
    pub kkt: ContactKkt,
    /// The Coulomb fixed point: steps, last relative change and contraction estimate (only
    /// with a Coulomb zone).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coulomb: Option<CoulombReport>,
    /// The stiffness factorisation was reused from an earlier solve with the same λ, μ.
    pub reused_factorisation: bool,
    /// Data directions whose derivatives the adjoint gave (design §4.3); the others were taken
    /// by the forward tangent, one-sided where the contact state is not differentiable.
    pub adjoint_directions: usize,
    /// Parts of the computation skipped because nothing needed them.
    pub skipped: Vec<String>,
    /// Messages for the user (e.g. undetermined rigid motions, near-incompressibility); a solve
    /// through the front door (`run::solve`) puts the scene's warnings first
    /// (`scene::warnings`: implausible magnitudes, data addressed by the index of a named entry).
    pub warnings: Vec<crate::scene::Warning>,
    /// Solver-specific details (DD iteration counts etc.).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dd: Option<Box<crate::dd::DdReport>>,
    /// Wall time of each phase of the solve \[s\].
    pub timings: Timings,
}

/// One state solution.
#[derive(Debug, Clone, Default)]
pub struct Solution {
    /// Nodal displacement (empty when the elastic problem was not needed).
    pub displacement: Vec<[f64; 2]>,
    /// Nodal temperature (when solved).
    pub temperature: Option<Vec<f64>>,
    /// Element strains and stresses (empty when not needed).
    pub stresses: Vec<ElementStress>,
    /// Results per contact node pair, in the order of the contact geometry's pairs.
    pub contact: Vec<ContactNode>,
    /// Contact multipliers and rigid amplitudes, to warm-start a nearby solve.
    pub warm_start: Option<WarmStart>,
    /// Φ1..Φ6 (None when not requested or not defined for the scene): the largest of each Φ's
    /// `region_values`.
    pub criteria: super::PerCriterion<Option<f64>>,
    /// Per Φ, the value of each region of its family (`state::family`; empty where Φ is not
    /// defined or its field was not solved).
    pub region_values: super::PerCriterion<Vec<f64>>,
    /// Per Φ and region of a dynamic scene's criteria over time: the first time its value
    /// reaches its maximum (empty for a static solve).
    pub peak_times: super::PerCriterion<Vec<f64>>,
    /// Per requested stencil (parameter), the one-sided derivatives of Φ1..Φ6
    /// ([`StateProblem::solve_with_sensitivities`]; empty when none were requested or they
    /// could not be computed, with a warning).
    ///
    /// [`StateProblem::solve_with_sensitivities`]: super::StateProblem::solve_with_sensitivities
    pub sensitivities: super::Sensitivities,
    /// Per requested stencil, the derivatives of the region values that tie for a maximum or
    /// that criteria bound to one region read.
    pub region_sensitivities: super::RegionSensitivities,
    /// Sizes, iterations, residuals, warnings and timings of the solve.
    pub report: SolveReport,
}

/// Per-pair results and the KKT residuals of a contact solution.
pub(crate) fn contact_results(
    geometry: &ContactGeometry,
    sol: &ContactSolution,
    data: &Data,
    positions: &[[f64; 2]],
    displacement_scale: f64,
) -> (Vec<ContactNode>, ContactKkt) {
    let lam = &sol.multipliers;
    let force_scale = lam
        .iter()
        .fold(0.0_f64, |m, x| m.max(x.abs()))
        .max(f64::MIN_POSITIVE);
    let u_scale = displacement_scale.max(f64::MIN_POSITIVE);
    let mut kkt = ContactKkt {
        equilibrium: sol.equilibrium_residual,
        ..ContactKkt::default()
    };
    let mut nodes = Vec::with_capacity(geometry.pairs.len());
    // The friction bounds g w (Tresca) or F λ_n (Coulomb, at the solution's normal forces).
    let (_, upper) = geometry.bounds(data, Some(lam));
    // A Coulomb bound F λ_n is known to the fixed point's last relative change of λ (rounding
    // for the direct solver, the steps' accuracy for DD).
    let normal_accuracy = sol.coulomb.map_or(0.0, |c| c.residual) * force_scale;
    for (m, p) in geometry.pairs.iter().enumerate() {
        let (n, t) = (normal_row(m), tangential_row(m));
        let (ln, lt) = (lam[n], lam[t]);
        let (wn, wt) = (sol.gaps[n], sol.gaps[t]);
        let bound = upper[t];
        let coefficient = data.friction.get(p.zone).copied().flatten().unwrap_or(0.0);
        let sticking = lt.abs() < bound * (1.0 - 1e-9) - coefficient * normal_accuracy;
        if !p.bilateral {
            kkt.penetration = kkt.penetration.max(wn.max(0.0) / u_scale);
            kkt.negative_pressure = kkt.negative_pressure.max((-ln).max(0.0) / force_scale);
            kkt.complementarity = kkt
                .complementarity
                .max((ln.abs() / force_scale) * (wn.abs() / u_scale));
        } else {
            kkt.penetration = kkt.penetration.max(wn.abs() / u_scale);
        }
        kkt.friction_excess = kkt
            .friction_excess
            .max((lt.abs() - bound).max(0.0) / force_scale);
        // Tresca: a pair below its slip limit does not slip; at the limit it slips along its
        // multiplier (open pairs included: g acts regardless of the normal force). g = 0 is free.
        // Coulomb: the same with the bound F λ_n (an open pair is free).
        let stick_slip = if bound == 0.0 {
            0.0
        } else if sticking {
            wt.abs() / u_scale
        } else {
            (-(lt.signum() * wt)).max(0.0) / u_scale
        };
        kkt.stick_slip = kkt.stick_slip.max(stick_slip);
        let w = p.weight.max(f64::MIN_POSITIVE);
        let open = ln.abs() <= 1e-12 * force_scale && !p.bilateral;
        nodes.push(ContactNode {
            zone: p.zone,
            position: positions[p.nodes[0]],
            pressure: ln / w,
            shear: lt / w,
            gap: (-wn).max(0.0),
            slip: wt,
            bound: bound / w,
            state: if open {
                ContactState::Open
            } else if sticking {
                ContactState::Stick
            } else {
                ContactState::Slip
            },
        });
    }
    (nodes, kkt)
}

/// Resultants and statistics of one contact zone.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct ZoneSummary {
    /// The contact zone's name.
    pub name: String,
    /// Σ normal force / Σ nodal length \[Pa\].
    pub mean_pressure: f64,
    /// Largest nodal contact pressure of the zone \[Pa\].
    pub max_pressure: f64,
    /// Resultant normal force, Σ pressure × nodal length \[N/m\].
    pub normal_force: f64,
    /// Resultant tangential force, Σ shear × nodal length \[N/m\].
    pub tangential_force: f64,
    /// Node pairs of the zone that are open.
    pub open: usize,
    /// Node pairs of the zone that stick.
    pub stick: usize,
    /// Node pairs of the zone that slip.
    pub slip: usize,
    /// The zone's friction law: `bilateral` (tied normal, frictionless), `frictionless`
    /// (unilateral, g = 0), `tresca` (a given slip limit) or `coulomb` (|τ_t| ≤ F τ_n).
    pub friction_law: String,
    /// Tresca: the smallest and the largest slip limit g over the zone \[Pa\] (equal for a
    /// constant g), in the solve's data.
    pub slip_limit: Option<[f64; 2]>,
    /// Coulomb: the friction coefficient F \[-\] in the solve's data.
    pub friction_coefficient: Option<f64>,
}

/// Per contact zone: mean and peak pressure, resultants and state counts.
pub fn zone_summaries(
    contacts: &[Contact],
    data: &Data,
    geometry: &ContactGeometry,
    nodes: &[ContactNode],
) -> Vec<ZoneSummary> {
    contacts
        .iter()
        .enumerate()
        .map(|(z, contact)| {
            let coefficient = data.friction.get(z).copied().flatten();
            let slip_limit = data.slip.get(z).map(|g| {
                g.values
                    .iter()
                    .fold([f64::INFINITY, f64::NEG_INFINITY], |r, &v| {
                        [r[0].min(v), r[1].max(v)]
                    })
            });
            let friction_law = if contact.kind == ContactKind::Bilateral {
                "bilateral"
            } else if coefficient.is_some() {
                "coulomb"
            } else if slip_limit.is_some_and(|[_, hi]| hi > 0.0) {
                "tresca"
            } else {
                "frictionless"
            };
            let mut s = ZoneSummary {
                name: contact.name.clone(),
                mean_pressure: 0.0,
                max_pressure: 0.0,
                normal_force: 0.0,
                tangential_force: 0.0,
                open: 0,
                stick: 0,
                slip: 0,
                friction_law: friction_law.to_string(),
                slip_limit: slip_limit.filter(|_| friction_law == "tresca"),
                friction_coefficient: coefficient,
            };
            let mut length = 0.0;
            for (c, p) in nodes
                .iter()
                .zip(&geometry.pairs)
                .filter(|(c, _)| c.zone == z)
            {
                s.normal_force += c.pressure * p.weight;
                s.tangential_force += c.shear * p.weight;
                s.max_pressure = s.max_pressure.max(c.pressure);
                length += p.weight;
                match c.state {
                    ContactState::Open => s.open += 1,
                    ContactState::Stick => s.stick += 1,
                    ContactState::Slip => s.slip += 1,
                }
            }
            s.mean_pressure = if length > 0.0 {
                s.normal_force / length
            } else {
                0.0
            };
            s
        })
        .collect()
}

/// The contact pair of each of the `n_nodes` mesh nodes (the last pair that lists it; `None` off
/// the contact zones).
pub(crate) fn pair_of_node(geometry: &ContactGeometry, n_nodes: usize) -> Vec<Option<usize>> {
    let mut pair = vec![None; n_nodes];
    for (m, p) in geometry.pairs.iter().enumerate() {
        for node in p.nodes {
            pair[node] = Some(m);
        }
    }
    pair
}

/// The mean of a contact traction over a boundary piece as a form on the multipliers: (row,
/// coefficient) with the traction λ_row / w of [`contact_results`] (`pressure` the normal rows,
/// else the tangential ones) and the piece's P1 trace weights, the form of
/// [`piece_pressures`]. `None` when a node of the piece is in no contact pair.
pub(crate) fn piece_traction_rows(
    piece: &crate::regions::PieceRegion,
    geometry: &ContactGeometry,
    pair: &[Option<usize>],
    pressure: bool,
) -> Option<Vec<(usize, f64)>> {
    piece
        .node_weights
        .iter()
        .map(|&(i, w)| {
            let m = pair[i]?;
            let row = if pressure {
                normal_row(m)
            } else {
                tangential_row(m)
            };
            Some((row, w / geometry.pairs[m].weight.max(f64::MIN_POSITIVE)))
        })
        .collect()
}

/// Mean contact pressure over each boundary piece G'_r that lies on a contact segment (the P1
/// trace of the nodal pressures; design §4.2, the contact-pressure form of Φ6). `None` for pieces
/// off the contact zones.
pub fn piece_pressures(
    pieces: &[crate::regions::PieceRegion],
    geometry: &ContactGeometry,
    nodes: &[ContactNode],
    n_nodes: usize,
) -> Vec<(String, Option<f64>)> {
    let pressure: Vec<Option<f64>> = pair_of_node(geometry, n_nodes)
        .into_iter()
        .map(|m| m.and_then(|m| nodes.get(m)).map(|c| c.pressure))
        .collect();
    pieces
        .iter()
        .map(|piece| {
            let mean = piece
                .node_weights
                .iter()
                .map(|&(i, w)| pressure[i].map(|p| w * p))
                .sum::<Option<f64>>();
            (piece.name.clone(), mean)
        })
        .collect()
}

impl Solution {
    /// The value of a requested criterion (`None` where not computed).
    pub fn value(&self, target: super::Target) -> Option<f64> {
        let c = target.criterion as usize;
        match target.region {
            None => self.criteria[c],
            Some(r) => self.region_values[c].get(r).copied(),
        }
    }

    /// The one-sided derivative of a requested criterion along the `j`-th stencil's parameter
    /// (`None` where not computed).
    pub fn derivative(&self, target: super::Target, j: usize) -> Option<super::OneSided> {
        let c = target.criterion as usize;
        match target.region {
            None => self.sensitivities.get(j)?[c],
            Some(r) => self.region_sensitivities.get(j)?[c]
                .get(r)
                .copied()
                .flatten(),
        }
    }
}
