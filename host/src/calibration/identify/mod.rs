//! Geometric identification: the D-H parameter errors from measured poses.
//!
//! | module | model |
//! | --- | --- |
//! | [`full`] | `--params full` (the default): joint offsets, every `s, a, α`, base and tool, weighted Levenberg–Marquardt with a rank-revealing Cholesky, standard errors and observability |
//! | [`paper`] | `--params paper`: the 3M position-independent model and the Iterative Regression Algorithm of Mirman & Gupta (1992), as the paper gives them |
//!
//! This module turns either result into the report of `armcal identify`: the
//! JSON of `docs/file-formats.md` §6, a human summary, and the [`Calibration`] the
//! controller loads. Values are SI inside; the report converts every length and
//! angle to the model file's units (`mm`-suffixed fields excepted).

pub mod full;
pub mod noise;
pub mod paper;
pub mod prior;
pub mod prior_scale;

#[cfg(test)]
mod constraint_tests;

use std::fmt::Write as _;

use armcal_shared::calibration::ParamError;
use armcal_shared::{Calibration, Param, Robot};
use serde_json::json;

use crate::calibration::diagnose::significant;
use crate::io::measurements::Measurements;
use crate::io::model_file::{RobotModel, Units};
use full::{FullFit, FullOptions, Observation, Status};
use paper::{PaperOptions, PaperPose};
use prior::{PRIOR_FACTORS, Prior};
use prior_scale::{PriorChoice, PriorScale};

/// Which model to identify.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamSet {
    /// The 3M position-independent model of Mirman & Gupta.
    Paper,
    /// Every identifiable geometric parameter, base and tool included.
    Full,
}

impl ParamSet {
    /// The name used on the command line and in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Full => "full",
        }
    }
}

/// The noise and prior scales a user states (`--position-noise`,
/// `--orientation-noise`, `--point-noise`, `--plane-noise`, `--prior-length`,
/// `--prior-angle`), in the model's length and angle units; `None` leaves the
/// default (the noise estimated from the residuals, each kind of row its own;
/// the prior of the model file or 1 mm and 1 mrad). A stated position noise
/// is also the noise of the contacts whose kind has none stated
/// ([`noise`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct StatedScales {
    /// Position noise, one standard deviation per axis.
    pub position_noise: Option<f64>,
    /// Orientation noise, one standard deviation per axis.
    pub orientation_noise: Option<f64>,
    /// Noise of a tool point at an unknown fixed point, per axis.
    pub point_noise: Option<f64>,
    /// Noise of a tool point on an unknown plane, along its normal.
    pub plane_noise: Option<f64>,
    /// Prior scale of a D-H length error.
    pub prior_length: Option<f64>,
    /// Prior scale of a D-H angle error.
    pub prior_angle: Option<f64>,
}

/// A stated scale that is not a positive number: which one, and its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotPositive {
    /// The scale's name as a flag, `--position-noise` …
    pub flag: &'static str,
    /// The value given.
    pub value: f64,
}

impl StatedScales {
    /// The options of a full identification of `model` with these scales,
    /// converted to SI; refused if one is not a positive finite number.
    pub fn options(&self, model: &RobotModel) -> Result<FullOptions, NotPositive> {
        let positive = |flag: &'static str, v: Option<f64>| match v {
            Some(value) if !(value.is_finite() && value > 0.0) => Err(NotPositive { flag, value }),
            _ => Ok(v),
        };
        let u = &model.units;
        let mut options = FullOptions {
            prior: model.prior,
            ..FullOptions::default()
        };
        if let Some(v) = positive("--position-noise", self.position_noise)? {
            options.position_noise = u.length_to_si(v);
            options.position_source = noise::NoiseSource::Stated;
        }
        if let Some(v) = positive("--orientation-noise", self.orientation_noise)? {
            options.orientation_noise = u.angle_to_si(v);
            options.orientation_source = noise::NoiseSource::Stated;
        }
        let stated = |v: f64| noise::Noise {
            sigma: u.length_to_si(v),
            source: noise::NoiseSource::Stated,
        };
        options.point_noise = positive("--point-noise", self.point_noise)?.map(stated);
        options.plane_noise = positive("--plane-noise", self.plane_noise)?.map(stated);
        if let Some(v) = positive("--prior-length", self.prior_length)? {
            options.prior.length = u.length_to_si(v);
        }
        if let Some(v) = positive("--prior-angle", self.prior_angle)? {
            options.prior.angle = u.angle_to_si(v);
        }
        Ok(options)
    }
}

