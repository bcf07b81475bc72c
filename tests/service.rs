//! The HTTP service against a real `wsm serve` process on a loopback port and a real SQLite
//! file: a job's result equals `wsm worst` on the same scene and seed; cancel; 20 concurrent
//! submissions on 2 workers; SIGKILL mid-job and restart on the same database (nothing lost,
//! nothing recomputed); bad requests answer the right status naming the field; the served
//! OpenAPI document equals the checked-in one.

mod common;

use std::time::{Duration, Instant};

use common::{extrema, get, http, post, temp_db, wait_finished, Server};
use serde_json::{json, Value};

fn submission(budget: usize, seed: u64) -> Value {
    json!({
        "example": "block-on-base",
        "settings": {"criteria": ["phi3", "phi6"], "budget": budget, "seed": seed}
    })
}

/// `wsm worst` on the same example and settings.
fn cli_worst(budget: usize, seed: u64) -> Value {
    common::cli_worst("block-on-base", "phi3,phi6", budget, seed)
}

/// A submission that makes its whole budget of solves: without derivatives (the vertex walk
/// certifies this block in 3 solves).
fn long_submission(budget: usize, seed: u64) -> Value {
    let mut s = submission(budget, seed);
    s["settings"]["derivatives"] = json!(false);
    s
}

#[test]
fn a_job_runs_to_the_result_of_wsm_worst_and_can_be_cancelled() {
    let db = temp_db("basic.db");
    let server = Server::start(&db, &["--workers", "1"]);
    let addr = &server.addr;
    assert_eq!(get(addr, "/healthz").json()["status"], "ok");
    let examples = get(addr, "/v1/examples").json();
    assert!(examples
        .as_array()
        .unwrap()
        .iter()
        .any(|e| e["name"] == "tunnel-fault"));

    let reply = post(addr, "/v1/jobs", &submission(30, 5));
    let id = reply.accepted_id();
    assert_eq!(
        reply.header("location"),
        Some(format!("/v1/jobs/{id}").as_str())
    );
    // The result of a job that has not finished is a conflict.
    let early = get(addr, &format!("/v1/jobs/{id}/result"));
    assert!(early.status == 409 || early.status == 200);
    let status = wait_finished(addr, &id, Duration::from_secs(120));
    assert_eq!(status["state"], "succeeded", "{status}");
    let result = get(addr, &format!("/v1/jobs/{id}/result")).json();
    let reference = cli_worst(30, 5);
    assert_eq!(extrema(&result), extrema(&reference), "service = wsm worst");
    assert_eq!(result["run_hash"], reference["run_hash"]);

    // Evaluations: JSON and CSV, one row per stored evaluation.
    let evaluations = get(addr, &format!("/v1/jobs/{id}/evaluations")).json();
    assert_eq!(
        evaluations.as_array().unwrap().len() as u64,
        result["evaluations"].as_u64().unwrap()
    );
    let csv = get(addr, &format!("/v1/jobs/{id}/evaluations?format=csv"));
    assert_eq!(csv.header("content-type"), Some("text/csv; charset=utf-8"));
    let text = String::from_utf8(csv.body).unwrap();
    assert_eq!(
        text.lines().count(),
        1 + evaluations.as_array().unwrap().len()
    );
    assert!(text.starts_with(
        "id,materials.rock.E,boundary[2].traction[0],contacts[joint].slip_limit,phi3,phi6,"
    ));
    let history = get(addr, &format!("/v1/jobs/{id}/history")).json();
    assert_eq!(history[0]["criterion"], "phi3");
    // Fields of the worst scenario of Φ6, as JSON and VTU.
    let fields = get(
        addr,
        &format!("/v1/jobs/{id}/fields?scenario=worst&criterion=phi6"),
    )
    .json();
    let nodes = fields["fields"]["nodes"].as_array().unwrap().len();
    assert!(nodes > 10);
    assert_eq!(
        fields["fields"]["displacement"].as_array().unwrap().len(),
        nodes
    );
    let phi6 = fields["summary"]["criteria"]["phi6"].as_f64().unwrap();
    let worst6 = result["criteria"][1]["worst"]["value"].as_f64().unwrap();
    assert_eq!(phi6, worst6, "the fields are those of the worst scenario");
    let vtu = get(
        addr,
        &format!("/v1/jobs/{id}/fields?criterion=phi3&format=vtu"),
    );
    assert!(String::from_utf8_lossy(&vtu.body).contains("<VTKFile"));
    assert!(vtu
        .header("content-disposition")
        .is_some_and(|d| d.contains(&format!("{id}-worst-phi3.vtu"))));
    // The nominal scenario: the summary of a plain solve of the scene, a VTU without criterion.
    let nominal = get(addr, &format!("/v1/jobs/{id}/fields?scenario=nominal")).json();
    let solved = post(addr, "/v1/solve", &json!({ "example": "block-on-base" })).json();
    assert_eq!(
        nominal["summary"]["criteria"],
        solved["summary"]["criteria"]
    );
    let vtu = get(
        addr,
        &format!("/v1/jobs/{id}/fields?scenario=nominal&format=vtu"),
    );
    let text = String::from_utf8_lossy(&vtu.body);
    assert!(text.contains("Name=\"scenario\"") && !text.contains("Name=\"criterion\""));
    let bad = get(addr, &format!("/v1/jobs/{id}/fields?scenario=sideways"));
    assert_eq!(bad.status, 422);
    assert_eq!(bad.json()["path"], "scenario");
    // SSE of a finished job: one status event, then the stream ends.
    let events = get(addr, &format!("/v1/jobs/{id}/events"));
    assert_eq!(events.header("content-type"), Some("text/event-stream"));
    assert!(String::from_utf8_lossy(&events.body).contains("event: status"));
    // Cancel a finished job: conflict.
    assert_eq!(
        post(addr, &format!("/v1/jobs/{id}/cancel"), &json!({})).status,
        409
    );

    // A long job, cancelled while running: partial result with status cancelled.
    let reply = post(addr, "/v1/jobs", &long_submission(20_000, 1));
    let long = reply.json()["id"].as_str().unwrap().to_string();
    let start = Instant::now();
    while get(addr, &format!("/v1/jobs/{long}")).json()["evaluations"]
        .as_u64()
        .unwrap_or(0)
        < 5
    {
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(20));
    }
    let cancel = post(addr, &format!("/v1/jobs/{long}/cancel"), &json!({}));
    assert_eq!(cancel.status, 202);
    let status = wait_finished(addr, &long, Duration::from_secs(30));
    assert_eq!(status["state"], "cancelled");
    let partial = get(addr, &format!("/v1/jobs/{long}/result")).json();
    assert_eq!(partial["status"], "cancelled");
    assert!(partial["criteria"][0]["worst"]["value"].is_number());
    let listed = get(addr, "/v1/jobs?state=cancelled").json();
    assert!(listed
        .as_array()
        .unwrap()
        .iter()
        .any(|j| j["id"] == long.as_str()));
}

