//! Benchmarks behind `wsm bench` (not part of the test suite): timings of the FEM pipeline and
//! of the direct contact solver on the tunnel example at chosen sizes, of the exact derivatives,
//! of the worst-scenario loop, of mortar against node-pair contact rows (design §2.4.1), and of a
//! dynamic run (design §3.5). Medians of a few runs.

use std::time::Instant;

use wsm_core::{
    apply_parameters, parameter_stencil, parse_scene, BoundaryValue, Coupling, DerivativeRoute,
    InlineMesh, Needs, Par, Parameter, Scene, SolveOptions, StateProblem, WsmError,
};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn time<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let out = f();
    (out, t.elapsed().as_secs_f64())
}

/// An example with all mesh sizes scaled by `factor`.
pub fn scaled_scene(example: &str, factor: f64) -> Result<Scene, WsmError> {
    wsm_core::scaled_scene(&parse_scene(wsm_core::find_example(example)?)?, factor)
}

/// The example scaled to about `unknowns` free DOFs (one correction step).
pub fn scene_of_size(example: &str, unknowns: usize) -> Result<Scene, WsmError> {
    let probe = StateProblem::new(scaled_scene(example, 1.0)?)?;
    let n0 = probe.elastic.dofs().n_free() as f64;
    let factor = (n0 / unknowns as f64).sqrt();
    scaled_scene(example, factor)
}

/// A state problem of the example with about `unknowns` free DOFs (one correction step).
pub fn problem_of_size(example: &str, unknowns: usize) -> Result<StateProblem, WsmError> {
    StateProblem::new(scene_of_size(example, unknowns)?)
}

/// Fixed interior point `r` of the box: a low-discrepancy walk through it.
fn interior_point(params: &[Parameter], r: usize) -> Vec<f64> {
    params
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let u = ((r + 1) as f64 * (0.618_034 + 0.1 * i as f64)).fract();
            p.lo + (0.1 + 0.8 * u) * (p.hi - p.lo)
        })
        .collect()
}

/// One row of the contact benchmark.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ContactBenchRow {
    /// Free displacement degrees of freedom of the scaled tunnel.
    pub unknowns: usize,
    /// Contact node pairs of the scaled mesh.
    pub contact_pairs: usize,
    /// Building the state problem (the size probe included): meshing, operators and contact
    /// geometry \[s\].
    pub setup: f64,
    /// Median numeric factorisation of K plus one solve, contact ignored \[s\].
    pub linear_factor_and_solve: f64,
    /// Median cold contact solve: factorisation, condensed operator C, QP and recovery \[s\].
    pub contact_first_solve: f64,
    /// Median warm-started contact re-solve after a 1 % change of pressures and slip limits \[s\].
    pub contact_warm_resolve: f64,
    /// QP iterations of the last run's cold contact solve.
    pub qp_iterations_first: usize,
    /// QP iterations of the last run's warm re-solve.
    pub qp_iterations_warm: usize,
}

