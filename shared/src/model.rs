//! The nominal robot model: D-H links, joint types, base and tool frames.
//!
//! Two link conventions are supported (`docs/file-formats.md` §1):
//! - [`Convention::Dh`], the one of Mirman & Gupta eq. (5):
//!   `A_m = Rot_z(θ_m) Trans_z(s_m) Trans_x(a_m) Rot_x(α_m)`;
//! - [`Convention::Mdh`], Craig's modified D-H:
//!   `A_m = Rot_x(α_m) Trans_x(a_m) Rot_z(θ_m) Trans_z(s_m)`.
//!
//! For a revolute joint the reading `q_m` is added to the constant offset `θ_m`;
//! for a prismatic joint it is added to `s_m`. The measured frame is
//! `base · A_1(q_1) ⋯ A_M(q_M) · tool`, and the measured point is its origin.
//!
//! Units are SI (m, rad, kg); the host converts from the model file's units.

use heapless::Vec;
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::Real;

/// The most joints a model may have. Sized for long chains (a humanoid torso and
/// arm has 9, a mobile manipulator with a lift 8) while keeping every per-joint
/// array on the controller's stack small.
pub const MAX_JOINTS: usize = 16;

/// The items of `iter` in a fixed-capacity list, for sources that never hold
/// more than its capacity (a model's links, one value per joint); any beyond
/// it are left out. `collect` would link a panic for the overflow that cannot
/// happen, and with it 2 KB of formatting code on the controller.
pub(crate) fn bounded<T, const N: usize>(iter: impl IntoIterator<Item = T>) -> Vec<T, N> {
    let mut list = Vec::new();
    for item in iter {
        if list.push(item).is_err() {
            break;
        }
    }
    list
}

/// The link convention of a model (`convention` in the model file).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Convention {
    /// Standard D-H as in Mirman & Gupta eq. (5): `Rot_z(θ) Trans_z(s) Trans_x(a) Rot_x(α)`.
    Dh,
    /// Modified D-H (Craig): `Rot_x(α) Trans_x(a) Rot_z(θ) Trans_z(s)`.
    Mdh,
}

/// What a joint's reading moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum JointType {
    /// The reading is an angle added to `θ`.
    Revolute,
    /// The reading is a length added to `s`.
    Prismatic,
}

/// Mass properties of the link that a joint moves, for gravity torques.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinkMass<T: Real> {
    /// Mass, kg.
    pub mass: T,
    /// Centre of mass in the link's own D-H frame (the frame after `A_m`), m.
    pub com: Vector3<T>,
}

/// One link: its joint type and its four D-H parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Link<T: Real> {
    /// Revolute or prismatic.
    pub joint: JointType,
    /// Rotation about z, rad: the constant offset of a revolute joint, or the fixed angle of a prismatic one.
    pub theta: T,
    /// Translation along z, m: the constant offset of a prismatic joint, or the fixed offset of a revolute one.
    pub s: T,
    /// Translation along x (link length), m.
    pub a: T,
    /// Rotation about x (link twist), rad.
    pub alpha: T,
    /// Hayati's tilt about y, rad: 0 in the D-H model of the file. Standard D-H
    /// cannot express a small tilt between nominally parallel axes (the common
    /// normal runs away); the `parallel_axis_tilt` effect identifies this instead.
    /// `A_m = Rot_z(θ) Trans_z(s) Trans_x(a) Rot_x(α) Rot_y(β)` in D-H,
    /// `Rot_x(α) Trans_x(a) Rot_y(β) Rot_z(θ) Trans_z(s)` in modified D-H.
    pub beta: T,
    /// Joint limits in joint units (rad or m), if the maker gives them.
    pub limits: Option<[T; 2]>,
    /// Mass properties of the link this joint moves, if known.
    pub mass: Option<LinkMass<T>>,
}

impl<T: Real> Link<T> {
    /// A link without limits or mass properties.
    pub fn new(joint: JointType, theta: T, s: T, a: T, alpha: T) -> Self {
        Self {
            joint,
            theta,
            s,
            a,
            alpha,
            beta: T::zero(),
            limits: None,
            mass: None,
        }
    }

    /// `(θ, s)` of this link at joint reading `q`: the reading is added to `θ`
    /// (revolute) or to `s` (prismatic).
    #[inline]
    pub fn joint_values(&self, q: T) -> (T, T) {
        match self.joint {
            JointType::Revolute => (self.theta + q, self.s),
            JointType::Prismatic => (self.theta, self.s + q),
        }
    }
}

/// A rigid frame given as `xyz` and roll-pitch-yaw, `R = Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`,
/// as `[base]` and `[tool]` in the model file.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame<T: Real> {
    /// Origin, m, in the parent frame.
    pub xyz: Vector3<T>,
    /// `[roll, pitch, yaw]`, rad.
    pub rpy: Vector3<T>,
}

