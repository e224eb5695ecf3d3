//! The project's simulator: true robots with built-in errors and the
//! measurements a laser tracker or a pose sensor would take of them. The tests,
//! the benchmarks and `armcal simulate` draw their data from it; `csv` writes
//! a session as a measurement file, from memory or as its rows are drawn.
//!
//! Units are SI (m, rad). Random draws come from a seeded `StdRng`, so every run
//! is repeatable.

use crate::report::units::{FrameReport, UnitsReport};
use crate::session::observation::Contact;
use crate::session::observation::Observation;
use armcal_shared::{Frame, JointType, Param, Robot};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

mod csv;
pub use csv::SessionWriter;

/// A seeded generator.
pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

/// A draw of its own made from one `--seed`, apart from the others: drawing
/// more of one leaves every other the same (a session's rows are those of
/// the same scenario with one session; a plan's random comparison does not
/// move with its candidates).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stream {
    /// The base frames and tools of the sessions after the first.
    SessionFrames,
    /// The axis of a growing orientation bias, when none is stated.
    BiasAxis,
    /// The targets a plan's accuracy is predicted at, drawn over the
    /// workspace when none are given.
    Workspace,
    /// The random poses a plan is compared with.
    RandomPoses,
    /// The starting configurations of the seatings in socket `k` (from 0).
    Socket(usize),
}

impl Stream {
    /// The seed of this draw from `seed`.
    pub fn seed(self, seed: u64) -> u64 {
        seed ^ match self {
            Self::SessionFrames => 0x5e55_10a5,
            Self::BiasAxis => 0x0b1a_5ed0,
            Self::Workspace => 0x7a7,
            Self::RandomPoses => 0x5eed,
            Self::Socket(k) => (k as u64 + 1) << 20,
        }
    }
}

/// How far the true robot is off its nominal model: each geometric parameter
/// moved by a uniform draw within ± its size, SI (m, rad). The D-H links'
/// lengths (`a`, `d`/`s`) and angles (the joint offsets `θ` and the twists
/// `α`), the base frame's (the instrument's placement) and the tool frame's
/// (the measured point's mount) each have their own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorSizes {
    /// The links' `a` and `d` (`s`), m.
    pub link_length: f64,
    /// The links' `θ` and `α`, rad.
    pub link_angle: f64,
    /// The base frame's position, m.
    pub base_length: f64,
    /// The base frame's orientation (roll, pitch, yaw), rad.
    pub base_angle: f64,
    /// The tool frame's position, m.
    pub tool_length: f64,
    /// The tool frame's orientation, rad.
    pub tool_angle: f64,
}

impl ErrorSizes {
    /// The same `length` (m) and `angle` (rad) for the links, the base and
    /// the tool.
    pub fn uniform(length: f64, angle: f64) -> Self {
        Self {
            link_length: length,
            link_angle: angle,
            base_length: length,
            base_angle: angle,
            tool_length: length,
            tool_angle: angle,
        }
    }

    /// The `[length, angle]` sizes given (SI) for the links, the base and the
    /// tool, each the default's where none is given.
    pub fn given(link: Option<[f64; 2]>, base: Option<[f64; 2]>, tool: Option<[f64; 2]>) -> Self {
        let d = Self::default();
        let [link_length, link_angle] = link.unwrap_or([d.link_length, d.link_angle]);
        let [base_length, base_angle] = base.unwrap_or([d.base_length, d.base_angle]);
        let [tool_length, tool_angle] = tool.unwrap_or([d.tool_length, d.tool_angle]);
        Self {
            link_length,
            link_angle,
            base_length,
            base_angle,
            tool_length,
            tool_angle,
        }
    }

    /// The size of `param`'s error (`Beta`, a tilt, is drawn by none: 0).
    pub fn of(&self, param: Param) -> f64 {
        match param {
            Param::Theta(_) | Param::Alpha(_) => self.link_angle,
            Param::S(_) | Param::A(_) => self.link_length,
            Param::Beta(_) => 0.0,
            Param::Base(ax) if ax.is_angle() => self.base_angle,
            Param::Base(_) => self.base_length,
            Param::Tool(ax) if ax.is_angle() => self.tool_angle,
            Param::Tool(_) => self.tool_length,
        }
    }
}

