//! The rows `identify`'s fit explains worst, named when they fail the
//! deleted-residual test: what `identify` says of a blunder it fitted.
//!
//! `identify` fits every row it is given; a single blunder (a reading taken
//! on the wrong target, a 5 mm jump in 200 rows of 20 µm noise) moves the
//! calibration without any figure showing it. So its final fit is
//! linearised (the identified unknowns, each session's own frames and the
//! fitted points and planes among them, at the prior it was fitted at) and
//! every pose's deleted residual tested as `diagnose` tests it
//! ([`crate::calibration::validation::blunders`]: `F_i` against the `1 −
//! α/n` quantile of `F(k, R − k)`, α = 1 % over the poses, at the robust
//! scale when the fit's mean square is inflated, a suspect there confirmed
//! at the fit's scale without the suspects). The poses that fail are
//! named, the most suspect first, at most [`NAMED`] of them; `identify`
//! keeps fitting them (setting a row aside is `diagnose`'s judgement, which
//! asks whether the others are then predicted better).
//!
//! Cost: one factorisation of the normal matrix and one triangular solve for
//! every row, as a Gauss–Newton step of the fit. A session of more than
//! [`SELECTION_POSES`] rows (where `diagnose` chooses its model on a
//! sample) is not tested: there the leverage of a row is below 10⁻³ and
//! `diagnose` screens every row's residual against the sample's noise
//! ([`crate::calibration::diagnose::large`]), while `identify` stays as
//! fast as its fit. Units: SI.

use crate::calibration::dense::unit_diagonal_scale;
use crate::calibration::fit::{Extension, FullFit, Linearization, linearize};
use crate::calibration::validation::blunders::{self, ALPHA, Deleted, Scale, Suspect};
use crate::calibration::validation::folds::SELECTION_POSES;
use crate::session::constraints::Constraints;
use crate::session::observation::Observation;
use crate::session::prior::Prior;
use faer::linalg::solvers::Solve;
use faer::{Col, Mat, Side};

/// The most rows named, the worst first: a fit with more such rows has a
/// problem `diagnose` should judge as a whole.
pub const NAMED: usize = 3;

/// A pose whose deleted residual fails the test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SuspectRow {
    /// Its index among the poses.
    pub pose: usize,
    /// The length of its position residual about the fit, m (its distance
    /// along the normal for a touch of a plane).
    pub residual: f64,
    /// Its deleted-residual statistic `F_i`.
    pub f: f64,
    /// The Bonferroni threshold `F_i` exceeds.
    pub threshold: f64,
}

/// The rows `identify`'s fit explains worst when they fail the test.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SuspectRows {
    /// At most [`NAMED`] of them, the most suspect first.
    pub named: Vec<SuspectRow>,
    /// How many poses fail the test in all.
    pub failing: usize,
    /// The poses tested.
    pub tested: usize,
}

/// The poses of `data` (with `constraints`) that `fit`, made at `prior`,
/// explains worst and that fail the deleted-residual test (see the module
/// header); none above [`SELECTION_POSES`] poses, or when the fit leaves too
/// little redundancy to test a pose.
pub fn of_fit(
    fit: &FullFit,
    data: &[Observation],
    constraints: &Constraints,
    prior: &Prior,
) -> SuspectRows {
    if data.len() > SELECTION_POSES || data.is_empty() {
        return SuspectRows::default();
    }
    let mut lin = linearize(fit, Extension::NONE, data, constraints, prior);
    let none = vec![false; data.len()];
    let Some(deleted) = blunders::deleted_residuals(&lin, &none) else {
        return SuspectRows::default();
    };
    let scale = blunders::scale(Some(&deleted), fit.redundancy);
    // The residuals about identify's fit, before any fit without suspects.
    let fitted = lin.r.clone();
    if fit.cancel.requested() {
        return SuspectRows::default();
    }
    let flagged = confirmed(
        &mut lin,
        &deleted,
        blunders::suspects(&deleted, &none, scale, fit.redundancy),
        scale,
        fit.redundancy,
    );
    let named = flagged
        .iter()
        .take(NAMED)
        .map(|s| {
            let rows = lin.rows_of(s.pose);
            let position_rows = data[s.pose].position_rows();
            let squares: f64 = (rows.start..rows.start + position_rows)
                .map(|r| fitted[(r, 0)].powi(2))
                .sum();
            SuspectRow {
                pose: s.pose,
                residual: squares.sqrt() * lin.noise[s.pose],
                f: s.f,
                threshold: s.threshold,
            }
        })
        .collect();
    SuspectRows {
        named,
        failing: flagged.len(),
        tested: data.len(),
    }
}

