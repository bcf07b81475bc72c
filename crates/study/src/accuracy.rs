//! `wsm study accuracy`: error against run time (design §6 "Error against run time"). A case —
//! a scene, or the built-in manufactured solution — is solved on every level of a mesh
//! [`Ladder`] with the direct solver and with the DD solver at several tolerances; each
//! quantity's error is measured against its analytic value where the case has one (Hertz
//! half-width and peak pressure, the exact Lamé or manufactured field in L² and in energy) and
//! otherwise against the Richardson extrapolation of the direct solver's sequence
//! ([`wsm_core::extrapolate`], [`wsm_core::observed_order`]), with the observed order. The energy
//! error of a scene without an exact field comes from the extrapolated total potential energy ([`crate::energy`]).
//!
//! Times are per solve (the median of `repeats` cold solves, contact warm start off), i.e. the
//! cost of one evaluation of a worst-scenario run; meshing and operator set-up are reported
//! apart. The study runs in its own thread pool (one thread by default: the per-core cost).

use std::time::Instant;

use serde::Serialize;
use serde_json::json;

use super::analytic::{field_errors, ExactField, Hertz, LameCylinder, Manufactured};
use super::energy::energy;
use wsm_core::{
    extrapolate, fixtures::perturb_interior, fixtures::rectangle, observed_order, parse_scene,
    scaled_scene, Criterion, Extrapolation, Ladder, Needs, Par, Scene, SceneError, Solution,
    SolveOptions, SolverKind, StateProblem, WsmError,
};

/// One solver configuration of the study.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SolverChoice {
    /// The solver: direct factorisation or domain decomposition.
    pub kind: SolverKind,
    /// The DD tolerance (`None` for the direct solver).
    pub tolerance: Option<f64>,
}

impl SolverChoice {
    /// The direct solver (no tolerance); it always runs and defines the Richardson references.
    pub const DIRECT: SolverChoice = SolverChoice {
        kind: SolverKind::Direct,
        tolerance: None,
    };

    /// The DD solver with the given relative stopping tolerance.
    pub fn dd(tolerance: f64) -> SolverChoice {
        SolverChoice {
            kind: SolverKind::Dd,
            tolerance: Some(tolerance),
        }
    }

    /// "direct" or "dd 1e-6".
    pub fn label(&self) -> String {
        match self.tolerance {
            Some(t) => format!("dd {t:.0e}"),
            None => "direct".into(),
        }
    }
}

/// What the study runs.
#[derive(Debug, Clone)]
pub struct AccuracyOptions {
    /// The mesh ladder: size factor of the coarsest level, refinement ratio and number of levels.
    pub ladder: Ladder,
    /// The direct solver always runs (it defines the Richardson references); these are the DD
    /// tolerances (empty: no DD rows).
    pub dd_tolerances: Vec<f64>,
    /// Cold solves per row; the median time is reported.
    pub repeats: usize,
    /// Threads of the study's pool.
    pub threads: usize,
}

/// The analytic reference of a scene case.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Analytic {
    /// 2D Hertz contact of a cylinder on a flat: the exact contact half-width and peak pressure.
    Hertz(Hertz),
    /// Lamé's thick-walled cylinder under internal pressure: the exact displacement field.
    Lame(LameCylinder),
}

/// A study case.
#[derive(Debug, Clone)]
pub enum Case {
    /// A scene (a bundled example or a scene file), solved on scaled meshes of its own geometry.
    Scene {
        /// The case's name in reports: the example's name or the scene's own name.
        name: String,
        /// The parsed scene at size factor 1.
        scene: Box<Scene>,
        /// The analytic reference, if any; otherwise errors are measured by Richardson
        /// extrapolation.
        analytic: Option<Analytic>,
    },
    /// The manufactured solution on the unit square (structured, perturbed meshes; 16 cells a
    /// side at size factor 1).
    Manufactured(Manufactured),
}

/// The name of the built-in manufactured case.
pub const MANUFACTURED: &str = "manufactured";