impl Default for ErrorSizes {
    /// ±1 mm / ±1 mrad on every parameter.
    fn default() -> Self {
        Self::uniform(1e-3, 1e-3)
    }
}

/// `nominal` with every parameter in `params` moved by a uniform draw within
/// `±length` (m) or `±angle` (rad); returns the true robot and the errors.
pub fn with_random_errors(
    nominal: &Robot<f64>,
    params: &[Param],
    length: f64,
    angle: f64,
    rng: &mut StdRng,
) -> (Robot<f64>, Vec<f64>) {
    with_error_sizes(nominal, params, &ErrorSizes::uniform(length, angle), rng)
}

/// `nominal` with every parameter in `params` moved by a uniform draw within
/// ± its size in `sizes` (none for a size of 0); returns the true robot and
/// the errors.
pub fn with_error_sizes(
    nominal: &Robot<f64>,
    params: &[Param],
    sizes: &ErrorSizes,
    rng: &mut StdRng,
) -> (Robot<f64>, Vec<f64>) {
    let mut truth = nominal.clone();
    let errors: Vec<f64> = params
        .iter()
        .map(|p| {
            let scale = sizes.of(*p);
            // A size of 0 moves nothing; the generator moves on all the same
            // (one draw), so that the other parameters' draws stay theirs.
            let e = if scale > 0.0 {
                rng.random_range(-scale..scale)
            } else {
                let _ = rng.random::<u64>();
                0.0
            };
            *truth.param_mut(*p).expect("param of the model") += e;
            e
        })
        .collect();
    (truth, errors)
}

/// `n` random configurations within the joint limits ([`random_configuration`]).
pub fn random_configurations(robot: &Robot<f64>, n: usize, rng: &mut StdRng) -> Vec<Vec<f64>> {
    (0..n).map(|_| random_configuration(robot, rng)).collect()
}

/// A random configuration within the joint limits (a revolute joint also
/// within ±π; without limits ±π, or 0 to 0.5 m for a prismatic joint).
pub fn random_configuration(robot: &Robot<f64>, rng: &mut StdRng) -> Vec<f64> {
    robot
        .links
        .iter()
        .map(|l| {
            let [lo, hi] = l.limits.unwrap_or(match l.joint {
                JointType::Revolute => [-std::f64::consts::PI, std::f64::consts::PI],
                JointType::Prismatic => [0.0, 0.5],
            });
            // Within ±π of a revolute joint's zero where the limits allow it.
            let pi = std::f64::consts::PI;
            let (a, b) = match l.joint {
                JointType::Revolute => (lo.max(-pi), hi.min(pi)),
                JointType::Prismatic => (lo, hi),
            };
            let (lo, hi) = if a < b { (a, b) } else { (lo, hi) };
            // A model file refuses limits that leave no motion; a built
            // robot may still have them.
            if lo < hi {
                rng.random_range(lo..hi)
            } else {
                lo
            }
        })
        .collect()
}

/// Rows that visit `configurations` in order one joint at a time (single-joint
/// sweeps): the first configuration is the first row; from each configuration
/// to the next, joints 1, 2, … in turn move to their new value, one row per
/// joint, while the others hold. `(K − 1) · M + 1` rows for `K` configurations
/// of `M` joints; a row repeats the one before where a joint's value is the same
/// in both configurations.
pub fn one_joint_at_a_time(configurations: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let mut rows: Vec<Vec<f64>> = configurations.iter().take(1).cloned().collect();
    for next in configurations.iter().skip(1) {
        for (j, value) in next.iter().enumerate() {
            let mut row = rows.last().cloned().unwrap_or_default();
            if let Some(x) = row.get_mut(j) {
                *x = *value;
            }
            rows.push(row);
        }
    }
    rows
}

