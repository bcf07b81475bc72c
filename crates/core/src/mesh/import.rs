//! Imported meshes (design §2.5): a triangle mesh made outside wsm — read from a Gmsh file
//! (`gmsh`) or given in the scene (`inline`) — checked and turned into the scene's mesh, after
//! `mesh.subdivide` uniform subdivisions (`subdivide`).
//!
//! Both sources hand over the same [`Imported`] mesh (their own node numbering, triangles in
//! either orientation, each with its zone, and named lines) and a [`Places`] that says where a
//! triangle, line or node is in the source, so that every error names the file's line and tags
//! or the inline mesh's JSON path. The checks: triangles are turned counter-clockwise; a
//! triangle with no area, two triangles folded over one edge (or an edge of three triangles), a
//! node lying inside another element's edge of the same body, a line of a scene segment that is
//! no triangle edge and a scene zone without triangles are refused. Nodes used by no triangle
//! are not part of the FE model and are dropped. Node splitting, segments and contacts are
//! shared with the mesher (`assemble`).

use std::collections::{BTreeMap, HashMap};

use super::assemble::{finish, mesh_zones, RawMesh};
use super::check::{self, Defect};
use super::geom::{orient, P};
use super::rows::Rows;
use super::subdivide::subdivide;
use super::{Mesh, MeshZone};
use crate::scene::{Scene, SceneError};

/// A mesh from outside wsm, in its source's node numbering.
#[derive(Debug, Clone, Default)]
pub(crate) struct Imported {
    /// Node coordinates.
    pub nodes: Vec<P>,
    /// Triangles (node indices, either orientation).
    pub triangles: Vec<[usize; 3]>,
    /// The mesh zone of each triangle (index into `mesh_zones`).
    pub zone: Vec<usize>,
    /// Line elements (node indices).
    pub lines: Vec<[usize; 2]>,
    /// Named groups of lines: name → indices into `lines`.
    pub curves: BTreeMap<String, Vec<usize>>,
}

/// Where the parts of an imported mesh are in its source, for error messages.
pub(crate) trait Places {
    /// The source in words ("the Gmsh file").
    fn source(&self) -> &'static str;
    /// What a triangle is called in the source ("triangle element").
    fn triangle_kind(&self) -> &'static str;
    /// The source's name of triangle `t` (a tag or an index).
    fn triangle_id(&self, t: usize) -> String;
    /// The source's name of node `n`.
    fn node_id(&self, n: usize) -> String;
    /// The source's name of line `l` ("line element 20").
    fn line(&self, l: usize) -> String;
    /// An error about triangle `t`.
    fn at_triangle(&self, t: usize, reason: String) -> SceneError;
    /// An error about line `l`.
    fn at_line(&self, l: usize, reason: String) -> SceneError;
}

/// The mesh zone number of every zone name (zones numbered body by body); the names must be
/// unique, since an imported mesh refers to zones by name.
pub(crate) fn zone_numbers(scene: &Scene) -> Result<HashMap<&str, usize>, SceneError> {
    let mut zone_of_name: HashMap<&str, usize> = HashMap::new();
    let mut z = 0;
    for (b, body) in scene.bodies.iter().enumerate() {
        for (k, zone) in body.zones.iter().enumerate() {
            if zone_of_name.insert(zone.name.as_str(), z).is_some() {
                return Err(SceneError::new(
                    format!("bodies[{b}].zones[{k}].name"),
                    "zone names must be unique when the mesh is imported",
                ));
            }
            z += 1;
        }
    }
    Ok(zone_of_name)
}

/// Checks the imported mesh, subdivides it `mesh.subdivide` times and builds the scene's mesh.
pub(crate) fn import(
    mut m: Imported,
    scene: &Scene,
    places: &dyn Places,
) -> Result<Mesh, SceneError> {
    let zones = mesh_zones(scene)?;
    for tri in &mut m.triangles {
        // Either orientation is accepted; the mesh is kept counter-clockwise.
        if orient(m.nodes[tri[0]], m.nodes[tri[1]], m.nodes[tri[2]]) < 0.0 {
            tri.swap(1, 2);
        }
    }
    check_zones_present(scene, &m.zone, places)?;
    let edges = check::connectivity(&m.nodes, &m.triangles).map_err(|d| defect(places, &m, d))?;
    check_hanging_nodes(&m, &zones, places)?;
    let mut curves = conforming_curves(&m, scene, &edges, places)?;
    let mut raw = RawMesh {
        nodes: m.nodes,
        triangles: m.triangles,
        zone: m.zone,
    };
    for _ in 0..scene.mesh.subdivide {
        (raw, curves) = subdivide(&raw, &curves);
    }
    finish(scene, raw, zones, &curves)
}

