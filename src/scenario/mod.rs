//! The worst-scenario method (SPEC §4): the admissible set checks, the physics evaluator and the
//! generic outer search.

pub mod admissible;
pub mod search;
pub mod worst;
