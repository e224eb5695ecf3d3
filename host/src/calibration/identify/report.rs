//! The identification as data: [`IdentifyReport`], the JSON of
//! `armcal identify --json` (docs/file-formats.md §6) and the dictionary
//! Python's `Identification.report` returns, both this type serialised.
//! Values in the model file's units (`mm`-suffixed fields excepted); the
//! noise rows ([`NoiseRow`]) are `diagnose`'s too. Nothing here computes; it
//! reads an [`Identification`].

use armcal_shared::units::Units;
use serde::{Serialize, Serializer};

use super::Identification;
use super::channel_weight::WeightReports;
use super::prior_scale::PriorChoice;
use super::sessions::{self, SessionReport};
use crate::calibration::fit::{FullFit, noise};
use crate::calibration::gravity::GravityReport;
use crate::calibration::validation::acceptance::Residual as Judged;
use crate::report::units::UnitsReport;
use crate::report::units::param_in_units;
use crate::session::channel::Channel;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use armcal_shared::compensation::Task;

/// One channel's noise as the reports show it, in the model's units.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NoiseRow {
    /// The channel's name (`position`, `point contact`, … `distance`).
    #[serde(rename = "channel")]
    pub what: &'static str,
    /// The noise the rows were weighed by.
    pub used: f64,
    /// The noise the residuals show.
    #[serde(rename = "shown_by_residuals")]
    pub shown: f64,
    /// Stated or estimated.
    #[serde(serialize_with = "source_name")]
    pub source: noise::NoiseSource,
    /// The unit of both (the model's length unit, its angle unit for
    /// orientations).
    pub unit: String,
}

/// How far one channel's noise can be checked, and the weight it was
/// fitted at: the summary's reading of a [`NoiseRow`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NoiseCheck {
    /// The channel's name, as its [`NoiseRow`]'s.
    pub channel: &'static str,
    /// Its rows beyond the unknowns they determine (below 1: too few to
    /// check a stated noise).
    pub redundancy: f64,
    /// The factor on the weight its noise gives its rows (1: full weight).
    pub weight: f64,
}

impl NoiseRow {
    /// `stated` or `estimated`, as the reports say it.
    pub fn source_name(&self) -> &'static str {
        match self.source {
            noise::NoiseSource::Stated => "stated",
            noise::NoiseSource::Estimated => "estimated",
        }
    }
}

/// [`NoiseRow::source`] as its name.
fn source_name<S: Serializer>(source: &noise::NoiseSource, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(match source {
        noise::NoiseSource::Stated => "stated",
        noise::NoiseSource::Estimated => "estimated",
    })
}

/// The noise of each channel the data have ([`noise::NoiseEstimate::rows`]),
/// in the model's units, for reports.
pub fn noise_rows(noise: &noise::NoiseEstimate, units: &Units) -> Vec<NoiseRow> {
    noise
        .rows()
        .into_iter()
        .map(|(channel, n)| {
            let (in_units, unit): (fn(&Units, f64) -> f64, String) =
                if channel == Some(Channel::Orientation) {
                    (Units::angle_from_si, units.angle.to_string())
                } else {
                    (Units::length_from_si, units.length.to_string())
                };
            NoiseRow {
                what: channel.map_or("distance", Channel::name),
                used: in_units(units, n.used),
                shown: in_units(units, n.shown),
                source: n.source,
                unit,
            }
        })
        .collect()
}

/// Each channel's [`NoiseCheck`] in `fit`, in the order of its
/// [`noise_rows`].
pub fn noise_checks(fit: &FullFit) -> Vec<NoiseCheck> {
    fit.noise
        .rows()
        .into_iter()
        .map(|(channel, n)| NoiseCheck {
            channel: channel.map_or("distance", Channel::name),
            redundancy: n.redundancy,
            // The known distances' weight is their noise's.
            weight: channel.map_or(1.0, |c| fit.weights.of_channel(c)),
        })
        .collect()
}

