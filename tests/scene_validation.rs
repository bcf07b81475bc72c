//! Bad scenes are refused before any work, with an error naming the offending JSON field.

use serde_json::{json, Value};
use wsm_core::parse_scene;

fn base() -> Value {
    serde_json::from_str(wsm_core::example("block-on-base").unwrap()).unwrap()
}

/// Apply `edit` to the block-on-base example and check the error path starts with `path`.
fn refused(edit: impl FnOnce(&mut Value), path: &str) {
    let mut scene = base();
    edit(&mut scene);
    let text = serde_json::to_string(&scene).unwrap();
    match parse_scene(&text) {
        Ok(_) => panic!("scene accepted, expected an error at {path}"),
        Err(e) => assert!(
            e.path.starts_with(path),
            "expected error at '{path}', got '{}': {}",
            e.path,
            e.reason
        ),
    }
}

/// Apply `edit` to the block-on-base example: the scene parses (its search criteria do not block
/// a solve), but a search with the scene's own criteria is refused with an error at `path`.
fn refused_by_search(edit: impl FnOnce(&mut Value), path: &str) {
    let mut v = base();
    edit(&mut v);
    let scene =
        parse_scene(&v.to_string()).expect("the criteria a search uses do not block parsing");
    match wsm_core::WorstRequest::default().settings(&scene) {
        Ok(_) => panic!("search accepted, expected an error at {path}"),
        Err(wsm_core::WsmError::Scene(e)) => assert!(
            e.path.starts_with(path),
            "expected error at '{path}', got '{}': {}",
            e.path,
            e.reason
        ),
        Err(e) => panic!("expected a scene error at {path}, got {e}"),
    }
}

#[test]
fn base_scene_is_valid() {
    parse_scene(&base().to_string()).unwrap();
}

#[test]
fn wrong_version() {
    refused(|s| s["version"] = json!(2), "version");
}

#[test]
fn unknown_top_level_field() {
    refused(|s| s["bodys"] = json!([]), "bodys");
}

#[test]
fn wrong_type_names_the_field() {
    refused(
        |s| s["materials"]["rock"]["E"] = json!("stiff"),
        "materials.rock.E",
    );
}

#[test]
fn no_bodies() {
    refused(|s| s["bodies"] = json!([]), "bodies");
}

#[test]
fn duplicate_body_name() {
    refused(|s| s["bodies"][1]["name"] = json!("base"), "bodies[1].name");
}

#[test]
fn unknown_zone_material() {
    refused(
        |s| s["bodies"][0]["zones"][0]["material"] = json!("granite"),
        "bodies[0].zones[0].material",
    );
}

#[test]
fn polygon_with_two_points() {
    refused(
        |s| s["bodies"][0]["zones"][0]["polygon"] = json!([[0, 0], [1, 0]]),
        "bodies[0].zones[0].polygon",
    );
}

#[test]
fn self_intersecting_polygon() {
    refused(
        |s| s["bodies"][0]["zones"][0]["polygon"] = json!([[0, 0], [2, 0.5], [2, 0], [0, 0.5]]),
        "bodies[0].zones[0].polygon",
    );
}

#[test]
fn poisson_ratio_half() {
    refused(
        |s| s["materials"]["rock"]["nu"] = json!(0.5),
        "materials.rock.nu",
    );
}

#[test]
fn non_positive_young_modulus() {
    refused(
        |s| s["materials"]["rock"]["E"] = json!(0.0),
        "materials.rock.E",
    );
}

#[test]
fn non_positive_shear_modulus() {
    refused(
        |s| s["materials"]["rock"] = json!({"lambda": 1e9, "mu": -1.0}),
        "materials.rock.mu",
    );
}

#[test]
fn mixed_elastic_constants() {
    refused(
        |s| s["materials"]["rock"]["lambda"] = json!(1e9),
        "materials.rock",
    );
}

#[test]
fn segment_of_unknown_body() {
    refused(
        |s| s["segments"]["top"]["body"] = json!("lid"),
        "segments.top.body",
    );
}

#[test]
fn boundary_on_unknown_segment() {
    refused(
        |s| s["boundary"][0]["segment"] = json!("floor"),
        "boundary[0].segment",
    );
}

#[test]
fn boundary_with_two_conditions() {
    refused(
        |s| s["boundary"][1]["traction"] = json!([0, 1]),
        "boundary[1]",
    );
}

#[test]
fn zero_roller_direction() {
    refused(
        |s| s["boundary"][0] = json!({"segment": "bottom", "roller": {"direction": [0, 0]}}),
        "boundary[0].roller.direction",
    );
}

#[test]
fn contact_within_one_body() {
    refused(
        |s| s["contacts"][0]["between"] = json!(["block_contact", "push"]),
        "contacts[0].between",
    );
}

#[test]
fn negative_slip_limit() {
    refused(
        |s| s["contacts"][0]["slip_limit"] = json!(-1.0),
        "contacts[0].slip_limit",
    );
}

