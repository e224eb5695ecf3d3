//! Tests of the measured-poses and joint-readings readers: refusals at their
//! line and column, the constraint extension, and the streaming reader.

use super::schema::QUAT;
use super::*;
use crate::io::builtin::DATA;
use crate::io::model_file::{load_model, parse_model};
use nalgebra::Point3;
use proptest::prelude::*;

fn ur5e() -> RobotModel {
    load_model("ur5e").unwrap()
}

const HEADER6: &str = "q1,q2,q3,q4,q5,q6,x,y,z";
const ROW6: &str = "0.1,0.2,0.3,0.4,0.5,0.6,1.0,2.0,3.0";

/// Asserts that `text` is refused at exactly `line`:`column` of "data.csv"
/// against `model`, with a message containing every one of `needles`.
#[track_caller]
fn refused(model: &RobotModel, text: &str, line: usize, column: usize, needles: &[&str]) {
    let e = match parse_measurements(text, "data.csv", model) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e,
    };
    assert_refused_at(&e, "data.csv", line, column, needles);
}

/// Asserts that `e` names `file` at exactly `line`:`column`, prints as
/// `file:line:column: …`, and has a message containing every one of `needles`.
#[track_caller]
fn assert_refused_at(e: &InputError, file: &str, line: usize, column: usize, needles: &[&str]) {
    assert_eq!(e.file, file);
    assert_eq!((e.line, e.column), (line, column), "{e}");
    assert!(
        e.to_string()
            .starts_with(&format!("{file}:{line}:{column}: ")),
        "{e}"
    );
    for needle in needles {
        assert!(e.message.contains(needle), "{e:?} does not name {needle:?}");
    }
}

/// Old Mac line ends (a lone CR) are line ends: a bad value on line 4 is
/// refused at line 4, not at line 1 with a long column.
#[test]
fn lone_carriage_returns_end_lines() {
    let text = format!("# comment\r{HEADER6}\r{ROW6}\r0.1,0.2,0.3,0.4,0.5,0.6,1.0,abc,3.0\r");
    refused(&ur5e(), &text, 4, 29, &["column 'y'", "\"abc\""]);
    let m = parse_measurements(&text.replace("abc", "2.0"), "data.csv", &ur5e()).unwrap();
    assert_eq!(m.lines, [3, 4]);
}

/// A temperature no working robot has (absolute zero, a value in K) and a
/// negative or absurd payload are refused at their cell.
#[test]
fn implausible_conditions_are_refused() {
    let h = format!("{HEADER6},temp,load");
    for (cells, column, needle) in [
        ("-273.15,1", 37, "°C is not the temperature"),
        ("1e300,1", 37, "°C is not the temperature"),
        ("293.15,1", 37, "in K or °F"),
        ("20,-0.5", 40, "payload of -0.5 kg is impossible"),
        ("20,1e9", 40, "kg is impossible"),
    ] {
        refused(
            &ur5e(),
            &format!("{h}\n{ROW6},{cells}\n"),
            2,
            column,
            &[needle],
        );
    }
    parse_measurements(
        &format!("{h}\n{ROW6},-20,0\n{ROW6},80,3.5\n"),
        "data.csv",
        &ur5e(),
    )
    .unwrap();
}

/// Garbage is refused with its line: one coordinate of 1e30 (or 1e300), a
/// data file in mm against a model in m, a constant z column. A real set
/// passes.
#[test]
fn implausible_positions_are_refused() {
    let model = load_model("puma560").unwrap();
    let robot = &model.robot;
    // An upper bound of the distance from the base, and not a loose one.
    let r = reach(robot, std::iter::empty());
    assert!(r < 2.0, "PUMA reach {r} m");
    let mut text = String::from("q1,q2,q3,q4,q5,q6,x,y,z\n");
    for i in 0..20 {
        let q = 0.1 * i as f64;
        let p = robot
            .forward(&[q, -q, q, 0.5, q, 0.0])
            .unwrap()
            .translation
            .vector;
        assert!(p.norm() <= r);
        text.push_str(&format!(
            "{q},{},{q},0.5,{q},0,{},{},{}\n",
            -q, p.x, p.y, p.z
        ));
    }
    let good = parse_measurements(&text, "data.csv", &model).unwrap();
    good.require_plausible(&model).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let with_line = |n: usize, f: &dyn Fn(&str) -> String| {
        let mut l = lines.clone();
        let changed = f(l[n - 1]);
        l[n - 1] = &changed;
        parse_measurements(&(l.join("\n") + "\n"), "data.csv", &model).unwrap()
    };
    for big in ["1e30", "1e300"] {
        let m = with_line(7, &|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            f[6] = big;
            f.join(",")
        });
        let e = m.require_plausible(&model).unwrap_err();
        assert_eq!((e.line, e.column), (7, 1), "{e}");
        assert!(e.message.contains("reaches at most"), "{e}");
    }
    let mm: String = lines
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                return format!("{l}\n");
            }
            let f: Vec<String> = l
                .split(',')
                .enumerate()
                .map(|(c, v)| {
                    if c >= 6 {
                        format!("{}", v.parse::<f64>().unwrap() * 1000.0)
                    } else {
                        v.to_owned()
                    }
                })
                .collect();
            f.join(",") + "\n"
        })
        .collect();
    let m = parse_measurements(&mm, "data.csv", &model).unwrap();
    assert!(
        m.require_plausible(&model)
            .unwrap_err()
            .message
            .contains("length units")
    );
    let flat: String = lines
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                return format!("{l}\n");
            }
            let mut f: Vec<&str> = l.split(',').collect();
            f[8] = "0.25";
            f.join(",") + "\n"
        })
        .collect();
    let e = parse_measurements(&flat, "data.csv", &model)
        .unwrap()
        .require_plausible(&model)
        .unwrap_err();
    assert_eq!(e.line, 2);
    assert!(
        e.message.contains("column 'z' reads 0.25 in on every row"),
        "{e}"
    );
    for d in DATA {
        let model = load_model(d.name).unwrap();
        let m = load_measurements(d.name, &model).unwrap();
        m.require_plausible(&model)
            .unwrap_or_else(|e| panic!("{e}"));
    }
}

