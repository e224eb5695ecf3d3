//! One function per verb of `armcal`: what `main.rs`'s `run` calls with the
//! verb's flags (`cli.rs`). A verb plans its outputs, reads its inputs, runs
//! its request of `armcal::commands` (or the library's computation, for the
//! verbs without one), and prints and writes the outcome (`terminal.rs`).

use armcal::apply::compensate::RowWarning;
use armcal::apply::ranges::RowNames;
use armcal::apply::{compensate, link, predict, ranges, serve as serve_apply};
use armcal::calibration::identify::paper::PaperOptions;
use armcal::calibration::{check, reproduce};
use armcal::commands::tool::Tool;
use armcal::commands::{diagnose as diagnose_cmd, export as export_cmd, holdout as holdout_cmd};
use armcal::commands::{identify as identify_cmd, plan as plan_cmd, simulate as simulate_cmd};
use armcal::io::{builtin, measurements, model_file, output};
use armcal::session::input_error::InputError;
use armcal::session::joints::JointRows;
use armcal::session::measurements::Measurements;
use armcal_shared::Calibration;
use armcal_shared::compensation::Pacing;
use armcal_shared::compensation::Task;
use armcal_shared::link::Request;

use crate::cli::{
    CheckArgs, CompensateArgs, DemoArgs, DiagnoseArgs, ExportArgs, HoldoutArgs, IdentifyArgs,
    PlanArgs, PredictArgs, RsiModeArg, ServeArgs, SimulateArgs, StreamArgs, SweepArgs,
};
use crate::terminal::{
    CLI, Progress, accept, finish, finish_csv, joints_outputs, load_session, warn,
};

/// `armcal check`.
pub(crate) fn check(args: CheckArgs) -> anyhow::Result<()> {
    let progress = Progress::stage("reading");
    // check reads each session in its own frames, as identify does by default.
    let frames = armcal::session::registration::FrameSharing::default();
    let (model, data) = load_session(&args.model, &args.data, frames, &progress)?;
    progress.set("the nominal model against the rows");
    let report = check::report(&model, &data);
    // The torques as identify and diagnose read them: a column they refuse
    // is refused here too.
    let (_, gravity) =
        armcal::calibration::gravity::with_measured_gravity(&model, &data, args.torques.sign())?;
    progress.finish();
    print!("{report}");
    if let Some(g) = gravity {
        println!("{}", g.summary());
        warn(g.warning().iter());
    }
    Ok(())
}

/// `armcal holdout`.
pub(crate) fn holdout(args: HoldoutArgs) -> anyhow::Result<()> {
    let chain = args.model.chain.spec();
    let model = args.model.load()?;
    let load = |file: &String| -> anyhow::Result<Measurements> {
        let d = measurements::load_measurements(file, &model)?;
        d.require_contacts()?;
        warn(&d.warnings);
        Ok(d)
    };
    let sessions = args
        .data
        .iter()
        .map(load)
        .collect::<anyhow::Result<Vec<_>>>()?;
    let training = args
        .train
        .iter()
        .map(load)
        .collect::<anyhow::Result<Vec<_>>>()?;
    let reference = match &args.reference {
        Some(path) => Some(model_file::load_model_with(path, &chain)?),
        None => None,
    };
    let given = holdout_cmd::Sessions {
        held_out: &sessions,
        training: &training,
        reference: reference.as_ref(),
    };
    let progress = Progress::stage("leaving each session out in turn");
    let rows = holdout_cmd::run(CLI, &model, given, &args.request())?;
    progress.finish();
    let reports: Vec<_> = rows.iter().map(|r| r.report(&model.units)).collect();
    print!(
        "{}",
        holdout_cmd::holdout_table(&reports, reference.as_ref().map(|_| "reference"))
    );
    Ok(())
}

