//! One conformance suite for the job store, run against SQLite (always) and PostgreSQL (when
//! `WSM_TEST_POSTGRES_URL` names a server, as `.ci/run` sets it; otherwise those runs say they
//! are skipped): jobs, leases and their expiry by the database clock, cancel, guarded appends,
//! the fan-out tasks of a batch (leased once each, results in part order, a dead worker's task
//! leased again, a taken-over job's tasks dropped), and the workers' heartbeat.

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Duration;

use crate::postgres::{postgres_url, PgSchema};
use wsm_core::{Criterion, Evaluation, OneSided, RefinedOutcome, WorstRequest};
use wsm_service::error_code::ErrorCode;
use wsm_service::jobs::sql::SqlStore;
use wsm_service::jobs::{
    JobEnd, JobState, JobStore, Lease, NewJob, Page, TaskKey, TaskKind, TaskScope,
};

/// A fresh SQLite file.
async fn sqlite() -> Arc<dyn JobStore> {
    let dir = std::env::temp_dir().join(format!("wsm-conformance-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{}.db", uuid::Uuid::new_v4()));
    Arc::new(SqlStore::open(path.to_str().unwrap()).await.unwrap())
}

/// Run `check` on every backend available.
macro_rules! conformance {
    ($name:ident, $check:ident) => {
        #[tokio::test(flavor = "multi_thread", worker_threads = 4)]
        async fn $name() {
            $check(sqlite().await).await;
            match postgres_url() {
                Some(url) => {
                    let schema = PgSchema::new(&url);
                    $check(Arc::new(SqlStore::open(&schema.url).await.unwrap())).await;
                }
                None => eprintln!(
                    "{}: PostgreSQL part skipped (WSM_TEST_POSTGRES_URL is not set)",
                    stringify!($name)
                ),
            }
        }
    };
}

fn job(id: &str) -> NewJob {
    NewJob {
        id: id.into(),
        scene: "{\"name\": \"scene\"}".into(),
        settings: WorstRequest::default(),
        scene_name: "scene".into(),
        criteria: vec![Criterion::Phi3.into()],
        budget: 10,
        run_hash: format!("hash-{id}"),
    }
}

/// An evaluation whose numbers need every bit of an f64.
fn evaluation(x: f64) -> Evaluation {
    Evaluation {
        point: vec![x, 1.0 / 3.0 + x, 1e-300 * x],
        values: Some(vec![std::f64::consts::PI * x, -0.1 - x]),
        error: None,
        max_kkt_residual: Some(1.234_567_890_123_456_7e-13),
        solve_seconds: 0.01,
        // Per criterion, per datum: one-sided derivatives (a kink in the last one).
        gradient: (0..2)
            .map(|c| {
                (0..3)
                    .map(|j| {
                        let slope = (c as f64 + 1.0) / 7.0 * x - j as f64 * 1e-200;
                        OneSided {
                            right: slope,
                            left: if j == 2 { -slope } else { slope },
                        }
                    })
                    .collect()
            })
            .collect(),
    }
}

