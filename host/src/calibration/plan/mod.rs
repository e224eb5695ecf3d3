//! `armcal plan`: which poses to measure, and how accurate the calibration
//! from them will be, before anything is measured.
//!
//! ## What is chosen
//! `N` joint configurations among candidates (random ones within the joint
//! limits less a margin, or the user's), each of whose tool point stays
//! within the cell (`--within` a box, `--above` a floor), chosen so that the
//! full calibration identified from them (`armcal identify --params full`,
//! least squares at the stated noise) predicts the tool point at the
//! workspace's configurations (random ones within the joint limits, or the
//! user's `--targets`) as well as possible: I-optimality ([`design`]), the
//! expected held-out error, not the volume of the parameters' confidence
//! region. Then a short path through them ([`order`]). A plan may serve
//! the joints' compliances (`--effects compliance`: each compliance under
//! gravity, `Δq_j = c_j τ_j(q)`, is a column of the criterion, so that the
//! torques at the poses spread) or a session without a tracker (`--sockets`:
//! which configurations to seat a ball in each socket at, [`sockets`]).
//!
//! ## What can be identified
//! What no choice of poses identifies (a parameter the model's geometry
//! makes inseparable from others, as `θ1` beside the base's turn about a
//! vertical first axis) is found as `identify` finds it: by identifying the
//! model from exact measurements at every candidate
//! ([`crate::calibration::fit`], its rank-revealing selection and
//! its reasons). The plan is made for the others, and checked the same way:
//! `identify` on exact measurements at the plan's poses must separate every
//! one of them, else the plan is refused with the parameters it misses.
//!
//! ## Predicted accuracy
//! At the stated noise `σ` (per axis) and the model's prior (`identify`'s
//! default: 1 mm, 1 mrad), the calibration from the plan has the covariance
//! `M⁻¹` ([`design`]: every parameter of the full model, those no plan
//! separates held by the prior where they move no tool point); the tool point at target `w` is off by
//! `v_w = tr(G_w M⁻¹ G_wᵀ)` m² in expectation: the predicted RMS error of
//! the calibrated robot over the workspace is `√(mean_w v_w)`, at the worst
//! target `√(max_w v_w)`; against a new measurement (what `predict` beside
//! an instrument shows, and `diagnose`'s held-out figures) its noise adds
//! `3σ²`: `√(mean_w v_w + 3σ²)`. The same for `N` random candidates, for
//! comparison. Each parameter's predicted standard
//! error is `√(M⁻¹)_kk`; the observability indices O1–O5 are those of the
//! plan's weighted Jacobian, its columns scaled to unit norm. SI inside.

pub mod design;
pub mod order;
pub mod report;
pub mod sockets;

use armcal_shared::effects::Effect;
use armcal_shared::{Param, Robot};
use nalgebra::{DMatrix, Point3, UnitQuaternion};
use rand::RngExt;

use crate::calibration::fit::{
    Extension, FitRequest, FullOptions, Status, full_params, independent_parameter_count,
};
use crate::calibration::simulate::{Stream, rng};
use crate::io::sockets::Sockets;
use crate::session::observation::Contact;
use crate::session::observation::Observation;
use crate::session::prior::Prior;
use design::Candidates;
use design::Optimality;

/// A box the tool point must stay in, measurement frame, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// The box's lowest corner (`-∞` where unbounded).
    pub min: [f64; 3],
    /// Its highest corner (`+∞` where unbounded).
    pub max: [f64; 3],
}

impl Cell {
    /// No bound.
    pub const ANYWHERE: Self = Self {
        min: [f64::NEG_INFINITY; 3],
        max: [f64::INFINITY; 3],
    };

    /// Whether `p` is within.
    pub fn holds(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|k| self.min[k] <= p[k] && p[k] <= self.max[k])
    }
}

/// What a plan is asked, SI.
#[derive(Clone, Debug)]
pub struct PlanOptions {
    /// Poses to measure.
    pub poses: usize,
    /// What measures them.
    pub instrument: Instrument,
    /// The position noise (m per axis) the plan is made and predicted for
    /// (of the ball's centre in its sockets, without a tracker).
    pub position_noise: f64,
    /// Random candidates drawn when none are given.
    pub candidates: usize,
    /// Random workspace configurations when no targets are given.
    pub workspace: usize,
    /// The share of each joint's range kept off each limit (0.05: 5 %).
    pub margin: f64,
    /// Where the tool point must stay.
    pub cell: Cell,
    /// Whether the flange (the last link's frame) and the tool point must
    /// stay above the robot's base plane (`z ≥ 0` in its base frame): a
    /// model without joint limits reaches through the table it stands on.
    pub above_base: bool,
    /// The prior on the D-H errors `identify` will fit with (the model's).
    pub prior: Prior,
    /// How each pose is visited: once, or from both sides (for backlash).
    pub visits: Visits,
    /// Whether the plan serves the joints' compliances: it identifies each
    /// joint's compliance under gravity with the geometry (the torques at its
    /// poses spread), and predicts with them.
    pub compliance: bool,
    /// The least [`conditioning`] a candidate may have: poses nearer a
    /// singularity of the arm are not planned (0, the default, keeps every
    /// candidate and names a planned pose below [`NEAR_SINGULAR`]: near a
    /// singularity a pose is informative, and a controller may still
    /// drive it slowly).
    pub singularity_margin: f64,
    /// What the poses are chosen for: the workspace's predicted error
    /// (I-optimal, the default) or the parameters' confidence region
    /// (D-optimal).
    pub criterion: Optimality,
    /// Seed of every draw.
    pub seed: u64,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            poses: 30,
            instrument: Instrument::Positions,
            position_noise: 20e-6,
            candidates: 10_000,
            workspace: 2_000,
            margin: 0.05,
            cell: Cell::ANYWHERE,
            above_base: false,
            prior: Prior::default(),
            visits: Visits::Once,
            compliance: false,
            singularity_margin: 0.0,
            criterion: Optimality::I,
            seed: 1,
        }
    }
}

/// The orientation noise a plan for full poses is made for unless stated,
/// rad per axis.
pub const ORIENTATION_NOISE: f64 = 20e-6;

/// What measures a plan's poses: an instrument (of positions, or of full
/// poses), or none, a ball seated in the sockets of a plate.
#[derive(Clone, Debug, PartialEq)]
pub enum Instrument {
    /// The tool point's position (a laser tracker's reflector).
    Positions,
    /// The full pose (a camera, a 6-D probe): the position and the
    /// orientation, this one at `orientation_noise` (rad per axis).
    Poses {
        /// The orientation's noise, rad per axis.
        orientation_noise: f64,
    },
    /// No instrument: a ball on the tool seated in the sockets of a plate
    /// ([`sockets`]).
    Sockets(Sockets),
}

impl Instrument {
    /// Whether it measures orientations.
    pub fn orientation(&self) -> bool {
        matches!(self, Self::Poses { .. })
    }

    /// The orientation's noise (rad per axis), when it measures one.
    pub fn orientation_noise(&self) -> Option<f64> {
        match self {
            Self::Poses { orientation_noise } => Some(*orientation_noise),
            Self::Positions | Self::Sockets(_) => None,
        }
    }

    /// The plate, without an instrument.
    pub fn sockets(&self) -> Option<&Sockets> {
        match self {
            Self::Sockets(plate) => Some(plate),
            Self::Positions | Self::Poses { .. } => None,
        }
    }
}

/// How the plan visits each pose.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Visits {
    /// Once, along the path.
    #[default]
    Once,
    /// Twice, approached from below and from above in every joint (a via
    /// row before each: [`order::both_sides`]), so that a joint's backlash
    /// shows (`--effects backlash`).
    BothSides,
}

