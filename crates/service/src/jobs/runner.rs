//! The job side of a worker process (`wsm serve` and `wsm worker`): each job slot leases a job from
//! the store and coordinates it — runs it through the front door (`wsm_core::worst`) on a blocking
//! thread (never on the async runtime), with its batches fanned out as tasks when other workers
//! share the store (`task_coordinator`), stores the evaluations it computes chunk by chunk, renews the
//! lease by heartbeat, passes cancel requests on, publishes progress, and stores how the job ended.
//! A panic inside a job fails that job with the reason; the worker goes on. Beside the job slots
//! run the task loop (`task_worker`) and the heartbeat that announces the process.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use tokio::sync::mpsc;

use super::task_coordinator::{HeldJob, StoreDispatch};
use super::task_worker::{serve_tasks, TaskConfig};
use super::{wait, JobEnd, JobRecord, JobStore, Lease};
use crate::error_code::ErrorCode;
use wsm_core::{
    ErrorKind, Evaluation, EvaluationLog, FaultSite, LogHeader, ProgressEvent, RunControl,
    SolveFault, Status, WsmError,
};

/// Settings of a worker process.
#[derive(Debug, Clone)]
pub struct RunnerConfig {
    /// Jobs coordinated at once (0: none, only tasks of other coordinators).
    pub workers: usize,
    /// Threads of each job's pool and of the task loop (`None`: all cores).
    pub threads_per_job: Option<usize>,
    /// A lease not renewed for this long is taken over \[s\].
    pub lease_seconds: f64,
    /// This process's name in leases and evaluations.
    pub owner: String,
    /// A job whose lease expired this many times (its worker died or hung each time) fails
    /// instead of being leased again.
    pub max_attempts: u32,
    /// Peak memory one solve may need \[bytes\]: a job beyond it fails naming the mesh size
    /// to coarsen, and refined accuracy levels beyond it are not built (design §3.1).
    pub max_solve_memory: u64,
    /// Fail solves on purpose (tests of failure handling; `wsm serve --inject-failures`).
    pub inject_failures: Vec<FaultRule>,
}

/// Runs of one job in one lease that may end on an unavailable store before the job fails:
/// each waits for the store to take writes again and resumes from the stored evaluations.
const STORE_RETRIES: u32 = 10;

/// The solves a [`FaultRule`] fails.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultSolves {
    /// The search's evaluations.
    Evaluations,
    /// The accuracy statement's refined solves.
    Refined,
}

/// The `solves` of every job whose uncertain `field` exceeds `above` fail (an injected fault,
/// for the end-to-end tests of how failures are reported). Only the job's coordinator injects
/// it: solves dealt to other worker processes run as usual.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultRule {
    /// Which solves fail.
    pub solves: FaultSolves,
    /// The `uncertain` entry's field path.
    pub field: String,
    /// Values above this fail.
    pub above: f64,
}

impl FaultRule {
    /// The reason this rule fails the solve at `site` of a run whose field is parameter `k`.
    fn answer(&self, k: usize, site: &FaultSite<'_>) -> Option<String> {
        let point = match (self.solves, site) {
            (FaultSolves::Evaluations, FaultSite::Evaluation { point }) => point,
            (FaultSolves::Refined, FaultSite::Refined { point, .. }) => point,
            _ => return None,
        };
        (point[k] > self.above).then(|| {
            format!(
                "injected failure: {} = {} > {}",
                self.field, point[k], self.above
            )
        })
    }
}

/// The fault of a job's run: the rules whose field is among its scene's uncertain data (`None`
/// when there is none).
fn fault_for(rules: &[FaultRule], scene: &wsm_core::Scene) -> Option<Arc<SolveFault>> {
    let active: Vec<(usize, FaultRule)> = rules
        .iter()
        .filter_map(|rule| {
            let k = scene.uncertain.iter().position(|u| u.field == rule.field)?;
            Some((k, rule.clone()))
        })
        .collect();
    if active.is_empty() {
        return None;
    }
    Some(Arc::new(move |site: &FaultSite<'_>| {
        active.iter().find_map(|(k, rule)| rule.answer(*k, site))
    }))
}

