//! The diagnosis as its reports give it: the summary `armcal diagnose`
//! prints, the JSON of `--json` (`docs/file-formats.md` §6), and the labels,
//! noise rows and held-out rows the HTML page ([`super::html`]) shares
//! with them. Nothing here computes; it reads a [`Diagnosis`].

use armcal_shared::effects::Effect;
use armcal_shared::{Calibration, JointType, Param, Robot};

use super::{Choice, DiagnoseOptions, Diagnosis, HeldOut, HeldOutModels, Shortfall};
use crate::calibration::fit::Status;
use crate::calibration::fit::prior::Geometry;
use crate::report::format::significant;
use crate::session::measurements::Measurements;
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

/// `a2, theta3`, or `none`: parameters as reports list them.
pub fn parameter_list(params: &[Param]) -> String {
    if params.is_empty() {
        "none".to_string()
    } else {
        params
            .iter()
            .map(|p| p.to_string())
            .collect::<Vec<_>>()
            .join(", ")
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

impl Diagnosis {
    /// What the models' scores include, for a report's heading: empty, or
    /// the effects found when the geometric models were scored again with
    /// them.
    pub fn models_scored(&self) -> String {
        if !self.models_with_effects || self.findings.is_empty() {
            return String::new();
        }
        let effects: Vec<String> = self
            .findings
            .iter()
            .map(|f| {
                format!(
                    "{} (joints {})",
                    f.candidate.name,
                    f.candidate.joints_label()
                )
            })
            .collect();
        format!(", each with the effects found: {}", effects.join(", "))
    }

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

    /// The noise of each channel, in the model's units, for reports: (what,
    /// used, shown by the residuals, source, unit).
    pub fn noise_rows(
        &self,
        units: &armcal_shared::units::Units,
    ) -> Vec<crate::calibration::identify::NoiseRow> {
        crate::calibration::identify::noise_rows(&self.geometric.noise, units)
    }

    /// The held-out statistics of the nominal model, the geometric and the
    /// extended calibration, labelled for reports.
    pub fn holdout_rows(&self) -> [(&'static str, HeldOut); 3] {
        let h = self.holdout;
        [
            ("nominal model", h.nominal),
            ("geometric calibration", h.geometric),
            ("extended calibration", h.extended),
        ]
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

    /// The JSON of `docs/file-formats.md` §6 (`noise_estimate_mm`, `holdout`, `effects`,
    /// `outlier_rows`), plus the chosen model, every model's held-out error, the
    /// noise of each channel, the prior's role and every candidate's
    /// first-round gain.
    pub fn to_json(
        &self,
        model: &crate::session::model::RobotModel,
        rows: RowPlaces<'_>,
        options: &DiagnoseOptions,
    ) -> serde_json::Value {
        use serde_json::json;
        let mm = |x: f64| x * 1e3;
        let line = |i: usize| rows.line(i);
        let units = &model.units;
        // The effects' values as the calibration written holds them.
        let written = self.calibration(&model.robot, false, *units);
        let effects = self.effects_json(model, &written, options);
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
        json!({
            "noise_estimate_mm": mm(self.noise),
            "noise": crate::calibration::identify::noise_json(&self.geometric.noise, units),
            "chosen": {
                "model": match self.choice {
                    Choice::Nominal => "nominal",
                    Choice::Calibrated { geometry, .. } => geometry.name(),
                },
                "label": self.chosen_label(),
                "prior_factor": factor,
                "prior": {"length": units.length_from_si(prior.length), "angle": units.angle_from_si(prior.angle)},
                "calibration_changes_nothing": self.choice == Choice::Nominal,
            },
            "models": self.models.iter().map(|m| json!({
                "model": m.label(),
                "parameters": m.parameters,
                "rms_mm": mm(m.held.rms), "mean_mm": mm(m.held.mean), "max_mm": mm(m.held.max),
            })).collect::<Vec<_>>(),
            "models_with_effects": self.models_with_effects && !self.findings.is_empty(),
            "prior_role": {
                "held_by_prior": names(&held),
                "moved_by_data": names(&moved),
                "data_share": self.fit.params.iter()
                    .filter(|p| matches!(p.status, Status::Identified { .. }))
                    .map(|p| json!({"name": p.param.to_string(), "data_share": p.data_share}))
                    .collect::<Vec<_>>(),
            },
            "holdout": self.holdout_json(options),
            "effects": effects,
            "written": {
                "held_out_rms_mm": written.held_out.map(mm),
                "geometric_fallback": written.geometric.as_ref().map(|g| json!({
                    "held_out_rms_mm": g.held_out.map(mm),
                    "parameters": g.errors.len(),
                })),
            },
            "replicates": self.replicates_json(),
            "selection": self.selection.map(|s| json!({
                "rows": s.rows, "every": s.every, "poses": s.poses, "set_aside": s.set_aside,
            })),
            "fitted": self.fitted.map(|h| json!({
                "rms_mm": mm(h.rms), "mean_mm": mm(h.mean), "max_mm": mm(h.max),
            })),
            "outlier_rows": self.blunders.iter().map(|&i| line(i)).collect::<Vec<_>>(),
            "suspect_rows": self.suspects.iter().map(|b| {
                let mut row = json!({
                    "row": line(b.pose), "f": b.f, "threshold": b.threshold,
                    "others_held_out_rms_mm_with": mm(b.held_with),
                    "others_held_out_rms_mm_without": mm(b.held_without),
                    "set_aside": b.set_aside,
                });
                if let Some(file) = rows.file(b.pose) {
                    row["file"] = json!(file);
                }
                row
            }).collect::<Vec<_>>(),
            "candidates": self.tried.iter().map(|(c, g)| json!({
                "name": c.name,
                "joints": c.joints.iter().map(|j| j + 1).collect::<Vec<_>>(),
                "gain": g,
            })).collect::<Vec<_>>(),
            "unsettled": self.unsettled_json(),
        })
    }

    /// The JSON's `effects`: each effect found, its parameters as the
    /// calibration `written` holds them (in the model's units), its evidence.
    fn effects_json(
        &self,
        model: &crate::session::model::RobotModel,
        written: &Calibration,
        options: &DiagnoseOptions,
    ) -> Vec<serde_json::Value> {
        use serde_json::json;
        let units = &model.units;
        self
            .findings
            .iter()
            .map(|f| {
                let mut parameters = serde_json::Map::new();
                if let Some(e) = written.effects.iter().find(|e| f.candidate.is(e)) {
                    for i in 0..e.parameter_count() {
                        let v = e.parameter(i).unwrap_or(0.0);
                        parameters.insert(
                            crate::calibration::fit::effect_parameter_name(e, i),
                            json!(effect_value(&model.robot, e, units, v)),
                        );
                    }
                }
                for p in &f.candidate.extra {
                    let error = written
                        .errors
                        .iter()
                        .find(|r| r.param == *p)
                        .map_or(0.0, |r| r.error);
                    parameters.insert(p.to_string(), json!(units.angle_from_si(error)));
                }
                let alike: Vec<serde_json::Value> = f
                    .alike
                    .iter()
                    .map(|a| {
                        json!({
                            "name": a.candidate.name,
                            "joints": a.candidate.joints.iter().map(|j| j + 1).collect::<Vec<_>>(),
                            "unexplained_sigma": a.unexplained,
                            "separated_by": a.separated_by(&f.candidate),
                        })
                    })
                    .collect();
                json!({
                    "name": f.candidate.name,
                    "joints": f.candidate.joints.iter().map(|j| j + 1).collect::<Vec<_>>(),
                    "parameters": parameters,
                    "gain": f.gain,
                    "alike": alike,
                    "evidence": format!(
                        "held-out RMS {:.1}% lower with it ({}-fold); F = {:.1} against the {:.1} of a 1% family-wise test",
                        100.0 * (1.0 - 1.0 / f.gain), options.folds, f.f_test.0, f.f_test.1
                    ),
                })
            })
            .collect()
    }

    /// The JSON's `holdout`: the held-out errors of the three models, mm.
    fn holdout_json(&self, options: &DiagnoseOptions) -> serde_json::Value {
        use serde_json::json;
        let mm = |x: f64| x * 1e3;
        let HeldOutModels {
            nominal,
            geometric,
            extended,
        } = self.holdout;
        json!({
            "method": format!("{}-fold", options.folds),
            "nominal_rms_mm": mm(nominal.rms),
            "geometric_rms_mm": mm(geometric.rms),
            "extended_rms_mm": mm(extended.rms),
            "nominal_mean_mm": mm(nominal.mean), "nominal_max_mm": mm(nominal.max),
            "geometric_mean_mm": mm(geometric.mean), "geometric_max_mm": mm(geometric.max),
            "extended_mean_mm": mm(extended.mean), "extended_max_mm": mm(extended.max),
        })
    }

    /// The JSON's `replicates`: the repeated configurations and the lack-of-fit test.
    fn replicates_json(&self) -> Option<serde_json::Value> {
        use serde_json::json;
        let mm = |x: f64| x * 1e3;
        self.replicates.map(|r| {
            json!({
                "rows": r.rows,
                "configurations": r.configurations,
                "robot_configurations": r.robot_configurations,
                "copies": r.copies,
                "pure_error_mm": r.lack_of_fit.map(|l| mm(l.pure.sigma)),
                "pure_error_dof": r.lack_of_fit.map(|l| l.pure.dof),
                "repeated_configurations": r.lack_of_fit.map(|l| l.pure.repeated),
                "residual_at_means_mm": r.lack_of_fit.map(|l| mm(l.shown)),
                "expected_at_means_mm": r.lack_of_fit.map(|l| mm(l.expected)),
                "lack_of_fit_f": r.lack_of_fit.map(|l| l.f),
                "lack_of_fit_threshold": r.lack_of_fit.map(|l| l.threshold),
                "lack_of_fit_p": r.lack_of_fit.map(|l| l.p),
                "lack_of_fit": r.lack_of_fit.map(|l| l.significant()),
            })
        })
    }

    /// The JSON's `unsettled`: the candidate the search stopped on.
    fn unsettled_json(&self) -> Option<serde_json::Value> {
        use serde_json::json;
        self.unsettled.as_ref().map(|u| {
            json!({
                "name": u.candidate.name,
                "joints": u.candidate.joints.iter().map(|j| j + 1).collect::<Vec<_>>(),
                "gain": u.gain, "f": u.f_test.0, "threshold": u.f_test.1,
                "shortfall": match u.shortfall {
                    Shortfall::Significance { .. } => "significance",
                    Shortfall::Gain { .. } => "gain",
                },
                "poses_needed": match u.shortfall {
                    Shortfall::Significance { poses_needed } => Some(poses_needed),
                    Shortfall::Gain { .. } => None,
                },
            })
        })
    }

    /// The human summary.
    pub fn summary(
        &self,
        rows: RowPlaces<'_>,
        options: &DiagnoseOptions,
        units: &armcal_shared::units::Units,
    ) -> String {
        let mut out = String::new();
        self.write_selection(&mut out);
        self.write_noise(&mut out, units);
        self.write_suspects(&mut out, rows);
        self.write_models(&mut out, options);
        self.write_holdout(&mut out, options);
        self.write_tried(&mut out);
        out
    }

    /// The noise of each channel and the repeated configurations.
    fn write_noise(&self, out: &mut String, units: &armcal_shared::units::Units) {
        use std::fmt::Write as _;
        let mm = |x: f64| x * 1e3;
        for n in self.noise_rows(units) {
            let (what, unit) = (n.what, &n.unit);
            let (used, shown) = (significant(n.used), significant(n.shown));
            let _ = match n.source_name() {
                "stated" => writeln!(
                    out,
                    "{what} noise {used} {unit} per axis (stated); the geometric calibration's \
                     residuals show {shown} {unit}"
                ),
                _ => writeln!(
                    out,
                    "{what} noise {used} {unit} per axis (estimated from the geometric \
                     calibration's residuals)"
                ),
            };
        }
        // With effects, what the extended calibration's residuals leave.
        if self.extends_the_geometry() {
            let _ = writeln!(
                out,
                "the extended calibration's residuals show {} mm per axis",
                significant(mm(self.noise))
            );
        }
        if let Some(r) = &self.replicates {
            let _ = writeln!(
                out,
                "{} rows in {} distinct configurations (joints equal within the encoder's resolution){}: every fit, test and count is of configurations, each the mean of its repeats, and every fold holds out a robot configuration whole",
                r.rows,
                r.configurations,
                robot_configurations(r)
            );
            if r.copies {
                let _ = writeln!(
                    out,
                    "the repeated positions are identical (copies of one reading, not readings of one pose): they show no instrument noise"
                );
            }
            if let Some(l) = &r.lack_of_fit {
                let _ = writeln!(
                    out,
                    "instrument noise from the repeats of {} configurations: {} mm per axis ({} degrees of freedom, model-free); the model's residuals at the means show {} mm where the instrument alone would leave {} mm: F {:.2} {} {:.2} (1%), {}",
                    l.pure.repeated,
                    significant(mm(l.pure.sigma)),
                    l.pure.dof,
                    significant(mm(l.shown)),
                    significant(mm(l.expected)),
                    l.f,
                    if l.significant() { ">" } else { "<" },
                    l.threshold,
                    if l.significant() {
                        "lack of fit: the model leaves more than the instrument's noise (an effect not modelled, or the robot's own repeatability)"
                    } else {
                        "no lack of fit"
                    }
                );
            }
        }
    }

    /// How a long session was diagnosed: on a sample, the calibration on all.
    fn write_selection(&self, out: &mut String) {
        use std::fmt::Write as _;
        if let Some(s) = &self.selection {
            let _ = writeln!(
                out,
                "{} rows: the model chosen on one row in {} ({} poses; every held-out figure, test \
                 and effect below is of them), the calibration written fitted to the {} rows \
                 kept; {} rows set aside by their residual about it (F above the 1% threshold \
                 over the rows)",
                s.rows,
                s.every,
                s.poses,
                s.rows - self.blunders.len(),
                s.set_aside
            );
        }
    }

    /// Each pose the screen flagged (`rows`: where each pose was read).
    fn write_suspects(&self, out: &mut String, rows: RowPlaces<'_>) {
        use std::fmt::Write as _;
        let mm = |x: f64| x * 1e3;
        for b in &self.suspects {
            let _ = writeln!(
                out,
                "{}: deleted residual F = {:.1} above the 1% threshold {:.1}; held-out RMS of the other poses {:.4} mm with it, {:.4} mm without: {}",
                rows.label(b.pose),
                b.f,
                b.threshold,
                mm(b.held_with),
                mm(b.held_without),
                if b.set_aside { "set aside" } else { "kept" }
            );
        }
    }

    /// Every geometric model's held-out error, the choice, the prior's role,
    /// the effects found and the one not settled.
    fn write_models(&self, out: &mut String, options: &DiagnoseOptions) {
        use std::fmt::Write as _;
        let mm = |x: f64| x * 1e3;
        let _ = writeln!(
            out,
            "\nheld-out position error of each model ({}-fold){}, mm:",
            options.folds,
            self.models_scored()
        );
        let _ = writeln!(
            out,
            "  {:<28} {:>6} {:>9} {:>9} {:>9}",
            "model", "params", "rms", "mean", "max"
        );
        for m in &self.models {
            let _ = writeln!(
                out,
                "  {:<28} {:>6} {:>9.4} {:>9.4} {:>9.4}",
                m.label(),
                m.parameters,
                mm(m.held.rms),
                mm(m.held.mean),
                mm(m.held.max)
            );
        }
        let _ = writeln!(out, "chosen: {}", self.chosen_label());
        if self.choice == Choice::Nominal {
            let _ = writeln!(
                out,
                "no calibrated model predicts poses it was not fitted to better than the nominal model: the calibration written changes nothing; measure more, and more varied, poses"
            );
        } else {
            let (held, moved) = self.prior_role();
            let _ = writeln!(out, "moved by the data: {}", parameter_list(&moved));
            let _ = writeln!(
                out,
                "held near nominal by the prior: {}",
                parameter_list(&held)
            );
        }
        if self.findings.is_empty() {
            let _ = writeln!(out, "nothing beyond geometry survives the test");
        }
        for f in &self.findings {
            let _ = writeln!(
                out,
                "found {} (joints {}): held-out gain ×{:.2}, F {:.1} > {:.1} (1% family-wise)",
                f.candidate.name,
                f.candidate.joints_label(),
                f.gain,
                f.f_test.0,
                f.f_test.1
            );
            for a in &f.alike {
                let _ = writeln!(out, "  {}", a.sentence(&f.candidate));
            }
        }
        if let Some(u) = &self.unsettled {
            let (name, joints, gain, (f, t)) = (
                &u.candidate.name,
                u.candidate.joints_label(),
                u.gain,
                u.f_test,
            );
            let _ = match u.shortfall {
                Shortfall::Significance { poses_needed } => writeln!(
                    out,
                    "not settled: {name} (joints {joints}) gains ×{gain:.2} held-out but F {f:.1} < {t:.1}; about {poses_needed} poses would settle it",
                ),
                Shortfall::Gain { min_gain } => writeln!(
                    out,
                    "not worth modelling: {name} (joints {joints}) passes the test (F {f:.1} > {t:.1}) but gains only ×{gain:.2} held-out (×{min_gain:.2} asked); more poses would not make it larger",
                ),
            };
        }
    }

    /// The held-out error of the nominal, geometric and extended models, the
    /// fitted one, and what a format without the effects gets.
    fn write_holdout(&self, out: &mut String, options: &DiagnoseOptions) {
        use std::fmt::Write as _;
        let mm = |x: f64| x * 1e3;
        let _ = writeln!(
            out,
            "\nheld-out position error ({}-fold), mm:   rms      mean     max",
            options.folds
        );
        for (label, h) in self.holdout_rows() {
            let _ = writeln!(
                out,
                "  {label:<24} {:>8.4} {:>8.4} {:>8.4}",
                mm(h.rms),
                mm(h.mean),
                mm(h.max)
            );
        }
        if let Some(h) = self.fitted {
            let gives = if self.fit.sessions.len() > 1 {
                "each session in its own frames: `armcal predict` gives the first session's"
            } else {
                "`armcal predict` gives these"
            };
            let _ = writeln!(
                out,
                "  {:<24} {:>8.4} {:>8.4} {:>8.4}  (the calibration written, at the poses it was fitted to: {gives})",
                "fitted, in-sample",
                mm(h.rms),
                mm(h.mean),
                mm(h.max)
            );
        }
        if !self.fit.effects.is_empty() && self.choice != Choice::Nominal {
            let _ = writeln!(
                out,
                "a format that cannot carry the effects (`armcal export --format urdf`, `ur-deltas`, `ur-calibration`) gets the geometric calibration fitted without them: {:.4} mm held-out",
                mm(self.holdout.geometric.rms)
            );
        }
    }

    /// The strongest candidates of the first round.
    fn write_tried(&self, out: &mut String) {
        use std::fmt::Write as _;
        let mut tried = self.tried.clone();
        tried.sort_by(|a, b| b.1.total_cmp(&a.1));
        if !tried.is_empty() {
            let _ = writeln!(
                out,
                "\nstrongest candidates (held-out gain on the geometric model):"
            );
        }
        for (c, gain) in tried.iter().take(6) {
            let _ = writeln!(
                out,
                "  {:<20} joints {:<6} ×{:.3}",
                c.name,
                c.joints_label(),
                gain
            );
        }
    }
}

/// `, at 16 configurations of the robot` when the configurations are of
/// several measured points or sessions at fewer robot configurations.
fn robot_configurations(r: &super::Replicates) -> String {
    if r.robot_configurations < r.configurations {
        format!(
            ", at {} configurations of the robot",
            r.robot_configurations
        )
    } else {
        String::new()
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
