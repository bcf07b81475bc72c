//! Fixtures for tests, studies and benchmarks — not part of the engine's pipeline: structured
//! meshes (mapped grids of P1 triangles with alternating diagonals, so no directional bias), their
//! random interior perturbation, rigid rotation, two stacked blocks with a contact zone, and the
//! one seeded random generator every test draws from (xoshiro256++, as the search's streams of
//! design §4.3).
//!
//! Segments follow the `Mesh` contract: names sorted, nodes and edges ordered counter-clockwise
//! around the body (edges with the body on their left).

use rand_xoshiro::rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::mesh::{Mesh, MeshContact, MeshSegment, MeshZone};

/// The seeded generator of the tests and fixtures.
pub type Rng = Xoshiro256PlusPlus;

/// The generator whose stream is fixed by `seed`.
pub fn rng(seed: u64) -> Rng {
    Rng::seed_from_u64(seed)
}

/// Uniform in [0, 1) with 53 random bits.
pub fn uniform(rng: &mut Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// Uniform in {0, …, n − 1} (n ≥ 1; the modulo bias is below n / 2⁶⁴).
pub fn below(rng: &mut Rng, n: usize) -> usize {
    (rng.next_u64() % n as u64) as usize
}

/// A mapped (nu × nv)-cell grid of the unit square through `map`; sides named
/// `[v = 0, u = 1, v = 1, u = 0]` (counter-clockwise). `map` must preserve orientation.
fn mapped_grid(nu: usize, nv: usize, names: [&str; 4], map: impl Fn(f64, f64) -> [f64; 2]) -> Mesh {
    let (nu, nv) = (nu.max(1), nv.max(1));
    let id = |i: usize, j: usize| j * (nu + 1) + i;
    let nodes: Vec<[f64; 2]> = (0..=nv)
        .flat_map(|j| (0..=nu).map(move |i| (i, j)))
        .map(|(i, j)| map(i as f64 / nu as f64, j as f64 / nv as f64))
        .collect();
    let mut triangles = Vec::with_capacity(2 * nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let (p00, p10, p11, p01) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                triangles.push([p00, p10, p11]);
                triangles.push([p00, p11, p01]);
            } else {
                triangles.push([p00, p10, p01]);
                triangles.push([p10, p11, p01]);
            }
        }
    }
    let sides: [Vec<usize>; 4] = [
        (0..=nu).map(|i| id(i, 0)).collect(),
        (0..=nv).map(|j| id(nu, j)).collect(),
        (0..=nu).rev().map(|i| id(i, nv)).collect(),
        (0..=nv).rev().map(|j| id(0, j)).collect(),
    ];
    let mut segments: Vec<MeshSegment> = sides
        .into_iter()
        .zip(names)
        .map(|(nodes, name)| MeshSegment {
            name: name.to_string(),
            body: 0,
            edges: nodes.windows(2).map(|w| [w[0], w[1]]).collect(),
            nodes,
        })
        .collect();
    segments.sort_by(|a, b| a.name.cmp(&b.name));
    Mesh {
        node_body: vec![0; nodes.len()],
        nodes,
        triangle_zone: vec![0; triangles.len()],
        triangles,
        zones: vec![MeshZone {
            name: "zone".into(),
            body: 0,
            material: 0,
        }],
        bodies: vec!["body".into()],
        segments,
        contacts: Vec::new(),
    }
}

/// Rectangle [x0, x1] × [y0, y1] with nx × ny cells, one body "body", one zone "zone" of
/// material 0; segments (sorted) "bottom", "left", "right", "top".
pub fn rectangle(x0: f64, y0: f64, x1: f64, y1: f64, nx: usize, ny: usize) -> Mesh {
    mapped_grid(nx, ny, ["bottom", "right", "top", "left"], |u, v| {
        [x0 + u * (x1 - x0), y0 + v * (y1 - y0)]
    })
}

/// Quarter annulus r_in ≤ r ≤ r_out, 0 ≤ θ ≤ π/2 with nr × ntheta cells; segments (sorted)
/// "inner", "outer", "x_axis" (y = 0), "y_axis" (x = 0).
pub fn quarter_annulus(r_in: f64, r_out: f64, nr: usize, ntheta: usize) -> Mesh {
    mapped_grid(
        nr,
        ntheta,
        ["x_axis", "outer", "y_axis", "inner"],
        |u, v| {
            let r = r_in + u * (r_out - r_in);
            let theta = v * std::f64::consts::FRAC_PI_2;
            [r * theta.cos(), r * theta.sin()]
        },
    )
}

/// Move every node that lies on no segment by a uniform random offset in [−a, a]²
/// (deterministic for a seed). Keep `amplitude` below about h/4 to keep triangles valid.
pub fn perturb_interior(mesh: &mut Mesh, amplitude: f64, seed: u64) {
    let mut on_boundary = vec![false; mesh.nodes.len()];
    for segment in &mesh.segments {
        for &n in &segment.nodes {
            on_boundary[n] = true;
        }
    }
    let mut rng = rng(seed);
    for (p, boundary) in mesh.nodes.iter_mut().zip(on_boundary) {
        if !boundary {
            p[0] += amplitude * (2.0 * uniform(&mut rng) - 1.0);
            p[1] += amplitude * (2.0 * uniform(&mut rng) - 1.0);
        }
    }
}

/// Rotate the whole mesh by `angle` (radians, counter-clockwise) about `center`.
pub fn rotate(mesh: &mut Mesh, angle: f64, center: [f64; 2]) {
    let (s, c) = angle.sin_cos();
    for p in &mut mesh.nodes {
        let (dx, dy) = (p[0] - center[0], p[1] - center[1]);
        *p = [center[0] + c * dx - s * dy, center[1] + s * dx + c * dy];
    }
}