/// The suspects `flagged` about `lin` at the robust scale, confirmed as
/// `diagnose` confirms them ([`blunders::REFITS`]): the fit made again
/// without them (here by one MAP Gauss–Newton step on the other rows from
/// the fit's solution, `(J_Tᵀ J_T + P) δ = J_Tᵀ r_T − P o`, what
/// `diagnose`'s cross-validation solves per fold), and every pose tested
/// about it at its own scale, the suspects as poses it predicts. A fit
/// pulled by a blunder misses its neighbours too; the fit without it does
/// not, and the robust scale (a median) flags good poses at the edge of the
/// test more often than its level says. Suspects at the fit's own scale are
/// as they are; so are more than a tenth of the poses (a fit that
/// misses that many is `diagnose`'s to judge as a whole).
fn confirmed(
    lin: &mut Linearization,
    deleted: &Deleted,
    flagged: Vec<Suspect>,
    scale: Scale,
    redundancy: f64,
) -> Vec<Suspect> {
    let n = lin.poses();
    if !matches!(scale, Scale::Robust(_)) || flagged.is_empty() || flagged.len() > n / 10 {
        return flagged;
    }
    let mut excluded = vec![false; n];
    for s in &flagged {
        excluded[s.pose] = true;
    }
    let kept: Vec<usize> = (0..lin.first_rows.len())
        .filter(|&i| i >= n || !excluded[i])
        .collect();
    let (jt, rt) = lin.gathered(&kept);
    let a = jt.transpose() * &jt;
    let b = jt.transpose() * &rt;
    let p = a.ncols();
    let scale = unit_diagonal_scale(&a);
    let normal = Mat::from_fn(p, p, |i, j| {
        (a[(i, j)] + if i == j { lin.precision[i] } else { 0.0 }) * scale[i] * scale[j]
    });
    let rhs = Col::from_fn(p, |c| {
        (b[(c, 0)] - lin.precision[c] * lin.offset[c]) * scale[c]
    });
    let Some(step) = normal.llt(Side::Lower).ok().map(|f| f.solve(&rhs)) else {
        return flagged;
    };
    let delta = Mat::from_fn(p, 1, |c, _| step[c] * scale[c]);
    lin.r = &lin.r - &lin.j * &delta;
    let rows: usize = flagged.iter().map(|s| deleted.stats[s.pose].1).sum();
    let Some(about) = blunders::deleted_residuals(lin, &excluded) else {
        return flagged;
    };
    blunders::suspects(&about, &excluded, Scale::Fitted, redundancy - rows as f64)
}

/// The family-wise level of the test, as a warning states it: `1 − 1 %/200`.
pub fn quantile_name(tested: usize) -> String {
    format!("1 − {:.0} %/{tested}", ALPHA * 100.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::fit::{FitRequest, FullOptions};
    use crate::calibration::simulate::{measure, random_configurations, rng};
    use crate::io::model_file::load_model;

    /// A UR5e measured at 200 positions (σ = 20 µm per axis), one reading
    /// moved 5 mm along x: that row alone fails the test (its F is of the
    /// order (5 mm / 20 µm)² / 3 ≈ 2·10⁴ against a threshold near 20), its
    /// residual above half the blunder (the fit, not knowing it, absorbs a
    /// part). Without the blunder no row fails (at most 1 % of such sessions
    /// would name one).
    #[test]
    fn identify_names_a_single_blunder_and_nothing_on_clean_rows() {
        let nominal = load_model("ur5e").unwrap().robot;
        let mut r = rng(11);
        let q = random_configurations(&nominal, 200, &mut r);
        let mut truth = nominal.clone();
        truth.links[1].a += 0.3e-3;
        let clean = measure(&truth, &q, 20e-6, None, &mut r);
        let options = FullOptions::default();
        let test = |rows: &[Observation]| {
            let fit = FitRequest::new(&nominal, rows, &options).run().unwrap();
            of_fit(&fit, rows, &Constraints::default(), &options.prior)
        };
        let none = test(&clean);
        assert_eq!(none.failing, 0, "{none:?}");
        let mut blundered = clean.clone();
        blundered[57].position.x += 5e-3;
        let found = test(&blundered);
        assert_eq!(found.failing, 1, "{found:?}");
        let row = found.named[0];
        assert_eq!(row.pose, 57);
        assert!(row.f > 100.0 * row.threshold, "{row:?}");
        assert!(row.residual > 2.5e-3 && row.residual < 5.5e-3, "{row:?}");
    }
}
