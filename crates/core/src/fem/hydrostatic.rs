//! Nodal forces of a hydrostatic pressure p(y) = γ max(y0 − y, 0) (+ a uniform `wet_pressure`
//! below the level) on a segment's P1 edges, integrated exactly (design §2.6).
//!
//! On an edge from a to b (s ∈ [0, 1], y(s) = y_a + s (y_b − y_a)) the pressure is linear on the
//! wet part {y(s) < y0}, an interval [s0, s1] (the whole edge, none, or the edge split at the
//! level), and zero elsewhere; the nodal force of node a is −n L ∫_{s0}^{s1} p(s) (1 − s) ds,
//! of b −n L ∫ p(s) s ds (n the unit outward normal, L the length). The integrands are quadratic,
//! so Simpson's rule on [s0, s1] is exact. A horizontal edge exactly at the level is dry.
//!
//! The level's derivative: ∂p/∂y0 = γ H(y0 − y) (the boundary term of the moving split point
//! vanishes since p = 0 there): the load of the uniform pressure γ on the wet part, which is the
//! difference of the loads with `wet_pressure = γ` and with `wet_pressure = 0`.

use super::geometry::edge_normal;
use crate::mesh::Mesh;
use crate::scene::HydrostaticData;

/// f += the nodal forces of the hydrostatic pressure `h` on the edges of mesh segment `segment`.
pub(super) fn add_hydrostatic(
    mesh: &Mesh,
    segment: usize,
    h: &HydrostaticData,
    f: &mut [[f64; 2]],
) {
    let Some(seg) = mesh.segments.get(segment) else {
        return;
    };
    for &edge in &seg.edges {
        let [a, b] = edge;
        let (ya, yb) = (mesh.nodes[a][1], mesh.nodes[b][1]);
        let Some((s0, s1)) = wet_interval(ya, yb, h.level) else {
            continue;
        };
        // p is linear on [s0, s1]: its values there and at the midpoint.
        let p = |s: f64| h.unit_weight * (h.level - (ya + s * (yb - ya))) + h.wet_pressure;
        let mid = 0.5 * (s0 + s1);
        let simpson = |g: &dyn Fn(f64) -> f64| (s1 - s0) / 6.0 * (g(s0) + 4.0 * g(mid) + g(s1));
        let fa = simpson(&|s| p(s) * (1.0 - s));
        let fb = simpson(&|s| p(s) * s);
        // edge_normal is the outward normal scaled by the edge length.
        let n = edge_normal(mesh, edge);
        for (node, w) in [(a, fa), (b, fb)] {
            f[node][0] -= w * n[0];
            f[node][1] -= w * n[1];
        }
    }
}

/// The part [s0, s1] of the edge s ∈ [0, 1] from height `ya` to `yb` that lies strictly below
/// `level`, or `None` when it is dry.
fn wet_interval(ya: f64, yb: f64, level: f64) -> Option<(f64, f64)> {
    let (da, db) = (level - ya, level - yb);
    match (da > 0.0, db > 0.0) {
        (true, true) => Some((0.0, 1.0)),
        (false, false) => None,
        (true, false) => Some((0.0, da / (da - db))),
        (false, true) => Some((da / (da - db), 1.0)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wet_part_of_an_edge_is_split_at_the_level() {
        assert_eq!(wet_interval(0.0, 4.0, 5.0), Some((0.0, 1.0)));
        assert_eq!(wet_interval(0.0, 4.0, 0.0), None);
        assert_eq!(wet_interval(0.0, 4.0, 1.0), Some((0.0, 0.25)));
        assert_eq!(wet_interval(4.0, 0.0, 1.0), Some((0.75, 1.0)));
        assert_eq!(wet_interval(2.0, 2.0, 2.0), None);
    }
}
