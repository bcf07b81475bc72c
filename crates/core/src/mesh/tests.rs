//! Tests of mesh generation, node splitting, segments, contacts and the Gmsh import.

use std::collections::HashMap;

use super::geom::{dist, point_in_ring, signed_area};
use super::gmsh::import_gmsh;
use super::*;
use crate::scene::{Scene, SceneError};

pub(crate) fn scene(json: serde_json::Value) -> Scene {
    serde_json::from_value(json).expect("test scene parses")
}

/// The design §5.2 example (block on a base), geometry and mesh part.
pub(crate) fn block_on_base() -> serde_json::Value {
    serde_json::json!({
        "version": 1,
        "bodies": [
            { "name": "base", "zones": [{ "name": "base", "material": "rock",
                "polygon": [[0, 0], [2, 0], [2, 0.5], [0, 0.5]] }] },
            { "name": "block", "zones": [{ "name": "block", "material": "rock",
                "polygon": [[0.5, 0.5], [1.5, 0.5], [1.5, 1.0], [0.5, 1.0]] }] }
        ],
        "segments": {
            "bottom":        { "body": "base",  "from": [0, 0],     "to": [2, 0] },
            "top":           { "body": "block", "from": [1.5, 1.0], "to": [0.5, 1.0] },
            "push":          { "body": "block", "from": [0.5, 1.0], "to": [0.5, 0.5] },
            "base_contact":  { "body": "base",  "from": [0.5, 0.5], "to": [1.5, 0.5] },
            "block_contact": { "body": "block", "from": [0.5, 0.5], "to": [1.5, 0.5] }
        },
        "materials": { "rock": { "E": 1.0e10, "nu": 0.25 } },
        "contacts": [{ "name": "joint", "between": ["block_contact", "base_contact"] }],
        "mesh": { "max_size": 0.05, "refine": [{ "segments": ["block_contact"], "max_size": 0.01 }] }
    })
}

fn edge_count(mesh: &Mesh) -> HashMap<[usize; 2], usize> {
    let mut count = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry([a.min(b), a.max(b)]).or_insert(0) += 1;
        }
    }
    count
}

fn centroid(mesh: &Mesh, t: usize) -> [f64; 2] {
    let [a, b, c] = mesh.triangles[t].map(|i| mesh.nodes[i]);
    [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0]
}

/// Checks shared by all generated meshes: CCW, zones, node bodies, min angle.
fn check_mesh(mesh: &Mesh, min_angle: f64) {
    assert_eq!(mesh.triangles.len(), mesh.triangle_zone.len());
    assert_eq!(mesh.nodes.len(), mesh.node_body.len());
    let mut used = vec![false; mesh.nodes.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        assert!(mesh.triangle_area(t) > 0.0, "triangle {t} not CCW");
        let body = mesh.zones[mesh.triangle_zone[t]].body;
        for &n in tri {
            assert_eq!(mesh.node_body[n], body);
            used[n] = true;
        }
    }
    assert!(used.iter().all(|&u| u), "unused nodes");
    let s = stats(mesh);
    assert!(
        s.min_angle_deg >= min_angle - 1.0,
        "min angle {}",
        s.min_angle_deg
    );
}

#[test]
fn block_on_base_contact_pairs_match() {
    let sc = scene(block_on_base());
    let mesh = generate(&sc).unwrap();
    check_mesh(&mesh, 28.0);
    assert_eq!(mesh.bodies, ["base", "block"]);
    assert_eq!(mesh.zones.len(), 2);
    let names: Vec<&str> = mesh.segments.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(
        names,
        ["base_contact", "block_contact", "bottom", "push", "top"]
    );
    let c = &mesh.contacts[0];
    let k = &mesh.segments[c.segment_k];
    assert_eq!(k.name, "block_contact");
    // Every block node on the contact line is paired.
    let on_line = (0..mesh.nodes.len())
        .filter(|&n| mesh.node_body[n] == 1)
        .filter(|&n| {
            let p = mesh.nodes[n];
            p[1] == 0.5 && (0.5..=1.5).contains(&p[0])
        })
        .count();
    assert_eq!(c.pairs.len(), on_line);
    assert!(c.pairs.len() >= 101, "{} pairs", c.pairs.len());
    for &[a, b] in &c.pairs {
        assert_eq!(mesh.nodes[a], mesh.nodes[b]);
        assert_eq!((mesh.node_body[a], mesh.node_body[b]), (1, 0));
    }
    assert_eq!(c.fraction[0], 0.0);
    assert_eq!(*c.fraction.last().unwrap(), 1.0);
    assert!(c.fraction.windows(2).all(|w| w[0] < w[1]));
    // Segment edges have the body on the left: outward normal of the block's bottom is −y.
    for &[a, b] in &k.edges {
        let (pa, pb) = (mesh.nodes[a], mesh.nodes[b]);
        assert!(pb[0] - pa[0] > 0.0, "block bottom edge must run in +x");
    }
    let bottom = &mesh.segments[mesh.segment_index("bottom").unwrap()];
    let len: f64 = bottom
        .edges
        .iter()
        .map(|&[a, b]| dist(mesh.nodes[a], mesh.nodes[b]))
        .sum();
    assert!((len - 2.0).abs() < 1e-12);
    assert_eq!(bottom.nodes.len(), bottom.edges.len() + 1);
    assert!(bottom
        .nodes
        .windows(2)
        .all(|w| mesh.nodes[w[0]][0] < mesh.nodes[w[1]][0]));
}

