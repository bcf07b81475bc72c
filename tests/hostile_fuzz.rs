//! A bounded black-box fuzz of `wsm serve` (design §5.3; docs/service.md, "Hostile requests"):
//! every number, string, list and object of a bundled scene replaced in turn by hostile values
//! (huge, tiny, negative, zero, wrong types, empty and oversized lists, long strings), each member
//! removed, plus the corpus of bad requests found by the independent probe
//! (`tests/data/hostile_corpus.json`). Every answer must be below 500, no larger than
//! [`MAX_REPLY`], within [`MAX_SECONDS`], and a 4xx about a field must name it in plain words (no
//! Rust type names); `/healthz` must answer after every request; the corpus cases marked
//! `refused_at_submission` (jobs a solve would refuse, design §5.2) must be refused with a path. The counts are printed
//! (kinds tried / 4xx with a path / 5xx / hangs).

mod common;

use std::time::{Duration, Instant};

use common::{get, http, temp_db, Server};
use serde_json::{json, Value};

/// Largest acceptable response to a bad or mutated request \[bytes\].
const MAX_REPLY: usize = 1 << 20;
/// Longest acceptable answer \[s\].
const MAX_SECONDS: u64 = 20;

/// Replacements tried at every leaf.
fn hostile_values() -> Vec<Value> {
    vec![
        json!(1e308),
        json!(-1e308),
        json!(1e-308),
        json!(0),
        json!(-1),
        json!("x".repeat(300)),
        json!(null),
        json!([]),
        json!({}),
        json!(true),
        json!(vec![0.5; 20_000]),
        // An object's members by position (strict bodies, design §5.3) and a vanishing number.
        json!([1e10, 0.25]),
        json!(1e-300),
    ]
}

/// Paths (as pointer strings) of every value in a JSON document.
fn pointers(value: &Value, at: String, out: &mut Vec<String>) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                pointers(v, format!("{at}/{k}"), out);
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                pointers(v, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
    if !at.is_empty() {
        out.push(at);
    }
}

fn without(doc: &Value, pointer: &str) -> Value {
    let mut doc = doc.clone();
    let (parent, key) = pointer.rsplit_once('/').unwrap();
    match doc.pointer_mut(parent) {
        Some(Value::Object(map)) => {
            map.remove(key);
        }
        Some(Value::Array(items)) => {
            items.remove(key.parse::<usize>().unwrap());
        }
        _ => {}
    }
    doc
}

#[derive(Default)]
struct Tally {
    tried: usize,
    accepted: usize,
    refused_with_path: usize,
    /// 4xx answers without a path (malformed JSON, unknown example, ...): status and case.
    refused_without_path: Vec<String>,
    server_errors: Vec<String>,
    hangs: Vec<String>,
    oversized: Vec<String>,
    /// 4xx answers whose message names a Rust type (a message speaks of the scene, not the code).
    rust_words: Vec<String>,
}

/// Rust and serde vocabulary a message must not show (`expected struct WorstRequest`,
/// `invalid type: map, expected u64`).
const RUST_WORDS: [&str; 8] = [
    "struct ",
    "expected f64",
    "expected u64",
    "expected usize",
    "expected u32",
    "invalid type: map",
    "sequence",
    "untagged enum",
];

impl Tally {
    /// Send one request and tally its answer; the status and the path it names.
    fn send(
        &mut self,
        addr: &str,
        what: &str,
        method: &str,
        path: &str,
        body: &[u8],
    ) -> (u16, Option<String>) {
        self.tried += 1;
        let start = Instant::now();
        let reply = http(addr, method, path, Some(body), &[]);
        let took = start.elapsed();
        if took > Duration::from_secs(MAX_SECONDS) {
            self.hangs.push(format!("{what}: {took:?}"));
        }
        if reply.body.len() > MAX_REPLY {
            self.oversized
                .push(format!("{what}: {} bytes", reply.body.len()));
        }
        match reply.status {
            200..=299 => self.accepted += 1,
            500.. => self.server_errors.push(format!(
                "{what}: {} {}",
                reply.status,
                String::from_utf8_lossy(&reply.body)
            )),
            _ => {
                let answer = serde_json::from_slice::<Value>(&reply.body).unwrap_or_default();
                let detail = answer["detail"].as_str().unwrap_or("");
                if RUST_WORDS.iter().any(|w| detail.contains(w)) {
                    self.rust_words.push(format!("{what}: {detail}"));
                }
                match answer["path"].as_str() {
                    Some(_) => self.refused_with_path += 1,
                    None => self
                        .refused_without_path
                        .push(format!("{}: {what}", reply.status)),
                }
            }
        }
        let health = get(addr, "/healthz");
        assert_eq!(health.status, 200, "/healthz after {what}");
        let named = serde_json::from_slice::<Value>(&reply.body)
            .ok()
            .and_then(|v| v["path"].as_str().map(str::to_string));
        (reply.status, named)
    }
}

