//! The history of a dynamic run (design §3.5, "Outputs"): at the output times, u, v and a
//! at the receivers (P1 interpolation in the triangle holding the point), per contact zone the
//! normal and tangential resultants, the open/stick/slip counts, the largest penetration, slip
//! and slip rate, per body the mean velocity, and the energy budget term by term; over every
//! step, the peak-over-time fields (max |u| per node, max I2² per element, max contact pressure
//! per pair) and where and when each field is largest.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::contact::pairs::{normal_row, tangential_row, ContactGeometry};
use crate::fem::stress::ElementStress;
use crate::mesh::Mesh;
use crate::scene::{ContactSolver, Scene, SceneError, TimeScheme};

/// Histories of one receiver: one entry per output time.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct ReceiverHistory {
    /// The receiver's position \[m\].
    pub point: [f64; 2],
    /// Displacement (x, y) \[m\].
    pub displacement: Vec<[f64; 2]>,
    /// Velocity (x, y) \[m/s\].
    pub velocity: Vec<[f64; 2]>,
    /// Acceleration (x, y) \[m/s²\]: (v_{n+1} − v_n)/Δt, the step's mean acceleration.
    pub acceleration: Vec<[f64; 2]>,
}

/// The nodal displacement at one output time of a dynamic run (a solve's `frames`).
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct DisplacementFrame {
    /// Time \[s\] (one of [`History::times`]).
    pub time: f64,
    /// Nodal displacement (x, y) \[m\], in the order of the fields' `nodes`.
    pub displacement: Vec<[f64; 2]>,
}

/// Histories of one contact zone: one entry per output time.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct ZoneHistory {
    /// Sum of the normal nodal forces (compression > 0) \[N/m\] (per unit thickness).
    pub normal_force: Vec<f64>,
    /// Sum of the tangential nodal forces along t = (−n_y, n_x) \[N/m\].
    pub tangential_force: Vec<f64>,
    /// Pairs without normal force.
    pub open: Vec<usize>,
    /// Pairs in contact below their friction bound.
    pub stick: Vec<usize>,
    /// Pairs in contact at their friction bound (every frictionless one).
    pub slip: Vec<usize>,
    /// Largest overlap max(B_n u − g0, 0) of the zone's pairs \[m\] (rounding level).
    pub penetration: Vec<f64>,
    /// Largest |slip| of the zone's pairs: the relative tangential displacement t·(u^k − u^l)
    /// \[m\] (from the undeformed state).
    pub max_slip: Vec<f64>,
    /// Largest |slip rate| of the zone's pairs over the step that ended at the output time:
    /// |Δslip|/Δt \[m/s\] (0 at t = 0).
    pub max_slip_rate: Vec<f64>,
}

/// Histories of one body: one entry per output time.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct BodyHistory {
    /// The mass-weighted mean velocity ∫ρv / ∫ρ (x, y) \[m/s\] (its momentum over its mass).
    pub mean_velocity: Vec<[f64; 2]>,
}

/// The energy budget at the output times \[J/m\] (per unit thickness). Per step,
/// work = Δ(kinetic + strain) + viscous + absorbing + contact + friction + numerical.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct EnergyHistory {
    /// ½ vᵀ M v.
    pub kinetic: Vec<f64>,
    /// ½ uᵀ K0 u + uᵀ K_fd u_d (the elastic energy up to a constant of the prescribed values).
    pub strain: Vec<f64>,
    /// Dissipated by the Kelvin–Voigt viscosity since t = 0: Σ Δt ṽᵀ K1 ṽ (ṽ the velocity the
    /// scheme's damping acts on).
    pub viscous: Vec<f64>,
    /// Dissipated by the absorbing layers since t = 0: Σ Δt ṽᵀ C_α ṽ.
    pub absorbing: Vec<f64>,
    /// Work of the normal contact forces since t = 0: Σ λ_nᵀ B_n Δu (≥ 0 for unilateral
    /// contact, design §3.5).
    pub contact: Vec<f64>,
    /// Dissipated by friction since t = 0: Σ λ_tᵀ B_t Δu (≥ 0).
    pub friction: Vec<f64>,
    /// Work of the loads since t = 0.
    pub work: Vec<f64>,
    /// What the scheme dissipated itself since t = 0 (the balance's residual; 0 to rounding
    /// for `newmark`).
    pub numerical: Vec<f64>,
}