#[test]
fn generation_is_deterministic() {
    let sc = scene(block_on_base());
    assert_eq!(generate(&sc).unwrap(), generate(&sc).unwrap());
}

fn regular_polygon(c: [f64; 2], r: f64, n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            [c[0] + r * a.cos(), c[1] + r * a.sin()]
        })
        .collect()
}

pub(crate) fn tunnel(h: f64) -> serde_json::Value {
    serde_json::json!({
        "version": 1,
        "bodies": [{ "name": "rock", "zones": [{ "name": "rock", "material": "granite",
            "polygon": [[-5, -5], [5, -5], [5, 5], [-5, 5]],
            "holes": [regular_polygon([0.0, 0.0], 1.0, 32)] }] }],
        "segments": { "rim": { "body": "rock", "path": regular_polygon([0.0, 0.0], 1.0, 32), "closed": true } },
        "materials": { "granite": { "E": 5.0e10, "nu": 0.2 } },
        "mesh": { "max_size": h }
    })
}

#[test]
fn square_with_hole_has_exact_area_and_no_triangle_in_the_hole() {
    let mesh = generate(&scene(tunnel(0.3))).unwrap();
    check_mesh(&mesh, 28.0);
    let hole = regular_polygon([0.0, 0.0], 1.0, 32);
    let area: f64 = (0..mesh.triangles.len())
        .map(|t| mesh.triangle_area(t))
        .sum();
    let exact = 100.0 - signed_area(&hole);
    assert!((area - exact).abs() < 1e-12 * exact, "{area} vs {exact}");
    assert!((0..mesh.triangles.len()).all(|t| !point_in_ring(centroid(&mesh, t), &hole)));
    let rim = &mesh.segments[0];
    assert_eq!(rim.nodes.len(), rim.edges.len(), "closed rim");
    // The rim's outward normal (body on the left) points into the hole.
    for &[a, b] in &rim.edges {
        let (pa, pb) = (mesh.nodes[a], mesh.nodes[b]);
        let n = [pb[1] - pa[1], -(pb[0] - pa[0])];
        let m = [(pa[0] + pb[0]) / 2.0, (pa[1] + pb[1]) / 2.0];
        assert!(n[0] * m[0] + n[1] * m[1] < 0.0);
    }
    assert!(stats(&mesh).max_edge <= 0.3 * (1.0 + 1e-9));
}

