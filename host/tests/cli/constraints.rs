//! Sessions without a tracker (a `point` column and distance lines): the
//! refusals, line by line with the column, and the held-out figures of the
//! real MUKCA ball-socket sessions (data/mukca-ball-socket).

use std::path::{Path, PathBuf};

use crate::{refused, succeeds};

/// Six joint values and a point name per row; then `tail` lines.
fn constraint_file(dir: &Path, rows: &[&str], tail: &[&str]) {
    let mut text = String::from("# a ball in two sockets\nq1,q2,q3,q4,q5,q6,point\n");
    for (i, point) in rows.iter().enumerate() {
        let q = 0.1 * (i + 1) as f64;
        text.push_str(&format!("{q},0.2,{q},0.4,0.5,{q},{point}\n"));
    }
    for line in tail {
        text.push_str(line);
        text.push('\n');
    }
    std::fs::write(dir.join("d.csv"), text).unwrap();
}

/// Writes `text` as `d.csv` in `dir` and asserts [`identify_refuses`] it.
fn data_refused(dir: &Path, text: impl AsRef<[u8]>, needles: &[&str]) {
    std::fs::write(dir.join("d.csv"), text).unwrap();
    identify_refuses(dir, needles);
}

fn identify_refuses(dir: &Path, needles: &[&str]) {
    refused(
        dir,
        &["identify", "--model", "ur5e", "--data", "d.csv"],
        needles,
    );
}

#[test]
fn a_point_named_by_one_row_only_is_refused_at_its_cell() {
    let dir = tempfile::tempdir().unwrap();
    let mut rows = vec!["front.0"; 10];
    rows.extend(["front.1"; 9]);
    rows.push("front.2");
    constraint_file(dir.path(), &rows, &["distance,front.0,front.1,0.05"]);
    // Line 22 (two lines before the rows), its point cell after "0.1..,0.2,..,0.4,0.5,..,".
    let line = "2,0.2,2,0.4,0.5,2,";
    identify_refuses(
        dir.path(),
        &[
            &format!("d.csv:22:{}:", line.chars().count() + 1),
            "'front.2' is named by this row only",
        ],
    );
}

#[test]
fn a_distance_to_a_point_no_row_names_is_refused_at_the_name() {
    let dir = tempfile::tempdir().unwrap();
    let mut rows = vec!["front.0"; 10];
    rows.extend(["front.1"; 10]);
    constraint_file(dir.path(), &rows, &["distance,front.0,fornt.1,0.05"]);
    identify_refuses(
        dir.path(),
        &[
            "d.csv:23:18:",
            "no row names the point 'fornt.1'",
            "front.0, front.1",
        ],
    );
}

#[test]
fn a_bad_distance_line_is_refused_at_its_field() {
    let dir = tempfile::tempdir().unwrap();
    let mut rows = vec!["a"; 10];
    rows.extend(["b"; 10]);
    for (line, needles) in [
        (
            "distance,a,b,-0.05",
            vec!["d.csv:23:14:", "not a positive number of m"],
        ),
        (
            "distance,a,b,0.05,0",
            vec!["d.csv:23:19:", "standard uncertainty"],
        ),
        ("distance,a,a,0.05", vec!["d.csv:23:12:", "to itself"]),
        ("distance,a,b", vec!["d.csv:23:13:", "4 or 5 fields"]),
    ] {
        constraint_file(dir.path(), &rows, &[line]);
        identify_refuses(dir.path(), &needles);
    }
}

