//! The summary `armcal diagnose` prints, rendered from its report
//! ([`DiagnoseReport`], the JSON `--json` writes: what the summary says, the
//! JSON holds), and the sentences and rows the HTML page ([`super::html`])
//! renders from the same report. Nothing here computes, and nothing reads
//! the [`super::Diagnosis`] itself.

use std::fmt::Write as _;

use super::candidates::joints_label;
use super::report::{
    AlikeReport, ApproachOrder, CandidateReport, DiagnoseReport, DiagnosisReport, EffectReport,
    HoldoutReport,
};
use crate::calibration::fit::noise::NoiseSource;
use crate::calibration::identify::sessions;
use crate::report::format::significant;

/// `a2, theta3`, or `none`: parameters by name as reports list them.
pub(crate) fn name_list(names: &[String]) -> String {
    if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    }
}

impl DiagnoseReport {
    /// The summary `armcal diagnose` prints: the masses' fit to the
    /// measured torques, if any, the weights, each session's figures when
    /// there are several, the diagnosis' own, and a note when a backlash
    /// read its approach directions from the rows' order.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        if let Some(g) = &self.gravity {
            out.push_str(&g.summary());
            out.push('\n');
        }
        out.push_str(&self.weights.summary());
        if let Some(s) = &self.sessions {
            out.push_str(&sessions::summary(s, &self.diagnosis.units));
        }
        out.push_str(&self.diagnosis.summary());
        let backlash: Vec<String> = self
            .diagnosis
            .effects
            .iter()
            .filter(|e| e.name == "backlash")
            .map(|e| joints_label(e.joints.iter().copied()))
            .collect();
        if self.approach_order == ApproachOrder::Rows && !backlash.is_empty() {
            let _ = writeln!(
                out,
                "note: the backlash of joint {} takes each pose's approach direction from the \
                 rows' order (the file has no `t` column): it holds only if the rows are in the \
                 order the robot moved",
                backlash.join(", ")
            );
        }
        out
    }
}

impl DiagnosisReport {
    /// What the models' scores include, for a heading: empty, or the
    /// effects found when the geometric models were scored again with them.
    pub fn models_scored(&self) -> String {
        if !self.models_with_effects {
            return String::new();
        }
        let effects: Vec<String> = self
            .effects
            .iter()
            .map(|e| {
                format!(
                    "{} (joints {})",
                    e.name,
                    joints_label(e.joints.iter().copied())
                )
            })
            .collect();
        format!(", each with the effects found: {}", effects.join(", "))
    }

