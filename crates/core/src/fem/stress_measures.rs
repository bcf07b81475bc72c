//! Derived stress measures (design §5.6, the written fields; §4.2, the defined criteria): the symmetric tensor in
//! ParaView's component order, the von Mises stress and the principal stresses of a
//! plane-strain stress (τ11, τ22, τ12, τ33), τ33 = σ_zz being the out-of-plane stress, and the
//! stress quantities of the defined criteria with their gradients (design §4.2).

use crate::fem::stress::{i2_bilinear, i2_squared};
use crate::scene::DefinedQuantity;

/// The six components in ParaView's symmetric-tensor order (XX, YY, ZZ, XY, YZ, XZ);
/// YZ = XZ = 0 in plane strain.
pub fn tensor6([s11, s22, s12, s33]: [f64; 4]) -> [f64; 6] {
    [s11, s22, s33, s12, 0.0, 0.0]
}

/// The von Mises stress √(3/2 I2²) = √(½[(σ11−σ22)² + (σ22−σ33)² + (σ33−σ11)²] + 3σ12²)
/// \[Pa\], with I2² = τᴰ:τᴰ the invariant of the criterion Φ5 (design §4.2).
pub fn von_mises(stress: [f64; 4]) -> f64 {
    (1.5 * i2_squared(stress)).max(0.0).sqrt()
}

/// The principal stresses of a plane-strain stress and the direction of the first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Principal {
    /// The larger in-plane principal stress σ1 \[Pa\].
    pub sigma1: f64,
    /// The smaller in-plane principal stress σ2 ≤ σ1 \[Pa\].
    pub sigma2: f64,
    /// The out-of-plane principal stress σ3 = σ_zz \[Pa\] (not ordered against σ1, σ2).
    pub sigma3: f64,
    /// The unit direction (cos θ, sin θ, 0) of σ1, θ ∈ (−90°, 90°] from the x axis.
    pub direction: [f64; 3],
}

/// The principal stresses of (τ11, τ22, τ12, τ33): σ1,2 = c ± √(d² + τ12²) with
/// c = (τ11 + τ22)/2, d = (τ11 − τ22)/2, and θ = ½ atan2(τ12, d) the angle of σ1.
pub fn principal([s11, s22, s12, s33]: [f64; 4]) -> Principal {
    let centre = 0.5 * (s11 + s22);
    let half_difference = 0.5 * (s11 - s22);
    let radius = half_difference.hypot(s12);
    let theta = 0.5 * s12.atan2(half_difference);
    Principal {
        sigma1: centre + radius,
        sigma2: centre - radius,
        sigma3: s33,
        direction: [theta.cos(), theta.sin(), 0.0],
    }
}

/// The value of a stress quantity of (τ11, τ22, τ12, τ33) \[Pa\] (`None` for a contact
/// traction or a receiver's peak velocity, which are no functions of the stress).
pub fn stress_quantity(quantity: DefinedQuantity, stress: [f64; 4]) -> Option<f64> {
    Some(match quantity {
        DefinedQuantity::SigmaXx => stress[0],
        DefinedQuantity::SigmaYy => stress[1],
        DefinedQuantity::TauXy => stress[2],
        DefinedQuantity::SigmaZz => stress[3],
        DefinedQuantity::Sigma1 => principal(stress).sigma1,
        DefinedQuantity::Sigma2 => principal(stress).sigma2,
        DefinedQuantity::VonMises => von_mises(stress),
        DefinedQuantity::ContactPressure
        | DefinedQuantity::ContactShear
        | DefinedQuantity::PeakVelocity => return None,
    })
}

