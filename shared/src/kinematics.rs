//! Forward kinematics of the measured frame and point, and the chain of link frames
//! from which the Jacobians are built.
//!
//! The measured frame is `T = base · A_1(q_1) ⋯ A_M(q_M) · tool` (`FORMAT.md` §1,
//! Mirman & Gupta eq. 1 with base and tool added); the measured point is its origin.
//! Everything is expressed in the measurement frame, in metres and radians.
//!
//! [`Chain`] keeps, for each link `m`, the lines that Mirman & Gupta's special
//! Jacobians need (eqs. 25–30, 40–42): the joint axis `w_m` (the z axis about
//! which θ_m turns and along which s_m slides), a point `ρ_m` on it, the common
//! normal `u_{m+1}` (the x axis about which α_m turns and along which a_m slides)
//! and a point `σ_{m+1}` on it. In standard D-H the z line belongs to the frame
//! before `A_m` and the x line to the frame after it; in modified D-H it is the
//! other way round. The same four vectors then serve both conventions.

use heapless::Vec;
use nalgebra::{IsometryMatrix3, Point3, Vector3};

use crate::dh::link_transform;
use crate::{Convention, Frame, JointType, MAX_JOINTS, ModelError, Real, Robot};

/// The two lines of link `m` in the measurement frame: the z line of θ_m and s_m,
/// the x line of α_m and a_m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkAxes<T: Real> {
    /// `w_m`: unit vector of the joint (z) axis.
    pub w: Vector3<T>,
    /// `ρ_m`: a point on the joint axis (the origin of the frame that carries it).
    pub rho: Point3<T>,
    /// `u_{m+1}`: unit vector of the common normal (x axis).
    pub u: Vector3<T>,
    /// `σ_{m+1}`: a point on the common normal (the origin of the frame that carries it).
    pub sigma: Point3<T>,
}

/// Every frame of the robot at one joint configuration, in the measurement frame.
#[derive(Clone, Debug)]
pub struct Chain<T: Real> {
    /// The robot base frame (`base`).
    pub base: IsometryMatrix3<T>,
    /// Link frames after each `A_m`: `links[m-1] = base · A_1 ⋯ A_m`.
    pub links: Vec<IsometryMatrix3<T>, MAX_JOINTS>,
    /// The lines of each link, for the special Jacobians.
    pub axes: Vec<LinkAxes<T>, MAX_JOINTS>,
    /// The last link frame, `base · A_1 ⋯ A_M` (the flange).
    pub flange: IsometryMatrix3<T>,
    /// The measured frame, `flange · tool`.
    pub end: IsometryMatrix3<T>,
    /// The joint type of each link.
    pub joints: Vec<JointType, MAX_JOINTS>,
    /// The base frame's parameters (for the base columns).
    pub base_frame: Frame<T>,
    /// The tool frame's parameters (for the tool columns).
    pub tool_frame: Frame<T>,
}

impl<T: Real> Chain<T> {
    /// The number of joints, M.
    #[inline]
    pub fn dof(&self) -> usize {
        self.axes.len()
    }

    /// The measured point: the origin of the measured frame.
    #[inline]
    pub fn point(&self) -> Point3<T> {
        Point3::from(self.end.translation.vector)
    }
}

impl<T: Real> Robot<T> {
    /// The measured frame `base · A_1(q_1) ⋯ A_M(q_M) · tool`.
    pub fn forward(&self, q: &[T]) -> Result<IsometryMatrix3<T>, ModelError> {
        self.check_joints(q)?;
        let mut t = self.base.isometry();
        for (link, &qm) in self.links.iter().zip(q) {
            t *= link_transform(self.convention, link, qm);
        }
        Ok(t * self.tool.isometry())
    }

    /// The measured point: the origin of [`Robot::forward`].
    pub fn measured_point(&self, q: &[T]) -> Result<Point3<T>, ModelError> {
        self.forward(q).map(|t| Point3::from(t.translation.vector))
    }

    /// Every link frame and line at configuration `q`.
    pub fn chain(&self, q: &[T]) -> Result<Chain<T>, ModelError> {
        self.check_joints(q)?;
        let base = self.base.isometry();
        let mut links = Vec::new();
        let mut axes = Vec::new();
        let mut before = base;
        for (link, &qm) in self.links.iter().zip(q) {
            let after = before * link_transform(self.convention, link, qm);
            // The z line and the x line of this link, from the frame that carries each.
            let (zf, xf) = match self.convention {
                Convention::Dh => (&before, &after),
                Convention::Mdh => (&after, &before),
            };
            let line = LinkAxes {
                w: zf.rotation.matrix().column(2).into_owned(),
                rho: Point3::from(zf.translation.vector),
                u: xf.rotation.matrix().column(0).into_owned(),
                sigma: Point3::from(xf.translation.vector),
            };
            // Capacity is MAX_JOINTS on both sides: a Robot never holds more links.
            let _ = links.push(after);
            let _ = axes.push(line);
            before = after;
        }
        let end = before * self.tool.isometry();
        Ok(Chain {
            base,
            links,
            axes,
            flange: before,
            end,
            joints: self.links.iter().map(|l| l.joint).collect(),
            base_frame: self.base,
            tool_frame: self.tool,
        })
    }
}
