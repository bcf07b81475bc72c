//! The sparse contact path (design §3.1, "The sparse contact path") against the dense one: on every
//! bundled example with contact and on the dam with a Coulomb joint of design §3.4, the same
//! displacement and contact forces to 1e-10 relative, the same contact states, KKT at rounding
//! level; the automatic choice by pair count; refusals named.

use crate::solves;

use serde_json::Value;
use wsm_core::{
    parameter_stencil, parse_scene, scene_parameters, ContactMethod, Needs, Solution, SolveOptions,
    SolverKind, SolverUsed, StateProblem,
};

fn solve_with(text: &str, method: ContactMethod) -> Result<Solution, String> {
    let mut scene = parse_scene(text).map_err(|e| e.to_string())?;
    scene.solver.kind = SolverKind::Direct;
    scene.solver.contact = method;
    let problem = StateProblem::new(scene).map_err(|e| e.to_string())?;
    assert_eq!(
        problem.contact.is_sparse(),
        method == ContactMethod::Sparse,
        "the path asked for"
    );
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm_core::Par::Seq,
        warm: None,
    };
    problem
        .solve(&problem.nominal, &options)
        .map_err(|e| e.to_string())
}

fn max_abs(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(0.0, |a, x| a.max(x.abs()))
}

/// (relative displacement difference, relative contact force difference)
fn differences(dense: &Solution, sparse: &Solution) -> (f64, f64) {
    let u_scale = max_abs(dense.displacement.iter().flatten().copied());
    let du = max_abs(
        dense
            .displacement
            .iter()
            .flatten()
            .zip(sparse.displacement.iter().flatten())
            .map(|(a, b)| a - b),
    );
    let f_scale = max_abs(dense.contact.iter().flat_map(|c| [c.pressure, c.shear]));
    let df = max_abs(
        dense
            .contact
            .iter()
            .zip(&sparse.contact)
            .flat_map(|(a, b)| [a.pressure - b.pressure, a.shear - b.shear]),
    );
    (
        du / u_scale.max(f64::MIN_POSITIVE),
        df / f_scale.max(f64::MIN_POSITIVE),
    )
}

#[test]
fn sparse_path_equals_dense_on_bundled_examples() {
    let mut compared = 0;
    let dam = include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/dam-coulomb-3data.json"
    ));
    let cases = wsm_core::example_names()
        .map(|name| (name, wsm_core::example(name).unwrap()))
        .chain([("dam (Coulomb joint, tests/data)", dam)]);
    for (name, text) in cases {
        let value: Value = serde_json::from_str(text).unwrap();
        if value["contacts"].as_array().is_none_or(|c| c.is_empty()) {
            continue;
        }
        let dense = solve_with(text, ContactMethod::Dense).unwrap();
        let sparse = match solve_with(text, ContactMethod::Sparse) {
            Ok(s) => s,
            Err(e) if e.contains("solver.contact") => {
                println!("{name}: not on the sparse path: {e}");
                continue;
            }
            Err(e) => panic!("{name}: sparse solve failed: {e}"),
        };
        let (du, df) = differences(&dense, &sparse);
        let steps = sparse.report.sparse_steps;
        println!(
            "{name}: pairs {}, unknowns {}, du {du:.1e}, dλ {df:.1e}, steps {steps}, KKT {:.1e}",
            dense.contact.len(),
            dense.report.unknowns,
            sparse.report.kkt.max()
        );
        assert!(du <= 1e-10, "{name}: displacement differs by {du:e}");
        assert!(df <= 1e-10, "{name}: contact forces differ by {df:e}");
        for (a, b) in dense.contact.iter().zip(&sparse.contact) {
            assert_eq!(a.state, b.state, "{name}: state at {:?}", a.position);
        }
        assert!(
            sparse.report.kkt.max() <= 1e-9,
            "{name}: KKT {:?}",
            sparse.report.kkt
        );
        assert!(steps >= 1, "{name}: the sparse path reports its steps");
        compared += 1;
    }
    assert!(compared >= 13, "only {compared} examples compared");
}

/// Hertz with a contact line refined to about 1,600 pairs: `auto` takes the sparse path, the
/// floating cylinder is balanced to 1e-8, KKT at rounding level, the half-width and the peak
/// pressure within 3 % of Hertz's, and exact derivatives given (by the forward tangent).
#[test]
fn many_pairs_take_the_sparse_path_and_meet_hertz() {
    let mut scene: Value = serde_json::from_str(wsm_core::example("hertz").unwrap()).unwrap();
    let h = 7.2e-4;
    scene["mesh"] = serde_json::json!({
        "max_size": 0.25,
        "refine": [{"polygon": [[-0.3, -2.0 * h], [0.3, -2.0 * h], [0.3, 2.0 * h], [-0.3, 2.0 * h]], "max_size": h}]
    });
    let problem = StateProblem::new(parse_scene(&scene.to_string()).unwrap()).unwrap();
    let pairs = &problem.contact.geometry.pairs;
    assert!(pairs.len() >= 1500, "{} pairs", pairs.len());
    assert!(problem.contact.is_sparse(), "auto takes the sparse path");
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm_core::Par::Seq,
        warm: None,
    };
    let sol = problem.solve(&problem.nominal, &options).unwrap();
    assert_eq!(sol.report.solver, SolverUsed::DirectSparse);
    assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
    let hertz = solves::hertz_measures(&problem, &sol);
    let ((a_exact, p0_exact), load, total) = (hertz.exact, hertz.load, hertz.total);
    assert!(
        (total - load).abs() <= 1e-8 * load,
        "total {total} vs {load}"
    );
    let (a, p0) = (hertz.half_width, hertz.peak);
    println!(
        "{} pairs, {} unknowns, {} steps: a = {a:.5} (Hertz {a_exact:.5}), p0 = {p0:.4e} (Hertz {p0_exact:.4e})",
        pairs.len(),
        sol.report.unknowns,
        sol.report.sparse_steps
    );
    assert!((a - a_exact).abs() < 0.03 * a_exact, "a = {a}");
    assert!((p0 - p0_exact).abs() < 0.03 * p0_exact, "p0 = {p0}");
    let params = scene_parameters(&problem.scene).unwrap();
    let theta: Vec<f64> = params.iter().map(|p| 0.5 * (p.lo + p.hi)).collect();
    let stencils: Vec<_> = (0..params.len())
        .map(|j| parameter_stencil(&problem.scene, &problem.nominal, &params, &theta, j))
        .collect();
    assert!(!stencils.is_empty());
    let with = problem
        .solve_with_sensitivities(&problem.nominal, &options, &stencils)
        .unwrap();
    assert_eq!(
        with.sensitivities.len(),
        params.len(),
        "{:?}",
        with.report.warnings
    );
    // dΦ/dp of the pressure on the top: Φ6 (mean normal compression) grows with the load.
    let d6 = with.sensitivities[0][5].expect("Φ6 derivative");
    assert!(d6.right > 0.0 && d6.left > 0.0, "{d6:?}");
}

