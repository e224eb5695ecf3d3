//! A stream of commands: the one owner of what a tick carries to the next.
//!
//! The controller, `armcal compensate` and the link all correct commands in
//! order through a [`Stream`]: it keeps the previous tick as sent (for each
//! joint's approach direction, [`super::inversion`], and the warm start,
//! [`super::start`]) and the workspace (the reused factors and
//! the correction's last change). The answer for a command depends on the
//! command, its conditions and the approach directions only; the rest is speed.
//!
//! [`Pacing`] says what the rows are:
//! - [`Pacing::Program`]: a robot program's target points, unrelated to each
//!   other. Each is solved alone from its own command (a cold start), to
//!   convergence; the row order gives the approach directions only.
//! - [`Pacing::Servo`]: servo ticks of a smooth motion. Each starts warm from
//!   the previous tick's correction, and the correction's change from the
//!   previous tick's sent correction is bounded per tick
//!   ([`Limits::max_change_angle`](super::Limits::max_change_angle),
//!   [`Limits::max_change_length`](super::Limits::max_change_length)): a
//!   safety limit that clips a tick ([`Fault::Limited`]) without changing the
//!   answer the next ticks converge to.
//!
//! After a command that could not be computed ([`Fault::NonFinite`],
//! [`Fault::JointCount`]) the next one is a first tick: no approach direction
//! is known and the search starts cold.

use super::start::Start;
use super::{
    Compensator, Conditions, Correction, Fault, Previous, Workspace, clamp, is_finite, listed,
};
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

/// The state of a stream of commands: see [the module](self).
#[derive(Clone, Debug)]
pub struct Stream<T: Real> {
    pacing: Pacing,
    previous: Previous<T>,
    work: Workspace<T>,
}

impl<T: Real> Stream<T> {
    /// A stream with no previous tick.
    pub fn new(pacing: Pacing) -> Self {
        Self {
            pacing,
            previous: Previous {
                q_cmd: [T::zero(); MAX_JOINTS],
                sent: [T::zero(); MAX_JOINTS],
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
        let previous = (last.joints == n && q_cmd.len() == n).then_some(last);
        let start = match self.pacing {
            Pacing::Program => Start::Cold,
            Pacing::Servo => Start::Warm,
        };
        let answer = match compensator.compute(q_cmd, previous, start, conditions, &mut self.work) {
            Ok(answer) => answer,
            Err(fault) => {
                self.previous.joints = 0;
                return Correction::unchanged(q_cmd, fault);
            }
        };
        let known = previous.is_some();
        let servo = self.pacing == Pacing::Servo && known;
        let extrapolates = answer.extrapolates && known;
        let Workspace { rate, tick, .. } = &mut self.work;
        rate.known = extrapolates;
        // One pass over the joints: the size bound, the change bound (servo
        // ticks), the correction's change for the next predictor, each
        // joint's approach direction, the outputs' check and the tick kept for
        // the next. Every slice is cut to the joints' count (no bound checks).
        let last = &mut self.previous;
        let (q_cmd, q, p) = (&q_cmd[..n], &mut tick.x[..n], &tick.p[..n]);
        let (last_q_cmd, last_sent) = (&mut last.q_cmd[..n], &mut last.sent[..n]);
        let (last_p, last_approach) = (&mut last.p[..n], &mut last.approach[..n]);
        let rate = &mut rate.change[..n];
        let (mut limited, mut outputs) = (false, answer.residual);
        for (m, joint) in compensator.joints.iter().enumerate() {
            let size = joint.max_correction;
            if let Some(bounded) = clamp(q[m] - q_cmd[m], -size, size) {
                limited = true;
                q[m] = q_cmd[m] + bounded;
            }
            if servo {
                // The change interval about the previous tick's sent
                // correction, then the size interval: where they do not
                // meet, the size bound's end nearest the change bound.
                let before = last_sent[m] - last_q_cmd[m];
                let change = joint.max_change;
                if let Some(changed) = clamp(q[m] - q_cmd[m], before - change, before + change) {
                    let bounded = clamp(changed, -size, size).unwrap_or(changed);
                    limited = true;
                    q[m] = q_cmd[m] + bounded;
                }
            }
            if extrapolates {
                rate[m] = (p[m] - q_cmd[m]) - (last_p[m] - last_q_cmd[m]);
            }
            // Only a joint with backlash reads its direction.
            if joint.backlash {
                last_approach[m] = if known {
                    approach_sign(q[m] - last_sent[m], last_approach[m])
                } else {
                    0
                };
            }
            outputs += q[m] + p[m];
            last_q_cmd[m] = q_cmd[m];
            last_sent[m] = q[m];
            last_p[m] = p[m];
        }
        if !is_finite(outputs) {
            self.previous.joints = 0;
            return Correction::unchanged(q_cmd, Fault::NonFinite);
        }
        self.previous.joints = n;
        let fault = if !answer.converged {
            Some(Fault::NotConverged)
        } else if limited {
            Some(Fault::Limited)
        } else {
            None
        };
        Correction {
            q: listed(&tick.x, n),
            p: listed(&tick.p, n),
            fault,
            iterations: answer.iterations,
            residual: answer.residual,
        }
    }
}
