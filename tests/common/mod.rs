//! Helpers shared by the tests that drive real `wsm` processes (tests/service.rs,
//! tests/scale_out.rs): starting a process and reading the address it prints, a minimal HTTP/1.1
//! client, waiting for a job, and the reference result of `wsm worst`.

#![allow(dead_code)] // each test binary uses its own subset

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

mod postgres;
#[allow(unused_imports)] // the binaries without PostgreSQL runs use neither
pub use postgres::{postgres_url, PgSchema};

/// A running server.
pub struct Server {
    pub child: Child,
    pub addr: String,
    /// The first line the server printed (its address).
    pub first_line: String,
}

impl Server {
    /// `wsm serve` on a free loopback port with `db` (a SQLite file or a PostgreSQL URL), a
    /// 2 s lease and one thread per job, plus `extra` arguments.
    pub fn start(db: &str, extra: &[&str]) -> Server {
        Server::start_with_token(db, extra, None).0
    }

    /// Start with `WSM_API_TOKEN` set (or unset); also the first line the server printed.
    pub fn start_with_token(db: &str, extra: &[&str], token: Option<&str>) -> (Server, String) {
        let command = Command::new(env!("CARGO_BIN_EXE_wsm"));
        let server = Server::start_command(command, db, extra, token);
        let line = server.first_line.clone();
        (server, line)
    }

    /// Start `command` (the `wsm` binary, with its own environment) as `start_with_token` does.
    pub fn start_command(
        mut command: Command,
        db: &str,
        extra: &[&str],
        token: Option<&str>,
    ) -> Server {
        match token {
            Some(t) => command.env("WSM_API_TOKEN", t),
            None => command.env_remove("WSM_API_TOKEN"),
        };
        let mut child = command
            .args(["serve", "--addr", "127.0.0.1:0", "--db", db])
            .args(["--lease-seconds", "2", "--threads-per-job", "1"])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let addr = line
            .split("http://")
            .nth(1)
            .and_then(|s| s.split('/').next())
            .unwrap_or_else(|| panic!("no address in {line:?}"))
            .to_string();
        Server {
            child,
            addr,
            first_line: line,
        }
    }

    pub fn kill(&mut self) {
        let _ = self.child.kill(); // SIGKILL
        let _ = self.child.wait();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A response: status, headers (lower-case names), body.
pub struct Reply {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&self.body)))
    }

    /// The id of the job this reply accepted: the status must be 202 (otherwise the test fails
    /// showing the body).
    pub fn accepted_id(&self) -> String {
        assert_eq!(self.status, 202, "{}", String::from_utf8_lossy(&self.body));
        self.json()["id"].as_str().unwrap().to_string()
    }

    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// One HTTP/1.1 request with `Connection: close`.
pub fn http(
    addr: &str,
    method: &str,
    path: &str,
    body: Option<&[u8]>,
    headers: &[(&str, &str)],
) -> Reply {
    let mut stream = TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .unwrap();
    let mut request = format!("{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n");
    for (k, v) in headers {
        request.push_str(&format!("{k}: {v}\r\n"));
    }
    if let Some(b) = body {
        request.push_str(&format!(
            "Content-Type: application/json\r\nContent-Length: {}\r\n",
            b.len()
        ));
    }
    request.push_str("\r\n");
    stream.write_all(request.as_bytes()).unwrap();
    if let Some(b) = body {
        stream.write_all(b).unwrap();
    }
    let mut raw = Vec::new();
    stream.read_to_end(&mut raw).unwrap();
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a header block");
    let head = String::from_utf8_lossy(&raw[..split]).to_string();
    let mut lines = head.lines();
    let status: u16 = lines
        .next()
        .unwrap()
        .split(' ')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    let headers: Vec<(String, String)> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    let mut body = raw[split + 4..].to_vec();
    if headers
        .iter()
        .any(|(k, v)| k == "transfer-encoding" && v == "chunked")
    {
        body = dechunk(&body);
    }
    Reply {
        status,
        headers,
        body,
    }
}

fn dechunk(mut data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(end) = data.windows(2).position(|w| w == b"\r\n") {
        let size =
            usize::from_str_radix(String::from_utf8_lossy(&data[..end]).trim(), 16).unwrap_or(0);
        if size == 0 {
            break;
        }
        out.extend_from_slice(&data[end + 2..end + 2 + size]);
        data = &data[end + 4 + size..];
    }
    out
}

pub fn get(addr: &str, path: &str) -> Reply {
    http(addr, "GET", path, None, &[])
}

pub fn post(addr: &str, path: &str, body: &Value) -> Reply {
    http(addr, "POST", path, Some(body.to_string().as_bytes()), &[])
}

/// A fresh SQLite database path in this test process's temporary folder.
pub fn temp_db(name: &str) -> String {
    let dir = std::env::temp_dir().join(format!("wsm-service-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    for suffix in ["", "-wal", "-shm"] {
        let _ = std::fs::remove_file(format!("{}{suffix}", path.display()));
    }
    path.to_str().unwrap().to_string()
}

/// Wait until the job is finished; its status.
pub fn wait_finished(addr: &str, id: &str, limit: Duration) -> Value {
    let start = Instant::now();
    loop {
        let status = get(addr, &format!("/v1/jobs/{id}")).json();
        let state = status["state"].as_str().unwrap().to_string();
        if ["succeeded", "failed", "cancelled"].contains(&state.as_str()) {
            return status;
        }
        assert!(start.elapsed() < limit, "job {id} still {state}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// `wsm worst` on one thread: the single-process reference of a job.
pub fn cli_worst(example: &str, criteria: &str, budget: usize, seed: u64) -> Value {
    cli_worst_with(example, criteria, budget, seed, &[])
}

/// As [`cli_worst`], with more options.
pub fn cli_worst_with(
    example: &str,
    criteria: &str,
    budget: usize,
    seed: u64,
    extra: &[&str],
) -> Value {
    let output = Command::new(env!("CARGO_BIN_EXE_wsm"))
        .args(["worst", "--example", example, "--criteria", criteria])
        .args(["--threads", "1"])
        .args(["--budget", &budget.to_string(), "--seed", &seed.to_string()])
        .args(extra)
        .output()
        .unwrap();
    assert!(output.status.success());
    serde_json::from_slice(&output.stdout).unwrap()
}

/// The criteria of an outcome without the histories (printed by the CLI without them).
pub fn extrema(outcome: &Value) -> Value {
    let mut criteria = outcome["criteria"].clone();
    for c in criteria.as_array_mut().unwrap() {
        for side in ["worst", "best"] {
            c[side]["history"] = json!(null);
        }
    }
    criteria
}