#[test]
fn piecewise_slip_with_decreasing_knots() {
    refused(
        |s| s["contacts"][0]["slip_limit"] = json!({"knots": [0.0, 0.8, 0.5], "values": [1, 1, 1]}),
        "contacts[0].slip_limit.knots",
    );
}

#[test]
fn non_positive_mesh_size() {
    refused(|s| s["mesh"]["max_size"] = json!(0.0), "mesh.max_size");
}

#[test]
fn refinement_of_unknown_segment() {
    refused(
        |s| s["mesh"]["refine"][0]["segments"] = json!(["nowhere"]),
        "mesh.refine[0].segments[0]",
    );
}

#[test]
fn thermal_condition_without_thermal_section() {
    refused(
        |s| s["boundary"][1] = json!({"segment": "top", "temperature": 300.0}),
        "boundary[1].temperature",
    );
}

#[test]
fn thermal_criterion_without_thermal_section() {
    refused_by_search(
        |s| s["search"]["criteria"] = json!(["phi1"]),
        "search.criteria[0]",
    );
}

#[test]
fn unknown_criterion_name() {
    refused(
        |s| s["search"]["criteria"] = json!(["phi9"]),
        "search.criteria[0]",
    );
}

#[test]
fn uncertain_unknown_field() {
    refused(
        |s| s["uncertain"][0]["field"] = json!("materials.rock.density"),
        "uncertain[0].field",
    );
}

#[test]
fn uncertain_inverted_interval() {
    refused(
        |s| s["uncertain"][1]["interval"] = json!([4e5, 3e5]),
        "uncertain[1].interval",
    );
}

#[test]
fn uncertain_reaches_zero_stiffness() {
    refused(
        |s| s["uncertain"][0]["interval"] = json!([-1e9, 1e10]),
        "uncertain[0].interval",
    );
}

#[test]
fn uncertain_lame_on_young_material() {
    refused(
        |s| s["uncertain"][0]["field"] = json!("materials.rock.mu"),
        "uncertain[0].field",
    );
}

#[test]
fn non_finite_number_is_refused() {
    let text = base()
        .to_string()
        .replace("\"max_size\":0.05", "\"max_size\":1e999");
    let err = parse_scene(&text).unwrap_err();
    assert!(err.path.starts_with("mesh.max_size"), "{err}");
}

#[test]
fn dd_partition_polygon_needs_three_points() {
    refused(
        |s| s["solver"] = json!({"kind": "dd", "partition": [[[0, 0], [1, 0]]]}),
        "solver.partition[0]",
    );
}

#[test]
fn dd_partition_polygon_must_be_finite() {
    refused(
        |s| s["solver"] = json!({"kind": "dd", "partition": [[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 0], ["x", 1]]]}),
        "solver.partition[1]",
    );
}

#[test]
fn phi4_piece_on_the_dirichlet_boundary() {
    // FGCS 4.32: Φ4 averages u·n over pieces off Γu; 'bottom' has a prescribed displacement.
    refused_by_search(
        |s| {
            s["criteria"]["boundary_pieces"][0]["segment"] = json!("bottom");
            s["criteria"]["boundary_pieces"][0]["from"] = json!([0.5, 0.0]);
            s["criteria"]["boundary_pieces"][0]["to"] = json!([1.5, 0.0]);
            s["search"]["criteria"] = json!(["phi4"]);
        },
        "criteria.boundary_pieces[0].segment",
    );
    // The same piece is fine when Φ4 is not requested.
    let mut scene = base();
    scene["criteria"]["boundary_pieces"][0]["segment"] = json!("bottom");
    scene["search"]["criteria"] = json!(["phi3"]);
    parse_scene(&scene.to_string()).unwrap();
}

#[test]
fn phi6_without_a_region_next_to_a_contact_zone() {
    // FGCS 4.34: Φ6 averages −τ_n over areas adjacent to Γc; move G1 off the contact line.
    refused_by_search(
        |s| {
            s["criteria"]["regions"][0]["polygon"] =
                json!([[0.9, 0.7], [1.1, 0.7], [1.1, 0.8], [0.9, 0.8]]);
            s["criteria"]["regions"][0]["normal_at"] = json!([1.0, 1.0]);
            s["search"]["criteria"] = json!(["phi6"]);
        },
        "search.criteria[0]",
    );
}

#[test]
fn too_many_vertices() {
    // The block's top edge split into 20,000 vertices: beyond the scene's vertex limit.
    refused(
        |s| {
            let mut polygon = vec![json!([0.5, 0.5]), json!([1.5, 0.5])];
            let n = 20_000;
            for k in 0..=n {
                polygon.push(json!([1.5 - k as f64 / n as f64, 1.0]));
            }
            s["bodies"][1]["zones"][0]["polygon"] = json!(polygon);
        },
        "bodies[1].zones[0].polygon",
    );
}

#[test]
fn a_criterion_listed_twice() {
    refused_by_search(
        |s| s["search"]["criteria"] = json!(["phi3", "phi6", "phi3"]),
        "search.criteria[2]",
    );
}

