//! Joint compensation: the commands that make the calibrated robot reach the pose
//! the nominal model intended. Kirchner, Gurumoorthy & Prinz (1985), section 4.
//!
//! The controller's nominal model turned a desired pose into joint commands
//! `q_cmd`; the real (calibrated) robot at `q_cmd` misses that pose. Wanted: the
//! joint positions `p` with
//!
//! ```text
//! T_cal(p) = T_nom(q_cmd)                    (the pose the nominal model intended)
//! ```
//!
//! and then the commands `q` that put the joints at `p` ([`inversion`]: the
//! identity without joint effects). Writing `p = q_cmd + δq`, the paper expands
//! the real forward solution in `δq` (eq. 4.3) and balances it against the source
//! term of the errors (eq. 4.8); the series inversion (4.9), `δq = J⁺ (e − H(δ₁,
//! δ₁))` with `δ₁ = J⁺ e`, is repeated about the better point until the residual
//! is below [`Limits::tolerance`] ([`newton`]; the bound that lets a step be taken
//! without evaluating the chain after it is [`step_bound`]; the `L D Lᵀ` factors
//! of `J Jᵀ + λ² I`, reused across ticks, are [`factors`]).
//!
//! # A correction is a function of the command and its context
//!
//! The answer depends on `q_cmd`, the tick's [`Conditions`] (temperature,
//! payload) and the approach direction of each joint (for backlash), never on
//! how the search got there. Three choices make it unique:
//!
//! - **The task.** A calibration from full poses is compensated in full pose
//!   (6 rows); one from positions alone in position (3 rows that must be
//!   reached), keeping the flange's orientation where the calibrated model
//!   has it at the command, `R_cal(p) = R_cal(q_cmd)` (3 rows more, weighed).
//!   A position-only calibration does not measure the orientation: parameters
//!   that turn the tool about its own point (a wrist offset traded against a
//!   wrist length, the tool's rotation) can be off by tens of mrad while every
//!   position fits, so bringing its orientation to the nominal one would ask
//!   the wrist for corrections of that size; keeping its own orientation at
//!   the command asks for none of that (the flange turns as the robot would
//!   at the command), and a working tool then misses by what the robot's own
//!   orientation error at the command puts at its tip, where the least
//!   correction reaching the point turned the flange by up to tens of mrad
//!   near a wrist singularity. Near a singularity keeping the orientation
//!   needs large corrections (`1/sin q5` of the turn for a wrist), and at it
//!   is impossible: the rotation rows are damped at
//!   [`Limits::turn_damping`], so that where the joints keeping the point
//!   turn the flange by less than 0.1 rad per rad, the orientation gives way
//!   smoothly to a smaller correction while the point is still reached; the
//!   turn left is reported ([`Compensator::turn`]). An arm of 3 joints or
//!   fewer has no joint to spare: the point alone.
//! - **The least correction.** Where joints remain beyond the task's rows (a
//!   6-axis arm in position, a 7-axis arm in full pose), the answer is the
//!   least correction `p − q_cmd` that reaches the target, weighed against
//!   the turn for a position (the damped least squares of all six rows: the
//!   position's reached, the turn's and the correction's squares balanced):
//!   each step solves for the whole correction (`J⁺ (r + J c)` in place of
//!   `c + J⁺ r`, with `c` the correction so far), so the null-space part of
//!   the correction is removed at every step, from whichever start, and the
//!   search goes on until a step no longer moves the joints (the task's
//!   residual says nothing of the null space; a search whose iterations run
//!   out first, near a singularity, is flagged [`Fault::NotConverged`]). It is
//!   measured from `q_cmd`, never from the previous tick. Position rows alone
//!   with steps from the previous tick would leave three directions free,
//!   along which a servo stream drifts (tens of mrad over a thousand
//!   ticks).
//! - **The frame of the targets** ([`TargetFrame`], carried by the
//!   calibration): targets in the world (measurement) frame compensate the
//!   identified base too; targets in the robot's own base frame compensate the
//!   arm alone (the identified base errors are left out: they register the
//!   measuring instrument, which no joint motion should "correct").
//!
//! The warm start, the predicted step and the reused factors are speed devices
//! only: a warm search that does not converge is repeated from `q_cmd` with
//! fresh factors in the same tick. [`Stream`] owns everything a stream of ticks
//! carries from one to the next, and sets the pacing ([`Pacing`]): a robot
//! program's target points, each solved alone to convergence, or servo ticks
//! with the per-tick change bound, a safety limit that may clip one tick
//! (flagged [`Fault::Limited`]) but never the answer the following ticks reach.
//!
//! # Rows and units
//!
//! Residual rows: rotation (rad, scaled by [`Limits::length_scale`], or for a
//! position task by [`Limits::turn_scale`], so that both parts are lengths),
//! then position (m). The rotation part is `φ`, the vector of the
//! skew-symmetric part of `R_target R_reachedᵀ` (eq. 15's `νdφ`, `½ Σ_i r_i ×
//! t_i` over the columns): zero exactly where the rotations agree. `J⁺` is the
//! damped least-squares inverse `Jᵀ (J Jᵀ + D)⁻¹`, `D = λ² I` (for a position
//! task keeping the orientation, `(λ/100)²` on every row, the position rows,
//! which must be reached, and [`Limits::turn_damping`]² more on the rotation
//! rows, which give way): away from singularities `J⁻¹` up to `λ²/σ²`, near
//! one it bounds the
//! step. Every correction is bounded
//! per joint in size ([`Limits::max_correction_angle`],
//! [`Limits::max_correction_length`]); any non-finite input or intermediate
//! value returns the nominal command with [`Fault::NonFinite`]: the controller
//! never sends a wild command.
//!
//! # Modules
//!
//! | module | idea |
//! | --- | --- |
//! | [`stream`] | the state a stream of ticks carries ([`Stream`]), pacing, change bound, approach directions |
//! | [`start`] | where a tick's search starts: cold from `q_cmd`, or warm from the previous tick's correction with a predicted step |
//! | [`newton`] | the geometric problem: eq. 4.9 repeated, the line search near singularities |
//! | [`step_bound`] | the second-order term `H`, the Jacobian's columns, the bound on the residual after a step |
//! | [`factors`] | the `L D Lᵀ` factors of the damped system, fresh or stale |
//! | [`inversion`] | the joint effects' inversion: commands from joint positions, backlash |

