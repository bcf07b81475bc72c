//! Point evaluations for a user's own method (`wsm evaluate`): the requested criteria and their
//! exact derivatives at data points chosen outside `wsm` — a design of experiments, a peer
//! optimiser, a check of a reported worst scenario — through the same prepared model a search
//! uses (meshed, assembled and solved at the nominal data once; every point then costs its
//! solve).
//!
//! The exchange is JSON lines: a header line `{parameters, criteria}`, then one answer line per
//! input line. An input line is an array of the uncertain data in the order of `parameters`, or
//! an object giving every datum by its field path or name. An answer is `{values: {criterion:
//! value}, gradient: {criterion: {field: {left, right}}}}` (the gradient without
//! `--no-derivatives`), or `{error}` for a line that cannot be read, a datum outside its interval
//! or a solve that fails; the stream goes on after an error line.

use std::collections::BTreeMap;
use std::io::{BufRead, Write};

use rayon::prelude::*;
use serde::Serialize;
use serde_json::Value;

use super::model::PreparedModel;
use super::request::WorstRequest;
use crate::contact::qp::WarmStart;
use crate::error::WsmError;
use crate::scenario::evaluator::{Evaluation, ScenarioEvaluator};
use crate::scenario::worst::ParameterInfo;
use crate::scene::params::parameters;
use crate::scene::{CriterionSpec, Scene};
use wsm_search::OneSided;

/// The first line of the stream: what a point is made of and what each answer holds.
#[derive(Debug, Serialize)]
struct Header<'a> {
    parameters: &'a [ParameterInfo],
    criteria: Vec<String>,
    derivatives: bool,
}

/// The answer at one point: the criteria by name, their one-sided derivatives by criterion and
/// field, the solve's largest KKT residual — or why there is none.
#[derive(Debug, Default, Clone, PartialEq, Serialize)]
pub struct PointAnswer {
    /// Each requested criterion's value (units of the criterion).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub values: Option<BTreeMap<String, f64>>,
    /// Per criterion, per uncertain datum's field: the one-sided derivatives (empty without
    /// derivatives).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub gradient: BTreeMap<String, BTreeMap<String, OneSided>>,
    /// The contact solve's largest KKT residual (with contact).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_kkt_residual: Option<f64>,
    /// Why the point has no values: outside its interval, or the solve failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

impl PointAnswer {
    fn refused(reason: String) -> PointAnswer {
        PointAnswer {
            error: Some(reason),
            ..PointAnswer::default()
        }
    }
}

/// A scene prepared for evaluations at points its caller chooses (`wsm evaluate`, the Python
/// package's `Evaluator`): meshed and assembled once, solved at the nominal data once — the
/// warm start of every point — then one solve per point. Answers depend on the point alone, not
/// on the batch it came in or the threads that solved it.
pub struct PointEvaluator {
    model: PreparedModel,
    parameters: Vec<ParameterInfo>,
    criteria: Vec<CriterionSpec>,
    derivatives: bool,
    warm: Option<WarmStart>,
}

impl PointEvaluator {
    /// Prepare `scene` for the criteria and derivatives of `request` (its other settings are
    /// unused). Errors of the scene or the request name their field.
    pub fn new(scene: Scene, request: &WorstRequest) -> Result<PointEvaluator, WsmError> {
        let settings = request.settings(&scene)?;
        let params = parameters(&scene)?;
        let parameters = ParameterInfo::list(&scene, &params);
        let model = PreparedModel::new(scene, params, settings.criteria.clone())?
            .with_derivatives(settings.derivatives);
        let warm = model.evaluator()?.warm_start().cloned();
        Ok(PointEvaluator {
            model,
            parameters,
            criteria: settings.criteria,
            derivatives: settings.derivatives,
            warm,
        })
    }

    /// The uncertain data a point is made of, in order: name, field and interval.
    pub fn parameters(&self) -> &[ParameterInfo] {
        &self.parameters
    }

    /// The names of the criteria each answer holds, in order.
    pub fn criteria(&self) -> Vec<String> {
        self.criteria.iter().map(|c| c.name()).collect()
    }

    /// Whether answers carry exact derivatives.
    pub fn derivatives(&self) -> bool {
        self.derivatives
    }

