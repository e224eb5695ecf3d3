//! `armcal predict` as a user runs it: a calibration with known errors predicts
//! the calibrated model's forward kinematics row for row, in the model's units;
//! a damaged, truncated or foreign calibration and a bad joints file are refused
//! with exit status 2, naming the file and the reason, and nothing is written.

use crate::{armcal, assert_success};
use armcal::io::model_file::{load_model, parse_model};
use armcal::session::model::RobotModel;
use armcal_shared::compensation::Task;
use armcal_shared::ranges::Ranges;
use armcal_shared::{Calibration, Param, ParamError};

/// `model`'s nominal calibration with the given errors (SI), as if identified
/// on every joint within a turn either way (m for a prismatic joint), at
/// 15–40 °C and 0–5 kg: the rows of these tests lie inside.
fn calibration(model: &RobotModel, task: Task, errors: &[(&str, f64)]) -> Calibration {
    let mut cal = Calibration::nominal(model.robot.clone(), task, model.units);
    let turn = vec![std::f64::consts::TAU; model.dof()];
    let back: Vec<f64> = turn.iter().map(|x| -x).collect();
    cal.ranges = Some(Ranges::of([
        (&back[..], Some(15.0), Some(0.0)),
        (&turn[..], Some(40.0), Some(5.0)),
    ]));
    for (name, error) in errors {
        let param: Param = name.parse().unwrap();
        cal.errors
            .push(ParamError {
                param,
                error: *error,
            })
            .unwrap();
    }
    cal
}

/// Joint readings in model units, one row per configuration, varied enough that
/// every joint matters.
fn readings(dof: usize, rows: usize, scale: f64) -> Vec<Vec<f64>> {
    (0..rows)
        .map(|r| {
            (0..dof)
                .map(|j| scale * (0.37 * (r as f64 + 1.0) * (j as f64 + 1.3)).sin())
                .collect()
        })
        .collect()
}

/// The rows of a predictions CSV: the first line is a comment, the second the
/// header; returns the header and the numbers.
fn read_predictions(csv: &str) -> (String, Vec<Vec<f64>>) {
    let mut lines = csv.lines();
    let comment = lines.next().expect("a comment line");
    assert!(comment.starts_with("# "), "{comment}");
    let header = lines.next().expect("a header").to_owned();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|f| f.parse::<f64>().unwrap_or_else(|e| panic!("{f:?}: {e}")))
                .collect()
        })
        .collect();
    (header, rows)
}

/// Runs `predict` on `cal` and the readings (model units), to a file and to
/// stdout, and checks every row against the calibrated model's forward
/// kinematics in the model's units.
fn predicts_the_calibrated_forward_kinematics(
    model: &RobotModel,
    cal: &Calibration,
    q: &[Vec<f64>],
) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cal.bin"), cal.to_bytes().unwrap()).unwrap();
    // A measurement-like file: comment, extra columns in the way, joints out of order.
    let dof = model.dof();
    let mut text = String::from("# joint readings\nid,x,y,z,");
    let order: Vec<usize> = (0..dof).rev().collect();
    let names: Vec<String> = order.iter().map(|j| format!("q{}", j + 1)).collect();
    text.push_str(&names.join(","));
    text.push_str(",temp\n");
    for (r, row) in q.iter().enumerate() {
        let values: Vec<String> = order.iter().map(|&j| format!("{}", row[j])).collect();
        text.push_str(&format!("{r},1,2,3,{},20\n", values.join(",")));
    }
    std::fs::write(dir.path().join("j.csv"), &text).unwrap();

    let out = armcal(
        &[
            "predict",
            "--calibration",
            "cal.bin",
            "--joints",
            "j.csv",
            "--out",
            "p.csv",
        ],
        dir.path(),
    );
    assert_success(&out);
    assert!(out.stdout.is_empty(), "--out prints nothing");
    let csv = std::fs::read_to_string(dir.path().join("p.csv")).unwrap();
    let first = csv.lines().next().unwrap();
    assert!(first.contains("cal.bin"), "{first}");
    assert!(
        first.contains(&format!("in {}", model.units.length)),
        "{first}"
    );

    let (header, rows) = read_predictions(&csv);
    if cal.task == Task::Pose {
        assert_eq!(header, "x,y,z,qw,qx,qy,qz");
    } else {
        assert_eq!(header, "x,y,z");
    }
    assert_eq!(rows.len(), q.len(), "one row per input row");
    let calibrated = cal.calibrated();
    let nominal = &model.robot;
    let u = model.units;
    for (row, qm) in rows.iter().zip(q) {
        let q_si: Vec<f64> = qm
            .iter()
            .zip(&nominal.links)
            .map(|(&v, l)| u.joint_to_si(l.joint, v))
            .collect();
        let t = calibrated.forward(&q_si).unwrap();
        let want = t.translation.vector.map(|x| u.length_from_si(x));
        let scale = want.norm();
        for (got, want) in row.iter().zip(want.iter()) {
            assert!(
                (got - want).abs() <= 1e-12 * scale,
                "{got} against {want} in {row:?}"
            );
        }
        // The errors move the point: this is not the nominal model.
        let moved = (nominal.measured_point(&q_si).unwrap().coords - t.translation.vector).norm();
        assert!(moved > 1e-5, "{moved}");
        if cal.task == Task::Pose {
            assert_eq!(row.len(), 7);
            let mut want = nalgebra::UnitQuaternion::from_rotation_matrix(&t.rotation);
            if want.w < 0.0 {
                want = nalgebra::UnitQuaternion::new_unchecked(-want.into_inner());
            }
            assert!(row[3] >= 0.0);
            for (got, want) in row[3..].iter().zip([want.w, want.i, want.j, want.k]) {
                assert!((got - want).abs() <= 1e-12, "{got} against {want}");
            }
        } else {
            assert_eq!(row.len(), 3);
        }
    }

    // Without --out, the same CSV on stdout.
    let out = armcal(
        &["predict", "--calibration", "cal.bin", "--joints", "j.csv"],
        dir.path(),
    );
    assert!(out.status.success());
    assert_eq!(String::from_utf8(out.stdout).unwrap(), csv);
}

