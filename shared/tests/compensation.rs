//! The compensation never sends a wild command: for any finite command it returns
//! finite corrections within their bounds, in size and in change per tick; for a
//! non-finite one it returns the command itself and says so.

use armcal_shared::compensation::{Compensator, Fault, Limits};
use armcal_shared::{JointType, Param, Robot};
use proptest::prelude::*;

mod common;
use common::robot_strategy;

/// `robot` with every parameter moved by `scale` times a draw in [−1, 1].
fn calibrated(robot: &Robot<f64>, draws: &[f64], scale: f64) -> Robot<f64> {
    let mut out = robot.clone();
    let params: Vec<Param> = robot.params().collect();
    for (p, d) in params.iter().zip(draws.iter().cycle()) {
        *out.param_mut(*p).unwrap() += d * scale;
    }
    out
}

/// A bound plus the rounding of `q_cmd + correction` (two ulps of the larger).
fn within(q: f64, q_cmd: f64, centre: f64, bound: f64) -> bool {
    (q - q_cmd - centre).abs() <= bound + 4.0 * f64::EPSILON * q_cmd.abs().max(1.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn any_finite_command_gives_finite_bounded_corrections(
        (robot, q) in robot_strategy(),
        draws in prop::collection::vec(-1.0..1.0f64, 8..16),
        scale in prop_oneof![Just(1e-4), Just(1e-2), Just(0.3)],
        far in prop_oneof![Just(1.0), Just(1e3)],
        orientation in any::<bool>(),
        previous in prop::collection::vec(-0.2..0.2f64, 8),
    ) {
        let cal = calibrated(&robot, &draws, scale);
        let limits = Limits::default();
        let comp = Compensator::new(&robot, &cal, orientation, limits);
        let q_cmd: Vec<f64> = q.iter().map(|x| x * far).collect();
        // A previous correction is one this returned: within the size bound.
        let prev: Vec<f64> = previous[..robot.dof()]
            .iter()
            .zip(&robot.links)
            .map(|(p, l)| match l.joint {
                JointType::Revolute => p / 0.2 * limits.max_correction_angle,
                JointType::Prismatic => p / 0.2 * limits.max_correction_length,
            })
            .collect();
        let prev = &prev[..];
        for previous in [None, Some(prev)] {
            let c = comp.correct(&q_cmd, previous);
            prop_assert_eq!(c.q.len(), robot.dof());
            for (m, (qm, q0)) in c.q.iter().zip(&q_cmd).enumerate() {
                prop_assert!(qm.is_finite());
                let (max, change) = match robot.links[m].joint {
                    JointType::Revolute => (limits.max_correction_angle, limits.max_change_angle),
                    JointType::Prismatic => (limits.max_correction_length, limits.max_change_length),
                };
                prop_assert!(within(*qm, *q0, 0.0, max), "joint {}: {} from {}", m + 1, qm, q0);
                if let Some(p) = previous {
                    prop_assert!(within(*qm, *q0, p[m], change), "joint {}: change from {}", m + 1, p[m]);
                }
            }
        }
    }

    #[test]
    fn non_finite_commands_return_the_command(
        (robot, q) in robot_strategy(),
        which in 0usize..8,
        bad in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)],
    ) {
        let comp = Compensator::new(&robot, &robot, true, Limits::default());
        let mut q_cmd = q.clone();
        let i = which % q_cmd.len();
        q_cmd[i] = bad;
        let c = comp.correct(&q_cmd, None);
        prop_assert_eq!(c.fault, Some(Fault::NonFinite));
        for (a, b) in c.q.iter().zip(&q_cmd) {
            prop_assert_eq!(a.to_bits(), b.to_bits());
        }
        // A non-finite previous correction is refused the same way.
        let prev = vec![f64::NAN; q.len()];
        prop_assert_eq!(comp.correct(&q, Some(&prev)).fault, Some(Fault::NonFinite));
    }
}

/// A command of the wrong length is returned as it is, flagged.
#[test]
fn wrong_joint_count_is_flagged() {
    let robot = Robot::new(
        armcal_shared::Convention::Dh,
        &[armcal_shared::Link::new(JointType::Revolute, 0.0, 0.3, 0.2, 1.0); 3],
    )
    .unwrap();
    let comp = Compensator::new(&robot, &robot, false, Limits::default());
    assert_eq!(
        comp.correct(&[0.1, 0.2], None).fault,
        Some(Fault::JointCount)
    );
}
