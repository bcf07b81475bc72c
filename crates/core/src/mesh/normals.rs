//! Outward normals of boundary edges and segments (edges are oriented with the body on their
//! left, `MeshSegment`): used by the loads and sliding supports (`fem`), the node-pair contact
//! normals (design §2.4) and the mortar coupling's slave normals (design §2.4.1).

use std::collections::HashMap;

use super::{Mesh, MeshSegment};

/// Outward normal times length of the boundary edge [a, b]: (y_b − y_a, −(x_b − x_a)).
pub fn edge_normal(mesh: &Mesh, [a, b]: [usize; 2]) -> [f64; 2] {
    let (pa, pb) = (mesh.nodes[a], mesh.nodes[b]);
    [pb[1] - pa[1], -(pb[0] - pa[0])]
}

/// Length of the edge [a, b].
pub fn edge_length(mesh: &Mesh, edge: [usize; 2]) -> f64 {
    let n = edge_normal(mesh, edge);
    n[0].hypot(n[1])
}

/// Averaged outward unit normal of a segment at each of its nodes (sum of the unit normals of
/// the adjacent segment edges, normalised), in the order of `segment.nodes`.
pub fn segment_node_normals(mesh: &Mesh, segment: &MeshSegment) -> Vec<(usize, [f64; 2])> {
    let mut sum = HashMap::<usize, [f64; 2]>::new();
    for &edge in &segment.edges {
        let n = edge_normal(mesh, edge);
        let len = n[0].hypot(n[1]);
        if len > 0.0 {
            for node in edge {
                let s = sum.entry(node).or_insert([0.0; 2]);
                s[0] += n[0] / len;
                s[1] += n[1] / len;
            }
        }
    }
    segment
        .nodes
        .iter()
        .filter_map(|&node| {
            let s = sum.get(&node)?;
            let len = s[0].hypot(s[1]);
            (len > 0.0).then(|| (node, [s[0] / len, s[1] / len]))
        })
        .collect()
}
