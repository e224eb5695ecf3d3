//! The forward solution expanded to second order in the parameter errors:
//! Kirchner, Gurumoorthy & Prinz, "A Perturbation Approach to Robot Calibration",
//! CMU-RI-TR-85-9, 1985, section 2 (eqs. 2.3–2.22).
//!
//! ## The paper's expansion
//! The ideal (nominal) and the real forward solutions are the products of the
//! link matrices with the nominal parameters `p_i` and with `p_i + Δp_i`:
//!
//! ```text
//! T^i = A_1 A_2 ⋯ A_M                                            (2.3)
//! T^r = A_1^r A_2^r ⋯ A_M^r                                      (2.4)
//! ```
//!
//! (here with the robot's `base` in front and `tool` behind, [`Robot::forward`]).
//! The derivative of a link matrix by one of its own parameters is the matrix
//! times a constant operator, `∂A_i/∂p = A_i Q_i^p` (2.9–2.12), and carried to
//! the base frame the operator becomes
//!
//! ```text
//! Ω_i^p = A_1⋯A_i Q_i^p A_i⁻¹⋯A_1⁻¹                              (2.20)
//! ```
//!
//! which is the 4×4 form `ξ̂` of the twist `ξ = [νdφ; dη]` that
//! [`Chain::column`] returns: `ξ̂ = [[ [νdφ]×, dη ], [0, 0]] = (∂T/∂p) T⁻¹`.
//! The expansion of the paper is then
//!
//! ```text
//! T^r − T^i = Σ_i K_i Δp_i + Σ_i Σ_j Δp_i L_ij Δp_j + O(Δp³)     (2.22)
//!
//! K_i  = ∂T/∂p_i                = ξ̂_i T^i
//! L_ij = L_ji = ½ ∂²T/∂p_i∂p_j  = ½ ξ̂_i ξ̂_j T^i    (p_i before p_j in the chain)
//! L_ii         = ½ ∂²T/∂p_i²    = ½ ξ̂_i ξ̂_i T^i                 (2.23)
//! ```
//!
//! with `i, j` over every parameter in error (the paper's 24 = 4M for M = 6).
//!
//! ## Why this holds, and the factor ½
//! Every parameter enters `T` as one elementary screw factor, a rotation about or
//! a translation along a line fixed in the frame before it: `Rot_z(θ) Trans_z(s)
//! Trans_x(a) Rot_x(α)` per link in standard D-H (the paper's convention, Paul's
//! eq. 2.1), `Rot_x(α) Trans_x(a) Rot_z(θ) Trans_z(s)` in modified D-H, and
//! `Trans(x, y, z) Rot_z(yaw) Rot_y(pitch) Rot_x(roll)` for base and tool. The
//! real factor is the nominal one times its increment `exp(X Δp)`; moving every
//! increment to the front of the chain (conjugating it by the nominal factors it
//! passes, which turns `X` into the nominal twist `ξ̂` of [`Chain::column`]) turns
//! the real solution into a product of exponentials, in chain order:
//!
//! ```text
//! T^r = exp(ξ̂_1 Δp_1) exp(ξ̂_2 Δp_2) ⋯ exp(ξ̂_N Δp_N) T^i
//! ```
//!
//! so that, with `E = T^r (T^i)⁻¹ − I`,
//!
//! ```text
//! E = Σ_i ξ̂_i Δp_i  +  Σ_{i<j} ξ̂_i ξ̂_j Δp_i Δp_j + ½ Σ_i ξ̂_i² Δp_i²  + O(Δp³)
//!   = E₁ + E₂ + O(Δp³)
//! ```
//!
//! which is (2.22) with the `L_ij` above. The derivation holds in both D-H
//! conventions and for base and tool parameters; the paper derives it for
//! standard D-H. Its printed (2.22) writes `L_ij = ∂²T/∂p_i∂p_j`, without the ½
//! of the Taylor series (and 2.21 shows `∂²A_1/∂α_1²` as the coefficient of
//! `Δα_1Δα_1`); with that literal coefficient the expansion is wrong at second
//! order. The ½ is used here.
//!
//! `E₂` is evaluated in one pass in chain order, with the prefix sum
//! `S_j = Σ_{i<j} ξ̂_i Δp_i`:  `E₂ = Σ_j (S_j + ½ ξ̂_j Δp_j) ξ̂_j Δp_j`.
//!
//! ## Twist form (the Cartesian coordinates of section 3)
//! The pose error of Mirman & Gupta eq. (15), [`pose_error`](crate::pose_error())`(T^r, T^i)`,
//! is a *linear* function of `E` (exactly, to all orders):
//!
//! ```text
//! pose_error(T^r, T^i) = P(E) = [ vee(skew E_R) ; e_t + sym(E_R) p ]
//! ```
//!
//! where `E_R`, `e_t` are the rotation block and translation column of `E` and
//! `p` the nominal measured point. Taking `x = pose_error` as the paper's six
//! Cartesian coordinates (3.3), the twist expansion is
//!
//! ```text
//! Δx = Σ_i K_i Δp_i + Σ_i Σ_j Δp_i L_ij Δp_j + O(Δp³)            (3.3), (3.4)
//! K_i = ξ_i = chain.column(p_i)        L_ij = P(½ ξ̂_i ξ̂_j)
//! ```
//!
//! and [`Perturbation::pose_error`] is `P(E₁ + E₂)`. The rotation block of `E₁`
//! is skew, so `P(E₁) = Σ ξ_i Δp_i` exactly: the special-Jacobian prediction.
//!
//! ## Joint variables
//! "At this point there is no difference between link variables and link
//! parameters" (section 2): a joint correction `δq_m` is the error of
//! `Param::Theta(m)` (revolute) or `Param::S(m)` (prismatic). One expansion in
//! `(δq, Δp)` together gives the terms of the compensation (4.5)–(4.9) to second
//! order: the `Δp` terms are the source `f` (4.8), the `δq` terms the ideal
//! Jacobian, the `δq Δp` cross terms its first-order change to the real Jacobian
//! `J_r` (4.4), and the `δq δq` terms `H` (4.7).
//!
//! ## Frames and units
//! Everything is in the measurement frame, after `base`, like [`Chain`]. Angles in
//! rad; lengths in the model's unit (SI, m, in this crate; the host's
//! reproduction of the paper runs the PUMA in inches). Twists are `[νdφ; dη]`,
//! rotation first. No allocation: errors are gathered into a fixed array sized by
//! [`MAX_JOINTS`].

