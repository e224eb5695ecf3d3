//! Non-geometric effects: what a D-H model of rigid links cannot express, and how
//! each one moves the robot.
//!
//! A calibrated robot is its geometric model plus a list of [`Effect`]s. Most
//! effects add a correction `Δq_j` to one joint's reading before the forward
//! kinematics, as the joint's real position differs from what its encoder
//! reports; thermal expansion scales the link lengths instead. With the effects,
//! the measured frame is
//!
//! ```text
//! T = base · A_1(q_1 + Δq_1; L(T)) ⋯ A_M(q_M + Δq_M; L(T)) · tool
//! ```
//!
//! | effect | physics | correction |
//! | --- | --- | --- |
//! | [`Effect::JointCompliance`] | a joint's drive and gearbox twist under the gravity torque they carry, linearly (Hooke) | `Δq_j = c_j τ_j(q, payload)` |
//! | [`Effect::GearTransmission`] | eccentricity and tooth errors of the gears make the output lag or lead periodically with the joint angle | `Δq_j = Σ_{k=1,2} (s_k sin k q_j + c_k cos k q_j)` |
//! | [`Effect::Backlash`] | the lost motion between gear flanks: the output stays on the flank of the last approach | `Δq_j = b_j σ_j`, `σ_j = ±1` the approach direction, `b_j` half the lost motion |
//! | [`Effect::ThermalExpansion`] | the links lengthen with temperature (one coefficient: one material) | `a_i, s_i → a_i, s_i · (1 + κ (T − T_ref))` |
//! | [`Effect::EncoderScale`] | a gear-ratio (encoder scale) error of one joint | `Δq_j = ε_j q_j` |
//!
//! A tilt between nominally parallel axes is geometric: it is Hayati's `β` of the
//! link ([`crate::Link::beta`], [`crate::Param::Beta`]), not an entry here.
//!
//! ## The gravity torque
//! `τ_j = w_j · Σ_{k ≥ j} (r_k − ρ_j) × m_k g` for a revolute joint (N·m) and
//! `w_j · Σ_{k ≥ j} m_k g` for a prismatic one (N), where the sum runs over the
//! links that joint `j` moves and the payload: `m_k` and `r_k` are the mass and
//! centre of mass of link `k` (its `com` in the frame after `A_k`), the payload
//! sits at the tool point, `g` is the model's gravity (default `[0, 0, −9.81]` in
//! the base frame), and `w_j`, `ρ_j` the joint's axis and a point on it
//! ([`crate::LinkAxes`]). A model without masses gets a proxy from its kinematic
//! structure: 1 kg at the origin of each link frame; the identified compliance
//! then absorbs the unknown scale, and only its product with the proxy torque is
//! meaningful.
//!
//! ## Backlash and the approach direction
//! A gear with lost motion `2 b_j` leaves its output on the flank it last
//! approached from, so the joint really is at `p_j = q_j + b_j σ_j`, with `σ_j`
//! the direction of the last move of joint `j`'s command (reading): +1 when it
//! last increased, −1 when it last decreased. A joint that holds (its value
//! exactly unchanged from one row or tick to the next) stays on that flank and
//! keeps its `σ_j`, through any number of standstills: in a single-joint sweep
//! the joints that do not move keep the sign of their last move, not 0. Only
//! before a joint has moved at all (the first row, or a joint that has not
//! changed since) is `σ_j = 0`, the middle of its lost motion. [`Approach`]
//! gives the signs of a stream of rows in this way (rows in measurement order,
//! commands in the order sent), [`approach_sign`] one joint's step of it; the
//! model, the fit and the simulator all read row order through it.
//!
//! Units: SI (rad, m, kg, N·m, °C); compliance in rad/(N·m) (m/N for a prismatic
//! joint), κ in 1/°C.

use heapless::Vec;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

use crate::kinematics::Prepared;
use crate::model::bounded;
use crate::{Chain, JointType, MAX_JOINTS, ModelError, Param, Real, Robot};