/// `armcal reproduce mirman-gupta`.
pub(crate) fn reproduce_mirman_gupta() -> anyhow::Result<()> {
    let (induced, fit) = reproduce::mirman_gupta::table2(&PaperOptions::default());
    print!("{}", reproduce::mirman_gupta::table2_report(&induced, &fit));
    println!();
    print!("{}", reproduce::mirman_gupta::table3_report());
    println!();
    print!("{}", reproduce::mirman_gupta::table6_7_report());
    Ok(())
}

/// `armcal identify`.
pub(crate) fn identify(args: IdentifyArgs) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new()
        .model_input(&args.model.model)
        .data_inputs(&args.data)
        .output("--out", args.out.as_deref())
        .output("--json", args.json.as_deref());
    outputs.check()?;
    let progress = Progress::stage("reading");
    let frames = args.sessions.sharing();
    let (model, data) = load_session(&args.model, &args.data, frames, &progress)?;
    progress.suspend(|| warn(&data.warnings));
    progress.set(format!("identifying from {} poses", data.len()));
    let identified = identify_cmd::run(CLI, &model, &data, &args.request())?;
    progress.finish();
    warn(
        identified
            .result
            .gravity
            .as_ref()
            .and_then(|g| g.warning())
            .iter(),
    );
    // What it prints, warns and writes as JSON: one report.
    let report = identified.result.report(&identified.model, &data);
    warn(&report.warnings);
    accept(identified.failed, args.write_failed)?;
    let result = identified.result;
    // Everything is computed and encoded before the first byte is written.
    if args.out.is_some() {
        outputs.set("--out", result.calibration.to_bytes()?);
    }
    if args.json.is_some() {
        let text = serde_json::to_string_pretty(&armcal::report::to_json(&report))?;
        outputs.set("--json", text.into_bytes());
    }
    finish(outputs, args.quiet, || report.summary())?;
    Ok(())
}

/// `armcal plan`.
pub(crate) fn plan(args: PlanArgs) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new()
        .model_input(&args.model.model)
        .output("--out", Some(&args.out))
        .output("--json", args.json.as_deref())
        .output("--html", args.html.as_deref());
    for (flag, file) in [
        ("--from", &args.from),
        ("--targets", &args.targets),
        ("--sockets", &args.sockets),
    ] {
        if let Some(file) = file {
            outputs = outputs.input(flag, file);
        }
    }
    outputs.check()?;
    let model = args.model.load()?;
    let mut request = args.request();
    if let Some(file) = &args.sockets {
        request.sockets = Some(armcal::io::sockets::load_sockets(file, &model.units)?);
    }
    let options = request.options(CLI, &model)?;
    let joints = |file: &Option<String>| -> anyhow::Result<Option<Vec<Vec<f64>>>> {
        let Some(file) = file else { return Ok(None) };
        let rows = measurements::load_joints(file, &model.robot, &model.units)?;
        warn(&rows.warnings);
        Ok(Some(rows.rows.into_iter().map(|r| r.q).collect()))
    };
    let from = match joints(&args.from)? {
        Some(rows) => {
            let (kept, dropped) = plan_cmd::within_limits(&model, rows, options.margin);
            if dropped > 0 {
                eprintln!(
                    "armcal: warning: --from: {dropped} configurations outside the joint limits \
                     (less the margin {}) left out",
                    options.margin
                );
            }
            Some(kept)
        }
        None => None,
    };
    let targets = joints(&args.targets)?;
    let (plan, options) = plan_cmd::run(
        CLI,
        &model,
        &request,
        from.as_deref(),
        targets.as_deref(),
        &|| false,
    )?;
    let cal = Calibration::nominal(model.robot.clone(), Task::Position, model.units);
    let comment = format!(
        "{}: the poses to measure, in this order",
        command_line(Some(args.seed))
    );
    outputs.set("--out", plan.csv(&comment, &cal, &options).into_bytes());
    // What it prints, and writes as JSON and HTML: one report.
    let report = plan.report(&model.name, &options, &model.units);
    if args.json.is_some() {
        let text = serde_json::to_string_pretty(&armcal::report::to_json(&report))?;
        outputs.set("--json", text.into_bytes());
    }
    if args.html.is_some() {
        outputs.set("--html", plan.html(&report, &model.units).into_bytes());
    }
    finish(outputs, false, || report.summary())
}