/// What the instrument measures of `truth` at `configs`: the tool point with
/// Gaussian noise `position_noise` (m, per axis) and, when `orientation_noise` is
/// given, the tool orientation with a Gaussian rotation-vector noise (rad, per axis).
pub fn measure(
    truth: &Robot<f64>,
    configs: &[Vec<f64>],
    position_noise: f64,
    orientation_noise: Option<f64>,
    rng: &mut StdRng,
) -> Vec<Observation> {
    let normal = Normal::new(0.0, 1.0).expect("unit normal");
    let mut draw3 = |s: f64| Vector3::from_fn(|_, _| s * normal.sample(rng));
    configs
        .iter()
        .map(|q| {
            let t = truth.forward(q).expect("joint count");
            let position = Point3::from(t.translation.vector + draw3(position_noise));
            let orientation = orientation_noise.map(|s| {
                UnitQuaternion::from_scaled_axis(draw3(s))
                    * UnitQuaternion::from_rotation_matrix(&t.rotation)
            });
            Observation {
                q: q.clone(),
                position,
                orientation,
                context: Default::default(),
                torque: None,
                contact: Contact::Measured,
                session: 0,
            }
        })
        .collect()
}

/// One simulated measurement session: a true robot (nominal + geometric errors +
/// hidden effects), the contexts of its poses, and what the instrument saw.
#[derive(Clone, Debug)]
pub struct Session {
    /// The true geometric robot (Hayati tilts included).
    pub truth: Robot<f64>,
    /// The hidden effects.
    pub effects: Vec<armcal_shared::effects::Effect<f64>>,
    /// Joint readings, in measurement order.
    pub q: Vec<Vec<f64>>,
    /// Time of each pose, s.
    pub t: Vec<f64>,
    /// Temperature of each pose, °C.
    pub temp: Vec<f64>,
    /// Payload of each pose, kg.
    pub load: Vec<f64>,
    /// The measurements.
    pub observations: Vec<Observation>,
    /// Each session's true base and tool frames, in order (the first the
    /// truth's own).
    pub frames: Vec<(Frame<f64>, Frame<f64>)>,
}

/// What a simulated session is made of.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Poses measured.
    pub poses: usize,
    /// The true robot's geometric errors: uniform within ± their sizes on
    /// every D-H, base and tool parameter.
    pub errors: ErrorSizes,
    /// Position noise, m per axis.
    pub position_noise: f64,
    /// Orientation noise, rad per axis, when orientations are measured.
    pub orientation_noise: Option<f64>,
    /// A systematic error of the measured orientations (none by default).
    pub orientation_bias: OrientationBias,
    /// The hidden effects.
    pub effects: Vec<armcal_shared::effects::Effect<f64>>,
    /// Hidden Hayati tilts `(joint, β)`.
    pub tilts: Vec<(usize, f64)>,
    /// Temperature drifts linearly from the first to the second value, °C.
    pub temperature: (f64, f64),
    /// Payloads the poses are measured with, kg (cycled in blocks).
    pub payloads: Vec<f64>,
    /// The joint torques the robot reports, when it does: the noise of each
    /// (N·m, N for a prismatic joint, per joint). Each pose's `tau` is its
    /// drives' torque, minus the true gravity torque with the payload.
    pub torque_noise: Option<f64>,
    /// The sign the torques are reported with: the drives' (armcal's
    /// `tau`), or the load torques the sensors read (the drives' negated).
    pub torque_sign: crate::calibration::gravity::TorqueSign,
    /// Seed of every draw.
    pub seed: u64,
    /// Sessions the rows are measured in, in consecutive blocks: each after
    /// the first with the instrument moved (its base frame turned by up to
    /// ±π about the vertical and ±50 mrad about the others, shifted by up
    /// to ±1 m) and the measured point remounted (the tool shifted by up to
    /// ±3 mm and turned by up to ±10 mrad).
    pub sessions: usize,
}

