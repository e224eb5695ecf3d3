//! `armcal`, the robot calibrator's command line.
//!
//! Each verb reads its inputs completely and validates them before it computes or
//! writes anything, so a refused input leaves every output file untouched. Errors
//! print as `file:line:column: what is wrong` and the process exits with status 2
//! (bad input) or 1 (anything else).

use std::process::ExitCode;

use armcal::check;
use std::path::PathBuf;

use armcal::identify::full::FullOptions;
use armcal::identify::paper::PaperOptions;
use armcal::identify::{self, ParamSet};
use armcal::input_error::{InputError, MODEL_FILE, read_text};
use armcal::urdf::{self, ChainSpec};
use armcal::{
    builtin, compensate, contact_check, link, measurements, model_file, output, predict, ranges,
    reproduce, simulate,
};
use armcal_shared::compensation::Pacing;
use armcal_shared::link::Request;
use armcal_shared::{Calibration, TargetFrame};
use clap::{Parser, Subcommand};

mod args;
mod verbs;

/// armcal makes serial robot arms accurate: it identifies the errors of their
/// Denavit-Hartenberg model from measured poses and writes the calibration the
/// motion controller applies.
#[derive(Parser, Debug)]
#[command(name = "armcal", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print what was read from a robot model and a measurement file, and the
    /// error of the nominal model against the measurements.
    Check {
        #[command(flatten)]
        model: ModelArgs,
        /// Measurements: a CSV file (docs/file-formats.md §2) or the name of a built-in data set.
        #[arg(long, value_name = "D.csv|NAME")]
        data: String,
    },
    /// Identify the geometric parameter errors from measured poses, say which
    /// parameters the data cannot separate, and write the calibration.
    Identify {
        #[command(flatten)]
        model: ModelArgs,
        /// Measurements: a CSV file (docs/file-formats.md §2) or the name of a built-in data set.
        #[arg(long, value_name = "D.csv|NAME")]
        data: String,
        /// `full`: every identifiable parameter, base and tool included; `paper`: the
        /// 3M model and iterative regression of Mirman & Gupta (needs full poses).
        #[arg(long, value_enum, default_value = "full")]
        params: Params,
        /// Write the calibration (postcard bytes the firmware loads) here.
        #[arg(long, value_name = "CAL")]
        out: Option<PathBuf>,
        /// Write the report as JSON here.
        #[arg(long, value_name = "R.json")]
        json: Option<PathBuf>,
        #[command(flatten)]
        weights: Weights,
        /// `chosen`: the stated prior (--prior-length, --prior-angle, the model
        /// file's `[prior]`, else 1 mm, 1 mrad) times the factor of 0.1, 0.3, 1,
        /// 3 or 10 that predicts held-out poses best (10-fold cross-validation
        /// of the rows, as `diagnose` chooses it; shown in the summary);
        /// `stated`: the stated prior as it is.
        #[arg(long, value_enum, default_value = "chosen")]
        prior_scale: PriorScaleArg,
        /// The frame the compensation's targets will be given in: `world` (the
        /// measurement frame of these data: the identified base is compensated)
        /// or `base` (the robot's own base frame: the identified base, the
        /// registration of the instrument, is not). Stored in the calibration.
        #[arg(long, value_enum, default_value = "world")]
        targets: Targets,
        /// Write the calibration (and the reports) even when the fit did not
        /// converge or fits its own data worse than the nominal model (the
        /// reason is printed as a warning); otherwise such a fit exits with
        /// status 1 and writes nothing.
        #[arg(long)]
        write_failed: bool,
    },
    /// Where the calibrated robot puts its tool point (and how it turns its tool
    /// frame, when the calibration has orientation) for each row of joint
    /// readings: a CSV with x,y,z (and qw,qx,qy,qz) in the model's units, rows in
    /// the order of the joints file.
    Predict {
        /// The calibration file written by `armcal identify --out`.
        #[arg(long, value_name = "CAL")]
        calibration: String,
        /// Joint readings: a CSV with q1..qM in the model's units (docs/file-formats.md §2;
        /// x, y, z and the quaternion of a measurement file are not read).
        #[arg(long, value_name = "J.csv")]
        joints: String,
        /// Write the predictions here (otherwise they are printed).
        #[arg(long, value_name = "P.csv")]
        out: Option<PathBuf>,
    },
    /// For each row of joint commands computed by the nominal model, the commands
    /// that make the calibrated robot reach the pose the nominal model intended.
    Compensate {
        /// The calibration file written by `armcal identify --out`.
        #[arg(long, value_name = "CAL")]
        calibration: String,
        /// Joint commands: a CSV with q1..qM in the model's units, rows in the order sent.
        #[arg(long, value_name = "J.csv")]
        joints: String,
        /// Write the corrected commands here (otherwise they are printed).
        #[arg(long, value_name = "C.csv")]
        out: Option<PathBuf>,
        /// Run the rows as consecutive servo ticks, as `armcal stream` and the
        /// controller do (warm starts, the per-tick change bound). Without it
        /// each row is a robot program's target point, solved alone to
        /// convergence (the row order still gives the approach directions).
        #[arg(long)]
        servo: bool,
    },
    /// Simulate a measurement session: a true robot (nominal + random geometric,
    /// base and tool errors + hidden effects) measured with noise; writes the
    /// measurements (docs/file-formats.md §2) and, with --truth, what was built in.
    Simulate {
        #[command(flatten)]
        model: ModelArgs,
        /// Poses to measure.
        #[arg(long, default_value_t = 200, value_parser = args::at_least(1, "pose"))]
        poses: usize,
        /// A hidden effect, `NAME[:JOINT[:VALUE]]` (joint from 1, value in SI units);
        /// repeat for several. Names: joint_compliance, gear_transmission, backlash,
        /// thermal_expansion, encoder_scale.
        #[arg(long = "effect", value_name = "NAME[:JOINT[:VALUE]]")]
        effects: Vec<String>,
        /// A hidden Hayati tilt `JOINT:BETA` (rad) between nominally parallel axes.
        #[arg(long = "tilt", value_name = "JOINT:BETA", value_parser = args::tilt)]
        tilts: Vec<args::Tilt>,
        /// Position noise, one standard deviation per axis, model length unit
        /// (default 20 µm).
        #[arg(long, value_name = "LENGTH", value_parser = args::non_negative)]
        noise: Option<f64>,
        /// Also measure orientations, with this noise (model angle unit).
        #[arg(long, value_name = "ANGLE", value_parser = args::non_negative)]
        orientation_noise: Option<f64>,
        /// Seed of every random draw.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Write the measurements here.
        #[arg(long, value_name = "D.csv")]
        out: PathBuf,
        /// Write what was built in (errors and effects) here, as JSON.
        #[arg(long, value_name = "T.json")]
        truth: Option<PathBuf>,
    },
    /// Load a calibration into the controller over its serial link, stream joint
    /// commands through it row by row and write the corrected commands it
    /// returns (model units, like `compensate`); report its faults and deadline
    /// misses. A calibration the controller refuses is named with its reason
    /// (exit status 2).
    #[command(group = clap::ArgGroup::new("port").required(true).multiple(false))]
    Stream {
        /// The calibration file written by `armcal identify --out`, sent as it is.
        #[arg(long, value_name = "CAL")]
        calibration: String,
        /// Joint commands: a CSV with q1..qM in the model's units (and optionally
        /// temp, load), rows in the order sent.
        #[arg(long, value_name = "J.csv")]
        joints: String,
        /// The controller's link over TCP (a serial-to-network bridge, or QEMU's
        /// `-serial tcp:…`).
        #[arg(long, value_name = "HOST:PORT", group = "port")]
        tcp: Option<String>,
        /// The controller's serial port (115200 baud, 8N1).
        #[arg(long, value_name = "PATH", group = "port")]
        serial: Option<String>,
        /// Write the corrected commands here (otherwise they are printed).
        #[arg(long, value_name = "C.csv")]
        out: Option<PathBuf>,
        /// After the stream, ask the controller to halt (under QEMU this ends the
        /// emulation; a real controller waits for a reset).
        #[arg(long)]
        halt: bool,
    },
    /// Fit the geometry, show what it gets wrong, name the cause, extend the model
    /// and measure the gain on held-out poses.
    Diagnose {
        #[command(flatten)]
        model: ModelArgs,
        /// Measurements: a CSV file or the name of a built-in data set.
        #[arg(long, value_name = "D.csv|NAME")]
        data: String,
        /// Write the extended calibration (geometry and effects) here.
        #[arg(long, value_name = "CAL")]
        out: Option<PathBuf>,
        /// Write the report as JSON here.
        #[arg(long, value_name = "R.json")]
        json: Option<PathBuf>,
        /// Write a self-contained HTML page (inline SVG plots) here.
        #[arg(long, value_name = "R.html")]
        html: Option<PathBuf>,
        #[command(flatten)]
        weights: Weights,
        /// Folds of the cross-validation, from 2 to the number of poses
        /// (default: 10, or one per pose with fewer poses).
        #[arg(long, value_parser = args::at_least(2, "folds"))]
        folds: Option<usize>,
        /// The frame the compensation's targets will be given in: `world` (the
        /// measurement frame of these data: the identified base is compensated)
        /// or `base` (the robot's own base frame: the identified base, the
        /// registration of the instrument, is not). Stored in the calibration.
        #[arg(long, value_enum, default_value = "world")]
        targets: Targets,
        /// Write the calibration (and the reports) even when the fit did not
        /// converge or fits its own data worse than the nominal model (the
        /// reason is printed as a warning); otherwise such a fit exits with
        /// status 1 and writes nothing.
        #[arg(long)]
        write_failed: bool,
    },
    /// Measure the diagnosis: hide a random effect (or none) in many simulated
    /// sessions and count how often it is named.
    Sweep {
        /// Cases to run.
        #[arg(long, default_value_t = 100)]
        cases: usize,
        /// Seed of every draw.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Tracker positions per simulated session (at least 20).
        #[arg(long, default_value_t = 300, value_parser = args::at_least(20, "positions per session"))]
        poses: usize,
        /// Write every case as JSON here.
        #[arg(long, value_name = "R.json")]
        json: Option<PathBuf>,
    },
    /// The whole of armcal on a simulated robot, no files needed: the Table 1 PUMA
    /// with random geometric errors and one hidden effect drawn from the seed,
    /// measured by a simulated laser tracker, diagnosed (what the geometric model
    /// gets wrong, and the named cause), 50 random targets compensated and checked
    /// on the true robot; writes the HTML report and prints the gain.
    Demo {
        /// Seed of every draw (the default is fixed, so the demo repeats; any other
        /// seed draws other geometric errors and another effect).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Write the HTML report here.
        #[arg(long, value_name = "R.html", default_value = "armcal-demo.html")]
        html: PathBuf,
    },
    /// Write a calibration as a URDF: into the URDF its model was read from
    /// (only the origins of the chain's moving joints change), or generated from
    /// the calibrated model; with two links added, `armcal_measured_point` (the
    /// calibrated measured point) and `armcal_measurement_frame` (the
    /// calibration's measurement frame). Effects other than geometry are left
    /// out, with a warning.
    Export {
        /// The calibration file written by `armcal identify --out` or `armcal diagnose --out`.
        #[arg(long, value_name = "CAL")]
        calibration: String,
        /// `--format urdf`: the URDF the calibration's model was read from (with
        /// the same --base-link, --tip-link and --tip-point); without it, a URDF
        /// is generated from the calibrated model. `--format ur-deltas` and
        /// `ur-calibration`: the Universal Robots model (ur5e, ur10, ur10e) whose
        /// nominal the deltas are against (required).
        #[arg(long, value_name = "M.urdf|NAME")]
        model: Option<String>,
        #[command(flatten)]
        chain: ChainArgs,
        /// The format to write.
        #[arg(long, value_enum)]
        format: ExportFormat,
        /// Write it here (otherwise it is printed).
        #[arg(long, value_name = "OUT.urdf")]
        out: Option<PathBuf>,
    },
    /// Sessions without a tracker (a `point` column: unknown fixed points and
    /// known distances; docs/file-formats.md): leave each --data session out
    /// in turn, identify on the others (or on --train), and print for the one
    /// left out the spread of the predicted points at each fixed point and the
    /// error of each known distance, for the nominal model, --reference and
    /// the calibration.
    Holdout {
        #[command(flatten)]
        model: ModelArgs,
        /// Constraint sessions to hold out, each in turn (CSV with a `point` column).
        #[arg(long, value_name = "D.csv", required = true, num_args = 1..)]
        data: Vec<String>,
        /// Identify once on these sessions instead, and check every --data session.
        #[arg(long, value_name = "T.csv", num_args = 1..)]
        train: Vec<String>,
        /// Another model of the same chain to check on the same rows (read with
        /// the same --base-link, --tip-link and --tip-point): another tool's
        /// calibration, for instance.
        #[arg(long, value_name = "R.urdf|R.toml")]
        reference: Option<String>,
        #[command(flatten)]
        weights: Weights,
        /// The prior's scale the training sessions are identified at, as
        /// `armcal identify --prior-scale` (shown beside the figures).
        #[arg(
            long,
            value_enum,
            default_value = "chosen",
            conflicts_with = "diagnose"
        )]
        prior_scale: PriorScaleArg,
        /// Calibrate the training sessions as `armcal diagnose` does: blunders
        /// set aside, the geometric model and the prior's scale chosen by
        /// 10-fold cross-validation of their rows, the effects the data name
        /// (the choice shown beside the figures, its effects in the prediction).
        #[arg(long)]
        diagnose: bool,
    },
    /// List the built-in robot models and data sets.
    Models,
    /// Rebuild the worked examples of a seed paper and print them as the paper does.
    Reproduce {
        /// Which paper.
        #[arg(value_enum)]
        paper: Paper,
    },
}

