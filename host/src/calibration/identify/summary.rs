//! The identification as its reports give it: the summary `armcal identify`
//! prints and the JSON of `--json` (`docs/file-formats.md` §6), values in the
//! model file's units (`mm`-suffixed fields excepted), and the noise rows
//! `diagnose`'s reports share. Nothing here computes; it reads an
//! [`Identification`].

use std::fmt::Write as _;

use armcal_shared::Param;
use serde_json::json;

use super::Identification;
use super::prior_scale::{self, PriorChoice};
use crate::calibration::fit::noise;
use crate::report::format::{length_and_mm, significant};
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::prior::PRIOR_FACTORS;
use armcal_shared::units::Units;

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
                if channel == Some(crate::session::channel::Channel::Orientation) {
                    (Units::angle_from_si, units.angle.to_string())
                } else {
                    (Units::length_from_si, units.length.to_string())
                };
            NoiseRow {
                what: channel.map_or("distance", crate::session::channel::Channel::name),
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
    /// The JSON of `docs/file-formats.md` §6 of an identification from
    /// `data`, values in the model's units.
    pub fn to_json(&self, units: &Units, data: &Measurements) -> serde_json::Value {
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
        if let Some(g) = &self.gravity {
            out["gravity"] = g.to_json();
        }
        out["warnings"] = json!(self.warnings(data, units));
        out["suspect_rows"] = json!(
            self.suspect_rows
                .named
                .iter()
                .map(|r| json!({
                    "file": data.file_of(r.pose),
                    "line": data.lines[r.pose],
                    "residual": units.length_from_si(r.residual),
                    "residual_mm": r.residual * 1e3,
                    "f": r.f,
                    "threshold": r.threshold,
                }))
                .collect::<Vec<_>>()
        );
        if let Some(j) = &self.judgement {
            out["nominal_residual"] = json!({
                "position_rms": units.length_from_si(j.nominal.position),
                "position_rms_mm": j.nominal.position * 1e3,
            });
        }
        if let Some(fit) = &self.full {
            if let Some(sessions) = super::sessions::json(fit, &self.sessions_held_out, data, units)
            {
                out["sessions"] = sessions;
            }
            out["condition_number"] = json!(fit.condition_number);
            out["observability_index"] = json!(fit.observability);
            out["variance_factor"] = json!(fit.variance_factor);
            out["equations"] = json!(fit.equations);
            out["noise"] = noise_json(&fit.noise, units);
            out["prior"] = self.prior_json(units);
            self.weighting.insert_json(&mut out, fit);
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
