//! What the `wsm` commands do, as a thin layer over wsm-core's front door (`wsm_core::worst`,
//! `wsm_core::solve`, …): reading scene files, a progress bar on stderr, writing result files, and one-line errors with an exit code
//! per error kind.

use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use wsm_core::{
    parse_scene, EvaluationLog, JsonLinesLog, LogMode, MemoryLog, ProgressEvent, RunControl, Scene,
    SceneError, Sense, SolveRequest, WorstOutcome, WorstRequest, WsmError,
};

/// Exit status of an error ([`wsm_core::ErrorKind::exit_code`]).
pub fn exit_code(error: &WsmError) -> ExitCode {
    ExitCode::from(error.kind().exit_code())
}

/// Read and validate the scene a command names (a file or a bundled example).
pub fn load_scene(input: &crate::args::SceneArgs) -> Result<Scene, WsmError> {
    read_scene(input.scene.as_deref(), input.example.as_deref())
}

/// [`load_scene`], refused (before meshing) when its solve is estimated to need more memory than
/// `--max-solve-memory` (design §3.1, cost estimate).
pub fn load_affordable_scene(
    input: &crate::args::SceneArgs,
    memory: &crate::args::MemoryArgs,
) -> Result<Scene, WsmError> {
    let scene = load_scene(input)?;
    wsm_core::estimate_solve_cost(&scene)?.check(memory.limit() as f64)?;
    Ok(scene)
}

/// Read and validate a scene from a file or a bundled example. A relative `mesh.gmsh_file` of a
/// scene file names a file beside it (in the scene file's directory), whatever the working
/// directory.
fn read_scene(path: Option<&Path>, example: Option<&str>) -> Result<Scene, WsmError> {
    let text = match (path, example) {
        (Some(p), None) => std::fs::read_to_string(p).map_err(|e| WsmError::io(p.display(), e))?,
        (None, Some(name)) => wsm_core::find_example(name)?.to_string(),
        _ => {
            return Err(
                SceneError::new("SCENE", "give a scene file or --example NAME (not both)").into(),
            )
        }
    };
    let mut scene = parse_scene(&text)?;
    if let (Some(p), Some(file)) = (path, scene.mesh.gmsh_file.as_mut()) {
        *file = beside(p, file)?;
    }
    Ok(scene)
}

/// `file` (a path written in the scene file `scene_file`) relative to the scene file's
/// directory; an absolute path, or a scene file in the working directory, leaves it as it is.
fn beside(scene_file: &Path, file: &str) -> Result<String, SceneError> {
    let dir = match scene_file.parent() {
        Some(dir) if Path::new(file).is_relative() && !dir.as_os_str().is_empty() => dir,
        _ => return Ok(file.to_string()),
    };
    dir.join(file).into_os_string().into_string().map_err(|_| {
        SceneError::new(
            "mesh.gmsh_file",
            "the scene file's directory is not valid UTF-8: give the mesh file's absolute path",
        )
    })
}

/// Pretty JSON of a result; an encoding failure is an error.
pub fn to_json(value: &impl Serialize) -> Result<String, WsmError> {
    serde_json::to_string_pretty(value).map_err(|e| WsmError::io("JSON output", e))
}

fn write(path: &Path, text: &str) -> Result<(), WsmError> {
    std::fs::write(path, text).map_err(|e| WsmError::io(path.display(), e))
}

