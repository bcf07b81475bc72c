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
//! Stopping (design §3.4). A Tresca step's multipliers are exact only to its rounding level η,
//! their relative accuracy (the direct solver: the condition of C times the QP's KKT residual;
//! DD: its tolerance times the amplification of its interface error), so successive states
//! cannot agree better than η however well the iteration contracts. The fixed point has
//! converged when ‖λᵏ⁺¹ − λᵏ‖∞ ≤ [`TOLERANCE`] ‖λᵏ⁺¹‖∞, or at the rounding level: a change
//! within η (of either state) that is more than [`NOISE_CONTRACTION`] of the previous one — the
//! iteration no longer contracts, its changes are rounding. Non-convergence is reported, never
//! returned as a state: after [`MAX_ITERATIONS`] steps, or as soon as the change, above η, has
//! failed to shrink over [`STALL_WINDOW`] consecutive steps (an observed contraction factor
//! ≥ 1). Only a contraction factor ≥ 1 at a change far above η ([`SIGNIFICANT`] × η) is taken as
//! a sign that F is too large for a unique solution.

use serde::Serialize;

use super::anderson::{Anderson, Shift};
use super::pairs::{is_tangential_row, normal_row, pair_of_row, ContactGeometry};
use crate::scene::Data;

/// Relative change of the multipliers at which the fixed point has converged whatever the
/// steps' rounding level.
pub const TOLERANCE: f64 = 1e-12;
/// Fixed-point steps at most.
pub const MAX_ITERATIONS: usize = 200;
/// Consecutive steps without a smaller change (above the rounding level) after which the
/// iteration is declared divergent.
pub const STALL_WINDOW: usize = 5;
/// A change within the rounding level that is more than this fraction of the previous one (the
/// iteration no longer contracts) ends the fixed point.
pub const NOISE_CONTRACTION: f64 = 0.5;
/// A change at least this multiple of the rounding level η is far above rounding: the noise
/// moves it by at most 1 %, so the ratio of two such changes estimates the contraction factor to
/// about 2 %.
pub const SIGNIFICANT: f64 = 100.0;

/// How the Coulomb fixed point converged.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct CoulombReport {
    /// Tresca problems solved after the bonded start.
    pub iterations: usize,
    /// ‖λᵏ⁺¹ − λᵏ‖∞ / ‖λᵏ⁺¹‖∞ of the last step (with Anderson mixing also the distance of the
    /// state's normal forces from its bounds', relative).
    pub residual: f64,
    /// Ratio of the last two changes (an estimate of the contraction factor; 0 before two).
    pub contraction: f64,
    /// The relative rounding level η of the steps' multipliers, as last asked by the stopping
    /// test (which asks only after a change that failed to halve; `None` if none did). The
    /// fixed point stopped at this level when `residual` exceeds [`TOLERANCE`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rounding_level: Option<f64>,
    /// Steps whose slip bounds came from Anderson-mixed normal forces.
    pub accelerated_steps: usize,
    /// Times the Anderson history was dropped because a mixed step made the residual grow.
    pub restarts: usize,
}

/// What the stopping test says after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Verdict {
    /// Go on.
    Continue,
    /// Converged: the change is within [`TOLERANCE`], or within the rounding level and no
    /// longer contracting.
    Converged,
    /// The change, above the rounding level, has not decreased over [`STALL_WINDOW`] steps.
    Stalled,
}

/// The stopping test of the fixed point (module doc), fed the relative change of every step.
#[derive(Debug, Clone)]
struct Stopping {
    previous: f64,
    stalled: usize,
    /// The last rounding level asked for.
    rounding_level: Option<f64>,
}

impl Stopping {
    fn new() -> Stopping {
        Stopping {
            previous: f64::INFINITY,
            stalled: 0,
            rounding_level: None,
        }
    }

    /// The verdict on a step whose relative change is `change`; `rounding_level` gives η of the
    /// step's states and is asked only for a change that is neither within [`TOLERANCE`] nor
    /// less than [`NOISE_CONTRACTION`] of the previous one.
    fn verdict(&mut self, change: f64, rounding_level: impl FnOnce() -> f64) -> Verdict {
        let previous = std::mem::replace(&mut self.previous, change);
        if change <= TOLERANCE {
            return Verdict::Converged;
        }
        if change <= NOISE_CONTRACTION * previous {
            self.stalled = 0;
            return Verdict::Continue;
        }
        let level = rounding_level();
        self.rounding_level = Some(level);
        if change <= level {
            return Verdict::Converged;
        }
        self.stalled = if change >= previous {
            self.stalled + 1
        } else {
            0
        };
        if self.stalled >= STALL_WINDOW {
            Verdict::Stalled
        } else {
            Verdict::Continue
        }
    }
}

