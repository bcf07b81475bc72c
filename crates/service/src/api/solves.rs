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
//! summary's numbers come from. A dynamic scene's displacement frames (design §3.5) count as
//! output times × triangles / [`FRAME_TRIANGLES_PER_FIELD_TRIANGLE`] against the same cap (the
//! bytes of the fields of as many triangles), checked on the estimated mesh before the time loop
//! runs and on the real one after.

use std::sync::Arc;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use super::error::ApiError;
use crate::error_code::ErrorCode;
use wsm_core::SolveOutput;

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

/// Frame triangles (one output time's displacement on one triangle) that weigh as much in a
/// response as one triangle of the fields: measured 25 B against 300 B of JSON per triangle on
/// `implant-impact` (5,132 triangles) and `tunnel-fault-seismic` (10,632).
pub const FRAME_TRIANGLES_PER_FIELD_TRIANGLE: usize = 12;

/// 422 at `settings.frames` when the displacement frames of `outputs` output times on a mesh of
/// `triangles` would make a larger response than the fields of `max_triangles`
/// ([`FRAME_TRIANGLES_PER_FIELD_TRIANGLE`]); `about` is `"about "` when `triangles` is
/// estimated before meshing, else empty.
pub fn check_frames(
    outputs: usize,
    triangles: usize,
    max_triangles: usize,
    about: &str,
) -> Result<(), ApiError> {
    let weight = outputs.saturating_mul(triangles);
    let equivalent = weight.div_ceil(FRAME_TRIANGLES_PER_FIELD_TRIANGLE);
    if equivalent <= max_triangles {
        return Ok(());
    }
    Err(ApiError::invalid(
        "settings.frames",
        format!(
            "{outputs} output times × {about}{triangles} triangles = {about}{weight} frame \
             triangles, a response as large as the fields of {about}{equivalent} triangles; \
             this server returns fields of at most {max_triangles} triangles \
             (--max-field-triangles); record less often (scene.dynamics.output_every), coarsen \
             scene.mesh.max_size, or ask without frames for the histories"
        ),
    ))
}

/// 422 at `path` when `output` carries the fields of a mesh larger than `max_triangles`
/// (`instead`: what to do), or at `settings.frames` when its frames exceed them
/// ([`check_frames`]).
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
    match &output.frames {
        Some(frames) => check_frames(frames.len(), triangles, max_triangles, ""),
        None => Ok(()),
    }
}
