//! Joint compensation: the commands that make the calibrated robot reach the pose
//! the nominal model intended. Kirchner, Gurumoorthy & Prinz (1985), section 4.
//!
//! The controller's nominal model turned a desired pose into joint commands
//! `q_cmd`; the real (calibrated) robot at `q_cmd` misses that pose. Wanted: `q`
//! with
//!
//! ```text
//! T_cal(q) = T_nom(q_cmd)                    (the pose the nominal model intended)
//! ```
//!
//! Writing `q = q_cmd + δq`, the paper expands the real forward solution in the
//! controllable changes `δq` (eq. 4.3) and balances it against the source term `f`
//! of the errors (eq. 4.8), `J_r δq + δqᵀ H δq + f = 0` (4.6), solved by the series
//! inversion (4.9):
//!
//! ```text
//! δq = −J_r⁻¹ (f + H(J_r⁻¹ f, J_r⁻¹ f) + …)
//! ```
//!
//! with `J_r` the real (calibrated) manipulator Jacobian and `f = x_real − x_target`.
//! Here `−f` is the residual `e` between the target and the calibrated robot, the
//! first-order step is `δ₁ = J_r⁺ e`, the second-order term `H(δ₁, δ₁)` is the
//! second-order part of the calibrated frame's change under `δ₁` (eq. 2.22 with the
//! joint variables as the parameters, [`crate::perturbation::expand`]), and
//! `δq = J_r⁺ (e − H(δ₁, δ₁))`. The step is repeated from the new `q` until the
//! residual is below the tolerance: each repetition is the same expansion about a
//! better point, and the error falls as the cube of the previous one.
//!
//! - Full pose when the calibration has orientation: 6 rows, rotation (rad, scaled
//!   by [`Limits::length_scale`] so that both parts are lengths) and position (m).
//!   Position only otherwise: 3 rows, and the minimum-norm correction.
//! - `J_r⁺` is the damped least-squares inverse `Jᵀ (J Jᵀ + λ² I)⁻¹`: for a
//!   6-axis arm away from singularities it is `J⁻¹` (up to `λ²/σ²`), near one it
//!   bounds the step instead of exploding; refinement removes the damping's bias
//!   wherever the robot can reach the target.
//! - The correction `δq` is bounded per joint ([`Limits::max_correction_angle`],
//!   [`Limits::max_correction_length`]), and its change from the previous tick's
//!   correction too ([`Limits::max_change_angle`], [`Limits::max_change_length`]).
//! - Any non-finite input or intermediate value returns the nominal command with
//!   [`Fault::NonFinite`]: the controller never sends a wild command.
//!
//! A step is taken only if it lowers the residual: the second-order step, else the
//! first-order one, each halved up to three times; near a singularity the
//! linearisation overshoots, and the best point found is kept. The cost per call
//! is bounded by [`Limits::max_iterations`]: each iteration is one to eight chains
//! of the calibrated model (one when the step succeeds, as it does away from
//! singularities), one second-order expansion and two 6 × 6 (or 3 × 3) Cholesky
//! solves; no allocation.

use heapless::Vec;
use nalgebra::{Matrix3, Matrix6, SMatrix, Vector3, Vector6};

use crate::jacobian::at_point;
use crate::kinematics::Prepared;
use crate::perturbation::expand;
use crate::{
    Calibration, Chain, Convention, JointType, MAX_JOINTS, Param, Real, Robot, rotation_error,
};

/// Bounds and tolerances of the compensation, SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits<T: Real> {
    /// Largest correction of a revolute joint, rad.
    pub max_correction_angle: T,
    /// Largest correction of a prismatic joint, m.
    pub max_correction_length: T,
    /// Largest change of a revolute joint's correction from one tick to the next, rad.
    pub max_change_angle: T,
    /// Largest change of a prismatic joint's correction per tick, m.
    pub max_change_length: T,
    /// Stop refining when the residual (position, and orientation times
    /// `length_scale`) is below this, m; above it after every iteration the
    /// correction is flagged [`Fault::NotConverged`].
    pub tolerance: T,
    /// Most refinement iterations (fixes the worst-case cost).
    pub max_iterations: usize,
    /// Damping `λ` of the least-squares inverse, m.
    pub damping: T,
    /// The length that turns rotation rows (rad) into lengths, m.
    pub length_scale: T,
}

