//! The front door of the engine: the one way the command line, the HTTP service and workers
//! drive it. [`solve`] runs one state solve; [`worst`] runs a worst-scenario search through its
//! phases (meshing, admissible-set check, nominal solve, screening, swarm, polish,
//! sensitivities), reporting progress, honouring the cancel flag and the time limit in every
//! phase, logging the evaluations of every chunk as it completes and replaying a log to resume. A cancelled or
//! timed-out run returns its partial outcome with its status.
//!
//! Requests and outcomes are plain serde types; failures are [`WsmError`]s whose
//! [`crate::error::ErrorKind`] maps onto HTTP statuses and exit codes.

mod control;
mod cost;
mod hash;
mod log;
mod model;
mod points;
mod remote;
mod request;
mod scenarios;
mod summary;
mod table;

pub use control::{BestSoFar, ProgressEvent, ProgressFn, RunControl, RunPhase};
pub use cost::{
    default_max_solve_memory, estimate_solve_cost, parse_bytes, CostRefusal, SolveCost,
};
pub use hash::{canonical_json, run_hash};
pub use log::{EvaluationLog, JsonLinesLog, LogHeader, LogMode, MemoryLog};
pub use model::{check_admissible_set, parameter_info, PreparedModel};
pub use points::{evaluate_points, PointAnswer, PointEvaluator};
pub use remote::{BatchDispatch, DispatchedBatch, LocalEvaluate};
pub use request::{SolveRequest, WorstRequest};
pub use scenarios::{
    scenario_series, scenario_solve, series_index, Scenario, ScenarioFields, ScenarioMissing,
};
pub use summary::summary;
pub use table::{columns as table_columns, write_csv};

pub use crate::bundled::{find as find_example, names as example_names, EXAMPLES};
pub use crate::estimate::ladder::Ladder;
pub use crate::estimate::mesh_choice::{CandidateMesh, MeshChoice};
pub use crate::estimate::statement::{
    CriterionAccuracy, ExtremumAccuracy, RefinedDispatch, RefinedFailure, RefinedLevel,
    RefinedOutcome, RefinedSolve, RefinedValues, StatementMesh,
};
pub use crate::fault::{FaultSite, SolveFault};
pub use crate::mesh::with_inline_mesh;
pub use crate::output::contact_profile::{profiles_csv, ContactProfile, PROFILE_CSV_HEADER};
pub use crate::output::pvd::{write_pvd, SeriesEntry};
pub use crate::output::result::{CriteriaValues, MeshSummary, SolveFields, SolveSummary};
pub use crate::scenario::evaluator::{Evaluation, InnerSummary};
pub use crate::scenario::worst::{CriterionOutcome, ParameterInfo, WorstOutcome};
pub use wsm_search::{
    ActiveBound, BoundProof, Certificate, ObjectiveResult, OneSided, Sense, Status, Verdict,
};

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

use crate::dynamics::{simulate_with, DisplacementFrame, Frame, FrameSink, Hooks};
use crate::error::WsmError;
use crate::estimate::ladder::scaled;
use crate::estimate::mesh_choice::choose_mesh;
use crate::estimate::statement::{
    default_refinements, refinement_factor, statement, AccuracyStatement, StatementControl,
};
use crate::fem::Par;
use crate::output::solution_grid::{solution_grid, state_grid, Motion, ScenarioLabel};
use crate::output::vtu::write_vtu;
use crate::scenario::evaluator::ScenarioEvaluator;
use crate::scenario::solvability::check_admissible_box;
use crate::scenario::worst::{self as engine, WorstSettings};
use crate::scene::params::{applied_values, apply, parameters, values, Parameter};
use crate::scene::{Scene, Warning, WarningKind};
use crate::state::{locking_warnings, Needs, SolveOptions, StateProblem};
use control::{best_so_far, phase_objective};
use remote::Dispatched;
use wsm_search::{EvalCache, Progress, SearchControl};

/// The result of [`solve`].
#[derive(Debug, Clone, serde::Serialize, utoipa::ToSchema)]
pub struct SolveOutput {
    /// The solve's summary: criteria, mesh, contact and solver report (what `wsm solve` prints).
    pub summary: SolveSummary,
    /// The fields, when requested.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fields: Option<SolveFields>,
    /// A dynamic scene's nodal displacement at every output time (t = 0 first, the times of
    /// `summary.history.times`), when requested.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frames: Option<Vec<DisplacementFrame>>,
    /// The solution as a VTU document (binary, design §5.6) for ParaView, PyVista and meshio,
    /// when fields were requested.
    #[serde(skip)]
    pub vtu: Option<String>,
}