    /// The answers at `points` (physical values in the order of [`Self::parameters`]), solved
    /// in parallel in the current rayon pool, in input order. A point of the wrong length, with a
    /// value that is not finite or outside its interval, is answered with an error.
    pub fn answer(&self, points: &[Vec<f64>]) -> Result<Vec<PointAnswer>, WsmError> {
        let evaluator = self.model.warmed_evaluator(self.warm.clone())?;
        Ok(points
            .par_iter()
            .map(|point| match check_point(point, &self.parameters) {
                Ok(()) => answer(&evaluator, &self.criteria, &self.parameters, point),
                Err(reason) => PointAnswer::refused(reason),
            })
            .collect())
    }
}

/// Evaluate every point read from `input` on `scene` with the criteria and derivatives of
/// `request` (its other settings are unused), writing the header and one answer per point to
/// `output`; the number of points. Errors of the scene or the request end the stream before
/// the header; errors of a point are answer lines.
pub fn evaluate_points(
    scene: Scene,
    request: &WorstRequest,
    input: &mut dyn BufRead,
    output: &mut dyn Write,
) -> Result<usize, WsmError> {
    let evaluator = PointEvaluator::new(scene, request)?;
    let header = Header {
        parameters: evaluator.parameters(),
        criteria: evaluator.criteria(),
        derivatives: evaluator.derivatives(),
    };
    write_line(output, &header)?;
    let mut count = 0;
    for (n, line) in input.lines().enumerate() {
        let line = line.map_err(|e| WsmError::io("standard input", e))?;
        if line.trim().is_empty() {
            continue;
        }
        let answer = match read_point(&line, evaluator.parameters()) {
            Ok(point) => evaluator.answer(&[point])?.remove(0),
            Err(reason) => PointAnswer::refused(format!("line {}: {reason}", n + 1)),
        };
        write_line(output, &answer)?;
        count += 1;
    }
    Ok(count)
}

fn write_line(output: &mut dyn Write, value: &impl Serialize) -> Result<(), WsmError> {
    let text = serde_json::to_string(value).map_err(|e| WsmError::io("answer", e))?;
    writeln!(output, "{text}")
        .and_then(|()| output.flush())
        .map_err(|e| WsmError::io("standard output", e))
}

/// The physical point of one input line, checked against the intervals.
fn read_point(line: &str, info: &[ParameterInfo]) -> Result<Vec<f64>, String> {
    let value: Value = serde_json::from_str(line).map_err(|e| format!("not JSON: {e}"))?;
    let point: Vec<f64> = match value {
        Value::Array(items) => items
            .iter()
            .enumerate()
            .map(|(i, v)| number(v, info.get(i).map_or("value", |p| p.field.as_str())))
            .collect::<Result<_, _>>()?,
        Value::Object(map) => {
            if let Some(key) = map
                .keys()
                .find(|k| !info.iter().any(|p| &p.field == *k || &p.name == *k))
            {
                return Err(format!("'{key}' is not an uncertain parameter"));
            }
            info.iter()
                .map(|p| {
                    let v = map
                        .get(&p.field)
                        .or_else(|| map.get(&p.name))
                        .ok_or_else(|| format!("'{}' is missing", p.field))?;
                    number(v, &p.field)
                })
                .collect::<Result<_, _>>()?
        }
        _ => return Err("give an array of values or an object of field: value".into()),
    };
    check_point(&point, info)?;
    Ok(point)
}

/// Whether `point` is a point of the box: one finite value per datum, each in its interval.
fn check_point(point: &[f64], info: &[ParameterInfo]) -> Result<(), String> {
    if point.len() != info.len() {
        return Err(format!(
            "{} values for {} uncertain parameters",
            point.len(),
            info.len()
        ));
    }
    for (v, p) in point.iter().zip(info) {
        let [lo, hi] = p.interval;
        if !v.is_finite() {
            return Err(format!("'{}' must be a finite number, got {v}", p.field));
        }
        if !(lo..=hi).contains(v) {
            return Err(format!(
                "'{}' = {v} is outside its interval [{lo}, {hi}]",
                p.field
            ));
        }
    }
    Ok(())
}

fn number(value: &Value, field: &str) -> Result<f64, String> {
    value
        .as_f64()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("'{field}' must be a finite number, got {value}"))
}

