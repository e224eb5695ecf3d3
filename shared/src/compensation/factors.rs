//! The `L D Lᵀ` factors of the damped system `J Jᵀ + D` of a step (`D = λ² I`,
//! the rotation rows damped more where a position-only task keeps the
//! orientation: [`Limits::turn_damping`](super::Limits::turn_damping)), and the
//! damped least-squares solve `J⁺ r = Jᵀ (J Jᵀ + D)⁻¹ r` with them.
//!
//! Always the six rows: where a task has no rotation rows (a position-only
//! compensation of an arm of 3 joints or fewer) the rotation rows of `J` and of
//! the residual are zero, their block is `λ² I` and their part of the solution
//! zero, the same step as the three position rows alone, and every loop has a
//! fixed length. No square root is taken (a software routine on the
//! controller).
//!
//! Factors of one tick's `J` solve the next tick's step too on a smooth motion
//! ([`Freshness::Stale`]): they are then an approximate inverse, whose linear
//! residual `ℓ` the step measures ([`super::step_bound`]), and they are replaced
//! by fresh ones when the step with them is not within its bound.

use crate::Real;

/// How the factors held relate to the current `J`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Freshness {
    /// No factors (the first tick, or after a tick that did not converge).
    None,
    /// The factors of a previous tick's `J`, which converged.
    Stale,
    /// The factors of this `J`.
    Fresh,
}

/// The factors: `L` (unit diagonal) below the diagonal, `1/D` on it.
#[derive(Clone, Debug)]
pub struct Factors<T: Real> {
    pub(crate) ldl: [[T; 6]; 6],
    pub(crate) freshness: Freshness,
}

impl<T: Real> Factors<T> {
    /// No factors.
    pub fn new() -> Self {
        Self {
            ldl: [[T::zero(); 6]; 6],
            freshness: Freshness::None,
        }
    }

    /// Factors `J Jᵀ + D` for the columns `jac`, in place, with the damping
    /// `D = λ² I` (`lambda2 = λ²`) plus `rotation2` on the three rotation
    /// rows; `None` (and no factors) if not positive definite or not finite.
    // Triangular index arithmetic reads best with indices.
    #[allow(clippy::needless_range_loop)]
    pub fn factor(&mut self, jac: &[[T; 6]], lambda2: T, rotation2: T) -> Option<()> {
        self.freshness = Freshness::None;
        let a = &mut self.ldl;
        for i in 0..6 {
            for j in 0..i {
                a[i][j] = T::zero();
            }
            a[i][i] = lambda2;
        }
        for i in 0..3 {
            a[i][i] += rotation2;
        }
        for col in jac {
            for i in 0..6 {
                for j in 0..=i {
                    a[i][j] += col[i] * col[j];
                }
            }
        }
        // Column by column: D_j = A_jj − Σ_p L_jp² D_p, L_ij = (A_ij − Σ_p L_ip L_jp D_p) / D_j.
        for j in 0..6 {
            let mut d = a[j][j];
            for p in 0..j {
                d -= a[j][p] * a[j][p] * a[p][p];
            }
            // Not positive, or NaN.
            if d.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
                return None;
            }
            let inv = T::one() / d;
            a[j][j] = inv;
            for i in j + 1..6 {
                // Here a[i][p] (p < j) holds L_ip D_p, and a[j][p] L_jp D_p.
                let mut s = a[i][j];
                for p in 0..j {
                    s -= a[i][p] * a[j][p] * a[p][p];
                }
                a[i][j] = s;
            }
        }
        // a[i][j] holds L_ij D_j below the diagonal: divide by D_j.
        for j in 0..6 {
            for i in j + 1..6 {
                a[i][j] *= a[j][j];
            }
        }
        self.freshness = Freshness::Fresh;
        Some(())
    }

    /// `Jᵀ y` into `out`, with `y = (J Jᵀ + λ² I)⁻¹ r` from these factors;
    /// returns `y`, or `None` if not finite.
    // Triangular index arithmetic reads best with indices.
    #[allow(clippy::needless_range_loop)]
    pub fn solve(&self, jac: &[[T; 6]], r: &[T; 6], out: &mut [T]) -> Option<[T; 6]> {
        let l = &self.ldl;
        // L z = r, y = z / D, then Lᵀ y = y.
        let mut y = *r;
        for i in 0..6 {
            for p in 0..i {
                y[i] -= l[i][p] * y[p];
            }
        }
        for i in 0..6 {
            y[i] *= l[i][i];
        }
        for i in (0..6).rev() {
            for p in i + 1..6 {
                y[i] -= l[p][i] * y[p];
            }
        }
        // Finite when the sum is (see `is_finite`; a sum beyond 10³⁸ even in
        // `f32` counts as not finite: no step is that large).
        let mut sum = T::zero();
        for (o, col) in out.iter_mut().zip(jac) {
            let mut d = T::zero();
            for i in 0..6 {
                d += col[i] * y[i];
            }
            sum += d;
            *o = d;
        }
        super::is_finite(sum).then_some(y)
    }
}

impl<T: Real> Default for Factors<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// `J v`: the residual row a joint change `v` moves the measured frame by, to
/// first order.
#[inline]
pub fn apply<T: Real>(jac: &[[T; 6]], v: &[T]) -> [T; 6] {
    let mut out = [T::zero(); 6];
    for (col, d) in jac.iter().zip(v) {
        for i in 0..6 {
            out[i] += col[i] * *d;
        }
    }
    out
}
