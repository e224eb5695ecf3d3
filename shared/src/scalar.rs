//! The scalar type of the kinematics: `f32` on the controller, `f64` on the host.
//!
//! Every function of this crate is generic over [`Real`], a `nalgebra::RealField`
//! that is `Copy`; in `no_std` the transcendental functions come from `libm`
//! (nalgebra's `libm` feature).
//!
//! One exception, for speed on the controller: the sine and cosine of a joint
//! angle, which every link transform needs, go through [`Real::sincos`]. In `f64`
//! it is libm's. In `f32` libm's `sinf`/`cosf` compute in `f64`, which a
//! Cortex-M4F does in software (about 2,100 instructions each); [`Real::sincos`]
//! for `f32` instead reduces the argument to `[−π/4, π/4]` in `f32` (Cody–Waite,
//! `π/2` split in three parts) and evaluates the minimax polynomials of Cephes'
//! `sinf.c`/`cosf.c` (S. L. Moshier), about 40 instructions; its error against
//! the exact sine and cosine of the same `f32` argument is below 1e-6 (tested on
//! a dense grid, see the tests below) for `|x| ≤ 8192` rad. Beyond that (no
//! joint turns so far) the argument is first reduced modulo `2π` in `f64`
//! (`x − k·2π`, `2π` split in two parts so that `k·hi` is exact for `k < 2^26`):
//! below 1e-6 up to 4e8 rad, a point of the unit circle beyond. Every
//! `f32` sine and cosine of the crate goes through it (the constant angles of a
//! model too), so that the controller links no libm `sinf`/`cosf`, whose `f64`
//! kernels and software `f64` arithmetic take 8 KB of its 64 KB of flash.

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

    /// `(sin x, cos x)` as the link transforms compute them: libm's in `f64`, a
    /// pure-`f32` evaluation in `f32` (see [the module](self)).
    #[inline]
    fn sincos(self) -> (Self, Self) {
        self.sin_cos()
    }
}

impl Real for f64 {}

impl Real for f32 {
    #[inline]
    fn sincos(self) -> (f32, f32) {
        sin_cos_f32(self)
    }
}

/// Beyond this `|x|` (rad) the `f32` reduction would lose accuracy: an exact
/// reduction first.
const REDUCTION_LIMIT: f32 = 8192.0;

