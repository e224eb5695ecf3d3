//! The distributions the diagnosis tests with: Fisher's F (through the
//! regularised incomplete beta function) and its quantiles.
//!
//! A sum of squares in units of a noise that is itself estimated from the
//! residuals is F-distributed, not χ²: with `d₂` degrees of freedom left for the
//! noise, `F = (drop / d₁) / (RSS / d₂)` follows `F(d₁, d₂)` when the `d₁`
//! parameters tested are zero. On 20 poses `d₂` is a few dozen and the F
//! quantile is markedly larger than the χ² one; on 1,000 poses they agree.
//!
//! The incomplete beta function is evaluated by its continued fraction (modified
//! Lentz; Press et al., *Numerical Recipes*, 3rd ed., §6.4), the quantile by
//! Newton's iteration on the distribution function, which is monotone,
//! safeguarded by bisection.
//!
//! [`significantly_smaller`] is the paired test by which a held-out
//! improvement counts: the diagnosis leaves the nominal model, or sets a pose
//! aside, only when the poses' held-out errors drop significantly, not merely
//! on average.

/// `ln Γ(x)` for `x > 0` (Lanczos, g = 7, n = 9: relative error below 1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The continued fraction of the incomplete beta function (valid for
/// `x < (a + 1) / (a + b + 2)`).
fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    // One modified-Lentz step with the partial numerator `aa`: the factor it
    // multiplies the fraction by.
    let mut step = |aa: f64| {
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        d * c
    };
    for m in 1..=300 {
        let m = m as f64;
        let m2 = 2.0 * m;
        h *= step(m * (b - m) * x / ((qam + m2) * (a + m2)));
        let delta = step(-(a + m) * (qab + m) * x / ((a + m2) * (qap + m2)));
        h *= delta;
        if (delta - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// The regularised incomplete beta function `I_x(a, b)`, `a, b > 0`, `0 ≤ x ≤ 1`.
pub fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_fraction(b, a, 1.0 - x) / b
    }
}

/// The distribution function of `F(d1, d2)` at `f`.
pub fn f_cdf(f: f64, d1: f64, d2: f64) -> f64 {
    if f <= 0.0 {
        return 0.0;
    }
    incomplete_beta(d1 / 2.0, d2 / 2.0, d1 * f / (d1 * f + d2))
}

/// The density of `F(d1, d2)` at `f > 0`.
fn f_density(f: f64, d1: f64, d2: f64) -> f64 {
    let (a, b) = (d1 / 2.0, d2 / 2.0);
    let x = d1 * f / (d1 * f + d2);
    // dI_x/dx = x^(a−1) (1−x)^(b−1) / B(a, b), and dx/df = d1 d2 / (d1 f + d2)².
    let ln_dx = (a - 1.0) * x.ln() + (b - 1.0) * (1.0 - x).ln() + ln_gamma(a + b)
        - ln_gamma(a)
        - ln_gamma(b);
    ln_dx.exp() * d1 * d2 / (d1 * f + d2).powi(2)
}

/// The quantile of `F(d1, d2)` at probability `p` (0 < p < 1): the `f` with
/// `P(F ≤ f) = p`, to a relative 1e-10. Degrees of freedom below 1 are taken as 1.
///
/// Newton's iteration on the distribution function, kept inside a bracket that
/// every evaluation narrows (a step leaving it bisects instead): a handful of
/// evaluations where bisection alone takes some forty.
pub fn f_quantile(p: f64, d1: f64, d2: f64) -> f64 {
    let (d1, d2) = (d1.max(1.0), d2.max(1.0));
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let (mut lo, mut hi) = (0.0, 1.0);
    while f_cdf(hi, d1, d2) < p {
        lo = hi;
        hi *= 2.0;
        if hi > 1e300 {
            return hi;
        }
    }
    let mut f = 0.5 * (lo + hi);
    for _ in 0..200 {
        let below = f_cdf(f, d1, d2) - p;
        if below < 0.0 {
            lo = f;
        } else {
            hi = f;
        }
        let newton = f - below / f_density(f, d1, d2);
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - f).abs() <= 1e-12 * next || hi - lo <= 1e-10 * hi {
            return next;
        }
        f = next;
    }
    f
}