impl Case {
    /// A bundled example by name (`manufactured` is the built-in manufactured solution); the
    /// `hertz` and `thick-cylinder` examples carry their analytic references.
    pub fn example(name: &str) -> Result<Case, WsmError> {
        if name == MANUFACTURED {
            return Ok(Case::Manufactured(Manufactured {
                lambda: 2.0,
                mu: 1.0,
            }));
        }
        let scene = parse_scene(wsm_core::find_example(name)?)?;
        let analytic = match name {
            "hertz" => Some(Analytic::Hertz(Hertz::from_scene(&scene)?)),
            "thick-cylinder" => Some(Analytic::Lame(LameCylinder::from_scene(&scene)?)),
            _ => None,
        };
        Ok(Case::Scene {
            name: name.into(),
            scene: Box::new(scene),
            analytic,
        })
    }

    /// A scene file's scene; `analytic` names a reference to compare with (`hertz`, `lame`).
    pub fn scene(scene: Scene, analytic: Option<&str>) -> Result<Case, WsmError> {
        let analytic = match analytic {
            None => None,
            Some("hertz") => Some(Analytic::Hertz(Hertz::from_scene(&scene)?)),
            Some("lame") => Some(Analytic::Lame(LameCylinder::from_scene(&scene)?)),
            Some(other) => {
                return Err(SceneError::new(
                    "--analytic",
                    format!("unknown analytic reference '{other}' (hertz, lame)"),
                )
                .into())
            }
        };
        Ok(Case::Scene {
            name: scene.name.clone(),
            scene: Box::new(scene),
            analytic,
        })
    }

    /// The case's name in reports (`manufactured` for the manufactured case).
    pub fn name(&self) -> &str {
        match self {
            Case::Scene { name, .. } => name,
            Case::Manufactured(_) => MANUFACTURED,
        }
    }
}

/// How a quantity's error is measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Reference {
    /// Against an analytic value.
    Analytic {
        /// The exact value of the quantity.
        value: f64,
    },
    /// Against the Richardson extrapolation of the direct solver's values.
    Richardson(Extrapolation),
    /// The measured value is already the relative error against an exact field.
    ExactField,
    /// The energy error (2 |J(u_h) − J*| / a(u, u))^½ from the extrapolated potential energy
    /// J* (and a(u, u) on the finest direct level).
    PotentialEnergy {
        /// The Richardson extrapolation J* of the direct solver's potential energies.
        j_star: Extrapolation,
        /// The strain energy a(u_h, u_h) on the finest direct level (the norm's scale).
        norm2: f64,
    },
    /// No reference could be formed (too few successful levels).
    None,
}

/// A measured quantity and its reference.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Quantity {
    /// `phi3`, `energy`, `half_width`, `L2`, ….
    pub name: String,
    /// What the quantity's errors are measured against.
    pub reference: Reference,
    /// The observed order in h of the direct solver's errors (least-squares slope; h ∝
    /// unknowns^−½).
    pub observed_order: Option<f64>,
}

/// DD iteration counts of a solve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DdIterations {
    /// PCG1 iterations of the auxiliary problem S U⁰ = F.
    pub pcg1: usize,
    /// Outer steps of the successive approximations.
    pub outer: usize,
    /// PCG2 iterations summed over all outer steps.
    pub pcg2: usize,
}

