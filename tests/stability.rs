//! Stiff and extreme cases (SPEC §6 "Stability", issue "Contact"): each is either solved with
//! small KKT residuals and finite fields, or refused with a clear reason — never a NaN, a panic
//! or a hang.

use std::time::Instant;

use serde_json::{json, Value};
use wsm::scene::parse;
use wsm::state::{Needs, Solution, SolveOptions, StateProblem};

fn solve_value(v: &Value) -> Result<(StateProblem, Solution), wsm::error::WsmError> {
    let scene = parse(&v.to_string())?;
    let problem = StateProblem::new(scene)?;
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm::fem::Par::Seq,
        warm: None,
    };
    let sol = problem.solve(&problem.nominal, &options)?;
    Ok((problem, sol))
}

fn assert_sound(sol: &Solution, what: &str) {
    assert_sound_to(sol, what, 1e-9);
}

fn assert_sound_to(sol: &Solution, what: &str, tol: f64) {
    assert!(sol.report.kkt.max() <= tol, "{what}: {:?}", sol.report.kkt);
    assert!(
        sol.displacement
            .iter()
            .all(|u| u[0].is_finite() && u[1].is_finite()),
        "{what}: non-finite displacement"
    );
    assert!(
        sol.stresses
            .iter()
            .all(|s| s.stress.iter().all(|x| x.is_finite())),
        "{what}"
    );
    assert!(
        sol.contact
            .iter()
            .all(|c| c.pressure.is_finite() && c.shear.is_finite()),
        "{what}"
    );
}

/// A block pressed on a clamped base and pushed sideways by a prescribed displacement of its
/// left side (so it is held whatever g is).
fn pushed_block(e_base: f64, e_block: f64, nu: f64, g: f64, pressure: f64) -> Value {
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
        "mesh": {"max_size": 0.1}
    })
}

#[test]
fn stiffness_contrast_of_a_million_across_the_contact() {
    for (eb, ek) in [(2.0e10, 2.0e4), (2.0e4, 2.0e10)] {
        let (_, sol) = solve_value(&pushed_block(eb, ek, 0.3, 1.0e5, 1.0e4)).unwrap();
        assert_sound(&sol, &format!("E {eb} / {ek}"));
    }
}

#[test]
fn nearly_incompressible_material_solves_and_warns_about_locking() {
    let (_, sol) = solve_value(&pushed_block(1.0e9, 1.0e9, 0.49, 1.0e5, 1.0e5)).unwrap();
    assert_sound(&sol, "nu 0.49");
    assert!(
        sol.report.warnings.iter().any(|w| w.contains("lock")),
        "{:?}",
        sol.report.warnings
    );
}

#[test]
fn slip_limits_from_zero_to_huge() {
    for g in [0.0, 1.0, 1.0e3, 1.0e6, 1.0e9, 1.0e12] {
        let (_, sol) = solve_value(&pushed_block(1.0e10, 1.0e10, 0.25, g, 1.0e5)).unwrap();
        assert_sound(&sol, &format!("g = {g}"));
    }
}

#[test]
fn load_that_nearly_opens_the_contact() {
    // The block weighs 2.45e4 N/m³ × 0.5 m = 12250 Pa over its top; a pull slightly below that
    // leaves tiny contact pressures, a pull slightly above lifts it off: refused, naming +y.
    let with_pull = |p: f64| {
        let mut v = pushed_block(1.0e10, 1.0e10, 0.25, 1.0e4, p);
        v["materials"]["block"]["specific_weight"] = json!(2.45e4);
        v
    };
    let (problem, sol) = solve_value(&with_pull(-12_240.0)).unwrap();
    assert_sound(&sol, "nearly open");
    let total: f64 = sol
        .contact
        .iter()
        .zip(&problem.contact.geometry.pairs)
        .map(|(c, p)| c.pressure * p.weight)
        .sum();
    assert!((total - 10.0).abs() < 1e-6, "net contact force {total} N/m");
    let err = solve_value(&with_pull(-12_260.0))
        .err()
        .expect("lifted off");
    let msg = err.to_string();
    assert!(
        msg.contains("'block'") && msg.contains("(0.000, 1.000)"),
        "{msg}"
    );
}

#[test]
fn floating_body_without_contact_is_refused_by_name() {
    let mut v = pushed_block(1.0e10, 1.0e10, 0.25, 1.0e5, 1.0e5);
    v["boundary"][1] = json!({"segment": "left", "traction": [1.0e3, 0]});
    v["contacts"] = json!([]);
    let err = solve_value(&v).err().expect("refused");
    assert!(err.to_string().contains("'block'"), "{err}");
}