/// `armcal identify`'s report (docs/file-formats.md §6). The fields after
/// `warnings` are the full model's (`--params full`), absent for the
/// paper's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct IdentifyReport {
    /// The model's name.
    pub model: String,
    /// Its joints.
    pub joints: usize,
    /// The data file (several sessions: their files), as the summary names
    /// it. Not in the JSON: two reports of the same rows compare equal
    /// whatever their files are called (a session's and a row's file are,
    /// where several files must be told apart).
    #[serde(skip)]
    pub data: String,
    /// The poses fitted.
    pub poses: usize,
    /// `pose` (full poses) or `position`: what the calibration compensates.
    pub task: TaskReport,
    /// `full` or `paper`.
    pub params: &'static str,
    /// Iterations run.
    pub iterations: usize,
    /// Whether they converged.
    pub converged: bool,
    /// Every parameter.
    pub parameters: Vec<ParameterReport>,
    /// The calibration's residuals on the rows.
    pub residual: Residual,
    /// The model file's units, which the values are in.
    pub units: UnitsReport,
    /// The masses' fit to the measured torques, when the rows have them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gravity: Option<GravityReport>,
    /// What the user should know before trusting the calibration.
    pub warnings: Vec<String>,
    /// The rows the fit explains worst that fail the deleted-residual test.
    pub suspect_rows: Vec<SuspectRowReport>,
    /// The rows that test tested.
    pub suspect_rows_tested: usize,
    /// Those failing it, named or not.
    pub suspect_rows_failing: usize,
    /// The nominal model's residual on the rows, once judged.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nominal_residual: Option<NominalResidual>,
    /// The full model's statistics.
    #[serde(flatten)]
    pub full: Option<FullReport>,
}

/// One parameter in the reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParameterReport {
    /// Its name (`a2`, `base.x`, …).
    pub name: String,
    /// Its nominal value.
    pub nominal: f64,
    /// Identified minus nominal.
    pub error: f64,
    /// Its standard error, when the method gives one.
    pub std: Option<f64>,
    /// `identified` or `fixed`.
    pub status: &'static str,
    /// Why it was held at nominal.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

impl ParameterReport {
    /// Its unit of `units`: the angle unit for an angle, else the length
    /// unit.
    pub fn unit<'a>(&self, units: &'a UnitsReport) -> &'a str {
        if self
            .name
            .parse::<armcal_shared::Param>()
            .is_ok_and(|p| p.is_angle())
        {
            &units.angle
        } else {
            &units.length
        }
    }

    /// Parameter `param` (its nominal value, error and standard error SI;
    /// `fixed`: why it was held) in `units`.
    pub fn of(
        units: &Units,
        param: armcal_shared::Param,
        nominal: f64,
        error: f64,
        std: Option<f64>,
        fixed: Option<&str>,
    ) -> Self {
        Self {
            name: param.to_string(),
            nominal: param_in_units(units, param, nominal),
            error: param_in_units(units, param, error),
            std: std.map(|s| param_in_units(units, param, s)),
            status: if fixed.is_some() {
                "fixed"
            } else {
                "identified"
            },
            reason: fixed.map(str::to_string),
        }
    }
}

/// A calibration's residuals on the rows it was fitted to.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Residual {
    /// RMS position residual, the model's length unit.
    pub position_rms: f64,
    /// RMS orientation residual, its angle unit (0 without orientations).
    pub orientation_rms: f64,
    /// RMS position residual, mm.
    pub position_rms_mm: f64,
}

/// A row the fit explains worst, failing the deleted-residual test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SuspectRowReport {
    /// Its file (several sessions), or the one file.
    pub file: String,
    /// Its line in that file.
    pub line: usize,
    /// The length of its residual, the model's length unit.
    pub residual: f64,
    /// The same, mm.
    pub residual_mm: f64,
    /// Its deleted-residual statistic.
    pub f: f64,
    /// The Bonferroni threshold it exceeds.
    pub threshold: f64,
}

/// What a calibration compensates, as the reports say it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TaskReport {
    /// Full poses: orientations and positions.
    Pose,
    /// Positions.
    Position,
}

