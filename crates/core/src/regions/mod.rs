//! Geometry of the criteria Φ1–Φ6 and the defined criteria (design §4.2): weights that turn a mesh field into its exact mean
//! over an area G_r or a boundary piece G'_r, and the normals n(X_r).
//!
//! An area region is clipped against every triangle of the body holding most of it
//! (Sutherland–Hodgman, the region polygon clipped by each convex triangle); the clipped pieces
//! give the exact integral of the P1 interpolant (∫λ_i = λ_i applied to the area and first
//! moments) and of element-constant fields. A boundary piece is the part of a segment between
//! the projections of two points; its weights integrate the P1 trace exactly, partial edges
//! included, whether the piece spans many edges or lies inside one (it is measured on the
//! traces of the edges it crosses, never refused for being shorter than an element). Means are then `Σ w_i f_i`.
//! A receiver's peak velocity (a defined criterion of a dynamic scene, design §3.5) reads the
//! P1 interpolant at the receiver: the shape functions' values there are its weights.

use std::collections::BTreeMap;

use crate::mesh::assemble::boundary_edges;
use crate::mesh::geom::{
    bbox, dist, lerp, orient, point_in_ring, point_segment, ring_moments, segment_segment,
    signed_area, P,
};
use crate::mesh::Mesh;
use crate::scene::{
    BoundaryPiece, CriterionRegion, DefinedCriterion, DefinedQuantity, Scene, SceneError,
};

/// X_r may lie at most this many lengths of the nearest boundary edge away from the boundary.
const NORMAL_REACH: f64 = 3.0;

/// An area G_r with its mean weights.
#[derive(Debug, Clone, PartialEq)]
pub struct AreaRegion {
    /// Name of the region from the scene (`criteria.regions[].name`).
    pub name: String,
    /// Body holding (most of) the region; only its triangles contribute.
    pub body: usize,
    /// Area of the region inside that body \[m²\].
    pub area: f64,
    /// (node, weight): mean of a P1 field f = Σ w_i f_i; the weights sum to 1.
    pub node_weights: Vec<(usize, f64)>,
    /// (triangle, weight): mean of an element-constant field; the weights sum to 1.
    pub element_weights: Vec<(usize, f64)>,
    /// n(X_r): the given `normal`, or the outward normal of the body at `normal_at`; `None` when
    /// neither is given (Φ3 and Φ6 are then not available for this region).
    pub normal: Option<[f64; 2]>,
    /// Nearest contact zone (index into `Mesh::contacts`) with a segment on the region's body.
    pub contact: Option<usize>,
    /// Distance from the region to that contact zone \[m\] (infinite when there is none).
    pub contact_distance: f64,
    /// The region touches that contact zone (G_r adjacent to Γc, FGCS 4.34): Φ6 uses it.
    pub adjacent_to_contact: bool,
}

/// A boundary piece G'_r with its mean weights.
#[derive(Debug, Clone, PartialEq)]
pub struct PieceRegion {
    /// Name of the piece from the scene (`criteria.boundary_pieces[].name`).
    pub name: String,
    /// Index into `Mesh::segments`.
    pub segment: usize,
    /// Index of the segment's body in `Mesh::bodies`.
    pub body: usize,
    /// Length of the piece \[m\].
    pub length: f64,
    /// (node, weight): mean of the P1 trace of a field over the piece; the weights sum to 1.
    pub node_weights: Vec<(usize, f64)>,
    /// Outward unit normal of the body at X_r (`normal_at`, default the piece's midpoint).
    pub normal: [f64; 2],
}

/// The weights of all criteria regions of a scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CriteriaGeometry {
    /// The areas G_r in scene order (`criteria.regions`).
    pub regions: Vec<AreaRegion>,
    /// The boundary pieces G'_r in scene order (`criteria.boundary_pieces`).
    pub pieces: Vec<PieceRegion>,
    /// The defined criteria in scene order (`criteria.defined`).
    pub defined: Vec<DefinedRegion>,
}

