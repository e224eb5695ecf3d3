//! Forward kinematics of the measured frame and point, and the chain of link frames
//! from which the Jacobians are built.
//!
//! The measured frame is `T = base · A_1(q_1) ⋯ A_M(q_M) · tool` (`docs/file-formats.md` §1,
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
//!
//! Frames are composed by [`compose`], the product of two rigid transforms
//! written out on nalgebra's column-major arrays (cheaper on the controller than
//! the generic product). [`Prepared::chain_scaled_into`] evaluates the chain
//! with every length `a`, `s` times a factor (thermal expansion) without
//! copying the model, and [`Prepared::chain_into`] fills a chain in place.

use heapless::Vec;
use nalgebra::{IsometryMatrix3, Point3, Vector3};

use crate::dh::transform;
use crate::{Convention, Frame, JointType, Link, MAX_JOINTS, ModelError, Real, Robot};

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
    /// The axis of Hayati's tilt `β_m`: the y axis of the frame in which it turns.
    pub v: Vector3<T>,
    /// A point on that axis.
    pub tau: Point3<T>,
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
    /// The lines of the base frame's parameters, in the measurement frame.
    pub base_axes: FrameAxes<T>,
    /// The lines of the tool frame's parameters, in the flange frame.
    pub tool_axes: FrameAxes<T>,
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

/// The lines of the six elementary motions of a base or tool frame
/// `Trans(x, y, z) Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`, in its parent frame:
/// the translations run along the parent's axes, and the rotations turn about
/// lines through the frame's origin along the parent's `z` (yaw),
/// `Rot_z(yaw)·y` (pitch) and `Rot_z(yaw) Rot_y(pitch)·x` (roll).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameAxes<T: Real> {
    /// The frame's origin in its parent.
    pub origin: Point3<T>,
    /// Axis of the roll rotation.
    pub roll: Vector3<T>,
    /// Axis of the pitch rotation.
    pub pitch: Vector3<T>,
    /// Axis of the yaw rotation (the parent's z).
    pub yaw: Vector3<T>,
}

/// Column `j` of the rotation of `frame`.
#[inline]
fn column<T: Real>(frame: &IsometryMatrix3<T>, j: usize) -> Vector3<T> {
    let c = &frame.rotation.matrix().data.0[j];
    Vector3::new(c[0], c[1], c[2])
}

/// The product `a · b` of two rigid transforms, written out on the column-major
/// arrays: nalgebra's generic product costs more on the controller.
#[inline]
pub fn compose<T: Real>(a: &IsometryMatrix3<T>, b: &IsometryMatrix3<T>) -> IsometryMatrix3<T> {
    let ra = &a.rotation.matrix().data.0;
    let rb = &b.rotation.matrix().data.0;
    let tb = &b.translation.vector;
    // Column j of Ra·Rb is Ra·(column j of Rb); the translation is ta + Ra·tb.
    let rot = |v: [T; 3]| -> [T; 3] {
        let mut out = [T::zero(); 3];
        for (i, o) in out.iter_mut().enumerate() {
            *o = ra[0][i] * v[0] + ra[1][i] * v[1] + ra[2][i] * v[2];
        }
        out
    };
    let t = rot([tb.x, tb.y, tb.z]);
    let ta = &a.translation.vector;
    IsometryMatrix3::from_parts(
        nalgebra::Translation3::new(ta.x + t[0], ta.y + t[1], ta.z + t[2]),
        nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_data(
            nalgebra::ArrayStorage([rot(rb[0]), rot(rb[1]), rot(rb[2])]),
        )),
    )
}

/// `Rot_y(β)` from `(sin β, cos β)`.
fn rot_y<T: Real>((s, c): (T, T)) -> IsometryMatrix3<T> {
    let (z, one) = (T::zero(), T::one());
    IsometryMatrix3::from_parts(
        nalgebra::Translation3::identity(),
        nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(
            c, z, s, z, one, z, -s, z, c,
        )),
    )
}

impl<T: Real> FrameAxes<T> {
    /// The axes of `frame`.
    pub fn of(frame: &Frame<T>) -> Self {
        let (sy, cy) = frame.rpy.z.sincos();
        let (sp, cp) = frame.rpy.y.sincos();
        Self {
            origin: Point3::from(frame.xyz),
            // Rot_z(yaw) Rot_y(pitch) x = (cy cp, sy cp, −sp); Rot_z(yaw) y = (−sy, cy, 0).
            roll: Vector3::new(cy * cp, sy * cp, -sp),
            pitch: Vector3::new(-sy, cy, T::zero()),
            yaw: Vector3::z(),
        }
    }
}