/// `armcal simulate`.
pub(crate) fn simulate(args: SimulateArgs) -> anyhow::Result<()> {
    // One file a session: `--out` itself for one.
    let paths: Vec<std::path::PathBuf> = if args.sessions > 1 {
        (0..args.sessions)
            .map(|k| simulate_cmd::Request::session_path(&args.out, k))
            .collect()
    } else {
        vec![args.out.clone()]
    };
    let mut outputs = paths
        .iter()
        .fold(
            output::Outputs::new().model_input(&args.model.model),
            |o, path| o.output("--out", Some(path)),
        )
        .output("--truth", args.truth.as_deref());
    outputs.check()?;
    let model = args.model.load()?;
    let u = model.units;
    let writer = simulate_cmd::writer(CLI, &model, &args.request())?;
    let description = command_line(Some(args.seed));
    if args.truth.is_some() {
        let truth = armcal::report::to_json(&writer.truth().truth(&model.robot, &u));
        let json = serde_json::to_string_pretty(&truth)?;
        outputs.set("--truth", json.into_bytes());
    }
    // The rows are drawn as they are written, session after session: the
    // writers are called in the order the files were planned.
    let writer = std::rc::Rc::new(std::cell::RefCell::new(writer));
    for (k, path) in paths.iter().enumerate() {
        let description = if paths.len() > 1 {
            format!("{description} (session {})", k + 1)
        } else {
            description.clone()
        };
        let writer = std::rc::Rc::clone(&writer);
        outputs.set_writer(
            path,
            Box::new(move |out| writer.borrow_mut().write_session(k, &description, out)),
        );
    }
    let _progress = Progress::stage(format!("simulating {} poses", args.poses));
    outputs.commit()?;
    Ok(())
}

/// The command line as typed, `armcal simulate --model ur10e.urdf …`: what
/// made a file, for its header. Each argument is quoted where a shell would
/// read it otherwise; `seed`, the seed of the draws when the command has one,
/// is added as `--seed N` when the default was taken, so that the line makes
/// the same file again.
fn command_line(seed: Option<u64>) -> String {
    let quoted = |a: String| {
        let plain = |c: char| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c);
        if !a.is_empty() && a.chars().all(plain) {
            a
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let given = args
        .iter()
        .any(|a| a == "--seed" || a.starts_with("--seed="));
    let mut line = std::iter::once("armcal".to_owned())
        .chain(args.into_iter().map(quoted))
        .collect::<Vec<_>>()
        .join(" ");
    if let (Some(seed), false) = (seed, given) {
        line += &format!(" --seed {seed}");
    }
    line
}

/// `armcal diagnose`.
pub(crate) fn diagnose(args: DiagnoseArgs) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new()
        .model_input(&args.model.model)
        .data_inputs(&args.data)
        .output("--out", args.out.as_deref())
        .output("--json", args.json.as_deref())
        .output("--html", args.html.as_deref());
    outputs.check()?;
    let progress = Progress::stage("reading");
    let frames = args.sessions.sharing();
    let (model, data) = load_session(&args.model, &args.data, frames, &progress)?;
    progress.suspend(|| warn(&data.warnings));
    progress.set(format!("diagnosing {} poses", data.len()));
    // A bar: every candidate is cross-validated.
    let mut bar = |round: usize, i: usize, n: usize| {
        progress.step(i, n, format!("selection round {round}: candidate"));
    };
    let diagnosed = diagnose_cmd::run(CLI, &model, &data, &args.request(), &mut bar);
    progress.finish();
    let mut diagnosed = diagnosed?;
    warn(diagnosed.gravity.as_ref().and_then(|g| g.warning()).iter());
    warn(&diagnosed.session_warnings(&data));
    accept(diagnosed.failed.take(), args.write_failed)?;
    // What it prints, and writes as JSON and HTML: one report.
    let report = diagnosed.report(&data, &data.lines);
    if args.out.is_some() {
        outputs.set("--out", diagnosed.calibration.to_bytes()?);
    }
    if args.json.is_some() {
        let text = serde_json::to_string_pretty(&armcal::report::to_json(&report))?;
        outputs.set("--json", text.into_bytes());
    }
    if args.html.is_some() {
        outputs.set("--html", diagnosed.html(&report, &data).into_bytes());
    }
    finish(outputs, args.quiet, || report.summary())?;
    Ok(())
}

