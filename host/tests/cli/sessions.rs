//! Several sessions in one calibration, as a user runs them: `simulate
//! --sessions` writes one file a session (the tracker moved and the SMR
//! remounted between them), `check`, `identify` and `diagnose` read them
//! together with `--data A.csv B.csv …`, and each session's figure is
//! reported; the file written holds the first session's registration, and
//! `armcal predict` with it gives the first session's figure.

use crate::{refused, rms_distance, succeeds};

#[test]
fn sessions_are_calibrated_together_and_the_file_holds_the_first() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    succeeds(
        d,
        &[
            "simulate",
            "--model",
            "ur5e",
            "--poses",
            "240",
            "--sessions",
            "3",
            "--out",
            "s.csv",
            "--truth",
            "t.json",
        ],
    );
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("t.json")).unwrap()).unwrap();
    assert_eq!(truth["sessions"].as_array().unwrap().len(), 3);
    let files = ["s-1.csv", "s-2.csv", "s-3.csv"];
    let mut args = vec!["check", "--model", "ur5e", "--data"];
    args.extend(files);
    let check = String::from_utf8_lossy(&succeeds(d, &args).stdout).into_owned();
    assert!(
        check.contains("3 sessions: s-1.csv, s-2.csv, s-3.csv"),
        "{check}"
    );
    assert!(check.contains("session 3 s-3.csv: rms"), "{check}");

    let mut args = vec!["identify", "--model", "ur5e", "--out", "c.cal"];
    args.extend(["--json", "r.json", "--data"]);
    args.extend(files);
    let out = String::from_utf8_lossy(&succeeds(d, &args).stdout).into_owned();
    assert!(
        out.contains("3 sessions, each with its own base frame and tool"),
        "{out}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    let sessions = report["sessions"].as_array().unwrap();
    assert_eq!(sessions.len(), 3);
    assert_eq!(sessions[0]["file"], "s-1.csv");
    assert_eq!(sessions[0]["written"], true);
    // Each session in its own frames fits to the simulated noise (20 µm per
    // axis: 35 µm in 3-D), though the tracker moved by up to a metre.
    // Left out, the others calibrated and its frames registered, a session
    // is predicted to the noise too: the robot is the same in all.
    for s in sessions {
        let rms = s["position_rms_mm"].as_f64().unwrap();
        assert!(rms < 0.05, "{s}");
        let left_out = s["held_out_rms_mm"].as_f64().unwrap();
        assert!(left_out >= rms && left_out < 0.05, "{s}");
        assert_eq!(s["poses"], 80);
    }
    // The figure printed for the first session is what the file delivers.
    succeeds(
        d,
        &[
            "predict",
            "--calibration",
            "c.cal",
            "--joints",
            "s-1.csv",
            "--out",
            "p.csv",
        ],
    );
    let delivered = rms_distance(&d.join("p.csv"), &d.join("s-1.csv"));
    let printed = sessions[0]["position_rms"].as_f64().unwrap();
    assert!(
        (delivered - printed).abs() < 1e-9 + 1e-6 * printed,
        "{delivered} {printed}"
    );

    // Taking the moved tracker's frames as one puts its motion into the
    // robot, which no geometry of this arm can fit: refused, nothing written.
    let mut args = vec![
        "identify",
        "--model",
        "ur5e",
        "--same-base",
        "--out",
        "same.cal",
    ];
    args.push("--data");
    args.extend(files);
    refused(d, &args, &["still misses the measured points"]);

    // A session given twice would count its rows twice: refused, as a copy.
    std::fs::copy(d.join("s-2.csv"), d.join("copy.csv")).unwrap();
    for twice in [["s-2.csv", "s-2.csv"], ["s-2.csv", "copy.csv"]] {
        let mut args = vec!["identify", "--model", "ur5e", "--data", "s-1.csv"];
        args.extend(twice);
        refused(d, &args, &["the same session as", "give each session once"]);
    }
}

