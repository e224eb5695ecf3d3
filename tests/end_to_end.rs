//! End-to-end tests across armcal's crates: the host reads the shipped files, the
//! shared kinematics evaluates them, and the results are checked against values
//! derived outside armcal.
//!
//! One test binary, a module per topic.

mod builtin_models {
    //! The shipped models, read by the host's parser, run by the shared kinematics.

    use armcal::io::model_file::load_model;

    #[allow(clippy::approx_constant)] // Table 1 positions as printed.
    mod reference {
        include!("reference/puma_table1.rs");
    }
    use reference::{TABLE1_FK, TABLE1_POSITIONS};

    /// `puma560` read from its TOML (inches) and converted to SI reproduces the
    /// independently derived Table 1 forward kinematics after converting back:
    /// checks the unit handling end to end. Tolerance: the f64 rounding bound of
    /// the shared test (`k ε L`, k = 128, L = 70.25 in) plus the two unit
    /// conversions (a few ε relative on each length).
    #[test]
    fn puma560_reproduces_table1() {
        let model = load_model("puma560").expect("built-in puma560");
        assert_eq!(model.robot.dof(), 6);
        let tol = 136.0 * f64::EPSILON * 70.25;
        for (q, want) in TABLE1_POSITIONS.iter().zip(&TABLE1_FK) {
            let t = model.robot.forward(q).unwrap();
            for (r, want_row) in want.iter().enumerate() {
                let got_in = model.units.length_from_si(t.translation.vector[r]);
                assert!(
                    (got_in - want_row[3]).abs() <= tol,
                    "{got_in} vs {} in",
                    want_row[3]
                );
                for (c, want_rc) in want_row.iter().take(3).enumerate() {
                    let got = t.rotation.matrix()[(r, c)];
                    assert!((got - want_rc).abs() <= 136.0 * f64::EPSILON);
                }
            }
        }
    }

    /// Every shipped model runs in the controller's f32 and agrees with f64.
    #[test]
    fn every_builtin_model_runs_in_f32() {
        for name in armcal::io::builtin::MODEL_NAMES {
            let model = load_model(name).unwrap();
            let q = vec![0.3; model.robot.dof()];
            let q32 = vec![0.3f32; model.robot.dof()];
            let p64 = model.robot.measured_point(&q).unwrap();
            let p32 = model.robot.cast::<f32>().measured_point(&q32).unwrap();
            let reach: f64 = model
                .robot
                .links
                .iter()
                .map(|l| l.s.abs() + l.a.abs())
                .sum::<f64>()
                + 3.0;
            // k ε L with k = 16 (M + 2) + 4π M (inputs rounded to f32).
            let m = model.robot.dof() as f64;
            let tol =
                (16.0 * (m + 2.0) + 4.0 * std::f64::consts::PI * m) * f32::EPSILON as f64 * reach;
            assert!(
                (p64.coords - p32.coords.cast::<f64>()).norm() <= tol,
                "{name}"
            );
        }
    }
}

mod bundled_data {
    //! The bundled real data sets: the nominal error armcal computes equals the
    //! figure the data set's README gives, computed there by independent code
    //! when the data were converted.

    use armcal::calibration::check::nominal_error;
    use armcal::io::measurements::load_measurements;
    use armcal::io::model_file::load_model;

    /// `(data set, rms mm, mean mm, max mm)` as printed in each README, to 0.1 mm.
    const README_FIGURES: [(&str, f64, Option<f64>, f64); 3] = [
        ("figaroh-talos-left-arm", 5.3, Some(4.5), 11.2),
        ("figaroh-tiago-mocap", 4.1, Some(3.8), 7.1),
        ("figaroh-ur10e-camera", 74.0, None, 84.0),
    ];

    #[test]
    fn nominal_error_matches_the_data_readmes() {
        for (name, rms, mean, max) in README_FIGURES {
            let model = load_model(name).unwrap();
            let data = load_measurements(name, &model).unwrap();
            let e = nominal_error(&model, &data);
            // Printed with one decimal (two significant figures for the UR10e):
            // the true value lies within half a unit of the last digit.
            let half_unit = if rms >= 10.0 { 0.5 } else { 0.05 };
            let close = |got_m: f64, want_mm: f64| (got_m * 1e3 - want_mm).abs() <= half_unit;
            assert!(
                close(e.position_rms, rms),
                "{name}: rms {} mm",
                e.position_rms * 1e3
            );
            assert!(
                close(e.position_max, max),
                "{name}: max {} mm",
                e.position_max * 1e3
            );
            if let Some(mean) = mean {
                assert!(
                    close(e.position_mean, mean),
                    "{name}: mean {} mm",
                    e.position_mean * 1e3
                );
            }
        }
    }

    /// The UR10e camera set has orientation; its README gives 3.5° mean, 4.9° max.
    #[test]
    fn ur10e_orientation_error_matches_readme() {
        let model = load_model("figaroh-ur10e-camera").unwrap();
        let data = load_measurements("figaroh-ur10e-camera", &model).unwrap();
        let (_, mean, max) = nominal_error(&model, &data)
            .orientation
            .expect("orientation data");
        assert!(
            (mean.to_degrees() - 3.5).abs() <= 0.05,
            "mean {}°",
            mean.to_degrees()
        );
        assert!(
            (max.to_degrees() - 4.9).abs() <= 0.05,
            "max {}°",
            max.to_degrees()
        );
    }
}

mod identification {
    //! `--params full` recovers errors built into a simulated robot.

    use armcal::calibration::fit::{FitRequest, FullOptions, Status, full_params};
    use armcal::io::model_file::{load_model, parse_model};
    use armcal_shared::{FrameAxis, Param, Robot};
    use armcal_tests::{measure, random_configurations, rng, with_random_errors};

    /// A 6R industrial arm in modified D-H, millimetres and degrees (typical
    /// dimensions of a 10 kg class arm; not any maker's data).
    const INDUSTRIAL_MM_DEG: &str = r#"
name = "industrial6"
convention = "mdh"
length_unit = "mm"
angle_unit = "deg"
[[joint]]
type = "revolute"
theta = 0
s = 400
a = 0
alpha = 0
[[joint]]
type = "revolute"
theta = -90
s = 0
a = 25
alpha = -90
[[joint]]
type = "revolute"
theta = 0
s = 0
a = 455
alpha = 0
[[joint]]
type = "revolute"
theta = 0
s = 420
a = 35
alpha = -90
[[joint]]
type = "revolute"
theta = 0
s = 0
a = 0
alpha = 90
[[joint]]
type = "revolute"
theta = 0
s = 80
a = 0
alpha = -90
[tool]
xyz = [10, -20, 150]
[base]
xyz = [2500, -1200, 300]
rpy = [0, 0, 120]
"#;

    /// The mm/deg industrial arm, parsed.
    pub fn industrial_mm_deg() -> Robot<f64> {
        parse_model(INDUSTRIAL_MM_DEG, "industrial6.toml")
            .unwrap()
            .robot
    }