#[test]
fn coordinates_and_points_mixed_wrongly_are_refused_with_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    // A row with both a point and coordinates: at its x cell.
    data_refused(
        dir.path(),
        "q1,q2,q3,q4,q5,q6,x,y,z,point\n\
         0.1,0.2,0.3,0.4,0.5,0.6,,,,a\n\
         0.1,0.2,0.3,0.4,0.5,0.7,0.4,0.1,0.2,a\n",
        &[
            "d.csv:3:25:",
            "column 'x': a coordinate on a row that names the unknown point 'a'",
        ],
    );
    // A row with neither: at its point cell.
    data_refused(
        dir.path(),
        "q1,q2,q3,q4,q5,q6,x,y,z,point\n0.1,0.2,0.3,0.4,0.5,0.6,0.4,,,\n",
        &["d.csv:2:29:", "column 'y': empty", "name the unknown point"],
    );
    // Measured rows and point rows in one file: at the first row of the other kind.
    let mut text = String::from("q1,q2,q3,q4,q5,q6,x,y,z,point\n");
    for i in 0..12 {
        text.push_str(&format!("0.{i},0.2,0.3,0.4,0.5,0.6,0.4,0.1,0.{i},\n"));
    }
    text.push_str("0.1,0.2,0.3,0.4,0.5,0.6,,,,a\n0.2,0.2,0.3,0.4,0.5,0.6,,,,a\n");
    data_refused(
        dir.path(),
        text,
        &[
            "d.csv:2:25:",
            "column 'x': this row measures x, y, z while line 14 names an unknown point",
            "not both",
        ],
    );
}

/// A file of measured coordinates with a `point` column (an id, as a
/// tracker's export may have) reads exactly as before the extension: every
/// row measures x, y, z, so the column is kept out of the computation.
#[test]
fn a_coordinate_file_with_a_point_id_column_reads_as_before() {
    let dir = tempfile::tempdir().unwrap();
    succeeds(
        dir.path(),
        &[
            "simulate", "--model", "ur5e", "--poses", "30", "--out", "s.csv",
        ],
    );
    let text = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    let mut with_id = String::new();
    let mut header_seen = false;
    for (i, line) in text.lines().enumerate() {
        if line.starts_with('#') {
            with_id.push_str(line);
        } else if !header_seen {
            header_seen = true;
            with_id.push_str(&format!("{line},point"));
        } else {
            with_id.push_str(&format!("{line},P{i}"));
        }
        with_id.push('\n');
    }
    std::fs::write(dir.path().join("p.csv"), with_id).unwrap();
    let run = |data: &str| {
        let json = format!("{data}.json");
        let out = succeeds(
            dir.path(),
            &[
                "identify", "--model", "ur5e", "--data", data, "--json", &json,
            ],
        );
        let report = std::fs::read_to_string(dir.path().join(&json)).unwrap();
        (report, String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (plain, _) = run("s.csv");
    let (with_point, warnings) = run("p.csv");
    assert_eq!(plain, with_point);
    assert!(
        warnings.contains("columns kept out of the computation: 'point'"),
        "{warnings}"
    );
}

/// The MUKCA data and models.
fn mukca() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/mukca-ball-socket")
}

/// The figures of `armcal holdout` per held-out file: the last path component
/// and the six (or four) numbers of its row.
fn holdout(args: &[&str]) -> Vec<(String, Vec<f64>)> {
    let dir = tempfile::tempdir().unwrap();
    let out = succeeds(dir.path(), args);
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.contains(".csv"))
        .map(|l| {
            let mut f = l.split_whitespace();
            let file = f.next().unwrap().rsplit('/').next().unwrap().to_owned();
            (file, f.map_while(|x| x.parse().ok()).collect())
        })
        .collect()
}

fn panda(robot: &str, placements: &[&str]) -> Vec<String> {
    let m = mukca();
    let mut args: Vec<String> = vec![
        "holdout".into(),
        "--model".into(),
        m.join("original/urdf/panda.urdf").display().to_string(),
        "--tip-link".into(),
        "ball_link".into(),
        "--reference".into(),
        m.join(format!(
            "original/calibrated_urdf/{robot}/panda_calibrated.urdf"
        ))
        .display()
        .to_string(),
        "--data".into(),
    ];
    args.extend(
        placements
            .iter()
            .map(|p| m.join(format!("{robot}/{p}.csv")).display().to_string()),
    );
    args
}

