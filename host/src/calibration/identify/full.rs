//! `--params full`: every identifiable geometric parameter, base and tool included.
//!
//! ## Model
//! The unknowns are, for every joint, the joint offset and the three link
//! parameters (`θ_m, s_m, a_m, α_m`: the offset is `θ` of a revolute joint and `s`
//! of a prismatic one), the six parameters of the base frame, and the tool: its
//! position (3) when only positions are measured, its full frame (6) when
//! orientations are measured too. Their columns are the analytic special
//! Jacobians of Mirman & Gupta (eqs. 51–54) and the base and tool columns of
//! [`armcal_shared::jacobian`].
//!
//! ## Residuals and weights
//! For each pose, the position residual `P_meas − P_model` (3 rows, with Jacobian
//! rows `dP = dη + νdφ × P`, eq. 8) and, when measured, the orientation residual:
//! the rotation vector of `R_meas R_modelᵀ` (3 rows, with the rotation part
//! `νdφ` of the columns). Rows are divided by the noise of their channel
//! ([`super::noise::Channel`]): `σ_p` for measured positions, `σ_r` for
//! orientations, and in a session without a tracker the noise of the kind of
//! contact (a tool point at a fixed point, on a plane), so that all are in
//! units of their noise and the fit is a weighted least-squares one.
//!
//! ## Initial estimate
//! The base and tool may be far from nominal (metres, tens of degrees). Before
//! the iterations they are estimated in closed form with the nominal joints:
//! positions only, by alternating the rigid registration of the nominal points
//! onto the measured ones (Kabsch/Horn, SVD) with the linear least-squares tool
//! position; full poses, by the chordal mean of the base and tool rotations and
//! the joint linear least squares of the base and tool positions.
//!
//! ## Identifiability
//! At the initial estimate the weighted Jacobian `J` of all unknowns is formed,
//! each column scaled to unit norm. The normal matrix `G = JᵀJ` (faer) is
//! factored by a rank-revealing Cholesky in the order of preference: base, tool,
//! then the joints base to tip (`θ, s, a, α` each). A parameter whose scaled
//! column keeps less than `1e-6` of its norm once the columns kept before it are
//! projected out cannot be separated from them by these data: it is held at its
//! nominal value (base and tool: at the closed-form estimate) and reported with the parameters it depends on and, where one
//! applies, the geometric reason (parallel axes). So the PUMA's `s3` beside `s2`
//! at `α2 = 0`, `θ1` beside `base.rz`, `s1` beside `base.z`. A parameter that is
//! separable in principle but whose standard error, given the columns kept
//! before it and the noise, would exceed [`FullOptions::max_std_length`] or
//! [`FullOptions::max_std_angle`] (10 mm, 10 mrad) is held at nominal too: the data
//! do not determine it. The noise is first the stated one; when the fit shows it
//! larger (variance factor above 1), the selection is made again with the noise
//! the residuals show, and the fit repeated.
//!
//! ## Solution
//! Levenberg–Marquardt on the identifiable parameters: the scaled normal
//! equations `(Gs + λI) δs = Jsᵀ r` solved by faer's Cholesky, a step accepted when
//! it lowers the weighted sum of squares. Converged when a step changes every
//! prediction by less than 1e-10 of its noise.
//!
//! `J` itself is never stored: the selection, the iterations and the statistics
//! need only, per channel (position, orientation rows), `JᵀJ`, `Jᵀr`, `rᵀr` and
//! the row count, summed pose by pose a block of poses at a time
//! (`NormalEquations`), so the fit's memory does not grow with the poses. Only
//! the diagnosis's [`linearize`] keeps the whole weighted Jacobian.
//!
//! ## Report
//! Standard errors `sqrt(diag(s² (JᵀJ)⁻¹))` with the a-posteriori variance factor
//! `s² = Σr²/(n − p)` (so they hold even when the stated noise is off by a
//! factor), the condition number of the scaled Jacobian, the observability index
//! O1 of Borm & Menq (1991), `(σ_1 ⋯ σ_p)^{1/p} / √n`, and the strongest
//! correlations of the estimates.

use armcal_shared::effects::{Effect, EffectModel, gravity_torques, joint_param};
use armcal_shared::jacobian::at_point;
use armcal_shared::{FrameAxis, JointType, Param, Robot, Twist, rotation_error};
use faer::linalg::matmul::{self, triangular, triangular::BlockStructure};
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{Accum, Mat, Par, Side};
use nalgebra::{DMatrix, DVector, IsometryMatrix3, Matrix3, Point3, Rotation3, Vector3};

use crate::calibration::parallel;
use std::borrow::Borrow;

use super::noise::{
    Channel, ChannelNoise, Noise, NoiseEstimate, NoiseSource, PerChannel, SETTLED, Weights,
};
use super::prior::{Geometry, PRIOR_FACTORS, Prior};

/// One unknown of the fit: a geometric parameter, or parameter `component` of
/// effect `effect` of the model's effect list.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Unknown {
    /// A D-H, base or tool parameter.
    Param(Param),
    /// A parameter of a non-geometric effect.
    Effect {
        /// Index into the effect list.
        effect: usize,
        /// Which of its parameters ([`Effect::parameter_mut`]).
        component: usize,
    },
    /// A coordinate of an unknown fixed point of a constraint session (base
    /// frame, m): a nuisance unknown estimated with the robot.
    Point {
        /// Index into [`Model::points`].
        point: usize,
        /// 0, 1, 2: x, y, z.
        axis: usize,
    },
    /// A parameter of an unknown plane of a constraint session
    /// ([`PlaneEstimate`]): a nuisance unknown estimated with the robot.
    Plane {
        /// Index into [`Model::planes`].
        plane: usize,
        /// 0, 1: the tilts of its normal; 2: its offset from the base origin (m).
        component: usize,
    },
}

/// An unknown plane `n · x = offset` (base frame, m), its unit normal `n =
/// frame · (a, b, 1)/|(a, b, 1)|`: `frame` is the start's (its z the start's
/// normal), `a`, `b` the tilts estimated from there, free of singularity near it.
#[derive(Clone, Debug)]
pub struct PlaneEstimate {
    /// The start's frame, its z the start's normal.
    pub frame: Rotation3<f64>,
    /// The tilts of the normal in that frame.
    pub tilt: [f64; 2],
    /// The plane's signed distance from the base origin along the normal, m.
    pub offset: f64,
}

impl PlaneEstimate {
    /// The plane through `centre` with unit normal `normal`.
    fn through(centre: &Point3<f64>, normal: &Vector3<f64>) -> Self {
        let z = normal.normalize();
        let helper = if z.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let x = helper.cross(&z).normalize();
        let y = z.cross(&x);
        Self {
            frame: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z])),
            tilt: [0.0, 0.0],
            offset: z.dot(&centre.coords),
        }
    }

    /// The unit normal.
    pub fn normal(&self) -> Vector3<f64> {
        self.frame * Vector3::new(self.tilt[0], self.tilt[1], 1.0).normalize()
    }

    /// The least-squares plane of `points` (at least three): through their
    /// centroid, normal to their least scatter (the eigenvector of the
    /// smallest eigenvalue of `Σ (x − c)(x − c)ᵀ`). Also the RMS distance of
    /// the points to it, m.
    pub fn least_squares(points: &[Vector3<f64>]) -> (Self, f64) {
        let n = points.len().max(1) as f64;
        let centre = points.iter().sum::<Vector3<f64>>() / n;
        let scatter: Matrix3<f64> = points
            .iter()
            .map(|x| (x - centre) * (x - centre).transpose())
            .sum();
        let eigen = scatter.symmetric_eigen();
        let smallest = eigen.eigenvalues.imin();
        let normal: Vector3<f64> = eigen.eigenvectors.column(smallest).into();
        let rms = (eigen.eigenvalues[smallest].max(0.0) / n).sqrt();
        (Self::through(&Point3::from(centre), &normal), rms)
    }

    /// The signed distance of `x` from the plane, along its normal, m.
    pub fn distance(&self, x: &Vector3<f64>) -> f64 {
        self.normal().dot(x) - self.offset
    }

    /// The derivative of the unit normal with respect to tilt `c` (0 or 1).
    fn normal_derivative(&self, c: usize) -> Vector3<f64> {
        let m = Vector3::new(self.tilt[0], self.tilt[1], 1.0);
        let (norm, u) = (m.norm(), m.normalize());
        let mut e = Vector3::zeros();
        e[c] = 1.0;
        self.frame * ((e - u * u[c]) / norm)
    }
}

/// The model being fitted: the geometric robot and its effects.
#[derive(Clone, Debug)]
pub struct Model {
    /// The geometric model (Hayati tilts included).
    pub robot: Robot<f64>,
    /// The non-geometric effects.
    pub effects: Vec<Effect<f64>>,
    /// The unknown fixed points of a constraint session, base frame, m (empty
    /// for measured coordinates).
    pub points: Vec<Point3<f64>>,
    /// The unknown planes of a constraint session (empty for measured coordinates).
    pub planes: Vec<PlaneEstimate>,
    /// The constraints the points come from: their names and the known distances.
    pub constraints: Constraints,
}

impl Model {
    /// The geometric model `robot` with `effects`, without fixed points.
    fn of(robot: Robot<f64>, effects: Vec<Effect<f64>>) -> Self {
        Self {
            robot,
            effects,
            points: Vec::new(),
            planes: Vec::new(),
            constraints: Constraints::default(),
        }
    }

    fn get(&self, u: Unknown) -> Option<f64> {
        match u {
            Unknown::Param(p) => self.robot.param(p),
            Unknown::Effect { effect, component } => self.effects.get(effect)?.parameter(component),
            Unknown::Point { point, axis } => self.points.get(point).map(|p| p[axis]),
            Unknown::Plane { plane, component } => {
                self.planes.get(plane).and_then(|p| match component {
                    0 | 1 => Some(p.tilt[component]),
                    2 => Some(p.offset),
                    _ => None,
                })
            }
        }
    }

    fn get_mut(&mut self, u: Unknown) -> Option<&mut f64> {
        match u {
            Unknown::Param(p) => self.robot.param_mut(p),
            Unknown::Effect { effect, component } => {
                self.effects.get_mut(effect)?.parameter_mut(component)
            }
            Unknown::Point { point, axis } => self.points.get_mut(point).map(|p| &mut p[axis]),
            Unknown::Plane { plane, component } => {
                self.planes.get_mut(plane).and_then(|p| match component {
                    0 | 1 => Some(&mut p.tilt[component]),
                    2 => Some(&mut p.offset),
                    _ => None,
                })
            }
        }
    }

    /// Where row `obs` says the tool point is: its measured position, or the
    /// current estimate of the fixed point it sits at.
    fn target(&self, obs: &Observation) -> Point3<f64> {
        match obs.fixed_point().and_then(|k| self.points.get(k)) {
            Some(p) => *p,
            None => obs.position,
        }
    }

    /// The name of an unknown in reports: the parameter name, or the effect
    /// parameter's (`c2` compliance of joint 2, `g2.sin1` … `g2.cos2` its gear
    /// harmonics, `b2` half its lost motion, `e2` its scale error, `kappa`).
    pub fn name(&self, u: Unknown) -> String {
        match u {
            Unknown::Param(p) => p.to_string(),
            Unknown::Effect { effect, component } => match self.effects.get(effect) {
                Some(e) => effect_parameter_name(e, component),
                None => format!("effect{effect}.{component}"),
            },
            Unknown::Point { point, axis } => format!(
                "point {}.{}",
                self.constraints
                    .points
                    .get(point)
                    .map_or("?", |p| p.name.as_str()),
                ["x", "y", "z"].get(axis).copied().unwrap_or("?")
            ),
            Unknown::Plane { plane, component } => format!(
                "plane {}.{}",
                self.constraints
                    .planes
                    .get(plane)
                    .map_or("?", |p| p.name.as_str()),
                ["tilt1", "tilt2", "offset"]
                    .get(component)
                    .copied()
                    .unwrap_or("?")
            ),
        }
    }
}

/// The report name of parameter `component` of `effect`.
pub fn effect_parameter_name(effect: &Effect<f64>, component: usize) -> String {
    let j = effect.joint().map_or(0, |j| j + 1);
    match effect {
        Effect::JointCompliance { .. } => format!("c{j}"),
        Effect::GearTransmission { .. } => {
            format!(
                "g{j}.{}",
                ["sin1", "cos1", "sin2", "cos2"]
                    .get(component)
                    .copied()
                    .unwrap_or("?")
            )
        }
        Effect::Backlash { .. } => format!("b{j}"),
        Effect::ThermalExpansion { .. } => "kappa".into(),
        Effect::EncoderScale { .. } => format!("e{j}"),
    }
}

use crate::io::measurements::Contact;
pub use crate::io::measurements::Observation;
pub use crate::session::constraints::Constraints;

