//! The plan as its reports give it: the summary `armcal plan` prints, the
//! JSON of `--json` (`docs/file-formats.md` §7) and the joints file it writes.
//! Lengths in the model's units (`_mm` fields in mm), each parameter's
//! standard error in its own unit. Nothing here computes; it reads a [`Plan`].

use std::fmt::Write as _;

use armcal_shared::units::Units;
use serde_json::json;

use super::{Plan, PlanOptions, Prediction};

/// A parameter's value in the model's unit: length or angle.
fn in_units(u: &Units, param: armcal_shared::Param, si: f64) -> f64 {
    if param.is_angle() {
        u.angle_from_si(si)
    } else {
        u.length_from_si(si)
    }
}

/// One prediction as JSON.
fn prediction_json(p: &Prediction, u: &Units) -> serde_json::Value {
    json!({
        "predicted_rms_mm": p.rms * 1e3,
        "predicted_max_mm": p.max * 1e3,
        "predicted_measured_rms_mm": p.measured_rms * 1e3,
        "std": p.std.iter().map(|(param, s)| json!({
            "name": param.to_string(),
            "std": in_units(u, *param, *s),
            "unit": if param.is_angle() { u.angle.to_string() } else { u.length.to_string() },
        })).collect::<Vec<_>>(),
        "observability": {
            "O1": p.observability[0], "O2": p.observability[1], "O3": p.observability[2],
            "O4": p.observability[3], "O5": p.observability[4],
        },
    })
}

impl Plan {
    /// The JSON of `--json` (`docs/file-formats.md` §7).
    pub fn to_json(&self, options: &PlanOptions, u: &Units) -> serde_json::Value {
        let mut out = prediction_json(&self.predicted, u);
        out["poses"] = json!(self.q.len());
        out["noise_mm"] = json!(options.position_noise * 1e3);
        out["orientation"] = json!(options.orientation);
        out["candidates"] = json!(self.candidates);
        out["targets"] = json!(self.targets);
        out["path"] = json!(self.path);
        out["random"] = match &self.random {
            Ok(p) => prediction_json(p, u),
            Err(missed) => json!({
                "identifies": false,
                "missed": missed.iter().map(ToString::to_string).collect::<Vec<_>>(),
            }),
        };
        out["held"] = json!(
            self.held
                .iter()
                .map(|(p, why)| json!({"name": p.to_string(), "reason": why}))
                .collect::<Vec<_>>()
        );
        out["units"] = json!({"length": u.length.to_string(), "angle": u.angle.to_string()});
        out
    }

    /// The summary `armcal plan` prints.
    pub fn summary(&self, model_name: &str, options: &PlanOptions) -> String {
        let mut out = String::new();
        let mm = |x: f64| x * 1e3;
        let _ = writeln!(
            out,
            "plan: {} poses of {model_name} ({}), chosen from {} candidates for {} workspace \
             configurations; the measurement path {:.3} (joint space, rad and m)",
            self.q.len(),
            if options.orientation {
                "full poses"
            } else {
                "positions"
            },
            self.candidates,
            self.targets,
            self.path
        );
        let _ = writeln!(
            out,
            "predicted at {} mm noise per axis: the calibrated robot off by {:.4} mm RMS over the \
             workspace, {:.4} mm at its worst target ({:.4} mm RMS against new measurements, \
             their noise added); {} random poses: {}",
            significant_mm(options.position_noise),
            mm(self.predicted.rms),
            mm(self.predicted.max),
            mm(self.predicted.measured_rms),
            self.q.len(),
            match &self.random {
                Ok(p) => format!(
                    "{:.4} mm, {:.4} mm ({:.4} mm)",
                    mm(p.rms),
                    mm(p.max),
                    mm(p.measured_rms)
                ),
                Err(missed) => format!(
                    "do not identify {}",
                    missed
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }
        );
        let o = &self.predicted.observability;
        let _ = writeln!(
            out,
            "observability O1 {:.3e}, O2 {:.3e}, O3 {:.3e}, O4 {:.3e}, O5 {:.3e}; {} parameters identified",
            o[0],
            o[1],
            o[2],
            o[3],
            o[4],
            self.predicted.std.len()
        );
        for (p, why) in &self.held {
            let _ = writeln!(out, "  {p}: no plan identifies it: {why}");
        }
        out
    }
}

/// A noise in mm, without trailing zeros.
fn significant_mm(m: f64) -> String {
    crate::calibration::diagnose::significant(m * 1e3)
}
