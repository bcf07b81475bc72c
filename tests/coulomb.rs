//! Coulomb friction (issue #26, design §3.4): the friction coefficient F on a contact zone,
//! solved as the fixed point of Tresca problems g = F |λ_n|. Checked against the statics of a
//! block on a base (gross slip exactly when Q > F N), the limits F → 0 (frictionless) and large
//! F (bonded), the Tresca problem with the converged slip bound, the Cattaneo–Mindlin stick zone
//! of a cylinder on a flat, the DD solver, and finite differences of the sensitivities.

use serde_json::{json, Value};
use wsm_core::error::WsmError;
use wsm_core::scene::parse;
use wsm_core::state::{ContactState, Needs, Solution, SolveOptions, StateProblem};

fn options(problem: &StateProblem) -> SolveOptions {
    SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm_core::fem::Par::Seq,
        warm: None,
    }
}

fn build(v: &Value) -> StateProblem {
    StateProblem::new(parse(&v.to_string()).expect("scene parses")).expect("problem builds")
}

fn solve_value(v: &Value) -> Result<(StateProblem, Solution), WsmError> {
    let problem = build(v);
    let sol = problem.solve(&problem.nominal, &options(&problem))?;
    Ok((problem, sol))
}

/// A block [0.5, 1.5] × [0.5, 1] held only by contact on a base [0, 2] × [0, 0.5] clamped at
/// its bottom, both of one material: normal load N = p × 1 m on the block's top, tangential
/// load Q as a traction Q / 0.5 m on its left side. `friction` is the contact's friction entry.
fn block_on_base(q: f64, friction: Value) -> Value {
    let p = 1.0e6;
    let mut contact = json!({"name": "joint", "between": ["block_contact", "base_contact"]});
    for (k, v) in friction.as_object().expect("an object").iter() {
        contact[k] = v.clone();
    }
    json!({
        "version": 1, "name": "block on base",
        "bodies": [
            {"name": "base", "zones": [{"name": "base", "material": "rock", "polygon": [[0,0],[2,0],[2,0.5],[0,0.5]]}]},
            {"name": "block", "zones": [{"name": "block", "material": "rock", "polygon": [[0.5,0.5],[1.5,0.5],[1.5,1],[0.5,1]]}]}
        ],
        "segments": {
            "bottom": {"body": "base", "from": [0,0], "to": [2,0]},
            "top": {"body": "block", "from": [1.5,1], "to": [0.5,1]},
            "push": {"body": "block", "from": [0.5,1], "to": [0.5,0.5]},
            "base_contact": {"body": "base", "from": [0.5,0.5], "to": [1.5,0.5]},
            "block_contact": {"body": "block", "from": [0.5,0.5], "to": [1.5,0.5]}
        },
        "materials": {"rock": {"E": 1.0e10, "nu": 0.25}},
        "boundary": [
            {"segment": "bottom", "displacement": [0, 0]},
            {"segment": "top", "pressure": p},
            {"segment": "push", "traction": [q / 0.5, 0]}
        ],
        "contacts": [contact],
        "mesh": {"max_size": 0.1, "refine": [{"segments": ["block_contact"], "max_size": 0.05}]}
    })
}

/// Normal load of [`block_on_base`] \[N/m\].
const N: f64 = 1.0e6;

/// Σ λ_n and Σ λ_t over the contact pairs \[N/m\].
fn resultants(problem: &StateProblem, sol: &Solution) -> (f64, f64) {
    sol.contact
        .iter()
        .zip(&problem.contact.geometry.pairs)
        .fold((0.0, 0.0), |(n, t), (c, p)| {
            (n + c.pressure * p.weight, t + c.shear * p.weight)
        })
}

