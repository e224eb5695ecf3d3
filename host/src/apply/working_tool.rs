//! The working tool: the tool a calibrated robot works with, in place of the
//! tool it was measured with (an SMR, a ball in a socket, a camera target).
//!
//! ## What a calibration knows of its flange
//! The measured frame is `base · A_1(q_1) ⋯ A_M(q_M) · tool`. The parameters
//! that act after the last joint's motion move the measured tool rigidly with
//! the flange, exactly as a change of `tool` does, whatever the joints read:
//!
//! | convention | parameters rigid with the tool (joint `M` the last) |
//! | --- | --- |
//! | `dh`, `A_M = Rot_z(θ) Trans_z(s) Trans_x(a) Rot_x(α) Rot_y(β)` | `θ_M`, `s_M`, `a_M`, `α_M`, `β_M` |
//! | `mdh`, `A_M = Rot_x(α) Trans_x(a) Rot_y(β) Rot_z(θ) Trans_z(s)` | `θ_M`, `s_M` |
//!
//! (`Rot_z(q + θ) = Rot_z(q) Rot_z(θ)`, and a rotation about z commutes with
//! `Trans_z`, for a prismatic last joint too.) With one measured tool, data of
//! any kind cannot tell these from the tool's own mount: the fit gives their
//! sum to the tool, whose frame is free ([`crate::calibration::identify`]), and
//! whatever share a parameter of them took is a split the data did not make.
//! Both are *the measured tool's offset*: they describe where that tool sat,
//! not the flange.
//!
//! ## What a working tool gets
//! [`WorkingTool::apply`] keeps everything the data separate from the tool
//! (the base, every joint axis up to and including the last one, the effects)
//! and replaces the measured tool by the working tool on the nominal flange:
//! the model's `tool` becomes the working tool's frame, and the identified
//! errors of `tool.*` and of the parameters above are dropped, in the
//! calibration and in its geometric fallback. The dropped errors are reported,
//! never applied to another tool. A flange whose real geometry differs from
//! nominal along those parameters reaches a working tool unresolved: a
//! flange tilt `δ` moves a tool point `L` from the flange by `δ·L`, and an
//! offset of the last joint's zero by `δ` moves a point `r` off its axis by
//! `δ·r`. Only a tool whose mount is known (or a second measured tool) can
//! separate them.
//!
//! A measured point on the last joint's axis (an SMR centred on the flange)
//! does not move when that joint turns: from positions alone the axis'
//! direction is then known only through the joints before it, and a working
//! tool further out or off the axis inherits that. The note says so below
//! [`NEAR_AXIS`] (not for a calibration from full poses: the orientations
//! show the last joint's turn).
//!
//! The expected held-out error of the file is the measured tool's; with
//! another tool it is unknown, and the calibration's `held_out` is cleared.
//!
//! Frames and units: the working tool is a frame in the robot's flange frame
//! ([`Calibration::flange`]: frame `M` of a model file, as its `[tool]`; the
//! tip link's frame of a URDF; UR's flange), SI here; the front ends read it
//! in the model's units ([`crate::commands::tool`]).

use armcal_shared::calibration::{Calibration, ParamError};
use armcal_shared::compensation::Task;
use armcal_shared::{Convention, Frame, JointType, Param, Robot};

use crate::io::urdf::convert::to_frame;

/// A measured point closer than this to a revolute last joint's axis, m, is
/// named in the note: turning the joint moves it by less than 1 mm per
/// 0.1 rad, a tracker's noise over a wrist's swing.
pub const NEAR_AXIS: f64 = 0.01;

/// The distance of `robot`'s measured point from its last joint's axis, m,
/// for a revolute last joint: from the chord the point travels when that
/// joint turns by half a radian from zero.
pub fn distance_from_last_axis(robot: &Robot<f64>) -> Option<f64> {
    let last = robot.links.last()?;
    if last.joint != JointType::Revolute {
        return None;
    }
    let mut q = vec![0.0; robot.dof()];
    let at_zero = robot.measured_point(&q).ok()?;
    let turn = 0.5_f64;
    *q.last_mut()? = turn;
    let turned = robot.measured_point(&q).ok()?;
    Some((turned - at_zero).norm() / (2.0 * (turn / 2.0).sin()))
}

