//! The plan as data: [`PlanReport`], the JSON of `--json`
//! (`docs/file-formats.md` §7) and Python's dictionary; the summary `armcal
//! plan` prints is rendered from it, and so are the HTML page's text and
//! table (`--html`), beside the workspace seen from above and from the
//! side, each target coloured by the predicted error there, the planned
//! poses' tool points on it (the plan's geometry, which the report does not
//! hold). Lengths in the model's units (`_mm` fields in mm), each
//! parameter's standard error in its own unit. Nothing here computes; it
//! reads a [`Plan`].

use crate::report::units::param_in_units;
use crate::session::measurements::plural;
use std::fmt::Write as _;

use armcal_shared::units::Units;
use serde::Serialize;

use crate::report::units::UnitsReport;

use armcal_shared::Param;

use super::{OFF_AXIS, Plan, PlanOptions, Prediction};
use crate::apply::compensate;
use armcal_shared::Calibration;

/// `armcal plan`'s report (docs/file-formats.md §7): the plan's predicted
/// accuracy, its rows, and the designs it was compared with.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlanReport {
    /// The model's name.
    pub model: String,
    /// The plan's predicted accuracy.
    #[serde(flatten)]
    pub predicted: PredictionReport,
    /// The poses planned.
    pub poses: usize,
    /// The rows written (a pose visited from both sides is two).
    pub rows: usize,
    /// Whether each pose is visited from both sides.
    pub both_sides: bool,
    /// The poses that could be approached from one side only.
    pub one_sided: usize,
    /// The rows near a singularity, from 1, with their conditioning.
    pub near_singular: Vec<NearSingular>,
    /// The position noise planned for, mm.
    pub noise_mm: f64,
    /// Whether orientations are measured.
    pub orientation: bool,
    /// Each compliance's predicted standard error.
    pub compliance: Vec<ComplianceStd>,
    /// The compliances held, and why.
    pub compliance_held: Vec<ComplianceHeld>,
    /// Without a tracker: the sockets and how the rows seat in them.
    #[serde(flatten)]
    pub sockets: Option<SocketsReport>,
    /// The candidate poses searched.
    pub candidates: usize,
    /// The target points the accuracy is predicted at.
    pub targets: usize,
    /// The length of the path through the poses, rad.
    pub path: f64,
    /// As many random poses.
    pub random: Predicted,
    /// The optimality criterion of the plan.
    pub criterion: &'static str,
    /// The best design of the other criterion.
    pub compared: ComparedReport,
    /// The parameters the poses identify.
    pub identified: Vec<String>,
    /// The parameters held, and why.
    pub held: Vec<HeldReport>,
    /// Whether the poses were kept above the robot's base plane (the model
    /// gives no joint limits, and no cell was stated).
    pub above_base: bool,
    /// The tool point off the flange's axis that the plan suggests.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub off_axis: Option<OffAxisReport>,
    /// The model file's units.
    pub units: UnitsReport,
}

/// A design's predicted accuracy at the targets.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PredictionReport {
    /// RMS of the predicted error at the targets, mm.
    pub predicted_rms_mm: f64,
    /// Its largest, mm.
    pub predicted_max_mm: f64,
    /// What a measurement at the targets would show, RMS, mm.
    pub predicted_measured_rms_mm: f64,
    /// Each parameter's predicted standard error.
    pub std: Vec<ParameterStd>,
    /// The observability indices O1 to O5.
    pub observability: Observability,
}

/// A parameter's predicted standard error, in its own unit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParameterStd {
    /// The parameter.
    pub name: String,
    /// Its standard error.
    pub std: f64,
    /// Its unit.
    pub unit: String,
    /// Whether poses can identify it (else the prior's).
    pub identified: bool,
}

/// The observability indices of Sun & Hollerbach's survey.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[expect(
    non_snake_case,
    reason = "the indices' names, O1 to O5, are the report's keys"
)]
pub struct Observability {
    /// Product of the singular values.
    pub O1: f64,
    /// Condition number's inverse.
    pub O2: f64,
    /// Smallest singular value.
    pub O3: f64,
    /// Noise amplification index.
    pub O4: f64,
    /// Inverse of the sum of the inverse singular values.
    pub O5: f64,
}