#[test]
fn a_scene_name_too_long_for_a_listing() {
    refused(|s| s["name"] = json!("x".repeat(201)), "name");
}

#[test]
fn long_lists_strings_and_keys_are_refused_with_their_path() {
    refused(
        |s| s["materials"]["rock"]["comment"] = json!("x".repeat(1001)),
        "materials.rock.comment",
    );
    refused(
        |s| s["bodies"][0]["name"] = json!("b".repeat(5000)),
        "bodies[0].name",
    );
    refused(
        |s| s["uncertain"] = json!(vec![json!({"field": "materials.rock.E"}); 10_001]),
        "uncertain",
    );
    refused(
        |s| {
            s["materials"]
                .as_object_mut()
                .unwrap()
                .insert("m".repeat(2000), json!({}));
        },
        "materials",
    );
}

// ---------- anisotropic materials and interval matrices (FGCS 2.7′, 4.5–4.8) ----------

/// The block-on-base example with `rock` replaced by `material` and the first uncertain entry
/// (the rock's E) replaced by `uncertain` (or dropped).
fn with_rock(material: Value, uncertain: &[Value]) -> Value {
    let mut scene = base();
    scene["materials"]["rock"] = material;
    let mut list = uncertain.to_vec();
    list.extend(scene["uncertain"].as_array().unwrap()[1..].iter().cloned());
    scene["uncertain"] = json!(list);
    scene
}

fn orthotropic() -> Value {
    json!({"E1": 20e9, "E2": 10e9, "E3": 12e9, "nu12": 0.22, "nu13": 0.2, "nu23": 0.25,
           "G12": 4e9, "angle": 30.0, "specific_weight": 24500.0})
}

fn general_matrix() -> Value {
    json!({"matrix": [[14e9, 4e9, 1e9], [4e9, 12e9, -0.5e9], [1e9, -0.5e9, 4e9]],
           "out_of_plane": [4e9, 4e9, 0.0], "specific_weight": 24500.0})
}

/// The error of a scene that must be refused.
fn refusal(scene: &Value) -> wsm_core::SceneError {
    match parse_scene(&scene.to_string()) {
        Ok(_) => panic!("scene accepted, expected an error"),
        Err(e) => e,
    }
}

#[test]
fn orthotropic_and_matrix_materials_are_accepted() {
    let uncertain = [
        json!({"field": "materials.rock.E1", "interval": [15e9, 25e9]}),
        json!({"field": "materials.rock.angle", "interval": [0.0, 60.0]}),
        json!({"field": "materials.rock.nu23", "interval": [0.2, 0.3]}),
    ];
    parse_scene(&with_rock(orthotropic(), &uncertain).to_string()).unwrap();
    let uncertain = [
        json!({"field": "materials.rock.matrix[0][1]", "interval": [3e9, 5e9]}),
        json!({"field": "materials.rock.matrix[2][2]", "interval": [3.5e9, 4.5e9]}),
        json!({"field": "materials.rock.out_of_plane[0]", "interval": [3e9, 5e9]}),
    ];
    parse_scene(&with_rock(general_matrix(), &uncertain).to_string()).unwrap();
}

#[test]
fn orthotropic_material_needs_all_constants() {
    let mut m = orthotropic();
    m.as_object_mut().unwrap().remove("G12");
    assert_eq!(refusal(&with_rock(m, &[])).path, "materials.rock.G12");
    let mut m = orthotropic();
    m["E"] = json!(1e9);
    assert_eq!(refusal(&with_rock(m, &[])).path, "materials.rock");
}

#[test]
fn orthotropic_poisson_ratios_must_keep_the_compliance_positive_definite() {
    let mut m = orthotropic();
    // ν12 √(E2/E1) = 1.6 × 0.707 > 1.
    m["nu12"] = json!(1.6);
    let e = refusal(&with_rock(m, &[]));
    assert_eq!(e.path, "materials.rock.nu12");
    assert!(e.reason.contains("1.6"), "{}", e.reason);
}

#[test]
fn stiffness_matrix_must_be_symmetric_and_positive_definite() {
    let mut m = general_matrix();
    m["matrix"][0][1] = json!(5e9);
    assert_eq!(
        refusal(&with_rock(m, &[])).path,
        "materials.rock.matrix[0][1]"
    );
    let mut m = general_matrix();
    m["matrix"][2][2] = json!(-1e9);
    let e = refusal(&with_rock(m, &[]));
    assert_eq!(e.path, "materials.rock.matrix");
    assert!(
        e.reason.contains("smallest eigenvalue is -1.1"),
        "{}",
        e.reason
    );
    let mut m = general_matrix();
    m["expansion"] = json!(1e-5);
    assert_eq!(refusal(&with_rock(m, &[])).path, "materials.rock.expansion");
}