/// Leave one plate placement out, calibrate on the others: columns are the
/// nominal URDF's spread and distance error, MUKCA's calibrated URDF's, and
/// armcal's (mm). MUKCA's URDF was fitted to the `front` placement (its
/// config.yaml), so `front` is not held out for it; on `left` and `right`
/// (held out for both) armcal's spread and distance error are smaller for
/// panda_6. For panda_7 (two placements, each calibration from one) they are
/// not: MUKCA's are smaller there, as measured here.
#[test]
fn mukca_panda_sessions_held_out() {
    let args = panda("panda_6", &["front", "left", "right"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let rows = holdout(&args);
    assert_eq!(rows.len(), 3);
    for (file, f) in &rows {
        let (nominal, mukca, armcal) = ((f[0], f[1]), (f[2], f[3]), (f[4], f[5]));
        // Far better than nominal.
        assert!(armcal.0 < nominal.0 / 20.0, "{file}: {f:?}");
        assert!(armcal.1.abs() < nominal.1.abs() / 20.0, "{file}: {f:?}");
        if file != "front.csv" {
            assert!(armcal.0 < mukca.0, "{file}: {f:?}");
            assert!(armcal.1.abs() < mukca.1.abs(), "{file}: {f:?}");
        }
    }
    let args = panda("panda_7", &["front", "right"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    for (file, f) in holdout(&args) {
        assert!(f[4] < f[0] / 5.0, "{file}: {f:?}");
        assert!(
            f[4] > f[2],
            "{file}: armcal now beats MUKCA on panda_7: {f:?}"
        );
    }
}

#[test]
fn a_plane_touched_fewer_than_three_times_is_refused_at_its_first_cell() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("q1,q2,q3,q4,q5,q6,point,plane\n");
    for i in 0..10 {
        text.push_str(&format!("0.{i},0.2,0.3,0.4,0.5,0.6,a,\n"));
        text.push_str(&format!("0.{i},0.3,0.3,0.4,0.5,0.6,b,\n"));
    }
    text.push_str("0.1,0.4,0.3,0.4,0.5,0.6,,table\n0.2,0.4,0.3,0.4,0.5,0.6,,table\n");
    text.push_str("distance,a,b,0.05\n");
    data_refused(
        dir.path(),
        text,
        &[
            "d.csv:22:26:",
            "the plane 'table' is touched by 2 rows only",
            "at least 3",
        ],
    );
    // A row naming a point and a plane: at its plane cell.
    data_refused(
        dir.path(),
        "q1,q2,q3,q4,q5,q6,point,plane\n0.1,0.2,0.3,0.4,0.5,0.6,a,table\n",
        &["d.csv:2:27:", "names the point 'a' and the plane 'table'"],
    );
}

/// `check` shows the nominal model against the constraints; `diagnose` reads
/// the same session as it reads a tracker's: the noise of the ball's contacts
/// estimated, the model chosen by its held-out error (each row's predicted
/// ball centre against the socket its fold's other rows put there), far below
/// the nominal model's, and a calibration written.
#[test]
fn check_shows_the_spread_and_diagnose_reads_a_constraint_session() {
    let m = mukca();
    let model = m.join("original/urdf/iiwa14.urdf").display().to_string();
    let data = m.join("kuka_14/front.csv").display().to_string();
    let dir = tempfile::tempdir().unwrap();
    let chain = [
        "--model",
        &model,
        "--tip-link",
        "ball_link",
        "--data",
        &data,
    ];
    let mut args = vec!["check"];
    args.extend(chain);
    let out = succeeds(dir.path(), &args);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("point front.0      31 rows, spread"),
        "{text}"
    );
    assert!(text.contains("predicted minus stated -0.103 mm"), "{text}");
    let mut args = vec!["diagnose", "--json", "d.json", "--out", "d.cal"];
    args.extend(chain);
    succeeds(dir.path(), &args);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("d.json")).unwrap()).unwrap();
    assert_eq!(report["noise"][0]["channel"], "point contact");
    assert_eq!(report["noise"][0]["source"], "estimated");
    assert_eq!(report["chosen"]["calibration_changes_nothing"], false);
    let held = |key: &str| report["holdout"][key].as_f64().unwrap();
    // The nominal iiwa misplaces the ball by about a millimetre (`check`'s
    // spreads); the calibration leaves about the contacts' noise (0.07 mm
    // per axis, `identify`'s estimate: 0.13 mm in 3-D).
    assert!(held("nominal_rms_mm") > 0.5, "{report}");
    assert!(held("extended_rms_mm") < 0.2, "{report}");
    // A session without a tracker has joints too: the calibration records
    // the range each of the seven swept.
    let bytes = std::fs::read(dir.path().join("d.cal")).unwrap();
    let cal = armcal_shared::Calibration::decode(&bytes).unwrap();
    let ranges = cal.ranges.expect("diagnose records the ranges");
    assert_eq!(ranges.joints.len(), 7);
    assert!(ranges.joints.iter().all(|r| r.min < r.max), "{ranges:?}");
}

