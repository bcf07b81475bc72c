//! Loads and data as engineers give them (design §2.6, §4.1): the hydrostatic pressure of the
//! bundled `dam-water-level` (water level on the upstream face, the reservoir bed and as uplift in
//! the heel crack) against a hand calculation of its resultants and moments, its exact level
//! derivative, a linked datum's derivative against the sum of its fields' derivatives times their
//! factors and against central differences of whole solves, the worst-scenario run that
//! certifies the level's extremum, and the refusals of bad hydrostatic and linked data.

use serde_json::{json, Value};
use wsm_core::{
    apply_parameters, parameter_stencil, parse_scene, scene_parameters, BoundaryValue, Criterion,
    CriterionSpec, Data, Needs, Parameter, PerCriterion, RunControl, ScenarioEvaluator, Scene,
    SolveOptions, StateProblem, Status, WorstRequest,
};

const GAMMA: f64 = 9810.0;

fn dam() -> Value {
    serde_json::from_str(wsm_core::example("dam-water-level").unwrap()).unwrap()
}

fn scene(v: &Value) -> Scene {
    parse_scene(&v.to_string()).unwrap()
}

fn options(problem: &StateProblem) -> SolveOptions {
    SolveOptions {
        needs: Needs::all(&problem.scene),
        par: wsm_core::Par::Seq,
        warm: None,
    }
}

/// The data with only boundary condition `keep` loading (no weight, other hydrostatics dry).
fn only(data: &Data, keep: usize) -> Data {
    let mut d = data.clone();
    for m in &mut d.materials {
        m.specific_weight = 0.0;
    }
    for (b, bc) in d.boundary.iter_mut().enumerate() {
        if let BoundaryValue::Hydrostatic(h) = &mut bc.value {
            if b != keep {
                h.unit_weight = 0.0;
            }
        }
    }
    d
}

/// (Σ f_x, Σ f_y, Σ y f_x, Σ x f_y) of nodal forces.
fn resultant(problem: &StateProblem, f: &[[f64; 2]]) -> [f64; 4] {
    let nodes = &problem.mesh().nodes;
    f.iter().zip(nodes).fold([0.0; 4], |r, (f, p)| {
        [
            r[0] + f[0],
            r[1] + f[1],
            r[2] + p[1] * f[0],
            r[3] + p[0] * f[1],
        ]
    })
}