/// The parameters of `robot` that act after its last joint's motion, rigidly
/// with the measured tool (the module header's table); empty for a robot
/// without joints.
pub fn flange_params(robot: &Robot<f64>) -> Vec<Param> {
    let Some(last) = robot.dof().checked_sub(1) else {
        return Vec::new();
    };
    match robot.convention {
        Convention::Dh => vec![
            Param::Theta(last),
            Param::S(last),
            Param::A(last),
            Param::Alpha(last),
            Param::Beta(last),
        ],
        Convention::Mdh => vec![Param::Theta(last), Param::S(last)],
    }
}

/// The tool a calibrated robot works with, in the flange frame, SI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkingTool {
    /// Its frame in the flange frame ([`Calibration::flange`]), m and rad.
    pub frame: Frame<f64>,
}

/// A calibration given a working tool, and what of the measured tool it left.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolChange {
    /// The calibration with the working tool on the nominal flange.
    pub calibration: Calibration,
    /// The working tool, SI.
    pub tool: WorkingTool,
    /// The measured tool's identified offset, not applied: the errors of
    /// `tool.*` and of the [`flange_params`] the calibration had.
    pub measured_offset: Vec<ParamError>,
    /// The parameters rigid with the measured tool ([`flange_params`]).
    pub confounded: Vec<Param>,
    /// The nominal measured point's distance from a revolute last joint's
    /// axis, m ([`distance_from_last_axis`]), for a calibration from
    /// positions alone.
    pub measured_from_axis: Option<f64>,
}

/// Whether `param` is the tool's or rigid with it.
fn of_measured_tool(param: Param, flange: &[Param]) -> bool {
    matches!(param, Param::Tool(_)) || flange.contains(&param)
}

impl WorkingTool {
    /// `cal` working with this tool (see the module header).
    pub fn apply(&self, cal: &Calibration) -> ToolChange {
        let confounded = flange_params(&cal.nominal);
        let measured_offset = cal
            .errors
            .iter()
            .filter(|e| of_measured_tool(e.param, &confounded))
            .copied()
            .collect();
        let mut calibration = cal.clone();
        // On the flange; the frame as given where the flange is the last
        // link's frame (no roll-pitch-yaw round trip of the user's numbers).
        calibration.nominal.tool = if cal.flange == Frame::identity() {
            self.frame
        } else {
            to_frame(&(cal.flange.isometry() * self.frame.isometry()))
        };
        calibration
            .errors
            .retain(|e| !of_measured_tool(e.param, &confounded));
        calibration.held_out = None;
        if let Some(g) = calibration.geometric.as_mut() {
            g.errors.retain(|e| !of_measured_tool(e.param, &confounded));
            g.held_out = None;
        }
        ToolChange {
            calibration,
            tool: *self,
            measured_offset,
            confounded,
            // Orientations measure the last axis' turn whatever the point.
            measured_from_axis: if cal.task == Task::Pose {
                None
            } else {
                distance_from_last_axis(&cal.nominal)
            },
        }
    }
}

