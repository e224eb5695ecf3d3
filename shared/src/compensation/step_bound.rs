//! The step of eq. 4.9 about a predicted point, the second-order term `H` of the
//! calibrated frame's change, and the bound on the residual after a step.
//!
//! **The step.** Each step starts from a predictor `δ₀`: the first-order step
//! `J⁺ e`, or on a warm tick the predicted step ([`super::start`]). With `r = e −
//! J δ₀ − H(δ₀, δ₀)`, the residual at `p + δ₀` to second order, the step is `δ
//! = δ₀ + J⁺ r` (eq. 4.9 about the predicted point; with `δ₀ = J⁺ e` it is the
//! paper's `J⁺ (e − H(δ₁, δ₁))` up to the damping), and `ℓ = r − J (δ − δ₀)` is
//! what it leaves of the linear part: `λ² y` for the factors of this `J`, a
//! little more for stale ones ([`super::factors`]). For a redundant arm the
//! solves are for the whole correction ([the module](super)); `ℓ` is the same.
//!
//! **H.** With the coordinates' origin at the tool point, each joint's twist is
//! `[w_m; v_m]` (`v_m` the tool point's velocity per unit of joint `m`), and eq.
//! 2.22's `E₂ = Σ_m (S_m + ½X_m) X_m`, `X_m = ξ̂_m δ_m`, `S_m = Σ_{i<m} X_i`, moves
//! the point by `Σ_m a_m × v_m δ_m` and turns by `½ Σ_m a_m × w_m δ_m`, with
//! `a_m = Σ_{i<m} w_i δ_i + ½ w_m δ_m` (zero `w` for a prismatic joint): a few
//! products per joint instead of the 4 × 4 ones of
//! [`crate::perturbation::expand`], which it equals (tested).
//!
//! **The bound.** After the step `δ` the residual is, exactly,
//!
//! ```text
//! e(p + δ) = ℓ + H(δ₀ − δ, δ₀ + δ) − R₃(δ) + C
//! ```
//!
//! (the linear part left, `|ℓ|₁` computed, the difference of the two
//! second-order terms, the expansion's remainder of third order and up, and for
//! the rotation the cross term `C = φ((N − I)(Eᵀ − I))` of the residual rotation
//! `N` with the step's rotation `E`). Each joint's `X_m δ_m` has norm at most
//! `|δ_m|` (revolute) or `|δ_m| / R` (prismatic) for points within `R` of every
//! joint axis (`R` the largest lever `|w_m × (p − ρ_m)|`, at least
//! [`Limits::length_scale`](super::Limits::length_scale)), so with `σ(δ) = Σ` of
//! those norms, `|H(a, b)| ≤ ½ σ(a) σ(b)` and `|R₃| ≤ σ³ e^σ / 6 ≤ 0.2 σ³` for
//! `σ ≤ 0.1`, each times `R` (plus the length scale for the rotation rows); and
//! `|C| ≤ ½ |φ × θ| + 0.55 |φ| s_r² + 0.65 |φ|² s_r` with `θ = Σ w_m δ_m` the
//! step's rotation and `s_r` its size (`|φ| ≤ 0.4`). When that bound is below
//! the tolerance the step is taken without evaluating the chain after it: on a
//! smooth motion a tick is one chain of the calibrated model and one step, and
//! [`Correction::residual`](super::Correction::residual) is the bound (a
//! property test checks that the real residual never exceeds it). For
//! [`Task::Position`] the bound is of the position rows alone (the rows that
//! must be reached: `ℓ` of those rows, the lever `R`), whether or not its
//! weighed rotation rows keep the orientation.

use nalgebra::Vector3;

use super::{Compensator, Task, larger};
use crate::servo_chain::{JointLine, ServoChain};
use crate::{JointType, Real};

/// The bound on the residual after a step and whether the step was whole.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bounded<T: Real> {
    /// The bound, m, where it applies (a step under 0.1 rad, a rotation error
    /// under 0.4 rad).
    pub bound: Option<T>,
    /// Whether the step was whole (else scaled into its trust region).
    pub whole: bool,
}

impl<T: Real> Compensator<T> {
    /// The columns of `J_r` at `chain` (with its joint lines) into `jac`, one
    /// `[T; 6]` per joint: its rotation (scaled by the rotation rows' length
    /// scale: zero for a position task that does not keep the orientation)
    /// and the tool point's displacement; returns `reach`, a
    /// bound on the levers `|v_m|` (1-norm), at least the length scale.
    #[inline(never)]
    pub(crate) fn jacobian(&self, chain: &ServoChain<T>, jac: &mut [[T; 6]]) -> T {
        let p = chain.end.translation.vector;
        let rotation = self.rotation_scale();
        let mut reach = self.limits.length_scale;
        for ((out, line), joint) in jac.iter_mut().zip(chain.lines()).zip(&self.joints) {
            (*out, _) = column(joint.kind, line, &p, rotation, &mut reach);
        }
        reach
    }

