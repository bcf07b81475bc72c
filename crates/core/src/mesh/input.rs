//! Checks the zone polygons of a scene and turns them into one planar straight-line graph (PSLG)
//! for the triangulator: coincident points of different zones and bodies are snapped together,
//! edges are split where another vertex lies on them (T-junctions between bodies, segment end
//! points), shared edges are kept once, and every edge is subdivided to the local target size so
//! that both sides of a common edge get identical vertices.

use std::collections::{BTreeSet, HashMap};

use super::geom::{
    bbox, cross_properly, overlapping_pairs, point_in_ring, point_segment, segment_segment,
    signed_area, P,
};
use super::size::SizeField;
use crate::scene::{Scene, SceneError};

/// Relative tolerance (of the scene diameter) under which points coincide (and are merged).
const SNAP: f64 = 1e-9;

/// Relative distance (of the scene diameter) under which distinct points, or a point and an
/// edge, are refused as near-coincident: features this small are almost always typing or
/// rounding slips, and would force elements many orders of magnitude below the body size.
pub(crate) const FEATURE: f64 = 1e-6;

/// A zone polygon with its holes, checked.
#[derive(Debug, Clone)]
pub(crate) struct ZoneGeom {
    pub body: usize,
    /// Index of the zone in its body.
    pub zone: usize,
    /// JSON path of the zone, `bodies[b].zones[z]`.
    pub path: String,
    pub outer: Vec<P>,
    pub holes: Vec<Vec<P>>,
}

impl ZoneGeom {
    /// Whether `p` lies in the polygon minus its holes.
    pub fn contains(&self, p: P) -> bool {
        point_in_ring(p, &self.outer) && !self.holes.iter().any(|h| point_in_ring(p, h))
    }

    pub fn area(&self) -> f64 {
        signed_area(&self.outer).abs()
            - self.holes.iter().map(|h| signed_area(h).abs()).sum::<f64>()
    }

    fn rings(&self) -> impl Iterator<Item = &Vec<P>> {
        std::iter::once(&self.outer).chain(self.holes.iter())
    }
}

/// The checked geometry of all bodies.
#[derive(Debug, Clone)]
pub(crate) struct Geometry {
    /// Zones body by body in scene order.
    pub zones: Vec<ZoneGeom>,
    /// Snapping tolerance (absolute).
    pub tol: f64,
}

/// Reads and checks the zone polygons of all bodies.
pub(crate) fn geometry(scene: &Scene) -> Result<Geometry, SceneError> {
    if scene.bodies.is_empty() {
        return Err(SceneError::new("bodies", "the scene has no body"));
    }
    for (b, body) in scene.bodies.iter().enumerate() {
        if body.zones.is_empty() {
            return Err(SceneError::new(
                format!("bodies[{b}].zones"),
                "a body needs at least one zone",
            ));
        }
        for (z, zone) in body.zones.iter().enumerate() {
            let rings = std::iter::once((format!("bodies[{b}].zones[{z}].polygon"), &zone.polygon))
                .chain(
                    zone.holes
                        .iter()
                        .enumerate()
                        .map(|(h, r)| (format!("bodies[{b}].zones[{z}].holes[{h}]"), r)),
                );
            for (path, ring) in rings {
                if ring.iter().flatten().any(|c| !c.is_finite()) {
                    return Err(SceneError::new(path, "coordinates must be finite numbers"));
                }
            }
        }
    }
    let all = scene
        .bodies
        .iter()
        .flat_map(|b| &b.zones)
        .flat_map(|z| z.polygon.iter().copied());
    let bb = bbox(all);
    let diameter = (bb[2] - bb[0]).hypot(bb[3] - bb[1]);
    let tol = SNAP * diameter;
    let mut zones = Vec::new();
    for (b, body) in scene.bodies.iter().enumerate() {
        for (z, zone) in body.zones.iter().enumerate() {
            let path = format!("bodies[{b}].zones[{z}]");
            let outer = clean_ring(&zone.polygon, tol, &format!("{path}.polygon"), diameter)?;
            let holes = zone
                .holes
                .iter()
                .enumerate()
                .map(|(h, r)| clean_ring(r, tol, &format!("{path}.holes[{h}]"), diameter))
                .collect::<Result<Vec<_>, _>>()?;
            let g = ZoneGeom {
                body: b,
                zone: z,
                path,
                outer,
                holes,
            };
            check_zone(&g, tol)?;
            zones.push(g);
        }
    }
    check_crossings(&zones, scene, tol)?;
    check_near_points(&zones, tol, FEATURE * diameter)?;
    Ok(Geometry { zones, tol })
}

