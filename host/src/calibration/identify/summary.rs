//! The summary `armcal identify` prints, values in the model file's units
//! (and mm beside them); the JSON is [`super::report`]'s. Nothing here
//! computes; it reads an [`Identification`].

use armcal_shared::compensation::Task;
use std::fmt::Write as _;

use super::Identification;
use super::prior_scale::{self, PriorChoice};
use super::report::{NoiseRow, noise_rows};
use crate::calibration::fit::noise;
use crate::report::format::{length_and_mm, significant};
use crate::report::units::param_in_units;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::prior::PRIOR_FACTORS;
use armcal_shared::units::Units;

impl Identification {
    /// The summary's line on the prior: its scale, and how it was chosen.
    fn prior_line(&self, u: &Units) -> Option<String> {
        self.full.as_ref()?;
        let p = &self.stated_prior;
        if !p.has_scale() {
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
            "identify --params {}: {} ({} joints) from {} ({}{})",
            self.params.name(),
            model.name,
            model.robot.dof(),
            data.file,
            crate::session::measurements::plural(data.poses.len(), "pose"),
            if self.calibration.task == Task::Pose {
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
            if self.calibration.task == Task::Pose {
                format!(
                    ", orientation rms {:.6} {}",
                    u.angle_from_si(self.orientation_rms),
                    u.angle
                )
            } else {
                String::new()
            }
        );
        self.write_judgement(&mut out, u, data);
        if let Some(fit) = &self.full {
            out.push_str(&super::sessions::summary(
                fit,
                &self.sessions_held_out,
                data,
                u,
            ));
        }
        self.write_suspect_rows(&mut out, data, u);
        if let Some(g) = &self.gravity {
            let _ = writeln!(out, "{}", g.summary());
        }
        self.write_fit_statistics(&mut out, u);
        self.write_parameters(&mut out, u);
        self.write_constraints(&mut out, u, data);
        self.write_correlations(&mut out);
        out
    }

    /// The rows the fit explains worst that fail the deleted-residual test
    /// ([`super::suspect_rows`]), each at its file and line, and what
    /// `diagnose` does with them.
    fn write_suspect_rows(&self, out: &mut String, data: &Measurements, u: &Units) {
        let rows = &self.suspect_rows;
        if rows.named.is_empty() {
            return;
        }
        let named: Vec<String> = rows
            .named
            .iter()
            .map(|r| {
                format!(
                    "{}:{} (residual {}, F = {:.3e} > {:.1})",
                    data.file_of(r.pose),
                    data.lines[r.pose],
                    length_and_mm(u, r.residual),
                    r.f,
                    r.threshold
                )
            })
            .collect();
        let more = rows.failing - rows.named.len();
        let _ = writeln!(
            out,
            "rows the fit explains worst, failing the deleted-residual test ({} of {} rows at \
             α = 1 %): {}{}; identify fits them, `armcal diagnose` sets such rows aside when \
             the others are predicted better without them",
            rows.failing,
            rows.tested,
            named.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        );
    }

    /// What the user should know of this identification of `data` that
    /// does not stop it, one a line for standard error and the JSON's
    /// `warnings`: each session that does not reconcile with the others
    /// ([`super::sessions::warnings`]), each row named by
    /// [`super::suspect_rows`].
    pub fn warnings(&self, data: &Measurements, u: &Units) -> Vec<String> {
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
                length_and_mm(u, r.residual),
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

    /// The nominal model's residual on the rows beside the calibration's
    /// (what `armcal predict` gives with the file written), when judged.
    fn write_judgement(&self, out: &mut String, u: &Units, data: &Measurements) {
        let Some(j) = &self.judgement else {
            return;
        };
        let what = if data.is_constrained() {
            "contact spread about the fitted points and planes"
        } else {
            "position RMS"
        };
        let length = |x: f64| length_and_mm(u, x);
        let _ = write!(
            out,
            "{what} on these rows: nominal {} → calibrated {}",
            length(j.nominal.position),
            length(j.calibrated.position)
        );
        if let (Some(n), Some(c)) = (j.nominal.orientation, j.calibrated.orientation) {
            let _ = write!(
                out,
                "; orientation nominal {:.6} → calibrated {:.6} {}",
                u.angle_from_si(n),
                u.angle_from_si(c),
                u.angle
            );
        }
        let several = self.full.as_ref().is_some_and(|f| f.sessions.len() > 1);
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

    /// The full fit's condition number, observability and variance factor, and each channel's noise.
    fn write_fit_statistics(&self, out: &mut String, u: &Units) {
        if let Some(fit) = &self.full {
            let _ = writeln!(
                out,
                "condition number {:.3e}, observability index O1 {:.3e}, variance factor {:.3} (residual/stated noise)²",
                fit.condition_number, fit.observability, fit.variance_factor
            );
            let rows = fit.noise.rows().into_iter().map(|(c, n)| {
                // The factor on the channel's weight (the known distances': 1).
                let factor = c.map_or(1.0, |c| fit.weights.of_channel(c));
                (n.redundancy, factor)
            });
            for (n, (r, factor)) in noise_rows(&fit.noise, u).into_iter().zip(rows) {
                let NoiseRow {
                    what,
                    used,
                    shown,
                    ref unit,
                    ..
                } = n;
                let stated = n.source == noise::NoiseSource::Stated;
                let _ = match stated {
                    _ if factor != 1.0 => writeln!(
                        out,
                        "{what} noise {used:.3e} {unit} ({}, at full weight; the rows weighed ×{factor} of it); the residuals show {shown:.3e} {unit}",
                        if stated { "stated" } else { "estimated" },
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

    /// The prior's line and the table of the parameters.
    fn write_parameters(&self, out: &mut String, u: &Units) {
        if let Some(line) = self.prior_line(u) {
            let _ = writeln!(out, "{line}");
        }
        if let Some(fit) = &self.full {
            out.push_str(&self.weighting.summary(fit));
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
                format!("{:.3e}", param_in_units(u, r.param, s))
            });
            let _ = writeln!(
                out,
                "  {:<9} {:>14.6} {:>14.6e} {:>12}   {} [{unit}]",
                r.param.to_string(),
                param_in_units(u, r.param, r.nominal),
                param_in_units(u, r.param, r.error),
                std,
                r.fixed
                    .as_deref()
                    .map_or("identified".to_string(), |why| format!("fixed: {why}")),
            );
        }
    }

    /// A constraint session's estimated points and planes and its distances' residuals.
    fn write_constraints(&self, out: &mut String, u: &Units, data: &Measurements) {
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
    }

    /// The strongest correlations of the estimates.
    fn write_correlations(&self, out: &mut String) {
        if let Some(fit) = self.full.as_ref().filter(|f| !f.correlations.is_empty()) {
            let _ = writeln!(out, "\nstrongest correlations:");
            for (a, b, r) in &fit.correlations {
                let _ = writeln!(out, "  {a:<9} {b:<9} {r:+.4}");
            }
        }
    }
}