/// One state solve of `scene` at its nominal data.
///
/// ```
/// use wsm_core::{solve, SolveRequest};
///
/// let scene = wsm_core::parse_scene(wsm_core::find_example("block-on-base")?)?;
/// let output = solve(scene, &SolveRequest::default())?;
/// // The block presses on its base: the mean contact pressure of the criteria region is positive.
/// assert!(output.summary.criteria.phi6.is_some_and(|p| p > 0.0));
/// assert!(output.summary.report.contact_pairs > 0);
/// # Ok::<(), wsm_core::WsmError>(())
/// ```
pub fn solve(scene: Scene, request: &SolveRequest) -> Result<SolveOutput, WsmError> {
    solve_at(scene, None, request)
}

/// One state solve at given values of the uncertain parameters (in the order of the scene's
/// `uncertain` list; `None`: the nominal data) — e.g. the worst scenario of a criterion. The
/// scene's warnings (`crate::scene::warnings`) come first in the report's warnings. The VTU
/// names the scenario `nominal`, or `data` at a given point.
pub fn solve_at(
    scene: Scene,
    point: Option<&[f64]>,
    request: &SolveRequest,
) -> Result<SolveOutput, WsmError> {
    solve_watched(scene, point, request, &RunControl::new(), None)
}

/// Where a dynamic solve's VTU series goes: (output index, time \[s\], VTU document) at every
/// output time, t = 0 first.
pub type SeriesSink<'a> = dyn FnMut(usize, f64, String) -> Result<(), WsmError> + 'a;

/// [`solve_at`] watched by `control`: the time steps of a dynamic scene report progress (phase
/// [`RunPhase::TimeSteps`]) and stop at the cancel flag with [`WsmError::Cancelled`]; with
/// `series`, the state at every output time goes there as a VTU document labelled with its time
/// (design §5.6), with the velocity and the peak-over-time fields up to that time.
pub fn solve_watched(
    scene: Scene,
    point: Option<&[f64]>,
    request: &SolveRequest,
    control: &RunControl,
    series: Option<&mut SeriesSink>,
) -> Result<SolveOutput, WsmError> {
    request.check(&scene)?;
    let scene = with_solver(scene, request);
    let params = parameters(&scene)?;
    if let Some(p) = point {
        check_point(p, &params)?;
    }
    let problem = StateProblem::new(scene)?;
    let (data, solution) = solve_point(&problem, &params, point)?;
    let label = scenario_label(
        &problem,
        &params,
        point,
        if point.is_some() { "data" } else { "nominal" },
    );
    let mut output = solve_output(&problem, &data, &solution, &label, request);
    if problem.scene.dynamics.is_some() {
        let start = Instant::now();
        let progress = |step: usize, steps: usize| {
            control.report(&ProgressEvent {
                phase: RunPhase::TimeSteps,
                objective: None,
                evaluations: step,
                failures: 0,
                budget: steps,
                best: Vec::new(),
                elapsed_seconds: start.elapsed().as_secs_f64(),
            });
        };
        let mut kept = request.frames.then(Vec::new);
        let watched = series.is_some() || kept.is_some();
        let mut series = series;
        let mut frames = |frame: &Frame| -> Result<(), WsmError> {
            if let Some(kept) = kept.as_mut() {
                kept.push(DisplacementFrame {
                    time: frame.t,
                    displacement: frame.displacement.to_vec(),
                });
            }
            match series.as_mut() {
                Some(sink) => sink(
                    frame.index,
                    frame.t,
                    frame_vtu(&problem, &data, &label, frame),
                ),
                None => Ok(()),
            }
        };
        let mut hooks = Hooks {
            cancel: Some(&control.cancel),
            progress: control
                .progress
                .is_some()
                .then_some(&progress as &dyn Fn(usize, usize)),
            frames: watched.then_some(&mut frames as &mut FrameSink),
        };
        output.summary.history = Some(simulate_with(&problem, &data, &mut hooks)?.history);
        output.frames = kept;
    }
    Ok(output)
}

