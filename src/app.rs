//! What the command line does, as library functions returning the text to print (so the same
//! work is testable and reusable by the service).

use std::path::Path;

use crate::error::WsmError;
use crate::examples::{example as example_text, EXAMPLES};
use crate::output::result;
use crate::scene::{parse, Scene, SolverKind};
use crate::state::{Needs, SolveOptions, StateProblem};

/// Read and validate a scene from a file or a bundled example.
pub fn load_scene(path: Option<&Path>, example: Option<&str>) -> Result<Scene, WsmError> {
    let text = match (path, example) {
        (Some(p), None) => std::fs::read_to_string(p)
            .map_err(|e| WsmError::Io(format!("cannot read {}: {e}", p.display())))?,
        (None, Some(name)) => example_text(name)
            .ok_or_else(|| WsmError::Io(format!("no bundled example '{name}' (see `wsm example --list`)")))?
            .to_string(),
        _ => return Err(WsmError::Io("give a scene file or --example NAME (not both)".into())),
    };
    Ok(parse(&text)?)
}

fn write(path: &Path, text: &str) -> Result<(), WsmError> {
    std::fs::write(path, text).map_err(|e| WsmError::Io(format!("cannot write {}: {e}", path.display())))
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
        write(p, &serde_json::to_string(&result::full(&problem, &solution)).unwrap_or_default())?;
    }
    if let Some(p) = vtu {
        write(p, &result::vtu(&problem, &solution))?;
    }
    Ok(serde_json::to_string_pretty(&result::summary(&problem, &solution)).unwrap_or_default())
}

/// `wsm example`: a scene's JSON, or the list of names.
pub fn example(name: Option<&str>, list: bool) -> Result<String, WsmError> {
    match (name, list) {
        (_, true) | (None, false) => Ok(EXAMPLES.iter().map(|(n, _)| *n).collect::<Vec<_>>().join("\n")),
        (Some(n), false) => example_text(n)
            .map(str::to_string)
            .ok_or_else(|| WsmError::Io(format!("no bundled example '{n}' (see `wsm example --list`)"))),
    }
}