impl<T: Real> Frame<T> {
    /// The identity frame (the default for a missing `[base]` or `[tool]`).
    pub fn identity() -> Self {
        Self {
            xyz: Vector3::zeros(),
            rpy: Vector3::zeros(),
        }
    }

    /// The homogeneous transform `Trans(xyz) Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`.
    pub fn isometry(&self) -> IsometryMatrix3<T> {
        IsometryMatrix3::from_parts(
            Translation3::from(self.xyz),
            // nalgebra's `Rotation3::from_euler_angles`, with [`Real::sincos`] (in
            // f32 the controller then links no libm sine).
            {
                let (sr, cr) = self.rpy.x.sincos();
                let (sp, cp) = self.rpy.y.sincos();
                let (sy, cy) = self.rpy.z.sincos();
                Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(
                    cy * cp,
                    cy * sp * sr - sy * cr,
                    cy * sp * cr + sy * sr,
                    sy * cp,
                    sy * sp * sr + cy * cr,
                    sy * sp * cr - cy * sr,
                    -sp,
                    cp * sr,
                    cp * cr,
                ))
            },
        )
    }
}

impl<T: Real> Default for Frame<T> {
    fn default() -> Self {
        Self::identity()
    }
}

/// Why a model or a joint vector cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ModelError {
    /// More joints than [`MAX_JOINTS`].
    TooManyJoints {
        /// Joints asked for.
        joints: usize,
    },
    /// A joint vector whose length is not the model's joint count.
    JointCount {
        /// The model's joint count.
        expected: usize,
        /// The length given.
        got: usize,
    },
}

impl core::fmt::Display for ModelError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooManyJoints { joints } => {
                write!(f, "{joints} joints: at most {MAX_JOINTS} are supported")
            }
            Self::JointCount { expected, got } => {
                write!(
                    f,
                    "{got} joint values given, the model has {expected} joints"
                )
            }
        }
    }
}

impl core::error::Error for ModelError {}

/// `Ok` if `got` joint values fit a model of `expected` joints.
#[inline]
pub(crate) fn check_joint_count(expected: usize, got: usize) -> Result<(), ModelError> {
    if got == expected {
        Ok(())
    } else {
        Err(ModelError::JointCount { expected, got })
    }
}

/// A serial robot: its links base to tip, the base frame (the robot in the
/// measurement frame), the tool frame (the measured point and frame in the last
/// link frame) and, optionally, gravity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Robot<T: Real> {
    /// Link convention.
    pub convention: Convention,
    /// Links, base to tip.
    pub links: Vec<Link<T>, MAX_JOINTS>,
    /// The robot base frame in the measurement frame.
    pub base: Frame<T>,
    /// The measured frame in the last link frame.
    pub tool: Frame<T>,
    /// Gravity in the base frame, m/s², if given.
    pub gravity: Option<Vector3<T>>,
}

impl<T: Real> Robot<T> {
    /// A robot with identity base and tool and no gravity.
    pub fn new(convention: Convention, links: &[Link<T>]) -> Result<Self, ModelError> {
        let links = Vec::from_slice(links).map_err(|_| ModelError::TooManyJoints {
            joints: links.len(),
        })?;
        Ok(Self {
            convention,
            links,
            base: Frame::identity(),
            tool: Frame::identity(),
            gravity: None,
        })
    }

    /// The number of joints, M.
    #[inline]
    pub fn dof(&self) -> usize {
        self.links.len()
    }

    /// Checks that `q` has one value per joint.
    #[inline]
    pub fn check_joints(&self, q: &[T]) -> Result<(), ModelError> {
        check_joint_count(self.dof(), q.len())
    }

    /// The same robot in another scalar type (`f64` → `f32` for the controller).
    pub fn cast<U: Real>(&self) -> Robot<U> {
        let c = |x: T| U::lit(x.to_f64());
        let v = |x: &Vector3<T>| Vector3::new(c(x.x), c(x.y), c(x.z));
        let frame = |f: &Frame<T>| Frame {
            xyz: v(&f.xyz),
            rpy: v(&f.rpy),
        };
        let links = bounded(self.links.iter().map(|l| Link {
            joint: l.joint,
            theta: c(l.theta),
            s: c(l.s),
            a: c(l.a),
            alpha: c(l.alpha),
            beta: c(l.beta),
            limits: l.limits.map(|[lo, hi]| [c(lo), c(hi)]),
            mass: l.mass.map(|m| LinkMass {
                mass: c(m.mass),
                com: v(&m.com),
            }),
        }));
        Robot {
            convention: self.convention,
            links,
            base: frame(&self.base),
            tool: frame(&self.tool),
            gravity: self.gravity.as_ref().map(v),
        }
    }
}
