//! JSON and VTU renderings of a state solution: a short summary (criteria, sizes, report) for
//! stdout and the full result (fields, contact results) for files.

use serde_json::{json, Value};

use super::vtu::{write_vtu, Field};
use crate::scene::Criterion;
use crate::state::{piece_pressures, zone_summaries, ContactState, Solution, StateProblem};

/// Criteria as a JSON object `{"phi1": value or null, ...}`.
pub fn criteria_json(values: &[Option<f64>; 6]) -> Value {
    Value::Object(
        Criterion::ALL
            .iter()
            .zip(values)
            .map(|(c, v)| (c.name().to_string(), json!(v)))
            .collect(),
    )
}

/// The summary printed by `wsm solve`.
pub fn summary(problem: &StateProblem, solution: &Solution) -> Value {
    let stats = crate::mesh::stats(problem.mesh());
    json!({
        "scene": problem.scene.name,
        "mesh": {
            "nodes": stats.nodes,
            "triangles": stats.triangles,
            "min_angle_deg": stats.min_angle_deg,
            "unknowns": solution.report.unknowns,
            "contact_pairs": solution.report.contact_pairs,
        },
        "criteria": criteria_json(&solution.criteria),
        "contact_zones": zone_summaries(
            &problem.scene.contacts.iter().map(|c| c.name.clone()).collect::<Vec<_>>(),
            &problem.contact.geometry,
            &solution.contact,
        ),
        "piece_contact_pressure": piece_pressures(
            &problem.criteria.pieces,
            &problem.contact.geometry,
            &solution.contact,
            problem.mesh().nodes.len(),
        )
        .into_iter()
        .filter_map(|(name, p)| p.map(|p| (name, json!(p))))
        .collect::<serde_json::Map<String, Value>>(),
        "report": solution.report,
        "setup_seconds": problem.setup_seconds,
    })
}

/// The full result: summary plus nodal and element fields and contact results.
pub fn full(problem: &StateProblem, solution: &Solution) -> Value {
    let mut out = summary(problem, solution);
    let mesh = problem.mesh();
    out["fields"] = json!({
        "nodes": mesh.nodes,
        "triangles": mesh.triangles,
        "displacement": solution.displacement,
        "temperature": solution.temperature,
        "stress": solution.stresses.iter().map(|s| s.stress).collect::<Vec<_>>(),
        "i2_squared": solution.stresses.iter().map(|s| s.i2_squared()).collect::<Vec<_>>(),
    });
    out["contact"] = json!(solution.contact);
    out
}

/// A VTU file with displacement, temperature, stresses, I2², zones and contact results.
pub fn vtu(problem: &StateProblem, solution: &Solution) -> String {
    let mesh = problem.mesh();
    let n = mesh.nodes.len();
    let mut points = Vec::new();
    if !solution.displacement.is_empty() {
        points.push(Field {
            name: "displacement",
            components: 3,
            values: solution
                .displacement
                .iter()
                .flat_map(|u| [u[0], u[1], 0.0])
                .collect(),
        });
    }
    if let Some(t) = &solution.temperature {
        points.push(Field {
            name: "temperature",
            components: 1,
            values: t.clone(),
        });
    }
    if !solution.contact.is_empty() {
        let mut pressure = vec![0.0; n];
        let mut shear = vec![0.0; n];
        let mut gap = vec![0.0; n];
        let mut state = vec![-1.0; n];
        for (c, pair) in solution.contact.iter().zip(&problem.contact.geometry.pairs) {
            for node in pair.nodes {
                pressure[node] = c.pressure;
                shear[node] = c.shear;
                gap[node] = c.gap;
                state[node] = match c.state {
                    ContactState::Open => 0.0,
                    ContactState::Stick => 1.0,
                    ContactState::Slip => 2.0,
                };
            }
        }
        points.push(Field {
            name: "contact_pressure",
            components: 1,
            values: pressure,
        });
        points.push(Field {
            name: "contact_shear",
            components: 1,
            values: shear,
        });
        points.push(Field {
            name: "contact_gap",
            components: 1,
            values: gap,
        });
        points.push(Field {
            name: "contact_state",
            components: 1,
            values: state,
        });
    }
    let mut cells = vec![Field {
        name: "zone",
        components: 1,
        values: mesh.triangle_zone.iter().map(|&z| z as f64).collect(),
    }];
    if !solution.stresses.is_empty() {
        for (k, name) in ["stress_xx", "stress_yy", "stress_xy", "stress_zz"]
            .into_iter()
            .enumerate()
        {
            cells.push(Field {
                name,
                components: 1,
                values: solution.stresses.iter().map(|s| s.stress[k]).collect(),
            });
        }
        cells.push(Field {
            name: "i2_squared",
            components: 1,
            values: solution.stresses.iter().map(|s| s.i2_squared()).collect(),
        });
    }
    write_vtu(mesh, &points, &cells)
}
