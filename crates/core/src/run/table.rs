//! The evaluations of a run as a table (CSV, what users of Dakota-style tools read): one row per
//! evaluation — its id (1-based, in log order), every uncertain parameter by its field path,
//! every requested criterion, the largest KKT residual, the solve time, for an infeasible
//! point the reason, and (with derivatives) every ∂Φ/∂θ as `d(phi3)/d(<field>)`: the derivative
//! where it exists, the right derivative where the one-sided derivatives differ. The left
//! derivatives follow in the columns `d(phi3)/d(<field>):left`, filled only where they differ
//! from the right ones. Every cell is a number or empty, so a CSV reader (pandas, a spreadsheet)
//! types every column but `error` as numbers.

use std::io::Write;

use crate::error::WsmError;
use crate::scenario::evaluator::Evaluation;
use crate::scenario::worst::ParameterInfo;
use crate::scene::CriterionSpec;

/// The header row.
pub fn columns(parameters: &[ParameterInfo], criteria: &[CriterionSpec]) -> Vec<String> {
    let derivatives = |suffix: &'static str| {
        criteria.iter().flat_map(move |c| {
            parameters
                .iter()
                .map(move |p| format!("d({})/d({}){suffix}", c.name(), p.field))
        })
    };
    std::iter::once("id".to_string())
        .chain(parameters.iter().map(|p| p.field.clone()))
        .chain(criteria.iter().map(|c| c.name().to_string()))
        .chain(["max_kkt_residual", "solve_seconds", "error"].map(String::from))
        .chain(derivatives(""))
        .chain(derivatives(LEFT))
        .collect()
}

/// The suffix of the left-derivative columns.
const LEFT: &str = ":left";

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
        // The right derivatives (the derivative where both sides agree), then the left ones
        // where they differ.
        let slopes = || {
            (0..criteria.len()).flat_map(move |k| {
                (0..parameters.len()).map(move |j| e.gradient.get(k).and_then(|row| row.get(j)))
            })
        };
        let right = slopes().map(|s| s.map_or_else(String::new, |s| number(s.right)));
        let left = slopes().map(|s| {
            s.filter(|s| s.left != s.right)
                .map_or_else(String::new, |s| number(s.left))
        });
        let row: Vec<String> = std::iter::once((id + 1).to_string())
            .chain(e.point.iter().map(|&x| number(x)))
            .chain(values)
            .chain([
                e.max_kkt_residual.map_or_else(String::new, number),
                number(e.solve_seconds),
                e.error.clone().unwrap_or_default(),
            ])
            .chain(right)
            .chain(left)
            .collect();
        writer.write_record(&row).map_err(fail)?;
    }
    writer.flush().map_err(|e| WsmError::io(what, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Criterion;
    use wsm_search::OneSided;

    fn parameter(field: &str) -> ParameterInfo {
        ParameterInfo {
            name: field.into(),
            field: field.into(),
            interval: [0.0, 1.0],
        }
    }

    /// One-sided derivatives are two numbers in two columns (never a `left/right` string), the
    /// left one only where it differs; a row without derivatives or values has empty cells.
    #[test]
    fn one_sided_derivatives_are_two_numeric_columns() {
        let parameters = [parameter("a"), parameter("b")];
        let criteria = [CriterionSpec::from(Criterion::Phi3)];
        let kink = Evaluation {
            point: vec![0.5, 0.25],
            values: Some(vec![2.0]),
            error: None,
            max_kkt_residual: None,
            solve_seconds: 0.5,
            gradient: vec![vec![
                OneSided::both(1.5),
                OneSided {
                    right: -2.0,
                    left: 3.0,
                },
            ]],
        };
        let failed = Evaluation {
            values: None,
            error: Some("no solution".into()),
            gradient: Vec::new(),
            ..kink.clone()
        };
        let mut out = Vec::new();
        write_csv(&mut out, "memory", &parameters, &criteria, &[kink, failed]).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "id,a,b,phi3,max_kkt_residual,solve_seconds,error,\
             d(phi3)/d(a),d(phi3)/d(b),d(phi3)/d(a):left,d(phi3)/d(b):left\n\
             1,5e-1,2.5e-1,2e0,,5e-1,,1.5e0,-2e0,,3e0\n\
             2,5e-1,2.5e-1,,,5e-1,no solution,,,,\n"
        );
    }
}
