//! The solution: Levenberg–Marquardt on the normal equations scaled to a
//! unit diagonal, with the prior's terms, stopping on the predicted decrease;
//! the parameter update. See the parent module's "Solution".

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::rows::NormalEquations;
use super::{FullError, FullOptions, Model, Unknown, prior_cost};
use crate::calibration::fit::noise::Weights;
use crate::session::rows::Rows;

/// The damping Levenberg–Marquardt starts from, on the normal equations
/// scaled to a unit diagonal: Nielsen's `τ = 1e-6` for a start near the
/// solution (the nominal model and the closed-form base and tool are), so that
/// the first steps are Gauss–Newton's.
pub(super) const LAMBDA_START: f64 = 1e-6;

/// Whether a step that lowers the weighted sum of squares (in units of the
/// noise², the prior's terms included) from `cost` by `decrease` is too small
/// to matter: less than 1e-8 of it, and never more than 1e-2. A Gauss–Newton
/// step `δ` lowers it by `δᵀGδ`, and no parameter moves by more than
/// `√(δᵀGδ)` of its standard error: by at most a tenth (adding at most 1 % to
/// its variance), however many poses.
pub(super) fn negligible(decrease: f64, cost: f64) -> bool {
    decrease <= (1e-8 * cost).min(1e-2)
}

/// Levenberg–Marquardt on `free` from `robot`, minimising the weighted sum of
/// squares plus the prior's `Σ (x − x_nominal)²/τ²` (`prior`: precision and
/// nominal value of each free unknown): iterations, convergence, the share
/// of the sum its last iteration removed (`None` when no damping lowered it:
/// [`FullFit::last_decrease`]) and the linearisation at the solution.
pub(super) fn levenberg_marquardt(
    robot: &mut Model,
    data: Rows<'_>,
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
            // A trial is a pass over the rows: the caller may stop it.
            options.cancel.check()?;
            let trial_sys =
                NormalEquations::accumulate(&trial, data, free_params, weights, options.cancel);
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
pub(super) fn predicted_decrease(g: &Mat<f64>, b: &Mat<f64>, d: &Mat<f64>) -> f64 {
    let n = d.nrows();
    let mut decrease = 0.0;
    for k in 0..n {
        let gd: f64 = (0..n).map(|l| g[(k, l)] * d[(l, 0)]).sum();
        decrease += d[(k, 0)] * (2.0 * b[(k, 0)] - gd);
    }
    decrease
}

/// Wraps an angle to (−π, π].
pub(super) fn wrap_angle(x: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let y = x.rem_euclid(two_pi);
    if y > std::f64::consts::PI {
        y - two_pi
    } else {
        y
    }
}

/// Adds `step` to `params` of `robot`.
pub(super) fn apply(robot: &mut Model, params: &[Unknown], step: &[f64]) {
    for (p, d) in params.iter().zip(step) {
        if let Some(v) = robot.get_mut(*p) {
            *v += d;
        }
    }
}
