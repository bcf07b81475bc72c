//! The papers' DD as printed (design §3.2, "The papers' method as printed"): every `solver.dd`
//! option gives the direct solver's answer on a small scene, the plain successive
//! approximations either converge or say that they do not contract, and bad options are refused
//! naming the field. The iteration counts at the papers' sizes (docs/verification.md) come from
//! the ignored test at the end.

use crate::solves;

use serde_json::{json, Value};
use solves::{relative_difference, solve};
use wsm_core::{parse_scene, Needs, Solution, SolveOptions, SolverKind, StateProblem};

fn block_on_base() -> Value {
    let mut scene: Value =
        serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap();
    scene["mesh"] = json!({"max_size": 0.08});
    scene
}

/// The DD report of a solve as JSON.
fn dd_report(sol: &Solution) -> Value {
    serde_json::to_value(sol.report.dd.as_ref().expect("DD report")).unwrap()
}

#[test]
fn each_printed_option_equals_the_direct_solver() {
    let mut scene = block_on_base();
    let (_, direct) = solve(&scene, SolverKind::Direct);
    let printed = json!({"pcg1": "printed", "coarse": "kernels", "weights": "mean_young"});
    // (options, report member, value it must show)
    let cases = [
        (json!({"pcg1": "printed"}), "pcg1_preconditioner", "full"),
        (json!({"coarse": "kernels"}), "coarse", "kernels"),
        (json!({"weights": "mean_young"}), "weights", "mean_young"),
        (printed, "coarse", "kernels"),
        (json!({"iteration": "plain"}), "iteration", "plain"),
    ];
    for (options, member, shown) in cases {
        scene["solver"] = json!({"kind": "dd", "dd": options});
        let (_, dd) = solve(&scene, SolverKind::Dd);
        let report = dd_report(&dd);
        assert_eq!(report[member], shown, "{options}");
        let rel = relative_difference(&direct, &dd);
        assert!(rel <= 1e-8, "{options}: relative difference {rel}");
        match report["fallback"].as_str() {
            None => {}
            // Only the plain iteration may stop, and only saying why.
            Some(said) => {
                assert_eq!(
                    options["iteration"], "plain",
                    "{options}: fell back: {said}"
                );
                assert!(said.contains("not contracting"), "{said}");
                assert!(
                    dd.report
                        .warnings
                        .iter()
                        .any(|w| w.contains("not contracting")),
                    "{:?}",
                    dd.report.warnings
                );
            }
        }
        if options.get("iteration").is_some() {
            assert!(report["acceleration"].is_null() && report["newton_steps"] == 0);
        }
    }
}

#[test]
fn bad_dd_options_are_refused_naming_the_field() {
    for (dd, field) in [
        (json!({"pcg1": "paper"}), "solver.dd.pcg1"),
        (json!({"coarse": "rigid_motions"}), "solver.dd.coarse"),
        (json!({"iteration": "anderson"}), "solver.dd.iteration"),
        (json!({"weights": "young"}), "solver.dd.weights"),
        (json!({"tied_zones": ["a"]}), "tied_zones"),
        (json!("printed"), "solver.dd"),
    ] {
        let mut scene = block_on_base();
        scene["solver"] = json!({"kind": "dd", "dd": dd});
        let err = parse_scene(&scene.to_string()).unwrap_err().to_string();
        assert!(err.contains(field), "{dd}: {err}");
    }
    // The defaults are not written back: a scene without `solver.dd` serialises as before.
    let scene = parse_scene(&block_on_base().to_string()).unwrap();
    let text = serde_json::to_string(&scene).unwrap();
    assert!(!text.contains("\"dd\""), "{text}");
}

