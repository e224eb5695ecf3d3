//! A URDF chain as armcal's kinematic model: modified D-H with Hayati's tilt
//! between nearly parallel axes, equal to the URDF's forward kinematics.
//!
//! ## Convention
//! [`Convention::Mdh`] (Craig), with Hayati's tilt `β` about y where two
//! consecutive axes are nearly parallel:
//! `A_k = Rot_x(α_k) Trans_x(a_k) Rot_y(β_k) Rot_z(θ_k + q_k) Trans_z(s_k)`
//! (prismatic: `s_k + q_k`). MDH frame `k` lies on joint axis `k`, its z along
//! the URDF `<axis>` (so a positive reading turns or slides the same way), and
//! moves with the child link of joint `k`: the URDF link frame and MDH frame
//! `k` differ by a constant transform. All frames are placed at zero readings,
//! so `θ_k`, `s_k` are the offsets that keep the URDF's zero.
//!
//! ## Frames
//! - Frame 0 (the model's `base`, in the base link's frame): z along axis 1,
//!   origin at the foot of the perpendicular from the base link's origin to
//!   axis 1, x the base link's x made perpendicular to z (its y if x is along
//!   the axis). A robot whose first axis is the base link's z gets an identity
//!   base, and its geometry is in the D-H parameters.
//! - Frame `k` (`1 ≤ k < M`), from axis `k` and axis `k+1`:
//!   - axes at an angle `γ` with `sin γ ≥ 0.1`: Craig's rule, origin at the foot
//!     of the common normal on axis `k`, x along the common normal towards
//!     axis `k+1` (`a_{k+1} ≥ 0`; for intersecting axes x is `z_k × z_{k+1}`),
//!     `β_{k+1} = 0`;
//!   - `sin γ < 0.1` (parallel or nearly): Hayati's rule, origin where the
//!     previous link left it (`s_k = 0`), x towards the point where axis `k+1`
//!     crosses the plane through that origin normal to axis `k` (`a_{k+1}` is
//!     its distance; when it is zero, x is kept, `θ_k = 0`), and
//!     `α_{k+1}`, `β_{k+1}` turn z_k onto axis `k+1`.
//! - Frame `M`: origin where the previous link left it (`s_M = 0`), x the tip
//!   link's x made perpendicular to the axis (its y if x is along it). The
//!   model's `tool` is the measured frame (tip link frame moved to the measured
//!   point) in frame `M`.
//!
//! ## Why this parametrisation
//! Modified D-H keeps every frame on its own joint axis, so the URDF link frame
//! is a constant transform of it and the URDF's zero and axis direction carry
//! over as they are. Where two axes are at an angle `γ` with lateral offset
//! `r`, the foot of Craig's common normal is about `r / γ` along the axis and
//! moves by `r / γ²` per radian of axis error: below `sin γ = 0.1` (5.7°) a
//! 1 mrad axis error moves `s` by more than a tenth of the link, far outside
//! the 1 mm prior of a length and the linear range of the fit, and at exact
//! parallelism (UR arms; URDF rounding leaves 1e-10 rad) the foot is undefined.
//! There Hayati's tilt `β` replaces the redundant offset: every parameter then
//! moves by about `r` per radian, and `--params full` identifies `β` with the
//! other four ([`crate::session::model::RobotModel::tilted`]). Above the threshold Craig's four parameters
//! span every small motion of the next axis (`--params full` identifies those
//! four; β is added by `armcal diagnose`'s `parallel_axis_tilt`), so the tilt
//! is not used where it is not needed. Real arms have consecutive axes either
//! parallel or perpendicular, so the threshold matters only for odd designs.
//!
//! ## Masses
//! The mass of joint `k`'s link is the sum over the URDF links it moves: the
//! child link of joint `k` and everything attached below it up to the next
//! moving joint of the chain (fixed children, and branches off the chain with
//! their own joints at zero). The centre of mass is the mass-weighted mean of
//! their `<inertial><origin xyz>`, expressed in MDH frame `k` (the link's own
//! D-H frame of `docs/file-formats.md` §1). Links with no `<inertial>` count as massless;
//! a link without any has no mass properties.
//!
//! Limits: `revolute` and `prismatic` joints keep their `<limit lower upper>`
//! (rad, m); `continuous` joints have none. Gravity is not in a URDF: none.

