//! The search space (design §4.1 box, §4.3): the unit box [0, 1]^k of the k free parameters and
//! its map onto the physical box, with the vertex and active-bound tests done in unit
//! coordinates so that every parameter is judged on its own range.

use super::{ActiveBound, SearchError};

/// Tolerance (unit box) for "on a bound" and "at a vertex".
pub(super) const BOUND_TOL: f64 = 1e-9;

pub(super) struct Space {
    bounds: Vec<[f64; 2]>,
    /// Indices of the parameters with lo < hi, in order.
    free: Vec<usize>,
}

impl Space {
    pub(super) fn new(bounds: &[[f64; 2]]) -> Result<Self, SearchError> {
        for (index, &[lo, hi]) in bounds.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(SearchError::InvalidBounds { index, lo, hi });
            }
        }
        let free = (0..bounds.len())
            .filter(|&i| bounds[i][0] < bounds[i][1])
            .collect();
        Ok(Space {
            bounds: bounds.to_vec(),
            free,
        })
    }

    /// Number of parameters (the dimension of the physical box).
    pub(super) fn len(&self) -> usize {
        self.bounds.len()
    }

    /// Number of free parameters (the dimension of the unit box).
    pub(super) fn dim(&self) -> usize {
        self.free.len()
    }

    /// Physical point of a unit-box point. Exact at the bounds (u = 0 gives lo, u = 1 gives hi
    /// bit for bit) and never outside [lo, hi].
    pub(super) fn to_physical(&self, unit: &[f64]) -> Vec<f64> {
        let mut point: Vec<f64> = self.bounds.iter().map(|b| b[0]).collect();
        for (&i, &u) in self.free.iter().zip(unit) {
            let [lo, hi] = self.bounds[i];
            let u = u.clamp(0.0, 1.0);
            point[i] = (lo * (1.0 - u) + hi * u).clamp(lo, hi);
        }
        point
    }

    /// Range hi − lo of the j-th free parameter and its index among all parameters.
    pub(super) fn free_param(&self, j: usize) -> (usize, f64) {
        let i = self.free[j];
        (i, self.bounds[i][1] - self.bounds[i][0])
    }

    /// Which bound each (physical) parameter is on at the unit point.
    pub(super) fn active_bounds(&self, unit: &[f64]) -> Vec<ActiveBound> {
        let mut active = vec![ActiveBound::Fixed; self.bounds.len()];
        for (&i, &u) in self.free.iter().zip(unit) {
            active[i] = if u <= BOUND_TOL {
                ActiveBound::Lower
            } else if u >= 1.0 - BOUND_TOL {
                ActiveBound::Upper
            } else {
                ActiveBound::None
            };
        }
        active
    }
}

/// Every coordinate within `BOUND_TOL` of 0 or 1.
pub(super) fn is_vertex(unit: &[f64]) -> bool {
    unit.iter().all(|&u| u <= BOUND_TOL || u >= 1.0 - BOUND_TOL)
}

/// Euclidean distance in the unit box.
pub(super) fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_exactly_at_bounds_and_skips_fixed() {
        let s = Space::new(&[[0.1, 0.7], [5.0, 5.0], [-3.0, 1e9]]).unwrap();
        assert_eq!(s.dim(), 2);
        assert_eq!(s.to_physical(&[0.0, 1.0]), vec![0.1, 5.0, 1e9]);
        assert_eq!(s.to_physical(&[1.0, 0.0]), vec![0.7, 5.0, -3.0]);
        let mid = s.to_physical(&[0.5, 0.5]);
        assert!((mid[0] - 0.4).abs() < 1e-15 && (mid[2] - (1e9 - 3.0) / 2.0).abs() < 1e-6);
        assert_eq!(
            s.active_bounds(&[0.0, 0.5]),
            vec![ActiveBound::Lower, ActiveBound::Fixed, ActiveBound::None]
        );
        assert_eq!(s.free_param(1), (2, 1e9 + 3.0));
    }

    #[test]
    fn rejects_bad_intervals() {
        assert_eq!(
            Space::new(&[[0.0, 1.0], [2.0, 1.0]]).err(),
            Some(SearchError::InvalidBounds {
                index: 1,
                lo: 2.0,
                hi: 1.0
            })
        );
        assert!(Space::new(&[[f64::NAN, 1.0]]).is_err());
        assert!(Space::new(&[[0.0, f64::INFINITY]]).is_err());
    }

    #[test]
    fn vertex_and_distance() {
        assert!(is_vertex(&[0.0, 1.0 - 1e-10]));
        assert!(!is_vertex(&[0.0, 0.5]));
        assert!(is_vertex(&[]));
        assert_eq!(distance(&[0.0, 0.0], &[0.3, 0.4]), 0.5);
    }
}
