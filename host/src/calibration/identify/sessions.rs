//! Several sessions in one calibration: each session left out in turn
//! ([`held_out_by_session`]), and the sessions as the reports give them —
//! each session's rows and residual RMS, where its own frames sit against
//! the first session's (the base frame's shift and turn, the tool's shift)
//! and its held-out figure, for the summary `identify` and `diagnose` print
//! and their JSON. The calibration file holds the first session's
//! registration ([`crate::session::registration`]), so `armcal predict`
//! with it gives the first session's figure; the reports say so. SI inside;
//! the reports in the model's units (`mm`-suffixed fields excepted).
//!
//! ## Leaving sessions out
//! A session left out is predicted as a new session of the calibrated robot
//! would be: the robot calibrated on the other sessions as the command
//! calibrates, then the left-out session's own frames (those that are each
//! session's own, [`crate::session::registration::FrameSharing`]) fitted to
//! its rows with the robot held ([`register_session`]), and its residual
//! RMS taken. It is what the robot keeps from one session to another: a
//! session far above the others' figures moved (the robot drifted between
//! days) or carries what the model does not (a load the others did not).
//! The registration is fitted to the rows it is judged on, 9 to 12 of them
//! per session: the figure is the robot's, not the instrument's.

use std::fmt::Write as _;

use armcal_shared::Frame;

use crate::calibration::fit::{FullError, FullFit, FullOptions, Status, register_session};
use crate::calibration::validation::stats::f_quantile;
use crate::report::format::{length_and_mm, length_and_mm_of};
use crate::report::units::{FrameReport, UnitsReport};
use crate::session::channel::Channel;
use crate::session::measurements::Measurements;
use crate::session::observation::Observation;
use crate::session::observation::session_count;
use crate::session::registration::FrameSharing;
use crate::session::registration::Sharing;
use crate::session::rows::Rows;
use armcal_shared::Robot;
use armcal_shared::effects::Effect;
use armcal_shared::units::Units;

/// One session left out (see the module header).
#[derive(Clone, Debug, PartialEq)]
pub enum SessionHeldOut {
    /// Predicted: the others calibrated, its own frames registered.
    Predicted(LeftOut),
    /// Not computed: the other sessions alone cannot calibrate the robot
    /// (too few equations: a short session beside a long one), or its
    /// frames could not be registered; `reason` says why. The calibration
    /// of all the sessions is unaffected.
    NotComputed {
        /// Why, as the fit that failed says it.
        reason: String,
    },
}

impl SessionHeldOut {
    /// Its figure, when computed.
    pub fn figure(&self) -> Option<&LeftOut> {
        match self {
            Self::Predicted(f) => Some(f),
            Self::NotComputed { .. } => None,
        }
    }
}

/// A session's residual once its own frames are registered to the robot
/// calibrated on the others, and how it compares with the others' noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeftOut {
    /// Position residual RMS (3-D distance), m.
    pub position_rms: f64,
    /// Orientation residual RMS, rad, when the session measures orientations.
    pub orientation_rms: Option<f64>,
    /// The test of its residual against the noise the others fit to
    /// ([`Reconciliation`]); `None` where the others' fit gives no noise
    /// (the nominal model kept) or leaves no redundancy.
    pub reconciliation: Option<Reconciliation>,
}

/// The family-wise level of the test of every session against the others'
/// noise: at most a 1 % chance that a session of the same robot, in its own
/// frames as stated, is named (Bonferroni over the sessions).
pub const RECONCILE_ALPHA: f64 = 0.01;

