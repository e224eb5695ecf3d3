//! Compliance from the joint torques a robot reports (issue: the sessions
//! real robots produce, measured torques).
//!
//! A UR10e whose shoulder and elbow twist under gravity (joints 2 and 3,
//! 2e-6 and 3e-6 rad/(N·m): about 0.5 mrad at the arm's own torques),
//! measured by a tracker (120 positions, σ = 20 µm, every joint moving,
//! payloads 0 and 5 kg) while it reports its drives' torques (σ = 0.05 N·m).
//! The diagnosis fits the arm's masses to the torques
//! (`armcal::calibration::gravity`) and the compliance to the torques they
//! give:
//! - with the model's own masses right, compliance from the torques predicts
//!   held-out poses as well as compliance from the masses (within 2 %: the
//!   torques' noise);
//! - with the model's masses 30 % off (a mass model is an approximation),
//!   from the torques it predicts better than from the masses, and finds each
//!   compliance within three standard errors of its value;
//! - a model without any masses, from the torques, finds them too;
//! - four sessions at four payloads whose robot reports the load torques
//!   its sensors read (the drives' negated, as a KUKA iiwa does) give the
//!   calibration the drives' torques give, the sign read from the data or
//!   stated, and each joint's torque residual at the torque noise; read with
//!   the drives' sign, the masses fitted to them are not used.

use armcal::calibration::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use armcal::calibration::fit::Status;
use armcal::calibration::gravity::{MassesUsed, TorqueSign, with_measured_gravity};
use armcal::calibration::simulate::{Scenario, parse_effect, simulate};
use armcal::io::measurements::parse_measurements;
use armcal::io::model_file::load_model;
use armcal::session::model::RobotModel;
use armcal_shared::effects::Effect;

/// The true compliances: (joint, rad/(N·m)).
const COMPLIANCE: [(usize, f64); 2] = [(1, 2e-6), (2, 3e-6)];