use heapless::Vec;
use nalgebra::{IsometryMatrix3, Vector3};

use crate::effects::{Effect, EffectModel, JointEffect, MAX_EFFECTS, Masses, length_factor};
use crate::kinematics::Prepared;
use crate::model::bounded;
use crate::servo_chain::{Angles, ServoChain, Sines, Wanted};
use crate::{Calibration, JointType, MAX_JOINTS, Real, Robot};

pub mod factors;
pub mod inversion;
pub mod newton;
pub mod start;
pub mod step_bound;
pub mod stream;

pub use crate::calibration::TargetFrame;
use factors::Factors;
use inversion::{Inverted, Slopes};
use newton::Steps;
use start::Start;
pub use stream::{Pacing, Stream};

/// The conditions of one tick that non-geometric effects depend on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Conditions<T: Real> {
    /// Temperature, °C; `None`: the reference temperature of thermal expansion.
    pub temperature: Option<T>,
    /// Payload at the tool point, kg; `None`: none.
    pub payload: Option<T>,
}

/// Bounds and tolerances of the compensation, SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits<T: Real> {
    /// Largest correction of a revolute joint, rad.
    pub max_correction_angle: T,
    /// Largest correction of a prismatic joint, m.
    pub max_correction_length: T,
    /// Largest change of a revolute joint's correction from one servo tick to
    /// the next, rad ([`Pacing::Servo`] only).
    pub max_change_angle: T,
    /// Largest change of a prismatic joint's correction per servo tick, m.
    pub max_change_length: T,
    /// Stop refining when the residual (position, and orientation times
    /// `length_scale`) is below this, m; above it after every iteration the
    /// correction is flagged [`Fault::NotConverged`].
    pub tolerance: T,
    /// Most refinement iterations of one search (fixes the worst-case cost; a
    /// warm search that fails is followed by one cold search).
    pub max_iterations: usize,
    /// Damping `λ` of the least-squares inverse, m.
    pub damping: T,
    /// The length that turns rotation rows (rad) into lengths, m.
    pub length_scale: T,
    /// The length that turns the rotation rows of a position-only
    /// compensation ([`Task::Position`]: the flange's turn from the calibrated
    /// orientation at the command) into lengths, m; zero: the orientation is
    /// not kept (the least correction that reaches the point).
    pub turn_scale: T,
    /// The damping of those rotation rows, m: where the joints that keep the
    /// point can turn the flange by less than `turn_damping / turn_scale` rad
    /// per rad (a wrist within that sine of its singularity), keeping the
    /// orientation gives way to a smaller correction.
    pub turn_damping: T,
}

