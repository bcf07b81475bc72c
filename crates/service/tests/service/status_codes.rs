//! The status-code matrix of the HTTP API (design §5.3), in process: the service's app (API,
//! dashboard, request guard) called with `tower::ServiceExt::oneshot`, no socket. One table
//! lists (method, path, body, credentials, expected status) for every route and its error
//! cases; a route whose status changes, or a route of the OpenAPI document without a row, fails
//! the test. Jobs in each state (queued, running, succeeded, failed) are made through the store
//! as a worker would, the succeeded one with a real search through the front door.

use std::sync::Arc;
use std::time::Duration;

use axum::body::Body;
use axum::http::{header, Method, Request, StatusCode};
use axum::response::Response;
use axum::Router;
use serde_json::{json, Value};
use tower::ServiceExt;

use wsm_core::RunControl;
use wsm_service::api::{self, Access, AppState, Limits, SolveSlots};
use wsm_service::error_code::ErrorCode;
use wsm_service::jobs::health::StoreHealth;
use wsm_service::jobs::runner::Live;
use wsm_service::jobs::sql::SqlStore;
use wsm_service::jobs::{JobEnd, JobStore};

/// The server's tokens: `WRITE` opens everything, `READ` the reads.
const WRITE: &str = "write-token";
const READ: &str = "read-token";

/// The body limit of the test app \[bytes\].
const MAX_BODY: usize = 64 << 10;

/// Who asks.
#[derive(Debug, Clone, Copy)]
enum Who {
    Nobody,
    Reader,
    Writer,
    /// Two `Authorization` headers (refused by the guard).
    Twice,
}

/// What the request carries.
#[derive(Debug, Clone)]
enum Sent {
    Nothing,
    /// JSON declared as such.
    Json(Value),
    /// Bytes with a Content-Type (or none).
    Raw(&'static str, Option<&'static str>),
    /// A JSON body larger than the server's limit.
    TooLarge,
    /// A body that never arrives (the guard's timeout).
    Stalled,
}

/// The app of `wsm serve` over a fresh SQLite store, with `limits`, both tokens set.
async fn app(store: Arc<dyn JobStore>, limits: Limits) -> Router {
    let state = AppState {
        store,
        live: Arc::new(Live::default()),
        solves: SolveSlots::new(limits.max_concurrent_solves),
        limits: Arc::new(limits.clone()),
        access: Arc::new(Access {
            token: Some(WRITE.into()),
            read_token: Some(READ.into()),
            open_reads: false,
        }),
        health: Arc::new(StoreHealth::default()),
    };
    api::guarded(
        api::router(state).merge(wsm_service::web::router()),
        &limits,
    )
}

async fn sqlite() -> Arc<dyn JobStore> {
    let dir = std::env::temp_dir().join(format!("wsm-status-codes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{}.db", uuid::Uuid::new_v4()));
    Arc::new(SqlStore::open(path.to_str().unwrap()).await.unwrap())
}

fn limits() -> Limits {
    Limits {
        max_body_bytes: MAX_BODY,
        max_concurrent_solves: 2,
        body_timeout: Duration::from_millis(300),
        ..Limits::default()
    }
}

/// One request; its status.
async fn status(app: &Router, method: &Method, path: &str, who: Who, sent: &Sent) -> StatusCode {
    send(app, method, path, who, sent).await.status()
}

