//! Mesh generation for a scene: one constrained Delaunay triangulation (spade's bulk load) of all
//! bodies together, copied into flat arrays (`tri`), classified into zones (by triangle
//! centroids, one test per region enclosed by constraint edges), Delaunay-refined on the
//! domain's triangles only (`refine`) to the minimum angle and to the local target size h(x),
//! checked (`check`), and handed to `assemble` for node splitting, segments and contacts. When the scene names a Gmsh file or gives an inline mesh, that
//! mesh is imported instead (`import`).

use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

use super::assemble::{finish, mesh_zones, RawMesh};
use super::check;
use super::geom::{bbox, dist, P};
use super::gmsh::import_gmsh;
use super::inline::import_inline;
use super::input::{self, zone_label, Geometry, Pslg};
use super::refine::Refiner;
use super::size::SizeField;
use super::tri::{orient, Tri, NONE};
use super::Mesh;
use crate::scene::{Coupling, Scene, SceneError};

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// Meshes all bodies of the scene (or imports `mesh.gmsh_file` or `mesh.inline`).
pub fn generate(scene: &Scene) -> Result<Mesh, SceneError> {
    if let Some(file) = &scene.mesh.gmsh_file {
        let bytes = std::fs::read(file)
            .map_err(|e| SceneError::new("mesh.gmsh_file", format!("cannot read '{file}': {e}")))?;
        return import_gmsh(bytes, scene);
    }
    if let Some(inline) = &scene.mesh.inline {
        return import_inline(inline, scene);
    }
    let min_angle = scene.mesh.min_angle;
    if !(0.0..=30.0).contains(&min_angle) {
        return Err(SceneError::new(
            "mesh.min_angle",
            "must lie between 0 and 30 degrees",
        ));
    }
    let zones = mesh_zones(scene)?;
    let groups = meshing_groups(scene);
    if groups.len() == 1 {
        let raw = raw_mesh_of(scene, min_angle)?;
        return finish(scene, raw, zones, &Default::default());
    }
    SizeField::from_scene(scene)?;
    let mut raw = RawMesh::default();
    for group in &groups {
        let part = bodies_only(scene, group);
        let piece = raw_mesh_of(&part, min_angle).map_err(|e| in_scene(e, group))?;
        // The part's zones are its bodies' zones in order; map them to the scene's.
        let zone_of: Vec<usize> = zones
            .iter()
            .enumerate()
            .filter(|(_, z)| group.contains(&z.body))
            .map(|(i, _)| i)
            .collect();
        let base = raw.nodes.len();
        raw.nodes.extend(piece.nodes);
        raw.triangles
            .extend(piece.triangles.iter().map(|t| t.map(|v| v + base)));
        raw.zone.extend(piece.zone.iter().map(|&z| zone_of[z]));
    }
    finish(scene, raw, zones, &Default::default())
}

