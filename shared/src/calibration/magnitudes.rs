//! The calibration's magnitude policy: the bounds a calibration's values must
//! keep to be accepted as a correction ([`Calibration::check_magnitudes`]). The
//! controller refuses a calibration beyond them
//! ([`crate::link::check_magnitudes`], sent as a
//! [`Rejection`](crate::link::Rejection)), keeping the one in force.
//!
//! Units: identified errors rad or m; compliance rad/(N·m) or m/N; gear
//! harmonics and half the lost motion rad or m; the thermal coefficient 1/°C
//! and its reference temperature °C; the encoder-scale error relative. Every
//! bound is on the magnitude, in `f64` as the file holds them; a value that is
//! not finite is beyond every bound.

use super::Calibration;
use crate::MAX_JOINTS;
use crate::effects::Effect;

/// Identified errors larger than this (rad) are refused by
/// [`Calibration::check_magnitudes`]: a real robot that far from its nominal
/// model needs a new nominal model, not a correction.
pub const MAX_ERROR_ANGLE: f64 = 0.5;

/// Identified errors larger than this (m) are refused by
/// [`Calibration::check_magnitudes`].
pub const MAX_ERROR_LENGTH: f64 = 0.5;

/// Effect parameters at or above these are refused by
/// [`Calibration::check_magnitudes`], as beyond what a real arm shows (a diagnosis that found them found something
/// else): compliance, rad/(N·m) or m/N (also with the proxy torques of a model
/// without masses, a few times 10 N·m); gear-harmonic amplitudes and half the
/// lost motion, rad or m; the thermal coefficient, 1/°C (metals: 1–3 · 10⁻⁵), and
/// its reference temperature, °C; the encoder-scale error, relative.
pub const MAX_COMPLIANCE: f64 = 1e-3;
/// See [`MAX_COMPLIANCE`].
pub const MAX_EFFECT_ANGLE: f64 = 0.05;
/// See [`MAX_COMPLIANCE`].
pub const MAX_EXPANSION: f64 = 1e-3;
/// See [`MAX_COMPLIANCE`].
pub const MAX_REFERENCE_TEMPERATURE: f64 = 200.0;
/// See [`MAX_COMPLIANCE`].
pub const MAX_SCALE_ERROR: f64 = 0.01;

/// Which bound a calibration exceeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MagnitudeError {
    /// An identified error at or above [`MAX_ERROR_ANGLE`] or
    /// [`MAX_ERROR_LENGTH`], or not finite (or more joints than
    /// [`MAX_JOINTS`]).
    ErrorTooLarge,
    /// An effect parameter at or beyond its bound ([`MAX_COMPLIANCE`] and the
    /// others), or not finite.
    EffectTooLarge,
}

impl Calibration {
    /// Refuses a calibration whose identified errors are too large for a
    /// correction: above [`MAX_ERROR_ANGLE`] (rad) or [`MAX_ERROR_LENGTH`] (m);
    /// or whose effect parameters are beyond their bounds ([`MAX_COMPLIANCE`]
    /// and the others). (Its joint count is at most [`MAX_JOINTS`] by
    /// construction.)
    pub fn check_magnitudes(&self) -> Result<(), MagnitudeError> {
        let too_large = self.errors.iter().any(|e| {
            let max = if e.param.is_angle() {
                MAX_ERROR_ANGLE
            } else {
                MAX_ERROR_LENGTH
            };
            !e.error.is_finite() || e.error.abs() >= max
        });
        if too_large || self.nominal.dof() > MAX_JOINTS {
            return Err(MagnitudeError::ErrorTooLarge);
        }
        for e in &self.effects {
            // At or beyond the bound, or NaN.
            let beyond =
                |x: f64, max: f64| x.abs().partial_cmp(&max) != Some(core::cmp::Ordering::Less);
            let refused = match *e {
                Effect::JointCompliance { compliance, .. } => beyond(compliance, MAX_COMPLIANCE),
                Effect::GearTransmission { first, second, .. } => first
                    .iter()
                    .chain(&second)
                    .any(|a| beyond(*a, MAX_EFFECT_ANGLE)),
                Effect::Backlash {
                    half_lost_motion, ..
                } => beyond(half_lost_motion, MAX_EFFECT_ANGLE),
                Effect::ThermalExpansion {
                    coefficient,
                    reference,
                } => {
                    beyond(coefficient, MAX_EXPANSION)
                        || beyond(reference, MAX_REFERENCE_TEMPERATURE)
                }
                Effect::EncoderScale { scale, .. } => beyond(scale, MAX_SCALE_ERROR),
            };
            if refused {
                return Err(MagnitudeError::EffectTooLarge);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::fixtures::calibration;
    use crate::effects::one_of_each;

    /// Effect parameters at their bounds (or not finite) are refused, below them accepted.
    #[test]
    fn effect_magnitude_bounds() {
        let mut cal = calibration();
        for e in one_of_each() {
            cal.effects.push(e).unwrap();
        }
        assert_eq!(cal.check_magnitudes(), Ok(()));
        let bounds = [
            MAX_COMPLIANCE,
            MAX_EFFECT_ANGLE,
            MAX_EFFECT_ANGLE,
            MAX_EXPANSION,
            MAX_SCALE_ERROR,
        ];
        for (i, max) in bounds.into_iter().enumerate() {
            for (value, ok) in [(0.99 * max, true), (-max, false), (f64::NAN, false)] {
                let mut bad = cal.clone();
                *bad.effects[i].parameter_mut(0).unwrap() = value;
                let want = if ok {
                    Ok(())
                } else {
                    Err(MagnitudeError::EffectTooLarge)
                };
                assert_eq!(bad.check_magnitudes(), want, "{:?}", bad.effects[i]);
            }
        }
        let mut bad = cal.clone();
        bad.effects[3] = Effect::ThermalExpansion {
            coefficient: 2.3e-5,
            reference: MAX_REFERENCE_TEMPERATURE,
        };
        assert_eq!(bad.check_magnitudes(), Err(MagnitudeError::EffectTooLarge));
    }

    /// Identified errors at the bounds are refused, just below them accepted.
    #[test]
    fn magnitude_bounds() {
        let mut cal = calibration();
        cal.errors[0].error = 0.499;
        cal.errors[1].error = -0.499;
        assert_eq!(cal.check_magnitudes(), Ok(()));
        cal.errors[0].error = -0.5;
        assert_eq!(cal.check_magnitudes(), Err(MagnitudeError::ErrorTooLarge));
        cal.errors[0].error = f64::NAN;
        assert_eq!(cal.check_magnitudes(), Err(MagnitudeError::ErrorTooLarge));
    }
}
