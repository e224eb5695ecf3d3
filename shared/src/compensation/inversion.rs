//! The joint effects' inversion: the commands `q` that put the joints at the
//! positions `p` the geometric problem found.
//!
//! A calibration from `armcal diagnose` adds effects ([`crate::effects`]) to the
//! geometry: the calibrated robot at commands (= joint readings) `q`, in the
//! tick's conditions (temperature `T`, payload `m`) and with approach directions
//! `σ`, is
//!
//! ```text
//! T_cal(q; T, m, σ) = G_T(p),   p_j = q_j + Δq_j(q; m, σ_j)
//! Δq_j = c_j τ_j(q, m) + Σ_k (s_jk sin k q_j + c_jk cos k q_j) + ε_j q_j + b_j σ_j
//! ```
//!
//! with `G_T` the calibrated geometry whose lengths `a`, `s` are scaled by `1 +
//! κ (T − T_ref)` (thermal expansion, applied inside each chain), `τ_j` the
//! gravity torque at the readings (N·m, or N for a prismatic joint), `c_j` the
//! compliance (rad/(N·m)), the gear harmonics (rad), `ε_j` the encoder-scale
//! error and `b_j` half the lost motion (rad or m). The commands are `q_j = (p_j
//! − o_j(q) − b_j σ_j) / (1 + ε_j)`, with `o_j` the compliance and gear terms at
//! the current `q` (the first time at the search's start, from the chain of the
//! geometric step; after that one chain for the gravity torques), repeated until
//! no joint changes by more than `tol` = tolerance / length scale, at most
//! [`Limits::max_iterations`](super::Limits::max_iterations) times. The encoder
//! scale is inverted exactly. The offsets change by at most `L` times a change
//! of `q` (the gravity torque by at most `2 R |g| M_j` per radian of a revolute
//! joint, `R` the robot's reach and `M_j` the mass it carries, and by `|g| M_j`
//! per metre of a prismatic one; a harmonic `s sin kq` by `k|s|`; each over `1 +
//! ε_j`), so the map is a contraction and the fixed point lies within `L / (1 −
//! L)` of the last change: the repetition stops as soon as that is below `tol`.
//! `L` is about 10⁻³ for a 1 m arm: on a smooth motion one pass suffices.
//!
//! **Approach direction.** `σ_j` is the direction of the last move of the
//! command *sent* to joint `j`: `sign(q_j − q_prev_j)`, and, when the joint does
//! not move, the direction it had (a gear stays on the flank it last approached
//! from); 0 only for a joint that has not moved since the stream began. This is
//! [`crate::effects::approach_sign`], the convention of the rows the calibration
//! was fitted to, so the tick and the fit agree. For a joint with backlash, with `d_j = (p_j − o_j)/(1 + ε_j) −
//! q_prev_j` the move that reaches `p_j` without lost motion, `σ_j = sign(d_j)`
//! and `q_j = q_prev_j + d_j − b_j σ_j / (1 + ε_j)`, consistent when that move,
//! as rounded, still has the sign `σ_j` (a joint moving on, or reversing by more
//! than its lost motion). Otherwise the target lies within the lost motion (a
//! standstill, or the first ticks of a reversal): the joint is held at
//! `q_prev_j` and keeps its flank (`σ_j` unchanged); at a standstill that
//! reaches the target, within a reversal the pose is missed by at most the lost
//! motion at the joint's lever and the correction is flagged
//! [`Fault::NotConverged`] with that residual.

use super::{Compensator, Fault, Parts, Problem, larger};
use crate::effects::{JointEffect, Masses, approach_sign, direction, sign_value};
use crate::servo_chain::ServoChain;
use crate::{JointType, Real, Robot};

/// The context of the inversion: the commands sent at the previous tick and
/// each joint's approach direction after them (−1, 0 or +1).
pub(crate) type Approach<'a, T> = Option<(&'a [T], &'a [i8])>;

/// How [`Compensator::invert`] left the commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Inverted {
    /// Every joint goes to its position `p` (to the tolerance).
    Reached,
    /// A joint is held within its lost motion: the joints go elsewhere
    /// ([`Compensator::reached`] tells where).
    Held,
}

