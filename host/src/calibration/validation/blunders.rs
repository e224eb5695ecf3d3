//! Blunders: a pose is set aside only when the evidence against it is strong at
//! a scale that blunders cannot inflate, and only when setting it aside
//! improves the held-out error of the other poses.
//!
//! The test is the deleted residual (Cook & Weisberg, *Residuals and Influence
//! in Regression*, 1982, §2.2) of each pose: with the weighted Jacobian `J`, the
//! MAP normal matrix `N = JᵀJ + P` and the pose's `k` rows (3, or 6 with an
//! orientation), the residual the fit would leave had the pose been left out
//! is `(I − H_ii)⁻¹ r_i` with `H_ii = J_i N⁻¹ J_iᵀ`, and
//!
//! `T_i = r_iᵀ (I − H_ii)⁻¹ r_i`
//!
//! is its squared norm in units of the noise (a pose the fit left out is
//! predicted: `T_i = r_iᵀ (I + H_ii)⁻¹ r_i`). With `n` poses tested, a pose is
//! suspect when `F_i = (T_i / k) / s²` exceeds the `1 − α/n` quantile of
//! `F(k, R − k)` (Bonferroni, α = 1 %): on clean data the chance of
//! suspecting any pose is at most 1 %.
//!
//! The scale `s²` is where blunders hide: the mean square of the residuals
//! grows with the square of every blunder, so that a few 1–5 mm blunders
//! among 20 µm tracker readings raise the noise estimate tenfold and pass
//! each other's test. The screen is therefore a hard-rejection M-estimator
//! started at a robust scale (Hampel et al., *Robust Statistics*, 1986, §8.3):
//!
//! 1. every pose's `T_i` about the fit to all poses, against the robust scale
//!    [`robust_scale`], the median of `T_i / med(χ²_k)` (breakdown point one
//!    half), when the fit's mean square exceeds it by more than a factor 2
//!    ([`INFLATION`]: blunders weigh on the fit); otherwise against the fit's
//!    own scale, the more efficient one ([`scale`]): the suspects;
//! 2. when the scale was inflated, the fit again without the
//!    suspects, every pose's `T_i` about it against its own variance factor
//!    (`s²₋ᵢ = (Ω − T_i) / (R − k)` for a pose in the fit, `Ω / R` for one
//!    left out): the suspects confirmed ([`REFITS`] such fits; at most a
//!    tenth of the poses).
//!
//! A suspect is set aside only when the model fitted without it predicts the
//! poses no test flagged significantly better held-out
//! ([`crate::calibration::validation::folds`], the paired test of
//! [`crate::calibration::validation::stats::significantly_smaller`] at 5 %) than the model
//! fitted with it, the other suspects left out of both: on a small real set a
//! pose far from the others can be the one that carries the information. Either
//! way the summary gives both figures.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, Par, Side};

use crate::calibration::dense::unit_diagonal_scale;
use crate::calibration::fit::Linearization;
use crate::calibration::validation::folds::{Folds, HeldOut, Role, Subset, interleaved_folds};
use crate::calibration::validation::stats::{f_quantile, significantly_smaller};
use crate::session::observation::Contact;

/// The family-wise error rate of the test over all poses.
pub const ALPHA: f64 = 0.01;

/// The fits without the suspects the screen makes (each followed by the test
/// again about it): one confirms the robust screen's suspects at the clean
/// fit's own noise; the robust scale is not masked, so more rarely change
/// them, and each costs a fit.
pub const REFITS: usize = 1;

/// A pose the test flags.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Suspect {
    /// Its index among the poses tested.
    pub pose: usize,
    /// Its deleted-residual statistic.
    pub f: f64,
    /// The Bonferroni threshold it exceeds.
    pub threshold: f64,
}

/// The outcome for one suspect pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blunder {
    /// Index into the data as given.
    pub pose: usize,
    /// The test statistic and its threshold.
    pub f: f64,
    /// The Bonferroni threshold.
    pub threshold: f64,
    /// Held-out RMS (m) of the other poses with the pose in every training set.
    pub held_with: f64,
    /// Held-out RMS (m) of the other poses without it.
    pub held_without: f64,
    /// Whether it was set aside: only when the other poses' held-out errors
    /// drop significantly without it (the paired test at 5 %).
    pub set_aside: bool,
}

