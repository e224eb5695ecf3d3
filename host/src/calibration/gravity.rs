//! Gravity from the joint torques a robot reports: the arm's masses fitted
//! so that the model's gravity torques are the measured ones.
//!
//! A joint's compliance twists it by `c τ_j`, with `τ_j` the torque gravity
//! exerts about joint `j` ([`armcal_shared::effects`]):
//!
//! ```text
//! τ_j = w_j · (Σ_{k ≥ j} m_k r_k + m_p p − ρ_j Σ_{k ≥ j} m_k − ρ_j m_p) × g      (revolute)
//! τ_j = w_j · g (Σ_{k ≥ j} m_k + m_p)                                            (prismatic)
//! ```
//!
//! with `m_k` the mass of link `k`, `r_k = o_k + R_k c_k` its centre of mass
//! (`c_k` in its own D-H frame), `m_p` the payload at the tool point `p`, and
//! `w_j`, `ρ_j` joint `j`'s axis and a point on it. It is linear in each
//! link's `m_k` and first moment `m_k c_k` (four unknowns a link). A robot
//! that reports its joint torques gives, at a pose held still, its drives'
//! torques `t_j = −τ_j + b_j` (`tau1..tauM`: the torque each drive exerts on
//! its link about the joint's axis, positive with increasing `q_j`; `b_j` a
//! sensor's offset). [`fit`] finds the masses, first moments and offsets of
//! least squares over the session's poses, held towards the model's own
//! masses (or the proxy's 1 kg at each link frame's origin, for a model
//! without masses) along what the torques cannot tell (Tikhonov, 10⁻⁸ of the
//! normal matrix's largest diagonal): the combinations of the masses that
//! gravity never shows stay at the model's values, and every combination it
//! does show is the data's.
//!
//! The identification then reads these masses as the model's
//! ([`with_measured_gravity`]): the compliance it fits is in rad/(N·m) of the
//! measured torques, whatever the model's masses were (an arm without a mass
//! model gets a compliance all the same), and the calibration written carries
//! the fitted masses, so `predict`, `compensate` and the controller compute
//! the same torques at any configuration — a robot program's targets
//! included, where no torque was measured.
//!
//! Units: SI (kg, m, N·m; N for a prismatic joint).

use armcal_shared::{JointType, LinkMass, Robot};
use nalgebra::{DMatrix, DVector, Vector3};

use crate::session::measurements::{Measurements, Observation};
use crate::session::model::RobotModel;

/// The regularisation towards the model's masses, relative to the normal
/// matrix's largest diagonal: far below what any pose shows.
const HOLD: f64 = 1e-8;

/// The masses fitted to a session's measured torques.
#[derive(Clone, Debug, PartialEq)]
pub struct GravityFit {
    /// The model with the fitted masses and centres of mass.
    pub robot: Robot<f64>,
    /// Each joint's RMS torque residual, N·m (N).
    pub residual: Vec<f64>,
    /// Each joint's RMS measured torque about its mean, N·m (N): what the
    /// residual compares with.
    pub spread: Vec<f64>,
    /// Each joint's fitted offset `b_j`, N·m (N).
    pub offset: Vec<f64>,
    /// The poses fitted.
    pub poses: usize,
    /// Whether the model had masses (else the proxy was held to).
    pub model_had_masses: bool,
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
/// each joint's offset) and its torques as the rows fit them, `−t − known`
/// (`−t_j = τ_j − b_j`); `None` for a pose without torques.
fn rows(robot: &Robot<f64>, obs: &Observation) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let t = obs.torque.as_ref()?;
    let (a, known) = design(robot, obs)?;
    let m = robot.dof();
    let mut full = DMatrix::zeros(m, 5 * m);
    full.view_mut((0, 0), (m, 4 * m)).copy_from(&a);
    for j in 0..m {
        full[(j, 4 * m + j)] = -1.0;
    }
    Some((full, DVector::from_fn(m, |j, _| -t[j] - known[j])))
}

