//! A working tool in place of the measured one (`--tool`, `--tool-link`), on
//! MUKCA's real Panda (`panda_6`): a ball in sockets measured, a hand's TCP
//! compensated.
//!
//! The ball's mount is the measured tool's own: where it sits on the flange
//! (its identified offset, millimetres from the URDF's ball) says nothing of
//! the arm. So the hand's commands must not depend on it: calibrating with
//! the ball's nominal place moved by 11 mm (`--tip-point`), which moves only
//! the identified tool, leaves the hand's commands as they were, to the
//! fit's rounding (1e-9 rad), while the ball's own commands change by the
//! 11 mm the nominal ball moved.

use std::path::{Path, PathBuf};

use crate::{refused, succeeds};

fn mukca() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/mukca-ball-socket")
}

fn urdf() -> String {
    mukca()
        .join("original/urdf/panda.urdf")
        .display()
        .to_string()
}

/// The joint rows of a commands CSV (comment lines, a header, numbers).
fn commands(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('q'))
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

/// The largest difference of two sets of commands, rad.
fn largest_difference(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(u, v)| (u - v).abs()))
        .fold(0.0, f64::max)
}

/// Identifies panda_6's `front` placement with the ball's nominal place
/// moved by `tip_point` (m, in ball_link), writing `cal`.
fn identify(dir: &Path, tip_point: &str, cal: &str) {
    let data = mukca().join("panda_6/front.csv").display().to_string();
    let u = urdf();
    succeeds(
        dir,
        &[
            "identify",
            "--model",
            &u,
            "--tip-link",
            "ball_link",
            "--tip-point",
            tip_point,
            "--data",
            &data,
            "--out",
            cal,
        ],
    );
}

/// Compensates the `left` placement's joint readings with `cal` and the
/// `tool` flags, writing `out`; returns the note printed.
fn compensate(dir: &Path, cal: &str, tool: &[&str], out: &str) -> String {
    let joints = mukca().join("panda_6/left.csv").display().to_string();
    let mut args = vec![
        "compensate",
        "--calibration",
        cal,
        "--joints",
        &joints,
        "--out",
        out,
    ];
    args.extend(tool);
    let o = succeeds(dir, &args);
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn mukca_panda_6_hand_commands_hold_nothing_of_the_ball_mount() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    identify(d, "0,0,0", "urdf-ball.cal");
    identify(d, "0.008,-0.006,0.004", "moved-ball.cal");
    let u = urdf();
    let hand = ["--tool-link", "panda_hand_tcp", "--model", u.as_str()];
    let note = compensate(d, "urdf-ball.cal", &hand, "hand-a.csv");
    compensate(d, "moved-ball.cal", &hand, "hand-b.csv");
    compensate(d, "urdf-ball.cal", &[], "ball-a.csv");
    compensate(d, "moved-ball.cal", &[], "ball-b.csv");
    let hand_change = largest_difference(
        &commands(&d.join("hand-a.csv")),
        &commands(&d.join("hand-b.csv")),
    );
    let ball_change = largest_difference(
        &commands(&d.join("ball-a.csv")),
        &commands(&d.join("ball-b.csv")),
    );
    eprintln!(
        "hand commands change by {hand_change:e} rad when the nominal ball moves 11 mm; the ball's by {ball_change:e} rad"
    );
    assert!(hand_change < 1e-9, "{hand_change:e} rad");
    assert!(ball_change > 1e-3, "{ball_change:e} rad");
    // The note names the ball's offset as the measured tool's, not applied,
    // and what the socket sessions cannot separate from it.
    for needle in [
        // The hand's TCP in the flange frame, ball_link's (the tip link the
        // calibration was read with): the URDF's ball_joint reversed.
        "working tool at (-0.000077737, 0.00004214, -0.030128298) m",
        "tool.x, tool.y, tool.z",
        "is not applied to it",
        "theta7, s7 move the measured tool rigidly with the flange",
    ] {
        assert!(note.contains(needle), "{needle:?} not in {note}");
    }
    // The same tool given as a frame in the flange frame, the tip link's
    // (ball_link; the hand's TCP is the URDF's ball_joint reversed): the same
    // commands.
    compensate(
        d,
        "urdf-ball.cal",
        &[
            "--tool",
            "-7.773732033005863e-05,4.214022515884392e-05,-0.030128297908475325",
        ],
        "hand-frame.csv",
    );
    let frame_change = largest_difference(
        &commands(&d.join("hand-a.csv")),
        &commands(&d.join("hand-frame.csv")),
    );
    assert!(frame_change < 1e-9, "{frame_change:e} rad");
}