/// Whether a session left out reconciles with the others: the position
/// residual it leaves against the noise the others fit to.
///
/// The others' fit leaves the position noise `s²` per coordinate (its
/// variance factor at the noise it weighed position rows by) with `R`
/// degrees of freedom (its redundancy) and `p = m − R` parameters' worth
/// spent of its `m` equations. A session of the same robot, left out, leaves
/// the sum of squares `S` (3 per pose) over `ν = 3n − u` degrees of freedom
/// (`u` its own frames' position unknowns: base 6, tool point 3), each
/// inflated by the others' estimation error, on average by `c = 1 + p/R` (a
/// new row's prediction variance from the same design). So
/// `F = (S/ν) / (c s²)` follows `F(ν, R)` near enough, and a session whose
/// `F` exceeds the `1 − α/K` quantile ([`RECONCILE_ALPHA`], `K` sessions)
/// does not reconcile: its frames are not what the flags say (a tool taken
/// as shared that was remounted), or it is not the robot the others are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reconciliation {
    /// The others' position residual RMS (3-D distance), m.
    pub others_rms: f64,
    /// The statistic `F`.
    pub f: f64,
    /// Its `1 − α/K` quantile of `F(ν, R)`.
    pub threshold: f64,
    /// `ν`.
    pub dof: f64,
    /// `R`.
    pub others_dof: f64,
}

impl Reconciliation {
    /// Whether the session reconciles with the others (`F` within its
    /// threshold).
    pub fn reconciled(&self) -> bool {
        self.f <= self.threshold
    }
}

/// The robot a command calibrates from rows, with its effects and, when it
/// fitted, the noise it left ([`TrainingNoise`]).
#[derive(Clone, Debug)]
pub struct Trained {
    /// The calibrated robot (the first session's frames).
    pub robot: Robot<f64>,
    /// Its effects.
    pub effects: Vec<Effect<f64>>,
    /// The noise its fit left; `None` for a model not fitted (nominal).
    pub noise: Option<TrainingNoise>,
}

/// The position noise a calibration of the others left (see
/// [`Reconciliation`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainingNoise {
    /// Its position residual RMS (3-D distance), m.
    pub position_rms: f64,
    /// `s²`: the variance of one position coordinate, m².
    pub variance: f64,
    /// `R`: its redundancy.
    pub redundancy: f64,
    /// `p`: the equations its parameters spent.
    pub spent: f64,
}

impl Trained {
    /// The robot, effects and noise of `fit`.
    pub fn of(fit: &FullFit) -> Self {
        Self {
            robot: fit.calibrated.clone(),
            effects: fit.fitted_effects(),
            noise: Some(TrainingNoise {
                position_rms: fit.position_rms,
                variance: fit.variance_factor * fit.noise_of(Channel::Position).powi(2),
                redundancy: fit.redundancy,
                spent: fit.equations as f64 - fit.redundancy,
            }),
        }
    }
}

/// The robot a command calibrates from rows (the sessions numbered from 0).
pub type Calibrate<'a> = dyn Fn(&[Observation]) -> Result<Trained, FullError> + 'a;

/// Each session of `data` left out in turn (see the module header): the
/// robot `calibrate` makes of the others, the left-out session's frames
/// that `sharing` gives it registered to its rows (with the noise of
/// `options`), its residual tested against the others' noise
/// ([`Reconciliation`]). Empty for one session. A session whose others
/// cannot be calibrated alone, or whose frames cannot be registered, has
/// no figure ([`SessionHeldOut::NotComputed`]): it never fails the whole.
pub fn held_out_by_session<'a>(
    data: impl Into<Rows<'a>>,
    calibrate: &Calibrate<'_>,
    sharing: FrameSharing,
    options: &FullOptions,
) -> Vec<SessionHeldOut> {
    let data = data.into();
    let count = session_count(data);
    if count < 2 {
        return Vec::new();
    }
    (0..count)
        .map(|k| {
            let training: Vec<Observation> = data
                .iter()
                .filter(|o| o.session != k)
                .map(|o| Observation {
                    session: o.session - usize::from(o.session > k),
                    ..o.clone()
                })
                .collect();
            let left = data.positions_of((0..data.len()).filter(|&i| data[i].session == k));
            let left_out = Rows::picked(data.all(), &left);
            let figure = calibrate(&training).and_then(|trained| {
                register_session(&trained.robot, &trained.effects, left_out, sharing, options)
                    .map(|r| (trained.noise, r.position_rms, r.orientation_rms))
            });
            match figure {
                Ok((noise, position_rms, orientation)) => SessionHeldOut::Predicted(LeftOut {
                    position_rms,
                    orientation_rms: left_out
                        .iter()
                        .any(|o| o.orientation.is_some())
                        .then_some(orientation),
                    reconciliation: noise
                        .and_then(|n| reconcile(&n, position_rms, left_out, sharing, count)),
                }),
                Err(e) => SessionHeldOut::NotComputed {
                    reason: e.to_string(),
                },
            }
        })
        .collect()
}