impl<T: Real> Default for Limits<T> {
    /// Corrections up to 0.1 rad (5.7°) and 50 mm, changing by at most 0.01 rad and
    /// 5 mm per tick; refine until the residual is below 8 ε of a metre or 1 nm,
    /// whichever is larger (0.95 µm in f32, where rounding of a 1 m chain is about
    /// 0.1 µm; 1 nm in f64), in at most 4 iterations; damping 1e-4 m; rotations
    /// weighed at 1 m.
    fn default() -> Self {
        Self {
            max_correction_angle: T::lit(0.1),
            max_correction_length: T::lit(0.05),
            max_change_angle: T::lit(0.01),
            max_change_length: T::lit(0.005),
            tolerance: (T::default_epsilon() * T::lit(8.0)).max(T::lit(1e-9)),
            max_iterations: 4,
            damping: T::lit(1e-4),
            length_scale: T::one(),
        }
    }
}

/// Why a correction is not the plain solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Fault {
    /// A command or an intermediate value was not finite: the nominal command is returned.
    NonFinite,
    /// The command has the wrong number of joints: the command is returned unchanged.
    JointCount,
    /// The residual stayed above the tolerance after every iteration (near a
    /// singularity or out of reach): the best correction found is returned, bounded.
    NotConverged,
    /// The correction was clipped to its bounds.
    Limited,
}

/// The result of one compensation.
#[derive(Clone, Debug, PartialEq)]
pub struct Correction<T: Real> {
    /// The corrected joint commands (rad or m).
    pub q: Vec<T, MAX_JOINTS>,
    /// Something to report, if any; the commands are still safe to send.
    pub fault: Option<Fault>,
    /// Iterations run.
    pub iterations: usize,
    /// The remaining residual before bounding, m: the norm of the position error
    /// and of the orientation error times [`Limits::length_scale`].
    pub residual: T,
}

/// The compensation for one calibration: the nominal and the calibrated model,
/// prepared once.
#[derive(Clone, Debug)]
pub struct Compensator<T: Real> {
    nominal: Prepared<T>,
    calibrated: Prepared<T>,
    convention: Convention,
    joints: Vec<JointType, MAX_JOINTS>,
    orientation: bool,
    /// The bounds and tolerances in force.
    pub limits: Limits<T>,
}

impl<T: Real> Compensator<T> {
    /// A compensator from the nominal model (the controller's) and the calibrated
    /// one (the real robot's), with full-pose compensation if `orientation`.
    pub fn new(
        nominal: &Robot<T>,
        calibrated: &Robot<T>,
        orientation: bool,
        limits: Limits<T>,
    ) -> Self {
        Self {
            nominal: nominal.prepare(),
            calibrated: calibrated.prepare(),
            convention: calibrated.convention,
            joints: calibrated.links.iter().map(|l| l.joint).collect(),
            orientation,
            limits,
        }
    }

    /// A compensator for a calibration file's models, in the scalar `T` (`f32` on
    /// the controller), with full-pose compensation if it was identified from full poses.
    pub fn from_calibration(calibration: &Calibration, limits: Limits<T>) -> Self {
        Self::new(
            &calibration.nominal.cast(),
            &calibration.calibrated().cast(),
            calibration.orientation,
            limits,
        )
    }

    /// The number of joints.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// The joint parameter that a joint's command moves.
    fn joint_param(&self, m: usize) -> Param {
        match self.joints[m] {
            JointType::Revolute => Param::Theta(m),
            JointType::Prismatic => Param::S(m),
        }
    }