use armcal_shared::{Convention, Frame, JointType, Link, LinkMass, Robot};
use nalgebra::{Point3, Rotation3, Translation3, Vector3};

use super::{ChainSpec, JointKind, Pose, Urdf, UrdfChain, rpy};
use crate::session::input_error::InputError;

/// Below this sine of the angle between consecutive axes, Hayati's tilt is used
/// instead of Craig's common normal (see the module header).
pub const SIN_PARALLEL: f64 = 0.1;

/// A distance from the previous origin to the next axis below which that axis
/// is taken to pass through it (`a = 0`, x kept): far below any machined length,
/// and small enough to leave the forward kinematics exact to 1e-13 m.
const ON_AXIS: f64 = 1e-14;

/// A URDF chain converted: the model, and what an export needs to turn a
/// calibrated model back into joint origins.
#[derive(Clone, Debug)]
pub struct Converted {
    /// The model, [`Convention::Mdh`], SI.
    pub robot: Robot<f64>,
    /// The chain it was read from.
    pub chain: UrdfChain,
    /// For each moving joint `k`, MDH frame `k` in the child link's frame.
    pub dh_in_link: Vec<Pose>,
    /// For each moving joint `k`, the fixed joints from the child link of the
    /// previous moving joint (the base link for the first) to the parent link
    /// of joint `k`.
    pub fixed_before: Vec<Pose>,
    /// The tip link in the child link of the last moving joint.
    pub tip_in_last: Pose,
    /// The measured point in the tip link, m.
    pub tip_point: Vector3<f64>,
    /// The tip link's frame (the flange a working tool is given in) in the
    /// model's last frame `M`: the model's `tool` without the tip point.
    pub flange: Frame<f64>,
    /// For each moving joint, whether its link uses Hayati's tilt (the axis
    /// before it nearly parallel).
    pub hayati: Vec<bool>,
}

/// A frame from its origin, its unit z and a hint for x (made perpendicular to z).
fn frame_from(
    origin: Point3<f64>,
    z: Vector3<f64>,
    x_hint: Vector3<f64>,
    y_hint: Vector3<f64>,
) -> Pose {
    let mut x = x_hint - z * z.dot(&x_hint);
    if x.norm() < 1e-6 {
        x = y_hint - z * z.dot(&y_hint);
    }
    let x = x.normalize();
    let y = z.cross(&x);
    Pose::from_parts(
        Translation3::from(origin.coords),
        Rotation3::from_basis_unchecked(&[x, y, z]),
    )
}

/// `frame` as armcal's `xyz`/`rpy`.
pub fn to_frame(frame: &Pose) -> Frame<f64> {
    Frame {
        xyz: frame.translation.vector,
        rpy: Vector3::from(rpy(&frame.rotation)),
    }
}

fn rot_z_trans_z(theta: f64, s: f64) -> Pose {
    Pose::from_parts(
        Translation3::new(0.0, 0.0, s),
        Rotation3::from_axis_angle(&Vector3::z_axis(), theta),
    )
}

/// `Rot_x(α) Trans_x(a) Rot_y(β)`: from MDH frame `k−1` to the frame on axis
/// `k` before `θ_k`, `s_k`.
pub fn pre_joint(alpha: f64, a: f64, beta: f64) -> Pose {
    Pose::from_parts(
        Translation3::identity(),
        Rotation3::from_axis_angle(&Vector3::x_axis(), alpha),
    ) * Pose::from_parts(
        Translation3::new(a, 0.0, 0.0),
        Rotation3::from_axis_angle(&Vector3::y_axis(), beta),
    )
}