#[test]
fn predicts_puma560_position_in_inches() {
    let model = load_model("puma560").unwrap();
    let cal = calibration(
        &model,
        Task::Position,
        &[
            ("theta2", 0.01),
            ("a3", 0.05 * 0.0254),
            ("alpha1", -0.01),
            ("s4", 0.002),
            ("base.x", 0.003),
            ("tool.z", -0.001),
        ],
    );
    predicts_the_calibrated_forward_kinematics(&model, &cal, &readings(6, 9, 1.2));
}

#[test]
fn predicts_full_pose_of_a_mm_degree_arm() {
    let model = parse_model(
        "name = \"rrp\"\nconvention = \"mdh\"\nlength_unit = \"mm\"\nangle_unit = \"deg\"\n\
         [[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 400\na = 0\nalpha = 0\n\
         [[joint]]\ntype = \"revolute\"\ntheta = -90\ns = 0\na = 150\nalpha = -90\n\
         [[joint]]\ntype = \"prismatic\"\ntheta = 0\ns = 200\na = 500\nalpha = 0\n\
         [tool]\nxyz = [10, 0, 80]\nrpy = [0, 90, 0]\n",
        "rrp.toml",
    )
    .unwrap();
    let cal = calibration(
        &model,
        Task::Pose,
        &[
            ("theta1", 0.002),
            ("alpha2", -0.001),
            ("s3", 0.0005),
            ("a2", -0.0003),
            ("tool.ry", 0.003),
            ("base.rz", 0.001),
        ],
    );
    // Degrees for the revolute joints, millimetres for the prismatic one.
    let q: Vec<Vec<f64>> = readings(3, 7, 60.0);
    predicts_the_calibrated_forward_kinematics(&model, &cal, &q);
}