/// A systematic error of the measured orientations, as a camera or an
/// optical tracker makes one: not noise, the same at the same pose. The
/// instrument sits at the origin of the measurement frame; each measured
/// orientation `R` is reported as `R_bias R`, `R_bias` a rotation in the
/// instrument's frame. The positions do not share it: a rotation shared by
/// both would be the base frame's, and one in the tool's frame the tool's,
/// both identified as such.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OrientationBias {
    /// A fixed rotation, rad: the orientations reported in a frame turned
    /// by it from the one the positions are in (a hand-eye rotation error,
    /// a marker frame built from few points).
    pub fixed: f64,
    /// The fixed rotation's axis in the instrument's frame; `None`: drawn
    /// from the seed (apart from the rows' draws).
    pub axis: Option<Vector3<f64>>,
    /// A rotation growing with the tool point's distance from the
    /// instrument, rad per m, about the horizontal axis across the line of
    /// sight (`ẑ × p`): a camera's orientation error, whose target seen
    /// farther is seen smaller and its tilt across the view worse.
    pub per_metre: f64,
}

impl OrientationBias {
    /// Whether it changes nothing.
    pub fn is_none(&self) -> bool {
        self.fixed == 0.0 && self.per_metre == 0.0
    }

    /// The rotation it puts on the orientation measured at tool point `p`
    /// (instrument frame, m), the fixed part about `axis` (unit).
    fn at(&self, p: &Vector3<f64>, axis: &Vector3<f64>) -> UnitQuaternion<f64> {
        let across = Vector3::z().cross(p);
        let across = if across.norm() > 1e-9 {
            across.normalize()
        } else {
            Vector3::x()
        };
        UnitQuaternion::from_scaled_axis(across * (self.per_metre * p.norm()))
            * UnitQuaternion::from_scaled_axis(axis * self.fixed)
    }
}

impl Scenario {
    /// A laser-tracker session: `poses` positions, σ = 20 µm, ±1 mm / ±1 mrad
    /// geometric errors, 20 °C to 30 °C, payloads 0 and 5 kg.
    pub fn tracker(poses: usize, seed: u64) -> Self {
        Self {
            poses,
            errors: ErrorSizes::default(),
            position_noise: 20e-6,
            orientation_noise: None,
            orientation_bias: OrientationBias::default(),
            effects: Vec::new(),
            tilts: Vec::new(),
            temperature: (20.0, 30.0),
            payloads: vec![0.0, 5.0],
            torque_noise: None,
            torque_sign: crate::calibration::gravity::TorqueSign::Drive,
            seed,
            sessions: 1,
        }
    }
}

/// The frames of `sessions` sessions of `truth` (see [`Scenario::sessions`]):
/// the first the truth's own, each later one drawn from `seed` (apart from
/// the rows' draws, so that one session's rows are those of a scenario of
/// one session).
fn session_frames(truth: &Robot<f64>, sessions: usize, seed: u64) -> Vec<(Frame<f64>, Frame<f64>)> {
    let mut r = rng(Stream::SessionFrames.seed(seed));
    let mut uniform = |x: f64| r.random_range(-x..x);
    let pi = std::f64::consts::PI;
    (0..sessions.max(1))
        .map(|k| {
            let (mut base, mut tool) = (truth.base, truth.tool);
            if k > 0 {
                base.xyz += Vector3::new(uniform(1.0), uniform(1.0), uniform(1.0));
                base.rpy += Vector3::new(uniform(0.05), uniform(0.05), uniform(pi));
                tool.xyz += Vector3::new(uniform(3e-3), uniform(3e-3), uniform(3e-3));
                tool.rpy += Vector3::new(uniform(0.01), uniform(0.01), uniform(0.01));
            }
            (base, tool)
        })
        .collect()
}

/// Simulates `scenario` on `nominal`. Poses are visited in random order, so that
/// every joint approaches them from both sides; the approach direction of each
/// joint is the sign of its last change, held while it holds, as `docs/file-formats.md` §2
/// reads row order ([`armcal_shared::effects::Approach`]).
pub fn simulate(
    nominal: &Robot<f64>,
    scenario: &Scenario,
) -> Result<Session, armcal_shared::effects::EffectError> {
    simulate_visiting(nominal, scenario, |r| {
        random_configurations(nominal, scenario.poses, r)
    })
}

