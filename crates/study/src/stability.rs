//! `wsm study stability`: the catalogue of stiff and extreme cases (design §6 "Stability") —
//! stiffness contrasts 1 … 1e9 across a contact, ν from 0 to 0.4999, slip limits 0 … 1e12,
//! loads near lift-off, floating bodies that can and cannot be balanced, element aspect ratios
//! up to 1e3, SI against scaled units, a worst-scenario interval spanning four orders of
//! magnitude, each with the direct and with the DD solver.
//!
//! Every case states what must happen: solved (KKT residuals under its tolerance, finite
//! fields, an expected warning such as P1 locking present, DD equal to direct) or refused with
//! a reason naming given words. A case passes only then; a "success" above tolerance, a NaN or
//! a refusal without the reason fails it.

use std::time::Instant;

use serde::Serialize;
use serde_json::{json, Value};

use super::condition::stiffness_condition;
use wsm_core::{
    fixtures::stacked_blocks, parse_scene, Criterion, Needs, Par, RunControl, Scene, Solution,
    SolveOptions, SolverKind, StateProblem, WorstRequest, WsmError,
};

/// What a case must do.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Expect {
    /// Solved with every KKT residual ≤ `kkt`, with a warning containing `warning` if given.
    Solved {
        /// The largest KKT residual allowed (raised to the rounding level 10 κ ε and, for the DD
        /// solver, to 100 τ).
        kkt: f64,
        /// A text one of the solve's warnings must contain (e.g. P1 locking), if any.
        warning: Option<&'static str>,
    },
    /// Refused; the reason contains every word.
    Refused(Vec<&'static str>),
}

/// How a case is built.
#[derive(Debug, Clone)]
enum Input {
    Scene(Value),
    /// A scene on a given (structured) mesh.
    OnMesh(Value, Box<wsm_core::Mesh>),
    /// Two scenes on meshes of the same topology whose displacements must agree after scaling
    /// the second's by the factor.
    SameShape(Box<[(Value, wsm_core::Mesh); 2]>, f64),
    /// A worst-scenario run whose worst Φ3 must be at `worst` and best at `best` (vertex
    /// coordinates as 0 = lo, 1 = hi).
    Worst(Value, Vec<usize>, Vec<usize>),
}

/// One case of the catalogue.
#[derive(Debug, Clone)]
pub struct Case {
    /// The family of the case ("stiffness contrast", …), the first column of the table.
    pub group: &'static str,
    /// The case within its group, e.g. its parameter value.
    pub name: String,
    input: Input,
    /// What the case must do: be solved within tolerance or refused with a reason.
    pub expect: Expect,
}

/// The outcome of one case with one solver.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaseResult {
    /// The case's group.
    pub group: String,
    /// The case's name within its group.
    pub name: String,
    /// The solver: "direct" or "dd".
    pub solver: String,
    /// `solved` or `refused`.
    pub outcome: String,
    /// The refusal's message, or what was wrong with a solved case (non-finite values, worst
    /// scenario away from the expected vertex).
    pub reason: Option<String>,
    /// The largest KKT residual of the solve (or of the run's inner solves).
    pub max_kkt: Option<f64>,
    /// QP iterations (direct) or PCG1 / outer / PCG2 (DD).
    pub iterations: String,
    /// κ(K_ff) without the floating bodies' rigid motions.
    pub condition: Option<f64>,
    /// The DD tolerance (DD rows).
    pub dd_tolerance: Option<f64>,
    /// Max |u_dd − u_direct| / max |u_direct| (DD rows), or of the rescaled displacements
    /// (units cases).
    pub difference: Option<f64>,
    /// The solve's or run's warnings.
    pub warnings: Vec<wsm_core::Warning>,
    /// Wall-clock time of the case \[s\].
    pub seconds: f64,
    /// The result meets the case's expectation (no failure).
    pub passed: bool,
    /// Why the case failed its expectation.
    pub failure: Option<String>,
}

