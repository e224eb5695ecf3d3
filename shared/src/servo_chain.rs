//! The chain of one servo tick: what the compensation needs of the forward
//! kinematics, and nothing more, for the controller's per-tick budget.
//!
//! [`crate::Chain`] keeps every frame and the six lines of each link that the
//! special Jacobians of identification need (Mirman & Gupta eqs. 25–30). One
//! compensation needs far less: the measured frame, and for the manipulator
//! Jacobian and the second-order term each joint's axis `w_m` and a point `ρ_m`
//! on it, and for the gravity torques each link's centre of mass. A
//! [`ServoChain`] holds exactly that, filled in place by
//! [`Prepared::servo_chain_into`] with the D-H link product written out on the
//! frame's columns instead of a general 4 × 4 product:
//!
//! ```text
//! D-H   A_m = Rot_z(θ) Trans_z(s) Trans_x(a) Rot_x(α) [Rot_y(β)]
//!       x' = c_θ x + s_θ y,   y' = −s_θ x + c_θ y,   o' = o + s z + a x'
//!       y'' = c_α y' + s_α z, z'' = −s_α y' + c_α z  [x''' = c_β x' − s_β z'', z''' = s_β x' + c_β z'']
//! MDH   A_m = Rot_x(α) Trans_x(a) [Rot_y(β)] Rot_z(θ) Trans_z(s)
//! ```
//!
//! about 40 multiplications a link instead of 63, and the tool frame's rotation
//! only when the calibration has orientation. The joint line is that of the
//! frame before `A_m` in D-H and after it in modified D-H, as in
//! [`crate::LinkAxes`]; the centre of mass of link `m` is its `com` in the frame
//! after `A_m` ([`crate::LinkMass`]), the frame's origin for a link without
//! mass properties (the proxy of [`crate::effects`]). Lengths `a`, `s` are
//! multiplied by a factor (thermal expansion) as in
//! [`Prepared::chain_scaled_into`]. Measurement frame, metres and radians; the
//! tests check every quantity against [`crate::Chain`].

use heapless::Vec;
use nalgebra::{IsometryMatrix3, Matrix3, Point3, Translation3, Vector3};

use crate::kinematics::Prepared;
use crate::{Convention, JointType, MAX_JOINTS, ModelError, Real};

/// The axis line of one joint in the measurement frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLine<T: Real> {
    /// `w_m`: unit vector of the joint (z) axis.
    pub w: Vector3<T>,
    /// `ρ_m`: a point on it.
    pub rho: Point3<T>,
}

/// What a [`Prepared::servo_chain_into`] call fills besides the measured frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wanted {
    /// Each joint's axis line ([`ServoChain::lines`]).
    pub lines: bool,
    /// Each link's centre of mass ([`ServoChain::centres`]).
    pub centres: bool,
    /// The measured frame's rotation; without it [`ServoChain::end`] carries
    /// the flange's rotation (a position-only calibration needs none).
    pub rotation: bool,
}

/// The frames of one configuration that a compensation tick needs.
///
/// `repr(C)`, the frame between the two lists: each list's length sits just
/// before its (uninitialised) storage, and two zero lengths on either side of
/// one list's storage were merged by the optimiser into a 400-byte clear at
/// every construction.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct ServoChain<T: Real> {
    /// The axis line of each joint, when [`Wanted::lines`].
    pub lines: Vec<JointLine<T>, MAX_JOINTS>,
    /// The measured frame `base · A_1 ⋯ A_M · tool` (its rotation the
    /// flange's unless [`Wanted::rotation`]).
    pub end: IsometryMatrix3<T>,
    /// The centre of mass of each link, when [`Wanted::centres`].
    pub centres: Vec<Point3<T>, MAX_JOINTS>,
}

impl<T: Real> Default for ServoChain<T> {
    fn default() -> Self {
        Self {
            lines: Vec::new(),
            centres: Vec::new(),
            end: IsometryMatrix3::identity(),
        }
    }
}

impl<T: Real> ServoChain<T> {
    /// The measured point.
    #[inline]
    pub fn point(&self) -> Point3<T> {
        Point3::from(self.end.translation.vector)
    }
}

/// A frame as its three axes and its origin.
#[derive(Clone, Copy)]
struct Axes<T: Real> {
    x: Vector3<T>,
    y: Vector3<T>,
    z: Vector3<T>,
    o: Vector3<T>,
}

impl<T: Real> Axes<T> {
    fn of(frame: &IsometryMatrix3<T>) -> Self {
        let c = &frame.rotation.matrix().data.0;
        let v = |j: usize| Vector3::new(c[j][0], c[j][1], c[j][2]);
        Self {
            x: v(0),
            y: v(1),
            z: v(2),
            o: frame.translation.vector,
        }
    }

    /// This frame turned about its own z by the angle of `(s, c)`.
    #[inline(always)]
    fn rot_z(&mut self, (s, c): (T, T)) {
        let x = self.x * c + self.y * s;
        self.y = self.y * c - self.x * s;
        self.x = x;
    }

    /// Turned about its own x.
    #[inline(always)]
    fn rot_x(&mut self, (s, c): (T, T)) {
        let y = self.y * c + self.z * s;
        self.z = self.z * c - self.y * s;
        self.y = y;
    }

    /// Turned about its own y.
    #[inline(always)]
    fn rot_y(&mut self, (s, c): (T, T)) {
        let x = self.x * c - self.z * s;
        self.z = self.z * c + self.x * s;
        self.x = x;
    }

    /// The point with coordinates `v` in this frame.
    #[inline(always)]
    fn point(&self, v: &Vector3<T>) -> Vector3<T> {
        self.o + self.x * v.x + self.y * v.y + self.z * v.z
    }
}

