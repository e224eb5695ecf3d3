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
//! The residual's rotation part is `φ`, the vector of the skew-symmetric part of
//! `R_target R_reachedᵀ` (eq. 15's `νdφ`, `½ Σ_i r_i × t_i` over the columns):
//! zero exactly where the rotations agree, and no square root or arc tangent.
//!
//! **The step.** Each step starts from a predictor `δ₀`: the first-order step
//! `J⁺ e`, or on a warm tick the previous tick's step (see below). With `r = e −
//! J δ₀ − H(δ₀, δ₀)`, the residual at `p + δ₀` to second order, the step is `δ
//! = δ₀ + J⁺ r` (eq. 4.9 about the predicted point; with `δ₀ = J⁺ e` it is the
//! paper's `J⁺ (e − H(δ₁, δ₁))` up to the damping), and `ℓ = r − J (δ − δ₀)` is
//! what it leaves of the linear part: `λ² y` for the factors of this `J`, a
//! little more for those of a nearby configuration, which are tried first
//! ([`Workspace`]: the factors the last step used, replaced by fresh ones when
//! the step with them is not within its bound; `ℓ` grows with the distance from
//! the configuration they were factored at, and on a smooth motion they serve
//! for tens of ticks).
//!
//! **The step's bound.** After the step `δ` the residual is, exactly,
//!
//! ```text
//! e(p + δ) = ℓ + H(δ₀ − δ, δ₀ + δ) − R₃(δ) + C
//! ```
//!
//! (the linear part left, `|ℓ|₁` computed, the difference of the two second-order terms, the
//! expansion's remainder of third order and up, and for the rotation the cross
//! term `C = φ((N − I)(Eᵀ − I))` of the residual rotation `N` with the step's
//! rotation `E`). With the coordinates' origin at the tool point, each joint's
//! `X_m δ_m` has norm at most `|δ_m|` (revolute) or `|δ_m| / R` (prismatic) for
//! points within `R` of every joint axis (`R` the largest lever `|w_m × (p −
//! ρ_m)|`, at least [`Limits::length_scale`]), so with `σ(δ) = Σ` of those norms,
//! `|H(a, b)| ≤ ½ σ(a) σ(b)` and `|R₃| ≤ σ³ e^σ / 6 ≤ 0.2 σ³` for `σ ≤ 0.1`, each
//! times `R` (plus the length scale for the rotation rows); and `|C| ≤ ½ |φ ×
//! θ| + 0.55 |φ| s_r² + 0.65 |φ|² s_r` with `θ = Σ w_m δ_m` the step's rotation
//! and `s_r` its size (`|φ| ≤ 0.4`). When that bound is below the tolerance the
//! step is taken without evaluating the chain after it: on a smooth motion every
//! tick is one chain of the calibrated model and one step. The returned
//! [`Correction::residual`] is then the bound (a property test checks that the
//! model's real residual never exceeds it, on cold and warm ticks with and
//! without joint effects; on random robots it is at most 0.99 of it).
//!
//! Otherwise a step is taken only if it lowers the residual: the second-order
//! step, else the first-order one, each halved up to three times; near a
//! singularity the linearisation overshoots, and the best point found is kept.
//! The cost per call is bounded by [`Limits::max_iterations`]: each iteration is
//! one to eight chains of the calibrated model, the joint-only second-order term
//! (with the origin at the tool point, `Σ_m a_m × v_m δ_m` and `½ Σ_m a_m × w_m
//! δ_m`, `a_m = Σ_{i<m} w_i δ_i + ½ w_m δ_m`: a few products per joint instead
//! of the 4 × 4 ones of [`crate::perturbation::expand`], which it equals), the
//! products `J δ₀`, `J (δ − δ₀)`, and at most one `L D Lᵀ` factorisation of `J
//! Jᵀ + λ² I` (no square root, fixed size) for all of its solves; no
//! allocation. The chains are
//! [`crate::servo_chain`]'s: the measured frame, the joint lines and the centres
//! of mass, with the D-H link product written out.
//!
//! **Warm start.** The search starts from the previous tick's correction applied
//! to this command, when it is within the size bound (else from `q_cmd`, as at
//! the first tick): `x = q_cmd + (q_prev − q_cmd_prev)`, the estimate of the
//! commands, when the calibration has joint effects; `x = q_cmd + (p_prev −
//! q_cmd_prev)` ([`Previous::p`]), the estimate of the joint positions, when it
//! has none. The one chain at `x` serves both the geometric step (from `x`) and
//! the gravity torques of the inversion (at `x`). The first step's predictor is
//! the previous tick's step from the commands to the joint positions, `p_prev −
//! q_prev` (the joint effects' offsets; zero without effects, where `x` is
//! already the estimate of the positions), plus the last change of the
//! correction `p − q_cmd` (from the [`Workspace`], after two warm ticks that
//! converged): the correction extrapolated linearly, which leaves `r` about
//! the tolerance (each tick's solution is only that exact). On a smooth motion
//! the factors of a recent tick then solve the step, and a tick is one chain
//! of the nominal model, one of the calibrated model, no factorisation, one
//! pair of triangular solves and two products with `J`.

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
//! `1 + κ (T − T_ref)` (thermal expansion; applied inside each chain, two
//! multiplications per link, the model is not copied), `τ_j` the gravity torque
//! at the
//! readings (N·m, or N for a prismatic joint), `c_j` the compliance (rad/(N·m)),
//! the gear harmonics (rad), `ε_j` the encoder-scale error and `b_j` half the lost
//! motion (rad or m). The effects act on the joint readings only, so the solution
//! is found in two steps:
//!
//! 1. the geometric problem above on `G_T`: the real joint positions `p` with
//!    `G_T(p) = T_nom(q_cmd)`;
//! 2. the commands that put the joints at `p`: `q_j = (p_j − o_j(q) − b_j σ_j) /
//!    (1 + ε_j)`, with `o_j` the compliance and gear terms evaluated at the
//!    current `q` (the first time at the start `x`, from the chain of the
//!    geometric step; after that one chain for the gravity torques), repeated
//!    until no joint changes by more than `tol` = [`Limits::tolerance`] /
//!    [`Limits::length_scale`] rad, at most [`Limits::max_iterations`] times.
//!    The encoder scale is inverted exactly. The offsets change by at most `L`
//!    times a change of `q` (their slope: the gravity torque `τ_j = Σ_{k ≥ j}
//!    m_k (w_j × (r_k − ρ_j))·g` by at most `2 R |g| M_j` per radian of a
//!    revolute joint, with `R` the robot's reach and `M_j` the mass it carries,
//!    and by `|g| M_j` per metre of a prismatic one; a harmonic `s sin kq` by
//!    `k|s|`; each over `1 + ε_j`), so the map is a contraction and the fixed
//!    point lies within `L / (1 − L)` of the last change: the repetition stops
//!    as soon as that is below `tol`. `L` is about 10⁻³ for a 1 m arm, and on a
//!    smooth motion one pass suffices.
//!
//! **Approach direction.** The controller sends `q`, so `σ_j = sign(q_j −
//! q_prev_j)` of the commands *sent* (the corrected ones) at this and the previous
//! tick, 0 when the joint does not move and at the first tick: exactly what
//! [`crate::effects::approach_signs`] gives for the stream of sent commands, as
//! the calibration was identified from readings in row order. For a joint with
//! backlash, with `d_j = (p_j − o_j)/(1 + ε_j) − q_prev_j` the move that reaches
//! `p_j` without lost motion, `σ_j = sign(d_j)` and `q_j = q_prev_j + d_j − b_j σ_j
//! / (1 + ε_j)`, which is consistent when that move, as rounded, still has the
//! sign `σ_j` (`|d_j| > |b_j|/(1 + ε_j)`): the usual case, a joint moving on or
//! reversing by more than its lost motion. Otherwise the target lies within the
//! lost motion (the first ticks of a reversal): no command reaches it in this
//! model, the joint is held at `q_prev_j` (`σ_j = 0`), and the pose is missed by
//! at most the lost motion at the joint's lever; the correction is flagged
//! [`Fault::NotConverged`] with that residual. A command repeated exactly (a
//! standstill) asks for the same joint positions to within the tolerance: the
//! joint then moves on by that rounding, and keeps its flank, or is held, as
//! the rounding falls.
//!
//! The tick's conditions are [`Conditions`]: temperature °C, payload kg (0 when
//! not given); without a temperature the lengths are the reference ones. A
//! geometric calibration takes exactly the steps of the geometric problem.

