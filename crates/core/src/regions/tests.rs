//! Tests of the criteria weights: exact means of linear fields, normals, errors.

use super::*;
use crate::mesh::generate;
use crate::mesh::tests::{block_on_base, scene, tunnel};

/// Mean of a P1 field: Σ w_i f_i.
fn mean_p1(weights: &[(usize, f64)], field: &[f64]) -> f64 {
    weights.iter().map(|&(i, w)| w * field[i]).sum()
}

/// Mean of an element-constant field: Σ w_t f_t.
fn mean_p0(weights: &[(usize, f64)], field: &[f64]) -> f64 {
    mean_p1(weights, field)
}

fn linear(mesh: &Mesh) -> Vec<f64> {
    mesh.nodes
        .iter()
        .map(|p| 2.0 + 3.0 * p[0] - 5.0 * p[1])
        .collect()
}

fn sum(w: &[(usize, f64)]) -> f64 {
    w.iter().map(|x| x.1).sum()
}

/// The design example with an extra non-convex region and a second boundary piece.
fn example() -> (Scene, Mesh) {
    let mut json = block_on_base();
    json["criteria"] = serde_json::json!({
        "regions": [
            { "name": "G1", "polygon": [[0.9, 0.5], [1.1, 0.5], [1.1, 0.6], [0.9, 0.6]],
              "normal_at": [1.0, 0.5] },
            { "name": "L", "polygon": [[0.613, 0.137], [0.977, 0.137], [0.977, 0.2311],
                                       [0.7011, 0.2311], [0.7011, 0.4123], [0.613, 0.4123]],
              "normal": [0, 2] },
            { "name": "square", "polygon": [[1.2037, 0.6113], [1.3311, 0.6113], [1.3311, 0.7391], [1.2037, 0.7391]] }
        ],
        "boundary_pieces": [
            { "name": "G1'", "segment": "top", "from": [1.1, 1.0], "to": [0.9, 1.0] },
            { "name": "part of bottom", "segment": "bottom", "from": [0.3141, 0.0], "to": [1.7777, 0.0] }
        ]
    });
    let sc = scene(json);
    let mesh = generate(&sc).unwrap();
    (sc, mesh)
}

#[test]
fn area_means_of_linear_fields_are_exact() {
    let (sc, mesh) = example();
    let g = build(&sc, &mesh).unwrap();
    let f = linear(&mesh);
    let exact = |c: [f64; 2]| 2.0 + 3.0 * c[0] - 5.0 * c[1];
    // Centroids: the squares' centres; the L-shape from its moments.
    let l = &sc.criteria.regions[1].polygon;
    let (a, m) = ring_moments(l);
    let centroids = [
        [1.0, 0.55],
        [m[0] / a, m[1] / a],
        [(1.2037 + 1.3311) / 2.0, (0.6113 + 0.7391) / 2.0],
    ];
    for (r, c) in g.regions.iter().zip(centroids) {
        assert!((sum(&r.node_weights) - 1.0).abs() < 1e-12, "{}", r.name);
        assert!((sum(&r.element_weights) - 1.0).abs() < 1e-12, "{}", r.name);
        let err = (mean_p1(&r.node_weights, &f) - exact(c)).abs();
        println!(
            "region {}: {} nodes, {} triangles, error {err:.1e}",
            r.name,
            r.node_weights.len(),
            r.element_weights.len()
        );
        assert!(err < 1e-12, "{}: {err}", r.name);
        // P0: the element means of the linear field are its values at triangle centroids only
        // for whole triangles, so check a constant field instead.
        let ones = vec![1.0; mesh.triangles.len()];
        assert!((mean_p0(&r.element_weights, &ones) - 1.0).abs() < 1e-12);
    }
    assert_eq!(
        (g.regions[0].body, g.regions[1].body, g.regions[2].body),
        (1, 0, 1)
    );
    assert!((g.regions[1].area - a).abs() < 1e-12);
    assert!(
        g.regions[0].element_weights.len() > 4,
        "the region cuts several triangles"
    );
}

