//! Scale-out with real processes on PostgreSQL (docs/scale-out.md, "Design" and "Tests"): a
//! `wsm serve` that only serves and three `wsm worker` processes on one database. A job's
//! evaluations are spread over the workers (each evaluation records who computed it); SIGKILL of a
//! worker holding a task, or of the process coordinating the job, loses nothing: the job finishes
//! with the result of a single-process `wsm worst`, bit for bit (its accuracy statement too, whose
//! refined solves are dealt out as well), with every evaluation stored exactly once.
//!
//! Needs `WSM_TEST_POSTGRES_URL` (set by `.ci/run`); without it the test says so and passes.

mod common;

use std::collections::HashSet;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{cli_worst_with, extrema, get, post, postgres_url, wait_finished, PgSchema, Server};
use serde_json::{json, Value};

const EXAMPLE: &str = "tunnel-fault";
const CRITERIA: &str = "phi3,phi5";
const BUDGET: usize = 90;
/// The jobs here run without derivatives: they must make their whole budget of solves for the
/// workers to share them (with derivatives the tunnel is certified in a few dozen solves, many
/// of them one at a time). The gradients' way through the store is checked by the store
/// conformance tests.
const PLAIN: &[&str] = &["--no-derivatives"];

struct Workers(Vec<Child>);

impl Workers {
    fn start(db: &str, count: usize) -> Workers {
        Workers(
            (0..count)
                .map(|_| {
                    Command::new(env!("CARGO_BIN_EXE_wsm"))
                        .args(["worker", "--db", db, "--threads", "1"])
                        .args(["--lease-seconds", "2"])
                        .stdout(Stdio::null())
                        .stderr(Stdio::null())
                        .spawn()
                        .unwrap()
                })
                .collect(),
        )
    }

    /// SIGKILL the worker whose lease owner name is `owner` (it carries the process id).
    fn kill_owner(&mut self, owner: &str) -> bool {
        for child in &mut self.0 {
            if owner.contains(&format!("-{}-", child.id())) {
                let _ = child.kill();
                let _ = child.wait();
                return true;
            }
        }
        false
    }
}