/// A working tool the calibration cannot take is refused, status 2, naming
/// the flag, and nothing is written.
#[test]
fn a_working_tool_that_is_not_the_arms_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    identify(d, "0,0,0", "ball.cal");
    let joints = mukca().join("panda_6/left.csv").display().to_string();
    let u = urdf();
    let run = |extra: &[&str], needles: &[&str]| {
        let mut args = vec![
            "compensate",
            "--calibration",
            "ball.cal",
            "--joints",
            &joints,
            "--out",
            "c.csv",
        ];
        args.extend(extra);
        refused(d, &args, needles);
    };
    run(
        &["--tool-link", "panda_link5", "--model", &u],
        &["--tool-link", "hangs on 5 moving joints"],
    );
    run(
        &["--tool-link", "no_such_link", "--model", &u],
        &["--tool-link", "no_such_link"],
    );
    run(&["--tool-link", "panda_hand_tcp"], &["--model"]);
    run(
        &["--tool", "0,0"],
        &["--tool", "three or six finite numbers"],
    );
    run(
        &[
            "--tool",
            "0,0,0.1",
            "--tool-link",
            "panda_hand_tcp",
            "--model",
            &u,
        ],
        &["--tool"],
    );
    run(
        &["--tool-link", "panda_hand_tcp", "--model", "ur5e"],
        &["--tool-link", "URDF"],
    );
    // A 250 mm tool typed in mm on a metre model: 250 m, farther from the
    // flange than the arm reaches (the Panda's links sum to 1.286 m); the unit it
    // fits in is named.
    run(
        &["--tool", "0,0,250"],
        &[
            "--tool",
            "250 m from the flange, farther than the arm reaches",
            "in mm it would be 0.25 m",
        ],
    );
    // Export alike: no 250 m link is written.
    refused(
        d,
        &[
            "export",
            "--calibration",
            "ball.cal",
            "--format",
            "urdf",
            "--tool",
            "0,0,250",
            "--out",
            "x.urdf",
        ],
        &["--tool", "in mm it would be 0.25 m"],
    );
}

/// `export` with a working tool: the URDF's measured point is the working
/// tool, on the calibrated arm's flange.
#[test]
fn export_writes_the_working_tool() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    identify(d, "0,0,0", "ball.cal");
    let u = urdf();
    let export = |extra: &[&str]| {
        let mut args = vec![
            "export",
            "--calibration",
            "ball.cal",
            "--format",
            "urdf",
            "--model",
            &u,
            "--tip-link",
            "ball_link",
        ];
        args.extend(extra);
        succeeds(d, &args)
    };
    let plain = export(&[]);
    let hand = export(&["--tool-link", "panda_hand_tcp"]);
    let (plain, hand) = (
        String::from_utf8_lossy(&plain.stdout),
        String::from_utf8_lossy(&hand.stdout),
    );
    let joint = |text: &str, name: &str| -> String {
        let start = text.find(&format!("<joint name=\"{name}\"")).unwrap();
        text[start..start + text[start..].find("</joint>").unwrap()].to_owned()
    };
    // The arm's joints are the calibrated ones either way; only the measured
    // point differs: the ball's identified place, or the hand's TCP.
    for j in 1..=7 {
        let name = format!("panda_joint{j}");
        assert_eq!(joint(&plain, &name), joint(&hand, &name), "{name}");
    }
    assert_ne!(
        joint(&plain, "armcal_measured_point_joint"),
        joint(&hand, "armcal_measured_point_joint")
    );
}