#[test]
fn normals_and_contact_adjacency() {
    let (sc, mesh) = example();
    let g = build(&sc, &mesh).unwrap();
    let n0 = g.regions[0].normal.unwrap();
    assert!(
        (n0[0]).abs() < 1e-12 && (n0[1] + 1.0).abs() < 1e-12,
        "{n0:?}"
    );
    assert_eq!(g.regions[1].normal, Some([0.0, 1.0]));
    assert_eq!(g.regions[2].normal, None);
    assert_eq!(g.regions[0].contact, Some(0));
    assert_eq!(g.regions[0].contact_distance, 0.0);
    assert_eq!(g.regions[1].contact, Some(0));
    assert!(g.regions[1].contact_distance > 0.08);
}

#[test]
fn boundary_piece_means_are_exact() {
    let (sc, mesh) = example();
    let g = build(&sc, &mesh).unwrap();
    let f = linear(&mesh);
    let exact = |x: f64, y: f64| 2.0 + 3.0 * x - 5.0 * y;
    let top = &g.pieces[0];
    assert!((top.length - 0.2).abs() < 1e-12);
    assert!((mean_p1(&top.node_weights, &f) - exact(1.0, 1.0)).abs() < 1e-12);
    assert!((top.normal[1] - 1.0).abs() < 1e-12);
    let bottom = &g.pieces[1];
    assert!((sum(&bottom.node_weights) - 1.0).abs() < 1e-12);
    // A field that is not linear along the piece but linear per edge is integrated exactly too:
    // the endpoints cut edges, so compare with the exact mean of x.
    let mid = 0.5 * (0.3141 + 1.7777);
    assert!((mean_p1(&bottom.node_weights, &f) - exact(mid, 0.0)).abs() < 1e-12);
    assert!((bottom.normal[1] + 1.0).abs() < 1e-12);
}

/// A 4 m × 1 m plate meshed at `h`, with the top side as two segments: `top_cw` drawn against
/// the body's orientation (its mesh edges point backwards along it, like the dam's crest) and
/// `top_ccw` drawn with it; `pieces` are boundary pieces on them.
fn plate(h: f64, pieces: serde_json::Value) -> (Scene, Mesh) {
    let sc = scene(serde_json::json!({
        "version": 1,
        "bodies": [{ "name": "plate", "zones": [{ "name": "plate", "material": "m",
            "polygon": [[0, 0], [4, 0], [4, 1], [0, 1]] }] }],
        "segments": {
            "top_cw":  { "body": "plate", "from": [0, 1], "to": [4, 1] },
            "top_ccw": { "body": "plate", "from": [4, 1], "to": [0, 1] }
        },
        "materials": { "m": { "E": 1.0e10, "nu": 0.25 } },
        "mesh": { "max_size": h },
        "criteria": { "boundary_pieces": pieces }
    }));
    let mesh = generate(&sc).unwrap();
    (sc, mesh)
}

/// The nodes of the plate's top side (y = 1) sorted by x.
fn top_nodes(mesh: &Mesh) -> Vec<usize> {
    let mut top: Vec<usize> = (0..mesh.nodes.len())
        .filter(|&n| mesh.nodes[n][1] == 1.0)
        .collect();
    top.sort_by(|&a, &b| mesh.nodes[a][0].total_cmp(&mesh.nodes[b][0]));
    top
}

/// ∫ over x ∈ [x0, x1] of the piecewise linear interpolant of `f` between the top nodes, by the
/// trapezoid rule on each clipped edge (exact for a function linear on each piece).
fn top_integral(mesh: &Mesh, f: &[f64], x0: f64, x1: f64) -> f64 {
    let top = top_nodes(mesh);
    top.windows(2)
        .map(|e| {
            let ([xa, _], [xb, _]) = (mesh.nodes[e[0]], mesh.nodes[e[1]]);
            let at = |x: f64| f[e[0]] + (f[e[1]] - f[e[0]]) * (x - xa) / (xb - xa);
            let (u0, u1) = (x0.max(xa), x1.min(xb));
            if u1 > u0 {
                0.5 * (u1 - u0) * (at(u0) + at(u1))
            } else {
                0.0
            }
        })
        .sum()
}

