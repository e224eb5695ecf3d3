//! The `armcal` binary as a user runs it: exit status, what it prints, and that a
//! refused input names file, line and column and leaves the output folder untouched.

use std::path::Path;
use std::process::{Command, Output};

fn armcal(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_armcal"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("armcal runs")
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn check_on_builtin_model_and_data_prints_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = armcal(
        &[
            "check",
            "--model",
            "figaroh-ur10e-camera",
            "--data",
            "figaroh-ur10e-camera",
        ],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for needle in [
        "ur10e_d435",
        "6 joints",
        "23 poses",
        "full poses",
        "position error",
        "orientation error",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in:\n{stdout}");
    }
    assert!(files_in(dir.path()).is_empty(), "check writes nothing");
}

#[test]
fn check_refuses_a_bad_value_with_file_line_column() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("arm.toml");
    std::fs::write(
        &model,
        "name = \"arm\"\nconvention = \"dh\"\nlength_unit = \"m\"\nangle_unit = \"rad\"\n\
         [[joint]]\ntype = \"revolute\"\ntheta = 0.0\ns = 0.5\na = 0.0\nalpha = 0.0\n",
    )
    .unwrap();
    let data = dir.path().join("poses.csv");
    std::fs::write(
        &data,
        "# one joint\nq1,x,y,z\n0.1,0.0,0.0,0.5\n0.2,0.0,abc,0.5\n",
    )
    .unwrap();
    let before = files_in(dir.path());
    let out = armcal(
        &["check", "--model", "arm.toml", "--data", "poses.csv"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    // Line 4, the field `abc` starts at character 9.
    assert!(stderr.contains("poses.csv:4:9:"), "{stderr}");
    assert!(stderr.contains("'y'"), "{stderr}");
    assert_eq!(files_in(dir.path()), before, "nothing written");
}

#[test]
fn check_refuses_too_few_poses() {
    let dir = tempfile::tempdir().unwrap();
    // 6R PUMA with positions only: 4·6 + 3 = 27 unknowns, 2 poses give 6 equations.
    std::fs::write(
        dir.path().join("few.csv"),
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n0.1,0,0,0,0,0,1,2,3\n",
    )
    .unwrap();
    let out = armcal(
        &["check", "--model", "puma560", "--data", "few.csv"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("few.csv:3:1:"), "{stderr}");
    assert!(stderr.contains("27"), "{stderr}");
}

#[test]
fn unknown_model_name_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = armcal(
        &[
            "check",
            "--model",
            "no-such-robot",
            "--data",
            "figaroh-ur10e-camera",
        ],
        dir.path(),
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no-such-robot"));
}