/// `armcal demo`.
pub(crate) fn demo(args: DemoArgs) -> anyhow::Result<()> {
    let DemoArgs { seed, html } = args;
    let mut outputs = output::Outputs::new().output("--html", Some(&html));
    outputs.check()?;
    let demo = armcal::calibration::demo::demo(seed)?;
    outputs.set("--html", demo.html().into_bytes());
    outputs.commit()?;
    print!("{}", demo.summary(&html.display().to_string()));
    Ok(())
}

/// `armcal sweep`.
pub(crate) fn sweep(args: SweepArgs) -> anyhow::Result<()> {
    use armcal::calibration::simulate::ErrorSizes;
    use armcal::calibration::sweep::{Case, KINDS, ROBOTS, Settings};
    let SweepArgs {
        cases,
        seed,
        poses,
        json,
        effect,
        robots,
        errors,
    } = args;
    let mut outputs = output::Outputs::new().output("--json", json.as_deref());
    outputs.check()?;
    // In SI, the built-in robots' units.
    let settings = Settings {
        errors: ErrorSizes::given(errors.link_errors, errors.base_errors, errors.tool_errors),
        effect: effect.and_then(|e| KINDS.iter().position(|k| *k == e)),
        robots: robots
            .iter()
            .filter_map(|r| ROBOTS.iter().position(|k| k == r))
            .collect(),
        ..Settings::new(cases, seed, poses)
    };
    let progress = Progress::stage("sweeping");
    let results = armcal::calibration::sweep::sweep_with(&settings, |i, c| {
        progress.step(
            i + 1,
            cases,
            format!(
                "{} {:?} → {:?}",
                c.robot,
                c.hidden,
                c.found.as_ref().map(|f| f.0)
            ),
        );
    });
    progress.finish();
    let r = armcal::calibration::sweep::rates(&results);
    println!(
        "{} cases: detected {} of {} hidden effects with signal ≥ 5× ({:.0}%); false positives {} of {} pure-geometry cases ({:.0}%); {:.2} s per diagnosis",
        results.len(),
        r.detected,
        r.strong,
        100.0 * r.detected as f64 / r.strong.max(1) as f64,
        r.false_positives,
        r.pure,
        100.0 * r.false_positives as f64 / r.pure.max(1) as f64,
        r.seconds
    );
    for c in results
        .iter()
        .filter(|c| c.hidden.is_some() && c.signal >= 5.0 && !c.detected())
    {
        println!(
            "  missed: {} {:?} joints {:?} (signal {:.1}×) → {:?}",
            c.robot, c.hidden, c.joints, c.signal, c.found
        );
    }
    if json.is_some() {
        // Through a JSON value: its keys in the alphabetical order of the
        // other reports.
        let rows: Vec<_> = results.iter().map(Case::report).collect();
        let rows = armcal::report::to_json(&rows);
        outputs.set("--json", serde_json::to_string_pretty(&rows)?.into_bytes());
        outputs.commit()?;
    }
    Ok(())
}

