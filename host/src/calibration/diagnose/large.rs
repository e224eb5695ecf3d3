//! Long sessions: the model chosen on an evenly spread sample of the rows,
//! the calibration fitted to every row.
//!
//! A laser tracker streaming 1,000 points a second measures 10⁶ positions in
//! a quarter of an hour. Which geometric model, prior and effects the robot
//! needs is settled long before that: the held-out RMS of [`SELECTION_POSES`](crate::calibration::validation::folds::SELECTION_POSES)
//! poses is known to about 0.2 % (its standard error is `1/√(2n)` of it), and
//! the rows of a streamed session are consecutive points of a few paths, far
//! from independent. So a session of more rows is diagnosed, as any other
//! ([`super::diagnose_with_progress`]), on every `k`-th row (`k = ⌈n /
//! SELECTION_POSES⌉`): every held-out figure, model, test and effect is of
//! those poses. Then every row is screened about the chosen calibration and
//! the calibration refitted to the rows kept, from the sample's fit:
//!
//! - **Screen.** With `n` rows the leverage of each is about `p/n` (below
//!   10⁻³), so its deleted residual is its residual: a row whose position
//!   residual `e` gives `F = (e²/σ²)/3` above the `1 − α/n` quantile of `F(3,
//!   R)` (`σ` and its redundancy `R` the sample fit's, estimated on poses
//!   already screened for blunders, which the rest therefore cannot inflate;
//!   α = 1 %, Bonferroni over the rows) is set aside: what [`crate::calibration::validation::blunders`]
//!   does about a fit, without its held-out judgement, which a row among 10⁵
//!   others cannot change.
//! - **Refit.** The chosen geometry, prior, effects and tilts, fitted to the
//!   rows kept from the sample's fit: the calibration written. Its in-sample
//!   figure and ranges are of those rows. The geometric fallback the file
//!   carries stays the sample's.
//!
//! A session without a tracker (its rows at unknown points and planes) is
//! never this long and is diagnosed whole. Units: SI.

use armcal_shared::Robot;
use armcal_shared::units::Units;

use super::{ALPHA, Choice, DiagnoseOptions, Diagnosis};
use crate::calibration::fit::{Extension, FitRequest, FullError, FullOptions};
use crate::calibration::validation::stats::f_quantile;
use crate::session::constraints::Constraints;
use crate::session::rows::Rows;

/// How a long session was diagnosed: on a sample, the calibration on all.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Selection {
    /// The session's rows.
    pub rows: usize,
    /// Every how many rows the sample takes one.
    pub every: usize,
    /// The poses the model was chosen on.
    pub poses: usize,
    /// The rows the screen about the chosen calibration set aside.
    pub set_aside: usize,
}

/// The diagnosis of a session of more than
/// [`DiagnoseOptions::selection_poses`] rows of measured coordinates (see the
/// module header).
pub(super) fn diagnose_large(
    nominal: &Robot<f64>,
    data: Rows<'_>,
    options: &DiagnoseOptions,
    progress: &mut dyn FnMut(usize, usize, usize),
) -> Result<Diagnosis, FullError> {
    let every = data.len().div_ceil(options.selection_poses.max(1));
    let sample: Vec<usize> = (0..data.len()).step_by(every).collect();
    let rows = data.positions_of(sample.iter().copied());
    let rows = Rows::picked(data.all(), &rows);
    let mut d =
        super::diagnose_with_progress(nominal, rows, &Constraints::default(), options, progress)?;
    for b in &mut d.blunders {
        *b = sample[*b];
    }
    for s in &mut d.suspects {
        s.pose = sample[s.pose];
    }
    // Every row screened about the chosen calibration.
    let sigma = d.fit.noise.position.used;
    let dof = d.fit.redundancy.max(1.0);
    let threshold = f_quantile(1.0 - ALPHA / data.len() as f64, 3.0, dof);
    let errors = d.position_errors(nominal, data);
    let flagged: Vec<usize> = errors
        .iter()
        .enumerate()
        .filter(|(_, e)| e.is_some_and(|e| (e / sigma).powi(2) / 3.0 > threshold))
        .map(|(i, _)| i)
        .collect();
    let mut blunders = d.blunders.clone();
    blunders.extend(&flagged);
    blunders.sort_unstable();
    blunders.dedup();
    let kept = data.positions_of((0..data.len()).filter(|i| blunders.binary_search(i).is_err()));
    let kept = Rows::picked(data.all(), &kept);
    if let Choice::Calibrated {
        geometry, prior, ..
    } = d.choice
    {
        let fit_options = FullOptions {
            geometry,
            prior,
            ..options.fit.at_noise_of(&d.fit).stated()
        };
        let extra: Vec<_> = d
            .findings
            .iter()
            .flat_map(|f| f.candidate.extra.iter().copied())
            .collect();
        d.fit = FitRequest::new(nominal, kept, &fit_options)
            .extended(Extension {
                effects: &d.fit.fitted_effects(),
                extra: &extra,
            })
            .starting_from(Some(&d.fit.calibrated))
            .constrained(&Constraints::default())
            .run()?;
        d.noise = d.fit.noise.tool_point().shown;
    }
    d.blunders = blunders;
    d.ranges = crate::session::observation::ranges(kept);
    d.fitted = d.fitted_at(nominal, kept);
    d.selection = Some(Selection {
        rows: data.len(),
        every,
        poses: sample.len(),
        set_aside: flagged.len(),
    });
    Ok(d)
}