/// One request; the response.
async fn send(app: &Router, method: &Method, path: &str, who: Who, sent: &Sent) -> Response {
    let mut request = Request::builder().method(method.clone()).uri(path);
    let bearer = |token: &str| format!("Bearer {token}");
    match who {
        Who::Nobody => {}
        Who::Reader => request = request.header(header::AUTHORIZATION, bearer(READ)),
        Who::Writer => request = request.header(header::AUTHORIZATION, bearer(WRITE)),
        Who::Twice => {
            request = request
                .header(header::AUTHORIZATION, bearer(WRITE))
                .header(header::AUTHORIZATION, bearer(WRITE))
        }
    }
    let body = match sent {
        Sent::Nothing => Body::empty(),
        Sent::Json(value) => {
            request = request.header(header::CONTENT_TYPE, "application/json");
            Body::from(value.to_string())
        }
        Sent::Raw(text, content_type) => {
            if let Some(content_type) = content_type {
                request = request.header(header::CONTENT_TYPE, *content_type);
            }
            Body::from(*text)
        }
        Sent::TooLarge => {
            request = request.header(header::CONTENT_TYPE, "application/json");
            Body::from(format!("{{\"example\": \"{}\"}}", "x".repeat(MAX_BODY)))
        }
        Sent::Stalled => {
            request = request.header(header::CONTENT_TYPE, "application/json");
            Body::from_stream(futures_util::stream::pending::<
                Result<Vec<u8>, std::io::Error>,
            >())
        }
    };
    app.clone()
        .oneshot(request.body(body).unwrap())
        .await
        .unwrap()
}

/// A job submitted through the API (block-on-base, Φ3, a budget of `budget`); its id.
async fn submit(app: &Router, budget: usize) -> String {
    let submission = json!({"example": "block-on-base",
        "settings": {"criteria": ["phi3"], "budget": budget}});
    let request = Request::post("/v1/jobs")
        .header(header::AUTHORIZATION, format!("Bearer {WRITE}"))
        .header(header::CONTENT_TYPE, "application/json")
        .body(Body::from(submission.to_string()))
        .unwrap();
    let response = app.clone().oneshot(request).await.unwrap();
    assert_eq!(response.status(), StatusCode::ACCEPTED);
    let body = axum::body::to_bytes(response.into_body(), 1 << 20)
        .await
        .unwrap();
    let reply: Value = serde_json::from_slice(&body).unwrap();
    reply["id"].as_str().unwrap().to_string()
}

/// Lease the oldest queued job as worker `owner` (it must be `id`).
async fn lease(store: &Arc<dyn JobStore>, id: &str) -> wsm_service::jobs::JobRecord {
    let job = store.lease("test", 3600.0, 3).await.unwrap().unwrap();
    assert_eq!(job.id, id);
    job
}

/// Jobs in each state: (queued, queued to cancel, running, succeeded, failed).
async fn jobs(app: &Router, store: &Arc<dyn JobStore>) -> [String; 5] {
    let succeeded = submit(app, 4).await;
    let job = lease(store, &succeeded).await;
    let scene = wsm_core::parse_scene(&job.scene).unwrap();
    let outcome = tokio::task::spawn_blocking(move || {
        wsm_core::worst(scene, &job.settings, &RunControl::default()).unwrap()
    })
    .await
    .unwrap();
    let end = JobEnd::Succeeded(outcome);
    store.finish(&succeeded, "test", end).await.unwrap();
    let failed = submit(app, 4).await;
    lease(store, &failed).await;
    let end = JobEnd::Failed {
        kind: ErrorCode::Solver,
        error: "made to fail".into(),
    };
    store.finish(&failed, "test", end).await.unwrap();
    let running = submit(app, 4).await;
    lease(store, &running).await;
    [
        submit(app, 4).await,
        submit(app, 4).await,
        running,
        succeeded,
        failed,
    ]
}

