//! Helpers shared by the tests that solve scenes in-process with either inner solver
//! (tests/dd_vs_direct.rs, tests/coulomb.rs, tests/knee_papers.rs).

#![allow(dead_code)] // each test binary uses its own subset

use serde_json::Value;
use wsm_core::scene::{parse, SolverKind};
use wsm_core::state::{Needs, Solution, SolveOptions, StateProblem};

/// Solve `scene` at its nominal data with `kind` (DD tolerance 1e-12), sequentially.
pub fn solve(scene: &Value, kind: SolverKind) -> (StateProblem, Solution) {
    let mut scene = parse(&scene.to_string()).unwrap();
    scene.solver.kind = kind;
    scene.solver.tolerance = 1e-12;
    let problem = StateProblem::new(scene).unwrap();
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm_core::fem::Par::Seq,
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
