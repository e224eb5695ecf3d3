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
//! A geometric step is taken only if it lowers the residual: the second-order step, else the
//! first-order one, each halved up to three times; near a singularity the
//! linearisation overshoots, and the best point found is kept. The cost per call
//! is bounded by [`Limits::max_iterations`]: each iteration is one to eight chains
//! of the calibrated model (one when the step succeeds, as it does away from
//! singularities), the joint-only second-order term (`â ŵ = w aᵀ − (a·w) I` per
//! joint instead of the 4 × 4 products of [`crate::perturbation::expand`]) and
//! one `L D Lᵀ` factorisation of `J Jᵀ + λ² I` (no square root) for both
//! solves; no allocation.
//!
//! **Warm start.** The search starts from the previous tick's joint positions
//! ([`Previous::p`]): `p = q_cmd + (p_prev − q_cmd_prev)`, the inversion of the
//! effects from `q = p − (p_prev − q_prev)`, each when that correction is within
//! the size bound (else from `q_cmd` and `p`, as at the first tick). On a smooth
//! motion one step then reaches the tolerance and one pass of the inversion
//! converges; the result is the same solution to within the tolerance.
//!
//! # Non-geometric effects
//!
//! A calibration from `armcal diagnose` adds effects ([`crate::effects`]) to the
//! geometry: the calibrated robot at commands (= joint readings) `q`, in the
//! tick's conditions (temperature `T`, payload `m`) and with approach signs `σ`, is
//!
//! ```text
//! T_cal(q; T, m, σ) = G_T(p),   p_j = q_j + Δq_j(q; m, σ_j)
//! Δq_j = c_j τ_j(q, m) + Σ_k (s_jk sin k q_j + c_jk cos k q_j) + ε_j q_j + b_j σ_j
//! ```
//!
//! with `G_T` the calibrated geometry whose lengths `a`, `s` are scaled by
//! `1 + κ (T − T_ref)` (thermal expansion; applied inside each chain,
//! [`Prepared::chain_scaled_into`], two multiplications per link, the model is
//! not copied), `τ_j` the gravity torque at the
//! readings (N·m, or N for a prismatic joint), `c_j` the compliance (rad/(N·m)),
//! the gear harmonics (rad), `ε_j` the encoder-scale error and `b_j` half the lost
//! motion (rad or m). The effects act on the joint readings only, so the solution
//! is found in two steps:
//!
//! 1. the geometric problem above on `G_T`: the real joint positions `p` with
//!    `G_T(p) = T_nom(q_cmd)`;
//! 2. the commands that put the joints at `p`: `q_j = (p_j − o_j(q) − b_j σ_j) /
//!    (1 + ε_j)`, with `o_j` the compliance and gear terms evaluated at the
//!    current `q` (one chain for the gravity torques when there is a compliance),
//!    repeated until no joint changes by more than [`Limits::tolerance`] /
//!    [`Limits::length_scale`] rad, at most [`Limits::max_iterations`] times. The
//!    encoder scale is inverted exactly; `o_j` changes with `q` by a factor of
//!    about 10⁻³ of the change in `q` (c·∂τ/∂q, the harmonic amplitudes), so each
//!    repetition gains three orders of magnitude: two or three suffice.
//!
//! **Approach direction.** The controller sends `q`, so `σ_j = sign(q_j −
//! q_prev_j)` of the commands *sent* (the corrected ones) at this and the previous
//! tick, 0 when the joint does not move and at the first tick: exactly what
//! [`crate::effects::approach_signs`] gives for the stream of sent commands, as
//! the calibration was identified from readings in row order. For a joint with
//! backlash, with `d_j = (p_j − o_j)/(1 + ε_j) − q_prev_j` the move that reaches
//! `p_j` without lost motion, `σ_j = sign(d_j)` and `q_j = q_prev_j + d_j − b_j σ_j
//! / (1 + ε_j)`, which is consistent when that move still has the sign `σ_j` (`|d_j|
//! > |b_j|/(1 + ε_j)`): the usual case, a joint moving on or reversing by more
//! than its lost motion. Otherwise the target lies within the lost motion (a
//! standstill after a motion, the first ticks of a reversal): no command reaches
//! it in this model, the joint is held at `q_prev_j` (`σ_j = 0`), and the pose is
//! missed by at most the lost motion at the joint's lever; the correction is
//! flagged [`Fault::NotConverged`] with that residual.
//!
//! The tick's conditions are [`Conditions`]: temperature °C, payload kg (0 when
//! not given); without a temperature the lengths are the reference ones. A
//! geometric calibration takes exactly the steps of the geometric problem.