/// A design's prediction, or what it misses.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Predicted {
    /// It identifies every parameter the plan does.
    Identifies(PredictionReport),
    /// It does not.
    Misses {
        /// Always false.
        identifies: bool,
        /// The parameters it does not identify.
        missed: Vec<String>,
    },
}

/// A row near a singularity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NearSingular {
    /// The row, from 1.
    pub row: usize,
    /// Its conditioning.
    pub conditioning: f64,
}

/// A compliance's predicted standard error, rad/(N·m).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ComplianceStd {
    /// The joint, from 1.
    pub joint: usize,
    /// Its standard error.
    pub std: f64,
}

/// A compliance held, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ComplianceHeld {
    /// The joint, from 1.
    pub joint: usize,
    /// Why.
    pub reason: String,
}

/// The sockets of a plan without a tracker.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SocketsReport {
    /// Each socket and its rows.
    pub sockets: Vec<SocketRows>,
    /// The known distances between them.
    pub distances: usize,
    /// Each row's socket.
    pub socket_of: Vec<String>,
}

/// A socket and the rows seated in it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SocketRows {
    /// Its name.
    pub name: String,
    /// The rows seated in it.
    pub poses: usize,
}

/// The best design of the other criterion.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ComparedReport {
    /// Its criterion.
    pub criterion: &'static str,
    /// Its prediction.
    pub predicted: Predicted,
}

/// A parameter held, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HeldReport {
    /// The parameter.
    pub name: String,
    /// Why.
    pub reason: String,
}

/// A tool point off the flange's axis and what it gains.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OffAxisReport {
    /// The tool point's distance from the axis today, the model's length unit.
    pub distance: f64,
    /// The same, mm.
    pub distance_mm: f64,
    /// The tool point suggested, the model's length unit (flange frame).
    pub tool: Vec<f64>,
    /// The same, mm.
    pub tool_mm: Vec<f64>,
    /// Its distance from the axis, mm.
    pub off_axis_mm: f64,
    /// The parameters it makes identifiable.
    pub gained: Vec<String>,
    /// The plan's prediction with it.
    pub predicted: Option<PredictionReport>,
}

/// One prediction in the reports; `identified`: the parameters poses can
/// identify (the others' standard errors are the prior's).
fn prediction_report(p: &Prediction, identified: &[Param], u: &Units) -> PredictionReport {
    PredictionReport {
        predicted_rms_mm: p.rms * 1e3,
        predicted_max_mm: p.max * 1e3,
        predicted_measured_rms_mm: p.measured_rms * 1e3,
        std: p
            .std
            .iter()
            .map(|(param, s)| ParameterStd {
                name: param.to_string(),
                std: param_in_units(u, *param, *s),
                unit: if param.is_angle() {
                    u.angle.to_string()
                } else {
                    u.length.to_string()
                },
                identified: identified.contains(param),
            })
            .collect(),
        observability: Observability {
            O1: p.observability[0],
            O2: p.observability[1],
            O3: p.observability[2],
            O4: p.observability[3],
            O5: p.observability[4],
        },
    }
}

