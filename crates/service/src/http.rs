//! The connections of `wsm serve` (docs/service.md, "Robustness": timeouts and the connection cap):
//! HTTP/1.1 by hyper with a header read timeout (a client that has not sent a whole request head
//! within it — a half-sent request line, or an idle keep-alive connection — is closed), and a cap
//! on open connections below the process's file-descriptor limit, so that idle or slow clients can
//! never take the descriptors the store and the workers need. Connections beyond the cap are
//! answered 503 `busy` with `Retry-After` at once (up to [`OVERFLOW`] of them at a time; beyond
//! those, closed unread) — a new client learns the server is full instead of hanging — except
//! `GET /healthz`, which is answered as usual there, so a monitor sees the server alive while idle
//! clients fill it. The body read timeout and the early 413 are the API's (`api::guard`), where the
//! error bodies are made.
//!
//! `axum::serve` offers neither a header timeout (hyper's needs a timer it does not set) nor a
//! connection cap, hence this loop over hyper's own connection builder and hyper-util's
//! graceful shutdown.

use std::convert::Infallible;
use std::future::Future;
use std::sync::Arc;
use std::time::Duration;

use axum::body::Body;
use axum::http::{Request, Response};
use axum::Router;
use hyper::body::Incoming;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::server::graceful::GracefulShutdown;
use hyper_util::service::TowerToHyperService;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tower::ServiceExt;

use crate::api::{closing, ApiError};
use crate::error_code::ErrorCode;

/// Limits on connections.
#[derive(Debug, Clone)]
pub struct ConnectionLimits {
    /// A request head (request line and headers) must arrive within this long of the
    /// connection's opening or of the previous response.
    pub header_timeout: Duration,
    /// Connections open at once (see [`default_max_connections`]).
    pub max_connections: usize,
}

/// Connections beyond the cap that are answered 503 at once; more are closed unread.
pub const OVERFLOW: usize = 64;

/// File descriptors kept free of connections: the store's pool and files, the listener, the
/// workers' and the runtime's own.
pub const RESERVED_DESCRIPTORS: usize = 256;

/// The largest default cap, whatever the descriptor limit (each idle connection holds buffers).
const MAX_DEFAULT_CONNECTIONS: usize = 4096;

/// The process's file-descriptor limit (`RLIMIT_NOFILE`, soft); 1024 where unknown.
pub fn descriptor_limit() -> usize {
    #[cfg(unix)]
    {
        let limit = rustix::process::getrlimit(rustix::process::Resource::Nofile);
        limit
            .current
            .map_or(usize::MAX, |n| usize::try_from(n).unwrap_or(usize::MAX))
    }
    #[cfg(not(unix))]
    {
        1024
    }
}

/// The default connection cap: the descriptor limit less [`RESERVED_DESCRIPTORS`] and
/// `OVERFLOW`, at most `MAX_DEFAULT_CONNECTIONS`, at least 16.
pub fn default_max_connections() -> usize {
    descriptor_limit()
        .saturating_sub(RESERVED_DESCRIPTORS + OVERFLOW)
        .clamp(16, MAX_DEFAULT_CONNECTIONS)
}

/// Refuse a cap that would leave too few descriptors for the store and the workers.
pub fn check_max_connections(max_connections: usize) -> Result<(), String> {
    let limit = descriptor_limit();
    let room = limit.saturating_sub(RESERVED_DESCRIPTORS + OVERFLOW);
    if max_connections == 0 || max_connections > room {
        return Err(format!(
            "--max-connections {max_connections}: must be between 1 and {room} (the file-descriptor \
             limit {limit} less {RESERVED_DESCRIPTORS} for the store and workers and {OVERFLOW} \
             for refusals; raise it with `ulimit -n`)"
        ));
    }
    Ok(())
}

/// Serve `app` on `listener` until `shutdown` completes, then let open requests finish (up to
/// `drain` long).
pub async fn serve(
    listener: TcpListener,
    app: Router,
    limits: ConnectionLimits,
    shutdown: impl Future<Output = ()>,
    drain: Duration,
) {
    let open = Arc::new(Semaphore::new(limits.max_connections));
    let refusing = Arc::new(Semaphore::new(OVERFLOW));
    let graceful = GracefulShutdown::new();
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                // Out of descriptors, or a connection reset before it was taken: pause briefly
                // (a tight loop would spin on EMFILE).
                Err(_) => {
                    tokio::time::sleep(Duration::from_millis(20)).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        let _ = stream.set_nodelay(true);
        if let Ok(permit) = open.clone().try_acquire_owned() {
            let service = TowerToHyperService::new(app.clone());
            let connection =
                builder(limits.header_timeout).serve_connection(TokioIo::new(stream), service);
            let connection = graceful.watch(connection);
            tokio::spawn(async move {
                let _ = connection.await;
                drop(permit);
            });
        } else if let Ok(permit) = refusing.clone().try_acquire_owned() {
            tokio::spawn(refuse(stream, app.clone(), permit));
        }
        // Else the stream is dropped here: closed unread.
    }
    drop(listener);
    let _ = tokio::time::timeout(drain, graceful.shutdown()).await;
}

fn builder(header_timeout: Duration) -> http1::Builder {
    let mut builder = http1::Builder::new();
    builder
        .timer(TokioTimer::new())
        .header_read_timeout(header_timeout);
    builder
}

/// Answer one request on a connection beyond the cap — `/healthz` by `app`, anything else with
/// 503 `busy` — and close it; the head must come within a second.
async fn refuse(stream: TcpStream, app: Router, permit: OwnedSemaphorePermit) {
    let busy = hyper::service::service_fn(move |request: Request<Incoming>| {
        let app = app.clone();
        async move {
            if request.uri().path() != "/healthz" {
                return Ok::<_, Infallible>(busy_response());
            }
            let response = app.oneshot(request.map(Body::new)).await;
            Ok(response.unwrap_or_else(|never| match never {}))
        }
    });
    let mut builder = builder(Duration::from_secs(1));
    builder.keep_alive(false);
    let _ = builder.serve_connection(TokioIo::new(stream), busy).await;
    drop(permit);
}

fn busy_response() -> Response<Body> {
    closing(
        ApiError::new(
            ErrorCode::Busy,
            "the server has as many connections open as it takes; try again shortly",
        )
        .retry_after(1),
    )
}
