//! One function per verb of `armcal`: what `main.rs`'s `run` calls with the
//! verb's parsed flags. The flags themselves, and the helpers the verbs share,
//! are in `main.rs`.

use super::*;
use armcal::commands::{self, Front};

/// `armcal check`.
pub(crate) fn check(model: ModelArgs, data: String) -> anyhow::Result<()> {
    let (model, data) = load_session(&model, &data)?;
    print!("{}", check::report(&model, &data));
    Ok(())
}

/// `armcal holdout`.
pub(crate) fn holdout(
    model: ModelArgs,
    data: Vec<String>,
    train: Vec<String>,
    reference: Option<String>,
    weights: Weights,
    selection: contact_check::Selection,
) -> anyhow::Result<()> {
    let chain = model.chain.spec();
    let model = model.load()?;
    let load = |file: &String| -> anyhow::Result<measurements::Measurements> {
        let d = measurements::load_measurements(file, &model)?;
        contact_check::require_session(&d)?;
        warn(&d.warnings);
        Ok(d)
    };
    let sessions = data.iter().map(load).collect::<anyhow::Result<Vec<_>>>()?;
    let training = train.iter().map(load).collect::<anyhow::Result<Vec<_>>>()?;
    let reference_model = match &reference {
        Some(path) => Some(model_file::load_model_with(path, &chain)?),
        None => None,
    };
    commands::holdout_sessions(
        Front::CommandLine,
        &model,
        &sessions,
        &training,
        reference_model.as_ref(),
    )?;
    let options = weights.options(&model)?;
    let reference_robot = reference_model.as_ref().map(|r| &r.robot);
    let rows = contact_check::held_out(
        &model,
        &sessions,
        &training,
        reference_robot,
        &options,
        selection,
    )?;
    print!(
        "{}",
        contact_check::holdout_table(&rows, reference.as_deref().map(|_| "reference"))
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
#[allow(clippy::too_many_arguments)]
pub(crate) fn identify(
    model: ModelArgs,
    data: String,
    params: Params,
    out: Option<PathBuf>,
    json: Option<PathBuf>,
    weights: Weights,
    prior_scale: PriorScale,
    targets: Targets,
    write_failed: bool,
) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new()
        .model_input(&model.model)
        .data_input(&data)
        .output("--out", out.as_deref())
        .output("--json", json.as_deref());
    outputs.check()?;
    let (model, data) = load_session(&model, &data)?;
    warn(&data.warnings);
    let options = weights.options(&model)?;
    let set = match params {
        Params::Full => ParamSet::Full,
        Params::Paper => ParamSet::Paper,
    };
    let mut result = identify::identify(&model, &data, set, &options, prior_scale)?;
    data.require_fit_supported(&model, result.position_rms)?;
    accept(
        result.refusal(&model, &data, "--write-failed"),
        write_failed,
    )?;
    result.calibration.targets = targets.into();
    // Everything is computed and encoded before the first byte is written.
    if out.is_some() {
        outputs.set("--out", result.calibration.to_bytes()?);
    }
    if json.is_some() {
        let text = serde_json::to_string_pretty(&result.to_json(&model.units))?;
        outputs.set("--json", text.into_bytes());
    }
    finish(outputs, || result.summary(&model, &data))?;
    Ok(())
}

/// `armcal simulate`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn simulate(
    model: ModelArgs,
    poses: usize,
    effects: Vec<String>,
    tilts: Vec<args::Tilt>,
    noise: Option<f64>,
    orientation_noise: Option<f64>,
    seed: u64,
    out: PathBuf,
    truth: Option<PathBuf>,
) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new()
        .model_input(&model.model)
        .output("--out", Some(&out))
        .output("--truth", truth.as_deref());
    outputs.check()?;
    let model = model.load()?;
    let u = model.units;
    let dof = model.robot.dof();
    let mut scenario = simulate::Scenario::tracker(poses, seed);
    if let Some(n) = noise {
        scenario.position_noise = u.length_to_si(n);
    }
    if let Some(n) = orientation_noise {
        scenario.orientation_noise = Some(u.angle_to_si(n));
    }
    for spec in &effects {
        scenario.effects.push(
            simulate::parse_effect(spec, dof).map_err(|e| InputError::argument("--effect", e))?,
        );
    }
    for tilt in &tilts {
        if tilt.joint > dof {
            return Err(InputError::argument(
                "--tilt",
                format!(
                    "{}:{}: the joint must be from 1 to {dof}",
                    tilt.joint, tilt.beta
                ),
            )
            .into());
        }
        scenario.tilts.push((tilt.joint - 1, tilt.beta));
    }
    let session = simulate::simulate(&model.robot, &scenario)?;
    let description = format!(
        "armcal simulate --model {} --poses {poses} --seed {seed}{}{}",
        model.name,
        effects
            .iter()
            .map(|e| format!(" --effect {e}"))
            .collect::<String>(),
        tilts
            .iter()
            .map(|t| format!(" --tilt {}:{}", t.joint, t.beta))
            .collect::<String>()
    );
    outputs.set("--out", session.to_csv(&u, &description).into_bytes());
    if truth.is_some() {
        let json = serde_json::to_string_pretty(&session.truth_json(&model.robot, &u))?;
        outputs.set("--truth", json.into_bytes());
    }
    outputs.commit()?;
    Ok(())
}