/// Every built-in data set parses against its built-in model, with the pose
/// counts that its README gives and the lines of its file.
#[test]
fn every_builtin_data_set_parses_against_its_model() {
    for d in DATA {
        let model = load_model(d.name).unwrap();
        let m = load_measurements(d.name, &model).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.file, d.file);
        let expected = match d.name {
            "figaroh-ur10e-camera" => 23,
            "figaroh-tiago-mocap" => 34,
            "figaroh-talos-left-arm" => 61,
            other => panic!("no expected count for {other}"),
        };
        assert_eq!(m.len(), expected, "{}", d.name);
        assert!(m.columns_ignored.is_empty(), "{:?}", m.columns_ignored);
        assert!(m.poses.iter().all(|p| p.q.len() == model.dof()));
        assert_eq!(m.has_orientation(), d.name == "figaroh-ur10e-camera");
        // Lines are those of the file: after the comment lines and the header.
        let first_data_line = d.text.lines().position(|l| !l.starts_with('#')).unwrap() + 2;
        assert_eq!(m.lines[0], first_data_line);
        assert_eq!(*m.lines.last().unwrap(), first_data_line + expected - 1);
    }
}

/// The UR10e set: orientation unit quaternions, columns in use; TALOS has `t`;
/// TIAGo row 3 reads the torso lift 0.18 mm above its 0.35 m limit (line 8).
#[test]
// The literals are the digits of the file, which round to the same f64.
#[allow(clippy::excessive_precision)]
fn builtin_sets_details() {
    let ur = load_model("figaroh-ur10e-camera").unwrap();
    let m = load_measurements("figaroh-ur10e-camera", &ur).unwrap();
    assert_eq!(
        m.columns_used,
        [
            "q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "qw", "qx", "qy", "qz"
        ]
    );
    assert_eq!(m.equations(), 23 * 6);
    let p = &m.poses[0];
    assert_eq!(p.q[0], 1.589200496673584);
    assert_eq!(
        p.position,
        Point3::new(0.90882845233650233, 0.34156959335807885, 1.2526995668918641)
    );
    let q = p.orientation.unwrap();
    assert!((q.w - 0.16704657887989197).abs() < 1e-9);

    let talos = load_model("figaroh-talos-left-arm").unwrap();
    let m = load_measurements("figaroh-talos-left-arm", &talos).unwrap();
    assert!(m.times.iter().all(Option::is_some));
    assert_eq!(m.times[0], Some(42.399117469787598));

    let tiago = load_model("figaroh-tiago-mocap").unwrap();
    let m = load_measurements("figaroh-tiago-mocap", &tiago).unwrap();
    assert!(
        m.warnings
            .iter()
            .any(|w| w.starts_with("data/figaroh-tiago-mocap/measurements.csv:8: q1 = 0.35018")),
        "{:?}",
        m.warnings
    );
}

