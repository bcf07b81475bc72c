//! The Matlab mortar paper's scalar mortar as heat conduction on non-matching subdomains (design
//! §2.4.1, §3.3): −Δu = f, κ = 1, bodies meshed on their own and glued by mortar ties whose slave
//! temperatures are T_p = Σ_q M̂_pq T_q (`fem::heat`).
//! - the patch test: a linear temperature is reproduced to rounding across a 1 : 2.7 interface,
//!   with the slave ends prescribed or insulated (paper part A.6 check 2);
//! - matching meshes: a mortar tie gives the node-pair temperatures (check 3);
//! - a manufactured smooth solution across a straight non-matching interface: L² error O(h²),
//!   energy error O(h) (check 5);
//! - example (24), the annulus with the data's jump: the series values at (r, π/2), and refining
//!   only the subdomain holding the jump improves them (the paper's claim);
//! - example (23), −Δu = 30 with u = 0 / 1 on two boundary parts, against a fine conforming
//!   solution.

use std::f64::consts::PI;

use serde_json::{json, Value};
use wsm_core::{parse_scene, Coupling, Data, HeatProblem, Mesh, Par, Scene};

/// A unit material (κ = 1, source `source`); the elastic constants are not used.
fn material(source: f64) -> Value {
    json!({"E": 1.0e9, "nu": 0.3, "conductivity": 1.0, "heat_source": source})
}

/// The mesh and heat problem of a scene.
fn heat(scene: &Scene) -> (Mesh, HeatProblem) {
    let mesh = wsm_core::generate_mesh(scene).unwrap();
    let problem = HeatProblem::from_scene(&mesh, scene).unwrap();
    (mesh, problem)
}

/// Solve with the scene's data.
fn solve(scene: &Scene, problem: &HeatProblem) -> Vec<f64> {
    let data = Data::from_scene(scene);
    problem
        .solve(&problem.factor(&data, Par::Seq).unwrap(), &data)
        .unwrap()
}

/// Solve −Δu = f with u prescribed on the temperature segments by `exact` at the nodes, the load
/// ∫ f φ_i by the degree-2 rule.
fn solve_with(
    mesh: &Mesh,
    problem: &HeatProblem,
    scene: &Scene,
    f: impl Fn([f64; 2]) -> f64,
    exact: impl Fn([f64; 2]) -> f64,
) -> Vec<f64> {
    let data = Data::from_scene(scene);
    let mut loads = vec![0.0; mesh.nodes.len()];
    for tri in &mesh.triangles {
        let x = tri.map(|n| mesh.nodes[n]);
        let area = area(x);
        for (l, p) in rule(x) {
            let v = f(p) * area / 3.0;
            for (i, &n) in tri.iter().enumerate() {
                loads[n] += v * l[i];
            }
        }
    }
    let field: Vec<f64> = mesh.nodes.iter().map(|&p| exact(p)).collect();
    let fixed = problem.fixed_values_from(&field).unwrap();
    problem
        .solve_with(&problem.factor(&data, Par::Seq).unwrap(), &loads, &fixed)
        .unwrap()
}

fn area(x: [[f64; 2]; 3]) -> f64 {
    0.5 * ((x[1][0] - x[0][0]) * (x[2][1] - x[0][1]) - (x[2][0] - x[0][0]) * (x[1][1] - x[0][1]))
}

/// The degree-2 rule on a triangle (weights area/3): barycentric coordinates and points.
fn rule(x: [[f64; 2]; 3]) -> [([f64; 3], [f64; 2]); 3] {
    let point = |l: [f64; 3]| {
        [
            l[0] * x[0][0] + l[1] * x[1][0] + l[2] * x[2][0],
            l[0] * x[0][1] + l[1] * x[1][1] + l[2] * x[2][1],
        ]
    };
    let (a, b) = (2.0 / 3.0, 1.0 / 6.0);
    [[a, b, b], [b, a, b], [b, b, a]].map(|l| (l, point(l)))
}

