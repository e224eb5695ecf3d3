//! The names of the geometric parameters, as the calibration engineer reads them
//! in reports, JSON and the calibration file (`docs/file-formats.md` §6).
//!
//! Joints count from 1 in names (`theta1`, `s2`, `a3`, `alpha4`); the index held
//! in a [`Param`] counts from 0. Base and tool parameters are `base.x`, `base.y`,
//! `base.z`, `base.rx`, `base.ry`, `base.rz` and likewise `tool.*`, where `rx`,
//! `ry`, `rz` are the roll, pitch and yaw of the frame's
//! `R = Rot_z(yaw) Rot_y(pitch) Rot_x(roll)` (`docs/file-formats.md` §1).

use core::fmt;
use core::str::FromStr;

use serde::{Deserialize, Serialize};

/// One of the six parameters of a base or tool frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum FrameAxis {
    /// Translation along x of the parent frame.
    X,
    /// Translation along y of the parent frame.
    Y,
    /// Translation along z of the parent frame.
    Z,
    /// Roll: rotation about x, applied first.
    Rx,
    /// Pitch: rotation about y.
    Ry,
    /// Yaw: rotation about z, applied last.
    Rz,
}

impl FrameAxis {
    /// All six, in the order `x, y, z, rx, ry, rz`.
    pub const ALL: [FrameAxis; 6] = [
        FrameAxis::X,
        FrameAxis::Y,
        FrameAxis::Z,
        FrameAxis::Rx,
        FrameAxis::Ry,
        FrameAxis::Rz,
    ];

    /// The position of this axis in [`FrameAxis::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The suffix used in names: `x`, ..., `rz`.
    pub fn suffix(self) -> &'static str {
        match self {
            Self::X => "x",
            Self::Y => "y",
            Self::Z => "z",
            Self::Rx => "rx",
            Self::Ry => "ry",
            Self::Rz => "rz",
        }
    }

    /// True for the three rotations.
    pub fn is_angle(self) -> bool {
        self.slot().0
    }

    /// Where the parameter lives in a [`crate::Frame`]: `(false, i)` is `xyz[i]`,
    /// `(true, i)` is `rpy[i]`.
    fn slot(self) -> (bool, usize) {
        match self {
            Self::X => (false, 0),
            Self::Y => (false, 1),
            Self::Z => (false, 2),
            Self::Rx => (true, 0),
            Self::Ry => (true, 1),
            Self::Rz => (true, 2),
        }
    }
}

/// One geometric parameter of a robot model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Param {
    /// `θ` of joint `i` (0-based): the joint offset of a revolute joint.
    Theta(usize),
    /// `s` of joint `i`: the joint offset of a prismatic joint.
    S(usize),
    /// `a` of joint `i`: the link length.
    A(usize),
    /// `α` of joint `i`: the link twist.
    Alpha(usize),
    /// `β` of joint `i`: Hayati's tilt about y (the `parallel_axis_tilt` effect);
    /// not among [`crate::Robot::params`], the D-H parameters of the file.
    Beta(usize),
    /// A parameter of the base frame.
    Base(FrameAxis),
    /// A parameter of the tool frame.
    Tool(FrameAxis),
}

impl Param {
    /// True if the parameter is an angle (rad), false if a length (m).
    pub fn is_angle(self) -> bool {
        match self {
            Self::Theta(_) | Self::Alpha(_) | Self::Beta(_) => true,
            Self::S(_) | Self::A(_) => false,
            Self::Base(ax) | Self::Tool(ax) => ax.is_angle(),
        }
    }
}

impl fmt::Display for Param {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Theta(i) => write!(f, "theta{}", i + 1),
            Self::S(i) => write!(f, "s{}", i + 1),
            Self::A(i) => write!(f, "a{}", i + 1),
            Self::Alpha(i) => write!(f, "alpha{}", i + 1),
            Self::Beta(i) => write!(f, "beta{}", i + 1),
            Self::Base(ax) => write!(f, "base.{}", ax.suffix()),
            Self::Tool(ax) => write!(f, "tool.{}", ax.suffix()),
        }
    }
}

/// A string that is not a parameter name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnknownParam;

impl fmt::Display for UnknownParam {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("not a parameter name: expected theta<i>, s<i>, a<i>, alpha<i> (i from 1), base.<x|y|z|rx|ry|rz> or tool.<...>")
    }
}

impl core::error::Error for UnknownParam {}

impl FromStr for Param {
    type Err = UnknownParam;