/// The most effects a calibration carries.
pub const MAX_EFFECTS: usize = 16;

/// What the effects depend on at one pose, besides the joint readings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Context<T: Real> {
    /// Temperature, °C, if measured.
    pub temperature: Option<T>,
    /// Payload mass at the tool point, kg, if known (0 otherwise).
    pub payload: Option<T>,
    /// The approach direction of each joint (+1, −1, or 0 when unknown), empty
    /// when not known at all: [`Approach`] gives it from row order.
    pub approach: Vec<i8, MAX_JOINTS>,
}

/// One non-geometric effect and its parameters (see the module header).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Effect<T: Real> {
    /// `Δq_j = compliance · τ_j`.
    JointCompliance {
        /// Joint, 0-based.
        joint: usize,
        /// rad/(N·m), or m/N for a prismatic joint.
        compliance: T,
    },
    /// `Δq_j = sin1 sin q + cos1 cos q + sin2 sin 2q + cos2 cos 2q`.
    GearTransmission {
        /// Joint, 0-based.
        joint: usize,
        /// Once-per-revolution amplitudes (sine, cosine), rad.
        first: [T; 2],
        /// Twice-per-revolution amplitudes (sine, cosine), rad.
        second: [T; 2],
    },
    /// `Δq_j = half_lost_motion · σ_j`.
    Backlash {
        /// Joint, 0-based.
        joint: usize,
        /// Half the lost motion, rad (m for a prismatic joint).
        half_lost_motion: T,
    },
    /// Link lengths `a, s` scaled by `1 + coefficient · (T − reference)`.
    ThermalExpansion {
        /// κ, 1/°C.
        coefficient: T,
        /// The temperature at which the lengths are the model's, °C.
        reference: T,
    },
    /// `Δq_j = scale · q_j`.
    EncoderScale {
        /// Joint, 0-based.
        joint: usize,
        /// Relative error of the gear ratio.
        scale: T,
    },
}

