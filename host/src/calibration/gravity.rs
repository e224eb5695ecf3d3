//! Gravity from the joint torques a robot reports: the sign its `tau`
//! columns are read with, the arm's masses fitted so that the model's gravity
//! torques are the measured ones, and the checks that the masses are
//! physically possible before anything uses them.
//!
//! Conventions, frames, units: a joint's compliance twists it by `c τ_j`,
//! with `τ_j` the torque gravity exerts about joint `j`
//! ([`armcal_shared::effects`]), in the robot's base frame:
//!
//! ```text
//! τ_j = w_j · (Σ_{k ≥ j} m_k r_k + m_p p − ρ_j Σ_{k ≥ j} m_k − ρ_j m_p) × g      (revolute)
//! τ_j = w_j · g (Σ_{k ≥ j} m_k + m_p)                                            (prismatic)
//! ```
//!
//! with `m_k` the mass of link `k`, `r_k = o_k + R_k c_k` its centre of mass
//! (`c_k` in its own D-H frame), `m_p` the payload at the tool point `p`, and
//! `w_j`, `ρ_j` joint `j`'s axis and a point on it. It is linear in each
//! link's `m_k` and first moment `m_k c_k` (four unknowns a link). Units: SI
//! (kg, m, N·m; N for a prismatic joint).
//!
//! **The sign.** armcal's `tau1..tauM` are the drives' torques
//! ([`TorqueSign::Drive`]: the torque each drive exerts on its link about the
//! joint's axis, positive with increasing `q_j`), so that at a pose held
//! still `t_j = −τ_j + b_{s,j}`, with `b_{s,j}` joint `j`'s sensor offset in
//! session `s` (sensors are zeroed at each start-up). Some robots report the
//! load torque their sensors read ([`TorqueSign::Load`]: `t_j = τ_j + b`).
//! Stated (`--torque-sign`), the sign is taken as stated; otherwise it is
//! read from the data ([`SignSource`]): the masses are fitted with either
//! sign, and the sign whose fit the payloads' known torques contradict is
//! rejected; when the fit cannot tell them apart (one payload: either sign
//! fits, with masses of the opposite signs), the sign whose torques oppose
//! (drive) or follow (load) the model's own gravity torques (its masses, or
//! the proxy's 1 kg at each link frame's origin) is taken.
//!
//! **The fit.** [`fit`] finds the masses, first moments and each session's
//! offsets of least squares over the poses, held towards the model's own
//! masses (or the proxy's) along what the torques cannot tell (Tikhonov,
//! 10⁻⁸ of the normal matrix's largest diagonal): the combinations of the
//! masses that gravity never shows stay at the model's values, and every
//! combination it does show is the data's.
//!
//! **The checks** ([`with_measured_gravity`]). A `tau` column constant
//! through a session where the model's gravity torque about its joint varies
//! is not that joint's torque: refused (its file and column named). Each
//! joint's residual is compared with its torques' own noise (the residual of
//! that joint's torques fitted alone, with any gravity of the links beyond it
//! and the payload's torque free: [`GravityFit::noise`]); a fit whose
//! residual is more than [`NOISE_RATIO`] times that noise and leaves, beyond
//! it, more than [`MISFIT`] of a joint's torque spread contradicts gravity at
//! that joint (columns swapped, another convention, not that joint's torque).
//! The masses must be physically possible: none negative, none more than
//! [`MASS_RATIO`] from the model's where it has them, no link's first moment
//! more than the whole arm's mass at the arm's reach (the sum of its links'
//! `|a|` and `|s|` and the tool's offset; a link's own mass and centre of mass
//! are not what gravity shows, only their combinations with the links beyond
//! it). A fit that fails any of these is not used: the model's masses are,
//! and the summary and a warning say which joint or link and why — with the
//! two columns whose exchange makes the fit pass, if two do, and the other
//! sign, if a stated sign fails where it passes; a model without masses has
//! nothing to fall back to, and the session is refused.
//!
//! The identification then reads the masses used as the model's: the
//! compliance it fits is in rad/(N·m) of the measured torques, whatever the
//! model's masses were (an arm without a mass model gets a compliance all the
//! same), and the calibration written carries the fitted masses, so
//! `predict`, `compensate` and the controller compute the same torques at any
//! configuration — a robot program's targets included, where no torque was
//! measured.

use armcal_shared::{JointType, LinkMass, Robot};
use nalgebra::{DMatrix, DVector, Vector3};

use crate::session::input_error::InputError;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::observation::{Observation, session_count};

/// The regularisation towards the model's masses, relative to the normal
/// matrix's largest diagonal: far below what any pose shows.
const HOLD: f64 = 1e-8;

/// The share of a joint's torque spread a fit may leave beyond the torques'
/// own noise: more, and the masses contradict that joint's torques.
pub const MISFIT: f64 = 0.05;

/// How many times its torques' own noise a joint's residual must be before
/// it is taken for a contradiction: the noise's estimate from `n` rows varies
/// by about `√(1/2n)` of itself, under 10 % from 50 rows.
pub const NOISE_RATIO: f64 = 1.5;

/// How far a fitted link mass may be from the model's (either way) and still
/// be taken for the same link's: a factor of 3.
pub const MASS_RATIO: f64 = 3.0;

/// The sign convention of the `tau1..tauM` columns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TorqueSign {
    /// The torque each joint's drive exerts on its link about the joint's
    /// axis, positive with increasing `q` (armcal's `tau`: minus gravity's
    /// torque, plus an offset).
    Drive,
    /// The load torque the joint's sensor reads: gravity's torque on the link,
    /// the drive's negated (a KUKA iiwa's).
    Load,
}

impl TorqueSign {
    /// The factor that turns a torque read with this sign into the drive's.
    pub fn to_drive(self) -> f64 {
        match self {
            Self::Drive => 1.0,
            Self::Load => -1.0,
        }
    }

    /// The flag's value: `drive` or `load`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Drive => "drive",
            Self::Load => "load",
        }
    }

    /// The other sign.
    fn other(self) -> Self {
        match self {
            Self::Drive => Self::Load,
            Self::Load => Self::Drive,
        }
    }

    /// What the torques are read as, for a summary.
    fn reading(self) -> &'static str {
        match self {
            Self::Drive => "tau read as the drives' torques",
            Self::Load => "tau read as the sensors' load torques: negated",
        }
    }
}

