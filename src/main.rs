//! The `wsm` command line: solve a scene, run a worst-scenario search, print bundled examples,
//! run benchmarks. Every error ends in one line on stderr and a non-zero exit status.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

use wsm::app;

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
        /// Write the full result as JSON.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Timing benchmarks of the inner solvers (not part of the test suite).
    Bench {
        /// Target numbers of unknowns.
        #[arg(long, value_delimiter = ',', default_value = "10000,100000")]
        sizes: Vec<usize>,
        /// Runs per measurement (the median is reported).
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Also print the domain-decomposition scalability tables (slow).
        #[arg(long)]
        dd: bool,
    },
    /// Print a bundled example scene, or list them.
    Example {
        name: Option<String>,
        #[arg(long)]
        list: bool,
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
            let solver = solver.map(|s| match s {
                SolverArg::Direct => wsm::scene::SolverKind::Direct,
                SolverArg::Dd => wsm::scene::SolverKind::Dd,
            });
            app::load_scene(scene.as_deref(), example.as_deref())
                .and_then(|s| app::solve(s, solver, out.as_deref(), vtu.as_deref()))
        }
        Command::Worst {
            scene,
            example,
            criteria,
            budget,
            seed,
            out,
        } => app::load_scene(scene.as_deref(), example.as_deref())
            .and_then(|s| app::worst(s, &criteria, budget, seed, out.as_deref())),
        Command::Bench { sizes, runs, dd } => wsm::bench::run(&sizes, runs, dd),
        Command::Example { name, list } => app::example(name.as_deref(), list),
    };
    match result {
        Ok(text) => {
            println!("{text}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
