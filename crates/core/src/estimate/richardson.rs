//! Richardson extrapolation of a mesh sequence and observed orders of convergence.
//!
//! A quantity computed on meshes of size h_k is modelled as f(h) = f* + C h^p (the leading term
//! of the discretisation error; O(h) in energy and O(h²) in L² for P1, design §2.4). With
//! non-nested unstructured meshes the values also scatter around this model (by an amount that
//! itself shrinks like h), so instead of the three-level formula, which needs exact geometric
//! ratios and monotone data, the model is fitted by weighted least squares over all levels
//! (weights h_k^−2, the inverse variance of a scatter ∝ h): for each order p on a fine grid the
//! best (f*, C) is linear least squares, and the p with the smallest residual wins. Two numbers
//! say how far to trust f*: the scatter (weighted RMS residual) and the uncertainty, the largest
//! change of f* when one level is left out of the fit.

/// Orders searched by [`extrapolate`]. A sequence converging more slowly than h^½ cannot be
/// extrapolated meaningfully; a fit at either end of the range is flagged (`at_bound`).
pub const ORDER_RANGE: [f64; 2] = [0.5, 4.0];
const ORDER_STEP: f64 = 0.005;

/// The fitted limit of a sequence.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Extrapolation {
    /// f*, the estimated value on an infinitely fine mesh.
    pub value: f64,
    /// The fitted order p (`None` when the values do not change within rounding).
    pub order: Option<f64>,
    /// Weighted RMS of the fit residuals, relative to |f*|.
    pub scatter: f64,
    /// The largest change of f* when one level is left out, relative to |f*| (`None` with
    /// fewer than four levels).
    pub uncertainty: Option<f64>,
    /// The three finest values approach f* from one side in decreasing steps.
    pub monotone: bool,
    /// The fitted order is at an end of `ORDER_RANGE`: the model does not describe the data.
    pub at_bound: bool,
}

/// Fit f = f* + C h^p to values `f` on mesh sizes `h` (any order, any unit; at least three).
pub fn extrapolate(h: &[f64], f: &[f64]) -> Option<Extrapolation> {
    let n = h.len();
    if n < 3
        || f.len() != n
        || h.iter().chain(f).any(|x| !x.is_finite())
        || h.iter().any(|&x| x <= 0.0)
    {
        return None;
    }
    let scale = f.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let spread = f.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - f.iter().copied().fold(f64::INFINITY, f64::min);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| h[b].total_cmp(&h[a]));
    let last: Vec<f64> = order[n - 3..].iter().map(|&k| f[k]).collect();
    if spread <= 1e-13 * scale {
        return Some(Extrapolation {
            value: last[2],
            order: None,
            scatter: 0.0,
            uncertainty: Some(0.0),
            monotone: true,
            at_bound: false,
        });
    }
    let (residual, p, value) = fit(h, f)?;
    let magnitude = value.abs().max(f64::MIN_POSITIVE);
    let uncertainty = (n >= 4).then(|| {
        (0..n)
            .filter_map(|skip| {
                let (hs, fs): (Vec<f64>, Vec<f64>) =
                    (0..n).filter(|&k| k != skip).map(|k| (h[k], f[k])).unzip();
                fit(&hs, &fs).map(|(_, _, v)| (v - value).abs() / magnitude)
            })
            .fold(0.0, f64::max)
    });
    let (d1, d2) = (last[1] - last[0], last[2] - last[1]);
    let monotone = d1 * d2 > 0.0 && d2.abs() < d1.abs() && (value - last[2]) * d2 >= 0.0;
    Some(Extrapolation {
        value,
        order: Some(p),
        scatter: residual / magnitude,
        uncertainty,
        monotone,
        at_bound: p <= ORDER_RANGE[0] + 0.5 * ORDER_STEP || p >= ORDER_RANGE[1] - 0.5 * ORDER_STEP,
    })
}