/// How the sign of the `tau` columns was settled.
#[derive(Clone, Debug, PartialEq)]
pub enum SignSource {
    /// Stated (`--torque-sign`).
    Stated,
    /// The other sign's fit contradicts the payloads' known torques: at its
    /// worst joint (from 0) it leaves `other` N·m RMS beyond the noise where
    /// this sign's leaves `this`.
    Fit {
        /// The other sign's worst joint, from 0.
        joint: usize,
        /// The other sign's misfit there, N·m RMS beyond the noise.
        other: f64,
        /// This sign's misfit there.
        this: f64,
    },
    /// Both signs fit alike (one payload): the torques read with this sign
    /// follow the model's gravity torques, their correlation across the poses
    /// (each session's mean removed) `correlation` (a drive's torques oppose
    /// them).
    ModelGravity {
        /// The correlation of the torques, read with this sign and negated
        /// back to gravity's, with the model's gravity torques.
        correlation: f64,
    },
}

/// The reports' `gravity` (docs/file-formats.md §6): the masses' fit to
/// the measured torques, as [`GravityFit::report`] gives it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GravityReport {
    /// Always `measured joint torques`.
    pub source: &'static str,
    /// `drive` or `load`: the sign the `tau` columns were read with.
    pub torque_sign: &'static str,
    /// How that sign was settled.
    pub torque_sign_source: SignSourceReport,
    /// The summary's sentence on the sign.
    pub reading: String,
    /// The poses fitted.
    pub poses: usize,
    /// Whether the model had masses.
    pub model_had_masses: bool,
    /// `fitted` or `model`.
    pub masses_used: MassesSource,
    /// Why the fitted masses are not used (empty when they are).
    pub not_used_because: Vec<String>,
    /// Each joint's RMS torque residual, N·m.
    pub residual_nm: Vec<f64>,
    /// Each joint's torque noise, N·m.
    pub noise_nm: Vec<f64>,
    /// Each joint's RMS measured torque about its mean, N·m.
    pub spread_nm: Vec<f64>,
    /// Each session's offset of each joint, N·m.
    pub offset_nm: Vec<Vec<f64>>,
}

impl GravityReport {
    /// The summary's lines: how the torques were read, and where the
    /// compliance's torques come from.
    pub fn summary(&self) -> String {
        let worst = self
            .residual_nm
            .iter()
            .zip(&self.spread_nm)
            .enumerate()
            .max_by(|a, b| a.1.0.total_cmp(b.1.0));
        let mut s = format!(
            "gravity torques from the measured joint torques (tau1..tau{}, {}, {}): ",
            self.residual_nm.len(),
            crate::session::measurements::plural(self.poses, "pose"),
            self.reading
        );
        if self.masses_used == MassesSource::Fitted {
            s.push_str(&format!(
                "the arm's masses fitted ({}); a compliance twists by these",
                if self.model_had_masses {
                    "held to the model's where the torques do not show them"
                } else {
                    "the model has none: held to 1 kg at each link frame where the torques do not show them"
                }
            ));
        } else {
            s.push_str(
                "the masses fitted to them are not used, the model's are (a compliance twists by the model's gravity torques)",
            );
        }
        if let Some((j, (r, spread))) = worst {
            s.push_str(&format!(
                "; largest residual joint {}: {r:.3} N·m RMS of a {spread:.3} N·m spread",
                j + 1
            ));
        }
        for r in &self.not_used_because {
            s.push_str(&format!("\n  not used: {r}"));
        }
        s
    }

    /// The section of `diagnose`'s HTML page: the [`GravityReport::summary`]
    /// the terminal prints, and each joint's residual RMS beside the spread
    /// of its torques.
    pub fn html(&self) -> String {
        use crate::report::html::html_escape;
        let mut s = format!(
            "<h2>Joint torques</h2><p>{}</p><table><tr><th>joint</th><th>residual RMS [N·m]</th><th>spread of the torques [N·m]</th></tr>",
            html_escape(&self.summary()).replace('\n', "<br>")
        );
        for (j, (r, spread)) in self.residual_nm.iter().zip(&self.spread_nm).enumerate() {
            s.push_str(&format!(
                "<tr><td>{}</td><td>{r:.3}</td><td>{spread:.3}</td></tr>",
                j + 1
            ));
        }
        s.push_str("</table>");
        s
    }
}

/// Whose masses a compliance twists by, as the reports give it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MassesSource {
    /// The masses fitted to the torques.
    Fitted,
    /// The model's own (the fit failed its checks).
    Model,
}

/// How the torques' sign was settled, as the reports give it: `stated`,
/// and for a sign found, `by` (`fit` or `model gravity`) with its figures.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SignSourceReport {
    /// Whether `--torque-sign` stated it.
    pub stated: bool,
    /// `fit` or `model gravity`, for a sign found.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub by: Option<&'static str>,
    /// By fit: the other sign's worst joint, from 1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub joint: Option<usize>,
    /// By fit: the other sign's misfit there, N·m RMS beyond the noise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub other_sign_misfit_nm: Option<f64>,
    /// By fit: this sign's misfit there.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub misfit_nm: Option<f64>,
    /// By the model's gravity: the torques' correlation with it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub correlation: Option<f64>,
}

/// Whether the fitted masses are used.
#[derive(Clone, Debug, PartialEq)]
pub enum MassesUsed {
    /// The fitted masses are the model's from here on.
    Fitted,
    /// The fit failed its checks, for these reasons (each names the joint's
    /// column or the link): the model's own masses are used.
    ModelMasses(Vec<String>),
}

