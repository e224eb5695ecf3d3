//! The prior on the D-H parameter errors: the scale a real arm is built to,
//! as the model file's `[prior]` or the flags state it. What the fit does with
//! it is [`crate::calibration::fit::prior`]'s (the MAP estimate) and
//! [`crate::calibration::identify::prior_scale`]'s (the scale chosen on
//! held-out poses).
//!
//! Units: SI (m, rad).

use armcal_shared::Param;

/// The prior scales a cross-validation tries, as factors on the stated one
/// ([`crate::calibration::identify::prior_scale`],
/// [`crate::calibration::diagnose::geometry`]).
pub const PRIOR_FACTORS: [f64; 5] = [0.1, 0.3, 1.0, 3.0, 10.0];

/// The prior scale of the D-H parameter errors: one standard deviation, SI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    /// Of a length error (`s`, `a`), m.
    pub length: f64,
    /// Of an angle error (`θ`, `α`, `β`), rad.
    pub angle: f64,
}

impl Default for Prior {
    /// 1 mm and 1 mrad: the tolerances of an industrial arm's links and joints.
    fn default() -> Self {
        Self {
            length: 1e-3,
            angle: 1e-3,
        }
    }
}

impl Prior {
    /// No prior: ordinary (weighted) least squares.
    pub const NONE: Self = Self {
        length: f64::INFINITY,
        angle: f64::INFINITY,
    };

    /// Whether it holds any parameter: a finite length or angle scale (not
    /// [`Prior::NONE`], least squares).
    pub fn has_scale(&self) -> bool {
        self.length.is_finite() || self.angle.is_finite()
    }

    /// This prior with both scales multiplied by `factor`.
    pub fn scaled(self, factor: f64) -> Self {
        Self {
            length: self.length * factor,
            angle: self.angle * factor,
        }
    }

    /// The prior precision `1/τ²` of `param`'s error: 0 for the base and the tool.
    pub fn precision(&self, param: Param) -> f64 {
        let tau = match param {
            Param::Base(_) | Param::Tool(_) => return 0.0,
            p if p.is_angle() => self.angle,
            _ => self.length,
        };
        if tau.is_finite() && tau > 0.0 {
            1.0 / (tau * tau)
        } else {
            0.0
        }
    }
}
