//! Post-processing: element strain and plane-strain stress, I2², nodal internal forces.
//!
//! Duhamel–Neumann law in Voigt form (FGCS 2.7′) in plane strain: (τ11, τ22, τ12) = D e −
//! (β11, β22, β12)(T − T0) and τ33 = c·e − β33 (T − T0), e = (e11, e22, γ12) (design §2.1;
//! isotropic: τ = λ tr e I + 2μ e − β (T − T0) I, τ33 = λ tr e − β (T − T0)). I2² = τᴰ:τᴰ with τ33 included (design §4.2, FGCS 4.33).
//! Internal forces Σ_e area Bᵀτ equal K u − f_thermal, so subtracting the mechanical loads gives
//! the residual K u − f: the reaction forces at constrained DOFs.

use crate::mesh::Mesh;
use crate::scene::PlaneStrainLaw;

use super::geometry::TriangleGradients;

/// The law of a zone: its plane-strain stiffness and thermal stress vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZoneMaterial {
    /// In-plane stiffness D and out-of-plane row c \[Pa\].
    pub law: PlaneStrainLaw,
    /// Thermal stress vector (β11, β22, β12, β33) \[Pa/K\].
    pub beta: [f64; 4],
}

/// Strain and stress of one element (constant for P1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElementStress {
    /// (e11, e22, e12) — tensor shear component.
    pub strain: [f64; 3],
    /// (τ11, τ22, τ12, τ33).
    pub stress: [f64; 4],
}

impl ElementStress {
    /// I2² = (2/3)[τ11² + τ22² + τ33² − τ11τ22 − τ11τ33 − τ22τ33] + 2τ12².
    pub fn i2_squared(&self) -> f64 {
        i2_squared(self.stress)
    }
}

/// I2² of (τ11, τ22, τ12, τ33).
pub fn i2_squared(s: [f64; 4]) -> f64 {
    i2_bilinear(s, s)
}

/// The symmetric bilinear form of I2²: i2_bilinear(a, a) = I2²(a), so the derivative of I2²(τ)
/// along dτ is 2 i2_bilinear(τ, dτ).
pub fn i2_bilinear([a11, a22, a12, a33]: [f64; 4], [b11, b22, b12, b33]: [f64; 4]) -> f64 {
    2.0 / 3.0
        * (a11 * b11 + a22 * b22 + a33 * b33
            - 0.5 * (a11 * b22 + a22 * b11)
            - 0.5 * (a11 * b33 + a33 * b11)
            - 0.5 * (a22 * b33 + a33 * b22))
        + 2.0 * a12 * b12
}

/// Stress (τ11, τ22, τ12, τ33) of a strain (e11, e22, e12) with temperature excess ΔT = T − T0.
pub fn plane_strain_stress(m: &ZoneMaterial, strain: [f64; 3], delta_t: f64) -> [f64; 4] {
    m.law.stress(&m.beta, strain, delta_t)
}

/// The six nodal displacement components of a triangle, node-major (u₁ₓ, u₁ᵧ, u₂ₓ, …).
pub fn element_displacements(u: &[[f64; 2]], tri: [usize; 3]) -> [f64; 6] {
    let [a, b, c] = tri;
    [u[a][0], u[a][1], u[b][0], u[b][1], u[c][0], u[c][1]]
}

/// Element strains (e11, e22, e12) and stresses (τ11, τ22, τ12, τ33) of every triangle for the
/// nodal displacement `u`; `thermal` is the nodal temperature and T0 (ΔT is the element mean).
pub fn element_stresses(
    mesh: &Mesh,
    gradients: &[TriangleGradients],
    materials: &[ZoneMaterial],
    u: &[[f64; 2]],
    thermal: Option<(&[f64], f64)>,
) -> Vec<ElementStress> {
    (0..mesh.triangles.len())
        .map(|t| element_stress(mesh, gradients, materials, u, thermal, t))
        .collect()
}

/// [`element_stresses`] of triangle `t` alone.
pub fn element_stress(
    mesh: &Mesh,
    gradients: &[TriangleGradients],
    materials: &[ZoneMaterial],
    u: &[[f64; 2]],
    thermal: Option<(&[f64], f64)>,
    t: usize,
) -> ElementStress {
    let tri = mesh.triangles[t];
    let v = element_displacements(u, tri);
    let [e11, e22, gamma] = gradients[t].strain(&v);
    let strain = [e11, e22, gamma / 2.0];
    let delta_t = thermal.map_or(0.0, |(temp, t0)| {
        tri.iter().map(|&n| temp[n]).sum::<f64>() / 3.0 - t0
    });
    let m = &materials[mesh.triangle_zone[t]];
    ElementStress {
        strain,
        stress: plane_strain_stress(m, strain, delta_t),
    }
}

/// Nodal internal forces Σ_e area Bᵀ(τ11, τ22, τ12) in global components.
pub fn internal_forces(
    mesh: &Mesh,
    gradients: &[TriangleGradients],
    stresses: &[ElementStress],
) -> Vec<[f64; 2]> {
    let mut f = vec![[0.0; 2]; mesh.nodes.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let s = stresses[t].stress;
        let fe = gradients[t].nodal_forces([s[0], s[1], s[2]]);
        for (i, &node) in tri.iter().enumerate() {
            f[node][0] += fe[2 * i];
            f[node][1] += fe[2 * i + 1];
        }
    }
    f
}