/// The masses fitted to a session's measured torques.
#[derive(Clone, Debug, PartialEq)]
pub struct GravityFit {
    /// The model with the fitted masses and centres of mass.
    pub robot: Robot<f64>,
    /// The sign the `tau` columns were read with.
    pub sign: TorqueSign,
    /// How that sign was settled.
    pub sign_source: SignSource,
    /// Each joint's RMS torque residual, N·m (N).
    pub residual: Vec<f64>,
    /// Each joint's torque noise: the RMS residual of its torques fitted
    /// alone (any gravity of the links beyond it, the payload's torque and
    /// the offsets free; per degree of freedom left), N·m (N).
    pub noise: Vec<f64>,
    /// Each joint's RMS measured torque about its mean, N·m (N): what the
    /// residual compares with.
    pub spread: Vec<f64>,
    /// Each session's fitted offset of each joint, `b_{s,j}`, N·m (N), in
    /// the drive's sign.
    pub offset: Vec<Vec<f64>>,
    /// The poses fitted.
    pub poses: usize,
    /// Whether the model had masses (else the proxy was held to).
    pub model_had_masses: bool,
    /// Whether the fitted masses are used.
    pub used: MassesUsed,
}

/// One pose's rows: the design of `τ_j` in the unknowns (each link's `m`,
/// `m c_x`, `m c_y`, `m c_z`), and the payload's known part.
fn design(robot: &Robot<f64>, obs: &Observation) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let m = robot.dof();
    let chain = robot.chain(&obs.q).ok()?;
    let gravity = chain.base.rotation
        * robot
            .gravity
            .unwrap_or_else(|| Vector3::new(0.0, 0.0, -9.81));
    let payload = obs.context.payload.unwrap_or(0.0);
    let tool = chain.point().coords;
    let mut a = DMatrix::zeros(m, 4 * m);
    let mut known = DVector::zeros(m);
    for j in 0..m {
        let (w, rho) = (chain.axes[j].w, chain.axes[j].rho.coords);
        let moment = |r: Vector3<f64>| w.dot(&(r - rho).cross(&gravity));
        let revolute = robot.links[j].joint == JointType::Revolute;
        for k in j..m {
            let frame = &chain.links[k];
            a[(j, 4 * k)] = if revolute {
                moment(frame.translation.vector)
            } else {
                w.dot(&gravity)
            };
            if revolute {
                for c in 0..3 {
                    let axis = frame.rotation * Vector3::ith(c, 1.0);
                    a[(j, 4 * k + 1 + c)] = w.dot(&axis.cross(&gravity));
                }
            }
        }
        known[j] = payload
            * if revolute {
                moment(tool)
            } else {
                w.dot(&gravity)
            };
    }
    Some((a, known))
}

/// The model's masses as the unknowns (mass, first moment per link), or
/// the proxy's 1 kg at each link frame's origin.
fn prior(robot: &Robot<f64>) -> DVector<f64> {
    let uses_masses = robot.links.iter().any(|l| l.mass.is_some());
    let mut x = DVector::zeros(4 * robot.dof());
    for (k, l) in robot.links.iter().enumerate() {
        let (mass, com) = match (&l.mass, uses_masses) {
            (Some(lm), _) => (lm.mass, lm.com),
            (None, true) => (0.0, Vector3::zeros()),
            (None, false) => (1.0, Vector3::zeros()),
        };
        x[4 * k] = mass;
        for c in 0..3 {
            x[4 * k + 1 + c] = mass * com[c];
        }
    }
    x
}

/// One pose's rows in every unknown (each link's mass and first moment, then
/// each session's offsets) and its torques as the rows fit them,
/// `−t − known` (`−t_j = τ_j − b_{s,j}`, `t` the drives' torques: the
/// column read times `sign`'s factor); `None` for a pose without torques.
fn rows(
    robot: &Robot<f64>,
    obs: &Observation,
    sign: TorqueSign,
    sessions: usize,
) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let t = obs.torque.as_ref()?;
    let (a, known) = design(robot, obs)?;
    let m = robot.dof();
    let mut full = DMatrix::zeros(m, 4 * m + m * sessions);
    full.view_mut((0, 0), (m, 4 * m)).copy_from(&a);
    for j in 0..m {
        full[(j, 4 * m + m * obs.session + j)] = -1.0;
    }
    let s = sign.to_drive();
    Some((full, DVector::from_fn(m, |j, _| -s * t[j] - known[j])))
}

/// The masses of `robot` fitted to the measured torques of `poses`, read
/// with `sign` (see the module header; one offset per joint and session,
/// the sessions those of [`Observation::session`]); `None` when no pose has
/// them. The fitted masses' checks are not made: [`MassesUsed::Fitted`], the
/// noise estimated, the sign's source [`SignSource::Stated`]. Two passes over
/// the poses, the second for the residuals: nothing kept per pose.
pub fn fit(robot: &Robot<f64>, poses: &[Observation], sign: TorqueSign) -> Option<GravityFit> {
    let m = robot.dof();
    let sessions = session_count(poses);
    let unknowns = 4 * m + m * sessions;
    let mut normal = DMatrix::<f64>::zeros(unknowns, unknowns);
    let mut rhs = DVector::<f64>::zeros(unknowns);
    let mut fitted_poses = 0;
    for (full, y) in poses.iter().filter_map(|o| rows(robot, o, sign, sessions)) {
        normal += full.transpose() * &full;
        rhs += full.transpose() * &y;
        fitted_poses += 1;
    }
    if fitted_poses == 0 {
        return None;
    }
    let mut x0 = DVector::zeros(unknowns);
    x0.rows_mut(0, 4 * m).copy_from(&prior(robot));
    // The masses held to the model's; an offset only when its session has
    // no torques (else it is the data's alone).
    let hold = HOLD * normal.diagonal().max().max(f64::MIN_POSITIVE);
    for i in 0..unknowns {
        if i < 4 * m || normal[(i, i)] == 0.0 {
            normal[(i, i)] += hold;
            rhs[i] += hold * x0[i];
        }
    }
    let x = normal.cholesky()?.solve(&rhs);
    let mut fitted = robot.clone();
    for (k, l) in fitted.links.iter_mut().enumerate() {
        let mass = x[4 * k];
        let moment = Vector3::new(x[4 * k + 1], x[4 * k + 2], x[4 * k + 3]);
        l.mass = Some(LinkMass {
            mass,
            com: if mass.abs() > f64::EPSILON {
                moment / mass
            } else {
                Vector3::zeros()
            },
        });
    }
    let n = fitted_poses as f64;
    let mut residual = vec![0.0; m];
    let mut mean = vec![0.0; m];
    let mut square = vec![0.0; m];
    for (full, y) in poses.iter().filter_map(|o| rows(robot, o, sign, sessions)) {
        let r = &y - full * &x;
        for j in 0..m {
            residual[j] += r[j] * r[j] / n;
            mean[j] += y[j] / n;
            square[j] += y[j] * y[j] / n;
        }
    }
    Some(GravityFit {
        robot: fitted,
        sign,
        sign_source: SignSource::Stated,
        residual: residual.iter().map(|s| s.sqrt()).collect(),
        noise: noise(robot, poses),
        spread: (0..m)
            .map(|j| (square[j] - mean[j] * mean[j]).max(0.0).sqrt())
            .collect(),
        offset: (0..sessions)
            .map(|s| (0..m).map(|j| x[4 * m + m * s + j]).collect())
            .collect(),
        poses: fitted_poses,
        model_had_masses: robot.links.iter().any(|l| l.mass.is_some()),
        used: MassesUsed::Fitted,
    })
}

