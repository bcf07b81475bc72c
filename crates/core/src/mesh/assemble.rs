//! Turns a triangulation of all bodies (from the mesher or from a Gmsh file) into the `Mesh`
//! contract: counter-clockwise triangles grouped body by body, nodes split so that each body
//! has its own copy, named boundary segments resolved to oriented boundary edges, and contact
//! zones resolved to node pairs at identical positions.

use std::collections::{BTreeMap, HashMap, HashSet};

use super::geom::{bbox, dist, lerp, orient, Polyline, P};
use super::mortar::{self, MortarFault};
use super::rows::Rows;
use super::{Mesh, MeshContact, MeshSegment, MeshZone};
use crate::scene::{Coupling, Scene, SceneError, Segment};

/// Relative tolerance (of the mesh diameter) for "lies on a segment" and "same position".
const ON: f64 = 1e-8;

/// Triangles of all bodies before node splitting.
#[derive(Debug, Clone, Default)]
pub(crate) struct RawMesh {
    pub nodes: Vec<P>,
    pub triangles: Vec<[usize; 3]>,
    /// Zone of each triangle (index into the list of `mesh_zones`).
    pub zone: Vec<usize>,
}

/// The zones of the scene body by body, with their material indices.
pub(crate) fn mesh_zones(scene: &Scene) -> Result<Vec<MeshZone>, SceneError> {
    let mut zones = Vec::new();
    for (b, body) in scene.bodies.iter().enumerate() {
        for (z, zone) in body.zones.iter().enumerate() {
            let material = scene
                .materials
                .keys()
                .position(|k| *k == zone.material)
                .ok_or_else(|| {
                    SceneError::new(
                        format!("bodies[{b}].zones[{z}].material"),
                        format!("unknown material '{}'", zone.material),
                    )
                })?;
            zones.push(MeshZone {
                name: zone.name.clone(),
                body: b,
                material,
            });
        }
    }
    Ok(zones)
}

/// Builds the mesh: splits nodes per body, resolves segments (from the named `curves` of raw
/// node pairs when one has the segment's name, else geometrically) and contacts.
pub(crate) fn finish(
    scene: &Scene,
    raw: RawMesh,
    zones: Vec<MeshZone>,
    curves: &BTreeMap<String, Vec<[usize; 2]>>,
) -> Result<Mesh, SceneError> {
    let bb = bbox(raw.nodes.iter().copied());
    let tol = ON * (bb[2] - bb[0]).hypot(bb[3] - bb[1]);
    let (mut mesh, copies) = split_bodies(&raw, zones, scene);
    let boundary = boundary_edges(&mesh);
    for (name, seg) in &scene.segments {
        let body = scene
            .bodies
            .iter()
            .position(|b| b.name == seg.body)
            .ok_or_else(|| {
                SceneError::new(
                    format!("segments.{name}.body"),
                    format!("unknown body '{}'", seg.body),
                )
            })?;
        let on = SegmentInput {
            name,
            seg,
            body,
            boundary: &boundary[body],
            tol,
        };
        let resolved = match curves.get(name) {
            Some(edges) => on.by_curve(&mesh, edges, &copies[body])?,
            None => on.by_geometry(&mesh, scene)?,
        };
        mesh.segments.push(resolved);
    }
    for i in 0..scene.contacts.len() {
        let c = contact(scene, i, &mesh, tol)?;
        mesh.contacts.push(c);
    }
    Ok(mesh)
}

/// Per body, the sorted raw node ids it uses and the index of its first node copy.
pub(crate) struct Copies {
    raw: Vec<usize>,
    base: usize,
}

impl Copies {
    fn get(&self, raw: usize) -> Option<usize> {
        self.raw.binary_search(&raw).ok().map(|k| self.base + k)
    }
}