/// The robot model and, for a URDF, which chain of it to read.
#[derive(clap::Args, Debug)]
struct ModelArgs {
    /// Robot model: a TOML file (docs/file-formats.md §1), a URDF (`*.urdf`, or text
    /// starting with `<`; docs/urdf.md) or the name of a built-in model.
    #[arg(long, value_name = "M.toml|M.urdf|NAME")]
    model: String,
    #[command(flatten)]
    chain: ChainArgs,
    /// Universal Robots model: the controller's factory calibration (YAML with
    /// `delta_theta`, `delta_a`, `delta_d`, `delta_alpha`; docs/ur.md), added to
    /// the nominal D-H and read as the robot's nominal model.
    #[arg(long, value_name = "CAL.yaml")]
    factory_calibration: Option<String>,
}

impl ModelArgs {
    /// The model these flags name.
    fn load(&self) -> Result<model_file::RobotModel, InputError> {
        let model = model_file::load_model_with(&self.model, &self.chain.spec())?;
        match &self.factory_calibration {
            None => Ok(model),
            Some(file) => armcal::ur::load_factory(&model, file),
        }
    }
}

/// Which chain of a URDF model is the arm, and where on it the measured point is.
#[derive(clap::Args, Debug)]
struct ChainArgs {
    /// URDF model: the link the chain starts from, whose frame is the robot's
    /// base (default: the root link).
    #[arg(long, value_name = "LINK")]
    base_link: Option<String>,
    /// URDF model: the link the chain ends at, which carries the measured point
    /// (default: followed down from the base while one branch holds the moving
    /// joints).
    #[arg(long, value_name = "LINK")]
    tip_link: Option<String>,
    /// URDF model: the measured point in the tip link's frame, `x,y,z` in m
    /// (default: the tip link's origin).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = args::tip_point)]
    tip_point: Option<nalgebra::Vector3<f64>>,
}

