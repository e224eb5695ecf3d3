//! `armcal plan` against random poses (issue: plan the measurement).
//!
//! For each of several true robots (the nominal model with every D-H, base
//! and tool parameter off by up to ±1 mm and ±1 mrad, uniform), a tracker
//! measures 20 poses (σ = 20 µm per axis): once the 20 `plan` chose, once 20
//! random poses within the joint limits. `armcal identify` (its defaults)
//! calibrates from each, and the calibration predicts where the true robot
//! puts its tool at 200 random held-out poses. Over the robots, the planned
//! poses' median RMS error and median worst error must be at most 0.8 of the
//! random poses' (the plan is worth measuring), and the plan's predicted RMS
//! within ±30 % of the RMS found (its prediction can be planned with): the
//! prediction is of a least-squares calibration at the stated noise,
//! `identify`'s default chooses a prior's scale, and 200 held-out poses
//! estimate an RMS to about 5 %. Against the tracker's own measurements of
//! the held-out poses (their noise, 35 µm RMS in 3-D, added) the plan's
//! predicted figure must hold as well.

use armcal::calibration::plan::{PlanOptions, plan};
use armcal::commands::{Front, identify};
use armcal::io::measurements::Measurements;
use armcal::io::model_file::{RobotModel, load_model};
use armcal::session::registration::FrameSharing;
use armcal_shared::{Param, Robot, TargetFrame};
use armcal_tests::{measure, random_configurations, rng, with_random_errors};

/// The tracker's noise, m per axis.
const NOISE: f64 = 20e-6;

/// The SMR on the flange, m: 60 mm off the last joint's axis, 80 mm along it
/// (on the axis, turning the last joint would not move it, and the
/// parameters of the last joints would be no better known than its nest).
const SMR: [f64; 3] = [0.06, 0.0, 0.08];

/// `armcal identify`'s calibrated robot (default options) of `model` from
/// a tracker session of `truth` at `q`.
fn calibrate(model: &RobotModel, truth: &Robot<f64>, q: &[Vec<f64>], seed: u64) -> Robot<f64> {
    let poses = measure(truth, q, NOISE, None, &mut rng(seed));
    let n = poses.len();
    let data = Measurements {
        file: "tracker.csv".into(),
        poses,
        lines: (2..2 + n).collect(),
        times: vec![None; n],
        columns_used: Vec::new(),
        columns_ignored: Vec::new(),
        warnings: Vec::new(),
        constraints: Default::default(),
        sessions: Vec::new(),
    };
    let request = identify::Request {
        params: armcal::calibration::identify::ParamSet::Full,
        scales: Default::default(),
        prior_scale: Default::default(),
        targets: TargetFrame::World,
        frames: FrameSharing::default(),
    };
    let identified = identify::run(Front::CommandLine, model, &data, &request).unwrap();
    identified.result.calibration.calibrated()
}

/// The held-out RMS and worst error (m) of `robot` predicting where
/// `truth` puts its tool at `q`, as measured with `noise` (0: the truth).
fn held_out(robot: &Robot<f64>, truth: &Robot<f64>, q: &[Vec<f64>], noise: f64) -> (f64, f64) {
    let measured = measure(truth, q, noise, None, &mut rng(7));
    let errors: Vec<f64> = measured
        .iter()
        .map(|o| (robot.forward(&o.q).unwrap().translation.vector - o.position.coords).norm())
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    (rms, errors.iter().copied().fold(0.0, f64::max))
}

