//! Admissible-set checks before any solve (design §4.1): the primal feasibility of the contact
//! constraints with the prescribed displacements on the whole box (in closed form, see
//! `crate::contact::feasibility`), and the semi-coercive solvability condition (CZ Thm 1.2,
//! D05 Thm 2.1) at the vertices of the box.
//!
//! For a floating body the condition is the existence of contact forces λ within their bounds
//! (normal ≥ 0, |tangential| ≤ g w) with G λ = e, G = RᵀBᵀ, e = Rᵀ f: the loads must be balanced
//! by contact and friction. G depends on geometry only, e on the applied forces only (a rigid
//! motion does no work against stiffness, prescribed displacements or thermal strain), and the
//! bounds on g only — all linearly. A larger g only makes balance easier, so the slip limits are
//! taken at their least values (a slope-limited slip limit at the least element of its set);
//! the set of load parameters where it holds is convex, and it holds on the whole box exactly
//! when it holds at every vertex of the loads' generators — parameters that do not move e drop
//! out and parallel ones merge (`check_balance`); up to 2^12 vertices are checked exhaustively,
//! beyond, a deterministic sample. On a Coulomb zone the forces lie in the friction cone
//! |λ_t| ≤ F λ_n, in 2D two linear inequalities: the check writes them exactly (a larger F only
//! widens the cone, so F is taken at its least). The nominal data are checked first, as a solve
//! of them would be: a scene whose own data leave a body unbalanced gets the solve's error.

use faer::Mat;

use crate::contact::feasibility::UncertainDisplacement;
use crate::contact::pairs::{normal_row, tangential_row};
use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions};
use crate::error::WsmError;
use crate::scene::params::{apply, least_slip_limits, ParamTarget, Parameter};
use crate::scene::SceneError;
use crate::state::StateProblem;

const MAX_VERTICES: usize = 4096;

/// Refuse the admissible set if at some vertex of the uncertain displacements the prescribed
/// displacements alone make two bodies overlap (no admissible displacement exists there).
fn check_feasibility_on_box(problem: &StateProblem, params: &[Parameter]) -> Result<(), WsmError> {
    // A datum driving several displacements is checked as if each moved on its own over its
    // interval: a larger set, so the check stays sufficient.
    let uncertain: Vec<UncertainDisplacement<'_>> = params
        .iter()
        .enumerate()
        .flat_map(|(index, p)| {
            p.field_intervals()
                .filter_map(move |(target, lo, hi)| match target {
                    ParamTarget::Displacement(bc, comp) => Some(UncertainDisplacement {
                        index,
                        name: &p.name,
                        source: (bc, comp),
                        lo,
                        hi,
                    }),
                    _ => None,
                })
        })
        .collect();
    let contact = &problem.contact;
    contact.feasibility.check_box(
        &problem.scene,
        problem.mesh(),
        &contact.geometry,
        &problem.nominal,
        &uncertain,
    )?;
    Ok(())
}

/// The admissible-set checks a search makes before any evaluation, on a meshed scene: the
/// contact feasibility of the prescribed displacements on the whole box, then the balance of
/// the floating bodies at the nominal data and over the box. The one check the service's
/// submission and every run (the job's worker too) make; `stop` is asked between vertices.
pub fn check_admissible_box(
    problem: &StateProblem,
    params: &[Parameter],
    stop: &dyn Fn() -> bool,
) -> Result<(), WsmError> {
    check_feasibility_on_box(problem, params)?;
    // A dynamic step's operator contains the mass: floating bodies need no balance (§3.5).
    if problem.scene.dynamics.is_some() {
        return Ok(());
    }
    check_balance(problem, params, stop)
}

