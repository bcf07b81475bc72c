//! Mesh generation for a scene: one constrained Delaunay triangulation (spade) of all bodies
//! together, quality-refined to the minimum angle and to the local target size h(x), then
//! classified into zones (by triangle centroids, one test per region enclosed by constraint
//! edges) and handed to `assemble` for node splitting, segments and contacts. When the scene
//! names a Gmsh file, that mesh is imported instead.

use spade::handles::{FixedFaceHandle, InnerTag};
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, PositionInTriangulation,
    RefinementParameters, Triangulation,
};

use super::assemble::{finish, mesh_zones, RawMesh};
use super::geom::{dist, P};
use super::gmsh::import_gmsh;
use super::input::{self, zone_label, Geometry, Pslg};
use super::size::SizeField;
use super::Mesh;
use crate::scene::{Scene, SceneError};

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// Rounds of the size-driven refinement before giving up.
const MAX_ROUNDS: usize = 64;

/// Meshes all bodies of the scene (or imports `mesh.gmsh_file`).
pub fn generate(scene: &Scene) -> Result<Mesh, SceneError> {
    if let Some(file) = &scene.mesh.gmsh_file {
        let text = std::fs::read_to_string(file)
            .map_err(|e| SceneError::new("mesh.gmsh_file", format!("cannot read '{file}': {e}")))?;
        return import_gmsh(&text, scene);
    }
    let min_angle = scene.mesh.min_angle;
    if !(0.0..=30.0).contains(&min_angle) {
        return Err(SceneError::new(
            "mesh.min_angle",
            "must lie between 0 and 30 degrees",
        ));
    }
    let zones = mesh_zones(scene)?;
    let geo = input::geometry(scene)?;
    let size = SizeField::from_scene(scene)?;
    let area: f64 = geo.zones.iter().map(|z| z.area()).sum();
    let estimate = size.check_budget(area)?;
    let extra: Vec<P> = scene.segments.values().flat_map(|s| s.polyline()).collect();
    let pslg = input::pslg(&geo, &extra, &size);
    let setup = Setup {
        geo: &geo,
        scene,
        min_angle,
        budget: (4.0 * estimate) as usize + 100_000,
    };
    let cdt = triangulate(pslg, &size, &setup)?;
    let raw = classify(&cdt, &geo, scene)?;
    finish(scene, raw, zones, &Default::default())
}

/// What the triangulation needs besides the PSLG and the size field.
struct Setup<'a> {
    geo: &'a Geometry,
    scene: &'a Scene,
    min_angle: f64,
    /// Vertex budget: generous against the estimate (faces outside the domain but inside the
    /// convex hull are refined by spade too).
    budget: usize,
}

fn spade_point(p: P) -> Point2<f64> {
    // spade rejects non-zero coordinates below ~1e-43 in magnitude.
    let flush = |x: f64| if x.abs() < 1e-40 { 0.0 } else { x };
    Point2::new(flush(p[0]), flush(p[1]))
}

fn mesh_error(reason: String) -> SceneError {
    SceneError::new("mesh", reason)
}

/// CDT of the PSLG, refined to the angle limit and to h(x).
fn triangulate(pslg: Pslg, size: &SizeField, setup: &Setup) -> Result<Cdt, SceneError> {
    let points: Vec<Point2<f64>> = pslg.points.iter().map(|&p| spade_point(p)).collect();
    let mut conflicts = 0;
    let mut cdt = Cdt::try_bulk_load_cdt(points, pslg.edges, |_| conflicts += 1)
        .map_err(|e| mesh_error(format!("triangulation failed: {e}")))?;
    if conflicts > 0 {
        return Err(SceneError::new(
            "bodies",
            "zone boundaries cross each other (overlapping zones)",
        ));
    }
    let mut h: Vec<f64> = Vec::new();
    for _ in 0..MAX_ROUNDS {
        refine(&mut cdt, setup.min_angle, setup.budget)?;
        let mut zone = face_zones(&cdt, setup.geo, setup.scene)?;
        let inserted = split_large_faces(&mut cdt, size, &mut h, &mut zone, setup.budget)?;
        if inserted == 0 {
            return Ok(cdt);
        }
    }
    Err(mesh_error(format!(
        "the size refinement did not converge in {MAX_ROUNDS} rounds"
    )))
}

/// Whether the face's longest edge exceeds h, taken as the smallest h at its corners.
fn too_big(cdt: &Cdt, face: FixedFaceHandle<InnerTag>, h: &[f64]) -> bool {
    let f = cdt.face(face);
    let limit = f
        .vertices()
        .iter()
        .map(|v| h[v.fix().index()])
        .fold(f64::INFINITY, f64::min);
    longest_edge(f.positions()) > limit * (1.0 + 1e-9)
}

