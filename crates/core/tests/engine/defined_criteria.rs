//! Criteria defined in the scene (design §4.2, `criteria.defined`): the mean of a stress
//! component, a principal stress or the von Mises stress over an area, and the mean contact
//! pressure or tangential traction over a piece of a contact zone.
//!
//! - Their exact derivatives (adjoint, and the forward tangent) equal central differences of
//!   whole solves to 1e-6 relative where the state is smooth (the difference with step h agreeing
//!   with the one of step h/2), on the block on a base (Tresca friction, three data) and Hertz
//!   (P1, and the MINI mixed element at ν = 0.499).
//! - At the nominal data their values equal the outputs they average: `piece_contact_pressure`,
//!   the region means of the `von_mises` and principal-stress fields, and −(Φ6's region value)
//!   for σyy where the region's normal is vertical.
//! - A worst-scenario run on Hertz for a mean contact pressure and a mean von Mises stress ends
//!   locally certified.

use serde_json::{json, Value};
use wsm_core::{
    apply_parameters, parameter_stencil, parse_scene, result_fields, result_summary,
    scene_parameters, worst, Criterion, CriterionSpec, DerivativeRoute, Needs, RunControl, Scene,
    SolveOptions, StateProblem, Status, StopRule, Target, WorstRequest,
};

const STRESS_QUANTITIES: [&str; 7] = [
    "sigma_xx",
    "sigma_yy",
    "tau_xy",
    "sigma_zz",
    "sigma1",
    "sigma2",
    "von_mises",
];

fn bundled(name: &str) -> Value {
    serde_json::from_str(wsm_core::example(name).unwrap()).unwrap()
}