/// `wsm solve`: the JSON summary; the full result, a VTU file and the contact profiles (CSV) on
/// request. The report's warnings also go to stderr, as `wsm worst`'s do. A dynamic scene shows
/// its time steps as a progress bar on stderr, and with `--vtu FILE` also writes the series of
/// its output times beside FILE (design §5.6): `STEM-00000.vtu`, … and their index `STEM.pvd`
/// with the times (FILE itself holds the static solve at t = 0 that the summary describes).
pub fn solve(
    scene: Scene,
    request: SolveRequest,
    out: Option<&Path>,
    vtu: Option<&Path>,
    profiles: Option<&Path>,
) -> Result<String, WsmError> {
    let request = SolveRequest {
        fields: out.is_some() || vtu.is_some() || profiles.is_some(),
        ..request
    };
    let dynamic = scene.dynamics.is_some();
    let bar = ProgressBar::hidden();
    let mut control = RunControl::new();
    if dynamic {
        bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} time steps")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        let progress_bar = bar.clone();
        control = control.with_progress(move |event: &ProgressEvent| {
            progress_bar.set_length(event.budget as u64);
            progress_bar.set_position(event.evaluations as u64);
        });
    }
    let mut entries = Vec::new();
    let mut sink = |index: usize, time: f64, text: String| -> Result<(), WsmError> {
        let Some(p) = vtu else { return Ok(()) };
        let stem = p.file_stem().unwrap_or_default().to_string_lossy();
        let file = format!("{stem}-{index:05}.vtu");
        write(&p.with_file_name(&file), &text)?;
        entries.push(wsm_core::SeriesEntry {
            file,
            title: format!("t = {time:e} s"),
            time: Some(time),
        });
        Ok(())
    };
    let series = (dynamic && vtu.is_some()).then_some(&mut sink as &mut wsm_core::SeriesSink);
    let output = wsm_core::solve_watched(scene, None, &request, &control, series);
    bar.finish_and_clear();
    let output = output?;
    for warning in &output.summary.report.warnings {
        eprintln!("warning: {warning}");
    }
    if let Some(p) = out {
        write(p, &to_json(&output)?)?;
    }
    if let (Some(p), Some(text)) = (vtu, &output.vtu) {
        write(p, text)?;
        if !entries.is_empty() {
            let index = p.with_extension("pvd");
            write(&index, &wsm_core::write_pvd(&entries))?;
            eprintln!(
                "{} output times written as {}-*.vtu, indexed by {}",
                entries.len(),
                p.with_extension("").display(),
                index.display()
            );
        }
    }
    if let (Some(p), Some(fields)) = (profiles, &output.fields) {
        write(p, &wsm_core::profiles_csv(&fields.contact_profiles))?;
    }
    to_json(&output.summary)
}

/// `wsm evaluate`: answers stream to stdout as the points arrive on stdin; the summary line
/// (the number of points) goes to stderr.
pub fn evaluate(scene: Scene, request: WorstRequest) -> Result<String, WsmError> {
    let count = wsm_core::evaluate_points(
        scene,
        &request,
        &mut std::io::stdin().lock(),
        &mut std::io::stdout().lock(),
    )?;
    eprintln!("{count} points evaluated");
    Ok(String::new())
}