/// Jobs running in this process: their cancel flags; and whether the process is stopping (its
/// job slots and task loop then lease nothing more).
#[derive(Default)]
pub struct Live {
    jobs: Mutex<HashMap<String, LiveJob>>,
    stopping: Arc<AtomicBool>,
}

struct LiveJob {
    cancel: Arc<AtomicBool>,
}

impl Live {
    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<String, LiveJob>> {
        self.jobs.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Raise the cancel flag of a job running here.
    pub fn cancel(&self, id: &str) {
        if let Some(job) = self.lock().get(id) {
            job.cancel.store(true, Ordering::SeqCst);
        }
    }

    /// Stop every job running here (the process is shutting down and has given the leases
    /// back, so their ends are not stored: their next owner resumes them).
    fn stop_all(&self) {
        for job in self.lock().values() {
            job.cancel.store(true, Ordering::SeqCst);
        }
    }
}

/// Give back what `owner` holds and stop its jobs: the shutdown of a worker process, so that
/// its running jobs are resumed elsewhere at once instead of after their lease expires.
pub async fn release_on_shutdown(store: &Arc<dyn JobStore>, live: &Live, owner: &str) {
    live.stopping.store(true, Ordering::SeqCst);
    match store.release_all(owner).await {
        Ok(0) => {}
        Ok(n) => tracing::info!(jobs = n, "running jobs given back to the queue"),
        Err(e) => tracing::warn!(
            error = %e,
            "giving the running jobs back failed; they resume when their lease expires"
        ),
    }
    live.stop_all();
    // Let them leave their batch while the runtime still serves their store calls.
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    while !live.lock().is_empty() && std::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Logs a repeated store error once (and again when it changes), with a growing pause between
/// attempts: a store that cannot write must not fill the log twice a second.
struct Backoff {
    last: Option<String>,
    pause: Duration,
}

impl Backoff {
    const FIRST: Duration = Duration::from_millis(500);
    const MAX: Duration = Duration::from_secs(5);

    fn new() -> Backoff {
        Backoff {
            last: None,
            pause: Backoff::FIRST,
        }
    }

    /// Report `error` (if new) and wait before the next attempt.
    async fn failed(&mut self, error: String) {
        if self.last.as_deref() != Some(error.as_str()) {
            tracing::warn!(
                error = %error,
                "the job store failed; retrying with growing pauses up to {:?}",
                Backoff::MAX
            );
            self.last = Some(error);
        }
        tokio::time::sleep(self.pause).await;
        self.pause = (self.pause * 2).min(Backoff::MAX);
    }

    fn succeeded(&mut self) {
        if self.last.take().is_some() {
            tracing::info!("the job store answers again");
        }
        self.pause = Backoff::FIRST;
    }
}

impl RunnerConfig {
    /// Evaluation threads of this process.
    pub fn threads(&self) -> usize {
        self.threads_per_job
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
            .max(1)
    }
}

/// Start the job slots, the task loop and the heartbeat that announces this process.
pub fn spawn_workers(store: Arc<dyn JobStore>, live: Arc<Live>, config: RunnerConfig) {
    for _ in 0..config.workers {
        let (store, live, config) = (store.clone(), live.clone(), config.clone());
        tokio::spawn(async move {
            let mut work = store.work_signal();
            let mut backoff = Backoff::new();
            while !live.stopping.load(Ordering::SeqCst) {
                work.borrow_and_update();
                let lease = store.lease(&config.owner, config.lease_seconds, config.max_attempts);
                match lease.await {
                    Ok(Some(job)) => {
                        backoff.succeeded();
                        run_job(&store, &live, &config, job).await
                    }
                    Ok(None) => {
                        backoff.succeeded();
                        wait(&mut work, Duration::from_millis(500)).await
                    }
                    Err(e) => backoff.failed(e.to_string()).await,
                }
            }
        });
    }
    {
        let (store, config) = (store.clone(), config.clone());
        tokio::spawn(async move {
            let period = Duration::from_secs_f64((config.lease_seconds / 3.0).max(0.05));
            let mut backoff = Backoff::new();
            loop {
                match store.register_worker(&config.owner, config.threads()).await {
                    Ok(()) => {
                        backoff.succeeded();
                        tokio::time::sleep(period).await
                    }
                    Err(e) => backoff.failed(e.to_string()).await,
                }
            }
        });
    }
    let tasks = TaskConfig {
        owner: config.owner.clone(),
        threads: config.threads(),
        lease_seconds: config.lease_seconds,
        stopping: live.stopping.clone(),
    };
    tokio::spawn(async move {
        if let Err(e) = serve_tasks(store, tasks).await {
            tracing::error!(error = %e, "the task loop stopped");
        }
    });
}

/// The evaluation log of a job: its stored evaluations, appended to chunk by chunk.
struct StoreLog {
    held: HeldJob,
    run_hash: String,
    replay: Vec<Evaluation>,
}

impl EvaluationLog for StoreLog {
    fn open(&self, header: &LogHeader) -> Result<Vec<Evaluation>, WsmError> {
        if header.run_hash != self.run_hash {
            return Err(WsmError::LogMismatch {
                path: format!("job {}", self.held.job),
                expected: header.run_hash.clone(),
                found: self.run_hash.clone(),
            });
        }
        Ok(self.replay.clone())
    }

    fn append(&self, evaluations: &[Evaluation]) -> Result<(), WsmError> {
        let held = &self.held;
        held.call(
            held.store
                .append_evaluations(&held.job, &held.owner, evaluations),
        )
        .map(|_| ())
    }
}

/// The text of a panic payload.
fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

async fn run_job(
    store: &Arc<dyn JobStore>,
    live: &Arc<Live>,
    config: &RunnerConfig,
    job: JobRecord,
) {
    let id = job.id.clone();
    let cancel = Arc::new(AtomicBool::new(job.cancel_requested));
    live.lock().insert(
        id.clone(),
        LiveJob {
            cancel: cancel.clone(),
        },
    );
    let lost = Arc::new(AtomicBool::new(false));
    let heartbeat = tokio::spawn(heartbeat(
        store.clone(),
        config.clone(),
        id.clone(),
        cancel.clone(),
        lost.clone(),
    ));
    let (progress_tx, progress_rx) = mpsc::unbounded_channel::<ProgressEvent>();
    let publisher = tokio::spawn(publish(store.clone(), id.clone(), progress_rx));
    let run = Run {
        store,
        config,
        job: &job,
        cancel: &cancel,
        lost: &lost,
    };
    let end = run.to_end(live, &progress_tx).await;
    drop(progress_tx);
    let _ = publisher.await;
    run.store_end(live, end).await;
    heartbeat.abort();
    live.lock().remove(&id);
}

/// How one run of a job ended.
enum Attempt {
    /// With an outcome or an error of its own.
    Ended(Box<JobEnd>),
    /// On an unavailable store (the message): the job is not at fault.
    StoreFailed(String),
}

/// One job in the hands of a job slot.
struct Run<'a> {
    store: &'a Arc<dyn JobStore>,
    config: &'a RunnerConfig,
    job: &'a JobRecord,
    cancel: &'a Arc<AtomicBool>,
    lost: &'a Arc<AtomicBool>,
}

impl Run<'_> {
    /// Run the job to its end: attempt after attempt while the store fails (up to
    /// `STORE_RETRIES` times, each after the store takes writes again).
    async fn to_end(
        &self,
        live: &Live,
        progress_tx: &mpsc::UnboundedSender<ProgressEvent>,
    ) -> JobEnd {
        let mut retries = 0;
        loop {
            match self.attempt(progress_tx.clone()).await {
                Attempt::Ended(end) => return *end,
                Attempt::StoreFailed(error) if retries < STORE_RETRIES => {
                    retries += 1;
                    tracing::warn!(job = %self.job.id, error = %error, "resuming once the store takes writes");
                    if !self.await_writable(live).await {
                        return match self.cancel.load(Ordering::SeqCst) {
                            true => JobEnd::Cancelled(None),
                            false => JobEnd::Failed {
                                kind: ErrorCode::Io,
                                error,
                            },
                        };
                    }
                }
                Attempt::StoreFailed(error) => {
                    return JobEnd::Failed {
                        kind: ErrorCode::Io,
                        error: format!(
                            "{error} (the store failed {} times in a row while the job ran)",
                            retries + 1
                        ),
                    }
                }
            }
        }
    }