/// (L² error, energy error |u − u_h|_1) of a P1 field against an exact solution and gradient.
fn errors(
    mesh: &Mesh,
    u: &[f64],
    exact: impl Fn([f64; 2]) -> f64,
    gradient: impl Fn([f64; 2]) -> [f64; 2],
) -> (f64, f64) {
    let (mut l2, mut h1) = (0.0, 0.0);
    for tri in &mesh.triangles {
        let x = tri.map(|n| mesh.nodes[n]);
        let v = tri.map(|n| u[n]);
        let a = area(x);
        // ∇u_h = Σ v_i ∇λ_i, ∇λ_i = (y_j − y_k, x_k − x_j) / 2A.
        let mut g = [0.0; 2];
        for (i, vi) in v.iter().enumerate() {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            g[0] += vi * (x[j][1] - x[k][1]) / (2.0 * a);
            g[1] += vi * (x[k][0] - x[j][0]) / (2.0 * a);
        }
        for (l, p) in rule(x) {
            let uh = l[0] * v[0] + l[1] * v[1] + l[2] * v[2];
            let ge = gradient(p);
            l2 += a / 3.0 * (uh - exact(p)).powi(2);
            h1 += a / 3.0 * ((g[0] - ge[0]).powi(2) + (g[1] - ge[1]).powi(2));
        }
    }
    (l2.sqrt(), h1.sqrt())
}

/// The P1 field at a point (the first triangle holding it).
fn value_at(mesh: &Mesh, u: &[f64], p: [f64; 2]) -> f64 {
    for tri in &mesh.triangles {
        let x = tri.map(|n| mesh.nodes[n]);
        let a = area(x);
        let l = [
            area([p, x[1], x[2]]) / a,
            area([x[0], p, x[2]]) / a,
            area([x[0], x[1], p]) / a,
        ];
        if l.iter().all(|&li| li >= -1e-12) {
            return l[0] * u[tri[0]] + l[1] * u[tri[1]] + l[2] * u[tri[2]];
        }
    }
    panic!("no triangle holds {p:?}");
}

/// Slope of log e against log h between consecutive levels.
fn slopes(h: &[f64], e: &[f64]) -> Vec<f64> {
    (1..h.len())
        .map(|i| (e[i - 1] / e[i]).ln() / (h[i - 1] / h[i]).ln())
        .collect()
}

/// The unit square as two bodies split at y = 1/2, meshed at size h below and h / `ratio` along
/// the upper side of the interface, glued by a mortar tie (slave: the finer upper side). Every
/// outer side is a temperature segment unless `insulated_sides`.
fn split_square(h: f64, ratio: f64, insulated_sides: bool) -> Value {
    let mut boundary = vec![
        json!({"segment": "floor", "temperature": 0.0}),
        json!({"segment": "top", "temperature": 0.0}),
    ];
    if !insulated_sides {
        for s in ["lower_left", "lower_right", "upper_left", "upper_right"] {
            boundary.push(json!({"segment": s, "temperature": 0.0}));
        }
    }
    json!({
        "version": 1, "name": "split square",
        "bodies": [
            {"name": "lower", "zones": [{"name": "lower", "material": "m", "polygon": [[0,0],[1,0],[1,0.5],[0,0.5]]}]},
            {"name": "upper", "zones": [{"name": "upper", "material": "m", "polygon": [[0,0.5],[1,0.5],[1,1],[0,1]]}]}
        ],
        "segments": {
            "floor": {"body": "lower", "from": [0,0], "to": [1,0]},
            "lower_right": {"body": "lower", "from": [1,0], "to": [1,0.5]},
            "lower_left": {"body": "lower", "from": [0,0.5], "to": [0,0]},
            "upper_right": {"body": "upper", "from": [1,0.5], "to": [1,1]},
            "upper_left": {"body": "upper", "from": [0,1], "to": [0,0.5]},
            "top": {"body": "upper", "from": [1,1], "to": [0,1]},
            "lower_top": {"body": "lower", "from": [0,0.5], "to": [1,0.5]},
            "upper_bottom": {"body": "upper", "from": [0,0.5], "to": [1,0.5]}
        },
        "materials": {"m": material(0.0)},
        "thermal": {"reference_temperature": 0.0},
        "boundary": boundary,
        "contacts": [{"name": "tie", "between": ["upper_bottom", "lower_top"], "kind": "bilateral",
                      "coupling": "mortar", "slave": "upper_bottom"}],
        "mesh": {"max_size": h, "refine": [{"segments": ["upper_bottom"], "max_size": h / ratio}]}
    })
}

