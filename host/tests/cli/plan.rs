//! `armcal plan` as a user runs it: the poses written as a joints file
//! that `predict` reads, the report's predicted accuracy beside random
//! poses', the HTML page's maps, candidates and targets from files, and
//! the refusals (a box that is no box, fewer poses than the parameters
//! need) with nothing written.

use crate::{refused, succeeds};

#[test]
fn a_plan_is_a_joints_file_with_its_predicted_accuracy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = succeeds(
        d,
        &[
            "plan", "--model", "ur10e", "--poses", "24", "--out", "p.csv", "--json", "r.json",
            "--html", "r.html", "--above", "0.1",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.starts_with("plan: 24 poses of ur10e"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(report["poses"], 24);
    let planned = report["predicted_rms_mm"].as_f64().unwrap();
    let random = report["random"]["predicted_rms_mm"].as_f64().unwrap();
    assert!(planned < random, "{planned} {random}");
    // The joints file is what predict and compensate read: 24 rows, and the
    // nominal tool point of each above the floor.
    let model = armcal::io::model_file::load_model("ur10e").unwrap();
    let text = std::fs::read_to_string(d.join("p.csv")).unwrap();
    let rows =
        armcal::io::measurements::parse_joints(&text, "p.csv", &model.robot, &model.units).unwrap();
    assert_eq!(rows.rows.len(), 24);
    for r in &rows.rows {
        assert!(model.robot.forward(&r.q).unwrap().translation.vector.z >= 0.1);
    }
    let page = std::fs::read_to_string(d.join("r.html")).unwrap();
    assert!(
        page.contains("seen from above") && page.contains("<svg"),
        "{page}"
    );

    // Candidates and targets from files: the plan keeps to the candidates.
    std::fs::write(
        d.join("c.csv"),
        format!(
            "q1,q2,q3,q4,q5,q6\n{}",
            text.lines().skip(2).collect::<Vec<_>>().join("\n")
        ),
    )
    .unwrap();
    succeeds(
        d,
        &[
            "plan",
            "--model",
            "ur10e",
            "--poses",
            "20",
            "--from",
            "c.csv",
            "--targets",
            "c.csv",
            "--out",
            "q.csv",
        ],
    );
    let chosen = std::fs::read_to_string(d.join("q.csv")).unwrap();
    for line in chosen.lines().skip(2) {
        assert!(text.contains(line), "{line} is not a candidate");
    }
}

#[test]
fn plans_that_cannot_be_made_are_refused_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    refused(
        d,
        &[
            "plan",
            "--model",
            "ur10e",
            "--out",
            "p.csv",
            "--within",
            "1,1,1,0,0,0",
        ],
        &["--within", "each minimum below its maximum"],
    );
    refused(
        d,
        &["plan", "--model", "ur10e", "--poses", "3", "--out", "p.csv"],
        &["3 poses give 9 equations", "at least"],
    );
    refused(
        d,
        &[
            "plan",
            "--model",
            "ur10e",
            "--poses",
            "10",
            "--out",
            "p.csv",
            "--within",
            "5,5,5,6,6,6",
        ],
        &["0 candidate configurations"],
    );
}

/// `--effects backlash`: every planned pose is measured twice, the first
/// time after a row below it in every joint, the second after a row above
/// it, so that the approach direction `identify` reads from row order
/// (docs/file-formats.md §2) is −1 then +1 for each joint.
#[test]
fn a_plan_for_backlash_approaches_each_pose_from_both_sides() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    succeeds(
        d,
        &[
            "plan",
            "--model",
            "ur10e",
            "--poses",
            "12",
            "--effects",
            "backlash",
            "--out",
            "p.csv",
            "--json",
            "r.json",
        ],
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(
        (report["poses"].as_u64(), report["rows"].as_u64()),
        (Some(12), Some(48))
    );
    assert_eq!(report["one_sided"], 0);
    let model = armcal::io::model_file::load_model("ur10e").unwrap();
    let text = std::fs::read_to_string(d.join("p.csv")).unwrap();
    let rows = armcal::io::measurements::parse_joints(&text, "p.csv", &model.robot, &model.units)
        .unwrap()
        .rows;
    for pose in rows.chunks(4) {
        assert_eq!(pose[1].q, pose[3].q);
        for j in 0..6 {
            assert!(pose[0].q[j] < pose[1].q[j] && pose[2].q[j] > pose[1].q[j]);
        }
    }
    refused(
        d,
        &[
            "plan",
            "--model",
            "ur10e",
            "--effects",
            "thermal",
            "--out",
            "p.csv",
        ],
        &["--effects", "thermal"],
    );
}

/// `--sockets`: a plan for a ball seated in the sockets of a plate is a
/// session file of docs/file-formats.md §3 — its `point` column names each
/// row's socket, its distance lines are the plate's — which `check` reads
/// as it is (the planned joints put the nominal ball at each socket: the
/// nominal spread at each is nil) and `predict` reads as a joints file; the
/// poses are shared among the sockets evenly. A sockets file with a bad cell
/// is refused at it, and a socket plan with orientations, with nothing
/// written.
#[test]
fn a_socket_plan_is_a_session_file_to_measure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("plate.csv"),
        "# three sockets, m\npoint,x,y,z\ns0,0.45,-0.15,0.05\ns1,0.45,0.15,0.05\n\
         s2,0.6,0,0.05\ndistance,s0,s1,0.3\ndistance,s0,s2,0.212132\n",
    )
    .unwrap();
    let out = succeeds(
        d,
        &[
            "plan",
            "--model",
            "ur5e",
            "--poses",
            "30",
            "--sockets",
            "plate.csv",
            "--out",
            "p.csv",
            "--json",
            "r.json",
            "--candidates",
            "3000",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("a ball seated in 3 sockets, 2 known distances"),
        "{stdout}"
    );
    assert!(
        stdout.contains("poses a socket: s0 10, s1 10, s2 10"),
        "{stdout}"
    );
    let text = std::fs::read_to_string(d.join("p.csv")).unwrap();
    assert!(
        text.lines().nth(1) == Some("q1,q2,q3,q4,q5,q6,point"),
        "{text}"
    );
    assert!(text.contains("\ndistance,s0,s1,0.3,"), "{text}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(report["socket_of"].as_array().unwrap().len(), 30);
    assert!(
        report["predicted_rms_mm"].as_f64().unwrap()
            < report["random"]["predicted_rms_mm"].as_f64().unwrap()
    );
    let check = succeeds(d, &["check", "--model", "ur5e", "--data", "p.csv"]);
    let checked = String::from_utf8_lossy(&check.stdout);
    assert!(checked.contains("s0"), "{checked}");
    let model = armcal::io::model_file::load_model("ur5e").unwrap();
    let rows =
        armcal::io::measurements::parse_joints(&text, "p.csv", &model.robot, &model.units).unwrap();
    assert_eq!(rows.rows.len(), 30);

    std::fs::write(d.join("bad.csv"), "point,x,y,z\ns0,450,-150,zz\n").unwrap();
    refused(
        d,
        &[
            "plan",
            "--model",
            "ur5e",
            "--sockets",
            "bad.csv",
            "--out",
            "q.csv",
        ],
        &["bad.csv:2:13", "not a number"],
    );
    refused(
        d,
        &[
            "plan",
            "--model",
            "ur5e",
            "--sockets",
            "plate.csv",
            "--orientation",
            "--out",
            "q.csv",
        ],
        &["--sockets", "--orientation"],
    );
    assert!(!d.join("q.csv").exists());
}

/// A model without joint limits (the built-in UR10e) reaches through the
/// table it stands on: by default the plan keeps the flange (the last link's
/// frame) and the tool point above the robot's base plane, and says so;
/// `--above` sets the floor instead (a robot on a pedestal may reach below).
#[test]
fn a_plan_stays_above_the_base_plane_of_a_model_without_limits() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = armcal::io::model_file::load_model("ur10e").unwrap();
    let flange = armcal_shared::Robot {
        tool: armcal_shared::Frame::identity(),
        ..model.robot.clone()
    };
    let heights = |file: &str| -> Vec<f64> {
        let text = std::fs::read_to_string(d.join(file)).unwrap();
        let rows = armcal::io::measurements::parse_joints(&text, file, &model.robot, &model.units)
            .unwrap();
        rows.rows
            .iter()
            .map(|r| flange.forward(&r.q).unwrap().translation.vector.z)
            .collect()
    };
    let out = succeeds(
        d,
        &[
            "plan", "--model", "ur10e", "--poses", "30", "--out", "p.csv",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("kept above the robot's base plane"),
        "{stdout}"
    );
    let lowest = heights("p.csv").into_iter().fold(f64::INFINITY, f64::min);
    assert!(lowest >= 0.0, "a flange {lowest} m below the base plane");
    // With a floor given, that floor: the flange may go below the base.
    succeeds(
        d,
        &[
            "plan", "--model", "ur10e", "--poses", "30", "--above", "-2", "--out", "q.csv",
        ],
    );
    assert!(heights("q.csv").iter().any(|&z| z < 0.0));
}