/// One level × solver of the study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// The ladder level (0 is the coarsest).
    pub level: usize,
    /// The mesh-size factor of the level (the scene's mesh sizes are multiplied by it).
    pub size_factor: f64,
    /// Free displacement degrees of freedom of the level's mesh.
    pub unknowns: usize,
    /// Triangles of the level's mesh.
    pub triangles: usize,
    /// The solver's label ("direct" or "dd 1e-6"), see [`SolverChoice::label`].
    pub solver: String,
    /// The DD tolerance (`None` for the direct solver).
    pub tolerance: Option<f64>,
    /// Meshing and operator set-up of the level \[s\].
    pub setup_seconds: f64,
    /// Median over the repeats of one cold solve \[s\].
    pub solve_seconds: f64,
    /// Iterations of the contact QP reported by the last solve (semismooth Newton steps of the
    /// direct solver, local contact iterations summed over the outer steps of the DD solver).
    pub qp_iterations: usize,
    /// The DD iteration counts of the last solve (`None` for the direct solver or after a fallback
    /// without a DD report).
    pub dd: Option<DdIterations>,
    /// The DD solver fell back to the direct one.
    pub fallback: bool,
    /// Measured values, aligned with the study's quantities.
    pub values: Vec<Option<f64>>,
    /// Relative errors, aligned with the study's quantities.
    pub errors: Vec<Option<f64>>,
    /// Why the solve failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// The cheapest row of a solver reaching an accuracy.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimeToAccuracy {
    /// The quantity's name (as in [`Quantity::name`]).
    pub quantity: String,
    /// The solver's label ("direct" or "dd 1e-6").
    pub solver: String,
    /// The relative error to reach (one of [`TARGETS`]).
    pub target: f64,
    /// The coarsest level from which on every level meets the target, with its solve time;
    /// `None` when no level does.
    pub level: Option<usize>,
    /// Free degrees of freedom of that level.
    pub unknowns: Option<usize>,
    /// Median time of one cold solve on that level \[s\].
    pub solve_seconds: Option<f64>,
    /// Meshing and operator set-up of that level \[s\].
    pub setup_seconds: Option<f64>,
    /// The error there (or the smallest error seen when the target was not reached).
    pub error: Option<f64>,
    /// The target is above the reference's own uncertainty (always for analytic references);
    /// below it the sequence cannot tell whether the target is met.
    pub resolved: bool,
}

/// The result of `wsm study accuracy`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AccuracyStudy {
    /// The case's name.
    pub case: String,
    /// Size factor of the ladder's coarsest level.
    pub ladder_coarsest: f64,
    /// Refinement in h from one ladder level to the next.
    pub ladder_ratio: f64,
    /// Threads of the study's pool.
    pub threads: usize,
    /// Cold solves per row (the median time is reported).
    pub repeats: usize,
    /// The measured quantities, in table order, with their references and observed orders.
    pub quantities: Vec<Quantity>,
    /// One row per level and solver, levels from coarsest to finest.
    pub rows: Vec<Row>,
    /// Per quantity, solver and target: the cheapest level meeting the target.
    pub time_to_accuracy: Vec<TimeToAccuracy>,
}

/// The accuracy targets of the summary table.
pub const TARGETS: [f64; 2] = [1e-2, 1e-3];

/// Run the study.
pub fn run(case: &Case, options: &AccuracyOptions) -> Result<AccuracyStudy, WsmError> {
    if options.repeats == 0 {
        return Err(SceneError::new("--repeats", "must be at least 1").into());
    }
    if let Some(t) = options
        .dd_tolerances
        .iter()
        .find(|t| !(t.is_finite() && **t > 0.0 && **t < 1.0))
    {
        return Err(SceneError::new(
            "--tolerances",
            format!("DD tolerances lie in (0, 1) (got {t})"),
        )
        .into());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.max(1))
        .build()
        .map_err(|e| WsmError::io("thread pool", e))?;
    pool.install(|| run_in_pool(case, options))
}

fn run_in_pool(case: &Case, options: &AccuracyOptions) -> Result<AccuracyStudy, WsmError> {
    let par = if options.threads <= 1 {
        Par::Seq
    } else {
        Par::rayon(0)
    };
    let solvers: Vec<SolverChoice> = std::iter::once(SolverChoice::DIRECT)
        .chain(options.dd_tolerances.iter().map(|&t| SolverChoice::dd(t)))
        .collect();
    let names = quantity_names(case);
    let mut rows = Vec::new();
    for level in 0..options.ladder.levels {
        let factor = options.ladder.factor(level);
        let start = Instant::now();
        let mut problem = LevelProblem::new(case, factor)?;
        let setup_seconds = start.elapsed().as_secs_f64();
        for solver in &solvers {
            let mut row = Row {
                level,
                size_factor: factor,
                unknowns: problem.state.elastic.dofs().n_free(),
                triangles: problem.state.mesh().triangles.len(),
                solver: solver.label(),
                tolerance: solver.tolerance,
                setup_seconds,
                solve_seconds: 0.0,
                qp_iterations: 0,
                dd: None,
                fallback: false,
                values: vec![None; names.len()],
                errors: vec![None; names.len()],
                failure: None,
            };
            match problem.measure(solver, par, options.repeats, &names) {
                Ok(m) => {
                    row.solve_seconds = m.seconds;
                    row.qp_iterations = m.qp_iterations;
                    row.dd = m.dd;
                    row.fallback = m.fallback;
                    row.values = m.values;
                }
                Err(e) => row.failure = Some(e.to_string()),
            }
            rows.push(row);
        }
    }
    let quantities = references(case, &names, &rows);
    for row in &mut rows {
        row.errors = quantities
            .iter()
            .zip(&row.values)
            .map(|(q, v)| v.and_then(|v| relative_error(&q.reference, v)))
            .collect();
    }
    let quantities: Vec<Quantity> = quantities
        .into_iter()
        .enumerate()
        .map(|(k, mut q)| {
            let (h, e): (Vec<f64>, Vec<f64>) = rows
                .iter()
                .filter(|r| r.tolerance.is_none())
                .filter_map(|r| r.errors[k].map(|e| (mesh_size(r), e)))
                .unzip();
            q.observed_order = observed_order(&h, &e);
            q
        })
        .collect();
    let time_to_accuracy = time_to_accuracy(&quantities, &rows, &solvers);
    Ok(AccuracyStudy {
        case: case.name().to_string(),
        ladder_coarsest: options.ladder.coarsest,
        ladder_ratio: options.ladder.ratio,
        threads: options.threads.max(1),
        repeats: options.repeats,
        quantities,
        rows,
        time_to_accuracy,
    })
}