#[test]
fn conductivity_matrix_must_be_symmetric_positive_definite() {
    let mut m = orthotropic();
    m["conductivity"] = json!([[2.0, 3.0], [3.0, 2.0]]);
    let e = refusal(&with_rock(m, &[]));
    assert_eq!(e.path, "materials.rock.conductivity");
    assert!(e.reason.contains("eigenvalues -1"), "{}", e.reason);
    let mut m = orthotropic();
    m["conductivity"] = json!([[2.0, 0.5], [0.4, 2.0]]);
    assert_eq!(
        refusal(&with_rock(m, &[])).path,
        "materials.rock.conductivity[0][1]"
    );
}

/// FGCS (4.6): the box of stiffness-matrix entries passes when the margin is positive, and is
/// refused naming the material, its zones and the margin when it is not, although the nominal
/// matrix is positive definite.
#[test]
fn stiffness_interval_matrix_checks_margin_4_6() {
    let passing = [json!({"field": "materials.rock.matrix[0][1]", "interval": [2e9, 6e9]})];
    parse_scene(&with_rock(general_matrix(), &passing).to_string()).unwrap();
    // Mid [[14, 4, 1], [4, 12, -0.5], [1, -0.5, 4]] GPa has λ_min < 4 GPa (below d33); a radius
    // of 6 GPa on d12 alone has ρ = 6 GPa.
    let failing = [json!({"field": "materials.rock.matrix[1][0]", "interval": [-2e9, 10e9]})];
    let e = refusal(&with_rock(general_matrix(), &failing));
    assert_eq!(e.path, "materials.rock.matrix");
    assert!(
        e.reason.contains("(4.6)") && e.reason.contains("zones base, block"),
        "{}",
        e.reason
    );
    assert!(
        e.reason.contains("e9 ≤ 0"),
        "a margin of GPa order: {}",
        e.reason
    );
}

/// FGCS (4.8) on the conductivity matrix.
#[test]
fn conductivity_interval_matrix_checks_margin_4_8() {
    let mut m = orthotropic();
    m["conductivity"] = json!([[3.0, 0.5], [0.5, 2.0]]);
    let passing = [json!({"field": "materials.rock.conductivity[0][1]", "interval": [0.0, 1.0]})];
    parse_scene(&with_rock(m.clone(), &passing).to_string()).unwrap();
    let failing = [
        json!({"field": "materials.rock.conductivity[0][1]", "interval": [-2.0, 3.0]}),
        json!({"field": "materials.rock.conductivity[1][1]", "interval": [1.5, 2.5]}),
    ];
    let e = refusal(&with_rock(m, &failing));
    assert_eq!(e.path, "materials.rock.conductivity");
    assert!(
        e.reason.contains("(4.8)") && e.reason.contains("zones base, block"),
        "{}",
        e.reason
    );
}

/// Uncertain orthotropic constants: the interval compliance must stay positive definite.
#[test]
fn orthotropic_interval_box_checks_the_compliance() {
    let failing = [
        json!({"field": "materials.rock.nu12", "interval": [0.2, 1.3]}),
        json!({"field": "materials.rock.E2", "interval": [5e9, 20e9]}),
    ];
    let e = refusal(&with_rock(orthotropic(), &failing));
    assert_eq!(e.path, "materials.rock");
    assert!(e.reason.contains("(4.6)"), "{}", e.reason);
}

#[test]
fn symmetric_entry_is_uncertain_once() {
    let twice = [
        json!({"field": "materials.rock.matrix[0][1]", "interval": [3e9, 5e9]}),
        json!({"field": "materials.rock.matrix[1][0]", "interval": [3e9, 5e9]}),
    ];
    let scene = parse_scene(&with_rock(general_matrix(), &twice).to_string()).unwrap();
    let e = wsm_core::scene_parameters(&scene).unwrap_err();
    assert_eq!(e.path, "uncertain[1].field");
}

/// The refusal of the block-on-base example after `edit`.
fn refusal_of(edit: impl FnOnce(&mut Value)) -> wsm_core::SceneError {
    let mut scene = base();
    edit(&mut scene);
    parse_scene(&scene.to_string()).unwrap_err()
}

/// Boundary conditions and contact zones may be named; a name must be unique in its list and
/// usable in a field path (not blank, no brackets, not all digits).
#[test]
fn entry_names_are_unique_and_usable_in_paths() {
    let named = |s: &mut Value| {
        s["boundary"][0]["name"] = json!("clamp");
        s["boundary"][2]["name"] = json!("push");
    };
    let mut ok = base();
    named(&mut ok);
    parse_scene(&ok.to_string()).unwrap();
    let e = refusal_of(|s| {
        named(s);
        s["boundary"][1]["name"] = json!("push");
    });
    assert_eq!(
        (e.path.as_str(), e.reason.as_str()),
        (
            "boundary[2].name",
            "boundary condition name 'push' used twice"
        )
    );
    for (bad, why) in [
        ("", "is empty"),
        ("  ", "is empty"),
        ("up[1]", "contains a bracket"),
        ("4", "is all digits"),
    ] {
        let e = refusal_of(|s| s["boundary"][1]["name"] = json!(bad));
        assert_eq!(e.path, "boundary[1].name", "{bad:?}");
        assert!(e.reason.contains(why), "{bad:?}: {}", e.reason);
        let e = refusal_of(|s| s["contacts"][0]["name"] = json!(bad));
        assert_eq!(e.path, "contacts[0].name", "{bad:?}");
        assert!(e.reason.contains(why), "{bad:?}: {}", e.reason);
    }
}

