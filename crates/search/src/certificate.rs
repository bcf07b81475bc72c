//! First-order optimality certificates of an extremum from the exact one-sided derivatives (design
//! §4.3: status `locally_certified`, and the kink check). In unit coordinates u_j ∈ [0, 1] of the
//! free data and with the score s = ±Φ (larger is better), a point is a first-order maximiser of s
//! over the box when every feasible direction decreases s: at a lower bound the right derivative is
//! ≤ 0, at an upper bound the left derivative is ≥ 0, strictly inside both hold (both vanish where
//! s is differentiable — the projected gradient is zero). The residual is the largest violation
//! relative to |Φ|; the point is certified when it is below [`CERTIFY_TOL`]. Each bound the point
//! sits on is proven by the sign of ∂Φ/∂θ into the box, reported as a rate.

use super::space::{Space, BOUND_TOL};
use super::{ActiveBound, OneSided, Sense};
use serde::{Deserialize, Serialize};

/// Largest relative projected-gradient residual of a certified point: the change of Φ along
/// any single datum moved over its whole interval, predicted by the first-order slope, is below
/// this fraction of |Φ|.
pub const CERTIFY_TOL: f64 = 1e-6;

/// What the derivatives prove about a reported extremum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// First-order optimal to [`CERTIFY_TOL`]: every active bound held by the derivative's sign,
    /// the slope along every interior datum vanishing — a local optimum (JSON
    /// `"locally_certified"`; stored results say `"certified"`).
    #[serde(alias = "certified")]
    LocallyCertified,
    /// Some datum can still be moved to make Φ more extreme (see `residual`).
    NotOptimal,
    /// The evaluator gave no derivatives at this point: nothing is proven.
    NoDerivatives,
}

/// One active bound of an extremum and the derivative that holds it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct BoundProof {
    /// Index of the parameter.
    pub parameter: usize,
    /// The bound it sits on (`lower` or `upper`).
    pub bound: ActiveBound,
    /// Relative change of Φ per whole interval when the datum leaves its bound into the box,
    /// (∂Φ/∂θ into the box) · (hi − lo) / |Φ|: ≤ 0 proves a maximum, ≥ 0 a minimum.
    pub rate: f64,
}

/// The optimality certificate of one extremum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct Certificate {
    /// What is proven.
    pub verdict: Verdict,
    /// Largest first-order violation relative to |Φ| (0 at a proven point); absent without
    /// derivatives.
    pub residual: Option<f64>,
    /// The bounds the point sits on, each with the rate that proves (or disproves) it.
    pub active: Vec<BoundProof>,
    /// How many local searches (the vertex walk, quasi-Newton ascents from different starts)
    /// ended at this point (within 1e-6 of the unit box). More than one is evidence, not proof,
    /// that no nearby basin is better; 0 when the point was found otherwise.
    pub starts: usize,
    /// For a point that is not certified: evidence that Φ has a kink next to it (see [`Kink`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kink: Option<Kink>,
}

/// Evidence of a kink next to an uncertified point x: along the datum whose derivative violates
/// optimality most, an evaluated point y a short way in the direction that derivative points to
/// is no better than x, and its own derivative along that datum points back towards x. Between
/// the two the derivative changes sign without vanishing (Φ is not differentiable there, e.g. a
/// contact pair switching between stick and slip), so no first-order proof exists at any point
/// the search can land on, and a larger budget will not give one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct Kink {
    /// Index of the parameter along which the derivative changes sign.
    pub parameter: usize,
    /// |y − x| along it, as a fraction of its interval.
    pub distance: f64,
    /// The relative rates (∂Φ/∂θ · (hi − lo) / |Φ|) at x and at y along it.
    pub rates: [f64; 2],
}

/// Unit points within this distance (Euclidean, unit box) of an uncertified point are searched
/// for [`Kink`] evidence.
pub const KINK_RADIUS: f64 = 0.05;

