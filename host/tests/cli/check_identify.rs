//! `armcal check` and `armcal identify`.

use std::path::Path;

use crate::{armcal, assert_success, files_in, succeeds};

#[test]
fn check_on_builtin_model_and_data_prints_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = armcal(
        &[
            "check",
            "--model",
            "figaroh-ur10e-camera",
            "--data",
            "figaroh-ur10e-camera",
        ],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_success(&out);
    for needle in [
        "ur10e_d435",
        "6 joints",
        "23 poses",
        "full poses",
        "position error",
        "orientation error",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in:\n{stdout}");
    }
    assert!(files_in(dir.path()).is_empty(), "check writes nothing");
}

#[test]
fn check_refuses_a_bad_value_with_file_line_column() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("arm.toml");
    std::fs::write(
        &model,
        "name = \"arm\"\nconvention = \"dh\"\nlength_unit = \"m\"\nangle_unit = \"rad\"\n\
         [[joint]]\ntype = \"revolute\"\ntheta = 0.0\ns = 0.5\na = 0.0\nalpha = 0.0\n",
    )
    .unwrap();
    let data = dir.path().join("poses.csv");
    std::fs::write(
        &data,
        "# one joint\nq1,x,y,z\n0.1,0.0,0.0,0.5\n0.2,0.0,abc,0.5\n",
    )
    .unwrap();
    let before = files_in(dir.path());
    let out = armcal(
        &["check", "--model", "arm.toml", "--data", "poses.csv"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    // Line 4, the field `abc` starts at character 9.
    assert!(stderr.contains("poses.csv:4:9:"), "{stderr}");
    assert!(stderr.contains("'y'"), "{stderr}");
    assert_eq!(files_in(dir.path()), before, "nothing written");
}

#[test]
fn check_refuses_too_few_poses() {
    let dir = tempfile::tempdir().unwrap();
    // 6R PUMA with positions only: 4·6 + 3 = 27 unknowns, 2 poses give 6 equations.
    std::fs::write(
        dir.path().join("few.csv"),
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n0.1,0,0,0,0,0,1,2,3\n",
    )
    .unwrap();
    let out = armcal(
        &["check", "--model", "puma560", "--data", "few.csv"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("few.csv:3:1:"), "{stderr}");
    assert!(stderr.contains("27"), "{stderr}");
}

#[test]
fn unknown_model_name_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = armcal(
        &[
            "check",
            "--model",
            "no-such-robot",
            "--data",
            "figaroh-ur10e-camera",
        ],
        dir.path(),
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no-such-robot"));
}

#[test]
fn identify_writes_the_interface_json_and_a_calibration_the_firmware_format_reads() {
    let dir = tempfile::tempdir().unwrap();
    let out = armcal(
        &[
            "identify",
            "--model",
            "figaroh-ur10e-camera",
            "--data",
            "figaroh-ur10e-camera",
            "--out",
            "ur10e.cal",
            "--json",
            "report.json",
        ],
        dir.path(),
    );
    assert_success(&out);
    // The summary is printed whatever files are written, with the nominal
    // model's error beside the calibration's.
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.starts_with("identify --params full: ur10e_d435")
            && stdout.contains("position RMS on these rows: nominal "),
        "{stdout}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("report.json")).unwrap()).unwrap();
    assert_eq!(json["params"], "full");
    assert!(json["iterations"].as_u64().unwrap() >= 1);
    assert_eq!(json["converged"], true);
    assert!(json["condition_number"].as_f64().unwrap() > 1.0);
    assert!(
        json["residual"]["position_rms"].as_f64().unwrap() < 0.074,
        "better than nominal"
    );
    assert!(json["residual"]["orientation_rms"].is_number());
    let params = json["parameters"].as_array().unwrap();
    assert_eq!(
        params.len(),
        6 + 6 + 4 * 6,
        "base 6, tool 6 (full poses), 4 per joint"
    );
    for p in params {
        for key in ["name", "nominal", "error", "std", "status"] {
            assert!(p.get(key).is_some(), "{p} lacks {key}");
        }
        match p["status"].as_str().unwrap() {
            "identified" => assert!(p["std"].as_f64().unwrap() > 0.0),
            "fixed" => {
                assert!(p["std"].is_null());
                assert!(p["reason"].as_str().unwrap().len() > 10, "{p}");
            }
            other => panic!("status {other}"),
        }
    }
    // The calibration file decodes and carries the identified errors.
    let bytes = std::fs::read(dir.path().join("ur10e.cal")).unwrap();
    let cal = armcal_shared::Calibration::decode(&bytes).unwrap();
    assert_eq!(cal.task, armcal_shared::compensation::Task::Pose);
    let base_x = params.iter().find(|p| p["name"] == "base.x").unwrap();
    let err = cal
        .errors
        .iter()
        .find(|e| e.param.to_string() == "base.x")
        .map_or(0.0, |e| e.error);
    assert!(
        (err - base_x["error"].as_f64().unwrap()).abs() < 1e-15,
        "lengths in m, as the model"
    );
}

#[test]
fn identify_without_outputs_prints_a_summary_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = armcal(
        &[
            "identify",
            "--model",
            "figaroh-tiago-mocap",
            "--data",
            "figaroh-tiago-mocap",
        ],
        dir.path(),
    );
    assert_success(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "converged",
        "condition number",
        "theta1",
        "fixed: not separable from base.rz",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in\n{stdout}");
    }
    assert!(files_in(dir.path()).is_empty());
}

#[test]
fn identify_refuses_paper_model_on_positions_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = armcal(
        &[
            "identify",
            "--model",
            "figaroh-tiago-mocap",
            "--data",
            "figaroh-tiago-mocap",
            "--params",
            "paper",
            "--out",
            "x.cal",
            "--json",
            "x.json",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("--params paper needs full poses"),
        "{stderr}"
    );
    assert!(files_in(dir.path()).is_empty(), "nothing written");
}

#[test]
fn identify_refuses_data_of_another_robot_naming_the_place() {
    let dir = tempfile::tempdir().unwrap();
    // Seven joint columns for the six-joint PUMA.
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,q7,x,y,z\n");
    for i in 0..40 {
        csv.push_str(&format!("{},0,0,0,0,0,0,1,2,3\n", i as f64 * 0.01));
    }
    std::fs::write(dir.path().join("seven.csv"), csv).unwrap();
    let out = armcal(
        &[
            "identify",
            "--model",
            "puma560",
            "--data",
            "seven.csv",
            "--out",
            "p.cal",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("seven.csv:1:"), "{stderr}");
    assert!(stderr.contains("q7"), "{stderr}");
    assert!(!dir.path().join("p.cal").exists());
}

/// `armcal simulate` writes a measurement CSV (docs/file-formats.md §2) that the readers accept: pure
/// geometry is explained by the geometric fit down to the noise (variance factor
/// near 1), a hidden joint compliance is not (the residual stays well above it).
#[test]
fn simulate_writes_data_that_identify_reads() {
    let dir = tempfile::tempdir().unwrap();
    let vf = |file: &str| -> f64 {
        let out = armcal(
            &[
                "identify",
                "--model",
                "ur10e",
                "--data",
                file,
                "--position-noise",
                "2e-5",
                "--json",
                "r.json",
            ],
            dir.path(),
        );
        assert_success(&out);
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("r.json")).unwrap()).unwrap();
        json["variance_factor"].as_f64().unwrap()
    };
    let run = |args: &[&str]| {
        let out = armcal(args, dir.path());
        assert_success(&out);
    };
    run(&[
        "simulate",
        "--model",
        "ur10e",
        "--poses",
        "300",
        "--out",
        "geometry.csv",
    ]);
    run(&[
        "simulate",
        "--model",
        "ur10e",
        "--poses",
        "300",
        "--effect",
        "joint_compliance:2",
        "--out",
        "compliance.csv",
        "--truth",
        "truth.json",
    ]);
    // 300 positions, ~33 parameters: the variance factor of pure noise is 1 ± 0.05.
    let geometric = vf("geometry.csv");
    assert!(
        (geometric - 1.0).abs() < 0.25,
        "pure geometry: variance factor {geometric}"
    );
    let with_effect = vf("compliance.csv");
    assert!(
        with_effect > 4.0,
        "hidden compliance: variance factor {with_effect}"
    );
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["effects"][0]["name"], "joint_compliance");
    assert_eq!(truth["effects"][0]["joint"], 2);
}

