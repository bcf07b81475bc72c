//! The sparse contact path (design §3.1, issue #44) against the dense one: on every bundled
//! example with contact, the same displacement and contact forces to 1e-10 relative, the same
//! contact states, KKT at rounding level; the automatic choice by pair count; refusals named.

use serde_json::Value;
use wsm_core::scene::{parse, ContactMethod, SolverKind};
use wsm_core::state::{Needs, Solution, SolveOptions, StateProblem};

fn solve_with(text: &str, method: ContactMethod) -> Result<Solution, String> {
    let mut scene = parse(text).map_err(|e| e.to_string())?;
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
        par: wsm_core::fem::Par::Seq,
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
    for name in wsm_core::bundled::names() {
        let text = wsm_core::bundled::example(name).unwrap();
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
    assert!(compared >= 8, "only {compared} examples compared");
}
