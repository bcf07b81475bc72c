//! The coordinator's side of fanning out (the second level of distribution: docs/scale-out.md,
//! "Design"): [`StoreDispatch`] hands a job's evaluation batches, as the search produces them, to
//! the other worker processes as tasks in the job store and collects the results. It runs in the
//! process that holds the job's lease and only ever serves that one job; the other processes pick
//! the tasks up in their task loops ([`super::task_worker`]), which never post tasks themselves.
//!
//! When other worker processes share the store, each chunk of a batch is dealt round robin to the
//! live evaluation threads: this process's share is computed at once in the job's own pool and
//! stored by one append that runs while the search goes on (awaited before the next append and by
//! `flush`), the others' shares are posted as tasks, one per remote thread. Once its share is done
//! the coordinator takes over any task of the batch that nobody has started or whose worker died,
//! then reads the evaluations back and returns them in input order. Alone (no other live worker), a
//! batch is declined and evaluated in-process as usual.
//!
//! The accuracy statement's refined solves go out the same way, as tasks of their own kind: each
//! process solves its share on the refined level it builds itself, and the values come back in
//! input order without entering the job's evaluations.
//!
//! Chunks hold about `CHUNK_SECONDS` of solves per live thread, so the store's round trips stay
//! a small share and a cancel is seen soon. Called from the search's blocking thread; talks to the
//! store through the runtime's handle.

use std::collections::HashSet;
use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use tokio::task::JoinHandle;

use super::{wait, JobStore, StoreError, StoreResult, TaskKey, TaskKind, TaskScope};
use wsm_core::{
    BatchDispatch, DispatchedBatch, Evaluation, LocalEvaluate, RefinedDispatch, RefinedOutcome,
    RefinedSolve, Scene, WsmError,
};

/// Solve time of one chunk per live thread \[s\].
const CHUNK_SECONDS: f64 = 1.5;
/// Points per live thread in a chunk, before any solve time is known and at the least.
const MIN_POINTS_PER_THREAD: usize = 2;
/// Points per live thread in a chunk at the most.
const MAX_POINTS_PER_THREAD: usize = 64;

/// Stores a task's results; false when the task is no longer this process's.
type Complete<'a, T> = dyn Fn(&TaskKey, &[T]) -> Result<bool, WsmError> + 'a;
/// A batch's results in input order, with whether another process computed each (`None`: not
/// dispatched).
type Fanned<T> = Option<(Vec<T>, Vec<bool>)>;

/// A job as its coordinator holds it in the store during one lease attempt: what the job's
/// evaluation log and its batch dispatch share.
#[derive(Clone)]
pub struct HeldJob {
    /// The job store the evaluations and tasks are written to and read back from.
    pub store: Arc<dyn JobStore>,
    /// The runtime's handle, through which the search's blocking thread calls the store.
    pub runtime: tokio::runtime::Handle,
    /// The job's id.
    pub job: String,
    /// This process's name in leases: the coordinator holding the job's lease.
    pub owner: String,
    /// The job's lease attempt; its tasks carry it, so an earlier coordinator's are told apart.
    pub attempt: u32,
    /// Raised when a store call failed because the database was unavailable (the job is then
    /// retried, not failed).
    pub store_failed: Arc<AtomicBool>,
}

impl HeldJob {
    /// An error of this job's (its id named).
    fn io(&self, e: impl std::fmt::Display) -> WsmError {
        WsmError::io(format!("job {}", self.job), e)
    }

    /// A store error as this job's, noting an unavailable database.
    fn store_error(&self, e: StoreError) -> WsmError {
        if e.unavailable {
            self.store_failed.store(true, Ordering::SeqCst);
        }
        self.io(e)
    }

    /// Wait for a store call; its error as this job's.
    pub fn call<T>(&self, call: impl Future<Output = StoreResult<T>>) -> Result<T, WsmError> {
        self.runtime.block_on(call).map_err(|e| self.store_error(e))
    }
}

/// The batches of one job (one lease attempt) as tasks.
pub struct StoreDispatch {
    /// The job and its store.
    pub held: HeldJob,
    /// Evaluation threads of this process's job pool.
    pub own_threads: usize,
    /// Workers seen within this many seconds are live.
    pub lease_seconds: f64,
    /// Raised when the job's lease was lost: stop waiting.
    pub lost: Arc<AtomicBool>,
    next_batch: AtomicU64,
    /// The live threads last counted, and when.
    live: Mutex<Option<(Instant, usize)>>,
    /// The append of this process's last share, still running.
    pending: Mutex<Option<JoinHandle<StoreResult<usize>>>>,
}