/// h ∝ unknowns^−½ (relative; the units cancel in orders and extrapolations).
fn mesh_size(row: &Row) -> f64 {
    (row.unknowns.max(1) as f64).powf(-0.5)
}

/// The potential energy and the strain energy a(u, u) are measured under these names (they
/// feed the `energy` quantity of scenes without an exact field).
const POTENTIAL: &str = "J";
const STRAIN: &str = "a(u,u)";

/// The quantities a case measures, in table order.
fn quantity_names(case: &Case) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    match case {
        Case::Manufactured(_) => names.extend(["L2".to_string(), "energy".to_string()]),
        Case::Scene {
            scene, analytic, ..
        } => {
            let regions = &scene.criteria;
            let thermal = scene.thermal.is_some();
            for c in Criterion::ALL {
                let defined = match c {
                    Criterion::Phi1 => thermal && !regions.regions.is_empty(),
                    Criterion::Phi2 => thermal && !regions.boundary_pieces.is_empty(),
                    Criterion::Phi3 | Criterion::Phi6 => regions
                        .regions
                        .iter()
                        .any(|r| r.normal_at.is_some() || r.normal.is_some()),
                    Criterion::Phi4 => !regions.boundary_pieces.is_empty(),
                    Criterion::Phi5 => !regions.regions.is_empty(),
                    Criterion::Defined => false,
                };
                if defined {
                    names.push(c.name().to_string());
                }
            }
            match analytic {
                Some(Analytic::Hertz(_)) => {
                    names.extend(["half_width".to_string(), "peak_pressure".to_string()]);
                    names.push("energy".into());
                }
                Some(Analytic::Lame(_)) => names.extend(["L2".to_string(), "energy".to_string()]),
                None => names.push("energy".into()),
            }
            if !matches!(analytic, Some(Analytic::Lame(_))) {
                names.extend([POTENTIAL.to_string(), STRAIN.to_string()]);
            }
        }
    }
    names
}

/// Whether the `energy` quantity of the case is measured against an exact field.
fn exact_energy(case: &Case) -> bool {
    matches!(
        case,
        Case::Manufactured(_)
            | Case::Scene {
                analytic: Some(Analytic::Lame(_)),
                ..
            }
    )
}

