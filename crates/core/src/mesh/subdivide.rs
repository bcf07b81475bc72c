//! Uniform subdivision of an imported mesh (design §2.5): every triangle split into four by its
//! edge midpoints, which halves every edge (h → h/2, about four times the unknowns). Each
//! child keeps its parent's zone; each line of a named curve becomes its two halves, so
//! segments keep their edges; a midpoint is made once per edge, so both triangles of an edge,
//! and bodies sharing a contact line, share it. Midpoints lie on the straight edge: a curved
//! boundary keeps the polygon of the parent mesh (the geometry is not refined, only the
//! approximation on it).

use std::collections::{BTreeMap, HashMap};

use super::assemble::RawMesh;
use super::geom::P;

/// The mesh with every triangle split into four, and the curves' lines into two.
pub(crate) fn subdivide(
    raw: &RawMesh,
    curves: &BTreeMap<String, Vec<[usize; 2]>>,
) -> (RawMesh, BTreeMap<String, Vec<[usize; 2]>>) {
    let mut nodes: Vec<P> = raw.nodes.clone();
    let mut made: HashMap<[usize; 2], usize> = HashMap::new();
    let mut mid = |a: usize, b: usize| -> usize {
        *made.entry([a.min(b), a.max(b)]).or_insert_with(|| {
            let (p, q) = (nodes[a], nodes[b]);
            // Symmetric in a and b: the same point from both sides of an edge.
            nodes.push([0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])]);
            nodes.len() - 1
        })
    };
    let mut triangles = Vec::with_capacity(4 * raw.triangles.len());
    let mut zone = Vec::with_capacity(4 * raw.triangles.len());
    for (&[a, b, c], &z) in raw.triangles.iter().zip(&raw.zone) {
        let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
        // Counter-clockwise parents give counter-clockwise children.
        triangles.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        zone.extend([z; 4]);
    }
    let curves = curves
        .iter()
        .map(|(name, lines)| {
            let halves = lines
                .iter()
                .flat_map(|&[a, b]| {
                    let m = mid(a, b);
                    [[a, m], [m, b]]
                })
                .collect();
            (name.clone(), halves)
        })
        .collect();
    (
        RawMesh {
            nodes,
            triangles,
            zone,
        },
        curves,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_becomes_four_of_a_quarter_area_with_shared_midpoints() {
        let raw = RawMesh {
            nodes: vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [2.0, 2.0]],
            triangles: vec![[0, 1, 2], [1, 3, 2]],
            zone: vec![0, 1],
        };
        let curves = BTreeMap::from([("bottom".to_string(), vec![[0, 1]])]);
        let (fine, fine_curves) = subdivide(&raw, &curves);
        assert_eq!(fine.triangles.len(), 8);
        assert_eq!(fine.zone, vec![0, 0, 0, 0, 1, 1, 1, 1]);
        // 4 corners + 5 edges (the diagonal's midpoint once).
        assert_eq!(fine.nodes.len(), 9);
        for t in &fine.triangles {
            let [p, q, r] = t.map(|i| fine.nodes[i]);
            let area = 0.5 * super::super::geom::orient(p, q, r);
            assert_eq!(area, 0.5, "{t:?}");
        }
        let bottom = &fine_curves["bottom"];
        assert_eq!(bottom.len(), 2);
        assert_eq!(fine.nodes[bottom[0][1]], [1.0, 0.0]);
        assert_eq!(bottom[0][1], bottom[1][0]);
    }
}
