//! The geometric problem: the joint positions `p` where the calibrated geometry
//! reaches the target, by eq. 4.9 repeated from the search's start
//! ([`super::start`]).
//!
//! Each iteration takes the step of [`super::step_bound`] from the predictor
//! (the predicted step on the first iteration of a warm tick, else the
//! first-order step), solved with the stale factors first when the previous
//! tick converged, then with fresh ones ([`super::factors`]). A step whose
//! bound on the residual after it is below the tolerance is taken without
//! evaluating the chain there. Otherwise a step is taken only if it lowers the
//! residual: the second-order step, else the first-order one (scaled into the
//! trust region: no joint moves by more than its correction bound), each halved
//! up to three times; near a singularity the linearisation overshoots, and the
//! best point found is kept. The cost is bounded by
//! [`Limits::max_iterations`](super::Limits::max_iterations): each iteration is
//! one to eight chains of the calibrated model and at most one `L D Lᵀ`
//! factorisation; no allocation.
//!
//! Where joints remain beyond the task's rows (a 6-axis arm in position, a
//! 7-axis arm in full pose: `redundant` below) every solve is for the whole
//! correction from `q_cmd`
//! (`J⁺ (rhs + J c) − c`, `c` the correction at the point of linearisation):
//! the least correction that reaches the target, from whichever start.

use super::factors::{Factors, Freshness, apply};
use super::start::Start;
use super::step_bound::Bounded;
use super::{Compensator, Fault, Joints, Parts, Problem, Task, Tick};
use crate::servo_chain::ServoChain;
use crate::{JointType, MAX_JOINTS, Real};

/// The work arrays of the geometric problem.
#[derive(Clone, Debug)]
pub(crate) struct Steps<T: Real> {
    /// The first-order step (or the predictor).
    pub first: Joints<T>,
    /// The second-order step.
    pub second: Joints<T>,
    /// A trial point of the line search.
    pub trial: Joints<T>,
    /// The correction at the point of linearisation (redundant arms).
    pub offset: Joints<T>,
    /// The columns of `J`, one per joint.
    pub jac: [[T; 6]; MAX_JOINTS],
}

impl<T: Real> Steps<T> {
    pub fn new() -> Self {
        let zeros = [T::zero(); MAX_JOINTS];
        Self {
            first: zeros,
            second: zeros,
            trial: zeros,
            offset: zeros,
            jac: [[T::zero(); 6]; MAX_JOINTS],
        }
    }
}

/// The search's point: the start `x` until the first step is taken, then
/// `p = x + δ` and the steps after (no copy of the start).
struct Point<'a, T: Real> {
    x: &'a [T],
    p: &'a mut [T],
    at_start: bool,
}

impl<T: Real> Point<'_, T> {
    /// The point now.
    #[inline(always)]
    fn current(&self) -> &[T] {
        if self.at_start { self.x } else { self.p }
    }

    /// Takes the step `d`.
    #[inline(always)]
    fn advance(&mut self, d: &[T]) {
        if self.at_start {
            for ((pm, xm), dm) in self.p.iter_mut().zip(self.x).zip(d) {
                *pm = *xm + *dm;
            }
            self.at_start = false;
        } else {
            for (pm, dm) in self.p.iter_mut().zip(d) {
                *pm += *dm;
            }
        }
    }

    /// Leaves the point in `p`.
    fn finish(self) {
        if self.at_start {
            self.p.copy_from_slice(self.x);
        }
    }
}

/// The linearisation at the search's point: the chain there (for its joint
/// lines), the columns of `J`, the factors of the step's system and `reach`,
/// the bound on the levers (m) that [`Compensator::jacobian`] returns.
struct Linearisation<'a, T: Real> {
    chain: &'a ServoChain<T>,
    jac: &'a [[T; 6]],
    factors: &'a Factors<T>,
    reach: T,
}

/// The line search's candidates: the second-order and the first-order step,
/// tried in that order and halved in place, and the trial point's buffer.
struct Candidates<'s, T: Real> {
    steps: [&'s mut [T]; 2],
    trial: &'s mut [T],
}