    fn robots() -> Vec<(&'static str, Robot<f64>)> {
        vec![
            ("puma560", load_model("puma560").unwrap().robot),
            ("ur10e", load_model("ur10e").unwrap().robot),
            (
                "industrial6",
                parse_model(INDUSTRIAL_MM_DEG, "industrial6.toml")
                    .unwrap()
                    .robot,
            ),
        ]
    }

    /// From exact data, the identified errors equal the built-in ones: every
    /// separable parameter to 1e-9 of the error scale (1 mm, 1 mrad), the base
    /// although it is 0.8 m and 35° away from nominal. The parameters that the
    /// data cannot separate carry no built-in error (their effect would be taken
    /// up by the ones they depend on, so no value would be "right"): a first fit
    /// names them, and they are reset to nominal in the truth.
    #[test]
    fn exact_data_recovers_the_built_in_errors() {
        for orientation in [false, true] {
            for (seed, (name, nominal)) in robots().into_iter().enumerate() {
                let mut r = rng(100 + seed as u64);
                let configs = random_configurations(&nominal, 60, &mut r);
                let all = full_params(&nominal, orientation);
                let (mut truth, _) = with_random_errors(&nominal, &all, 1e-3, 1e-3, &mut r);
                // The base far from nominal.
                for (axis, d) in [
                    (FrameAxis::X, 0.8),
                    (FrameAxis::Z, -0.3),
                    (FrameAxis::Rz, 35f64.to_radians()),
                ] {
                    *truth.param_mut(Param::Base(axis)).unwrap() += d;
                }
                // Which parameters these data cannot separate: ask the identification,
                // then take their errors out of the truth.
                let probe = measure(&truth, &configs, 0.0, orientation.then_some(0.0), &mut r);
                let fit = FitRequest::new(&nominal, &probe, &FullOptions::least_squares())
                    .run()
                    .unwrap();
                let fixed: Vec<Param> = fit
                    .params
                    .iter()
                    .filter(|p| matches!(p.status, Status::Fixed { .. }))
                    .map(|p| p.param)
                    .collect();
                for p in &fixed {
                    *truth.param_mut(*p).unwrap() = nominal.param(*p).unwrap();
                }
                let data = measure(&truth, &configs, 0.0, orientation.then_some(0.0), &mut r);
                let fit = FitRequest::new(&nominal, &data, &FullOptions::least_squares())
                    .run()
                    .unwrap();
                assert!(
                    fit.converged,
                    "{name}: not converged after {} iterations",
                    fit.iterations
                );
                let fixed_again: Vec<Param> = fit
                    .params
                    .iter()
                    .filter(|p| matches!(p.status, Status::Fixed { .. }))
                    .map(|p| p.param)
                    .collect();
                assert_eq!(
                    fixed_again, fixed,
                    "{name}: the same parameters are not separable"
                );
                for p in &fit.params {
                    let want = truth.param(p.param).unwrap() - nominal.param(p.param).unwrap();
                    let got = p.error;
                    assert!(
                        (got - want).abs() <= 1e-9 * 1e-3,
                        "{name} (orientation {orientation}): {}: identified {got:e}, built in {want:e}, status {:?}",
                        p.param,
                        p.status
                    );
                }
            }
        }
    }
}

mod identification_noise {
    //! With measurement noise the estimates scatter about the truth exactly as
    //! their standard errors say.

    use armcal::calibration::fit::{FitRequest, FullOptions, Status, full_params};
    use armcal::io::model_file::load_model;
    use armcal_shared::{Param, Robot};
    use armcal_tests::{measure, random_configurations, rng, with_random_errors};

    /// The parameters the data of `configs` cannot separate (from exact data).
    fn not_separable(nominal: &Robot<f64>, configs: &[Vec<f64>], orientation: bool) -> Vec<Param> {
        let mut r = rng(0);
        let exact = measure(nominal, configs, 0.0, orientation.then_some(0.0), &mut r);
        FitRequest::new(nominal, &exact, &FullOptions::least_squares())
            .run()
            .unwrap()
            .params
            .iter()
            .filter(|p| matches!(p.status, Status::Fixed { .. }))
            .map(|p| p.param)
            .collect()
    }

    /// A UR10e measured by a laser tracker (σ = 50 µm per axis) at 100 random
    /// poses, 30 independent noise draws on one true robot. For an unbiased
    /// estimator with correct standard errors the normalised errors
    /// `z = (identified − true) / std` are standard normal: every |z| of the 30 × p
    /// values stays below 4.5 (probability of one exceeding it by chance: about
    /// 30·p·7e-6 ≈ 0.006), and their mean square is 1 within ±0.25 (its standard
    /// deviation is √(2/(30 p)) ≈ 0.05, so this is a 5σ bound).
    #[test]
    fn standard_errors_match_the_scatter_over_noisy_draws() {
        let nominal = load_model("ur10e").unwrap().robot;
        let mut r = rng(7);
        let configs = random_configurations(&nominal, 100, &mut r);
        let fixed = not_separable(&nominal, &configs, false);
        let free: Vec<Param> = full_params(&nominal, false)
            .into_iter()
            .filter(|p| !fixed.contains(p))
            .collect();
        let (truth, _) = with_random_errors(&nominal, &free, 1e-3, 1e-3, &mut r);
        let noise = 50e-6;
        let options = FullOptions {
            position_noise: noise,
            ..FullOptions::least_squares()
        };
        let (mut sum_z2, mut count, mut worst) = (0.0, 0usize, 0.0f64);
        for _ in 0..30 {
            let data = measure(&truth, &configs, noise, None, &mut r);
            let fit = FitRequest::new(&nominal, &data, &options).run().unwrap();
            assert!(fit.converged);
            for p in &fit.params {
                if let Status::Identified { std } = p.status {
                    let want = truth.param(p.param).unwrap() - nominal.param(p.param).unwrap();
                    let z = (p.error - want) / std;
                    sum_z2 += z * z;
                    count += 1;
                    worst = worst.max(z.abs());
                }
            }
        }
        let mean_z2 = sum_z2 / count as f64;
        assert!(worst < 4.5, "largest |z| = {worst}");
        assert!(
            (mean_z2 - 1.0).abs() < 0.25,
            "mean z² = {mean_z2} over {count} values"
        );
    }

    /// One noisy draw on each robot (positions σ = 50 µm, orientations σ = 50 µrad):
    /// every identified parameter lies within 4 standard errors of its built-in
    /// value (for ~30 normal z-values the chance that one exceeds 4 is 0.2 %).
    #[test]
    fn every_estimate_is_within_four_standard_errors() {
        let industrial = super::identification::industrial_mm_deg();
        let robots = [
            ("puma560", load_model("puma560").unwrap().robot),
            ("ur10e", load_model("ur10e").unwrap().robot),
            ("industrial6", industrial),
        ];
        for (seed, (name, nominal)) in robots.into_iter().enumerate() {
            for orientation in [false, true] {
                let mut r = rng(40 + seed as u64);
                let configs = random_configurations(&nominal, 80, &mut r);
                let fixed = not_separable(&nominal, &configs, orientation);
                let free: Vec<Param> = full_params(&nominal, orientation)
                    .into_iter()
                    .filter(|p| !fixed.contains(p))
                    .collect();
                let (truth, _) = with_random_errors(&nominal, &free, 1e-3, 1e-3, &mut r);
                let noise = 50e-6;
                let data = measure(
                    &truth,
                    &configs,
                    noise,
                    orientation.then_some(noise),
                    &mut r,
                );
                let options = FullOptions {
                    position_noise: noise,
                    orientation_noise: noise,
                    ..FullOptions::least_squares()
                };
                let fit = FitRequest::new(&nominal, &data, &options).run().unwrap();
                for p in &fit.params {
                    if let Status::Identified { std } = p.status {
                        let want = truth.param(p.param).unwrap() - nominal.param(p.param).unwrap();
                        let z = (p.error - want) / std;
                        assert!(
                            z.abs() <= 4.0,
                            "{name} (orientation {orientation}) {}: z = {z:.2}",
                            p.param
                        );
                    }
                }
            }
        }
    }

