//! Whether the job store takes writes, probed in the background every few seconds (a committed
//! write of one row: a write that is rolled back never reaches the disk) so that `/healthz` can
//! say so at once without waiting for the database: a store that turned read-only, lost its
//! disk or is locked by another process makes the service answer "degraded" instead of "ok"
//! while it keeps serving what it can read, and "ok" again as soon as a probe writes.

use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use super::JobStore;

/// The last probe's answer: `None` while writes succeed, else the reason they fail.
#[derive(Debug, Default)]
pub struct StoreHealth {
    failure: Mutex<Option<String>>,
}

impl StoreHealth {
    /// Why the store does not take writes, if it does not.
    pub fn write_failure(&self) -> Option<String> {
        self.failure
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    fn record(&self, failure: Option<String>) {
        *self.failure.lock().unwrap_or_else(PoisonError::into_inner) = failure;
    }
}

/// How often the store's writability is probed.
const PERIOD: Duration = Duration::from_secs(2);
/// A probe not answered within this long counts as a failure (a database locked by another
/// process makes a write wait for the whole lock timeout).
const PROBE_TIMEOUT: Duration = Duration::from_secs(2);

/// Probe `store` now and then every `PERIOD`, recording the answers in `health`.
pub fn spawn_monitor(store: Arc<dyn JobStore>, health: Arc<StoreHealth>) {
    tokio::spawn(async move {
        loop {
            let failure = match tokio::time::timeout(PROBE_TIMEOUT, store.check_writable()).await {
                Ok(answer) => answer.err().map(|e| e.to_string()),
                Err(_) => Some(format!(
                    "job store: a write did not complete within {} s (the database is locked \
                     or stalled)",
                    PROBE_TIMEOUT.as_secs()
                )),
            };
            health.record(failure);
            tokio::time::sleep(PERIOD).await;
        }
    });
}