/// Refuse the scene if a floating body is unbalanced at the nominal data (the error a solve of
/// them gives, naming the body), then the admissible set if a vertex of the box leaves one
/// unbalanced (naming the vertex). `stop` is asked before each vertex; when it answers true the
/// check ends with [`WsmError::Cancelled`].
///
/// On the box, slip limits and friction coefficients are taken at their least values (larger
/// ones only widen the bounds: the balance holds for them when it holds there), and the loads'
/// parameters act through e = e₀ + Σ tᵢ Δᵢ, tᵢ ∈ [0, 1] (e is affine in them): a parameter with
/// Δᵢ = 0 (a load on a clamped body) cannot move the balance, and parameters with parallel Δᵢ
/// (pressures on one face) add up to one generator, both exactly. The vertices of the remaining
/// generators are checked — all of them up to 2^12, beyond that a deterministic sample of
/// `MAX_VERTICES`.
pub fn check_balance(
    problem: &StateProblem,
    params: &[Parameter],
    stop: &dyn Fn() -> bool,
) -> Result<(), WsmError> {
    if problem.contact.kernel_dim() == 0 {
        return Ok(());
    }
    Balance::new(problem, &problem.nominal).check(&load_work(problem, &problem.nominal)?)?;
    if !params.iter().any(|p| is_load(p) || is_bound(p)) {
        return Ok(());
    }
    // Every parameter at its lower end: the least bounds, and the loads' base point e₀.
    let lows: Vec<f64> = params.iter().map(|p| p.lo).collect();
    let mut least = apply(&problem.scene, &problem.nominal, params, &lows);
    least_slip_limits(&problem.scene, params, &mut least);
    let balance = Balance::new(problem, &least);
    let base = load_work(problem, &least)?;
    let mut swings = Vec::new();
    for (i, p) in params.iter().enumerate() {
        if is_load(p) && p.hi > p.lo {
            let mut theta = lows.clone();
            theta[i] = p.hi;
            let e = load_work(
                problem,
                &apply(&problem.scene, &problem.nominal, params, &theta),
            )?;
            swings.push((i, e.iter().zip(&base).map(|(a, b)| a - b).collect()));
        }
    }
    let generators = Generators::merge(&base, swings);
    let r = generators.directions.len();
    let count = if r <= 12 { 1usize << r } else { MAX_VERTICES };
    for v in 0..count {
        if stop() {
            return Err(WsmError::Cancelled);
        }
        // Vertex bits: exhaustive up to 2^12, else a fixed pseudo-random sequence of vertices.
        let bits = if r <= 12 {
            v as u64
        } else {
            splitmix(v as u64)
        };
        let up = |g: usize| (bits >> (g % 64)) & 1 == 1;
        let mut e = generators.offset.clone();
        for (g, (direction, _)) in generators.directions.iter().enumerate() {
            if up(g) {
                e.iter_mut().zip(direction).for_each(|(a, d)| *a += d);
            }
        }
        if let Err(err) = balance.check(&e) {
            let mut at: Vec<String> = Vec::new();
            for (g, (_, members)) in generators.directions.iter().enumerate() {
                for &(i, sign) in members {
                    let high = up(g) == (sign > 0.0);
                    let p = &params[i];
                    at.push(format!("{} = {}", p.name, if high { p.hi } else { p.lo }));
                }
            }
            let limits = if params.iter().any(is_bound) {
                ", slip limits and friction coefficients at their least"
            } else {
                ""
            };
            return Err(SceneError::new(
                "uncertain",
                format!("at the vertex ({}{limits}): {err}", at.join(", ")),
            )
            .into());
        }
    }
    Ok(())
}

/// Whether a parameter drives a load (it moves e).
fn is_load(p: &Parameter) -> bool {
    p.fields().any(|(target, _)| {
        matches!(
            target,
            ParamTarget::SpecificWeight(_)
                | ParamTarget::BodyForce(..)
                | ParamTarget::Traction(..)
                | ParamTarget::Pressure(_)
                | ParamTarget::HydrostaticLevel(_)
                | ParamTarget::UnitWeight(_)
        )
    })
}

/// Whether a parameter drives a bound of the contact forces (a slip limit or a friction
/// coefficient; a driven one has a positive factor, so it is least at θ = lo).
fn is_bound(p: &Parameter) -> bool {
    p.fields().any(|(target, _)| {
        matches!(
            target,
            ParamTarget::SlipConstant(_)
                | ParamTarget::SlipKnot(..)
                | ParamTarget::FrictionCoefficient(_)
        )
    })
}

/// Parameters (by index) with the sign of their swing along a generator.
type Members = Vec<(usize, f64)>;

/// The loads' generators over the box: e = offset + Σ t_g direction_g, t_g ∈ [0, 1]; each with
/// its parameters and the sign of their swing along it.
struct Generators {
    offset: Vec<f64>,
    directions: Vec<(Vec<f64>, Members)>,
}

