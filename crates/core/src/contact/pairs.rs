//! Discrete contact geometry (design §2.4, D05 §3): for every node pair m of every contact zone,
//! the normal n_m (outward of body k, averaged at kinks), the tangent t_m = (−n_y, n_x), the
//! nodal share w_m of the contact length (friction lumped at nodes: j_h(v) = Σ g(s_m) w_m
//! |t_m·(v^k_m − v^l_m)|), the initial gap g0_m, and the rows of the contact operator B on the
//! reduced (free, rotated) DOFs: (B u)_{2m} = n_m·(u^k_m − u^l_m), (B u)_{2m+1} = t_m·(u^k_m − u^l_m).
//! On a mortar zone (design §2.4.1) k is the slave side, u^l_m the master combination
//! Σ_q M̂_mq u_q, w_m the mortar weight D_mm and g0_m the weighted gap d_m / D_mm (plus any
//! `initial_gap`): the decoupled dual mortar constraint (PDAS paper (25)) divided by D_mm.
//! That layout of rows (and multipliers) is read through `normal_row`, `tangential_row`,
//! `pair_of_row`, `is_normal_row` and `is_tangential_row`.
//! On a Coulomb zone the nodal friction bound is F λ_n,m instead of g(s_m) w_m (design §3.4).

use std::collections::HashMap;

use crate::fem::{DofMap, Slot};
use crate::mesh::Mesh;
use crate::scene::{piecewise_linear, ContactKind, Data, InitialGap, Scene};

/// One contact node pair.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactPair {
    /// Contact zone index (scene order).
    pub zone: usize,
    /// Node of body k and node of body l (same position); with mortar the slave node and the
    /// master node of its largest coefficient.
    pub nodes: [usize; 2],
    /// Body l's side of the row: nodes and coefficients (`[(l, 1.0)]` for a node pair, the
    /// mortar combination Σ_q M̂_mq u_q otherwise).
    pub master: Vec<(usize, f64)>,
    /// Unit normal, outward of body k.
    pub normal: [f64; 2],
    /// Unit tangent (−n_y, n_x).
    pub tangent: [f64; 2],
    /// Nodal share of the contact length \[m\].
    pub weight: f64,
    /// Arc-length fraction along the zone (for g(s)).
    pub fraction: f64,
    /// Tied normal, frictionless.
    pub bilateral: bool,
    /// Initial normal gap g0 ≥ 0 \[m\].
    pub gap: f64,
}

impl ContactPair {
    /// The nodes of the pair's rows and their signs: (node of body k, 1) and (q, −c_q) for the
    /// master side, so that the jump is Σ sign · u_node.
    pub fn terms(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        std::iter::once((self.nodes[0], 1.0)).chain(self.master.iter().map(|&(q, c)| (q, -c)))
    }

    /// The displacement jump u^k − Σ_q c_q u_q of nodal displacements `u`.
    pub fn jump(&self, u: &[[f64; 2]]) -> [f64; 2] {
        self.terms().fold([0.0; 2], |j, (node, sign)| {
            [j[0] + sign * u[node][0], j[1] + sign * u[node][1]]
        })
    }
}

/// A row of B: coefficients on free DOFs and on prescribed DOFs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactRow {
    pub free: Vec<(usize, f64)>,
    pub fixed: Vec<(usize, f64)>,
}

impl ContactRow {
    /// B_row · x for a free-DOF vector.
    pub fn dot(&self, x: &[f64]) -> f64 {
        self.free.iter().map(|&(i, c)| c * x[i]).sum()
    }

    /// The contribution of prescribed values.
    pub fn dot_fixed(&self, fixed: &[f64]) -> f64 {
        self.fixed.iter().map(|&(i, c)| c * fixed[i]).sum()
    }
}

/// The row of B (and the multiplier) of pair m's normal constraint: 2m.
pub(crate) fn normal_row(m: usize) -> usize {
    2 * m
}

/// The row of B (and the multiplier) of pair m's tangential constraint: 2m + 1.
pub(crate) fn tangential_row(m: usize) -> usize {
    2 * m + 1
}

/// The pair of row r of B: r / 2.
pub(crate) fn pair_of_row(r: usize) -> usize {
    r / 2
}

/// Whether row r of B is a normal row (even r).
pub(crate) fn is_normal_row(r: usize) -> bool {
    r.is_multiple_of(2)
}

/// Whether row r of B is a tangential row (odd r).
pub(crate) fn is_tangential_row(r: usize) -> bool {
    r % 2 == 1
}

/// All contact pairs of a scene and their B rows.
#[derive(Debug, Clone, Default)]
pub struct ContactGeometry {
    pub pairs: Vec<ContactPair>,
    /// 2 rows per pair: normal, tangential ([`normal_row`], [`tangential_row`]).
    pub rows: Vec<ContactRow>,
}