/// Solve the contact problem of `data` with `tresca`, a solver of the box-constrained problem
/// for given multiplier bounds (lower, upper) that may warm-start from a previous solution;
/// `multipliers` reads λ off a solution and `rounding_level` its relative rounding level η,
/// `fail` makes the solver's error from the account of a fixed point that does not converge;
/// `anderson_depth` is the depth of Anderson mixing (0 = plain successive approximations).
/// Without a Coulomb zone this is one Tresca solve (and no report); otherwise the fixed point
/// above.
pub fn solve<S, E>(
    geometry: &ContactGeometry,
    data: &Data,
    anderson_depth: usize,
    mut tresca: impl FnMut(&[f64], &[f64], Option<&S>) -> Result<S, E>,
    multipliers: impl Fn(&S) -> &[f64],
    rounding_level: impl Fn(&S) -> f64,
    fail: impl Fn(String) -> E,
) -> Result<(S, Option<CoulombReport>), E> {
    let (mut lower, mut upper) = geometry.bounds(data, None);
    // A tangential row that the prescribed displacements alone decide has no stiffness: bonded,
    // its multiplier would be unbounded; it starts at 0 instead.
    for (r, row) in geometry.rows.iter().enumerate() {
        if upper[r].is_infinite() && is_tangential_row(r) && row.free.is_empty() {
            (lower[r], upper[r]) = (0.0, 0.0);
        }
    }
    let mut state = tresca(&lower, &upper, None)?;
    if !data.has_coulomb() {
        return Ok((state, None));
    }
    let mut report = CoulombReport::default();
    // The slip bounds F max(x, 0) are read from `input` (a full multiplier vector); x are its
    // normal forces on Coulomb pairs, the fixed point's unknowns.
    let coulomb_rows: Vec<usize> = geometry
        .pairs
        .iter()
        .enumerate()
        .filter(|(_, p)| !p.bilateral && data.friction.get(p.zone).copied().flatten().is_some())
        .map(|(m, _)| normal_row(m))
        .collect();
    let mut mixer = Anderson::new(anderson_depth, Shift::OfTrace(1e-12));
    let mut input = multipliers(&state).to_vec();
    let mut mixed_input = false;
    let mut previous_residual = f64::INFINITY;
    let mut stopping = Stopping::new();
    let mut first_change = None;
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
        let first_change = *first_change.get_or_insert(change);
        report.iterations = iteration;
        if report.residual > 0.0 {
            report.contraction = change / report.residual;
        }
        report.residual = change;
        let verdict =
            stopping.verdict(change, || rounding_level(&next).max(rounding_level(&state)));
        report.rounding_level = stopping.rounding_level;
        state = next;
        let zone = geometry.pairs.get(pair_of_row(worst)).map_or(0, |p| p.zone);
        let why = match verdict {
            Verdict::Converged => return Ok((state, Some(report))),
            Verdict::Stalled => format!("the change has not decreased over {STALL_WINDOW} steps"),
            Verdict::Continue if iteration == MAX_ITERATIONS => {
                format!("no convergence in {MAX_ITERATIONS} steps")
            }
            Verdict::Continue => continue,
        };
        // The geometric mean of the ratios of successive changes.
        let average = (change / first_change).powf(1.0 / (iteration - 1).max(1) as f64);
        let reading = reading(&report, average, anderson_depth > 0);
        return Err(fail(not_converged(zone, &report, &why, &reading)));
    }
}

/// The account of a fixed point that did not converge, naming the zone of the largest change
/// and what the changes say (`reading`).
fn not_converged(zone: usize, report: &CoulombReport, why: &str, reading: &str) -> String {
    format!(
        "Coulomb friction: the successive Tresca problems (g = F |normal force|) do not converge \
         ({why}; largest change at contacts[{zone}], last relative change {:.2e}, observed \
         contraction factor {:.2}): {reading}",
        report.residual, report.contraction
    )
}

