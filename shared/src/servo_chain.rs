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
//! only when the calibration has orientation. A twist `α` of exactly 0 or
//! ±π/2 (most nominal links) turns the frame by moving two axes instead
//! (`y'' = ±z`, `z'' = ∓y`). The sines and cosines of the joint angles come
//! from [`Sines`]: evaluated, or, for a chain near one whose angles were
//! recorded ([`Angles`]: the calibrated model's chains of a tick near its
//! nominal chain), the recorded ones turned by the small difference `d`,
//! `sin(θ₀ + d) = s₀ cos d + c₀ sin d`, `cos(θ₀ + d) = c₀ cos d − s₀ sin d`,
//! with `|d| ≤ π/4` so that `sin d`, `cos d` need no range reduction; the
//! recording chain's own sines are turned the same way from the angles it
//! last evaluated (kept from tick to tick, re-evaluated beyond a quarter
//! turn), so every sine is at most one turn from an evaluated one per
//! chain and no rounding accumulates over ticks. The joint line is that of the
//! frame before `A_m` in D-H and after it in modified D-H, as in
//! [`crate::LinkAxes`]; the centre of mass of link `m` is its `com` in the frame
//! after `A_m` ([`crate::LinkMass`]), the frame's origin for a link without
//! mass properties (the proxy of [`crate::effects`]). Lengths `a`, `s` are
//! multiplied by a factor (thermal expansion) as in
//! [`Prepared::chain_scaled_into`]. Measurement frame, metres and radians; the
//! tests check every quantity against [`crate::Chain`].

use nalgebra::{IsometryMatrix3, Matrix3, Point3, Translation3, Vector3};

use crate::kinematics::{Prepared, PreparedLink, Twist};
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
/// Fixed arrays with a count each, written by index: a compensation keeps one
/// in the workspace of its [`crate::compensation::Stream`], so that nothing is cleared per
/// tick, and a store by index costs less than a push on the controller.
#[derive(Clone, Debug)]
pub struct ServoChain<T: Real> {
    lines: [JointLine<T>; MAX_JOINTS],
    centres: [Point3<T>; MAX_JOINTS],
    line_count: usize,
    centre_count: usize,
    /// The measured frame `base · A_1 ⋯ A_M · tool` (its rotation the
    /// flange's unless [`Wanted::rotation`]).
    pub end: IsometryMatrix3<T>,
}

