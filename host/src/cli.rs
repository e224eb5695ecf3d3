//! The command line's flags: clap's description of every verb, and the
//! checked request of `armcal::commands` each verb's flags make. Nothing here
//! reads a file; the value parsers are in `args.rs`.

use std::path::PathBuf;

use armcal::calibration::gravity::TorqueSign;
use armcal::calibration::identify::StatedScales;
use armcal::calibration::identify::channel_weight::ChannelWeights;
use armcal::cancel::Cancel;
use armcal::commands::choices::{
    CriterionArg, Params, PriorScaleArg, Targets, TorqueSignArg, WeightArg,
};
use armcal::commands::tool::Tool;
use armcal::commands::{diagnose, export, holdout, identify, plan, simulate};
use armcal::io::model_file;
use armcal::io::urdf::ChainSpec;
use armcal::session::channel::Weighed;
use armcal::session::input_error::InputError;
use armcal::session::model::RobotModel;
use armcal::session::registration::FrameSharing;
use clap::{Parser, Subcommand};

use crate::args;

/// armcal makes serial robot arms accurate: it identifies the errors of their
/// Denavit-Hartenberg model from measured poses and writes the calibration the
/// motion controller applies.
#[derive(Parser, Debug)]
#[command(name = "armcal", version, about, long_about = None)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand, Debug)]
pub(crate) enum Command {
    /// Print what was read from a robot model and a measurement file, and the
    /// error of the nominal model against the measurements.
    Check(CheckArgs),
    /// Identify the geometric parameter errors from measured poses, say which
    /// parameters the data cannot separate, and write the calibration.
    Identify(IdentifyArgs),
    /// Where the calibrated robot puts its tool point (and how it turns its tool
    /// frame, when the calibration has orientation) for each row of joint
    /// readings: a CSV with x,y,z (and qw,qx,qy,qz) in the model's units, rows in
    /// the order of the joints file.
    Predict(PredictArgs),
    /// For each row of joint commands computed by the nominal model, the commands
    /// that make the calibrated robot reach the pose the nominal model intended.
    Compensate(CompensateArgs),
    /// Simulate a measurement session: a true robot (nominal + random geometric,
    /// base and tool errors + hidden effects) measured with noise; writes the
    /// measurements (docs/file-formats.md §2) and, with --truth, what was built in.
    Simulate(SimulateArgs),
    /// Load a calibration into the controller over its serial link, stream joint
    /// commands through it row by row and write the corrected commands it
    /// returns (model units, like `compensate`); report its faults and deadline
    /// misses. A calibration the controller refuses is named with its reason
    /// (exit status 2).
    #[command(group = clap::ArgGroup::new("port").required(true).multiple(false))]
    Stream(StreamArgs),
    /// Online compensation through a controller's real-time sensor
    /// interface over UDP: KUKA RSI (`--rsi`: each `<Rob>`'s set-point axes
    /// answered with their correction `AK`, degrees, `IPOC` echoed) or ABB
    /// EGM (`--egm`: each `EgmRobot` answered with the next row of
    /// `--joints`, corrected). The same correction as `compensate --servo`
    /// and the controller's firmware; ramped, counted, and to none on
    /// Ctrl-C; statistics and the answer's latency printed at the end
    /// (docs/controllers.md).
    #[command(group = clap::ArgGroup::new("interface").required(true).multiple(false))]
    Serve(ServeArgs),
    /// Fit the geometry, show what it gets wrong, name the cause, extend the model
    /// and measure the gain on held-out poses.
    Diagnose(DiagnoseArgs),
    /// Measure the diagnosis: hide a random effect (or none) in many simulated
    /// sessions and count how often it is named.
    Sweep(SweepArgs),
    /// The whole of armcal on a simulated robot, no files needed: the Table 1 PUMA
    /// with random geometric errors and one hidden effect drawn from the seed,
    /// measured by a simulated laser tracker, diagnosed (what the geometric model
    /// gets wrong, and the named cause), 50 random targets compensated and checked
    /// on the true robot; writes the HTML report and prints the gain.
    Demo(DemoArgs),
    /// Write a calibration for a robot's own software, each file read back
    /// before it is written: a URDF (`--format urdf`: into the URDF its model
    /// was read from, only the origins of the chain's moving joints changed, or
    /// generated from the calibrated model; with two links added,
    /// `armcal_measured_point` and `armcal_measurement_frame`), or a Universal
    /// Robots controller's delta D-H (`ur-deltas`) or ur_calibration file
    /// (`ur-calibration`). Effects other than geometry are left out, with a
    /// warning.
    Export(ExportArgs),
    /// Sessions without a tracker (a `point` column: unknown fixed points and
    /// known distances; docs/file-formats.md): leave each --data session out
    /// in turn, identify on the others (or on --train), and print for the one
    /// left out the spread of the predicted points at each fixed point and the
    /// error of each known distance, for the nominal model, --reference and
    /// the calibration.
    Holdout(HoldoutArgs),
    /// Plan the measurement: the joint configurations to measure (a joints
    /// CSV, in measurement order along a short path) chosen so that the
    /// calibration from them predicts the workspace best, and the accuracy it
    /// is predicted to reach, beside as many random poses'.
    Plan(PlanArgs),
    /// List the built-in robot models and data sets.
    Models,
    /// Rebuild the worked examples of a seed paper and print them as the paper does.
    Reproduce(ReproduceArgs),
}

