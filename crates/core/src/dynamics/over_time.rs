//! The criteria of a dynamic scene over time (design §3.5, "The worst scenario over time").
//!
//! **Values.** Φ_i of a run is the largest value over the time steps t_n (t = 0 included) of the
//! static Φ_i (design §4.2, FGCS 4.29–4.34) at the state u(t_n): per region r of Φ_i's family,
//! V_r = max_n V_r(u(t_n)), and Φ_i = max_r V_r (a criterion bound to a region reads its V_r).
//! Every criterion is a function of the displacement, as in statics: Φ3, Φ4 of u, the stress
//! criteria Φ5 (mean I2²) and Φ6 (mean normal pressure) of the elastic stress c⁽⁰⁾ e(u(t_n)) —
//! the Kelvin–Voigt part c⁽¹⁾ e(u′) is left out. The defined criteria (design §4.2) are taken
//! the same way, each its own maximum over time: a stress quantity's mean of c⁽⁰⁾ e(u(t_n)), a
//! contact traction's mean of the step's forces λ_{n+1}, and a receiver's peak velocity
//! max_n |v_n(x_r)|, v_n the scheme's velocity interpolated in P1 at the receiver. The time
//! reported is the first step that reaches the maximum.
//!
//! **Derivatives.** Forward (direct) differentiation through the time loop: per uncertain datum
//! θ_j the tangent (du/dθ, dv/dθ, dλ/dθ) is carried through the steps. A step solves
//! A u_{n+1} = F(u_n, v_n, b) − BᵀΛ (module `scheme`); with the data derivative of the step,
//! g = F(dM, dC, dK; u_n, v_n, db) − dA u_{n+1} (dA = dM + a dC + c dK, db = df − d(K_fd u_d),
//! operators and loads differentiated by the datum's stencil, exact for the affine data maps),
//! and y = A⁻¹ (F(M, C, K; du_n, dv_n, 0) + g), the multiplier derivative dΛ solves the tangent
//! QP of the step (the one of the static contact tangent, `contact::direct::tangent`) on the
//! step's C_h = B A⁻¹ Bᵀ: min ½ dΛᵀ C_h dΛ − dΛᵀ d′ with d′ = B y + B_d du_d (normal rows) or
//! B y − B du_n (tangential rows: the friction acts on the step's slip); free rows (active normal,
//! sticking tangential) unconstrained, rows strictly at a bound follow the bound's derivative —
//! a slipping Coulomb row s(dF λ_n + F dλ_n) with λ_n of the previous level, a Tresca row
//! s dg w, an open normal row 0 — and weakly active rows one-sided. Then du_{n+1} = y − W dΛ
//! with W = A⁻¹ Bᵀ, computed as A⁻¹ (F(du_n, dv_n) + g − Bᵀ dΛ), and dv_{n+1} by the scheme's
//! velocity update. Each step's tangent reuses the step's factor of A and C_h: k data cost k
//! extra solves per step (2k where dΛ ≠ 0).
//!
//! A criterion reads the tangent through its derivative form (`state`'s region forms): du, dτ
//! (with the law's change), dλ, and for a receiver (v/|v|)·dv(x_r) — the receiver's velocity is
//! a linear functional of the state, its speed is not differentiable where v(x_r) = 0, and there
//! the one-sided derivatives are |dv(x_r)| along the tangent of each side.
//!
//! The derivative of a region's maximum over time is the derivative at the maximising step; where
//! steps tie (relative [`TIE_TOL`]) the right derivative is the largest right one and the left the
//! smallest left one, and the maximum over regions is treated as the static criteria treat it
//! ([`crate::state`]'s one-sided rule). Along −θ_j the tangent is −(the tangent along +θ_j) until
//! a step is only one-sided differentiable (a weakly active row, a pinched row whose bounds move
//! apart, a Coulomb bound at an open pair whose normal force moves, a slip-rate bound at v = 0);
//! from there on the tangent along −θ_j is carried separately, so both one-sided derivatives are
//! exact directional derivatives of the run.
//!
//! **Initial tangent.** A run from rest starts from the zero tangent; a run from the static
//! contact solution (`dynamics.initial = "static"`) from the static state's own forward tangent
//! (design §4.4, `StateProblem::solve_with_tangents`) along the same datum at t = 0: du_0 and
//! dλ_0 from the static solve, dv_0 = 0 (initial velocities are not uncertain), and the static
//! tangent along −θ_j where the static state is only one-sided differentiable.
//!
//! **Slip-rate friction** (paper (6)): the bound of a slipping pair is
//! G = F(v) max(λ_n, 0) with F(v) = F_k + (F_s − F_k) e^{−|v|/v_c}, v = (B v_n)_t and λ_n of the
//! previous level, so dG = F(v) d max(λ_n, 0) + max(λ_n, 0) F′(v; dv) + (the data's part), with
//! dv = (B dv_n)_t of the carried tangent and F′(v; dv) = −(F_s − F_k)/v_c e^{−|v|/v_c} d|v|,
//! d|v| = sign(v) dv and |dv| at v = 0 (a directional derivative; at that kink the tangent
//! along −θ_j is carried separately). The data's part comes from the stencil's bounds, F(v) at
//! each point's F_s (F is affine in F_s).