/// Splits every face of the domain whose longest edge exceeds h, one at a time (Ruppert-style):
/// inserts its circumcentre, or its centroid when the circumcentre lies across a constraint
/// edge, encroaches one, or falls outside the triangulation. `zone` (per face index) is kept up
/// to date: the faces around a new vertex belong to the zone of the face it split. Returns the
/// number of inserted vertices.
fn split_large_faces(
    cdt: &mut Cdt,
    size: &SizeField,
    h: &mut Vec<f64>,
    zone: &mut Vec<Option<usize>>,
    budget: usize,
) -> Result<usize, SceneError> {
    let update = |cdt: &Cdt, h: &mut Vec<f64>| {
        let start = h.len();
        h.extend(
            cdt.vertices()
                .skip(start)
                .map(|v| size.at([v.position().x, v.position().y])),
        );
    };
    update(cdt, h);
    let mut queue: Vec<FixedFaceHandle<InnerTag>> = cdt
        .fixed_inner_faces()
        .filter(|&f| zone[f.index()].is_some() && too_big(cdt, f, h))
        .collect();
    let mut inserted = 0;
    while let Some(face) = queue.pop() {
        if !too_big(cdt, face, h) {
            continue;
        }
        if cdt.num_vertices() >= budget {
            return Err(SceneError::new(
                "mesh.max_size",
                format!("the mesh needs more than {budget} vertices"),
            ));
        }
        let hint = cdt.face(face).vertices()[0].fix();
        let before = cdt.num_vertices();
        let v = cdt
            .insert_with_hint(steiner_point(cdt, face), hint)
            .map_err(|e| mesh_error(format!("triangulation failed: {e}")))?;
        if cdt.num_vertices() == before {
            continue; // the point already existed: nothing to split here
        }
        inserted += 1;
        update(cdt, h);
        zone.resize(cdt.num_all_faces(), None);
        let z = zone[face.index()];
        let around: Vec<FixedFaceHandle<InnerTag>> = cdt
            .vertex(v)
            .out_edges()
            .filter_map(|e| e.face().fix().as_inner())
            .collect();
        for g in around {
            zone[g.index()] = z;
            if too_big(cdt, g, h) {
                queue.push(g);
            }
        }
    }
    Ok(inserted)
}

/// The circumcentre of the face when it is safe to insert, else its centroid.
fn steiner_point(cdt: &Cdt, face: FixedFaceHandle<InnerTag>) -> Point2<f64> {
    let f = cdt.face(face);
    let (centroid, cc) = (f.center(), f.circumcenter());
    let cc = spade_point([cc.x, cc.y]);
    let located = match cdt.locate_with_hint(cc, f.vertices()[0].fix()) {
        PositionInTriangulation::OnFace(g) => Some(g),
        _ => None,
    };
    let safe = located.is_some_and(|g| {
        !cdt.intersects_constraint(centroid, cc)
            && cdt.face(g).adjacent_edges().iter().all(|e| {
                !e.is_constraint_edge() || {
                    let [a, b] = e.positions();
                    let mid = Point2::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y));
                    mid.distance_2(cc) >= 0.25 * a.distance_2(b)
                }
            })
    });
    if safe {
        cc
    } else {
        spade_point([centroid.x, centroid.y])
    }
}

/// spade's Delaunay refinement to the angle limit. No area bound: spade refines every face of
/// the convex hull, and an area bound would fill the gaps between bodies; sizes are enforced on
/// the domain's faces only, by `split_large_faces`.
fn refine(cdt: &mut Cdt, min_angle: f64, budget: usize) -> Result<(), SceneError> {
    let left = budget.saturating_sub(cdt.num_vertices());
    let result = cdt.refine(
        RefinementParameters::new()
            .with_angle_limit(AngleLimit::from_deg(min_angle))
            .with_max_additional_vertices(left),
    );
    if result.refinement_complete {
        Ok(())
    } else {
        Err(SceneError::new(
            "mesh.min_angle",
            format!(
                "the angle refinement did not finish within {budget} vertices; \
                 lower min_angle or check the geometry for tiny features"
            ),
        ))
    }
}

fn longest_edge(p: [Point2<f64>; 3]) -> f64 {
    let q = p.map(|v| [v.x, v.y]);
    dist(q[0], q[1]).max(dist(q[1], q[2])).max(dist(q[2], q[0]))
}

/// The zone of every face (by face index; `None` outside all zones). Faces are grouped into
/// regions connected across non-constraint edges, and each region is located once, by the
/// centroid of its largest face.
fn face_zones(cdt: &Cdt, geo: &Geometry, scene: &Scene) -> Result<Vec<Option<usize>>, SceneError> {
    const NONE: usize = usize::MAX;
    let mut region = vec![NONE; cdt.num_all_faces()];
    let mut region_zone: Vec<Option<usize>> = Vec::new();
    let mut stack = Vec::new();
    for start in cdt.inner_faces() {
        if region[start.fix().index()] != NONE {
            continue;
        }
        let r = region_zone.len();
        let mut best = (f64::NEG_INFINITY, [0.0, 0.0]);
        region[start.fix().index()] = r;
        stack.push(start);
        while let Some(f) = stack.pop() {
            if f.area() > best.0 {
                let c = f.center();
                best = (f.area(), [c.x, c.y]);
            }
            for e in f.adjacent_edges() {
                if e.is_constraint_edge() {
                    continue;
                }
                if let Some(g) = e.rev().face().as_inner() {
                    if region[g.fix().index()] == NONE {
                        region[g.fix().index()] = r;
                        stack.push(g);
                    }
                }
            }
        }
        region_zone.push(locate(best.1, geo, scene)?);
    }
    Ok(region
        .into_iter()
        .map(|r| region_zone.get(r).copied().flatten())
        .collect())
}

/// The triangles of the domain with their zones; faces in no zone are dropped.
fn classify(cdt: &Cdt, geo: &Geometry, scene: &Scene) -> Result<RawMesh, SceneError> {
    let zone = face_zones(cdt, geo, scene)?;
    let mut raw = RawMesh {
        nodes: cdt
            .vertices()
            .map(|v| [v.position().x, v.position().y])
            .collect(),
        ..RawMesh::default()
    };
    for f in cdt.inner_faces() {
        if let Some(z) = zone[f.fix().index()] {
            raw.triangles.push(f.vertices().map(|v| v.fix().index()));
            raw.zone.push(z);
        }
    }
    Ok(raw)
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
    pub nodes: usize,
    pub triangles: usize,
    /// Smallest interior angle \[deg\].
    pub min_angle_deg: f64,
    /// Largest circumradius / (2 × inradius) (1 for an equilateral triangle).
    pub max_aspect_ratio: f64,
    pub min_edge: f64,
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