/// The flags of `armcal plan`.
#[derive(clap::Args, Debug)]
pub(crate) struct PlanArgs {
    #[command(flatten)]
    pub(crate) model: ModelArgs,
    /// Poses to measure.
    #[arg(long, default_value_t = 30, value_parser = args::at_least(1, "pose"))]
    pub(crate) poses: usize,
    /// Write the poses here: a joints CSV (q1..qM, model units), in
    /// measurement order.
    #[arg(long, value_name = "P.csv")]
    pub(crate) out: PathBuf,
    /// Write the report as JSON here.
    #[arg(long, value_name = "R.json")]
    pub(crate) json: Option<PathBuf>,
    /// Write a self-contained HTML page here: where in the workspace the
    /// calibration is predicted to miss most.
    #[arg(long, value_name = "R.html")]
    pub(crate) html: Option<PathBuf>,
    /// The instrument measures orientations too (full poses).
    #[arg(long)]
    pub(crate) orientation: bool,
    /// The instrument's position noise, one standard deviation per axis, model
    /// length unit [default: 20 µm]
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    pub(crate) noise: Option<f64>,
    /// The instrument's orientation noise, per axis, model angle unit
    /// [default: 20 µrad]
    #[arg(long, value_name = "ANGLE", value_parser = args::positive)]
    pub(crate) orientation_noise: Option<f64>,
    /// A box the tool point must stay in, measurement frame, model length unit.
    #[arg(
        long,
        value_name = "XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub(crate) within: Option<Vec<f64>>,
    /// A floor the tool point must stay above: its height z, measurement frame,
    /// model length unit.
    #[arg(long, value_name = "Z", allow_hyphen_values = true)]
    pub(crate) above: Option<f64>,
    /// The share of each joint's range kept off each limit [default: 0.05]
    #[arg(long, value_name = "SHARE")]
    pub(crate) margin: Option<f64>,
    /// Choose among these configurations (a joints CSV) instead of random ones
    /// within the limits.
    #[arg(long, value_name = "C.csv")]
    pub(crate) from: Option<String>,
    /// The configurations the robot will work at (a joints CSV): the plan
    /// predicts them best (default: random configurations within the limits).
    #[arg(long, value_name = "T.csv")]
    pub(crate) targets: Option<String>,
    /// Random candidates to choose from, at most 100000 [default: 10000]
    #[arg(long, value_name = "N")]
    pub(crate) candidates: Option<usize>,
    /// Effects the measurement must serve besides the geometry: `backlash`
    /// (each pose measured twice, approached from below and from above in
    /// every joint, a via row before each), `compliance` (the joints'
    /// gravity torques spread, each joint's compliance identified).
    #[arg(long, value_name = "NAME", value_delimiter = ',')]
    pub(crate) effects: Vec<String>,
    /// A session without a tracker: the sockets a ball on the flange is
    /// seated in (a CSV `point,x,y,z` of their nominal centres, base frame,
    /// model length unit, and `distance` lines): the plan says which
    /// configurations to seat it in each at.
    #[arg(long, value_name = "S.csv")]
    pub(crate) sockets: Option<String>,
    /// The least conditioning of a planned pose (the smallest singular value
    /// of its manipulator Jacobian over the largest, rotation rows scaled by
    /// the reach): candidates nearer a singularity are not planned. Default
    /// 0: every candidate kept, a planned pose below 0.005 named (a UR10e's
    /// wrist within about 1.5° of q5 = 0).
    #[arg(long, value_name = "C")]
    pub(crate) singularity_margin: Option<f64>,
    /// What the poses are chosen for: `i-optimal`, the calibrated robot's
    /// predicted error over the workspace; `d-optimal`, the volume of the
    /// parameters' confidence region (as most tools choose). The report
    /// gives the other's plan of as many poses beside.
    #[arg(long, value_enum, default_value = "i-optimal")]
    pub(crate) criterion: CriterionArg,
    /// Seed of every random draw.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
}

impl PlanArgs {
    /// What these flags ask of `plan`.
    pub(crate) fn request(&self) -> plan::Request {
        plan::Request {
            poses: self.poses,
            orientation: self.orientation,
            noise: self.noise,
            orientation_noise: self.orientation_noise,
            within: self.within.clone(),
            above: self.above,
            margin: self.margin,
            candidates: self.candidates,
            effects: self.effects.clone(),
            sockets: None,
            singularity_margin: self.singularity_margin,
            criterion: self.criterion.into(),
            seed: self.seed,
        }
    }
}

/// The flags of `armcal check`.
#[derive(clap::Args, Debug)]
pub(crate) struct CheckArgs {
    #[command(flatten)]
    pub(crate) model: ModelArgs,
    /// Measurements: a CSV file (docs/file-formats.md §2) or the name of a
    /// built-in data set; several files are several sessions of one robot,
    /// each in its own measurement frame with its own tool.
    #[arg(long, value_name = "D.csv|NAME", required = true, num_args = 1..)]
    pub(crate) data: Vec<String>,
    #[command(flatten)]
    pub(crate) torques: TorqueArgs,
}

