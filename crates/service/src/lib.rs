//! wsm-service — the HTTP service of `wsm`: the durable job store and queue (`jobs`: SQLite or
//! PostgreSQL, migrations in the repository's `migrations/`), its workers, the HTTP API (`api`),
//! the dashboard (`web`), the connections (`http`: timeouts and a connection cap) and the
//! `wsm serve` / `wsm worker` entry points (`server`).
//!
//! It drives the engine only through wsm-core's front door (the re-exports of its `run`:
//! requests, prepared models, outcomes; of its `scene`: the document; of its `error`); the
//! engine never depends on this crate.

pub mod api;
pub mod error_code;
pub mod http;
pub mod jobs;
pub mod server;
pub mod web;
