//! One cycle of `armcal serve`, whatever the wire: the set-point corrected by
//! the same [`Stream`] the firmware and `armcal compensate --servo` run
//! (servo pacing, [`Limits::of`]`(`[`Pacing::Servo`]`)`, `f64`), then the
//! correction sent ramped so that it never changes by more than the
//! configured step per cycle.
//!
//! The correction is `p − q_cmd` per joint: what the controller adds to its
//! own set-point `q_cmd` so that the calibrated robot reaches the pose the
//! nominal model intended (`docs/compensation.md`). The stream's own
//! per-tick change bound (0.01 rad) keeps one tick from another; the ramp
//! here bounds what is *sent*, which also changes where the stream does not
//! tick: the first cycle (from no correction), a set-point that could not be
//! computed (the stream answers with no correction), and the end (Ctrl-C,
//! towards no correction). A controller therefore never receives a
//! correction that jumps by more than the step, and a fault always ramps to
//! none.
//!
//! Units: SI inside (rad; every joint revolute: RSI's `AK` and EGM's joints
//! are degrees, converted by the wire's module); conditions in °C and kg.
//! Frames: joint space, the calibration's joint order.

use armcal_shared::compensation::{
    Compensator, Conditions, Correction, Fault, Limits, Pacing, Stream,
};
use armcal_shared::ranges::{Outside, Ranges};
use armcal_shared::{Calibration, JointType};

/// What one cycle did besides its correction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Step {
    /// The correction sent differs from the stream's: its change was held
    /// to the step.
    pub ramped: bool,
    /// What the stream said of the set-point ([`Fault`]), if anything.
    pub fault: Option<Fault>,
    /// Whether the residual of a [`Fault::NotConverged`] set-point is above
    /// the tolerance (its pose is missed; at or below, it is reached).
    pub missed: bool,
    /// The set-point's values outside the ranges the calibration was
    /// identified on (none when it does not record them).
    pub outside: Outside,
}

/// The state of a served stream: see [the module](self).
#[derive(Clone, Debug)]
pub struct Cycle {
    compensator: Compensator<f64>,
    stream: Stream<f64>,
    ranges: Option<Ranges<f64>>,
    tolerance: f64,
    /// The largest change of a joint's sent correction per cycle, rad.
    max_step: f64,
    /// The correction last sent, rad, per joint.
    offset: Vec<f64>,
}

/// Why a calibration cannot be served: a joint that is not revolute (RSI's
/// `AK` and EGM's joints are degrees of rotary axes).
pub fn served_joints(cal: &Calibration) -> Result<usize, String> {
    match cal
        .nominal
        .links
        .iter()
        .position(|l| l.joint != JointType::Revolute)
    {
        Some(m) => Err(format!(
            "joint {} is prismatic: armcal serve corrects rotary axes (degrees) only",
            m + 1
        )),
        None => Ok(cal.nominal.links.len()),
    }
}

impl Cycle {
    /// The cycle of `cal` with a step of `max_step` rad per cycle (positive).
    pub fn new(cal: &Calibration, max_step: f64) -> Self {
        let limits = Limits::of(Pacing::Servo);
        let compensator = Compensator::<f64>::from_calibration(cal, limits);
        let dof = compensator.dof();
        Self {
            compensator,
            stream: Stream::new(Pacing::Servo),
            ranges: cal.ranges.clone(),
            tolerance: limits.tolerance,
            max_step,
            offset: vec![0.0; dof],
        }
    }

    /// The calibration's joint count.
    pub fn dof(&self) -> usize {
        self.offset.len()
    }

    /// Whether the calibration records the ranges it was identified on.
    pub fn ranges_known(&self) -> bool {
        self.ranges.is_some()
    }

    /// The correction last sent, rad, per joint.
    pub fn offset(&self) -> &[f64] {
        &self.offset
    }

    /// True when the correction sent is none on every joint.
    pub fn is_zero(&self) -> bool {
        self.offset.iter().all(|&x| x == 0.0)
    }

    /// The cycle of the set-point `q_cmd` (rad, [`Self::dof`] values) in
    /// `conditions`: the stream's correction, sent ramped.
    pub fn correct(&mut self, q_cmd: &[f64], conditions: &Conditions<f64>) -> Step {
        let c: Correction<f64> = self.stream.tick(&self.compensator, q_cmd, conditions);
        let outside = self
            .ranges
            .as_ref()
            .map(|r| r.outside(q_cmd, conditions.temperature, conditions.payload))
            .unwrap_or_default();
        let target: Vec<f64> = c.q.iter().zip(q_cmd).map(|(q, q_cmd)| q - q_cmd).collect();
        Step {
            ramped: self.ramp(&target),
            fault: c.fault,
            missed: c.fault == Some(Fault::NotConverged) && c.residual > self.tolerance,
            outside,
        }
    }

