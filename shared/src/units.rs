//! The units of a model file and of every data file read against it.
//!
//! `docs/file-formats.md` §1: `length_unit` is `"m"`, `"mm"` or `"in"` (25.4 mm exactly),
//! `angle_unit` is `"rad"` or `"deg"`; every length and angle of the model file and
//! of its data files is in these units. Inside armcal everything is SI (m, rad);
//! these types convert on the way in and out. They live in the shared crate
//! because the calibration file records them, so that a calibration's results are
//! reported in the units its model was written in.

use core::fmt;

use serde::{Deserialize, Serialize};

use crate::JointType;

/// The length unit of a model file and of its data files (`length_unit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LengthUnit {
    /// Metre (`"m"`).
    M,
    /// Millimetre (`"mm"`).
    Mm,
    /// Inch (`"in"`), 25.4 mm exactly.
    In,
}

impl LengthUnit {
    /// Every length unit, in the order the error messages list them.
    pub const ALL: [Self; 3] = [Self::M, Self::Mm, Self::In];

    /// The unit as written in the file: `"m"`, `"mm"` or `"in"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::M => "m",
            Self::Mm => "mm",
            Self::In => "in",
        }
    }

    /// The unit written as `name` in a file, if it is one.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|u| u.name() == name)
    }

    /// A length in this unit, in metres.
    pub fn to_si(self, x: f64) -> f64 {
        match self {
            Self::M => x,
            Self::Mm => x / 1000.0,
            Self::In => x * 0.0254,
        }
    }

    /// A length in metres, in this unit.
    pub fn from_si(self, x: f64) -> f64 {
        match self {
            Self::M => x,
            Self::Mm => x * 1000.0,
            Self::In => x / 0.0254,
        }
    }
}

impl fmt::Display for LengthUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The angle unit of a model file and of its data files (`angle_unit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum AngleUnit {
    /// Radian (`"rad"`).
    Rad,
    /// Degree (`"deg"`).
    Deg,
}

impl AngleUnit {
    /// Every angle unit, in the order the error messages list them.
    pub const ALL: [Self; 2] = [Self::Rad, Self::Deg];

    /// The unit as written in the file: `"rad"` or `"deg"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rad => "rad",
            Self::Deg => "deg",
        }
    }

    /// The unit written as `name` in a file, if it is one.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|u| u.name() == name)
    }

    /// An angle in this unit, in radians.
    pub fn to_si(self, x: f64) -> f64 {
        match self {
            Self::Rad => x,
            Self::Deg => x.to_radians(),
        }
    }

    /// An angle in radians, in this unit.
    pub fn from_si(self, x: f64) -> f64 {
        match self {
            Self::Rad => x,
            Self::Deg => x.to_degrees(),
        }
    }
}

impl fmt::Display for AngleUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The units of a model file and of every data file read against it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Units {
    /// Unit of every length (D-H `s`, `a`, frame `xyz`, `com`, measured `x, y, z`,
    /// prismatic joint readings).
    pub length: LengthUnit,
    /// Unit of every angle (D-H `theta`, `alpha`, frame `rpy`, revolute joint readings).
    pub angle: AngleUnit,
}

impl Units {
    /// Metres and radians.
    pub const SI: Self = Self {
        length: LengthUnit::M,
        angle: AngleUnit::Rad,
    };

    /// A length in these units, in metres.
    pub fn length_to_si(&self, x: f64) -> f64 {
        self.length.to_si(x)
    }

    /// A length in metres, in these units.
    pub fn length_from_si(&self, x: f64) -> f64 {
        self.length.from_si(x)
    }

    /// An angle in these units, in radians.
    pub fn angle_to_si(&self, x: f64) -> f64 {
        self.angle.to_si(x)
    }

    /// An angle in radians, in these units.
    pub fn angle_from_si(&self, x: f64) -> f64 {
        self.angle.from_si(x)
    }

    /// A joint reading (or limit) in these units, in SI: an angle for a revolute
    /// joint, a length for a prismatic one.
    pub fn joint_to_si(&self, joint: JointType, q: f64) -> f64 {
        match joint {
            JointType::Revolute => self.angle_to_si(q),
            JointType::Prismatic => self.length_to_si(q),
        }
    }

    /// A joint value in SI (rad or m), in these units.
    pub fn joint_from_si(&self, joint: JointType, q: f64) -> f64 {
        match joint {
            JointType::Revolute => self.angle_from_si(q),
            JointType::Prismatic => self.length_from_si(q),
        }
    }

    /// The name of the unit of a joint's readings: the angle unit for a revolute
    /// joint, the length unit for a prismatic one.
    pub fn joint_unit(&self, joint: JointType) -> &'static str {
        match joint {
            JointType::Revolute => self.angle.name(),
            JointType::Prismatic => self.length.name(),
        }
    }
}

impl Default for Units {
    fn default() -> Self {
        Self::SI
    }
}

impl fmt::Display for Units {
    /// `"mm, deg"`: the length unit, then the angle unit, as in the file.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}, {}", self.length, self.angle)
    }
}