/// `(sin x, cos x)` in `f32` arithmetic only; see [the module](self).
#[allow(clippy::excessive_precision)] // The constants as published (Cephes).
pub fn sin_cos_f32(x: f32) -> (f32, f32) {
    // Beyond the limit, or NaN.
    if x.is_nan() || x.abs() > REDUCTION_LIMIT {
        return sin_cos_wide(x);
    }
    // π/2 = P1 + P2 + P3, P1 and P2 with few significant bits so that k·P1 and
    // k·P2 are exact for |k| < 2^13 (Cephes' DP1..DP3, doubled).
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_512_969_970_703e-4;
    const P3: f32 = 7.549_789_954_891_882e-8;
    let k = (x * core::f32::consts::FRAC_2_PI + 0.5f32.copysign(x)) as i32;
    let kf = k as f32;
    let r = ((x - kf * P1) - kf * P2) - kf * P3;
    let z = r * r;
    // Minimax on [−π/4, π/4] (Cephes sinf.c, cosf.c): relative error about 1e-7.
    let s = r + r * z * (-1.666_665_461_1e-1 + z * (8.332_160_873_6e-3 + z * -1.951_529_589_1e-4));
    let c = 1.0 - 0.5 * z
        + z * z
            * (4.166_664_568_298_827e-2
                + z * (-1.388_731_625_493_765e-3 + z * 2.443_315_711_809_948e-5));
    match k & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Beyond [`REDUCTION_LIMIT`]: `x` reduced modulo `2π` in `f64` (see [the
/// module](self)), then [`sin_cos_f32`]; out of line, the rare case stays out of
/// the hot path. NaN for NaN and infinities.
#[cold]
#[inline(never)]
fn sin_cos_wide(x: f32) -> (f32, f32) {
    if !x.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    // 2π = HI + LO, HI with 26 significant bits (k·HI exact for k < 2^26).
    const HI: f64 = 6.283_185_362_815_857;
    const LO: f64 = core::f64::consts::TAU - HI;
    let x = f64::from(x);
    // k: x/2π rounded to an integer (adding and removing 1.5·2^52 rounds to
    // nearest below 2^51; beyond, every f64 is an integer already).
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let q = x * (1.0 / core::f64::consts::TAU);
    let k = if q.abs() < 2_251_799_813_685_248.0 {
        (q + ROUND) - ROUND
    } else {
        q
    };
    let r = ((x - k * HI) - k * LO) as f32;
    if r.abs() <= REDUCTION_LIMIT {
        sin_cos_f32(r)
    } else {
        // Only where k·HI is far from exact (|x| > 1e15): any point of the circle.
        (0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    /// The worst error of [`sin_cos_f32`] against the `f64` sine and cosine of the
    /// same `f32` argument, over `n` evenly spaced points of `[lo, hi]`.
    fn worst_error(lo: f64, hi: f64, n: usize) -> f64 {
        let mut worst: f64 = 0.0;
        for i in 0..=n {
            let x = (lo + (hi - lo) * i as f64 / n as f64) as f32;
            let (s, c) = sin_cos_f32(x);
            let (s64, c64) = (x as f64).sin_cos();
            worst = worst
                .max((s as f64 - s64).abs())
                .max((c as f64 - c64).abs());
        }
        worst
    }

    /// Below 1e-6 everywhere a joint angle can be: a dense grid of ±4π (step
    /// about 2.5e-6 rad, so every quadrant boundary and polynomial segment is
    /// crossed many times), and coarser grids up to the reduction limit. An `f32`
    /// itself rounds the sine by up to 6e-8, so this is a few units in the last place.
    #[test]
    fn sin_cos_f32_within_1e_6_of_f64() {
        let four_pi = 4.0 * core::f64::consts::PI;
        let dense = worst_error(-four_pi, four_pi, 10_000_000);
        let wide = worst_error(-8192.0, 8192.0, 4_000_000);
        std::eprintln!("sin_cos_f32: worst error {dense:e} on ±4π, {wide:e} on ±8192");
        assert!(dense < 1e-6, "worst error {dense:e} on ±4π");
        assert!(wide < 1e-6, "worst error {wide:e} on ±8192");
        // Beyond the limit: the exact reduction modulo the f64 2π, whose error
        // is |x| · 2.4e-16 / 2π, plus the polynomials' 1e-7.
        for lo in [8192.0, 1e5, 1e7] {
            let far = worst_error(lo, 4.0 * lo, 100_000).max(worst_error(-4.0 * lo, -lo, 100_000));
            assert!(
                far < 1e-6 + 4.0 * lo * 4e-17,
                "worst error {far:e} beyond {lo}"
            );
        }
        assert!(sin_cos_f32(f32::INFINITY).0.is_nan() && sin_cos_f32(f32::NAN).1.is_nan());
        // Around the quadrant boundaries, where the reduction switches polynomials.
        for k in -40..=40 {
            let b = k as f64 * core::f64::consts::FRAC_PI_2;
            let near = worst_error(b - 1e-3, b + 1e-3, 20_000);
            assert!(near < 1e-6, "worst error {near:e} near {k}·π/2");
        }
    }

    /// Beyond the reduction limit it is libm's (the correctly reduced value)
    /// within 1e-6 up to 4e8 rad; for any finite `x` a point of the unit circle;
    /// NaN for non-finite input.
    #[test]
    fn sin_cos_f32_beyond_the_limit() {
        for x in [1e4f32, -3e5, 1e8, -3.9e8] {
            let ((s, c), (ls, lc)) = (sin_cos_f32(x), libm::sincosf(x));
            assert!((s - ls).abs() <= 1e-6 && (c - lc).abs() <= 1e-6, "{x}");
        }
        for x in [1e9f32, 3e12, 1e16, 1e30, -f32::MAX] {
            let (s, c) = sin_cos_f32(x);
            assert!((s * s + c * c - 1.0).abs() < 1e-6, "{x}");
        }
        let (s, c) = sin_cos_f32(f32::NAN);
        assert!(s.is_nan() && c.is_nan());
        let (s, c) = sin_cos_f32(f32::INFINITY);
        assert!(s.is_nan() && c.is_nan());
        assert_eq!(1.0f64.sincos(), 1.0f64.sin_cos());
    }
}