/// A defined criterion on the mesh: the mean of `quantity` over an area (`regions[region]`) or,
/// for a contact traction, over a boundary piece (`pieces[region]`).
#[derive(Debug, Clone, PartialEq)]
pub struct DefinedRegion {
    /// The criterion's name (`criteria.defined[].name`).
    pub name: String,
    /// The area ([`CriteriaGeometry::regions`]) or, for a contact traction, the boundary piece
    /// ([`CriteriaGeometry::pieces`]).
    pub region: usize,
    /// The quantity averaged.
    pub quantity: DefinedQuantity,
    /// A contact traction's mean as a form on the contact multipliers, (row, coefficient); set
    /// by the state problem once the contact pairs are known (empty for a stress quantity).
    pub multipliers: Vec<(usize, f64)>,
    /// For `peak_velocity`, the receiver's P1 interpolation, (node, shape function value at the
    /// receiver); `region` is then the receiver's index in `receivers` (empty otherwise).
    pub receiver: Vec<(usize, f64)>,
}

/// Builds the weights and normals of the scene's criteria regions on `mesh`.
pub fn build(scene: &Scene, mesh: &Mesh) -> Result<CriteriaGeometry, SceneError> {
    let boundary = boundary_edges(mesh);
    let regions = scene
        .criteria
        .regions
        .iter()
        .enumerate()
        .map(|(r, region)| area_region(r, region, mesh, &boundary))
        .collect::<Result<_, _>>()?;
    let pieces = scene
        .criteria
        .boundary_pieces
        .iter()
        .enumerate()
        .map(|(r, piece)| piece_region(r, piece, mesh, &boundary))
        .collect::<Result<_, _>>()?;
    let defined = scene
        .criteria
        .defined
        .iter()
        .enumerate()
        .map(|(k, d)| {
            let criteria = &scene.criteria;
            let place = d.place();
            if d.quantity.is_receiver() {
                return receiver_criterion(scene, mesh, k, d);
            }
            let region = if d.quantity.is_contact() {
                criteria
                    .boundary_pieces
                    .iter()
                    .position(|p| p.name == place)
            } else {
                criteria.regions.iter().position(|g| g.name == place)
            };
            let region = region.ok_or_else(|| {
                SceneError::new(
                    format!("criteria.defined[{k}].region"),
                    format!("'{place}' is no region of this criterion's kind"),
                )
            })?;
            Ok(DefinedRegion {
                name: d.name.clone(),
                region,
                quantity: d.quantity,
                multipliers: Vec::new(),
                receiver: Vec::new(),
            })
        })
        .collect::<Result<_, SceneError>>()?;
    Ok(CriteriaGeometry {
        regions,
        pieces,
        defined,
    })
}

/// The `k`-th defined criterion `d`, a receiver's peak velocity: the receiver located in the
/// mesh (its P1 shape functions at the point, design §3.5).
fn receiver_criterion(
    scene: &Scene,
    mesh: &Mesh,
    k: usize,
    d: &DefinedCriterion,
) -> Result<DefinedRegion, SceneError> {
    let place = d.place();
    let index = scene
        .receivers
        .iter()
        .position(|r| r.name == place)
        .ok_or_else(|| {
            SceneError::new(
                format!("criteria.defined[{k}].receiver"),
                format!("'{place}' is not the name of one of the scene's `receivers`"),
            )
        })?;
    let (nodes, weights) = mesh.locate(scene.receivers[index].point).ok_or_else(|| {
        SceneError::new(format!("receivers[{index}].point"), "not inside any body")
    })?;
    Ok(DefinedRegion {
        name: d.name.clone(),
        region: index,
        quantity: d.quantity,
        multipliers: Vec::new(),
        receiver: nodes.into_iter().zip(weights).collect(),
    })
}

fn finite_point(p: P, path: impl FnOnce() -> String) -> Result<P, SceneError> {
    if p.iter().all(|c| c.is_finite()) {
        Ok(p)
    } else {
        Err(SceneError::new(
            path(),
            "coordinates must be finite numbers",
        ))
    }
}

/// The part of the region inside one triangle: its area and first moments.
struct Cut {
    triangle: usize,
    area: f64,
    moment: P,
}