/// `A_k` at zero reading: `Rot_x(α) Trans_x(a) Rot_y(β) Rot_z(θ) Trans_z(s)`.
pub fn link_at_zero(l: &Link<f64>) -> Pose {
    pre_joint(l.alpha, l.a, l.beta) * rot_z_trans_z(l.theta, l.s)
}

impl Urdf {
    /// The chain `spec` names as armcal's model (see the module header).
    pub fn convert(&self, spec: &ChainSpec) -> Result<Converted, InputError> {
        let chain = self.chain(spec)?;
        let tip_point = spec.tip_point.unwrap_or_else(Vector3::zeros);
        // Walk the path at zero readings: each moving joint's child link frame
        // in the base link, and the fixed joints between.
        let mut fixed_before = Vec::new();
        let mut link_frames: Vec<Pose> = Vec::new();
        let mut at = Pose::identity();
        let mut fixed = Pose::identity();
        for &j in &chain.path {
            let joint = &self.joints[j];
            if joint.kind.moves() {
                fixed_before.push(fixed);
                at = at * fixed * joint.origin;
                link_frames.push(at);
                fixed = Pose::identity();
            } else {
                fixed *= joint.origin;
            }
        }
        let tip_in_last = fixed;
        let tip = at * fixed * Translation3::from(tip_point);
        // Axis lines in the base link: a point and the unit direction.
        let lines: Vec<(Point3<f64>, Vector3<f64>)> = chain
            .moving
            .iter()
            .zip(&link_frames)
            .map(|(&j, f)| {
                (
                    Point3::from(f.translation.vector),
                    (f.rotation * self.joints[j].axis).normalize(),
                )
            })
            .collect();
        let n = lines.len();

        // Frame 0.
        let (p0, z0) = lines[0];
        let foot = p0 + z0 * (-p0.coords).dot(&z0);
        let base = to_frame(&frame_from(foot, z0, Vector3::x(), Vector3::y()));
        let frame0 = base.isometry();

        let mut links: Vec<Link<f64>> = Vec::with_capacity(n);
        let mut hayati = vec![false; n];
        // The frame on axis k before θ_k, s_k, and the (α, a, β) that led to it.
        let mut pre = frame0;
        let mut before = (0.0, 0.0, 0.0);
        let mut dh_frames = Vec::with_capacity(n);
        for k in 0..n {
            let (theta, s, next) = if k + 1 < n {
                let inv = pre.inverse();
                let p = inv * lines[k + 1].0;
                let d = inv.rotation * lines[k + 1].1;
                let sin_gamma = d.x.hypot(d.y);
                if sin_gamma >= SIN_PARALLEL {
                    // Craig: the common normal of z (through 0) and (p, d).
                    let b = d.z;
                    let t = (p.z - b * d.dot(&p.coords)) / (1.0 - b * b);
                    let mut x = Vector3::new(-d.y, d.x, 0.0) / sin_gamma;
                    if (p.coords - Vector3::new(0.0, 0.0, t)).dot(&x) < 0.0 {
                        x = -x;
                    }
                    (x.y.atan2(x.x), t, false)
                } else {
                    // Hayati: where (p, d) crosses z = 0.
                    let c = p - d * (p.z / d.z);
                    let r = c.x.hypot(c.y);
                    let theta = if r < ON_AXIS { 0.0 } else { c.y.atan2(c.x) };
                    (theta, 0.0, true)
                }
            } else {
                // Last frame: x from the tip link's x (or y).
                let r = pre.rotation.inverse() * tip.rotation;
                let x = r * Vector3::x();
                let x = if x.x.hypot(x.y) > 1e-6 {
                    x
                } else {
                    r * Vector3::y()
                };
                (x.y.atan2(x.x), 0.0, false)
            };
            let joint = &self.joints[chain.moving[k]];
            let frame = pre * rot_z_trans_z(theta, s);
            let (alpha, a, beta) = before;
            let mut link = Link::new(
                match joint.kind {
                    JointKind::Prismatic => JointType::Prismatic,
                    _ => JointType::Revolute,
                },
                theta,
                s,
                a,
                alpha,
            );
            link.beta = beta;
            link.limits = joint.limits;
            links.push(link);
            dh_frames.push(frame);
            if k + 1 < n {
                hayati[k + 1] = next;
                let inv = frame.inverse();
                let p = inv * lines[k + 1].0;
                let d = inv.rotation * lines[k + 1].1;
                let alpha = (-d.y).atan2(d.z);
                before = if next {
                    // (p, d) crosses z = 0 on the x axis.
                    let a = p.x - d.x * (p.z / d.z);
                    let a = if a.abs() < ON_AXIS { 0.0 } else { a };
                    (alpha, a, d.x.clamp(-1.0, 1.0).asin())
                } else {
                    // The common normal is the x axis, and the axis crosses it at x = a.
                    (alpha, p.x, 0.0)
                };
                pre = frame * pre_joint(before.0, before.1, before.2);
            }
        }
        let last = dh_frames[n - 1];
        let dh_in_link: Vec<Pose> = link_frames
            .iter()
            .zip(&dh_frames)
            .map(|(l, f)| l.inverse() * f)
            .collect();
        for (k, link) in links.iter_mut().enumerate() {
            link.mass = self.link_mass(&chain, k, &dh_in_link[k]);
        }
        let mut robot = Robot::new(Convention::Mdh, &links)
            .map_err(|e| InputError::new(&self.file, 1, 1, e.to_string()))?;
        robot.base = base;
        robot.tool = to_frame(&(last.inverse() * tip));
        let flange = to_frame(&(last.inverse() * at * fixed));
        Ok(Converted {
            robot,
            chain,
            dh_in_link,
            fixed_before,
            tip_in_last,
            tip_point,
            flange,
            hayati,
        })
    }

