//! P1 geometry shared by every operator: shape-function gradients of a triangle and outward
//! normals of boundary edges (edges are oriented with the body on their left, `mesh::MeshSegment`).

use std::collections::BTreeMap;

pub use crate::mesh::normals::{edge_length, edge_normal, segment_node_normals};
use crate::mesh::Mesh;
use crate::scene::BoundaryData;

use super::FemError;

/// Area and constant shape-function gradients of a P1 triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleGradients {
    /// Signed area (positive for counter-clockwise triangles).
    pub area: f64,
    /// ∂φ_i/∂x for the three vertices.
    pub dx: [f64; 3],
    /// ∂φ_i/∂y for the three vertices.
    pub dy: [f64; 3],
}

impl TriangleGradients {
    /// Gradients of the barycentric coordinates of triangle `t`.
    pub fn of(mesh: &Mesh, t: usize) -> TriangleGradients {
        let [a, b, c] = mesh.triangles[t];
        let p = [mesh.nodes[a], mesh.nodes[b], mesh.nodes[c]];
        let area = mesh.triangle_area(t);
        let mut dx = [0.0; 3];
        let mut dy = [0.0; 3];
        for i in 0..3 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            dx[i] = (p[j][1] - p[k][1]) / (2.0 * area);
            dy[i] = (p[k][0] - p[j][0]) / (2.0 * area);
        }
        TriangleGradients { area, dx, dy }
    }

    /// Strain (e11, e22, γ12 = 2 e12) of the element displacement v = (v1x, v1y, v2x, ...).
    pub fn strain(&self, v: &[f64; 6]) -> [f64; 3] {
        let mut e = [0.0; 3];
        for i in 0..3 {
            let (ux, uy) = (v[2 * i], v[2 * i + 1]);
            e[0] += self.dx[i] * ux;
            e[1] += self.dy[i] * uy;
            e[2] += self.dy[i] * ux + self.dx[i] * uy;
        }
        e
    }

    /// Nodal forces Bᵀσ·area of a constant stress (σ11, σ22, σ12).
    pub fn nodal_forces(&self, s: [f64; 3]) -> [f64; 6] {
        let mut f = [0.0; 6];
        for i in 0..3 {
            f[2 * i] = self.area * (self.dx[i] * s[0] + self.dy[i] * s[2]);
            f[2 * i + 1] = self.area * (self.dy[i] * s[1] + self.dx[i] * s[2]);
        }
        f
    }
}

/// Shape-function gradients of every triangle.
pub fn element_gradients(mesh: &Mesh) -> Vec<TriangleGradients> {
    (0..mesh.triangles.len())
        .map(|t| TriangleGradients::of(mesh, t))
        .collect()
}

/// Triangles must be counter-clockwise and non-degenerate, zones and bodies consistent.
pub fn check_mesh(mesh: &Mesh) -> Result<(), FemError> {
    if mesh.triangle_zone.len() != mesh.triangles.len() || mesh.node_body.len() != mesh.nodes.len()
    {
        return Err(FemError::Input(
            "mesh arrays have inconsistent lengths".into(),
        ));
    }
    for t in 0..mesh.triangles.len() {
        let area = mesh.triangle_area(t);
        if area.is_nan() || area <= 0.0 {
            return Err(FemError::Input(format!(
                "triangle {t} {:?} has area {area} (must be counter-clockwise, non-degenerate)",
                mesh.triangles[t]
            )));
        }
        if mesh.triangle_zone[t] >= mesh.zones.len() {
            return Err(FemError::Input(format!("triangle {t} has no valid zone")));
        }
    }
    Ok(())
}

/// Nodal weights of the boundary loads of one boundary condition's segment.
#[derive(Debug, Clone, Default)]
pub struct SegmentLoad {
    /// ∫ φ_i ds per node (traction P gives P·w_i).
    pub weights: Vec<(usize, f64)>,
    /// ∫ φ_i n ds per node (pressure p gives −p·v_i).
    pub normals: Vec<(usize, [f64; 2])>,
}

/// ∫ φ_i dx = area/3 per element node, grouped by zone.
pub fn zone_weights(mesh: &Mesh, gradients: &[TriangleGradients]) -> Vec<Vec<(usize, f64)>> {
    let mut per_zone = vec![BTreeMap::<usize, f64>::new(); mesh.zones.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for &node in tri {
            *per_zone[mesh.triangle_zone[t]].entry(node).or_insert(0.0) += gradients[t].area / 3.0;
        }
    }
    per_zone
        .into_iter()
        .map(|m| m.into_iter().collect())
        .collect()
}

/// The load weights shared by elasticity and heat: per zone ∫ φ_i dx (body force, source) and
/// per boundary condition ∫ φ_i ds, ∫ φ_i n ds on its segment (traction, pressure, flux).
#[derive(Debug, Clone)]
pub struct UnitLoads {
    pub zones: Vec<Vec<(usize, f64)>>,
    pub segments: Vec<SegmentLoad>,
}

impl UnitLoads {
    pub fn new(
        mesh: &Mesh,
        boundary: &[BoundaryData],
        gradients: &[TriangleGradients],
    ) -> UnitLoads {
        UnitLoads {
            zones: zone_weights(mesh, gradients),
            segments: boundary
                .iter()
                .map(|bc| segment_load(mesh, bc.segment))
                .collect(),
        }
    }
}

/// ∫ φ_i ds and ∫ φ_i n ds on a segment (exact for P1 on straight edges).
pub fn segment_load(mesh: &Mesh, segment: usize) -> SegmentLoad {
    let Some(seg) = mesh.segments.get(segment) else {
        return SegmentLoad::default();
    };
    let mut weights = BTreeMap::<usize, f64>::new();
    let mut normals = BTreeMap::<usize, [f64; 2]>::new();
    for &edge in &seg.edges {
        let half = edge_length(mesh, edge) / 2.0;
        let n = edge_normal(mesh, edge);
        for node in edge {
            *weights.entry(node).or_insert(0.0) += half;
            let v = normals.entry(node).or_insert([0.0; 2]);
            v[0] += n[0] / 2.0;
            v[1] += n[1] / 2.0;
        }
    }
    SegmentLoad {
        weights: weights.into_iter().collect(),
        normals: normals.into_iter().collect(),
    }
}
