//! What the command line does with an outcome: warnings and progress on
//! standard error, the human summary on standard output, the files asked for
//! written all or none (`armcal::io::output::Outputs`), a failed calibration
//! refused unless `--write-failed`.

use armcal::calibration::validation::acceptance::FailedCalibration;
use armcal::commands::{self, Front};
use armcal::io::measurements;
use armcal::io::output::Outputs;
use armcal::session::input_error::InputError;
use armcal::session::measurements::Measurements;
use armcal::session::model::RobotModel;
use armcal::session::registration::FrameSharing;

use crate::cli::ModelArgs;

/// The model and the measurements of one session or several (one file
/// each: [`Measurements::sessions`]), refused
/// ([`commands::require_session`]) if the poses give fewer equations than
/// the model's independent parameters, a session fewer than the frames
/// `frames` makes its own, or if they cannot be measurements of this robot.
pub(crate) fn load_session(
    model: &ModelArgs,
    data: &[String],
    frames: FrameSharing,
    progress: &Progress,
) -> anyhow::Result<(RobotModel, Measurements)> {
    let model = model.load()?;
    let parts = data
        .iter()
        .map(|file| {
            progress.set(format!("reading {file}"));
            measurements::load_measurements(file, &model)
        })
        .collect::<Result<Vec<_>, _>>()?;
    progress.set("checking the rows");
    let data = commands::sessions(parts)?;
    commands::require_session(&model, &data, frames)?;
    Ok((model, data))
}

/// The command line's front end, as the command layer names its arguments.
pub(crate) const CLI: Front = Front::CommandLine;

/// The progress of a long run on standard error (indicatif), drawn only
/// when standard error is a terminal: the one factory of every verb's
/// progress. A stage is a spinner with its message and the time elapsed,
/// ticking on its own while the work runs; a step of a counted loop a bar.
pub(crate) struct Progress {
    bar: indicatif::ProgressBar,
}

impl Progress {
    /// A spinner with `message`, on standard error when it is a terminal.
    pub(crate) fn stage(message: impl Into<String>) -> Self {
        use std::io::IsTerminal as _;
        let bar = if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new_spinner();
            bar.set_style(
                indicatif::ProgressStyle::with_template("{spinner} {msg} [{elapsed}]")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            bar.enable_steady_tick(std::time::Duration::from_millis(120));
            bar
        } else {
            indicatif::ProgressBar::hidden()
        };
        bar.set_message(message.into());
        Self { bar }
    }

    /// A new stage: `message`.
    pub(crate) fn set(&self, message: impl Into<String>) {
        self.bar.set_message(message.into());
    }

    /// Step `done` of `total` of a counted loop, with `message`: drawn as a bar.
    pub(crate) fn step(&self, done: usize, total: usize, message: impl Into<String>) {
        if self.bar.length() != Some(total as u64) {
            self.bar.set_length(total as u64);
            self.bar.set_style(
                indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} [{elapsed}]")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                    .progress_chars("#>."),
            );
        }
        self.bar.set_position(done as u64);
        self.bar.set_message(message.into());
    }

    /// Runs `f` (that prints to standard error) with the line cleared.
    pub(crate) fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        self.bar.suspend(f)
    }

    /// Clears the line, so that what follows starts on a clean one.
    pub(crate) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Drop for Progress {
    /// An error returned through a stage clears its line before the message.
    fn drop(&mut self) {
        self.bar.finish_and_clear();
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