/// `scene` with a defined criterion per stress quantity over `area` and the contact pressure and
/// shear over a new boundary piece `piece` (`segment`, from `from` to `to`).
fn with_defined(
    mut scene: Value,
    area: &str,
    segment: &str,
    from: [f64; 2],
    to: [f64; 2],
) -> Value {
    let criteria = &mut scene["criteria"];
    let mut pieces = criteria["boundary_pieces"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    pieces.push(json!({"name": "contact piece", "segment": segment, "from": from, "to": to}));
    criteria["boundary_pieces"] = Value::Array(pieces);
    let mut defined: Vec<Value> = STRESS_QUANTITIES
        .iter()
        .map(|q| json!({"name": format!("mean_{q}"), "region": area, "quantity": q}))
        .collect();
    defined.push(
        json!({"name": "pressure", "region": "contact piece", "quantity": "contact_pressure"}),
    );
    defined.push(json!({"name": "shear", "region": "contact piece", "quantity": "contact_shear"}));
    criteria["defined"] = Value::Array(defined);
    scene
}

fn block() -> Scene {
    let v = with_defined(
        bundled("block-on-base"),
        "G1",
        "block_contact",
        [0.8, 0.5],
        [1.2, 0.5],
    );
    parse_scene(&v.to_string()).unwrap()
}

fn hertz() -> Value {
    let mut v = with_defined(
        bundled("hertz"),
        "at contact",
        "cylinder_contact",
        [-0.02, 0.0],
        [0.02, 0.0],
    );
    // Coarser than the bundled mesh: the test is about derivatives, not Hertz's accuracy.
    v["mesh"]["refine"][0]["max_size"] = json!(0.016);
    v
}

fn names() -> Vec<String> {
    let mut names: Vec<String> = STRESS_QUANTITIES
        .iter()
        .map(|q| format!("mean_{q}"))
        .collect();
    names.extend(["pressure".to_string(), "shear".to_string()]);
    names
}

fn specs() -> Vec<CriterionSpec> {
    names()
        .iter()
        .map(|n| CriterionSpec::parse(n).unwrap())
        .collect()
}

fn options(problem: &StateProblem, targets: &[Target]) -> SolveOptions {
    SolveOptions {
        needs: Needs::for_targets(&problem.scene, targets),
        par: wsm_core::Par::Seq,
        warm: None,
    }
}

/// The values of the targets at θ.
fn values_at(problem: &StateProblem, targets: &[Target], theta: &[f64]) -> Vec<f64> {
    let params = scene_parameters(&problem.scene).unwrap();
    let data = apply_parameters(&problem.scene, &problem.nominal, &params, theta);
    let solution = problem.solve(&data, &options(problem, targets)).unwrap();
    targets
        .iter()
        .map(|&t| solution.value(t).unwrap())
        .collect()
}

/// At θ, every target's derivative by the adjoint and by the forward tangent against central
/// differences; returns (components compared, largest relative error, components skipped as
/// straddling a kink).
fn check_derivatives(scene: Scene, theta_of: impl Fn(f64, f64) -> f64) -> (usize, f64, usize) {
    let problem = StateProblem::new(scene).unwrap();
    let targets = problem.targets(&specs()).unwrap();
    assert!(targets.iter().all(|t| t.criterion == Criterion::Defined));
    let params = scene_parameters(&problem.scene).unwrap();
    let theta: Vec<f64> = params.iter().map(|p| theta_of(p.lo, p.hi)).collect();
    let data = apply_parameters(&problem.scene, &problem.nominal, &params, &theta);
    let stencils: Vec<_> = (0..params.len())
        .map(|j| parameter_stencil(&problem.scene, &problem.nominal, &params, &theta, j))
        .collect();
    let opts = options(&problem, &targets);
    let adjoint = problem
        .solve_with_sensitivities_by(&data, &opts, &stencils, DerivativeRoute::Adjoint)
        .unwrap();
    let forward = problem
        .solve_with_sensitivities_by(&data, &opts, &stencils, DerivativeRoute::Forward)
        .unwrap();
    eprintln!(
        "{} of {} directions by the adjoint",
        adjoint.report.adjoint_directions,
        params.len()
    );
    let (mut compared, mut worst, mut kinks) = (0, 0.0_f64, 0);
    for (j, p) in params.iter().enumerate() {
        let h = 1e-4 * (p.hi - p.lo);
        let fd = |h: f64| -> Vec<f64> {
            let (mut plus, mut minus) = (theta.clone(), theta.clone());
            plus[j] += h;
            minus[j] -= h;
            let (a, b) = (
                values_at(&problem, &targets, &plus),
                values_at(&problem, &targets, &minus),
            );
            a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)).collect()
        };
        let (coarse, fine) = (fd(h), fd(0.5 * h));
        let largest = targets
            .iter()
            .map(|&t| adjoint.value(t).unwrap().abs())
            .fold(0.0, f64::max);
        for (k, &t) in targets.iter().enumerate() {
            let a = adjoint.derivative(t, j).unwrap();
            let f = forward.derivative(t, j).unwrap();
            assert_eq!(a.left, a.right, "smooth state: one derivative");
            let value = adjoint.value(t).unwrap();
            // The scale of a derivative: the criterion's size per the interval's width, at
            // least 1e-12 of the largest criterion's (a traction that is zero by symmetry has a
            // derivative at rounding level).
            let scale = (value.abs() / (p.hi - p.lo))
                .max(a.right.abs())
                .max(1e-12 * largest / (p.hi - p.lo));
            assert!(
                (a.right - f.right).abs() <= 1e-9 * scale,
                "{} along {}: adjoint {} forward {}",
                names()[k],
                p.name,
                a.right,
                f.right
            );
            if (coarse[k] - fine[k]).abs() > 1e-5 * scale {
                kinks += 1;
                continue;
            }
            let error = (a.right - fine[k]).abs() / scale;
            assert!(
                error <= 1e-6,
                "{} along {}: exact {} vs central difference {} (relative {error:.1e})",
                names()[k],
                p.name,
                a.right,
                fine[k]
            );
            compared += 1;
            worst = worst.max(error);
        }
    }
    (compared, worst, kinks)
}

#[test]
fn derivatives_equal_central_differences_on_the_block_with_friction() {
    for (label, at) in [("centre", 0.5), ("off centre", 0.3)] {
        let (compared, worst, kinks) = check_derivatives(block(), |lo, hi| lo + at * (hi - lo));
        eprintln!(
            "block at {label}: {compared} compared, worst relative {worst:.1e}, {kinks} kinks"
        );
        assert!(compared >= 8 * 3, "{compared} compared, {kinks} kinks");
    }
}

