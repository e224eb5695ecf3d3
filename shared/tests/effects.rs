//! The effect library: each correction is the physics its documentation states.

use armcal_shared::effects::{
    Approach, Context, Effect, EffectModel, approach_sign, gravity_torques,
};
use armcal_shared::{Convention, Frame, JointType, Link, LinkMass, Robot};
use nalgebra::Vector3;
use proptest::prelude::*;

mod common;
use common::robot_strategy;

/// A one-link arm whose joint axis is horizontal (gravity along the base's −y, as
/// for a robot mounted on a wall), with its centre of mass `d` out along the link:
/// the gravity torque is that of a pendulum, `τ = −m g d cos q` (zero hanging
/// straight down, largest horizontal).
#[test]
fn gravity_torque_of_a_horizontal_pendulum() {
    let mut link = Link::new(JointType::Revolute, 0.0, 0.0, 0.8, 0.0);
    let (m, d) = (3.0, 0.5);
    link.mass = Some(LinkMass {
        mass: m,
        com: Vector3::new(d - 0.8, 0.0, 0.0),
    });
    let mut robot = Robot::new(Convention::Dh, &[link]).unwrap();
    // The base pose does not matter: gravity is given in the base frame.
    robot.base = Frame {
        xyz: Vector3::new(1.0, 2.0, 3.0),
        rpy: Vector3::new(0.3, -0.2, 1.1),
    };
    robot.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    for q in [0.0f64, 0.4, 1.2, -2.0] {
        let chain = robot.chain(&[q]).unwrap();
        let tau = gravity_torques(&robot, &chain, 0.0)[0];
        let want = -m * 9.81 * d * q.cos();
        assert!((tau - want).abs() < 1e-12, "q = {q}: {tau} vs {want}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The gravity torque is the generalised force of gravity: `τ_j = −∂V/∂q_j`
    /// with the potential `V = −Σ m_k g · r_k` (payload included), checked by
    /// central differences (step 1e-6: truncation ~1e-12 · V''', rounding ~1e-10).
    #[test]
    fn gravity_torque_is_minus_the_gradient_of_the_potential(
        (robot, q) in robot_strategy(),
        masses in prop::collection::vec((0.1..10.0f64, prop::array::uniform3(-0.3..0.3f64)), 8),
        payload in 0.0..5.0f64,
    ) {
        let mut robot = robot;
        for (l, (m, c)) in robot.links.iter_mut().zip(&masses) {
            l.mass = Some(LinkMass { mass: *m, com: Vector3::from(*c) });
        }
        robot.gravity = Some(Vector3::new(0.3, -0.2, -9.81));
        let potential = |q: &[f64]| -> f64 {
            let chain = robot.chain(q).unwrap();
            let g = chain.base.rotation * robot.gravity.unwrap();
            let links: f64 = robot.links.iter().enumerate().map(|(k, l)| {
                let lm = l.mass.unwrap();
                -lm.mass * g.dot(&(chain.links[k] * nalgebra::Point3::from(lm.com)).coords)
            }).sum();
            links - payload * g.dot(&chain.point().coords)
        };
        let tau = gravity_torques(&robot, &robot.chain(&q).unwrap(), payload);
        let h = 1e-6;
        for j in 0..robot.dof() {
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[j] += h;
            qm[j] -= h;
            let numeric = -(potential(&qp) - potential(&qm)) / (2.0 * h);
            let scale = 1.0 + tau[j].abs();
            prop_assert!((tau[j] - numeric).abs() <= 1e-6 * scale, "joint {}: {} vs {}", j + 1, tau[j], numeric);
        }
    }

    /// Each joint effect is the stated correction of the reading: the model with
    /// the effect at `q` is the geometric model at `q + Δq`.
    #[test]
    fn joint_effects_add_their_stated_correction((robot, q) in robot_strategy(), k in 0.001..0.01f64, sign in prop_oneof![Just(-1i8), Just(1i8)]) {
        let j = q.len() - 1;
        let ctx = Context { temperature: None, payload: None, approach: q.iter().map(|_| sign).collect() };
        let cases = [
            (Effect::EncoderScale { joint: j, scale: k }, k * q[j]),
            (Effect::Backlash { joint: j, half_lost_motion: k }, k * f64::from(sign)),
            (
                Effect::GearTransmission { joint: j, first: [k, -k / 2.0], second: [k / 3.0, k / 4.0] },
                k * q[j].sin() - k / 2.0 * q[j].cos() + k / 3.0 * (2.0 * q[j]).sin() + k / 4.0 * (2.0 * q[j]).cos(),
            ),
        ];
        for (effect, dq) in cases {
            let model = EffectModel::new(robot.clone(), &[effect]).unwrap();
            let mut shifted = q.clone();
            shifted[j] += dq;
            let a = model.forward(&q, &ctx).unwrap().to_homogeneous();
            let b = robot.forward(&shifted).unwrap().to_homogeneous();
            prop_assert!((a - b).abs().max() < 1e-12, "{}", effect.name());
        }
    }

    /// Thermal expansion scales every link length by `1 + κ (T − T_ref)`, and
    /// nothing at the reference temperature or without a temperature.
    #[test]
    fn thermal_expansion_scales_the_links((robot, q) in robot_strategy(), t in -10.0..40.0f64) {
        let (kappa, reference) = (2.3e-5, 20.0);
        let model = EffectModel::new(robot.clone(), &[Effect::ThermalExpansion { coefficient: kappa, reference }]).unwrap();
        let mut scaled = robot.clone();
        for l in scaled.links.iter_mut() {
            l.a *= 1.0 + kappa * (t - reference);
            l.s *= 1.0 + kappa * (t - reference);
        }
        let ctx = |temperature| Context { temperature, ..Context::default() };
        let a = model.forward(&q, &ctx(Some(t))).unwrap().to_homogeneous();
        prop_assert!((a - scaled.forward(&q).unwrap().to_homogeneous()).abs().max() < 1e-13);
        let at_ref = model.forward(&q, &ctx(Some(reference))).unwrap().to_homogeneous();
        let unknown = model.forward(&q, &ctx(None)).unwrap().to_homogeneous();
        let plain = robot.forward(&q).unwrap().to_homogeneous();
        prop_assert!((at_ref - plain).abs().max() < 1e-15 && (unknown - plain).abs().max() == 0.0);
    }
}

/// A joint's approach sign is the sign of its change, and the sign it had when
/// the change is zero: a gear that holds stays on the flank it last approached.
#[test]
fn a_holding_joint_keeps_its_approach_sign() {
    for previous in [-1i8, 0, 1] {
        assert_eq!(approach_sign(0.3f64, previous), 1);
        assert_eq!(approach_sign(-1e-300f64, previous), -1);
        assert_eq!(approach_sign(f64::MIN_POSITIVE, previous), 1);
        assert_eq!(approach_sign(0.0f64, previous), previous);
        assert_eq!(approach_sign(-0.0f32, previous), previous);
        assert_eq!(approach_sign(2.5e-7f32, previous), 1);
    }
}

/// The rows of a single-joint sweep of a three-joint arm: the first row, a move
/// of joint 1 up and joint 3 down, then joint 2 moving up in four steps and down
/// in four while the others hold (joint 2 never moved before the sweep).
fn single_joint_sweep() -> Vec<[f64; 3]> {
    let mut rows = vec![[0.2, -0.4, 0.7], [0.5, -0.4, 0.3]];
    for step in (1..=4).chain((0..4).rev()) {
        rows.push([0.5, -0.4 + 0.1 * f64::from(step), 0.3]);
    }
    rows
}

/// A single-joint sweep: the first row has no history (every σ = 0); a joint
/// keeps the sign of its last move while it holds (joints 1 and 3 through the
/// whole sweep of joint 2), a joint that has not yet moved stays at 0 (joint 2
/// before the sweep), and the sweeping joint takes the sign of each step.
#[test]
fn single_joint_sweep_holds_the_other_joints_signs() {
    let mut approach = Approach::new();
    let signs: Vec<Vec<i8>> = single_joint_sweep()
        .iter()
        .map(|q| approach.next(q).to_vec())
        .collect();
    let mut want = vec![vec![0, 0, 0], vec![1, 0, -1]];
    want.extend((0..4).map(|_| vec![1, 1, -1]));
    want.extend((0..4).map(|_| vec![1, -1, -1]));
    assert_eq!(signs, want);
    // f32 readings give the same signs.
    let mut approach = Approach::new();
    for (q, want) in single_joint_sweep().iter().zip(&want) {
        let q32 = q.map(|x| x as f32);
        assert_eq!(&approach.next(&q32)[..], &want[..]);
    }
}

/// Along a single-joint sweep, a model with backlash `b_j` on every joint puts
/// each joint at `q_j + b_j σ_j`, `σ_j` the direction of the joint's last move
/// before this row (found here by looking back along the rows), 0 before its
/// first move: the holding joints stay on their flank (±b), not in the middle.
#[test]
fn backlash_puts_a_holding_joint_on_the_flank_of_its_last_move() {
    let links = [
        Link::new(JointType::Revolute, 0.0, 0.3, 0.4, 1.2),
        Link::new(JointType::Revolute, 0.5, 0.0, 0.6, -0.4),
        Link::new(JointType::Revolute, -0.2, 0.1, 0.3, 0.0),
    ];
    let robot = Robot::new(Convention::Dh, &links).unwrap();
    let b = [2e-3, -1e-3, 3e-3];
    let effects: Vec<Effect<f64>> = (0..3)
        .map(|joint| Effect::Backlash {
            joint,
            half_lost_motion: b[joint],
        })
        .collect();
    let model = EffectModel::new(robot.clone(), &effects).unwrap();
    let rows = single_joint_sweep();
    let mut approach = Approach::new();
    for (r, q) in rows.iter().enumerate() {
        let ctx = Context {
            approach: approach.next(q),
            ..Context::default()
        };
        let last_move = |j: usize| -> f64 {
            (1..=r)
                .rev()
                .map(|k| rows[k][j] - rows[k - 1][j])
                .find(|d| *d != 0.0)
                .map_or(0.0, f64::signum)
        };
        let reached: Vec<f64> = (0..3).map(|j| q[j] + b[j] * last_move(j)).collect();
        // Exact: the model adds 0 + 0 · q + b σ to each reading.
        let a = model.forward(q, &ctx).unwrap();
        assert_eq!(a, robot.forward(&reached).unwrap(), "row {r}");
        if r >= 2 {
            // Joints 1 and 3 hold through the sweep, on their flanks.
            assert_eq!((reached[0], reached[2]), (q[0] + b[0], q[2] - b[2]));
        }
    }
}

/// An effect on a joint the model lacks is refused.
#[test]
fn effects_on_missing_joints_are_refused() {
    let robot = Robot::new(
        Convention::Dh,
        &[Link::new(JointType::Revolute, 0.0, 0.1, 0.2, 0.3)],
    )
    .unwrap();
    assert!(
        EffectModel::new(
            robot,
            &[Effect::Backlash {
                joint: 1,
                half_lost_motion: 1e-3
            }]
        )
        .is_err()
    );
}
