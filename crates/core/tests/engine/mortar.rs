//! Mortar contact on non-matching meshes (design §2.4.1): on matching meshes the dual mortar rows
//! are the node-pair rows (every bundled contact example, 1e-10); the contact patch test across
//! a 1 : 2.7 interface; Hertz meshed finely on one side and coarsely on the other, both ways;
//! Tresca stick and refusal; refusals named; a Gmsh mesh whose bodies were meshed on their own.
//! (Exact derivatives on the bundled `hertz-nonmatching` are checked against finite differences in
//! tests/sensitivities.rs; worst-scenario runs on the bundled mortar examples against their
//! matching twins in crates/core/tests/engine/worst_scenario.rs.)

use crate::solves;

use std::time::Instant;

use serde_json::{json, Value};
use wsm_core::{
    parse_scene, ContactState, Coupling, Needs, Scene, Solution, SolveOptions, SolverKind,
    StateProblem,
};

fn options(scene: &Scene) -> SolveOptions {
    SolveOptions {
        needs: Needs::all(scene),
        par: wsm_core::Par::Seq,
        warm: None,
    }
}

fn solve_scene(scene: Scene) -> Result<(StateProblem, Solution), String> {
    let problem = StateProblem::new(scene).map_err(|e| e.to_string())?;
    let sol = problem
        .solve(&problem.nominal, &options(&problem.scene))
        .map_err(|e| e.to_string())?;
    Ok((problem, sol))
}

fn solve_value(v: &Value) -> Result<(StateProblem, Solution), String> {
    solve_scene(parse_scene(&v.to_string()).map_err(|e| e.to_string())?)
}

fn max_abs(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(0.0, |a, x| a.max(x.abs()))
}

/// The scene's generated mesh given inline, so that a second coupling meets the same nodes.
fn with_own_mesh_inline(scene: &Scene) -> Scene {
    let mesh = wsm_core::generate_mesh(scene).unwrap();
    let mut out = scene.clone();
    out.mesh.inline = Some(mesh.to_inline());
    // Larger than a posted inline mesh may be (10,000 nodes), so not through `parse` again.
    out
}

#[test]
fn matching_meshes_give_the_node_pair_results_on_every_bundled_contact_example() {
    let mut compared = 0;
    for name in wsm_core::example_names() {
        let mut scene = parse_scene(wsm_core::example(name).unwrap()).unwrap();
        if scene.contacts.is_empty()
            || scene
                .contacts
                .iter()
                .any(|c| c.coupling == Coupling::Mortar)
        {
            continue;
        }
        scene.solver.kind = SolverKind::Direct;
        let nodes = with_own_mesh_inline(&scene);
        let mut mortar = nodes.clone();
        for c in &mut mortar.contacts {
            c.coupling = Coupling::Mortar;
            c.slave = Some(c.between[0].clone());
        }
        let (pn, a) = solve_scene(nodes).unwrap();
        let (pm, b) = solve_scene(mortar).unwrap();
        assert_eq!(
            pn.contact.geometry.pairs.len(),
            pm.contact.geometry.pairs.len()
        );
        for (p, q) in pn
            .contact
            .geometry
            .pairs
            .iter()
            .zip(&pm.contact.geometry.pairs)
        {
            assert_eq!(p.nodes, q.nodes, "{name}: the same pairs");
            assert!(
                (p.weight - q.weight).abs() <= 1e-12 * p.weight,
                "{name}: weight {} vs {}",
                p.weight,
                q.weight
            );
        }
        let u = max_abs(a.displacement.iter().flatten().copied());
        let du = max_abs(
            a.displacement
                .iter()
                .flatten()
                .zip(b.displacement.iter().flatten())
                .map(|(x, y)| x - y),
        );
        // A pair whose rows have no free DOF (both nodes held) has multipliers the problem does
        // not determine (any value in the box): compared are the others.
        let geometry = &pn.contact.geometry;
        let determined: Vec<bool> = (0..geometry.pairs.len())
            .map(|m| {
                !geometry.rows[2 * m].free.is_empty() || !geometry.rows[2 * m + 1].free.is_empty()
            })
            .collect();
        let compared_pairs = || {
            a.contact
                .iter()
                .zip(&b.contact)
                .zip(&determined)
                .filter(|(_, d)| **d)
                .map(|(c, _)| c)
        };
        let f = max_abs(compared_pairs().flat_map(|(c, _)| [c.pressure, c.shear]));
        let df = max_abs(
            compared_pairs().flat_map(|(x, y)| [x.pressure - y.pressure, x.shear - y.shear]),
        );
        println!(
            "{name}: displacement {:.1e}, contact {:.1e}",
            du / u,
            df / f.max(1e-300)
        );
        assert!(
            du <= 1e-10 * u,
            "{name}: displacement differs by {du:e} of {u:e}"
        );
        assert!(
            df <= 1e-10 * f,
            "{name}: contact stress differs by {df:e} of {f:e}"
        );
        for (x, y) in a.criteria.iter().zip(&b.criteria) {
            if let (Some(x), Some(y)) = (x, y) {
                assert!(
                    (x - y).abs() <= 1e-10 * x.abs().max(1e-300),
                    "{name}: criterion {x} vs {y}"
                );
            }
        }
        compared += 1;
    }
    assert!(compared >= 8, "only {compared} examples compared");
}