/// [`simulate`], with the joint readings of the poses, in measurement order,
/// from `visit` (given the session's generator after the geometric errors are
/// drawn), instead of `scenario.poses` random configurations: for example
/// [`one_joint_at_a_time`] over random configurations. The temperature drift
/// and the payload blocks spread over the rows `visit` gives.
pub fn simulate_visiting(
    nominal: &Robot<f64>,
    scenario: &Scenario,
    visit: impl FnOnce(&mut StdRng) -> Vec<Vec<f64>>,
) -> Result<Session, armcal_shared::effects::EffectError> {
    let mut draw = Draw::new(nominal, scenario)?;
    let q = visit(&mut draw.rng);
    draw.rows = q.len();
    let mut session = draw.session();
    for qi in &q {
        let row = draw.row(qi)?;
        session.observations.push(row.observation);
        session.t.push(row.t);
        session.temp.push(row.temp);
        session.load.push(row.load);
    }
    // Moved in once the rows are drawn: a long session is not copied.
    session.q = q;
    Ok(session)
}

/// A simulated session being drawn, one row at a time: the true robot (and
/// the robot each session's instrument and mount see, with the hidden
/// effects), and what the rows carry on from one to the next — the
/// generator, each joint's approach direction and the row's index among
/// the session's `rows`.
pub(crate) struct Draw {
    scenario: Scenario,
    truth: Robot<f64>,
    frames: Vec<(Frame<f64>, Frame<f64>)>,
    models: Vec<armcal_shared::effects::EffectModel<f64>>,
    rng: StdRng,
    normal: Normal<f64>,
    approach: armcal_shared::effects::Approach,
    /// The rows the session has (the temperature drift, the payload blocks
    /// and the sessions spread over them).
    rows: usize,
    /// The index of the next row.
    next: usize,
    /// The axis of the orientations' fixed bias (unit, instrument frame).
    bias_axis: Vector3<f64>,
}

/// One drawn row: what the instrument saw, and when, how warm and how loaded.
pub(crate) struct DrawnRow {
    pub(crate) observation: Observation,
    /// s
    pub(crate) t: f64,
    /// °C
    pub(crate) temp: f64,
    /// kg
    pub(crate) load: f64,
}

impl Draw {
    /// The truth `scenario` draws on `nominal` (its geometric errors from the
    /// scenario's seed, its tilts, each session's frames), the generator left
    /// where the rows' draws begin.
    pub(crate) fn new(
        nominal: &Robot<f64>,
        scenario: &Scenario,
    ) -> Result<Self, armcal_shared::effects::EffectError> {
        let mut rng = rng(scenario.seed);
        let params: Vec<Param> = nominal.params().collect();
        let (mut truth, _) = with_error_sizes(nominal, &params, &scenario.errors, &mut rng);
        for &(joint, beta) in &scenario.tilts {
            if let Some(l) = truth.links.get_mut(joint) {
                l.beta = beta;
            }
        }
        let frames = session_frames(&truth, scenario.sessions, scenario.seed);
        let models = frames
            .iter()
            .map(|(base, tool)| {
                let mut seen = truth.clone();
                (seen.base, seen.tool) = (*base, *tool);
                armcal_shared::effects::EffectModel::new(seen, &scenario.effects)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            scenario: scenario.clone(),
            truth,
            frames,
            models,
            rng,
            normal: Normal::new(0.0, 1.0).expect("unit normal"),
            approach: armcal_shared::effects::Approach::new(),
            rows: scenario.poses,
            next: 0,
            bias_axis: scenario.orientation_bias.axis.map_or_else(
                || {
                    // From its own generator: the rows' draws are the unbiased session's.
                    let mut r = self::rng(Stream::BiasAxis.seed(scenario.seed));
                    let n = Normal::new(0.0, 1.0).expect("unit normal");
                    Vector3::from_fn(|_, _| n.sample(&mut r)).normalize()
                },
                |a| a.normalize(),
            ),
        })
    }