/// The flags of `armcal identify`.
#[derive(clap::Args, Debug)]
pub(crate) struct IdentifyArgs {
    #[command(flatten)]
    pub(crate) model: ModelArgs,
    /// Measurements: a CSV file (docs/file-formats.md §2) or the name of a
    /// built-in data set; several files are several sessions of one robot
    /// (see --same-base, --same-tool).
    #[arg(long, value_name = "D.csv|NAME", required = true, num_args = 1..)]
    pub(crate) data: Vec<String>,
    #[command(flatten)]
    pub(crate) sessions: SessionArgs,
    #[command(flatten)]
    pub(crate) torques: TorqueArgs,
    /// `full`: every identifiable parameter, base and tool included; `paper`: the
    /// 3M model and iterative regression of Mirman & Gupta (needs full poses).
    #[arg(long, value_enum, default_value = "full")]
    pub(crate) params: Params,
    /// Write the calibration (postcard bytes the firmware loads) here.
    #[arg(long, value_name = "CAL")]
    pub(crate) out: Option<PathBuf>,
    /// Write the report as JSON here.
    #[arg(long, value_name = "R.json")]
    pub(crate) json: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) weights: Weights,
    /// `chosen`: the stated prior (--prior-length, --prior-angle, the model
    /// file's `[prior]`, else 1 mm, 1 mrad) times the factor of 0.1, 0.3, 1,
    /// 3 or 10 that predicts held-out poses best (10-fold cross-validation
    /// of the rows, as `diagnose` chooses it; shown in the summary);
    /// `stated`: the stated prior as it is.
    #[arg(long, value_enum, default_value = "chosen")]
    pub(crate) prior_scale: PriorScaleArg,
    #[command(flatten)]
    pub(crate) channel_weights: ChannelWeightArgs,
    /// The frame the compensation's targets will be given in: `world` (the
    /// measurement frame of these data: the identified base is compensated)
    /// or `base` (the robot's own base frame: the identified base, the
    /// registration of the instrument, is not). Stored in the calibration.
    #[arg(long, value_enum, default_value = "world")]
    pub(crate) targets: Targets,
    /// Write the calibration (and the reports) even when the fit did not
    /// converge or fits its own data worse than the nominal model (the
    /// reason is printed as a warning); otherwise such a fit exits with
    /// status 1 and writes nothing.
    #[arg(long)]
    pub(crate) write_failed: bool,
    /// Print nothing on success (the summary is printed otherwise, whatever
    /// files are written).
    #[arg(long)]
    pub(crate) quiet: bool,
}

/// The flags of `armcal predict`.
#[derive(clap::Args, Debug)]
pub(crate) struct PredictArgs {
    /// The calibration file written by `armcal identify --out` or `armcal diagnose --out`.
    #[arg(long, value_name = "CAL")]
    pub(crate) calibration: String,
    /// Joint readings: a CSV with q1..qM in the model's units (docs/file-formats.md §2;
    /// x, y, z and the quaternion of a measurement file are not read).
    #[arg(long, value_name = "J.csv")]
    pub(crate) joints: String,
    /// Write the predictions here (otherwise they are printed).
    #[arg(long, value_name = "P.csv")]
    pub(crate) out: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) tool: ToolArgs,
    #[command(flatten)]
    pub(crate) tool_model: ToolModelArgs,
}

/// The flags of `armcal compensate`.
#[derive(clap::Args, Debug)]
pub(crate) struct CompensateArgs {
    /// The calibration file written by `armcal identify --out` or `armcal diagnose --out`.
    #[arg(long, value_name = "CAL")]
    pub(crate) calibration: String,
    /// Joint commands: a CSV with q1..qM in the model's units, rows in the order sent.
    #[arg(long, value_name = "J.csv")]
    pub(crate) joints: String,
    /// Write the corrected commands here (otherwise they are printed).
    #[arg(long, value_name = "C.csv")]
    pub(crate) out: Option<PathBuf>,
    /// Run the rows as consecutive servo ticks, as `armcal stream` and the
    /// controller do (warm starts, the per-tick change bound). Without it
    /// each row is a robot program's target point, solved alone to
    /// convergence (the row order still gives the approach directions).
    #[arg(long)]
    pub(crate) servo: bool,
    #[command(flatten)]
    pub(crate) tool: ToolArgs,
    #[command(flatten)]
    pub(crate) tool_model: ToolModelArgs,
}

/// The flags of `armcal simulate`.
#[derive(clap::Args, Debug)]
pub(crate) struct SimulateArgs {
    #[command(flatten)]
    pub(crate) model: ModelArgs,
    /// Poses to measure.
    #[arg(long, default_value_t = 200, value_parser = args::at_least(1, "pose"))]
    pub(crate) poses: usize,
    /// A hidden effect, `NAME[:JOINT[:VALUE]]` (joint from 1, value in SI units);
    /// repeat for several. Names: joint_compliance, gear_transmission, backlash,
    /// thermal_expansion, encoder_scale.
    #[arg(long = "effect", value_name = "NAME[:JOINT[:VALUE]]")]
    pub(crate) effects: Vec<String>,
    /// A hidden Hayati tilt `JOINT:BETA` (rad) between nominally parallel axes.
    #[arg(long = "tilt", value_name = "JOINT:BETA", value_parser = args::tilt)]
    pub(crate) tilts: Vec<args::Tilt>,
    /// Position noise, one standard deviation per axis, model length unit
    /// [default: 20 µm]
    #[arg(long, value_name = "LENGTH", value_parser = args::non_negative)]
    pub(crate) noise: Option<f64>,
    /// Also measure orientations, with this noise (model angle unit).
    #[arg(long, value_name = "ANGLE", value_parser = args::non_negative)]
    pub(crate) orientation_noise: Option<f64>,
    /// A systematic orientation error: the measured orientations turned by
    /// this angle (model angle unit) about an axis drawn from the seed, in
    /// the instrument's frame, which the positions do not share (a hand-eye
    /// rotation error). Needs --orientation-noise.
    #[arg(long, value_name = "ANGLE", value_parser = args::non_negative)]
    pub(crate) orientation_bias: Option<f64>,
    /// A systematic orientation error growing with the tool point's
    /// distance from the instrument (model angle unit per model length
    /// unit), about the horizontal axis across the line of sight, as a
    /// camera's. Needs --orientation-noise.
    #[arg(long, value_name = "ANGLE/LENGTH", value_parser = args::non_negative)]
    pub(crate) orientation_bias_growth: Option<f64>,
    /// Also write the joint torques the robot reports (tau1..tauM: its
    /// drives' torques, minus the true gravity torques), with this noise
    /// (N·m, N for a prismatic joint).
    #[arg(long, value_name = "N·m", value_parser = args::non_negative)]
    pub(crate) torque_noise: Option<f64>,
    /// The sign the torques are written with: `drive` (the torque each
    /// drive exerts on its link, armcal's tau) or `load` (the load torque
    /// the joints' sensors read, as a KUKA iiwa reports it: the drive's
    /// negated).
    #[arg(long, value_enum, value_name = "drive|load", default_value = "drive")]
    pub(crate) torque_sign: TorqueSignArg,
    /// The payloads the poses are measured with, kg, in consecutive blocks
    /// of rows [default: 0,5]
    #[arg(long, value_name = "KG,KG,…", value_delimiter = ',', value_parser = args::non_negative)]
    pub(crate) payloads: Vec<f64>,
    /// Measure the poses in this many sessions, in consecutive blocks of
    /// rows: each after the first with the instrument moved and the measured
    /// point remounted. Written one file a session, `D-1.csv`, `D-2.csv`, …
    /// for `--out D.csv`.
    #[arg(long, default_value_t = 1, value_parser = args::at_least(1, "session"))]
    pub(crate) sessions: usize,
    #[command(flatten)]
    pub(crate) errors: TrueErrorArgs,
    /// Seed of every random draw.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Write the measurements here (one file a session: see --sessions).
    #[arg(long, value_name = "D.csv")]
    pub(crate) out: PathBuf,
    /// Write what was built in (errors and effects) here, as JSON.
    #[arg(long, value_name = "T.json")]
    pub(crate) truth: Option<PathBuf>,
}