/// `wsm worst`: the search with a progress bar; prints the outcome without the histories.
/// Refined levels of the accuracy statement whose solve would need more than `max_solve_bytes`
/// are not built, and the result says so.
pub fn worst(
    scene: Scene,
    request: WorstRequest,
    files: crate::args::WorstFiles,
    max_solve_bytes: u64,
) -> Result<String, WsmError> {
    let settings = request.settings(&scene)?;
    let names: Vec<String> = settings.criteria.iter().map(|c| c.name()).collect();
    let (file_log, memory_log) = match (&files.log, &files.resume) {
        (Some(_), Some(_)) => {
            return Err(SceneError::new(
                "--log",
                "give --log FILE for a new log or --resume FILE to continue one, not both",
            )
            .into())
        }
        (Some(p), None) => (Some(Arc::new(JsonLinesLog::new(p, LogMode::Create))), None),
        (None, Some(p)) => (Some(Arc::new(JsonLinesLog::new(p, LogMode::Resume))), None),
        (None, None) => (
            None,
            files.table.as_ref().map(|_| Arc::new(MemoryLog::new())),
        ),
    };
    let bar = ProgressBar::new(settings.budget as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} solves {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let progress_bar = bar.clone();
    let mut control = RunControl::new()
        .with_max_solve_memory(max_solve_bytes)
        .with_progress(move |event: &ProgressEvent| {
            progress_bar.set_position(event.evaluations as u64);
            let best: Vec<String> = event
                .best
                .iter()
                .filter(|b| b.sense == Sense::Max)
                .zip(&names)
                .filter_map(|(b, n)| b.value.map(|v| format!("max {n} {v:.4e}")))
                .collect();
            progress_bar.set_message(format!("{:?} {}", event.phase, best.join(", ")));
        });
    if let Some(log) = &file_log {
        control = control.with_log(log.clone() as Arc<dyn EvaluationLog>);
    } else if let Some(log) = &memory_log {
        control = control.with_log(log.clone() as Arc<dyn EvaluationLog>);
    }
    let fields_scene = files.fields.as_ref().map(|_| scene.clone());
    let defined = scene.criteria.defined.clone();
    let outcome = wsm_core::worst(scene, &request, &control)?;
    bar.finish_and_clear();
    eprint!("{}", wsm_core::summary(&outcome, &defined));
    if let Some(p) = &files.out {
        write(p, &to_json(&outcome)?)?;
    }
    if let Some(p) = &files.table {
        let evaluations = match (&file_log, &memory_log) {
            (Some(log), _) => log.evaluations(),
            (None, Some(log)) => log.evaluations(),
            (None, None) => Vec::new(),
        };
        let file = std::fs::File::create(p).map_err(|e| WsmError::io(p.display(), e))?;
        wsm_core::write_csv(
            file,
            &p.display().to_string(),
            &outcome.parameters,
            &settings.criteria,
            &evaluations,
        )?;
    }
    if let (Some(dir), Some(scene)) = (&files.fields, fields_scene) {
        write_scenario_fields(dir, scene, &outcome)?;
    }
    to_json(&outcome.without_histories())
}

/// `wsm worst --fields DIR`: a VTU per scenario (nominal, worst and best of every criterion)
/// and their index `scenarios.pvd` in `dir`; scenarios without data are named on stderr.
fn write_scenario_fields(dir: &Path, scene: Scene, outcome: &WorstOutcome) -> Result<(), WsmError> {
    let (series, skipped) = wsm_core::scenario_series(scene, outcome, &SolveRequest::default())?;
    for reason in skipped {
        eprintln!("warning: --fields: {reason}; its file is left out");
    }
    for s in &series {
        write_in(dir, &s.file, s.output.vtu.as_deref().unwrap_or_default())?;
    }
    write_in(dir, "scenarios.pvd", &wsm_core::series_index(&series))?;
    eprintln!(
        "fields of {} scenarios written to {}",
        series.len(),
        dir.join("scenarios.pvd").display()
    );
    Ok(())
}

/// `wsm example`: a scene's JSON, or the list of names.
pub fn example(name: Option<&str>, list: bool) -> Result<String, WsmError> {
    match (name, list) {
        (Some(n), false) => Ok(wsm_core::find_example(n)?.to_string()),
        _ => Ok(wsm_core::example_names().collect::<Vec<_>>().join("\n")),
    }
}

/// `wsm inline-mesh`: the scene file with its Gmsh mesh given inline (`mesh.inline`), as JSON.
pub fn inline_mesh(scene: &Path) -> Result<String, WsmError> {
    let scene = read_scene(Some(scene), None)?;
    to_json(&wsm_core::with_inline_mesh(&scene)?)
}

/// `wsm openapi`: the OpenAPI document of the HTTP API.
pub fn openapi() -> Result<String, WsmError> {
    wsm_service::api::openapi_json()
        .map(|t| t.trim_end().to_string())
        .map_err(|e| WsmError::io("OpenAPI document", e))
}

/// `wsm schema`: the JSON Schema of the scene document (design §5.2).
pub fn schema() -> String {
    wsm_core::scene_schema_json().trim_end().to_string()
}

/// `wsm bench`: the inner-solver timings, or with `--worst` the worst-scenario loop, or with
/// `--gradients` the cost of the exact derivatives, or with `--mortar` mortar against node-pair
/// contact rows.
pub fn bench(args: &crate::args::BenchArgs) -> Result<String, WsmError> {
    let sizes = |default: &[usize]| args.sizes.clone().unwrap_or_else(|| default.to_vec());
    let sizes = if args.dynamics {
        sizes(&[2500, 5000, 10000])
    } else {
        sizes(&[10000, 100000])
    };
    if args.dynamics {
        wsm_study::bench::run_dynamics(&sizes, args.runs)
    } else if args.mortar {
        wsm_study::bench::run_mortar(&sizes, args.runs)
    } else if args.gradients {
        wsm_study::bench::run_gradients(&sizes, args.runs)
    } else if args.worst {
        wsm_study::bench::run_worst(&sizes, args.budget, args.dd)
    } else {
        wsm_study::bench::run(&sizes, args.runs, args.dd)
    }
}

/// `wsm serve`: the service on a multi-threaded runtime, until Ctrl-C or SIGTERM.
pub fn serve(config: wsm_service::server::ServeConfig) -> Result<String, WsmError> {
    init_logging();
    until_stopped(wsm_service::server::serve(config))
}

/// `wsm worker`: a worker process on a multi-threaded runtime, until Ctrl-C or SIGTERM.
pub fn worker(config: wsm_service::server::WorkerConfig) -> Result<String, WsmError> {
    init_logging();
    until_stopped(wsm_service::server::worker(config))
}

/// The service's log (design §5.3, "Logs"): `tracing` events on stderr, at `info` and above
/// unless `RUST_LOG` says otherwise (`RUST_LOG=tower_http=debug` adds a line per request;
/// directives it cannot read are left out). Colours only on a terminal. The address line that
/// scripts wait for stays on stdout.
fn init_logging() {
    use std::io::IsTerminal;
    use tracing_subscriber::filter::{EnvFilter, LevelFilter};
    let filter = EnvFilter::builder()
        .with_default_directive(LevelFilter::INFO.into())
        .from_env_lossy();
    // A second call in one process (tests) keeps the first subscriber.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .try_init();
}

/// Run a server or worker to its end; its jobs, given back and told to stop, get a few seconds
/// to leave their evaluation batch before the process exits.
fn until_stopped(
    service: impl std::future::Future<Output = Result<(), WsmError>>,
) -> Result<String, WsmError> {
    let runtime = runtime()?;
    let result = runtime.block_on(service);
    runtime.shutdown_timeout(std::time::Duration::from_secs(5));
    result.map(|()| "wsm: stopped".into())
}

fn runtime() -> Result<tokio::runtime::Runtime, WsmError> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|e| WsmError::io("async runtime", e))
}

