//! The summary `armcal diagnose` prints, and the labels, noise rows and
//! held-out rows the HTML page ([`super::html`]) and the report
//! ([`super::report`], the JSON) share with it. Nothing here computes; it
//! reads a [`Diagnosis`].

use armcal_shared::effects::Effect;
use armcal_shared::{JointType, Param, Robot};

use super::{Choice, DiagnoseOptions, Diagnosis, HeldOut, Shortfall};
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
    ) -> Vec<crate::calibration::identify::report::NoiseRow> {
        crate::calibration::identify::report::noise_rows(&self.geometric.noise, units)
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
            let _ = writeln!(out, "{}", f.sentence());
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