/// Triangles grouped by body and oriented CCW; each body gets its own copies of its nodes (in
/// raw node order). Linear in the mesh size: counting passes, no sorting of all nodes.
fn split_bodies(raw: &RawMesh, zones: Vec<MeshZone>, scene: &Scene) -> (Mesh, Vec<Copies>) {
    const NONE: usize = usize::MAX;
    let nb = scene.bodies.len();
    let body = |t: usize| zones[raw.zone[t]].body;
    // The bodies of every raw node: the first one, and (node, body) for any further ones.
    let mut first = vec![NONE; raw.nodes.len()];
    let mut more: Vec<(usize, usize)> = Vec::new();
    for (t, tri) in raw.triangles.iter().enumerate() {
        let b = body(t);
        for &i in tri {
            if first[i] == NONE {
                first[i] = b;
            } else if first[i] != b {
                more.push((i, b));
            }
        }
    }
    more.sort_unstable();
    more.dedup();
    let mut ids: Vec<Vec<usize>> = vec![Vec::new(); nb];
    let mut extra = more.iter().peekable();
    for (i, &b) in first.iter().enumerate() {
        if b != NONE {
            ids[b].push(i);
        }
        while let Some(&(_, b)) = extra.next_if(|e| e.0 == i) {
            ids[b].push(i);
        }
    }
    let mut mesh = Mesh {
        bodies: scene.bodies.iter().map(|b| b.name.clone()).collect(),
        ..Mesh::default()
    };
    let mut tris: Vec<Vec<usize>> = vec![Vec::new(); nb];
    for t in 0..raw.triangles.len() {
        tris[body(t)].push(t);
    }
    let mut local = vec![0usize; raw.nodes.len()];
    let mut copies = Vec::with_capacity(nb);
    for (b, raw_ids) in ids.into_iter().enumerate() {
        let base = mesh.nodes.len();
        for (k, &i) in raw_ids.iter().enumerate() {
            local[i] = base + k;
            mesh.nodes.push(raw.nodes[i]);
            mesh.node_body.push(b);
        }
        for &t in &tris[b] {
            let [a, b1, c1] = raw.triangles[t].map(|i| local[i]);
            let ccw = orient(mesh.nodes[a], mesh.nodes[b1], mesh.nodes[c1]) >= 0.0;
            mesh.triangles
                .push(if ccw { [a, b1, c1] } else { [a, c1, b1] });
            mesh.triangle_zone.push(raw.zone[t]);
        }
        copies.push(Copies { raw: raw_ids, base });
    }
    mesh.zones = zones;
    (mesh, copies)
}

/// Boundary edges of each body (edges of exactly one of its triangles), body on the left.
pub(crate) fn boundary_edges(mesh: &Mesh) -> Vec<Vec<[usize; 2]>> {
    // The counter-clockwise edges a → b leaving each node; a → b is on the boundary when no
    // triangle has b → a.
    let directed = || {
        mesh.triangles
            .iter()
            .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
    };
    let rows = Rows::new(mesh.nodes.len(), directed);
    let mut out = vec![Vec::new(); mesh.bodies.len()];
    for [a, b] in directed() {
        if !rows.row(b).contains(&a) {
            out[mesh.node_body[a]].push([a, b]);
        }
    }
    out
}

/// What is needed to resolve one named segment.
struct SegmentInput<'a> {
    name: &'a str,
    seg: &'a Segment,
    body: usize,
    boundary: &'a [[usize; 2]],
    tol: f64,
}