/// The VTU document of one output time of a dynamic run: its state as a solution (contact
/// pressures, states and slips from the forces and gaps of the time) with its [`Motion`],
/// labelled `label` at its time.
fn frame_vtu(
    problem: &StateProblem,
    data: &crate::scene::Data,
    label: &ScenarioLabel,
    frame: &Frame,
) -> String {
    let mesh = problem.mesh();
    let scale = frame
        .displacement
        .iter()
        .fold(0.0_f64, |m, v| m.max(v[0].abs()).max(v[1].abs()));
    let contact = crate::contact::direct::ContactSolution {
        u_free: Vec::new(),
        multipliers: frame.forces.to_vec(),
        rigid: Vec::new(),
        gaps: frame.gaps.to_vec(),
        qp: None,
        equilibrium_residual: 0.0,
        free_motions: 0,
        qp_seconds: 0.0,
        refinements: 0,
        coulomb: None,
        sparse: None,
    };
    let (nodes, _) = crate::state::contact_results(
        &problem.contact.geometry,
        &contact,
        data,
        &mesh.nodes,
        scale,
    );
    let solution = crate::state::Solution {
        displacement: frame.displacement.to_vec(),
        stresses: frame.stresses.to_vec(),
        contact: nodes,
        ..Default::default()
    };
    let label = ScenarioLabel {
        scenario: format!("{} at t = {:e} s", label.scenario, frame.t),
        ..label.clone()
    };
    let motion = Motion {
        velocity: frame.velocity,
        peak_displacement: &frame.peaks.displacement,
        peak_i2_squared: &frame.peaks.i2_squared,
        peak_contact_pressure: &frame.peaks.contact_pressure,
    };
    write_vtu(&state_grid(problem, &solution, &label, Some(&motion)))
}

/// `scene` with the request's inner solver, if it names one.
fn with_solver(mut scene: Scene, request: &SolveRequest) -> Scene {
    if let Some(kind) = request.solver {
        scene.solver.kind = kind;
    }
    scene
}

/// A point must give one value per uncertain parameter.
fn check_point(point: &[f64], params: &[Parameter]) -> Result<(), WsmError> {
    if point.len() == params.len() {
        return Ok(());
    }
    Err(crate::scene::SceneError::new(
        "point",
        format!(
            "{} values for {} uncertain parameters",
            point.len(),
            params.len()
        ),
    )
    .into())
}

/// The data of `point` (`None`: nominal) and its solution with every field.
fn solve_point(
    problem: &StateProblem,
    params: &[Parameter],
    point: Option<&[f64]>,
) -> Result<(crate::scene::Data, crate::state::Solution), WsmError> {
    let data = match point {
        Some(p) => apply(&problem.scene, &problem.nominal, params, p),
        None => problem.nominal.clone(),
    };
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: Par::rayon(0),
        warm: None,
    };
    // A dynamic scene's summary is the static solve with the loads at t = 0.
    let solution = match problem.scene.dynamics {
        Some(_) => problem.solve(
            &crate::dynamics::data_at(&problem.scene, &data, 0.0),
            &options,
        )?,
        None => problem.solve(&data, &options)?,
    };
    Ok((data, solution))
}

/// The label of the solve of `point` (`None`: nominal) as scenario `scenario`, with the value of
/// every uncertain parameter in its data.
fn scenario_label(
    problem: &StateProblem,
    params: &[Parameter],
    point: Option<&[f64]>,
    scenario: &str,
) -> ScenarioLabel {
    let values = match point {
        Some(p) => applied_values(&problem.scene, &problem.nominal, params, p),
        None => values(&problem.nominal, params),
    };
    ScenarioLabel {
        scenario: scenario.to_string(),
        criterion: None,
        criterion_value: None,
        data: params.iter().map(|p| p.name.clone()).zip(values).collect(),
    }
}

/// The output of a solve: its summary (the scene's warnings first), and the fields and the VTU
/// labelled `label` when the request asks for fields.
fn solve_output(
    problem: &StateProblem,
    data: &crate::scene::Data,
    solution: &crate::state::Solution,
    label: &ScenarioLabel,
    request: &SolveRequest,
) -> SolveOutput {
    let mut summary = crate::output::result::summary(problem, data, solution);
    let scene_warnings = crate::scene::warnings(&problem.scene);
    summary.report.warnings.splice(0..0, scene_warnings);
    let (fields, vtu) = if request.fields {
        let grid = solution_grid(problem, solution, label);
        (
            Some(crate::output::result::fields(problem, solution)),
            Some(write_vtu(&grid)),
        )
    } else {
        (None, None)
    };
    SolveOutput {
        summary,
        fields,
        frames: None,
        vtu,
    }
}

