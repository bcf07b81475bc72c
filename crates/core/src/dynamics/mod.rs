//! Dynamic contact of Kelvin–Voigt viscoelastic bodies (design §3.5; Nedoma–Daněk, ICCSA 2008,
//! "Time-space FE-PDAS method for dynamic unilateral contact problem in viscoelasticity",
//! equations (1)–(12)): ρ ü + α u̇ = div τ + F with τ = c⁽⁰⁾ e(u) + c⁽¹⁾ e(u̇), c⁽¹⁾ = τ_v c⁽⁰⁾,
//! Signorini contact with the friction bound of the previous time level, in P1 space.
//!
//! - `operators`: M_ρ, C = C_α + K1 and K0 on the elastic operator's pattern and DOF map.
//! - `scheme`: the paper's semi-implicit scheme (10) with backward-difference velocity, and
//!   Newmark average acceleration with the contact impulse at the end of the step.
//! - `step`: one step's contact problem on A = M + a C + c K0 (factorised once), condensed on
//!   the multipliers and solved by `pdas` (the paper's primal–dual active set method (27)) or
//!   the existing dense box QP.
//! - `excitation`: initial velocities, point loads, the slip-rate-dependent friction bound.
//! - `history`: receivers, contact-zone resultants, states, slip and slip rate, bodies' mean
//!   velocities, the energy budget, the peak-over-time fields.
//! - `over_time`: the criteria as maxima over the time steps, with the time they occur, and
//!   their exact one-sided derivatives by forward differentiation through the time loop.
//!
//! [`simulate`] runs a dynamic scene from rest or from its static contact solution;
//! [`simulate_with`] also reports progress, honours a cancel flag and hands every output time's
//! state to the caller (a VTU series, design §5.6).

#[cfg(test)]
mod acceptance;
mod excitation;
mod history;
mod operators;
#[cfg(test)]
mod output_tests;
mod over_time;
mod pdas;
pub mod scheme;
mod step;
#[cfg(test)]
mod tests;

pub use history::{
    BodyHistory, CriterionPeak, DisplacementFrame, DynamicsReport, EnergyHistory, History, Peak,
    PeakFields, Peaks, ReceiverHistory, ZoneHistory,
};
pub use operators::Operators;
pub use over_time::{derivatives_unavailable, solve_over_time};

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use crate::contact::direct::TangentDisplacement;
use crate::contact::pairs::{is_normal_row, normal_row, pair_of_row, tangential_row};
use crate::error::WsmError;
use crate::fem::{ElasticProblem, ElementStress, Par};
use crate::scene::params::Stencil;
use crate::scene::{BoundaryValue, Criterion, Data, InitialState, Scene, SceneError, TimeScheme};
use crate::state::{Needs, Solution, SolveOptions, StateProblem};
use excitation::{initial_velocity, slip_rate_bounds, PointLoads};
use history::{Energy, Recorder, Snapshot};
use over_time::OverTime;
use scheme::{constants, dot, rhs, step_energy, velocity, SecondOrderSystem, StepConstants};
use step::StepContact;

/// The result of a dynamic run: the history and the final state.
#[derive(Debug, Clone)]
pub struct DynamicRun {
    /// What `wsm solve` writes under `history`.
    pub history: History,
    /// Final displacement, global nodal \[m\].
    pub displacement: Vec<[f64; 2]>,
    /// Final velocity, global nodal \[m/s\].
    pub velocity: Vec<[f64; 2]>,
    /// The peak-over-time fields over every step.
    pub peaks: PeakFields,
}

/// Receives the state at each output time; an error stops the run.
pub type FrameSink<'a> = dyn FnMut(&Frame) -> Result<(), WsmError> + 'a;

/// What the caller of [`simulate_with`] watches and receives during a run.
#[derive(Default)]
pub struct Hooks<'a> {
    /// Polled before every step: once raised, the run stops with [`WsmError::Cancelled`].
    pub cancel: Option<&'a AtomicBool>,
    /// Called after every step with (steps done, steps of the run).
    pub progress: Option<&'a dyn Fn(usize, usize)>,
    /// Called with the state at every output time (t = 0 first); an error stops the run.
    pub frames: Option<&'a mut FrameSink<'a>>,
}

