//! Every analytic Jacobian column against central finite differences of the
//! forward kinematics.
//!
//! The physics: a column of the special Jacobians (Mirman & Gupta eqs. 51–54), of
//! the base and tool frames and of the manipulator Jacobian is the twist
//! `(∂T/∂p)·T⁻¹ = [νdφ; dη]` of the measured frame `T` per unit change of one
//! parameter `p` (eq. 12). Here it is measured directly: `T` is evaluated at
//! `p ± h`, and
//!
//! ```text
//! νdφ ≈ vee( (R(p+h) − R(p−h)) / 2h · R(p)ᵀ )      dη ≈ (t(p+h) − t(p−h)) / 2h − νdφ × t(p)
//! ```
//!
//! for random robots (both conventions, both joint types, 1 to 8 joints, random
//! lengths and twists, random base and tool) at random configurations, in f64
//! and f32.
//!
//! ## Tolerance, derived from the step and the precision
//! Central differences err by the truncation term `h²/6·|f'''|` plus the rounding
//! term `δf/h`, where `δf` is the absolute rounding error of one evaluation of `f`.
//! - Angles enter `T` through rotations `Rot(p)` about fixed lines, so the third
//!   derivative of a rotation entry is bounded by 1 and that of a position by the
//!   distance of the point from the line, at most `L`, the sum of all lengths of
//!   the model (base, links, tool). Lengths enter `T` linearly: no truncation error.
//! - `T` is a product of `M + 2` transforms, each entry a short sum of products of
//!   numbers bounded by 1 (rotations) or by `L` (positions), each rounded to the
//!   precision `ε`; `k = 16 (M + 2)` rounding errors of relative size `ε` bound
//!   `δf` by `k ε` (rotation) and `k ε L` (position). The perturbed argument `p ± h`
//!   is itself rounded, which changes the step by `ε|p|` and adds `ε|p|/h·|f'|`.
//! - The extraction multiplies by `R(p)ᵀ` (entries ≤ 1, three terms: factor 3)
//!   and forms `νdφ × t(p)` (adds the rotation error times `|t(p)| ≤ L`).
//!
//! so `tol_rot = 3 (h²/6 + k ε/h + ε|p|/h)` and
//! `tol_trans = tol_rot · 2L`, with `L ≥ 1 m`. The step minimising the bound,
//! `h = (3 k ε)^{1/3}`, is used: about 5e-5 in f64 and 4e-2 in f32.

use armcal_shared::jacobian::at_point;
use armcal_shared::{Convention, FrameAxis, JointType, Link, Param, Real, Robot, Twist};
use nalgebra::{IsometryMatrix3, Vector3};
use proptest::prelude::*;

mod common;
use common::robot_strategy;

/// `L`: the sum of every length of the model and the joint travel, at least 1 m.
fn reach<T: Real>(robot: &Robot<T>, q: &[T]) -> f64 {
    let links: f64 = robot
        .links
        .iter()
        .zip(q)
        .map(|(l, &qm)| {
            let travel = if l.joint == JointType::Prismatic {
                qm.to_f64().abs()
            } else {
                0.0
            };
            l.s.to_f64().abs() + l.a.to_f64().abs() + travel
        })
        .sum();
    (links + robot.base.xyz.norm().to_f64() + robot.tool.xyz.norm().to_f64()).max(1.0)
}

/// The twist of `T` per unit change of a scalar, by central differences of
/// `frame_at(δ)`, the measured frame with the scalar moved by `δ`.
fn fd_twist<T: Real>(frame_at: impl Fn(T) -> IsometryMatrix3<T>, h: T) -> Twist<T> {
    let (plus, minus, here) = (frame_at(h), frame_at(-h), frame_at(T::zero()));
    let two_h = h + h;
    let dr = (plus.rotation.matrix() - minus.rotation.matrix()) / two_h;
    let n = dr * here.rotation.matrix().transpose();
    let half = T::lit(0.5);
    let phi = Vector3::new(n.m32 - n.m23, n.m13 - n.m31, n.m21 - n.m12) * half;
    let dp = (plus.translation.vector - minus.translation.vector) / two_h;
    let eta = dp - phi.cross(&here.translation.vector);
    Twist::new(phi.x, phi.y, phi.z, eta.x, eta.y, eta.z)
}