/// (method, path, who, body, status). `{queued}`, `{cancellable}`, `{running}`,
/// `{succeeded}` and `{failed}` stand for jobs in that state; rows run in order (the cancels
/// change their jobs' states, so they come last).
fn table() -> Vec<(Method, &'static str, Who, Sent, u16)> {
    use Method as M;
    use Sent::*;
    use Who::*;
    let ok = json!({"example": "block-on-base"});
    let budget = |b: i64| json!({"example": "block-on-base", "settings": {"budget": b}});
    vec![
        // Open to anyone.
        (M::GET, "/healthz", Nobody, Nothing, 200),
        (M::GET, "/openapi.json", Nobody, Nothing, 200),
        (M::GET, "/v1/schema/scene", Nobody, Nothing, 200),
        (M::GET, "/v1/examples", Nobody, Nothing, 200),
        (M::GET, "/v1/examples/block-on-base", Nobody, Nothing, 200),
        (M::GET, "/v1/examples/nope", Nobody, Nothing, 404),
        (M::GET, "/v1/labels", Nobody, Nothing, 200),
        (M::GET, "/", Nobody, Nothing, 200),
        (M::GET, "/index.html", Nobody, Nothing, 200),
        (M::GET, "/assets/js/app.js", Nobody, Nothing, 200),
        (M::GET, "/assets/index.html", Nobody, Nothing, 404),
        (M::GET, "/assets/nope.js", Nobody, Nothing, 404),
        (M::GET, "/v1/nothing-here", Writer, Nothing, 404),
        (M::DELETE, "/v1/jobs", Writer, Nothing, 405),
        (M::GET, "/v1/jobs", Twice, Nothing, 400),
        // Listing.
        (M::GET, "/v1/jobs", Nobody, Nothing, 401),
        (M::GET, "/v1/jobs", Reader, Nothing, 200),
        (M::GET, "/v1/jobs", Writer, Nothing, 200),
        (
            M::GET,
            "/v1/jobs?state=failed&limit=500&offset=1",
            Reader,
            Nothing,
            200,
        ),
        (M::GET, "/v1/jobs?limit=0", Reader, Nothing, 422),
        (M::GET, "/v1/jobs?limit=501", Reader, Nothing, 422),
        (M::GET, "/v1/jobs?limit=abc", Reader, Nothing, 422),
        (M::GET, "/v1/jobs?offset=-1", Reader, Nothing, 422),
        (M::GET, "/v1/jobs?state=sleeping", Reader, Nothing, 422),
        // One job's status, events, scene.
        (M::GET, "/v1/jobs/{queued}", Nobody, Nothing, 401),
        (M::GET, "/v1/jobs/{queued}", Reader, Nothing, 200),
        (M::GET, "/v1/jobs/nope", Reader, Nothing, 404),
        (M::GET, "/v1/jobs/{succeeded}/events", Reader, Nothing, 200),
        (M::GET, "/v1/jobs/{queued}/events", Reader, Nothing, 200),
        (M::GET, "/v1/jobs/nope/events", Reader, Nothing, 404),
        (M::GET, "/v1/jobs/{queued}/events", Nobody, Nothing, 401),
        (M::GET, "/v1/jobs/{queued}/scene", Reader, Nothing, 200),
        (M::GET, "/v1/jobs/nope/scene", Reader, Nothing, 404),
        (M::GET, "/v1/jobs/{queued}/scene", Nobody, Nothing, 401),
        // Result and history: only a job that ran has them.
        (M::GET, "/v1/jobs/{succeeded}/result", Reader, Nothing, 200),
        (M::GET, "/v1/jobs/{queued}/result", Reader, Nothing, 409),
        (M::GET, "/v1/jobs/{running}/result", Reader, Nothing, 409),
        (M::GET, "/v1/jobs/{failed}/result", Reader, Nothing, 409),
        (M::GET, "/v1/jobs/nope/result", Reader, Nothing, 404),
        (M::GET, "/v1/jobs/{succeeded}/result", Nobody, Nothing, 401),
        (M::GET, "/v1/jobs/{succeeded}/history", Reader, Nothing, 200),
        (M::GET, "/v1/jobs/{queued}/history", Reader, Nothing, 409),
        (M::GET, "/v1/jobs/nope/history", Reader, Nothing, 404),
        (M::GET, "/v1/jobs/{succeeded}/history", Nobody, Nothing, 401),
        // Evaluations.
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations",
            Reader,
            Nothing,
            200,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations?format=csv",
            Reader,
            Nothing,
            200,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations?format=json&limit=2&offset=1",
            Reader,
            Nothing,
            200,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations?offset=1",
            Reader,
            Nothing,
            200,
        ),
        (
            M::GET,
            "/v1/jobs/{queued}/evaluations",
            Reader,
            Nothing,
            200,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations?format=xml",
            Reader,
            Nothing,
            422,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations?limit=10001",
            Reader,
            Nothing,
            422,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations?limit=1e3",
            Reader,
            Nothing,
            422,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations?offset=x",
            Reader,
            Nothing,
            422,
        ),
        (M::GET, "/v1/jobs/nope/evaluations", Reader, Nothing, 404),
        (
            M::GET,
            "/v1/jobs/{succeeded}/evaluations",
            Nobody,
            Nothing,
            401,
        ),
        // Fields of a scenario.
        (M::GET, "/v1/jobs/{succeeded}/fields", Reader, Nothing, 200),
        (
            M::GET,
            "/v1/jobs/{succeeded}/fields?scenario=best&criterion=phi3&format=vtu",
            Reader,
            Nothing,
            200,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/fields?scenario=nominal",
            Reader,
            Nothing,
            200,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/fields?scenario=sideways",
            Reader,
            Nothing,
            422,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/fields?format=png",
            Reader,
            Nothing,
            422,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/fields?criterion=phi6",
            Reader,
            Nothing,
            422,
        ),
        (
            M::GET,
            "/v1/jobs/{succeeded}/fields?criterion=phi9",
            Reader,
            Nothing,
            422,
        ),
        (M::GET, "/v1/jobs/{queued}/fields", Reader, Nothing, 409),
        (M::GET, "/v1/jobs/{failed}/fields", Reader, Nothing, 409),
        (M::GET, "/v1/jobs/nope/fields", Reader, Nothing, 404),
        (M::GET, "/v1/jobs/{succeeded}/fields", Nobody, Nothing, 401),
        // Submissions.
        (M::POST, "/v1/jobs", Writer, Json(ok.clone()), 202),
        (M::POST, "/v1/jobs", Nobody, Json(ok.clone()), 401),
        (M::POST, "/v1/jobs", Reader, Json(ok.clone()), 401),
        (
            M::POST,
            "/v1/jobs",
            Writer,
            Raw("{\"example\": ", Some("application/json")),
            400,
        ),
        (
            M::POST,
            "/v1/jobs",
            Writer,
            Raw("{\"example\": \"hertz\"}", None),
            415,
        ),
        (
            M::POST,
            "/v1/jobs",
            Writer,
            Raw("{\"example\": \"hertz\"}", Some("text/plain")),
            415,
        ),
        (M::POST, "/v1/jobs", Writer, TooLarge, 413),
        (M::POST, "/v1/jobs", Writer, Stalled, 408),
        (M::POST, "/v1/jobs", Writer, Json(json!({})), 422),
        (
            M::POST,
            "/v1/jobs",
            Writer,
            Json(json!({"example": "nope"})),
            422,
        ),
        (
            M::POST,
            "/v1/jobs",
            Writer,
            Json(json!({"example": "hertz", "extra": 1})),
            422,
        ),
        (M::POST, "/v1/jobs", Writer, Json(budget(0)), 422),
        (M::POST, "/v1/jobs", Writer, Json(budget(-3)), 422),
        (M::POST, "/v1/jobs", Writer, Json(budget(1_000_000)), 422),
        (
            M::POST,
            "/v1/jobs",
            Writer,
            Json(json!({"example": "hertz", "settings": []})),
            422,
        ),
        // Synchronous solves.
        (M::POST, "/v1/solve", Writer, Json(ok.clone()), 200),
        (M::POST, "/v1/solve", Nobody, Json(ok.clone()), 401),
        (M::POST, "/v1/solve", Reader, Json(ok.clone()), 401),
        (
            M::POST,
            "/v1/solve",
            Writer,
            Raw("not json", Some("application/json")),
            400,
        ),
        (M::POST, "/v1/solve", Writer, Raw("{}", None), 415),
        (
            M::POST,
            "/v1/solve",
            Writer,
            Json(json!({"example": "block-on-base", "scene": {}})),
            422,
        ),
        (M::POST, "/v1/solve", Writer, TooLarge, 413),
        // Cancels, last: they change the jobs' states.
        (
            M::POST,
            "/v1/jobs/{cancellable}/cancel",
            Nobody,
            Nothing,
            401,
        ),
        (
            M::POST,
            "/v1/jobs/{cancellable}/cancel",
            Reader,
            Nothing,
            401,
        ),
        (M::POST, "/v1/jobs/nope/cancel", Writer, Nothing, 404),
        (M::POST, "/v1/jobs/{succeeded}/cancel", Writer, Nothing, 409),
        (M::POST, "/v1/jobs/{failed}/cancel", Writer, Nothing, 409),
        (M::POST, "/v1/jobs/{running}/cancel", Writer, Nothing, 202),
        (
            M::POST,
            "/v1/jobs/{cancellable}/cancel",
            Writer,
            Nothing,
            200,
        ),
        (
            M::POST,
            "/v1/jobs/{cancellable}/cancel",
            Writer,
            Nothing,
            409,
        ),
    ]
}