/// Settings of the full identification.
#[derive(Clone, Copy, Debug)]
pub struct FullOptions {
    /// Position noise (one standard deviation per axis), m.
    pub position_noise: f64,
    /// Orientation noise (one standard deviation per axis), rad.
    pub orientation_noise: f64,
    /// Most Levenberg–Marquardt iterations.
    pub max_iterations: usize,
    /// Relative residual norm below which a scaled column is not separable.
    pub separability: f64,
    /// A length parameter whose standard error would exceed this (m) is held at
    /// nominal: the data do not determine it.
    pub max_std_length: f64,
    /// Likewise for an angle parameter (rad).
    pub max_std_angle: f64,
    /// Estimate base and tool in closed form before iterating.
    pub initial_estimate: bool,
    /// Whether `position_noise` is the user's or a starting value to estimate from.
    pub position_source: NoiseSource,
    /// Whether `orientation_noise` is the user's or a starting value to estimate from.
    pub orientation_source: NoiseSource,
    /// The noise of the rows of a tool point at an unknown fixed point, m;
    /// `None`: the position noise and its source.
    pub point_noise: Option<Noise>,
    /// The noise of the rows of a tool point on an unknown plane, m; `None`:
    /// the position noise and its source.
    pub plane_noise: Option<Noise>,
    /// The prior on the D-H parameter errors ([`Prior::NONE`]: least squares).
    pub prior: Prior,
    /// Which parameters are free; the others are held at nominal.
    pub geometry: Geometry,
}

impl FullOptions {
    /// Ordinary weighted least squares: no prior, the noise as stated (the
    /// default 0.1 mm and 0.1 mrad unless set). What the classical
    /// identification of the papers computes.
    pub fn least_squares() -> Self {
        Self {
            prior: Prior::NONE,
            ..Self::default().stated()
        }
    }

    /// These options starting from the noise `fit` used (for an estimated noise,
    /// a start that settles in a round or two; a stated one is as stated).
    pub fn at_noise_of(self, fit: &FullFit) -> Self {
        let contact = |c: Channel, own: Option<Noise>| {
            fit.noise.channel(c).map_or(own, |n| {
                Some(Noise {
                    sigma: n.used,
                    source: self.noise(c).source,
                })
            })
        };
        Self {
            position_noise: fit.noise.position.used,
            orientation_noise: fit
                .noise
                .orientation
                .map_or(self.orientation_noise, |o| o.used),
            point_noise: contact(Channel::Point, self.point_noise),
            plane_noise: contact(Channel::Plane, self.plane_noise),
            ..self
        }
    }

    /// These options with every noise stated (as given), not estimated.
    pub fn stated(self) -> Self {
        let stated = |n: Option<Noise>| {
            n.map(|n| Noise {
                source: NoiseSource::Stated,
                ..n
            })
        };
        Self {
            position_source: NoiseSource::Stated,
            orientation_source: NoiseSource::Stated,
            point_noise: stated(self.point_noise),
            plane_noise: stated(self.plane_noise),
            ..self
        }
    }

    /// The noise of channel `c`'s rows: its value and source (a contact's, the
    /// position noise's unless set).
    pub fn noise(&self, c: Channel) -> Noise {
        let position = Noise {
            sigma: self.position_noise,
            source: self.position_source,
        };
        match c {
            Channel::Position => position,
            Channel::Orientation => Noise {
                sigma: self.orientation_noise,
                source: self.orientation_source,
            },
            Channel::Point => self.point_noise.unwrap_or(position),
            Channel::Plane => self.plane_noise.unwrap_or(position),
        }
    }
}

impl Default for FullOptions {
    fn default() -> Self {
        Self {
            position_noise: 1e-4,
            orientation_noise: 1e-4,
            max_iterations: 100,
            separability: 1e-6,
            max_std_length: 0.01,
            max_std_angle: 0.01,
            initial_estimate: true,
            position_source: NoiseSource::Estimated,
            orientation_source: NoiseSource::Estimated,
            point_noise: None,
            plane_noise: None,
            prior: Prior::default(),
            geometry: Geometry::Full,
        }
    }
}

/// What became of one parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// Identified, with its standard error (SI units).
    Identified {
        /// One standard error, m or rad.
        std: f64,
    },
    /// Not identified: held at nominal because the data cannot separate it (a
    /// base or tool parameter at its closed-form estimate from the data, which
    /// the reason then says).
    Fixed {
        /// Why, for the engineer.
        reason: String,
    },
}

/// One parameter of the result.
#[derive(Clone, Debug)]
pub struct ParamResult {
    /// Which parameter.
    pub param: Param,
    /// Nominal value, SI.
    pub nominal: f64,
    /// Identified minus nominal, SI (angles wrapped to (−π, π]).
    pub error: f64,
    /// Identified or fixed.
    pub status: Status,
    /// The data's share in the estimate, 0 to 1 (the resolution matrix's
    /// diagonal): 1 when the data alone determine it, near 0 when the prior
    /// holds it, 0 when fixed.
    pub data_share: f64,
}

/// The result of the full identification.
#[derive(Clone, Debug)]
pub struct FullFit {
    /// Every parameter: base, tool, then the joints.
    pub params: Vec<ParamResult>,
    /// The calibrated model.
    pub calibrated: Robot<f64>,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// True if the last step was below the convergence threshold.
    pub converged: bool,
    /// How the last Levenberg–Marquardt iteration ended: the share of the
    /// weighted sum of squares its step removed (`(cost − new) / cost`), or
    /// `None` when no damping tried gave a step that lowered it.
    pub last_decrease: Option<f64>,
    /// RMS of the position residual (3-D distance), m.
    pub position_rms: f64,
    /// RMS of the orientation residual angle, rad (0 without orientation data).
    pub orientation_rms: f64,
    /// Condition number of the scaled, weighted Jacobian of the identified parameters.
    pub condition_number: f64,
    /// Observability index O1 (Borm & Menq) of the same matrix.
    pub observability: f64,
    /// The a-posteriori variance factor `s² = Σr²/(n − p)`, in units of the stated noise².
    pub variance_factor: f64,
    /// The strongest correlations between identified parameters, strongest first.
    pub correlations: Vec<(String, String, f64)>,
    /// The effects fitted with the geometry, with their parameters' statuses.
    pub effects: Vec<EffectFit>,
    /// Equations (rows).
    pub equations: usize,
    /// The redundancy: equations less the parameters' share they determine
    /// (`n − tr(H)`; `n − p` without a prior).
    pub redundancy: f64,
    /// The noise of each channel: used and shown by the residuals.
    pub noise: NoiseEstimate,
    /// How much another scale of the prior (a factor of [`PRIOR_FACTORS`])
    /// could change the sum of squares of the held-out residuals, in units
    /// of its sampling error (the first-order change of the fit between
    /// scales; see the function `prior_reach` of this module): 0 without a prior.
    pub prior_reach: f64,
    /// The unknown fixed points of a constraint session, estimated with the
    /// robot (empty for measured coordinates).
    pub points: Vec<PointFit>,
    /// The unknown planes of a constraint session, estimated with the robot.
    pub planes: Vec<PlaneFit>,
    /// The known distances of a constraint session as the fit leaves them:
    /// the distance between the estimated points less the stated one, m.
    pub distance_residuals: Vec<f64>,
}

/// One estimated unknown plane `normal · x = offset` (base frame).
#[derive(Clone, Debug)]
pub struct PlaneFit {
    /// Its name in the file.
    pub name: String,
    /// Its unit normal.
    pub normal: Vector3<f64>,
    /// Its signed distance from the base origin along the normal, m.
    pub offset: f64,
}

/// One estimated unknown fixed point.
#[derive(Clone, Debug)]
pub struct PointFit {
    /// Its name in the file.
    pub name: String,
    /// Its estimate, base frame, m.
    pub position: Point3<f64>,
    /// The standard error of each coordinate, m (NaN where held).
    pub std: Vector3<f64>,
}

impl FullFit {
    /// The weights of the rows of each channel at the noise the fit used (1
    /// for a channel without rows).
    pub fn weights(&self) -> Weights {
        PerChannel::from_fn(|c| 1.0 / self.noise_of(c))
    }

    /// The noise the fit divided channel `c`'s rows by (1 for a channel
    /// without rows).
    pub fn noise_of(&self, c: Channel) -> f64 {
        self.noise.channel(c).map_or(1.0, |n| n.used)
    }

    /// The fitted effects, with their identified parameters.
    pub fn fitted_effects(&self) -> Vec<Effect<f64>> {
        self.effects.iter().map(|e| e.effect).collect()
    }
}

/// One effect of the result: its identified parameters and their statuses (in
/// the order of [`Effect::parameter_mut`]).
#[derive(Clone, Debug)]
pub struct EffectFit {
    /// The effect with its identified parameters (SI).
    pub effect: Effect<f64>,
    /// Each parameter's status (standard error, or why it is held at zero).
    pub status: Vec<Status>,
}

/// Why the identification could not run.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum FullError {
    /// Fewer equations than identifiable parameters.
    #[error("{equations} equations for {unknowns} independent parameters: measure more poses")]
    TooFewEquations {
        /// Rows.
        equations: usize,
        /// Identifiable parameters.
        unknowns: usize,
    },
    /// A pose whose joint count is not the model's.
    #[error("pose {pose}: {got} joint values, the model has {expected} joints")]
    JointCount {
        /// 1-based pose index.
        pose: usize,
        /// Model joints.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// An effect acts on a joint the model does not have.
    #[error("an effect acts on joint {joint}, which the model does not have")]
    EffectJoint {
        /// 1-based joint.
        joint: usize,
    },
    /// A non-finite value appeared (the data or the model are unusable).
    #[error("the fit produced a value that is not finite: check units and joint order")]
    NonFinite,
    /// Rows at unknown points or planes given without their constraints (a
    /// computation that reads measured coordinates only).
    #[error(
        "pose {pose} names an unknown point or plane, but no constraints were given: \
         this computation reads measured coordinates only"
    )]
    ConstraintsMissing {
        /// 1-based pose index.
        pose: usize,
    },
}

/// The count of independent geometric parameters of a full calibration of
/// `robot`: `4R + 2P + 6` with orientation data, `4R + 2P + 3` with positions only.
pub fn independent_parameter_count(robot: &Robot<f64>, full_pose: bool) -> usize {
    let revolute = robot
        .links
        .iter()
        .filter(|l| l.joint == JointType::Revolute)
        .count();
    let prismatic = robot.dof() - revolute;
    4 * revolute + 2 * prismatic + if full_pose { 6 } else { 3 }
}

/// The unknowns of the full model, in the order of preference: base, tool, joints.
pub fn full_params(robot: &Robot<f64>, orientation: bool) -> Vec<Param> {
    let tool_axes: &[FrameAxis] = if orientation {
        &FrameAxis::ALL
    } else {
        &[FrameAxis::X, FrameAxis::Y, FrameAxis::Z]
    };
    FrameAxis::ALL
        .into_iter()
        .map(Param::Base)
        .chain(tool_axes.iter().copied().map(Param::Tool))
        .chain(
            (0..robot.dof())
                .flat_map(|m| [Param::Theta(m), Param::S(m), Param::A(m), Param::Alpha(m)]),
        )
        .collect()
}

/// Identifies every identifiable geometric parameter of `nominal` from `data`.
pub fn identify_full(
    nominal: &Robot<f64>,
    data: &[Observation],
    options: &FullOptions,
) -> Result<FullFit, FullError> {
    identify_with_effects(nominal, &[], &[], data, options)
}

/// Identifies the geometry of `nominal` together with the parameters of
/// `effects` (their starting values are the initial guesses, usually zero) and
/// the `extra` geometric parameters (Hayati tilts `Param::Beta` between nominally
/// parallel axes): the extended model of `armcal diagnose`. They come after the
/// model's own parameters in the order of preference.
pub fn identify_with_effects(
    nominal: &Robot<f64>,
    effects: &[Effect<f64>],
    extra: &[Param],
    data: &[Observation],
    options: &FullOptions,
) -> Result<FullFit, FullError> {
    identify_from(nominal, None, effects, extra, data, options)
}

/// [`identify_with_effects`] from the geometry of `start` (a fit of the same
/// data) instead of the nominal model and the closed-form base and tool: the
/// extended model's refit converges in a few iterations from the fit it extends.
pub fn identify_from(
    nominal: &Robot<f64>,
    start: Option<&Robot<f64>>,
    effects: &[Effect<f64>],
    extra: &[Param],
    data: &[Observation],
    options: &FullOptions,
) -> Result<FullFit, FullError> {
    identify_constrained(
        nominal,
        start,
        effects,
        extra,
        data,
        &Constraints::default(),
        options,
    )
}