/// ‖a − b‖ / ‖a‖ over all nodal displacements.
fn relative_difference(a: &Solution, b: &Solution) -> f64 {
    let norm = |s: &Solution, t: &Solution| {
        s.displacement
            .iter()
            .zip(&t.displacement)
            .map(|(x, y)| (x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let zero = Solution {
        displacement: vec![[0.0; 2]; a.displacement.len()],
        ..Solution::default()
    };
    norm(a, b) / norm(a, &zero)
}

/// The floating block holds exactly while Q ≤ F N: just below the threshold the Coulomb state
/// exists, carries Q by friction and satisfies the Coulomb KKT conditions; just above no static
/// state exists and the solve names the block and the motion.
#[test]
fn block_slips_exactly_when_q_exceeds_f_n() {
    let f = 0.4;
    for margin in [1e-3, 1e-2] {
        let q = (1.0 - margin) * f * N;
        let (problem, sol) = solve_value(&block_on_base(q, json!({"friction_coefficient": f})))
            .unwrap_or_else(|e| panic!("Q = (1 - {margin}) F N: {e}"));
        let (normal, tangential) = resultants(&problem, &sol);
        assert!((normal - N).abs() <= 1e-8 * N, "Σλ_n = {normal}");
        assert!(
            (tangential.abs() - q).abs() <= 1e-8 * N,
            "Σλ_t = {tangential}"
        );
        let coulomb = sol.report.coulomb.expect("a Coulomb report");
        let slipping = sol
            .contact
            .iter()
            .filter(|c| c.state == ContactState::Slip)
            .count();
        println!(
            "Q = (1 - {margin}) F N: {} steps, residual {:.1e}, contraction {:.2}, {slipping}/{} pairs slip, KKT {:.1e}",
            coulomb.iterations,
            coulomb.residual,
            coulomb.contraction,
            sol.contact.len(),
            sol.report.kkt.max()
        );
        assert!(coulomb.residual <= 1e-12);
        assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
        // |τ_t| ≤ F τ_n at every pair.
        for c in &sol.contact {
            assert!(c.shear.abs() <= f * c.pressure * (1.0 + 1e-9) + 1e-9 * N);
        }
        let q = (1.0 + margin) * f * N;
        match solve_value(&block_on_base(q, json!({"friction_coefficient": f}))) {
            Err(WsmError::UnbalancedMode { body, motion, .. }) => {
                assert_eq!(body, "block");
                assert!(motion.contains("translation"), "{motion}");
            }
            other => panic!(
                "Q = (1 + {margin}) F N must slip: {:?}",
                other.map(|(_, s)| s.report)
            ),
        }
    }
}

/// Tangential load with a prescribed shift: two stacked blocks, the upper one's left side
/// displaced by 1e-4 m, under a pressure (the setting of the frictionless patch test).
fn stacked_blocks(friction: Value) -> Value {
    let mut contact = json!({"name": "c", "between": ["upper_bottom", "lower_top"]});
    for (k, v) in friction.as_object().expect("an object").iter() {
        contact[k] = v.clone();
    }
    json!({
        "version": 1, "name": "stacked blocks",
        "bodies": [
            {"name": "lower", "zones": [{"name": "lower", "material": "m", "polygon": [[0,0],[1,0],[1,0.5],[0,0.5]]}]},
            {"name": "upper", "zones": [{"name": "upper", "material": "m", "polygon": [[0,0.5],[1,0.5],[1,1],[0,1]]}]}
        ],
        "segments": {
            "floor": {"body": "lower", "from": [0,0], "to": [1,0]},
            "lower_left": {"body": "lower", "from": [0,0.5], "to": [0,0]},
            "upper_left": {"body": "upper", "from": [0,1], "to": [0,0.5]},
            "top": {"body": "upper", "from": [1,1], "to": [0,1]},
            "lower_top": {"body": "lower", "from": [0,0.5], "to": [1,0.5]},
            "upper_bottom": {"body": "upper", "from": [0,0.5], "to": [1,0.5]}
        },
        "materials": {"m": {"E": 2.0e10, "nu": 0.3}},
        "boundary": [
            {"segment": "floor", "roller": {}},
            {"segment": "lower_left", "roller": {}},
            {"segment": "upper_left", "displacement": [1.0e-4, null]},
            {"segment": "top", "pressure": 1.0e6}
        ],
        "contacts": [contact],
        "mesh": {"max_size": 0.1}
    })
}

/// F → 0 tends to the frictionless solution (g = 0), linearly in F; F = 0 is it.
#[test]
fn vanishing_coefficient_gives_the_frictionless_solution() {
    let (_, frictionless) = solve_value(&stacked_blocks(json!({"slip_limit": 0.0}))).unwrap();
    let (_, zero) = solve_value(&stacked_blocks(json!({"friction_coefficient": 0.0}))).unwrap();
    assert!(relative_difference(&frictionless, &zero) <= 1e-12);
    let mut differences = Vec::new();
    for f in [1e-3, 1e-4, 1e-5] {
        let (_, sol) = solve_value(&stacked_blocks(json!({"friction_coefficient": f}))).unwrap();
        assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
        differences.push(relative_difference(&frictionless, &sol));
    }
    println!("F = 1e-3, 1e-4, 1e-5: ‖u − u_frictionless‖/‖u‖ = {differences:?}");
    assert!(differences[0] > 0.0, "friction changes the state");
    for w in differences.windows(2) {
        let ratio = w[0] / w[1];
        assert!((8.0..12.0).contains(&ratio), "linear in F: {differences:?}");
    }
}

/// A coefficient large enough that no pair reaches F λ_n gives the bonded solution (Tresca with
/// an unreachable slip limit), every pair sticking.
#[test]
fn large_coefficient_gives_the_bonded_solution() {
    let q = 0.2 * N;
    let (_, bonded) = solve_value(&block_on_base(q, json!({"slip_limit": 1.0e13}))).unwrap();
    let (_, coulomb) =
        solve_value(&block_on_base(q, json!({"friction_coefficient": 20.0}))).unwrap();
    let rel = relative_difference(&bonded, &coulomb);
    println!(
        "F = 20: ‖u − u_bonded‖/‖u‖ = {rel:.2e}, {:?}",
        coulomb.report.coulomb
    );
    assert!(rel <= 1e-10, "{rel}");
    assert!(coulomb
        .contact
        .iter()
        .all(|c| c.state == ContactState::Stick));
}

/// The Coulomb state is the Tresca state of its own slip bound: with g(s_m) = F λ_n,m / w_m as a
/// piecewise linear slip limit through the pairs' positions, the Tresca solve gives the same
/// displacement and forces.
#[test]
fn coulomb_equals_tresca_with_the_converged_slip_bound() {
    let f = 0.4;
    let q = 0.8 * f * N;
    let (problem, coulomb) =
        solve_value(&block_on_base(q, json!({"friction_coefficient": f}))).unwrap();
    let slipping = coulomb
        .contact
        .iter()
        .filter(|c| c.state == ContactState::Slip)
        .count();
    assert!(slipping > 0, "partial slip");
    assert!(coulomb
        .contact
        .iter()
        .any(|c| c.state == ContactState::Stick));
    let mut knots: Vec<(f64, f64)> = problem
        .contact
        .geometry
        .pairs
        .iter()
        .zip(&coulomb.contact)
        .map(|(p, c)| (p.fraction, f * c.pressure.max(0.0)))
        .collect();
    knots.sort_by(|a, b| a.0.total_cmp(&b.0));
    let slip_limit = json!({
        "knots": knots.iter().map(|k| k.0).collect::<Vec<_>>(),
        "values": knots.iter().map(|k| k.1).collect::<Vec<_>>(),
    });
    let (_, tresca) = solve_value(&block_on_base(q, json!({"slip_limit": slip_limit}))).unwrap();
    let rel = relative_difference(&coulomb, &tresca);
    let force = coulomb
        .contact
        .iter()
        .zip(&tresca.contact)
        .fold(0.0_f64, |m, (a, b)| {
            m.max((a.pressure - b.pressure).abs())
                .max((a.shear - b.shear).abs())
        });
    println!(
        "{slipping}/{} pairs slip; ‖u_C − u_T‖/‖u‖ = {rel:.2e}, max |τ_C − τ_T| = {force:.2e} Pa",
        coulomb.contact.len()
    );
    assert!(rel <= 1e-10, "{rel}");
    assert!(force <= 1e-8 * N, "{force}");
}

/// The friction coefficient is validated like every scene number, naming the field: exclusive
/// with a slip limit, non-negative and finite, unilateral zones only; as an uncertain datum only
/// on a Coulomb zone (and a Coulomb zone's slip limit is not a datum).
#[test]
fn friction_coefficient_is_validated_by_path() {
    let refused = |v: Value| -> (String, String) {
        let error = match parse(&v.to_string()) {
            Err(e) => e,
            Ok(scene) => wsm_core::scene::params::parameters(&scene).expect_err("refused"),
        };
        (error.path, error.reason)
    };
    let (path, reason) = refused(block_on_base(
        0.0,
        json!({"friction_coefficient": 0.3, "slip_limit": 1.0e5}),
    ));
    assert_eq!(path, "contacts[0].slip_limit");
    assert!(reason.contains("not both"), "{reason}");
    for bad in [json!(-0.1), json!(1.0e3)] {
        let (path, _) = refused(block_on_base(0.0, json!({"friction_coefficient": bad})));
        assert_eq!(path, "contacts[0].friction_coefficient");
    }
    let (path, _) = refused(block_on_base(
        0.0,
        json!({"friction_coefficient": 0.3, "kind": "bilateral"}),
    ));
    assert_eq!(path, "contacts[0].friction_coefficient");
    let mut scene = block_on_base(0.0, json!({"friction_coefficient": 0.3}));
    scene["uncertain"] = json!([{"field": "contacts[0].slip_limit", "interval": [0.0, 1.0]}]);
    let (path, reason) = refused(scene.clone());
    assert_eq!(path, "uncertain[0].field");
    assert!(reason.contains("friction_coefficient"), "{reason}");
    scene["uncertain"] =
        json!([{"field": "contacts[0].friction_coefficient", "interval": [0.2, -0.1]}]);
    assert_eq!(refused(scene.clone()).0, "uncertain[0].interval");
    let mut tresca = block_on_base(0.0, json!({"slip_limit": 1.0e5}));
    tresca["uncertain"] =
        json!([{"field": "contacts[0].friction_coefficient", "interval": [0.2, 0.3]}]);
    assert_eq!(refused(tresca).0, "uncertain[0].field");
    scene["uncertain"] =
        json!([{"field": "contacts[0].friction_coefficient", "interval": [0.2, 0.3]}]);
    let scene = parse(&scene.to_string()).unwrap();
    assert_eq!(
        wsm_core::scene::params::parameters(&scene).unwrap().len(),
        1
    );
}
