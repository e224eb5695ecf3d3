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
//! region. Then a short path through them ([`order`]).
//!
//! ## What can be identified
//! What no choice of poses identifies (a parameter the model's geometry
//! makes inseparable from others, as `θ1` beside the base's turn about a
//! vertical first axis) is found as `identify` finds it: by identifying the
//! model from exact measurements at every candidate
//! ([`crate::calibration::identify::full`], its rank-revealing selection and
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

use armcal_shared::{Param, Robot};
use nalgebra::{DMatrix, Point3, UnitQuaternion};
use rand::RngExt;

use crate::calibration::identify::full::{
    FullOptions, Observation, Status, full_params, identify_full,
};
use crate::calibration::simulate::rng;
use crate::io::measurements::Contact;
use crate::session::prior::Prior;
use design::Candidates;

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
    /// Whether the instrument measures orientations too (full poses).
    pub orientation: bool,
    /// The position noise (m per axis) the plan is made and predicted for.
    pub position_noise: f64,
    /// The orientation noise (rad per axis), when measured.
    pub orientation_noise: f64,
    /// Random candidates drawn when none are given.
    pub candidates: usize,
    /// Random workspace configurations when no targets are given.
    pub workspace: usize,
    /// The share of each joint's range kept off each limit (0.05: 5 %).
    pub margin: f64,
    /// Where the tool point must stay.
    pub cell: Cell,
    /// The prior on the D-H errors `identify` will fit with (the model's).
    pub prior: Prior,
    /// How each pose is visited: once, or from both sides (for backlash).
    pub visits: Visits,
    /// Seed of every draw.
    pub seed: u64,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            poses: 30,
            orientation: false,
            position_noise: 20e-6,
            orientation_noise: 20e-6,
            candidates: 10_000,
            workspace: 2_000,
            margin: 0.05,
            cell: Cell::ANYWHERE,
            prior: Prior::default(),
            visits: Visits::Once,
            seed: 1,
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
    /// With [`Visits::BothSides`], the poses that could not be approached
    /// from both sides in every joint (a limit or the cell in the way).
    pub one_sided: usize,
    /// The plan's predicted accuracy.
    pub predicted: Prediction,
    /// As many random candidates' (`None` when they do not identify every
    /// parameter the plan does, with the ones they miss).
    pub random: Result<Prediction, Vec<Param>>,
    /// The parameters the plan identifies.
    pub identified: Vec<Param>,
    /// The parameters no choice of poses identifies, with why (`identify`'s
    /// reasons): the prior holds them.
    pub held: Vec<(Param, String)>,
    /// The length of the measurement path, joint space (rad, m).
    pub path: f64,
    /// The candidates the plan was chosen from (within the limits and the cell).
    pub candidates: usize,
    /// The workspace configurations it was made for.
    pub targets: usize,
    /// The nominal tool point of each workspace target, measurement frame, m.
    pub target_points: Vec<Point3<f64>>,
    /// The nominal tool point of each planned pose, in measurement order.
    pub points: Vec<Point3<f64>>,
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
    #[error("the {poses} poses chosen do not identify {}: measure more poses", names(.missed))]
    NotIdentified {
        /// Poses asked.
        poses: usize,
        /// The parameters they miss.
        missed: Vec<Param>,
    },
}