    /// The session without rows: the truth, its effects and frames.
    pub(crate) fn session(&self) -> Session {
        Session {
            truth: self.truth.clone(),
            effects: self.scenario.effects.clone(),
            q: Vec::new(),
            t: Vec::new(),
            temp: Vec::new(),
            load: Vec::new(),
            observations: Vec::new(),
            frames: self.frames.clone(),
        }
    }

    /// The rows of each session but the last: the rows are shared among the
    /// sessions in consecutive blocks.
    fn session_rows(&self) -> usize {
        self.rows.max(1).div_ceil(self.frames.len())
    }

    /// The session (from 0) of row `i`.
    fn session_of(&self, i: usize) -> usize {
        i / self.session_rows()
    }

    /// The first row of session `k` (from 0): the number of rows when
    /// `k` is past the last.
    fn first_row(&self, k: usize) -> usize {
        (k * self.session_rows()).min(self.rows)
    }

    /// The next row, measured at the joint readings `q`.
    pub(crate) fn row(
        &mut self,
        q: &[f64],
    ) -> Result<DrawnRow, armcal_shared::effects::EffectError> {
        let scenario = &self.scenario;
        let (i, n) = (self.next, self.rows.max(1));
        self.next += 1;
        let frac = i as f64 / (n.max(2) - 1) as f64;
        let temp =
            scenario.temperature.0 + frac * (scenario.temperature.1 - scenario.temperature.0);
        let block = n.div_ceil(scenario.payloads.len().max(1));
        let load = scenario.payloads.get(i / block).copied().unwrap_or(0.0);
        let ctx = armcal_shared::effects::Context {
            temperature: Some(temp),
            payload: Some(load),
            approach: self.approach.next(q),
        };
        let session_of = self.session_of(i);
        let frame = self.models[session_of].forward(q, &ctx)?;
        let (rng, normal) = (&mut self.rng, self.normal);
        let torque = match scenario.torque_noise {
            None => None,
            Some(s) => {
                let chain = self.truth.chain(q)?;
                let gravity = armcal_shared::effects::gravity_torques(&self.truth, &chain, load);
                // The drive's torque, negated exactly for the load's.
                let sign = scenario.torque_sign.to_drive();
                Some(
                    gravity
                        .iter()
                        .map(|g| sign * (-g + s * normal.sample(rng)))
                        .collect(),
                )
            }
        };
        let mut draw3 = |s: f64| Vector3::from_fn(|_, _| s * normal.sample(rng));
        let position = Point3::from(frame.translation.vector + draw3(scenario.position_noise));
        let bias = scenario
            .orientation_bias
            .at(&frame.translation.vector, &self.bias_axis);
        let orientation = scenario.orientation_noise.map(|s| {
            bias * UnitQuaternion::from_scaled_axis(draw3(s))
                * UnitQuaternion::from_rotation_matrix(&frame.rotation)
        });
        Ok(DrawnRow {
            observation: Observation {
                q: q.to_vec(),
                position,
                orientation,
                context: ctx,
                torque,
                contact: Contact::Measured,
                session: session_of,
            },
            t: 10.0 * i as f64,
            temp,
            load,
        })
    }
}

/// What `armcal simulate --truth` writes: every geometric error the session
/// was simulated with (true minus nominal, by parameter name, the model's
/// units; the zero ones left out), the hidden effects, and with several
/// sessions each one's base frame and tool.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Truth {
    /// Each non-zero error by parameter name.
    pub errors: std::collections::BTreeMap<String, f64>,
    /// The hidden effects.
    pub effects: Vec<TruthEffect>,
    /// The model file's units.
    pub units: UnitsReport,
    /// With several sessions, each one's frames.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sessions: Option<Vec<TruthFrames>>,
}

/// A hidden effect of the truth.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TruthEffect {
    /// Its name.
    pub name: &'static str,
    /// Its joint, from 1.
    pub joint: Option<usize>,
    /// The effect as the calibration file holds it, SI.
    pub si: armcal_shared::effects::Effect<f64>,
}

/// One session's true base frame and tool.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TruthFrames {
    /// Its base frame.
    pub base: FrameReport,
    /// Its tool.
    pub tool: FrameReport,
}

