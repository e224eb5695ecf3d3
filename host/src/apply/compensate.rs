//! `armcal compensate`: for each row of joint commands that the controller's
//! nominal model computed, the commands that make the calibrated robot reach the
//! pose the nominal model intended.
//!
//! The computation is [`armcal_shared::compensation::Compensator`] in `f64`, the
//! same code the firmware runs in `f32`: the perturbation approach of Kirchner,
//! Gurumoorthy & Prinz (1985), section 4 (eq. 4.9), refined until the residual is
//! below its tolerance (the task, the frame of the targets and the uniqueness of
//! the answer are that module's). Rows are taken in the order they are sent,
//! with a [`Pacing`]: by default each row is a robot program's target point,
//! solved alone to convergence; with `--servo` ([`Pacing::Servo`]) they are
//! consecutive servo ticks, warm-started, each correction changing from the
//! previous row's by at most the per-tick bound, as on the controller.
//!
//! Non-geometric effects (a calibration from `armcal diagnose`) are compensated
//! in each row's conditions, its `temp` and `load` columns
//! ([`crate::apply::predict::row_conditions`], as `armcal predict` reads them), and
//! with the approach direction of each joint from the previous row's corrected
//! commands (the commands sent; see [`armcal_shared::compensation`]): `armcal
//! predict` on the output rows, with the same columns, gives the nominal poses.
//!
//! Units: commands are read in the calibration's model units (the angle unit for
//! revolute joints, the length unit for prismatic ones) and written back in them,
//! `q1..qM` with Rust's shortest round-trip formatting. A row whose correction was
//! bounded, whose pose was not reached or that could not be computed is named on
//! standard error with its line; a row that could not be computed keeps its
//! nominal command.
//!
//! A correction flagged [`Fault::NotConverged`] is one of two things, told apart
//! by the residual it carries: above the tolerance the pose is missed (near a
//! singularity, out of reach, within a joint's lost motion), and the row is
//! named; at or below it the pose is reached and only the search for the least
//! correction (the joints left free by the task) ran out of iterations, so the
//! commands are good but may not be the command's own least change: such rows
//! are counted once ([`RowWarning::Unsettled`]).

use armcal_shared::compensation::Task;
use core::fmt::Write as _;

use armcal_shared::compensation::{
    Compensator, Correction, Fault, Limits, Pacing, Stream, TargetFrame,
};
use armcal_shared::{Calibration, JointType, Param};

use crate::apply::predict::row_conditions;
use crate::apply::ranges::{ROWS_NAMED, RowNames};
use crate::session::joints::JointRows;

/// A CSV of joint commands `q1..qM` (SI in, the calibration's model units out,
/// shortest round-trip formatting) after a `#` comment line.
pub fn joints_csv(
    comment: &str,
    cal: &Calibration,
    rows: impl Iterator<Item = Vec<f64>>,
) -> String {
    let units = &cal.units;
    let joints: Vec<JointType> = cal.nominal.links.iter().map(|l| l.joint).collect();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# {comment}; joints in {} (revolute) and {} (prismatic)",
        units.angle, units.length
    );
    let header: Vec<String> = (1..=joints.len()).map(|m| format!("q{m}")).collect();
    let _ = writeln!(out, "{}", header.join(","));
    for q in rows {
        let values: Vec<String> = q
            .iter()
            .zip(&joints)
            .map(|(q, j)| {
                let v = units.joint_from_si(*j, *q);
                if v == 0.0 {
                    "0".to_string()
                } else {
                    format!("{v}")
                }
            })
            .collect();
        let _ = writeln!(out, "{}", values.join(","));
    }
    out
}

/// The corrected commands of every row, in order, with what each row reported.
#[derive(Clone, Debug)]
pub struct Compensated {
    /// `(line, correction)` per input row.
    pub rows: Vec<(usize, Correction<f64>)>,
    /// Per input row, how far the flange turns from the orientation the
    /// calibrated model has at the command, rad ([`Compensator::turn`]):
    /// zero for a full-pose calibration.
    pub turns: Vec<f64>,
    /// The residual below which a row's pose is reached, m ([`Limits::tolerance`]).
    pub tolerance: f64,
}