impl Plan {
    /// The report of `--json` (docs/file-formats.md §7), of the plan for
    /// the model named `model`.
    pub fn report(&self, model: &str, options: &PlanOptions, u: &Units) -> PlanReport {
        let other = |predicted: &Result<Prediction, Vec<String>>| match predicted {
            Ok(p) => Predicted::Identifies(prediction_report(p, &self.identified, u)),
            Err(missed) => Predicted::Misses {
                identifies: false,
                missed: missed.clone(),
            },
        };
        PlanReport {
            model: model.to_string(),
            predicted: prediction_report(&self.predicted, &self.identified, u),
            poses: self.points.len(),
            rows: self.q.len(),
            both_sides: options.visits == super::Visits::BothSides,
            one_sided: self.one_sided,
            near_singular: self
                .near_singular
                .iter()
                .map(|&(row, conditioning)| NearSingular {
                    row: row + 1,
                    conditioning,
                })
                .collect(),
            noise_mm: options.position_noise * 1e3,
            orientation: options.instrument.orientation(),
            compliance: self
                .predicted
                .compliance
                .iter()
                .map(|&(joint, std)| ComplianceStd {
                    joint: joint + 1,
                    std,
                })
                .collect(),
            compliance_held: self
                .compliance_held
                .iter()
                .map(|(joint, why)| ComplianceHeld {
                    joint: joint + 1,
                    reason: why.clone(),
                })
                .collect(),
            sockets: options.instrument.sockets().map(|plate| SocketsReport {
                sockets: plate
                    .sockets
                    .iter()
                    .enumerate()
                    .map(|(k, s)| SocketRows {
                        name: s.name.clone(),
                        poses: super::sockets::rows_at(&self.socket_of, k),
                    })
                    .collect(),
                distances: plate.distances.len(),
                socket_of: self
                    .socket_of
                    .iter()
                    .map(|&k| plate.sockets[k].name.clone())
                    .collect(),
            }),
            candidates: self.candidates,
            targets: self.targets,
            path: self.path,
            random: other(&self.random),
            criterion: options.criterion.name(),
            compared: ComparedReport {
                criterion: self.compared.criterion.name(),
                predicted: other(&self.compared.predicted),
            },
            identified: self.identified.iter().map(ToString::to_string).collect(),
            held: self
                .held
                .iter()
                .map(|(p, why)| HeldReport {
                    name: p.to_string(),
                    reason: why.clone(),
                })
                .collect(),
            above_base: options.above_base,
            off_axis: self.off_axis.as_ref().map(|o| OffAxisReport {
                distance: u.length_from_si(o.distance),
                distance_mm: o.distance * 1e3,
                tool: o.tool.iter().map(|&x| u.length_from_si(x)).collect(),
                tool_mm: o.tool.iter().map(|&x| x * 1e3).collect(),
                off_axis_mm: OFF_AXIS * 1e3,
                gained: o.gained.iter().map(ToString::to_string).collect(),
                predicted: o
                    .predicted
                    .as_ref()
                    .map(|p| prediction_report(p, &self.identified, u)),
            }),
            units: UnitsReport::from(u),
        }
    }
}

