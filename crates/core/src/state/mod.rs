//! The state problem (design §2–§3): for one data set, the heat solve (only when needed), the
//! elastic contact solve (direct solver; DD when the scene asks for it), stresses, contact
//! results with KKT residuals, and the criteria Φ1–Φ6.
//!
//! Everything that depends only on the mesh and the topology is built once in
//! [`StateProblem::new`]: mesh, criteria weights, DOF map, per-zone operators, symbolic
//! factorisations, contact geometry and the floating-body kernel. Per data set only numeric work
//! remains: K is factorised body by body, and a body's factor (with its share of the contact
//! Schur complement C) is reused when the λ, μ of its zones did not change, a temperature field
//! when the thermal data did not change (memos keyed by the exact bits, so reused values equal
//! fresh ones); the DD partition is built once.

mod criterion_values;
mod sensitivity;
mod solution;

pub use criterion_values::{
    attaining, family, maxima, per_region, region_name, Fields, PerCriterion,
};
pub(crate) use criterion_values::{per_region_with, receiver_velocity, region_forms};
pub(crate) use sensitivity::{add_scaled, one_sided, tied_regions, TIE_TOL};
pub use sensitivity::{OneSided, RegionSensitivities, Sensitivities};
pub(crate) use solution::contact_results;
pub use solution::{
    piece_pressures, zone_summaries, ContactKkt, ContactNode, ContactState, Solution, SolveReport,
    SolverUsed, Timings, ZoneSummary,
};

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use crate::contact::bodies::BodyFactor;
use crate::contact::direct::{
    ContactSolution, DirectContact, StiffnessFactor, TangentDisplacement,
};
use crate::contact::qp::WarmStart;
use crate::contact::LoadCase;
use crate::dd::DirectAnswer;
use crate::error::WsmError;
use crate::fem::OperatorFactor;
use crate::fem::{ElasticCoefficients, ElasticProblem, HeatProblem, Par};
use crate::memo::{self, Memo};
use crate::mesh::Mesh;
use crate::regions::CriteriaGeometry;
use crate::scene::params::Stencil;
use crate::scene::{
    BoundaryValue, Criterion, CriterionSpec, Data, Element, Scene, SceneError, SolverKind, Warning,
    WarningKind,
};
pub use sensitivity::DerivativeRoute;
use sensitivity::{ElasticState, SolvedState};

/// What a solve must compute.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Needs {
    /// Solve the heat problem (the scene has a thermal part and a criterion or the thermal load
    /// of the elastic solve needs T).
    pub heat: bool,
    /// Solve the elastic contact problem (some criterion other than Φ1/Φ2 is requested).
    pub elastic: bool,
    /// Per Φ, the regions (indices in its `family`) that criteria bound to one region read:
    /// their derivatives are computed beside those of the regions tying for the maximum.
    pub bound_regions: PerCriterion<Vec<usize>>,
}

impl Needs {
    /// Only what the criteria need: no heat solve without a thermal part, no elastic solve for
    /// Φ1/Φ2 alone.
    pub fn for_criteria(scene: &Scene, criteria: &[Criterion]) -> Needs {
        let elastic = criteria.iter().any(|c| !c.is_thermal());
        let thermal = scene.thermal.is_some();
        Needs {
            heat: thermal && (elastic || criteria.iter().any(|c| c.is_thermal())),
            elastic,
            bound_regions: Default::default(),
        }
    }

    /// What the resolved `targets` need (see [`StateProblem::targets`]).
    pub fn for_targets(scene: &Scene, targets: &[Target]) -> Needs {
        let kinds: Vec<Criterion> = targets.iter().map(|t| t.criterion).collect();
        let mut needs = Needs::for_criteria(scene, &kinds);
        for t in targets {
            if let Some(r) = t.region {
                needs.bound_regions[t.criterion as usize].push(r);
            }
        }
        needs
    }

    /// Everything the scene has.
    pub fn all(scene: &Scene) -> Needs {
        Needs::for_criteria(scene, &Criterion::ALL)
    }
}

/// A requested criterion resolved on the mesh: Φ, and when it is bound to one region, that
/// region's index in Φ's `family` (design §4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Target {
    /// Which Φ.
    pub criterion: Criterion,
    /// The bound region's index in the family (`None`: the largest over the family).
    pub region: Option<usize>,
}

