//! Displacement DOF map with constraints (design §2.1 Γu and Γo): two DOFs per node in a per-node
//! local basis, u_global = R u_local with R = [e0 e1].
//!
//! Constraints u·a = value come from prescribed displacement components (a = e_x or e_y) and from
//! rollers u·d = 0 (d given, or the averaged outward normal of the segment at the node). Per node:
//! no constraint → both local DOFs free, R = I; one independent direction a → R = [a, a⊥], local
//! DOF 0 fixed; two independent directions → R = I, both DOFs fixed with u from the 2×2 system.
//! Further (dependent) constraints must agree with these, checked whenever values are computed.
//! Which DOFs are constrained is topology (fixed per mesh and scene); the prescribed values are
//! data and are re-read by [`DofMap::fixed_values`].

use crate::mesh::geom::{cross, dot};
use crate::mesh::Mesh;
use crate::scene::{BoundaryData, BoundaryValue};

use super::geometry::segment_node_normals;
use super::operator::Slot;
use super::{boundary_segment, expect_len, FemError};

/// sin of the smallest angle between two constraint directions still treated as independent.
const INDEPENDENT: f64 = 1e-6;

/// Where the value of a constraint u·a = value comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    /// Roller: value 0.
    Zero,
    /// Component `comp` of the `Displacement` boundary condition `bc`.
    Component { bc: usize, comp: usize },
}

/// One constraint u·dir = value at a node.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Constraint {
    dir: [f64; 2],
    source: Source,
}

/// A constrained node: the 1 or 2 independent constraints defining its fixed DOFs, and the
/// dependent ones that must agree.
#[derive(Debug, Clone)]
struct ConstrainedNode {
    node: usize,
    basis: Vec<Constraint>,
    extra: Vec<Constraint>,
}

/// The DOF map of the displacement field.
#[derive(Debug, Clone)]
pub struct DofMap {
    /// Local basis per node: [e0, e1] in global components.
    basis: Vec<[[f64; 2]; 2]>,
    slots: Vec<[Slot; 2]>,
    n_free: usize,
    n_fixed: usize,
    constrained: Vec<ConstrainedNode>,
}

impl DofMap {
    /// Build the map from the displacement and roller conditions of `boundary`.
    pub fn new(mesh: &Mesh, boundary: &[BoundaryData]) -> Result<DofMap, FemError> {
        let per_node = collect_constraints(mesh, boundary)?;
        let mut map = DofMap {
            basis: vec![[[1.0, 0.0], [0.0, 1.0]]; mesh.nodes.len()],
            slots: Vec::with_capacity(mesh.nodes.len()),
            n_free: 0,
            n_fixed: 0,
            constrained: Vec::new(),
        };
        for (node, constraints) in per_node.into_iter().enumerate() {
            let (basis, extra) = split_independent(constraints);
            let fixed_count = basis.len();
            if let [c] = basis.as_slice() {
                let a = c.dir;
                map.basis[node] = [a, [-a[1], a[0]]];
            }
            let mut slot = |fixed: bool| {
                let counter = if fixed {
                    &mut map.n_fixed
                } else {
                    &mut map.n_free
                };
                *counter += 1;
                if fixed {
                    Slot::Fixed(*counter - 1)
                } else {
                    Slot::Free(*counter - 1)
                }
            };
            let s0 = slot(fixed_count >= 1);
            let s1 = slot(fixed_count >= 2);
            map.slots.push([s0, s1]);
            if fixed_count > 0 {
                map.constrained.push(ConstrainedNode { node, basis, extra });
            }
        }
        Ok(map)
    }

    /// Number of free DOFs (size of the reduced system).
    pub fn n_free(&self) -> usize {
        self.n_free
    }

    /// Number of prescribed local DOFs.
    pub fn n_fixed(&self) -> usize {
        self.n_fixed
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.slots.len()
    }

    /// Slots of the two local DOFs of `node`.
    pub fn slots(&self, node: usize) -> [Slot; 2] {
        self.slots[node]
    }

    /// Local basis [e0, e1] of `node` (global components); u_global = u0 e0 + u1 e1.
    pub fn basis(&self, node: usize) -> [[f64; 2]; 2] {
        self.basis[node]
    }

