//! A flat constrained Delaunay triangulation for the refinement: triangles in plain arrays
//! (vertices, neighbours, constraint bits, zone), built once from spade's bulk-loaded CDT and
//! then changed only by Bowyer–Watson insertions whose cavity never crosses a constraint edge
//! (the constrained Delaunay property is kept; Shewchuk, "Delaunay refinement algorithms for
//! triangular mesh generation", 2002). All orientation and in-circle decisions use exact
//! predicates (`robust`), and every insertion checks that its new triangles are
//! counter-clockwise before it changes anything, so a degenerate point is refused, never
//! inserted.
//!
//! Edge `k` of triangle `t` joins `v[t][k + 1]` to `v[t][k + 2]` (indices mod 3) and lies
//! opposite `v[t][k]`; `n[t][k]` is the triangle across it (`NONE` on the hull).

use robust::{incircle, orient2d, Coord};

use super::geom::P;

/// No triangle / no zone / no vertex.
pub(crate) const NONE: u32 = u32::MAX;

fn c(p: P) -> Coord<f64> {
    Coord { x: p[0], y: p[1] }
}

/// Exact orientation: positive when (a, b, q) is counter-clockwise.
pub(crate) fn orient(a: P, b: P, q: P) -> f64 {
    orient2d(c(a), c(b), c(q))
}

fn next(k: usize) -> usize {
    (k + 1) % 3
}

fn prev(k: usize) -> usize {
    (k + 2) % 3
}

/// Where a straight walk through the triangulation ended.
pub(crate) enum Walk {
    /// The triangle containing the target (possibly on a non-constraint edge).
    Reached(u32),
    /// The constraint edge (triangle, edge) crossed on the way or containing the target.
    Blocked(u32, usize),
    Lost,
}

/// The result of an insertion.
pub(crate) enum Insert {
    /// The new vertex; its triangles are in `Tri::fan`.
    Done(u32),
    /// The point encroaches these constraint edges (vertex pairs); nothing was changed.
    Encroached(Vec<[u32; 2]>),
    /// The point cannot be inserted (degenerate position); nothing was changed.
    Refused,
}

/// An edge of an insertion cavity's boundary.
#[derive(Clone, Copy)]
struct Rim {
    a: u32,
    b: u32,
    /// The triangle outside the cavity and the index of the edge (b, a) in it.
    out: u32,
    out_k: usize,
    seg: bool,
    zone: u32,
}

/// The triangulation.
#[derive(Default)]
pub(crate) struct Tri {
    pub pts: Vec<P>,
    /// Vertices of each triangle, counter-clockwise.
    pub v: Vec<[u32; 3]>,
    /// Neighbour across each edge.
    pub n: Vec<[u32; 3]>,
    /// Bit k set: edge k is a constraint.
    pub seg: Vec<u8>,
    /// Zone of each triangle (`NONE` outside the domain).
    pub zone: Vec<u32>,
    /// One triangle of each vertex.
    vt: Vec<u32>,
    /// Visit stamps of the cavity search (triangles) and of its rim (vertices).
    mark: Vec<u32>,
    vmark: Vec<u32>,
    /// The rim edge starting at each marked vertex.
    vslot: Vec<u32>,
    stamp: u32,
    cavity: Vec<u32>,
    rim: Vec<Rim>,
    /// The triangles made by the last successful insertion.
    pub fan: Vec<u32>,
}

