//! The two integrators of M ü + C u̇ + K u = b(t) (design §3.5), written for any linear system
//! (the FEM operators, or one mode in the tests). State (u_n, v_n); each step solves
//! A u_{n+1} = F − BᵀΛ with A = M + a C + c K, contact multipliers Λ = s λ (λ the nodal contact
//! forces), and updates v.
//!
//! - **paper** (PDAS paper (10), read with the backward-difference velocity that its right-hand
//!   side implies, reference note B.4): ü ≈ (u_{n+1} − 2u_n + u_{n−1})/Δt², u̇ ≈ (u_{n+1} −
//!   u_n)/Δt, stiffness at t_{n+1}; multiplied by Δt²:
//!   (M + Δt C + Δt² K) u_{n+1} = Δt² b_{n+1} + M(2u_n − u_{n−1}) + Δt C u_n − Δt² Bᵀλ,
//!   with 2u_n − u_{n−1} = u_n + Δt v_n. So a = Δt, c = Δt², s = Δt². One undamped mode
//!   decays by |z| = (1 + ω²Δt²)^{−1/2} per step: unconditionally stable, first order,
//!   dissipative.
//! - **newmark** (average acceleration = trapezoidal rule): u_{n+1} − u_n = Δt (v_n + v_{n+1})/2,
//!   M(v_{n+1} − v_n) = Δt (b̄ − K ū − C (u_{n+1} − u_n)/Δt − Bᵀλ) with b̄, ū the step means and
//!   the contact force λ one impulse per step, complementary to the gap at t_{n+1}. Eliminating
//!   v_{n+1}: (M + Δt/2 C + Δt²/4 K) u_{n+1} = M(u_n + Δt v_n) + Δt/2 C u_n − Δt²/4 K u_n +
//!   Δt²/4 (b_n + b_{n+1}) − Δt²/2 Bᵀλ; a = Δt/2, c = Δt²/4, s = Δt²/2. Without contact it is
//!   Newmark (β, γ) = (¼, ½): second order, |z| = 1. Energy: testing the velocity equation with
//!   (v_n + v_{n+1})/2 gives E_{n+1} − E_n = Δuᵀ b̄ − Δt v̄ᵀ C v̄ − λᵀ B Δu exactly, and
//!   λᵀ B Δu ≥ 0 by complementarity at t_{n+1} (λ_n (g_n − g_{n+1}) = λ_n g_n ≥ 0) and by the
//!   friction bound on the slip increment: contact never adds energy.

use crate::scene::TimeScheme;

/// A linear second-order system: products with M, C and K.
pub trait SecondOrderSystem {
    /// M x.
    fn mass(&self, x: &[f64]) -> Vec<f64>;
    /// C x.
    fn damping(&self, x: &[f64]) -> Vec<f64>;
    /// K x.
    fn stiffness(&self, x: &[f64]) -> Vec<f64>;
}

/// The constants of one scheme at step Δt: A = M + a C + c K, Λ = s λ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepConstants {
    /// Factor of C in A.
    pub damping: f64,
    /// Factor of K in A.
    pub stiffness: f64,
    /// Λ = s λ: the step system's multipliers against the contact forces.
    pub force: f64,
}

/// The constants of `scheme` at step `dt`.
pub fn constants(scheme: TimeScheme, dt: f64) -> StepConstants {
    match scheme {
        TimeScheme::Paper => StepConstants {
            damping: dt,
            stiffness: dt * dt,
            force: dt * dt,
        },
        TimeScheme::Newmark => StepConstants {
            damping: dt / 2.0,
            stiffness: dt * dt / 4.0,
            force: dt * dt / 2.0,
        },
    }
}

/// The step's right-hand side F (before contact) from the state (u_n, v_n) and the loads
/// b_n, b_{n+1}.
pub fn rhs(
    scheme: TimeScheme,
    dt: f64,
    system: &impl SecondOrderSystem,
    u: &[f64],
    v: &[f64],
    b_now: &[f64],
    b_next: &[f64],
) -> Vec<f64> {
    let predicted: Vec<f64> = u.iter().zip(v).map(|(u, v)| u + dt * v).collect();
    let mut f = system.mass(&predicted);
    let cu = system.damping(u);
    match scheme {
        TimeScheme::Paper => {
            for i in 0..f.len() {
                f[i] += dt * cu[i] + dt * dt * b_next[i];
            }
        }
        TimeScheme::Newmark => {
            let ku = system.stiffness(u);
            let q = dt * dt / 4.0;
            for i in 0..f.len() {
                f[i] += dt / 2.0 * cu[i] - q * ku[i] + q * (b_now[i] + b_next[i]);
            }
        }
    }
    f
}

