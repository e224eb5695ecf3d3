//! The scalar type of the kinematics: `f32` on the controller, `f64` on the host.
//!
//! Every function of this crate is generic over [`Real`], a `nalgebra::RealField`
//! that is `Copy`; in `no_std` the transcendental functions come from `libm`
//! (nalgebra's `libm` feature).

use nalgebra::RealField;

/// A real scalar the kinematics can run in: `f32` or `f64`.
pub trait Real: RealField + Copy {
    /// Converts an `f64` constant (a tolerance, a unit factor) to this scalar.
    #[inline]
    fn lit(x: f64) -> Self {
        nalgebra::convert(x)
    }

    /// Converts this scalar to `f64`, for reports and serialisation.
    #[inline]
    fn to_f64(self) -> f64 {
        // Every RealField is a superset of f64 (simba's `SupersetOf<f64>`); for f32
        // and f64 the conversion back always succeeds.
        nalgebra::convert_unchecked(self)
    }
}

impl<T: RealField + Copy> Real for T {}