    fn from_str(name: &str) -> Result<Self, Self::Err> {
        let frame_axis = |suffix: &str| {
            FrameAxis::ALL
                .into_iter()
                .find(|ax| ax.suffix() == suffix)
                .ok_or(UnknownParam)
        };
        if let Some(rest) = name.strip_prefix("base.") {
            return frame_axis(rest).map(Self::Base);
        }
        if let Some(rest) = name.strip_prefix("tool.") {
            return frame_axis(rest).map(Self::Tool);
        }
        // Longest prefixes first: "alpha" before "a".
        type MakeJointParam = fn(usize) -> Param;
        let joint: [(&str, MakeJointParam); 5] = [
            ("theta", Self::Theta),
            ("alpha", Self::Alpha),
            ("beta", Self::Beta),
            ("s", Self::S),
            ("a", Self::A),
        ];
        for (prefix, make) in joint {
            if let Some(digits) = name.strip_prefix(prefix) {
                if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                    return Err(UnknownParam);
                }
                return match digits.parse::<usize>() {
                    Ok(i) if i >= 1 => Ok(make(i - 1)),
                    _ => Err(UnknownParam),
                };
            }
        }
        Err(UnknownParam)
    }
}

impl<T: crate::Real> crate::Robot<T> {
    /// The current value of a parameter (SI units), or `None` if its joint index
    /// is beyond the model's joints.
    pub fn param(&self, param: Param) -> Option<T> {
        let frame = |f: &crate::Frame<T>, axis: FrameAxis| match axis.slot() {
            (false, i) => f.xyz[i],
            (true, i) => f.rpy[i],
        };
        match param {
            Param::Theta(m) => self.links.get(m).map(|l| l.theta),
            Param::S(m) => self.links.get(m).map(|l| l.s),
            Param::A(m) => self.links.get(m).map(|l| l.a),
            Param::Alpha(m) => self.links.get(m).map(|l| l.alpha),
            Param::Beta(m) => self.links.get(m).map(|l| l.beta),
            Param::Base(axis) => Some(frame(&self.base, axis)),
            Param::Tool(axis) => Some(frame(&self.tool, axis)),
        }
    }

    /// A mutable reference to a parameter, or `None` if its joint index is beyond
    /// the model's joints. This is how identified errors are applied to a model.
    pub fn param_mut(&mut self, param: Param) -> Option<&mut T> {
        fn frame<T: crate::Real>(f: &mut crate::Frame<T>, axis: FrameAxis) -> &mut T {
            match axis.slot() {
                (false, i) => &mut f.xyz[i],
                (true, i) => &mut f.rpy[i],
            }
        }
        match param {
            Param::Theta(m) => self.links.get_mut(m).map(|l| &mut l.theta),
            Param::S(m) => self.links.get_mut(m).map(|l| &mut l.s),
            Param::A(m) => self.links.get_mut(m).map(|l| &mut l.a),
            Param::Alpha(m) => self.links.get_mut(m).map(|l| &mut l.alpha),
            Param::Beta(m) => self.links.get_mut(m).map(|l| &mut l.beta),
            Param::Base(axis) => Some(frame(&mut self.base, axis)),
            Param::Tool(axis) => Some(frame(&mut self.tool, axis)),
        }
    }

    /// Every geometric parameter of this model, joints first (`theta, s, a, alpha`
    /// of each joint), then the six base and the six tool parameters.
    pub fn params(&self) -> impl Iterator<Item = Param> + '_ {
        let joints = (0..self.dof())
            .flat_map(|m| [Param::Theta(m), Param::S(m), Param::A(m), Param::Alpha(m)]);
        joints
            .chain(FrameAxis::ALL.into_iter().map(Param::Base))
            .chain(FrameAxis::ALL.into_iter().map(Param::Tool))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::string::ToString;

    #[test]
    fn names_round_trip() {
        let all = [
            Param::Theta(0),
            Param::S(1),
            Param::A(2),
            Param::Alpha(11),
            Param::Base(FrameAxis::Rx),
            Param::Tool(FrameAxis::Z),
        ];
        for p in all {
            assert_eq!(p.to_string().parse::<Param>(), Ok(p), "{p}");
        }
        assert_eq!(Param::Alpha(0).to_string(), "alpha1");
        for bad in [
            "theta0", "theta", "a-1", "alpha1x", "base.w", "tool.", "q1", "",
        ] {
            assert_eq!(bad.parse::<Param>(), Err(UnknownParam), "{bad}");
        }
    }
}