/// Runs `predict --out p.csv` with `bytes` as the calibration and checks the
/// refusal: status 2, the message names the file and `reason`, nothing written.
#[track_caller]
fn refuses_calibration(bytes: &[u8], reason: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cal.bin"), bytes).unwrap();
    std::fs::write(dir.path().join("j.csv"), "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n").unwrap();
    let out = armcal(
        &[
            "predict",
            "--calibration",
            "cal.bin",
            "--joints",
            "j.csv",
            "--out",
            "p.csv",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.starts_with("armcal: error: cal.bin: "), "{stderr}");
    assert!(stderr.contains(reason), "{reason:?} not in {stderr}");
    assert!(out.stdout.is_empty());
    assert!(!dir.path().join("p.csv").exists(), "--out written");
}

#[test]
fn refuses_damaged_truncated_and_foreign_calibrations() {
    let model = load_model("puma560").unwrap();
    let bytes = calibration(&model, Task::Pose, &[("theta2", 0.01)])
        .to_bytes()
        .unwrap();

    let mut flipped = bytes.clone();
    flipped[armcal_shared::calibration::HEADER_LEN + 5] ^= 0x10;
    refuses_calibration(&flipped, "CRC");

    refuses_calibration(&bytes[..bytes.len() - 7], "truncated");
    refuses_calibration(&bytes[..3], "truncated");

    refuses_calibration(
        b"q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n",
        "not an armcal calibration file",
    );
    refuses_calibration(b"", "truncated");

    // A missing file: status 2 too, naming it.
    let dir = tempfile::tempdir().unwrap();
    let out = armcal(
        &[
            "predict",
            "--calibration",
            "none.bin",
            "--joints",
            "j.csv",
            "--out",
            "p.csv",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("none.bin: cannot read"));
    assert!(!dir.path().join("p.csv").exists());
}

#[test]
fn refuses_a_bad_joint_value_with_file_line_column() {
    let model = load_model("puma560").unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("cal.bin"),
        calibration(&model, Task::Position, &[]).to_bytes().unwrap(),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("j.csv"),
        "# readings\nq1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n0.1,0.2,0..3,0.4,0.5,0.6\n",
    )
    .unwrap();
    // An existing output stays as it was.
    std::fs::write(dir.path().join("p.csv"), "old").unwrap();
    let out = armcal(
        &[
            "predict",
            "--calibration",
            "cal.bin",
            "--joints",
            "j.csv",
            "--out",
            "p.csv",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("j.csv:4:9: column 'q3': \"0..3\" is not a finite number"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("p.csv")).unwrap(),
        "old"
    );

    // Joints of another robot: a joint-count mismatch.
    std::fs::write(dir.path().join("j.csv"), "q1,q2,q3\n0,0,0\n").unwrap();
    let out = armcal(
        &["predict", "--calibration", "cal.bin", "--joints", "j.csv"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("j.csv:1:1: missing column 'q4'"),
        "{stderr}"
    );
    assert!(out.stdout.is_empty());
}

/// Commands in a well-conditioned part of the UR10e's workspace (elbow and wrist
/// bent), 0.1 rad apart, as CSV rows `q1..q6` followed by `extra(row)`.
fn ur10e_commands(extra: impl Fn(usize) -> String) -> (Vec<Vec<f64>>, String) {
    let commands: Vec<Vec<f64>> = (0..12)
        .map(|r| {
            let t = r as f64 * 0.1;
            vec![
                0.3 + t,
                -1.2 + 0.5 * t,
                1.5 - 0.3 * t,
                -1.0 + t,
                1.2 + 0.2 * t,
                0.4 - t,
            ]
        })
        .collect();
    let mut text = String::new();
    for (r, q) in commands.iter().enumerate() {
        let v: Vec<String> = q.iter().map(|x| format!("{x}")).collect();
        text.push_str(&(v.join(",") + &extra(r) + "\n"));
    }
    (commands, text)
}

/// Runs `armcal compensate` with `cal` on the joints file `text`; checks that it
/// succeeds and reports no row; returns the corrected rows.
fn compensate_rows(cal: &Calibration, text: &str) -> Vec<Vec<f64>> {
    let (rows, stderr) = compensate_warning(cal, text);
    assert!(stderr.is_empty(), "no row reported: {stderr}");
    rows
}

/// Runs `armcal compensate` with `cal` on the joints file `text`; checks that it
/// succeeds; returns the corrected rows and its standard error.
fn compensate_warning(cal: &Calibration, text: &str) -> (Vec<Vec<f64>>, String) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cal.bin"), cal.to_bytes().unwrap()).unwrap();
    std::fs::write(dir.path().join("cmd.csv"), text).unwrap();
    let out = armcal(
        &[
            "compensate",
            "--calibration",
            "cal.bin",
            "--joints",
            "cmd.csv",
            "--out",
            "c.csv",
        ],
        dir.path(),
    );
    assert_success(&out);
    let (header, rows) =
        read_predictions(&std::fs::read_to_string(dir.path().join("c.csv")).unwrap());
    assert_eq!(header, "q1,q2,q3,q4,q5,q6");
    (rows, String::from_utf8_lossy(&out.stderr).into_owned())
}

/// `armcal compensate`: the calibrated robot at each corrected command reaches
/// the nominal model's pose at the command (to the compensation's f64 tolerance,
/// 1 nm, plus the rounding of the printed values), rows in order, in model units.
#[test]
fn compensate_makes_the_calibrated_robot_reach_the_nominal_pose() {
    let model = load_model("ur10e").unwrap();
    let cal = calibration(
        &model,
        Task::Pose,
        &[
            ("alpha2", 1.2e-3),
            ("a3", -0.8e-3),
            ("theta4", 0.9e-3),
            ("s5", 0.6e-3),
            ("base.x", 2e-3),
        ],
    );
    let (commands, text) = ur10e_commands(|_| String::new());
    let rows = compensate_rows(&cal, &format!("q1,q2,q3,q4,q5,q6\n{text}"));
    assert_eq!(rows.len(), commands.len());
    let calibrated = cal.calibrated();
    for (q, q_cmd) in rows.iter().zip(&commands) {
        let target = cal.nominal.forward(q_cmd).unwrap();
        let reached = calibrated.forward(q).unwrap();
        let dp = (target.translation.vector - reached.translation.vector).norm();
        assert!(dp < 1e-9, "{dp:e} m at {q_cmd:?}");
        let moved = q
            .iter()
            .zip(q_cmd)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(moved > 1e-5, "the commands were corrected");
    }
}

/// `armcal compensate` with a calibration from `armcal diagnose` (geometry and
/// every kind of effect) applies the effects in each row's conditions (the
/// `temp` and `load` columns) with the approach direction of each joint from the
/// output rows before (held while the joint holds): the calibrated model with its effects, evaluated as
/// `armcal predict` evaluates it on the output rows with the same columns,
/// reaches the nominal pose. Tolerance: 1 nm of the geometric step plus at most
/// 1e-9 rad per joint left by the inversion at the UR10e's 1.6 m reach, 11 nm
/// (see `shared/tests/compensation.rs`); the printed values read back exactly.
/// Without the columns (the reference temperature, no payload) the commands
/// differ, and the warning names both columns with the value assumed.
#[test]
fn compensate_applies_the_effects_in_each_rows_context() {
    use armcal_shared::effects::{Approach, Context, one_of_each};
    let model = load_model("ur10e").unwrap();
    let mut cal = calibration(&model, Task::Pose, &[("alpha2", 1.2e-3), ("a3", -0.8e-3)]);
    for effect in one_of_each() {
        cal.effects.push(effect).unwrap();
    }
    let temp = |r: usize| 20.0 + 1.5 * r as f64;
    let load = |r: usize| if r < 6 { 0.0 } else { 5.0 };
    let (commands, text) = ur10e_commands(|r| format!(",{},{}", temp(r), load(r)));
    let rows = compensate_rows(&cal, &format!("q1,q2,q3,q4,q5,q6,temp,load\n{text}"));
    let effect_model = cal.model();
    let mut approach = Approach::new();
    for (r, (q, q_cmd)) in rows.iter().zip(&commands).enumerate() {
        let ctx = Context {
            temperature: Some(temp(r)),
            payload: Some(load(r)),
            approach: approach.next(q),
        };
        let target = cal.nominal.forward(q_cmd).unwrap();
        let reached = effect_model.forward(q, &ctx).unwrap();
        let dp = (target.translation.vector - reached.translation.vector).norm();
        assert!(dp < 1.1e-8, "{dp:e} m at row {r}");
    }
    let (_, plain) = ur10e_commands(|_| String::new());
    let (without, stderr) = compensate_warning(&cal, &format!("q1,q2,q3,q4,q5,q6\n{plain}"));
    let (_, reference) = cal
        .effects
        .iter()
        .find_map(|e| e.thermal_expansion())
        .unwrap();
    for needle in [
        format!("cmd.csv: no `temp` column: {reference} °C assumed for every row, the calibration's thermal expansion needs it (identified at 15 to 40 °C)"),
        "cmd.csv: no `load` column: 0 kg assumed for every row, the calibration's joint compliance needs it (identified at 0 to 5 kg)".into(),
    ] {
        assert!(stderr.contains(&needle), "{needle} not in {stderr}");
    }
    let differ = rows
        .iter()
        .flatten()
        .zip(without.iter().flatten())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        differ > 1e-5,
        "the context columns are used: {differ:e} rad"
    );
}

/// `compensate --servo` on a smooth PUMA path with a position-only
/// calibration from `identify`: ticks whose pose is reached but whose
/// search for the least joint change ran out of its 4 iterations are counted
/// once, as such, and no row is said not to converge (every pose is
/// reached: the residuals are within the 1 nm tolerance).
#[test]
fn compensate_servo_counts_an_unsettled_least_correction_once() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| crate::succeeds(dir.path(), args);
    run(&[
        "simulate", "--model", "puma560", "--out", "p.csv", "--poses", "100", "--seed", "2",
    ]);
    run(&[
        "identify", "--model", "puma560", "--data", "p.csv", "--out", "p.cal",
    ]);
    let mut text = String::from("q1,q2,q3,q4,q5,q6\n");
    for t in 0..3000 {
        let s = 0.01 * t as f64;
        let q = [
            0.5 * s.sin(),
            -0.5 + 0.4 * (1.3 * s).sin(),
            0.5 + 0.3 * (0.7 * s).sin(),
            0.5 * (0.9 * s).sin(),
            0.6 * (1.1 * s).sin(),
            0.3 * s.sin(),
        ];
        let values: Vec<String> = q.iter().map(|v| v.to_string()).collect();
        text.push_str(&values.join(","));
        text.push('\n');
    }
    std::fs::write(dir.path().join("j.csv"), text).unwrap();
    let out = run(&[
        "compensate",
        "--servo",
        "--calibration",
        "p.cal",
        "--joints",
        "j.csv",
        "--out",
        "c.csv",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("did not converge"), "{stderr}");
    let counted: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("rows reach their pose, but the search for the least joint change"))
        .collect();
    assert_eq!(counted.len(), 1, "{stderr}");
    assert!(counted[0].contains("j.csv: "), "{stderr}");
    assert!(counted[0].contains(" of 3000 rows"), "{stderr}");
}