/// The log header of a run: its hash, scene, criteria and parameter fields.
pub fn log_header(scene: &Scene, settings: &WorstSettings) -> Result<LogHeader, WsmError> {
    Ok(LogHeader::new(
        run_hash(scene, &settings.criteria, settings.target_error)?,
        scene.name.clone(),
        settings.criteria.clone(),
        scene.uncertain.iter().map(|u| u.field.clone()).collect(),
    ))
}

/// The scene a run solves: `scene` itself, or with a target error the scene on the coarsest
/// mesh meeting it (`crate::estimate::mesh_choice`), with how it was chosen. `stop` is polled
/// between the meshes tried; `fault` fails the solves where it answers (tests); a mesh whose
/// solve is estimated beyond `max_solve_bytes` ends the ladder unbuilt (design §3.1). Workers
/// call this too when the coordinator shared no scene, so every process solves the same mesh.
pub fn run_scene(
    scene: Scene,
    settings: &WorstSettings,
    stop: &dyn Fn() -> bool,
    fault: Option<&SolveFault>,
    max_solve_bytes: Option<f64>,
) -> Result<(Scene, Option<MeshChoice>), WsmError> {
    let Some(target) = settings.target_error else {
        return Ok((scene, None));
    };
    let refuse = |factor: f64| -> Option<WsmError> {
        let limit = max_solve_bytes?;
        let level = scaled(&scene, factor).ok()?;
        let refusal = estimate_solve_cost(&level).ok()?.check(limit).err()?;
        Some(refusal.into())
    };
    let (chosen, choice) = choose_mesh(
        &scene,
        &settings.criteria,
        target,
        stop,
        fault,
        Some(&refuse),
    )?;
    Ok((chosen, Some(choice)))
}

/// A worst-scenario search on `scene`: the worst and best of each requested criterion over the
/// admissible box. Runs in its own thread pool when `request.threads` is set.
pub fn worst(
    scene: Scene,
    request: &WorstRequest,
    control: &RunControl,
) -> Result<WorstOutcome, WsmError> {
    let settings = request.settings(&scene)?;
    if scene.dynamics.is_some() && settings.target_error.is_some() {
        return Err(crate::scene::SceneError::new(
            "target_error",
            "the mesh choice by a target error is built for static scenes; give a dynamic scene's mesh",
        )
        .into());
    }
    if let Some(limit) = control.max_solve_bytes {
        estimate_solve_cost(&scene)?.check(limit)?;
    }
    let params = parameters(&scene)?;
    let header = log_header(&scene, &settings)?;
    let replay = match &control.log {
        Some(log) => log.open(&header)?,
        None => Vec::new(),
    };
    let run = Run {
        control,
        settings: &settings,
        params: &params,
        start: Instant::now(),
        halt: AtomicBool::new(false),
        log_error: Mutex::new(None),
    };
    let mut outcome = match request.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| WsmError::io("thread pool", e))?
            .install(|| run.execute(scene, replay))?,
        None => run.execute(scene, replay)?,
    };
    outcome.run_hash = header.run_hash;
    Ok(outcome)
}

/// One worst-scenario run in progress.
struct Run<'a> {
    control: &'a RunControl,
    settings: &'a WorstSettings,
    params: &'a [Parameter],
    start: Instant,
    /// Raised (for the search) by a cancel request or a failed log write or dispatch.
    halt: AtomicBool,
    /// A failed log write or dispatch: the run stops with it.
    log_error: Mutex<Option<WsmError>>,
}