/// One parameter of the report, SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamRow {
    /// Which parameter.
    pub param: Param,
    /// Nominal value.
    pub nominal: f64,
    /// Identified minus nominal.
    pub error: f64,
    /// Standard error, when the method gives one.
    pub std: Option<f64>,
    /// `None` when identified, the reason when held at nominal.
    pub fixed: Option<String>,
}

/// The outcome of `armcal identify`.
#[derive(Clone, Debug)]
pub struct Identification {
    /// The model identified.
    pub params: ParamSet,
    /// Iterations run.
    pub iterations: usize,
    /// Whether the iterations converged.
    pub converged: bool,
    /// Every parameter.
    pub parameters: Vec<ParamRow>,
    /// RMS position residual, m.
    pub position_rms: f64,
    /// RMS orientation residual, rad (0 without orientation data).
    pub orientation_rms: f64,
    /// Full model only: its statistics.
    pub full: Option<FullFit>,
    /// The prior as stated (flags, model file, default), SI.
    pub stated_prior: Prior,
    /// Full model with the prior's scale chosen: the factor on the stated
    /// prior it was fitted at and every factor's held-out score.
    pub prior: Option<PriorChoice>,
    /// The calibration to write.
    pub calibration: Calibration,
}

/// Why an identification could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IdentifyError {
    /// The full model failed.
    #[error(transparent)]
    Full(#[from] full::FullError),
    /// The paper's model failed.
    #[error(transparent)]
    Paper(#[from] paper::PaperError),
    /// The paper's model needs orientations.
    #[error(
        "{file}: --params paper needs full poses (columns qw, qx, qy, qz): Mirman & Gupta's regression uses the rotational and translational errors of eq. (15); use --params full for positions"
    )]
    PaperNeedsPoses {
        /// The data file.
        file: String,
    },
    /// The calibration could not be encoded.
    #[error("the calibration cannot be written: {0}")]
    Calibration(#[from] armcal_shared::CalibrationError),
}

/// The observations of `data`, SI, with each pose's context: temperature and
/// payload from the `temp` and `load` columns, and the approach direction of
/// every joint from row order (the sign of its last change, held while the joint
/// holds: [`armcal_shared::effects::Approach`]).
pub fn observations(data: &Measurements) -> &[Observation] {
    &data.poses
}