use std::time::Instant;

use faer::Mat;

use super::excitation::{slip_rate_bounds, SlipRateLaw};
use super::history::CriterionPeak;
use super::operators::Operators;
use super::scheme::{rhs, velocity, SecondOrderSystem};
use super::step::StepContact;
use super::{simulate_observed, FemSystem, RunContext, StepObserver, StepView};
use crate::contact::direct::{
    classify, tangent_bounds, ContactPoint, DataDerivative, RowMotion, TangentDisplacement,
};
use crate::contact::pairs::{
    is_normal_row, is_tangential_row, normal_row, pair_of_row, tangential_row,
};
use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions};
use crate::error::WsmError;
use crate::fem::ElementStress;
use crate::scene::params::Stencil;
use crate::scene::{Criterion, Data, InitialState, SceneError, Warning, WarningKind};
use crate::state::{
    add_scaled, attaining, maxima, one_sided, per_region_with, receiver_velocity, region_forms,
    region_name, tied_regions, Fields, OneSided, PerCriterion, Solution, StateProblem, TIE_TOL,
};

/// The index of the defined criteria in the per-criterion arrays.
const DEFINED: usize = Criterion::Defined as usize;

/// Why a dynamic scene has no exact derivatives over time (the field and the reason), if it
/// has none: a run from the static solution of a scene with a Coulomb zone on the sparse
/// contact path, whose static state has no derivative there (the search runs on values).
pub fn derivatives_unavailable(problem: &StateProblem) -> Option<(&'static str, &'static str)> {
    let dynamics = problem.scene.dynamics.as_ref()?;
    (dynamics.initial == InitialState::Static
        && problem.contact.is_sparse()
        && problem.nominal.has_coulomb())
    .then_some((
        "solver.contact",
        "a run from the static solution starts from the static state's tangent, and a Coulomb \
         state has none on the sparse contact path (solver.contact: \"dense\" gives it)",
    ))
}

/// The requested criteria of a dynamic scene as maxima over time, with their exact one-sided
/// derivatives along the parameter of every stencil (none without stencils): a [`Solution`]
/// whose `criteria`, `region_values`, `peak_times`, `sensitivities` and `region_sensitivities`
/// are those of the run (its fields are empty: the run's state changes with time).
pub fn solve_over_time(
    problem: &StateProblem,
    data: &Data,
    criteria: &[Criterion],
    stencils: &[Stencil],
) -> Result<Solution, WsmError> {
    let started = Instant::now();
    let mut over = OverTime::new(problem, data, criteria, stencils)?;
    let run = simulate_observed(problem, data, &mut over, &mut super::Hooks::default())?;
    let mut solution = Solution::default();
    over.fill(&mut solution);
    let mesh = problem.mesh();
    let report = &mut solution.report;
    report.nodes = mesh.nodes.len();
    report.triangles = mesh.triangles.len();
    report.unknowns = run.history.report.unknowns;
    report.qp_iterations = run.history.report.qp_iterations;
    report.active_set_changes = run.history.report.active_set_changes;
    report.timings.total = started.elapsed().as_secs_f64();
    Ok(solution)
}

/// The largest value over time of one region value, with its one-sided derivatives per
/// direction over the steps that tie for it.
#[derive(Debug, Clone)]
struct Peak {
    value: f64,
    time: f64,
    right: Vec<f64>,
    left: Vec<f64>,
}

impl Peak {
    /// Take the value at time `t` with its derivatives into the maximum.
    fn update(&mut self, value: f64, t: f64, right: &[f64], left: &[f64]) {
        let scale = value.abs().max(self.value.abs());
        if !self.value.is_finite() || value > self.value + TIE_TOL * scale {
            *self = Peak {
                value,
                time: t,
                right: right.to_vec(),
                left: left.to_vec(),
            };
        } else if value >= self.value - TIE_TOL * scale {
            for (a, b) in self.right.iter_mut().zip(right) {
                *a = a.max(*b);
            }
            for (a, b) in self.left.iter_mut().zip(left) {
                *a = a.min(*b);
            }
        }
    }
}

/// The state derivative along one signed direction: du, dv on the free DOFs and the
/// derivative of the contact forces λ (per multiplier row).
#[derive(Debug, Clone)]
struct Tangent {
    du: Vec<f64>,
    dv: Vec<f64>,
    dforces: Vec<f64>,
}