/// The true robot's error sizes, shared by `simulate` and `sweep`: in the
/// model's units (m and rad for `sweep`'s built-in robots).
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct TrueErrorArgs {
    /// How far the true robot's links are off the nominal D-H model: each
    /// length (a, d) drawn uniform within ±LENGTH, each angle (the joint
    /// offset θ, the twist α) within ±ANGLE, in the model's units (m and rad
    /// for sweep; default 1 mm, 1 mrad).
    #[arg(long, value_name = "LENGTH,ANGLE", value_parser = args::error_sizes)]
    pub(crate) link_errors: Option<[f64; 2]>,
    /// How far the true base frame (the instrument's placement) is off the
    /// model's: each coordinate within ±LENGTH, each angle within ±ANGLE
    /// [default: 1 mm, 1 mrad]
    #[arg(long, value_name = "LENGTH,ANGLE", value_parser = args::error_sizes)]
    pub(crate) base_errors: Option<[f64; 2]>,
    /// How far the true tool frame (the measured point's mount) is off the
    /// model's: each coordinate within ±LENGTH, each angle within ±ANGLE
    /// [default: 1 mm, 1 mrad]
    #[arg(long, value_name = "LENGTH,ANGLE", value_parser = args::error_sizes)]
    pub(crate) tool_errors: Option<[f64; 2]>,
}

impl TrueErrorArgs {
    /// What these flags ask.
    pub(crate) fn request(&self) -> simulate::ErrorRequest {
        simulate::ErrorRequest {
            link: self.link_errors,
            base: self.base_errors,
            tool: self.tool_errors,
        }
    }
}

/// The flags of `armcal stream`.
#[derive(clap::Args, Debug)]
pub(crate) struct StreamArgs {
    /// The calibration file written by `armcal identify --out` or `armcal diagnose --out`,
    /// sent as it is.
    #[arg(long, value_name = "CAL")]
    pub(crate) calibration: String,
    /// Joint commands: a CSV with q1..qM in the model's units (and optionally
    /// temp, load), rows in the order sent.
    #[arg(long, value_name = "J.csv")]
    pub(crate) joints: String,
    /// The controller's link over TCP (a serial-to-network bridge, or QEMU's
    /// `-serial tcp:…`).
    #[arg(long, value_name = "HOST:PORT", group = "port")]
    pub(crate) tcp: Option<String>,
    /// The controller's serial port (115200 baud, 8N1).
    #[arg(long, value_name = "PATH", group = "port")]
    pub(crate) serial: Option<String>,
    /// Write the corrected commands here (otherwise they are printed).
    #[arg(long, value_name = "C.csv")]
    pub(crate) out: Option<PathBuf>,
    /// After the stream, ask the controller to halt (under QEMU this ends the
    /// emulation; a real controller waits for a reset).
    #[arg(long)]
    pub(crate) halt: bool,
    #[command(flatten)]
    pub(crate) tool: ToolArgs,
    #[command(flatten)]
    pub(crate) tool_model: ToolModelArgs,
}