use core::fmt;

use nalgebra::{IsometryMatrix3, Matrix3, Matrix4, Vector3};

use crate::{Chain, Convention, FrameAxis, MAX_JOINTS, ModelError, Param, Real, Robot, Twist};

/// Slots of the chain order: six base factors, four per joint, six tool factors.
const SLOTS: usize = 6 + 5 * MAX_JOINTS + 6;

/// The order of a frame's six factors in `Trans(x, y, z) Rot_z Rot_y Rot_x`.
const FRAME_ORDER: [FrameAxis; 6] = [
    FrameAxis::X,
    FrameAxis::Y,
    FrameAxis::Z,
    FrameAxis::Rz,
    FrameAxis::Ry,
    FrameAxis::Rx,
];

/// Why an expansion cannot be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum PerturbationError {
    /// The joint vector does not fit the model.
    Model(ModelError),
    /// A parameter of a joint the model does not have.
    NoSuchJoint {
        /// The parameter asked for.
        param: Param,
        /// The model's joint count.
        joints: usize,
    },
}

impl From<ModelError> for PerturbationError {
    fn from(e: ModelError) -> Self {
        Self::Model(e)
    }
}

impl fmt::Display for PerturbationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Model(e) => e.fmt(f),
            Self::NoSuchJoint { param, joints } => write!(
                f,
                "{param}: the model has {joints} joints; give errors of joints 1 to {joints} only"
            ),
        }
    }
}

impl core::error::Error for PerturbationError {}

