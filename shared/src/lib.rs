//! # armcal-shared: the one copy of armcal's robot math
//!
//! `#![no_std]`, generic over `f32` (the controller) and `f64` (the calibrator),
//! so that the host tests run exactly the code the firmware runs.
//!
//! | module | idea |
//! | --- | --- |
//! | [`model`] | the nominal robot: D-H links (standard or modified), joint types, base and tool frames |
//! | [`dh`] | one link's homogeneous transform in either convention, elementary rotations, roll-pitch-yaw |
//! | [`kinematics`] | forward kinematics of the measured frame and point, and the [`kinematics::Chain`] of every link frame |
//! | [`jacobian`] | the special Jacobians J_θ, J_s, J_α, J_a of Mirman & Gupta (eqs. 51–54), base and tool columns, the manipulator Jacobian |
//! | [`pose_error`](mod@pose_error) | the end-effector error of Mirman & Gupta eqs. 12–15, full pose and position only |
//! | [`perturbation`] | the forward solution to second order in the parameter errors, `K_i` and `L_ij` of Kirchner, Gurumoorthy & Prinz (1985) eq. 2.22 |
//! | [`compensation`] | the corrected joint commands that make the calibrated robot reach the nominal model's pose, Kirchner et al. section 4 (eq. 4.9) |
//! | [`effects`] | non-geometric effects (joint compliance, gear transmission, backlash, thermal expansion, encoder scale) and the model that carries them |
//! | [`calibration`] | the calibration file the calibrator writes and the controller loads: magic, version, model hash, CRC, postcard payload |
//! | [`ranges`] | the joint, temperature and payload ranges a calibration was identified on, and which values of a pose lie outside them |
//! | [`link`] | the serial link to the controller: wire messages (postcard + COBS), and the controller's side of the protocol |
//! | [`units`] | the model file's length and angle units, and their conversion to SI |
//! | [`param`] | the names of the geometric parameters (`theta3`, `alpha1`, `base.rx`, `tool.z`, ...) |
//!
//! ## Conventions used throughout
//! - Units: SI inside this crate, metres and radians. The host converts model files
//!   from their declared units (`in`, `mm`, `deg`) on reading and back on writing.
//! - Frames: every vector and point returned by [`kinematics`] and [`jacobian`] is
//!   expressed in the *measurement frame* (the laser tracker's or the world frame),
//!   i.e. after the robot's `base` transform.
//! - Errors and Jacobian columns are 6-vectors `[νdφ; dη]`: the rotation error vector
//!   first, then the translation error of the point of the end effector that
//!   coincides with the measurement-frame origin, exactly as in eq. (49) of
//!   C. R. Mirman and K. C. Gupta, "Identification of Position-Independent Robot
//!   Parameter Errors Using Special Jacobian Matrices", Int. J. Robotics Research,
//!   11(3), 1992. The error of a point `P` follows as `dP = dη + νdφ × P` (eq. 8).
#![no_std]
#![forbid(unsafe_code)]

#[cfg(feature = "std")]
extern crate std;

pub mod calibration;
pub mod compensation;
pub mod dh;
pub mod effects;
pub mod jacobian;
pub mod kinematics;
pub mod link;
pub mod model;
pub mod param;
pub mod perturbation;
pub mod pose_error;
pub mod ranges;
pub mod scalar;
pub mod servo_chain;
pub mod units;

pub use calibration::{
    Calibration, CalibrationError, GeometricCalibration, ParamError, TargetFrame,
};
pub use jacobian::{SpecialJacobians, Twist};
pub use kinematics::{Chain, FrameAxes, LinkAxes, Prepared};
pub use model::{Convention, Frame, JointType, Link, LinkMass, MAX_JOINTS, ModelError, Robot};
pub use param::{FrameAxis, Param};
pub use pose_error::{pose_error, position_error, rotation_error};
pub use scalar::Real;