impl<T: Real> Effect<T> {
    /// The effect name used in reports and JSON (`docs/file-formats.md` §6).
    pub fn name(&self) -> &'static str {
        match self {
            Self::JointCompliance { .. } => "joint_compliance",
            Self::GearTransmission { .. } => "gear_transmission",
            Self::Backlash { .. } => "backlash",
            Self::ThermalExpansion { .. } => "thermal_expansion",
            Self::EncoderScale { .. } => "encoder_scale",
        }
    }

    /// A thermal expansion's coefficient (1/°C) and reference temperature
    /// (°C); `None` for the other effects.
    pub fn thermal_expansion(&self) -> Option<(T, T)> {
        match self {
            Self::ThermalExpansion {
                coefficient,
                reference,
            } => Some((*coefficient, *reference)),
            _ => None,
        }
    }

    /// The joint a joint effect acts on.
    pub fn joint(&self) -> Option<usize> {
        match *self {
            Self::JointCompliance { joint, .. }
            | Self::GearTransmission { joint, .. }
            | Self::Backlash { joint, .. }
            | Self::EncoderScale { joint, .. } => Some(joint),
            Self::ThermalExpansion { .. } => None,
        }
    }

    /// The number of parameters the effect has (its unknowns in a fit).
    pub fn parameter_count(&self) -> usize {
        match self {
            Self::GearTransmission { .. } => 4,
            _ => 1,
        }
    }

    /// Parameter `i` (see [`Effect::parameter_mut`] for the order).
    pub fn parameter(&self, i: usize) -> Option<T> {
        let mut copy = *self;
        copy.parameter_mut(i).map(|v| *v)
    }

    /// Parameter `i`: the compliance, the four harmonic amplitudes (sin 1, cos 1,
    /// sin 2, cos 2), half the lost motion, κ, or the scale error. The thermal
    /// reference temperature is not a parameter: the fit fixes it.
    pub fn parameter_mut(&mut self, i: usize) -> Option<&mut T> {
        match (self, i) {
            (Self::JointCompliance { compliance, .. }, 0) => Some(compliance),
            (Self::GearTransmission { first, .. }, 0) => Some(&mut first[0]),
            (Self::GearTransmission { first, .. }, 1) => Some(&mut first[1]),
            (Self::GearTransmission { second, .. }, 2) => Some(&mut second[0]),
            (Self::GearTransmission { second, .. }, 3) => Some(&mut second[1]),
            (
                Self::Backlash {
                    half_lost_motion, ..
                },
                0,
            ) => Some(half_lost_motion),
            (Self::ThermalExpansion { coefficient, .. }, 0) => Some(coefficient),
            (Self::EncoderScale { scale, .. }, 0) => Some(scale),
            _ => None,
        }
    }

    /// How parameter `i` enters the joint correction: `∂Δq_j/∂p_i` at reading
    /// `q_j`, gravity torque `tau_j` and approach sign (0 for thermal expansion).
    pub fn joint_sensitivity(&self, i: usize, q_j: T, tau_j: T, ctx: &Context<T>) -> T {
        match (*self, i) {
            (Self::JointCompliance { .. }, _) => tau_j,
            (Self::GearTransmission { .. }, 0) => q_j.sin(),
            (Self::GearTransmission { .. }, 1) => q_j.cos(),
            (Self::GearTransmission { .. }, 2) => (q_j + q_j).sin(),
            (Self::GearTransmission { .. }, _) => (q_j + q_j).cos(),
            (Self::Backlash { joint, .. }, _) => context_sign(ctx, joint),
            (Self::EncoderScale { .. }, _) => q_j,
            (Self::ThermalExpansion { .. }, _) => T::zero(),
        }
    }

    /// The same effect in another scalar type.
    pub fn cast<U: Real>(&self) -> Effect<U> {
        let c = |x: T| U::lit(x.to_f64());
        match *self {
            Self::JointCompliance { joint, compliance } => Effect::JointCompliance {
                joint,
                compliance: c(compliance),
            },
            Self::GearTransmission {
                joint,
                first,
                second,
            } => Effect::GearTransmission {
                joint,
                first: first.map(c),
                second: second.map(c),
            },
            Self::Backlash {
                joint,
                half_lost_motion,
            } => Effect::Backlash {
                joint,
                half_lost_motion: c(half_lost_motion),
            },
            Self::ThermalExpansion {
                coefficient,
                reference,
            } => Effect::ThermalExpansion {
                coefficient: c(coefficient),
                reference: c(reference),
            },
            Self::EncoderScale { joint, scale } => Effect::EncoderScale {
                joint,
                scale: c(scale),
            },
        }
    }
}

/// The joint effects of one joint, summed over the calibration's effects:
/// `Δq_j = compliance · τ_j + first · (sin q_j, cos q_j) + second · (sin 2q_j,
/// cos 2q_j) + scale · q_j + backlash · σ_j` (the table of the module header).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointEffect<T: Real> {
    /// rad/(N·m) (m/N).
    pub compliance: T,
    /// Once-per-revolution gear amplitudes (sine, cosine), rad.
    pub first: [T; 2],
    /// Twice-per-revolution gear amplitudes (sine, cosine), rad.
    pub second: [T; 2],
    /// Encoder-scale error, relative.
    pub scale: T,
    /// Half the lost motion, rad (m).
    pub backlash: T,
}

impl<T: Real> JointEffect<T> {
    /// No effect.
    pub fn none() -> Self {
        let z = T::zero();
        Self {
            compliance: z,
            first: [z, z],
            second: [z, z],
            scale: z,
            backlash: z,
        }
    }

    /// The part of `Δq_j` that varies slowly with the reading: compliance times
    /// the gravity torque `tau`, and the gear harmonics at `q` (the double angle
    /// from the single one: one sine and cosine).
    #[inline]
    pub fn offset(&self, q: T, tau: T) -> T {
        self.compliance * tau + self.harmonics(q)
    }

