//! The diagnosis as data: [`DiagnoseReport`], the JSON of
//! `armcal diagnose --json` (docs/file-formats.md §6) and the dictionary
//! Python's `Diagnosis.report` returns, both this type serialised. Lengths in
//! mm where the field says so, the model's units otherwise. Nothing here
//! computes; it reads a [`Diagnosis`] and what the command ran beside it
//! (the torques' fit, the weights, the sessions).

use armcal_shared::compensation::Task;
use std::collections::BTreeMap;

use armcal_shared::effects::Effect;
use armcal_shared::{Calibration, JointType, Param, Robot};
use serde::Serialize;

use super::{Choice, DiagnoseOptions, Diagnosis, HeldOutModels, Shortfall};
use crate::calibration::fit::Status;
use crate::calibration::fit::prior::Geometry;
use crate::calibration::gravity::GravityReport;
use crate::calibration::identify::channel_weight::WeightReports;
use crate::calibration::identify::report::{NoiseRow, ParameterReport, noise_rows};
use crate::calibration::identify::sessions::SessionReport;
use crate::report::units::UnitsReport;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::observation::Observation;

/// How the reports name a pose: its row's line (a file's; an array's row,
/// from 0) and, with several sessions, its session's file.
#[derive(Clone, Copy, Debug)]
pub struct RowPlaces<'a> {
    /// Each pose's line.
    pub lines: &'a [usize],
    /// With several sessions: the poses (their sessions) and each session's file.
    pub sessions: Option<(&'a [Observation], &'a [String])>,
}

impl<'a> RowPlaces<'a> {
    /// The places of the poses of `data`, each at its line in `lines`.
    pub fn of(lines: &'a [usize], data: &'a Measurements) -> Self {
        Self {
            lines,
            sessions: (data.session_count() > 1).then_some((&data.poses[..], &data.sessions[..])),
        }
    }

    /// Poses named by their line alone (one session).
    pub fn lines(lines: &'a [usize]) -> Self {
        Self {
            lines,
            sessions: None,
        }
    }

    /// Pose `i`'s line.
    pub fn line(&self, i: usize) -> usize {
        self.lines.get(i).copied().unwrap_or(0)
    }

    /// Pose `i`'s file, with several sessions.
    pub fn file(&self, i: usize) -> Option<&'a str> {
        let (poses, files) = self.sessions?;
        files.get(poses.get(i)?.session).map(String::as_str)
    }

    /// Pose `i` as the summary names it: `data line N`, or `FILE line N`
    /// with several sessions.
    pub fn label(&self, i: usize) -> String {
        match self.file(i) {
            Some(file) => format!("{file} line {}", self.line(i)),
            None => format!("data line {}", self.line(i)),
        }
    }
}

/// A parameter of a found effect in the model's units: angles (gear amplitudes,
/// half the lost motion of a revolute joint, a compliance's rad per N·m) in the
/// angle unit, lengths in the length unit, ratios as they are.
pub(crate) fn effect_value(
    robot: &Robot<f64>,
    effect: &Effect<f64>,
    units: &armcal_shared::units::Units,
    v: f64,
) -> f64 {
    let revolute = effect
        .joint()
        .is_some_and(|j| robot.links[j].joint == JointType::Revolute);
    match effect {
        Effect::ThermalExpansion { .. } | Effect::EncoderScale { .. } => v,
        _ if revolute => units.angle_from_si(v),
        _ => units.length_from_si(v),
    }
}

/// The unit of a parameter of `effect` as [`effect_value`] gives it.
pub(crate) fn effect_unit(
    robot: &Robot<f64>,
    effect: &Effect<f64>,
    units: &armcal_shared::units::Units,
) -> String {
    let revolute = effect
        .joint()
        .is_some_and(|j| robot.links[j].joint == JointType::Revolute);
    let moved = if revolute {
        units.angle.name()
    } else {
        units.length.name()
    };
    match effect {
        Effect::ThermalExpansion { .. } => "1/°C".into(),
        Effect::EncoderScale { .. } => "1".into(),
        Effect::JointCompliance { .. } if revolute => format!("{moved}/(N·m)"),
        Effect::JointCompliance { .. } => format!("{moved}/N"),
        _ => moved.into(),
    }
}

