//! Domain decomposition solver for multibody contact with Tresca friction: the papers' method
//! (D03, D05 §4–7, FGCS §3; design §3.2), written with matrices: Schur complements of local
//! stiffness matrices and Boolean interface restrictions (D05 4.24, 4.29–4.34).
//!
//! - `partition`: bodies → subdomains (automatic, or fixed by the scene); interfaces never cut a
//!   contact zone (D05 4.4), each contact zone's two subdomains form one nonlinear cluster (D05
//!   §4.1, D03 Ω*_j), kept small (FGCS Remark 3.1).
//! - `decomposition`: interface numbering, blocks and clusters built from a partition.
//! - `subdomain`: local matrices, Dirichlet factors of K_II (Schur complements S_i = K_ΓΓ −
//!   K_ΓI K_II⁻¹ K_IΓ, D05 4.24, formed densely once per block) and Neumann factors with the
//!   rigid-mode kernel pinned and projected out (D05 5.1–5.2; their trace map formed densely).
//! - `pair`: contact clusters — the tied auxiliary problem (D05 4.35–4.46, normal tie by
//!   master/slave elimination) and the frictional local problem S_CON (D05 4.27–4.28), condensed
//!   on the contact multipliers and solved by [`crate::contact::qp::solve_box_qp`].
//! - `dense`: sequential dense Cholesky and products (results independent of the thread count).
//! - `coarse`: balancing Neumann–Neumann preconditioner: injections D (D05 5.5–5.8), coarse space
//!   V_H (5.11), S-orthogonal projection (5.12–5.14), coarse start (5.15); the reduced variant D̊,
//!   V_0H for S0 (D05 6.4–6.8), also used for PCG1 by default, and the rigid-motion coarse
//!   enrichment that keeps the iteration counts bounded in the subdomain count
//!   ([`options::Pcg1Preconditioner`], [`options::CoarseKind`]).
//! - `coarse_space`: a coarse space W with A W and the factored G = Wᵀ A W: the A-orthogonal
//!   projection and the coarse start (D05 5.12–5.15), shared by `coarse`, `pcg` and
//!   `newton`.
//! - `pcg`: PCG1 / PCG2 (D05 §5, §6).
//! - `options`: solver options (partition request, PCG1 preconditioner, coarse space,
//!   tolerances, acceleration).
//! - `newton`: safeguarded semismooth Newton steps on S0 U + S_CON(U) = F for when the
//!   successive approximations do not contract (2β² ≥ 1) and Anderson mixing stagnates.
//! - `successive`: successive approximations S0 U^k = F − S_CON(U^{k−1}) (D05 4.37 / 6.1–6.3)
//!   with inexact warm-started PCG2, contraction monitoring (Thm 7.1, Cor 7.1; FGCS 3.37–3.38),
//!   Anderson acceleration, Newton steps (`newton`) and a direct fallback.
//! - `report`: iteration counts, coarse dimensions, contraction factors, error bound, times.
//! - `from_scene`: DD for a scene's elastic contact problem, the entry of the state layer
//!   (`solver.kind = "dd"`): options from the scene's solver settings, contact rows from the
//!   direct solver's geometry, the answer in the direct solver's form.
//! - `bench` (cargo feature `bench`): scalability tables for `wsm bench dd`.
//!
//! Everything works on the reduced DOF vector of [`crate::fem::ElasticProblem`] (free DOFs in the
//! rotated nodal bases); [`DdProblem::from_elastic`] builds the input from it.

#[cfg(feature = "bench")]
pub(crate) mod bench;
mod coarse;
mod coarse_space;
mod decomposition;
mod dense;
pub(crate) mod from_scene;
mod newton;
mod options;
mod pair;
mod partition;
mod pcg;
mod report;
pub(crate) mod subdomain;
mod successive;

use crate::fem::{ElasticCoefficients, ElasticProblem, FemError, Slot};
use crate::scene::law::bulk_and_shear;

pub use from_scene::{options as scene_options, solve_elastic};
pub use options::{CoarseKind, DdOptions, OuterIteration, Pcg1Preconditioner};
pub use partition::{Partition, PartitionRequest};
pub use report::{D03Bound, DdReport, Times as DdTimes};
pub use successive::{DdSolution, DirectAnswer};