/// `armcal diagnose`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn diagnose(
    model: ModelArgs,
    data: String,
    out: Option<PathBuf>,
    json: Option<PathBuf>,
    html: Option<PathBuf>,
    weights: Weights,
    folds: Option<usize>,
    targets: Targets,
    write_failed: bool,
) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new()
        .model_input(&model.model)
        .data_input(&data)
        .output("--out", out.as_deref())
        .output("--json", json.as_deref())
        .output("--html", html.as_deref());
    outputs.check()?;
    let (model, data) = load_session(&model, &data)?;
    warn(&data.warnings);
    let folds = commands::folds(Front::CommandLine, folds, data.len())?;
    let options = armcal::diagnose::DiagnoseOptions {
        folds,
        fit: weights.options(&model)?,
        ..Default::default()
    };
    let observations = identify::observations(&data);
    // A progress bar on a terminal: every candidate is cross-validated.
    let progress = Progress::on_stderr();
    let mut bar = |round: usize, i: usize, n: usize| {
        progress.show(|| {
            let filled = 30 * i / n.max(1);
            format!(
                "selection round {round}: [{}{}] candidate {i}/{n}",
                "#".repeat(filled),
                ".".repeat(30 - filled)
            )
        });
    };
    let diagnosis = armcal::diagnose::diagnose_with_progress(
        &model.robot,
        observations,
        &data.constraints,
        &options,
        &mut bar,
    )?;
    progress.finish();
    data.require_fit_supported(&model, diagnosis.reference.position_rms)?;
    accept(
        armcal::acceptance::diagnosis_refusal(&model, &data, &diagnosis, "--write-failed"),
        write_failed,
    )?;
    let lines = &data.lines;
    if out.is_some() {
        let mut cal = diagnosis.calibration(&model.robot, data.has_orientation(), model.units);
        cal.targets = targets.into();
        outputs.set("--out", cal.to_bytes()?);
    }
    if json.is_some() {
        let text = serde_json::to_string_pretty(&diagnosis.to_json(&model, lines, &options))?;
        outputs.set("--json", text.into_bytes());
    }
    if html.is_some() {
        let page = armcal::report::html(&model, &data.file, &diagnosis, observations, &options);
        outputs.set("--html", page.into_bytes());
    }
    finish(outputs, || diagnosis.summary(lines, &options, &model.units))?;
    Ok(())
}

/// `armcal demo`.
pub(crate) fn demo(seed: u64, html: PathBuf) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new().output("--html", Some(&html));
    outputs.check()?;
    let demo = armcal::demo::demo(seed)?;
    outputs.set("--html", demo.html().into_bytes());
    outputs.commit()?;
    print!("{}", demo.summary(&html.display().to_string()));
    Ok(())
}