impl Drop for Workers {
    fn drop(&mut self) {
        for child in &mut self.0 {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// Queries on the test's schema.
struct Db {
    runtime: tokio::runtime::Runtime,
    pool: sqlx::PgPool,
}

impl Db {
    fn open(url: &str) -> Db {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let pool = runtime.block_on(sqlx::PgPool::connect(url)).unwrap();
        Db { runtime, pool }
    }

    /// The first column of every row, as text.
    fn column(&self, query: &'static str, job: &str) -> Vec<String> {
        self.runtime
            .block_on(
                sqlx::query_scalar::<_, String>(query)
                    .bind(job)
                    .fetch_all(&self.pool),
            )
            .unwrap()
    }

    fn coordinator(&self, job: &str) -> Option<String> {
        self.column(
            "SELECT COALESCE(lease_owner, '') FROM jobs WHERE id = $1",
            job,
        )
        .pop()
        .filter(|o| !o.is_empty())
    }

    fn task_holders(&self, job: &str) -> Vec<String> {
        self.column(
            "SELECT lease_owner FROM tasks WHERE job_id = $1 AND state = 'running'",
            job,
        )
    }

    fn chosen_scene(&self, job: &str) -> Vec<String> {
        self.column(
            "SELECT chosen_scene FROM jobs WHERE id = $1 AND chosen_scene IS NOT NULL",
            job,
        )
    }

    fn evaluation_workers(&self, job: &str) -> Vec<String> {
        self.column(
            "SELECT worker FROM evaluations WHERE job_id = $1 ORDER BY seq",
            job,
        )
    }
}

/// Submit the tunnel with `settings`; the job's id.
fn submit_settings(addr: &str, settings: Value) -> String {
    let reply = post(
        addr,
        "/v1/jobs",
        &json!({"example": EXAMPLE, "settings": settings}),
    );
    assert_eq!(
        reply.status,
        202,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    reply.json()["id"].as_str().unwrap().to_string()
}

fn submit(addr: &str, seed: u64) -> String {
    submit_settings(
        addr,
        json!({"criteria": ["phi3", "phi5"], "budget": BUDGET, "seed": seed, "derivatives": false}),
    )
}

/// A `wsm serve` that only serves and `workers` worker processes on a fresh schema (`None`,
/// and a note saying so, without `WSM_TEST_POSTGRES_URL`). Fields drop in order: the
/// processes stop before the schema goes, and the next cluster starts after both.
struct Cluster {
    db: Db,
    workers: Workers,
    server: Server,
    _schema: PgSchema,
    _alone: std::sync::MutexGuard<'static, ()>,
}

impl Cluster {
    fn start(workers: usize) -> Option<Cluster> {
        // One cluster at a time: its processes share the machine's cores, and a worker that
        // prepares its model while another cluster computes may miss a short job entirely.
        static ALONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let alone = ALONE
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let Some(server_url) = postgres_url() else {
            eprintln!("scale-out test skipped: WSM_TEST_POSTGRES_URL is not set");
            return None;
        };
        let schema = PgSchema::new(&server_url);
        let server = Server::start(&schema.url, &["--workers", "0"]);
        Some(Cluster {
            workers: Workers::start(&schema.url, workers),
            db: Db::open(&schema.url),
            server,
            _schema: schema,
            _alone: alone,
        })
    }
}

/// Wait until `pick` names a process to kill while the job runs (after some evaluations).
fn victim(addr: &str, id: &str, pick: impl Fn() -> Option<String>) -> String {
    let start = Instant::now();
    loop {
        let status = get(addr, &format!("/v1/jobs/{id}")).json();
        assert!(
            status["state"] != "succeeded",
            "the job must still be running when a process is killed"
        );
        if status["evaluations"].as_u64().unwrap_or(0) >= 10 {
            if let Some(owner) = pick() {
                return owner;
            }
        }
        assert!(start.elapsed() < Duration::from_secs(120), "{status}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The finished job matches the single-process run; every evaluation is stored once; the
/// evaluations came from more than one worker.
fn check_finished(addr: &str, db: &Db, id: &str, seed: u64) -> Value {
    let status = wait_finished(addr, id, Duration::from_secs(300));
    assert_eq!(status["state"], "succeeded", "{status}");
    let result = get(addr, &format!("/v1/jobs/{id}/result")).json();
    let alone = cli_worst_with(EXAMPLE, CRITERIA, BUDGET, seed, PLAIN);
    assert_eq!(
        extrema(&result),
        extrema(&alone),
        "same worst and best values and data as one process"
    );
    // The accuracy statement's refined solves were dealt out to the workers too.
    assert!(result["accuracy"]["points"].as_u64().unwrap() >= 2);
    assert_eq!(
        result["accuracy"]["criteria"], alone["accuracy"]["criteria"],
        "the same accuracy statement as one process, bit for bit"
    );
    let stored = get(addr, &format!("/v1/jobs/{id}/evaluations")).json();
    let stored = stored.as_array().unwrap();
    let points: HashSet<String> = stored.iter().map(|e| e["point"].to_string()).collect();
    assert_eq!(points.len(), stored.len(), "no point stored twice");
    assert_eq!(
        stored.len() as u64,
        result["evaluations"].as_u64().unwrap(),
        "every evaluation of the result is stored"
    );
    let workers: HashSet<String> = db.evaluation_workers(id).into_iter().collect();
    assert!(workers.len() >= 2, "evaluations spread over {workers:?}");
    status
}

#[test]
fn three_workers_share_a_job_and_survive_sigkill_of_a_worker_and_of_the_coordinator() {
    let Some(mut cluster) = Cluster::start(3) else {
        return;
    };
    let (db, server) = (&cluster.db, &cluster.server);

    // A worker that holds a task (not the coordinator) dies mid-batch.
    let id = submit(&server.addr, 3);
    let owner = victim(&server.addr, &id, || {
        let coordinator = db.coordinator(&id)?;
        db.task_holders(&id)
            .into_iter()
            .find(|holder| *holder != coordinator)
    });
    assert!(cluster.workers.kill_owner(&owner), "{owner} is one of ours");
    let status = check_finished(&server.addr, db, &id, 3);
    assert_eq!(status["attempts"], 1, "the coordinator kept the job");

    // The coordinating process dies: another worker takes the job over.
    let id = submit(&server.addr, 4);
    let owner = victim(&server.addr, &id, || db.coordinator(&id));
    assert!(cluster.workers.kill_owner(&owner), "{owner} is one of ours");
    let status = check_finished(&server.addr, db, &id, 4);
    assert_eq!(status["attempts"], 2, "taken over once");
}

#[test]
fn workers_evaluate_a_target_error_job_on_the_scene_its_coordinator_chose() {
    let Some(cluster) = Cluster::start(2) else {
        return;
    };
    let (db, server) = (&cluster.db, &cluster.server);
    // Long enough (a few seconds) for the second worker to mesh the chosen scene and take part.
    let (budget, seed) = (120, 6);
    let id = submit_settings(
        &server.addr,
        json!({"criteria": ["phi3"], "budget": budget, "seed": seed, "target_error": 0.05, "derivatives": false}),
    );
    let status = wait_finished(&server.addr, &id, Duration::from_secs(300));
    assert_eq!(status["state"], "succeeded", "{status}");
    let result = get(&server.addr, &format!("/v1/jobs/{id}/result")).json();
    let reference = cli_worst_with(
        EXAMPLE,
        "phi3",
        budget,
        seed,
        &["--target-error", "0.05", "--no-derivatives"],
    );
    assert_eq!(extrema(&result), extrema(&reference), "same as one process");
    // The coordinator stored its choice; the workers' evaluations, made on it, are part of
    // the bit-identical result.
    let chosen: Value = serde_json::from_str(&db.chosen_scene(&id).pop().expect("stored")).unwrap();
    let submitted = get(&server.addr, "/v1/examples/tunnel-fault").json();
    assert_ne!(
        chosen["mesh"]["max_size"], submitted["mesh"]["max_size"],
        "the 5 % target takes another mesh"
    );
    let workers: HashSet<String> = db.evaluation_workers(&id).into_iter().collect();
    assert!(workers.len() >= 2, "evaluations spread over {workers:?}");
}