/// The flags of `armcal serve`.
#[derive(clap::Args, Debug)]
pub(crate) struct ServeArgs {
    /// The calibration file written by `armcal identify --out` or `armcal diagnose --out`.
    #[arg(long, value_name = "CAL")]
    pub(crate) calibration: String,
    /// Serve KUKA RSI on this UDP address (the ETHERNET object's
    /// IP_NUMBER and PORT).
    #[arg(long, value_name = "HOST:PORT", group = "interface")]
    pub(crate) rsi: Option<String>,
    /// Serve ABB EGM on this UDP address (the controller's UDPUC device),
    /// streaming --joints.
    #[arg(
        long,
        value_name = "HOST:PORT",
        group = "interface",
        requires = "joints"
    )]
    pub(crate) egm: Option<String>,
    /// EGM: the trajectory, a CSV with q1..qM in the model's units (and
    /// optionally temp, load), one row per controller cycle.
    #[arg(long, value_name = "J.csv", conflicts_with = "rsi")]
    pub(crate) joints: Option<String>,
    /// RSI: the AXISCORR object's mode: `absolute` (the whole correction
    /// each cycle, RSI_ON(#ABSOLUTE)) or `relative` (each cycle's increment).
    #[arg(long, value_enum, default_value = "absolute", conflicts_with = "egm")]
    pub(crate) rsi_mode: RsiModeArg,
    /// RSI: the `Type` of the answer's `<Sen>` (the ETHERNET object's SENTYPE).
    #[arg(
        long,
        value_name = "NAME",
        default_value = "ImFree",
        conflicts_with = "egm"
    )]
    pub(crate) rsi_type: String,
    /// The temperature of every cycle, °C (EGM: of the rows without a temp column).
    #[arg(long, value_name = "CELSIUS", allow_hyphen_values = true, value_parser = args::finite)]
    pub(crate) temperature: Option<f64>,
    /// The payload of every cycle, kg (EGM: of the rows without a load column).
    #[arg(long, value_name = "KG", value_parser = args::non_negative)]
    pub(crate) payload: Option<f64>,
    /// The largest change of a joint's correction sent per cycle, degrees:
    /// a larger one (the first cycle, after a fault, at the end) is ramped.
    #[arg(long, value_name = "DEG", default_value_t = 0.01, value_parser = args::positive)]
    pub(crate) max_step: f64,
    /// The controller's cycle, ms: an answer later than it is counted late.
    #[arg(long, value_name = "MS", default_value_t = 4.0, value_parser = args::positive)]
    pub(crate) cycle_ms: f64,
    /// After this long without a datagram (ms) the controller is taken to
    /// have stopped, and the run ends with its statistics.
    #[arg(long, value_name = "MS", default_value_t = 1000.0, value_parser = args::positive)]
    pub(crate) timeout_ms: f64,
}

/// `--rsi-mode`.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub(crate) enum RsiModeArg {
    /// The whole correction each cycle.
    Absolute,
    /// Each cycle's increment.
    Relative,
}

/// The flags of `armcal diagnose`.
#[derive(clap::Args, Debug)]
pub(crate) struct DiagnoseArgs {
    #[command(flatten)]
    pub(crate) model: ModelArgs,
    /// Measurements: a CSV file or the name of a built-in data set; several
    /// files are several sessions of one robot (see --same-base, --same-tool).
    #[arg(long, value_name = "D.csv|NAME", required = true, num_args = 1..)]
    pub(crate) data: Vec<String>,
    #[command(flatten)]
    pub(crate) sessions: SessionArgs,
    #[command(flatten)]
    pub(crate) torques: TorqueArgs,
    /// Write the extended calibration (geometry and effects) here.
    #[arg(long, value_name = "CAL")]
    pub(crate) out: Option<PathBuf>,
    /// Write the report as JSON here.
    #[arg(long, value_name = "R.json")]
    pub(crate) json: Option<PathBuf>,
    /// Write a self-contained HTML page (inline SVG plots) here.
    #[arg(long, value_name = "R.html")]
    pub(crate) html: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) weights: Weights,
    /// Folds of the cross-validation, from 2 to the number of poses
    /// (default: 10, or one per pose with fewer poses).
    #[arg(long, value_parser = args::at_least(2, "folds"))]
    pub(crate) folds: Option<usize>,
    #[command(flatten)]
    pub(crate) channel_weights: ChannelWeightArgs,
    /// The frame the compensation's targets will be given in: `world` (the
    /// measurement frame of these data: the identified base is compensated)
    /// or `base` (the robot's own base frame: the identified base, the
    /// registration of the instrument, is not). Stored in the calibration.
    #[arg(long, value_enum, default_value = "world")]
    pub(crate) targets: Targets,
    /// Write the calibration (and the reports) even when the fit did not
    /// converge or fits its own data worse than the nominal model (the
    /// reason is printed as a warning); otherwise such a fit exits with
    /// status 1 and writes nothing.
    #[arg(long)]
    pub(crate) write_failed: bool,
    /// Print nothing on success (the summary is printed otherwise, whatever
    /// files are written).
    #[arg(long)]
    pub(crate) quiet: bool,
}

/// The flags of `armcal sweep`.
#[derive(clap::Args, Debug)]
pub(crate) struct SweepArgs {
    /// Cases to run.
    #[arg(long, default_value_t = 100, value_parser = args::at_least(1, "case"))]
    pub(crate) cases: usize,
    /// Seed of every draw.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Tracker positions per simulated session (at least 20).
    #[arg(long, default_value_t = 300, value_parser = args::at_least(20, "positions per session"))]
    pub(crate) poses: usize,
    /// Hide only this effect in every case that hides one, the other draws
    /// of each case kept (parallel_axis_tilt: a Hayati tilt between axes 2
    /// and 3).
    #[arg(long, value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(armcal::calibration::sweep::KINDS))]
    pub(crate) effect: Option<String>,
    /// Draw the true robots from these built-in models only (repeat for
    /// several).
    #[arg(long = "robot", value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(armcal::calibration::sweep::ROBOTS))]
    pub(crate) robots: Vec<String>,
    /// The true robots' error sizes, in m and rad (the built-in robots' units).
    #[command(flatten)]
    pub(crate) errors: TrueErrorArgs,
    /// Write every case as JSON here.
    #[arg(long, value_name = "R.json")]
    pub(crate) json: Option<PathBuf>,
}

