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