/// [`identify_from`] for a session whose rows may sit at unknown fixed points
/// tied by known distances (`constraints`, see [`crate::session::constraints`])
/// instead of measuring coordinates: each point's three coordinates are
/// unknowns of the same fit (first in the order of preference), each distance
/// one more row weighted by its stated uncertainty. The base is then not
/// observable and is held at nominal with that reason. With no points this is
/// [`identify_from`].
pub fn identify_constrained(
    nominal: &Robot<f64>,
    start: Option<&Robot<f64>>,
    effects: &[Effect<f64>],
    extra: &[Param],
    data: &[Observation],
    constraints: &Constraints,
    options: &FullOptions,
) -> Result<FullFit, FullError> {
    let constrained = !constraints.is_empty();
    if let Some(i) = data.iter().position(|o| {
        o.fixed_point()
            .is_some_and(|k| k >= constraints.points.len())
            || o.on_plane().is_some_and(|k| k >= constraints.planes.len())
    }) {
        return Err(FullError::ConstraintsMissing { pose: i + 1 });
    }
    if let Some(joint) = effects
        .iter()
        .filter_map(|e| e.joint())
        .find(|j| *j >= nominal.dof())
    {
        return Err(FullError::EffectJoint { joint: joint + 1 });
    }
    for (i, obs) in data.iter().enumerate() {
        if obs.q.len() != nominal.dof() {
            return Err(FullError::JointCount {
                pose: i + 1,
                expected: nominal.dof(),
                got: obs.q.len(),
            });
        }
    }
    let orientation = data.iter().any(|o| o.orientation.is_some());
    // Every parameter of the full model and the extra tilts; the chosen geometry
    // frees some of the model's, the others are held at nominal.
    let all: Vec<Param> = full_params(nominal, orientation)
        .into_iter()
        .chain(extra.iter().copied())
        .collect();
    // Without a measured coordinate the base frame is arbitrary: the fixed
    // points are found in whatever frame the base sets.
    let base_unobservable = |p: &Param| constrained && matches!(p, Param::Base(_));
    let frees = |p: &Param| {
        (options.geometry.frees(nominal, *p) || extra.contains(p)) && !base_unobservable(p)
    };
    let held_by_model: Vec<(Unknown, String)> = all
        .iter()
        .filter(|p| !frees(p))
        .map(|p| {
            let reason = if base_unobservable(p) {
                "not observable: the data measure no coordinate (only unknown fixed points \
                 and distances between them), so the base frame is arbitrary; held at nominal"
                    .to_owned()
            } else {
                format!(
                    "held at nominal: the {} model does not free it",
                    options.geometry.name()
                )
            };
            (Unknown::Param(*p), reason)
        })
        .collect();
    let point_unknowns = (0..constraints.points.len())
        .flat_map(|point| (0..3).map(move |axis| Unknown::Point { point, axis }))
        .chain(
            (0..constraints.planes.len())
                .flat_map(|plane| (0..3).map(move |component| Unknown::Plane { plane, component })),
        );
    let mut params: Vec<Unknown> = point_unknowns
        .chain(all.iter().filter(|p| frees(p)).map(|p| Unknown::Param(*p)))
        .collect();
    for (effect, e) in effects.iter().enumerate() {
        params.extend(
            (0..e.parameter_count()).map(|component| Unknown::Effect { effect, component }),
        );
    }
    // However the columns happen to fall, fewer equations than the model's
    // independent parameters (Everett, Driels & Mooring) cannot determine it.
    let equations = LinearSystem::rows(data) + constraints.equations();
    let mut unknowns =
        independent_parameter_count(nominal, data.iter().all(|o| o.orientation.is_some()));
    if constrained {
        // No base (6), three coordinates per point.
        unknowns = (unknowns + 3 * constraints.points.len() + 3 * constraints.planes.len())
            .saturating_sub(6);
    }
    if equations < unknowns {
        return Err(FullError::TooFewEquations {
            equations,
            unknowns,
        });
    }

    let mut robot = Model::of(start.unwrap_or(nominal).clone(), effects.to_vec());
    if constrained {
        robot.constraints = constraints.clone();
        robot.points = vec![Point3::origin(); constraints.points.len()];
        robot.planes = vec![
            PlaneEstimate::through(&Point3::origin(), &Vector3::z());
            constraints.planes.len()
        ];
        initial_points_tool(
            &mut robot,
            data,
            options.initial_estimate && start.is_none(),
        );
    } else if options.initial_estimate && start.is_none() {
        initial_base_tool(&mut robot.robot, data);
    }
    // What this model does not free is nominal, whatever the start.
    for (u, _) in &held_by_model {
        if let (Unknown::Param(p), Some(v)) = (u, robot.get_mut(*u))
            && let Some(n) = nominal.param(*p)
        {
            *v = n;
        }
    }

    // Identifiability at the initial estimate; the fit; then, for an estimated
    // noise, the variance components and the fit again with their weights until
    // they settle. A stated noise is kept, but when the fit shows it
    // significantly larger the selection is made again with the noise the
    // residuals show.
    // The channels the data have rows in: each of those whose noise is not
    // stated is estimated.
    let present = PerChannel::from_fn(|c| match c {
        Channel::Position => true,
        Channel::Orientation => orientation,
        Channel::Point => data.iter().any(|o| o.fixed_point().is_some()),
        Channel::Plane => data.iter().any(|o| o.on_plane().is_some()),
    });
    let estimate =
        present.map(|c, &present| present && options.noise(c).source == NoiseSource::Estimated);
    let start = robot.clone();
    let mut noise = PerChannel::from_fn(|c| options.noise(c).sigma);
    let mut noise_scale = 1.0;
    let mut iterations = 0;
    let (mut free_params, mut fixed, mut converged, mut sys, mut prior, mut post);
    let mut last_decrease;
    let mut round = 0;
    loop {
        round += 1;
        let weights = Weights::of(&noise);
        let system = NormalEquations::accumulate(&robot, data, &params, &weights);
        let (free, f) = if constrained {
            constrained_subset(&params, &robot, data, options, noise_scale, &weights)
        } else {
            separable_subset(&system, &params, &robot, data, options, noise_scale)
        };
        fixed = f;
        if equations < free.len() && options.prior == Prior::NONE {
            return Err(FullError::TooFewEquations {
                equations,
                unknowns: free.len(),
            });
        }
        free_params = free.iter().map(|&k| params[k]).collect::<Vec<Unknown>>();
        // Parameters held fixed keep their nominal value (base and tool: their
        // closed-form estimate).
        let mut moved = false;
        for (p, _) in &fixed {
            let keep = match *p {
                Unknown::Param(Param::Base(_) | Param::Tool(_)) => start.get(*p),
                Unknown::Param(q) => nominal.param(q),
                Unknown::Effect { .. } | Unknown::Point { .. } | Unknown::Plane { .. } => {
                    start.get(*p)
                }
            };
            if let (Some(v), Some(slot)) = (keep, robot.get_mut(*p)) {
                moved |= *slot != v;
                *slot = v;
            }
        }
        // The linearisation of every parameter serves the first iteration unless a
        // held parameter was just moved back.
        let first = if moved {
            NormalEquations::accumulate(&robot, data, &free_params, &weights)
        } else {
            system.select_columns(&free)
        };
        prior = prior_terms(&free_params, nominal, &options.prior);
        // The fit of the free parameters at `weights` from the linearisation `first`.
        let solve = |robot: &mut Model, weights: &Weights, first| {
            levenberg_marquardt(robot, data, &free_params, weights, options, first, &prior)
        };
        let run;
        (run, converged, last_decrease, sys) = solve(&mut robot, &weights, first)?;
        iterations += run;
        post = Posterior::at(&sys, &prior);
        if estimate.0.contains(&true) {
            // The free parameters stay; each round reweighs the rows of the
            // solution's linearisation and iterates from there.
            loop {
                let next = noise.map(|c, &sigma| {
                    if estimate[c] {
                        ChannelNoise::update(sigma, post.omega[c], post.redundancy[c])
                    } else {
                        sigma
                    }
                });
                let settled = Channel::ALL
                    .iter()
                    .all(|&c| (next[c] / noise[c] - 1.0).abs() < SETTLED);
                if settled || round >= MAX_NOISE_ROUNDS {
                    break;
                }
                round += 1;
                let before = Weights::of(&noise);
                noise = next;
                let weights = Weights::of(&noise);
                let first = sys.reweighted(&before, &weights);
                let run;
                (run, converged, last_decrease, sys) = solve(&mut robot, &weights, first)?;
                iterations += run;
                post = Posterior::at(&sys, &prior);
            }
            break;
        }
        let variance_factor = post.variance_factor();
        // Select again only if the noise is significantly larger than stated: the
        // variance factor of correctly stated noise scatters about 1 with a
        // standard deviation of √(2/dof).
        let significant = 1.0 + 3.0 * (2.0 / post.redundancy().max(1.0)).sqrt();
        let new_scale = variance_factor.sqrt();
        if variance_factor <= significant * noise_scale * noise_scale {
            break;
        }
        let (free_again, _) = if constrained {
            constrained_subset(&params, &robot, data, options, new_scale, &weights)
        } else {
            let system = NormalEquations::accumulate(&robot, data, &params, &weights);
            separable_subset(&system, &params, &robot, data, options, new_scale)
        };
        noise_scale = new_scale;
        if free_again.iter().map(|&k| params[k]).collect::<Vec<_>>() == free_params {
            break;
        }
    }

    // Statistics at the solution (the last linearisation is at the solution).
    let (g, _, scale) = sys.scaled_normal_equations();
    let variance_factor = post.variance_factor();
    let eig = g.self_adjoint_eigenvalues(Side::Lower).unwrap_or_default();
    let (smin, smax) = (
        eig.first().copied().unwrap_or(0.0).max(0.0).sqrt(),
        eig.last().copied().unwrap_or(0.0).max(0.0).sqrt(),
    );
    let condition_number = if smin > 0.0 {
        smax / smin
    } else {
        f64::INFINITY
    };
    let observability = {
        let p = eig.len().max(1) as f64;
        let log_sum: f64 = eig
            .iter()
            .map(|l| 0.5 * l.max(f64::MIN_POSITIVE).ln())
            .sum();
        (log_sum / p).exp() / (equations.max(1) as f64).sqrt()
    };
    let prior_reach = prior_reach(&g, &scale, &robot, &free_params, &prior, equations);
    let mut correlations = Vec::new();
    let mut std_of = vec![f64::NAN; free_params.len()];
    if let Some(c) = &post.cov {
        for k in 0..free_params.len() {
            std_of[k] = (variance_factor * c[(k, k)]).sqrt() * scale[k];
            for l in 0..k {
                let rho = c[(k, l)] / (c[(k, k)] * c[(l, l)]).sqrt();
                correlations.push((robot.name(free_params[l]), robot.name(free_params[k]), rho));
            }
        }
    }
    correlations.sort_by(|a, b| b.2.abs().total_cmp(&a.2.abs()));
    correlations.truncate(5);

    let (position_rms, orientation_rms) = sys.residual_rms(&Weights::of(&noise));
    let channel = |c: Channel| ChannelNoise {
        source: options.noise(c).source,
        used: noise[c],
        shown: ChannelNoise::update(noise[c], post.omega[c], post.redundancy[c]),
        rows: post.rows[c],
        redundancy: post.redundancy[c],
    };
    let distance = (!constraints.distances.is_empty()).then(|| {
        let n = constraints.distances.len();
        let used = (constraints
            .distances
            .iter()
            .map(|d| d.std * d.std)
            .sum::<f64>()
            / n as f64)
            .sqrt();
        let (omega, redundancy) = post.distances;
        ChannelNoise {
            source: NoiseSource::Stated,
            used,
            shown: ChannelNoise::update(used, omega, redundancy),
            rows: n,
            redundancy,
        }
    });
    let noise_estimate = NoiseEstimate {
        position: channel(Channel::Position),
        orientation: orientation.then(|| channel(Channel::Orientation)),
        point: present[Channel::Point].then(|| channel(Channel::Point)),
        plane: present[Channel::Plane].then(|| channel(Channel::Plane)),
        distance,
    };
    let mut fixed_reason = fixed
        .into_iter()
        .chain(held_by_model)
        .collect::<std::collections::HashMap<_, _>>();
    let mut status_of = |u: Unknown| match free_params.iter().position(|p| *p == u) {
        Some(k) => (Status::Identified { std: std_of[k] }, post.share[k]),
        None => {
            let mut reason = fixed_reason
                .remove(&u)
                .unwrap_or_else(|| "not separable".into());
            // The error shown is then the registration's, not a fitted one.
            if let Unknown::Param(p @ (Param::Base(_) | Param::Tool(_))) = u
                && start.get(u) != nominal.param(p)
            {
                reason.push_str("; held at its closed-form estimate from the data, not at nominal");
            }
            (Status::Fixed { reason }, 0.0)
        }
    };
    let effect_fits: Vec<EffectFit> = robot
        .effects
        .iter()
        .enumerate()
        .map(|(effect, e)| EffectFit {
            effect: *e,
            status: (0..e.parameter_count())
                .map(|component| status_of(Unknown::Effect { effect, component }).0)
                .collect(),
        })
        .collect();
    let results = all
        .iter()
        .map(|&param| {
            let nominal_value = nominal.param(param).unwrap_or(0.0);
            let mut error = robot.robot.param(param).unwrap_or(0.0) - nominal_value;
            if param.is_angle() {
                error = wrap_angle(error);
            }
            let (status, data_share) = status_of(Unknown::Param(param));
            ParamResult {
                param,
                nominal: nominal_value,
                error,
                status,
                data_share,
            }
        })
        .collect();
    if !sys.cost().is_finite() {
        return Err(FullError::NonFinite);
    }
    let points = robot
        .constraints
        .points
        .iter()
        .zip(&robot.points)
        .enumerate()
        .map(|(point, (named, position))| PointFit {
            name: named.name.clone(),
            position: *position,
            std: Vector3::from_fn(|axis, _| {
                free_params
                    .iter()
                    .position(|u| *u == Unknown::Point { point, axis })
                    .map_or(f64::NAN, |k| std_of[k])
            }),
        })
        .collect();
    let distance_residuals = robot
        .constraints
        .distances
        .iter()
        .map(|d| {
            let [a, b] = d
                .points
                .map(|k| robot.points.get(k).copied().unwrap_or_else(Point3::origin));
            (a - b).norm() - d.length
        })
        .collect();
    let planes = robot
        .constraints
        .planes
        .iter()
        .zip(&robot.planes)
        .map(|(named, p)| PlaneFit {
            name: named.name.clone(),
            normal: p.normal(),
            offset: p.offset,
        })
        .collect();
    Ok(FullFit {
        points,
        planes,
        distance_residuals,
        params: results,
        calibrated: robot.robot,
        effects: effect_fits,
        iterations,
        converged,
        last_decrease,
        position_rms,
        orientation_rms,
        condition_number,
        observability,
        variance_factor,
        correlations,
        equations,
        redundancy: post.redundancy(),
        noise: noise_estimate,
        prior_reach,
    })
}

