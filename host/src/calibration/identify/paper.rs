//! The Iterative Regression Algorithm of Mirman & Gupta (1992), faithfully.
//!
//! The model is the 3M position-independent one: for each joint the link twist
//! `dα_m`, the link length `da_m` and the fixed joint parameter, `ds_m` of a
//! revolute joint (or `dθ_m` of a prismatic one). The joint-variable error `dθ_m`
//! of a revolute joint is position dependent: it may be supplied per pose, and
//! is zero otherwise (eq. 56).
//!
//! Each iteration:
//! 1. evaluates the current model (nominal + errors so far) at every pose, with
//!    the joint readings plus the position-dependent errors, and the end-effector
//!    error `w = [νdφ; dη]` of eq. (15) against the measured `A_h^actual`;
//! 2. builds the 6N × 3M regressor matrix `B = [J_α J_a J_s]` of the special
//!    Jacobians (eqs. 51–54, 56);
//! 3. scales every regressor and `w` to correlation form (eq. 59),
//!    `(b_i − b̄_i)/σ_i` and `(w − w̄)/σ_w`, so that the correlation matrix
//!    `r = [r_ij]` replaces `BᵀB` in the normal equations (eq. 58);
//! 4. declares the regressors `i < j` dependent when `|r_ij| ≈ 1` (within
//!    [`PaperOptions::dependence`]) and holds the later one, `j`, at zero for this
//!    iteration (the PUMA's `s3` beside `s2` while `α2 = 0`, Table 2);
//! 5. solves `r x' = zᵀw' / (6N − 1)` and unscales, `x_i = x'_i σ_w / σ_i`;
//! 6. step-cut: while either sum of squares, rotational `Σ|νdφ|²` or translational
//!    `Σ|dη|²`, would grow, halves the step, up to eight times;
//! 7. stops when every change is below `1e-7` (the paper's ε).
//!
//! Units are the caller's: the paper's PUMA is in inches and radians, and the
//! correlation scaling makes the mixed units harmless.

use armcal_shared::{JointType, Param, Robot, pose_error};
use nalgebra::{DMatrix, DVector, IsometryMatrix3};

/// One measured pose for the paper's model.
#[derive(Clone, Debug)]
pub struct PaperPose {
    /// Joint readings.
    pub q: Vec<f64>,
    /// The measured end-effector frame `A_h^actual`.
    pub actual: IsometryMatrix3<f64>,
    /// Position-dependent joint errors `dθ` (revolute) or `ds` (prismatic) at this
    /// pose, if known; zero otherwise.
    pub joint_errors: Option<Vec<f64>>,
}

/// Settings of the iterative regression; the defaults are the paper's.
#[derive(Clone, Copy, Debug)]
pub struct PaperOptions {
    /// Most iterations.
    pub max_iterations: usize,
    /// Convergence: every parameter change below this (paper: 1e-7).
    pub tolerance: f64,
    /// Most halvings of a step that would increase an error sum of squares (paper: 8).
    pub max_step_cuts: usize,
    /// Two regressors are dependent when `1 − |r_ij|` is below this.
    pub dependence: f64,
}

impl Default for PaperOptions {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            tolerance: 1e-7,
            max_step_cuts: 8,
            dependence: 1e-9,
        }
    }
}

/// What one iteration did.
#[derive(Clone, Debug)]
pub struct Iteration {
    /// The accumulated errors after this iteration, in the order of [`PaperFit::params`].
    pub errors: Vec<f64>,
    /// Regressors held at zero in this iteration, each with the one it depends on and `r_ij`.
    pub dependent: Vec<(Param, Param, f64)>,
    /// Halvings of the step.
    pub step_cuts: usize,
    /// Rotational and translational sums of squares before this iteration's step.
    pub sum_sq_before: (f64, f64),
    /// Largest change of a parameter in this iteration.
    pub max_change: f64,
}

/// The result of the iterative regression.
#[derive(Clone, Debug)]
pub struct PaperFit {
    /// The 3M parameters, in the paper's order: every `α`, every `a`, then every
    /// `s` (or `θ` for a prismatic joint).
    pub params: Vec<Param>,
    /// Identified errors (identified minus nominal), same order.
    pub errors: Vec<f64>,
    /// Every iteration, first to last.
    pub iterations: Vec<Iteration>,
    /// True if the last change was below the tolerance.
    pub converged: bool,
    /// Rotational and translational sums of squares of the final model.
    pub sum_sq: (f64, f64),
}

