//! The total potential energy of a discrete solution (design §2.2):
//! J(u) = ½ a(u, u) − S(u, T) + j(u), with a(u, u) = Σ_e ∫ (λ (tr e)² + 2μ e:e),
//! S the work of body forces, tractions and the thermal load, and j_h(u) = Σ_m g w_m |slip_m|
//! the lumped Tresca term.
//!
//! The exact solution u minimises J over K, and for every v ∈ K
//! J(v) − J(u) ≥ ½ ‖v − u‖²_a (from the variational inequality), with equality for a linear
//! problem (Galerkin orthogonality). So a sequence J(u_h) extrapolated to J* gives the energy
//! error estimate ‖u − u_h‖_a ≈ (2 (J(u_h) − J*))^½, exact without contact and an upper-bound
//! estimate with it.

use wsm_core::{Data, Solution, StateProblem, WsmError};

/// The parts of J(u_h).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Energy {
    /// a(u, u) (twice the strain energy) [J/m].
    pub strain: f64,
    /// S(u, T) [J/m].
    pub work: f64,
    /// j_h(u) [J/m].
    pub friction: f64,
}

impl Energy {
    /// J(u) = ½ a(u, u) − S(u) + j(u).
    pub fn potential(&self) -> f64 {
        0.5 * self.strain - self.work + self.friction
    }
}

/// J(u_h) of an elastic solution of `problem` for `data`.
pub fn energy(
    problem: &StateProblem,
    data: &Data,
    solution: &Solution,
) -> Result<Energy, WsmError> {
    let elastic = &problem.elastic;
    let mesh = problem.mesh();
    let u = &solution.displacement;
    if u.len() != mesh.nodes.len() || solution.stresses.len() != mesh.triangles.len() {
        return Err(WsmError::io(
            "energy",
            "the solution has no displacement field",
        ));
    }
    let materials = elastic.zone_materials(data)?;
    let strain = solution
        .stresses
        .iter()
        .enumerate()
        .map(|(t, s)| {
            let m = &materials[mesh.triangle_zone[t]];
            // eᵀ D e with e = (e11, e22, γ12) (FGCS 2.7′).
            let e = [s.strain[0], s.strain[1], 2.0 * s.strain[2]];
            let d = &m.law.d;
            mesh.triangle_area(t)
                * (0..3)
                    .map(|i| e[i] * (0..3).map(|j| d[i][j] * e[j]).sum::<f64>())
                    .sum::<f64>()
        })
        .sum();
    let loads = elastic.loads(data, solution.temperature.as_deref())?;
    let work = loads
        .iter()
        .zip(u)
        .map(|(f, v)| f[0] * v[0] + f[1] * v[1])
        .sum();
    // The friction bound of each pair: g w, or F λ_n at the solution's multipliers (Coulomb).
    let multipliers = solution.warm_start.as_ref().map(|w| w.x.as_slice());
    let (_, upper) = problem.contact.geometry.bounds(data, multipliers);
    let friction = solution
        .contact
        .iter()
        .enumerate()
        .map(|(m, c)| upper[2 * m + 1] * c.slip.abs())
        .sum();
    Ok(Energy {
        strain,
        work,
        friction,
    })
}
