//! The units a report's values are in, as every JSON report states them
//! (`units`: `length`, `angle`; docs/file-formats.md §6, §7), and a frame
//! and a parameter's value given in them.

use armcal_shared::units::Units;
use armcal_shared::{Frame, Param};
use serde::Serialize;

/// The model file's units, which a report's values are in.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UnitsReport {
    /// `m`, `mm` or `in`.
    pub length: String,
    /// `rad` or `deg`.
    pub angle: String,
}

impl From<&Units> for UnitsReport {
    fn from(units: &Units) -> Self {
        Self {
            length: units.length.to_string(),
            angle: units.angle.to_string(),
        }
    }
}

impl UnitsReport {
    /// The units the report names.
    pub fn units(&self) -> Units {
        Units {
            length: armcal_shared::units::LengthUnit::from_name(&self.length)
                .expect("a report names the length unit of its model"),
            angle: armcal_shared::units::AngleUnit::from_name(&self.angle)
                .expect("a report names the angle unit of its model"),
        }
    }
}

/// A frame in a report: its shift and roll-pitch-yaw in the model's units.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameReport {
    /// Shift, the model's length unit.
    pub xyz: Vec<f64>,
    /// Roll, pitch, yaw, the model's angle unit.
    pub rpy: Vec<f64>,
}

impl FrameReport {
    /// `frame` (SI) in `units`.
    pub fn of(frame: &Frame<f64>, units: &Units) -> Self {
        Self {
            xyz: frame.xyz.iter().map(|x| units.length_from_si(*x)).collect(),
            rpy: frame.rpy.iter().map(|x| units.angle_from_si(*x)).collect(),
        }
    }
}

/// A parameter's value `si` (m or rad) in the model's unit of its kind:
/// its length unit, or its angle unit for an angle.
pub fn param_in_units(units: &Units, param: Param, si: f64) -> f64 {
    if param.is_angle() {
        units.angle_from_si(si)
    } else {
        units.length_from_si(si)
    }
}