#[test]
fn derivatives_equal_central_differences_on_hertz() {
    let scene = parse_scene(&hertz().to_string()).unwrap();
    let (compared, worst, kinks) = check_derivatives(scene, |lo, hi| lo + 0.37 * (hi - lo));
    eprintln!("hertz: {compared} compared, worst relative {worst:.1e}, {kinks} kinks");
    assert!(compared >= 8, "{compared} compared, {kinks} kinks");
}

/// Hertz with the MINI mixed element at ν = 0.499 (design §2.7), Young's modulus and Poisson's
/// ratio uncertain besides the load: the stress means read the recovered pressure, whose
/// derivative and adjoint are the mixed element's own.
#[test]
fn derivatives_equal_central_differences_on_mixed_hertz() {
    let mut v = hertz();
    v["mesh"]["element"] = json!("mixed");
    v["materials"]["steel"]["nu"] = json!(0.499);
    let uncertain = v["uncertain"].as_array_mut().unwrap();
    uncertain.push(json!({"field": "materials.steel.E", "interval": [1.8e11, 2.2e11]}));
    uncertain.push(json!({"field": "materials.steel.nu", "interval": [0.49, 0.4995]}));
    let scene = parse_scene(&v.to_string()).unwrap();
    let (compared, worst, kinks) = check_derivatives(scene, |lo, hi| lo + 0.37 * (hi - lo));
    eprintln!("mixed hertz: {compared} compared, worst relative {worst:.1e}, {kinks} kinks");
    assert!(compared >= 8 * 3, "{compared} compared, {kinks} kinks");
}

#[test]
fn nominal_values_equal_the_outputs() {
    let problem = StateProblem::new(block()).unwrap();
    let solution = problem
        .solve(
            &problem.nominal,
            &SolveOptions {
                needs: Needs::all(&problem.scene),
                par: wsm_core::Par::Seq,
                warm: None,
            },
        )
        .unwrap();
    let out = result_summary(&problem, &problem.nominal, &solution);
    let field = result_fields(&problem, &solution);
    let defined = &out.defined_criteria;
    assert_eq!(defined.len(), 9);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
    // The contact pressure as `piece_contact_pressure` reports it.
    let pressure = out.piece_contact_pressure["contact piece"];
    assert!(pressure > 0.0);
    assert!(
        close(defined["pressure"], pressure),
        "{} vs {pressure}",
        defined["pressure"]
    );
    // The stress fields' means over the area G1.
    let area = &problem.criteria.regions[0];
    let mean = |f: &dyn Fn(usize) -> f64| -> f64 {
        area.element_weights.iter().map(|&(e, w)| w * f(e)).sum()
    };
    let checks: [(&str, f64); 7] = [
        ("mean_sigma_xx", mean(&|e| field.stress[e][0])),
        ("mean_sigma_yy", mean(&|e| field.stress[e][1])),
        ("mean_tau_xy", mean(&|e| field.stress[e][2])),
        ("mean_sigma_zz", mean(&|e| field.stress[e][3])),
        ("mean_sigma1", mean(&|e| field.principal_stress[e][0])),
        ("mean_sigma2", mean(&|e| field.principal_stress[e][1])),
        ("mean_von_mises", mean(&|e| field.von_mises[e])),
    ];
    for (name, expected) in checks {
        assert!(
            close(defined[name], expected),
            "{name}: {} vs {expected}",
            defined[name]
        );
    }
    // G1's normal is vertical (the base's top at (1, 0.5)): Φ6 there is −σyy's mean.
    let phi6 = out.region_values["phi6"]["G1"];
    assert!(
        close(defined["mean_sigma_yy"], -phi6),
        "{} vs {phi6}",
        defined["mean_sigma_yy"]
    );
    // σ1 ≥ σ2, von Mises ≥ 0; the shear under a push is bounded by the slip limit (Tresca).
    assert!(defined["mean_sigma1"] >= defined["mean_sigma2"] && defined["mean_von_mises"] > 0.0);
    assert!(
        defined["shear"].abs() <= 300000.0 * (1.0 + 1e-9),
        "{}",
        defined["shear"]
    );
}

