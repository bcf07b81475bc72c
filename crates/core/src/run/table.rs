//! The evaluations of a run as a table (CSV, what users of Dakota-style tools read): one row per
//! evaluation — its id (1-based, in log order), every uncertain parameter by its field path,
//! every requested criterion, the largest KKT residual, the solve time and, for an infeasible
//! point, the reason.

use std::io::Write;

use crate::error::WsmError;
use crate::scenario::evaluator::Evaluation;
use crate::scenario::worst::ParameterInfo;
use crate::scene::Criterion;

/// The header row.
pub fn columns(parameters: &[ParameterInfo], criteria: &[Criterion]) -> Vec<String> {
    std::iter::once("id".to_string())
        .chain(parameters.iter().map(|p| p.field.clone()))
        .chain(criteria.iter().map(|c| c.name().to_string()))
        .chain(["max_kkt_residual", "solve_seconds", "error"].map(String::from))
        .collect()
}

/// Write the table; `what` names the destination in errors.
pub fn write_csv(
    out: impl Write,
    what: &str,
    parameters: &[ParameterInfo],
    criteria: &[Criterion],
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
        let row: Vec<String> = std::iter::once((id + 1).to_string())
            .chain(e.point.iter().map(|&x| number(x)))
            .chain(values)
            .chain([
                e.max_kkt_residual.map_or_else(String::new, number),
                number(e.solve_seconds),
                e.error.clone().unwrap_or_default(),
            ])
            .collect();
        writer.write_record(&row).map_err(fail)?;
    }
    writer.flush().map_err(|e| WsmError::io(what, e))
}
