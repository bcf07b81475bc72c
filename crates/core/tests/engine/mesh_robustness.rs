//! Geometry corpus for the built-in mesher: every case must mesh (the mesher checks every mesh
//! it hands out, see `mesh::check`) and pass the independent checks below; nothing may panic.
//! Cases: the quarter thick-walled cylinders of the robustness report (also solved and compared
//! with Lamé), annuli and quarter annuli with 8–400-point arcs, polygons with holes, star- and
//! comb-shaped concave polygons, thin features down to 1e-3 of the body size, stacks of bodies
//! with contact lines, refinement boxes and graded sizes, near-coincident input points, and 200
//! random simple polygons (proptest, deterministic seed).

use std::f64::consts::{FRAC_PI_2, PI};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use serde_json::{json, Value};
use wsm_core::{
    generate_mesh, mesh_stats, validate_scene, Mesh, Needs, Par, Scene, SolveOptions, StateProblem,
};

type P = [f64; 2];

fn area(ring: &[P]) -> f64 {
    let n = ring.len();
    0.5 * (0..n)
        .map(|i| ring[i][0] * ring[(i + 1) % n][1] - ring[(i + 1) % n][0] * ring[i][1])
        .sum::<f64>()
}

/// Points of an arc of radius r from angle t0 to t1 (n points, ends included), by cos/sin.
fn arc(r: f64, t0: f64, t1: f64, n: usize) -> Vec<P> {
    (0..n)
        .map(|i| {
            let t = t0 + (t1 - t0) * i as f64 / (n - 1) as f64;
            [r * t.cos(), r * t.sin()]
        })
        .collect()
}

fn circle(c: P, r: f64, n: usize) -> Vec<P> {
    (0..n)
        .map(|i| {
            let t = 2.0 * PI * i as f64 / n as f64;
            [c[0] + r * t.cos(), c[1] + r * t.sin()]
        })
        .collect()
}

fn body(name: &str, polygon: &[P], holes: &[Vec<P>]) -> Value {
    json!({ "name": name, "zones": [{ "name": name, "material": "m",
        "polygon": polygon, "holes": holes }] })
}

fn scene(bodies: Vec<Value>, extra: Value, mesh: Value) -> Scene {
    let mut s = json!({
        "version": 1,
        "bodies": bodies,
        "materials": { "m": { "E": 1.0e9, "nu": 0.3 } },
        "mesh": mesh
    });
    if let (Some(s), Some(extra)) = (s.as_object_mut(), extra.as_object()) {
        s.extend(extra.clone());
    }
    serde_json::from_value(s).expect("test scene parses")
}

/// Independent checks of a mesh: positive areas, used nodes, the domain's area, and (when
/// `min_angle` is given, for inputs without small angles) the minimum angle.
fn check(name: &str, mesh: &Mesh, domain_area: f64, min_angle: Option<f64>) {
    let mut used = vec![false; mesh.nodes.len()];
    let mut total = 0.0;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let a = mesh.triangle_area(t);
        assert!(a > 0.0, "{name}: triangle {t} has area {a}");
        total += a;
        for &n in tri {
            used[n] = true;
        }
    }
    assert!(used.iter().all(|&u| u), "{name}: unused nodes");
    assert!(
        (total - domain_area).abs() <= 1e-9 * domain_area,
        "{name}: area {total} vs {domain_area}"
    );
    if let Some(limit) = min_angle {
        let s = mesh_stats(mesh);
        assert!(
            s.min_angle_deg >= limit - 1e-6,
            "{name}: min angle {}",
            s.min_angle_deg
        );
    }
}

fn mesh_ok(name: &str, sc: &Scene) -> Mesh {
    match generate_mesh(sc) {
        Ok(m) => m,
        Err(e) => panic!("{name}: {e}"),
    }
}

