//! A store that refuses writes while the server runs (docs/service.md, "Robustness": the store
//! heals; unavailable, not failed): another connection holds the SQLite database's write lock
//! (`BEGIN EXCLUSIVE`) past the server's store timeout. `/healthz` turns 503 "degraded" within a
//! few seconds and back to 200 "ok" after the lock is released, without a restart; submissions
//! during the outage get 503 `store_unavailable` (never 500) and afterwards 202; the job running
//! through the outage and those accepted after it all end `succeeded` — none is failed by the
//! outage.

mod common;

use std::time::{Duration, Instant};

use common::{get, post, temp_db, wait_finished, Server};
use serde_json::{json, Value};
use sqlx::{Connection, Executor};

fn submission(budget: usize, seed: u64) -> Value {
    json!({
        "example": "block-on-base",
        "settings": {"criteria": ["phi3", "phi6"], "budget": budget, "seed": seed,
                     "derivatives": false}
    })
}

/// Poll `/healthz` until its status is `status`; its body then, and how long it took.
fn health_becomes(addr: &str, status: u16, limit: Duration) -> (Value, Duration) {
    let start = Instant::now();
    loop {
        let reply = get(addr, "/healthz");
        if reply.status == status {
            return (reply.json(), start.elapsed());
        }
        assert!(
            start.elapsed() < limit,
            "/healthz still {} after {limit:?}: {}",
            reply.status,
            String::from_utf8_lossy(&reply.body)
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn a_locked_store_degrades_health_refuses_with_503_and_recovers_without_failing_jobs() {
    let db = temp_db("outage.db");
    let server = Server::start(&db, &["--workers", "1", "--store-timeout", "1"]);
    let addr = server.addr.clone();
    let (ok, _) = health_becomes(&addr, 200, Duration::from_secs(5));
    assert_eq!(ok["status"], "ok", "{ok}");

    // A job that runs through the outage (budget 40 without derivatives: a few seconds).
    let running = post(&addr, "/v1/jobs", &submission(40, 1));
    assert_eq!(running.status, 202);
    let running = running.json()["id"].as_str().unwrap().to_string();

    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let mut lock = runtime.block_on(async {
        let mut conn = sqlx::SqliteConnection::connect(&format!("sqlite://{db}"))
            .await
            .unwrap();
        conn.execute("BEGIN EXCLUSIVE").await.unwrap();
        conn
    });

    let (degraded, took) = health_becomes(&addr, 503, Duration::from_secs(8));
    assert_eq!(degraded["status"], "degraded", "{degraded}");
    assert_ne!(degraded["store"], "ok", "{degraded}");
    println!("degraded after {took:?}: {}", degraded["store"]);
    let refused = post(&addr, "/v1/jobs", &submission(10, 2));
    assert_eq!(
        refused.status,
        503,
        "{}",
        String::from_utf8_lossy(&refused.body)
    );
    assert_eq!(refused.json()["error"], "store_unavailable");
    assert!(refused.header("retry-after").is_some());
    // Reads still work.
    assert_eq!(get(&addr, &format!("/v1/jobs/{running}")).status, 200);

    runtime.block_on(async {
        lock.execute("ROLLBACK").await.unwrap();
        lock.close().await.unwrap();
    });
    let (ok, took) = health_becomes(&addr, 200, Duration::from_secs(8));
    assert_eq!(ok["status"], "ok", "{ok}");
    println!("ok again {took:?} after the lock was released");

    // Every pooled connection takes writes again: more submissions than the pool has
    // connections, all accepted.
    let mut accepted = vec![running];
    for seed in 0..10 {
        let reply = post(&addr, "/v1/jobs", &submission(4, 10 + seed));
        accepted.push(reply.accepted_id());
    }
    for id in &accepted {
        let done = wait_finished(&addr, id, Duration::from_secs(120));
        assert_eq!(done["state"], "succeeded", "{done}");
    }
}
