//! wsm-service's tests, one binary (`cargo test -p wsm-service --test service`): the HTTP API's
//! status-code matrix in process (`status_codes`) and the job store's conformance suite on
//! SQLite and PostgreSQL (`store_conformance`).

#[path = "../../../../tests/common/postgres.rs"]
mod postgres;
mod status_codes;
mod store_conformance;
