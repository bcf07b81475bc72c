//! wsm-core — the numerical engine of `wsm`: worst-scenario analysis of multibody elastic contact
//! with Tresca friction, and its front door.
//!
//! The pipeline, one module each, every module using only those before it (a test keeps it so:
//! `layering`), after the private `memo` (a small value cache): `scene` (the JSON
//! document and its validation) → `mesh` (P1 triangles, contact node pairs) → `fixtures` (structured meshes
//! and the seeded random generator for tests, studies and benchmarks) → `fem` (elasticity
//! and heat operators, loads, stresses) → `error` (the engine's error type, over the scene and
//! FEM errors and the search's) → `fault` (injected solve failures, for the tests of how runs
//! report them) → `bundled` (the example scenes) → `contact` (the exact direct contact solver) →
//! `dd` (the papers' domain decomposition solver) → `regions` (the criteria's areas and boundary
//! pieces as exact weights) → `state` (one state solve and its criteria) → `dynamics` (dynamic
//! viscoelastic contact: time stepping from rest or the static state, histories) → `output`
//! (result documents, the VTU writer) → `estimate` (discretisation-error estimates: mesh
//! ladders, Richardson extrapolation, the accuracy statement of a result, the mesh choice for a
//! target error) → `scenario` (admissible-set checks, the physics evaluator and the engine around
//! the generic search of the `wsm-search` crate) → `run` (the front door: typed requests,
//! outcomes, progress, cancellation and evaluation logs, shared by the command line, the service
//! and workers).
//!
//! The crate depends on no service crate (tokio, axum, sqlx, tower, rust-embed): the service
//! (`wsm-service`) and the studies (`wsm-study`) use it through its public items.

pub mod bundled;
pub mod contact;
pub mod dd;
pub mod dynamics;
pub mod error;
pub mod estimate;
pub mod fault;
pub mod fem;
pub mod fixtures;
mod memo;
pub mod mesh;
pub mod output;
pub mod regions;
pub mod run;
pub mod scenario;
pub mod scene;
pub mod state;

#[cfg(test)]
mod layering;