impl From<Task> for TaskReport {
    fn from(task: Task) -> Self {
        match task {
            Task::Pose => Self::Pose,
            Task::Position => Self::Position,
        }
    }
}

/// The nominal model's residual on the rows, and the written calibration's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NominalResidual {
    /// RMS position residual, the model's length unit.
    pub position_rms: f64,
    /// The same, mm.
    pub position_rms_mm: f64,
    /// RMS orientation residual, the model's angle unit (`null` without
    /// orientations).
    pub orientation_rms: Option<f64>,
    /// The written calibration's on the same rows: what `armcal predict`
    /// gives with the file.
    pub calibrated: JudgedResidual,
    /// Whether the figures are the contacts' spread about the fitted points
    /// and planes (a session without a tracker) rather than position errors.
    pub contact_spread: bool,
}

/// A model's residual on the rows it is judged on.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JudgedResidual {
    /// RMS position residual, the model's length unit.
    pub position_rms: f64,
    /// The same, mm.
    pub position_rms_mm: f64,
    /// RMS orientation residual, the model's angle unit (`null` without
    /// orientations).
    pub orientation_rms: Option<f64>,
}

/// The full model's statistics in `identify`'s report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FullReport {
    /// Each session, when there are several.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sessions: Option<Vec<SessionReport>>,
    /// Of the scaled Jacobian.
    pub condition_number: f64,
    /// Its observability index.
    pub observability_index: f64,
    /// The residuals' variance over the noise's.
    pub variance_factor: f64,
    /// Scalar equations fitted.
    pub equations: usize,
    /// Each channel's noise.
    pub noise: Vec<NoiseRow>,
    /// Each channel's redundancy and weight, in the order of `noise`.
    pub noise_checks: Vec<NoiseCheck>,
    /// The prior fitted at.
    pub prior: PriorReport,
    /// The weights of orientations and contacts.
    #[serde(flatten)]
    pub weights: WeightReports,
    /// The strongly correlated pairs of parameters.
    pub correlations: Vec<CorrelationReport>,
    /// The contacts' points and planes, when the rows touch some.
    #[serde(flatten)]
    pub contacts: Option<ContactsReport>,
}

/// The prior as fitted at.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PriorReport {
    /// Its length scale, the model's unit (`null` for none).
    pub length: Option<f64>,
    /// Its angle scale, the model's unit (`null` for none).
    pub angle: Option<f64>,
    /// The factor on the stated one.
    pub factor: f64,
    /// How it was chosen.
    pub chosen_by: PriorChosenBy,
    /// The cross-validation's folds (`null`: none run).
    pub folds: Option<usize>,
    /// How far it reaches (the full fit's).
    pub reach: Option<f64>,
    /// Each factor's held-out score, when cross-validated.
    pub held_out: Option<Vec<PriorScoreReport>>,
}

/// How the prior's scale was chosen, as the reports say it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum PriorChosenBy {
    /// As stated, nothing tried.
    #[serde(rename = "stated")]
    Stated,
    /// As stated: no factor tried changes the held-out error materially.
    #[serde(rename = "stated: immaterial to the data")]
    Immaterial,
    /// As stated: no training set of the folds determines the model.
    #[serde(rename = "stated: folds undetermined")]
    Undetermined,
    /// The factor that predicts held-out poses best.
    #[serde(rename = "cross-validation")]
    CrossValidation,
}

/// One prior factor's held-out score.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PriorScoreReport {
    /// The factor.
    pub factor: f64,
    /// The held-out RMS at it, mm.
    pub rms_mm: f64,
}

/// A strongly correlated pair of parameters.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CorrelationReport {
    /// One.
    pub a: String,
    /// The other.
    pub b: String,
    /// Their correlation.
    pub r: f64,
}

/// The points and planes a session without a tracker touches.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ContactsReport {
    /// Each point (socket).
    pub points: Vec<PointReport>,
    /// Each plane.
    pub planes: Vec<PlaneReport>,
    /// Each known distance's residual, the model's length unit.
    pub distance_residuals: Vec<f64>,
    /// Each known distance, with its residual.
    pub distances: Vec<DistanceReport>,
}