impl StoreDispatch {
    /// A dispatch of the batches of the held job with this process's `own_threads`, live
    /// workers counted within `lease_seconds`; batches are numbered from 0.
    pub fn new(
        held: HeldJob,
        own_threads: usize,
        lease_seconds: f64,
        lost: Arc<AtomicBool>,
    ) -> StoreDispatch {
        StoreDispatch {
            held,
            own_threads,
            lease_seconds,
            lost,
            next_batch: AtomicU64::new(0),
            live: Mutex::new(None),
            pending: Mutex::new(None),
        }
    }

    /// Evaluation threads of the live workers, counted again at most once a second.
    fn live_threads(&self) -> usize {
        let mut live = self.live.lock().unwrap_or_else(PoisonError::into_inner);
        match *live {
            Some((at, n)) if at.elapsed() < Duration::from_secs(1) => n,
            _ => {
                let n = self
                    .held
                    .runtime
                    .block_on(self.held.store.live_threads(self.lease_seconds))
                    .unwrap_or(0);
                *live = Some((Instant::now(), n));
                n
            }
        }
    }

    /// Wait for the append of the last share; its error, if any.
    fn settle(&self) -> Result<(), WsmError> {
        let pending = self
            .pending
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take();
        match pending {
            Some(append) => self.join(append).map(|_| ()),
            None => Ok(()),
        }
    }

    /// Store this process's share in the background (after the previous share).
    fn store_share(&self, evaluations: Vec<Evaluation>) -> Result<(), WsmError> {
        self.settle()?;
        let (store, job, owner) = (
            self.held.store.clone(),
            self.held.job.clone(),
            self.held.owner.clone(),
        );
        let append = self
            .held
            .runtime
            .spawn(async move { store.append_evaluations(&job, &owner, &evaluations).await });
        *self.pending.lock().unwrap_or_else(PoisonError::into_inner) = Some(append);
        Ok(())
    }

    /// Wait for a store call spawned on the runtime; its error (or the task's) as this job's.
    fn join<T>(&self, task: JoinHandle<StoreResult<T>>) -> Result<T, WsmError> {
        self.held
            .runtime
            .block_on(task)
            .map_err(|e| self.held.io(e))?
            .map_err(|e| self.held.store_error(e))
    }

    /// Take over the batch's tasks nobody has started (or whose worker died), solve them with
    /// `local` and store them with `complete`; the parts taken.
    fn take_over<T>(
        &self,
        batch: u64,
        local: &dyn Fn(&[Vec<f64>]) -> Vec<T>,
        complete: &Complete<'_, T>,
    ) -> Result<Vec<u32>, WsmError> {
        let mut taken = Vec::new();
        let scope = TaskScope::Batch {
            job: &self.held.job,
            attempt: self.held.attempt,
            batch,
        };
        while let Some(task) = self.held.call(self.held.store.lease_task(
            &self.held.owner,
            self.lease_seconds,
            scope,
        ))? {
            if complete(&task.key, &local(&task.points))? {
                taken.push(task.key.part);
            }
        }
        Ok(taken)
    }