/// A field that is not linear: its P1 trace is linear only edge by edge.
fn curved(mesh: &Mesh) -> Vec<f64> {
    mesh.nodes
        .iter()
        .map(|p| p[0] * p[0] + 0.5 * p[1])
        .collect()
}

/// A piece lying strictly inside one boundary edge is measured on that edge: its mean is the
/// mean of the edge's linear interpolation over [from, to], on a segment drawn either way.
#[test]
fn a_piece_inside_one_edge_takes_the_mean_of_the_edge_interpolation() {
    let (sc, mesh) = plate(
        2.5,
        serde_json::json!([
            { "name": "cw", "segment": "top_cw", "from": [1.1, 1], "to": [1.3, 1] },
            { "name": "ccw", "segment": "top_ccw", "from": [1.3, 1], "to": [1.1, 1] }
        ]),
    );
    let top = top_nodes(&mesh);
    let (a, b) = top
        .windows(2)
        .map(|e| (e[0], e[1]))
        .find(|&(a, b)| mesh.nodes[a][0] < 1.1 && mesh.nodes[b][0] > 1.3)
        .expect("one edge holds the piece");
    let g = build(&sc, &mesh).unwrap();
    let f = curved(&mesh);
    let t_mid = (1.2 - mesh.nodes[a][0]) / (mesh.nodes[b][0] - mesh.nodes[a][0]);
    let exact = f[a] * (1.0 - t_mid) + f[b] * t_mid;
    for piece in &g.pieces {
        assert!((piece.length - 0.2).abs() < 1e-14, "{}", piece.length);
        let mut nodes: Vec<usize> = piece.node_weights.iter().map(|w| w.0).collect();
        nodes.sort_unstable();
        assert_eq!(nodes, [a.min(b), a.max(b)], "{}", piece.name);
        let mean = mean_p1(&piece.node_weights, &f);
        assert!(
            (mean - exact).abs() < 1e-14 * exact,
            "{}: {mean} vs {exact}",
            piece.name
        );
        assert!((piece.normal[1] - 1.0).abs() < 1e-12);
    }
}

/// A piece over parts of several edges integrates the piecewise linear trace exactly, clipped
/// edges included, whichever way its segment is drawn; the whole side is its full length.
#[test]
fn a_piece_over_several_edges_integrates_the_trace_exactly() {
    let (sc, mesh) = plate(
        0.3,
        serde_json::json!([
            { "name": "cw", "segment": "top_cw", "from": [0.37, 1], "to": [2.91, 1] },
            { "name": "ccw", "segment": "top_ccw", "from": [2.91, 1], "to": [0.37, 1] },
            { "name": "whole cw", "segment": "top_cw" },
            { "name": "whole ccw", "segment": "top_ccw" }
        ]),
    );
    let g = build(&sc, &mesh).unwrap();
    let f = curved(&mesh);
    for (piece, (x0, x1)) in
        g.pieces
            .iter()
            .zip([(0.37, 2.91), (0.37, 2.91), (0.0, 4.0), (0.0, 4.0)])
    {
        assert!(
            (piece.length - (x1 - x0)).abs() < 1e-12,
            "{}: {}",
            piece.name,
            piece.length
        );
        assert!(piece.node_weights.len() > 8, "{}", piece.name);
        assert!((sum(&piece.node_weights) - 1.0).abs() < 1e-12);
        let exact = top_integral(&mesh, &f, x0, x1) / (x1 - x0);
        let mean = mean_p1(&piece.node_weights, &f);
        assert!(
            (mean - exact).abs() < 1e-13 * exact,
            "{}: {mean} vs {exact}",
            piece.name
        );
    }
}

