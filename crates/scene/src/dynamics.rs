//! The dynamic part of a scene (design §3.5; PDAS paper (1)–(7), (10)): the time grid and the
//! scheme (`dynamics`), time functions of loads, absorbing layers and receivers, their serde
//! shape and their validation. Densities and the Kelvin–Voigt retardation times live on the
//! materials (`materials.M.density`, `materials.M.viscosity`).
//!
//! A scene without `dynamics` is a static scene, exactly as before; the dynamic-only entries
//! (`time_function`, `absorbing`, `receivers`) are refused there, so that a value is never
//! silently ignored.

use std::collections::BTreeSet;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::model::{Point, Scene};
use super::validate::{check_point, finite, unique_name};
use super::SceneError;

/// At most this many time steps (`t_end / dt`): a request cannot run for days.
pub const MAX_STEPS: usize = 1_000_000;
/// At most this many output times (`t_end / (dt · output_every)`): the history stays small.
pub const MAX_OUTPUTS: usize = 100_000;
/// At most this many entries in a time-function table.
pub const MAX_TABLE: usize = 1_000;

/// The time grid and the integrator of a dynamic scene (design §3.5).
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Dynamics {
    /// End time \[s\] (> 0); the run takes ⌈t_end / dt⌉ steps.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub t_end: f64,
    /// Time step Δt \[s\] (0 < Δt ≤ t_end), fixed: the step operator is factorised once.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub dt: f64,
    /// Record the history every this many steps (default 1; the first and last steps are
    /// always recorded).
    #[serde(default = "one")]
    #[schemars(range(min = 1))]
    pub output_every: usize,
    /// Initial state: `rest` (u = 0, v = 0; default) or `static` (the static contact solution
    /// of the same scene with the loads at t = 0, v = 0; PDAS paper (8)).
    #[serde(default)]
    pub initial: InitialState,
    /// Integrator: `paper` (the paper's semi-implicit scheme (10) with backward-difference
    /// velocity; first order, dissipative; default) or `newmark` (average acceleration with the
    /// contact impulse at the end of the step; second order, energy never grows).
    #[serde(default)]
    pub scheme: TimeScheme,
    /// Per-step contact solver: `pdas` (the paper's primal–dual active set method (27),
    /// warm-started from the previous step's sets, falling back to the QP kernel on a step
    /// where it does not terminate; default) or `qp` (the dense box QP kernel of the static
    /// solver). Both give the same step to 1e-10.
    #[serde(default)]
    pub contact_solver: ContactSolver,
}

fn one() -> usize {
    1
}

/// The initial state of a dynamic run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum InitialState {
    /// u = 0, v = 0.
    #[default]
    Rest,
    /// u = the static contact solution with the loads at t = 0, v = 0.
    Static,
}

/// The time integrator of a dynamic run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum TimeScheme {
    /// The paper's semi-implicit three-level scheme (10), backward-difference velocity.
    #[default]
    Paper,
    /// Newmark average acceleration (trapezoidal rule), contact impulse at t_{n+1}.
    Newmark,
}

/// The per-step contact solver of a dynamic run (design §3.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ContactSolver {
    /// The paper's primal–dual active set method (27), QP kernel as fallback.
    #[default]
    Pdas,
    /// The dense box QP kernel (semismooth Newton with an MPRGP fallback).
    Qp,
}

/// A load's factor against time: the condition's traction or pressure is multiplied by it.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum TimeFunction {
    /// Piecewise linear through (times\[k\], values\[k\]), constant beyond the first and last
    /// time.
    Table {
        /// Times \[s\], strictly increasing.
        times: Vec<f64>,
        /// Factors at those times [-].
        values: Vec<f64>,
    },
    /// Ricker wavelet (1 − 2π²f²(t − t0)²) exp(−π²f²(t − t0)²): peak 1 at t0, peak frequency f.
    Ricker {
        /// Peak frequency f \[Hz\] (> 0).
        #[schemars(extend("exclusiveMinimum" = 0.0))]
        frequency: f64,
        /// Time of the peak t0 \[s\].
        delay: f64,
    },
}