/// Runs the identification of `set` on `data`.
///
/// `--params full` fits at the prior `scale` says: as stated, or at the
/// factor on it that predicts held-out poses best ([`prior_scale`]; the fit at
/// the stated prior first, then again at the factor chosen when it differs).
pub fn identify(
    model: &RobotModel,
    data: &Measurements,
    set: ParamSet,
    options: &FullOptions,
    scale: PriorScale,
) -> Result<Identification, IdentifyError> {
    let nominal = &model.robot;
    let orientation = data.poses.iter().any(|p| p.orientation.is_some());
    let mut prior = None;
    let (iterations, converged, parameters, calibrated, fit) = match set {
        ParamSet::Full => {
            // The model's own tilts (a URDF's parallel axes) beside its D-H parameters.
            let tilts: Vec<Param> = model.tilted.iter().map(|&k| Param::Beta(k)).collect();
            let fit_at = |factor: f64| {
                full::identify_constrained(
                    nominal,
                    None,
                    &[],
                    &tilts,
                    observations(data),
                    &data.constraints,
                    &FullOptions {
                        prior: options.prior.scaled(factor),
                        ..*options
                    },
                )
            };
            let mut fit = fit_at(1.0)?;
            // A prior without a finite scale (least squares) has none to choose.
            let scalable = options.prior.length.is_finite() || options.prior.angle.is_finite();
            if let (PriorScale::Chosen { folds }, true) = (scale, scalable) {
                let choice = prior_scale::choose(
                    &fit,
                    observations(data),
                    &data.constraints,
                    &options.prior,
                    folds,
                );
                if choice.factor() != 1.0 {
                    fit = fit_at(choice.factor())?;
                }
                prior = Some(choice);
            }
            let rows: Vec<ParamRow> = fit
                .params
                .iter()
                .map(|p| ParamRow {
                    param: p.param,
                    nominal: p.nominal,
                    error: p.error,
                    std: match &p.status {
                        Status::Identified { std } => Some(*std),
                        Status::Fixed { .. } => None,
                    },
                    fixed: match &p.status {
                        Status::Identified { .. } => None,
                        Status::Fixed { reason } => Some(reason.clone()),
                    },
                })
                .collect();
            (
                fit.iterations,
                fit.converged,
                rows,
                fit.calibrated.clone(),
                Some(fit),
            )
        }
        ParamSet::Paper => {
            let mut poses = Vec::with_capacity(data.poses.len());
            for p in &data.poses {
                let Some(q) = p.orientation else {
                    return Err(IdentifyError::PaperNeedsPoses {
                        file: data.file.clone(),
                    });
                };
                poses.push(PaperPose {
                    q: p.q.clone(),
                    actual: nalgebra::IsometryMatrix3::from_parts(
                        p.position.coords.into(),
                        q.to_rotation_matrix(),
                    ),
                    joint_errors: None,
                });
            }
            let fit = paper::identify_paper(nominal, &poses, &PaperOptions::default())?;
            let last = fit.iterations.last();
            let rows = fit
                .params
                .iter()
                .zip(&fit.errors)
                .map(|(&param, &error)| {
                    let dependent =
                        last.and_then(|it| it.dependent.iter().find(|(held, _, _)| *held == param));
                    ParamRow {
                        param,
                        nominal: nominal.param(param).unwrap_or(0.0),
                        error,
                        std: None,
                        fixed: dependent.map(|(_, beside, r)| {
                            format!("not separable from {beside} (r = {r:.9})")
                        }),
                    }
                })
                .collect();
            let mut calibrated = nominal.clone();
            for (p, e) in fit.params.iter().zip(&fit.errors) {
                if let Some(v) = calibrated.param_mut(*p) {
                    *v += e;
                }
            }
            (fit.iterations.len(), fit.converged, rows, calibrated, None)
        }
    };
    let (position_rms, orientation_rms) = match &fit {
        // The fit's last linearisation is at the solution: its sums of squares
        // (for a constraint session, of each tool point's distance to its
        // estimated fixed point or plane).
        Some(f) => (f.position_rms, f.orientation_rms),
        None => full::residual_rms(&calibrated, observations(data)),
    };
    let mut calibration = Calibration::nominal(nominal.clone(), orientation, model.units);
    calibration.ranges = Some(crate::io::measurements::ranges(&data.poses));
    // What the prior's cross-validation measured of the fit written.
    calibration.held_out = prior.as_ref().and_then(PriorChoice::held_out);
    for row in parameters
        .iter()
        .filter(|r| r.fixed.is_none() && r.error != 0.0)
    {
        // At most 4M + 12 parameters: the capacity of the calibration.
        let _ = calibration.errors.push(ParamError {
            param: row.param,
            error: row.error,
        });
    }
    // Refuse now, before anything is written, if the calibration cannot be encoded.
    calibration.to_bytes()?;
    Ok(Identification {
        params: set,
        iterations,
        converged,
        parameters,
        position_rms,
        orientation_rms,
        full: fit,
        stated_prior: options.prior,
        prior,
        calibration,
    })
}

/// One channel's noise as the reports show it, in the model's units.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseRow {
    /// The channel's name (`position`, `point contact`, … `distance`).
    pub what: &'static str,
    /// The noise the rows were weighed by.
    pub used: f64,
    /// The noise the residuals show.
    pub shown: f64,
    /// Stated or estimated.
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

/// The noise of each channel the data have ([`noise::NoiseEstimate::rows`]),
/// in the model's units, for reports.
pub fn noise_rows(noise: &noise::NoiseEstimate, units: &Units) -> Vec<NoiseRow> {
    noise
        .rows()
        .into_iter()
        .map(|(channel, n)| {
            let (in_units, unit): (fn(&Units, f64) -> f64, String) =
                if channel == Some(noise::Channel::Orientation) {
                    (Units::angle_from_si, units.angle.to_string())
                } else {
                    (Units::length_from_si, units.length.to_string())
                };
            NoiseRow {
                what: channel.map_or("distance", noise::Channel::name),
                used: in_units(units, n.used),
                shown: in_units(units, n.shown),
                source: n.source,
                unit,
            }
        })
        .collect()
}

