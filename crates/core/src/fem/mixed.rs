//! The MINI mixed element for nearly incompressible isotropic zones (design §2.7,
//! `mesh.element: "mixed"`): displacement P1 + cubic bubble per triangle, continuous P1
//! pressure p = λ div u, the bubble condensed element by element. The displacement nodes are the
//! P1 vertices, so DOFs, loads, contact rows and outputs are those of P1.
//!
//! Herrmann's form: find (u, p) with
//! 2μ ∫ e(u):e(v) + ∫ p div v = S(v) and ∫ q div u − ∫ p q / λ = 0 for all (v, q).
//! With u = u₁ + b β (b = 27 λ₁λ₂λ₃ the bubble), ∫ e(u₁):e(bβ) = 0 (e(u₁) is constant and
//! ∫ ∇b = 0), so condensing β gives the symmetric quasi-definite system
//! [[μ K_μ, Gᵀ], [G, −(C_b/μ + M/λ)]] (x = (u, p)) with K_μ the P1 stiffness of D = diag(2, 2, 1),
//! G_{j,(a,c)} = ∫ φ_j ∂_c φ_a = |T|/3 ∂_c φ_a, M the P1 pressure mass and
//! C_b = Σ_T G_bᵀ A_bb⁻¹ G_b the bubble's stabilisation: G_b = −(9|T|/20) ∇φ_j (∫ q div(bβ) =
//! −∫ b ∇q·β, ∫ b = 9|T|/20) and A_bb = tr(Γ) I + Γ, Γ = ∫ ∇b ∇bᵀ = (81|T|/20) Σ_i ∇φ_i ∇φ_iᵀ (the
//! bubble's 2μ∫e:e at μ = 1). The bubble's share of a body force is neglected (design §2.7).
//!
//! MINI is inf-sup stable on triangles (Arnold–Brezzi–Fortin 1984), so the error bounds hold
//! uniformly in λ → ∞: no locking. The pressure unknown is scaled, p = s p̂ with s = μ_max / h
//! (h² the mean triangle area), so both diagonal blocks are of order μ and the LDLᵀ factorisation
//! without pivoting of the quasi-definite matrix ([`super::Symbolic::factorize_quasi_definite`])
//! is well scaled; its zone coefficients are (μ, s, s²/μ, s²/λ, 0, 0) (six, as the P1
//! operator's, so that the contact solver and the caches take either).
//!
//! Stresses: the second equation gives p = (C_b/μ + M/λ)⁻¹ G u exactly (G on all nodal DOFs),
//! solved with a Cholesky factor of the SPD pressure block; per element
//! τ = 2μ e(u) + p̄ I and τ33 = p̄ (plane strain, ε33 = 0), p̄ the element mean of p.

use faer::Par;

use crate::mesh::Mesh;

use super::dofs::DofMap;
use super::element_matrices::{element_matrices, rotate};
use super::geometry::TriangleGradients;
use super::operator::{OperatorBuilder, OperatorFactor, Slot, ZonedOperator};
use super::{ElasticCoefficients, FemError};

/// The pressure side of the mixed element of a mesh: the SPD pressure block and the pressure
/// scale; the quasi-definite (u, p̂) system itself is the elastic problem's operator
/// ([`mixed_system`]).
#[derive(Debug, Clone)]
pub struct MixedOperator {
    /// Number of free displacement DOFs (the pressure unknowns follow them).
    n_u: usize,
    /// C_b/μ + M/λ on the nodal pressures, coefficients (1/μ, 1/λ).
    pressure: ZonedOperator<2>,
    /// Mean triangle area (the h² of the pressure scale).
    h2: f64,
}

/// Per triangle: K_μ (global xy, node-major), G (row j, column (a, c)), C_b at μ = 1 and M.
struct Blocks {
    k: [[f64; 6]; 6],
    g: [[f64; 6]; 3],
    cb: [[f64; 3]; 3],
    m: [[f64; 3]; 3],
}

/// The D entries of 2 × diag(1, 1, ½): K_μ = Σ_k UNIT_SHEAR_D[k] K^k.
const UNIT_SHEAR_D: [f64; 6] = [2.0, 0.0, 0.0, 2.0, 0.0, 1.0];