impl TimeFunction {
    /// The factor at time `t`.
    pub fn at(&self, t: f64) -> f64 {
        match self {
            TimeFunction::Table { times, values } => {
                super::data::piecewise_linear(times, values, t)
            }
            TimeFunction::Ricker { frequency, delay } => {
                let a = (std::f64::consts::PI * frequency * (t - delay)).powi(2);
                (1.0 - 2.0 * a) * (-a).exp()
            }
        }
    }
}

/// A named point where the history records u, v and a.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Receiver {
    /// Name, unique among the receivers (the key in the history).
    pub name: String,
    /// Position `[x, y]` \[m\], inside a body.
    pub point: Point,
}

/// A point force (PDAS paper §2: a seismic source is a volume force at the source point):
/// `force` × `time_function(t)` applied at `point`, distributed exactly on the P1 basis of the
/// triangle holding it (f_i = φ_i(point) F).
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PointLoad {
    /// Position `[x, y]` \[m\], inside a body.
    pub point: Point,
    /// Force `[Fx, Fy]` \[N/m\] (per unit thickness).
    pub force: [f64; 2],
    /// Factor against time (default: constant 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_function: Option<TimeFunction>,
}

/// An absorbing layer (PDAS paper (3)): viscous damping α u′ in the elements whose centroid
/// lies within `thickness` of the named segments.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AbsorbingLayer {
    /// Segments the layer runs along (keys of `segments`).
    pub segments: Vec<String>,
    /// Layer thickness D \[m\] (> 0).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub thickness: f64,
    /// Damping α \[kg/(m³ s)\] (≥ 0), constant in the layer.
    #[schemars(range(min = 0.0))]
    pub damping: f64,
}

/// Number of steps of the time grid: ⌈t_end / dt⌉ (a quotient within 1e-9 of an integer is
/// that integer).
pub fn step_count(dynamics: &Dynamics) -> usize {
    let q = dynamics.t_end / dynamics.dt;
    let nearest = q.round();
    if (q - nearest).abs() <= 1e-9 * nearest.max(1.0) {
        nearest as usize
    } else {
        q.ceil() as usize
    }
}

/// The output times of a run: t = 0, every `output_every` steps, and the last step.
pub fn output_count(dynamics: &Dynamics) -> usize {
    let steps = step_count(dynamics);
    let every = dynamics.output_every.max(1);
    1 + steps / every + usize::from(!steps.is_multiple_of(every))
}

/// Check the dynamic entries of a scene; errors name the field.
pub(super) fn check_dynamics(scene: &Scene) -> Result<(), SceneError> {
    check_material_dynamics(scene)?;
    check_time_functions(scene)?;
    check_dynamic_contacts(scene)?;
    for (i, body) in scene.bodies.iter().enumerate() {
        let Some(v) = body.initial_velocity else {
            continue;
        };
        let path = format!("bodies[{i}].initial_velocity");
        if scene.dynamics.is_none() {
            return Err(SceneError::new(path, "only in a scene with `dynamics`"));
        }
        finite(&format!("{path}[0]"), v[0])?;
        finite(&format!("{path}[1]"), v[1])?;
    }
    for (i, load) in scene.point_loads.iter().enumerate() {
        let path = format!("point_loads[{i}]");
        if scene.dynamics.is_none() {
            return Err(SceneError::new(path, "only in a scene with `dynamics`"));
        }
        check_point(&format!("{path}.point"), load.point)?;
        finite(&format!("{path}.force[0]"), load.force[0])?;
        finite(&format!("{path}.force[1]"), load.force[1])?;
        if let Some(f) = &load.time_function {
            check_time_function(&format!("{path}.time_function"), f)?;
        }
    }
    let Some(dynamics) = &scene.dynamics else {
        if !scene.absorbing.is_empty() {
            return Err(SceneError::new(
                "absorbing",
                "only in a scene with `dynamics`",
            ));
        }
        if !scene.receivers.is_empty() {
            return Err(SceneError::new(
                "receivers",
                "only in a scene with `dynamics`",
            ));
        }
        return Ok(());
    };
    check_grid(dynamics)?;
    if scene.thermal.is_some() {
        return Err(SceneError::new(
            "thermal",
            "a thermal part with `dynamics` is not supported",
        ));
    }
    for name in scene.used_materials() {
        if scene.materials[name].density.is_none() {
            return Err(SceneError::new(
                format!("materials.{name}.density"),
                "a scene with `dynamics` needs the density of every material its zones use",
            ));
        }
    }
    let mut names = BTreeSet::new();
    for (i, r) in scene.receivers.iter().enumerate() {
        let path = format!("receivers[{i}]");
        if r.name.is_empty() {
            return Err(SceneError::new(format!("{path}.name"), "must not be empty"));
        }
        unique_name(&mut names, &r.name, &path, "receiver")?;
        check_point(&format!("{path}.point"), r.point)?;
    }
    for (i, layer) in scene.absorbing.iter().enumerate() {
        let path = format!("absorbing[{i}]");
        if layer.segments.is_empty() {
            return Err(SceneError::new(
                format!("{path}.segments"),
                "name at least one segment",
            ));
        }
        for (k, s) in layer.segments.iter().enumerate() {
            if !scene.segments.contains_key(s) {
                return Err(SceneError::new(
                    format!("{path}.segments[{k}]"),
                    format!("unknown segment '{s}'"),
                ));
            }
        }
        let thickness = finite(&format!("{path}.thickness"), layer.thickness)?;
        if thickness <= 0.0 {
            return Err(SceneError::new(format!("{path}.thickness"), "must be > 0"));
        }
        if finite(&format!("{path}.damping"), layer.damping)? < 0.0 {
            return Err(SceneError::new(format!("{path}.damping"), "must be ≥ 0"));
        }
    }
    Ok(())
}