/// Every scene zone must have triangles.
fn check_zones_present(
    scene: &Scene,
    zone: &[usize],
    places: &dyn Places,
) -> Result<(), SceneError> {
    let mut present = vec![false; scene.bodies.iter().map(|b| b.zones.len()).sum()];
    for &z in zone {
        present[z] = true;
    }
    let mut z = 0;
    for (b, body) in scene.bodies.iter().enumerate() {
        for (k, zone) in body.zones.iter().enumerate() {
            if !present[z] {
                return Err(SceneError::new(
                    format!("bodies[{b}].zones[{k}]"),
                    format!(
                        "{} has no triangles in the zone '{}'",
                        places.source(),
                        zone.name
                    ),
                ));
            }
            z += 1;
        }
    }
    Ok(())
}

/// No hanging node inside any one body (bodies in contact may have non-matching meshes).
fn check_hanging_nodes(
    m: &Imported,
    zones: &[MeshZone],
    places: &dyn Places,
) -> Result<(), SceneError> {
    let bodies = zones.iter().map(|z| z.body + 1).max().unwrap_or(0);
    for b in 0..bodies {
        let of_body: Vec<usize> = (0..m.triangles.len())
            .filter(|&t| zones[m.zone[t]].body == b)
            .collect();
        let tris: Vec<[usize; 3]> = of_body.iter().map(|&t| m.triangles[t]).collect();
        if let Some(Defect::Hanging(n, t, e)) = check::hanging_node(&m.nodes, &tris) {
            return Err(defect(places, m, Defect::Hanging(n, of_body[t], e)));
        }
    }
    Ok(())
}

/// The lines of every named curve as node pairs; those of the scene's segments must be
/// triangle edges (`edges`: the mesh's node adjacency).
fn conforming_curves(
    m: &Imported,
    scene: &Scene,
    edges: &Rows,
    places: &dyn Places,
) -> Result<BTreeMap<String, Vec<[usize; 2]>>, SceneError> {
    let mut curves = BTreeMap::new();
    for (name, lines) in &m.curves {
        let pairs: Vec<[usize; 2]> = lines.iter().map(|&l| m.lines[l]).collect();
        if scene.segments.contains_key(name) {
            for (&l, &[a, b]) in lines.iter().zip(&pairs) {
                if !(edges.row(a).contains(&b) || edges.row(b).contains(&a)) {
                    return Err(places.at_line(
                        l,
                        format!(
                            "{} of the segment '{name}' joins nodes {} and {}, which are not \
                             two corners of one triangle: the curve does not conform to the \
                             surface mesh",
                            places.line(l),
                            places.node_id(a),
                            places.node_id(b)
                        ),
                    ));
                }
            }
        }
        curves.insert(name.clone(), pairs);
    }
    Ok(curves)
}

/// The error for a connectivity defect, in the source's names.
fn defect(places: &dyn Places, m: &Imported, d: Defect) -> SceneError {
    let kind = places.triangle_kind();
    let id = |t: usize| places.triangle_id(t);
    let node = |n: usize| places.node_id(n);
    match d {
        Defect::Degenerate(t) => places.at_triangle(
            t,
            format!(
                "{kind} {} (nodes {}) is degenerate: its corners are repeated or collinear, so \
                 it has no area",
                id(t),
                m.triangles[t].map(node).join(", ")
            ),
        ),
        Defect::Overlap([s, t], [a, b]) => places.at_triangle(
            t,
            format!(
                "{kind}s {} and {} lie on the same side of the edge between nodes {} and {}: \
                 they overlap (a folded, inverted or duplicated element), or the edge belongs \
                 to more than two triangles",
                id(s),
                id(t),
                node(a),
                node(b)
            ),
        ),
        Defect::Hanging(n, t, [a, b]) => places.at_triangle(
            t,
            format!(
                "node {} lies on the edge between nodes {} and {} of {kind} {} without being \
                 one of its corners (a hanging node): neighbouring elements must share their \
                 nodes along every edge",
                node(n),
                node(a),
                node(b),
                id(t)
            ),
        ),
    }
}