/// How well a set of poses would calibrate the robot (see the module header).
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    /// Predicted RMS error of the calibrated robot's tool point over the
    /// workspace, m.
    pub rms: f64,
    /// Predicted RMS error at the worst target, m.
    pub max: f64,
    /// Predicted RMS against new measurements of the workspace (the
    /// instrument's noise added), m.
    pub measured_rms: f64,
    /// Each parameter's predicted standard error, SI (the prior's where the
    /// poses do not determine it).
    pub std: Vec<(Param, f64)>,
    /// Each compliance's predicted standard error (joint, rad/(N·m)), when
    /// the plan serves compliance.
    pub compliance: Vec<(usize, f64)>,
    /// The observability indices O1–O5.
    pub observability: [f64; 5],
    /// The predicted RMS error at each workspace target, m.
    pub per_target: Vec<f64>,
}

/// A plan: the poses in measurement order, what they are predicted to give,
/// and the same for as many random poses.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The joint configurations to measure, SI, in measurement order (with
    /// [`Visits::BothSides`], each pose's four rows).
    pub q: Vec<Vec<f64>>,
    /// For a socket plan, the socket of each row of `q` (empty otherwise).
    pub socket_of: Vec<usize>,
    /// With [`Visits::BothSides`], the poses that could not be approached
    /// from both sides in every joint (a limit or the cell in the way).
    pub one_sided: usize,
    /// The plan's predicted accuracy.
    pub predicted: Prediction,
    /// As many random candidates' (`None` when they do not identify every
    /// parameter the plan does, with the ones they miss).
    pub random: Result<Prediction, Vec<String>>,
    /// The plan of as many poses the other criterion chooses from the same
    /// candidates, and its predicted accuracy.
    pub compared: Compared,
    /// The parameters the plan identifies.
    pub identified: Vec<Param>,
    /// The parameters no choice of poses identifies, with why (`identify`'s
    /// reasons): the prior holds them.
    pub held: Vec<(Param, String)>,
    /// The joints whose compliance the plan identifies (when it serves
    /// compliance).
    pub compliance: Vec<usize>,
    /// The joints whose compliance no plan identifies, with why.
    pub compliance_held: Vec<(usize, String)>,
    /// The length of the measurement path, joint space (rad, m).
    pub path: f64,
    /// The rows of `q` near a singularity of the arm, with how near
    /// ([`conditioning`]: below [`NEAR_SINGULAR`]).
    pub near_singular: Vec<(usize, f64)>,
    /// The candidates the plan was chosen from (within the limits and the cell).
    pub candidates: usize,
    /// The workspace configurations it was made for.
    pub targets: usize,
    /// The nominal tool point of each workspace target, measurement frame, m.
    pub target_points: Vec<Point3<f64>>,
    /// The nominal tool point of each planned pose, in measurement order.
    pub points: Vec<Point3<f64>>,
    /// With the tool point on the last joint's axis, what an SMR off it
    /// would gain (a tracker plan; `None` otherwise).
    pub off_axis: Option<OffAxis>,
}

/// What measuring a point off the last joint's axis would gain, when the
/// tool point is on it ([`ON_AXIS`]): a turn of that joint does not move the
/// point, so the parameters of the wrist's last link are held by the prior.
#[derive(Clone, Debug)]
pub struct OffAxis {
    /// How far the tool point is from the last joint's axis, m.
    pub distance: f64,
    /// The point tried instead: the tool point moved [`OFF_AXIS`] square to
    /// that axis, flange frame, m.
    pub tool: nalgebra::Vector3<f64>,
    /// What the same poses would identify there and do not here.
    pub gained: Vec<Param>,
    /// The same poses' predicted accuracy at that point (`None` when they
    /// would not determine it).
    pub predicted: Option<Prediction>,
}

/// A tool point nearer the last joint's axis than this is on it, m.
pub const ON_AXIS: f64 = 0.005;

/// How far off the last joint's axis [`OffAxis`] tries the point, m: an SMR
/// nest on a 60 mm arm.
pub const OFF_AXIS: f64 = 0.06;

/// The tool point's distance from the last joint's axis (m) and a unit
/// vector square to that axis (flange frame), at `q`: rigid, the same at
/// every configuration.
fn from_last_axis(robot: &Robot<f64>, q: &[f64]) -> Option<(f64, nalgebra::Vector3<f64>)> {
    let chain = robot.chain(q).ok()?;
    let last = chain.axes.last()?;
    let w = last.w.normalize();
    let d = chain.point() - last.rho;
    let distance = d.cross(&w).norm();
    // The axis in the flange frame, and a direction square to it.
    let axis = chain.flange.rotation.inverse() * w;
    let helper = if axis.x.abs() < 0.9 {
        nalgebra::Vector3::x()
    } else {
        nalgebra::Vector3::y()
    };
    Some((distance, axis.cross(&helper).normalize()))
}

/// Another criterion's plan, for comparison.
#[derive(Clone, Debug)]
pub struct Compared {
    /// The criterion it was chosen by.
    pub criterion: Optimality,
    /// Its predicted accuracy (`Err` with what it misses when it does not
    /// identify every parameter the plan does).
    pub predicted: Result<Prediction, Vec<String>>,
}

/// Why a plan cannot be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PlanError {
    /// Fewer candidates within the limits and the cell than poses asked.
    #[error(
        "{found} candidate configurations keep the tool point within the cell and the joints \
         within their limits (less the margin), fewer than the {poses} poses asked: widen the \
         cell or give more candidates"
    )]
    TooFewCandidates {
        /// Candidates kept.
        found: usize,
        /// Poses asked.
        poses: usize,
    },
    /// Fewer poses than the identifiable parameters need.
    #[error(
        "{poses} poses give {equations} equations, fewer than the {parameters} parameters they \
         would identify: at least {fewest} poses"
    )]
    TooFewPoses {
        /// Poses asked.
        poses: usize,
        /// Their equations.
        equations: usize,
        /// Identifiable parameters.
        parameters: usize,
        /// The fewest poses that give as many equations.
        fewest: usize,
    },
    /// The plan chosen does not identify every identifiable parameter.
    #[error("the {poses} poses chosen do not identify {}: measure more poses", .missed.join(", "))]
    NotIdentified {
        /// Poses asked.
        poses: usize,
        /// What they miss: parameters, compliances.
        missed: Vec<String>,
    },
    /// A socket the nominal model reaches at too few configurations.
    #[error(
        "socket `{socket}` is reached within the joint limits (less the margin), the stem within \
         the approach cone, from {reached} of {tried} starts, fewer than the {least} poses it \
         needs: check its centre (base frame, the model's length unit) and approach direction"
    )]
    SocketUnreached {
        /// The socket's name.
        socket: String,
        /// Configurations that reach it.
        reached: usize,
        /// Starts tried.
        tried: usize,
        /// Poses it needs.
        least: usize,
    },
    /// The caller's `cancelled` check turned true ([`plan_cancellable`]).
    #[error("the plan was cancelled")]
    Cancelled,
}

/// `n` random configurations of `robot` within its joint limits less
/// `margin` of each range (a joint without limits: ±π, or 0 to 0.5 m).
pub fn within_limits(robot: &Robot<f64>, n: usize, margin: f64, seed: u64) -> Vec<Vec<f64>> {
    let mut r = rng(seed);
    (0..n)
        .map(|_| {
            robot
                .links
                .iter()
                .map(|l| {
                    let [lo, hi] = margin_range(l, margin);
                    if lo < hi { r.random_range(lo..hi) } else { lo }
                })
                .collect()
        })
        .collect()
}

/// The range of joint `link` less `margin` of it at each end (a joint
/// without limits: ±π, or 0 to 0.5 m for a prismatic one).
pub fn margin_range(link: &armcal_shared::Link<f64>, margin: f64) -> [f64; 2] {
    let pi = std::f64::consts::PI;
    let [lo, hi] = link.limits.unwrap_or(match link.joint {
        armcal_shared::JointType::Revolute => [-pi, pi],
        armcal_shared::JointType::Prismatic => [0.0, 0.5],
    });
    let keep = margin * (hi - lo);
    [lo + keep, hi - keep]
}

/// What a plan's calibration estimates: a column of its criterion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Column {
    /// A parameter of the full model.
    Param(Param),
    /// The compliance of a revolute joint, rad/(N·m): its reading off by the
    /// compliance times its gravity torque.
    Compliance(usize),
    /// One coordinate (`axis` 0–2) of a socket's unknown centre, base frame, m.
    Socket {
        /// The socket.
        socket: usize,
        /// Its coordinate.
        axis: usize,
    },
}