/// The bodies meshed together: those joined by node-coupled contact zones (their nodes must
/// match), each group on its own when a mortar zone lets bodies be meshed separately (design
/// §2.4.1). One group, in body order, when no zone is mortar-coupled.
fn meshing_groups(scene: &Scene) -> Vec<Vec<usize>> {
    let n = scene.bodies.len();
    if scene.contacts.iter().all(|c| c.coupling == Coupling::Nodes) {
        return vec![(0..n).collect()];
    }
    let body_of = |segment: &str| {
        let name = &scene.segments.get(segment)?.body;
        scene.bodies.iter().position(|b| b.name == *name)
    };
    let mut group: Vec<usize> = (0..n).collect();
    let root = |group: &[usize], mut b: usize| {
        while group[b] != b {
            b = group[b];
        }
        b
    };
    for c in scene
        .contacts
        .iter()
        .filter(|c| c.coupling == Coupling::Nodes)
    {
        if let (Some(a), Some(b)) = (body_of(&c.between[0]), body_of(&c.between[1])) {
            let (ra, rb) = (root(&group, a), root(&group, b));
            group[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut out: Vec<Vec<usize>> = Vec::new();
    let mut slot = vec![usize::MAX; n];
    for b in 0..n {
        let r = root(&group, b);
        if slot[r] == usize::MAX {
            slot[r] = out.len();
            out.push(Vec::new());
        }
        out[slot[r]].push(b);
    }
    out
}

/// The scene restricted to some bodies for meshing: their zones, their segments, and the
/// refinements along their segments or inside polygons.
fn bodies_only(scene: &Scene, bodies: &[usize]) -> Scene {
    let mut part = scene.clone();
    part.bodies = bodies.iter().map(|&b| scene.bodies[b].clone()).collect();
    let names: Vec<&str> = part.bodies.iter().map(|b| b.name.as_str()).collect();
    part.segments
        .retain(|_, segment| names.contains(&segment.body.as_str()));
    part.contacts.clear();
    part.mesh.refine = scene
        .mesh
        .refine
        .iter()
        .filter_map(|r| {
            let mut r = r.clone();
            r.segments.retain(|s| part.segments.contains_key(s));
            (!r.segments.is_empty() || r.polygon.is_some()).then_some(r)
        })
        .collect();
    part
}

/// An error of a part's mesh named in the scene's body numbering.
fn in_scene(mut error: SceneError, bodies: &[usize]) -> SceneError {
    if let Some(rest) = error.path.strip_prefix("bodies[") {
        if let Some((index, tail)) = rest.split_once(']') {
            if let Some(&b) = index.parse::<usize>().ok().and_then(|j| bodies.get(j)) {
                error.path = format!("bodies[{b}]{tail}");
            }
        }
    }
    error
}

/// The checked raw triangulation of every body of `scene` together.
fn raw_mesh_of(scene: &Scene, min_angle: f64) -> Result<RawMesh, SceneError> {
    let geo = input::geometry(scene)?;
    let size = SizeField::from_scene(scene)?;
    let area: f64 = geo.zones.iter().map(|z| z.area()).sum();
    let estimate = size.check_budget(area)?;
    let extra: Vec<P> = scene.segments.values().flat_map(|s| s.polyline()).collect();
    let pslg = input::pslg(&geo, &extra, &size);
    let budget = (4.0 * estimate) as usize + 10 * pslg.points.len() + 10_000;
    // spade is not expected to panic on checked input; if it does, the user gets an error
    // naming the geometry instead of a crash.
    let run = || -> Result<RawMesh, SceneError> {
        let tri = triangulate(&pslg, &size, &geo, scene, min_angle, budget)?;
        Ok(raw_mesh(&tri))
    };
    let raw =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)).unwrap_or_else(|panic| {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(SceneError::new(
                "bodies",
                format!("the triangulator failed on this geometry ({what}); please report it"),
            ))
        })?;
    check::raw_mesh(&raw, &geo, &pslg, &size, min_angle)?;
    Ok(raw)
}

fn spade_point(p: P) -> Point2<f64> {
    // spade rejects non-zero coordinates below ~1e-43 in magnitude.
    let flush = |x: f64| if x.abs() < 1e-40 { 0.0 } else { x };
    Point2::new(flush(p[0]), flush(p[1]))
}

/// CDT of the PSLG (spade), refined on the domain's triangles to the angle limit and to h(x).
fn triangulate(
    pslg: &Pslg,
    size: &SizeField,
    geo: &Geometry,
    scene: &Scene,
    min_angle: f64,
    budget: usize,
) -> Result<Tri, SceneError> {
    let mut points: Vec<Point2<f64>> = pslg.points.iter().map(|&p| spade_point(p)).collect();
    // A frame of four far corners keeps every segment off the convex hull, so that each one
    // has a triangle on both sides.
    let bb = bbox(pslg.points.iter().copied());
    let margin = (bb[2] - bb[0]).max(bb[3] - bb[1]);
    let (x0, y0, x1, y1) = (
        bb[0] - margin,
        bb[1] - margin,
        bb[2] + margin,
        bb[3] + margin,
    );
    points.extend([[x0, y0], [x1, y0], [x1, y1], [x0, y1]].map(spade_point));
    let mut conflicts = 0;
    let cdt = Cdt::try_bulk_load_cdt(points, pslg.edges.clone(), |_| conflicts += 1)
        .map_err(|e| SceneError::new("bodies", format!("triangulation failed: {e}")))?;
    if conflicts > 0 {
        return Err(SceneError::new(
            "bodies",
            "zone boundaries cross each other (overlapping zones)",
        ));
    }
    let mut tri = flat(&cdt);
    tri.zone = zones(&tri, geo, scene)?;
    let mut refiner = Refiner::new(tri, size, min_angle, budget);
    refiner.run()?;
    Ok(refiner.tri)
}

/// spade's triangulation as flat arrays.
fn flat(cdt: &Cdt) -> Tri {
    let pts: Vec<P> = cdt
        .vertices()
        .map(|v| [v.position().x, v.position().y])
        .collect();
    let id = |v: FixedVertexHandle| v.index() as u32;
    let tris: Vec<[u32; 3]> = cdt
        .inner_faces()
        .map(|f| {
            let [a, b, c] = f.vertices().map(|v| id(v.fix()));
            if orient(pts[a as usize], pts[b as usize], pts[c as usize]) > 0.0 {
                [a, b, c]
            } else {
                [a, c, b]
            }
        })
        .collect();
    let mut constraints: Vec<[u32; 2]> = cdt
        .undirected_edges()
        .filter(|e| e.is_constraint_edge())
        .map(|e| {
            let [a, b] = e.vertices().map(|v| id(v.fix()));
            [a.min(b), a.max(b)]
        })
        .collect();
    constraints.sort_unstable();
    Tri::new(pts, tris, |a, b| constraints.binary_search(&[a, b]).is_ok())
}

/// The zone of every triangle (`NONE` outside all zones). Triangles are grouped into regions
/// connected across non-constraint edges, and each region is located once, by the centroid of
/// its largest triangle.
fn zones(tri: &Tri, geo: &Geometry, scene: &Scene) -> Result<Vec<u32>, SceneError> {
    let mut region = vec![NONE; tri.v.len()];
    let mut region_zone: Vec<u32> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..tri.v.len() as u32 {
        if region[start as usize] != NONE {
            continue;
        }
        let r = region_zone.len() as u32;
        let mut best = (f64::NEG_INFINITY, [0.0, 0.0]);
        region[start as usize] = r;
        stack.push(start);
        while let Some(t) = stack.pop() {
            let [a, b, c] = tri.corners(t);
            let area = orient(a, b, c);
            if area > best.0 {
                best = (
                    area,
                    [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0],
                );
            }
            for k in 0..3 {
                let u = tri.n[t as usize][k];
                if !tri.is_seg(t, k) && u != NONE && region[u as usize] == NONE {
                    region[u as usize] = r;
                    stack.push(u);
                }
            }
        }
        region_zone.push(locate(best.1, geo, scene)?.map_or(NONE, |z| z as u32));
    }
    Ok(region
        .into_iter()
        .map(|r| region_zone[r as usize])
        .collect())
}

/// The triangles of the domain with their zones; triangles in no zone are dropped, and so are
/// the vertices only they use.
fn raw_mesh(tri: &Tri) -> RawMesh {
    let mut id = vec![NONE; tri.pts.len()];
    let mut raw = RawMesh::default();
    for (t, &z) in tri.zone.iter().enumerate() {
        if z == NONE {
            continue;
        }
        let corners = tri.v[t].map(|k| {
            if id[k as usize] == NONE {
                id[k as usize] = raw.nodes.len() as u32;
                raw.nodes.push(tri.pts[k as usize]);
            }
            id[k as usize] as usize
        });
        raw.triangles.push(corners);
        raw.zone.push(z as usize);
    }
    raw
}

/// The zone containing `p`; an error when two zones claim it.
fn locate(p: P, geo: &Geometry, scene: &Scene) -> Result<Option<usize>, SceneError> {
    let mut found: Option<usize> = None;
    for (z, g) in geo.zones.iter().enumerate() {
        if g.contains(p) {
            if let Some(first) = found {
                return Err(SceneError::new(
                    g.path.clone(),
                    format!("overlaps {}", zone_label(scene, &geo.zones[first])),
                ));
            }
            found = Some(z);
        }
    }
    Ok(found)
}

/// Size and quality figures of a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshStats {
    /// Number of nodes (contact nodes counted once per body).
    pub nodes: usize,
    /// Number of triangles.
    pub triangles: usize,
    /// Smallest interior angle \[deg\].
    pub min_angle_deg: f64,
    /// Largest circumradius / (2 × inradius) (1 for an equilateral triangle).
    pub max_aspect_ratio: f64,
    /// Shortest edge length \[m\].
    pub min_edge: f64,
    /// Longest edge length \[m\].
    pub max_edge: f64,
}