/// Drops repeated consecutive points (and a closing repeat), then checks size and area.
fn clean_ring(ring: &[P], tol: f64, path: &str, diameter: f64) -> Result<Vec<P>, SceneError> {
    let mut out: Vec<P> = Vec::with_capacity(ring.len());
    for &p in ring {
        if out.last().is_none_or(|&q| super::geom::dist(p, q) > tol) {
            out.push(p);
        }
    }
    while out.len() > 1 && super::geom::dist(out[0], out[out.len() - 1]) <= tol {
        out.pop();
    }
    if out.len() < 3 {
        return Err(SceneError::new(
            path,
            "a polygon needs at least 3 distinct points",
        ));
    }
    if signed_area(&out).abs() <= tol * diameter {
        return Err(SceneError::new(path, "the polygon has zero area"));
    }
    Ok(out)
}

/// Edges of a zone's rings: (ring index, edge index, a, b).
fn ring_edges(g: &ZoneGeom) -> Vec<(usize, usize, P, P)> {
    g.rings()
        .enumerate()
        .flat_map(|(r, ring)| {
            let n = ring.len();
            (0..n).map(move |i| (r, i, ring[i], ring[(i + 1) % n]))
        })
        .collect()
}

fn ring_path(g: &ZoneGeom, r: usize) -> String {
    if r == 0 {
        format!("{}.polygon", g.path)
    } else {
        format!("{}.holes[{}]", g.path, r - 1)
    }
}

/// Self-intersections of the polygon and its holes, holes outside the polygon or nested.
fn check_zone(g: &ZoneGeom, tol: f64) -> Result<(), SceneError> {
    let edges = ring_edges(g);
    let sizes: Vec<usize> = g.rings().map(|r| r.len()).collect();
    let boxes: Vec<[f64; 4]> = edges.iter().map(|e| bbox([e.2, e.3])).collect();
    overlapping_pairs(&boxes, tol, |i, j| {
        let ((ri, ei, a, b), (rj, ej, c, d)) = (edges[i], edges[j]);
        let n = sizes[ri];
        let adjacent = ri == rj && ((ei + 1) % n == ej || (ej + 1) % n == ei);
        let bad = if adjacent {
            // Consecutive edges share one vertex; they must not fold back onto each other.
            let (far_i, far_j) = if (ei + 1) % n == ej { (a, d) } else { (b, c) };
            point_segment(far_j, a, b).0 <= tol || point_segment(far_i, c, d).0 <= tol
        } else {
            segment_segment(a, b, c, d) <= tol
        };
        if !bad {
            return Ok(());
        }
        let reason = if ri == rj {
            "the polygon intersects itself".to_string()
        } else if ri == 0 {
            "the hole touches or crosses the zone polygon".to_string()
        } else {
            format!("the hole touches or crosses holes[{}]", ri - 1)
        };
        Err(SceneError::new(ring_path(g, rj.max(ri)), reason))
    })?;
    for (h, hole) in g.holes.iter().enumerate() {
        if !hole.iter().all(|&p| point_in_ring(p, &g.outer)) {
            return Err(SceneError::new(
                ring_path(g, h + 1),
                "the hole lies outside its zone polygon",
            ));
        }
        if let Some(k) = (0..g.holes.len()).find(|&k| k != h && point_in_ring(hole[0], &g.holes[k]))
        {
            return Err(SceneError::new(
                ring_path(g, h + 1),
                format!("the hole lies inside holes[{k}]"),
            ));
        }
    }
    Ok(())
}

