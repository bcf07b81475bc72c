//! A coordinator's evaluation batches as tasks in the job store (the second level of
//! distribution, issue #14): when other worker processes share the store, each chunk of a batch is
//! split into one task per live evaluation thread, posted, and its evaluations are read back in
//! input order once every task is done. The coordinator's own process evaluates tasks too (its
//! task loop), so a job never waits on nobody. Alone (no other live worker), a batch is declined
//! and evaluated in-process with no store round trips.
//!
//! Called from the search's blocking thread; talks to the store through the runtime's handle.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use super::{wait, JobStore};
use crate::error::WsmError;
use crate::run::{BatchDispatch, Evaluation};
use crate::scenario::search::CHUNK_PER_THREAD;

/// Solve time of one fan-out chunk per live thread \[s\]: long enough that the store's round
/// trips (a few ms per batch) stay a small share, short enough that a cancel is seen soon.
const CHUNK_SECONDS: f64 = 0.5;
/// Points per live thread in a chunk, before any solve time is known and at the least.
const MIN_POINTS_PER_THREAD: usize = 4;
/// Points per live thread in a chunk at the most.
const MAX_POINTS_PER_THREAD: usize = 64;

/// The batches of one job (one lease attempt) as tasks.
pub struct StoreDispatch {
    pub store: Arc<dyn JobStore>,
    pub runtime: tokio::runtime::Handle,
    pub job: String,
    pub owner: String,
    pub attempt: u32,
    /// Evaluation threads of this process (the batch goes out only when others are live).
    pub own_threads: usize,
    /// Workers seen within this many seconds are live.
    pub lease_seconds: f64,
    /// Raised when the job's lease was lost: stop waiting.
    pub lost: Arc<AtomicBool>,
    next_batch: AtomicU64,
    /// The live threads last counted, and when.
    live: Mutex<Option<(Instant, usize)>>,
    /// Solve seconds and count of the evaluations returned so far.
    solves: Mutex<(f64, usize)>,
}

impl StoreDispatch {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        store: Arc<dyn JobStore>,
        runtime: tokio::runtime::Handle,
        job: String,
        owner: String,
        attempt: u32,
        own_threads: usize,
        lease_seconds: f64,
        lost: Arc<AtomicBool>,
    ) -> StoreDispatch {
        StoreDispatch {
            store,
            runtime,
            job,
            owner,
            attempt,
            own_threads,
            lease_seconds,
            lost,
            next_batch: AtomicU64::new(0),
            live: Mutex::new(None),
            solves: Mutex::new((0.0, 0)),
        }
    }

    /// Points per live thread in a chunk: about `CHUNK_SECONDS` of solves.
    fn points_per_thread(&self) -> usize {
        let (seconds, count) = *self.solves.lock().unwrap_or_else(PoisonError::into_inner);
        if count == 0 || seconds <= 0.0 {
            return MIN_POINTS_PER_THREAD;
        }
        let per_point = seconds / count as f64;
        ((CHUNK_SECONDS / per_point).ceil() as usize)
            .clamp(MIN_POINTS_PER_THREAD, MAX_POINTS_PER_THREAD)
    }

    /// Evaluation threads of the live workers, counted again at most once a second.
    fn live_threads(&self) -> usize {
        let mut live = self.live.lock().unwrap_or_else(PoisonError::into_inner);
        match *live {
            Some((at, n)) if at.elapsed() < Duration::from_secs(1) => n,
            _ => {
                let n = self
                    .runtime
                    .block_on(self.store.live_threads(self.lease_seconds))
                    .unwrap_or(0);
                *live = Some((Instant::now(), n));
                n
            }
        }
    }

    fn io(&self, e: impl std::fmt::Display) -> WsmError {
        WsmError::io(format!("job {}", self.job), e)
    }
}

impl BatchDispatch for StoreDispatch {
    fn chunk_size(&self) -> usize {
        let live = self.live_threads().max(self.own_threads);
        if live > self.own_threads {
            self.points_per_thread() * live
        } else {
            CHUNK_PER_THREAD * self.own_threads
        }
    }

    fn evaluate(&self, points: &[Vec<f64>]) -> Result<Option<Vec<Evaluation>>, WsmError> {
        let live = self.live_threads();
        if live <= self.own_threads || points.len() < 2 {
            return Ok(None);
        }
        let parts_count = live.min(points.len());
        let per_part = points.len().div_ceil(parts_count);
        let parts: Vec<Vec<Vec<f64>>> = points.chunks(per_part).map(|c| c.to_vec()).collect();
        let batch = self.next_batch.fetch_add(1, Ordering::SeqCst);
        let mut done = self.store.results_signal();
        done.borrow_and_update();
        self.runtime
            .block_on(
                self.store
                    .post_tasks(&self.job, &self.owner, self.attempt, batch, &parts),
            )
            .map_err(|e| self.io(e))?;
        loop {
            if self.lost.load(Ordering::SeqCst) {
                return Err(self.io("the job's lease was taken over"));
            }
            match self
                .runtime
                .block_on(self.store.batch_results(&self.job, self.attempt, batch))
            {
                Ok(Some(evaluations)) => {
                    let mut solves = self.solves.lock().unwrap_or_else(PoisonError::into_inner);
                    solves.0 += evaluations.iter().map(|e| e.solve_seconds).sum::<f64>();
                    solves.1 += evaluations.len();
                    return Ok(Some(evaluations));
                }
                Ok(None) => {}
                Err(e) => return Err(self.io(e)),
            }
            self.runtime
                .block_on(wait(&mut done, Duration::from_millis(200)));
        }
    }
}