/// Solve at `point` and name what came out.
fn answer(
    evaluator: &ScenarioEvaluator<'_>,
    criteria: &[CriterionSpec],
    info: &[ParameterInfo],
    point: &[f64],
) -> PointAnswer {
    let Evaluation {
        values,
        error,
        max_kkt_residual,
        gradient,
        ..
    } = evaluator.evaluate_one(point);
    let names = || criteria.iter().map(|c| c.name());
    PointAnswer {
        values: values.map(|v| names().zip(v).collect()),
        gradient: names()
            .zip(gradient)
            .map(|(c, slopes)| {
                let by_field = info.iter().map(|p| p.field.clone()).zip(slopes).collect();
                (c, by_field)
            })
            .collect(),
        max_kkt_residual,
        error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Criterion;

    fn block() -> Scene {
        crate::scene::parse(crate::bundled::find("block-on-base").unwrap()).unwrap()
    }

    fn run(scene: Scene, request: &WorstRequest, input: &str) -> Vec<Value> {
        let mut out = Vec::new();
        evaluate_points(scene, request, &mut input.as_bytes(), &mut out).unwrap();
        String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    }

    /// An answer equals the search's own evaluation at the same point, an object line equals
    /// the array line, and bad lines are answered with an error naming the field while the
    /// stream goes on.
    #[test]
    fn points_are_answered_in_order_and_bad_lines_name_the_field() {
        let scene = block();
        let params = parameters(&scene).unwrap();
        assert!(!params.is_empty());
        let mid: Vec<f64> = params.iter().map(|p| 0.5 * (p.lo + p.hi)).collect();
        let by_field: serde_json::Map<String, Value> = scene
            .uncertain
            .iter()
            .zip(&mid)
            .map(|(u, v)| (u.field.clone(), Value::from(*v)))
            .collect();
        let mut outside = mid.clone();
        outside[0] = params[0].hi * 2.0 + 1.0;
        let input = format!(
            "{}\n\n{}\nnot json\n{}\n{{\"nope\": 1}}\n",
            serde_json::to_string(&mid).unwrap(),
            Value::Object(by_field),
            serde_json::to_string(&outside).unwrap(),
        );
        let request = WorstRequest {
            criteria: Some(vec![Criterion::Phi3.into(), Criterion::Phi6.into()]),
            ..WorstRequest::default()
        };
        let lines = run(scene.clone(), &request, &input);
        assert_eq!(lines.len(), 6, "{lines:?}");
        assert_eq!(lines[0]["criteria"], serde_json::json!(["phi3", "phi6"]));
        assert_eq!(lines[0]["derivatives"], Value::Bool(true));

        let model = PreparedModel::new(
            scene.clone(),
            params.clone(),
            vec![Criterion::Phi3.into(), Criterion::Phi6.into()],
        )
        .unwrap()
        .with_derivatives(true);
        let expected = model.evaluator().unwrap().evaluate_one(&mid);
        let values = expected.values.unwrap();
        assert_eq!(lines[1]["values"]["phi3"].as_f64(), Some(values[0]));
        assert_eq!(lines[1]["values"]["phi6"].as_f64(), Some(values[1]));
        let field = &scene.uncertain[0].field;
        assert_eq!(
            lines[1]["gradient"]["phi3"][field]["right"].as_f64(),
            Some(expected.gradient[0][0].right)
        );
        assert_eq!(lines[2], lines[1]);
        assert!(lines[3]["error"]
            .as_str()
            .unwrap()
            .contains("line 4: not JSON"));
        let error = lines[4]["error"].as_str().unwrap();
        assert!(
            error.contains(field) && error.contains("outside its interval"),
            "{error}"
        );
        assert!(lines[5]["error"].as_str().unwrap().contains("'nope'"));
    }

    /// Without derivatives the answers carry values only; a scene error stops before the
    /// header.
    #[test]
    fn no_derivatives_and_bad_requests() {
        let scene = block();
        let n = parameters(&scene).unwrap().len();
        let lo: Vec<f64> = parameters(&scene).unwrap().iter().map(|p| p.lo).collect();
        let request = WorstRequest {
            criteria: Some(vec![Criterion::Phi3.into()]),
            derivatives: Some(false),
            ..WorstRequest::default()
        };
        let lines = run(
            scene.clone(),
            &request,
            &serde_json::to_string(&lo).unwrap(),
        );
        assert_eq!(lines[0]["parameters"].as_array().unwrap().len(), n);
        assert!(lines[1]["values"]["phi3"].is_f64());
        assert!(lines[1].get("gradient").is_none());

        let empty = WorstRequest {
            criteria: Some(Vec::new()),
            ..WorstRequest::default()
        };
        let mut out = Vec::new();
        let error = evaluate_points(scene, &empty, &mut "".as_bytes(), &mut out).unwrap_err();
        assert!(error.to_string().contains("criteria"), "{error}");
        assert!(out.is_empty());
    }
}