async fn jobs_round_trip_and_list_newest_first(store: Arc<dyn JobStore>) {
    for id in ["a", "b", "c"] {
        assert!(store.insert(job(id), usize::MAX).await.unwrap());
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let a = store.get("a").await.unwrap().unwrap();
    assert_eq!(a.state, JobState::Queued);
    assert_eq!(a.criteria, vec![Criterion::Phi3.into()]);
    assert_eq!(a.run_hash, "hash-a");
    assert!(store.get("missing").await.unwrap().is_none());
    let page = Page {
        limit: 2,
        offset: 0,
    };
    let listed: Vec<String> = store
        .list(None, page)
        .await
        .unwrap()
        .into_iter()
        .map(|j| j.id)
        .collect();
    assert_eq!(listed, ["c", "b"]);
    assert_eq!(store.active_count().await.unwrap(), 3);
    let queued = store.list(Some(JobState::Running), page).await.unwrap();
    assert!(queued.is_empty());
}
conformance!(
    jobs_round_trip_and_list_newest_first_on_every_backend,
    jobs_round_trip_and_list_newest_first
);

async fn concurrent_leases_take_each_job_once(store: Arc<dyn JobStore>) {
    for i in 0..12 {
        assert!(store
            .insert(job(&format!("job{i:02}")), usize::MAX)
            .await
            .unwrap());
    }
    let leasers: Vec<_> = (0..4)
        .map(|w| {
            let store = store.clone();
            tokio::spawn(async move {
                let mut got = Vec::new();
                while let Some(job) = store.lease(&format!("w{w}"), 60.0, 3).await.unwrap() {
                    assert_eq!(job.state, JobState::Running);
                    got.push(job.id);
                }
                got
            })
        })
        .collect();
    let mut all = Vec::new();
    for l in leasers {
        all.extend(l.await.unwrap());
    }
    let distinct: HashSet<_> = all.iter().cloned().collect();
    assert_eq!(all.len(), 12, "{all:?}");
    assert_eq!(distinct.len(), 12);
}
conformance!(
    concurrent_leases_take_each_job_once_on_every_backend,
    concurrent_leases_take_each_job_once
);

async fn leases_renew_expire_by_the_database_clock_and_pass_cancel_on(store: Arc<dyn JobStore>) {
    assert!(store.insert(job("j"), usize::MAX).await.unwrap());
    let first = store.lease("w1", 0.3, 3).await.unwrap().unwrap();
    assert_eq!(first.attempts, 1);
    assert!(store.lease("w2", 0.3, 3).await.unwrap().is_none(), "held");
    assert_eq!(
        store.renew("j", "w1", 0.3).await.unwrap(),
        Lease::Held {
            cancel_requested: false
        }
    );
    assert_eq!(store.renew("j", "w2", 0.3).await.unwrap(), Lease::Lost);
    tokio::time::sleep(Duration::from_millis(450)).await;
    let second = store.lease("w2", 30.0, 3).await.unwrap().expect("expired");
    assert_eq!(second.attempts, 2);
    assert_eq!(store.renew("j", "w1", 30.0).await.unwrap(), Lease::Lost);
    assert!(
        !store.request_cancel("j").await.unwrap(),
        "running: flagged"
    );
    assert_eq!(
        store.renew("j", "w2", 30.0).await.unwrap(),
        Lease::Held {
            cancel_requested: true
        }
    );
    // Only the lease holder ends the job.
    store
        .finish("j", "w1", JobEnd::Cancelled(None))
        .await
        .unwrap();
    assert_eq!(
        store.get("j").await.unwrap().unwrap().state,
        JobState::Running
    );
    store
        .finish("j", "w2", JobEnd::Cancelled(None))
        .await
        .unwrap();
    let ended = store.get("j").await.unwrap().unwrap();
    assert_eq!(ended.state, JobState::Cancelled);
    assert!(ended.finished_at.unwrap() >= ended.created_at);
    // A queued job is cancelled at once.
    assert!(store.insert(job("q"), usize::MAX).await.unwrap());
    assert!(store.request_cancel("q").await.unwrap());
    assert_eq!(
        store.get("q").await.unwrap().unwrap().state,
        JobState::Cancelled
    );
    assert_eq!(store.active_count().await.unwrap(), 0);
}
conformance!(
    leases_renew_expire_by_the_database_clock_and_pass_cancel_on_on_every_backend,
    leases_renew_expire_by_the_database_clock_and_pass_cancel_on
);

/// A job whose worker keeps dying (its lease expires each time) is leased `max_attempts` times,
/// then failed with the cause; a lease given back on shutdown is not counted.
async fn a_job_whose_workers_keep_dying_fails_after_max_attempts(store: Arc<dyn JobStore>) {
    assert!(store.insert(job("dies"), usize::MAX).await.unwrap());
    let first = store.lease("w0", 0.2, 3).await.unwrap().unwrap();
    assert_eq!(first.attempts, 1);
    // A shutdown gives the lease back: not a death.
    assert_eq!(store.release_all("w0").await.unwrap(), 1);
    for attempt in 2..=4 {
        let leased = store.lease(&format!("w{attempt}"), 0.2, 3).await.unwrap();
        assert_eq!(leased.expect("leased again").attempts, attempt);
        tokio::time::sleep(Duration::from_millis(350)).await; // the worker "dies"
    }
    // Its third death: failed instead of leased.
    assert!(store.lease("w5", 30.0, 3).await.unwrap().is_none());
    let failed = store.get("dies").await.unwrap().unwrap();
    assert_eq!(failed.state, JobState::Failed);
    assert_eq!(
        failed.error_kind.map(ErrorCode::name),
        Some("attempts_exhausted")
    );
    let error = failed.error.unwrap();
    assert!(error.contains("3 times"), "{error}");
    assert!(error.contains("--max-attempts 3"), "{error}");
    // Another job behind it is still leased.
    assert!(store.insert(job("next"), usize::MAX).await.unwrap());
    let next = store.lease("w5", 30.0, 3).await.unwrap().unwrap();
    assert_eq!(next.id, "next");
}
conformance!(
    a_job_whose_workers_keep_dying_fails_after_max_attempts_on_every_backend,
    a_job_whose_workers_keep_dying_fails_after_max_attempts
);

async fn evaluations_are_stored_exactly_in_order_by_the_lease_holder_only(
    store: Arc<dyn JobStore>,
) {
    assert!(store.insert(job("e"), usize::MAX).await.unwrap());
    store.lease("w1", 30.0, 3).await.unwrap().unwrap();
    for i in 0..5 {
        let seq = store
            .append_evaluations("e", "w1", &[evaluation(i as f64 + 0.1)])
            .await
            .unwrap();
        assert_eq!(seq, i + 1);
    }
    // A chunk in one call: consecutive sequence numbers, in the given order.
    let chunk: Vec<Evaluation> = (5..8).map(|i| evaluation(i as f64 + 0.1)).collect();
    assert_eq!(
        store.append_evaluations("e", "w1", &chunk).await.unwrap(),
        8
    );
    assert!(store
        .append_evaluations("e", "intruder", &[evaluation(9.0)])
        .await
        .is_err());
    let stored = store.evaluations("e", None).await.unwrap();
    let expected: Vec<Evaluation> = (0..8).map(|i| evaluation(i as f64 + 0.1)).collect();
    assert_eq!(stored, expected, "bit-exact round trip, in order");
    let page = store
        .evaluations(
            "e",
            Some(Page {
                limit: 2,
                offset: 3,
            }),
        )
        .await
        .unwrap();
    assert_eq!(page, expected[3..5]);
    assert_eq!(store.get("e").await.unwrap().unwrap().evaluations, 8);
}
conformance!(
    evaluations_are_stored_exactly_in_order_by_the_lease_holder_only_on_every_backend,
    evaluations_are_stored_exactly_in_order_by_the_lease_holder_only
);

async fn batch_tasks_are_leased_once_and_return_in_part_order(store: Arc<dyn JobStore>) {
    assert!(store.insert(job("t"), usize::MAX).await.unwrap());
    let coordinator = store.lease("coord", 30.0, 3).await.unwrap().unwrap();
    let parts: Vec<Vec<Vec<f64>>> = (0..6)
        .map(|p| vec![vec![p as f64, 0.5], vec![p as f64, 0.25]])
        .collect();
    assert!(store
        .post_tasks(
            "t",
            "someone-else",
            coordinator.attempts,
            0,
            TaskKind::Evaluate,
            &parts
        )
        .await
        .is_err());
    store
        .post_tasks(
            "t",
            "coord",
            coordinator.attempts,
            0,
            TaskKind::Evaluate,
            &parts,
        )
        .await
        .unwrap();
    assert!(store
        .batch_results("t", coordinator.attempts, 0)
        .await
        .unwrap()
        .is_none());
    let workers: Vec<_> = (0..3)
        .map(|w| {
            let store = store.clone();
            tokio::spawn(async move {
                let owner = format!("worker{w}");
                let mut done = Vec::new();
                while let Some(task) = store
                    .lease_task(&owner, 30.0, TaskScope::Others)
                    .await
                    .unwrap()
                {
                    assert_eq!(task.run_hash, "hash-t");
                    let evaluations: Vec<Evaluation> = task
                        .points
                        .iter()
                        .map(|p| evaluation(p[0] * 10.0 + p[1]))
                        .collect();
                    assert!(store
                        .complete_task(&task.key, &owner, &evaluations)
                        .await
                        .unwrap());
                    done.push(task.key.part);
                }
                done
            })
        })
        .collect();
    let mut parts_done = Vec::new();
    for w in workers {
        parts_done.extend(w.await.unwrap());
    }
    parts_done.sort();
    assert_eq!(parts_done, [0, 1, 2, 3, 4, 5], "each task leased once");
    let results = store
        .batch_results("t", coordinator.attempts, 0)
        .await
        .unwrap()
        .expect("all parts done");
    let expected: Vec<Evaluation> = parts
        .iter()
        .flatten()
        .map(|p| evaluation(p[0] * 10.0 + p[1]))
        .collect();
    assert_eq!(results, expected, "part order, point order, exact numbers");
    assert_eq!(
        store.evaluations("t", None).await.unwrap().len(),
        12,
        "task evaluations are the job's evaluations"
    );
}
conformance!(
    batch_tasks_are_leased_once_and_return_in_part_order_on_every_backend,
    batch_tasks_are_leased_once_and_return_in_part_order
);

async fn refined_tasks_return_their_values_and_add_no_evaluations(store: Arc<dyn JobStore>) {
    assert!(store.insert(job("r"), usize::MAX).await.unwrap());
    let coordinator = store.lease("coord", 30.0, 3).await.unwrap().unwrap();
    let attempt = coordinator.attempts;
    store
        .post_tasks(
            "r",
            "coord",
            attempt,
            0,
            TaskKind::Evaluate,
            &[vec![vec![1.0]]],
        )
        .await
        .unwrap();
    let parts = vec![vec![vec![0.1], vec![0.2]], vec![vec![0.3]]];
    store
        .post_tasks("r", "coord", attempt, 1, TaskKind::Refined(2), &parts)
        .await
        .unwrap();
    let first = store
        .lease_task("w", 30.0, TaskScope::Others)
        .await
        .unwrap()
        .unwrap();
    assert_eq!((first.kind, first.key.batch), (TaskKind::Evaluate, 0));
    assert!(store
        .complete_task(&first.key, "w", &[evaluation(1.0)])
        .await
        .unwrap());
    let mut values: Vec<(u32, Vec<RefinedOutcome>)> = Vec::new();
    while let Some(task) = store
        .lease_task("w", 30.0, TaskScope::Others)
        .await
        .unwrap()
    {
        assert_eq!(
            task.kind,
            TaskKind::Refined(2),
            "the level travels with the task"
        );
        let solved: Vec<RefinedOutcome> = task
            .points
            .iter()
            .map(|p| {
                Some(if p[0] == 0.2 {
                    Err("solver failed".into())
                } else {
                    Ok(vec![Some(p[0] * 3.0), None])
                })
            })
            .collect();
        assert!(!store
            .complete_refined_task(&task.key, "intruder", &solved)
            .await
            .unwrap());
        assert!(store
            .complete_refined_task(&task.key, "w", &solved)
            .await
            .unwrap());
        values.push((task.key.part, solved));
    }
    assert_eq!(values.len(), 2);
    let results = store
        .refined_results("r", attempt, 1)
        .await
        .unwrap()
        .expect("both parts done");
    assert_eq!(
        results,
        vec![
            Some(Ok(vec![Some(0.1 * 3.0), None])),
            Some(Err("solver failed".to_string())),
            Some(Ok(vec![Some(0.3 * 3.0), None])),
        ],
        "part order, point order, failures kept"
    );
    assert_eq!(
        store.evaluations("r", None).await.unwrap().len(),
        1,
        "refined solves are not search evaluations"
    );
}
conformance!(
    refined_tasks_return_their_values_and_add_no_evaluations_on_every_backend,
    refined_tasks_return_their_values_and_add_no_evaluations
);

async fn a_coordinator_takes_its_own_batch_only_and_a_released_task_is_leased_again(
    store: Arc<dyn JobStore>,
) {
    assert!(store.insert(job("s"), usize::MAX).await.unwrap());
    let coordinator = store.lease("coord", 30.0, 3).await.unwrap().unwrap();
    let attempt = coordinator.attempts;
    let parts = [vec![vec![1.0]], vec![vec![2.0]]];
    store
        .post_tasks("s", "coord", attempt, 0, TaskKind::Evaluate, &parts)
        .await
        .unwrap();
    // A worker's task loop never takes the tasks of a job its own process coordinates.
    assert!(store
        .lease_task("coord", 30.0, TaskScope::Others)
        .await
        .unwrap()
        .is_none());
    let batch = |batch| TaskScope::Batch {
        job: "s",
        attempt,
        batch,
    };
    assert!(store
        .lease_task("coord", 30.0, batch(1))
        .await
        .unwrap()
        .is_none());
    let mine = store
        .lease_task("coord", 30.0, batch(0))
        .await
        .unwrap()
        .expect("the coordinator takes a part of its batch");
    let theirs = store
        .lease_task("w", 30.0, TaskScope::Others)
        .await
        .unwrap()
        .expect("a worker takes the other part");
    assert_ne!(mine.key.part, theirs.key.part);
    assert!(!store.release_task(&theirs.key, "intruder").await.unwrap());
    assert!(store.release_task(&theirs.key, "w").await.unwrap());
    assert!(
        !store
            .complete_task(&theirs.key, "w", &[evaluation(2.0)])
            .await
            .unwrap(),
        "a released task is no longer the worker's"
    );
    let again = store
        .lease_task("coord", 30.0, batch(0))
        .await
        .unwrap()
        .expect("the released part");
    assert_eq!(again.key, theirs.key);
    for (task, value) in [(&mine, 1.0), (&again, 2.0)] {
        assert!(store
            .complete_task(&task.key, "coord", &[evaluation(value)])
            .await
            .unwrap());
    }
    let results = store.batch_results("s", attempt, 0).await.unwrap().unwrap();
    assert_eq!(results, [evaluation(1.0), evaluation(2.0)]);
}
conformance!(
    a_coordinator_takes_its_own_batch_only_and_a_released_task_is_leased_again_on_every_backend,
    a_coordinator_takes_its_own_batch_only_and_a_released_task_is_leased_again
);

async fn a_dead_workers_task_is_leased_again_and_a_taken_over_jobs_tasks_are_dropped(
    store: Arc<dyn JobStore>,
) {
    assert!(store.insert(job("d"), usize::MAX).await.unwrap());
    let first = store.lease("coord1", 0.3, 3).await.unwrap().unwrap();
    store
        .post_tasks(
            "d",
            "coord1",
            first.attempts,
            0,
            TaskKind::Evaluate,
            &[vec![vec![1.0]]],
        )
        .await
        .unwrap();
    let task = store
        .lease_task("dies", 0.2, TaskScope::Others)
        .await
        .unwrap()
        .unwrap();
    assert!(store
        .lease_task("other", 0.2, TaskScope::Others)
        .await
        .unwrap()
        .is_none());
    assert!(store.renew_task(&task.key, "dies", 0.2).await.unwrap());
    tokio::time::sleep(Duration::from_millis(350)).await;
    // The worker "dies" holding the task: its lease expires and another worker takes it.
    let again = store
        .lease_task("other", 30.0, TaskScope::Others)
        .await
        .unwrap()
        .expect("expired task");
    assert_eq!(again.key, task.key);
    assert!(!store.renew_task(&task.key, "dies", 0.2).await.unwrap());
    assert!(
        !store
            .complete_task(&task.key, "dies", &[evaluation(1.0)])
            .await
            .unwrap(),
        "a lost lease stores nothing"
    );
    assert!(store.evaluations("d", None).await.unwrap().is_empty());
    // The coordinator dies too: whoever takes the job over starts without the old tasks.
    let second = store
        .lease("coord2", 30.0, 3)
        .await
        .unwrap()
        .expect("expired");
    assert_eq!(second.attempts, first.attempts + 1);
    assert!(
        !store
            .complete_task(&again.key, "other", &[evaluation(1.0)])
            .await
            .unwrap(),
        "tasks of an earlier attempt are gone"
    );
    assert!(store
        .lease_task("other", 30.0, TaskScope::Others)
        .await
        .unwrap()
        .is_none());
    assert!(store.evaluations("d", None).await.unwrap().is_empty());
    let stale = TaskKey {
        attempt: first.attempts,
        ..again.key.clone()
    };
    assert!(store
        .batch_results("d", stale.attempt, stale.batch)
        .await
        .is_err());
}
conformance!(
    a_dead_workers_task_is_leased_again_and_a_taken_over_jobs_tasks_are_dropped_on_every_backend,
    a_dead_workers_task_is_leased_again_and_a_taken_over_jobs_tasks_are_dropped
);

async fn workers_announce_their_threads_by_heartbeat(store: Arc<dyn JobStore>) {
    assert_eq!(store.live_threads(5.0).await.unwrap(), 0);
    store.register_worker("w1", 2).await.unwrap();
    store.register_worker("w2", 1).await.unwrap();
    store.register_worker("w1", 3).await.unwrap();
    assert_eq!(store.live_threads(5.0).await.unwrap(), 4);
    tokio::time::sleep(Duration::from_millis(300)).await;
    store.register_worker("w2", 1).await.unwrap();
    assert_eq!(store.live_threads(0.2).await.unwrap(), 1, "w1 is silent");
}
conformance!(
    workers_announce_their_threads_by_heartbeat_on_every_backend,
    workers_announce_their_threads_by_heartbeat
);

async fn the_chosen_scene_is_recorded_by_the_lease_holder_for_the_workers(
    store: Arc<dyn JobStore>,
) {
    assert!(store.insert(job("c"), usize::MAX).await.unwrap());
    let input = store.job_input("c").await.unwrap().unwrap();
    assert_eq!(input.chosen_scene, None, "nothing chosen before the run");
    assert!(
        !store.record_chosen_scene("c", "coord", "{}").await.unwrap(),
        "a queued job has no coordinator"
    );
    store.lease("coord", 30.0, 3).await.unwrap().unwrap();
    assert!(!store
        .record_chosen_scene("c", "intruder", "{\"x\": 1}")
        .await
        .unwrap());
    let chosen = "{\"mesh\": {\"max_size\": 0.25}}";
    assert!(store
        .record_chosen_scene("c", "coord", chosen)
        .await
        .unwrap());
    let input = store.job_input("c").await.unwrap().unwrap();
    assert_eq!(input.chosen_scene.as_deref(), Some(chosen));
    assert_eq!(input.scene, job("c").scene, "the submitted scene is kept");
}
conformance!(
    the_chosen_scene_is_recorded_by_the_lease_holder_for_the_workers_on_every_backend,
    the_chosen_scene_is_recorded_by_the_lease_holder_for_the_workers
);

async fn an_idle_worker_finds_the_newest_job_coordinated_elsewhere(store: Arc<dyn JobStore>) {
    assert_eq!(store.coordinated_elsewhere("w").await.unwrap(), None);
    assert!(store.insert(job("p"), usize::MAX).await.unwrap());
    assert_eq!(
        store.coordinated_elsewhere("w").await.unwrap(),
        None,
        "a queued job has no coordinator yet"
    );
    store.lease("coord", 30.0, 3).await.unwrap().unwrap();
    assert_eq!(
        store.coordinated_elsewhere("w").await.unwrap(),
        Some(("p".to_string(), "hash-p".to_string()))
    );
    assert_eq!(
        store.coordinated_elsewhere("coord").await.unwrap(),
        None,
        "a coordinator does not prepare its own job twice"
    );
    // A coordinator whose lease expired is gone: nothing to prepare for until a new lease.
    store.renew("p", "coord", -1.0).await.unwrap();
    assert_eq!(store.coordinated_elsewhere("w").await.unwrap(), None);
    store
        .finish(
            "p",
            "coord",
            JobEnd::Failed {
                kind: ErrorCode::Solver,
                error: "y".into(),
            },
        )
        .await
        .unwrap();
    assert_eq!(store.coordinated_elsewhere("w").await.unwrap(), None);
}
conformance!(
    an_idle_worker_finds_the_newest_job_coordinated_elsewhere_on_every_backend,
    an_idle_worker_finds_the_newest_job_coordinated_elsewhere
);

async fn the_active_job_limit_holds_under_concurrent_submissions(store: Arc<dyn JobStore>) {
    let submitters: Vec<_> = (0..30)
        .map(|i| {
            let store = store.clone();
            tokio::spawn(async move { store.insert(job(&format!("s{i:02}")), 5).await.unwrap() })
        })
        .collect();
    let mut accepted = 0;
    for s in submitters {
        accepted += usize::from(s.await.unwrap());
    }
    assert_eq!(accepted, 5, "the limit is 5");
    assert_eq!(store.active_count().await.unwrap(), 5);
    assert!(!store.insert(job("late"), 5).await.unwrap());
    let leased = store.lease("w", 30.0, 3).await.unwrap().unwrap();
    store
        .finish(&leased.id, "w", JobEnd::Cancelled(None))
        .await
        .unwrap();
    assert!(store.insert(job("late"), 5).await.unwrap(), "room again");
}
conformance!(
    the_active_job_limit_holds_under_concurrent_submissions_on_every_backend,
    the_active_job_limit_holds_under_concurrent_submissions
);

/// Run one statement on the SQLite file at `path` through a connection of its own, as a fault
/// or another program would, and close it.
async fn execute_behind_the_store(path: &std::path::Path, statement: &'static str) {
    let raw = sqlx::SqlitePool::connect(&format!("sqlite://{}", path.display()))
        .await
        .unwrap();
    sqlx::query(statement).execute(&raw).await.unwrap();
    raw.close().await;
}

/// The newest ten jobs.
async fn first_ten(store: &dyn JobStore) -> Vec<wsm_service::jobs::JobRecord> {
    let page = Page {
        limit: 10,
        offset: 0,
    };
    store.list(None, page).await.unwrap()
}

async fn a_stopping_process_gives_its_leases_back_and_listings_leave_scenes_out(
    store: Arc<dyn JobStore>,
) {
    store.check_writable().await.unwrap();
    assert!(store.insert(job("r"), usize::MAX).await.unwrap());
    let listed = first_ten(&*store).await;
    assert_eq!(
        listed[0].scene, "",
        "a listing does not read scene documents"
    );
    assert_eq!(listed[0].scene_name, "scene");
    store.lease("leaving", 600.0, 3).await.unwrap().unwrap();
    assert_eq!(store.release_all("someone else").await.unwrap(), 0);
    assert!(
        store.lease("other", 60.0, 3).await.unwrap().is_none(),
        "still leased"
    );
    assert_eq!(store.release_all("leaving").await.unwrap(), 1);
    let queued = store.get("r").await.unwrap().unwrap();
    assert_eq!(queued.state, JobState::Queued);
    let again = store.lease("other", 60.0, 3).await.unwrap().unwrap();
    assert_eq!((again.id.as_str(), again.attempts), ("r", 2));
    assert!(
        store
            .append_evaluations("r", "leaving", &[evaluation(1.0)])
            .await
            .is_err(),
        "the old owner can no longer write"
    );
}
conformance!(
    a_stopping_process_gives_its_leases_back_and_listings_leave_scenes_out_on_every_backend,
    a_stopping_process_gives_its_leases_back_and_listings_leave_scenes_out
);

/// One damaged row (a JSON column that no longer decodes, an unknown state) is listed with the
/// reason and does not hide the others (SQLite: the rows are damaged behind the store's back).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_damaged_row_is_listed_with_the_reason_and_hides_nothing() {
    let dir = std::env::temp_dir().join(format!("wsm-damaged-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{}.db", uuid::Uuid::new_v4()));
    let store = SqlStore::open(path.to_str().unwrap()).await.unwrap();
    for id in ["ok1", "bad", "ok2"] {
        assert!(store.insert(job(id), usize::MAX).await.unwrap());
    }
    execute_behind_the_store(
        &path,
        "UPDATE jobs SET settings = '{not json', progress = 'x' WHERE id = 'bad'",
    )
    .await;
    let listed = first_ten(&store).await;
    assert_eq!(listed.len(), 3);
    let bad = listed.iter().find(|j| j.id == "bad").unwrap();
    let reason = bad.damaged.as_deref().unwrap();
    assert!(
        reason.contains("settings") && reason.contains("progress"),
        "{reason}"
    );
    assert!(listed
        .iter()
        .filter(|j| j.id != "bad")
        .all(|j| j.damaged.is_none()));
    let got = store.get("bad").await.unwrap().unwrap();
    assert!(got.damaged.is_some());
}