/// Parameter names, comma-separated.
fn names(params: &[Param]) -> String {
    params
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(", ")
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

/// Which of the full model's parameters `identify` separates from exact
/// measurements at `q` (at the stated noise of `options`), and the others
/// with its reasons.
fn identifiable(
    robot: &Robot<f64>,
    q: &[Vec<f64>],
    options: &PlanOptions,
) -> (Vec<Param>, Vec<(Param, String)>) {
    let fit_options = FullOptions {
        position_noise: options.position_noise,
        orientation_noise: options.orientation_noise,
        prior: Prior::NONE,
        ..FullOptions::default()
    }
    .stated();
    let data = exact(robot, q, options.orientation);
    let Ok(fit) = identify_full(robot, &data, &fit_options) else {
        let all = full_params(robot, options.orientation);
        return (
            Vec::new(),
            all.into_iter()
                .map(|p| (p, "not identified".into()))
                .collect(),
        );
    };
    let mut free = Vec::new();
    let mut held = Vec::new();
    for p in fit.params {
        match p.status {
            Status::Identified { .. } => free.push(p.param),
            Status::Fixed { reason } => held.push((p.param, reason)),
        }
    }
    (free, held)
}

/// The weighted Jacobian rows of `robot` at each of `q` (3 position rows
/// divided by `noise.0`, then 3 orientation rows divided by `noise.1` when
/// given) for `params`, stacked; the position rows alone, unweighted, when
/// `noise` is `None` (the targets').
fn jacobian(
    robot: &Robot<f64>,
    q: &[Vec<f64>],
    params: &[Param],
    noise: Option<(f64, Option<f64>)>,
) -> DMatrix<f64> {
    let (wp, wr) = match noise {
        Some((p, r)) => (1.0 / p, r.map(|r| 1.0 / r)),
        None => (1.0, None),
    };
    let rows = if wr.is_some() { 6 } else { 3 };
    let kinematics = robot.prepare();
    let mut j = DMatrix::zeros(rows * q.len(), params.len());
    for (i, qi) in q.iter().enumerate() {
        let Ok(chain) = kinematics.chain(qi) else {
            continue;
        };
        let p = chain.point();
        for (k, &param) in params.iter().enumerate() {
            let col = chain.column(param);
            let v = armcal_shared::jacobian::at_point(&col, &p);
            for a in 0..3 {
                j[(rows * i + a, k)] = v[a] * wp;
            }
            if let Some(wr) = wr {
                for a in 0..3 {
                    j[(rows * i + 3 + a, k)] = col[a] * wr;
                }
            }
        }
    }
    j
}

/// The plan for `robot` (see the module header): the poses among
/// `candidates` (or random ones within the limits) for the workspace
/// `targets` (or random configurations within the limits).
pub fn plan(
    robot: &Robot<f64>,
    candidates: Option<&[Vec<f64>]>,
    targets: Option<&[Vec<f64>]>,
    options: &PlanOptions,
) -> Result<Plan, PlanError> {
    let drawn;
    let given = match candidates {
        Some(c) => c,
        None => {
            drawn = within_limits(robot, options.candidates, options.margin, options.seed);
            &drawn
        }
    };
    // The candidates whose tool point stays within the cell.
    let kinematics = robot.prepare();
    let kept: Vec<Vec<f64>> = given
        .iter()
        .filter(|q| in_cell(&kinematics, q, &options.cell))
        .cloned()
        .collect();
    if kept.len() < options.poses {
        return Err(PlanError::TooFewCandidates {
            found: kept.len(),
            poses: options.poses,
        });
    }
    let (free, held) = identifiable(robot, &kept, options);
    let rows = if options.orientation { 6 } else { 3 };
    let equations = rows * options.poses;
    if equations < free.len() {
        return Err(PlanError::TooFewPoses {
            poses: options.poses,
            equations,
            parameters: free.len(),
            fewest: free.len().div_ceil(rows),
        });
    }
    let workspace_drawn;
    let workspace = match targets {
        Some(t) => t,
        None => {
            workspace_drawn = within_limits(robot, options.workspace, 0.0, options.seed ^ 0x7a7);
            &workspace_drawn
        }
    };
    let criterion = Criterion::of(robot, workspace, options);
    let poses = criterion.choose(robot, &kept, options);
    let (separated, _) = identifiable(robot, &poses, options);
    let missed: Vec<Param> = free
        .iter()
        .filter(|p| !separated.contains(p))
        .copied()
        .collect();
    if !missed.is_empty() {
        return Err(PlanError::NotIdentified {
            poses: options.poses,
            missed,
        });
    }
    let predicted = criterion
        .predict(robot, &poses, &free, options.position_noise)
        .expect("the plan identifies every parameter");
    let random_q = within_limits_in_cell(&kept, options.poses, options.seed ^ 0x5eed);
    let (random_free, _) = identifiable(robot, &random_q, options);
    let random_missed: Vec<Param> = free
        .iter()
        .filter(|p| !random_free.contains(p))
        .copied()
        .collect();
    let random = if random_missed.is_empty() {
        criterion
            .predict(robot, &random_q, &free, options.position_noise)
            .ok_or(random_missed)
    } else {
        Err(random_missed)
    };
    let path = order::path(&poses, &middle(&kept, robot.dof()));
    let ordered: Vec<Vec<f64>> = path.iter().map(|&i| poses[i].clone()).collect();
    let tool_point = |q: &Vec<f64>| {
        kinematics
            .forward(q)
            .map_or(Point3::origin(), |t| Point3::from(t.translation.vector))
    };
    let (rows, one_sided) = measurement_rows(robot, &ordered, options);
    let all: Vec<usize> = (0..rows.len()).collect();
    Ok(Plan {
        target_points: workspace.iter().map(tool_point).collect(),
        points: ordered.iter().map(tool_point).collect(),
        path: order::length(&rows, &all),
        q: rows,
        one_sided,
        predicted,
        random,
        identified: free,
        held,
        candidates: kept.len(),
        targets: workspace.len(),
    })
}

/// Whether the tool point of `kinematics` at `q` keeps within `cell`.
fn in_cell(kinematics: &armcal_shared::Prepared<f64>, q: &[f64], cell: &Cell) -> bool {
    kinematics
        .forward(q)
        .is_ok_and(|t| cell.holds(&Point3::from(t.translation.vector)))
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
            let kinematics = robot.prepare();
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
            order::both_sides(ordered, &limits, &prismatic, |q| {
                in_cell(&kinematics, q, &options.cell)
            })
        }
    }
}

