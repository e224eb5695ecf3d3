//! The `armcal` binary as a user runs it: exit status, what it prints, what it
//! writes, and that a refused input names file, line and column and leaves the
//! output folder untouched. One test binary, a module per verb.

use std::path::Path;
use std::process::{Command, Output};

mod check_identify;
mod demo;
mod link;
mod outputs;
mod predict;
mod refusals;

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