/// The reference of every quantity, from the case and the direct solver's rows.
fn references(case: &Case, names: &[String], rows: &[Row]) -> Vec<Quantity> {
    let direct: Vec<&Row> = rows
        .iter()
        .filter(|r| r.tolerance.is_none() && r.failure.is_none())
        .collect();
    let sequence = |k: usize| -> (Vec<f64>, Vec<f64>) {
        direct
            .iter()
            .filter_map(|r| r.values[k].map(|v| (mesh_size(r), v)))
            .unzip()
    };
    let index = |name: &str| names.iter().position(|n| n == name);
    names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let reference = match (name.as_str(), case) {
                ("L2", _) => Reference::ExactField,
                ("energy", _) if exact_energy(case) => Reference::ExactField,
                ("energy", _) => {
                    let j = index(POTENTIAL).map(sequence);
                    let finest_norm = index(STRAIN).and_then(|s| {
                        direct
                            .iter()
                            .max_by_key(|r| r.unknowns)
                            .and_then(|r| r.values[s])
                    });
                    match (j.and_then(|(h, f)| extrapolate(&h, &f)), finest_norm) {
                        (Some(j_star), Some(norm2)) => Reference::PotentialEnergy { j_star, norm2 },
                        _ => Reference::None,
                    }
                }
                (
                    "half_width",
                    Case::Scene {
                        analytic: Some(Analytic::Hertz(h)),
                        ..
                    },
                ) => Reference::Analytic {
                    value: h.half_width(),
                },
                (
                    "peak_pressure",
                    Case::Scene {
                        analytic: Some(Analytic::Hertz(h)),
                        ..
                    },
                ) => Reference::Analytic {
                    value: h.peak_pressure(),
                },
                _ => {
                    let (h, f) = sequence(k);
                    extrapolate(&h, &f).map_or(Reference::None, Reference::Richardson)
                }
            };
            Quantity {
                name: name.clone(),
                reference,
                observed_order: None,
            }
        })
        .collect()
}

/// The relative error of a measured value (for `PotentialEnergy`, the value is J(u_h)).
fn relative_error(reference: &Reference, value: f64) -> Option<f64> {
    let rel = |r: f64| (value - r).abs() / r.abs().max(f64::MIN_POSITIVE);
    match reference {
        Reference::Analytic { value: r } => Some(rel(*r)),
        Reference::Richardson(e) => Some(rel(e.value)),
        Reference::ExactField => Some(value),
        Reference::PotentialEnergy { j_star, norm2 } => {
            Some((2.0 * (value - j_star.value).abs() / norm2.abs()).sqrt())
        }
        Reference::None => None,
    }
}

impl Reference {
    /// The relative uncertainty of the errors measured against this reference.
    pub fn uncertainty(&self) -> Option<f64> {
        match self {
            Reference::Analytic { .. } | Reference::ExactField => Some(0.0),
            Reference::Richardson(e) => e.uncertainty,
            Reference::PotentialEnergy { j_star, norm2 } => j_star
                .uncertainty
                .map(|u| (2.0 * u * j_star.value.abs() / norm2.abs()).sqrt()),
            Reference::None => None,
        }
    }
}

/// Per quantity, solver and target: the coarsest level from which on all levels meet it.
fn time_to_accuracy(
    quantities: &[Quantity],
    rows: &[Row],
    solvers: &[SolverChoice],
) -> Vec<TimeToAccuracy> {
    let mut out = Vec::new();
    for (k, quantity) in quantities.iter().enumerate() {
        let name = &quantity.name;
        if name == POTENTIAL || name == STRAIN {
            continue;
        }
        let uncertainty = quantity.reference.uncertainty();
        for solver in solvers {
            let label = solver.label();
            let series: Vec<&Row> = rows.iter().filter(|r| r.solver == label).collect();
            for target in TARGETS {
                let resolved = uncertainty.is_some_and(|u| u < target);
                let meets = |r: &&Row| r.errors[k].is_some_and(|e| e <= target);
                let first = (0..series.len()).find(|&i| series[i..].iter().all(meets));
                let entry = match first {
                    Some(i) => {
                        let r = series[i];
                        TimeToAccuracy {
                            quantity: name.clone(),
                            solver: label.clone(),
                            target,
                            level: Some(r.level),
                            unknowns: Some(r.unknowns),
                            solve_seconds: Some(r.solve_seconds),
                            setup_seconds: Some(r.setup_seconds),
                            error: r.errors[k],
                            resolved,
                        }
                    }
                    None => TimeToAccuracy {
                        quantity: name.clone(),
                        solver: label.clone(),
                        target,
                        level: None,
                        unknowns: None,
                        solve_seconds: None,
                        setup_seconds: None,
                        error: series
                            .iter()
                            .filter_map(|r| r.errors[k])
                            .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.min(e)))),
                        resolved,
                    },
                };
                out.push(entry);
            }
        }
    }
    out
}