/// How much another scale of the prior could change the fit's held-out
/// error: the most, over the factors `f` of [`PRIOR_FACTORS`], of the change
/// of the predictions' sum of squares over the rows, in units of the sampling
/// error of that sum.
///
/// About the solution `x` at the prior precision `P` (centre `x₀`), the data's
/// normal matrix `G` gives the fit at `P_f = P/f²` to first order as the step
/// `(G + P_f) δ = −(P_f − P)(x − x₀)`, which moves the predictions by `Jδ`:
/// `δᵀGδ` in units of the noise², the most it can change the expected sum of
/// squares of the residuals of as many new rows. That sum, `n` rows of unit
/// variance, scatters by `√(2n)`: a change far below it is one no
/// cross-validation of these rows can see. The reach is `max_f δᵀGδ / √(2n)`;
/// `g` and the step are in the unit-diagonal scaling `scale` of
/// [`NormalEquations::scaled_normal_equations`].
fn prior_reach(
    g: &Mat<f64>,
    scale: &[f64],
    robot: &Model,
    free: &[Unknown],
    prior: &[(f64, f64)],
    rows: usize,
) -> f64 {
    let p = free.len();
    if p == 0 || rows == 0 {
        return 0.0;
    }
    // The prior's precision and the offset from its centre, scaled.
    let precision: Vec<f64> = (0..p).map(|k| prior[k].0 * scale[k] * scale[k]).collect();
    let offset: Vec<f64> = (0..p)
        .map(|k| {
            let x = robot.get(free[k]).unwrap_or(prior[k].1);
            if scale[k] > 0.0 {
                (x - prior[k].1) / scale[k]
            } else {
                0.0
            }
        })
        .collect();
    PRIOR_FACTORS
        .iter()
        .filter_map(|&f| {
            let mut n = g.clone();
            for k in 0..p {
                n[(k, k)] += precision[k] / (f * f);
            }
            let rhs = Mat::from_fn(p, 1, |k, _| {
                -(precision[k] / (f * f) - precision[k]) * offset[k]
            });
            let d = n.llt(Side::Lower).ok()?.solve(&rhs);
            let moved: f64 = (0..p)
                .map(|a| {
                    (0..p)
                        .map(|b| d[(a, 0)] * g[(a, b)] * d[(b, 0)])
                        .sum::<f64>()
                })
                .sum();
            moved
                .is_finite()
                .then(|| moved.max(0.0) / (2.0 * rows as f64).sqrt())
        })
        .fold(0.0, f64::max)
}

/// Most rounds of the variance-component iteration (each a fit from the last);
/// they settle in a handful.
const MAX_NOISE_ROUNDS: usize = 30;

/// The prior of each free unknown: its precision `1/τ²` (0 for none) and its
/// nominal value.
fn prior_terms(free: &[Unknown], nominal: &Robot<f64>, prior: &Prior) -> Vec<(f64, f64)> {
    free.iter()
        .map(|u| match u {
            Unknown::Param(p) => (prior.precision(*p), nominal.param(*p).unwrap_or(0.0)),
            Unknown::Effect { .. } | Unknown::Point { .. } | Unknown::Plane { .. } => (0.0, 0.0),
        })
        .collect()
}

/// `Σ (x − x_nominal)² / τ²` over the free unknowns of `robot`.
fn prior_cost(robot: &Model, free: &[Unknown], prior: &[(f64, f64)]) -> f64 {
    free.iter()
        .zip(prior)
        .filter(|(_, (precision, _))| *precision > 0.0)
        .map(|(u, (precision, centre))| {
            let d = robot.get(*u).unwrap_or(*centre) - centre;
            precision * d * d
        })
        .sum()
}

/// The posterior at a solution: the covariance of the scaled unknowns, each
/// channel's weighted sum of squares, rows and redundancy, and each unknown's
/// data share (see [`super::noise`] and [`super::prior`]).
struct Posterior {
    /// `(G + P)⁻¹` in the unit-diagonal scaling of the data's normal matrix `G`.
    cov: Option<Mat<f64>>,
    /// Weighted sums of squares per channel.
    omega: PerChannel<f64>,
    /// Rows per channel.
    rows: PerChannel<usize>,
    /// Redundancies per channel.
    redundancy: PerChannel<f64>,
    /// The known-distance rows: weighted sum of squares and redundancy.
    distances: (f64, f64),
    /// The diagonal of the resolution matrix `(G + P)⁻¹ G`.
    share: Vec<f64>,
}

impl Posterior {
    fn at(sys: &NormalEquations, prior: &[(f64, f64)]) -> Self {
        let (g, _, scale) = sys.scaled_normal_equations();
        let p = g.nrows();
        let mut n = g.clone();
        for (k, (precision, _)) in prior.iter().enumerate() {
            n[(k, k)] += precision * scale[k] * scale[k];
        }
        let cov = n.llt(Side::Lower).map(|l| l.inverse()).ok();
        let trace = |a: &Mat<f64>| match &cov {
            Some(c) => (0..p)
                .map(|i| (0..p).map(|j| c[(i, j)] * a[(j, i)]).sum::<f64>())
                .sum(),
            None => p as f64,
        };
        // Each channel's rows less the parameters' share they determine,
        // `tr(N⁻¹ J_cᵀ J_c)`; none for a channel without rows.
        let redundancy = sys.rows.map(|c, &rows| {
            if rows == 0 {
                return 0.0;
            }
            let gc = Mat::from_fn(p, p, |a, b| sys.jtj[c][(a, b)] * scale[a] * scale[b]);
            rows as f64 - trace(&gc)
        });
        let gd = Mat::from_fn(p, p, |a, b| sys.distances.jtj[(a, b)] * scale[a] * scale[b]);
        let td = trace(&gd);
        let share = (0..p)
            .map(|k| match &cov {
                Some(c) => (0..p).map(|j| c[(k, j)] * g[(j, k)]).sum::<f64>(),
                None => 1.0,
            })
            .collect();
        Self {
            cov,
            omega: sys.rtr,
            rows: sys.rows,
            redundancy,
            distances: (sys.distances.rtr, sys.distances.rows as f64 - td),
            share,
        }
    }

    /// The total redundancy.
    fn redundancy(&self) -> f64 {
        self.redundancy.0.iter().sum::<f64>() + self.distances.1
    }

    /// The a-posteriori variance factor: the weighted sum of squares over the redundancy.
    fn variance_factor(&self) -> f64 {
        let r = self.redundancy();
        if r > 0.0 {
            (self.omega.0.iter().sum::<f64>() + self.distances.0) / r
        } else {
            1.0
        }
    }
}

/// The model at a fit's solution and the unknowns of a linearisation about
/// it ([`linearize`], [`fold_normals`]): the fit's identified parameters, its
/// points, planes and effects, then `extra` and `effects`'s parameters.
struct AtFit {
    model: Model,
    unknowns: Vec<Unknown>,
    fitted: usize,
    precision: Vec<f64>,
    offset: Vec<f64>,
}

impl AtFit {
    fn of(
        fit: &FullFit,
        effects: &[Effect<f64>],
        extra: &[Param],
        constraints: &Constraints,
        prior: &Prior,
    ) -> Self {
        let mut model = Model::of(fit.calibrated.clone(), fit.fitted_effects());
        model.constraints = constraints.clone();
        model.points = fit.points.iter().map(|p| p.position).collect();
        model.planes = fit
            .planes
            .iter()
            .map(|p| PlaneEstimate::through(&Point3::from(p.normal * p.offset), &p.normal))
            .collect();
        let identified = |s: &Status| matches!(s, Status::Identified { .. });
        let mut unknowns: Vec<Unknown> = Vec::new();
        let mut offset: Vec<f64> = Vec::new();
        for p in fit.params.iter().filter(|p| identified(&p.status)) {
            unknowns.push(Unknown::Param(p.param));
            offset.push(p.error);
        }
        for (point, p) in fit.points.iter().enumerate() {
            unknowns.extend(
                (0..3)
                    .filter(|&a| p.std[a].is_finite())
                    .map(|axis| Unknown::Point { point, axis }),
            );
        }
        for plane in 0..fit.planes.len() {
            unknowns.extend((0..3).map(|component| Unknown::Plane { plane, component }));
        }
        for (effect, e) in fit.effects.iter().enumerate() {
            for (component, _) in e.status.iter().enumerate().filter(|(_, s)| identified(s)) {
                unknowns.push(Unknown::Effect { effect, component });
            }
        }
        let fitted = unknowns.len();
        unknowns.extend(extra.iter().map(|p| Unknown::Param(*p)));
        for e in effects {
            let effect = model.effects.len();
            model.effects.push(*e);
            unknowns.extend(
                (0..e.parameter_count()).map(|component| Unknown::Effect { effect, component }),
            );
        }
        // Only the geometry is off its nominal value: points, planes and effects
        // have no prior's centre.
        offset.resize(unknowns.len(), 0.0);
        let precision = unknowns
            .iter()
            .map(|u| match u {
                Unknown::Param(p) => prior.precision(*p),
                Unknown::Effect { .. } | Unknown::Point { .. } | Unknown::Plane { .. } => 0.0,
            })
            .collect();
        Self {
            model,
            unknowns,
            fitted,
            precision,
            offset,
        }
    }
}

/// The weighted linearisation of a fitted model, extended: the Jacobian columns
/// of `fit`'s identified unknowns (geometry, the identified coordinates of a
/// constraint session's points and every parameter of its planes, then its
/// effects' parameters), then of the `extra` geometric parameters, then of the
/// parameters of `effects` (at their values, usually zero), all at `fit`'s
/// solution; and the weighted residual. Rows as in the fit: per pose 3
/// position rows (divided by the noise of its kind), or 1 for a touch of a
/// plane, then 3 orientation rows when measured; then one row per known
/// distance of `constraints` (empty for a session of coordinates), after the
/// poses in [`Linearization::first_rows`] (a cross-validation trains on them
/// always). Each column carries its `prior` precision and its current offset
/// from nominal, so that a solve on any subset of the poses is the MAP step of
/// the fit. What [`crate::calibration::diagnose`] cross-validates models with,
/// by one Gauss–Newton step per fold.
pub fn linearize(
    fit: &FullFit,
    effects: &[Effect<f64>],
    extra: &[Param],
    data: &[Observation],
    constraints: &Constraints,
    prior: &Prior,
) -> Linearization {
    let AtFit {
        model,
        unknowns,
        fitted,
        precision,
        offset,
    } = AtFit::of(fit, effects, extra, constraints, prior);
    let weights = fit.weights();
    let sys = LinearSystem::build(&model, data, &unknowns, &weights);
    let distances = DistanceRows::rows(&model, &unknowns);
    let poses_rows = sys.j.nrows();
    let (j, r) = if distances.is_empty() {
        (sys.j, sys.r)
    } else {
        let rows = poses_rows + distances.len();
        let j = Mat::from_fn(rows, unknowns.len(), |i, c| {
            if i < poses_rows {
                sys.j[(i, c)]
            } else {
                distances[i - poses_rows].0[c]
            }
        });
        let r = Mat::from_fn(rows, 1, |i, _| {
            if i < poses_rows {
                sys.r[(i, 0)]
            } else {
                distances[i - poses_rows].1
            }
        });
        (j, r)
    };
    let mut first_rows = Vec::with_capacity(data.len() + distances.len());
    let mut row = 0;
    for obs in data {
        first_rows.push(row);
        row += obs.equations();
    }
    first_rows.extend(poses_rows..poses_rows + distances.len());
    Linearization {
        j,
        r,
        first_rows,
        contacts: data.iter().map(|o| o.contact).collect(),
        fitted,
        noise: data
            .iter()
            .map(|o| fit.noise_of(o.channel()))
            .chain(constraints.distances.iter().map(|d| d.std))
            .collect(),
        unknowns,
        precision,
        offset,
    }
}