impl ToolChange {
    /// What the change kept and dropped, for the user: the working tool, the
    /// measured tool's offset not applied (its position part's length), and
    /// which parameters a single measured tool leaves to the working tool's
    /// nominal flange. In the calibration's units.
    pub fn note(&self) -> String {
        let units = &self.calibration.units;
        // Nine decimals of the unit: 1 nm in m, nothing the URDF's rounding
        // left (1e-17) shown as a number.
        let value = |x: f64| format!("{}", (x * 1e9).round() / 1e9 + 0.0);
        let triple = |v: [f64; 3]| format!("({}, {}, {})", value(v[0]), value(v[1]), value(v[2]));
        let frame = &self.tool.frame;
        let mut note = format!(
            "working tool at {} {}, roll-pitch-yaw {} {} in the flange frame: it replaces the measured tool",
            triple(frame.xyz.map(|x| units.length_from_si(x)).into()),
            units.length.name(),
            triple(frame.rpy.map(|a| units.angle_from_si(a)).into()),
            units.angle.name(),
        );
        if self.measured_offset.is_empty() {
            note.push_str("; the calibration identified no offset of the measured tool");
        } else {
            let position = self
                .measured_offset
                .iter()
                .filter(|e| matches!(e.param, Param::Tool(ax) if !ax.is_angle()))
                .map(|e| e.error * e.error)
                .sum::<f64>()
                .sqrt();
            let names: Vec<String> = self
                .measured_offset
                .iter()
                .map(|e| e.param.to_string())
                .collect();
            note.push_str(&format!(
                "; the measured tool's identified offset ({}; {:.4} {} of position) is not applied to it",
                names.join(", "),
                units.length_from_si(position),
                units.length.name(),
            ));
        }
        // β is a parameter of a link only where the model or the calibration
        // gives it one.
        let has = |p: &Param| match p {
            Param::Beta(j) => {
                self.calibration.nominal.links[*j].beta != 0.0
                    || self.measured_offset.iter().any(|e| e.param == *p)
            }
            _ => true,
        };
        let confounded: Vec<Param> = self.confounded.iter().copied().filter(has).collect();
        if !confounded.is_empty() {
            let names: Vec<String> = confounded.iter().map(|p| p.to_string()).collect();
            let mut reach = Vec::new();
            if confounded.iter().any(|p| matches!(p, Param::Theta(_))) {
                reach
                    .push("a zero of the last joint off by δ moves a point r from its axis by δ·r");
            }
            if confounded
                .iter()
                .any(|p| matches!(p, Param::S(_) | Param::A(_)))
            {
                reach.push("a flange offset moves it by as much");
            }
            if confounded
                .iter()
                .any(|p| matches!(p, Param::Alpha(_) | Param::Beta(_)))
            {
                reach.push("a flange tilt δ moves a point L from the flange by δ·L");
            }
            note.push_str(&format!(
                ". {} move the measured tool rigidly with the flange: one measured tool cannot separate them from its mount, so the working tool sits on the nominal flange along them, and a flange error there reaches it unresolved ({})",
                names.join(", "),
                reach.join("; "),
            ));
        }
        if let Some(r) = self.measured_from_axis.filter(|&r| r < NEAR_AXIS) {
            note.push_str(&format!(
                ". The measured point was {:.4} {} from the last joint's axis: turning that joint hardly moved it, so the data know the axis' direction only through the joints before it, and a working tool far from the flange or off the axis inherits that (a measured tool off the axis separates it)",
                units.length_from_si(r),
                units.length.name(),
            ));
        }
        note.push_str(
            ". The calibration's expected held-out error was the measured tool's: for this tool it is unknown",
        );
        note
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use armcal_shared::FrameAxis;
    use armcal_shared::units::Units;
    use nalgebra::Vector3;

    fn puma560() -> Robot<f64> {
        crate::io::model_file::load_model("puma560").unwrap().robot
    }

    /// A calibration of `robot` whose errors are every parameter rigid with
    /// the tool, the tool's position, and one parameter the data separate.
    fn calibration(robot: Robot<f64>) -> Calibration {
        let mut cal = Calibration::nominal(robot, Task::Position, Units::SI);
        let separated = Param::Alpha(1);
        for (param, error) in flange_params(&cal.nominal)
            .into_iter()
            .chain(FrameAxis::ALL[..3].iter().map(|&ax| Param::Tool(ax)))
            .zip([1e-3, 2e-3, 3e-3, 4e-3, 5e-3, 6e-3, 7e-3, 8e-3])
            .chain([(separated, 0.5e-3)])
        {
            cal.errors.push(ParamError { param, error }).unwrap();
        }
        cal.held_out = Some(1e-4);
        cal
    }

    /// The working tool replaces the measured one: what the data separate
    /// stays, the measured tool's offset (the tool's errors and those rigid
    /// with it) goes, and the held-out figure of the measured tool with it.
    #[test]
    fn the_measured_tools_offset_is_not_applied_to_a_working_tool() {
        for robot in [puma560(), {
            let mut r = puma560();
            r.convention = Convention::Mdh;
            r
        }] {
            let cal = calibration(robot);
            let frame = Frame {
                xyz: Vector3::new(0.0, 0.0, 0.25),
                rpy: Vector3::new(0.0, 0.1, 0.0),
            };
            let change = WorkingTool { frame }.apply(&cal);
            assert_eq!(change.calibration.nominal.tool, frame);
            let kept: Vec<Param> = change.calibration.errors.iter().map(|e| e.param).collect();
            assert_eq!(kept, [Param::Alpha(1)]);
            assert_eq!(
                change.measured_offset.len(),
                flange_params(&cal.nominal).len() + 3
            );
            assert_eq!(change.calibration.held_out, None);
            // The calibrated model's working tool sits on the nominal flange
            // wherever the separated parameter leaves it.
            let mut expected = cal.nominal.clone();
            expected.tool = frame;
            *expected.param_mut(Param::Alpha(1)).unwrap() += 0.5e-3;
            assert_eq!(change.calibration.calibrated(), expected);
        }
    }

    /// Where the robot's flange is not its last link's frame (a URDF's
    /// `tool0`, 117 mm out along the last axis and turned about it), the
    /// working tool is given in the flange: its frame in the last link's is
    /// the flange's composed with it, to rounding.
    #[test]
    fn a_working_tool_is_given_in_the_robots_flange() {
        let mut cal = calibration(puma560());
        cal.flange = Frame {
            xyz: Vector3::new(0.0, 0.0, 0.11655),
            rpy: Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2),
        };
        let frame = Frame {
            xyz: Vector3::new(0.01, 0.0, 0.25),
            rpy: Vector3::new(0.0, 0.1, 0.0),
        };
        let tool = WorkingTool { frame }.apply(&cal).calibration.nominal.tool;
        let want = cal.flange.isometry() * frame.isometry();
        let got = tool.isometry();
        assert!((got.translation.vector - Vector3::new(0.0, 0.01, 0.36655)).norm() < 1e-15);
        assert!((got.to_homogeneous() - want.to_homogeneous()).amax() < 1e-15);
        // A tool at the flange's origin is the flange.
        let at_flange = WorkingTool {
            frame: Frame::identity(),
        }
        .apply(&cal);
        let f = at_flange.calibration.nominal.tool.isometry();
        assert!((f.to_homogeneous() - cal.flange.isometry().to_homogeneous()).amax() < 1e-15);
    }