/// `simulate`'s true robot is off nominal by the sizes asked, in the model's
/// units: the PUMA (inches) with its links' lengths within ±0.5 mm
/// (0.019685 in) and angles within ±2 mrad, the base exact and the tool's
/// position within ±1 mm, its orientation exact. Every error the truth
/// lists is within its size, and none of the base or of the tool's angles.
#[test]
fn simulate_draws_the_error_sizes_asked() {
    let dir = tempfile::tempdir().unwrap();
    succeeds(
        dir.path(),
        &[
            "simulate",
            "--model",
            "puma560",
            "--poses",
            "20",
            "--link-errors",
            "0.019685,0.002",
            "--base-errors",
            "0,0",
            "--tool-errors",
            "0.0393701,0",
            "--out",
            "s.csv",
            "--truth",
            "t.json",
        ],
    );
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("t.json")).unwrap()).unwrap();
    let errors = truth["errors"].as_object().unwrap();
    assert!(errors.len() >= 20, "{} errors", errors.len());
    for (name, e) in errors {
        let e = e.as_f64().unwrap().abs();
        let size = match name.as_str() {
            n if n.starts_with("base.") || n.starts_with("tool.r") => 0.0,
            n if n.starts_with("tool.") => 0.0393701,
            n if n.starts_with("theta") || n.starts_with("alpha") => 0.002,
            _ => 0.019685,
        };
        assert!(e <= size, "{name}: {e} beyond ±{size}");
    }
}