impl Run<'_> {
    /// Cancelled or out of time: the status to stop with.
    fn stop_status(&self) -> Option<Status> {
        if self.control.is_cancelled() || self.halt.load(Ordering::SeqCst) {
            Some(Status::Cancelled)
        } else if self
            .settings
            .max_seconds
            .is_some_and(|t| self.start.elapsed().as_secs_f64() >= t)
        {
            Some(Status::TimeLimit)
        } else {
            None
        }
    }

    fn event(&self, phase: RunPhase, evaluations: usize) -> ProgressEvent {
        ProgressEvent {
            phase,
            objective: None,
            evaluations,
            failures: 0,
            budget: self.settings.budget,
            best: Vec::new(),
            elapsed_seconds: self.start.elapsed().as_secs_f64(),
        }
    }

    /// Report a phase before the search; the status to stop with, if any.
    fn enter(&self, phase: RunPhase) -> Option<Status> {
        self.control.report(&self.event(phase, 0));
        self.stop_status()
    }

    /// A run stopped before its search started, with `status`.
    fn unstarted(&self, scene: &Scene, status: Status) -> WorstOutcome {
        WorstOutcome::unstarted(scene, self.params, self.settings, status)
    }

    /// The run's phases: mesh choice, meshing, the checks on the box, the nominal solve, the
    /// search, then the warnings and the accuracy statement.
    fn execute(&self, scene: Scene, replay: Vec<Evaluation>) -> Result<WorstOutcome, WsmError> {
        let (scene, mesh_choice) = match self.choose_scene(scene)? {
            ControlFlow::Continue(chosen) => chosen,
            ControlFlow::Break(stopped) => return Ok(stopped),
        };
        if let Some(status) = self.enter(RunPhase::Meshing) {
            return Ok(self.unstarted(&scene, status));
        }
        let model =
            PreparedModel::new(scene, self.params.to_vec(), self.settings.criteria.clone())?
                .with_derivatives(self.settings.derivatives);
        let problem = model.problem();
        if let ControlFlow::Break(stopped) = self.check_box(problem)? {
            return Ok(stopped);
        }
        let observer = |evaluations: &[Evaluation]| self.record(evaluations);
        let evaluator = model
            .evaluator()?
            .observed_by(&observer)
            .with_fault(self.control.fault.as_deref());
        if let Some(status) = self.stop_status() {
            return Ok(self.unstarted(&problem.scene, status));
        }
        let mut outcome = self.search(problem, &evaluator, replay)?;
        self.finish(problem, &mut outcome, mesh_choice)?;
        Ok(outcome)
    }

    /// With a target error: the coarsest mesh meeting it (shared with the dispatch's workers);
    /// else the scene as it is.
    fn choose_scene(
        &self,
        scene: Scene,
    ) -> Result<ControlFlow<WorstOutcome, (Scene, Option<MeshChoice>)>, WsmError> {
        if self.settings.target_error.is_none() {
            return Ok(ControlFlow::Continue((scene, None)));
        }
        if let Some(status) = self.enter(RunPhase::MeshChoice) {
            return Ok(ControlFlow::Break(self.unstarted(&scene, status)));
        }
        let stop = || self.stop_status().is_some();
        match run_scene(
            scene.clone(),
            self.settings,
            &stop,
            self.control.fault.as_deref(),
            self.control.max_solve_bytes,
        ) {
            Ok((chosen, choice)) => {
                if let Some(dispatch) = &self.control.dispatch {
                    dispatch.share_scene(&chosen)?;
                }
                Ok(ControlFlow::Continue((chosen, choice)))
            }
            Err(WsmError::Cancelled) => {
                let status = self.stop_status().unwrap_or(Status::Cancelled);
                Ok(ControlFlow::Break(self.unstarted(&scene, status)))
            }
            Err(e) => Err(e),
        }
    }

    /// The admissible-set checks on the box (contact feasibility, solvability at the vertices),
    /// then the entry into the nominal solve.
    fn check_box(&self, problem: &StateProblem) -> Result<ControlFlow<WorstOutcome>, WsmError> {
        if let Some(status) = self.enter(RunPhase::AdmissibleCheck) {
            return Ok(ControlFlow::Break(self.unstarted(&problem.scene, status)));
        }
        match check_admissible_box(problem, self.params, &|| self.stop_status().is_some()) {
            Err(WsmError::Cancelled) => {
                let status = self.stop_status().unwrap_or(Status::Cancelled);
                return Ok(ControlFlow::Break(self.unstarted(&problem.scene, status)));
            }
            other => other?,
        }
        if let Some(status) = self.enter(RunPhase::NominalSolve) {
            return Ok(ControlFlow::Break(self.unstarted(&problem.scene, status)));
        }
        Ok(ControlFlow::Continue(()))
    }

    /// The search itself, from the replayed evaluations on, through the dispatch when there is
    /// one; a failed log write or dispatch ends it with that error.
    fn search(
        &self,
        problem: &StateProblem,
        evaluator: &ScenarioEvaluator<'_>,
        replay: Vec<Evaluation>,
    ) -> Result<WorstOutcome, WsmError> {
        let mut cache = EvalCache::new();
        for evaluation in replay {
            cache.insert(evaluation.point.clone(), evaluation.outcome());
        }
        // The search's clock starts now: give it what is left of the run's time.
        let mut settings = self.settings.clone();
        settings.max_seconds = settings
            .max_seconds
            .map(|t| (t - self.start.elapsed().as_secs_f64()).max(0.0));
        let on_progress = |p: &Progress| self.search_progress(p);
        let control = SearchControl {
            cancel: &self.halt,
            on_progress: &on_progress,
        };
        let outcome = match &self.control.dispatch {
            Some(dispatch) => {
                let dispatched =
                    Dispatched::new(evaluator, dispatch.as_ref(), &self.log_error, &self.halt);
                engine::run(
                    problem,
                    self.params,
                    &settings,
                    &dispatched,
                    &|| dispatched.summary(),
                    &mut cache,
                    control,
                )?
            }
            None => engine::run(
                problem,
                self.params,
                &settings,
                evaluator,
                &|| evaluator.summary(),
                &mut cache,
                control,
            )?,
        };
        if let Some(dispatch) = &self.control.dispatch {
            dispatch.flush()?;
        }
        if let Some(error) = self
            .log_error
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
        {
            return Err(error);
        }
        Ok(outcome)
    }

    /// Warnings (the scene's own first, `crate::scene::warnings`) and, for a search that ran
    /// to its end, the accuracy statement.
    fn finish(
        &self,
        problem: &StateProblem,
        outcome: &mut WorstOutcome,
        mesh_choice: Option<MeshChoice>,
    ) -> Result<(), WsmError> {
        outcome.setup_seconds = problem.setup_seconds;
        outcome.failures.check_majority(outcome.evaluations)?;
        outcome.warnings = crate::scene::warnings(&problem.scene);
        outcome.warnings.extend(self.warnings(problem, outcome)?);
        let names: Vec<String> = outcome.parameters.iter().map(|p| p.name.clone()).collect();
        if let Some(warning) = outcome.failures.warning(outcome.evaluations, &names) {
            outcome.warnings.insert(0, warning);
        }
        let dynamic = problem.scene.dynamics.is_some();
        let over_time = crate::dynamics::derivatives_unavailable(problem);
        if let Some((field, reason)) = over_time.filter(|_| self.settings.derivatives) {
            outcome.warnings.push(Warning::new(
                WarningKind::Derivatives,
                field,
                format!("exact derivatives over time are not available ({reason}): the search ran on values alone"),
            ));
        } else if self.settings.derivatives
            && !dynamic
            && problem.contact.is_sparse()
            && problem.nominal.has_coulomb()
        {
            outcome.warnings.push(Warning::new(
                WarningKind::Derivatives,
                "solver.contact",
                format!(
                    "exact derivatives of Coulomb states are not available on the sparse contact path that this scene's {} contact pairs take (solver.contact: auto, from 1,500 pairs): the search ran on values alone; solver.contact = \"dense\" gives derivatives and local proofs at a memory cost that grows with the square of the pairs",
                    problem.contact.geometry.pairs.len()
                ),
            ));
        }
        outcome
            .warnings
            .extend(crate::scenario::unproven::warnings(outcome));
        if dynamic {
            outcome.warnings.push(Warning::new(
                WarningKind::Accuracy,
                "accuracy statement",
                "built for static scenes; a dynamic scene's values carry the discretisation error \
                 of its mesh and time step",
            ));
        }
        if !matches!(outcome.status, Status::Cancelled | Status::TimeLimit) && !dynamic {
            if let Some((statement, asked)) = self.accuracy(problem, outcome)? {
                outcome.warnings.extend(statement.warnings(asked));
                outcome.accuracy = Some(statement);
            }
        }
        if let Some(choice) = &mesh_choice {
            outcome.warnings.extend(target_warnings(choice, outcome));
        }
        outcome.mesh_choice = mesh_choice;
        let mut finished = self.event(RunPhase::Finished, outcome.evaluations);
        finished.failures = outcome.failures.count;
        self.control.report(&finished);
        Ok(())
    }

    /// The accuracy statement of a finished search (design §6, `crate::estimate::statement`),
    /// with the refinements asked for.
    fn accuracy(
        &self,
        problem: &StateProblem,
        outcome: &WorstOutcome,
    ) -> Result<Option<(AccuracyStatement, usize)>, WsmError> {
        let refinements = self
            .settings
            .accuracy_refinements
            .unwrap_or_else(|| default_refinements(problem.elastic.dofs().n_free()));
        if refinements == 0 {
            return Ok(None);
        }
        self.control
            .report(&self.event(RunPhase::Accuracy, outcome.evaluations));
        let stop = || self.stop_status().is_some();
        let refuse = |level: u32| {
            let limit = self.control.max_solve_bytes?;
            let refined = scaled(&problem.scene, refinement_factor(level)).ok()?;
            let cost = estimate_solve_cost(&refined).ok()?;
            cost.check(limit).err().map(|r| r.message)
        };
        let control = StatementControl {
            stop: &stop,
            dispatch: self
                .control
                .dispatch
                .as_deref()
                .map(|d| d as &dyn RefinedDispatch),
            fault: self.control.fault.as_deref(),
            refuse_level: Some(&refuse),
        };
        let statement = statement(
            problem,
            self.params,
            &self.settings.criteria,
            &outcome.extrema(),
            refinements,
            control,
        )?;
        Ok(Some((statement, refinements)))
    }

    /// Warnings about the result: P1 locking (ν ≥ 0.49) at the nominal, worst or best data,
    /// one per zone.
    fn warnings(
        &self,
        problem: &StateProblem,
        outcome: &WorstOutcome,
    ) -> Result<Vec<Warning>, WsmError> {
        if problem.elastic.element() == crate::scene::Element::Mixed {
            // The mixed element does not lock (design §2.7).
            return Ok(Vec::new());
        }
        let mut data = vec![problem.nominal.clone()];
        for [worst, best] in outcome.extrema() {
            for (_, point) in [worst, best].into_iter().flatten() {
                data.push(apply(&problem.scene, &problem.nominal, self.params, &point));
            }
        }
        let mut warnings: Vec<Warning> = Vec::new();
        let mut zones_warned: Vec<usize> = Vec::new();
        for d in &data {
            let coefficients = problem.elastic.coefficients(d)?;
            for (zone, w) in locking_warnings(&coefficients, problem.mesh()) {
                if !zones_warned.contains(&zone) {
                    zones_warned.push(zone);
                    warnings.push(w);
                }
            }
        }
        Ok(warnings)
    }

    /// A chunk of evaluations completed: log it; pass a cancel request on to the search.
    fn record(&self, evaluations: &[Evaluation]) {
        if let Some(log) = &self.control.log {
            if let Err(e) = log.append(evaluations) {
                let mut error = self
                    .log_error
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner);
                error.get_or_insert(e);
                self.halt.store(true, Ordering::SeqCst);
            }
        }
        if self.control.is_cancelled() {
            self.halt.store(true, Ordering::SeqCst);
        }
    }

    fn search_progress(&self, progress: &Progress) {
        let best = best_so_far(&self.settings.criteria, progress);
        let objective = phase_objective(progress.phase).and_then(|k| best.get(k).cloned());
        self.control.report(&ProgressEvent {
            phase: RunPhase::of(progress.phase),
            objective,
            evaluations: progress.evaluations,
            failures: progress.failures,
            budget: progress.budget,
            best,
            elapsed_seconds: self.start.elapsed().as_secs_f64(),
        });
        // A cancel raised by the progress callback itself stops the next batch.
        if self.control.is_cancelled() {
            self.halt.store(true, Ordering::SeqCst);
        }
    }
}