/// The flags of `armcal demo`.
#[derive(clap::Args, Debug)]
pub(crate) struct DemoArgs {
    /// Seed of every draw (the default is fixed, so the demo repeats; any other
    /// seed draws other geometric errors and another effect).
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Write the HTML report here.
    #[arg(long, value_name = "R.html", default_value = "armcal-demo.html")]
    pub(crate) html: PathBuf,
}

/// The flags of `armcal export`.
#[derive(clap::Args, Debug)]
pub(crate) struct ExportArgs {
    /// The calibration file written by `armcal identify --out` or `armcal diagnose --out`.
    #[arg(long, value_name = "CAL")]
    pub(crate) calibration: String,
    /// `--format urdf`: the URDF the calibration's model was read from (with
    /// the same --base-link, --tip-link and --tip-point); without it, a URDF
    /// is generated from the calibrated model. `--format ur-deltas` and
    /// `ur-calibration`: the Universal Robots model (ur5e, ur10, ur10e) whose
    /// nominal the deltas are against (required).
    #[arg(long, value_name = "M.urdf|NAME")]
    pub(crate) model: Option<String>,
    #[command(flatten)]
    pub(crate) chain: ChainArgs,
    /// The format to write.
    #[arg(long, value_enum)]
    pub(crate) format: ExportFormat,
    /// Write it here (otherwise it is printed).
    #[arg(long, value_name = "OUT.urdf")]
    pub(crate) out: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) tool: ToolArgs,
}

/// The flags of `armcal holdout`.
#[derive(clap::Args, Debug)]
pub(crate) struct HoldoutArgs {
    #[command(flatten)]
    pub(crate) model: ModelArgs,
    /// Constraint sessions to hold out, each in turn (CSV with a `point` column).
    #[arg(long, value_name = "D.csv", required = true, num_args = 1..)]
    pub(crate) data: Vec<String>,
    /// Identify once on these sessions instead, and check every --data session.
    #[arg(long, value_name = "T.csv", num_args = 1..)]
    pub(crate) train: Vec<String>,
    /// Another model of the same chain to check on the same rows (read with
    /// the same --base-link, --tip-link and --tip-point): another tool's
    /// calibration, for instance.
    #[arg(long, value_name = "R.urdf|R.toml")]
    pub(crate) reference: Option<String>,
    #[command(flatten)]
    pub(crate) weights: Weights,
    /// The prior's scale the training sessions are identified at, as
    /// `armcal identify --prior-scale` (shown beside the figures).
    #[arg(
        long,
        value_enum,
        default_value = "chosen",
        conflicts_with = "diagnose"
    )]
    pub(crate) prior_scale: PriorScaleArg,
    /// Calibrate the training sessions as `armcal diagnose` does: blunders
    /// set aside, the geometric model and the prior's scale chosen by
    /// 10-fold cross-validation of their rows, the effects the data name
    /// (the choice shown beside the figures, its effects in the prediction).
    #[arg(long)]
    pub(crate) diagnose: bool,
}

/// The flags of `armcal reproduce`.
#[derive(clap::Args, Debug)]
pub(crate) struct ReproduceArgs {
    /// Which paper.
    #[arg(value_enum)]
    pub(crate) paper: Paper,
}

/// The robot model and, for a URDF, which chain of it to read.
#[derive(clap::Args, Debug)]
pub(crate) struct ModelArgs {
    /// Robot model: a TOML file (docs/file-formats.md §1), a URDF (`*.urdf`, or text
    /// starting with `<`; docs/urdf.md) or the name of a built-in model.
    #[arg(long, value_name = "M.toml|M.urdf|NAME")]
    pub(crate) model: String,
    #[command(flatten)]
    pub(crate) chain: ChainArgs,
    /// Universal Robots model: the controller's factory calibration (YAML with
    /// `delta_theta`, `delta_a`, `delta_d`, `delta_alpha`; docs/ur.md), added to
    /// the nominal D-H and read as the robot's nominal model.
    #[arg(long, value_name = "CAL.yaml")]
    pub(crate) factory_calibration: Option<String>,
}

impl ModelArgs {
    /// The model these flags name.
    pub(crate) fn load(&self) -> Result<RobotModel, InputError> {
        let model = model_file::load_model_with(&self.model, &self.chain.spec())?;
        match &self.factory_calibration {
            None => Ok(model),
            Some(file) => armcal::io::ur::load_factory(&model, file),
        }
    }
}

/// The working tool that replaces the measured one (`armcal::commands::tool`).
#[derive(clap::Args, Debug)]
pub(crate) struct ToolArgs {
    /// The working tool in the robot's flange frame (a model file's last link
    /// frame, as its [tool]; a URDF's tip link; a UR's flange), model units: it
    /// replaces the tool the
    /// calibration was measured with, whose identified offset is reported
    /// and not applied (docs/file-formats.md §4).
    #[arg(long, value_name = "X,Y,Z[,RX,RY,RZ]", allow_hyphen_values = true, value_parser = args::tool_frame, conflicts_with = "tool_link")]
    pub(crate) tool: Option<[f64; 6]>,
    /// The working tool as a link of the URDF given with --model (the one
    /// the calibration's model was read from, with its --base-link), carried
    /// by the last joint.
    #[arg(long, value_name = "LINK", requires = "model")]
    pub(crate) tool_link: Option<String>,
}