/// Each joint's torque noise (see [`GravityFit::noise`]): its torques fitted
/// alone, every column of its own rows free (the links beyond it, the
/// payload's torque, each session's offset), the residual per degree of
/// freedom left. Whichever sign the torques have, the same.
fn noise(robot: &Robot<f64>, poses: &[Observation]) -> Vec<f64> {
    let m = robot.dof();
    let sessions = session_count(poses);
    let unknowns = 4 * m + 1 + sessions;
    let mut normal = vec![DMatrix::<f64>::zeros(unknowns, unknowns); m];
    let mut rhs = vec![DVector::<f64>::zeros(unknowns); m];
    let mut square = vec![0.0; m];
    let mut n = 0usize;
    for obs in poses {
        let (Some(t), Some((a, known))) = (obs.torque.as_ref(), design(robot, obs)) else {
            continue;
        };
        n += 1;
        for j in 0..m {
            let mut row = DVector::zeros(unknowns);
            row.rows_mut(0, 4 * m).copy_from(&a.row(j).transpose());
            row[4 * m] = known[j];
            row[4 * m + 1 + obs.session] = 1.0;
            normal[j] += &row * row.transpose();
            rhs[j] += &row * t[j];
            square[j] += t[j] * t[j];
        }
    }
    (0..m)
        .map(|j| {
            // Columns scaled to unit diagonal, the rank and least squares
            // from the eigenvalues above 10⁻¹⁰ of the largest.
            let d: DVector<f64> = normal[j]
                .diagonal()
                .map(|v| if v > 0.0 { 1.0 / v.sqrt() } else { 0.0 });
            let scaled =
                DMatrix::from_fn(unknowns, unknowns, |r, c| normal[j][(r, c)] * d[r] * d[c]);
            let b = rhs[j].component_mul(&d);
            let eigen = scaled.symmetric_eigen();
            let largest = eigen.eigenvalues.max().max(f64::MIN_POSITIVE);
            let mut rank = 0;
            let mut explained = 0.0;
            for (i, &l) in eigen.eigenvalues.iter().enumerate() {
                if l > 1e-10 * largest {
                    rank += 1;
                    let p = eigen.eigenvectors.column(i).dot(&b);
                    explained += p * p / l;
                }
            }
            let left = n.saturating_sub(rank);
            if left == 0 {
                0.0
            } else {
                ((square[j] - explained).max(0.0) / left as f64).sqrt()
            }
        })
        .collect()
}

impl GravityFit {
    /// Each joint's residual beyond its torques' own noise, N·m RMS:
    /// `√(residual² − noise²)`, 0 when the residual is the noise.
    pub fn misfit(&self) -> Vec<f64> {
        self.residual
            .iter()
            .zip(&self.noise)
            .map(|(r, s)| (r * r - s * s).max(0.0).sqrt())
            .collect()
    }

    /// Whether joint `j`'s torques contradict the fit: its residual more
    /// than [`NOISE_RATIO`] times its noise (beyond what the noise's own
    /// estimate varies by), and its misfit more than [`MISFIT`] of its
    /// torque spread.
    fn contradicts(&self, j: usize) -> bool {
        self.residual[j] > NOISE_RATIO * self.noise[j] && self.misfit()[j] > self.allowed(j)
    }

    /// The misfit joint `j` may have: [`MISFIT`] of its spread, and never
    /// less than the fit resolves (10⁻⁶ of the largest joint's spread: the
    /// hold towards the model's masses, rounding).
    fn allowed(&self, j: usize) -> f64 {
        let largest = self.spread.iter().copied().fold(0.0, f64::max);
        (MISFIT * self.spread[j])
            .max(1e-6 * largest)
            .max(f64::MIN_POSITIVE)
    }

    /// The joints (from 0) whose torques contradict the fit.
    fn contradicting_joints(&self) -> Vec<usize> {
        (0..self.residual.len())
            .filter(|&j| self.contradicts(j))
            .collect()
    }

    /// Why the fitted masses cannot be the arm's (see the module header),
    /// each reason naming its `tau` column or link; empty when they can.
    /// `model` is the model asked with (its masses, when it has them).
    fn failed_checks(&self, model: &Robot<f64>) -> Vec<String> {
        let mut reasons = Vec::new();
        let misfit = self.misfit();
        for j in self.contradicting_joints() {
            reasons.push(format!(
                "tau{}: the masses' fit leaves {:.3} N·m RMS beyond the torques' own noise ({:.3} N·m) \
                 of a {:.3} N·m spread ({:.0} %, more than {:.0} %): joint {}'s torques contradict the \
                 gravity the other joints' show (columns swapped, another convention, not joint {}'s torque?)",
                j + 1,
                misfit[j],
                self.noise[j],
                self.spread[j],
                100.0 * misfit[j] / self.spread[j].max(f64::MIN_POSITIVE),
                100.0 * MISFIT,
                j + 1,
                j + 1
            ));
        }
        let reach: f64 = model
            .links
            .iter()
            .map(|l| l.a.abs() + l.s.abs())
            .sum::<f64>()
            + model.tool.xyz.norm();
        let total: f64 = self
            .robot
            .links
            .iter()
            .filter_map(|l| l.mass.map(|m| m.mass.max(0.0)))
            .sum();
        for (k, (fitted, nominal)) in self.robot.links.iter().zip(&model.links).enumerate() {
            let Some(lm) = fitted.mass else { continue };
            if !lm.mass.is_finite() || lm.mass < 0.0 {
                reasons.push(format!(
                    "link {}: mass fitted as {:.3} kg: a mass is not negative",
                    k + 1,
                    lm.mass
                ));
                continue;
            }
            if let Some(m0) = nominal.mass.map(|n| n.mass).filter(|m0| *m0 > 0.0)
                && !(m0 / MASS_RATIO..=m0 * MASS_RATIO).contains(&lm.mass)
            {
                reasons.push(format!(
                    "link {}: mass fitted as {:.3} kg where the model's is {m0:.3} kg (more than \
                     {MASS_RATIO}× apart)",
                    k + 1,
                    lm.mass
                ));
            }
            let moment = lm.mass * lm.com.norm();
            if !moment.is_finite() || moment > total * reach {
                reasons.push(format!(
                    "link {}: first moment fitted as {moment:.3} kg·m, more than the whole arm's \
                     {total:.3} kg at its reach of {reach:.3} m",
                    k + 1
                ));
            }
        }
        reasons
    }
}

