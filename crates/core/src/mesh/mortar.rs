//! Dual mortar coupling of a contact zone whose two sides are meshed on their own (design §2.4.1;
//! the PDAS paper's (15)–(25) after Wohlmuth; partially covered slave elements after Popp et al.).
//!
//! On the slave segment every node p carries a multiplier with the dual (biorthogonal) basis
//! function ψ_p: on a slave element with nodal functions φ_a, φ_b, ψ = A φ with A = D_e M_e⁻¹,
//! M_e = ∫ φ_i φ_j and D_e = diag(∫ φ_i), both over the part of the element the master covers
//! (A = [[2, −1], [−1, 2]] on a fully covered element). Then
//! - D_pp = ∫ ψ_p φ_p = ∫ φ_p (paper (23)), the nodal share of the covered contact length;
//! - M_pq = ∫ ψ_p φ^m_q (paper (22)), master traces against the slave's dual functions;
//! - d_p = ∫ ψ_p g, the weighted gap, g the distance from the slave along its normal to the master.
//!
//! The decoupled constraint (25), D_pp n_p·(u_p − Σ_q M̂_pq u_q) ≤ d_p with M̂ = D⁻¹M, is the
//! node-pair row of design §2.4 with the master node replaced by the combination M̂_p· and the gap
//! d_p / D_pp: this module returns, per slave node, M̂_p·, D_pp (the row's weight) and d_p / D_pp.
//! On matching meshes M̂ is the identity to rounding and the rows are the node-pair rows.
//!
//! Integration is segment-based: the master nodes are projected onto each slave element along the
//! slave normal field n(ξ) = (1 − ξ) n_a + ξ n_b (the averaged nodal normals), the element splits
//! at the projections, and each piece, facing one master edge, is integrated with 4 Gauss points
//! (exact on straight parallel sides; on curved polylines the projection is rational in ξ). The
//! slave and master sides are polylines: a curved boundary is its mesh's polygon.

use std::collections::BTreeMap;

use super::geom::{cross, cross_properly, dist, lerp, sub};
use super::normals::segment_node_normals;
use super::{Mesh, MeshSegment};

/// One slave node's mortar row.
#[derive(Debug, Clone, PartialEq)]
pub struct MortarRow {
    /// Master nodes q and M̂_pq = M_pq / D_pp (summing to 1 where the master covers the support).
    pub master: Vec<(usize, f64)>,
    /// D_pp = ∫ φ_p over the covered part of the slave \[m\].
    pub weight: f64,
    /// The weighted gap d_p / D_pp \[m\] (positive: open).
    pub gap: f64,
}

/// Why two segments cannot be coupled by mortar.
#[derive(Debug, Clone, PartialEq)]
pub enum MortarFault {
    /// The slave segment has fewer than two elements.
    TooFewElements(usize),
    /// No slave element faces the master segment.
    NoOverlap,
    /// The two segments cross at a point, at an angle (degrees).
    Crossing { at: [f64; 2], angle: f64 },
}

/// Gauss–Legendre on [0, 1], 4 points (exact to degree 7).
const GAUSS: [(f64, f64); 4] = [
    (0.069_431_844_202_973_71, 0.173_927_422_568_726_93),
    (0.330_009_478_207_571_9, 0.326_072_577_431_273_07),
    (0.669_990_521_792_428_1, 0.326_072_577_431_273_07),
    (0.930_568_155_797_026_3, 0.173_927_422_568_726_93),
];

/// Pieces shorter than this fraction of a slave element are dropped (a projection landing on a
/// slave node to rounding).
const PIECE: f64 = 1e-12;

/// A slave node whose covered share is below this fraction of its whole nodal share gets no row.
const COVERED: f64 = 1e-6;

/// A weighted gap below this fraction of the node's share of the slave length is rounding.
const GAP_ROUNDING: f64 = 1e-12;

/// |M̂_pq| below this is rounding (matching meshes give 1e-17).
const COEFFICIENT: f64 = 1e-13;

/// Crossings at larger angles than this are refused (chords of one curve crossing the chords of
/// another at small angles are not crossings).
const CROSSING_DEGREES: f64 = 30.0;

/// A slave element: end points, nodal normals and nodes.
struct SlaveEdge {
    nodes: [usize; 2],
    x: [[f64; 2]; 2],
    n: [[f64; 2]; 2],
    length: f64,
}

