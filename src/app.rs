//! What the command line does, as library functions returning the text to print (so the same
//! work is testable and reusable by the service).

use std::path::Path;

use crate::error::WsmError;
use crate::examples::{example as example_text, EXAMPLES};
use crate::output::result;
use crate::scenario::search::{EvalCache, Progress};
use crate::scenario::worst::{prepare, run, WorstSettings};
use crate::scene::{parse, Criterion, Scene, SceneError, SolverKind};
use crate::state::{Needs, SolveOptions, StateProblem};
use indicatif::{ProgressBar, ProgressStyle};
use std::sync::atomic::AtomicBool;

/// Read and validate a scene from a file or a bundled example.
pub fn load_scene(path: Option<&Path>, example: Option<&str>) -> Result<Scene, WsmError> {
    let text = match (path, example) {
        (Some(p), None) => std::fs::read_to_string(p)
            .map_err(|e| WsmError::Io(format!("cannot read {}: {e}", p.display())))?,
        (None, Some(name)) => example_text(name)
            .ok_or_else(|| {
                WsmError::Io(format!(
                    "no bundled example '{name}' (see `wsm example --list`)"
                ))
            })?
            .to_string(),
        _ => {
            return Err(WsmError::Io(
                "give a scene file or --example NAME (not both)".into(),
            ))
        }
    };
    Ok(parse(&text)?)
}

fn write(path: &Path, text: &str) -> Result<(), WsmError> {
    std::fs::write(path, text)
        .map_err(|e| WsmError::Io(format!("cannot write {}: {e}", path.display())))
}

/// `wsm solve`: one state solve; returns the JSON summary.
pub fn solve(
    mut scene: Scene,
    solver: Option<SolverKind>,
    out: Option<&Path>,
    vtu: Option<&Path>,
) -> Result<String, WsmError> {
    if let Some(kind) = solver {
        scene.solver.kind = kind;
    }
    let problem = StateProblem::new(scene)?;
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: crate::fem::Par::rayon(0),
        warm: None,
    };
    let solution = problem.solve(&problem.nominal, &options)?;
    if let Some(p) = out {
        write(
            p,
            &serde_json::to_string(&result::full(&problem, &solution)).unwrap_or_default(),
        )?;
    }
    if let Some(p) = vtu {
        write(p, &result::vtu(&problem, &solution))?;
    }
    Ok(serde_json::to_string_pretty(&result::summary(&problem, &solution)).unwrap_or_default())
}

/// `wsm worst`: the worst-scenario search with a progress bar on stderr; returns a JSON summary
/// (worst and best value and data per criterion) and writes the full result to `out`.
pub fn worst(
    scene: Scene,
    criteria: &[String],
    budget: Option<usize>,
    seed: Option<u64>,
    out: Option<&Path>,
) -> Result<String, WsmError> {
    let mut settings = WorstSettings::from_scene(&scene);
    if !criteria.is_empty() {
        settings.criteria = criteria
            .iter()
            .enumerate()
            .map(|(i, c)| {
                Criterion::parse(c).ok_or_else(|| {
                    WsmError::Scene(SceneError::new(
                        format!("--criteria[{i}]"),
                        format!("unknown criterion '{c}' (phi1..phi6)"),
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
        let mut check = scene.clone();
        check.search.criteria = settings.criteria.clone();
        crate::scene::validate(&check)?;
    }
    settings.budget = budget.unwrap_or(settings.budget);
    settings.seed = seed.unwrap_or(settings.seed);
    let (problem, params) = prepare(scene)?;
    let bar = ProgressBar::new(settings.budget as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} solves {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let names: Vec<&str> = settings.criteria.iter().map(|c| c.name()).collect();
    let on_progress = |p: &Progress| {
        bar.set_position(p.evaluations as u64);
        let best: Vec<String> = p
            .best
            .iter()
            .step_by(2)
            .zip(&names)
            .filter_map(|(b, n)| b.map(|v| format!("max {n} {v:.4e}")))
            .collect();
        bar.set_message(best.join(", "));
    };
    let result = run(
        &problem,
        &params,
        &settings,
        &mut EvalCache::new(),
        &AtomicBool::new(false),
        &on_progress,
    )?;
    bar.finish_and_clear();
    let full = serde_json::to_value(&result).unwrap_or_default();
    if let Some(p) = out {
        write(p, &serde_json::to_string_pretty(&full).unwrap_or_default())?;
    }
    Ok(serde_json::to_string_pretty(&worst_summary(&full)).unwrap_or_default())
}

/// The result without the convergence histories.
fn worst_summary(full: &serde_json::Value) -> serde_json::Value {
    let mut v = full.clone();
    if let Some(list) = v["criteria"].as_array_mut() {
        for c in list {
            for side in ["worst", "best"] {
                if let Some(o) = c[side].as_object_mut() {
                    o.remove("history");
                }
            }
        }
    }
    v
}

/// `wsm example`: a scene's JSON, or the list of names.
pub fn example(name: Option<&str>, list: bool) -> Result<String, WsmError> {
    match (name, list) {
        (_, true) | (None, false) => Ok(EXAMPLES
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join("\n")),
        (Some(n), false) => example_text(n).map(str::to_string).ok_or_else(|| {
            WsmError::Io(format!(
                "no bundled example '{n}' (see `wsm example --list`)"
            ))
        }),
    }
}