    /// Whether any DOF of `node` is prescribed.
    pub fn is_constrained(&self, node: usize) -> bool {
        matches!(self.slots[node][0], Slot::Fixed(_))
    }

    /// Local components (e0·v, e1·v) of a global vector v at `node`.
    pub fn to_local(&self, node: usize, v: [f64; 2]) -> [f64; 2] {
        let [e0, e1] = self.basis[node];
        [dot(e0, v), dot(e1, v)]
    }

    /// Split a global nodal vector field (e.g. loads) into its free and fixed local parts (Rᵀ f).
    pub fn restrict(&self, field: &[[f64; 2]]) -> (Vec<f64>, Vec<f64>) {
        let mut free = vec![0.0; self.n_free];
        let mut fixed = vec![0.0; self.n_fixed];
        for (node, &v) in field.iter().enumerate() {
            let local = self.to_local(node, v);
            for (slot, value) in self.slots[node].into_iter().zip(local) {
                match slot {
                    Slot::Free(i) => free[i] = value,
                    Slot::Fixed(i) => fixed[i] = value,
                }
            }
        }
        (free, fixed)
    }

    /// The global nodal field u = R u_local from free and fixed local values.
    pub fn expand(&self, free: &[f64], fixed: &[f64]) -> Vec<[f64; 2]> {
        (0..self.n_nodes())
            .map(|node| {
                let [e0, e1] = self.basis[node];
                let [u0, u1] = self.slots[node].map(|s| match s {
                    Slot::Free(i) => free[i],
                    Slot::Fixed(i) => fixed[i],
                });
                [u0 * e0[0] + u1 * e1[0], u0 * e0[1] + u1 * e1[1]]
            })
            .collect()
    }

    /// Prescribed local values u_d read from the data (rollers give 0); errors when the data no
    /// longer match the topology or dependent constraints disagree.
    pub fn fixed_values(
        &self,
        mesh: &Mesh,
        boundary: &[BoundaryData],
    ) -> Result<Vec<f64>, FemError> {
        let mut fixed = vec![0.0; self.n_fixed];
        for c in &self.constrained {
            let u = node_displacement(c, boundary)?;
            check_dependent(mesh, c, u, boundary)?;
            self.store_fixed(c.node, u, &mut fixed);
        }
        Ok(fixed)
    }

    /// Prescribed local values taken from a global nodal field (e.g. an exact solution).
    pub fn fixed_values_from(&self, field: &[[f64; 2]]) -> Result<Vec<f64>, FemError> {
        expect_len("nodal displacements", field.len(), self.n_nodes())?;
        let mut fixed = vec![0.0; self.n_fixed];
        for c in &self.constrained {
            self.store_fixed(c.node, field[c.node], &mut fixed);
        }
        Ok(fixed)
    }

    fn store_fixed(&self, node: usize, u: [f64; 2], fixed: &mut [f64]) {
        let local = self.to_local(node, u);
        for (slot, value) in self.slots[node].into_iter().zip(local) {
            if let Slot::Fixed(i) = slot {
                fixed[i] = value;
            }
        }
    }

    /// How the prescribed displacement of `node` (global components) depends on the values of
    /// the displacement components that constrain it: `((bc, comp), ∂u/∂value)` per source, with
    /// `bc` the boundary condition and `comp` the component (the same 2×2 solve as
    /// [`DofMap::fixed_values`]). Empty for an unconstrained node; rollers add nothing (their
    /// value is 0).
    pub fn prescribed_sources(&self, node: usize) -> Vec<((usize, usize), [f64; 2])> {
        let Some(c) = self.constrained.iter().find(|c| c.node == node) else {
            return Vec::new();
        };
        let derivatives: Vec<[f64; 2]> = match c.basis.as_slice() {
            [a] => vec![a.dir],
            [a, b] => {
                let det = cross(a.dir, b.dir);
                vec![
                    [b.dir[1] / det, -b.dir[0] / det],
                    [-a.dir[1] / det, a.dir[0] / det],
                ]
            }
            _ => Vec::new(),
        };
        c.basis
            .iter()
            .zip(derivatives)
            .filter_map(|(k, du)| match k.source {
                Source::Component { bc, comp } => Some(((bc, comp), du)),
                Source::Zero => None,
            })
            .collect()
    }