/// Why the regression could not run.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum PaperError {
    /// Fewer equations than unknowns.
    #[error(
        "{poses} poses give {equations} equations for {unknowns} unknowns: measure at least {needed} poses"
    )]
    TooFewPoses {
        /// Poses given.
        poses: usize,
        /// 6 per pose.
        equations: usize,
        /// 3M.
        unknowns: usize,
        /// Poses needed.
        needed: usize,
    },
    /// A pose's joint count differs from the model's.
    #[error("pose {pose}: {got} joint values, the model has {expected} joints")]
    JointCount {
        /// 1-based pose index.
        pose: usize,
        /// Model joints.
        expected: usize,
        /// Values given.
        got: usize,
    },
}

/// The 3M position-independent parameters of `robot`, in the paper's order.
pub fn paper_params(robot: &Robot<f64>) -> Vec<Param> {
    let m = robot.dof();
    let fixed_joint = |i: usize| match robot.links[i].joint {
        JointType::Revolute => Param::S(i),
        JointType::Prismatic => Param::Theta(i),
    };
    (0..m)
        .map(Param::Alpha)
        .chain((0..m).map(Param::A))
        .chain((0..m).map(fixed_joint))
        .collect()
}

/// Runs the Iterative Regression Algorithm from the nominal model.
pub fn identify_paper(
    nominal: &Robot<f64>,
    poses: &[PaperPose],
    options: &PaperOptions,
) -> Result<PaperFit, PaperError> {
    let params = paper_params(nominal);
    let (n, k) = (poses.len(), params.len());
    if 6 * n < k + 1 {
        return Err(PaperError::TooFewPoses {
            poses: n,
            equations: 6 * n,
            unknowns: k,
            needed: (k + 1).div_ceil(6),
        });
    }
    for (i, p) in poses.iter().enumerate() {
        let bad = |got| PaperError::JointCount {
            pose: i + 1,
            expected: nominal.dof(),
            got,
        };
        if p.q.len() != nominal.dof() {
            return Err(bad(p.q.len()));
        }
        if let Some(e) = p.joint_errors.as_ref().filter(|e| e.len() != nominal.dof()) {
            return Err(bad(e.len()));
        }
    }

    let mut x = vec![0.0; k];
    let mut iterations = Vec::new();
    let mut converged = false;
    let (_, _, mut sum_sq) = linear_system(nominal, &params, &x, poses);
    for _ in 0..options.max_iterations {
        let (b, w, before) = linear_system(nominal, &params, &x, poses);
        let (mut dx, dependent) = correlation_regression(&b, &w, &params, options.dependence);
        // Step-cut: halve while either sum of squares would grow.
        let mut step_cuts = 0;
        let mut trial: Vec<f64> = x.iter().zip(&dx).map(|(a, d)| a + d).collect();
        let mut after = sums_of_squares(nominal, &params, &trial, poses);
        while (after.0 > before.0 || after.1 > before.1) && step_cuts < options.max_step_cuts {
            dx.iter_mut().for_each(|d| *d *= 0.5);
            trial = x.iter().zip(&dx).map(|(a, d)| a + d).collect();
            after = sums_of_squares(nominal, &params, &trial, poses);
            step_cuts += 1;
        }
        x = trial;
        sum_sq = after;
        let max_change = dx.iter().fold(0.0f64, |m, d| m.max(d.abs()));
        iterations.push(Iteration {
            errors: x.clone(),
            dependent,
            step_cuts,
            sum_sq_before: before,
            max_change,
        });
        if max_change < options.tolerance {
            converged = true;
            break;
        }
    }
    Ok(PaperFit {
        params,
        errors: x,
        iterations,
        converged,
        sum_sq,
    })
}

/// `nominal` with `errors` added to `params`.
fn with_errors(nominal: &Robot<f64>, params: &[Param], errors: &[f64]) -> Robot<f64> {
    let mut robot = nominal.clone();
    for (p, e) in params.iter().zip(errors) {
        if let Some(v) = robot.param_mut(*p) {
            *v += e;
        }
    }
    robot
}

/// The joint values at which the current model is evaluated: readings plus the
/// position-dependent errors.
fn joint_values(pose: &PaperPose) -> Vec<f64> {
    match &pose.joint_errors {
        Some(e) => pose.q.iter().zip(e).map(|(q, d)| q + d).collect(),
        None => pose.q.clone(),
    }
}

