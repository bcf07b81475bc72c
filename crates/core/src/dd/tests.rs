//! DD vs a monolithic solve on small two-block problems: the whole condensed contact system
//! C = B K⁻¹ Bᵀ solved by the same contact kernel.

use faer::Mat;

use super::bench::{two_blocks, two_blocks_with};
use super::options::Weights;
use super::successive::{solve, DirectAnswer};
use super::*;
use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions};
use crate::scene::BoundaryValue;

/// Monolithic reference: K factorised, the whole contact problem condensed and solved.
pub(crate) fn direct(problem: &DdProblem) -> DirectAnswer {
    let n = problem.n_dofs();
    let mut trips = Vec::new();
    for el in &problem.elements {
        for i in 0..6 {
            for j in 0..6 {
                if let (Some(a), Some(b)) = (el.dofs[i], el.dofs[j]) {
                    trips.push((a, b, el.matrix[i][j]));
                }
            }
        }
    }
    let k = subdomain::Csr::from_triplets(n, trips);
    let none = Mat::<f64>::zeros(n, 0);
    let factor = subdomain::KernelFactor::new(&k, n, none.as_ref()).expect("K SPD");
    let rows: Vec<&DdContactRow> = problem
        .pairs
        .iter()
        .flat_map(|p| [&p.normal, &p.tangent])
        .collect();
    let m = rows.len();
    let bt = Mat::from_fn(n, m, |i, j| {
        rows[j]
            .entries
            .iter()
            .filter(|e| e.0 == i)
            .map(|e| e.1)
            .sum()
    });
    let x = factor.solve_mat(bt.as_ref());
    let dot = |r: &DdContactRow, v: &dyn Fn(usize) -> f64| -> f64 {
        r.entries.iter().map(|&(i, a)| a * v(i)).sum()
    };
    let c = Mat::from_fn(m, m, |i, j| {
        0.5 * (dot(rows[i], &|p| x[(p, j)]) + dot(rows[j], &|p| x[(p, i)]))
    });
    let w = factor.solve(&problem.rhs);
    let d = rows.iter().map(|r| dot(r, &|p| w[p]) - r.value).collect();
    let qp = BoxQp::new(
        c,
        d,
        rows.iter().map(|r| r.lower).collect(),
        rows.iter().map(|r| r.upper).collect(),
    );
    let sol = solve_box_qp(&qp, None, &QpOptions::default()).expect("QP");
    let mut u = w;
    for (j, &l) in sol.x.iter().enumerate() {
        for (i, ui) in u.iter_mut().enumerate() {
            *ui -= x[(i, j)] * l;
        }
    }
    DirectAnswer {
        u,
        multipliers: sol.x.chunks(2).map(|c| [c[0], c[1]]).collect(),
    }
}

/// open / stick / slip per pair.
pub(crate) fn states(problem: &DdProblem, multipliers: &[[f64; 2]]) -> Vec<u8> {
    let scale = multipliers
        .iter()
        .map(|m| m[0].abs())
        .fold(f64::MIN_POSITIVE, f64::max);
    problem
        .pairs
        .iter()
        .zip(multipliers)
        .map(|(p, m)| {
            if m[0] <= 1e-9 * scale {
                0
            } else if m[1].abs() >= p.tangent.upper * (1.0 - 1e-9) {
                2
            } else {
                1
            }
        })
        .collect()
}

fn rel(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let n: f64 = b.iter().map(|y| y * y).sum();
    (d / n).sqrt()
}

fn options(subdomains: usize, layers: usize) -> DdOptions {
    DdOptions {
        partition: PartitionRequest::Automatic {
            subdomains,
            contact_layers: layers,
        },
        ..DdOptions::default()
    }
}