/// A base error from which the compensation of targets in the world frame
/// names the registration when rows are bounded: 10 mm or 10 mrad, a camera's
/// or a tracker's frame rather than a robot's mounting.
pub const REGISTRATION: (f64, f64) = (0.01, 0.01);

/// A turn of the flange (rad) from the orientation the calibrated model has at
/// the command beyond which a row of a position-only calibration is named:
/// 1 mrad, of the order of a robot's own orientation error (an arm off by
/// 1 mm / 1 mrad turns its flange by 1–4 mrad), which moves the tip of a
/// 250 mm tool by 0.25 mm. Away from singularities the compensation keeps
/// the orientation to within a few µrad
/// ([`armcal_shared::compensation::Task::Position`]).
pub const TURN: f64 = 1e-3;

/// The warning of a row flagged [`Fault::NotConverged`] whose `residual` (m)
/// is above the tolerance: its pose is not reached.
pub fn missed(residual: f64) -> String {
    format!(
        "did not converge: the pose is missed by {residual:.3e} m (near a singularity, out of \
         reach, or within a joint's lost motion)"
    )
}

/// What a compensation says of its rows, for the user: a row whose
/// correction was bounded, missed its pose or could not be computed, and one
/// count of the rows whose pose is reached but whose search for the least
/// correction did not settle.
#[derive(Clone, Debug, PartialEq)]
pub enum RowWarning {
    /// One row: its line (a file's line, or an array's row from 1) and what
    /// happened to it.
    Row {
        /// The row's line.
        line: usize,
        /// What happened.
        what: String,
    },
    /// `bounded` of `rows` rows were bounded or missed their pose while the
    /// calibration's targets are in the world frame and its base (the
    /// instrument's registration) is `base` (m, rad) from the model's: the
    /// arm is asked to move by the registration.
    Registration {
        /// Rows bounded or missed.
        bounded: usize,
        /// Rows in all.
        rows: usize,
        /// The largest base translation (m) and rotation (rad).
        base: (f64, f64),
    },
    /// Rows of a position-only calibration whose point is reached with the
    /// flange turned by more than [`TURN`] from the orientation the
    /// calibrated model has at the command: near a singularity, keeping the
    /// orientation would ask for a larger correction.
    Turned {
        /// `(line, turn)` of each such row, rad, in order.
        turned: Vec<(usize, f64)>,
        /// Rows in all.
        rows: usize,
    },
    /// `count` of `rows` rows flagged [`Fault::NotConverged`] reach their
    /// pose (residual within the tolerance), but their search for the least
    /// correction did not settle in its iterations.
    Unsettled {
        /// Rows that did not settle.
        count: usize,
        /// Rows in all.
        rows: usize,
    },
}