/// Size and quality figures of `mesh`.
pub fn stats(mesh: &Mesh) -> MeshStats {
    let mut s = MeshStats {
        nodes: mesh.nodes.len(),
        triangles: mesh.triangles.len(),
        min_angle_deg: 180.0,
        max_aspect_ratio: 0.0,
        min_edge: f64::INFINITY,
        max_edge: 0.0,
    };
    for t in &mesh.triangles {
        let p = t.map(|i| mesh.nodes[i]);
        let l = [dist(p[1], p[2]), dist(p[2], p[0]), dist(p[0], p[1])];
        for i in 0..3 {
            let (a, b, c) = (l[i], l[(i + 1) % 3], l[(i + 2) % 3]);
            let cos = ((b * b + c * c - a * a) / (2.0 * b * c)).clamp(-1.0, 1.0);
            s.min_angle_deg = s.min_angle_deg.min(cos.acos().to_degrees());
        }
        let perimeter = l[0] + l[1] + l[2];
        let area = super::geom::orient(p[0], p[1], p[2]).abs() * 0.5;
        let (circum, inner) = (l[0] * l[1] * l[2] / (4.0 * area), 2.0 * area / perimeter);
        s.max_aspect_ratio = s.max_aspect_ratio.max(circum / (2.0 * inner));
        s.min_edge = s.min_edge.min(l[0].min(l[1]).min(l[2]));
        s.max_edge = s.max_edge.max(l[0].max(l[1]).max(l[2]));
    }
    s
}
