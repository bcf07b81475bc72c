//! The engine's integration tests, one test binary (`cargo test -p wsm-core --test engine`):
//! scenes solved and searched through wsm-core's public items only, one module per subject.
//! `solves` holds the shared fixtures (scene builders, solves with either inner solver, the
//! seeded random generator). Tests that need the `wsm` binary, the service or the studies stay
//! in the root package's `tests/`.

mod solves;

mod anisotropy;
mod contact_qp;
mod contact_verification;
mod coulomb;
mod czech_models;
mod dd_printed;
mod dd_vs_direct;
mod defined_criteria;
mod dynamic_worst;
mod failed_evaluations;
mod global_search;
mod hydrostatic;
mod knee_papers;
mod mesh_robustness;
mod mixed_thermal;
mod mortar;
mod mortar_poisson;
mod sparse_contact;
mod worst_scenario;