/// `armcal compensate` with a position-only calibration keeps the flange's
/// orientation where the calibrated model has it at the command, and names
/// the rows near a singularity where it cannot without a larger joint
/// correction: a UR10e whose link lengths, twists and base are off by
/// millimetres and milliradians, commanded at its wrist singularity (q5 = 0,
/// joints 4 and 6 aligned) and away from it (q5 = 1.2 rad). The row at the
/// singularity is named with its line and its turn (the figure the library's
/// correction reports, to the 0.01 mrad printed), the row away from it is
/// not; both reach their point (no row said missed).
#[test]
fn compensate_names_the_rows_whose_flange_turns_near_a_singularity() {
    use armcal_shared::compensation::{Compensator, Conditions, Limits, Pacing};
    let model = load_model("ur10e").unwrap();
    let cal = calibration(
        &model,
        Task::Position,
        &[
            ("base.y", 5e-3),
            ("alpha2", 3e-3),
            ("a3", 3e-3),
            ("alpha4", 3e-3),
            ("s4", -3e-3),
            ("theta5", 2e-3),
        ],
    );
    let singular = [0.3, -1.2, 1.5, -1.0, 0.0, 0.4];
    let away = [0.3, -1.2, 1.5, -1.0, 1.2, 0.4];
    let comp = Compensator::<f64>::from_calibration(&cal, Limits::of(Pacing::Program));
    let turn = |q: &[f64]| {
        let c = comp.correct(q, &Conditions::default());
        comp.turn(q, &c.p).unwrap()
    };
    assert!(
        turn(&away) < 1e-5,
        "away from the singularity: {:e} rad",
        turn(&away)
    );
    let at = turn(&singular);
    assert!(at > 1e-3, "at the singularity: {at:e} rad");
    let row = |q: &[f64; 6]| q.map(|x| x.to_string()).join(",");
    let text = format!("q1,q2,q3,q4,q5,q6\n{}\n{}\n", row(&singular), row(&away));
    let (rows, stderr) = compensate_warning(&cal, &text);
    assert_eq!(rows.len(), 2);
    let named: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("the flange turned from the orientation"))
        .collect();
    assert_eq!(named.len(), 1, "{stderr}");
    // The warning as a user reads it (`-- --nocapture`).
    eprintln!("{}", named[0]);
    let want = format!(
        "cmd.csv: on 1 of 2 rows the point is reached with the flange turned from the orientation the calibrated model has at the command by more than 1 mrad, at worst {:.2} mrad (line 2)",
        at * 1e3
    );
    assert!(named[0].contains(&want), "{want} not in {stderr}");
    assert!(
        named[0].ends_with(&format!("line 2 turned by {:.2} mrad", at * 1e3)),
        "{stderr}"
    );
    assert!(!stderr.contains("did not converge"), "{stderr}");
}