/// A path may pick a boundary condition or contact zone by name: the same datum as its index.
#[test]
fn a_name_in_a_path_picks_the_same_datum_as_the_index() {
    use wsm_core::scene_parameters;
    let mut by_index = base();
    by_index["boundary"][2]["name"] = json!("push");
    let mut by_name = by_index.clone();
    by_name["uncertain"][1]["field"] = json!("boundary[push].traction[0]");
    by_name["uncertain"][2]["field"] = json!("contacts[joint].slip_limit");
    let targets = |v: &Value| {
        scene_parameters(&parse_scene(&v.to_string()).unwrap())
            .unwrap()
            .into_iter()
            .map(|p| (p.target, p.lo, p.hi))
            .collect::<Vec<_>>()
    };
    by_index["uncertain"][2]["field"] = json!("contacts[0].slip_limit");
    assert_eq!(targets(&by_name), targets(&by_index));
    // The parameter is reported by the path as written.
    let scene = parse_scene(&by_name.to_string()).unwrap();
    assert_eq!(
        scene_parameters(&scene).unwrap()[1].name,
        "boundary[push].traction[0]"
    );
    // One datum named twice, by name and by index, is refused as for two indices.
    let mut twice = by_name.clone();
    twice["uncertain"][0] = json!({"field": "boundary[2].traction[0]", "interval": [3e5, 4e5]});
    let e = scene_parameters(&parse_scene(&twice.to_string()).unwrap()).unwrap_err();
    assert_eq!(e.path, "uncertain[1].field");
}

/// A name that no entry has is refused at the field, with the names there are.
#[test]
fn an_unknown_name_in_a_path_lists_the_names() {
    let e = refusal_of(|s| {
        s["boundary"][0]["name"] = json!("clamp");
        s["boundary"][2]["name"] = json!("push");
        s["uncertain"][1]["field"] = json!("boundary[pull].traction[0]");
    });
    assert_eq!(e.path, "uncertain[1].field");
    assert_eq!(
        e.reason,
        "'boundary[pull].traction[0]': no boundary entry is named 'pull'; the names are 'clamp', 'push'"
    );
    let e = refusal_of(|s| s["uncertain"][1]["field"] = json!("boundary[push].traction[0]"));
    assert!(e.reason.contains("none has a name"), "{}", e.reason);
    let e = refusal_of(|s| s["uncertain"][2]["field"] = json!("contacts[fault].slip_limit"));
    assert_eq!(e.path, "uncertain[2].field");
    assert!(e.reason.ends_with("the names are 'joint'"), "{}", e.reason);
}

/// The scene's own value of an uncertain datum must lie in its interval, ends included.
#[test]
fn a_nominal_value_outside_its_interval_is_refused() {
    // rock E = 1e10 Pa against [1.1e10, 1.2e10].
    let e = refusal_of(|s| s["uncertain"][0]["interval"] = json!([1.1e10, 1.2e10]));
    assert_eq!(e.path, "uncertain[0]");
    assert!(
        e.reason.starts_with(
            "the nominal value 10000000000 of materials.rock.E lies outside its interval \
             [11000000000, 12000000000]"
        ),
        "{}",
        e.reason
    );
    // A number the scene leaves out is zero in its data: uncertain, it needs a value too.
    let e = refusal_of(|s| {
        s["uncertain"][0] = json!({"field": "materials.rock.body_force[0]", "interval": [1.0, 2.0]})
    });
    assert_eq!(e.path, "uncertain[0]");
    assert!(
        e.reason.starts_with("the nominal value 0 of"),
        "{}",
        e.reason
    );
    let mut at_the_ends = base();
    at_the_ends["uncertain"][0]["interval"] = json!([1e10, 1.2e10]);
    at_the_ends["uncertain"][2]["interval"] = json!([2.5e5, 3e5]);
    parse_scene(&at_the_ends.to_string()).unwrap();
}