/// The [`Kink`] evidence for the uncertified point `x` (unit coordinates, value, physical
/// slopes) among evaluated `neighbours` (within [`KINK_RADIUS`]), the nearest along the
/// violating datum; `None` if there is none or `x` has no derivatives.
pub(super) fn kink(
    space: &Space,
    sense: Sense,
    x: (&[f64], f64, &[OneSided]),
    neighbours: &[(Vec<f64>, f64, Vec<OneSided>)],
) -> Option<Kink> {
    let (unit, value, slopes) = x;
    let direction = ascent_direction(unit, &unit_slopes(space, sense, slopes));
    let (j, d) = direction
        .iter()
        .copied()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    if d.abs() <= CERTIFY_TOL * scale(value) {
        return None;
    }
    let (i, width) = space.free_param(j);
    neighbours
        .iter()
        .filter_map(|(y, y_value, y_slopes)| {
            let step = y[j] - unit[j];
            let back = unit_slopes(space, sense, y_slopes)[j].mean();
            let no_better = sense.score(*y_value) <= sense.score(value);
            (step * d > 0.0 && back * d < 0.0 && no_better).then(|| Kink {
                parameter: i,
                distance: step.abs(),
                rates: [
                    slopes[i].mean() * width / scale(value),
                    y_slopes[i].mean() * width / scale(value),
                ],
            })
        })
        .min_by(|a, b| a.distance.total_cmp(&b.distance))
}

/// Per free datum j: the one-sided derivatives of the score along the unit coordinate u_j,
/// from the physical derivatives `slopes` of Φ (all parameters).
pub(super) fn unit_slopes(space: &Space, sense: Sense, slopes: &[OneSided]) -> Vec<OneSided> {
    let sign = match sense {
        Sense::Max => 1.0,
        Sense::Min => -1.0,
    };
    (0..space.dim())
        .map(|j| {
            let (i, width) = space.free_param(j);
            slopes[i].scaled(sign * width)
        })
        .collect()
}

/// Per free datum: the projected ascent direction at `unit` — the rate at which the score still
/// rises when u_j moves into the box (> 0 upwards, < 0 downwards, the steeper side at a convex
/// kink), 0 where the point is first-order optimal along it. Its magnitude is the violation the
/// certificate measures.
pub(super) fn ascent_direction(unit: &[f64], score_slopes: &[OneSided]) -> Vec<f64> {
    unit.iter()
        .zip(score_slopes)
        .map(|(&u, s)| {
            let up = if u < 1.0 - BOUND_TOL {
                s.right.max(0.0)
            } else {
                0.0
            };
            let down = if u > BOUND_TOL {
                (-s.left).max(0.0)
            } else {
                0.0
            };
            if up >= down {
                up
            } else {
                -down
            }
        })
        .collect()
}

/// The relative projected-gradient residual: the largest magnitude of `direction` over |Φ|.
pub(super) fn residual(direction: &[f64], value: f64) -> f64 {
    direction.iter().fold(0.0_f64, |m, d| m.max(d.abs())) / scale(value)
}

/// Scale of relative statements about Φ = `value` (never zero).
pub(super) fn scale(value: f64) -> f64 {
    value.abs().max(f64::MIN_POSITIVE)
}

