//! The grid of one state solution for ParaView, PyVista and meshio (design §5.6): the mesh's
//! triangles with the element stresses and their measures, the contact zones as line cells
//! carrying the contact results, and field data naming the scene, the scenario and its data.
//!
//! Contact lines: every contact pair (a node of body k, the first side of its zone) owns half
//! of each edge of body k's contact segment at that node, the share its contact force is lumped
//! on (design §2.4). Each half-edge is one `VTK_LINE` from the node to the edge's midpoint (a
//! point added after the mesh nodes) carrying its pair's values, so a pair's values are shown
//! along its share of the zone and never spread into the triangles.
//!
//! Every cell carries every cell array: the triangle arrays are NaN (integers −1) on the lines,
//! and the contact arrays NaN (−1) on the triangles; `body_id` is set on both (a line's body is
//! its pair's body k).
//!
//! A state of a dynamic run (design §3.5, one file of the VTU series) adds its [`Motion`]: the
//! nodal `velocity`, and the peak-over-time fields up to its time, `peak_displacement` (max |u|,
//! nodal), `peak_i2_squared` (triangles) and `peak_contact_pressure` (contact lines).

use std::collections::HashMap;

use super::vtu::{CellKind, DataArray, Grid};
use crate::fem::stress_measures::{principal, tensor6, von_mises};
use crate::mesh::Mesh;
use crate::state::{ContactState, Solution, StateProblem};

/// What a file holds: the scenario and its data, written as field data.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioLabel {
    /// `nominal`, `worst`, `best`, or `data` (values given by the caller).
    pub scenario: String,
    /// The criterion whose worst or best scenario it is (`phi3`, `phi3@crest`).
    pub criterion: Option<String>,
    /// That criterion's value found by the search, in its unit.
    pub criterion_value: Option<f64>,
    /// The value of every uncertain parameter by name, in the units of its field.
    pub data: Vec<(String, f64)>,
}

/// The codes of `contact_state`, as written in the field data `contact_state_legend`.
pub const CONTACT_STATE_LEGEND: &str = "-1 no contact cell\n0 open\n1 stick\n2 slip";

fn state_code(state: ContactState) -> i32 {
    match state {
        ContactState::Open => 0,
        ContactState::Stick => 1,
        ContactState::Slip => 2,
    }
}

/// One contact line cell: its two points and the index of its pair in the solution.
struct ContactLine {
    points: [usize; 2],
    pair: usize,
}

/// What a state of a dynamic run adds to its grid.
#[derive(Debug, Clone, Copy)]
pub struct Motion<'a> {
    /// Nodal velocity \[m/s\].
    pub velocity: &'a [[f64; 2]],
    /// max |u| per node up to the state's time \[m\].
    pub peak_displacement: &'a [f64],
    /// max I2² per element up to the state's time \[Pa²\].
    pub peak_i2_squared: &'a [f64],
    /// max contact pressure per pair up to the state's time \[Pa\].
    pub peak_contact_pressure: &'a [f64],
}

/// The grid of `solution` labelled with `label`.
pub fn solution_grid(problem: &StateProblem, solution: &Solution, label: &ScenarioLabel) -> Grid {
    state_grid(problem, solution, label, None)
}