/// `armcal diagnose`'s report (docs/file-formats.md §6): the diagnosis'
/// own figures and what the command ran beside it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiagnoseReport {
    /// The data file (several sessions: their files), as the HTML page
    /// names it; not in the JSON (as `identify`'s).
    #[serde(skip)]
    pub data: String,
    /// The poses diagnosed.
    pub poses: usize,
    /// The diagnosis' own figures.
    #[serde(flatten)]
    pub diagnosis: DiagnosisReport,
    /// With several sessions: each outlier's file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outlier_files: Option<Vec<Option<String>>>,
    /// The masses' fit to the measured torques, when the rows have them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gravity: Option<GravityReport>,
    /// Where the backlash's approach directions came from.
    pub approach_order: ApproachOrder,
    /// The weights of orientations and contacts.
    #[serde(flatten)]
    pub weights: WeightReports,
    /// Each session, when there are several.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sessions: Option<Vec<SessionReport>>,
}

/// Where each pose's approach directions (which a backlash reads) came
/// from, as the reports say it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ApproachOrder {
    /// Every row has a time `t`: the order of the times.
    Times,
    /// The rows' order (a row without a time).
    Rows,
}

/// The diagnosis' own figures ([`Diagnosis::report`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiagnosisReport {
    /// The model's name.
    pub model: String,
    /// The noise the chosen calibration's residuals show, mm (the geometric
    /// calibration's, or the extended one's when it extends the geometry).
    pub noise_estimate_mm: f64,
    /// Whether the calibration chosen extends the geometry with effects:
    /// its residuals are then not the geometric calibration's.
    pub extends_the_geometry: bool,
    /// The sessions fitted (each in its own frames).
    pub session_count: usize,
    /// The model file's units, which the values not in mm are in.
    pub units: UnitsReport,
    /// Each channel's noise.
    pub noise: Vec<NoiseRow>,
    /// The model chosen.
    pub chosen: ChosenReport,
    /// Every geometric model's held-out error.
    pub models: Vec<ModelReport>,
    /// Whether the geometric models were scored with the effects found.
    pub models_with_effects: bool,
    /// Which parameters the prior holds and which the data move.
    pub prior_role: PriorRoleReport,
    /// The held-out errors of the three models.
    pub holdout: HoldoutReport,
    /// Each effect found.
    pub effects: Vec<EffectReport>,
    /// What the calibration written delivers held-out.
    pub written: WrittenReport,
    /// The repeated configurations and the lack-of-fit test.
    pub replicates: Option<ReplicatesReport>,
    /// The poses a large session was thinned to.
    pub selection: Option<SelectionReport>,
    /// The chosen model's error on the rows it was fitted to, mm.
    pub fitted: Option<ErrorsReport>,
    /// The outliers' lines.
    pub outlier_rows: Vec<usize>,
    /// The rows that fail the deleted-residual test.
    pub suspect_rows: Vec<SuspectReport>,
    /// Every candidate's first-round gain.
    pub candidates: Vec<CandidateReport>,
    /// The final fit's parameters (the extended calibration's geometry).
    pub parameters: Vec<ParameterReport>,
    /// The final fit's effects' parameters.
    pub effect_parameters: Vec<EffectParameterReport>,
    /// The candidate the search stopped on.
    pub unsettled: Option<UnsettledReport>,
}