/// What a search found: in `p` of the [`Tick`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Solved<T: Real> {
    /// Iterations run.
    pub iterations: usize,
    /// The squared residual, or the square of the bound on it.
    pub residual2: T,
    /// The bound on the residual, when the last step was taken on it.
    pub bound: Option<T>,
    /// Whether the least correction settled (a step no longer moved the
    /// joints); always for a task without joints beyond its rows.
    pub settled: bool,
}

impl<T: Real> Compensator<T> {
    /// One search for `problem` from the start in `tick.x` (written by
    /// [`Self::start`]): the chain there serves the geometric step (joint
    /// lines, measured frame) and the gravity torques of the inversion
    /// (centres of mass, into `tick.tau`); the joint positions found go into
    /// `tick.p`.
    pub(crate) fn search(
        &self,
        problem: &Problem<'_, T>,
        start: Start,
        factors: &mut Factors<T>,
        tick: &mut Tick<T>,
    ) -> Result<Solved<T>, Fault> {
        let n = self.dof();
        let needs_torque = self.compliant != 0;
        let parts = if needs_torque {
            Parts::LinesAndCentres
        } else {
            Parts::Lines
        };
        let (geometry, payload) = (problem.geometry, problem.payload);
        geometry.chain(&tick.x[..n], parts, &mut tick.chain)?;
        if needs_torque {
            self.torques(&tick.chain, payload, &mut tick.tau[..n]);
        } else {
            tick.tau[..n].iter_mut().for_each(|t| *t = T::zero());
        }
        let solved = self.solve(problem, start, factors, tick);
        // Factors of a search that converged serve the next tick.
        factors.freshness = match &solved {
            Ok(s) if s.residual2 <= self.limits.tolerance * self.limits.tolerance => {
                Freshness::Stale
            }
            _ => Freshness::None,
        };
        solved
    }

    /// The geometric problem from `tick.x`, with the chain there in
    /// `tick.chain` (see the module header).
    fn solve(
        &self,
        problem: &Problem<'_, T>,
        start: Start,
        factors: &mut Factors<T>,
        tick: &mut Tick<T>,
    ) -> Result<Solved<T>, Fault> {
        let n = self.dof();
        let (geometry, target, q_cmd) = (problem.geometry, problem.target, problem.q_cmd);
        let Tick {
            chain, x, p, steps, ..
        } = tick;
        let Steps {
            first,
            second,
            trial,
            offset,
            jac,
        } = steps;
        let (first, second, trial, jac) = (
            &mut first[..n],
            &mut second[..n],
            &mut trial[..n],
            &mut jac[..n],
        );
        let mut point = Point {
            x: &x[..n],
            p: &mut p[..n],
            at_start: true,
        };
        let tolerance = self.limits.tolerance;
        let mut predicted = start == Start::Warm;
        let mut residual = self.residual(target, &chain.end);
        let mut iterations = 0;
        // Where joints remain beyond the task's rows, the least correction is
        // reached when a step no longer moves the joints (the task's residual
        // says nothing of the null space): until then the search goes on.
        let mut settling = self.redundant;
        while (residual.1 > tolerance * tolerance || settling)
            && iterations < self.limits.max_iterations
        {
            iterations += 1;
            let (reach, mut r) = if predicted {
                self.jacobian_predicted(chain, jac, &residual.0, first)
            } else {
                (self.jacobian(chain, jac), [T::zero(); 6])
            };
            // Stale factors only in the first iteration of a warm tick:
            // otherwise the configuration has moved by more than a tick's motion.
            let mut fresh =
                !(predicted && iterations == 1 && factors.freshness == Freshness::Stale);
            let bound = loop {
                if fresh {
                    factors
                        .factor(jac, self.damping2(), self.rotation_damping2)
                        .ok_or(Fault::NonFinite)?;
                }
                if !predicted {
                    // δ₀ = J⁺ e with fresh factors, which leave exactly `D y`.
                    let c = self.offset(&mut offset[..n], &point, q_cmd, None);
                    let y = self
                        .pseudo_solve(jac, factors, &residual.0, c, first)
                        .ok_or(Fault::NonFinite)?;
                    r = self.predicted(chain, jac, self.leftover(y), first);
                }
                let c = self.offset(&mut offset[..n], &point, q_cmd, Some(first));
                let at = Linearisation {
                    chain,
                    jac,
                    factors,
                    reach,
                };
                match self.step(&at, &residual.0, first, &r, c, second) {
                    Some(Bounded {
                        bound: Some(bound),
                        whole: true,
                    }) if bound <= tolerance => break Some(bound),
                    None if fresh => return Err(Fault::NonFinite),
                    _ if fresh => break None,
                    _ => fresh = true,
                }
            };
            if let Some(bound) = bound {
                // The residual after the step is bounded below the tolerance:
                // taken without evaluating the chain there, unless the null
                // space is still settling.
                point.advance(second);
                settling = self.redundant && !self.settled(second);
                if !settling {
                    return Ok(Solved {
                        iterations,
                        residual2: bound * bound,
                        bound: Some(bound),
                        settled: true,
                    });
                }
                geometry.chain(point.current(), Parts::Lines, chain)?;
                residual = self.residual(target, &chain.end);
                predicted = false;
                continue;
            }
            // The fallback's first candidate after the step: the first-order
            // step (the loop above left fresh factors).
            if predicted {
                predicted = false;
                let c = self.offset(&mut offset[..n], &point, q_cmd, None);
                self.pseudo_solve(jac, factors, &residual.0, c, first)
                    .ok_or(Fault::NonFinite)?;
            }
            self.trust(first);
            let candidates = Candidates {
                steps: [&mut *second, &mut *first],
                trial: &mut *trial,
            };
            let improved = self.line_search(
                problem,
                &mut point,
                candidates,
                chain,
                &mut residual,
                settling,
            )?;
            let Some(step) = improved else {
                break;
            };
            settling = self.redundant && !self.settled(step);
        }
        point.finish();
        Ok(Solved {
            iterations,
            residual2: residual.1,
            bound: None,
            settled: !settling,
        })
    }

