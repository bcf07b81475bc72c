//! The `wsm` command line: solve a scene, run a worst-scenario search, print bundled examples,
//! run benchmarks. Every error ends in one line on stderr and a non-zero exit status (see
//! `cli::exit_code`).

mod cli;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

use wsm_core::run::{SolveRequest, WorstRequest};

#[derive(Parser)]
#[command(
    name = "wsm",
    version,
    about = "Worst-scenario analysis of multibody elastic contact"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum SolverArg {
    Direct,
    Dd,
}

#[derive(Subcommand)]
enum Command {
    /// Solve one state problem and print a JSON summary.
    Solve {
        /// Scene file (JSON).
        scene: Option<PathBuf>,
        /// Use a bundled example scene instead of a file.
        #[arg(long)]
        example: Option<String>,
        /// Inner solver (default: the scene's choice).
        #[arg(long, value_enum)]
        solver: Option<SolverArg>,
        /// Write the full result (fields, contact results) as JSON.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Write a ParaView VTU file.
        #[arg(long)]
        vtu: Option<PathBuf>,
    },
    /// Worst-scenario search: worst and best value of each criterion over the admissible set.
    Worst {
        /// Scene file (JSON).
        scene: Option<PathBuf>,
        /// Use a bundled example scene instead of a file.
        #[arg(long)]
        example: Option<String>,
        /// Criteria, e.g. phi3,phi5 (default: the scene's `search.criteria`).
        #[arg(long, value_delimiter = ',')]
        criteria: Vec<String>,
        /// Inner-solve budget (default: the scene's).
        #[arg(long)]
        budget: Option<usize>,
        /// Random seed (default: the scene's).
        #[arg(long)]
        seed: Option<u64>,
        /// Wall-time limit of the run [s]; the partial result is returned with status time_limit.
        #[arg(long)]
        max_seconds: Option<f64>,
        /// Threads of the run's own pool (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Refined meshes of the accuracy statement: 0, 1 or 2 (default: 2 for small meshes,
        /// else 1).
        #[arg(long)]
        accuracy_refinements: Option<usize>,
        /// Relative error (e.g. 0.01) the mesh must meet: the run takes the coarsest of the
        /// scene's mesh sizes × 4, 2, 1, 1/2, … whose estimated error at the nominal data is
        /// within it, and reports the choice in `mesh_choice`.
        #[arg(long)]
        target_error: Option<f64>,
        /// Write the full result as JSON.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Write every evaluation, as it completes, to a new JSON-lines log.
        #[arg(long)]
        log: Option<PathBuf>,
        /// Replay a log written by --log (recomputing nothing stored), then continue it.
        #[arg(long)]
        resume: Option<PathBuf>,
        /// Write one CSV row per evaluation (parameters, criteria, KKT residual, time).
        #[arg(long)]
        table: Option<PathBuf>,
    },
    /// Run the HTTP service and dashboard (job store: an embedded SQLite file, or PostgreSQL).
    Serve {
        /// Address to listen on (port 0: any free port, printed on start).
        #[arg(long, default_value = "127.0.0.1:8080")]
        addr: String,
        /// SQLite database file (created and migrated on start) or postgres:// URL.
        #[arg(long, default_value = "wsm.db")]
        db: String,
        /// Jobs run at once by this process (0: only serve; `wsm worker` processes run them).
        #[arg(long, default_value_t = 1)]
        workers: usize,
        /// Threads of each job (default: all cores).
        #[arg(long)]
        threads_per_job: Option<usize>,
        /// A running job whose lease is not renewed for this long is resumed by another worker [s].
        #[arg(long, default_value_t = 30.0)]
        lease_seconds: f64,
        /// Largest inner-solve budget a job may ask for.
        #[arg(long, default_value_t = 100_000)]
        max_budget: usize,
        /// Queued and running jobs at once (beyond: 503 with Retry-After).
        #[arg(long, default_value_t = 1000)]
        max_active_jobs: usize,
        /// Largest estimated mesh of a job [triangles].
        #[arg(long, default_value_t = 2_000_000)]
        max_triangles: usize,
        /// Largest request body [bytes].
        #[arg(long, default_value_t = 4 << 20)]
        max_body_bytes: usize,
    },
    /// A worker process for a shared job store: coordinates jobs and evaluates batches of any
    /// job (needs nothing but the database URL; start as many as you have machines).
    Worker {
        /// postgres:// URL (or a SQLite file shared by processes on one machine).
        #[arg(long)]
        db: String,
        /// Evaluation threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Jobs coordinated at once by this process.
        #[arg(long, default_value_t = 1)]
        jobs: usize,
        /// A job or task whose lease is not renewed for this long is taken over [s].
        #[arg(long, default_value_t = 30.0)]
        lease_seconds: f64,
    },
    /// Print the OpenAPI 3.1 document of the HTTP API.
    Openapi,
    /// Timing benchmarks of the inner solvers (not part of the test suite).
    Bench {
        /// Target numbers of unknowns.
        #[arg(long, value_delimiter = ',', default_value = "10000,100000")]
        sizes: Vec<usize>,
        /// Runs per measurement (the median is reported).
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Also print the domain-decomposition scalability tables (slow); with --worst: also
        /// run the loop with the DD solver.
        #[arg(long)]
        dd: bool,
        /// Instead: evaluations/s of the worst-scenario loop on the tunnel, with phase shares.
        #[arg(long)]
        worst: bool,
        /// Inner-solve budget of each --worst run.
        #[arg(long, default_value_t = 400)]
        budget: usize,
    },
    /// Accuracy against run time, and numerical stability on stiff and extreme cases.
    Study {
        #[command(subcommand)]
        study: StudyCommand,
    },
    /// Print a bundled example scene, or list them.
    Example {
        name: Option<String>,
        #[arg(long)]
        list: bool,
    },
}