#[test]
fn dd_equals_direct_on_two_blocks_frictionless_partial_slip_and_stick() {
    for g in [0.0, 8.0, 1e9] {
        let problem = two_blocks(24, g, 0.003).expect("problem");
        let reference = direct(&problem);
        let st = states(&problem, &reference.multipliers);
        let sol = solve(&problem, &options(8, 2), None).expect("dd");
        eprintln!("g = {g}: {}", sol.report);
        assert!(sol.report.fallback.is_none());
        let e = rel(&sol.u, &reference.u);
        assert!(e <= 1e-8, "g = {g}: relative difference {e:.3e}");
        assert_eq!(states(&problem, &sol.multipliers), st, "g = {g}");
        assert!(sol
            .report
            .partition_of_unity_error
            .iter()
            .all(|&x| x <= 1e-14));
        assert!(sol.report.coarse_residual.iter().all(|&x| x <= 1e-12));
    }
    // The partial-slip case has stick, slip and (at the free ends) all kinds of pairs.
    let problem = two_blocks(24, 8.0, 0.003).expect("problem");
    let st = states(&problem, &direct(&problem).multipliers);
    assert!(st.contains(&1) && st.contains(&2), "{st:?}");
}

#[test]
fn divergent_successive_approximations_are_detected_and_accelerated() {
    // A thin contact band in a full-width contact: ρ(S0⁻¹ S_CON') > 1, the plain fixed point
    // diverges (the papers' contraction condition fails); Anderson mixing and, when that
    // stagnates, the safeguarded Newton steps recover it.
    let problem = two_blocks(24, 8.0, 0.003).expect("problem");
    let reference = direct(&problem);
    let sol = solve(&problem, &options(8, 2), None).expect("dd");
    assert!(sol.report.contraction.iter().any(|&q| q >= 1.0));
    assert!(sol.report.acceleration.is_some());
    assert!(rel(&sol.u, &reference.u) <= 1e-8);
    // Without acceleration: divergence is reported, and the direct fallback is used and said.
    let plain = DdOptions {
        anderson_depth: 0,
        max_outer: 15,
        ..options(8, 2)
    };
    assert!(matches!(
        solve(&problem, &plain, None),
        Err(DdError::Diverged { .. })
    ));
    let fallback = || Ok(direct(&problem));
    let sol = solve(&problem, &plain, Some(&fallback)).expect("fallback");
    assert!(sol.report.fallback.is_some());
    assert!(rel(&sol.u, &reference.u) <= 1e-14);
    assert!(sol.report.to_string().contains("FALLBACK"));
}

#[test]
fn coarse_dimensions_equal_the_counted_kernels() {
    use super::coarse::Balancing;
    use super::decomposition::Decomposition;
    let problem = two_blocks(24, 8.0, 0.003).expect("problem");
    let part = Partition::new(
        &problem,
        &PartitionRequest::Automatic {
            subdomains: 20,
            contact_layers: 2,
        },
    )
    .expect("partition");
    let dec = Decomposition::new(&problem, part, None, Weights::Stiffness).expect("decomposition");
    let kernels: usize = dec.blocks.iter().map(|b| b.kernel().ncols()).sum();
    let tied: usize = dec.tied.iter().map(|b| b.kernel().ncols()).sum();
    assert!(kernels > 0, "expected floating subdomains");
    // Tied full-width pair: joint rigid motions + relative sliding.
    assert_eq!(tied, 4);
    let n = dec.n_interface();
    let s0 = Balancing::new(dec.blocks.iter().collect(), Vec::new(), &[], n).expect("S0");
    let s = Balancing::new(
        dec.blocks.iter().chain(&dec.tied).collect(),
        Vec::new(),
        &[],
        n,
    )
    .expect("S");
    let s_reduced = Balancing::new(
        dec.blocks.iter().collect(),
        dec.tied.iter().collect(),
        &[],
        n,
    )
    .expect("S, reduced preconditioner");
    assert_eq!(s0.coarse_dim(), kernels);
    assert_eq!(s.coarse_dim(), kernels + tied);
    assert_eq!(s_reduced.coarse_dim(), kernels);
    for op in [&s0, &s, &s_reduced] {
        assert!(op.partition_of_unity_error() <= 1e-14);
    }
    let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
    for op in [&s0, &s, &s_reduced] {
        let out = pcg::pcg(op, &b, vec![0.0; n], 1e-12, 500, "test").expect("pcg");
        assert!(out.coarse_residual <= 1e-13, "{}", out.coarse_residual);
        assert!(rel(&op.apply(&out.x), &b) <= 1e-11);
    }
    // The operators S of the two PCG1 variants are the same.
    assert!(rel(&s_reduced.apply(&b), &s.apply(&b)) <= 1e-14);
    let reference = direct(&problem);
    // Papers' coarse spaces: kernels only; ours adds the rigid motions of every non-contact
    // subdomain (3 each, which contain the kernels).
    let rigid = 3 * dec.blocks.len();
    for (preconditioner, coarse, pcg1, pcg2) in [
        (
            Pcg1Preconditioner::Reduced,
            CoarseKind::Kernels,
            kernels,
            kernels,
        ),
        (
            Pcg1Preconditioner::Full,
            CoarseKind::Kernels,
            kernels + tied,
            kernels,
        ),
        (Pcg1Preconditioner::Reduced, CoarseKind::Rigid, rigid, rigid),
        (
            Pcg1Preconditioner::Full,
            CoarseKind::Rigid,
            rigid + tied,
            rigid,
        ),
    ] {
        let opts = DdOptions {
            pcg1_preconditioner: preconditioner,
            coarse,
            ..options(20, 2)
        };
        let sol = solve(&problem, &opts, None).expect("dd");
        assert_eq!(
            sol.report.coarse_dim_pcg1, pcg1,
            "{preconditioner:?} {coarse:?}"
        );
        assert_eq!(
            sol.report.coarse_dim_pcg2, pcg2,
            "{preconditioner:?} {coarse:?}"
        );
        assert!(sol.report.coarse_residual.iter().all(|&r| r <= 1e-12));
        assert!(rel(&sol.u, &reference.u) <= 1e-8);
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let problem = two_blocks(96, 8.0, 0.003).expect("problem");
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| solve(&problem, &options(8, 2), None).expect("dd"))
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.u, b.u);
    assert_eq!(a.multipliers, b.multipliers);
    assert_eq!(a.report.outer_iterations, b.report.outer_iterations);
}

