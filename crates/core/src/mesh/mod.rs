//! Mesh: P1 triangles of all bodies, with zones, named boundary segments and contact node pairs.
//!
//! Bodies are meshed together so that nodes match on both sides of every contact zone (design §2.4:
//! node-to-node contact as in all the papers), then every node shared by two bodies is split into
//! one copy per body. A contact zone is the list of node pairs (node of body k, node of body l) at
//! the same position, ordered along body k's segment.

pub(crate) mod assemble;
mod check;
mod count;
mod generate;
pub(crate) mod geom;
mod gmsh;
mod import;
mod inline;
mod input;
mod mortar;
mod msh;
pub mod normals;
mod refine;
mod rows;
mod size;
mod subdivide;
#[cfg(test)]
pub(crate) mod tests;
mod tri;

pub use count::count;
pub use generate::{generate, stats, MeshStats};
pub use gmsh::with_inline_mesh;
pub use mortar::MortarRow;

/// A material zone of the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshZone {
    /// Zone name from the scene (`bodies[].zones[].name`).
    pub name: String,
    /// Index of the body in `Mesh::bodies`.
    pub body: usize,
    /// Index of the material (scene materials in name order).
    pub material: usize,
}

/// A named boundary segment resolved on the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSegment {
    /// Segment name from the scene (the key of `segments`).
    pub name: String,
    /// Index of the segment's body in `Mesh::bodies`.
    pub body: usize,
    /// Nodes on the segment, ordered along its polyline.
    pub nodes: Vec<usize>,
    /// Boundary edges on the segment, each oriented with the body on its left, so that the
    /// outward normal of edge [a, b] is (y_b − y_a, −(x_b − x_a)) / length.
    pub edges: Vec<[usize; 2]>,
}

/// A contact zone Γ^kl: matching node pairs between body k and body l, or, with mortar
/// coupling, the slave nodes and their dual mortar rows (design §2.4.1).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshContact {
    /// Name of the contact zone from the scene.
    pub name: String,
    /// Index of body k's segment in `Mesh::segments` (the normal is outward of body k); with
    /// mortar the slave segment.
    pub segment_k: usize,
    /// Index of body l's segment in `Mesh::segments`; with mortar the master segment.
    pub segment_l: usize,
    /// (node of body k, node of body l), ordered along body k's segment; with mortar (slave node,
    /// the master node of its largest mortar coefficient).
    pub pairs: Vec<[usize; 2]>,
    /// Arc-length fraction s ∈ [0, 1] of each pair along the zone (for slip limits g(s)),
    /// measured along the scene's first segment of the zone (`between[0]`).
    pub fraction: Vec<f64>,
    /// With mortar coupling, each pair's row: the master combination, weight and weighted gap.
    pub mortar: Option<Vec<MortarRow>>,
}

/// The mesh of a scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Node coordinates `[x, y]` \[m\]; a node shared by two bodies appears once per body.
    pub nodes: Vec<[f64; 2]>,
    /// Triangles, counter-clockwise.
    pub triangles: Vec<[usize; 3]>,
    /// Zone of each triangle (index into `zones`).
    pub triangle_zone: Vec<usize>,
    /// Material zones in scene order (bodies in list order, their zones in list order).
    pub zones: Vec<MeshZone>,
    /// Body names.
    pub bodies: Vec<String>,
    /// Body of each node.
    pub node_body: Vec<usize>,
    /// Segments in scene order (names sorted).
    pub segments: Vec<MeshSegment>,
    /// Contact zones in scene order.
    pub contacts: Vec<MeshContact>,
}

impl Mesh {
    /// This mesh as a scene's `mesh.inline` (nodes, triangles, zone names, segment edges): a
    /// scene given it meshes to the same nodes, e.g. to couple one mesh two ways.
    pub fn to_inline(&self) -> crate::scene::InlineMesh {
        crate::scene::InlineMesh {
            nodes: self.nodes.clone(),
            triangles: self.triangles.clone(),
            zones: self.zones.iter().map(|z| z.name.clone()).collect(),
            triangle_zones: self.triangle_zone.clone(),
            segments: self
                .segments
                .iter()
                .map(|s| (s.name.clone(), s.edges.clone()))
                .collect(),
        }
    }

    /// Signed area of triangle `t` (positive for counter-clockwise).
    pub fn triangle_area(&self, t: usize) -> f64 {
        let [a, b, c] = self.triangles[t];
        0.5 * geom::orient(self.nodes[a], self.nodes[b], self.nodes[c])
    }

    /// Index of the segment with this name.
    pub fn segment_index(&self, name: &str) -> Option<usize> {
        self.segments.iter().position(|s| s.name == name)
    }

    /// The triangle holding `p` and its barycentric coordinates (the P1 shape functions'
    /// values at `p`; a point on an edge belongs to the first triangle found).
    pub fn locate(&self, p: [f64; 2]) -> Option<([usize; 3], [f64; 3])> {
        let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
            (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        };
        self.triangles.iter().find_map(|&tri| {
            let [a, b, c] = tri.map(|n| self.nodes[n]);
            let area = cross(a, b, c);
            let w = [
                cross(p, b, c) / area,
                cross(a, p, c) / area,
                cross(a, b, p) / area,
            ];
            w.iter().all(|&x| x >= -1e-12).then_some((tri, w))
        })
    }
}