fn blocks(g: &TriangleGradients) -> Blocks {
    let per_entry = element_matrices(g);
    let k = std::array::from_fn(|i| {
        std::array::from_fn(|j| (0..6).map(|q| UNIT_SHEAR_D[q] * per_entry[i][j][q]).sum())
    });
    let a = g.area;
    let grad = |i: usize| [g.dx[i], g.dy[i]];
    let gm = std::array::from_fn(|_j| std::array::from_fn(|c| a / 3.0 * grad(c / 2)[c % 2]));
    // Γ = (81|T|/20) Σ ∇φ_i ∇φ_iᵀ; A_bb = tr Γ I + Γ.
    let mut gamma = [[0.0; 2]; 2];
    for i in 0..3 {
        let d = grad(i);
        for (r, row) in gamma.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v += 81.0 * a / 20.0 * d[r] * d[c];
            }
        }
    }
    let tr = gamma[0][0] + gamma[1][1];
    let abb = [
        [tr + gamma[0][0], gamma[0][1]],
        [gamma[1][0], tr + gamma[1][1]],
    ];
    let det = abb[0][0] * abb[1][1] - abb[0][1] * abb[1][0];
    let inv = [
        [abb[1][1] / det, -abb[0][1] / det],
        [-abb[1][0] / det, abb[0][0] / det],
    ];
    let w = (9.0 * a / 20.0).powi(2);
    let cb = std::array::from_fn(|j| {
        std::array::from_fn(|l| {
            let (dj, dl) = (grad(j), grad(l));
            w * (0..2)
                .map(|r| (0..2).map(|c| dj[r] * inv[r][c] * dl[c]).sum::<f64>())
                .sum::<f64>()
        })
    });
    let m =
        std::array::from_fn(|j| std::array::from_fn(|l| a / 12.0 * if j == l { 2.0 } else { 1.0 }));
    Blocks { k, g: gm, cb, m }
}

/// The mixed (u_free, p̂) system on the DOFs of `dofs` (pressure unknown of node n at
/// `dofs.n_free() + n`), marked quasi-definite, and the pressure side; every node must belong to
/// a triangle (it carries a pressure unknown).
pub fn mixed_system(
    mesh: &Mesh,
    dofs: &DofMap,
    gradients: &[TriangleGradients],
) -> Result<(ZonedOperator<6>, MixedOperator), FemError> {
    let mut used = vec![false; mesh.nodes.len()];
    for tri in &mesh.triangles {
        for &n in tri {
            used[n] = true;
        }
    }
    if let Some(node) = used.iter().position(|u| !u) {
        return Err(FemError::Input(format!(
            "node {node} belongs to no triangle: the mixed element needs a pressure on every node"
        )));
    }
    let n_u = dofs.n_free();
    let n_p = mesh.nodes.len();
    let zones = mesh.zones.len();
    let identity = [[1.0, 0.0], [0.0, 1.0]];
    let mut system = OperatorBuilder::<6>::new(n_u + n_p, dofs.n_fixed(), zones);
    let mut pressure = OperatorBuilder::<2>::new(n_p, 0, zones);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let mut b = blocks(&gradients[t]);
        let bases = tri.map(|n| dofs.basis(n));
        if bases.iter().any(|basis| *basis != identity) {
            // The same change of basis as the P1 stiffness, on K_μ and on the columns of G.
            let mut per: [[[f64; 6]; 6]; 6] = std::array::from_fn(|i| {
                std::array::from_fn(|j| [b.k[i][j], 0.0, 0.0, 0.0, 0.0, 0.0])
            });
            rotate(&mut per, bases);
            b.k = std::array::from_fn(|i| std::array::from_fn(|j| per[i][j][0]));
            for row in &mut b.g {
                let global = *row;
                for a in 0..3 {
                    for c in 0..2 {
                        let e = bases[a][c];
                        row[2 * a + c] = e[0] * global[2 * a] + e[1] * global[2 * a + 1];
                    }
                }
            }
        }
        let mut slots: Vec<Slot> = tri.iter().flat_map(|&n| dofs.slots(n)).collect();
        slots.extend(tri.iter().map(|&n| Slot::Free(n_u + n)));
        let zone = mesh.triangle_zone[t];
        system.add_element(zone, &slots, |i, j| match (i < 6, j < 6) {
            (true, true) => [b.k[i][j], 0.0, 0.0, 0.0, 0.0, 0.0],
            (true, false) => [0.0, b.g[j - 6][i], 0.0, 0.0, 0.0, 0.0],
            (false, true) => [0.0, b.g[i - 6][j], 0.0, 0.0, 0.0, 0.0],
            (false, false) => [0.0, 0.0, -b.cb[i - 6][j - 6], -b.m[i - 6][j - 6], 0.0, 0.0],
        });
        let p_slots = tri.map(Slot::Free);
        pressure.add_element(zone, &p_slots, |i, j| [b.cb[i][j], b.m[i][j]]);
    }
    let total: f64 = gradients.iter().map(|g| g.area).sum();
    Ok((
        system.finish()?.into_quasi_definite(),
        MixedOperator {
            n_u,
            pressure: pressure.finish()?,
            h2: total / gradients.len().max(1) as f64,
        },
    ))
}