/// A parameter of an effect in the final fit, in its own unit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EffectParameterReport {
    /// Its name (`compliance2`, …).
    pub name: String,
    /// The effect's name.
    pub effect: &'static str,
    /// Its unit (`rad/(N·m)`, `1/°C`, …).
    pub unit: String,
    /// Its value (its nominal is 0).
    pub value: f64,
    /// Its standard error (`null`: held).
    pub std: Option<f64>,
}

/// The model chosen.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChosenReport {
    /// `nominal`, or the geometric model's name.
    pub model: &'static str,
    /// As the summary names it.
    pub label: String,
    /// The factor on the stated prior.
    pub prior_factor: f64,
    /// The prior fitted at.
    pub prior: PriorScales,
    /// Whether the nominal model was kept.
    pub calibration_changes_nothing: bool,
}

/// A prior's scales, the model's units.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PriorScales {
    /// Of lengths.
    pub length: f64,
    /// Of angles.
    pub angle: f64,
}

/// A geometric model's held-out error.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelReport {
    /// As the summary names it.
    pub model: String,
    /// Its parameters.
    pub parameters: usize,
    /// Held-out RMS, mm.
    pub rms_mm: f64,
    /// Held-out mean, mm.
    pub mean_mm: f64,
    /// Held-out largest, mm.
    pub max_mm: f64,
}

/// Which parameters the prior holds and which the data move.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PriorRoleReport {
    /// Held by the prior.
    pub held_by_prior: Vec<String>,
    /// Moved by the data.
    pub moved_by_data: Vec<String>,
    /// Each identified parameter's data share.
    pub data_share: Vec<DataShare>,
}

/// A parameter's share of the data in its estimate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DataShare {
    /// The parameter.
    pub name: String,
    /// Its data share, 0 to 1.
    pub data_share: f64,
}

/// The held-out errors of the nominal, geometric and extended models, mm.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HoldoutReport {
    /// `K-fold`.
    pub method: String,
    /// K.
    pub folds: usize,
    /// Nominal RMS.
    pub nominal_rms_mm: f64,
    /// Geometric RMS.
    pub geometric_rms_mm: f64,
    /// Extended RMS.
    pub extended_rms_mm: f64,
    /// Nominal mean.
    pub nominal_mean_mm: f64,
    /// Nominal largest.
    pub nominal_max_mm: f64,
    /// Geometric mean.
    pub geometric_mean_mm: f64,
    /// Geometric largest.
    pub geometric_max_mm: f64,
    /// Extended mean.
    pub extended_mean_mm: f64,
    /// Extended largest.
    pub extended_max_mm: f64,
}

/// An effect found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EffectReport {
    /// Its name.
    pub name: &'static str,
    /// Its joints, from 1.
    pub joints: Vec<usize>,
    /// Its parameters as the calibration written holds them, by name.
    pub parameters: BTreeMap<String, f64>,
    /// Held-out RMS without it over with it.
    pub gain: f64,
    /// Its F statistic.
    pub f: f64,
    /// The 1 % family-wise threshold it exceeds.
    pub threshold: f64,
    /// The effects the data could not tell from it.
    pub alike: Vec<AlikeReport>,
    /// The evidence, as a sentence.
    pub evidence: String,
}

/// An effect the data could not tell from the one found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AlikeReport {
    /// Its name.
    pub name: &'static str,
    /// Its joints, from 1.
    pub joints: Vec<usize>,
    /// What it leaves unexplained, in standard errors.
    pub unexplained_sigma: f64,
    /// What would separate the two.
    pub separated_by: &'static str,
}

/// What the calibration written delivers held-out.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WrittenReport {
    /// Its held-out RMS, mm.
    pub held_out_rms_mm: Option<f64>,
    /// The geometric calibration it falls back to, when it carries one.
    pub geometric_fallback: Option<FallbackReport>,
}

/// The geometric fallback of a calibration with effects.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FallbackReport {
    /// Its held-out RMS, mm.
    pub held_out_rms_mm: Option<f64>,
    /// Its parameters.
    pub parameters: usize,
}