/// Readings and positions in mm and degrees become the same SI poses as their
/// twin in m and rad; a prismatic joint's reading uses the length unit.
#[test]
fn units_of_the_model_apply_to_the_data() {
    let model = |length: &str, angle: &str| {
        parse_model(
            &format!(
                "name = \"rp\"\nconvention = \"dh\"\nlength_unit = \"{length}\"\nangle_unit = \"{angle}\"\n\
                 [[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 0\na = 0\nalpha = 0\n\
                 [[joint]]\ntype = \"prismatic\"\ntheta = 0\ns = 0\na = 0\nalpha = 0\n"
            ),
            "rp.toml",
        )
        .unwrap()
    };
    let si = parse_measurements(
        "q1,q2,x,y,z\n1.5707963267948966,0.25,1.5,-0.002,0.0125\n",
        "si.csv",
        &model("m", "rad"),
    )
    .unwrap();
    let mm = parse_measurements(
        "q2,z,x,y,q1\n250,12.5,1500,-2,90\n",
        "mm.csv",
        &model("mm", "deg"),
    )
    .unwrap();
    let (a, b) = (&si.poses[0], &mm.poses[0]);
    assert!((a.q[0] - b.q[0]).abs() <= 4.0 * f64::EPSILON);
    assert_eq!(a.q[1], b.q[1]);
    assert_eq!(b.q[1], 0.25);
    assert_eq!(a.position, b.position);
    assert_eq!(mm.columns_used, ["q2", "z", "x", "y", "q1"]);
}

/// A `\r` that no `\n` follows ends a record (the `csv` crate's rule) and
/// a line: old Mac files read with each row on its own line, and a refusal
/// names that line. (Found by the `measurements_csv` fuzz target: rows
/// split at a lone `\r` shared one line number.)
#[test]
fn lone_carriage_returns_end_records_and_lines() {
    let model = ur5e();
    let text = format!("{HEADER6}\r{ROW6}\r{ROW6}\n{ROW6}\r\n");
    let m = parse_measurements(&text, "data.csv", &model).unwrap();
    let lines = m.lines.clone();
    assert_eq!(lines, [2, 3, 4]);
    let rows = parse_joints(&text, "data.csv", &model.robot, &model.units).unwrap();
    let lines: Vec<usize> = rows.rows.iter().map(|r| r.line).collect();
    assert_eq!(lines, [2, 3, 4]);
    refused(
        &model,
        &format!("{HEADER6}\r{ROW6}\r0,0,0,0,0,0,1,abc,3\r"),
        3,
        15,
        &["'y'", "abc"],
    );
}

/// Comments, blank lines, CRLF, quoted fields, optional columns, ignored
/// columns (named in a warning), and a near-unit quaternion that is normalised.
#[test]
fn reads_the_optional_and_the_ignored() {
    let text = "# a comment\r\n\r\nid,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz,t,temp,load,comment\r\n\
                # between\r\n\
                7,0,0,0,0,0,0,1,2,3,1.0005,0,0,0,0.5,21.5,2.0,\"a, b\"\r\n\
                \r\n\
                8,0,0,0,0,0,0,1,2,3,,,,,,,,\r\n";
    let m = parse_measurements(text, "data.csv", &ur5e()).unwrap();
    assert_eq!(m.len(), 2);
    assert_eq!(m.lines, [5, 7]);
    assert_eq!(m.columns_ignored, ["id", "comment"]);
    assert!(
        m.warnings[0].contains("'id', 'comment'"),
        "{:?}",
        m.warnings
    );
    let p = &m.poses[0];
    assert!((p.orientation.unwrap().into_inner().norm() - 1.0).abs() < 1e-15);
    let conditions = |i: usize| {
        let c = &m.poses[i].context;
        (m.times[i], c.temperature, c.payload)
    };
    assert_eq!(conditions(0), (Some(0.5), Some(21.5), Some(2.0)));
    assert_eq!(conditions(1), (None, None, None));
    assert!(m.poses[1].orientation.is_none());
    assert_eq!(m.equations(), 9);
    assert!(!m.has_orientation());
}

#[test]
fn refuses_missing_required_columns_on_the_header_line() {
    let model = ur5e();
    refused(
        &model,
        "# c\nq1,q2,q3,q4,q5,q6,x,z\n0,0,0,0,0,0,1,3\n",
        2,
        1,
        &["missing required column 'y'"],
    );
    refused(
        &model,
        "q1,q2,q3,q4,q5,q6,X,y,z\n",
        1,
        1,
        &["'x'", "found 'X'"],
    );
}

#[test]
fn refuses_joint_count_mismatch() {
    let model = ur5e();
    refused(
        &model,
        &format!("{HEADER6},q7\n{ROW6},0.7\n"),
        1,
        25,
        &["column 'q7'", "the model has 6 joints, the data has 7"],
    );
    refused(
        &model,
        "q1,q2,q3,q4,q5,x,y,z\n0,0,0,0,0,1,2,3\n",
        1,
        1,
        &[
            "missing column 'q6'",
            "the model has 6 joints, the data has 5",
        ],
    );
    refused(&model, &format!("q0,{HEADER6}\n"), 1, 1, &["column 'q0'"]);
}