impl PlanReport {
    /// The summary `armcal plan` prints.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        let measured = match (&self.sockets, self.orientation) {
            (Some(s), _) => format!(
                "a ball seated in {}, {} between them",
                plural(s.sockets.len(), "socket"),
                plural(s.distances, "known distance")
            ),
            (None, true) => "full poses".into(),
            (None, false) => "positions".into(),
        };
        let _ = writeln!(
            out,
            "plan: {} of {} ({measured}), chosen from {} for {}; the measurement \
             path {:.3} (joint space, rad and m)",
            plural(self.poses, "pose"),
            self.model,
            plural(self.candidates, "candidate"),
            plural(self.targets, "workspace configuration"),
            self.path
        );
        if !self.near_singular.is_empty() {
            let rows: Vec<String> = self
                .near_singular
                .iter()
                .map(|n| format!("{} ({:.4})", n.row, n.conditioning))
                .collect();
            let _ = writeln!(
                out,
                "warning: {} near a singularity of the arm (its Jacobian's conditioning below {}): row{} {}; the controller may turn some joints fast there",
                if rows.len() == 1 { "a pose" } else { "poses" },
                super::NEAR_SINGULAR,
                if rows.len() == 1 { "" } else { "s" },
                rows.join(", ")
            );
        }
        if self.above_base {
            let _ = writeln!(
                out,
                "the flange and the tool point kept above the robot's base plane: the model \
                 gives no joint limits (--above or --within sets the cell instead)"
            );
        }
        if let Some(s) = &self.sockets {
            let counts: Vec<String> = s
                .sockets
                .iter()
                .map(|s| format!("{} {}", s.name, s.poses))
                .collect();
            let _ = writeln!(
                out,
                "poses a socket: {}; the robot is predicted in the frame the sockets are \
                 estimated in (its base held at nominal){}",
                counts.join(", "),
                if s.distances == 0 {
                    "; no known distance: only the prior on the lengths holds the arm's scale"
                } else {
                    ""
                }
            );
        }
        let p = &self.predicted;
        let _ = writeln!(
            out,
            "predicted at {} mm noise per axis: the calibrated robot off by {:.4} mm RMS over the \
             workspace, {:.4} mm at its worst target ({:.4} mm RMS against new measurements, \
             their noise added), chosen {}; {} random poses: {}; the {} plan of as many: {}",
            crate::report::format::significant(self.noise_mm),
            p.predicted_rms_mm,
            p.predicted_max_mm,
            p.predicted_measured_rms_mm,
            self.criterion,
            self.poses,
            self.random.figures(),
            self.compared.criterion,
            self.compared.predicted.figures(),
        );
        if self.both_sides {
            let _ = writeln!(
                out,
                "each pose measured approached from below and from above in every joint (for \
                 backlash): {} rows, a via row before each; {} poses not from both sides (a \
                 limit or the cell in the way)",
                self.rows, self.one_sided
            );
        }
        for c in &self.compliance {
            let _ = writeln!(
                out,
                "the compliance of joint {} identified with the geometry, predicted standard \
                 error {:.3e} rad/(N·m)",
                c.joint, c.std
            );
        }
        for c in &self.compliance_held {
            let _ = writeln!(
                out,
                "  the compliance of joint {}: no plan identifies it: {}",
                c.joint, c.reason
            );
        }
        let o = &p.observability;
        let _ = writeln!(
            out,
            "observability O1 {:.3e}, O2 {:.3e}, O3 {:.3e}, O4 {:.3e}, O5 {:.3e}; {} parameters \
             identified, {} not (held at nominal, or by the prior):",
            o.O1,
            o.O2,
            o.O3,
            o.O4,
            o.O5,
            self.identified.len(),
            self.held.len()
        );
        for h in &self.held {
            let _ = writeln!(out, "  {}: no plan identifies it: {}", h.name, h.reason);
        }
        if let Some(o) = &self.off_axis {
            let _ = writeln!(
                out,
                "the tool point is {:.1} mm from the last joint's axis: a turn of that joint does \
                 not move it. Measured {:.0} mm off that axis (tool at {:.1}, {:.1}, {:.1} mm, \
                 flange frame), the same poses would identify {}{}",
                o.distance_mm,
                o.off_axis_mm,
                o.tool_mm[0],
                o.tool_mm[1],
                o.tool_mm[2],
                if o.gained.is_empty() {
                    "nothing more".to_string()
                } else {
                    format!("{} too", o.gained.join(", "))
                },
                match &o.predicted {
                    Some(p) => format!(
                        ", and predict that point to {:.4} mm RMS over the workspace, {:.4} mm at \
                         its worst target",
                        p.predicted_rms_mm, p.predicted_max_mm
                    ),
                    None => String::new(),
                }
            );
        }
        out
    }

    /// The HTML page's table of the predicted accuracy: the plan's, and as
    /// many random poses' and the other criterion's where they identify
    /// what the plan does.
    fn html_table(&self) -> String {
        let mut s = String::new();
        let row = |s: &mut String, what: &str, p: &PredictionReport| {
            let _ = write!(
                s,
                "<tr><td>{what}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td></tr>",
                p.predicted_rms_mm, p.predicted_max_mm, p.predicted_measured_rms_mm
            );
        };
        s.push_str("<h2>Predicted accuracy</h2><table><tr><th>poses</th><th>calibrated robot, RMS over the workspace [mm]</th><th>at the worst target [mm]</th><th>against new measurements, RMS [mm]</th></tr>");
        row(&mut s, "planned", &self.predicted);
        if let Predicted::Identifies(p) = &self.random {
            row(&mut s, "as many random", p);
        }
        if let Predicted::Identifies(p) = &self.compared.predicted {
            row(&mut s, &format!("as many, {}", self.compared.criterion), p);
        }
        s
    }
}