/// The position of `param`'s elementary factor in the chain, base to tool (for
/// joint indices below [`MAX_JOINTS`]): the order of `L_ij`'s product `ξ̂_i ξ̂_j`.
/// Within a link, `θ, s, a, α, β` in standard D-H and `α, a, β, θ, s` in modified D-H;
/// in base and tool, `x, y, z, yaw, pitch, roll`.
pub fn chain_order(convention: Convention, param: Param) -> usize {
    let frame = |ax: FrameAxis| FRAME_ORDER.iter().position(|&a| a == ax).unwrap_or(0);
    let link = |m: usize, k: usize| 6 + 5 * m + k;
    match (convention, param) {
        (_, Param::Base(ax)) => frame(ax),
        (Convention::Dh, Param::Theta(m)) | (Convention::Mdh, Param::Alpha(m)) => link(m, 0),
        (Convention::Dh, Param::S(m)) | (Convention::Mdh, Param::A(m)) => link(m, 1),
        (Convention::Dh, Param::A(m)) | (Convention::Mdh, Param::Beta(m)) => link(m, 2),
        (Convention::Dh, Param::Alpha(m)) | (Convention::Mdh, Param::Theta(m)) => link(m, 3),
        (Convention::Dh, Param::Beta(m)) | (Convention::Mdh, Param::S(m)) => link(m, 4),
        (_, Param::Tool(ax)) => 6 + 5 * MAX_JOINTS + frame(ax),
    }
}

/// The parameter at chain position `slot` (the inverse of [`chain_order`]).
fn slot_param(convention: Convention, slot: usize) -> Param {
    if slot < 6 {
        return Param::Base(FRAME_ORDER[slot]);
    }
    if slot >= 6 + 5 * MAX_JOINTS {
        return Param::Tool(FRAME_ORDER[slot - 6 - 5 * MAX_JOINTS]);
    }
    let (m, k) = ((slot - 6) / 5, (slot - 6) % 5);
    let order = match convention {
        Convention::Dh => [
            Param::Theta(m),
            Param::S(m),
            Param::A(m),
            Param::Alpha(m),
            Param::Beta(m),
        ],
        Convention::Mdh => [
            Param::Alpha(m),
            Param::A(m),
            Param::Beta(m),
            Param::Theta(m),
            Param::S(m),
        ],
    };
    order[k]
}

/// The joint index of a link parameter, if it is one.
fn joint_of(param: Param) -> Option<usize> {
    match param {
        Param::Theta(m) | Param::S(m) | Param::A(m) | Param::Alpha(m) | Param::Beta(m) => Some(m),
        Param::Base(_) | Param::Tool(_) => None,
    }
}

/// `[ω]×`, the skew-symmetric matrix of `ω`.
#[inline]
fn skew<T: Real>(w: &Vector3<T>) -> Matrix3<T> {
    let z = T::zero();
    Matrix3::new(z, -w.z, w.y, w.z, z, -w.x, -w.y, w.x, z)
}

/// The rotation part `νdφ` and translation part `dη` of a twist.
#[inline]
fn split<T: Real>(xi: &Twist<T>) -> (Vector3<T>, Vector3<T>) {
    (
        xi.fixed_rows::<3>(0).into_owned(),
        xi.fixed_rows::<3>(3).into_owned(),
    )
}

/// A 4×4 matrix with zero bottom row, `[[r, t], [0, 0]]`.
#[inline]
fn affine<T: Real>(r: &Matrix3<T>, t: &Vector3<T>) -> Matrix4<T> {
    let mut m = Matrix4::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(r);
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(t);
    m
}

/// `ξ̂ = [[ [νdφ]×, dη ], [0, 0]]`, the 4×4 form of a twist (the paper's `Ω`, 2.20).
pub fn hat<T: Real>(twist: &Twist<T>) -> Matrix4<T> {
    let (w, v) = split(twist);
    affine(&skew(&w), &v)
}