impl MixedOperator {
    /// Number of free displacement DOFs (the first pressure unknown of the system).
    pub fn n_displacement(&self) -> usize {
        self.n_u
    }

    /// (λ, μ) per zone from the entries of isotropic plane-strain stiffnesses; any other law,
    /// or λ ≤ 0 (ν ≤ 0: the element is meant for ν → ½), is an error naming the zone.
    pub fn lame(
        coefficients: &[ElasticCoefficients],
        zone_names: &[String],
    ) -> Result<Vec<(f64, f64)>, FemError> {
        coefficients
            .iter()
            .enumerate()
            .map(|(z, c)| {
                let [d11, d12, d13, d22, d23, d33] = *c;
                let scale = d11.abs().max(f64::MIN_POSITIVE);
                let isotropic = d13 == 0.0
                    && d23 == 0.0
                    && (d11 - d22).abs() <= 1e-12 * scale
                    && (d11 - d12 - 2.0 * d33).abs() <= 1e-12 * scale;
                let name = zone_names.get(z).map_or("?", |s| s.as_str());
                if !isotropic {
                    return Err(FemError::Input(format!(
                        "zone '{name}': mesh.element \"mixed\" needs an isotropic material \
                         (D entries d11, d12, d13, d22, d23, d33 = {c:?})"
                    )));
                }
                if !(d12 > 0.0 && d33 > 0.0) {
                    return Err(FemError::Input(format!(
                        "zone '{name}': mesh.element \"mixed\" needs λ > 0 and μ > 0 (0 < ν < ½), got λ = {d12:e}, μ = {d33:e}"
                    )));
                }
                Ok((d12, d33))
            })
            .collect()
    }

    /// The pressure scale s = μ_max / h (module doc).
    fn scale(&self, lame: &[(f64, f64)]) -> f64 {
        let mu = lame.iter().fold(0.0_f64, |m, &(_, mu)| m.max(mu));
        mu / self.h2.sqrt()
    }

    /// Zone coefficients (μ, s, s²/μ, s²/λ, 0, 0) of the system for the Lamé constants per
    /// zone.
    pub fn coefficients(&self, lame: &[(f64, f64)]) -> Vec<ElasticCoefficients> {
        let s = self.scale(lame);
        lame.iter()
            .map(|&(lambda, mu)| [mu, s, s * s / mu, s * s / lambda, 0.0, 0.0])
            .collect()
    }

    /// Nodal pressures p = (C_b/μ + M/λ)⁻¹ G u of a global nodal displacement (module doc).
    pub fn pressure(
        &self,
        mesh: &Mesh,
        gradients: &[TriangleGradients],
        lame: &[(f64, f64)],
        u: &[[f64; 2]],
    ) -> Result<Vec<f64>, FemError> {
        self.solve_pressure(lame, &divergence_rows(mesh, gradients, u))
    }

    /// (C_b/μ + M/λ)⁻¹ `rows` (a Cholesky factor of the SPD pressure block).
    fn solve_pressure(&self, lame: &[(f64, f64)], rows: &[f64]) -> Result<Vec<f64>, FemError> {
        Ok(self.pressure_factor(lame)?.factor.solve(rows))
    }