/// What the plan minimises and predicts with: every parameter of the full
/// model, the prior's precision of each, the workspace targets' position
/// rows, the instrument's noise (see the module header).
struct Criterion {
    params: Vec<Param>,
    precision: Vec<f64>,
    /// The targets' position rows, unweighted (m per unit parameter).
    g: DMatrix<f64>,
    /// The position noise and, when measured, the orientation noise.
    noise: (f64, Option<f64>),
}

impl Criterion {
    /// The criterion of `robot` over the targets `workspace`.
    fn of(robot: &Robot<f64>, workspace: &[Vec<f64>], options: &PlanOptions) -> Self {
        let params = full_params(robot, options.orientation);
        Self {
            precision: params.iter().map(|p| options.prior.precision(*p)).collect(),
            g: jacobian(robot, workspace, &params, None),
            noise: (
                options.position_noise,
                options.orientation.then_some(options.orientation_noise),
            ),
            params,
        }
    }

    /// The poses among `kept` the exchange chooses ([`design::choose`]), in
    /// the order chosen.
    fn choose(
        &self,
        robot: &Robot<f64>,
        kept: &[Vec<f64>],
        options: &PlanOptions,
    ) -> Vec<Vec<f64>> {
        let rows = if options.orientation { 6 } else { 3 };
        let j = jacobian(robot, kept, &self.params, Some(self.noise));
        // Columns scaled to a unit mean square per candidate.
        let scale: Vec<f64> = j
            .column_iter()
            .map(|c| {
                let rms = c.norm() / (kept.len() as f64).sqrt();
                if rms > 0.0 { 1.0 / rms } else { 1.0 }
            })
            .collect();
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(scale.clone()));
        let w = (self.g.transpose() * &self.g) / (self.g.nrows() / 3).max(1) as f64;
        let candidates = Candidates::of(rows, &(&j * &d));
        let prior: Vec<f64> = self
            .precision
            .iter()
            .zip(&scale)
            .map(|(p, s)| p * s * s)
            .collect();
        design::choose(&candidates, &(&d * &w * &d), &prior, options.poses)
            .iter()
            .map(|&c| kept[c].clone())
            .collect()
    }

    /// The predicted accuracy of measuring `q` (see the module header), the
    /// observability of the parameters `free` (those a plan can separate) at
    /// the position noise `sigma`; `None` when `q` and the prior do not
    /// determine every parameter.
    fn predict(
        &self,
        robot: &Robot<f64>,
        q: &[Vec<f64>],
        free: &[Param],
        sigma: f64,
    ) -> Option<Prediction> {
        let j = jacobian(robot, q, &self.params, Some(self.noise));
        let mut information = j.transpose() * &j;
        for (k, p) in self.precision.iter().enumerate() {
            information[(k, k)] += p;
        }
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
        let s = design::scaled_singular_values(&jacobian(robot, q, free, Some(self.noise)));
        Some(Prediction {
            rms: mean.sqrt(),
            max: worst.sqrt(),
            measured_rms: (mean + 3.0 * sigma * sigma).sqrt(),
            std: self
                .params
                .iter()
                .enumerate()
                .map(|(k, p)| (*p, cov[(k, k)].max(0.0).sqrt()))
                .collect(),
            observability: design::observability(&s, j.nrows()),
            per_target: per_target.iter().map(|v| v.sqrt()).collect(),
        })
    }
}

/// `n` of the candidates `kept` (already within the limits and the cell),
/// drawn at random: the random plan a planned one is compared with.
fn within_limits_in_cell(kept: &[Vec<f64>], n: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut r = rng(seed);
    let mut indices: Vec<usize> = (0..kept.len()).collect();
    for i in 0..n.min(indices.len()) {
        let k = r.random_range(i..indices.len());
        indices.swap(i, k);
    }
    indices[..n.min(kept.len())]
        .iter()
        .map(|&i| kept[i].clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::simulate::{measure, with_random_errors};
    use crate::io::model_file::load_model;

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
                orientation,
                candidates: 3_000,
                ..PlanOptions::default()
            };
            let (free, _) = identifiable(&robot, &within_limits(&robot, 3_000, 0.05, 1), &asked);
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
            let fit = identify_full(&robot, &data, &FullOptions::least_squares()).unwrap();
            for param in &p.identified {
                let status = &fit
                    .params
                    .iter()
                    .find(|x| x.param == *param)
                    .unwrap()
                    .status;
                assert!(
                    matches!(status, Status::Identified { .. }),
                    "{name}, {} poses: {param} {status:?}",
                    options.poses
                );
            }
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
}