/// One P1 triangle in the reduced basis: its nodes, the reduced index of each of its six DOFs
/// (node-major; `None` for prescribed DOFs) and its 6×6 stiffness in the same basis.
#[derive(Debug, Clone, PartialEq)]
pub struct DdElement {
    /// Mesh nodes of the triangle (indices into [`DdProblem::nodes`]).
    pub nodes: [usize; 3],
    /// Reduced DOF of each of the six local DOFs, node-major in the nodes' rotated bases; `None`
    /// for a prescribed DOF.
    pub dofs: [Option<usize>; 6],
    /// The 6×6 element stiffness in the same local order, prescribed DOFs included [Pa, i.e. N/m of
    /// force per m of displacement per unit thickness].
    pub matrix: [[f64; 6]; 6],
    /// Young's modulus of the element's material \[Pa\] (for the injection weights
    /// [`Weights::MeanYoung`]): E = G(3K − G)/K from the in-plane bulk and shear moduli K, G of
    /// [`bulk_and_shear`] (= μ(3λ + 2μ)/(λ + μ), exact for an isotropic material; an isotropic
    /// equivalent for an anisotropic one).
    pub young: f64,
    /// Area of the triangle \[m²\].
    pub area: f64,
}

/// One constraint row of a contact node pair: its multiplier x lies in [lower, upper] and the
/// primal term is the support function σ_[lower, upper](Σ entries·u − value) — a unilateral
/// normal ([0, ∞): Σ a_j u_j ≤ value), a Tresca tangential ([−g w, g w]: g w |Σ a_j u_j − value|),
/// a bilateral normal ((−∞, ∞)) or a frictionless tangential ([0, 0]).
#[derive(Debug, Clone, PartialEq)]
pub struct DdContactRow {
    /// (reduced DOF, coefficient).
    pub entries: Vec<(usize, f64)>,
    /// Right-hand side of the row \[m\]: the initial gap g0 (0 for a tangential row) minus the
    /// row's product with the prescribed displacements.
    pub value: f64,
    /// Lower bound of the multiplier [N/m]: 0 for a unilateral normal, −g w for a Tresca
    /// tangential, −∞ for a bilateral normal.
    pub lower: f64,
    /// Upper bound of the multiplier [N/m]: +∞ for a normal row, g w for a tangential one (0 when
    /// frictionless).
    pub upper: f64,
}

/// A contact pair with its normal and tangential rows: a node pair (node of body k, node of body
/// l), or a mortar row (slave node of body k, the master nodes of body l's combination
/// Σ_q M̂_pq u_q, design §2.4.1).
#[derive(Debug, Clone, PartialEq)]
pub struct DdContactPair {
    /// The mesh nodes of the rows: the node of body k first, then body l's side — one node for a
    /// node pair, the master nodes of the combination for a mortar row. The partition keeps them
    /// all inside one contact cluster (design §3.2).
    pub nodes: Vec<usize>,
    /// Normal row n·(u^k − u^l) with the non-penetration (or bilateral tie) bounds.
    pub normal: DdContactRow,
    /// Tangential row t·(u^k − u^l) with the Tresca bounds ±g w.
    pub tangent: DdContactRow,
    /// Whether the pair lies on the tied set Γc0 of the auxiliary problem (D05 4.35); the other
    /// pairs carry no traction there.
    pub tied: bool,
}

/// The discrete contact problem min ½uᵀKu − fᵀu + Σ_rows σ(B_r u − e_r), K = Σ_e K_e.
#[derive(Debug, Clone)]
pub struct DdProblem {
    /// Node coordinates `[x, y]` \[m\] of the mesh.
    pub nodes: Vec<[f64; 2]>,
    /// Body index of each node.
    pub node_body: Vec<usize>,
    /// Every triangle of the mesh with its reduced DOFs and element stiffness.
    pub elements: Vec<DdElement>,
    /// Node and global direction (unit vector) of each reduced DOF.
    pub dof_node: Vec<usize>,
    /// Global unit direction of each reduced DOF (an axis of its node's rotated basis).
    pub dof_direction: Vec<[f64; 2]>,
    /// Reduced right-hand side (loads minus the lifting of prescribed values).
    pub rhs: Vec<f64>,
    /// Contact node pairs with their normal and tangential rows, in the direct solver's pair order.
    pub pairs: Vec<DdContactPair>,
    /// Bodies whose supports leave rigid motions free (held only by contact).
    pub floating_bodies: Vec<usize>,
}

impl DdProblem {
    /// Number of reduced DOFs.
    pub fn n_dofs(&self) -> usize {
        self.rhs.len()
    }

    /// Body of element `e`.
    pub fn element_body(&self, e: usize) -> usize {
        self.node_body[self.elements[e].nodes[0]]
    }

