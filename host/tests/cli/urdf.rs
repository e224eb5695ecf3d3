//! URDF in (`--model x.urdf`) and out (`armcal export --format urdf`).
//!
//! The reference is an independent evaluation of the URDF written here: the
//! joint origins composed as the URDF specification defines them,
//! `origin · Rot(axis, q)` or `origin · Trans(axis · q)`, from the XML itself,
//! not through armcal's conversion. Tolerances: the model's forward kinematics
//! equals the URDF's to 1e-12 m (the issue's bound; a chain of ~20 products of
//! metre-sized transforms rounds at ~1e-15 m), and an exported calibration's
//! to 1e-9 m (the issue's bound; the export writes every number exactly, so
//! the error is rounding again).

use armcal_shared::compensation::Task;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use armcal::io::model_file::load_model_with;
use armcal::io::urdf::ChainSpec;
use armcal_shared::{Param, Robot};
use nalgebra::{IsometryMatrix3, Point3, Rotation3, Translation3, Unit, Vector3};

use crate::{refused, succeeds};

type Pose = IsometryMatrix3<f64>;

/// The project's URDF files (`data/urdf/`).
fn urdf_file(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/urdf")
        .join(name)
}

/// One joint as the test reads it straight from the XML.
struct RefJoint {
    kind: String,
    parent: String,
    origin: Pose,
    axis: Vector3<f64>,
}

/// The joints of a URDF by child link name.
fn reference(text: &str) -> HashMap<String, RefJoint> {
    let doc = roxmltree::Document::parse(text).unwrap();
    let nums = |n: Option<roxmltree::Node<'_, '_>>, attr: &str, default: [f64; 3]| {
        n.and_then(|n| n.attribute(attr)).map_or(default, |v| {
            let w: Vec<f64> = v.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [w[0], w[1], w[2]]
        })
    };
    let mut out = HashMap::new();
    for j in doc
        .root_element()
        .children()
        .filter(|n| n.has_tag_name("joint"))
    {
        let child = |tag: &str| j.children().find(|n| n.has_tag_name(tag));
        let o = child("origin");
        let [x, y, z] = nums(o, "xyz", [0.0; 3]);
        let [r, p, w] = nums(o, "rpy", [0.0; 3]);
        let origin = Pose::from_parts(
            Translation3::new(x, y, z),
            Rotation3::from_axis_angle(&Vector3::z_axis(), w)
                * Rotation3::from_axis_angle(&Vector3::y_axis(), p)
                * Rotation3::from_axis_angle(&Vector3::x_axis(), r),
        );
        let link = |tag: &str| child(tag).unwrap().attribute("link").unwrap().to_owned();
        out.insert(
            link("child"),
            RefJoint {
                kind: j.attribute("type").unwrap().to_owned(),
                parent: link("parent"),
                origin,
                axis: Vector3::from(nums(child("axis"), "xyz", [1.0, 0.0, 0.0])),
            },
        );
    }
    out
}

/// The frame of link `tip` in link `base` at readings `q` of the moving joints
/// between them, base to tip.
fn reference_fk(joints: &HashMap<String, RefJoint>, base: &str, tip: &str, q: &[f64]) -> Pose {
    let mut path = Vec::new();
    let mut at = tip.to_owned();
    while at != base {
        let j = &joints[&at];
        path.push(j);
        at = j.parent.clone();
    }
    path.reverse();
    let mut pose = Pose::identity();
    let mut readings = q.iter();
    for j in path {
        pose *= j.origin;
        let axis = Unit::new_normalize(j.axis);
        match j.kind.as_str() {
            "revolute" | "continuous" => {
                let q = *readings.next().unwrap();
                pose *= Rotation3::from_axis_angle(&axis, q);
            }
            "prismatic" => {
                let q = *readings.next().unwrap();
                pose *= Translation3::from(axis.into_inner() * q);
            }
            _ => {}
        }
    }
    assert!(readings.next().is_none(), "more readings than joints");
    pose
}

/// 200 reproducible random configurations within the joint limits, as
/// `armcal simulate` draws them.
fn configurations(robot: &Robot<f64>) -> Vec<Vec<f64>> {
    armcal::calibration::simulate::random_configurations(
        robot,
        200,
        &mut armcal::calibration::simulate::rng(7),
    )
}

