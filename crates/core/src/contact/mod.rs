//! Contact (design §2.1–2.4, §3.1, §3.4): unilateral contact with Tresca or Coulomb friction and
//! bilateral contact between bodies on matching node pairs, solved exactly.
//!
//! - `pairs`: discrete contact geometry — normals, tangents, nodal contact lengths, initial
//!   gaps, the contact operator B on the reduced DOFs, and the multiplier bounds.
//! - `qp`: the dense box- and equality-constrained QP in the contact multipliers.
//! - `feasibility`: whether the prescribed displacements let the bodies meet the contact
//!   constraints at all (pairs whose DOFs are all prescribed), on one data set and on a box.
//! - `bodies`: the diagonal blocks of K, one per body, analysed and factorised on their own.
//! - `direct`: the exact direct solver — K factorised once per stiffness, the contact problem
//!   condensed on the multipliers (C = B K⁺ Bᵀ), floating bodies handled through their kernel.
//! - `sparse`: the direct solver's sparse path above a pair count — a primal–dual active set on
//!   the primal, each step one sparse factorisation, memory O(nnz of a factor).
//! - `coulomb`: Coulomb friction as the fixed point of Tresca problems with g = F |λ_n|,
//!   accelerated by `anderson` mixing, stopped at the rounding level that `condition` (the
//!   condition of C) gives the direct solver's steps.

pub mod anderson;
pub(crate) mod bodies;
pub(crate) mod condition;
pub mod coulomb;
pub(crate) mod direct;
pub(crate) mod feasibility;
pub(crate) mod pairs;
pub mod qp;
pub(crate) mod sparse;

use crate::fem::ElasticCoefficients;
use crate::scene::Data;

/// One data point's elastic contact problem as the contact solvers take it: the data (friction,
/// slip limits, gaps), the zones' elastic coefficients, the reduced right-hand side and the
/// prescribed displacement values.
#[derive(Debug, Clone, Copy)]
pub struct LoadCase<'a> {
    /// The data of the point.
    pub data: &'a Data,
    /// The zones' elastic coefficients at the data.
    pub coefficients: &'a [ElasticCoefficients],
    /// The reduced right-hand side.
    pub rhs: &'a [f64],
    /// The prescribed displacement values.
    pub fixed: &'a [f64],
}
