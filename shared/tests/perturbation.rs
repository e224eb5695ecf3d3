//! The second-order expansion of the forward solution (Kirchner, Gurumoorthy &
//! Prinz 1985, eq. 2.22) against the exact forward kinematics of the perturbed
//! model.
//!
//! The physics: with every parameter error of size ε, the first-order prediction
//! `T^i + Σ K_i Δp_i` misses the real frame `T^r` (computed by [`Robot::forward`]
//! of the model with the errors added) by a term of order ε², and the
//! second-order one `T^i + Σ K_i Δp_i + Σ Δp_i L_ij Δp_j` by a term of order ε³:
//! halving ε divides the first residual by 4 and the second by 8. Checked for
//! random robots in both conventions (the derivation holds for both: every
//! parameter is one elementary screw factor), both joint types, with random
//! base and tool, and errors in every parameter (4M link parameters and the 12 of
//! base and tool), f64.
//!
//! ## The terms beyond, and the tolerance of the ratio, derived
//! Every parameter is one elementary screw factor of the chain, so
//! `T^r (T^i)⁻¹ = exp(X_1) exp(X_2) ⋯ exp(X_N)` with `X_k = ξ̂_k Δp_k` in chain
//! order (module header of `armcal_shared::perturbation`). Its terms of order
//! n = 1 … 4, `E_n`, are computed here independently of the crate's one-pass
//! formula, by multiplying out the truncated exponentials factor by factor. Then:
//!
//! 1. `E₁` and `E₂` are the crate's first and second-order terms (to rounding);
//! 2. `T^i + (E₁ + … + E₄) T^i` is the exact `T^r` up to the terms of order ≥ 5;
//! 3. the residual of the first-order prediction is `E₂ + E₃ + …`, that of the
//!    second-order one `E₃ + E₄ + …`, so the ratio of residuals when ε is halved
//!    is `1/4` and `1/8` up to the next term, whose size is known.
//!
//! ### Bounds
//! A product of `ξ̂ = [[ [ω]×, v ], [0, 0]]` has rotation block `[ω_1]×⋯[ω_n]×`
//! and translation column `[ω_1]×⋯[ω_{n−1}]× v_n`. Taken about the measured
//! point `P` (where `v` becomes `v + ω × P`, the point's velocity, and the
//! translation column the point's displacement), with `a = Σ |Δp_k| |ω_k|` (rad)
//! and `b = Σ |Δp_k| |v_k + ω_k × P|` (m), the terms of order ≥ n together are
//! bounded by
//!
//! ```text
//! orientation (Frobenius):  H_n = √2 aⁿ/n! eᵃ        point:  H_n = b aⁿ⁻¹/(n−1)! eᵃ
//! ```
//!
//! Rounding adds at most `δ` to each residual measured against `Robot::forward`:
//! `δ = 2 k ε_mach · 3` (orientation) and `2 k ε_mach L` (point), with
//! `k = 16 (M + 2)` operations per forward solution (as in `jacobian_fd.rs`) and
//! `L` the reach.
//!
//! ### Ratio
//! For a truncation whose residual starts at order m, with `τ = |E_m|` and
//! `f = |E_{m+1}|` at ε and `H = H_{m+2}`, `r(ε) ≥ τ − f − H − δ` and
//! `|2ᵐ r(ε/2) − r(ε)| ≤ 1.5 f + 1.25 H + (2ᵐ + 1) δ`, so
//!
//! ```text
//! |2ᵐ r(ε/2) / r(ε) − 1| ≤ (1.5 f + 1.25 H + (2ᵐ + 1) δ) / (τ − f − H − δ)
//! ```
//!
//! is the tolerance, case by case. ε is set per robot so that `a = 1e-2`: the
//! next term is then a fraction ~`a` of the leading one and the leading one stays
//! well above the rounding. Every case asserts that the tolerance is below 0.5,
//! i.e. that the leading term is resolved (`2ᵐ r(ε/2)/r(ε)` then tells order m
//! from order m ± 1, ratios 2 and ½). Over 3000 random cases the tolerance was
//! 2e-3 to 4e-3 (median) and 0.2 at most, and the measured `|ρ − 1|` at most
//! 0.3 of it.