#[test]
fn refuses_duplicate_column_names_at_the_second() {
    refused(
        &ur5e(),
        &format!("{HEADER6}, x\n{ROW6},1\n"),
        1,
        26,
        &["column 'x'", "duplicate"],
    );
}

#[test]
fn refuses_rows_with_the_wrong_number_of_fields() {
    let model = ur5e();
    // One too many: the column of the extra field.
    refused(
        &model,
        &format!("{HEADER6}\n{ROW6},9\n"),
        2,
        37,
        &["10 fields, the header has 9"],
    );
    // One too few: the end of the line.
    refused(
        &model,
        &format!("{HEADER6}\n{ROW6}\n0,0,0,0,0,0,1,2\n"),
        3,
        16,
        &["8 fields, the header has 9"],
    );
    // An indented comment is a row.
    refused(
        &model,
        &format!("{HEADER6}\n  # note\n"),
        2,
        9,
        &["1 field,", "first column"],
    );
}

#[test]
fn refuses_values_that_are_not_finite_numbers() {
    let model = ur5e();
    for bad in ["abc", "nan", "inf", "-inf", "1e999", "0x10", "1_0"] {
        let row = format!("0.1,0.2,0.3,0.4,0.5,0.6,1.0,2.0,{bad}");
        let needle = format!("column 'z': \"{bad}\" is not a finite number");
        refused(
            &model,
            &format!("{HEADER6}\n{ROW6}\n{row}\n"),
            3,
            33,
            &[&needle],
        );
    }
    // A decimal comma splits the field: the extra field is refused.
    let row = "0.1,0.2,0.3,0.4,0.5,0.6,1.0,2.0,1,5";
    refused(
        &model,
        &format!("{HEADER6}\n{row}\n"),
        2,
        35,
        &["10 fields, the header has 9"],
    );
    // Empty cell of a required column; column counts characters (é is one),
    // and commas inside quotes do not split fields.
    refused(
        &model,
        &format!("note,{HEADER6}\n\"é, ü\",0.1,0.2,0.3,0.4,0.5,0.6,,2,3\n"),
        2,
        32,
        &["column 'x': empty"],
    );
    refused(
        &model,
        &format!("{HEADER6}\n0.1, 0.2,0.3,0.4,0.5,0.6, abc ,2,3\n"),
        2,
        27,
        &["column 'x'", "\"abc\""],
    );
    // A value in a joint column.
    refused(
        &model,
        &format!("{HEADER6}\n0.1,0.2,three,0.4,0.5,0.6,1,2,3\n"),
        2,
        9,
        &["column 'q3'"],
    );
    // Optional columns too, when not empty.
    refused(
        &model,
        &format!("{HEADER6},temp\n{ROW6},warm\n"),
        2,
        37,
        &["column 'temp'", "\"warm\""],
    );
}

#[test]
fn refuses_partial_quaternions() {
    let model = ur5e();
    refused(
        &model,
        &format!("{HEADER6},qx,qw,qz\n"),
        1,
        25,
        &[
            "column 'qx'",
            "partial quaternion",
            "qw, qx, qz given, qy missing",
        ],
    );
    refused(
        &model,
        &format!("{HEADER6},qw,qx,qy,qz\n{ROW6},1,0,,0\n"),
        2,
        41,
        &["column 'qy'", "partial quaternion"],
    );
}

#[test]
fn refuses_quaternions_far_from_unit_norm() {
    refused(
        &ur5e(),
        &format!("{HEADER6},qx,qy,qz,qw\n{ROW6},0,0,0,0.998\n"),
        2,
        43,
        &["column 'qw'", "norm 0.998000", "not 1 within 0.001"],
    );
    // Within the tolerance: accepted.
    parse_measurements(
        &format!("{HEADER6},qx,qy,qz,qw\n{ROW6},0,0,0,0.9991\n"),
        "ok.csv",
        &ur5e(),
    )
    .unwrap();
}

#[test]
fn refuses_files_without_data() {
    let model = ur5e();
    refused(
        &model,
        &format!("# only a header\n\n{HEADER6}\n# and a comment\n"),
        3,
        1,
        &["no data rows"],
    );
    refused(&model, "", 1, 1, &["no header line"]);
    refused(&model, "# comments\n# only\n", 1, 1, &["no header line"]);
}