/// What the changes of a fixed point that did not converge say, given their `average` ratio:
/// near the rounding level, that rounding limits the solve; far above it, a contraction factor
/// ≥ 1 (F may be too large for a unique solution) or a slow contraction (F may be near that
/// limit; Anderson mixing helps when it is off).
fn reading(report: &CoulombReport, average: f64, anderson: bool) -> String {
    match report.rounding_level {
        Some(level) if report.residual <= SIGNIFICANT * level => format!(
            "the changes stopped shrinking within {SIGNIFICANT:.0} times the rounding level \
             {level:.1e} of the steps' multipliers but above it: rounding, not the friction \
             coefficient, limits this solve"
        ),
        _ if report.contraction >= 1.0 => {
            "the friction coefficient may be too large for a unique solution".to_string()
        }
        _ => format!(
            "the changes shrink by a factor {average:.3} a step on average, too slowly for \
             {MAX_ITERATIONS} steps; the contraction slows down as F grows, so the friction \
             coefficient may be near the limit of a unique solution{}",
            if anderson {
                ""
            } else {
                " (solver.coulomb_acceleration: anderson mixes the steps)"
            }
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feed `changes` to a fresh stopping test with the rounding level `level`; the step
    /// (1-based) and verdict at which it stops, if it does.
    fn run(changes: &[f64], level: f64) -> Option<(usize, Verdict)> {
        let mut stopping = Stopping::new();
        changes
            .iter()
            .enumerate()
            .find_map(|(k, &c)| match stopping.verdict(c, || level) {
                Verdict::Continue => None,
                verdict => Some((k + 1, verdict)),
            })
    }

    /// The changes of the 75,700-unknown dam with F = 0.5 (design §3.4, "Rounding level"; direct
    /// solver, Anderson): contraction by about 0.1 a step down to 6e-12, then rounding noise at
    /// 1.1e-12–2.2e-12.
    const DAM: [f64; 24] = [
        7.8e-1, 3.0e-1, 1.5e-1, 1.5e-2, 1.6e-3, 1.3e-4, 1.4e-5, 2.3e-6, 7.0e-7, 3.5e-8, 3.2e-9,
        9.2e-10, 7.1e-11, 6.2e-12, 1.35e-12, 1.29e-12, 1.40e-12, 2.2e-12, 1.50e-12, 1.51e-12,
        1.50e-12, 2.0e-12, 1.69e-12, 1.29e-12,
    ];

    /// At a noise floor above TOLERANCE the iteration converges at the first change within the
    /// rounding level that no longer halves (step 16 of the dam); with a rounding level below
    /// the floor it neither converges nor stalls (the noise goes up and down), which is what
    /// ran the dam into the step cap.
    #[test]
    fn a_noise_floor_within_the_rounding_level_is_convergence() {
        assert_eq!(run(&DAM, 1.3e-11), Some((16, Verdict::Converged)));
        assert_eq!(run(&DAM, TOLERANCE), None);
        // A floor at 3× the rounding level is not convergence either.
        let above: Vec<f64> = DAM.iter().map(|c| c * 3.0).collect();
        assert_eq!(run(&above, 1.3e-12 * 1.5), None);
    }

    /// While the change at least halves, the rounding level is not needed (not computed) and
    /// the iteration goes on down to TOLERANCE.
    #[test]
    fn a_contracting_iteration_runs_to_the_tolerance() {
        let changes: Vec<f64> = (0..40).map(|k| 0.4_f64.powi(k)).collect();
        let mut stopping = Stopping::new();
        let stop = changes.iter().position(|&c| {
            stopping.verdict(c, || panic!("rounding level asked at {c:e}")) != Verdict::Continue
        });
        assert_eq!(stop.map(|k| changes[k] <= TOLERANCE), Some(true));
        assert_eq!(stopping.rounding_level, None);
    }

    /// A change far above rounding that does not decrease over STALL_WINDOW steps is a stall,
    /// reported with the reading that F may be too large; a slow contraction is not a stall.
    #[test]
    fn a_non_contracting_iteration_stalls() {
        let flat = [0.3, 0.21, 0.2, 0.2, 0.22, 0.23, 0.23, 0.24];
        assert_eq!(run(&flat, 1e-11), Some((8, Verdict::Stalled)));
        let slow: Vec<f64> = (0..200).map(|k| 0.96_f64.powi(k)).collect();
        assert_eq!(run(&slow, 1e-11), None);
    }

    /// The failure's reading follows the last change and the rounding level.
    #[test]
    fn the_account_of_a_failure_says_what_happened() {
        let report = |residual: f64, contraction: f64, rounding_level: Option<f64>| CoulombReport {
            iterations: MAX_ITERATIONS,
            residual,
            contraction,
            rounding_level,
            ..CoulombReport::default()
        };
        let too_large = reading(&report(0.2, 1.02, Some(1e-11)), 0.99, true);
        assert!(
            too_large.contains("may be too large for a unique solution"),
            "{too_large}"
        );
        let slow = reading(&report(1e-3, 0.96, None), 0.96, false);
        assert!(
            slow.contains("0.960 a step") && slow.contains("anderson"),
            "{slow}"
        );
        let rounding = reading(&report(2e-12, 1.16, Some(1e-13)), 0.9, true);
        assert!(
            rounding.contains("rounding, not the friction coefficient"),
            "{rounding}"
        );
        assert!(!rounding.contains("too large"), "{rounding}");
        let account = not_converged(1, &report(2e-12, 1.16, None), "stalled", &rounding);
        assert!(
            account.contains("contacts[1]") && account.contains("2.00e-12"),
            "{account}"
        );
    }
}