    /// Build the input from an elasticity problem, its zone coefficients [λ_z, μ_z], the reduced
    /// right-hand side and the contact rows (from the contact assembly).
    pub fn from_elastic(
        problem: &ElasticProblem,
        coefficients: &[ElasticCoefficients],
        rhs: Vec<f64>,
        pairs: Vec<DdContactPair>,
    ) -> Result<DdProblem, DdError> {
        let mesh = problem.mesh();
        let dofs = problem.dofs();
        if rhs.len() != dofs.n_free() {
            return Err(DdError::Input(format!(
                "right-hand side has {} entries, the problem {} free DOFs",
                rhs.len(),
                dofs.n_free()
            )));
        }
        let mut elements = Vec::with_capacity(mesh.triangles.len());
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let (slots, matrix) = problem.element_matrix(t, coefficients)?;
            let dofs = slots.map(|s| match s {
                Slot::Free(i) => Some(i),
                Slot::Fixed(_) => None,
            });
            let (bulk, shear) = bulk_and_shear(&coefficients[mesh.triangle_zone[t]]);
            let [a, b, c] = tri.map(|n| mesh.nodes[n]);
            let area = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs();
            elements.push(DdElement {
                nodes: *tri,
                dofs,
                matrix,
                young: shear * (3.0 * bulk - shear) / bulk,
                area,
            });
        }
        let mut dof_node = vec![0; dofs.n_free()];
        let mut dof_direction = vec![[0.0; 2]; dofs.n_free()];
        for node in 0..mesh.nodes.len() {
            let basis = dofs.basis(node);
            for (slot, dir) in dofs.slots(node).into_iter().zip(basis) {
                if let Slot::Free(i) = slot {
                    dof_node[i] = node;
                    dof_direction[i] = dir;
                }
            }
        }
        let n = rhs.len();
        for p in &pairs {
            for row in [&p.normal, &p.tangent] {
                if row.entries.iter().any(|&(d, _)| d >= n) || row.lower > row.upper {
                    return Err(DdError::Input(format!(
                        "contact pair at nodes {:?}: row with a DOF out of range or empty bounds",
                        p.nodes
                    )));
                }
            }
        }
        Ok(DdProblem {
            nodes: mesh.nodes.clone(),
            node_body: mesh.node_body.clone(),
            elements,
            dof_node,
            dof_direction,
            rhs,
            pairs,
            floating_bodies: problem.floating_bodies().to_vec(),
        })
    }
}

/// Errors of the DD solver; each says which part failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DdError {
    /// Inconsistent input (vector sizes, contact rows with a DOF out of range or empty bounds), or
    /// an I/O error of the bench tables.
    #[error("invalid DD input: {0}")]
    Input(String),
    /// The partition breaks a rule: wrong length, an empty subdomain or one spanning two bodies, or
    /// an interface that cuts a contact zone.
    #[error("partition: {0}")]
    Partition(String),
    /// A local factorisation (Dirichlet or Neumann) of one subdomain failed.
    #[error("subdomain {subdomain}: {reason}")]
    Subdomain {
        /// Index of the subdomain in the partition.
        subdomain: usize,
        /// What the local factorisation reported.
        reason: String,
    },
    /// The local problem of one contact cluster could not be assembled or solved.
    #[error("contact cluster {cluster}: {reason}")]
    Cluster {
        /// Index of the contact cluster in the decomposition.
        cluster: usize,
        /// What the cluster's assembly or QP solve reported.
        reason: String,
    },
    /// The coarse space is degenerate: an interface DOF in no block, or WᵀSW singular.
    #[error("coarse problem: {0}")]
    Coarse(String),
    /// A PCG or the successive approximations stopped short of the tolerance (iteration limit or
    /// a PCG breakdown).
    #[error(
        "{solver} did not converge: relative residual {residual:.3e} after {iterations} iterations"
    )]
    NotConverged {
        /// The iteration that stopped: `PCG1`, `PCG2` or `successive approximations`.
        solver: &'static str,
        /// Iterations done when it stopped.
        iterations: usize,
        /// Relative residual reached: ‖r‖/‖b‖ for a PCG, ‖T(U) − U‖/‖U‖ for the successive
        /// approximations.
        residual: f64,
    },
    /// The successive approximations failed (no convergence or a cluster failure) and no direct
    /// fallback was given.
    #[error("successive approximations failed ({reason}) and no direct fallback was given")]
    Diverged {
        /// The error of the failed iteration.
        reason: String,
    },
    /// The plain successive approximations ([`OuterIteration::Plain`]) do not contract: the
    /// observed factor q_k = ‖U^{k+1} − U^k‖ / ‖U^k − U^{k−1}‖ was ≥ 1 on two consecutive steps,
    /// so the contraction condition of D05 Thm 7.1 (2β² < 1) / D03 Thm 4.1 (2λ²P_c < 1) fails.
    #[error("successive approximations not contracting: observed contraction q = {q:.3} ≥ 1 at outer step {step} (D05 Thm 7.1 needs q ≤ 2β² < 1); the papers' plain iteration does not converge on this problem")]
    NotContracting {
        /// Outer step at which non-contraction was declared.
        step: usize,
        /// The last observed contraction factor.
        q: f64,
    },
    /// The direct fallback was tried after a DD failure and failed as well.
    #[error("direct fallback failed: {0}")]
    Fallback(String),
    /// An error of the FEM layer (element matrices, zone coefficients, assembly).
    #[error(transparent)]
    Fem(#[from] FemError),
}

#[cfg(test)]
mod tests;
