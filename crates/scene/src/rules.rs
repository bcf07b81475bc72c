//! Admissible values of the scene numbers with a sign or range rule (design §5.2, §4.1): the
//! single source of the material rules — E > 0, ν ∈ (−1, ½), λ ≥ 0, μ > 0 (positive definite
//! plane elasticity) and κ > 0 (heat conduction) — of the slip limit g ≥ 0 (Tresca, FGCS
//! 4.15) and of the friction coefficient F ∈ [0, 100] (Coulomb, design §3.4). Used by the validation of the nominal scene ([`super::validate`]) and by the
//! uncertain intervals ([`super::params`]), with the same wording.
//!
//! The rules also bound the magnitudes to what double precision can solve (design §5.2): the
//! stiffness, its Cholesky factor and the squared stresses of Φ5 must neither overflow nor sink
//! into subnormal numbers. Moduli (E, λ, μ) lie in [1e-3, 1e15] Pa (λ may be 0), loads
//! (pressure, traction, specific weight, body force) and slip limits in magnitude ≤ 1e15 (Pa or
//! N/m³), prescribed displacements ≤ 1e3 m, conductivities in [1e-9, 1e9] W/(m·K).
//!
//! A hydrostatic pressure's level y0 lies in [−1e6, 1e6] m and its unit weight γ in [0, 1e8]
//! N/m³ (design §2.6), so that γ (y0 − y) stays a load double precision solves.
//!
//! Depends on nothing else in the crate.

/// A scene number with a rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Constant {
    Young,
    Poisson,
    Lambda,
    Mu,
    /// A Poisson ratio ν_ij of an orthotropic material (its range follows from the moduli).
    OrthotropicPoisson,
    /// An entry of a plane-strain stiffness matrix.
    MatrixEntry,
    Conductivity,
    SlipLimit,
    /// The Coulomb friction coefficient F [-].
    FrictionCoefficient,
    /// A pressure, traction component, specific weight or body-force component.
    Load,
    /// A prescribed displacement component.
    Displacement,
    /// The orientation of an orthotropic material's axis 1 \[deg\].
    Angle,
    /// The level y0 of a hydrostatic pressure \[m\].
    Level,
    /// The unit weight γ of a hydrostatic pressure's liquid \[N/m³\].
    UnitWeight,
    /// A density ρ \[kg/m³\] of a dynamic scene.
    Density,
    /// A Kelvin–Voigt retardation time τ_v \[s\].
    Retardation,
    /// The damping α of an absorbing layer \[kg/(m³ s)\].
    Damping,
}

/// Largest modulus, load or slip limit \[Pa, N/m³\].
pub(crate) const MAX_STRESS: f64 = 1e15;
/// Smallest positive modulus \[Pa\].
pub(crate) const MIN_MODULUS: f64 = 1e-3;
/// Largest prescribed displacement \[m\].
const MAX_DISPLACEMENT: f64 = 1e3;
/// Largest orientation angle in magnitude \[deg\]: a full turn either way; beyond, the angle
/// is no orientation a user means (and 1e308° has no accurate sine).
pub(crate) const MAX_ANGLE: f64 = 360.0;
/// Largest friction coefficient [-] (measured coefficients are below 2; far beyond that the
/// Coulomb problem has no unique solution and the fixed point cannot converge).
pub(crate) const MAX_FRICTION: f64 = 100.0;
/// Largest level of a hydrostatic pressure in magnitude \[m\] (with [`MAX_UNIT_WEIGHT`] the
/// pressure stays within [`MAX_STRESS`] on any model within this distance of the origin).
pub(crate) const MAX_LEVEL: f64 = 1e6;
/// Largest unit weight of a liquid \[N/m³\] (mercury is 1.3e5).
pub(crate) const MAX_UNIT_WEIGHT: f64 = 1e8;
/// Largest density \[kg/m³\] (osmium is 2.3e4; beyond, the mass swamps the stiffness).
const MAX_DENSITY: f64 = 1e8;
/// Largest retardation time \[s\].
const MAX_RETARDATION: f64 = 1e9;
/// Smallest conductivity \[W/(m K)\].
pub(crate) const MIN_CONDUCTIVITY: f64 = 1e-9;
/// Largest conductivity \[W/(m K)\].
pub(crate) const MAX_CONDUCTIVITY: f64 = 1e9;

impl Constant {
    /// Whether `v` is admissible (false for NaN).
    pub(crate) fn admits(self, v: f64) -> bool {
        match self {
            Constant::Young | Constant::Mu => (MIN_MODULUS..=MAX_STRESS).contains(&v),
            Constant::Lambda => v == 0.0 || (MIN_MODULUS..=MAX_STRESS).contains(&v),
            Constant::Conductivity => (MIN_CONDUCTIVITY..=MAX_CONDUCTIVITY).contains(&v),
            Constant::OrthotropicPoisson => v.is_finite(),
            Constant::MatrixEntry => v.abs() <= MAX_STRESS,
            Constant::SlipLimit => (0.0..=MAX_STRESS).contains(&v),
            Constant::FrictionCoefficient => (0.0..=MAX_FRICTION).contains(&v),
            Constant::Poisson => v > -1.0 && v < 0.5,
            Constant::Load => v.abs() <= MAX_STRESS,
            Constant::Displacement => v.abs() <= MAX_DISPLACEMENT,
            Constant::Angle => v.abs() <= MAX_ANGLE,
            Constant::Level => v.abs() <= MAX_LEVEL,
            Constant::UnitWeight => (0.0..=MAX_UNIT_WEIGHT).contains(&v),
            Constant::Density => v > 0.0 && v <= MAX_DENSITY,
            Constant::Retardation => (0.0..=MAX_RETARDATION).contains(&v),
            Constant::Damping => (0.0..=MAX_STRESS).contains(&v),
        }
    }