#[test]
fn two_zones_sharing_an_edge_are_conforming() {
    let sc = scene(serde_json::json!({
        "version": 1,
        "bodies": [{ "name": "b", "zones": [
            { "name": "left", "material": "soft", "polygon": [[0, 0], [1, 0], [1, 1], [0, 1]] },
            { "name": "right", "material": "hard", "polygon": [[1, 0], [3, 0], [3, 1], [1, 1]] }
        ] }],
        "materials": { "soft": { "E": 1.0, "nu": 0.3 }, "hard": { "E": 2.0, "nu": 0.3 } },
        "mesh": { "max_size": 0.1 }
    }));
    let mesh = generate(&sc).unwrap();
    check_mesh(&mesh, 28.0);
    // Materials in name order: hard = 0, soft = 1.
    assert_eq!((mesh.zones[0].material, mesh.zones[1].material), (1, 0));
    let mut zone_area = [0.0; 2];
    for t in 0..mesh.triangles.len() {
        zone_area[mesh.triangle_zone[t]] += mesh.triangle_area(t);
    }
    assert!((zone_area[0] - 1.0).abs() < 1e-12 && (zone_area[1] - 2.0).abs() < 1e-12);
    // Conforming: every edge is in one (outer boundary) or two triangles, and the edges in one
    // triangle make up exactly the outer boundary (length 8).
    let count = edge_count(&mesh);
    assert!(count.values().all(|&c| c == 1 || c == 2));
    let boundary: f64 = count
        .iter()
        .filter(|(_, &c)| c == 1)
        .map(|(e, _)| dist(mesh.nodes[e[0]], mesh.nodes[e[1]]))
        .sum();
    assert!((boundary - 8.0).abs() < 1e-12, "{boundary}");
}

#[test]
fn local_refinement_along_a_segment() {
    let sc = scene(block_on_base());
    let mesh = generate(&sc).unwrap();
    let k = &mesh.segments[mesh.segment_index("block_contact").unwrap()];
    let on: std::collections::HashSet<usize> = k.nodes.iter().copied().collect();
    let (mut near, mut far) = (0.0_f64, 0.0_f64);
    for t in &mesh.triangles {
        let longest = (0..3)
            .map(|i| dist(mesh.nodes[t[i]], mesh.nodes[t[(i + 1) % 3]]))
            .fold(0.0, f64::max);
        if t.iter().any(|n| on.contains(n)) {
            near = near.max(longest);
        } else if t.iter().all(|&n| mesh.nodes[n][1] < 0.2) {
            far = far.max(longest);
        }
    }
    println!("longest edge touching the refined segment {near:.4}, far away {far:.4}");
    assert!(near <= 1.2 * 0.01, "{near}");
    assert!(far > 0.03, "{far}");
}

fn error_of(json: serde_json::Value) -> SceneError {
    generate(&scene(json)).expect_err("scene must be rejected")
}

fn with(mut base: serde_json::Value, pointer: &str, value: serde_json::Value) -> serde_json::Value {
    *base.pointer_mut(pointer).expect("pointer exists") = value;
    base
}

#[test]
fn local_refinement_inside_a_polygon() {
    let mut json = block_on_base();
    json["mesh"]["refine"] = serde_json::json!([
        { "polygon": [[0.2, 0.1], [0.4, 0.1], [0.4, 0.3], [0.2, 0.3]], "max_size": 0.008 }
    ]);
    let mesh = generate(&scene(json)).unwrap();
    check_mesh(&mesh, 28.0);
    let (mut inside, mut outside) = (0.0_f64, 0.0_f64);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let c = centroid(&mesh, t);
        let longest = (0..3)
            .map(|i| dist(mesh.nodes[tri[i]], mesh.nodes[tri[(i + 1) % 3]]))
            .fold(0.0, f64::max);
        if (0.2..=0.4).contains(&c[0]) && (0.1..=0.3).contains(&c[1]) {
            inside = inside.max(longest);
        } else if c[0] > 1.0 {
            outside = outside.max(longest);
        }
    }
    println!("longest edge inside the refined polygon {inside:.4}, far away {outside:.4}");
    assert!(inside <= 0.008 * (1.0 + 1e-9), "{inside}");
    assert!(outside > 0.03);
}

#[test]
fn gmsh_file_named_in_the_scene_is_read() {
    let file = std::env::temp_dir().join(format!("wsm-two-squares-{}.msh", std::process::id()));
    std::fs::write(&file, TWO_SQUARES_MSH).unwrap();
    let mut sc = two_squares_scene();
    sc.mesh.gmsh_file = Some(file.to_string_lossy().into_owned());
    let mesh = generate(&sc);
    std::fs::remove_file(&file).unwrap();
    assert_eq!(mesh.unwrap().triangles.len(), 4);
    sc.mesh.gmsh_file = Some("/nonexistent/wsm.msh".into());
    assert_eq!(generate(&sc).unwrap_err().path, "mesh.gmsh_file");
}

