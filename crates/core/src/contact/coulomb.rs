//! Coulomb friction by successive Tresca problems (design §3.4; D05 §1 and §8: Tresca's given
//! friction as the inner step towards Coulomb's law, the approach of the MCS 2007 knee model).
//!
//! On a Coulomb zone the nodal law is |λ_t,m| ≤ F λ_n,m (both multipliers are nodal forces
//! \[N/m\], so the bound needs no weight w_m), with slip opposite to λ_t where the bound is
//! attained. The fixed point
//!
//! ```text
//!   λ⁰ = Tresca solution with unbounded tangential multipliers on Coulomb zones (bonded; a
//!        tangential row without free DOFs, decided by prescribed displacements, starts at 0),
//!   λᵏ⁺¹ = Tresca solution with the bounds |λ_t,m| ≤ F max(λᵏ_n,m, 0),
//! ```
//!
//! is the method of successive approximations of the papers (g ← F |τ_n|). Its map is a
//! contraction for small F (Nečas–Jarušek–Haslinger; the constant grows with F and with the
//! coupling of normal and tangential responses, which vanishes for two bodies of the same
//! material in plane strain, Goodman's decoupling); for large F the discrete Coulomb problem may
//! have several solutions and the iteration need not converge. Each step is one box QP on the
//! already factored K and C, warm-started from the previous multipliers.
//!
//! By default the fixed point's unknowns, the normal forces x on the Coulomb pairs (the bounds
//! read nothing else), are Anderson-mixed ([`super::anderson`], depth 3): the bounds of step
//! k + 1 come from x⁺ = G(x_k) − ΔG γ instead of G(x_k); a mixed step that makes ‖G(x) − x‖∞
//! grow drops the history. Convergence then also asks the state's own normal forces to match
//! the bounds'.
//!
//! Convergence: ‖λᵏ⁺¹ − λᵏ‖∞ ≤ [`TOLERANCE`] ‖λᵏ⁺¹‖∞; with inexact (DD) steps also a change
//! within their accuracy that has stopped shrinking. Non-convergence is reported, never
//! returned as a state: after [`MAX_ITERATIONS`] steps, or as soon as the change has failed to
//! shrink over [`STALL_WINDOW`] consecutive steps (an observed contraction factor ≥ 1).

use serde::Serialize;

use super::anderson::Anderson;
use super::pairs::ContactGeometry;
use crate::scene::Data;

/// Relative change of the multipliers at which the fixed point of exact Tresca steps has
/// converged.
pub const TOLERANCE: f64 = 1e-12;
/// Fixed-point steps at most.
pub const MAX_ITERATIONS: usize = 200;
/// Consecutive steps without a smaller change after which the iteration is declared divergent.
pub const STALL_WINDOW: usize = 5;
/// Changes at or below this multiple of the tolerance do not count as a stall (rounding of the
/// QP near the fixed point).
const STALL_FLOOR: f64 = 1e3;
/// With inexact steps, a change within the steps' accuracy that is more than this fraction of
/// the previous one (the iteration no longer contracts) ends the fixed point.
const NOISE_CONTRACTION: f64 = 0.5;

/// How the Coulomb fixed point converged.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct CoulombReport {
    /// Tresca problems solved after the bonded start.
    pub iterations: usize,
    /// ‖λᵏ⁺¹ − λᵏ‖∞ / ‖λᵏ⁺¹‖∞ of the last step.
    pub residual: f64,
    /// Ratio of the last two changes (an estimate of the contraction factor; 0 before two).
    pub contraction: f64,
    /// Steps whose slip bounds came from Anderson-mixed normal forces.
    pub accelerated_steps: usize,
    /// Times the Anderson history was dropped because a mixed step made the residual grow.
    pub restarts: usize,
}

/// How the fixed point is run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedPoint {
    /// The relative accuracy of the steps' multipliers ([`TOLERANCE`] for exact steps), below
    /// which a change that no longer shrinks ends the iteration.
    pub tolerance: f64,
    /// Anderson depth on the normal forces of the Coulomb pairs (0 = plain successive
    /// approximations).
    pub anderson_depth: usize,
}

