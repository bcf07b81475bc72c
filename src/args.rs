//! The command line's arguments, one clap `Args` struct per command, and their conversions into
//! the requests and configurations of the crates' front doors (`wsm_core::WorstRequest`,
//! `wsm_core::SolveRequest`, `wsm_service::server`, `wsm_study`).

use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, ValueEnum};

use wsm_core::{
    CriterionSpec, SceneError, SolveRequest, SolverKind, StopRule, WorstRequest, WsmError,
};
use wsm_service::api::{Access, Limits};
use wsm_service::http::ConnectionLimits;
use wsm_service::jobs::runner::{FaultRule, FaultSolves};
use wsm_service::server::{ServeConfig, WorkerConfig};
use wsm_study::accuracy::AccuracyOptions;

/// The inner solver named on the command line.
#[derive(Clone, Copy, ValueEnum)]
pub enum SolverArg {
    Direct,
    Dd,
}

impl From<SolverArg> for SolverKind {
    fn from(solver: SolverArg) -> SolverKind {
        match solver {
            SolverArg::Direct => SolverKind::Direct,
            SolverArg::Dd => SolverKind::Dd,
        }
    }
}

/// `--stop`: when the search may stop before its budget is spent.
#[derive(Clone, Copy, ValueEnum)]
pub enum StopArg {
    /// Spend the whole budget looking for other local optima.
    Budget,
    /// Stop once every vertex is screened and few local optima are estimated unseen (default).
    GlobalRule,
    /// Stop at the first locally certified extremum (fast; nothing global).
    FirstCertificate,
}

impl From<StopArg> for StopRule {
    fn from(stop: StopArg) -> StopRule {
        match stop {
            StopArg::Budget => StopRule::Budget,
            StopArg::GlobalRule => StopRule::GlobalRule,
            StopArg::FirstCertificate => StopRule::FirstCertificate,
        }
    }
}

/// Where the scene comes from: a file, or a bundled example.
#[derive(Args)]
pub struct SceneArgs {
    /// Scene file (JSON).
    pub scene: Option<PathBuf>,
    /// Use a bundled example scene instead of a file.
    #[arg(long)]
    pub example: Option<String>,
}

/// The memory limit of the commands that solve.
#[derive(Args)]
pub struct MemoryArgs {
    /// Refuse (exit status 2), before meshing, a scene whose solve is estimated to need more
    /// memory than this: bytes, or 512M, 12G, 1.5T (default: half the machine's memory).
    #[arg(long, value_name = "BYTES", value_parser = wsm_core::parse_bytes)]
    pub max_solve_memory: Option<u64>,
}

impl MemoryArgs {
    /// The limit in bytes: the flag's value or the machine's default share.
    pub fn limit(&self) -> u64 {
        self.max_solve_memory
            .unwrap_or_else(wsm_core::default_max_solve_memory)
    }
}

/// `wsm evaluate`.
#[derive(Args)]
pub struct EvaluateArgs {
    #[command(flatten)]
    pub input: SceneArgs,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// Criteria, e.g. phi3,phi5 (default: the scene's `search.criteria`).
    #[arg(long, value_delimiter = ',')]
    pub criteria: Vec<String>,
    /// Values only, without the exact derivatives.
    #[arg(long)]
    pub no_derivatives: bool,
}

impl TryFrom<&EvaluateArgs> for WorstRequest {
    type Error = WsmError;

    fn try_from(args: &EvaluateArgs) -> Result<WorstRequest, WsmError> {
        Ok(WorstRequest {
            criteria: parse_criteria(&args.criteria)?,
            derivatives: args.no_derivatives.then_some(false),
            ..WorstRequest::default()
        })
    }
}

/// `wsm solve`.
#[derive(Args)]
pub struct SolveArgs {
    #[command(flatten)]
    pub input: SceneArgs,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// Inner solver (default: the scene's choice).
    #[arg(long, value_enum)]
    pub solver: Option<SolverArg>,
    /// Write the full result (fields, contact results) as JSON.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write a VTU file (binary) for ParaView, PyVista and meshio: fields, stress tensor and
    /// measures, contact zones as line cells, the scenario in its field data.
    #[arg(long)]
    pub vtu: Option<PathBuf>,
    /// Write the contact profiles as CSV: per contact zone and node pair, the arc length, the
    /// normal and tangential displacement jumps and the contact pressure and shear.
    #[arg(long)]
    pub profiles: Option<PathBuf>,
}