/// The slip-rate-dependent friction law: only in dynamic scenes, on a Coulomb zone, with its
/// characteristic slip rate.
fn check_dynamic_contacts(scene: &Scene) -> Result<(), SceneError> {
    for (i, c) in scene.contacts.iter().enumerate() {
        let path = format!("contacts[{i}]");
        match (c.friction_kinetic, c.slip_rate_scale) {
            (None, None) => continue,
            (Some(_), None) => {
                return Err(SceneError::new(
                    format!("{path}.slip_rate_scale"),
                    "`friction_kinetic` needs the characteristic slip rate v_c (m/s)",
                ))
            }
            (None, Some(_)) => {
                return Err(SceneError::new(
                    format!("{path}.slip_rate_scale"),
                    "only with `friction_kinetic`",
                ))
            }
            (Some(kinetic), Some(scale)) => {
                let field = format!("{path}.friction_kinetic");
                if scene.dynamics.is_none() {
                    return Err(SceneError::new(field, "only in a scene with `dynamics`"));
                }
                if c.friction_coefficient.is_none() {
                    return Err(SceneError::new(
                        field,
                        "needs `friction_coefficient` (the static coefficient)",
                    ));
                }
                if !(0.0..=super::rules::MAX_FRICTION).contains(&finite(&field, kinetic)?) {
                    return Err(SceneError::new(
                        field,
                        format!("must be in [0, {}]", super::rules::MAX_FRICTION),
                    ));
                }
                let field = format!("{path}.slip_rate_scale");
                if finite(&field, scale)? <= 0.0 {
                    return Err(SceneError::new(field, "must be > 0 (m/s)"));
                }
            }
        }
    }
    Ok(())
}

/// Densities positive, retardation times non-negative, wherever given.
fn check_material_dynamics(scene: &Scene) -> Result<(), SceneError> {
    for (name, m) in &scene.materials {
        if let Some(rho) = m.density {
            let path = format!("materials.{name}.density");
            if finite(&path, rho)? <= 0.0 {
                return Err(SceneError::new(path, "must be > 0 (kg/m³)"));
            }
        }
        if let Some(tau) = m.viscosity {
            let path = format!("materials.{name}.viscosity");
            if finite(&path, tau)? < 0.0 {
                return Err(SceneError::new(
                    path,
                    "the retardation time τ_v must be ≥ 0 (s)",
                ));
            }
        }
    }
    Ok(())
}

/// Time functions only on loads of a dynamic scene, with usable tables and wavelets.
fn check_time_functions(scene: &Scene) -> Result<(), SceneError> {
    for (i, bc) in scene.boundary.iter().enumerate() {
        let Some(function) = &bc.time_function else {
            continue;
        };
        let path = format!("boundary[{i}].time_function");
        if scene.dynamics.is_none() {
            return Err(SceneError::new(path, "only in a scene with `dynamics`"));
        }
        if bc.traction.is_none() && bc.pressure.is_none() {
            return Err(SceneError::new(
                path,
                "only on a load (a traction or a pressure condition)",
            ));
        }
        check_time_function(&path, function)?;
    }
    Ok(())
}