    /// The rule, as reported to the user.
    pub(crate) fn rule(self) -> &'static str {
        match self {
            Constant::Young => {
                "Young's modulus E must be > 0 and lie in [1e-3, 1e15] Pa (what double precision solves)"
            }
            Constant::Poisson => "Poisson's ratio nu must lie in (-1, 0.5)",
            Constant::Lambda => {
                "Lamé's lambda must be >= 0 and be 0 or lie in [1e-3, 1e15] Pa (what double precision solves)"
            }
            Constant::Mu => {
                "the shear modulus mu must be > 0 and lie in [1e-3, 1e15] Pa (what double precision solves)"
            }
            Constant::Conductivity => "the conductivity must be > 0 and lie in [1e-9, 1e9] W/(m K)",
            Constant::OrthotropicPoisson => "an orthotropic Poisson ratio must be a finite number",
            Constant::MatrixEntry => {
                "a stiffness-matrix entry must be at most 1e15 Pa in magnitude (what double precision solves)"
            }
            Constant::SlipLimit => "the slip limit must be >= 0 and at most 1e15 Pa",
            Constant::FrictionCoefficient => {
                "the friction coefficient must be >= 0 and at most 100 (dimensionless)"
            }
            Constant::Load => {
                "a load (pressure, traction, specific weight, body force) must be at most 1e15 in magnitude (Pa or N/m3)"
            }
            Constant::Displacement => "a prescribed displacement must be at most 1e3 m in magnitude",
            Constant::Angle => "the angle must lie in [-360, 360] degrees",
            Constant::Level => "the level of a hydrostatic pressure must lie in [-1e6, 1e6] m",
            Constant::UnitWeight => {
                "the unit weight of a hydrostatic pressure must be >= 0 and at most 1e8 N/m3 (water is 9810)"
            }
            Constant::Density => "the density must be > 0 and at most 1e8 kg/m3",
            Constant::Retardation => {
                "the retardation time (viscosity) must be >= 0 and at most 1e9 s"
            }
            Constant::Damping => {
                "the damping of an absorbing layer must be >= 0 and at most 1e15 kg/(m3 s)"
            }
        }
    }

    /// Check one value; the error is the rule.
    pub(crate) fn check(self, v: f64) -> Result<(), String> {
        if self.admits(v) {
            Ok(())
        } else {
            Err(self.rule().to_string())
        }
    }

    /// Check an interval [lo, hi] with lo ≤ hi: every admissible set is an interval, so its two
    /// ends decide.
    pub(crate) fn check_interval(self, lo: f64, hi: f64) -> Result<(), String> {
        if self.admits(lo) && self.admits(hi) {
            Ok(())
        } else {
            Err(format!("{} on the whole interval", self.rule()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_and_intervals_agree() {
        assert!(Constant::Young.check(1.0).is_ok() && Constant::Young.check(0.0).is_err());
        assert!(Constant::Lambda.check(0.0).is_ok() && Constant::Lambda.check(-1e-9).is_err());
        assert!(Constant::Poisson.check(0.3).is_ok() && Constant::Poisson.check(0.5).is_err());
        assert!(Constant::Poisson.check_interval(-0.5, 0.49).is_ok());
        assert!(Constant::Poisson.check_interval(0.2, 0.5).is_err());
        assert!(Constant::Mu.check(f64::NAN).is_err());
        assert!(Constant::FrictionCoefficient.check(0.0).is_ok());
        assert!(Constant::FrictionCoefficient.check(-0.1).is_err());
        assert!(Constant::FrictionCoefficient.check(f64::NAN).is_err());
        assert_eq!(
            Constant::SlipLimit.check_interval(-1.0, 1.0).unwrap_err(),
            "the slip limit must be >= 0 and at most 1e15 Pa on the whole interval"
        );
    }

    #[test]
    fn magnitudes_beyond_double_precision_are_refused() {
        for v in [1e308, 1e-300, 1e16, 1e-4] {
            assert!(Constant::Young.check(v).is_err(), "E = {v}");
            assert!(Constant::Mu.check(v).is_err(), "mu = {v}");
        }
        assert!(Constant::Young.check(1e-3).is_ok() && Constant::Young.check(1e15).is_ok());
        assert!(Constant::Lambda.check(0.0).is_ok() && Constant::Lambda.check(1e-300).is_err());
        assert!(Constant::Load.check(-1e15).is_ok() && Constant::Load.check(1e200).is_err());
        assert!(Constant::Displacement.check(0.025).is_ok());
        assert!(Constant::Displacement.check(1e4).is_err());
        assert!(Constant::Conductivity.check(1e10).is_err());
        assert!(Constant::Angle.check(-360.0).is_ok() && Constant::Angle.check(1e308).is_err());
        assert!(Constant::Angle.check(f64::NAN).is_err());
        assert!(Constant::Young.check_interval(1e9, 1e16).is_err());
    }
}
