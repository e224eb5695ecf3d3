//! Blunders: a pose is set aside only when the evidence against it is strong at
//! the estimated noise, and only when setting it aside improves the held-out
//! error of the other poses.
//!
//! The test is the deleted residual (Cook & Weisberg, *Residuals and Influence
//! in Regression*, 1982, §2.2) of each pose: with the weighted Jacobian `J`, the
//! MAP normal matrix `N = JᵀJ + P` and the pose's `k` rows (3, or 6 with an
//! orientation), the residual the fit would leave had the pose been left out
//! is `(I − H_ii)⁻¹ r_i` with `H_ii = J_i N⁻¹ J_iᵀ`, and
//!
//! `T_i = r_iᵀ (I − H_ii)⁻¹ r_i`
//!
//! is its squared norm in units of the noise. Against the noise estimated
//! without the pose, `s²₋ᵢ = (Ω − T_i) / (R − k)` (`Ω` the weighted sum of
//! squares, `R` the redundancy), `F_i = (T_i / k) / s²₋ᵢ` follows `F(k, R − k)`
//! when the pose is good. With `n` poses tested, a pose is suspect when `F_i`
//! exceeds the `1 − α/n` quantile (Bonferroni, α = 1 %): on clean data the
//! chance of suspecting any pose is at most 1 %.
//!
//! A suspect is set aside only when the model fitted without it predicts the
//! other poses significantly better held-out ([`super::cross_validation`],
//! the paired test of [`crate::calibration::stats::significantly_smaller`] at 5 %) than the
//! model fitted with it; either way the summary gives both figures.

use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, Par, Side};
use nalgebra::{DMatrix, DVector};

use super::cross_validation::{Folds, Role, Subset, interleaved_folds};
use crate::calibration::identify::full::{FullFit, Linearization, unit_diagonal_scale};
use crate::calibration::stats::f_quantile;
use crate::io::measurements::Contact;

/// The family-wise error rate of the test over all poses.
pub const ALPHA: f64 = 0.01;

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

/// The most suspect pose of a fit, if any exceeds its threshold (`lin`: the
/// linearisation of `fit`'s own unknowns at its solution).
pub fn most_suspect(fit: &FullFit, lin: &Linearization) -> Option<Suspect> {
    let p = lin.j.ncols();
    let n = lin.poses();
    let a = lin.j.transpose() * &lin.j;
    let scale = unit_diagonal_scale(&a);
    let normal = Mat::from_fn(p, p, |i, j| {
        (a[(i, j)] + if i == j { lin.precision[i] } else { 0.0 }) * scale[i] * scale[j]
    });
    // With N = L Lᵀ in the scaled unknowns, H = (JS) N⁻¹ (JS)ᵀ = BᵀB for
    // B = L⁻¹ (JS)ᵀ: one triangular solve for every row at once, then each
    // pose's block H_ii from its own columns of B.
    let llt = normal.llt(Side::Lower).ok()?;
    let mut b = Mat::from_fn(p, lin.j.nrows(), |c, row| lin.j[(row, c)] * scale[c]);
    solve_lower_triangular_in_place(llt.L(), b.as_mut(), Par::Seq);
    let omega = lin.r.squared_norm_l2();
    let redundancy = fit.redundancy;
    let mut worst: Option<Suspect> = None;
    let mut thresholds = std::collections::HashMap::new();
    for i in 0..n {
        let rows = lin.rows_of(i);
        let k = rows.len();
        if redundancy - (k as f64) < 1.0 {
            return None;
        }
        let i_minus_h = DMatrix::from_fn(k, k, |r, s| {
            let h: f64 = (0..p)
                .map(|c| b[(c, rows.start + r)] * b[(c, rows.start + s)])
                .sum();
            let identity = if r == s { 1.0 } else { 0.0 };
            identity - h
        });
        let ri = DVector::from_fn(k, |r, _| lin.r[(rows.start + r, 0)]);
        let Some(f) = i_minus_h.cholesky() else {
            continue;
        };
        let t = ri.dot(&f.solve(&ri));
        let rest = (omega - t).max(f64::MIN_POSITIVE) / (redundancy - k as f64);
        let stat = (t / k as f64) / rest;
        // The same for every pose of k rows.
        let threshold = *thresholds
            .entry(k)
            .or_insert_with(|| f_quantile(1.0 - ALPHA / n as f64, k as f64, redundancy - k as f64));
        if stat > threshold && worst.is_none_or(|w| stat / threshold > w.f / w.threshold) {
            worst = Some(Suspect {
                pose: i,
                f: stat,
                threshold,
            });
        }
    }
    worst
}

/// The held-out errors (m) of every pose but `suspect`, in order (interleaved
/// folds over them, `k` of them), with the suspect in every training set
/// ([`Role::Train`]) or in none ([`Role::Out`]).
pub fn held_out_of_others(
    lin: &Linearization,
    k: usize,
    suspect: usize,
    role: Role,
) -> Option<Vec<f64>> {
    let n = lin.poses();
    let k = k.clamp(2, n.saturating_sub(1).max(2));
    let others: Vec<Contact> = (0..n)
        .filter(|&i| i != suspect)
        .map(|i| lin.contacts[i])
        .collect();
    let mut folds = interleaved_folds(&others, k).into_iter();
    let roles = (0..n)
        .map(|i| {
            if i == suspect {
                role
            } else {
                Role::Fold(folds.next().unwrap_or(0))
            }
        })
        .collect();
    let folds = Folds::new(lin, roles);
    let all = Subset {
        columns: (0..lin.j.ncols()).collect(),
        precision_factor: 1.0,
    };
    folds.evaluate(&all).map(|e| {
        e.errors
            .into_iter()
            .enumerate()
            .filter(|(i, _)| *i != suspect)
            .map(|(_, x)| x)
            .collect()
    })
}
