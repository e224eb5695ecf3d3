//! `armcal`, the robot calibrator's command line.
//!
//! Each verb reads its inputs completely and validates them before it computes or
//! writes anything, so a refused input leaves every output file untouched. Errors
//! print as `file:line:column: what is wrong` and the process exits with status 2
//! (bad input) or 1 (anything else).
//!
//! The layers of the binary: `cli.rs` describes the flags and turns them into
//! the requests of `armcal::commands`; `verbs.rs` runs each verb (its inputs
//! read, its request run, its outcome printed and written); `terminal.rs`
//! holds what the verbs print and write with; `args.rs` the value parsers.

use std::process::ExitCode;

use clap::Parser;

mod args;
mod cli;
mod terminal;
mod verbs;

use cli::{Cli, Command, Paper};

/// An interrupt (Ctrl-C, SIGTERM) ends the run as it would, but leaves no
/// temporary of the outputs being written; the exit status is 128 plus the
/// signal's number (130 for Ctrl-C, 143 for SIGTERM), as a shell reports it.
#[cfg(unix)]
fn on_interrupt() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    if let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) {
        std::thread::spawn(move || {
            if let Some(signal) = signals.forever().next() {
                armcal::io::output::remove_pending();
                std::process::exit(128 + signal);
            }
        });
    }
}

/// An interrupt (Ctrl-C) ends the run as it would, but leaves no temporary of
/// the outputs being written (exit status 130).
#[cfg(not(unix))]
fn on_interrupt() {
    let _ = ctrlc::set_handler(|| {
        armcal::io::output::remove_pending();
        std::process::exit(130);
    });
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // `serve` answers its controller until the correction has ramped to
    // none: it reads the signals itself.
    if !matches!(cli.command, Command::Serve(_)) {
        on_interrupt();
    }
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("armcal: error: {err}");
            let mut source = err.source();
            while let Some(cause) = source {
                eprintln!("  caused by: {cause}");
                source = cause.source();
            }
            // A refusal of what the user gave: status 2; anything else is a
            // failure of the program or the machine: 1.
            if armcal::commands::is_refusal(&err) {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// Runs the verb `command` names.
fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Check(a) => verbs::check(a),
        Command::Holdout(a) => verbs::holdout(a),
        Command::Reproduce(a) => match a.paper {
            Paper::MirmanGupta => verbs::reproduce_mirman_gupta(),
            Paper::Kirchner => verbs::reproduce_kirchner(),
        },
        Command::Identify(a) => verbs::identify(a),
        Command::Simulate(a) => verbs::simulate(a),
        Command::Diagnose(a) => verbs::diagnose(a),
        Command::Demo(a) => verbs::demo(a),
        Command::Sweep(a) => verbs::sweep(a),
        Command::Compensate(a) => verbs::compensate(a),
        Command::Predict(a) => verbs::predict(a),
        Command::Stream(a) => verbs::stream(a),
        Command::Serve(a) => verbs::serve(a),
        Command::Export(a) => verbs::export(a),
        Command::Plan(a) => verbs::plan(a),
        Command::Models => verbs::models(),
    }
}
