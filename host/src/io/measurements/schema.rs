//! The shape of a data file: which file is read ([`Kind`]) against what
//! ([`Schema`]), the role of each header name ([`Role`]), what a data line is
//! as read ([`Item`]: a [`Record`] in SI — rad or m per joint, m, s, °C, kg —
//! or a [`DistanceLine`], m), the columns used and ignored ([`Columns`]), and
//! the warnings about them and about readings outside the joints' limits.

use armcal_shared::Robot;
use armcal_shared::units::Units;
use nalgebra::UnitQuaternion;

use crate::session::constraints::DistanceLine;
use crate::session::measurements::POSITION;

/// The most measured poses a measurement file holds: three million, 50 minutes
/// of a tracker's 1 kHz stream and what `armcal simulate` writes at most. Each
/// pose is held while the calibration runs (a few hundred bytes): the rows,
/// not only the bytes, bound the memory, whatever the rows' length; a file or
/// a stream is refused at the row past the bound, as it is read.
pub const MAX_MEASURED_ROWS: usize = 3_000_000;

/// The most rows a joints file holds (`predict`, `compensate`, `stream`): ten
/// million, close to three hours of 1 kHz servo commands (each row held as
/// read: about a hundred bytes).
pub const MAX_JOINT_ROWS: usize = 10_000_000;

/// Which file is read: the columns it needs and those it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    /// Measured poses: `q1..qM, x, y, z` required, the quaternion read.
    Measurements,
    /// Joint readings: `q1..qM` required, the pose columns not read.
    Joints,
}

impl Kind {
    /// The required columns, for messages.
    pub(super) fn required(self, m: usize) -> String {
        match self {
            Self::Measurements => format!("q1..q{m}, x, y, z"),
            Self::Joints => format!("q1..q{m}"),
        }
    }

    /// The columns read, for the warning about the others.
    pub(super) fn used(self, m: usize) -> String {
        match self {
            Self::Measurements => {
                format!("q1..q{m}, x, y, z, qw, qx, qy, qz, t, temp, load, tau1..tau{m}")
            }
            Self::Joints => format!("q1..q{m}, t, temp, load"),
        }
    }

    /// The most data rows a file of this kind holds ([`MAX_MEASURED_ROWS`],
    /// [`MAX_JOINT_ROWS`]).
    pub(super) fn max_rows(self) -> usize {
        match self {
            Self::Measurements => MAX_MEASURED_ROWS,
            Self::Joints => MAX_JOINT_ROWS,
        }
    }

    /// What one data row is, for messages.
    pub(super) fn row_noun(self) -> &'static str {
        match self {
            Self::Measurements => "measured pose",
            Self::Joints => "row of joint readings",
        }
    }
}

/// What a file is read against.
pub(super) struct Schema<'m> {
    /// Joint count, joint types (the unit of each reading) and limits.
    pub(super) robot: &'m Robot<f64>,
    /// The units of the file.
    pub(super) units: Units,
    /// Which file.
    pub(super) kind: Kind,
}

impl Schema<'_> {
    pub(super) fn dof(&self) -> usize {
        self.robot.dof()
    }
}

/// One data row as read, in SI, before it becomes an
/// [`Observation`](crate::session::observation::Observation) or a
/// [`JointRow`](crate::session::joints::JointRow)
/// (a joints file leaves `position` at 0 and `orientation` empty).
pub(super) struct Record {
    pub(super) line: usize,
    pub(super) q: Vec<f64>,
    pub(super) position: [f64; 3],
    pub(super) orientation: Option<UnitQuaternion<f64>>,
    pub(super) t: Option<f64>,
    pub(super) temp: Option<f64>,
    pub(super) load: Option<f64>,
    /// The joints' measured torques (`tau1..tauM`, N·m or N), in a file that
    /// has them.
    pub(super) torque: Option<Vec<f64>>,
    /// The unknown fixed point the row names (`point` column): its name and the
    /// place of its cell.
    pub(super) point: Option<(String, Place)>,
    /// The unknown plane the row names (`plane` column), likewise.
    pub(super) plane: Option<(String, Place)>,
    /// The place and the name of the row's first coordinate when it measures
    /// all of x, y, z (in a file with a `point` or `plane` column).
    pub(super) measured: Option<(Place, &'static str)>,
}

/// The line and character column of a cell. A cell after a quoted field that
/// spans lines is on a later line than its record's first.
pub(super) type Place = (usize, usize);

/// What a data line of a file is.
pub(super) enum Item {
    /// A row: one pose.
    Row(Record),
    /// A known distance between two named points.
    Distance(DistanceLine),
}

/// The columns of a file as read.
pub(super) struct Columns {
    /// The header's line and names, in file order.
    pub(super) header: (usize, Vec<String>),
    /// The header names of the columns used, in file order.
    pub(super) used: Vec<String>,
    /// The header names of the columns not read, in file order.
    pub(super) ignored: Vec<String>,
    /// Things the user should know that do not stop the computation.
    pub(super) warnings: Vec<String>,
}

/// What a column of the file feeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Role {
    /// Joint reading, 0-based joint index.
    Joint(usize),
    /// Position component 0, 1, 2 (x, y, z).
    Position(usize),
    /// Quaternion component 0..4 (w, x, y, z).
    Quat(usize),
    T,
    Temp,
    Load,
    /// A joint's measured torque, 0-based joint index.
    Torque(usize),
    /// The name of the unknown fixed point the tool point sits at.
    Point,
    /// The name of the unknown plane the tool point touches.
    Plane,
    Ignored,
}

