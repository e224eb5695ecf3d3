//! What the command line does with an outcome: warnings and progress on
//! standard error, the human summary on standard output, the files asked for
//! written all or none (`armcal::io::output::Outputs`), a failed calibration
//! refused unless `--write-failed`.

use armcal::calibration::acceptance::FailedCalibration;
use armcal::commands::{self, Front};
use armcal::io::input_error::InputError;
use armcal::io::measurements::{self, Measurements};
use armcal::io::model_file::RobotModel;
use armcal::io::output::Outputs;

use crate::cli::ModelArgs;

/// The model and the measurements of one session or several (one file
/// each: [`Measurements::sessions`]), refused
/// ([`commands::require_session`]) if the poses give fewer equations than
/// the model's independent parameters or if they cannot be measurements of
/// this robot.
pub(crate) fn load_session(
    model: &ModelArgs,
    data: &[String],
) -> anyhow::Result<(RobotModel, Measurements)> {
    let model = model.load()?;
    let parts = data
        .iter()
        .map(|file| measurements::load_measurements(file, &model))
        .collect::<Result<Vec<_>, _>>()?;
    let data = commands::sessions(parts)?;
    commands::require_session(&model, &data)?;
    Ok((model, data))
}

/// The command line's front end, as the command layer names its arguments.
pub(crate) const CLI: Front = Front::CommandLine;

/// A one-line progress display on standard error, redrawn in place (`\r`), shown
/// only when standard error is a terminal: the one progress bar of `diagnose`
/// and `sweep`.
pub(crate) struct Progress {
    tty: bool,
}

impl Progress {
    /// A progress line on standard error, silent unless it is a terminal.
    pub(crate) fn on_stderr() -> Self {
        use std::io::IsTerminal as _;
        Self {
            tty: std::io::stderr().is_terminal(),
        }
    }

    /// Redraws the line with `line()` (not called when nothing is shown).
    pub(crate) fn show(&self, line: impl FnOnce() -> String) {
        if self.tty {
            eprint!("\r{}", line());
        }
    }

    /// Ends the line, so what follows starts on a new one.
    pub(crate) fn finish(&self) {
        if self.tty {
            eprintln!();
        }
    }
}

/// Prints warnings (of a data file, of a computation) to standard error.
pub(crate) fn warn<'a>(warnings: impl IntoIterator<Item = &'a String>) {
    for w in warnings {
        eprintln!("armcal: warning: {w}");
    }
}

/// Refuses (exit status 1) the calibration `refusal` names unless
/// `write_failed`, in which case its reason is printed as a warning.
pub(crate) fn accept(refusal: Option<FailedCalibration>, write_failed: bool) -> anyhow::Result<()> {
    match refusal {
        Some(failed) if write_failed => {
            eprintln!(
                "armcal: warning: {}: {} (written as --write-failed asks)",
                failed.file, failed.reason
            );
            Ok(())
        }
        Some(failed) => Err(failed.into()),
        None => Ok(()),
    }
}

/// Writes the requested outputs (every one prepared before the first byte is
/// written), then prints the human summary unless `quiet`.
pub(crate) fn finish(
    outputs: Outputs,
    quiet: bool,
    summary: impl FnOnce() -> String,
) -> anyhow::Result<()> {
    outputs.commit()?;
    if !quiet {
        print!("{}", summary());
    }
    Ok(())
}

/// The checked `--out` of a verb that reads a calibration and a joints file.
pub(crate) fn joints_outputs(
    calibration: &str,
    joints: &str,
    out: &Option<std::path::PathBuf>,
) -> Result<Outputs, InputError> {
    let outputs = Outputs::new()
        .input("--calibration", calibration)
        .input("--joints", joints)
        .output("--out", out.as_deref());
    outputs.check()?;
    Ok(outputs)
}

/// Writes `csv` to the planned `--out`, or prints it when none was asked for.
pub(crate) fn finish_csv(mut outputs: Outputs, csv: String) -> anyhow::Result<()> {
    if outputs.is_empty() {
        print!("{csv}");
        return Ok(());
    }
    outputs.set("--out", csv.into_bytes());
    outputs.commit()
}
