//! What `armcal diagnose` reports is what it writes: for every effect it names,
//! in standard and modified D-H, in m/rad, mm/deg and in/rad, `armcal predict`
//! with the written calibration reproduces the report's in-sample figure on the
//! poses it was fitted to, and predicts poses it never saw near the noise.
//!
//! The arm is a UR5e-like six-axis arm (axes 2, 3 and 4 parallel), written in
//! each convention and unit system; `armcal simulate` builds a true robot
//! (±1 mm / ±1 mrad errors) with one hidden effect and measures 250 positions
//! (σ = 20 µm per axis); the first 150 are diagnosed, the last 100 held out.

use crate::succeeds;
use std::path::Path;

/// Link `(d, a, α)` in m and degrees, standard D-H.
const DH: [(f64, f64, f64); 6] = [
    (0.1625, 0.0, 90.0),
    (0.0, -0.425, 0.0),
    (0.0, -0.3922, 0.0),
    (0.1333, 0.0, 90.0),
    (0.0997, 0.0, -90.0),
    (0.0996, 0.0, 0.0),
];

/// The same arm in modified D-H: link `i` carries the `a`, `α` that join axis
/// `i − 1` to axis `i` (the last link's `a = α = 0`, so no tool offset moves).
const MDH: [(f64, f64, f64); 6] = [
    (0.1625, 0.0, 0.0),
    (0.0, 0.0, 90.0),
    (0.0, -0.425, 0.0),
    (0.1333, -0.3922, 0.0),
    (0.0997, 0.0, 90.0),
    (0.0996, 0.0, -90.0),
];

/// Link masses, kg (gravity torques for the compliance).
const MASSES: [f64; 6] = [3.761, 8.058, 2.846, 1.37, 1.3, 0.365];

/// A unit system: the names, metres per length unit, and whether angles are in degrees.
struct UnitSystem {
    length: &'static str,
    angle: &'static str,
    metres: f64,
    degrees: bool,
}

const UNITS: [UnitSystem; 3] = [
    UnitSystem {
        length: "m",
        angle: "rad",
        metres: 1.0,
        degrees: false,
    },
    UnitSystem {
        length: "mm",
        angle: "deg",
        metres: 1e-3,
        degrees: true,
    },
    UnitSystem {
        length: "in",
        angle: "rad",
        metres: 0.0254,
        degrees: false,
    },
];

/// The model file of the arm in `convention` and `units`.
fn model_toml(convention: &str, units: &UnitSystem) -> String {
    let links = if convention == "dh" { DH } else { MDH };
    let mut s = format!(
        "name = \"arm\"\nconvention = \"{convention}\"\nlength_unit = \"{}\"\nangle_unit = \"{}\"\ngravity = [0.0, 0.0, -9.81]\n",
        units.length, units.angle
    );
    let length = |x: f64| x / units.metres;
    let angle = |deg: f64| {
        if units.degrees { deg } else { deg.to_radians() }
    };
    for ((d, a, alpha), mass) in links.iter().zip(MASSES) {
        s.push_str(&format!(
            "\n[[joint]]\ntype = \"revolute\"\ntheta = 0.0\nd = {:?}\na = {:?}\nalpha = {:?}\nmass = {mass}\ncom = [0.0, 0.0, {:?}]\n",
            length(*d),
            length(*a),
            angle(*alpha),
            length(0.02)
        ));
    }
    s
}

/// The data rows of a measurements or predictions CSV (comments and header skipped).
fn rows(text: &str) -> Vec<&str> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .collect()
}

/// The header and `rows` of a measurements file as a file of its own.
fn part(text: &str, rows: &[&str]) -> String {
    let header = text.lines().find(|l| !l.starts_with('#')).unwrap();
    let mut out = format!("{header}\n");
    for r in rows {
        out.push_str(r);
        out.push('\n');
    }
    out
}

/// The RMS distance between the measured `x,y,z` of `data` and the predicted
/// `x,y,z` of `predicted`, row for row, in the model's length unit.
fn rms_between(data: &str, predicted: &str) -> f64 {
    let header: Vec<&str> = data
        .lines()
        .find(|l| !l.starts_with('#'))
        .unwrap()
        .split(',')
        .collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (x, y, z) = (at("x"), at("y"), at("z"));
    let measured = rows(data);
    let predicted = rows(predicted);
    assert_eq!(measured.len(), predicted.len());
    let sum: f64 = measured
        .iter()
        .zip(&predicted)
        .map(|(m, p)| {
            let m: Vec<f64> = m.split(',').map(|v| v.parse().unwrap()).collect();
            let p: Vec<f64> = p.split(',').map(|v| v.parse().unwrap()).collect();
            (m[x] - p[0]).powi(2) + (m[y] - p[1]).powi(2) + (m[z] - p[2]).powi(2)
        })
        .sum();
    (sum / measured.len() as f64).sqrt()
}

