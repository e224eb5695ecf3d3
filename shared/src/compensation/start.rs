//! Where a tick's search starts (a speed device only: the answer is the same
//! from either start, to within the tolerance; see [the module](super)).
//!
//! - [`Start::Cold`]: from `q_cmd`; the first step is the first-order one, `J⁺ e`.
//! - [`Start::Warm`]: from the previous tick's correction applied to this
//!   command, `x = q_cmd + (q_prev − q_cmd_prev)` with joint effects (the
//!   estimate of the commands, where the gravity torques are evaluated) and `x =
//!   q_cmd + (p_prev − q_cmd_prev)` without (the estimate of the joint
//!   positions), when the previous tick's solution `p_prev − q_cmd_prev` is
//!   within the size bound (a search that found a root beyond it, clipped,
//!   has left the command's own: the next starts cold). The first
//!   step's predictor `δ₀` is the previous tick's step from the commands to the
//!   joint positions, `p_prev − q_prev` (the joint effects' offsets; zero
//!   without effects), plus the correction's last change (the
//!   rate in the stream's workspace, after two warm ticks that converged):
//!   the correction extrapolated linearly, which on a smooth motion leaves a
//!   residual of about the tolerance, so the factors of a recent tick solve the
//!   step. `q_prev` is the command sent: after a tick that the change bound
//!   clipped, the start is off by the clip and the search corrects it (a start
//!   changes the time to the answer, not the answer).

use super::{Compensator, Previous, Rate, Tick};
use crate::Real;

/// How a tick's search starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// From the nominal command, with the first-order step.
    Cold,
    /// From the previous tick's correction, with the predicted step.
    Warm,
}

impl<T: Real> Compensator<T> {
    /// Writes the start into `tick.x` and, for a warm start, the predictor into
    /// `tick.steps.first`; returns the start taken (cold when there is no
    /// previous tick or its solution's correction is beyond the size bound).
    pub(crate) fn start(
        &self,
        q_cmd: &[T],
        previous: Option<&Previous<T>>,
        wanted: Start,
        rate: &Rate<T>,
        tick: &mut Tick<T>,
    ) -> Start {
        let x = &mut tick.x;
        if let (Start::Warm, Some(prev)) = (wanted, previous) {
            // Every slice cut to the joints' count: no bound checks below.
            let n = self.joints.len();
            let from = if self.corrects_joints {
                &prev.sent
            } else {
                &prev.p
            };
            let (from, q_cmd_prev, p_prev) = (&from[..n], &prev.q_cmd[..n], &prev.p[..n]);
            let (x, q_cmd, predictor) = (&mut x[..n], &q_cmd[..n], &mut tick.steps.first[..n]);
            let mut within = true;
            for (m, joint) in self.joints.iter().enumerate() {
                let correction = from[m] - q_cmd_prev[m];
                x[m] = q_cmd[m] + correction;
                predictor[m] = p_prev[m] - from[m];
                // The previous solution's own correction, before any bound.
                within &= (correction + predictor[m]).abs() <= joint.max_correction;
            }
            if rate.known {
                let predicted = predictor.iter_mut().zip(&rate.change);
                predicted.for_each(|(d, r)| *d += *r);
            }
            if within {
                return Start::Warm;
            }
        }
        x[..q_cmd.len()].copy_from_slice(q_cmd);
        Start::Cold
    }
}