    /// The Cholesky factor of the pressure block C_b/μ + M/λ (coefficients (1/μ, 1/λ)).
    fn pressure_factor(&self, lame: &[(f64, f64)]) -> Result<OperatorFactor<2>, FemError> {
        let coefs: Vec<[f64; 2]> = lame.iter().map(|&(l, m)| [1.0 / m, 1.0 / l]).collect();
        self.pressure.factor(&coefs, Par::Seq)
    }
}

/// Derivatives along the data (design §2.7, "Derivatives"): the operator's zone coefficients
/// and the pressure recovery p = P⁻¹ (G u − r), P = C_b/μ + M/λ, differentiated in the Lamé
/// constants (dλ, dμ) per zone and the thermal rows r.
impl MixedOperator {
    /// d(μ, s, s²/μ, s²/λ, 0, 0) per zone for the Lamé derivatives `d_lame`, the pressure scale s
    /// held at its value for `lame`: s only scales the pressure unknown (p = s p̂), so u and p do
    /// not depend on it and the derivative of (u, p̂) at fixed s gives their exact derivatives.
    pub fn coefficient_derivatives(
        &self,
        lame: &[(f64, f64)],
        d_lame: &[(f64, f64)],
    ) -> Vec<ElasticCoefficients> {
        let s2 = self.scale(lame).powi(2);
        lame.iter()
            .zip(d_lame)
            .map(|(&(l, m), &(dl, dm))| [dm, 0.0, -s2 * dm / (m * m), -s2 * dl / (l * l), 0.0, 0.0])
            .collect()
    }

    /// The derivative of the nodal pressures p = P⁻¹ (G u − r) at fixed u along `d_lame` and the
    /// derivative `d_rows` of the thermal rows r (None: no temperature):
    /// dp = −P⁻¹ (dP p + dr) = P⁻¹ ((C_b dμ/μ² + M dλ/λ²) p − dr).
    pub fn pressure_rate_at_fixed_displacement(
        &self,
        lame: &[(f64, f64)],
        d_lame: &[(f64, f64)],
        p: &[f64],
        d_rows: Option<&[f64]>,
    ) -> Result<Vec<f64>, FemError> {
        let rates: Vec<[f64; 2]> = lame
            .iter()
            .zip(d_lame)
            .map(|(&(l, m), &(dl, dm))| [dm / (m * m), dl / (l * l)])
            .collect();
        let values = self.pressure.assemble(&rates)?;
        let mut rhs = self.pressure.apply(&values, p);
        if let Some(dr) = d_rows {
            for (b, r) in rhs.iter_mut().zip(dr) {
                *b -= r;
            }
        }
        Ok(self.pressure_factor(lame)?.factor.solve(&rhs))
    }

    /// The transpose of the pressure recovery: for nodal weights q, the weights y = P⁻¹ q with
    /// Σ_n q_n p_n = yᵀ (G u − r) (P symmetric).
    pub fn pressure_weights(&self, lame: &[(f64, f64)], q: &[f64]) -> Result<Vec<f64>, FemError> {
        Ok(self.pressure_factor(lame)?.factor.solve(q))
    }

    /// The global nodal coefficients a = Gᵀ y with yᵀ G u = Σ_n a_n·u_n, for the pressure
    /// weights y of [`Self::pressure_weights`].
    pub fn divergence_transpose(
        &self,
        mesh: &Mesh,
        gradients: &[TriangleGradients],
        y: &[f64],
    ) -> Vec<[f64; 2]> {
        let mut a = vec![[0.0; 2]; mesh.nodes.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let g = &gradients[t];
            let weight = g.area / 3.0 * tri.iter().map(|&n| y[n]).sum::<f64>();
            for (k, &n) in tri.iter().enumerate() {
                a[n][0] += weight * g.dx[k];
                a[n][1] += weight * g.dy[k];
            }
        }
        a
    }
}