use heapless::Vec;
use nalgebra::{IsometryMatrix3, Vector3};

use crate::effects::{
    Effect, EffectModel, JointEffect, MAX_EFFECTS, Masses, direction, length_factor,
};
use crate::kinematics::Prepared;
use crate::model::bounded;
use crate::servo_chain::{Angles, JointLine, ServoChain, Sines, Wanted};
use crate::{Calibration, JointType, MAX_JOINTS, Real, Robot};

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
    /// [`Correction::p`]): the start of this tick's search when the calibration
    /// has no joint effects (with them the search starts from the commands
    /// sent, [`Previous::q`]).
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
    /// and of the orientation error times [`Limits::length_scale`]; when the
    /// last step was taken on its bound (see the module header), that bound,
    /// which the residual does not exceed.
    pub residual: T,
}

/// What one tick leaves for the next besides [`Previous`] (the factors of the
/// last step's linear system, which the next step tries first, and the
/// correction's last change; see the module header), and the tick's work
/// arrays. Keep one per stream of ticks and pass it to
/// [`Compensator::correct_with`]; any workspace is valid with any compensator
/// (factors that no longer solve the step are replaced), so a fresh one is
/// only slower.
#[derive(Clone, Debug)]
pub struct Workspace<T: Real> {
    reuse: Reuse<T>,
    tick: Tick<T>,
}

impl<T: Real> Default for Workspace<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> Workspace<T> {
    /// An empty workspace: the first step factors afresh.
    pub fn new() -> Self {
        let zeros = [T::zero(); MAX_JOINTS];
        Self {
            reuse: Reuse {
                factors: [[T::zero(); 6]; 6],
                factored: false,
                rate: zeros,
                rate_valid: false,
                converged: false,
            },
            tick: Tick {
                chain: ServoChain::default(),
                angles: Angles::default(),
                x: zeros,
                tau: zeros,
                p: zeros,
                q: zeros,
                steps: Steps {
                    first: zeros,
                    second: zeros,
                    trial: zeros,
                    jac: [[T::zero(); 6]; MAX_JOINTS],
                },
            },
        }
    }
}

/// What a tick leaves for the next.
#[derive(Clone, Debug)]
struct Reuse<T: Real> {
    /// The factors of the last step's system (valid when [`Self::factored`]).
    factors: Factors<T>,
    /// Whether [`Self::factors`] holds the factors of a step.
    factored: bool,
    /// The last tick's change of the joint positions' correction `p − q_cmd`
    /// from the tick before (valid when [`Self::rate_valid`]): the next
    /// predictor extrapolates it.
    rate: Joints<T>,
    /// Whether the last tick was a warm one that converged.
    rate_valid: bool,
    /// Whether the last tick converged (its factors are then those of a
    /// configuration near this tick's).
    converged: bool,
}

/// The work arrays of one tick, kept in the [`Workspace`] so that none is
/// cleared or copied per tick (on the controller that costs as much as a
/// chain's worth of arithmetic). Between ticks their contents mean nothing:
/// each is written before it is read.
#[derive(Clone, Debug)]
struct Tick<T: Real> {
    /// The chain of the last evaluation.
    chain: ServoChain<T>,
    /// The nominal chain's joint angles, their sines and cosines.
    angles: Angles<T>,
    /// The start of the search (see the module header), then, in place, the
    /// commands that put the joints at `p`.
    x: Joints<T>,
    /// The gravity torques at the last evaluation.
    tau: Joints<T>,
    /// The joint positions that reach the target.
    p: Joints<T>,
    /// Where the joints really go when one is held within its lost motion.
    q: Joints<T>,
    /// The geometric problem's.
    steps: Steps<T>,
}

/// The work arrays of the geometric problem ([`Compensator::solve`]).
#[derive(Clone, Debug)]
struct Steps<T: Real> {
    /// The first-order step (or the predictor).
    first: Joints<T>,
    /// The second-order step.
    second: Joints<T>,
    /// A trial point of the line search.
    trial: Joints<T>,
    /// The columns of `J`, one per joint.
    jac: [[T; 6]; MAX_JOINTS],
}

/// The compensation for one calibration: the nominal and the calibrated model,
/// prepared once, and the calibration's effects.
#[derive(Clone, Debug)]
pub struct Compensator<T: Real> {
    nominal: Prepared<T>,
    calibrated: Prepared<T>,
    joints: Vec<JointType, MAX_JOINTS>,
    orientation: bool,
    /// The thermal expansions among the effects: coefficient (1/°C) and
    /// reference temperature (°C).
    thermal: Vec<(T, T), MAX_EFFECTS>,
    /// The effects of each joint, summed.
    joint_effects: Vec<JointEffect<T>, MAX_JOINTS>,
    /// Bit `j` set when joint `j` has a compliance (needs its gravity torque).
    compliant: u32,
    /// Bit `j` set when joint `j` has gear harmonics.
    harmonic: u32,
    /// The calibrated model's masses and gravity, for the torques of a compliance.
    masses: Masses<T>,
    /// How fast the effects' joint offsets change with the joints.
    slopes: Slopes<T>,
    /// Whether the effects move the joints (any but thermal expansion).
    corrects_joints: bool,
    /// Per joint: the size bound and the change-per-tick bound of its
    /// correction (from [`Limits`], by joint type).
    bounds: Vec<(T, T), MAX_JOINTS>,
    /// The bounds and tolerances in force.
    limits: Limits<T>,
}

/// One value per joint, sized for the most joints: the tick's work arrays
/// (fixed size, kept in the [`Workspace`], no allocation).
type Joints<T> = [T; MAX_JOINTS];

/// What bounds the slope of the effects' joint offsets `o_j(q)` (compliance
/// times gravity torque, gear harmonics), for the stopping rule of the
/// inversion (see the module header).
#[derive(Clone, Debug)]
struct Slopes<T: Real> {
    /// The largest over the joints of the compliance's magnitude times `|g|`
    /// times the mass the joint carries without the payload (`Σ_{k ≥ j}
    /// m_k`), each divided by the least `1 + ε_j`; the largest compliance
    /// times `|g|` alone (for the payload), divided likewise; and the
    /// largest gear harmonics' slope `|s₁| + |c₁| + 2 (|s₂| + |c₂|)`, divided
    /// likewise. Each is the largest of its own, so that the slope's bound
    /// from them is at least every joint's, in one product.
    most: (T, T, T),
    /// A bound on the distance between any two of the joint axes' points, the
    /// centres of mass and the tool point at the reference lengths, without the
    /// travel of prismatic joints: `Σ (|a| + |s|) + |tool| + max |com|`, m.
    reach: T,
    /// The number of revolute joints, and of prismatic ones.
    revolute: T,
    prismatic: T,
}

