//! `plan`: the poses to measure and the accuracy they are predicted to give,
//! as [`crate::calibration::plan`] chooses them, with the request checked
//! the same way whichever front end asks.
//!
//! Lengths and angles are in the model's units as the user states them;
//! the plan is SI.

use super::Front;
use crate::calibration::plan::design::Optimality;
use crate::calibration::plan::{
    Instrument, ORIENTATION_NOISE, Plan, PlanOptions, Visits, plan_cancellable,
};
use crate::io::sockets::Sockets;
use crate::session::input_error::InputError;
use crate::session::input_error::number;
use crate::session::model::RobotModel;

/// The most candidates a plan chooses from, drawn (`--candidates`) or given
/// (`--from`): what the plan holds of each (its configuration and its rows of
/// the identification Jacobian, about 3 KB) and its exchanges keep the peak
/// memory within 0.3 GB at this bound: 30 poses of a UR10e from 10⁵
/// candidates, 0.21 GB and 8 s on a 2-core machine; 50 of a PUMA 560, 0.31 GB
/// and 52 s (`scripts/scale-bench.py` measures the first). The poses are at
/// most the candidates.
pub const MAX_CANDIDATES: usize = 100_000;

/// What `plan` is asked.
#[derive(Clone, Debug, Default)]
pub struct Request {
    /// Poses to measure (at least 1).
    pub poses: usize,
    /// Whether orientations are measured too.
    pub orientation: bool,
    /// The position noise per axis (model length unit); `None`: 20 µm.
    pub noise: Option<f64>,
    /// The orientation noise per axis (model angle unit); `None`: 20 µrad.
    pub orientation_noise: Option<f64>,
    /// A box the tool point stays in, `[x_min, y_min, z_min, x_max, y_max,
    /// z_max]`, measurement frame, model length unit.
    pub within: Option<Vec<f64>>,
    /// A floor the tool point stays above (its height z, model length unit).
    pub above: Option<f64>,
    /// The share of each joint's range kept off each limit; `None`: 5 %.
    pub margin: Option<f64>,
    /// Random candidates drawn when none are given; `None`: 10,000.
    pub candidates: Option<usize>,
    /// The effects the measurement must serve besides the geometry, by name
    /// (`backlash`: each pose approached from both sides).
    pub effects: Vec<String>,
    /// For a session without a tracker: the sockets the ball is seated in
    /// (SI, as read).
    pub sockets: Option<Sockets>,
    /// The least conditioning of a planned pose (0 to below 1); `None`: 0,
    /// every candidate kept.
    pub singularity_margin: Option<f64>,
    /// What the poses are chosen for (I-optimal by default).
    pub criterion: Optimality,
    /// Seed of every draw.
    pub seed: u64,
}