fn area_region(
    r: usize,
    region: &CriterionRegion,
    mesh: &Mesh,
    boundary: &[Vec<[usize; 2]>],
) -> Result<AreaRegion, SceneError> {
    let path = format!("criteria.regions[{r}]");
    let mut poly = region.polygon.clone();
    if poly.len() < 3 || poly.iter().flatten().any(|c| !c.is_finite()) {
        return Err(SceneError::new(
            format!("{path}.polygon"),
            "needs at least 3 points with finite coordinates",
        ));
    }
    if signed_area(&poly) < 0.0 {
        poly.reverse();
    }
    let cuts = clip_against_mesh(&poly, mesh);
    let mut per_body = vec![0.0; mesh.bodies.len()];
    for c in &cuts {
        per_body[body_of_triangle(mesh, c.triangle)] += c.area;
    }
    let (body, area) =
        per_body.iter().copied().enumerate().fold(
            (0, 0.0),
            |best, (b, a)| if a > best.1 { (b, a) } else { best },
        );
    if area <= 0.0 {
        return Err(SceneError::new(
            format!("{path}.polygon"),
            "the region does not overlap the mesh",
        ));
    }
    let mut nodes: BTreeMap<usize, f64> = BTreeMap::new();
    let mut element_weights = Vec::new();
    for c in cuts
        .iter()
        .filter(|c| body_of_triangle(mesh, c.triangle) == body)
    {
        let tri = mesh.triangles[c.triangle];
        for (i, w) in barycentric_integrals(tri.map(|n| mesh.nodes[n]), c.area, c.moment)
            .into_iter()
            .enumerate()
        {
            *nodes.entry(tri[i]).or_default() += w / area;
        }
        element_weights.push((c.triangle, c.area / area));
    }
    let normal = match (region.normal, region.normal_at) {
        (Some(n), _) => Some(unit(n).ok_or_else(|| {
            SceneError::new(format!("{path}.normal"), "must be a finite non-zero vector")
        })?),
        (None, Some(x)) => {
            let at = format!("{path}.normal_at");
            let x = finite_point(x, || at.clone())?;
            Some(boundary_normal(mesh, &boundary[body], x, &at)?)
        }
        (None, None) => None,
    };
    let (contact, contact_distance) = nearest_contact(mesh, body, &poly);
    Ok(AreaRegion {
        name: region.name.clone(),
        body,
        area,
        node_weights: nodes.into_iter().collect(),
        element_weights,
        normal,
        contact,
        contact_distance,
        adjacent_to_contact: contact_distance <= crate::scene::touching_tolerance(&region.polygon),
    })
}

fn body_of_triangle(mesh: &Mesh, t: usize) -> usize {
    mesh.zones[mesh.triangle_zone[t]].body
}

/// The pieces of the (CCW) polygon inside each triangle whose box meets the polygon's box.
fn clip_against_mesh(poly: &[P], mesh: &Mesh) -> Vec<Cut> {
    let pb = bbox(poly.iter().copied());
    let mut cuts = Vec::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let corners = tri.map(|n| mesh.nodes[n]);
        let tb = bbox(corners);
        if tb[0] > pb[2] || tb[2] < pb[0] || tb[1] > pb[3] || tb[3] < pb[1] {
            continue;
        }
        let piece = clip_by_triangle(poly, corners);
        let (area, moment) = ring_moments(&piece);
        if area > 0.0 {
            cuts.push(Cut {
                triangle: t,
                area,
                moment,
            });
        }
    }
    cuts
}