/// [`noise_rows`] as the reports' JSON list: `channel`, `used`,
/// `shown_by_residuals`, `source`, `unit`.
pub fn noise_json(noise: &noise::NoiseEstimate, units: &Units) -> serde_json::Value {
    noise_rows(noise, units)
        .into_iter()
        .map(|n| {
            json!({
                "channel": n.what, "used": n.used, "shown_by_residuals": n.shown,
                "source": n.source_name(), "unit": n.unit,
            })
        })
        .collect()
}

/// A parameter value in the model file's units.
fn in_units(units: &Units, param: Param, si: f64) -> f64 {
    if param.is_angle() {
        units.angle_from_si(si)
    } else {
        units.length_from_si(si)
    }
}

impl Identification {
    /// The JSON of `docs/file-formats.md` §6, values in the model's units.
    pub fn to_json(&self, units: &Units) -> serde_json::Value {
        let parameters: Vec<serde_json::Value> = self
            .parameters
            .iter()
            .map(|r| {
                let mut v = json!({
                    "name": r.param.to_string(),
                    "nominal": in_units(units, r.param, r.nominal),
                    "error": in_units(units, r.param, r.error),
                    "std": r.std.map(|s| in_units(units, r.param, s)),
                    "status": if r.fixed.is_some() { "fixed" } else { "identified" },
                });
                if let Some(reason) = &r.fixed {
                    v["reason"] = json!(reason);
                }
                v
            })
            .collect();
        let mut out = json!({
            "params": self.params.name(),
            "iterations": self.iterations,
            "converged": self.converged,
            "parameters": parameters,
            "residual": {
                "position_rms": units.length_from_si(self.position_rms),
                "orientation_rms": units.angle_from_si(self.orientation_rms),
                "position_rms_mm": self.position_rms * 1e3,
            },
            "units": {"length": units.length.to_string(), "angle": units.angle.to_string()},
        });
        if let Some(fit) = &self.full {
            out["condition_number"] = json!(fit.condition_number);
            out["observability_index"] = json!(fit.observability);
            out["variance_factor"] = json!(fit.variance_factor);
            out["equations"] = json!(fit.equations);
            out["noise"] = noise_json(&fit.noise, units);
            out["prior"] = self.prior_json(units);
            out["correlations"] = json!(
                fit.correlations
                    .iter()
                    .map(|(a, b, r)| json!({"a": a.to_string(), "b": b.to_string(), "r": r}))
                    .collect::<Vec<_>>()
            );
            if !fit.points.is_empty() || !fit.planes.is_empty() {
                let length = |x: f64| units.length_from_si(x);
                out["points"] = json!(
                    fit.points
                        .iter()
                        .map(|p| json!({
                            "name": p.name,
                            "xyz": [length(p.position.x), length(p.position.y), length(p.position.z)],
                            "std": p.std.iter().map(|s| s.is_finite().then(|| length(*s))).collect::<Vec<_>>(),
                        }))
                        .collect::<Vec<_>>()
                );
                out["planes"] = json!(
                    fit.planes
                        .iter()
                        .map(|p| json!({
                            "name": p.name,
                            "normal": [p.normal.x, p.normal.y, p.normal.z],
                            "offset": length(p.offset),
                        }))
                        .collect::<Vec<_>>()
                );
                out["distance_residuals"] = json!(
                    fit.distance_residuals
                        .iter()
                        .map(|d| length(*d))
                        .collect::<Vec<_>>()
                );
            }
        }
        out
    }

    /// The JSON's `prior`: the scale fitted at (model units; `null` for
    /// none), the factor on the stated one, and how it was chosen.
    fn prior_json(&self, units: &Units) -> serde_json::Value {
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
        json!({
            "length": finite(units.length_from_si(scaled.length)),
            "angle": finite(units.angle_from_si(scaled.angle)),
            "factor": factor,
            "chosen_by": chosen_by,
            "reach": self.full.as_ref().map(|f| f.prior_reach),
            "held_out": scores.map(|s| s.iter().map(|s| json!({
                "factor": s.factor,
                "rms_mm": s.held_out * 1e3,
            })).collect::<Vec<_>>()),
        })
    }

