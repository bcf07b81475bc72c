//! `POST /v1/solve` of a dynamic scene (design §3.5) against a real `wsm serve`: the history's
//! arrays have one entry per output time, the displacement frames are at those times on the
//! fields' nodes and agree with the receivers' histories (P1 interpolation at the receiver,
//! computed here from the frames) and, at t = 0, with the static start; frames of a static scene
//! and frames beyond the server's field cap are refused with 422 naming `settings.frames`.

mod common;

use common::{post, temp_db, Server};
use serde_json::{json, Value};

const EXAMPLE: &str = "implant-impact";

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn pairs(v: &Value) -> Vec<[f64; 2]> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let p = numbers(p);
            [p[0], p[1]]
        })
        .collect()
}

/// The P1 interpolation of a nodal field at `point`: the first triangle containing it
/// (barycentric weights ≥ −1e-12).
fn interpolate(
    nodes: &[[f64; 2]],
    triangles: &[[usize; 3]],
    field: &[[f64; 2]],
    point: [f64; 2],
) -> [f64; 2] {
    for t in triangles {
        let [a, b, c] = t.map(|k| nodes[k]);
        let det = (b[1] - c[1]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[1] - c[1]);
        let l1 = ((b[1] - c[1]) * (point[0] - c[0]) + (c[0] - b[0]) * (point[1] - c[1])) / det;
        let l2 = ((c[1] - a[1]) * (point[0] - c[0]) + (a[0] - c[0]) * (point[1] - c[1])) / det;
        let w = [l1, l2, 1.0 - l1 - l2];
        if w.iter().all(|&x| x >= -1e-12) {
            return [0, 1].map(|i| (0..3).map(|j| w[j] * field[t[j]][i]).sum());
        }
    }
    panic!("no triangle holds {point:?}");
}

fn largest(field: &[[f64; 2]]) -> f64 {
    field.iter().fold(0.0_f64, |m, u| m.max(u[0].hypot(u[1])))
}

