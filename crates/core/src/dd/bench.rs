//! Benchmarks for `wsm bench dd` (not tests): structured two-block contact problems, PCG1
//! iteration counts of the tied auxiliary problem as the number of subdomains grows at fixed H/h
//! and as H/h grows at a fixed count (balancing NN theory: bounded by C(1 + log(H/h))², D05 §5),
//! and DD solve times on 1 and 2 threads (frictionless interface, so that the tables measure
//! the linear solvers).

use std::io::Write;
use std::time::Instant;

use super::options::{CoarseKind, DdOptions, Pcg1Preconditioner};
use super::successive::solve;
use super::{DdContactPair, DdContactRow, DdError, DdProblem, PartitionRequest};
use crate::fem::{ElasticProblem, Slot};
use crate::fixtures::stacked_blocks;
use crate::scene::{BoundaryData, BoundaryValue, Data, Elastic, Expansion, MaterialData, SlipData};

fn material(e: f64, weight: f64) -> MaterialData {
    MaterialData {
        elastic: Elastic::Young { e, nu: 0.3 },
        specific_weight: weight,
        body_force: [0.0, 0.0],
        conductivity: [1.0, 0.0, 1.0],
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
        friction: vec![None],
        reference_temperature: 0.0,
        dynamic: Default::default(),
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
        DdContactRow {
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
                nodes: nodes.to_vec(),
                normal: row(nodes, [0.0, 1.0], 0.0, f64::INFINITY),
                tangent: row(nodes, [-1.0, 0.0], -gw, gw),
                tied: true,
            }
        })
        .collect();
    DdProblem::from_elastic(&elastic, &coefs, rhs, pairs)
}

/// One DD solve of the two-block problem; returns (DOFs, PCG1, outer, PCG2, subdomains, seconds).
fn run(
    nx: usize,
    subdomains: usize,
    variant: (Pcg1Preconditioner, CoarseKind),
    threads: usize,
) -> Result<[f64; 6], DdError> {
    let problem = two_blocks(nx, 0.0, 0.003)?;
    let options = DdOptions {
        partition: PartitionRequest::Automatic {
            subdomains,
            contact_layers: super::partition::CONTACT_LAYERS,
        },
        pcg1_preconditioner: variant.0,
        coarse: variant.1,
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

/// Our defaults and the papers' preconditioners as printed (D05 §5 / §6).
const DEFAULT: (Pcg1Preconditioner, CoarseKind) = (Pcg1Preconditioner::Reduced, CoarseKind::Rigid);
const PAPER: (Pcg1Preconditioner, CoarseKind) = (Pcg1Preconditioner::Full, CoarseKind::Kernels);

/// Print the scalability tables: PCG1 / PCG2 iterations of our default preconditioners and of
/// the papers' as the subdomain count grows at fixed H/h (mesh refined with the count: about 384
/// elements per subdomain) and as H/h grows at 16 subdomains, with (1 + ln(H/h))² for
/// comparison; then DD times on 1 and 2 threads.
pub fn scalability(out: &mut impl Write) -> Result<(), DdError> {
    let io = |e: std::io::Error| DdError::Input(e.to_string());
    let header = |out: &mut dyn Write, first: &str| {
        writeln!(
            out,
            "{first:>11} {:>8} {:>10} {:>5} {:>5} {:>5} {:>8} {:>11} {:>11}",
            "DOFs", "subdomains", "PCG1", "PCG2", "outer", "time [s]", "PCG1 paper", "PCG2 paper"
        )
    };
    // Total subdomain count, and non-contact subdomains (the contact band is one tied cluster of
    // two more subdomains), both at about 384 elements per subdomain.
    let series_count = [(32, 4), (64, 16), (128, 64), (256, 256)];
    let series_noncontact = [(32, 6), (64, 18), (128, 66), (256, 258)];
    let series_size = [(32, 16), (64, 16), (128, 16), (256, 16)];
    for (title, first, series) in [
        (
            "Iterations vs subdomain count at fixed H/h",
            "requested",
            &series_count[..],
        ),
        (
            "Same with 4 / 16 / 64 / 256 non-contact subdomains (+ 2 forming the contact cluster)",
            "requested",
            &series_noncontact[..],
        ),
        (
            "Iterations vs H/h at 16 subdomains",
            "(1+ln H/h)²",
            &series_size[..],
        ),
    ] {
        writeln!(out, "{title}").map_err(io)?;
        header(out, first).map_err(io)?;
        for &(nx, count) in series {
            let ours = run(nx, count, DEFAULT, 2)?;
            let paper = run(nx, count, PAPER, 2)?;
            let first = if first == "requested" {
                format!("{count}")
            } else {
                // H/h: cells per subdomain side (≈ DOFs / 2 squares of two triangles).
                let h_over_h = (ours[0] / 2.0 / count as f64).sqrt();
                format!("{:.1}", (1.0 + h_over_h.ln()).powi(2))
            };
            writeln!(
                out,
                "{first:>11} {:>8} {:>10} {:>5} {:>5} {:>5} {:>8.3} {:>11} {:>11}",
                ours[0], ours[4], ours[1], ours[3], ours[2], ours[5], paper[1], paper[3]
            )
            .map_err(io)?;
        }
    }
    writeln!(out, "threads: DD time on 1 and 2 threads").map_err(io)?;
    for nx in [96, 288] {
        for threads in [1, 2] {
            let r = run(nx, 16, DEFAULT, threads)?;
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
