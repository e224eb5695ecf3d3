//! Forward kinematics of the PUMA of Mirman & Gupta, Table 1, at its six
//! positions, against values derived independently by
//! `tests/reference/puma_table1.py` (plain Python floats, eq. 5 written out entry
//! by entry, no code shared with this crate).
//!
//! Units: inches and radians, as in the table; no base, no tool, offsets zero.
//! Tolerance: both sides round about `k = 16 (M + 2) = 128` times in f64 on
//! numbers bounded by the sum of the lengths `L = 70.25 in`, so entries agree to
//! `k ε L ≈ 2e-12 in` (positions) and `k ε ≈ 3e-14` (rotations).

use armcal_shared::{Convention, JointType, Link, Robot};

/// Table 1: (s, alpha, a) of links 1..6, inches and radians, as printed: the
/// six-decimal twists are the paper's data, not approximations of π/2 and π.
#[allow(clippy::approx_constant)]
const TABLE1_LINKS: [(f64, f64, f64); 6] = [
    (26.0, 1.570796, 0.0),
    (-8.0, 0.0, 17.0),
    (0.0, 1.570796, 0.0),
    (17.0, 1.570796, 0.0),
    (0.0, 1.570796, 0.0),
    (-2.25, 3.141593, 0.0),
];

#[allow(clippy::approx_constant)] // Table 1 positions as printed (0.7854 is not π/4 here).
mod reference {
    include!("../../tests/reference/puma_table1.rs");
}
use reference::{TABLE1_FK, TABLE1_POSITIONS};

fn puma() -> Robot<f64> {
    let links: Vec<Link<f64>> = TABLE1_LINKS
        .iter()
        .map(|&(s, alpha, a)| Link::new(JointType::Revolute, 0.0, s, a, alpha))
        .collect();
    Robot::new(Convention::Dh, &links).unwrap()
}

#[test]
fn table1_forward_kinematics_matches_independent_derivation() {
    let robot = puma();
    let l: f64 = TABLE1_LINKS.iter().map(|(s, _, a)| s.abs() + a.abs()).sum();
    let k = 16.0 * (6.0 + 2.0);
    let (tol_rot, tol_pos) = (k * f64::EPSILON, k * f64::EPSILON * l);
    for (i, (q, want)) in TABLE1_POSITIONS.iter().zip(&TABLE1_FK).enumerate() {
        let t = robot.forward(q).unwrap().to_homogeneous();
        for r in 0..3 {
            for c in 0..4 {
                let tol = if c == 3 { tol_pos } else { tol_rot };
                assert!(
                    (t[(r, c)] - want[r][c]).abs() <= tol,
                    "position {}: A_h[{r}][{c}] = {} but the reference is {} (tol {tol:e})",
                    i + 1,
                    t[(r, c)],
                    want[r][c]
                );
            }
        }
    }
}

/// The measured point of the chain is the same as `forward`'s origin, and the
/// f32 model the controller runs reaches it to f32 precision (`k ε L`).
#[test]
fn table1_in_f32_agrees() {
    let robot = puma();
    let r32 = robot.cast::<f32>();
    for (q, want) in TABLE1_POSITIONS.iter().zip(&TABLE1_FK) {
        let q32: Vec<f32> = q.iter().map(|&x| x as f32).collect();
        let p = r32.chain(&q32).unwrap().point();
        for r in 0..3 {
            // Inputs rounded to f32 add 4 ε per link (angles up to π): k = 128 + 24π.
            let tol = (128.0 + 24.0 * std::f64::consts::PI) * f32::EPSILON as f64 * 70.25;
            assert!(
                (p[r] as f64 - want[r][3]).abs() <= tol,
                "{} vs {}",
                p[r],
                want[r][3]
            );
        }
    }
}