/// The state at one output time, as [`Hooks::frames`] receives it.
pub struct Frame<'a> {
    /// The output's index (0 at t = 0), as in [`History::times`].
    pub index: usize,
    /// Time \[s\].
    pub t: f64,
    /// Global nodal displacement \[m\].
    pub displacement: &'a [[f64; 2]],
    /// Global nodal velocity \[m/s\].
    pub velocity: &'a [[f64; 2]],
    /// Element stresses: the elastic plus the Kelvin–Voigt viscous stress τ(u) + τ_v τ(v).
    pub stresses: &'a [ElementStress],
    /// Contact forces per multiplier row (normal, tangential per pair) \[N/m\].
    pub forces: &'a [f64],
    /// B u + B_d u_d − g0 per multiplier row (gap on normal rows, slip on tangential ones).
    pub gaps: &'a [f64],
    /// The peak-over-time fields up to `t`.
    pub peaks: &'a PeakFields,
}

/// `data` with each load that has a time function scaled by its value at `t`.
pub fn data_at(scene: &Scene, data: &Data, t: f64) -> Data {
    let mut out = data.clone();
    for (bc, value) in scene.boundary.iter().zip(&mut out.boundary) {
        let Some(f) = &bc.time_function else { continue };
        let s = f.at(t);
        match &mut value.value {
            BoundaryValue::Traction(p) => *p = [s * p[0], s * p[1]],
            BoundaryValue::Pressure(p) => *p *= s,
            _ => {}
        }
    }
    out
}

/// The static contact solution of the scene with the loads at t = 0 (the paper's u0, (8)).
pub fn static_start(problem: &StateProblem, data: &Data) -> Result<Solution, WsmError> {
    problem.solve(
        &data_at(&problem.scene, data, 0.0),
        &static_options(problem),
    )
}

/// [`static_start`] with the static state's tangents along `stencils` (their data at t = 0).
fn static_start_with_tangents(
    problem: &StateProblem,
    data: &Data,
    stencils: &[Stencil],
) -> Result<(Solution, Result<Vec<TangentDisplacement>, WsmError>), WsmError> {
    problem.solve_with_tangents(
        &data_at(&problem.scene, data, 0.0),
        &static_options(problem),
        stencils,
    )
}

/// The options of the static start: everything the scene has, sequential, cold.
fn static_options(problem: &StateProblem) -> SolveOptions {
    SolveOptions {
        needs: Needs::all(&problem.scene),
        par: Par::Seq,
        warm: None,
    }
}

/// The FEM operators as a [`SecondOrderSystem`].
struct FemSystem<'a> {
    elastic: &'a ElasticProblem,
    ops: &'a Operators,
}

impl SecondOrderSystem for FemSystem<'_> {
    fn mass(&self, x: &[f64]) -> Vec<f64> {
        self.elastic.operator().apply(&self.ops.mass, x)
    }
    fn damping(&self, x: &[f64]) -> Vec<f64> {
        self.elastic.operator().apply(&self.ops.damping, x)
    }
    fn stiffness(&self, x: &[f64]) -> Vec<f64> {
        self.elastic.operator().apply(&self.ops.stiffness, x)
    }
}

/// Run the dynamic scene of `problem` with `data` (design §3.5); the history carries the
/// maximum over time of every criterion the scene defines (design §3.5, criteria over time).
pub fn simulate(problem: &StateProblem, data: &Data) -> Result<DynamicRun, WsmError> {
    simulate_with(problem, data, &mut Hooks::default())
}

/// [`simulate`] with progress, cancellation and the state at every output time (`hooks`).
pub fn simulate_with(
    problem: &StateProblem,
    data: &Data,
    hooks: &mut Hooks,
) -> Result<DynamicRun, WsmError> {
    let mut criteria = Criterion::ALL.to_vec();
    criteria.push(Criterion::Defined);
    let mut peaks = OverTime::new(problem, data, &criteria, &[])?;
    let mut run = simulate_observed(problem, data, &mut peaks, hooks)?;
    run.history.criteria = peaks.history_entries();
    Ok(run)
}

