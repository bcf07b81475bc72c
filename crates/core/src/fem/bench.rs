//! Timing of the direct FEM pipeline on a structured rectangle (for `wsm bench` and reports):
//! problem build (DOFs, pattern, per-zone matrices, unit loads), symbolic analysis, numeric
//! refactorisation and solve, medians over several runs.

use std::time::Instant;

use faer::Par;

use crate::fixtures::rectangle;
use crate::scene::{BoundaryData, BoundaryValue, Data, Elastic, Expansion, MaterialData};

use super::linear::Symbolic;
use super::{ElasticProblem, FemError};

/// Median timings in seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct ElasticTimings {
    /// Free DOFs of the benchmark problem (the order of K_ff).
    pub free_dofs: usize,
    /// Nonzeros of the Cholesky factor L.
    pub factor_nnz: usize,
    /// Problem build without the symbolic analysis.
    pub assembly: f64,
    /// Symbolic analysis: fill-reducing ordering and the factor pattern.
    pub symbolic: f64,
    /// Re-assembly of K for new (λ, μ) plus numeric Cholesky.
    pub numeric: f64,
    /// Right-hand side, triangular solves and expansion to nodal u.
    pub solve: f64,
    /// (numeric + solve) / (assembly + symbolic + numeric + solve).
    pub refactor_ratio: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn seconds<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let start = Instant::now();
    let out = f();
    (out, start.elapsed().as_secs_f64())
}

/// A 4 × 1 cantilever, clamped on the left, gravity and an end traction, nx × ny cells × 2.
fn cantilever_data(mesh: &crate::mesh::Mesh, e: f64) -> Data {
    let segment = |name: &str| mesh.segment_index(name).unwrap_or_default();
    Data {
        materials: vec![MaterialData {
            elastic: Elastic::Young { e, nu: 0.3 },
            specific_weight: 2.0e4,
            body_force: [0.0; 2],
            conductivity: [1.0, 0.0, 1.0],
            heat_source: 0.0,
            expansion: Expansion::Beta(0.0),
        }],
        boundary: vec![
            BoundaryData {
                segment: segment("left"),
                value: BoundaryValue::Displacement([Some(0.0), Some(0.0)]),
            },
            BoundaryData {
                segment: segment("right"),
                value: BoundaryValue::Traction([0.0, -1.0e5]),
            },
        ],
        slip: Vec::new(),
        friction: Vec::new(),
        reference_temperature: 0.0,
        dynamic: Default::default(),
    }
}

/// Time the pipeline on an nx × ny cantilever, `runs` times, with parallelism `par` for the
/// numeric factorisation and solves.
pub fn elastic_benchmark(
    nx: usize,
    ny: usize,
    runs: usize,
    par: Par,
) -> Result<ElasticTimings, FemError> {
    let mesh = rectangle(0.0, 0.0, 4.0, 1.0, nx, ny);
    let mut samples = [Vec::new(), Vec::new(), Vec::new(), Vec::new()];
    let mut sizes = (0, 0);
    for run in 0..runs.max(1) {
        let data = cantilever_data(&mesh, 1.0e9 * (1.0 + run as f64));
        let (problem, build) = seconds(|| ElasticProblem::new(&mesh, &data));
        let problem = problem?;
        let (symbolic, analyse) = seconds(|| Symbolic::analyse(problem.operator().pattern()));
        sizes = (problem.dofs().n_free(), symbolic?.factor_nnz());
        let (factor, numeric) = seconds(|| problem.factor(&data, par));
        let factor = factor?;
        let (u, solve) = seconds(|| problem.solve(&factor, &data, None));
        u?;
        for (s, v) in samples
            .iter_mut()
            .zip([build - analyse, analyse, numeric, solve])
        {
            s.push(v);
        }
    }
    let [assembly, symbolic, numeric, solve] = samples.map(median);
    Ok(ElasticTimings {
        free_dofs: sizes.0,
        factor_nnz: sizes.1,
        assembly,
        symbolic,
        numeric,
        solve,
        refactor_ratio: (numeric + solve) / (assembly + symbolic + numeric + solve),
    })
}