impl RowWarning {
    /// The warning of the commands `commands` (a file, or the array the
    /// Python package names) with its rows named as `names` says.
    pub fn text(&self, commands: &str, names: RowNames) -> String {
        match (self, names) {
            (Self::Row { line, what }, RowNames::FileLines) => format!("{commands}:{line}: {what}"),
            (Self::Row { line, what }, RowNames::ArrayRows) => {
                format!("{commands} row {}: {what}", line - 1)
            }
            (
                Self::Registration {
                    bounded,
                    rows,
                    base: (length, angle),
                },
                _,
            ) => format!(
                "{commands}: {bounded} of {rows} rows were bounded or missed, and the calibration's \
                 base (the instrument's registration, {:.1} mm and {:.1} mrad from the model's) is \
                 compensated because its targets are in the world frame of its measurements: for \
                 targets in the robot's own base frame, identify or diagnose with --targets base \
                 (Python: targets=\"base\")",
                length * 1e3,
                angle * 1e3
            ),
            (Self::Turned { turned, rows }, names) => {
                let (worst_line, worst) = turned
                    .iter()
                    .copied()
                    .fold((0, 0.0), |w, t| if t.1 > w.1 { t } else { w });
                let lines: Vec<usize> = turned.iter().map(|(l, _)| *l).collect();
                let each: Vec<String> = turned
                    .iter()
                    .take(ROWS_NAMED)
                    .map(|(_, t)| format!("{:.2}", t * 1e3))
                    .collect();
                format!(
                    "{commands}: on {} of {rows} rows the point is reached with the flange turned \
                     from the orientation the calibrated model has at the command by more than \
                     {} mrad, at worst {:.2} mrad ({}): near a singularity, keeping the \
                     orientation would ask for a larger joint correction; {} turned by {} mrad",
                    turned.len(),
                    TURN * 1e3,
                    worst * 1e3,
                    names.list(&[worst_line], 1),
                    names.list(&lines, lines.len()),
                    each.join(", "),
                )
            }
            (Self::Unsettled { count, rows }, _) => format!(
                "{commands}: {count} of {rows} rows reach their pose, but the search for the \
                 least joint change did not settle in its iterations (near a singularity, or a \
                 servo tick's few): their commands reach the pose and may differ from the least \
                 correction"
            ),
        }
    }

    /// The texts of `warnings` (of `rows` rows of the commands `commands`,
    /// rows named as `names` says) with the rows that report the same thing
    /// in one text:
    /// `{commands}: what, on 3 of 40 rows (rows 3, 7, 12)` (the rows as the
    /// range warnings list them: [`RowNames::list`]), for a front end that
    /// shows each text once.
    pub fn grouped(warnings: &[Self], rows: usize, commands: &str, names: RowNames) -> Vec<String> {
        let mut groups: Vec<(&str, Vec<usize>)> = Vec::new();
        let mut others = Vec::new();
        for w in warnings {
            match w {
                Self::Row { line, what } => match groups.iter_mut().find(|(w, _)| *w == what) {
                    Some((_, lines)) => lines.push(*line),
                    None => groups.push((what, vec![*line])),
                },
                other => others.push(other.text(commands, names)),
            }
        }
        groups
            .into_iter()
            .map(|(what, lines)| {
                format!(
                    "{commands}: {what}, on {} of {rows} rows ({})",
                    lines.len(),
                    names.list(&lines, lines.len())
                )
            })
            .chain(others)
            .collect()
    }

    /// The warnings of rows `(line, what)`, of the rows `turned` beyond
    /// [`TURN`] (`(line, turn)`, none when none), of `settling` of `rows`
    /// rows that did not settle (none when none), and, when rows were named
    /// and the calibration compensates a `registration` ([`registration`]),
    /// of that.
    pub fn of_rows(
        named: impl Iterator<Item = (usize, String)>,
        turned: Vec<(usize, f64)>,
        settling: usize,
        rows: usize,
        registration: Option<(f64, f64)>,
    ) -> Vec<Self> {
        let mut out: Vec<Self> = named.map(|(line, what)| Self::Row { line, what }).collect();
        let bounded = out.len();
        if !turned.is_empty() {
            out.push(Self::Turned { turned, rows });
        }
        if settling > 0 {
            out.push(Self::Unsettled {
                count: settling,
                rows,
            });
        }
        if let (Some(base), true) = (registration, bounded > 0) {
            out.push(Self::Registration {
                bounded,
                rows,
                base,
            });
        }
        out
    }
}