    /// The diagnosis' own summary: the long session's selection, the noise,
    /// the flagged poses, every model's held-out error and the choice, the
    /// held-out errors of the three models, the strongest candidates.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        self.write_selection(&mut out);
        self.write_noise(&mut out);
        self.write_suspects(&mut out);
        self.write_models(&mut out);
        self.write_holdout(&mut out);
        self.write_tried(&mut out);
        out
    }

    /// The noise of each channel and the repeated configurations.
    fn write_noise(&self, out: &mut String) {
        for n in &self.noise {
            let (what, unit) = (n.what, &n.unit);
            let (used, shown) = (significant(n.used), significant(n.shown));
            let _ = match n.source {
                NoiseSource::Stated => writeln!(
                    out,
                    "{what} noise {used} {unit} per axis (stated); the geometric calibration's \
                     residuals show {shown} {unit}"
                ),
                NoiseSource::Estimated => writeln!(
                    out,
                    "{what} noise {used} {unit} per axis (estimated from the geometric \
                     calibration's residuals)"
                ),
            };
        }
        // With effects, what the extended calibration's residuals leave.
        if self.extends_the_geometry {
            let _ = writeln!(
                out,
                "the extended calibration's residuals show {} mm per axis",
                significant(self.noise_estimate_mm)
            );
        }
        if let Some(r) = &self.replicates {
            let robot = if r.robot_configurations < r.configurations {
                format!(
                    ", at {} configurations of the robot",
                    r.robot_configurations
                )
            } else {
                String::new()
            };
            let _ = writeln!(
                out,
                "{} rows in {} distinct configurations (joints equal within the encoder's resolution){robot}: every fit, test and count is of configurations, each the mean of its repeats, and every fold holds out a robot configuration whole",
                r.rows, r.configurations,
            );
            if r.copies {
                let _ = writeln!(
                    out,
                    "the repeated positions are identical (copies of one reading, not readings of one pose): they show no instrument noise"
                );
            }
            if let (
                Some(repeated),
                Some(pure),
                Some(dof),
                Some(shown),
                Some(expected),
                Some(f),
                Some(threshold),
                Some(lack),
            ) = (
                r.repeated_configurations,
                r.pure_error_mm,
                r.pure_error_dof,
                r.residual_at_means_mm,
                r.expected_at_means_mm,
                r.lack_of_fit_f,
                r.lack_of_fit_threshold,
                r.lack_of_fit,
            ) {
                let _ = writeln!(
                    out,
                    "instrument noise from the repeats of {repeated} configurations: {} mm per axis ({dof} degrees of freedom, model-free); the model's residuals at the means show {} mm where the instrument alone would leave {} mm: F {f:.2} {} {threshold:.2} (1%), {}",
                    significant(pure),
                    significant(shown),
                    significant(expected),
                    if lack { ">" } else { "<" },
                    if lack {
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
                s.rows - self.outlier_rows.len(),
                s.set_aside
            );
        }
    }

    /// Each pose the screen flagged, named by its line (and file, with
    /// several sessions).
    fn write_suspects(&self, out: &mut String) {
        for b in &self.suspect_rows {
            let _ = writeln!(
                out,
                "{} line {}: deleted residual F = {:.1} above the 1% threshold {:.1}; held-out RMS of the other poses {:.4} mm with it, {:.4} mm without: {}",
                b.file.as_deref().unwrap_or("data"),
                b.row,
                b.f,
                b.threshold,
                b.others_held_out_rms_mm_with,
                b.others_held_out_rms_mm_without,
                if b.set_aside { "set aside" } else { "kept" }
            );
        }
    }

    /// Every geometric model's held-out error, the choice, the prior's role,
    /// the effects found and the one not settled.
    fn write_models(&self, out: &mut String) {
        let scored = self.models_scored();
        let _ = writeln!(
            out,
            "\nheld-out position error of each model ({}-fold){scored}, mm:",
            self.holdout.folds,
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
                m.model, m.parameters, m.rms_mm, m.mean_mm, m.max_mm
            );
        }
        let _ = writeln!(out, "chosen: {}", self.chosen.label);
        if self.chosen.calibration_changes_nothing {
            let _ = writeln!(
                out,
                "no calibrated model predicts poses it was not fitted to better than the nominal model: the calibration written changes nothing; measure more, and more varied, poses"
            );
        } else {
            let role = &self.prior_role;
            let _ = writeln!(out, "moved by the data: {}", name_list(&role.moved_by_data));
            let _ = writeln!(
                out,
                "held near nominal by the prior: {}",
                name_list(&role.held_by_prior)
            );
        }
        if self.effects.is_empty() {
            let _ = writeln!(out, "nothing beyond geometry survives the test");
        }
        for e in &self.effects {
            let _ = writeln!(out, "{}", e.sentence());
            for a in &e.alike {
                let _ = writeln!(out, "  {}", a.sentence());
            }
        }
        if let Some(u) = &self.unsettled {
            let (name, joints, gain, f, t) = (
                u.name,
                joints_label(u.joints.iter().copied()),
                u.gain,
                u.f,
                u.threshold,
            );
            let _ = match (u.poses_needed, u.min_gain) {
                (Some(poses_needed), _) => writeln!(
                    out,
                    "not settled: {name} (joints {joints}) gains ×{gain:.2} held-out but F {f:.1} < {t:.1}; about {poses_needed} poses would settle it",
                ),
                (None, min_gain) => writeln!(
                    out,
                    "not worth modelling: {name} (joints {joints}) passes the test (F {f:.1} > {t:.1}) but gains only ×{gain:.2} held-out (×{:.2} asked); more poses would not make it larger",
                    min_gain.unwrap_or(f64::NAN)
                ),
            };
        }
    }

    /// The held-out error of the nominal, geometric and extended models, the
    /// fitted one, and what a format without the effects gets.
    fn write_holdout(&self, out: &mut String) {
        let h = &self.holdout;
        let _ = writeln!(
            out,
            "\nheld-out position error ({}-fold), mm:   rms      mean     max",
            h.folds
        );
        for (label, rms, mean, max) in h.rows() {
            let _ = writeln!(out, "  {label:<24} {rms:>8.4} {mean:>8.4} {max:>8.4}");
        }
        if let Some(f) = &self.fitted {
            let gives = if self.session_count > 1 {
                "each session in its own frames: `armcal predict` gives the first session's"
            } else {
                "`armcal predict` gives these"
            };
            let _ = writeln!(
                out,
                "  {:<24} {:>8.4} {:>8.4} {:>8.4}  (the calibration written, at the poses it was fitted to: {gives})",
                "fitted, in-sample", f.rms_mm, f.mean_mm, f.max_mm
            );
        }
        if self.extends_the_geometry {
            let _ = writeln!(
                out,
                "a format that cannot carry the effects (`armcal export --format urdf`, `ur-deltas`, `ur-calibration`) gets the geometric calibration fitted without them: {:.4} mm held-out",
                h.geometric_rms_mm
            );
        }
    }

    /// The strongest candidates of the first round.
    fn write_tried(&self, out: &mut String) {
        let mut tried: Vec<&CandidateReport> = self.candidates.iter().collect();
        tried.sort_by(|a, b| b.gain.total_cmp(&a.gain));
        if !tried.is_empty() {
            let _ = writeln!(
                out,
                "\nstrongest candidates (held-out gain on the geometric model):"
            );
        }
        for c in tried.iter().take(6) {
            let _ = writeln!(
                out,
                "  {:<20} joints {:<6} ×{:.3}",
                c.name,
                joints_label(c.joints.iter().copied()),
                c.gain
            );
        }
    }
}