/// Largest |u_h − u| at the nodes.
fn nodal_error(mesh: &Mesh, u: &[f64], exact: impl Fn([f64; 2]) -> f64) -> f64 {
    mesh.nodes
        .iter()
        .zip(u)
        .fold(0.0, |m, (&p, &v)| m.max((v - exact(p)).abs()))
}

/// Interface node counts (slave, master) of the first contact zone.
fn interface_nodes(mesh: &Mesh) -> (usize, usize) {
    let c = &mesh.contacts[0];
    (
        mesh.segments[c.segment_k].nodes.len(),
        mesh.segments[c.segment_l].nodes.len(),
    )
}

#[test]
fn a_linear_temperature_passes_a_non_matching_interface_exactly() {
    for insulated in [false, true] {
        let scene = parse_scene(&split_square(0.1, 2.7, insulated).to_string()).unwrap();
        let (mesh, problem) = heat(&scene);
        let (ns, nm) = interface_nodes(&mesh);
        // Insulated sides: ∂u/∂x = 0 there, so u depends on y only.
        let exact = |p: [f64; 2]| {
            if insulated {
                1.0 - 3.0 * p[1]
            } else {
                1.0 + 2.0 * p[0] - 3.0 * p[1]
            }
        };
        let u = solve_with(&mesh, &problem, &scene, |_| 0.0, exact);
        let e = nodal_error(&mesh, &u, exact);
        println!("patch test (insulated sides: {insulated}): {ns} : {nm} interface nodes, max nodal error {e:.1e}");
        assert!(ns > 2 * nm, "the interface meshes must differ: {ns} : {nm}");
        assert!(e < 1e-12, "linear field off by {e:e}");
    }
}