#[derive(Subcommand)]
enum StudyCommand {
    /// A scene on a ladder of meshes with the direct and the DD solver: errors against analytic
    /// solutions or Richardson extrapolation, against solve time (Markdown, CSV, SVG plot).
    Accuracy {
        /// Scene file (JSON).
        scene: Option<PathBuf>,
        /// A bundled example instead of a file (also `manufactured`: the built-in manufactured
        /// solution on the unit square).
        #[arg(long)]
        example: Option<String>,
        /// Compare a scene file with an analytic solution: `hertz` or `lame`.
        #[arg(long)]
        analytic: Option<String>,
        /// Mesh levels.
        #[arg(long, default_value_t = 5)]
        levels: usize,
        /// Mesh size factor of the coarsest level (relative to the scene's sizes).
        #[arg(long, default_value_t = 2.0)]
        coarsest: f64,
        /// Refinement in h from one level to the next.
        #[arg(long, default_value_t = std::f64::consts::SQRT_2)]
        ratio: f64,
        /// DD tolerances (a DD row per tolerance and level).
        #[arg(long, value_delimiter = ',', default_value = "1e-4,1e-6,1e-8")]
        tolerances: Vec<f64>,
        /// Only the direct solver.
        #[arg(long)]
        direct_only: bool,
        /// Cold solves per row (the median time is reported).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Threads (default 1: the cost per core, as in a worst-scenario run).
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Directory for NAME-accuracy.md, .csv and .svg.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// The catalogue of stiff and extreme cases with both solvers: outcome, KKT residuals,
    /// iterations, condition estimate, time (Markdown; exit status 4 when a case fails).
    Stability {
        /// Directory for stability.md and stability.json.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Solve {
            scene,
            example,
            solver,
            out,
            vtu,
        } => {
            let request = SolveRequest {
                solver: solver.map(|s| match s {
                    SolverArg::Direct => wsm_core::scene::SolverKind::Direct,
                    SolverArg::Dd => wsm_core::scene::SolverKind::Dd,
                }),
                fields: false,
            };
            cli::load_scene(scene.as_deref(), example.as_deref())
                .and_then(|s| cli::solve(s, request, out.as_deref(), vtu.as_deref()))
        }
        Command::Worst {
            scene,
            example,
            criteria,
            budget,
            seed,
            max_seconds,
            threads,
            accuracy_refinements,
            target_error,
            out,
            log,
            resume,
            table,
        } => cli::load_scene(scene.as_deref(), example.as_deref()).and_then(|s| {
            let request = WorstRequest {
                criteria: cli::parse_criteria(&criteria)?,
                budget,
                seed,
                max_seconds,
                threads,
                accuracy_refinements,
                target_error,
            };
            let files = cli::WorstFiles {
                out,
                log,
                resume,
                table,
            };
            cli::worst(s, request, files)
        }),
        Command::Serve {
            addr,
            db,
            workers,
            threads_per_job,
            lease_seconds,
            max_budget,
            max_active_jobs,
            max_triangles,
            max_body_bytes,
        } => cli::serve(wsm_service::server::ServeConfig {
            addr,
            db,
            workers,
            threads_per_job,
            lease_seconds,
            limits: wsm_service::api::Limits {
                max_budget,
                max_active_jobs,
                max_triangles,
                max_body_bytes,
                ..wsm_service::api::Limits::default()
            },
            token: std::env::var("WSM_API_TOKEN")
                .ok()
                .filter(|t| !t.is_empty()),
        }),
        Command::Worker {
            db,
            threads,
            jobs,
            lease_seconds,
        } => cli::worker(wsm_service::server::WorkerConfig {
            db,
            threads,
            jobs,
            lease_seconds,
        }),
        Command::Openapi => wsm_service::api::openapi_json()
            .map(|t| t.trim_end().to_string())
            .map_err(|e| wsm_core::error::WsmError::io("OpenAPI document", e)),
        Command::Bench {
            sizes,
            runs,
            dd,
            worst,
            budget,
        } => {
            if worst {
                wsm_study::bench::run_worst(&sizes, budget, dd)
            } else {
                wsm_study::bench::run(&sizes, runs, dd)
            }
        }
        Command::Example { name, list } => cli::example(name.as_deref(), list),
        Command::Study { study } => match study {
            StudyCommand::Accuracy {
                scene,
                example,
                analytic,
                levels,
                coarsest,
                ratio,
                tolerances,
                direct_only,
                repeats,
                threads,
                out,
            } => cli::study_case(scene.as_deref(), example.as_deref(), analytic.as_deref())
                .and_then(|case| {
                    let options = wsm_study::accuracy::AccuracyOptions {
                        ladder: wsm_core::estimate::ladder::Ladder::new(coarsest, ratio, levels)?,
                        dd_tolerances: if direct_only { Vec::new() } else { tolerances },
                        repeats,
                        threads,
                    };
                    cli::study_accuracy(&case, &options, out.as_deref())
                }),
            StudyCommand::Stability { out } => cli::study_stability(out.as_deref()),
        },
    };
    match result {
        Ok(text) => {
            println!("{text}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            cli::exit_code(&e)
        }
    }
}