    /// Store how the job ended, once the store takes writes again — unless its lease was taken
    /// over (the job belongs to its new owner now) or this process stops (it has given its
    /// leases back).
    async fn store_end(&self, live: &Live, end: JobEnd) {
        let (id, owner) = (&self.job.id, &self.config.owner);
        let mut backoff = Backoff::new();
        while !self.lost.load(Ordering::SeqCst) && !live.stopping.load(Ordering::SeqCst) {
            match self.store.finish(id, owner, end.clone()).await {
                Ok(()) => break,
                Err(e) if e.unavailable => backoff.failed(format!("job {id}: {e}")).await,
                Err(e) => {
                    tracing::error!(job = %id, error = %e, "storing how the job ended");
                    break;
                }
            }
        }
    }

    /// Run the job from its stored evaluations to its end (or to a store failure).
    async fn attempt(&self, progress_tx: mpsc::UnboundedSender<ProgressEvent>) -> Attempt {
        let (store, config, job) = (self.store, self.config, self.job);
        let id = job.id.clone();
        if let Some(why) = &job.damaged {
            return Attempt::Ended(Box::new(JobEnd::Failed {
                kind: ErrorCode::Damaged,
                error: format!("the stored job is damaged and cannot run: {why}"),
            }));
        }
        let replay = match store.evaluations(&id, None).await {
            Ok(replay) => replay,
            Err(e) if e.unavailable => return Attempt::StoreFailed(e.to_string()),
            Err(e) => {
                return Attempt::Ended(Box::new(JobEnd::Failed {
                    kind: ErrorCode::Io,
                    error: e.to_string(),
                }))
            }
        };
        let store_failed = Arc::new(AtomicBool::new(false));
        let held = HeldJob {
            store: store.clone(),
            runtime: tokio::runtime::Handle::current(),
            job: id.clone(),
            owner: config.owner.clone(),
            attempt: job.attempts,
            store_failed: store_failed.clone(),
        };
        let log = StoreLog {
            held: held.clone(),
            run_hash: job.run_hash.clone(),
            replay,
        };
        let dispatch = StoreDispatch::new(
            held,
            config.threads(),
            config.lease_seconds,
            self.lost.clone(),
        );
        let control = RunControl::new()
            .with_max_solve_memory(config.max_solve_memory)
            .with_cancel(self.cancel.clone())
            .with_log(Arc::new(log))
            .with_dispatch(Arc::new(dispatch))
            .with_progress(move |e| {
                let _ = progress_tx.send(e.clone());
            });
        let mut request = job.settings.clone();
        if config.threads_per_job.is_some() {
            request.threads = config.threads_per_job;
        }
        let scene_text = job.scene.clone();
        let rules = config.inject_failures.clone();
        let task = tokio::task::spawn_blocking(move || {
            let scene = wsm_core::parse_scene(&scene_text)?;
            let fault = fault_for(&rules, &scene);
            let control = match fault {
                Some(fault) => control.with_fault(fault),
                None => control,
            };
            wsm_core::worst(scene, &request, &control)
        });
        Attempt::Ended(Box::new(match task.await {
            // A cancel that came after the last evaluation (during the sensitivities or
            // the accuracy statement) still ends the job cancelled, as the 202 promised.
            Ok(Ok(outcome))
                if outcome.status == Status::Cancelled || self.cancel.load(Ordering::SeqCst) =>
            {
                JobEnd::Cancelled(Some(outcome))
            }
            Ok(Ok(outcome)) => JobEnd::Succeeded(outcome),
            Ok(Err(WsmError::Cancelled)) => JobEnd::Cancelled(None),
            Ok(Err(e)) if store_failed.load(Ordering::SeqCst) && e.kind() == ErrorKind::Io => {
                return Attempt::StoreFailed(e.to_string())
            }
            Ok(Err(e)) => JobEnd::Failed {
                kind: ErrorCode::of_kind(e.kind()),
                error: e.to_string(),
            },
            Err(join) if join.is_panic() => JobEnd::Failed {
                kind: ErrorCode::Panic,
                error: format!("the job panicked: {}", panic_message(join.into_panic())),
            },
            Err(join) => JobEnd::Failed {
                kind: ErrorCode::Panic,
                error: format!("the job was aborted: {join}"),
            },
        }))
    }