impl Session {
    /// The truth ([`Truth`]), in `units`.
    pub fn truth(&self, nominal: &Robot<f64>, units: &armcal_shared::units::Units) -> Truth {
        let mut params: Vec<Param> = nominal.params().collect();
        params.extend((0..nominal.dof()).map(Param::Beta));
        let errors = params
            .iter()
            .filter_map(|p| {
                let e = self.truth.param(*p)? - nominal.param(*p)?;
                let v = if p.is_angle() {
                    units.angle_from_si(e)
                } else {
                    units.length_from_si(e)
                };
                (e != 0.0).then(|| (p.to_string(), v))
            })
            .collect();
        let frame = |f: &Frame<f64>| FrameReport::of(f, units);
        Truth {
            errors,
            effects: self
                .effects
                .iter()
                .map(|e| TruthEffect {
                    name: e.name(),
                    joint: e.joint().map(|j| j + 1),
                    si: *e,
                })
                .collect(),
            units: UnitsReport::from(units),
            sessions: (self.frames.len() > 1).then(|| {
                self.frames
                    .iter()
                    .map(|(b, t)| TruthFrames {
                        base: frame(b),
                        tool: frame(t),
                    })
                    .collect()
            }),
        }
    }
}

/// An effect from its name on the command line, `NAME[:JOINT[:VALUE]]` (joint from
/// 1, value in SI), with a realistic default size for a 1 m class arm: a few
/// tenths of a millimetre at the tool.
pub fn parse_effect(spec: &str, dof: usize) -> Result<armcal_shared::effects::Effect<f64>, String> {
    use armcal_shared::effects::Effect;
    let mut parts = spec.split(':');
    let name = parts.next().unwrap_or_default();
    let joint = match parts.next() {
        Some(j) => match j.parse::<usize>() {
            Ok(j) if (1..=dof).contains(&j) => j - 1,
            _ => {
                return Err(format!(
                    "{spec}: the joint must be a number from 1 to {dof}"
                ));
            }
        },
        None => 1.min(dof.saturating_sub(1)),
    };
    let value = match parts.next() {
        Some(v) => match v.parse::<f64>() {
            Ok(v) if v.is_finite() => Some(v),
            _ => {
                return Err(format!(
                    "{spec}: the value must be a finite number (SI units)"
                ));
            }
        },
        None => None,
    };
    let v = |default: f64| value.unwrap_or(default);
    Ok(match name {
        "joint_compliance" => Effect::JointCompliance {
            joint,
            compliance: v(2e-6),
        },
        "gear_transmission" => Effect::GearTransmission {
            joint,
            first: [v(2e-4), 0.0],
            second: [0.0, v(2e-4) / 2.0],
        },
        "backlash" => Effect::Backlash {
            joint,
            half_lost_motion: v(1.5e-4),
        },
        "thermal_expansion" => Effect::ThermalExpansion {
            coefficient: v(2.3e-5),
            reference: 20.0,
        },
        "encoder_scale" => Effect::EncoderScale {
            joint,
            scale: v(1e-4),
        },
        other => {
            return Err(format!(
                "{other}: not an effect; one of joint_compliance, gear_transmission, backlash, thermal_expansion, encoder_scale (parallel_axis_tilt: use --tilt)"
            ));
        }
    })
}

/// A simulated session without a tracker: a ball on the flange put into
/// sockets at unknown fixed points (see [`crate::session::constraints`]).
#[derive(Clone, Debug)]
pub struct SocketSession {
    /// One row per contact, `contact` naming its socket; `position` is 0.
    pub observations: Vec<Observation>,
    /// The true socket centres, base frame, m.
    pub sockets: Vec<Point3<f64>>,
    /// The true plane touched, if any: a point of it and its unit normal.
    pub plane: Option<(Point3<f64>, Vector3<f64>)>,
}