#[test]
fn partitions_keep_contact_zones_inside_one_subdomain() {
    let problem = two_blocks(24, 8.0, 0.003).expect("problem");
    let part = Partition::new(
        &problem,
        &PartitionRequest::BySize {
            elements: 60,
            contact_layers: 3,
        },
    )
    .expect("partition");
    assert_eq!(part.contact.iter().filter(|&&c| c).count(), 2);
    assert!(part.n_subdomains > 6);
    // Cutting the contact zone is refused with a clear message.
    let mut cut = part.element_subdomain.clone();
    let contact_node = problem.pairs[5].nodes[0];
    let e = problem
        .elements
        .iter()
        .position(|el| el.nodes.contains(&contact_node))
        .expect("element");
    cut[e] = part.n_subdomains;
    let err = Partition::new(&problem, &PartitionRequest::Explicit(cut)).unwrap_err();
    assert!(err.to_string().contains("contact node"), "{err}");
}

#[test]
fn floating_upper_block_is_solved_inside_its_cluster_and_satisfies_the_kkt_conditions() {
    // The upper block is held only by contact and friction (D05 Thm 2.1): a traction on its
    // top, pressing and shearing less than the friction can hold.
    let problem =
        two_blocks_with(24, 30.0, BoundaryValue::Traction([3.0, -40.0])).expect("problem");
    assert_eq!(problem.floating_bodies, vec![1]);
    let sol = solve(&problem, &options(8, 2), None).expect("dd");
    eprintln!("{}", sol.report);
    assert_eq!(sol.report.floating_modes, 3);
    // Global equilibrium K u − f + Bᵀλ = 0.
    let mut r: Vec<f64> = problem.rhs.iter().map(|f| -f).collect();
    for el in &problem.elements {
        for i in 0..6 {
            for j in 0..6 {
                if let (Some(a), Some(b)) = (el.dofs[i], el.dofs[j]) {
                    r[a] += el.matrix[i][j] * sol.u[b];
                }
            }
        }
    }
    let mut scale: f64 = 0.0;
    for (p, m) in problem.pairs.iter().zip(&sol.multipliers) {
        for (row, l) in [(&p.normal, m[0]), (&p.tangent, m[1])] {
            for &(d, a) in &row.entries {
                r[d] += a * l;
            }
            scale = scale.max(l.abs());
        }
        // Non-penetration, sign and friction bounds, complementarity.
        let gap: f64 = p.normal.entries.iter().map(|&(d, a)| a * sol.u[d]).sum();
        assert!(gap <= 1e-10 && m[0] >= -1e-10 * scale);
        assert!(m[0] * gap.abs() <= 1e-8 * scale);
        assert!(m[1].abs() <= p.tangent.upper * (1.0 + 1e-12));
    }
    let f = problem.rhs.iter().map(|x| x * x).sum::<f64>().sqrt();
    let res = r.iter().map(|x| x * x).sum::<f64>().sqrt() / f;
    assert!(res <= 1e-9, "equilibrium residual {res:.3e}");
}

