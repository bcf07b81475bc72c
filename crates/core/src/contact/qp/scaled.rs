//! The QP in scaled variables: `x = S y` with `S = diag(C)^{-1/2}` (unit diagonal of `S C S`),
//! and rows of `G S` normalised to unit length (`α = α̃ / n_r`).

use faer::Mat;

use super::{BoxQp, ProblemRef, WarmStart};

pub(super) struct Scaled {
    pub c: Mat<f64>,
    pub d: Vec<f64>,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    pub g: Mat<f64>,
    pub e: Vec<f64>,
    /// `x_i = s_i y_i`.
    pub s: Vec<f64>,
    /// Row norms of `G S` (1 for zero rows): `α_r = α̃_r / n_r`.
    pub n: Vec<f64>,
    /// Original bounds, so that variables on a bound unscale exactly onto it.
    orig_lo: Vec<f64>,
    orig_hi: Vec<f64>,
}

impl Scaled {
    pub fn new(p: &BoxQp) -> Self {
        let m = p.dim();
        let k = p.n_equalities();
        let s = column_scales(p);
        let c = Mat::from_fn(m, m, |i, j| 0.5 * (p.c[(i, j)] + p.c[(j, i)]) * s[i] * s[j]);
        let mut g = Mat::from_fn(k, m, |r, j| p.g[(r, j)] * s[j]);
        let mut n = vec![1.0; k];
        for (r, nr) in n.iter_mut().enumerate() {
            let norm = (0..m).map(|j| g[(r, j)].powi(2)).sum::<f64>().sqrt();
            if norm > 0.0 {
                *nr = norm;
                for j in 0..m {
                    g[(r, j)] /= norm;
                }
            }
        }
        Self {
            c,
            d: (0..m).map(|i| p.d[i] * s[i]).collect(),
            lo: (0..m).map(|i| p.lower[i] / s[i]).collect(),
            hi: (0..m).map(|i| p.upper[i] / s[i]).collect(),
            g,
            e: (0..k).map(|r| p.e[r] / n[r]).collect(),
            s,
            n,
            orig_lo: p.lower.clone(),
            orig_hi: p.upper.clone(),
        }
    }

    pub fn dim(&self) -> usize {
        self.d.len()
    }

    pub fn n_equalities(&self) -> usize {
        self.e.len()
    }

    pub fn view(&self) -> ProblemRef<'_> {
        ProblemRef {
            c: self.c.as_ref(),
            d: &self.d,
            lo: &self.lo,
            hi: &self.hi,
            g: self.g.as_ref(),
            e: &self.e,
        }
    }

    /// Scaled starting point: the warm start projected on the box, or the projection of 0.
    pub fn start(&self, warm: Option<&WarmStart>) -> (Vec<f64>, Vec<f64>) {
        let m = self.dim();
        let k = self.n_equalities();
        let mut y: Vec<f64> = match warm {
            Some(w) => (0..m).map(|i| w.x[i] / self.s[i]).collect(),
            None => vec![0.0; m],
        };
        self.project(&mut y);
        let alpha = match warm {
            Some(w) if w.alpha.len() == k => (0..k).map(|r| w.alpha[r] * self.n[r]).collect(),
            _ => vec![0.0; k],
        };
        (y, alpha)
    }

    pub fn project(&self, y: &mut [f64]) {
        for ((yi, lo), hi) in y.iter_mut().zip(&self.lo).zip(&self.hi) {
            *yi = yi.clamp(*lo, *hi);
        }
    }

    /// Original-space `(x, α)` from scaled `(y, α̃)`.
    pub fn unscale(&self, y: &[f64], alpha: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let x = (0..y.len())
            .map(|i| {
                if y[i] <= self.lo[i] {
                    self.orig_lo[i]
                } else if y[i] >= self.hi[i] {
                    self.orig_hi[i]
                } else {
                    (y[i] * self.s[i]).clamp(self.orig_lo[i], self.orig_hi[i])
                }
            })
            .collect();
        let a = alpha.iter().zip(&self.n).map(|(ai, ni)| ai / ni).collect();
        (x, a)
    }

    /// Original-space equality residual `G x − e` from the scaled one.
    pub fn unscale_equality(&self, r: &[f64]) -> Vec<f64> {
        r.iter().zip(&self.n).map(|(ri, ni)| ri * ni).collect()
    }
}

/// `s_i = C_ii^{-1/2}`; variables with a zero diagonal get the scale of the mean positive diagonal.
fn column_scales(p: &BoxQp) -> Vec<f64> {
    let m = p.dim();
    let diag: Vec<f64> = (0..m).map(|i| p.c[(i, i)]).collect();
    let positive: Vec<f64> = diag.iter().copied().filter(|&v| v > 0.0).collect();
    let fallback = if positive.is_empty() {
        1.0
    } else {
        positive.iter().sum::<f64>() / positive.len() as f64
    };
    diag.iter()
        .map(|&v| 1.0 / if v > 0.0 { v } else { fallback }.sqrt())
        .collect()
}