/// Whether `new` errors are significantly smaller than `base` errors of the
/// same poses: the one-sided paired t-test of the per-pose drop of the squared
/// error, `d_i = base_i² − new_i²`, at `level` (such as 0.05). Fewer than
/// three poses never are.
pub fn significantly_smaller(base: &[f64], new: &[f64], level: f64) -> bool {
    let d: Vec<f64> = base.iter().zip(new).map(|(b, n)| b * b - n * n).collect();
    let n = d.len();
    if n < 3 {
        return false;
    }
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    if mean <= 0.0 {
        return false;
    }
    if var == 0.0 {
        return true;
    }
    // t_{1−α}(ν)² = F_{1−2α}(1, ν).
    let t = mean / (var / n as f64).sqrt();
    t * t > f_quantile(1.0 - 2.0 * level, 1.0, (n - 1) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Quantiles of F against printed tables (Abramowitz & Stegun 26.9, and the
    /// χ² limit): each to the four significant digits the tables give.
    #[test]
    fn f_quantiles_match_the_tables() {
        for (p, d1, d2, table) in [
            (0.95, 1.0, 10.0, 4.9646),
            (0.99, 3.0, 20.0, 4.9382),
            (0.999, 1.0, 30.0, 13.293),
            (0.99, 5.0, 60.0, 3.3389),
            (0.95, 2.0, 120.0, 3.0718),
            // d2 → ∞: χ²(1) 99.9 % quantile 10.828.
            (0.999, 1.0, 1e9, 10.828),
        ] {
            let q = f_quantile(p, d1, d2);
            assert!(
                (q - table).abs() < 5e-4 * table,
                "F({d1}, {d2}) at {p}: {q} against {table}"
            );
        }
    }

    /// The quantile inverts the distribution function to its stated 1e-10:
    /// `P(F ≤ f(1 − 1e-10)) ≤ p ≤ P(F ≤ f(1 + 1e-10))`, over the degrees of
    /// freedom and probabilities the diagnosis asks for (1 to 60 parameters,
    /// 1 to 10⁶ degrees of freedom of the noise, p from 0.5 to 1 − 1e-6).
    #[test]
    fn f_quantiles_invert_the_distribution_function() {
        for d1 in [1.0, 2.0, 7.0, 60.0] {
            for d2 in [1.0, 3.0, 40.0, 1e3, 1e6] {
                for p in [0.5, 0.9, 0.95, 0.999, 1.0 - 1e-6] {
                    let f = f_quantile(p, d1, d2);
                    let (below, above) = (
                        f_cdf(f * (1.0 - 1e-10), d1, d2),
                        f_cdf(f * (1.0 + 1e-10), d1, d2),
                    );
                    assert!(
                        below <= p + 1e-15 && p <= above + 1e-15,
                        "F({d1}, {d2}) at {p}: {f} gives {below}..{above}"
                    );
                }
            }
        }
    }

    /// The paired test: a uniform drop of every error by a tenth is
    /// significant on 20 poses; errors that fall on some poses and rise as much
    /// on others are not; a single large drop among 20 unchanged poses is not.
    #[test]
    fn the_paired_test_asks_for_a_consistent_drop() {
        let base: Vec<f64> = (0..20).map(|i| 1.0 + 0.05 * i as f64).collect();
        let uniform: Vec<f64> = base.iter().map(|b| 0.9 * b).collect();
        assert!(significantly_smaller(&base, &uniform, 0.05));
        let mixed: Vec<f64> = base
            .iter()
            .enumerate()
            .map(|(i, b)| if i % 2 == 0 { 0.8 * b } else { 1.2 * b })
            .collect();
        assert!(!significantly_smaller(&base, &mixed, 0.05));
        let mut single = base.clone();
        single[3] = 0.0;
        assert!(!significantly_smaller(&base, &single, 0.05));
    }

    /// The incomplete beta function at points with closed forms:
    /// `I_x(1, b) = 1 − (1 − x)^b` and `I_x(a, 1) = x^a`.
    #[test]
    fn incomplete_beta_closed_forms() {
        for x in [0.01f64, 0.3, 0.5, 0.9, 0.999] {
            for k in [0.5, 1.0, 2.5, 7.0] {
                let one_b = 1.0 - (1.0 - x).powf(k);
                let a_one = x.powf(k);
                assert!((incomplete_beta(1.0, k, x) - one_b).abs() < 1e-12);
                assert!((incomplete_beta(k, 1.0, x) - a_one).abs() < 1e-12);
            }
        }
    }
}