/// The calibration of a session without a tracker, exported as a URDF (the
/// Panda's own, its joint origins calibrated, the ball's calibrated centre
/// the link `armcal_measured_point`), predicts a held-out session as the
/// calibration itself does: `check` on the exported URDF gives `holdout`'s
/// spread and distance error.
#[test]
fn the_exported_urdf_predicts_as_the_calibration() {
    let m = mukca();
    let panda = m.join("original/urdf/panda.urdf").display().to_string();
    let train = m.join("panda_6/front.csv").display().to_string();
    let held = m.join("panda_6/left.csv").display().to_string();
    let dir = tempfile::tempdir().unwrap();
    let chain = ["--tip-link", "ball_link"];
    let mut args = vec![
        "identify", "--model", &panda, "--data", &train, "--out", "p6.cal",
    ];
    args.extend(chain);
    succeeds(dir.path(), &args);
    let mut args = vec![
        "export",
        "--calibration",
        "p6.cal",
        "--model",
        &panda,
        "--format",
        "urdf",
        "--out",
        "p6.urdf",
    ];
    args.extend(chain);
    succeeds(dir.path(), &args);
    let out = succeeds(
        dir.path(),
        &[
            "check",
            "--model",
            "p6.urdf",
            "--tip-link",
            "armcal_measured_point",
            "--data",
            &held,
        ],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let spreads: Vec<f64> = text
        .lines()
        .filter(|l| l.contains("spread (RMS"))
        .map(|l| l.split_whitespace().rev().nth(1).unwrap().parse().unwrap())
        .collect();
    let spread = (spreads.iter().map(|s| s * s).sum::<f64>() / spreads.len() as f64).sqrt();
    let mut args = vec![
        "holdout", "--model", &panda, "--train", &train, "--data", &held,
    ];
    args.extend(chain);
    let rows = holdout(&args);
    let armcal = (rows[0].1[2], rows[0].1[3]);
    assert!((spread - armcal.0).abs() < 2e-3, "{spread} {armcal:?}");
    assert!(
        text.contains(&format!("predicted minus stated {:+.3} mm", armcal.1)),
        "{text}"
    );
}

/// `holdout` of `robot`'s `placements` with the MUKCA reference and `flags`
/// (how the training placements are calibrated): each held-out file's figures.
fn panda_held_out(robot: &str, placements: &[&str], flags: &[&str]) -> Vec<(String, Vec<f64>)> {
    let mut args = panda(robot, placements);
    args.extend(flags.iter().map(|f| f.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    holdout(&args)
}

/// On panda_6's `left` and `right` (held out for MUKCA too), armcal's spread
/// and distance error are smaller than MUKCA's (columns 4, 5 against 2, 3);
/// panda_7's `right` row.
fn panda_6_beats_mukca_and_panda_7_right(flags: &[&str]) -> Vec<f64> {
    for (file, f) in panda_held_out("panda_6", &["front", "left", "right"], flags)
        .into_iter()
        .filter(|(f, _)| f != "front.csv")
    {
        assert!(
            f[4] < f[2] && f[5].abs() < f[3].abs(),
            "{flags:?} {file}: {f:?}"
        );
    }
    let rows = panda_held_out("panda_7", &["front", "right"], flags);
    let (_, f) = rows.into_iter().find(|(f, _)| f == "right.csv").unwrap();
    f
}

/// With the prior's scale chosen by cross-validation on the training
/// placements (the default, as `identify` and `diagnose` choose it), as measured: on
/// panda_6's `left` and `right` (held out for MUKCA too) armcal's spread and
/// distance error are smaller than MUKCA's; on panda_7's `right`, its distance
/// error is smaller and its spread slightly larger (0.328 against 0.326 mm).
#[test]
fn mukca_panda_sessions_held_out_with_the_prior_chosen_by_cross_validation() {
    let f = panda_6_beats_mukca_and_panda_7_right(&[]);
    assert!(f[5].abs() < f[3].abs(), "{f:?}");
    assert!(f[4] > f[2] && f[4] < f[2] + 0.01, "{f:?}");
}

/// Calibrated on the training placements as `armcal diagnose` chooses
/// (`holdout --diagnose`: blunders, the geometric model and its prior, the
/// effects the rows name), as measured: on panda_6's `left` and `right` (held
/// out for MUKCA too) armcal's spread and distance error are smaller than
/// MUKCA's; on panda_7's `right`, predicted from `front` alone, its spread is
/// far below the nominal model's and its distance error below MUKCA's.
#[test]
fn mukca_panda_sessions_held_out_as_diagnose_chooses() {
    let f = panda_6_beats_mukca_and_panda_7_right(&["--diagnose"]);
    assert!(f[4] < f[0] / 10.0, "{f:?}");
    assert!(f[5].abs() < f[3].abs(), "{f:?}");
}

/// The report names the noise of each kind of row: a ball seated in sockets
/// (`point`) estimated from those rows' residuals, the socket distance at the
/// uncertainty its line states. A stated `--point-noise` weighs the contacts;
/// `--position-noise` states it too when no kind has its own (as before the
/// contacts had channels of their own).
#[test]
fn identify_reports_the_noise_of_each_kind_of_row() {
    let dir = tempfile::tempdir().unwrap();
    let m = mukca();
    let model = m.join("original/urdf/panda.urdf");
    let data = m.join("panda_6/front.csv");
    let noise = |extra: &[&str]| -> Vec<serde_json::Value> {
        let mut args = vec![
            "identify",
            "--model",
            model.to_str().unwrap(),
            "--tip-link",
            "ball_link",
            "--data",
            data.to_str().unwrap(),
            "--json",
            "r.json",
        ];
        args.extend(extra);
        succeeds(dir.path(), &args);
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("r.json")).unwrap()).unwrap();
        report["noise"].as_array().unwrap().clone()
    };
    let field = |c: &serde_json::Value, key: &str| c[key].as_f64().unwrap();
    let estimated = noise(&[]);
    let channels: Vec<&str> = estimated
        .iter()
        .map(|c| c["channel"].as_str().unwrap())
        .collect();
    assert_eq!(channels, ["point contact", "distance"]);
    let point = &estimated[0];
    assert_eq!(point["source"], "estimated");
    // Settled variance components: the noise used is the one the residuals show.
    let (used, shown) = (field(point, "used"), field(point, "shown_by_residuals"));
    assert!((shown / used - 1.0).abs() < 2e-3, "{used} {shown}");
    assert_eq!(estimated[1]["source"], "stated");
    assert_eq!(field(&estimated[1], "used"), 5e-5);

    let stated = noise(&["--point-noise", "0.0002"]);
    assert_eq!(stated[0]["source"], "stated");
    assert_eq!(field(&stated[0], "used"), 2e-4);
    // Weighed at a larger noise than they show, the contacts count for less
    // against the prior on the D-H errors and the stated distance: the fit
    // gives them more residual (least squares regularised harder leaves a
    // residual no smaller), so they show more than the estimate.
    let shown_stated = field(&stated[0], "shown_by_residuals");
    assert!(shown_stated > used, "{shown_stated} {used}");
    assert_eq!(noise(&["--position-noise", "0.0002"]), stated);
}

/// Unknown points alone fix no length: a larger arm reaching larger points
/// fits the rows as well. A session without a known distance is read, and
/// says that only the prior holds the arm's scale; with the distance, it
/// says nothing of the kind. `check` shows a touched plane's flatness.
#[test]
fn a_session_without_a_known_distance_says_what_holds_the_scale() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut rows = vec!["front.0"; 10];
    rows.extend(["front.1"; 10]);
    let check = ["check", "--model", "ur5e", "--data", "d.csv"];
    constraint_file(d, &rows, &[]);
    // `check` lists what was read, its warnings among it.
    let out = succeeds(d, &check);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("warning: no known distance")
            && stdout.contains("only the prior on the lengths holds it"),
        "{stdout}"
    );
    // These rows' nominal tool points are 0.635 m apart: a distance near it.
    constraint_file(d, &rows, &["distance,front.0,front.1,0.6"]);
    let out = succeeds(d, &check);
    assert!(!String::from_utf8_lossy(&out.stdout).contains("no known distance"));
    // `identify` warns on a real session without its distance line.
    let m = mukca();
    let front = std::fs::read_to_string(m.join("panda_6/front.csv")).unwrap();
    let without: String = front
        .lines()
        .filter(|l| !l.starts_with("distance"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(without.len() < front.len());
    std::fs::write(d.join("front.csv"), without).unwrap();
    let panda = m.join("original/urdf/panda.urdf").display().to_string();
    let identify = [
        "identify",
        "--model",
        &panda,
        "--tip-link",
        "ball_link",
        "--data",
        "front.csv",
    ];
    let out = succeeds(d, &identify);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("no known distance"), "{stderr}");

    // Four touches of a plane give four equations, not twelve.
    let mut text = String::from("q1,q2,q3,q4,q5,q6,plane\n");
    for i in 0..4 {
        let q = 0.1 * (i + 1) as f64;
        text.push_str(&format!("{q},0.2,{q},0.4,0.5,{q},table\n"));
    }
    std::fs::write(d.join("d.csv"), text).unwrap();
    refused(
        d,
        &check,
        &[
            "d.csv:5:1: fewer equations than unknowns: 4 rows and 0 distances give 4 (3 per row at a point, 1 per touch of a plane",
        ],
    );
    let mut text = String::from("q1,q2,q3,q4,q5,q6,plane\n");
    for i in 0..30 {
        let q = 0.03 * (i + 1) as f64;
        text.push_str(&format!("{q},0.2,{q},0.4,0.5,{q},table\n"));
    }
    std::fs::write(d.join("d.csv"), text).unwrap();
    let out = succeeds(d, &check);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains(
            "plane table        30 touches, flatness (RMS distance to their least-squares plane)"
        ),
        "{stdout}"
    );
}