/// A weighted linearisation ([`linearize`]).
pub struct Linearization {
    /// Weighted Jacobian, rows × unknowns.
    pub j: Mat<f64>,
    /// Weighted residual, rows × 1.
    pub r: Mat<f64>,
    /// The first row of each pose (its 3 position rows; then 3 orientation
    /// rows if measured), then of each known distance.
    pub first_rows: Vec<usize>,
    /// What each pose's tool point is held to, one per pose (its folds follow it:
    /// [`crate::calibration::diagnose::cross_validation::interleaved_folds`]).
    pub contacts: Vec<Contact>,
    /// How many leading columns are the fit's own unknowns.
    pub fitted: usize,
    /// The noise the position rows of each pose (the rows of its tool point:
    /// a measured position or a contact) are divided by, then of each
    /// distance row: m, in the order of [`Linearization::first_rows`].
    pub noise: Vec<f64>,
    /// The unknown of each column.
    pub unknowns: Vec<Unknown>,
    /// The prior precision `1/τ²` of each column (0: none).
    pub precision: Vec<f64>,
    /// Each column's value less its nominal value (its prior's centre), SI.
    pub offset: Vec<f64>,
}

impl Linearization {
    /// How many of [`Linearization::first_rows`] are poses; the others are
    /// known distances, which a cross-validation trains on in every fold.
    pub fn poses(&self) -> usize {
        self.contacts.len()
    }

    /// The rows of pose `i`.
    pub fn rows_of(&self, i: usize) -> std::ops::Range<usize> {
        self.first_rows[i]
            ..self
                .first_rows
                .get(i + 1)
                .copied()
                .unwrap_or(self.j.nrows())
    }
}

/// One fold's share of the normal equations about a fit ([`fold_normals`]).
pub struct FoldNormal {
    /// `JᵀJ` of the fold's pose rows, every channel, each row divided by its
    /// noise as in the fit.
    pub a: DMatrix<f64>,
    /// `Jᵀr` of the same rows.
    pub b: DVector<f64>,
    /// `JᵀJ` of its tool-point rows alone (a measured position or a
    /// contact; not the orientation), each row in m (multiplied back by its
    /// noise), so that `‖r − Jδ‖²` of those rows is in m².
    pub held_a: DMatrix<f64>,
    /// `Jᵀr` of the same rows, m.
    pub held_b: DVector<f64>,
    /// `rᵀr` of the same rows, m².
    pub held_rtr: f64,
    /// The fold's poses.
    pub poses: usize,
}

/// The normal equations about a fit's solution, summed fold by fold: all a
/// linearised k-fold cross-validation of the fit's unknowns at another prior
/// needs, in memory independent of the number of poses (`O(k p²)`).
pub struct FoldNormals {
    /// Each fold's.
    pub folds: Vec<FoldNormal>,
    /// `JᵀJ` and `Jᵀr` of the known distances (trained on in every fold).
    pub distances: (DMatrix<f64>, DVector<f64>),
    /// Each unknown's prior precision `1/τ²` (0: none).
    pub precision: Vec<f64>,
    /// Each unknown's value less its nominal value (its prior's centre), SI.
    pub offset: Vec<f64>,
}

/// The normal equations of the fit's unknowns (those of [`linearize`]
/// without effects or extras) at its solution, summed over the poses of each
/// fold: pose `i` in fold `fold[i]` of `k`. One pass over the poses, however
/// many folds.
pub fn fold_normals(
    fit: &FullFit,
    data: &[Observation],
    constraints: &Constraints,
    prior: &Prior,
    fold: &[usize],
    k: usize,
) -> FoldNormals {
    let AtFit {
        model,
        unknowns,
        precision,
        offset,
        ..
    } = AtFit::of(fit, &[], &[], constraints, prior);
    let weights = fit.weights();
    let p = unknowns.len();
    let matrix = |m: &Mat<f64>| DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)]);
    let vector = |v: &Mat<f64>| DVector::from_fn(v.nrows(), |i, _| v[(i, 0)]);
    let tool = [Channel::Position, Channel::Point, Channel::Plane];
    let folds = (0..k)
        .map(|f| {
            let poses: Vec<&Observation> = data
                .iter()
                .zip(fold)
                .filter(|&(_, &g)| g == f)
                .map(|(o, _)| o)
                .collect();
            let sums = NormalEquations::accumulate(&model, &poses, &unknowns, &weights);
            let mut fold = FoldNormal {
                a: DMatrix::zeros(p, p),
                b: DVector::zeros(p),
                held_a: DMatrix::zeros(p, p),
                held_b: DVector::zeros(p),
                held_rtr: 0.0,
                poses: poses.len(),
            };
            for c in Channel::ALL {
                let (a, b) = (matrix(&sums.jtj[c]), vector(&sums.jtr[c]));
                if tool.contains(&c) {
                    let s2 = fit.noise_of(c).powi(2);
                    fold.held_a += &a * s2;
                    fold.held_b += &b * s2;
                    fold.held_rtr += sums.rtr[c] * s2;
                }
                fold.a += a;
                fold.b += b;
            }
            fold
        })
        .collect();
    let distances = DistanceRows::of(&model, &unknowns);
    FoldNormals {
        folds,
        distances: (matrix(&distances.jtj), vector(&distances.jtr)),
        precision,
        offset,
    }
}

/// The damping Levenberg–Marquardt starts from, on the normal equations
/// scaled to a unit diagonal: Nielsen's `τ = 1e-6` for a start near the
/// solution (the nominal model and the closed-form base and tool are), so that
/// the first steps are Gauss–Newton's.
const LAMBDA_START: f64 = 1e-6;

/// Whether a step that lowers the weighted sum of squares (in units of the
/// noise², the prior's terms included) from `cost` by `decrease` is too small
/// to matter: less than 1e-8 of it, and never more than 1e-2. A Gauss–Newton
/// step `δ` lowers it by `δᵀGδ`, and no parameter moves by more than
/// `√(δᵀGδ)` of its standard error: by at most a tenth (adding at most 1 % to
/// its variance), however many poses.
fn negligible(decrease: f64, cost: f64) -> bool {
    decrease <= (1e-8 * cost).min(1e-2)
}

/// Levenberg–Marquardt on `free` from `robot`, minimising the weighted sum of
/// squares plus the prior's `Σ (x − x_nominal)²/τ²` (`prior`: precision and
/// nominal value of each free unknown): iterations, convergence, the share
/// of the sum its last iteration removed (`None` when no damping lowered it:
/// [`FullFit::last_decrease`]) and the linearisation at the solution.
fn levenberg_marquardt(
    robot: &mut Model,
    data: &[Observation],
    free_params: &[Unknown],
    weights: &Weights,
    options: &FullOptions,
    mut sys: NormalEquations,
    prior: &[(f64, f64)],
) -> Result<(usize, bool, Option<f64>, NormalEquations), FullError> {
    // One linearisation per trial: an accepted trial's normal equations are the
    // next iteration's, so each iteration costs one pass over the poses. `sys` is
    // the linearisation at `robot`.
    let mut cost = sys.cost() + prior_cost(robot, free_params, prior);
    let mut lambda = LAMBDA_START;
    let mut iterations = 0;
    let mut converged = false;
    let mut last_decrease = Some(0.0);
    while iterations < options.max_iterations && !converged {
        iterations += 1;
        let (mut g, mut rhs, scale) = sys.scaled_normal_equations();
        for (k, (precision, centre)) in prior.iter().enumerate() {
            if *precision > 0.0 {
                let x = robot.get(free_params[k]).unwrap_or(*centre);
                g[(k, k)] += precision * scale[k] * scale[k];
                rhs[(k, 0)] += precision * scale[k] * (centre - x);
            }
        }
        let mut accepted = false;
        for _ in 0..30 {
            let mut a = g.clone();
            for k in 0..a.nrows() {
                a[(k, k)] += lambda;
            }
            let Ok(llt) = a.llt(Side::Lower) else {
                lambda *= 10.0;
                continue;
            };
            let ds = llt.solve(&rhs);
            let step: Vec<f64> = (0..free_params.len())
                .map(|k| ds[(k, 0)] * scale[k])
                .collect();
            if step.iter().any(|s| !s.is_finite()) {
                return Err(FullError::NonFinite);
            }
            // The step in scaled parameters: its effect on the predictions in units
            // of their noise is at most |ds_k| per column (unit-norm columns).
            let size = (0..free_params.len())
                .map(|k| ds[(k, 0)].abs())
                .fold(0.0, f64::max);
            // Near Gauss–Newton, the linearisation at `robot` predicts what the step
            // would gain, `2δᵀb − δᵀGδ`: when that is negligible, `robot` is the
            // minimum and the pass over the poses that would confirm it is spared.
            if lambda <= LAMBDA_START
                && (size < 1e-10 || negligible(predicted_decrease(&g, &rhs, &ds), cost))
            {
                accepted = true;
                converged = true;
                break;
            }
            let mut trial = robot.clone();
            apply(&mut trial, free_params, &step);
            let trial_sys = NormalEquations::accumulate(&trial, data, free_params, weights);
            let trial_cost = trial_sys.cost() + prior_cost(&trial, free_params, prior);
            if trial_cost <= cost {
                // Converged when the step no longer matters: below 1e-10 of the
                // noise, or lowering the sum of squares negligibly.
                converged = size < 1e-10 || negligible(cost - trial_cost, cost);
                last_decrease = Some(if cost > 0.0 {
                    (cost - trial_cost) / cost
                } else {
                    0.0
                });
                (*robot, cost, sys) = (trial, trial_cost, trial_sys);
                lambda = (lambda / 10.0).max(1e-12);
                accepted = true;
                break;
            }
            if size < 1e-10 || negligible(trial_cost - cost, cost) {
                // A step this small, or one that raises the sum of squares by
                // less than matters (at the minimum its change is rounding),
                // changes nothing measurable: at a minimum.
                accepted = true;
                converged = true;
                break;
            }
            lambda *= 10.0;
        }
        if !accepted {
            converged = cost == 0.0;
            last_decrease = None;
            break;
        }
    }
    Ok((iterations, converged, last_decrease, sys))
}

/// The decrease of the weighted sum of squares that the linearisation with
/// normal matrix `g` and right-hand side `b` predicts for the step `d`:
/// `‖r‖² − ‖r − Jd‖² = 2dᵀb − dᵀGd`.
fn predicted_decrease(g: &Mat<f64>, b: &Mat<f64>, d: &Mat<f64>) -> f64 {
    let n = d.nrows();
    let mut decrease = 0.0;
    for k in 0..n {
        let gd: f64 = (0..n).map(|l| g[(k, l)] * d[(l, 0)]).sum();
        decrease += d[(k, 0)] * (2.0 * b[(k, 0)] - gd);
    }
    decrease
}

/// Wraps an angle to (−π, π].
fn wrap_angle(x: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let y = x.rem_euclid(two_pi);
    if y > std::f64::consts::PI {
        y - two_pi
    } else {
        y
    }
}

/// Adds `step` to `params` of `robot`.
fn apply(robot: &mut Model, params: &[Unknown], step: &[f64]) {
    for (p, d) in params.iter().zip(step) {
        if let Some(v) = robot.get_mut(*p) {
            *v += d;
        }
    }
}

/// The weighted Jacobian and residual of one linearisation, stored whole (rows ×
/// unknowns): what [`linearize`] hands the diagnosis, which solves on subsets of
/// the poses. The fit itself needs only [`NormalEquations`].
struct LinearSystem {
    /// Weighted Jacobian, rows × params.
    j: Mat<f64>,
    /// Weighted residual, rows × 1.
    r: Mat<f64>,
}

impl LinearSystem {
    fn rows(data: &[Observation]) -> usize {
        data.iter().map(Observation::equations).sum()
    }

    /// The linearisation at `model`: per pose its 3 position rows, then its 3
    /// orientation rows when measured ([`for_each_pose_rows`]); the poses in
    /// one piece per core, each piece filling its own rows.
    fn build(model: &Model, data: &[Observation], params: &[Unknown], weights: &Weights) -> Self {
        let rows = Self::rows(data);
        let mut j = Mat::zeros(rows, params.len());
        let mut r = Mat::zeros(rows, 1);
        let piece = data.len().div_ceil(parallel::cores()).max(MIN_PIECE_POSES);
        let mut pieces = Vec::new();
        let (mut j_rest, mut r_rest) = (j.as_mut(), r.as_mut());
        for poses in data.chunks(piece) {
            let n = Self::rows(poses);
            let (j_piece, j_after) = j_rest.split_at_row_mut(n);
            let (r_piece, r_after) = r_rest.split_at_row_mut(n);
            pieces.push((poses, j_piece, r_piece));
            (j_rest, r_rest) = (j_after, r_after);
        }
        parallel::each(pieces, |(poses, mut j, mut r)| {
            let mut row = 0;
            for_each_pose_rows(model, poses, params, weights, |pose| {
                let orientation = if pose.orientation { 3..6 } else { 0..0 };
                for i in (0..pose.position_rows).chain(orientation) {
                    r[(row, 0)] = pose.r[i];
                    for k in 0..params.len() {
                        j[(row, k)] = pose.row(i)[k];
                    }
                    row += 1;
                }
            });
        });
        Self { j, r }
    }
}

/// The fewest poses [`LinearSystem::build`] gives a core: about a µs each
/// (their rows of tens of columns), fewer take no longer than waking a
/// sleeping worker ([`parallel::map_if`]).
const MIN_PIECE_POSES: usize = 512;

