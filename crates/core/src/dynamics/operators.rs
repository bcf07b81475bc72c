//! The operators of the semi-discrete equation of motion (design §3.5; PDAS paper (3), (8)–(10)):
//! M ü + C u̇ + K0 u = b(t) on the free DOFs, with
//!
//! - M = M_ρ, the consistent P1 mass, ∫ ρ φ_a φ_b = ρ |e|/12 (1 + δ_ab) per element,
//! - C = C_α + K1: the absorbing-layer damping ∫ α φ_a φ_b (α constant per element, from its
//!   centroid) and the Kelvin–Voigt viscous stiffness K1 = Σ_z τ_v,z K0_z (c⁽¹⁾ = τ_v c⁽⁰⁾),
//! - K0, the elastic operator of [`crate::fem::ElasticProblem`] (the same DOF map: rotated nodal
//!   bases, rollers, prescribed components),
//!
//! all stored as values on the one lower-triangular pattern of K0, so that any combination
//! A = M + a C + c K0 is a sum of value arrays, factorised on K0's symbolic analysis. Prescribed
//! components are constant in time, so their mass and damping couplings never act; K0's
//! coupling K_fd u_d enters b.

use crate::fem::{ElasticCoefficients, ElasticProblem, Factor, FemError, Par, Slot};
use crate::mesh::geom::point_segment;
use crate::mesh::Mesh;
use crate::scene::{Data, Scene};

/// M, C and K0 on K0's pattern, with K_fd u_d.
#[derive(Debug, Clone)]
pub struct Operators {
    /// Values of M (lower triangle, K0's pattern).
    pub mass: Vec<f64>,
    /// Values of C = C_α + K1.
    pub damping: Vec<f64>,
    /// Values of C_α alone (the absorbing layers' share of C, for the energy budget).
    pub absorbing: Vec<f64>,
    /// Values of K0.
    pub stiffness: Vec<f64>,
    /// K_fd u_d: the prescribed displacements' share of K0 u on the free DOFs.
    pub prescribed_force: Vec<f64>,
}

impl Operators {
    /// Assemble M, C and K0 for the data's densities, retardation times, absorbing-layer
    /// dampings and elastic constants (the layers' geometry from the scene).
    pub fn new(
        elastic: &ElasticProblem,
        scene: &Scene,
        data: &Data,
    ) -> Result<Operators, FemError> {
        let mesh = elastic.mesh();
        let operator = elastic.operator();
        let coefficients = elastic.coefficients(data)?;
        let stiffness = operator.assemble(&coefficients)?;
        let zone_value = |values: &[f64]| -> Vec<f64> {
            mesh.zones
                .iter()
                .map(|z| values.get(z.material).copied().unwrap_or(0.0))
                .collect()
        };
        let density = zone_value(&data.dynamic.density);
        let retardation = zone_value(&data.dynamic.viscosity);
        let viscous: Vec<ElasticCoefficients> = coefficients
            .iter()
            .zip(&retardation)
            .map(|(c, tau)| c.map(|v| tau * v))
            .collect();
        let mut damping = operator.assemble(&viscous)?;
        let mut mass = vec![0.0; stiffness.len()];
        let mut absorbing = vec![0.0; stiffness.len()];
        let alpha = element_damping(scene, data, mesh);
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let area = mesh.triangle_area(t);
            let rho = density[mesh.triangle_zone[t]];
            add_weighted_mass(elastic, &mut mass, *tri, rho * area)?;
            if alpha[t] > 0.0 {
                add_weighted_mass(elastic, &mut damping, *tri, alpha[t] * area)?;
                add_weighted_mass(elastic, &mut absorbing, *tri, alpha[t] * area)?;
            }
        }
        let fixed = elastic.fixed_values(data)?;
        let mut lifted = vec![0.0; operator.n_free()];
        operator.lift(&coefficients, &fixed, &mut lifted)?;
        Ok(Operators {
            mass,
            damping,
            absorbing,
            stiffness,
            prescribed_force: lifted.iter().map(|v| -v).collect(),
        })
    }

    /// Values of A = M + a C + c K0.
    pub fn combination(&self, a: f64, c: f64) -> Vec<f64> {
        self.mass
            .iter()
            .zip(&self.damping)
            .zip(&self.stiffness)
            .map(|((m, d), k)| m + a * d + c * k)
            .collect()
    }

    /// Factorise A = M + a C + c K0 on K0's symbolic analysis.
    pub fn factor(&self, elastic: &ElasticProblem, a: f64, c: f64) -> Result<Factor, FemError> {
        let operator = elastic.operator();
        let values = self.combination(a, c);
        operator
            .symbolic()
            .factorize(operator.matrix(&values), Par::Seq)
    }
}

/// An absorbing layer as the elements see it: thickness, damping and the edges of its segments.
type Layer = (f64, f64, Vec<[[f64; 2]; 2]>);

/// α per element: the largest damping of the absorbing layers whose segments lie within the
/// layer's thickness of the element's centroid (0 outside every layer).
fn element_damping(scene: &Scene, data: &Data, mesh: &Mesh) -> Vec<f64> {
    let layers: Vec<Layer> = scene
        .absorbing
        .iter()
        .zip(&data.dynamic.absorbing)
        .map(|(layer, &damping)| {
            let edges = layer
                .segments
                .iter()
                .filter_map(|name| mesh.segment_index(name))
                .flat_map(|s| &mesh.segments[s].edges)
                .map(|&[a, b]| [mesh.nodes[a], mesh.nodes[b]])
                .collect();
            (layer.thickness, damping, edges)
        })
        .collect();
    mesh.triangles
        .iter()
        .map(|tri| {
            let p = tri.map(|n| mesh.nodes[n]);
            let centroid = [
                (p[0][0] + p[1][0] + p[2][0]) / 3.0,
                (p[0][1] + p[1][1] + p[2][1]) / 3.0,
            ];
            layers
                .iter()
                .filter(|(thickness, _, edges)| {
                    edges
                        .iter()
                        .any(|&[a, b]| point_segment(centroid, a, b).0 <= *thickness)
                })
                .map(|(_, alpha, _)| *alpha)
                .fold(0.0, f64::max)
        })
        .collect()
}

/// values += w/12 (1 + δ_ab) e_c^a · e_d^b on the free DOFs of triangle `tri` (the P1 mass of
/// an element of weight w = ρ |e| in the rotated nodal bases).
fn add_weighted_mass(
    elastic: &ElasticProblem,
    values: &mut [f64],
    tri: [usize; 3],
    weight: f64,
) -> Result<(), FemError> {
    let dofs = elastic.dofs();
    let pattern = elastic.operator().pattern();
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    for &a in &tri {
        for &b in &tri {
            let m = weight / 12.0 * if a == b { 2.0 } else { 1.0 };
            let (ba, bb) = (dofs.basis(a), dofs.basis(b));
            for (c, sa) in dofs.slots(a).into_iter().enumerate() {
                for (d, sb) in dofs.slots(b).into_iter().enumerate() {
                    let (Slot::Free(row), Slot::Free(col)) = (sa, sb) else {
                        continue;
                    };
                    if row < col {
                        continue;
                    }
                    let v = m * (ba[c][0] * bb[d][0] + ba[c][1] * bb[d][1]);
                    let rows = &row_idx[col_ptr[col]..col_ptr[col + 1]];
                    let k = rows.binary_search(&row).map_err(|_| {
                        FemError::Input(format!(
                            "mass entry ({row}, {col}) is outside the stiffness pattern"
                        ))
                    })?;
                    values[col_ptr[col] + k] += v;
                }
            }
        }
    }
    Ok(())
}