    /// Deal `points` to the live threads as tasks of `kind` and return their results in input
    /// order, with whether another process computed each: this process's share is solved with
    /// `local` (then handed to `keep_own`), the others' tasks are read back with `results`
    /// once done, and any task nobody has started is taken over and stored with `complete`.
    /// `None`: no other live worker, or fewer than two points (not dispatched).
    fn fan_out<T>(
        &self,
        kind: TaskKind,
        points: &[Vec<f64>],
        local: &dyn Fn(&[Vec<f64>]) -> Vec<T>,
        keep_own: &dyn Fn(Vec<T>) -> Result<(), WsmError>,
        complete: &Complete<'_, T>,
        results: &dyn Fn(u64) -> Result<Option<Vec<T>>, WsmError>,
    ) -> Result<Fanned<T>, WsmError>
    where
        T: Clone,
    {
        let live = self.live_threads();
        if live <= self.own_threads || points.len() < 2 {
            return Ok(None);
        }
        // Slots 0..own are this process's, the others one task each. Round robin puts
        // neighbouring points of a polish step (one coordinate each, the expensive material
        // ones together) on different threads, which balances the shares.
        let n = points.len();
        let slots = live.min(n);
        let own = self.own_threads.min(slots - 1);
        // The point indices of each slot: s, s + slots, …
        let by_slot: Vec<Vec<usize>> = (0..slots)
            .map(|s| (s..n).step_by(slots).collect())
            .collect();
        let gather = |indices: &[usize]| -> Vec<Vec<f64>> {
            indices.iter().map(|&i| points[i].clone()).collect()
        };
        let parts: Vec<Vec<Vec<f64>>> = by_slot[own..].iter().map(|ix| gather(ix)).collect();
        let batch = self.next_batch.fetch_add(1, Ordering::SeqCst);
        let mut done = self.held.store.results_signal();
        done.borrow_and_update();
        // The tasks are posted while this process computes its share.
        let post = {
            let (store, job, owner, attempt) = (
                self.held.store.clone(),
                self.held.job.clone(),
                self.held.owner.clone(),
                self.held.attempt,
            );
            self.held.runtime.spawn(async move {
                store
                    .post_tasks(&job, &owner, attempt, batch, kind, &parts)
                    .await
            })
        };
        let mine_indices: Vec<usize> = by_slot[..own].concat();
        let own_results = local(&gather(&mine_indices));
        self.join(post)?;
        keep_own(own_results.clone())?;
        let mut taken: HashSet<u32> = HashSet::new();
        let remote_results = loop {
            if self.lost.load(Ordering::SeqCst) {
                return Err(self.held.io("the job's lease was taken over"));
            }
            if let Some(values) = results(batch)? {
                break values;
            }
            let newly = self.take_over(batch, local, complete)?;
            if newly.is_empty() {
                self.held
                    .runtime
                    .block_on(wait(&mut done, Duration::from_millis(200)));
            }
            taken.extend(newly);
        };
        // Back to input order, with who computed each.
        let mut placed: Vec<Option<(T, bool)>> = (0..n).map(|_| None).collect();
        for (&i, v) in mine_indices.iter().zip(own_results) {
            placed[i] = Some((v, false));
        }
        let mut remote_results = remote_results.into_iter();
        for (part, indices) in by_slot[own..].iter().enumerate() {
            let remote = !taken.contains(&(part as u32));
            for (&i, v) in indices.iter().zip(remote_results.by_ref()) {
                placed[i] = Some((v, remote));
            }
        }
        Ok(Some(placed.into_iter().flatten().unzip()))
    }
}

impl BatchDispatch for StoreDispatch {
    fn chunk_size(&self, seconds_per_point: Option<f64>) -> usize {
        let per_thread = match seconds_per_point {
            Some(s) if s > 0.0 => ((CHUNK_SECONDS / s).ceil() as usize)
                .clamp(MIN_POINTS_PER_THREAD, MAX_POINTS_PER_THREAD),
            _ => MIN_POINTS_PER_THREAD,
        };
        per_thread * self.live_threads().max(self.own_threads)
    }

    fn evaluate(
        &self,
        points: &[Vec<f64>],
        local: &LocalEvaluate<'_>,
    ) -> Result<Option<DispatchedBatch>, WsmError> {
        let complete = |key: &TaskKey, evaluations: &[Evaluation]| {
            self.held.call(
                self.held
                    .store
                    .complete_task(key, &self.held.owner, evaluations),
            )
        };
        let results = |batch: u64| {
            self.held.call(
                self.held
                    .store
                    .batch_results(&self.held.job, self.held.attempt, batch),
            )
        };
        let fanned = self.fan_out(
            TaskKind::Evaluate,
            points,
            local,
            &|own| self.store_share(own),
            &complete,
            &results,
        )?;
        Ok(fanned.map(|(evaluations, remote)| DispatchedBatch {
            evaluations,
            remote,
        }))
    }

    fn share_scene(&self, scene: &Scene) -> Result<(), WsmError> {
        let text = serde_json::to_string(scene).map_err(|e| self.held.io(e))?;
        let held = self.held.call(self.held.store.record_chosen_scene(
            &self.held.job,
            &self.held.owner,
            &text,
        ))?;
        if held {
            Ok(())
        } else {
            Err(self.held.io("the job's lease was taken over"))
        }
    }

    fn flush(&self) -> Result<(), WsmError> {
        self.settle()
    }
}

impl RefinedDispatch for StoreDispatch {
    fn refined(
        &self,
        level: u32,
        points: &[Vec<f64>],
        local: &RefinedSolve<'_>,
    ) -> Result<Option<Vec<RefinedOutcome>>, WsmError> {
        let complete = |key: &TaskKey, values: &[RefinedOutcome]| {
            self.held.call(
                self.held
                    .store
                    .complete_refined_task(key, &self.held.owner, values),
            )
        };
        let results = |batch: u64| {
            self.held.call(self.held.store.refined_results(
                &self.held.job,
                self.held.attempt,
                batch,
            ))
        };
        // The refined solves are not search points: nothing of them goes to the evaluations.
        let fanned = self.fan_out(
            TaskKind::Refined(level),
            points,
            local,
            &|_| Ok(()),
            &complete,
            &results,
        )?;
        Ok(fanned.map(|(values, _)| values))
    }
}