/// The median of `v`.
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Plans 20 poses for `name` and compares them with 20 random ones on
/// `robots` true robots (see the module header).
fn planned_against_random(name: &str, robots: u64) {
    let mut model = load_model(name).unwrap();
    model.robot.tool.xyz = nalgebra::Vector3::from(SMR);
    let nominal = &model.robot;
    let options = PlanOptions {
        poses: 20,
        ..PlanOptions::default()
    };
    let p = plan(nominal, None, None, &options).unwrap();
    let params: Vec<Param> = nominal.params().collect();
    let (mut planned, mut random) = (Vec::new(), Vec::new());
    let (mut ratio, mut measured_ratio) = (Vec::new(), Vec::new());
    for seed in 1..=robots {
        let mut r = rng(100 + seed);
        let (truth, _) = with_random_errors(nominal, &params, 1e-3, 1e-3, &mut r);
        let random_q = random_configurations(nominal, 20, &mut r);
        let targets = random_configurations(nominal, 200, &mut r);
        let from_plan = calibrate(&model, &truth, &p.q, seed);
        let planned_error = held_out(&from_plan, &truth, &targets, 0.0);
        let random_error = held_out(
            &calibrate(&model, &truth, &random_q, seed),
            &truth,
            &targets,
            0.0,
        );
        let against_measured = held_out(&from_plan, &truth, &targets, NOISE).0;
        eprintln!(
            "{name} robot {seed}: planned {:.4} / {:.4} mm, random {:.4} / {:.4} mm (RMS / worst); \
             predicted {:.4} mm; against the measurements {:.4} mm, predicted {:.4} mm",
            planned_error.0 * 1e3,
            planned_error.1 * 1e3,
            random_error.0 * 1e3,
            random_error.1 * 1e3,
            p.predicted.rms * 1e3,
            against_measured * 1e3,
            p.predicted.measured_rms * 1e3,
        );
        ratio.push(p.predicted.rms / planned_error.0);
        measured_ratio.push(p.predicted.measured_rms / against_measured);
        planned.push(planned_error);
        random.push(random_error);
    }
    let rms = |v: &[(f64, f64)]| median(v.iter().map(|x| x.0).collect());
    let worst = |v: &[(f64, f64)]| median(v.iter().map(|x| x.1).collect());
    eprintln!(
        "{name}: median RMS planned/random {:.3}, worst {:.3}, predicted/measured {:.3}",
        rms(&planned) / rms(&random),
        worst(&planned) / worst(&random),
        median(ratio.clone())
    );
    assert!(
        rms(&planned) <= 0.8 * rms(&random),
        "{planned:?} {random:?}"
    );
    assert!(
        worst(&planned) <= 0.8 * worst(&random),
        "{planned:?} {random:?}"
    );
    for predicted in [median(ratio), median(measured_ratio)] {
        assert!(
            (0.7..=1.3).contains(&predicted),
            "predicted/found {predicted}"
        );
    }
}

#[test]
fn planned_poses_beat_random_ones_on_a_ur10e() {
    planned_against_random("ur10e", 15);
}

#[test]
fn planned_poses_beat_random_ones_on_a_puma_560() {
    planned_against_random("puma560", 15);
}

/// A plan for backlash serves it: a UR10e whose joint 2 has lost motion
/// (the default size of `simulate`'s backlash), measured along a plan of 20
/// poses each approached from both sides (80 rows), is diagnosed with the
/// backlash of joint 2.
#[test]
fn a_plan_for_backlash_lets_diagnose_name_it() {
    use armcal::calibration::diagnose::{DiagnoseOptions, diagnose};
    use armcal::calibration::plan::Visits;
    use armcal::calibration::simulate::{Scenario, parse_effect, simulate_visiting};
    let mut model = load_model("ur10e").unwrap();
    model.robot.tool.xyz = nalgebra::Vector3::from(SMR);
    let nominal = &model.robot;
    let options = PlanOptions {
        poses: 20,
        visits: Visits::BothSides,
        ..PlanOptions::default()
    };
    let p = plan(nominal, None, None, &options).unwrap();
    assert_eq!(p.q.len(), 80);
    let mut scenario = Scenario::tracker(p.q.len(), 5);
    scenario.effects = vec![parse_effect("backlash:2", nominal.dof()).unwrap()];
    scenario.temperature = (20.0, 20.0);
    let session = simulate_visiting(nominal, &scenario, |_| p.q.clone()).unwrap();
    let d = diagnose(nominal, &session.observations, &DiagnoseOptions::default()).unwrap();
    let found: Vec<String> = d
        .findings
        .iter()
        .map(|f| format!("{} {}", f.candidate.name, f.candidate.joints_label()))
        .collect();
    eprintln!("found {found:?}");
    assert_eq!(
        found.first().map(String::as_str),
        Some("backlash 2"),
        "{found:?}"
    );
}