    /// The summary's line on the prior: its scale, and how it was chosen.
    fn prior_line(&self, u: &Units) -> Option<String> {
        self.full.as_ref()?;
        let p = &self.stated_prior;
        if !(p.length.is_finite() || p.angle.is_finite()) {
            return Some("prior: none (least squares)".into());
        }
        let factor = self.prior.as_ref().map_or(1.0, PriorChoice::factor);
        let scaled = p.scaled(factor);
        let mut line = format!(
            "prior {} {}, {} {} on the D-H errors",
            significant(u.length_from_si(scaled.length)),
            u.length,
            significant(u.angle_from_si(scaled.angle)),
            u.angle
        );
        match &self.prior {
            None => line.push_str(" (as stated)"),
            Some(PriorChoice::Immaterial) => line.push_str(&format!(
                " (as stated: no scale from ×{} to ×{} could change the held-out error by {} of its sampling error)",
                PRIOR_FACTORS[0],
                PRIOR_FACTORS[PRIOR_FACTORS.len() - 1],
                prior_scale::IMMATERIAL
            )),
            Some(PriorChoice::Undetermined { folds }) => line.push_str(&format!(
                " (as stated: no training set of the {folds}-fold cross-validation determines the model)"
            )),
            Some(
                c @ PriorChoice::CrossValidated {
                    factor, folds, ..
                },
            ) => {
                let mm = |f: f64| c.score_of(f).map(|s| format!("{} mm", significant(s * 1e3)));
                line.push_str(&format!(
                    ", the stated ×{factor}: held-out {} by {folds}-fold cross-validation",
                    mm(*factor).unwrap_or_default(),
                ));
                if *factor != 1.0
                    && let Some(stated) = mm(1.0)
                {
                    line.push_str(&format!(" against {stated} at the stated scale"));
                }
            }
        }
        Some(line)
    }