/// A block pressed on a clamped base and pushed sideways by a prescribed displacement of its
/// left side (so it is held whatever g is); the criteria region lies in the block.
pub fn pushed_block(e_base: f64, e_block: f64, nu: f64, g: f64, pressure: f64) -> Value {
    json!({
        "version": 1, "name": "pushed block",
        "bodies": [
            {"name": "base", "zones": [{"name": "base", "material": "base", "polygon": [[0,0],[2,0],[2,0.5],[0,0.5]]}]},
            {"name": "block", "zones": [{"name": "block", "material": "block", "polygon": [[0.5,0.5],[1.5,0.5],[1.5,1],[0.5,1]]}]}
        ],
        "segments": {
            "bottom": {"body": "base", "from": [0,0], "to": [2,0]},
            "left": {"body": "block", "from": [0.5,1], "to": [0.5,0.5]},
            "top": {"body": "block", "from": [1.5,1], "to": [0.5,1]},
            "base_top": {"body": "base", "from": [0.5,0.5], "to": [1.5,0.5]},
            "block_bottom": {"body": "block", "from": [0.5,0.5], "to": [1.5,0.5]}
        },
        "materials": {"base": {"E": e_base, "nu": nu}, "block": {"E": e_block, "nu": nu}},
        "boundary": [
            {"segment": "bottom", "displacement": [0, 0]},
            {"segment": "left", "displacement": [1.0e-6, null]},
            {"segment": "top", "pressure": pressure}
        ],
        "contacts": [{"name": "c", "between": ["block_bottom", "base_top"], "slip_limit": g}],
        "criteria": {"regions": [{"name": "G", "polygon": [[0.9,0.8],[1.1,0.8],[1.1,1],[0.9,1]], "normal_at": [1.0, 1.0]}]},
        "mesh": {"max_size": 0.1}
    })
}

/// Two thin layers 10 m long and `t` thick, one cell across: cells of aspect ratio 1/t.
fn thin_layers(t: f64) -> (Value, wsm_core::Mesh) {
    layers(10.0, t, 1, 1.0, 1.0)
}

/// Two layers `width` long and `t` thick (`ny` cells across each), every length × `length`
/// and every stress × `stress`.
fn layers(width: f64, t: f64, ny: usize, length: f64, stress: f64) -> (Value, wsm_core::Mesh) {
    let (w, t) = (width * length, t * length);
    let mesh = stacked_blocks(w, t, t, 10, ny, ny);
    let seg = |body: &str, a: [f64; 2], b: [f64; 2]| json!({"body": body, "from": a, "to": b});
    let scene = json!({
        "version": 1, "name": "thin layers",
        "bodies": [
            {"name": "lower", "zones": [{"name": "lower", "material": "a", "polygon": [[0,0],[w,0],[w,t],[0,t]]}]},
            {"name": "upper", "zones": [{"name": "upper", "material": "b", "polygon": [[0,t],[w,t],[w,2.0*t],[0,2.0*t]]}]}
        ],
        "segments": {
            "lower_bottom": seg("lower", [0.0, 0.0], [w, 0.0]),
            "lower_left": seg("lower", [0.0, t], [0.0, 0.0]),
            "lower_right": seg("lower", [w, 0.0], [w, t]),
            "lower_top": seg("lower", [w, t], [0.0, t]),
            "upper_bottom": seg("upper", [0.0, t], [w, t]),
            "upper_left": seg("upper", [0.0, 2.0 * t], [0.0, t]),
            "upper_right": seg("upper", [w, t], [w, 2.0 * t]),
            "upper_top": seg("upper", [w, 2.0 * t], [0.0, 2.0 * t])
        },
        "materials": {"a": {"E": 1.0e10 * stress, "nu": 0.3}, "b": {"E": 1.0e10 * stress, "nu": 0.3}},
        "boundary": [
            {"segment": "lower_bottom", "displacement": [0, 0]},
            {"segment": "upper_left", "displacement": [1.0e-6 * length, null]},
            {"segment": "upper_top", "pressure": 1.0e5 * stress}
        ],
        "contacts": [{"name": "interface", "between": ["lower_top", "upper_bottom"], "slip_limit": 1.0e4 * stress}],
        "mesh": {"max_size": w / 10.0}
    });
    (scene, mesh)
}