impl<T: Real> Default for Limits<T> {
    /// Corrections up to 0.1 rad (5.7°) and 50 mm, changing by at most 0.01 rad and
    /// 5 mm per servo tick; refine until the residual is below 8 ε of a metre or
    /// 1 nm, whichever is larger (0.95 µm in f32, where rounding of a 1 m chain
    /// is about 0.1 µm; 1 nm in f64), in at most 4 iterations; damping 1e-4 m;
    /// rotations weighed at 1 m, in a position-only compensation too, where
    /// they are damped at 0.1 m: keeping the orientation gives way within a
    /// sine of about 0.1 of a wrist singularity (about 6°, where keeping a
    /// turn asks the wrist for about 7 times as much), and the wrist's
    /// correction for a turn of a few mrad stays within its 0.1 rad bound.
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
            turn_scale: T::one(),
            turn_damping: T::lit(0.1),
        }
    }
}

impl<T: Real> Limits<T> {
    /// The limits of a [`Pacing`]: [`Limits::default`] for servo ticks (the
    /// controller's deadline fixes the iterations); for a program's points the
    /// same bounds and tolerance with 20 iterations (each point starts from its
    /// own command, and a row has no servo deadline).
    pub fn of(pacing: Pacing) -> Self {
        match pacing {
            Pacing::Servo => Self::default(),
            Pacing::Program => Self {
                max_iterations: 20,
                ..Self::default()
            },
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
    /// singularity, out of reach, or within a joint's lost motion), or, where
    /// joints remain beyond the task's rows, the least correction was still
    /// moving after the last (near a singularity: the target is reached, but
    /// the correction is not yet the command's own): the best correction
    /// found is returned, bounded.
    NotConverged,
    /// The correction was clipped to its size bound, or (servo ticks) its
    /// change from the previous tick to the change bound.
    Limited,
}

/// The result of one compensation.
#[derive(Clone, Debug, PartialEq)]
pub struct Correction<T: Real> {
    /// The corrected joint commands (rad or m).
    pub q: Vec<T, MAX_JOINTS>,
    /// The real joint positions these commands aim at (the solution of the
    /// geometric problem, before bounding; `q_cmd` after a fault that returns it).
    pub p: Vec<T, MAX_JOINTS>,
    /// Something to report, if any; the commands are still safe to send.
    pub fault: Option<Fault>,
    /// Iterations run (a cold search after a failed warm one adds its own).
    pub iterations: usize,
    /// The remaining residual before bounding, m: the norm of the position error
    /// and, for [`Task::Pose`], of the orientation error times
    /// [`Limits::length_scale`]; when the last step was taken on its bound
    /// ([`step_bound`]), that bound, which the residual does not exceed.
    pub residual: T,
}

/// The rows a correction brings to the target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Task {
    /// Rotation and position: 6 rows.
    Pose,
    /// The position (3 rows), with the flange's orientation kept where the
    /// calibrated model has it at the command, weighed at
    /// [`Limits::turn_scale`] (3 rows more, which give way near a
    /// singularity; none for an arm of 3 joints or fewer, which has no
    /// joint to spare).
    Position,
}

impl Task {
    /// The number of rows that must be reached.
    pub fn rows(self) -> usize {
        match self {
            Self::Pose => 6,
            Self::Position => 3,
        }
    }
}

/// What the compensation knows of one joint.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JointSpec<T: Real> {
    /// Revolute or prismatic.
    pub kind: JointType,
    /// Its effects, summed.
    pub effect: JointEffect<T>,
    /// Its correction's largest size, rad or m.
    pub max_correction: T,
    /// Its correction's largest change per servo tick, rad or m.
    pub max_change: T,
    /// Whether it has gear harmonics.
    pub harmonic: bool,
    /// Whether it has backlash.
    pub backlash: bool,
}

/// One value per joint, sized for the most joints: the tick's vectors (points,
/// steps), fixed size, kept in the [`Workspace`], no allocation.
pub(crate) type Joints<T> = [T; MAX_JOINTS];

