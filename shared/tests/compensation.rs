//! The compensation never sends a wild command: for any finite command it returns
//! finite corrections within their bounds, in size and in change per tick; for a
//! non-finite one it returns the command itself and says so. With
//! non-geometric effects, the corrected commands make the calibrated model with
//! its effects, in the tick's context, reach the nominal model's pose. A
//! correction is a function of the command and its context: a servo stream
//! gives, at every tick it does not clip, the correction of the command alone,
//! and does not drift.

use armcal_shared::compensation::{
    Compensator, Conditions, Correction, Fault, Limits, Pacing, Stream, Task,
};
use armcal_shared::effects::{Approach, Context, Effect, EffectModel, one_of_each};
use armcal_shared::{Convention, JointType, Link, Param, Real, Robot, rotation_error};
use nalgebra::IsometryMatrix3;
use proptest::prelude::*;

mod common;
use common::robot_strategy;

/// The task of a calibration from full poses (`orientation`) or positions.
fn task_of(orientation: bool) -> Task {
    if orientation {
        Task::Pose
    } else {
        Task::Position
    }
}

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

/// The size and change bounds of joint `m` of `robot`: (size, change).
fn bounds(robot: &Robot<f64>, m: usize, limits: &Limits<f64>) -> (f64, f64) {
    match robot.links[m].joint {
        JointType::Revolute => (limits.max_correction_angle, limits.max_change_angle),
        JointType::Prismatic => (limits.max_correction_length, limits.max_change_length),
    }
}

/// Each joint's approach direction after sending `q`, the previous tick having
/// sent `previous` with directions `signs`: the sign of the move, or, for a joint
/// that did not move, the direction it had (a gear stays on the flank it last
/// approached from); 0 only before a joint's first move. The tick's convention
/// ([`armcal_shared::compensation::inversion`]).
fn held_signs(previous: Option<(&[f64], &[i8])>, q: &[f64]) -> Vec<i8> {
    q.iter()
        .enumerate()
        .map(|(j, qj)| match previous {
            None => 0,
            Some((sent, signs)) => {
                let d = qj - sent[j];
                if d > 0.0 {
                    1
                } else if d < 0.0 {
                    -1
                } else {
                    signs[j]
                }
            }
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Any finite command, alone or after a previous tick of a servo stream
    /// that was sent (a command up to 0.2 rad or 50 mm away), gets finite
    /// corrections within the size bound, and within the change bound of the
    /// previous tick's sent correction; parameter errors up to 0.3 (so that
    /// corrections reach their size bound), commands up to 3000 rad.
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
        let comp = Compensator::new(&robot, &cal, task_of(orientation), limits);
        let q_cmd: Vec<f64> = q.iter().map(|x| x * far).collect();
        // The previous tick's command: up to 0.2 rad (50 mm) away.
        let q_prev: Vec<f64> = q_cmd
            .iter()
            .zip(&previous)
            .zip(&robot.links)
            .map(|((q, d), l)| match l.joint {
                JointType::Revolute => q - d,
                JointType::Prismatic => q - d / 0.2 * limits.max_correction_length,
            })
            .collect();
        let none = Conditions::default();
        let alone = comp.correct(&q_cmd, &none);
        let mut stream = Stream::new(Pacing::Servo);
        let first = stream.tick(&comp, &q_prev, &none);
        let c = stream.tick(&comp, &q_cmd, &none);
        for x in [&alone, &first, &c] {
            prop_assert_eq!(x.q.len(), robot.dof());
        }
        for m in 0..robot.dof() {
            let (max, change) = bounds(&robot, m, &limits);
            for (x, q0) in [(&alone, &q_cmd), (&first, &q_prev), (&c, &q_cmd)] {
                prop_assert!(x.q[m].is_finite());
                prop_assert!(within(x.q[m], q0[m], 0.0, max), "joint {}: {} from {}", m + 1, x.q[m], q0[m]);
            }
            let sent = first.q[m] - q_prev[m];
            prop_assert!(
                within(c.q[m], q_cmd[m], sent, change),
                "joint {}: {} from {}, the previous correction {}", m + 1, c.q[m], q_cmd[m], sent
            );
        }
    }

    /// A non-finite command, temperature or payload returns the command itself,
    /// flagged; a stream forgets such a tick (the next is a first tick).
    #[test]
    fn non_finite_commands_return_the_command(
        (robot, q) in robot_strategy(),
        which in 0usize..8,
        bad in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)],
    ) {
        let comp = Compensator::new(&robot, &robot, Task::Pose, Limits::default());
        let mut q_cmd = q.clone();
        let i = which % q_cmd.len();
        q_cmd[i] = bad;
        let none = Conditions::default();
        let c = comp.correct(&q_cmd, &none);
        prop_assert_eq!(c.fault, Some(Fault::NonFinite));
        for (a, b) in c.q.iter().zip(&q_cmd) {
            prop_assert_eq!(a.to_bits(), b.to_bits());
        }
        // In a stream, after a sent tick: refused the same way, and the next
        // command is a first tick, the command alone.
        let mut stream = Stream::new(Pacing::Servo);
        stream.tick(&comp, &q, &none);
        let c = stream.tick(&comp, &q_cmd, &none);
        prop_assert_eq!(c.fault, Some(Fault::NonFinite));
        for (a, b) in c.q.iter().zip(&q_cmd) {
            prop_assert_eq!(a.to_bits(), b.to_bits());
        }
        let after = stream.tick(&comp, &q, &none);
        let alone = comp.correct(&q, &none);
        prop_assert_eq!(&after.q, &alone.q);
        prop_assert_eq!(after.fault, alone.fault);
        for conditions in [
            Conditions { temperature: Some(bad), payload: None },
            Conditions { temperature: None, payload: Some(bad) },
        ] {
            prop_assert_eq!(comp.correct(&q, &conditions).fault, Some(Fault::NonFinite));
            prop_assert_eq!(stream.tick(&comp, &q, &conditions).fault, Some(Fault::NonFinite));
        }
    }
}

