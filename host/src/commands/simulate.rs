//! `simulate`: a measurement session of a true robot (the nominal model with
//! random errors and the hidden effects and tilts asked), as
//! [`crate::calibration::simulate`] draws it, with the request checked the
//! same way whichever front end asks.
//!
//! Noises and the true robot's error sizes are in the model's units as the
//! user states them; effect values and tilts in SI (rad, m), as
//! `NAME[:JOINT[:VALUE]]` and `JOINT:BETA` say.

use super::{Argument, Front};
use crate::calibration::gravity::TorqueSign;
use crate::calibration::simulate::{self, ErrorSizes, Scenario, Session, SessionWriter};
use crate::session::input_error::InputError;
use crate::session::input_error::number;
use crate::session::model::RobotModel;
use crate::session::observation::PAYLOAD_RANGE;

/// What `simulate` is asked.
#[derive(Clone, Debug)]
pub struct Request {
    /// Poses measured (at least 1).
    pub poses: usize,
    /// Seed of every draw.
    pub seed: u64,
    /// Position noise per axis (model length unit, zero or more); `None`
    /// for the tracker's default.
    pub noise: Option<f64>,
    /// Orientation noise per axis (model angle unit); `None` measures no
    /// orientation.
    pub orientation_noise: Option<f64>,
    /// A fixed rotation of the measured orientations in the instrument's
    /// frame, about an axis drawn from the seed (model angle unit; needs
    /// `orientation_noise`): see [`simulate::OrientationBias`].
    pub orientation_bias: Option<f64>,
    /// A rotation of the measured orientations growing with the tool
    /// point's distance from the instrument (model angle unit per model
    /// length unit; needs `orientation_noise`).
    pub orientation_bias_growth: Option<f64>,
    /// Noise of the joint torques the robot reports (N·m, N for a prismatic
    /// joint); `None` reports none.
    pub torque_noise: Option<f64>,
    /// The sign the torques are written with.
    pub torque_sign: TorqueSign,
    /// Hidden effects, `NAME[:JOINT[:VALUE]]` (joint from 1).
    pub effects: Vec<String>,
    /// Hidden Hayati tilts `(joint from 1, β rad)`.
    pub tilts: Vec<(usize, f64)>,
    /// The payloads of consecutive blocks of rows, kg; empty for the
    /// tracker's default (0 and 5 kg).
    pub payloads: Vec<f64>,
    /// Sessions the rows are measured in (at least 1): see
    /// [`Scenario::sessions`].
    pub sessions: usize,
    /// The true robot's errors off the nominal model (model units, each
    /// `[length, angle]`, drawn uniform within ± each): of the D-H links
    /// (`a`, `d`; `θ`, `α`), of the base frame (the instrument's placement)
    /// and of the tool frame (the measured point's mount); `None` for
    /// ±1 mm / ±1 mrad.
    pub errors: ErrorRequest,
}

/// The true robot's error sizes a [`Request`] asks, each `[length, angle]`
/// in the model's units; `None` for ±1 mm / ±1 mrad.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorRequest {
    /// The D-H links' lengths (`a`, `d`) and angles (`θ`, `α`).
    pub link: Option<[f64; 2]>,
    /// The base frame's position and orientation.
    pub base: Option<[f64; 2]>,
    /// The tool frame's position and orientation.
    pub tool: Option<[f64; 2]>,
}

impl Request {
    /// The file session `k` (from 0) of several is written to, for `--out
    /// path`: `D-1.csv`, `D-2.csv`, … for `D.csv`.
    pub fn session_path(path: &std::path::Path, k: usize) -> std::path::PathBuf {
        let stem = path
            .file_stem()
            .map_or_else(Default::default, |s| s.to_string_lossy());
        let name = match path.extension() {
            Some(ext) => format!("{stem}-{}.{}", k + 1, ext.to_string_lossy()),
            None => format!("{stem}-{}", k + 1),
        };
        path.with_file_name(name)
    }
}

/// The most poses a simulated session holds: its file stays within the
/// 1 GiB armcal reads of a data file (about 200 bytes a row, 280 with
/// orientations).
pub const MAX_POSES: usize = 3_000_000;