/// Counters of the run.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct DynamicsReport {
    /// The integrator.
    #[schema(value_type = String)]
    pub scheme: TimeScheme,
    /// Time step \[s\].
    pub dt: f64,
    /// Steps taken.
    pub steps: usize,
    /// Free unknowns.
    pub unknowns: usize,
    /// Contact multipliers (2 per node pair).
    pub multipliers: usize,
    /// The per-step contact solver.
    #[schema(value_type = String)]
    pub contact_solver: ContactSolver,
    /// Steps where PDAS did not terminate and the QP kernel solved the step.
    pub pdas_fallbacks: usize,
    /// Contact solver iterations over the run (PDAS STEP 2 solves, or the QP's semismooth
    /// Newton steps).
    pub qp_iterations: usize,
    /// Active-set changes over the run.
    pub active_set_changes: usize,
    /// Wall time of the run \[s\].
    pub seconds: f64,
}

/// Where and when one peak-over-time field is largest.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct Peak {
    /// The largest value over the nodes (elements, pairs) and every step (0 when there is none).
    pub value: f64,
    /// The time it happened \[s\].
    pub time: f64,
    /// The node (element centroid, pair node) where it happened \[m\].
    pub point: [f64; 2],
}

/// The largest values of the peak-over-time fields (the fields themselves are in the VTU
/// series).
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct Peaks {
    /// max |u| \[m\].
    pub displacement: Peak,
    /// max I2² of the total (elastic + Kelvin–Voigt viscous) stress \[Pa²\].
    pub i2_squared: Peak,
    /// max contact pressure \[Pa\].
    pub contact_pressure: Peak,
}

/// The peak-over-time fields over every step of a run.
#[derive(Debug, Clone, Default)]
pub struct PeakFields {
    /// max over time of |u| per node \[m\].
    pub displacement: Vec<f64>,
    /// max over time of I2² per element \[Pa²\].
    pub i2_squared: Vec<f64>,
    /// max over time of the contact pressure per pair (in the contact geometry's order) \[Pa\].
    pub contact_pressure: Vec<f64>,
    /// The largest of each and where and when.
    pub summary: Peaks,
}

impl PeakFields {
    /// Raise the fields to the state at `t`: nodal displacement, element stresses and contact
    /// forces (normal, tangential per pair).
    pub fn update(
        &mut self,
        mesh: &Mesh,
        geometry: &ContactGeometry,
        t: f64,
        displacement: &[[f64; 2]],
        stresses: &[ElementStress],
        forces: &[f64],
    ) {
        let raise = |field: &mut Vec<f64>,
                     peak: &mut Peak,
                     values: &mut dyn Iterator<Item = (f64, [f64; 2])>| {
            for (k, (value, point)) in values.enumerate() {
                if k == field.len() {
                    field.push(value);
                } else {
                    field[k] = field[k].max(value);
                }
                if value > peak.value {
                    *peak = Peak {
                        value,
                        time: t,
                        point,
                    };
                }
            }
        };
        let s = &mut self.summary;
        raise(
            &mut self.displacement,
            &mut s.displacement,
            &mut displacement
                .iter()
                .zip(&mesh.nodes)
                .map(|(u, p)| (u[0].hypot(u[1]), *p)),
        );
        raise(
            &mut self.i2_squared,
            &mut s.i2_squared,
            &mut stresses
                .iter()
                .zip(&mesh.triangles)
                .map(|(e, tri)| (e.i2_squared(), centroid(mesh, *tri))),
        );
        raise(
            &mut self.contact_pressure,
            &mut s.contact_pressure,
            &mut geometry.pairs.iter().enumerate().map(|(m, p)| {
                let w = p.weight.max(f64::MIN_POSITIVE);
                (forces[normal_row(m)] / w, mesh.nodes[p.nodes[0]])
            }),
        );
    }
}

fn centroid(mesh: &Mesh, tri: [usize; 3]) -> [f64; 2] {
    let p = tri.map(|n| mesh.nodes[n]);
    [
        (p[0][0] + p[1][0] + p[2][0]) / 3.0,
        (p[0][1] + p[1][1] + p[2][1]) / 3.0,
    ]
}

/// The history `wsm solve` writes for a dynamic scene.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct History {
    /// Output times \[s\] (t = 0 first).
    pub times: Vec<f64>,
    /// Per receiver name.
    pub receivers: BTreeMap<String, ReceiverHistory>,
    /// Per contact zone name.
    pub contact_zones: BTreeMap<String, ZoneHistory>,
    /// Per body name.
    pub bodies: BTreeMap<String, BodyHistory>,
    /// The energy budget.
    pub energy: EnergyHistory,
    /// The largest values of the peak-over-time fields, over every step.
    pub peaks: Peaks,
    /// Counters.
    pub report: DynamicsReport,
    /// Per criterion the scene defines (`phi1`…, and each of `criteria.defined` by its name),
    /// its maximum over the time steps.
    pub criteria: BTreeMap<String, CriterionPeak>,
}