/// Options of one solve.
#[derive(Debug, Clone)]
pub struct SolveOptions {
    /// Which parts of the state problem to compute.
    pub needs: Needs,
    /// Parallelism inside factorisations (`Par::Seq` when many solves run in parallel).
    pub par: Par,
    /// Contact multipliers of a nearby solution to start from.
    pub warm: Option<WarmStart>,
}

/// How often the expensive parts ran (for reports and for tests of "compute only what is needed").
#[derive(Debug, Default)]
pub struct Counters {
    /// Heat problems factorised and solved (a temperature field reused from the memo is not
    /// counted).
    pub heat_solves: AtomicUsize,
    /// Stiffness factors built (at least one body block factorised numerically).
    pub factorisations: AtomicUsize,
    /// Body blocks factorised numerically.
    pub body_factorisations: AtomicUsize,
    /// Elastic contact solves (direct or DD), with or without a reused factor.
    pub elastic_solves: AtomicUsize,
}

impl Counters {
    /// (heat solves, stiffness factorisations, elastic solves) so far.
    pub fn snapshot(&self) -> (usize, usize, usize) {
        (
            self.heat_solves.load(Ordering::Relaxed),
            self.factorisations.load(Ordering::Relaxed),
            self.elastic_solves.load(Ordering::Relaxed),
        )
    }
}

/// Everything built once per scene.
pub struct StateProblem {
    /// The validated scene the problem was built from.
    pub scene: Scene,
    /// The data as the scene gives them (the nominal point of the uncertain parameters).
    pub nominal: Data,
    /// The exact weights of the criteria's areas and boundary pieces on the mesh.
    pub criteria: CriteriaGeometry,
    /// The elasticity problem on the mesh: DOF map, per-zone operators, unit loads.
    pub elastic: ElasticProblem,
    /// The heat problem, when the scene has a thermal part.
    pub heat: Option<HeatProblem>,
    /// The contact problem: node pairs, B rows, floating-body kernel and the body blocks of K.
    pub contact: DirectContact,
    factors: Memo<Arc<StiffnessFactor>>,
    /// Per body block of K: its factors keyed by the coefficients of its zones.
    body_factors: Vec<Memo<Arc<BodyFactor>>>,
    temperatures: Memo<Arc<Vec<f64>>>,
    /// Heat factors keyed by the conductivities.
    heat_factors: Memo<Arc<OperatorFactor<3>>>,
    /// The DD partition, built on the first DD solve from the nominal data (it depends only on
    /// the mesh and the contact pairs).
    dd_partition: OnceLock<Result<crate::dd::Partition, crate::dd::DdError>>,
    /// The DD subdomain operators of the stiffnesses seen last.
    pub dd_operators: Arc<crate::dd::subdomain::OperatorCache>,
    /// How often the heat solve, the factorisation and the elastic solve ran.
    pub counters: Counters,
    /// Time to build the problem \[s\].
    pub setup_seconds: f64,
}

impl StateProblem {
    /// Mesh the scene and build the operators (the scene must be validated).
    pub fn new(scene: Scene) -> Result<StateProblem, WsmError> {
        let start = Instant::now();
        let mesh = crate::mesh::generate(&scene)?;
        StateProblem::with_mesh(scene, mesh, start)
    }

