//! The least-squares fit under every identification (`--params full`, the
//! default): every identifiable geometric parameter, base and tool included,
//! with the effects a diagnosis adds; the noise of each channel ([`noise`])
//! and the prior on the parameter errors ([`prior`]) it weighs by.
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
//! ([`crate::session::channel::Channel`]): `σ_p` for measured positions, `σ_r` for
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
//!
//! ## Where each part is
//! | module | part |
//! | --- | --- |
//! | this one | the unknowns, the options and the result ([`FullFit`]), the posterior and the prior's reach |
//! | `fit` | the fit itself ([`FitRequest::run`]): the unknowns of one fit, its state through the noise rounds and selections, the statistics and the result |
//! | `rows` | residuals and weights: each pose's rows, the normal equations per channel |
//! | `initial` | the initial estimate of base, tool, points and planes |
//! | `selection` | identifiability: what the data separate, and why the others are held |
//! | `solve` | the solution: Levenberg–Marquardt with the prior |
//! | `linearization` | the linearisation about a solution, stored or summed per fold, for the cross-validations |
//! | `register` | a session the robot was not fitted to: its own base and tool fitted with the robot held |

use armcal_shared::effects::Effect;
use armcal_shared::{FrameAxis, JointType, Param, Robot, rotation_error};
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{Mat, Side};
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};

use crate::cancel::{Cancel, Cancelled};
use crate::session::channel::WeightFactors;
use crate::session::channel::{Channel, PerChannel};
use crate::session::prior::{PRIOR_FACTORS, Prior};
use crate::session::registration::{FrameSharing, Registrations, Sharing};
use noise::{Noise, NoiseEstimate, NoiseSource, Weights};
use prior::Geometry;

mod initial;
mod linearization;
pub mod noise;
pub mod prior;
mod register;
mod rounds;
mod rows;
mod selection;
mod solve;

pub use initial::session_registrations;
pub use linearization::{FoldNormal, FoldNormals, Linearization, fold_normals, linearize};
pub use register::{Registered, register_session};
use rounds::{Fit, Unknowns, check_inputs};
use rows::NormalEquations;

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
    /// A parameter of the own base or tool frame of session `session ≥ 1`
    /// of several ([`crate::session::registration`]): a nuisance unknown
    /// estimated with the robot.
    Session {
        /// The session, 0-based (never 0: the first session's frames are the model's).
        session: usize,
        /// `Param::Base(_)` or `Param::Tool(_)`.
        param: Param,
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
    /// The own frames of the sessions after the first (empty for one session).
    pub registrations: Registrations,
}

impl Model {
    /// The geometric model `robot` with `effects`, without fixed points, of one session.
    fn of(robot: Robot<f64>, effects: Vec<Effect<f64>>) -> Self {
        Self {
            robot,
            effects,
            points: Vec::new(),
            planes: Vec::new(),
            constraints: Constraints::default(),
            registrations: Registrations::default(),
        }
    }

