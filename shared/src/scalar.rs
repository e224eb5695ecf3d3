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
//! joint turns so far) the argument is first reduced modulo `2π` exactly, in
//! integer arithmetic (Payne–Hanek: the 24-bit significand times the 64 bits
//! of `1/2π` at its exponent, modulo 2⁶⁴, is the fraction of a turn to 2⁻⁴⁰):
//! below 1e-6 for every finite `f32`. Every `f32` sine and cosine of the crate
//! goes through it (the constant angles of a model too), so that the
//! controller links no libm `sinf`/`cosf` and no software `f64` arithmetic,
//! which would take 8 KB of its 64 KB of flash.

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

    /// [`Real::sincos`] of an `x` within `[−π/4, π/4]` (not checked): libm's
    /// in `f64`, in `f32` the polynomials alone, without the reduction (about
    /// 15 instructions; the same error, below 1e-7 there).
    #[inline]
    fn sincos_small(self) -> (Self, Self) {
        self.sin_cos()
    }
}

impl Real for f64 {}

impl Real for f32 {
    #[inline]
    fn sincos(self) -> (f32, f32) {
        sin_cos_f32(self)
    }

    #[inline]
    fn sincos_small(self) -> (f32, f32) {
        sin_cos_kernel(self)
    }
}

/// Beyond this `|x|` (rad) the `f32` reduction would lose accuracy: an exact
/// reduction first.
const REDUCTION_LIMIT: f32 = 8192.0;

/// `(sin x, cos x)` in `f32` arithmetic only; see [the module](self).
#[inline]
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
    let (s, c) = sin_cos_kernel(r);
    match k & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `(sin r, cos r)` for `r` in `[−π/4, π/4]`: the minimax polynomials of
/// Cephes' `sinf.c`, `cosf.c`, relative error about 1e-7.
#[inline(always)]
#[allow(clippy::excessive_precision)] // The constants as published (Cephes).
fn sin_cos_kernel(r: f32) -> (f32, f32) {
    let z = r * r;
    let s = r + r * z * (-1.666_665_461_1e-1 + z * (8.332_160_873_6e-3 + z * -1.951_529_589_1e-4));
    let c = 1.0 - 0.5 * z
        + z * z
            * (4.166_664_568_298_827e-2
                + z * (-1.388_731_625_493_765e-3 + z * 2.443_315_711_809_948e-5));
    (s, c)
}

/// Beyond [`REDUCTION_LIMIT`]: `x` reduced modulo `2π` exactly, in integer
/// arithmetic (Payne–Hanek; see [the module](self)), then [`sin_cos_f32`]; out
/// of line, the rare case stays out of the hot path. NaN for NaN and
/// infinities.
#[cold]
#[inline(never)]
fn sin_cos_wide(x: f32) -> (f32, f32) {
    if !x.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    // 1/2π in binary, 32 bits a word, after a word of zeros: bit `g` (from the
    // left, 0-based) has the weight 2^(31 − g).
    const INV_TAU: [u32; 7] = [
        0,
        0x28be_60db,
        0x9391_054a,
        0x7f09_d5f4,
        0x7d4d_3770,
        0x36d8_a566,
        0x4f10_e410,
    ];
    // |x| = m · 2^e, m the 24-bit significand; |x| > 8192 makes it normal,
    // with −10 ≤ e ≤ 104.
    let bits = x.abs().to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 150;
    let m = u64::from((bits & 0x7f_ffff) | 0x80_0000);
    // x / 2π = m · 2^e · (1/2π): the bits of 1/2π of weight 2^(−e) and up,
    // times m, are whole turns. The 64 bits after them (from bit g = e + 32),
    // times m modulo 2^64, are the fraction of a turn, short by less than
    // m · 2^−64 < 2^−40 turns.
    let g = (e + 32) as u32;
    let (k, s) = ((g / 32) as usize, g % 32);
    let high = (u64::from(INV_TAU[k]) << 32) | u64::from(INV_TAU[k + 1]);
    let window = (high << s) | ((u64::from(INV_TAU[k + 2]) << s) >> 32);
    // As a signed fraction, a turn in [−½, ½), then radians.
    let turns = m.wrapping_mul(window) as i64;
    const RADIANS_PER_UNIT: f32 = core::f32::consts::TAU / 18_446_744_073_709_551_616.0;
    let r = turns as f32 * RADIANS_PER_UNIT;
    sin_cos_f32(if x < 0.0 { -r } else { r })
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
        // Beyond the limit: the exact reduction, to the same 1e-6 at any size.
        for lo in [8192.0, 1e5, 1e7, 1e12, 1e20, 1e30, 8e37] {
            let far = worst_error(lo, 4.0 * lo, 100_000).max(worst_error(-4.0 * lo, -lo, 100_000));
            assert!(far < 1e-6, "worst error {far:e} beyond {lo}");
        }
        assert!(sin_cos_f32(f32::INFINITY).0.is_nan() && sin_cos_f32(f32::NAN).1.is_nan());
        // Around the quadrant boundaries, where the reduction switches polynomials.
        for k in -40..=40 {
            let b = k as f64 * core::f64::consts::FRAC_PI_2;
            let near = worst_error(b - 1e-3, b + 1e-3, 20_000);
            assert!(near < 1e-6, "worst error {near:e} near {k}·π/2");
        }
    }

    /// The polynomials alone ([`Real::sincos_small`]) on the quarter turn
    /// either side of zero, where the reduction leaves the argument unchanged:
    /// within 1e-7 of the `f64` values (a few units in the last place of an
    /// `f32` below 1), on a grid of step 8e-8 rad.
    #[test]
    fn sincos_small_within_1e_7_on_the_quarter_turn() {
        let quarter = core::f64::consts::FRAC_PI_4;
        let n = 20_000_000;
        let mut worst: f64 = 0.0;
        for i in 0..=n {
            let x = (-quarter + 2.0 * quarter * i as f64 / n as f64) as f32;
            let (s, c) = x.sincos_small();
            let (s64, c64) = f64::from(x).sin_cos();
            worst = worst
                .max((f64::from(s) - s64).abs())
                .max((f64::from(c) - c64).abs());
        }
        assert!(worst < 1e-7, "worst error {worst:e}");
    }

    /// Beyond the reduction limit it is the correctly reduced value within
    /// 1e-6, up to the largest `f32`, and on both sides of every exponent step
    /// (where the window into the bits of 1/2π moves); NaN for non-finite input.
    #[test]
    fn sin_cos_f32_beyond_the_limit() {
        let check = |x: f32| {
            let (s, c) = sin_cos_f32(x);
            let (s64, c64) = f64::from(x).sin_cos();
            let worst = (f64::from(s) - s64).abs().max((f64::from(c) - c64).abs());
            assert!(worst <= 1e-6, "{x:e}: {worst:e}");
        };
        for x in [
            1e4f32,
            -3e5,
            1e8,
            -3.9e8,
            1e9,
            3e12,
            1e16,
            1e30,
            -f32::MAX,
            f32::MAX,
        ] {
            check(x);
        }
        for exponent in 13..128 {
            let step = 2.0f32.powi(exponent);
            for x in [
                step,
                f32::from_bits(step.to_bits() - 1),
                f32::from_bits(step.to_bits() + 1),
            ] {
                check(x);
                check(-x);
            }
        }
        let (s, c) = sin_cos_f32(f32::NAN);
        assert!(s.is_nan() && c.is_nan());
        let (s, c) = sin_cos_f32(f32::INFINITY);
        assert!(s.is_nan() && c.is_nan());
        assert_eq!(1.0f64.sincos(), 1.0f64.sin_cos());
    }
}