/// The correlation of the torques of `poses`, read with `sign` and turned
/// to gravity's (`τ = −t`), with `robot`'s gravity torques (its masses, or
/// the proxy's, with the payload), each session's mean removed from both:
/// near 1 when `sign` is right.
fn model_correlation(robot: &Robot<f64>, poses: &[Observation], sign: TorqueSign) -> f64 {
    let m = robot.dof();
    let sessions = session_count(poses);
    let x0 = prior(robot);
    // Per session and joint: n, Σt, Στ, Σtτ, Σt², Στ².
    let mut sums = vec![[0.0f64; 6]; sessions * m];
    for obs in poses {
        let (Some(t), Some((a, known))) = (obs.torque.as_ref(), design(robot, obs)) else {
            continue;
        };
        let tau = a * &x0 + known;
        for j in 0..m {
            let g = -sign.to_drive() * t[j];
            let s = &mut sums[obs.session * m + j];
            let v = [1.0, g, tau[j], g * tau[j], g * g, tau[j] * tau[j]];
            for (acc, v) in s.iter_mut().zip(v) {
                *acc += v;
            }
        }
    }
    let (mut cross, mut gg, mut tt) = (0.0, 0.0, 0.0);
    for [n, g, tau, gt, g2, t2] in sums {
        if n > 0.0 {
            cross += gt - g * tau / n;
            gg += g2 - g * g / n;
            tt += t2 - tau * tau / n;
        }
    }
    let scale = (gg * tt).sqrt();
    if scale > 0.0 { cross / scale } else { 0.0 }
}

/// The masses of `robot` fitted to `poses`' torques with the sign stated,
/// or with the sign the data show (see the module header).
fn fit_with_sign(
    robot: &Robot<f64>,
    poses: &[Observation],
    stated: Option<TorqueSign>,
) -> Option<GravityFit> {
    if let Some(sign) = stated {
        return fit(robot, poses, sign);
    }
    let (drive, load) = (
        fit(robot, poses, TorqueSign::Drive)?,
        fit(robot, poses, TorqueSign::Load)?,
    );
    // Each sign's misfit at the joints that contradict it, in units of
    // what a joint may leave.
    let score = |g: &GravityFit| -> f64 {
        let misfit = g.misfit();
        g.contradicting_joints()
            .into_iter()
            .map(|j| (misfit[j] / g.allowed(j)).powi(2))
            .sum()
    };
    let (sd, sl) = (score(&drive), score(&load));
    let by_fit = |(mut this, other): (GravityFit, GravityFit)| {
        let worse = other.misfit();
        let joint = (0..worse.len())
            .max_by(|&a, &b| worse[a].total_cmp(&worse[b]))
            .unwrap_or(0);
        this.sign_source = SignSource::Fit {
            joint,
            other: worse[joint],
            this: this.misfit()[joint],
        };
        this
    };
    // One sign's fit contradicts the torques, the other's far less.
    if sd.max(sl) > 1.0 && sd.max(sl) > 4.0 * sd.min(sl) {
        return Some(if sd < sl {
            by_fit((drive, load))
        } else {
            by_fit((load, drive))
        });
    }
    let correlation = model_correlation(robot, poses, TorqueSign::Drive);
    let mut chosen = if correlation >= 0.0 { drive } else { load };
    chosen.sign_source = SignSource::ModelGravity {
        correlation: correlation.abs(),
    };
    Some(chosen)
}

/// Two `tau` columns (joints `j < k`, from 0) whose exchange makes the fit
/// with one of `signs` pass every check, that sign, and its largest residual
/// then; `None` when no exchange does.
fn swapped_pair(
    robot: &Robot<f64>,
    poses: &[Observation],
    signs: &[TorqueSign],
) -> Option<(usize, usize, TorqueSign, f64)> {
    let m = robot.dof();
    (0..m)
        .flat_map(|j| (j + 1..m).map(move |k| (j, k)))
        .flat_map(|(j, k)| signs.iter().map(move |&sign| (j, k, sign)))
        .find_map(|(j, k, sign)| {
            let exchanged: Vec<Observation> = poses
                .iter()
                .map(|o| {
                    let mut o = o.clone();
                    if let Some(t) = o.torque.as_mut() {
                        t.swap(j, k);
                    }
                    o
                })
                .collect();
            let g = fit(robot, &exchanged, sign)?;
            g.failed_checks(robot).is_empty().then(|| {
                let worst = g.residual.iter().copied().fold(0.0, f64::max);
                (j, k, sign, worst)
            })
        })
}