impl<T: Real> Prepared<T> {
    /// The [`ServoChain`] at joint positions `q` with every length `a`, `s`
    /// times `factor` (1 for the model's own lengths), into `out`.
    pub fn servo_chain_into(
        &self,
        q: &[T],
        factor: T,
        wanted: Wanted,
        out: &mut ServoChain<T>,
    ) -> Result<(), ModelError> {
        crate::model::check_joint_count(self.dof(), q.len())?;
        out.lines.clear();
        out.centres.clear();
        let mut f = Axes::of(&self.base);
        let mdh = self.convention == Convention::Mdh;
        for (l, &qm) in self.links.iter().zip(q) {
            let link = &l.link;
            let (theta, s) = match link.joint {
                JointType::Revolute => (link.theta + qm, link.s * factor),
                JointType::Prismatic => (link.theta, link.s * factor + qm),
            };
            let a = link.a * factor;
            let tilted = link.beta != T::zero();
            if mdh {
                f.o += f.x * a;
                f.rot_x(l.sin_cos_alpha);
                if tilted {
                    f.rot_y(l.sin_cos_beta);
                }
                f.o += f.z * s;
                f.rot_z(theta.sincos());
            } else {
                if wanted.lines {
                    // Capacity MAX_JOINTS: a model never has more links.
                    let _ = out.lines.push(JointLine {
                        w: f.z,
                        rho: Point3::from(f.o),
                    });
                }
                f.rot_z(theta.sincos());
                f.o += f.z * s + f.x * a;
                f.rot_x(l.sin_cos_alpha);
                if tilted {
                    f.rot_y(l.sin_cos_beta);
                }
            }
            if mdh && wanted.lines {
                let _ = out.lines.push(JointLine {
                    w: f.z,
                    rho: Point3::from(f.o),
                });
            }
            if wanted.centres {
                let centre = match &link.mass {
                    Some(m) => f.point(&m.com),
                    None => f.o,
                };
                let _ = out.centres.push(Point3::from(centre));
            }
        }
        let tool = &self.tool;
        let origin = f.point(&tool.translation.vector);
        let rotation = if wanted.rotation {
            let t = Axes::of(tool);
            Matrix3::from_columns(&[
                f.point(&t.x) - f.o,
                f.point(&t.y) - f.o,
                f.point(&t.z) - f.o,
            ])
        } else {
            Matrix3::from_columns(&[f.x, f.y, f.z])
        };
        out.end = IsometryMatrix3::from_parts(
            Translation3::from(origin),
            nalgebra::Rotation3::from_matrix_unchecked(rotation),
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Frame, Link, LinkMass, Robot};

    /// Every quantity equals [`crate::Chain`]'s: both conventions, revolute and
    /// prismatic joints, tilted links, links with and without masses, a base
    /// and a tool, at two length factors. Both are sums of a few products of
    /// unit vectors and lengths under 1 m, so they agree to rounding (1e-14).
    #[test]
    fn servo_chain_equals_the_chain() {
        let (r, p) = (JointType::Revolute, JointType::Prismatic);
        let mut links = [
            Link::new(r, 0.1, 0.3, 0.2, 1.2),
            Link::new(p, -0.4, 0.1, 0.5, -0.7),
            Link::new(r, 0.7, -0.2, 0.3, 0.4),
            Link::new(r, -1.1, 0.15, -0.25, -1.3),
        ];
        links[2].beta = 0.01;
        links[1].mass = Some(LinkMass {
            mass: 2.0,
            com: Vector3::new(0.1, -0.05, 0.2),
        });
        let q = [0.3, 0.05, -0.8, 1.9];
        let all = Wanted {
            lines: true,
            centres: true,
            rotation: true,
        };
        for convention in [Convention::Dh, Convention::Mdh] {
            let mut robot = Robot::new(convention, &links).unwrap();
            robot.base = Frame {
                xyz: Vector3::new(0.1, 0.2, -0.3),
                rpy: Vector3::new(0.2, -0.1, 0.5),
            };
            robot.tool = Frame {
                xyz: Vector3::new(0.01, 0.02, 0.15),
                rpy: Vector3::new(0.3, 0.1, -0.2),
            };
            for factor in [1.0, 1.001] {
                let prepared = robot.prepare();
                let chain = prepared.with_length_factor(factor).chain(&q).unwrap();
                let mut servo = ServoChain::default();
                prepared
                    .servo_chain_into(&q, factor, all, &mut servo)
                    .unwrap();
                let near = |a: &Vector3<f64>, b: &Vector3<f64>| (a - b).norm() < 1e-14;
                assert!((servo.end.to_homogeneous() - chain.end.to_homogeneous()).norm() < 1e-14);
                for (m, line) in servo.lines.iter().enumerate() {
                    assert!(near(&line.w, &chain.axes[m].w), "{convention:?} w {m}");
                    assert!(near(&line.rho.coords, &chain.axes[m].rho.coords));
                }
                for (m, centre) in servo.centres.iter().enumerate() {
                    let frame = &chain.links[m];
                    let want = match &links[m].mass {
                        Some(lm) => frame * Point3::from(lm.com * 1.0),
                        None => Point3::from(frame.translation.vector),
                    };
                    assert!(near(&centre.coords, &want.coords), "centre {m}");
                }
                assert_eq!(servo.lines.len(), 4);
                assert_eq!(servo.centres.len(), 4);
                // Without the rotation: the same point.
                let mut point_only = ServoChain::default();
                let none = Wanted {
                    lines: false,
                    centres: false,
                    rotation: false,
                };
                prepared
                    .servo_chain_into(&q, factor, none, &mut point_only)
                    .unwrap();
                assert!(near(&point_only.point().coords, &chain.point().coords));
                assert!(point_only.lines.is_empty() && point_only.centres.is_empty());
            }
        }
    }
}
