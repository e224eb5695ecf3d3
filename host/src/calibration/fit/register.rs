//! A session the robot was not fitted to, registered: its own base frame
//! and tool fitted to its rows with the robot's geometry and effects held
//! (closed form, then Levenberg–Marquardt on the 6 + 3 — 6 + 6 with
//! orientations — frame parameters alone). What a new session of a
//! calibrated robot needs before its rows can be compared with the robot,
//! and what a cross-validation that leaves whole sessions out predicts a
//! session with ([`crate::calibration::identify::sessions`]). SI units; the
//! rows weighed by the options' noise, as the fit weighs them.

use armcal_shared::effects::Effect;
use armcal_shared::{FrameAxis, Param, Robot};

use super::initial::initial_base_tool;
use super::rows::NormalEquations;
use super::solve::levenberg_marquardt;
use super::{FrameSharing, FullError, FullOptions, Model, Sharing, Unknown};
use crate::calibration::fit::noise::Weights;
use crate::session::channel::PerChannel;
use crate::session::rows::Rows;

/// A session registered ([`register_session`]).
#[derive(Clone, Debug)]
pub struct Registered {
    /// The robot with the session's own base and tool.
    pub robot: Robot<f64>,
    /// The RMS of the rows' position residuals, m.
    pub position_rms: f64,
    /// The RMS of the rows' orientation residuals, rad (0 without orientations).
    pub orientation_rms: f64,
}

/// `robot` with `effects`, its base and tool (those `sharing` gives each
/// session; the others held at `robot`'s) registered to `data` (one
/// session's rows).
pub fn register_session(
    robot: &Robot<f64>,
    effects: &[Effect<f64>],
    data: Rows<'_>,
    sharing: FrameSharing,
    options: &FullOptions,
) -> Result<Registered, FullError> {
    let mut seen = robot.clone();
    initial_base_tool(&mut seen, data);
    if sharing.base == Sharing::Shared {
        seen.base = robot.base;
    }
    if sharing.tool == Sharing::Shared {
        seen.tool = robot.tool;
    }
    // A model of one session: every row, whatever its session, is seen
    // through its frames.
    let mut model = Model::of(seen, effects.to_vec());
    let orientation = data.iter().any(|o| o.orientation.is_some());
    let tool: &[FrameAxis] = if orientation {
        &FrameAxis::ALL
    } else {
        &[FrameAxis::X, FrameAxis::Y, FrameAxis::Z]
    };
    let frames: Vec<Unknown> = FrameAxis::ALL
        .into_iter()
        .map(Param::Base)
        .chain(tool.iter().map(|&a| Param::Tool(a)))
        .filter(|p| sharing.per_session(*p))
        .map(Unknown::Param)
        .collect();
    let weights = Weights::of(&PerChannel::from_fn(|c| options.noise(c).sigma));
    let mut sys = NormalEquations::accumulate(&model, data, &frames, &weights, options.cancel);
    if !frames.is_empty() {
        let prior = vec![(0.0, 0.0); frames.len()];
        (_, _, _, sys) =
            levenberg_marquardt(&mut model, data, &frames, &weights, options, sys, &prior)?;
    }
    let (position, orientation) = sys.residual_rms(&weights);
    Ok(Registered {
        robot: model.robot,
        position_rms: position,
        orientation_rms: orientation,
    })
}