#[test]
fn pcg1_iterations_stay_bounded_as_the_subdomain_count_grows() {
    // Two-block benchmark at fixed H/h (≈ 384 elements per subdomain) with 4 → 16 → 64
    // non-contact subdomains plus the two of the contact cluster: balancing NN theory bounds the
    // PCG1 count independently of the number of subdomains (issue: within a factor 1.5).
    let counts: Vec<usize> = [(32, 6), (64, 18), (128, 66)]
        .iter()
        .map(|&(nx, subdomains)| {
            let problem = two_blocks(nx, 0.0, 0.003).expect("problem");
            let opts = DdOptions {
                outer_tol: 1e-6,
                ..options(subdomains, 2)
            };
            solve(&problem, &opts, None)
                .expect("dd")
                .report
                .pcg1_iterations
        })
        .collect();
    let (lo, hi) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
    assert!(
        *hi as f64 <= 1.5 * *lo as f64,
        "PCG1 iterations {counts:?} grow by more than 1.5"
    );
}

#[test]
fn subdomain_operators_are_reused_while_the_stiffness_is_unchanged_with_the_same_bits() {
    let cache = std::sync::Arc::new(subdomain::OperatorCache::default());
    let cached = DdOptions {
        operators: Some(cache.clone()),
        ..options(8, 2)
    };
    let first = two_blocks(48, 8.0, 0.003).expect("problem");
    let a = solve(&first, &cached, None).expect("dd");
    let (built, reused) = cache.counts();
    assert!(built > 0 && reused == 0, "{built} built, {reused} reused");
    // Another prescribed displacement: the same stiffness, so nothing is built again, and the
    // result equals a solve that builds everything.
    let moved = two_blocks(48, 8.0, 0.004).expect("problem");
    let b = solve(&moved, &cached, None).expect("dd");
    assert_eq!(cache.counts(), (built, built), "every subdomain reused");
    let fresh = solve(&moved, &options(8, 2), None).expect("dd");
    assert_eq!(b.u, fresh.u);
    assert_eq!(b.multipliers, fresh.multipliers);
    assert_ne!(a.u, b.u, "the load did change");
}

/// [`two_blocks`] (slip limit `g`) with the elements of its contact subdomains made `scale` times
/// as stiff, and the partition it was cut with.
fn scaled_contact_band(g: f64, scale: f64) -> (DdProblem, PartitionRequest) {
    let mut problem = two_blocks(24, g, 0.003).expect("problem");
    let request = PartitionRequest::Automatic {
        subdomains: 8,
        contact_layers: 4,
    };
    let part = Partition::new(&problem, &request).expect("partition");
    for (e, el) in problem.elements.iter_mut().enumerate() {
        if part.contact[part.element_subdomain[e]] {
            el.matrix.iter_mut().flatten().for_each(|x| *x *= scale);
        }
    }
    (problem, PartitionRequest::Given(Box::new(part)))
}

