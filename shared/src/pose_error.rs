//! The end-effector error of Mirman & Gupta, eqs. (12)–(15).
//!
//! With `dA_h ≅ A_h^actual − A_h^current` (eq. 13), the error matrix
//! `(dA_h) A_h⁻¹` is split into a skew-symmetric rotation part and a vector
//! (eq. 14), giving (eq. 15):
//!
//! ```text
//! N dφ = (dR_h) R_hᵀ        dη = dp_h − (dR_h) R_hᵀ p_h
//! ```
//!
//! `νdφ` is the vector of the skew-symmetric part of `N dφ` (to first order
//! `dR Rᵀ` is skew-symmetric; taking its skew part discards the second-order
//! symmetric remainder), and `dη` is the translation error of the end-effector
//! point that coincides with the measurement-frame origin. Both are in the
//! measurement frame; the result is the [`Twist`] `[νdφ; dη]` that the special
//! Jacobians predict (eq. 50). A laser tracker measures only the tool point, and
//! then the error is simply `dP = P^actual − P^current` (eq. 7), which the
//! Jacobians predict through [`crate::jacobian::at_point`].

use nalgebra::{IsometryMatrix3, Point3, Rotation3, UnitQuaternion, Vector3};

use crate::{Real, Twist};

/// The full-pose error `[νdφ; dη]` of `current` with respect to `actual` (eq. 15).
pub fn pose_error<T: Real>(actual: &IsometryMatrix3<T>, current: &IsometryMatrix3<T>) -> Twist<T> {
    let r = current.rotation.matrix();
    let dr = actual.rotation.matrix() - r;
    let n = dr * r.transpose();
    let half = T::lit(0.5);
    // vee of the skew-symmetric part (N − Nᵀ)/2.
    let phi = Vector3::new(n.m32 - n.m23, n.m13 - n.m31, n.m21 - n.m12) * half;
    let p = &current.translation.vector;
    let dp = actual.translation.vector - p;
    let eta = dp - phi.cross(p);
    Twist::new(phi.x, phi.y, phi.z, eta.x, eta.y, eta.z)
}

/// The position error `dP = P^actual − P^current` of a measured point.
#[inline]
pub fn position_error<T: Real>(actual: &Point3<T>, current: &Point3<T>) -> Vector3<T> {
    actual - current
}

/// The exact rotation error: the rotation vector `φ·ν` of `R_actual · R_currentᵀ`,
/// measurement frame. To first order it is the `νdφ` of eq. (15); unlike that, it
/// stays exact for large errors. Computed through a unit quaternion and `atan2`,
/// so it is finite for any two rotations, however rounded (an `acos` of the trace
/// is not: rounding can push its argument past 1).
pub fn rotation_error<T: Real>(actual: &Rotation3<T>, current: &Rotation3<T>) -> Vector3<T> {
    UnitQuaternion::from_rotation_matrix(&(actual * current.inverse())).scaled_axis()
}