use armcal_shared::jacobian::at_point;
use armcal_shared::perturbation::{
    PerturbationError, chain_order, error_twist, expand, hat, k_matrix, l_matrix, l_twist,
};
use armcal_shared::{Convention, JointType, Link, Param, Robot, Twist, pose_error};
use nalgebra::{IsometryMatrix3, Matrix3, Matrix4, Vector3};
use proptest::prelude::*;

mod common;
use common::robot_strategy;

/// Random error directions, `±[0.2, 1]`, one per parameter of a robot of up to 8
/// joints: every parameter is in error.
fn directions() -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(
        (0.2..1.0f64, any::<bool>()).prop_map(|(m, neg)| if neg { -m } else { m }),
        4 * 8 + 12,
    )
}

/// `L`: the sum of every length of the model and the joint travel, at least 1 m.
fn reach(robot: &Robot<f64>, q: &[f64]) -> f64 {
    let links: f64 = robot
        .links
        .iter()
        .zip(q)
        .map(|(l, &qm)| {
            let travel = if l.joint == JointType::Prismatic {
                qm.abs()
            } else {
                0.0
            };
            l.s.abs() + l.a.abs() + travel
        })
        .sum();
    (links + robot.base.xyz.norm() + robot.tool.xyz.norm()).max(1.0)
}

/// `robot` with `errors` added to its parameters: the real robot.
fn perturbed(robot: &Robot<f64>, errors: &[(Param, f64)]) -> Robot<f64> {
    let mut real = robot.clone();
    for &(p, d) in errors {
        *real.param_mut(p).expect("param of this robot") += d;
    }
    real
}

fn rotation(m: &Matrix4<f64>) -> Matrix3<f64> {
    m.fixed_view::<3, 3>(0, 0).into_owned()
}

fn translation(m: &Matrix4<f64>) -> Vector3<f64> {
    m.fixed_view::<3, 1>(0, 3).into_owned()
}

/// Orientation and point residuals of the first- and second-order predictions:
/// `[(rot₁, point₁), (rot₂, point₂)]`.
fn residuals(robot: &Robot<f64>, q: &[f64], errors: &[(Param, f64)]) -> [(f64, f64); 2] {
    let exact = perturbed(robot, errors)
        .forward(q)
        .expect("joint count")
        .to_homogeneous();
    let pert = robot.perturbation(q, errors).expect("params of this robot");
    [pert.frame_first_order(), pert.frame()].map(|predicted| {
        let diff = exact - predicted;
        (rotation(&diff).norm(), translation(&diff).norm())
    })
}

/// The terms of order 1 … 4 of `exp(X_1) ⋯ exp(X_N)`, `X_k = ξ̂_k Δp_k` in chain
/// order, multiplied out factor by factor: `terms[n] = E_n` (`terms[0] = I`).
fn series_terms(robot: &Robot<f64>, q: &[f64], errors: &[(Param, f64)]) -> [Matrix4<f64>; 5] {
    let chain = robot.chain(q).unwrap();
    let mut sorted = errors.to_vec();
    sorted.sort_by_key(|&(p, _)| chain_order(robot.convention, p));
    let mut terms = [Matrix4::zeros(); 5];
    terms[0] = Matrix4::identity();
    for (p, d) in sorted {
        let x = hat(&chain.column(p)) * d;
        // exp(X) to order 4: X^j / j!.
        let mut pow = [Matrix4::identity(); 5];
        for j in 1..5 {
            pow[j] = pow[j - 1] * x / j as f64;
        }
        let before = terms;
        for n in 1..5 {
            terms[n] = (0..=n).map(|j| before[n - j] * pow[j]).sum();
        }
    }
    terms
}

/// `(orientation, point)` sizes of a 4×4 error `E` of the frame `T^i`: the
/// Frobenius norm of `E_R` and the displacement `E_R P + e_t` of the point.
fn sizes(e: &Matrix4<f64>, point: &Vector3<f64>) -> (f64, f64) {
    (
        rotation(e).norm(),
        (rotation(e) * point + translation(e)).norm(),
    )
}