/// One warning per level of the target-error ladder that could not be built or solved: it
/// cannot be chosen, nor estimate the error of the (up to two) coarser levels that solved.
fn ladder_failure_warnings(candidates: &[CandidateMesh]) -> Vec<Warning> {
    candidates
        .iter()
        .enumerate()
        .filter_map(|(i, candidate)| {
            let error = candidate.failure.as_ref()?;
            let factor = candidate.size_factor;
            let what = match candidate.unknowns {
                0 => format!("the ladder's mesh with sizes × {factor} could not be built"),
                n => format!(
                    "the solve at the nominal data on the ladder's mesh with sizes × {factor} \
                     ({n} unknowns) failed"
                ),
            };
            let needed: Vec<String> = candidates[i.saturating_sub(2)..i]
                .iter()
                .filter(|c| c.failure.is_none())
                .map(|c| format!("× {}", c.size_factor))
                .collect();
            let meaning = match needed.len() {
                0 => "That mesh cannot be chosen.".to_string(),
                1 => format!(
                    "That mesh cannot be chosen, and the error of the mesh with sizes {} cannot \
                     be estimated with it.",
                    needed[0]
                ),
                _ => format!(
                    "That mesh cannot be chosen, and the errors of the meshes with sizes {} \
                     cannot be estimated with it.",
                    needed.join(" and ")
                ),
            };
            Some(target_error(format!("{what}: {error}. {meaning}")))
        })
        .collect()
}