    /// Fewer equations than identifiable parameters is refused with the counts.
    #[test]
    fn too_few_poses_are_refused() {
        let nominal = load_model("ur10e").unwrap().robot;
        let mut r = rng(5);
        let configs = random_configurations(&nominal, 6, &mut r);
        let data = measure(&nominal, &configs, 0.0, None, &mut r);
        let err = FitRequest::new(&nominal, &data, &FullOptions::least_squares())
            .run()
            .unwrap_err();
        let text = err.to_string();
        assert!(text.contains("18 equations"), "{text}");
        assert!(text.contains("measure more poses"), "{text}");
    }

    /// Parallel consecutive axes are found and named: the PUMA's axes 2 and 3
    /// (α2 = 0), the UR10e's axes 2, 3 and 4 (α2 = α3 = 0).
    #[test]
    fn parallel_axes_are_named() {
        for (name, expected) in [
            ("puma560", vec![Param::S(2)]),
            ("ur10e", vec![Param::S(2), Param::S(3)]),
        ] {
            let nominal = load_model(name).unwrap().robot;
            let mut r = rng(3);
            let configs = random_configurations(&nominal, 50, &mut r);
            let data = measure(&nominal, &configs, 0.0, Some(0.0), &mut r);
            let fit = FitRequest::new(&nominal, &data, &FullOptions::least_squares())
                .run()
                .unwrap();
            for want in expected {
                let p = fit.params.iter().find(|p| p.param == want).unwrap();
                match &p.status {
                    Status::Fixed { reason } => {
                        let m = match want {
                            Param::S(m) => m,
                            _ => unreachable!(),
                        };
                        assert!(
                            reason.contains(&format!("axes {m} and {} parallel", m + 1)),
                            "{name} {want}: {reason}"
                        );
                        // The offset along the parallel axes that is kept is s2's.
                        assert!(
                            reason.contains("not separable from s2"),
                            "{name} {want}: {reason}"
                        );
                    }
                    other => panic!("{name}: {want} should be fixed, is {other:?}"),
                }
            }
        }
    }
}

mod compensation {
    //! Closed loop on the host: a simulated true robot, a calibration identified
    //! from its noisy measurements, and the compensation the controller runs.

    use armcal::calibration::fit::{FitRequest, FullOptions, Status, full_params};
    use armcal::io::model_file::load_model;
    use armcal_shared::calibration::ParamError;
    use armcal_shared::compensation::{Compensator, Conditions, Fault, Limits};
    use armcal_shared::units::Units;
    use armcal_shared::{Calibration, Robot};
    use armcal_tests::{measure, random_configurations, rng, sigma_min, with_random_errors};

    /// UR10e with ±1 mm / ±1 mrad errors, identified from 200 noisy full poses
    /// (σ = 20 µm, 20 µrad): the truth, the calibration, and 100 commands.
    fn setup() -> (Robot<f64>, Calibration, Vec<Vec<f64>>) {
        let nominal = load_model("ur10e").unwrap().robot;
        let mut r = rng(11);
        let params = full_params(&nominal, true);
        let (truth, _) = with_random_errors(&nominal, &params, 1e-3, 1e-3, &mut r);
        let configs = random_configurations(&nominal, 200, &mut r);
        let data = measure(&truth, &configs, 20e-6, Some(20e-6), &mut r);
        let options = FullOptions {
            position_noise: 20e-6,
            orientation_noise: 20e-6,
            ..FullOptions::default()
        };
        let fit = FitRequest::new(&nominal, &data, &options).run().unwrap();
        let mut cal = Calibration::nominal(
            nominal.clone(),
            armcal_shared::compensation::Task::Pose,
            Units::SI,
        );
        for p in fit
            .params
            .iter()
            .filter(|p| matches!(p.status, Status::Identified { .. }))
        {
            cal.errors
                .push(ParamError {
                    param: p.param,
                    error: p.error,
                })
                .unwrap();
        }
        let commands = random_configurations(&nominal, 100, &mut r);
        (truth, cal, commands)
    }

    /// Away from singularities (σ_min > 0.05) the robot's error at the target
    /// shrinks to the calibrated model's own prediction error plus at most 2 µm,
    /// and from millimetres to tens of µm. Near them the correction is flagged
    /// and stays within its bounds.
    #[test]
    fn compensated_robot_reaches_the_nominal_target() {
        let (truth, cal, commands) = setup();
        let calibrated = cal.calibrated();
        let limits = Limits::default();
        let compensator = Compensator::<f64>::from_calibration(&cal, limits);
        let (mut before, mut after, mut counted) = (0.0, 0.0, 0);
        for q_cmd in &commands {
            let c = compensator.correct(q_cmd, &Conditions::default());
            if sigma_min(&calibrated, q_cmd) < 0.05 {
                for (q, q0) in c.q.iter().zip(q_cmd) {
                    // The bound, plus the rounding of `q_cmd + correction`.
                    let bound =
                        limits.max_correction_angle + 2.0 * f64::EPSILON * q0.abs().max(1.0);
                    assert!(q.is_finite() && (q - q0).abs() <= bound, "{q} from {q0}");
                }
                continue;
            }
            assert_eq!(c.fault, None, "{q_cmd:?}");
            counted += 1;
            let target = cal.nominal.measured_point(q_cmd).unwrap();
            let reached = truth.measured_point(&c.q).unwrap();
            let model_error = (reached - calibrated.measured_point(&c.q).unwrap()).norm();
            let error = (reached - target).norm();
            assert!(
                error <= model_error + 2e-6,
                "error {error:e} m, calibrated model's own {model_error:e} m"
            );
            before += (truth.measured_point(q_cmd).unwrap() - target).norm();
            after += error;
        }
        // Random joint vectors over the full ranges put about a third of the UR10e's
        // configurations near a singularity (68 of these 100 are away from one).
        assert!(
            counted >= 50,
            "only {counted} of 100 random commands away from singularities"
        );
        let (before, after) = (before / counted as f64, after / counted as f64);
        assert!(
            before > 1e-3 && after < 1e-4,
            "mean error {before:e} m uncompensated, {after:e} m compensated"
        );
    }