#[test]
fn require_poses_refuses_fewer_equations_than_unknowns() {
    let row = |k: f64| format!("0.1,0.2,0.3,0.4,0.5,{k},1.0,2.0,3.0");
    let text = format!(
        "{HEADER6}\n{}\n{}\n# end\n{}\n",
        row(0.6),
        row(0.7),
        row(0.8)
    );
    let robot = ur5e().robot;
    let m = parse_measurements(&text, "data.csv", &ur5e()).unwrap();
    assert!(m.require_poses(&robot, 9).is_ok());
    let e = m.require_poses(&robot, 27).unwrap_err();
    assert_eq!(
        (e.file.as_str(), e.line, e.column),
        ("data.csv", 5, 1),
        "{e}"
    );
    for needle in [
        "3 poses give 9 equations",
        "27 unknowns",
        "at least 9 poses are needed",
    ] {
        assert!(e.message.contains(needle), "{e}");
    }
    // With orientation, 6 equations per pose.
    let text = format!("{HEADER6},qw,qx,qy,qz\n{ROW6},1,0,0,0\n");
    let m = parse_measurements(&text, "data.csv", &ur5e()).unwrap();
    let e = m.require_poses(&robot, 30).unwrap_err();
    assert!(
        e.message.contains("1 pose gives 6 equations (6 per pose)"),
        "{e}"
    );
    assert!(e.message.contains("at least 5 poses"), "{e}");
    // One configuration read three times: 3 equations, not 9.
    let text = format!("{HEADER6}\n{ROW6}\n{ROW6}\n# end\n{ROW6}\n");
    let m = parse_measurements(&text, "data.csv", &ur5e()).unwrap();
    assert!(m.require_poses(&robot, 3).is_ok());
    let e = m.require_poses(&robot, 9).unwrap_err();
    assert_eq!(e.line, 5, "{e}");
    assert!(
        e.message.contains("3 rows in 1 distinct configuration")
            && e.message.contains("give 3 equations"),
        "{e}"
    );
}