    /// One cycle: of the set-point `q_cmd` in its conditions
    /// ([`Self::correct`]), or with none, towards no correction (at the end).
    pub fn next(&mut self, set_point: Option<(&[f64], &Conditions<f64>)>) -> Step {
        match set_point {
            Some((q_cmd, conditions)) => self.correct(q_cmd, conditions),
            None => Step {
                ramped: self.toward_zero(),
                ..Step::default()
            },
        }
    }

    /// One cycle towards no correction (at the end): true while ramping.
    pub fn toward_zero(&mut self) -> bool {
        let zero = vec![0.0; self.dof()];
        self.ramp(&zero)
    }

    /// Moves the sent correction to `target`, each joint by at most the
    /// step; true when one was held to it.
    fn ramp(&mut self, target: &[f64]) -> bool {
        let mut ramped = false;
        for (sent, &target) in self.offset.iter_mut().zip(target) {
            let change = target - *sent;
            if change.abs() > self.max_step {
                ramped = true;
                *sent += self.max_step.copysign(change);
            } else {
                *sent = target;
            }
        }
        ramped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::apply::compensate::compensate;
    use crate::io::model_file::load_model;
    use crate::session::joints::JointRows;
    use armcal_shared::compensation::Task;
    use armcal_shared::{Param, ParamError};

    fn calibration() -> Calibration {
        let model = load_model("ur10e").unwrap();
        let mut cal = Calibration::nominal(model.robot.clone(), Task::Pose, model.units);
        for (name, error) in [("theta2", -6e-4), ("a2", -6e-3), ("alpha3", -8e-3)] {
            let param: Param = name.parse().unwrap();
            cal.errors.push(ParamError { param, error }).unwrap();
        }
        cal
    }

    fn q(t: usize) -> Vec<f64> {
        let q0 = [1.589, 0.578, -1.675, 0.351, 1.784, 2.232];
        (0..6)
            .map(|j| q0[j] + 0.2 * (0.05 * t as f64 + j as f64).sin())
            .collect()
    }

    /// With a step wider than any change, each cycle sends exactly the
    /// correction of `compensate --servo`'s stream (the same code, the same
    /// order): the sent command equals its row's to the last bit of the
    /// subtraction.
    #[test]
    fn a_wide_step_sends_the_servo_streams_correction() {
        let cal = calibration();
        let commands: Vec<Vec<f64>> = (0..200).map(q).collect();
        let rows = JointRows::commands("j.csv", &commands, None, None);
        let servo = compensate(&cal, &rows, Pacing::Servo);
        let mut cycle = Cycle::new(&cal, 1.0);
        for (t, (_, c)) in servo.rows.iter().enumerate() {
            let step = cycle.correct(&q(t), &Conditions::default());
            assert!(!step.ramped);
            for m in 0..6 {
                assert_eq!(cycle.offset()[m], c.q[m] - q(t)[m], "tick {t} joint {m}");
            }
        }
    }

    /// With a narrow step the correction ramps in by exactly the step per
    /// cycle, joins the stream's, and ramps out to exactly none.
    #[test]
    fn a_narrow_step_ramps_in_and_out() {
        let cal = calibration();
        let step = 1e-4;
        let mut cycle = Cycle::new(&cal, step);
        let mut wide = Cycle::new(&cal, 1.0);
        let mut before = vec![0.0; 6];
        let mut joined = None;
        for t in 0..400 {
            let s = cycle.correct(&q(t), &Conditions::default());
            wide.correct(&q(t), &Conditions::default());
            for (now, before) in cycle.offset().iter().zip(&before) {
                assert!((now - before).abs() <= step * (1.0 + 1e-12));
            }
            before = cycle.offset().to_vec();
            if !s.ramped && joined.is_none() {
                joined = Some(t);
            }
            if joined.is_some() {
                assert_eq!(cycle.offset(), wide.offset(), "tick {t}");
            }
        }
        let joined = joined.expect("the ramp joins the stream");
        let largest = wide.offset().iter().fold(0.0_f64, |a, b| a.max(b.abs()));
        assert!(joined > 0 && largest > step, "joined at {joined}");
        let mut cycles = 0;
        while cycle.toward_zero() {
            cycles += 1;
            assert!(cycles < 10_000);
        }
        assert!(cycle.is_zero());
    }
}