#[test]
fn hostile_requests_get_clear_4xx_answers_and_the_server_keeps_answering() {
    let db = temp_db("fuzz.db");
    // No job slots: accepted jobs stay queued (the limit on active jobs is not the subject).
    let server = Server::start(&db, &["--workers", "0", "--max-active-jobs", "100000"]);
    let addr = &server.addr;
    let mut tally = Tally::default();

    let scene: Value = serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    let mut leaves = Vec::new();
    pointers(&scene, String::new(), &mut leaves);
    for pointer in &leaves {
        for value in hostile_values() {
            let mut mutated = scene.clone();
            *mutated.pointer_mut(pointer).unwrap() = value.clone();
            let shown = value.to_string();
            let what = format!("{pointer} = {}", &shown[..shown.len().min(40)]);
            let body = serde_json::to_vec(&json!({ "scene": mutated })).unwrap();
            tally.send(addr, &what, "POST", "/v1/solve", &body);
        }
        let body = serde_json::to_vec(&json!({ "scene": without(&scene, pointer) })).unwrap();
        tally.send(
            addr,
            &format!("{pointer} removed"),
            "POST",
            "/v1/solve",
            &body,
        );
    }
    // Settings of a job.
    for key in [
        "criteria",
        "budget",
        "seed",
        "max_seconds",
        "target_error",
        "solver",
        "threads",
    ] {
        for value in hostile_values() {
            let body = serde_json::to_vec(
                &json!({ "example": "block-on-base", "settings": { key: value } }),
            )
            .unwrap();
            let shown = value.to_string();
            let what = format!("settings.{key} = {}", &shown[..shown.len().min(40)]);
            tally.send(addr, &what, "POST", "/v1/jobs", &body);
        }
    }
    // The probe's corpus: raw bodies, as sent.
    let corpus: Vec<Value> =
        serde_json::from_str(include_str!("data/hostile_corpus.json")).unwrap();
    for case in &corpus {
        let body = match &case["body"] {
            Value::String(raw) => raw.clone().into_bytes(),
            other => serde_json::to_vec(other).unwrap(),
        };
        let name = case["name"].as_str().unwrap();
        let (status, path) = tally.send(addr, name, "POST", case["path"].as_str().unwrap(), &body);
        // Cases marked `refused_at_submission`: a job is refused at submission as a solve
        // would be, with the path.
        if case["refused_at_submission"] == true {
            assert_eq!(status, 422, "{name}");
            assert!(path.is_some(), "{name}");
        }
    }
    // Listings stay small however many jobs were accepted.
    let listing = get(addr, "/v1/jobs?limit=500");
    assert_eq!(listing.status, 200);
    // Query parameters (docs/service.md, "Robustness"): a bad value is refused naming its
    // parameter.
    let id = listing.json()[0]["id"].as_str().unwrap().to_string();
    let bad = [
        "abc",
        "-1",
        "0",
        "1e3",
        "99999999999999999999999",
        "10001",
        "",
    ];
    for (path, parameter) in [
        ("/v1/jobs".to_string(), "limit"),
        ("/v1/jobs".to_string(), "offset"),
        ("/v1/jobs".to_string(), "state"),
        (format!("/v1/jobs/{id}/evaluations"), "limit"),
        (format!("/v1/jobs/{id}/evaluations"), "offset"),
        (format!("/v1/jobs/{id}/fields"), "format"),
    ] {
        for value in bad {
            let query = format!("{path}?{parameter}={value}");
            let reply = http(addr, "GET", &query, None, &[]);
            if reply.status == 422 {
                assert_eq!(reply.json()["path"], parameter, "{query}");
            }
            tally.send(addr, &query, "GET", &query, b"");
        }
    }
    assert!(
        listing.body.len() < 500 * 4096,
        "{} bytes",
        listing.body.len()
    );

    println!(
        "fuzz: {} requests, {} accepted, {} refused with the path, {} refused without a path, \
         {} server errors, {} hangs, {} oversized",
        tally.tried,
        tally.accepted,
        tally.refused_with_path,
        tally.refused_without_path.len(),
        tally.server_errors.len(),
        tally.hangs.len(),
        tally.oversized.len()
    );
    assert!(tally.server_errors.is_empty(), "{:#?}", tally.server_errors);
    assert!(tally.hangs.is_empty(), "{:#?}", tally.hangs);
    assert!(tally.oversized.is_empty(), "{:#?}", tally.oversized);
    assert!(tally.rust_words.is_empty(), "{:#?}", tally.rust_words);
    assert!(tally.tried > 1000, "{} requests", tally.tried);
    // A 422 is about a field and names it; only the body as a whole (400, 413, 415) has none.
    let unnamed: Vec<&String> = tally
        .refused_without_path
        .iter()
        .filter(|r| r.starts_with("422"))
        .collect();
    assert!(unnamed.is_empty(), "{unnamed:#?}");
}