/// Quarter of a thick-walled cylinder a ≤ r ≤ b with n-point arcs, rollers on the straight
/// edges and pressure p inside; `exact_ends` puts the arc ends exactly on the axes.
fn quarter_cylinder(a: f64, b: f64, n: usize, h: f64, exact_ends: bool) -> Value {
    let mut outer = arc(b, 0.0, FRAC_PI_2, n);
    let mut inner = arc(a, 0.0, FRAC_PI_2, n);
    if exact_ends {
        outer[n - 1] = [0.0, b];
        inner[n - 1] = [0.0, a];
    }
    let mut polygon = outer.clone();
    polygon.extend(inner.iter().rev());
    json!({
        "version": 1,
        "bodies": [{ "name": "cylinder", "zones": [{ "name": "wall", "material": "steel",
            "polygon": polygon }] }],
        "segments": {
            "inner": { "body": "cylinder", "path": inner },
            "outer": { "body": "cylinder", "path": outer },
            "x_axis": { "body": "cylinder", "from": [a, 0.0], "to": [b, 0.0] },
            "y_axis": { "body": "cylinder", "from": [0.0, b], "to": [0.0, a] }
        },
        "materials": { "steel": { "E": 2.1e11, "nu": 0.3 } },
        "boundary": [
            { "segment": "x_axis", "roller": {} },
            { "segment": "y_axis", "roller": {} },
            { "segment": "inner", "pressure": 1.0e7 }
        ],
        "mesh": { "max_size": h }
    })
}

/// Meshes and solves a quarter cylinder; returns the largest error of the radial displacement
/// against Lamé's solution relative to u_r(a) (the polyline arcs cost a little accuracy).
fn solve_cylinder(a: f64, b: f64, n: usize, h: f64, exact_ends: bool) -> f64 {
    let text = quarter_cylinder(a, b, n, h, exact_ends).to_string();
    let sc: Scene = serde_json::from_str(&text).expect("scene parses");
    validate_scene(&sc).expect("scene is valid");
    let name = format!("quarter cylinder {a}/{b}, {n}-point arcs, h {h}");
    let problem = StateProblem::new(sc).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mesh = problem.mesh().clone();
    let exact = PI / 4.0 * (b * b - a * a);
    // The polygon's area is a little less than the exact annulus.
    let poly_area = {
        let mut ring = arc(b, 0.0, FRAC_PI_2, n);
        ring.extend(arc(a, 0.0, FRAC_PI_2, n).into_iter().rev());
        area(&ring)
    };
    assert!((poly_area - exact).abs() < 0.01 * exact);
    check(&name, &mesh, poly_area, Some(28.0));
    let options = SolveOptions {
        needs: Needs::all(&problem.scene),
        par: Par::Seq,
        warm: None,
    };
    let sol = problem
        .solve(&problem.nominal, &options)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let (p, e, nu) = (1.0e7, 2.1e11, 0.3);
    let c = a * a * p / (b * b - a * a);
    let ur = |r: f64| (1.0 + nu) / e * c * ((1.0 - 2.0 * nu) * r + b * b / r);
    let mut worst = 0.0f64;
    for (x, u) in mesh.nodes.iter().zip(&sol.displacement) {
        let r = x[0].hypot(x[1]);
        let got = (u[0] * x[0] + u[1] * x[1]) / r;
        worst = worst.max((got - ur(r)).abs() / ur(a));
    }
    println!(
        "{name}: {} triangles, min angle {:.2}°, Lamé u_r error {:.2e}",
        mesh.triangles.len(),
        mesh_stats(&mesh).min_angle_deg,
        worst
    );
    worst
}

#[test]
fn quarter_cylinders_of_the_report_mesh_and_solve() {
    let cases = [
        (0.2, 0.5, 97, 0.006, true),
        (0.2, 0.5, 97, 0.003, true),
        (0.2, 0.5, 33, 0.006, true),
        (0.2, 0.5, 33, 0.02, true),
        (0.2, 0.5, 49, 0.02, false),
        (0.1, 0.2, 33, 0.008, true),
    ];
    for (a, b, n, h, exact) in cases {
        let err = solve_cylinder(a, b, n, h, exact);
        // The polyline radius differs from the circle by up to r(1 − cos(π/4/(n−1))).
        assert!(err < 0.03, "Lamé error {err}");
    }
}