#[test]
fn matching_meshes_give_the_node_pair_temperatures() {
    let mut v = split_square(0.1, 1.0, true);
    v["materials"]["m"] = material(7.0);
    v["boundary"][1]["temperature"] = json!(2.0);
    v["contacts"][0]["coupling"] = json!("nodes");
    v["contacts"][0].as_object_mut().unwrap().remove("slave");
    let nodes = parse_scene(&v.to_string()).unwrap();
    let mesh = wsm_core::generate_mesh(&nodes).unwrap();
    let mut inline = nodes.clone();
    inline.mesh.inline = Some(mesh.to_inline());
    let mut mortar = inline.clone();
    mortar.contacts[0].coupling = Coupling::Mortar;
    let (_, pn) = heat(&inline);
    let (mm, pm) = heat(&mortar);
    assert!(mm.contacts[0].mortar.is_some());
    let (a, b) = (solve(&inline, &pn), solve(&mortar, &pm));
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let d = a
        .iter()
        .zip(&b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    println!(
        "matching meshes: mortar vs node pairs {:.1e} of {scale:.2}",
        d / scale
    );
    assert!(d <= 1e-10 * scale, "differs by {d:e}");
}

#[test]
fn manufactured_heat_converges_at_h2_in_l2_and_h_in_energy_across_a_non_matching_interface() {
    let exact = |p: [f64; 2]| (PI * p[0]).sin() * (1.5 * p[1]).exp();
    let gradient = |p: [f64; 2]| {
        [
            PI * (PI * p[0]).cos() * (1.5 * p[1]).exp(),
            1.5 * (PI * p[0]).sin() * (1.5 * p[1]).exp(),
        ]
    };
    // −Δu = (π² − 2.25) u.
    let f = |p: [f64; 2]| (PI * PI - 2.25) * exact(p);
    let hs = [0.1, 0.05, 0.025, 0.0125];
    let (mut l2, mut h1) = (Vec::new(), Vec::new());
    for &h in &hs {
        let scene = parse_scene(&split_square(h, 2.7, false).to_string()).unwrap();
        let (mesh, problem) = heat(&scene);
        let u = solve_with(&mesh, &problem, &scene, f, exact);
        let (a, b) = errors(&mesh, &u, exact, gradient);
        let (ns, nm) = interface_nodes(&mesh);
        println!(
            "h = {h}: {} nodes, interface {ns} : {nm}, L² {a:.3e}, energy {b:.3e}",
            mesh.nodes.len()
        );
        l2.push(a);
        h1.push(b);
    }
    let (sl2, sh1) = (slopes(&hs, &l2), slopes(&hs, &h1));
    println!("slopes: L² {sl2:.2?}, energy {sh1:.2?}");
    let last = |s: &[f64]| s[s.len() - 1];
    assert!(
        last(&sl2) > 1.8 && sl2.iter().all(|&s| s > 1.6),
        "L² slopes {sl2:?}"
    );
    assert!(
        last(&sh1) > 0.9 && sh1.iter().all(|&s| s > 0.8),
        "energy slopes {sh1:?}"
    );
}

/// The annulus 1/4 < r² < 1 as four sector bodies cut at φ = −π/8 + kπ/2 (the data's jump at
/// φ = π/4 lies in sector 0, the points (r, π/2) in sector 1), the circles as polygons with a
/// vertex every π/`per_pi` (`per_pi` a multiple of 8, so that φ = π/4 is one); sector k meshed at size `sizes[k]`; mortar ties
/// across the cuts.
fn annulus(sizes: [f64; 4], per_pi: usize) -> Value {
    let cut = |k: usize| -PI / 8.0 + k as f64 * PI / 2.0;
    let steps = per_pi / 2;
    let arc = |k: usize, r: f64| -> Vec<Value> {
        (0..=steps)
            .map(|i| {
                let phi = cut(k) + PI / 2.0 * i as f64 / steps as f64;
                json!([r * phi.cos(), r * phi.sin()])
            })
            .collect()
    };
    let mut bodies = Vec::new();
    let mut segments = serde_json::Map::new();
    let mut boundary = Vec::new();
    let mut contacts = Vec::new();
    let mut refine = Vec::new();
    for (k, size) in sizes.iter().enumerate() {
        let (outer, inner) = (arc(k, 1.0), arc(k, 0.5));
        let mut polygon = outer.clone();
        polygon.extend(inner.iter().rev().cloned());
        let name = format!("s{k}");
        bodies.push(
            json!({"name": name, "zones": [{"name": name, "material": "m", "polygon": polygon}]}),
        );
        segments.insert(
            format!("{name}_outer"),
            json!({"body": name, "path": outer}),
        );
        segments.insert(
            format!("{name}_inner"),
            json!({"body": name, "path": inner}),
        );
        // Radial sides: at the start cut (from inner to outer) and the end cut.
        segments.insert(
            format!("{name}_start"),
            json!({"body": name, "from": inner[0], "to": outer[0]}),
        );
        segments.insert(
            format!("{name}_end"),
            json!({"body": name, "from": outer[steps], "to": inner[steps]}),
        );
        boundary.push(json!({"segment": format!("{name}_outer"), "temperature": 0.0}));
        boundary.push(json!({"segment": format!("{name}_inner"), "temperature": 0.0}));
        contacts.push(json!({"name": format!("cut{k}"), "kind": "bilateral", "coupling": "mortar",
                             "between": [format!("{name}_end"), format!("s{}_start", (k + 1) % 4)]}));
        refine.push(json!({"polygon": polygon, "max_size": size}));
    }
    let largest = sizes.iter().fold(0.0f64, |m, &s| m.max(s));
    json!({
        "version": 1, "name": "annulus, paper example (24)",
        "bodies": bodies, "segments": segments,
        "materials": {"m": material(0.0)},
        "thermal": {"reference_temperature": 0.0},
        "boundary": boundary, "contacts": contacts,
        "mesh": {"max_size": largest, "refine": refine}
    })
}

/// The series solution of (24) (paper part A.6).
fn annulus_series(r: f64, phi: f64) -> f64 {
    (1..=4000usize)
        .map(|k| {
            let n = k as f64;
            let sign = if k.is_multiple_of(2) { 1.0 } else { -1.0 };
            // ((2r)ⁿ + r⁻ⁿ) / (2ⁿ + 1) without overflow.
            let radial = (r.powf(n) + (2.0 * r).powf(-n)) / (1.0 + 2f64.powf(-n));
            2.0 * sign / n * radial * (n * (phi - 1.25 * PI)).sin()
        })
        .sum()
}

/// The data of (24) on the circles: 5π/4 − φ with φ ∈ (π/4, 9π/4), 0 (the mean) at the jump.
fn annulus_data(p: [f64; 2]) -> f64 {
    let mut phi = p[1].atan2(p[0]);
    while phi <= PI / 4.0 - 1e-9 {
        phi += 2.0 * PI;
    }
    if (phi - PI / 4.0).abs() < 1e-9 {
        0.0
    } else {
        1.25 * PI - phi
    }
}

/// Errors of (24) meshed per sector at `sizes`: the largest at the paper's three points
/// (r, π/2), r = 0.6, 0.75, 0.9, the root mean square over those radii at φ = π/2, 3π/4, …, 7π/4
/// (every sector but the jump's), and the number of nodes.
fn annulus_errors(sizes: [f64; 4]) -> (f64, f64, usize) {
    let scene = parse_scene(&annulus(sizes, 128).to_string()).unwrap();
    let (mesh, problem) = heat(&scene);
    let u = solve_with(&mesh, &problem, &scene, |_| 0.0, annulus_data);
    let (mut paper_worst, mut squares, mut count) = (0.0f64, 0.0, 0);
    for (r, paper) in [(0.6, 2.272489), (0.75, 2.246457), (0.9, 2.303868)] {
        let series = annulus_series(r, PI / 2.0);
        assert!((series - paper).abs() < 1e-6, "series {series} vs {paper}");
        paper_worst = paper_worst.max((value_at(&mesh, &u, [0.0, r]) - series).abs());
        for k in 2..=7 {
            let phi = k as f64 * PI / 4.0;
            let p = [r * phi.cos(), r * phi.sin()];
            squares += (value_at(&mesh, &u, p) - annulus_series(r, phi)).powi(2);
            count += 1;
        }
    }
    (
        paper_worst,
        (squares / count as f64).sqrt(),
        mesh.nodes.len(),
    )
}

#[test]
fn annulus_values_and_refining_only_the_subdomain_with_the_jump() {
    let cases = [
        ("uniform 0.1", [0.1; 4]),
        ("jump's sector at 0.025", [0.025, 0.1, 0.1, 0.1]),
        ("points' sector at 0.025", [0.1, 0.025, 0.1, 0.1]),
        ("uniform 0.025", [0.025; 4]),
        ("uniform 0.0125", [0.0125; 4]),
    ];
    let mut rms = Vec::new();
    for (name, sizes) in cases {
        let (paper, mean, nodes) = annulus_errors(sizes);
        println!("annulus, {name}: {nodes} nodes, largest error at the paper's points {paper:.2e}, rms over 18 points {mean:.2e}");
        rms.push((paper, mean));
    }
    assert!(rms[0].0 < 1e-2, "coarse: {:?}", rms[0]);
    assert!(rms[4].0 < 1e-4, "fine: {:?}", rms[4]);
    // The jump's pollution dominates the coarse error: refining its sector alone removes most of
    // it, at the paper's points (which stay in a coarse sector) more than refining their own
    // sector does.
    assert!(rms[1].0 < 0.1 * rms[0].0, "{rms:?}");
    assert!(rms[1].0 < rms[2].0, "{rms:?}");
    assert!(rms[1].1 < 0.35 * rms[0].1, "{rms:?}");
}

/// Example (23) on an L-shaped Ω = (0,2)×(0,1) ∪ (0,1)×(1,2): −Δu = 30, u = 0 on Γ0 (y = 0),
/// u = 1 on Γ1 (y = 2), insulated elsewhere. `subdomains`: as three bodies A = (0,1)², B to the
/// right, C on top, meshed at 0.1, 0.04 and 0.06 and glued by mortar ties (the corner (1, 1) is a
/// cross point of both ties); otherwise one body meshed at `h`.
fn example_23(subdomains: bool, h: f64) -> Value {
    let boundary = json!([
        {"segment": "gamma0", "temperature": 0.0},
        {"segment": "gamma1", "temperature": 1.0}
    ]);
    let materials = json!({"m": material(30.0)});
    let thermal = json!({"reference_temperature": 0.0});
    if !subdomains {
        return json!({
            "version": 1, "name": "example (23), conforming",
            "bodies": [{"name": "l", "zones": [{"name": "l", "material": "m",
                        "polygon": [[0,0],[2,0],[2,1],[1,1],[1,2],[0,2]]}]}],
            "segments": {
                "gamma0": {"body": "l", "from": [0,0], "to": [2,0]},
                "gamma1": {"body": "l", "from": [1,2], "to": [0,2]}
            },
            "materials": materials, "thermal": thermal, "boundary": boundary,
            "mesh": {"max_size": h}
        });
    }
    json!({
        "version": 1, "name": "example (23), mortar subdomains",
        "bodies": [
            {"name": "a", "zones": [{"name": "a", "material": "m", "polygon": [[0,0],[1,0],[1,1],[0,1]]}]},
            {"name": "b", "zones": [{"name": "b", "material": "m", "polygon": [[1,0],[2,0],[2,1],[1,1]]}]},
            {"name": "c", "zones": [{"name": "c", "material": "m", "polygon": [[0,1],[1,1],[1,2],[0,2]]}]}
        ],
        "segments": {
            "gamma0": {"body": "a", "from": [0,0], "to": [1,0]},
            "gamma0_b": {"body": "b", "from": [1,0], "to": [2,0]},
            "gamma1": {"body": "c", "from": [1,2], "to": [0,2]},
            "a_right": {"body": "a", "from": [1,0], "to": [1,1]},
            "a_top": {"body": "a", "from": [1,1], "to": [0,1]},
            "b_left": {"body": "b", "from": [1,1], "to": [1,0]},
            "c_bottom": {"body": "c", "from": [0,1], "to": [1,1]}
        },
        "materials": materials, "thermal": thermal,
        "boundary": [
            {"segment": "gamma0", "temperature": 0.0},
            {"segment": "gamma0_b", "temperature": 0.0},
            {"segment": "gamma1", "temperature": 1.0}
        ],
        "contacts": [
            {"name": "ab", "between": ["b_left", "a_right"], "kind": "bilateral", "coupling": "mortar"},
            {"name": "ac", "between": ["c_bottom", "a_top"], "kind": "bilateral", "coupling": "mortar"}
        ],
        "mesh": {"max_size": 0.1, "refine": [
            {"polygon": [[1,0],[2,0],[2,1],[1,1]], "max_size": 0.04},
            {"polygon": [[0,1],[1,1],[1,2],[0,2]], "max_size": 0.06}
        ]}
    })
}

#[test]
fn example_23_matches_a_fine_conforming_solution() {
    let solve_23 = |subdomains: bool, h: f64| {
        let scene = parse_scene(&example_23(subdomains, h).to_string()).unwrap();
        let (mesh, problem) = heat(&scene);
        let u = solve(&scene, &problem);
        (mesh, u)
    };
    let (fine, reference) = solve_23(false, 0.01);
    let (coarse, conforming) = solve_23(false, 0.1);
    let (mortar, u) = solve_23(true, 0.0);
    let (ns, nm) = interface_nodes(&mortar);
    // Sample points off the interfaces, the re-entrant corner's neighbourhood included.
    let points: Vec<[f64; 2]> = (1..20)
        .flat_map(|i| (1..20).map(move |j| [0.1 * i as f64 + 0.013, 0.1 * j as f64 + 0.007]))
        .filter(|p| p[0] < 1.0 || p[1] < 1.0)
        .collect();
    let deviation = |mesh: &Mesh, v: &[f64]| {
        points.iter().fold(0.0f64, |m, &p| {
            m.max((value_at(mesh, v, p) - value_at(&fine, &reference, p)).abs())
        })
    };
    let (dm, dc) = (deviation(&mortar, &u), deviation(&coarse, &conforming));
    let peak = reference.iter().fold(0.0f64, |m, &v| m.max(v));
    let least = u.iter().fold(f64::INFINITY, |m, &v| m.min(v));
    println!(
        "example (23): max u {peak:.4}; mortar ({} nodes, ab interface {ns} : {nm}) vs fine conforming ({} nodes): {dm:.2e}; conforming at 0.1 ({} nodes): {dc:.2e}; min u {least:.1e}",
        mortar.nodes.len(),
        fine.nodes.len(),
        coarse.nodes.len()
    );
    // −Δu = 30 > 0: the minimum 0 is on Γ0 (paper part A.6 check 6).
    assert!(least >= -1e-12, "min u = {least:e}");
    // No worse than the conforming mesh of the coarsest subdomain's size.
    assert!(dm <= dc, "mortar {dm:e} vs conforming {dc:e}");
    assert!(dm < 1e-2 * peak, "mortar off by {dm:e} of {peak}");
}