/// The test of [`Reconciliation`] for the session `rows` leaving
/// `position_rms` (m) about the others' fit that left `noise`, its own
/// frames as `sharing` says, one of `sessions`; `None` when the others'
/// fit or the session leaves no degrees of freedom.
fn reconcile(
    noise: &TrainingNoise,
    position_rms: f64,
    rows: Rows<'_>,
    sharing: FrameSharing,
    sessions: usize,
) -> Option<Reconciliation> {
    let positions = rows
        .iter()
        .filter(|o| o.channel() == Channel::Position)
        .count() as f64;
    let own = 6.0 * f64::from(u8::from(sharing.base == Sharing::PerSession))
        + 3.0 * f64::from(u8::from(sharing.tool == Sharing::PerSession));
    let dof = 3.0 * positions - own;
    if dof < 1.0 || noise.redundancy < 1.0 || noise.variance <= 0.0 || !position_rms.is_finite() {
        return None;
    }
    let inflation = 1.0 + noise.spent / noise.redundancy;
    let squares = positions * position_rms.powi(2);
    let f = (squares / dof) / (inflation * noise.variance);
    let threshold = f_quantile(
        1.0 - RECONCILE_ALPHA / sessions as f64,
        dof,
        noise.redundancy,
    );
    Some(Reconciliation {
        others_rms: noise.position_rms,
        f,
        threshold,
        dof,
        others_dof: noise.redundancy,
    })
}

/// The warnings on sessions left out that do not reconcile with the others
/// ([`Reconciliation`]), one a session, each naming its file, its figure
/// and the others', and the likely cause as `sharing` makes it (`units` for
/// the figures).
pub fn warnings(
    held_out: &[SessionHeldOut],
    data: &Measurements,
    sharing: FrameSharing,
    u: &Units,
) -> Vec<String> {
    let cause = match (sharing.base, sharing.tool) {
        (Sharing::Shared, Sharing::Shared) => {
            "a different tool than --same-tool says, an instrument moved though --same-base \
             says not, another robot, or the robot changed between the sessions?"
        }
        (Sharing::PerSession, Sharing::Shared) => {
            "a different tool than --same-tool says? another robot, or the robot changed \
             between the sessions?"
        }
        (Sharing::Shared, Sharing::PerSession) => {
            "an instrument moved though --same-base says not? another robot, or the robot \
             changed between the sessions?"
        }
        (Sharing::PerSession, Sharing::PerSession) => {
            "another robot, or the robot changed between the sessions (a repair, a load or \
             a temperature the others did not have)?"
        }
    };
    held_out
        .iter()
        .enumerate()
        .filter_map(|(k, h)| {
            let figure = h.figure()?;
            let r = figure.reconciliation.filter(|r| !r.reconciled())?;
            let file = data.sessions.get(k).map_or("?", String::as_str);
            Some(format!(
                "session {file}: left out, its rows miss the robot the other sessions calibrate \
                 by {} RMS (its own frames registered), {:.1}× the {} RMS the others fit to: \
                 F = {:.1} above {:.2}, the {} quantile of F({:.0}, {:.0}); it does not reconcile \
                 with them: {cause}",
                length_and_mm(u, figure.position_rms),
                figure.position_rms / r.others_rms,
                length_and_mm(u, r.others_rms),
                r.f,
                r.threshold,
                quantile_name(held_out.len()),
                r.dof,
                r.others_dof
            ))
        })
        .collect()
}