impl<T: Real> Slopes<T> {
    fn of(robot: &Robot<T>, effects: &[JointEffect<T>], masses: &Masses<T>) -> Self {
        let gravity = masses.gravity.norm();
        let mut most = (T::zero(), T::zero(), T::zero());
        let mut total = T::zero();
        for (j, e) in effects.iter().enumerate().rev() {
            total += masses.mass[j];
            let stretch = T::one() - e.scale.abs();
            let per_mass = e.compliance.abs() * gravity / stretch;
            let gear = e.first[0].abs()
                + e.first[1].abs()
                + T::lit(2.0) * (e.second[0].abs() + e.second[1].abs());
            most.0 = larger(most.0, per_mass * total);
            most.1 = larger(most.1, per_mass);
            most.2 = larger(most.2, gear / stretch);
        }
        let mut reach = robot.tool.xyz.norm();
        let mut com = T::zero();
        for l in &robot.links {
            reach += l.a.abs() + l.s.abs();
            if let Some(m) = &l.mass {
                com = larger(com, m.com.norm());
            }
        }
        let (mut revolute, mut prismatic) = (T::zero(), T::zero());
        for l in &robot.links {
            match l.joint {
                JointType::Revolute => revolute += T::one(),
                JointType::Prismatic => prismatic += T::one(),
            }
        }
        Self {
            most,
            reach: reach + com,
            revolute,
            prismatic,
        }
    }
}

/// Whether `x` is finite: `x − x` is 0 for a finite `x` and NaN otherwise (one
/// subtraction; `is_finite` is two comparisons).
#[inline(always)]
#[allow(clippy::eq_op)]
fn is_finite<T: Real>(x: T) -> bool {
    x - x == T::zero()
}

