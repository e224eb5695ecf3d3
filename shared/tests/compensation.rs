//! The compensation never sends a wild command: for any finite command it returns
//! finite corrections within their bounds, in size and in change per tick; for a
//! non-finite one it returns the command itself and says so. With
//! non-geometric effects, the corrected commands make the calibrated model with
//! its effects, in the tick's context, reach the nominal model's pose.

use armcal_shared::compensation::{Compensator, Conditions, Fault, Limits, Previous, Workspace};
use armcal_shared::effects::{Approach, Context, Effect, EffectModel, one_of_each};
use armcal_shared::{Convention, JointType, Link, Param, Robot};
use nalgebra::IsometryMatrix3;
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
        // The previous tick commanded q_cmd too and sent q_cmd + prev.
        let sent: Vec<f64> = q_cmd.iter().zip(&prev).map(|(q, p)| q + p).collect();
        let last = Previous { q_cmd: &q_cmd, q: &sent, p: &sent };
        let prev = &prev[..];
        for previous in [None, Some(prev)] {
            let c = comp.correct(&q_cmd, previous.map(|_| last), &Conditions::default());
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
        let none = Conditions::default();
        let c = comp.correct(&q_cmd, None, &none);
        prop_assert_eq!(c.fault, Some(Fault::NonFinite));
        for (a, b) in c.q.iter().zip(&q_cmd) {
            prop_assert_eq!(a.to_bits(), b.to_bits());
        }
        // A non-finite previous command, temperature or payload is refused the same way.
        let prev = vec![f64::NAN; q.len()];
        let last = Some(Previous { q_cmd: &q, q: &prev, p: &q });
        prop_assert_eq!(comp.correct(&q, last, &none).fault, Some(Fault::NonFinite));
        for conditions in [
            Conditions { temperature: Some(bad), payload: None },
            Conditions { temperature: None, payload: Some(bad) },
        ] {
            prop_assert_eq!(comp.correct(&q, None, &conditions).fault, Some(Fault::NonFinite));
        }
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
        comp.correct(&[0.1, 0.2], None, &Conditions::default())
            .fault,
        Some(Fault::JointCount)
    );
}