    /// The gear harmonics at `q`: 0 without amplitudes, else one sine and
    /// cosine (the double angle from the single one).
    #[inline]
    pub fn harmonics(&self, q: T) -> T {
        let z = T::zero();
        if self.first == [z, z] && self.second == [z, z] {
            return z;
        }
        let (s1, c1) = q.sincos();
        let (s2, c2) = ((s1 + s1) * c1, (c1 - s1) * (c1 + s1));
        self.first[0] * s1 + self.first[1] * c1 + self.second[0] * s2 + self.second[1] * c2
    }

    /// `Δq_j` at reading `q` with gravity torque `tau` and approach sign `sigma`
    /// (+1, −1 or 0).
    #[inline]
    pub fn correction(&self, q: T, tau: T, sigma: T) -> T {
        self.offset(q, tau) + self.scale * q + self.backlash * sigma
    }
}

/// The sign of a change: +1, −1, or 0 when there is none (no change, or NaN).
/// A joint's approach direction is this sign only when the joint moved: one that
/// holds keeps its previous direction ([`approach_sign`]).
#[inline]
pub fn direction<T: Real>(d: T) -> T {
    if d > T::zero() {
        T::one()
    } else if d < T::zero() {
        -T::one()
    } else {
        T::zero()
    }
}

/// The factor `Π (1 + κ (T − T_ref))` of thermal expansion at `temperature`
/// over `expansions` (coefficient `κ`, reference `T_ref`, as
/// [`Effect::thermal_expansion`] gives them); 1 without a temperature.
#[inline]
pub fn length_factor<T: Real>(
    expansions: impl IntoIterator<Item = (T, T)>,
    temperature: Option<T>,
) -> T {
    let mut f = T::one();
    if let Some(t) = temperature {
        for (coefficient, reference) in expansions {
            f *= T::one() + coefficient * (t - reference);
        }
    }
    f
}

/// One effect of each kind, of the size a 1 m class arm shows (tenths of a
/// millimetre at the tool): a compliance of joint 2 (2e-6 rad/(N·m)), gear
/// harmonics of joint 3, a backlash of joint 4 (0.15 mrad half the lost motion),
/// aluminium's expansion (2.3e-5 /°C from 20 °C) and a 1e-4 encoder-scale error
/// of joint 1: the controller's benchmark and the tests' calibration with
/// every effect active. Behind the `test-support` feature.
#[cfg(any(test, feature = "test-support"))]
pub fn one_of_each() -> [Effect<f64>; 5] {
    [
        Effect::JointCompliance {
            joint: 1,
            compliance: 2e-6,
        },
        Effect::GearTransmission {
            joint: 2,
            first: [2e-4, -1e-4],
            second: [5e-5, 1e-4],
        },
        Effect::Backlash {
            joint: 3,
            half_lost_motion: 1.5e-4,
        },
        Effect::ThermalExpansion {
            coefficient: 2.3e-5,
            reference: 20.0,
        },
        Effect::EncoderScale {
            joint: 0,
            scale: 1e-4,
        },
    ]
}

/// One joint's approach direction after a change `change` of its value: +1 or
/// −1, the sign of the change, or `previous` (the direction it had) when the
/// change is exactly zero, or NaN: a joint that holds stays on the flank of its
/// last move (see the module header).
#[inline]
pub fn approach_sign<T: Real>(change: T, previous: i8) -> i8 {
    if change > T::zero() {
        1
    } else if change < T::zero() {
        -1
    } else {
        previous
    }
}