/// The largest value of a criterion over the time steps (design §3.5).
#[derive(Debug, Clone, Default, PartialEq, Serialize, utoipa::ToSchema)]
pub struct CriterionPeak {
    /// max over the steps t_n (t = 0 included) of the criterion at u(t_n).
    pub value: f64,
    /// The first time where it is reached \[s\].
    pub time: f64,
    /// The region of the criterion's family where it is reached (a defined criterion: its area,
    /// boundary piece or receiver).
    pub region: String,
}

/// One state of the run, as the recorder reads it (global nodal fields).
pub struct Snapshot<'a> {
    pub t: f64,
    pub displacement: &'a [[f64; 2]],
    pub velocity: &'a [[f64; 2]],
    pub acceleration: &'a [[f64; 2]],
    /// Contact forces λ (normal, tangential per pair) and their friction bounds.
    pub forces: &'a [f64],
    pub bounds: &'a [f64],
    /// B u + B_d u_d − g0 per multiplier row: the gap on normal rows, the slip on tangential
    /// rows.
    pub gaps: &'a [f64],
    /// B Δu / Δt over the step that ended at `t` (zero at t = 0): the slip rate on tangential
    /// rows.
    pub rates: &'a [f64],
    /// The energies at `t` and the cumulative terms since t = 0.
    pub energy: Energy,
}

/// The energy terms of a [`Snapshot`]: kinetic and strain at its time, the rest cumulative
/// since t = 0 (the [`EnergyHistory`] fields of the same names).
#[derive(Debug, Clone, Copy, Default)]
pub struct Energy {
    pub kinetic: f64,
    pub strain: f64,
    pub viscous: f64,
    pub absorbing: f64,
    pub contact: f64,
    pub friction: f64,
    pub work: f64,
}

/// Where each receiver sits (its triangle's nodes and barycentric weights), the zones' names
/// and each body's nodal mass weights.
pub struct Recorder {
    receivers: Vec<(String, [usize; 3], [f64; 3])>,
    zones: Vec<String>,
    /// Per body: (node, ∫ρφ_node / ∫ρ over the body).
    bodies: Vec<(String, Vec<(usize, f64)>)>,
    initial_energy: f64,
}

impl Recorder {
    /// Locate the receivers in the mesh; a point in no triangle is an error naming it.
    pub fn new(scene: &Scene, mesh: &Mesh) -> Result<Recorder, SceneError> {
        let receivers = scene
            .receivers
            .iter()
            .enumerate()
            .map(|(i, r)| {
                mesh.locate(r.point)
                    .map(|(tri, w)| (r.name.clone(), tri, w))
                    .ok_or_else(|| {
                        SceneError::new(format!("receivers[{i}].point"), "not inside any body")
                    })
            })
            .collect::<Result<_, _>>()?;
        Ok(Recorder {
            receivers,
            zones: scene.contacts.iter().map(|c| c.name.clone()).collect(),
            bodies: body_weights(scene, mesh),
            initial_energy: 0.0,
        })
    }

    /// A history with the receivers' positions and the zones' names and no entries.
    pub fn empty(&self, scene: &Scene) -> History {
        History {
            receivers: scene
                .receivers
                .iter()
                .map(|r| {
                    let h = ReceiverHistory {
                        point: r.point,
                        ..Default::default()
                    };
                    (r.name.clone(), h)
                })
                .collect(),
            contact_zones: self
                .zones
                .iter()
                .map(|z| (z.clone(), ZoneHistory::default()))
                .collect(),
            bodies: self
                .bodies
                .iter()
                .map(|(b, _)| (b.clone(), BodyHistory::default()))
                .collect(),
            ..Default::default()
        }
    }