impl Tangent {
    fn negated(&self) -> Tangent {
        let neg = |x: &[f64]| x.iter().map(|v| -v).collect();
        Tangent {
            du: neg(&self.du),
            dv: neg(&self.dv),
            dforces: neg(&self.dforces),
        }
    }
}

/// One datum's derivative of the run's data, fixed over the run, and its tangents.
struct Direction<'a> {
    stencil: &'a Stencil,
    /// Σ_k w_k of the operators at the stencil's data and the values of dA = dM + a dC + c dK
    /// (`None`: the operators do not move).
    operators: Option<(Operators, Vec<f64>)>,
    /// du_d.
    fixed: Vec<f64>,
    /// Whether the loads, the multiplier bounds' data and the stress law move.
    loads: bool,
    bounds: bool,
    law: bool,
    /// d(f − K_fd u_d) at the current level (free DOFs).
    load_now: Vec<f64>,
    /// Along +θ, and along −θ once the run is only one-sided differentiable (`None`: minus
    /// the tangent along +θ).
    plus: Tangent,
    minus: Option<Tangent>,
}

/// A system whose products are zero: the load part of a step's right-hand side alone.
struct Zero;

impl SecondOrderSystem for Zero {
    fn mass(&self, x: &[f64]) -> Vec<f64> {
        vec![0.0; x.len()]
    }
    fn damping(&self, x: &[f64]) -> Vec<f64> {
        vec![0.0; x.len()]
    }
    fn stiffness(&self, x: &[f64]) -> Vec<f64> {
        vec![0.0; x.len()]
    }
}

/// Sees a run: the region values at every step, their maxima over time, and the tangents.
pub(super) struct OverTime<'a> {
    problem: &'a StateProblem,
    data: &'a Data,
    /// Φ1..Φ6 asked for.
    wanted: PerCriterion<bool>,
    /// Whether the stresses are needed (Φ5, Φ6 or a defined criterion asked for).
    stresses: bool,
    /// Whether the velocity is needed (a receiver's peak velocity asked for).
    speeds: bool,
    /// Elements the criteria regions read (where the law's change enters dτ).
    elements: Vec<usize>,
    peaks: PerCriterion<Vec<Peak>>,
    directions: Vec<Direction<'a>>,
    /// Why the static start's tangent is not available (then no direction is carried).
    unavailable: Option<String>,
}