/// `armcal diagnose` on a session with a hidden joint compliance: the JSON of
/// docs/file-formats.md §6 names it on joint 2 with its parameter, the held-out error drops
/// to the noise, the noise estimate is the simulated 20 µm, and the calibration
/// it writes carries the effect: `predict` with it reproduces the measurements to
/// the noise, and `compensate` applies it.
#[test]
fn diagnose_names_a_hidden_compliance_and_its_calibration_carries_it() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let out = armcal(args, dir.path());
        assert_success(&out);
        out
    };
    run(&[
        "simulate",
        "--model",
        "ur10e",
        "--poses",
        "300",
        "--effect",
        "joint_compliance:2",
        "--out",
        "d.csv",
    ]);
    run(&[
        "diagnose", "--model", "ur10e", "--data", "d.csv", "--folds", "5", "--json", "r.json",
        "--out", "c.cal",
    ]);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("r.json")).unwrap()).unwrap();
    assert_eq!(json["effects"][0]["name"], "joint_compliance", "{json}");
    assert_eq!(json["effects"][0]["joints"], serde_json::json!([2]));
    assert!(json["effects"][0]["parameters"]["c2"].as_f64().unwrap() > 0.0);
    let noise = json["noise_estimate_mm"].as_f64().unwrap();
    assert!((noise / 0.020 - 1.0).abs() < 0.1, "noise {noise} mm");
    let (g, e) = (
        json["holdout"]["geometric_rms_mm"].as_f64().unwrap(),
        json["holdout"]["extended_rms_mm"].as_f64().unwrap(),
    );
    assert!(
        e < g / 2.0 && e < 2.0 * 0.020 * 3f64.sqrt(),
        "held-out rms {g} mm → {e} mm"
    );
    assert_eq!(json["outlier_rows"], serde_json::json!([]));

    let out = run(&["predict", "--calibration", "c.cal", "--joints", "d.csv"]);
    let text = String::from_utf8_lossy(&out.stdout);
    let predicted: Vec<Vec<f64>> = text
        .lines()
        .skip(2)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let measured: Vec<Vec<f64>> = std::fs::read_to_string(dir.path().join("d.csv"))
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| {
            l.split(',')
                .skip(6)
                .take(3)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    let rms = (predicted
        .iter()
        .zip(&measured)
        .map(|(p, m)| (0..3).map(|i| (p[i] - m[i]).powi(2)).sum::<f64>())
        .sum::<f64>()
        / predicted.len() as f64)
        .sqrt();
    // Training residual of 3-D positions with σ = 20 µm per axis: about 34.6 µm.
    assert!(rms < 40e-6, "predict against the measurements: {rms} m rms");

    let compensated = armcal(
        &["compensate", "--calibration", "c.cal", "--joints", "d.csv"],
        dir.path(),
    );
    assert!(compensated.status.success());
}

