//! A stream of commands: the one owner of what a tick carries to the next.
//!
//! The controller, `armcal compensate` and the link all correct commands in
//! order through a [`Stream`]: it keeps the previous tick as sent (for each
//! joint's approach direction, [`super::inversion`]), the previous answer (the
//! warm start, [`super::start`]) and the [`Workspace`] (the reused factors and
//! the correction's last change). The answer for a command depends on the
//! command, its conditions and the approach directions only; the rest is speed.
//!
//! [`Pacing`] says what the rows are:
//! - [`Pacing::Program`]: a robot program's target points, unrelated to each
//!   other. Each is solved alone from its own command (a cold start), to
//!   convergence; the row order gives the approach directions only.
//! - [`Pacing::Servo`]: servo ticks of a smooth motion. Each starts warm from
//!   the previous answer, and the correction's change from the previous tick's
//!   sent correction is bounded per tick ([`Limits::max_change_angle`](
//!   super::Limits::max_change_angle), [`Limits::max_change_length`](
//!   super::Limits::max_change_length)): a safety limit that clips a tick
//!   ([`Fault::Limited`]) without changing the answer the next ticks start from
//!   and converge to.
//!
//! After a command that could not be computed ([`Fault::NonFinite`],
//! [`Fault::JointCount`]) the next one is a first tick: no approach direction
//! is known and the search starts cold.

use super::start::Start;
use super::{Compensator, Conditions, Correction, Fault, Joints, Previous, Workspace};
use crate::effects::approach_sign;
use crate::{MAX_JOINTS, Real};

/// What the rows of a stream are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pacing {
    /// A robot program's points: each solved alone, no change bound.
    Program,
    /// Servo ticks: warm starts and the per-tick change bound.
    Servo,
}

/// The previous tick: vectors over the joints.
#[derive(Clone, Debug)]
struct Sent<T: Real> {
    /// The nominal commands.
    q_cmd: Joints<T>,
    /// The commands sent.
    sent: Joints<T>,
    /// The answer for the commands (before the change bound).
    q: Joints<T>,
    /// The joint positions they aimed at.
    p: Joints<T>,
    /// Each joint's approach direction after it: −1, 0 (never moved) or +1.
    approach: [i8; MAX_JOINTS],
    /// The number of joints; 0 before the first tick.
    joints: usize,
}

/// The state of a stream of commands: see [the module](self).
#[derive(Clone, Debug)]
pub struct Stream<T: Real> {
    pacing: Pacing,
    previous: Sent<T>,
    work: Workspace<T>,
}

impl<T: Real> Stream<T> {
    /// A stream with no previous tick.
    pub fn new(pacing: Pacing) -> Self {
        Self {
            pacing,
            previous: Sent {
                q_cmd: [T::zero(); MAX_JOINTS],
                sent: [T::zero(); MAX_JOINTS],
                q: [T::zero(); MAX_JOINTS],
                p: [T::zero(); MAX_JOINTS],
                approach: [0; MAX_JOINTS],
                joints: 0,
            },
            work: Workspace::new(),
        }
    }

    /// The pacing.
    pub fn pacing(&self) -> Pacing {
        self.pacing
    }

    /// Forgets the previous tick and the workspace: the next command is a
    /// first tick (after a new calibration is loaded).
    pub fn reset(&mut self) {
        self.previous.joints = 0;
        self.work = Workspace::new();
    }

    /// The corrected commands for `q_cmd` in `conditions`, after the commands
    /// this stream corrected before (see [the module](self)).
    pub fn tick(
        &mut self,
        compensator: &Compensator<T>,
        q_cmd: &[T],
        conditions: &Conditions<T>,
    ) -> Correction<T> {
        let n = compensator.dof();
        let last = &self.previous;
        let previous = (last.joints == n && q_cmd.len() == n).then_some(Previous {
            q_cmd: &last.q_cmd[..n],
            sent: &last.sent[..n],
            q: &last.q[..n],
            p: &last.p[..n],
            approach: &last.approach[..n],
        });
        let start = match self.pacing {
            Pacing::Program => Start::Cold,
            Pacing::Servo => Start::Warm,
        };
        let mut c = compensator.compute(q_cmd, previous, start, conditions, &mut self.work);
        if matches!(c.fault, Some(Fault::NonFinite | Fault::JointCount)) {
            self.previous.joints = 0;
            return c;
        }
        let mut answer = [T::zero(); MAX_JOINTS];
        answer[..n].copy_from_slice(&c.q);
        if let (Pacing::Servo, Some(prev)) = (self.pacing, previous) {
            // The change bound, about the previous tick's sent correction.
            let mut limited = false;
            for (m, joint) in compensator.joints.iter().enumerate() {
                let last = prev.sent[m] - prev.q_cmd[m];
                let correction = c.q[m] - q_cmd[m];
                let clipped = correction
                    .max(last - joint.max_change)
                    .min(last + joint.max_change)
                    .max(-joint.max_correction)
                    .min(joint.max_correction);
                if clipped != correction {
                    limited = true;
                    c.q[m] = q_cmd[m] + clipped;
                }
            }
            if limited {
                c.fault = c.fault.or(Some(Fault::Limited));
            }
        }
        let mut approach = [0; MAX_JOINTS];
        if let Some(prev) = previous {
            for (m, a) in approach.iter_mut().enumerate().take(n) {
                *a = approach_sign(c.q[m] - prev.sent[m], prev.approach[m]);
            }
        }
        let last = &mut self.previous;
        last.approach[..n].copy_from_slice(&approach[..n]);
        last.q[..n].copy_from_slice(&answer[..n]);
        last.q_cmd[..n].copy_from_slice(q_cmd);
        last.sent[..n].copy_from_slice(&c.q);
        last.p[..n].copy_from_slice(&c.p);
        last.joints = n;
        c
    }
}