/// The largest distance between `a` and `b` (positions) and of their
/// rotations (Frobenius norm of the difference, ~ the angle in rad).
fn distance(a: &Pose, b: &Pose) -> (f64, f64) {
    (
        (a.translation.vector - b.translation.vector).norm(),
        (a.rotation.matrix() - b.rotation.matrix()).norm(),
    )
}

/// The URDF chains of the acceptance: file, base, tip, tip point.
const CHAINS: [(&str, &str, &str, [f64; 3]); 5] = [
    (
        "panda.urdf",
        "panda_link0",
        "panda_hand",
        [0.0, 0.0, 0.1034],
    ),
    ("iiwa14.urdf", "base_link", "ball_link", [0.0; 3]),
    ("ur10e_robot.urdf", "world", "tool0", [0.01, -0.02, 0.05]),
    (
        "talos_full_v2.urdf",
        "base_link",
        "gripper_left_base_link",
        [0.0; 3],
    ),
    (
        "tiago_48_schunk.urdf",
        "base_footprint",
        "arm_tool_link",
        [0.0; 3],
    ),
];

fn spec(base: &str, tip: &str, point: [f64; 3]) -> ChainSpec {
    ChainSpec {
        base_link: Some(base.into()),
        tip_link: Some(tip.into()),
        tip_point: Some(Vector3::from(point)),
    }
}

/// The model read from each URDF moves its measured frame exactly as the URDF
/// does: 1e-12 m (and 1e-12 in rotation) at 200 random configurations.
#[test]
fn a_urdf_model_has_the_urdfs_forward_kinematics() {
    for (file, base, tip, point) in CHAINS {
        let path = urdf_file(file);
        let model = load_model_with(path.to_str().unwrap(), &spec(base, tip, point))
            .unwrap_or_else(|e| panic!("{e}"));
        let joints = reference(&std::fs::read_to_string(&path).unwrap());
        let (mut worst, mut worst_rot) = (0.0f64, 0.0f64);
        for q in configurations(&model.robot) {
            let want =
                reference_fk(&joints, base, tip, &q) * Translation3::from(Vector3::from(point));
            let got = model.robot.forward(&q).unwrap();
            let (d, r) = distance(&got, &want);
            worst = worst.max(d);
            worst_rot = worst_rot.max(r);
        }
        eprintln!(
            "{file} {base} -> {tip}: {} joints, {}; max |Δp| = {worst:.2e} m, max |ΔR| = {worst_rot:.2e}",
            model.dof(),
            model.description
        );
        assert!(
            worst < 1e-12 && worst_rot < 1e-12,
            "{file}: {worst} m, {worst_rot}"
        );
    }
}

/// The UR10e's three parallel axes (2, 3, 4) use Hayati's tilt, its others
/// Craig's common normal; its limits and masses are read; a default chain
/// follows the one moving branch (iiwa14: base_link to ball_link).
#[test]
fn parallel_axes_use_hayati_and_limits_and_masses_are_read() {
    let path = urdf_file("ur10e_robot.urdf");
    let model = load_model_with(
        path.to_str().unwrap(),
        &spec("base_link", "tool0", [0.0; 3]),
    )
    .unwrap();
    assert!(
        model.description.contains("Hayati's tilt on joint(s) 3, 4"),
        "{}",
        model.description
    );
    let l = &model.robot.links;
    // URDF rounding (1.570796327 for π/2) leaves a tilt of ~1e-10 rad.
    assert!(l[2].beta.abs() < 1e-8 && l[3].beta.abs() < 1e-8);
    assert!(l.iter().all(|l| l.limits.is_some() && l.mass.is_some()));
    // The UR10e's upper arm is 12.93 kg (ur_description).
    assert!((l[1].mass.unwrap().mass - 12.93).abs() < 1e-9);
    let iiwa = load_model_with(
        urdf_file("iiwa14.urdf").to_str().unwrap(),
        &ChainSpec::default(),
    )
    .unwrap();
    assert!(
        iiwa.description.contains("base_link -> ball_link"),
        "{}",
        iiwa.description
    );
}

