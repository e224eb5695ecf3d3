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
use crate::calibration::fit::noise;
use crate::calibration::gravity::GravityReport;
use crate::report::units::UnitsReport;
use crate::report::units::param_in_units;
use crate::session::channel::Channel;
use crate::session::measurements::Measurements;

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

/// `armcal identify`'s report (docs/file-formats.md §6). The fields after
/// `warnings` are the full model's (`--params full`), absent for the
/// paper's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct IdentifyReport {
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

/// The nominal model's residual on the rows.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NominalResidual {
    /// RMS position residual, the model's length unit.
    pub position_rms: f64,
    /// The same, mm.
    pub position_rms_mm: f64,
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
    pub chosen_by: &'static str,
    /// How far it reaches (the full fit's).
    pub reach: Option<f64>,
    /// Each factor's held-out score, when cross-validated.
    pub held_out: Option<Vec<PriorScoreReport>>,
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
    /// The report of an identification from `data`, in `units`.
    pub fn report(&self, units: &Units, data: &Measurements) -> IdentifyReport {
        let length = |x: f64| units.length_from_si(x);
        IdentifyReport {
            params: self.params.name(),
            iterations: self.iterations,
            converged: self.converged,
            parameters: self
                .parameters
                .iter()
                .map(|r| ParameterReport {
                    name: r.param.to_string(),
                    nominal: param_in_units(units, r.param, r.nominal),
                    error: param_in_units(units, r.param, r.error),
                    std: r.std.map(|s| param_in_units(units, r.param, s)),
                    status: if r.fixed.is_some() {
                        "fixed"
                    } else {
                        "identified"
                    },
                    reason: r.fixed.clone(),
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
            nominal_residual: self.judgement.as_ref().map(|j| NominalResidual {
                position_rms: length(j.nominal.position),
                position_rms_mm: j.nominal.position * 1e3,
            }),
            full: self.full.as_ref().map(|fit| FullReport {
                sessions: sessions::reports(fit, &self.sessions_held_out, data, units),
                condition_number: fit.condition_number,
                observability_index: fit.observability,
                variance_factor: fit.variance_factor,
                equations: fit.equations,
                noise: noise_rows(&fit.noise, units),
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
                    }
                }),
            }),
        }
    }

    /// The JSON of an identification from `data` (docs/file-formats.md
    /// §6): [`Identification::report`] serialised.
    pub fn to_json(&self, units: &Units, data: &Measurements) -> serde_json::Value {
        crate::report::to_json(&self.report(units, data))
    }

    /// The report's `prior`: the scale fitted at (model units; `None` for
    /// none), the factor on the stated one, and how it was chosen.
    fn prior_report(&self, units: &Units) -> PriorReport {
        let factor = self.prior.as_ref().map_or(1.0, PriorChoice::factor);
        let scaled = self.stated_prior.scaled(factor);
        let finite = |x: f64| x.is_finite().then_some(x);
        let (chosen_by, scores) = match &self.prior {
            None => ("stated", None),
            Some(PriorChoice::Immaterial) => ("stated: immaterial to the data", None),
            Some(PriorChoice::Undetermined { .. }) => ("stated: folds undetermined", None),
            Some(PriorChoice::CrossValidated { scores, .. }) => {
                ("cross-validation", Some(scores.as_slice()))
            }
        };
        PriorReport {
            length: finite(units.length_from_si(scaled.length)),
            angle: finite(units.angle_from_si(scaled.angle)),
            factor,
            chosen_by,
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