/// Solve the contact problem of `data` with `tresca`, a solver of the box-constrained problem
/// for given multiplier bounds (lower, upper) that may warm-start from a previous solution;
/// `multipliers` reads λ off a solution, `fail` makes the solver's error from the account of a
/// fixed point that does not converge; `how` gives the steps' accuracy and the Anderson depth.
/// Without a Coulomb zone this is one Tresca solve (and no report); otherwise the fixed point
/// above.
pub fn solve<S, E>(
    geometry: &ContactGeometry,
    data: &Data,
    how: FixedPoint,
    mut tresca: impl FnMut(&[f64], &[f64], Option<&S>) -> Result<S, E>,
    multipliers: impl Fn(&S) -> &[f64],
    fail: impl Fn(String) -> E,
) -> Result<(S, Option<CoulombReport>), E> {
    let (mut lower, mut upper) = geometry.bounds(data, None);
    // A tangential row that the prescribed displacements alone decide has no stiffness: bonded,
    // its multiplier would be unbounded; it starts at 0 instead.
    for (r, row) in geometry.rows.iter().enumerate() {
        if upper[r].is_infinite() && r % 2 == 1 && row.free.is_empty() {
            (lower[r], upper[r]) = (0.0, 0.0);
        }
    }
    let mut state = tresca(&lower, &upper, None)?;
    if !data.has_coulomb() {
        return Ok((state, None));
    }
    let mut report = CoulombReport::default();
    let tolerance = how.tolerance;
    // The slip bounds F max(x, 0) are read from `input` (a full multiplier vector); x are its
    // normal forces on Coulomb pairs, the fixed point's unknowns.
    let coulomb_rows: Vec<usize> = geometry
        .pairs
        .iter()
        .enumerate()
        .filter(|(_, p)| !p.bilateral && data.friction.get(p.zone).copied().flatten().is_some())
        .map(|(m, _)| 2 * m)
        .collect();
    let mut mixer = Anderson::new(how.anderson_depth);
    let mut input = multipliers(&state).to_vec();
    let mut mixed_input = false;
    let mut previous_residual = f64::INFINITY;
    let mut previous_change = f64::INFINITY;
    let mut stalled = 0;
    let mut iteration = 0;
    loop {
        iteration += 1;
        report.accelerated_steps += usize::from(mixed_input);
        let (lower, upper) = geometry.bounds(data, Some(&input));
        let next = tresca(&lower, &upper, Some(&state))?;
        let (old, new) = (multipliers(&state), multipliers(&next));
        let scale = new
            .iter()
            .fold(0.0_f64, |m, x| m.max(x.abs()))
            .max(f64::MIN_POSITIVE);
        // The change between successive states, and (after a mixed step) how far the bounds'
        // normal forces are from the new state's own: both vanish at the fixed point.
        let (worst, change) = old
            .iter()
            .zip(new)
            .map(|(a, b)| (a - b).abs())
            .enumerate()
            .chain(coulomb_rows.iter().map(|&r| (r, (new[r] - input[r]).abs())))
            .fold(
                (0, 0.0_f64),
                |(i, m), (j, d)| if d > m { (j, d) } else { (i, m) },
            );
        let x: Vec<f64> = coulomb_rows.iter().map(|&r| input[r]).collect();
        let g: Vec<f64> = coulomb_rows.iter().map(|&r| new[r]).collect();
        let residual = x
            .iter()
            .zip(&g)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        if mixed_input && residual > previous_residual {
            mixer.restart();
            report.restarts += 1;
        }
        previous_residual = residual;
        input = new.to_vec();
        let mixed = mixer.next(&x, &g);
        mixed_input = mixed != g;
        for (&r, v) in coulomb_rows.iter().zip(mixed) {
            input[r] = v.max(0.0);
        }
        let change = change / scale;
        report.iterations = iteration;
        report.residual = change;
        if previous_change.is_finite() && previous_change > 0.0 {
            report.contraction = change / previous_change;
        }
        state = next;
        // Inexact steps: at their accuracy, a change that no longer shrinks is their noise.
        let at_noise = change <= tolerance && change > NOISE_CONTRACTION * previous_change;
        if change <= TOLERANCE || at_noise {
            return Ok((state, Some(report)));
        }
        if change >= previous_change && change > tolerance.max(STALL_FLOOR * TOLERANCE) {
            stalled += 1;
        } else {
            stalled = 0;
        }
        previous_change = change;
        let zone = geometry.pairs.get(worst / 2).map_or(0, |p| p.zone);
        if stalled >= STALL_WINDOW {
            return Err(fail(not_converged(
                zone,
                &report,
                &format!("the change has not decreased over {STALL_WINDOW} steps"),
            )));
        }
        if iteration == MAX_ITERATIONS {
            return Err(fail(not_converged(
                zone,
                &report,
                &format!("no convergence in {MAX_ITERATIONS} steps"),
            )));
        }
    }
}

/// The account of a fixed point that did not converge, naming the zone of the largest change.
fn not_converged(zone: usize, report: &CoulombReport, why: &str) -> String {
    format!(
        "Coulomb friction: the successive Tresca problems (g = F |normal force|) do not converge \
         ({why}; largest change at contacts[{zone}], last relative change {:.2e}, observed \
         contraction factor {:.2}): the friction coefficient may be too large for a unique \
         solution",
        report.residual, report.contraction
    )
}
