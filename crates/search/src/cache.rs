//! The evaluation cache (design §4.3: "cached by (scene hash, θ), and persisted"): outcomes keyed
//! by the exact bit pattern of the physical point, kept in insertion order so that persisting
//! and reloading it is deterministic. One cache belongs to one scene; the caller keys the scene.

use super::Outcome;
use std::collections::HashMap;

/// Evaluated points and their outcomes, in insertion order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EvalCache {
    entries: Vec<(Vec<f64>, Outcome)>,
    index: HashMap<Vec<u64>, usize>,
}

fn key(point: &[f64]) -> Vec<u64> {
    point.iter().map(|x| x.to_bits()).collect()
}

impl EvalCache {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// The outcome stored for exactly this point (bit for bit).
    pub fn get(&self, point: &[f64]) -> Option<&Outcome> {
        self.index.get(&key(point)).map(|&i| &self.entries[i].1)
    }

    /// Store an outcome (pre-loading a persisted evaluation, for instance); an existing entry for
    /// the same point is replaced in place.
    pub fn insert(&mut self, point: Vec<f64>, outcome: Outcome) {
        match self.index.get(&key(&point)) {
            Some(&i) => self.entries[i].1 = outcome,
            None => {
                self.index.insert(key(&point), self.entries.len());
                self.entries.push((point, outcome));
            }
        }
    }

    /// All entries in insertion order (for persistence).
    pub fn iter(&self) -> impl Iterator<Item = (&[f64], &Outcome)> {
        self.entries.iter().map(|(p, o)| (p.as_slice(), o))
    }

    /// The number of distinct points stored.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether no point is stored.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keyed_by_exact_bits_and_ordered() {
        let mut c = EvalCache::new();
        c.insert(vec![1.0, 2.0], Ok(vec![3.0].into()));
        c.insert(vec![0.0], Err("bad".into()));
        assert_eq!(c.get(&[1.0, 2.0]), Some(&Ok(vec![3.0].into())));
        assert_eq!(c.get(&[-0.0]), None, "-0.0 and 0.0 are different keys");
        assert_eq!(c.get(&[1.0, 2.0 + f64::EPSILON * 2.0]), None);
        c.insert(vec![1.0, 2.0], Ok(vec![4.0].into()));
        assert_eq!(c.len(), 2);
        let order: Vec<_> = c.iter().map(|(p, _)| p.to_vec()).collect();
        assert_eq!(order, vec![vec![1.0, 2.0], vec![0.0]]);
        assert_eq!(c.get(&[1.0, 2.0]), Some(&Ok(vec![4.0].into())));
    }
}