    fn get(&self, u: Unknown) -> Option<f64> {
        match u {
            Unknown::Param(p) => self.robot.param(p),
            Unknown::Effect { effect, component } => self.effects.get(effect)?.parameter(component),
            Unknown::Point { point, axis } => self.points.get(point).map(|p| p[axis]),
            Unknown::Session { session, param } => self.registrations.param(session, param),
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
            Unknown::Session { session, param } => self.registrations.param_mut(session, param),
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
            Unknown::Session { session, param } => format!("session {} {param}", session + 1),
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

use crate::session::constraints::Constraints;
use crate::session::observation::Observation;
use crate::session::rows::Rows;

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
    /// With several sessions, which frames are each session's own.
    pub sessions: FrameSharing,
    /// The weight of each kind of row but the positions relative to what
    /// its noise gives it (`1/σ²`): 1 as the noise says, 0.1, 0.01, or 0 —
    /// not used ([`crate::calibration::identify::channel_weight`]).
    /// Below 1 a channel's noise is held where these options put it (the
    /// estimate at full weight), not estimated again: variance components
    /// would restore the weight.
    pub weights: WeightFactors,
    /// The caller's request to stop, asked before each pass over the rows
    /// ([`crate::cancel`]): a fit asked to stop ends with
    /// [`FullError::Cancelled`]. Never raised by default.
    pub cancel: Cancel,
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
            sessions: FrameSharing::default(),
            weights: WeightFactors::NOISE,
            cancel: Cancel::NEVER,
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
    /// Each weighed kind's weight relative to its noise's
    /// ([`FullOptions::weights`]): 1 unless down-weighted.
    pub weights: WeightFactors,
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
    /// The own frames of the sessions after the first, as fitted (empty for
    /// one session): `calibrated` is the first session's.
    pub registrations: Registrations,
    /// Each session's figures and own frames, in order (empty for one session).
    pub sessions: Vec<SessionFit>,
    /// The caller's request to stop the computation this fit is part of
    /// ([`FullOptions::cancel`]): what is computed about the fit (its
    /// linearisation, its folds, its deleted residuals) asks it too.
    pub cancel: Cancel,
}

/// One session of several, as the fit leaves it.
#[derive(Clone, Debug)]
pub struct SessionFit {
    /// Its poses.
    pub poses: usize,
    /// The RMS of its rows' position residuals (3-D distance), m.
    pub position_rms: f64,
    /// The RMS of its rows' orientation angles, rad, when it measures them.
    pub orientation_rms: Option<f64>,
    /// Its own frames' parameters (none for the first session, whose frames
    /// are the model's): the value, SI, and its status.
    pub frames: Vec<(Param, f64, Status)>,
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
    /// The calibrated robot as session `session` sees it: with its own frames.
    pub fn robot_of(&self, session: usize) -> Robot<f64> {
        self.registrations.robot(&self.calibrated, session)
    }

    /// The weights of the rows of each channel at the noise the fit used (1
    /// for a channel without rows).
    pub fn weights(&self) -> Weights {
        channel_weights(&PerChannel::from_fn(|c| self.noise_of(c)), &self.weights)
    }

    /// The noise the fit divided channel `c`'s rows by (1 for a channel
    /// without rows).
    pub fn noise_of(&self, c: Channel) -> f64 {
        self.noise.channel(c).map_or(1.0, |n| n.used)
    }

    /// What channel `c`'s rows were divided by in the fit: its noise over
    /// the square root of its weight's factor (m or rad per axis; 1 for a
    /// channel without rows). A row times it is back in m or rad.
    pub fn row_scale(&self, c: Channel) -> f64 {
        match self.weights.fitted_channel(c) {
            0.0 => self.noise_of(c),
            factor => self.noise_of(c) / factor.sqrt(),
        }
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
    /// The caller asked the computation to stop ([`FullOptions::cancel`]).
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
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

/// What a fit frees beyond the model's own geometry, after it in the order
/// of preference: the parameters of `effects` (their values the start,
/// usually zero) and the `extra` geometric parameters (Hayati tilts
/// `Param::Beta` between nominally parallel axes): the extended model of
/// `armcal diagnose`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Extension<'a> {
    /// The effects whose parameters are fitted.
    pub effects: &'a [Effect<f64>],
    /// The extra geometric parameters.
    pub extra: &'a [Param],
}

impl Extension<'_> {
    /// The geometry alone.
    pub const NONE: Extension<'static> = Extension {
        effects: &[],
        extra: &[],
    };
}

/// One fit of the full model, as asked: every identifiable geometric
/// parameter of `nominal` from `data` with `options`, and as the builder
/// says, the parameters of an [`Extension`], a start from a fit's geometry,
/// and the unknown points, planes and known distances of a session without
/// a tracker. [`FitRequest::run`] fits it.
#[derive(Clone, Copy, Debug)]
pub struct FitRequest<'a> {
    nominal: &'a Robot<f64>,
    data: Rows<'a>,
    options: &'a FullOptions,
    extension: Extension<'a>,
    start: Option<&'a Robot<f64>>,
    constraints: Option<&'a Constraints>,
}