impl SegmentInput<'_> {
    fn error(&self, reason: String) -> SceneError {
        SceneError::new(format!("segments.{}", self.name), reason)
    }

    /// Boundary edges of the body whose end points and midpoint lie on the segment's polyline.
    fn by_geometry(&self, mesh: &Mesh, scene: &Scene) -> Result<MeshSegment, SceneError> {
        let body_name = &scene.bodies[self.body].name;
        let line = Polyline::new(self.seg.polyline());
        if line.pts.len() < 2 {
            return Err(self.error(
                "needs `from` and `to`, a `path`, or a physical curve of this name in the Gmsh file"
                    .into(),
            ));
        }
        let on = |p: P| line.project(p).0 <= self.tol;
        let edges: Vec<[usize; 2]> = self
            .boundary
            .iter()
            .copied()
            .filter(|&[a, b]| {
                let (pa, pb) = (mesh.nodes[a], mesh.nodes[b]);
                on(pa) && on(pb) && on(lerp(pa, pb, 0.5))
            })
            .collect();
        if edges.is_empty() {
            return Err(self.error(format!(
                "does not lie on the boundary of body '{body_name}'"
            )));
        }
        let covered: f64 = edges
            .iter()
            .map(|&[a, b]| dist(mesh.nodes[a], mesh.nodes[b]))
            .sum();
        if covered < line.length() * (1.0 - 1e-6) - self.tol {
            return Err(self.error(format!(
                "only {covered:.6} m of its {:.6} m lie on the boundary of body '{body_name}'",
                line.length()
            )));
        }
        Ok(self.ordered(mesh, edges, Some(&line)))
    }

    /// The edges of a physical curve (raw node pairs), oriented with the body on the left.
    fn by_curve(
        &self,
        mesh: &Mesh,
        curve: &[[usize; 2]],
        copies: &Copies,
    ) -> Result<MeshSegment, SceneError> {
        let body_name = &mesh.bodies[self.body];
        let oriented: HashSet<[usize; 2]> = self.boundary.iter().copied().collect();
        let mut edges = Vec::with_capacity(curve.len());
        for &[ra, rb] in curve {
            let (a, b) = match (copies.get(ra), copies.get(rb)) {
                (Some(a), Some(b)) => (a, b),
                _ => {
                    return Err(self.error(format!(
                        "the physical curve '{}' is not on body '{body_name}'",
                        self.name
                    )))
                }
            };
            if oriented.contains(&[a, b]) {
                edges.push([a, b]);
            } else if oriented.contains(&[b, a]) {
                edges.push([b, a]);
            } else {
                return Err(self.error(format!(
                    "the physical curve '{}' does not lie on the boundary of body '{body_name}'",
                    self.name
                )));
            }
        }
        if edges.is_empty() {
            return Err(self.error(format!("the physical curve '{}' has no edges", self.name)));
        }
        let line = Polyline::new(self.seg.polyline());
        Ok(self.ordered(mesh, edges, (line.pts.len() >= 2).then_some(&line)))
    }

    /// Orders edges and nodes along the polyline (by arc length), or along the edge chains.
    fn ordered(
        &self,
        mesh: &Mesh,
        mut edges: Vec<[usize; 2]>,
        line: Option<&Polyline>,
    ) -> MeshSegment {
        let nodes = match line {
            Some(line) => {
                let arc = |p: P| line.project(p).1;
                let mid = |e: &[usize; 2]| arc(lerp(mesh.nodes[e[0]], mesh.nodes[e[1]], 0.5));
                edges.sort_by(|x, y| mid(x).total_cmp(&mid(y)));
                let mut nodes: Vec<(f64, usize)> = edges
                    .iter()
                    .flatten()
                    .map(|&n| (arc(mesh.nodes[n]), n))
                    .collect();
                nodes.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                let mut ids: Vec<usize> = nodes.into_iter().map(|(_, n)| n).collect();
                let mut seen = HashSet::new();
                ids.retain(|n| seen.insert(*n));
                ids
            }
            None => {
                let (e, n) = chain_order(&edges);
                edges = e;
                n
            }
        };
        MeshSegment {
            name: self.name.to_string(),
            body: self.body,
            nodes,
            edges,
        }
    }
}

/// Orders consistently oriented edges into chains (open chains from their start, closed loops
/// from their first edge); returns the edges and the nodes in walking order.
fn chain_order(edges: &[[usize; 2]]) -> (Vec<[usize; 2]>, Vec<usize>) {
    let next: HashMap<usize, usize> = edges.iter().enumerate().map(|(i, e)| (e[0], i)).collect();
    let heads: HashSet<usize> = edges.iter().map(|e| e[1]).collect();
    let mut used = vec![false; edges.len()];
    let (mut out_edges, mut out_nodes) = (Vec::new(), Vec::new());
    let starts = (0..edges.len())
        .filter(|&i| !heads.contains(&edges[i][0]))
        .chain(0..edges.len());
    for s in starts {
        if used[s] {
            continue;
        }
        out_nodes.push(edges[s][0]);
        let mut i = s;
        while !used[i] {
            used[i] = true;
            out_edges.push(edges[i]);
            out_nodes.push(edges[i][1]);
            match next.get(&edges[i][1]) {
                Some(&j) => i = j,
                None => break,
            }
        }
        if out_nodes.len() > 1 && out_nodes.first() == out_nodes.last() {
            out_nodes.pop();
        }
    }
    (out_edges, out_nodes)
}