    /// The controller's f32 corrections put the calibrated robot's tool point
    /// within 2 µm of where the host's f64 ones put it (away from singularities).
    #[test]
    fn f32_corrections_agree_with_f64_within_two_micrometres() {
        let (_, cal, commands) = setup();
        let calibrated = cal.calibrated();
        let c64 = Compensator::<f64>::from_calibration(&cal, Limits::default());
        let c32 = Compensator::<f32>::from_calibration(&cal, Limits::default());
        for q_cmd in commands
            .iter()
            .filter(|q| sigma_min(&calibrated, q) >= 0.05)
        {
            let a = c64.correct(q_cmd, &Conditions::default());
            let q32: Vec<f32> = q_cmd.iter().map(|&x| x as f32).collect();
            let b = c32.correct(&q32, &Conditions::default());
            assert_eq!((a.fault, b.fault), (None, None), "{q_cmd:?}");
            let qb: Vec<f64> = b.q.iter().map(|&x| x as f64).collect();
            let pa = calibrated.measured_point(&a.q).unwrap();
            let pb = calibrated.measured_point(&qb).unwrap();
            assert!(
                (pa - pb).norm() <= 2e-6,
                "{:e} m apart at {q_cmd:?}",
                (pa - pb).norm()
            );
        }
    }

