//! Finite elements: P1 triangles, plane-strain anisotropic elasticity with thermal stress, and
//! stationary anisotropic heat (design §2, §2.4, §3.1, §3.3).
//!
//! - [`ElasticProblem`]: a(u, v) = Σ_z ∫ e(v)ᵀ D_z e(u) and
//!   S(v, T) = Σ ∫ F·v + ∫_{Γτ} P·v + Σ ∫ (T − T0) β·e(v) (FGCS 2.7′, 2.13', 2.16; D05 Def. 2.1, §3),
//!   Dirichlet components and rollers in any direction through rotated nodal DOFs ([`DofMap`]).
//! - [`HeatProblem`]: Σ_z ∫ ∇wᵀ κ_z ∇T = Σ_z ∫ W_z w + ∫ q w ds, perfect thermal contact
//!   (FGCS problem P1).
//! - Both are a [`ZonedOperator`]: per-zone matrices on one pattern, re-assembled by a linear
//!   combination, factorised by faer Cholesky on a symbolic analysis computed once ([`Factor`]).
//! - [`stress`]: element stresses τ11, τ22, τ12, τ33 and I2²; reactions K u − f.
//! - [`rigid`]: floating bodies and their rigid-motion kernels (design §2.3).
//! - [`MixedOperator`]: the MINI u–p element for nearly incompressible zones (design §2.7).
//!
//! Typical use: `let p = ElasticProblem::new(&mesh, &data)?; let k = p.factor(&data, Par::Seq)?;
//! let u = p.solve(&k, &data, None)?;` and for a new data set only `factor` and `solve` again.

#[cfg(feature = "bench")]
pub(crate) mod bench;
mod dofs;
mod elasticity;
mod element_matrices;
mod geometry;
mod heat;
mod hydrostatic;
mod linear;
mod mixed;
mod operator;
pub mod rigid;
pub mod stress;
pub mod stress_measures;

pub use dofs::DofMap;
pub use elasticity::ElasticProblem;
pub(crate) use elasticity::MixedThermalRate;
pub use geometry::{segment_node_normals, TriangleGradients};
pub use heat::HeatProblem;
pub use linear::{symmetric_apply, Factor, Symbolic};
pub use operator::{OperatorFactor, Slot};
pub use rigid::RigidModes;
pub use stress::ElementStress;

pub use faer::Par;

/// Zone coefficients of the elastic operator: the six independent entries (d11, d12, d13, d22,
/// d23, d33) of the zone's plane-strain stiffness D ([`crate::scene::law::ENTRIES`]).
pub type ElasticCoefficients = [f64; 6];

/// Zone coefficients of the heat operator: the conductivity (κ11, κ12, κ22).
pub type HeatCoefficients = [f64; 3];

/// Errors of the FEM layer; each names what is wrong in the user's data.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FemError {
    /// A body's displacement and roller conditions leave rigid motions free, so K_ff cannot be
    /// factorised without contact (design §2.3).
    #[error("body '{name}' (index {body}) is floating: its displacement and roller conditions do not remove all rigid motions")]
    FloatingBody {
        /// Index of the body in the mesh.
        body: usize,
        /// The body's name in the scene.
        name: String,
    },
    /// The conditions meeting at one node disagree: two different prescribed temperatures, or
    /// a displacement along a direction that the other conditions already fix to another value.
    #[error("conflicting conditions at node {node} ({x}, {y}): {reason}")]
    ConflictingConstraints {
        /// Index of the node in the mesh.
        node: usize,
        /// x coordinate of the node \[m\].
        x: f64,
        /// y coordinate of the node \[m\].
        y: f64,
        /// Which conditions conflict.
        reason: String,
    },
    /// A zone's material constants are unusable (μ ≤ 0 or λ + μ ≤ 0 in plane strain, κ ≤ 0) or
    /// the material is missing.
    #[error("material {material}: {reason}")]
    InvalidMaterial {
        /// Index of the material (scene materials in name order).
        material: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// A boundary condition does not fit the mesh (unknown segment, a roller direction of zero
    /// length, nodes without a boundary normal) or no longer has the kind the problem was built
    /// with.
    #[error("boundary condition {index}: {reason}")]
    InvalidBoundary {
        /// Index of the condition in the scene's `boundary` list.
        index: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// A connected thermal component has no prescribed temperature: the heat problem is
    /// singular there.
    #[error("no prescribed temperature on the thermal component of node {node} (body '{body}'): the heat problem is singular")]
    NoTemperature {
        /// A node of the component.
        node: usize,
        /// Name of the body that node belongs to.
        body: String,
    },
    /// The numeric Cholesky factorisation met a non-positive pivot.
    #[error("the matrix is not positive definite (pivot {pivot} of the reordered system)")]
    NotPositiveDefinite {
        /// Index of the failing pivot in the fill-reducing order.
        pivot: usize,
    },
    /// Inconsistent arguments: arrays of the wrong length, an invalid mesh, or a factor built
    /// for other data.
    #[error("{0}")]
    Input(String),
    /// The sparse solver failed (ordering, symbolic analysis, memory).
    #[error("sparse solver: {0}")]
    Solver(String),
}

/// The material data of a mesh zone.
fn material_of<'a>(
    data: &'a crate::scene::Data,
    zone: &crate::mesh::MeshZone,
) -> Result<&'a crate::scene::MaterialData, FemError> {
    data.materials
        .get(zone.material)
        .ok_or_else(|| FemError::InvalidMaterial {
            material: zone.material,
            reason: format!("zone '{}' refers to a missing material", zone.name),
        })
}

/// The mesh segment of boundary condition `bc` (an unknown segment index is an error).
fn boundary_segment(
    mesh: &crate::mesh::Mesh,
    bc: usize,
    segment: usize,
) -> Result<&crate::mesh::MeshSegment, FemError> {
    mesh.segments
        .get(segment)
        .ok_or_else(|| FemError::InvalidBoundary {
            index: bc,
            reason: format!("segment index {segment} is not in the mesh"),
        })
}

/// An input array of the wrong length is an error, not a panic.
fn expect_len(what: &str, given: usize, expected: usize) -> Result<(), FemError> {
    if given == expected {
        Ok(())
    } else {
        Err(FemError::Input(format!(
            "{given} {what} given, {expected} expected"
        )))
    }
}