/// Element stresses of a state: c⁽⁰⁾e(u) + c⁽¹⁾e(v) = τ(u) + τ_v τ(v), τ_v per element
/// (`retardation`; τ(v) is skipped when no material is viscous).
fn state_stresses(
    elastic: &ElasticProblem,
    data: &Data,
    retardation: &[f64],
    u: &[[f64; 2]],
    v: &[[f64; 2]],
) -> Result<Vec<ElementStress>, WsmError> {
    let mut stresses = elastic.stresses(data, u, None)?;
    if retardation.iter().any(|&tau| tau > 0.0) {
        let rate = elastic.stresses(data, v, None)?;
        for ((s, r), &tau) in stresses.iter_mut().zip(&rate).zip(retardation) {
            for (a, b) in s.stress.iter_mut().zip(r.stress) {
                *a += tau * b;
            }
        }
    }
    Ok(stresses)
}

/// What the time loop shares with a [`StepObserver`]: the run's operators and scheme.
struct RunContext<'a> {
    system: &'a FemSystem<'a>,
    constants: StepConstants,
    scheme: TimeScheme,
    dt: f64,
    /// Prescribed values u_d.
    fixed: &'a [f64],
}

/// One step n → n + 1 as an observer sees it (free-DOF vectors; multipliers and bounds of the
/// step system, Λ = s λ).
struct StepView<'a> {
    t: f64,
    u: &'a [f64],
    v: &'a [f64],
    u_next: &'a [f64],
    v_next: &'a [f64],
    multipliers: &'a [f64],
    lower: &'a [f64],
    upper: &'a [f64],
    /// λ of the previous level (the friction bound's).
    forces: &'a [f64],
}

/// Sees the initial state and every step of a run (criteria over time and their forward
/// tangents, [`over_time`]).
trait StepObserver {
    /// The static contact solution a run from `dynamics.initial = "static"` starts from.
    fn static_start(&mut self, problem: &StateProblem, data: &Data) -> Result<Solution, WsmError>;
    /// The state at t = 0: u, v (free DOFs) and the contact forces λ (per multiplier row).
    fn start(
        &mut self,
        context: &RunContext,
        u: &[f64],
        v: &[f64],
        forces: &[f64],
    ) -> Result<(), WsmError>;
    /// One step, solved by `contact` (its factor of A and C_h).
    fn step(
        &mut self,
        context: &RunContext,
        contact: &StepContact,
        view: &StepView,
    ) -> Result<(), WsmError>;
}