/// What one row measured.
struct Measurement {
    seconds: f64,
    qp_iterations: usize,
    dd: Option<DdIterations>,
    fallback: bool,
    values: Vec<Option<f64>>,
}

/// One level of a case, built once for all its solver rows.
struct LevelProblem<'a> {
    case: &'a Case,
    state: StateProblem,
}

/// The unit square of the manufactured case as a scene: one body clamped on all four sides
/// (the prescribed values are replaced by the exact field's).
fn manufactured_scene(ms: &Manufactured) -> Result<Scene, WsmError> {
    let side = |a: [f64; 2], b: [f64; 2]| json!({"body": "body", "from": a, "to": b});
    let clamp = |s: &str| json!({"segment": s, "displacement": [0, 0]});
    let scene = json!({
        "version": 1, "name": MANUFACTURED,
        "bodies": [{"name": "body", "zones": [{"name": "zone", "material": "m",
            "polygon": [[0, 0], [1, 0], [1, 1], [0, 1]]}]}],
        "segments": {
            "bottom": side([0.0, 0.0], [1.0, 0.0]), "right": side([1.0, 0.0], [1.0, 1.0]),
            "top": side([1.0, 1.0], [0.0, 1.0]), "left": side([0.0, 1.0], [0.0, 0.0])
        },
        "materials": {"m": {"lambda": ms.lambda, "mu": ms.mu}},
        "boundary": [clamp("bottom"), clamp("left"), clamp("right"), clamp("top")],
        "mesh": {"max_size": 1.0 / 16.0}
    });
    Ok(parse_scene(&scene.to_string())?)
}