fn index(v: &Value, name: &str) -> usize {
    v["boundary"]
        .as_array()
        .unwrap()
        .iter()
        .position(|b| b["name"] == name)
        .unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

/// p = γ (y0 − y) on the vertical face x = 0, 0 ≤ y ≤ 30 (outward normal −x): horizontal force
/// γ y0²/2 and moment about the base γ y0³/6; on the heel crack (dam outward normal −y, rock
/// +y, 0 ≤ x ≤ 6 at y = 0): ±γ y0 · 6 up/down with moment ±γ y0 · 18; on the reservoir bed
/// (−60 ≤ x ≤ 0): −γ y0 · 60. Exact for levels that split an edge and for a dry face (the edge
/// integral is exact, Σ φ_i = 1 and Σ φ_i x_i = x).
#[test]
fn face_pressure_and_uplift_resultants_match_a_hand_calculation() {
    let v = dam();
    let problem = StateProblem::new(scene(&v)).unwrap();
    let (face, bed, up_dam, up_rock) = (
        index(&v, "face"),
        index(&v, "bed"),
        index(&v, "uplift_dam"),
        index(&v, "uplift_rock"),
    );
    let params = scene_parameters(&problem.scene).unwrap();
    for level in [20.0, 23.37, 26.0, 27.913, 28.0] {
        let data = apply_parameters(
            &problem.scene,
            &problem.nominal,
            &params,
            &[level, 4.0e5, 1e10],
        );
        let loads = |b: usize| {
            resultant(
                &problem,
                &problem.elastic.loads(&only(&data, b), None).unwrap(),
            )
        };
        let [fx, fy, my, _] = loads(face);
        assert!(
            close(fx, GAMMA * level * level / 2.0, 1e-12),
            "{level}: {fx}"
        );
        assert!(fy.abs() <= 1e-9 * fx, "{level}: {fy}");
        assert!(
            close(my, GAMMA * level.powi(3) / 6.0, 1e-12),
            "{level}: {my}"
        );
        let uplift = GAMMA * level * 6.0;
        let [gx, gy, _, mx] = loads(up_dam);
        assert!(
            gx.abs() <= 1e-9 * uplift && close(gy, uplift, 1e-12),
            "{gx} {gy}"
        );
        assert!(close(mx, uplift * 3.0, 1e-12), "{mx}");
        let [hx, hy, _, _] = loads(up_rock);
        assert!(
            hx.abs() <= 1e-9 * uplift && close(hy, -uplift, 1e-12),
            "{hx} {hy}"
        );
        let [_, by, _, _] = loads(bed);
        assert!(close(by, -GAMMA * level * 60.0, 1e-12), "{by}");
    }
    // Above the face's top the whole face is wet; at the base it is dry.
    let mut data = only(&problem.nominal, face);
    let BoundaryValue::Hydrostatic(h) = &mut data.boundary[face].value else {
        panic!("a hydrostatic face")
    };
    h.level = 0.0;
    let dry = problem.elastic.loads(&data, None).unwrap();
    assert!(dry.iter().all(|f| f == &[0.0, 0.0]));
}

/// The level's stencil gives the exact load derivative γ H(y0 − y): on the face d/dy0 of the
/// force γ y0²/2 is γ y0 and of the moment γ y0³/6 is γ y0²/2, at levels splitting an edge, at a
/// node height and at the interval's ends (one-sided points there), to rounding.
#[test]
fn the_level_derivative_of_the_load_is_exact() {
    let v = dam();
    let problem = StateProblem::new(scene(&v)).unwrap();
    let face = index(&v, "face");
    let params = scene_parameters(&problem.scene).unwrap();
    let nominal = only(&problem.nominal, face);
    for level in [20.0, 22.5, 24.0, 25.123, 28.0] {
        let theta = [level, 4.0e5, 1e10];
        let s = parameter_stencil(&problem.scene, &nominal, &params, &theta, 0);
        let mut derivative = [0.0; 4];
        for (_, w, d) in &s.points {
            let r = resultant(
                &problem,
                &problem.elastic.loads(&only(d, face), None).unwrap(),
            );
            for (d, r) in derivative.iter_mut().zip(r) {
                *d += w * r;
            }
        }
        assert!(
            close(derivative[0], GAMMA * level, 1e-12),
            "{level}: {derivative:?}"
        );
        assert!(
            close(derivative[2], GAMMA * level * level / 2.0, 1e-12),
            "{level}"
        );
    }
}

/// The scene with the water level's fields as separate data (each over factor × the interval).
fn unlinked(v: &Value) -> Value {
    let mut u = v.clone();
    let level = u["uncertain"][0].clone();
    let [lo, hi] = [0, 1].map(|k| level["interval"][k].as_f64().unwrap());
    let mut data = vec![json!({"field": level["field"], "interval": [lo, hi]})];
    for d in level["drives"].as_array().unwrap() {
        let c = d["factor"].as_f64().unwrap();
        data.push(json!({"field": d["field"], "interval": [c * lo, c * hi]}));
    }
    data.push(u["uncertain"][1].clone());
    data.push(u["uncertain"][2].clone());
    u["uncertain"] = Value::Array(data);
    u
}

fn sensitivities_at(
    problem: &StateProblem,
    params: &[Parameter],
    theta: &[f64],
) -> (Vec<PerCriterion<Option<f64>>>, PerCriterion<Option<f64>>) {
    let data = apply_parameters(&problem.scene, &problem.nominal, params, theta);
    let stencils: Vec<_> = (0..params.len())
        .map(|j| parameter_stencil(&problem.scene, &problem.nominal, params, theta, j))
        .collect();
    let solution = problem
        .solve_with_sensitivities(&data, &options(problem), &stencils)
        .unwrap();
    assert_eq!(solution.sensitivities.len(), params.len());
    let right = solution
        .sensitivities
        .iter()
        .map(|s| s.map(|d| d.map(|d| d.right)))
        .collect();
    (right, solution.criteria)
}

/// A linked datum's derivative is Σ factor × its fields' derivatives (the same fields as
/// separate data), and equals central differences of whole solves; here the water level drives
/// the uplift on the dam's face of the crack with the factor 0.5 (half the head).
#[test]
fn a_linked_datum_derivative_is_the_factored_sum_of_its_fields() {
    let mut v = dam();
    v["uncertain"][0]["drives"][1]["factor"] = json!(0.5);
    let up_dam = index(&v, "uplift_dam");
    v["boundary"][up_dam]["hydrostatic"]["level"] = json!(13.0);
    let linked = StateProblem::new(scene(&v)).unwrap();
    let p_linked = scene_parameters(&linked.scene).unwrap();
    assert_eq!(p_linked.len(), 3);
    let separate = StateProblem::new(scene(&unlinked(&v))).unwrap();
    let p_separate = scene_parameters(&separate.scene).unwrap();
    assert_eq!(p_separate.len(), 6);
    let theta = [25.37, 4.1e5, 8e9];
    let spread = [25.37, 25.37, 0.5 * 25.37, 25.37, 4.1e5, 8e9];
    let (d_linked, phi) = sensitivities_at(&linked, &p_linked, &theta);
    let (d_separate, phi_separate) = sensitivities_at(&separate, &p_separate, &spread);
    let factors: [&[(usize, f64)]; 2] = [&[(0, 1.0), (1, 1.0), (2, 0.5), (3, 1.0)], &[(4, 1.0)]];
    let mut compared = 0;
    for c in [Criterion::Phi3, Criterion::Phi5, Criterion::Phi6] {
        let i = c as usize;
        let (a, b) = (phi[i].unwrap(), phi_separate[i].unwrap());
        assert!(close(a, b, 1e-9), "{c:?}: {a} {b}");
        for (j, fields) in factors.iter().enumerate() {
            let sum: f64 = fields
                .iter()
                .map(|&(k, f)| f * d_separate[k][i].unwrap())
                .sum();
            let exact = d_linked[j][i].unwrap();
            assert!(
                close(exact, sum, 1e-8),
                "{c:?} datum {j}: {exact:e} vs Σ {sum:e}"
            );
            // Central differences of whole solves, steps h and h/2 agreeing.
            let fd = |h: f64| {
                let at = |t: f64| {
                    let mut moved = theta.to_vec();
                    moved[j] += t;
                    let data = apply_parameters(&linked.scene, &linked.nominal, &p_linked, &moved);
                    linked.solve(&data, &options(&linked)).unwrap().criteria[i].unwrap()
                };
                (at(h) - at(-h)) / (2.0 * h)
            };
            let h = 1e-4 * (p_linked[j].hi - p_linked[j].lo);
            let (d1, d2) = (fd(h), fd(h / 2.0));
            assert!(
                close(d1, d2, 1e-5),
                "{c:?} datum {j}: a kink within ±h ({d1:e}, {d2:e})"
            );
            assert!(
                (exact - d2).abs() <= 1e-6 * d2.abs() + 1e-9 * a.abs(),
                "{c:?} datum {j}: exact {exact:e}, central difference {d2:e}"
            );
            compared += 1;
        }
    }
    assert_eq!(compared, 6);
}

/// The worst-scenario run on the bundled dam: the crest's downstream displacement (Φ3@crest) is
/// worst at the highest water level, and the run certifies it (locally, and the global rule with
/// every vertex screened); no vertex of the box solved on its own is more extreme.
#[test]
fn the_worst_water_level_is_certified() {
    let v = dam();
    let crest = CriterionSpec::parse("phi3@crest").unwrap();
    let request = WorstRequest {
        criteria: Some(vec![crest.clone()]),
        accuracy_refinements: Some(0),
        ..WorstRequest::default()
    };
    let outcome = wsm_core::worst(scene(&v), &request, &RunControl::new()).unwrap();
    let phi3 = &outcome.criteria[0];
    let worst = &phi3.worst;
    let point = worst.point.as_deref().unwrap();
    assert_eq!(point[0], 28.0, "the highest level: {point:?}");
    assert_eq!(
        worst.status,
        Status::LocallyCertified,
        "{:?}",
        worst.certificate
    );
    assert!(worst.global.rule_met, "{:?}", worst.global);
    assert_eq!(worst.global.vertices_screened, 8);
    let problem = StateProblem::new(scene(&v)).unwrap();
    let params = scene_parameters(&problem.scene).unwrap();
    let vertices: Vec<Vec<f64>> = (0..8usize)
        .map(|mask| {
            params
                .iter()
                .enumerate()
                .map(|(i, p)| if mask >> i & 1 == 1 { p.hi } else { p.lo })
                .collect()
        })
        .collect();
    let specs = [crest];
    let evaluator = ScenarioEvaluator::new(&problem, &params, &specs).unwrap();
    let (w, b) = (worst.value.unwrap(), phi3.best.value.unwrap());
    for (theta, e) in vertices.iter().zip(evaluator.evaluate_batch(&vertices)) {
        let phi = e.values.expect("every vertex solves")[0];
        assert!(
            phi <= w + 1e-9 * w.abs() && phi >= b - 1e-9 * b.abs(),
            "{theta:?}: {phi}"
        );
    }
    println!(
        "dam-water-level Φ3@crest: worst {w:e} m at {point:?}, best {b:e} m at {:?}, {} evaluations",
        phi3.best.point, outcome.evaluations
    );
}

/// An edit of the scene document.
type Edit = Box<dyn Fn(&mut Value)>;

fn refusal(v: &Value) -> wsm_core::SceneError {
    let scene = parse_scene(&v.to_string()).and_then(|s| scene_parameters(&s).map(|_| s));
    scene.expect_err("refused")
}

#[test]
fn bad_hydrostatic_and_linked_data_are_refused_naming_the_field() {
    let cases: Vec<(Edit, &str, &str)> = vec![
        (
            Box::new(|v| v["boundary"][3]["hydrostatic"]["unit_weight"] = json!(-1.0)),
            "boundary[3].hydrostatic.unit_weight",
            "must be >= 0",
        ),
        (
            Box::new(|v| v["boundary"][3]["pressure"] = json!(1.0)),
            "boundary[3]",
            "set exactly one of",
        ),
        (
            Box::new(|v| v["uncertain"][0]["drives"][1]["factor"] = json!(0.0)),
            "uncertain[0].drives[1].factor",
            "other than 0",
        ),
        (
            Box::new(|v| v["uncertain"][0]["drives"][1]["factor"] = json!(2.0)),
            "uncertain[0].drives[1].factor",
            "is not factor × the nominal value",
        ),
        (
            Box::new(|v| v["uncertain"][0]["drives"][1]["field"] = json!("boundary[bed].pressure")),
            "uncertain[0].drives[1].field",
            "no such number",
        ),
        (
            Box::new(|v| {
                v["uncertain"][0]["drives"][1]["field"] = json!("boundary[face].hydrostatic.level")
            }),
            "uncertain[0].drives[1].field",
            "already set",
        ),
        (
            Box::new(|v| {
                v["uncertain"][0]["drives"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!({"field": "contacts[joint].slip_limit", "factor": -1.0}))
            }),
            "uncertain[0].drives[3].factor",
            "must be > 0",
        ),
        (
            Box::new(|v| v["uncertain"][0]["interval"] = json!([20, 2e6])),
            "uncertain[0].interval",
            "level of a hydrostatic pressure",
        ),
    ];
    for (edit, path, reason) in cases {
        let mut v = dam();
        edit(&mut v);
        let e = refusal(&v);
        assert_eq!(e.path, path, "{e}");
        assert!(e.reason.contains(reason), "{path}: {}", e.reason);
    }
}