/// No failure hidden (design §6): on a server whose search evaluations fail above one traction
/// and whose accuracy statements' refined solves all fail (`--inject-failures`), the job list
/// and the job's status count the result's warnings and the statement's failed solves, apart
/// from the search's failed evaluations.
#[test]
fn the_job_list_and_status_count_warnings_and_failed_refined_solves() {
    let db = temp_db("faults.db");
    let server = Server::start(
        &db,
        &[
            "--workers",
            "1",
            "--inject-failures",
            "boundary[2].traction[0]=375000",
            "--inject-failures",
            "refined:boundary[2].traction[0]=0",
        ],
    );
    let addr = &server.addr;
    let mut body = submission(30, 4);
    body["settings"]["accuracy_refinements"] = json!(1);
    let id = post(addr, "/v1/jobs", &body).json()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let status = wait_finished(addr, &id, Duration::from_secs(120));
    assert_eq!(status["state"], "succeeded", "{status}");
    let result = get(addr, &format!("/v1/jobs/{id}/result")).json();
    let statement = &result["accuracy"];
    assert_eq!(statement["complete"], false, "{statement}");
    // One refinement: every distinct worst/best data failed once.
    let failed = statement["failures"].as_array().unwrap();
    assert_eq!(failed.len() as u64, statement["points"].as_u64().unwrap());
    assert!(failed
        .iter()
        .all(|f| f["error"].as_str().unwrap().contains("injected failure")));
    for c in statement["criteria"].as_array().unwrap() {
        for side in ["worst", "best"] {
            assert!(c[side]["estimate"].is_null(), "{c}");
            assert!(c[side]["failure"].as_str().unwrap().contains("injected"));
        }
    }
    let warnings = result["warnings"].as_array().unwrap();
    let about_statement = warnings
        .iter()
        .filter(|w| w["kind"] == "accuracy" && w["subject"] == "accuracy statement")
        .count();
    assert_eq!(about_statement, failed.len(), "{warnings:#?}");
    // The search's failures are counted apart.
    let search_failures = result["failures"]["count"].as_u64().unwrap();
    assert!(search_failures > 0);
    let listed = get(addr, "/v1/jobs").json();
    let in_list = listed
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["id"] == id.as_str())
        .unwrap()
        .clone();
    for job in [
        &status,
        &get(addr, &format!("/v1/jobs/{id}")).json(),
        &in_list,
    ] {
        assert_eq!(
            job["warnings"].as_u64().unwrap(),
            warnings.len() as u64,
            "{job}"
        );
        assert_eq!(
            job["accuracy_failures"].as_u64().unwrap(),
            failed.len() as u64
        );
        assert_eq!(job["failures"].as_u64().unwrap(), search_failures);
    }
}