#[test]
fn load_measurements_refuses_a_missing_file_naming_it() {
    let e = load_measurements("/nonexistent/data.csv", &ur5e()).unwrap_err();
    assert_eq!((e.file.as_str(), e.line), ("/nonexistent/data.csv", 0));
    assert!(e.message.contains("figaroh-ur10e-camera"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.csv");
    std::fs::write(&path, format!("{HEADER6}\n{ROW6}\n")).unwrap();
    let p = path.to_str().unwrap();
    assert_eq!(load_measurements(p, &ur5e()).unwrap().file, p);
}

/// Asserts that `text` is refused as joint readings at exactly
/// `line`:`column` of "joints.csv" against `model`, naming every `needles`.
#[track_caller]
fn joints_refused(model: &RobotModel, text: &str, line: usize, column: usize, needles: &[&str]) {
    let e = match parse_joints(text, "joints.csv", &model.robot, &model.units) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e,
    };
    assert_refused_at(&e, "joints.csv", line, column, needles);
}

/// Every built-in measurement file reads as joint readings too: the same
/// readings, times, temperatures and loads on the same lines, the pose columns
/// listed as ignored and named in a warning.
#[test]
fn measurement_files_read_as_joints() {
    for d in DATA {
        let model = load_model(d.name).unwrap();
        let m = load_measurements(d.name, &model).unwrap();
        let j = parse_joints(d.text, d.file, &model.robot, &model.units)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(j.file, d.file);
        assert_eq!(j.len(), m.len());
        for (i, (r, p)) in j.rows.iter().zip(&m.poses).enumerate() {
            assert_eq!((r.line, &r.q), (m.lines[i], &p.q));
            let c = &p.context;
            assert_eq!(
                (r.t, r.temp, r.load),
                (m.times[i], c.temperature, c.payload)
            );
        }
        let pose_columns: Vec<&String> = m
            .columns_used
            .iter()
            .filter(|c| POSITION.contains(&c.as_str()) || QUAT.contains(&c.as_str()))
            .collect();
        assert!(pose_columns.len() >= 3);
        assert_eq!(j.columns_ignored.iter().collect::<Vec<_>>(), pose_columns);
        assert!(
            j.warnings
                .iter()
                .any(|w| w.contains("kept out of the computation: 'x', 'y', 'z'")
                    && w.contains(&format!("(used: q1..q{}, t, temp, load)", model.dof()))),
            "{:?}",
            j.warnings
        );
        // The limit warnings are the measurement reader's.
        let limits = |w: &[String]| -> Vec<String> {
            w.iter().filter(|w| w.contains("limits")).cloned().collect()
        };
        assert_eq!(limits(&j.warnings), limits(&m.warnings));
    }
}

/// Only the joints are required; readings follow the units (deg, and mm for a
/// prismatic joint); `t`, `temp`, `load` are kept; pose columns are not read,
/// not even checked (a partial quaternion or a text in `x` is fine); other
/// columns are ignored and named.
#[test]
fn joints_need_only_the_joints() {
    let model = parse_model(
        "name = \"rp\"\nconvention = \"dh\"\nlength_unit = \"mm\"\nangle_unit = \"deg\"\n\
         [[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 0\na = 0\nalpha = 0\n\
         [[joint]]\ntype = \"prismatic\"\ntheta = 0\ns = 0\na = 0\nalpha = 0\n",
        "rp.toml",
    )
    .unwrap();
    let j = parse_joints(
        "\u{feff}# c\nid,q2,q1,load,x,qw,t,temp\n1,250,90,2.5,abc,,0.5,\n\n2,0,-45,,1,1,,21\n",
        "j.csv",
        &model.robot,
        &model.units,
    )
    .unwrap();
    assert_eq!(j.columns_used, ["q2", "q1", "load", "t", "temp"]);
    assert_eq!(j.columns_ignored, ["id", "x", "qw"]);
    assert_eq!(j.len(), 2);
    let (a, b) = (&j.rows[0], &j.rows[1]);
    assert_eq!((a.line, b.line), (3, 5));
    assert!((a.q[0] - core::f64::consts::FRAC_PI_2).abs() <= 4.0 * f64::EPSILON);
    assert_eq!(a.q[1], 0.25);
    assert_eq!((a.t, a.temp, a.load), (Some(0.5), None, Some(2.5)));
    assert_eq!((b.t, b.temp, b.load), (None, Some(21.0), None));
    assert!(
        j.warnings[0].contains("'id', 'x', 'qw'"),
        "{:?}",
        j.warnings
    );
}

/// The measurement reader's refusals, from the same code, with the place.
#[test]
fn joints_refusals_name_file_line_column() {
    let model = ur5e();
    const JOINTS6: &str = "q1,q2,q3,q4,q5,q6";
    joints_refused(
        &model,
        &format!("{JOINTS6}\n0.1,0.2,three,0.4,0.5,0.6\n"),
        2,
        9,
        &["column 'q3'", "\"three\" is not a finite number"],
    );
    joints_refused(
        &model,
        &format!("{JOINTS6},temp\n0,0,0,0,0,0,1\n0,0,0,0,0,0,inf\n"),
        3,
        13,
        &["column 'temp'", "\"inf\" is not a finite number"],
    );
    joints_refused(
        &model,
        &format!("{JOINTS6},q7\n0,0,0,0,0,0,0\n"),
        1,
        19,
        &["column 'q7'", "the model has 6 joints, the data has 7"],
    );
    joints_refused(
        &model,
        "q1,q2,q3,q4,q5,x,y,z\n0,0,0,0,0,1,2,3\n",
        1,
        1,
        &["missing column 'q6'", "joint-count mismatch"],
    );
    joints_refused(
        &model,
        &format!("{JOINTS6}\n0,0,0,0,0\n"),
        2,
        10,
        &["5 fields, the header has 6"],
    );
    joints_refused(
        &model,
        &format!("{JOINTS6},x,x\n"),
        1,
        21,
        &["column 'x'", "duplicate"],
    );
    joints_refused(
        &model,
        &format!("{JOINTS6}\n# nothing\n"),
        1,
        1,
        &["no data rows", "row of joint readings"],
    );
    joints_refused(&model, "", 1, 1, &["no header line", "expected q1..q6,"]);
}

#[test]
fn load_joints_reads_a_file_and_refuses_a_missing_one() {
    let model = ur5e();
    let e = load_joints("/nonexistent/j.csv", &model.robot, &model.units).unwrap_err();
    assert_eq!((e.file.as_str(), e.line), ("/nonexistent/j.csv", 0));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("j.csv");
    std::fs::write(&path, "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n").unwrap();
    let p = path.to_str().unwrap();
    let j = load_joints(p, &model.robot, &model.units).unwrap();
    assert_eq!((j.file.as_str(), j.len()), (p, 1));
}

/// Characters that matter to CSV and to this format, to mutate files with.
const CSV_ALPHABET: &str = ",,,\"\"#\n\r .-+e0123456789qwxyzntaif\u{e9}\u{1f600}";

/// A reader that gives at most `piece` bytes a read.
struct Trickle<'a> {
    bytes: &'a [u8],
    piece: usize,
}

impl std::io::Read for Trickle<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.piece.min(buf.len()).min(self.bytes.len());
        buf[..n].copy_from_slice(&self.bytes[..n]);
        self.bytes = &self.bytes[n..];
        Ok(n)
    }
}