/// `armcal diagnose --html` writes one self-contained page (no external
/// resource: it opens offline) with the residual plots as inline SVG, and it
/// renders in headless Chromium: the rendered DOM holds the plots' points and a
/// screenshot of the requested size is taken. Chromium is Debian's package; CI
/// installs it, and on CI its absence fails the test.
#[test]
fn diagnose_html_is_self_contained_and_renders_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let out = armcal(args, dir.path());
        assert_success(&out);
    };
    run(&[
        "simulate",
        "--model",
        "ur10e",
        "--poses",
        "200",
        "--effect",
        "gear_transmission:3",
        "--out",
        "d.csv",
    ]);
    run(&[
        "diagnose", "--model", "ur10e", "--data", "d.csv", "--folds", "5", "--html", "r.html",
    ]);
    let page = std::fs::read_to_string(dir.path().join("r.html")).unwrap();
    for external in [" src=", " href=", "@import", "url("] {
        assert!(
            !page.contains(external),
            "the page refers to something outside it: {external}"
        );
    }
    assert!(page.contains("gear_transmission"), "the finding is named");
    // Every value of the parameter table has its unit: the model's for the
    // geometry, the effect's own in the model's angle unit for a gear.
    assert!(page.contains("<th>unit</th>"));
    assert!(page.contains("<tr><td>a2</td><td>m</td>"), "a length in m");
    assert!(
        page.contains("<tr><td>alpha2</td><td>rad</td>"),
        "an angle in rad"
    );
    assert!(
        page.contains("<tr><td>g3.sin1</td><td>rad</td>"),
        "a gear amplitude in rad"
    );
    // One estimated noise figure for the positions, named for what it is
    // (the geometric calibration's residual), in the model's unit and in mm.
    assert_eq!(
        page.matches("The geometric calibration's residuals, positions: <b>")
            .count(),
        1
    );
    assert!(
        page.contains(" mm) per axis (estimated from them"),
        "the noise in mm too"
    );
    assert!(
        page.matches("<svg").count() >= 2,
        "a plot per finding and the residual in order"
    );
    assert!(
        page.matches("<circle").count() >= 4 * 200,
        "before and after, in two plots"
    );

    let chromium = ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .into_iter()
        .find(|p| std::path::Path::new(p).exists());
    let Some(chromium) = chromium else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must install Debian's chromium"
        );
        eprintln!("chromium not installed here: the rendering check runs in CI");
        return;
    };
    let profile = tempfile::tempdir().unwrap();
    let url = format!("file://{}", dir.path().join("r.html").display());
    let chrome = |extra: &[&str]| {
        std::process::Command::new(chromium)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                &format!("--user-data-dir={}", profile.path().display()),
            ])
            .args(extra)
            .arg(&url)
            .current_dir(dir.path())
            .output()
            .expect("chromium runs")
    };
    let dom = chrome(&["--dump-dom"]);
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom.matches("<circle").count() >= 4 * 200,
        "the rendered DOM holds the plots"
    );
    let shot = dir.path().join("shot.png");
    chrome(&[
        "--window-size=1200,900",
        &format!("--screenshot={}", shot.display()),
    ]);
    let png = std::fs::read(&shot).expect("a screenshot");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let (w, h) = (
        u32::from_be_bytes(png[16..20].try_into().unwrap()),
        u32::from_be_bytes(png[20..24].try_into().unwrap()),
    );
    assert_eq!((w, h), (1200, 900));
    assert!(
        png.len() > 20_000,
        "a page with plots, not a blank one ({} bytes)",
        png.len()
    );
}