/// The warnings of a joints file used with `cal`: the reader's, the rows
/// outside the ranges the calibration was identified on ([`ranges::check`]),
/// then `rows_reported` (what the computation said of the rows of `joints`).
fn warn_rows(cal: &Calibration, rows: &JointRows, joints: &str, rows_reported: &[RowWarning]) {
    let outside = ranges::check(cal, rows, RowNames::FileLines);
    let reported: Vec<String> = rows_reported
        .iter()
        .map(|w| w.text(joints, RowNames::FileLines))
        .collect();
    warn(rows.warnings.iter().chain(&outside).chain(&reported));
}

/// `cal` with the working tool `tool` names, its note printed; `cal` as it
/// is without one.
fn with_tool(cal: Calibration, tool: Option<Tool>) -> anyhow::Result<Calibration> {
    let Some(tool) = tool else {
        return Ok(cal);
    };
    let change = tool.apply(CLI, &cal)?;
    eprintln!("armcal: {}", change.note());
    Ok(change.calibration)
}

/// `armcal compensate`.
pub(crate) fn compensate(args: CompensateArgs) -> anyhow::Result<()> {
    let CompensateArgs {
        calibration,
        joints,
        out,
        servo,
        tool,
        tool_model,
    } = args;
    let outputs = joints_outputs(&calibration, &joints, &out)?;
    let cal = with_tool(
        armcal::io::calibration_file::load_calibration(&calibration)?,
        tool_model.tool(&tool),
    )?;
    let rows = measurements::load_joints(&joints, &cal.nominal, &cal.units)?;
    let pacing = if servo {
        Pacing::Servo
    } else {
        Pacing::Program
    };
    let result = compensate::compensate(&cal, &rows, pacing);
    let csv = result.to_csv(&cal, &calibration);
    warn_rows(&cal, &rows, &joints, &result.warnings(&cal));
    finish_csv(outputs, csv)?;
    Ok(())
}

/// `armcal predict`.
pub(crate) fn predict(args: PredictArgs) -> anyhow::Result<()> {
    let PredictArgs {
        calibration,
        joints,
        out,
        tool,
        tool_model,
    } = args;
    let outputs = joints_outputs(&calibration, &joints, &out)?;
    let cal = with_tool(
        armcal::io::calibration_file::load_calibration(&calibration)?,
        tool_model.tool(&tool),
    )?;
    let rows = measurements::load_joints(&joints, &cal.nominal, &cal.units)?;
    let mut predictions = predict::predict(&cal, &rows)?;
    predictions.calibration_file = Some(calibration);
    let csv = predictions.to_csv(&cal.units);
    warn_rows(&cal, &rows, &joints, &[]);
    finish_csv(outputs, csv)?;
    Ok(())
}

/// `armcal reproduce kirchner`.
pub(crate) fn reproduce_kirchner() -> anyhow::Result<()> {
    print!("{}", reproduce::kirchner::report());
    Ok(())
}