/// Interface node counts of the two sides.
fn interface_nodes(problem: &StateProblem) -> (usize, usize) {
    let mesh = &problem.mesh();
    let count = |name: &str| {
        mesh.segments
            .iter()
            .find(|s| s.name == name)
            .map_or(0, |s| s.nodes.len())
    };
    (count("upper_bottom"), count("lower_top"))
}

/// Largest deviation of the element stresses (σ11, σ22, σ12, τ33) from the uniform state
/// σ22 = −p, σ11 = σ12 = 0 (rollers on the left sides and the floor, free right sides), relative
/// to p: a displacement field linear in each body has one constant stress per body.
fn stress_misfit(sol: &Solution, p: f64) -> f64 {
    sol.stresses
        .iter()
        .flat_map(|s| [s.stress[0], s.stress[1] + p, s.stress[2]])
        .fold(0.0, |worst: f64, x| worst.max(x.abs() / p))
}

#[test]
fn contact_patch_test_across_a_non_matching_interface() {
    let p = 3.0e6;
    let (problem, sol) = solve_value(&solves::stacked_blocks_mortar(p, 1.0e5, 0.1, 2.7)).unwrap();
    let (fine, coarse) = interface_nodes(&problem);
    println!("interface nodes: upper {fine}, lower {coarse}");
    assert!(
        fine >= 2 * coarse,
        "the sides do not match: {fine} vs {coarse}"
    );
    let zone = &problem.mesh().contacts[0];
    assert!(zone.mortar.is_some());
    assert_eq!(zone.pairs.len(), fine, "the finer side is the slave");
    for c in &sol.contact {
        assert!(
            (c.pressure - p).abs() <= 1e-8 * p,
            "λ_n / D_pp = {} at {:?}",
            c.pressure,
            c.position
        );
        assert!(c.shear.abs() <= 1e-8 * p, "shear {}", c.shear);
    }
    let misfit = stress_misfit(&sol, p);
    println!("element stresses off the uniform state by {misfit:.1e} p");
    assert!(
        misfit <= 1e-10,
        "displacement not linear: stresses off by {misfit:e} p"
    );
    assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
}

#[test]
fn tresca_block_sticks_below_and_is_refused_above_the_capacity_on_non_matching_meshes() {
    let g = 2.0e5;
    let scene = |t: f64| {
        let mut s = solves::stacked_blocks_mortar(1.0e6, g, 0.1, 2.7);
        s["boundary"][2] = json!({"segment": "upper_left", "traction": [t, 0]});
        s
    };
    let (problem, below) = solve_value(&scene(3.8e5)).unwrap();
    let total_shear: f64 = below
        .contact
        .iter()
        .zip(&problem.contact.geometry.pairs)
        .map(|(c, p)| c.shear * p.weight)
        .sum();
    assert!(
        (total_shear.abs() - 1.9e5).abs() <= 1e-8 * 1.9e5,
        "friction force {total_shear}"
    );
    assert!(below.contact.iter().any(|c| c.state == ContactState::Stick));
    assert!(below.report.kkt.max() <= 1e-9, "{:?}", below.report.kkt);
    let err = solve_value(&scene(4.2e5)).err().expect("must be refused");
    assert!(
        err.contains("upper") && err.contains("translation"),
        "{err}"
    );
}