    /// Append the snapshot to the history (the first one fixes the initial energy).
    pub fn record(&mut self, h: &mut History, geometry: &ContactGeometry, s: &Snapshot) {
        h.times.push(s.t);
        for (name, tri, w) in &self.receivers {
            let at = |field: &[[f64; 2]]| {
                let mut v = [0.0; 2];
                for (n, wi) in tri.iter().zip(w) {
                    v[0] += wi * field[*n][0];
                    v[1] += wi * field[*n][1];
                }
                v
            };
            let r = h.receivers.get_mut(name).expect("receiver recorded");
            r.displacement.push(at(s.displacement));
            r.velocity.push(at(s.velocity));
            r.acceleration.push(at(s.acceleration));
        }
        let scale = s.forces.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let mut zones: Vec<ZoneHistory> = self
            .zones
            .iter()
            .map(|_| ZoneHistory {
                normal_force: vec![0.0],
                tangential_force: vec![0.0],
                open: vec![0],
                stick: vec![0],
                slip: vec![0],
                penetration: vec![0.0],
                max_slip: vec![0.0],
                max_slip_rate: vec![0.0],
            })
            .collect();
        for (m, p) in geometry.pairs.iter().enumerate() {
            let z = &mut zones[p.zone];
            let (ln, lt) = (s.forces[normal_row(m)], s.forces[tangential_row(m)]);
            z.normal_force[0] += ln;
            z.tangential_force[0] += lt;
            z.penetration[0] = z.penetration[0].max(s.gaps[normal_row(m)]);
            z.max_slip[0] = z.max_slip[0].max(s.gaps[tangential_row(m)].abs());
            z.max_slip_rate[0] = z.max_slip_rate[0].max(s.rates[tangential_row(m)].abs());
            if !p.bilateral && ln.abs() <= 1e-12 * scale {
                z.open[0] += 1;
            } else if lt.abs() < s.bounds[tangential_row(m)] * (1.0 - 1e-9) {
                z.stick[0] += 1;
            } else {
                z.slip[0] += 1;
            }
        }
        for (name, z) in self.zones.iter().zip(zones) {
            let h = h.contact_zones.get_mut(name).expect("zone recorded");
            h.normal_force.extend(z.normal_force);
            h.tangential_force.extend(z.tangential_force);
            h.open.extend(z.open);
            h.stick.extend(z.stick);
            h.slip.extend(z.slip);
            h.penetration.extend(z.penetration);
            h.max_slip.extend(z.max_slip);
            h.max_slip_rate.extend(z.max_slip_rate);
        }
        for (name, weights) in &self.bodies {
            let mut v = [0.0; 2];
            for &(n, w) in weights {
                v[0] += w * s.velocity[n][0];
                v[1] += w * s.velocity[n][1];
            }
            let b = h.bodies.get_mut(name).expect("body recorded");
            b.mean_velocity.push(v);
        }
        let en = s.energy;
        if h.energy.kinetic.is_empty() {
            self.initial_energy = en.kinetic + en.strain;
        }
        let e = &mut h.energy;
        e.kinetic.push(en.kinetic);
        e.strain.push(en.strain);
        e.viscous.push(en.viscous);
        e.absorbing.push(en.absorbing);
        e.contact.push(en.contact);
        e.friction.push(en.friction);
        e.work.push(en.work);
        e.numerical.push(
            en.work
                - (en.kinetic + en.strain - self.initial_energy)
                - en.viscous
                - en.absorbing
                - en.contact
                - en.friction,
        );
    }
}

/// Per body, each node's share of the body's mass: Σ_e∋node ρ|e|/3 over Σ_e ρ|e| (the P1
/// consistent mass's row sums, so Σ share × v is the momentum over the mass). A body without
/// mass has no shares (its mean velocity reads 0).
fn body_weights(scene: &Scene, mesh: &Mesh) -> Vec<(String, Vec<(usize, f64)>)> {
    let materials: Vec<_> = scene.materials.values().collect();
    let mut nodal = vec![0.0; mesh.nodes.len()];
    let mut mass = vec![0.0; mesh.bodies.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let zone = &mesh.zones[mesh.triangle_zone[t]];
        let rho = materials
            .get(zone.material)
            .and_then(|m| m.density)
            .unwrap_or(0.0);
        let m = rho * mesh.triangle_area(t);
        mass[zone.body] += m;
        for &n in tri {
            nodal[n] += m / 3.0;
        }
    }
    mesh.bodies
        .iter()
        .enumerate()
        .map(|(b, name)| {
            let weights = if mass[b] > 0.0 {
                (0..mesh.nodes.len())
                    .filter(|&n| mesh.node_body[n] == b && nodal[n] > 0.0)
                    .map(|n| (n, nodal[n] / mass[b]))
                    .collect()
            } else {
                Vec::new()
            };
            (name.clone(), weights)
        })
        .collect()
}