/// One DD solve of `scene` with the `solver.dd` options `dd` at the papers' tolerance 1e-6, its
/// report and its distance to the direct solver.
fn papers_run(scene: &Value, subdomains: usize, dd: &Value) -> (Value, f64) {
    let mut scene = scene.clone();
    scene["solver"] = json!({"kind": "dd", "subdomains": subdomains, "tolerance": 1e-6, "dd": dd});
    let problem = StateProblem::new(parse_scene(&scene.to_string()).unwrap()).unwrap();
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm_core::Par::Seq,
        warm: None,
    };
    let sol = problem.solve(&problem.nominal, &options).unwrap();
    let (_, direct) = solve(&scene, SolverKind::Direct);
    (dd_report(&sol), relative_difference(&direct, &sol))
}

/// The iteration counts of docs/verification.md ("The papers' DD as printed"): the bundled D03
/// model problem, tunnel and D05 knee at the papers' sizes, wsm's DD, each printed variant and a
/// smaller tied set Γc0. Slow (minutes):
/// `cargo test --release -p wsm-core --test engine dd_printed -- --ignored --nocapture`.
#[test]
#[ignore]
fn iteration_counts_at_the_papers_sizes() {
    let tunnel = {
        let mut s: Value =
            serde_json::from_str(wsm_core::example("tunnel-fault").unwrap()).unwrap();
        s["mesh"]["refine"][0]["max_size"] = json!(0.8);
        s
    };
    let knee = {
        let mut s: Value = serde_json::from_str(wsm_core::example("knee-d05").unwrap()).unwrap();
        let env = |k: &str, d: f64| std::env::var(k).map(|v| v.parse().unwrap()).unwrap_or(d);
        s["mesh"]["max_size"] = json!(env("KNEE_SIZE", 0.0021));
        s["mesh"]["refine"][0]["max_size"] = json!(env("KNEE_REFINE", 0.0012));
        s
    };
    let d03 = {
        let mut s: Value =
            serde_json::from_str(wsm_core::example("d03-model-problem").unwrap()).unwrap();
        let env = |k: &str, d: f64| std::env::var(k).map(|v| v.parse().unwrap()).unwrap_or(d);
        s["mesh"]["max_size"] = json!(env("D03_SIZE", 0.037));
        s
    };
    let variants = [
        ("wsm", json!({})),
        ("pcg1 printed", json!({"pcg1": "printed"})),
        ("coarse kernels", json!({"coarse": "kernels"})),
        ("weights mean_young", json!({"weights": "mean_young"})),
        ("iteration plain", json!({"iteration": "plain"})),
        (
            "all printed",
            json!({"pcg1": "printed", "coarse": "kernels", "weights": "mean_young", "iteration": "plain"}),
        ),
    ];
    // D05 4.35: a smaller tied set Γc0 where the other supports still hold every body (the
    // tunnel's lower fault segment, the knee's lateral condyle; each D03 block rests on its
    // zone alone, so there Γc0 = Γc).
    let tied = |zones: &[&str]| vec![("tied_zones", json!({ "tied_zones": zones }))];
    let cases = [
        ("d03", &d03, 8, vec![]),
        ("tunnel", &tunnel, 12, tied(&["fault_low"])),
        (
            "knee-d05",
            &knee,
            13,
            tied(&["lateral condyle inner face", "lateral condyle outer face"]),
        ),
    ];
    for (name, scene, subdomains, gamma_c0) in cases {
        for (label, dd) in variants.iter().chain(&gamma_c0) {
            let (r, rel) = papers_run(scene, subdomains, dd);
            println!(
                "| {name} | {label} | {} | {} | {} | {} / {} / {} | {} | {:.1e} | {} |",
                r["n_dofs"],
                r["n_pairs"],
                r["n_subdomains"],
                r["pcg1_iterations"],
                r["outer_iterations"],
                r["pcg2_iterations"],
                r["newton_steps"],
                rel,
                r["fallback"]
                    .as_str()
                    .or(r["acceleration"].as_str())
                    .unwrap_or("plain, converged")
            );
            assert!(rel <= 1e-5, "{name} {label}: {rel}");
        }
    }
}