/// The bundled Hertz scene with the bodies meshed on their own: the cylinder's contact side at
/// `cylinder` and the flat's at `flat`.
fn hertz_non_matching(cylinder: f64, flat: f64) -> Value {
    let mut v: Value = serde_json::from_str(wsm_core::example("hertz").unwrap()).unwrap();
    v["contacts"][0]["coupling"] = json!("mortar");
    v["mesh"]["refine"] = json!([
        {"segments": ["cylinder_contact"], "max_size": cylinder},
        {"segments": ["flat_contact"], "max_size": flat},
        {"polygon": [[-0.3, -0.15], [0.3, -0.15], [0.3, 0.15], [-0.3, 0.15]], "max_size": flat.max(cylinder)}
    ]);
    v
}

#[test]
fn hertz_on_non_matching_meshes_both_ways() {
    // The nodal pressure of the finer side carries the coarser side's chords: a wave of about
    // E* π H / (8 R_eff) (R_eff = 2R for equal materials), 2 % of p0 at H = 0.005.
    for (cylinder, flat) in [(0.0025, 0.005), (0.005, 0.0025)] {
        let (problem, sol) = solve_value(&hertz_non_matching(cylinder, flat)).unwrap();
        let h = solves::hertz_measures(&problem, &sol);
        let (a_exact, p0_exact) = h.exact;
        let (ea, ep) = (
            (h.half_width - a_exact).abs() / a_exact,
            (h.peak - p0_exact).abs() / p0_exact,
        );
        println!(
            "cylinder {cylinder}, flat {flat}: {} slave nodes, a = {:.5} ({ea:.2e}), p0 = {:.4e} ({ep:.2e}), Σλ = {:.6e}",
            sol.contact.len(),
            h.half_width,
            h.peak,
            h.total
        );
        assert!(
            (h.total - h.load).abs() <= 1e-8 * h.load,
            "resultant {} vs load {}",
            h.total,
            h.load
        );
        assert!(ea <= 0.03 && ep <= 0.03, "a off by {ea:.3}, p0 by {ep:.3}");
        assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
    }
}

#[test]
fn bad_mortar_zones_are_refused_in_milliseconds_naming_the_field() {
    let base = solves::stacked_blocks_mortar(1.0e6, 0.0, 0.1, 2.7);
    let cases: Vec<(Value, &str, &str)> = vec![
        {
            // The master side moved away sideways: nothing faces.
            let mut v = base.clone();
            v["bodies"][0]["zones"][0]["polygon"] = json!([[3, 0], [4, 0], [4, 0.5], [3, 0.5]]);
            v["segments"]["floor"] = json!({"body": "lower", "from": [3,0], "to": [4,0]});
            v["segments"]["lower_left"] = json!({"body": "lower", "from": [3,0.5], "to": [3,0]});
            v["segments"]["lower_top"] = json!({"body": "lower", "from": [3,0.5], "to": [4,0.5]});
            (v, "contacts[0].between", "do not face")
        },
        {
            // A slave of one element.
            let mut v = base.clone();
            v["mesh"]["refine"] = json!([]);
            v["segments"]["upper_bottom"]["to"] = json!([0.05, 0.5]);
            v["contacts"][0]["slave"] = json!("upper_bottom");
            (v, "contacts[0].between", "at least 2")
        },
        {
            // The lower body tilted through the upper one: the segments cross.
            let mut v = base.clone();
            v["bodies"][0]["zones"][0]["polygon"] = json!([[0, 0], [1, 0], [1, 1.0], [0, 0.2]]);
            v["segments"]["lower_left"] = json!({"body": "lower", "from": [0,0.2], "to": [0,0]});
            v["segments"]["lower_top"] = json!({"body": "lower", "from": [0,0.2], "to": [1,1.0]});
            (v, "contacts[0].between", "cross")
        },
        {
            let mut v = base.clone();
            v["segments"]["lower_top"]["body"] = json!("upper");
            v["segments"]["lower_top"]["from"] = json!([1, 1]);
            v["segments"]["lower_top"]["to"] = json!([0, 1]);
            v["boundary"][3] = json!({"segment": "upper_left", "roller": {}});
            (v, "contacts[0].between", "two different bodies")
        },
        {
            let mut v = base.clone();
            v["contacts"][0]["slave"] = json!("top");
            (v, "contacts[0].slave", "not one of")
        },
        {
            let mut v = base.clone();
            v["contacts"][0]["coupling"] = json!("nodes");
            v["contacts"][0]["slave"] = json!("upper_bottom");
            (v, "contacts[0].slave", "mortar")
        },
    ];
    for (v, path, words) in cases {
        let start = Instant::now();
        let err = parse_scene(&v.to_string())
            .map_err(|e| e.to_string())
            .and_then(|s| StateProblem::new(s).map(|_| ()).map_err(|e| e.to_string()))
            .expect_err("must be refused");
        let took = start.elapsed();
        println!("{path}: {err} ({took:?})");
        assert!(err.contains(path), "{err} does not name {path}");
        assert!(err.contains(words), "{err} does not say '{words}'");
        assert!(took.as_secs_f64() < 2.0, "took {took:?}");
    }
}