/// Time a linear solve (factor + solve, contact ignored), a first contact solve (factor, C,
/// QP, recovery) and a warm re-solve after a 1% change of pressures and slip limits.
pub fn contact_benchmark(
    example: &str,
    unknowns: usize,
    runs: usize,
) -> Result<ContactBenchRow, WsmError> {
    let (problem, setup) = time(|| problem_of_size(example, unknowns));
    let problem = problem?;
    let elastic = &problem.elastic;
    let data = &problem.nominal;
    let options = |warm| SolveOptions {
        needs: Needs::all(&problem.scene),
        par: Par::rayon(0),
        warm,
    };
    let (mut linear, mut first, mut warm) = (Vec::new(), Vec::new(), Vec::new());
    let (mut it_first, mut it_warm) = (0, 0);
    for run in 0..runs.max(1) {
        // Perturb λ, μ slightly per run so every first solve really factorises.
        let mut d = data.clone();
        for m in &mut d.materials {
            if let wsm_core::Elastic::Lame { lambda, .. } = &mut m.elastic {
                *lambda *= 1.0 + 1e-6 * run as f64;
            }
            if let wsm_core::Elastic::Young { e, .. } = &mut m.elastic {
                *e *= 1.0 + 1e-6 * run as f64;
            }
        }
        let ((), t_lin) = time(|| {
            if let Ok(f) = elastic
                .operator()
                .factor(&elastic.coefficients(&d).unwrap_or_default(), Par::rayon(0))
            {
                let rhs = elastic.rhs(&d, None).unwrap_or_default();
                let _ = f.factor.solve(&rhs);
            }
        });
        linear.push(t_lin);
        let (sol, t_first) = time(|| problem.solve(&d, &options(None)));
        let sol = sol?;
        first.push(t_first);
        it_first = sol.report.qp_iterations;
        let mut changed = d.clone();
        for b in &mut changed.boundary {
            if let BoundaryValue::Pressure(p) = &mut b.value {
                *p *= 1.01;
            }
        }
        for s in &mut changed.slip {
            for v in &mut s.values {
                *v *= 1.01;
            }
        }
        let start = sol.warm_start.clone();
        let (sol2, t_warm) = time(|| problem.solve(&changed, &options(start)));
        it_warm = sol2?.report.qp_iterations;
        warm.push(t_warm);
    }
    Ok(ContactBenchRow {
        unknowns: elastic.dofs().n_free(),
        contact_pairs: problem.contact.geometry.pairs.len(),
        setup,
        linear_factor_and_solve: median(linear),
        contact_first_solve: median(first),
        contact_warm_resolve: median(warm),
        qp_iterations_first: it_first,
        qp_iterations_warm: it_warm,
    })
}

/// One row of the FEM pipeline benchmark (no contact: the linear elastic solve).
#[derive(Debug, Clone, serde::Serialize)]
pub struct FemRow {
    /// Free displacement degrees of freedom of the scaled tunnel.
    pub unknowns: usize,
    /// Median meshing time \[s\].
    pub mesh: f64,
    /// Per-zone matrices on the shared pattern, unit loads, DOF map (symbolic excluded).
    pub assembly: f64,
    /// Median symbolic Cholesky analysis of the stiffness pattern (AMD ordering, elimination
    /// tree) \[s\].
    pub symbolic: f64,
    /// Median numeric factorisation of K for given (λ, μ) \[s\].
    pub numeric: f64,
    /// Median forward and back substitution of one load vector \[s\].
    pub solve: f64,
}

/// Time meshing, assembly, symbolic and numeric factorisation and the solve of the linear
/// elastic tunnel problem; the numeric refactorisation + solve is what a new (λ, μ) costs.
pub fn fem_benchmark(example: &str, unknowns: usize, runs: usize) -> Result<FemRow, WsmError> {
    let probe = StateProblem::new(scaled_scene(example, 1.0)?)?;
    let factor = (probe.elastic.dofs().n_free() as f64 / unknowns as f64).sqrt();
    let scene = scaled_scene(example, factor)?;
    let data = wsm_core::Data::from_scene(&scene);
    let mut samples = [Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new()];
    let mut n = 0;
    for _ in 0..runs.max(1) {
        let (mesh, t_mesh) = time(|| wsm_core::generate_mesh(&scene));
        let mesh = mesh?;
        let (elastic, t_build) = time(|| wsm_core::ElasticProblem::new(&mesh, &data));
        let elastic = elastic?;
        let (symbolic, t_symbolic) =
            time(|| wsm_core::Symbolic::analyse(elastic.operator().pattern()));
        symbolic?;
        let coefficients = elastic.coefficients(&data)?;
        let (f, t_numeric) = time(|| elastic.operator().factor(&coefficients, Par::rayon(0)));
        let f = f?;
        let rhs = elastic.rhs(&data, None)?;
        let (_, t_solve) = time(|| f.factor.solve(&rhs));
        n = elastic.dofs().n_free();
        for (v, t) in
            samples
                .iter_mut()
                .zip([t_mesh, t_build - t_symbolic, t_symbolic, t_numeric, t_solve])
        {
            v.push(t);
        }
    }
    let [mesh, assembly, symbolic, numeric, solve] = samples.map(median);
    Ok(FemRow {
        unknowns: n,
        mesh,
        assembly,
        symbolic,
        numeric,
        solve,
    })
}

