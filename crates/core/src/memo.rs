//! A tiny shared memo: the last few values keyed by the exact bits of the numbers they were
//! computed from (stiffness factorisations by λ, μ; temperature fields by the thermal data; the
//! DD subdomain operators by the subdomain's stiffness values).

use std::collections::VecDeque;
use std::sync::Mutex;

/// The key of a list of numbers: their exact bit patterns.
pub fn key(numbers: impl Iterator<Item = f64>) -> Vec<u64> {
    numbers.map(f64::to_bits).collect()
}

/// How many values of `bytes` each fit in `budget` bytes, at least 2 and at most 64.
pub fn capacity(budget: usize, bytes: usize) -> usize {
    (budget / bytes.max(1)).clamp(2, 64)
}

/// Most-recently-used cache of `capacity` values.
pub struct Memo<V> {
    entries: Mutex<VecDeque<(Vec<u64>, V)>>,
    capacity: usize,
}

impl<V: Clone> Memo<V> {
    pub fn new(capacity: usize) -> Memo<V> {
        Memo {
            entries: Mutex::new(VecDeque::new()),
            capacity,
        }
    }

    /// The cached value for `key`, or `make()` stored under it; `true` when it was cached.
    pub fn get_or_try<E>(
        &self,
        key: Vec<u64>,
        make: impl FnOnce() -> Result<V, E>,
    ) -> Result<(V, bool), E> {
        if let Some(v) = self.lookup(&key) {
            return Ok((v, true));
        }
        let value = make()?;
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        entries.push_front((key, value.clone()));
        entries.truncate(self.capacity);
        Ok((value, false))
    }

    fn lookup(&self, key: &[u64]) -> Option<V> {
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        let pos = entries.iter().position(|(k, _)| k == key)?;
        let entry = entries.remove(pos)?;
        let value = entry.1.clone();
        entries.push_front(entry);
        Some(value)
    }
}
