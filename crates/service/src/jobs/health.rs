//! Whether the job store takes writes, probed in the background every few seconds (a write in a
//! rolled-back transaction) so that `/healthz` can say so at once without waiting for the
//! database: a store that turned read-only or lost its disk makes the service answer
//! "degraded" instead of "ok" while it keeps serving what it can read.

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

/// Probe `store` now and then every [`PERIOD`], recording the answers in `health`.
pub fn spawn_monitor(store: Arc<dyn JobStore>, health: Arc<StoreHealth>) {
    tokio::spawn(async move {
        loop {
            let failure = store.check_writable().await.err().map(|e| e.to_string());
            health.record(failure);
            tokio::time::sleep(PERIOD).await;
        }
    });
}
