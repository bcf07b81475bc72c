//! Sensitivities at an optimum (design §4.3 item 4): S_i = ∂Φ/∂θ_i · (hi − lo) / |Φ|, the relative
//! change of Φ over the whole interval of θ_i, by a one-sided difference with the step 1e-3 of
//! the range pointing into the box (forward unless that leaves it).

use super::space::Space;

/// Difference step (unit box).
const STEP: f64 = 1e-3;

/// The k points at which one-sided differences are taken around the unit point `x`.
pub(super) fn steps(x: &[f64]) -> Vec<Vec<f64>> {
    (0..x.len())
        .map(|j| {
            let mut y = x.to_vec();
            y[j] = if x[j] + STEP <= 1.0 {
                x[j] + STEP
            } else {
                x[j] - STEP
            };
            y
        })
        .collect()
}

/// Per parameter of the physical box: S_i from Φ(x) = `value` and Φ at `steps(x)` (`values`);
/// `None` for fixed parameters, missing values, or Φ(x) = 0.
pub(super) fn normalised(
    space: &Space,
    x: &[f64],
    value: f64,
    values: &[Option<f64>],
) -> Vec<Option<f64>> {
    let mut s = vec![None; space.len()];
    if value == 0.0 {
        return s;
    }
    for (j, (y, v)) in steps(x).iter().zip(values).enumerate() {
        let (i, _) = space.free_param(j);
        // In unit coordinates dθ_i = du_j · (hi − lo), so the range cancels.
        s[i] = v.map(|v| (v - value) / (y[j] - x[j]) / value.abs());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_sided_into_the_box_and_normalised() {
        assert_eq!(
            steps(&[1.0, 0.5]),
            vec![vec![1.0 - STEP, 0.5], vec![1.0, 0.5 + STEP]]
        );
        // Φ = 2 p0 − p2 on p0 ∈ [0, 4], p1 fixed, p2 ∈ [1, 3]; at p = (4, 7, 2), Φ = 6.
        let space = Space::new(&[[0.0, 4.0], [7.0, 7.0], [1.0, 3.0]]).unwrap();
        let x = [1.0, 0.5];
        let phi = |u: &[f64]| {
            let p = space.to_physical(u);
            2.0 * p[0] - p[2]
        };
        let values: Vec<Option<f64>> = steps(&x).iter().map(|y| Some(phi(y))).collect();
        let s = normalised(&space, &x, phi(&x), &values);
        assert!((s[0].unwrap() - 2.0 * 4.0 / 6.0).abs() < 1e-9);
        assert_eq!(s[1], None);
        assert!((s[2].unwrap() + 2.0 / 6.0).abs() < 1e-9);
        assert_eq!(normalised(&space, &x, 0.0, &values), vec![None; 3]);
    }
}