/// `armcal sweep`.
pub(crate) fn sweep(
    cases: usize,
    seed: u64,
    poses: usize,
    json: Option<PathBuf>,
) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new().output("--json", json.as_deref());
    outputs.check()?;
    let progress = Progress::on_stderr();
    let results = armcal::sweep::sweep(cases, seed, poses, |i, c| {
        progress.show(|| {
            format!(
                "case {}/{cases}: {} {:?} → {:?}      ",
                i + 1,
                c.robot,
                c.hidden,
                c.found.as_ref().map(|f| f.0)
            )
        });
    });
    progress.finish();
    let r = armcal::sweep::rates(&results);
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
        let rows: Vec<serde_json::Value> = results
            .iter()
            .map(|c| serde_json::json!({
                "robot": c.robot, "hidden": c.hidden, "joints": c.joints.iter().map(|j| j + 1).collect::<Vec<_>>(),
                "signal": c.signal, "found": c.found.as_ref().map(|f| f.0), "named": c.named, "seconds": c.seconds,
                "detected": c.detected(),
            }))
            .collect();
        outputs.set("--json", serde_json::to_string_pretty(&rows)?.into_bytes());
        outputs.commit()?;
    }
    Ok(())
}

/// The warnings of a joints file used with `cal`: the reader's, the rows
/// outside the ranges the calibration was identified on ([`ranges::check`]),
/// then `rows_reported` (what the computation said of single rows).
fn warn_rows(cal: &Calibration, rows: &measurements::JointRows, rows_reported: &[String]) {
    let outside = ranges::check(cal, rows, ranges::RowNames::FileLines);
    warn(rows.warnings.iter().chain(&outside).chain(rows_reported));
}

/// `armcal compensate`.
pub(crate) fn compensate(
    calibration: String,
    joints: String,
    out: Option<PathBuf>,
    servo: bool,
) -> anyhow::Result<()> {
    let outputs = joints_outputs(&calibration, &joints, &out)?;
    let cal = predict::load_calibration(&calibration)?;
    let rows = measurements::load_joints(&joints, &cal.nominal, &cal.units)?;
    let pacing = if servo {
        Pacing::Servo
    } else {
        Pacing::Program
    };
    let result = compensate::compensate(&cal, &rows, pacing);
    let csv = result.to_csv(&cal, &calibration);
    warn_rows(&cal, &rows, &result.warnings(&joints));
    finish_csv(outputs, csv)?;
    Ok(())
}

/// `armcal predict`.
pub(crate) fn predict(
    calibration: String,
    joints: String,
    out: Option<PathBuf>,
) -> anyhow::Result<()> {
    let outputs = joints_outputs(&calibration, &joints, &out)?;
    let cal = predict::load_calibration(&calibration)?;
    let rows = measurements::load_joints(&joints, &cal.nominal, &cal.units)?;
    let mut predictions = predict::predict(&cal, &rows)?;
    predictions.calibration_file = Some(calibration);
    let csv = predictions.to_csv(&cal.units);
    warn_rows(&cal, &rows, &[]);
    finish_csv(outputs, csv)?;
    Ok(())
}

/// `armcal reproduce kirchner`.
pub(crate) fn reproduce_kirchner() -> anyhow::Result<()> {
    print!("{}", reproduce::kirchner::report());
    Ok(())
}

/// `armcal stream`.
pub(crate) fn stream(
    calibration: String,
    joints: String,
    tcp: Option<String>,
    serial: Option<String>,
    out: Option<PathBuf>,
    halt: bool,
) -> anyhow::Result<()> {
    let outputs = joints_outputs(&calibration, &joints, &out)?;
    let bytes = predict::read_calibration(&calibration)?;
    // Read locally first, so that a bad joints file is refused before the
    // controller is touched; a calibration this armcal refuses is still
    // sent, and the controller says why it refuses it too.
    let local = Calibration::decode(&bytes);
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
    warn_rows(&cal, &rows, &streamed.warnings(&joints));
    eprintln!("armcal: {}", streamed.summary());
    finish_csv(outputs, csv)?;
    Ok(())
}

