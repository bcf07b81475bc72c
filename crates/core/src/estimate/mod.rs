//! Discretisation-error estimates that a run reports (the engine's part of the accuracy work):
//!
//! - [`ladder`]: mesh levels of a scene (every mesh size scaled by one factor) and cold direct
//!   solves on them;
//! - [`richardson`]: Richardson extrapolation and observed orders of a mesh sequence;
//! - [`statement`]: the accuracy statement of every worst-scenario result — the criteria at the
//!   worst and best data re-evaluated on refined meshes;
//! - [`mesh_choice`]: `--target-error REL` — the coarsest mesh of a ladder whose estimated error
//!   at the nominal data meets a target, chosen before the search.
//!
//! The `wsm study` commands that drive whole runs (accuracy studies, the stability catalogue)
//! live in the `wsm-study` crate above the front door.

pub mod ladder;
pub mod mesh_choice;
pub mod richardson;
pub mod statement;
