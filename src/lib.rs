//! wsm — worst-scenario analysis of multibody elastic contact with Tresca friction.
//!
//! The pipeline, one module each: `scene` (the JSON document) → `mesh` (P1 triangles, contact
//! node pairs) → `fem` (elasticity and heat operators, loads, stresses) → `contact` (the exact
//! direct contact solver) → `dd` (the papers' domain decomposition solver) → `state` (one state
//! solve and its criteria) → `scenario` (admissible sets, the outer maximiser) → `run` (the front
//! door: typed requests, outcomes, progress, cancellation and evaluation logs, shared by the
//! command line, the service and workers) → `jobs` (the durable job queue and its workers) →
//! `api` (the HTTP API) and `web` (the dashboard over it) → `server` (`wsm serve`). The
//! numerical core (everything up to `run`) never imports the service modules.

pub mod api;
pub mod bench;
pub mod contact;
pub mod criteria;
pub mod dd;
pub mod error;
pub mod examples;
pub mod fem;
pub mod jobs;
mod memo;
pub mod mesh;
pub mod output;
pub mod run;
pub mod scenario;
pub mod scene;
pub mod server;
pub mod state;
pub mod study;
pub mod web;