/// The weighted rows of one pose: 3 position rows, then 3 orientation rows when
/// its orientation is measured.
struct PoseRows {
    /// Jacobian rows, 6 × params, row after row (rows 3..6 only meaningful when
    /// `orientation`).
    j: Vec<f64>,
    /// Params: the length of a row.
    params: usize,
    /// Residual rows (3..6 only meaningful when `orientation`).
    r: [f64; 6],
    /// Whether the orientation rows are present.
    orientation: bool,
    /// The position rows: 3, or 1 for a touch of a plane (its distance along
    /// the normal; rows 1..3 then hold zeros).
    position_rows: usize,
    /// The channel of the position rows: a measured position or a contact.
    channel: Channel,
}

impl PoseRows {
    /// Row `i` of the Jacobian.
    fn row(&self, i: usize) -> &[f64] {
        &self.j[i * self.params..(i + 1) * self.params]
    }
}

/// Hands `emit` the weighted rows of each pose in turn, linearised at `model`:
/// the one per-pose computation behind both the stored [`LinearSystem`] and the
/// accumulated [`NormalEquations`]. A pose whose kinematics fail is skipped (joint
/// counts are checked on entry, so none does).
///
/// With effects, each pose is evaluated at its temperature (thermal expansion
/// scales the lengths) and at the joint values `q + Δq(q, context)`; a joint
/// effect's column is the joint's column times `∂Δq_j/∂p`, thermal
/// expansion's is `ΔT Σ_i (a_i ∂/∂a_i + s_i ∂/∂s_i)`. The dependence of `Δq`
/// on the geometry (through the gravity torque) is left out of the Jacobian:
/// it only slows convergence, the residuals stay exact.
fn for_each_pose_rows<O: Borrow<Observation>>(
    model: &Model,
    data: &[O],
    params: &[Unknown],
    weights: &Weights,
    mut emit: impl FnMut(&PoseRows),
) {
    let wr = weights[Channel::Orientation];
    let robot = &model.robot;
    let kinematics = robot.prepare();
    let Some(Ok(mut chain)) = data.first().map(|o| kinematics.chain(&o.borrow().q)) else {
        return;
    };
    let mut rows = PoseRows {
        j: vec![0.0; 6 * params.len()],
        params: params.len(),
        r: [0.0; 6],
        orientation: false,
        position_rows: 3,
        channel: Channel::Position,
    };
    let base_columns = chain.base_columns();
    let effects = (!model.effects.is_empty())
        .then(|| EffectModel::new(robot.clone(), &model.effects).ok())
        .flatten();
    let thermal = model.effects.iter().find_map(|e| match e {
        Effect::ThermalExpansion {
            coefficient,
            reference,
        } => Some((*coefficient, *reference)),
        _ => None,
    });
    let needs_torque = model
        .effects
        .iter()
        .any(|e| matches!(e, Effect::JointCompliance { .. }));
    let mut q_eff: Vec<f64> = Vec::new();
    for obs in data {
        let obs: &Observation = obs.borrow();
        // Joint counts were checked on entry.
        let ctx = &obs.context;
        let delta_t = match (thermal, ctx.temperature) {
            (Some((_, reference)), Some(t)) => t - reference,
            _ => 0.0,
        };
        // The lengths at the pose's temperature: the chain of
        // `EffectModel::robot_at`, without preparing a model per pose.
        let length_scale = match (&effects, delta_t != 0.0) {
            (Some(em), true) => em.length_factor(ctx.temperature),
            _ => 1.0,
        };
        let mut tau: Vec<f64> = Vec::new();
        q_eff.clear();
        match &effects {
            Some(em) => {
                if needs_torque
                    && kinematics
                        .chain_scaled_into(&obs.q, length_scale, &mut chain)
                        .is_ok()
                {
                    tau = gravity_torques(robot, &chain, ctx.payload.unwrap_or(0.0)).to_vec();
                }
                q_eff.extend_from_slice(&em.joint_values_at(&obs.q, &tau, ctx));
            }
            None => q_eff.extend_from_slice(&obs.q),
        }
        if kinematics
            .chain_scaled_into(&q_eff, length_scale, &mut chain)
            .is_err()
        {
            continue;
        }
        let tool_columns = chain.tool_columns();
        let p = chain.point();
        let dp = model.target(obs) - p;
        let orientation = obs
            .orientation
            .map(|q| rotation_error(&q.to_rotation_matrix(), &chain.end.rotation));
        // A touch of a plane: one row, the distance along the normal.
        let touched = obs
            .on_plane()
            .and_then(|k| model.planes.get(k).map(|pl| (k, pl, pl.normal())));
        // The tool point's rows are weighed by the noise of their kind.
        let channel = obs.channel();
        let wp = weights[channel];
        for (k, &u) in params.iter().enumerate() {
            let col: Twist<f64> = match u {
                Unknown::Param(Param::Base(ax)) => base_columns[ax.index()],
                Unknown::Param(Param::Tool(ax)) => tool_columns[ax.index()],
                Unknown::Param(pm @ (Param::A(_) | Param::S(_))) => chain.column(pm) * length_scale,
                Unknown::Param(pm) => chain.column(pm),
                Unknown::Effect { effect, component } => {
                    let e = &model.effects[effect];
                    match e.joint() {
                        Some(jt) => {
                            let sens = e.joint_sensitivity(
                                component,
                                obs.q[jt],
                                tau.get(jt).copied().unwrap_or(0.0),
                                ctx,
                            );
                            chain.column(joint_param(robot, jt)) * sens
                        }
                        // Thermal expansion: every length, scaled by ΔT.
                        None => {
                            (0..robot.dof())
                                .map(|i| {
                                    let l = &robot.links[i];
                                    chain.column(Param::A(i)) * l.a
                                        + chain.column(Param::S(i)) * l.s
                                })
                                .fold(Twist::zeros(), |acc, c| acc + c)
                                * delta_t
                        }
                    }
                }
                Unknown::Plane { plane, component } => {
                    let n = params.len();
                    for i in 0..6 {
                        rows.j[i * n + k] = 0.0;
                    }
                    if let Some((own, pl, _)) = touched
                        && own == plane
                    {
                        // The plane's side of the row: `offset`, against the model's `n · p`.
                        rows.j[k] = wp
                            * match component {
                                0 | 1 => pl.normal_derivative(component).dot(&p.coords),
                                _ => -1.0,
                            };
                    }
                    continue;
                }
                Unknown::Point { point, axis } => {
                    // The row's target moves with its own point: −1 on the axis.
                    let n = params.len();
                    let own = obs.fixed_point() == Some(point);
                    for i in 0..6 {
                        rows.j[i * n + k] = if own && i == axis { -wp } else { 0.0 };
                    }
                    continue;
                }
            };
            let v = at_point(&col, &p);
            let n = params.len();
            if let Some((_, _, normal)) = touched {
                rows.j[k] = normal.dot(&Vector3::new(v[0], v[1], v[2])) * wp;
                for i in 1..6 {
                    rows.j[i * n + k] = 0.0;
                }
                continue;
            }
            for i in 0..3 {
                rows.j[i * n + k] = v[i] * wp;
            }
            if orientation.is_some() {
                for i in 0..3 {
                    rows.j[(3 + i) * n + k] = col[i] * wr;
                }
            }
        }
        for i in 0..3 {
            rows.r[i] = dp[i] * wp;
        }
        rows.position_rows = 3;
        rows.channel = channel;
        if let Some((_, pl, normal)) = touched {
            rows.r = [0.0; 6];
            rows.r[0] = (pl.offset - normal.dot(&p.coords)) * wp;
            rows.position_rows = 1;
        }
        rows.orientation = orientation.is_some() && touched.is_none();
        if let Some(e) = orientation {
            for i in 0..3 {
                rows.r[3 + i] = e[i] * wr;
            }
        }
        emit(&rows);
    }
}

/// Poses whose rows [`NormalEquations::accumulate`] gathers before adding their
/// products: large enough for the matrix product to run at full speed, small
/// enough (a few MB) not to matter.
const BLOCK_POSES: usize = 2048;

/// Poses whose normal equations [`NormalEquations::accumulate`] sums alone (on
/// one thread) before adding them to the others': a few blocks, so that 10⁵
/// poses already give each core several.
const CHUNK_POSES: usize = 8 * BLOCK_POSES;

/// The normal equations of one weighted linearisation, summed pose by pose: all
/// that the fit, the separability test, the posterior and the statistics need of
/// it, in memory independent of the number of poses (`O(p²)`, plus
/// `O(BLOCK_POSES · p)` while accumulating).
///
/// Per channel ([`Channel`]: measured positions and orientations, point and
/// plane contacts) of the weighted Jacobian `J` and residual `r` of
/// [`for_each_pose_rows`] — each row divided by its channel's noise (`σ_c` in
/// m, or rad for orientations), so the residual is
/// in units of the noise and a column is the change of the predictions, in units
/// of the noise, per SI unit of its unknown:
/// - `jtj`: `JᵀJ`, params × params;
/// - `jtr`: `Jᵀr`, params × 1;
/// - `rtr`: `rᵀr`, the channel's weighted sum of squares;
/// - `rows`: the channel's rows (3 per pose, 1 per touch of a plane; 3 per
///   pose with an orientation).
///
/// Each channel is kept apart for the per-channel redundancy of
/// [`Posterior`], and so that a change of the noises is a scalar multiply of
/// each channel ([`NormalEquations::reweighted`]).
///
/// The known distances of a constraint session are rows of their own
/// (`distances`), each divided by its stated uncertainty and never reweighed.
#[derive(Clone)]
struct NormalEquations {
    jtj: PerChannel<Mat<f64>>,
    jtr: PerChannel<Mat<f64>>,
    rtr: PerChannel<f64>,
    rows: PerChannel<usize>,
    distances: DistanceRows,
}

/// The normal equations of the known-distance rows: `(L − |P_a − P_b|)/σ`,
/// whose Jacobian row is `u/σ` on the columns of `P_a` and `−u/σ` on those of
/// `P_b` (`u` the unit vector from `P_b` to `P_a`).
#[derive(Clone)]
struct DistanceRows {
    jtj: Mat<f64>,
    jtr: Mat<f64>,
    rtr: f64,
    rows: usize,
}

impl DistanceRows {
    /// The rows of `model`'s distances over the unknowns `params`.
    fn of(model: &Model, params: &[Unknown]) -> Self {
        let p = params.len();
        let mut sums = Self {
            jtj: Mat::zeros(p, p),
            jtr: Mat::zeros(p, 1),
            rtr: 0.0,
            rows: model.constraints.distances.len(),
        };
        for (row, r) in Self::rows(model, params) {
            for i in 0..p {
                sums.jtr[(i, 0)] += row[i] * r;
                for j in 0..p {
                    sums.jtj[(i, j)] += row[i] * row[j];
                }
            }
            sums.rtr += r * r;
        }
        sums
    }

    /// Each distance's weighted Jacobian row over `params` and weighted residual.
    fn rows(model: &Model, params: &[Unknown]) -> Vec<(Vec<f64>, f64)> {
        let mut out = Vec::new();
        for d in &model.constraints.distances {
            let [a, b] = d
                .points
                .map(|k| model.points.get(k).copied().unwrap_or_else(Point3::origin));
            let v = a - b;
            let length = v.norm();
            let u = if length > 0.0 {
                v / length
            } else {
                Vector3::zeros()
            };
            let r = (d.length - length) / d.std;
            let row: Vec<f64> = params
                .iter()
                .map(|x| match *x {
                    Unknown::Point { point, axis } if point == d.points[0] => u[axis] / d.std,
                    Unknown::Point { point, axis } if point == d.points[1] => -u[axis] / d.std,
                    _ => 0.0,
                })
                .collect();
            out.push((row, r));
        }
        out
    }
}

impl NormalEquations {
    /// The normal equations of the linearisation at `model`: the poses in
    /// chunks of [`CHUNK_POSES`], each chunk's sums accumulated alone
    /// ([`NormalEquations::accumulate_chunk`]), on as many threads as the machine
    /// has, then added in pose order — the same sums whatever the number of
    /// threads.
    fn accumulate<O: Borrow<Observation> + Sync>(
        model: &Model,
        data: &[O],
        params: &[Unknown],
        weights: &Weights,
    ) -> Self {
        let chunks: Vec<&[O]> = data.chunks(CHUNK_POSES).collect();
        let partials = parallel::map(&chunks, |c| {
            Self::accumulate_chunk(model, c, params, weights)
        });
        let mut partials = partials.into_iter();
        let Some(mut sums) = partials.next() else {
            let mut sums = Self::accumulate_chunk(model, data, params, weights);
            sums.distances = DistanceRows::of(model, params);
            return sums;
        };
        sums.distances = DistanceRows::of(model, params);
        for part in partials {
            for c in Channel::ALL {
                sums.jtj[c] += &part.jtj[c];
                sums.jtr[c] += &part.jtr[c];
                sums.rtr[c] += part.rtr[c];
                sums.rows[c] += part.rows[c];
            }
        }
        sums
    }