/// The repeated configurations and the lack-of-fit test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplicatesReport {
    /// The session's rows.
    pub rows: usize,
    /// Its distinct configurations.
    pub configurations: usize,
    /// The robot's distinct configurations.
    pub robot_configurations: usize,
    /// Whether the repeats are copies of one reading.
    pub copies: bool,
    /// The noise the repeats show, mm.
    pub pure_error_mm: Option<f64>,
    /// Its degrees of freedom.
    pub pure_error_dof: Option<usize>,
    /// The configurations repeated.
    pub repeated_configurations: Option<usize>,
    /// The chosen model's residual at the repeats' means, mm.
    pub residual_at_means_mm: Option<f64>,
    /// What the noise alone would leave there, mm.
    pub expected_at_means_mm: Option<f64>,
    /// The lack-of-fit statistic.
    pub lack_of_fit_f: Option<f64>,
    /// Its threshold.
    pub lack_of_fit_threshold: Option<f64>,
    /// Its p-value.
    pub lack_of_fit_p: Option<f64>,
    /// Whether the model lacks fit.
    pub lack_of_fit: Option<bool>,
}

/// The poses a large session was thinned to.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SelectionReport {
    /// The session's rows.
    pub rows: usize,
    /// Every how many rows one was taken.
    pub every: usize,
    /// The poses diagnosed.
    pub poses: usize,
    /// Those set aside.
    pub set_aside: usize,
}

/// An error distribution, mm.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorsReport {
    /// RMS.
    pub rms_mm: f64,
    /// Mean.
    pub mean_mm: f64,
    /// Largest.
    pub max_mm: f64,
}

/// A row that fails the deleted-residual test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SuspectReport {
    /// Its line.
    pub row: usize,
    /// Its file, with several sessions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Its deleted-residual statistic.
    pub f: f64,
    /// The threshold it exceeds.
    pub threshold: f64,
    /// The other poses' held-out RMS with it, mm.
    pub others_held_out_rms_mm_with: f64,
    /// The same without it, mm.
    pub others_held_out_rms_mm_without: f64,
    /// Whether it was set aside.
    pub set_aside: bool,
}

/// A candidate effect's first-round gain.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CandidateReport {
    /// Its name.
    pub name: &'static str,
    /// Its joints, from 1.
    pub joints: Vec<usize>,
    /// Held-out RMS without it over with it.
    pub gain: f64,
}

/// The candidate the search stopped on.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UnsettledReport {
    /// Its name.
    pub name: &'static str,
    /// Its joints, from 1.
    pub joints: Vec<usize>,
    /// Its gain.
    pub gain: f64,
    /// Its F statistic.
    pub f: f64,
    /// The F test's threshold.
    pub threshold: f64,
    /// `significance` or `gain`: what it fell short of.
    pub shortfall: &'static str,
    /// Poses that would settle it, when significance fell short.
    pub poses_needed: Option<usize>,
    /// The gain asked of an effect, when its gain fell short.
    pub min_gain: Option<f64>,
}

impl Diagnosis {
    /// The model chosen, as reports name it: `nominal`, or the geometric model
    /// with its prior and the effects.
    pub fn chosen_label(&self) -> String {
        match self.choice {
            Choice::Nominal => "nominal (nothing beats it held-out)".into(),
            Choice::Calibrated {
                geometry,
                prior_factor,
                ..
            } => {
                let mut s = if geometry == Geometry::Registration {
                    "registration (base and tool)".to_string()
                } else {
                    format!("{}, prior ×{prior_factor}", geometry.name())
                };
                for f in &self.findings {
                    s.push_str(&format!(
                        " + {} (joints {})",
                        f.candidate.name,
                        f.candidate.joints_label()
                    ));
                }
                s
            }
        }
    }

