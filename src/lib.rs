//! wsm — worst-scenario analysis of multibody elastic contact with Tresca friction.
//!
//! The pipeline, one module each: `scene` (the JSON document) → `mesh` (P1 triangles, contact
//! node pairs) → `fem` (elasticity and heat operators, loads, stresses) → `contact` (the exact
//! direct contact solver) → `dd` (the papers' domain decomposition solver) → `state` (one state
//! solve and its criteria) → `scenario` (admissible sets, the outer maximiser) → `app` (what the
//! command line and the service do).

pub mod app;
pub mod bench;
pub mod contact;
pub mod criteria;
pub mod dd;
pub mod error;
pub mod examples;
pub mod fem;
pub mod mesh;
pub mod output;
pub mod scenario;
pub mod scene;
pub mod state;
