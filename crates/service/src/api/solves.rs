//! The cap on synchronous solves (docs/service.md, "Robustness": caps on synchronous work):
//! `POST /v1/solve` and a job's fields solve on the request's behalf, each on a blocking thread
//! with the memory of its mesh; beyond `Limits::max_concurrent_solves` at once a request is
//! answered 503 `busy` with `Retry-After` instead of queuing more solves than the machine holds.
//! The place is held by the solve itself (it moves into the blocking task), so a client that hangs
//! up does not free it early.
//!
//! The fields of a solve cost about 0.75 kB of JSON per triangle (the independent probe had a
//! 1.8 kB request answered with 71 MB); a response carries them only for meshes up to
//! `Limits::max_field_triangles`. Beyond, the request is refused with 422 naming the option —
//! not answered with decimated fields, which would show a coarser solution than the one the
//! summary's numbers come from.

use std::sync::Arc;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use super::error::ApiError;
use crate::error_code::ErrorCode;
use wsm_core::run::SolveOutput;

/// Places for synchronous solves.
#[derive(Debug, Clone)]
pub struct SolveSlots {
    places: Arc<Semaphore>,
    count: usize,
}

/// A place taken; freed when dropped.
pub type SolvePlace = OwnedSemaphorePermit;

impl SolveSlots {
    /// Room for `count` synchronous solves at once.
    pub fn new(count: usize) -> SolveSlots {
        SolveSlots {
            places: Arc::new(Semaphore::new(count)),
            count,
        }
    }

    /// A place now, or 503 `busy` with `Retry-After`.
    pub fn take(&self) -> Result<SolvePlace, ApiError> {
        self.places.clone().try_acquire_owned().map_err(|_| {
            ApiError::new(
                ErrorCode::Busy,
                format!(
                    "{} synchronous solves are running, as many as this server runs at once; \
                     try again shortly, or submit a job",
                    self.count
                ),
            )
            .retry_after(2)
        })
    }
}

/// 422 at `path` when `output` carries the fields of a mesh larger than `max_triangles`
/// (`instead`: what to do).
pub fn check_fields(
    output: &SolveOutput,
    max_triangles: usize,
    path: &str,
    instead: &str,
) -> Result<(), ApiError> {
    let triangles = output.summary.mesh.triangles;
    if output.fields.is_some() && triangles > max_triangles {
        return Err(ApiError::invalid(
            path,
            format!(
                "the fields of {triangles} triangles would make a response of about {} MB; this \
                 server returns fields for meshes of at most {max_triangles} triangles \
                 (--max-field-triangles); {instead}",
                triangles * 750 / 1_000_000
            ),
        ));
    }
    Ok(())
}