/// The block-on-base scene on a Gmsh mesh whose bodies were meshed on their own
/// (`scripts/gmsh_block_on_base.py`: the base's contact side in 8 elements, the block's in 21):
/// node-coupled it is refused as before; mortar-coupled it solves, the finer block side is the
/// slave, and the contact resultants carry the block's loads exactly — its top pressure 1e6 Pa on
/// 1 m plus its weight 2.45e4 N/m³ × 0.5 m² normally, the push 4e5 Pa on its 0.5 m side
/// tangentially (the block is held by the contact only).
#[test]
fn a_gmsh_mesh_with_the_bodies_meshed_on_their_own_is_coupled_by_mortar() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    let text = std::fs::read_to_string(data.join("block-on-base-gmsh.json")).unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["mesh"]["gmsh_file"] = json!(data.join("block-on-base-nonmatching.msh"));
    let err = solve_value(&v)
        .err()
        .expect("node coupling must be refused");
    assert!(
        err.contains("contacts[0].between") && err.contains("node for node"),
        "{err}"
    );
    v["contacts"][0]["coupling"] = json!("mortar");
    let (problem, sol) = solve_value(&v).unwrap();
    let mesh = problem.mesh();
    let count = |name: &str| {
        let s = mesh.segments.iter().find(|s| s.name == name).unwrap();
        s.nodes.len()
    };
    assert_eq!((count("block_contact"), count("base_contact")), (22, 9));
    let zone = &mesh.contacts[0];
    assert_eq!(mesh.segments[zone.segment_k].name, "block_contact");
    assert_eq!(zone.pairs.len(), 22, "every block node has a row");
    let resultant = |f: fn(&wsm_core::ContactNode) -> f64| -> f64 {
        sol.contact
            .iter()
            .zip(&problem.contact.geometry.pairs)
            .map(|(c, p)| f(c) * p.weight)
            .sum()
    };
    let (normal, tangential) = (resultant(|c| c.pressure), resultant(|c| c.shear));
    println!("normal {normal:.10e}, tangential {tangential:.10e}");
    let (n, t) = (1.0e6 + 2.45e4 * 0.5, 4.0e5 * 0.5);
    assert!((normal - n).abs() <= 1e-8 * n, "normal {normal} vs {n}");
    assert!(
        (tangential.abs() - t).abs() <= 1e-8 * t,
        "tangential {tangential} vs {t}"
    );
    assert!(sol.report.kkt.max() <= 1e-9, "{:?}", sol.report.kkt);
}

