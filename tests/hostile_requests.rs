//! One validation for jobs and solves (design §5.2, last paragraph): data that only the mesh or the
//! assembled problem can refuse — a segment off its body's boundary, contact zones of different
//! lengths, overlapping bodies, a hole outside its polygon, a criteria region outside the mesh,
//! an unbalanced floating body — answers `POST /v1/jobs` with the same 422 and path as
//! `POST /v1/solve`, before anything is queued.

mod common;

use common::{get, post, temp_db, Server};
use serde_json::{json, Value};

fn block() -> Value {
    serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap()
}

/// The block's polygon with 100,000 vertices along its top edge (the probe's repro of defect 1).
fn block_with_a_huge_polygon() -> Value {
    let mut scene = block();
    let mut polygon = vec![json!([0.5, 0.5]), json!([1.5, 0.5])];
    let n = 100_000;
    for k in 0..=n {
        polygon.push(json!([1.5 - k as f64 / n as f64, 1.0]));
    }
    scene["bodies"][1]["zones"][0]["polygon"] = json!(polygon);
    scene
}

fn text(reply: &common::Reply) -> String {
    String::from_utf8_lossy(&reply.body).into_owned()
}

#[test]
fn jobs_are_refused_with_the_path_a_solve_names() {
    let db = temp_db("hostile.db");
    let server = Server::start(&db, &["--workers", "1"]);
    let addr = &server.addr;
    type Edit = fn(&mut Value);
    let cases: Vec<(&str, Edit)> = vec![
        ("segment off its body's boundary", |s| {
            s["segments"]["push"]["from"] = json!([0.7, 0.9]);
            s["segments"]["push"]["to"] = json!([0.7, 0.6]);
        }),
        ("contact zones of different lengths", |s| {
            s["segments"]["block_contact"]["to"] = json!([1.2, 0.5]);
        }),
        ("overlapping bodies", |s| {
            s["bodies"][1]["zones"][0]["polygon"] =
                json!([[0.5, 0.4], [1.5, 0.4], [1.5, 1.0], [0.5, 1.0]]);
        }),
        ("a hole outside its polygon", |s| {
            s["bodies"][0]["zones"][0]["holes"] =
                json!([[[3.0, 0.1], [3.2, 0.1], [3.2, 0.2], [3.0, 0.2]]]);
        }),
        ("a criteria region outside the mesh", |s| {
            s["criteria"]["regions"][0]["polygon"] =
                json!([[10.0, 10.0], [10.1, 10.0], [10.1, 10.1], [10.0, 10.1]]);
        }),
        ("an unbalanced floating body", |s| {
            // Frictionless: nothing holds the pushed block sideways.
            s["contacts"][0]["slip_limit"] = json!(0.0);
            s["uncertain"] = json!([{"field": "materials.rock.E", "interval": [8e9, 12e9]}]);
        }),
    ];
    let jobs_before = get(addr, "/v1/jobs").json().as_array().map_or(0, Vec::len);
    for (what, edit) in cases {
        let mut scene = block();
        edit(&mut scene);
        let solve = post(addr, "/v1/solve", &json!({ "scene": scene }));
        assert_eq!(solve.status, 422, "{what}: /v1/solve {}", text(&solve));
        // Criteria that every case leaves computable (Φ6 needs the moved region): a search checks
        // its criteria before it meshes, a solve does not look at them.
        let job = post(
            addr,
            "/v1/jobs",
            &json!({ "scene": scene, "settings": {"budget": 10, "criteria": ["phi3", "phi5"]} }),
        );
        assert_eq!(job.status, 422, "{what}: /v1/jobs {}", text(&job));
        let (solve, job) = (solve.json(), job.json());
        assert_eq!(job["error"], solve["error"], "{what}: {job} vs {solve}");
        assert_eq!(job["path"], solve["path"], "{what}: {job} vs {solve}");
    }
    let queued = post(
        addr,
        "/v1/jobs",
        &json!({ "scene": block(), "settings": {"budget": 10} }),
    );
    assert_eq!(queued.status, 202, "{}", text(&queued));
    let jobs_after = get(addr, "/v1/jobs").json().as_array().map_or(0, Vec::len);
    assert_eq!(jobs_after, jobs_before + 1, "only the valid job was queued");
}