/// A quoted cell may span lines: the cells after it are on a later line
/// than their record's first, and a refusal at one of them names that
/// line and the column within it (fuzzing found the column counted from
/// the record's start, beyond the end of its first line). Each named
/// cell: a point named once, a plane touched twice, a distance to a point
/// no row names, a coordinate on a constraint row.
#[test]
fn a_named_cell_after_a_quoted_line_break_is_placed_on_its_own_line() {
    let model = ur5e();
    let header = "q1,q2,q3,q4,q5,q6,note,x,y,z,point,plane\n";
    let row = |note: &str, point: &str, plane: &str| {
        format!("0.1,0.2,0.3,0.4,0.5,0.6,{note},,,,{point},{plane}\n")
    };
    let split = "\"two\nlines\"";
    // The point cell of line 4's record is on line 5, after `lines",,,,`.
    let at = "lines\",,,,".chars().count() + 1;
    let mut text = format!("{header}{}{}", row("a", "s.0", ""), row("b", "s.0", ""));
    text.push_str(&row(split, "s.1", ""));
    refused(&model, &text, 5, at, &["'s.1' is named by this row only"]);

    let mut text = format!("{header}{}{}", row("a", "s.0", ""), row("b", "s.0", ""));
    text.push_str(&row(split, "", "table"));
    text.push_str(&row("c", "", "table"));
    refused(
        &model,
        &text,
        5,
        at + 1,
        &["plane 'table' is touched by 2 rows"],
    );

    // A point named across a line break (rows on lines 2–3 and 4–5), and a
    // distance from it (lines 6–7) to a point no row names, on line 7.
    let named = "\"s\n.0\"";
    let mut text = format!("{header}{}{}", row("a", named, ""), row("b", named, ""));
    text.push_str(&format!("distance,{named},s.1,0.05\n"));
    refused(
        &model,
        &text,
        7,
        ".0\",".chars().count() + 1,
        &["no row names the point 's.1'"],
    );

    let mut text = format!("{header}{}{}", row("a", "s.0", ""), row("b", "s.0", ""));
    text.push_str("0.1,0.2,0.3,0.4,0.5,0.6,\"x\ny\",1,2,3,,\n");
    refused(
        &model,
        &text,
        5,
        "y\",".chars().count() + 1,
        &["column 'x': this row measures x, y, z"],
    );
}

/// A file far longer than the reader keeps (it lets go of what lies
/// before the record being read): a refusal on its last line is placed
/// as in the whole text, and every pose keeps its line.
#[test]
fn a_long_file_keeps_its_places() {
    let model = ur5e();
    let rows = 40_000;
    let mut text = format!("# a long session\r\n{HEADER6}\r\n");
    for i in 0..rows {
        text.push_str(&format!("{ROW6}\r\n"));
        if i % 1000 == 0 {
            text.push_str("# a comment\r");
        }
    }
    let m = parse_measurements(&text, "data.csv", &model).unwrap();
    assert_eq!(m.len(), rows);
    let expected = crate::session::input_error::line_col(&text, text.len()).0 - 1;
    assert_eq!(*m.lines.last().unwrap(), expected);
    text.push_str("0.1,0.2,0.3,0.4,0.5,0.6,1.0,€x,3.0\r\n");
    let (line, column) = crate::session::input_error::line_col(&text, text.rfind('€').unwrap());
    refused(&model, &text, line, column, &["column 'y'"]);
    assert!(text.len() > 16 << 16, "sixteen times what the reader keeps");
}

/// Two threads read a file (the records split on one, the rows read on
/// the other, in batches): the refusal is the first in file order whichever
/// thread meets it, a bad joint reading (converted by the reader) or
/// coordinate (by the parser), or a byte that is not UTF-8 (the reader's own
/// stop), thousands of rows in.
#[test]
fn the_first_refusal_in_the_file_is_the_one_given() {
    let model = ur5e();
    let bad_joint = "0.1,0.2,q,0.4,0.5,0.6,1.0,2.0,3.0";
    let bad_y = "0.1,0.2,0.3,0.4,0.5,0.6,1.0,y,3.0";
    let file = |lines: &[(usize, &str)]| {
        let mut text = format!("{HEADER6}\n").into_bytes();
        for i in 2..6000 {
            let line = lines.iter().find(|(at, _)| *at == i).map_or(ROW6, |l| l.1);
            text.extend_from_slice(line.as_bytes());
            text.push(b'\n');
        }
        text
    };
    let read = |bytes: Vec<u8>| {
        let source = Source::new(&bytes[..], DATA_FILE);
        read_measurements(source, "data.csv", &model).unwrap_err()
    };
    let not_utf8 = "0.1,0.2,0.3,0.4,0.5,0.6,1.0,2.0,\u{1}";
    let with_byte = |mut text: Vec<u8>| {
        // The control character made a byte that is never UTF-8.
        let at = text.iter().position(|&b| b == 1).unwrap();
        text[at] = 0xFF;
        text
    };
    let e = read(file(&[(3000, bad_joint), (4000, bad_y)]));
    assert_refused_at(&e, "data.csv", 3000, 9, &["column 'q3'", "\"q\""]);
    let e = read(file(&[(3000, bad_y), (4000, bad_joint)]));
    assert_refused_at(&e, "data.csv", 3000, 29, &["column 'y'"]);
    let e = read(with_byte(file(&[(3000, bad_y), (4000, not_utf8)])));
    assert_refused_at(&e, "data.csv", 3000, 29, &["column 'y'"]);
    let e = read(with_byte(file(&[(3000, not_utf8), (4000, bad_joint)])));
    assert_refused_at(&e, "data.csv", 3000, 33, &["not UTF-8"]);
}