/// Warnings of a run with a target error: a mesh of the ladder that failed, no mesh met the
/// target, or the accuracy statement finds a worst or best value whose estimate exceeds it (the
/// choice was made at the nominal data).
fn target_warnings(choice: &MeshChoice, outcome: &WorstOutcome) -> Vec<Warning> {
    let mut warnings = Vec::new();
    let target = choice.target_error;
    warnings.extend(ladder_failure_warnings(&choice.candidates));
    if !choice.met {
        let finest = choice.candidates.iter().map(|c| c.unknowns).max();
        let finest = finest.unwrap_or(0);
        warnings.push(target_error(format!(
            "no mesh up to {finest} unknowns met the target {target:e} at the nominal data; the \
             run used the finest one that solved (mesh sizes × {})",
            choice.size_factor
        )));
    }
    let Some(statement) = &outcome.accuracy else {
        return warnings;
    };
    for c in &statement.criteria {
        for (name, extremum) in [("worst", &c.worst), ("best", &c.best)] {
            if let Some(relative) = extremum.as_ref().and_then(|e| e.relative) {
                if relative > target {
                    warnings.push(target_error(format!(
                        "the accuracy statement estimates the {name} value of {} to \
                         {relative:.2e} relative, above the target {target:e} met at the nominal \
                         data",
                        c.criterion.name()
                    )));
                }
            }
        }
    }
    warnings
}