/// A known distance between two points, and what the fit made of it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DistanceReport {
    /// The points' names (`?` for one not in the file).
    pub between: [String; 2],
    /// The distance stated, the model's length unit.
    pub length: f64,
    /// Fitted minus stated, the model's length unit.
    pub residual: f64,
    /// Its line in the constraints file.
    pub line: usize,
}

/// A point the tool touches, located by the fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointReport {
    /// Its name.
    pub name: String,
    /// Where it is, the model's length unit.
    pub xyz: [f64; 3],
    /// The standard error of each coordinate (`null`: not determined).
    pub std: Vec<Option<f64>>,
}

/// A plane the tool touches, located by the fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlaneReport {
    /// Its name.
    pub name: String,
    /// Its unit normal.
    pub normal: [f64; 3],
    /// Its distance from the origin, the model's length unit.
    pub offset: f64,
}

impl Identification {
    /// The report of an identification of `model` from `data`, in the
    /// model's units.
    pub fn report(&self, model: &RobotModel, data: &Measurements) -> IdentifyReport {
        let units = &model.units;
        let length = |x: f64| units.length_from_si(x);
        let angle = |x: f64| units.angle_from_si(x);
        let judged = |r: &Judged| JudgedResidual {
            position_rms: length(r.position),
            position_rms_mm: r.position * 1e3,
            orientation_rms: r.orientation.map(angle),
        };
        IdentifyReport {
            model: model.name.clone(),
            joints: model.robot.dof(),
            data: data.file.clone(),
            poses: data.poses.len(),
            task: self.calibration.task.into(),
            params: self.params.name(),
            iterations: self.iterations,
            converged: self.converged,
            parameters: self
                .parameters
                .iter()
                .map(|r| {
                    ParameterReport::of(
                        units,
                        r.param,
                        r.nominal,
                        r.error,
                        r.std,
                        r.fixed.as_deref(),
                    )
                })
                .collect(),
            residual: Residual {
                position_rms: length(self.position_rms),
                orientation_rms: units.angle_from_si(self.orientation_rms),
                position_rms_mm: self.position_rms * 1e3,
            },
            units: UnitsReport::from(units),
            gravity: self.gravity.as_ref().map(|g| g.report()),
            warnings: self.warnings(data, units),
            suspect_rows: self
                .suspect_rows
                .named
                .iter()
                .map(|r| SuspectRowReport {
                    file: data.file_of(r.pose).to_string(),
                    line: data.lines[r.pose],
                    residual: length(r.residual),
                    residual_mm: r.residual * 1e3,
                    f: r.f,
                    threshold: r.threshold,
                })
                .collect(),
            suspect_rows_tested: self.suspect_rows.tested,
            suspect_rows_failing: self.suspect_rows.failing,
            nominal_residual: self.judgement.as_ref().map(|j| NominalResidual {
                position_rms: length(j.nominal.position),
                position_rms_mm: j.nominal.position * 1e3,
                orientation_rms: j.nominal.orientation.map(angle),
                calibrated: judged(&j.calibrated),
                contact_spread: data.is_constrained(),
            }),
            full: self.full.as_ref().map(|fit| FullReport {
                sessions: sessions::reports(fit, &self.sessions_held_out, data, units),
                condition_number: fit.condition_number,
                observability_index: fit.observability,
                variance_factor: fit.variance_factor,
                equations: fit.equations,
                noise: noise_rows(&fit.noise, units),
                noise_checks: noise_checks(fit),
                prior: self.prior_report(units),
                weights: self.weighting.reports(fit),
                correlations: fit
                    .correlations
                    .iter()
                    .map(|(a, b, r)| CorrelationReport {
                        a: a.to_string(),
                        b: b.to_string(),
                        r: *r,
                    })
                    .collect(),
                contacts: (!fit.points.is_empty() || !fit.planes.is_empty()).then(|| {
                    ContactsReport {
                        points: fit
                            .points
                            .iter()
                            .map(|p| PointReport {
                                name: p.name.clone(),
                                xyz: [
                                    length(p.position.x),
                                    length(p.position.y),
                                    length(p.position.z),
                                ],
                                std: p
                                    .std
                                    .iter()
                                    .map(|s| s.is_finite().then(|| length(*s)))
                                    .collect(),
                            })
                            .collect(),
                        planes: fit
                            .planes
                            .iter()
                            .map(|p| PlaneReport {
                                name: p.name.clone(),
                                normal: [p.normal.x, p.normal.y, p.normal.z],
                                offset: length(p.offset),
                            })
                            .collect(),
                        distance_residuals: fit
                            .distance_residuals
                            .iter()
                            .map(|d| length(*d))
                            .collect(),
                        distances: data
                            .constraints
                            .distances
                            .iter()
                            .zip(&fit.distance_residuals)
                            .map(|(d, r)| DistanceReport {
                                between: d.points.map(|k| {
                                    data.constraints
                                        .points
                                        .get(k)
                                        .map_or("?", |p| p.name.as_str())
                                        .to_string()
                                }),
                                length: length(d.length),
                                residual: length(*r),
                                line: d.line,
                            })
                            .collect(),
                    }
                }),
            }),
        }
    }