/// The approach direction of every joint along a stream of rows (readings in
/// measurement order, or commands in the order sent): each joint's sign is
/// that of its last change, held while the joint holds, and 0 until the joint
/// has first moved (so every sign of the first row is 0). See the module header.
///
/// ```
/// use armcal_shared::effects::Approach;
/// let mut approach = Approach::new();
/// assert_eq!(approach.next(&[0.0, 0.0]), [0, 0]);
/// assert_eq!(approach.next(&[0.1, 0.0]), [1, 0]);
/// assert_eq!(approach.next(&[0.1, -0.2]), [1, -1]);
/// assert_eq!(approach.next(&[0.0, -0.2]), [-1, -1]);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Approach {
    /// The last row's values (as f64: exact for f32 and f64 values).
    last: Vec<f64, MAX_JOINTS>,
    /// Each joint's sign after the last row.
    signs: Vec<i8, MAX_JOINTS>,
}

impl Approach {
    /// No row yet.
    pub const fn new() -> Self {
        Self {
            last: Vec::new(),
            signs: Vec::new(),
        }
    }

    /// The signs at row `q`, which follows the rows already given; `q` becomes
    /// the last row. A joint the previous row did not have starts at 0.
    pub fn next<T: Real>(&mut self, q: &[T]) -> Vec<i8, MAX_JOINTS> {
        let signs: Vec<i8, MAX_JOINTS> = q
            .iter()
            .enumerate()
            .map(|(j, qj)| match (self.last.get(j), self.signs.get(j)) {
                (Some(last), Some(sign)) => approach_sign(qj.to_f64() - *last, *sign),
                _ => 0,
            })
            .collect();
        self.last = q.iter().map(|qj| qj.to_f64()).collect();
        self.signs.clone_from(&signs);
        signs
    }
}

/// `σ_j` of the context as a scalar (0 when unknown).
fn context_sign<T: Real>(ctx: &Context<T>, joint: usize) -> T {
    ctx.approach
        .get(joint)
        .map_or(T::zero(), |s| sign_value(*s))
}

/// An approach direction (−1, 0, +1) as the scalar `σ` of the backlash term.
#[inline]
pub fn sign_value<T: Real>(sign: i8) -> T {
    match sign {
        s if s > 0 => T::one(),
        s if s < 0 => -T::one(),
        _ => T::zero(),
    }
}

/// Why effects cannot be evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum EffectError {
    /// The joint count or the model is unusable.
    Model(ModelError),
    /// An effect names a joint the model does not have.
    NoSuchJoint {
        /// The joint, 0-based.
        joint: usize,
    },
}

impl From<ModelError> for EffectError {
    fn from(e: ModelError) -> Self {
        Self::Model(e)
    }
}

impl core::fmt::Display for EffectError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Model(e) => e.fmt(f),
            Self::NoSuchJoint { joint } => write!(
                f,
                "an effect acts on joint {}, which the model does not have",
                joint + 1
            ),
        }
    }
}

impl core::error::Error for EffectError {}

/// The gravity torque (N·m) or force (N) on every joint at `chain` (see the
/// module header), with `payload` kg at the tool point.
pub fn gravity_torques<T: Real>(
    robot: &Robot<T>,
    chain: &Chain<T>,
    payload: T,
) -> Vec<T, MAX_JOINTS> {
    let masses = Masses::of(robot, &chain.base);
    let mut out: Vec<T, MAX_JOINTS> = chain.axes.iter().map(|_| T::zero()).collect();
    masses.torques(
        payload,
        &chain.point(),
        |j| (chain.axes[j].w, chain.axes[j].rho),
        |j| match &robot.links[j].mass {
            Some(lm) => chain.links[j] * Point3::from(lm.com),
            None => Point3::from(chain.links[j].translation.vector),
        },
        u32::MAX,
        &mut out,
    );
    out
}

/// What the gravity torques need of a model besides its configuration: the
/// joint types, each link's mass (kg; the proxy's 1 kg for a model without
/// masses, 0 for a link without mass in a model with them) and gravity in the
/// measurement frame (m/s²).
#[derive(Clone, Debug, PartialEq)]
pub struct Masses<T: Real> {
    /// The joint types.
    pub joints: Vec<JointType, MAX_JOINTS>,
    /// Each link's mass, kg.
    pub mass: Vec<T, MAX_JOINTS>,
    /// Gravity in the measurement frame, m/s².
    pub gravity: Vector3<T>,
}

