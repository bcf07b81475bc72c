//! Helpers shared by the tests that solve scenes in-process with either inner solver
//! (dd_vs_direct, coulomb, knee_papers, mortar), and the data builders of the tests that
//! assemble FEM problems by hand (anisotropy here; tests/fem_verification.rs and
//! tests/mixed_element.rs of the root package include this file by path).

#![allow(dead_code)] // each test binary uses its own subset

use serde_json::{json, Value};
use wsm_core::{
    parse_scene, BoundaryData, BoundaryValue, Data, Elastic, ElasticProblem, Expansion,
    MaterialData, Mesh, Needs, Par, Solution, SolveOptions, SolverKind, StateProblem,
};

/// Solve `scene` at its nominal data with `kind` (DD tolerance 1e-12), sequentially.
pub fn solve(scene: &Value, kind: SolverKind) -> (StateProblem, Solution) {
    let mut scene = parse_scene(&scene.to_string()).unwrap();
    scene.solver.kind = kind;
    scene.solver.tolerance = 1e-12;
    let problem = StateProblem::new(scene).unwrap();
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm_core::Par::Seq,
        warm: None,
    };
    let sol = problem.solve(&problem.nominal, &options).unwrap();
    (problem, sol)
}

/// ‖a − b‖ / ‖a‖ over all nodal displacements.
pub fn relative_difference(a: &Solution, b: &Solution) -> f64 {
    let norm = a
        .displacement
        .iter()
        .map(|u| u[0] * u[0] + u[1] * u[1])
        .sum::<f64>()
        .sqrt();
    let diff = a
        .displacement
        .iter()
        .zip(&b.displacement)
        .map(|(x, y)| (x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2))
        .sum::<f64>()
        .sqrt();
    diff / norm
}

/// The bundled Hertz scene's analytic answer and what a solve gives for it.
pub struct HertzMeasures {
    /// Hertz's half-width a = 2 √(P R / (π E*)) and peak pressure p0 = 2P / (π a).
    pub exact: (f64, f64),
    /// The applied load P [N/m].
    pub load: f64,
    /// Σ λ_n over the pairs (the cylinder floats in y: equal to P).
    pub total: f64,
    /// Half-width from the second moment of the pressure: ∫x²p = p0 π a³/8, ∫p = π a p0/2.
    pub half_width: f64,
    /// Largest nodal pressure.
    pub peak: f64,
}

/// The load of the bundled Hertz scene: P = 4 m × 2.5e8 Pa \[N/m\].
pub const HERTZ_LOAD: f64 = 4.0 * 2.5e8;

/// Hertz's half-width a = 2 √(P R / (π E*)) and peak pressure p0 = 2P / (π a) of the bundled
/// Hertz scene (R = 0.5 m, two steel bodies: E* = E / (2 (1 − ν²))).
pub fn hertz_exact() -> (f64, f64) {
    let e_star = 2.0e11 / (2.0 * (1.0 - 0.3 * 0.3));
    let a = 2.0 * (HERTZ_LOAD * 0.5 / (std::f64::consts::PI * e_star)).sqrt();
    (a, 2.0 * HERTZ_LOAD / (std::f64::consts::PI * a))
}

/// Measure a solve of the bundled Hertz scene (R = 0.5 m, P = 4 m × 2.5e8 Pa, steel).
pub fn hertz_measures(problem: &StateProblem, sol: &Solution) -> HertzMeasures {
    let (load, (a_exact, p0_exact)) = (HERTZ_LOAD, hertz_exact());
    let forces: Vec<f64> = sol
        .contact
        .iter()
        .zip(&problem.contact.geometry.pairs)
        .map(|(c, p)| c.pressure * p.weight)
        .collect();
    let total: f64 = forces.iter().sum();
    let m2: f64 = sol
        .contact
        .iter()
        .zip(&forces)
        .map(|(c, f)| c.position[0].powi(2) * f)
        .sum();
    HertzMeasures {
        exact: (a_exact, p0_exact),
        load,
        total,
        half_width: (4.0 * m2 / total).sqrt(),
        peak: sol.contact.iter().map(|c| c.pressure).fold(0.0, f64::max),
    }
}