/// G u = ∫ φ_j div u per node of a global nodal displacement.
fn divergence_rows(mesh: &Mesh, gradients: &[TriangleGradients], u: &[[f64; 2]]) -> Vec<f64> {
    let mut gu = vec![0.0; mesh.nodes.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let g = &gradients[t];
        let div: f64 = (0..3)
            .map(|a| g.dx[a] * u[tri[a]][0] + g.dy[a] * u[tri[a]][1])
            .sum();
        for &n in tri {
            gu[n] += g.area / 3.0 * div;
        }
    }
    gu
}

// ---------- thermal strain (design §2.7, "Thermal stress") ----------

/// The thermal stress β ΔT split for Herrmann's form: p = τ33 = λ div u − β33 ΔT carries β33 ΔT
/// I, the rest (β11 − β33, β22 − β33, β12) ΔT stays a load on the displacement rows (zero for
/// an isotropic expansion, β = (3λ + 2μ) α (1, 1, 0, 1)).
pub(super) fn deviatoric_beta(beta: &[f64; 4]) -> [f64; 3] {
    [beta[0] - beta[3], beta[1] - beta[3], beta[2]]
}

/// The element mean of the nodal temperature's excess over `reference` (the ΔT of the P1
/// thermal load, exact against the element-wise constant e(v) and div v).
pub(super) fn mean_excess(tri: [usize; 3], temperature: &[f64], reference: f64) -> f64 {
    tri.iter().map(|&n| temperature[n]).sum::<f64>() / 3.0 - reference
}

impl MixedOperator {
    /// The thermal rows r_j = Σ_T (|T|/3) γ ΔT̄_T of the pressure equation
    /// ∫ q div u − ∫ q (p + β33 ΔT)/λ = 0, i.e. G u − (C_b/μ + M/λ) p = r, for the zones'
    /// γ = β33/λ in `expansion` and the temperature's excess over `reference` (linear in γ and in
    /// (temperature, reference)).
    pub fn thermal_rows(
        &self,
        mesh: &Mesh,
        expansion: &[f64],
        temperature: &[f64],
        reference: f64,
    ) -> Vec<f64> {
        let mut r = vec![0.0; mesh.nodes.len()];
        for (t, &tri) in mesh.triangles.iter().enumerate() {
            let z = mesh.triangle_zone[t];
            let area = mesh.triangle_area(t);
            let v = area / 3.0 * expansion[z] * mean_excess(tri, temperature, reference);
            for n in tri {
                r[n] += v;
            }
        }
        r
    }

    /// The transpose of the thermal rows in the temperature: for pressure weights y, the nodal
    /// coefficients c with yᵀ r(T) = Σ_n c_n T_n + (the reference's part), r of
    /// [`Self::thermal_rows`] for the zones' `expansion`.
    pub fn thermal_rows_transpose(&self, mesh: &Mesh, expansion: &[f64], y: &[f64]) -> Vec<f64> {
        let mut c = vec![0.0; mesh.nodes.len()];
        for (t, &tri) in mesh.triangles.iter().enumerate() {
            let weight = tri.iter().map(|&n| y[n]).sum::<f64>();
            let v = mesh.triangle_area(t) / 9.0 * expansion[mesh.triangle_zone[t]] * weight;
            for n in tri {
                c[n] += v;
            }
        }
        c
    }

    /// Adds the thermal rows s r (scaled like the pressure rows of the system, p = s p̂) to the
    /// pressure rows of the reduced right-hand side `b`.
    pub fn add_thermal_rows(&self, lame: &[(f64, f64)], rows: &[f64], b: &mut [f64]) {
        let s = self.scale(lame);
        for (bi, r) in b[self.n_u..].iter_mut().zip(rows) {
            *bi += s * r;
        }
    }

    /// Nodal pressures p = (C_b/μ + M/λ)⁻¹ (G u − r) with the thermal rows r of
    /// [`Self::thermal_rows`]: p = τ33 = λ div u − β33 ΔT.
    pub fn thermo_pressure(
        &self,
        mesh: &Mesh,
        gradients: &[TriangleGradients],
        lame: &[(f64, f64)],
        u: &[[f64; 2]],
        rows: &[f64],
    ) -> Result<Vec<f64>, FemError> {
        let mut gu = divergence_rows(mesh, gradients, u);
        for (g, r) in gu.iter_mut().zip(rows) {
            *g -= r;
        }
        self.solve_pressure(lame, &gu)
    }
}