/// Append a one-body, one-zone mesh as a new body `name` whose zone uses material = body index;
/// its segments are renamed `{name}_{segment}`.
fn append_body(into: &mut Mesh, part: Mesh, name: &str) {
    let (offset, body) = (into.nodes.len(), into.bodies.len());
    into.nodes.extend(part.nodes);
    into.node_body
        .extend(std::iter::repeat_n(body, part.node_body.len()));
    into.triangles
        .extend(part.triangles.iter().map(|t| t.map(|n| n + offset)));
    let zone = into.zones.len();
    into.triangle_zone
        .extend(std::iter::repeat_n(zone, part.triangle_zone.len()));
    into.zones.push(MeshZone {
        name: name.into(),
        body,
        material: body,
    });
    into.bodies.push(name.into());
    into.segments
        .extend(part.segments.into_iter().map(|s| MeshSegment {
            name: format!("{name}_{}", s.name),
            body,
            nodes: s.nodes.iter().map(|n| n + offset).collect(),
            edges: s.edges.iter().map(|e| e.map(|n| n + offset)).collect(),
        }));
}

/// Two blocks [0, width] × [0, h_lower] ("lower", material 0) and [0, width] × [h_lower,
/// h_lower + h_upper] ("upper", material 1), nx cells wide, with duplicated interface nodes and
/// the contact zone "interface" between "lower_top" (body k) and "upper_bottom" (body l).
pub fn stacked_blocks(
    width: f64,
    h_lower: f64,
    h_upper: f64,
    nx: usize,
    ny_lower: usize,
    ny_upper: usize,
) -> Mesh {
    // A rectangle's segments are "bottom", "left", "right", "top" in this order, and appending
    // "lower" before "upper" keeps all names sorted: the indices are fixed by construction.
    const BOTTOM: usize = 0;
    const TOP: usize = 3;
    let mut mesh = Mesh::default();
    let lower = rectangle(0.0, 0.0, width, h_lower, nx, ny_lower);
    let (k, l) = (TOP, lower.segments.len() + BOTTOM);
    append_body(&mut mesh, lower, "lower");
    append_body(
        &mut mesh,
        rectangle(0.0, h_lower, width, h_lower + h_upper, nx, ny_upper),
        "upper",
    );
    let (top, bottom) = (&mesh.segments[k], &mesh.segments[l]);
    let pairs: Vec<[usize; 2]> = top
        .nodes
        .iter()
        .filter_map(|&a| {
            let b = bottom
                .nodes
                .iter()
                .copied()
                .find(|&b| (mesh.nodes[b][0] - mesh.nodes[a][0]).abs() <= 1e-12 * width)?;
            Some([a, b])
        })
        .collect();
    let start = mesh.nodes[pairs[0][0]][0];
    let fraction = pairs
        .iter()
        .map(|p| (mesh.nodes[p[0]][0] - start).abs() / width)
        .collect();
    mesh.contacts.push(MeshContact {
        name: "interface".into(),
        segment_k: k,
        segment_l: l,
        pairs,
        fraction,
        mortar: None,
    });
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    fn total_area(mesh: &Mesh) -> f64 {
        (0..mesh.triangles.len())
            .map(|t| mesh.triangle_area(t))
            .sum()
    }

    #[test]
    fn rectangle_counts_orientation_and_segments() {
        let m = rectangle(0.0, 0.0, 2.0, 1.0, 4, 3);
        assert_eq!(m.nodes.len(), 20);
        assert_eq!(m.triangles.len(), 24);
        assert!((0..24).all(|t| m.triangle_area(t) > 0.0));
        assert!((total_area(&m) - 2.0).abs() < 1e-14);
        let names: Vec<&str> = m.segments.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["bottom", "left", "right", "top"]);
        // Outward normal of every bottom edge is −y.
        let bottom = &m.segments[0];
        for &[a, b] in &bottom.edges {
            assert!(m.nodes[b][0] > m.nodes[a][0]);
        }
        assert_eq!(m.segments[3].nodes.len(), 5);
    }

    #[test]
    fn annulus_area_and_perturbation_keep_validity() {
        let mut m = quarter_annulus(1.0, 2.0, 8, 16);
        let exact = std::f64::consts::PI * 3.0 / 4.0;
        assert!((total_area(&m) - exact).abs() < 0.01 * exact);
        let before = total_area(&m);
        perturb_interior(&mut m, 0.02, 7);
        assert!((0..m.triangles.len()).all(|t| m.triangle_area(t) > 0.0));
        assert!((total_area(&m) - before).abs() < 1e-12);
    }

    #[test]
    fn stacked_blocks_pair_interface_nodes() {
        let m = stacked_blocks(2.0, 1.0, 0.5, 4, 2, 3);
        assert_eq!(m.bodies, ["lower", "upper"]);
        let names: Vec<&str> = m.segments.iter().map(|s| s.name.as_str()).collect();
        let mut sorted = names.clone();
        sorted.sort_unstable();
        assert_eq!(names, sorted);
        let c = &m.contacts[0];
        assert_eq!(m.segments[c.segment_k].name, "lower_top");
        assert_eq!(m.segments[c.segment_l].name, "upper_bottom");
        assert_eq!(c.pairs.len(), 5);
        for &[a, b] in &c.pairs {
            assert_eq!(m.nodes[a], m.nodes[b]);
            assert_eq!((m.node_body[a], m.node_body[b]), (0, 1));
        }
        assert_eq!(c.fraction[0], 0.0);
        assert!((c.fraction[4] - 1.0).abs() < 1e-15);
    }
}