    /// Build on a given mesh.
    pub fn with_mesh(scene: Scene, mesh: Mesh, start: Instant) -> Result<StateProblem, WsmError> {
        let nominal = Data::from_scene(&scene);
        let mut criteria = crate::regions::build(&scene, &mesh)?;
        let heat = match scene.thermal {
            Some(_) => Some(HeatProblem::new(&mesh, &nominal)?),
            None => None,
        };
        let elastic = ElasticProblem::with_element(&mesh, &nominal, scene.mesh.element)?;
        let contact = DirectContact::new(&scene, &elastic)?;
        criterion_values::attach_contact_rows(
            &mut criteria,
            &contact.geometry,
            elastic.mesh().nodes.len(),
        )?;
        let body_factors = contact
            .bodies()
            .iter()
            .map(|b| {
                let budget = BODY_CACHE_BYTES / contact.bodies().len();
                Memo::new(memo::capacity(budget, 8 * b.factor_nnz()))
            })
            .collect();
        Ok(StateProblem {
            scene,
            nominal,
            criteria,
            elastic,
            heat,
            contact,
            factors: Memo::new(4),
            body_factors,
            temperatures: Memo::new(4),
            heat_factors: Memo::new(2),
            dd_partition: OnceLock::new(),
            dd_operators: Arc::default(),
            counters: Counters::default(),
            setup_seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The mesh the problem is built on (contact nodes split per body).
    pub fn mesh(&self) -> &Mesh {
        self.elastic.mesh()
    }

    /// Solve the state problem for `data`.
    pub fn solve(&self, data: &Data, options: &SolveOptions) -> Result<Solution, WsmError> {
        self.solve_with_sensitivities(data, options, &[])
    }

    /// The requested criteria on this mesh: a bound region is found by name in its Φ's family
    /// (the scene's validation has checked that it qualifies; a region the mesh cannot resolve is
    /// an error naming the criterion).
    pub fn targets(&self, criteria: &[CriterionSpec]) -> Result<Vec<Target>, SceneError> {
        criteria
            .iter()
            .enumerate()
            .map(|(k, spec)| {
                let region = match &spec.region {
                    None => None,
                    Some(name) => {
                        let members = family(&self.criteria, spec.criterion).len();
                        let found = (0..members)
                            .find(|&r| region_name(&self.criteria, spec.criterion, r) == name);
                        Some(found.ok_or_else(|| {
                            SceneError::new(
                                format!("criteria[{k}]"),
                                format!(
                                    "{}: region '{name}' is not one of the regions {} is defined on",
                                    spec.name(),
                                    spec.criterion.name()
                                ),
                            )
                        })?)
                    }
                };
                Ok(Target {
                    criterion: spec.criterion,
                    region,
                })
            })
            .collect()
    }

    /// The name of the region where a solution's Φ is largest (`None` where Φ has no value).
    pub fn attaining_region(&self, solution: &Solution, criterion: Criterion) -> Option<&str> {
        attaining(&solution.region_values[criterion as usize])
            .map(|r| region_name(&self.criteria, criterion, r))
    }

    /// Solve the state problem for `data` and differentiate the criteria along the parameter of
    /// every stencil ([`Solution::sensitivities`], one entry per stencil). A derivative that
    /// cannot be computed leaves the sensitivities empty with a warning; the state stands.
    pub fn solve_with_sensitivities(
        &self,
        data: &Data,
        options: &SolveOptions,
        stencils: &[Stencil],
    ) -> Result<Solution, WsmError> {
        self.solve_with_sensitivities_by(data, options, stencils, DerivativeRoute::Adjoint)
    }

    /// [`Self::solve_with_sensitivities`] with the derivatives taken by `route` (the forward
    /// route serves as the check and the cost baseline of the adjoint one).
    pub fn solve_with_sensitivities_by(
        &self,
        data: &Data,
        options: &SolveOptions,
        stencils: &[Stencil],
        route: DerivativeRoute,
    ) -> Result<Solution, WsmError> {
        let start = Instant::now();
        let (mut solution, elastic, mut report) = self.solve_parts(data, options)?;
        if !stencils.is_empty() {
            let t0 = Instant::now();
            let sensitivities =
                self.differentiate(data, options, elastic.as_ref(), &solution, stencils, route);
            match sensitivities {
                Ok((s, regions, adjoint)) => {
                    solution.sensitivities = s;
                    solution.region_sensitivities = regions;
                    report.adjoint_directions = adjoint;
                }
                Err(e) => report.warnings.push(Warning::new(
                    WarningKind::Sensitivities,
                    "",
                    format!("the sensitivities are not available: {e}"),
                )),
            }
            report.timings.sensitivities = t0.elapsed().as_secs_f64();
        }
        report.timings.total = start.elapsed().as_secs_f64();
        solution.report = report;
        Ok(solution)
    }

    /// Solve the elastic state for `data` and take its derivative along every stencil (§4.4's
    /// forward tangent: per stencil du on the free DOFs and dλ per multiplier row along +θ_j,
    /// and along −θ_j where the state is only one-sided differentiable). The tangents are an
    /// error of their own (the solution stands without them); scenes without a thermal part.
    pub(crate) fn solve_with_tangents(
        &self,
        data: &Data,
        options: &SolveOptions,
        stencils: &[Stencil],
    ) -> Result<(Solution, Result<Vec<TangentDisplacement>, WsmError>), WsmError> {
        let start = Instant::now();
        let (mut solution, elastic, mut report) = self.solve_parts(data, options)?;
        let t0 = Instant::now();
        let tangents = match elastic {
            Some(parts) => self.with_solved_state(data, options, &parts, &solution, |state| {
                self.state_tangents(state, stencils)
            }),
            None => Err(WsmError::contact("the elastic state was not solved")),
        };
        report.timings.sensitivities = t0.elapsed().as_secs_f64();
        report.timings.total = start.elapsed().as_secs_f64();
        solution.report = report;
        Ok((solution, tangents))
    }

    /// The state for `data` (heat when needed, elastic contact, criteria) with its elastic
    /// parts and its report (total time not set).
    fn solve_parts(
        &self,
        data: &Data,
        options: &SolveOptions,
    ) -> Result<(Solution, Option<ElasticParts>, SolveReport), WsmError> {
        let mesh = self.mesh();
        let mut report = SolveReport {
            solver: SolverUsed::Direct,
            nodes: mesh.nodes.len(),
            triangles: mesh.triangles.len(),
            unknowns: self.elastic.dofs().n_free(),
            contact_pairs: self.contact.geometry.pairs.len(),
            floating_modes: self.contact.kernel_dim(),
            ..SolveReport::default()
        };
        let temperature = if options.needs.heat {
            let t0 = Instant::now();
            let t = self.temperature(data, options.par)?;
            report.timings.heat = t0.elapsed().as_secs_f64();
            Some(t)
        } else {
            if self.heat.is_some() {
                report
                    .skipped
                    .push("heat solve (no requested criterion needs it)".into());
            }
            None
        };
        let mut solution = Solution::default();
        let mut elastic = None;
        if options.needs.elastic {
            elastic = Some(self.solve_elastic(
                data,
                options,
                temperature.as_deref().map(Vec::as_slice),
                &mut solution,
                &mut report,
            )?);
        } else {
            report
                .skipped
                .push("elastic contact solve (only thermal criteria requested)".into());
        }
        let t0 = Instant::now();
        solution.region_values = per_region(
            &self.criteria,
            &Fields {
                temperature: temperature.as_deref().map(Vec::as_slice),
                displacement: options
                    .needs
                    .elastic
                    .then_some(solution.displacement.as_slice()),
                stresses: options
                    .needs
                    .elastic
                    .then_some(solution.stresses.as_slice()),
                multipliers: elastic.as_ref().map(|e| e.contact.multipliers.as_slice()),
                velocity: None,
            },
        );
        solution.criteria = maxima(&solution.region_values);
        report.timings.post += t0.elapsed().as_secs_f64();
        solution.temperature = temperature.map(|t| t.as_ref().clone());
        Ok((solution, elastic, report))
    }

    /// The sensitivities of a solved state (the direct factor is built for a DD state).
    fn differentiate(
        &self,
        data: &Data,
        options: &SolveOptions,
        elastic: Option<&ElasticParts>,
        solution: &Solution,
        stencils: &[Stencil],
        route: DerivativeRoute,
    ) -> Result<(Sensitivities, RegionSensitivities, usize), WsmError> {
        let bound = &options.needs.bound_regions;
        match elastic {
            Some(parts) => self.with_solved_state(data, options, parts, solution, |state| {
                self.sensitivities(state, stencils, route, bound)
            }),
            None => {
                let state = SolvedState {
                    data,
                    temperature: solution.temperature.as_deref(),
                    elastic: None,
                };
                self.sensitivities(&state, stencils, route, bound)
            }
        }
    }

    /// `f` of the solved state with its elastic part (the direct factor is built for a DD
    /// state).
    fn with_solved_state<T>(
        &self,
        data: &Data,
        options: &SolveOptions,
        parts: &ElasticParts,
        solution: &Solution,
        f: impl FnOnce(&SolvedState) -> Result<T, WsmError>,
    ) -> Result<T, WsmError> {
        let factor = match &parts.factor {
            Some(f) => f.clone(),
            None => self.stiffness_factor(&parts.coefficients, options.par)?.0,
        };
        let state = SolvedState {
            data,
            temperature: solution.temperature.as_deref(),
            elastic: Some(ElasticState {
                coefficients: &parts.coefficients,
                factor: &factor,
                contact: &parts.contact,
                displacement: &solution.displacement,
                stresses: &solution.stresses,
            }),
        };
        f(&state)
    }

    fn solve_elastic(
        &self,
        data: &Data,
        options: &SolveOptions,
        temperature: Option<&[f64]>,
        solution: &mut Solution,
        report: &mut SolveReport,
    ) -> Result<ElasticParts, WsmError> {
        let elastic = &self.elastic;
        let t0 = Instant::now();
        self.contact
            .feasibility
            .check(&self.scene, self.mesh(), &self.contact.geometry, data)?;
        let coefficients = elastic.coefficients(data)?;
        if elastic.element() == Element::P1 {
            report.warnings.extend(
                locking_warnings(&coefficients, elastic.mesh())
                    .into_iter()
                    .map(|(_, w)| w),
            );
        }
        let fixed = elastic.fixed_values(data)?;
        let rhs = elastic.load_rhs(data, temperature, &coefficients, &fixed)?;
        report.timings.assembly = t0.elapsed().as_secs_f64();
        self.counters.elastic_solves.fetch_add(1, Ordering::Relaxed);
        let t1 = Instant::now();
        let mut direct_factor = None;
        let sol = if self.scene.solver.kind == SolverKind::Dd {
            self.solve_dd(
                LoadCase {
                    data,
                    coefficients: &coefficients,
                    rhs: &rhs,
                    fixed: &fixed,
                },
                options,
                report,
            )?
        } else {
            let (factor, reused) = self.stiffness_factor(&coefficients, options.par)?;
            direct_factor = Some(factor.clone());
            report.reused_factorisation = reused;
            report.timings.factor = t1.elapsed().as_secs_f64();
            if !reused {
                [report.timings.numeric, report.timings.hessian] = factor.seconds;
            }
            let t1 = Instant::now();
            let sol =
                self.contact
                    .solve(&factor, elastic, &rhs, &fixed, data, options.warm.as_ref())?;
            report.timings.contact = t1.elapsed().as_secs_f64();
            report.timings.qp = sol.qp_seconds;
            sol
        };
        let t2 = Instant::now();
        let u = elastic.dofs().expand(&sol.u_free, &fixed);
        let u_scale = u
            .iter()
            .fold(0.0_f64, |m, v| m.max(v[0].abs()).max(v[1].abs()));
        let (nodes, kkt) = contact_results(
            &self.contact.geometry,
            &sol,
            data,
            &elastic.mesh().nodes,
            u_scale,
        );
        report.kkt = kkt;
        report.coulomb = sol.coulomb;
        if let Some(qp) = &sol.qp {
            report.qp_iterations = qp.iterations;
            report.qp_fallback_iterations = qp.fallback_iterations;
            report.active_set_changes = qp.active_set_changes;
            report.undetermined_modes = qp.undetermined_modes;
        }
        if let Some(sparse) = &sol.sparse {
            if report.solver == SolverUsed::Direct {
                report.solver = SolverUsed::DirectSparse;
            }
            report.sparse_steps = sparse.steps;
            report.active_set_changes = sparse.changes;
        }
        report.undetermined_modes = report.undetermined_modes.max(sol.free_motions);
        if report.undetermined_modes > 0 {
            report.warnings.push(Warning::new(
                WarningKind::RigidMotion,
                "",
                format!(
                    "{} rigid motion(s) of floating bodies are not determined by contact (e.g. frictionless sliding with balanced loads); the displacement with no component along them is reported",
                    report.undetermined_modes
                ),
            ));
        }
        solution.stresses = elastic.stresses(data, &u, temperature)?;
        solution.displacement = u;
        solution.contact = nodes;
        solution.warm_start = Some(WarmStart {
            x: sol.multipliers.clone(),
            alpha: sol.rigid.clone(),
        });
        report.timings.post += t2.elapsed().as_secs_f64();
        Ok(ElasticParts {
            coefficients,
            factor: direct_factor,
            contact: sol,
        })
    }

    /// The stiffness factorisation of the direct solver for the coefficients (memoised), and
    /// whether it was reused whole. Body blocks whose zone coefficients were seen before reuse
    /// their factor (keyed by the exact bits, so a reused factor equals a fresh one).
    fn stiffness_factor(
        &self,
        coefficients: &[ElasticCoefficients],
        par: Par,
    ) -> Result<(Arc<StiffnessFactor>, bool), WsmError> {
        let key = memo::key(coefficients.iter().flatten().copied());
        let body = |b: usize, block: &crate::contact::bodies::BodyBlock, values: &[f64]| {
            let key = memo::key(block.zones.iter().flat_map(|&z| coefficients[z]));
            self.body_factors[b].get_or_try(key, || {
                self.counters
                    .body_factorisations
                    .fetch_add(1, Ordering::Relaxed);
                block.factor(values).map(Arc::new)
            })
        };
        self.factors.get_or_try(key, || {
            let factor = self
                .contact
                .factor_with(&self.elastic, coefficients, par, &body)?;
            if factor.reused_bodies < self.contact.bodies().len() {
                self.counters.factorisations.fetch_add(1, Ordering::Relaxed);
            }
            Ok(Arc::new(factor))
        })
    }

    /// The elastic contact solve by domain decomposition (design §3.2); the direct solver is the
    /// fallback, used (and reported in `report.dd.fallback`) only when DD fails.
    fn solve_dd(
        &self,
        case: LoadCase,
        options: &SolveOptions,
        report: &mut SolveReport,
    ) -> Result<ContactSolution, WsmError> {
        let elastic = &self.elastic;
        let LoadCase {
            data,
            coefficients,
            rhs,
            fixed,
        } = case;
        let direct = || -> Result<DirectAnswer, String> {
            let (factor, _) = self
                .stiffness_factor(coefficients, options.par)
                .map_err(|e| e.to_string())?;
            let sol = self
                .contact
                .solve(&factor, elastic, rhs, fixed, data, options.warm.as_ref())
                .map_err(|e| e.to_string())?;
            Ok(DirectAnswer {
                u: sol.u_free,
                multipliers: sol.multipliers.chunks(2).map(|c| [c[0], c[1]]).collect(),
            })
        };
        let mut dd_options = crate::dd::from_scene::options(&self.scene, elastic.mesh());
        let partition = self.dd_partition.get_or_init(|| {
            crate::dd::from_scene::partition(elastic, &self.contact, &self.nominal, &dd_options)
        });
        // A partition error is left to the solve below, which reports it as before.
        if let Ok(p) = partition {
            dd_options.partition = crate::dd::PartitionRequest::Given(Box::new(p.clone()));
        }
        dd_options.operators = Some(self.dd_operators.clone());
        let outcome = crate::dd::from_scene::solve_elastic(
            elastic,
            &self.contact,
            case,
            &dd_options,
            Some(&direct),
        );
        // A DD answer that does not balance the loads is never returned as a solution.
        let limit = DD_EQUILIBRIUM_LIMIT.max(100.0 * self.scene.solver.tolerance);
        let unbalanced = |sol: &ContactSolution| sol.equilibrium_residual > limit;
        let (sol, dd) = match outcome {
            Ok((sol, _)) if unbalanced(&sol) => {
                let e = format!(
                    "the result does not balance the loads (relative equilibrium residual {:.1e})",
                    sol.equilibrium_residual
                );
                return self.direct_instead(&e, case, options, report);
            }
            Ok(done) => done,
            // A partition the user fixed is bad input, not a reason to switch solvers.
            Err(crate::dd::DdError::Partition(reason))
                if !self.scene.solver.partition.is_empty() =>
            {
                return Err(SceneError::new("solver.partition", reason).into());
            }
            Err(e) => {
                // DD cannot be set up for this scene (e.g. a cluster with an unsupported
                // floating part): answer with the direct solver and say why.
                return self.direct_instead(&e.to_string(), case, options, report);
            }
        };
        report.solver = SolverUsed::Dd;
        let times = &dd.report.times;
        report.timings.contact = times.total;
        report.timings.dd_setup = times.setup;
        report.timings.dd_pcg1 = times.pcg1;
        report.timings.dd_outer = times.outer;
        report.timings.dd_recovery = times.recovery;
        if let Some(fallback) = &dd.report.fallback {
            report.warnings.push(Warning::new(
                WarningKind::SolverFallback,
                "solver.dd",
                fallback.clone(),
            ));
        }
        report.dd = Some(Box::new(dd.report));
        Ok(sol)
    }

    /// The direct solver's answer when DD cannot give one, with the reason as a warning.
    fn direct_instead(
        &self,
        reason: &str,
        case: LoadCase,
        options: &SolveOptions,
        report: &mut SolveReport,
    ) -> Result<ContactSolution, WsmError> {
        let LoadCase {
            data,
            coefficients,
            rhs,
            fixed,
        } = case;
        report.solver = SolverUsed::DirectDdUnavailable;
        report.warnings.push(Warning::new(
            WarningKind::SolverFallback,
            "domain decomposition",
            format!("{reason}; solved by the direct solver"),
        ));
        let (factor, reused) = self.stiffness_factor(coefficients, options.par)?;
        report.reused_factorisation = reused;
        self.contact.solve(
            &factor,
            &self.elastic,
            rhs,
            fixed,
            data,
            options.warm.as_ref(),
        )
    }

    /// The temperature field of the data (reused when the thermal data did not change).
    fn temperature(&self, data: &Data, par: Par) -> Result<Arc<Vec<f64>>, WsmError> {
        let heat = self.heat_problem()?;
        let (t, _) = self.temperatures.get_or_try(thermal_key(data), || {
            self.counters.heat_solves.fetch_add(1, Ordering::Relaxed);
            let factor = self.heat_factor(data, par)?;
            Ok::<_, WsmError>(Arc::new(heat.solve(&factor, data)?))
        })?;
        Ok(t)
    }

    /// The heat problem, or the error of a scene without a thermal part.
    fn heat_problem(&self) -> Result<&HeatProblem, WsmError> {
        self.heat.as_ref().ok_or_else(|| WsmError::Solver {
            stage: crate::error::SolverStage::Heat,
            reason: "the scene has no thermal part".into(),
        })
    }

    /// The factor of the heat operator for the conductivities of `data` (memoised).
    fn heat_factor(&self, data: &Data, par: Par) -> Result<Arc<OperatorFactor<3>>, WsmError> {
        let heat = self.heat_problem()?;
        let coefficients = heat.coefficients(data)?;
        let key = memo::key(coefficients.iter().flatten().copied());
        let (factor, _) = self.heat_factors.get_or_try(key, || {
            Ok::<_, WsmError>(Arc::new(heat.operator().factor(&coefficients, par)?))
        })?;
        Ok(factor)
    }
}

/// The elastic part of a solve that its sensitivities need.
struct ElasticParts {
    coefficients: Vec<ElasticCoefficients>,
    /// The direct solver's factor (None after a DD solve).
    factor: Option<Arc<StiffnessFactor>>,
    contact: ContactSolution,
}

/// The memo key of the numbers the temperature field depends on.
fn thermal_key(data: &Data) -> Vec<u64> {
    let thermal_numbers = data
        .materials
        .iter()
        .flat_map(|m| m.conductivity.into_iter().chain([m.heat_source]))
        .chain(data.boundary.iter().filter_map(|b| match b.value {
            BoundaryValue::Temperature(v) | BoundaryValue::HeatFlux(v) => Some(v),
            _ => None,
        }));
    memo::key(thermal_numbers)
}

/// Memory for cached body factors of a scene \[bytes\] (shared by its bodies).
const BODY_CACHE_BYTES: usize = 1 << 28;

/// Largest relative equilibrium residual ‖K u − f + Bᵀλ‖ / ‖f‖ of an accepted DD result (or 100 ×
/// the DD tolerance when that is larger); above it the direct solver answers (with a warning).
const DD_EQUILIBRIUM_LIMIT: f64 = 1e-6;

/// P1 triangles lock for nearly incompressible materials: warn from ν ≥ 0.49, with ν = (K − G)/(2K)
/// from the plane-strain bulk and shear moduli of D ([`crate::scene::law::bulk_and_shear`];
/// isotropic: λ/(2(λ + μ)), Poisson's ratio). One (zone index, message) per zone that locks.
pub fn locking_warnings(
    coefficients: &[ElasticCoefficients],
    mesh: &Mesh,
) -> Vec<(usize, Warning)> {
    coefficients
        .iter()
        .zip(&mesh.zones)
        .enumerate()
        .filter_map(|(index, (c, zone))| {
            let (bulk, shear) = crate::scene::law::bulk_and_shear(c);
            let nu = (bulk - shear) / (2.0 * bulk);
            (nu >= 0.49).then(|| {
                let message = format!(
                    "Poisson's ratio {nu:.4} is close to 0.5; linear triangles lock (stresses and displacements are underestimated)"
                );
                let subject = format!("zone '{}'", zone.name);
                (index, Warning::new(WarningKind::Locking, subject, message))
            })
        })
        .collect()
}