    /// The fallback near singularities: takes a step only if it lowers the
    /// residual (or, settling the null space, keeps it within the tolerance):
    /// the second-order one (eq. 4.9) first, then the first-order one, each
    /// halved up to three times. Returns the step taken, if any; `residual`
    /// is then the new point's. Out of line: it runs only where the step's
    /// bound fails, and the warm tick's code stays small.
    #[inline(never)]
    fn line_search<'s>(
        &self,
        problem: &Problem<'_, T>,
        point: &mut Point<'_, T>,
        candidates: Candidates<'s, T>,
        chain: &mut ServoChain<T>,
        residual: &mut ([T; 6], T),
        settling: bool,
    ) -> Result<Option<&'s [T]>, Fault> {
        let Candidates { steps, trial } = candidates;
        let (geometry, target) = (problem.geometry, problem.target);
        let tolerance2 = self.limits.tolerance * self.limits.tolerance;
        let acceptable =
            |candidate: T, current: T| candidate < current || (settling && candidate <= tolerance2);
        for step in steps {
            for _ in 0..4 {
                let base = point.current();
                for ((t, b), d) in trial.iter_mut().zip(base).zip(step.iter()) {
                    *t = *b + *d;
                }
                geometry.chain(trial, Parts::Lines, chain)?;
                let candidate = self.residual(target, &chain.end);
                if acceptable(candidate.1, residual.1) {
                    *residual = candidate;
                    point.advance(step);
                    return Ok(Some(step));
                }
                step.iter_mut().for_each(|d| *d *= T::lit(0.5));
            }
        }
        Ok(None)
    }

    /// Whether a step `d` no longer moves the joints: each by at most the
    /// tolerance (a revolute joint's turn weighed at the length scale).
    fn settled(&self, d: &[T]) -> bool {
        let ls = self.limits.length_scale;
        self.joints.iter().zip(d).all(|(joint, d)| {
            let moved = match joint.kind {
                JointType::Revolute => d.abs() * ls,
                JointType::Prismatic => d.abs(),
            };
            moved <= self.limits.tolerance
        })
    }

    /// For a redundant arm, the correction at the search's point, `p − q_cmd`
    /// (plus the predictor `plus`), into `offset`; `None` otherwise.
    #[inline(always)]
    fn offset<'a>(
        &self,
        offset: &'a mut [T],
        point: &Point<'_, T>,
        q_cmd: &[T],
        plus: Option<&[T]>,
    ) -> Option<&'a [T]> {
        if !self.redundant {
            return None;
        }
        let p = point.current();
        for (m, o) in offset.iter_mut().enumerate() {
            *o = p[m] - q_cmd[m] + plus.map_or(T::zero(), |d| d[m]);
        }
        Some(offset)
    }

    /// `J⁺ rhs` into `out`; for a redundant arm with the correction `c` at the
    /// point of linearisation, `J⁺ (rhs + J c) − c`: the step to the least
    /// whole correction that moves the frame by `rhs`, refined once. Returns
    /// the `y` whose `λ² y` the solve leaves of `rhs` (with fresh factors), or
    /// `None` if not finite.
    #[inline(always)]
    fn pseudo_solve(
        &self,
        jac: &[[T; 6]],
        factors: &Factors<T>,
        rhs: &[T; 6],
        c: Option<&[T]>,
        out: &mut [T],
    ) -> Option<[T; 6]> {
        match c {
            None => factors.solve(jac, rhs, out),
            Some(c) => {
                let mut whole = apply(jac, c);
                whole.iter_mut().zip(rhs).for_each(|(w, r)| *w += *r);
                let y = factors.solve(jac, &whole, out)?;
                out.iter_mut().zip(c).for_each(|(o, c)| *o -= *c);
                // The damping leaves `D y` of `rhs`, of the order of `λ²/σ²`
                // times `J c`, which does not shrink as the search converges
                // (the correction does not): one refinement with the same
                // factors leaves `D y₂`, of order `(λ²/σ²)²`.
                let left = self.leftover(y);
                let mut refined = [T::zero(); MAX_JOINTS];
                let y2 = factors.solve(jac, &left, &mut refined[..out.len()])?;
                out.iter_mut().zip(refined).for_each(|(o, d)| *o += d);
                Some(y2)
            }
        }
    }

    /// The second-order step from the predictor `first = δ₀` into `second`,
    /// linearised `at` the search's point with the residual `e` there and `r`
    /// at the predicted point: `δ = δ₀ + J⁺ r` ([`Self::pseudo_solve`] with
    /// the correction `c` at the predicted point), its bound with `|ℓ|₁` as the
    /// linear share (`λ² y` for fresh factors, measured for stale ones), the
    /// step scaled into its trust region; `None` if not finite.
    fn step(
        &self,
        at: &Linearisation<'_, T>,
        e: &[T; 6],
        first: &[T],
        r: &[T; 6],
        c: Option<&[T]>,
        second: &mut [T],
    ) -> Option<Bounded<T>> {
        let Linearisation {
            chain,
            jac,
            factors,
            reach,
        } = *at;
        let y = self.pseudo_solve(jac, factors, r, c, second)?;
        // The rows that must be reached: all for a full pose, the position's
        // for a position (whose rotation rows, where the orientation is kept,
        // give way near a singularity and are not bounded).
        let pose = self.task == Task::Pose;
        let linear = match factors.freshness {
            Freshness::Fresh => self.damping2() * rows_sum(&y, pose),
            // Factors of a nearby configuration leave a part of order `|J −
            // J'| |δ − δ₀|` besides: measured, `ℓ = r − J (δ − δ₀)`.
            _ => {
                let moved = apply(jac, second);
                if pose {
                    r.iter()
                        .zip(moved)
                        .fold(T::zero(), |s, (r, m)| s + (*r - m).abs())
                } else {
                    (r[3] - moved[3]).abs() + (r[4] - moved[4]).abs() + (r[5] - moved[5]).abs()
                }
            }
        };
        if !linear.is_finite() {
            return None;
        }
        Some(self.step_bound(chain.lines(), e, first, second, linear, reach))
    }
}

/// `|v|₁` over the rows that must be reached: all six for a full pose
/// (`pose`), the position's three otherwise. Fixed lengths: no loop over a
/// slice cut at run time.
#[inline(always)]
fn rows_sum<T: Real>(v: &[T; 6], pose: bool) -> T {
    if pose {
        v.iter().fold(T::zero(), |s, x| s + x.abs())
    } else {
        v[3].abs() + v[4].abs() + v[5].abs()
    }
}