#[test]
fn bad_geometry_is_rejected_with_its_path() {
    let base = block_on_base();
    let cases = [
        (
            "/bodies/1/zones/0/polygon",
            serde_json::json!([[0.5, 0.5], [1.5, 0.5]]),
            "bodies[1].zones[0].polygon",
        ),
        (
            "/bodies/1/zones/0/polygon",
            serde_json::json!([[0.5, 0.5], [1.5, 0.5], [2.5, 0.5]]),
            "bodies[1].zones[0].polygon",
        ),
        (
            "/bodies/1/zones/0/polygon",
            serde_json::json!([[0.5, 0.5], [1.5, 0.5], [0.5, 1.0], [1.5, 1.0]]),
            "bodies[1].zones[0].polygon",
        ),
        (
            "/bodies/1/zones/0/polygon",
            serde_json::json!([[0.5, 0.4], [1.5, 0.4], [1.5, 1.0], [0.5, 1.0]]),
            "bodies[1].zones[0]",
        ),
        ("/mesh/max_size", serde_json::json!(0.0), "mesh.max_size"),
        ("/mesh/max_size", serde_json::json!(1e-5), "mesh.max_size"),
        (
            "/mesh/refine/0/segments/0",
            serde_json::json!("nope"),
            "mesh.refine[0].segments[0]",
        ),
        (
            "/mesh/refine/0/max_size",
            serde_json::json!(-1.0),
            "mesh.refine[0].max_size",
        ),
        (
            "/segments/top/from",
            serde_json::json!([1.5, 1.2]),
            "segments.top",
        ),
        (
            "/segments/push/body",
            serde_json::json!("base"),
            "segments.push",
        ),
        (
            "/contacts/0/between/1",
            serde_json::json!("top"),
            "contacts[0].between",
        ),
        (
            "/contacts/0/between/1",
            serde_json::json!("push"),
            "contacts[0].between",
        ),
        (
            "/bodies/1/zones/0/material",
            serde_json::json!("cheese"),
            "bodies[1].zones[0].material",
        ),
    ];
    for (pointer, value, path) in cases {
        let e = error_of(with(base.clone(), pointer, value.clone()));
        assert_eq!(e.path, path, "{pointer} = {value}: {e}");
    }
    // A nested zone without a matching hole overlaps its host.
    let mut nested = base.clone();
    nested["bodies"][0]["zones"].as_array_mut().unwrap().push(serde_json::json!(
        { "name": "inclusion", "material": "rock", "polygon": [[0.1, 0.1], [0.3, 0.1], [0.3, 0.3]] }));
    assert_eq!(error_of(nested).path, "bodies[0].zones[1]");
    // Segments whose extents differ cannot form a contact.
    let shorter = with(
        base.clone(),
        "/segments/base_contact/to",
        serde_json::json!([1.0, 0.5]),
    );
    assert_eq!(error_of(shorter).path, "contacts[0].between");
    let mut hole_outside = base.clone();
    hole_outside["bodies"][0]["zones"][0]["holes"] =
        serde_json::json!([[[3, 0.1], [3.2, 0.1], [3.2, 0.2]]]);
    assert_eq!(error_of(hole_outside).path, "bodies[0].zones[0].holes[0]");
}

#[test]
fn non_finite_coordinates_are_rejected() {
    let mut sc = scene(block_on_base());
    sc.bodies[1].zones[0].polygon[2][0] = f64::NAN;
    assert_eq!(
        generate(&sc).unwrap_err().path,
        "bodies[1].zones[0].polygon"
    );
}

#[test]
fn timing_of_a_large_mesh() {
    let t0 = std::time::Instant::now();
    let mesh = generate(&scene(tunnel(0.07))).unwrap();
    let s = stats(&mesh);
    println!(
        "tunnel mesh: {} nodes, {} triangles in {:.2} s; min angle {:.1}°, max aspect {:.2}, edges {:.4}..{:.4}",
        s.nodes,
        s.triangles,
        t0.elapsed().as_secs_f64(),
        s.min_angle_deg,
        s.max_aspect_ratio,
        s.min_edge,
        s.max_edge
    );
    assert!(s.triangles > 50_000);
    assert!(s.min_angle_deg >= 27.0);
}