impl From<&SolveArgs> for SolveRequest {
    fn from(args: &SolveArgs) -> SolveRequest {
        SolveRequest {
            solver: args.solver.map(SolverKind::from),
            fields: false,
            frames: false,
        }
    }
}

/// `wsm worst`.
#[derive(Args)]
pub struct WorstArgs {
    #[command(flatten)]
    pub input: SceneArgs,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// Criteria, e.g. phi3,phi5 (default: the scene's `search.criteria`).
    #[arg(long, value_delimiter = ',')]
    pub criteria: Vec<String>,
    /// Inner-solve budget (default: the scene's).
    #[arg(long)]
    pub budget: Option<usize>,
    /// Random seed (default: the scene's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Wall-time limit of the run (seconds); the partial result is returned with status time_limit.
    #[arg(long)]
    pub max_seconds: Option<f64>,
    /// Threads of the run's own pool (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Refined meshes of the accuracy statement: 0, 1 or 2 (default: 2 for small meshes,
    /// else 1; an imported Gmsh mesh is not refined, and 1 or 2 are refused for it).
    #[arg(long)]
    pub accuracy_refinements: Option<usize>,
    /// Relative error (e.g. 0.01) the mesh must meet: the run takes the coarsest of the
    /// scene's mesh sizes × 4, 2, 1, 1/2, … whose estimated error at the nominal data is
    /// within it, and reports the choice in `mesh_choice`.
    #[arg(long)]
    pub target_error: Option<f64>,
    /// Search without exact derivatives (no vertex walk, no certificates; finite-difference
    /// sensitivities): cheaper evaluations, weaker answers.
    #[arg(long)]
    pub no_derivatives: bool,
    /// When the search may stop before its budget is spent (default: the scene's
    /// `search.stop`, global-rule).
    #[arg(long, value_enum)]
    pub stop: Option<StopArg>,
    /// Write the full result as JSON.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write every evaluation, as it completes, to a new JSON-lines log.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Replay a log written by --log (recomputing nothing stored), then continue it.
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// Write one CSV row per evaluation (parameters, criteria, KKT residual, time).
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// Write the fields of the nominal, worst and best scenarios of every criterion into this
    /// directory: one binary VTU each and `scenarios.pvd`, the series for ParaView.
    #[arg(long, value_name = "DIR")]
    pub fields: Option<PathBuf>,
}

impl TryFrom<&WorstArgs> for WorstRequest {
    type Error = WsmError;

    fn try_from(args: &WorstArgs) -> Result<WorstRequest, WsmError> {
        Ok(WorstRequest {
            criteria: parse_criteria(&args.criteria)?,
            budget: args.budget,
            seed: args.seed,
            max_seconds: args.max_seconds,
            threads: args.threads,
            accuracy_refinements: args.accuracy_refinements,
            target_error: args.target_error,
            derivatives: args.no_derivatives.then_some(false),
            stop: args.stop.map(StopRule::from),
        })
    }
}

impl From<&WorstArgs> for WorstFiles {
    fn from(args: &WorstArgs) -> WorstFiles {
        WorstFiles {
            out: args.out.clone(),
            log: args.log.clone(),
            resume: args.resume.clone(),
            table: args.table.clone(),
            fields: args.fields.clone(),
        }
    }
}

