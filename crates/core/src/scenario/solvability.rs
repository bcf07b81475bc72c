//! Admissible-set checks before any solve (design §4.1): the primal feasibility of the contact
//! constraints with the prescribed displacements on the whole box (in closed form, see
//! `crate::contact::feasibility`), and the semi-coercive solvability condition (CZ Thm 1.2,
//! D05 Thm 2.1) at the vertices of the box.
//!
//! For a floating body the condition is the existence of contact forces λ within their bounds
//! (normal ≥ 0, |tangential| ≤ g w) with G λ = e, G = RᵀBᵀ, e = Rᵀ f: the loads must be balanced
//! by contact and friction. G depends on geometry only, e on the applied forces only (a rigid
//! motion does no work against stiffness, prescribed displacements or thermal strain), and the
//! bounds on g only — all linearly. The set of parameters where it holds is therefore convex, and
//! it holds on the whole box exactly when it holds at every vertex of the force and slip-limit
//! parameters. Up to 2^12 vertices are checked exhaustively; beyond, a deterministic sample. A
//! slope-limited slip limit is not a box: the check takes it at the least element of its set,
//! since a larger g only makes balance easier. On a Coulomb zone the bound F λ_n depends on the
//! state; the check leaves its tangential forces unbounded (a necessary condition only: a body
//! that Coulomb friction cannot hold is refused by its solve, naming the motion).

use faer::Mat;

use crate::contact::feasibility::UncertainDisplacement;
use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions};
use crate::error::WsmError;
use crate::scene::params::{apply, least_slip_limits, ParamTarget, Parameter};
use crate::scene::SceneError;
use crate::scene::{Scene, SlipLimit};
use crate::state::StateProblem;

const MAX_VERTICES: usize = 4096;

/// Whether a parameter can change the balance of a floating body at the vertices: the knots of
/// a slope-limited slip limit do not, since the check takes that slip limit at the least
/// element of its set (see [`crate::scene::params`]).
fn affects_balance(scene: &Scene, target: ParamTarget) -> bool {
    if let ParamTarget::SlipKnot(c, _) = target {
        if matches!(
            scene.contacts[c].slip_limit,
            SlipLimit::PiecewiseLinear {
                max_slope: Some(_),
                ..
            }
        ) {
            return false;
        }
    }
    matches!(
        target,
        ParamTarget::SpecificWeight(_)
            | ParamTarget::BodyForce(..)
            | ParamTarget::Traction(..)
            | ParamTarget::Pressure(_)
            | ParamTarget::SlipConstant(_)
            | ParamTarget::SlipKnot(..)
    )
}

/// Refuse the admissible set if at some vertex of the uncertain displacements the prescribed
/// displacements alone make two bodies overlap (no admissible displacement exists there).
pub fn check_feasibility_on_box(
    problem: &StateProblem,
    params: &[Parameter],
) -> Result<(), WsmError> {
    let uncertain: Vec<UncertainDisplacement<'_>> = params
        .iter()
        .enumerate()
        .filter_map(|(index, p)| match p.target {
            ParamTarget::Displacement(bc, comp) => Some(UncertainDisplacement {
                index,
                name: &p.name,
                source: (bc, comp),
                lo: p.lo,
                hi: p.hi,
            }),
            _ => None,
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

/// Refuse the admissible set if some vertex leaves a floating body unbalanced. `stop` is asked
/// before each vertex; when it answers true the check ends with [`WsmError::Cancelled`].
pub fn check_balance_on_vertices(
    problem: &StateProblem,
    params: &[Parameter],
    stop: &dyn Fn() -> bool,
) -> Result<(), WsmError> {
    let contact = &problem.contact;
    if contact.kernel_dim() == 0 {
        return Ok(());
    }
    let relevant: Vec<usize> = (0..params.len())
        .filter(|&i| affects_balance(&problem.scene, params[i].target))
        .collect();
    let n = relevant.len();
    let count = if n < 12 { 1usize << n } else { MAX_VERTICES };
    let mid: Vec<f64> = params.iter().map(|p| 0.5 * (p.lo + p.hi)).collect();
    for v in 0..count {
        if stop() {
            return Err(WsmError::Cancelled);
        }
        // Vertex bits: exhaustive below 2^12, else a fixed pseudo-random sequence of vertices.
        let bits = if n < 12 { v as u64 } else { splitmix(v as u64) };
        let mut theta = mid.clone();
        for (b, &i) in relevant.iter().enumerate() {
            theta[i] = if (bits >> (b % 64)) & 1 == 1 {
                params[i].hi
            } else {
                params[i].lo
            };
        }
        let mut data = apply(&problem.scene, &problem.nominal, params, &theta);
        least_slip_limits(&problem.scene, params, &mut data);
        if n == 0 {
            // No uncertain datum moves the balance: the nominal data decide, as in a solve.
            return balance(problem, &data);
        }
        if let Err(e) = balance(problem, &data) {
            let at: Vec<String> = relevant
                .iter()
                .map(|&i| format!("{} = {}", params[i].name, theta[i]))
                .collect();
            return Err(SceneError::new(
                "uncertain",
                format!("at the vertex ({}): {e}", at.join(", ")),
            )
            .into());
        }
    }
    Ok(())
}

/// Feasibility of G λ = e within the bounds for one data set (the minimum-norm balancing forces).
fn balance(problem: &StateProblem, data: &crate::scene::Data) -> Result<(), WsmError> {
    let elastic = &problem.elastic;
    let loads = elastic.loads(data, None)?;
    let (f, _) = elastic.dofs().restrict(&loads);
    let (lower, upper) = problem.contact.geometry.bounds(data, None);
    let m = lower.len();
    let (g, e) = problem.contact.equilibrium(&f);
    let qp = BoxQp::new(Mat::identity(m, m), vec![0.0; m], lower, upper).with_equalities(g, e);
    solve_box_qp(&qp, None, &QpOptions::default())
        .map(|_| ())
        .map_err(|err| problem.contact.explain(err))
}

fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}