#[test]
fn twenty_concurrent_submissions_on_two_workers_all_finish_correctly() {
    let db = temp_db("concurrent.db");
    let server = Server::start(&db, &["--workers", "2"]);
    let addr = server.addr.clone();
    let ids: Vec<(String, u64)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..20u64)
            .map(|seed| {
                let addr = addr.clone();
                s.spawn(move || {
                    let reply = post(&addr, "/v1/jobs", &submission(12, seed));
                    (reply.accepted_id(), seed)
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for (id, seed) in &ids {
        let status = wait_finished(&addr, id, Duration::from_secs(300));
        assert_eq!(status["state"], "succeeded", "{status}");
        if seed % 5 == 0 {
            let result = get(&addr, &format!("/v1/jobs/{id}/result")).json();
            assert_eq!(
                extrema(&result),
                extrema(&cli_worst(12, *seed)),
                "seed {seed}"
            );
        }
    }
    assert_eq!(
        get(&addr, "/v1/jobs?limit=500")
            .json()
            .as_array()
            .unwrap()
            .len(),
        20
    );
}

#[test]
fn a_server_killed_mid_job_resumes_it_on_restart_losing_and_recomputing_nothing() {
    let db = temp_db("restart.db");
    let mut server = Server::start(&db, &["--workers", "1"]);
    let reply = post(&server.addr, "/v1/jobs", &long_submission(150, 9));
    let id = reply.json()["id"].as_str().unwrap().to_string();
    let start = Instant::now();
    loop {
        let status = get(&server.addr, &format!("/v1/jobs/{id}")).json();
        assert_ne!(
            status["state"], "succeeded",
            "the job must still be running when killed"
        );
        if status["evaluations"].as_u64().unwrap_or(0) >= 20 {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(10));
    }
    server.kill();
    let server = Server::start(&db, &["--workers", "1"]);
    let status = wait_finished(&server.addr, &id, Duration::from_secs(180));
    assert_eq!(status["state"], "succeeded", "{status}");
    assert_eq!(status["attempts"], 2, "leased again after the restart");
    let result = get(&server.addr, &format!("/v1/jobs/{id}/result")).json();
    assert_eq!(
        extrema(&result),
        extrema(&common::cli_worst_with(
            "block-on-base",
            "phi3,phi6",
            150,
            9,
            &["--no-derivatives"]
        )),
        "same result as uninterrupted"
    );
    let stored = get(&server.addr, &format!("/v1/jobs/{id}/evaluations")).json();
    assert_eq!(
        stored.as_array().unwrap().len() as u64,
        result["evaluations"].as_u64().unwrap(),
        "every evaluation stored exactly once"
    );
    assert!(result["new_evaluations"].as_u64().unwrap() < result["evaluations"].as_u64().unwrap());
}

#[test]
fn bad_requests_answer_the_right_status_and_name_the_field() {
    let db = temp_db("bad.db");
    let server = Server::start(
        &db,
        &[
            "--workers",
            "1",
            "--max-budget",
            "5000",
            "--max-body-bytes",
            "200000",
        ],
    );
    let addr = &server.addr;
    let scene: Value = serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    let with = |path: &str, value: Value| {
        let mut s = scene.clone();
        let mut target = &mut s;
        let parts: Vec<&str> = path.split('.').collect();
        for p in &parts[..parts.len() - 1] {
            target = match p.parse::<usize>() {
                Ok(i) => &mut target[i],
                Err(_) => &mut target[*p],
            };
        }
        let last = parts[parts.len() - 1];
        match last.parse::<usize>() {
            Ok(i) => target[i] = value,
            Err(_) => target[last] = value,
        }
        json!({ "scene": s })
    };
    // (body, status, path the error must name)
    let cases: Vec<(Value, u16, &str)> = vec![
        (
            with("materials.rock.E", json!(-1.0)),
            422,
            "scene.materials.rock.E",
        ),
        (
            with("materials.rock.nu", json!(0.5)),
            422,
            "scene.materials.rock.nu",
        ),
        (
            with("materials.rock.E", json!("ten")),
            422,
            "scene.materials.rock.E",
        ),
        (with("version", json!(2)), 422, "scene.version"),
        (
            with("mesh.max_size", json!(0.0)),
            422,
            "scene.mesh.max_size",
        ),
        (
            with("mesh.max_size", json!(1e-5)),
            422,
            "scene.mesh.max_size",
        ),
        (
            with("mesh.gmsh_file", json!("/etc/passwd")),
            422,
            "scene.mesh.gmsh_file",
        ),
        (
            with("boundary.0.segment", json!("nowhere")),
            422,
            "scene.boundary[0].segment",
        ),
        (
            with("contacts.0.between.0", json!("nowhere")),
            422,
            "scene.contacts[0].between",
        ),
        (
            with("contacts.0.slip_limit", json!(-5.0)),
            422,
            "scene.contacts[0].slip_limit",
        ),
        (
            with("uncertain.0.field", json!("materials.nope.E")),
            422,
            "scene.uncertain[0].field",
        ),
        (
            with("uncertain.0.interval", json!([2.0, 1.0])),
            422,
            "scene.uncertain[0].interval",
        ),
        (with("search.budget", json!(0)), 422, "scene.search.budget"),
        (
            with("search.budget", json!(1_000_000)),
            422,
            "scene.search.budget",
        ),
        (
            with("search.criteria.0", json!("phi9")),
            422,
            "scene.search.criteria[0]",
        ),
        (
            with("bodies.0.zones.0.material", json!("steel")),
            422,
            "scene.bodies[0].zones[0].material",
        ),
        (with("bodies", json!([])), 422, "scene.bodies"),
        (
            with("segments.bottom.body", json!("ghost")),
            422,
            "scene.segments.bottom.body",
        ),
        (with("unknown_field", json!(1)), 422, "scene"),
        (json!({"example": "nope"}), 422, "example"),
        (json!({}), 422, "scene"),
        (
            json!({"example": "hertz", "scene": scene.clone()}),
            422,
            "example",
        ),
        (
            json!({"example": "block-on-base", "extra": 1}),
            422,
            "extra",
        ),
        (
            json!({"example": "block-on-base", "settings": {"budget": 0}}),
            422,
            "settings.budget",
        ),
        (
            json!({"example": "block-on-base", "settings": {"budget": 10_000}}),
            422,
            "settings.budget",
        ),
        (
            json!({"example": "block-on-base", "settings": {"budget": -3}}),
            422,
            "settings.budget",
        ),
        (
            json!({"example": "block-on-base", "settings": {"criteria": []}}),
            422,
            "settings.criteria",
        ),
        (
            json!({"example": "block-on-base", "settings": {"criteria": ["phi7"]}}),
            422,
            "settings.criteria[0]",
        ),
        (
            json!({"example": "block-on-base", "settings": {"max_seconds": -1.0}}),
            422,
            "settings.max_seconds",
        ),
        (
            json!({"example": "block-on-base", "settings": {"threads": 4}}),
            422,
            "settings.threads",
        ),
        (
            json!({"example": "block-on-base", "settings": {"target_error": 2.0}}),
            422,
            "settings.target_error",
        ),
        (
            json!({"example": "block-on-base", "settings": {"target_error": 0.0}}),
            422,
            "settings.target_error",
        ),
        (
            json!({"example": "block-on-base", "settings": {"seed": "x"}}),
            422,
            "settings.seed",
        ),
        (
            json!({"example": "block-on-base", "settings": {"colour": "red"}}),
            422,
            "settings",
        ),
        (json!([1, 2]), 422, "$"),
    ];
    assert!(cases.len() >= 30);
    for (body, status, path) in &cases {
        let reply = post(addr, "/v1/jobs", body);
        let text = String::from_utf8_lossy(&reply.body).to_string();
        assert_eq!(reply.status, *status, "{path}: {text}");
        let error = reply.json();
        let got = error["path"].as_str().unwrap_or("");
        assert!(
            got.starts_with(path),
            "expected path {path}, got {got}: {text}"
        );
        assert!(!error["detail"].as_str().unwrap().is_empty());
    }
    // A nominal value outside its own interval: refused on submission, naming the entry (the
    // same rule as `wsm solve` and `wsm worst`; tests/dam.rs).
    for endpoint in ["/v1/jobs", "/v1/solve"] {
        let reply = post(
            addr,
            endpoint,
            &with("uncertain.0.interval", json!([1.1e10, 1.2e10])),
        );
        assert_eq!(reply.status, 422, "{endpoint}");
        let error = reply.json();
        assert_eq!(error["path"], "scene.uncertain[0]", "{endpoint}");
        let detail = error["detail"].as_str().unwrap();
        assert!(
            detail.contains(
                "the nominal value 10000000000 of materials.rock.E lies outside its interval \
                 [11000000000, 12000000000]"
            ),
            "{endpoint}: {detail}"
        );
    }
    // Malformed JSON, empty body, too large, unknown ids, wrong states, bad queries.
    let raw = |method: &str, path: &str, body: &[u8]| http(addr, method, path, Some(body), &[]);
    assert_eq!(raw("POST", "/v1/jobs", b"{not json").status, 400);
    assert_eq!(raw("POST", "/v1/jobs", b"").status, 400);
    assert_eq!(raw("POST", "/v1/solve", b"[1,").status, 400);
    let big = vec![b' '; 300_000];
    let reply = raw("POST", "/v1/jobs", &big);
    assert_eq!(reply.status, 413);
    assert_eq!(reply.json()["error"], "too_large");
    assert_eq!(get(addr, "/v1/jobs/does-not-exist").status, 404);
    assert_eq!(get(addr, "/v1/jobs/does-not-exist/result").status, 404);
    assert_eq!(
        post(addr, "/v1/jobs/does-not-exist/cancel", &json!({})).status,
        404
    );
    assert_eq!(get(addr, "/v1/examples/nope").status, 404);
    assert_eq!(get(addr, "/v1/jobs?limit=0").status, 422);
    assert_eq!(get(addr, "/v1/jobs?state=sleeping").status, 422);
    let solve = post(addr, "/v1/solve", &with("materials.rock.nu", json!(0.7)));
    assert_eq!(solve.status, 422);
    assert_eq!(solve.json()["path"], "scene.materials.rock.nu");
    let ok = post(addr, "/v1/solve", &json!({"example": "block-on-base"}));
    assert_eq!(ok.status, 200, "{}", String::from_utf8_lossy(&ok.body));
    assert!(ok.json()["summary"]["criteria"]["phi6"].is_number());
    // A queued job's result and fields are conflicts until it ran.
    let id = post(addr, "/v1/jobs", &submission(5000, 3)).json()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let reply = get(addr, &format!("/v1/jobs/{id}/fields?scenario=sideways"));
    assert!(reply.status == 409 || reply.status == 422);
    assert_eq!(
        post(addr, &format!("/v1/jobs/{id}/cancel"), &json!({})).status / 100,
        2
    );
}

#[test]
fn the_bearer_token_guards_job_endpoints_when_set() {
    let db = temp_db("token.db");
    let (server, line) = Server::start_with_token(&db, &[], Some("s3cret-token"));
    assert!(!line.contains("s3cret"), "the token is never printed");
    let addr = server.addr.clone();
    let body = submission(5, 1).to_string();
    let no = http(&addr, "POST", "/v1/jobs", Some(body.as_bytes()), &[]);
    assert_eq!(no.status, 401);
    let wrong = http(
        &addr,
        "POST",
        "/v1/jobs",
        Some(body.as_bytes()),
        &[("Authorization", "Bearer nope")],
    );
    assert_eq!(wrong.status, 401);
    let yes = http(
        &addr,
        "POST",
        "/v1/jobs",
        Some(body.as_bytes()),
        &[("Authorization", "Bearer s3cret-token")],
    );
    assert_eq!(yes.status, 202);
    // The scheme is case-insensitive; the token is not.
    for (header, status) in [
        ("bearer s3cret-token", 202),
        ("BEARER s3cret-token", 202),
        ("Basic s3cret-token", 401),
        ("bearer S3CRET-TOKEN", 401),
    ] {
        let reply = http(
            &addr,
            "POST",
            "/v1/jobs",
            Some(body.as_bytes()),
            &[("Authorization", header)],
        );
        assert_eq!(reply.status, status, "{header}");
    }
    // Reads of job data need it too (tests/hostile_requests.rs covers the read token and
    // --open-reads).
    assert_eq!(
        get(&addr, "/v1/jobs").status,
        401,
        "reading jobs needs the token"
    );
    let read = http(
        &addr,
        "GET",
        "/v1/jobs",
        None,
        &[("Authorization", "Bearer s3cret-token")],
    );
    assert_eq!(read.status, 200);
}

/// The scene's JSON Schema (design §5.2) is one document wherever it appears: derived from the
/// model, printed by `wsm schema`, checked in as openapi/scene.schema.json, served without a
/// token at /v1/schema/scene, and carried by the OpenAPI document where the scene is a body.
#[test]
fn the_scene_schema_is_the_derived_one_everywhere() {
    let derived = wsm_core::scene_schema();
    assert_eq!(
        derived["$schema"], "https://json-schema.org/draft/2020-12/schema",
        "the schema declares JSON Schema 2020-12"
    );
    let printed = std::process::Command::new(env!("CARGO_BIN_EXE_wsm"))
        .arg("schema")
        .output()
        .unwrap();
    assert!(printed.status.success());
    assert_eq!(
        serde_json::from_slice::<Value>(&printed.stdout).unwrap(),
        derived
    );
    let file: Value = serde_json::from_str(
        &std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/openapi/scene.schema.json"
        ))
        .expect("openapi/scene.schema.json"),
    )
    .unwrap();
    assert_eq!(
        file, derived,
        "regenerate with `cargo run --release -- schema > openapi/scene.schema.json`"
    );

    let db = temp_db("scene-schema.db");
    let (server, _) = Server::start_with_token(&db, &[], Some("s3cret-token"));
    let served = get(&server.addr, "/v1/schema/scene");
    assert_eq!(served.status, 200, "open without the token");
    assert_eq!(served.json(), derived);

    let openapi = get(&server.addr, "/openapi.json").json();
    let schemas = &openapi["components"]["schemas"];
    for body in ["JobSubmission", "SolveSubmission"] {
        let scene = schemas[body]["properties"]["scene"].to_string();
        assert!(
            scene.contains(r##""$ref":"#/components/schemas/Scene""##),
            "{body}.scene: {scene}"
        );
    }
    assert_eq!(schemas["Scene"]["properties"], {
        let mut root = derived["properties"].to_string();
        root = root.replace("#/$defs/", "#/components/schemas/Scene.");
        serde_json::from_str::<Value>(&root).unwrap()
    });
    for (name, def) in derived["$defs"].as_object().unwrap() {
        let def = def
            .to_string()
            .replace("#/$defs/", "#/components/schemas/Scene.");
        assert_eq!(
            schemas[format!("Scene.{name}")],
            serde_json::from_str::<Value>(&def).unwrap()
        );
    }
}

#[test]
fn the_served_openapi_document_is_the_checked_in_one() {
    let db = temp_db("openapi.db");
    let server = Server::start(&db, &[]);
    let served = get(&server.addr, "/openapi.json").json();
    let file: Value = serde_json::from_str(
        &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/openapi/openapi.json"))
            .expect("openapi/openapi.json (write it with `wsm openapi > openapi/openapi.json`)"),
    )
    .unwrap();
    assert_eq!(
        served, file,
        "regenerate with `cargo run --release -- openapi > openapi/openapi.json`"
    );
    assert_eq!(served["openapi"], "3.1.0");
    let paths = served["paths"].as_object().unwrap();
    for p in [
        "/v1/jobs",
        "/v1/jobs/{id}",
        "/v1/jobs/{id}/events",
        "/v1/jobs/{id}/result",
        "/v1/jobs/{id}/fields",
        "/v1/solve",
        "/v1/examples",
        "/healthz",
    ] {
        assert!(paths.contains_key(p), "{p} documented");
    }
}
