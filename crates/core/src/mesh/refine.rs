//! Delaunay refinement (Ruppert/Chew with Shewchuk's rules) of the domain's triangles only, on
//! the flat triangulation of `tri`.
//!
//! spade's own `refine` works on every face of the convex hull: the crescent between a concave
//! arc and its chord, and every gap between bodies, are refined too, which costs vertices and
//! can exhaust any budget. Here only triangles that belong to a zone are split; the exterior is
//! left as it is (Triangle removes it before refining, to the same effect). A constraint edge is
//! encroached only by vertices of domain triangles next to it.
//!
//! The loop: split encroached segments first (at the midpoint, or on a power-of-two shell around
//! an input vertex so that segments meeting at a small angle stop encroaching each other); then
//! take a domain triangle that is too big for h(x) or has an angle below the limit and insert its
//! circumcentre, unless that point lies behind a segment or encroaches one, in which case the
//! segment is split instead (one cavity search decides and inserts). Triangles whose smallest
//! angle comes from a small input angle are left alone (Miller–Pav–Walkington). A vertex budget
//! turns any runaway into an error.

use std::collections::VecDeque;

use super::geom::P;
use super::size::SizeField;
use super::tri::{encroaches, Insert, Tri, Walk, NONE};
use crate::scene::SceneError;

/// Input angles below this (degrees) may keep smaller element angles next to them.
pub(crate) const SMALL_INPUT_ANGLE: f64 = 60.0;

fn d2(a: P, b: P) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

fn circumcenter([a, b, c]: [P; 3]) -> P {
    let (bx, by, cx, cy) = (b[0] - a[0], b[1] - a[1], c[0] - a[0], c[1] - a[1]);
    let d = 2.0 * (bx * cy - by * cx);
    let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
    [
        a[0] + (cy * b2 - by * c2) / d,
        a[1] + (bx * c2 - cx * b2) / d,
    ]
}

/// The refinement state: the triangulation, h at every vertex, and the input segment each
/// Steiner point on a segment lies on.
pub(crate) struct Refiner<'a> {
    pub tri: Tri,
    h: Vec<f64>,
    /// For a vertex inserted on a segment: the two input vertices of that input segment.
    origin: Vec<Option<[u32; 2]>>,
    size: &'a SizeField,
    /// Largest allowed circumradius / shortest edge (1 / (2 sin θ_min)).
    ratio: f64,
    budget: usize,
    /// Constraint edges to test for encroachment (vertex pairs; gone ones are skipped).
    segments: Vec<[u32; 2]>,
    /// Bad domain triangles with their vertices (an entry whose slot changed is skipped).
    faces: VecDeque<(u32, [u32; 3])>,
}

