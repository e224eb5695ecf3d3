//! One link's homogeneous transform, in either D-H convention.
//!
//! Standard D-H, Mirman & Gupta eq. (5), `A_m = Rot_z(θ) Trans_z(s) Trans_x(a) Rot_x(α)`:
//!
//! ```text
//!       ⎡ cθ   -sθ·cα    sθ·sα   a·cθ ⎤
//! A_m = ⎢ sθ    cθ·cα   -cθ·sα   a·sθ ⎥
//!       ⎢ 0     sα       cα      s    ⎥
//!       ⎣ 0     0        0       1    ⎦
//! ```
//!
//! Modified D-H (Craig), `A_m = Rot_x(α) Trans_x(a) Rot_z(θ) Trans_z(s)`:
//!
//! ```text
//!       ⎡ cθ      -sθ      0     a     ⎤
//! A_m = ⎢ cα·sθ    cα·cθ  -sα   -sα·s  ⎥
//!       ⎢ sα·sθ    sα·cθ   cα    cα·s  ⎥
//!       ⎣ 0        0       0     1     ⎦
//! ```
//!
//! `θ` and `s` here already include the joint reading ([`Link::joint_values`]).
//! Angles in rad, lengths in m.

use nalgebra::{IsometryMatrix3, Matrix3, Rotation3, Translation3};

use crate::{Convention, Link, Real};

/// The transform of link `link` at joint reading `q`, from the link's own frame
/// (after `A_m`) to the previous one.
#[inline]
pub fn link_transform<T: Real>(convention: Convention, link: &Link<T>, q: T) -> IsometryMatrix3<T> {
    let (theta, s) = link.joint_values(q);
    transform(convention, theta, s, link.a, link.alpha.sincos())
}

/// `A_m` from its four parameters, with the twist given by `(sin α, cos α)` so that
/// a caller that evaluates the same link many times computes them once.
#[inline]
pub fn transform<T: Real>(
    convention: Convention,
    theta: T,
    s: T,
    a: T,
    (sa, ca): (T, T),
) -> IsometryMatrix3<T> {
    let (st, ct) = theta.sincos();
    let z = T::zero();
    match convention {
        Convention::Dh => IsometryMatrix3::from_parts(
            Translation3::new(a * ct, a * st, s),
            Rotation3::from_matrix_unchecked(Matrix3::new(
                ct,
                -st * ca,
                st * sa,
                st,
                ct * ca,
                -ct * sa,
                z,
                sa,
                ca,
            )),
        ),
        Convention::Mdh => IsometryMatrix3::from_parts(
            Translation3::new(a, -sa * s, ca * s),
            Rotation3::from_matrix_unchecked(Matrix3::new(
                ct,
                -st,
                z,
                ca * st,
                ca * ct,
                -sa,
                sa * st,
                sa * ct,
                ca,
            )),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::JointType;
    use nalgebra::{UnitVector3, Vector3};

    fn rot(axis: Vector3<f64>, angle: f64) -> IsometryMatrix3<f64> {
        IsometryMatrix3::from_parts(
            Translation3::identity(),
            Rotation3::from_axis_angle(&UnitVector3::new_normalize(axis), angle),
        )
    }
    fn trans(v: Vector3<f64>) -> IsometryMatrix3<f64> {
        IsometryMatrix3::from_parts(Translation3::from(v), Rotation3::identity())
    }

    /// The closed forms above equal the products of elementary motions that
    /// define each convention.
    #[test]
    fn closed_forms_equal_elementary_products() {
        let link = Link::new(JointType::Revolute, 0.3, 0.2, -0.7, 1.1);
        let q = -0.45;
        let (th, s) = link.joint_values(q);
        let (x, z) = (Vector3::x(), Vector3::z());
        let dh = rot(z, th) * trans(z * s) * trans(x * link.a) * rot(x, link.alpha);
        let mdh = rot(x, link.alpha) * trans(x * link.a) * rot(z, th) * trans(z * s);
        let got_dh = link_transform(Convention::Dh, &link, q);
        let got_mdh = link_transform(Convention::Mdh, &link, q);
        assert!((dh.to_homogeneous() - got_dh.to_homogeneous()).abs().max() < 1e-15);
        assert!(
            (mdh.to_homogeneous() - got_mdh.to_homogeneous())
                .abs()
                .max()
                < 1e-15
        );
    }
}