/// A `tau` column constant through a session where the model's gravity
/// torque about its joint varies (more than 1 % of the joint's largest
/// spread, and more than 10⁻⁶ N·m): refused, its file and column named.
fn require_varying_columns(model: &Robot<f64>, data: &Measurements) -> Result<(), InputError> {
    let m = model.dof();
    let sessions = session_count(&data.poses);
    let x0 = prior(model);
    // Per session and joint: n, Σt, Σt², Στ, Στ², and the first t.
    let mut sums = vec![[0.0f64; 5]; sessions * m];
    let mut first: Vec<Option<f64>> = vec![None; sessions * m];
    let mut constant = vec![true; sessions * m];
    for obs in &data.poses {
        let (Some(t), Some((a, known))) = (obs.torque.as_ref(), design(model, obs)) else {
            continue;
        };
        let tau = a * &x0 + known;
        for j in 0..m {
            let i = obs.session * m + j;
            let v = [1.0, t[j], t[j] * t[j], tau[j], tau[j] * tau[j]];
            for (acc, v) in sums[i].iter_mut().zip(v) {
                *acc += v;
            }
            match first[i] {
                None => first[i] = Some(t[j]),
                Some(f) => constant[i] &= f == t[j],
            }
        }
    }
    let spread = |n: f64, s: f64, s2: f64| ((s2 - s * s / n) / n).max(0.0).sqrt();
    for s in 0..sessions {
        let model_spread: Vec<f64> = (0..m)
            .map(|j| {
                let [n, _, _, tau, tau2] = sums[s * m + j];
                if n > 1.0 { spread(n, tau, tau2) } else { 0.0 }
            })
            .collect();
        let largest = model_spread.iter().copied().fold(0.0, f64::max);
        for (j, &varying) in model_spread.iter().enumerate() {
            let i = s * m + j;
            let varies = varying > 0.01 * largest && varying > 1e-6;
            if let (true, true, Some(value)) = (constant[i], varies, first[i])
                && sums[i][0] > 1.0
            {
                let file = data.sessions.get(s).unwrap_or(&data.file);
                return Err(InputError::new(
                    file.clone(),
                    0,
                    0,
                    format!(
                        "column 'tau{}': {value} N·m at every row, where gravity's torque about \
                         joint {} varies by {:.3} N·m RMS over these poses (the model's {}): not \
                         joint {}'s torque (a column not written?); leave the tau columns out to \
                         use the model's masses",
                        j + 1,
                        j + 1,
                        varying,
                        if model.links.iter().any(|l| l.mass.is_some()) {
                            "masses"
                        } else {
                            "proxy of 1 kg at each link frame"
                        },
                        j + 1
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// `model` with the masses fitted to `data`'s measured torques, read with
/// the sign `stated` (`None`: the sign the data show), and the fit; `model`
/// as it is when the session has none, or when the fit fails its checks
/// ([`MassesUsed::ModelMasses`]: the fit says why). Refused when a `tau`
/// column is constant where gravity varies, and when the fit fails its
/// checks and the model has no masses to fall back to.
pub fn with_measured_gravity(
    model: &RobotModel,
    data: &Measurements,
    stated: Option<TorqueSign>,
) -> Result<(RobotModel, Option<GravityFit>), InputError> {
    if data.poses.iter().all(|o| o.torque.is_none()) {
        return Ok((model.clone(), None));
    }
    require_varying_columns(&model.robot, data)?;
    let Some(mut g) = fit_with_sign(&model.robot, &data.poses, stated) else {
        return Ok((model.clone(), None));
    };
    let mut reasons = g.failed_checks(&model.robot);
    let signs = match stated {
        Some(sign) => vec![sign],
        None => vec![g.sign, g.sign.other()],
    };
    if let Some(sign) = stated
        && !reasons.is_empty()
        && fit(&model.robot, &data.poses, sign.other())
            .is_some_and(|other| other.failed_checks(&model.robot).is_empty())
    {
        reasons.insert(
            0,
            format!(
                "{} pass every check: --torque-sign {}?",
                match sign.other() {
                    TorqueSign::Drive => "read as the drives' torques, the masses",
                    TorqueSign::Load => "read as the sensors' load torques (negated), the masses",
                },
                sign.other().name()
            ),
        );
    }
    if !g.contradicting_joints().is_empty()
        && let Some((j, k, sign, worst)) = swapped_pair(&model.robot, &data.poses, &signs)
    {
        reasons.insert(
            0,
            format!(
                "tau{} and tau{} swapped? With the two columns exchanged ({}) the masses pass \
                 every check (largest residual {worst:.3} N·m RMS)",
                j + 1,
                k + 1,
                sign.reading()
            ),
        );
    }
    if reasons.is_empty() {
        let mut fitted = model.clone();
        fitted.robot = g.robot.clone();
        return Ok((fitted, Some(g)));
    }
    if !g.model_had_masses {
        return Err(InputError::new(
            data.file.clone(),
            0,
            0,
            format!(
                "the joint torques ({}) cannot be the arm's gravity, and the model has no masses \
                 to use instead: {}",
                g.sign.reading(),
                reasons.join("; ")
            ),
        ));
    }
    g.used = MassesUsed::ModelMasses(reasons);
    Ok((model.clone(), Some(g)))
}

impl GravityFit {
    /// The warning a front end prints when the fitted masses are not used
    /// (whatever else it prints): why, each reason naming its column or
    /// link; `None` when they are used.
    pub fn warning(&self) -> Option<String> {
        match &self.used {
            MassesUsed::Fitted => None,
            MassesUsed::ModelMasses(reasons) => Some(format!(
                "the masses fitted to the joint torques ({}) are not used, the model's are: {}",
                self.sign.reading(),
                reasons.join("; ")
            )),
        }
    }

    /// How the sign was read, for the summary: what the torques were read
    /// as, and why.
    pub fn sign_summary(&self) -> String {
        let why = match &self.sign_source {
            SignSource::Stated => format!("as stated, --torque-sign {}", self.sign.name()),
            SignSource::Fit { joint, other, this } => format!(
                "read as the {}, the masses' fit leaves {other:.3} N·m RMS beyond the noise at joint {} \
                 against {this:.3}; --torque-sign states it",
                match self.sign.other() {
                    TorqueSign::Drive => "drives' torques",
                    TorqueSign::Load => "sensors' load torques",
                },
                joint + 1
            ),
            SignSource::ModelGravity { correlation } => format!(
                "both signs fit alike; read so, they follow the model's gravity torques \
                 (correlation {correlation:.2}); --torque-sign states it"
            ),
        };
        format!("{} ({why})", self.sign.reading())
    }

    /// The summary's lines ([`GravityReport::summary`] of its report).
    pub fn summary(&self) -> String {
        self.report().summary()
    }

    /// The reports' `gravity`: where the compliance's torques come from.
    pub fn report(&self) -> GravityReport {
        let torque_sign_source = match &self.sign_source {
            SignSource::Stated => SignSourceReport {
                stated: true,
                ..SignSourceReport::default()
            },
            SignSource::Fit { joint, other, this } => SignSourceReport {
                by: Some("fit"),
                joint: Some(joint + 1),
                other_sign_misfit_nm: Some(*other),
                misfit_nm: Some(*this),
                ..SignSourceReport::default()
            },
            SignSource::ModelGravity { correlation } => SignSourceReport {
                by: Some("model gravity"),
                correlation: Some(*correlation),
                ..SignSourceReport::default()
            },
        };
        let (masses_used, not_used_because) = match &self.used {
            MassesUsed::Fitted => (MassesSource::Fitted, Vec::new()),
            MassesUsed::ModelMasses(r) => (MassesSource::Model, r.clone()),
        };
        GravityReport {
            source: "measured joint torques",
            torque_sign: self.sign.name(),
            torque_sign_source,
            reading: self.sign_summary(),
            poses: self.poses,
            model_had_masses: self.model_had_masses,
            masses_used,
            not_used_because,
            residual_nm: self.residual.clone(),
            noise_nm: self.noise.clone(),
            spread_nm: self.spread.clone(),
            offset_nm: self.offset.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::simulate::{Scenario, simulate};
    use crate::io::measurements::parse_measurements;
    use crate::io::model_file::load_model;
    use armcal_shared::effects::{Approach, gravity_torques};
    use nalgebra::Point3;

    /// A UR5e's poses with the drives' torques `t = −τ + b_s` (`τ`
    /// gravity's, with the payload; `b_s` each session's offsets), no noise.
    fn exact_poses(
        truth: &Robot<f64>,
        count: usize,
        payloads: &[f64],
        offsets: &[[f64; 6]],
        seed: u64,
    ) -> Vec<Observation> {
        let mut r = crate::calibration::simulate::rng(seed);
        let configurations =
            crate::calibration::simulate::random_configurations(truth, count, &mut r);
        let mut approach = Approach::new();
        configurations
            .iter()
            .enumerate()
            .map(|(i, q)| {
                let payload = payloads[i % payloads.len()];
                let session = i * offsets.len() / count;
                let chain = truth.chain(q).unwrap();
                let tau = gravity_torques(truth, &chain, payload);
                let t: Vec<f64> = tau
                    .iter()
                    .zip(offsets[session])
                    .map(|(g, b)| -g + b)
                    .collect();
                let mut o = Observation::of_row(
                    q.clone(),
                    Point3::origin(),
                    None,
                    (None, Some(payload)),
                    Some(t),
                    &mut approach,
                );
                o.session = session;
                o
            })
            .collect()
    }

    fn massless(robot: &Robot<f64>) -> Robot<f64> {
        let mut r = robot.clone();
        for l in &mut r.links {
            l.mass = None;
        }
        r
    }

    /// Gravity's torques of `fitted` agree with `truth`'s at other
    /// configurations, with a 1 kg payload, to `tolerance` N·m.
    fn assert_same_gravity(fitted: &Robot<f64>, truth: &Robot<f64>, tolerance: f64) {
        let mut r = crate::calibration::simulate::rng(99);
        for q in crate::calibration::simulate::random_configurations(truth, 20, &mut r) {
            let want = gravity_torques(truth, &truth.chain(&q).unwrap(), 1.0);
            let got = gravity_torques(fitted, &fitted.chain(&q).unwrap(), 1.0);
            for (a, b) in got.iter().zip(&want) {
                assert!((a - b).abs() < tolerance, "{a} vs {b}");
            }
        }
    }

    /// A UR5e with its model masses, measured torques the drives' (minus
    /// gravity's, plus an offset per joint and session: sensors zeroed at
    /// each start-up): the fit gives back gravity's torques at other
    /// configurations to 1e-6 N·m (exact data: only rounding), from the
    /// model without masses too, and each session's offsets.
    #[test]
    fn the_fitted_masses_give_the_measured_torques_back() {
        let truth = &load_model("ur5e").unwrap().robot;
        assert!(truth.links.iter().any(|l| l.mass.is_some()));
        let offsets = [
            [0.3, -0.2, 0.1, 0.05, -0.04, 0.02],
            [-1.5, 2.0, 0.7, -0.3, 0.1, -0.05],
        ];
        let poses = exact_poses(truth, 80, &[0.0, 2.0], &offsets, 4);
        for start in [truth, &massless(truth)] {
            let g = fit(start, &poses, TorqueSign::Drive).unwrap();
            assert_eq!(g.offset.len(), 2);
            for (got, want) in g.offset.iter().zip(&offsets) {
                for (b, want) in got.iter().zip(want) {
                    assert!((b - want).abs() < 1e-6, "{b} vs {want}");
                }
            }
            assert_same_gravity(&g.robot, truth, 1e-6);
            assert!(g.residual.iter().all(|r| *r < 1e-6), "{:?}", g.residual);
            assert!(
                g.failed_checks(start).is_empty(),
                "{:?}",
                g.failed_checks(start)
            );
        }
    }

    /// The same torques reported as the sensors' load torques (negated):
    /// unstated, the sign is read as the load's — by the fit with two
    /// payloads (the drive's sign contradicts the payload's known torque),
    /// by the model's gravity with one (either sign fits) — and the masses
    /// are the drive's fit's, bit for bit. Read as the drive's against the
    /// data with two payloads, the fit fails its checks.
    #[test]
    fn the_load_sign_is_read_from_the_data() {
        let truth = &load_model("ur5e").unwrap().robot;
        for payloads in [&[0.0, 2.0][..], &[2.0][..]] {
            let drive = exact_poses(truth, 80, payloads, &[[0.1; 6]], 5);
            let mut load = drive.clone();
            for o in &mut load {
                o.torque = o.torque.as_ref().map(|t| t.iter().map(|v| -v).collect());
            }
            let want = fit(truth, &drive, TorqueSign::Drive).unwrap();
            for start in [truth, &massless(truth)] {
                let got = fit_with_sign(start, &load, None).unwrap();
                eprintln!(
                    "{payloads:?}: {} (residual {:?}, noise {:?})",
                    got.sign_summary(),
                    got.residual,
                    got.noise
                );
                assert_eq!(got.sign, TorqueSign::Load, "{payloads:?}");
                match (payloads.len(), &got.sign_source) {
                    (2, SignSource::Fit { .. }) | (1, SignSource::ModelGravity { .. }) => {}
                    (_, other) => panic!("{payloads:?}: {other:?}"),
                }
                if start == truth {
                    assert_eq!(got.robot, want.robot);
                }
                assert!(
                    got.failed_checks(start).is_empty(),
                    "{:?}",
                    got.failed_checks(start)
                );
            }
            let wrong = fit(truth, &load, TorqueSign::Drive).unwrap();
            assert!(
                !wrong.failed_checks(truth).is_empty(),
                "{payloads:?}: the wrong sign passes"
            );
        }
    }

    /// A simulated UR10e session (120 poses, payloads 0 and 5 kg, torque
    /// noise 0.05 N·m) as armcal reads its CSV, with `edit` applied to each
    /// row's tau cells.
    fn session_csv(model: &RobotModel, edit: impl Fn(&mut Vec<String>)) -> Measurements {
        let truth = load_model("ur10e").unwrap();
        let mut scenario = Scenario::tracker(120, 8);
        scenario.torque_noise = Some(0.05);
        let s = simulate(&truth.robot, &scenario).unwrap();
        let text: String = s
            .to_csv(&truth.units, "UR10e")
            .lines()
            .map(|l| {
                if l.starts_with('#') || l.starts_with('q') {
                    return format!("{l}\n");
                }
                let cells: Vec<String> = l.split(',').map(String::from).collect();
                let mut tau = cells[cells.len() - 6..].to_vec();
                edit(&mut tau);
                let mut row = cells[..cells.len() - 6].to_vec();
                row.extend(tau);
                row.join(",") + "\n"
            })
            .collect();
        parse_measurements(&text, "s.csv", model).unwrap()
    }

    /// Torques at the noise (σ = 0.05 N·m): the residual of each joint is
    /// its noise (within 25 %: 120 rows, the fit's own unknowns taken out),
    /// and the masses are used, with or without the model's.
    #[test]
    fn torques_at_the_noise_are_used() {
        let ur = load_model("ur10e").unwrap();
        let mut bare = ur.clone();
        bare.robot = massless(&ur.robot);
        for model in [&ur, &bare] {
            let data = session_csv(model, |_| {});
            let (fitted, g) = with_measured_gravity(model, &data, None).unwrap();
            let g = g.unwrap();
            assert_eq!(g.used, MassesUsed::Fitted, "{}", g.summary());
            assert_eq!(g.sign, TorqueSign::Drive);
            assert_eq!(fitted.robot, g.robot);
            for (j, (r, s)) in g.residual.iter().zip(&g.noise).enumerate() {
                assert!(
                    (0.75 * 0.05..1.25 * 0.05).contains(r),
                    "joint {}: {r}",
                    j + 1
                );
                assert!(
                    (0.75 * 0.05..1.25 * 0.05).contains(s),
                    "joint {}: {s}",
                    j + 1
                );
            }
        }
    }

    /// A column all zero, or constant, where gravity's torque about its
    /// joint varies: refused, the file and the column named.
    #[test]
    fn a_constant_torque_column_is_refused() {
        let ur = load_model("ur10e").unwrap();
        /// An edit of a row's tau cells.
        type Edit = fn(&mut Vec<String>);
        let zero: Edit = |t| t.iter_mut().for_each(|v| *v = "0".into());
        let constant: Edit = |t| t[2] = "12.5".into();
        // All zero: the first joint gravity turns is the second (the first
        // turns about the vertical).
        for (what, edit, column) in [("all zero", zero, "tau2"), ("constant", constant, "tau3")] {
            let data = session_csv(&ur, edit);
            let e = with_measured_gravity(&ur, &data, None).unwrap_err();
            assert_eq!(e.file, "s.csv", "{what}");
            assert!(
                e.message.contains(&format!("column '{column}'")),
                "{what}: {e}"
            );
        }
    }

    /// Two joints' columns swapped (tau2 and tau3): the fit contradicts
    /// both joints' torques; the model's masses are used, both columns
    /// named; without masses in the model, refused.
    #[test]
    fn swapped_torque_columns_are_not_used() {
        let ur = load_model("ur10e").unwrap();
        let swap = |t: &mut Vec<String>| t.swap(1, 2);
        let data = session_csv(&ur, swap);
        let (used, g) = with_measured_gravity(&ur, &data, None).unwrap();
        let g = g.unwrap();
        assert_eq!(used.robot, ur.robot, "the model's masses");
        let MassesUsed::ModelMasses(reasons) = &g.used else {
            panic!("used: {}", g.summary())
        };
        assert!(
            reasons[0].starts_with("tau2 and tau3 swapped?"),
            "{}",
            reasons.join("\n")
        );
        let mut bare = ur.clone();
        bare.robot = massless(&ur.robot);
        let data = session_csv(&bare, swap);
        let e = with_measured_gravity(&bare, &data, None).unwrap_err();
        assert_eq!(e.file, "s.csv");
        assert!(e.message.contains("no masses"), "{e}");
    }

    /// Torques of the load's sign stated as the drive's (two payloads):
    /// the fit contradicts them, the masses it gives are not used, and the
    /// sign that fits is named; unstated, the sign is read and the masses
    /// are used.
    #[test]
    fn a_flipped_sign_stated_wrong_is_not_used() {
        let ur = load_model("ur10e").unwrap();
        let data = session_csv(&ur, |t| {
            t.iter_mut()
                .for_each(|v| *v = format!("{}", -v.parse::<f64>().unwrap()))
        });
        let (used, g) = with_measured_gravity(&ur, &data, Some(TorqueSign::Drive)).unwrap();
        assert_eq!(used.robot, ur.robot);
        let MassesUsed::ModelMasses(reasons) = g.unwrap().used else {
            panic!("the fit of the wrong sign used")
        };
        assert!(
            reasons[0].ends_with("pass every check: --torque-sign load?"),
            "{reasons:?}"
        );
        let (_, g) = with_measured_gravity(&ur, &data, None).unwrap();
        let g = g.unwrap();
        assert_eq!((g.sign, &g.used), (TorqueSign::Load, &MassesUsed::Fitted));
        assert!(
            g.report()
                .summary()
                .contains("tau read as the sensors' load torques: negated")
        );
    }
}