/// The weighted least-squares fit over the order grid: (weighted RMS residual, p, f*).
fn fit(h: &[f64], f: &[f64]) -> Option<(f64, f64, f64)> {
    let h_max = h.iter().copied().fold(0.0, f64::max);
    let weights: Vec<f64> = h.iter().map(|&hk| (h_max / hk).powi(2)).collect();
    let total: f64 = weights.iter().sum();
    let steps = ((ORDER_RANGE[1] - ORDER_RANGE[0]) / ORDER_STEP).round() as usize;
    let mut best: Option<(f64, f64, f64)> = None;
    for s in 0..=steps {
        let p = ORDER_RANGE[0] + s as f64 * ORDER_STEP;
        let x: Vec<f64> = h.iter().map(|&hk| (hk / h_max).powf(p)).collect();
        let Some((f_star, c)) = line_fit(&x, f, &weights) else {
            continue;
        };
        let r2: f64 = x
            .iter()
            .zip(f)
            .zip(&weights)
            .map(|((xk, fk), w)| w * (f_star + c * xk - fk).powi(2))
            .sum();
        if best.is_none_or(|(b, _, _)| r2 < b) {
            best = Some((r2, p, f_star));
        }
    }
    best.map(|(r2, p, v)| ((r2 / total).sqrt(), p, v))
}

/// Weighted least-squares (a, b) of f ≈ a + b x.
fn line_fit(x: &[f64], f: &[f64], w: &[f64]) -> Option<(f64, f64)> {
    let total: f64 = w.iter().sum();
    let mx = x.iter().zip(w).map(|(v, wk)| wk * v).sum::<f64>() / total;
    let mf = f.iter().zip(w).map(|(v, wk)| wk * v).sum::<f64>() / total;
    let sxx: f64 = x.iter().zip(w).map(|(v, wk)| wk * (v - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxf: f64 = x
        .iter()
        .zip(f)
        .zip(w)
        .map(|((v, fv), wk)| wk * (v - mx) * (fv - mf))
        .sum();
    let b = sxf / sxx;
    Some((mf - b * mx, b))
}

/// The observed order of errors `e` on mesh sizes `h`: the least-squares slope of ln e against
/// ln h (`None` with fewer than two positive errors).
pub fn observed_order(h: &[f64], e: &[f64]) -> Option<f64> {
    let (x, y): (Vec<f64>, Vec<f64>) = h
        .iter()
        .zip(e)
        .filter(|(hk, ek)| **hk > 0.0 && **ek > 0.0 && ek.is_finite())
        .map(|(hk, ek)| (hk.ln(), ek.ln()))
        .unzip();
    if x.len() < 2 {
        return None;
    }
    line_fit(&x, &y, &vec![1.0; x.len()]).map(|(_, slope)| slope)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_power_laws_are_recovered() {
        let h = [0.4, 0.28, 0.2, 0.14, 0.1];
        for p in [1.0, 1.5, 2.0] {
            let f: Vec<f64> = h.iter().map(|x: &f64| 3.0 - 0.7 * x.powf(p)).collect();
            let e = extrapolate(&h, &f).unwrap();
            assert!((e.value - 3.0).abs() < 1e-3, "{e:?}");
            assert!((e.order.unwrap() - p).abs() < 0.02, "{e:?}");
            assert!(
                e.monotone && e.scatter < 1e-4 && e.uncertainty.unwrap() < 1e-3,
                "{e:?}"
            );
            let errors: Vec<f64> = f.iter().map(|v| (v - 3.0).abs()).collect();
            assert!((observed_order(&h, &errors).unwrap() - p).abs() < 1e-9);
        }
    }

    #[test]
    fn noise_shows_as_scatter_and_constant_data_has_no_order() {
        let h = [0.4, 0.28, 0.2, 0.14, 0.1];
        let noise = [5e-3, -5e-3, 5e-3, -5e-3, 5e-3];
        let f: Vec<f64> = h.iter().zip(noise).map(|(x, d)| 1.0 + x * x + d).collect();
        let e = extrapolate(&h, &f).unwrap();
        assert!(e.scatter > 1e-4 && !e.monotone, "{e:?}");
        assert!(e.uncertainty.unwrap() > 1e-4, "{e:?}");
        let flat = extrapolate(&h, &[2.0; 5]).unwrap();
        assert_eq!((flat.value, flat.order), (2.0, None));
        assert!(extrapolate(&h[..2], &f[..2]).is_none());
        assert!(extrapolate(&h, &[1.0, f64::NAN, 1.0, 1.0, 1.0]).is_none());
    }
}