/// `identify --params full` frees the tilt `β` of a URDF's parallel axes,
/// a parameter of the imported model: a UR10e built with its third axis
/// tilted by 2 mrad towards the fourth (200 positions, 20 µm noise) is
/// identified with `beta3` within 4 standard errors of the truth, and the
/// residuals show the simulated noise within 4 standard deviations of its
/// estimate (`1/√(2r)` relative, `r` the redundancy): the tilt, 1.2 mm at
/// the tool over the forearm, is explained, not left in the residuals.
#[test]
fn identify_frees_the_tilt_of_a_urdfs_parallel_axes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let urdf = urdf_file("ur10e_robot.urdf");
    let chain = [
        "--model",
        urdf.to_str().unwrap(),
        "--base-link",
        "base_link",
        "--tip-link",
        "tool0",
        "--tip-point",
        "0,0,0.05",
    ];
    let run = |verb: &[&str]| {
        let args: Vec<&str> = verb.iter().chain(&chain).copied().collect();
        succeeds(d, &args)
    };
    run(&[
        "simulate", "--poses", "200", "--seed", "5", "--tilt", "3:0.002", "--out", "d.csv",
        "--truth", "t.json",
    ]);
    run(&["identify", "--data", "d.csv", "--json", "r.json"]);
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join(name)).unwrap()).unwrap()
    };
    let (truth, report) = (read("t.json"), read("r.json"));
    let parameters = report["parameters"].as_array().unwrap();
    let beta3 = parameters.iter().find(|p| p["name"] == "beta3").unwrap();
    assert_eq!(beta3["status"], "identified", "{beta3}");
    let (error, std) = (
        beta3["error"].as_f64().unwrap(),
        beta3["std"].as_f64().unwrap(),
    );
    let true_tilt = truth["errors"]["beta3"].as_f64().unwrap();
    assert!(
        (error - true_tilt).abs() < 4.0 * std,
        "beta3 {error} ± {std} rad against {true_tilt}"
    );
    let identified = parameters
        .iter()
        .filter(|p| p["status"] == "identified")
        .count();
    let redundancy = (3 * 200 - identified) as f64;
    let noise = report["noise"][0]["shown_by_residuals"].as_f64().unwrap();
    assert!(
        (noise / 20e-6 - 1.0).abs() < 4.0 / (2.0 * redundancy).sqrt(),
        "the residuals show {noise} m against the simulated 20 µm"
    );
}

/// Identified errors applied to the nominal model, as a `Robot`.
fn with_errors(nominal: &Robot<f64>, errors: &serde_json::Value) -> Robot<f64> {
    let mut robot = nominal.clone();
    for (name, value) in errors.as_object().unwrap() {
        let p: Param = name.parse().unwrap();
        *robot.param_mut(p).unwrap() += value.as_f64().unwrap();
    }
    robot
}

/// Reads the x, y, z columns of a predictions CSV.
fn predicted_points(csv: &str) -> Vec<Point3<f64>> {
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (x, y, z) = (col("x"), col("y"), col("z"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            Point3::new(v[x], v[y], v[z])
        })
        .collect()
}

/// The joint readings of a measurement CSV, `dof` columns q1..qM.
fn readings(csv: &str, dof: usize) -> Vec<Vec<f64>> {
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let cols: Vec<usize> = (1..=dof)
        .map(|i| header.iter().position(|h| *h == format!("q{i}")).unwrap())
        .collect();
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            cols.iter().map(|&c| v[c].parse().unwrap()).collect()
        })
        .collect()
}

/// In `d`: simulate `poses` poses of the model `model_args` name, identify,
/// export (`--model` and the chain flags passed on when `into_urdf`) and
/// predict the simulated readings.
fn calibrate_and_export(d: &Path, model_args: &[&str], poses: &str, into_urdf: bool) {
    let run = |verb: &[&str], extra: &[&str]| {
        let args: Vec<&str> = verb.iter().chain(extra).copied().collect();
        succeeds(d, &args)
    };
    run(
        &[
            "simulate", "--poses", poses, "--out", "d.csv", "--truth", "t.json",
        ],
        model_args,
    );
    run(
        &["identify", "--data", "d.csv", "--out", "cal.bin"],
        model_args,
    );
    run(
        &[
            "export",
            "--calibration",
            "cal.bin",
            "--format",
            "urdf",
            "--out",
            "cal.urdf",
        ],
        if into_urdf { model_args } else { &[] },
    );
    run(
        &[
            "predict",
            "--calibration",
            "cal.bin",
            "--joints",
            "d.csv",
            "--out",
            "p.csv",
        ],
        &[],
    );
}