    /// [`Self::jacobian`], and in the same pass the residual at the predicted
    /// point `p + δ₀` to second order, `r = e − J δ₀ − H(δ₀, δ₀)` for the
    /// predictor `delta = δ₀`: each joint's twist is at hand for the sums of
    /// `H`, and `J δ₀` is their first-order part.
    #[inline(never)]
    pub(crate) fn jacobian_predicted(
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
            (*out, w) = column(joint.kind, line, &p, rotation, &mut reach);
            sums.add(w, Vector3::new(out[3], out[4], out[5]), d);
        }
        let (moved, h) = sums.finish(rotation);
        let mut r = *e;
        for ((r, m), h) in r.iter_mut().zip(moved).zip(h) {
            *r -= m + h;
        }
        (reach, r)
    }

    /// `r = left − H(δ₀, δ₀)` for `left = e − J δ₀` and the predictor `first =
    /// δ₀`: the residual at `p + δ₀` to second order.
    pub(crate) fn predicted(
        &self,
        chain: &ServoChain<T>,
        jac: &[[T; 6]],
        left: [T; 6],
        first: &[T],
    ) -> [T; 6] {
        let mut r = left;
        let h = second_order(
            self.joints.iter().map(|j| j.kind),
            chain.lines(),
            jac,
            first,
            self.rotation_scale(),
        );
        r.iter_mut().zip(h).for_each(|(r, h)| *r -= h);
        r
    }

    /// The bound of the module header on the residual after the step `δ =
    /// first + second` (`second` holds `δ − δ₀` on entry and `δ` on return),
    /// with `linear = |ℓ|₁`, and the step scaled into its trust region: no
    /// joint moves by more than its correction bound.
    pub(crate) fn step_bound(
        &self,
        lines: &[JointLine<T>],
        e: &[T; 6],
        first: &[T],
        second: &mut [T],
        linear: T,
        reach: T,
    ) -> Bounded<T> {
        let ls = self.limits.length_scale;
        // σ(δ) = Σ_revolute |δ_m| + Σ_prismatic |δ_m| / R; s_r the revolute part.
        let (mut diff, mut sum, mut size, mut turn) = (T::zero(), T::zero(), T::zero(), T::zero());
        let mut theta = Vector3::zeros();
        let mut worst = T::zero();
        let steps = first.iter().zip(second.iter_mut());
        for ((joint, line), (&d1, d2)) in self.joints.iter().zip(lines).zip(steps) {
            *d2 += d1;
            let d2 = *d2;
            worst = larger(worst, d2.abs() / joint.max_correction);
            let unit = match joint.kind {
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
        let whole = shrink(second, worst);
        if size > T::lit(0.1) {
            return Bounded { bound: None, whole };
        }
        let pose = self.task == Task::Pose;
        let mut bound = linear;
        let lever = reach + if pose { ls } else { T::zero() };
        bound += lever * (T::lit(0.5) * diff * sum + T::lit(0.2) * size * size * size);
        if pose {
            let phi = Vector3::new(e[0], e[1], e[2]) / ls;
            let phi1 = phi.x.abs() + phi.y.abs() + phi.z.abs();
            if phi1 > T::lit(0.4) {
                return Bounded { bound: None, whole };
            }
            let cross = phi.cross(&theta);
            let cross1 = cross.x.abs() + cross.y.abs() + cross.z.abs();
            bound += ls
                * (T::lit(0.5) * cross1
                    + T::lit(0.55) * phi1 * turn * turn
                    + T::lit(0.65) * phi1 * phi1 * turn);
        }
        Bounded {
            bound: Some(bound),
            whole,
        }
    }

    /// Trust region: scales `step` so that no joint moves by more than its
    /// correction bound (near a singularity the step is otherwise huge);
    /// whether it was whole.
    pub(crate) fn trust(&self, step: &mut [T]) -> bool {
        let mut worst = T::zero();
        for (d, joint) in step.iter().zip(&self.joints) {
            worst = larger(worst, d.abs() / joint.max_correction);
        }
        shrink(step, worst)
    }
}

/// Scales `step` by `1 / worst` when `worst`, the largest share of its bound
/// that a joint's step takes, is over 1; whether it was whole.
#[inline]
fn shrink<T: Real>(step: &mut [T], worst: T) -> bool {
    if worst <= T::one() {
        return true;
    }
    let scale = T::one() / worst;
    step.iter_mut().for_each(|d| *d *= scale);
    false
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
    kinds: impl IntoIterator<Item = JointType>,
    lines: &[JointLine<T>],
    jac: &[[T; 6]],
    delta: &[T],
    ls: T,
) -> [T; 6] {
    let mut sums = SecondOrder::new();
    for (((kind, line), col), &d) in kinds.into_iter().zip(lines).zip(jac).zip(delta) {
        let w = match kind {
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
    use crate::MAX_JOINTS;
    use crate::jacobian::at_point;
    use crate::perturbation::expand;
    use crate::servo_chain::Wanted;
    use crate::{Convention, Link, Param, Robot};
    use heapless::Vec;

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
            let h = second_order(joints, servo.lines(), &jac, &delta, ls);
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