/// `armcal stream`.
pub(crate) fn stream(args: StreamArgs) -> anyhow::Result<()> {
    let StreamArgs {
        calibration,
        joints,
        tcp,
        serial,
        out,
        halt,
        tool,
        tool_model,
    } = args;
    let outputs = joints_outputs(&calibration, &joints, &out)?;
    let mut bytes = armcal::io::calibration_file::read_calibration(&calibration)?;
    // Read locally first, so that a bad joints file is refused before the
    // controller is touched; a calibration this armcal refuses is still
    // sent, and the controller says why it refuses it too. With a working
    // tool, the calibration sent is the one with that tool: this armcal
    // must read it.
    let local = match tool_model.tool(&tool) {
        None => Calibration::decode(&bytes),
        Some(tool) => {
            let cal = Calibration::decode(&bytes)
                .map_err(|e| InputError::new(&calibration, 0, 0, e.to_string()))?;
            let cal = with_tool(cal, Some(tool))?;
            bytes = cal.to_bytes()?;
            Ok(cal)
        }
    };
    let rows = match &local {
        Ok(cal) => Some(measurements::load_joints(
            &joints,
            &cal.nominal,
            &cal.units,
        )?),
        Err(_) => None,
    };
    let (port, name) = match (tcp, serial) {
        (Some(address), _) => {
            use std::net::ToSocketAddrs as _;
            if let Err(e) = address.to_socket_addrs() {
                return Err(InputError::argument(
                    "--tcp",
                    format!("{address}: not a HOST:PORT address: {e}"),
                )
                .into());
            }
            (link::open_tcp(&address)?, address)
        }
        (None, Some(path)) => (link::open_serial(&path)?, path),
        (None, None) => anyhow::bail!("give --tcp HOST:PORT or --serial PATH"),
    };
    let (mut session, _) = link::Session::open(port)?;
    match session.load_calibration(&bytes) {
        Ok(_) => {}
        Err(link::StreamError::Refused(reason)) => {
            let mut message = format!("the controller refused the calibration: {reason}");
            if let Err(e) = &local {
                message.push_str(&format!(" (this armcal reads it as: {e})"));
            }
            return Err(InputError::new(&calibration, 0, 0, message).into());
        }
        Err(e) => return Err(e.into()),
    }
    let (Ok(cal), Some(rows)) = (local, rows) else {
        anyhow::bail!(
            "{calibration}: the controller accepted a calibration this armcal refuses: update armcal"
        );
    };
    let streamed = link::stream_rows(&mut session, &rows)?;
    if halt {
        session.status(Request::Halt)?;
    }
    let csv = streamed.to_csv(&cal, &calibration, &name);
    warn_rows(&cal, &rows, &joints, &streamed.warnings(&cal));
    eprintln!("armcal: {}", streamed.summary());
    finish_csv(outputs, csv)?;
    Ok(())
}

/// The stop (SIGINT, SIGTERM) and report (SIGUSR1) signals of `armcal
/// serve`, as flags its loop reads: a stop ramps the correction to none
/// before the run ends.
#[cfg(unix)]
fn serve_signals() -> anyhow::Result<serve_apply::Signals> {
    use signal_hook::consts::{SIGINT, SIGTERM, SIGUSR1};
    let signals = serve_apply::Signals::default();
    for signal in [SIGINT, SIGTERM] {
        signal_hook::flag::register_usize(signal, signals.stop.clone(), signal as usize)?;
    }
    signal_hook::flag::register(SIGUSR1, signals.report.clone())?;
    Ok(signals)
}

/// The stop signal (Ctrl-C) of `armcal serve`, as a flag its loop reads.
#[cfg(not(unix))]
fn serve_signals() -> anyhow::Result<serve_apply::Signals> {
    let signals = serve_apply::Signals::default();
    let stop = signals.stop.clone();
    ctrlc::set_handler(move || stop.store(2, std::sync::atomic::Ordering::Relaxed))?;
    Ok(signals)
}