    /// The normal equations of the poses `data` at `model`, their rows filled a
    /// block of [`BLOCK_POSES`] poses at a time into a reused block matrix
    /// whose `JᵀJ` (lower half) and `Jᵀr` are then added by faer's matrix product.
    fn accumulate_chunk<O: Borrow<Observation>>(
        model: &Model,
        data: &[O],
        params: &[Unknown],
        weights: &Weights,
    ) -> Self {
        let p = params.len();
        let mut rows = PerChannel::<usize>::default();
        for o in data {
            let o: &Observation = o.borrow();
            rows[o.channel()] += o.position_rows();
            rows[Channel::Orientation] += o.orientation_rows();
        }
        let mut sums = Self {
            jtj: PerChannel::from_fn(|_| Mat::zeros(p, p)),
            jtr: PerChannel::from_fn(|_| Mat::zeros(p, 1)),
            rtr: PerChannel::default(),
            rows,
            distances: DistanceRows {
                jtj: Mat::zeros(p, p),
                jtr: Mat::zeros(p, 1),
                rtr: 0.0,
                rows: 0,
            },
        };
        // Room for the rows of a block of poses in each channel the poses have.
        let block_rows = 3 * BLOCK_POSES.min(data.len().max(1));
        let capacity = rows.map(|_, &n| if n > 0 { block_rows } else { 0 });
        let mut block = Block {
            j: capacity.map(|_, &n| Mat::zeros(p, n)),
            r: capacity.map(|_, &n| Mat::zeros(n, 1)),
            filled: PerChannel::default(),
        };
        for_each_pose_rows(model, data, params, weights, |pose| {
            let orientation = pose.orientation.then_some((Channel::Orientation, 3, 3));
            for (c, offset, count) in
                std::iter::once((pose.channel, 0, pose.position_rows)).chain(orientation)
            {
                let row = block.filled[c];
                for i in 0..count {
                    block.r[c][(row + i, 0)] = pose.r[offset + i];
                    if p > 0 {
                        block
                            .row_mut(c, row + i)
                            .copy_from_slice(pose.row(offset + i));
                    }
                }
                block.filled[c] += count;
            }
            // Room for the next pose's rows in every channel.
            if Channel::ALL
                .iter()
                .any(|&c| capacity[c] > 0 && block.filled[c] + 3 > capacity[c])
            {
                block.add_to(&mut sums);
            }
        });
        block.add_to(&mut sums);
        // Mirror the lower halves.
        for g in &mut sums.jtj.0 {
            for a in 0..p {
                for b in a + 1..p {
                    g[(a, b)] = g[(b, a)];
                }
            }
        }
        sums
    }

    /// The weighted sum of squares of the residual.
    fn cost(&self) -> f64 {
        self.rtr.0.iter().sum::<f64>() + self.distances.rtr
    }

    /// `JᵀJ` of every channel and of the distance rows.
    fn normal_matrix(&self) -> Mat<f64> {
        let d = &self.distances.jtj;
        Mat::from_fn(d.nrows(), d.ncols(), |a, b| {
            self.jtj.0.iter().map(|g| g[(a, b)]).sum::<f64>() + d[(a, b)]
        })
    }

    /// `(Gs, Jsᵀr, scale)`: the normal matrix of the columns scaled to unit norm,
    /// its right-hand side, and the scale factors (`δ = scale · δs`). A zero column
    /// keeps scale 0 (it cannot move anything).
    fn scaled_normal_equations(&self) -> (Mat<f64>, Mat<f64>, Vec<f64>) {
        let g = self.normal_matrix();
        let n = g.nrows();
        let scale = unit_diagonal_scale(&g);
        let gs = Mat::from_fn(n, n, |a, b| g[(a, b)] * scale[a] * scale[b]);
        let d = &self.distances.jtr;
        let rhs = Mat::from_fn(n, 1, |a, _| {
            (self.jtr.0.iter().map(|v| v[(a, 0)]).sum::<f64>() + d[(a, 0)]) * scale[a]
        });
        (gs, rhs, scale)
    }

    /// The normal equations of the parameters `columns` (indices into this one's):
    /// their rows and columns.
    fn select_columns(&self, columns: &[usize]) -> Self {
        let n = columns.len();
        Self {
            jtj: self
                .jtj
                .map(|_, g| Mat::from_fn(n, n, |a, b| g[(columns[a], columns[b])])),
            jtr: self
                .jtr
                .map(|_, v| Mat::from_fn(n, 1, |a, _| v[(columns[a], 0)])),
            rtr: self.rtr,
            rows: self.rows,
            distances: DistanceRows {
                jtj: Mat::from_fn(n, n, |a, b| self.distances.jtj[(columns[a], columns[b])]),
                jtr: Mat::from_fn(n, 1, |a, _| self.distances.jtr[(columns[a], 0)]),
                rtr: self.distances.rtr,
                rows: self.distances.rows,
            },
        }
    }

    /// These normal equations with their rows weighed by `after` in place of
    /// `before`: the same linearisation at other noises, each channel
    /// multiplied by the square of its weight ratio.
    fn reweighted(&self, before: &Weights, after: &Weights) -> Self {
        let mut next = self.clone();
        for c in Channel::ALL {
            let ratio = after[c] / before[c];
            let f = ratio * ratio;
            let (g, v) = (&mut next.jtj[c], &mut next.jtr[c]);
            for b in 0..g.ncols() {
                for a in 0..g.nrows() {
                    g[(a, b)] *= f;
                }
                v[(b, 0)] *= f;
            }
            next.rtr[c] *= f;
        }
        next
    }

    /// RMS of the unweighted residual of the rows that locate the tool point
    /// (3-D distance of a measured position or a fixed point, m; a touch of a
    /// plane counts a third) and of the orientation residual angle (rad), from
    /// the sums of squares.
    fn residual_rms(&self, weights: &Weights) -> (f64, f64) {
        let located = [Channel::Position, Channel::Point, Channel::Plane];
        let sum = |c: Channel| self.rtr[c] / (weights[c] * weights[c]);
        let wr = weights[Channel::Orientation];
        rms_pair(
            located.iter().map(|&c| sum(c)).sum(),
            located.iter().map(|&c| self.rows[c]).sum::<usize>() / 3,
            self.rtr[Channel::Orientation] / (wr * wr),
            self.rows[Channel::Orientation] / 3,
        )
    }
}

/// The rows of up to [`BLOCK_POSES`] poses, per channel, waiting to be added to
/// [`NormalEquations`].
struct Block {
    /// The Jacobian rows, transposed: params × rows, a row of `J` a column here.
    j: PerChannel<Mat<f64>>,
    r: PerChannel<Mat<f64>>,
    /// Rows filled, per channel.
    filled: PerChannel<usize>,
}

impl Block {
    /// Row `row` of channel `c`'s Jacobian, to write.
    fn row_mut(&mut self, c: Channel, row: usize) -> &mut [f64] {
        self.j[c]
            .col_mut(row)
            .try_as_col_major_mut()
            .expect("a column of an owned matrix is contiguous")
            .as_slice_mut()
    }

    /// Adds the filled rows' `JᵀJ` (lower half), `Jᵀr` and `rᵀr` to `sums`, and
    /// empties the block.
    fn add_to(&mut self, sums: &mut NormalEquations) {
        for c in Channel::ALL {
            let n = self.filled[c];
            if n == 0 {
                continue;
            }
            let jt = self.j[c].as_ref().subcols(0, n);
            let r = self.r[c].as_ref().subrows(0, n);
            triangular::matmul(
                sums.jtj[c].as_mut(),
                BlockStructure::TriangularLower,
                Accum::Add,
                jt,
                BlockStructure::Rectangular,
                jt.transpose(),
                BlockStructure::Rectangular,
                1.0,
                Par::Seq,
            );
            matmul::matmul(sums.jtr[c].as_mut(), Accum::Add, jt, r, 1.0, Par::Seq);
            sums.rtr[c] += r.squared_norm_l2();
            self.filled[c] = 0;
        }
    }
}

/// The factors `1/√G_kk` that scale a normal matrix `G = JᵀJ` to a unit diagonal
/// (its columns of `J` to unit norm); 0 for a zero column, which cannot move anything.
pub(crate) fn unit_diagonal_scale(g: &Mat<f64>) -> Vec<f64> {
    (0..g.nrows()).map(|k| unit_scale(g[(k, k)])).collect()
}

/// The factor `1/√d` that scales a normal matrix's diagonal entry `d` to 1; 0
/// for a zero column.
pub(crate) fn unit_scale(d: f64) -> f64 {
    if d > 0.0 { 1.0 / d.sqrt() } else { 0.0 }
}

/// The rank-revealing Cholesky of the scaled normal matrix in the order of
/// preference: the indices of the separable parameters, and the others with the
/// reason each is not.
fn separable_subset(
    sys: &NormalEquations,
    params: &[Unknown],
    robot: &Model,
    data: &[Observation],
    options: &FullOptions,
    noise_scale: f64,
) -> (Vec<usize>, Vec<(Unknown, String)>) {
    let tolerance = options.separability;
    let (g, _, scale) = sys.scaled_normal_equations();
    let n = g.nrows();
    // Cholesky factor columns of the kept parameters: L[k] holds row k of L.
    let mut l = Mat::<f64>::zeros(n, n);
    let mut kept: Vec<usize> = Vec::new();
    let mut fixed = Vec::new();
    let tol2 = tolerance * tolerance;
    for k in 0..n {
        if scale[k] == 0.0 {
            fixed.push((
                params[k],
                "does not move the measured point or frame".to_string(),
            ));
            continue;
        }
        // Residual of column k after projecting out the kept columns: d = G_kk − Σ L_kj².
        let mut lk = vec![0.0; kept.len()];
        for (a, &i) in kept.iter().enumerate() {
            let mut s = g[(k, i)];
            for b in 0..a {
                s -= lk[b] * l[(i, b)];
            }
            lk[a] = s / l[(i, a)];
        }
        let d = g[(k, k)] - lk.iter().map(|x| x * x).sum::<f64>();
        // The standard error this parameter would have beside the ones kept so far.
        let std = noise_scale * scale[k] / d.max(0.0).sqrt();
        // Effect parameters have units of their own: only exact dependence holds them.
        // A parameter with a prior is held near nominal by the prior, not here.
        let (limit, unit) = match params[k] {
            // A constraint session's base, in its selection only: kept to
            // absorb the joint parameters that move the arm as it would.
            Unknown::Param(Param::Base(_)) if !robot.points.is_empty() => (f64::INFINITY, ""),
            Unknown::Param(p) if options.prior.precision(p) > 0.0 => (f64::INFINITY, ""),
            Unknown::Param(p) if p.is_angle() => (options.max_std_angle, "rad"),
            Unknown::Plane {
                component: 0 | 1, ..
            } => (options.max_std_angle, "rad"),
            Unknown::Param(_) | Unknown::Point { .. } | Unknown::Plane { .. } => {
                (options.max_std_length, "m")
            }
            Unknown::Effect { .. } => (f64::INFINITY, ""),
        };
        if d > tol2 && std > limit {
            fixed.push((
                params[k],
                format!("not determined by these data: its standard error would be {std:.2e} {unit}, above {limit:.0e} {unit}"),
            ));
        } else if d > tol2 {
            let a = kept.len();
            for (b, v) in lk.iter().enumerate() {
                l[(k, b)] = *v;
            }
            l[(k, a)] = d.sqrt();
            kept.push(k);
        } else {
            fixed.push((
                params[k],
                dependence_reason(k, &kept, &g, params, robot, data),
            ));
        }
    }
    (kept, fixed)
}

/// [`separable_subset`] of a constraint session's unknowns `params` (the
/// points first; no base): the selection is made with the six base columns
/// after the points, as though the base were free, and the base then left out.
/// A joint parameter that moves the whole arm as the base would (`θ1`, `s1`
/// about a first axis along the base z) is so held as not separable from the
/// base, exactly at any linearisation, where beside the points alone it would
/// be only at the solution (the start's tool points of one point's rows are
/// apart by the model's errors).
fn constrained_subset(
    params: &[Unknown],
    robot: &Model,
    data: &[Observation],
    options: &FullOptions,
    noise_scale: f64,
    weights: &Weights,
) -> (Vec<usize>, Vec<(Unknown, String)>) {
    let points = params
        .iter()
        .take_while(|u| matches!(u, Unknown::Point { .. } | Unknown::Plane { .. }))
        .count();
    let selection: Vec<Unknown> = params[..points]
        .iter()
        .copied()
        .chain(
            FrameAxis::ALL
                .into_iter()
                .map(|a| Unknown::Param(Param::Base(a))),
        )
        .chain(params[points..].iter().copied())
        .collect();
    let system = NormalEquations::accumulate(robot, data, &selection, weights);
    let (kept, fixed) = separable_subset(&system, &selection, robot, data, options, noise_scale);
    let is_base = |u: &Unknown| matches!(u, Unknown::Param(Param::Base(_)));
    let free = kept
        .into_iter()
        .filter_map(|k| params.iter().position(|u| *u == selection[k]))
        .collect();
    let fixed = fixed
        .into_iter()
        .filter(|(u, _)| !is_base(u))
        .map(|(u, reason)| {
            if reason.contains("base.") {
                (
                    u,
                    format!("{reason} (a motion of the base frame, which these data cannot see)"),
                )
            } else {
                (u, reason)
            }
        })
        .collect();
    (free, fixed)
}