impl HoldoutReport {
    /// The held-out errors (RMS, mean, largest, mm) of the nominal model,
    /// the geometric and the extended calibration, labelled for reports.
    pub fn rows(&self) -> [(&'static str, f64, f64, f64); 3] {
        [
            (
                "nominal model",
                self.nominal_rms_mm,
                self.nominal_mean_mm,
                self.nominal_max_mm,
            ),
            (
                "geometric calibration",
                self.geometric_rms_mm,
                self.geometric_mean_mm,
                self.geometric_max_mm,
            ),
            (
                "extended calibration",
                self.extended_rms_mm,
                self.extended_mean_mm,
                self.extended_max_mm,
            ),
        ]
    }
}

impl AlikeReport {
    /// The effect the data cannot tell from the one found, as the summary
    /// and the HTML page say it.
    pub fn sentence(&self) -> String {
        format!(
            "these data cannot tell it from {} (joints {}), which reproduces its signature to within {:.1} standard errors of the noise; to separate them, {}",
            self.name,
            joints_label(self.joints.iter().copied()),
            self.unexplained_sigma,
            self.separated_by
        )
    }
}

impl EffectReport {
    /// The effect found, as the summary and the HTML page say it.
    pub fn sentence(&self) -> String {
        format!(
            "found {} (joints {}): held-out gain ×{:.2}, F {:.1} > {:.1} (1% family-wise)",
            self.name,
            joints_label(self.joints.iter().copied()),
            self.gain,
            self.f,
            self.threshold
        )
    }
}