/// One link ready for repeated evaluation: the sine and cosine of its constant
/// twist computed once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PreparedLink<T: Real> {
    pub(crate) link: Link<T>,
    pub(crate) sin_cos_alpha: (T, T),
    pub(crate) sin_cos_beta: (T, T),
    /// The twist when it is exactly none or a quarter turn.
    pub(crate) twist: Twist,
}

/// A link's twist `α` when it is one of the angles of most nominal models
/// exactly: the frame then turns about its x axis by moving two axes (and
/// negating one) instead of twelve products ([`crate::servo_chain`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Twist {
    /// `α = 0`.
    None,
    /// `α = π/2`: `y' = z`, `z' = −y`.
    Quarter,
    /// `α = −π/2`: `y' = −z`, `z' = y`.
    MinusQuarter,
    /// Any other: by `sin_cos_alpha`.
    Other,
}

impl Twist {
    fn of<T: Real>(alpha: T) -> Self {
        let quarter = T::lit(core::f64::consts::FRAC_PI_2);
        if alpha == T::zero() {
            Self::None
        } else if alpha == quarter {
            Self::Quarter
        } else if alpha == -quarter {
            Self::MinusQuarter
        } else {
            Self::Other
        }
    }
}

/// A robot made ready for many evaluations: the trigonometry of every constant
/// angle (link twists, base and tool rotations) computed once, so that a forward
/// kinematics costs one sine and cosine per joint. Identification prepares the
/// model once per parameter update and evaluates it at every pose; the
/// controller prepares it once per calibration load.
#[derive(Clone, Debug)]
pub struct Prepared<T: Real> {
    pub(crate) convention: Convention,
    pub(crate) links: Vec<PreparedLink<T>, MAX_JOINTS>,
    pub(crate) base: IsometryMatrix3<T>,
    pub(crate) tool: IsometryMatrix3<T>,
    base_axes: FrameAxes<T>,
    tool_axes: FrameAxes<T>,
}

impl<T: Real> Robot<T> {
    /// This robot made ready for repeated evaluation.
    pub fn prepare(&self) -> Prepared<T> {
        Prepared {
            convention: self.convention,
            links: crate::model::bounded(self.links.iter().map(|l| PreparedLink {
                link: *l,
                sin_cos_alpha: l.alpha.sincos(),
                sin_cos_beta: l.beta.sincos(),
                twist: Twist::of(l.alpha),
            })),
            base: self.base.isometry(),
            tool: self.tool.isometry(),
            base_axes: FrameAxes::of(&self.base),
            tool_axes: FrameAxes::of(&self.tool),
        }
    }

    /// The measured frame `base · A_1(q_1) ⋯ A_M(q_M) · tool`.
    pub fn forward(&self, q: &[T]) -> Result<IsometryMatrix3<T>, ModelError> {
        self.prepare().forward(q)
    }

    /// The measured point: the origin of [`Robot::forward`].
    pub fn measured_point(&self, q: &[T]) -> Result<Point3<T>, ModelError> {
        self.forward(q).map(|t| Point3::from(t.translation.vector))
    }

    /// Every link frame and line at configuration `q`.
    pub fn chain(&self, q: &[T]) -> Result<Chain<T>, ModelError> {
        self.prepare().chain(q)
    }
}

impl<T: Real> Prepared<T> {
    /// The number of joints, M.
    #[inline]
    pub fn dof(&self) -> usize {
        self.links.len()
    }

    /// The same robot with every link length `a` and offset `s` multiplied by
    /// `factor` (thermal expansion, [`crate::effects::Effect::ThermalExpansion`]):
    /// what preparing the scaled robot gives, without recomputing any sine.
    pub fn with_length_factor(&self, factor: T) -> Self {
        let mut out = self.clone();
        for l in out.links.iter_mut() {
            l.link.a *= factor;
            l.link.s *= factor;
        }
        out
    }

    fn check_joints(&self, q: &[T]) -> Result<(), ModelError> {
        crate::model::check_joint_count(self.dof(), q.len())
    }