/// v_{n+1} from u_n, u_{n+1} and v_n.
pub fn velocity(scheme: TimeScheme, dt: f64, u: &[f64], u_next: &[f64], v: &[f64]) -> Vec<f64> {
    match scheme {
        TimeScheme::Paper => u.iter().zip(u_next).map(|(a, b)| (b - a) / dt).collect(),
        TimeScheme::Newmark => u
            .iter()
            .zip(u_next)
            .zip(v)
            .map(|((a, b), v)| 2.0 * (b - a) / dt - v)
            .collect(),
    }
}

/// The step's energy terms: (viscous dissipation, work of the loads f) over the step, with
/// the velocity the scheme's damping acts on (paper: v_{n+1}; newmark: Δu/Δt) and the load the
/// step applies (paper: f_{n+1}; newmark: (f_n + f_{n+1})/2).
pub fn step_energy(
    scheme: TimeScheme,
    dt: f64,
    system: &impl SecondOrderSystem,
    u: &[f64],
    u_next: &[f64],
    f_now: &[f64],
    f_next: &[f64],
) -> (f64, f64) {
    let rate: Vec<f64> = u.iter().zip(u_next).map(|(a, b)| (b - a) / dt).collect();
    let viscous = dt * dot(&rate, &system.damping(&rate));
    let work = match scheme {
        TimeScheme::Paper => dt * dot(&rate, f_next),
        TimeScheme::Newmark => {
            let mean: Vec<f64> = f_now
                .iter()
                .zip(f_next)
                .map(|(a, b)| 0.5 * (a + b))
                .collect();
            dt * dot(&rate, &mean)
        }
    };
    (viscous, work)
}

/// xᵀ y.
pub fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One undamped mode: M = 1, C = 0, K = ω².
    struct Mode(f64);

    impl SecondOrderSystem for Mode {
        fn mass(&self, x: &[f64]) -> Vec<f64> {
            x.to_vec()
        }
        fn damping(&self, x: &[f64]) -> Vec<f64> {
            vec![0.0; x.len()]
        }
        fn stiffness(&self, x: &[f64]) -> Vec<f64> {
            x.iter().map(|x| self.0 * self.0 * x).collect()
        }
    }

    /// One step of the free mode from (u, v).
    fn step(scheme: TimeScheme, dt: f64, omega: f64, u: f64, v: f64) -> (f64, f64) {
        let mode = Mode(omega);
        let k = constants(scheme, dt);
        let f = rhs(scheme, dt, &mode, &[u], &[v], &[0.0], &[0.0]);
        let u1 = f[0] / (1.0 + k.stiffness * omega * omega);
        (u1, velocity(scheme, dt, &[u], &[u1], &[v])[0])
    }

    /// |z| of the step map (u, v) ↦ (u', v') from its 2×2 matrix: √det for complex eigenvalues.
    fn amplification(scheme: TimeScheme, dt: f64, omega: f64) -> f64 {
        let (a, c) = step(scheme, dt, omega, 1.0, 0.0);
        let (b, d) = step(scheme, dt, omega, 0.0, 1.0);
        let (trace, det) = (a + d, a * d - b * c);
        assert!(trace * trace < 4.0 * det, "the mode oscillates");
        det.sqrt()
    }

    #[test]
    fn amplification_factors_are_the_schemes() {
        for (omega, dt) in [(1.0, 0.01), (10.0, 0.05), (1e3, 0.1), (2.0, 1.0)] {
            let paper = amplification(TimeScheme::Paper, dt, omega);
            let expected = (1.0 + (omega * dt).powi(2)).powf(-0.5);
            assert!(
                (paper - expected).abs() < 1e-13 * expected,
                "{paper} vs {expected}"
            );
            let newmark = amplification(TimeScheme::Newmark, dt, omega);
            assert!((newmark - 1.0).abs() < 1e-13, "newmark |z| = {newmark}");
        }
    }

    /// Newmark's period error is (ωΔt)²/12 relative: second order; the paper's first order
    /// in the amplitude.
    #[test]
    fn orders_of_the_single_mode() {
        let omega = 2.0 * std::f64::consts::PI;
        let error = |scheme, dt: f64| {
            let n = (1.0 / dt).round() as usize;
            let (mut u, mut v) = (1.0, 0.0);
            for _ in 0..n {
                (u, v) = step(scheme, dt, omega, u, v);
            }
            (u - 1.0_f64).abs() + (v / omega).abs()
        };
        for scheme in [TimeScheme::Paper, TimeScheme::Newmark] {
            let (e1, e2) = (error(scheme, 1e-3), error(scheme, 5e-4));
            let order = (e1 / e2).log2();
            let expected = if scheme == TimeScheme::Paper {
                1.0
            } else {
                2.0
            };
            assert!((order - expected).abs() < 0.05, "{scheme:?}: order {order}");
        }
    }
}