/// `B` (6N × 3M), `w` (6N) and the rotational and translational sums of squares
/// of `w` at the current errors `x`.
fn linear_system(
    nominal: &Robot<f64>,
    params: &[Param],
    x: &[f64],
    poses: &[PaperPose],
) -> (DMatrix<f64>, DVector<f64>, (f64, f64)) {
    let current = with_errors(nominal, params, x);
    let mut b = DMatrix::zeros(6 * poses.len(), params.len());
    let mut w = DVector::zeros(6 * poses.len());
    let (mut rot, mut trans) = (0.0, 0.0);
    for (i, pose) in poses.iter().enumerate() {
        // Joint counts were checked on entry.
        let Ok(chain) = current.chain(&joint_values(pose)) else {
            continue;
        };
        let e = pose_error(&pose.actual, &chain.end);
        rot += e.fixed_rows::<3>(0).norm_squared();
        trans += e.fixed_rows::<3>(3).norm_squared();
        w.fixed_rows_mut::<6>(6 * i).copy_from(&e);
        for (j, p) in params.iter().enumerate() {
            b.fixed_view_mut::<6, 1>(6 * i, j)
                .copy_from(&chain.column(*p));
        }
    }
    (b, w, (rot, trans))
}

fn sums_of_squares(
    nominal: &Robot<f64>,
    params: &[Param],
    x: &[f64],
    poses: &[PaperPose],
) -> (f64, f64) {
    let current = with_errors(nominal, params, x);
    let (mut rot, mut trans) = (0.0, 0.0);
    for pose in poses {
        if let Ok(end) = current.forward(&joint_values(pose)) {
            let e = pose_error(&pose.actual, &end);
            rot += e.fixed_rows::<3>(0).norm_squared();
            trans += e.fixed_rows::<3>(3).norm_squared();
        }
    }
    (rot, trans)
}

/// Column means and standard deviations (sample, `n − 1`).
fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// One regression in correlation form (eqs. 58–59): the parameter changes, with
/// dependent regressors held at zero, and the dependences found.
fn correlation_regression(
    b: &DMatrix<f64>,
    w: &DVector<f64>,
    params: &[Param],
    dependence: f64,
) -> (Vec<f64>, Vec<(Param, Param, f64)>) {
    let (rows, k) = b.shape();
    let (w_mean, w_std) = mean_std(w.as_slice());
    let mut dx = vec![0.0; k];
    if w_std == 0.0 {
        return (dx, Vec::new()); // exact fit: nothing to regress
    }
    let mut z = b.clone();
    let sigma: Vec<f64> = z
        .column_iter_mut()
        .map(|mut col| {
            let (mean, std) = mean_std(col.as_slice());
            if std > 0.0 {
                col.iter_mut().for_each(|v| *v = (*v - mean) / std);
            }
            std
        })
        .collect();
    let wz = w.map(|v| (v - w_mean) / w_std);
    let r = z.transpose() * &z / (rows as f64 - 1.0);
    // Dependence: hold the later of each nearly collinear pair (and any regressor
    // without variation) at zero.
    let mut active: Vec<bool> = sigma.iter().map(|s| *s > 0.0).collect();
    let mut dependent = Vec::new();
    for j in 0..k {
        for i in 0..j {
            if active[i] && active[j] && 1.0 - r[(i, j)].abs() < dependence {
                active[j] = false;
                dependent.push((params[j], params[i], r[(i, j)]));
            }
        }
    }
    let idx: Vec<usize> = (0..k).filter(|&j| active[j]).collect();
    let r_sub = DMatrix::from_fn(idx.len(), idx.len(), |a, c| r[(idx[a], idx[c])]);
    let rhs = DVector::from_iterator(
        idx.len(),
        idx.iter()
            .map(|&j| z.column(j).dot(&wz) / (rows as f64 - 1.0)),
    );
    // The correlation matrix of independent regressors is positive definite;
    // should rounding make it not so, the SVD gives the least-squares answer.
    let xp = match r_sub.clone().cholesky() {
        Some(ch) => ch.solve(&rhs),
        None => r_sub
            .svd(true, true)
            .solve(&rhs, 1e-12)
            .unwrap_or_else(|_| DVector::zeros(idx.len())),
    };
    for (a, &j) in idx.iter().enumerate() {
        dx[j] = xp[a] * w_std / sigma[j];
    }
    (dx, dependent)
}