/// The session, as `armcal` reads its CSV against `model` (with the
/// `tau` columns or without).
fn session(model: &RobotModel, torques: bool) -> armcal::session::measurements::Measurements {
    let truth = load_model("ur10e").unwrap();
    let mut scenario = Scenario::tracker(120, 31);
    scenario.effects = COMPLIANCE
        .iter()
        .map(|(j, c)| parse_effect(&format!("joint_compliance:{}:{c}", j + 1), 6).unwrap())
        .collect();
    scenario.temperature = (20.0, 20.0);
    scenario.torque_noise = Some(0.05);
    let s = simulate(&truth.robot, &scenario).unwrap();
    let mut text = s.to_csv(&truth.units, "UR10e with torques");
    if !torques {
        // The same rows without the tau columns.
        text = text
            .lines()
            .map(|l| {
                if l.starts_with('#') {
                    l.to_owned()
                } else {
                    l.split(',').take(12).collect::<Vec<_>>().join(",")
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
    }
    parse_measurements(&text, "s.csv", model).unwrap()
}

/// `armcal diagnose`'s diagnosis (default options) of `model` on the
/// session, the masses fitted to its torques when it has them.
fn diagnosis(model: &RobotModel, torques: bool) -> Diagnosis {
    let data = session(model, torques);
    let (fitted, gravity) = with_measured_gravity(model, &data, None).unwrap();
    assert_eq!(gravity.is_some(), torques);
    let observations = armcal::calibration::identify::observations(&data);
    diagnose(&fitted.robot, observations, &DiagnoseOptions::default()).unwrap()
}

/// Each compliance found, with its standard error: (joint, value, std).
fn compliances(d: &Diagnosis) -> Vec<(usize, f64, f64)> {
    d.fit
        .effects
        .iter()
        .filter_map(|e| match (e.effect, &e.status[0]) {
            (Effect::JointCompliance { joint, compliance }, Status::Identified { std }) => {
                Some((joint, compliance, *std))
            }
            _ => None,
        })
        .collect()
}

/// The model with every link's mass 30 % light.
fn light(model: &RobotModel) -> RobotModel {
    let mut m = model.clone();
    for l in &mut m.robot.links {
        if let Some(lm) = &mut l.mass {
            lm.mass *= 0.7;
        }
    }
    m
}

fn held_out(d: &Diagnosis) -> f64 {
    d.holdout.extended.rms
}

fn assert_found(d: &Diagnosis, what: &str) {
    let found = compliances(d);
    eprintln!("{what}: {found:?}, held-out {:.4} mm", held_out(d) * 1e3);
    for (joint, value) in COMPLIANCE {
        let (_, c, std) = found
            .iter()
            .find(|(j, _, _)| *j == joint)
            .unwrap_or_else(|| panic!("{what}: no compliance of joint {}", joint + 1));
        assert!(
            (c - value).abs() < 3.0 * std,
            "{what}: joint {}: {c:e} ± {std:e}",
            joint + 1
        );
    }
}

#[test]
fn right_masses_torques_predict_as_well() {
    let model = load_model("ur10e").unwrap();
    let (masses, torques) = (diagnosis(&model, false), diagnosis(&model, true));
    assert_found(&torques, "right masses, torques");
    assert!(
        held_out(&torques) <= 1.02 * held_out(&masses),
        "{} vs {}",
        held_out(&torques),
        held_out(&masses)
    );
}

#[test]
fn wrong_masses_torques_predict_better() {
    let model = light(&load_model("ur10e").unwrap());
    let (masses, torques) = (diagnosis(&model, false), diagnosis(&model, true));
    eprintln!(
        "30 % light masses: held-out {:.4} mm from the masses, {:.4} mm from the torques",
        held_out(&masses) * 1e3,
        held_out(&torques) * 1e3
    );
    assert_found(&torques, "light masses, torques");
    assert!(held_out(&torques) <= held_out(&masses));
}

#[test]
fn a_model_without_masses_gets_its_compliance_from_the_torques() {
    let mut model = load_model("ur10e").unwrap();
    for l in &mut model.robot.links {
        l.mass = None;
    }
    assert_found(&diagnosis(&model, true), "no masses, torques");
}

/// The torque noise of the four-session scenario, N·m.
const TORQUE_NOISE: f64 = 0.05;

/// Four sessions of 40 positions of the compliant UR10e, at 0, 1.25, 2.5
/// and 5 kg, the tracker moved and the SMR remounted between them, the
/// torques reported with `sign`: as armcal reads the four files.
fn payload_sessions(sign: TorqueSign) -> armcal::session::measurements::Measurements {
    let truth = load_model("ur10e").unwrap();
    let mut scenario = Scenario::tracker(160, 41);
    scenario.effects = COMPLIANCE
        .iter()
        .map(|(j, c)| parse_effect(&format!("joint_compliance:{}:{c}", j + 1), 6).unwrap())
        .collect();
    scenario.payloads = vec![0.0, 1.25, 2.5, 5.0];
    scenario.sessions = 4;
    scenario.torque_noise = Some(TORQUE_NOISE);
    scenario.torque_sign = sign;
    let s = simulate(&truth.robot, &scenario).unwrap();
    let mut data = parse_measurements(&s.to_csv(&truth.units, "UR10e"), "s.csv", &truth).unwrap();
    for (pose, simulated) in data.poses.iter_mut().zip(&s.observations) {
        pose.session = simulated.session;
    }
    data.sessions = (1..=4).map(|k| format!("s-{k}.csv")).collect();
    data
}

/// Every number of `a` within `relative` of `b`'s (1e-300 absolute for
/// zeros), the two of the same shape.
fn assert_close(a: &serde_json::Value, b: &serde_json::Value, relative: f64, at: &str) {
    use serde_json::Value;
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= relative * x.abs().max(y.abs()) + 1e-300,
                "{at}: {x} vs {y}"
            );
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}");
            for (i, (x, y)) in x.iter().zip(y).enumerate() {
                assert_close(x, y, relative, &format!("{at}[{i}]"));
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            assert_eq!(x.len(), y.len(), "{at}");
            for (k, x) in x {
                assert_close(x, &y[k], relative, &format!("{at}.{k}"));
            }
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

#[test]
fn load_torques_give_the_drive_torques_calibration() {
    use armcal::commands::{Front, diagnose as diagnose_cmd};
    let model = load_model("ur10e").unwrap();
    let run = |data: &armcal::session::measurements::Measurements, sign: Option<TorqueSign>| {
        let request = diagnose_cmd::Request {
            folds: None,
            scales: Default::default(),
            channel_weights: Default::default(),
            targets: armcal_shared::TargetFrame::World,
            frames: armcal::session::registration::FrameSharing::stated(false, false),
            torque_sign: sign,
            cancel: Default::default(),
        };
        diagnose_cmd::run(
            Front::CommandLine,
            &model,
            data,
            &request,
            &mut |_, _, _| {},
        )
        .unwrap()
    };
    let (drive, load) = (
        payload_sessions(TorqueSign::Drive),
        payload_sessions(TorqueSign::Load),
    );
    let reference = run(&drive, None);
    let g = reference.gravity.as_ref().unwrap();
    assert_eq!((g.sign, &g.used), (TorqueSign::Drive, &MassesUsed::Fitted));
    let want = serde_json::to_value(&reference.calibration).unwrap();
    for sign in [None, Some(TorqueSign::Load)] {
        let d = run(&load, sign);
        let g = d.gravity.as_ref().unwrap();
        let line = g.summary();
        eprintln!("{line}");
        assert_eq!(
            (g.sign, &g.used),
            (TorqueSign::Load, &MassesUsed::Fitted),
            "{line}"
        );
        assert!(
            line.contains("tau read as the sensors' load torques: negated"),
            "{line}"
        );
        // 160 rows, a few tens of unknowns: the residual RMS is the noise
        // within 25 %.
        for (j, r) in g.residual.iter().enumerate() {
            assert!(
                (0.75 * TORQUE_NOISE..1.25 * TORQUE_NOISE).contains(r),
                "joint {}: {r} N·m ({line})",
                j + 1
            );
        }
        let got = serde_json::to_value(&d.calibration).unwrap();
        assert_close(&got, &want, 1e-6, "calibration");
    }
    // Read with the drives' sign, the payloads' torques contradict the fit:
    // its masses are not used, joint 2 named, the sign that fits said.
    let (used, g) = with_measured_gravity(&model, &load, Some(TorqueSign::Drive)).unwrap();
    let g = g.unwrap();
    assert_eq!(used.robot, model.robot);
    let MassesUsed::ModelMasses(reasons) = &g.used else {
        panic!("{}", g.summary())
    };
    assert!(
        reasons.iter().any(|r| r.starts_with("tau2:")),
        "{reasons:?}"
    );
    // And says which sign the masses fit.
    assert!(
        reasons[0].ends_with("pass every check: --torque-sign load?"),
        "{reasons:?}"
    );
}