/// `template` (an OpenAPI path, `/v1/jobs/{id}`) matches `path` (a row's, its query left out).
fn matches(template: &str, path: &str) -> bool {
    let path = path.split('?').next().unwrap_or(path);
    let (t, p): (Vec<&str>, Vec<&str>) = (template.split('/').collect(), path.split('/').collect());
    t.len() == p.len()
        && t.iter()
            .zip(&p)
            .all(|(t, p)| t == p || (t.starts_with('{') && !p.is_empty()))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_route_answers_each_case_with_its_status() {
    let store = sqlite().await;
    let app = app(store.clone(), limits()).await;
    let [queued, cancellable, running, succeeded, failed] = jobs(&app, &store).await;
    let mut wrong = Vec::new();
    for (method, path, who, sent, expected) in table() {
        let path = path
            .replace("{queued}", &queued)
            .replace("{cancellable}", &cancellable)
            .replace("{running}", &running)
            .replace("{succeeded}", &succeeded)
            .replace("{failed}", &failed);
        let got = status(&app, &method, &path, who, &sent).await;
        if got.as_u16() != expected {
            wrong.push(format!(
                "{method} {path} ({who:?}, {sent:?}): {got}, expected {expected}"
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "{} rows differ:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}

/// The 503 answers need a server at its limits: a full queue, every solve place taken.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_full_queue_and_a_busy_server_answer_503_with_retry_after() {
    let full = Limits {
        max_active_jobs: 0,
        max_concurrent_solves: 0,
        ..limits()
    };
    let app = app(sqlite().await, full).await;
    let ok = Sent::Json(json!({"example": "block-on-base"}));
    for path in ["/v1/jobs", "/v1/solve"] {
        let reply = send(&app, &Method::POST, path, Who::Writer, &ok).await;
        assert_eq!(reply.status(), StatusCode::SERVICE_UNAVAILABLE, "{path}");
        assert!(reply.headers().contains_key(header::RETRY_AFTER), "{path}");
    }
}

/// Every operation of the OpenAPI document has a row (a new route without one fails here).
#[test]
fn the_table_covers_every_route_of_the_openapi_document() {
    let document: Value = serde_json::from_str(&api::openapi_json().unwrap()).unwrap();
    let table = table();
    let mut missing = Vec::new();
    for (template, operations) in document["paths"].as_object().unwrap() {
        for method in operations.as_object().unwrap().keys() {
            let method: Method = method.to_uppercase().parse().unwrap();
            let covered = table
                .iter()
                .any(|(m, path, ..)| *m == method && matches(template, path));
            if !covered {
                missing.push(format!("{method} {template}"));
            }
        }
    }
    assert!(missing.is_empty(), "routes without a row: {missing:?}");
}