pub(super) const QUAT: [&str; 4] = ["qw", "qx", "qy", "qz"];

/// The role of a header name in a file of `kind` (`q0` is no joint; the header
/// check refuses it). A joints file does not read the pose columns.
pub(super) fn role_of(name: &str, kind: Kind) -> Role {
    if let Some(i) = POSITION.iter().position(|n| *n == name) {
        return match kind {
            Kind::Measurements => Role::Position(i),
            Kind::Joints => Role::Ignored,
        };
    }
    if let Some(i) = QUAT.iter().position(|n| *n == name) {
        return match kind {
            Kind::Measurements => Role::Quat(i),
            Kind::Joints => Role::Ignored,
        };
    }
    match name {
        "point" if kind == Kind::Measurements => return Role::Point,
        "plane" if kind == Kind::Measurements => return Role::Plane,
        "t" => return Role::T,
        "temp" => return Role::Temp,
        "load" => return Role::Load,
        _ => {}
    }
    if let Some(k) = joint_index(name).filter(|&k| k > 0) {
        return Role::Joint(k - 1);
    }
    if let Some(k) = torque_index(name).filter(|&k| k > 0 && kind == Kind::Measurements) {
        return Role::Torque(k - 1);
    }
    Role::Ignored
}

/// `k` for a column `tau<k>`, as [`joint_index`] reads `q<k>`.
pub(super) fn torque_index(name: &str) -> Option<usize> {
    joint_index(&format!("q{}", name.strip_prefix("tau")?))
}

/// `k` for a column `q<k>` (decimal, no leading zero, `q0` gives 0).
pub(super) fn joint_index(name: &str) -> Option<usize> {
    let digits = name.strip_prefix('q')?;
    if digits.is_empty()
        || !digits.bytes().all(|b| b.is_ascii_digit())
        || (digits.len() > 1 && digits.starts_with('0'))
    {
        return None;
    }
    // More digits than fit are still a (huge) joint number.
    Some(digits.parse::<usize>().unwrap_or(usize::MAX))
}

/// The warning naming the columns `ignored` kept out of the computation, if any.
pub(super) fn ignored_warning(
    file: &str,
    line: usize,
    ignored: &[String],
    schema: &Schema<'_>,
) -> Option<String> {
    if ignored.is_empty() {
        return None;
    }
    let names: Vec<String> = ignored
        .iter()
        .map(|n| {
            if n.is_empty() {
                "(unnamed)".to_owned()
            } else {
                format!("'{n}'")
            }
        })
        .collect();
    Some(format!(
        "{file}:{line}: columns kept out of the computation: {} (used: {})",
        names.join(", "),
        schema.kind.used(schema.dof())
    ))
}

/// ` (found 'X': column names are case-sensitive)` when a header name matches
/// `wanted` but for case.
pub(super) fn case_hint(names: &[&str], wanted: &str) -> String {
    names
        .iter()
        .find(|n| n.eq_ignore_ascii_case(wanted))
        .map(|n| format!(" (found '{n}': column names are case-sensitive)"))
        .unwrap_or_default()
}

/// The readings outside each joint's limits, tallied row by row, for one
/// warning per joint: the first (its line and value) and how many.
pub(super) struct LimitTally {
    pub(super) joints: Vec<JointTally>,
}

/// One joint's [`LimitTally`]: its limits, the first reading outside them
/// (line, value) and the count.
pub(super) type JointTally = (Option<[f64; 2]>, Option<(usize, f64)>, usize);

impl LimitTally {
    pub(super) fn new(schema: &Schema<'_>) -> Self {
        Self {
            joints: schema
                .robot
                .links
                .iter()
                .map(|l| (l.limits, None, 0))
                .collect(),
        }
    }

    pub(super) fn add(&mut self, record: &Record) {
        for ((limits, first, count), &q) in self.joints.iter_mut().zip(&record.q) {
            if let Some([lo, hi]) = *limits
                && (q < lo || q > hi)
            {
                first.get_or_insert((record.line, q));
                *count += 1;
            }
        }
    }

    /// One warning per joint with readings outside its limits.
    pub(super) fn warnings(&self, file: &str, schema: &Schema<'_>) -> Vec<String> {
        let units = schema.units;
        let mut warnings = Vec::new();
        for (j, (link, (limits, first, count))) in
            schema.robot.links.iter().zip(&self.joints).enumerate()
        {
            if let (Some([lo, hi]), Some((line, q))) = (limits, first) {
                let unit = units.joint_unit(link.joint);
                warnings.push(format!(
                    "{file}:{line}: q{} = {} {unit} is outside the model's limits [{}, {}] {unit} ({count} reading(s) outside in all)",
                    j + 1,
                    units.joint_from_si(link.joint, *q),
                    units.joint_from_si(link.joint, *lo),
                    units.joint_from_si(link.joint, *hi),
                ));
            }
        }
        warnings
    }
}