impl SlaveEdge {
    /// The parameter ξ where the line through `q` along n(ξ) meets the element (nearest to the
    /// element's middle), if any: cross(q − x(ξ), n(ξ)) = 0 is quadratic in ξ.
    fn project(&self, q: [f64; 2]) -> Option<f64> {
        let r = sub(q, self.x[0]);
        let d = sub(self.x[1], self.x[0]);
        let dn = sub(self.n[1], self.n[0]);
        let a = -cross(d, dn);
        let b = cross(r, dn) - cross(d, self.n[0]);
        let c = cross(r, self.n[0]);
        if a.abs() <= 1e-14 * b.abs() {
            return (b != 0.0).then(|| -c / b);
        }
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let s = -0.5 * (b + b.signum() * disc.sqrt());
        let roots = [s / a, if s != 0.0 { c / s } else { f64::NAN }];
        roots
            .into_iter()
            .filter(|x| x.is_finite())
            .min_by(|x, y| (x - 0.5).abs().total_cmp(&(y - 0.5).abs()))
    }

    /// Point and unit normal at ξ.
    fn at(&self, xi: f64) -> ([f64; 2], [f64; 2]) {
        let n = lerp(self.n[0], self.n[1], xi);
        let len = n[0].hypot(n[1]);
        (lerp(self.x[0], self.x[1], xi), [n[0] / len, n[1] / len])
    }
}

/// Where the ray x + s n meets the master edge's line: (s, η) with the edge at η ∈ [0, 1].
fn hit(x: [f64; 2], n: [f64; 2], edge: &[[f64; 2]; 2]) -> Option<(f64, f64)> {
    let m = sub(edge[1], edge[0]);
    let w = sub(edge[0], x);
    let det = cross(m, n);
    if det.abs() <= 1e-14 * m[0].hypot(m[1]) {
        return None;
    }
    let s = cross(m, w) / det;
    let eta = cross(n, w) / det;
    Some((s, eta))
}

/// A piece [ξ0, ξ1] of a slave element facing master edge `edge`.
struct Piece {
    xi: [f64; 2],
    edge: usize,
}

/// Mortar rows of every covered slave node, in the order of `slave.nodes`.
pub fn couple(
    mesh: &Mesh,
    slave: &MeshSegment,
    master: &MeshSegment,
) -> Result<Vec<(usize, MortarRow)>, MortarFault> {
    if slave.edges.len() < 2 {
        return Err(MortarFault::TooFewElements(slave.edges.len()));
    }
    check_crossing(mesh, slave, master)?;
    let normals: BTreeMap<usize, [f64; 2]> =
        segment_node_normals(mesh, slave).into_iter().collect();
    let master_edges: Vec<[[f64; 2]; 2]> = master
        .edges
        .iter()
        .map(|&[a, b]| [mesh.nodes[a], mesh.nodes[b]])
        .collect();
    let master_normals: Vec<[f64; 2]> = master_edges
        .iter()
        .map(|[a, b]| [b[1] - a[1], -(b[0] - a[0])])
        .collect();
    let mut weight = BTreeMap::<usize, f64>::new();
    let mut share = BTreeMap::<usize, f64>::new();
    let mut gap = BTreeMap::<usize, f64>::new();
    let mut coupling = BTreeMap::<usize, BTreeMap<usize, f64>>::new();
    for &[a, b] in &slave.edges {
        let (xa, xb) = (mesh.nodes[a], mesh.nodes[b]);
        let edge = SlaveEdge {
            nodes: [a, b],
            x: [xa, xb],
            n: [normals[&a], normals[&b]],
            length: dist(xa, xb),
        };
        for node in edge.nodes {
            *share.entry(node).or_default() += 0.5 * edge.length;
        }
        let pieces = pieces(&edge, &master_edges, &master_normals);
        integrate(
            &edge,
            &pieces,
            &master_edges,
            master,
            [&mut weight, &mut gap],
            &mut coupling,
        );
    }
    let rows: Vec<(usize, MortarRow)> = slave
        .nodes
        .iter()
        .filter_map(|&p| {
            let d = *weight.get(&p)?;
            if d.partial_cmp(&(COVERED * share[&p])) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            let master = coupling[&p]
                .iter()
                .map(|(&q, &m)| (q, m / d))
                .filter(|&(_, c)| c.abs() > COEFFICIENT)
                .collect();
            // A gap at the rounding level of the coordinates is a closed one (matching sides).
            let gap = Some(gap[&p] / d).filter(|g| g.abs() > GAP_ROUNDING * share[&p]);
            Some((
                p,
                MortarRow {
                    master,
                    weight: d,
                    gap: gap.unwrap_or(0.0),
                },
            ))
        })
        .collect();
    if rows.is_empty() {
        return Err(MortarFault::NoOverlap);
    }
    Ok(rows)
}

