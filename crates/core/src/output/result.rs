//! Typed renderings of a state solution: a short summary (criteria, mesh sizes, contact zones,
//! solver report) and the full result (nodal and element fields, contact results), both plain
//! serde types. The fields carry the stress measures of design §5.6 and the contact profiles of
//! design §5.8.

use std::collections::BTreeMap;

use serde::Serialize;

use super::contact_profile::{contact_profiles, ContactProfile};
use crate::fem::stress_measures::{principal, von_mises};
use crate::scene::{Criterion, Data};
use crate::state::{
    piece_pressures, region_name, zone_summaries, ContactNode, PerCriterion, Solution, SolveReport,
    StateProblem, ZoneSummary,
};

/// Φ1–Φ6 of one solve (`None`: not requested, or the scene has no region for it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize, utoipa::ToSchema)]
pub struct CriteriaValues {
    /// Φ1: largest mean temperature over the areas G_r \[K\].
    pub phi1: Option<f64>,
    /// Φ2: largest mean temperature over the boundary pieces G'_r \[K\].
    pub phi2: Option<f64>,
    /// Φ3: largest mean displacement along n(X_r) over the areas G_r that have a normal \[m\].
    pub phi3: Option<f64>,
    /// Φ4: largest mean displacement along n(X_r) over the boundary pieces G'_r \[m\].
    pub phi4: Option<f64>,
    /// Φ5: largest mean shear-stress intensity I2² over the areas G_r \[Pa²\].
    pub phi5: Option<f64>,
    /// Φ6: largest mean normal compression −n·τ·n over the areas G_r that have a normal \[Pa\].
    pub phi6: Option<f64>,
    /// √Φ5 \[Pa\]: Φ5 as a stress, the root mean square over its region of |τᴰ| = √(τᴰ:τᴰ)
    /// (I2² = τᴰ:τᴰ); the von Mises stress is √(3/2) |τᴰ|, so the region's root-mean-square
    /// von Mises stress is √(3/2) times this.
    #[serde(default)]
    pub phi5_equivalent_stress: Option<f64>,
}

impl CriteriaValues {
    /// The values from an array in the order Φ1..Φ6 (`Criterion as usize`), with √Φ5.
    pub fn new(values: &PerCriterion<Option<f64>>) -> CriteriaValues {
        CriteriaValues {
            phi1: values[0],
            phi2: values[1],
            phi3: values[2],
            phi4: values[3],
            phi5: values[4],
            phi6: values[5],
            phi5_equivalent_stress: values[4].map(f64::sqrt),
        }
    }

    /// The value of one criterion (`None` for the defined criteria, which have no maximum).
    pub fn get(&self, criterion: Criterion) -> Option<f64> {
        let values: PerCriterion<Option<f64>> = [
            self.phi1, self.phi2, self.phi3, self.phi4, self.phi5, self.phi6, None,
        ];
        values[criterion as usize]
    }
}

/// Sizes of the mesh and the algebraic problem.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct MeshSummary {
    /// Mesh nodes (contact nodes counted once per body).
    pub nodes: usize,
    /// Mesh triangles.
    pub triangles: usize,
    /// Smallest interior angle \[deg\].
    pub min_angle_deg: f64,
    /// Unknowns of the elastic problem (free displacement DOFs).
    pub unknowns: usize,
    /// Contact node pairs over all contact zones.
    pub contact_pairs: usize,
}

/// The summary of one solve (what `wsm solve` prints).
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct SolveSummary {
    /// The scene's `name`.
    pub scene: String,
    /// Mesh and problem sizes.
    pub mesh: MeshSummary,
    /// The criteria Φ1–Φ6 of the solve.
    pub criteria: CriteriaValues,
    /// Per criterion (`phi1` … `phi6`), the mean over each of its regions by name: Φ is the
    /// largest of them, and `phi3@NAME` in a search is one of them (design §4.2).
    pub region_values: BTreeMap<String, BTreeMap<String, f64>>,
    /// Per criterion, the region where it is largest (the region its value comes from).
    pub attained_in: BTreeMap<String, String>,
    /// The scene's defined criteria (`criteria.defined`) by name \[Pa\] (design §4.2).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub defined_criteria: BTreeMap<String, f64>,
    /// Resultants and open / stick / slip counts per contact zone, in scene order.
    pub contact_zones: Vec<ZoneSummary>,
    /// Mean contact pressure over each criteria boundary piece on a contact zone \[Pa\].
    pub piece_contact_pressure: BTreeMap<String, f64>,
    /// Solver report: iterations, KKT residuals (relative), warnings, timings \\[s\\].
    #[schema(value_type = Object)]
    pub report: SolveReport,
    /// Meshing and operator set-up \[s\].
    pub setup_seconds: f64,
    /// A dynamic scene's time histories (design §3.5); the rest of the summary is then the
    /// static solve with the loads at t = 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub history: Option<crate::dynamics::History>,
}