/// Step and tolerances `(h, tol_rot, tol_trans)` from the bound in the module header.
fn fd_budget<T: Real>(robot: &Robot<T>, q: &[T], value: f64) -> (f64, f64, f64) {
    let eps = T::default_epsilon().to_f64();
    let k = 16.0 * (robot.dof() as f64 + 2.0);
    let h = (3.0 * k * eps).cbrt();
    let tol_rot = 3.0 * (h * h / 6.0 + k * eps / h + eps * value.abs() / h);
    (h, tol_rot, tol_rot * 2.0 * reach(robot, q))
}

fn assert_twist_close<T: Real>(
    what: &str,
    analytic: &Twist<T>,
    numeric: &Twist<T>,
    tol_rot: f64,
    tol_trans: f64,
) -> Result<(), TestCaseError> {
    for i in 0..6 {
        let (a, n) = (analytic[i].to_f64(), numeric[i].to_f64());
        let tol = if i < 3 { tol_rot } else { tol_trans };
        prop_assert!(
            (a - n).abs() <= tol,
            "{what}: component {i}: analytic {a:e} vs finite difference {n:e} (|diff| {:e} > tol {tol:e})",
            (a - n).abs()
        );
    }
    Ok(())
}

/// Every parameter column and every joint column of one robot in scalar `T`.
fn check_all_columns<T: Real>(robot: &Robot<T>, q: &[T]) -> Result<(), TestCaseError> {
    let chain = robot.chain(q).expect("joint count matches");
    // The D-H parameters of the file and Hayati's tilt of every link.
    let tilts = (0..robot.dof()).map(Param::Beta);
    for param in robot.params().chain(tilts) {
        let value = robot.param(param).expect("param of this robot").to_f64();
        let (h, tol_rot, tol_trans) = fd_budget(robot, q, value);
        let frame_at = |d: T| {
            let mut moved = robot.clone();
            *moved.param_mut(param).expect("param of this robot") += d;
            moved.forward(q).expect("joint count matches")
        };
        let numeric = fd_twist(frame_at, T::lit(h));
        assert_twist_close(
            &param.to_string(),
            &chain.column(param),
            &numeric,
            tol_rot,
            tol_trans,
        )?;
    }
    // The manipulator Jacobian: the twist per unit joint reading.
    let jac = chain.manipulator_jacobian();
    prop_assert_eq!(jac.ncols(), robot.dof());
    for m in 0..robot.dof() {
        let (h, tol_rot, tol_trans) = fd_budget(robot, q, q[m].to_f64());
        let frame_at = |d: T| {
            let mut moved = q.to_vec();
            moved[m] += d;
            robot.forward(&moved).expect("joint count matches")
        };
        let numeric = fd_twist(frame_at, T::lit(h));
        assert_twist_close(
            &format!("joint {}", m + 1),
            &jac.column(m),
            &numeric,
            tol_rot,
            tol_trans,
        )?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn columns_match_finite_differences_f64((robot, q) in robot_strategy()) {
        check_all_columns(&robot, &q)?;
    }

    /// With Hayati tilts on the links (the `parallel_axis_tilt` effect), every
    /// column, the tilts' own included, still matches the finite differences.
    #[test]
    fn columns_with_tilted_links_match_finite_differences(
        (robot, q) in robot_strategy(),
        tilts in prop::collection::vec(-0.5..0.5f64, 8),
    ) {
        let mut robot = robot;
        for (link, beta) in robot.links.iter_mut().zip(&tilts) {
            link.beta = *beta;
        }
        check_all_columns(&robot, &q)?;
    }

    #[test]
    fn columns_match_finite_differences_f32((robot, q) in robot_strategy()) {
        let q32: Vec<f32> = q.iter().map(|&x| x as f32).collect();
        check_all_columns(&robot.cast::<f32>(), &q32)?;
    }

    /// The four special Jacobians hold the same columns as `Chain::column`.
    #[test]
    fn special_jacobians_hold_the_columns((robot, q) in robot_strategy()) {
        let chain = robot.chain(&q).unwrap();
        let sj = chain.special_jacobians();
        for m in 0..robot.dof() {
            prop_assert_eq!(sj.theta.column(m), chain.column(Param::Theta(m)));
            prop_assert_eq!(sj.s.column(m), chain.column(Param::S(m)));
            prop_assert_eq!(sj.alpha.column(m), chain.column(Param::Alpha(m)));
            prop_assert_eq!(sj.a.column(m), chain.column(Param::A(m)));
        }
        prop_assert_eq!(sj.theta.view().ncols(), robot.dof());
    }

    /// Position-only rows (a laser tracker): the measured point moves by
    /// `dP = dη + νdφ × P` (eq. 8) per unit of every parameter.
    #[test]
    fn point_rows_match_finite_differences((robot, q) in robot_strategy()) {
        let chain = robot.chain(&q).unwrap();
        let p = chain.point();
        for param in robot.params() {
            let value = robot.param(param).unwrap();
            let (h, _, tol_trans) = fd_budget(&robot, &q, value);
            let point_at = |d: f64| {
                let mut moved = robot.clone();
                *moved.param_mut(param).unwrap() += d;
                moved.measured_point(&q).unwrap()
            };
            let numeric = (point_at(h) - point_at(-h)) / (2.0 * h);
            let analytic = at_point(&chain.column(param), &p);
            prop_assert!((analytic - numeric).norm() <= tol_trans * 3f64.sqrt(),
                "{param}: {analytic:?} vs {numeric:?}");
        }
    }

    /// The f32 kinematics the controller runs agree with the f64 ones to the f32
    /// rounding of `k = 16 (M + 2)` operations on numbers bounded by `L`.
    #[test]
    fn f32_chain_agrees_with_f64((robot, q) in robot_strategy()) {
        let q32: Vec<f32> = q.iter().map(|&x| x as f32).collect();
        let (c64, c32) = (robot.chain(&q).unwrap(), robot.cast::<f32>().chain(&q32).unwrap());
        let l = reach(&robot, &q);
        // Inputs are rounded to f32 too (relative ε, angles up to π): 4 more ε per link.
        let k = 16.0 * (robot.dof() as f64 + 2.0) + 4.0 * robot.dof() as f64 * std::f64::consts::PI;
        let tol = k * f32::EPSILON as f64;
        for param in robot.params() {
            let (a, b) = (c64.column(param), c32.column(param));
            for i in 0..6 {
                let scale = if i < 3 { 1.0 } else { 2.0 * l };
                prop_assert!((a[i] - b[i] as f64).abs() <= tol * scale, "{param}[{i}]: {} vs {}", a[i], b[i]);
            }
        }
        prop_assert!((c64.point().coords - c32.point().coords.cast::<f64>()).norm() <= tol * l);
    }
}

/// A joint vector of the wrong length is refused, not a panic.
#[test]
fn wrong_joint_count_is_an_error() {
    let robot = Robot::new(
        Convention::Dh,
        &[Link::new(JointType::Revolute, 0.0, 0.1, 0.2, 0.3)],
    )
    .unwrap();
    assert!(robot.forward(&[0.0, 1.0]).is_err());
    assert!(robot.chain(&[]).is_err());
}

/// The base columns at the identity base are the unit twists of the measurement frame.
#[test]
fn base_columns_at_identity_are_unit_twists() {
    let robot = Robot::new(
        Convention::Mdh,
        &[Link::new(JointType::Revolute, 0.0, 0.1, 0.2, 0.3)],
    )
    .unwrap();
    let chain = robot.chain(&[0.4]).unwrap();
    let unit = |i: usize| {
        let mut t = Twist::<f64>::zeros();
        t[i] = 1.0;
        t
    };
    assert_eq!(chain.base_column(FrameAxis::X), unit(3));
    assert_eq!(chain.base_column(FrameAxis::Y), unit(4));
    assert_eq!(chain.base_column(FrameAxis::Z), unit(5));
    assert_eq!(chain.base_column(FrameAxis::Rx), unit(0));
    assert_eq!(chain.base_column(FrameAxis::Ry), unit(1));
    assert_eq!(chain.base_column(FrameAxis::Rz), unit(2));
}