/// `wsm serve`.
#[derive(Args)]
pub struct ServeArgs {
    /// Address to listen on (port 0: any free port, printed on start).
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub addr: String,
    /// SQLite database file (created and migrated on start) or postgres:// URL.
    #[arg(long, default_value = "wsm.db")]
    pub db: String,
    /// Jobs run at once by this process (0: only serve; `wsm worker` processes run them).
    #[arg(long, default_value_t = 1)]
    pub workers: usize,
    /// Threads of each job (default: all cores).
    #[arg(long)]
    pub threads_per_job: Option<usize>,
    /// A running job whose lease is not renewed for this long is resumed by another worker (seconds).
    #[arg(long, default_value_t = 30.0)]
    pub lease_seconds: f64,
    /// Largest inner-solve budget a job may ask for.
    #[arg(long, default_value_t = 100_000)]
    pub max_budget: usize,
    /// Queued and running jobs at once (beyond: 503 with Retry-After).
    #[arg(long, default_value_t = 1000)]
    pub max_active_jobs: usize,
    /// Largest estimated mesh of a job (triangles).
    #[arg(long, default_value_t = 2_000_000)]
    pub max_triangles: usize,
    /// Largest request body (bytes); a larger declared Content-Length is refused (413) before
    /// the body is read.
    #[arg(long, default_value_t = 4 << 20)]
    pub max_body_bytes: usize,
    /// A request's head (request line and headers) must arrive within this long of the
    /// connection's opening or of the previous response, else the connection is closed (seconds).
    #[arg(long, default_value_t = 10.0, value_parser = parse_seconds)]
    pub header_timeout: f64,
    /// A request's body must arrive within this long of its head, else 408 (seconds).
    #[arg(long, default_value_t = 30.0, value_parser = parse_seconds)]
    pub body_timeout: f64,
    /// Connections open at once; beyond, 503 at once (default: the file-descriptor limit less
    /// room for the store and workers, at most 4096).
    #[arg(long)]
    pub max_connections: Option<usize>,
    /// Synchronous solves (POST /v1/solve, a job's fields) at once; beyond, 503 with Retry-After
    /// (default: half the cores, 1 to 4).
    #[arg(long)]
    pub max_concurrent_solves: Option<usize>,
    /// Triangles of the largest mesh whose fields a response carries (beyond: 422 naming
    /// settings.fields).
    #[arg(long, default_value_t = 50_000)]
    pub max_field_triangles: usize,
    /// Peak memory one solve may need: bytes, or 512M, 12G (default: half the machine's
    /// memory). A scene beyond it is refused with 422 naming the mesh size to coarsen, before
    /// meshing; a job's refined accuracy levels beyond it are not built (and say so).
    #[arg(long, value_name = "BYTES", value_parser = wsm_core::parse_bytes)]
    pub max_solve_memory: Option<u64>,
    /// A job whose worker died (its lease expired) this many times fails instead of being
    /// leased again.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_attempts: u32,
    /// How long a store statement waits for a lock another process holds before it fails (the
    /// request then gets 503, the job is retried) (seconds).
    #[arg(long, default_value_t = 10.0, value_parser = parse_seconds)]
    pub store_timeout: f64,
    /// With WSM_API_TOKEN set, let anyone read jobs, scenes and results (by default reads need
    /// the token, or the read-only token WSM_READ_TOKEN).
    #[arg(long)]
    pub open_reads: bool,
    /// For the end-to-end tests of failure reporting only: `FIELD=VALUE` makes every
    /// evaluation whose uncertain FIELD exceeds VALUE fail, `refined:FIELD=VALUE` every refined
    /// solve of the accuracy statement; repeatable. Hidden from the help.
    #[arg(long, hide = true, value_parser = parse_fault_rule)]
    pub inject_failures: Vec<FaultRule>,
}

/// A positive, finite number of seconds.
fn parse_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && s > 0.0 && s <= 86_400.0 => Ok(s),
        Ok(_) => Err("must be more than 0 and at most 86400 seconds".into()),
        Err(e) => Err(e.to_string()),
    }
}

/// `[refined:]FIELD=VALUE` of `--inject-failures`.
fn parse_fault_rule(text: &str) -> Result<FaultRule, String> {
    let (solves, rule) = match text.strip_prefix("refined:") {
        Some(rest) => (FaultSolves::Refined, rest),
        None => (FaultSolves::Evaluations, text),
    };
    let (field, value) = rule
        .rsplit_once('=')
        .ok_or_else(|| "expected [refined:]FIELD=VALUE".to_string())?;
    let above = value.parse::<f64>().map_err(|e| format!("VALUE: {e}"))?;
    Ok(FaultRule {
        solves,
        field: field.to_string(),
        above,
    })
}

