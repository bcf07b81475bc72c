//! Slow and idle clients (docs/service.md, "Robustness": timeouts and the connection cap) against a
//! real `wsm serve` on loopback: a half-sent request line is closed after the header timeout; a
//! body that stalls gets 408 after the body timeout; a `Content-Length` beyond the body limit gets
//! 413 before any body is sent; with the connection cap at 20 and 70 idle connections, a new client
//! never hangs — `/healthz` is answered 200 throughout, other requests a quick 503 — the idle ones
//! are closed after the header timeout and `/healthz` answers 200 again while their clients still
//! hold them open.

mod common;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use common::{get, temp_db, Server};

/// Read until the server closes the connection (or `limit`); what it sent and when it closed.
fn read_until_closed(stream: &mut TcpStream, limit: Duration) -> (String, Option<Duration>) {
    let start = Instant::now();
    stream.set_read_timeout(Some(limit)).unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        match stream.read(&mut buf) {
            Ok(0) => return (String::from_utf8_lossy(&got).into(), Some(start.elapsed())),
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => {
                return (String::from_utf8_lossy(&got).into(), Some(start.elapsed()))
            }
            Err(_) => return (String::from_utf8_lossy(&got).into(), None),
        }
        if start.elapsed() > limit {
            return (String::from_utf8_lossy(&got).into(), None);
        }
    }
}

#[test]
fn slow_clients_are_cut_off_after_the_timeouts_and_a_huge_length_is_refused_up_front() {
    let db = temp_db("slow.db");
    let server = Server::start(
        &db,
        &[
            "--workers",
            "0",
            "--header-timeout",
            "2",
            "--body-timeout",
            "2",
        ],
    );
    let addr = &server.addr;

    // Half a request line, then nothing.
    let mut half = TcpStream::connect(addr).unwrap();
    half.write_all(b"GET /healthz HTT").unwrap();
    let (_, closed) = read_until_closed(&mut half, Duration::from_secs(8));
    let closed = closed.expect("a half-sent request line is closed");
    assert!(
        closed >= Duration::from_millis(1500) && closed < Duration::from_secs(5),
        "{closed:?}"
    );

    // A whole head, then 10 of the 100 bytes promised.
    let mut stalled = TcpStream::connect(addr).unwrap();
    stalled
        .write_all(
            b"POST /v1/solve HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\
              Content-Length: 100\r\n\r\n{\"example\"",
        )
        .unwrap();
    let (reply, closed) = read_until_closed(&mut stalled, Duration::from_secs(8));
    assert!(reply.starts_with("HTTP/1.1 408"), "{reply}");
    assert!(reply.contains("request_timeout"), "{reply}");
    let closed = closed.expect("closed after the 408");
    assert!(closed < Duration::from_secs(5), "{closed:?}");

    // 10^12 bytes announced, a few sent: refused at once, without waiting for the rest.
    let mut huge = TcpStream::connect(addr).unwrap();
    let start = Instant::now();
    huge.write_all(
        b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\
          Content-Length: 1000000000000\r\n\r\n{}",
    )
    .unwrap();
    let (reply, _) = read_until_closed(&mut huge, Duration::from_secs(5));
    assert!(reply.starts_with("HTTP/1.1 413"), "{reply}");
    assert!(reply.contains("too_large"), "{reply}");
    assert!(
        start.elapsed() < Duration::from_secs(3),
        "{:?}",
        start.elapsed()
    );

    assert_eq!(get(addr, "/healthz").status, 200);
}

/// Sockets the server process holds open (Linux: its descriptors that are sockets).
fn open_sockets(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/fd"))
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .filter(|e| {
                    std::fs::read_link(e.path())
                        .is_ok_and(|target| target.to_string_lossy().starts_with("socket:"))
                })
                .count()
        })
        .unwrap_or(0)
}

#[test]
fn idle_connections_beyond_the_cap_never_make_health_hang_and_are_closed() {
    let db = temp_db("idle.db");
    let server = Server::start(
        &db,
        &[
            "--workers",
            "0",
            "--max-connections",
            "20",
            "--header-timeout",
            "3",
        ],
    );
    let addr = &server.addr;
    let idle: Vec<TcpStream> = (0..70).map(|_| TcpStream::connect(addr).unwrap()).collect();
    std::thread::sleep(Duration::from_millis(300));
    let held = open_sockets(server.child.id());
    // The cap (20) and the refusals in flight (at most 64), plus the listener and the store.
    assert!(held <= 20 + 64 + 8, "{held} sockets open in the server");

    // A new client is answered at once, never left hanging: `/healthz` as usual (a monitor sees
    // the server alive), anything else 503 `busy` with Retry-After.
    let start = Instant::now();
    let reply = get(addr, "/healthz");
    let took = start.elapsed();
    // At once (a hang would be the header timeout or longer); room for a loaded machine.
    assert!(took < Duration::from_secs(2), "{took:?}");
    assert_eq!(
        reply.status,
        200,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    let reply = get(addr, "/v1/jobs");
    assert_eq!(
        reply.status,
        503,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    assert_eq!(reply.json()["error"], "busy");
    assert_eq!(reply.header("retry-after"), Some("1"));

    // The idle ones are closed by the header timeout; their clients still hold them.
    std::thread::sleep(Duration::from_millis(3500));
    let start = Instant::now();
    let reply = get(addr, "/healthz");
    assert_eq!(
        reply.status,
        200,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    assert!(start.elapsed() < Duration::from_secs(2));
    let mut closed = 0;
    for mut stream in idle {
        stream
            .set_read_timeout(Some(Duration::from_millis(200)))
            .unwrap();
        let mut buf = [0u8; 512];
        match stream.read(&mut buf) {
            Ok(_) => closed += 1, // EOF, or a 503 before it
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => closed += 1,
            Err(_) => {}
        }
    }
    assert_eq!(closed, 70, "idle connections the server closed");
}