/// The largest distance, over the rows of `d.csv`, between `p.csv`'s predicted
/// point and `cal.urdf`'s `armcal_measured_point` in its
/// `armcal_measurement_frame`: evaluated independently, and by re-importing
/// `cal.urdf` from `base` to `armcal_measured_point`.
fn export_against_predict(d: &Path, base: &str, dof: usize) -> (f64, f64) {
    let q = readings(&std::fs::read_to_string(d.join("d.csv")).unwrap(), dof);
    let predicted = predicted_points(&std::fs::read_to_string(d.join("p.csv")).unwrap());
    assert_eq!(q.len(), predicted.len());
    let joints = reference(&std::fs::read_to_string(d.join("cal.urdf")).unwrap());
    let measurement = reference_fk(&joints, base, "armcal_measurement_frame", &[]).inverse();
    let reimported = load_model_with(
        d.join("cal.urdf").to_str().unwrap(),
        &spec(base, "armcal_measured_point", [0.0; 3]),
    )
    .unwrap();
    let (mut independent, mut imported) = (0.0f64, 0.0f64);
    for (q, p) in q.iter().zip(&predicted) {
        let want = measurement * reference_fk(&joints, base, "armcal_measured_point", q);
        independent = independent.max((Point3::from(want.translation.vector) - p).norm());
        let got = measurement * reimported.robot.forward(q).unwrap();
        imported = imported.max((Point3::from(got.translation.vector) - p).norm());
    }
    (independent, imported)
}

/// Simulate, identify, export into the URDF, and compare: the exported URDF's
/// measured point in its measurement frame equals `armcal predict` to 1e-9 m,
/// evaluated independently and by re-importing the export; and the identified
/// model recovers the simulated robot: its points within 50 µm of the true
/// robot's at other configurations within the limits, about 5 times the rms
/// standard error of a prediction, `σ √(p / n)` ≈ 20 µm · √(40 / 150) ≈ 10 µm
/// (20 µm noise per axis, ~40 unknowns, 150–200 poses); the nominal model
/// misses by millimetres.
fn round_trip(file: &str, base: &str, tip: &str, point: [f64; 3], poses: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = urdf_file(file);
    let model = model.to_str().unwrap();
    let point_arg = format!("{},{},{}", point[0], point[1], point[2]);
    let chain = [
        "--model",
        model,
        "--base-link",
        base,
        "--tip-link",
        tip,
        "--tip-point",
        &point_arg,
    ];
    calibrate_and_export(d, &chain, poses, true);
    let nominal = load_model_with(model, &spec(base, tip, point)).unwrap();
    let (independent, imported) = export_against_predict(d, base, nominal.dof());
    // The true robot of the simulation against the identified one, at other configurations.
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("t.json")).unwrap()).unwrap();
    let true_robot = with_errors(&nominal.robot, &truth["errors"]);
    let cal = armcal::io::calibration_file::load_calibration(d.join("cal.bin").to_str().unwrap())
        .unwrap();
    let calibrated = cal.calibrated();
    let (mut recovered, mut nominal_error) = (0.0f64, 0.0f64);
    for q in configurations(&nominal.robot) {
        let t = true_robot.measured_point(&q).unwrap();
        recovered = recovered.max((calibrated.measured_point(&q).unwrap() - t).norm());
        nominal_error = nominal_error.max((nominal.robot.measured_point(&q).unwrap() - t).norm());
    }
    eprintln!(
        "{file}: export vs predict max {independent:.2e} m (independent FK), {imported:.2e} m (re-imported); identified vs true robot max {recovered:.2e} m (nominal {nominal_error:.2e} m)"
    );
    assert!(
        independent < 1e-9 && imported < 1e-9,
        "{independent} {imported}"
    );
    assert!(recovered < 5e-5, "{recovered}");
    // Only the moving joints' origins changed, and two links were added.
    let original = std::fs::read_to_string(model).unwrap();
    let exported = std::fs::read_to_string(d.join("cal.urdf")).unwrap();
    assert_eq!(
        original.matches("<link").count() + 2,
        exported.matches("<link").count()
    );
}

#[test]
fn panda_round_trip() {
    round_trip(
        "panda.urdf",
        "panda_link0",
        "panda_hand",
        [0.0, 0.0, 0.1034],
        "150",
    );
}

#[test]
fn iiwa14_round_trip() {
    round_trip("iiwa14.urdf", "base_link", "ball_link", [0.0; 3], "150");
}