/// The sizes that bound the ratio of a truncation's residuals (module header,
/// "Ratio"), in orientation or in the point: `τ = |E_m|` and `f = |E_{m+1}|` at
/// ε, `h = H_{m+2}` and the rounding `δ`.
struct RatioBounds {
    tau: f64,
    f: f64,
    h: f64,
    delta: f64,
}

/// Checks `ρ = 2ᵐ r(ε/2)/r(ε) ≈ 1` for the residuals `(r(ε), r(ε/2))` with the
/// tolerance of the module header.
fn check_ratio(
    what: &str,
    m: i32,
    (r, r_half): (f64, f64),
    bounds: RatioBounds,
) -> Result<(), TestCaseError> {
    let RatioBounds { tau, f, h, delta } = bounds;
    let two_m = 2f64.powi(m);
    let tol = (1.5 * f + 1.25 * h + (two_m + 1.0) * delta) / (tau - f - h - delta);
    prop_assert!(
        (0.0..0.5).contains(&tol),
        "{what}: |E_{m}| = {tau:e} does not stand out of |E_{}| = {f:e}, H = {h:e}, δ = {delta:e}",
        m + 1
    );
    let rho = two_m * r_half / r;
    prop_assert!(
        (rho - 1.0).abs() <= tol,
        "{what}: 2^{m} r(ε/2)/r(ε) = {rho} (r(ε) = {r:e}, r(ε/2) = {r_half:e}), tolerance {tol:e}"
    );
    Ok(())
}