    /// What the user should know of this identification of `data` that
    /// does not stop it, one a line for standard error and the JSON's
    /// `warnings`: each session that does not reconcile with the others
    /// ([`super::sessions::warnings`]), each row named by
    /// [`super::suspect_rows`].
    fn warnings(&self, data: &Measurements, u: &Units) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(fit) = &self.full {
            out.extend(super::sessions::warnings(
                &self.sessions_held_out,
                data,
                super::sessions::sharing_of(fit),
                u,
            ));
        }
        let rows = &self.suspect_rows;
        out.extend(rows.named.iter().map(|r| {
            format!(
                "{}:{}: the fit explains this row worst: its residual {}, its deleted residual \
                 F = {:.3e} above {:.1} (the {} quantile of F(k, R − k)): a blunder? identify \
                 fitted it; `armcal diagnose` sets such rows aside when the others are \
                 predicted better without them",
                data.file_of(r.pose),
                data.lines[r.pose],
                crate::report::format::length_and_mm(u, r.residual),
                r.f,
                r.threshold,
                super::suspect_rows::quantile_name(rows.tested)
            )
        }));
        if rows.failing > rows.named.len() {
            out.push(format!(
                "{} more rows fail the deleted-residual test: run `armcal diagnose`",
                rows.failing - rows.named.len()
            ));
        }
        out
    }

    /// The report's `prior`: the scale fitted at (model units; `None` for
    /// none), the factor on the stated one, and how it was chosen.
    fn prior_report(&self, units: &Units) -> PriorReport {
        let factor = self.prior.as_ref().map_or(1.0, PriorChoice::factor);
        let scaled = self.stated_prior.scaled(factor);
        let finite = |x: f64| x.is_finite().then_some(x);
        let (chosen_by, folds, scores) = match &self.prior {
            None => (PriorChosenBy::Stated, None, None),
            Some(PriorChoice::Immaterial) => (PriorChosenBy::Immaterial, None, None),
            Some(PriorChoice::Undetermined { folds }) => {
                (PriorChosenBy::Undetermined, Some(*folds), None)
            }
            Some(PriorChoice::CrossValidated { folds, scores, .. }) => (
                PriorChosenBy::CrossValidation,
                Some(*folds),
                Some(scores.as_slice()),
            ),
        };
        PriorReport {
            length: finite(units.length_from_si(scaled.length)),
            angle: finite(units.angle_from_si(scaled.angle)),
            factor,
            chosen_by,
            folds,
            reach: self.full.as_ref().map(|f| f.prior_reach),
            held_out: scores.map(|s| {
                s.iter()
                    .map(|s| PriorScoreReport {
                        factor: s.factor,
                        rms_mm: s.held_out * 1e3,
                    })
                    .collect()
            }),
        }
    }
}