impl Diagnosis {
    /// The position error (m) of the calibration written at each row of
    /// `data` (`None` where it has no measured position, `∞` where the model
    /// cannot be evaluated), its model evaluated as `armcal predict`
    /// evaluates it. The fit's request to stop is asked every
    /// [`crate::cancel::ROWS`] rows; once it is, the rows left have none (`None`):
    /// the caller's next check drops them.
    pub(super) fn position_errors(&self, nominal: &Robot<f64>, data: Rows<'_>) -> Vec<Option<f64>> {
        let task = crate::session::observation::task(data);
        let model = self.calibration(nominal, task, Units::SI).model();
        // Each session's rows as its own frames place the written model.
        let models = self.fit.registrations.effect_models(&model);
        let cancel = self.fit.cancel;
        let mut stopped = false;
        data.iter()
            .enumerate()
            .map(|(i, o)| {
                stopped = stopped || cancel.requested_at(i);
                let measured = o.contact == crate::session::observation::Contact::Measured;
                (measured && !stopped).then(|| {
                    crate::session::registration::in_session(&models, o.session)
                        .forward(&o.q, &o.context)
                        .map_or(f64::INFINITY, |t| {
                            (o.position.coords - t.translation.vector).norm()
                        })
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::diagnose::diagnose;
    use crate::calibration::simulate::{Scenario, simulate};
    use crate::io::model_file::load_model;

    /// A session longer than the sample (600 tracker positions of a UR5e, σ
    /// = 20 µm, the model chosen on every 3rd) with four blunders of 2 mm in
    /// rows the sample does not take: the screen about the chosen
    /// calibration sets each aside, the calibration is fitted to the 596
    /// rows kept, and it predicts them as well as the diagnosis of the whole
    /// session does (in-sample RMS within 5 %: both are the noise, 35 µm in
    /// 3-D, plus an estimation error of a few µm).
    #[test]
    fn a_long_session_is_chosen_on_a_sample_and_fitted_to_every_row() {
        let nominal = load_model("ur5e").unwrap().robot;
        let mut data = simulate(&nominal, &Scenario::tracker(600, 11))
            .unwrap()
            .observations;
        let blunders = [1, 301, 452, 599];
        for &i in &blunders {
            data[i].position.x += 2e-3;
        }
        let whole = diagnose(&nominal, &data, &DiagnoseOptions::default()).unwrap();
        let options = DiagnoseOptions {
            selection_poses: 200,
            ..DiagnoseOptions::default()
        };
        let d = diagnose(&nominal, &data, &options).unwrap();
        let selection = d.selection.unwrap();
        assert_eq!(
            (selection.rows, selection.every, selection.poses),
            (600, 3, 200)
        );
        for b in blunders {
            assert!(d.blunders.contains(&b), "{b} not in {:?}", d.blunders);
        }
        assert_eq!(d.blunders.len(), blunders.len(), "{:?}", d.blunders);
        assert_eq!(d.fit.equations, 3 * (600 - blunders.len()));
        let (large, all) = (d.fitted.unwrap().rms, whole.fitted.unwrap().rms);
        assert!((large / all - 1.0).abs() < 0.05, "{large} {all}");
        assert!(whole.selection.is_none());
    }
}