/// The frames `fit`'s sessions share, as its registrations hold them.
pub fn sharing_of(fit: &FullFit) -> FrameSharing {
    let (base, tool) = fit.registrations.own_frames(1);
    FrameSharing::stated(!base, !tool)
}

/// `1 − 1 %/3` for three sessions.
fn quantile_name(sessions: usize) -> String {
    format!("1 − {:.0} %/{sessions}", RECONCILE_ALPHA * 100.0)
}

/// How far frame `b` sits from frame `a`: the shift (m) and the turn (rad)
/// of `a⁻¹ b`.
fn moved(a: &Frame<f64>, b: &Frame<f64>) -> (f64, f64) {
    let d = a.isometry().inverse() * b.isometry();
    (d.translation.vector.norm(), d.rotation.angle())
}

/// The summary's lines on the sessions (their [`reports`], in units `u`),
/// when there are several: which frames are each session's own, which
/// registration the file holds, and each session's poses, residual and
/// frames.
pub fn summary(sessions: &[SessionReport], u: &UnitsReport) -> String {
    let mut out = String::new();
    let Some(second) = sessions.get(1) else {
        return out;
    };
    let frames = match (second.base.is_some(), second.tool.is_some()) {
        (true, true) => "each with its own base frame and tool",
        (true, false) => "each with its own base frame, one tool (--same-tool)",
        (false, true) => "one base frame (--same-base), each with its own tool",
        (false, false) => "one base frame and one tool (--same-base --same-tool)",
    };
    let _ = writeln!(
        out,
        "{} sessions, {frames}; the calibration written holds the first session's registration \
         ({}): `armcal predict` with it gives that session's figure",
        sessions.len(),
        sessions[0].file
    );
    let length = |x: f64, mm: f64| length_and_mm_of(x, &u.length, mm);
    for (k, s) in sessions.iter().enumerate() {
        let _ = write!(
            out,
            "  session {} {}: {}, position RMS {}",
            k + 1,
            s.file,
            crate::session::measurements::plural(s.poses, "pose"),
            length(s.position_rms, s.position_rms_mm)
        );
        if let Some(o) = s.orientation_rms {
            let _ = write!(out, ", orientation RMS {o:.6} {}", u.angle);
        }
        if let (Some(h), Some(mm)) = (s.held_out_rms, s.held_out_rms_mm) {
            let _ = write!(
                out,
                "; left out {} (the others calibrated, its own frames registered)",
                length(h, mm)
            );
            if s.reconciled == Some(false) {
                out.push_str(", NOT reconciled with the others (see the warning)");
            }
        }
        if let Some(reason) = &s.held_out_not_computed {
            let _ = write!(
                out,
                "; left out: not computed, the others alone cannot calibrate the robot \
                 ({reason})"
            );
        }
        if let Some(m) = &s.from_first {
            let _ = write!(
                out,
                "; base {} and {:.6} {} from the first's, tool {} from the first's",
                length(m.base_shift, m.base_shift_mm),
                m.base_turn,
                u.angle,
                length(m.tool_shift, m.tool_shift_mm)
            );
        }
        if !s.held_frames.is_empty() {
            let _ = write!(
                out,
                "; its {} held at their start (its rows do not determine them)",
                s.held_frames.join(", ")
            );
        }
        let _ = writeln!(out);
    }
    out
}