impl Tri {
    /// Builds the structure from triangles (counter-clockwise vertex triples) and the
    /// constraint edges among their edges.
    pub fn new(pts: Vec<P>, v: Vec<[u32; 3]>, is_constraint: impl Fn(u32, u32) -> bool) -> Tri {
        let nt = v.len();
        // Match each directed edge with its reverse: sort (min, max, triangle, edge).
        let mut half: Vec<(u32, u32, u32, u8)> = Vec::with_capacity(3 * nt);
        for (t, tri) in v.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[next(k)], tri[prev(k)]);
                half.push((a.min(b), a.max(b), t as u32, k as u8));
            }
        }
        half.sort_unstable();
        let mut n = vec![[NONE; 3]; nt];
        let mut seg = vec![0u8; nt];
        for w in half.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            if let [x, y] = w {
                n[x.2 as usize][x.3 as usize] = y.2;
                n[y.2 as usize][y.3 as usize] = x.2;
            }
            if is_constraint(w[0].0, w[0].1) {
                for h in w {
                    seg[h.2 as usize] |= 1 << h.3;
                }
            }
        }
        let mut vt = vec![NONE; pts.len()];
        for (t, tri) in v.iter().enumerate() {
            for &x in tri {
                vt[x as usize] = t as u32;
            }
        }
        Tri {
            vmark: vec![0; pts.len()],
            vslot: vec![0; pts.len()],
            pts,
            mark: vec![0; nt],
            zone: vec![NONE; nt],
            v,
            n,
            seg,
            vt,
            ..Tri::default()
        }
    }

    pub fn is_seg(&self, t: u32, k: usize) -> bool {
        self.seg[t as usize] & (1 << k) != 0
    }

    /// The end points of edge k of t.
    pub fn edge(&self, t: u32, k: usize) -> [u32; 2] {
        let v = self.v[t as usize];
        [v[next(k)], v[prev(k)]]
    }

    pub fn corners(&self, t: u32) -> [P; 3] {
        self.v[t as usize].map(|x| self.pts[x as usize])
    }

    /// A triangle with the edge a–b and the index of that edge in it.
    pub fn find_edge(&self, a: u32, b: u32) -> Option<(u32, usize)> {
        let start = *self.vt.get(a as usize)?;
        // Turn around a one way, then (on the hull) the other way.
        for dir in [next, prev] {
            let mut t = start;
            for _ in 0..self.v.len() {
                let tri = self.v[t as usize];
                let i = tri.iter().position(|&x| x == a)?;
                if let Some(j) = tri.iter().position(|&x| x == b) {
                    return Some((t, 3 - i - j));
                }
                t = self.n[t as usize][dir(i)];
                if t == NONE || t == start {
                    break;
                }
            }
            if t == start {
                break;
            }
        }
        None
    }

    /// Walks from triangle `t` (containing `from`) straight towards `to`.
    pub fn walk(&self, mut t: u32, from: P, to: P) -> Walk {
        for _ in 0..self.v.len() {
            let p = self.corners(t);
            let exit = (0..3).find(|&k| {
                let (a, b) = (p[next(k)], p[prev(k)]);
                let (sa, sb) = (orient(from, to, a), orient(from, to, b));
                orient(a, b, to) < 0.0 && !(sa > 0.0 && sb > 0.0) && !(sa < 0.0 && sb < 0.0)
            });
            let Some(k) = exit else {
                // `to` lies in t or on its boundary; on a constraint means blocked by it.
                let on = (0..3)
                    .find(|&k| self.is_seg(t, k) && orient(p[next(k)], p[prev(k)], to) == 0.0);
                return match on {
                    Some(k) => Walk::Blocked(t, k),
                    None => Walk::Reached(t),
                };
            };
            if self.is_seg(t, k) {
                return Walk::Blocked(t, k);
            }
            t = self.n[t as usize][k];
            if t == NONE {
                return Walk::Lost;
            }
        }
        Walk::Lost
    }

    fn in_circle(&self, t: u32, q: P) -> bool {
        let [a, b, d] = self.corners(t);
        incircle(c(a), c(b), c(d), c(q)) > 0.0
    }

    /// Inserts `p` by Bowyer–Watson from the `seeds` (the triangle containing p, or the two
    /// triangles of the constraint edge `split` that p divides). With `encroach`, constraint
    /// edges on the cavity's rim whose diametral circle contains p are reported instead.
    pub fn insert(
        &mut self,
        p: P,
        seeds: &[u32],
        split: Option<[u32; 2]>,
        encroach: bool,
    ) -> Insert {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.mark.fill(0);
            self.vmark.fill(0);
            self.stamp = 1;
        }
        let stamp = self.stamp;
        self.cavity.clear();
        for &s in seeds {
            self.mark[s as usize] = stamp;
            self.cavity.push(s);
        }
        let is_split = |e: [u32; 2]| split.is_some_and(|[a, b]| (e == [a, b]) || (e == [b, a]));
        let mut i = 0;
        while i < self.cavity.len() {
            let t = self.cavity[i];
            i += 1;
            for k in 0..3 {
                let u = self.n[t as usize][k];
                if u == NONE || self.mark[u as usize] == stamp || self.is_seg(t, k) {
                    continue;
                }
                if self.in_circle(u, p) {
                    self.mark[u as usize] = stamp;
                    self.cavity.push(u);
                }
            }
        }
        self.rim.clear();
        for &t in &self.cavity {
            for k in 0..3 {
                let u = self.n[t as usize][k];
                let seg = self.is_seg(t, k);
                let e = self.edge(t, k);
                let inside = u != NONE && self.mark[u as usize] == stamp;
                if inside && (!seg || is_split(e)) {
                    continue;
                }
                let out_k = if u == NONE {
                    0
                } else {
                    match self.n[u as usize].iter().position(|&x| x == t) {
                        Some(j) => j,
                        None => return Insert::Refused,
                    }
                };
                self.rim.push(Rim {
                    a: e[0],
                    b: e[1],
                    out: u,
                    out_k,
                    seg,
                    zone: self.zone[t as usize],
                });
            }
        }
        if encroach {
            let hit: Vec<[u32; 2]> = self
                .rim
                .iter()
                .filter(|r| r.seg && encroaches(self.pts[r.a as usize], self.pts[r.b as usize], p))
                .map(|r| [r.a, r.b])
                .collect();
            if !hit.is_empty() {
                return Insert::Encroached(hit);
            }
        }
        // A star-shaped cavity with p inside: every rim edge sees p on its left, the rim is one
        // cycle (each vertex starts one edge) and has two more edges than the cavity triangles.
        if self.rim.len() != self.cavity.len() + 2
            || self
                .rim
                .iter()
                .any(|r| orient(self.pts[r.a as usize], self.pts[r.b as usize], p) <= 0.0)
        {
            return Insert::Refused;
        }
        for (i, r) in self.rim.iter().enumerate() {
            let a = r.a as usize;
            if self.vmark[a] == stamp {
                return Insert::Refused;
            }
            self.vmark[a] = stamp;
            self.vslot[a] = i as u32;
        }
        if self.rim.iter().any(|r| self.vmark[r.b as usize] != stamp) {
            return Insert::Refused;
        }
        self.commit(p, split)
    }

    /// Replaces the cavity by the fan of its rim around the new vertex p.
    fn commit(&mut self, p: P, split: Option<[u32; 2]>) -> Insert {
        let vi = self.pts.len() as u32;
        self.pts.push(p);
        self.vt.push(NONE);
        self.vmark.push(0);
        self.vslot.push(0);
        self.fan.clear();
        for i in 0..self.rim.len() {
            let t = match self.cavity.get(i) {
                Some(&t) => t,
                None => {
                    self.v.push([NONE; 3]);
                    self.n.push([NONE; 3]);
                    self.seg.push(0);
                    self.zone.push(NONE);
                    self.mark.push(0);
                    (self.v.len() - 1) as u32
                }
            };
            self.fan.push(t);
        }
        for (i, r) in self.rim.iter().enumerate() {
            let t = self.fan[i] as usize;
            self.v[t] = [vi, r.a, r.b];
            self.n[t][0] = r.out;
            self.seg[t] = r.seg as u8;
            self.zone[t] = r.zone;
            if r.out != NONE {
                self.n[r.out as usize][r.out_k] = t as u32;
            }
            self.vt[r.a as usize] = t as u32;
        }
        for i in 0..self.rim.len() {
            let r = self.rim[i];
            let j = self.vslot[r.b as usize] as usize;
            let (ti, tj) = (self.fan[i], self.fan[j]);
            self.n[ti as usize][1] = tj;
            self.n[tj as usize][2] = ti;
            if let Some([a, b]) = split {
                if r.b == a || r.b == b {
                    // The edge (r.b, vi) is half of the split constraint.
                    self.seg[ti as usize] |= 1 << 1;
                    self.seg[tj as usize] |= 1 << 2;
                }
            }
        }
        self.vt[vi as usize] = self.fan[0];
        Insert::Done(vi)
    }
}