/// Implausible magnitudes are warned about (not refused), with the JSON path and the value;
/// every bundled example is free of warnings.
#[test]
fn implausible_magnitudes_are_warned_about_with_path_and_value() {
    use wsm_core::scene_warnings;
    let warned = |edit: &dyn Fn(&mut Value)| {
        let mut s = base();
        edit(&mut s);
        scene_warnings(&parse_scene(&s.to_string()).unwrap())
    };
    type Edit<'a> = &'a dyn Fn(&mut Value);
    let cases: [(Edit, &str); 8] = [
        (
            &|s| {
                s["materials"]["rock"]["E"] = json!(3e4);
                s["uncertain"][0]["interval"] = json!([2e4, 4e4]);
            },
            "materials.rock.E: a Young's modulus of 3e4 Pa",
        ),
        (
            &|s| s["uncertain"][0]["interval"] = json!([5e4, 1.2e10]),
            "uncertain[0].interval: a Young's modulus of 5e4 Pa",
        ),
        (
            &|s| {
                s["materials"]["rock"] = json!({"lambda": 2e4, "mu": 2e4});
                s["uncertain"].as_array_mut().unwrap().remove(0);
            },
            "materials.rock.mu: a Young's modulus of 5e4 Pa (E = μ(3λ + 2μ)/(λ + μ)",
        ),
        (
            &|s| {
                s["materials"]["rock"] = json!({"E1": 1e10, "E2": 9e4, "E3": 1e10, "nu12": 0.01,
                    "nu13": 0.2, "nu23": 1e-4, "G12": 1e9});
                s["uncertain"].as_array_mut().unwrap().remove(0);
            },
            "materials.rock.E2: a Young's modulus of 9e4 Pa",
        ),
        (
            // The model is 2 m × 1 m: a diagonal of √5 m.
            &|s| s["boundary"][0]["displacement"] = json!([null, -3.0]),
            "boundary[0].displacement[1]: a prescribed displacement of -3e0 m is larger than the \
             whole model (the diagonal of its bounding box is 2.23606797749979e0 m)",
        ),
        (
            &|s| s["materials"]["rock"]["specific_weight"] = json!(2.45e7),
            "materials.rock.specific_weight: a specific weight of 2.45e7 N/m³",
        ),
        (
            &|s| s["boundary"][1]["pressure"] = json!(3e10),
            "boundary[1].pressure: a surface load of 3e10 Pa",
        ),
        (
            &|s| s["uncertain"][1]["interval"] = json!([3e5, 2e10]),
            "uncertain[1].interval: a surface load of 2e10 Pa",
        ),
    ];
    for (edit, start) in cases {
        let w = warned(edit);
        assert!(
            w.iter().any(|w| w.to_string().starts_with(start)),
            "{start}: {w:?}"
        );
    }
    assert!(warned(&|_| ()).is_empty());
    for name in wsm_core::example_names() {
        let scene = parse_scene(wsm_core::find_example(name).unwrap()).unwrap();
        assert!(
            scene_warnings(&scene).is_empty(),
            "{name}: {:?}",
            scene_warnings(&scene)
        );
    }
}

// ---------- design §5.2: shapes, plain messages, names, coordinates, angles ----------

/// The error of the block-on-base example after `edit`.
fn refusal_after(edit: impl FnOnce(&mut Value)) -> wsm_core::SceneError {
    let mut scene = base();
    edit(&mut scene);
    refusal(&scene)
}

/// An edit of the example scene.
type Edit = fn(&mut Value);
/// An edit that writes a name into the example scene.
type Naming = Box<dyn Fn(&mut Value, String)>;

/// Words of Rust's or serde's vocabulary that a user must never read.
const RUST_WORDS: [&str; 9] = [
    "struct", "Material", "Scene", "f64", "u64", "usize", "u32", "sequence", "enum ",
];

fn assert_plain(e: &wsm_core::SceneError) {
    for word in RUST_WORDS {
        assert!(!e.reason.contains(word), "'{word}' in {e}");
    }
}

#[test]
fn an_array_where_an_object_belongs_is_refused_with_its_path() {
    // serde would read these by position: E = 1e10, ν = 0.25 (accepted), E = 1, ν = 2 (a ν
    // message about a value the user never wrote as ν).
    for rock in [json!([1e10, 0.25]), json!([1, 2]), json!([1e10])] {
        let e = refusal_after(|s| s["materials"]["rock"] = rock.clone());
        assert_eq!(e.path, "materials.rock", "{rock}: {e}");
        assert!(e.reason.contains("expected an object"), "{rock}: {e}");
        assert_plain(&e);
    }
    let e = refusal_after(|s| s["mesh"] = json!([0.05]));
    assert_eq!(e.path, "mesh", "{e}");
    assert!(e.reason.contains("expected an object"), "{e}");
    let e = refusal_after(|s| s["boundary"][1] = json!(["top", null, null, 1e6]));
    assert_eq!(e.path, "boundary[1]", "{e}");
    let e = refusal_after(|s| s["contacts"][0]["slip_limit"] = json!([[0.0, 1.0], [1e5, 2e5]]));
    assert_eq!(e.path, "contacts[0].slip_limit", "{e}");
    assert!(e.reason.contains("expected an object"), "{e}");
    let e = refusal_after(|s| s["search"] = json!([["phi3"], 10]));
    assert_eq!(e.path, "search", "{e}");
}

#[test]
fn type_errors_are_told_in_json_words() {
    let cases: Vec<(Edit, &str, &str)> = vec![
        (
            |s| s["materials"]["rock"]["E"] = json!("stiff"),
            "materials.rock.E",
            "expected a number",
        ),
        (
            |s| s["version"] = json!({}),
            "version",
            "expected a non-negative whole number, got an object",
        ),
        (
            |s| s["bodies"] = json!({"a": 1}),
            "bodies",
            "expected an array",
        ),
        (
            |s| s["materials"]["rock"]["conductivity"] = json!("high"),
            "materials.rock.conductivity",
            "a conductivity",
        ),
        (
            |s| s["contacts"][0]["kind"] = json!(3),
            "contacts[0].kind",
            "expected",
        ),
        (
            |s| s["search"]["seed"] = json!(-1),
            "search.seed",
            "whole number",
        ),
    ];
    for (edit, path, words) in cases {
        let e = refusal_after(edit);
        assert_eq!(e.path, path, "{e}");
        assert!(e.reason.contains(words), "{e}");
        assert_plain(&e);
    }
}