/// What `identify` separates from exact measurements at some poses: the full
/// model's parameters and the compliances asked, the others with its reasons.
#[derive(Clone, Debug, Default)]
struct Separable {
    params: Vec<Param>,
    held: Vec<(Param, String)>,
    compliance: Vec<usize>,
    compliance_held: Vec<(usize, String)>,
}

impl Separable {
    /// The names of what `self` separates and `fewer` does not.
    fn missed_by(&self, fewer: &Self) -> Vec<String> {
        let params = self
            .params
            .iter()
            .filter(|p| !fewer.params.contains(p))
            .map(ToString::to_string);
        let compliance = self
            .compliance
            .iter()
            .filter(|j| !fewer.compliance.contains(j))
            .map(|j| format!("the compliance of joint {}", j + 1));
        params.chain(compliance).collect()
    }
}

/// The configurations a plan chooses among and, for a socket plan, the
/// socket each puts the ball in.
struct Pool {
    q: Vec<Vec<f64>>,
    socket_of: Option<Vec<usize>>,
}

/// Exact measurements of `robot` at `q` (its tool point, and its
/// orientation when `orientation`): what the identifiability checks read.
fn exact(robot: &Robot<f64>, q: &[Vec<f64>], orientation: bool) -> Vec<Observation> {
    let kinematics = robot.prepare();
    q.iter()
        .filter_map(|q| {
            let t = kinematics.forward(q).ok()?;
            Some(Observation {
                q: q.clone(),
                position: Point3::from(t.translation.vector),
                orientation: orientation.then(|| UnitQuaternion::from_rotation_matrix(&t.rotation)),
                context: Default::default(),
                torque: None,
                contact: Contact::Measured,
                session: 0,
            })
        })
        .collect()
}

/// Which of the full model's parameters and the compliances of the joints
/// `compliance` `identify` separates from exact measurements at `q` (at the
/// sockets `socket_of` for a socket plan), at the stated noise of `options`,
/// and the others with its reasons.
fn identifiable(
    robot: &Robot<f64>,
    q: &[Vec<f64>],
    socket_of: Option<&[usize]>,
    compliance: &[usize],
    options: &PlanOptions,
) -> Separable {
    let defaults = FullOptions::default();
    let fit_options = FullOptions {
        position_noise: options.position_noise,
        // Without orientations there are no rows it weighs.
        orientation_noise: options
            .instrument
            .orientation_noise()
            .unwrap_or(defaults.orientation_noise),
        prior: Prior::NONE,
        ..defaults
    }
    .stated();
    let effects: Vec<Effect<f64>> = compliance
        .iter()
        .map(|&joint| Effect::JointCompliance {
            joint,
            compliance: 0.0,
        })
        .collect();
    let fit = match (socket_of, options.instrument.sockets()) {
        (Some(socket_of), Some(plate)) => {
            FitRequest::new(robot, &sockets::exact(q, socket_of), &fit_options)
                .extended(Extension {
                    effects: &effects,
                    extra: &[],
                })
                .constrained(&sockets::constraints(plate, socket_of))
                .run()
        }
        _ => FitRequest::new(
            robot,
            &exact(robot, q, options.instrument.orientation()),
            &fit_options,
        )
        .extended(Extension {
            effects: &effects,
            extra: &[],
        })
        .run(),
    };
    let Ok(fit) = fit else {
        return Separable {
            held: full_params(robot, options.instrument.orientation())
                .into_iter()
                .map(|p| (p, "not identified".into()))
                .collect(),
            compliance_held: compliance
                .iter()
                .map(|&j| (j, "not identified".into()))
                .collect(),
            ..Separable::default()
        };
    };
    let mut out = Separable::default();
    for p in fit.params {
        match p.status {
            Status::Identified { .. } => out.params.push(p.param),
            Status::Fixed { reason } => out.held.push((p.param, reason)),
        }
    }
    for (e, &joint) in fit.effects.iter().zip(compliance) {
        match e.status.first() {
            Some(Status::Identified { .. }) => out.compliance.push(joint),
            Some(Status::Fixed { reason }) => out.compliance_held.push((joint, reason.clone())),
            None => {}
        }
    }
    out
}

/// The joints whose compliance a plan serving compliance estimates: the
/// revolute ones whose gravity torque (the model's masses, or 1 kg a link
/// without them) is not zero at every one of `q`.
fn compliance_joints(robot: &Robot<f64>, q: &[Vec<f64>]) -> Vec<usize> {
    let kinematics = robot.prepare();
    let mut largest = vec![0.0_f64; robot.dof()];
    for qi in q {
        if let Ok(chain) = kinematics.chain(qi) {
            let tau = armcal_shared::effects::gravity_torques(robot, &chain, 0.0);
            for (l, t) in largest.iter_mut().zip(&tau) {
                *l = l.max(t.abs());
            }
        }
    }
    let top = largest.iter().copied().fold(0.0, f64::max);
    (0..robot.dof())
        .filter(|&j| {
            robot.links[j].joint == armcal_shared::JointType::Revolute && largest[j] > 1e-9 * top
        })
        .collect()
}

/// The weighted Jacobian rows of `robot` at each of `q` (3 position rows
/// divided by `noise.0`, then 3 orientation rows divided by `noise.1` when
/// given) for `columns`, stacked, each row of a socket plan at its socket
/// `socket_of`; the position rows alone, unweighted, when `noise` is `None`
/// (the targets', whose rows are at no socket).
fn jacobian(
    robot: &Robot<f64>,
    q: &[Vec<f64>],
    socket_of: Option<&[usize]>,
    columns: &[Column],
    noise: Option<(f64, Option<f64>)>,
) -> DMatrix<f64> {
    let (wp, wr) = match noise {
        Some((p, r)) => (1.0 / p, r.map(|r| 1.0 / r)),
        None => (1.0, None),
    };
    let rows = if wr.is_some() { 6 } else { 3 };
    let kinematics = robot.prepare();
    let torques = columns.iter().any(|c| matches!(c, Column::Compliance(_)));
    let mut j = DMatrix::zeros(rows * q.len(), columns.len());
    for (i, qi) in q.iter().enumerate() {
        let Ok(chain) = kinematics.chain(qi) else {
            continue;
        };
        let p = chain.point();
        let tau = torques.then(|| armcal_shared::effects::gravity_torques(robot, &chain, 0.0));
        for (k, column) in columns.iter().enumerate() {
            let twist = match *column {
                Column::Param(param) => chain.column(param),
                Column::Compliance(joint) => {
                    chain.column(Param::Theta(joint)) * tau.as_ref().map_or(0.0, |t| t[joint])
                }
                Column::Socket { socket, axis } => {
                    if socket_of.is_some_and(|s| s[i] == socket) {
                        j[(rows * i + axis, k)] = -wp;
                    }
                    continue;
                }
            };
            let v = armcal_shared::jacobian::at_point(&twist, &p);
            for a in 0..3 {
                j[(rows * i + a, k)] = v[a] * wp;
            }
            if let Some(wr) = wr {
                for a in 0..3 {
                    j[(rows * i + 3 + a, k)] = twist[a] * wr;
                }
            }
        }
    }
    j
}

/// The plan for `robot` (see the module header): the poses among
/// `candidates` (or random ones within the limits; for a socket plan, those
/// that reach its sockets) for the workspace `targets` (or random
/// configurations within the limits).
pub fn plan(
    robot: &Robot<f64>,
    candidates: Option<&[Vec<f64>]>,
    targets: Option<&[Vec<f64>]>,
    options: &PlanOptions,
) -> Result<Plan, PlanError> {
    plan_cancellable(robot, candidates, targets, options, &|| false)
}

