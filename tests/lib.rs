//! Helpers of the end-to-end tests: the host's simulator, re-exported, and the
//! distance of a configuration from a singularity.

pub use armcal::calibration::simulate::{
    measure, random_configuration, random_configurations, rng, with_random_errors,
};

use armcal_shared::Robot;

/// The smallest singular value of the manipulator Jacobian of `robot` at `q`
/// (rotation rows in rad, position rows in m: a 1 m lever): below about 0.05
/// the arm is near a singularity, where a small pose correction needs a large
/// joint motion.
pub fn sigma_min(robot: &Robot<f64>, q: &[f64]) -> f64 {
    let j = robot.chain(q).unwrap().manipulator_jacobian();
    let m = nalgebra::DMatrix::from_fn(6, robot.dof(), |r, c| j.column(c)[r]);
    m.svd(false, false).singular_values.min()
}
