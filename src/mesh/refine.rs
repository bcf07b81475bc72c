//! Delaunay refinement (Ruppert/Chew with Shewchuk's rules) of the domain's faces only.
//!
//! spade's own `refine` works on every face of the convex hull: the crescent between a concave
//! arc and its chord, and every gap between bodies, are refined too, which costs vertices and
//! can exhaust any budget. Here only faces that belong to a zone are split; the exterior is left
//! as it is (Triangle removes it before refining, to the same effect). A constraint edge is
//! encroached only by vertices of domain faces next to it.
//!
//! The loop: split encroached segments first (at the midpoint, or on a power-of-two shell around
//! an input vertex so that segments meeting at a small angle stop encroaching each other); then
//! take a domain face that is too big for h(x) or has an angle below the limit and insert its
//! circumcentre, unless that point lies behind a segment or encroaches one, in which case the
//! segment is split instead. Faces whose smallest angle comes from a small input angle are left
//! alone (Miller–Pav–Walkington). A vertex budget turns any runaway into an error.

use std::collections::VecDeque;

use spade::handles::{FixedFaceHandle, FixedUndirectedEdgeHandle, FixedVertexHandle, InnerTag};
use spade::{ConstrainedDelaunayTriangulation, Point2, PositionInTriangulation, Triangulation};

use super::size::SizeField;
use crate::scene::SceneError;

pub(crate) type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// Where a straight walk through the triangulation ended.
enum Walk {
    Reached(FixedFaceHandle<InnerTag>),
    Blocked(FixedUndirectedEdgeHandle),
    Lost,
}

/// Input angles below this (degrees) may keep smaller element angles next to them.
pub(crate) const SMALL_INPUT_ANGLE: f64 = 60.0;

/// The refinement state: the triangulation, the zone of every face (by face index, `None`
/// outside the domain), h at every vertex, and the input segment each Steiner point lies on.
pub(crate) struct Refiner<'a> {
    pub cdt: Cdt,
    pub zone: Vec<Option<usize>>,
    h: Vec<f64>,
    /// For a vertex inserted on a segment: the two input vertices of that input segment.
    origin: Vec<Option<[FixedVertexHandle; 2]>>,
    size: &'a SizeField,
    /// Largest allowed circumradius / shortest edge (1 / (2 sin θ_min)).
    ratio: f64,
    budget: usize,
    segments: Vec<FixedUndirectedEdgeHandle>,
    faces: VecDeque<FixedFaceHandle<InnerTag>>,
}

fn p2(p: Point2<f64>) -> [f64; 2] {
    [p.x, p.y]
}

fn d2(a: Point2<f64>, b: Point2<f64>) -> f64 {
    (a.x - b.x).powi(2) + (a.y - b.y).powi(2)
}

/// Whether `q` lies strictly inside the diametral circle of [a, b].
fn encroaches(a: Point2<f64>, b: Point2<f64>, q: Point2<f64>) -> bool {
    let m = Point2::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y));
    d2(q, m) < 0.25 * d2(a, b) * (1.0 - 1e-12)
}

/// Whether `q` lies strictly inside the circumcircle of the CCW triangle (a, b, c) (float test;
/// only used to collect the segments a new point would see).
fn in_circle(a: Point2<f64>, b: Point2<f64>, c: Point2<f64>, q: Point2<f64>) -> bool {
    let (ax, ay) = (a.x - q.x, a.y - q.y);
    let (bx, by) = (b.x - q.x, b.y - q.y);
    let (cx, cy) = (c.x - q.x, c.y - q.y);
    let det = (ax * ax + ay * ay) * (bx * cy - cx * by) - (bx * bx + by * by) * (ax * cy - cx * ay)
        + (cx * cx + cy * cy) * (ax * by - bx * ay);
    det > 0.0
}