/// The scale the deleted residuals are tested against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    /// The robust variance factor of every pose's deleted residual
    /// ([`robust_scale`]): the first screen, which blunders cannot inflate.
    Robust(f64),
    /// The fit's own weighted sum of squares over the poses it was fitted to,
    /// less the pose's own (`s²₋ᵢ`; a pose left out of the fit is tested
    /// against `Ω / R`): the efficient scale, when nothing inflates it or
    /// once the suspects are left out of the fit.
    Fitted,
}

/// The deleted residuals of every pose about one fit.
#[derive(Clone, Debug)]
pub struct Deleted {
    /// Each pose's `T_i` (the squared norm of its deleted residual in units of
    /// the fit's weights) and its rows `k`.
    pub stats: Vec<(f64, usize)>,
    /// The weighted sum of squares `Ω` of the rows the fit was fitted to.
    pub omega: f64,
}

/// The rows [`deleted_residuals`] solves between two questions to the
/// caller's request to stop (a few ms).
const CANCEL_ROWS: usize = 8192;

/// Each pose's deleted residual about the fit `lin` linearises, which was
/// fitted to the poses not `excluded`. A pose in the fit has
/// `T_i = r_iᵀ (I − H_ii)⁻¹ r_i`; one left out is predicted, and its residual
/// has the covariance `I + H_ii`: `T_i = r_iᵀ (I + H_ii)⁻¹ r_i`. `None` when
/// the fit's normal matrix is singular, or once the caller asked to stop
/// ([`Linearization::cancel`], asked every 8,192 rows).
pub fn deleted_residuals(lin: &Linearization, excluded: &[bool]) -> Option<Deleted> {
    let p = lin.j.ncols();
    let n = lin.poses();
    // The rows of the fit: every included pose's, and every known distance's.
    let fitted: Vec<usize> = (0..lin.first_rows.len())
        .filter(|&i| i >= n || !excluded[i])
        .collect();
    // Each product below is a pass over the rows: none starts once the
    // caller asked to stop.
    let cancel = lin.cancel;
    if cancel.requested() {
        return None;
    }
    // Every row fitted (no pose left out): the linearisation's own rows, not
    // a copy of them.
    let gathered;
    let (jf, rf) = if fitted.len() == lin.first_rows.len() {
        (lin.j.as_ref(), lin.r.as_ref())
    } else {
        gathered = lin.gathered(&fitted);
        (gathered.0.as_ref(), gathered.1.as_ref())
    };
    if cancel.requested() {
        return None;
    }
    let a = jf.transpose() * jf;
    if cancel.requested() {
        return None;
    }
    let scale = unit_diagonal_scale(&a);
    let normal = Mat::from_fn(p, p, |i, j| {
        (a[(i, j)] + if i == j { lin.precision[i] } else { 0.0 }) * scale[i] * scale[j]
    });
    // With N = L Lᵀ in the scaled unknowns, H = (JS) N⁻¹ (JS)ᵀ = BᵀB for
    // B = L⁻¹ (JS)ᵀ: one triangular solve for every row at once, then each
    // pose's block H_ii from its own columns of B.
    let llt = normal.llt(Side::Lower).ok()?;
    // B in blocks of CANCEL_ROWS rows' columns, each made and solved alone
    // (each row's column is solved alone), so that the caller's request to
    // stop is asked between them (`None` once it is).
    let columns = lin.j.nrows();
    let mut blocks = Vec::with_capacity(columns.div_ceil(CANCEL_ROWS));
    for start in (0..columns).step_by(CANCEL_ROWS) {
        if cancel.requested() {
            return None;
        }
        let width = CANCEL_ROWS.min(columns - start);
        let mut block = Mat::from_fn(p, width, |c, row| lin.j[(start + row, c)] * scale[c]);
        solve_lower_triangular_in_place(llt.L(), block.as_mut(), Par::Seq);
        blocks.push(block);
    }
    let b = |c: usize, row: usize| blocks[row / CANCEL_ROWS][(c, row % CANCEL_ROWS)];
    let omega = rf.squared_norm_l2();
    // Each pose's `I ± H_ii` (its `k` rows: 1, 3 or 6) factorised in place in
    // one matrix and scratch reused pose after pose (faer's Cholesky, the
    // lower half), and `T_i = r_iᵀ (L Lᵀ)⁻¹ r_i = ‖L⁻¹ r_i‖²`.
    let most = (0..n).map(|i| lin.rows_of(i).len()).max().unwrap_or(0);
    let mut m = Mat::<f64>::zeros(most, most);
    let mut y = Mat::<f64>::zeros(most, 1);
    let mut scratch = MemBuffer::new(cholesky_in_place_scratch::<f64>(
        most,
        Par::Seq,
        Default::default(),
    ));
    let mut stats = Vec::with_capacity(n);
    for (i, &out) in excluded.iter().enumerate().take(n) {
        if i % CANCEL_ROWS == 0 && cancel.requested() {
            return None;
        }
        let rows = lin.rows_of(i);
        let k = rows.len();
        let sign = if out { 1.0 } else { -1.0 };
        let mut m = m.as_mut().submatrix_mut(0, 0, k, k);
        for s in 0..k {
            for r in s..k {
                let h: f64 = (0..p)
                    .map(|c| b(c, rows.start + r) * b(c, rows.start + s))
                    .sum();
                let identity = if r == s { 1.0 } else { 0.0 };
                m[(r, s)] = identity + sign * h;
            }
        }
        let mut y = y.as_mut().subrows_mut(0, k);
        for r in 0..k {
            y[(r, 0)] = lin.r[(rows.start + r, 0)];
        }
        let factored = cholesky_in_place(
            m.as_mut(),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut scratch),
            Default::default(),
        );
        let t = match factored {
            Ok(_) => {
                solve_lower_triangular_in_place(m.as_ref(), y.as_mut(), Par::Seq);
                y.squared_norm_l2()
            }
            Err(_) => f64::INFINITY,
        };
        stats.push((t, k));
    }
    Some(Deleted { stats, omega })
}