#[test]
fn annuli_and_quarter_annuli_with_many_arc_resolutions() {
    for n in [8, 17, 33, 64, 150, 400] {
        for h in [0.5, 0.1, 0.02] {
            let outer = circle([0.0, 0.0], 1.0, n);
            let inner = circle([0.0, 0.0], 0.4, n.max(8) / 2 + 3);
            let sc = scene(
                vec![body("ring", &outer, std::slice::from_ref(&inner))],
                json!({}),
                json!({ "max_size": h }),
            );
            let name = format!("annulus n={n} h={h}");
            let m = mesh_ok(&name, &sc);
            check(&name, &m, area(&outer) - area(&inner).abs(), Some(28.0));

            let mut q = arc(1.0, 0.0, FRAC_PI_2, n);
            q.extend(arc(0.3, 0.0, FRAC_PI_2, n).into_iter().rev());
            let sc = scene(
                vec![body("quarter", &q, &[])],
                json!({}),
                json!({ "max_size": h }),
            );
            let name = format!("quarter annulus n={n} h={h}");
            let m = mesh_ok(&name, &sc);
            check(&name, &m, area(&q), Some(28.0));
        }
    }
}

#[test]
fn polygons_with_holes() {
    let outer = vec![[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]];
    let holes = vec![
        circle([1.0, 1.0], 0.5, 40),
        vec![[2.5, 0.5], [3.5, 0.5], [3.5, 1.0], [2.5, 1.0]],
        circle([2.0, 2.2], 0.3, 12),
        // A thin slot: 1e-3 of the body size.
        vec![[0.5, 2.0], [1.5, 2.0], [1.5, 2.004], [0.5, 2.004]],
    ];
    let hole_area: f64 = holes.iter().map(|h| area(h).abs()).sum();
    for h in [1.0, 0.2, 0.05] {
        let sc = scene(
            vec![body("plate", &outer, &holes)],
            json!({}),
            json!({ "max_size": h }),
        );
        let name = format!("plate with holes h={h}");
        let m = mesh_ok(&name, &sc);
        check(&name, &m, 12.0 - hole_area, Some(28.0));
    }
}

fn star(spikes: usize, r_in: f64, r_out: f64) -> Vec<P> {
    (0..2 * spikes)
        .map(|i| {
            let t = PI * i as f64 / spikes as f64;
            let r = if i % 2 == 0 { r_out } else { r_in };
            [r * t.cos(), r * t.sin()]
        })
        .collect()
}

/// A comb: a spine of height `spine` over `teeth` teeth of width w and length `length`
/// separated by gaps g (counter-clockwise).
fn comb(teeth: usize, w: f64, g: f64, length: f64, spine: f64) -> Vec<P> {
    let mut pts = Vec::new();
    for i in 0..teeth {
        let x = i as f64 * (w + g);
        if i > 0 {
            pts.push([x, 0.0]);
        }
        pts.push([x, -length]);
        pts.push([x + w, -length]);
        if i + 1 < teeth {
            pts.push([x + w, 0.0]);
        }
    }
    let right = teeth as f64 * w + (teeth - 1) as f64 * g;
    pts.push([right, spine]);
    pts.push([0.0, spine]);
    pts
}

