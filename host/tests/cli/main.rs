//! The `armcal` binary as a user runs it: exit status, what it prints, what it
//! writes, and that a refused input names file, line and column and leaves the
//! output folder untouched. One test binary, a module per verb.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod check_identify;
mod constraints;
mod demo;
mod link;
mod mukca_urdf;
mod outputs;
mod plan;
mod predict;
mod ranges;
mod refusals;
mod replicates;
mod report_schema;
mod serve;
mod sessions;
mod time_order;
mod torques;
mod ur;
mod urdf;
mod working_tool;
mod written;

/// Runs `armcal` with `args` in `dir`.
pub fn armcal(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_armcal"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("armcal runs")
}

/// Asserts that a run of `armcal` succeeded, showing its standard error if not.
pub fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The names of the files in `dir`, sorted.
pub fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Every entry of `dir` (recursively) with its kind and, for regular files, bytes.
pub fn snapshot(dir: &Path) -> Vec<(PathBuf, String, Vec<u8>)> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        let kind = entry.file_type().unwrap();
        let path = entry.path();
        let (label, bytes) = if kind.is_symlink() {
            let target = std::fs::read_link(&path).unwrap();
            (
                "link".to_owned(),
                target.to_string_lossy().into_owned().into_bytes(),
            )
        } else if kind.is_dir() {
            out.extend(snapshot(&path));
            ("dir".to_owned(), Vec::new())
        } else if kind.is_file() {
            ("file".to_owned(), std::fs::read(&path).unwrap())
        } else {
            (format!("{kind:?}"), Vec::new())
        };
        out.push((path, label, bytes));
    }
    out.sort();
    out
}

/// Runs `args` in `dir` and asserts the refusal: exit status 2, a standard
/// error holding every one of `needles` and no panic, and every entry of `dir`
/// as it was; the standard error.
#[track_caller]
pub fn refused(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let before = snapshot(dir);
    let out = armcal(args, dir);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    for needle in needles {
        assert!(
            stderr.contains(needle),
            "{args:?}: {needle:?} not in {stderr}"
        );
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(snapshot(dir), before, "{args:?} changed the folder");
    stderr
}

/// Runs `args` in `dir` and asserts it succeeded, showing its standard error if not.
#[track_caller]
pub fn succeeds(dir: &Path, args: &[&str]) -> Output {
    let out = armcal(args, dir);
    assert_success(&out);
    out
}

/// The RMS 3-D distance (model units) between the `x, y, z` of the rows of
/// two CSV files (predicted and measured points, rows in order).
pub fn rms_distance(predicted: &Path, measured: &Path) -> f64 {
    let rows = |path: &Path| -> Vec<Vec<f64>> {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines().filter(|l| !l.starts_with('#'));
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let at: Vec<usize> = ["x", "y", "z"]
            .iter()
            .map(|c| header.iter().position(|h| h == c).unwrap())
            .collect();
        lines
            .map(|l| {
                let cells: Vec<&str> = l.split(',').collect();
                at.iter().map(|&i| cells[i].parse().unwrap()).collect()
            })
            .collect()
    };
    let (p, m) = (rows(predicted), rows(measured));
    assert_eq!(p.len(), m.len());
    let sum: f64 = p
        .iter()
        .zip(&m)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>())
        .sum();
    (sum / p.len() as f64).sqrt()
}