/// `P(E)`: the pose error `[νdφ; dη]` (Mirman & Gupta eq. 15) of the frame
/// `(I + E)·nominal` against `nominal`, for any `E` with zero bottom row:
/// `[vee(skew E_R); e_t + sym(E_R) p]`. Exact and linear in `E`.
pub fn error_twist<T: Real>(e: &Matrix4<T>, nominal: &IsometryMatrix3<T>) -> Twist<T> {
    let r = e.fixed_view::<3, 3>(0, 0).into_owned();
    let t = e.fixed_view::<3, 1>(0, 3).into_owned();
    let half = T::lit(0.5);
    let phi = Vector3::new(r.m32 - r.m23, r.m13 - r.m31, r.m21 - r.m12) * half;
    let sym = (r + r.transpose()) * half;
    let eta = t + sym * nominal.translation.vector;
    Twist::new(phi.x, phi.y, phi.z, eta.x, eta.y, eta.z)
}

/// Checks that `param` belongs to a joint of `chain`.
fn check_param<T: Real>(chain: &Chain<T>, param: Param) -> Result<(), PerturbationError> {
    match joint_of(param) {
        Some(m) if m >= chain.dof() => Err(PerturbationError::NoSuchJoint {
            param,
            joints: chain.dof(),
        }),
        _ => Ok(()),
    }
}

/// `K_i = ∂T/∂p_i = ξ̂_i T^i` of eq. (2.22), a 4×4 matrix.
pub fn k_matrix<T: Real>(chain: &Chain<T>, param: Param) -> Result<Matrix4<T>, PerturbationError> {
    check_param(chain, param)?;
    Ok(hat(&chain.column(param)) * chain.end.to_homogeneous())
}

/// `½ ξ̂_i ξ̂_j` with `p_i` before `p_j` in the chain: `L_ij (T^i)⁻¹`.
fn l_operator<T: Real>(
    chain: &Chain<T>,
    convention: Convention,
    pi: Param,
    pj: Param,
) -> Result<Matrix4<T>, PerturbationError> {
    check_param(chain, pi)?;
    check_param(chain, pj)?;
    let (first, second) = if chain_order(convention, pi) <= chain_order(convention, pj) {
        (pi, pj)
    } else {
        (pj, pi)
    };
    Ok(hat(&chain.column(first)) * hat(&chain.column(second)) * T::lit(0.5))
}

/// `L_ij = L_ji = ½ ∂²T/∂p_i∂p_j` of eqs. (2.22)–(2.23), a 4×4 matrix:
/// `½ ξ̂_i ξ̂_j T^i` with `p_i` the earlier of the two in the chain.
pub fn l_matrix<T: Real>(
    chain: &Chain<T>,
    convention: Convention,
    pi: Param,
    pj: Param,
) -> Result<Matrix4<T>, PerturbationError> {
    Ok(l_operator(chain, convention, pi, pj)? * chain.end.to_homogeneous())
}

/// `L_ij` in the twist coordinates `x = pose_error(T^r, T^i)` of section 3 (the
/// `L^i_jk` of eqs. 3.4 and 3.6 at one pose): `P(½ ξ̂_i ξ̂_j)`. The second-order
/// pose error is `Σ_i Σ_j Δp_i l_twist(p_i, p_j) Δp_j`.
pub fn l_twist<T: Real>(
    chain: &Chain<T>,
    convention: Convention,
    pi: Param,
    pj: Param,
) -> Result<Twist<T>, PerturbationError> {
    Ok(error_twist(
        &l_operator(chain, convention, pi, pj)?,
        &chain.end,
    ))
}

/// The measured frame of the real robot expanded to second order in the
/// parameter errors about the ideal one, eq. (2.22).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perturbation<T: Real> {
    /// `T^i`, the nominal measured frame.
    pub nominal: IsometryMatrix3<T>,
    /// The first-order term as a twist: `Σ_i ξ_i Δp_i`, so that
    /// `Σ_i K_i Δp_i = ξ̂ T^i` ([`Perturbation::first_matrix`]).
    pub first: Twist<T>,
    /// The second-order term `E₂ = Σ_i Σ_j Δp_i L_ij Δp_j (T^i)⁻¹`, a 4×4 matrix
    /// with zero bottom row (not a twist: its rotation block has a symmetric part).
    pub second: Matrix4<T>,
}

impl<T: Real> Perturbation<T> {
    /// `E₁ = ξ̂`, the 4×4 form of [`Perturbation::first`].
    #[inline]
    pub fn first_matrix(&self) -> Matrix4<T> {
        hat(&self.first)
    }