/// The HTML page's section on the sessions (their [`reports`]), when there
/// are several: a table of each session's file, poses, residual, left-out
/// figure and frames' shift from the first's; empty for one session.
pub fn html(sessions: &[SessionReport]) -> String {
    use crate::report::html::html_escape;
    let mut s = String::new();
    if sessions.len() < 2 {
        return s;
    }
    let _ = write!(
        s,
        "<h2>Sessions</h2><p>{} sessions of one robot: one geometry and one set of effects, each session \
         in its own frames. The calibration written holds the first session's registration \
         (<b>{}</b>): <code>armcal predict</code> with it gives that session's figure. Left out: the \
         other sessions calibrated, the session's own frames registered to its rows.</p><table><tr>\
         <th>session</th><th>poses</th><th>RMS [mm]</th><th>left out [mm]</th><th>base from the \
         first's [mm, mrad]</th><th>tool from the first's [mm]</th></tr>",
        sessions.len(),
        html_escape(&sessions[0].file)
    );
    for (k, session) in sessions.iter().enumerate() {
        let left_out = session
            .held_out_rms_mm
            .map_or("–".into(), |h| format!("{h:.4}"));
        let (shift, turn, tool) = session.from_first.as_ref().map_or((0.0, 0.0, 0.0), |m| {
            (m.base_shift_mm, m.base_turn_mrad, m.tool_shift_mm)
        });
        let _ = write!(
            s,
            "<tr><td>{} {}</td><td>{}</td><td>{:.4}</td><td>{left_out}</td><td>{shift:.3}, {turn:.3}</td><td>{tool:.3}</td></tr>",
            k + 1,
            html_escape(&session.file),
            session.poses,
            session.position_rms_mm,
        );
    }
    s.push_str("</table>");
    s
}

/// The reports' `sessions` (docs/file-formats.md §6): each session's rows,
/// residual and held-out figures, and its own frames against the first
/// session's, in the model's units; `None` for one session.
pub fn reports(
    fit: &FullFit,
    held_out: &[SessionHeldOut],
    data: &Measurements,
    u: &Units,
) -> Option<Vec<SessionReport>> {
    if fit.sessions.len() < 2 {
        return None;
    }
    let frame = |f: &Frame<f64>| FrameReport::of(f, u);
    let sessions = fit
        .sessions
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let robot = fit.robot_of(k);
            // The first session's frames are the model's: its own.
            let (base, tool) = fit.registrations.own_frames(k);
            let (base, tool) = (k == 0 || base, k == 0 || tool);
            let left_out = held_out.get(k).and_then(SessionHeldOut::figure);
            let reconciliation = left_out.and_then(|h| h.reconciliation);
            let held_out_not_computed = match held_out.get(k) {
                Some(SessionHeldOut::NotComputed { reason }) => Some(reason.clone()),
                _ => None,
            };
            let from_first = (k > 0).then(|| {
                let first = fit.robot_of(0);
                let (shift, turn) = moved(&first.base, &robot.base);
                let tool = (robot.tool.xyz - first.tool.xyz).norm();
                MovedReport {
                    base_shift: u.length_from_si(shift),
                    base_shift_mm: shift * 1e3,
                    base_turn: u.angle_from_si(turn),
                    base_turn_mrad: turn * 1e3,
                    tool_shift: u.length_from_si(tool),
                    tool_shift_mm: tool * 1e3,
                }
            });
            let held_frames = s
                .frames
                .iter()
                .filter(|(_, _, status)| matches!(status, Status::Fixed { .. }))
                .map(|(p, _, _)| p.to_string())
                .collect();
            SessionReport {
                file: data.sessions.get(k).map_or("?", String::as_str).to_string(),
                from_first,
                held_frames,
                held_out_not_computed,
                reconciled: reconciliation.map(|r| r.reconciled()),
                reconciliation: reconciliation.map(|r| ReconciliationReport {
                    others_rms_mm: r.others_rms * 1e3,
                    f: r.f,
                    threshold: r.threshold,
                    dof: r.dof,
                    others_dof: r.others_dof,
                    alpha: RECONCILE_ALPHA,
                }),
                held_out_rms: left_out.map(|h| u.length_from_si(h.position_rms)),
                held_out_rms_mm: left_out.map(|h| h.position_rms * 1e3),
                held_out_orientation_rms: left_out
                    .and_then(|h| h.orientation_rms)
                    .map(|o| u.angle_from_si(o)),
                poses: s.poses,
                position_rms: u.length_from_si(s.position_rms),
                position_rms_mm: s.position_rms * 1e3,
                orientation_rms: s.orientation_rms.map(|o| u.angle_from_si(o)),
                base: base.then(|| frame(&robot.base)),
                tool: tool.then(|| frame(&robot.tool)),
                written: k == 0,
            }
        })
        .collect();
    Some(sessions)
}