#[test]
fn frictionless_floating_body_with_balanced_load_reports_the_undetermined_sliding() {
    // Held only by frictionless contact with vertical loads: the sliding motion is free.
    let mut v = pushed_block(1.0e10, 1.0e10, 0.25, 0.0, 1.0e5);
    v["boundary"].as_array_mut().unwrap().remove(1);
    let (_, sol) = solve_value(&v).unwrap();
    assert_sound(&sol, "frictionless floating");
    assert!(sol.report.undetermined_modes >= 1);
    assert!(sol
        .report
        .warnings
        .iter()
        .any(|w| w.contains("not determined")));
}

#[test]
fn units_pascal_and_gigapascal_give_the_same_shape() {
    // Scaling all stresses by 1e-9 (Pa → GPa) scales nothing in the displacement.
    let (_, pa) = solve_value(&pushed_block(2.0e10, 1.0e10, 0.3, 2.0e5, 1.0e6)).unwrap();
    let (_, gpa) = solve_value(&pushed_block(20.0, 10.0, 0.3, 2.0e-4, 1.0e-3)).unwrap();
    assert_sound(&pa, "Pa");
    assert_sound(&gpa, "GPa");
    let scale = pa
        .displacement
        .iter()
        .fold(0.0_f64, |m, u| m.max(u[0].abs()).max(u[1].abs()));
    for (a, b) in pa.displacement.iter().zip(&gpa.displacement) {
        assert!((a[0] - b[0]).abs().max((a[1] - b[1]).abs()) <= 1e-8 * scale);
    }
}

#[test]
fn elements_with_aspect_ratio_100() {
    // Structured stacked blocks 10 m wide, cells 1 m × 0.01 m.
    let mesh = wsm::mesh::structured::stacked_blocks(10.0, 0.01, 0.01, 10, 1, 1);
    let stats = wsm::mesh::stats(&mesh);
    assert!(
        stats.max_aspect_ratio >= 50.0,
        "aspect {}",
        stats.max_aspect_ratio
    );
    let seg = |body: &str, a: [f64; 2], b: [f64; 2]| json!({"body": body, "from": a, "to": b});
    let scene = json!({
        "version": 1, "name": "thin",
        "bodies": [
            {"name": "lower", "zones": [{"name": "lower", "material": "a", "polygon": [[0,0],[10,0],[10,0.01],[0,0.01]]}]},
            {"name": "upper", "zones": [{"name": "upper", "material": "b", "polygon": [[0,0.01],[10,0.01],[10,0.02],[0,0.02]]}]}
        ],
        "segments": {
            "lower_bottom": seg("lower", [0.0, 0.0], [10.0, 0.0]),
            "lower_left": seg("lower", [0.0, 0.01], [0.0, 0.0]),
            "lower_right": seg("lower", [10.0, 0.0], [10.0, 0.01]),
            "lower_top": seg("lower", [10.0, 0.01], [0.0, 0.01]),
            "upper_bottom": seg("upper", [0.0, 0.01], [10.0, 0.01]),
            "upper_left": seg("upper", [0.0, 0.02], [0.0, 0.01]),
            "upper_right": seg("upper", [10.0, 0.01], [10.0, 0.02]),
            "upper_top": seg("upper", [10.0, 0.02], [0.0, 0.02])
        },
        "materials": {"a": {"E": 1.0e10, "nu": 0.3}, "b": {"E": 1.0e10, "nu": 0.3}},
        "boundary": [
            {"segment": "lower_bottom", "displacement": [0, 0]},
            {"segment": "upper_left", "displacement": [1.0e-6, null]},
            {"segment": "upper_top", "pressure": 1.0e5}
        ],
        "contacts": [{"name": "interface", "between": ["lower_top", "upper_bottom"], "slip_limit": 1.0e4}],
        "mesh": {"max_size": 1.0}
    });
    let scene = parse(&scene.to_string()).unwrap();
    let problem = StateProblem::with_mesh(scene, mesh, Instant::now()).unwrap();
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm::fem::Par::Seq,
        warm: None,
    };
    let sol = problem.solve(&problem.nominal, &options).unwrap();
    // Slender cells (1 m × 0.01 m) and displacements on two scales (1e-6 m prescribed sliding,
    // 1e-10 m normal compression) cost digits: the relative KKT residuals reach ~1e-8 here.
    assert_sound_to(&sol, "aspect ratio 100", 1e-6);
}