    /// The second-order term of the pose error, `P(E₂)`.
    #[inline]
    pub fn second_twist(&self) -> Twist<T> {
        error_twist(&self.second, &self.nominal)
    }

    /// `pose_error(T^r, T^i)` to second order: `first + P(E₂)`, in the
    /// coordinates of [`crate::pose_error()`] (eq. 3.3 with `x = [νdφ; dη]`).
    #[inline]
    pub fn pose_error(&self) -> Twist<T> {
        self.first + self.second_twist()
    }

    /// `T^r − T^i` to first order: `Σ_i K_i Δp_i`.
    #[inline]
    pub fn delta_first(&self) -> Matrix4<T> {
        self.first_matrix() * self.nominal.to_homogeneous()
    }

    /// `T^r − T^i` to second order: `Σ_i K_i Δp_i + Σ_i Σ_j Δp_i L_ij Δp_j` (2.22).
    #[inline]
    pub fn delta(&self) -> Matrix4<T> {
        (self.first_matrix() + self.second) * self.nominal.to_homogeneous()
    }

    /// The predicted real frame to first order, `T^i + Σ_i K_i Δp_i`.
    #[inline]
    pub fn frame_first_order(&self) -> Matrix4<T> {
        self.nominal.to_homogeneous() + self.delta_first()
    }

    /// The predicted real frame to second order, `T^i + Σ K_i Δp_i + Σ Δp_i L_ij Δp_j`.
    /// Its rotation block is orthonormal only to second order.
    #[inline]
    pub fn frame(&self) -> Matrix4<T> {
        self.nominal.to_homogeneous() + self.delta()
    }

    /// The error of the measured point, `P^r − P^i`, to second order: the
    /// translation column of [`Perturbation::delta`].
    #[inline]
    pub fn point_error(&self) -> Vector3<T> {
        self.delta().fixed_view::<3, 1>(0, 3).into_owned()
    }
}

/// Expands the real measured frame about the nominal `chain` to second order in
/// `errors`, a list of `(parameter, Δp)` in any order (a parameter given twice
/// counts with the sum of its errors). `convention` is the model's: it fixes the
/// order of each link's four factors, on which the cross terms depend.
pub fn expand<T: Real>(
    chain: &Chain<T>,
    convention: Convention,
    errors: &[(Param, T)],
) -> Result<Perturbation<T>, PerturbationError> {
    let mut dp = [T::zero(); SLOTS];
    for &(param, d) in errors {
        check_param(chain, param)?;
        dp[chain_order(convention, param)] += d;
    }
    let half = T::lit(0.5);
    let mut first = Twist::zeros();
    // Prefix sum S = Σ_{i<j} ξ̂_i Δp_i and E₂ = (e_r, e_t) as rotation block and translation.
    // Only S's rotation block enters (S + ½X)·X: the bottom rows are zero.
    let mut s_r = Matrix3::zeros();
    let (mut e_r, mut e_t) = (Matrix3::<T>::zeros(), Vector3::<T>::zeros());
    for (slot, &d) in dp.iter().enumerate() {
        if d == T::zero() {
            continue;
        }
        let xi = chain.column(slot_param(convention, slot)) * d;
        let (w, v) = split(&xi);
        let x_r = skew(&w);
        // (S + ½X)·X, with X = [[x_r, v], [0, 0]].
        let left = s_r + x_r * half;
        e_r += left * x_r;
        e_t += left * v;
        s_r += x_r;
        first += xi;
    }
    Ok(Perturbation {
        nominal: chain.end,
        first,
        second: affine(&e_r, &e_t),
    })
}

impl<T: Real> Robot<T> {
    /// The measured frame at joint readings `q` expanded to second order in the
    /// parameter errors `errors` (eq. 2.22); see [`expand`].
    pub fn perturbation(
        &self,
        q: &[T],
        errors: &[(Param, T)],
    ) -> Result<Perturbation<T>, PerturbationError> {
        expand(&self.chain(q)?, self.convention, errors)
    }
}