impl<'a> OverTime<'a> {
    /// Prepare the criteria `criteria` and a direction per stencil.
    pub(super) fn new(
        problem: &'a StateProblem,
        data: &'a Data,
        criteria: &[Criterion],
        stencils: &'a [Stencil],
    ) -> Result<OverTime<'a>, WsmError> {
        let scene = &problem.scene;
        if let Some((field, reason)) =
            derivatives_unavailable(problem).filter(|_| !stencils.is_empty())
        {
            return Err(SceneError::new(field, reason).into());
        }
        let wanted: PerCriterion<bool> =
            std::array::from_fn(|i| criteria.iter().any(|c| *c as usize == i));
        let defined = &problem.criteria.defined;
        let stresses = wanted[Criterion::Phi5 as usize]
            || wanted[Criterion::Phi6 as usize]
            || (wanted[DEFINED] && !defined.is_empty());
        let speeds = wanted[DEFINED] && defined.iter().any(|d| d.quantity.is_receiver());
        let mut elements: Vec<usize> = problem
            .criteria
            .regions
            .iter()
            .flat_map(|r| r.element_weights.iter().map(|&(e, _)| e))
            .collect();
        elements.sort_unstable();
        elements.dedup();
        let elastic = &problem.elastic;
        let (n, m) = (elastic.dofs().n_free(), problem.contact.geometry.dim());
        let constants = scene
            .dynamics
            .as_ref()
            .map(|d| super::scheme::constants(d.scheme, d.dt))
            .ok_or_else(|| SceneError::new("dynamics", "the scene has no `dynamics`"))?;
        let zero = Tangent {
            du: vec![0.0; n],
            dv: vec![0.0; n],
            dforces: vec![0.0; m],
        };
        let directions = stencils
            .iter()
            .map(|stencil| {
                let moves =
                    |same: &dyn Fn(&Data) -> bool| stencil.points.iter().any(|(_, _, d)| !same(d));
                let operators =
                    if moves(&|d| d.materials == data.materials && d.dynamic == data.dynamic) {
                        let sum = weighted_operators(problem, stencil)?;
                        let da = sum.combination(constants.damping, constants.stiffness);
                        Some((sum, da))
                    } else {
                        None
                    };
                let mut fixed = vec![0.0; elastic.dofs().n_fixed()];
                for (_, w, d) in &stencil.points {
                    add_scaled(&mut fixed, *w, &elastic.fixed_values(d)?);
                }
                let mut direction = Direction {
                    stencil,
                    operators,
                    fixed,
                    loads: moves(&|d| d.boundary == data.boundary && d.materials == data.materials),
                    bounds: moves(&|d| d.slip == data.slip && d.friction == data.friction),
                    law: moves(&|d| d.materials == data.materials),
                    load_now: Vec::new(),
                    plus: zero.clone(),
                    minus: None,
                };
                direction.load_now = load_derivative(problem, &direction, 0.0)?;
                Ok(direction)
            })
            .collect::<Result<_, WsmError>>()?;
        Ok(OverTime {
            problem,
            data,
            wanted,
            stresses,
            speeds,
            elements,
            peaks: Default::default(),
            directions,
            unavailable: None,
        })
    }

    /// The static start with every direction's initial tangent: the static state's tangent
    /// along the datum's stencil at t = 0 (no direction is carried when it has none).
    fn static_start(&mut self, problem: &StateProblem, data: &Data) -> Result<Solution, WsmError> {
        if self.directions.is_empty() {
            return super::static_start(problem, data);
        }
        let at_start: Vec<Stencil> = self
            .directions
            .iter()
            .map(|d| Stencil {
                points: (d.stencil.points.iter())
                    .map(|(t, w, point)| (*t, *w, super::data_at(&problem.scene, point, 0.0)))
                    .collect(),
            })
            .collect();
        let (start, tangents) = super::static_start_with_tangents(problem, data, &at_start)?;
        match tangents {
            Ok(tangents) => {
                for (direction, tangent) in self.directions.iter_mut().zip(tangents) {
                    (direction.plus, direction.minus) = initial_tangents(tangent, &direction.plus);
                }
            }
            Err(e) => {
                self.unavailable = Some(e.to_string());
                self.directions.clear();
            }
        }
        Ok(start)
    }

    /// The region values at the state `u`, `v` (free DOFs) and contact forces λ at time `t`,
    /// and their derivatives along every direction, into the maxima.
    fn record(
        &mut self,
        context: &RunContext,
        t: f64,
        u: &[f64],
        v: &[f64],
        forces: &[f64],
    ) -> Result<(), WsmError> {
        let (problem, data) = (self.problem, self.data);
        let elastic = &problem.elastic;
        let global = elastic.dofs().expand(u, context.fixed);
        let stresses = match self.stresses {
            true => Some(elastic.stresses(data, &global, None)?),
            false => None,
        };
        let zero_fixed = vec![0.0; elastic.dofs().n_fixed()];
        let nodal_velocity = |v: &[f64]| self.speeds.then(|| elastic.dofs().expand(v, &zero_fixed));
        let velocity = nodal_velocity(v);
        let fields = Fields {
            temperature: None,
            displacement: Some(&global),
            stresses: stresses.as_deref(),
            multipliers: Some(forces),
            velocity: velocity.as_deref(),
        };
        let mut forms = region_forms(&problem.criteria, &fields);
        for (i, f) in forms.iter_mut().enumerate() {
            if !self.wanted[i] {
                f.clear();
            }
        }
        let mut values = per_region_with(&problem.criteria, &fields, &forms);
        for (i, v) in values.iter_mut().enumerate() {
            if !self.wanted[i] {
                v.clear();
            }
        }
        // Receivers at rest: |v| has only one-sided derivatives there, |dv(x_r)| along every
        // direction (their forms are empty).
        let kinks: Vec<usize> = problem
            .criteria
            .defined
            .iter()
            .enumerate()
            .filter(|(k, d)| {
                d.quantity.is_receiver()
                    && values[DEFINED].get(*k).is_some_and(|&speed| speed == 0.0)
            })
            .map(|(k, _)| k)
            .collect();
        // Per direction, per Φ, per region: the right and left derivatives.
        let mut right: Vec<PerCriterion<Vec<f64>>> = Vec::with_capacity(self.directions.len());
        let mut left: Vec<PerCriterion<Vec<f64>>> = Vec::with_capacity(self.directions.len());
        for direction in &self.directions {
            let law = match self.stresses && direction.law {
                true => Some(self.law_part(direction.stencil, &global)?),
                false => None,
            };
            let along =
                |tangent: &Tangent, sign: f64| -> Result<PerCriterion<Vec<f64>>, WsmError> {
                    let fixed: Vec<f64> = direction.fixed.iter().map(|x| sign * x).collect();
                    let du = elastic.dofs().expand(&tangent.du, &fixed);
                    let dtau = match self.stresses {
                        true => {
                            let mut s = elastic.stress_increments(data, &du, None)?;
                            if let Some(law) = &law {
                                for (&e, part) in self.elements.iter().zip(law) {
                                    for (sc, pc) in s[e].stress.iter_mut().zip(part) {
                                        *sc += sign * pc;
                                    }
                                }
                            }
                            Some(s)
                        }
                        false => None,
                    };
                    let dv = nodal_velocity(&tangent.dv);
                    let tangent_fields = Fields {
                        temperature: None,
                        displacement: Some(&du),
                        stresses: dtau.as_deref(),
                        multipliers: Some(&tangent.dforces),
                        velocity: dv.as_deref(),
                    };
                    let mut out: PerCriterion<Vec<f64>> = forms
                        .each_ref()
                        .map(|f| f.iter().map(|form| form.apply(&tangent_fields)).collect());
                    for &k in &kinks {
                        let receiver = &problem.criteria.defined[k].receiver;
                        let [x, y] = receiver_velocity(receiver, dv.as_deref());
                        out[DEFINED][k] = x.hypot(y);
                    }
                    Ok(out)
                };
            let plus = along(&direction.plus, 1.0)?;
            let minus = match &direction.minus {
                Some(tangent) => along(tangent, -1.0)?.map(|d| d.iter().map(|v| -v).collect()),
                None => {
                    let mut minus = plus.clone();
                    for &k in &kinks {
                        minus[DEFINED][k] = -plus[DEFINED][k];
                    }
                    minus
                }
            };
            right.push(plus);
            left.push(minus);
        }
        let directions = self.directions.len();
        for (i, region_values) in values.iter().enumerate() {
            let peaks = &mut self.peaks[i];
            if peaks.len() != region_values.len() {
                *peaks = vec![
                    Peak {
                        value: f64::NEG_INFINITY,
                        time: t,
                        right: vec![0.0; directions],
                        left: vec![0.0; directions],
                    };
                    region_values.len()
                ];
            }
            for (r, (peak, &value)) in peaks.iter_mut().zip(region_values).enumerate() {
                let r_right: Vec<f64> = right.iter().map(|d| d[i][r]).collect();
                let r_left: Vec<f64> = left.iter().map(|d| d[i][r]).collect();
                peak.update(value, t, &r_right, &r_left);
            }
        }
        Ok(())
    }

    /// Σ_k w_k τ(D_k; u) at the criteria's elements: the part of dτ from the law's change.
    fn law_part(&self, stencil: &Stencil, global: &[[f64; 2]]) -> Result<Vec<[f64; 4]>, WsmError> {
        let elastic = &self.problem.elastic;
        let mut sum = vec![[0.0; 4]; self.elements.len()];
        for (_, w, d) in &stencil.points {
            let stresses: Vec<ElementStress> =
                elastic.stresses_at(d, global, None, &self.elements)?;
            for (acc, s) in sum.iter_mut().zip(&stresses) {
                for (a, c) in acc.iter_mut().zip(&s.stress) {
                    *a += w * c;
                }
            }
        }
        Ok(sum)
    }

    /// Carry every direction's tangents over the step.
    fn advance(
        &mut self,
        context: &RunContext,
        contact: &StepContact,
        view: &StepView,
    ) -> Result<(), WsmError> {
        let (problem, data) = (self.problem, self.data);
        let geometry = &problem.contact.geometry;
        let s = context.constants.force;
        let gaps: Vec<f64> = geometry
            .rows
            .iter()
            .enumerate()
            .map(|(r, row)| {
                if is_normal_row(r) {
                    row.dot(view.u_next) + row.dot_fixed(context.fixed)
                        - geometry.pairs[pair_of_row(r)].gap
                } else {
                    row.dot(view.u_next) - row.dot(view.u)
                }
            })
            .collect();
        // Per pair its slip-rate law, and the Coulomb coefficient of the step's bound (F(v) of
        // the previous level's slip rate on a slip-rate zone).
        let slip_rates = geometry.apply(view.v);
        let laws: Vec<Option<SlipRateLaw>> = geometry
            .pairs
            .iter()
            .map(|p| SlipRateLaw::of(&problem.scene, data, p.zone).filter(|_| !p.bilateral))
            .collect();
        let friction: Vec<Option<f64>> = geometry
            .pairs
            .iter()
            .zip(&laws)
            .enumerate()
            .map(|(m, (p, law))| {
                let coefficient = data.friction[p.zone].filter(|_| !p.bilateral)?;
                Some(law.map_or(coefficient, |l| {
                    l.coefficient(slip_rates[tangential_row(m)])
                }))
            })
            .collect();
        let motions = classify(&ContactPoint {
            multipliers: view.multipliers,
            gaps: &gaps,
            lower: view.lower,
            upper: view.upper,
            friction: &friction,
            displacement_scale: view.u_next.iter().fold(0.0_f64, |a, x| a.max(x.abs())),
        });
        let step = Step {
            context,
            contact,
            view,
            motions: &motions,
            friction: &friction,
            laws: &laws,
            slip_rates: &slip_rates,
        };
        for direction in &mut self.directions {
            // The step's data part g (unsigned).
            let load_next = load_derivative(problem, direction, view.t)?;
            let g = match &direction.operators {
                Some((ops, da)) => {
                    let system = FemSystem {
                        elastic: &problem.elastic,
                        ops,
                    };
                    let mut g = rhs(
                        context.scheme,
                        context.dt,
                        &system,
                        view.u,
                        view.v,
                        &direction.load_now,
                        &load_next,
                    );
                    let dau = problem.elastic.operator().apply(da, view.u_next);
                    add_scaled(&mut g, -1.0, &dau);
                    g
                }
                None => rhs(
                    context.scheme,
                    context.dt,
                    &Zero,
                    view.u,
                    view.v,
                    &direction.load_now,
                    &load_next,
                ),
            };
            direction.load_now = load_next;
            let mut bound_rates = vec![0.0; geometry.dim()];
            if direction.bounds {
                for (_, w, d) in &direction.stencil.points {
                    // The upper bounds carry the rates (tangential rows: G, lower −G; normal
                    // rows' infinite bounds do not move).
                    let (mut lo, mut hi) = geometry.bounds(d, Some(view.forces));
                    slip_rate_bounds(
                        &problem.scene,
                        geometry,
                        d,
                        view.forces,
                        &slip_rates,
                        &mut lo,
                        &mut hi,
                    );
                    for (rate, b) in bound_rates.iter_mut().zip(&hi) {
                        if b.is_finite() {
                            *rate += w * s * b;
                        }
                    }
                }
            }
            let plus_rates = step.rates(&bound_rates, 1.0, &direction.plus);
            if direction.minus.is_none() && step.one_sided(&plus_rates, &direction.plus) {
                direction.minus = Some(direction.plus.negated());
            }
            direction.plus =
                step.tangent(&direction.plus, &g, &direction.fixed, 1.0, &plus_rates)?;
            if let Some(minus) = &direction.minus {
                let rates = step.rates(&bound_rates, -1.0, minus);
                direction.minus = Some(step.tangent(minus, &g, &direction.fixed, -1.0, &rates)?);
            }
        }
        Ok(())
    }

    /// Fill a solution's criteria, their times and derivatives from the maxima over time.
    fn fill(&self, solution: &mut Solution) {
        if let Some(reason) = &self.unavailable {
            solution.report.warnings.push(Warning::new(
                WarningKind::Sensitivities,
                "dynamics.initial",
                format!("the derivatives over time are not available: the static start has no tangent: {reason}"),
            ));
        }
        solution.region_values = self
            .peaks
            .each_ref()
            .map(|p| p.iter().map(|p| p.value).collect());
        solution.peak_times = self
            .peaks
            .each_ref()
            .map(|p| p.iter().map(|p| p.time).collect());
        solution.criteria = maxima(&solution.region_values);
        let values = &solution.region_values;
        let tied: PerCriterion<Vec<bool>> = std::array::from_fn(|i| tied_regions(&values[i]));
        // The defined criteria have no maximum: only their region derivatives (below).
        solution.sensitivities = (0..self.directions.len())
            .map(|j| {
                std::array::from_fn(|i| {
                    let right: Vec<f64> = self.peaks[i].iter().map(|p| p.right[j]).collect();
                    let left: Vec<f64> = self.peaks[i].iter().map(|p| p.left[j]).collect();
                    (i != DEFINED)
                        .then(|| one_sided(&values[i], &tied[i], &right, &left))
                        .flatten()
                })
            })
            .collect();
        solution.region_sensitivities = (0..self.directions.len())
            .map(|j| {
                std::array::from_fn(|i| {
                    self.peaks[i]
                        .iter()
                        .map(|p| {
                            Some(OneSided {
                                right: p.right[j],
                                left: p.left[j],
                            })
                        })
                        .collect()
                })
            })
            .collect();
    }

    /// Per criterion with a value, its maximum over time, when and where (for the history);
    /// a defined criterion under its name, where its region or receiver.
    pub(super) fn history_entries(&self) -> std::collections::BTreeMap<String, CriterionPeak> {
        let mut out = std::collections::BTreeMap::new();
        let scene = &self.problem.scene;
        for (d, peak) in scene.criteria.defined.iter().zip(&self.peaks[DEFINED]) {
            out.insert(
                d.name.clone(),
                CriterionPeak {
                    value: peak.value,
                    time: peak.time,
                    region: d.place().to_string(),
                },
            );
        }
        for criterion in Criterion::ALL {
            let peaks = &self.peaks[criterion as usize];
            let values: Vec<f64> = peaks.iter().map(|p| p.value).collect();
            if let Some(r) = attaining(&values) {
                out.insert(
                    criterion.name().to_string(),
                    CriterionPeak {
                        value: peaks[r].value,
                        time: peaks[r].time,
                        region: region_name(&self.problem.criteria, criterion, r).to_string(),
                    },
                );
            }
        }
        out
    }
}