/// [`plan`], asking `cancelled` between its steps (each stage, each pose
/// the exchange puts in: a pass over the candidates) and giving up with
/// [`PlanError::Cancelled`] once it is true (Python's Ctrl-C).
pub fn plan_cancellable(
    robot: &Robot<f64>,
    candidates: Option<&[Vec<f64>]>,
    targets: Option<&[Vec<f64>]>,
    options: &PlanOptions,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Result<Plan, PlanError> {
    let check = || {
        if cancelled() {
            Err(PlanError::Cancelled)
        } else {
            Ok(())
        }
    };
    let pool = pool(robot, candidates, options)?;
    check()?;
    let sockets = options.instrument.sockets().map_or(0, |s| s.sockets.len());
    let compliance = if options.compliance {
        compliance_joints(robot, &pool.q)
    } else {
        Vec::new()
    };
    let all = identifiable(
        robot,
        &pool.q,
        pool.socket_of.as_deref(),
        &compliance,
        options,
    );
    check()?;
    let rows = if options.instrument.orientation() {
        6
    } else {
        3
    };
    let distances = options
        .instrument
        .sockets()
        .map_or(0, |s| s.distances.len());
    // What the plan separates, and at least what `identify` asks equations
    // for (the independent parameters; for contacts, the points' and not the
    // base's).
    let counted =
        independent_parameter_count(robot, options.instrument.orientation()) + 3 * sockets;
    let unknowns =
        (all.params.len() + 3 * sockets).max(if sockets > 0 { counted - 6 } else { counted })
            + all.compliance.len();
    let equations = rows * options.poses + distances;
    let fewest = unknowns
        .saturating_sub(distances)
        .div_ceil(rows)
        .max(2 * sockets);
    if options.poses < fewest {
        return Err(PlanError::TooFewPoses {
            poses: options.poses,
            equations,
            parameters: unknowns,
            fewest,
        });
    }
    let workspace_drawn;
    let workspace = match targets {
        Some(t) => t,
        None => {
            workspace_drawn = within_limits(
                robot,
                options.workspace,
                0.0,
                Stream::Workspace.seed(options.seed),
            );
            &workspace_drawn
        }
    };
    check()?;
    let criterion = Criterion::of(robot, workspace, options, &pool, &all);
    check()?;
    let slots = match &pool.socket_of {
        Some(_) => sockets::slots(options.poses, sockets),
        None => vec![0; options.poses],
    };
    // The plan, and the other criterion's of as many poses for comparison
    // ([`choose`]).
    let other = match options.criterion {
        Optimality::I => Optimality::D,
        Optimality::D => Optimality::I,
    };
    let (chosen, other_picked) = choose(
        &criterion.design(robot, &pool),
        options.criterion,
        &slots,
        cancelled,
    )
    .ok_or(PlanError::Cancelled)?;
    let socket_at = |picked: &[usize]| {
        pool.socket_of
            .as_ref()
            .map(|s| picked.iter().map(|&c| s[c]).collect::<Vec<usize>>())
    };
    let poses: Vec<Vec<f64>> = chosen.iter().map(|&c| pool.q[c].clone()).collect();
    let at = socket_at(&chosen);
    let separated = identifiable(robot, &poses, at.as_deref(), &compliance, options);
    let missed = all.missed_by(&separated);
    if !missed.is_empty() {
        return Err(PlanError::NotIdentified {
            poses: options.poses,
            missed,
        });
    }
    let free = criterion.observable(&all);
    let predicted = criterion
        .predict(robot, &poses, at.as_deref(), &free)
        .expect("the plan identifies every parameter");
    // Another set of the candidates' poses judged as the plan is: what it
    // misses of what the plan identifies, else its predicted accuracy.
    let judged = |picked: &[usize]| -> Result<Prediction, Vec<String>> {
        let q: Vec<Vec<f64>> = picked.iter().map(|&c| pool.q[c].clone()).collect();
        let at = socket_at(picked);
        let missed = all.missed_by(&identifiable(
            robot,
            &q,
            at.as_deref(),
            &compliance,
            options,
        ));
        if missed.is_empty() {
            criterion
                .predict(robot, &q, at.as_deref(), &free)
                .ok_or(missed)
        } else {
            Err(missed)
        }
    };
    let random = judged(&random_picks(
        &pool,
        &slots,
        Stream::RandomPoses.seed(options.seed),
    ));
    let compared = Compared {
        criterion: other,
        predicted: judged(&other_picked),
    };
    let path = order::path(&poses, &middle(&pool.q, robot.dof()));
    let ordered: Vec<Vec<f64>> = path.iter().map(|&i| poses[i].clone()).collect();
    let socket_of: Vec<usize> =
        at.map_or_else(Vec::new, |at| path.iter().map(|&i| at[i]).collect());
    let kinematics = robot.prepare();
    let tool_point = |q: &Vec<f64>| {
        kinematics
            .forward(q)
            .map_or(Point3::origin(), |t| Point3::from(t.translation.vector))
    };
    let (rows, one_sided) = measurement_rows(robot, &ordered, options);
    let all_rows: Vec<usize> = (0..rows.len()).collect();
    let near_singular = rows
        .iter()
        .enumerate()
        .filter_map(|(i, q)| conditioning(robot, q).map(|c| (i, c)))
        .filter(|&(_, c)| c < NEAR_SINGULAR)
        .collect();
    Ok(Plan {
        near_singular,
        target_points: workspace.iter().map(tool_point).collect(),
        points: ordered.iter().map(tool_point).collect(),
        off_axis: match &pool.socket_of {
            Some(_) => None,
            None => off_axis(robot, (&poses, workspace), options, &separated),
        },
        path: order::length(&rows, &all_rows),
        q: rows,
        socket_of,
        one_sided,
        predicted,
        random,
        compared,
        identified: all.params,
        held: all.held,
        compliance: all.compliance,
        compliance_held: all.compliance_held,
        candidates: pool.q.len(),
        targets: workspace.len(),
    })
}

/// The candidates of `d` the plan measures, by `criterion`, and those the
/// other criterion chooses, for comparison: one for each of `slots` (the
/// socket of each pose of a socket plan; all 0 otherwise), in the order
/// chosen; `None` once `cancelled`. The D-optimal plan is the exchange's from
/// the greedy start ([`design::choose`], DETMAX's). The I-optimal plan is the
/// better of the I-optimal exchange's from the greedy start and from the
/// D-optimal plan: an exchange settles in a local optimum, and the D-optimal
/// plan is another start, as good as any (the I-criterion's landscape is
/// flat: a UR10e's plans of 20 poses from the greedy start, from the
/// D-optimal plan and from random ones end within 1.5 % of each other in
/// predicted RMS), which the I-optimal plan so never ends worse than.
fn choose(
    d: &Design,
    criterion: Optimality,
    slots: &[usize],
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<(Vec<usize>, Vec<usize>)> {
    let by = |o| design::choose(&d.candidates, o, &d.w, &d.prior, slots, &d.group, cancelled);
    let d_optimal = by(Optimality::D)?;
    let greedy = by(Optimality::I)?;
    let from_d = design::exchange(
        &d.candidates,
        Optimality::I,
        (&d.w, &d.prior),
        d_optimal.clone(),
        (slots, &d.group),
        (design::PASSES, design::SETTLED),
        cancelled,
    )?;
    let value = |p: &[usize]| {
        Optimality::I
            .criterion(&(&d.prior + d.candidates.information(p)), &d.w)
            .unwrap_or(f64::INFINITY)
    };
    let i_optimal = if value(&from_d) < value(&greedy) {
        from_d
    } else {
        greedy
    };
    Some(match criterion {
        Optimality::I => (i_optimal, d_optimal),
        Optimality::D => (d_optimal, i_optimal),
    })
}

/// With `robot`'s tool point on its last joint's axis, what the same
/// `poses` would identify and predict of a point [`OFF_AXIS`] off it, over
/// the targets `workspace` (`here`: what they separate at the tool point).
fn off_axis(
    robot: &Robot<f64>,
    (poses, workspace): (&[Vec<f64>], &[Vec<f64>]),
    options: &PlanOptions,
    here: &Separable,
) -> Option<OffAxis> {
    let (distance, square) = from_last_axis(robot, poses.first()?)?;
    if distance >= ON_AXIS {
        return None;
    }
    let mut moved = robot.clone();
    moved.tool.xyz += square * OFF_AXIS;
    let pool = Pool {
        q: poses.to_vec(),
        socket_of: None,
    };
    let there = identifiable(&moved, poses, None, &[], options);
    let criterion = Criterion::of(&moved, workspace, options, &pool, &there);
    let free = criterion.observable(&there);
    Some(OffAxis {
        distance,
        tool: moved.tool.xyz,
        gained: there
            .params
            .iter()
            .filter(|p| !here.params.contains(p))
            .copied()
            .collect(),
        predicted: criterion.predict(&moved, poses, None, &free),
    })
}

/// Below this [`conditioning`] a pose is near a singularity, and the plan
/// says so: for the UR10e, its wrist axes 4 and 6 within about 1.5° of each
/// other (`q5` near 0), where the controller turns joints 4 and 6 fast for a
/// small motion of the flange.
pub const NEAR_SINGULAR: f64 = 0.005;

/// How far `q` is from a singularity of `robot`: the smallest singular value
/// of its manipulator Jacobian over the largest, the rotation rows scaled by
/// the arm's reach (so that a radian and a reach weigh alike), over the
/// `min(6, M)` singular values. `None` where the chain cannot be evaluated.
pub fn conditioning(robot: &Robot<f64>, q: &[f64]) -> Option<f64> {
    let chain = robot.chain(q).ok()?;
    let j = chain.manipulator_jacobian();
    let reach = crate::session::measurements::reach(robot, std::iter::once(q)).max(1e-9);
    let m = nalgebra::DMatrix::from_fn(6, robot.dof(), |r, c| {
        let v = j.view()[(r, c)];
        if r < 3 { v * reach } else { v }
    });
    let s = m.singular_values();
    let largest = s.max();
    (largest > 0.0).then(|| s.min() / largest)
}

/// The configurations `options` lets a plan choose among: for a socket
/// plan, those that reach its sockets; else the `given` ones (or random
/// ones within the limits) whose tool point stays within the cell.
fn pool(
    robot: &Robot<f64>,
    given: Option<&[Vec<f64>]>,
    options: &PlanOptions,
) -> Result<Pool, PlanError> {
    if let Some(plate) = options.instrument.sockets() {
        let least = options.poses.div_ceil(plate.sockets.len().max(1)).max(2);
        let (q, socket_of) = sockets::candidates(
            robot,
            plate,
            options.candidates,
            least,
            options.margin,
            options.seed,
        )?;
        return Ok(Pool {
            q,
            socket_of: Some(socket_of),
        });
    }
    let drawn;
    let given = match given {
        Some(c) => c,
        None => {
            drawn = within_limits(robot, options.candidates, options.margin, options.seed);
            &drawn
        }
    };
    let bounds = Bounds::new(robot, options);
    let kept: Vec<Vec<f64>> = given.iter().filter(|q| bounds.hold(q)).cloned().collect();
    if kept.len() < options.poses {
        return Err(PlanError::TooFewCandidates {
            found: kept.len(),
            poses: options.poses,
        });
    }
    Ok(Pool {
        q: kept,
        socket_of: None,
    })
}

/// Where a pose may put the arm ([`PlanOptions::cell`],
/// [`PlanOptions::above_base`]).
struct Bounds<'a> {
    /// The robot's tool point, measurement frame.
    tool: armcal_shared::Prepared<f64>,
    /// Its flange (the last link's frame), in its own base frame.
    flange: armcal_shared::Prepared<f64>,
    /// Its tool point in its own base frame.
    tool_in_base: armcal_shared::Prepared<f64>,
    cell: &'a Cell,
    above_base: bool,
    /// The robot, for the conditioning of a pose.
    robot: &'a Robot<f64>,
    /// The least conditioning a pose may have.
    singularity_margin: f64,
}

impl<'a> Bounds<'a> {
    fn new(robot: &'a Robot<f64>, options: &'a PlanOptions) -> Self {
        let in_base = Robot {
            base: armcal_shared::Frame::identity(),
            ..robot.clone()
        };
        let flange = Robot {
            tool: armcal_shared::Frame::identity(),
            ..in_base.clone()
        };
        Self {
            tool: robot.prepare(),
            flange: flange.prepare(),
            tool_in_base: in_base.prepare(),
            cell: &options.cell,
            above_base: options.above_base,
            robot,
            singularity_margin: options.singularity_margin,
        }
    }

    /// Whether the arm at `q` keeps within them.
    fn hold(&self, q: &[f64]) -> bool {
        let in_cell = self
            .tool
            .forward(q)
            .is_ok_and(|t| self.cell.holds(&Point3::from(t.translation.vector)));
        let above = |k: &armcal_shared::Prepared<f64>| {
            k.forward(q).is_ok_and(|t| t.translation.vector.z >= 0.0)
        };
        let away = || {
            self.singularity_margin <= 0.0
                || conditioning(self.robot, q).is_some_and(|c| c >= self.singularity_margin)
        };
        in_cell
            && (!self.above_base || (above(&self.flange) && above(&self.tool_in_base)))
            && away()
    }
}

/// The middle of the joint ranges of `poses`: where the path starts from.
fn middle(poses: &[Vec<f64>], dof: usize) -> Vec<f64> {
    (0..dof)
        .map(|k| {
            let (lo, hi) = poses
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[k]), hi.max(q[k]))
                });
            0.5 * (lo + hi)
        })
        .collect()
}