/// Exact derivatives on the sparse path equal the dense path's (forward tangent there too, and
/// its default adjoint) at an interior point and at a vertex of every bundled Tresca or
/// frictionless example with uncertain data: 1e-8 relative to the largest derivative of each
/// criterion, left and right; Coulomb states have none on the sparse path and say so.
#[test]
fn sparse_derivatives_equal_dense_ones() {
    use wsm_core::apply_parameters;
    let mut compared = 0;
    for name in wsm_core::example_names() {
        let text = wsm_core::example(name).unwrap();
        let value: Value = serde_json::from_str(text).unwrap();
        if value["contacts"].as_array().is_none_or(|c| c.is_empty())
            || value["uncertain"].as_array().is_none_or(|u| u.is_empty())
        {
            continue;
        }
        let build = |method: ContactMethod| {
            let mut scene = parse_scene(text).unwrap();
            scene.solver.kind = SolverKind::Direct;
            scene.solver.contact = method;
            StateProblem::new(scene).map_err(|e| e.to_string())
        };
        let dense = build(ContactMethod::Dense).unwrap();
        let sparse = match build(ContactMethod::Sparse) {
            Ok(s) => s,
            // A mortar zone chains its rows (design §2.4.1): not eligible for the sparse path.
            Err(e) if e.contains("solver.contact") => {
                println!("{name}: not on the sparse path: {e}");
                continue;
            }
            Err(e) => panic!("{name}: {e}"),
        };
        let coulomb = dense.nominal.has_coulomb();
        let params = scene_parameters(&dense.scene).unwrap();
        for vertex in [false, true] {
            let theta: Vec<f64> = params
                .iter()
                .enumerate()
                .map(|(i, p)| match (vertex, i % 2) {
                    (false, _) => p.lo + 0.37 * (p.hi - p.lo),
                    (true, 0) => p.lo,
                    (true, _) => p.hi,
                })
                .collect();
            let derivatives = |problem: &StateProblem| {
                let data = apply_parameters(&problem.scene, &problem.nominal, &params, &theta);
                let stencils: Vec<_> = (0..params.len())
                    .map(|j| {
                        parameter_stencil(&problem.scene, &problem.nominal, &params, &theta, j)
                    })
                    .collect();
                let options = SolveOptions {
                    needs: Needs::all(&problem.scene),
                    par: wsm_core::Par::Seq,
                    warm: None,
                };
                problem
                    .solve_with_sensitivities(&data, &options, &stencils)
                    .unwrap()
            };
            let (d, s) = (derivatives(&dense), derivatives(&sparse));
            if coulomb {
                assert!(
                    s.sensitivities.is_empty(),
                    "{name}: Coulomb on the sparse path"
                );
                assert!(
                    s.report.warnings.iter().any(|w| w.contains("Coulomb")),
                    "{name}: {:?}",
                    s.report.warnings
                );
                continue;
            }
            assert_eq!(
                d.sensitivities.len(),
                params.len(),
                "{name}: {:?}",
                d.report.warnings
            );
            assert_eq!(
                s.sensitivities.len(),
                params.len(),
                "{name}: {:?}",
                s.report.warnings
            );
            let mut worst = 0.0_f64;
            for phi in 0..6 {
                let scale = d
                    .sensitivities
                    .iter()
                    .filter_map(|row| row[phi].map(|o| o.right.abs().max(o.left.abs())))
                    .fold(0.0, f64::max);
                for (rd, rs) in d.sensitivities.iter().zip(&s.sensitivities) {
                    match (rd[phi], rs[phi]) {
                        (Some(a), Some(b)) => {
                            let diff = (a.right - b.right).abs().max((a.left - b.left).abs());
                            worst = worst.max(diff / scale.max(f64::MIN_POSITIVE));
                        }
                        (None, None) => {}
                        other => panic!("{name}: Φ{} given on one path only: {other:?}", phi + 1),
                    }
                }
            }
            println!(
                "{name} ({}): derivatives differ by {worst:.1e}",
                if vertex { "vertex" } else { "interior" }
            );
            assert!(worst <= 1e-8, "{name}: derivatives differ by {worst:e}");
            compared += 1;
        }
    }
    assert!(compared >= 10, "only {compared} points compared");
}