impl<T: Real> Default for ServoChain<T> {
    fn default() -> Self {
        let line = JointLine {
            w: Vector3::zeros(),
            rho: Point3::origin(),
        };
        Self {
            lines: [line; MAX_JOINTS],
            centres: [Point3::origin(); MAX_JOINTS],
            line_count: 0,
            centre_count: 0,
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

    /// The axis line of each joint, when [`Wanted::lines`] (else none).
    #[inline]
    pub fn lines(&self) -> &[JointLine<T>] {
        &self.lines[..self.line_count]
    }

    /// The centre of mass of each link, when [`Wanted::centres`] (else none).
    #[inline]
    pub fn centres(&self) -> &[Point3<T>] {
        &self.centres[..self.centre_count]
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

    /// Turned about its own x by a link's twist: by a move of two axes when
    /// it is none or a quarter turn exactly.
    #[inline(always)]
    fn twist(&mut self, l: &PreparedLink<T>) {
        match l.twist {
            Twist::None => {}
            Twist::Quarter => {
                let y = self.z;
                self.z = -self.y;
                self.y = y;
            }
            Twist::MinusQuarter => {
                let y = -self.z;
                self.z = self.y;
                self.y = y;
            }
            Twist::Other => self.rot_x(l.sin_cos_alpha),
        }
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

/// Each link's angle `θ` of one chain, with its sine and cosine: a later
/// chain at nearby angles (the calibrated model's near the nominal one's)
/// turns these by the difference instead of evaluating new ones
/// ([`Sines::Near`]). The recording chain's own sines come the same way from
/// the last angles it *evaluated* (its base, kept from tick to tick while
/// within a quarter turn): each is one turn of an evaluated value, so no
/// rounding accumulates from tick to tick.
#[derive(Clone, Debug)]
pub struct Angles<T: Real> {
    /// The recording chain's angles, sines and cosines.
    recorded: Sampled<T>,
    /// The last evaluated angle of each link, with its sine and cosine.
    base: Sampled<T>,
}

/// Angles with their sines and cosines (valid below `count`).
#[derive(Clone, Debug)]
struct Sampled<T: Real> {
    theta: [T; MAX_JOINTS],
    sin_cos: [(T, T); MAX_JOINTS],
    count: usize,
}

impl<T: Real> Sampled<T> {
    fn new() -> Self {
        Self {
            theta: [T::zero(); MAX_JOINTS],
            sin_cos: [(T::zero(), T::one()); MAX_JOINTS],
            count: 0,
        }
    }

    /// `(sin θ, cos θ)` of link `m`'s angle `theta`: from the angle `θ₀`
    /// held for that link by the angle-difference formulas when `|θ − θ₀| ≤
    /// π/4` (the small difference's sine and cosine are polynomials alone,
    /// [`Real::sincos_small`]); `beyond(θ)` beyond, or with none held.
    #[inline(always)]
    fn near(&self, m: usize, theta: T, beyond: impl FnOnce(T) -> (T, T)) -> (T, T) {
        if m < self.count {
            let d = theta - self.theta[m];
            let (s0, c0) = self.sin_cos[m];
            // Not for a NaN either: evaluated, it stays NaN.
            if d.abs() <= T::lit(core::f64::consts::FRAC_PI_4) {
                let (sd, cd) = d.sincos_small();
                return (s0 * cd + c0 * sd, c0 * cd - s0 * sd);
            }
        }
        beyond(theta)
    }

    /// Holds `theta` and its `sin_cos` for link `m`.
    #[inline(always)]
    fn set(&mut self, m: usize, theta: T, sin_cos: (T, T)) {
        self.theta[m] = theta;
        self.sin_cos[m] = sin_cos;
    }
}

impl<T: Real> Default for Angles<T> {
    /// None recorded.
    fn default() -> Self {
        Self {
            recorded: Sampled::new(),
            base: Sampled::new(),
        }
    }
}

impl<T: Real> Angles<T> {
    /// `(sin θ, cos θ)` of link `m`'s angle `theta`: near the recorded angle
    /// of that link ([`Sampled::near`]), else evaluated.
    #[inline(always)]
    fn near(&self, m: usize, theta: T) -> (T, T) {
        self.recorded.near(m, theta, T::sincos)
    }

    /// Records link `m`'s angle `theta` and returns its sine and cosine:
    /// near the base ([`Sampled::near`]), else evaluated and made the base.
    #[inline(always)]
    fn record(&mut self, m: usize, theta: T) -> (T, T) {
        let mut evaluated = false;
        let sin_cos = self.base.near(m, theta, |theta| {
            evaluated = true;
            theta.sincos()
        });
        if evaluated {
            self.base.set(m, theta, sin_cos);
        }
        self.recorded.set(m, theta, sin_cos);
        sin_cos
    }

    /// Ends a recording of `n` links: every link below `n` has a base now
    /// (held, or just evaluated).
    #[inline(always)]
    fn end_record(&mut self, n: usize) {
        self.recorded.count = n;
        self.base.count = self.base.count.max(n);
    }
}

/// Where the sine and cosine of each link's angle come from.
#[derive(Debug)]
pub enum Sines<'a, T: Real> {
    /// Evaluated ([`Real::sincos`]).
    Evaluate,
    /// Evaluated and recorded, for chains near this one.
    Record(&'a mut Angles<T>),
    /// From a chain's record, when within a quarter turn of it
    /// ([`Angles`]).
    Near(&'a Angles<T>),
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
        self.servo_chain_with(q, factor, wanted, Sines::Evaluate, out)
    }

    /// [`Self::servo_chain_into`], with the sines and cosines of the joint
    /// angles from `sines`.
    pub fn servo_chain_with(
        &self,
        q: &[T],
        factor: T,
        wanted: Wanted,
        mut sines: Sines<'_, T>,
        out: &mut ServoChain<T>,
    ) -> Result<(), ModelError> {
        let n = self.dof();
        crate::model::check_joint_count(n, q.len())?;
        let mut f = Axes::of(&self.base);
        let mdh = self.convention == Convention::Mdh;
        for (m, (l, &qm)) in self.links.iter().zip(q).enumerate() {
            let link = &l.link;
            let (theta, s) = match link.joint {
                JointType::Revolute => (link.theta + qm, link.s * factor),
                JointType::Prismatic => (link.theta, link.s * factor + qm),
            };
            let sin_cos = match &mut sines {
                Sines::Evaluate => theta.sincos(),
                Sines::Record(angles) => angles.record(m, theta),
                Sines::Near(angles) => angles.near(m, theta),
            };
            let a = link.a * factor;
            let tilted = link.beta != T::zero();
            if mdh {
                f.o += f.x * a;
                f.twist(l);
                if tilted {
                    f.rot_y(l.sin_cos_beta);
                }
                f.o += f.z * s;
                f.rot_z(sin_cos);
            } else {
                if wanted.lines {
                    out.lines[m] = JointLine {
                        w: f.z,
                        rho: Point3::from(f.o),
                    };
                }
                f.rot_z(sin_cos);
                f.o += f.z * s + f.x * a;
                f.twist(l);
                if tilted {
                    f.rot_y(l.sin_cos_beta);
                }
            }
            if mdh && wanted.lines {
                out.lines[m] = JointLine {
                    w: f.z,
                    rho: Point3::from(f.o),
                };
            }
            if wanted.centres {
                let centre = match &link.mass {
                    Some(m) => f.point(&m.com),
                    None => f.o,
                };
                out.centres[m] = Point3::from(centre);
            }
        }
        if let Sines::Record(angles) = &mut sines {
            angles.end_record(n);
        }
        out.line_count = if wanted.lines { n } else { 0 };
        out.centre_count = if wanted.centres { n } else { 0 };
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
                for (m, line) in servo.lines().iter().enumerate() {
                    assert!(near(&line.w, &chain.axes[m].w), "{convention:?} w {m}");
                    assert!(near(&line.rho.coords, &chain.axes[m].rho.coords));
                }
                for (m, centre) in servo.centres().iter().enumerate() {
                    let frame = &chain.links[m];
                    let want = match &links[m].mass {
                        Some(lm) => frame * Point3::from(lm.com * 1.0),
                        None => Point3::from(frame.translation.vector),
                    };
                    assert!(near(&centre.coords, &want.coords), "centre {m}");
                }
                assert_eq!(servo.lines().len(), 4);
                assert_eq!(servo.centres().len(), 4);
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
                assert!(point_only.lines().is_empty() && point_only.centres().is_empty());
            }
        }
    }

    /// A chain whose sines come from a nearby chain's record equals the one
    /// that evaluates them: in `f64` to rounding (1e-14), in `f32` to a few
    /// units in the last place of the turned sines (their error below 2e-7,
    /// times levers under 1.5 m, summed over four links: 1e-6). Differences
    /// up to just under a quarter turn use the record, larger ones evaluate;
    /// the first recording (nothing held yet) evaluates, and changes
    /// nothing. A recording chain's own sines, turned from the angles it last
    /// evaluated (its base), are one turn from exact too; a chain near such
    /// a record is two turns from exact (twice the error: 2e-6).
    #[test]
    fn sines_near_a_record_equal_evaluated_ones() {
        let (r, p) = (JointType::Revolute, JointType::Prismatic);
        let links = [
            Link::new(r, 0.1, 0.3, 0.2, core::f64::consts::FRAC_PI_2),
            Link::new(p, -0.4, 0.1, 0.5, 0.0),
            Link::new(r, 0.7, -0.2, 0.3, -core::f64::consts::FRAC_PI_2),
            Link::new(r, -1.1, 0.15, -0.25, -1.3),
        ];
        let robot = Robot::new(Convention::Dh, &links).unwrap();
        let all = Wanted {
            lines: true,
            centres: true,
            rotation: true,
        };
        let q0 = [0.3, 0.05, -0.8, 1.9];
        // Each within a quarter turn of q0, or with one or two joints beyond
        // it; the prismatic joint's angle does not change.
        let nearby = [
            [0.3, 0.05, -0.8, 1.9],
            [1.08, 0.3, -1.55, 1.2],
            [-0.4, -0.2, 0.0, 3.0],
        ];
        let f32_gaps = gaps::<f32>(&robot, &q0, &nearby, all);
        assert!(f32_gaps.near < 1e-6, "f32: {:e}", f32_gaps.near);
        assert!(f32_gaps.recorded < 1e-6, "f32: {:e}", f32_gaps.recorded);
        assert!(f32_gaps.twice < 2e-6, "f32: {:e}", f32_gaps.twice);
        let f64_gaps = gaps::<f64>(&robot, &q0, &nearby, all);
        for gap in [f64_gaps.near, f64_gaps.recorded, f64_gaps.twice] {
            assert!(gap < 1e-14, "f64: {gap:e}");
        }
    }

    /// The largest differences from the chain with evaluated sines.
    struct Gaps {
        /// Of chains near the record at `q0`.
        near: f64,
        /// Of recording chains, each turned from the angles evaluated last.
        recorded: f64,
        /// Of chains near those records.
        twice: f64,
    }

    /// [`Gaps`] of chains in `T` at each of `nearby` (and, near their
    /// records, 0.01 rad further): the largest difference of any frame
    /// entry, joint line or centre. Recording at `q0` first must change
    /// nothing.
    fn gaps<T: Real>(robot: &Robot<f64>, q0: &[f64], nearby: &[[f64; 4]], all: Wanted) -> Gaps {
        let prepared = robot.cast::<T>().prepare();
        let cast = |q: &[f64]| -> heapless::Vec<T, MAX_JOINTS> {
            crate::model::bounded(q.iter().map(|x| T::lit(*x)))
        };
        let chain = |q: &[f64], sines: Sines<'_, T>| {
            let mut out = ServoChain::default();
            prepared
                .servo_chain_with(&cast(q), T::one(), all, sines, &mut out)
                .unwrap();
            out
        };
        let gap = |a: &ServoChain<T>, b: &ServoChain<T>| {
            let mut worst = (a.end.to_homogeneous() - b.end.to_homogeneous())
                .abs()
                .max()
                .to_f64();
            for (a, b) in a.lines().iter().zip(b.lines()) {
                worst = worst.max((a.w - b.w).norm().to_f64());
                worst = worst.max((a.rho - b.rho).norm().to_f64());
            }
            for (a, b) in a.centres().iter().zip(b.centres()) {
                worst = worst.max((a - b).norm().to_f64());
            }
            worst
        };
        let mut angles = Angles::default();
        let recorded = chain(q0, Sines::Record(&mut angles));
        assert_eq!(recorded.end, chain(q0, Sines::Evaluate).end);
        let mut gaps = Gaps {
            near: 0.0,
            recorded: 0.0,
            twice: 0.0,
        };
        for q in nearby {
            let exact = chain(q, Sines::Evaluate);
            gaps.near = gaps.near.max(gap(&chain(q, Sines::Near(&angles)), &exact));
        }
        for q in nearby {
            let exact = chain(q, Sines::Evaluate);
            let recorded = chain(q, Sines::Record(&mut angles));
            gaps.recorded = gaps.recorded.max(gap(&recorded, &exact));
            let further: [f64; 4] = core::array::from_fn(|m| q[m] + 0.01);
            let near = chain(&further, Sines::Near(&angles));
            gaps.twice = gaps
                .twice
                .max(gap(&near, &chain(&further, Sines::Evaluate)));
        }
        gaps
    }
}
