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
use serde_json::json;

use super::full::{
    FrameSharing, FullError, FullFit, FullOptions, Observation, Status, register_session,
};
use super::summary::length_and_mm;
use crate::io::measurements::Measurements;
use crate::io::model_file::Units;
use crate::session::measurements::session_count;
use armcal_shared::Robot;
use armcal_shared::effects::Effect;

/// One session left out: its residual RMS once its own frames are
/// registered to the robot calibrated on the others.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SessionHeldOut {
    /// Position residual RMS (3-D distance), m.
    pub position_rms: f64,
    /// Orientation residual RMS, rad, when the session measures orientations.
    pub orientation_rms: Option<f64>,
}

/// The robot a command calibrates from rows (the sessions numbered from 0),
/// with its effects.
pub type Calibrate<'a> =
    dyn Fn(&[Observation]) -> Result<(Robot<f64>, Vec<Effect<f64>>), FullError> + 'a;

/// Each session of `data` left out in turn (see the module header): the
/// robot `calibrate` makes of the others, the left-out session's frames
/// that `sharing` gives it registered to its rows (with the noise of
/// `options`). Empty for one session.
pub fn held_out_by_session(
    data: &[Observation],
    calibrate: &Calibrate<'_>,
    sharing: FrameSharing,
    options: &FullOptions,
) -> Result<Vec<SessionHeldOut>, FullError> {
    let count = session_count(data);
    if count < 2 {
        return Ok(Vec::new());
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
            let left_out: Vec<Observation> =
                data.iter().filter(|o| o.session == k).cloned().collect();
            let (robot, effects) = calibrate(&training)?;
            let (_, position, orientation) =
                register_session(&robot, &effects, &left_out, sharing, options)?;
            Ok(SessionHeldOut {
                position_rms: position,
                orientation_rms: left_out
                    .iter()
                    .any(|o| o.orientation.is_some())
                    .then_some(orientation),
            })
        })
        .collect()
}

/// How far frame `b` sits from frame `a`: the shift (m) and the turn (rad)
/// of `a⁻¹ b`.
fn moved(a: &Frame<f64>, b: &Frame<f64>) -> (f64, f64) {
    let d = a.isometry().inverse() * b.isometry();
    (d.translation.vector.norm(), d.rotation.angle())
}

/// The summary's lines on the sessions, when `data` has several: which
/// frames are each session's own, which registration the file holds, and
/// each session's poses, residual and frames.
pub fn summary(
    fit: &FullFit,
    held_out: &[SessionHeldOut],
    data: &Measurements,
    u: &Units,
) -> String {
    let mut out = String::new();
    if fit.sessions.len() < 2 {
        return out;
    }
    let frames = match fit.registrations.own_frames(1) {
        (true, true) => "each with its own base frame and tool",
        (true, false) => "each with its own base frame, one tool (--same-tool)",
        (false, true) => "one base frame (--same-base), each with its own tool",
        (false, false) => "one base frame and one tool (--same-base --same-tool)",
    };
    let first = data
        .sessions
        .first()
        .map_or(data.file.as_str(), String::as_str);
    let _ = writeln!(
        out,
        "{} sessions, {frames}; the calibration written holds the first session's registration \
         ({first}): `armcal predict` with it gives that session's figure",
        fit.sessions.len()
    );
    let length = |x: f64| length_and_mm(u, x);
    for (k, s) in fit.sessions.iter().enumerate() {
        let file = data.sessions.get(k).map_or("?", String::as_str);
        let _ = write!(
            out,
            "  session {} {file}: {}, position RMS {}",
            k + 1,
            crate::session::measurements::plural(s.poses, "pose"),
            length(s.position_rms)
        );
        if let Some(o) = s.orientation_rms {
            let _ = write!(
                out,
                ", orientation RMS {:.6} {}",
                u.angle_from_si(o),
                u.angle
            );
        }
        if let Some(h) = held_out.get(k) {
            let _ = write!(
                out,
                "; left out {} (the others calibrated, its own frames registered)",
                length(h.position_rms)
            );
        }
        if k > 0 {
            let (a, b) = (fit.robot_of(0), fit.robot_of(k));
            let (shift, turn) = moved(&a.base, &b.base);
            let _ = write!(
                out,
                "; base {} and {:.6} {} from the first's, tool {} from the first's",
                length(shift),
                u.angle_from_si(turn),
                u.angle,
                length((b.tool.xyz - a.tool.xyz).norm())
            );
        }
        let held: Vec<String> = s
            .frames
            .iter()
            .filter(|(_, _, status)| matches!(status, Status::Fixed { .. }))
            .map(|(p, _, _)| p.to_string())
            .collect();
        if !held.is_empty() {
            let _ = write!(
                out,
                "; its {} held at their start (its rows do not determine them)",
                held.join(", ")
            );
        }
        let _ = writeln!(out);
    }
    out
}