/// The certificate of the unit point `unit` with criterion value `value` and physical
/// derivatives `slopes` (`None` without derivatives).
pub(super) fn certify(
    space: &Space,
    sense: Sense,
    unit: &[f64],
    value: f64,
    slopes: Option<&[OneSided]>,
) -> Certificate {
    let Some(slopes) = slopes else {
        return Certificate {
            verdict: Verdict::NoDerivatives,
            residual: None,
            active: Vec::new(),
            starts: 0,
            kink: None,
        };
    };
    let score_slopes = unit_slopes(space, sense, slopes);
    let residual = residual(&ascent_direction(unit, &score_slopes), value);
    let bounds = space.active_bounds(unit);
    let active = (0..space.dim())
        .filter_map(|j| {
            let (i, width) = space.free_param(j);
            let rate = match bounds[i] {
                ActiveBound::Lower => slopes[i].right * width,
                ActiveBound::Upper => -slopes[i].left * width,
                ActiveBound::None | ActiveBound::Fixed => return None,
            } / scale(value);
            Some(BoundProof {
                parameter: i,
                bound: bounds[i],
                rate,
            })
        })
        .collect();
    Certificate {
        verdict: if residual <= CERTIFY_TOL {
            Verdict::LocallyCertified
        } else {
            Verdict::NotOptimal
        },
        residual: Some(residual),
        active,
        starts: 0,
        kink: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sign_change_of_the_derivative_next_to_the_point_is_a_kink() {
        // Minimise Φ on θ0 ∈ [0, 2], θ1 ∈ [0, 1]: at x = (1.1, 0.5) Φ = 2 rises with θ0
        // (dΦ/dθ0 = 1), so a minimiser would move θ0 down; at θ0 = 1.0 the slope is −4 and Φ
        // is higher: the derivative changed sign in between.
        let space = Space::new(&[[0.0, 2.0], [0.0, 1.0]]).unwrap();
        let x_slopes = [OneSided::both(1.0), OneSided::both(0.0)];
        let x = ([0.55, 0.5].as_slice(), 2.0, x_slopes.as_slice());
        let back = |u0: f64, value: f64, slope: f64| {
            (
                vec![u0, 0.5],
                value,
                vec![OneSided::both(slope), OneSided::both(0.0)],
            )
        };
        let found = kink(
            &space,
            Sense::Min,
            x,
            &[
                back(0.5, 2.3, -4.0),
                back(0.45, 2.6, -4.0),
                back(0.6, 2.05, 1.0),
            ],
        )
        .expect("a kink");
        assert_eq!(found.parameter, 0);
        assert!((found.distance - 0.05).abs() < 1e-12);
        assert_eq!(found.rates, [1.0 * 2.0 / 2.0, -4.0 * 2.0 / 2.0]);
        // No evidence: the neighbour's slope does not point back, or it is better, or it lies
        // on the other side.
        for n in [
            back(0.5, 2.3, 0.5),
            back(0.5, 1.9, -4.0),
            back(0.6, 2.3, -4.0),
        ] {
            assert_eq!(
                kink(&space, Sense::Min, x, std::slice::from_ref(&n)),
                None,
                "{n:?}"
            );
        }
        // A point that is first-order optimal has no kink to report.
        let flat = [OneSided::both(0.0), OneSided::both(0.0)];
        let y = ([0.55, 0.5].as_slice(), 2.0, flat.as_slice());
        assert_eq!(kink(&space, Sense::Min, y, &[back(0.5, 2.3, -4.0)]), None);
    }

    #[test]
    fn proves_vertices_and_interior_points_and_refuses_the_rest() {
        // Φ = 3 p0 − p2 on p0 ∈ [0, 2], p1 fixed, p2 ∈ [1, 5]: max at (2, ·, 1), Φ = 5.
        let space = Space::new(&[[0.0, 2.0], [4.0, 4.0], [1.0, 5.0]]).unwrap();
        let slopes = [
            OneSided::both(3.0),
            OneSided::both(0.0),
            OneSided::both(-1.0),
        ];
        let max = certify(&space, Sense::Max, &[1.0, 0.0], 5.0, Some(&slopes));
        assert_eq!(max.verdict, Verdict::LocallyCertified);
        assert_eq!(max.residual, Some(0.0));
        assert_eq!(
            max.active,
            vec![
                BoundProof {
                    parameter: 0,
                    bound: ActiveBound::Upper,
                    rate: -3.0 * 2.0 / 5.0
                },
                BoundProof {
                    parameter: 2,
                    bound: ActiveBound::Lower,
                    rate: -4.0 / 5.0
                }
            ]
        );
        // The same point is the worst place for a minimum: moving p0 down lowers Φ by 6 / 5.
        let min = certify(&space, Sense::Min, &[1.0, 0.0], 5.0, Some(&slopes));
        assert_eq!(min.verdict, Verdict::NotOptimal);
        assert!((min.residual.unwrap() - 6.0 / 5.0).abs() < 1e-15);
        // Interior: certified only where both one-sided slopes vanish, or at a concave kink.
        let flat = [
            OneSided::both(1e-9),
            OneSided::both(0.0),
            OneSided::both(0.0),
        ];
        let kink = [
            OneSided {
                right: -1.0,
                left: 1.0,
            },
            OneSided::both(0.0),
            OneSided::both(0.0),
        ];
        for s in [&flat, &kink] {
            let c = certify(&space, Sense::Max, &[0.5, 0.5], 1.0, Some(s));
            assert_eq!(c.verdict, Verdict::LocallyCertified);
            assert!(c.active.is_empty());
        }
        let convex_kink = kink.map(|s| s.scaled(-1.0));
        let c = certify(&space, Sense::Max, &[0.5, 0.5], 1.0, Some(&convex_kink));
        assert_eq!(c.verdict, Verdict::NotOptimal);
        let none = certify(&space, Sense::Max, &[0.5, 0.5], 1.0, None);
        assert_eq!(none.verdict, Verdict::NoDerivatives);
    }
}