/// One case: the arm in `convention` and `units` with the hidden effect of
/// `flags`, expected to be named `name`.
fn check(dir: &Path, convention: &str, units: &UnitSystem, flags: &[&str], name: &str) {
    let case = format!("{convention} {}/{} {flags:?}", units.length, units.angle);
    std::fs::write(dir.join("arm.toml"), model_toml(convention, units)).unwrap();
    let mut args = vec![
        "simulate", "--model", "arm.toml", "--poses", "250", "--seed", "3", "--out", "all.csv",
    ];
    args.extend_from_slice(flags);
    succeeds(dir, &args);
    let all = std::fs::read_to_string(dir.join("all.csv")).unwrap();
    let data = rows(&all);
    std::fs::write(dir.join("train.csv"), part(&all, &data[..150])).unwrap();
    std::fs::write(dir.join("test.csv"), part(&all, &data[150..])).unwrap();
    succeeds(
        dir,
        &[
            "diagnose",
            "--model",
            "arm.toml",
            "--data",
            "train.csv",
            "--out",
            "arm.cal",
            "--json",
            "report.json",
        ],
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    let named: Vec<&str> = report["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(named, [name], "{case}");
    let mm = units.metres * 1e3;
    let fitted = report["fitted"]["rms_mm"].as_f64().unwrap();
    let extended = report["holdout"]["extended_rms_mm"].as_f64().unwrap();
    for (joints, out) in [("train.csv", "train_p.csv"), ("test.csv", "test_p.csv")] {
        succeeds(
            dir,
            &[
                "predict",
                "--calibration",
                "arm.cal",
                "--joints",
                joints,
                "--out",
                out,
            ],
        );
    }
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap();
    // The same f64 model evaluated on the same joints: equal to rounding.
    let train = rms_between(&read("train.csv"), &read("train_p.csv")) * mm;
    assert!(
        (train - fitted).abs() <= 1e-9 * fitted,
        "{case}: predict gives {train} mm on the fitted poses, the report {fitted} mm"
    );
    // Held out: the noise (20 µm per axis, 34.6 µm in 3-D) grown by the
    // parameters' own uncertainty (√(1 + p/n) ≈ 1.04 for 30 parameters from
    // 450 equations) and the sampling error of an RMS over 100 poses (4 %
    // each: three of them 12 %): below 1.2 × 34.6 µm.
    let test = rms_between(&read("test.csv"), &read("test_p.csv")) * mm;
    let noise = 20e-3 * 3f64.sqrt();
    assert!(
        test < 1.2 * noise,
        "{case}: {test:.4} mm on the held-out poses"
    );
    // And the cross-validated figure the report prints tells it: within the
    // same sampling error.
    assert!(
        (test / extended - 1.0).abs() < 0.2,
        "{case}: held out {test:.4} mm, the report's cross-validation {extended:.4} mm"
    );
}

/// Every effect, in standard and modified D-H, in m/rad, mm/deg and in/rad.
#[test]
fn predict_with_the_written_calibration_reproduces_the_report() {
    let dir = tempfile::tempdir().unwrap();
    for convention in ["dh", "mdh"] {
        // The tilt between axes 2 and 3 is link 2's in standard D-H, link 3's
        // in modified D-H.
        let tilt = if convention == "dh" {
            "2:0.001"
        } else {
            "3:0.001"
        };
        for units in &UNITS {
            for (flags, name) in [
                (["--effect", "joint_compliance:2"], "joint_compliance"),
                (["--effect", "gear_transmission:2"], "gear_transmission"),
                (["--effect", "backlash:2"], "backlash"),
                (["--effect", "thermal_expansion"], "thermal_expansion"),
                (["--effect", "encoder_scale:2"], "encoder_scale"),
                (["--tilt", tilt], "parallel_axis_tilt"),
            ] {
                check(dir.path(), convention, units, &flags, name);
            }
        }
    }
}