/// Edges of different zones must not cross: crossing boundaries mean overlapping zones.
fn check_crossings(zones: &[ZoneGeom], scene: &Scene, tol: f64) -> Result<(), SceneError> {
    let edges: Vec<(usize, P, P)> = zones
        .iter()
        .enumerate()
        .flat_map(|(z, g)| ring_edges(g).into_iter().map(move |e| (z, e.2, e.3)))
        .collect();
    let boxes: Vec<[f64; 4]> = edges.iter().map(|e| bbox([e.1, e.2])).collect();
    overlapping_pairs(&boxes, tol, |i, j| {
        let ((zi, a, b), (zj, c, d)) = (edges[i], edges[j]);
        if zi == zj || !cross_properly(a, b, c, d, tol) {
            return Ok(());
        }
        let (first, second) = (zi.min(zj), zi.max(zj));
        Err(SceneError::new(
            zones[second].path.clone(),
            format!(
                "overlaps {} (their edges cross)",
                zone_label(scene, &zones[first])
            ),
        ))
    })
}

/// A vertex closer than `feature` to an edge (or a vertex) of any ring without touching it
/// (within `tol`) is refused, naming both places.
fn check_near_points(zones: &[ZoneGeom], tol: f64, feature: f64) -> Result<(), SceneError> {
    let edges: Vec<(usize, usize, P, P)> = zones
        .iter()
        .enumerate()
        .flat_map(|(z, g)| ring_edges(g).into_iter().map(move |e| (z, e.0, e.2, e.3)))
        .collect();
    let boxes: Vec<[f64; 4]> = edges.iter().map(|e| bbox([e.2, e.3])).collect();
    overlapping_pairs(&boxes, feature, |i, j| {
        for (v, e) in [(i, j), (j, i)] {
            let (zv, rv, a, b) = edges[v];
            let (ze, re, c, d) = edges[e];
            for p in [a, b] {
                let (dist, _) = point_segment(p, c, d);
                if dist > tol && dist < feature {
                    let (gv, ge) = (&zones[zv], &zones[ze]);
                    return Err(SceneError::new(
                        ring_path(gv, rv),
                        format!(
                            "the point ({}, {}) lies {dist:.3e} m from the edge ({}, {})–({}, {}) \
                             of {}: closer than {FEATURE:e} of the geometry's size without \
                             touching it; make the points identical or move them apart",
                            p[0],
                            p[1],
                            c[0],
                            c[1],
                            d[0],
                            d[1],
                            ring_path(ge, re)
                        ),
                    ));
                }
            }
        }
        Ok(())
    })
}

/// "zone 'Z' of body 'B'".
pub(crate) fn zone_label(scene: &Scene, g: &ZoneGeom) -> String {
    let body = &scene.bodies[g.body];
    format!("zone '{}' of body '{}'", body.zones[g.zone].name, body.name)
}

/// The planar straight-line graph handed to the triangulator.
#[derive(Debug, Clone, Default)]
pub(crate) struct Pslg {
    pub points: Vec<P>,
    pub edges: Vec<[usize; 2]>,
}

/// Merges points closer than `tol` (grid hashing; first point wins).
struct Snapper {
    tol: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
    points: Vec<P>,
}

impl Snapper {
    fn cell(&self, p: P) -> (i64, i64) {
        (
            (p[0] / self.tol).floor() as i64,
            (p[1] / self.tol).floor() as i64,
        )
    }

    fn find(&self, p: P) -> Option<usize> {
        let (cx, cy) = self.cell(p);
        (cx - 1..=cx + 1)
            .flat_map(|x| (cy - 1..=cy + 1).map(move |y| (x, y)))
            .filter_map(|c| self.cells.get(&c))
            .flatten()
            .copied()
            .find(|&i| super::geom::dist(self.points[i], p) <= self.tol)
    }