/// `holdout` refuses a session given twice: the same path (also as another
/// spelling of it), or a copy with the same rows, among `--data` and
/// `--train` together, naming both; nothing is computed.
#[test]
fn holdout_refuses_the_same_session_twice() {
    let dir = tempfile::tempdir().unwrap();
    let m = mukca();
    let front = m.join("panda_6/front.csv");
    std::fs::copy(&front, dir.path().join("copy.csv")).unwrap();
    let front = front.display().to_string();
    let left = m.join("panda_6/left.csv").display().to_string();
    let other_spelling = m.join("panda_6/../panda_6/front.csv").display().to_string();
    let model = m.join("original/urdf/panda.urdf").display().to_string();
    let run = |data: &[&str], train: &[&str], needles: &[&str]| {
        let mut args = vec![
            "holdout",
            "--model",
            &model,
            "--tip-link",
            "ball_link",
            "--data",
        ];
        args.extend(data);
        if !train.is_empty() {
            args.push("--train");
            args.extend(train);
        }
        refused(dir.path(), &args, needles);
    };
    run(
        &[&front, &front],
        &[],
        &["the same session as", "(the same file)", "front.csv"],
    );
    run(
        &[&front, &left, &other_spelling],
        &[],
        &["(the same file)", "give each session once"],
    );
    run(
        &[&front, "copy.csv"],
        &[],
        &["copy.csv: the same session as", "front.csv (the same rows"],
    );
    run(&[&left], &[&front, "copy.csv"], &["the same rows"]);
    run(&[&left], &[&left], &["(the same file)"]);
}