#[test]
fn every_name_has_the_same_limit_in_every_message() {
    let limit = wsm_core::MAX_NAME;
    let edits: Vec<(Naming, &str)> = vec![
        (Box::new(|s, n| s["name"] = json!(n)), "name"),
        (
            Box::new(|s, n| s["bodies"][0]["name"] = json!(n)),
            "bodies[0].name",
        ),
        (
            Box::new(|s, n| s["criteria"]["regions"][0]["name"] = json!(n)),
            "criteria.regions[0].name",
        ),
        (
            Box::new(|s, n| {
                let rock = s["materials"]["rock"].clone();
                s["materials"].as_object_mut().unwrap().insert(n, rock);
            }),
            "materials",
        ),
    ];
    for (edit, path) in &edits {
        for length in [limit + 1, 5 * limit, wsm_core::MAX_TEXT + 1] {
            let mut scene = base();
            edit(&mut scene, "n".repeat(length));
            let e = refusal(&scene);
            assert_eq!(&e.path, path, "{e}");
            assert!(
                e.reason.contains(&format!("at most {limit}")),
                "{length} characters: {e}"
            );
        }
        let mut scene = base();
        edit(&mut scene, "n".repeat(limit));
        if *path == "name" {
            parse_scene(&scene.to_string()).expect("a name of the limit's length is accepted");
        }
    }
}

#[test]
fn huge_coordinates_are_named_as_such_not_as_zero_area() {
    let cases: Vec<(Edit, &str)> = vec![
        (
            |s| s["bodies"][1]["zones"][0]["polygon"][2] = json!([1e308, 1e308]),
            "bodies[1].zones[0].polygon[2]",
        ),
        (
            |s| {
                s["bodies"][0]["zones"][0]["polygon"] =
                    json!([[0, 0], [1e308, 0], [1e308, 1e308], [0, 1e308]])
            },
            "bodies[0].zones[0].polygon[1]",
        ),
        (
            |s| s["criteria"]["regions"][0]["normal_at"] = json!([1e308, 0.5]),
            "criteria.regions[0].normal_at",
        ),
        (
            |s| s["criteria"]["boundary_pieces"][0]["to"] = json!([-1e300, 1.0]),
            "criteria.boundary_pieces[0].to",
        ),
        (
            |s| s["segments"]["top"]["to"] = json!([0.5, 1e9]),
            "segments.top.path[1]",
        ),
    ];
    for (edit, path) in cases {
        let e = refusal_after(edit);
        assert_eq!(e.path, path, "{e}");
        assert!(!e.reason.contains("zero area"), "{e}");
        assert!(e.reason.contains("finite numbers of at most"), "{e}");
    }
    // A large but sane site (a 100 km model) is accepted.
    let mut scene = base();
    for body in scene["bodies"].as_array_mut().unwrap() {
        for p in body["zones"][0]["polygon"].as_array_mut().unwrap() {
            p[0] = json!(p[0].as_f64().unwrap() * 1e5);
            p[1] = json!(p[1].as_f64().unwrap() * 1e5);
        }
    }
    if let Err(e) = parse_scene(&scene.to_string()) {
        assert!(!e.reason.contains("finite numbers"), "{e}");
    }
}

#[test]
fn an_orthotropic_angle_must_be_a_sane_number_of_degrees() {
    for angle in [1e308, -1e308, 361.0, 1e20] {
        let e = refusal(&with_rock(
            json!({"E1": 20e9, "E2": 10e9, "E3": 12e9, "nu12": 0.22, "nu13": 0.2, "nu23": 0.25,
                   "G12": 4e9, "angle": angle, "specific_weight": 24500.0}),
            &[],
        ));
        assert_eq!(e.path, "materials.rock.angle", "{angle}: {e}");
        assert!(e.reason.contains("[-360, 360] degrees"), "{e}");
    }
    let e = refusal(&with_rock(
        orthotropic(),
        &[json!({"field": "materials.rock.angle", "interval": [0.0, 1e308]})],
    ));
    assert_eq!(e.path, "uncertain[0].interval", "{e}");
    parse_scene(
        &with_rock(
            orthotropic(),
            &[json!({"field": "materials.rock.angle", "interval": [-90.0, 90.0]})],
        )
        .to_string(),
    )
    .expect("an angle within a half turn either way is accepted");
}