/// The masses of `robot` fitted to the measured torques of `poses` (see
/// the module header); `None` when no pose has them. Two passes over the
/// poses, the second for the residuals: nothing kept per pose.
pub fn fit(robot: &Robot<f64>, poses: &[Observation]) -> Option<GravityFit> {
    let m = robot.dof();
    let mut normal = DMatrix::<f64>::zeros(5 * m, 5 * m);
    let mut rhs = DVector::<f64>::zeros(5 * m);
    let mut fitted_poses = 0;
    for (full, y) in poses.iter().filter_map(|o| rows(robot, o)) {
        normal += full.transpose() * &full;
        rhs += full.transpose() * &y;
        fitted_poses += 1;
    }
    if fitted_poses == 0 {
        return None;
    }
    let x0 = prior(robot);
    let hold = HOLD * normal.diagonal().max().max(f64::MIN_POSITIVE);
    for i in 0..4 * m {
        normal[(i, i)] += hold;
        rhs[i] += hold * x0[i];
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
    for (full, y) in poses.iter().filter_map(|o| rows(robot, o)) {
        let r = &y - full * &x;
        for j in 0..m {
            residual[j] += r[j] * r[j] / n;
            mean[j] += y[j] / n;
            square[j] += y[j] * y[j] / n;
        }
    }
    Some(GravityFit {
        robot: fitted,
        residual: residual.iter().map(|s| s.sqrt()).collect(),
        spread: (0..m)
            .map(|j| (square[j] - mean[j] * mean[j]).max(0.0).sqrt())
            .collect(),
        offset: (0..m).map(|j| x[4 * m + j]).collect(),
        poses: fitted_poses,
        model_had_masses: robot.links.iter().any(|l| l.mass.is_some()),
    })
}

/// `model` with the masses fitted to `data`'s measured torques, and the
/// fit; `model` as it is when the session has none.
pub fn with_measured_gravity(
    model: &RobotModel,
    data: &Measurements,
) -> (RobotModel, Option<GravityFit>) {
    match fit(&model.robot, &data.poses) {
        None => (model.clone(), None),
        Some(g) => {
            let mut fitted = model.clone();
            fitted.robot = g.robot.clone();
            (fitted, Some(g))
        }
    }
}

impl GravityFit {
    /// The reports' `gravity`: where the compliance's torques come from.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "source": "measured joint torques",
            "poses": self.poses,
            "model_had_masses": self.model_had_masses,
            "residual_nm": self.residual,
            "spread_nm": self.spread,
            "offset_nm": self.offset,
        })
    }

    /// The summary's line: where the compliance's torques come from.
    pub fn summary(&self) -> String {
        let worst = self
            .residual
            .iter()
            .zip(&self.spread)
            .enumerate()
            .max_by(|a, b| a.1.0.total_cmp(b.1.0));
        let mut s = format!(
            "gravity torques from the measured joint torques (tau1..tau{}, {} poses): the arm's masses fitted ({}); a compliance twists by these",
            self.residual.len(),
            self.poses,
            if self.model_had_masses {
                "held to the model's where the torques do not show them"
            } else {
                "the model has none: held to 1 kg at each link frame where the torques do not show them"
            }
        );
        if let Some((j, (r, spread))) = worst {
            s.push_str(&format!(
                "; largest residual joint {}: {r:.3} N·m RMS of a {spread:.3} N·m spread",
                j + 1
            ));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use armcal_shared::effects::{Approach, gravity_torques};
    use nalgebra::Point3;

    /// A UR5e with its model masses, measured torques the drives' (minus
    /// gravity's, plus an offset per joint): the fit gives back gravity's
    /// torques at other configurations to 1e-6 N·m, from the model without
    /// masses too, and the offsets.
    #[test]
    fn the_fitted_masses_give_the_measured_torques_back() {
        let model = crate::io::model_file::load_model("ur5e").unwrap();
        let truth = &model.robot;
        assert!(truth.links.iter().any(|l| l.mass.is_some()));
        let mut r = crate::calibration::simulate::rng(4);
        let configurations = crate::calibration::simulate::random_configurations(truth, 80, &mut r);
        let offset = [0.3, -0.2, 0.1, 0.05, -0.04, 0.02];
        let mut approach = Approach::new();
        let poses: Vec<Observation> = configurations
            .iter()
            .enumerate()
            .map(|(i, q)| {
                let payload = if i % 2 == 0 { 0.0 } else { 2.0 };
                let chain = truth.chain(q).unwrap();
                let tau = gravity_torques(truth, &chain, payload);
                let t: Vec<f64> = tau.iter().zip(offset).map(|(g, b)| -g + b).collect();
                Observation::of_row(
                    q.clone(),
                    Point3::origin(),
                    None,
                    (None, Some(payload)),
                    Some(t),
                    &mut approach,
                )
            })
            .collect();
        let mut massless = truth.clone();
        for l in &mut massless.links {
            l.mass = None;
        }
        for start in [truth, &massless] {
            let g = fit(start, &poses).unwrap();
            for (b, want) in g.offset.iter().zip(offset) {
                assert!((b - want).abs() < 1e-6, "{b} vs {want}");
            }
            for q in crate::calibration::simulate::random_configurations(truth, 20, &mut r) {
                let want = gravity_torques(truth, &truth.chain(&q).unwrap(), 1.0);
                let got = gravity_torques(&g.robot, &g.robot.chain(&q).unwrap(), 1.0);
                for (a, b) in got.iter().zip(&want) {
                    assert!((a - b).abs() < 1e-6, "{a} vs {b}");
                }
            }
            assert!(g.residual.iter().all(|r| *r < 1e-6), "{:?}", g.residual);
        }
    }
}