/// Two unit squares side by side, sharing the edge x = 1 (nodes 2 and 5), one body each.
const TWO_SQUARES_MSH: &str = r#"$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
5
1 10 "left_right"
1 11 "right_left"
1 12 "ground"
2 1 "left zone"
2 2 "right"
$EndPhysicalNames
$Entities
0 3 2 0
1 1 0 0 1 1 0 1 10 0
2 1 0 0 1 1 0 1 11 0
3 0 0 0 2 0 0 1 12 0
1 0 0 0 1 1 0 1 1 0
2 1 0 0 2 1 0 1 2 0
$EndEntities
$Nodes
1 6 1 6
2 1 0 6
1
2
3
4
5
6
0 0 0
1 0 0
2 0 0
0 1 0
1 1 0
2 1 0
$EndNodes
$Elements
5 9 1 9
2 1 2 2
1 1 2 5
2 1 5 4
2 2 2 2
3 2 3 6
4 2 6 5
1 1 1 1
5 2 5
1 2 1 1
6 5 2
1 3 1 1
7 1 2
$EndElements
"#;

fn two_squares_scene() -> Scene {
    scene(serde_json::json!({
        "version": 1,
        "bodies": [
            { "name": "L", "zones": [{ "name": "left zone", "material": "m", "polygon": [] }] },
            { "name": "R", "zones": [{ "name": "right", "material": "m", "polygon": [] }] }
        ],
        "segments": {
            "left_right": { "body": "L" },
            "right_left": { "body": "R" },
            "ground": { "body": "L", "from": [0, 0], "to": [1, 0] }
        },
        "materials": { "m": { "E": 1.0, "nu": 0.3 } },
        "contacts": [{ "name": "c", "between": ["left_right", "right_left"] }],
        "mesh": { "max_size": 1.0 }
    }))
}

#[test]
fn gmsh_import_splits_bodies_and_pairs_contact_nodes() {
    let sc = two_squares_scene();
    let mesh = import_gmsh(TWO_SQUARES_MSH, &sc).unwrap();
    check_mesh(&mesh, 45.0);
    assert_eq!(
        mesh.nodes.len(),
        8,
        "the shared edge's two nodes are duplicated"
    );
    assert_eq!(mesh.triangles.len(), 4);
    let c = &mesh.contacts[0];
    assert_eq!(c.pairs.len(), 2);
    for &[a, b] in &c.pairs {
        assert_eq!(mesh.nodes[a], mesh.nodes[b]);
        assert_eq!((mesh.node_body[a], mesh.node_body[b]), (0, 1));
    }
    // The physical curve "ground" lies on body L: declared on body R it is rejected.
    let mut sc2 = sc.clone();
    sc2.segments.get_mut("ground").unwrap().body = "R".into();
    assert_eq!(
        import_gmsh(TWO_SQUARES_MSH, &sc2).unwrap_err().path,
        "segments.ground"
    );
    // The left square's right edge is oriented with body L on its left: it runs upwards.
    let s = &mesh.segments[mesh.segment_index("left_right").unwrap()];
    let [a, b] = s.edges[0];
    assert!(mesh.nodes[b][1] > mesh.nodes[a][1]);
}

#[test]
fn gmsh_errors_name_the_problem() {
    let sc = two_squares_scene();
    let reason = |text: &str| import_gmsh(text, &sc).unwrap_err().reason;
    let quad = TWO_SQUARES_MSH.replace("2 1 2 2\n", "2 1 3 2\n");
    assert!(reason(&quad).contains("type 3"));
    let r = reason(&TWO_SQUARES_MSH.replace("2 1 2 2\n", "2 1 9 2\n"));
    assert!(r.contains("type 9") && r.contains("second-order"), "{r}");
    let r = reason(&TWO_SQUARES_MSH.replace("4.1 0 8", "3.0 0 8"));
    assert!(r.starts_with("line 2: MSH version 3.0"), "{r}");
    let r = reason(&TWO_SQUARES_MSH.replace(
        "$EndMeshFormat\n",
        "$EndMeshFormat\n$PartitionedEntities\n1\n$EndPartitionedEntities\n",
    ));
    assert!(r.contains("partitioned"), "{r}");
    // A binary file written on a big-endian machine: its byte-order mark reads 1 << 24 here.
    let mut big = b"$MeshFormat\n4.1 1 8\n".to_vec();
    big.extend(1i32.to_be_bytes());
    big.extend(b"\n$EndMeshFormat\n");
    let r = import_gmsh(&big, &sc).unwrap_err().reason;
    assert!(r.contains("big-endian"), "{r}");
    let mut renamed = sc.clone();
    renamed.bodies[1].zones[0].name = "other".into();
    let e = import_gmsh(TWO_SQUARES_MSH, &renamed).unwrap_err();
    assert_eq!(e.path, "mesh.gmsh_file", "{e}");
    let truncated = &TWO_SQUARES_MSH[..TWO_SQUARES_MSH.find("$EndNodes").unwrap()];
    assert!(import_gmsh(truncated, &sc).is_err());
}