#[test]
fn diagnose_reports_each_session() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    succeeds(
        d,
        &[
            "simulate",
            "--model",
            "ur5e",
            "--poses",
            "120",
            "--sessions",
            "2",
            "--out",
            "s.csv",
        ],
    );
    let out = succeeds(
        d,
        &[
            "diagnose", "--model", "ur5e", "--data", "s-1.csv", "s-2.csv", "--json", "d.json",
            "--html", "d.html",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("session 2 s-2.csv: 60 poses"), "{stdout}");
    assert!(
        stdout.contains("`armcal predict` gives the first session's"),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("d.json")).unwrap()).unwrap();
    assert_eq!(report["sessions"].as_array().unwrap().len(), 2);
    let page = std::fs::read_to_string(d.join("d.html")).unwrap();
    assert!(page.contains("<h2>Sessions</h2>"), "{page}");
    assert!(page.contains("<td>2 s-2.csv</td><td>60</td>"), "{page}");
}

/// One configuration seen through three SMRs: a PUMA 560 (±1 mm / ±1 mrad
/// errors) measured at the same 24 configurations with three SMRs on its
/// flange, each a session of its own (`--same-base`: the tracker stays). The
/// diagnosis' held-out figure is then of configurations its folds never
/// trained on (a configuration's three points share a fold), so it is what
/// the calibration delivers on configurations it never saw: within 1.5× of
/// its RMS error on 200 new configurations of the same robot (the new
/// measurements carry their own 20 µm noise, as the held-out rows do).
#[test]
fn three_smrs_at_the_same_configurations_claim_what_they_deliver() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let puma = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/puma560.toml"),
    )
    .unwrap();
    // The SMRs, inches (the PUMA's unit): 60 to 100 mm from the flange.
    for (k, smr) in ["2.4, 0.0, 3.2", "-2.0, 1.6, 3.2", "0.0, -2.4, 4.0"]
        .iter()
        .enumerate()
    {
        let model = format!("smr{k}.toml");
        std::fs::write(d.join(&model), format!("{puma}\n[tool]\nxyz = [{smr}]\n")).unwrap();
        // The same seed: the same true robot and the same configurations;
        // the first 24 rows of the longer session are the short one's.
        for (poses, out) in [("24", format!("s{k}.csv")), ("224", format!("all{k}.csv"))] {
            succeeds(
                d,
                &[
                    "simulate", "--model", &model, "--poses", poses, "--seed", "5", "--out", &out,
                ],
            );
        }
    }
    succeeds(
        d,
        &[
            "diagnose",
            "--model",
            "smr0.toml",
            "--data",
            "s0.csv",
            "s1.csv",
            "s2.csv",
            "--same-base",
            "--out",
            "d.cal",
            "--json",
            "d.json",
            "--quiet",
        ],
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("d.json")).unwrap()).unwrap();
    let claimed = report["holdout"]["extended_rms_mm"].as_f64().unwrap();
    // The 200 configurations after the first 24, seen through the first SMR
    // (the calibration holds the first session's registration).
    let text = std::fs::read_to_string(d.join("all0.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let mut new = lines[..=header].join("\n") + "\n";
    new += &lines[header + 1 + 24..].join("\n");
    std::fs::write(d.join("new.csv"), new + "\n").unwrap();
    succeeds(
        d,
        &[
            "predict",
            "--calibration",
            "d.cal",
            "--joints",
            "new.csv",
            "--out",
            "p.csv",
        ],
    );
    let delivered = rms_distance(&d.join("p.csv"), &d.join("new.csv")) * 25.4;
    eprintln!("three SMRs: claimed {claimed:.4} mm held out, delivered {delivered:.4} mm");
    assert!(
        claimed * 1.5 >= delivered && delivered * 1.5 >= claimed,
        "claimed {claimed} mm, delivered {delivered} mm"
    );
}

/// A session given again reversed, re-rounded to nine significant digits
/// and one row short is the same session, not a second one: refused (its
/// "left out" figure would be in-sample), naming both files. The same
/// configurations measured again (the instrument's noise drawn anew, 30 µm
/// instead of 20 µm: points microns apart) are a session of their own.
#[test]
fn a_session_copied_reordered_or_rounded_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (noise, out) in [("0.00002", "a.csv"), ("0.00003", "again.csv")] {
        succeeds(
            d,
            &[
                "simulate", "--model", "ur10e", "--poses", "50", "--seed", "9", "--noise", noise,
                "--out", out,
            ],
        );
    }
    let text = std::fs::read_to_string(d.join("a.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let mut copy = lines[..=header].join("\n") + "\n";
    for line in lines[header + 2..].iter().rev() {
        let cells: Vec<String> = line
            .split(',')
            .map(|c| format!("{:.8e}", c.parse::<f64>().unwrap()))
            .collect();
        copy += &(cells.join(",") + "\n");
    }
    std::fs::write(d.join("copy.csv"), copy).unwrap();
    refused(
        d,
        &[
            "identify", "--model", "ur10e", "--data", "a.csv", "copy.csv",
        ],
        &[
            "copy.csv",
            "a.csv",
            "49 of its 49 rows repeat a configuration",
        ],
    );
    succeeds(
        d,
        &[
            "identify",
            "--model",
            "ur10e",
            "--data",
            "a.csv",
            "again.csv",
            "--quiet",
        ],
    );
}

/// A simulated CSV as its lines: the comment lines and the header, then the
/// data rows; `line(i)` is the 1-based line of data row `i` in the file.
struct Csv {
    head: Vec<String>,
    rows: Vec<String>,
}

impl Csv {
    fn read(path: &std::path::Path) -> Self {
        let text = std::fs::read_to_string(path).unwrap();
        let lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
        Self {
            head: lines[..=header].to_vec(),
            rows: lines[header + 1..].to_vec(),
        }
    }

    /// The 1-based line of data row `i`.
    fn line(&self, i: usize) -> usize {
        self.head.len() + 1 + i
    }

    /// The index of column `name`.
    fn column(&self, name: &str) -> usize {
        self.head
            .last()
            .unwrap()
            .split(',')
            .position(|c| c.trim() == name)
            .unwrap()
    }

    /// Adds `delta` to column `name` of data row `i`.
    fn add(&mut self, i: usize, name: &str, delta: f64) {
        let c = self.column(name);
        let mut cells: Vec<String> = self.rows[i].split(',').map(str::to_owned).collect();
        cells[c] = format!("{}", cells[c].trim().parse::<f64>().unwrap() + delta);
        self.rows[i] = cells.join(",");
    }

    /// Its first `n` data rows.
    fn first(&self, n: usize) -> Self {
        Self {
            head: self.head.clone(),
            rows: self.rows[..n].to_vec(),
        }
    }

    fn write(&self, path: &std::path::Path) {
        std::fs::write(
            path,
            self.head.join("\n") + "\n" + &self.rows.join("\n") + "\n",
        )
        .unwrap();
    }
}

/// `armcal simulate --model ur5e` with `args` in `d`, which must succeed.
fn simulate(d: &std::path::Path, args: &[&str]) {
    let mut all = vec!["simulate", "--model", "ur5e"];
    all.extend(args);
    succeeds(d, &all);
}

/// Runs `args` in `d`, which must succeed, and returns its standard error.
fn stderr_of(d: &std::path::Path, args: &[&str]) -> String {
    String::from_utf8_lossy(&succeeds(d, args).stderr).into_owned()
}

/// Two good sessions of a UR5e whose tracker frames are 8 m apart (the
/// second session's every point shifted 8 m along x: its base frame
/// registered there) are calibrated, each in its own base frame: a frame
/// far away is a registration, not a unit mistake. Said to share one base
/// frame (`--same-base`), they are refused at the first row of the session
/// far from the median of all the points (the shorter one, so that the
/// median lies among the other's), named by its own file and line, as an
/// instrument moved. A real unit mistake in one row of the second session
/// (a point written in mm in a file in m) is refused at that row of that
/// file, exit 2, nothing written.
#[test]
fn sessions_far_apart_are_judged_each_in_its_own_frame_and_named_by_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, &["--poses", "120", "--sessions", "2", "--out", "s.csv"]);
    let mut far = Csv::read(&d.join("s-2.csv")).first(30);
    for i in 0..far.rows.len() {
        far.add(i, "x", 8.0);
    }
    far.write(&d.join("far.csv"));
    let stderr = stderr_of(
        d,
        &[
            "identify", "--model", "ur5e", "--data", "s-1.csv", "far.csv", "--out", "c.cal",
        ],
    );
    assert!(!stderr.contains("reconcile"), "{stderr}");
    let line = far.line(0);
    refused(
        d,
        &[
            "identify",
            "--model",
            "ur5e",
            "--same-base",
            "--data",
            "s-1.csv",
            "far.csv",
            "--out",
            "same.cal",
        ],
        &[
            &format!("far.csv:{line}:1: the point ("),
            "from the median of every session's points",
            "each session alone is within reach",
            "was the instrument moved between them?",
        ],
    );
    let mut typo = Csv::read(&d.join("far.csv"));
    let x = typo.rows[7]
        .split(',')
        .nth(typo.column("x"))
        .unwrap()
        .trim()
        .parse::<f64>()
        .unwrap();
    typo.add(7, "x", 999.0 * x);
    typo.write(&d.join("typo.csv"));
    let line = typo.line(7);
    for verb in ["identify", "check", "diagnose"] {
        refused(
            d,
            &[verb, "--model", "ur5e", "--data", "s-1.csv", "typo.csv"],
            &[
                &format!("typo.csv:{line}:1: the point ("),
                "a typo, or the data and the model in different length units?",
            ],
        );
    }
}