use heapless::Vec;
use nalgebra::{IsometryMatrix3, Matrix3, Point3, Vector3, Vector6};

use crate::effects::{Effect, EffectModel, JointTerms, MAX_EFFECTS, gravity_torques};
use crate::jacobian::at_point;
use crate::kinematics::Prepared;
use crate::{Calibration, Chain, JointType, MAX_JOINTS, Param, Real, Robot, Twist, rotation_error};

/// The conditions of one tick that non-geometric effects depend on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Conditions<T: Real> {
    /// Temperature, °C; `None`: the reference temperature of thermal expansion.
    pub temperature: Option<T>,
    /// Payload at the tool point, kg; `None`: none.
    pub payload: Option<T>,
}

/// The previous tick, as it was sent: for the change bound of the correction and
/// the approach direction of each joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Previous<'a, T: Real> {
    /// The nominal commands of the previous tick.
    pub q_cmd: &'a [T],
    /// The commands sent at the previous tick (its corrected `q`).
    pub q: &'a [T],
    /// The joint positions the previous tick's commands aimed at (its
    /// [`Correction::p`]): the start of this tick's search.
    pub p: &'a [T],
}

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
    /// The real joint positions these commands aim at (the solution of the
    /// geometric problem, before bounding; `q_cmd` after a fault that returns
    /// it): give it back as [`Previous::p`] at the next tick.
    pub p: Vec<T, MAX_JOINTS>,
    /// Something to report, if any; the commands are still safe to send.
    pub fault: Option<Fault>,
    /// Iterations run.
    pub iterations: usize,
    /// The remaining residual before bounding, m: the norm of the position error
    /// and of the orientation error times [`Limits::length_scale`].
    pub residual: T,
}