impl ToolArgs {
    /// The working tool these flags name, with the URDF and base link of a
    /// `--tool-link`.
    pub(crate) fn tool(&self, model: Option<&str>, base_link: Option<&str>) -> Option<Tool> {
        match (&self.tool, &self.tool_link, model) {
            (Some(t), _, _) => Some(Tool::Frame {
                xyz: [t[0], t[1], t[2]],
                rpy: [t[3], t[4], t[5]],
            }),
            (None, Some(link), Some(model)) => Some(Tool::Link {
                model: model.to_owned(),
                base_link: base_link.map(str::to_owned),
                link: link.clone(),
            }),
            _ => None,
        }
    }
}

/// The URDF a `--tool-link` is a link of.
#[derive(clap::Args, Debug)]
pub(crate) struct ToolModelArgs {
    /// --tool-link: the URDF the calibration's model was read from.
    #[arg(long, value_name = "M.urdf", requires = "tool_link")]
    pub(crate) model: Option<String>,
    /// --tool-link: the link the chain starts from, as the calibration's
    /// model was read with (default: the root link).
    #[arg(long, value_name = "LINK", requires = "tool_link")]
    pub(crate) base_link: Option<String>,
}

impl ToolModelArgs {
    /// The working tool `tool` names with this URDF.
    pub(crate) fn tool(&self, tool: &ToolArgs) -> Option<Tool> {
        tool.tool(self.model.as_deref(), self.base_link.as_deref())
    }
}

/// Which chain of a URDF model is the arm, and where on it the measured point is.
#[derive(clap::Args, Debug)]
pub(crate) struct ChainArgs {
    /// URDF model: the link the chain starts from, whose frame is the robot's
    /// base (default: the root link).
    #[arg(long, value_name = "LINK")]
    pub(crate) base_link: Option<String>,
    /// URDF model: the link the chain ends at, which carries the measured point
    /// (default: followed down from the base while one branch holds the moving
    /// joints).
    #[arg(long, value_name = "LINK")]
    pub(crate) tip_link: Option<String>,
    /// URDF model: the measured point in the tip link's frame, `x,y,z` in m
    /// (default: the tip link's origin).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = args::tip_point)]
    pub(crate) tip_point: Option<nalgebra::Vector3<f64>>,
}