impl<T: Real> Compensator<T> {
    /// The commands `q` with `q + Δq(q) = p` for `problem`'s geometry and
    /// payload (see the module header), from the start in `q`, whose gravity
    /// torques `tau` are (zero without a compliance; on return, those of the
    /// last evaluation): whether a joint was held within its lost motion
    /// ([`Inverted`]), or [`Fault::NonFinite`] if a value was not finite.
    /// `chain` is a work buffer.
    pub(crate) fn invert(
        &self,
        problem: &Problem<'_, T>,
        q: &mut [T],
        p: &[T],
        tau: &mut [T],
        approach: Approach<'_, T>,
        chain: &mut ServoChain<T>,
    ) -> Result<Inverted, Fault> {
        let (geometry, payload) = (problem.geometry, problem.payload);
        let tolerance = self.limits.tolerance / self.limits.length_scale;
        let mut inverted = Inverted::Reached;
        let needs_torque = self.compliant != 0;
        for iteration in 0..self.limits.max_iterations.max(1) {
            if needs_torque && iteration > 0 {
                geometry
                    .chain(q, Parts::LinesAndCentres, chain)
                    .map_err(|_| Fault::NonFinite)?;
                self.torques(chain, payload, tau);
            }
            let mut change = T::zero();
            inverted = Inverted::Reached;
            let joints = self.joints.iter().zip(q.iter_mut()).zip(p).zip(&*tau);
            for (m, (((joint, qm), pm), tm)) in joints.enumerate() {
                let e = &joint.effect;
                let stretch = T::one() + e.scale;
                let mut next = (*pm - offset(e, joint.harmonic, *qm, *tm)) / stretch;
                if let Some((sent, _)) = approach.filter(|_| joint.backlash) {
                    let lost = e.backlash / stretch;
                    let sigma = direction(next - sent[m]);
                    // Consistent when the command, lost motion taken off,
                    // still moves the joint the way σ says (tested on the
                    // rounded command: it is what is sent).
                    let moved = next - lost * sigma;
                    if sigma != T::zero() && direction(moved - sent[m]) == sigma {
                        next = moved;
                    } else {
                        // Within the lost motion: held on its flank.
                        next = sent[m];
                        inverted = Inverted::Held;
                    }
                }
                change = larger(change, (next - *qm).abs());
                *qm = next;
            }
            if !change.is_finite() {
                return Err(Fault::NonFinite);
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
        Ok(inverted)
    }

    /// Where the joints really go at commands `q` with gravity torques `tau`:
    /// `q + Δq(q)`, with each joint's approach direction after the move from
    /// the previous tick's commands, into `out`.
    pub(crate) fn reached(&self, q: &[T], tau: &[T], approach: Approach<'_, T>, out: &mut [T]) {
        for (m, joint) in self.joints.iter().enumerate().take(out.len()) {
            let sigma = approach.map_or(T::zero(), |(sent, signs)| {
                sign_value(approach_sign(q[m] - sent[m], signs[m]))
            });
            out[m] = q[m] + joint.effect.correction(q[m], tau[m], sigma);
        }
    }

    /// The gravity torques at `chain` (with its lines and centres) into `tau`.
    pub(crate) fn torques(&self, chain: &ServoChain<T>, payload: T, tau: &mut [T]) {
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
    /// `payload` kg and the lengths times `factor`, near `q` (see the module
    /// header); the compliance's and the harmonics' shares are each the
    /// largest joint's ([`Slopes::most`]): a bound on the largest joint's sum
    /// in O(1).
    fn slope(&self, payload: T, factor: T, q: &[T]) -> T {
        let s = &self.slopes;
        let mut reach = s.reach * larger(factor, T::one());
        if s.prismatic > T::zero() {
            for (m, joint) in self.joints.iter().enumerate() {
                if joint.kind == JointType::Prismatic {
                    reach += q[m].abs() + self.limits.max_correction_length;
                }
            }
        }
        let levers = T::lit(2.0) * reach * s.revolute + s.prismatic;
        let (links, per_payload, gear) = s.most;
        (links + per_payload * payload.abs()) * levers + gear
    }
}

/// [`JointEffect::offset`], the harmonics skipped on a joint without them.
#[inline]
fn offset<T: Real>(e: &JointEffect<T>, harmonic: bool, q: T, tau: T) -> T {
    let harmonics = if harmonic { e.harmonics(q) } else { T::zero() };
    e.compliance * tau + harmonics
}

/// What bounds the slope of the effects' joint offsets `o_j(q)` (compliance
/// times gravity torque, gear harmonics), for the stopping rule of the
/// inversion (see the module header).
#[derive(Clone, Debug)]
pub(crate) struct Slopes<T: Real> {
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
    pub(crate) fn of(robot: &Robot<T>, effects: &[JointEffect<T>], masses: &Masses<T>) -> Self {
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
