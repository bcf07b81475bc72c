//! Validity check of every generated mesh before it reaches the FEM. A failure is a mesher bug
//! and is reported as one (path `mesh`), never left to surface later as a singular matrix.
//!
//! Checked: every triangle counter-clockwise with positive area; every node used; no two
//! triangles on the same side of an edge (no fold, no edge in more than two triangles); every input edge (zone boundaries, contact lines, holes)
//! covered by a chain of mesh edges; the area of every zone equal to its polygon's area (so no
//! triangle is missing, doubled or misclassified); every angle at least `min_angle` except next
//! to input angles below 60° (`SMALL_INPUT_ANGLE`); every edge no longer than the size field
//! allows at its end points (factor 1 + 1e-6).
//!
//! The connectivity part (`connectivity`, `hanging_node`) is shared with the Gmsh import,
//! which names the file's element and node tags in its errors.

use std::collections::HashSet;

use super::assemble::RawMesh;
use super::geom::{dist, orient, point_segment, P};
use super::input::{Geometry, Pslg};
use super::refine::SMALL_INPUT_ANGLE;
use super::rows::Rows;
use super::size::SizeField;
use crate::scene::SceneError;

/// Allowed excess of an edge over the size field at its end points.
pub(crate) const SIZE_FACTOR: f64 = 1.0 + 1e-6;

fn bug(what: String) -> SceneError {
    SceneError::new(
        "mesh",
        format!("mesher bug: {what}; please report it with the scene file"),
    )
}

/// Angle at `p` between the directions to `a` and `b`, degrees.
fn angle_at(p: P, a: P, b: P) -> f64 {
    let (u, v) = ([a[0] - p[0], a[1] - p[1]], [b[0] - p[0], b[1] - p[1]]);
    let cross = u[0] * v[1] - u[1] * v[0];
    let dot = u[0] * v[0] + u[1] * v[1];
    cross.abs().atan2(dot).to_degrees()
}

/// A defect of a triangle mesh's connectivity (indices of triangles and nodes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Defect {
    /// The triangle has zero area (repeated or collinear corners) or is clockwise.
    Degenerate(usize),
    /// The two triangles both have the directed edge a → b: they overlap (a fold or a
    /// duplicate), or the edge belongs to more than two triangles.
    Overlap([usize; 2], [usize; 2]),
    /// The node lies inside the boundary edge a → b of the triangle without being a corner of
    /// it: the mesh does not conform there.
    Hanging(usize, usize, [usize; 2]),
}

fn directed(triangles: &[[usize; 3]]) -> impl Iterator<Item = [usize; 2]> + '_ {
    triangles
        .iter()
        .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
}

fn with_edge(triangles: &[[usize; 3]], [a, b]: [usize; 2]) -> impl Iterator<Item = usize> + '_ {
    (0..triangles.len()).filter(move |&t| {
        let v = triangles[t];
        (0..3).any(|k| v[k] == a && v[(k + 1) % 3] == b)
    })
}

/// Checks that every triangle is counter-clockwise with a non-degenerate area (twice the area
/// above 1e-12 of its longest edge squared) and that no directed edge occurs twice; returns the
/// directed edges in sorted compressed rows (a → b stored in row a).
pub(crate) fn connectivity(nodes: &[P], triangles: &[[usize; 3]]) -> Result<Rows, Defect> {
    for (t, tri) in triangles.iter().enumerate() {
        let p = tri.map(|i| nodes[i]);
        let l2 = (0..3)
            .map(|k| {
                let d = [p[k][0] - p[(k + 1) % 3][0], p[k][1] - p[(k + 1) % 3][1]];
                d[0] * d[0] + d[1] * d[1]
            })
            .fold(0.0, f64::max);
        let area2 = orient(p[0], p[1], p[2]);
        if area2.is_nan() || area2 <= 1e-12 * l2 {
            return Err(Defect::Degenerate(t));
        }
    }
    let mut rows = Rows::new(nodes.len(), || directed(triangles));
    rows.sort_rows();
    for a in 0..nodes.len() {
        if let Some(w) = rows.row(a).windows(2).find(|w| w[0] == w[1]) {
            let mut two = with_edge(triangles, [a, w[0]]);
            let (s, t) = (two.next().unwrap_or(0), two.next().unwrap_or(0));
            return Err(Defect::Overlap([s, t], [a, w[0]]));
        }
    }
    Ok(rows)
}

