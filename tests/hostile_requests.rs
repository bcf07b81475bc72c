//! One validation for jobs and solves (issue #23, defect 3): data that only the mesh or the
//! assembled problem can refuse — a segment off its body's boundary, contact zones of different
//! lengths, overlapping bodies, a hole outside its polygon, a criteria region outside the mesh,
//! an unbalanced floating body — answers `POST /v1/jobs` with the same 422 and path as
//! `POST /v1/solve`, before anything is queued.

mod common;

use common::{get, post, temp_db, Server};
use serde_json::{json, Value};

fn block() -> Value {
    serde_json::from_str(wsm_core::bundled::example("block-on-base").unwrap()).unwrap()
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
        let job = post(
            addr,
            "/v1/jobs",
            &json!({ "scene": scene, "settings": {"budget": 10} }),
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
    let mut scene = block();
    let mut polygon = vec![json!([0.5, 0.5]), json!([1.5, 0.5])];
    let n = 100_000;
    for k in 0..=n {
        polygon.push(json!([1.5 - k as f64 / n as f64, 1.0]));
    }
    scene["bodies"][1]["zones"][0]["polygon"] = json!(polygon);
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