/// `armcal serve`.
pub(crate) fn serve(args: ServeArgs) -> anyhow::Result<()> {
    use armcal_shared::compensation::Conditions;
    use serve_apply::{Ending, Interface, RsiMode};
    let cal = armcal::io::calibration_file::load_calibration(&args.calibration)?;
    serve_apply::cycle::served_joints(&cal)
        .map_err(|reason| InputError::new(&args.calibration, 0, 0, reason))?;
    let defaults = Conditions {
        temperature: args.temperature,
        payload: args.payload,
    };
    let (flag, address, interface, what) = match (&args.rsi, &args.egm, &args.joints) {
        (Some(address), _, _) => {
            let mode = match args.rsi_mode {
                RsiModeArg::Absolute => RsiMode::Absolute,
                RsiModeArg::Relative => RsiMode::Relative,
            };
            let interface = Interface::Rsi {
                mode,
                sen_type: args.rsi_type.clone(),
            };
            ("--rsi", address, interface, "KUKA RSI")
        }
        (None, Some(address), Some(joints)) => {
            let rows = measurements::load_joints(joints, &cal.nominal, &cal.units)?;
            if rows.rows.is_empty() {
                return Err(InputError::new(joints, 0, 0, "no rows: nothing to stream").into());
            }
            warn_rows(&cal, &rows, joints, &[]);
            let rows = rows
                .rows
                .iter()
                .map(|r| (r.q.clone(), predict::row_conditions(r)))
                .collect();
            ("--egm", address, Interface::Egm { rows }, "ABB EGM")
        }
        _ => anyhow::bail!("give --rsi HOST:PORT, or --egm HOST:PORT with --joints J.csv"),
    };
    let socket = {
        use std::net::ToSocketAddrs as _;
        let addresses: Vec<_> = address
            .to_socket_addrs()
            .map_err(|e| {
                InputError::argument(flag, format!("{address}: not a HOST:PORT address: {e}"))
            })?
            .collect();
        std::net::UdpSocket::bind(&addresses[..])
            .map_err(|e| anyhow::anyhow!("{flag} {address}: cannot bind a UDP socket: {e}"))?
    };
    let signals = serve_signals()?;
    let options = serve_apply::Options {
        cycle: std::time::Duration::from_secs_f64(args.cycle_ms / 1e3),
        timeout: std::time::Duration::from_secs_f64(args.timeout_ms / 1e3),
        max_step: args.max_step.to_radians(),
        conditions: defaults,
    };
    let local = socket.local_addr()?;
    eprintln!(
        "armcal: serving {what} on {local} for {} ({} joints): waiting for the controller",
        args.calibration,
        cal.nominal.links.len()
    );
    let heading = |ending: &str| format!("serve: {what} on {local}: {ending}");
    let served = serve_apply::serve(&socket, &cal, interface, &options, &signals, &mut |s| {
        eprint!("{}", s.text(&heading("so far"), options.cycle));
    });
    let served = match served {
        Ok(served) => served,
        Err(e @ serve_apply::ServeError::JointCount { .. }) => {
            return Err(InputError::argument(flag, e.to_string()).into());
        }
        Err(e) => return Err(e.into()),
    };
    let ending = match served.ending {
        Ending::Silent => format!(
            "ended, the controller silent for {} ms",
            options.timeout.as_millis()
        ),
        Ending::Interrupted(signal) => {
            format!("stopped by signal {signal}, the correction ramped to none")
        }
    };
    eprint!("{}", served.stats.text(&heading(&ending), options.cycle));
    if let Ending::Interrupted(signal) = served.ending {
        std::process::exit(128 + i32::try_from(signal).unwrap_or(0));
    }
    Ok(())
}

/// `armcal export`.
pub(crate) fn export(args: ExportArgs) -> anyhow::Result<()> {
    let request = args.request();
    request.check(CLI)?;
    let mut outputs = output::Outputs::new().input("--calibration", &args.calibration);
    if let Some(m) = &request.model {
        outputs = outputs.input("--model", m);
    }
    let outputs = outputs.output("--out", args.out.as_deref());
    outputs.check()?;
    let exported = export_cmd::run(CLI, &args.calibration, &request)?;
    if let Some(change) = &exported.tool {
        eprintln!("armcal: {}", change.note());
    }
    let held = &exported.held;
    if let Some(note) = &held.note {
        if held.warning {
            warn([note]);
        } else {
            eprintln!("armcal: {note}");
        }
    }
    warn(&exported.warnings);
    finish_csv(outputs, exported.text)?;
    Ok(())
}

/// `armcal models`.
pub(crate) fn models() -> anyhow::Result<()> {
    println!("built-in robot models (use as --model NAME):");
    for name in builtin::MODEL_NAMES {
        println!("  {name}");
    }
    println!("built-in data sets (use as --data NAME):");
    for name in builtin::DATA_NAMES {
        println!("  {name}");
    }
    Ok(())
}