impl ChainArgs {
    /// The chain these flags name.
    fn spec(&self) -> ChainSpec {
        ChainSpec {
            base_link: self.base_link.clone(),
            tip_link: self.tip_link.clone(),
            tip_point: self.tip_point,
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum ExportFormat {
    /// URDF (ROS robot description).
    Urdf,
    /// Universal Robots factory calibration: D-H deltas against the UR model
    /// given with --model (docs/ur.md).
    UrDeltas,
    /// Universal Robots: ur_calibration's URDF-correction YAML (joint origins
    /// for ur_description; docs/ur.md).
    UrCalibration,
}

/// The folds of the diagnosis' cross-validation unless `--folds` says otherwise.
use armcal::identify::prior_scale::{DEFAULT_FOLDS, PriorScale};

/// The noise and the prior: what weighs the rows and the parameters.
#[derive(clap::Args, Debug)]
struct Weights {
    /// Position noise of the measurements, one standard deviation per axis, in
    /// the model's length unit (default: estimated from the residuals); also
    /// the noise of the contacts of a session without a tracker whose kind
    /// has none stated.
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    position_noise: Option<f64>,
    /// Orientation noise, one standard deviation per axis, in the model's angle
    /// unit (default: estimated from the residuals).
    #[arg(long, value_name = "ANGLE", value_parser = args::positive)]
    orientation_noise: Option<f64>,
    /// Noise of a tool point at an unknown fixed point (`point` column), per
    /// axis, model length unit (default: `--position-noise`, else estimated
    /// from the residuals of those rows alone).
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    point_noise: Option<f64>,
    /// Noise of a tool point on an unknown plane (`plane` column), along its
    /// normal, model length unit (default: `--position-noise`, else estimated
    /// from the residuals of those rows alone).
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    plane_noise: Option<f64>,
    /// Prior scale of a D-H length error (s, a), one standard deviation, model
    /// length unit (default: the model file's `[prior]`, else 1 mm).
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    prior_length: Option<f64>,
    /// Prior scale of a D-H angle error (θ, α), model angle unit (default: the
    /// model file's `[prior]`, else 1 mrad).
    #[arg(long, value_name = "ANGLE", value_parser = args::positive)]
    prior_angle: Option<f64>,
}

impl Weights {
    /// The fit options these flags and the model file's prior give.
    fn options(&self, model: &model_file::RobotModel) -> Result<FullOptions, InputError> {
        let scales = identify::StatedScales {
            position_noise: self.position_noise,
            orientation_noise: self.orientation_noise,
            point_noise: self.point_noise,
            plane_noise: self.plane_noise,
            prior_length: self.prior_length,
            prior_angle: self.prior_angle,
        };
        scales.options(model).map_err(|e| {
            InputError::argument(e.flag, format!("{}: must be a positive number", e.value))
        })
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum PriorScaleArg {
    /// The stated scale times the factor that predicts held-out poses best.
    Chosen,
    /// The stated scale.
    Stated,
}

impl From<PriorScaleArg> for PriorScale {
    fn from(a: PriorScaleArg) -> Self {
        match a {
            PriorScaleArg::Chosen => PriorScale::Chosen {
                folds: DEFAULT_FOLDS,
            },
            PriorScaleArg::Stated => PriorScale::Stated,
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum Params {
    /// Every identifiable geometric parameter, base and tool included.
    Full,
    /// The 3M position-independent model of Mirman & Gupta.
    Paper,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum Targets {
    /// The world (measurement) frame.
    World,
    /// The robot's own base frame.
    Base,
}

impl From<Targets> for TargetFrame {
    fn from(t: Targets) -> Self {
        match t {
            Targets::World => TargetFrame::World,
            Targets::Base => TargetFrame::Base,
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum Paper {
    /// Mirman & Gupta (1992): Tables 2 and 3, the iterative regression on the Table 1 PUMA.
    MirmanGupta,
    /// Kirchner, Gurumoorthy & Prinz (1985): the second-order expansion (eq. 2.22)
    /// and the series inversion of section 3 beside the iterative regression.
    Kirchner,
}

fn main() -> ExitCode {
    // An interrupt (Ctrl-C, SIGTERM) ends the run as it would, but leaves no
    // temporary of the outputs being written (exit status 130).
    let _ = ctrlc::set_handler(|| {
        armcal::output::remove_pending();
        std::process::exit(130);
    });
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("armcal: error: {err}");
            let mut source = err.source();
            while let Some(cause) = source {
                eprintln!("  caused by: {cause}");
                source = cause.source();
            }
            if is_bad_input(&err) {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// Whether `err` refuses what the user gave (a file, an argument, data that
/// cannot carry the computation): exit status 2. Anything else is a failure
/// of the program or the machine: 1.
fn is_bad_input(err: &anyhow::Error) -> bool {
    use armcal::identify::{IdentifyError, full::FullError, paper::PaperError};
    err.downcast_ref::<InputError>().is_some()
        || err.downcast_ref::<FullError>().is_some()
        || err.downcast_ref::<PaperError>().is_some()
        || err
            .downcast_ref::<IdentifyError>()
            .is_some_and(|e| !matches!(e, IdentifyError::Calibration(_)))
}

/// The model and the measurements of a session, refused if the poses give fewer
/// equations than the model's independent parameters or if they cannot be
/// measurements of this robot ([`measurements::Measurements::require_plausible`]);
/// what the user should know of the data (columns not read, readings outside the
/// limits) is printed as warnings.
fn load_session(
    model: &ModelArgs,
    data: &str,
) -> anyhow::Result<(model_file::RobotModel, measurements::Measurements)> {
    let model = model.load()?;
    let data = measurements::load_measurements(data, &model)?;
    data.require_poses(
        &model.robot,
        check::independent_parameter_count(&model.robot, data.has_orientation()),
    )?;
    data.require_plausible(&model)?;
    Ok((model, data))
}

/// A one-line progress display on standard error, redrawn in place (`\r`), shown
/// only when standard error is a terminal: the one progress bar of `diagnose`
/// and `sweep`.
struct Progress {
    tty: bool,
}

impl Progress {
    /// A progress line on standard error, silent unless it is a terminal.
    fn on_stderr() -> Self {
        use std::io::IsTerminal as _;
        Self {
            tty: std::io::stderr().is_terminal(),
        }
    }

    /// Redraws the line with `line()` (not called when nothing is shown).
    fn show(&self, line: impl FnOnce() -> String) {
        if self.tty {
            eprint!("\r{}", line());
        }
    }

    /// Ends the line, so what follows starts on a new one.
    fn finish(&self) {
        if self.tty {
            eprintln!();
        }
    }
}

/// Prints warnings (of a data file, of a computation) to standard error.
fn warn<'a>(warnings: impl IntoIterator<Item = &'a String>) {
    for w in warnings {
        eprintln!("armcal: warning: {w}");
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Check { model, data } => verbs::check(model, data),
        Command::Holdout {
            model,
            data,
            train,
            reference,
            weights,
            prior_scale,
            diagnose,
        } => {
            let selection = match (prior_scale, diagnose) {
                (_, true) => contact_check::Selection::Diagnosis {
                    folds: DEFAULT_FOLDS,
                },
                (PriorScaleArg::Chosen, false) => contact_check::Selection::Prior {
                    folds: DEFAULT_FOLDS,
                },
                (PriorScaleArg::Stated, false) => contact_check::Selection::Stated,
            };
            verbs::holdout(model, data, train, reference, weights, selection)
        }
        Command::Reproduce {
            paper: Paper::MirmanGupta,
        } => verbs::reproduce_mirman_gupta(),
        Command::Identify {
            model,
            data,
            params,
            out,
            json,
            weights,
            prior_scale,
            targets,
            write_failed,
        } => verbs::identify(
            model,
            data,
            params,
            out,
            json,
            weights,
            prior_scale.into(),
            targets,
            write_failed,
        ),
        Command::Simulate {
            model,
            poses,
            effects,
            tilts,
            noise,
            orientation_noise,
            seed,
            out,
            truth,
        } => verbs::simulate(
            model,
            poses,
            effects,
            tilts,
            noise,
            orientation_noise,
            seed,
            out,
            truth,
        ),
        Command::Diagnose {
            model,
            data,
            out,
            json,
            html,
            weights,
            folds,
            targets,
            write_failed,
        } => verbs::diagnose(
            model,
            data,
            out,
            json,
            html,
            weights,
            folds,
            targets,
            write_failed,
        ),
        Command::Demo { seed, html } => verbs::demo(seed, html),
        Command::Sweep {
            cases,
            seed,
            poses,
            json,
        } => verbs::sweep(cases, seed, poses, json),
        Command::Compensate {
            calibration,
            joints,
            out,
            servo,
        } => verbs::compensate(calibration, joints, out, servo),
        Command::Predict {
            calibration,
            joints,
            out,
        } => verbs::predict(calibration, joints, out),
        Command::Reproduce {
            paper: Paper::Kirchner,
        } => verbs::reproduce_kirchner(),
        Command::Stream {
            calibration,
            joints,
            tcp,
            serial,
            out,
            halt,
        } => verbs::stream(calibration, joints, tcp, serial, out, halt),
        Command::Export {
            calibration,
            model,
            chain,
            format: ExportFormat::Urdf,
            out,
        } => verbs::export_urdf(calibration, model, chain, out),
        Command::Export {
            calibration,
            model,
            chain,
            format: format @ (ExportFormat::UrDeltas | ExportFormat::UrCalibration),
            out,
        } => verbs::export_ur(calibration, model, chain, format, out),
        Command::Models => verbs::models(),
    }
}

/// Refuses (exit status 1) the calibration `refusal` names unless
/// `write_failed`, in which case its reason is printed as a warning.
fn accept(
    refusal: Option<armcal::acceptance::FailedCalibration>,
    write_failed: bool,
) -> anyhow::Result<()> {
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
/// written), or prints the human summary when none was asked for.
fn finish(outputs: output::Outputs, summary: impl FnOnce() -> String) -> anyhow::Result<()> {
    if outputs.is_empty() {
        print!("{}", summary());
    }
    outputs.commit()
}

/// The checked `--out` of a verb that reads a calibration and a joints file.
fn joints_outputs(
    calibration: &str,
    joints: &str,
    out: &Option<PathBuf>,
) -> Result<output::Outputs, InputError> {
    let outputs = output::Outputs::new()
        .input("--calibration", calibration)
        .input("--joints", joints)
        .output("--out", out.as_deref());
    outputs.check()?;
    Ok(outputs)
}

/// Writes `csv` to the planned `--out`, or prints it when none was asked for.
fn finish_csv(mut outputs: output::Outputs, csv: String) -> anyhow::Result<()> {
    if outputs.is_empty() {
        print!("{csv}");
        return Ok(());
    }
    outputs.set("--out", csv.into_bytes());
    outputs.commit()
}