impl StepObserver for OverTime<'_> {
    fn static_start(&mut self, problem: &StateProblem, data: &Data) -> Result<Solution, WsmError> {
        OverTime::static_start(self, problem, data)
    }

    fn start(
        &mut self,
        context: &RunContext,
        u: &[f64],
        v: &[f64],
        forces: &[f64],
    ) -> Result<(), WsmError> {
        self.record(context, 0.0, u, v, forces)
    }

    fn step(
        &mut self,
        context: &RunContext,
        contact: &StepContact,
        view: &StepView,
    ) -> Result<(), WsmError> {
        if !self.directions.is_empty() {
            self.advance(context, contact, view)?;
        }
        let scale = context.constants.force;
        let forces: Vec<f64> = view.multipliers.iter().map(|x| x / scale).collect();
        self.record(context, view.t, view.u_next, view.v_next, &forces)
    }
}

/// One step's primal state as its tangents read it.
struct Step<'s> {
    context: &'s RunContext<'s>,
    contact: &'s StepContact<'s>,
    view: &'s StepView<'s>,
    motions: &'s [RowMotion],
    /// Per pair the Coulomb coefficient of the step's bound (`None`: Tresca or bilateral).
    friction: &'s [Option<f64>],
    /// Per pair its slip-rate law (`None`: a constant coefficient).
    laws: &'s [Option<SlipRateLaw>],
    /// B v of the previous level (the slip rates on tangential rows).
    slip_rates: &'s [f64],
}

