//! The worst-scenario method (SPEC §4): the admissible set checks, the physics evaluator, the
//! generic outer search and the engine that joins them.

pub mod admissible;
pub mod evaluator;
pub mod search;
pub mod worst;