/// `wsm bench`: the tables as Markdown.
pub fn run(sizes: &[usize], runs: usize, dd: bool) -> Result<String, WsmError> {
    let mut out = String::from(
        "Linear elastic tunnel (FEM pipeline):\n\n| unknowns | mesh [s] | assembly [s] | symbolic [s] | numeric [s] | solve [s] | (numeric+solve)/first |\n|---|---|---|---|---|---|---|\n",
    );
    for &n in sizes {
        let r = fem_benchmark("tunnel-fault", n, runs)?;
        let first = r.assembly + r.symbolic + r.numeric + r.solve;
        out.push_str(&format!(
            "| {} | {:.3} | {:.3} | {:.3} | {:.4} | {:.4} | {:.2} |\n",
            r.unknowns,
            r.mesh,
            r.assembly,
            r.symbolic,
            r.numeric,
            r.solve,
            (r.numeric + r.solve) / first
        ));
    }
    out.push_str("\nContact (direct solver) on the tunnel:\n\n");
    out.push_str(
        "| unknowns | pairs | setup [s] | linear factor+solve [s] | contact first solve [s] | ratio | warm re-solve [s] | warm/first | QP it. first / warm |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for &n in sizes {
        let r = contact_benchmark("tunnel-fault", n, runs)?;
        out.push_str(&format!(
            "| {} | {} | {:.3} | {:.4} | {:.4} | {:.2} | {:.4} | {:.2} | {} / {} |\n",
            r.unknowns,
            r.contact_pairs,
            r.setup,
            r.linear_factor_and_solve,
            r.contact_first_solve,
            r.contact_first_solve / r.linear_factor_and_solve,
            r.contact_warm_resolve,
            r.contact_warm_resolve / r.contact_first_solve,
            r.qp_iterations_first,
            r.qp_iterations_warm
        ));
    }
    if dd {
        let mut buffer = Vec::new();
        wsm_core::bench::dd_scalability(&mut buffer)
            .map_err(|e| WsmError::io("DD scalability benchmark", e))?;
        out.push_str("\nDomain decomposition:\n\n");
        out.push_str(&String::from_utf8_lossy(&buffer));
    }
    Ok(out)
}

/// One row of the worst-scenario loop benchmark.
#[derive(Debug, Clone, serde::Serialize)]
pub struct WorstRow {
    /// The inner solver: "direct" or "dd".
    pub solver: &'static str,
    /// Free displacement degrees of freedom of the scaled tunnel.
    pub unknowns: usize,
    /// New criterion evaluations (inner solves) of the run.
    pub evaluations: usize,
    /// Wall-clock time of the whole run \[s\].
    pub wall: f64,
    /// Evaluations per wall-clock second.
    pub evaluations_per_second: f64,
    /// Summed over threads \[s\]: the inner solves and their phases.
    pub solver_seconds: f64,
    /// Time per phase of the inner solves (assembly, factorisation, contact, DD, post-processing),
    /// summed over threads \[s\].
    pub phases: wsm_core::Timings,
    /// Local operators built: numeric factorisations of body blocks of K (direct solver and DD
    /// fallback) plus DD subdomain operators (factor, S, Neumann map).
    pub local_factorisations: usize,
    /// DD subdomain operators taken from the cache.
    pub reused_subdomains: usize,
    /// The worst (max) value of each criterion.
    pub worst: Vec<f64>,
}

/// `wsm worst` on the tunnel at about `unknowns` unknowns with the scene's criteria and
/// parameters and `budget` inner solves, with the direct solver or DD: evaluations/s and the
/// phase times of the inner solves.
pub fn worst_benchmark(
    example: &str,
    unknowns: usize,
    budget: usize,
    solver: wsm_core::SolverKind,
) -> Result<WorstRow, WsmError> {
    let probe = StateProblem::new(scaled_scene(example, 1.0)?)?;
    let factor = (probe.elastic.dofs().n_free() as f64 / unknowns as f64).sqrt();
    let mut scene = scaled_scene(example, factor)?;
    scene.solver.kind = solver;
    let problem = StateProblem::new(scene)?;
    let params = wsm_core::scene_parameters(&problem.scene)?;
    let mut settings = wsm_core::WorstSettings::from_scene(&problem.scene);
    settings.budget = budget;
    let evaluator = wsm_core::ScenarioEvaluator::new(&problem, &params, &settings.criteria)?
        .with_derivatives(settings.derivatives);
    let mut cache = wsm_search::EvalCache::new();
    let (outcome, wall) = time(|| {
        wsm_core::run_worst_scenario(
            &problem,
            &params,
            &settings,
            &evaluator,
            &|| evaluator.summary(),
            &mut cache,
            Default::default(),
        )
    });
    let outcome = outcome?;
    Ok(WorstRow {
        solver: match solver {
            wsm_core::SolverKind::Dd => "dd",
            _ => "direct",
        },
        unknowns: problem.elastic.dofs().n_free(),
        evaluations: outcome.new_evaluations,
        wall,
        evaluations_per_second: outcome.new_evaluations as f64 / wall,
        solver_seconds: outcome.inner.solver_seconds,
        phases: evaluator.phase_seconds(),
        local_factorisations: problem
            .counters
            .body_factorisations
            .load(std::sync::atomic::Ordering::Relaxed)
            + problem.dd_operators.counts().0,
        reused_subdomains: problem.dd_operators.counts().1,
        worst: outcome
            .criteria
            .iter()
            .map(|c| c.worst.value.unwrap_or(f64::NAN))
            .collect(),
    })
}