/// The command line as typed, with the program named `wsm` (recorded in study reports).
fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    format!("wsm {}", args.join(" "))
}

/// The case of `wsm study accuracy`: a bundled example (or `manufactured`) or a scene file.
pub fn study_case(
    path: Option<&Path>,
    example: Option<&str>,
    analytic: Option<&str>,
) -> Result<wsm_study::accuracy::Case, WsmError> {
    use wsm_study::accuracy::Case;
    match (path, example) {
        (None, Some(name)) if analytic.is_none() => Case::example(name),
        (None, Some(_)) => Err(SceneError::new(
            "--analytic",
            "is for scene files; examples bring their own",
        )
        .into()),
        _ => Case::scene(read_scene(path, example)?, analytic),
    }
}

/// A file name piece from a case name (`tunnel-fault`, `hertz-cylinder-on-a-flat`).
fn slug(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect();
    s.split('-')
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

/// Create `dir` and write `name` in it.
fn write_in(dir: &Path, name: &str, text: &str) -> Result<(), WsmError> {
    std::fs::create_dir_all(dir).map_err(|e| WsmError::io(dir.display(), e))?;
    write(&dir.join(name), text)
}

/// `wsm study accuracy`: the Markdown report on stdout; with `--out`, the report, the CSV table
/// and the SVG plot in that directory.
pub fn study_accuracy(
    case: &wsm_study::accuracy::Case,
    options: &wsm_study::accuracy::AccuracyOptions,
    out: Option<&Path>,
) -> Result<String, WsmError> {
    use wsm_study::report;
    let study = wsm_study::accuracy::run(case, options)?;
    let markdown = report::markdown(&study, &command_line());
    if let Some(dir) = out {
        let name = slug(&study.case);
        write_in(dir, &format!("{name}-accuracy.md"), &markdown)?;
        write_in(dir, &format!("{name}-accuracy.csv"), &report::csv(&study)?)?;
        write_in(dir, &format!("{name}-accuracy.svg"), &report::plot(&study))?;
    }
    Ok(markdown)
}

/// `wsm study stability`: the catalogue as Markdown (and JSON with `--out`); an error when a case
/// fails its expectation.
pub fn study_stability(out: Option<&Path>) -> Result<String, WsmError> {
    use wsm_study::stability;
    let results = stability::run_catalogue(&stability::catalogue());
    let markdown = stability::markdown(&results, &command_line());
    if let Some(dir) = out {
        write_in(dir, "stability.md", &markdown)?;
        write_in(dir, "stability.json", &to_json(&results)?)?;
    }
    let failed: Vec<String> = results
        .iter()
        .filter(|r| !r.passed)
        .map(|r| format!("{} / {} ({})", r.group, r.name, r.solver))
        .collect();
    if failed.is_empty() {
        Ok(markdown)
    } else {
        println!("{markdown}");
        Err(WsmError::contact(format!(
            "{} stability case(s) failed: {}",
            failed.len(),
            failed.join(", ")
        )))
    }
}
