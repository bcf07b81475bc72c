//! Contact verification (design §6, issue "Contact"): 2D Hertz, the contact patch test, Tresca
//! limits, stick/slip thresholds, and KKT residuals of every example.

use crate::solves;

use serde_json::{json, Value};
use wsm_core::{
    parse_scene, ContactState, Data, Needs, Scene, Solution, SolveOptions, StateProblem,
};

fn options(scene: &Scene) -> SolveOptions {
    SolveOptions {
        needs: Needs::all(scene),
        par: wsm_core::Par::Seq,
        warm: None,
    }
}

fn solve_value(v: &Value) -> Result<(StateProblem, Solution), wsm_core::WsmError> {
    let scene = parse_scene(&v.to_string())?;
    let problem = StateProblem::new(scene)?;
    let sol = problem.solve(&problem.nominal, &options(&problem.scene))?;
    Ok((problem, sol))
}

#[test]
fn contact_patch_test_transmits_uniform_pressure_exactly() {
    let p = 3.0e6;
    let (problem, sol) = solve_value(&solves::stacked_blocks(p, 1.0e5, 0.1)).unwrap();
    assert!(
        problem.contact.kernel_dim() >= 1,
        "the upper block floats in y"
    );
    assert!(!sol.contact.is_empty());
    for c in &sol.contact {
        assert!(
            (c.pressure - p).abs() <= 1e-8 * p,
            "pressure {} at {:?}",
            c.pressure,
            c.position
        );
        assert!(c.shear.abs() <= 1e-8 * p, "shear {}", c.shear);
        assert_eq!(c.state, ContactState::Stick);
    }
    assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
}

#[test]
fn zero_slip_limit_is_frictionless() {
    // The upper block's left side is pushed by a prescribed horizontal displacement; with g = 0
    // both blocks carry the same uniaxial stress, so the upper one is shifted by exactly the
    // prescribed 1e-4 m relative to the lower one at every contact node, without shear.
    let mut scene = solves::stacked_blocks(1.0e6, 0.0, 0.1);
    scene["boundary"][2] = json!({"segment": "upper_left", "displacement": [1.0e-4, null]});
    let (_, free) = solve_value(&scene).unwrap();
    for c in &free.contact {
        assert!(c.shear.abs() <= 1e-9 * 1e6);
        assert!(
            (c.slip.abs() - 1.0e-4).abs() <= 1e-10,
            "slip {} at {:?}",
            c.slip,
            c.position
        );
    }
    assert!(free.report.kkt.max() <= 1e-9, "{:?}", free.report.kkt);
}

#[test]
fn huge_slip_limit_gives_the_bonded_solution() {
    // Sheared by a traction on its top, small enough (2% of the pressure) that even the peeling
    // stress at the free ends of the interface stays compressive, the upper block sticks
    // everywhere when g is huge, and the displacement equals that of one body made of the same
    // two zones (same mesh). A larger shear opens the left end: a real peeling effect.
    let mut two = solves::stacked_blocks(1.0e6, 1.0e12, 0.1);
    two["boundary"] = json!([
        {"segment": "floor", "roller": {}},
        {"segment": "lower_left", "roller": {}},
        {"segment": "top", "traction": [2.0e4, -1.0e6]}
    ]);
    let mut one = two.clone();
    one["bodies"] = json!([{"name": "lower", "zones": [
        {"name": "lower", "material": "m", "polygon": [[0,0],[1,0],[1,0.5],[0,0.5]]},
        {"name": "upper", "material": "m", "polygon": [[0,0.5],[1,0.5],[1,1],[0,1]]}]}]);
    for seg in ["upper_left", "top", "lower_top", "upper_bottom"] {
        one["segments"][seg]["body"] = json!("lower");
    }
    one["segments"].as_object_mut().unwrap().remove("lower_top");
    one["segments"]
        .as_object_mut()
        .unwrap()
        .remove("upper_bottom");
    one["contacts"] = json!([]);
    let (p2, bonded) = solve_value(&two).unwrap();
    let (p1, single) = solve_value(&one).unwrap();
    for c in &bonded.contact {
        assert_eq!(c.state, ContactState::Stick, "{c:?}");
        assert!(c.slip.abs() <= 1e-12 && c.gap <= 1e-12, "{c:?}");
    }
    let scale = single
        .displacement
        .iter()
        .fold(0.0_f64, |m, u| m.max(u[0].abs()).max(u[1].abs()));
    let (m1, m2) = (p1.mesh(), p2.mesh());
    let mut compared = 0;
    for (i, x) in m2.nodes.iter().enumerate() {
        let j = m1.nodes.iter().position(|y| y == x).expect("same mesh");
        let (a, b) = (bonded.displacement[i], single.displacement[j]);
        assert!(
            (a[0] - b[0]).abs().max((a[1] - b[1]).abs()) <= 1e-8 * scale,
            "node {x:?}: {a:?} vs {b:?}"
        );
        compared += 1;
    }
    assert_eq!(compared, m2.nodes.len());
    assert!(bonded.report.kkt.max() <= 1e-9, "{:?}", bonded.report.kkt);
}