fn factorial(n: i32) -> f64 {
    (1..=n).map(f64::from).product()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// The expansion is the Taylor series of the exact forward solution: the
    /// crate's terms are `E₁`, `E₂`; with `E₃`, `E₄` added the exact frame is met
    /// to the fifth-order bound; and halving ε divides the first-order residual by
    /// 4 and the second-order one by 8, in orientation and in the measured point.
    #[test]
    fn first_order_leaves_eps2_second_order_leaves_eps3(
        (robot, q) in robot_strategy(),
        u in directions(),
    ) {
        let chain = robot.chain(&q).unwrap();
        let point = chain.point();
        let params: Vec<Param> = robot.params().collect();
        // ε such that a = Σ|Δp||ω| = 1e-2; b about the measured point.
        let (a_unit, b_unit) = params.iter().zip(&u).fold((0.0, 0.0), |(a, b), (p, ui)| {
            let xi = chain.column(*p);
            (a + ui.abs() * xi.fixed_rows::<3>(0).norm(), b + ui.abs() * at_point(&xi, &point).norm())
        });
        let eps = 1e-2 / a_unit;
        let (a, b) = (a_unit * eps, b_unit * eps);
        let errors_at = |e: f64| -> Vec<(Param, f64)> {
            params.iter().zip(&u).map(|(p, ui)| (*p, ui * e)).collect()
        };
        let errors = errors_at(eps);
        let terms = series_terms(&robot, &q, &errors);
        let pert = robot.perturbation(&q, &errors).unwrap();
        let bound = |n: i32| -> (f64, f64) {
            (2f64.sqrt() * a.powi(n) / factorial(n) * a.exp(), b * a.powi(n - 1) / factorial(n - 1) * a.exp())
        };
        let k = 16.0 * (robot.dof() as f64 + 2.0);
        let delta = (2.0 * k * f64::EPSILON * 3.0, 2.0 * k * f64::EPSILON * reach(&robot, &q));

        // 1. The crate's terms are E₁ and E₂ (rounding of N products of size ≤ a, b).
        let round = 16.0 * params.len() as f64 * f64::EPSILON * (a + b + a * (a + b));
        prop_assert!((pert.first_matrix() - terms[1]).amax() <= round);
        prop_assert!((pert.second - terms[2]).amax() <= round);

        // 2. Up to E₄ the series meets Robot::forward to the fifth-order bound.
        let t = chain.end.to_homogeneous();
        let exact = perturbed(&robot, &errors).forward(&q).unwrap().to_homogeneous();
        let e4 = terms[1] + terms[2] + terms[3] + terms[4];
        let (rot, pt) = sizes(&((exact - t) * chain.end.inverse().to_homogeneous() - e4), &point.coords);
        let (h5_rot, h5_pt) = bound(5);
        prop_assert!(rot <= h5_rot + delta.0, "orientation {rot:e} > {:e}", h5_rot + delta.0);
        prop_assert!(pt <= h5_pt + delta.1, "point {pt:e} > {:e}", h5_pt + delta.1);

        // 3. The ratios.
        let full = residuals(&robot, &q, &errors);
        let half = residuals(&robot, &q, &errors_at(eps / 2.0));
        for (order, m) in [(0usize, 2i32), (1, 3)] {
            let name = ["first-order", "second-order"][order];
            let (tau, f) = (sizes(&terms[m as usize], &point.coords), sizes(&terms[m as usize + 1], &point.coords));
            let h = bound(m + 2);
            let orientation = RatioBounds { tau: tau.0, f: f.0, h: h.0, delta: delta.0 };
            let in_point = RatioBounds { tau: tau.1, f: f.1, h: h.1, delta: delta.1 };
            check_ratio(&format!("{name} orientation"), m, (full[order].0, half[order].0), orientation)?;
            check_ratio(&format!("{name} point"), m, (full[order].1, half[order].1), in_point)?;
        }
    }

    /// The twist form: `Perturbation::pose_error` predicts `pose_error(T^r, T^i)`
    /// (Mirman & Gupta eq. 15) exactly as well as the 4×4 form predicts `T^r`:
    /// `pose_error` is the linear map `P` of the 4×4 error `E = T^r (T^i)⁻¹ − I`.
    #[test]
    fn pose_error_is_linear_in_the_4x4_error((robot, q) in robot_strategy(), u in directions()) {
        let params: Vec<Param> = robot.params().collect();
        let errors: Vec<(Param, f64)> = params.iter().zip(&u).map(|(p, ui)| (*p, ui * 1e-3)).collect();
        let nominal = robot.forward(&q).unwrap();
        let real = perturbed(&robot, &errors).forward(&q).unwrap();
        let e = real.to_homogeneous() * nominal.inverse().to_homogeneous() - Matrix4::identity();
        // P(E) against pose_error, both from the same two frames: rounding only,
        // on entries bounded by 1 (rotation) and L (translation), k operations.
        let l = reach(&robot, &q);
        let tol = 16.0 * (robot.dof() as f64 + 2.0) * f64::EPSILON * l;
        let (pe, pe_of_e) = (pose_error(&real, &nominal), error_twist(&e, &nominal));
        prop_assert!((pe - pe_of_e).amax() <= tol, "{pe:?} vs {pe_of_e:?}");
        // And so the twist prediction misses pose_error by P(residual of the 4×4 form).
        let pert = robot.perturbation(&q, &errors).unwrap();
        let residual = e - pert.first_matrix() - pert.second;
        let want = pe - error_twist(&residual, &nominal);
        prop_assert!((pert.pose_error() - want).amax() <= 2.0 * tol, "{:?} vs {want:?}", pert.pose_error());
    }

    /// `Σ_i K_i Δp_i + Σ_i Σ_j Δp_i L_ij Δp_j`, summed term by term from the
    /// paper's operators, is the expansion `expand` computes in one pass, in the
    /// 4×4 form and in the twist form, and `L_ij = L_ji` (2.23).
    #[test]
    fn k_and_l_operators_sum_to_the_expansion((robot, q) in robot_strategy(), u in directions()) {
        let chain = robot.chain(&q).unwrap();
        let params: Vec<Param> = robot.params().collect();
        let errors: Vec<(Param, f64)> = params.iter().zip(&u).map(|(p, ui)| (*p, ui * 1e-2)).collect();
        let pert = expand(&chain, robot.convention, &errors).unwrap();
        let t = chain.end.to_homogeneous();
        let (mut first, mut second, mut second_twist) = (Matrix4::zeros(), Matrix4::zeros(), Twist::zeros());
        let mut x = 0.0;
        for &(pi, di) in &errors {
            first += k_matrix(&chain, pi).unwrap() * di;
            x += hat(&chain.column(pi)).norm() * di.abs();
            for &(pj, dj) in &errors {
                let l = l_matrix(&chain, robot.convention, pi, pj).unwrap();
                prop_assert_eq!(l, l_matrix(&chain, robot.convention, pj, pi).unwrap());
                second += l * (di * dj);
                second_twist += l_twist(&chain, robot.convention, pi, pj).unwrap() * (di * dj);
            }
        }
        // Rounding: N² terms, each a product of entries bounded by x, |T| and |p|.
        let n = errors.len() as f64;
        let scale = t.norm() * (1.0 + x) * (1.0 + x);
        let tol = 16.0 * n * n * f64::EPSILON * scale;
        prop_assert!((first - pert.delta_first()).amax() <= tol);
        prop_assert!((second - (pert.delta() - pert.delta_first())).amax() <= tol);
        prop_assert!((second_twist - pert.second_twist()).amax() <= tol);
    }

    /// The order of the list does not matter, and a parameter given twice counts
    /// with the sum of its errors.
    #[test]
    fn order_of_the_error_list_does_not_matter((robot, q) in robot_strategy(), u in directions()) {
        let params: Vec<Param> = robot.params().collect();
        let errors: Vec<(Param, f64)> = params.iter().zip(&u).map(|(p, ui)| (*p, ui * 1e-2)).collect();
        let mut shuffled: Vec<(Param, f64)> = errors.iter().rev().flat_map(|&(p, d)| [(p, d / 2.0), (p, d / 2.0)]).collect();
        shuffled.rotate_left(errors.len() / 3);
        let (a, b) = (robot.perturbation(&q, &errors).unwrap(), robot.perturbation(&q, &shuffled).unwrap());
        let tol = 1e-14 * reach(&robot, &q);
        prop_assert!((a.first - b.first).amax() <= tol);
        prop_assert!((a.second - b.second).amax() <= tol);
    }
}