    /// The human summary.
    pub fn summary(&self, model: &RobotModel, data: &Measurements) -> String {
        let u = &model.units;
        let mut out = String::new();
        let _ = writeln!(
            out,
            "identify --params {}: {} ({} joints) from {} ({} poses{})",
            self.params.name(),
            model.name,
            model.robot.dof(),
            data.file,
            data.poses.len(),
            if self.calibration.orientation {
                ", full poses"
            } else {
                ", positions"
            }
        );
        let _ = writeln!(
            out,
            "{} after {} iterations; residual rms {:.6} {} ({:.4} mm){}",
            if self.converged {
                "converged"
            } else {
                "NOT converged"
            },
            self.iterations,
            u.length_from_si(self.position_rms),
            u.length,
            self.position_rms * 1e3,
            if self.calibration.orientation {
                format!(
                    ", orientation rms {:.6} {}",
                    u.angle_from_si(self.orientation_rms),
                    u.angle
                )
            } else {
                String::new()
            }
        );
        if let Some(fit) = &self.full {
            let _ = writeln!(
                out,
                "condition number {:.3e}, observability index O1 {:.3e}, variance factor {:.3} (residual/stated noise)²",
                fit.condition_number, fit.observability, fit.variance_factor
            );
            let redundancies = fit.noise.rows().into_iter().map(|(_, n)| n.redundancy);
            for (n, r) in noise_rows(&fit.noise, u).into_iter().zip(redundancies) {
                let NoiseRow {
                    what,
                    used,
                    shown,
                    ref unit,
                    ..
                } = n;
                let stated = n.source == noise::NoiseSource::Stated;
                let _ = match stated {
                    true if r < 1.0 => writeln!(
                        out,
                        "{what} noise {used:.3e} {unit} (stated); too few rows beyond the unknowns (redundancy {r:.2}) to check it"
                    ),
                    true => writeln!(
                        out,
                        "{what} noise {used:.3e} {unit} (stated); the residuals show {shown:.3e} {unit}"
                    ),
                    false => writeln!(
                        out,
                        "{what} noise {used:.3e} {unit} (estimated from the residuals)"
                    ),
                };
            }
        }
        if let Some(line) = self.prior_line(u) {
            let _ = writeln!(out, "{line}");
        }
        let _ = writeln!(
            out,
            "\n  {:<9} {:>14} {:>14} {:>12}   status",
            "parameter", "nominal", "error", "std"
        );
        for r in &self.parameters {
            let unit = if r.param.is_angle() {
                u.angle.to_string()
            } else {
                u.length.to_string()
            };
            let std = r.std.map_or("-".to_string(), |s| {
                format!("{:.3e}", in_units(u, r.param, s))
            });
            let _ = writeln!(
                out,
                "  {:<9} {:>14.6} {:>14.6e} {:>12}   {} [{unit}]",
                r.param.to_string(),
                in_units(u, r.param, r.nominal),
                in_units(u, r.param, r.error),
                std,
                r.fixed
                    .as_deref()
                    .map_or("identified".to_string(), |why| format!("fixed: {why}")),
            );
        }
        if let Some(fit) = self
            .full
            .as_ref()
            .filter(|f| !f.points.is_empty() || !f.planes.is_empty())
        {
            let _ = writeln!(
                out,
                "\nunknown fixed points (base frame, estimated with the robot) [{}]:",
                u.length
            );
            for p in &fit.points {
                let l = |x: f64| u.length_from_si(x);
                let _ = writeln!(
                    out,
                    "  {:<12} {:>12.6} {:>12.6} {:>12.6}   std {:.2e} {:.2e} {:.2e}",
                    p.name,
                    l(p.position.x),
                    l(p.position.y),
                    l(p.position.z),
                    l(p.std.x),
                    l(p.std.y),
                    l(p.std.z)
                );
            }
            for p in &fit.planes {
                let _ = writeln!(
                    out,
                    "  plane {:<12} normal ({:+.6}, {:+.6}, {:+.6}), offset {:.6} {}",
                    p.name,
                    p.normal.x,
                    p.normal.y,
                    p.normal.z,
                    u.length_from_si(p.offset),
                    u.length
                );
            }
            for (d, r) in data
                .constraints
                .distances
                .iter()
                .zip(&fit.distance_residuals)
            {
                let names = d.points.map(|k| {
                    data.constraints
                        .points
                        .get(k)
                        .map_or("?", |p| p.name.as_str())
                });
                let _ = writeln!(
                    out,
                    "  distance {} – {}: {:.6} {} stated, fitted minus stated {:+.2e} {} (line {})",
                    names[0],
                    names[1],
                    u.length_from_si(d.length),
                    u.length,
                    u.length_from_si(*r),
                    u.length,
                    d.line
                );
            }
        }
        if let Some(fit) = self.full.as_ref().filter(|f| !f.correlations.is_empty()) {
            let _ = writeln!(out, "\nstrongest correlations:");
            for (a, b, r) in &fit.correlations {
                let _ = writeln!(out, "  {a:<9} {b:<9} {r:+.4}");
            }
        }
        out
    }

    /// The calibrated model.
    pub fn calibrated(&self) -> Robot<f64> {
        self.calibration.calibrated()
    }

    /// Why this calibration of `model` from `data` must not be written (it
    /// did not converge, or fits `data` worse than the nominal model:
    /// [`crate::calibration::acceptance`]); `flag` names the way to write it
    /// anyway. `None` when it may be.
    pub fn refusal(
        &self,
        model: &RobotModel,
        data: &Measurements,
        flag: &'static str,
    ) -> Option<crate::calibration::acceptance::FailedCalibration> {
        use crate::calibration::acceptance::{Ending, Judged, Residual, refusal};
        use crate::calibration::contact_check::geometric;
        let ending = Ending {
            iterations: self.iterations,
            converged: self.converged,
            last_decrease: self.full.as_ref().map(|f| f.last_decrease),
        };
        // Measured coordinates, and every parameter held at its nominal
        // value: the file holds the fit's own model, whose residual the fit
        // has (a pass over a million rows spared).
        let own = self.full.is_some()
            && !data.is_constrained()
            && self
                .parameters
                .iter()
                .all(|r| r.fixed.is_none() || r.error == 0.0);
        let residual = own.then(|| Residual {
            position: self.position_rms,
            orientation: data.has_orientation().then_some(self.orientation_rms),
        });
        refusal(
            &model.robot,
            Judged {
                model: &geometric(&self.calibrated()),
                residual,
            },
            data,
            &[],
            ending,
            &model.units,
            flag,
        )
    }
}