/// The gradient of [`stress_quantity`] with respect to (τ11, τ22, τ12, τ33) (design §4.2). With
/// c, d, R = √(d² + τ12²) of [`principal`]: ∂σ1,2 = (½ ± d/2R, ½ ∓ d/2R, ±τ12/R, 0), and the von
/// Mises stress s has ∂s = (3/2s) B(τ, ·) with B the bilinear form of I2². Where these are not
/// differentiable (σ1 = σ2, i.e. R = 0; s = 0) the gradient of the smooth part is taken:
/// (½, ½, 0, 0) for σ1 and σ2, 0 for s — the one-sided convention of the criteria's kinks.
/// `None` for a contact traction.
pub fn stress_quantity_gradient(quantity: DefinedQuantity, stress: [f64; 4]) -> Option<[f64; 4]> {
    let [s11, s22, s12, _] = stress;
    let principal_gradient = |sign: f64| {
        let half_difference = 0.5 * (s11 - s22);
        let radius = half_difference.hypot(s12);
        if radius > 0.0 {
            let a = sign * half_difference / (2.0 * radius);
            [0.5 + a, 0.5 - a, sign * s12 / radius, 0.0]
        } else {
            [0.5, 0.5, 0.0, 0.0]
        }
    };
    Some(match quantity {
        DefinedQuantity::SigmaXx => [1.0, 0.0, 0.0, 0.0],
        DefinedQuantity::SigmaYy => [0.0, 1.0, 0.0, 0.0],
        DefinedQuantity::TauXy => [0.0, 0.0, 1.0, 0.0],
        DefinedQuantity::SigmaZz => [0.0, 0.0, 0.0, 1.0],
        DefinedQuantity::Sigma1 => principal_gradient(1.0),
        DefinedQuantity::Sigma2 => principal_gradient(-1.0),
        DefinedQuantity::VonMises => {
            let s = von_mises(stress);
            if s > 0.0 {
                std::array::from_fn(|k| {
                    let unit = std::array::from_fn(|j| f64::from(u8::from(j == k)));
                    1.5 * i2_bilinear(stress, unit) / s
                })
            } else {
                [0.0; 4]
            }
        }
        DefinedQuantity::ContactPressure
        | DefinedQuantity::ContactShear
        | DefinedQuantity::PeakVelocity => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const STRESS: [f64; 4] = [50.0, -30.0, 30.0, 10.0];

    #[test]
    fn von_mises_of_a_known_stress() {
        // ½[(50+30)² + (−30−10)² + (10−50)²] + 3·30² = ½(6400+1600+1600) + 2700 = 7500.
        assert!((von_mises(STRESS) - 7500f64.sqrt()).abs() < 1e-12);
        // Uniaxial tension: von Mises is the tension itself.
        assert!((von_mises([7.0, 0.0, 0.0, 0.0]) - 7.0).abs() < 1e-12);
        // Hydrostatic: zero.
        assert!(von_mises([-3.0, -3.0, 0.0, -3.0]).abs() < 1e-12);
    }

    #[test]
    fn principal_stresses_of_a_known_stress() {
        // Mohr's circle: centre 10, radius √(40² + 30²) = 50; 2θ = atan2(30, 40).
        let p = principal(STRESS);
        assert!((p.sigma1 - 60.0).abs() < 1e-12 && (p.sigma2 + 40.0).abs() < 1e-12);
        assert_eq!(p.sigma3, 10.0);
        let theta = 0.5 * (0.75f64).atan();
        assert!((p.direction[0] - theta.cos()).abs() < 1e-12);
        assert!((p.direction[1] - theta.sin()).abs() < 1e-12);
        // σ1 acts along its direction: σ·d = σ1 d.
        let [c, s, _] = p.direction;
        assert!((STRESS[0] * c + STRESS[2] * s - p.sigma1 * c).abs() < 1e-12);
        assert!((STRESS[2] * c + STRESS[1] * s - p.sigma1 * s).abs() < 1e-12);
        // The von Mises stress of the principal stresses is the same.
        let diagonal = [p.sigma1, p.sigma2, 0.0, p.sigma3];
        assert!((von_mises(diagonal) - von_mises(STRESS)).abs() < 1e-9);
    }

    #[test]
    fn quantity_gradients_are_central_differences() {
        let all = [
            DefinedQuantity::SigmaXx,
            DefinedQuantity::SigmaYy,
            DefinedQuantity::TauXy,
            DefinedQuantity::SigmaZz,
            DefinedQuantity::Sigma1,
            DefinedQuantity::Sigma2,
            DefinedQuantity::VonMises,
        ];
        for q in all {
            let g = stress_quantity_gradient(q, STRESS).unwrap();
            for k in 0..4 {
                let h = 1e-4;
                let at = |t: f64| {
                    let mut s = STRESS;
                    s[k] += t;
                    stress_quantity(q, s).unwrap()
                };
                let fd = (at(h) - at(-h)) / (2.0 * h);
                assert!(
                    (g[k] - fd).abs() < 1e-8,
                    "{q:?} component {k}: {} vs {fd}",
                    g[k]
                );
            }
        }
        // σ1 = σ2: the smooth part.
        let round = [3.0, 3.0, 0.0, 1.0];
        assert_eq!(
            stress_quantity_gradient(DefinedQuantity::Sigma1, round),
            Some([0.5, 0.5, 0.0, 0.0])
        );
        assert_eq!(
            stress_quantity_gradient(DefinedQuantity::VonMises, [2.0, 2.0, 0.0, 2.0]),
            Some([0.0; 4])
        );
    }

    #[test]
    fn pure_shear_and_the_tensor_order() {
        let p = principal([0.0, 0.0, 5.0, 0.0]);
        assert!((p.sigma1 - 5.0).abs() < 1e-12 && (p.sigma2 + 5.0).abs() < 1e-12);
        let diagonal = std::f64::consts::FRAC_1_SQRT_2;
        assert!((p.direction[0] - diagonal).abs() < 1e-12);
        assert!((p.direction[1] - diagonal).abs() < 1e-12);
        assert_eq!(
            tensor6([1.0, 2.0, 3.0, 4.0]),
            [1.0, 2.0, 4.0, 3.0, 0.0, 0.0]
        );
    }
}
