//! The working tool a front end names, checked once: `--tool X,Y,Z[,RX,RY,RZ]`
//! or `--tool-link LINK` on the command line (`compensate`, `predict`,
//! `stream`, `export`), `Calibration.with_tool` and `with_tool_link` in
//! Python. What a calibration becomes with it is
//! [`crate::apply::working_tool`]'s.
//!
//! - A frame: `x, y, z` and optionally roll, pitch, yaw
//!   (`R = Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`) of the working tool in the
//!   robot's flange frame ([`Calibration::flange`]: frame `M` of a model file,
//!   as its `[tool]`; the tip link's frame of a URDF model; UR's flange of a
//!   UR read with its factory calibration), in the calibration's model
//!   units. A tool farther from the flange than the arm reaches is refused,
//!   naming the unit it would fit in (250 typed for 0.25 m).
//! - A URDF link: the working tool is that link's frame. The URDF is the one
//!   the calibration's model was read from, the chain from the same base link;
//!   the link must move rigidly with the calibration's last joint (checked at
//!   three configurations: its frame in the flange frame the same to 1e-9 m
//!   and rad). Its frame in the flange frame is the nominal chain's, read from
//!   the URDF: `F(q)⁻¹ · L(q)`, with `F` the calibration's nominal flange
//!   and `L` the link's frame, both in the model's base frame.

use armcal_shared::units::LengthUnit;
use armcal_shared::{Calibration, Frame, Robot};
use nalgebra::{IsometryMatrix3, Matrix3, Vector3};

use super::Front;
use crate::apply::working_tool::{ToolChange, WorkingTool};
use crate::io::model_file::load_model_with;
use crate::io::urdf::ChainSpec;
use crate::report::format::significant;
use crate::session::input_error::InputError;
use crate::session::measurements::reach;

/// How far the link's frame in the flange frame may move between
/// configurations and still be rigid with the last joint, m and rad: the
/// URDF's own rounding leaves 1e-13.
const RIGID: f64 = 1e-9;

/// The working tool as a front end named it.
#[derive(Clone, Debug, PartialEq)]
pub enum Tool {
    /// A frame in the flange frame, in the calibration's model units.
    Frame {
        /// `x, y, z`, model length unit.
        xyz: [f64; 3],
        /// Roll, pitch, yaw, model angle unit.
        rpy: [f64; 3],
    },
    /// A link of the URDF the calibration's model was read from.
    Link {
        /// The URDF.
        model: String,
        /// The chain's base link, as the calibration was read with (the root
        /// when `None`).
        base_link: Option<String>,
        /// The working tool's link.
        link: String,
    },
}

impl Tool {
    /// `cal` with this working tool ([`WorkingTool::apply`]); a link that is
    /// not in the URDF, or does not move with the calibration's last joint,
    /// is refused naming the argument as `front` calls it.
    pub fn apply(&self, front: Front, cal: &Calibration) -> Result<ToolChange, InputError> {
        let frame = match self {
            Self::Frame { xyz, rpy } => {
                require_within_reach(front, cal, xyz)?;
                Frame {
                    xyz: Vector3::from_fn(|i, _| cal.units.length_to_si(xyz[i])),
                    rpy: Vector3::from_fn(|i, _| cal.units.angle_to_si(rpy[i])),
                }
            }
            Self::Link {
                model,
                base_link,
                link,
            } => link_frame(front, cal, model, base_link, link)?,
        };
        Ok(WorkingTool { frame }.apply(cal))
    }
}

/// Refuses a working tool `xyz` (model units) farther from the flange than
/// the arm reaches ([`reach`] of the nominal arm without its tool): no tool
/// is longer than the arm that carries it, and such a number is a length in
/// another unit (250 typed for 0.25 m). The error names the units it would
/// fit in.
fn require_within_reach(front: Front, cal: &Calibration, xyz: &[f64; 3]) -> Result<(), InputError> {
    let arm = Robot {
        tool: Frame::identity(),
        ..cal.nominal.clone()
    };
    let reach = reach(&arm, std::iter::empty());
    let typed = Vector3::from(*xyz).norm();
    let unit = cal.units.length;
    if unit.to_si(typed) <= reach {
        return Ok(());
    }
    let fits: Vec<String> = LengthUnit::ALL
        .into_iter()
        .filter(|u| *u != unit && u.to_si(typed) <= reach)
        .map(|u| {
            format!(
                "in {} it would be {} {}",
                u.name(),
                unit.from_si(u.to_si(typed)),
                unit.name()
            )
        })
        .collect();
    Err(InputError::argument(
        front.flag("--tool"),
        format!(
            "the working tool is {} {} from the flange, farther than the arm reaches ({} {}): the tool is given in the model's length unit, {}{}",
            typed,
            unit.name(),
            significant(unit.from_si(reach)),
            unit.name(),
            unit.name(),
            if fits.is_empty() {
                String::new()
            } else {
                format!(" ({})", fits.join("; "))
            }
        ),
    ))
}

/// The frame of `link` of the URDF `model` in `cal`'s flange frame.
fn link_frame(
    front: Front,
    cal: &Calibration,
    model: &str,
    base_link: &Option<String>,
    link: &str,
) -> Result<Frame<f64>, InputError> {
    let flag = front.flag("--tool-link");
    let spec = ChainSpec {
        base_link: base_link.clone(),
        tip_link: Some(link.to_owned()),
        tip_point: None,
    };
    let chain = load_model_with(model, &spec).map_err(|mut e| {
        if e.file == "--tip-link" {
            e.file = flag.clone();
        }
        e
    })?;
    let refused = |why: String| InputError::argument(flag.clone(), why);
    if chain.dof() != cal.nominal.dof() {
        return Err(refused(format!(
            "{link} of {model} hangs on {} moving joints from the base, the calibration's model has {}: give a link carried by its last joint",
            chain.dof(),
            cal.nominal.dof()
        )));
    }
    let flange = Robot {
        tool: cal.flange,
        ..cal.nominal.clone()
    };
    let in_flange = |q: &[f64]| -> IsometryMatrix3<f64> {
        let f = flange.forward(q).expect("joint count checked");
        let l = chain.robot.forward(q).expect("joint count checked");
        f.inverse() * l
    };
    let at_zero = in_flange(&vec![0.0; flange.dof()]);
    for k in [1.0, -2.0] {
        let q: Vec<f64> = (0..flange.dof())
            .map(|j| 0.1 * k * (j + 1) as f64)
            .collect();
        let moved = at_zero.inverse() * in_flange(&q);
        // The rotation's matrix, not its angle: acos loses half the digits
        // near the identity.
        let turned = (moved.rotation.matrix() - Matrix3::identity()).norm();
        if moved.translation.vector.norm() > RIGID || turned > RIGID {
            return Err(refused(format!(
                "{link} of {model} does not move rigidly with the calibration's last joint: give the URDF and the base link the calibration was identified with, and a link carried by its last joint"
            )));
        }
    }
    let (roll, pitch, yaw) = at_zero.rotation.euler_angles();
    Ok(Frame {
        xyz: at_zero.translation.vector,
        rpy: Vector3::new(roll, pitch, yaw),
    })
}
