//! The worker's side of fanning out: the task loop ([`serve_tasks`]) that every worker process runs
//! beside its job slots. It serves any job but coordinates none: it leases a task (some points of
//! one batch of a job that another process coordinates; a coordinator computes its own share in the
//! job's pool and never leases its own job's tasks here), evaluates its points with the job's
//! prepared model, and stores the evaluations with the task's completion in one transaction. The
//! tasks are posted, taken over when abandoned and read back by the job's coordinator
//! ([`super::task_coordinator`]). The lease is renewed by heartbeat while the points are solved; a task
//! whose worker died is leased again by another once its lease expires, so a killed worker loses at
//! most the task it held.
//!
//! A prepared model (mesh, per-zone operators, symbolic factorisations, the nominal solve that
//! warm-starts every contact solve) is kept per run hash, so a task costs only its solves. A
//! task of the accuracy statement (`TaskKind::Refined`) is solved on the model's refined
//! level, built on the first such task and kept for the next. Each
//! model lives on a thread of its own that owns the state problem and its evaluator; tasks reach
//! it through a channel and are solved in the worker's thread pool.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use super::{wait, JobInput, JobStore, TaskKind, TaskRecord, TaskScope};
use wsm_core::{Evaluation, PreparedModel, RefinedLevel, RefinedOutcome, WorstRequest, WsmError};

/// Prepared models kept per worker process.
const MODELS_KEPT: usize = 2;

/// Settings of a worker's evaluation side.
#[derive(Debug, Clone)]
pub struct TaskConfig {
    /// This process's name in leases and evaluations.
    pub owner: String,
    /// Threads solving the points of a task.
    pub threads: usize,
    /// A task lease not renewed for this long is taken over \[s\].
    pub lease_seconds: f64,
    /// Raised when the process stops: no more tasks are leased.
    pub stopping: Arc<AtomicBool>,
}

/// What a task's points came back with.
enum Solved {
    Evaluations(Vec<Evaluation>),
    Refined(Vec<RefinedOutcome>),
}

type Reply = mpsc::Sender<Result<Solved, WsmError>>;

/// A job's prepared model on its own thread.
struct Model {
    run_hash: String,
    requests: mpsc::Sender<(TaskKind, Vec<Vec<f64>>, Reply)>,
}

impl Model {
    /// Mesh the scene, build the operators and solve the nominal state on a new thread that
    /// then serves evaluation requests until the model is dropped.
    fn prepare(input: &JobInput, pool: Arc<rayon::ThreadPool>) -> Result<Model, WsmError> {
        let (requests, inbox) = mpsc::channel::<(TaskKind, Vec<Vec<f64>>, Reply)>();
        let (ready_tx, ready_rx) = mpsc::channel::<Result<(), WsmError>>();
        let scene_text = input.scene.clone();
        let chosen_scene = input.chosen_scene.clone();
        let settings: WorstRequest = input.settings.clone();
        std::thread::Builder::new()
            .name("wsm-model".into())
            .spawn(move || {
                let model = match pool.install(|| {
                    PreparedModel::for_job(&scene_text, &settings, chosen_scene.as_deref())
                }) {
                    Ok(model) => model,
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return;
                    }
                };
                let evaluator = match pool.install(|| model.evaluator()) {
                    Ok(e) => e,
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return;
                    }
                };
                let _ = ready_tx.send(Ok(()));
                // The accuracy statement's refined level, built on its first task and kept
                // for the job's later ones.
                let mut refined: Option<RefinedLevel<'_>> = None;
                for (kind, points, reply) in inbox {
                    let solved = match kind {
                        TaskKind::Evaluate => {
                            Solved::Evaluations(pool.install(|| evaluator.evaluate_batch(&points)))
                        }
                        TaskKind::Refined(level) => {
                            let level = match refined.take() {
                                Some(kept) if kept.level() == level => kept,
                                _ => model.refined_level(level),
                            };
                            let values = pool.install(|| level.solve(&points, &|| false));
                            refined = Some(level);
                            Solved::Refined(values)
                        }
                    };
                    let _ = reply.send(Ok(solved));
                }
            })
            .map_err(|e| WsmError::io("model thread", e))?;
        ready_rx
            .recv()
            .map_err(|_| WsmError::io("model thread", "the model thread ended"))??;
        Ok(Model {
            run_hash: input.run_hash.clone(),
            requests,
        })
    }

    fn solve(&self, kind: TaskKind, points: Vec<Vec<f64>>) -> Result<Solved, WsmError> {
        let (reply, answer) = mpsc::channel();
        self.requests
            .send((kind, points, reply))
            .map_err(|_| WsmError::io("model thread", "the model thread ended"))?;
        answer
            .recv()
            .map_err(|_| WsmError::io("model thread", "the model thread ended"))?
    }
}

/// The models of the most recent jobs, newest first.
struct Models {
    kept: VecDeque<Arc<Model>>,
    pool: Arc<rayon::ThreadPool>,
    /// Run hashes whose model failed to prepare ahead of a task.
    failed_ahead: Vec<String>,
}

impl Models {
    fn get(&mut self, run_hash: &str) -> Option<Arc<Model>> {
        let i = self.kept.iter().position(|m| m.run_hash == run_hash)?;
        let model = self.kept.remove(i)?;
        self.kept.push_front(model.clone());
        Some(model)
    }

    fn insert(&mut self, model: Model) -> Arc<Model> {
        let model = Arc::new(model);
        self.kept.push_front(model.clone());
        self.kept.truncate(MODELS_KEPT);
        model
    }
}

