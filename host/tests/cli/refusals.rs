//! Bad input as an adversarial user gives it: each is refused with exit status
//! 2, a message naming the file and line or the argument, and every file on
//! disk as it was.

use std::path::Path;

use crate::{refused, succeeds};

/// A simulated UR5e session of `poses` positions in `dir/name`; its lines.
fn session(dir: &Path, name: &str, poses: usize) -> Vec<String> {
    let poses = poses.to_string();
    succeeds(
        dir,
        &[
            "simulate", "--model", "ur5e", "--poses", &poses, "--out", name,
        ],
    );
    std::fs::read_to_string(dir.join(name))
        .unwrap()
        .lines()
        .map(str::to_owned)
        .collect()
}

/// `lines` with `column` of every data row (or of the `row`-th only) set to
/// `value`, written to `dir/name`.
fn edited(dir: &Path, name: &str, lines: &[String], column: &str, row: Option<usize>, value: &str) {
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let c = lines[header].split(',').position(|h| h == column).unwrap();
    let text: Vec<String> = lines
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if i <= header || row.is_some_and(|r| i != header + r) {
                return l.clone();
            }
            let mut f: Vec<&str> = l.split(',').collect();
            f[c] = value;
            f.join(",")
        })
        .collect();
    std::fs::write(dir.join(name), text.join("\n") + "\n").unwrap();
}

/// Item 1: a joint whose limits leave it no motion panicked `simulate` (an
/// empty sampling range); it is refused at the limits' place by every verb.
#[test]
fn limits_that_leave_no_motion_are_refused_where_they_stand() {
    let dir = tempfile::tempdir().unwrap();
    let model = "name = \"one\"\nconvention = \"dh\"\nlength_unit = \"m\"\nangle_unit = \"rad\"\n\n\
                 [[joint]]\ntype = \"revolute\"\ntheta = 0.0\ns = 0.1\na = 0.5\nalpha = 0.0\n\
                 limits = [0.5, 0.5]\n";
    std::fs::write(dir.path().join("m.toml"), model).unwrap();
    std::fs::write(dir.path().join("d.csv"), "q1,x,y,z\n0.5,0.4,0.2,0.1\n").unwrap();
    for verb in [
        &[
            "simulate", "--model", "m.toml", "--poses", "50", "--out", "s.csv",
        ][..],
        &["check", "--model", "m.toml", "--data", "d.csv"],
        &["identify", "--model", "m.toml", "--data", "d.csv"],
        &["diagnose", "--model", "m.toml", "--data", "d.csv"],
    ] {
        refused(dir.path(), verb, &["m.toml:12:10:", "cannot move"]);
    }
}

/// Item 6: one coordinate of 1e30 or 1e300, a constant z column, and data
/// whose joints are not the model's (two columns swapped, so that no geometry
/// fits) are refused with the place; nothing is calibrated from them.
#[test]
fn garbage_data_is_refused_not_calibrated() {
    let dir = tempfile::tempdir().unwrap();
    let lines = session(dir.path(), "good.csv", 40);
    edited(dir.path(), "x30.csv", &lines, "x", Some(5), "1e30");
    edited(dir.path(), "x300.csv", &lines, "x", Some(5), "1e300");
    edited(dir.path(), "flat.csv", &lines, "z", None, "0.5");
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let mut swapped = lines.clone();
    swapped[header] = swapped[header].replacen("q1,q2,", "q2,q1,", 1);
    std::fs::write(dir.path().join("swapped.csv"), swapped.join("\n") + "\n").unwrap();
    let line = (header + 6).to_string();
    for verb in ["identify", "diagnose"] {
        for (file, needles) in [
            (
                "x30.csv",
                vec![
                    format!("x30.csv:{line}:1:"),
                    "1e30".into(),
                    "reaches at most".into(),
                ],
            ),
            (
                "x300.csv",
                vec![format!("x300.csv:{line}:1:"), "1e300".into()],
            ),
            (
                "flat.csv",
                vec!["column 'z' reads 0.5 m on every row".into()],
            ),
            (
                "swapped.csv",
                vec![
                    "swapped.csv: the fitted model still misses".into(),
                    "nothing is written".into(),
                ],
            ),
        ] {
            let needles: Vec<&str> = needles.iter().map(String::as_str).collect();
            refused(
                dir.path(),
                &[
                    verb, "--model", "ur5e", "--data", file, "--out", "c.cal", "--json", "r.json",
                ],
                &needles,
            );
        }
    }
    // The good session is calibrated.
    succeeds(
        dir.path(),
        &[
            "identify", "--model", "ur5e", "--data", "good.csv", "--out", "c.cal",
        ],
    );
}