#[test]
fn star_and_comb_shaped_concave_polygons() {
    for (spikes, r_in) in [(5, 0.4), (12, 0.2), (40, 0.7), (7, 0.05)] {
        for h in [0.5, 0.05] {
            let s = star(spikes, r_in, 1.0);
            let sc = scene(
                vec![body("star", &s, &[])],
                json!({}),
                json!({ "max_size": h }),
            );
            let name = format!("star {spikes}/{r_in} h={h}");
            let m = mesh_ok(&name, &sc);
            check(&name, &m, area(&s), None);
        }
    }
    for (teeth, w, g) in [(5, 0.1, 0.1), (10, 0.02, 0.001), (3, 0.001, 0.2)] {
        for h in [0.2, 0.02] {
            let c = comb(teeth, w, g, 1.0, 0.1);
            assert!(area(&c) > 0.0, "{c:?}");
            let sc = scene(
                vec![body("comb", &c, &[])],
                json!({}),
                json!({ "max_size": h }),
            );
            let name = format!("comb {teeth}×{w}/{g} h={h}");
            let m = mesh_ok(&name, &sc);
            check(&name, &m, area(&c), Some(28.0));
        }
    }
}

#[test]
fn thin_bodies_and_near_coincident_points() {
    // A strip 1e-3 of its length thick.
    let strip = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.001], [0.0, 0.001]];
    let sc = scene(
        vec![body("strip", &strip, &[])],
        json!({}),
        json!({ "max_size": 0.1 }),
    );
    let m = mesh_ok("strip", &sc);
    check("strip", &m, 0.001, Some(28.0));
    // A repeated vertex 1e-13 away from the first is merged, not meshed.
    let sq = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1e-13], [1.0, 1.0], [0.0, 1.0]];
    let sc = scene(
        vec![body("square", &sq, &[])],
        json!({}),
        json!({ "max_size": 0.2 }),
    );
    let m = mesh_ok("near-coincident", &sc);
    check("near-coincident", &m, 1.0, Some(28.0));
    // A vertex 1e-8 away from another is neither the same point nor a real feature: refused,
    // naming the polygon and the point.
    let sq = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1e-8], [1.0, 1.0], [0.0, 1.0]];
    let sc = scene(
        vec![body("square", &sq, &[])],
        json!({}),
        json!({ "max_size": 0.2 }),
    );
    let e = generate_mesh(&sc).expect_err("near-coincident points are refused");
    assert_eq!(e.path, "bodies[0].zones[0].polygon", "{e}");
    assert!(
        e.reason.contains("(1, 0.00000001)") || e.reason.contains("(1, 0)"),
        "{e}"
    );
    // Nearly collinear vertices along an edge.
    let mut wavy = vec![[0.0, 0.0]];
    wavy.extend((1..50).map(|i| [i as f64 / 50.0, 1e-7 * (i % 2) as f64]));
    wavy.extend([[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    let sc = scene(
        vec![body("wavy", &wavy, &[])],
        json!({}),
        json!({ "max_size": 0.05 }),
    );
    let m = mesh_ok("wavy", &sc);
    check("wavy", &m, area(&wavy), None);
}

#[test]
fn stacks_of_bodies_with_contact_lines_and_refinement() {
    // Three blocks on a base, touching along lines with vertices at different places (T-junctions),
    // a concave L-shaped body and a body resting in a notch.
    let base = vec![[0.0, 0.0], [6.0, 0.0], [6.0, 1.0], [0.0, 1.0]];
    let b1 = vec![[0.5, 1.0], [2.0, 1.0], [2.0, 2.0], [0.5, 2.0]];
    let b2 = vec![[2.0, 1.0], [3.3, 1.0], [3.3, 1.7], [2.0, 1.7]];
    let l = vec![
        [3.5, 1.0],
        [5.5, 1.0],
        [5.5, 1.5],
        [4.0, 1.5],
        [4.0, 3.0],
        [3.5, 3.0],
    ];
    let top = vec![[0.5, 2.0], [2.0, 2.0], [2.0, 2.5], [0.5, 2.5]];
    let bodies = vec![
        body("base", &base, &[]),
        body("b1", &b1, &[]),
        body("b2", &b2, &[]),
        body("l", &l, &[]),
        body("top", &top, &[]),
    ];
    let extra = json!({
        "segments": {
            "base_1": { "body": "base", "from": [0.5, 1.0], "to": [2.0, 1.0] },
            "b1_base": { "body": "b1", "from": [0.5, 1.0], "to": [2.0, 1.0] },
            "b1_b2": { "body": "b1", "from": [2.0, 1.0], "to": [2.0, 1.7] },
            "b2_b1": { "body": "b2", "from": [2.0, 1.0], "to": [2.0, 1.7] },
            "b1_top": { "body": "b1", "from": [0.5, 2.0], "to": [2.0, 2.0] },
            "top_b1": { "body": "top", "from": [0.5, 2.0], "to": [2.0, 2.0] },
            "base_l": { "body": "base", "from": [3.5, 1.0], "to": [5.5, 1.0] },
            "l_base": { "body": "l", "from": [3.5, 1.0], "to": [5.5, 1.0] }
        },
        "contacts": [
            { "name": "c1", "between": ["b1_base", "base_1"] },
            { "name": "c2", "between": ["b1_b2", "b2_b1"] },
            { "name": "c3", "between": ["top_b1", "b1_top"] },
            { "name": "c4", "between": ["l_base", "base_l"] }
        ]
    });
    let total = area(&base) + area(&b1) + area(&b2) + area(&l) + area(&top);
    for mesh in [
        json!({ "max_size": 0.3 }),
        json!({ "max_size": 0.2, "refine": [{ "segments": ["b1_base", "l_base"], "max_size": 0.01 }] }),
        json!({ "max_size": 0.5, "refine": [{ "polygon": [[3.0, 0.5], [4.5, 0.5], [4.5, 2.0], [3.0, 2.0]], "max_size": 0.02 }] }),
    ] {
        let sc = scene(bodies.clone(), extra.clone(), mesh.clone());
        let name = format!("stack {mesh}");
        let m = mesh_ok(&name, &sc);
        check(&name, &m, total, Some(28.0));
        assert_eq!(m.contacts.len(), 4);
        for c in &m.contacts {
            assert!(c.pairs.len() >= 2);
            for &[a, b] in &c.pairs {
                assert!(
                    (m.nodes[a][0] - m.nodes[b][0]).hypot(m.nodes[a][1] - m.nodes[b][1]) < 1e-12
                );
            }
        }
    }
}

/// A random simple polygon: star-shaped about the origin, one vertex at a random angle in each
/// of n equal sectors (so that no angular gap reaches π), at random radii (deep notches and
/// nearly collinear runs included), scaled randomly.
fn random_polygon() -> impl Strategy<Value = Vec<P>> {
    (5usize..60)
        .prop_flat_map(|n| {
            (
                prop::collection::vec(0.0f64..0.9, n),
                prop::collection::vec(0.02f64..1.0, n),
                0.01f64..100.0,
            )
        })
        .prop_map(|(u, r, scale)| {
            let n = u.len() as f64;
            u.iter()
                .zip(&r)
                .enumerate()
                .map(|(i, (&u, &r))| {
                    let a = 2.0 * PI * (i as f64 + u) / n;
                    [scale * r * a.cos(), scale * r * a.sin()]
                })
                .collect::<Vec<P>>()
        })
}

#[test]
fn random_simple_polygons() {
    let config = Config {
        cases: 200,
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        ..Config::default()
    };
    let rng = TestRng::deterministic_rng(RngAlgorithm::ChaCha);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let count = std::cell::Cell::new(0);
    let result = runner.run(&(random_polygon(), 0.02f64..0.5), |(poly, rel)| {
        let size = poly.iter().map(|q| q[0].hypot(q[1])).fold(0.0, f64::max);
        let sc = scene(
            vec![body("p", &poly, &[])],
            json!({}),
            json!({ "max_size": rel * size }),
        );
        let m = generate_mesh(&sc).map_err(|e| TestCaseError::fail(format!("{poly:?}: {e}")))?;
        check("random polygon", &m, area(&poly), None);
        count.set(count.get() + 1);
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    assert!(count.get() >= 200, "{} cases ran", count.get());
}