    /// Whether the calibration chosen extends the geometry with effects:
    /// its residuals are then not the geometric calibration's, and the
    /// reports give both.
    pub fn extends_the_geometry(&self) -> bool {
        !self.fit.effects.is_empty() && self.choice != Choice::Nominal
    }

    /// The D-H parameters the prior holds (data share below one half) and those
    /// the data moved (at least one half), in the final fit.
    pub fn prior_role(&self) -> (Vec<Param>, Vec<Param>) {
        let (mut held, mut moved) = (Vec::new(), Vec::new());
        for p in &self.fit.params {
            if matches!(p.param, Param::Base(_) | Param::Tool(_))
                || !matches!(p.status, Status::Identified { .. })
            {
                continue;
            }
            if p.data_share < 0.5 {
                held.push(p.param);
            } else {
                moved.push(p.param);
            }
        }
        (held, moved)
    }
}

/// Joints from 0 as the reports give them, from 1.
fn from_one(joints: &[usize]) -> Vec<usize> {
    joints.iter().map(|j| j + 1).collect()
}

impl Diagnosis {
    /// The diagnosis' own report: the noise, the chosen model, every
    /// model's held-out error, the prior's role, the effects found and every
    /// candidate's first-round gain.
    pub fn report(
        &self,
        model: &RobotModel,
        rows: RowPlaces<'_>,
        options: &DiagnoseOptions,
    ) -> DiagnosisReport {
        let mm = |x: f64| x * 1e3;
        let units = &model.units;
        // The effects' values as the calibration written holds them.
        let written = self.calibration(&model.robot, Task::Position, *units);
        let (held, moved) = self.prior_role();
        let names = |v: &[Param]| v.iter().map(|p| p.to_string()).collect::<Vec<_>>();
        let (prior, factor) = match self.choice {
            Choice::Calibrated {
                prior,
                prior_factor,
                ..
            } => (prior, prior_factor),
            Choice::Nominal => (options.fit.prior, 1.0),
        };
        DiagnosisReport {
            model: model.name.clone(),
            noise_estimate_mm: mm(self.noise),
            extends_the_geometry: self.extends_the_geometry(),
            session_count: self.fit.sessions.len(),
            units: UnitsReport::from(units),
            noise: noise_rows(&self.geometric.noise, units),
            chosen: ChosenReport {
                model: match self.choice {
                    Choice::Nominal => "nominal",
                    Choice::Calibrated { geometry, .. } => geometry.name(),
                },
                label: self.chosen_label(),
                prior_factor: factor,
                prior: PriorScales {
                    length: units.length_from_si(prior.length),
                    angle: units.angle_from_si(prior.angle),
                },
                calibration_changes_nothing: self.choice == Choice::Nominal,
            },
            models: self
                .models
                .iter()
                .map(|m| ModelReport {
                    model: m.label(),
                    parameters: m.parameters,
                    rms_mm: mm(m.held.rms),
                    mean_mm: mm(m.held.mean),
                    max_mm: mm(m.held.max),
                })
                .collect(),
            models_with_effects: self.models_with_effects && !self.findings.is_empty(),
            prior_role: PriorRoleReport {
                held_by_prior: names(&held),
                moved_by_data: names(&moved),
                data_share: self
                    .fit
                    .params
                    .iter()
                    .filter(|p| matches!(p.status, Status::Identified { .. }))
                    .map(|p| DataShare {
                        name: p.param.to_string(),
                        data_share: p.data_share,
                    })
                    .collect(),
            },
            holdout: self.holdout_report(options),
            effects: self.effect_reports(model, &written, options),
            written: WrittenReport {
                held_out_rms_mm: written.held_out.map(mm),
                geometric_fallback: written.geometric.as_ref().map(|g| FallbackReport {
                    held_out_rms_mm: g.held_out.map(mm),
                    parameters: g.errors.len(),
                }),
            },
            replicates: self.replicates_report(),
            selection: self.selection.map(|s| SelectionReport {
                rows: s.rows,
                every: s.every,
                poses: s.poses,
                set_aside: s.set_aside,
            }),
            fitted: self.fitted.map(|h| ErrorsReport {
                rms_mm: mm(h.rms),
                mean_mm: mm(h.mean),
                max_mm: mm(h.max),
            }),
            outlier_rows: self.blunders.iter().map(|&i| rows.line(i)).collect(),
            suspect_rows: self
                .suspects
                .iter()
                .map(|b| SuspectReport {
                    row: rows.line(b.pose),
                    file: rows.file(b.pose).map(str::to_string),
                    f: b.f,
                    threshold: b.threshold,
                    others_held_out_rms_mm_with: mm(b.held_with),
                    others_held_out_rms_mm_without: mm(b.held_without),
                    set_aside: b.set_aside,
                })
                .collect(),
            candidates: self
                .tried
                .iter()
                .map(|(c, g)| CandidateReport {
                    name: c.name,
                    joints: from_one(&c.joints),
                    gain: *g,
                })
                .collect(),
            parameters: self
                .fit
                .params
                .iter()
                .map(|p| {
                    let (std, fixed) = match &p.status {
                        Status::Identified { std } => (Some(*std), None),
                        Status::Fixed { reason } => (None, Some(reason.as_str())),
                    };
                    ParameterReport::of(units, p.param, p.nominal, p.error, std, fixed)
                })
                .collect(),
            effect_parameters: self.effect_parameter_reports(model),
            unsettled: self.unsettled.as_ref().map(|u| UnsettledReport {
                name: u.candidate.name,
                joints: from_one(&u.candidate.joints),
                gain: u.gain,
                f: u.f_test.0,
                threshold: u.f_test.1,
                shortfall: match u.shortfall {
                    Shortfall::Significance { .. } => "significance",
                    Shortfall::Gain { .. } => "gain",
                },
                poses_needed: match u.shortfall {
                    Shortfall::Significance { poses_needed } => Some(poses_needed),
                    Shortfall::Gain { .. } => None,
                },
                min_gain: match u.shortfall {
                    Shortfall::Significance { .. } => None,
                    Shortfall::Gain { min_gain } => Some(min_gain),
                },
            }),
        }
    }

