//! Several sessions in one calibration, as the reports give them: each
//! session's rows and residual RMS, and where its own frames sit against the
//! first session's (the base frame's shift and turn, the tool's shift), for
//! the summary `identify` and `diagnose` print and their JSON. The
//! calibration file holds the first session's registration
//! ([`crate::session::registration`]), so `armcal predict` with it gives the
//! first session's figure; the reports say so. Values in the model's units
//! (`mm`-suffixed fields excepted). Nothing here computes; it reads a
//! [`FullFit`].

use std::fmt::Write as _;

use armcal_shared::{Frame, FrameAxis, Param};
use serde_json::json;

use super::full::FullFit;
use crate::io::measurements::Measurements;
use crate::io::model_file::Units;

/// A parameter of the base frame and one of the tool: whose they are.
const BASE: Param = Param::Base(FrameAxis::X);
const TOOL: Param = Param::Tool(FrameAxis::X);

/// How far frame `b` sits from frame `a`: the shift (m) and the turn (rad)
/// of `a⁻¹ b`.
fn moved(a: &Frame<f64>, b: &Frame<f64>) -> (f64, f64) {
    let d = a.isometry().inverse() * b.isometry();
    (d.translation.vector.norm(), d.rotation.angle())
}

/// The summary's lines on the sessions, when `data` has several: which
/// frames are each session's own, which registration the file holds, and
/// each session's poses, residual and frames.
pub fn summary(fit: &FullFit, data: &Measurements, u: &Units) -> String {
    let mut out = String::new();
    if fit.sessions.len() < 2 {
        return out;
    }
    let own = |p: Param| fit.registrations.owns(1, p);
    let frames = match (own(BASE), own(TOOL)) {
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
    let length = |x: f64| {
        format!(
            "{:.6} {} ({:.4} mm)",
            u.length_from_si(x),
            u.length,
            x * 1e3
        )
    };
    for (k, s) in fit.sessions.iter().enumerate() {
        let file = data.sessions.get(k).map_or("?", String::as_str);
        let _ = write!(
            out,
            "  session {} {file}: {} poses, position RMS {}",
            k + 1,
            s.poses,
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
        let _ = writeln!(out);
    }
    out
}

/// The JSON's `sessions`, when `data` has several: each session's file,
/// poses, residual RMS and own frames (`null` where it shares the first's;
/// x, y, z in the model's length unit, roll, pitch, yaw in its angle unit).
pub fn json(fit: &FullFit, data: &Measurements, u: &Units) -> Option<serde_json::Value> {
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
            let own = |p| k == 0 || fit.registrations.owns(k, p);
            json!({
                "file": data.sessions.get(k),
                "poses": s.poses,
                "position_rms": u.length_from_si(s.position_rms),
                "position_rms_mm": s.position_rms * 1e3,
                "orientation_rms": s.orientation_rms.map(|o| u.angle_from_si(o)),
                "base": own(BASE).then(|| frame(&robot.base)),
                "tool": own(TOOL).then(|| frame(&robot.tool)),
                "written": k == 0,
            })
        })
        .collect();
    Some(json!(sessions))
}
