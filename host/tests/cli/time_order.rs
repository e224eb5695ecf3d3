//! Rows out of the order the robot moved in: a joint's approach direction,
//! which a backlash turns into a position error, is that of its move to the
//! pose, so it is read in the order of the times when the rows carry them.

use super::succeeds;
use std::path::Path;

/// The effects `diagnose` names on `data` (a PUMA 560 session), and its
/// JSON report.
fn diagnosed(dir: &Path, data: &str) -> (Vec<String>, serde_json::Value, String) {
    let out = succeeds(
        dir,
        &[
            "diagnose", "--model", "puma560", "--data", data, "--json", "r.json",
        ],
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("r.json")).unwrap()).unwrap();
    let named = report["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap().to_owned())
        .collect();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    (named, report, text)
}

/// A hidden backlash of joint 2 on 200 tracker positions (each joint
/// approaching from either side as the robot moved, every row timed): the
/// diagnosis names it from the file as written. The same rows sorted by
/// their first joint (a file sorted by configuration) are read in the order
/// of their times, so the same backlash is named and a warning says the rows
/// were out of order. Sorted and without the times, each pose's direction is
/// that of a move the robot never made: half the poses' signs are wrong, the
/// backlash's signature is gone from the data, and it is not named.
#[test]
fn the_approach_directions_are_read_in_the_order_of_the_times() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    succeeds(
        dir,
        &[
            "simulate",
            "--model",
            "puma560",
            "--poses",
            "200",
            "--seed",
            "5",
            "--effect",
            "backlash:2",
            "--out",
            "moved.csv",
        ],
    );
    let text = std::fs::read_to_string(dir.join("moved.csv")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let header_at = lines.iter().position(|l| l.starts_with("q1")).unwrap();
    let header: Vec<&str> = lines[header_at].split(',').collect();
    let t = header.iter().position(|c| *c == "t").unwrap();
    let mut rows = lines.split_off(header_at + 1);
    let q1 = |row: &str| row.split(',').next().unwrap().parse::<f64>().unwrap();
    rows.sort_by(|a, b| q1(a).total_cmp(&q1(b)));
    let sorted = lines
        .iter()
        .chain(&rows)
        .map(|l| format!("{l}\n"))
        .collect::<String>();
    std::fs::write(dir.join("sorted.csv"), sorted).unwrap();
    let without_t = |l: &str| {
        let mut fields: Vec<&str> = l.split(',').collect();
        if fields.len() == header.len() {
            fields.remove(t);
        }
        format!("{}\n", fields.join(","))
    };
    let untimed = lines
        .iter()
        .chain(&rows)
        .map(|l| without_t(l))
        .collect::<String>();
    std::fs::write(dir.join("untimed.csv"), untimed).unwrap();

    let (named, report, _) = diagnosed(dir, "moved.csv");
    assert_eq!(named, ["backlash"]);
    assert_eq!(report["approach_order"], "times");
    let (named, report, text) = diagnosed(dir, "sorted.csv");
    assert_eq!(named, ["backlash"], "{text}");
    assert_eq!(report["approach_order"], "times");
    assert!(text.contains("not in the order of their times"), "{text}");
    let (named, report, text) = diagnosed(dir, "untimed.csv");
    assert!(!named.contains(&"backlash".to_owned()), "{named:?}\n{text}");
    assert_eq!(report["approach_order"], "rows");
}