/// The larger of two values (a comparison; `max` is a library call in f32 on
/// the controller).
#[inline(always)]
fn larger<T: Real>(a: T, b: T) -> T {
    if b > a { b } else { a }
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
        let robot = &calibrated.robot;
        let masses = Masses::of(robot, &robot.base.isometry());
        let joint_effects = calibrated.joint_effects(robot.dof());
        let mask = |has: &dyn Fn(&JointEffect<T>) -> bool| {
            joint_effects
                .iter()
                .enumerate()
                .filter(|(_, e)| has(e))
                .fold(0u32, |m, (j, _)| m | 1 << j)
        };
        let zero = [T::zero(), T::zero()];
        let compliant = mask(&|e| e.compliance != T::zero());
        let harmonic = mask(&|e| e.first != zero || e.second != zero);
        let bounds = bounded(robot.links.iter().map(|l| match l.joint {
            JointType::Revolute => (limits.max_correction_angle, limits.max_change_angle),
            JointType::Prismatic => (limits.max_correction_length, limits.max_change_length),
        }));
        Self {
            compliant,
            harmonic,
            corrects_joints: calibrated.corrects_joints(),
            bounds,
            nominal: nominal.prepare(),
            calibrated: robot.prepare(),
            joints: bounded(robot.links.iter().map(|l| l.joint)),
            orientation,
            slopes: Slopes::of(robot, &joint_effects, &masses),
            joint_effects,
            masses,
            thermal: bounded(
                calibrated
                    .effects
                    .iter()
                    .filter_map(Effect::thermal_expansion),
            ),
            limits,
        }
    }

    /// [`EffectModel::length_factor`], over the thermal expansions alone.
    fn length_factor(&self, temperature: Option<T>) -> T {
        length_factor(self.thermal.iter().copied(), temperature)
    }

    /// A compensator for a calibration file's models and effects, in the scalar
    /// `T` (`f32` on the controller), with full-pose compensation if it was
    /// identified from full poses. Never inlined: a constructor runs once per
    /// calibration load, and one copy of it keeps the controller's flash small.
    #[inline(never)]
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
            bounded(calibration.effects.iter().map(|e| e.cast()));
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

    /// The bounds and tolerances in force.
    pub fn limits(&self) -> &Limits<T> {
        &self.limits
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
        self.correct_with(q_cmd, previous, conditions, &mut Workspace::new())
    }

    /// [`Self::correct`] with the factors of the previous tick's step from
    /// `work`, which it then holds this tick's: on a smooth motion the step
    /// needs no new factorisation. The result satisfies the same bounds.
    pub fn correct_with(
        &self,
        q_cmd: &[T],
        previous: Option<Previous<'_, T>>,
        conditions: &Conditions<T>,
        work: &mut Workspace<T>,
    ) -> Correction<T> {
        let n = self.dof();
        let unchanged = |fault| Correction {
            q: bounded(q_cmd.iter().copied()),
            p: bounded(q_cmd.iter().copied()),
            fault: Some(fault),
            iterations: 0,
            residual: T::zero(),
        };
        if q_cmd.len() != n
            || previous.is_some_and(|p| p.q_cmd.len() != n || p.q.len() != n || p.p.len() != n)
        {
            return unchanged(Fault::JointCount);
        }
        let Workspace { reuse, tick } = work;
        let Tick {
            chain,
            angles,
            x,
            tau,
            p,
            q,
            steps,
        } = tick;
        // The start: the previous tick's correction applied to this command,
        // when it is within the bounds (warm start). With joint effects it is
        // the estimate of the commands `q` (where the gravity torques are
        // evaluated); without, of the joint positions `p`, which then equal `q`.
        let corrects_joints = self.corrects_joints;
        // The first step's predictor from there: the previous tick's step
        // from the commands to the joint positions (`p − q`, the joint
        // effects' offset; none without them, the start being the positions),
        // plus the last change of the correction `p − q_cmd` when known.
        //
        // In the same pass, the inputs' check: their sum is finite exactly
        // when each is (a NaN or an infinity survives the sum), unless it
        // overflows, beyond 10³⁸ even in `f32`: no joint value or condition
        // is that large, and such a value is refused too. One addition a
        // value, and nothing is evaluated before it passes.
        let mut inputs =
            conditions.temperature.unwrap_or(T::zero()) + conditions.payload.unwrap_or(T::zero());
        let mut predicted = false;
        match previous {
            Some(prev) => {
                // In one pass, undone below if a correction is out of its bound.
                let mut within = true;
                let start = x.iter_mut().zip(steps.first.iter_mut()).zip(&self.bounds);
                let last = prev.q.iter().zip(prev.q_cmd).zip(prev.p);
                for ((((xm, dm), &(max, _)), ((pq, pc), pp)), qc) in start.zip(last).zip(q_cmd) {
                    inputs += *qc + *pc + *pq + *pp;
                    let from = if corrects_joints { *pq } else { *pp };
                    let correction = from - *pc;
                    within &= correction.abs() <= max;
                    *xm = *qc + correction;
                    *dm = *pp - from;
                }
                if within {
                    if reuse.rate_valid {
                        let first = steps.first.iter_mut().take(n);
                        first.zip(&reuse.rate).for_each(|(d, r)| *d += *r);
                    }
                    predicted = true;
                } else {
                    x.iter_mut().zip(q_cmd).for_each(|(x, c)| *x = *c);
                }
            }
            None => {
                for (xm, qc) in x.iter_mut().zip(q_cmd) {
                    inputs += *qc;
                    *xm = *qc;
                }
            }
        }
        if !is_finite(inputs) {
            return unchanged(Fault::NonFinite);
        }
        // The pose the nominal model intended, its joint angles' sines and
        // cosines recorded: every chain of the calibrated model below is near
        // them.
        let wanted = Wanted {
            lines: false,
            centres: false,
            rotation: self.orientation,
        };
        let sines = Sines::Record(angles);
        if self
            .nominal
            .servo_chain_with(q_cmd, T::one(), wanted, sines, chain)
            .is_err()
        {
            return unchanged(Fault::JointCount);
        }
        let target = chain.end;
        // The calibrated geometry at the tick's temperature: its lengths times
        // the thermal factor, applied inside each chain.
        let geometry = Geometry {
            model: &self.calibrated,
            factor: self.length_factor(conditions.temperature),
            rotation: self.orientation,
            angles,
        };
        // One chain at the start serves the geometric step (joint lines,
        // measured frame) and the gravity torques (centres of mass).
        let needs_torque = self.compliant != 0;
        if geometry.chain(&x[..n], true, needs_torque, chain).is_err() {
            return unchanged(Fault::JointCount);
        }
        let payload = conditions.payload.unwrap_or(T::zero());
        if needs_torque {
            self.torques(chain, payload, &mut tau[..n]);
        } else {
            tau.iter_mut().take(n).for_each(|t| *t = T::zero());
        }
        // 1. The real joint positions p that reach the target, from the start.
        let (iterations, mut residual2, mut norm) = match self.solve(
            &geometry,
            &target,
            &x[..n],
            &mut p[..n],
            predicted,
            chain,
            reuse,
            steps,
        ) {
            Ok(solved) => solved,
            Err(fault) => return unchanged(fault),
        };
        let tolerance2 = self.limits.tolerance * self.limits.tolerance;
        let mut fault = (residual2 > tolerance2).then_some(Fault::NotConverged);
        let solved = fault.is_none();
        // 2. The commands that put the joints at p, from the start and its
        // torques: in place of the start (without joint effects, p itself).
        let q_sent = &mut x[..n];
        if corrects_joints {
            match self.invert(
                &geometry,
                q_sent,
                &p[..n],
                &mut tau[..n],
                previous,
                payload,
                chain,
            ) {
                None => return unchanged(Fault::NonFinite),
                Some(false) => {}
                Some(true) => {
                    // Held within a lost motion: where the joints really go
                    // (into `q`, a work array here).
                    self.reached(q_sent, &tau[..n], previous, &mut q[..n]);
                    if geometry.chain(&q[..n], false, false, chain).is_err() {
                        return unchanged(Fault::JointCount);
                    }
                    residual2 = self.residual(&target, &chain.end).1;
                    norm = None;
                    fault = (residual2 > tolerance2).then_some(Fault::NotConverged);
                }
            }
        } else {
            q_sent.copy_from_slice(&p[..n]);
        }
        // Bounds: the change of the correction since the last tick, then its
        // size. The size bound always holds, and when the previous correction
        // was within it (as every correction this returns is) both do. A
        // clamp to one interval, then to the other, is the clamp to their
        // intersection when they meet; when they do not, the size bound's end
        // nearest the change bound's.
        //
        // In the same pass, the change of the correction `p − q_cmd` since the
        // last tick, which the next tick's predictor extrapolates (kept when
        // this tick was a warm one that converged).
        let mut limited = false;
        let mut outputs = residual2;
        let clamp = |c: &mut T, lo: T, hi: T, limited: &mut bool| {
            if *c < lo {
                (*c, *limited) = (lo, true);
            } else if *c > hi {
                (*c, *limited) = (hi, true);
            }
        };
        let joints = q_sent.iter_mut().zip(p.iter()).zip(q_cmd).zip(&self.bounds);
        match previous {
            Some(prev) => {
                let last = prev.q.iter().zip(prev.q_cmd).zip(prev.p);
                let rates = reuse.rate.iter_mut();
                for (((((qm, pm), c), &(max, change)), ((pq, pc), pp)), r) in
                    joints.zip(last).zip(rates)
                {
                    *r = (*pm - *c) - (*pp - *pc);
                    let last = *pq - *pc;
                    let mut correction = *qm - *c;
                    clamp(&mut correction, last - change, last + change, &mut limited);
                    clamp(&mut correction, -max, max, &mut limited);
                    *qm = *c + correction;
                    outputs += *qm + *pm;
                }
            }
            None => {
                for (((qm, pm), c), &(max, _)) in joints {
                    let mut correction = *qm - *c;
                    clamp(&mut correction, -max, max, &mut limited);
                    *qm = *c + correction;
                    outputs += *qm + *pm;
                }
            }
        }
        reuse.converged = solved;
        reuse.rate_valid = predicted && solved;
        if limited {
            fault = fault.or(Some(Fault::Limited));
        }
        if !is_finite(outputs) {
            return unchanged(Fault::NonFinite);
        }
        Correction {
            q: listed(x, n),
            p: listed(p, n),
            fault,
            iterations,
            residual: norm.unwrap_or_else(|| residual2.sqrt()),
        }
    }

    /// The geometric problem: the joint positions `p` where `geometry`
    /// reaches `target`, refined from `start` (eq. 4.9, repeated; see the
    /// module header). `chain` is at `start` with its joint lines on entry, a
    /// work buffer after. The first step starts from the predictor in
    /// `steps.first` when `predicted` (the previous tick's step, on a warm
    /// tick), else from the first-order step; each step solves with the
    /// factors `reuse` holds while they give a step within its bound, else
    /// with fresh ones. Returns the iterations and the squared residual, or,
    /// when the last step was taken on its bound, the square of that bound
    /// and the bound itself. `steps` are work arrays.
    #[allow(clippy::too_many_arguments)]
    fn solve(
        &self,
        geometry: &Geometry<'_, T>,
        target: &IsometryMatrix3<T>,
        start: &[T],
        p: &mut [T],
        mut predicted: bool,
        chain: &mut ServoChain<T>,
        reuse: &mut Reuse<T>,
        steps: &mut Steps<T>,
    ) -> Result<(usize, T, Option<T>), Fault> {
        let Steps {
            first,
            second,
            trial,
            jac,
        } = steps;
        let n = p.len();
        let tolerance = self.limits.tolerance;
        let tolerance2 = tolerance * tolerance;
        let mut iterations = 0;
        let mut residual = self.residual(target, &chain.end);
        let jac = &mut jac[..n];
        while residual.1 > tolerance2 && iterations < self.limits.max_iterations {
            iterations += 1;
            // The step from the predictor, with the last factors first (they
            // are those of a nearby configuration on a smooth motion), then
            // fresh ones.
            let (reach, mut r) = if predicted {
                self.jacobian_predicted(chain, jac, &residual.0, &first[..n])
            } else {
                (self.jacobian(chain, jac), [T::zero(); 6])
            };
            // Stale factors only in the first iteration after a tick that
            // converged: otherwise the configuration has moved by more than a
            // tick's motion.
            let mut fresh = !(reuse.factored && iterations == 1 && reuse.converged && predicted);
            loop {
                // The factors are written in place (a copy of them costs as
                // much as a solve on the controller).
                if fresh {
                    reuse.factored = false;
                    factor(jac, self.damping2(), &mut reuse.factors).ok_or(Fault::NonFinite)?;
                    reuse.factored = true;
                }
                let l = &reuse.factors;
                let predictor = predicted
                    || damped_solve(jac, l, &residual.0, &mut first[..n]).is_some_and(|y| {
                        let left = if fresh {
                            // These factors leave exactly `e − J δ₁ = λ² y₁`.
                            let lambda2 = self.damping2();
                            y.map(|y| lambda2 * y)
                        } else {
                            self.left(jac, &residual.0, &first[..n])
                        };
                        r = self.predicted(chain, jac, left, &first[..n]);
                        true
                    });
                let bound = if predictor {
                    self.step(
                        chain,
                        jac,
                        l,
                        fresh,
                        &residual.0,
                        &first[..n],
                        &r,
                        &mut second[..n],
                        reach,
                    )
                } else {
                    None
                };
                // The residual after the whole step is bounded below the
                // tolerance: taken without evaluating the chain there.
                let taken = bound.and_then(|(bound, whole)| bound.filter(|_| whole));
                if let Some(bound) = taken.filter(|b| *b <= tolerance) {
                    // From the start in the first iteration, else from p.
                    if iterations == 1 {
                        moved(p, start, &second[..n]);
                    } else {
                        take(p, &second[..n]);
                    }
                    return Ok((iterations, bound * bound, Some(bound)));
                }
                if fresh {
                    if bound.is_none() {
                        return Err(Fault::NonFinite);
                    }
                    break;
                }
                fresh = true;
            }
            // The fallback's first candidate after the step: the first-order
            // step (the loop above left fresh factors).
            if predicted {
                predicted = false;
                damped_solve(jac, &reuse.factors, &residual.0, &mut first[..n])
                    .ok_or(Fault::NonFinite)?;
            }
            self.trust(&mut first[..n]);
            if iterations == 1 {
                p.copy_from_slice(start);
            }
            // Take a step only if it lowers the residual: the second-order one (eq.
            // 4.9) first, then the first-order one, each halved up to three times.
            // Near a singularity the linearisation overshoots and the second-order
            // term, built on an overshooting first step, can mislead; otherwise the
            // full second-order step is taken at once.
            let mut improved = false;
            'candidates: for step in [&mut second[..n], &mut first[..n]] {
                for _ in 0..4 {
                    for ((t, pm), d) in trial.iter_mut().zip(p.iter()).zip(step.iter()) {
                        *t = *pm + *d;
                    }
                    geometry.chain(&trial[..n], true, false, chain)?;
                    let candidate = self.residual(target, &chain.end);
                    if candidate.1 < residual.1 {
                        (residual, improved) = (candidate, true);
                        take(p, step);
                        break 'candidates;
                    }
                    step.iter_mut().for_each(|d| *d *= T::lit(0.5));
                }
            }
            if !improved {
                // `chain` holds the last trial: back to the best point.
                geometry.chain(p, true, false, chain)?;
                break;
            }
        }
        if iterations == 0 {
            p.copy_from_slice(start);
        }
        Ok((iterations, residual.1, None))
    }

    /// Trust region: scales `step` so that no joint moves by more than its
    /// correction bound (near a singularity the step is otherwise huge);
    /// whether it was whole.
    #[inline]
    fn trust(&self, step: &mut [T]) -> bool {
        // The largest share of its bound that a joint's step takes.
        let mut worst = T::zero();
        for (d, &(max, _)) in step.iter().zip(&self.bounds) {
            worst = larger(worst, d.abs() / max);
        }
        shrink(step, worst)
    }

    /// The effects' inversion: the commands `q` with `q + Δq(q) = p` (see the
    /// module header), from the start in `q`, whose gravity torques `tau` are
    /// (zero without a compliance; on return, those of the last evaluation).
    /// `None` if a value was not finite; `Some(true)` when a joint was held
    /// within its lost motion ([`Self::reached`] tells where the joints go);
    /// `Some(false)` otherwise. `chain` is a work buffer.
    #[allow(clippy::too_many_arguments)]
    fn invert(
        &self,
        geometry: &Geometry<'_, T>,
        q: &mut [T],
        p: &[T],
        tau: &mut [T],
        previous: Option<Previous<'_, T>>,
        payload: T,
        chain: &mut ServoChain<T>,
    ) -> Option<bool> {
        let sent = previous.map(|prev| prev.q);
        let tolerance = self.limits.tolerance / self.limits.length_scale;
        let mut held = false;
        let needs_torque = self.compliant != 0;
        for iteration in 0..self.limits.max_iterations.max(1) {
            if needs_torque && iteration > 0 {
                geometry.chain(q, true, true, chain).ok()?;
                self.torques(chain, payload, tau);
            }
            let mut change = T::zero();
            held = false;
            let joints = self
                .joint_effects
                .iter()
                .zip(q.iter_mut())
                .zip(p)
                .zip(&*tau);
            for (j, (((e, qj), pj), tj)) in joints.enumerate() {
                let stretch = T::one() + e.scale;
                let mut next = (*pj - self.offset(j, e, *qj, *tj)) / stretch;
                if let Some(prev) = sent.filter(|_| e.backlash != T::zero()) {
                    let lost = e.backlash / stretch;
                    let sigma = direction(next - prev[j]);
                    // Consistent when the command, lost motion taken off,
                    // still moves the joint the way σ says (tested on the
                    // rounded command: it is what is sent).
                    let moved = next - lost * sigma;
                    if direction(moved - prev[j]) == sigma {
                        next = moved;
                    } else {
                        // Within the lost motion: held (σ = 0).
                        next = prev[j];
                        held = true;
                    }
                }
                change = larger(change, (next - *qj).abs());
                *qj = next;
            }
            if !change.is_finite() {
                return None;
            }
            if change <= tolerance {
                break;
            }
            // The offsets change by at most `slope` times the change of q: the
            // fixed point is within slope / (1 − slope) of this change.
            let slope = self.slope(payload, geometry.factor, q);
            if slope < T::lit(0.5) && slope * change <= (T::one() - slope) * tolerance {
                break;
            }
        }
        Some(held)
    }

    /// [`JointEffect::offset`] of joint `j` (its effects `e`), the harmonics skipped by a mask
    /// test on joints without them (instead of four comparisons).
    #[inline]
    fn offset(&self, j: usize, e: &JointEffect<T>, q: T, tau: T) -> T {
        let harmonics = if self.harmonic & (1 << j) != 0 {
            e.harmonics(q)
        } else {
            T::zero()
        };
        e.compliance * tau + harmonics
    }

    /// Where the joints really go at commands `q` with gravity torques `tau`:
    /// `q + Δq(q)`, with the approach of the commands from the previous
    /// tick's, into `out`.
    fn reached(&self, q: &[T], tau: &[T], previous: Option<Previous<'_, T>>, out: &mut [T]) {
        let sent = previous.map(|prev| prev.q);
        for (j, e) in self.joint_effects.iter().enumerate().take(out.len()) {
            let sigma = sent.map_or(T::zero(), |prev| direction(q[j] - prev[j]));
            out[j] = q[j] + e.correction(q[j], tau[j], sigma);
        }
    }

    /// The gravity torques at `chain` (with its lines and centres) into `tau`.
    fn torques(&self, chain: &ServoChain<T>, payload: T, tau: &mut [T]) {
        let (lines, centres) = (chain.lines(), chain.centres());
        self.masses.torques(
            payload,
            &chain.point(),
            |j| (lines[j].w, lines[j].rho),
            |k| centres[k],
            self.compliant,
            tau,
        );
    }

    /// A bound on how much the joint offsets `o_j(q)` divided by `1 + ε_j`
    /// change per radian (metre) of change of `q`, in the largest joint, with
    /// `payload` kg and the lengths times `factor`, near `q`: the gravity torque
    /// `τ_j = Σ_{k≥j} m_k (w_j × (r_k − ρ_j))·g` changes by at most `2 R |g| M_j`
    /// per radian of any revolute joint (the lever and the axis both turn; `R`
    /// bounds every lever) and by `|g| M_j` per metre of a prismatic one, with
    /// `M_j` the mass carried; a harmonic `s sin kq` by `k |s|`. The
    /// compliance's and the harmonics' shares are each the largest joint's
    /// ([`Slopes::most`]): a bound on the largest joint's sum in O(1).
    fn slope(&self, payload: T, factor: T, q: &[T]) -> T {
        let s = &self.slopes;
        let mut reach = s.reach * larger(factor, T::one());
        if s.prismatic > T::zero() {
            for (m, joint) in self.joints.iter().enumerate() {
                if *joint == JointType::Prismatic {
                    reach += q[m].abs() + self.limits.max_correction_length;
                }
            }
        }
        let levers = T::lit(2.0) * reach * s.revolute + s.prismatic;
        let (links, per_payload, gear) = s.most;
        (links + per_payload * payload.abs()) * levers + gear
    }

    /// The residual `e` (rotation scaled to a length, then position; the rotation
    /// part is zero without orientation) and its squared norm. The rotation
    /// part is `φ`, the vector of the skew-symmetric part of `R_target R_reachedᵀ`
    /// (`½ Σ_i r_i × t_i` over the columns, eq. 15's `νdφ`): zero exactly where
    /// the rotations agree, the rotation vector to third order.
    fn residual(&self, target: &IsometryMatrix3<T>, reached: &IsometryMatrix3<T>) -> ([T; 6], T) {
        let dp = target.translation.vector - reached.translation.vector;
        let mut dr = Vector3::zeros();
        if self.orientation {
            let (t, r) = (target.rotation.matrix(), reached.rotation.matrix());
            for i in 0..3 {
                dr += r.column(i).cross(&t.column(i));
            }
            dr *= T::lit(0.5) * self.limits.length_scale;
        }
        // The size the steps lower: the norm of the whole residual, the orientation
        // counting as the position error it causes at `length_scale`.
        let e = [dr.x, dr.y, dr.z, dp.x, dp.y, dp.z];
        (e, e.iter().fold(T::zero(), |s, x| s + *x * *x))
    }

    /// The rows of `J_r` at `chain` (with its joint lines) into `jac`, one
    /// `[T; 6]` per joint: its rotation (scaled by the length scale; zero without
    /// orientation) and the tool point's displacement; and `reach`, a bound on
    /// the levers `|v_m|` (1-norm), at least the length scale.
    fn jacobian(&self, chain: &ServoChain<T>, jac: &mut [[T; 6]]) -> T {
        let p = chain.end.translation.vector;
        let rotation = self.rotation_scale();
        let mut reach = self.limits.length_scale;
        for ((out, line), joint) in jac.iter_mut().zip(chain.lines()).zip(&self.joints) {
            (*out, _) = column(*joint, line, &p, rotation, &mut reach);
        }
        reach
    }

    /// [`Self::jacobian`], and in the same pass the residual at the predicted
    /// point `p + δ₀` to second order, `r = e − J δ₀ − H(δ₀, δ₀)` for the
    /// predictor `delta = δ₀` (see [`Self::predicted`]): each joint's twist is
    /// at hand for [`second_order`]'s sums, and `J δ₀` is their first-order
    /// part (`Σ w_m δ_m` scaled, and `Σ v_m δ_m`).
    fn jacobian_predicted(
        &self,
        chain: &ServoChain<T>,
        jac: &mut [[T; 6]],
        e: &[T; 6],
        delta: &[T],
    ) -> (T, [T; 6]) {
        let p = chain.end.translation.vector;
        let rotation = self.rotation_scale();
        let mut reach = self.limits.length_scale;
        let mut sums = SecondOrder::new();
        let joints = jac.iter_mut().zip(chain.lines()).zip(&self.joints);
        for (((out, line), joint), &d) in joints.zip(delta) {
            let w;
            (*out, w) = column(*joint, line, &p, rotation, &mut reach);
            sums.add(w, Vector3::new(out[3], out[4], out[5]), d);
        }
        let (moved, h) = sums.finish(rotation);
        let mut r = *e;
        for ((r, m), h) in r.iter_mut().zip(moved).zip(h) {
            *r -= m + h;
        }
        (reach, r)
    }

    /// The length scale of the rotation rows: zero without orientation.
    fn rotation_scale(&self) -> T {
        if self.orientation {
            self.limits.length_scale
        } else {
            T::zero()
        }
    }

    /// `λ²`, the square of the damping of the step's least-squares inverse.
    fn damping2(&self) -> T {
        self.limits.damping * self.limits.damping
    }

    /// The second-order step from the predictor `first = δ₀` into `second`
    /// (eq. 4.9 about the predicted point): with `r` the residual there to
    /// second order ([`Self::predicted`]), `δ = δ₀ + J⁺ r` with `J⁺` from the
    /// factors `l` (of this `jac` or of a nearby one), and `ℓ = r − J (δ − δ₀)`
    /// what is left of the linear part. Returns the bound of the module header
    /// on the residual after `δ` with `|ℓ|₁` as its linear share, if it
    /// applies, and whether the step was whole (else it is scaled into its
    /// trust region, [`Self::trust`]); `None` if not finite. `chain` carries
    /// the joint lines.
    #[allow(clippy::too_many_arguments)]
    fn step(
        &self,
        chain: &ServoChain<T>,
        jac: &[[T; 6]],
        l: &Factors<T>,
        fresh: bool,
        e: &[T; 6],
        first: &[T],
        r: &[T; 6],
        second: &mut [T],
        reach: T,
    ) -> Option<(Option<T>, bool)> {
        let y = damped_solve(jac, l, r, second)?;
        let linear = if fresh {
            // The factors of this `J` leave exactly `λ² y`.
            self.damping2() * y.iter().fold(T::zero(), |s, v| s + v.abs())
        } else {
            // Factors of a nearby configuration leave a part of order `|J −
            // J'| |δ − δ₀|` besides: measured.
            self.linear_residual(jac, r, second)
        };
        if !linear.is_finite() {
            return None;
        }
        let (bound, worst) = self.step_bound(chain.lines(), e, first, second, linear, reach);
        Some((bound, shrink(second, worst)))
    }

    /// `r = e − J δ₀ − H(δ₀, δ₀)`: the residual at `p + δ₀` (`δ₀ = first`) to
    /// second order, from `left = e − J δ₀` (what the linear
    /// part leaves: `λ² y₁` exactly when `δ₀` is the first-order step of fresh
    /// factors, whose solve gave `y₁`).
    fn predicted(
        &self,
        chain: &ServoChain<T>,
        jac: &[[T; 6]],
        left: [T; 6],
        first: &[T],
    ) -> [T; 6] {
        let mut r = left;
        let h = second_order(
            &self.joints,
            chain.lines(),
            jac,
            first,
            self.rotation_scale(),
        );
        r.iter_mut().zip(h).for_each(|(r, h)| *r -= h);
        r
    }

    /// `e − J d`.
    fn left(&self, jac: &[[T; 6]], e: &[T; 6], d: &[T]) -> [T; 6] {
        let moved = apply(jac, d);
        let mut left = *e;
        left.iter_mut().zip(moved).for_each(|(l, m)| *l -= m);
        left
    }

    /// The 1-norm of `ℓ = r − J d`, the part of `r` a step `d` leaves to
    /// first order.
    fn linear_residual(&self, jac: &[[T; 6]], r: &[T; 6], d: &[T]) -> T {
        let left = self.left(jac, r, d);
        left.iter().fold(T::zero(), |s, x| s + x.abs())
    }

    /// The second-order step `δ = δ₀ + (δ − δ₀)` into `second` (which holds
    /// `δ − δ₀` on entry), and in the same pass the bound of the module header
    /// on the residual after it, or `None` where that does not apply (a step
    /// over 0.1 rad, a rotation error over 0.4 rad); and the largest share of
    /// its bound that a joint's step takes (for the trust region,
    /// [`shrink`]).
    #[inline(always)]
    fn step_bound(
        &self,
        lines: &[JointLine<T>],
        e: &[T; 6],
        first: &[T],
        second: &mut [T],
        linear: T,
        reach: T,
    ) -> (Option<T>, T) {
        let ls = self.limits.length_scale;
        // σ(δ) = Σ_revolute |δ_m| + Σ_prismatic |δ_m| / R; s_r the revolute part.
        let (mut diff, mut sum, mut size, mut turn) = (T::zero(), T::zero(), T::zero(), T::zero());
        let mut theta = Vector3::zeros();
        let mut worst = T::zero();
        let steps = first.iter().zip(second.iter_mut()).zip(&self.bounds);
        for ((joint, line), ((&d1, d2), &(max, _))) in self.joints.iter().zip(lines).zip(steps) {
            *d2 += d1;
            let d2 = *d2;
            worst = larger(worst, d2.abs() / max);
            let unit = match joint {
                JointType::Revolute => {
                    turn += d2.abs();
                    theta += line.w * d2;
                    T::one()
                }
                JointType::Prismatic => T::one() / reach,
            };
            diff += (d1 - d2).abs() * unit;
            sum += (d1 + d2).abs() * unit;
            size += d2.abs() * unit;
        }
        if size > T::lit(0.1) {
            return (None, worst);
        }
        let mut bound = linear;
        let lever = reach + if self.orientation { ls } else { T::zero() };
        bound += lever * (T::lit(0.5) * diff * sum + T::lit(0.2) * size * size * size);
        if self.orientation {
            let phi = Vector3::new(e[0], e[1], e[2]) / ls;
            let phi1 = phi.x.abs() + phi.y.abs() + phi.z.abs();
            if phi1 > T::lit(0.4) {
                return (None, worst);
            }
            let cross = phi.cross(&theta);
            let cross1 = cross.x.abs() + cross.y.abs() + cross.z.abs();
            bound += ls
                * (T::lit(0.5) * cross1
                    + T::lit(0.55) * phi1 * turn * turn
                    + T::lit(0.65) * phi1 * phi1 * turn);
        }
        (Some(bound), worst)
    }
}