impl<'a> FitRequest<'a> {
    /// Every identifiable geometric parameter of `nominal` from `data` (a
    /// session's rows, or a view of some of them: [`Rows`]), from the
    /// nominal model and the closed-form base and tool.
    pub fn new(
        nominal: &'a Robot<f64>,
        data: impl Into<Rows<'a>>,
        options: &'a FullOptions,
    ) -> Self {
        Self {
            nominal,
            data: data.into(),
            options,
            extension: Extension::NONE,
            start: None,
            constraints: None,
        }
    }

    /// The geometry fitted together with `extension`'s parameters.
    pub fn extended(self, extension: Extension<'a>) -> Self {
        Self { extension, ..self }
    }

    /// From the geometry of `start` (a fit of the same data), when given,
    /// instead of the nominal model and the closed-form base and tool: the
    /// extended model's refit converges in a few iterations from the fit it
    /// extends.
    pub fn starting_from(self, start: Option<&'a Robot<f64>>) -> Self {
        Self { start, ..self }
    }

    /// For a session whose rows may sit at unknown fixed points or planes
    /// tied by known distances (`constraints`, see
    /// [`crate::session::constraints`]) instead of measuring coordinates: each
    /// point's three coordinates (a plane's normal and offset) are unknowns
    /// of the same fit, first in the order of preference, each distance one
    /// more row weighted by its stated uncertainty. The base is then not
    /// observable and is held at nominal with that reason. With no points
    /// this changes nothing.
    pub fn constrained(self, constraints: &'a Constraints) -> Self {
        Self {
            constraints: Some(constraints),
            ..self
        }
    }

    /// The fit.
    pub fn run(self) -> Result<FullFit, FullError> {
        let Self {
            nominal,
            data,
            options,
            extension: Extension { effects, extra },
            start,
            constraints,
        } = self;
        let none = Constraints::default();
        let constraints = constraints.unwrap_or(&none);
        options.cancel.check()?;
        check_inputs(nominal, effects, data, constraints)?;
        let unknowns = Unknowns::of(nominal, effects, extra, data, constraints, options)?;
        let model = unknowns.initial_model(nominal, start, effects, data, constraints, options);
        let fit = Fit::new(nominal, data, constraints, options, unknowns, model).run()?;
        // A fit asked to stop in its last pass is not returned as found.
        options.cancel.check()?;
        Ok(fit)
    }
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

/// The weight of each channel's rows at the noises `noise`: `1/σ_c`, a
/// weighed kind's times the square root of the factor it is fitted at
/// ([`WeightFactors::fitted`]; a factor on `1/σ_c²`).
pub(crate) fn channel_weights(noise: &PerChannel<f64>, factors: &WeightFactors) -> Weights {
    noise.map(|c, s| factors.fitted_channel(c).sqrt() / s)
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
            Unknown::Effect { .. }
            | Unknown::Point { .. }
            | Unknown::Plane { .. }
            | Unknown::Session { .. } => (0.0, 0.0),
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
    /// The channels the variance factor counts: those weighted by their
    /// noise (a down-weighted channel's rows are not in units of theirs).
    counted: PerChannel<bool>,
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
            counted: PerChannel::from_fn(|_| true),
        }
    }

    /// The total redundancy.
    fn redundancy(&self) -> f64 {
        self.redundancy.0.iter().sum::<f64>() + self.distances.1
    }

    /// The a-posteriori variance factor: the weighted sum of squares over the redundancy.
    fn variance_factor(&self) -> f64 {
        let counted = |v: &PerChannel<f64>| {
            Channel::ALL
                .iter()
                .filter(|&&c| self.counted[c])
                .map(|&c| v[c])
                .sum::<f64>()
        };
        let r = counted(&self.redundancy) + self.distances.1;
        if r > 0.0 {
            (counted(&self.omega) + self.distances.0) / r
        } else {
            1.0
        }
    }
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