    /// A non-finite command returns the nominal command with a fault, never a wild one.
    #[test]
    fn non_finite_commands_keep_the_nominal_command() {
        let (_, cal, _) = setup();
        let comp = Compensator::<f32>::from_calibration(&cal, Limits::default());
        let q = [0.1, f32::NAN, 0.3, 0.4, 0.5, 0.6];
        let c = comp.correct(&q, &Conditions::default());
        assert_eq!(c.fault, Some(Fault::NonFinite));
        assert!(c.q.iter().zip(&q).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}

mod compensation_of_effects {
    //! Closed loop with hidden effects: a simulated true robot with geometric
    //! errors and non-geometric effects, measured in a session with a
    //! temperature drift and payload blocks; the calibration `armcal diagnose`
    //! makes of it (geometry and the effects it finds); a smooth motion
    //! compensated tick by tick in its conditions, as the controller does.

    use armcal::calibration::diagnose::{DiagnoseOptions, diagnose};
    use armcal::calibration::fit::FullOptions;
    use armcal::calibration::simulate::{Scenario, simulate};
    use armcal::io::model_file::load_model;
    use armcal_shared::compensation::{Compensator, Conditions, Limits, Pacing, Stream};
    use armcal_shared::effects::{Approach, Context, Effect, EffectModel};
    use armcal_shared::units::Units;
    use armcal_tests::{random_configuration, rng};

    /// UR10e, 300 tracker positions (σ = 20 µm) at 20–30 °C with 0 and 5 kg,
    /// ±1 mm / ±1 mrad geometry, a hidden compliance of joint 2 and backlash of
    /// joint 4. A motion of 60 ticks (1 mrad per tick per joint, joint 4
    /// reversing halfway) at 27 °C with 5 kg, away from singularities, is
    /// compensated with the diagnosis's calibration. At every tick the true
    /// robot's tool point at the compensated commands is within the calibrated
    /// model's own prediction error at those commands plus 2 µm of the nominal
    /// target (the compensation puts the calibrated model on the target to
    /// 11 nm: `shared/tests/compensation.rs`), and the mean error falls from the
    /// uncompensated millimetres to the model's error.
    #[test]
    fn compensated_true_robot_with_effects_reaches_the_nominal_target() {
        let nominal = load_model("ur10e").unwrap().robot;
        let mut scenario = Scenario::tracker(300, 17);
        scenario.effects = vec![
            Effect::JointCompliance {
                joint: 1,
                compliance: 3e-6,
            },
            Effect::Backlash {
                joint: 3,
                half_lost_motion: 2e-4,
            },
        ];
        let session = simulate(&nominal, &scenario).unwrap();
        let options = DiagnoseOptions {
            folds: 5,
            fit: FullOptions {
                position_noise: 20e-6,
                ..FullOptions::default()
            },
            ..DiagnoseOptions::default()
        };
        let diagnosis = diagnose(&nominal, &session.observations, &options).unwrap();
        let cal = diagnosis.calibration(
            &nominal,
            armcal_shared::compensation::Task::Position,
            Units::SI,
        );
        assert!(!cal.effects.is_empty(), "the diagnosis found effects");
        let truth = EffectModel::new(session.truth.clone(), &session.effects).unwrap();
        let model = cal.model();
        let compensator = Compensator::<f64>::from_calibration(&cal, Limits::default());
        let conditions = Conditions {
            temperature: Some(27.0),
            payload: Some(5.0),
        };
        // A start whose whole motion stays away from singularities: the
        // compensation converges (no fault) at every tick.
        let mut r = rng(3);
        let motion = |q0: &[f64]| -> Vec<Vec<f64>> {
            (0..60)
                .map(|t| {
                    q0.iter()
                        .enumerate()
                        .map(|(m, q)| {
                            let ticks = if m == 3 && t > 30 { 60 - t } else { t };
                            q + 1e-3 * ticks as f64
                        })
                        .collect()
                })
                .collect()
        };
        // The context of a command, with the approach of the stream it is sent in.
        let context = |q: &[f64], stream: &mut Approach| Context {
            temperature: conditions.temperature,
            payload: conditions.payload,
            approach: stream.next(q),
        };
        // The motion's ticks: command, corrected command and its context, and
        // the context of the command sent uncompensated.
        type Tick = (Vec<f64>, Vec<f64>, Context<f64>, Context<f64>);
        let mut ticks: Vec<Tick> = Vec::new();
        for tried in 0.. {
            assert!(tried < 50, "no motion away from singularities");
            let q0 = random_configuration(&nominal, &mut r);
            ticks.clear();
            let mut stream = Stream::new(Pacing::Servo);
            // The streams of compensated and of uncompensated commands.
            let (mut sent, mut uncompensated) = (Approach::new(), Approach::new());
            for q_cmd in motion(&q0) {
                let c = stream.tick(&compensator, &q_cmd, &conditions);
                if c.fault.is_some() {
                    break;
                }
                let ctx = context(&c.q, &mut sent);
                let plain = context(&q_cmd, &mut uncompensated);
                ticks.push((q_cmd, c.q.to_vec(), ctx, plain));
            }
            if ticks.len() == 60 {
                break;
            }
        }
        let (mut before, mut after) = (0.0, 0.0);
        for (q_cmd, q, ctx, plain) in &ticks {
            let target = nominal.measured_point(q_cmd).unwrap().coords;
            let point = |m: &EffectModel<f64>, q: &[f64], ctx: &Context<f64>| {
                m.forward(q, ctx).unwrap().translation.vector
            };
            let reached = point(&truth, q, ctx);
            let model_error = (reached - point(&model, q, ctx)).norm();
            let error = (reached - target).norm();
            assert!(
                error <= model_error + 2e-6,
                "error {error:e} m, calibrated model's own {model_error:e} m"
            );
            before += (point(&truth, q_cmd, plain) - target).norm();
            after += error;
        }
        let n = ticks.len() as f64;
        assert!(
            before / n > 1e-3 && after / n < 1e-4,
            "mean error {:e} m uncompensated, {:e} m compensated",
            before / n,
            after / n
        );
    }
}

mod extended_fit {
    //! The geometry refitted together with a hidden effect's parameters recovers
    //! the effect and brings the residual down to the noise.

    use armcal::calibration::fit::{Extension, FitRequest, FullFit, FullOptions, Status};
    use armcal::calibration::identify::observations;
    use armcal::calibration::simulate::{
        Scenario, one_joint_at_a_time, random_configurations, simulate, simulate_visiting,
    };
    use armcal::io::measurements::parse_measurements;
    use armcal::io::model_file::load_model;
    use armcal::session::observation::Observation;
    use armcal_shared::Param;
    use armcal_shared::effects::Effect;

    /// UR10e, 400 tracker positions (σ = 20 µm), ±1 mm / ±1 mrad geometric errors,
    /// one hidden effect of realistic size. The geometric fit alone leaves a
    /// variance factor well above 1; with the effect's structure added (its
    /// parameters starting at zero) the variance factor is 1 within 5 standard
    /// deviations of its sampling distribution (√(2/dof) ≈ 0.05), and every
    /// effect parameter lies within 4 standard errors of the built-in value.
    #[test]
    fn each_hidden_effect_is_recovered_with_the_geometry() {
        let nominal = load_model("ur10e").unwrap().robot;
        let cases: [Effect<f64>; 5] = [
            Effect::JointCompliance {
                joint: 1,
                compliance: 3e-6,
            },
            Effect::GearTransmission {
                joint: 2,
                first: [2e-4, -1e-4],
                second: [1e-4, 5e-5],
            },
            Effect::Backlash {
                joint: 1,
                half_lost_motion: 2e-4,
            },
            Effect::ThermalExpansion {
                coefficient: 2.3e-5,
                reference: 25.0,
            },
            Effect::EncoderScale {
                joint: 0,
                scale: 2e-4,
            },
        ];
        for (seed, effect) in cases.into_iter().enumerate() {
            let mut scenario = Scenario::tracker(400, 70 + seed as u64);
            scenario.effects = vec![effect];
            let session = simulate(&nominal, &scenario).unwrap();
            let options = FullOptions {
                position_noise: 20e-6,
                ..FullOptions::default().stated()
            };
            let geometric = FitRequest::new(&nominal, &session.observations, &options)
                .run()
                .unwrap();
            assert!(
                geometric.variance_factor > 2.0,
                "{}: geometry alone already fits ({})",
                effect.name(),
                geometric.variance_factor
            );
            // The structure of the effect, its parameters at zero (thermal: the
            // reference temperature is the data's mean, 25 °C).
            let mut start = effect;
            for i in 0..start.parameter_count() {
                *start.parameter_mut(i).unwrap() = 0.0;
            }
            let fit = FitRequest::new(&nominal, &session.observations, &options)
                .extended(Extension {
                    effects: &[start],
                    extra: &[],
                })
                .run()
                .unwrap();
            let dof = fit.equations as f64 - 40.0;
            assert!(
                (fit.variance_factor - 1.0).abs() < 5.0 * (2.0 / dof).sqrt(),
                "{}: variance factor {}",
                effect.name(),
                fit.variance_factor
            );
            let found = &fit.effects[0];
            for i in 0..effect.parameter_count() {
                let Status::Identified { std } = found.status[i] else {
                    panic!(
                        "{}: parameter {i} not identified: {:?}",
                        effect.name(),
                        found.status[i]
                    );
                };
                let (got, want) = (
                    found.effect.parameter(i).unwrap(),
                    effect.parameter(i).unwrap(),
                );
                assert!(
                    (got - want).abs() <= 4.0 * std,
                    "{} [{i}]: {got:e} vs {want:e} ± {std:e}",
                    effect.name()
                );
            }
        }
    }

    /// The degrees of freedom of a fit: its equations less every parameter it
    /// identified (geometric and of the effects).
    fn dof(fit: &FullFit) -> f64 {
        let identified = |s: &Status| matches!(s, Status::Identified { .. });
        let geometric = fit.params.iter().filter(|p| identified(&p.status)).count();
        let effects = fit
            .effects
            .iter()
            .flat_map(|e| &e.status)
            .filter(|s| identified(s))
            .count();
        (fit.equations - geometric - effects) as f64
    }

    /// Single-joint sweeps: UR10e, 67 random configurations visited one joint at
    /// a time (397 tracker positions, σ = 20 µm, ±1 mm / ±1 mrad geometry), a
    /// hidden backlash of joint 2 (0.2 mrad half the lost motion). In 5 of 6
    /// rows joint 2 holds, on the flank of its last move. Written as a
    /// measurement CSV (`docs/file-formats.md` §2) and read back, the rows in measurement order give the
    /// fit the simulator's approach signs; with the backlash's structure added
    /// the variance factor is 1 within 5 standard deviations of its sampling
    /// distribution (√(2/dof)) and the backlash lies within 4 standard errors of
    /// the hidden one. The same fit with the holding joints' signs set to 0 (a
    /// holding joint in the middle of its lost motion) leaves a variance factor
    /// outside that band: the data tell the conventions apart.
    #[test]
    fn backlash_is_recovered_from_single_joint_sweeps() {
        let model = load_model("ur10e").unwrap();
        let nominal = model.robot.clone();
        let half_lost_motion = 2e-4;
        let effect = Effect::Backlash {
            joint: 1,
            half_lost_motion,
        };
        let mut scenario = Scenario::tracker(0, 77);
        scenario.effects = vec![effect];
        let session = simulate_visiting(&nominal, &scenario, |r| {
            one_joint_at_a_time(&random_configurations(&nominal, 67, r))
        })
        .unwrap();
        assert_eq!(session.observations.len(), 397);
        for pair in session.q.windows(2) {
            let moved = pair[0].iter().zip(&pair[1]).filter(|(a, b)| a != b);
            assert_eq!(moved.count(), 1, "one joint moves per row");
        }
        // The fit reads the signs from the file's row order.
        let csv = session.to_csv(&model.units, "single-joint sweeps");
        let data = parse_measurements(&csv, "sweeps.csv", &model).unwrap();
        let observations = observations(&data);
        let mut holding = 0;
        for (i, (read, simulated)) in observations.iter().zip(&session.observations).enumerate() {
            assert_eq!(read.context.approach, simulated.context.approach, "row {i}");
            let sigma = read.context.approach[1];
            if i > 0 && session.q[i][1] == session.q[i - 1][1] && sigma != 0 {
                holding += 1;
            }
        }
        assert!(
            holding > 300,
            "{holding} rows where joint 2 holds on a flank"
        );
        let options = FullOptions {
            position_noise: 20e-6,
            ..FullOptions::default().stated()
        };
        let mut start = effect;
        *start.parameter_mut(0).unwrap() = 0.0;
        let fit = |data: &[Observation]| {
            FitRequest::new(&nominal, data, &options)
                .extended(Extension {
                    effects: &[start],
                    extra: &[],
                })
                .run()
                .unwrap()
        };
        let geometric = FitRequest::new(&nominal, observations, &options)
            .run()
            .unwrap();
        assert!(
            geometric.variance_factor > 2.0,
            "geometry alone already fits ({})",
            geometric.variance_factor
        );
        let extended = fit(observations);
        let band = 5.0 * (2.0 / dof(&extended)).sqrt();
        assert!(
            (extended.variance_factor - 1.0).abs() < band,
            "variance factor {} (band ±{band})",
            extended.variance_factor
        );
        let Status::Identified { std } = extended.effects[0].status[0] else {
            panic!("{:?}", extended.effects[0].status[0]);
        };
        let got = extended.effects[0].effect.parameter(0).unwrap();
        assert!(
            (got - half_lost_motion).abs() <= 4.0 * std,
            "{got:e} vs {half_lost_motion:e} ± {std:e}"
        );
        // The holding joints in the middle of their lost motion instead.
        let mut middle = observations.to_vec();
        for (i, o) in middle.iter_mut().enumerate().skip(1) {
            for (j, sigma) in o.context.approach.iter_mut().enumerate() {
                if session.q[i][j] == session.q[i - 1][j] {
                    *sigma = 0;
                }
            }
        }
        let wrong = fit(&middle);
        let band = 5.0 * (2.0 / dof(&wrong)).sqrt();
        assert!(
            wrong.variance_factor - 1.0 > band,
            "σ = 0 while holding fits as well: variance factor {}",
            wrong.variance_factor
        );
    }

    /// A Hayati tilt between the UR10e's parallel axes 2 and 3 (β2), which
    /// standard D-H cannot express, is recovered as `beta2`.
    #[test]
    fn a_tilt_between_parallel_axes_is_recovered() {
        let nominal = load_model("ur10e").unwrap().robot;
        let mut scenario = Scenario::tracker(400, 91);
        scenario.tilts = vec![(1, 1.5e-3)];
        let session = simulate(&nominal, &scenario).unwrap();
        let options = FullOptions {
            position_noise: 20e-6,
            ..FullOptions::default().stated()
        };
        let fit = FitRequest::new(&nominal, &session.observations, &options)
            .extended(Extension {
                effects: &[],
                extra: &[Param::Beta(1)],
            })
            .run()
            .unwrap();
        let beta = fit
            .params
            .iter()
            .find(|p| p.param == Param::Beta(1))
            .unwrap();
        let Status::Identified { std } = beta.status else {
            panic!("{:?}", beta.status)
        };
        assert!(
            (beta.error - 1.5e-3).abs() <= 4.0 * std,
            "{} ± {std}",
            beta.error
        );
    }
}

mod diagnosis {
    //! Hide an effect in simulated data and require the diagnosis to find it.

    use armcal::calibration::diagnose::{DiagnoseOptions, diagnose};
    use armcal::calibration::simulate::{Scenario, simulate};
    use armcal::calibration::sweep::tracker_diagnosis;
    use armcal::io::model_file::load_model;
    use armcal_shared::effects::Effect;

    /// 5-fold, σ = 20 µm: the simulated tracker's noise.
    fn options() -> DiagnoseOptions {
        tracker_diagnosis()
    }

    /// A hidden compliance of joint 2 is named, with its joint, and the extended
    /// model's held-out RMS comes within 2× of the noise-limited one.
    #[test]
    fn a_hidden_compliance_is_named() {
        let nominal = load_model("ur10e").unwrap().robot;
        let mut scenario = Scenario::tracker(300, 5);
        scenario.effects = vec![Effect::JointCompliance {
            joint: 1,
            compliance: 3e-6,
        }];
        let session = simulate(&nominal, &scenario).unwrap();
        let d = diagnose(&nominal, &session.observations, &options()).unwrap();
        let names: Vec<(&str, Vec<usize>)> = d
            .findings
            .iter()
            .map(|f| (f.candidate.name, f.candidate.joints.clone()))
            .collect();
        assert_eq!(
            names.first(),
            Some(&("joint_compliance", vec![1])),
            "{names:?}"
        );
        let (geometric, extended) = (d.holdout.geometric, d.holdout.extended);
        assert!(
            extended.rms < geometric.rms,
            "{extended:?} vs {geometric:?}"
        );
        // Noise-limited held-out RMS of a 3-D position: about σ √3 (1 + p/n).
        assert!(
            extended.rms < 2.0 * 20e-6 * 3f64.sqrt() * 1.2,
            "{extended:?}"
        );
    }

    /// Every effect of the library, hidden in turn on the UR10e (300 tracker
    /// positions, σ = 20 µm, ±1 mm / ±1 mrad geometry, 20–30 °C, payload 0 and
    /// 5 kg), is named first, with its joints.
    #[test]
    fn every_hidden_effect_is_named_with_its_joints() {
        let nominal = load_model("ur10e").unwrap().robot;
        /// What is hidden (an effect or a tilt `(joint, β)`), and what must be named.
        type Case = (
            Option<Effect<f64>>,
            Option<(usize, f64)>,
            &'static str,
            Vec<usize>,
        );
        let cases: [Case; 5] = [
            (
                Some(Effect::GearTransmission {
                    joint: 2,
                    first: [2e-4, 0.0],
                    second: [0.0, 1e-4],
                }),
                None,
                "gear_transmission",
                vec![2],
            ),
            (
                Some(Effect::Backlash {
                    joint: 0,
                    half_lost_motion: 2e-4,
                }),
                None,
                "backlash",
                vec![0],
            ),
            (
                Some(Effect::ThermalExpansion {
                    coefficient: 2.3e-5,
                    reference: 20.0,
                }),
                None,
                "thermal_expansion",
                vec![],
            ),
            (
                Some(Effect::EncoderScale {
                    joint: 3,
                    scale: 3e-4,
                }),
                None,
                "encoder_scale",
                vec![3],
            ),
            (None, Some((1, 1.5e-3)), "parallel_axis_tilt", vec![1, 2]),
        ];
        for (seed, (effect, tilt, name, joints)) in cases.into_iter().enumerate() {
            let mut scenario = Scenario::tracker(300, 20 + seed as u64);
            scenario.effects = effect.into_iter().collect();
            scenario.tilts = tilt.into_iter().collect();
            let session = simulate(&nominal, &scenario).unwrap();
            let d = diagnose(&nominal, &session.observations, &options()).unwrap();
            let found: Vec<(&str, Vec<usize>)> = d
                .findings
                .iter()
                .map(|f| (f.candidate.name, f.candidate.joints.clone()))
                .collect();
            assert_eq!(found.first(), Some(&(name, joints)), "{found:?}");
        }
    }

    /// A real compliance whose deflection, after the geometry has absorbed
    /// what it can, is about a fifth of the 20 µm noise: over 1,000 positions
    /// its F statistic is far past the threshold (it grows with the poses,
    /// about 3n·(e/σ)² ≈ 120), but it lowers the held-out RMS by about
    /// √(1 + 0.2²) − 1 ≈ 2 %, under the 5 % asked. It is not modelled, and the
    /// summary says why: not that more poses would settle it (they would not
    /// raise the gain), but that it gains too little.
    #[test]
    fn a_real_effect_too_small_to_matter_is_called_so() {
        use armcal::calibration::diagnose::{Shortfall, report::RowPlaces};
        let nominal = load_model("ur10e").unwrap().robot;
        let mut scenario = Scenario::tracker(1000, 7);
        scenario.effects = vec![Effect::JointCompliance {
            joint: 1,
            compliance: 1e-7,
        }];
        let session = simulate(&nominal, &scenario).unwrap();
        let d = diagnose(&nominal, &session.observations, &options()).unwrap();
        assert!(d.findings.is_empty(), "{:?}", d.findings);
        let u = d
            .unsettled
            .as_ref()
            .expect("the compliance gained held-out");
        assert_eq!(
            (u.candidate.name, u.candidate.joints.as_slice()),
            ("joint_compliance", [1].as_slice())
        );
        let (f, threshold) = u.f_test;
        assert!(f > 3.0 * threshold, "F {f} against {threshold}");
        assert!(u.gain > 1.0 && u.gain < 1.05, "gain {}", u.gain);
        assert_eq!(u.shortfall, Shortfall::Gain { min_gain: 1.05 });
        let lines: Vec<usize> = (2..2 + session.observations.len()).collect();
        // The summary is rendered from the report, as the command prints it.
        let model = load_model("ur10e").unwrap();
        let summary = d
            .report(&model, RowPlaces::lines(&lines), &options())
            .summary();
        assert!(
            summary.contains("not worth modelling: joint_compliance (joints 2)"),
            "{summary}"
        );
        assert!(!summary.contains("would settle it"), "{summary}");
    }

    /// Pure geometry: nothing beyond geometry is named, and the noise estimate
    /// is the simulated 20 µm within 10 %.
    #[test]
    fn pure_geometry_names_nothing() {
        let nominal = load_model("ur10e").unwrap().robot;
        let session = simulate(&nominal, &Scenario::tracker(300, 6)).unwrap();
        let d = diagnose(&nominal, &session.observations, &options()).unwrap();
        assert!(
            d.findings.is_empty(),
            "{:?}",
            d.findings
                .iter()
                .map(|f| f.candidate.name)
                .collect::<Vec<_>>()
        );
        assert!((d.noise / 20e-6 - 1.0).abs() < 0.1, "noise {}", d.noise);
        assert!(d.blunders.is_empty());
    }
}

mod diagnosis_random {
    //! The issue's hidden-effect tests: for each effect, a random robot (the PUMA,
    //! a UR arm, a mm/deg industrial arm), random joint, a magnitude leaving 5–20×
    //! the noise after a geometric fit, a random seed.

    use armcal::calibration::diagnose::{cross_validate, diagnose};
    use armcal::calibration::fit::FitRequest;
    use armcal::calibration::simulate::{rng, simulate};
    use armcal::calibration::sweep::{hidden_case, tracker_diagnosis};
    use armcal::io::model_file::load_model;
    use armcal_shared::effects::Effect;
    use armcal_shared::{Param, Robot};
    use rand::RngExt;

    /// The diagnosis names the hidden effect and its joints, and the extended
    /// model's held-out RMS is within 2× of what the true model structure (the
    /// geometry plus the hidden effect's own parameters) achieves on the same data.
    #[test]
    fn each_effect_on_a_random_robot_joint_and_size_is_named() {
        let robots: Vec<(&str, Robot<f64>)> = vec![
            ("puma560", load_model("puma560").unwrap().robot),
            ("ur10e", load_model("ur10e").unwrap().robot),
            ("industrial6", super::identification::industrial_mm_deg()),
        ];
        let options = tracker_diagnosis();
        let mut r = rng(2024);
        let noise_rms = 20e-6 * 3f64.sqrt();
        for kind in 0..6 {
            // Draw until the effect, at a size real arms show, leaves at least 5×
            // the noise (an effect on a joint whose axis runs through the measured
            // point cannot, whatever its size).
            let mut drawn = None;
            for _ in 0..20 {
                let (name, nominal) = &robots[r.random_range(0..robots.len())];
                if kind == 5 && *name == "industrial6" {
                    continue; // its axes 2 and 3 are parallel too, but keep the tilt on the URs and PUMA
                }
                let joint = r.random_range(0..nominal.dof());
                let target: f64 = r.random_range(5.0..20.0);
                let seed = r.random_range(0..u64::MAX / 2);
                let Some((scenario, hidden, joints)) =
                    hidden_case(nominal, Some(kind), joint, target, seed, 300, &options.fit)
                else {
                    continue;
                };
                let session = simulate(nominal, &scenario).unwrap();
                let geometric = FitRequest::new(nominal, &session.observations, &options.fit)
                    .run()
                    .unwrap();
                if geometric.position_rms / noise_rms >= 5.0 {
                    drawn = Some((name, nominal, scenario, hidden.unwrap(), joints, session));
                    break;
                }
            }
            let (name, nominal, scenario, hidden, joints, session) =
                drawn.expect("a case with enough signal");
            let d = diagnose(nominal, &session.observations, &options).unwrap();
            let found = d
                .findings
                .first()
                .map(|f| (f.candidate.name, f.candidate.joints.clone()));
            assert_eq!(
                found,
                Some((hidden, joints.clone())),
                "{name}: hidden {hidden} on {joints:?}"
            );
            // The true structure: the hidden effect's parameters (or the tilt) fitted with the geometry.
            let structure: Vec<Effect<f64>> = scenario
                .effects
                .iter()
                .map(|e| {
                    let mut e = *e;
                    for i in 0..e.parameter_count() {
                        *e.parameter_mut(i).unwrap() = 0.0;
                    }
                    e
                })
                .collect();
            let extra: Vec<Param> = scenario
                .tilts
                .iter()
                .map(|(j, _)| Param::Beta(*j))
                .collect();
            let truth =
                cross_validate(nominal, &structure, &extra, &session.observations, &options)
                    .unwrap();
            let extended = d.holdout.extended;
            assert!(
                extended.rms <= 2.0 * truth.rms,
                "{name} {hidden}: extended {:e} m vs true structure {:e} m",
                extended.rms,
                truth.rms
            );
        }
    }
}

mod tilt_sweep {
    //! Issue 41's tilt sweep: the rate `armcal sweep --effect
    //! parallel_axis_tilt` measures with the true robots off nominal by the
    //! independent simulator's sizes.

    use armcal::calibration::simulate::ErrorSizes;
    use armcal::calibration::sweep::{KINDS, Settings, rates, sweep_with};

    /// A Hayati tilt between axes 2 and 3 of a PUMA 560, UR5e or UR10e, sized
    /// to leave 5–20× the noise after a geometric fit, with the D-H angles off
    /// by up to ±2 mrad and lengths by ±0.5 mm, the base by ±2 mm / ±2 mrad and
    /// the tool by ±1 mm / ±2 mrad (120 tracker positions, σ = 20 µm): the
    /// tilt is named first in at least 95 % of the cases whose signal reaches
    /// 5×, and nothing is named in the pure-geometry cases (one in five), as
    /// at ±1 mm / ±1 mrad. Before the fit's selection was made at the nominal
    /// structure, 73 % of such tilts were named (500 cases).
    #[test]
    fn a_tilt_is_named_at_the_independent_simulators_error_sizes() {
        let settings = Settings {
            errors: ErrorSizes {
                link_length: 0.5e-3,
                link_angle: 2e-3,
                base_length: 2e-3,
                base_angle: 2e-3,
                tool_length: 1e-3,
                tool_angle: 2e-3,
            },
            effect: KINDS.iter().position(|k| *k == "parallel_axis_tilt"),
            ..Settings::new(100, 1, 120)
        };
        let cases = sweep_with(&settings, |_, _| {});
        let r = rates(&cases);
        eprintln!(
            "tilts named {} of {}, false positives {} of {}",
            r.detected, r.strong, r.false_positives, r.pure
        );
        assert!(r.strong >= 60, "{} strong cases", r.strong);
        assert!(
            r.detected as f64 >= 0.95 * r.strong as f64,
            "named {} of {}",
            r.detected,
            r.strong
        );
        assert_eq!(r.false_positives, 0, "of {} pure-geometry cases", r.pure);
    }
}

mod blunders {
    //! Blunders among tracker readings are found at a scale they cannot
    //! inflate: a 1–5 mm blunder is 50–250 times the 20 µm noise, and a few of
    //! them raise the mean square of the residuals tenfold, under which each
    //! would pass the others' test.

    use armcal::calibration::diagnose::{DiagnoseOptions, diagnose};
    use armcal::calibration::simulate::{Scenario, simulate};
    use armcal::io::model_file::load_model;
    use armcal_shared::effects::Effect;
    use armcal_shared::units::Units;
    use nalgebra::Vector3;

    /// `n` training poses of `robot` (±1 mm / ±1 mrad, σ = 20 µm per axis, the
    /// `effects` hidden) with 2 % of them moved by 1–5 mm in fixed directions,
    /// and 100 poses of the same robot held out: every blunder is set aside,
    /// nothing else, the effects are named, the noise is the simulated 20 µm
    /// within 10 %, and the calibration written predicts the held-out poses near the noise (σ√3 = 34.6 µm, grown by the
    /// parameters' own uncertainty, √(1 + 30/300) ≈ 1.05, and the sampling
    /// error of an RMS over 100 poses, 3 × 4 %: below 1.2 × 34.6 µm).
    fn blunders_are_set_aside(robot: &str, n: usize, seed: u64, effects: Vec<Effect<f64>>) {
        let nominal = load_model(robot).unwrap().robot;
        let scenario = Scenario {
            effects: effects.clone(),
            ..Scenario::tracker(n + 100, seed)
        };
        let session = simulate(&nominal, &scenario).unwrap();
        let (train, test) = session.observations.split_at(n);
        let mut train = train.to_vec();
        let blunders: Vec<usize> = (0..n / 50).map(|b| 7 + b * 47 % n).collect();
        for (b, &i) in blunders.iter().enumerate() {
            let size = 1e-3 + 4e-3 * b as f64 / (blunders.len() - 1).max(1) as f64;
            let direction = Vector3::new(1.0, (b as f64).sin(), (b as f64).cos()).normalize();
            train[i].position += direction * size;
        }
        let d = diagnose(&nominal, &train, &DiagnoseOptions::default()).unwrap();
        let mut found = d.blunders.clone();
        found.sort_unstable();
        assert_eq!(found, blunders, "{n} poses: {:?}", d.suspects);
        let named: Vec<&str> = d.findings.iter().map(|f| f.candidate.name).collect();
        let hidden: Vec<&str> = effects.iter().map(|e| e.name()).collect();
        assert_eq!(named, hidden);
        assert!((d.noise / 20e-6 - 1.0).abs() < 0.1, "noise {}", d.noise);
        let cal = d.calibration(
            &nominal,
            armcal_shared::compensation::Task::Position,
            Units::SI,
        );
        let model = cal.model();
        let rms = (test
            .iter()
            .map(|o| {
                let t = model.forward(&o.q, &o.context).unwrap();
                (o.position.coords - t.translation.vector).norm_squared()
            })
            .sum::<f64>()
            / test.len() as f64)
            .sqrt();
        assert!(
            rms < 1.2 * 20e-6 * 3f64.sqrt(),
            "{n} poses: held out {rms:e} m"
        );
    }

    /// A 100-pose session with two blunders.
    #[test]
    fn two_blunders_in_100_poses_are_set_aside() {
        blunders_are_set_aside("ur5e", 100, 1, Vec::new());
    }

    /// Six among 300 poses of a UR10e with a hidden compliance of joint 2: the
    /// compliance's residual fills the other poses' held-out errors before it
    /// is modelled, and the smallest blunder's harm does not show there; about
    /// the final model it does.
    #[test]
    fn blunders_behind_an_effect_are_set_aside() {
        let compliance = Effect::JointCompliance {
            joint: 1,
            compliance: 2e-6,
        };
        blunders_are_set_aside("ur10e", 300, 5, vec![compliance]);
    }

    /// A 600-pose session with twelve: each would hide the others at the
    /// mean square of the residuals.
    #[test]
    fn twelve_blunders_in_600_poses_are_set_aside() {
        blunders_are_set_aside("ur5e", 600, 2, Vec::new());
    }
}

mod replicates {
    //! Poses measured again: the repeats' spread is the instrument noise, and
    //! the model's residuals at the configurations' means are tested against it.

    use armcal::calibration::diagnose::{DiagnoseOptions, diagnose};
    use armcal::calibration::fit::full_params;
    use armcal::io::model_file::load_model;
    use armcal_tests::{measure, random_configurations, rng, with_random_errors};

    /// 40 poses of a UR10e (±1 mm / ±1 mrad) each read five times, every
    /// reading with its own 20 µm tracker noise. The diagnosis fits the 40
    /// means; the repeats show the 20 µm within the sampling error of 480
    /// degrees of freedom (3 % each; 15 % is five of them); the geometry
    /// leaves the means no more than the instrument does: no lack of fit.
    #[test]
    fn repeats_show_the_instrument_noise_and_no_lack_of_fit() {
        let nominal = load_model("ur10e").unwrap().robot;
        let mut rng = rng(4);
        let params = full_params(&nominal, false);
        let (truth, _) = with_random_errors(&nominal, &params, 1e-3, 1e-3, &mut rng);
        let configs = random_configurations(&nominal, 40, &mut rng);
        let data: Vec<_> = (0..5)
            .flat_map(|_| measure(&truth, &configs, 20e-6, None, &mut rng))
            .collect();
        let d = diagnose(&nominal, &data, &DiagnoseOptions::default()).unwrap();
        let r = d.replicates.expect("repeated configurations");
        assert_eq!((r.rows, r.configurations), (200, 40));
        let l = r.lack_of_fit.expect("the repeats differ");
        assert_eq!(l.pure.dof, 3 * 40 * 4);
        assert!((l.pure.sigma / 20e-6 - 1.0).abs() < 0.15, "{l:?}");
        assert!(!l.significant(), "{l:?}");
        assert!(d.findings.is_empty());
    }
}