/// The compensation for one calibration: the nominal and the calibrated model,
/// prepared once, and the calibration's effects.
#[derive(Clone, Debug)]
pub struct Compensator<T: Real> {
    nominal: Prepared<T>,
    calibrated: Prepared<T>,
    joints: Vec<JointSpec<T>, MAX_JOINTS>,
    task: Task,
    /// Whether joints remain beyond the task's rows (the least correction
    /// from the command is chosen among the solutions).
    redundant: bool,
    /// Whether the task keeps the calibrated orientation at the command
    /// ([`Task::Position`] with more than 3 joints).
    keeps: bool,
    /// Whether the residual has rotation rows: [`Task::Pose`], or `keeps`.
    rotation_rows: bool,
    /// The length scale of the rotation rows: [`Limits::length_scale`] for
    /// [`Task::Pose`], [`Limits::turn_scale`] where the orientation is kept,
    /// else zero.
    rotation: T,
    /// The rotation rows' damping beyond `λ²` ([`Limits::turn_damping`]²
    /// where the orientation is kept, else zero), m².
    rotation_damping2: T,
    /// `λ²`: [`Limits::damping`]², or, where the orientation is kept,
    /// `(λ/100)²`. There the position rows must be reached while the rotation
    /// rows give way; the damping of the position rows leaves of the
    /// position about `λ²/σ²` times what the rotation rows leave, a few nm at
    /// `λ` near a singularity: at `λ/100` it is far below the tolerance. The
    /// rotation rows' damping keeps the system positive definite.
    damping2: T,
    /// The thermal expansions among the effects: coefficient (1/°C) and
    /// reference temperature (°C).
    thermal: Vec<(T, T), MAX_EFFECTS>,
    /// Bit `j` set when joint `j` has a compliance (for [`Masses::torques`]).
    compliant: u32,
    /// The calibrated model's masses and gravity, for the torques of a compliance.
    masses: Masses<T>,
    /// How fast the effects' joint offsets change with the joints.
    slopes: Slopes<T>,
    /// Whether the effects move the joints (any but thermal expansion).
    corrects_joints: bool,
    /// The bounds and tolerances in force.
    limits: Limits<T>,
}

/// What a tick leaves for the next (the factors of the last step's system, the
/// correction's last change) and its work arrays. [`Stream`] keeps one; a fresh
/// one is only slower.
#[derive(Clone, Debug)]
pub(crate) struct Workspace<T: Real> {
    /// The factors the last step used.
    pub(crate) factors: Factors<T>,
    /// The last servo tick's change of the correction `p − q_cmd` from the
    /// tick before, when both converged from a warm start: the next predictor
    /// extrapolates it.
    pub(crate) rate: Rate<T>,
    /// The nominal chain's joint angles, their sines and cosines.
    pub(crate) angles: Angles<T>,
    pub(crate) tick: Tick<T>,
}

impl<T: Real> Workspace<T> {
    /// An empty workspace: the first step factors afresh.
    pub(crate) fn new() -> Self {
        let zeros = [T::zero(); MAX_JOINTS];
        Self {
            factors: Factors::new(),
            rate: Rate {
                change: zeros,
                known: false,
            },
            angles: Angles::default(),
            tick: Tick {
                chain: ServoChain::default(),
                x: zeros,
                tau: zeros,
                p: zeros,
                reached: zeros,
                steps: Steps::new(),
            },
        }
    }
}

/// The last servo tick's change of the correction `p − q_cmd` from the tick
/// before, known when both converged from a warm start.
#[derive(Clone, Debug)]
pub(crate) struct Rate<T: Real> {
    pub change: Joints<T>,
    pub known: bool,
}

/// The work arrays of one tick, kept in the [`Workspace`] so that none is
/// cleared or copied per tick. Between ticks their contents mean nothing.
#[derive(Clone, Debug)]
pub(crate) struct Tick<T: Real> {
    /// The chain of the last evaluation.
    pub chain: ServoChain<T>,
    /// The start of the search ([`start`]), then, in place, the commands that
    /// put the joints at `p`.
    pub x: Joints<T>,
    /// The gravity torques at the last evaluation.
    pub tau: Joints<T>,
    /// The joint positions that reach the target.
    pub p: Joints<T>,
    /// Where the joints really go when one is held within its lost motion.
    pub reached: Joints<T>,
    /// The geometric problem's.
    pub steps: Steps<T>,
}