/// Sutherland–Hodgman: the part of `subject` left of each edge of the CCW triangle.
fn clip_by_triangle(subject: &[P], tri: [P; 3]) -> Vec<P> {
    let mut out = subject.to_vec();
    for k in 0..3 {
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        let input = std::mem::take(&mut out);
        let n = input.len();
        for i in 0..n {
            let (p, q) = (input[i], input[(i + 1) % n]);
            let (sp, sq) = (orient(a, b, p), orient(a, b, q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                out.push(lerp(p, q, sp / (sp - sq)));
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

/// ∫ λ_i over a part of the triangle with the given area and first moments (λ_i affine).
fn barycentric_integrals(t: [P; 3], area: f64, moment: P) -> [f64; 3] {
    let det = orient(t[0], t[1], t[2]);
    let mut out = [0.0; 3];
    for (i, w) in out.iter_mut().enumerate() {
        let (b, c) = (t[(i + 1) % 3], t[(i + 2) % 3]);
        // λ_i(x) = orient(b, c, x) / det = (α + β·x) / det.
        let beta = [b[1] - c[1], c[0] - b[0]];
        let alpha = b[0] * c[1] - c[0] * b[1];
        *w = (alpha * area + beta[0] * moment[0] + beta[1] * moment[1]) / det;
    }
    out
}

fn unit(v: [f64; 2]) -> Option<[f64; 2]> {
    let n = v[0].hypot(v[1]);
    (n.is_finite() && n > 0.0).then(|| [v[0] / n, v[1] / n])
}

/// Outward unit normal of the body at the boundary point nearest to `x` (the average of the
/// normals of the edges meeting there).
fn boundary_normal(
    mesh: &Mesh,
    boundary: &[[usize; 2]],
    x: P,
    path: &str,
) -> Result<[f64; 2], SceneError> {
    let far = || {
        SceneError::new(
            path,
            format!("is farther than {NORMAL_REACH} element sizes from the boundary of the body"),
        )
    };
    let d: Vec<f64> = boundary
        .iter()
        .map(|&[a, b]| point_segment(x, mesh.nodes[a], mesh.nodes[b]).0)
        .collect();
    let (k, dmin) = d
        .iter()
        .copied()
        .enumerate()
        .min_by(|p, q| p.1.total_cmp(&q.1))
        .ok_or_else(far)?;
    let edge_len = |[a, b]: [usize; 2]| dist(mesh.nodes[a], mesh.nodes[b]);
    if dmin > NORMAL_REACH * edge_len(boundary[k]) {
        return Err(far());
    }
    let tie = dmin + 1e-9 * edge_len(boundary[k]);
    let sum = boundary
        .iter()
        .zip(&d)
        .filter(|(_, &di)| di <= tie)
        .filter_map(|(&[a, b], _)| {
            let (pa, pb) = (mesh.nodes[a], mesh.nodes[b]);
            unit([pb[1] - pa[1], pa[0] - pb[0]])
        })
        .fold([0.0, 0.0], |s, n| [s[0] + n[0], s[1] + n[1]]);
    unit(sum).ok_or_else(|| SceneError::new(path, "the boundary normal is undefined there"))
}

/// The nearest contact zone having a segment on `body`, and its distance to the polygon.
fn nearest_contact(mesh: &Mesh, body: usize, poly: &[P]) -> (Option<usize>, f64) {
    let n = poly.len();
    let edge_distance = |p: P, q: P| {
        if point_in_ring(p, poly) {
            return 0.0;
        }
        (0..n)
            .map(|i| segment_segment(p, q, poly[i], poly[(i + 1) % n]))
            .fold(f64::INFINITY, f64::min)
    };
    let mut best = (None, f64::INFINITY);
    for (c, contact) in mesh.contacts.iter().enumerate() {
        for s in [contact.segment_k, contact.segment_l] {
            let seg = &mesh.segments[s];
            if seg.body != body {
                continue;
            }
            let d = seg
                .edges
                .iter()
                .map(|&[a, b]| edge_distance(mesh.nodes[a], mesh.nodes[b]))
                .fold(f64::INFINITY, f64::min);
            if d < best.1 {
                best = (Some(c), d);
            }
        }
    }
    best
}

/// Arc-length parametrisation of a segment's edges in their stored order, each edge taken in
/// the direction of the walk.
///
/// A segment's edges are stored in order along it but oriented with the body on their left, so
/// a segment drawn clockwise around its body (the dam's crest from the upstream to the
/// downstream corner) has every edge pointing backwards; [`walk_direction`] turns them.
struct Chain<'a> {
    mesh: &'a Mesh,
    edges: Vec<[usize; 2]>,
    start: Vec<f64>,
    total: f64,
}

impl<'a> Chain<'a> {
    fn new(mesh: &'a Mesh, edges: &[[usize; 2]]) -> Chain<'a> {
        let edges = walk_direction(edges);
        let mut start = Vec::with_capacity(edges.len());
        let mut total = 0.0;
        for &[a, b] in &edges {
            start.push(total);
            total += dist(mesh.nodes[a], mesh.nodes[b]);
        }
        Chain {
            mesh,
            edges,
            start,
            total,
        }
    }

    fn ends(&self, k: usize) -> (P, P, f64) {
        let [a, b] = self.edges[k];
        let (pa, pb) = (self.mesh.nodes[a], self.mesh.nodes[b]);
        (pa, pb, dist(pa, pb))
    }

    /// Arc length of the projection of `p`, its distance and the length of the nearest edge.
    fn project(&self, p: P) -> (f64, f64, f64) {
        (0..self.edges.len())
            .map(|k| {
                let (pa, pb, len) = self.ends(k);
                let (d, t) = point_segment(p, pa, pb);
                (self.start[k] + t * len, d, len)
            })
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .unwrap_or((0.0, f64::INFINITY, 0.0))
    }

    /// The point at arc length `s`.
    fn at(&self, s: f64) -> P {
        let k = self.start.partition_point(|&x| x <= s).saturating_sub(1);
        let (pa, pb, len) = self.ends(k);
        lerp(
            pa,
            pb,
            if len > 0.0 {
                ((s - self.start[k]) / len).clamp(0.0, 1.0)
            } else {
                0.0
            },
        )
    }

    /// ∫ over arc lengths [s0, s1] of the P1 trace, as node weights (not normalised).
    fn integrals(&self, s0: f64, s1: f64) -> BTreeMap<usize, f64> {
        let mut w: BTreeMap<usize, f64> = BTreeMap::new();
        for (k, &[a, b]) in self.edges.iter().enumerate() {
            let (_, _, len) = self.ends(k);
            let (u0, u1) = (s0.max(self.start[k]), s1.min(self.start[k] + len));
            if u1 <= u0 || len <= 0.0 {
                continue;
            }
            let t_mid = (0.5 * (u0 + u1) - self.start[k]) / len;
            *w.entry(a).or_default() += (u1 - u0) * (1.0 - t_mid);
            *w.entry(b).or_default() += (u1 - u0) * t_mid;
        }
        w
    }
}

/// The edges of a chain in their order, each oriented from the node it shares with the edge
/// before it to the next one (the first edge away from the node it shares with the second); an
/// edge that shares no node with its neighbours keeps its direction.
fn walk_direction(edges: &[[usize; 2]]) -> Vec<[usize; 2]> {
    let mut out: Vec<[usize; 2]> = Vec::with_capacity(edges.len());
    for (k, &[a, b]) in edges.iter().enumerate() {
        let reversed = match (out.last(), edges.get(k + 1)) {
            (Some(&[_, end]), _) if end == a || end == b => end == b,
            (_, Some(next)) => next.contains(&a),
            _ => false,
        };
        out.push(if reversed { [b, a] } else { [a, b] });
    }
    out
}

fn piece_region(
    r: usize,
    piece: &BoundaryPiece,
    mesh: &Mesh,
    boundary: &[Vec<[usize; 2]>],
) -> Result<PieceRegion, SceneError> {
    let path = format!("criteria.boundary_pieces[{r}]");
    let segment = mesh.segment_index(&piece.segment).ok_or_else(|| {
        SceneError::new(
            format!("{path}.segment"),
            format!("unknown segment '{}'", piece.segment),
        )
    })?;
    let seg = &mesh.segments[segment];
    let chain = Chain::new(mesh, &seg.edges);
    let arc = |p: Option<P>, field: &str, default: f64| -> Result<f64, SceneError> {
        let Some(p) = p else { return Ok(default) };
        let p = finite_point(p, || format!("{path}.{field}"))?;
        let (s, d, len) = chain.project(p);
        if d > NORMAL_REACH * len {
            return Err(SceneError::new(
                format!("{path}.{field}"),
                format!("does not lie on segment '{}'", piece.segment),
            ));
        }
        Ok(s)
    };
    let (a, b) = (
        arc(piece.from, "from", 0.0)?,
        arc(piece.to, "to", chain.total)?,
    );
    let (s0, s1) = (a.min(b), a.max(b));
    let length = s1 - s0;
    if length <= 1e-12 * chain.total {
        return Err(SceneError::new(
            path,
            format!(
                "the boundary piece has zero length: its ends project onto the same point of \
                 segment '{}'",
                piece.segment
            ),
        ));
    }
    let node_weights = chain
        .integrals(s0, s1)
        .into_iter()
        .map(|(n, w)| (n, w / length))
        .collect();
    let (x, at_path) = match piece.normal_at {
        Some(x) => (
            finite_point(x, || format!("{path}.normal_at"))?,
            format!("{path}.normal_at"),
        ),
        None => (chain.at(0.5 * (s0 + s1)), path.clone()),
    };
    let normal = boundary_normal(mesh, &boundary[seg.body], x, &at_path)?;
    Ok(PieceRegion {
        name: piece.name.clone(),
        segment,
        body: seg.body,
        length,
        node_weights,
        normal,
    })
}

#[cfg(test)]
mod tests;