/// `armcal export --format urdf`.
pub(crate) fn export_urdf(
    calibration: String,
    model: Option<String>,
    chain: ChainArgs,
    out: Option<PathBuf>,
) -> anyhow::Result<()> {
    let mut outputs = output::Outputs::new().input("--calibration", &calibration);
    if let Some(m) = &model {
        outputs = outputs.input("--model", m);
    }
    let outputs = outputs.output("--out", out.as_deref());
    outputs.check()?;
    let spec = chain.spec();
    let loaded = predict::load_calibration(&calibration)?;
    // The geometry refitted without the effects a URDF cannot carry, when the
    // calibration has one.
    let held = armcal::export::geometry_only(&loaded, "a URDF");
    let cal = &held.calibration;
    let exported = match &model {
        Some(m) => {
            let text = read_text(m, MODEL_FILE)?;
            if !urdf::is_urdf(m, &text) {
                return Err(InputError::argument(
                    "--model",
                    format!("{m} is not a URDF: export writes into the URDF the model was read from; leave out --model to generate a URDF from the calibration"),
                )
                .into());
            }
            let (parsed, converted) = model_file::urdf_chain(&text, m, &spec)?;
            urdf::export::into_urdf(cal, &parsed, &converted)?
        }
        None if !spec.is_default() => {
            return Err(InputError::argument(
                "--model",
                "--base-link, --tip-link and --tip-point name a chain of the URDF given with --model: give it",
            )
            .into());
        }
        None => urdf::export::generate(cal, &calibration),
    };
    note(&held);
    warn(&exported.warnings);
    finish_csv(outputs, exported.text)?;
    Ok(())
}

/// `armcal export --format ur-deltas|ur-calibration`.
pub(crate) fn export_ur(
    calibration: String,
    model: Option<String>,
    chain: ChainArgs,
    format: ExportFormat,
    out: Option<PathBuf>,
) -> anyhow::Result<()> {
    let Some(m) = model else {
        return Err(InputError::argument(
            "--model",
            "--format ur-deltas and ur-calibration: give the UR model (ur5e, ur10, ur10e; the deltas are against its nominal)",
        )
        .into());
    };
    let outputs = output::Outputs::new()
        .input("--calibration", &calibration)
        .input("--model", &m)
        .output("--out", out.as_deref());
    outputs.check()?;
    let nominal = model_file::load_model_with(&m, &chain.spec())?;
    if !armcal::ur::is_ur_model(&nominal) {
        return Err(InputError::argument(
            "--model",
            format!("--format ur-deltas and ur-calibration: {m} is not a Universal Robots model (named `ur` and a digit, standard D-H, six revolute joints)"),
        )
        .into());
    }
    let loaded = predict::load_calibration(&calibration)?;
    let held = armcal::export::geometry_only(
        &loaded,
        match format {
            ExportFormat::UrDeltas => "a UR deltas file",
            _ => "a ur_calibration file",
        },
    );
    let cal = &held.calibration;
    let robot = cal.calibrated();
    if robot.dof() != armcal::ur::JOINTS
        || robot
            .links
            .iter()
            .any(|l| l.joint != armcal_shared::JointType::Revolute)
    {
        return Err(InputError::argument(
            "--calibration",
            format!("--format ur-deltas and ur-calibration: {calibration} is not of a six-joint revolute arm"),
        )
        .into());
    }
    armcal::ur::require_same_type(&cal.nominal, &nominal, &calibration)?;
    let exported = armcal::ur::export_deltas(&robot, &nominal.robot);
    let text = if matches!(format, ExportFormat::UrDeltas) {
        armcal::ur::deltas_yaml(&exported, &calibration)
    } else {
        armcal::ur::ur_calibration_yaml(&exported, &calibration)
    };
    note(&held);
    finish_csv(outputs, text)?;
    Ok(())
}

/// The note of an export that cannot carry effects on standard error: a
/// warning when it leaves them out with the geometry fitted with them.
fn note(held: &armcal::export::GeometryExport) {
    if let Some(note) = &held.note {
        if held.warning {
            warn([note]);
        } else {
            eprintln!("armcal: {note}");
        }
    }
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