/// The `L D Lᵀ` factors of the damped system `J Jᵀ + λ² I` of a step: `L`
/// (unit diagonal) below the diagonal, `1/D` on it.
type Factors<T> = [[T; 6]; 6];

/// The `L D Lᵀ` factors of `J Jᵀ + λ² I` (`lambda2 = λ²`) for the columns
/// `jac` into `a` (its lower triangle); `None` if not positive definite or not finite. Always the six rows
/// (without orientation the rotation rows of `J` and of the residual are zero,
/// their block is `λ² I` and their part of the solution zero: the same step as
/// the three position rows alone), so that every loop has a fixed length; no
/// square root is taken (a software routine on the controller).
// Triangular index arithmetic reads best with indices.
#[allow(clippy::needless_range_loop)]
fn factor<T: Real>(jac: &[[T; 6]], lambda2: T, a: &mut Factors<T>) -> Option<()> {
    for i in 0..6 {
        for j in 0..i {
            a[i][j] = T::zero();
        }
        a[i][i] = lambda2;
    }
    for col in jac {
        for i in 0..6 {
            for j in 0..=i {
                a[i][j] += col[i] * col[j];
            }
        }
    }
    // Column by column: D_j = A_jj − Σ_p L_jp² D_p, L_ij = (A_ij − Σ_p L_ip L_jp D_p) / D_j.
    for j in 0..6 {
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
        for i in j + 1..6 {
            // Here a[i][p] (p < j) holds L_ip D_p, and a[j][p] L_jp D_p.
            let mut s = a[i][j];
            for p in 0..j {
                s -= a[i][p] * a[j][p] * a[p][p];
            }
            a[i][j] = s;
        }
    }
    // a[i][j] holds L_ij D_j below the diagonal: divide by D_j.
    for j in 0..6 {
        for i in j + 1..6 {
            a[i][j] *= a[j][j];
        }
    }
    Some(())
}