/// Two stacked blocks of width 1: `lower` [0,1]×[0,0.5] on a roller floor, `upper`
/// [0,1]×[0.5,1] held only by contact (floating in y), rollers on both left sides, matching
/// nodes along the interface.
pub fn stacked_blocks(pressure: f64, slip_limit: f64, h: f64) -> Value {
    json!({
        "version": 1, "name": "stacked blocks",
        "bodies": [
            {"name": "lower", "zones": [{"name": "lower", "material": "m", "polygon": [[0,0],[1,0],[1,0.5],[0,0.5]]}]},
            {"name": "upper", "zones": [{"name": "upper", "material": "m", "polygon": [[0,0.5],[1,0.5],[1,1],[0,1]]}]}
        ],
        "segments": {
            "floor": {"body": "lower", "from": [0,0], "to": [1,0]},
            "lower_left": {"body": "lower", "from": [0,0.5], "to": [0,0]},
            "upper_left": {"body": "upper", "from": [0,1], "to": [0,0.5]},
            "top": {"body": "upper", "from": [1,1], "to": [0,1]},
            "lower_top": {"body": "lower", "from": [0,0.5], "to": [1,0.5]},
            "upper_bottom": {"body": "upper", "from": [0,0.5], "to": [1,0.5]}
        },
        "materials": {"m": {"E": 2.0e10, "nu": 0.3}},
        "boundary": [
            {"segment": "floor", "roller": {}},
            {"segment": "lower_left", "roller": {}},
            {"segment": "upper_left", "roller": {}},
            {"segment": "top", "pressure": pressure}
        ],
        "contacts": [{"name": "c", "between": ["upper_bottom", "lower_top"], "slip_limit": slip_limit}],
        "mesh": {"max_size": h}
    })
}

/// The stacked blocks meshed on their own and coupled by mortar: the lower at size h, the upper
/// `ratio` times finer along the interface.
pub fn stacked_blocks_mortar(pressure: f64, slip_limit: f64, h: f64, ratio: f64) -> Value {
    let mut v = stacked_blocks(pressure, slip_limit, h);
    v["name"] = json!("stacked blocks, non-matching");
    v["contacts"][0]["coupling"] = json!("mortar");
    v["mesh"]["refine"] = json!([{"segments": ["upper_bottom"], "max_size": h / ratio}]);
    v
}

/// Material data with the elastic law `elastic`: no weight, body force, heat source or
/// expansion, unit isotropic conductivity.
pub fn material(elastic: Elastic) -> MaterialData {
    MaterialData {
        elastic,
        specific_weight: 0.0,
        body_force: [0.0, 0.0],
        conductivity: [1.0, 0.0, 1.0],
        heat_source: 0.0,
        expansion: Expansion::Beta(0.0),
    }
}

/// The boundary condition `value` on the mesh's segment named `segment`.
pub fn bc(mesh: &Mesh, segment: &str, value: BoundaryValue) -> BoundaryData {
    BoundaryData {
        segment: mesh.segment_index(segment).expect("segment exists"),
        value,
    }
}

/// Data of `materials` and `boundary`: no contact data, reference temperature 0, no dynamic data.
pub fn data(materials: Vec<MaterialData>, boundary: Vec<BoundaryData>) -> Data {
    Data {
        materials,
        boundary,
        slip: Vec::new(),
        friction: Vec::new(),
        reference_temperature: 0.0,
        dynamic: Default::default(),
    }
}

/// The patch test's solve on `mesh` with the data `d` (no loads, every node `d` clamps
/// prescribed): the linear field u = (0.1 + 0.02x − 0.03y, −0.05 + 0.01x + 0.04y) on the clamped
/// nodes. Returns the problem, the FEM displacement and the exact field at the nodes, which a
/// consistent element reproduces to rounding.
pub fn linear_patch_solve(mesh: &Mesh, d: &Data) -> (ElasticProblem, Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let problem = ElasticProblem::new(mesh, d).unwrap();
    let exact = |p: [f64; 2]| {
        [
            0.1 + 0.02 * p[0] - 0.03 * p[1],
            -0.05 + 0.01 * p[0] + 0.04 * p[1],
        ]
    };
    let field: Vec<[f64; 2]> = mesh.nodes.iter().map(|&p| exact(p)).collect();
    let fixed = problem.dofs().fixed_values_from(&field).unwrap();
    let factor = problem.factor(d, Par::Seq).unwrap();
    let zero = vec![[0.0; 2]; mesh.nodes.len()];
    let u = problem.solve_with(&factor, &zero, &fixed).unwrap();
    (problem, u, field)
}

/// The largest |component| of a vector field.
pub fn max_abs(v: &[[f64; 2]]) -> f64 {
    v.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()))
}