/// The paper's own example (2.21): link 1 of the Stanford manipulator, `α_1 =
/// −90°`, `a_1 = s_1 = 0`, expanded in `Δα_1`. The operators are the derivatives
/// of (2.2): `K = ∂A_1/∂α_1` and `L = ½ ∂²A_1/∂α_1²`. The first two rows of each
/// are the ones printed in (2.21). The third rows printed there (as our copy of
/// the report reads, `(0, 0, −sin θ_1, 0)` and `(0, 0, −cos θ_1, 0)`) depend on
/// `θ_1`, which the third row `(0, sin α, cos α, s)` of (2.2) does not: the
/// derivatives of (2.2) are used. The paper prints `∂²A_1/∂α_1²` itself as the
/// coefficient of `Δα_1Δα_1`, without the ½ of the Taylor series.
#[test]
fn stanford_link1_example_2_21() {
    let alpha = -std::f64::consts::FRAC_PI_2;
    let robot = Robot::new(
        Convention::Dh,
        &[Link::new(JointType::Revolute, 0.0, 0.0, 0.0, alpha)],
    )
    .unwrap();
    for theta1 in [0.3, -1.2, 2.5] {
        let chain = robot.chain(&[theta1]).unwrap();
        let (s, c) = f64::sin_cos(theta1);
        #[rustfmt::skip]
        let d_alpha = Matrix4::new(
            0.0, -s,  0.0, 0.0,
            0.0,  c,  0.0, 0.0,
            0.0, 0.0, 1.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
        );
        #[rustfmt::skip]
        let d2_alpha = Matrix4::new(
            0.0, 0.0,  s,  0.0,
            0.0, 0.0, -c,  0.0,
            0.0, 1.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
        );
        let k = k_matrix(&chain, Param::Alpha(0)).unwrap();
        let l = l_matrix(&chain, Convention::Dh, Param::Alpha(0), Param::Alpha(0)).unwrap();
        assert!((k - d_alpha).amax() < 1e-15, "K = {k}");
        assert!((l - d2_alpha * 0.5).amax() < 1e-15, "L = {l}");
    }
}