#[test]
fn plain_successive_approximations_stop_as_not_contracting() {
    // The two blocks as they are: the contact band is as stiff as its neighbours and the
    // papers' contraction condition fails (q ≈ 2.4); the plain iteration says so instead of
    // accelerating.
    let (problem, partition) = scaled_contact_band(8.0, 1.0);
    let plain = DdOptions {
        iteration: OuterIteration::Plain,
        partition,
        ..DdOptions::default()
    };
    match solve(&problem, &plain, None) {
        Err(DdError::NotContracting { q, step }) => assert!(q >= 1.0 && step >= 1, "{q} {step}"),
        other => panic!("expected non-contraction, got {other:?}"),
    }
    let reference = direct(&problem);
    let fallback = || Ok(reference.clone());
    let sol = solve(&problem, &plain, Some(&fallback)).expect("fallback");
    let said = sol.report.fallback.as_deref().unwrap_or_default();
    assert!(said.contains("not contracting"), "{said}");
    assert!(sol.report.acceleration.is_none() && sol.report.newton_steps == 0);
    assert!(sol
        .report
        .contraction
        .iter()
        .rev()
        .take(2)
        .all(|&q| q >= 1.0));
    assert_eq!(sol.report.iteration, OuterIteration::Plain);
}

#[test]
fn plain_successive_approximations_converge_on_a_soft_contact_band() {
    // Contact band softer than the rest (0.3 and 0.01 times the stiffness): the cluster's energy
    // is small against S0's (D03 (66), D05 Assumption 7.1), the plain iteration contracts
    // (q ≈ 0.5–0.7 at 0.3); frictionless, so the D03 form of the bound is reported, 2λ²P_c = q.
    let (problem, partition) = scaled_contact_band(0.0, 0.3);
    let plain = DdOptions {
        iteration: OuterIteration::Plain,
        partition,
        ..DdOptions::default()
    };
    let sol = solve(&problem, &plain, None).expect("plain DD converges");
    let report = &sol.report;
    assert!(report.acceleration.is_none() && report.newton_steps == 0);
    assert!(report.fallback.is_none());
    assert!(rel(&sol.u, &direct(&problem).u) <= 1e-8);
    let q = report.contraction_estimate.expect("a contraction estimate");
    assert!(q < 1.0, "{q}");
    let d03 = report
        .d03
        .as_ref()
        .expect("D03 bound for a frictionless problem");
    assert_eq!(d03.clusters, report.n_clusters);
    assert!((2.0 * d03.lambda_observed.powi(2) * d03.clusters as f64 - q).abs() <= 1e-12);
    assert!(d03.lambda_observed < d03.lambda_limit);
    assert!((d03.lambda_limit - 1.0 / (2.0 * d03.clusters as f64).sqrt()).abs() <= 1e-15);
    assert_eq!(Some(d03.bound), report.error_bound);
    assert!(report.to_string().contains("D03 Thm 4.1"));
    // With friction the D03 (frictionless) bound does not apply.
    let (problem, partition) = scaled_contact_band(8.0, 0.01);
    let plain = DdOptions {
        iteration: OuterIteration::Plain,
        partition,
        ..DdOptions::default()
    };
    let sol = solve(&problem, &plain, None).expect("plain DD converges with friction");
    assert!(sol.report.d03.is_none() && !sol.report.frictionless);
    assert!(rel(&sol.u, &direct(&problem).u) <= 1e-8);
}

#[test]
fn mean_young_weights_are_the_materials_moduli_and_dd_still_equals_direct() {
    // two_blocks: E = 1e4 (lower body 0), 2e4 (upper body 1), ν = 0.3.
    let problem = two_blocks(24, 8.0, 0.003).expect("problem");
    for (e, el) in problem.elements.iter().enumerate() {
        let expected = [1.0e4, 2.0e4][problem.element_body(e)];
        assert!(
            (el.young - expected).abs() <= 1e-10 * expected,
            "{}",
            el.young
        );
    }
    let area: f64 = problem.elements.iter().map(|el| el.area).sum();
    assert!((area - 3.0).abs() <= 1e-12, "{area}");
    let opts = DdOptions {
        weights: Weights::MeanYoung,
        ..options(8, 2)
    };
    let sol = solve(&problem, &opts, None).expect("dd");
    assert_eq!(sol.report.weights, Weights::MeanYoung);
    assert!(sol
        .report
        .partition_of_unity_error
        .iter()
        .all(|&x| x <= 1e-14));
    assert!(rel(&sol.u, &direct(&problem).u) <= 1e-8);
}