/// Contact `i` of the scene: the node pairs of its two segments at the same positions, or with
/// mortar coupling the slave nodes' mortar rows.
fn contact(scene: &Scene, i: usize, mesh: &Mesh, tol: f64) -> Result<MeshContact, SceneError> {
    let c = &scene.contacts[i];
    let err = |reason: String| SceneError::new(format!("contacts[{i}].between"), reason);
    let index = |name: &str| {
        mesh.segment_index(name)
            .ok_or_else(|| err(format!("unknown segment '{name}'")))
    };
    let (k, l) = (index(&c.between[0])?, index(&c.between[1])?);
    let (sk, sl) = (&mesh.segments[k], &mesh.segments[l]);
    if sk.body == sl.body {
        return Err(err(format!(
            "both segments belong to body '{}'; a contact joins two bodies",
            mesh.bodies[sk.body]
        )));
    }
    if c.coupling == Coupling::Mortar {
        return mortar_contact(scene, i, mesh, [k, l]);
    }
    let mismatch = || {
        err(format!(
            "segments '{}' ({} nodes) and '{}' ({} nodes) do not cover the same part of the \
             common boundary node for node",
            sk.name,
            sk.nodes.len(),
            sl.name,
            sl.nodes.len()
        ))
    };
    if sk.nodes.len() != sl.nodes.len() {
        return Err(mismatch());
    }
    let mut by_x: Vec<usize> = sl.nodes.clone();
    by_x.sort_by(|&a, &b| {
        mesh.nodes[a][0]
            .total_cmp(&mesh.nodes[b][0])
            .then(a.cmp(&b))
    });
    let mut used = HashSet::new();
    let mut pairs = Vec::with_capacity(sk.nodes.len());
    for &a in &sk.nodes {
        let p = mesh.nodes[a];
        let lo = by_x.partition_point(|&b| mesh.nodes[b][0] < p[0] - tol);
        let partner = by_x[lo..]
            .iter()
            .take_while(|&&b| mesh.nodes[b][0] <= p[0] + tol)
            .copied()
            .find(|&b| dist(mesh.nodes[b], p) <= tol && !used.contains(&b))
            .ok_or_else(mismatch)?;
        used.insert(partner);
        pairs.push([a, partner]);
    }
    if pairs.len() < 2 {
        return Err(err("the contact zone needs at least 2 node pairs".into()));
    }
    let mut arc = vec![0.0; pairs.len()];
    for m in 1..pairs.len() {
        arc[m] = arc[m - 1] + dist(mesh.nodes[pairs[m - 1][0]], mesh.nodes[pairs[m][0]]);
    }
    let total = arc[pairs.len() - 1];
    Ok(MeshContact {
        name: c.name.clone(),
        segment_k: k,
        segment_l: l,
        pairs,
        fraction: arc.iter().map(|s| s / total).collect(),
        mortar: None,
    })
}

/// A mortar zone (design §2.4.1): the slave side (`slave`, else the finer segment, else the
/// first), its covered nodes' rows against the master side, and their arc-length fractions along
/// the zone's first segment.
fn mortar_contact(
    scene: &Scene,
    i: usize,
    mesh: &Mesh,
    [k, l]: [usize; 2],
) -> Result<MeshContact, SceneError> {
    let c = &scene.contacts[i];
    let mean_edge = |s: usize| {
        let seg = &mesh.segments[s];
        let length: f64 = seg
            .edges
            .iter()
            .map(|&[a, b]| dist(mesh.nodes[a], mesh.nodes[b]))
            .sum();
        length / seg.edges.len().max(1) as f64
    };
    let slave_is_l = match &c.slave {
        Some(name) => *name == c.between[1],
        None => mean_edge(l) < mean_edge(k),
    };
    let (slave, master) = if slave_is_l { (l, k) } else { (k, l) };
    let (ss, sm) = (&mesh.segments[slave], &mesh.segments[master]);
    let rows = mortar::couple(mesh, ss, sm).map_err(|fault| match fault {
        MortarFault::TooFewElements(n) => SceneError::new(
            format!("contacts[{i}].between"),
            format!(
                "the mortar slave segment '{}' has {n} element(s) on the mesh; it needs at least 2 \
                 (refine it or choose the other side as `slave`)",
                ss.name
            ),
        ),
        MortarFault::NoOverlap => SceneError::new(
            format!("contacts[{i}].between"),
            format!(
                "segments '{}' and '{}' do not face each other anywhere: no slave point sees the \
                 master side along its outward normal",
                ss.name, sm.name
            ),
        ),
        MortarFault::Crossing { at, angle } => SceneError::new(
            format!("contacts[{i}].between"),
            format!(
                "segments '{}' and '{}' cross each other at ({:.6}, {:.6}) at {angle:.0}°; a \
                 contact zone needs two boundaries facing each other",
                ss.name, sm.name, at[0], at[1]
            ),
        ),
    })?;
    let along = &mesh.segments[k];
    let fraction = rows
        .iter()
        .map(|(p, _)| arc_fraction(mesh, along, mesh.nodes[*p]))
        .collect();
    let pairs = rows
        .iter()
        .map(|(p, row)| {
            let main = row
                .master
                .iter()
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                .map_or(*p, |&(q, _)| q);
            [*p, main]
        })
        .collect();
    Ok(MeshContact {
        name: c.name.clone(),
        segment_k: slave,
        segment_l: master,
        pairs,
        fraction,
        mortar: Some(rows.into_iter().map(|(_, row)| row).collect()),
    })
}

/// The arc-length fraction along `segment` (its nodes' chain) of the point nearest to `p`.
fn arc_fraction(mesh: &Mesh, segment: &MeshSegment, p: P) -> f64 {
    let line = Polyline::new(segment.nodes.iter().map(|&n| mesh.nodes[n]).collect());
    let length = line.length();
    if length > 0.0 {
        line.project(p).1 / length
    } else {
        0.0
    }
}
