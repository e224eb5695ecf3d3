//! The summary `armcal identify` prints, rendered from its report
//! ([`IdentifyReport`], the JSON `--json` writes): values in the model
//! file's units, mm beside the lengths. Nothing here computes; what the
//! summary says, the JSON holds.

use std::fmt::Write as _;

use super::prior_scale;
use super::report::{
    ContactsReport, FullReport, IdentifyReport, NoiseRow, PriorChosenBy, PriorReport, TaskReport,
};
use super::sessions;
use crate::calibration::fit::noise::NoiseSource;
use crate::report::format::{length_and_mm_of, significant};
use crate::session::prior::PRIOR_FACTORS;

impl IdentifyReport {
    /// A length the report gives in the model's unit (`x`) and in `mm`, as
    /// the summary prints it.
    fn length(&self, x: f64, mm: f64) -> String {
        length_and_mm_of(x, &self.units.length, mm)
    }

    /// The human summary.
    pub fn summary(&self) -> String {
        let (length, angle) = (&self.units.length, &self.units.angle);
        let mut out = String::new();
        let _ = writeln!(
            out,
            "identify --params {}: {} ({} joints) from {} ({}{})",
            self.params,
            self.model,
            self.joints,
            self.data,
            crate::session::measurements::plural(self.poses, "pose"),
            match self.task {
                TaskReport::Pose => ", full poses",
                TaskReport::Position => ", positions",
            }
        );
        let r = &self.residual;
        let _ = writeln!(
            out,
            "{} after {} iterations; residual rms {:.6} {length} ({:.4} mm){}",
            if self.converged {
                "converged"
            } else {
                "NOT converged"
            },
            self.iterations,
            r.position_rms,
            r.position_rms_mm,
            match self.task {
                TaskReport::Pose => format!(", orientation rms {:.6} {angle}", r.orientation_rms),
                TaskReport::Position => String::new(),
            }
        );
        self.write_judgement(&mut out);
        if let Some(s) = self.full.as_ref().and_then(|f| f.sessions.as_deref()) {
            out.push_str(&sessions::summary(s, &self.units));
        }
        self.write_suspect_rows(&mut out);
        if let Some(g) = &self.gravity {
            let _ = writeln!(out, "{}", g.summary());
        }
        if let Some(full) = &self.full {
            full.write_statistics(&mut out);
            let _ = writeln!(out, "{}", full.prior.line(&self.units));
            out.push_str(&full.weights.summary());
        }
        self.write_parameters(&mut out);
        if let Some(contacts) = self.full.as_ref().and_then(|f| f.contacts.as_ref()) {
            contacts.write(&mut out, length);
        }
        if let Some(full) = self.full.as_ref().filter(|f| !f.correlations.is_empty()) {
            let _ = writeln!(out, "\nstrongest correlations:");
            for c in &full.correlations {
                let _ = writeln!(out, "  {:<9} {:<9} {:+.4}", c.a, c.b, c.r);
            }
        }
        out
    }

    /// The rows the fit explains worst that fail the deleted-residual test
    /// ([`super::suspect_rows`]), each at its file and line, and what
    /// `diagnose` does with them.
    fn write_suspect_rows(&self, out: &mut String) {
        if self.suspect_rows.is_empty() {
            return;
        }
        let named: Vec<String> = self
            .suspect_rows
            .iter()
            .map(|r| {
                format!(
                    "{}:{} (residual {}, F = {:.3e} > {:.1})",
                    r.file,
                    r.line,
                    self.length(r.residual, r.residual_mm),
                    r.f,
                    r.threshold
                )
            })
            .collect();
        let more = self.suspect_rows_failing - self.suspect_rows.len();
        let _ = writeln!(
            out,
            "rows the fit explains worst, failing the deleted-residual test ({} of {} rows at \
             α = 1 %): {}{}; identify fits them, `armcal diagnose` sets such rows aside when \
             the others are predicted better without them",
            self.suspect_rows_failing,
            self.suspect_rows_tested,
            named.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        );
    }

    /// The nominal model's residual on the rows beside the calibration's
    /// (what `armcal predict` gives with the file written), when judged.
    fn write_judgement(&self, out: &mut String) {
        let Some(j) = &self.nominal_residual else {
            return;
        };
        let what = if j.contact_spread {
            "contact spread about the fitted points and planes"
        } else {
            "position RMS"
        };
        let c = &j.calibrated;
        let _ = write!(
            out,
            "{what} on these rows: nominal {} → calibrated {}",
            self.length(j.position_rms, j.position_rms_mm),
            self.length(c.position_rms, c.position_rms_mm)
        );
        if let (Some(n), Some(c)) = (j.orientation_rms, c.orientation_rms) {
            let _ = write!(
                out,
                "; orientation nominal {n:.6} → calibrated {c:.6} {}",
                self.units.angle
            );
        }
        let several = self.full.as_ref().is_some_and(|f| f.sessions.is_some());
        let _ = writeln!(
            out,
            " (the calibration written{}",
            if several {
                ", each session in its own frames: `armcal predict` gives the first session's, below)"
            } else {
                ": `armcal predict` gives it)"
            }
        );
    }