    /// The report's `effects`: each effect found, its parameters as the
    /// calibration `written` holds them (in the model's units), its evidence.
    fn effect_reports(
        &self,
        model: &RobotModel,
        written: &Calibration,
        options: &DiagnoseOptions,
    ) -> Vec<EffectReport> {
        let units = &model.units;
        self.findings
            .iter()
            .map(|f| {
                let mut parameters = BTreeMap::new();
                if let Some(e) = written.effects.iter().find(|e| f.candidate.is(e)) {
                    for i in 0..e.parameter_count() {
                        let v = e.parameter(i).unwrap_or(0.0);
                        parameters.insert(
                            crate::calibration::fit::effect_parameter_name(e, i),
                            effect_value(&model.robot, e, units, v),
                        );
                    }
                }
                for p in &f.candidate.extra {
                    let error = written
                        .errors
                        .iter()
                        .find(|r| r.param == *p)
                        .map_or(0.0, |r| r.error);
                    parameters.insert(p.to_string(), units.angle_from_si(error));
                }
                EffectReport {
                    name: f.candidate.name,
                    joints: from_one(&f.candidate.joints),
                    parameters,
                    gain: f.gain,
                    f: f.f_test.0,
                    threshold: f.f_test.1,
                    alike: f
                        .alike
                        .iter()
                        .map(|a| AlikeReport {
                            name: a.candidate.name,
                            joints: from_one(&a.candidate.joints),
                            unexplained_sigma: a.unexplained,
                            separated_by: a.separated_by(&f.candidate),
                        })
                        .collect(),
                    evidence: f.evidence(options.folds),
                }
            })
            .collect()
    }