/// An MSH 4.1 file of one physical surface "z" (entity 1) and one physical curve "bottom"
/// (entity 1): nodes (tag, x, y), triangles and lines (element tag, node tags).
fn square_msh(
    nodes: &[(usize, f64, f64)],
    tris: &[(usize, [usize; 3])],
    lines: &[(usize, [usize; 2])],
) -> String {
    let mut s = String::from(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n1 7 \"bottom\"\n2 3 \"z\"\n\
         $EndPhysicalNames\n$Entities\n0 1 1 0\n1 0 0 0 1 0 0 1 7 0\n1 0 0 0 1 1 0 1 3 0\n\
         $EndEntities\n",
    );
    let max_tag = nodes.iter().map(|n| n.0).max().unwrap_or(0);
    s += &format!(
        "$Nodes\n1 {} 1 {max_tag}\n2 1 0 {}\n",
        nodes.len(),
        nodes.len()
    );
    for n in nodes {
        s += &format!("{}\n", n.0);
    }
    for n in nodes {
        s += &format!("{} {} 0\n", n.1, n.2);
    }
    let count = tris.len() + lines.len();
    s += &format!(
        "$EndNodes\n$Elements\n2 {count} 1 {count}\n2 1 2 {}\n",
        tris.len()
    );
    for (tag, v) in tris {
        s += &format!("{tag} {} {} {}\n", v[0], v[1], v[2]);
    }
    s += &format!("1 1 1 {}\n", lines.len());
    for (tag, v) in lines {
        s += &format!("{tag} {} {}\n", v[0], v[1]);
    }
    s + "$EndElements\n"
}

fn square_scene() -> Scene {
    scene(serde_json::json!({
        "version": 1,
        "bodies": [{ "name": "b", "zones": [{ "name": "z", "material": "m", "polygon": [] }] }],
        "segments": { "bottom": { "body": "b" } },
        "materials": { "m": { "E": 1.0, "nu": 0.3 } },
        "mesh": { "max_size": 1.0 }
    }))
}

const UNIT_SQUARE: [(usize, f64, f64); 4] =
    [(1, 0.0, 0.0), (2, 1.0, 0.0), (3, 1.0, 1.0), (4, 0.0, 1.0)];

#[test]
fn gmsh_import_accepts_either_orientation_and_drops_unused_nodes() {
    // Element 11 is clockwise; node 9 (a circle's centre point, say) belongs to no triangle.
    let mut nodes = UNIT_SQUARE.to_vec();
    nodes.push((9, 0.5, 3.0));
    let text = square_msh(&nodes, &[(10, [1, 2, 3]), (11, [1, 4, 3])], &[(20, [1, 2])]);
    let mesh = import_gmsh(&text, &square_scene()).unwrap();
    check_mesh(&mesh, 45.0);
    assert_eq!(mesh.nodes.len(), 4, "the unused node is dropped");
    let area: f64 = (0..mesh.triangles.len())
        .map(|t| mesh.triangle_area(t))
        .sum();
    assert!((area - 1.0).abs() < 1e-12);
    assert_eq!(mesh.segments[0].edges.len(), 1);
}