/// The rows to measure `ordered` by, as `options` visits them: each once,
/// or each from both sides ([`order::both_sides`]) with the poses that
/// could not be.
fn measurement_rows(
    robot: &Robot<f64>,
    ordered: &[Vec<f64>],
    options: &PlanOptions,
) -> (Vec<Vec<f64>>, usize) {
    match options.visits {
        Visits::Once => (ordered.to_vec(), 0),
        Visits::BothSides => {
            let bounds = Bounds::new(robot, options);
            let limits: Vec<[f64; 2]> = robot
                .links
                .iter()
                .map(|l| margin_range(l, options.margin))
                .collect();
            let prismatic: Vec<bool> = robot
                .links
                .iter()
                .map(|l| l.joint == armcal_shared::JointType::Prismatic)
                .collect();
            order::both_sides(ordered, &limits, &prismatic, |q| bounds.hold(q))
        }
    }
}

/// What the plan minimises and predicts with: what the calibration will
/// estimate (every parameter of the full model but those a socket plan's
/// frame holds, the compliances asked, the sockets' centres), their prior
/// information (the prior's precision, and the known distances between
/// sockets), the workspace targets' position rows, the instrument's noise
/// (see the module header).
struct Criterion {
    columns: Vec<Column>,
    /// The information before any pose: the prior's and the distances'.
    prior: DMatrix<f64>,
    /// A socket plan's sockets.
    plate: Option<Sockets>,
    /// The targets' position rows, unweighted (m per unit parameter).
    g: DMatrix<f64>,
    /// The position noise and, when measured, the orientation noise.
    noise: (f64, Option<f64>),
}

/// The candidates, targets and prior [`design`] chooses by, in scaled
/// columns ([`Criterion::design`]).
struct Design {
    candidates: Candidates,
    w: DMatrix<f64>,
    prior: DMatrix<f64>,
    group: Vec<usize>,
}