/// `Jᵀ y` into `out`, with `y = (J Jᵀ + λ² I)⁻¹ r` and `l` from [`factor`]
/// (of this `J`, or of a nearby one: then an approximate inverse, whose
/// linear residual the caller measures); returns `y`, or `None` if not finite.
// Triangular index arithmetic reads best with indices.
#[allow(clippy::needless_range_loop)]
fn damped_solve<T: Real>(
    jac: &[[T; 6]],
    l: &Factors<T>,
    r: &[T; 6],
    out: &mut [T],
) -> Option<[T; 6]> {
    // L z = r, y = z / D, then Lᵀ y = y.
    let mut y = *r;
    for i in 0..6 {
        for p in 0..i {
            y[i] -= l[i][p] * y[p];
        }
    }
    for i in 0..6 {
        y[i] *= l[i][i];
    }
    for i in (0..6).rev() {
        for p in i + 1..6 {
            y[i] -= l[p][i] * y[p];
        }
    }
    // Finite when the sum is (see `is_finite`; a sum beyond 10³⁸ even in
    // `f32` counts as not finite: no step is that large).
    let mut sum = T::zero();
    for (o, col) in out.iter_mut().zip(jac) {
        let mut d = T::zero();
        for i in 0..6 {
            d += col[i] * y[i];
        }
        sum += d;
        *o = d;
    }
    is_finite(sum).then_some(y)
}

