//! Benchmarks for `wsm bench dd` (not tests): structured two-block contact problems, PCG1
//! iteration counts of the tied auxiliary problem as the number of subdomains grows at fixed H/h
//! and as H/h grows at a fixed count (balancing NN theory: bounded by C(1 + log(H/h))², D05 §5),
//! and DD solve times on 1 and 2 threads (frictionless interface, so that the tables measure
//! the linear solvers).

use std::io::Write;
use std::time::Instant;

use super::successive::{solve, DdOptions};
use super::{ContactRow, DdContactPair, DdError, DdProblem, PartitionRequest};
use crate::fem::{ElasticProblem, Slot};
use crate::mesh::structured::stacked_blocks;
use crate::scene::{BoundaryData, BoundaryValue, Data, Elastic, Expansion, MaterialData, SlipData};

fn material(e: f64, weight: f64) -> MaterialData {
    MaterialData {
        elastic: Elastic::Young { e, nu: 0.3 },
        specific_weight: weight,
        body_force: [0.0, 0.0],
        conductivity: 1.0,
        heat_source: 0.0,
        expansion: Expansion::Alpha(0.0),
    }
}

/// Two stacked blocks, lower clamped at the bottom, upper pushed down and sideways by a
/// prescribed displacement of its top; Tresca slip limit `g` on the interface.
pub fn two_blocks(nx: usize, g: f64, shear: f64) -> Result<DdProblem, DdError> {
    two_blocks_with(
        nx,
        g,
        BoundaryValue::Displacement([Some(shear), Some(-0.004)]),
    )
}

/// [`two_blocks`] with any condition on the top of the upper block.
pub fn two_blocks_with(nx: usize, g: f64, top: BoundaryValue) -> Result<DdProblem, DdError> {
    let mesh = stacked_blocks(2.0, 1.0, 0.5, nx, nx / 2, nx / 4);
    let seg = |name: &str| mesh.segment_index(name).unwrap_or_default();
    let data = Data {
        materials: vec![material(1.0e4, 10.0), material(2.0e4, 10.0)],
        boundary: vec![
            BoundaryData {
                segment: seg("lower_bottom"),
                value: BoundaryValue::Displacement([Some(0.0), Some(0.0)]),
            },
            BoundaryData {
                segment: seg("upper_top"),
                value: top,
            },
        ],
        slip: vec![SlipData {
            knots: vec![0.0, 1.0],
            values: vec![g, g],
        }],
        reference_temperature: 0.0,
    };
    let elastic = ElasticProblem::new(&mesh, &data)?;
    let coefs = elastic.coefficients(&data)?;
    let rhs = elastic.rhs(&data, None)?;
    let dofs = elastic.dofs();
    let contact = &mesh.contacts[0];
    let top = &mesh.segments[contact.segment_k];
    let mut weight = vec![0.0; mesh.nodes.len()];
    for &[a, b] in &top.edges {
        let h = 0.5 * (mesh.nodes[b][0] - mesh.nodes[a][0]).abs();
        weight[a] += h;
        weight[b] += h;
    }
    let row = |nodes: [usize; 2], v: [f64; 2], lower: f64, upper: f64| {
        let mut entries = Vec::new();
        for (node, sign) in [(nodes[0], 1.0), (nodes[1], -1.0)] {
            let basis = dofs.basis(node);
            for (c, slot) in dofs.slots(node).into_iter().enumerate() {
                if let Slot::Free(i) = slot {
                    entries.push((i, sign * (v[0] * basis[c][0] + v[1] * basis[c][1])));
                }
            }
        }
        ContactRow {
            entries,
            value: 0.0,
            lower,
            upper,
        }
    };
    let pairs = contact
        .pairs
        .iter()
        .map(|&nodes| {
            let gw = g * weight[nodes[0]];
            DdContactPair {
                nodes,
                normal: row(nodes, [0.0, 1.0], 0.0, f64::INFINITY),
                tangent: row(nodes, [-1.0, 0.0], -gw, gw),
            }
        })
        .collect();
    DdProblem::from_elastic(&elastic, &coefs, rhs, pairs)
}

/// One DD solve of the two-block problem; returns (DOFs, PCG1, outer, PCG2, subdomains, seconds).
fn run(nx: usize, request: PartitionRequest, threads: usize) -> Result<[f64; 6], DdError> {
    let problem = two_blocks(nx, 0.0, 0.003)?;
    let options = DdOptions {
        partition: request,
        outer_tol: 1e-6,
        ..DdOptions::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| DdError::Input(e.to_string()))?;
    let t = Instant::now();
    let sol = pool.install(|| solve(&problem, &options, None))?;
    let r = &sol.report;
    Ok([
        r.n_dofs as f64,
        r.pcg1_iterations as f64,
        r.outer_iterations as f64,
        r.pcg2_iterations as f64,
        r.n_subdomains as f64,
        t.elapsed().as_secs_f64(),
    ])
}

/// Print the scalability tables.
pub fn scalability(out: &mut impl Write) -> Result<(), DdError> {
    let io = |e: std::io::Error| DdError::Input(e.to_string());
    writeln!(
        out,
        "PCG1 vs subdomain count at fixed H/h (about 32 elements per subdomain side)"
    )
    .map_err(io)?;
    writeln!(
        out,
        "{:>8} {:>11} {:>6} {:>6} {:>6} {:>9}",
        "DOFs", "subdomains", "PCG1", "outer", "PCG2", "time [s]"
    )
    .map_err(io)?;
    let requests = [
        (
            "",
            PartitionRequest::BySize {
                elements: 512,
                contact_layers: 2,
            },
        ),
        (
            "PCG1 vs H/h at 16 subdomains",
            PartitionRequest::Automatic {
                subdomains: 16,
                contact_layers: 2,
            },
        ),
    ];
    for (title, request) in requests {
        if !title.is_empty() {
            writeln!(out, "{title}").map_err(io)?;
        }
        for nx in [32, 64, 128] {
            let r = run(nx, request.clone(), 2)?;
            writeln!(
                out,
                "{:>8} {:>11} {:>6} {:>6} {:>6} {:>9.3}",
                r[0], r[4], r[1], r[2], r[3], r[5]
            )
            .map_err(io)?;
        }
    }
    writeln!(out, "threads: DD time on 1 and 2 threads").map_err(io)?;
    for nx in [96, 288] {
        for threads in [1, 2] {
            let r = run(
                nx,
                PartitionRequest::Automatic {
                    subdomains: 16,
                    contact_layers: 2,
                },
                threads,
            )?;
            writeln!(
                out,
                "{:>8} DOFs, {threads} thread(s): {:.3} s ({} outer)",
                r[0], r[5], r[2]
            )
            .map_err(io)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    #[ignore = "benchmark: run with --ignored --nocapture"]
    fn print_scalability_tables() {
        super::scalability(&mut std::io::stdout()).expect("bench");
    }
}