#[test]
fn a_worst_scenario_run_on_defined_criteria_on_hertz_is_certified() {
    let mut v = hertz();
    v["search"]["criteria"] = json!(["pressure", "mean_von_mises"]);
    let scene = parse_scene(&v.to_string()).unwrap();
    let request = WorstRequest {
        budget: Some(40),
        stop: Some(StopRule::FirstCertificate),
        ..WorstRequest::default()
    };
    let r = worst(scene, &request, &RunControl::new()).unwrap();
    assert_eq!(r.criteria.len(), 2);
    for c in &r.criteria {
        for o in [&c.worst, &c.best] {
            assert_eq!(
                o.status,
                Status::LocallyCertified,
                "{}: {:?}",
                c.criterion,
                o.certificate
            );
        }
        eprintln!(
            "{}: worst {:?} at {:?}, best {:?} at {:?} ({} evaluations in the run)",
            c.criterion, c.worst.value, c.worst.point, c.best.value, c.best.point, r.evaluations
        );
    }
    assert_eq!(r.status, Status::LocallyCertified);
    // The names a user reads, and the region each averages over.
    assert_eq!(r.criteria[0].criterion.name(), "pressure");
    assert_eq!(r.criteria[0].worst.region.as_deref(), Some("contact piece"));
    assert_eq!(r.criteria[1].worst.region.as_deref(), Some("at contact"));
    // A higher load presses harder: the worst pressure is at the largest load.
    let p = scene_parameters(&parse_scene(&v.to_string()).unwrap()).unwrap();
    assert_eq!(r.criteria[0].worst.point.as_ref().unwrap()[0], p[0].hi);
}

#[test]
fn bad_definitions_are_refused_with_the_field() {
    let base = with_defined(
        bundled("block-on-base"),
        "G1",
        "block_contact",
        [0.8, 0.5],
        [1.2, 0.5],
    );
    let refused = |edit: &dyn Fn(&mut Value), field: &str| {
        let mut v = base.clone();
        edit(&mut v);
        let e = parse_scene(&v.to_string()).unwrap_err().to_string();
        assert!(e.contains(field), "{field}: {e}");
    };
    refused(
        &|v| v["criteria"]["defined"][0]["name"] = json!("phi7"),
        "criteria.defined[0].name",
    );
    refused(
        &|v| v["criteria"]["defined"][1]["name"] = json!("mean_sigma_xx"),
        "criteria.defined[1].name",
    );
    refused(
        &|v| v["criteria"]["defined"][0]["region"] = json!("nowhere"),
        "criteria.defined[0].region",
    );
    // A contact traction over an area, a stress over a piece, a piece off the contact zones.
    refused(
        &|v| v["criteria"]["defined"][7]["region"] = json!("G1"),
        "criteria.defined[7].region",
    );
    refused(
        &|v| v["criteria"]["defined"][0]["region"] = json!("G1'"),
        "criteria.defined[0].region",
    );
    refused(
        &|v| v["criteria"]["defined"][8]["region"] = json!("G1'"),
        "criteria.defined[8].region",
    );
    // A search for an undefined name names the list entry.
    let mut v = base.clone();
    v["search"]["criteria"] = json!(["pressure", "no_such"]);
    let scene = parse_scene(&v.to_string()).unwrap();
    let e = worst(scene, &WorstRequest::default(), &RunControl::new())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no_such"), "{e}");
    // The names keep their meaning: `phi3` is Φ3, `pressure` a defined criterion.
    assert_eq!(
        CriterionSpec::parse("phi3").unwrap().criterion,
        Criterion::Phi3
    );
    assert_eq!(
        CriterionSpec::parse(" pressure ").unwrap(),
        CriterionSpec::defined("pressure")
    );
    assert!(CriterionSpec::parse("phi7").is_err());
}
