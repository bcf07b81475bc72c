//! wsm-study — accuracy and numerical stability as product outputs, and the benchmarks: the
//! `wsm study` and `wsm bench` commands, built on the engine's front door (`wsm_core::worst`,
//! `wsm_core::solve`) and its state solves (`wsm_core::StateProblem`).
//!
//! - [`accuracy`]: `wsm study accuracy` — a case on a ladder of meshes
//!   (`wsm_core::Ladder`, `wsm_core::scaled_scene`) with the direct and the DD solver, errors
//!   against analytic solutions ([`analytic`]) or Richardson extrapolation
//!   (`wsm_core::extrapolate`,
//!   energy errors through [`energy`]), written as tables and a log-log plot ([`report`],
//!   [`plot`]).
//! - [`stability`]: `wsm study stability` — the catalogue of stiff and extreme cases, each
//!   solved with its KKT residuals and a condition estimate ([`condition`]) or refused with a
//!   reason.
//! - [`mod@bench`]: `wsm bench` — timings of assembly, factorisation, the inner solvers and the
//!   outer loop.

pub mod accuracy;
pub mod analytic;
pub mod bench;
pub mod condition;
pub mod energy;
pub mod plot;
pub mod report;
pub mod stability;