/// A fit that did not converge is not written: a prior of 1e-300 m and rad
/// on a simulated UR5e session leaves Levenberg–Marquardt no step that lowers
/// the sum of squares after 2 iterations. `identify` exits 1 naming the
/// iterations, the last step and the residuals nominal and calibrated, and
/// writes neither the calibration nor the report; `--write-failed` writes
/// them with the reason as a warning.
#[test]
fn identify_refuses_to_write_a_fit_that_did_not_converge() {
    let dir = tempfile::tempdir().unwrap();
    crate::succeeds(
        dir.path(),
        &[
            "simulate", "--model", "ur5e", "--out", "s.csv", "--poses", "100", "--seed", "2",
        ],
    );
    let mut args = vec![
        "identify",
        "--model",
        "ur5e",
        "--data",
        "s.csv",
        "--prior-length",
        "1e-300",
        "--prior-angle",
        "1e-300",
        "--out",
        "nc.cal",
        "--json",
        "nc.json",
    ];
    let before = crate::snapshot(dir.path());
    let out = armcal(&args, dir.path());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    for needle in [
        "s.csv: the fit did not converge after 2 iterations",
        "no step that lowers the sum of squares",
        "m calibrated, 0.003191 m nominal",
        "nothing is written (--write-failed writes it anyway)",
    ] {
        assert!(stderr.contains(needle), "{needle:?} not in {stderr}");
    }
    assert_eq!(crate::snapshot(dir.path()), before, "nothing written");
    args.push("--write-failed");
    let out = crate::succeeds(dir.path(), &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("warning: s.csv: the fit did not converge"),
        "{stderr}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("nc.json")).unwrap()).unwrap();
    assert_eq!(report["converged"], false);
    assert!(dir.path().join("nc.cal").exists());
}

/// The bundled FIGAROH UR10e camera set's measurement file, as a path.
fn camera_measurements() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/figaroh-ur10e-camera/measurements.csv")
        .display()
        .to_string()
}

/// The summary's calibrated figure is what the file written delivers: the
/// position RMS of `armcal predict` with it on the same rows, to the six
/// decimals printed; `--quiet` prints nothing and writes the same file.
#[test]
fn identify_prints_what_its_file_delivers_and_quiet_prints_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = camera_measurements();
    let identify = |extra: &[&str]| {
        let mut args = vec![
            "identify",
            "--model",
            "figaroh-ur10e-camera",
            "--data",
            &data,
        ];
        args.extend(extra);
        succeeds(d, &args)
    };
    let out = identify(&["--out", "a.cal"]);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let line = stdout
        .lines()
        .find(|l| l.starts_with("position RMS on these rows"))
        .unwrap();
    let printed: f64 = line
        .split("→ calibrated ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .unwrap()
        .parse()
        .unwrap();
    succeeds(
        d,
        &[
            "predict",
            "--calibration",
            "a.cal",
            "--joints",
            &data,
            "--out",
            "p.csv",
        ],
    );
    let delivered = crate::rms_distance(&d.join("p.csv"), Path::new(&data));
    assert!(
        (delivered - printed).abs() <= 5e-7,
        "printed {printed} m, predict gives {delivered} m"
    );
    let quiet = identify(&["--out", "b.cal", "--quiet"]);
    assert!(quiet.stdout.is_empty());
    assert_eq!(
        std::fs::read(d.join("a.cal")).unwrap(),
        std::fs::read(d.join("b.cal")).unwrap()
    );
}