/// Scales `step` by `1 / worst` when `worst`, the largest share of its bound
/// that a joint's step takes, is over 1 (see [`Compensator::trust`]);
/// whether it was whole.
#[inline]
fn shrink<T: Real>(step: &mut [T], worst: T) -> bool {
    if worst <= T::one() {
        return true;
    }
    let scale = T::one() / worst;
    step.iter_mut().for_each(|d| *d *= scale);
    false
}

/// The first `n` values of `joints` as a list: the whole array copied
/// (a fixed-size copy, which the compiler writes in place of the result;
/// from a slice, the values are copied twice), then cut to `n`.
#[inline(always)]
fn listed<T: Real>(joints: &Joints<T>, n: usize) -> Vec<T, MAX_JOINTS> {
    let mut list = Vec::from_array(*joints);
    list.truncate(n);
    list
}

/// The point `start + d` into `p`.
fn moved<T: Real>(p: &mut [T], start: &[T], d: &[T]) {
    for ((pm, s), dm) in p.iter_mut().zip(start).zip(d) {
        *pm = *s + *dm;
    }
}

/// Takes the step `d`: `p += d`.
fn take<T: Real>(p: &mut [T], d: &[T]) {
    for (pm, dm) in p.iter_mut().zip(d) {
        *pm += *dm;
    }
}

/// `J v`: the residual row a joint change `v` moves the measured frame by, to
/// first order.
#[inline]
fn apply<T: Real>(jac: &[[T; 6]], v: &[T]) -> [T; 6] {
    let mut out = [T::zero(); 6];
    for (col, d) in jac.iter().zip(v) {
        for i in 0..6 {
            out[i] += col[i] * *d;
        }
    }
    out
}

/// The calibrated geometry at one tick's temperature: the prepared model, the
/// thermal length factor its chains apply, whether the measured frame's
/// rotation is wanted, and the nominal chain's angles, near which its chains'
/// sines and cosines are found ([`Sines::Near`]).
struct Geometry<'a, T: Real> {
    model: &'a Prepared<T>,
    factor: T,
    rotation: bool,
    angles: &'a Angles<T>,
}