/// A command of the wrong length is returned as it is, flagged.
#[test]
fn wrong_joint_count_is_flagged() {
    let robot = Robot::new(
        Convention::Dh,
        &[Link::new(JointType::Revolute, 0.0, 0.3, 0.2, 1.0); 3],
    )
    .unwrap();
    let comp = Compensator::new(&robot, &robot, Task::Position, Limits::default());
    let none = Conditions::default();
    let c = comp.correct(&[0.1, 0.2], &none);
    assert_eq!(c.fault, Some(Fault::JointCount));
    assert_eq!(&c.q[..], &[0.1, 0.2]);
    let mut stream = Stream::new(Pacing::Servo);
    stream.tick(&comp, &[0.1, 0.2, 0.3], &none);
    assert_eq!(
        stream.tick(&comp, &[0.1, 0.2], &none).fault,
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
    /// finite and within their bounds, in size and in change per tick (a servo
    /// stream's second tick, after a move of up to 50 mrad).
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
        let comp = Compensator::with_effects(&robot, model, Task::Pose, limits);
        let conditions = Conditions { temperature: Some(temperature), payload: Some(payload) };
        let mut stream = Stream::new(Pacing::Servo);
        let first = stream.tick(&comp, &q, &conditions);
        let q_cmd: Vec<f64> = q.iter().zip(&step).map(|(q, s)| q + s).collect();
        let c = stream.tick(&comp, &q_cmd, &conditions);
        for m in 0..robot.dof() {
            let (max, change) = bounds(&robot, m, &limits);
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

/// The UR10e's start of [`trajectory`], away from singularities.
const UR10E_START: [f64; 6] = [1.589, 0.578, -1.675, 0.351, 1.784, 2.232];

/// Twelve 1 kHz ticks away from singularities: every joint moves by 2 mrad per
/// tick, joint 4 forwards for six ticks and then back (both approach directions,
/// each move 2 mrad, well beyond its lost motion of 0.3 mrad).
fn trajectory() -> Vec<Vec<f64>> {
    (0..12)
        .map(|t| {
            UR10E_START
                .iter()
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
    let dr = rotation_error(&a.rotation, &b.rotation);
    (dp.norm_squared() + dr.norm_squared()).sqrt()
}

/// One tick of [`run`]: the commands sent, the fault, the context the
/// calibrated model evaluates them in, and the joint positions aimed at.
struct Sent {
    q: Vec<f64>,
    fault: Option<Fault>,
    ctx: Context<f64>,
    p: Vec<f64>,
}

/// Runs `comp` along `commands` in `conditions` through one servo stream (as a
/// controller does); returns each tick as sent, with the context the calibrated
/// model evaluates its commands in: the approach direction of each joint from
/// the commands sent, held when a joint does not move (the tick's convention,
/// [`held_signs`]), which must be the fit's ([`Approach`]).
fn run<T: Real>(
    comp: &Compensator<T>,
    commands: &[Vec<f64>],
    conditions: Conditions<f64>,
) -> Vec<Sent> {
    let cast = |v: &[f64]| v.iter().map(|x| T::lit(*x)).collect::<Vec<T>>();
    let conditions_t = Conditions {
        temperature: conditions.temperature.map(T::lit),
        payload: conditions.payload.map(T::lit),
    };
    let mut stream = Stream::new(Pacing::Servo);
    let mut out: Vec<Sent> = Vec::new();
    let mut signs: Vec<i8> = Vec::new();
    let mut fit = Approach::new();
    for q_cmd in commands {
        let c = stream.tick(comp, &cast(q_cmd), &conditions_t);
        let q: Vec<f64> = c.q.iter().map(|x| x.to_f64()).collect();
        let previous = out.last().map(|s| (&s.q[..], &signs[..]));
        signs = held_signs(previous, &q);
        let approach = fit.next(&c.q);
        assert_eq!(&approach[..], &signs[..], "the fit's approach directions");
        let ctx = Context {
            temperature: conditions.temperature,
            payload: conditions.payload,
            approach,
        };
        let p = c.p.iter().map(|x| x.to_f64()).collect();
        out.push(Sent {
            q,
            fault: c.fault,
            ctx,
            p,
        });
    }
    out
}

/// The error of each tick's commands (in its context) against its target.
fn misses(
    nominal: &Robot<f64>,
    model: &EffectModel<f64>,
    commands: &[Vec<f64>],
    run: &[Sent],
) -> Vec<f64> {
    commands
        .iter()
        .zip(run)
        .map(|(q_cmd, s)| {
            let target = nominal.forward(q_cmd).unwrap();
            pose_residual(&target, &model.forward(&s.q, &s.ctx).unwrap())
        })
        .collect()
}

/// The largest error of commands `q` (each in its context) against the targets.
fn worst_miss(
    nominal: &Robot<f64>,
    model: &EffectModel<f64>,
    commands: &[Vec<f64>],
    run: &[Sent],
) -> f64 {
    misses(nominal, model, commands, run)
        .into_iter()
        .fold(0.0, f64::max)
}

/// The bound on the miss of a tick with joint effects, derived: the geometric
/// step leaves at most `Limits::tolerance` (1 nm); the inversion stops when no
/// joint changes by more than 1 nm/(1 m) = 1e-9 rad, and the error left is that
/// change times the contraction of the fixed point (about 1e-3), so at most
/// 1e-9 rad per joint, which moves the pose by at most 1e-9 × 1.6 m (the
/// UR10e's reach, the orientation at 1 m) per joint: 1 nm + 6 × 1.6 nm ≈ 11 nm.
const UR10E_EFFECTS_MISS: f64 = 1.1e-8;

/// Each effect of [`one_of_each`] alone (the compliance with the proxy torques of
/// a model without masses, about 30 N·m and 90 N·m with the payload: 0.2 mrad),
/// and all together, at 35 °C with 5 kg: the corrected commands of a servo
/// stream make the calibrated model with its effects, in the context they are
/// sent in (approach from the commands sent, held by a joint that does not
/// move), reach the nominal pose within [`UR10E_EFFECTS_MISS`]. The geometric
/// compensation alone misses by more than a micrometre with every effect (so
/// the test tests something).
#[test]
fn effects_are_compensated_in_context() {
    let nominal = ur10e();
    let commands = trajectory();
    let limits = Limits::default();
    let geometric = Compensator::new(&nominal, &calibrated_ur10e(), Task::Pose, limits);
    let mut sets: Vec<Vec<Effect<f64>>> = one_of_each().iter().map(|e| vec![*e]).collect();
    sets.push(one_of_each().to_vec());
    for effects in sets {
        let model = EffectModel::new(calibrated_ur10e(), &effects).unwrap();
        let comp = Compensator::with_effects(&nominal, model.clone(), Task::Pose, limits);
        let corrected = run(&comp, &commands, WARM_LOADED);
        assert!(corrected.iter().all(|s| s.fault.is_none()), "{effects:?}");
        let miss = worst_miss(&nominal, &model, &commands, &corrected);
        assert!(
            miss <= UR10E_EFFECTS_MISS,
            "{effects:?}: misses by {miss:e} m"
        );
        let plain = run(&geometric, &commands, WARM_LOADED);
        let plain_miss = worst_miss(&nominal, &model, &commands, &plain);
        assert!(plain_miss > 1e-6, "{effects:?}: {plain_miss:e} m");
        // Both approach directions of the backlash joint occurred.
        let signs: Vec<i8> = corrected.iter().map(|s| s.ctx.approach[3]).collect();
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
    let c64 = Compensator::with_effects(&nominal, model.clone(), Task::Pose, Limits::default());
    let effects32: Vec<Effect<f32>> = effects.iter().map(|e| e.cast()).collect();
    let model32 = EffectModel::new(calibrated_ur10e().cast(), &effects32).unwrap();
    let c32 = Compensator::with_effects(&nominal.cast(), model32, Task::Pose, Limits::default());
    let a = run(&c64, &commands, WARM_LOADED);
    let b = run(&c32, &commands, WARM_LOADED);
    for (sa, sb) in a.iter().zip(&b) {
        assert_eq!(sb.fault, None);
        let pa = model.forward(&sa.q, &sa.ctx).unwrap();
        let pb = model.forward(&sb.q, &sb.ctx).unwrap();
        let apart = (pa.translation.vector - pb.translation.vector).norm();
        assert!(apart <= 2e-6, "{apart:e} m apart");
    }
}

/// The UR10e's wrist: the largest distance of the tool point from joint 4's
/// axis is under `d5 + d6` = 0.2364 m (`d4` runs along that axis).
const UR10E_JOINT4_LEVER: f64 = 0.11985 + 0.11655;

/// A joint that reverses by less than its lost motion after moving forwards
/// would have to stay within the lost motion: it is held at its previous
/// command and stays on its forward flank (its approach direction stays +1),
/// so it stays where the previous tick put it, `p₃ = q₃ + b`, while the target
/// wants it `ρ` = 10 µrad back. The pose is then missed by that joint error `δ`
/// at the joint: `|δ|` in orientation (weighed at 1 m) and `|δ|` times the
/// lever of joint 4 at the tool point, so by between `|δ|` and `|δ| √(1 +
/// lever²)`, to the tolerance and the second order (`δ²`, 1e-10 m). `δ` is
/// the reversal plus the change of joint 4's correction over the tick (that
/// correction moves with the command by the size of the errors, under 1 %:
/// `|δ − ρ| ≤ 0.01 ρ`). The correction is flagged with that residual.
#[test]
fn a_joint_within_its_lost_motion_is_held_and_flagged() {
    let nominal = ur10e();
    let half_lost_motion = 1.5e-4;
    let backlash = Effect::Backlash {
        joint: 3,
        half_lost_motion,
    };
    let model = EffectModel::new(calibrated_ur10e(), &[backlash]).unwrap();
    let limits = Limits::default();
    let comp = Compensator::with_effects(&nominal, model.clone(), Task::Pose, limits);
    let mut commands = trajectory()[..4].to_vec();
    let reversal = 1e-5;
    let mut back = commands[3].clone();
    back[3] -= reversal;
    commands.push(back);
    let corrected = run(&comp, &commands, Conditions::default());
    let (before, held) = (&corrected[3], &corrected[4]);
    assert_eq!(before.fault, None);
    assert_eq!(before.ctx.approach[3], 1, "moving forwards");
    assert_eq!(held.fault, Some(Fault::NotConverged));
    assert_eq!(held.q[3], before.q[3], "held");
    assert_eq!(held.ctx.approach[3], 1, "on its forward flank");
    // Where joint 4 is (its previous command on the forward flank) against
    // where the target wants it.
    let at = held.q[3] + half_lost_motion;
    let delta = at - held.p[3];
    assert!(
        (delta - reversal).abs() <= 0.01 * reversal,
        "joint 4 is {delta:e} rad from its target position"
    );
    let miss = misses(&nominal, &model, &commands[4..], &corrected[4..])[0];
    let slack = limits.tolerance + delta * delta;
    let bound = delta.abs() * 1.0f64.hypot(UR10E_JOINT4_LEVER) + slack;
    assert!(
        miss >= delta.abs() - slack && miss <= bound,
        "misses by {miss:e} m, joint error {delta:e} rad, bound {bound:e} m"
    );
}

/// A joint whose command holds while the others move keeps its approach
/// direction (+1 here: it was moving forwards), so its sent command keeps the
/// lost-motion offset of its flank, `q = p − b`: with the old convention (σ =
/// 0 when not moving) it would jump by `b` = 0.15 mrad to `p`. Joint 4 moves
/// forwards for five ticks (2 mrad each), then its command holds for eight
/// while every other joint moves on by 2 mrad per tick.
///
/// 1. The calibrated UR10e differs from the nominal one by joint offsets
///    alone, and its effects other than the backlash (all of [`one_of_each`]
///    but the thermal expansion, which would couple the joints through the
///    lengths) act on other joints: joint 4's target position `p = q_cmd −
///    Δθ₄` does not change while its command holds, so its sent command stays
///    put (within 1e-12 rad: the solution `p` is found to the tolerance, 1 nm
///    with the orientation at 1 m, and a creep back within the lost motion
///    holds it exactly), at `p − b`, and the calibrated model with the held
///    direction reaches every target within [`UR10E_EFFECTS_MISS`].
/// 2. With the FIGAROH errors joint 4's target moves with the other joints
///    (a few µrad per tick). While the others move on, it creeps forwards:
///    the sent command follows it on the forward flank, `q = p − b`, and
///    every target is reached within [`UR10E_EFFECTS_MISS`].
/// 3. While the others move back, it creeps backwards, within the lost
///    motion: the joint is held at its sent command on its forward flank, at
///    `q + b`, and the tick is flagged; the pose is missed by that joint error
///    `δ = q + b − p` at the joint, `|δ|` in orientation and `|δ|` times its
///    lever (under [`UR10E_JOINT4_LEVER`]) in position: between `|δ|` and
///    `|δ| √(1 + lever²)`, to the tolerance and `δ²` (the second order).
///
/// In every case the approach direction of joint 4 stays +1 and its sent
/// command never moves backwards.
#[test]
fn a_holding_joint_keeps_its_flank() {
    let nominal = ur10e();
    let mut offsets = ur10e();
    for (j, e) in [1.2e-3, -0.8e-3, 0.5e-3, 1.0e-3, -0.6e-3, 0.9e-3]
        .into_iter()
        .enumerate()
    {
        *offsets.param_mut(Param::Theta(j)).unwrap() += e;
    }
    let effects: Vec<Effect<f64>> = one_of_each()
        .into_iter()
        .filter(|e| !matches!(e, Effect::ThermalExpansion { .. }))
        .collect();
    let b = 1.5e-4;
    assert!(effects.contains(&Effect::Backlash {
        joint: 3,
        half_lost_motion: b
    }));
    let (moving, holding): (usize, usize) = (5, 8);
    let commands = |others: f64| -> Vec<Vec<f64>> {
        (0..moving + holding)
            .map(|t| {
                UR10E_START
                    .iter()
                    .enumerate()
                    .map(|(m, q)| {
                        let hold = t.saturating_sub(moving - 1) as f64;
                        let ticks = (t.min(moving - 1)) as f64;
                        let ticks = if m == 3 { ticks } else { ticks + others * hold };
                        q + 2e-3 * ticks
                    })
                    .collect()
            })
            .collect()
    };
    #[derive(Debug, PartialEq)]
    enum Expect {
        StaysPut,
        CreepsForwards,
        HeldAndFlagged,
    }
    let limits = Limits::default();
    for (calibrated, others, expect) in [
        (offsets, 1.0, Expect::StaysPut),
        (calibrated_ur10e(), 1.0, Expect::CreepsForwards),
        (calibrated_ur10e(), -1.0, Expect::HeldAndFlagged),
    ] {
        let commands = commands(others);
        let model = EffectModel::new(calibrated, &effects).unwrap();
        let comp = Compensator::with_effects(&nominal, model.clone(), Task::Pose, limits);
        let corrected = run(&comp, &commands, WARM_LOADED);
        let miss = misses(&nominal, &model, &commands, &corrected);
        let last_move = &corrected[moving - 1];
        assert_eq!(last_move.fault, None);
        assert_eq!(last_move.ctx.approach[3], 1);
        assert!(miss[moving - 1] <= UR10E_EFFECTS_MISS);
        for t in moving..moving + holding {
            let (s, before) = (&corrected[t], &corrected[t - 1]);
            let label = format!("{expect:?}, tick {t}");
            assert_eq!(commands[t][3], commands[t - 1][3], "{label}: holding");
            assert_eq!(s.ctx.approach[3], 1, "{label}: the held direction");
            assert!(s.q[3] >= before.q[3], "{label}: moved backwards");
            let moved = s.q[3] - before.q[3];
            match expect {
                Expect::StaysPut | Expect::CreepsForwards => {
                    assert_eq!(s.fault, None, "{label}");
                    assert!(
                        miss[t] <= UR10E_EFFECTS_MISS,
                        "{label}: misses by {:e} m",
                        miss[t]
                    );
                    // On its forward flank, not at the mid-point.
                    let offset = s.q[3] - s.p[3];
                    assert!((offset + b).abs() <= 1e-12, "{label}: q − p = {offset:e}");
                    if expect == Expect::StaysPut {
                        assert!(moved <= 1e-12, "{label}: moved by {moved:e} rad");
                    } else {
                        assert!(moved > 1e-7, "{label}: moved by {moved:e} rad");
                    }
                }
                Expect::HeldAndFlagged => {
                    assert_eq!(s.fault, Some(Fault::NotConverged), "{label}");
                    assert_eq!(moved, 0.0, "{label}: held");
                    let delta = s.q[3] + b - s.p[3];
                    assert!(delta > 0.0 && delta < 2.0 * b, "{label}: δ = {delta:e}");
                    let slack = limits.tolerance + delta * delta;
                    let bound = delta * 1.0f64.hypot(UR10E_JOINT4_LEVER) + slack;
                    assert!(
                        miss[t] >= delta - slack && miss[t] <= bound,
                        "{label}: misses by {:e} m, joint error {delta:e} rad, bound {bound:e} m",
                        miss[t]
                    );
                }
            }
        }
    }
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
    /// misses the target by no more than the residual reported (in full pose
    /// whenever the task is [`Task::Pose`]). Random robots (both conventions,
    /// revolute and prismatic joints, 1–8 joints), parameter errors of 0.1 to
    /// 10 mm/mrad, full pose and position only, with and without joint effects
    /// (whose offsets the warm ticks predict), cold (from the command) and two
    /// warm ticks of a servo stream (from the previous tick's correction after
    /// a move of 1 mrad per joint, with its factors), at a tolerance of 1 µm so
    /// that the bound decides. A tick clipped by a bound is checked too (the
    /// bounds act after the search); a tick not converged is not.
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
        let comp = Compensator::with_effects(&robot, model, task_of(orientation), limits);
        let mut stream = Stream::new(Pacing::Servo);
        let mut ticks: Vec<(Vec<f64>, Correction<f64>)> = Vec::new();
        for t in 0..3 {
            let q_cmd: Vec<f64> = q.iter().map(|x| x + 1e-3 * t as f64).collect();
            let c = stream.tick(&comp, &q_cmd, &Conditions::default());
            ticks.push((q_cmd, c));
        }
        for (q_cmd, c) in &ticks {
            if !matches!(c.fault, None | Some(Fault::Limited)) {
                continue;
            }
            let target = robot.forward(q_cmd).unwrap();
            let reached = cal.forward(&c.p).unwrap();
            let miss = if comp.task() == Task::Pose {
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

/// The task the rule of the module header gives: full pose for a full-pose
/// calibration, position for a position-only one (whose orientation was not
/// measured), whatever the number of joints.
#[test]
fn the_task_follows_the_calibration_and_the_arm() {
    for dof in 1..=8 {
        let arm = Robot::new(
            Convention::Dh,
            &vec![Link::new(JointType::Revolute, 0.1, 0.3, 0.2, 1.0); dof],
        )
        .unwrap();
        for orientation in [false, true] {
            let comp = Compensator::new(&arm, &arm, task_of(orientation), Limits::default());
            let expected = if orientation {
                Task::Pose
            } else {
                Task::Position
            };
            assert_eq!(
                comp.task(),
                expected,
                "{dof} joints, orientation {orientation}"
            );
        }
    }
}

/// A small deterministic generator (SplitMix64) for the random jumps of a
/// stream, seeded by proptest: uniform in [−1, 1).
struct Draws(u64);

impl Draws {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// The agreement required of two corrections of the same command: the tool
/// point within 1 µm, the orientation within 1 µrad (and, where the least
/// correction is unique in joint space, each joint within 1 µrad or 1 µm).
const SAME: f64 = 1e-6;

/// How a stream's corrections compared with those of the commands alone.
#[derive(Debug, Default)]
struct Agreement {
    /// Ticks compared.
    compared: usize,
    /// Ticks clipped by the change bound (not compared).
    limited: usize,
    /// Ticks whose command alone did not converge (not compared).
    alone_failed: usize,
    /// Jumps beyond a servo tick's iterations, where the command alone with
    /// the servo's budget does not converge either (not compared).
    unconverged: usize,
    /// The largest distances: tool point (m), orientation (rad), joint.
    point: f64,
    turn: f64,
    joint: f64,
}

/// What [`compare_stream`] found: the agreement, whether each tick was
/// compared, and the stream's corrections.
type Streamed = (Agreement, Vec<bool>, Vec<Correction<f64>>);

/// Runs `commands` through one servo stream of `comp` and corrects each
/// command alone with `program` (a program point's iterations: the least
/// correction of a redundant task settled); at every tick the stream does not
/// clip and whose command alone converges, the two corrections must put the calibrated model's tool
/// (with its effects, in `conditions`) within [`SAME`] in position and in
/// orientation, and, if `joints`, each joint within [`SAME`]. The stream must
/// converge wherever the command alone does. `Err` with the first
/// disagreement.
fn compare_stream(
    comp: &Compensator<f64>,
    program: &Compensator<f64>,
    model: &EffectModel<f64>,
    commands: &[Vec<f64>],
    conditions: &Conditions<f64>,
    joints: bool,
) -> Result<Streamed, String> {
    let ctx = Context {
        temperature: conditions.temperature,
        payload: conditions.payload,
        approach: Default::default(),
    };
    let mut stream = Stream::new(Pacing::Servo);
    let mut agreement = Agreement::default();
    let mut compared = Vec::with_capacity(commands.len());
    let mut corrections = Vec::with_capacity(commands.len());
    for (t, q_cmd) in commands.iter().enumerate() {
        let servo = stream.tick(comp, q_cmd, conditions);
        corrections.push(servo.clone());
        let alone = program.correct(q_cmd, conditions);
        if alone.fault.is_some() {
            agreement.alone_failed += 1;
            compared.push(false);
            continue;
        }
        match servo.fault {
            None => {}
            Some(Fault::Limited) => {
                agreement.limited += 1;
                compared.push(false);
                continue;
            }
            // A jump too large for the servo tick's iterations: the command
            // alone with the same budget does no better (the stream's warm
            // search failed and its cold one is that of the command alone).
            Some(Fault::NotConverged)
                if comp.correct(q_cmd, conditions).fault == Some(Fault::NotConverged) =>
            {
                agreement.unconverged += 1;
                compared.push(false);
                continue;
            }
            other => {
                return Err(format!(
                    "tick {t}: the stream's correction {other:?} (residual {:e}) where the command alone converges; q_cmd {q_cmd:?}",
                    servo.residual
                ));
            }
        }
        let a = model.forward(&servo.q, &ctx).unwrap();
        let b = model.forward(&alone.q, &ctx).unwrap();
        let point = (a.translation.vector - b.translation.vector).norm();
        let turn = rotation_error(&a.rotation, &b.rotation).norm();
        let joint = servo
            .q
            .iter()
            .zip(&alone.q)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        agreement.point = agreement.point.max(point);
        agreement.turn = agreement.turn.max(turn);
        agreement.joint = agreement.joint.max(joint);
        agreement.compared += 1;
        compared.push(true);
        if point > SAME || turn > SAME || (joints && joint > SAME) {
            return Err(format!(
                "tick {t}: the stream's correction is {point:e} m, {turn:e} rad, {joint:e} (joints) from the command alone's (iterations {} and {}, residual {:e} and {:e}); q_cmd {q_cmd:?}, stream {:?}, alone {:?}",
                servo.iterations,
                alone.iterations,
                servo.residual,
                alone.residual,
                &servo.q[..],
                &alone.q[..]
            ));
        }
    }
    Ok((agreement, compared, corrections))
}

/// A smooth servo motion of `ticks` ticks 1 ms apart about `q0`: joint `m`
/// follows `A_m (sin(2π f_m t + φ_m) − sin φ_m)`, `f_m` a whole number of
/// cycles over the stream, so that it ends where it started.
fn sinusoids(
    q0: &[f64],
    amplitude: &[f64],
    cycles: &[u32],
    phase: &[f64],
    ticks: usize,
) -> Vec<Vec<f64>> {
    let tau = std::f64::consts::TAU;
    (0..ticks)
        .map(|t| {
            let s = t as f64 / (ticks - 1) as f64;
            q0.iter()
                .enumerate()
                .map(|(m, q)| {
                    let angle = tau * cycles[m] as f64 * s + phase[m];
                    q + amplitude[m] * (angle.sin() - phase[m].sin())
                })
                .collect()
        })
        .collect()
}

/// Random jumps about `q0`: each joint at a uniform offset in ±`half` from
/// `q0` at every tick (so a jump of up to `2 half` from one tick to the next),
/// then `q0` again for `settle` ticks.
fn jumps(
    q0: &[f64],
    half: &[f64],
    ticks: usize,
    settle: usize,
    draws: &mut Draws,
) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = (0..ticks)
        .map(|_| {
            q0.iter()
                .zip(half)
                .map(|(q, h)| q + h * draws.next())
                .collect()
        })
        .collect();
    out.extend(std::iter::repeat_n(q0.to_vec(), settle));
    out
}

/// The per-joint scale of a revolute motion for a joint of `robot`: 1 for a
/// revolute joint, 1/(2π) m per rad for a prismatic one (as the robots'
/// readings of [`robot_strategy`]).
fn joint_scale(robot: &Robot<f64>) -> Vec<f64> {
    robot
        .links
        .iter()
        .map(|l| match l.joint {
            JointType::Revolute => 1.0,
            JointType::Prismatic => 1.0 / std::f64::consts::TAU,
        })
        .collect()
}

/// The joint effects of [`random_effects`] but the backlash (which depends on
/// the approach history, so legitimately on the stream).
fn smooth_effects(dof: usize, d: &[f64]) -> Vec<Effect<f64>> {
    random_effects(dof, d)
        .into_iter()
        .filter(|e| !matches!(e, Effect::Backlash { .. }))
        .collect()
}

/// The ticks of the smooth stream (5 s at 1 kHz).
const SMOOTH_TICKS: usize = 5000;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(8))]

    /// History independence: a servo stream's correction is, at every tick it
    /// does not clip, the correction of its command alone (within 1 µm at the
    /// tool point and 1 µrad in orientation, both through the calibrated model
    /// with its effects), and it does not drift: its last tick, back at the
    /// first command, agrees too. Random robots of 6 to 8 joints (both
    /// conventions, revolute and prismatic), geometric errors of 1 mm/mrad,
    /// position-only and full-pose calibrations, without and with joint effects
    /// but no backlash (compliance, gear harmonics, encoder scale, thermal
    /// expansion at 15–40 °C, payload up to 10 kg); each case runs all four: a
    /// smooth stream of 5,000 ticks (sinusoids of 0.2–0.3 rad, 1–3 cycles, 1 ms
    /// apart, from a configuration whose correction alone converges), and a
    /// stream of 300 random jumps of up to 0.3 rad per joint followed by 20
    /// ticks back at the start. Ticks whose command alone does not converge
    /// (near a singularity) are not compared; the stream must converge wherever
    /// the command alone does. A calibration whose correction alone does not
    /// converge at the start (a singular start, or, in full pose, an
    /// orientation the robot's joints cannot turn: random robots have
    /// prismatic joints) is skipped; a case where all four are is rejected.
    #[test]
    fn a_servo_stream_gives_the_correction_of_the_command_alone(
        (robot, q0) in robot_strategy().prop_filter("six joints or more", |(r, _)| r.dof() >= 6),
        draws in prop::collection::vec(-1.0..1.0f64, 8..16),
        effect_draws in prop::collection::vec(-1.0..1.0f64, 12),
        amplitude in prop::collection::vec(0.2..0.3f64, 8),
        cycles in prop::collection::vec(1u32..=3, 8),
        phase in prop::collection::vec(0.0..std::f64::consts::TAU, 8),
        temperature in 15.0..40.0f64,
        payload in 0.0..10.0f64,
        seed in any::<u64>(),
    ) {
        let n = robot.dof();
        let cal = calibrated(&robot, &draws, 1e-3);
        let scale = joint_scale(&robot);
        let amplitude: Vec<f64> = amplitude[..n].iter().zip(&scale).map(|(a, s)| a * s).collect();
        let smooth = sinusoids(&q0, &amplitude, &cycles[..n], &phase[..n], SMOOTH_TICKS);
        let half: Vec<f64> = scale.iter().map(|s| 0.15 * s).collect();
        let random = jumps(&q0, &half, 300, 20, &mut Draws(seed));
        let mut ran = 0;
        for (orientation, effects) in [(false, false), (true, false), (false, true), (true, true)] {
            let list = if effects { smooth_effects(n, &effect_draws) } else { Vec::new() };
            let model = EffectModel::new(cal.clone(), &list).unwrap();
            let comp = Compensator::with_effects(&robot, model.clone(), task_of(orientation), Limits::default());
            let program = Compensator::with_effects(&robot, model.clone(), task_of(orientation), Limits::of(Pacing::Program));
            let conditions = if effects {
                Conditions { temperature: Some(temperature), payload: Some(payload) }
            } else {
                Conditions::default()
            };
            // A start the command alone does not reach (a singularity, or an
            // orientation the joints cannot turn) is no start.
            if comp.correct(&q0, &conditions).fault.is_some() {
                continue;
            }
            ran += 1;
            for (name, commands) in [("smooth", &smooth), ("jumps", &random)] {
                let label = format!("{name}, orientation {orientation}, effects {effects}, task {:?}", comp.task());
                let (agreement, compared, _) = compare_stream(&comp, &program, &model, commands, &conditions, false)
                    .map_err(|e| TestCaseError::fail(format!("{label}: {e}")))?;
                // The figures (`-- --nocapture`): the largest differences.
                eprintln!("{label}: {agreement:?}");
                prop_assert!(
                    compared.last() == Some(&true),
                    "{}: the last tick, at the start, was not compared: {:?}", label, agreement
                );
            }
        }
        prop_assume!(ran > 0, "no calibration's correction converges at the start");
    }
}

/// A redundant arm: a KUKA LBR iiwa-like 7R (standard D-H, spherical shoulder
/// and wrist, consecutive axes perpendicular, none parallel) with a tool 0.1 m
/// off its last axis.
fn seven_joints() -> Robot<f64> {
    let pi2 = std::f64::consts::FRAC_PI_2;
    let d = [0.34, 0.0, 0.4, 0.0, 0.4, 0.0, 0.126];
    let alpha = [-pi2, pi2, pi2, -pi2, -pi2, pi2, 0.0];
    let links: Vec<Link<f64>> = (0..7)
        .map(|m| Link::new(JointType::Revolute, 0.0, d[m], 0.0, alpha[m]))
        .collect();
    let mut robot = Robot::new(Convention::Dh, &links).unwrap();
    robot.tool.xyz.x = 0.1;
    robot
}

/// A 7-joint arm, position-only and full-pose calibrations (every parameter
/// off by up to 1 mm/mrad), without and with joint effects but no backlash
/// (one_of_each's others): the least correction from the command is unique, so
/// a smooth servo stream of 5,000 ticks (sinusoids of 0.2–0.3 rad, away from
/// the arm's singularities at q2, q4, q6 = 0) gives at every tick the
/// correction of the command alone within 1 µrad in every joint (and 1 µm,
/// 1 µrad at the tool), never clipped; back at its first command, its
/// correction is the first tick's (no drift in the null space).
#[test]
fn a_redundant_arm_streams_the_least_correction() {
    let arm = seven_joints();
    let draws: Vec<f64> = (0..16).map(|k| (1.7 * k as f64 + 0.3).sin()).collect();
    let cal = calibrated(&arm, &draws, 1e-3);
    let q0 = [0.3, 0.9, -0.4, -1.3, 0.5, 1.0, 0.2];
    let amplitude: Vec<f64> = (0..7).map(|m| 0.2 + 0.1 * (m as f64 / 6.0)).collect();
    let cycles = [1, 2, 3, 1, 2, 3, 1];
    let phase: Vec<f64> = (0..7).map(|m| 0.9 * m as f64).collect();
    let commands = sinusoids(&q0, &amplitude, &cycles, &phase, SMOOTH_TICKS);
    let effects: Vec<Effect<f64>> = one_of_each()
        .into_iter()
        .filter(|e| !matches!(e, Effect::Backlash { .. }))
        .collect();
    for orientation in [false, true] {
        for with_effects in [false, true] {
            let list = if with_effects { &effects[..] } else { &[] };
            let model = EffectModel::new(cal.clone(), list).unwrap();
            let comp = Compensator::with_effects(
                &arm,
                model.clone(),
                task_of(orientation),
                Limits::default(),
            );
            let program = Compensator::with_effects(
                &arm,
                model.clone(),
                task_of(orientation),
                Limits::of(Pacing::Program),
            );
            let conditions = if with_effects {
                WARM_LOADED
            } else {
                Conditions::default()
            };
            let label = format!(
                "orientation {orientation}, effects {with_effects}, task {:?}",
                comp.task()
            );
            let (agreement, compared, corrections) =
                compare_stream(&comp, &program, &model, &commands, &conditions, true)
                    .unwrap_or_else(|e| panic!("{label}: {e}"));
            eprintln!("7R {label}: {agreement:?}");
            assert!(
                compared.iter().all(|c| *c),
                "{label}: not every tick compared: {agreement:?}"
            );
            // Back at the first command: the first tick's correction.
            let (first, last) = (&corrections[0], corrections.last().unwrap());
            let end = commands.last().unwrap();
            let drift = first
                .q
                .iter()
                .zip(&commands[0])
                .zip(last.q.iter().zip(end))
                .map(|((a, qa), (b, qb))| ((b - qb) - (a - qa)).abs())
                .fold(0.0, f64::max);
            assert!(
                drift <= SAME,
                "{label}: the correction drifted by {drift:e}"
            );
        }
    }
}