/// Compensates every row of `commands` in order, with `pacing`.
///
/// A robot program's point of a position-only calibration whose correction
/// keeping the flange's orientation is bounded, or misses its point (near a
/// singularity, where keeping the orientation asks for large joint
/// motions), takes the least correction that reaches the point instead,
/// computed in a second pass over the rows (the same approach directions);
/// its turn is reported as every row's. Servo ticks keep one stream.
pub fn compensate(cal: &Calibration, commands: &JointRows, pacing: Pacing) -> Compensated {
    let limits = Limits::of(pacing);
    let compensator = Compensator::<f64>::from_calibration(cal, limits);
    let run = |compensator: &Compensator<f64>| -> Vec<Correction<f64>> {
        let mut stream = Stream::new(pacing);
        commands
            .rows
            .iter()
            .map(|row| stream.tick(compensator, &row.q, &row_conditions(row)))
            .collect()
    };
    let mut corrections = run(&compensator);
    let failed = |c: &Correction<f64>| {
        c.fault == Some(Fault::Limited)
            || (c.fault == Some(Fault::NotConverged) && c.residual > limits.tolerance)
    };
    if pacing == Pacing::Program && cal.task == Task::Position && corrections.iter().any(failed) {
        let least = Compensator::<f64>::from_calibration(
            cal,
            Limits {
                turn_scale: 0.0,
                ..limits
            },
        );
        for (c, again) in corrections.iter_mut().zip(run(&least)) {
            if failed(c) && !failed(&again) {
                *c = again;
            }
        }
    }
    let rows: Vec<(usize, Correction<f64>)> = commands
        .rows
        .iter()
        .map(|row| row.line)
        .zip(corrections)
        .collect();
    let turns = commands
        .rows
        .iter()
        .zip(&rows)
        .map(|(row, (_, c))| compensator.turn(&row.q, &c.p).unwrap_or(0.0))
        .collect();
    Compensated {
        rows,
        turns,
        tolerance: limits.tolerance,
    }
}

/// The calibration's base error (largest translation m, rotation rad) when
/// its targets are in the world frame and it reaches [`REGISTRATION`].
pub fn registration(cal: &Calibration) -> Option<(f64, f64)> {
    if cal.targets != TargetFrame::World {
        return None;
    }
    let (mut length, mut angle) = (0.0_f64, 0.0_f64);
    for e in &cal.errors {
        if let Param::Base(ax) = e.param {
            if ax.is_angle() {
                angle = angle.max(e.error.abs());
            } else {
                length = length.max(e.error.abs());
            }
        }
    }
    (length >= REGISTRATION.0 || angle >= REGISTRATION.1).then_some((length, angle))
}

impl Compensated {
    /// The CSV `q1..qM` in the model's units, with a comment line naming its origin.
    pub fn to_csv(&self, cal: &Calibration, calibration_file: &str) -> String {
        joints_csv(
            &format!(
                "armcal compensate: commands for the calibrated robot from {calibration_file}"
            ),
            cal,
            self.rows.iter().map(|(_, c)| c.q.to_vec()),
        )
    }

    /// What the compensation of `cal` says of its rows ([`RowWarning`]):
    /// each row that reported something, in order, the count of the rows
    /// that did not settle, and the registration of `cal` the rows were
    /// asked to move by, when they were bounded ([`registration`]).
    pub fn warnings(&self, cal: &Calibration) -> Vec<RowWarning> {
        let mut settling = 0;
        let turned: Vec<(usize, f64)> = self
            .rows
            .iter()
            .zip(&self.turns)
            .filter(|((_, c), turn)| **turn > TURN && c.residual <= self.tolerance)
            .map(|((line, _), turn)| (*line, *turn))
            .collect();
        let named: Vec<(usize, String)> = self
            .rows
            .iter()
            .filter_map(|(line, c)| {
                let what = match c.fault? {
                    Fault::NonFinite => {
                        "not computable (a value was not finite): nominal command kept".to_string()
                    }
                    Fault::JointCount => "wrong joint count: nominal command kept".to_string(),
                    Fault::NotConverged if c.residual <= self.tolerance => {
                        settling += 1;
                        return None;
                    }
                    Fault::NotConverged => missed(c.residual),
                    Fault::Limited => {
                        "correction bounded (its size, or its change per servo tick)".to_string()
                    }
                    f => format!("{f:?}"),
                };
                Some((*line, what))
            })
            .collect();
        RowWarning::of_rows(
            named.into_iter(),
            turned,
            settling,
            self.rows.len(),
            registration(cal),
        )
    }
}