impl Request {
    /// The options of this request on `model`, SI: refused when a value is
    /// out of range.
    pub fn options(&self, front: Front, model: &RobotModel) -> Result<PlanOptions, InputError> {
        let u = &model.units;
        let refuse =
            |flag: &'static str, message: String| InputError::argument(front.flag(flag), message);
        let positive = |flag: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(refuse(
                    flag,
                    format!("{}: must be a positive number", number(v)),
                ))
            }
        };
        if self.poses == 0 {
            return Err(refuse("--poses", "0: at least 1".into()));
        }
        let mut options = PlanOptions {
            poses: self.poses,
            criterion: self.criterion,
            seed: self.seed,
            ..PlanOptions::default()
        };
        options.prior = model.prior;
        if let Some(n) = self.noise {
            options.position_noise = u.length_to_si(positive("--noise", n)?);
        }
        let orientation_noise = match self.orientation_noise {
            Some(n) => u.angle_to_si(positive("--orientation-noise", n)?),
            None => ORIENTATION_NOISE,
        };
        if self.orientation {
            options.instrument = Instrument::Poses { orientation_noise };
        }
        if let Some(m) = self.margin {
            if !(0.0..0.5).contains(&m) {
                return Err(refuse(
                    "--margin",
                    format!(
                        "{}: the share of each joint's range kept off each limit, from 0 to below 0.5",
                        number(m)
                    ),
                ));
            }
            options.margin = m;
        }
        if let Some(c) = self.singularity_margin {
            if !(0.0..1.0).contains(&c) {
                return Err(refuse(
                    "--singularity-margin",
                    format!(
                        "{}: the least conditioning of a pose (the smallest singular value of its \
                         manipulator Jacobian over the largest), from 0 to below 1",
                        number(c)
                    ),
                ));
            }
            options.singularity_margin = c;
        }
        if self.poses > MAX_CANDIDATES {
            return Err(refuse(
                "--poses",
                format!(
                    "{}: at most {MAX_CANDIDATES}, the most candidates a plan chooses from",
                    self.poses
                ),
            ));
        }
        if let Some(c) = self.candidates {
            if c > MAX_CANDIDATES {
                return Err(refuse(
                    "--candidates",
                    format!(
                        "{c}: at most {MAX_CANDIDATES} (each held while the plan runs: about 3 KB, \
                         and the exchanges' time grows faster than their number)"
                    ),
                ));
            }
            if c < self.poses {
                return Err(refuse(
                    "--candidates",
                    format!("{c}: at least the {} poses asked", self.poses),
                ));
            }
            options.candidates = c;
        }
        if let Some(b) = &self.within {
            let ok =
                b.len() == 6 && b.iter().all(|v| v.is_finite()) && (0..3).all(|k| b[k] < b[k + 3]);
            if !ok {
                return Err(refuse(
                    "--within",
                    format!(
                        "{}: six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX ({}), each minimum below its maximum",
                        b.iter().map(f64::to_string).collect::<Vec<_>>().join(","),
                        u.length
                    ),
                ));
            }
            for k in 0..3 {
                options.cell.min[k] = u.length_to_si(b[k]);
                options.cell.max[k] = u.length_to_si(b[k + 3]);
            }
        }
        for effect in &self.effects {
            match effect.as_str() {
                "backlash" => options.visits = Visits::BothSides,
                "compliance" => options.compliance = true,
                other => {
                    return Err(refuse(
                        "--effects",
                        format!(
                            "{other}: the plans serve `backlash` (each pose approached from both \
                             sides) and `compliance` (the joints' gravity torques spread); the \
                             geometry is served always"
                        ),
                    ));
                }
            }
        }
        if let Some(z) = self.above {
            if !z.is_finite() {
                return Err(refuse(
                    "--above",
                    format!("{}: must be a number", number(z)),
                ));
            }
            options.cell.min[2] = options.cell.min[2].max(u.length_to_si(z));
            if options.cell.min[2] >= options.cell.max[2] {
                return Err(refuse(
                    "--above",
                    format!("{}: above the box's top", number(z)),
                ));
            }
        }
        // A model without joint limits would plan through the table the
        // robot stands on: its flange and tool point stay above its base
        // plane unless the cell is given.
        options.above_base = self.sockets.is_none()
            && self.within.is_none()
            && self.above.is_none()
            && model.robot.links.iter().any(|l| l.limits.is_none());
        if let Some(plate) = &self.sockets {
            let clash = [
                (
                    self.orientation,
                    "--orientation: a ball in a socket gives no orientation",
                ),
                (
                    self.within.is_some() || self.above.is_some(),
                    "--within/--above: the ball's centre is at the sockets",
                ),
                (
                    options.visits == Visits::BothSides,
                    "--effects backlash: a pose approached from both sides leaves its socket",
                ),
            ];
            if let Some((_, why)) = clash.iter().find(|(c, _)| *c) {
                return Err(refuse("--sockets", format!("not with {why}")));
            }
            options.instrument = Instrument::Sockets(plate.clone());
        }
        Ok(options)
    }
}

/// The candidates a user gives (`--from`, SI) that keep within `model`'s
/// joint limits less the margin: those kept, and how many were dropped.
pub fn within_limits(
    model: &RobotModel,
    rows: Vec<Vec<f64>>,
    margin: f64,
) -> (Vec<Vec<f64>>, usize) {
    let before = rows.len();
    let kept: Vec<Vec<f64>> = rows
        .into_iter()
        .filter(|q| {
            model
                .robot
                .links
                .iter()
                .zip(q)
                .all(|(l, v)| match l.limits {
                    Some([lo, hi]) => {
                        let keep = margin * (hi - lo);
                        lo + keep <= *v && *v <= hi - keep
                    }
                    None => true,
                })
        })
        .collect();
    let dropped = before - kept.len();
    (kept, dropped)
}

/// The plan `request` asks of `model`, from the candidates `from` (SI; the
/// ones within the limits) or random ones, for the workspace `targets` (SI)
/// or random configurations; giving up with
/// [`crate::calibration::plan::PlanError::Cancelled`] once `cancelled` is
/// true (asked between the plan's steps).
pub fn run(
    front: Front,
    model: &RobotModel,
    request: &Request,
    from: Option<&[Vec<f64>]>,
    targets: Option<&[Vec<f64>]>,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> anyhow::Result<(Plan, PlanOptions)> {
    let options = request.options(front, model)?;
    if options.instrument.sockets().is_some() && from.is_some() {
        return Err(InputError::argument(
            front.flag("--sockets"),
            "not with --from: a socket plan's candidates are the configurations that reach its \
             sockets",
        )
        .into());
    }
    if let Some(from) = from
        && from.len() > MAX_CANDIDATES
    {
        return Err(InputError::argument(
            front.flag("--from"),
            format!(
                "{} candidates within the limits: at most {MAX_CANDIDATES} (a plan holds about 3 KB \
                 of each); give a sample of them",
                from.len()
            ),
        )
        .into());
    }
    let plan = plan_cancellable(&model.robot, from, targets, &options, cancelled)?;
    Ok((plan, options))
}