/// The compensation for one calibration: the nominal and the calibrated model,
/// prepared once, and the calibration's effects.
#[derive(Clone, Debug)]
pub struct Compensator<T: Real> {
    nominal: Prepared<T>,
    calibrated: Prepared<T>,
    joints: Vec<JointType, MAX_JOINTS>,
    orientation: bool,
    /// The calibrated geometry (its masses and gravity, for the torques) and the
    /// effects; none for a geometric calibration.
    effects: EffectModel<T>,
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
        Self::with_effects(
            nominal,
            EffectModel {
                robot: calibrated.clone(),
                effects: Vec::new(),
            },
            orientation,
            limits,
        )
    }

    /// A compensator for a calibrated model with non-geometric effects.
    pub fn with_effects(
        nominal: &Robot<T>,
        calibrated: EffectModel<T>,
        orientation: bool,
        limits: Limits<T>,
    ) -> Self {
        Self {
            nominal: nominal.prepare(),
            calibrated: calibrated.robot.prepare(),
            joints: calibrated.robot.links.iter().map(|l| l.joint).collect(),
            orientation,
            effects: calibrated,
            limits,
        }
    }

    /// A compensator for a calibration file's models and effects, in the scalar
    /// `T` (`f32` on the controller), with full-pose compensation if it was
    /// identified from full poses.
    pub fn from_calibration(calibration: &Calibration, limits: Limits<T>) -> Self {
        // The identified errors are added in `T` (in f32 the sum rounds once more,
        // by at most an f32 unit in the last place): the controller then needs no
        // f64 arithmetic.
        let mut robot: Robot<T> = calibration.nominal.cast();
        for e in &calibration.errors {
            if let Some(v) = robot.param_mut(e.param) {
                *v += T::lit(e.error);
            }
        }
        let effects: Vec<Effect<T>, MAX_EFFECTS> =
            calibration.effects.iter().map(|e| e.cast()).collect();
        // `Calibration::decode` checked every effect's joint; a calibration built
        // in memory with an effect on a missing joint is compensated geometrically,
        // as `Calibration::model` evaluates it.
        let model = EffectModel::new(robot.clone(), &effects).unwrap_or(EffectModel {
            robot,
            effects: Vec::new(),
        });
        Self::with_effects(
            &calibration.nominal.cast(),
            model,
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

    /// The size bound and the change-per-tick bound of joint `m`'s correction.
    fn bounds(&self, m: usize) -> (T, T) {
        match self.joints[m] {
            JointType::Revolute => (
                self.limits.max_correction_angle,
                self.limits.max_change_angle,
            ),
            JointType::Prismatic => (
                self.limits.max_correction_length,
                self.limits.max_change_length,
            ),
        }
    }

    /// The corrected commands for `q_cmd` in the tick's `conditions`. `previous`
    /// is the previous tick as sent (`None` at the first tick): its correction
    /// bounds the change of this one, its commands give each joint's approach
    /// direction, and its joint positions start the search (see the module header).
    pub fn correct(
        &self,
        q_cmd: &[T],
        previous: Option<Previous<'_, T>>,
        conditions: &Conditions<T>,
    ) -> Correction<T> {
        let n = self.dof();
        let unchanged = |fault| Correction {
            q: q_cmd.iter().copied().take(MAX_JOINTS).collect(),
            p: q_cmd.iter().copied().take(MAX_JOINTS).collect(),
            fault: Some(fault),
            iterations: 0,
            residual: T::zero(),
        };
        if q_cmd.len() != n
            || previous.is_some_and(|p| p.q_cmd.len() != n || p.q.len() != n || p.p.len() != n)
        {
            return unchanged(Fault::JointCount);
        }
        let finite = |v: &[T]| v.iter().all(|x| x.is_finite());
        let conditions_finite = [conditions.temperature, conditions.payload]
            .iter()
            .all(|c| c.is_none_or(|x| x.is_finite()));
        if !finite(q_cmd)
            || previous.is_some_and(|p| !finite(p.q_cmd) || !finite(p.q) || !finite(p.p))
            || !conditions_finite
        {
            return unchanged(Fault::NonFinite);
        }
        let Ok(target) = self.nominal.forward(q_cmd) else {
            return unchanged(Fault::JointCount);
        };
        // The calibrated geometry at the tick's temperature: its lengths times
        // the thermal factor, applied inside each chain.
        let geometry = Geometry {
            model: &self.calibrated,
            factor: self.effects.length_factor(conditions.temperature),
        };
        // 1. The real joint positions p that reach the target, from the previous
        // tick's correction of them when it is within the bounds (warm start).
        let mut p: Vec<T, MAX_JOINTS> = q_cmd.iter().copied().collect();
        if let Some(prev) = previous {
            let warm = (0..n).all(|m| (prev.p[m] - prev.q_cmd[m]).abs() <= self.bounds(m).0);
            if warm {
                for m in 0..n {
                    p[m] += prev.p[m] - prev.q_cmd[m];
                }
            }
        }
        let mut chain = self.calibrated.empty_chain();
        if geometry.chain(&p, &mut chain).is_err() {
            return unchanged(Fault::JointCount);
        }
        let (iterations, mut residual2) = match self.solve(&geometry, &target, &mut p, &mut chain) {
            Ok(solved) => solved,
            Err(fault) => return unchanged(fault),
        };
        let tolerance2 = self.limits.tolerance * self.limits.tolerance;
        let mut fault = (residual2 > tolerance2).then_some(Fault::NotConverged);
        // 2. The commands that put the joints at p.
        let mut q = p.clone();
        if self.effects.corrects_joints() {
            match self.invert(&geometry, &mut q, previous, conditions, &mut chain) {
                None => return unchanged(Fault::NonFinite),
                Some(None) => {}
                Some(Some(held)) => {
                    if geometry.chain(&held, &mut chain).is_err() {
                        return unchanged(Fault::JointCount);
                    }
                    residual2 = self.residual(&target, &chain.end).1;
                    fault = (residual2 > tolerance2).then_some(Fault::NotConverged);
                }
            }
        }
        // Bounds: the size of the correction, then its change since the last tick.
        for m in 0..n {
            let (max, change) = self.bounds(m);
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
                let last = prev.q[m] - prev.q_cmd[m];
                clip(last - change, last + change);
            }
            clip(-max, max);
            q[m] = q_cmd[m] + c;
        }
        if !finite(&q) || !finite(&p) || !residual2.is_finite() {
            return unchanged(Fault::NonFinite);
        }
        Correction {
            q,
            p,
            fault,
            iterations,
            residual: residual2.sqrt(),
        }
    }

    /// The geometric problem: refines the joint positions `p` until `geometry`
    /// reaches `target` (eq. 4.9, repeated; see the module header). `chain` is at
    /// `p` on entry and on return. Returns the iterations and the squared norm of
    /// the residual.
    fn solve(
        &self,
        geometry: &Geometry<'_, T>,
        target: &IsometryMatrix3<T>,
        p: &mut Vec<T, MAX_JOINTS>,
        chain: &mut Chain<T>,
    ) -> Result<(usize, T), Fault> {
        let tolerance2 = self.limits.tolerance * self.limits.tolerance;
        let mut iterations = 0;
        let mut residual = self.residual(target, &chain.end);
        let mut trial_p = p.clone();
        while residual.1 > tolerance2 && iterations < self.limits.max_iterations {
            iterations += 1;
            let (first, second) = self.step(chain, &residual.0).ok_or(Fault::NonFinite)?;
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
                    let max = self.bounds(m).0;
                    if d.abs() * scale > max {
                        scale = max / d.abs();
                    }
                }
                step.iter_mut().for_each(|d| *d *= scale);
                for _ in 0..4 {
                    for ((t, pm), d) in trial_p.iter_mut().zip(p.iter()).zip(step.iter()) {
                        *t = *pm + *d;
                    }
                    geometry.chain(&trial_p, chain)?;
                    let trial = self.residual(target, &chain.end);
                    if trial.1 < residual.1 {
                        (residual, improved) = (trial, true);
                        core::mem::swap(p, &mut trial_p);
                        break 'candidates;
                    }
                    step.iter_mut().for_each(|d| *d *= T::lit(0.5));
                }
            }
            if !improved {
                // `chain` holds the last trial: back to the best point.
                geometry.chain(p, chain)?;
                break;
            }
        }
        Ok((iterations, residual.1))
    }

    /// The effects' inversion: replaces the joint positions `p` in `q` by the
    /// commands `q` with `q + Δq(q) = p` (see the module header), starting from
    /// `p` minus the previous tick's `Δq`. `None` if a value was not finite;
    /// `Some(Some(p'))` with the joint positions really reached when a joint was
    /// held within its lost motion; `Some(None)` otherwise. `chain` is a work
    /// buffer.
    #[allow(clippy::option_option)]
    fn invert(
        &self,
        geometry: &Geometry<'_, T>,
        q: &mut Vec<T, MAX_JOINTS>,
        previous: Option<Previous<'_, T>>,
        conditions: &Conditions<T>,
        chain: &mut Chain<T>,
    ) -> Option<Option<Vec<T, MAX_JOINTS>>> {
        let p = q.clone();
        let sent = previous.map(|prev| prev.q);
        if let Some(prev) = previous {
            // Warm start: the previous tick's joint correction Δq = p − q, when
            // within the bounds.
            let n = q.len();
            if (0..n).all(|m| (prev.p[m] - prev.q[m]).abs() <= self.bounds(m).0) {
                for m in 0..n {
                    q[m] -= prev.p[m] - prev.q[m];
                }
            }
        }
        let payload = conditions.payload.unwrap_or(T::zero());
        let tolerance = self.limits.tolerance / self.limits.length_scale;
        let sign = |x: T| {
            if x > T::zero() {
                T::one()
            } else if x < T::zero() {
                -T::one()
            } else {
                T::zero()
            }
        };
        let mut held = false;
        let mut tau: Vec<T, MAX_JOINTS> = q.iter().map(|_| T::zero()).collect();
        let mut terms = JointTerms {
            offset: Vec::new(),
            scale: Vec::new(),
            backlash: Vec::new(),
        };
        for _ in 0..self.limits.max_iterations.max(1) {
            if self.effects.needs_torque() {
                geometry.chain(q, chain).ok()?;
                tau = gravity_torques(&self.effects.robot, chain, payload);
            }
            terms = self.effects.joint_terms(q, &tau);
            let mut change = T::zero();
            held = false;
            for j in 0..q.len() {
                let stretch = T::one() + terms.scale[j];
                let mut next = (p[j] - terms.offset[j]) / stretch;
                if let Some(prev) = sent.filter(|_| terms.backlash[j] != T::zero()) {
                    let lost = terms.backlash[j] / stretch;
                    let d = next - prev[j];
                    let sigma = sign(d);
                    if sign(d - lost * sigma) == sigma {
                        next -= lost * sigma;
                    } else {
                        // Within the lost motion: held (σ = 0).
                        next = prev[j];
                        held = true;
                    }
                }
                change = change.max((next - q[j]).abs());
                q[j] = next;
            }
            if !change.is_finite() {
                return None;
            }
            if change <= tolerance {
                break;
            }
        }
        if !held {
            return Some(None);
        }
        // Where the joints really go: q + Δq(q) with the approach of the commands.
        let reached = q
            .iter()
            .enumerate()
            .map(|(j, &qj)| {
                let sigma = sent.map_or(T::zero(), |prev| sign(qj - prev[j]));
                qj + terms.correction(j, qj, sigma)
            })
            .collect();
        Some(Some(reached))
    }

    /// The residual `e` (rotation scaled to a length, then position; the rotation
    /// part is zero without orientation) and its squared norm.
    fn residual(
        &self,
        target: &IsometryMatrix3<T>,
        reached: &IsometryMatrix3<T>,
    ) -> (Vector6<T>, T) {
        let dp = target.translation.vector - reached.translation.vector;
        let dr = if self.orientation {
            rotation_error(&target.rotation, &reached.rotation) * self.limits.length_scale
        } else {
            Vector3::zeros()
        };
        // The size the steps lower: the norm of the whole residual, the orientation
        // counting as the position error it causes at `length_scale`.
        let e = Vector6::new(dr.x, dr.y, dr.z, dp.x, dp.y, dp.z);
        (e, e.norm_squared())
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
        // The joints' twists, and the rows of J_r: rotation (scaled) and the tool
        // point's displacement.
        let mut twists: Vec<Twist<T>, MAX_JOINTS> = Vec::new();
        let mut jac: Vec<[T; 6], MAX_JOINTS> = Vec::new();
        for m in 0..n {
            let col = chain.column(self.joint_param(m));
            let v = at_point(&col, &p);
            let s = self.limits.length_scale;
            // n ≤ MAX_JOINTS: always room.
            let _ = jac.push([col[0] * s, col[1] * s, col[2] * s, v.x, v.y, v.z]);
            let _ = twists.push(col);
        }
        let l = self.factor(&jac)?;
        let first = self.damped_solve(&jac, &l, e)?;
        // Second-order change of the calibrated frame under δ₁ (eq. 2.22).
        let (rot, point) = joint_second_order(&twists, &first, &p);
        let rot = rot * self.limits.length_scale;
        let h = Vector6::new(rot.x, rot.y, rot.z, point.x, point.y, point.z);
        let second = self.damped_solve(&jac, &l, &(e - h))?;
        Some((first, second))
    }

    /// The `L D Lᵀ` factors of `J Jᵀ + λ² I` over the rows in use (6 with
    /// orientation, the 3 position rows without): `L` (unit diagonal) below the
    /// diagonal of a 6 × 6 array, `1/D` on it (the first 3 × 3 without
    /// orientation); `None` if not positive definite or not finite. Written out
    /// rather than nalgebra's, so that one small loop serves both sizes (flash
    /// on the controller), one factorisation serves both solves of a step, and
    /// no square root is taken (a software routine on the controller).
    // Triangular index arithmetic reads best with indices.
    #[allow(clippy::needless_range_loop)]
    fn factor(&self, jac: &[[T; 6]]) -> Option<[[T; 6]; 6]> {
        let (first, k) = self.rows();
        let lambda2 = self.limits.damping * self.limits.damping;
        let mut a = [[T::zero(); 6]; 6];
        for i in 0..k {
            for j in 0..=i {
                let mut s = if i == j { lambda2 } else { T::zero() };
                for col in jac {
                    s += col[first + i] * col[first + j];
                }
                a[i][j] = s;
            }
        }
        // Column by column: D_j = A_jj − Σ_p L_jp² D_p, L_ij = (A_ij − Σ_p L_ip L_jp D_p) / D_j.
        for j in 0..k {
            let mut d = a[j][j];
            for p in 0..j {
                d -= a[j][p] * a[j][p] * a[p][p];
            }
            // Not positive, or NaN.
            if d.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
                return None;
            }
            let inv = T::one() / d;
            a[j][j] = inv;
            for i in j + 1..k {
                // Here a[i][p] (p < j) holds L_ip D_p, and a[j][p] L_jp D_p.
                let mut s = a[i][j];
                for p in 0..j {
                    s -= a[i][p] * a[j][p] * a[p][p];
                }
                a[i][j] = s;
            }
        }
        // a[i][j] holds L_ij D_j below the diagonal: divide by D_j.
        for j in 0..k {
            for i in j + 1..k {
                a[i][j] *= a[j][j];
            }
        }
        Some(a)
    }

    /// The first row in use and their number: 0 and 6 with orientation, 3 and 3
    /// without.
    fn rows(&self) -> (usize, usize) {
        if self.orientation { (0, 6) } else { (3, 3) }
    }

    /// `Jᵀ (J Jᵀ + λ² I)⁻¹ r` over the rows in use, with `l` from [`Self::factor`];
    /// `None` if not finite.
    // Triangular index arithmetic reads best with indices.
    #[allow(clippy::needless_range_loop)]
    fn damped_solve(
        &self,
        jac: &[[T; 6]],
        l: &[[T; 6]; 6],
        r: &Vector6<T>,
    ) -> Option<Vec<T, MAX_JOINTS>> {
        let (first, k) = self.rows();
        // L z = r, y = z / D, then Lᵀ y = y.
        let mut y = [T::zero(); 6];
        for i in 0..k {
            let mut s = r[first + i];
            for p in 0..i {
                s -= l[i][p] * y[p];
            }
            y[i] = s;
        }
        for i in 0..k {
            y[i] *= l[i][i];
        }
        for i in (0..k).rev() {
            let mut s = y[i];
            for p in i + 1..k {
                s -= l[p][i] * y[p];
            }
            y[i] = s;
        }
        let mut out: Vec<T, MAX_JOINTS> = Vec::new();
        for col in jac {
            let mut d = T::zero();
            for (i, yi) in y.iter().enumerate().take(k) {
                d += col[first + i] * *yi;
            }
            if !d.is_finite() {
                return None;
            }
            let _ = out.push(d);
        }
        Some(out)
    }
}