#[test]
fn a_huge_polygon_or_a_repeated_criterion_is_refused_at_once_and_the_server_keeps_answering() {
    let db = temp_db("hostile-limits.db");
    let server = Server::start(&db, &["--workers", "1"]);
    let addr = &server.addr;
    let scene = block_with_a_huge_polygon();
    let start = std::time::Instant::now();
    let reply = post(addr, "/v1/solve", &json!({ "scene": scene }));
    assert_eq!(reply.status, 422, "{}", text(&reply));
    assert_eq!(reply.json()["path"], "scene.bodies[1].zones[0].polygon");
    assert!(
        start.elapsed() < std::time::Duration::from_secs(3),
        "{:?}",
        start.elapsed()
    );
    assert_eq!(get(addr, "/healthz").status, 200);

    let criteria: Vec<&str> = std::iter::repeat_n("phi3", 1000).collect();
    let reply = post(
        addr,
        "/v1/jobs",
        &json!({ "example": "block-on-base", "settings": {"criteria": criteria} }),
    );
    assert_eq!(reply.status, 422, "{}", text(&reply));
    assert_eq!(
        reply.json()["path"],
        "settings.criteria[1]",
        "{}",
        text(&reply)
    );
}

/// The probe's one request that killed the server (block-on-base refined to 0.0002: 23 GB, OOM;
/// now 0.66 GB on the sparse contact path), four times finer: refused before meshing as a solve
/// and as a job, naming the refinement to coarsen and the value that fits; a refinement that
/// fits the limit but not the triangle cap is named the same way.
#[test]
fn a_solve_beyond_the_memory_limit_is_refused_before_meshing_naming_the_size() {
    let db = temp_db("hostile-memory.db");
    let server = Server::start(&db, &["--workers", "1", "--max-solve-memory", "2G"]);
    let addr = &server.addr;
    let mut scene = block();
    scene["mesh"]["refine"][0]["max_size"] = json!(0.00005);
    for (path, body) in [
        ("/v1/solve", json!({ "scene": scene })),
        (
            "/v1/jobs",
            json!({ "scene": scene, "settings": {"criteria": ["phi3"]} }),
        ),
    ] {
        let start = std::time::Instant::now();
        let reply = post(addr, path, &body);
        assert_eq!(reply.status, 422, "{path}: {}", text(&reply));
        let error = reply.json();
        assert_eq!(error["path"], "scene.mesh.refine[0].max_size", "{error}");
        let detail = error["detail"].as_str().unwrap();
        assert!(
            detail.contains("contact pairs") && detail.contains("fits"),
            "{detail}"
        );
        assert!(
            start.elapsed() < std::time::Duration::from_secs(3),
            "{:?}",
            start.elapsed()
        );
    }
    assert_eq!(get(addr, "/healthz").status, 200);
    // The probe's undercounted mesh (max_size = refine = 0.0042: 432,721 triangles, estimated
    // 447,547 now, 2.2× under before) is over the synchronous solve's triangle cap.
    let mut scene = block();
    scene["mesh"]["max_size"] = json!(0.0042);
    scene["mesh"]["refine"][0]["max_size"] = json!(0.0042);
    let reply = post(addr, "/v1/solve", &json!({ "scene": scene }));
    assert_eq!(reply.status, 422, "{}", text(&reply));
    let path = reply.json()["path"].as_str().unwrap().to_string();
    assert!(path.starts_with("scene.mesh."), "{path}");
}

#[test]
fn numbers_beyond_double_precision_are_bad_input_not_server_errors() {
    let db = temp_db("hostile-magnitudes.db");
    let server = Server::start(&db, &["--workers", "1"]);
    let addr = &server.addr;
    let cases: Vec<(&str, Value, &str)> = vec![
        ("materials.rock.E", json!(1e308), "scene.materials.rock.E"),
        ("materials.rock.E", json!(1e-300), "scene.materials.rock.E"),
        (
            "materials.rock.specific_weight",
            json!(1e300),
            "scene.materials.rock.specific_weight",
        ),
        (
            "boundary.1.pressure",
            json!(1e308),
            "scene.boundary[1].pressure",
        ),
        (
            "boundary.2.traction",
            json!([1e200, 0.0]),
            "scene.boundary[2].traction[0]",
        ),
    ];
    for (field, value, path) in cases {
        let mut scene = block();
        let mut target = &mut scene;
        let parts: Vec<&str> = field.split('.').collect();
        for p in &parts[..parts.len() - 1] {
            target = match p.parse::<usize>() {
                Ok(i) => &mut target[i],
                Err(_) => &mut target[*p],
            };
        }
        target[parts[parts.len() - 1]] = value.clone();
        for endpoint in ["/v1/solve", "/v1/jobs"] {
            let reply = post(addr, endpoint, &json!({ "scene": scene }));
            assert_eq!(
                reply.status,
                422,
                "{field} = {value} at {endpoint}: {}",
                text(&reply)
            );
            assert_eq!(
                reply.json()["path"],
                path,
                "{field} = {value} at {endpoint}"
            );
        }
    }
}

