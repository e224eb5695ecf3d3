//! The project's simulator: true robots with built-in errors and the
//! measurements a laser tracker or a pose sensor would take of them. The tests,
//! the benchmarks and (later) `armcal simulate` draw their data from it.
//!
//! Units are SI (m, rad). Random draws come from a seeded `StdRng`, so every run
//! is repeatable.

use crate::identify::full::Observation;
use armcal_shared::{JointType, Param, Robot};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

/// A seeded generator.
pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

/// `nominal` with every parameter in `params` moved by a uniform draw within
/// `±length` (m) or `±angle` (rad); returns the true robot and the errors.
pub fn with_random_errors(
    nominal: &Robot<f64>,
    params: &[Param],
    length: f64,
    angle: f64,
    rng: &mut StdRng,
) -> (Robot<f64>, Vec<f64>) {
    let mut truth = nominal.clone();
    let errors: Vec<f64> = params
        .iter()
        .map(|p| {
            let scale = if p.is_angle() { angle } else { length };
            let e = rng.random_range(-scale..scale);
            *truth.param_mut(*p).expect("param of the model") += e;
            e
        })
        .collect();
    (truth, errors)
}

/// `n` random configurations within the joint limits (±π, or ±0.5 m for a
/// prismatic joint without limits).
pub fn random_configurations(robot: &Robot<f64>, n: usize, rng: &mut StdRng) -> Vec<Vec<f64>> {
    (0..n)
        .map(|_| {
            robot
                .links
                .iter()
                .map(|l| {
                    let [lo, hi] = l.limits.unwrap_or(match l.joint {
                        JointType::Revolute => [-std::f64::consts::PI, std::f64::consts::PI],
                        JointType::Prismatic => [0.0, 0.5],
                    });
                    let (lo, hi) = (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI));
                    rng.random_range(lo..hi)
                })
                .collect()
        })
        .collect()
}

/// What the instrument measures of `truth` at `configs`: the tool point with
/// Gaussian noise `position_noise` (m, per axis) and, when `orientation_noise` is
/// given, the tool orientation with a Gaussian rotation-vector noise (rad, per axis).
pub fn measure(
    truth: &Robot<f64>,
    configs: &[Vec<f64>],
    position_noise: f64,
    orientation_noise: Option<f64>,
    rng: &mut StdRng,
) -> Vec<Observation> {
    let normal = Normal::new(0.0, 1.0).expect("unit normal");
    let mut draw3 = |s: f64| Vector3::from_fn(|_, _| s * normal.sample(rng));
    configs
        .iter()
        .map(|q| {
            let t = truth.forward(q).expect("joint count");
            let position = Point3::from(t.translation.vector + draw3(position_noise));
            let orientation = orientation_noise.map(|s| {
                UnitQuaternion::from_scaled_axis(draw3(s))
                    * UnitQuaternion::from_rotation_matrix(&t.rotation)
            });
            Observation {
                q: q.clone(),
                position,
                orientation,
            }
        })
        .collect()
}