impl Criterion {
    /// The criterion of `robot` over the targets `workspace`, for the poses
    /// of `pool`, of which `all` separate what they do.
    fn of(
        robot: &Robot<f64>,
        workspace: &[Vec<f64>],
        options: &PlanOptions,
        pool: &Pool,
        all: &Separable,
    ) -> Self {
        let sockets = options.instrument.sockets().map_or(0, |s| s.sockets.len());
        let gauge = match &pool.socket_of {
            Some(socket_of) => {
                let held: Vec<Param> = all.held.iter().map(|(p, _)| *p).collect();
                sockets::gauge(robot, &pool.q, socket_of, sockets, &held)
            }
            None => Vec::new(),
        };
        let columns: Vec<Column> = full_params(robot, options.instrument.orientation())
            .into_iter()
            .filter(|p| {
                // A socket plan's base and gauge are the frame of its sockets.
                let frame = sockets > 0 && matches!(p, Param::Base(_));
                !(frame || gauge.contains(p))
            })
            .map(Column::Param)
            .chain(all.compliance.iter().copied().map(Column::Compliance))
            .chain(
                (0..sockets)
                    .flat_map(|socket| (0..3).map(move |axis| Column::Socket { socket, axis })),
            )
            .collect();
        let mut prior = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            columns.len(),
            columns.iter().map(|c| match c {
                Column::Param(p) => options.prior.precision(*p),
                Column::Compliance(_) | Column::Socket { .. } => 0.0,
            }),
        ));
        let distances = distance_rows(options.instrument.sockets(), &columns);
        prior += distances.transpose() * &distances;
        let g = jacobian(robot, workspace, None, &columns, None);
        Self {
            g: if sockets > 0 {
                without_rigid_motion(robot, workspace, &g)
            } else {
                g
            },
            noise: (
                options.position_noise,
                options.instrument.orientation_noise(),
            ),
            prior,
            plate: options.instrument.sockets().cloned(),
            columns,
        }
    }

    /// The columns a plan can separate (`all`'s, and the sockets'): those
    /// the observability indices are of.
    fn observable(&self, all: &Separable) -> Vec<Column> {
        self.columns
            .iter()
            .copied()
            .filter(|c| match c {
                Column::Param(p) => all.params.contains(p),
                Column::Compliance(j) => all.compliance.contains(j),
                Column::Socket { .. } => true,
            })
            .collect()
    }

    /// What [`design`] chooses among: `pool`'s candidates' weighted rows,
    /// the targets' `W` and the prior, in columns scaled to a unit mean
    /// square per candidate, and each candidate's group.
    fn design(&self, robot: &Robot<f64>, pool: &Pool) -> Design {
        let rows = if self.noise.1.is_some() { 6 } else { 3 };
        let j = jacobian(
            robot,
            &pool.q,
            pool.socket_of.as_deref(),
            &self.columns,
            Some(self.noise),
        );
        // Columns scaled to a unit mean square per candidate.
        let scale: Vec<f64> = j
            .column_iter()
            .map(|c| {
                let rms = c.norm() / (pool.q.len() as f64).sqrt();
                if rms > 0.0 { 1.0 / rms } else { 1.0 }
            })
            .collect();
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(scale));
        let w = (self.g.transpose() * &self.g) / (self.g.nrows() / 3).max(1) as f64;
        Design {
            candidates: Candidates::of(rows, &(&j * &d)),
            w: &d * &w * &d,
            prior: &d * &self.prior * &d,
            group: pool
                .socket_of
                .clone()
                .unwrap_or_else(|| vec![0; pool.q.len()]),
        }
    }

    /// The predicted accuracy of measuring `q` (at the sockets `socket_of`
    /// for a socket plan; see the module header), the observability of the
    /// columns `free` (those a plan can separate); `None` when `q` and the
    /// prior do not determine every column.
    fn predict(
        &self,
        robot: &Robot<f64>,
        q: &[Vec<f64>],
        socket_of: Option<&[usize]>,
        free: &[Column],
    ) -> Option<Prediction> {
        let j = jacobian(robot, q, socket_of, &self.columns, Some(self.noise));
        let information = j.transpose() * &j + &self.prior;
        let cov = information.cholesky()?.inverse();
        let g = &self.g;
        let targets = g.nrows() / 3;
        let per_target: Vec<f64> = (0..targets)
            .map(|t| {
                let gt = g.rows(3 * t, 3);
                (gt * &cov * gt.transpose()).trace().max(0.0)
            })
            .collect();
        let mean = per_target.iter().sum::<f64>() / targets.max(1) as f64;
        let worst = per_target.iter().copied().fold(0.0, f64::max);
        // The observability of the rows and the known distances.
        let rows = jacobian(robot, q, socket_of, free, Some(self.noise));
        let distances = distance_rows(self.plate.as_ref(), free);
        let s = design::scaled_singular_values(&stack(&rows, &distances));
        // Each parameter's and each compliance's standard error.
        let (mut std, mut compliance) = (Vec::new(), Vec::new());
        for (k, column) in self.columns.iter().enumerate() {
            let s = cov[(k, k)].max(0.0).sqrt();
            match *column {
                Column::Param(p) => std.push((p, s)),
                Column::Compliance(joint) => compliance.push((joint, s)),
                Column::Socket { .. } => {}
            }
        }
        let sigma = self.noise.0;
        Some(Prediction {
            rms: mean.sqrt(),
            max: worst.sqrt(),
            measured_rms: (mean + 3.0 * sigma * sigma).sqrt(),
            std,
            compliance,
            observability: design::observability(&s, j.nrows()),
            per_target: per_target.iter().map(|v| v.sqrt()).collect(),
        })
    }
}

/// The targets' rows `g` less what a rigid motion of the whole workspace
/// would do (projected off the six rows of a small turn and shift of the
/// targets' nominal tool points): a socket plan's robot is known in the
/// frame of its sockets, and is registered to the cell afterwards.
fn without_rigid_motion(
    robot: &Robot<f64>,
    workspace: &[Vec<f64>],
    g: &DMatrix<f64>,
) -> DMatrix<f64> {
    let kinematics = robot.prepare();
    let points: Vec<nalgebra::Vector3<f64>> = workspace
        .iter()
        .map(|q| {
            kinematics
                .forward(q)
                .map_or(nalgebra::Vector3::zeros(), |t| t.translation.vector)
        })
        .collect();
    let centre = points.iter().sum::<nalgebra::Vector3<f64>>() / points.len().max(1) as f64;
    let mut rigid = DMatrix::zeros(3 * points.len(), 6);
    for (t, p) in points.iter().enumerate() {
        let r = p - centre;
        for a in 0..3 {
            rigid[(3 * t + a, a)] = 1.0;
        }
        // A turn ω moves the point by ω × r.
        let cross = r.cross_matrix();
        for a in 0..3 {
            for b in 0..3 {
                rigid[(3 * t + a, 3 + b)] = -cross[(a, b)];
            }
        }
    }
    let Some(normal) = (rigid.transpose() * &rigid).cholesky() else {
        return g.clone();
    };
    g - &rigid * normal.solve(&(rigid.transpose() * g))
}

/// The rows of the known distances between `plate`'s sockets, each divided
/// by its uncertainty, in `columns` (linearised at the nominal centres).
fn distance_rows(plate: Option<&Sockets>, columns: &[Column]) -> DMatrix<f64> {
    let Some(plate) = plate else {
        return DMatrix::zeros(0, columns.len());
    };
    let at = |socket: usize, axis: usize| {
        columns
            .iter()
            .position(|c| *c == Column::Socket { socket, axis })
    };
    let mut rows = DMatrix::zeros(plate.distances.len(), columns.len());
    for (r, d) in plate.distances.iter().enumerate() {
        let [a, b] = d.points;
        let u = (plate.sockets[a].centre - plate.sockets[b].centre).normalize() / d.std;
        for axis in 0..3 {
            if let (Some(i), Some(k)) = (at(a, axis), at(b, axis)) {
                rows[(r, i)] = u[axis];
                rows[(r, k)] = -u[axis];
            }
        }
    }
    rows
}

/// `a` over `b` (the same columns).
fn stack(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(a.nrows() + b.nrows(), a.ncols());
    out.rows_mut(0, a.nrows()).copy_from(a);
    out.rows_mut(a.nrows(), b.nrows()).copy_from(b);
    out
}