    /// The mass properties of the links moving joint `k` of `chain` moves, in
    /// MDH frame `k` (`dh` in the child link's frame).
    fn link_mass(&self, chain: &UrdfChain, k: usize, dh: &Pose) -> Option<LinkMass<f64>> {
        let start = self.joints[chain.moving[k]].child;
        let stop = chain.moving.get(k + 1).copied();
        let (mut mass, mut moment, mut any) = (0.0, Vector3::zeros(), false);
        let mut stack = vec![(start, Pose::identity())];
        while let Some((l, frame)) = stack.pop() {
            if let Some(i) = self.links[l].inertial {
                any = true;
                mass += i.mass;
                moment += (frame * Point3::from(i.com)).coords * i.mass;
            }
            for j in self.children(l) {
                if Some(j) != stop {
                    stack.push((self.joints[j].child, frame * self.joints[j].origin));
                }
            }
        }
        any.then(|| LinkMass {
            mass,
            com: if mass > 0.0 {
                (dh.inverse() * Point3::from(moment / mass)).coords
            } else {
                Vector3::zeros()
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::{joint_motion, parse};
    use super::*;

    /// One joint of a test chain: origin xyz, rpy, axis, type.
    type TestJoint<'a> = ([f64; 3], [f64; 3], [f64; 3], &'a str);

    /// A URDF of `axes` in a chain.
    fn chain_urdf(axes: &[TestJoint<'_>]) -> String {
        let mut s = String::from("<robot name=\"t\">\n<link name=\"l0\"/>\n");
        for (i, (xyz, rpy, axis, kind)) in axes.iter().enumerate() {
            let f = |v: &[f64; 3]| format!("{} {} {}", v[0], v[1], v[2]);
            s += &format!(
                "<link name=\"l{n}\"/>\n<joint name=\"j{n}\" type=\"{kind}\"><parent link=\"l{i}\"/><child link=\"l{n}\"/><origin xyz=\"{}\" rpy=\"{}\"/><axis xyz=\"{}\"/></joint>\n",
                f(xyz),
                f(rpy),
                f(axis),
                n = i + 1
            );
        }
        s + "</robot>\n"
    }

    /// The converted model equals the URDF (its joints composed as the URDF
    /// defines them) to 1e-12 m at random readings, on both sides of the
    /// Hayati threshold, at exact and rounded parallelism, anti-parallel axes,
    /// skewed and negative axes, prismatic joints, and a measured point.
    #[test]
    fn exact_on_both_sides_of_the_parallel_threshold() {
        for gamma in [
            0.0,
            1e-10,
            1e-4,
            0.05,
            0.0999,
            0.1001,
            0.3,
            1.2,
            std::f64::consts::PI - 1e-9,
        ] {
            let text = chain_urdf(&[
                (
                    [0.1, -0.2, 0.3],
                    [0.2, -0.1, 0.4],
                    [0.0, 0.0, 1.0],
                    "revolute",
                ),
                (
                    [0.4, 0.05, 0.02],
                    [gamma, 0.0, 0.0],
                    [0.0, 0.0, 1.0],
                    "revolute",
                ),
                (
                    [0.35, 0.0, 0.1],
                    [0.0, gamma, 0.0],
                    [0.0, 0.0, -1.0],
                    "continuous",
                ),
                (
                    [0.0, 0.1, 0.2],
                    [0.3, 0.2, 0.1],
                    [1.0, 2.0, -0.5],
                    "prismatic",
                ),
                (
                    [0.0, 0.0, 0.0],
                    [0.0, 0.0, 0.0],
                    [1.0, 2.0, -0.5],
                    "revolute",
                ),
                (
                    [0.05, 0.0, 0.1],
                    [1.5, 0.0, 0.0],
                    [0.0, 1.0, 0.0],
                    "revolute",
                ),
            ]);
            let urdf = parse(&text, "t.urdf").unwrap();
            let spec = ChainSpec {
                tip_point: Some(Vector3::new(0.01, 0.02, 0.15)),
                ..Default::default()
            };
            let c = urdf.convert(&spec).unwrap();
            let mut worst = 0.0f64;
            for i in 0..100 {
                let q: Vec<f64> = (0..6)
                    .map(|k| ((i * 7 + k * 13) as f64 * 0.618).sin() * 2.0)
                    .collect();
                let mut want = Pose::identity();
                for (j, &qk) in urdf.joints.iter().zip(&q) {
                    want = want * j.origin * joint_motion(j.kind, &j.axis, qk);
                }
                let want = want * Translation3::new(0.01, 0.02, 0.15);
                let got = c.robot.forward(&q).unwrap();
                worst = worst
                    .max((got.translation.vector - want.translation.vector).norm())
                    .max((got.rotation.matrix() - want.rotation.matrix()).norm());
            }
            assert!(worst < 1e-12, "γ = {gamma}: {worst}");
            // Joint 3's axis is at γ to joint 2's.
            assert_eq!(c.hayati[2], gamma.sin().abs() < SIN_PARALLEL, "γ = {gamma}");
        }
    }

    /// Roll, pitch and yaw reproduce the rotation to a few ulp, also at and
    /// next to the gimbal lock (pitch ±π/2).
    #[test]
    fn rpy_reproduces_the_rotation_everywhere() {
        let mut worst = 0.0f64;
        for i in 0..2000 {
            let t = i as f64;
            let pitch = match i % 4 {
                0 => std::f64::consts::FRAC_PI_2,
                1 => -std::f64::consts::FRAC_PI_2 + 1e-9 * (t * 0.3).sin(),
                _ => (t * 0.77).sin() * 1.6,
            };
            let r =
                Rotation3::from_euler_angles((t * 1.3).sin() * 3.1, pitch, (t * 2.1).cos() * 3.1);
            let [a, b, c] = rpy(&r);
            let back = Rotation3::from_euler_angles(a, b, c);
            worst = worst.max((back.matrix() - r.matrix()).norm());
        }
        assert!(worst < 1e-14, "{worst}");
    }
}
