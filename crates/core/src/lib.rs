//! wsm-core — the numerical engine of `wsm`: worst-scenario analysis of multibody elastic contact
//! with Tresca friction, and its front door.
//!
//! The pipeline, one module each, every module using only those before it (a test keeps it so:
//! `layering`), after the private `memo` (a small value cache): `scene` (the JSON
//! document and its validation: the crate `wsm-scene`, which needs no numerics library and so
//! compiles beside faer) → `mesh` (P1 triangles, contact node pairs) → `fixtures` (structured meshes
//! and the seeded random generator for tests, studies and benchmarks) → `fem` (elasticity
//! and heat operators, loads, stresses) → `error` (the engine's error type, over the scene and
//! FEM errors and the search's) → `fault` (injected solve failures, for the tests of how runs
//! report them) → `bundled` (the example scenes) → `contact` (the exact direct contact solver) →
//! `dd` (the papers' domain decomposition solver) → `regions` (the criteria's areas and boundary
//! pieces as exact weights) → `state` (one state solve and its criteria) → `dynamics` (dynamic
//! viscoelastic contact: time stepping from rest or the static state, histories) → `output`
//! (result documents, the VTU writer) → `estimate` (discretisation-error estimates: mesh
//! ladders, Richardson extrapolation, the accuracy statement of a result, the mesh choice for a
//! target error) → `scenario` (admissible-set checks, the physics evaluator and the engine around
//! the generic search of the `wsm-search` crate) → `run` (the front door: typed requests,
//! outcomes, progress, cancellation and evaluation logs, shared by the command line, the service
//! and workers).
//!
//! The modules are private; what the crate offers is the curated set of re-exports below, in
//! three groups. **The front door** — the typed requests and outcomes of `run`, the scene document
//! of `scene` and the errors of `error` — is all the service, the binary and the Python package
//! use (a test keeps it so: `front_door`). **The engine's stages** — the contact QP, the FEM
//! operators, the mesh, the state solve and its derivatives, the DD solver, time stepping, the
//! estimates — serve the studies (`wsm-study`) and the engine's own tests. **Their types** —
//! reports, histories, options — are named last.
//!
//! Two cargo features add what is not the engine: `fixtures` (the `fixtures` module: structured
//! meshes and the seeded random generator of the tests and studies) and `bench` (the `bench`
//! drivers of `wsm bench`, with `fixtures`). Both are off by default; `wsm-study` and the tests
//! turn them on.
//!
//! The crate depends on no service crate (tokio, axum, sqlx, tower, rust-embed): the service
//! (`wsm-service`) and the studies (`wsm-study`) use it through its public items.

mod bundled;
mod contact;
mod dd;
mod dynamics;
mod error;
mod estimate;
mod fault;
mod fem;
#[cfg(feature = "fixtures")]
pub mod fixtures;
mod memo;
mod mesh;
mod output;
mod regions;
mod run;
mod scenario;
mod state;

// The scene document is its own crate (it needs no numerics library, so it compiles beside
// faer); the engine names it `scene` as before.
use wsm_scene as scene;

#[cfg(test)]
mod layering;