/// A stated distance that the nominal model contradicts by far more than a
/// geometric error could is refused at its cell with the unit that fits:
/// MUKCA's 50 mm socket spacing (the nominal URDF puts the sockets 56.9 mm
/// apart: its error is 6.9 mm) written as `50` in a session in m, or as
/// `1.9685` (inches), or `5` (no unit fits: a typo). A distance off by a
/// factor within 2 is a calibration's business, not a refusal.
#[test]
fn a_distance_in_another_unit_than_the_model_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = mukca();
    let front = std::fs::read_to_string(m.join("panda_6/front.csv")).unwrap();
    let line = front
        .lines()
        .position(|l| l.starts_with("distance,front.0,front.1,0.05,"))
        .unwrap()
        + 1;
    let panda = m.join("original/urdf/panda.urdf").display().to_string();
    let check = [
        "check",
        "--model",
        &panda,
        "--tip-link",
        "ball_link",
        "--data",
        "front.csv",
    ];
    let place = format!("front.csv:{line}:26: distance: ");
    for (length, needles) in [
        (
            "50",
            vec![
                "50 m stated between 'front.0' and 'front.1'",
                "is the distance in mm?",
            ],
        ),
        (
            "1.9685",
            vec!["1.9685 m stated", "is the distance in inches?"],
        ),
        ("5", vec!["5 m stated", "a typo"]),
    ] {
        let text = front.replace(
            "distance,front.0,front.1,0.05,",
            &format!("distance,front.0,front.1,{length},"),
        );
        std::fs::write(dir.path().join("front.csv"), text).unwrap();
        let mut needles = needles.clone();
        needles.push(&place);
        needles.push("the nominal model puts them 0.0569 m apart");
        refused(dir.path(), &check, &needles);
        for verb in ["identify", "holdout"] {
            let mut args = check.to_vec();
            args[0] = verb;
            refused(dir.path(), &args, &[&place]);
        }
    }
    let text = front.replace(
        "distance,front.0,front.1,0.05,",
        "distance,front.0,front.1,0.1,",
    );
    std::fs::write(dir.path().join("front.csv"), text).unwrap();
    succeeds(dir.path(), &check);
}