#[test]
fn ur10e_round_trip() {
    round_trip(
        "ur10e_robot.urdf",
        "base_link",
        "tool0",
        [0.0, 0.0, 0.05],
        "150",
    );
}

#[test]
fn talos_round_trip() {
    round_trip(
        "talos_full_v2.urdf",
        "base_link",
        "gripper_left_base_link",
        [0.0; 3],
        "200",
    );
}

/// A URDF generated from a calibration of a TOML model (the built-in UR10e,
/// standard D-H): its measured point in its measurement frame is `predict`'s,
/// independently evaluated and re-imported.
#[test]
fn generated_urdf_of_the_builtin_ur10e_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    calibrate_and_export(d, &["--model", "ur10e"], "100", false);
    let (independent, imported) = export_against_predict(d, "base_link", 6);
    eprintln!(
        "generated ur10e: export vs predict max {independent:.2e} m (independent FK), {imported:.2e} m (re-imported)"
    );
    assert!(
        independent < 1e-9 && imported < 1e-9,
        "{independent} {imported}"
    );
}

/// The measured `x,y,z` of each row of a measurements CSV, in its units.
fn measured_points(csv: &str) -> Vec<Point3<f64>> {
    predicted_points(csv)
}

/// The mm figures of a line, in order: each number followed by ` mm`.
fn mm_figures(line: &str) -> Vec<f64> {
    let words: Vec<&str> = line.split_whitespace().collect();
    words
        .windows(2)
        .filter(|w| w[1].starts_with("mm"))
        .map(|w| w[0].trim_start_matches('(').parse().unwrap())
        .collect()
}