impl<T: Real> Geometry<'_, T> {
    /// The chain at joint positions `p` into `chain`, with the joint lines if
    /// `lines` and the centres of mass (for the gravity torques) if `centres`.
    fn chain(
        &self,
        p: &[T],
        lines: bool,
        centres: bool,
        chain: &mut ServoChain<T>,
    ) -> Result<(), Fault> {
        let wanted = Wanted {
            lines,
            centres,
            rotation: self.rotation,
        };
        self.model
            .servo_chain_with(p, self.factor, wanted, Sines::Near(self.angles), chain)
            .map_err(|_| Fault::JointCount)
    }
}

/// The second-order term `H(δ, δ)` for joint changes `δ`, as a residual row
/// (rotation scaled by `ls`, then displacement of the tool point), from the
/// joint lines and the Jacobian's displacement rows `v_m` (the velocity of the
/// tool point per unit of joint `m`): with the coordinates' origin at the tool
/// point, each joint's twist is `[w_m; v_m]` and eq. 2.22's `E₂ = Σ_m (S_m +
/// ½X_m) X_m`, `X_m = ξ̂_m δ_m`, `S_m = Σ_{i<m} X_i`, moves the point by `Σ_m a_m
/// × v_m δ_m` and turns by `½ Σ_m a_m × w_m δ_m` (the vector of the
/// skew-symmetric part of its rotation block), with `a_m = Σ_{i<m} w_i δ_i + ½
/// w_m δ_m` (zero `w` for a prismatic joint). A few products per joint instead
/// of the 4 × 4 ones of [`crate::perturbation::expand`], which it equals
/// (tested).
fn second_order<T: Real>(
    joints: &[JointType],
    lines: &[JointLine<T>],
    jac: &[[T; 6]],
    delta: &[T],
    ls: T,
) -> [T; 6] {
    let mut sums = SecondOrder::new();
    for (((joint, line), col), &d) in joints.iter().zip(lines).zip(jac).zip(delta) {
        let w = match joint {
            JointType::Revolute => line.w,
            JointType::Prismatic => Vector3::zeros(),
        };
        sums.add(w, Vector3::new(col[3], col[4], col[5]), d);
    }
    sums.finish(ls).1
}

/// The sums of [`second_order`], joint by joint from the base: `s = Σ_{i<m}
/// w_i δ_i`, the rotation `Σ s × w_m δ_m`, the displacement `Σ a_m × v_m δ_m`,
/// and `Σ v_m δ_m` (with `s`, the first-order change `J δ`).
struct SecondOrder<T: Real> {
    s: Vector3<T>,
    rot: Vector3<T>,
    disp: Vector3<T>,
    lin: Vector3<T>,
}

impl<T: Real> SecondOrder<T> {
    /// No joint yet.
    #[inline(always)]
    fn new() -> Self {
        Self {
            s: Vector3::zeros(),
            rot: Vector3::zeros(),
            disp: Vector3::zeros(),
            lin: Vector3::zeros(),
        }
    }

    /// Adds joint `m` with axis `w` (zero for a prismatic joint), tool-point
    /// velocity `v` and change `d`.
    #[inline(always)]
    fn add(&mut self, w: Vector3<T>, v: Vector3<T>, d: T) {
        let (w, v) = (w * d, v * d);
        // a = s + ½ w, and a × w = s × w.
        let a = self.s + w * T::lit(0.5);
        self.rot += self.s.cross(&w);
        self.disp += a.cross(&v);
        self.s += w;
        self.lin += v;
    }

    /// `J δ` and `H(δ, δ)` as residual rows, the rotation rows scaled by `ls`.
    #[inline(always)]
    fn finish(self, ls: T) -> ([T; 6], [T; 6]) {
        let (s, lin) = (self.s * ls, self.lin);
        let rot = self.rot * (T::lit(0.5) * ls);
        let disp = self.disp;
        (
            [s.x, s.y, s.z, lin.x, lin.y, lin.z],
            [rot.x, rot.y, rot.z, disp.x, disp.y, disp.z],
        )
    }
}

/// Joint `m`'s column of `J_r` at the tool point `p` (rotation rows scaled by
/// `rotation`) and its rotation axis (zero for a prismatic joint); raises
/// `reach` to the 1-norm of its lever.
#[inline(always)]
fn column<T: Real>(
    joint: JointType,
    line: &JointLine<T>,
    p: &Vector3<T>,
    rotation: T,
    reach: &mut T,
) -> ([T; 6], Vector3<T>) {
    let w = line.w;
    match joint {
        JointType::Revolute => {
            let v = w.cross(&(p - line.rho.coords));
            *reach = larger(*reach, v.x.abs() + v.y.abs() + v.z.abs());
            let r = w * rotation;
            ([r.x, r.y, r.z, v.x, v.y, v.z], w)
        }
        JointType::Prismatic => (
            [T::zero(), T::zero(), T::zero(), w.x, w.y, w.z],
            Vector3::zeros(),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jacobian::at_point;
    use crate::perturbation::expand;
    use crate::servo_chain::Wanted;
    use crate::{Convention, Link, Param};

    /// [`second_order`] is the second-order part of [`expand`] for joint
    /// errors, in both conventions, with revolute and prismatic joints, with
    /// the rotation rows scaled by a length scale of 0.7 m.
    #[test]
    fn second_order_equals_expand() {
        let (r, p) = (JointType::Revolute, JointType::Prismatic);
        let links = [
            Link::new(r, 0.1, 0.3, 0.2, 1.2),
            Link::new(p, -0.4, 0.1, 0.5, -0.7),
            Link::new(r, 0.7, -0.2, 0.3, 0.4),
            Link::new(r, -1.1, 0.15, -0.25, -1.3),
        ];
        let joints = [r, p, r, r];
        let q = [0.3, 0.05, -0.8, 1.9];
        let delta = [0.02, -0.01, 0.03, -0.015];
        let ls = 0.7;
        for convention in [Convention::Dh, Convention::Mdh] {
            let robot = Robot::new(convention, &links).unwrap();
            let chain = robot.chain(&q).unwrap();
            let mut servo = ServoChain::default();
            let wanted = Wanted {
                lines: true,
                centres: false,
                rotation: true,
            };
            robot
                .prepare()
                .servo_chain_into(&q, 1.0, wanted, &mut servo)
                .unwrap();
            let params = [
                Param::Theta(0),
                Param::S(1),
                Param::Theta(2),
                Param::Theta(3),
            ];
            let point = chain.point();
            let jac: Vec<[f64; 6], MAX_JOINTS> = params
                .iter()
                .map(|&m| {
                    let col = chain.column(m);
                    let v = at_point(&col, &point);
                    [col[0] * ls, col[1] * ls, col[2] * ls, v.x, v.y, v.z]
                })
                .collect();
            let h = second_order(&joints, servo.lines(), &jac, &delta, ls);
            let errors: Vec<(Param, f64), MAX_JOINTS> = params.iter().copied().zip(delta).collect();
            let e = expand(&chain, convention, &errors).unwrap();
            let want_disp = e.point_error() - at_point(&e.first, &point);
            let want_rot = e.second_twist().fixed_rows::<3>(0).into_owned() * ls;
            let rot = Vector3::new(h[0], h[1], h[2]);
            let disp = Vector3::new(h[3], h[4], h[5]);
            assert!((rot - want_rot).norm() < 1e-15, "{convention:?}");
            assert!((disp - want_disp).norm() < 1e-15, "{convention:?}");
            // Not vacuous: the terms are 1e4 times the tolerance above.
            assert!(want_disp.norm() > 1e-5 && want_rot.norm() > 1e-5);
        }
    }
}
