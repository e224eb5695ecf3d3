//! The robot model a session is read against ([`RobotModel`]): its identity,
//! the units of its files (which are also those of its data files), the
//! nominal robot in SI (m, rad, kg, m/s²), the prior on its D-H parameter
//! errors and the joints whose link carries a tilt. [`crate::io::model_file`]
//! reads it from a model file, a URDF or a built-in name.

use armcal_shared::units::Units;
use armcal_shared::{Frame, Robot};

use crate::session::prior::Prior;

/// A robot model as read from a model file: its identity, its units and the
/// nominal robot in SI.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotModel {
    /// Short identifier (`name`, `[a-z0-9_-]+`).
    pub name: String,
    /// Free text (`description`; empty when the file has none).
    pub description: String,
    /// Where the model came from: the path as given, or `"built-in <name>"`.
    pub source: String,
    /// The units of the file, which are also those of its data files.
    pub units: Units,
    /// The nominal robot, SI (m, rad, kg, m/s²).
    pub robot: Robot<f64>,
    /// The prior scale of its D-H parameter errors (`[prior]`), SI; 1 mm and
    /// 1 mrad when the file gives none.
    pub prior: Prior,
    /// The joints (0-based) whose link carries Hayati's tilt `β` as a
    /// parameter of the model itself: a URDF's nearly parallel consecutive
    /// axes ([`crate::io::urdf::convert`]). `identify --params full` frees
    /// their `β`; a model file has none (`armcal diagnose` adds tilts as it
    /// finds them).
    pub tilted: Vec<usize>,
    /// The robot's flange in the last link's frame `M`, SI: the frame a
    /// working tool (`--tool`, `with_tool`) is given in. Identity for a model
    /// file, whose `[tool]` is in frame `M`; the tip link's frame for a URDF
    /// (before `--tip-point`); UR's flange (D-H frame 6) for a UR with its
    /// factory calibration.
    pub flange: Frame<f64>,
}

impl RobotModel {
    /// The number of joints, M.
    pub fn dof(&self) -> usize {
        self.robot.dof()
    }
}