/// The calibrated geometry at one tick's temperature: the prepared model and
/// the thermal length factor its chains apply.
struct Geometry<'a, T: Real> {
    model: &'a Prepared<T>,
    factor: T,
}

impl<T: Real> Geometry<'_, T> {
    /// The chain at joint positions `p`, into `chain`.
    fn chain(&self, p: &[T], chain: &mut Chain<T>) -> Result<(), Fault> {
        self.model
            .chain_scaled_into(p, self.factor, chain)
            .map_err(|_| Fault::JointCount)
    }
}

/// The second-order term `H(δ, δ)` of the compensation for joint changes `δ`
/// only, with `twists` the joints' twists `ξ_m = [w_m; v_m]` in chain order:
/// the rotation `vee(skew E₂_R)` and the displacement `E₂_R p + e₂_t` of the
/// point `p`, where `E₂ = Σ_m (S_m + ½X_m) X_m`, `X_m = ξ̂_m δ_m`, `S_m = Σ_{i<m}
/// X_i` ([`crate::perturbation`], eq. 2.22). With `ŵ` the skew matrix of `w`,
/// the rotation block of `S_m + ½X_m` is `â` with `a = Σ_{i<m} w_i δ_i + ½ w_m
/// δ_m`, and `â ŵ = w aᵀ − (a·w) I`, `â v = a × v`: a few products per joint
/// instead of the 4 × 4 ones of [`crate::perturbation::expand`], which it equals.
fn joint_second_order<T: Real>(
    twists: &[Twist<T>],
    delta: &[T],
    p: &Point3<T>,
) -> (Vector3<T>, Vector3<T>) {
    let half = T::lit(0.5);
    let mut s = Vector3::zeros();
    let mut e_r = Matrix3::zeros();
    let mut e_t = Vector3::zeros();
    for (xi, &d) in twists.iter().zip(delta) {
        let w = Vector3::new(xi[0], xi[1], xi[2]) * d;
        let v = Vector3::new(xi[3], xi[4], xi[5]) * d;
        let a = s + w * half;
        e_r += w * a.transpose();
        let aw = a.dot(&w);
        for i in 0..3 {
            e_r[(i, i)] -= aw;
        }
        e_t += a.cross(&v);
        s += w;
    }
    let rot = Vector3::new(e_r.m32 - e_r.m23, e_r.m13 - e_r.m31, e_r.m21 - e_r.m12) * half;
    (rot, e_r * p.coords + e_t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::perturbation::expand;
    use crate::{Convention, Link};

    /// [`joint_second_order`] is the second-order part of [`expand`] for joint
    /// errors, in both conventions, with revolute and prismatic joints.
    #[test]
    fn joint_second_order_equals_expand() {
        let (r, p) = (JointType::Revolute, JointType::Prismatic);
        let links = [
            Link::new(r, 0.1, 0.3, 0.2, 1.2),
            Link::new(p, -0.4, 0.1, 0.5, -0.7),
            Link::new(r, 0.7, -0.2, 0.3, 0.4),
            Link::new(r, -1.1, 0.15, -0.25, -1.3),
        ];
        let q = [0.3, 0.05, -0.8, 1.9];
        let delta = [0.02, -0.01, 0.03, -0.015];
        for convention in [Convention::Dh, Convention::Mdh] {
            let robot = Robot::new(convention, &links).unwrap();
            let chain = robot.chain(&q).unwrap();
            let params = [
                Param::Theta(0),
                Param::S(1),
                Param::Theta(2),
                Param::Theta(3),
            ];
            let twists: Vec<Twist<f64>, MAX_JOINTS> =
                params.iter().map(|&m| chain.column(m)).collect();
            let point = chain.point();
            let (rot, disp) = joint_second_order(&twists, &delta, &point);
            let errors: Vec<(Param, f64), MAX_JOINTS> = params.iter().copied().zip(delta).collect();
            let e = expand(&chain, convention, &errors).unwrap();
            let want_disp = e.point_error() - at_point(&e.first, &point);
            let want_rot = e.second_twist().fixed_rows::<3>(0).into_owned();
            assert!((rot - want_rot).norm() < 1e-15, "{convention:?}");
            assert!((disp - want_disp).norm() < 1e-15, "{convention:?}");
        }
    }
}