/// A [`WarningKind::TargetError`] warning about the mesh choice for `target_error`.
fn target_error(message: String) -> Warning {
    Warning::new(WarningKind::TargetError, "target_error", message)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(size_factor: f64, unknowns: usize, failure: Option<&str>) -> CandidateMesh {
        CandidateMesh {
            size_factor,
            unknowns,
            triangles: unknowns,
            values: vec![None],
            relative_errors: vec![None],
            meets_target: false,
            seconds: 0.0,
            failure: failure.map(str::to_string),
        }
    }

    /// The ladder of the Coulomb dam with a target error of 0.002 (docs/verification.md): the
    /// two coarsest meshes cannot be built, the finest one's Coulomb fixed point refuses.
    #[test]
    fn a_ladder_level_that_failed_is_warned_about_with_what_it_costs() {
        let ladder = [
            candidate(4.0, 0, Some("criteria.boundary_pieces[0]: zero length")),
            candidate(2.0, 0, Some("criteria.boundary_pieces[0]: zero length")),
            candidate(1.0, 4595, None),
            candidate(0.5, 14516, None),
            candidate(0.25, 51302, None),
            candidate(0.125, 191419, Some("contact solver: no convergence")),
        ];
        let texts: Vec<String> = ladder_failure_warnings(&ladder)
            .iter()
            .map(ToString::to_string)
            .collect();
        assert_eq!(
            texts,
            [
                "target_error: the ladder's mesh with sizes × 4 could not be built: \
                 criteria.boundary_pieces[0]: zero length. That mesh cannot be chosen.",
                "target_error: the ladder's mesh with sizes × 2 could not be built: \
                 criteria.boundary_pieces[0]: zero length. That mesh cannot be chosen.",
                "target_error: the solve at the nominal data on the ladder's mesh with sizes × \
                 0.125 (191419 unknowns) failed: contact solver: no convergence. That mesh cannot \
                 be chosen, and the errors of the meshes with sizes × 0.5 and × 0.25 cannot be \
                 estimated with it.",
            ]
        );
        assert!(ladder_failure_warnings(&ladder[2..5]).is_empty());
    }
}