impl Generators {
    /// Drop the swings Δᵢ that are round-off of the assembly (≤ 1e-13 of the largest work) and
    /// merge parallel ones: Σ tᵢ aᵢ d over tᵢ ∈ [0, 1] is the segment from Σ min(aᵢ, 0) d to
    /// Σ max(aᵢ, 0) d, exactly one generator.
    fn merge(base: &[f64], swings: Vec<(usize, Vec<f64>)>) -> Generators {
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let scale = swings
            .iter()
            .map(|(_, d)| norm(d))
            .fold(norm(base), f64::max);
        let mut offset = base.to_vec();
        // (unit direction, total length, members with their signed lengths)
        let mut groups: Vec<(Vec<f64>, f64, Members)> = Vec::new();
        for (i, swing) in swings {
            let length = norm(&swing);
            if length <= 1e-13 * scale {
                continue;
            }
            let unit: Vec<f64> = swing.iter().map(|x| x / length).collect();
            let dot = |d: &[f64]| d.iter().zip(&unit).map(|(a, b)| a * b).sum::<f64>();
            match groups
                .iter_mut()
                .find(|(d, _, _)| dot(d).abs() >= 1.0 - 1e-12)
            {
                Some((d, total, members)) => {
                    let a = length * dot(d).signum();
                    if a < 0.0 {
                        offset
                            .iter_mut()
                            .zip(d.iter())
                            .for_each(|(o, x)| *o += a * x);
                    }
                    *total += a.abs();
                    members.push((i, a.signum()));
                }
                None => groups.push((unit, length, vec![(i, 1.0)])),
            }
        }
        let directions = groups
            .into_iter()
            .map(|(d, total, members)| (d.iter().map(|x| x * total).collect(), members))
            .collect();
        Generators { offset, directions }
    }
}

/// e = Rᵀ f: the loads' work on the floating bodies' rigid motions.
fn load_work(problem: &StateProblem, data: &crate::scene::Data) -> Result<Vec<f64>, WsmError> {
    let loads = problem.elastic.loads(data, None)?;
    let (f, _) = problem.elastic.dofs().restrict(&loads);
    Ok(problem.contact.equilibrium(&f).1)
}

/// The balance of the floating bodies for given bounds: contact forces λ within them with
/// G λ = e. A Coulomb pair's (λ_n, λ_t) is written μ⁺ (1, F) + μ⁻ (1, −F) with μ± ≥ 0 — exactly
/// its friction cone |λ_t| ≤ F λ_n (F = 0: no tangential force).
struct Balance<'a> {
    problem: &'a StateProblem,
    g: Mat<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl<'a> Balance<'a> {
    fn new(problem: &'a StateProblem, data: &crate::scene::Data) -> Balance<'a> {
        let contact = &problem.contact;
        let (mut g, _) = contact.equilibrium(&[]);
        let (mut lower, mut upper) = contact.geometry.bounds(data, None);
        for (m, pair) in contact.geometry.pairs.iter().enumerate() {
            let Some(f) = data.friction.get(pair.zone).copied().flatten() else {
                continue;
            };
            if pair.bilateral {
                continue;
            }
            let (n, t) = (normal_row(m), tangential_row(m));
            for row in 0..g.nrows() {
                let (gn, gt) = (g[(row, n)], g[(row, t)]);
                g[(row, n)] = gn + f * gt;
                g[(row, t)] = gn - f * gt;
            }
            (lower[n], upper[n], lower[t], upper[t]) = (0.0, f64::INFINITY, 0.0, f64::INFINITY);
        }
        Balance {
            problem,
            g,
            lower,
            upper,
        }
    }

    /// Feasibility for the loads' work `e` (the minimum-norm forces).
    fn check(&self, e: &[f64]) -> Result<(), WsmError> {
        let m = self.lower.len();
        let qp = BoxQp::new(
            Mat::identity(m, m),
            vec![0.0; m],
            self.lower.clone(),
            self.upper.clone(),
        )
        .with_equalities(self.g.clone(), e.to_vec());
        solve_box_qp(&qp, None, &QpOptions::default())
            .map(|_| ())
            .map_err(|err| self.problem.contact.explain(err))
    }
}

fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}
