//! The `wsm` command line: solve a scene, run a worst-scenario search, serve the HTTP API, print
//! bundled examples, run studies and benchmarks. The arguments of each command are a struct in
//! `args`; `cli` does the work over the crates' front doors. Every error ends in one line on
//! stderr and a non-zero exit status (see `cli::exit_code`).

mod args;
mod cli;

use std::io::Write;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use args::{
    AccuracyArgs, BenchArgs, EvaluateArgs, ExampleArgs, InlineMeshArgs, ServeArgs, SolveArgs,
    StabilityArgs, WorkerArgs, WorstArgs,
};

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

#[derive(Subcommand)]
enum Command {
    /// Solve one state problem and print a JSON summary.
    Solve(SolveArgs),
    /// Worst-scenario search: worst and best value of each criterion over the admissible set.
    Worst(WorstArgs),
    /// Evaluate the criteria (and their exact derivatives) at data points read as JSON lines
    /// from stdin — an array in the order of `parameters`, or an object of field: value — and
    /// write a header line, then one answer line per point, to stdout (mesh and assembly once).
    Evaluate(EvaluateArgs),
    /// Run the HTTP service and dashboard (job store: an embedded SQLite file, or PostgreSQL).
    Serve(ServeArgs),
    /// A worker process for a shared job store: coordinates jobs and evaluates batches of any
    /// job (needs nothing but the database URL; start as many as you have machines).
    Worker(WorkerArgs),
    /// Print the OpenAPI 3.1 document of the HTTP API.
    Openapi,
    /// Print the JSON Schema (2020-12) of the scene document, for editors and validators.
    Schema,
    /// Timing benchmarks of the inner solvers (not part of the test suite).
    Bench(BenchArgs),
    /// Accuracy against run time, and numerical stability on stiff and extreme cases.
    Study {
        #[command(subcommand)]
        study: StudyCommand,
    },
    /// Print a bundled example scene, or list them.
    Example(ExampleArgs),
    /// Print the scene with its Gmsh mesh (mesh.gmsh_file) given inline (mesh.inline), as the
    /// HTTP service takes it: `wsm inline-mesh scene.json > inline.json`.
    InlineMesh(InlineMeshArgs),
}

#[derive(Subcommand)]
enum StudyCommand {
    /// A scene on a ladder of meshes with the direct and the DD solver: errors against analytic
    /// solutions or Richardson extrapolation, against solve time (Markdown, CSV, SVG plot).
    Accuracy(AccuracyArgs),
    /// The catalogue of stiff and extreme cases with both solvers: outcome, KKT residuals,
    /// iterations, condition estimate, time (Markdown; exit status 4 when a case fails).
    Stability(StabilityArgs),
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Solve(a) => cli::load_affordable_scene(&a.input, &a.memory).and_then(|scene| {
            cli::solve(
                scene,
                (&a).into(),
                a.out.as_deref(),
                a.vtu.as_deref(),
                a.profiles.as_deref(),
            )
        }),
        Command::Worst(a) => cli::load_affordable_scene(&a.input, &a.memory)
            .and_then(|scene| cli::worst(scene, (&a).try_into()?, (&a).into(), a.memory.limit())),
        Command::Evaluate(a) => cli::load_affordable_scene(&a.input, &a.memory)
            .and_then(|scene| cli::evaluate(scene, (&a).try_into()?)),
        Command::Serve(a) => cli::serve(a.into()),
        Command::Worker(a) => cli::worker(a.into()),
        Command::Openapi => cli::openapi(),
        Command::Schema => Ok(cli::schema()),
        Command::Bench(a) => cli::bench(&a),
        Command::Example(a) => cli::example(a.name.as_deref(), a.list),
        Command::InlineMesh(a) => cli::inline_mesh(&a.scene),
        Command::Study { study } => match study {
            StudyCommand::Accuracy(a) => cli::study_case(
                a.scene.as_deref(),
                a.example.as_deref(),
                a.analytic.as_deref(),
            )
            .and_then(|case| cli::study_accuracy(&case, &(&a).try_into()?, a.out.as_deref())),
            StudyCommand::Stability(a) => cli::study_stability(a.out.as_deref()),
        },
    };
    match result {
        Ok(text) => {
            // A reader that went away (`| head`, a closed pipe) is not a failure of the command.
            // A command that streamed its output returns no text.
            if !text.is_empty() {
                let _ = writeln!(std::io::stdout(), "{text}");
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            cli::exit_code(&e)
        }
    }
}