/// `wsm bench --gradients`: per size, the median time of one evaluation of the tunnel's criteria at
/// `runs` fixed interior points of its box (new λ, μ: the stiffness is factorised), and of the same
/// solve once the factor is cached, without and with the exact derivatives of all criteria along
/// all uncertain data — by the adjoint (the product's route) and by the forward tangent. The ratio
/// is that of an evaluation with derivatives to one without, 1 + (with − without, factor cached) /
/// evaluation (the aim: at most 1.5 at 10^4 unknowns; measured in design §4.4 and
/// docs/benchmarks.md, "Search with exact derivatives").
pub fn run_gradients(sizes: &[usize], runs: usize) -> Result<String, WsmError> {
    let mut out = String::from(
        "Exact derivatives on the tunnel (all criteria along all uncertain data; one thread per solve):\n\n| unknowns | uncertain data | criteria | evaluation [s] | solve, factor cached [s] | with derivatives: adjoint [s] | ratio | forward tangent [s] | ratio |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for &n in sizes {
        let problem = problem_of_size("tunnel-fault", n)?;
        let params = wsm_core::scene_parameters(&problem.scene)?;
        let targets = problem.targets(&problem.scene.search.criteria)?;
        let options = SolveOptions {
            needs: Needs::for_targets(&problem.scene, &targets),
            par: Par::Seq,
            warm: None,
        };
        let mut times: [Vec<f64>; 4] = Default::default();
        for r in 0..runs.max(1) {
            let theta = interior_point(&params, r);
            let data = apply_parameters(&problem.scene, &problem.nominal, &params, &theta);
            let stencils: Vec<_> = (0..params.len())
                .map(|j| parameter_stencil(&problem.scene, &problem.nominal, &params, &theta, j))
                .collect();
            times[0].push(time(|| problem.solve(&data, &options)).1);
            times[1].push(time(|| problem.solve(&data, &options)).1);
            for (slot, route) in [(2, DerivativeRoute::Adjoint), (3, DerivativeRoute::Forward)] {
                let (solution, t) =
                    time(|| problem.solve_with_sensitivities_by(&data, &options, &stencils, route));
                if solution?.sensitivities.len() != params.len() {
                    return Err(WsmError::io(
                        "gradient benchmark",
                        format!("no derivatives at {theta:?}"),
                    ));
                }
                times[slot].push(t);
            }
        }
        let [evaluation, cached, adjoint, forward] = times.map(median);
        let ratio = |with: f64| 1.0 + (with - cached) / evaluation;
        out.push_str(&format!(
            "| {} | {} | {} | {:.4} | {:.4} | {:.4} | {:.2} | {:.4} | {:.2} |\n",
            problem.elastic.dofs().n_free(),
            params.len(),
            targets.len(),
            evaluation,
            cached,
            adjoint,
            ratio(adjoint),
            forward,
            ratio(forward)
        ));
    }
    Ok(out)
}