/// Whether `q` lies strictly inside the diametral circle of [a, b].
pub(crate) fn encroaches(a: P, b: P, q: P) -> bool {
    let m = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
    let d2 = |x: P, y: P| (x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2);
    d2(q, m) < 0.25 * d2(a, b) * (1.0 - 1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit square as two triangles (diagonal 0–2), with the given constraint edges.
    fn square(constraints: &[[u32; 2]]) -> Tri {
        let pts = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let c: Vec<[u32; 2]> = constraints
            .iter()
            .map(|e| [e[0].min(e[1]), e[0].max(e[1])])
            .collect();
        let mut t = Tri::new(pts, vec![[0, 1, 2], [0, 2, 3]], |a, b| c.contains(&[a, b]));
        t.zone = vec![0, 0];
        t
    }

    /// Counter-clockwise triangles, symmetric neighbours and constraint bits, and the
    /// constrained Delaunay property across every non-constraint edge.
    fn assert_valid(t: &Tri) {
        for s in 0..t.v.len() as u32 {
            let p = t.corners(s);
            assert!(orient(p[0], p[1], p[2]) > 0.0, "triangle {s} not CCW");
            for k in 0..3 {
                let u = t.n[s as usize][k];
                if u == NONE {
                    continue;
                }
                let [a, b] = t.edge(s, k);
                let j = (0..3)
                    .find(|&j| t.edge(u, j) == [b, a])
                    .expect("neighbour shares the edge");
                assert_eq!(t.n[u as usize][j], s);
                assert_eq!(t.is_seg(s, k), t.is_seg(u, j));
                if !t.is_seg(s, k) {
                    let apex = t.pts[t.v[u as usize][j] as usize];
                    assert!(
                        !t.in_circle(s, apex),
                        "edge {a}–{b} is not locally Delaunay"
                    );
                }
            }
        }
    }

    #[test]
    fn insertions_keep_a_valid_delaunay_triangulation() {
        let mut t = square(&[[0, 1], [1, 2], [2, 3], [3, 0]]);
        let mut rng = crate::fixtures::rng(12345);
        let mut rnd = || crate::fixtures::uniform(&mut rng);
        for _ in 0..300 {
            let p = [0.05 + 0.9 * rnd(), 0.05 + 0.9 * rnd()];
            let Walk::Reached(s) = t.walk(
                0,
                t.corners(0)
                    .iter()
                    .fold([0.0; 2], |c, q| [c[0] + q[0] / 3.0, c[1] + q[1] / 3.0]),
                p,
            ) else {
                panic!("the walk did not reach {p:?}");
            };
            assert!(matches!(t.insert(p, &[s], None, false), Insert::Done(_)));
        }
        assert_eq!(t.pts.len(), 304);
        assert_eq!(t.v.len(), 2 * 304 - 4 - 2, "Euler: 2n − h − 2 triangles");
        assert_valid(&t);
    }

    #[test]
    fn a_split_constraint_becomes_two_constraints() {
        let mut t = square(&[[0, 2]]);
        let (s, k) = t.find_edge(0, 2).unwrap();
        let u = t.n[s as usize][k];
        let Insert::Done(m) = t.insert([0.5, 0.5], &[s, u], Some([0, 2]), false) else {
            panic!("the split was refused");
        };
        for e in [[0, m], [m, 2]] {
            let (s, k) = t.find_edge(e[0], e[1]).unwrap();
            assert!(t.is_seg(s, k), "{e:?} is a constraint");
        }
        assert_eq!(t.v.len(), 4);
        assert_valid(&t);
    }

    #[test]
    fn encroaching_and_duplicate_points_change_nothing() {
        let mut t = square(&[[0, 1], [1, 2], [2, 3], [3, 0]]);
        let before = (t.v.clone(), t.n.clone());
        // Close to the bottom edge: inside its diametral circle.
        match t.insert([0.5, 0.1], &[0], None, true) {
            Insert::Encroached(e) => assert_eq!(e, vec![[0, 1]]),
            _ => panic!("the bottom edge is encroached"),
        }
        // An existing vertex would make a flat triangle.
        assert!(matches!(
            t.insert([1.0, 1.0], &[0], None, false),
            Insert::Refused
        ));
        assert_eq!((t.v.clone(), t.n.clone()), before);
        assert_eq!(t.pts.len(), 4);
    }
}