/// A camera's calibration (its base 64 mm and 23 mrad from the model's: the
/// registration of the camera) compensates its own poses' commands with the
/// targets in the world frame: the bounded rows are named with the way out
/// (`--targets base`), with which a tenth as many are bounded, by the arm's
/// own corrections.
#[test]
fn bounded_rows_of_a_registration_suggest_targets_in_the_base_frame() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = camera_measurements();
    let compensate = |targets: &str| {
        let cal = format!("{targets}.cal");
        succeeds(
            d,
            &[
                "identify",
                "--model",
                "figaroh-ur10e-camera",
                "--data",
                &data,
                "--targets",
                targets,
                "--out",
                &cal,
                "--quiet",
            ],
        );
        let out = succeeds(
            d,
            &[
                "compensate",
                "--calibration",
                &cal,
                "--joints",
                &data,
                "--out",
                &format!("{targets}.csv"),
            ],
        );
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let world = compensate("world");
    assert!(
        world.contains("rows were bounded or missed, and the calibration's base")
            && world.contains("--targets base"),
        "{world}"
    );
    let base = compensate("base");
    let bounded = |stderr: &str| stderr.matches("correction bounded").count();
    assert!(!base.contains("the instrument's registration"), "{base}");
    assert!(bounded(&base) * 5 < bounded(&world), "{base}\n{world}");
}

/// A simulated marker frame whose orientations are turned 2 mrad from the
/// positions' frame (`simulate --orientation-bias`), 20 UR5e poses: the
/// positions say the orientations mislead them, and `identify` and
/// `diagnose` weigh them down and name it — in the summary, the JSON
/// (`orientation_weight`: each weight's held-out figure and the
/// disagreement) and the HTML report; `--orientation-weight estimated`
/// states the weight instead and chooses nothing.
#[test]
fn biased_orientations_are_weighed_down_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = armcal(
        &[
            "simulate",
            "--model",
            "ur5e",
            "--poses",
            "20",
            "--noise",
            "0.00005",
            "--orientation-noise",
            "0.0001",
            "--orientation-bias",
            "0.002",
            "--seed",
            "3",
            "--out",
            "b.csv",
        ],
        d,
    );
    assert_success(&out);
    let args = ["--model", "ur5e", "--data", "b.csv", "--json", "r.json"];
    for verb in ["identify", "diagnose"] {
        let mut all = vec![verb];
        all.extend_from_slice(&args);
        if verb == "diagnose" {
            all.extend_from_slice(&["--html", "r.html"]);
        }
        let out = armcal(&all, d);
        assert_success(&out);
        let summary = String::from_utf8_lossy(&out.stdout);
        assert!(
            summary.contains("orientation weight: none (chosen")
                && summary.contains("the orientations disagree with the positions"),
            "{verb}: {summary}"
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
        let w = &json["orientation_weight"];
        assert_eq!(w["chosen_by"], "cross-validation", "{verb}: {w}");
        assert_eq!(w["held_out"].as_array().unwrap().len(), 4, "{verb}: {w}");
        assert!(
            w["disagreement"]["significance"].as_f64().unwrap() > 2.0,
            "{verb}: {w}"
        );
    }
    let html = std::fs::read_to_string(d.join("r.html")).unwrap();
    assert!(html.contains("<h2>Orientation weight</h2>") && html.contains("none (chosen)"));
    let out = armcal(
        &[
            "identify",
            "--model",
            "ur5e",
            "--data",
            "b.csv",
            "--orientation-weight",
            "estimated",
        ],
        d,
    );
    assert_success(&out);
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        summary.contains("orientation weight: estimated (stated"),
        "{summary}"
    );
}