/// The grid of `solution` labelled with `label`, with a dynamic state's `motion`.
pub fn state_grid(
    problem: &StateProblem,
    solution: &Solution,
    label: &ScenarioLabel,
    motion: Option<&Motion>,
) -> Grid {
    let mesh = problem.mesh();
    let mut grid = Grid {
        points: mesh.nodes.iter().map(|p| [p[0], p[1], 0.0]).collect(),
        ..Grid::default()
    };
    // Midpoint edges: (a, b) of each new point, for the nodal fields' interpolation.
    let mut midpoints: Vec<[usize; 2]> = Vec::new();
    let lines = if solution.contact.is_empty() {
        Vec::new()
    } else {
        contact_lines(problem, &mut midpoints)
    };
    for &[a, b] in &midpoints {
        let (pa, pb) = (mesh.nodes[a], mesh.nodes[b]);
        grid.points
            .push([0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.0]);
    }
    for t in &mesh.triangles {
        grid.push_cell(CellKind::Triangle, t);
    }
    for line in &lines {
        grid.push_cell(CellKind::Line, &line.points);
    }
    grid.point_data = point_data(solution, &midpoints);
    if let Some(m) = motion {
        let v = on_points(m.velocity, &midpoints, |a, b| {
            [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]
        });
        grid.point_data.push(DataArray::float(
            "velocity",
            3,
            v.iter().flat_map(|v| [v[0], v[1], 0.0]).collect(),
        ));
        // A midpoint's peak is its ends' mean (a P1 reading of the nodal peaks).
        let peak = on_points(m.peak_displacement, &midpoints, |a, b| 0.5 * (a + b));
        grid.point_data
            .push(DataArray::float("peak_displacement", 1, peak));
    }
    let pairs = &problem.contact.geometry.pairs;
    let line_bodies: Vec<usize> = lines
        .iter()
        .map(|l| mesh.node_body[pairs[l.pair].nodes[0]])
        .collect();
    grid.cell_data = triangle_data(mesh, solution, &line_bodies);
    if let Some(m) = motion {
        let values = m
            .peak_i2_squared
            .iter()
            .copied()
            .chain(std::iter::repeat_n(f64::NAN, lines.len()))
            .collect();
        grid.cell_data
            .push(DataArray::float("peak_i2_squared", 1, values));
    }
    if !lines.is_empty() {
        grid.cell_data
            .extend(contact_data(problem, solution, &lines));
        if let Some(m) = motion {
            let values = std::iter::repeat_n(f64::NAN, mesh.triangles.len())
                .chain(lines.iter().map(|l| m.peak_contact_pressure[l.pair]))
                .collect();
            grid.cell_data
                .push(DataArray::float("peak_contact_pressure", 1, values));
        }
    }
    grid.field_data = field_data(problem, label);
    grid
}

/// The line cells of every contact zone; new midpoints are appended to `midpoints` and numbered
/// after the mesh nodes.
fn contact_lines(problem: &StateProblem, midpoints: &mut Vec<[usize; 2]>) -> Vec<ContactLine> {
    let mesh = problem.mesh();
    let pairs = &problem.contact.geometry.pairs;
    let mut lines = Vec::new();
    let mut first = 0;
    for zone in &mesh.contacts {
        let pair_of: HashMap<usize, usize> = (first..first + zone.pairs.len())
            .map(|p| (pairs[p].nodes[0], p))
            .collect();
        first += zone.pairs.len();
        for &[a, b] in &mesh.segments[zone.segment_k].edges {
            let (pa, pb) = (pair_of.get(&a), pair_of.get(&b));
            if pa.is_none() && pb.is_none() {
                continue;
            }
            let mid = mesh.nodes.len() + midpoints.len();
            midpoints.push([a, b]);
            for (node, pair) in [(a, pa), (b, pb)] {
                if let Some(&pair) = pair {
                    lines.push(ContactLine {
                        points: [node, mid],
                        pair,
                    });
                }
            }
        }
    }
    lines
}

/// A nodal field on every point: the mesh nodes' values, then the midpoints' (the mean of
/// their edge's ends, exact for P1).
fn on_points<T: Copy>(nodal: &[T], midpoints: &[[usize; 2]], mean: impl Fn(T, T) -> T) -> Vec<T> {
    let mut values = nodal.to_vec();
    values.extend(midpoints.iter().map(|&[a, b]| mean(nodal[a], nodal[b])));
    values
}

fn point_data(solution: &Solution, midpoints: &[[usize; 2]]) -> Vec<DataArray> {
    let mut arrays = Vec::new();
    if !solution.displacement.is_empty() {
        let u = on_points(&solution.displacement, midpoints, |a, b| {
            [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]
        });
        arrays.push(DataArray::float(
            "displacement",
            3,
            u.iter().flat_map(|u| [u[0], u[1], 0.0]).collect(),
        ));
    }
    if let Some(t) = &solution.temperature {
        let t = on_points(t, midpoints, |a, b| 0.5 * (a + b));
        arrays.push(DataArray::float("temperature", 1, t));
    }
    arrays
}