fn solved(kkt: f64) -> Expect {
    Expect::Solved { kkt, warning: None }
}

/// The catalogue (each case runs with the direct and with the DD solver).
pub fn catalogue() -> Vec<Case> {
    let mut cases = Vec::new();
    let mut add = |group, name: String, input, expect| {
        cases.push(Case {
            group,
            name,
            input,
            expect,
        })
    };
    for (e_base, e_block) in [
        (2e10, 2e10),
        (2e10, 2e7),
        (2e10, 2e4),
        (2e10, 2e1),
        (2e4, 2e10),
        (2e1, 2e10),
    ] {
        add(
            "stiffness contrast",
            format!("E base / block = {:.0e}", e_base / e_block),
            Input::Scene(pushed_block(e_base, e_block, 0.3, 1e5, 1e4)),
            solved(1e-9),
        );
    }
    for nu in [0.0, 0.25, 0.45, 0.49, 0.499, 0.4999] {
        add(
            "Poisson's ratio",
            format!("ν = {nu}"),
            Input::Scene(pushed_block(1e9, 1e9, nu, 1e5, 1e5)),
            Expect::Solved {
                kkt: 1e-9,
                warning: (nu >= 0.49).then_some("lock"),
            },
        );
    }
    for g in [0.0, 1.0, 1e3, 1e6, 1e9, 1e12] {
        add(
            "slip limit",
            format!("g = {g:.0e} Pa"),
            Input::Scene(pushed_block(1e10, 1e10, 0.25, g, 1e5)),
            solved(1e-9),
        );
    }
    // The block weighs 2.45e4 N/m³ × 0.5 m = 12250 Pa over its top.
    let pulled = |p: f64| {
        let mut v = pushed_block(1e10, 1e10, 0.25, 1e4, p);
        v["materials"]["block"]["specific_weight"] = json!(2.45e4);
        v
    };
    add(
        "near lift-off",
        "pull 10 N/m below lift-off".into(),
        Input::Scene(pulled(-12_240.0)),
        solved(1e-9),
    );
    add(
        "near lift-off",
        "pull 10 N/m above lift-off".into(),
        Input::Scene(pulled(-12_260.0)),
        Expect::Refused(vec!["'block'", "(0.000, 1.000)"]),
    );
    let mut no_contact = pushed_block(1e10, 1e10, 0.25, 1e5, 1e5);
    no_contact["boundary"][1] = json!({"segment": "left", "traction": [1.0e3, 0]});
    no_contact["contacts"] = json!([]);
    add(
        "floating body",
        "no support, no contact".into(),
        Input::Scene(no_contact),
        Expect::Refused(vec!["'block'"]),
    );
    let mut frictionless = pushed_block(1e10, 1e10, 0.25, 0.0, 1e5);
    if let Some(b) = frictionless["boundary"].as_array_mut() {
        b.remove(1);
    }
    add(
        "floating body",
        "frictionless, balanced vertical load".into(),
        Input::Scene(frictionless),
        Expect::Solved {
            kkt: 1e-9,
            warning: Some("not determined"),
        },
    );
    let block: Value = serde_json::from_str(wsm_core::example("block-on-base").unwrap_or("{}"))
        .unwrap_or(Value::Null);
    let mut coarse = block.clone();
    coarse["mesh"] = json!({"max_size": 0.1});
    add(
        "floating body",
        "held by friction (block-on-base)".into(),
        Input::Scene(coarse.clone()),
        solved(1e-9),
    );
    let mut pushed_off = coarse;
    pushed_off["boundary"][2]["traction"] = json!([7.0e5, 0]);
    // One solve of that push: the example's interval [3e5, 4e5] for it would not hold it.
    pushed_off["uncertain"] = json!([]);
    add(
        "floating body",
        "push above the friction capacity".into(),
        Input::Scene(pushed_off),
        Expect::Refused(vec!["'block'", "translation"]),
    );
    for t in [0.1, 0.01, 0.001] {
        let (scene, mesh) = thin_layers(t);
        add(
            "aspect ratio",
            format!("cells 1 m × {t} m (aspect {:.0})", 1.0 / t),
            Input::OnMesh(scene, Box::new(mesh)),
            solved(1e-6),
        );
    }
    let si = layers(2.0, 0.2, 4, 1.0, 1.0);
    add(
        "units",
        "Pa against GPa".into(),
        Input::SameShape(Box::new([si.clone(), layers(2.0, 0.2, 4, 1.0, 1e-9)]), 1.0),
        solved(1e-9),
    );
    add(
        "units",
        "m against mm".into(),
        Input::SameShape(Box::new([si, layers(2.0, 0.2, 4, 1e3, 1.0)]), 1e-3),
        solved(1e-9),
    );
    let mut wide = pushed_block(2e10, 2e10, 0.3, 1e5, 1.5e5);
    wide["uncertain"] = json!([
        {"field": "materials.block.E", "interval": [2.0e6, 2.0e10]},
        {"field": "boundary[2].pressure", "interval": [1.0e5, 2.0e5]}
    ]);
    wide["search"] = json!({"criteria": ["phi3"], "budget": 24, "seed": 1});
    // Φ3 = mean u·n under the top (n = +y): largest for the stiffest block and least pressure.
    add(
        "wide interval",
        "E of the block in [2e6, 2e10] Pa".into(),
        Input::Worst(wide, vec![1, 0], vec![0, 1]),
        solved(1e-9),
    );
    cases
}