    /// Constraint directions at `node` (global components), for rigid-motion checks.
    pub fn constraint_directions(&self, node: usize) -> Vec<[f64; 2]> {
        let [e0, e1] = self.basis[node];
        self.slots[node]
            .iter()
            .zip([e0, e1])
            .filter(|(s, _)| matches!(s, Slot::Fixed(_)))
            .map(|(_, e)| e)
            .collect()
    }
}

/// All constraints of every node, in boundary-condition order.
fn collect_constraints(
    mesh: &Mesh,
    boundary: &[BoundaryData],
) -> Result<Vec<Vec<Constraint>>, FemError> {
    let mut per_node = vec![Vec::new(); mesh.nodes.len()];
    for (bc, data) in boundary.iter().enumerate() {
        let segment = boundary_segment(mesh, bc, data.segment)?;
        match data.value {
            BoundaryValue::Displacement(components) => {
                for (comp, value) in components.iter().enumerate() {
                    if value.is_none() {
                        continue;
                    }
                    let mut dir = [0.0; 2];
                    dir[comp] = 1.0;
                    for &node in &segment.nodes {
                        per_node[node].push(Constraint {
                            dir,
                            source: Source::Component { bc, comp },
                        });
                    }
                }
            }
            BoundaryValue::Roller(Some(d)) => {
                let len = d[0].hypot(d[1]);
                if !(len.is_finite() && len > 0.0) {
                    return Err(FemError::InvalidBoundary {
                        index: bc,
                        reason: format!("roller direction {d:?} has no length"),
                    });
                }
                for &node in &segment.nodes {
                    per_node[node].push(Constraint {
                        dir: [d[0] / len, d[1] / len],
                        source: Source::Zero,
                    });
                }
            }
            BoundaryValue::Roller(None) => {
                let normals = segment_node_normals(mesh, segment);
                if normals.len() != segment.nodes.len() {
                    return Err(FemError::InvalidBoundary {
                        index: bc,
                        reason: format!(
                            "segment '{}' has nodes without a boundary normal",
                            segment.name
                        ),
                    });
                }
                for (node, dir) in normals {
                    per_node[node].push(Constraint {
                        dir,
                        source: Source::Zero,
                    });
                }
            }
            _ => {}
        }
    }
    Ok(per_node)
}

/// Split constraints into at most two independent ones (first come first) and the dependent rest.
fn split_independent(constraints: Vec<Constraint>) -> (Vec<Constraint>, Vec<Constraint>) {
    let mut basis: Vec<Constraint> = Vec::new();
    let mut extra = Vec::new();
    for c in constraints {
        let independent = match basis.as_slice() {
            [] => true,
            [b] => cross(b.dir, c.dir).abs() > INDEPENDENT,
            _ => false,
        };
        if independent {
            basis.push(c);
        } else {
            extra.push(c);
        }
    }
    (basis, extra)
}

/// Value of a constraint from the data.
fn constraint_value(c: &Constraint, boundary: &[BoundaryData]) -> Result<f64, FemError> {
    match c.source {
        Source::Zero => Ok(0.0),
        Source::Component { bc, comp } => match boundary.get(bc).map(|b| &b.value) {
            Some(BoundaryValue::Displacement(v)) => {
                v[comp].ok_or_else(|| FemError::InvalidBoundary {
                    index: bc,
                    reason: format!("displacement component {comp} was prescribed when the problem was built but is missing now"),
                })
            }
            _ => Err(FemError::InvalidBoundary {
                index: bc,
                reason: "no longer a displacement condition (the problem was built with one)".into(),
            }),
        },
    }
}

/// Global displacement of a constrained node implied by its independent constraints (for one
/// constraint, the component along a; the other component is a free unknown and reads 0).
fn node_displacement(c: &ConstrainedNode, boundary: &[BoundaryData]) -> Result<[f64; 2], FemError> {
    match c.basis.as_slice() {
        [a] => {
            let v = constraint_value(a, boundary)?;
            Ok([v * a.dir[0], v * a.dir[1]])
        }
        [a, b] => {
            let (va, vb) = (
                constraint_value(a, boundary)?,
                constraint_value(b, boundary)?,
            );
            let det = cross(a.dir, b.dir);
            Ok([
                (va * b.dir[1] - vb * a.dir[1]) / det,
                (a.dir[0] * vb - b.dir[0] * va) / det,
            ])
        }
        _ => Ok([0.0; 2]),
    }
}