/// The Lamé cylinder (inner radius 1, outer 2, internal pressure p) cut at r = 1.5 into two rings
/// meshed on their own — the outer ring's side of the cut `ratio` times finer — and tied by a
/// bilateral mortar zone (normal tie; the exact solution has no shear on circles). Returns the
/// largest nodal error of u_r relative to u_r(1) and the relative L² error of the stress (the
/// energy norm's equivalent).
fn split_lame_errors(h: f64, ratio: f64) -> (f64, f64) {
    let (a, m, b, p, e, nu) = (1.0, 1.5, 2.0, 1.0e6, 2.0e9, 0.3);
    let arc = |r: f64, reverse: bool| {
        let n = 256;
        let mut pts: Vec<[f64; 2]> = (0..=n)
            .map(|k| {
                let t = std::f64::consts::FRAC_PI_2 * k as f64 / n as f64;
                [r * t.cos(), r * t.sin()]
            })
            .collect();
        if reverse {
            pts.reverse();
        }
        pts
    };
    let ring = |r0: f64, r1: f64| {
        let mut poly = arc(r0, false);
        poly.extend(arc(r1, true));
        poly
    };
    let scene = json!({
        "version": 1, "name": "split Lamé cylinder",
        "bodies": [
            {"name": "inner", "zones": [{"name": "inner", "material": "m", "polygon": ring(a, m)}]},
            {"name": "outer", "zones": [{"name": "outer", "material": "m", "polygon": ring(m, b)}]}
        ],
        "segments": {
            "bore": {"body": "inner", "path": arc(a, false)},
            "inner_cut": {"body": "inner", "path": arc(m, false)},
            "outer_cut": {"body": "outer", "path": arc(m, false)},
            "inner_x": {"body": "inner", "from": [a, 0], "to": [m, 0]},
            "outer_x": {"body": "outer", "from": [m, 0], "to": [b, 0]},
            "inner_y": {"body": "inner", "from": [0, m], "to": [0, a]},
            "outer_y": {"body": "outer", "from": [0, b], "to": [0, m]}
        },
        "materials": {"m": {"E": e, "nu": nu}},
        "boundary": [
            {"segment": "bore", "pressure": p},
            {"segment": "inner_x", "roller": {}}, {"segment": "outer_x", "roller": {}},
            {"segment": "inner_y", "roller": {}}, {"segment": "outer_y", "roller": {}}
        ],
        "contacts": [{"name": "cut", "between": ["outer_cut", "inner_cut"], "kind": "bilateral",
                      "coupling": "mortar"}],
        "mesh": {"max_size": h, "refine": [{"segments": ["outer_cut"], "max_size": h / ratio}]}
    });
    let (problem, sol) = solve_value(&scene).unwrap();
    // Plane strain Lamé: u_r = A r + B / r, σ_θ = C + D / r².
    let (lam, mu) = (
        e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        e / (2.0 * (1.0 + nu)),
    );
    let c = p * a * a / (b * b - a * a);
    let d = p * a * a * b * b / (b * b - a * a);
    let u_r = |r: f64| c / (2.0 * (lam + mu)) * r + d / (2.0 * mu * r);
    let hoop = |r: f64| c + d / (r * r);
    let mesh = problem.mesh();
    let u_err = mesh
        .nodes
        .iter()
        .zip(&sol.displacement)
        .map(|(x, u)| {
            let r = x[0].hypot(x[1]);
            ((u[0] * x[0] + u[1] * x[1]) / r - u_r(r)).abs() / u_r(a)
        })
        .fold(0.0, f64::max);
    // Relative L² error of the stress tensor (centroid rule), equivalent to the energy norm.
    let (mut num, mut den) = (0.0, 0.0);
    for (t, s) in sol.stresses.iter().enumerate() {
        let tri = mesh.triangles[t];
        let c = tri.iter().fold([0.0; 2], |c, &n| {
            [c[0] + mesh.nodes[n][0] / 3.0, c[1] + mesh.nodes[n][1] / 3.0]
        });
        let r = c[0].hypot(c[1]);
        let (cs, sn) = (c[0] / r, c[1] / r);
        let (srr, stt) = (hoop(r) - 2.0 * d / (r * r), hoop(r));
        let exact = [
            srr * cs * cs + stt * sn * sn,
            srr * sn * sn + stt * cs * cs,
            (srr - stt) * cs * sn,
        ];
        let area = mesh.triangle_area(t);
        for ((w, computed), exact) in [1.0, 1.0, 2.0].into_iter().zip(s.stress).zip(exact) {
            num += area * w * (computed - exact).powi(2);
            den += area * w * exact.powi(2);
        }
    }
    let s_err = (num / den).sqrt();
    (u_err, s_err)
}

#[test]
fn elasticity_across_a_mortar_tie_converges_at_the_p1_rates() {
    let errors: Vec<(f64, f64)> = [0.1, 0.05, 0.025]
        .iter()
        .map(|&h| split_lame_errors(h, 2.7))
        .collect();
    println!("split Lamé (u_r, σ_θ) errors at h = 0.1, 0.05, 0.025: {errors:?}");
    for w in errors.windows(2) {
        println!(
            "ratios: u_r {:.2}, stress {:.2}",
            w[0].0 / w[1].0,
            w[0].1 / w[1].1
        );
    }
    // Asymptotic on the finer pair (the coarsest ring has 5 elements across).
    let (du, ds) = (errors[1].0 / errors[2].0, errors[1].1 / errors[2].1);
    assert!(du > 3.4, "u_r error must fall like h²: {errors:?}");
    assert!(ds > 1.7, "stress error must fall like h: {errors:?}");
}