/// Run every case with both solvers (the DD row after its direct row).
pub fn run_catalogue(cases: &[Case]) -> Vec<CaseResult> {
    let mut out = Vec::new();
    for case in cases {
        let direct = run_case(case, SolverKind::Direct, None);
        let reference = direct.1;
        out.push(direct.0);
        out.push(run_case(case, SolverKind::Dd, reference.as_deref()).0);
    }
    out
}

fn with_solver(v: &Value, kind: SolverKind) -> Result<Scene, WsmError> {
    let mut scene = parse_scene(&v.to_string())?;
    scene.solver.kind = kind;
    if kind == SolverKind::Dd {
        scene.solver.subdomains = 4;
    }
    Ok(scene)
}

fn solve(problem: &StateProblem) -> Result<Solution, WsmError> {
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: Par::Seq,
        warm: None,
    };
    problem.solve(&problem.nominal, &options)
}

fn max_abs(u: &[[f64; 2]]) -> f64 {
    u.iter().flatten().fold(0.0_f64, |m, x| m.max(x.abs()))
}

fn difference(a: &[[f64; 2]], b: &[[f64; 2]], scale: f64) -> f64 {
    let d = a.iter().zip(b).fold(0.0_f64, |m, (x, y)| {
        m.max((x[0] - scale * y[0]).abs())
            .max((x[1] - scale * y[1]).abs())
    });
    d / max_abs(a).max(f64::MIN_POSITIVE)
}

fn finite(sol: &Solution) -> bool {
    sol.displacement.iter().flatten().all(|x| x.is_finite())
        && sol
            .stresses
            .iter()
            .all(|s| s.stress.iter().all(|x| x.is_finite()))
        && sol
            .contact
            .iter()
            .all(|c| c.pressure.is_finite() && c.shear.is_finite())
        && sol.criteria.iter().flatten().all(|x| x.is_finite())
}

/// One case with one solver; the displacement of a solved single-scene case (the reference of
/// its DD row).
fn run_case(
    case: &Case,
    kind: SolverKind,
    reference: Option<&[[f64; 2]]>,
) -> (CaseResult, Option<Vec<[f64; 2]>>) {
    let start = Instant::now();
    let mut result = CaseResult {
        group: case.group.into(),
        name: case.name.clone(),
        solver: match kind {
            SolverKind::Direct => "direct".into(),
            SolverKind::Dd => "dd".into(),
        },
        outcome: "refused".into(),
        reason: None,
        max_kkt: None,
        iterations: String::new(),
        condition: None,
        dd_tolerance: (kind == SolverKind::Dd)
            .then(|| wsm_core::SolverSettings::default().tolerance),
        difference: None,
        warnings: Vec::new(),
        seconds: 0.0,
        passed: false,
        failure: None,
    };
    let mut displacement = None;
    let attempt = attempt(case, kind, reference, &mut result, &mut displacement);
    if let Err(e) = attempt {
        result.outcome = "refused".into();
        result.reason = Some(e.to_string());
    }
    result.seconds = start.elapsed().as_secs_f64();
    result.failure = verdict(case, &result);
    result.passed = result.failure.is_none();
    (result, displacement)
}