/// A token from the environment (unset or empty: none).
fn token_from_env(name: &str) -> Option<String> {
    std::env::var(name).ok().filter(|t| !t.is_empty())
}

impl From<ServeArgs> for ServeConfig {
    /// The bearer tokens come from the environment (`WSM_API_TOKEN`, `WSM_READ_TOKEN`), never
    /// from the arguments.
    fn from(args: ServeArgs) -> ServeConfig {
        ServeConfig {
            addr: args.addr,
            db: args.db,
            workers: args.workers,
            threads_per_job: args.threads_per_job,
            lease_seconds: args.lease_seconds,
            limits: Limits {
                max_budget: args.max_budget,
                max_active_jobs: args.max_active_jobs,
                max_triangles: args.max_triangles,
                max_body_bytes: args.max_body_bytes,
                max_concurrent_solves: args
                    .max_concurrent_solves
                    .unwrap_or_else(wsm_service::api::default_concurrent_solves)
                    .max(1),
                max_field_triangles: args.max_field_triangles,
                max_solve_memory: args
                    .max_solve_memory
                    .unwrap_or_else(wsm_core::default_max_solve_memory),
                body_timeout: Duration::from_secs_f64(args.body_timeout),
                ..Limits::default()
            },
            connections: ConnectionLimits {
                header_timeout: Duration::from_secs_f64(args.header_timeout),
                max_connections: args
                    .max_connections
                    .unwrap_or_else(wsm_service::http::default_max_connections),
            },
            store_timeout: Duration::from_secs_f64(args.store_timeout),
            max_attempts: args.max_attempts,
            inject_failures: args.inject_failures,
            access: Access {
                token: token_from_env("WSM_API_TOKEN"),
                read_token: token_from_env("WSM_READ_TOKEN"),
                open_reads: args.open_reads,
            },
        }
    }
}

/// `wsm worker`.
#[derive(Args)]
pub struct WorkerArgs {
    /// postgres:// URL (or a SQLite file shared by processes on one machine).
    #[arg(long)]
    pub db: String,
    /// Evaluation threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Jobs coordinated at once by this process.
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// A job or task whose lease is not renewed for this long is taken over (seconds).
    #[arg(long, default_value_t = 30.0)]
    pub lease_seconds: f64,
    /// A job whose worker died (its lease expired) this many times fails instead of being
    /// leased again.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_attempts: u32,
    /// How long a store statement waits for a lock another process holds before it fails (seconds).
    #[arg(long, default_value_t = 10.0, value_parser = parse_seconds)]
    pub store_timeout: f64,
    /// Peak memory one solve may need: bytes, or 512M, 12G (default: half the machine's
    /// memory). A job beyond it fails naming the mesh size to coarsen; its refined accuracy
    /// levels beyond it are not built (and say so).
    #[arg(long, value_name = "BYTES", value_parser = wsm_core::parse_bytes)]
    pub max_solve_memory: Option<u64>,
}

impl From<WorkerArgs> for WorkerConfig {
    fn from(args: WorkerArgs) -> WorkerConfig {
        WorkerConfig {
            db: args.db,
            threads: args.threads,
            jobs: args.jobs,
            lease_seconds: args.lease_seconds,
            store_timeout: Duration::from_secs_f64(args.store_timeout),
            max_attempts: args.max_attempts,
            max_solve_memory: args
                .max_solve_memory
                .unwrap_or_else(wsm_core::default_max_solve_memory),
        }
    }
}