proptest! {
    /// Random bytes never make the measurement parser panic.
    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = parse_measurements(&text, "fuzz.csv", &ur5e());
    }

    /// Random bytes never make the joint-readings parser panic.
    #[test]
    fn random_bytes_never_panic_as_joints(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let text = String::from_utf8_lossy(&bytes);
        let model = ur5e();
        let _ = parse_joints(&text, "fuzz.csv", &model.robot, &model.units);
    }

    /// Read in pieces of 1 to 7 bytes (as a pipe delivers a file: a CR and
    /// its LF, the bytes of one character, a line split between reads),
    /// a file gives what it gives read whole: the same poses, or the same
    /// refusal at the same place. Edited built-in data sets with CRs,
    /// multi-byte characters and bytes that are not UTF-8 among the edits.
    #[test]
    fn a_file_read_in_pieces_reads_as_a_whole(
        which in 0..DATA.len(),
        edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<usize>()), 0..12),
        invalid in prop::option::of(any::<prop::sample::Index>()),
        piece in 1usize..8,
    ) {
        let d = &DATA[which];
        let model = load_model(d.name).unwrap();
        let text = crate::test_support::mutate(d.text, &edits, CSV_ALPHABET);
        let mut bytes = text.into_bytes();
        if let Some(at) = invalid {
            let at = at.index(bytes.len() + 1);
            bytes.insert(at, 0xff);
        }
        let whole = read_measurements(Source::new(&bytes[..], DATA_FILE), "data.csv", &model);
        let pieces = read_measurements(
            Source::new(Trickle { bytes: &bytes, piece }, DATA_FILE),
            "data.csv",
            &model,
        );
        prop_assert_eq!(whole, pieces);
    }

    /// Random edits of the built-in data sets never make the parser panic, and a
    /// refusal always has a place in the text.
    #[test]
    fn mutated_data_never_panic(
        which in 0..DATA.len(),
        edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<usize>()), 1..12),
    ) {
        let d = &DATA[which];
        let model = load_model(d.name).unwrap();
        let text = crate::test_support::mutate(d.text, &edits, CSV_ALPHABET);
        match parse_measurements(&text, "fuzz.csv", &model) {
            Err(e) => {
                let lines = crate::session::input_error::line_col(&text, text.len()).0;
                prop_assert!(e.line >= 1 && e.line <= lines, "{e}");
                prop_assert!(e.column >= 1, "{e}");
            }
            Ok(m) => {
                let _ = m.require_poses(&model.robot, usize::MAX);
            }
        }
    }
}

/// Several files are several sessions of one robot: their rows in order,
/// each marked with its session and its own file's line, `file_of` naming
/// the file a row came from. A session of contacts with one of measured
/// coordinates is refused at the first file of the other kind.
#[test]
fn sessions_read_as_one_calibration_and_mixed_kinds_are_refused() {
    let model = ur5e();
    let coordinates = |file: &str, rows: usize| {
        let text = format!("{HEADER6}\n{}", format!("{ROW6}\n").repeat(rows));
        parse_measurements(&text, file, &model).unwrap()
    };
    let data =
        Measurements::sessions(vec![coordinates("a.csv", 2), coordinates("b.csv", 3)]).unwrap();
    assert_eq!(data.session_count(), 2);
    assert_eq!(data.sessions, ["a.csv", "b.csv"]);
    let sessions: Vec<usize> = data.poses.iter().map(|p| p.session).collect();
    assert_eq!(sessions, [0, 0, 1, 1, 1]);
    assert_eq!(data.lines, [2, 3, 2, 3, 4]);
    assert_eq!(data.file_of(1), "a.csv");
    assert_eq!(data.file_of(4), "b.csv");
    let one = Measurements::sessions(vec![coordinates("a.csv", 2)]).unwrap();
    assert_eq!((one.session_count(), one.file.as_str()), (1, "a.csv"));

    let mut text = String::from("q1,q2,q3,q4,q5,q6,point\n");
    for k in 0..12 {
        text.push_str(&format!("0.{k},0.2,0.3,0.4,0.5,0.6,s{}\n", k % 2));
    }
    let contacts = parse_measurements(&text, "c.csv", &model).unwrap();
    let e = Measurements::sessions(vec![coordinates("a.csv", 2), contacts]).unwrap_err();
    assert_refused_at(&e, "c.csv", 2, 1, &["a session of contacts"]);
}