/// Item 7: every refusal of a bad argument exits 2 and names the argument.
#[test]
fn bad_arguments_exit_two_naming_the_argument() {
    let dir = tempfile::tempdir().unwrap();
    session(dir.path(), "pos.csv", 30);
    let sim = |extra: &[&'static str]| {
        let mut v = vec!["simulate", "--model", "ur5e", "--out", "s.csv"];
        v.extend_from_slice(extra);
        v
    };
    for (args, needle) in [
        (sim(&["--poses", "0"]), "--poses"),
        // More poses than armcal reads back (1 GiB a data file) is refused
        // before anything is drawn.
        (
            sim(&["--poses", "100000000"]),
            "--poses: 100000000: at most 3000000",
        ),
        // A plan holds about 3 KB of each candidate: its memory is bounded
        // by refusing more than 10⁵, before anything is drawn.
        (
            vec![
                "plan",
                "--model",
                "ur5e",
                "--poses",
                "30",
                "--candidates",
                "1000000000",
                "--out",
                "p.csv",
            ],
            "--candidates: 1000000000: at most 100000",
        ),
        (
            vec![
                "plan", "--model", "ur5e", "--poses", "10000000", "--out", "p.csv",
            ],
            "--poses: 10000000: at most 100000",
        ),
        // A value is quoted as short as it was given, not in 300 digits.
        (
            vec![
                "plan", "--model", "ur5e", "--poses", "5", "--margin", "1e300", "--out", "p.csv",
            ],
            "--margin: 1e300: the share",
        ),
        (
            sim(&["--payloads", "1e300"]),
            "--payloads: 1e300: a payload",
        ),
        // Sessions armcal would refuse to read back are not written.
        (
            sim(&["--poses", "5", "--sessions", "10"]),
            "--sessions: 10: 5 poses in blocks of 1 leave 0 to the last session",
        ),
        (
            sim(&["--poses", "17", "--sessions", "4"]),
            "give at least 16 poses",
        ),
        (sim(&["--noise", "nan"]), "--noise"),
        (sim(&["--orientation-noise=-1"]), "--orientation-noise"),
        // A bias of orientations not measured.
        (sim(&["--orientation-bias", "0.002"]), "--orientation-bias"),
        (
            sim(&["--orientation-bias-growth", "0.002"]),
            "--orientation-bias-growth",
        ),
        (
            sim(&["--orientation-noise", "1e-4", "--orientation-bias=-1"]),
            "--orientation-bias",
        ),
        (sim(&["--effect", "foo"]), "--effect"),
        (sim(&["--effect", "backlash:9"]), "--effect"),
        (sim(&["--tilt", "7:0.01"]), "--tilt"),
        (sim(&["--link-errors", "0.0005"]), "--link-errors"),
        (sim(&["--base-errors=-0.002,0.002"]), "--base-errors"),
        (sim(&["--tool-errors", "0.001,nan"]), "--tool-errors"),
        (vec!["sweep", "--effect", "parallel_axis_tilts"], "--effect"),
        (
            vec![
                "identify",
                "--model",
                "ur5e",
                "--data",
                "pos.csv",
                "--position-noise",
                "0",
            ],
            "--position-noise",
        ),
        (
            vec![
                "identify", "--model", "ur5e", "--data", "pos.csv", "--params", "paper",
            ],
            "--params paper needs full poses",
        ),
        (
            vec![
                "diagnose", "--model", "ur5e", "--data", "pos.csv", "--folds", "1",
            ],
            "--folds",
        ),
        (
            vec![
                "identify",
                "--model",
                "ur5e",
                "--data",
                "pos.csv",
                "--orientation-weight",
                "half",
            ],
            "--orientation-weight",
        ),
        (
            vec![
                "stream",
                "--calibration",
                "c.cal",
                "--joints",
                "pos.csv",
                "--tcp",
                "127.0.0.1:99999",
            ],
            "c.cal",
        ),
    ] {
        refused(dir.path(), &args, &[needle]);
    }
    // With a calibration to send, the address itself is refused.
    succeeds(
        dir.path(),
        &[
            "identify", "--model", "ur5e", "--data", "pos.csv", "--out", "c.cal",
        ],
    );
    refused(
        dir.path(),
        &[
            "stream",
            "--calibration",
            "c.cal",
            "--joints",
            "pos.csv",
            "--tcp",
            "127.0.0.1:99999",
        ],
        &["--tcp", "127.0.0.1:99999"],
    );
}