#[test]
fn a_dynamic_solve_returns_consistent_histories_and_frames() {
    let db = temp_db("dynamic.db");
    let server = Server::start(&db, &[]);
    let addr = &server.addr;
    let body = json!({"example": EXAMPLE, "settings": {"fields": true, "frames": true}});
    let reply = post(addr, "/v1/solve", &body);
    assert_eq!(
        reply.status,
        200,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    let out = reply.json();
    let history = &out["summary"]["history"];
    let times = numbers(&history["times"]);
    let n = times.len();
    let scene: Value = serde_json::from_str(wsm_core::example(EXAMPLE).unwrap()).unwrap();
    let dynamics = &scene["dynamics"];
    let (t_end, dt) = (
        dynamics["t_end"].as_f64().unwrap(),
        dynamics["dt"].as_f64().unwrap(),
    );
    let every = dynamics["output_every"].as_f64().unwrap();
    // t = 0, every output_every steps, the last step at t_end.
    assert_eq!(times[0], 0.0);
    assert!((times[n - 1] - t_end).abs() <= 1e-9 * t_end, "{times:?}");
    for w in times.windows(2) {
        let gap = w[1] - w[0];
        assert!(gap > 0.0 && gap <= every * dt * (1.0 + 1e-9), "{w:?}");
    }
    assert_eq!(n, (t_end / (every * dt)).round() as usize + 1);

    // Every history array: one entry per output time.
    let receivers = history["receivers"].as_object().unwrap();
    assert!(!receivers.is_empty());
    for r in receivers.values() {
        for key in ["displacement", "velocity", "acceleration"] {
            assert_eq!(r[key].as_array().unwrap().len(), n, "{key}");
        }
    }
    let zones = history["contact_zones"].as_object().unwrap();
    assert!(!zones.is_empty());
    for z in zones.values() {
        for key in [
            "normal_force",
            "tangential_force",
            "open",
            "stick",
            "slip",
            "max_slip",
            "max_slip_rate",
        ] {
            assert_eq!(z[key].as_array().unwrap().len(), n, "{key}");
        }
    }
    let bodies = history["bodies"].as_object().unwrap();
    assert!(!bodies.is_empty());
    for b in bodies.values() {
        assert_eq!(b["mean_velocity"].as_array().unwrap().len(), n);
    }
    for (key, values) in history["energy"].as_object().unwrap() {
        assert_eq!(values.as_array().unwrap().len(), n, "energy.{key}");
    }

    // The frames: at the output times, on the fields' nodes.
    let fields = &out["fields"];
    let nodes = pairs(&fields["nodes"]);
    let triangles: Vec<[usize; 3]> = fields["triangles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let t: Vec<usize> = t
                .as_array()
                .unwrap()
                .iter()
                .map(|k| k.as_u64().unwrap() as usize)
                .collect();
            [t[0], t[1], t[2]]
        })
        .collect();
    let frames = out["frames"].as_array().unwrap();
    assert_eq!(frames.len(), n);
    let frames: Vec<(f64, Vec<[f64; 2]>)> = frames
        .iter()
        .map(|f| (f["time"].as_f64().unwrap(), pairs(&f["displacement"])))
        .collect();
    let scale = frames.iter().map(|(_, u)| largest(u)).fold(0.0, f64::max);
    assert!(scale > 0.0);
    // The run moves: frames differ from the first one.
    assert!(frames
        .iter()
        .any(|(_, u)| (largest(u) - largest(&frames[0].1)).abs() > 1e-3 * scale));
    let mut worst = 0.0_f64;
    for (k, (time, u)) in frames.iter().enumerate() {
        assert_eq!(*time, times[k]);
        assert_eq!(u.len(), nodes.len());
        // The receivers' displacement is the P1 interpolation of the frame at the receiver.
        for r in receivers.values() {
            let point = pairs(&json!([r["point"]]))[0];
            let at = interpolate(&nodes, &triangles, u, point);
            let recorded = pairs(&r["displacement"])[k];
            worst = worst.max((at[0] - recorded[0]).hypot(at[1] - recorded[1]));
        }
    }
    eprintln!(
        "largest |u| over the frames {scale:.3e} m; receivers against the frames: {worst:.3e} m"
    );
    assert!(worst <= 1e-12 * scale, "{worst:e} against {scale:e}");
    // `initial: static`: the first frame is the static solve at t = 0 that the fields show.
    assert_eq!(dynamics["initial"], "static");
    let start = pairs(&fields["displacement"]);
    let gap = start
        .iter()
        .zip(&frames[0].1)
        .fold(0.0_f64, |m, (a, b)| m.max((a[0] - b[0]).hypot(a[1] - b[1])));
    eprintln!(
        "first frame against the static fields: {gap:.3e} m (|u| up to {:.3e} m)",
        largest(&start)
    );
    assert!(gap <= 1e-8 * largest(&start), "{gap:e}");

    // Without frames: the same history, no frames.
    let plain = post(addr, "/v1/solve", &json!({"example": EXAMPLE})).json();
    assert!(plain.get("frames").is_none() && plain.get("fields").is_none());
    assert_eq!(plain["summary"]["history"]["times"], history["times"]);
    assert_eq!(
        plain["summary"]["history"]["receivers"],
        history["receivers"]
    );
}

#[test]
fn frames_of_a_static_scene_or_beyond_the_cap_are_refused_naming_the_option() {
    let db = temp_db("dynamic-cap.db");
    // A cap above the example's 5,132 triangles (fields alone pass) but below its frames
    // (41 output times × 5,132 / 12 ≈ 17,500 field triangles).
    let server = Server::start(&db, &["--max-field-triangles", "10000"]);
    let addr = &server.addr;
    let refused = post(
        addr,
        "/v1/solve",
        &json!({"example": "block-on-base", "settings": {"fields": true, "frames": true}}),
    );
    assert_eq!(refused.status, 422);
    let error = refused.json();
    assert_eq!(error["path"], "settings.frames", "{error}");
    assert!(error["detail"].as_str().unwrap().contains("dynamics"));

    let started = std::time::Instant::now();
    let over = post(
        addr,
        "/v1/solve",
        &json!({"example": EXAMPLE, "settings": {"fields": true, "frames": true}}),
    );
    assert_eq!(over.status, 422);
    let error = over.json();
    assert_eq!(error["path"], "settings.frames", "{error}");
    let detail = error["detail"].as_str().unwrap();
    assert!(
        detail.contains("--max-field-triangles") && detail.contains("output_every"),
        "{detail}"
    );
    // Refused before the time loop runs.
    assert!(
        started.elapsed().as_secs_f64() < 2.0,
        "{:?}",
        started.elapsed()
    );
    let fields_only = post(
        addr,
        "/v1/solve",
        &json!({"example": EXAMPLE, "settings": {"fields": true}}),
    );
    assert_eq!(fields_only.status, 200);
    assert!(fields_only.json().get("frames").is_none());
}