/// What [`Compensator::compute`] found besides the commands and positions in
/// the [`Tick`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Answer<T: Real> {
    /// Whether the residual is below the tolerance and, where joints remain
    /// beyond the task's rows, the least correction settled.
    pub converged: bool,
    /// Whether it converged from a warm start (the correction's change is
    /// then the next predictor's rate).
    pub extrapolates: bool,
    /// Iterations run.
    pub iterations: usize,
    /// The residual, m (or its bound).
    pub residual: T,
}

impl<T: Real> Correction<T> {
    /// The command itself, flagged.
    pub(crate) fn unchanged(q_cmd: &[T], fault: Fault) -> Self {
        Self {
            q: bounded(q_cmd.iter().copied()),
            p: bounded(q_cmd.iter().copied()),
            fault: Some(fault),
            iterations: 0,
            residual: T::zero(),
        }
    }
}

/// The previous tick as sent, the context of this one (kept by the
/// [`Stream`]): the approach direction of each joint and, on a warm start, the
/// correction to start from. Vectors over the joints.
#[derive(Clone, Debug)]
pub(crate) struct Previous<T: Real> {
    /// The nominal commands.
    pub q_cmd: Joints<T>,
    /// The commands sent (after every bound).
    pub sent: Joints<T>,
    /// The joint positions they aimed at.
    pub p: Joints<T>,
    /// Each joint's approach direction after it: −1, 0 (never moved) or +1;
    /// kept for the joints with backlash, the only ones that read it.
    pub approach: [i8; MAX_JOINTS],
    /// The number of joints; 0 before the first tick.
    pub joints: usize,
}

/// Whether `x` is finite: `x − x` is 0 for a finite `x` and NaN otherwise.
#[inline(always)]
#[allow(clippy::eq_op)]
pub(crate) fn is_finite<T: Real>(x: T) -> bool {
    x - x == T::zero()
}

/// `x` clamped to `[lo, hi]` if it lies outside (comparisons; `max` and `min`
/// are library calls in f32 on the controller), else `None`.
#[inline(always)]
pub(crate) fn clamp<T: Real>(x: T, lo: T, hi: T) -> Option<T> {
    if x < lo {
        Some(lo)
    } else if x > hi {
        Some(hi)
    } else {
        None
    }
}

/// The larger of two values (a comparison; `max` is a library call in f32 on
/// the controller).
#[inline(always)]
pub(crate) fn larger<T: Real>(a: T, b: T) -> T {
    if b > a { b } else { a }
}

impl<T: Real> Compensator<T> {
    /// A compensator from the nominal model (the controller's) and the calibrated
    /// one (the real robot's), reaching `task`: the full pose (a calibration
    /// from full poses) or the position (see the module header).
    pub fn new(nominal: &Robot<T>, calibrated: &Robot<T>, task: Task, limits: Limits<T>) -> Self {
        Self::with_effects(
            nominal,
            EffectModel {
                robot: calibrated.clone(),
                effects: Vec::new(),
            },
            task,
            limits,
        )
    }