/// `wsm bench --worst`: the worst-scenario loop on the tunnel, both solvers, as Markdown.
pub fn run_worst(sizes: &[usize], budget: usize, dd: bool) -> Result<String, WsmError> {
    let mut out = format!(
        "Worst-scenario loop on the tunnel (budget {budget}, {} threads); phase shares of the summed inner-solve time:\n\n| solver | unknowns | evaluations | local factorisations (body blocks; DD subdomains, reused) | wall [s] | evaluations/s | ms per evaluation (thread time) | assembly | factor (numeric / C) | contact (QP; DD setup / PCG1 / outer / recovery) | post | worst values |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        rayon::current_num_threads()
    );
    let mut kinds = vec![wsm_core::SolverKind::Direct];
    if dd {
        kinds.push(wsm_core::SolverKind::Dd);
    }
    for &n in sizes {
        for &kind in &kinds {
            let r = worst_benchmark("tunnel-fault", n, budget, kind)?;
            let p = &r.phases;
            let share = |x: f64| x / r.solver_seconds.max(1e-12);
            out.push_str(&format!(
                "| {} | {} | {} | {} ({}) | {:.2} | {:.1} | {:.2} | {:.2} | {:.2} ({:.2} / {:.2}) | {:.2} ({:.2}; {:.2} / {:.2} / {:.2} / {:.2}) | {:.2} | {} |\n",
                r.solver,
                r.unknowns,
                r.evaluations,
                r.local_factorisations,
                r.reused_subdomains,
                r.wall,
                r.evaluations_per_second,
                1e3 * r.solver_seconds / r.evaluations.max(1) as f64,
                share(p.assembly),
                share(p.factor),
                share(p.numeric),
                share(p.hessian),
                share(p.contact),
                share(p.qp),
                share(p.dd_setup),
                share(p.dd_pcg1),
                share(p.dd_outer),
                share(p.dd_recovery),
                share(p.post),
                r.worst
                    .iter()
                    .map(|v| format!("{v:.10e}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
    }
    Ok(out)
}

/// The scene with its own generated mesh given inline, so that a second coupling of its contact
/// zones meets the same nodes and the same unknowns.
fn with_generated_mesh_inline(scene: &Scene) -> Result<Scene, WsmError> {
    let mesh = wsm_core::generate_mesh(scene)?;
    let mut out = scene.clone();
    out.mesh.inline = Some(InlineMesh {
        zones: mesh.zones.iter().map(|z| z.name.clone()).collect(),
        segments: mesh
            .segments
            .iter()
            .map(|s| (s.name.clone(), s.edges.clone()))
            .collect(),
        nodes: mesh.nodes,
        triangles: mesh.triangles,
        triangle_zones: mesh.triangle_zone,
    });
    Ok(out)
}

/// `wsm bench --mortar`: the cost of an evaluation with dual mortar contact rows against one with
/// node-to-node pairs at equal unknowns (design §2.4.1; the mortar's cost target: at most 1.3×).
/// Per example and size the scene's mesh is generated once and given inline, and its contact
/// zones are coupled once by node pairs and once by mortar (the first segment the slave, so both
/// have their rows on the same nodes). Medians over `runs` interior points of the box, the two
/// couplings alternating, of an evaluation (new data: factorisation where the stiffness
/// changes, contact solve, criteria) and then of the same solve with the exact derivatives of
/// the scene's criteria (adjoint; the factor cached by then), one thread per solve; the set-up
/// (operators, contact rows) once.
pub fn run_mortar(sizes: &[usize], runs: usize) -> Result<String, WsmError> {
    let mut out = String::from(
        "Mortar against node-pair contact rows on one mesh (one thread per solve; medians):\n\n| example | unknowns | slave nodes | set-up nodes / mortar [s] | evaluation nodes / mortar [s] | ratio | again with derivatives, factor cached, nodes / mortar [s] | ratio | sparse steps nodes / mortar |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for example in ["hertz", "tunnel-fault"] {
        for &n in sizes {
            let nodes = with_generated_mesh_inline(&scene_of_size(example, n)?)?;
            let mut mortar = nodes.clone();
            for c in &mut mortar.contacts {
                c.coupling = Coupling::Mortar;
                c.slave = Some(c.between[0].clone());
            }
            let mut problems = Vec::new();
            let mut setup = Vec::new();
            for scene in [nodes, mortar] {
                let (problem, t) = time(|| StateProblem::new(scene));
                problems.push(problem?);
                setup.push(t);
            }
            let params = wsm_core::scene_parameters(&problems[0].scene)?;
            let mut times: [[Vec<f64>; 2]; 2] = Default::default();
            let mut sparse = [0; 2];
            for r in 0..runs.max(1) {
                let theta = interior_point(&params, r);
                // Alternating which coupling goes first.
                for k in [r % 2, 1 - r % 2] {
                    let problem = &problems[k];
                    let targets = problem.targets(&problem.scene.search.criteria)?;
                    let options = SolveOptions {
                        needs: Needs::for_targets(&problem.scene, &targets),
                        par: Par::Seq,
                        warm: None,
                    };
                    let data = apply_parameters(&problem.scene, &problem.nominal, &params, &theta);
                    let stencils: Vec<_> = (0..params.len())
                        .map(|j| {
                            parameter_stencil(&problem.scene, &problem.nominal, &params, &theta, j)
                        })
                        .collect();
                    let (solution, t) = time(|| problem.solve(&data, &options));
                    sparse[k] = solution?.report.sparse_steps;
                    times[0][k].push(t);
                    let (solution, t) = time(|| {
                        problem.solve_with_sensitivities_by(
                            &data,
                            &options,
                            &stencils,
                            DerivativeRoute::Adjoint,
                        )
                    });
                    solution?;
                    times[1][k].push(t);
                }
            }
            let [[e_nodes, e_mortar], [d_nodes, d_mortar]] = times.map(|t| t.map(median));
            out.push_str(&format!(
                "| {example} | {} | {} | {:.3} / {:.3} | {:.4} / {:.4} | {:.2} | {:.4} / {:.4} | {:.2} | {} / {} |\n",
                problems[0].elastic.dofs().n_free(),
                problems[1].contact.geometry.pairs.len(),
                setup[0],
                setup[1],
                e_nodes,
                e_mortar,
                e_mortar / e_nodes,
                d_nodes,
                d_mortar,
                d_mortar / d_nodes,
                sparse[0],
                sparse[1],
            ));
        }
    }
    Ok(out)
}

/// Steps of a `wsm bench --dynamics` run.
pub const DYNAMIC_STEPS: usize = 1000;

/// `wsm bench --dynamics`: the seismic tunnel example (design §3.5; the speed target:
/// about 10⁴ unknowns, 1000 steps with contact in ≤ 10 s on 2 cores) scaled to each size, run for
/// [`DYNAMIC_STEPS`] steps of its Δt (the pulse crosses the rock mass and the fault, the absorbing
/// layers take it out) with an output every 10 steps. Medians over `runs` runs of the set-up
/// (meshing, operators, contact rows) and of the run (static start, factorisation of A,
/// W = A⁻¹Bᵀ, the steps), one thread.
pub fn run_dynamics(sizes: &[usize], runs: usize) -> Result<String, WsmError> {
    let mut out = String::from(
        "Dynamic run of tunnel-fault-seismic, 1000 steps (newmark, contact on both faults; one thread; medians):\n\n| unknowns | contact pairs | set-up [s] | run [s] | per step [ms] | QP iterations / step | active-set changes |\n|---|---|---|---|---|---|---|\n",
    );
    for &n in sizes {
        let mut scene = scene_of_size("tunnel-fault-seismic", n)?;
        let dynamics = scene
            .dynamics
            .as_mut()
            .ok_or_else(|| wsm_core::SceneError::new("dynamics", "missing"))?;
        dynamics.t_end = DYNAMIC_STEPS as f64 * dynamics.dt;
        dynamics.output_every = 10;
        let (mut setup, mut total) = (Vec::new(), Vec::new());
        let mut last = None;
        for _ in 0..runs.max(1) {
            let (problem, t) = time(|| StateProblem::new(scene.clone()));
            let problem = problem?;
            setup.push(t);
            let (run, t) = time(|| wsm_core::simulate(&problem, &problem.nominal));
            total.push(t);
            last = Some((problem.contact.geometry.pairs.len(), run?.history.report));
        }
        let Some((pairs, report)) = last else {
            continue;
        };
        let run = median(total);
        out.push_str(&format!(
            "| {} | {pairs} | {:.3} | {run:.3} | {:.3} | {:.2} | {} |\n",
            report.unknowns,
            median(setup),
            1e3 * run / report.steps as f64,
            report.qp_iterations as f64 / report.steps as f64,
            report.active_set_changes,
        ));
    }
    Ok(out)
}