    fn insert(&mut self, p: P) -> usize {
        if let Some(i) = self.find(p) {
            return i;
        }
        let c = self.cell(p);
        self.points.push(p);
        self.cells.entry(c).or_default().push(self.points.len() - 1);
        self.points.len() - 1
    }
}

/// Builds the PSLG of all zone rings; `extra` points (segment ends) become vertices where they
/// lie on a ring edge.
pub(crate) fn pslg(geo: &Geometry, extra: &[P], size: &SizeField) -> Pslg {
    let tol = geo.tol;
    let mut snap = Snapper {
        tol,
        cells: HashMap::new(),
        points: Vec::new(),
    };
    let mut ring_edges: Vec<[usize; 2]> = Vec::new();
    for g in &geo.zones {
        for ring in g.rings() {
            let ids: Vec<usize> = ring.iter().map(|&p| snap.insert(p)).collect();
            let n = ids.len();
            ring_edges.extend(
                (0..n)
                    .map(|i| [ids[i], ids[(i + 1) % n]])
                    .filter(|e| e[0] != e[1]),
            );
        }
    }
    for &p in extra {
        let on_edge = ring_edges.iter().any(|e| {
            let (d, _) = point_segment(p, snap.points[e[0]], snap.points[e[1]]);
            d <= tol
        });
        if on_edge {
            snap.insert(p);
        }
    }
    let points = snap.points;
    let unique = split_at_vertices(&points, &ring_edges, tol);
    let mut out = Pslg {
        points,
        edges: Vec::new(),
    };
    for [a, b] in unique {
        let mut prev = a;
        for p in size.subdivide(out.points[a], out.points[b]) {
            out.points.push(p);
            let id = out.points.len() - 1;
            out.edges.push([prev, id]);
            prev = id;
        }
        out.edges.push([prev, b]);
    }
    out
}

/// Splits every edge at the vertices lying on it and returns the distinct edges (sorted).
fn split_at_vertices(points: &[P], edges: &[[usize; 2]], tol: f64) -> BTreeSet<[usize; 2]> {
    let mut by_x: Vec<usize> = (0..points.len()).collect();
    by_x.sort_by(|&i, &j| points[i][0].total_cmp(&points[j][0]).then(i.cmp(&j)));
    let mut unique = BTreeSet::new();
    for &[a, b] in edges {
        let (pa, pb) = (points[a], points[b]);
        let lo = by_x.partition_point(|&i| points[i][0] < pa[0].min(pb[0]) - tol);
        let mut on: Vec<(f64, usize)> = by_x[lo..]
            .iter()
            .take_while(|&&i| points[i][0] <= pa[0].max(pb[0]) + tol)
            .filter(|&&i| i != a && i != b)
            .filter_map(|&i| {
                let (d, t) = point_segment(points[i], pa, pb);
                (d <= tol && t > 0.0 && t < 1.0).then_some((t, i))
            })
            .collect();
        on.sort_by(|x, y| x.0.total_cmp(&y.0));
        let chain: Vec<usize> = std::iter::once(a)
            .chain(on.into_iter().map(|(_, i)| i))
            .chain(std::iter::once(b))
            .collect();
        for w in chain.windows(2) {
            unique.insert([w[0].min(w[1]), w[0].max(w[1])]);
        }
    }
    unique
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_junction_splits_the_long_edge() {
        let pts = vec![[0.0, 0.0], [2.0, 0.0], [0.5, 0.0], [1.5, 0.0]];
        let e = split_at_vertices(&pts, &[[0, 1], [2, 3]], 1e-12);
        let want: BTreeSet<[usize; 2]> = [[0, 2], [2, 3], [1, 3]].into_iter().collect();
        assert_eq!(e, want);
    }
}