/// Like for like with MUKCA's URDF, which was fitted to `front` alone: armcal
/// trained on `front` alone too (`--train`), judged on the other placements,
/// as measured (the README's comparison): at the stated prior (1 mm / 1 mrad,
/// `--prior-scale stated`) armcal's spread is larger than MUKCA's on every
/// held-out placement (panda_7 `right` 0.561 against 0.326 mm: the prior
/// holds joint 5's offset, which the data put at 23 mrad); with the scale
/// `identify` chooses by default (×10) it is smaller on panda_6 `left` and
/// `right` and within 0.01 mm on panda_7 `right`.
#[test]
fn mukca_like_for_like_trained_on_front_alone() {
    let m = mukca();
    let run = |robot: &str, held: &[&str], flags: &[&str]| {
        let mut args = panda(robot, held);
        let data = args.iter().position(|a| a == "--data").unwrap();
        args.insert(
            data,
            m.join(format!("{robot}/front.csv")).display().to_string(),
        );
        args.insert(data, "--train".into());
        args.extend(flags.iter().map(|f| f.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let rows = holdout(&args);
        for (file, f) in &rows {
            eprintln!("{robot} {file} {flags:?}: {f:?}");
        }
        rows
    };
    for (robot, held) in [
        ("panda_6", &["left", "right"][..]),
        ("panda_7", &["right"][..]),
    ] {
        for (file, f) in run(robot, held, &["--prior-scale", "stated"]) {
            assert!(f[4] > f[2], "{robot} {file}, stated prior: {f:?}");
        }
        for (file, f) in run(robot, held, &[]) {
            if robot == "panda_6" {
                assert!(f[4] < f[2], "{robot} {file}, chosen prior: {f:?}");
            } else {
                assert!(
                    (f[4] - f[2]).abs() < 0.01,
                    "{robot} {file}, chosen prior: {f:?}"
                );
            }
        }
    }
}