/// The element split at the projections of the master nodes, each piece with the master edge
/// its middle faces (the nearest along the normal among the edges whose outward normals oppose
/// the slave's); uncovered pieces are left out.
fn pieces(edge: &SlaveEdge, master: &[[[f64; 2]; 2]], master_normals: &[[f64; 2]]) -> Vec<Piece> {
    let mut cuts = vec![0.0, 1.0];
    for e in master {
        for q in e {
            if let Some(xi) = edge.project(*q) {
                if xi > 0.0 && xi < 1.0 {
                    cuts.push(xi);
                }
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|x, y| (*x - *y).abs() < PIECE);
    let mut out = Vec::new();
    for w in cuts.windows(2) {
        if w[1] - w[0] < PIECE {
            continue;
        }
        let (x, n) = edge.at(0.5 * (w[0] + w[1]));
        let facing = master
            .iter()
            .zip(master_normals)
            .enumerate()
            .filter(|(_, (_, mn))| mn[0] * n[0] + mn[1] * n[1] < 0.0)
            .filter_map(|(i, (e, _))| {
                let (s, eta) = hit(x, n, e)?;
                (-1e-9..=1.0 + 1e-9).contains(&eta).then_some((i, s))
            })
            .min_by(|p, q| p.1.abs().total_cmp(&q.1.abs()));
        if let Some((i, _)) = facing {
            out.push(Piece {
                xi: [w[0], w[1]],
                edge: i,
            });
        }
    }
    out
}

/// Accumulates D_pp, d_p and M_pq of the element's two nodes from its covered pieces.
fn integrate(
    edge: &SlaveEdge,
    pieces: &[Piece],
    master_edges: &[[[f64; 2]; 2]],
    master: &MeshSegment,
    [weight, gap]: [&mut BTreeMap<usize, f64>; 2],
    coupling: &mut BTreeMap<usize, BTreeMap<usize, f64>>,
) {
    if pieces.is_empty() {
        return;
    }
    // Quadrature points: (ξ, weight · length, master edge, η, gap).
    let mut points = Vec::with_capacity(4 * pieces.len());
    for piece in pieces {
        let span = piece.xi[1] - piece.xi[0];
        for (g, w) in GAUSS {
            let xi = piece.xi[0] + g * span;
            let (x, n) = edge.at(xi);
            let (s, eta) = hit(x, n, &master_edges[piece.edge]).unwrap_or((0.0, 0.5));
            points.push((
                xi,
                w * span * edge.length,
                piece.edge,
                eta.clamp(0.0, 1.0),
                s,
            ));
        }
    }
    let mut mass = [[0.0; 2]; 2];
    let mut lumped = [0.0; 2];
    for &(xi, dw, ..) in &points {
        let phi = [1.0 - xi, xi];
        for i in 0..2 {
            lumped[i] += phi[i] * dw;
            for j in 0..2 {
                mass[i][j] += phi[i] * phi[j] * dw;
            }
        }
    }
    // A = D_e M_e⁻¹, so that ψ_i = Σ_j A_ij φ_j is biorthogonal to φ on the covered part.
    let det = mass[0][0] * mass[1][1] - mass[0][1] * mass[1][0];
    let inverse = [
        [mass[1][1] / det, -mass[0][1] / det],
        [-mass[1][0] / det, mass[0][0] / det],
    ];
    let dual = [
        [lumped[0] * inverse[0][0], lumped[0] * inverse[0][1]],
        [lumped[1] * inverse[1][0], lumped[1] * inverse[1][1]],
    ];
    for (node, share) in edge.nodes.into_iter().zip(lumped) {
        *weight.entry(node).or_default() += share;
    }
    for &(xi, dw, e, eta, s) in &points {
        let phi = [1.0 - xi, xi];
        let [qa, qb] = master.edges[e];
        for (node, a) in edge.nodes.into_iter().zip(dual) {
            let psi = a[0] * phi[0] + a[1] * phi[1];
            *gap.entry(node).or_default() += psi * s * dw;
            let row = coupling.entry(node).or_default();
            *row.entry(qa).or_default() += psi * (1.0 - eta) * dw;
            *row.entry(qb).or_default() += psi * eta * dw;
        }
    }
}

/// Refuses two segments that cross each other at a real angle.
fn check_crossing(
    mesh: &Mesh,
    slave: &MeshSegment,
    master: &MeshSegment,
) -> Result<(), MortarFault> {
    let limit = CROSSING_DEGREES.to_radians().sin();
    for &[a, b] in &slave.edges {
        let (p, q) = (mesh.nodes[a], mesh.nodes[b]);
        for &[c, e] in &master.edges {
            let (r, s) = (mesh.nodes[c], mesh.nodes[e]);
            let (d, m) = (sub(q, p), sub(s, r));
            let sine = cross(d, m) / (dist(p, q) * dist(r, s));
            let tol = 1e-9 * dist(p, q).max(dist(r, s));
            if sine.abs() >= limit && cross_properly(p, q, r, s, tol) {
                let t = cross(m, sub(r, p)) / cross(m, d);
                return Err(MortarFault::Crossing {
                    at: lerp(p, q, t),
                    angle: sine.abs().asin().to_degrees(),
                });
            }
        }
    }
    Ok(())
}
