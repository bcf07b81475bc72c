//! What drives a dynamic run besides the boundary loads (design §3.5): the bodies' initial
//! velocities, point forces with time functions (PDAS paper §2: a seismic source is a volume
//! force at the source point), and the slip-rate-dependent friction coefficient of the paper's
//! (6) (static F_s at rest, kinetic F_k in fast slip).

use crate::contact::pairs::{normal_row, tangential_row, ContactGeometry};
use crate::fem::DofMap;
use crate::mesh::Mesh;
use crate::scene::{Data, Scene, SceneError, TimeFunction};

/// Free-DOF initial velocity: every node of body i moves at `bodies[i].initial_velocity`
/// (prescribed DOFs keep their prescribed values).
pub fn initial_velocity(scene: &Scene, mesh: &Mesh, dofs: &DofMap) -> Vec<f64> {
    let global: Vec<[f64; 2]> = mesh
        .node_body
        .iter()
        .map(|&b| scene.bodies[b].initial_velocity.unwrap_or([0.0; 2]))
        .collect();
    dofs.restrict(&global).0
}

/// One point load located in the mesh.
struct Located {
    /// The triangle holding the point and the point's barycentric coordinates in it.
    nodes: [usize; 3],
    weights: [f64; 3],
    force: [f64; 2],
    function: Option<TimeFunction>,
}

/// The point loads located in the mesh.
pub struct PointLoads(Vec<Located>);

impl PointLoads {
    /// Locate every point load; a point in no triangle is an error naming it.
    pub fn new(scene: &Scene, mesh: &Mesh) -> Result<PointLoads, SceneError> {
        scene
            .point_loads
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (nodes, weights) = mesh.locate(p.point).ok_or_else(|| {
                    SceneError::new(format!("point_loads[{i}].point"), "not inside any body")
                })?;
                Ok(Located {
                    nodes,
                    weights,
                    force: p.force,
                    function: p.time_function.clone(),
                })
            })
            .collect::<Result<_, _>>()
            .map(PointLoads)
    }

    /// f_i += φ_i(point) F s(t) on the global nodal loads (the exact P1 load of a point force).
    pub fn add(&self, t: f64, f: &mut [[f64; 2]]) {
        for p in &self.0 {
            let s = p.function.as_ref().map_or(1.0, |f| f.at(t));
            for (&n, w) in p.nodes.iter().zip(&p.weights) {
                f[n][0] += w * s * p.force[0];
                f[n][1] += w * s * p.force[1];
            }
        }
    }
}

/// The slip-rate-dependent friction coefficient of a zone (paper (6)):
/// F(v) = F_k + (F_s − F_k) exp(−|v| / v_c), F_s the data's coefficient, F_k and v_c the zone's.
#[derive(Debug, Clone, Copy)]
pub struct SlipRateLaw {
    stat: f64,
    kinetic: f64,
    scale: f64,
}

impl SlipRateLaw {
    /// The law of contact zone `zone` with the data's F_s (`None` on a zone without
    /// `friction_kinetic` or without a Coulomb coefficient).
    pub fn of(scene: &Scene, data: &Data, zone: usize) -> Option<SlipRateLaw> {
        let contact = &scene.contacts[zone];
        match (
            contact.friction_kinetic,
            contact.slip_rate_scale,
            data.friction.get(zone).copied(),
        ) {
            (Some(kinetic), Some(scale), Some(Some(stat))) => Some(SlipRateLaw {
                stat,
                kinetic,
                scale,
            }),
            _ => None,
        }
    }

    /// F(v) at the slip rate `rate`.
    pub fn coefficient(&self, rate: f64) -> f64 {
        self.kinetic + (self.stat - self.kinetic) * (-rate.abs() / self.scale).exp()
    }

    /// The directional derivative of F at `rate` along a change `d_rate` of the slip rate:
    /// −(F_s − F_k)/v_c exp(−|v|/v_c) d|v|, with d|v| = sign(v) dv, and |dv| at v = 0 (the kink
    /// of |v|: the one-sided derivative along the change).
    pub fn rate_derivative(&self, rate: f64, d_rate: f64) -> f64 {
        let d_abs = if rate == 0.0 {
            d_rate.abs()
        } else {
            rate.signum() * d_rate
        };
        -(self.stat - self.kinetic) / self.scale * (-rate.abs() / self.scale).exp() * d_abs
    }
}

/// On the zones with `friction_kinetic`, the friction bounds ±F(v_p) max(λ_n, 0) of each pair
/// from its slip rate v_p (`rates`: B v of the previous step, tangential rows) and its normal
/// force of the previous step (`forces`), in place of the constant F_s bound.
pub fn slip_rate_bounds(
    scene: &Scene,
    geometry: &ContactGeometry,
    data: &Data,
    forces: &[f64],
    rates: &[f64],
    lower: &mut [f64],
    upper: &mut [f64],
) {
    for (m, pair) in geometry.pairs.iter().enumerate() {
        let Some(law) = SlipRateLaw::of(scene, data, pair.zone) else {
            continue;
        };
        let t = tangential_row(m);
        let bound = law.coefficient(rates[t]) * forces[normal_row(m)].max(0.0);
        lower[t] = -bound;
        upper[t] = bound;
    }
}