/// Lease and evaluate tasks until the process ends.
pub async fn serve_tasks(store: Arc<dyn JobStore>, config: TaskConfig) -> Result<(), WsmError> {
    let pool = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(config.threads.max(1))
            .thread_name(|i| format!("wsm-eval-{i}"))
            .build()
            .map_err(|e| WsmError::io("thread pool", e))?,
    );
    let mut models = Models {
        kept: VecDeque::new(),
        pool,
        failed_ahead: Vec::new(),
    };
    let mut work = store.work_signal();
    while !config.stopping.load(Ordering::SeqCst) {
        work.borrow_and_update();
        match store
            .lease_task(&config.owner, config.lease_seconds, TaskScope::Others)
            .await
        {
            Ok(Some(task)) => match models.get(&task.run_hash) {
                Some(model) => run_task(&store, &config, model, task).await,
                // Not prepared yet: give the task back at once (its coordinator or a prepared
                // worker takes it rather than wait for this one), then prepare the model.
                None => {
                    if let Err(e) = store.release_task(&task.key, &config.owner).await {
                        tracing::warn!(job = %task.key.job_id, error = %e, "giving a task back");
                    }
                    let job = &task.key.job_id;
                    if let Err(e) = prepare(&store, &mut models, job, true).await {
                        tracing::warn!(job = %job, error = %e, "preparing the job's model");
                        tokio::time::sleep(Duration::from_secs_f64(config.lease_seconds)).await;
                    }
                }
            },
            Ok(None) => {
                prepare_ahead(&store, &config, &mut models).await;
                wait(&mut work, Duration::from_millis(500)).await
            }
            Err(e) => {
                tracing::warn!(error = %e, "leasing a task");
                tokio::time::sleep(Duration::from_secs(1)).await;
            }
        }
    }
    Ok(())
}

/// Evaluate one task and store its evaluations (unless its lease was lost meanwhile).
async fn run_task(
    store: &Arc<dyn JobStore>,
    config: &TaskConfig,
    model: Arc<Model>,
    task: TaskRecord,
) {
    let heartbeat = {
        let (store, key, owner) = (store.clone(), task.key.clone(), config.owner.clone());
        let lease = config.lease_seconds;
        tokio::spawn(async move {
            loop {
                tokio::time::sleep(Duration::from_secs_f64((lease / 3.0).max(0.05))).await;
                match store.renew_task(&key, &owner, lease).await {
                    Ok(true) => {}
                    Ok(false) => return,
                    Err(e) => {
                        tracing::warn!(job = %key.job_id, error = %e, "renewing a task's lease")
                    }
                }
            }
        })
    };
    let (kind, points) = (task.kind, task.points.clone());
    let solved = tokio::task::spawn_blocking(move || model.solve(kind, points))
        .await
        .map_err(|e| WsmError::io("model thread", e))
        .and_then(|r| r);
    heartbeat.abort();
    match solved {
        Ok(solved) => {
            let stored = match &solved {
                Solved::Evaluations(evaluations) => {
                    store
                        .complete_task(&task.key, &config.owner, evaluations)
                        .await
                }
                Solved::Refined(values) => {
                    store
                        .complete_refined_task(&task.key, &config.owner, values)
                        .await
                }
            };
            if let Err(e) = stored {
                tracing::warn!(job = %task.key.job_id, error = %e, "storing a task's results");
            }
        }
        // The coordinator built the same model, so this is this process's trouble (memory, a
        // thread that died): leave the task to expire and be leased by another worker.
        Err(e) => {
            tracing::warn!(job = %task.key.job_id, error = %e, "solving a task; left to another worker");
            tokio::time::sleep(Duration::from_secs_f64(config.lease_seconds)).await;
        }
    }
}

/// An idle worker prepares the model of the newest job another process coordinates, before
/// its first task arrives: its meshing and nominal solve then overlap the coordinator's own
/// instead of holding up the first fanned-out batch. A job whose model failed to prepare here
/// is not tried again ahead of a task.
async fn prepare_ahead(store: &Arc<dyn JobStore>, config: &TaskConfig, models: &mut Models) {
    let Ok(Some((job, run_hash))) = store.coordinated_elsewhere(&config.owner).await else {
        return;
    };
    if models.get(&run_hash).is_some() || models.failed_ahead.contains(&run_hash) {
        return;
    }
    if prepare(store, models, &job, false).await.is_err() {
        models.failed_ahead.push(run_hash);
    }
}

/// Prepare and keep the model of `job`. Ahead of a task (`!for_task`), a job with a target
/// error is prepared only once its coordinator has recorded the mesh it chose (choosing again
/// here would repeat the coordinator's mesh study).
async fn prepare(
    store: &Arc<dyn JobStore>,
    models: &mut Models,
    job: &str,
    for_task: bool,
) -> Result<(), WsmError> {
    let input = store
        .job_input(job)
        .await
        .map_err(|e| WsmError::io(format!("job {job}"), e))?
        .ok_or_else(|| WsmError::io(format!("job {job}"), "the job is gone"))?;
    if !for_task && input.settings.target_error.is_some() && input.chosen_scene.is_none() {
        return Ok(());
    }
    let pool = models.pool.clone();
    let model = tokio::task::spawn_blocking(move || Model::prepare(&input, pool))
        .await
        .map_err(|e| WsmError::io("model thread", e))??;
    models.insert(model);
    Ok(())
}
