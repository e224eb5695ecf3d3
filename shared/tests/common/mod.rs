//! Strategies shared by the property tests of the shared crate.

use armcal_shared::{Convention, Frame, JointType, Link, Robot};
use nalgebra::Vector3;
use proptest::prelude::*;

/// A random robot in f64: both conventions, mixed joints, lengths within ±1 m.
pub fn robot_strategy() -> impl Strategy<Value = (Robot<f64>, Vec<f64>)> {
    let pi = std::f64::consts::PI;
    let link = (
        any::<bool>(),
        -pi..pi,
        -1.0..1.0f64,
        -1.0..1.0f64,
        -pi..pi,
        -pi..pi,
    );
    let frame = |len: f64| {
        (
            prop::array::uniform3(-len..len),
            prop::array::uniform3(-pi..pi),
        )
            .prop_map(|(xyz, rpy)| Frame {
                xyz: Vector3::from(xyz),
                rpy: Vector3::from(rpy),
            })
    };
    (
        any::<bool>(),
        prop::collection::vec(link, 1..=8),
        frame(2.0),
        frame(0.3),
    )
        .prop_map(move |(mdh, links, base, tool)| {
            let convention = if mdh { Convention::Mdh } else { Convention::Dh };
            let mut q = Vec::new();
            let links: Vec<Link<f64>> = links
                .into_iter()
                .map(|(prismatic, theta, s, a, alpha, qm)| {
                    let joint = if prismatic {
                        JointType::Prismatic
                    } else {
                        JointType::Revolute
                    };
                    // A prismatic reading is a length: scale the random angle to ±0.5 m.
                    q.push(if prismatic { qm / (2.0 * pi) } else { qm });
                    Link::new(joint, theta, s, a, alpha)
                })
                .collect();
            let mut robot = Robot::new(convention, &links).expect("at most 8 joints");
            robot.base = base;
            robot.tool = tool;
            (robot, q)
        })
}
