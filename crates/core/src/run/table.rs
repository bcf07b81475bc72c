//! The evaluations of a run as a table (CSV, what users of Dakota-style tools read): one row per
//! evaluation — its id (1-based, in log order), every uncertain parameter by its field path,
//! every requested criterion, the largest KKT residual, the solve time, for an infeasible
//! point the reason, and (with derivatives) every ∂Φ/∂θ as `d(phi3)/d(<field>)`: a number
//! where it exists, `left/right` where the one-sided derivatives differ.

use std::io::Write;

use crate::error::WsmError;
use crate::scenario::evaluator::Evaluation;
use crate::scenario::worst::ParameterInfo;
use crate::scene::CriterionSpec;

/// The header row.
pub fn columns(parameters: &[ParameterInfo], criteria: &[CriterionSpec]) -> Vec<String> {
    std::iter::once("id".to_string())
        .chain(parameters.iter().map(|p| p.field.clone()))
        .chain(criteria.iter().map(|c| c.name().to_string()))
        .chain(["max_kkt_residual", "solve_seconds", "error"].map(String::from))
        .chain(criteria.iter().flat_map(|c| {
            parameters
                .iter()
                .map(move |p| format!("d({})/d({})", c.name(), p.field))
        }))
        .collect()
}

/// Write the table; `what` names the destination in errors.
pub fn write_csv(
    out: impl Write,
    what: &str,
    parameters: &[ParameterInfo],
    criteria: &[CriterionSpec],
    evaluations: &[Evaluation],
) -> Result<(), WsmError> {
    let fail = |e: csv::Error| WsmError::io(what, e);
    let mut writer = csv::Writer::from_writer(out);
    writer
        .write_record(columns(parameters, criteria))
        .map_err(fail)?;
    let number = |x: f64| format!("{x:e}");
    for (id, e) in evaluations.iter().enumerate() {
        let values = (0..criteria.len()).map(|k| {
            e.values
                .as_ref()
                .and_then(|v| v.get(k))
                .map_or_else(String::new, |&x| number(x))
        });
        let gradient = (0..criteria.len()).flat_map(|k| {
            (0..parameters.len()).map(move |j| {
                e.gradient
                    .get(k)
                    .and_then(|row| row.get(j))
                    .map_or_else(String::new, |s| {
                        if s.right == s.left {
                            number(s.right)
                        } else {
                            format!("{}/{}", number(s.left), number(s.right))
                        }
                    })
            })
        });
        let row: Vec<String> = std::iter::once((id + 1).to_string())
            .chain(e.point.iter().map(|&x| number(x)))
            .chain(values)
            .chain([
                e.max_kkt_residual.map_or_else(String::new, number),
                number(e.solve_seconds),
                e.error.clone().unwrap_or_default(),
            ])
            .chain(gradient)
            .collect();
        writer.write_record(&row).map_err(fail)?;
    }
    writer.flush().map_err(|e| WsmError::io(what, e))
}