/// Item 8: `--folds` is bounded by the number of poses (a huge count never
/// ended); without it, fewer poses than 10 give one fold per pose.
#[test]
fn folds_are_bounded_by_the_poses() {
    let dir = tempfile::tempdir().unwrap();
    session(dir.path(), "pos.csv", 30);
    for k in ["31", "18446744073709551615"] {
        refused(
            dir.path(),
            &[
                "diagnose", "--model", "ur5e", "--data", "pos.csv", "--folds", k,
            ],
            &["--folds", "number of poses (30"],
        );
    }
    succeeds(
        dir.path(),
        &[
            "diagnose", "--model", "ur5e", "--data", "pos.csv", "--folds", "30",
        ],
    );
}

/// Items 9 and 10: a file with old Mac line ends (lone CR) is refused at the
/// line of its bad value, not all on line 1; `identify` and `diagnose` warn
/// about columns they do not read, as `check` does.
#[test]
fn carriage_return_lines_and_unknown_columns() {
    let dir = tempfile::tempdir().unwrap();
    let lines = session(dir.path(), "pos.csv", 30);
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let mut bad = lines.clone();
    let mut f: Vec<String> = bad[header + 5].split(',').map(str::to_owned).collect();
    f[6] = "abc".into();
    bad[header + 5] = f.join(",");
    std::fs::write(dir.path().join("cr.csv"), bad.join("\r") + "\r").unwrap();
    refused(
        dir.path(),
        &["identify", "--model", "ur5e", "--data", "cr.csv"],
        &[&format!("cr.csv:{}:", header + 6), "\"abc\""],
    );
    let extra: Vec<String> = lines
        .iter()
        .enumerate()
        .map(|(i, l)| match i {
            i if i < header => l.clone(),
            i if i == header => format!("{l},operator"),
            _ => format!("{l},kim"),
        })
        .collect();
    std::fs::write(dir.path().join("extra.csv"), extra.join("\n") + "\n").unwrap();
    for verb in ["identify", "diagnose"] {
        let out = succeeds(
            dir.path(),
            &[verb, "--model", "ur5e", "--data", "extra.csv"],
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("warning") && stderr.contains("'operator'"),
            "{verb}: {stderr}"
        );
    }
}

/// Item 11: context values no working robot has are refused at their cell.
#[test]
fn implausible_temperature_and_payload_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let lines = session(dir.path(), "pos.csv", 30);
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    succeeds(
        dir.path(),
        &[
            "identify", "--model", "ur5e", "--data", "pos.csv", "--out", "c.cal",
        ],
    );
    for (column, value, needle) in [
        ("temp", "1e300", "°C is not the temperature"),
        ("temp", "-273.15", "°C is not the temperature"),
        ("load", "-2", "payload of -2 kg is impossible"),
    ] {
        edited(dir.path(), "ctx.csv", &lines, column, Some(3), value);
        let place = format!("ctx.csv:{}:", header + 4);
        refused(
            dir.path(),
            &[
                "identify", "--model", "ur5e", "--data", "ctx.csv", "--out", "x.cal",
            ],
            &[&place, needle],
        );
        // The joint readings of `predict` and `compensate` are read alike.
        refused(
            dir.path(),
            &[
                "predict",
                "--calibration",
                "c.cal",
                "--joints",
                "ctx.csv",
                "--out",
                "p.csv",
            ],
            &[&place, needle],
        );
    }
}

/// A file saved with semicolons or tabs between its fields is named as such,
/// not as a file of no joints.
#[test]
fn a_file_with_another_delimiter_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    for (name, delimiter, called) in [("semi.csv", ";", "semicolons"), ("tab.csv", "\t", "tabs")] {
        let header = ["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z"].join(delimiter);
        let row = ["0", "0", "0", "0", "0", "0", "1", "1", "1"].join(delimiter);
        std::fs::write(dir.path().join(name), format!("{header}\n{row}\n")).unwrap();
        refused(
            dir.path(),
            &["check", "--model", "ur5e", "--data", name],
            &[
                &format!("{name}:1:1: the header is one field with {called} in it"),
                "save the file with commas",
            ],
        );
    }
}