/// The median of `χ²_k`: `k` times the median of `F(k, ∞)`; computed once
/// per process for the row counts a pose has (1, 3, 6: tens of µs each, a
/// tenth of a fit).
fn chi_squared_median(k: usize) -> f64 {
    use std::sync::OnceLock;
    static MEDIANS: [OnceLock<f64>; 7] = [const { OnceLock::new() }; 7];
    let compute = || k as f64 * f_quantile(0.5, k as f64, 1e9);
    MEDIANS
        .get(k)
        .map_or_else(compute, |m| *m.get_or_init(compute))
}

/// The robust variance factor of the deleted residuals `stats`: the median
/// over the poses of `T_i / med(χ²_k)`. A good pose's `T_i / σ²` follows
/// `χ²_k`, so each term has the median `σ²`; blunders, however large, move
/// the median of the terms by no more than their share of the poses
/// (breakdown point one half), where the mean square `Ω / R` grows with the
/// square of each blunder.
pub fn robust_scale(stats: &[(f64, usize)]) -> f64 {
    let mut medians = std::collections::HashMap::new();
    let mut terms: Vec<f64> = stats
        .iter()
        .map(|&(t, k)| t / *medians.entry(k).or_insert_with(|| chi_squared_median(k)))
        .collect();
    if terms.is_empty() {
        return 0.0;
    }
    let half = terms.len() / 2;
    *terms.select_nth_unstable_by(half, f64::total_cmp).1
}

/// How far the mean square of a fit's residuals may exceed the robust scale
/// of its deleted residuals before the fit is made again without the
/// suspects: a factor 2 in variance, the noise the rows were weighed by √2
/// off in σ. Below it the fit weighs its rows against the prior much as a
/// clean fit would, and the suspects are judged about it as it is (an
/// unmodelled effect's heavier tail raises the ratio to 1.2–1.6; a few
/// blunders of 1–5 mm among 20 µm readings to 10–50).
pub const INFLATION: f64 = 2.0;

/// The scale to test a fit's deleted residuals against: the robust one when
/// the fit's own mean square `Ω / R` exceeds it by more than [`INFLATION`]
/// (blunders inflate the noise the fit weighed its rows by), else the fit's
/// own, which is the more efficient estimate (the median of `χ²` terms keeps
/// about 37 % of a normal sample's information on its variance, Hampel et al.
/// 1986, §2.3, and so flags more good poses by chance).
pub fn scale(deleted: Option<&Deleted>, redundancy: f64) -> Scale {
    let Some(deleted) = deleted else {
        return Scale::Fitted;
    };
    let robust = robust_scale(&deleted.stats);
    if redundancy >= 1.0 && robust > 0.0 && deleted.omega / redundancy > INFLATION * robust {
        Scale::Robust(robust)
    } else {
        Scale::Fitted
    }
}