impl<'a> Refiner<'a> {
    pub fn new(tri: Tri, size: &'a SizeField, min_angle: f64, budget: usize) -> Refiner<'a> {
        let h = tri.pts.iter().map(|&p| size.at(p)).collect();
        let origin = vec![None; tri.pts.len()];
        let ratio = if min_angle > 0.0 {
            1.0 / (2.0 * min_angle.to_radians().sin())
        } else {
            f64::INFINITY
        };
        let mut r = Refiner {
            tri,
            h,
            origin,
            size,
            ratio,
            budget,
            segments: Vec::new(),
            faces: VecDeque::new(),
        };
        for t in 0..r.tri.v.len() as u32 {
            for k in 0..3 {
                let e = r.tri.edge(t, k);
                if r.tri.is_seg(t, k) && (e[0] < e[1] || r.tri.n[t as usize][k] == NONE) {
                    r.segments.push(e);
                }
            }
            r.queue_if_bad(t);
        }
        r
    }

    /// Runs the refinement to completion.
    pub fn run(&mut self) -> Result<(), SceneError> {
        loop {
            if let Some(e) = self.segments.pop() {
                if self.is_encroached(e) {
                    self.split_segment(e)?;
                }
            } else if let Some((t, v)) = self.faces.pop_front() {
                if self.tri.v[t as usize] == v {
                    self.fix_face(t, v)?;
                }
            } else {
                return Ok(());
            }
        }
    }

    /// Whether a vertex of a domain triangle next to the constraint edge lies in its diametral
    /// circle.
    fn is_encroached(&self, [a, b]: [u32; 2]) -> bool {
        let Some((t, k)) = self.tri.find_edge(a, b) else {
            return false;
        };
        if !self.tri.is_seg(t, k) {
            return false;
        }
        let (pa, pb) = (self.tri.pts[a as usize], self.tri.pts[b as usize]);
        [t, self.tri.n[t as usize][k]].into_iter().any(|s| {
            s != NONE && self.tri.zone[s as usize] != NONE && {
                let apex = self.tri.v[s as usize]
                    .into_iter()
                    .find(|&x| x != a && x != b)
                    .unwrap_or(a);
                encroaches(pa, pb, self.tri.pts[apex as usize])
            }
        })
    }

    fn check_budget(&self) -> Result<(), SceneError> {
        if self.tri.pts.len() >= self.budget {
            Err(SceneError::new(
                "mesh",
                format!(
                    "the refinement needed more than {} vertices; check the geometry for tiny \
                     features or lower mesh.min_angle",
                    self.budget
                ),
            ))
        } else {
            Ok(())
        }
    }

    /// Bookkeeping after inserting vertex `v`: its h and origin, the new triangles that need
    /// work and the constraint edges to look at again.
    fn after_insert(&mut self, v: u32, origin: Option<[u32; 2]>) {
        self.h.push(self.size.at(self.tri.pts[v as usize]));
        self.origin.push(origin);
        for i in 0..self.tri.fan.len() {
            let t = self.tri.fan[i];
            for k in 0..3 {
                if self.tri.is_seg(t, k) {
                    self.segments.push(self.tri.edge(t, k));
                }
            }
            self.queue_if_bad(t);
        }
    }

    fn queue_if_bad(&mut self, t: u32) {
        if self.tri.zone[t as usize] != NONE && self.is_bad(t) {
            self.faces.push_back((t, self.tri.v[t as usize]));
        }
    }

    /// Whether a domain triangle is too big for h at its corners, or too skinny (unless a small
    /// input angle forces it).
    fn is_bad(&self, t: u32) -> bool {
        let p = self.tri.corners(t);
        let l2 = [d2(p[1], p[2]), d2(p[2], p[0]), d2(p[0], p[1])];
        let (lmin2, lmax2) = (l2[0].min(l2[1]).min(l2[2]), l2[0].max(l2[1]).max(l2[2]));
        let hmin = self.tri.v[t as usize]
            .iter()
            .map(|&v| self.h[v as usize])
            .fold(f64::INFINITY, f64::min);
        if lmax2 > (hmin * (1.0 + 1e-9)).powi(2) {
            return true;
        }
        let r2 = d2(circumcenter(p), p[0]);
        r2 > self.ratio * self.ratio * lmin2 * (1.0 + 1e-9) && !self.small_input_angle(t)
    }

    /// Splits a constraint edge at its midpoint or on a power-of-two shell around an input
    /// vertex. Returns false when the split point cannot be placed.
    fn split_segment(&mut self, [a, b]: [u32; 2]) -> Result<bool, SceneError> {
        self.check_budget()?;
        let Some((t, k)) = self.tri.find_edge(a, b) else {
            return Ok(false);
        };
        if !self.tri.is_seg(t, k) {
            return Ok(false);
        }
        let (pa, pb) = (self.tri.pts[a as usize], self.tri.pts[b as usize]);
        let (oa, ob) = (self.origin[a as usize], self.origin[b as usize]);
        let len = d2(pa, pb).sqrt();
        // Distance of the split point from a.
        let s = match (oa, ob) {
            (None, Some(_)) => (0.5 * len).log2().round().exp2() / len,
            (Some(_), None) => 1.0 - (0.5 * len).log2().round().exp2() / len,
            _ => 0.5,
        };
        let m = [pa[0] + s * (pb[0] - pa[0]), pa[1] + s * (pb[1] - pa[1])];
        if !(m[0].is_finite() && m[1].is_finite()) || m == pa || m == pb {
            return Ok(false);
        }
        let u = self.tri.n[t as usize][k];
        let seeds = [t, u];
        let sides = if u == NONE { 1 } else { 2 };
        match self.tri.insert(m, &seeds[..sides], Some([a, b]), false) {
            Insert::Done(v) => {
                self.after_insert(v, Some(oa.or(ob).unwrap_or([a, b])));
                Ok(true)
            }
            _ => Ok(false),
        }
    }

    /// Whether the smallest angle of the triangle is forced by a small input angle: it fills a
    /// whole input corner, or its shortest edge joins two points on segments from a common
    /// input vertex that meet there at less than `SMALL_INPUT_ANGLE`.
    fn small_input_angle(&self, t: u32) -> bool {
        let p = self.tri.corners(t);
        let l2 = [d2(p[1], p[2]), d2(p[2], p[0]), d2(p[0], p[1])];
        let k = (0..3).min_by(|&i, &j| l2[i].total_cmp(&l2[j])).unwrap_or(0);
        // The corner opposite the shortest edge.
        if self.tri.is_seg(t, (k + 1) % 3) && self.tri.is_seg(t, (k + 2) % 3) {
            return true;
        }
        if self.tri.is_seg(t, k) {
            return false;
        }
        let [u, w] = self.tri.edge(t, k);
        let apexes = |x: u32| self.origin[x as usize].unwrap_or([x, x]);
        let (au, aw) = (apexes(u), apexes(w));
        if au == aw || au.iter().rev().eq(aw.iter()) {
            return false;
        }
        au.iter().filter(|q| aw.contains(q)).any(|&q| {
            let pp = self.tri.pts[q as usize];
            let (du, dw) = (self.tri.pts[u as usize], self.tri.pts[w as usize]);
            let (x1, y1, x2, y2) = (du[0] - pp[0], du[1] - pp[1], dw[0] - pp[0], dw[1] - pp[1]);
            let angle = (x1 * y2 - y1 * x2).abs().atan2(x1 * x2 + y1 * y2);
            angle.to_degrees() < SMALL_INPUT_ANGLE
        })
    }

    /// Refines one bad triangle.
    fn fix_face(&mut self, t: u32, v: [u32; 3]) -> Result<(), SceneError> {
        let z = self.tri.zone[t as usize];
        let p = self.tri.corners(t);
        let c = circumcenter(p);
        if !(c[0].is_finite() && c[1].is_finite()) {
            return Ok(());
        }
        self.check_budget()?;
        let centre = [
            (p[0][0] + p[1][0] + p[2][0]) / 3.0,
            (p[0][1] + p[1][1] + p[2][1]) / 3.0,
        ];
        // A segment between the triangle and its circumcentre (or under it) is split instead.
        let target = match self.tri.walk(t, centre, c) {
            Walk::Reached(g) if self.tri.zone[g as usize] == z => g,
            Walk::Blocked(s, k) => {
                if self.split_segment(self.tri.edge(s, k))? {
                    self.faces.push_back((t, v));
                }
                return Ok(());
            }
            _ => return Ok(()),
        };
        match self.tri.insert(c, &[target], None, true) {
            Insert::Done(x) => self.after_insert(x, None),
            Insert::Encroached(segments) => {
                let mut split = false;
                for s in segments {
                    split |= self.split_segment(s)?;
                }
                if split {
                    self.faces.push_back((t, v));
                }
            }
            Insert::Refused => {}
        }
        Ok(())
    }
}