impl Request {
    /// The scenario this request draws on `model`: refused when a value is
    /// out of range or an effect or tilt does not name a joint of it.
    pub fn scenario(&self, front: Front, model: &RobotModel) -> Result<Scenario, InputError> {
        let u = model.units;
        let dof = model.robot.dof();
        if self.poses == 0 {
            return Err(Argument::Poses.refused(front, "0: at least 1"));
        }
        if self.poses > MAX_POSES {
            return Err(Argument::Poses.refused(
                front,
                format!(
                    "{}: at most {MAX_POSES} a session (about 200 bytes a row, 280 with \
                     orientations: a larger file is more than the 1 GiB armcal reads of a data \
                     file)",
                    self.poses
                ),
            ));
        }
        let non_negative = |argument: Argument, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                Err(argument.refused(
                    front,
                    format!("{}: must be a non-negative number", number(v)),
                ))
            }
        };
        let mut scenario = Scenario::tracker(self.poses, self.seed);
        if let Some(n) = self.noise {
            scenario.position_noise = u.length_to_si(non_negative(Argument::Noise, n)?);
        }
        if let Some(n) = self.orientation_noise {
            let n = non_negative(Argument::OrientationNoise, n)?;
            scenario.orientation_noise = Some(u.angle_to_si(n));
        }
        for (argument, given) in [
            (Argument::OrientationBias, self.orientation_bias),
            (
                Argument::OrientationBiasGrowth,
                self.orientation_bias_growth,
            ),
        ] {
            if let Some(v) = given {
                non_negative(argument, v)?;
                if self.orientation_noise.is_none() {
                    return Err(argument.refused(
                        front,
                        format!("{v}: biases measured orientations; measure them (--orientation-noise, orientation_noise)"),
                    ));
                }
            }
        }
        scenario.orientation_bias = simulate::OrientationBias {
            fixed: self.orientation_bias.map_or(0.0, |b| u.angle_to_si(b)),
            axis: None,
            // An angle per length: the angle to rad, per the length in m.
            per_metre: self
                .orientation_bias_growth
                .map_or(0.0, |g| u.angle_to_si(g) / u.length_to_si(1.0)),
        };
        if let Some(n) = self.torque_noise {
            scenario.torque_noise = Some(non_negative(Argument::TorqueNoise, n)?);
        }
        scenario.torque_sign = self.torque_sign;
        if self.sessions == 0 {
            return Err(Argument::SimulatedSessions.refused(front, "0: at least 1"));
        }
        // The poses go in consecutive blocks of ⌈poses/sessions⌉, the last
        // one what is left; each session has its own base frame and tool,
        // which its rows must determine with equations to spare, or armcal
        // refuses the file written (`require_own_frames`).
        if self.sessions > 1 {
            let least = crate::session::measurements::fewest_poses_of_a_session(
                crate::session::registration::FrameSharing::stated(false, false),
                self.orientation_noise.is_some(),
            );
            let block = self.poses.div_ceil(self.sessions);
            let last = self.poses.saturating_sub((self.sessions - 1) * block);
            if last < least {
                return Err(Argument::SimulatedSessions.refused(
                    front,
                    format!(
                        "{}: {} in blocks of {block} leave {} to the last session, which needs at \
                         least {least} to determine its own base frame and tool; give at least {} \
                         poses, or fewer sessions",
                        self.sessions,
                        crate::session::measurements::plural(self.poses, "pose"),
                        last,
                        self.sessions * least
                    ),
                ));
            }
        }
        // Each size given checked and in SI.
        let si = |argument: Argument, given: Option<[f64; 2]>| {
            given
                .map(|[length, angle]| {
                    Ok([
                        u.length_to_si(non_negative(argument, length)?),
                        u.angle_to_si(non_negative(argument, angle)?),
                    ])
                })
                .transpose()
        };
        scenario.errors = ErrorSizes::given(
            si(Argument::LinkErrors, self.errors.link)?,
            si(Argument::BaseErrors, self.errors.base)?,
            si(Argument::ToolErrors, self.errors.tool)?,
        );
        scenario.sessions = self.sessions;
        for &kg in &self.payloads {
            let [lo, hi] = PAYLOAD_RANGE;
            if !(lo..=hi).contains(&kg) {
                return Err(Argument::Payloads.refused(
                    front,
                    format!("{}: a payload from {lo} to {hi} kg", number(kg)),
                ));
            }
        }
        if !self.payloads.is_empty() {
            scenario.payloads = self.payloads.clone();
        }
        for spec in &self.effects {
            let effect = simulate::parse_effect(spec, dof)
                .map_err(|e| Argument::Effects.refused(front, e))?;
            scenario.effects.push(effect);
        }
        for &(joint, beta) in &self.tilts {
            if !((1..=dof).contains(&joint) && beta.is_finite()) {
                let value = match front {
                    Front::CommandLine => format!("{joint}:{beta}"),
                    Front::Python => format!("({joint}, {beta})"),
                };
                let finite = if beta.is_finite() {
                    ""
                } else {
                    " and β a finite number of rad"
                };
                return Err(Argument::Tilts.refused(
                    front,
                    format!("{value}: the joint must be from 1 to {dof}{finite}"),
                ));
            }
            scenario.tilts.push((joint - 1, beta));
        }
        Ok(scenario)
    }
}

/// Simulates the session `request` asks of `model`, held in memory.
pub fn run(front: Front, model: &RobotModel, request: &Request) -> anyhow::Result<Session> {
    let scenario = request.scenario(front, model)?;
    Ok(simulate::simulate(&model.robot, &scenario)?)
}

/// The session `request` asks of `model`, to be written to its files as its
/// rows are drawn, in the model's units (what `armcal simulate` writes: the
/// bytes of [`Session::to_csv`] of [`run`]'s session).
pub fn writer(
    front: Front,
    model: &RobotModel,
    request: &Request,
) -> anyhow::Result<SessionWriter> {
    let scenario = request.scenario(front, model)?;
    Ok(SessionWriter::new(&model.robot, &scenario, model.units)?)
}
