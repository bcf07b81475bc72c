//! The worst-scenario method (design §4): the admissible set checks, the physics evaluator, the
//! generic outer search and the engine that joins them, and the failed evaluations of a run.

pub mod evaluator;
pub mod failures;
pub mod solvability;
pub mod unproven;
pub mod worst;