    /// The table of the parameters.
    fn write_parameters(&self, out: &mut String) {
        let _ = writeln!(
            out,
            "\n  {:<9} {:>14} {:>14} {:>12}   status",
            "parameter", "nominal", "error", "std"
        );
        for r in &self.parameters {
            let unit = r.unit(&self.units);
            let std = r.std.map_or("-".to_string(), |s| format!("{s:.3e}"));
            let _ = writeln!(
                out,
                "  {:<9} {:>14.6} {:>14.6e} {:>12}   {} [{unit}]",
                r.name,
                r.nominal,
                r.error,
                std,
                r.reason
                    .as_deref()
                    .map_or("identified".to_string(), |why| format!("fixed: {why}")),
            );
        }
    }
}

impl FullReport {
    /// The full fit's condition number, observability and variance factor,
    /// and each channel's noise.
    fn write_statistics(&self, out: &mut String) {
        let _ = writeln!(
            out,
            "condition number {:.3e}, observability index O1 {:.3e}, variance factor {:.3} (residual/stated noise)²",
            self.condition_number, self.observability_index, self.variance_factor
        );
        for (n, check) in self.noise.iter().zip(&self.noise_checks) {
            let NoiseRow {
                what,
                used,
                shown,
                ref unit,
                ..
            } = *n;
            let (r, factor) = (check.redundancy, check.weight);
            let stated = n.source == NoiseSource::Stated;
            let _ = match stated {
                _ if factor != 1.0 => writeln!(
                    out,
                    "{what} noise {used:.3e} {unit} ({}, at full weight; the rows weighed ×{factor} of it); the residuals show {shown:.3e} {unit}",
                    n.source_name(),
                ),
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
}

impl PriorReport {
    /// The summary's line on the prior: its scale, and how it was chosen.
    fn line(&self, u: &crate::report::units::UnitsReport) -> String {
        if self.length.is_none() && self.angle.is_none() {
            return "prior: none (least squares)".into();
        }
        // A scale of none is infinite.
        let scale = |x: Option<f64>| significant(x.unwrap_or(f64::INFINITY));
        let mut line = format!(
            "prior {} {}, {} {} on the D-H errors",
            scale(self.length),
            u.length,
            scale(self.angle),
            u.angle
        );
        let mm = |f: f64| {
            self.held_out
                .iter()
                .flatten()
                .find(|s| s.factor == f)
                .map(|s| format!("{} mm", significant(s.rms_mm)))
        };
        match (self.chosen_by, self.folds) {
            (PriorChosenBy::Immaterial, _) => line.push_str(&format!(
                " (as stated: no scale from ×{} to ×{} could change the held-out error by {} of its sampling error)",
                PRIOR_FACTORS[0],
                PRIOR_FACTORS[PRIOR_FACTORS.len() - 1],
                prior_scale::IMMATERIAL
            )),
            (PriorChosenBy::Undetermined, Some(folds)) => line.push_str(&format!(
                " (as stated: no training set of the {folds}-fold cross-validation determines the model)"
            )),
            (PriorChosenBy::CrossValidation, Some(folds)) => {
                let factor = self.factor;
                line.push_str(&format!(
                    ", the stated ×{factor}: held-out {} by {folds}-fold cross-validation",
                    mm(factor).unwrap_or_default(),
                ));
                if factor != 1.0
                    && let Some(stated) = mm(1.0)
                {
                    line.push_str(&format!(" against {stated} at the stated scale"));
                }
            }
            _ => line.push_str(" (as stated)"),
        }
        line
    }
}

impl ContactsReport {
    /// A constraint session's estimated points and planes and its
    /// distances' residuals, lengths in `length`.
    fn write(&self, out: &mut String, length: &str) {
        let _ = writeln!(
            out,
            "\nunknown fixed points (base frame, estimated with the robot) [{length}]:"
        );
        // A coordinate's standard error not determined reads as NaN.
        let std = |s: Option<f64>| s.unwrap_or(f64::NAN);
        for p in &self.points {
            let _ = writeln!(
                out,
                "  {:<12} {:>12.6} {:>12.6} {:>12.6}   std {:.2e} {:.2e} {:.2e}",
                p.name,
                p.xyz[0],
                p.xyz[1],
                p.xyz[2],
                std(p.std[0]),
                std(p.std[1]),
                std(p.std[2])
            );
        }
        for p in &self.planes {
            let _ = writeln!(
                out,
                "  plane {:<12} normal ({:+.6}, {:+.6}, {:+.6}), offset {:.6} {length}",
                p.name, p.normal[0], p.normal[1], p.normal[2], p.offset,
            );
        }
        for d in &self.distances {
            let _ = writeln!(
                out,
                "  distance {} – {}: {:.6} {length} stated, fitted minus stated {:+.2e} {length} (line {})",
                d.between[0], d.between[1], d.length, d.residual, d.line
            );
        }
    }
}