impl<'a> LevelProblem<'a> {
    fn new(case: &'a Case, factor: f64) -> Result<LevelProblem<'a>, WsmError> {
        let state = match case {
            Case::Scene { scene, .. } => StateProblem::new(scaled_scene(scene, factor)?)?,
            Case::Manufactured(ms) => {
                let n = ((16.0 / factor).round() as usize).max(2);
                let mut mesh = rectangle(0.0, 0.0, 1.0, 1.0, n, n);
                perturb_interior(&mut mesh, 0.15 / n as f64, 11);
                StateProblem::with_mesh(manufactured_scene(ms)?, mesh, Instant::now())?
            }
        };
        Ok(LevelProblem { case, state })
    }

    /// Solve `repeats` times with `solver`; the values of the last solve.
    fn measure(
        &mut self,
        solver: &SolverChoice,
        par: Par,
        repeats: usize,
        names: &[String],
    ) -> Result<Measurement, WsmError> {
        // The state problem reads its solver settings from its scene.
        let settings = &mut self.state.scene.solver;
        settings.kind = solver.kind;
        if let Some(t) = solver.tolerance {
            settings.tolerance = t;
        }
        let mut times = Vec::with_capacity(repeats);
        let mut last = None;
        for _ in 0..repeats {
            let start = Instant::now();
            let outcome = self.solve_once(par)?;
            times.push(start.elapsed().as_secs_f64());
            last = Some(outcome);
        }
        times.sort_by(f64::total_cmp);
        let solution = last.ok_or_else(|| WsmError::io("study", "no solve"))?;
        let report = &solution.report;
        let dd = report.dd.as_ref().map(|d| DdIterations {
            pcg1: d.pcg1_iterations,
            outer: d.outer_iterations,
            pcg2: d.pcg2_iterations,
        });
        let fallback = report.dd.as_ref().is_some_and(|d| d.fallback.is_some())
            || (solver.kind == SolverKind::Dd && report.solver != wsm_core::SolverUsed::Dd);
        Ok(Measurement {
            seconds: times[times.len() / 2],
            qp_iterations: report.qp_iterations,
            dd,
            fallback,
            values: self.values(&solution, names)?,
        })
    }

    fn solve_once(&self, par: Par) -> Result<Solution, WsmError> {
        let problem = &self.state;
        match self.case {
            Case::Scene { .. } => {
                let options = SolveOptions {
                    needs: Needs::all(&problem.scene),
                    par,
                    warm: None,
                };
                problem.solve(&problem.nominal, &options)
            }
            Case::Manufactured(ms) => manufactured_solve(problem, ms, par),
        }
    }

    fn values(&self, solution: &Solution, names: &[String]) -> Result<Vec<Option<f64>>, WsmError> {
        let problem = &self.state;
        let mesh = problem.mesh();
        let exact = match self.case {
            Case::Manufactured(ms) => Some(Box::new(*ms) as Box<dyn ExactField>),
            Case::Scene {
                analytic: Some(Analytic::Lame(l)),
                ..
            } => Some(Box::new(*l) as Box<dyn ExactField>),
            _ => None,
        };
        let field = match &exact {
            Some(f) => {
                let coefficients = problem.elastic.coefficients(&problem.nominal)?;
                let lame = |t: usize| {
                    // The analytic cases are isotropic: λ = d12 and μ = d33 of D.
                    let [_, l, _, _, _, m] = coefficients[mesh.triangle_zone[t]];
                    (l, m)
                };
                Some(field_errors(
                    mesh,
                    &solution.displacement,
                    f.as_ref(),
                    &lame,
                ))
            }
            None => None,
        };
        let hertz = match self.case {
            Case::Scene {
                analytic: Some(Analytic::Hertz(h)),
                ..
            } => Some(
                h.measure(
                    solution
                        .contact
                        .iter()
                        .zip(&problem.contact.geometry.pairs)
                        .map(|(c, p)| (c.position, c.pressure, p.weight)),
                ),
            ),
            _ => None,
        };
        let potential = match self.case {
            Case::Scene { .. } if field.is_none() => {
                Some(energy(problem, &problem.nominal, solution)?)
            }
            _ => None,
        };
        Ok(names
            .iter()
            .map(|name| match name.as_str() {
                "L2" => field.map(|f| f.relative_l2()),
                "energy" => match (field, potential) {
                    (Some(f), _) => Some(f.relative_energy()),
                    (None, Some(e)) => Some(e.potential()),
                    _ => None,
                },
                "half_width" => hertz.map(|h| h.0),
                "peak_pressure" => hertz.map(|h| h.1),
                POTENTIAL => potential.map(|e| e.potential()),
                STRAIN => potential.map(|e| e.strain),
                other => Criterion::parse(other).and_then(|c| solution.criteria[c as usize]),
            })
            .collect())
    }
}

/// The manufactured problem solved with its body force and boundary values (not expressible as
/// scene data): the same operators, contact-free direct or DD solve as a scene solve.
fn manufactured_solve(
    problem: &StateProblem,
    ms: &Manufactured,
    par: Par,
) -> Result<Solution, WsmError> {
    let elastic = &problem.elastic;
    let mesh = problem.mesh();
    let data = &problem.nominal;
    let coefficients = elastic.coefficients(data)?;
    let exact: Vec<[f64; 2]> = mesh.nodes.iter().map(|&p| ms.u(p)).collect();
    let fixed = elastic.dofs().fixed_values_from(&exact)?;
    let rhs = elastic.rhs_with(&coefficients, &ms.loads(mesh), &fixed)?;
    let mut solution = Solution::default();
    let start = Instant::now();
    let u_free = match problem.scene.solver.kind {
        SolverKind::Direct => {
            let factor = problem.contact.factor(elastic, &coefficients, par)?;
            problem
                .contact
                .solve(&factor, elastic, &rhs, &fixed, data, None)?
                .u_free
        }
        SolverKind::Dd => {
            let options = wsm_core::dd_scene_options(&problem.scene, mesh);
            let (sol, dd) = wsm_core::dd_solve_elastic(
                elastic,
                &problem.contact,
                wsm_core::LoadCase {
                    data,
                    coefficients: &coefficients,
                    rhs: &rhs,
                    fixed: &fixed,
                },
                &options,
                None,
            )
            .map_err(|e| WsmError::contact(format!("domain decomposition: {e}")))?;
            solution.report.solver = wsm_core::SolverUsed::Dd;
            solution.report.dd = Some(Box::new(dd.report));
            sol.u_free
        }
    };
    solution.displacement = elastic.dofs().expand(&u_free, &fixed);
    solution.report.timings.total = start.elapsed().as_secs_f64();
    Ok(solution)
}