#[test]
fn gmsh_import_refuses_broken_meshes_naming_the_elements() {
    let sc = square_scene();
    let reason = |nodes: &[(usize, f64, f64)],
                  tris: &[(usize, [usize; 3])],
                  lines: &[(usize, [usize; 2])]| {
        let e = import_gmsh(square_msh(nodes, tris, lines), &sc).unwrap_err();
        assert_eq!(e.path, "mesh.gmsh_file", "{e}");
        e.reason
    };
    let bottom = [(20, [1, 2])];
    // Collinear corners: node 5 lies on the line through nodes 1 and 2.
    let mut nodes = UNIT_SQUARE.to_vec();
    nodes.push((5, 2.0, 0.0));
    let r = reason(
        &nodes,
        &[(10, [1, 2, 3]), (11, [1, 3, 4]), (12, [1, 2, 5])],
        &bottom,
    );
    assert!(r.contains("element 12") && r.contains("degenerate"), "{r}");
    // A repeated node.
    let r = reason(&UNIT_SQUARE, &[(10, [1, 2, 3]), (11, [1, 3, 3])], &bottom);
    assert!(r.contains("element 11") && r.contains("degenerate"), "{r}");
    // Two triangles folded over the edge 1–2 (both on its upper side).
    let r = reason(&UNIT_SQUARE, &[(10, [1, 2, 3]), (11, [1, 2, 4])], &bottom);
    assert!(
        r.contains("elements 10") && r.contains("and 11") && r.contains("nodes 1 and 2"),
        "{r}"
    );
    // A duplicated element.
    let r = reason(
        &UNIT_SQUARE,
        &[(10, [1, 2, 3]), (11, [1, 3, 4]), (12, [3, 4, 1])],
        &bottom,
    );
    assert!(r.contains("elements 11") && r.contains("and 12"), "{r}");
    // A hanging node: node 6 splits the diagonal on one side only.
    let mut nodes = UNIT_SQUARE.to_vec();
    nodes.push((6, 0.5, 0.5));
    let r = reason(
        &nodes,
        &[(10, [1, 2, 3]), (11, [1, 6, 4]), (12, [6, 3, 4])],
        &bottom,
    );
    assert!(
        r.contains("node 6") && r.contains("element 10") && r.contains("hanging"),
        "{r}"
    );
    // A physical curve that crosses the triangles instead of following their edges.
    let r = reason(
        &UNIT_SQUARE,
        &[(10, [1, 2, 3]), (11, [1, 3, 4])],
        &[(20, [2, 4])],
    );
    assert!(
        r.contains("line element 20") && r.contains("'bottom'") && r.contains("conform"),
        "{r}"
    );
    // The same file with conforming elements imports.
    assert!(import_gmsh(
        square_msh(&UNIT_SQUARE, &[(10, [1, 2, 3]), (11, [1, 3, 4])], &bottom),
        &sc
    )
    .is_ok());
}

#[test]
fn far_apart_bodies_do_not_mesh_the_gap() {
    let sc = scene(serde_json::json!({
        "version": 1,
        "bodies": [
            { "name": "a", "zones": [{ "name": "a", "material": "m", "polygon": [[0, 0], [1, 0], [1, 1], [0, 1]] }] },
            { "name": "b", "zones": [{ "name": "b", "material": "m", "polygon": [[300, 0], [301, 0], [301, 1], [300, 1]] }] }
        ],
        "materials": { "m": { "E": 1.0, "nu": 0.3 } },
        "mesh": { "max_size": 0.02 }
    }));
    let t0 = std::time::Instant::now();
    let mesh = generate(&sc).unwrap();
    println!(
        "far apart: {} triangles in {:.3} s",
        mesh.triangles.len(),
        t0.elapsed().as_secs_f64()
    );
    check_mesh(&mesh, 28.0);
    assert!(t0.elapsed().as_secs_f64() < 2.0);
}

#[test]
fn small_input_angles_terminate() {
    let sc = scene(serde_json::json!({
        "version": 1,
        "bodies": [{ "name": "rock", "zones": [
            { "name": "wedge", "material": "m", "polygon": [[0, 0], [4, 0], [4, 0.3]] },
            { "name": "rest", "material": "m", "polygon": [[0, 0], [4, 0.3], [4, 1], [0, 1]] }
        ] }],
        "materials": { "m": { "E": 1.0, "nu": 0.3 } },
        "mesh": { "max_size": 0.1 }
    }));
    let mesh = generate(&sc).unwrap();
    let s = stats(&mesh);
    println!(
        "wedge of 4.3°: {} triangles, min angle {:.2}°",
        s.triangles, s.min_angle_deg
    );
    assert!(s.min_angle_deg > 1.0);
}