    /// `A_m` of link `l` at reading `q`, with its lengths `a`, `s` times `factor`
    /// (the joint's own travel of a prismatic joint is not scaled).
    #[inline]
    fn link(&self, l: &PreparedLink<T>, q: T, factor: T) -> IsometryMatrix3<T> {
        let link = &l.link;
        let (theta, s) = match link.joint {
            JointType::Revolute => (link.theta + q, link.s * factor),
            JointType::Prismatic => (link.theta, link.s * factor + q),
        };
        let a = link.a * factor;
        if link.beta == T::zero() {
            return transform(self.convention, theta, s, a, l.sin_cos_alpha);
        }
        let tilt = rot_y(l.sin_cos_beta);
        let (z, one) = (T::zero(), T::one());
        match self.convention {
            // Rot_z(θ) Trans_z(s) Trans_x(a) Rot_x(α) · Rot_y(β)
            Convention::Dh => compose(
                &transform(Convention::Dh, theta, s, a, l.sin_cos_alpha),
                &tilt,
            ),
            // Rot_x(α) Trans_x(a) · Rot_y(β) · Rot_z(θ) Trans_z(s)
            Convention::Mdh => compose(
                &compose(&transform(Convention::Mdh, z, z, a, l.sin_cos_alpha), &tilt),
                &transform(Convention::Dh, theta, s, z, (z, one)),
            ),
        }
    }

    /// The measured frame `base · A_1(q_1) ⋯ A_M(q_M) · tool`.
    pub fn forward(&self, q: &[T]) -> Result<IsometryMatrix3<T>, ModelError> {
        self.check_joints(q)?;
        let mut t = self.base;
        for (l, &qm) in self.links.iter().zip(q) {
            t = compose(&t, &self.link(l, qm, T::one()));
        }
        Ok(compose(&t, &self.tool))
    }

    /// Every link frame and line at configuration `q`.
    pub fn chain(&self, q: &[T]) -> Result<Chain<T>, ModelError> {
        let mut chain = self.empty_chain();
        self.chain_into(q, &mut chain)?;
        Ok(chain)
    }

    /// A chain without links, to be filled by [`Prepared::chain_into`]: cheap to
    /// make (its link storage is not initialised), unlike a [`Chain`] moved out
    /// of a `Result`.
    pub fn empty_chain(&self) -> Chain<T> {
        Chain {
            base: self.base,
            links: Vec::new(),
            axes: Vec::new(),
            flange: self.base,
            end: self.base,
            joints: Vec::new(),
            base_axes: self.base_axes,
            tool_axes: self.tool_axes,
        }
    }

    /// [`Prepared::chain`] into an existing [`Chain`], which a caller evaluating
    /// many configurations reuses instead of moving a new one out each time.
    pub fn chain_into(&self, q: &[T], chain: &mut Chain<T>) -> Result<(), ModelError> {
        self.chain_scaled_into(q, T::one(), chain)
    }

    /// [`Prepared::chain_into`] with every link length `a` and offset `s` times
    /// `factor`: the chain of [`Prepared::with_length_factor`]`(factor)`, without
    /// copying the model (two multiplications per link).
    pub fn chain_scaled_into(
        &self,
        q: &[T],
        factor: T,
        chain: &mut Chain<T>,
    ) -> Result<(), ModelError> {
        self.check_joints(q)?;
        chain.links.clear();
        chain.axes.clear();
        chain.joints.clear();
        let mut before = self.base;
        for (l, &qm) in self.links.iter().zip(q) {
            let after = compose(&before, &self.link(l, qm, factor));
            // The z line and the x line of this link, from the frame that carries each.
            let (sb, cb) = l.sin_cos_beta;
            let (sa, ca) = l.sin_cos_alpha;
            let line = match self.convention {
                // The x line is that of the frame before Rot_y(β): after·Rot_y(−β)·x;
                // β turns about that frame's y, which Rot_y(β) leaves in place.
                Convention::Dh => LinkAxes {
                    w: column(&before, 2),
                    rho: Point3::from(before.translation.vector),
                    u: column(&after, 0) * cb + column(&after, 2) * sb,
                    sigma: Point3::from(after.translation.vector),
                    v: column(&after, 1),
                    tau: Point3::from(after.translation.vector),
                },
                // β turns about the y axis of before·Rot_x(α)·Trans_x(a).
                Convention::Mdh => LinkAxes {
                    w: column(&after, 2),
                    rho: Point3::from(after.translation.vector),
                    u: column(&before, 0),
                    sigma: Point3::from(before.translation.vector),
                    v: column(&before, 1) * ca + column(&before, 2) * sa,
                    tau: Point3::from(
                        before.translation.vector + column(&before, 0) * (l.link.a * factor),
                    ),
                },
            };
            // Capacity is MAX_JOINTS on all three: a Robot never holds more links.
            let _ = chain.links.push(after);
            let _ = chain.axes.push(line);
            let _ = chain.joints.push(l.link.joint);
            before = after;
        }
        chain.base = self.base;
        chain.flange = before;
        chain.end = compose(&before, &self.tool);
        chain.base_axes = self.base_axes;
        chain.tool_axes = self.tool_axes;
        Ok(())
    }
}