/// Names the kept parameters that column `k` depends on, and the geometry behind it.
fn dependence_reason(
    k: usize,
    kept: &[usize],
    g: &Mat<f64>,
    params: &[Unknown],
    robot: &Model,
    data: &[Observation],
) -> String {
    // Least-squares coefficients of column k on the kept columns: G_SS c = G_Sk.
    let n = kept.len();
    let gss = Mat::from_fn(n, n, |a, b| g[(kept[a], kept[b])]);
    let gsk = Mat::from_fn(n, 1, |a, _| g[(kept[a], k)]);
    let mut names: Vec<(f64, Unknown)> = match gss.llt(Side::Lower) {
        Ok(llt) => {
            let c = llt.solve(&gsk);
            (0..n).map(|a| (c[(a, 0)].abs(), params[kept[a]])).collect()
        }
        Err(_) => Vec::new(),
    };
    names.sort_by(|a, b| b.0.total_cmp(&a.0));
    let top = names.first().map_or(0.0, |x| x.0);
    let list: Vec<String> = names
        .iter()
        .take_while(|x| x.0 >= 0.1 * top && x.0 > 0.0)
        .take(3)
        .map(|x| robot.name(x.1))
        .collect();
    let mut reason = if list.is_empty() {
        "not separable by these data".to_string()
    } else {
        format!("not separable from {}", list.join(", "))
    };
    let geometry = match params[k] {
        // Without a measured coordinate the first axis is a line of the arbitrary frame.
        Unknown::Param(Param::Theta(0)) if !robot.constraints.is_empty() => Some(
            "a turn about axis 1 moves every tool point as a turn of the base would, and no \
             coordinate is measured"
                .into(),
        ),
        Unknown::Param(Param::S(0)) if !robot.constraints.is_empty() => Some(
            "a shift along axis 1 moves every tool point as a shift of the base would, and no \
             coordinate is measured"
                .into(),
        ),
        Unknown::Param(p) => geometry_reason(p, &robot.robot, data),
        Unknown::Effect { .. } | Unknown::Point { .. } | Unknown::Plane { .. } => None,
    }
    .or_else(|| {
        names
            .iter()
            .take_while(|x| x.0 >= 0.1 * top && x.0 > 0.0)
            .take(3)
            .any(|(_, u)| matches!(u, Unknown::Point { .. } | Unknown::Plane { .. }))
            .then(|| {
                "it moves every tool point alike, and the unknown fixed points move with it \
                 (a motion of the frame they are found in)"
                    .to_owned()
            })
    });
    if let Some(geometry) = geometry {
        reason.push_str(": ");
        reason.push_str(&geometry);
    }
    reason
}

/// The geometric reason for a dependence, where one is recognised: consecutive
/// parallel joint axes, or the first joint axis parallel to the measurement frame's z.
fn geometry_reason(param: Param, robot: &Robot<f64>, data: &[Observation]) -> Option<String> {
    let chain = robot.chain(&data.first()?.q).ok()?;
    let parallel = |a: &Vector3<f64>, b: &Vector3<f64>| a.cross(b).norm() < 1e-9;
    let m = match param {
        Param::Theta(m) | Param::S(m) => m,
        _ => return None,
    };
    if m > 0 && parallel(&chain.axes[m].w, &chain.axes[m - 1].w) {
        return Some(format!("axes {} and {} parallel", m, m + 1));
    }
    if m == 0 && parallel(&chain.axes[0].w, &Vector3::z()) {
        return Some("axis 1 parallel to the measurement frame's z".into());
    }
    None
}

/// RMS of the position residual (m) and of the orientation angle (rad).
pub fn residual_rms(robot: &Robot<f64>, data: &[Observation]) -> (f64, f64) {
    let (mut pos, mut rot, mut n_rot) = (0.0, 0.0, 0usize);
    let kinematics = robot.prepare();
    for obs in data {
        if let Ok(t) = kinematics.forward(&obs.q) {
            pos += (obs.position.coords - t.translation.vector).norm_squared();
            if let Some(q) = obs.orientation {
                rot += rotation_error(&q.to_rotation_matrix(), &t.rotation).norm_squared();
                n_rot += 1;
            }
        }
    }
    rms_pair(pos, data.len(), rot, n_rot)
}

/// `(√(pos / n), √(rot / n_rot))` from sums of squares, 0 for an empty sum.
fn rms_pair(pos: f64, n: usize, rot: f64, n_rot: usize) -> (f64, f64) {
    let rms = |sum: f64, k: usize| if k > 0 { (sum / k as f64).sqrt() } else { 0.0 };
    (rms(pos, n), rms(rot, n_rot))
}

/// The most poses the closed-form estimate of base and tool reads: evenly
/// spaced over a longer session. A start for the fit, which then reads every
/// pose; at this many its own scatter is below a hundredth of the noise.
const START_POSES: usize = 10_000;

/// The closed-form estimate of base and tool with the nominal joints (see the
/// module header), from at most [`START_POSES`] of the poses.
fn initial_base_tool(robot: &mut Robot<f64>, data: &[Observation]) {
    let step = data.len().div_ceil(START_POSES).max(1);
    let sample: std::borrow::Cow<'_, [Observation]> = if step > 1 {
        data.iter().step_by(step).cloned().collect()
    } else {
        data.into()
    };
    let data = &*sample;
    let mut bare = robot.clone();
    bare.base = armcal_shared::Frame::identity();
    bare.tool = armcal_shared::Frame::identity();
    let bare = bare.prepare();
    let flange: Vec<IsometryMatrix3<f64>> = data
        .iter()
        .filter_map(|o| bare.forward(&o.q).ok())
        .collect();
    if flange.len() != data.len() || data.len() < 3 {
        return;
    }
    let with_orientation: Vec<usize> = (0..data.len())
        .filter(|&i| data[i].orientation.is_some())
        .collect();
    let mut base = robot.base.isometry();
    let mut tool = robot.tool.isometry();
    // Sums of squares from the flange frames already computed: base · flange · tool.
    let frames_cost = |b: &IsometryMatrix3<f64>, t: &IsometryMatrix3<f64>| -> f64 {
        data.iter()
            .zip(&flange)
            .map(|(obs, f)| {
                let m = b * f * t;
                let dp = (obs.position.coords - m.translation.vector).norm_squared();
                dp + obs.orientation.map_or(0.0, |q| {
                    rotation_error(&q.to_rotation_matrix(), &m.rotation).norm_squared()
                })
            })
            .sum()
    };
    let before = frames_cost(&base, &tool);
    for _ in 0..20 {
        if with_orientation.len() >= 2 {
            // Rotations: R_meas = R_b R_f R_t, alternating chordal means.
            let rb: Matrix3<f64> = with_orientation
                .iter()
                .map(|&i| {
                    let rm = data[i].orientation.unwrap_or_default().to_rotation_matrix();
                    (rm * (flange[i].rotation * tool.rotation).inverse()).into_inner()
                })
                .sum();
            base.rotation = project_to_rotation(&rb);
            let rt: Matrix3<f64> = with_orientation
                .iter()
                .map(|&i| {
                    let rm = data[i].orientation.unwrap_or_default().to_rotation_matrix();
                    ((base.rotation * flange[i].rotation).inverse() * rm).into_inner()
                })
                .sum();
            tool.rotation = project_to_rotation(&rt);
        } else {
            // Positions only: register the current model's points onto the measured ones.
            let model: Vec<Point3<f64>> = flange
                .iter()
                .map(|f| base * (f * Point3::from(tool.translation.vector)))
                .collect();
            let measured: Vec<Point3<f64>> = data.iter().map(|o| o.position).collect();
            let correction = kabsch(&model, &measured);
            base = correction * base;
        }
        // Positions: P = t_b + R_b (p_f + R_f t_t), linear in (t_b, t_t): the 6 × 6
        // normal equations, accumulated pose by pose.
        let mut ata = nalgebra::Matrix6::<f64>::zeros();
        let mut atb = nalgebra::Vector6::<f64>::zeros();
        for (obs, f) in data.iter().zip(&flange) {
            let rbrf = base.rotation.matrix() * f.rotation.matrix();
            let mut a = nalgebra::Matrix3x6::<f64>::zeros();
            a.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&Matrix3::identity());
            a.fixed_view_mut::<3, 3>(0, 3).copy_from(&rbrf);
            let rhs = obs.position.coords - base.rotation * f.translation.vector;
            ata += a.transpose() * a;
            atb += a.transpose() * rhs;
        }
        // Singular when the tool point cannot be told from the base (all poses alike).
        let Some(x) = ata.cholesky().map(|c| c.solve(&atb)) else {
            return;
        };
        let (tb, tt) = (
            Vector3::new(x[0], x[1], x[2]),
            Vector3::new(x[3], x[4], x[5]),
        );
        let change = (tb - base.translation.vector).norm() + (tt - tool.translation.vector).norm();
        base.translation.vector = tb;
        tool.translation.vector = tt;
        if change < 1e-12 {
            break;
        }
    }
    let mut trial = robot.clone();
    trial.base = frame_of(&base);
    trial.tool = frame_of(&tool);
    if with_orientation.len() < 2 {
        trial.tool.rpy = robot.tool.rpy; // not observable from positions: keep nominal
    }
    if frames_cost(&trial.base.isometry(), &trial.tool.isometry()) < before {
        *robot = trial;
    }
}

/// The start of a constraint session's fit: each unknown fixed point at the
/// mean of the tool points its rows put there and, when `tool` is set, the
/// tool point that brings them closest together (a linear least-squares
/// problem once the points are eliminated: `Σ_k Σ_i |(R_i − R̄_k) t + p_i − p̄_k|²`
/// over the flange frames `(R_i, p_i)` of point `k`'s rows, with a faint pull
/// to the nominal tool point where the rows leave it undetermined). The base
/// is nominal; the distances do not enter the start.
fn initial_points_tool(model: &mut Model, data: &[Observation], tool: bool) {
    let mut bare = model.robot.clone();
    bare.tool = armcal_shared::Frame::identity();
    let bare = bare.prepare();
    let flange: Vec<Option<IsometryMatrix3<f64>>> =
        data.iter().map(|o| bare.forward(&o.q).ok()).collect();
    let points = model.points.len();
    // Mean flange position and rotation of each point's rows.
    let mut sums = vec![(Vector3::zeros(), Matrix3::zeros(), 0usize); points];
    for (obs, f) in data.iter().zip(&flange) {
        if let (Some(k), Some(f)) = (obs.fixed_point(), f)
            && let Some(s) = sums.get_mut(k)
        {
            s.0 += f.translation.vector;
            s.1 += f.rotation.matrix();
            s.2 += 1;
        }
    }
    let means: Vec<(Vector3<f64>, Matrix3<f64>)> = sums
        .iter()
        .map(|(p, r, n)| {
            let n = (*n).max(1) as f64;
            (p / n, r / n)
        })
        .collect();
    let mut t = model.robot.tool.xyz;
    if tool {
        let mut a = Matrix3::<f64>::zeros();
        let mut b = Vector3::<f64>::zeros();
        for (obs, f) in data.iter().zip(&flange) {
            if let (Some(k), Some(f)) = (obs.fixed_point(), f) {
                let (p_mean, r_mean) = means[k];
                let dr = f.rotation.matrix() - r_mean;
                a += dr.transpose() * dr;
                b -= dr.transpose() * (f.translation.vector - p_mean);
            }
        }
        let ridge = 1e-6 * a.trace() / 3.0;
        let a = a + Matrix3::identity() * ridge;
        let b = b + t * ridge;
        if let Some(x) = a.cholesky().map(|c| c.solve(&b))
            && x.iter().all(|v| v.is_finite())
        {
            t = x;
        }
    }
    model.robot.tool.xyz = t;
    model.points = means.iter().map(|(p, r)| Point3::from(p + r * t)).collect();
    // Each plane through its touches' centroid, normal to their least spread.
    for (k, plane) in model.planes.iter_mut().enumerate() {
        let touches: Vec<Vector3<f64>> = data
            .iter()
            .zip(&flange)
            .filter(|(o, _)| o.on_plane() == Some(k))
            .filter_map(|(_, f)| f.as_ref().map(|f| f.translation.vector + f.rotation * t))
            .collect();
        if touches.len() < 3 {
            continue;
        }
        *plane = PlaneEstimate::least_squares(&touches).0;
    }
}

/// xyz and roll-pitch-yaw of an isometry.
fn frame_of(iso: &IsometryMatrix3<f64>) -> armcal_shared::Frame<f64> {
    let (roll, pitch, yaw) = iso.rotation.euler_angles();
    armcal_shared::Frame {
        xyz: iso.translation.vector,
        rpy: Vector3::new(roll, pitch, yaw),
    }
}

/// The rotation nearest to `m` (Frobenius norm): `U diag(1, 1, det(UVᵀ)) Vᵀ`.
fn project_to_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return Rotation3::identity();
    };
    let mut d = Matrix3::identity();
    d[(2, 2)] = (u * vt).determinant().signum();
    Rotation3::from_matrix_unchecked(u * d * vt)
}

/// The rigid motion `T` minimising `Σ |T a_i − b_i|²` (Kabsch/Horn).
fn kabsch(a: &[Point3<f64>], b: &[Point3<f64>]) -> IsometryMatrix3<f64> {
    let n = a.len() as f64;
    let ca = a.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let cb = b.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = a
        .iter()
        .zip(b)
        .map(|(p, q)| (q.coords - cb) * (p.coords - ca).transpose())
        .sum();
    let r = project_to_rotation(&h);
    IsometryMatrix3::from_parts((cb - r * ca).into(), r)
}