fn attempt(
    case: &Case,
    kind: SolverKind,
    reference: Option<&[[f64; 2]]>,
    result: &mut CaseResult,
    displacement: &mut Option<Vec<[f64; 2]>>,
) -> Result<(), WsmError> {
    let record = |result: &mut CaseResult, sol: &Solution| {
        let report = &sol.report;
        result.max_kkt = Some(report.kkt.max());
        result.iterations = match &report.dd {
            Some(d) => format!(
                "{} / {} / {}{}",
                d.pcg1_iterations,
                d.outer_iterations,
                d.pcg2_iterations,
                if d.fallback.is_some() {
                    " (fallback)"
                } else {
                    ""
                }
            ),
            None => format!("QP {}", report.qp_iterations),
        };
        result.warnings.extend(report.warnings.iter().cloned());
        if !finite(sol) {
            result.reason = Some("non-finite values in the solution".into());
        }
    };
    match &case.input {
        Input::Scene(_) | Input::OnMesh(..) => {
            let problem = match &case.input {
                Input::OnMesh(v, mesh) => StateProblem::with_mesh(
                    with_solver(v, kind)?,
                    (**mesh).clone(),
                    Instant::now(),
                )?,
                Input::Scene(v) => StateProblem::new(with_solver(v, kind)?)?,
                _ => unreachable!("matched above"),
            };
            result.condition = stiffness_condition(&problem, &problem.nominal)
                .ok()
                .flatten();
            let sol = solve(&problem)?;
            result.outcome = "solved".into();
            record(result, &sol);
            if let Some(r) = reference {
                result.difference = Some(difference(r, &sol.displacement, 1.0));
            }
            *displacement = Some(sol.displacement);
        }
        Input::SameShape(pair, scale) => {
            let [(a, ma), (b, mb)] = pair.as_ref();
            let pa = StateProblem::with_mesh(with_solver(a, kind)?, ma.clone(), Instant::now())?;
            let pb = StateProblem::with_mesh(with_solver(b, kind)?, mb.clone(), Instant::now())?;
            let (sa, sb) = (solve(&pa)?, solve(&pb)?);
            result.outcome = "solved".into();
            record(result, &sb);
            result.condition = stiffness_condition(&pa, &pa.nominal).ok().flatten();
            let kkt = sa.report.kkt.max().max(sb.report.kkt.max());
            result.max_kkt = Some(kkt);
            result.difference = Some(difference(&sa.displacement, &sb.displacement, *scale));
        }
        Input::Worst(v, worst, best) => {
            let scene = with_solver(v, kind)?;
            let request = WorstRequest {
                criteria: Some(vec![Criterion::Phi3.into()]),
                accuracy_refinements: Some(0),
                ..WorstRequest::default()
            };
            let params = wsm_core::scene_parameters(&scene)?;
            let outcome = wsm_core::worst(scene, &request, &RunControl::new())?;
            result.outcome = "solved".into();
            result.max_kkt = Some(outcome.inner.max_kkt_residual);
            result.iterations = format!("{} solves", outcome.inner.solves);
            let c = &outcome.criteria[0];
            let at = |point: &Option<Vec<f64>>, vertex: &[usize]| {
                point.as_ref().is_some_and(|p| {
                    p.iter().zip(vertex).zip(&params).all(|((x, &v), q)| {
                        let target = if v == 0 { q.lo } else { q.hi };
                        (x - target).abs() <= 1e-9 * target.abs()
                    })
                })
            };
            let values_finite = [c.worst.value, c.best.value]
                .iter()
                .all(|v| v.is_some_and(f64::is_finite));
            if !(values_finite && at(&c.worst.point, worst) && at(&c.best.point, best)) {
                result.reason = Some(format!(
                    "worst {:?} at {:?}, best {:?} at {:?}: not the expected vertices",
                    c.worst.value, c.worst.point, c.best.value, c.best.point
                ));
            }
            result.warnings = outcome.warnings;
        }
    }
    Ok(())
}