/// As many of `pool`'s candidates as `slots` (the socket of each, for a
/// socket plan), drawn at random among those of the slot's socket: the
/// random plan a planned one is compared with.
fn random_picks(pool: &Pool, slots: &[usize], seed: u64) -> Vec<usize> {
    let mut r = rng(seed);
    let group = |c: usize| pool.socket_of.as_ref().map_or(0, |s| s[c]);
    let groups = slots.iter().copied().max().map_or(0, |g| g + 1);
    let mut drawn: Vec<std::collections::VecDeque<usize>> = (0..groups)
        .map(|g| {
            let mut indices: Vec<usize> = (0..pool.q.len()).filter(|&c| group(c) == g).collect();
            let n = slots.iter().filter(|&&s| s == g).count().min(indices.len());
            for i in 0..n {
                let k = r.random_range(i..indices.len());
                indices.swap(i, k);
            }
            indices.truncate(n);
            indices.into()
        })
        .collect();
    slots.iter().filter_map(|&g| drawn[g].pop_front()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::fit::FitRequest;
    use crate::calibration::simulate::{measure, reach_point, with_random_errors};
    use crate::io::model_file::load_model;

    /// Asserts that `fit` identifies each of `params` (`what` names the case).
    fn assert_identified(fit: &crate::calibration::fit::FullFit, params: &[Param], what: &str) {
        for param in params {
            let status = &fit
                .params
                .iter()
                .find(|x| x.param == *param)
                .unwrap()
                .status;
            assert!(
                matches!(status, Status::Identified { .. }),
                "{what}: {param} {status:?}"
            );
        }
    }

    /// A plan of the fewest poses that give as many equations as the
    /// parameters it says it identifies does identify each of them: on a
    /// true robot off by up to 1 mm and 1 mrad, measured at the planned poses
    /// with 20 µm noise, `identify` (least squares) separates every one.
    /// For positions (UR10e with an SMR off the last axis, PUMA 560) and full
    /// poses (PUMA 560).
    #[test]
    fn a_plan_of_the_fewest_poses_identifies_every_parameter_it_says() {
        for (name, orientation) in [("ur10e", false), ("puma560", false), ("puma560", true)] {
            let mut robot = load_model(name).unwrap().robot;
            robot.tool.xyz = nalgebra::Vector3::new(0.06, 0.0, 0.08);
            let rows = if orientation { 6 } else { 3 };
            let asked = PlanOptions {
                instrument: if orientation {
                    Instrument::Poses {
                        orientation_noise: ORIENTATION_NOISE,
                    }
                } else {
                    Instrument::Positions
                },
                candidates: 3_000,
                ..PlanOptions::default()
            };
            let free = identifiable(
                &robot,
                &within_limits(&robot, 3_000, 0.05, 1),
                None,
                &[],
                &asked,
            )
            .params;
            let options = PlanOptions {
                poses: free.len().div_ceil(rows),
                ..asked
            };
            let p = plan(&robot, None, None, &options).unwrap();
            assert_eq!(p.identified, free);
            let params: Vec<Param> = robot.params().collect();
            let mut r = rng(4);
            let (truth, _) = with_random_errors(&robot, &params, 1e-3, 1e-3, &mut r);
            let noise = orientation.then_some(20e-6);
            let data = measure(&truth, &p.q, 20e-6, noise, &mut r);
            let fit = FitRequest::new(&robot, &data, &FullOptions::least_squares())
                .run()
                .unwrap();
            assert_identified(
                &fit,
                &p.identified,
                &format!("{name}, {} poses", options.poses),
            );
            // One pose fewer gives fewer equations than parameters: refused.
            let fewer = PlanOptions {
                poses: options.poses - 1,
                ..options.clone()
            };
            if rows * fewer.poses < free.len() {
                assert!(matches!(
                    plan(&robot, None, None, &fewer),
                    Err(PlanError::TooFewPoses { .. })
                ));
            }
        }
    }

    /// Every planned pose keeps its joints within their limits less the
    /// margin (±π for a revolute joint the model gives none), and its tool
    /// point within the cell.
    #[test]
    fn a_plan_keeps_within_the_limits_and_the_cell() {
        let robot = load_model("puma560").unwrap().robot;
        let cell = Cell {
            min: [-0.4, -0.6, 0.0],
            max: [0.8, 0.6, 1.0],
        };
        let options = PlanOptions {
            poses: 25,
            margin: 0.1,
            cell,
            candidates: 3_000,
            ..PlanOptions::default()
        };
        let p = plan(&robot, None, None, &options).unwrap();
        assert_eq!(p.q.len(), 25);
        for q in &p.q {
            for (l, v) in robot.links.iter().zip(q) {
                let pi = std::f64::consts::PI;
                let [lo, hi] = l.limits.unwrap_or([-pi, pi]);
                let keep = 0.1 * (hi - lo);
                assert!(lo + keep <= *v && *v <= hi - keep, "{v} in [{lo}, {hi}]");
            }
            let t = robot.forward(q).unwrap().translation.vector;
            assert!(cell.holds(&Point3::from(t)), "{t:?}");
        }
        let nowhere = PlanOptions {
            cell: Cell {
                min: [5.0, 5.0, 5.0],
                max: [6.0, 6.0, 6.0],
            },
            ..options
        };
        assert_eq!(
            plan(&robot, None, None, &nowhere).unwrap_err(),
            PlanError::TooFewCandidates {
                found: 0,
                poses: 25
            }
        );
    }

    /// A socket plan of the fewest poses identifies every parameter it says:
    /// a PUMA 560 with a ball 30 mm off its last axis on a 100 mm stem,
    /// every D-H parameter off by up to 1 mm and 1 mrad, seats the ball in
    /// three sockets (their distances known) at the planned configurations,
    /// each seating off by 20 µm; `identify` (least squares) separates each
    /// parameter the plan names.
    #[test]
    fn a_socket_plan_of_the_fewest_poses_identifies_every_parameter_it_says() {
        let mut robot = load_model("puma560").unwrap().robot;
        robot.tool.xyz = nalgebra::Vector3::new(0.03, 0.0, 0.1);
        let plate = crate::io::sockets::parse_sockets(
            "point,x,y,z\ns0,0.45,-0.15,0.1\ns1,0.45,0.15,0.1\ns2,0.6,0,0.1\n\
             distance,s0,s1,0.3\ndistance,s0,s2,0.2121320343559643\n",
            "plate.csv",
            &Default::default(),
        )
        .unwrap();
        let asked = PlanOptions {
            instrument: Instrument::Sockets(plate.clone()),
            candidates: 1_500,
            poses: 1,
            ..PlanOptions::default()
        };
        let Err(PlanError::TooFewPoses { fewest, .. }) = plan(&robot, None, None, &asked) else {
            panic!("one pose for three sockets is refused");
        };
        let p = plan(
            &robot,
            None,
            None,
            &PlanOptions {
                poses: fewest,
                ..asked
            },
        )
        .unwrap();
        assert_eq!(p.q.len(), fewest);
        let params: Vec<Param> = robot.params().collect();
        let mut r = rng(4);
        let (truth, _) = with_random_errors(&robot, &params, 1e-3, 1e-3, &mut r);
        let normal = rand_distr::Normal::new(0.0, 20e-6).unwrap();
        let reached: Vec<Vec<f64>> =
            p.q.iter()
                .zip(&p.socket_of)
                .map(|(q, &k)| {
                    use rand_distr::Distribution;
                    let seat = plate.sockets[k].centre
                        + nalgebra::Vector3::from_fn(|_, _| normal.sample(&mut r));
                    reach_point(&truth, q.clone(), &seat).unwrap()
                })
                .collect();
        let fit = FitRequest::new(
            &robot,
            &sockets::exact(&reached, &p.socket_of),
            &FullOptions::least_squares(),
        )
        .constrained(&sockets::constraints(&plate, &p.socket_of))
        .run()
        .unwrap();
        assert_identified(&fit, &p.identified, &format!("{fewest} poses"));
    }

    /// A UR10e with its wrist axes 4 and 6 aligned (`q5 = 0`) is at a
    /// singularity; 1° away the conditioning is still below the bound, 2°
    /// away above it, and at an ordinary pose (`q5` 69°) ten times above
    /// (the conditioning grows as `sin q5` until the arm's own limits it:
    /// 0.0033 at 1°, 0.0066 at 2°, 0.088 at 69°).
    #[test]
    fn a_pose_near_the_wrist_singularity_is_named() {
        let robot = crate::io::model_file::load_model("ur10e").unwrap().robot;
        let at = |q5: f64| conditioning(&robot, &[0.3, -1.2, 1.4, -0.7, q5, 0.4]).unwrap();
        assert!(at(0.0) < 1e-12, "{}", at(0.0));
        assert!(
            at(1f64.to_radians()) < NEAR_SINGULAR,
            "{}",
            at(1f64.to_radians())
        );
        assert!(
            at(2f64.to_radians()) > NEAR_SINGULAR,
            "{}",
            at(2f64.to_radians())
        );
        assert!(at(1.2) > 10.0 * NEAR_SINGULAR, "{}", at(1.2));
    }

    /// A plan can be kept safe to drive: among candidates with the UR10e's
    /// wrist within 1° of its singularity (`q5` forced into ±1° in every
    /// fourth candidate, where the controller would spin joints 4 and 6),
    /// none is planned at the margin [`NEAR_SINGULAR`], and none is named
    /// near a singularity; with the default margin 0 they are kept.
    #[test]
    fn no_pose_is_planned_near_a_singularity() {
        let robot = crate::io::model_file::load_model("ur10e").unwrap().robot;
        let mut candidates = within_limits(&robot, 2000, 0.05, 9);
        for q in candidates.iter_mut().step_by(4) {
            q[4] = q[4].rem_euclid(2f64.to_radians()) - 1f64.to_radians();
        }
        let options = PlanOptions {
            poses: 20,
            singularity_margin: NEAR_SINGULAR,
            ..PlanOptions::default()
        };
        let p = plan(&robot, Some(&candidates), None, &options).unwrap();
        assert!(p.near_singular.is_empty(), "{:?}", p.near_singular);
        for q in &p.q {
            assert!(conditioning(&robot, q).unwrap() >= NEAR_SINGULAR, "{q:?}");
        }
        let unguarded = PlanOptions {
            singularity_margin: 0.0,
            ..options
        };
        let all = plan(&robot, Some(&candidates), None, &unguarded).unwrap();
        // Every forced candidate out (and those the arm's other
        // singularities put near one).
        assert!(
            all.candidates - p.candidates >= candidates.len().div_ceil(4),
            "{} kept of {}",
            p.candidates,
            all.candidates
        );
    }

    /// A tool point on the last joint's axis (the UR10e's nominal flange
    /// point) is named with what an SMR 60 mm off it would gain: the same
    /// poses identify the wrist's parameters the axis hides (the UR10e's
    /// a5 and α5 at least) and predict that point as well as a plan does.
    /// A tool point already off the axis (60 mm) is not.
    #[test]
    fn a_tool_point_on_the_last_axis_is_told_what_an_smr_off_it_would_gain() {
        let mut robot = crate::io::model_file::load_model("ur10e").unwrap().robot;
        let options = PlanOptions {
            poses: 20,
            candidates: 2000,
            ..PlanOptions::default()
        };
        let p = plan(&robot, None, None, &options).unwrap();
        let o = p.off_axis.expect("on the axis");
        assert!(o.distance < 1e-9, "{}", o.distance);
        assert!((o.tool.norm() - OFF_AXIS).abs() < 1e-12);
        for gained in [Param::A(4), Param::Alpha(4)] {
            assert!(o.gained.contains(&gained), "{:?}", o.gained);
            assert!(p.held.iter().any(|(h, _)| *h == gained));
        }
        let there = o.predicted.expect("determined");
        assert!(there.rms < 2.0 * p.predicted.rms, "{there:?}");
        robot.tool.xyz = o.tool;
        let off = plan(&robot, None, None, &options).unwrap();
        assert!(off.off_axis.is_none());
    }

    /// A certified lower bound of the predicted RMS (m) of every design of
    /// `n` poses among `d`'s candidates, fractional ones included: the convex
    /// relaxation of the I-criterion `f(λ) = tr(W M(λ)⁻¹)`, `M(λ) = Π + n
    /// Σ_c λ_c J_cᵀ J_c`, `λ ≥ 0`, `Σ λ = 1`, by the multiplicative
    /// algorithm (`λ_c ← λ_c √d_c / Σ λ √d`, `d_c = tr(J_c M⁻¹ W M⁻¹ J_cᵀ)`)
    /// in `steps` steps; `f` is convex, so every step's `f(λ) − n (max_c d_c
    /// − Σ_c λ_c d_c)` (its linearisation's least over the simplex) is below
    /// the least `f`, and the largest is returned.
    fn relaxed_bound(d: &Design, n: f64, steps: usize) -> f64 {
        let (count, r) = (d.candidates.count(), d.candidates.rows);
        let jt = &d.candidates.jt;
        let mut lambda = vec![1.0 / count as f64; count];
        let mut bound = 0.0_f64;
        for _ in 0..steps {
            let mut weighed = jt.clone();
            for (c, l) in lambda.iter().enumerate() {
                weighed.columns_mut(c * r, r).scale_mut((n * l).sqrt());
            }
            let m = &d.prior + &weighed * weighed.transpose();
            let a = m
                .cholesky()
                .expect("the prior and the candidates determine M")
                .inverse();
            let value = (&a * &d.w).trace();
            let x = (&a * &d.w * &a * jt).component_mul(jt);
            let dc: Vec<f64> = (0..count).map(|c| x.columns(c * r, r).sum()).collect();
            let mean: f64 = lambda.iter().zip(&dc).map(|(l, d)| l * d).sum();
            let largest = dc.iter().copied().fold(0.0, f64::max);
            bound = bound.max(value - n * (largest - mean));
            let total: f64 = lambda.iter().zip(&dc).map(|(l, d)| l * d.sqrt()).sum();
            for (l, dc) in lambda.iter_mut().zip(&dc) {
                *l *= dc.sqrt() / total;
            }
        }
        bound.max(0.0).sqrt()
    }

    /// How near the best possible a plan is, and the D-optimal exchange
    /// beside it: for a UR10e and a PUMA 560 at their nominal tool point (on
    /// the last joint's axis), 20 poses among 2,000 candidates, the plan's
    /// predicted RMS is at most the D-optimal exchange's (its exchange is
    /// also run from that plan, [`choose`]), and within 5 % of the certified
    /// lower bound of every design of 20 poses from these candidates, even
    /// one of fractional poses ([`relaxed_bound`]); the D-optimal exchange
    /// is within 5 % of it too (4.7 % and 4.5 %: no choice of 20 poses from
    /// these candidates can be predicted 5 % better than it, and the
    /// prediction is the error `identify` delivers, `tests/plan.rs`).
    #[test]
    fn a_plan_is_within_five_per_cent_of_the_best_any_design_can_do() {
        for name in ["ur10e", "puma560"] {
            let robot = load_model(name).unwrap().robot;
            let options = PlanOptions {
                poses: 20,
                ..PlanOptions::default()
            };
            let candidates = within_limits(&robot, 2000, 0.05, 3);
            let p = plan(&robot, Some(&candidates), None, &options).unwrap();
            let d_optimal = p.compared.predicted.as_ref().unwrap().rms;
            let pool = pool(&robot, Some(&candidates), &options).unwrap();
            let all = identifiable(&robot, &pool.q, None, &[], &options);
            let workspace = within_limits(
                &robot,
                options.workspace,
                0.0,
                Stream::Workspace.seed(options.seed),
            );
            let criterion = Criterion::of(&robot, &workspace, &options, &pool, &all);
            let bound = relaxed_bound(&criterion.design(&robot, &pool), 20.0, 300);
            eprintln!(
                "{name}: predicted RMS µm: plan {:.3}, D-optimal exchange {:.3}, lower bound \
                 {:.3}: plan/bound {:.3}, D/bound {:.3}, bound/D {:.3}",
                p.predicted.rms * 1e6,
                d_optimal * 1e6,
                bound * 1e6,
                p.predicted.rms / bound,
                d_optimal / bound,
                bound / d_optimal,
            );
            assert!(p.predicted.rms <= d_optimal, "{name}");
            assert!(p.predicted.rms <= 1.05 * bound, "{name}");
            assert!(d_optimal <= 1.05 * bound, "{name}");
        }
    }
}