/// What a URDF user gets from a diagnosis that names an effect: the geometry
/// refitted without it, not the geometry fitted with it.
///
/// The UR5e of `armcal simulate` (±1 mm / ±1 mrad errors, 20 µm noise per
/// axis) with an encoder scale error of joint 2 (1e-4: the reading is
/// 1.0001 q, so a 1 rad reading turns the arm 0.1 mrad more, ~0.1 mm at the
/// tool point across the 0.85 m reach): 250 positions, the first 150
/// diagnosed, the last 100 held out. Diagnose names the encoder scale; a URDF
/// cannot carry it, so the export writes the calibration's geometric
/// fallback, and
/// - the URDF read back (`--tip-link armcal_measured_point`) in its
///   measurement frame is the fallback's forward kinematics to 1e-9 m (the
///   export writes every number exactly: rounding, ~1e-15 m), and not the
///   geometry fitted with the effect: the two differ by far more (the scale's
///   share the geometry takes when fitted alone, tens of µm);
/// - the line it prints gives the held-out figures of diagnose's JSON, to
///   the 4 significant digits printed (relative 5e-4);
/// - on the 100 poses held out the URDF predicts better than the geometry
///   fitted with the effect would without it, and its RMS agrees with the
///   printed figure within sampling error: the residual left is the
///   encoder scale's, which an RMS over 100 poses estimates to about 10 %
///   (as does the 10-fold figure over 150): within 30 %. Measured: the URDF
///   0.1125 mm, the geometry fitted with the effect 0.1212 mm, printed
///   0.0997 mm; the URDF is the fallback's kinematics to 9.5e-16 m and
///   7.2e-5 m from the geometry fitted with the effect.
#[test]
fn export_of_a_diagnosis_with_an_effect_holds_the_geometry_refitted_without_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    succeeds(
        d,
        &[
            "simulate",
            "--model",
            "ur5e",
            "--poses",
            "250",
            "--seed",
            "3",
            "--effect",
            "encoder_scale:2",
            "--out",
            "all.csv",
        ],
    );
    let all = std::fs::read_to_string(d.join("all.csv")).unwrap();
    let mut lines = all.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.collect();
    let part = |rows: &[&str]| format!("{header}\n{}\n", rows.join("\n"));
    std::fs::write(d.join("train.csv"), part(&rows[..150])).unwrap();
    std::fs::write(d.join("test.csv"), part(&rows[150..])).unwrap();
    succeeds(
        d,
        &[
            "diagnose",
            "--model",
            "ur5e",
            "--data",
            "train.csv",
            "--out",
            "arm.cal",
            "--json",
            "r.json",
        ],
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(report["effects"][0]["name"], "encoder_scale", "{report}");
    let out = succeeds(
        d,
        &[
            "export",
            "--calibration",
            "arm.cal",
            "--format",
            "urdf",
            "--out",
            "arm.urdf",
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    let note = stderr
        .lines()
        .find(|l| l.contains("cannot carry the effects"))
        .unwrap_or_else(|| panic!("{stderr}"));
    assert!(
        note.contains("(encoder scale of joint 2): it holds the geometry refitted without them"),
        "{note}"
    );
    // The printed figures are the JSON's (m, then mm beside: ur5e is in m).
    let printed = mm_figures(note);
    let written = &report["written"];
    let fallback = written["geometric_fallback"]["held_out_rms_mm"]
        .as_f64()
        .unwrap();
    let with_effects = written["held_out_rms_mm"].as_f64().unwrap();
    assert_eq!(fallback, report["holdout"]["geometric_rms_mm"]);
    assert_eq!(with_effects, report["holdout"]["extended_rms_mm"]);
    assert_eq!(printed.len(), 2, "{note}");
    for (p, j) in printed.iter().zip([fallback, with_effects]) {
        assert!(
            (p / j - 1.0).abs() <= 5e-4,
            "printed {p} mm, the JSON {j} mm"
        );
    }

    // The URDF's forward kinematics: the fallback's, not the geometry fitted
    // with the effect.
    let cal = armcal::io::calibration_file::load_calibration(d.join("arm.cal").to_str().unwrap())
        .unwrap();
    let geometric = cal.geometric_only().expect("a fallback").calibrated();
    let fitted_with = cal.calibrated();
    let text = std::fs::read_to_string(d.join("arm.urdf")).unwrap();
    let joints = reference(&text);
    let measurement = reference_fk(&joints, "base_link", "armcal_measurement_frame", &[]).inverse();
    let urdf = load_model_with(
        d.join("arm.urdf").to_str().unwrap(),
        &spec("base_link", "armcal_measured_point", [0.0; 3]),
    )
    .unwrap();
    let test = std::fs::read_to_string(d.join("test.csv")).unwrap();
    let measured = measured_points(&test);
    let (mut to_fallback, mut to_fitted_with) = (0.0f64, 0.0f64);
    let (mut urdf_sq, mut fitted_with_sq) = (0.0, 0.0);
    for (q, m) in readings(&test, 6).iter().zip(&measured) {
        let point = |pose: Pose| Point3::from(pose.translation.vector);
        let got = point(measurement * urdf.robot.forward(q).unwrap());
        let want = point(geometric.forward(q).unwrap());
        let other = point(fitted_with.forward(q).unwrap());
        to_fallback = to_fallback.max((got - want).norm());
        to_fitted_with = to_fitted_with.max((got - other).norm());
        urdf_sq += (got - m).norm_squared();
        fitted_with_sq += (other - m).norm_squared();
    }
    let n = measured.len() as f64;
    let (urdf_rms, fitted_with_rms) = ((urdf_sq / n).sqrt(), (fitted_with_sq / n).sqrt());
    eprintln!(
        "URDF vs fallback max {to_fallback:.2e} m, vs the geometry fitted with the effect {to_fitted_with:.2e} m; held out: URDF {:.4} mm, the geometry fitted with the effect {:.4} mm, printed {:.4} mm",
        urdf_rms * 1e3,
        fitted_with_rms * 1e3,
        printed[0]
    );
    assert!(to_fallback < 1e-9, "{to_fallback}");
    assert!(to_fitted_with > 1e-5, "{to_fitted_with}");
    assert!(urdf_rms < fitted_with_rms);
    assert!(
        (urdf_rms * 1e3 / printed[0] - 1.0).abs() < 0.3,
        "held out {urdf_rms} m, printed {} mm",
        printed[0]
    );
}

/// Export refuses a URDF other than the model's, and chain flags without it,
/// writing nothing.
#[test]
fn export_refuses_another_model() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    succeeds(
        d,
        &[
            "simulate", "--model", "ur10e", "--poses", "60", "--out", "d.csv",
        ],
    );
    succeeds(
        d,
        &[
            "identify", "--model", "ur10e", "--data", "d.csv", "--out", "cal.bin",
        ],
    );
    let panda = urdf_file("panda.urdf");
    refused(
        d,
        &[
            "export",
            "--calibration",
            "cal.bin",
            "--model",
            panda.to_str().unwrap(),
            "--tip-link",
            "panda_hand",
            "--format",
            "urdf",
            "--out",
            "x.urdf",
        ],
        &["panda.urdf", "was not identified with this model"],
    );
    refused(
        d,
        &[
            "export",
            "--calibration",
            "cal.bin",
            "--tip-link",
            "x",
            "--format",
            "urdf",
            "--out",
            "x.urdf",
        ],
        &["--model"],
    );
    refused(
        d,
        &[
            "check",
            "--model",
            "ur10e",
            "--data",
            "d.csv",
            "--tip-link",
            "tool0",
        ],
        &["--tip-link", "applies to a URDF model only"],
    );
}

/// A small URDF whose line `n` the refusal tests replace.
const SMALL: &str = r#"<?xml version="1.0"?>
<robot name="two">
  <link name="base"/>
  <link name="l1"/>
  <link name="l2"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="l1"/>
    <child link="l2"/>
    <origin xyz="0.4 0 0" rpy="1.5707963267948966 0 0"/>
    <axis xyz="0 0 1"/>
  </joint>
</robot>
"#;

/// Each bad URDF is refused with exit status 2 and its file:line:column, and
/// nothing is written.
#[test]
fn bad_urdfs_are_refused_with_their_place() {
    let cases: [(usize, &str, &str); 11] = [
        (
            9,
            r#"    <origin xyz="1 2" rpy="0 0 0"/>"#,
            "small.urdf:9:18: xyz=\"1 2\": 2 numbers, expected 3",
        ),
        (
            9,
            r#"    <origin xyz="0 0 abc"/>"#,
            "small.urdf:9:18: xyz=\"0 0 abc\": \"abc\" is not a finite number",
        ),
        (
            8,
            r#"    <child link="l9"/>"#,
            "small.urdf:8:18: joint \"j1\": child link \"l9\" is not a <link>",
        ),
        (
            6,
            r#"  <joint name="j1" type="hinge">"#,
            "small.urdf:6:26: joint \"j1\": unknown joint type \"hinge\"",
        ),
        (
            6,
            r#"  <joint name="j1" type="floating">"#,
            "small.urdf:6:3: joint \"j1\" on the chain from \"base\" to \"l2\" is floating",
        ),
        (
            6,
            r#"  <joint name="j1" type="planar">"#,
            "small.urdf:6:3: joint \"j1\" on the chain from \"base\" to \"l2\" is planar",
        ),
        // A second parent for l2: not a tree.
        (
            8,
            r#"    <child link="l2"/>"#,
            "small.urdf:12:3: link \"l2\" is the child of joint \"j1\" (line 6) and of joint \"j2\"",
        ),
        // Two roots.
        (
            5,
            r#"  <link name="l2"/><link name="lone"/>"#,
            "small.urdf:5:20: link \"lone\" is nobody's child, and so is link \"base\"",
        ),
        // A loop: j1 makes base its own child.
        (
            8,
            r#"    <child link="base"/>"#,
            "small.urdf:6:3: joint \"j1\" is part of a loop",
        ),
        (
            10,
            r#"    <axis xyz="0 0 0"/>"#,
            "small.urdf:10:5: joint \"j1\": the axis of a revolute joint is zero",
        ),
        // A joint of the chain whose reading is another's.
        (
            16,
            r#"    <axis xyz="0 0 1"/><mimic joint="j1" multiplier="2"/>"#,
            "small.urdf:16:24: joint \"j2\" on the chain from \"base\" to \"l2\" mimics joint \"j1\"",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("d.csv"), "q1,q2,x,y,z\n0,0,0,0,0\n").unwrap();
    for (line, new, place) in cases {
        let mut lines: Vec<&str> = SMALL.lines().collect();
        lines[line - 1] = new;
        std::fs::write(d.join("small.urdf"), lines.join("\n")).unwrap();
        refused(
            d,
            &[
                "simulate",
                "--model",
                "small.urdf",
                "--poses",
                "10",
                "--out",
                "out.csv",
            ],
            &[place],
        );
    }
    // A tip that is not below the base, and an unknown link.
    std::fs::write(d.join("small.urdf"), SMALL).unwrap();
    refused(
        d,
        &[
            "simulate",
            "--model",
            "small.urdf",
            "--base-link",
            "l2",
            "--tip-link",
            "l1",
            "--out",
            "out.csv",
        ],
        &["small.urdf:4:3: ", "not below the base link"],
    );
    refused(
        d,
        &[
            "simulate",
            "--model",
            "small.urdf",
            "--tip-link",
            "l7",
            "--out",
            "out.csv",
        ],
        &["--tip-link", "no such link"],
    );
    // Several moving branches and no tip.
    let branched = SMALL.replace(
        "</robot>",
        "  <link name=\"l3\"/>\n  <joint name=\"j3\" type=\"prismatic\">\n    <parent link=\"l1\"/>\n    <child link=\"l3\"/>\n  </joint>\n</robot>",
    );
    std::fs::write(d.join("small.urdf"), branched).unwrap();
    refused(
        d,
        &["simulate", "--model", "small.urdf", "--out", "out.csv"],
        &["small.urdf:4:3: ", "branches", "--tip-link"],
    );
}

/// `--tool` of a URDF model is in the URDF's own frame of the tip link: the
/// UR10e read with its default chain (world to `wrist_3_link`, whose frame
/// is the flange face, 116.55 mm out from where the model's last frame sits,
/// at the crossing of the wrist axes), an SMR measured 50 mm out on it. The
/// calibration `identify` writes carries that flange; `predict --tool X,Y,Z`
/// of its nominal puts the working tool at the URDF's `wrist_3_link ·
/// (X, Y, Z)` and `--tool 0,0,0` at `tool0` (the same origin), by the
/// independent evaluation of the joint origins, to 1e-12 m at 200
/// configurations.
#[test]
fn a_working_tool_of_a_urdf_model_is_in_its_tip_links_frame() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let path = urdf_file("ur10e_robot.urdf");
    let file = path.to_str().unwrap();
    let chain = ChainSpec {
        tip_point: Some(Vector3::new(0.0, 0.0, 0.05)),
        ..ChainSpec::default()
    };
    let model = load_model_with(file, &chain).unwrap();
    // The flange is 116.55 mm from the model's last frame, on its axis.
    let flange = model.flange.isometry();
    assert!(
        (flange.translation.vector.norm() - 0.11655).abs() < 1e-9,
        "{flange}"
    );
    // What identify writes carries the flange.
    succeeds(
        d,
        &[
            "simulate",
            "--model",
            file,
            "--tip-point",
            "0,0,0.05",
            "--poses",
            "60",
            "--out",
            "s.csv",
        ],
    );
    succeeds(
        d,
        &[
            "identify",
            "--model",
            file,
            "--tip-point",
            "0,0,0.05",
            "--data",
            "s.csv",
            "--out",
            "s.cal",
            "--quiet",
        ],
    );
    let written =
        armcal::io::calibration_file::load_calibration(d.join("s.cal").to_str().unwrap()).unwrap();
    assert_eq!(written.flange, model.flange);
    // The nominal calibration with that flange, predicted with working tools.
    let mut cal =
        armcal_shared::Calibration::nominal(model.robot.clone(), Task::Position, model.units);
    cal.flange = model.flange;
    std::fs::write(d.join("n.cal"), cal.to_bytes().unwrap()).unwrap();
    let qs = configurations(&model.robot);
    let mut joints = String::from("q1,q2,q3,q4,q5,q6\n");
    for q in &qs {
        let row: Vec<String> = q.iter().map(|v| format!("{v:?}")).collect();
        joints += &(row.join(",") + "\n");
    }
    std::fs::write(d.join("j.csv"), joints).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let joints = reference(&text);
    for (tool, link) in [
        ([0.0, 0.0, 0.0], "tool0"),
        ([0.01, -0.02, 0.25], "wrist_3_link"),
    ] {
        let flag = format!("{},{},{}", tool[0], tool[1], tool[2]);
        let out = succeeds(
            d,
            &[
                "predict",
                "--calibration",
                "n.cal",
                "--joints",
                "j.csv",
                "--tool",
                &flag,
            ],
        );
        let points = predicted_points(&String::from_utf8(out.stdout).unwrap());
        let worst = qs
            .iter()
            .zip(&points)
            .map(|(q, p)| {
                let want = reference_fk(&joints, "world", link, q) * Point3::from(tool);
                (want - p).norm()
            })
            .fold(0.0, f64::max);
        assert!(worst < 1e-12, "--tool {flag} against {link}: {worst} m");
    }
}
