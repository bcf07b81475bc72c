//! Contact profiles (design §5.8): along each contact zone, against the arc length s, the
//! displacement jumps and the tractions at the node pairs — the curves the source papers plot
//! (D05 Figs. 4, 5, 8; ICCSA Figs. 4–5) — as JSON arrays and as a CSV table.
//!
//! The jumps are those of the contact conditions (design §2.4): the normal jump
//! n·(u^k − u^l), n outward of body k (positive where body k moves toward body l; the
//! unilateral condition is n·(u^k − u^l) ≤ g0), and the tangential jump t·(u^k − u^l) with
//! t = (−n_y, n_x) (the slip). The tractions are the nodal contact pressure (≥ 0 in compression)
//! and the tangential stress along t, as in the per-pair contact results.

use serde::Serialize;

use crate::state::{ContactState, Solution, StateProblem};

/// One contact zone's profile, its arrays in the order of the zone's node pairs along body k's
/// segment.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct ContactProfile {
    /// The contact zone's name.
    pub zone: String,
    /// Arc length along body k's segment from the zone's first pair \[m\].
    pub arc_length: Vec<f64>,
    /// Undeformed position of each pair (x, y) \[m\].
    pub position: Vec<[f64; 2]>,
    /// Normal displacement jump n·(u^k − u^l) \[m\].
    pub normal_jump: Vec<f64>,
    /// Tangential displacement jump t·(u^k − u^l) \[m\].
    pub tangential_jump: Vec<f64>,
    /// Contact pressure \[Pa\].
    pub pressure: Vec<f64>,
    /// Tangential contact stress along t \[Pa\].
    pub shear: Vec<f64>,
    /// Open, stick or slip.
    pub state: Vec<ContactState>,
}

/// The profile of every contact zone, in scene order (none when the solve has no contact
/// results).
pub fn contact_profiles(problem: &StateProblem, solution: &Solution) -> Vec<ContactProfile> {
    let pairs = &problem.contact.geometry.pairs;
    if solution.contact.len() != pairs.len() || solution.displacement.is_empty() {
        return Vec::new();
    }
    let u = &solution.displacement;
    problem
        .scene
        .contacts
        .iter()
        .enumerate()
        .map(|(z, contact)| {
            let mut profile = ContactProfile {
                zone: contact.name.clone(),
                arc_length: Vec::new(),
                position: Vec::new(),
                normal_jump: Vec::new(),
                tangential_jump: Vec::new(),
                pressure: Vec::new(),
                shear: Vec::new(),
                state: Vec::new(),
            };
            for (pair, node) in pairs
                .iter()
                .zip(&solution.contact)
                .filter(|(p, _)| p.zone == z)
            {
                let jump = pair.jump(u);
                let along = |d: [f64; 2]| d[0] * jump[0] + d[1] * jump[1];
                let s = match (profile.arc_length.last(), profile.position.last()) {
                    (Some(&s), Some(p)) => {
                        s + (node.position[0] - p[0]).hypot(node.position[1] - p[1])
                    }
                    _ => 0.0,
                };
                profile.arc_length.push(s);
                profile.position.push(node.position);
                profile.normal_jump.push(along(pair.normal));
                profile.tangential_jump.push(along(pair.tangent));
                profile.pressure.push(node.pressure);
                profile.shear.push(node.shear);
                profile.state.push(node.state);
            }
            profile
        })
        .collect()
}

/// The header of [`profiles_csv`].
pub const PROFILE_CSV_HEADER: &str =
    "zone,arc_length,x,y,normal_jump,tangential_jump,pressure,shear,state";

/// The profiles as CSV, one row per node pair ([`PROFILE_CSV_HEADER`]; lengths in m, stresses
/// in Pa, the zone name quoted).
pub fn profiles_csv(profiles: &[ContactProfile]) -> String {
    let mut out = format!("{PROFILE_CSV_HEADER}\n");
    for p in profiles {
        let zone = format!("\"{}\"", p.zone.replace('"', "\"\""));
        for m in 0..p.arc_length.len() {
            let state = match p.state[m] {
                ContactState::Open => "open",
                ContactState::Stick => "stick",
                ContactState::Slip => "slip",
            };
            out.push_str(&format!(
                "{zone},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{state}\n",
                p.arc_length[m],
                p.position[m][0],
                p.position[m][1],
                p.normal_jump[m],
                p.tangential_jump[m],
                p.pressure[m],
                p.shear[m],
            ));
        }
    }
    out
}