// The front door: requests, outcomes, progress, logs and examples (`run`), the scene document
// (`scene`) and the errors (`error`).
pub use error::{ErrorKind, SolverStage, WsmError};
pub use run::{
    canonical_json, check_admissible_set, default_max_solve_memory, estimate_solve_cost,
    evaluate_points, example_names, find_example, log_header, parameter_info, parse_bytes,
    profiles_csv, run_hash, run_scene, scenario_series, scenario_solve, series_index, solve,
    solve_at, solve_watched, summary, table_columns, with_inline_mesh, worst, write_csv, write_pvd,
    ActiveBound, BatchDispatch, BestSoFar, BoundProof, CandidateMesh, Certificate, ContactProfile,
    CostRefusal, CriteriaValues, CriterionAccuracy, CriterionOutcome, DispatchedBatch, Evaluation,
    EvaluationLog, ExtremumAccuracy, FaultSite, InnerSummary, JsonLinesLog, Ladder, LocalEvaluate,
    LogHeader, LogMode, MemoryLog, MeshChoice, MeshSummary, ObjectiveResult, OneSided,
    ParameterInfo, PointAnswer, PointEvaluator, PreparedModel, ProgressEvent, ProgressFn,
    RefinedDispatch, RefinedFailure, RefinedLevel, RefinedOutcome, RefinedSolve, RefinedValues,
    RunControl, RunPhase, Scenario, ScenarioFields, ScenarioMissing, Sense, SeriesEntry,
    SeriesSink, SolveCost, SolveFault, SolveFields, SolveOutput, SolveRequest, SolveSummary,
    StatementMesh, Status, Verdict, WorstOutcome, WorstRequest, EXAMPLES, PROFILE_CSV_HEADER,
};
pub use scene::dynamics::output_count as dynamic_output_count;
pub use scene::params::{
    apply as apply_parameters, parameters as scene_parameters, stencil as parameter_stencil,
    Parameter, Stencil,
};
pub use scene::{
    check_criteria_list, is_defined_name, objects_where_objects, parse as parse_scene,
    plain_message, scene_schema, scene_schema_json, strict_value, validate as validate_scene,
    warnings as scene_warnings, AbsorbingLayer, Body, BoundaryCondition, BoundaryData,
    BoundaryPiece, BoundaryValue, Conductivity, Contact, ContactKind, ContactMethod, ContactSolver,
    CoulombAcceleration, Coupling, CriteriaRegions, Criterion, CriterionRegion, CriterionSpec,
    Data, DdCoarse, DdIteration, DdPcg1, DdSettings, DdWeights, DefinedCriterion, DefinedQuantity,
    Driven, DynamicData, Dynamics, Elastic, Element, Expansion, Hydrostatic, HydrostaticData,
    InitialGap, InitialState, InlineMesh, Material, MaterialData, MeshControls, Orthotropic,
    PlaneStrainLaw, Point, PointLoad, Receiver, Refinement, Roller, Scene, SceneError,
    SearchSettings, Segment, SlipData, SlipLimit, SolverKind, SolverSettings, StopRule,
    StrictError, Thermal, ThermalStress, TimeFunction, TimeScheme, Uncertain, Warning, WarningKind,
    Zone, MAX_COORDINATE, MAX_NAME, MAX_SPECIFIC_WEIGHT, MAX_SUBDIVIDE, MAX_SURFACE_LOAD, MAX_TEXT,
    MIN_SOLID_MODULUS, SCENE_SCHEMA_DIALECT,
};

// The engine's stages, for the studies and the engine's own tests: the bundled scenes, the
// contact QP, the FEM operators, the mesh, the DD solver, time stepping, the state solve and its
// derivatives, the result documents, the estimates and the worst-scenario engine.
pub use bundled::example;
pub use contact::coulomb::TOLERANCE as COULOMB_TOLERANCE;
pub use contact::qp::{
    kkt_residuals, solve_box_qp, BoxQp, KktResiduals, QpError, QpMethod, QpOptions, QpSolution,
    WarmStart,
};
pub use contact::LoadCase;
pub use dd::{scene_options as dd_scene_options, solve_elastic as dd_solve_elastic};
pub use dynamics::{simulate, solve_over_time};
pub use estimate::ladder::scaled as scaled_scene;
pub use estimate::richardson::{extrapolate, observed_order, Extrapolation};
pub use estimate::statement::refinement_factor;
pub use fem::stress::element_displacements;
pub use fem::stress_measures::principal as principal_stresses;
pub use fem::{ElasticProblem, FemError, HeatProblem, Par, Symbolic, TriangleGradients};
pub use mesh::{generate as generate_mesh, stats as mesh_stats, Mesh, MeshSegment};
pub use output::result::{fields as result_fields, summary as result_summary};
pub use scenario::evaluator::ScenarioEvaluator;
pub use scenario::worst::{run as run_worst_scenario, WorstSettings};
pub use state::{
    piece_pressures, zone_summaries, ContactNode, ContactState, DerivativeRoute, Needs,
    PerCriterion, Solution, SolveOptions, SolverUsed, StateProblem, Target, Timings,
};

// The types the items above return or take: result documents and reports (the state solve's,
// the contact solvers', the DD solver's, time stepping's histories, the accuracy statement, the
// failed evaluations of a run), the mesh's parts and the DD solver's options.
pub use contact::coulomb::CoulombReport;
pub use contact::direct::SparseReport;
pub use dd::{
    CoarseKind, D03Bound, DdError, DdOptions, DdReport, DdSolution, DdTimes, OuterIteration,
    PartitionRequest, Pcg1Preconditioner,
};
pub use dynamics::{
    BodyHistory, CriterionPeak, DisplacementFrame, DynamicsReport, EnergyHistory, History, Peak,
    PeakFields, Peaks, ReceiverHistory, ZoneHistory,
};
pub use estimate::statement::AccuracyStatement;
pub use fem::stress_measures::Principal;
pub use fem::ElementStress;
pub use mesh::{MeshContact, MeshStats, MeshZone, MortarRow};
pub use scenario::failures::{FailedEvaluation, FailureSummary};
pub use state::{ContactKkt, SolveReport, ZoneSummary};

/// The drivers of `wsm bench` (cargo feature `bench`): the FEM assembly and factorisation
/// timings and the DD solver's scalability tables.
#[cfg(feature = "bench")]
pub mod bench {
    pub use crate::dd::bench::scalability as dd_scalability;
    pub use crate::fem::bench::{elastic_benchmark, ElasticTimings};
}