/// A short session beside a 50-pose one. Two rows (6 equations) cannot
/// determine its own base frame and tool point (9 unknowns): refused up
/// front at its last line, naming the file and what it would need, exit 2,
/// nothing written; sharing the tool (`--same-tool`, 6 unknowns) it still
/// has no equation for the robot. Four rows (12 equations) determine them:
/// the calibration is made, and the 50-pose session's figure left out (the
/// robot from the short one's 12 equations alone: fewer than its
/// parameters) is not computed, with a note, while the short session's own
/// figure is.
#[test]
fn a_session_too_short_for_its_own_frames_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, &["--poses", "100", "--sessions", "2", "--out", "s.csv"]);
    let second = Csv::read(&d.join("s-2.csv"));
    second.first(2).write(&d.join("two.csv"));
    second.first(4).write(&d.join("four.csv"));
    let last = second.line(1);
    refused(
        d,
        &[
            "identify", "--model", "ur5e", "--data", "s-1.csv", "two.csv", "--out", "c.cal",
        ],
        &[&format!(
            "two.csv:{last}:1: session two.csv: 2 rows in 2 distinct configurations give 6 \
             equations (3 per pose), no more than the 9 unknowns of its own frames (its base \
             frame's 6 and its tool point's 3): its rows would fit its frames alone and add \
             nothing to the robot; measure at least 4 distinct poses in it, or share frames"
        )],
    );
    refused(
        d,
        &[
            "identify",
            "--model",
            "ur5e",
            "--same-tool",
            "--data",
            "s-1.csv",
            "two.csv",
        ],
        &[
            &format!("two.csv:{last}:1: session two.csv"),
            "no more than the 6 unknowns of its own frames (its base frame's 6)",
            "measure at least 3 distinct poses in it",
        ],
    );
    let out = succeeds(
        d,
        &[
            "identify", "--model", "ur5e", "--data", "s-1.csv", "four.csv", "--json", "r.json",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("left out: not computed, the others alone cannot calibrate the robot"),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    let sessions = report["sessions"].as_array().unwrap();
    let why = sessions[0]["held_out_not_computed"].as_str().unwrap();
    assert!(why.contains("12 equations"), "{why}");
    assert!(sessions[0]["held_out_rms_mm"].is_null());
    assert!(sessions[1]["held_out_not_computed"].is_null());
    assert!(sessions[1]["held_out_rms_mm"].as_f64().unwrap() > 0.0);
}

/// A session of another robot (another seed: other D-H errors, of the
/// order of a millimetre) beside two sessions of one UR5e (20 µm noise): it
/// is named, with its figure left out and the others' noise (F far above
/// the 1 − 1 %/3 quantile), the two sessions of the same robot reconciled;
/// the calibration is written (exit 0), since it may still be good for the
/// other sessions. The same three files with the tools taken as one
/// (`--same-tool`, while the simulator remounted the point by up to 3 mm
/// before each later session) name the remounted tool as the likely cause.
#[test]
fn a_session_that_does_not_reconcile_is_named_with_its_figures() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, &["--poses", "120", "--sessions", "2", "--out", "r.csv"]);
    simulate(d, &["--poses", "60", "--seed", "2", "--out", "other.csv"]);
    let files = ["r-1.csv", "r-2.csv", "other.csv"];
    let mut args = vec![
        "identify", "--model", "ur5e", "--out", "c.cal", "--json", "r.json",
    ];
    args.push("--data");
    args.extend(files);
    let stderr = stderr_of(d, &args);
    assert!(d.join("c.cal").exists());
    assert_eq!(stderr.matches("does not reconcile").count(), 1, "{stderr}");
    assert!(
        stderr.contains(
            "session other.csv: left out, its rows miss the robot the other sessions calibrate by"
        ),
        "{stderr}"
    );
    assert!(
        stderr.contains("the 1 − 1 %/3 quantile of F(171, "),
        "{stderr}"
    );
    assert!(
        stderr.contains("another robot, or the robot changed"),
        "{stderr}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    let sessions = report["sessions"].as_array().unwrap();
    for s in &sessions[..2] {
        assert_eq!(s["reconciled"], true, "{s}");
    }
    let other = &sessions[2];
    assert_eq!(other["reconciled"], false, "{other}");
    let r = &other["reconciliation"];
    // The others fit to their noise, 20 µm per axis (35 µm in 3-D), and
    // the other robot misses by its own millimetre-sized errors.
    let others = r["others_rms_mm"].as_f64().unwrap();
    assert!(others < 0.05, "{r}");
    assert!(
        other["held_out_rms_mm"].as_f64().unwrap() > 10.0 * others,
        "{other}"
    );
    assert!(
        r["f"].as_f64().unwrap() > 100.0 * r["threshold"].as_f64().unwrap(),
        "{r}"
    );
    let warnings = report["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().starts_with("session other.csv:")),
        "{warnings:?}"
    );

    let mut args = vec!["identify", "--model", "ur5e", "--same-tool", "--data"];
    args.extend(&files[..2]);
    let stderr = stderr_of(d, &args);
    assert!(
        stderr.contains("does not reconcile with them: a different tool than --same-tool says?"),
        "{stderr}"
    );
    // In its own frames, the same robot's two sessions reconcile.
    let mut args = vec!["identify", "--model", "ur5e", "--data"];
    args.extend(&files[..2]);
    assert!(!stderr_of(d, &args).contains("reconcile"));
}