/// The residual a solve can promise at condition number κ: relative residuals at 10 κ ε are at
/// the rounding level of K itself.
fn rounding_level(condition: Option<f64>) -> f64 {
    condition.map_or(0.0, |k| 10.0 * k * f64::EPSILON)
}

/// Why the result does not meet the case's expectation (`None`: passed). A solved case's KKT
/// residuals and DD − direct difference must stay below max(its tolerance, 10 κ ε), and for the
/// DD solver, which stops on the relative change τ of its iterates, below 100 τ (a slowly
/// contracting iteration leaves residuals of τ / (1 − q)).
fn verdict(case: &Case, r: &CaseResult) -> Option<String> {
    match (&case.expect, r.outcome.as_str()) {
        (Expect::Solved { kkt, warning }, "solved") => {
            if let Some(reason) = &r.reason {
                return Some(reason.clone());
            }
            let tol = kkt
                .max(rounding_level(r.condition))
                .max(r.dd_tolerance.map_or(0.0, |t| 100.0 * t));
            match r.max_kkt {
                Some(k) if k <= tol => {}
                other => return Some(format!("KKT residual {other:?} above {tol:.1e}")),
            }
            if let Some(w) = warning {
                if !r.warnings.iter().any(|x| x.contains(w)) {
                    return Some(format!("no warning containing '{w}': {:?}", r.warnings));
                }
            }
            let tol = 1e-6_f64.max(rounding_level(r.condition));
            match r.difference {
                Some(d) if d > tol => Some(format!("differs by {d:.1e} (above {tol:.1e})")),
                _ => None,
            }
        }
        (Expect::Solved { .. }, _) => {
            Some(format!("refused: {}", r.reason.as_deref().unwrap_or("?")))
        }
        (Expect::Refused(words), "refused") => {
            let reason = r.reason.as_deref().unwrap_or_default();
            let missing: Vec<&&str> = words.iter().filter(|w| !reason.contains(**w)).collect();
            (!missing.is_empty()).then(|| format!("reason '{reason}' does not name {missing:?}"))
        }
        (Expect::Refused(_), _) => Some("solved, but it must be refused".into()),
    }
}

/// The catalogue as a Markdown table; `command` made it.
pub fn markdown(results: &[CaseResult], command: &str) -> String {
    use std::fmt::Write;
    let sci = |v: Option<f64>| v.map_or("—".into(), |x| format!("{x:.1e}"));
    let mut out = format!(
        "### Stability catalogue\n\nMade by `{command}`. {} of {} rows pass.\n\n| group | case | solver | outcome | max KKT | iterations | κ(K) | DD − direct / shape | time [s] | notes | pass |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
        results.iter().filter(|r| r.passed).count(),
        results.len()
    );
    for r in results {
        let mut notes: Vec<String> = r.warnings.iter().map(|w| short(&w.to_string())).collect();
        if let Some(reason) = &r.reason {
            notes.insert(0, short(reason));
        }
        if let Some(f) = &r.failure {
            notes.push(format!("FAILED: {f}"));
        }
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.3} | {} | {} |",
            r.group,
            r.name,
            r.solver,
            r.outcome,
            sci(r.max_kkt),
            r.iterations,
            sci(r.condition),
            sci(r.difference),
            r.seconds,
            notes.join("; ").replace('|', "/"),
            if r.passed { "yes" } else { "**no**" }
        );
    }
    out
}

/// A message cut to its first 140 characters.
fn short(s: &str) -> String {
    if s.chars().count() > 140 {
        format!("{}…", s.chars().take(140).collect::<String>())
    } else {
        s.to_string()
    }
}