/// The mean of a linear field over a piece is its value at the piece's midpoint on every mesh,
/// from pieces inside one edge to pieces over many.
#[test]
fn piece_means_of_a_linear_field_do_not_depend_on_the_mesh() {
    let pieces = serde_json::json!([
        { "name": "short cw", "segment": "top_cw", "from": [3.05, 1], "to": [3.15, 1] },
        { "name": "long ccw", "segment": "top_ccw", "from": [3.9, 1], "to": [0.2, 1] }
    ]);
    for h in [4.0, 1.7, 0.6, 0.23, 0.09] {
        let (sc, mesh) = plate(h, pieces.clone());
        let g = build(&sc, &mesh).unwrap();
        let f = linear(&mesh);
        for (piece, mid) in g.pieces.iter().zip([3.1, 2.05]) {
            let exact = 2.0 + 3.0 * mid - 5.0;
            let mean = mean_p1(&piece.node_weights, &f);
            assert!(
                (mean - exact).abs() < 1e-12,
                "h = {h}, {}: {mean} vs {exact}",
                piece.name
            );
        }
    }
}

#[test]
fn tunnel_normal_points_into_the_hole() {
    let mut json = tunnel(0.3);
    json["criteria"] = serde_json::json!({
        "regions": [{ "name": "crown", "polygon": [[-0.3, 1.0], [0.3, 1.0], [0.3, 1.6], [-0.3, 1.6]],
                      "normal_at": [0.0, 1.0] }],
        "boundary_pieces": [{ "name": "rim", "segment": "rim" }]
    });
    let sc = scene(json);
    let mesh = generate(&sc).unwrap();
    let g = build(&sc, &mesh).unwrap();
    let n = g.regions[0].normal.unwrap();
    assert!(n[1] < -0.99, "{n:?}");
    let rim = &g.pieces[0];
    let perimeter = 32.0 * 2.0 * (std::f64::consts::PI / 32.0).sin();
    assert!((rim.length - perimeter).abs() < 1e-12);
    // The default X_r is the midpoint of the whole rim walk; its normal points to the centre.
    let x = rim.normal;
    assert!((x[0].hypot(x[1]) - 1.0).abs() < 1e-12);
    assert_eq!(g.regions[0].contact, None);
}

#[test]
fn criteria_errors_name_the_field() {
    let cases = [
        (
            serde_json::json!({ "regions": [{ "name": "out", "polygon": [[5, 5], [6, 5], [6, 6]] }] }),
            "criteria.regions[0].polygon",
        ),
        (
            serde_json::json!({ "regions": [{ "name": "few", "polygon": [[0.1, 0.1], [0.2, 0.1]] }] }),
            "criteria.regions[0].polygon",
        ),
        (
            serde_json::json!({ "regions": [{ "name": "far", "polygon": [[0.9, 0.1], [1.1, 0.1], [1.0, 0.2]],
                                            "normal_at": [1.0, 3.0] }] }),
            "criteria.regions[0].normal_at",
        ),
        (
            serde_json::json!({ "regions": [{ "name": "zero", "polygon": [[0.9, 0.1], [1.1, 0.1], [1.0, 0.2]],
                                            "normal": [0, 0] }] }),
            "criteria.regions[0].normal",
        ),
        (
            serde_json::json!({ "boundary_pieces": [{ "name": "x", "segment": "nope" }] }),
            "criteria.boundary_pieces[0].segment",
        ),
        (
            serde_json::json!({ "boundary_pieces": [{ "name": "x", "segment": "top", "from": [1.0, 1.0], "to": [1.0, 1.0] }] }),
            "criteria.boundary_pieces[0]",
        ),
        (
            serde_json::json!({ "boundary_pieces": [{ "name": "x", "segment": "top", "from": [1.0, 3.0] }] }),
            "criteria.boundary_pieces[0].from",
        ),
    ];
    let sc0 = scene(block_on_base());
    let mesh = generate(&sc0).unwrap();
    for (criteria, path) in cases {
        let mut json = block_on_base();
        json["criteria"] = criteria.clone();
        let e = build(&scene(json), &mesh).unwrap_err();
        assert_eq!(e.path, path, "{criteria}: {e}");
    }
}
