//! The history of a dynamic run (design §3.5): at the output times, u, v and a at the
//! receivers (P1 interpolation in the triangle holding the point), per contact zone the normal
//! and tangential resultants, the open/stick/slip counts and the largest penetration, and the
//! energy budget.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::contact::pairs::{normal_row, tangential_row, ContactGeometry};
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
}

/// The energy budget at the output times \[J/m\] (per unit thickness). Per step,
/// work = Δ(kinetic + strain) + viscous + contact + numerical.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct EnergyHistory {
    /// ½ vᵀ M v.
    pub kinetic: Vec<f64>,
    /// ½ uᵀ K0 u + uᵀ K_fd u_d (the elastic energy up to a constant of the prescribed values).
    pub strain: Vec<f64>,
    /// Dissipated by the Kelvin–Voigt viscosity and the absorbing layers since t = 0.
    pub viscous: Vec<f64>,
    /// Dissipated by contact and friction since t = 0: Σ λᵀ B Δu (≥ 0).
    pub contact: Vec<f64>,
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

/// The history `wsm solve` writes for a dynamic scene.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct History {
    /// Output times \[s\] (t = 0 first).
    pub times: Vec<f64>,
    /// Per receiver name.
    pub receivers: BTreeMap<String, ReceiverHistory>,
    /// Per contact zone name.
    pub contact_zones: BTreeMap<String, ZoneHistory>,
    /// The energy budget.
    pub energy: EnergyHistory,
    /// Counters.
    pub report: DynamicsReport,
    /// Per criterion the scene defines (`phi1`…), its maximum over the time steps.
    pub criteria: BTreeMap<String, CriterionPeak>,
}

/// The largest value of a criterion over the time steps (design §3.5).
#[derive(Debug, Clone, Default, PartialEq, Serialize, utoipa::ToSchema)]
pub struct CriterionPeak {
    /// max over the steps t_n (t = 0 included) of the criterion at u(t_n).
    pub value: f64,
    /// The first time where it is reached \[s\].
    pub time: f64,
    /// The region of the criterion's family where it is reached.
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
    /// B_n u + B_d u_d − g0 per multiplier row (normal rows read).
    pub gaps: &'a [f64],
    /// Energies: kinetic, strain, and the cumulative viscous, contact, work.
    pub energy: [f64; 5],
}

/// Where each receiver sits: its triangle's nodes and barycentric weights.
pub struct Recorder {
    receivers: Vec<(String, [usize; 3], [f64; 3])>,
    zones: Vec<String>,
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
                locate(mesh, r.point)
                    .map(|(tri, w)| (r.name.clone(), tri, w))
                    .ok_or_else(|| {
                        SceneError::new(format!("receivers[{i}].point"), "not inside any body")
                    })
            })
            .collect::<Result<_, _>>()?;
        Ok(Recorder {
            receivers,
            zones: scene.contacts.iter().map(|c| c.name.clone()).collect(),
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
            })
            .collect();
        for (m, p) in geometry.pairs.iter().enumerate() {
            let z = &mut zones[p.zone];
            let (ln, lt) = (s.forces[normal_row(m)], s.forces[tangential_row(m)]);
            z.normal_force[0] += ln;
            z.tangential_force[0] += lt;
            z.penetration[0] = z.penetration[0].max(s.gaps[normal_row(m)]);
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
        }
        let [kinetic, strain, viscous, contact, work] = s.energy;
        if h.energy.kinetic.is_empty() {
            self.initial_energy = kinetic + strain;
        }
        let e = &mut h.energy;
        e.kinetic.push(kinetic);
        e.strain.push(strain);
        e.viscous.push(viscous);
        e.contact.push(contact);
        e.work.push(work);
        e.numerical
            .push(work - (kinetic + strain - self.initial_energy) - viscous - contact);
    }
}

/// The triangle holding `p` and its barycentric coordinates (a point on an edge belongs to
/// the first triangle found).
pub(super) fn locate(mesh: &Mesh, p: [f64; 2]) -> Option<([usize; 3], [f64; 3])> {
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    mesh.triangles.iter().find_map(|&tri| {
        let [a, b, c] = tri.map(|n| mesh.nodes[n]);
        let area = cross(a, b, c);
        let w = [
            cross(p, b, c) / area,
            cross(a, p, c) / area,
            cross(a, b, p) / area,
        ];
        w.iter().all(|&x| x >= -1e-12).then_some((tri, w))
    })
}