/// A node lying inside a boundary edge of the counter-clockwise `triangles` (within 1e-9 of
/// the edge's length, away from its ends) without being its corner. Only nodes of these
/// triangles are considered.
pub(crate) fn hanging_node(nodes: &[P], triangles: &[[usize; 3]]) -> Option<Defect> {
    let rows = Rows::new(nodes.len(), || directed(triangles));
    let mut used = vec![false; nodes.len()];
    for &i in triangles.iter().flatten() {
        used[i] = true;
    }
    let mut by_x: Vec<(f64, usize)> = (0..nodes.len())
        .filter(|&i| used[i])
        .map(|i| (nodes[i][0], i))
        .collect();
    by_x.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    for [a, b] in directed(triangles) {
        if rows.row(b).contains(&a) {
            continue;
        }
        let (pa, pb) = (nodes[a], nodes[b]);
        let tol = 1e-9 * dist(pa, pb);
        let lo = by_x.partition_point(|&(x, _)| x < pa[0].min(pb[0]) - tol);
        let inside = by_x[lo..]
            .iter()
            .take_while(|&&(x, _)| x <= pa[0].max(pb[0]) + tol)
            .map(|&(_, i)| i)
            .find(|&i| {
                let p = nodes[i];
                point_segment(p, pa, pb).0 <= tol && dist(p, pa) > tol && dist(p, pb) > tol
            });
        if let Some(i) = inside {
            let t = with_edge(triangles, [a, b]).next().unwrap_or(0);
            return Some(Defect::Hanging(i, t, [a, b]));
        }
    }
    None
}

/// Checks a raw mesh against its input; see the module documentation.
pub(crate) fn raw_mesh(
    raw: &RawMesh,
    geo: &Geometry,
    pslg: &Pslg,
    size: &SizeField,
    min_angle: f64,
) -> Result<(), SceneError> {
    let edges = checked_connectivity(raw)?;
    check_nodes_used(raw)?;
    check_zone_areas(raw, geo)?;
    let on_input = covered_input_edges(raw, pslg, geo.tol, &edges)?;
    // Sizes and angles.
    let h: Vec<f64> = raw.nodes.iter().map(|&p| size.at(p)).collect();
    for t in 0..raw.triangles.len() {
        check_edge_sizes(raw, t, &h)?;
        check_min_angle(raw, t, pslg, &on_input, min_angle)?;
    }
    Ok(())
}

/// The directed edges of the raw mesh's triangles ([`connectivity`]), a defect reported as a
/// mesher bug.
fn checked_connectivity(raw: &RawMesh) -> Result<Rows, SceneError> {
    let nodes = &raw.nodes;
    connectivity(nodes, &raw.triangles).map_err(|d| match d {
        Defect::Degenerate(t) => bug(format!(
            "triangle {t} at {:?} is flat or inverted",
            nodes[raw.triangles[t][0]]
        )),
        Defect::Overlap(_, [a, b]) => bug(format!(
            "the edge from {:?} to {:?} has two triangles on one side",
            nodes[a], nodes[b]
        )),
        Defect::Hanging(..) => bug("a hanging node".into()),
    })
}

/// Every node is a corner of some triangle.
fn check_nodes_used(raw: &RawMesh) -> Result<(), SceneError> {
    let nodes = &raw.nodes;
    let mut used = vec![false; nodes.len()];
    for &i in raw.triangles.iter().flatten() {
        used[i] = true;
    }
    if let Some(n) = used.iter().position(|u| !u) {
        return Err(bug(format!("node {n} at {:?} is unused", nodes[n])));
    }
    Ok(())
}

/// The triangles of every zone cover exactly the zone polygon's area.
fn check_zone_areas(raw: &RawMesh, geo: &Geometry) -> Result<(), SceneError> {
    let nodes = &raw.nodes;
    let mut area = vec![0.0; geo.zones.len()];
    for (t, tri) in raw.triangles.iter().enumerate() {
        let p = tri.map(|i| nodes[i]);
        area[raw.zone[t]] += 0.5 * orient(p[0], p[1], p[2]);
    }
    for (z, g) in geo.zones.iter().enumerate() {
        let want = g.area();
        if (area[z] - want).abs() > 1e-9 * want.abs().max(geo.tol * geo.tol) {
            return Err(bug(format!(
                "the triangles of {} cover {:.12e} m² of its {:.12e} m²",
                g.path, area[z], want
            )));
        }
    }
    Ok(())
}