/// One mesh of two triangles given inline (`mesh.inline`) on the square scene: the errors name
/// the inline mesh's JSON paths.
#[test]
fn inline_mesh_errors_name_their_json_paths() {
    let base = serde_json::json!({
        "nodes": [[0, 0], [1, 0], [1, 1], [0, 1]],
        "triangles": [[0, 1, 2], [0, 3, 2]],
        "zones": ["z"],
        "triangle_zones": [0, 0],
        "segments": { "bottom": [[0, 1]] }
    });
    let with = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut inline = base.clone();
        edit(&mut inline);
        let mut sc = square_scene();
        sc.mesh.max_size = None;
        sc.mesh.inline = Some(serde_json::from_value(inline).unwrap());
        generate(&sc)
    };
    let mesh = with(&|_| {}).unwrap();
    check_mesh(&mesh, 45.0);
    assert_eq!(mesh.segments[0].edges.len(), 1);
    let err = |edit: &dyn Fn(&mut serde_json::Value)| with(edit).unwrap_err();
    let e = err(&|m| m["triangles"][1] = serde_json::json!([0, 3, 7]));
    assert_eq!(e.path, "mesh.inline.triangles[1]", "{e}");
    assert!(e.reason.contains("node index 7 is out of range"), "{e}");
    let e = err(&|m| m["triangles"][1] = serde_json::json!([0, 1, 2]));
    assert_eq!(e.path, "mesh.inline.triangles[1]", "{e}");
    assert!(
        e.reason.contains("triangles 0 and 1") && e.reason.contains("overlap"),
        "{e}"
    );
    let e = err(&|m| m["triangles"][1] = serde_json::json!([0, 2, 2]));
    assert!(
        e.path == "mesh.inline.triangles[1]" && e.reason.contains("degenerate"),
        "{e}"
    );
    let e = err(&|m| m["zones"][0] = serde_json::json!("rock"));
    assert_eq!(e.path, "mesh.inline.zones[0]", "{e}");
    let e = err(&|m| m["triangle_zones"][1] = serde_json::json!(1));
    assert_eq!(e.path, "mesh.inline.triangle_zones[1]", "{e}");
    let e = err(&|m| m["triangle_zones"] = serde_json::json!([0]));
    assert_eq!(e.path, "mesh.inline.triangle_zones", "{e}");
    let e = err(&|m| m["segments"]["bottom"] = serde_json::json!([[0, 1], [1, 3]]));
    assert_eq!(e.path, "mesh.inline.segments.bottom[1]", "{e}");
    assert!(e.reason.contains("not two corners of one triangle"), "{e}");
    let e = err(&|m| m["segments"] = serde_json::json!({}));
    assert_eq!(e.path, "segments.bottom", "no edges and no geometry: {e}");
}

/// Subdividing an imported mesh k times is the same as importing its k-times subdivided
/// version: 4^k triangles, the same area, the segments' edges split, and the counts of
/// `count` exact.
#[test]
fn subdivided_imports_keep_zones_segments_and_contacts() {
    let mut sc = two_squares_scene();
    let coarse = import_gmsh(TWO_SQUARES_MSH, &sc).unwrap();
    for k in 1..=2u32 {
        sc.mesh.subdivide = k;
        let fine = import_gmsh(TWO_SQUARES_MSH, &sc).unwrap();
        check_mesh(&fine, 45.0);
        let f = 4usize.pow(k);
        assert_eq!(fine.triangles.len(), f * coarse.triangles.len());
        let area = |m: &Mesh| {
            (0..m.triangles.len())
                .map(|t| m.triangle_area(t))
                .sum::<f64>()
        };
        assert!((area(&fine) - area(&coarse)).abs() < 1e-12);
        for (s, c) in fine.segments.iter().zip(&coarse.segments) {
            assert_eq!(s.edges.len(), 2usize.pow(k) * c.edges.len(), "{}", s.name);
        }
        let pairs = &fine.contacts[0].pairs;
        assert_eq!(pairs.len(), 2usize.pow(k) + 1);
        assert!(pairs.iter().all(|&[a, b]| fine.nodes[a] == fine.nodes[b]));
        let zone_area = |m: &Mesh, z: usize| {
            (0..m.triangles.len())
                .filter(|&t| m.triangle_zone[t] == z)
                .map(|t| m.triangle_area(t))
                .sum::<f64>()
        };
        assert!((zone_area(&fine, 1) - zone_area(&coarse, 1)).abs() < 1e-12);
        let mut file = sc.clone();
        let path = std::env::temp_dir().join(format!("wsm-subdivide-{}.msh", std::process::id()));
        std::fs::write(&path, TWO_SQUARES_MSH).unwrap();
        file.mesh.gmsh_file = Some(path.display().to_string());
        let counted = crate::mesh::count(&file).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(counted.triangles, fine.triangles.len() as f64);
        assert_eq!(counted.nodes, fine.nodes.len() as f64);
        assert_eq!(counted.contact_pairs, pairs.len() as f64);
    }
}