#[test]
fn pushed_block_sticks_below_and_is_refused_above_the_friction_capacity() {
    // Upper block pushed by a traction on its left side (height 0.5): capacity g·L = g·1.
    let g = 2.0e5;
    let scene = |t: f64| {
        let mut s = solves::stacked_blocks(1.0e6, g, 0.1);
        s["boundary"][2] = json!({"segment": "upper_left", "traction": [t, 0]});
        s
    };
    // Below: 0.5 m × 3.8e5 Pa = 1.9e5 N/m < 2e5 N/m.
    let (below_problem, below) = solve_value(&scene(3.8e5)).unwrap();
    let pairs = &below_problem.contact.geometry.pairs;
    let total_shear: f64 = below
        .contact
        .iter()
        .zip(pairs)
        .map(|(c, p)| c.shear * p.weight)
        .sum();
    assert!(
        (total_shear.abs() - 1.9e5).abs() <= 1e-8 * 1.9e5,
        "friction force {total_shear}"
    );
    assert!(below.contact.iter().any(|c| c.state == ContactState::Stick));
    assert!(below.report.kkt.max() <= 1e-9, "{:?}", below.report.kkt);
    // Above: 0.5 × 4.2e5 = 2.1e5 > 2e5: the block cannot be held.
    let err = solve_value(&scene(4.2e5)).err().expect("must be refused");
    let msg = err.to_string();
    assert!(
        msg.contains("upper") && msg.contains("translation"),
        "{msg}"
    );
}

#[test]
fn hertz_half_width_and_peak_pressure() {
    let base: Value = serde_json::from_str(wsm_core::example("hertz").unwrap()).unwrap();
    let mut errors = Vec::new();
    for h in [0.016, 0.008, 0.004] {
        let mut scene = base.clone();
        scene["mesh"]["refine"][0]["max_size"] = json!(h);
        let (problem, sol) = solve_value(&scene).unwrap();
        // Total normal force: Σ λ_n = load exactly (the cylinder floats in y).
        let hertz = solves::hertz_measures(&problem, &sol);
        let ((a_exact, p0_exact), load, total) = (hertz.exact, hertz.load, hertz.total);
        assert!(
            (total - load).abs() <= 1e-8 * load,
            "total {total} vs {load}"
        );
        let (a, p0) = (hertz.half_width, hertz.peak);
        let (ea, ep) = (
            (a - a_exact).abs() / a_exact,
            (p0 - p0_exact).abs() / p0_exact,
        );
        println!("h = {h}: a = {a:.5} (exact {a_exact:.5}, err {ea:.2e}), p0 = {p0:.4e} (exact {p0_exact:.4e}, err {ep:.2e})");
        assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
        errors.push((ea, ep));
    }
    let (ea, ep) = errors[errors.len() - 1];
    assert!(ea < 0.03 && ep < 0.03, "finest errors a {ea}, p0 {ep}");
    assert!(
        errors[2].0 + errors[2].1 < errors[0].0 + errors[0].1,
        "errors shrink: {errors:?}"
    );
}

#[test]
fn every_example_solves_with_small_kkt_residuals() {
    for (name, text) in wsm_core::EXAMPLES {
        let scene = parse_scene(text).unwrap();
        let problem = StateProblem::new(scene).unwrap_or_else(|e| panic!("{name}: {e}"));
        let sol = problem
            .solve(&problem.nominal, &options(&problem.scene))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(sol.report.kkt.max() <= 1e-9, "{name}: {:?}", sol.report.kkt);
        assert!(
            sol.displacement
                .iter()
                .all(|u| u[0].is_finite() && u[1].is_finite()),
            "{name}"
        );
        let data: &Data = &problem.nominal;
        assert_eq!(data.slip.len(), problem.scene.contacts.len());
    }
}

#[test]
fn contact_resultants_balance_the_applied_loads() {
    // block-on-base: the floating block carries 1e6 Pa on its 1 m top plus its weight
    // 2.45e4 N/m³ × 0.5 m², and is pushed by 4e5 Pa on its 0.5 m side.
    let scene: Value = serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    let (problem, sol) = solve_value(&scene).unwrap();
    let zones = wsm_core::zone_summaries(
        &problem.scene.contacts,
        &problem.nominal,
        &problem.contact.geometry,
        &sol.contact,
    );
    let z = &zones[0];
    let g = problem.nominal.slip[0].values[0];
    assert_eq!(z.friction_law, "tresca");
    assert_eq!(z.slip_limit, Some([g, g]));
    assert_eq!(z.friction_coefficient, None);
    assert!(
        (z.normal_force - 1_012_250.0).abs() <= 1e-8 * 1_012_250.0,
        "{z:?}"
    );
    assert!(
        (z.tangential_force.abs() - 2.0e5).abs() <= 1e-8 * 2.0e5,
        "{z:?}"
    );
    assert!((z.mean_pressure - 1_012_250.0).abs() <= 1e-8 * 1_012_250.0);
}

#[test]
fn mean_contact_pressure_on_a_contact_piece() {
    let p = 3.0e6;
    let mut scene = solves::stacked_blocks(p, 1.0e5, 0.1);
    scene["criteria"] = json!({"boundary_pieces": [
        {"name": "middle", "segment": "upper_bottom", "from": [0.25, 0.5], "to": [0.75, 0.5]}]});
    let (problem, sol) = solve_value(&scene).unwrap();
    let pieces = wsm_core::piece_pressures(
        &problem.criteria.pieces,
        &problem.contact.geometry,
        &sol.contact,
        problem.mesh().nodes.len(),
    );
    let mean = pieces[0].1.expect("the piece lies on the contact zone");
    assert!((mean - p).abs() <= 1e-8 * p, "mean pressure {mean}");
}