impl<'a> Refiner<'a> {
    pub fn new(
        cdt: Cdt,
        zone: Vec<Option<usize>>,
        size: &'a SizeField,
        min_angle: f64,
        budget: usize,
    ) -> Refiner<'a> {
        let h = cdt.vertices().map(|v| size.at(p2(v.position()))).collect();
        let origin = vec![None; cdt.num_vertices()];
        let segments = cdt
            .fixed_undirected_edges()
            .filter(|&e| cdt.is_constraint_edge(e))
            .collect();
        let faces = cdt
            .fixed_inner_faces()
            .filter(|f| zone[f.index()].is_some())
            .collect();
        let ratio = if min_angle > 0.0 {
            1.0 / (2.0 * min_angle.to_radians().sin())
        } else {
            f64::INFINITY
        };
        Refiner {
            cdt,
            zone,
            h,
            origin,
            size,
            ratio,
            budget,
            segments,
            faces,
        }
    }

    /// Runs the refinement to completion.
    pub fn run(&mut self) -> Result<(), SceneError> {
        loop {
            if let Some(e) = self.segments.pop() {
                if self.is_encroached(e) {
                    self.split_segment(e)?;
                }
            } else if let Some(f) = self.faces.pop_front() {
                self.fix_face(f)?;
            } else {
                return Ok(());
            }
        }
    }

    fn face_zone(&self, f: FixedFaceHandle<InnerTag>) -> Option<usize> {
        self.zone.get(f.index()).copied().flatten()
    }

    /// Whether a vertex of a domain face next to the constraint edge lies in its diametral circle.
    fn is_encroached(&self, e: FixedUndirectedEdgeHandle) -> bool {
        let edge = self.cdt.directed_edge(e.as_directed());
        if !edge.is_constraint_edge() {
            return false;
        }
        let [a, b] = edge.positions();
        [edge, edge.rev()].into_iter().any(|d| {
            let inside = d
                .face()
                .as_inner()
                .is_some_and(|f| self.face_zone(f.fix()).is_some());
            inside && d.opposite_position().is_some_and(|q| encroaches(a, b, q))
        })
    }

    fn check_budget(&self) -> Result<(), SceneError> {
        if self.cdt.num_vertices() >= self.budget {
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

    /// Bookkeeping after inserting vertex `v`: h and origin of the new vertex, zones of new faces
    /// (`zone` for all new face indices), and the faces and segments to look at again.
    fn after_insert(
        &mut self,
        v: FixedVertexHandle,
        zone: Option<usize>,
        origin: Option<[FixedVertexHandle; 2]>,
    ) {
        let p = self.cdt.vertex(v).position();
        self.h.push(self.size.at(p2(p)));
        self.origin.push(origin);
        self.zone.resize(self.cdt.num_all_faces(), zone);
        self.queue_around(v);
    }

    fn queue_around(&mut self, v: FixedVertexHandle) {
        for e in self.cdt.vertex(v).out_edges() {
            if let Some(f) = e.face().as_inner() {
                self.faces.push_back(f.fix());
            }
            if e.is_constraint_edge() {
                self.segments.push(e.fix().as_undirected());
            }
            let opposite = e.next();
            if opposite.is_constraint_edge() {
                self.segments.push(opposite.fix().as_undirected());
            }
        }
    }

    /// Splits a constraint edge at its midpoint or on a power-of-two shell around an input
    /// vertex. Returns false when the split point cannot be placed safely.
    fn split_segment(&mut self, e: FixedUndirectedEdgeHandle) -> Result<bool, SceneError> {
        self.check_budget()?;
        let edge = self.cdt.directed_edge(e.as_directed());
        let [a, b] = [edge.from().fix(), edge.to().fix()];
        let [pa, pb] = edge.positions();
        let (oa, ob) = (self.origin[a.index()], self.origin[b.index()]);
        let len = d2(pa, pb).sqrt();
        // Distance of the split point from a.
        let t = match (oa, ob) {
            (None, Some(_)) => (0.5 * len).log2().round().exp2() / len,
            (Some(_), None) => 1.0 - (0.5 * len).log2().round().exp2() / len,
            _ => 0.5,
        };
        let m = Point2::new(pa.x + t * (pb.x - pa.x), pa.y + t * (pb.y - pa.y));
        // The point must lie strictly inside the quadrilateral of the edge's two faces.
        let valid = m.x.is_finite()
            && d2(m, pa) > 0.0
            && d2(m, pb) > 0.0
            && [edge, edge.rev()].into_iter().all(|d| {
                d.opposite_vertex().is_none_or(|_| {
                    d.next().side_query(m).is_on_left_side()
                        && d.prev().side_query(m).is_on_left_side()
                })
            });
        if !valid {
            return Ok(false);
        }
        let zones =
            [edge, edge.rev()].map(|d| d.face().as_inner().and_then(|f| self.face_zone(f.fix())));
        let origin = oa.or(ob).unwrap_or([a, b]);
        let located = self.cdt.locate_with_hint(m, a);
        let v = self
            .cdt
            .insert_with_hint(m, a)
            .map_err(|err| SceneError::new("mesh", format!("mesher bug: {err}")))?;
        if v.index() < self.origin.len() {
            return Ok(false);
        }
        match located {
            PositionInTriangulation::OnEdge(_) => {
                // spade split the constraint edge; faces on each side keep that side's zone.
                self.h.push(self.size.at(p2(m)));
                self.origin.push(Some(origin));
                self.zone.resize(self.cdt.num_all_faces(), None);
                let around: Vec<_> = self
                    .cdt
                    .vertex(v)
                    .out_edges()
                    .filter_map(|d| d.face().as_inner().map(|f| (f.fix(), f.center())))
                    .collect();
                for (f, c) in around {
                    let left = (pb.x - pa.x) * (c.y - pa.y) - (pb.y - pa.y) * (c.x - pa.x) > 0.0;
                    self.zone[f.index()] = if left { zones[0] } else { zones[1] };
                }
                self.queue_around(v);
            }
            PositionInTriangulation::OnFace(f) => {
                // m is a hair off the edge: it sits in one of the edge's faces, forming a
                // sliver (a, b, m). Constrain a–m and m–b, then release a–b: the sliver merges
                // with the face across, on that side.
                let inserted_zone = self.face_zone(f);
                self.h.push(self.size.at(p2(m)));
                self.origin.push(Some(origin));
                self.zone.resize(self.cdt.num_all_faces(), inserted_zone);
                self.resplit(a, b, v, zones)?;
                self.queue_around(v);
            }
            _ => {
                return Err(SceneError::new(
                    "mesh",
                    "mesher bug: a segment split point fell outside the segment's faces",
                ))
            }
        }
        Ok(true)
    }

    /// Replaces the constraint a–b by a–v and v–b when v sits just off a–b (see
    /// `split_segment`); `zones` are the zones left and right of a → b.
    fn resplit(
        &mut self,
        a: FixedVertexHandle,
        b: FixedVertexHandle,
        v: FixedVertexHandle,
        zones: [Option<usize>; 2],
    ) -> Result<(), SceneError> {
        let bug = |what: &str| SceneError::new("mesh", format!("mesher bug: {what}"));
        let ab = self
            .cdt
            .get_edge_from_neighbors(a, b)
            .ok_or_else(|| bug("a split segment lost its edge"))?;
        // The sliver is the face of a → b (or b → a) whose opposite vertex is v.
        let left_is_sliver = ab.opposite_vertex().is_some_and(|o| o.fix() == v);
        let (sliver, other, other_zone) = if left_is_sliver {
            (ab.face(), ab.rev().face(), zones[1])
        } else {
            (ab.rev().face(), ab.face(), zones[0])
        };
        let handles: Vec<FixedFaceHandle<InnerTag>> = [sliver, other]
            .into_iter()
            .filter_map(|f| f.as_inner().map(|f| f.fix()))
            .collect();
        let ab = ab.fix().as_undirected();
        if self.cdt.try_add_constraint(a, v).is_empty()
            || self.cdt.try_add_constraint(v, b).is_empty()
        {
            return Err(bug("cannot constrain the halves of a split segment"));
        }
        self.cdt.remove_constraint_edge(ab);
        for f in handles {
            self.zone[f.index()] = other_zone;
        }
        Ok(())
    }

    /// Whether the smallest angle of the face is forced by a small input angle: the face fills
    /// a whole input corner, or its shortest edge joins two points on segments from a common
    /// input vertex that meet there at less than `SMALL_INPUT_ANGLE`.
    fn small_input_angle(&self, f: FixedFaceHandle<InnerTag>) -> bool {
        let face = self.cdt.face(f);
        let Some(shortest) = face
            .adjacent_edges()
            .into_iter()
            .min_by(|x, y| x.length_2().total_cmp(&y.length_2()))
        else {
            return false;
        };
        // The corner opposite the shortest edge.
        let corner_edges = [shortest.next(), shortest.prev()];
        if corner_edges.iter().all(|e| e.is_constraint_edge()) {
            return true;
        }
        if shortest.is_constraint_edge() {
            return false;
        }
        let (u, w) = (shortest.from(), shortest.to());
        let apexes = |x: FixedVertexHandle| match self.origin[x.index()] {
            Some(o) => o.to_vec(),
            None => vec![x],
        };
        let (au, aw) = (apexes(u.fix()), apexes(w.fix()));
        if au == aw || au.iter().rev().eq(aw.iter()) {
            return false;
        }
        au.iter().filter(|p| aw.contains(p)).any(|&p| {
            let pp = self.cdt.vertex(p).position();
            let (du, dw) = (u.position(), w.position());
            let (x1, y1, x2, y2) = (du.x - pp.x, du.y - pp.y, dw.x - pp.x, dw.y - pp.y);
            let angle = (x1 * y2 - y1 * x2).abs().atan2(x1 * x2 + y1 * y2);
            angle.to_degrees() < SMALL_INPUT_ANGLE
        })
    }

    /// Refines one face if it is too big or too skinny.
    fn fix_face(&mut self, f: FixedFaceHandle<InnerTag>) -> Result<(), SceneError> {
        let Some(z) = self.face_zone(f) else {
            return Ok(());
        };
        let face = self.cdt.face(f);
        let pos = face.positions();
        let vs = face.vertices().map(|v| v.fix());
        let l2 = [d2(pos[1], pos[2]), d2(pos[2], pos[0]), d2(pos[0], pos[1])];
        let (lmin2, lmax2) = (l2[0].min(l2[1]).min(l2[2]), l2[0].max(l2[1]).max(l2[2]));
        let hmin = vs
            .iter()
            .map(|v| self.h[v.index()])
            .fold(f64::INFINITY, f64::min);
        let big = lmax2.sqrt() > hmin * (1.0 + 1e-9);
        let c = face.circumcenter();
        let r2 = d2(c, pos[0]);
        let skinny = r2 > self.ratio * self.ratio * lmin2 * (1.0 + 1e-9);
        let needs_work = big || (skinny && !self.small_input_angle(f));
        if !needs_work {
            return Ok(());
        }
        if !(c.x.is_finite() && c.y.is_finite()) {
            return Ok(());
        }
        self.check_budget()?;
        let centre = face.center();
        // A segment between the face and its circumcentre (or under it) is split instead.
        let target = match self.walk(f, centre, c) {
            Walk::Reached(g) if self.face_zone(g) == Some(z) => g,
            Walk::Blocked(s) => {
                if self.split_segment(s)? {
                    self.faces.push_back(f);
                }
                return Ok(());
            }
            _ => return Ok(()),
        };
        let hint = self.cdt.face(target).vertices()[0].fix();
        let encroached = self.encroached_by(target, c);
        if !encroached.is_empty() {
            let mut split = false;
            for s in encroached {
                split |= self.split_segment(s)?;
            }
            if split {
                self.faces.push_back(f);
            }
            return Ok(());
        }
        let v = self
            .cdt
            .insert_with_hint(c, hint)
            .map_err(|err| SceneError::new("mesh", format!("mesher bug: {err}")))?;
        if v.index() >= self.origin.len() {
            self.after_insert(v, Some(z), None);
        }
        Ok(())
    }

    /// Walks from face `f` (containing `from`) straight towards `to`: the face containing `to`,
    /// or the first constraint edge crossed on the way or containing `to`.
    fn walk(&self, f: FixedFaceHandle<InnerTag>, from: Point2<f64>, to: Point2<f64>) -> Walk {
        let side = |a: Point2<f64>, b: Point2<f64>, p: Point2<f64>| {
            (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
        };
        let mut face = f;
        for _ in 0..self.cdt.num_inner_faces() {
            let exit = self.cdt.face(face).adjacent_edges().into_iter().find(|e| {
                let [a, b] = e.positions();
                e.side_query(to).is_on_right_side() && side(from, to, a) * side(from, to, b) <= 0.0
            });
            let Some(e) = exit else {
                // `to` lies in this face or on its boundary; on a segment means splitting it.
                let on = self
                    .cdt
                    .face(face)
                    .adjacent_edges()
                    .into_iter()
                    .find(|e| e.is_constraint_edge() && e.side_query(to).is_on_line());
                return match on {
                    Some(e) => Walk::Blocked(e.fix().as_undirected()),
                    None => Walk::Reached(face),
                };
            };
            if e.is_constraint_edge() {
                return Walk::Blocked(e.fix().as_undirected());
            }
            match e.rev().face().as_inner() {
                Some(g) => face = g.fix(),
                None => return Walk::Lost,
            }
        }
        Walk::Lost
    }

    /// Segments (constraint edges) on the boundary of the Delaunay cavity of `p` (started at
    /// face `start`) whose diametral circle contains `p`.
    fn encroached_by(
        &self,
        start: FixedFaceHandle<InnerTag>,
        p: Point2<f64>,
    ) -> Vec<FixedUndirectedEdgeHandle> {
        let mut out = Vec::new();
        let mut seen = vec![start];
        let mut stack = vec![start];
        while let Some(f) = stack.pop() {
            for e in self.cdt.face(f).adjacent_edges() {
                if e.is_constraint_edge() {
                    let [a, b] = e.positions();
                    if encroaches(a, b, p) && !out.contains(&e.fix().as_undirected()) {
                        out.push(e.fix().as_undirected());
                    }
                    continue;
                }
                if let Some(g) = e.rev().face().as_inner() {
                    let [x, y, z] = g.positions();
                    if !seen.contains(&g.fix()) && in_circle(x, y, z, p) {
                        seen.push(g.fix());
                        stack.push(g.fix());
                    }
                }
            }
        }
        out
    }
}