    /// Wait until the store takes writes again; false when the job should not run again here
    /// (its lease was lost, it was cancelled, or the process is stopping).
    async fn await_writable(&self, live: &Live) -> bool {
        let mut backoff = Backoff::new();
        loop {
            if self.lost.load(Ordering::SeqCst)
                || self.cancel.load(Ordering::SeqCst)
                || live.stopping.load(Ordering::SeqCst)
            {
                return false;
            }
            match self.store.check_writable().await {
                Ok(()) => return true,
                Err(e) => backoff.failed(format!("job {}: {e}", self.job.id)).await,
            }
        }
    }
}

/// Renew the lease every third of its length; the same statement reads the cancel flag (a
/// cancel sent to another process reaches this one within a heartbeat).
async fn heartbeat(
    store: Arc<dyn JobStore>,
    config: RunnerConfig,
    id: String,
    cancel: Arc<AtomicBool>,
    lost: Arc<AtomicBool>,
) {
    let period = Duration::from_secs_f64((config.lease_seconds / 3.0).max(0.05));
    loop {
        tokio::time::sleep(period).await;
        match store.renew(&id, &config.owner, config.lease_seconds).await {
            Ok(Lease::Held { cancel_requested }) => {
                if cancel_requested {
                    cancel.store(true, Ordering::SeqCst);
                }
            }
            Ok(Lease::Lost) => {
                lost.store(true, Ordering::SeqCst);
                cancel.store(true, Ordering::SeqCst);
                return;
            }
            Err(e) => tracing::warn!(job = %id, error = %e, "renewing the job's lease"),
        }
    }
}

/// Store the latest progress: at most every 200 ms, and always the last (readers, and the
/// server-sent events, poll the store).
async fn publish(
    store: Arc<dyn JobStore>,
    id: String,
    mut events: mpsc::UnboundedReceiver<ProgressEvent>,
) {
    let mut last_write = std::time::Instant::now() - Duration::from_secs(1);
    let mut pending: Option<ProgressEvent> = None;
    while let Some(event) = events.recv().await {
        if last_write.elapsed() >= Duration::from_millis(200) {
            if let Err(e) = store.set_progress(&id, &event).await {
                tracing::warn!(job = %id, error = %e, "storing the job's progress");
            }
            last_write = std::time::Instant::now();
            pending = None;
        } else {
            pending = Some(event);
        }
    }
    if let Some(event) = pending {
        let _ = store.set_progress(&id, &event).await;
    }
}