impl<T: Real> Masses<T> {
    /// The masses of `robot`, whose base frame is `base`.
    pub fn of(robot: &Robot<T>, base: &nalgebra::IsometryMatrix3<T>) -> Self {
        let g_base = robot
            .gravity
            .unwrap_or_else(|| Vector3::new(T::zero(), T::zero(), T::lit(-9.81)));
        let uses_masses = robot.links.iter().any(|l| l.mass.is_some());
        Self {
            joints: bounded(robot.links.iter().map(|l| l.joint)),
            mass: bounded(robot.links.iter().map(|l| match (uses_masses, &l.mass) {
                (true, Some(lm)) => lm.mass,
                (true, None) => T::zero(),
                (false, _) => T::one(),
            })),
            gravity: base.rotation * g_base,
        }
    }

    /// The gravity torque on every joint into `out`, with `payload` kg at `tool` (the
    /// measured point), joint `j`'s axis line `line(j) = (w_j, ρ_j)` and link
    /// `k`'s centre of mass `centre(k)`: in one pass from the tip, carrying the
    /// mass `M_j = Σ_{k ≥ j} m_k + payload` and its first moment `F_j = Σ_{k ≥ j}
    /// m_k r_k + payload · tool`, as `τ_j = w_j · ((F_j − M_j ρ_j) × g)` for a
    /// revolute joint and `M_j w_j · g` for a prismatic one: the module header's
    /// sums, in O(M) instead of O(M²).
    /// Only the joints whose bit is set in `which` get their torque (the others
    /// keep their value in `out`), and the pass stops at the lowest of them.
    pub fn torques(
        &self,
        payload: T,
        tool: &Point3<T>,
        line: impl Fn(usize) -> (Vector3<T>, Point3<T>),
        centre: impl Fn(usize) -> Point3<T>,
        which: u32,
        out: &mut [T],
    ) {
        let mut total = payload;
        let mut moment = tool.coords * payload;
        let lowest = which.trailing_zeros() as usize;
        for j in (lowest..self.joints.len().min(out.len())).rev() {
            let m = self.mass[j];
            total += m;
            moment += centre(j).coords * m;
            if which & (1 << j) == 0 {
                continue;
            }
            let (w, rho) = line(j);
            out[j] = match self.joints[j] {
                JointType::Revolute => w.dot(&(moment - rho.coords * total).cross(&self.gravity)),
                JointType::Prismatic => w.dot(&self.gravity) * total,
            };
        }
    }
}

/// A geometric model with its effects, ready for evaluation.
#[derive(Clone, Debug)]
pub struct EffectModel<T: Real> {
    /// The geometric (calibrated) model at the reference temperature.
    pub robot: Robot<T>,
    /// The effects.
    pub effects: Vec<Effect<T>, MAX_EFFECTS>,
}

impl<T: Real> EffectModel<T> {
    /// A model with effects; refuses an effect on a joint the robot lacks.
    pub fn new(robot: Robot<T>, effects: &[Effect<T>]) -> Result<Self, EffectError> {
        let mut list = Vec::new();
        for e in effects {
            if let Some(joint) = e.joint().filter(|j| *j >= robot.dof()) {
                return Err(EffectError::NoSuchJoint { joint });
            }
            let _ = list.push(*e);
        }
        Ok(Self {
            robot,
            effects: list,
        })
    }

    /// The factor `1 + κ (T − T_ref)` of thermal expansion at `temperature` (the
    /// product over thermal effects; 1 without one or without a temperature).
    pub fn length_factor(&self, temperature: Option<T>) -> T {
        let expansions = self.effects.iter().filter_map(Effect::thermal_expansion);
        length_factor(expansions, temperature)
    }