    /// The distance from the last axis is the tool point's lever about it:
    /// an SMR 60 mm off the flange axis of a standard D-H wrist is 60 mm
    /// from it, one on the axis 0, and the note names the latter for a
    /// calibration from positions alone.
    #[test]
    fn a_measured_point_on_the_last_axis_is_named() {
        let mut robot = puma560();
        robot.tool = Frame {
            xyz: Vector3::new(0.06, 0.0, 0.08),
            rpy: Vector3::zeros(),
        };
        let off = distance_from_last_axis(&robot).unwrap();
        // The file's α6 = 3.141593 tilts the flange axis by 6.5e-7 rad.
        assert!((off - 0.06).abs() < 1e-6, "{off}");
        robot.tool.xyz = Vector3::new(0.0, 0.0, 0.1);
        let on = distance_from_last_axis(&robot).unwrap();
        assert!(on < 1e-6, "{on}");
        let frame = Frame::identity();
        let cal = Calibration::nominal(robot.clone(), Task::Position, Units::SI);
        let note = WorkingTool { frame }.apply(&cal).note();
        assert!(note.contains("from the last joint's axis"), "{note}");
        // Full poses show the last joint's turn through the orientations.
        let full = Calibration::nominal(robot, Task::Pose, Units::SI);
        let note = WorkingTool { frame }.apply(&full).note();
        assert!(!note.contains("from the last joint's axis"), "{note}");
    }

    /// The parameters said to be rigid with the tool are: changing one moves
    /// the measured frame as a change of the tool frame does, at every
    /// configuration (a constant transform in the flange frame).
    #[test]
    fn flange_parameters_move_the_tool_rigidly() {
        for convention in [Convention::Dh, Convention::Mdh] {
            let mut robot = puma560();
            robot.convention = convention;
            for p in flange_params(&robot) {
                let mut moved = robot.clone();
                *moved.param_mut(p).unwrap() += 0.01;
                let offset = |q: &[f64]| {
                    let flange = {
                        let mut r = robot.clone();
                        r.tool = Frame::identity();
                        r.forward(q).unwrap()
                    };
                    flange.inverse() * moved.forward(q).unwrap()
                };
                let at_zero = offset(&[0.0; 6]);
                let elsewhere = offset(&[0.3, -0.7, 1.1, 0.4, -0.9, 2.0]);
                let difference = at_zero.inverse() * elsewhere;
                // (The rotation's matrix, not its angle: acos loses half the
                // digits near the identity.)
                let turn = (difference.rotation.matrix() - nalgebra::Matrix3::identity()).norm();
                assert!(
                    difference.translation.vector.norm() < 1e-12 && turn < 1e-12,
                    "{p} ({convention:?}) is not rigid with the tool"
                );
            }
        }
    }
}
