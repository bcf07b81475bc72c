//! Compressed rows of node pairs (the CSR layout): for every node a, the nodes b of the pairs
//! (a, b), built by a counting pass in O(pairs), with no sorting and no hashing. Used for mesh
//! edges by the validity check and by the boundary search of the assembly.

/// Pairs grouped by their first node.
pub(crate) struct Rows {
    start: Vec<usize>,
    to: Vec<usize>,
}

impl Rows {
    /// Rows for nodes 0..n of the pairs produced by `pairs` (called twice: count, then fill).
    pub fn new<I: Iterator<Item = [usize; 2]>>(n: usize, pairs: impl Fn() -> I) -> Rows {
        let mut start = vec![0usize; n + 1];
        for [a, _] in pairs() {
            start[a + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut to = vec![0usize; start[n]];
        for [a, b] in pairs() {
            to[fill[a]] = b;
            fill[a] += 1;
        }
        Rows { start, to }
    }

    /// The second nodes of the pairs starting at `a`.
    pub fn row(&self, a: usize) -> &[usize] {
        &self.to[self.start[a]..self.start[a + 1]]
    }

    /// Sorts every row (rows are short: the edges at one node).
    pub fn sort_rows(&mut self) {
        for a in 0..self.start.len() - 1 {
            self.to[self.start[a]..self.start[a + 1]].sort_unstable();
        }
    }
}
