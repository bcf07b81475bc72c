//! Coordination overhead of one fan-out batch on a job store (issue #14; not part of the test
//! suite): a coordinator posts a batch of `parts` tasks of `points` points each, `workers`
//! in-process task loops lease them and complete them at once (no solve), and the coordinator
//! reads the results back. The median batch round trip is the store's share of every batch.
//!
//! cargo run --release --example store_bench -- postgres://postgres@127.0.0.1:5432/test [batches]
//! (a SQLite file path works too). Uses a fresh schema (PostgreSQL) or file, removed afterwards.

use std::sync::Arc;
use std::time::{Duration, Instant};

use wsm_core::{Evaluation, WorstRequest};
use wsm_service::jobs::sql::{Backend, SqlStore};
use wsm_service::jobs::{wait, JobStore, NewJob, TaskKind, TaskScope};

fn evaluation(point: &[f64]) -> Evaluation {
    Evaluation {
        point: point.to_vec(),
        values: Some(vec![1.0, 2.0]),
        error: None,
        max_kkt_residual: Some(1e-14),
        solve_seconds: 0.0,
        gradient: Vec::new(),
    }
}

async fn task_loop(store: Arc<dyn JobStore>, owner: String) {
    let mut work = store.work_signal();
    loop {
        work.borrow_and_update();
        match store.lease_task(&owner, 30.0, TaskScope::Others).await {
            Ok(Some(task)) => {
                let evaluations: Vec<Evaluation> =
                    task.points.iter().map(|p| evaluation(p)).collect();
                store
                    .complete_task(&task.key, &owner, &evaluations)
                    .await
                    .unwrap();
            }
            Ok(None) => wait(&mut work, Duration::from_millis(500)).await,
            Err(e) => panic!("{e}"),
        }
    }
}

async fn bench(db: &str, batches: usize) {
    let store: Arc<dyn JobStore> = Arc::new(SqlStore::open(db).await.unwrap());
    println!(
        "| workers | tasks per batch | points per task | batch round trip median [ms] | p90 [ms] |"
    );
    println!("|---|---|---|---|---|");
    let mut job_no = 0;
    for (workers, parts, points) in [(1, 1, 4), (2, 2, 4), (4, 4, 4), (8, 8, 4), (8, 8, 16)] {
        job_no += 1;
        let id = format!("bench{job_no}");
        let inserted = store
            .insert(
                NewJob {
                    id: id.clone(),
                    scene: "{}".into(),
                    settings: WorstRequest::default(),
                    scene_name: "bench".into(),
                    criteria: vec![wsm_core::Criterion::Phi3.into()],
                    budget: 1,
                    run_hash: format!("hash{job_no}"),
                },
                usize::MAX,
            )
            .await
            .unwrap();
        assert!(inserted);
        let job = store.lease("coordinator", 60.0, 3).await.unwrap().unwrap();
        let loops: Vec<_> = (0..workers)
            .map(|w| tokio::spawn(task_loop(store.clone(), format!("w{job_no}-{w}"))))
            .collect();
        let mut times = Vec::new();
        for batch in 0..batches as u64 {
            let tasks: Vec<Vec<Vec<f64>>> = (0..parts)
                .map(|p| {
                    (0..points)
                        .map(|i| vec![batch as f64, p as f64, i as f64])
                        .collect()
                })
                .collect();
            let start = Instant::now();
            let mut done = store.results_signal();
            done.borrow_and_update();
            store
                .post_tasks(
                    &id,
                    "coordinator",
                    job.attempts,
                    batch,
                    TaskKind::Evaluate,
                    &tasks,
                )
                .await
                .unwrap();
            while store
                .batch_results(&id, job.attempts, batch)
                .await
                .unwrap()
                .is_none()
            {
                wait(&mut done, Duration::from_millis(200)).await;
            }
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        for l in loops {
            l.abort();
        }
        times.sort_by(f64::total_cmp);
        println!(
            "| {workers} | {parts} | {points} | {:.2} | {:.2} |",
            times[times.len() / 2],
            times[times.len() * 9 / 10]
        );
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let db = args
        .next()
        .unwrap_or_else(|| "postgres://postgres@127.0.0.1:5432/test".into());
    let batches: usize = args.next().and_then(|b| b.parse().ok()).unwrap_or(100);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    runtime.block_on(async {
        match Backend::of(&db) {
            Backend::Postgres => {
                let schema = format!("wsm_bench_{}", uuid::Uuid::new_v4().simple());
                let admin = sqlx::PgPool::connect(&db).await.unwrap();
                sqlx::query(sqlx::AssertSqlSafe(format!("CREATE SCHEMA {schema}")))
                    .execute(&admin)
                    .await
                    .unwrap();
                let sep = if db.contains('?') { '&' } else { '?' };
                bench(
                    &format!("{db}{sep}options=-c%20search_path%3D{schema}"),
                    batches,
                )
                .await;
                sqlx::query(sqlx::AssertSqlSafe(format!("DROP SCHEMA {schema} CASCADE")))
                    .execute(&admin)
                    .await
                    .unwrap();
            }
            Backend::Sqlite => {
                let _ = std::fs::remove_file(&db);
                bench(&db, batches).await;
                for suffix in ["", "-wal", "-shm"] {
                    let _ = std::fs::remove_file(format!("{db}{suffix}"));
                }
            }
        }
    });
}