/// The triangles' arrays, padded for the contact lines after them (of bodies `line_bodies`):
/// `body_id` is set on every cell, the rest NaN or −1 on the lines.
fn triangle_data(mesh: &Mesh, solution: &Solution, line_bodies: &[usize]) -> Vec<DataArray> {
    let lines = line_bodies.len();
    let id = |i: usize| i32::try_from(i).unwrap_or(i32::MAX);
    let ids = |values: Vec<i32>| {
        values
            .into_iter()
            .chain(std::iter::repeat_n(-1, lines))
            .collect()
    };
    let pad = |values: Vec<f64>, components: usize| {
        values
            .into_iter()
            .chain(std::iter::repeat_n(f64::NAN, components * lines))
            .collect::<Vec<f64>>()
    };
    let mut arrays = vec![
        DataArray::int(
            "zone_id",
            ids(mesh.triangle_zone.iter().map(|&z| id(z)).collect()),
        ),
        DataArray::int(
            "body_id",
            mesh.triangle_zone
                .iter()
                .map(|&z| id(mesh.zones[z].body))
                .chain(line_bodies.iter().map(|&b| id(b)))
                .collect(),
        ),
    ];
    if solution.stresses.is_empty() {
        return arrays;
    }
    let stress: Vec<[f64; 4]> = solution.stresses.iter().map(|s| s.stress).collect();
    let principal: Vec<_> = stress.iter().map(|&s| principal(s)).collect();
    let scalar = |name: &str, f: &dyn Fn(usize) -> f64| {
        DataArray::float(name, 1, pad((0..stress.len()).map(f).collect(), 1))
    };
    arrays.push(DataArray::float(
        "stress",
        6,
        pad(stress.iter().flat_map(|&s| tensor6(s)).collect(), 6),
    ));
    arrays.push(scalar("i2_squared", &|e| solution.stresses[e].i2_squared()));
    arrays.push(scalar("von_mises", &|e| von_mises(stress[e])));
    arrays.push(scalar("principal_stress_1", &|e| principal[e].sigma1));
    arrays.push(scalar("principal_stress_2", &|e| principal[e].sigma2));
    arrays.push(scalar("principal_stress_3", &|e| principal[e].sigma3));
    arrays.push(DataArray::float(
        "principal_direction_1",
        3,
        pad(principal.iter().flat_map(|p| p.direction).collect(), 3),
    ));
    arrays
}

/// The contact lines' arrays, padded for the triangles before them.
fn contact_data(
    problem: &StateProblem,
    solution: &Solution,
    lines: &[ContactLine],
) -> Vec<DataArray> {
    let mesh = problem.mesh();
    let triangles = mesh.triangles.len();
    let float = |name: &str, f: &dyn Fn(usize) -> f64| {
        let values = std::iter::repeat_n(f64::NAN, triangles)
            .chain(lines.iter().map(|l| f(l.pair)))
            .collect();
        DataArray::float(name, 1, values)
    };
    let int = |name: &str, f: &dyn Fn(usize) -> usize| {
        let values = std::iter::repeat_n(-1, triangles)
            .chain(
                lines
                    .iter()
                    .map(|l| i32::try_from(f(l.pair)).unwrap_or(i32::MAX)),
            )
            .collect();
        DataArray::int(name, values)
    };
    let contact = &solution.contact;
    let pairs = &problem.contact.geometry.pairs;
    let state = std::iter::repeat_n(-1, triangles)
        .chain(lines.iter().map(|l| state_code(contact[l.pair].state)))
        .collect();
    vec![
        float("contact_pressure", &|p| contact[p].pressure),
        float("contact_shear", &|p| contact[p].shear),
        float("contact_gap", &|p| contact[p].gap),
        float("contact_slip", &|p| contact[p].slip),
        DataArray::int("contact_state", state),
        int("contact_zone_id", &|p| pairs[p].zone),
        int("contact_pair", &|p| p),
    ]
}