#[test]
fn health_answers_within_100_ms_while_huge_scenes_are_validated() {
    let db = temp_db("hostile-health.db");
    let server = Server::start(&db, &["--workers", "1"]);
    let addr = server.addr.clone();
    let scene = block_with_a_huge_polygon();
    let body = serde_json::to_vec(&json!({ "scene": scene })).unwrap();
    let senders: Vec<_> = (0..2)
        .map(|i| {
            let (addr, body) = (addr.clone(), body.clone());
            std::thread::spawn(move || {
                let endpoint = if i == 0 { "/v1/solve" } else { "/v1/jobs" };
                common::http(&addr, "POST", endpoint, Some(&body), &[]).status
            })
        })
        .collect();
    let mut times = Vec::new();
    for _ in 0..20 {
        let start = std::time::Instant::now();
        assert_eq!(get(&addr, "/healthz").status, 200);
        times.push(start.elapsed());
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    for s in senders {
        assert_eq!(s.join().unwrap(), 422);
    }
    // Answered, not queued behind the checks (those take seconds each): typically within a few
    // ms; the bounds leave room for a loaded 2-core machine running other tests meanwhile —
    // the 18th fastest within 1 s, none beyond 2 s.
    times.sort();
    assert!(times[17] < std::time::Duration::from_secs(1), "{times:?}");
    assert!(times[19] < std::time::Duration::from_secs(2), "{times:?}");
}

#[test]
fn bodies_must_be_declared_json_without_repeated_keys_and_settings_must_be_an_object() {
    let db = temp_db("hostile-bodies.db");
    let server = Server::start(&db, &["--workers", "0"]);
    let addr = &server.addr;
    let body = br#"{"example": "block-on-base"}"#;
    // Without the Content-Type the test client adds to every body.
    let raw = |content_type: Option<&str>| {
        use std::io::{Read, Write};
        let mut stream = std::net::TcpStream::connect(addr).unwrap();
        let mut request = format!(
            "POST /v1/jobs HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Length: {}\r\n",
            body.len()
        );
        if let Some(t) = content_type {
            request.push_str(&format!("Content-Type: {t}\r\n"));
        }
        request.push_str("\r\n");
        stream.write_all(request.as_bytes()).unwrap();
        stream.write_all(body).unwrap();
        let mut reply = String::new();
        stream.read_to_string(&mut reply).unwrap();
        reply
    };
    for content_type in [
        None,
        Some("application/x-www-form-urlencoded"),
        Some("text/plain"),
    ] {
        let reply = raw(content_type);
        assert!(
            reply.starts_with("HTTP/1.1 415"),
            "{content_type:?}: {reply}"
        );
        assert!(reply.contains("Content-Type: application/json"), "{reply}");
    }
    assert!(raw(Some("application/json; charset=utf-8")).starts_with("HTTP/1.1 202"));

    let cases: [(&[u8], &str); 4] = [
        (
            br#"{"example": "block-on-base", "settings": {"budget": 10, "budget": 1000000}}"#,
            "settings.budget",
        ),
        (
            br#"{"example": "block-on-base", "example": "knee"}"#,
            "example",
        ),
        (
            br#"{"example": "block-on-base", "settings": []}"#,
            "settings",
        ),
        (br#"{"scene": [1, 2, 3]}"#, "scene"),
    ];
    for (body, path) in cases {
        let reply = common::http(addr, "POST", "/v1/jobs", Some(body), &[]);
        assert_eq!(reply.status, 422, "{}", text(&reply));
        assert_eq!(reply.json()["path"], path, "{}", text(&reply));
    }
}

#[test]
fn the_active_job_limit_holds_when_clients_race() {
    let db = temp_db("hostile-race.db");
    // No job slots: nothing finishes while the clients race.
    let server = Server::start(&db, &["--workers", "0", "--max-active-jobs", "5"]);
    let addr = server.addr.clone();
    let clients: Vec<_> = (0..2)
        .map(|_| {
            let addr = addr.clone();
            std::thread::spawn(move || {
                (0..15)
                    .map(|_| {
                        post(
                            &addr,
                            "/v1/jobs",
                            &json!({"example": "block-on-base", "settings": {"budget": 10}}),
                        )
                        .status
                    })
                    .collect::<Vec<u16>>()
            })
        })
        .collect();
    let codes: Vec<u16> = clients
        .into_iter()
        .flat_map(|c| c.join().unwrap())
        .collect();
    assert_eq!(codes.iter().filter(|&&c| c == 202).count(), 5, "{codes:?}");
    assert_eq!(codes.iter().filter(|&&c| c == 503).count(), 25, "{codes:?}");
    assert_eq!(get(&addr, "/healthz").json()["active_jobs"], 5);
}

#[test]
fn reads_need_a_token_when_the_server_has_one_unless_they_are_opened() {
    let db = temp_db("hostile-reads.db");
    let write = ("Authorization", "Bearer w-secret");
    let read = ("Authorization", "bearer r-secret");
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_wsm"));
    command.env("WSM_READ_TOKEN", "r-secret");
    let server = common::Server::start_command(command, &db, &["--workers", "0"], Some("w-secret"));
    let addr = &server.addr;
    let body = serde_json::to_vec(&json!({"example": "block-on-base", "settings": {"budget": 10}}))
        .unwrap();
    let submitted = common::http(addr, "POST", "/v1/jobs", Some(&body), &[write]);
    assert_eq!(submitted.status, 202);
    let id = submitted.json()["id"].as_str().unwrap().to_string();
    let reads = [
        "/v1/jobs".to_string(),
        format!("/v1/jobs/{id}"),
        format!("/v1/jobs/{id}/scene"),
        format!("/v1/jobs/{id}/evaluations"),
        format!("/v1/jobs/{id}/events"),
    ];
    for path in &reads {
        assert_eq!(get(addr, path).status, 401, "{path} without a token");
        let wrong = common::http(addr, "GET", path, None, &[("Authorization", "Bearer nope")]);
        assert_eq!(wrong.status, 401, "{path} with a wrong token");
    }
    for path in &reads[..4] {
        assert_eq!(
            common::http(addr, "GET", path, None, &[read]).status,
            200,
            "{path}"
        );
        assert_eq!(
            common::http(addr, "GET", path, None, &[write]).status,
            200,
            "{path}"
        );
    }
    let by_reader = common::http(addr, "POST", "/v1/jobs", Some(&body), &[read]);
    assert_eq!(by_reader.status, 401, "the read token cannot submit");
    let cancel = format!("/v1/jobs/{id}/cancel");
    assert_eq!(
        common::http(addr, "POST", &cancel, None, &[read]).status,
        401
    );
    for open in ["/healthz", "/v1/examples", "/openapi.json", "/"] {
        assert_eq!(get(addr, open).status, 200, "{open} stays open");
    }
    drop(server);

    let opened =
        Server::start_with_token(&db, &["--workers", "0", "--open-reads"], Some("w-secret")).0;
    assert_eq!(get(&opened.addr, &format!("/v1/jobs/{id}")).status, 200);
    let submit = common::http(&opened.addr, "POST", "/v1/jobs", Some(&body), &[]);
    assert_eq!(submit.status, 401, "writes still need the token");
}

/// Run `wsm serve` on `db` and expect it to stop by itself within `seconds`; its stderr.
fn refused_at_start(db: &str, seconds: u64) -> String {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_wsm"))
        .args(["serve", "--addr", "127.0.0.1:0", "--db", db])
        .env_remove("WSM_API_TOKEN")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            assert!(!status.success(), "{db}: the server should refuse to start");
            let mut stderr = String::new();
            use std::io::Read;
            child
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut stderr)
                .unwrap();
            return stderr;
        }
        if start.elapsed() > std::time::Duration::from_secs(seconds) {
            let _ = child.kill();
            panic!("{db}: still running after {seconds} s");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

#[test]
fn a_database_that_is_not_sqlite_or_read_only_is_refused_at_start_with_the_reason() {
    let notes = temp_db("notes.txt");
    std::fs::write(&notes, "my notes, not a database\n".repeat(100)).unwrap();
    let stderr = refused_at_start(&notes, 5);
    assert!(stderr.contains("not a SQLite database"), "{stderr}");
    assert_eq!(
        std::fs::read_to_string(&notes).unwrap(),
        "my notes, not a database\n".repeat(100),
        "the file is left as it was"
    );

    let db = temp_db("hostile-read-only.db");
    drop(Server::start(&db, &["--workers", "0"]));
    let stderr = refused_at_start(&format!("sqlite://{db}?mode=ro"), 5);
    assert!(stderr.contains("does not take writes"), "{stderr}");
}

fn send_sigterm(server: &Server) {
    let pid = server.child.id().to_string();
    let status = std::process::Command::new("kill")
        .args(["-TERM", &pid])
        .status()
        .unwrap();
    assert!(status.success());
}

/// Submit a tunnel job long enough (budget 300, Φ3) to be caught running.
fn submit_tunnel_phi3(addr: &str, seed: u64) -> common::Reply {
    post(
        addr,
        "/v1/jobs",
        // Without derivatives, so that it runs long (with them it is certified in a few solves).
        &json!({"example": "tunnel-fault", "settings": {"budget": 300, "criteria": ["phi3"], "seed": seed, "derivatives": false}}),
    )
}

#[test]
fn a_stopped_server_gives_its_running_job_back_and_another_resumes_it() {
    let db = temp_db("hostile-sigterm.db");
    let mut first = Server::start(&db, &["--workers", "1"]);
    let submitted = submit_tunnel_phi3(&first.addr, 3);
    assert_eq!(submitted.status, 202, "{}", text(&submitted));
    let id = submitted.json()["id"].as_str().unwrap().to_string();
    let start = std::time::Instant::now();
    loop {
        let s = get(&first.addr, &format!("/v1/jobs/{id}")).json();
        if s["state"] == "running" && s["evaluations"].as_u64().unwrap_or(0) > 0 {
            break;
        }
        assert!(start.elapsed() < std::time::Duration::from_secs(60), "{s}");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    send_sigterm(&first);
    let stopping = std::time::Instant::now();
    let status = first.child.wait().unwrap();
    assert!(
        stopping.elapsed() < std::time::Duration::from_secs(8),
        "{:?}",
        stopping.elapsed()
    );
    assert!(status.success(), "{status:?}");

    // A reader sees the job queued again at once (not `running` under a dead lease), waiting.
    let reader = Server::start(&db, &["--workers", "0"]);
    let waiting = get(&reader.addr, &format!("/v1/jobs/{id}")).json();
    assert_eq!(waiting["state"], "queued", "{waiting}");
    assert_eq!(waiting["phase"], "queued", "{waiting}");
    drop(reader);

    let second = Server::start(&db, &["--workers", "1"]);
    let done = common::wait_finished(&second.addr, &id, std::time::Duration::from_secs(180));
    assert_eq!(done["state"], "succeeded", "{done}");
    assert_eq!(done["attempts"], 2, "{done}");
}

#[test]
fn a_cancel_after_the_last_search_evaluation_still_ends_the_job_cancelled() {
    let db = temp_db("hostile-late-cancel.db");
    let server = Server::start(&db, &["--workers", "1"]);
    let addr = &server.addr;
    let submitted = post(
        addr,
        "/v1/jobs",
        // Without derivatives: the finite-difference sensitivities are the late phase to catch.
        &json!({"example": "tunnel-fault", "settings": {"budget": 40, "criteria": ["phi3", "phi5", "phi4"], "seed": 1, "derivatives": false}}),
    );
    let id = submitted.json()["id"].as_str().unwrap().to_string();
    let start = std::time::Instant::now();
    let phase = loop {
        let s = get(addr, &format!("/v1/jobs/{id}")).json();
        let phase = s["phase"].as_str().unwrap_or("").to_string();
        if phase == "sensitivities"
            || phase == "accuracy"
            || s["state"] != "running" && s["state"] != "queued"
        {
            break phase;
        }
        assert!(start.elapsed() < std::time::Duration::from_secs(120), "{s}");
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    assert!(
        phase == "sensitivities" || phase == "accuracy",
        "the late phases were not seen: {phase}"
    );
    let reply = post(addr, &format!("/v1/jobs/{id}/cancel"), &json!({}));
    assert_eq!(reply.status, 202, "{}", text(&reply));
    let done = common::wait_finished(addr, &id, std::time::Duration::from_secs(60));
    assert_eq!(
        done["state"], "cancelled",
        "the 202 promised a cancel: {done}"
    );
    let result = get(addr, &format!("/v1/jobs/{id}/result"));
    assert_eq!(result.status, 200, "the outcome is kept");
}

#[test]
fn a_job_whose_server_died_shows_it_waits_for_a_worker_not_its_last_phase() {
    let db = temp_db("hostile-stale-phase.db");
    let mut first = Server::start(&db, &["--workers", "1"]);
    let submitted = submit_tunnel_phi3(&first.addr, 4);
    let id = submitted.json()["id"].as_str().unwrap().to_string();
    let start = std::time::Instant::now();
    loop {
        let s = get(&first.addr, &format!("/v1/jobs/{id}")).json();
        if s["state"] == "running" && s["phase"] != "queued" && s["evaluations"].as_u64() > Some(0)
        {
            break;
        }
        assert!(start.elapsed() < std::time::Duration::from_secs(60), "{s}");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    first.kill(); // SIGKILL: the lease is left to expire (2 s)
    let reader = Server::start(&db, &["--workers", "0"]);
    let start = std::time::Instant::now();
    loop {
        let s = get(&reader.addr, &format!("/v1/jobs/{id}")).json();
        assert_eq!(s["state"], "running", "nobody took it over: {s}");
        if s["phase"] == "queued" {
            break;
        }
        assert!(
            start.elapsed() < std::time::Duration::from_secs(10),
            "stale phase: {s}"
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// The block on its base meshed finer (a solve of about a second here).
fn slow_block() -> Value {
    let mut scene = block();
    scene["mesh"]["max_size"] = json!(0.01);
    scene
}

#[test]
fn synchronous_solves_beyond_the_cap_get_503_with_retry_after() {
    let db = temp_db("hostile-solves.db");
    let server = Server::start(&db, &["--workers", "0", "--max-concurrent-solves", "1"]);
    let addr = server.addr.clone();
    let first = {
        let addr = addr.clone();
        std::thread::spawn(move || post(&addr, "/v1/solve", &json!({ "scene": slow_block() })))
    };
    // While the first runs (its request is given a head start), a second is refused at once.
    std::thread::sleep(std::time::Duration::from_millis(300));
    let mut refused = None;
    let start = std::time::Instant::now();
    while start.elapsed() < std::time::Duration::from_secs(20) {
        let reply = post(&addr, "/v1/solve", &json!({ "example": "block-on-base" }));
        if reply.status == 503 {
            refused = Some(reply);
            break;
        }
        assert_eq!(reply.status, 200, "{}", text(&reply));
        if first.is_finished() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let first = first.join().unwrap();
    assert_eq!(first.status, 200, "{}", text(&first));
    let refused = refused.expect("a solve refused while another ran");
    assert_eq!(refused.json()["error"], "busy", "{}", text(&refused));
    assert_eq!(refused.header("retry-after"), Some("2"));
    // The place is free again.
    let after = post(&addr, "/v1/solve", &json!({ "example": "block-on-base" }));
    assert_eq!(after.status, 200, "{}", text(&after));
}

#[test]
fn fields_of_a_mesh_beyond_the_limit_are_refused_naming_the_option() {
    let db = temp_db("hostile-fields.db");
    let server = Server::start(&db, &["--workers", "0", "--max-field-triangles", "100"]);
    let addr = &server.addr;
    let with_fields = post(
        addr,
        "/v1/solve",
        &json!({ "example": "block-on-base", "settings": {"fields": true} }),
    );
    assert_eq!(with_fields.status, 422, "{}", text(&with_fields));
    let body = with_fields.json();
    assert_eq!(body["path"], "settings.fields", "{body}");
    assert!(
        body["detail"]
            .as_str()
            .unwrap()
            .contains("at most 100 triangles"),
        "{body}"
    );
    let summary = post(addr, "/v1/solve", &json!({ "example": "block-on-base" }));
    assert_eq!(summary.status, 200, "{}", text(&summary));
    let triangles = summary.json()["summary"]["mesh"]["triangles"]
        .as_u64()
        .unwrap();
    assert!(triangles > 100, "{triangles}");
}

#[test]
fn query_errors_name_their_parameter_and_evaluation_pages_are_bounded() {
    let db = temp_db("hostile-queries.db");
    let server = Server::start(&db, &["--workers", "0"]);
    let addr = &server.addr;
    let job = post(addr, "/v1/jobs", &json!({ "example": "block-on-base" }));
    assert_eq!(job.status, 202, "{}", text(&job));
    let id = job.json()["id"].as_str().unwrap().to_string();
    let cases = [
        ("/v1/jobs?limit=abc".to_string(), "limit"),
        ("/v1/jobs?offset=-1".to_string(), "offset"),
        ("/v1/jobs?state=sleeping".to_string(), "state"),
        ("/v1/jobs?limit=501".to_string(), "limit"),
        (format!("/v1/jobs/{id}/evaluations?limit=10001"), "limit"),
        (format!("/v1/jobs/{id}/evaluations?limit=1e3"), "limit"),
        (format!("/v1/jobs/{id}/evaluations?offset=x"), "offset"),
        (format!("/v1/jobs/{id}/evaluations?format=xml"), "format"),
    ];
    for (path, parameter) in cases {
        let reply = get(addr, &path);
        assert_eq!(reply.status, 422, "{path}: {}", text(&reply));
        assert_eq!(reply.json()["path"], parameter, "{path}: {}", text(&reply));
    }
    let page = get(addr, &format!("/v1/jobs/{id}/evaluations?limit=10000"));
    assert_eq!(page.status, 200, "{}", text(&page));
}

#[test]
fn two_authorization_headers_are_refused() {
    let db = temp_db("hostile-auth.db");
    let (server, _) = Server::start_with_token(&db, &["--workers", "0"], Some("secret"));
    let addr = &server.addr;
    let both = [
        ("Authorization", "Bearer secret"),
        ("Authorization", "Bearer wrong"),
    ];
    for headers in [both, [both[1], both[0]]] {
        let reply = common::http(addr, "GET", "/v1/jobs", None, &headers);
        assert_eq!(reply.status, 400, "{}", text(&reply));
        assert_eq!(reply.json()["error"], "bad_request");
    }
    let one = common::http(addr, "GET", "/v1/jobs", None, &[both[0]]);
    assert_eq!(one.status, 200, "{}", text(&one));
}

/// The block with Coulomb friction F on its joint instead of the Tresca slip limit.
fn block_with_coulomb(f: f64) -> Value {
    let mut scene = block();
    let joint = scene["contacts"][0].as_object_mut().unwrap();
    joint.remove("slip_limit");
    joint.insert("friction_coefficient".into(), json!(f));
    scene["uncertain"].as_array_mut().unwrap().truncate(2);
    scene
}

/// `wsm worst` on `scene` (a file in the test's directory): its exit code and stderr.
fn worst_cli(scene: &Value, name: &str) -> (i32, String) {
    let file = temp_db(name);
    std::fs::write(&file, scene.to_string()).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_wsm"))
        .args(["worst", &file, "--budget", "5"])
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// One validation (design §5.2; nominal data §4.1, exit codes §5.1): what a solve refuses, a job
/// refuses at submission — the nominal data included — with the same 422 and path, and `wsm worst`
/// with the matching exit code (2 bad input, 3 unsolvable, as `wsm solve`); arrays where objects
/// belong and oversized coordinates are refused with their path, in plain words.
#[test]
fn jobs_refuse_what_a_solve_refuses_nominal_data_included() {
    let db = temp_db("hostile-nominal.db");
    let server = Server::start(&db, &["--workers", "0"]);
    let addr = &server.addr;
    let mut cases: Vec<(String, Value, &str, &str, i32)> = Vec::new();
    // A Coulomb coefficient that holds nothing: the pushed block slides (a solve says so).
    for f in [0.0, -0.0, 1e-300] {
        cases.push((
            format!("friction coefficient {f:e}"),
            block_with_coulomb(f),
            "unsolvable",
            "scene.bodies[1]",
            3,
        ));
    }
    cases.push((
        "a negative friction coefficient".into(),
        block_with_coulomb(-0.1),
        "invalid_input",
        "scene.contacts[0].friction_coefficient",
        2,
    ));
    let mut second = block();
    second["boundary"]
        .as_array_mut()
        .unwrap()
        .push(json!({"segment": "bottom", "displacement": [0.001, 0.0]}));
    cases.push((
        "a second displacement on one segment".into(),
        second,
        "invalid_input",
        "scene.boundary[3].displacement[0]",
        2,
    ));
    let mut outside = block();
    outside["boundary"][2]["traction"] = json!([500000.0, 0.0]);
    cases.push((
        "a nominal traction outside its interval".into(),
        outside,
        "invalid_input",
        "scene.uncertain[1]",
        2,
    ));
    for rock in [json!([1e10, 0.25]), json!([1, 2])] {
        let mut scene = block();
        scene["materials"]["rock"] = rock.clone();
        cases.push((
            format!("materials.rock = {rock}"),
            scene,
            "invalid_input",
            "scene.materials.rock",
            2,
        ));
    }
    let mut huge = block();
    huge["bodies"][1]["zones"][0]["polygon"][2] = json!([1e308, 1e308]);
    cases.push((
        "coordinates of 1e308".into(),
        huge,
        "invalid_input",
        "scene.bodies[1].zones[0].polygon[2]",
        2,
    ));
    for (k, (what, scene, error, path, code)) in cases.iter().enumerate() {
        for endpoint in ["/v1/solve", "/v1/jobs"] {
            let reply = post(addr, endpoint, &json!({ "scene": scene }));
            assert_eq!(reply.status, 422, "{what} at {endpoint}: {}", text(&reply));
            let body = reply.json();
            assert_eq!(body["error"], *error, "{what} at {endpoint}: {body}");
            assert_eq!(body["path"], *path, "{what} at {endpoint}: {body}");
            let detail = body["detail"].as_str().unwrap();
            for word in ["zero area", "struct", "Poisson", "f64", "sequence"] {
                assert!(!detail.contains(word), "{what} at {endpoint}: {detail}");
            }
        }
        let (exit, stderr) = worst_cli(scene, &format!("nominal-{k}.json"));
        assert_eq!(exit, *code, "{what}: wsm worst said {stderr}");
        // The command line prints the message: a bad field by its path, an unsolvable body
        // by its name.
        let named = if *code == 3 {
            "body 'block'"
        } else {
            path.trim_start_matches("scene.")
        };
        assert!(stderr.contains(named), "{what}: {stderr}");
    }
    let listed = get(addr, "/v1/jobs").json();
    assert_eq!(
        listed.as_array().map_or(0, Vec::len),
        0,
        "nothing was queued"
    );
}

/// Item 8: a job whose scene has no `search` is told to add criteria to its settings (or the
/// scene), and a wrong criterion of the scene's own search block is named in the scene.
#[test]
fn missing_or_wrong_criteria_are_named_where_the_user_fixes_them() {
    let db = temp_db("hostile-criteria-paths.db");
    let server = Server::start(&db, &["--workers", "0"]);
    let addr = &server.addr;
    let mut scene = block();
    scene.as_object_mut().unwrap().remove("search");
    let reply = post(addr, "/v1/jobs", &json!({ "scene": scene }));
    assert_eq!(reply.status, 422, "{}", text(&reply));
    let body = reply.json();
    assert_eq!(body["path"], "settings.criteria", "{body}");
    assert!(
        body["detail"].as_str().unwrap().contains("search.criteria"),
        "{body}"
    );
    let with_criteria = post(
        addr,
        "/v1/jobs",
        &json!({ "scene": scene, "settings": {"criteria": ["phi3"], "budget": 10} }),
    );
    assert_eq!(with_criteria.status, 202, "{}", text(&with_criteria));

    let mut scene = block();
    scene["search"]["criteria"] = json!(["phi3", "phi1"]);
    let reply = post(addr, "/v1/jobs", &json!({ "scene": scene }));
    assert_eq!(reply.status, 422, "{}", text(&reply));
    assert_eq!(reply.json()["path"], "scene.search.criteria[1]");
    let reply = post(
        addr,
        "/v1/jobs",
        &json!({ "scene": block(), "settings": {"criteria": ["phi3", "phi1"]} }),
    );
    assert_eq!(reply.json()["path"], "settings.criteria[1]");
}

/// Item 7: request settings of the wrong JSON kind are told in JSON words, without Rust type
/// names.
#[test]
fn settings_of_the_wrong_kind_are_told_in_json_words() {
    let db = temp_db("hostile-plain-words.db");
    let server = Server::start(&db, &["--workers", "0"]);
    let addr = &server.addr;
    let cases = [
        (
            json!({"budget": {}}),
            "settings.budget",
            "non-negative whole number",
        ),
        (
            json!({"budget": -3}),
            "settings.budget",
            "non-negative whole number",
        ),
        (
            json!({"max_seconds": "soon"}),
            "settings.max_seconds",
            "a number",
        ),
        (json!({"criteria": "phi3"}), "settings.criteria", "an array"),
        (
            json!({"derivatives": 1}),
            "settings.derivatives",
            "a boolean",
        ),
    ];
    for (settings, path, words) in cases {
        let reply = post(
            addr,
            "/v1/jobs",
            &json!({"example": "block-on-base", "settings": settings}),
        );
        assert_eq!(reply.status, 422, "{settings}: {}", text(&reply));
        let body = reply.json();
        assert_eq!(body["path"], path, "{body}");
        let detail = body["detail"].as_str().unwrap();
        assert!(detail.contains(words), "{settings}: {detail}");
        for word in [
            "WorstRequest",
            "struct",
            "u64",
            "usize",
            "f64",
            "map",
            "sequence",
        ] {
            assert!(!detail.contains(word), "{settings}: {detail}");
        }
    }
}

/// The block with `n` uncertain pressures on its top (the top pressure split into n parts of
/// 1e6/n Pa, each uncertain in [lo/n, 1.1e6/n]) besides its own three uncertain data.
fn block_with_uncertain_pressures(n: usize, lo: f64) -> Value {
    let mut scene = block();
    scene["boundary"][1]["pressure"] = json!(0.0);
    for k in 0..n {
        let b = scene["boundary"].as_array().unwrap().len();
        scene["boundary"]
            .as_array_mut()
            .unwrap()
            .push(json!({"segment": "top", "pressure": 1e6 / n as f64}));
        scene["uncertain"].as_array_mut().unwrap().push(json!({
            "field": format!("boundary[{b}].pressure"),
            "interval": [lo / n as f64, 1.1e6 / n as f64],
            "name": format!("p{k}"),
        }));
    }
    scene
}

/// Item 5: the submission checks of 64 uncertain data answer within 2 s (they took 2.6–
/// 9.9 s: 4,096 vertices, each with its loads assembled) and stay exact: 61 pressures of the
/// block's top whose least total cannot hold the pushed block upright are refused at that
/// vertex — one of 2^61, which a sample of the box would not meet.
#[test]
fn submission_checks_of_many_uncertain_data_are_quick_and_exact() {
    let db = temp_db("hostile-quick-checks.db");
    let server = Server::start(&db, &["--workers", "0"]);
    let addr = &server.addr;
    let scene = block_with_uncertain_pressures(61, 2e5);
    assert_eq!(scene["uncertain"].as_array().unwrap().len(), 64);
    let mut times = Vec::new();
    for _ in 0..3 {
        let start = std::time::Instant::now();
        let reply = post(
            addr,
            "/v1/jobs",
            &json!({ "scene": scene, "settings": {"budget": 10} }),
        );
        times.push(start.elapsed());
        assert_eq!(reply.status, 202, "{}", text(&reply));
    }
    times.sort();
    // 2 s (below the 2.6 s of the old vertex enumeration) leaves room for a
    // loaded 2-core machine.
    assert!(
        times[1] < std::time::Duration::from_secs(2),
        "median {:?} of {times:?}",
        times[1]
    );
    // The pushed block (2e5 N/m at 0.25 m) tips unless ≈ 1e5 N/m press it down: a least total
    // of 5e4 N/m from the pressures (weight 12,250 N/m) cannot hold it.
    let reply = post(
        addr,
        "/v1/jobs",
        &json!({ "scene": block_with_uncertain_pressures(61, 5e4), "settings": {"budget": 10} }),
    );
    assert_eq!(reply.status, 422, "{}", text(&reply));
    let body = reply.json();
    assert_eq!(body["path"], "scene.uncertain", "{body}");
    let detail = body["detail"].as_str().unwrap();
    assert!(
        detail.contains(&format!("p0 = {}", 5e4 / 61.0)) && detail.contains("p60 = "),
        "{detail}"
    );
}