    /// A compensator for a calibrated model with non-geometric effects.
    pub fn with_effects(
        nominal: &Robot<T>,
        calibrated: EffectModel<T>,
        task: Task,
        limits: Limits<T>,
    ) -> Self {
        let robot = &calibrated.robot;
        let masses = Masses::of(robot, &robot.base.isometry());
        let effects = calibrated.joint_effects(robot.dof());
        let zero = [T::zero(), T::zero()];
        let joints: Vec<JointSpec<T>, MAX_JOINTS> =
            bounded(robot.links.iter().zip(&effects).map(|(l, e)| {
                let (max_correction, max_change) = match l.joint {
                    JointType::Revolute => (limits.max_correction_angle, limits.max_change_angle),
                    JointType::Prismatic => {
                        (limits.max_correction_length, limits.max_change_length)
                    }
                };
                JointSpec {
                    kind: l.joint,
                    effect: *e,
                    max_correction,
                    max_change,
                    harmonic: e.first != zero || e.second != zero,
                    backlash: e.backlash != T::zero(),
                }
            }));
        let compliant = effects
            .iter()
            .enumerate()
            .filter(|(_, e)| e.compliance != T::zero())
            .fold(0u32, |m, (j, _)| m | 1 << j);
        let keeps =
            task == Task::Position && robot.dof() > task.rows() && limits.turn_scale > T::zero();
        Self {
            redundant: robot.dof() > task.rows(),
            keeps,
            rotation_rows: task == Task::Pose || keeps,
            rotation: match task {
                Task::Pose => limits.length_scale,
                Task::Position if keeps => limits.turn_scale,
                Task::Position => T::zero(),
            },
            damping2: if keeps {
                limits.damping * limits.damping * T::lit(1e-4)
            } else {
                limits.damping * limits.damping
            },
            rotation_damping2: if keeps {
                limits.turn_damping * limits.turn_damping
            } else {
                T::zero()
            },
            task,
            compliant,
            corrects_joints: calibrated.corrects_joints(),
            nominal: nominal.prepare(),
            calibrated: robot.prepare(),
            slopes: Slopes::of(robot, &effects, &masses),
            joints,
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

    /// A compensator for a calibration file's models and effects, in the scalar
    /// `T` (`f32` on the controller), for the frame of targets it names
    /// ([`Calibration::targets`]). Never inlined: a constructor runs once per
    /// calibration load, and one copy of it keeps the controller's flash small.
    #[inline(never)]
    pub fn from_calibration(calibration: &Calibration, limits: Limits<T>) -> Self {
        // The identified errors are added in `T` (in f32 the sum rounds once more,
        // by at most an f32 unit in the last place): the controller then needs no
        // f64 arithmetic.
        let mut robot: Robot<T> = calibration.nominal.cast();
        for e in calibration.compensated_errors() {
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
        Self::with_effects(&calibration.nominal.cast(), model, calibration.task, limits)
    }

    /// The number of joints.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// The rows brought to the target.
    pub fn task(&self) -> Task {
        self.task
    }

    /// The bounds and tolerances in force.
    pub fn limits(&self) -> &Limits<T> {
        &self.limits
    }

    /// The corrected commands for `q_cmd` alone (no previous command: every
    /// joint's approach direction unknown), in `conditions`: a robot program's
    /// first point. [`Stream`] gives the points that follow their context.
    pub fn correct(&self, q_cmd: &[T], conditions: &Conditions<T>) -> Correction<T> {
        Stream::new(Pacing::Program).tick(self, q_cmd, conditions)
    }

    /// One tick's answer for `q_cmd` in `conditions` after `previous`,
    /// searched from `start`: the commands into `work.tick.x`, the joint
    /// positions into `work.tick.p`, before any bound (the [`Stream`] applies
    /// the bounds, in the pass that keeps the tick for the next). A warm search
    /// that does not converge is repeated cold.
    #[inline(never)]
    pub(crate) fn compute(
        &self,
        q_cmd: &[T],
        previous: Option<&Previous<T>>,
        start: Start,
        conditions: &Conditions<T>,
        work: &mut Workspace<T>,
    ) -> Result<Answer<T>, Fault> {
        let n = self.dof();
        if q_cmd.len() != n {
            return Err(Fault::JointCount);
        }
        // The inputs' check: their sum is finite exactly when each is, unless
        // it overflows beyond 10³⁸, which no joint value or condition reaches
        // (such a value is refused too). Nothing is evaluated before it passes.
        let inputs = q_cmd.iter().fold(
            conditions.temperature.unwrap_or(T::zero()) + conditions.payload.unwrap_or(T::zero()),
            |s, q| s + *q,
        );
        if !is_finite(inputs) {
            return Err(Fault::NonFinite);
        }
        let Workspace {
            factors,
            rate,
            angles,
            tick,
        } = work;
        // The pose the nominal model intended (for a position-only task, its
        // point), its joint angles' sines and cosines recorded: every chain of
        // the calibrated model below is near them.
        let wanted = Wanted {
            lines: false,
            centres: false,
            rotation: self.task == Task::Pose,
        };
        if self
            .nominal
            .servo_chain_with(
                q_cmd,
                T::one(),
                wanted,
                Sines::Record(angles),
                &mut tick.chain,
            )
            .is_err()
        {
            return Err(Fault::JointCount);
        }
        let mut target = tick.chain.end;
        let geometry = Geometry {
            model: &self.calibrated,
            factor: length_factor(self.thermal.iter().copied(), conditions.temperature),
            rotation: self.rotation_rows,
            angles,
        };
        if self.keeps {
            // The orientation to keep: the calibrated model's at the command.
            geometry.chain(q_cmd, Parts::Frame, &mut tick.chain)?;
            target.rotation = tick.chain.end.rotation;
        }
        let problem = Problem {
            geometry: &geometry,
            target: &target,
            q_cmd,
            payload: conditions.payload.unwrap_or(T::zero()),
        };
        // 1. The joint positions that reach the target: warm, and cold if the
        // warm search does not converge (or its least correction does not settle).
        let tolerance2 = self.limits.tolerance * self.limits.tolerance;
        let mut start = self.start(q_cmd, previous, start, rate, tick);
        let mut iterations = 0;
        let solved = loop {
            let solved = self.search(&problem, start, factors, tick)?;
            iterations += solved.iterations;
            if (solved.residual2 <= tolerance2 && solved.settled) || start == Start::Cold {
                break solved;
            }
            start = self.start(q_cmd, None, Start::Cold, rate, tick);
        };
        // The correction's change is known for the next warm tick's
        // predictor when this one converged from a warm start.
        let extrapolates = start == Start::Warm && solved.residual2 <= tolerance2;
        let (mut residual2, mut norm) = (solved.residual2, solved.bound);
        // 2. The commands that put the joints at p (in place of the start).
        let Tick {
            chain,
            x,
            tau,
            p,
            reached,
            ..
        } = tick;
        let q = &mut x[..n];
        if self.corrects_joints {
            let approach = previous.map(|prev| (&prev.sent[..n], &prev.approach[..n]));
            match self.invert(&problem, q, &p[..n], &mut tau[..n], approach, chain)? {
                Inverted::Reached => {}
                Inverted::Held => {
                    // Held within a lost motion: where the joints really go.
                    self.reached(q, &tau[..n], approach, &mut reached[..n]);
                    if geometry.chain(&reached[..n], Parts::Frame, chain).is_err() {
                        return Err(Fault::JointCount);
                    }
                    residual2 = self.residual(&target, &chain.end).1;
                    norm = None;
                }
            }
        } else {
            q.copy_from_slice(&p[..n]);
        }
        Ok(Answer {
            converged: residual2 <= tolerance2 && solved.settled,
            extrapolates,
            iterations,
            residual: norm.unwrap_or_else(|| residual2.sqrt()),
        })
    }

    /// The residual `e` (rotation scaled to a length, then position; the rotation
    /// part is zero for [`Task::Position`] of an arm of 3 joints or fewer) and
    /// the squared norm of the rows that must be reached (all six for
    /// [`Task::Pose`], the position's for [`Task::Position`]). The rotation
    /// part is `φ`, the vector of the skew-symmetric part of `R_target R_reachedᵀ`
    /// (`½ Σ_i r_i × t_i` over the columns, eq. 15's `νdφ`): zero exactly where
    /// the rotations agree, the rotation vector to third order.
    pub(crate) fn residual(
        &self,
        target: &IsometryMatrix3<T>,
        reached: &IsometryMatrix3<T>,
    ) -> ([T; 6], T) {
        let dp = target.translation.vector - reached.translation.vector;
        let mut dr = Vector3::zeros();
        if self.rotation_rows {
            let (t, r) = (target.rotation.matrix(), reached.rotation.matrix());
            for i in 0..3 {
                dr += r.column(i).cross(&t.column(i));
            }
            dr *= T::lit(0.5) * self.rotation;
        }
        let e = [dr.x, dr.y, dr.z, dp.x, dp.y, dp.z];
        if self.task == Task::Pose {
            (e, e.iter().fold(T::zero(), |s, x| s + *x * *x))
        } else {
            (e, dp.x * dp.x + dp.y * dp.y + dp.z * dp.z)
        }
    }

    /// For [`Task::Position`], how far the flange turns at the joint
    /// positions `p` ([`Correction::p`]) from the orientation the calibrated
    /// model has at the command `q_cmd`, rad: the norm of the vector of the
    /// skew-symmetric part of the rotation between them, the sine of its
    /// angle (eq. 15's `νdφ`). Near zero, unless the command is so near a
    /// singularity that keeping the orientation would ask for a larger
    /// correction. Zero for [`Task::Pose`] and where the orientation is not
    /// kept; `None` for the wrong number of joints. Two evaluations of the
    /// calibrated geometry: for the calibrator, not part of a tick.
    pub fn turn(&self, q_cmd: &[T], p: &[T]) -> Option<T> {
        if !self.keeps {
            return (q_cmd.len() == self.dof() && p.len() == self.dof()).then(T::zero);
        }
        let (kept, turned) = (
            self.calibrated.forward(q_cmd).ok()?,
            self.calibrated.forward(p).ok()?,
        );
        let (t, r) = (kept.rotation.matrix(), turned.rotation.matrix());
        let mut phi = Vector3::zeros();
        for i in 0..3 {
            phi += r.column(i).cross(&t.column(i));
        }
        Some(phi.norm() * T::lit(0.5))
    }

    /// The length scale of the rotation rows: [`Limits::length_scale`] for
    /// [`Task::Pose`], [`Limits::turn_scale`] where the orientation is kept,
    /// zero otherwise.
    pub(crate) fn rotation_scale(&self) -> T {
        self.rotation
    }

    /// `λ²`, the square of the damping of the step's least-squares inverse
    /// (of its position rows, and of its rotation rows but where the
    /// orientation is kept: [`Self::leftover`]).
    pub(crate) fn damping2(&self) -> T {
        self.damping2
    }

    /// What a solve with fresh factors leaves of its right-hand side, `D y`
    /// for the `y` it returns: `D` the damping, `λ²` on every row, plus
    /// [`Limits::turn_damping`]² on the rotation rows where the orientation
    /// is kept.
    #[inline(always)]
    pub(crate) fn leftover(&self, y: [T; 6]) -> [T; 6] {
        let lambda2 = self.damping2();
        let mut left = y.map(|y| lambda2 * y);
        if self.keeps {
            for (l, y) in left.iter_mut().zip(y).take(3) {
                *l += self.rotation_damping2 * y;
            }
        }
        left
    }
}

/// The first `n` values of `joints` as a list: the whole array copied (a
/// fixed-size copy, written in place of the result), then cut to `n`.
#[inline(always)]
pub(crate) fn listed<T: Real>(joints: &Joints<T>, n: usize) -> Vec<T, MAX_JOINTS> {
    let mut list = Vec::from_array(*joints);
    list.truncate(n);
    list
}

/// The calibrated geometry at one tick's temperature: the prepared model, the
/// thermal length factor its chains apply, whether the measured frame's
/// rotation is wanted, and the nominal chain's angles, near which its chains'
/// sines and cosines are found ([`Sines::Near`]).
pub(crate) struct Geometry<'a, T: Real> {
    pub model: &'a Prepared<T>,
    pub factor: T,
    pub rotation: bool,
    pub angles: &'a Angles<T>,
}

/// One tick's problem: the calibrated geometry at the tick's temperature, the
/// pose to reach (the nominal model's at the commands), the nominal commands
/// `q_cmd` (rad or m) and the payload (kg, zero when none is given). The
/// search ([`Compensator::search`], its line search) and the inversion
/// ([`Compensator::invert`]) read it.
pub(crate) struct Problem<'a, T: Real> {
    pub geometry: &'a Geometry<'a, T>,
    pub target: &'a IsometryMatrix3<T>,
    pub q_cmd: &'a [T],
    pub payload: T,
}

/// What a chain of the calibrated [`Geometry`] computes besides the measured
/// frame. The gravity torques need the joint lines as well as the centres of
/// mass, so there is no chain with the centres alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Parts {
    /// The measured frame alone: a residual.
    Frame,
    /// With each joint's axis line: a step's Jacobian.
    Lines,
    /// With the joint lines and each link's centre of mass: a step's Jacobian
    /// and the gravity torques.
    LinesAndCentres,
}

impl<T: Real> Geometry<'_, T> {
    /// The chain at joint positions `p` into `chain`, with the `parts` besides
    /// the measured frame.
    pub fn chain(&self, p: &[T], parts: Parts, chain: &mut ServoChain<T>) -> Result<(), Fault> {
        let wanted = Wanted {
            lines: parts != Parts::Frame,
            centres: parts == Parts::LinesAndCentres,
            rotation: self.rotation,
        };
        self.model
            .servo_chain_with(p, self.factor, wanted, Sines::Near(self.angles), chain)
            .map_err(|_| Fault::JointCount)
    }
}