/// Input edges covered by mesh edges: the nodes within `tol` of each input edge must run from
/// its one end to the other along mesh `edges`. Returns the input edges each node lies on.
fn covered_input_edges(
    raw: &RawMesh,
    pslg: &Pslg,
    tol: f64,
    edges: &Rows,
) -> Result<Vec<Vec<usize>>, SceneError> {
    let nodes = &raw.nodes;
    let is_edge = |a: usize, b: usize| {
        edges.row(a).binary_search(&b).is_ok() || edges.row(b).binary_search(&a).is_ok()
    };
    let mut by_x: Vec<(f64, usize)> = nodes.iter().enumerate().map(|(i, p)| (p[0], i)).collect();
    by_x.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let mut on_input: Vec<Vec<usize>> = vec![Vec::new(); nodes.len()];
    for (k, &[a, b]) in pslg.edges.iter().enumerate() {
        let (pa, pb) = (pslg.points[a], pslg.points[b]);
        let lo = by_x.partition_point(|&(x, _)| x < pa[0].min(pb[0]) - tol);
        let mut on: Vec<(f64, usize)> = by_x[lo..]
            .iter()
            .take_while(|&&(x, _)| x <= pa[0].max(pb[0]) + tol)
            .filter_map(|&(_, i)| {
                let (d, t) = point_segment(nodes[i], pa, pb);
                (d <= tol).then_some((t, i))
            })
            .collect();
        on.sort_by(|x, y| x.0.total_cmp(&y.0));
        let ends_found = on.len() >= 2
            && dist(nodes[on[0].1], pa) <= tol
            && dist(nodes[on[on.len() - 1].1], pb) <= tol;
        let chained = on.windows(2).all(|w| is_edge(w[0].1, w[1].1));
        if !ends_found || !chained {
            return Err(bug(format!(
                "the input edge from {pa:?} to {pb:?} is not a chain of mesh edges"
            )));
        }
        for (_, i) in on {
            on_input[i].push(k);
        }
    }
    Ok(on_input)
}

/// No edge of triangle `t` is longer than the size field `h` allows at its end points.
fn check_edge_sizes(raw: &RawMesh, t: usize, h: &[f64]) -> Result<(), SceneError> {
    let tri = &raw.triangles[t];
    let p = tri.map(|i| raw.nodes[i]);
    for k in 0..3 {
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        let (q, r) = (p[k], p[(k + 1) % 3]);
        let limit = h[a].min(h[b]) * SIZE_FACTOR;
        if (q[0] - r[0]).powi(2) + (q[1] - r[1]).powi(2) > limit * limit {
            return Err(bug(format!(
                "triangle {t} at {:?} is larger than mesh.max_size or the refinement asks",
                p[0]
            )));
        }
    }
    Ok(())
}

/// Every angle of triangle `t` is at least `min_angle`, unless it is caused by a small input
/// angle ([`small_input_angle`]).
fn check_min_angle(
    raw: &RawMesh,
    t: usize,
    pslg: &Pslg,
    on_input: &[Vec<usize>],
    min_angle: f64,
) -> Result<(), SceneError> {
    let (nodes, tri) = (&raw.nodes, &raw.triangles[t]);
    let p = tri.map(|i| nodes[i]);
    // Cheap test first: every corner's cosine at most cos(min_angle).
    let cos_limit = (min_angle - 1e-6).to_radians().cos();
    let fine = (0..3).all(|k| {
        let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
        let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
        let dot = u[0] * v[0] + u[1] * v[1];
        let norms = (u[0] * u[0] + u[1] * u[1]) * (v[0] * v[0] + v[1] * v[1]);
        dot <= 0.0 || dot * dot <= cos_limit * cos_limit * norms
    });
    if fine {
        return Ok(());
    }
    let angles = [0, 1, 2].map(|k| angle_at(p[k], p[(k + 1) % 3], p[(k + 2) % 3]));
    let k = (0..3)
        .min_by(|&i, &j| angles[i].total_cmp(&angles[j]))
        .unwrap_or(0);
    if angles[k] >= min_angle - 1e-6 {
        return Ok(());
    }
    let (u, w) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
    if !small_input_angle(u, w, nodes, pslg, on_input) {
        return Err(bug(format!(
            "triangle {t} at {:?} has an angle of {:.3}° (mesh.min_angle {min_angle}°) \
             away from any small input angle",
            p[0], angles[k]
        )));
    }
    Ok(())
}

/// Whether the small angle opposite edge (u, w) of a triangle is caused by an input angle
/// below `SMALL_INPUT_ANGLE`: u and w lie on two input edges that meet at a common input vertex
/// at such an angle.
fn small_input_angle(
    u: usize,
    w: usize,
    nodes: &[P],
    pslg: &Pslg,
    on_input: &[Vec<usize>],
) -> bool {
    let apexes = |n: usize| -> HashSet<usize> {
        on_input[n]
            .iter()
            .flat_map(|&k| pslg.edges[k])
            .filter(|&v| dist(pslg.points[v], nodes[n]) > 0.0)
            .collect()
    };
    let (au, aw) = (apexes(u), apexes(w));
    au.intersection(&aw).any(|&p| {
        let pp = pslg.points[p];
        angle_at(pp, nodes[u], nodes[w]) < SMALL_INPUT_ANGLE
    })
}