impl Step<'_> {
    /// The signed derivatives (lower, upper) of the step's multiplier bounds along a tangent:
    /// `sign` × the data rates, plus on a Coulomb pair's tangential rows s F d max(λ_n, 0) of
    /// the previous level, and on a slip-rate pair s max(λ_n, 0) F′(v; dv) with dv the
    /// tangent's slip rate.
    fn rates(&self, data_rates: &[f64], sign: f64, tangent: &Tangent) -> (Vec<f64>, Vec<f64>) {
        let s = self.context.constants.force;
        let mut upper: Vec<f64> = data_rates.iter().map(|r| sign * r).collect();
        for (r, rate) in upper.iter_mut().enumerate() {
            if !is_tangential_row(r) {
                continue;
            }
            let p = pair_of_row(r);
            if let Some(f) = self.friction[p] {
                let (lambda, dlambda) = (
                    self.view.forces[normal_row(p)],
                    tangent.dforces[normal_row(p)],
                );
                let d = if lambda > 0.0 {
                    dlambda
                } else {
                    dlambda.max(0.0)
                };
                *rate += s * f * d;
                if let Some(law) = &self.laws[p] {
                    let dv = self.contact.geometry().rows[r].dot(&tangent.dv);
                    *rate += s * lambda.max(0.0) * law.rate_derivative(self.slip_rates[r], dv);
                }
            }
        }
        // Tangential bounds are ±G: the lower one moves opposite to the upper one; normal rows'
        // bounds (0, ∞) and bilateral ones do not move.
        let lower = upper
            .iter()
            .enumerate()
            .map(|(r, u)| if is_tangential_row(r) { -u } else { 0.0 })
            .collect();
        let upper = upper
            .iter()
            .enumerate()
            .map(|(r, u)| if is_tangential_row(r) { *u } else { 0.0 })
            .collect();
        (lower, upper)
    }

    /// Whether the step is only one-sided differentiable along the tangent with these rates: a
    /// weakly active row, a pinched row whose bounds move apart, a Coulomb bound at an open
    /// pair whose normal force moves (max(λ_n, 0) at its kink with dλ_n ≠ 0), or a slip-rate bound of a closed pair at rest that the
    /// tangent sets sliding (|v| at its kink).
    fn one_sided(&self, (lower, upper): &(Vec<f64>, Vec<f64>), tangent: &Tangent) -> bool {
        let rows = &self.contact.geometry().rows;
        let rate_kink = self.laws.iter().enumerate().any(|(p, law)| {
            let t = tangential_row(p);
            law.is_some()
                && self.slip_rates[t] == 0.0
                && self.view.forces[normal_row(p)] > 0.0
                && rows[t].dot(&tangent.dv) != 0.0
        });
        rate_kink
            || self
                .motions
                .iter()
                .enumerate()
                .any(|(r, motion)| match motion {
                    RowMotion::WeakLower | RowMotion::WeakUpper => true,
                    RowMotion::Pinched => {
                        let n = normal_row(pair_of_row(r));
                        lower[r] != upper[r]
                            || (is_tangential_row(r)
                                && self.friction[pair_of_row(r)].is_some()
                                && self.view.forces[n] <= 0.0
                                && tangent.dforces[n] != 0.0)
                    }
                    _ => false,
                })
    }

    /// The tangent after the step along the signed direction: y = A⁻¹(F(du, dv) + sign g),
    /// dΛ from the step's tangent QP, du' = y − W dΛ = A⁻¹(F(du, dv) + sign g − Bᵀ dΛ), dv' by
    /// the scheme.
    fn tangent(
        &self,
        tangent: &Tangent,
        g: &[f64],
        fixed: &[f64],
        sign: f64,
        (lower, upper): &(Vec<f64>, Vec<f64>),
    ) -> Result<Tangent, WsmError> {
        let (context, contact) = (self.context, self.contact);
        let n = tangent.du.len();
        let mut r = rhs(
            context.scheme,
            context.dt,
            context.system,
            &tangent.du,
            &tangent.dv,
            &vec![0.0; n],
            &vec![0.0; n],
        );
        add_scaled(&mut r, sign, g);
        let mut y = contact.factor().solve(&r);
        let geometry = contact.geometry();
        let m = geometry.dim();
        let mut dforces = vec![0.0; m];
        if m > 0 {
            let d: Vec<f64> = geometry
                .rows
                .iter()
                .enumerate()
                .map(|(r, row)| {
                    if is_normal_row(r) {
                        row.dot(&y) + sign * row.dot_fixed(fixed)
                    } else {
                        row.dot(&y) - row.dot(&tangent.du)
                    }
                })
                .collect();
            let derivative = DataDerivative {
                residual: &[],
                fixed: &[],
                lower,
                upper,
            };
            let (lo, hi) = tangent_bounds(self.motions, &derivative, 1.0);
            let c: &Mat<f64> = contact.condensed();
            let problem = BoxQp::new(c.clone(), d, lo, hi);
            let solution = solve_box_qp(&problem, None, &QpOptions::default()).map_err(|e| {
                WsmError::contact(format!("derivative of a time step's contact state: {e}"))
            })?;
            let scale = context.constants.force;
            dforces = solution.x.iter().map(|x| x / scale).collect();
            y = contact.respond(&r, y, &solution.x);
        }
        let du = y;
        let dv = velocity(context.scheme, context.dt, &tangent.du, &du, &tangent.dv);
        Ok(Tangent { du, dv, dforces })
    }
}