/// A usable table or wavelet.
fn check_time_function(path: &str, function: &TimeFunction) -> Result<(), SceneError> {
    match function {
        TimeFunction::Table { times, values } => {
            if times.is_empty() || times.len() != values.len() || times.len() > MAX_TABLE {
                return Err(SceneError::new(
                    format!("{path}.table"),
                    format!(
                        "times and values need the same length, 1 to {MAX_TABLE} (got {} and {})",
                        times.len(),
                        values.len()
                    ),
                ));
            }
            for (k, (t, v)) in times.iter().zip(values).enumerate() {
                finite(&format!("{path}.table.times[{k}]"), *t)?;
                finite(&format!("{path}.table.values[{k}]"), *v)?;
                if k > 0 && *t <= times[k - 1] {
                    return Err(SceneError::new(
                        format!("{path}.table.times[{k}]"),
                        "times must be strictly increasing",
                    ));
                }
            }
        }
        TimeFunction::Ricker { frequency, delay } => {
            let f = finite(&format!("{path}.ricker.frequency"), *frequency)?;
            if f <= 0.0 {
                return Err(SceneError::new(
                    format!("{path}.ricker.frequency"),
                    "must be > 0 (Hz)",
                ));
            }
            finite(&format!("{path}.ricker.delay"), *delay)?;
        }
    }
    Ok(())
}

/// dt and t_end positive, dt ≤ t_end, the step and output counts bounded.
fn check_grid(d: &Dynamics) -> Result<(), SceneError> {
    let t_end = finite("dynamics.t_end", d.t_end)?;
    let dt = finite("dynamics.dt", d.dt)?;
    if t_end <= 0.0 {
        return Err(SceneError::new("dynamics.t_end", "must be > 0 (s)"));
    }
    if dt <= 0.0 {
        return Err(SceneError::new("dynamics.dt", "must be > 0 (s)"));
    }
    if dt > t_end {
        return Err(SceneError::new(
            "dynamics.dt",
            format!("the step {dt:e} s exceeds t_end = {t_end:e} s"),
        ));
    }
    let steps = t_end / dt;
    if steps > MAX_STEPS as f64 {
        return Err(SceneError::new(
            "dynamics.dt",
            format!("t_end / dt = {steps:.3e} steps; at most {MAX_STEPS} are allowed"),
        ));
    }
    if d.output_every == 0 {
        return Err(SceneError::new("dynamics.output_every", "must be ≥ 1"));
    }
    if steps / d.output_every as f64 > MAX_OUTPUTS as f64 {
        return Err(SceneError::new(
            "dynamics.output_every",
            format!(
                "{:.3e} output times; at most {MAX_OUTPUTS} (record less often)",
                steps / d.output_every as f64
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ricker_peaks_at_its_delay_and_table_interpolates() {
        let r = TimeFunction::Ricker {
            frequency: 10.0,
            delay: 0.1,
        };
        assert_eq!(r.at(0.1), 1.0);
        // First zeros at t0 ± 1/(π f √2).
        let z = 1.0 / (std::f64::consts::PI * 10.0 * 2f64.sqrt());
        assert!(r.at(0.1 + z).abs() < 1e-14);
        let t = TimeFunction::Table {
            times: vec![0.0, 1.0],
            values: vec![0.0, 2.0],
        };
        assert_eq!(t.at(0.25), 0.5);
        assert_eq!(t.at(3.0), 2.0);
        assert_eq!(t.at(-1.0), 0.0);
    }

    #[test]
    fn step_count_rounds_near_integers() {
        let d = |t_end, dt| Dynamics {
            t_end,
            dt,
            output_every: 1,
            initial: InitialState::Rest,
            scheme: TimeScheme::Paper,
            contact_solver: ContactSolver::Pdas,
        };
        assert_eq!(step_count(&d(1.0, 0.1)), 10);
        assert_eq!(step_count(&d(1.0, 0.3)), 4);
    }
}