    /// The corrected commands for `q_cmd`. `previous` is the correction sent at the
    /// previous tick (`q − q_cmd`), to bound its change; `None` at the first tick.
    pub fn correct(&self, q_cmd: &[T], previous: Option<&[T]>) -> Correction<T> {
        let n = self.dof();
        let unchanged = |fault| Correction {
            q: q_cmd.iter().copied().take(MAX_JOINTS).collect(),
            fault: Some(fault),
            iterations: 0,
            residual: T::zero(),
        };
        if q_cmd.len() != n || previous.is_some_and(|p| p.len() != n) {
            return unchanged(Fault::JointCount);
        }
        let finite = |v: &[T]| v.iter().all(|x| x.is_finite());
        if !finite(q_cmd) || previous.is_some_and(|p| !finite(p)) {
            return unchanged(Fault::NonFinite);
        }
        let Ok(target) = self.nominal.forward(q_cmd) else {
            return unchanged(Fault::JointCount);
        };
        let mut q: Vec<T, MAX_JOINTS> = q_cmd.iter().copied().collect();
        let Ok(mut chain) = self.calibrated.chain(&q) else {
            return unchanged(Fault::JointCount);
        };
        let mut iterations = 0;
        let mut residual = self.residual(&target, &chain);
        let mut trial_q = q.clone();
        while residual.1 > self.limits.tolerance && iterations < self.limits.max_iterations {
            iterations += 1;
            let Some((first, second)) = self.step(&chain, &residual.0) else {
                return unchanged(Fault::NonFinite);
            };
            // Take a step only if it lowers the residual: the second-order one (eq.
            // 4.9) first, then the first-order one, each halved up to three times.
            // Near a singularity the linearisation overshoots and the second-order
            // term, built on an overshooting first step, can mislead; otherwise the
            // full second-order step is taken at once.
            let mut improved = false;
            'candidates: for mut step in [second, first] {
                // Trust region: no joint moves by more than its correction bound in
                // one step (near a singularity the step is otherwise huge).
                let mut scale = T::one();
                for (m, d) in step.iter().enumerate() {
                    let max = match self.joints[m] {
                        JointType::Revolute => self.limits.max_correction_angle,
                        JointType::Prismatic => self.limits.max_correction_length,
                    };
                    if d.abs() * scale > max {
                        scale = max / d.abs();
                    }
                }
                step.iter_mut().for_each(|d| *d *= scale);
                for _ in 0..4 {
                    for ((t, qm), d) in trial_q.iter_mut().zip(q.iter()).zip(step.iter()) {
                        *t = *qm + *d;
                    }
                    if self.calibrated.chain_into(&trial_q, &mut chain).is_err() {
                        return unchanged(Fault::JointCount);
                    }
                    let trial = self.residual(&target, &chain);
                    if trial.1 < residual.1 {
                        (residual, improved) = (trial, true);
                        core::mem::swap(&mut q, &mut trial_q);
                        break 'candidates;
                    }
                    step.iter_mut().for_each(|d| *d *= T::lit(0.5));
                }
            }
            if !improved {
                // `chain` holds the last trial: back to the best point.
                if self.calibrated.chain_into(&q, &mut chain).is_err() {
                    return unchanged(Fault::JointCount);
                }
                break;
            }
        }
        let mut fault = (residual.1 > self.limits.tolerance).then_some(Fault::NotConverged);
        // Bounds: the size of the correction, then its change since the last tick.
        for m in 0..n {
            let (max, change) = match self.joints[m] {
                JointType::Revolute => (
                    self.limits.max_correction_angle,
                    self.limits.max_change_angle,
                ),
                JointType::Prismatic => (
                    self.limits.max_correction_length,
                    self.limits.max_change_length,
                ),
            };
            let mut c = q[m] - q_cmd[m];
            let mut clip = |lo: T, hi: T| {
                if c < lo || c > hi {
                    c = c.clamp(lo, hi);
                    fault = fault.or(Some(Fault::Limited));
                }
            };
            // The change per tick first, then the size: the size bound always holds,
            // and when the previous correction was within it (as every correction
            // this returns is) both do.
            if let Some(prev) = previous {
                clip(prev[m] - change, prev[m] + change);
            }
            clip(-max, max);
            q[m] = q_cmd[m] + c;
        }
        if !finite(&q) || !residual.1.is_finite() {
            return unchanged(Fault::NonFinite);
        }
        Correction {
            q,
            fault,
            iterations,
            residual: residual.1,
        }
    }

    /// The residual `e` (rotation scaled to a length, then position; the rotation
    /// part is zero without orientation) and the position residual's norm.
    fn residual(&self, target: &nalgebra::IsometryMatrix3<T>, chain: &Chain<T>) -> (Vector6<T>, T) {
        let dp = target.translation.vector - chain.end.translation.vector;
        let dr = if self.orientation {
            rotation_error(&target.rotation, &chain.end.rotation) * self.limits.length_scale
        } else {
            Vector3::zeros()
        };
        // The size the steps lower: the norm of the whole residual, the orientation
        // counting as the position error it causes at `length_scale`.
        let e = Vector6::new(dr.x, dr.y, dr.z, dp.x, dp.y, dp.z);
        (e, e.norm())
    }

    /// The first-order step `δ₁ = J⁺ e` and the second-order one
    /// `δq = J⁺ (e − H(δ₁, δ₁))` (eq. 4.9); `None` if not finite.
    #[allow(clippy::type_complexity)]
    fn step(
        &self,
        chain: &Chain<T>,
        e: &Vector6<T>,
    ) -> Option<(Vec<T, MAX_JOINTS>, Vec<T, MAX_JOINTS>)> {
        let n = self.dof();
        let p = chain.point();
        // Rows of J_r: rotation (scaled) and the tool point's displacement.
        let mut jac = SMatrix::<T, 6, MAX_JOINTS>::zeros();
        for m in 0..n {
            let col = chain.column(self.joint_param(m));
            let v = at_point(&col, &p);
            let w = col.fixed_rows::<3>(0) * self.limits.length_scale;
            jac.set_column(m, &Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z));
        }
        let first = self.damped_solve(&jac, e)?;
        // Second-order change of the calibrated frame under δ₁ (eq. 2.22).
        let mut dq: Vec<(Param, T), MAX_JOINTS> = Vec::new();
        for (m, d) in first.iter().enumerate() {
            let _ = dq.push((self.joint_param(m), *d));
        }
        let expansion = expand(chain, self.convention, &dq).ok()?;
        let first_point = at_point(&expansion.first, &p);
        let second_point = expansion.point_error() - first_point;
        let second_rot = expansion.second_twist().fixed_rows::<3>(0) * self.limits.length_scale;
        let h = Vector6::new(
            second_rot.x,
            second_rot.y,
            second_rot.z,
            second_point.x,
            second_point.y,
            second_point.z,
        );
        let second = self.damped_solve(&jac, &(e - h))?;
        Some((first, second))
    }

    /// `Jᵀ (J Jᵀ + λ² I)⁻¹ r` over the rows in use (6 with orientation, 3 without).
    fn damped_solve(
        &self,
        jac: &SMatrix<T, 6, MAX_JOINTS>,
        r: &Vector6<T>,
    ) -> Option<Vec<T, MAX_JOINTS>> {
        let n = self.dof();
        let lambda2 = self.limits.damping * self.limits.damping;
        let y: Vector6<T> = if self.orientation {
            let mut a = Matrix6::<T>::zeros();
            for m in 0..n {
                let c = jac.column(m);
                a += c * c.transpose();
            }
            for i in 0..6 {
                a[(i, i)] += lambda2;
            }
            a.cholesky()?.solve(r)
        } else {
            let mut a = Matrix3::<T>::zeros();
            for m in 0..n {
                let c = jac.fixed_view::<3, 1>(3, m);
                a += c * c.transpose();
            }
            for i in 0..3 {
                a[(i, i)] += lambda2;
            }
            let yp = a.cholesky()?.solve(&r.fixed_rows::<3>(3).into_owned());
            Vector6::new(T::zero(), T::zero(), T::zero(), yp.x, yp.y, yp.z)
        };
        let mut out: Vec<T, MAX_JOINTS> = Vec::new();
        for m in 0..n {
            let d = jac.column(m).dot(&y);
            if !d.is_finite() {
                return None;
            }
            let _ = out.push(d);
        }
        Some(out)
    }
}
