//! What users bring: 20–40 poses from a camera or motion capture, noise they do
//! not know, one channel noisier than the other. Simulated sessions of the
//! PUMA 560 and the UR10e whose true geometry is the nominal one with ±1 mm /
//! ±1 mrad errors on every D-H, base and tool parameter; the calibrations are
//! judged on 300 other configurations of the same true robot, noise-free (the
//! error of where each model puts the tool point).
//!
//! - A calibration from few noisy poses may be worse than the nominal model;
//!   the diagnosis must then keep the nominal one. Held-out it is never worse
//!   than nominal, and on average at least as good as the full geometric fit
//!   (every parameter, least squares).
//! - Variance components recover each channel's noise: within 20 % on 300
//!   poses (the estimate's own scatter is `1/√(2r)` ≈ 4 % at r ≈ 300 rows).

use armcal::calibration::diagnose::{Choice, DiagnoseOptions, diagnose};
use armcal::calibration::fit::{FitRequest, FullOptions};
use armcal::calibration::simulate::{Scenario, simulate};
use armcal::io::model_file::load_model;
use armcal_shared::Robot;
use armcal_shared::units::Units;
use armcal_tests::{random_configurations, rng};

/// RMS distance (m) between where `model` and `truth` put the tool point over
/// `configs`.
fn rms_against(model: &Robot<f64>, truth: &Robot<f64>, configs: &[Vec<f64>]) -> f64 {
    let sum: f64 = configs
        .iter()
        .map(|q| {
            let a = model.forward(q).unwrap().translation.vector;
            let b = truth.forward(q).unwrap().translation.vector;
            (a - b).norm_squared()
        })
        .sum();
    (sum / configs.len() as f64).sqrt()
}

/// A camera (σ 1.5 mm, 7 mrad, full poses) or motion capture (σ 1 mm, positions).
#[derive(Clone, Copy, Debug)]
enum Instrument {
    Camera,
    Mocap,
}

#[test]
fn few_noisy_poses_never_make_the_robot_worse() {
    let (mut chosen_sum, mut full_sum, mut sessions) = (0.0, 0.0, 0);
    for robot in ["puma560", "ur10e"] {
        let nominal = load_model(robot).unwrap().robot;
        for poses in [20, 30, 40] {
            for instrument in [Instrument::Camera, Instrument::Mocap] {
                for seed in 0..2u64 {
                    let mut scenario = Scenario::tracker(poses, 500 + seed * 17 + poses as u64);
                    scenario.effects.clear();
                    match instrument {
                        Instrument::Camera => {
                            scenario.position_noise = 1.5e-3;
                            scenario.orientation_noise = Some(7e-3);
                        }
                        Instrument::Mocap => scenario.position_noise = 1e-3,
                    }
                    let session = simulate(&nominal, &scenario).unwrap();
                    let data = &session.observations;
                    let task = if data[0].orientation.is_some() {
                        armcal_shared::compensation::Task::Pose
                    } else {
                        armcal_shared::compensation::Task::Position
                    };
                    let d = diagnose(&nominal, data, &DiagnoseOptions::default()).unwrap();
                    let chosen = d.calibration(&nominal, task, Units::SI).calibrated();
                    let full = FitRequest::new(&nominal, data, &FullOptions::least_squares())
                        .run()
                        .unwrap()
                        .calibrated;
                    let configs = random_configurations(&nominal, 300, &mut rng(seed + 9));
                    let truth = &session.truth;
                    let (e_nominal, e_chosen, e_full) = (
                        rms_against(&nominal, truth, &configs),
                        rms_against(&chosen, truth, &configs),
                        rms_against(&full, truth, &configs),
                    );
                    eprintln!(
                        "{robot} {poses} poses {instrument:?} seed {seed}: nominal {:.3} mm, chosen {:.3} mm ({}), full fit {:.3} mm",
                        e_nominal * 1e3,
                        e_chosen * 1e3,
                        d.chosen_label(),
                        e_full * 1e3
                    );
                    assert!(
                        e_chosen <= e_nominal,
                        "{robot} {poses} poses {instrument:?} seed {seed}: the chosen model ({}) misses by {:.3} mm, the nominal one by {:.3} mm",
                        d.chosen_label(),
                        e_chosen * 1e3,
                        e_nominal * 1e3
                    );
                    if d.choice == Choice::Nominal {
                        assert!(d.calibration(&nominal, task, Units::SI).errors.is_empty());
                    }
                    chosen_sum += e_chosen;
                    full_sum += e_full;
                    sessions += 1;
                }
            }
        }
    }
    eprintln!(
        "mean over {sessions} sessions: chosen {:.3} mm, full fit {:.3} mm",
        chosen_sum / sessions as f64 * 1e3,
        full_sum / sessions as f64 * 1e3
    );
    assert!(chosen_sum <= full_sum);
}

/// A session whose channels differ in quality: positions to 0.5 mm, orientations
/// to 5 mrad (a camera's orientations are worth 5 mm at a metre), and the
/// reverse. The estimates land within 20 % of the truth.
#[test]
fn each_channel_noise_is_recovered() {
    let nominal = load_model("ur10e").unwrap().robot;
    for (position, orientation) in [(0.5e-3, 5e-3), (2e-3, 0.1e-3)] {
        let mut scenario = Scenario::tracker(300, 42);
        scenario.position_noise = position;
        scenario.orientation_noise = Some(orientation);
        let session = simulate(&nominal, &scenario).unwrap();
        let fit = FitRequest::new(&nominal, &session.observations, &FullOptions::default())
            .run()
            .unwrap();
        let p = fit.noise.position.used;
        let r = fit.noise.orientation.unwrap().used;
        eprintln!(
            "true {:.3} mm / {:.3} mrad, estimated {:.3} mm / {:.3} mrad",
            position * 1e3,
            orientation * 1e3,
            p * 1e3,
            r * 1e3
        );
        assert!(
            (p / position - 1.0).abs() < 0.2,
            "position {p} against {position}"
        );
        assert!(
            (r / orientation - 1.0).abs() < 0.2,
            "orientation {r} against {orientation}"
        );
    }
}
