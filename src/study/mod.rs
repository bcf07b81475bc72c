//! Accuracy and numerical stability as product outputs (SPEC §6, issue 13).
//!
//! - [`accuracy`]: `wsm study accuracy` — a case on a ladder of meshes ([`ladder`]) with the
//!   direct and the DD solver, errors against analytic solutions ([`analytic`]) or Richardson
//!   extrapolation ([`richardson`], energy errors through [`energy`]), written as tables and a
//!   log-log plot ([`report`], [`plot`]).
//! - [`statement`]: the accuracy statement of every worst-scenario result — the criteria at the
//!   worst and best data re-evaluated on refined meshes.
//! - [`mesh_choice`]: `--target-error REL` — the coarsest mesh of a ladder whose estimated error
//!   at the nominal data meets a target, chosen before the search.
//! - [`stability`]: `wsm study stability` — the catalogue of stiff and extreme cases, each
//!   solved with its KKT residuals and a condition estimate ([`condition`]) or refused with a
//!   reason.

pub mod accuracy;
pub mod analytic;
pub mod condition;
pub mod energy;
pub mod ladder;
pub mod mesh_choice;
pub mod plot;
pub mod report;
pub mod richardson;
pub mod stability;
pub mod statement;