impl ContactGeometry {
    /// Pairs in zone order, each zone along body k's segment.
    pub fn new(scene: &Scene, mesh: &Mesh, dofs: &DofMap) -> ContactGeometry {
        let mut pairs = Vec::new();
        for (z, zone) in mesh.contacts.iter().enumerate() {
            let contact = &scene.contacts[z];
            let segment = &mesh.segments[zone.segment_k];
            let normals: HashMap<usize, [f64; 2]> = crate::fem::segment_node_normals(mesh, segment)
                .into_iter()
                .collect();
            let mut weights = HashMap::<usize, f64>::new();
            for &[a, b] in &segment.edges {
                let (pa, pb) = (mesh.nodes[a], mesh.nodes[b]);
                let half = 0.5 * (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
                *weights.entry(a).or_insert(0.0) += half;
                *weights.entry(b).or_insert(0.0) += half;
            }
            for (m, (&[k, l], &fraction)) in zone.pairs.iter().zip(&zone.fraction).enumerate() {
                let normal = normals.get(&k).copied().unwrap_or([0.0, 0.0]);
                let position = mesh.nodes[k];
                let given = initial_gap(contact.initial_gap.as_ref(), position, fraction);
                let (master, weight, gap) = match &zone.mortar {
                    None => (
                        vec![(l, 1.0)],
                        weights.get(&k).copied().unwrap_or(0.0),
                        given,
                    ),
                    Some(rows) => (rows[m].master.clone(), rows[m].weight, rows[m].gap + given),
                };
                pairs.push(ContactPair {
                    zone: z,
                    nodes: [k, l],
                    master,
                    normal,
                    tangent: [-normal[1], normal[0]],
                    weight,
                    fraction,
                    bilateral: contact.kind == ContactKind::Bilateral,
                    gap,
                });
            }
        }
        let rows = pairs
            .iter()
            .flat_map(|p| [row(dofs, p, p.normal), row(dofs, p, p.tangent)])
            .collect();
        ContactGeometry { pairs, rows }
    }

    /// Number of multipliers (2 per pair).
    pub fn dim(&self) -> usize {
        self.rows.len()
    }

    /// Box bounds of the multipliers for the data: normal [0, ∞) (bilateral: free), tangential
    /// [−g w, g w] (bilateral: 0). On a Coulomb zone the tangential bound F λ_n depends on the
    /// state: with the multipliers `state` of one it is F max(λ_n, 0); without, unbounded (the
    /// bonded tangential problem, which relaxes every friction bound).
    pub fn bounds(&self, data: &Data, state: Option<&[f64]>) -> (Vec<f64>, Vec<f64>) {
        let mut lower = Vec::with_capacity(self.dim());
        let mut upper = Vec::with_capacity(self.dim());
        for (m, p) in self.pairs.iter().enumerate() {
            if p.bilateral {
                lower.extend([f64::NEG_INFINITY, 0.0]);
                upper.extend([f64::INFINITY, 0.0]);
                continue;
            }
            let bound = match (data.friction.get(p.zone).copied().flatten(), state) {
                (Some(f), Some(lambda)) => f * lambda[normal_row(m)].max(0.0),
                (Some(_), None) => f64::INFINITY,
                (None, _) => {
                    let slip = &data.slip[p.zone];
                    piecewise_linear(&slip.knots, &slip.values, p.fraction).max(0.0) * p.weight
                }
            };
            lower.extend([0.0, -bound]);
            upper.extend([f64::INFINITY, bound]);
        }
        (lower, upper)
    }

    /// B x for a free-DOF vector.
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        self.rows.iter().map(|r| r.dot(x)).collect()
    }

    /// y += Bᵀ λ on the free DOFs.
    pub fn add_transpose(&self, lambda: &[f64], y: &mut [f64]) {
        for (r, &l) in self.rows.iter().zip(lambda) {
            for &(i, c) in &r.free {
                y[i] += c * l;
            }
        }
    }
}

/// The row v·(u^k − Σ_q c_q u_q) in local DOFs (u_global = e0 u0 + e1 u1 per node), the sum
/// over the pair's master side.
fn row(dofs: &DofMap, pair: &ContactPair, v: [f64; 2]) -> ContactRow {
    let mut out = ContactRow::default();
    for (node, sign) in pair.terms() {
        let basis = dofs.basis(node);
        for (c, slot) in dofs.slots(node).into_iter().enumerate() {
            let coef = sign * (v[0] * basis[c][0] + v[1] * basis[c][1]);
            if coef == 0.0 {
                continue;
            }
            match slot {
                Slot::Free(i) => out.free.push((i, coef)),
                Slot::Fixed(i) => out.fixed.push((i, coef)),
            }
        }
    }
    out
}

fn initial_gap(gap: Option<&InitialGap>, position: [f64; 2], fraction: f64) -> f64 {
    match gap {
        None => 0.0,
        Some(InitialGap::Parabola { radius, touch_at }) => {
            let d2 = (position[0] - touch_at[0]).powi(2) + (position[1] - touch_at[1]).powi(2);
            d2 / (2.0 * radius)
        }
        Some(InitialGap::PiecewiseLinear { knots, values }) => {
            piecewise_linear(knots, values, fraction)
        }
    }
}