/// Dependent constraints must agree with the node displacement along their direction.
fn check_dependent(
    mesh: &Mesh,
    c: &ConstrainedNode,
    u: [f64; 2],
    boundary: &[BoundaryData],
) -> Result<(), FemError> {
    let mut values = Vec::with_capacity(c.basis.len() + c.extra.len());
    for k in c.basis.iter().chain(&c.extra) {
        values.push(constraint_value(k, boundary)?);
    }
    let scale = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (k, &v) in c.extra.iter().zip(&values[c.basis.len()..]) {
        if (dot(k.dir, u) - v).abs() > 1e-9 * scale {
            let p = mesh.nodes[c.node];
            return Err(FemError::ConflictingConstraints {
                node: c.node,
                x: p[0],
                y: p[1],
                reason: format!(
                    "u·({:.6}, {:.6}) must be {v} but the other conditions give {}",
                    k.dir[0],
                    k.dir[1],
                    dot(k.dir, u)
                ),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::rectangle;

    fn condition(mesh: &Mesh, name: &str, value: BoundaryValue) -> BoundaryData {
        BoundaryData {
            segment: mesh.segment_index(name).unwrap(),
            value,
        }
    }

    #[test]
    fn oblique_roller_rotates_and_two_constraints_fix_the_node() {
        let mesh = rectangle(0.0, 0.0, 1.0, 1.0, 2, 2);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let boundary = vec![
            condition(&mesh, "left", BoundaryValue::Roller(Some([1.0, 1.0]))),
            condition(
                &mesh,
                "bottom",
                BoundaryValue::Displacement([None, Some(0.3)]),
            ),
        ];
        let map = DofMap::new(&mesh, &boundary).unwrap();
        // Node (0, 0.5) on the left side only: local axis 0 along (1, 1)/√2, fixed.
        let left_middle = 3;
        assert_eq!(mesh.nodes[left_middle], [0.0, 0.5]);
        let [e0, e1] = map.basis(left_middle);
        assert!((e0[0] - s).abs() < 1e-15 && (e0[1] - s).abs() < 1e-15);
        assert!((e1[0] + s).abs() < 1e-15 && (e1[1] - s).abs() < 1e-15);
        assert!(matches!(
            map.slots(left_middle),
            [Slot::Fixed(_), Slot::Free(_)]
        ));
        // Corner (0, 0): u·(1,1)/√2 = 0 and u_y = 0.3 → u = (−0.3, 0.3).
        let fixed = map.fixed_values(&mesh, &boundary).unwrap();
        let u = map.expand(&vec![0.0; map.n_free()], &fixed);
        assert!((u[0][0] + 0.3).abs() < 1e-15 && (u[0][1] - 0.3).abs() < 1e-15);
        assert_eq!(map.n_fixed() + map.n_free(), 2 * mesh.nodes.len());
        // Restrict is Rᵀ: a load along e1 at the left middle node lands on its free DOF.
        let mut load = vec![[0.0; 2]; mesh.nodes.len()];
        load[left_middle] = [-s, s];
        let (free, _) = map.restrict(&load);
        let Slot::Free(i) = map.slots(left_middle)[1] else {
            unreachable!()
        };
        assert!((free[i] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn dependent_constraints_must_agree() {
        let mesh = rectangle(0.0, 0.0, 1.0, 1.0, 2, 2);
        let with = |v: f64| {
            vec![
                condition(
                    &mesh,
                    "bottom",
                    BoundaryValue::Displacement([None, Some(v)]),
                ),
                condition(&mesh, "left", BoundaryValue::Roller(Some([0.0, -2.0]))),
            ]
        };
        let map = DofMap::new(&mesh, &with(0.0)).unwrap();
        assert!(map.fixed_values(&mesh, &with(0.0)).is_ok());
        let err = map.fixed_values(&mesh, &with(1e-3)).unwrap_err();
        assert!(
            matches!(err, FemError::ConflictingConstraints { node: 0, .. }),
            "{err}"
        );
        let zero = vec![condition(
            &mesh,
            "left",
            BoundaryValue::Roller(Some([0.0, 0.0])),
        )];
        assert!(DofMap::new(&mesh, &zero).is_err());
    }
}