/// One effect of each kind on `dof` joints, from draws in [−1, 1]: magnitudes up
/// to (and, for compliance with 8 links of proxy torque, beyond) what real arms show.
fn random_effects(dof: usize, d: &[f64]) -> Vec<Effect<f64>> {
    let joint = |x: f64| ((x + 1.0) * 0.5 * dof as f64) as usize % dof;
    vec![
        Effect::JointCompliance {
            joint: joint(d[0]),
            compliance: 1e-4 * d[1],
        },
        Effect::GearTransmission {
            joint: joint(d[2]),
            first: [1e-3 * d[3], 1e-3 * d[4]],
            second: [1e-3 * d[5], 1e-3 * d[6]],
        },
        Effect::Backlash {
            joint: joint(d[7]),
            half_lost_motion: 1e-3 * d[8].abs(),
        },
        Effect::ThermalExpansion {
            coefficient: 1e-4 * d[9],
            reference: 20.0,
        },
        Effect::EncoderScale {
            joint: joint(d[10]),
            scale: 1e-3 * d[11],
        },
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// With every kind of effect, in any finite conditions, the corrections are
    /// finite and within their bounds, in size and in change per tick.
    #[test]
    fn effects_give_finite_bounded_corrections(
        (robot, q) in robot_strategy(),
        draws in prop::collection::vec(-1.0..1.0f64, 12),
        temperature in -20.0..80.0f64,
        payload in 0.0..20.0f64,
        step in prop::collection::vec(-0.05..0.05f64, 8),
    ) {
        let model = EffectModel::new(robot.clone(), &random_effects(robot.dof(), &draws)).unwrap();
        let limits = Limits::default();
        let comp = Compensator::with_effects(&robot, model, true, limits);
        let conditions = Conditions { temperature: Some(temperature), payload: Some(payload) };
        let first = comp.correct(&q, None, &conditions);
        let q_cmd: Vec<f64> = q.iter().zip(&step).map(|(q, s)| q + s).collect();
        let last = Previous { q_cmd: &q, q: &first.q, p: &first.p };
        let c = comp.correct(&q_cmd, Some(last), &conditions);
        for (m, link) in robot.links.iter().enumerate() {
            let (max, change) = match link.joint {
                JointType::Revolute => (limits.max_correction_angle, limits.max_change_angle),
                JointType::Prismatic => (limits.max_correction_length, limits.max_change_length),
            };
            prop_assert!(first.q[m].is_finite() && c.q[m].is_finite());
            prop_assert!(within(first.q[m], q[m], 0.0, max));
            prop_assert!(within(c.q[m], q_cmd[m], 0.0, max));
            prop_assert!(within(c.q[m], q_cmd[m], first.q[m] - q[m], change));
        }
    }
}

/// A UR10e (standard D-H, the maker's table, m and rad) without masses: the
/// gravity torques are the proxy of 1 kg at each link frame.
fn ur10e() -> Robot<f64> {
    let pi2 = std::f64::consts::FRAC_PI_2;
    let d = [0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655];
    let a = [0.0, -0.6127, -0.57155, 0.0, 0.0, 0.0];
    let alpha = [pi2, 0.0, 0.0, pi2, -pi2, 0.0];
    let links: Vec<Link<f64>> = (0..6)
        .map(|m| Link::new(JointType::Revolute, 0.0, d[m], a[m], alpha[m]))
        .collect();
    Robot::new(Convention::Dh, &links).unwrap()
}

/// The UR10e with the joint errors of the FIGAROH data set (as the firmware's
/// benchmark), millimetres and milliradians.
fn calibrated_ur10e() -> Robot<f64> {
    let mut robot = ur10e();
    for (param, error) in [
        (Param::Alpha(0), 1.031e-3),
        (Param::Theta(1), -6.23e-4),
        (Param::S(1), 1.511e-3),
        (Param::A(1), -6.03e-3),
        (Param::Theta(2), 9.79e-4),
        (Param::A(2), -5.337e-3),
        (Param::Alpha(2), -8.031e-3),
        (Param::Theta(4), 1.514e-3),
        (Param::Alpha(4), 2.613e-3),
    ] {
        *robot.param_mut(param).unwrap() += error;
    }
    robot
}

/// 35 °C (15 °C above the reference) and a 5 kg payload.
const WARM_LOADED: Conditions<f64> = Conditions {
    temperature: Some(35.0),
    payload: Some(5.0),
};

/// Twelve 1 kHz ticks away from singularities: every joint moves by 2 mrad per
/// tick, joint 4 forwards for six ticks and then back (both approach directions,
/// each move 2 mrad, well beyond its lost motion of 0.3 mrad).
fn trajectory() -> Vec<Vec<f64>> {
    let q0 = [1.589, 0.578, -1.675, 0.351, 1.784, 2.232];
    (0..12)
        .map(|t| {
            q0.iter()
                .enumerate()
                .map(|(m, q)| {
                    let ticks = if m == 3 && t > 6 { 12 - t } else { t };
                    q + 2e-3 * ticks as f64
                })
                .collect()
        })
        .collect()
}

/// The norm the compensation lowers: the orientation error times 1 m and the
/// position error, m.
fn pose_residual(a: &IsometryMatrix3<f64>, b: &IsometryMatrix3<f64>) -> f64 {
    let dp = a.translation.vector - b.translation.vector;
    let dr = armcal_shared::rotation_error(&a.rotation, &b.rotation);
    (dp.norm_squared() + dr.norm_squared()).sqrt()
}

/// Runs `comp` along `commands` in `conditions`, each tick with the previous
/// one as sent and its workspace (as a controller does); returns each correction and the context the calibrated model
/// evaluates its commands in (approach from the commands sent).
fn run<T: armcal_shared::Real>(
    comp: &Compensator<T>,
    commands: &[Vec<f64>],
    conditions: Conditions<f64>,
) -> Vec<(Vec<f64>, Option<Fault>, Context<f64>)> {
    let cast = |v: &[f64]| v.iter().map(|x| T::lit(*x)).collect::<Vec<T>>();
    let conditions = Conditions {
        temperature: conditions.temperature.map(T::lit),
        payload: conditions.payload.map(T::lit),
    };
    let mut out = Vec::new();
    let mut last: Option<(Vec<T>, Vec<T>, Vec<T>)> = None;
    let mut work = Workspace::new();
    let mut approach = Approach::new();
    for q_cmd in commands {
        let q_cmd = cast(q_cmd);
        let previous = last.as_ref().map(|(q_cmd, q, p)| Previous { q_cmd, q, p });
        let c = comp.correct_with(&q_cmd, previous, &conditions, &mut work);
        let q: Vec<f64> = c.q.iter().map(|x| x.to_f64()).collect();
        let ctx = Context {
            temperature: conditions.temperature.map(|x| x.to_f64()),
            payload: conditions.payload.map(|x| x.to_f64()),
            approach: approach.next(&q),
        };
        out.push((q, c.fault, ctx));
        last = Some((q_cmd, c.q.to_vec(), c.p.to_vec()));
    }
    out
}

/// The largest error of commands `q` (each in its context) against the targets.
fn worst_miss(
    nominal: &Robot<f64>,
    model: &EffectModel<f64>,
    commands: &[Vec<f64>],
    run: &[(Vec<f64>, Option<Fault>, Context<f64>)],
) -> f64 {
    commands
        .iter()
        .zip(run)
        .map(|(q_cmd, (q, _, ctx))| {
            let target = nominal.forward(q_cmd).unwrap();
            pose_residual(&target, &model.forward(q, ctx).unwrap())
        })
        .fold(0.0, f64::max)
}

/// Each effect of [`one_of_each`] alone (the compliance with the proxy torques of
/// a model without masses, about 30 N·m and 90 N·m with the payload: 0.2 mrad),
/// and all together, at 35 °C with 5 kg: the corrected
/// commands make the calibrated model with its effects, in the context they are
/// sent in (approach from the previous command sent), reach the nominal pose.
///
/// Tolerance, derived: the geometric step leaves at most `Limits::tolerance`
/// (1 nm); the inversion stops when no joint changes by more than 1 nm/(1 m) =
/// 1e-9 rad, and the error left is that change times the contraction of the
/// fixed point (about 1e-3), so at most 1e-9 rad per joint, which moves the pose
/// by at most 1e-9 × 1.6 m (the UR10e's reach, the orientation at 1 m) per joint:
/// 1 nm + 6 × 1.6 nm ≈ 11 nm. The geometric compensation alone misses by more
/// than a micrometre with every effect (so the test tests something).
#[test]
fn effects_are_compensated_in_context() {
    let nominal = ur10e();
    let commands = trajectory();
    let limits = Limits::default();
    let geometric = Compensator::new(&nominal, &calibrated_ur10e(), true, limits);
    let mut sets: Vec<Vec<Effect<f64>>> = one_of_each().iter().map(|e| vec![*e]).collect();
    sets.push(one_of_each().to_vec());
    for effects in sets {
        let model = EffectModel::new(calibrated_ur10e(), &effects).unwrap();
        let comp = Compensator::with_effects(&nominal, model.clone(), true, limits);
        let corrected = run(&comp, &commands, WARM_LOADED);
        assert!(
            corrected.iter().all(|(_, fault, _)| fault.is_none()),
            "{effects:?}"
        );
        let miss = worst_miss(&nominal, &model, &commands, &corrected);
        assert!(miss <= 1.1e-8, "{effects:?}: misses by {miss:e} m");
        let plain = run(&geometric, &commands, WARM_LOADED);
        let plain_miss = worst_miss(&nominal, &model, &commands, &plain);
        assert!(plain_miss > 1e-6, "{effects:?}: {plain_miss:e} m");
        // Both approach directions of the backlash joint occurred.
        let signs: Vec<i8> = corrected
            .iter()
            .map(|(_, _, ctx)| ctx.approach[3])
            .collect();
        assert!(signs.contains(&1) && signs.contains(&-1), "{signs:?}");
    }
}

/// The controller's f32 corrections with every effect put the tool within 2 µm
/// of where the f64 ones put it (f32 rounding of a 1.6 m chain is about 0.2 µm
/// per evaluation; the f32 tolerance is 0.95 µm).
#[test]
fn f32_with_effects_agrees_with_f64_within_two_micrometres() {
    let nominal = ur10e();
    let commands = trajectory();
    let effects = one_of_each();
    let model = EffectModel::new(calibrated_ur10e(), &effects).unwrap();
    let c64 = Compensator::with_effects(&nominal, model.clone(), true, Limits::default());
    let effects32: Vec<Effect<f32>> = effects.iter().map(|e| e.cast()).collect();
    let model32 = EffectModel::new(calibrated_ur10e().cast(), &effects32).unwrap();
    let c32 = Compensator::with_effects(&nominal.cast(), model32, true, Limits::default());
    let a = run(&c64, &commands, WARM_LOADED);
    let b = run(&c32, &commands, WARM_LOADED);
    for ((qa, _, ctx_a), (qb, fault, ctx_b)) in a.iter().zip(&b) {
        assert_eq!(*fault, None);
        let pa = model.forward(qa, ctx_a).unwrap();
        let pb = model.forward(qb, ctx_b).unwrap();
        let apart = (pa.translation.vector - pb.translation.vector).norm();
        assert!(apart <= 2e-6, "{apart:e} m apart");
    }
}

/// A joint that reverses by less than its lost motion after moving forwards
/// would have to stay within the lost motion, which the backlash model
/// (approach 0 when not moving, the mid-point) cannot reach: it is held at its
/// previous command, the pose is missed by at most half the lost motion (and
/// the reversal) at the joint's lever, and the correction is flagged with that
/// residual.
#[test]
fn a_joint_within_its_lost_motion_is_held_and_flagged() {
    let nominal = ur10e();
    let half_lost_motion = 1.5e-4;
    let backlash = Effect::Backlash {
        joint: 3,
        half_lost_motion,
    };
    let model = EffectModel::new(calibrated_ur10e(), &[backlash]).unwrap();
    let comp = Compensator::with_effects(&nominal, model.clone(), true, Limits::default());
    let mut commands = trajectory()[..4].to_vec();
    let reversal = 1e-5;
    let mut back = commands[3].clone();
    back[3] -= reversal;
    commands.push(back);
    let corrected = run(&comp, &commands, Conditions::default());
    let (q, fault, ctx) = &corrected[4];
    assert_eq!(*fault, Some(Fault::NotConverged));
    assert_eq!(q[3], corrected[3].0[3], "held");
    assert_eq!(ctx.approach[3], 0);
    // The lever of joint 4 to the tool is under 0.3 m (d5, d6, the wrist);
    // the orientation error is the angle itself, weighed at 1 m.
    let miss = worst_miss(&nominal, &model, &commands[4..], &corrected[4..]);
    assert!(
        miss > 1e-5 && miss <= (half_lost_motion + reversal) * (1.0f64 + 0.3).hypot(0.3),
        "{miss:e}"
    );
}

/// The residual the compensation lowers, as it defines it: the vector of the
/// skew-symmetric part of `R_target R_reachedᵀ` (eq. 15's `νdφ`) times the
/// length scale, and the position error.
fn skew_residual(target: &IsometryMatrix3<f64>, reached: &IsometryMatrix3<f64>, ls: f64) -> f64 {
    let (t, r) = (target.rotation.matrix(), reached.rotation.matrix());
    let mut phi = nalgebra::Vector3::zeros();
    for i in 0..3 {
        phi += r.column(i).cross(&t.column(i)) * 0.5;
    }
    let dp = target.translation.vector - reached.translation.vector;
    ((phi * ls).norm_squared() + dp.norm_squared()).sqrt()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// A step taken on its bound (without evaluating the chain after it) is
    /// within that bound: the calibrated model at the returned joint positions
    /// misses the target by no more than the residual reported. Random robots
    /// (both conventions, revolute and prismatic joints, 1–8 joints), parameter
    /// errors of 0.1 to 10 mm/mrad, full pose and position only, with and
    /// without joint effects (whose offsets the warm ticks predict), cold (from
    /// the command) and two warm ticks (from the previous tick's correction
    /// after a move of 1 mrad per joint, with its factors), at a tolerance of
    /// 1 µm so that the bound decides.
    #[test]
    fn a_step_taken_on_its_bound_is_within_it(
        (robot, q) in robot_strategy(),
        draws in prop::collection::vec(-1.0..1.0f64, 8..16),
        effect_draws in prop::collection::vec(-1.0..1.0f64, 12),
        scale in prop_oneof![Just(1e-4), Just(1e-3), Just(1e-2)],
        orientation in any::<bool>(),
        effects in any::<bool>(),
    ) {
        let cal = calibrated(&robot, &draws, scale);
        let limits = Limits { tolerance: 1e-6, ..Limits::default() };
        let list = if effects { random_effects(robot.dof(), &effect_draws) } else { Vec::new() };
        let model = EffectModel::new(cal.clone(), &list).unwrap();
        let comp = Compensator::with_effects(&robot, model, orientation, limits);
        let mut work = Workspace::new();
        let mut ticks: Vec<(Vec<f64>, armcal_shared::compensation::Correction<f64>)> = Vec::new();
        for t in 0..3 {
            let q_cmd: Vec<f64> = q.iter().map(|x| x + 1e-3 * t as f64).collect();
            let previous = ticks.last().map(|(q_cmd, c)| Previous { q_cmd, q: &c.q, p: &c.p });
            let c = comp.correct_with(&q_cmd, previous, &Conditions::default(), &mut work);
            ticks.push((q_cmd, c));
        }
        for (q_cmd, c) in &ticks {
            if c.fault.is_some() {
                continue;
            }
            let target = robot.forward(q_cmd).unwrap();
            let reached = cal.forward(&c.p).unwrap();
            let miss = if orientation {
                skew_residual(&target, &reached, limits.length_scale)
            } else {
                (target.translation.vector - reached.translation.vector).norm()
            };
            // The bound is on exact arithmetic; evaluating the chain rounds by
            // a few ε of a metre.
            prop_assert!(
                miss <= c.residual + 1e-14,
                "misses by {:e}, reported {:e}", miss, c.residual
            );
        }
    }
}