    /// The report's `effect_parameters`: each parameter of the final fit's
    /// effects, in its own unit.
    fn effect_parameter_reports(&self, model: &RobotModel) -> Vec<EffectParameterReport> {
        let units = &model.units;
        let mut out = Vec::new();
        for e in &self.fit.effects {
            let value = |v: f64| effect_value(&model.robot, &e.effect, units, v);
            let unit = effect_unit(&model.robot, &e.effect, units);
            for (i, status) in e.status.iter().enumerate() {
                out.push(EffectParameterReport {
                    name: crate::calibration::fit::effect_parameter_name(&e.effect, i),
                    effect: e.effect.name(),
                    unit: unit.clone(),
                    value: value(e.effect.parameter(i).unwrap_or(0.0)),
                    std: match status {
                        Status::Identified { std } => Some(value(*std)),
                        Status::Fixed { .. } => None,
                    },
                });
            }
        }
        out
    }

    /// The report's `holdout`: the held-out errors of the three models, mm.
    fn holdout_report(&self, options: &DiagnoseOptions) -> HoldoutReport {
        let mm = |x: f64| x * 1e3;
        let HeldOutModels {
            nominal,
            geometric,
            extended,
        } = self.holdout;
        HoldoutReport {
            method: format!("{}-fold", options.folds),
            folds: options.folds,
            nominal_rms_mm: mm(nominal.rms),
            geometric_rms_mm: mm(geometric.rms),
            extended_rms_mm: mm(extended.rms),
            nominal_mean_mm: mm(nominal.mean),
            nominal_max_mm: mm(nominal.max),
            geometric_mean_mm: mm(geometric.mean),
            geometric_max_mm: mm(geometric.max),
            extended_mean_mm: mm(extended.mean),
            extended_max_mm: mm(extended.max),
        }
    }

    /// The report's `replicates`: the repeated configurations and the
    /// lack-of-fit test.
    fn replicates_report(&self) -> Option<ReplicatesReport> {
        let mm = |x: f64| x * 1e3;
        self.replicates.map(|r| {
            let l = r.lack_of_fit;
            ReplicatesReport {
                rows: r.rows,
                configurations: r.configurations,
                robot_configurations: r.robot_configurations,
                copies: r.copies,
                pure_error_mm: l.map(|l| mm(l.pure.sigma)),
                pure_error_dof: l.map(|l| l.pure.dof),
                repeated_configurations: l.map(|l| l.pure.repeated),
                residual_at_means_mm: l.map(|l| mm(l.shown)),
                expected_at_means_mm: l.map(|l| mm(l.expected)),
                lack_of_fit_f: l.map(|l| l.f),
                lack_of_fit_threshold: l.map(|l| l.threshold),
                lack_of_fit_p: l.map(|l| l.p),
                lack_of_fit: l.map(|l| l.significant()),
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::measurements::parse_measurements;
    use crate::io::model_file::load_model;

    /// A pose of one session is named by its line; of several, by its
    /// file and its line in it (each file numbers its own lines).
    #[test]
    fn a_row_is_named_by_its_file_when_there_are_several() {
        let model = load_model("ur5e").unwrap();
        let file = |name: &str| {
            let text = "q1,q2,q3,q4,q5,q6,x,y,z\n0.1,0.2,0.3,0.4,0.5,0.6,0.1,0.2,0.3\n";
            parse_measurements(text, name, &model).unwrap()
        };
        let one = file("a.csv");
        assert_eq!(RowPlaces::of(&one.lines, &one).label(0), "data line 2");
        let two = Measurements::sessions(vec![file("a.csv"), file("b.csv")]).unwrap();
        let rows = RowPlaces::of(&two.lines, &two);
        assert_eq!(rows.label(0), "a.csv line 2");
        assert_eq!(rows.label(1), "b.csv line 2");
        assert_eq!(rows.file(1), Some("b.csv"));
    }
}
