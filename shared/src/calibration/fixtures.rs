//! Calibrations for the tests of the modules that take one (the link's
//! [`Device`](crate::link::Device), the magnitude policy): SI units, `f64`.

extern crate std;

use crate::compensation::Task;
use std::vec::Vec;

use crate::units::Units;
use crate::{Calibration, Convention, JointType, Link, Param, ParamError, Robot};

/// A six-axis arm like a UR10e (standard D-H), with a few identified errors.
pub(crate) fn calibration() -> Calibration {
    let pi2 = core::f64::consts::FRAC_PI_2;
    let rows = [
        (0.1807, 0.0, pi2),
        (0.0, -0.6127, 0.0),
        (0.0, -0.57155, 0.0),
        (0.17415, 0.0, pi2),
        (0.11985, 0.0, -pi2),
        (0.11655, 0.0, 0.0),
    ];
    let links: Vec<Link<f64>> = rows
        .iter()
        .map(|&(s, a, alpha)| Link::new(JointType::Revolute, 0.0, s, a, alpha))
        .collect();
    let robot = Robot::new(Convention::Dh, &links).unwrap();
    let mut cal = Calibration::nominal(robot, Task::Pose, Units::default());
    for (param, error) in [
        (Param::Theta(1), 1e-3),
        (Param::A(2), -2e-3),
        (Param::Alpha(3), 5e-4),
        (Param::S(4), 1e-3),
    ] {
        cal.errors.push(ParamError { param, error }).unwrap();
    }
    cal
}