/// Contacts of `truth`'s tool point with `sockets` (true centres, base frame,
/// m): `per_socket` configurations each, found by inverse kinematics from random
/// starts, each reaching its socket's centre displaced by a Gaussian contact
/// error of `contact_noise` (m, per axis). `None` if some socket is not reached
/// from 200 starts.
pub fn socket_session(
    truth: &Robot<f64>,
    sockets: &[Point3<f64>],
    per_socket: usize,
    contact_noise: f64,
    rng: &mut StdRng,
) -> Option<SocketSession> {
    let normal = Normal::new(0.0, 1.0).expect("unit normal");
    let mut observations = Vec::new();
    for (k, socket) in sockets.iter().enumerate() {
        let mut found = 0;
        for _ in 0..200 {
            if found == per_socket {
                break;
            }
            let noise = Vector3::from_fn(|_, _| contact_noise * normal.sample(rng));
            let start = random_configuration(truth, rng);
            if let Some(q) = reach_point(truth, start, &(socket + noise)) {
                observations.push(Observation::at_contact(q, Contact::Point(k)));
                found += 1;
            }
        }
        if found < per_socket {
            return None;
        }
    }
    Some(SocketSession {
        observations,
        sockets: sockets.to_vec(),
        plane: None,
    })
}

/// Touches of `truth`'s tool point on the plane through `centre` with unit
/// normal `normal` (base frame, m): `count` configurations found by inverse
/// kinematics from random starts, each at a random point of the plane within
/// `radius` of `centre`, displaced along the normal by a Gaussian contact error
/// of `contact_noise` (m). Each row names plane `plane`. `None` if fewer are
/// reached from `20 · count` starts.
pub fn plane_touches(
    truth: &Robot<f64>,
    (centre, normal, radius): (Point3<f64>, Vector3<f64>, f64),
    plane: usize,
    count: usize,
    contact_noise: f64,
    rng: &mut StdRng,
) -> Option<Vec<Observation>> {
    let normal_draw = Normal::new(0.0, 1.0).expect("unit normal");
    let helper = if normal.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = helper.cross(&normal).normalize();
    let v = normal.cross(&u);
    let mut out = Vec::new();
    for _ in 0..20 * count {
        if out.len() == count {
            break;
        }
        let (x, y) = (
            rng.random_range(-radius..radius),
            rng.random_range(-radius..radius),
        );
        let target = centre + u * x + v * y + normal * (contact_noise * normal_draw.sample(rng));
        let start = random_configuration(truth, rng);
        if let Some(q) = reach_point(truth, start, &target) {
            out.push(Observation::at_contact(q, Contact::Plane(plane)));
        }
    }
    (out.len() == count).then_some(out)
}

/// Joint values from `q` on that put `robot`'s tool point at `target` to 1e-13 m
/// (damped least squares on the finite-difference position Jacobian), within
/// the joint limits; `None` when they do not converge there.
pub fn reach_point(robot: &Robot<f64>, mut q: Vec<f64>, target: &Point3<f64>) -> Option<Vec<f64>> {
    let kin = robot.prepare();
    let point = |q: &[f64]| kin.forward(q).ok().map(|t| t.translation.vector);
    for _ in 0..100 {
        let p = point(&q)?;
        let e = target.coords - p;
        if e.norm() < 1e-13 {
            let within = robot
                .links
                .iter()
                .zip(&q)
                .all(|(l, v)| l.limits.is_none_or(|[lo, hi]| (lo..=hi).contains(v)));
            return within.then_some(q);
        }
        let h = 1e-7;
        let mut j = nalgebra::DMatrix::<f64>::zeros(3, q.len());
        for c in 0..q.len() {
            let mut qh = q.clone();
            qh[c] += h;
            let d = (point(&qh)? - p) / h;
            j.set_column(c, &d);
        }
        let jjt = &j * j.transpose() + nalgebra::Matrix3::identity() * 1e-9;
        let step = j.transpose() * jjt.try_inverse()? * e;
        let norm = step.norm();
        let step = if norm > 0.5 {
            step * (0.5 / norm)
        } else {
            step
        };
        for (v, d) in q.iter_mut().zip(step.iter()) {
            *v += d;
        }
    }
    None
}