fn field_data(problem: &StateProblem, label: &ScenarioLabel) -> Vec<DataArray> {
    let mesh = problem.mesh();
    let names = |list: Vec<&str>| list.join("\n");
    let mut arrays = vec![
        DataArray::text("wsm_version", env!("CARGO_PKG_VERSION")),
        DataArray::text("scene", &problem.scene.name),
        DataArray::text("scenario", &label.scenario),
    ];
    if let Some(criterion) = &label.criterion {
        arrays.push(DataArray::text("criterion", criterion));
    }
    if let Some(value) = label.criterion_value {
        arrays.push(DataArray::float("criterion_value", 1, vec![value]));
    }
    for (name, value) in &label.data {
        arrays.push(DataArray::float(&format!("data:{name}"), 1, vec![*value]));
    }
    arrays.push(DataArray::text(
        "zone_names",
        &names(mesh.zones.iter().map(|z| z.name.as_str()).collect()),
    ));
    arrays.push(DataArray::text(
        "body_names",
        &names(mesh.bodies.iter().map(String::as_str).collect()),
    ));
    if !mesh.contacts.is_empty() {
        arrays.push(DataArray::text(
            "contact_zone_names",
            &names(mesh.contacts.iter().map(|c| c.name.as_str()).collect()),
        ));
        arrays.push(DataArray::text(
            "contact_state_legend",
            CONTACT_STATE_LEGEND,
        ));
    }
    arrays
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::vtu::Values;
    use crate::state::{Needs, SolveOptions};

    fn floats<'a>(arrays: &'a [DataArray], name: &str) -> &'a [f64] {
        match &arrays.iter().find(|a| a.name == name).expect(name).values {
            Values::Float64(v) => v,
            _ => panic!("{name} is not Float64"),
        }
    }

    fn ints<'a>(arrays: &'a [DataArray], name: &str) -> &'a [i32] {
        match &arrays.iter().find(|a| a.name == name).expect(name).values {
            Values::Int32(v) => v,
            _ => panic!("{name} is not Int32"),
        }
    }

    #[test]
    fn contact_lines_cover_each_pairs_share_with_its_values() {
        let scene = crate::scene::parse(crate::bundled::find("block-on-base").unwrap()).unwrap();
        let problem = StateProblem::new(scene).unwrap();
        let options = SolveOptions {
            needs: Needs::all(&problem.scene),
            par: crate::fem::Par::Seq,
            warm: None,
        };
        let solution = problem.solve(&problem.nominal, &options).unwrap();
        let label = ScenarioLabel {
            scenario: "nominal".into(),
            criterion: None,
            criterion_value: None,
            data: vec![],
        };
        let grid = solution_grid(&problem, &solution, &label);
        let triangles = problem.mesh().triangles.len();
        let pairs = &problem.contact.geometry.pairs;
        assert!(!pairs.is_empty());
        let cells = grid.cell_kinds.len();
        assert!(grid.cell_kinds[..triangles]
            .iter()
            .all(|&k| k == CellKind::Triangle));
        assert!(grid.cell_kinds[triangles..]
            .iter()
            .all(|&k| k == CellKind::Line));
        for array in &grid.cell_data {
            assert_eq!(array.tuples(), cells, "{}", array.name);
        }
        for array in &grid.point_data {
            assert_eq!(array.tuples(), grid.points.len(), "{}", array.name);
        }
        // Each pair's lines add up to its nodal share of the contact length (the weight its
        // friction is lumped with) and carry its values.
        let pair = ints(&grid.cell_data, "contact_pair");
        let pressure = floats(&grid.cell_data, "contact_pressure");
        let mut length = vec![0.0; pairs.len()];
        for (c, &p) in pair.iter().enumerate().skip(triangles) {
            let p = usize::try_from(p).unwrap();
            let nodes = &grid.connectivity[3 * triangles + 2 * (c - triangles)..][..2];
            let (a, b) = (grid.points[nodes[0]], grid.points[nodes[1]]);
            length[p] += (b[0] - a[0]).hypot(b[1] - a[1]);
            assert_eq!(pressure[c], solution.contact[p].pressure);
        }
        for (p, share) in pairs.iter().zip(&length) {
            assert!(
                (share - p.weight).abs() <= 1e-12 * p.weight.max(1.0),
                "{share} vs {}",
                p.weight
            );
        }
        // Triangles carry no contact values, lines no stresses.
        assert!(pressure[..triangles].iter().all(|v| v.is_nan()));
        let von_mises = floats(&grid.cell_data, "von_mises");
        assert!(von_mises[triangles..].iter().all(|v| v.is_nan()));
        assert!(von_mises[..triangles]
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0));
    }
}