/// One session as the reports give it ([`reports`]), lengths and angles in
/// the model's units (`mm`-suffixed fields excepted).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SessionReport {
    /// Its file.
    pub file: String,
    /// Its base and tool against the first session's (`null` for the first).
    pub from_first: Option<MovedReport>,
    /// Its own frames' parameters its rows do not determine, held at their
    /// start.
    pub held_frames: Vec<String>,
    /// Why it was not left out, when it was not.
    pub held_out_not_computed: Option<String>,
    /// Whether its left-out figure agrees with the others' residuals.
    pub reconciled: Option<bool>,
    /// The test of that agreement.
    pub reconciliation: Option<ReconciliationReport>,
    /// Its RMS position error left out.
    pub held_out_rms: Option<f64>,
    /// The same, mm.
    pub held_out_rms_mm: Option<f64>,
    /// Its RMS orientation error left out.
    pub held_out_orientation_rms: Option<f64>,
    /// Its poses.
    pub poses: usize,
    /// Its RMS position residual in the fit.
    pub position_rms: f64,
    /// The same, mm.
    pub position_rms_mm: f64,
    /// Its RMS orientation residual in the fit.
    pub orientation_rms: Option<f64>,
    /// Its own base frame, when it has one.
    pub base: Option<FrameReport>,
    /// Its own tool, when it has one.
    pub tool: Option<FrameReport>,
    /// Whether the calibration written holds its registration (the first).
    pub written: bool,
}

/// How far a session's frames sit from the first session's.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MovedReport {
    /// The base frame's shift, the model's length unit.
    pub base_shift: f64,
    /// The same, mm.
    pub base_shift_mm: f64,
    /// The base frame's turn, the model's angle unit.
    pub base_turn: f64,
    /// The same, mrad.
    pub base_turn_mrad: f64,
    /// The tool point's shift, the model's length unit.
    pub tool_shift: f64,
    /// The same, mm.
    pub tool_shift_mm: f64,
}