/// The HTML page's section on the sessions, when `data` has several: a
/// table of each session's file, poses, residual, left-out figure and
/// frames' shift from the first's; empty for one session.
pub fn html(fit: &FullFit, held_out: &[SessionHeldOut], data: &Measurements) -> String {
    use crate::calibration::report::html_escape;
    let mut s = String::new();
    if fit.sessions.len() < 2 {
        return s;
    }
    let first = data.sessions.first().map_or("", String::as_str);
    let _ = write!(
        s,
        "<h2>Sessions</h2><p>{} sessions of one robot: one geometry and one set of effects, each session \
         in its own frames. The calibration written holds the first session's registration \
         (<b>{}</b>): <code>armcal predict</code> with it gives that session's figure. Left out: the \
         other sessions calibrated, the session's own frames registered to its rows.</p><table><tr>\
         <th>session</th><th>poses</th><th>RMS [mm]</th><th>left out [mm]</th><th>base from the \
         first's [mm, mrad]</th><th>tool from the first's [mm]</th></tr>",
        fit.sessions.len(),
        html_escape(first)
    );
    let first_robot = fit.robot_of(0);
    for (k, session) in fit.sessions.iter().enumerate() {
        let robot = fit.robot_of(k);
        let (shift, turn) = moved(&first_robot.base, &robot.base);
        let left_out = held_out
            .get(k)
            .map_or("–".into(), |h| format!("{:.4}", h.position_rms * 1e3));
        let _ = write!(
            s,
            "<tr><td>{} {}</td><td>{}</td><td>{:.4}</td><td>{left_out}</td><td>{:.3}, {:.3}</td><td>{:.3}</td></tr>",
            k + 1,
            html_escape(data.sessions.get(k).map_or("?", String::as_str)),
            session.poses,
            session.position_rms * 1e3,
            shift * 1e3,
            turn * 1e3,
            (robot.tool.xyz - first_robot.tool.xyz).norm() * 1e3
        );
    }
    s.push_str("</table>");
    s
}

/// The JSON's `sessions`, when `data` has several: each session's file,
/// poses, residual RMS and own frames (`null` where it shares the first's;
/// x, y, z in the model's length unit, roll, pitch, yaw in its angle unit).
pub fn json(
    fit: &FullFit,
    held_out: &[SessionHeldOut],
    data: &Measurements,
    u: &Units,
) -> Option<serde_json::Value> {
    if fit.sessions.len() < 2 {
        return None;
    }
    let frame = |f: &Frame<f64>| {
        json!({
            "xyz": f.xyz.iter().map(|x| u.length_from_si(*x)).collect::<Vec<_>>(),
            "rpy": f.rpy.iter().map(|x| u.angle_from_si(*x)).collect::<Vec<_>>(),
        })
    };
    let sessions: Vec<serde_json::Value> = fit
        .sessions
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let robot = fit.robot_of(k);
            // The first session's frames are the model's: its own.
            let (base, tool) = fit.registrations.own_frames(k);
            let (base, tool) = (k == 0 || base, k == 0 || tool);
            let left_out = held_out.get(k);
            json!({
                "file": data.sessions.get(k),
                "held_out_rms": left_out.map(|h| u.length_from_si(h.position_rms)),
                "held_out_rms_mm": left_out.map(|h| h.position_rms * 1e3),
                "held_out_orientation_rms": left_out.and_then(|h| h.orientation_rms).map(|o| u.angle_from_si(o)),
                "poses": s.poses,
                "position_rms": u.length_from_si(s.position_rms),
                "position_rms_mm": s.position_rms * 1e3,
                "orientation_rms": s.orientation_rms.map(|o| u.angle_from_si(o)),
                "base": base.then(|| frame(&robot.base)),
                "tool": tool.then(|| frame(&robot.tool)),
                "written": k == 0,
            })
        })
        .collect();
    Some(json!(sessions))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::identify::full::identify_full;
    use crate::calibration::simulate::{measure, random_configurations, rng};
    use crate::io::model_file::load_model;

    /// Each of four sessions of a UR5e (60 positions each, σ = 20 µm, the
    /// tracker moved between them) left out in turn, predicted by the robot
    /// the others make; in the last, when `drift`, the upper arm is 0.5 mm
    /// shorter (it drifted, or was repaired, between days). Figures in mm.
    fn left_out(drift: bool) -> Vec<f64> {
        let nominal = load_model("ur5e").unwrap().robot;
        let mut r = rng(5);
        let mut rows = Vec::new();
        for session in 0..4 {
            let mut truth = nominal.clone();
            truth.base.xyz.x += 0.4 * session as f64;
            truth.base.rpy.z += 0.7 * session as f64;
            if drift && session == 3 {
                truth.links[1].a -= 0.5e-3;
            }
            let q = random_configurations(&nominal, 60, &mut r);
            rows.extend(
                measure(&truth, &q, 20e-6, None, &mut r)
                    .into_iter()
                    .map(|o| Observation { session, ..o }),
            );
        }
        let options = FullOptions::default();
        let calibrate = |rows: &[Observation]| {
            identify_full(&nominal, rows, &options).map(|f| (f.calibrated, Vec::new()))
        };
        held_out_by_session(&rows, &calibrate, FrameSharing::default(), &options)
            .unwrap()
            .iter()
            .map(|h| h.position_rms * 1e3)
            .collect()
    }

    /// The same robot in every session: each left out is predicted to the
    /// noise (3-D RMS near σ√3 = 35 µm). A robot that changed in one
    /// session: that session's figure stands out, far above the noise and
    /// well above the others' (which the changed session's rows pull too).
    #[test]
    fn leaving_sessions_out_shows_a_robot_that_changed_between_them() {
        let noise = 20e-3 * 3f64.sqrt();
        let same = left_out(false);
        eprintln!("the same robot, left out: {same:?} mm");
        assert!(same.iter().all(|mm| *mm < 1.5 * noise), "{same:?}");
        let changed = left_out(true);
        eprintln!("the last session's robot changed, left out: {changed:?} mm");
        let others = changed[..3].iter().copied().fold(0.0, f64::max);
        assert!(
            changed[3] > 5.0 * noise && changed[3] > 1.5 * others,
            "{changed:?}"
        );
    }
}