/// A run's initial tangents (along +θ_j, and along −θ_j when one-sided) from the static
/// state's tangent: du_0 and dλ_0, dv_0 = 0 (`zero` gives its size).
fn initial_tangents(tangent: TangentDisplacement, zero: &Tangent) -> (Tangent, Option<Tangent>) {
    let at_rest = |du: Vec<f64>, dforces: Vec<f64>| Tangent {
        du,
        dv: zero.dv.clone(),
        dforces,
    };
    let minus = tangent
        .minus
        .zip(tangent.minus_multipliers)
        .map(|(du, dlambda)| at_rest(du, dlambda));
    (at_rest(tangent.plus, tangent.plus_multipliers), minus)
}

/// d(f − K_fd u_d) at time `t` along the direction (free DOFs): the stencil's loads when they
/// move, less the derivative of the prescribed displacements' share of K0 u.
fn load_derivative(
    problem: &StateProblem,
    direction: &Direction,
    t: f64,
) -> Result<Vec<f64>, WsmError> {
    let elastic = &problem.elastic;
    let mut out = vec![0.0; elastic.dofs().n_free()];
    if direction.loads {
        for (_, w, d) in &direction.stencil.points {
            let loads = elastic.loads(&super::data_at(&problem.scene, d, t), None)?;
            add_scaled(&mut out, *w, &elastic.dofs().restrict(&loads).0);
        }
    }
    if let Some((ops, _)) = &direction.operators {
        add_scaled(&mut out, -1.0, &ops.prescribed_force);
    }
    Ok(out)
}