/// Nodal and element fields of one solve.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct SolveFields {
    /// Node coordinates \[m\].
    pub nodes: Vec<[f64; 2]>,
    /// Node indices of each triangle (counter-clockwise).
    pub triangles: Vec<[usize; 3]>,
    /// Zone index of each triangle.
    pub triangle_zone: Vec<usize>,
    /// Nodal displacement \[m\] (empty when no elastic solve was needed).
    pub displacement: Vec<[f64; 2]>,
    /// Nodal temperature \[K\] (when the heat problem was solved).
    pub temperature: Option<Vec<f64>>,
    /// Element stresses (τ11, τ22, τ12, τ33) \[Pa\].
    pub stress: Vec<[f64; 4]>,
    /// Element shear-stress intensity I2² \[Pa²\].
    pub i2_squared: Vec<f64>,
    /// Element von Mises stress √(3/2 I2²) \[Pa\].
    pub von_mises: Vec<f64>,
    /// Element principal stresses (σ1, σ2, σ3): the in-plane σ1 ≥ σ2 and the out-of-plane
    /// σ3 = τ33 \[Pa\]. The shear τ_xy is `stress[e][2]`.
    pub principal_stress: Vec<[f64; 3]>,
    /// Element unit direction (cos θ, sin θ) of σ1, θ ∈ (−90°, 90°] from the x axis.
    pub principal_direction: Vec<[f64; 2]>,
    /// Per contact node pair: pressure, shear, gap, slip and state.
    pub contact: Vec<ContactNode>,
    /// Per contact zone, the displacement jumps and tractions against the arc length.
    pub contact_profiles: Vec<ContactProfile>,
}

/// The summary of a solve of `data`.
pub fn summary(problem: &StateProblem, data: &Data, solution: &Solution) -> SolveSummary {
    let stats = crate::mesh::stats(problem.mesh());
    SolveSummary {
        scene: problem.scene.name.clone(),
        mesh: MeshSummary {
            nodes: stats.nodes,
            triangles: stats.triangles,
            min_angle_deg: stats.min_angle_deg,
            unknowns: solution.report.unknowns,
            contact_pairs: solution.report.contact_pairs,
        },
        criteria: CriteriaValues::new(&solution.criteria),
        region_values: Criterion::ALL
            .into_iter()
            .filter(|c| !solution.region_values[*c as usize].is_empty())
            .map(|c| {
                let values = solution.region_values[c as usize]
                    .iter()
                    .enumerate()
                    .map(|(r, &v)| (region_name(&problem.criteria, c, r).to_string(), v))
                    .collect();
                (c.name().to_string(), values)
            })
            .collect(),
        attained_in: Criterion::ALL
            .into_iter()
            .filter_map(|c| {
                let region = problem.attaining_region(solution, c)?;
                Some((c.name().to_string(), region.to_string()))
            })
            .collect(),
        defined_criteria: solution.region_values[Criterion::Defined as usize]
            .iter()
            .enumerate()
            .map(|(r, &v)| {
                let name = region_name(&problem.criteria, Criterion::Defined, r);
                (name.to_string(), v)
            })
            .collect(),
        contact_zones: zone_summaries(
            &problem.scene.contacts,
            data,
            &problem.contact.geometry,
            &solution.contact,
        ),
        piece_contact_pressure: piece_pressures(
            &problem.criteria.pieces,
            &problem.contact.geometry,
            &solution.contact,
            problem.mesh().nodes.len(),
        )
        .into_iter()
        .filter_map(|(name, p)| p.map(|p| (name, p)))
        .collect(),
        report: solution.report.clone(),
        setup_seconds: problem.setup_seconds,
        history: None,
    }
}

/// The fields of a solve.
pub fn fields(problem: &StateProblem, solution: &Solution) -> SolveFields {
    let mesh = problem.mesh();
    let principals: Vec<_> = solution
        .stresses
        .iter()
        .map(|s| principal(s.stress))
        .collect();
    SolveFields {
        nodes: mesh.nodes.clone(),
        triangles: mesh.triangles.clone(),
        triangle_zone: mesh.triangle_zone.clone(),
        displacement: solution.displacement.clone(),
        temperature: solution.temperature.clone(),
        stress: solution.stresses.iter().map(|s| s.stress).collect(),
        i2_squared: solution.stresses.iter().map(|s| s.i2_squared()).collect(),
        von_mises: solution
            .stresses
            .iter()
            .map(|s| von_mises(s.stress))
            .collect(),
        principal_stress: principals
            .iter()
            .map(|p| [p.sigma1, p.sigma2, p.sigma3])
            .collect(),
        principal_direction: principals
            .iter()
            .map(|p| [p.direction[0], p.direction[1]])
            .collect(),
        contact: solution.contact.clone(),
        contact_profiles: contact_profiles(problem, solution),
    }
}