/// The F test of a left-out session against the others' residuals.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ReconciliationReport {
    /// The others' residual RMS, mm.
    pub others_rms_mm: f64,
    /// The statistic.
    pub f: f64,
    /// Its threshold at `alpha`.
    pub threshold: f64,
    /// The left-out session's degrees of freedom.
    pub dof: f64,
    /// The others'.
    pub others_dof: f64,
    /// The test's level.
    pub alpha: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::fit::FitRequest;
    use crate::calibration::simulate::{measure, random_configurations, rng};
    use crate::io::model_file::load_model;

    /// Rows of `truths` (each a session's true robot and its positions),
    /// measured at random configurations of `nominal` with σ = 20 µm, each
    /// marked with its session.
    fn measured(
        nominal: &Robot<f64>,
        truths: &[(Robot<f64>, usize)],
        seed: u64,
    ) -> Vec<Observation> {
        let mut r = rng(seed);
        let mut rows = Vec::new();
        for (session, (truth, poses)) in truths.iter().enumerate() {
            let q = random_configurations(nominal, *poses, &mut r);
            rows.extend(
                measure(truth, &q, 20e-6, None, &mut r)
                    .into_iter()
                    .map(|o| Observation { session, ..o }),
            );
        }
        rows
    }

    /// Each session of `rows` left out, `nominal` calibrated as `FitRequest::run`
    /// calibrates it, each session in its own frames.
    fn each_left_out(nominal: &Robot<f64>, rows: &[Observation]) -> Vec<SessionHeldOut> {
        let options = FullOptions::default();
        let calibrate = |rows: &[Observation]| {
            FitRequest::new(nominal, rows, &options)
                .run()
                .map(|f| Trained::of(&f))
        };
        held_out_by_session(rows, &calibrate, FrameSharing::default(), &options)
    }

    /// Each of four sessions of a UR5e (60 positions each, σ = 20 µm, the
    /// tracker moved between them) left out in turn, predicted by the robot
    /// the others make; in the last, when `drift`, the upper arm is 0.5 mm
    /// shorter (it drifted, or was repaired, between days). Each session's
    /// figure in mm and whether it reconciles with the others.
    fn left_out(drift: bool) -> Vec<(f64, bool)> {
        let nominal = load_model("ur5e").unwrap().robot;
        let truths: Vec<(Robot<f64>, usize)> = (0..4)
            .map(|session| {
                let mut truth = nominal.clone();
                truth.base.xyz.x += 0.4 * session as f64;
                truth.base.rpy.z += 0.7 * session as f64;
                if drift && session == 3 {
                    truth.links[1].a -= 0.5e-3;
                }
                (truth, 60)
            })
            .collect();
        each_left_out(&nominal, &measured(&nominal, &truths, 5))
            .iter()
            .map(|h| {
                let figure = h.figure().unwrap();
                (
                    figure.position_rms * 1e3,
                    figure.reconciliation.unwrap().reconciled(),
                )
            })
            .collect()
    }

    /// The same robot in every session: each left out is predicted to the
    /// noise (3-D RMS near σ√3 = 35 µm) and reconciles with the others (the
    /// test's level is 1 % over the four). A robot that changed in one
    /// session: that session's figure stands out, far above the noise and
    /// well above the others' (which the changed session's rows pull too),
    /// and it alone does not reconcile.
    #[test]
    fn leaving_sessions_out_shows_a_robot_that_changed_between_them() {
        let noise = 20e-3 * 3f64.sqrt();
        let same = left_out(false);
        eprintln!("the same robot, left out: {same:?} mm");
        assert!(
            same.iter().all(|(mm, ok)| *mm < 1.5 * noise && *ok),
            "{same:?}"
        );
        let changed = left_out(true);
        eprintln!("the last session's robot changed, left out: {changed:?} mm");
        let others = changed[..3].iter().map(|c| c.0).fold(0.0, f64::max);
        assert!(
            changed[3].0 > 5.0 * noise && changed[3].0 > 1.5 * others,
            "{changed:?}"
        );
        assert!(!changed[3].1, "{changed:?}");
        assert!(changed[..3].iter().all(|c| c.1), "{changed:?}");
    }

    /// A short session (4 positions) beside a long one (50): left out, the
    /// long one leaves the robot to the short one's 12 equations, fewer than
    /// its parameters: that figure is not computed, with the fit's reason,
    /// and the short session's own figure is.
    #[test]
    fn a_figure_left_out_that_cannot_be_computed_is_skipped() {
        let nominal = load_model("ur5e").unwrap().robot;
        let mut moved = nominal.clone();
        moved.base.xyz.y += 0.3;
        let rows = measured(&nominal, &[(nominal.clone(), 50), (moved, 4)], 8);
        let held = each_left_out(&nominal, &rows);
        match &held[0] {
            SessionHeldOut::NotComputed { reason } => {
                assert!(reason.contains("12 equations"), "{reason}")
            }
            other => panic!("{other:?}"),
        }
        assert!(held[1].figure().is_some(), "{held:?}");
    }
}