/// [`simulate_with`] with `observer` shown every step.
fn simulate_observed(
    problem: &StateProblem,
    data: &Data,
    observer: &mut dyn StepObserver,
    hooks: &mut Hooks,
) -> Result<DynamicRun, WsmError> {
    let started = Instant::now();
    let scene = &problem.scene;
    let dynamics = scene
        .dynamics
        .as_ref()
        .ok_or_else(|| SceneError::new("dynamics", "the scene has no `dynamics`"))?;
    let (dt, scheme_kind) = (dynamics.dt, dynamics.scheme);
    let steps = crate::scene::dynamics::step_count(dynamics);
    let elastic = &problem.elastic;
    let dofs = elastic.dofs();
    let geometry = &problem.contact.geometry;
    let ops = Operators::new(elastic, scene, data)?;
    let system = FemSystem { elastic, ops: &ops };
    let k = constants(scheme_kind, dt);
    let fixed = elastic.fixed_values(data)?;
    let mut contact = StepContact::new(
        geometry,
        ops.factor(elastic, k.damping, k.stiffness)?,
        fixed.clone(),
    )
    .with_solver(dynamics.contact_solver);
    let n = dofs.n_free();
    let mut forces = vec![0.0; geometry.dim()];
    let mut u = vec![0.0; n];
    if dynamics.initial == InitialState::Static {
        let start = observer.static_start(problem, data).map_err(|e| {
            SceneError::new(
                "dynamics.initial",
                format!("the static start (the static contact problem at t = 0) fails: {e}"),
            )
        })?;
        u = dofs.restrict(&start.displacement).0;
        for (m, (node, pair)) in start.contact.iter().zip(&geometry.pairs).enumerate() {
            forces[normal_row(m)] = node.pressure * pair.weight;
            forces[tangential_row(m)] = node.shear * pair.weight;
        }
    }
    let mut v = initial_velocity(scene, elastic.mesh(), dofs);
    let point_loads = PointLoads::new(scene, elastic.mesh())?;
    let context = RunContext {
        system: &system,
        constants: k,
        scheme: scheme_kind,
        dt,
        fixed: &fixed,
    };
    observer.start(&context, &u, &v, &forces)?;
    let free_loads = |t: f64| -> Result<Vec<f64>, WsmError> {
        let mut f = elastic.loads(&data_at(scene, data, t), None)?;
        point_loads.add(t, &mut f);
        Ok(dofs.restrict(&f).0)
    };
    let lifted = |f: &[f64]| -> Vec<f64> {
        f.iter()
            .zip(&ops.prescribed_force)
            .map(|(f, p)| f - p)
            .collect()
    };
    let strain = |u: &[f64]| 0.5 * dot(u, &system.stiffness(u)) + dot(u, &ops.prescribed_force);
    let kinetic = |v: &[f64]| 0.5 * dot(v, &system.mass(v));
    let gaps = |u: &[f64]| -> Vec<f64> {
        geometry
            .rows
            .iter()
            .enumerate()
            .map(|(r, row)| {
                let gap = if is_normal_row(r) {
                    geometry.pairs[pair_of_row(r)].gap
                } else {
                    0.0
                };
                row.dot(u) + row.dot_fixed(&fixed) - gap
            })
            .collect()
    };
    let zero_fixed = vec![0.0; dofs.n_fixed()];
    let global = |x: &[f64], prescribed: &[f64]| dofs.expand(x, prescribed);

    let mesh = elastic.mesh();
    let materials: Vec<_> = scene.materials.values().collect();
    let retardation: Vec<f64> = mesh
        .triangle_zone
        .iter()
        .map(|&z| {
            materials
                .get(mesh.zones[z].material)
                .and_then(|m| m.viscosity)
                .unwrap_or(0.0)
        })
        .collect();
    let layers = !scene.absorbing.is_empty();
    let viscous = retardation.iter().any(|&tau| tau > 0.0);
    let mut recorder = Recorder::new(scene, mesh)?;
    let mut history = recorder.empty(scene);
    let mut peaks = PeakFields::default();
    let mut outputs = 0;
    // Record the state at an output time (history, peaks already raised, the caller's frame).
    let mut output = |history: &mut History,
                      peaks: &PeakFields,
                      snapshot: &Snapshot,
                      stresses: &[ElementStress]|
     -> Result<(), WsmError> {
        recorder.record(history, geometry, snapshot);
        if let Some(frames) = hooks.frames.as_mut() {
            frames(&Frame {
                index: outputs,
                t: snapshot.t,
                displacement: snapshot.displacement,
                velocity: snapshot.velocity,
                stresses,
                forces: snapshot.forces,
                gaps: snapshot.gaps,
                peaks,
            })?;
        }
        outputs += 1;
        Ok(())
    };
    let (lower0, upper0) = geometry.bounds(data, Some(&forces));
    let scaled = |b: &[f64]| -> Vec<f64> { b.iter().map(|x| x * k.force).collect() };
    contact.start_from(&scaled(&forces), &scaled(&lower0), &scaled(&upper0));
    let mut totals = Energy::default();
    let (u_global, v_global) = (global(&u, &fixed), global(&v, &zero_fixed));
    let stresses = state_stresses(elastic, data, &retardation, &u_global, &v_global)?;
    peaks.update(mesh, geometry, 0.0, &u_global, &stresses, &forces);
    output(
        &mut history,
        &peaks,
        &Snapshot {
            t: 0.0,
            displacement: &u_global,
            velocity: &v_global,
            acceleration: &global(&vec![0.0; n], &zero_fixed),
            forces: &forces,
            bounds: &upper0,
            gaps: &gaps(&u),
            rates: &vec![0.0; geometry.dim()],
            energy: Energy {
                kinetic: kinetic(&v),
                strain: strain(&u),
                ..Energy::default()
            },
        },
        &stresses,
    )?;
    let mut f_now = free_loads(0.0)?;
    let (mut iterations, mut changes, mut fallbacks) = (0, 0, 0);
    for step in 1..=steps {
        if hooks.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return Err(WsmError::Cancelled);
        }
        let t = step as f64 * dt;
        let f_next = free_loads(t)?;
        let load = rhs(
            scheme_kind,
            dt,
            &system,
            &u,
            &v,
            &lifted(&f_now),
            &lifted(&f_next),
        );
        let (mut lower, mut upper) = geometry.bounds(data, Some(&forces));
        let rates = geometry.apply(&v);
        slip_rate_bounds(
            scene, geometry, data, &forces, &rates, &mut lower, &mut upper,
        );
        let (lower, upper) = (scaled(&lower), scaled(&upper));
        let (u_next, multipliers, stats) = contact.solve(&load, &u, &lower, &upper)?;
        iterations += stats.iterations;
        changes += stats.changes;
        fallbacks += usize::from(stats.fallback);
        let v_next = velocity(scheme_kind, dt, &u, &u_next, &v);
        observer.step(
            &context,
            &contact,
            &StepView {
                t,
                u: &u,
                v: &v,
                u_next: &u_next,
                v_next: &v_next,
                multipliers: &multipliers,
                lower: &lower,
                upper: &upper,
                forces: &forces,
            },
        )?;
        let (damped, work) = step_energy(scheme_kind, dt, &system, &u, &u_next, &f_now, &f_next);
        let increment: Vec<f64> = u_next.iter().zip(&u).map(|(a, b)| a - b).collect();
        // C = C_α + K1: the absorbing layers' share read from C_α, the viscous one the rest
        // (each exactly 0 without its cause).
        let absorbed = match (layers, viscous) {
            (false, _) => 0.0,
            (true, false) => damped,
            (true, true) => {
                let c_alpha = elastic.operator().apply(&ops.absorbing, &increment);
                dot(&increment, &c_alpha) / dt
            }
        };
        let new_forces: Vec<f64> = multipliers.iter().map(|x| x / k.force).collect();
        let moved = geometry.apply(&increment);
        for (r, (lambda, db)) in new_forces.iter().zip(&moved).enumerate() {
            if is_normal_row(r) {
                totals.contact += lambda * db;
            } else {
                totals.friction += lambda * db;
            }
        }
        totals.viscous += damped - absorbed;
        totals.absorbing += absorbed;
        totals.work += work;
        let (u_global, v_global) = (global(&u_next, &fixed), global(&v_next, &zero_fixed));
        let stresses = state_stresses(elastic, data, &retardation, &u_global, &v_global)?;
        peaks.update(mesh, geometry, t, &u_global, &stresses, &new_forces);
        if step % dynamics.output_every == 0 || step == steps {
            let accel: Vec<f64> = v_next.iter().zip(&v).map(|(a, b)| (a - b) / dt).collect();
            let (mut below, mut bounds) = geometry.bounds(data, Some(&new_forces));
            slip_rate_bounds(
                scene,
                geometry,
                data,
                &new_forces,
                &geometry.apply(&v_next),
                &mut below,
                &mut bounds,
            );
            let rates: Vec<f64> = moved.iter().map(|x| x / dt).collect();
            output(
                &mut history,
                &peaks,
                &Snapshot {
                    t,
                    displacement: &u_global,
                    velocity: &v_global,
                    acceleration: &global(&accel, &zero_fixed),
                    forces: &new_forces,
                    bounds: &bounds,
                    gaps: &gaps(&u_next),
                    rates: &rates,
                    energy: Energy {
                        kinetic: kinetic(&v_next),
                        strain: strain(&u_next),
                        ..totals
                    },
                },
                &stresses,
            )?;
        }
        u = u_next;
        v = v_next;
        forces = new_forces;
        f_now = f_next;
        if let Some(progress) = hooks.progress {
            progress(step, steps);
        }
    }
    history.peaks = peaks.summary.clone();
    history.report = DynamicsReport {
        scheme: scheme_kind,
        dt,
        steps,
        unknowns: n,
        multipliers: geometry.dim(),
        contact_solver: dynamics.contact_solver,
        pdas_fallbacks: fallbacks,
        qp_iterations: iterations,
        active_set_changes: changes,
        seconds: started.elapsed().as_secs_f64(),
    };
    Ok(DynamicRun {
        history,
        displacement: global(&u, &fixed),
        velocity: global(&v, &zero_fixed),
        peaks,
    })
}