/// With the paper's literal `L_ij = ∂²T/∂p_i∂p_j` (no ½), the "second-order"
/// prediction is wrong at second order: its residual scales as ε², not ε³.
#[test]
fn without_the_half_the_residual_is_second_order() {
    let links = [
        Link::new(JointType::Revolute, 0.1, 0.4, 0.3, 1.2),
        Link::new(JointType::Revolute, -0.5, 0.1, 0.5, -0.4),
        Link::new(JointType::Prismatic, 0.7, 0.2, 0.1, 0.9),
    ];
    let robot = Robot::new(Convention::Dh, &links).unwrap();
    let q = [0.4, -0.9, 0.25];
    let residual = |eps: f64| {
        let errors: Vec<(Param, f64)> = robot
            .params()
            .enumerate()
            .map(|(i, p)| (p, eps * if i % 2 == 0 { 1.0 } else { -0.7 }))
            .collect();
        let exact = perturbed(&robot, &errors)
            .forward(&q)
            .unwrap()
            .to_homogeneous();
        let pert = robot.perturbation(&q, &errors).unwrap();
        let literal = pert.frame_first_order() + pert.second * 2.0 * pert.nominal.to_homogeneous();
        (exact - literal).norm()
    };
    let ratio = residual(5e-4) / residual(1e-3);
    // Leading term ε² (ratio 1/4) up to a relative O(ε) ≈ 1e-2 from the next order.
    assert!((ratio * 4.0 - 1.0).abs() < 2e-2, "ratio {ratio}");
}

#[test]
fn a_parameter_of_a_missing_joint_is_refused() {
    let robot = Robot::new(
        Convention::Mdh,
        &[Link::new(JointType::Revolute, 0.0, 0.1, 0.2, 0.3)],
    )
    .unwrap();
    let err = robot
        .perturbation(&[0.0], &[(Param::A(1), 1e-3)])
        .unwrap_err();
    assert_eq!(
        err,
        PerturbationError::NoSuchJoint {
            param: Param::A(1),
            joints: 1
        }
    );
    assert!(err.to_string().contains("a2"), "{err}");
    assert!(matches!(
        robot.perturbation(&[0.0, 1.0], &[]),
        Err(PerturbationError::Model(_))
    ));
}

/// The firmware runs the same code in f32: it agrees with f64 to the f32
/// rounding of the chain (`k ε₃₂ L` per unit error, as in `jacobian_fd.rs`).
#[test]
fn f32_expansion_agrees_with_f64() {
    let links = [
        Link::new(JointType::Revolute, 0.1, 0.4, 0.3, 1.2),
        Link::new(JointType::Revolute, -0.5, 0.1, 0.5, -0.4),
        Link::new(JointType::Revolute, 0.2, -0.3, 0.2, 0.8),
    ];
    let robot = Robot::new(Convention::Mdh, &links).unwrap();
    let q = [0.4, -0.9, 1.3];
    let errors: Vec<(Param, f64)> = robot
        .params()
        .enumerate()
        .map(|(i, p)| (p, 1e-3 * (1.0 + i as f64 % 3.0)))
        .collect();
    let e32: Vec<(Param, f32)> = errors.iter().map(|&(p, d)| (p, d as f32)).collect();
    let p64 = robot.perturbation(&q, &errors).unwrap();
    let p32 = robot
        .cast::<f32>()
        .perturbation(&q.map(|x| x as f32), &e32)
        .unwrap();
    let l = reach(&robot, &q);
    let n = errors.len() as f64;
    // Each of the N terms carries the chain's rounding k ε₃₂ L times |Δp| ≤ 3e-3.
    let tol = 16.0 * 5.0 * f32::EPSILON as f64 * l * n * 3e-3;
    let d1 = (p64.first - p32.first.cast::<f64>()).amax();
    let d2 = (p64.second - p32.second.cast::<f64>()).amax();
    assert!(d1 <= tol && d2 <= tol, "{d1:e} {d2:e} > {tol:e}");
    let _: IsometryMatrix3<f32> = p32.nominal;
}
