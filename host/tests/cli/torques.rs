//! The joint torques a robot reports (`tau1..tauM`), as a user gives them:
//! simulated with `armcal simulate --torque-noise`, read by `check`, the
//! masses fitted to them named first in `identify`'s and `diagnose`'s
//! summaries and JSON; a file with some of the columns, or a torque no arm
//! carries, refused with its line and column, nothing written.

use crate::{refused, succeeds};

#[test]
fn torques_are_read_fitted_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    succeeds(
        d,
        &[
            "simulate",
            "--model",
            "ur10e",
            "--poses",
            "60",
            "--effect",
            "joint_compliance:2",
            "--torque-noise",
            "0.05",
            "--out",
            "s.csv",
        ],
    );
    let header = std::fs::read_to_string(d.join("s.csv")).unwrap();
    assert!(
        header.contains("load,tau1,tau2,tau3,tau4,tau5,tau6\n"),
        "{header}"
    );
    let check = succeeds(d, &["check", "--model", "ur10e", "--data", "s.csv"]);
    assert!(String::from_utf8_lossy(&check.stdout).contains("tau1..tau6 in N·m"));
    let out = succeeds(
        d,
        &[
            "identify", "--model", "ur10e", "--data", "s.csv", "--json", "r.json",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("gravity torques from the measured joint torques (tau1..tau6, 60 poses)"),
        "{stdout}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(json["gravity"]["poses"], 60);
    // The fitted masses reproduce the torques to their noise (0.05 N·m).
    for r in json["gravity"]["residual_nm"].as_array().unwrap() {
        assert!(r.as_f64().unwrap() < 0.1, "{r}");
    }
}

#[test]
fn partial_or_impossible_torques_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let row = "0.1,0.2,0.3,0.4,0.5,0.6,0.5,0.2,0.3";
    // A file of `header` and one row ending in `torques`, refused with `needles`.
    let refuses = |file: &str, header: &str, torques: &str, needles: &[&str]| {
        std::fs::write(d.join(file), format!("{header}\n{row},{torques}\n")).unwrap();
        refused(
            d,
            &[
                "identify", "--model", "ur10e", "--data", file, "--out", "c.cal",
            ],
            needles,
        );
    };
    let six = "q1,q2,q3,q4,q5,q6,x,y,z,tau1,tau2,tau3,tau4,tau5,tau6";
    refuses(
        "some.csv",
        "q1,q2,q3,q4,q5,q6,x,y,z,tau1,tau2",
        "1,2",
        &["some.csv:1:1", "missing column 'tau3'"],
    );
    refuses(
        "huge.csv",
        six,
        "1,2,3e6,4,5,6",
        &["huge.csv:2:", "column 'tau3'", "N·mm"],
    );
    refuses(
        "seven.csv",
        &format!("{six},tau7"),
        "1,2,3,4,5,6,7",
        &["seven.csv:1:", "column 'tau7'", "the model has 6 joints"],
    );
}