/// Σ_k w_k of the operators at the stencil's data: M, C, K0 and K_fd u_d are linear in the
/// densities, dampings, retardation times and zone coefficients (products τ_v K0 of two data
/// are linear in each), so the sum is their exact derivative for the affine data maps.
fn weighted_operators(problem: &StateProblem, stencil: &Stencil) -> Result<Operators, WsmError> {
    let mut sum: Option<Operators> = None;
    for (_, w, d) in &stencil.points {
        let ops = Operators::new(&problem.elastic, &problem.scene, d)?;
        match &mut sum {
            None => {
                let mut first = ops;
                for values in [
                    &mut first.mass,
                    &mut first.damping,
                    &mut first.stiffness,
                    &mut first.prescribed_force,
                ] {
                    values.iter_mut().for_each(|x| *x *= w);
                }
                sum = Some(first);
            }
            Some(acc) => {
                add_scaled(&mut acc.mass, *w, &ops.mass);
                add_scaled(&mut acc.damping, *w, &ops.damping);
                add_scaled(&mut acc.stiffness, *w, &ops.stiffness);
                add_scaled(&mut acc.prescribed_force, *w, &ops.prescribed_force);
            }
        }
    }
    sum.ok_or_else(|| WsmError::contact("a derivative stencil without points"))
}