    /// The geometric model at the context's temperature (lengths scaled by
    /// thermal expansion, when there is such an effect and a temperature).
    pub fn robot_at(&self, ctx: &Context<T>) -> Robot<T> {
        let mut robot = self.robot.clone();
        let f = self.length_factor(ctx.temperature);
        if f != T::one() {
            for l in robot.links.iter_mut() {
                l.a *= f;
                l.s *= f;
            }
        }
        robot
    }

    /// True if an effect corrects a joint (every effect but thermal expansion).
    pub fn corrects_joints(&self) -> bool {
        self.effects
            .iter()
            .any(|e| !matches!(e, Effect::ThermalExpansion { .. }))
    }

    /// True if an effect needs the gravity torques (joint compliance).
    pub fn needs_torque(&self) -> bool {
        self.effects
            .iter()
            .any(|e| matches!(e, Effect::JointCompliance { .. }))
    }

    /// Each joint's effects summed ([`JointEffect`]); effects on joints beyond
    /// `dof` are left out.
    pub fn joint_effects(&self, dof: usize) -> Vec<JointEffect<T>, MAX_JOINTS> {
        let mut out: Vec<JointEffect<T>, MAX_JOINTS> =
            bounded((0..dof).map(|_| JointEffect::none()));
        for e in &self.effects {
            let Some(j) = e.joint().filter(|j| *j < out.len()) else {
                continue;
            };
            let je = &mut out[j];
            match *e {
                Effect::JointCompliance { compliance, .. } => je.compliance += compliance,
                Effect::GearTransmission { first, second, .. } => {
                    for k in 0..2 {
                        je.first[k] += first[k];
                        je.second[k] += second[k];
                    }
                }
                Effect::Backlash {
                    half_lost_motion, ..
                } => je.backlash += half_lost_motion,
                Effect::EncoderScale { scale, .. } => je.scale += scale,
                Effect::ThermalExpansion { .. } => {}
            }
        }
        out
    }

    /// The joint values the robot really takes at readings `q`: `q + Δq`.
    pub fn joint_values(
        &self,
        robot: &Prepared<T>,
        geometric: &Robot<T>,
        q: &[T],
        ctx: &Context<T>,
    ) -> Result<Vec<T, MAX_JOINTS>, EffectError> {
        if !self.corrects_joints() {
            return Ok(q.iter().copied().collect());
        }
        let tau: Vec<T, MAX_JOINTS> = if self.needs_torque() {
            let chain = robot.chain(q)?;
            gravity_torques(geometric, &chain, ctx.payload.unwrap_or(T::zero()))
        } else {
            Vec::new()
        };
        Ok(self.joint_values_at(q, &tau, ctx))
    }

    /// [`Self::joint_values`] with the gravity torques `tau` at `q` already
    /// known (N·m per joint; an empty slice when no effect needs them).
    pub fn joint_values_at(&self, q: &[T], tau: &[T], ctx: &Context<T>) -> Vec<T, MAX_JOINTS> {
        let effects = self.joint_effects(q.len());
        q.iter()
            .zip(&effects)
            .enumerate()
            .map(|(j, (&qj, e))| {
                let tau = tau.get(j).copied().unwrap_or(T::zero());
                qj + e.correction(qj, tau, context_sign(ctx, j))
            })
            .collect()
    }

    /// The measured frame at readings `q` in context `ctx`.
    pub fn forward(
        &self,
        q: &[T],
        ctx: &Context<T>,
    ) -> Result<nalgebra::IsometryMatrix3<T>, EffectError> {
        let robot = self.robot_at(ctx);
        let prepared = robot.prepare();
        let qe = self.joint_values(&prepared, &robot, q, ctx)?;
        Ok(prepared.forward(&qe)?)
    }
}

/// The joint parameter a joint's reading moves (θ revolute, s prismatic), whose
/// column is the effect of a joint correction.
pub fn joint_param(robot: &Robot<impl Real>, joint: usize) -> Param {
    match robot.links[joint].joint {
        JointType::Revolute => Param::Theta(joint),
        JointType::Prismatic => Param::S(joint),
    }
}