#[test]
fn a_segment_component_is_prescribed_once() {
    let e = refusal_after(|s| {
        s["boundary"]
            .as_array_mut()
            .unwrap()
            .push(json!({"segment": "bottom", "displacement": [0.001, null]}))
    });
    assert_eq!(e.path, "boundary[3].displacement[0]", "{e}");
    assert!(e.reason.contains("boundary[0]"), "{e}");
    // Equal values too: with uncertain data the two would part.
    let e = refusal_after(|s| {
        s["boundary"]
            .as_array_mut()
            .unwrap()
            .push(json!({"segment": "bottom", "displacement": [null, 0.0]}))
    });
    assert_eq!(e.path, "boundary[3].displacement[1]", "{e}");
    // Each component once, in two conditions, is fine.
    let mut scene = base();
    scene["boundary"][0]["displacement"] = json!([0.0, null]);
    scene["boundary"]
        .as_array_mut()
        .unwrap()
        .push(json!({"segment": "bottom", "displacement": [null, 0.0]}));
    parse_scene(&scene.to_string()).expect("x by one condition, y by another");
}

#[test]
fn a_repeated_key_is_refused_naming_its_path() {
    let text = base()
        .to_string()
        .replace("\"max_size\":0.05", "\"max_size\":0.05,\"max_size\":0.5");
    let err = parse_scene(&text).unwrap_err();
    assert_eq!(err.path, "mesh.max_size", "{err}");
    assert_eq!(
        err.reason,
        "the key 'max_size' appears more than once in its object"
    );
    let text = base().to_string().replacen("{", "{\"version\":1,", 1);
    assert_eq!(parse_scene(&text).unwrap_err().path, "version");
}

/// The command line reads a scene file as the service reads a request body: a repeated key is
/// bad input (exit status 2) naming the key's path, not the last value silently.
#[test]
fn the_command_line_refuses_a_repeated_key() {
    let dir = std::env::temp_dir().join(format!("wsm-scene-validation-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("repeated.json");
    let text = base()
        .to_string()
        .replace("\"nu\":0.25", "\"nu\":0.25,\"nu\":0.3");
    std::fs::write(&file, text).unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_wsm"))
        .args(["solve", file.to_str().unwrap()])
        .output()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(
        stderr.trim(),
        "error: materials.rock.nu: the key 'nu' appears more than once in its object"
    );
}

#[test]
fn the_built_in_mesher_needs_a_mesh_size() {
    for mesh in [
        json!({}),
        json!({ "max_size": null }),
        json!({ "min_angle": 25 }),
    ] {
        let mut scene = base();
        scene["mesh"] = mesh;
        let err = parse_scene(&scene.to_string()).unwrap_err();
        assert_eq!(err.path, "mesh.max_size", "{err}");
        assert!(
            err.reason.starts_with("missing: the built-in mesher needs")
                && err.reason.contains("mesh.gmsh_file"),
            "{err}"
        );
    }
}

/// An imported Gmsh mesh has its own sizes: no `max_size` is asked for (one given is still
/// checked), and the scene written back has none either.
#[test]
fn a_gmsh_scene_needs_no_mesh_size() {
    let mut scene = base();
    scene["mesh"] = json!({ "gmsh_file": "blocks.msh" });
    let parsed = parse_scene(&scene.to_string()).unwrap();
    assert_eq!(parsed.mesh.max_size, None);
    let written = serde_json::to_value(&parsed).unwrap();
    assert_eq!(
        written["mesh"],
        json!({ "min_angle": 28.0, "gmsh_file": "blocks.msh" })
    );
    refused(
        |s| s["mesh"] = json!({ "gmsh_file": "blocks.msh", "max_size": -1.0 }),
        "mesh.max_size",
    );
}

/// An inline mesh needs no `max_size` either and is written back as given; it excludes a Gmsh
/// file, and `mesh.subdivide` applies to imported meshes only, up to its limit.
#[test]
fn inline_meshes_and_subdivisions_are_checked_in_the_mesh_section() {
    let inline = json!({
        "nodes": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        "triangles": [[0, 1, 2]],
        "zones": ["z"],
        "triangle_zones": [0]
    });
    let mut scene = base();
    scene["mesh"] = json!({ "inline": inline.clone(), "subdivide": 2 });
    let parsed = parse_scene(&scene.to_string()).unwrap();
    assert_eq!(parsed.mesh.max_size, None);
    assert_eq!(parsed.mesh.subdivide, 2);
    let written = serde_json::to_value(&parsed).unwrap();
    assert_eq!(written["mesh"]["inline"], inline);
    refused(
        |s| s["mesh"] = json!({ "inline": inline.clone(), "gmsh_file": "blocks.msh" }),
        "mesh.inline",
    );
    refused(
        |s| s["mesh"] = json!({ "max_size": 0.1, "subdivide": 1 }),
        "mesh.subdivide",
    );
    refused(
        |s| s["mesh"] = json!({ "gmsh_file": "blocks.msh", "subdivide": 9 }),
        "mesh.subdivide",
    );
    refused(
        |s| s["mesh"] = json!({ "inline": { "nodes": [], "triangles": [], "zones": [], "triangle_zones": [], "edges": {} } }),
        "mesh.inline",
    );
}