/// A file that is not SQLite, a damaged database and a read-only one are refused at start with
/// a message that says which, at once.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unusable_database_files_are_refused_at_start_with_the_reason() {
    let dir = std::env::temp_dir().join(format!("wsm-unusable-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let start = std::time::Instant::now();

    let text = dir.join("notes.txt");
    std::fs::write(&text, "these are my notes, not a database\n".repeat(200)).unwrap();
    let e = SqlStore::open(text.to_str().unwrap()).await.err().unwrap();
    assert!(e.to_string().contains("not a SQLite database"), "{e}");

    let good = dir.join(format!("{}.db", uuid::Uuid::new_v4()));
    drop(SqlStore::open(good.to_str().unwrap()).await.unwrap());
    let read_only = format!("sqlite://{}?mode=ro", good.display());
    let e = SqlStore::open(&read_only).await.err().unwrap();
    assert!(e.to_string().contains("does not take writes"), "{e}");

    // Damage the pages after the header (the schema and the jobs table).
    let damaged = dir.join(format!("{}.db", uuid::Uuid::new_v4()));
    {
        let store = SqlStore::open(damaged.to_str().unwrap()).await.unwrap();
        for i in 0..50 {
            assert!(store
                .insert(job(&format!("j{i}")), usize::MAX)
                .await
                .unwrap());
        }
    }
    execute_behind_the_store(&damaged, "PRAGMA wal_checkpoint(TRUNCATE)").await;
    let mut bytes = std::fs::read(&damaged).unwrap();
    for b in bytes.iter_mut().skip(4096).take(8192) {
        *b ^= 0x5a;
    }
    std::fs::write(&damaged, bytes).unwrap();
    let e = SqlStore::open(damaged.to_str().unwrap())
        .await
        .err()
        .unwrap();
    assert!(
        e.to_string().contains("damaged") || e.to_string().contains("malformed"),
        "{e}"
    );
    assert!(
        start.elapsed() < Duration::from_secs(10),
        "{:?}",
        start.elapsed()
    );
}