/// One reading of 200 (20 µm noise) moved 5 mm: `identify` names its file
/// and line as the row its fit explains worst, failing the deleted-residual
/// test, in the warnings, the summary and the JSON, and says that
/// `diagnose` sets such rows aside; on the same rows without the blunder it
/// names none. Beside another session, the row is named by its own file.
#[test]
fn identify_names_the_row_it_explains_worst() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, &["--poses", "200", "--out", "s.csv"]);
    let clean = stderr_of(
        d,
        &[
            "identify",
            "--model",
            "ur5e",
            "--data",
            "s.csv",
            "--json",
            "clean.json",
        ],
    );
    assert!(!clean.contains("explains this row worst"), "{clean}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("clean.json")).unwrap()).unwrap();
    assert_eq!(report["suspect_rows"].as_array().unwrap().len(), 0);
    let mut bad = Csv::read(&d.join("s.csv"));
    bad.add(57, "x", 0.005);
    bad.write(&d.join("bad.csv"));
    let line = bad.line(57);
    let out = succeeds(
        d,
        &[
            "identify", "--model", "ur5e", "--data", "bad.csv", "--json", "bad.json",
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stderr.contains(&format!("bad.csv:{line}: the fit explains this row worst")),
        "{stderr}"
    );
    assert!(
        stderr.contains("`armcal diagnose` sets such rows aside"),
        "{stderr}"
    );
    assert!(
        stdout.contains(&format!(
            "failing the deleted-residual test (1 of 200 rows at α = 1 %): bad.csv:{line} ("
        )),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("bad.json")).unwrap()).unwrap();
    let rows = report["suspect_rows"].as_array().unwrap();
    assert_eq!(rows.len(), 1, "{rows:?}");
    assert_eq!(rows[0]["file"], "bad.csv");
    assert_eq!(rows[0]["line"], line);
    // The fit absorbs a part of the blunder: its residual is below 5 mm,
    // and far above the noise.
    let mm = rows[0]["residual_mm"].as_f64().unwrap();
    assert!(mm > 2.5 && mm < 5.5, "{mm}");

    simulate(d, &["--poses", "60", "--seed", "3", "--out", "first.csv"]);
    let stderr = stderr_of(
        d,
        &[
            "identify",
            "--model",
            "ur5e",
            "--data",
            "first.csv",
            "bad.csv",
        ],
    );
    assert!(
        stderr.contains(&format!("bad.csv:{line}: the fit explains this row worst")),
        "{stderr}"
    );
}