/// The poses whose deleted residual exceeds the `1 − α/n` quantile of
/// `F(k, R − k)` at `scale` (`deleted` from [`deleted_residuals`],
/// `redundancy` the fit's `R`), the most suspect (largest `F` over its
/// threshold) first.
pub fn suspects(
    deleted: &Deleted,
    excluded: &[bool],
    scale: Scale,
    redundancy: f64,
) -> Vec<Suspect> {
    let (stats, omega) = (&deleted.stats, deleted.omega);
    let n = stats.len();
    let mut thresholds = std::collections::HashMap::new();
    let mut out: Vec<Suspect> = stats
        .iter()
        .enumerate()
        .filter_map(|(i, &(t, k))| {
            let dof = redundancy - k as f64;
            if dof < 1.0 || !t.is_finite() {
                return None;
            }
            // The variance factor the pose is measured against.
            let s2 = match scale {
                Scale::Robust(robust) => robust,
                // The fit's variance factor; less the pose's own share when
                // it was fitted to.
                Scale::Fitted if excluded[i] => omega / redundancy,
                Scale::Fitted => (omega - t).max(0.0) / dof,
            };
            let f = (t / k as f64) / s2.max(f64::MIN_POSITIVE);
            let threshold = *thresholds
                .entry(k)
                .or_insert_with(|| f_quantile(1.0 - ALPHA / n as f64, k as f64, dof));
            (f > threshold).then_some(Suspect {
                pose: i,
                f,
                threshold,
            })
        })
        .collect();
    out.sort_by(|a, b| (b.f / b.threshold).total_cmp(&(a.f / a.threshold)));
    out
}

/// Each of the `flagged` poses judged by the poses no test flagged (`k`
/// interleaved folds over them): held-out with it in every training set and
/// without it, the other flagged poses left out of both (the folds with every
/// flagged pose out serve as "without" for all, and each one's "with" adds
/// its rows to them), and set aside when the paired test at `level` finds
/// the others significantly better predicted without it. Poses are `lin`'s.
pub fn judge(lin: &Linearization, k: usize, flagged: &[Suspect], level: f64) -> Vec<Blunder> {
    let n = lin.poses();
    let mut excluded = vec![false; n];
    for s in flagged {
        excluded[s.pose] = true;
    }
    let others: Vec<Contact> = (0..n)
        .filter(|&i| !excluded[i])
        .map(|i| lin.contacts[i])
        .collect();
    let configurations: Vec<usize> = (0..n)
        .filter(|&i| !excluded[i])
        .map(|i| lin.configurations[i])
        .collect();
    if flagged.is_empty() || others.len() < 2 {
        return Vec::new();
    }
    let k = k.clamp(2, others.len());
    let mut folds = interleaved_folds(&others, &configurations, k).into_iter();
    let roles = (0..n)
        .map(|i| {
            if excluded[i] {
                Role::Out
            } else {
                Role::Fold(folds.next().unwrap_or(0))
            }
        })
        .collect();
    let without_all = Folds::new(lin, roles);
    let all = Subset {
        columns: (0..lin.j.ncols()).collect(),
        precision_factor: 1.0,
    };
    // The held-out errors of the poses no test flagged.
    let of_others = |folds: &Folds| -> Option<Vec<f64>> {
        folds.evaluate(&all).map(|e| {
            e.errors
                .into_iter()
                .enumerate()
                .filter(|(i, _)| !excluded[*i])
                .map(|(_, x)| x)
                .collect()
        })
    };
    let Some(without) = of_others(&without_all) else {
        return Vec::new();
    };
    flagged
        .iter()
        .filter_map(|s| {
            // Not judged once the caller asked to stop: its next check drops them.
            if lin.cancel.requested() {
                return None;
            }
            let with = of_others(&without_all.adding(s.pose))?;
            Some(Blunder {
                pose: s.pose,
                f: s.f,
                threshold: s.threshold,
                held_with: HeldOut::of(&with).rms,
                held_without: HeldOut::of(&without).rms,
                set_aside: significantly_smaller(&with, &without, level),
            })
        })
        .collect()
}