impl ChainArgs {
    /// The chain these flags name.
    pub(crate) fn spec(&self) -> ChainSpec {
        ChainSpec {
            base_link: self.base_link.clone(),
            tip_link: self.tip_link.clone(),
            tip_point: self.tip_point,
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub(crate) enum ExportFormat {
    /// URDF (ROS robot description).
    Urdf,
    /// Universal Robots factory calibration: D-H deltas against the UR model
    /// given with --model (docs/ur.md).
    UrDeltas,
    /// Universal Robots: ur_calibration's URDF-correction YAML (joint origins
    /// for ur_description; docs/ur.md).
    UrCalibration,
}

/// The noise and the prior: what weighs the rows and the parameters.
#[derive(clap::Args, Debug)]
pub(crate) struct Weights {
    /// Position noise of the measurements, one standard deviation per axis, in
    /// the model's length unit (default: estimated from the residuals); also
    /// the noise of the contacts of a session without a tracker whose kind
    /// has none stated.
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    pub(crate) position_noise: Option<f64>,
    /// Orientation noise, one standard deviation per axis, in the model's angle
    /// unit (default: estimated from the residuals).
    #[arg(long, value_name = "ANGLE", value_parser = args::positive)]
    pub(crate) orientation_noise: Option<f64>,
    /// Noise of a tool point at an unknown fixed point (`point` column), per
    /// axis, model length unit (default: `--position-noise`, else estimated
    /// from the residuals of those rows alone).
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    pub(crate) point_noise: Option<f64>,
    /// Noise of a tool point on an unknown plane (`plane` column), along its
    /// normal, model length unit (default: `--position-noise`, else estimated
    /// from the residuals of those rows alone).
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    pub(crate) plane_noise: Option<f64>,
    /// Prior scale of a D-H length error (s, a), one standard deviation, model
    /// length unit (default: the model file's `[prior]`, else 1 mm).
    #[arg(long, value_name = "LENGTH", value_parser = args::positive)]
    pub(crate) prior_length: Option<f64>,
    /// Prior scale of a D-H angle error (θ, α), model angle unit (default: the
    /// model file's `[prior]`, else 1 mrad).
    #[arg(long, value_name = "ANGLE", value_parser = args::positive)]
    pub(crate) prior_angle: Option<f64>,
}

/// How several sessions (`--data A.csv B.csv …`) share their frames. By
/// default each session has its own base frame (the instrument's
/// registration: a tracker moved between sessions) and its own tool (the
/// measured point: an SMR or marker remounted), so that neither's motion
/// is taken for the robot's geometry.
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct SessionArgs {
    /// The sessions share one base frame: the instrument was not moved
    /// between them.
    #[arg(long)]
    pub(crate) same_base: bool,
    /// The sessions share one tool: the measured point was not remounted
    /// between them.
    #[arg(long)]
    pub(crate) same_tool: bool,
}

/// How the measured joint torques (`tau1..tauM`) are read.
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct TorqueArgs {
    /// The sign of the tau columns: `drive` (the torque each drive exerts on
    /// its link about the joint's axis, positive with increasing q: armcal's
    /// convention) or `load` (the load torque the joints' sensors read, as a
    /// KUKA iiwa reports it: negated when read). Default: read from the data
    /// (the fit of the arm's masses with either sign, else the model's
    /// gravity torques); the summary says which was read and why.
    #[arg(long, value_enum, value_name = "drive|load")]
    pub(crate) torque_sign: Option<TorqueSignArg>,
}

impl TorqueArgs {
    /// The sign these flags state; `None`: read from the data.
    pub(crate) fn sign(self) -> Option<TorqueSign> {
        self.torque_sign.map(TorqueSign::from)
    }
}

impl SessionArgs {
    /// The frames these flags share.
    pub(crate) fn sharing(self) -> FrameSharing {
        FrameSharing::stated(self.same_base, self.same_tool)
    }
}

impl Weights {
    /// The scales these flags state (model units).
    pub(crate) fn scales(&self) -> StatedScales {
        StatedScales {
            position_noise: self.position_noise,
            orientation_noise: self.orientation_noise,
            point_noise: self.point_noise,
            plane_noise: self.plane_noise,
            prior_length: self.prior_length,
            prior_angle: self.prior_angle,
        }
    }
}

/// The weight of each kind of row beside the measured positions (or, in a
/// session without a tracker, beside the first kind of contact): chosen on
/// held-out tool points, or stated.
#[derive(clap::Args, Clone, Copy, Debug)]
pub(crate) struct ChannelWeightArgs {
    /// The orientation rows' weight relative to what their noise gives
    /// them: `chosen` scores as estimated, 0.1, 0.01 and none by the
    /// held-out error of the tool point's position (10-fold
    /// cross-validation) and fits at the best (the largest within two
    /// standard errors of the least: orientations as clean as their noise
    /// stay); `estimated`, `0.1`, `0.01`, `none` state it. Full poses only.
    #[arg(long, value_enum, default_value = "chosen")]
    pub(crate) orientation_weight: WeightArg,
    /// The point contacts' weight (a ball in a socket) beside measured
    /// positions, chosen or stated as --orientation-weight's.
    #[arg(long, value_enum, default_value = "chosen")]
    pub(crate) point_weight: WeightArg,
    /// The plane contacts' weight (a probe on a plate) beside measured
    /// positions or point contacts, chosen or stated as --orientation-weight's.
    #[arg(long, value_enum, default_value = "chosen")]
    pub(crate) plane_weight: WeightArg,
}

impl ChannelWeightArgs {
    /// What these flags ask.
    pub(crate) fn request(&self) -> ChannelWeights {
        ChannelWeights::from_fn(|w| {
            match w {
                Weighed::Orientation => self.orientation_weight,
                Weighed::Point => self.point_weight,
                Weighed::Plane => self.plane_weight,
            }
            .into()
        })
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub(crate) enum Paper {
    /// Mirman & Gupta (1992): Tables 2 and 3, the iterative regression on the Table 1 PUMA.
    MirmanGupta,
    /// Kirchner, Gurumoorthy & Prinz (1985): the second-order expansion (eq. 2.22)
    /// and the series inversion of section 3 beside the iterative regression.
    Kirchner,
}

impl IdentifyArgs {
    /// What these flags ask of `identify`.
    pub(crate) fn request(&self) -> identify::Request {
        identify::Request {
            params: self.params.into(),
            scales: self.weights.scales(),
            prior_scale: self.prior_scale.into(),
            channel_weights: self.channel_weights.request(),
            targets: self.targets.into(),
            frames: self.sessions.sharing(),
            torque_sign: self.torques.sign(),
            // SIGINT ends the process: nothing to cancel.
            cancel: Cancel::NEVER,
        }
    }
}

impl DiagnoseArgs {
    /// What these flags ask of `diagnose`.
    pub(crate) fn request(&self) -> diagnose::Request {
        diagnose::Request {
            folds: self.folds,
            scales: self.weights.scales(),
            channel_weights: self.channel_weights.request(),
            targets: self.targets.into(),
            frames: self.sessions.sharing(),
            torque_sign: self.torques.sign(),
            cancel: Cancel::NEVER,
        }
    }
}

impl HoldoutArgs {
    /// What these flags ask of `holdout`.
    pub(crate) fn request(&self) -> holdout::Request {
        let calibrate = match (self.prior_scale, self.diagnose) {
            (_, true) => holdout::Calibrate::Diagnosis,
            (PriorScaleArg::Chosen, false) => holdout::Calibrate::Prior,
            (PriorScaleArg::Stated, false) => holdout::Calibrate::Stated,
        };
        holdout::Request {
            calibrate,
            scales: self.weights.scales(),
            cancel: Cancel::NEVER,
        }
    }
}

impl ExportArgs {
    /// What these flags ask of `export`.
    pub(crate) fn request(&self) -> export::Request {
        export::Request {
            format: match self.format {
                ExportFormat::Urdf => export::Format::Urdf,
                ExportFormat::UrDeltas => export::Format::UrDeltas,
                ExportFormat::UrCalibration => export::Format::UrCalibration,
            },
            model: self.model.clone(),
            chain: self.chain.spec(),
            tool: self
                .tool
                .tool(self.model.as_deref(), self.chain.base_link.as_deref()),
        }
    }
}

impl SimulateArgs {
    /// What these flags ask of `simulate`.
    pub(crate) fn request(&self) -> simulate::Request {
        simulate::Request {
            poses: self.poses,
            seed: self.seed,
            noise: self.noise,
            orientation_noise: self.orientation_noise,
            orientation_bias: self.orientation_bias,
            orientation_bias_growth: self.orientation_bias_growth,
            torque_noise: self.torque_noise,
            torque_sign: self.torque_sign.into(),
            effects: self.effects.clone(),
            tilts: self.tilts.iter().map(|t| (t.joint, t.beta)).collect(),
            payloads: self.payloads.clone(),
            sessions: self.sessions,
            errors: self.errors.request(),
        }
    }
}