/// `wsm bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Target numbers of unknowns (default 10000,100000; with --dynamics 2500,5000,10000).
    #[arg(long, value_delimiter = ',')]
    pub sizes: Option<Vec<usize>>,
    /// Runs per measurement (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub runs: usize,
    /// Also print the domain-decomposition scalability tables (slow); with --worst: also
    /// run the loop with the DD solver.
    #[arg(long)]
    pub dd: bool,
    /// Instead: evaluations/s of the worst-scenario loop on the tunnel, with phase shares.
    #[arg(long)]
    pub worst: bool,
    /// Inner-solve budget of each --worst run.
    #[arg(long, default_value_t = 400)]
    pub budget: usize,
    /// Instead: the cost of the exact derivatives of all criteria along all uncertain data,
    /// per evaluation on the tunnel (with / without, medians over --runs points).
    #[arg(long)]
    pub gradients: bool,
    /// Instead: the cost of an evaluation with mortar contact rows against node-to-node pairs
    /// on one mesh (equal unknowns), on the Hertz and tunnel examples (medians over --runs points).
    #[arg(long)]
    pub mortar: bool,
    /// Instead: a dynamic run of the seismic tunnel example (1000 steps with contact), total and
    /// per-step time against unknowns (medians over --runs runs).
    #[arg(long)]
    pub dynamics: bool,
}

/// `wsm example`.
#[derive(Args)]
pub struct ExampleArgs {
    pub name: Option<String>,
    #[arg(long)]
    pub list: bool,
}

/// `wsm inline-mesh`.
#[derive(Args)]
pub struct InlineMeshArgs {
    /// Scene file (JSON) with `mesh.gmsh_file` (a relative path is read beside the scene file).
    pub scene: PathBuf,
}

/// `wsm study accuracy`.
#[derive(Args)]
pub struct AccuracyArgs {
    /// Scene file (JSON).
    pub scene: Option<PathBuf>,
    /// A bundled example instead of a file (also `manufactured`: the built-in manufactured
    /// solution on the unit square).
    #[arg(long)]
    pub example: Option<String>,
    /// Compare a scene file with an analytic solution: `hertz` or `lame`.
    #[arg(long)]
    pub analytic: Option<String>,
    /// Mesh levels.
    #[arg(long, default_value_t = 5)]
    pub levels: usize,
    /// Mesh size factor of the coarsest level (relative to the scene's sizes).
    #[arg(long, default_value_t = 2.0)]
    pub coarsest: f64,
    /// Refinement in h from one level to the next.
    #[arg(long, default_value_t = std::f64::consts::SQRT_2)]
    pub ratio: f64,
    /// DD tolerances (a DD row per tolerance and level).
    #[arg(long, value_delimiter = ',', default_value = "1e-4,1e-6,1e-8")]
    pub tolerances: Vec<f64>,
    /// Only the direct solver.
    #[arg(long)]
    pub direct_only: bool,
    /// Cold solves per row (the median time is reported).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Threads (default 1: the cost per core, as in a worst-scenario run).
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Directory for NAME-accuracy.md, .csv and .svg.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

impl TryFrom<&AccuracyArgs> for AccuracyOptions {
    type Error = WsmError;

    fn try_from(args: &AccuracyArgs) -> Result<AccuracyOptions, WsmError> {
        Ok(AccuracyOptions {
            ladder: wsm_core::Ladder::new(args.coarsest, args.ratio, args.levels)?,
            dd_tolerances: if args.direct_only {
                Vec::new()
            } else {
                args.tolerances.clone()
            },
            repeats: args.repeats,
            threads: args.threads,
        })
    }
}

/// `wsm study stability`.
#[derive(Args)]
pub struct StabilityArgs {
    /// Directory for stability.md and stability.json.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `--criteria phi3,phi5@heel` (empty: the scene's criteria).
fn parse_criteria(names: &[String]) -> Result<Option<Vec<CriterionSpec>>, WsmError> {
    if names.is_empty() {
        return Ok(None);
    }
    names
        .iter()
        .enumerate()
        .map(|(i, c)| {
            CriterionSpec::parse(c)
                .map_err(|why| SceneError::new(format!("--criteria[{i}]"), why).into())
        })
        .collect::<Result<Vec<_>, WsmError>>()
        .map(Some)
}

/// Files of `wsm worst`.
pub struct WorstFiles {
    pub out: Option<PathBuf>,
    pub log: Option<PathBuf>,
    pub resume: Option<PathBuf>,
    pub table: Option<PathBuf>,
    pub fields: Option<PathBuf>,
}