/// One absurd joint reading (q2 = 1000 rad on row 6 of 60, a UR5e without
/// joint limits in its model): `check` names the line of the largest
/// error; `identify`'s refusal names the same file and line, and the joint
/// outside what the other rows read, exit 2, nothing written; given as the
/// second of two sessions, the same row of its own file.
#[test]
fn an_absurd_joint_reading_is_refused_at_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, &["--poses", "60", "--out", "s.csv"]);
    let mut absurd = Csv::read(&d.join("s.csv"));
    let q2 = absurd.rows[5]
        .split(',')
        .nth(absurd.column("q2"))
        .unwrap()
        .trim()
        .parse::<f64>()
        .unwrap();
    absurd.add(5, "q2", 1000.0 - q2);
    absurd.write(&d.join("absurd.csv"));
    let line = absurd.line(5);
    let check = String::from_utf8_lossy(
        &succeeds(d, &["check", "--model", "ur5e", "--data", "absurd.csv"]).stdout,
    )
    .into_owned();
    assert!(check.contains(&format!("(line {line})")), "{check}");
    refused(
        d,
        &[
            "identify",
            "--model",
            "ur5e",
            "--data",
            "absurd.csv",
            "--out",
            "c.cal",
            "--json",
            "r.json",
        ],
        &[
            &format!("absurd.csv:{line}:1: the fitted model still misses the measured points"),
            "this row holds 100 % of the nominal model's sum of squares",
            "its q2 = 1000 rad lies outside what the other rows read",
            "nothing is written",
        ],
    );
    simulate(d, &["--poses", "60", "--seed", "4", "--out", "first.csv"]);
    refused(
        d,
        &[
            "identify",
            "--model",
            "ur5e",
            "--data",
            "first.csv",
            "absurd.csv",
            "--out",
            "c.cal",
        ],
        &[&format!(
            "absurd.csv:{line}:1: the fitted model still misses"
        )],
    );
}

/// With two sessions each has its own base and tool frames: a parameter held
/// as not separable names each frame parameter it cannot be told from with
/// its session (`session 1 tool.y`, `session 2 tool.x`), never a bare
/// `tool.y` that could be either.
#[test]
fn what_a_parameter_cannot_be_told_from_names_each_frame_s_session() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    succeeds(
        dir,
        &[
            "simulate",
            "--model",
            "ur10e",
            "--poses",
            "60",
            "--sessions",
            "2",
            "--out",
            "s.csv",
        ],
    );
    let out = succeeds(
        dir,
        &[
            "identify", "--model", "ur10e", "--data", "s-1.csv", "s-2.csv",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lists: Vec<&str> = stdout
        .lines()
        .filter_map(|l| l.split("not separable from ").nth(1))
        .map(|rest| rest.split([':', '[']).next().unwrap())
        .collect();
    let frames: Vec<&str> = lists
        .iter()
        .flat_map(|l| l.split(", "))
        .map(str::trim)
        .filter(|n| n.contains("base.") || n.contains("tool."))
        .collect();
    assert!(frames.len() >= 2, "{stdout}");
    assert!(
        frames.iter().all(|n| n.starts_with("session ")),
        "{frames:?}"
    );
}