impl Predicted {
    /// Another set of poses' predicted figures for the summary (RMS, worst,
    /// RMS against new measurements, mm), or what it does not identify.
    fn figures(&self) -> String {
        match self {
            Self::Identifies(p) => format!(
                "{:.4} mm, {:.4} mm ({:.4} mm)",
                p.predicted_rms_mm, p.predicted_max_mm, p.predicted_measured_rms_mm
            ),
            Self::Misses { missed, .. } => format!("do not identify {}", missed.join(", ")),
        }
    }
}

impl Plan {
    /// The plan file of `--out`: the joints CSV of `docs/file-formats.md` §4
    /// (the model's units of `cal`), the rows in measurement order. A socket
    /// plan's is a session file of §3 besides: a `point` column naming each
    /// row's socket and the known distances, so that the joints reached
    /// written over the planned ones make the session to identify from.
    pub fn csv(&self, comment: &str, cal: &Calibration, options: &PlanOptions) -> String {
        let joints = compensate::joints_csv(comment, cal, self.q.iter().cloned());
        let Some(plate) = options.instrument.sockets() else {
            return joints;
        };
        let u = &cal.units;
        let mut out = String::new();
        let mut rows = self.socket_of.iter();
        for (i, line) in joints.lines().enumerate() {
            let _ = match i {
                0 => writeln!(
                    out,
                    "{line}; seat the ball in the row's socket at about these joints and write \
                     the joints it is seated at over them"
                ),
                1 => writeln!(out, "{line},point"),
                _ => writeln!(
                    out,
                    "{line},{}",
                    rows.next().map_or("", |&k| plate.sockets[k].name.as_str())
                ),
            };
        }
        for d in &plate.distances {
            let _ = writeln!(
                out,
                "distance,{},{},{},{}",
                plate.sockets[d.points[0]].name,
                plate.sockets[d.points[1]].name,
                u.length_from_si(d.length),
                u.length_from_si(d.std)
            );
        }
        out
    }

    /// The HTML page of `--html`: the summary and the figures of its
    /// `report`, then where in the workspace the calibration from the plan
    /// is predicted to miss most (the plan's targets and poses).
    pub fn html(&self, report: &PlanReport, u: &Units) -> String {
        use crate::report::html::{html_escape, page_head};
        use crate::report::svg::{Point, Scatter, Series};
        let mm = |x: f64| x * 1e3;
        let length = |x: f64| u.length_from_si(x);
        let view = |title: &str, axes: (usize, usize), names: (&str, &str)| {
            let targets = Series {
                name: "workspace target".into(),
                colour: "#1f77b4",
                radius: 2.2,
                points: self
                    .target_points
                    .iter()
                    .zip(&self.predicted.per_target)
                    .map(|(p, e)| Point {
                        x: length(p[axes.0]),
                        y: length(p[axes.1]),
                        value: Some(mm(*e)),
                    })
                    .collect(),
            };
            let planned = Series {
                name: "planned pose".into(),
                colour: "#000000",
                radius: 4.0,
                points: self
                    .points
                    .iter()
                    .map(|p| Point {
                        x: length(p[axes.0]),
                        y: length(p[axes.1]),
                        value: None,
                    })
                    .collect(),
            };
            Scatter {
                title: title.into(),
                x_label: format!("{} [{}]", names.0, u.length),
                y_label: format!("{} [{}]", names.1, u.length),
                value_label: "error [mm]".into(),
                series: vec![targets, planned],
                equal_aspect: true,
                y_from_zero: false,
            }
            .svg(560.0, 460.0)
        };
        let mut s = String::new();
        let _ = write!(
            s,
            "{head}<pre>{summary}</pre>{table}",
            head = page_head("plan", &report.model),
            summary = html_escape(&report.summary()),
            table = report.html_table(),
        );
        let _ = write!(
            s,
            "</table><h2>Where the calibration will miss most</h2><p>Each workspace target's nominal tool point, coloured by the calibrated robot's predicted RMS error there; the planned poses' tool points in black (measurement frame).</p><div class=\"plots\">{}{}</div></body></html>",
            view("seen from above", (0, 1), ("x", "y")),
            view("seen from the side", (0, 2), ("x", "z"))
        );
        s
    }
}
