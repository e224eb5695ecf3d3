//! Measured poses: the CSV of `docs/file-formats.md` §2, read against a robot model.
//!
//! One row per measured pose, in the order the poses were measured (row order
//! carries information: the direction from which each joint approached a pose is
//! the sign of its last change, held through the rows where it holds, so rows are
//! kept in file order).
//! Lines that start with `#` are comments; the first other line is the header;
//! blank lines are skipped; fields are trimmed. Lines end at `\n`, `\r\n` or a
//! lone `\r`.
//!
//! | column | required | unit on file | read into |
//! | --- | --- | --- | --- |
//! | `q1` … `qM` | yes | model angle unit (revolute) or length unit (prismatic) | [`Observation::q`], rad or m |
//! | `x`, `y`, `z` | yes | model length unit, measurement frame | [`Observation::position`], m |
//! | `qw`, `qx`, `qy`, `qz` | no, all four or none | unit quaternion, scalar first | [`Observation::orientation`], normalised |
//! | `t` | no | s | [`Measurements::times`] |
//! | `temp` | no | °C | [`Observation::context`] |
//! | `load` | no | kg | [`Observation::context`] |
//!
//! Other columns (an id, a comment) are kept out of the computation, listed in
//! [`Measurements::columns_ignored`] and named in a warning. An empty cell of an
//! optional column means "not measured for this pose" (all four quaternion cells
//! empty: no orientation for this pose).
//!
//! Refusals are [`InputError`]s naming the file, the line, the character column of
//! the offending field and the column's header name: a missing required column, a
//! `q` column beyond the model's joint count or a missing one (joint-count
//! mismatch), a duplicate column name, a row with the wrong number of fields, a
//! value that is not a finite number, a partial quaternion, a quaternion whose norm
//! differs from 1 by more than [`QUATERNION_NORM_TOLERANCE`], a `temp` outside
//! [`TEMPERATURE_RANGE`] or a `load` outside [`PAYLOAD_RANGE`], no data rows, and —
//! once the caller knows how many parameters it identifies — fewer equations
//! than unknowns ([`Measurements::require_poses`]).
//!
//! ## Joint readings
//!
//! [`parse_joints`] reads the same CSV for `armcal predict` and `compensate`: only
//! `q1` … `qM` are required. `t`, `temp` and `load` are read as above and kept on
//! each [`JointRow`]; `x`, `y`, `z`, `qw`, `qx`, `qy`, `qz` are allowed (a
//! measurement file may be fed as it is) but not read: they are listed in
//! [`JointRows::columns_ignored`] with any other column, and named in a warning.
//! Every other refusal is the measurement reader's, from the same code.
//!
//! The `csv` crate splits the records; the column of a field is found by scanning
//! the raw line for commas outside double quotes. A file is read as a stream,
//! one record at a time, into [`Observation`]s (one copy of each pose, which
//! the identification then reads in place): memory grows with the poses, not
//! with the text.

use armcal_shared::effects::Approach;
use armcal_shared::units::Units;
use armcal_shared::{JointType, Robot};
use nalgebra::{Point3, Quaternion, UnitQuaternion};

use crate::io::builtin;
use crate::io::input_error::{DATA_FILE, InputError, SizeLimit, open_bounded};
use crate::io::model_file::RobotModel;
use crate::session::constraints::{
    Constraints, DEFAULT_DISTANCE_STD, Distance, MIN_PLANE_TOUCHES, Named, RESERVED, merge_named,
};

pub use crate::session::joints::{JointRow, JointRows};
pub use crate::session::measurements::*;

/// The mean nominal tool point (m, base frame) of the rows of `poses` held
/// to each of `points` fixed points; `None` for a point no row the model
/// can place names.
fn nominal_point_means(
    robot: &Robot<f64>,
    poses: &[Observation],
    points: usize,
) -> Vec<Option<Point3<f64>>> {
    let kinematics = robot.prepare();
    let mut sums = vec![(nalgebra::Vector3::zeros(), 0usize); points];
    for p in poses {
        if let (Contact::Point(k), Ok(t)) = (p.contact, kinematics.forward(&p.q))
            && let Some((sum, n)) = sums.get_mut(k)
        {
            *sum += t.translation.vector;
            *n += 1;
        }
    }
    sums.into_iter()
        .map(|(sum, n)| (n > 0).then(|| Point3::from(sum / n as f64)))
        .collect()
}

/// Refuses the distance line `d` when the nominal model puts its two points
/// `nominal` m apart and the stated length contradicts it by far more than
/// a geometric error could: more than a factor of 2 apart and by more than
/// twice [`FIT_LIMIT`] of the robot's `reach` (each point's nominal tool
/// point may miss by that much and the data still carry a calibration). A
/// length unit other than the model's gives a factor of 25.4 or more (mm,
/// in, m): the message names the unit that fits, if one does.
fn require_plausible_distance(
    file: &str,
    d: &DistanceLine,
    nominal: f64,
    reach: f64,
    units: &Units,
) -> Result<(), InputError> {
    let (stated, apart) = (d.length, (d.length - nominal).abs());
    let within_factor = |x: f64| x <= 2.0 * nominal && nominal <= 2.0 * x;
    if within_factor(stated) || apart <= 2.0 * FIT_LIMIT * reach {
        return Ok(());
    }
    let unit = units.length;
    let value = units.length_from_si(stated);
    // The unit the written number fits the nominal distance in, if any.
    let hint = armcal_shared::units::LengthUnit::ALL
        .into_iter()
        .filter(|&u| u != unit)
        .find(|&u| {
            let as_u = Units {
                length: u,
                ..*units
            }
            .length_to_si(value);
            within_factor(as_u)
        })
        .map_or_else(
            || "a typo, or the two points' names swapped with others?".to_owned(),
            |u| match u {
                armcal_shared::units::LengthUnit::In => "is the distance in inches?".to_owned(),
                u => format!("is the distance in {}?", u.name()),
            },
        );
    Err(InputError::new(
        file,
        d.length_at.0,
        d.length_at.1,
        format!(
            "distance: {value} {} stated between '{}' and '{}', the nominal model puts them {:.4} \
             {} apart: {hint}",
            unit.name(),
            d.points[0].0,
            d.points[1].0,
            units.length_from_si(nominal),
            unit.name()
        ),
    ))
}

/// Loads measurements: a built-in set if `name_or_path` is the name of one (see
/// [`builtin::DATA`]), otherwise the file at that path, read against `model`.
pub fn load_measurements(
    name_or_path: &str,
    model: &RobotModel,
) -> Result<Measurements, InputError> {
    if let Some((text, label)) = builtin::builtin_data(name_or_path) {
        return parse_measurements(text, label, model);
    }
    let source = open_bounded(name_or_path, DATA_FILE).map_err(|mut e| {
        if e.line == 0 {
            e.message = format!(
                "{} (and it is not a built-in data set: {})",
                e.message,
                builtin::DATA_NAMES.join(", ")
            );
        }
        e
    })?;
    read_measurements(
        Source::new(std::io::BufReader::new(source), DATA_FILE),
        name_or_path,
        model,
    )
}

/// Loads the joint readings of the file at `path`, read against `robot` (its
/// joint count, joint types and limits) in `units`.
pub fn load_joints(path: &str, robot: &Robot<f64>, units: &Units) -> Result<JointRows, InputError> {
    let source = open_bounded(path, DATA_FILE)?;
    read_joints(
        Source::new(std::io::BufReader::new(source), DATA_FILE),
        path,
        robot,
        units,
    )
}

/// Parses the text of a joint-readings file (see [the module](self)) against
/// `robot`, whose readings are in `units` on file.
///
/// `file` names the file in error messages. Never panics, whatever the text.
pub fn parse_joints(
    text: &str,
    file: &str,
    robot: &Robot<f64>,
    units: &Units,
) -> Result<JointRows, InputError> {
    read_joints(Source::new(text.as_bytes(), DATA_FILE), file, robot, units)
}

/// Reads a joint-readings file from `source` against `robot`.
fn read_joints<R: std::io::Read>(
    source: Source<R>,
    file: &str,
    robot: &Robot<f64>,
    units: &Units,
) -> Result<JointRows, InputError> {
    let schema = Schema {
        robot,
        units: *units,
        kind: Kind::Joints,
    };
    let mut rows = Vec::new();
    let columns = read_table(source, file, &schema, |item| {
        // A joints file fed a constraint file reads its joints only.
        let Item::Row(r) = item else { return };
        rows.push(JointRow {
            line: r.line,
            q: r.q,
            t: r.t,
            temp: r.temp,
            load: r.load,
        });
    })?;
    Ok(JointRows {
        file: file.to_owned(),
        rows,
        columns_used: columns.used,
        columns_ignored: columns.ignored,
        warnings: columns.warnings,
    })
}

/// Which file is read: the columns it needs and those it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Measured poses: `q1..qM, x, y, z` required, the quaternion read.
    Measurements,
    /// Joint readings: `q1..qM` required, the pose columns not read.
    Joints,
}

impl Kind {
    /// The required columns, for messages.
    fn required(self, m: usize) -> String {
        match self {
            Self::Measurements => format!("q1..q{m}, x, y, z"),
            Self::Joints => format!("q1..q{m}"),
        }
    }

    /// The columns read, for the warning about the others.
    fn used(self, m: usize) -> String {
        match self {
            Self::Measurements => format!("q1..q{m}, x, y, z, qw, qx, qy, qz, t, temp, load"),
            Self::Joints => format!("q1..q{m}, t, temp, load"),
        }
    }

    /// What one data row is, for messages.
    fn row_noun(self) -> &'static str {
        match self {
            Self::Measurements => "measured pose",
            Self::Joints => "row of joint readings",
        }
    }
}

/// What a file is read against.
struct Schema<'m> {
    /// Joint count, joint types (the unit of each reading) and limits.
    robot: &'m Robot<f64>,
    /// The units of the file.
    units: Units,
    /// Which file.
    kind: Kind,
}

impl Schema<'_> {
    fn dof(&self) -> usize {
        self.robot.dof()
    }
}

/// One data row as read, in SI, before it becomes a [`Pose`] or a [`JointRow`]
/// (a joints file leaves `position` at 0 and `orientation` empty).
struct Record {
    line: usize,
    q: Vec<f64>,
    position: [f64; 3],
    orientation: Option<UnitQuaternion<f64>>,
    t: Option<f64>,
    temp: Option<f64>,
    load: Option<f64>,
    /// The unknown fixed point the row names (`point` column): its name and the
    /// place of its cell.
    point: Option<(String, Place)>,
    /// The unknown plane the row names (`plane` column), likewise.
    plane: Option<(String, Place)>,
    /// The place and the name of the row's first coordinate when it measures
    /// all of x, y, z (in a file with a `point` or `plane` column).
    measured: Option<(Place, &'static str)>,
}

/// The line and character column of a cell. A cell after a quoted field that
/// spans lines is on a later line than its record's first.
type Place = (usize, usize);

/// A distance line of a constraint file, as read (see [`crate::session::constraints`]).
struct DistanceLine {
    line: usize,
    /// The two point names and the place of each.
    points: [(String, Place); 2],
    /// Length and standard uncertainty, m.
    length: f64,
    std: f64,
    /// The place of the length's cell.
    length_at: Place,
}

/// What a data line of a file is.
enum Item {
    /// A row: one pose.
    Row(Record),
    /// A known distance between two named points.
    Distance(DistanceLine),
}

/// The columns of a file as read.
struct Columns {
    /// The header's line and names, in file order.
    header: (usize, Vec<String>),
    /// The header names of the columns used, in file order.
    used: Vec<String>,
    /// The header names of the columns not read, in file order.
    ignored: Vec<String>,
    /// Things the user should know that do not stop the computation.
    warnings: Vec<String>,
}

/// Reads the file `source` (`file` in messages) as a file of `schema.kind`,
/// giving each data row to `sink` as it is read.
fn read_table<R: std::io::Read>(
    source: Source<R>,
    file: &str,
    schema: &Schema<'_>,
    sink: impl FnMut(Item),
) -> Result<Columns, InputError> {
    CsvReader::new(source, file).read(schema, sink)
}

/// What a column of the file feeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    /// Joint reading, 0-based joint index.
    Joint(usize),
    /// Position component 0, 1, 2 (x, y, z).
    Position(usize),
    /// Quaternion component 0..4 (w, x, y, z).
    Quat(usize),
    T,
    Temp,
    Load,
    /// The name of the unknown fixed point the tool point sits at.
    Point,
    /// The name of the unknown plane the tool point touches.
    Plane,
    Ignored,
}

const QUAT: [&str; 4] = ["qw", "qx", "qy", "qz"];

/// The role of a header name in a file of `kind` (`q0` is no joint; the header
/// check refuses it). A joints file does not read the pose columns.
fn role_of(name: &str, kind: Kind) -> Role {
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
    Role::Ignored
}

/// `k` for a column `q<k>` (decimal, no leading zero, `q0` gives 0).
fn joint_index(name: &str) -> Option<usize> {
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

/// Parses the text of a measurement file (`docs/file-formats.md` §2) against `model`.
///
/// `file` names the file in error messages. Never panics, whatever the text.
pub fn parse_measurements(
    text: &str,
    file: &str,
    model: &RobotModel,
) -> Result<Measurements, InputError> {
    read_measurements(Source::new(text.as_bytes(), DATA_FILE), file, model)
}

/// Reads a measurement file from `source` against `model`, one row at a time.
fn read_measurements<R: std::io::Read>(
    source: Source<R>,
    file: &str,
    model: &RobotModel,
) -> Result<Measurements, InputError> {
    let schema = Schema {
        robot: &model.robot,
        units: model.units,
        kind: Kind::Measurements,
    };
    let (mut poses, mut lines, mut times) = (Vec::new(), Vec::new(), Vec::new());
    let mut approach = Approach::new();
    let mut constraints = Constraints::default();
    let mut distance_lines = Vec::new();
    // What a row says beside its joints: its line, where it measures x, y, z
    // (the column of its first coordinate), and the point and plane it names.
    // Kept for the constraint rows (x, y, z not measured, a point or plane
    // named), with their pose's index, and for the first row measuring x, y,
    // z: a file of coordinates keeps nothing per row.
    type NameCell = Option<(String, Place)>;
    type Tag = (usize, Option<(Place, &'static str)>, NameCell, NameCell);
    let mut constraint_rows: Vec<(usize, Tag)> = Vec::new();
    let mut first_measured: Option<Tag> = None;
    let mut columns = read_table(source, file, &schema, |item| {
        let r = match item {
            Item::Row(r) => r,
            Item::Distance(d) => return distance_lines.push(d),
        };
        let tag = (r.line, r.measured, r.point, r.plane);
        if tag.1.is_some() {
            first_measured.get_or_insert(tag);
        } else if tag.2.is_some() || tag.3.is_some() {
            constraint_rows.push((poses.len(), tag));
        }
        poses.push(Observation::of_row(
            r.q,
            Point3::from(r.position),
            r.orientation,
            (r.temp, r.load),
            &mut approach,
        ));
        lines.push(r.line);
        times.push(r.t);
    })?;
    // A file whose every row measures x, y, z is a file of coordinates, read
    // as without the extension: a `point` or `plane` column is then an id,
    // kept out of the computation.
    let Some((_, first_constraint)) = constraint_rows.first() else {
        if let Some(d) = distance_lines.first() {
            return Err(InputError::new(
                file,
                d.line,
                1,
                "a distance line in a file whose every row measures x, y, z: distances tie \
                 unknown points (rows naming a point, x, y, z empty)",
            ));
        }
        let (line, header) = &columns.header;
        if header.iter().any(|n| n == "point" || n == "plane") {
            let old = ignored_warning(file, *line, &columns.ignored, &schema);
            columns.used.retain(|n| n != "point" && n != "plane");
            columns.ignored = header
                .iter()
                .filter(|n| !columns.used.contains(n))
                .cloned()
                .collect();
            let new = ignored_warning(file, *line, &columns.ignored, &schema);
            match (old, new) {
                (Some(_), Some(w)) => columns.warnings[0] = w,
                (None, Some(w)) => columns.warnings.insert(0, w),
                _ => {}
            }
        }
        return Ok(Measurements {
            file: file.to_owned(),
            poses,
            lines,
            times,
            columns_used: columns.used,
            columns_ignored: columns.ignored,
            warnings: columns.warnings,
            constraints,
        });
    };
    if let Some((_, Some(((line, column), coordinate)), point, plane)) = &first_measured {
        let message = match point
            .as_ref()
            .map(|p| ("point", p))
            .or(plane.as_ref().map(|p| ("plane", p)))
        {
            Some((kind, (name, _))) => format!(
                "column '{coordinate}': a coordinate on a row that names the unknown {kind} '{name}': a row either \
                 measures x, y, z or names the point its tool point sits at or the plane it \
                 touches; leave x, y, z empty here"
            ),
            None => format!(
                "column '{coordinate}': this row measures x, y, z while line {} names an unknown point or plane: a \
                 file holds either measured coordinates or constraints (unknown points, planes, \
                 distances), not both",
                first_constraint.0
            ),
        };
        return Err(InputError::new(file, *line, *column, message));
    }
    for (index, (_, _, point, plane)) in constraint_rows {
        let pose = &mut poses[index];
        let named = |name: String, first: Place| Named {
            name,
            first,
            rows: 1,
        };
        if let Some((name, place)) = plane {
            let k = merge_named(&mut constraints.planes, &[named(name, place)])[0];
            pose.contact = Contact::Plane(k);
        } else if let Some((name, place)) = point {
            let k = merge_named(&mut constraints.points, &[named(name, place)])[0];
            pose.contact = Contact::Point(k);
        }
    }
    if let Some(once) = constraints.points.iter().find(|p| p.rows < 2) {
        return Err(InputError::new(
            file,
            once.first.0,
            once.first.1,
            format!(
                "column 'point': the point '{}' is named by this row only: an unknown fixed point \
                 needs at least two rows to say anything (a typo in its name?)",
                once.name
            ),
        ));
    }
    if let Some(few) = constraints
        .planes
        .iter()
        .find(|p| p.rows < MIN_PLANE_TOUCHES)
    {
        return Err(InputError::new(
            file,
            few.first.0,
            few.first.1,
            format!(
                "column 'plane': the plane '{}' is touched by {} only: an unknown plane needs at \
                 least {MIN_PLANE_TOUCHES} touches to say anything (its own three unknowns)",
                few.name,
                plural(few.rows, "row")
            ),
        ));
    }
    // The nominal tool point of every row held to a point, for the distances'
    // check; computed only when there is a distance.
    let nominal_points = (!distance_lines.is_empty())
        .then(|| nominal_point_means(&model.robot, &poses, constraints.points.len()));
    for d in distance_lines {
        let mut ends = [0; 2];
        for (end, (name, (line, column))) in ends.iter_mut().zip(&d.points) {
            *end = constraints.index(name).ok_or_else(|| {
                let named: Vec<&str> = constraints.points.iter().map(|p| p.name.as_str()).collect();
                InputError::new(
                    file,
                    *line,
                    *column,
                    format!(
                        "distance: no row names the point '{name}' (points named: {})",
                        if named.is_empty() {
                            "none".to_owned()
                        } else {
                            named.join(", ")
                        }
                    ),
                )
            })?;
        }
        if let Some(means) = &nominal_points {
            let reach = reach(&model.robot, poses.iter().map(|p| p.q.as_slice()));
            if let (Some(a), Some(b)) = (means[ends[0]], means[ends[1]]) {
                require_plausible_distance(file, &d, (a - b).norm(), reach, &model.units)?;
            }
        }
        constraints.distances.push(Distance {
            points: ends,
            length: d.length,
            std: d.std,
            line: d.line,
        });
    }
    let mut warnings = columns.warnings;
    let prismatic = model
        .robot
        .links
        .iter()
        .any(|l| l.joint == JointType::Prismatic);
    if !constraints.is_empty() && constraints.distances.is_empty() && !prismatic {
        warnings.push(
            "no known distance (no `distance` line): nothing in this file fixes the arm's scale \
             (a larger arm reaching larger points or planes fits these rows as well), so only the \
             prior on the lengths holds it; give the distance between two of its points (a \
             plate's socket spacing, a ball-bar's length)"
                .to_owned(),
        );
    }
    Ok(Measurements {
        file: file.to_owned(),
        poses,
        lines,
        times,
        columns_used: columns.used,
        columns_ignored: columns.ignored,
        warnings,
        constraints,
    })
}

/// The bytes of a data file as the `csv` crate reads them, prepared as the
/// module says: a leading byte-order mark dropped, every lone CR made an LF (one
/// byte for one, so offsets stay those of the file), the size bounded and the
/// text checked to be UTF-8 before the reader sees it. What the reader consumed
/// since the record being read began stays in `window`, for the places of
/// errors; the rest is let go, so a file is read in memory independent of its
/// length.
struct Source<R> {
    inner: R,
    /// The most bytes read from `inner` ([`SizeLimit::bytes`]).
    limit: u64,
    /// Bytes read from `inner` so far.
    raw: u64,
    /// The text from offset `start` on.
    window: Vec<u8>,
    start: usize,
    /// The offset of the next byte for the `csv` reader.
    given: usize,
    /// The text up to this offset is UTF-8 (and may be given).
    checked: usize,
    /// A CR ended the last read: whether it ends a line depends on the next byte.
    held_cr: bool,
    /// Whether a read has been made (the mark is looked for in the first).
    begun: bool,
    /// Whether `inner` is exhausted (or the text ends early: `stop`).
    eof: bool,
    /// Where the text ends early, and why.
    stop: Option<(usize, Stop)>,
    /// The buffer `inner` is read into.
    chunk: Vec<u8>,
}

/// Why the text of a data file ends before its end.
#[derive(Clone, Debug)]
enum Stop {
    /// The file is larger than the limit.
    TooLarge,
    /// A byte that is not UTF-8.
    NotUtf8,
    /// The file could not be read on (an I/O error).
    Unreadable(String),
}

impl<R: std::io::Read> Source<R> {
    fn new(inner: R, limit: SizeLimit) -> Self {
        Self {
            inner,
            limit: limit.bytes,
            raw: 0,
            window: Vec::new(),
            start: 0,
            given: 0,
            checked: 0,
            held_cr: false,
            begun: false,
            eof: false,
            stop: None,
            chunk: vec![0; 1 << 16],
        }
    }

    /// The offset one past the last byte in the window.
    fn end(&self) -> usize {
        self.start + self.window.len()
    }

    /// The byte at `offset`, if it is in the window.
    fn byte(&self, offset: usize) -> Option<u8> {
        offset
            .checked_sub(self.start)
            .and_then(|i| self.window.get(i).copied())
    }

    /// The text from `from` to `to` (what of it is in the window).
    fn text(&self, from: usize, to: usize) -> &[u8] {
        let (a, b) = (
            from.saturating_sub(self.start),
            to.saturating_sub(self.start),
        );
        self.window.get(a..b.min(self.window.len())).unwrap_or(&[])
    }

    /// Lets go of the text before `offset` once that is most of the window.
    fn forget_before(&mut self, offset: usize) {
        let dead = offset.min(self.given).saturating_sub(self.start);
        if dead >= 1 << 16 && dead >= self.window.len() / 2 {
            self.window.drain(..dead);
            self.start += dead;
        }
    }

    /// Reads the next chunk of `inner` into the window.
    fn fill(&mut self) {
        let n = loop {
            match self.inner.read(&mut self.chunk) {
                Ok(n) => break n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    self.end_early(self.end(), Stop::Unreadable(e.to_string()));
                    return;
                }
            }
        };
        self.raw += n as u64;
        let mut bytes = self.chunk.get(..n).unwrap_or(&[]);
        if self.raw > self.limit {
            let over = usize::try_from(self.raw - self.limit).unwrap_or(n).min(n);
            bytes = &bytes[..n - over];
        }
        if !self.begun {
            self.begun = true;
            bytes = bytes.strip_prefix("\u{feff}".as_bytes()).unwrap_or(bytes);
        }
        if std::mem::take(&mut self.held_cr) {
            self.window.push(if bytes.first() == Some(&b'\n') {
                b'\r'
            } else {
                b'\n'
            });
        }
        let mut rest = bytes;
        while let Some(i) = memchr::memchr(b'\r', rest) {
            self.window.extend_from_slice(&rest[..i]);
            match rest.get(i + 1) {
                Some(b'\n') => self.window.push(b'\r'),
                Some(_) => self.window.push(b'\n'),
                None => self.held_cr = true,
            }
            rest = &rest[i + 1..];
        }
        self.window.extend_from_slice(rest);
        if n == 0 {
            self.eof = true;
        }
        let checked = self.checked - self.start;
        if let Err(e) = std::str::from_utf8(&self.window[checked..]) {
            self.checked += e.valid_up_to();
            if e.error_len().is_some() || self.eof {
                self.window.truncate(self.checked - self.start);
                self.end_early(self.checked, Stop::NotUtf8);
            }
        } else {
            self.checked = self.end();
        }
        if self.raw > self.limit {
            self.end_early(self.end(), Stop::TooLarge);
        }
    }

    fn end_early(&mut self, offset: usize, why: Stop) {
        self.eof = true;
        self.held_cr = false;
        if self.stop.is_none() {
            self.stop = Some((offset, why));
        }
    }
}

impl<R: std::io::Read> std::io::Read for Source<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.given == self.checked && !self.eof {
            self.fill();
        }
        let ready = self
            .window
            .get(self.given - self.start..self.checked - self.start)
            .unwrap_or(&[]);
        let n = ready.len().min(buf.len());
        buf[..n].copy_from_slice(&ready[..n]);
        self.given += n;
        Ok(n)
    }
}

/// Reads the records of a data file one at a time and says where each is.
struct CsvReader<'f, R> {
    reader: csv::Reader<Source<R>>,
    file: &'f str,
    /// Line counting cursor: `line` is the 1-based line of byte `byte`.
    byte: usize,
    line: usize,
}

/// One record: its fields (untrimmed: [`Row::field`] trims), where it starts
/// and its line.
#[derive(Default)]
struct Row {
    fields: csv::StringRecord,
    start: usize,
    line: usize,
}

impl Row {
    /// The number of fields.
    fn len(&self) -> usize {
        self.fields.len()
    }

    /// The fields, trimmed.
    fn fields(&self) -> impl Iterator<Item = &str> {
        self.fields.iter().map(trim)
    }

    /// Field `i`, trimmed.
    fn field(&self, i: usize) -> Option<&str> {
        self.fields.get(i).map(trim)
    }
}

/// `field` without leading and trailing white space ([`str::trim`], which a
/// field that starts and ends in a printable ASCII character does not need).
fn trim(field: &str) -> &str {
    match (field.as_bytes().first(), field.as_bytes().last()) {
        (Some(a), Some(b)) if a.is_ascii_graphic() && b.is_ascii_graphic() => field,
        _ => field.trim(),
    }
}

impl<'f, R: std::io::Read> CsvReader<'f, R> {
    fn new(source: Source<R>, file: &'f str) -> Self {
        Self {
            reader: csv::ReaderBuilder::new()
                .has_headers(false)
                .comment(Some(b'#'))
                .flexible(true)
                .from_reader(source),
            file,
            byte: 0,
            line: 1,
        }
    }

    fn source(&self) -> &Source<R> {
        self.reader.get_ref()
    }

    /// The place of field `index` of the record at `start`.
    fn place(&self, start: usize, index: usize) -> Place {
        self.place_at(self.field_offset(start, index))
    }

    /// The refusal `message` at byte `offset` ([`Self::place_at`]).
    fn err_at(&self, offset: usize, message: impl Into<String>) -> InputError {
        let (line, column) = self.place_at(offset);
        InputError::new(self.file, line, column, message)
    }

    /// The line and character column of byte `offset`.
    fn place_at(&self, offset: usize) -> Place {
        let source = self.source();
        let mut offset = offset.clamp(self.byte, source.end());
        // Not inside a character.
        while offset > self.byte && source.byte(offset).is_some_and(|b| b & 0xC0 == 0x80) {
            offset -= 1;
        }
        let before = source.text(self.byte, offset);
        let line_start = memchr::memrchr(b'\n', before).map_or(0, |i| i + 1);
        let column = before[line_start..]
            .iter()
            .filter(|&&b| b & 0xC0 != 0x80)
            .count()
            + 1;
        let line = self.line + memchr::memchr_iter(b'\n', before).count();
        (line, column)
    }

    /// The 1-based line of byte `offset`; offsets come in increasing order, so
    /// the file is scanned once. Every line ends in `\n` by now: a lone CR
    /// became one ([`Source`]), the CR of a CR LF is the line's last character.
    fn line_of(&mut self, offset: usize) -> usize {
        let offset = offset.min(self.source().end());
        if offset > self.byte {
            self.line += memchr::memchr_iter(b'\n', self.source().text(self.byte, offset)).count();
            self.byte = offset;
        }
        self.line
    }

    /// Where a record really starts: the `csv` crate reports the place it began
    /// reading, before the comment and blank lines it skipped.
    fn record_start(&self, mut i: usize) -> usize {
        let source = self.source();
        loop {
            match source.byte(i) {
                Some(b'#') => {
                    while let Some(b) = source.byte(i) {
                        i += 1;
                        if b == b'\n' {
                            break;
                        }
                    }
                }
                Some(b'\n' | b'\r') => i += 1,
                _ => return i,
            }
        }
    }

    /// The byte offsets where the fields of the record at `start` begin (after
    /// leading blanks, as the fields are trimmed), and where the record ends.
    fn field_offsets(&self, start: usize) -> (Vec<usize>, usize) {
        let source = self.source();
        let skip_blanks = |mut i: usize| {
            while matches!(source.byte(i), Some(b' ' | b'\t')) {
                i += 1;
            }
            i
        };
        let mut starts = Vec::new();
        let mut i = start;
        loop {
            starts.push(skip_blanks(i));
            // As in csv-core, a quote opens a quoted field only as its first byte.
            let mut in_quotes = source.byte(i) == Some(b'"');
            if in_quotes {
                i += 1;
            }
            loop {
                match source.byte(i) {
                    None => return (starts, i),
                    Some(b'"') if in_quotes => {
                        if source.byte(i + 1) == Some(b'"') {
                            i += 2;
                        } else {
                            in_quotes = false;
                            i += 1;
                        }
                    }
                    Some(b',') if !in_quotes => {
                        i += 1;
                        break;
                    }
                    Some(b'\n' | b'\r') if !in_quotes => return (starts, i),
                    Some(_) => i += 1,
                }
            }
        }
    }

    /// The byte offset of field `index` of the record at `start` (the end of the
    /// record if it has fewer fields).
    fn field_offset(&self, start: usize, index: usize) -> usize {
        let (starts, end) = self.field_offsets(start);
        starts.get(index).copied().unwrap_or(end)
    }

    /// Reads the next record that is not a blank-looking line into `row`;
    /// `false` at the end of the file.
    fn next_row(&mut self, row: &mut Row) -> Result<bool, InputError> {
        loop {
            let read = self.reader.read_record(&mut row.fields);
            // The text may end early where the reader stopped: the record
            // read is cut there unless its line ended just before the stop
            // (then the record is whole, and the stop is the next line's).
            let at = self.reader.position().byte() as usize;
            let line_ended =
                matches!(read, Ok(true)) && self.source().byte(at.wrapping_sub(1)) == Some(b'\n');
            if let Some((offset, why)) = self.source().stop.clone()
                && (offset < at || (offset == at && !line_ended))
            {
                return Err(match why {
                    Stop::TooLarge => SizeLimit {
                        bytes: self.source().limit,
                        what: DATA_FILE.what,
                    }
                    .refusal(self.file),
                    Stop::NotUtf8 => {
                        self.err_at(offset, "the file is not UTF-8 text (invalid byte here)")
                    }
                    Stop::Unreadable(reason) => InputError::unreadable(self.file, reason),
                });
            }
            match read {
                Ok(false) => return Ok(false),
                Ok(true) => {
                    let begun = row.fields.position().map_or(0, |p| p.byte() as usize);
                    row.start = self.record_start(begun);
                    row.line = self.line_of(row.start);
                    self.reader.get_mut().forget_before(row.start);
                    if row.len() == 1 && row.field(0).is_some_and(str::is_empty) {
                        continue; // a line of blanks only
                    }
                    return Ok(true);
                }
                Err(e) => {
                    let offset = e.position().map_or(0, |p| p.byte() as usize);
                    return Err(self.err_at(offset, format!("CSV: {e}")));
                }
            }
        }
    }

    /// Reads the header and every data row, giving each row to `sink`.
    fn read(
        mut self,
        schema: &Schema<'_>,
        mut sink: impl FnMut(Item),
    ) -> Result<Columns, InputError> {
        let mut header = Row::default();
        if !self.next_row(&mut header)? {
            return Err(InputError::new(
                self.file,
                1,
                1,
                format!(
                    "no header line: the file is empty or has only comments (expected {}, ...)",
                    schema.kind.required(schema.dof())
                ),
            ));
        }
        let columns = self.header(&header, schema)?;

        let mut tally = LimitTally::new(schema);
        let mut row = Row::default();
        let mut rows = 0;
        // Only a file with a `point` column has distance lines (an old file's
        // rows read as before).
        let constraint_file = header.fields().any(|n| n == "point" || n == "plane");
        while self.next_row(&mut row)? {
            if constraint_file && row.field(0) == Some("distance") {
                sink(Item::Distance(self.distance_line(&row, schema)?));
                continue;
            }
            let record = self.record(&row, &header, &columns, schema)?;
            tally.add(&record);
            sink(Item::Row(record));
            rows += 1;
        }
        if rows == 0 {
            return Err(InputError::new(
                self.file,
                header.line,
                1,
                format!(
                    "no data rows after the header: at least one {} is needed",
                    schema.kind.row_noun()
                ),
            ));
        }

        let mut used = Vec::new();
        let mut ignored = Vec::new();
        for (name, role) in header.fields().zip(&columns) {
            if *role == Role::Ignored {
                ignored.push(name.to_owned());
            } else {
                used.push(name.to_owned());
            }
        }
        let mut warnings = Vec::new();
        warnings.extend(ignored_warning(self.file, header.line, &ignored, schema));
        warnings.extend(tally.warnings(self.file, schema));

        Ok(Columns {
            header: (header.line, header.fields().map(str::to_owned).collect()),
            used,
            ignored,
            warnings,
        })
    }

    /// Checks the header against the schema; the role of each column.
    fn header(&self, header: &Row, schema: &Schema<'_>) -> Result<Vec<Role>, InputError> {
        let m = schema.dof();
        let at = |index: usize, message: String| {
            self.err_at(self.field_offset(header.start, index), message)
        };
        let names: Vec<&str> = header.fields().collect();

        for (i, name) in names.iter().enumerate() {
            if name.is_empty() {
                continue;
            }
            if let Some(first) = names.iter().take(i).position(|n| n == name) {
                return Err(at(
                    i,
                    format!(
                        "column '{name}': duplicate column name (field {} of the header is '{name}' too)",
                        first + 1
                    ),
                ));
            }
        }

        let roles: Vec<Role> = names.iter().map(|n| role_of(n, schema.kind)).collect();
        let joint_numbers: Vec<(usize, usize)> = names
            .iter()
            .enumerate()
            .filter_map(|(i, n)| joint_index(n).map(|k| (i, k)))
            .collect();
        let data_joints = joint_numbers.iter().map(|(_, k)| *k).max().unwrap_or(0);
        for &(i, k) in &joint_numbers {
            if k == 0 {
                return Err(at(
                    i,
                    "column 'q0': joints are numbered from 1 (q1..qM)".to_owned(),
                ));
            }
            if k > m {
                return Err(at(
                    i,
                    format!(
                        "column '{}': joint-count mismatch: the model has {m} joints, the data has {data_joints} (q1..q{m} expected)",
                        names.get(i).unwrap_or(&"")
                    ),
                ));
            }
        }
        let header_err = |message: String| InputError::new(self.file, header.line, 1, message);
        for j in 0..m {
            if !roles.contains(&Role::Joint(j)) {
                return Err(header_err(format!(
                    "missing column 'q{}': joint-count mismatch: the model has {m} joints, the data has {}{}",
                    j + 1,
                    joint_numbers.len(),
                    case_hint(&names, &format!("q{}", j + 1))
                )));
            }
        }
        // A constraint file (a `point` column) may leave out x, y, z altogether.
        let constraint_file = roles.contains(&Role::Point) || roles.contains(&Role::Plane);
        let any_position = (0..3).any(|c| roles.contains(&Role::Position(c)));
        for (c, name) in POSITION.iter().enumerate() {
            if schema.kind == Kind::Measurements
                && (!constraint_file || any_position)
                && !roles.contains(&Role::Position(c))
            {
                return Err(header_err(format!(
                    "missing required column '{name}' (required: {}){}",
                    schema.kind.required(m),
                    case_hint(&names, name)
                )));
            }
        }
        let present: Vec<usize> = (0..4).filter(|c| roles.contains(&Role::Quat(*c))).collect();
        if !present.is_empty() && present.len() < 4 {
            let first = roles
                .iter()
                .position(|r| matches!(r, Role::Quat(_)))
                .unwrap_or(0);
            let have: Vec<&str> = present
                .iter()
                .filter_map(|c| QUAT.get(*c).copied())
                .collect();
            let missing: Vec<&str> = (0..4)
                .filter(|c| !present.contains(c))
                .filter_map(|c| QUAT.get(c).copied())
                .collect();
            return Err(at(
                first,
                format!(
                    "column '{}': partial quaternion: {} given, {} missing; give all four of qw, qx, qy, qz or none",
                    names.get(first).unwrap_or(&""),
                    have.join(", "),
                    missing.join(", ")
                ),
            ));
        }
        Ok(roles)
    }

    /// One data row.
    fn record(
        &self,
        row: &Row,
        header: &Row,
        roles: &[Role],
        schema: &Schema<'_>,
    ) -> Result<Record, InputError> {
        let at = |index: usize, message: String| {
            self.err_at(self.field_offset(row.start, index), message)
        };
        if row.len() != roles.len() {
            let hint = if row.field(0).is_some_and(|f| f.starts_with('#')) {
                " (a comment line must start with '#' in its first column)"
            } else {
                ""
            };
            return Err(at(
                roles.len().min(row.len()),
                format!(
                    "row has {}, the header has {}{hint}",
                    plural(row.len(), "field"),
                    roles.len()
                ),
            ));
        }

        let units = schema.units;
        let mut q = vec![0.0; schema.dof()];
        let mut position = [0.0; 3];
        // Position cells as read (a constraint row leaves them empty).
        let mut given: [Option<usize>; 3] = [None; 3];
        let mut point: Option<(String, Place)> = None;
        let mut plane: Option<(String, Place)> = None;
        let point_index = roles.iter().position(|r| *r == Role::Point);
        let plane_index = roles.iter().position(|r| *r == Role::Plane);
        let constraint_file = point_index.is_some() || plane_index.is_some();
        let named_cell =
            |ix: Option<usize>| ix.and_then(|i| row.field(i)).filter(|f| !f.is_empty());
        // What the row names, if anything: ("point" or "plane", the name).
        let named: Option<(&str, &str)> = named_cell(point_index)
            .map(|n| ("point", n))
            .or_else(|| named_cell(plane_index).map(|n| ("plane", n)));
        let mut quat: [Option<f64>; 4] = [None; 4];
        let (mut t, mut temp, mut load) = (None, None, None);
        for (i, (value, role)) in row.fields().zip(roles).enumerate() {
            if *role == Role::Ignored {
                continue;
            }
            let name = header.field(i).unwrap_or("");
            let number = || -> Result<f64, InputError> {
                match value.parse::<f64>() {
                    Ok(x) if x.is_finite() => Ok(x),
                    _ if value.is_empty() => Err(at(
                        i,
                        format!("column '{name}': empty, expected a finite number"),
                    )),
                    _ => Err(at(
                        i,
                        format!("column '{name}': {value:?} is not a finite number"),
                    )),
                }
            };
            // A value outside `range` refused with `why(value, range)`.
            let within = |v: Option<f64>,
                          [lo, hi]: [f64; 2],
                          why: &dyn Fn(f64, [f64; 2]) -> String|
             -> Result<Option<f64>, InputError> {
                match v {
                    Some(x) if !(lo..=hi).contains(&x) => Err(at(i, why(x, [lo, hi]))),
                    _ => Ok(v),
                }
            };
            let optional = || -> Result<Option<f64>, InputError> {
                if value.is_empty() {
                    Ok(None)
                } else {
                    number().map(Some)
                }
            };
            match *role {
                Role::Joint(j) => {
                    let joint = schema
                        .robot
                        .links
                        .get(j)
                        .map_or(JointType::Revolute, |l| l.joint);
                    if let Some(slot) = q.get_mut(j) {
                        *slot = units.joint_to_si(joint, number()?);
                    }
                }
                Role::Position(c) => {
                    if constraint_file && value.is_empty() {
                        continue;
                    }
                    if let Some(slot) = position.get_mut(c) {
                        *slot = units.length_to_si(number()?);
                    }
                    if let Some(slot) = given.get_mut(c) {
                        *slot = Some(i);
                    }
                }
                Role::Point | Role::Plane => {
                    if !value.is_empty() {
                        let kind = if *role == Role::Point {
                            "point"
                        } else {
                            "plane"
                        };
                        if RESERVED.contains(&value) || value.parse::<f64>().is_ok() {
                            return Err(at(
                                i,
                                format!(
                                    "column '{kind}': {value:?} cannot name a {kind} (a number, or a word \
                                     that starts a line of its own: {})",
                                    RESERVED.join(", ")
                                ),
                            ));
                        }
                        let slot = if *role == Role::Point {
                            &mut point
                        } else {
                            &mut plane
                        };
                        *slot = Some((value.to_owned(), self.place(row.start, i)));
                    }
                }
                Role::Quat(c) => {
                    if let Some(slot) = quat.get_mut(c) {
                        *slot = optional()?;
                    }
                }
                Role::T => t = optional()?,
                Role::Temp => {
                    temp = within(optional()?, TEMPERATURE_RANGE, &|c, [lo, hi]| {
                        format!(
                            "column '{name}': {c} °C is not the temperature of a working robot \
                             (accepted: {lo} to {hi} °C; a value in K or °F?)"
                        )
                    })?;
                }
                Role::Load => {
                    load = within(optional()?, PAYLOAD_RANGE, &|m, [lo, hi]| {
                        format!(
                            "column '{name}': a payload of {m} kg is impossible \
                             (accepted: {lo} to {hi} kg; a value in g or lb?)"
                        )
                    })?;
                }
                Role::Ignored => {}
            }
        }

        let orientation = match quat {
            [None, None, None, None] => None,
            [Some(w), Some(x), Some(y), Some(z)] => {
                let quaternion = Quaternion::new(w, x, y, z);
                let norm = quaternion.norm();
                if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                    let first = roles.iter().position(|r| *r == Role::Quat(0)).unwrap_or(0);
                    return Err(at(
                        first,
                        format!(
                            "column 'qw': quaternion (qw, qx, qy, qz) = ({w}, {x}, {y}, {z}) has norm {norm:.6}, \
                             not 1 within {QUATERNION_NORM_TOLERANCE}"
                        ),
                    ));
                }
                Some(UnitQuaternion::from_quaternion(quaternion))
            }
            partial => {
                let empty = partial.iter().position(Option::is_none).unwrap_or(0);
                let index = roles
                    .iter()
                    .position(|r| *r == Role::Quat(empty))
                    .unwrap_or(0);
                let name = QUAT.get(empty).copied().unwrap_or("q");
                return Err(at(
                    index,
                    format!(
                        "column '{name}': partial quaternion: empty while other quaternion cells of the row are given; give all four of qw, qx, qy, qz or none"
                    ),
                ));
            }
        };

        if let (Some(p), Some((plane_name, _))) = (&point, &plane) {
            return Err(at(
                plane_index.unwrap_or(0),
                format!(
                    "column 'plane': the row names the point '{}' and the plane '{plane_name}': its \
                     tool point sits at a point or touches a plane; name one",
                    p.0
                ),
            ));
        }
        let measured = given.iter().filter(|g| g.is_some()).count();
        if let Some(first) = point_index.into_iter().chain(plane_index).min() {
            let column = if Some(first) == point_index {
                "point"
            } else {
                "plane"
            };
            if let (Some((kind, n)), 1..=2) = (named, measured) {
                let (i, _) = given
                    .iter()
                    .enumerate()
                    .find_map(|(c, g)| g.map(|i| (i, c)))
                    .unwrap_or((first, 0));
                return Err(at(
                    i,
                    format!(
                        "column '{}': a coordinate on a row that names the unknown {kind} '{n}': a row \
                         either measures x, y, z or names the point its tool point sits at or the \
                         plane it touches; leave x, y, z empty here",
                        header.field(i).unwrap_or("")
                    ),
                ));
            }
            if named.is_none() && measured < 3 {
                // At the first empty coordinate, as a file without the column is refused.
                let empty = (0..3).find_map(|c| {
                    let i = roles.iter().position(|r| *r == Role::Position(c))?;
                    given[c].is_none().then_some((i, POSITION[c]))
                });
                return Err(match empty {
                    Some((i, name)) => at(
                        i,
                        format!(
                            "column '{name}': empty, expected a finite number (or, for a session \
                             without a tracker, name the unknown point in '{column}')"
                        ),
                    ),
                    None => at(
                        first,
                        format!(
                            "column '{column}': empty, and the row does not measure x, y, z either: \
                             name the unknown point its tool point sits at or the plane it touches"
                        ),
                    ),
                });
            }
            if let Some((kind, _)) = named
                && orientation.is_some()
            {
                let first = roles.iter().position(|r| *r == Role::Quat(0)).unwrap_or(0);
                return Err(at(
                    first,
                    format!(
                        "column 'qw': an orientation on a row that names an unknown {kind}: only \
                         positions are constrained; leave qw, qx, qy, qz empty"
                    ),
                ));
            }
        }

        Ok(Record {
            line: row.line,
            q,
            position,
            orientation,
            t,
            temp,
            load,
            point,
            plane,
            // Asked for only in a file that can name points or planes: in
            // another, no row is a constraint row that a coordinate could clash with.
            measured: (measured == 3
                && roles.iter().any(|r| matches!(r, Role::Point | Role::Plane)))
            .then(|| {
                let (i, c) = given
                    .iter()
                    .enumerate()
                    .filter_map(|(c, g)| g.map(|i| (i, c)))
                    .min()?;
                Some((self.place(row.start, i), POSITION[c]))
            })
            .flatten(),
        })
    }

    /// A distance line of a constraint file: `distance,<point>,<point>,<length>[,<std>]`.
    fn distance_line(&self, row: &Row, schema: &Schema<'_>) -> Result<DistanceLine, InputError> {
        let at = |index: usize, message: String| {
            self.err_at(self.field_offset(row.start, index), message)
        };
        const FORM: &str = "distance,<point>,<point>,<length>[,<std>]";
        if !(4..=5).contains(&row.len()) {
            return Err(at(
                row.len().min(5),
                format!(
                    "a distance line has 4 or 5 fields ({FORM}), this one has {}",
                    row.len()
                ),
            ));
        }
        let name = |i: usize| -> Result<(String, Place), InputError> {
            let value = row.field(i).unwrap_or("");
            if value.is_empty() {
                return Err(at(
                    i,
                    format!(
                        "distance: field {} is empty, expected a point name ({FORM})",
                        i + 1
                    ),
                ));
            }
            Ok((value.to_owned(), self.place(row.start, i)))
        };
        let points = [name(1)?, name(2)?];
        if points[0].0 == points[1].0 {
            return Err(at(
                2,
                format!("distance: from the point '{}' to itself", points[0].0),
            ));
        }
        let unit = schema.units.length.name();
        let positive = |i: usize, what: &str| -> Result<f64, InputError> {
            let value = row.field(i).unwrap_or("");
            match value.parse::<f64>() {
                Ok(x) if x.is_finite() && x > 0.0 => Ok(schema.units.length_to_si(x)),
                _ => Err(at(
                    i,
                    format!(
                        "distance: {what} {value:?} is not a positive number of {unit} ({FORM})"
                    ),
                )),
            }
        };
        let length = positive(3, "the length")?;
        let std = if row.len() == 5 {
            positive(4, "the standard uncertainty")?
        } else {
            DEFAULT_DISTANCE_STD
        };
        Ok(DistanceLine {
            line: row.line,
            points,
            length,
            std,
            length_at: self.place(row.start, 3),
        })
    }
}

/// The warning naming the columns `ignored` kept out of the computation, if any.
fn ignored_warning(
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
fn case_hint(names: &[&str], wanted: &str) -> String {
    names
        .iter()
        .find(|n| n.eq_ignore_ascii_case(wanted))
        .map(|n| format!(" (found '{n}': column names are case-sensitive)"))
        .unwrap_or_default()
}

/// The readings outside each joint's limits, tallied row by row, for one
/// warning per joint: the first (its line and value) and how many.
struct LimitTally {
    joints: Vec<JointTally>,
}

/// One joint's [`LimitTally`]: its limits, the first reading outside them
/// (line, value) and the count.
type JointTally = (Option<[f64; 2]>, Option<(usize, f64)>, usize);

impl LimitTally {
    fn new(schema: &Schema<'_>) -> Self {
        Self {
            joints: schema
                .robot
                .links
                .iter()
                .map(|l| (l.limits, None, 0))
                .collect(),
        }
    }

    fn add(&mut self, record: &Record) {
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
    fn warnings(&self, file: &str, schema: &Schema<'_>) -> Vec<String> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::builtin::DATA;
    use crate::io::model_file::{load_model, parse_model};
    use proptest::prelude::*;

    fn ur5e() -> RobotModel {
        load_model("ur5e").unwrap()
    }

    const HEADER6: &str = "q1,q2,q3,q4,q5,q6,x,y,z";
    const ROW6: &str = "0.1,0.2,0.3,0.4,0.5,0.6,1.0,2.0,3.0";

    /// Asserts that `text` is refused at exactly `line`:`column` of "data.csv"
    /// against `model`, with a message containing every one of `needles`.
    #[track_caller]
    fn refused(model: &RobotModel, text: &str, line: usize, column: usize, needles: &[&str]) {
        let e = match parse_measurements(text, "data.csv", model) {
            Ok(_) => panic!("accepted:\n{text}"),
            Err(e) => e,
        };
        assert_refused_at(&e, "data.csv", line, column, needles);
    }

    /// Asserts that `e` names `file` at exactly `line`:`column`, prints as
    /// `file:line:column: …`, and has a message containing every one of `needles`.
    #[track_caller]
    fn assert_refused_at(e: &InputError, file: &str, line: usize, column: usize, needles: &[&str]) {
        assert_eq!(e.file, file);
        assert_eq!((e.line, e.column), (line, column), "{e}");
        assert!(
            e.to_string()
                .starts_with(&format!("{file}:{line}:{column}: ")),
            "{e}"
        );
        for needle in needles {
            assert!(e.message.contains(needle), "{e:?} does not name {needle:?}");
        }
    }

    /// Old Mac line ends (a lone CR) are line ends: a bad value on line 4 is
    /// refused at line 4, not at line 1 with a long column.
    #[test]
    fn lone_carriage_returns_end_lines() {
        let text = format!("# comment\r{HEADER6}\r{ROW6}\r0.1,0.2,0.3,0.4,0.5,0.6,1.0,abc,3.0\r");
        refused(&ur5e(), &text, 4, 29, &["column 'y'", "\"abc\""]);
        let m = parse_measurements(&text.replace("abc", "2.0"), "data.csv", &ur5e()).unwrap();
        assert_eq!(m.lines, [3, 4]);
    }

    /// A temperature no working robot has (absolute zero, a value in K) and a
    /// negative or absurd payload are refused at their cell.
    #[test]
    fn implausible_conditions_are_refused() {
        let h = format!("{HEADER6},temp,load");
        for (cells, column, needle) in [
            ("-273.15,1", 37, "°C is not the temperature"),
            ("1e300,1", 37, "°C is not the temperature"),
            ("293.15,1", 37, "in K or °F"),
            ("20,-0.5", 40, "payload of -0.5 kg is impossible"),
            ("20,1e9", 40, "kg is impossible"),
        ] {
            refused(
                &ur5e(),
                &format!("{h}\n{ROW6},{cells}\n"),
                2,
                column,
                &[needle],
            );
        }
        parse_measurements(
            &format!("{h}\n{ROW6},-20,0\n{ROW6},80,3.5\n"),
            "data.csv",
            &ur5e(),
        )
        .unwrap();
    }

    /// Garbage is refused with its line: one coordinate of 1e30 (or 1e300), a
    /// data file in mm against a model in m, a constant z column. A real set
    /// passes.
    #[test]
    fn implausible_positions_are_refused() {
        let model = load_model("puma560").unwrap();
        let robot = &model.robot;
        // An upper bound of the distance from the base, and not a loose one.
        let r = reach(robot, std::iter::empty());
        assert!(r < 2.0, "PUMA reach {r} m");
        let mut text = String::from("q1,q2,q3,q4,q5,q6,x,y,z\n");
        for i in 0..20 {
            let q = 0.1 * i as f64;
            let p = robot
                .forward(&[q, -q, q, 0.5, q, 0.0])
                .unwrap()
                .translation
                .vector;
            assert!(p.norm() <= r);
            text.push_str(&format!(
                "{q},{},{q},0.5,{q},0,{},{},{}\n",
                -q, p.x, p.y, p.z
            ));
        }
        let good = parse_measurements(&text, "data.csv", &model).unwrap();
        good.require_plausible(&model).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let with_line = |n: usize, f: &dyn Fn(&str) -> String| {
            let mut l = lines.clone();
            let changed = f(l[n - 1]);
            l[n - 1] = &changed;
            parse_measurements(&(l.join("\n") + "\n"), "data.csv", &model).unwrap()
        };
        for big in ["1e30", "1e300"] {
            let m = with_line(7, &|l| {
                let mut f: Vec<&str> = l.split(',').collect();
                f[6] = big;
                f.join(",")
            });
            let e = m.require_plausible(&model).unwrap_err();
            assert_eq!((e.line, e.column), (7, 1), "{e}");
            assert!(e.message.contains("reaches at most"), "{e}");
        }
        let mm: String = lines
            .iter()
            .enumerate()
            .map(|(i, l)| {
                if i == 0 {
                    return format!("{l}\n");
                }
                let f: Vec<String> = l
                    .split(',')
                    .enumerate()
                    .map(|(c, v)| {
                        if c >= 6 {
                            format!("{}", v.parse::<f64>().unwrap() * 1000.0)
                        } else {
                            v.to_owned()
                        }
                    })
                    .collect();
                f.join(",") + "\n"
            })
            .collect();
        let m = parse_measurements(&mm, "data.csv", &model).unwrap();
        assert!(
            m.require_plausible(&model)
                .unwrap_err()
                .message
                .contains("length units")
        );
        let flat: String = lines
            .iter()
            .enumerate()
            .map(|(i, l)| {
                if i == 0 {
                    return format!("{l}\n");
                }
                let mut f: Vec<&str> = l.split(',').collect();
                f[8] = "0.25";
                f.join(",") + "\n"
            })
            .collect();
        let e = parse_measurements(&flat, "data.csv", &model)
            .unwrap()
            .require_plausible(&model)
            .unwrap_err();
        assert_eq!(e.line, 2);
        assert!(
            e.message.contains("column 'z' reads 0.25 in on every row"),
            "{e}"
        );
        for d in DATA {
            let model = load_model(d.name).unwrap();
            let m = load_measurements(d.name, &model).unwrap();
            m.require_plausible(&model)
                .unwrap_or_else(|e| panic!("{e}"));
        }
    }

    /// Every built-in data set parses against its built-in model, with the pose
    /// counts that its README gives and the lines of its file.
    #[test]
    fn every_builtin_data_set_parses_against_its_model() {
        for d in DATA {
            let model = load_model(d.name).unwrap();
            let m = load_measurements(d.name, &model).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(m.file, d.file);
            let expected = match d.name {
                "figaroh-ur10e-camera" => 23,
                "figaroh-tiago-mocap" => 34,
                "figaroh-talos-left-arm" => 61,
                other => panic!("no expected count for {other}"),
            };
            assert_eq!(m.len(), expected, "{}", d.name);
            assert!(m.columns_ignored.is_empty(), "{:?}", m.columns_ignored);
            assert!(m.poses.iter().all(|p| p.q.len() == model.dof()));
            assert_eq!(m.has_orientation(), d.name == "figaroh-ur10e-camera");
            // Lines are those of the file: after the comment lines and the header.
            let first_data_line = d.text.lines().position(|l| !l.starts_with('#')).unwrap() + 2;
            assert_eq!(m.lines[0], first_data_line);
            assert_eq!(*m.lines.last().unwrap(), first_data_line + expected - 1);
        }
    }

    /// The UR10e set: orientation unit quaternions, columns in use; TALOS has `t`;
    /// TIAGo row 3 reads the torso lift 0.18 mm above its 0.35 m limit (line 8).
    #[test]
    // The literals are the digits of the file, which round to the same f64.
    #[allow(clippy::excessive_precision)]
    fn builtin_sets_details() {
        let ur = load_model("figaroh-ur10e-camera").unwrap();
        let m = load_measurements("figaroh-ur10e-camera", &ur).unwrap();
        assert_eq!(
            m.columns_used,
            [
                "q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "qw", "qx", "qy", "qz"
            ]
        );
        assert_eq!(m.equations(), 23 * 6);
        let p = &m.poses[0];
        assert_eq!(p.q[0], 1.589200496673584);
        assert_eq!(
            p.position,
            Point3::new(0.90882845233650233, 0.34156959335807885, 1.2526995668918641)
        );
        let q = p.orientation.unwrap();
        assert!((q.w - 0.16704657887989197).abs() < 1e-9);

        let talos = load_model("figaroh-talos-left-arm").unwrap();
        let m = load_measurements("figaroh-talos-left-arm", &talos).unwrap();
        assert!(m.times.iter().all(Option::is_some));
        assert_eq!(m.times[0], Some(42.399117469787598));

        let tiago = load_model("figaroh-tiago-mocap").unwrap();
        let m = load_measurements("figaroh-tiago-mocap", &tiago).unwrap();
        assert!(
            m.warnings.iter().any(|w| w.starts_with("data/figaroh-tiago-mocap/measurements.csv:8: q1 = 0.35018")),
            "{:?}",
            m.warnings
        );
    }

    /// Readings and positions in mm and degrees become the same SI poses as their
    /// twin in m and rad; a prismatic joint's reading uses the length unit.
    #[test]
    fn units_of_the_model_apply_to_the_data() {
        let model = |length: &str, angle: &str| {
            parse_model(
                &format!(
                    "name = \"rp\"\nconvention = \"dh\"\nlength_unit = \"{length}\"\nangle_unit = \"{angle}\"\n\
                     [[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 0\na = 0\nalpha = 0\n\
                     [[joint]]\ntype = \"prismatic\"\ntheta = 0\ns = 0\na = 0\nalpha = 0\n"
                ),
                "rp.toml",
            )
            .unwrap()
        };
        let si = parse_measurements(
            "q1,q2,x,y,z\n1.5707963267948966,0.25,1.5,-0.002,0.0125\n",
            "si.csv",
            &model("m", "rad"),
        )
        .unwrap();
        let mm = parse_measurements(
            "q2,z,x,y,q1\n250,12.5,1500,-2,90\n",
            "mm.csv",
            &model("mm", "deg"),
        )
        .unwrap();
        let (a, b) = (&si.poses[0], &mm.poses[0]);
        assert!((a.q[0] - b.q[0]).abs() <= 4.0 * f64::EPSILON);
        assert_eq!(a.q[1], b.q[1]);
        assert_eq!(b.q[1], 0.25);
        assert_eq!(a.position, b.position);
        assert_eq!(mm.columns_used, ["q2", "z", "x", "y", "q1"]);
    }

    /// A `\r` that no `\n` follows ends a record (the `csv` crate's rule) and
    /// a line: old Mac files read with each row on its own line, and a refusal
    /// names that line. (Found by the `measurements_csv` fuzz target: rows
    /// split at a lone `\r` shared one line number.)
    #[test]
    fn lone_carriage_returns_end_records_and_lines() {
        let model = ur5e();
        let text = format!("{HEADER6}\r{ROW6}\r{ROW6}\n{ROW6}\r\n");
        let m = parse_measurements(&text, "data.csv", &model).unwrap();
        let lines = m.lines.clone();
        assert_eq!(lines, [2, 3, 4]);
        let rows = parse_joints(&text, "data.csv", &model.robot, &model.units).unwrap();
        let lines: Vec<usize> = rows.rows.iter().map(|r| r.line).collect();
        assert_eq!(lines, [2, 3, 4]);
        refused(
            &model,
            &format!("{HEADER6}\r{ROW6}\r0,0,0,0,0,0,1,abc,3\r"),
            3,
            15,
            &["'y'", "abc"],
        );
    }

    /// Comments, blank lines, CRLF, quoted fields, optional columns, ignored
    /// columns (named in a warning), and a near-unit quaternion that is normalised.
    #[test]
    fn reads_the_optional_and_the_ignored() {
        let text = "# a comment\r\n\r\nid,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz,t,temp,load,comment\r\n\
                    # between\r\n\
                    7,0,0,0,0,0,0,1,2,3,1.0005,0,0,0,0.5,21.5,2.0,\"a, b\"\r\n\
                    \r\n\
                    8,0,0,0,0,0,0,1,2,3,,,,,,,,\r\n";
        let m = parse_measurements(text, "data.csv", &ur5e()).unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!(m.lines, [5, 7]);
        assert_eq!(m.columns_ignored, ["id", "comment"]);
        assert!(
            m.warnings[0].contains("'id', 'comment'"),
            "{:?}",
            m.warnings
        );
        let p = &m.poses[0];
        assert!((p.orientation.unwrap().into_inner().norm() - 1.0).abs() < 1e-15);
        let conditions = |i: usize| {
            let c = &m.poses[i].context;
            (m.times[i], c.temperature, c.payload)
        };
        assert_eq!(conditions(0), (Some(0.5), Some(21.5), Some(2.0)));
        assert_eq!(conditions(1), (None, None, None));
        assert!(m.poses[1].orientation.is_none());
        assert_eq!(m.equations(), 9);
        assert!(!m.has_orientation());
    }

    #[test]
    fn refuses_missing_required_columns_on_the_header_line() {
        let model = ur5e();
        refused(
            &model,
            "# c\nq1,q2,q3,q4,q5,q6,x,z\n0,0,0,0,0,0,1,3\n",
            2,
            1,
            &["missing required column 'y'"],
        );
        refused(
            &model,
            "q1,q2,q3,q4,q5,q6,X,y,z\n",
            1,
            1,
            &["'x'", "found 'X'"],
        );
    }

    #[test]
    fn refuses_joint_count_mismatch() {
        let model = ur5e();
        refused(
            &model,
            &format!("{HEADER6},q7\n{ROW6},0.7\n"),
            1,
            25,
            &["column 'q7'", "the model has 6 joints, the data has 7"],
        );
        refused(
            &model,
            "q1,q2,q3,q4,q5,x,y,z\n0,0,0,0,0,1,2,3\n",
            1,
            1,
            &[
                "missing column 'q6'",
                "the model has 6 joints, the data has 5",
            ],
        );
        refused(&model, &format!("q0,{HEADER6}\n"), 1, 1, &["column 'q0'"]);
    }

    #[test]
    fn refuses_duplicate_column_names_at_the_second() {
        refused(
            &ur5e(),
            &format!("{HEADER6}, x\n{ROW6},1\n"),
            1,
            26,
            &["column 'x'", "duplicate"],
        );
    }

    #[test]
    fn refuses_rows_with_the_wrong_number_of_fields() {
        let model = ur5e();
        // One too many: the column of the extra field.
        refused(
            &model,
            &format!("{HEADER6}\n{ROW6},9\n"),
            2,
            37,
            &["10 fields, the header has 9"],
        );
        // One too few: the end of the line.
        refused(
            &model,
            &format!("{HEADER6}\n{ROW6}\n0,0,0,0,0,0,1,2\n"),
            3,
            16,
            &["8 fields, the header has 9"],
        );
        // An indented comment is a row.
        refused(
            &model,
            &format!("{HEADER6}\n  # note\n"),
            2,
            9,
            &["1 field,", "first column"],
        );
    }

    #[test]
    fn refuses_values_that_are_not_finite_numbers() {
        let model = ur5e();
        for bad in ["abc", "nan", "inf", "-inf", "1e999", "0x10", "1_0"] {
            let row = format!("0.1,0.2,0.3,0.4,0.5,0.6,1.0,2.0,{bad}");
            let needle = format!("column 'z': \"{bad}\" is not a finite number");
            refused(
                &model,
                &format!("{HEADER6}\n{ROW6}\n{row}\n"),
                3,
                33,
                &[&needle],
            );
        }
        // A decimal comma splits the field: the extra field is refused.
        let row = "0.1,0.2,0.3,0.4,0.5,0.6,1.0,2.0,1,5";
        refused(
            &model,
            &format!("{HEADER6}\n{row}\n"),
            2,
            35,
            &["10 fields, the header has 9"],
        );
        // Empty cell of a required column; column counts characters (é is one),
        // and commas inside quotes do not split fields.
        refused(
            &model,
            &format!("note,{HEADER6}\n\"é, ü\",0.1,0.2,0.3,0.4,0.5,0.6,,2,3\n"),
            2,
            32,
            &["column 'x': empty"],
        );
        refused(
            &model,
            &format!("{HEADER6}\n0.1, 0.2,0.3,0.4,0.5,0.6, abc ,2,3\n"),
            2,
            27,
            &["column 'x'", "\"abc\""],
        );
        // A value in a joint column.
        refused(
            &model,
            &format!("{HEADER6}\n0.1,0.2,three,0.4,0.5,0.6,1,2,3\n"),
            2,
            9,
            &["column 'q3'"],
        );
        // Optional columns too, when not empty.
        refused(
            &model,
            &format!("{HEADER6},temp\n{ROW6},warm\n"),
            2,
            37,
            &["column 'temp'", "\"warm\""],
        );
    }

    #[test]
    fn refuses_partial_quaternions() {
        let model = ur5e();
        refused(
            &model,
            &format!("{HEADER6},qx,qw,qz\n"),
            1,
            25,
            &[
                "column 'qx'",
                "partial quaternion",
                "qw, qx, qz given, qy missing",
            ],
        );
        refused(
            &model,
            &format!("{HEADER6},qw,qx,qy,qz\n{ROW6},1,0,,0\n"),
            2,
            41,
            &["column 'qy'", "partial quaternion"],
        );
    }

    #[test]
    fn refuses_quaternions_far_from_unit_norm() {
        refused(
            &ur5e(),
            &format!("{HEADER6},qx,qy,qz,qw\n{ROW6},0,0,0,0.998\n"),
            2,
            43,
            &["column 'qw'", "norm 0.998000", "not 1 within 0.001"],
        );
        // Within the tolerance: accepted.
        parse_measurements(
            &format!("{HEADER6},qx,qy,qz,qw\n{ROW6},0,0,0,0.9991\n"),
            "ok.csv",
            &ur5e(),
        )
        .unwrap();
    }

    #[test]
    fn refuses_files_without_data() {
        let model = ur5e();
        refused(
            &model,
            &format!("# only a header\n\n{HEADER6}\n# and a comment\n"),
            3,
            1,
            &["no data rows"],
        );
        refused(&model, "", 1, 1, &["no header line"]);
        refused(&model, "# comments\n# only\n", 1, 1, &["no header line"]);
    }

    #[test]
    fn require_poses_refuses_fewer_equations_than_unknowns() {
        let row = |k: f64| format!("0.1,0.2,0.3,0.4,0.5,{k},1.0,2.0,3.0");
        let text = format!(
            "{HEADER6}\n{}\n{}\n# end\n{}\n",
            row(0.6),
            row(0.7),
            row(0.8)
        );
        let robot = ur5e().robot;
        let m = parse_measurements(&text, "data.csv", &ur5e()).unwrap();
        assert!(m.require_poses(&robot, 9).is_ok());
        let e = m.require_poses(&robot, 27).unwrap_err();
        assert_eq!(
            (e.file.as_str(), e.line, e.column),
            ("data.csv", 5, 1),
            "{e}"
        );
        for needle in [
            "3 poses give 9 equations",
            "27 unknowns",
            "at least 9 poses are needed",
        ] {
            assert!(e.message.contains(needle), "{e}");
        }
        // With orientation, 6 equations per pose.
        let text = format!("{HEADER6},qw,qx,qy,qz\n{ROW6},1,0,0,0\n");
        let m = parse_measurements(&text, "data.csv", &ur5e()).unwrap();
        let e = m.require_poses(&robot, 30).unwrap_err();
        assert!(
            e.message.contains("1 pose gives 6 equations (6 per pose)"),
            "{e}"
        );
        assert!(e.message.contains("at least 5 poses"), "{e}");
        // One configuration read three times: 3 equations, not 9.
        let text = format!("{HEADER6}\n{ROW6}\n{ROW6}\n# end\n{ROW6}\n");
        let m = parse_measurements(&text, "data.csv", &ur5e()).unwrap();
        assert!(m.require_poses(&robot, 3).is_ok());
        let e = m.require_poses(&robot, 9).unwrap_err();
        assert_eq!(e.line, 5, "{e}");
        assert!(
            e.message.contains("3 rows in 1 distinct configuration")
                && e.message.contains("give 3 equations"),
            "{e}"
        );
    }

    #[test]
    fn load_measurements_refuses_a_missing_file_naming_it() {
        let e = load_measurements("/nonexistent/data.csv", &ur5e()).unwrap_err();
        assert_eq!((e.file.as_str(), e.line), ("/nonexistent/data.csv", 0));
        assert!(e.message.contains("figaroh-ur10e-camera"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.csv");
        std::fs::write(&path, format!("{HEADER6}\n{ROW6}\n")).unwrap();
        let p = path.to_str().unwrap();
        assert_eq!(load_measurements(p, &ur5e()).unwrap().file, p);
    }

    /// Asserts that `text` is refused as joint readings at exactly
    /// `line`:`column` of "joints.csv" against `model`, naming every `needles`.
    #[track_caller]
    fn joints_refused(
        model: &RobotModel,
        text: &str,
        line: usize,
        column: usize,
        needles: &[&str],
    ) {
        let e = match parse_joints(text, "joints.csv", &model.robot, &model.units) {
            Ok(_) => panic!("accepted:\n{text}"),
            Err(e) => e,
        };
        assert_refused_at(&e, "joints.csv", line, column, needles);
    }

    /// Every built-in measurement file reads as joint readings too: the same
    /// readings, times, temperatures and loads on the same lines, the pose columns
    /// listed as ignored and named in a warning.
    #[test]
    fn measurement_files_read_as_joints() {
        for d in DATA {
            let model = load_model(d.name).unwrap();
            let m = load_measurements(d.name, &model).unwrap();
            let j = parse_joints(d.text, d.file, &model.robot, &model.units)
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(j.file, d.file);
            assert_eq!(j.len(), m.len());
            for (i, (r, p)) in j.rows.iter().zip(&m.poses).enumerate() {
                assert_eq!((r.line, &r.q), (m.lines[i], &p.q));
                let c = &p.context;
                assert_eq!(
                    (r.t, r.temp, r.load),
                    (m.times[i], c.temperature, c.payload)
                );
            }
            let pose_columns: Vec<&String> = m
                .columns_used
                .iter()
                .filter(|c| POSITION.contains(&c.as_str()) || QUAT.contains(&c.as_str()))
                .collect();
            assert!(pose_columns.len() >= 3);
            assert_eq!(j.columns_ignored.iter().collect::<Vec<_>>(), pose_columns);
            assert!(
                j.warnings
                    .iter()
                    .any(|w| w.contains("kept out of the computation: 'x', 'y', 'z'")
                        && w.contains(&format!("(used: q1..q{}, t, temp, load)", model.dof()))),
                "{:?}",
                j.warnings
            );
            // The limit warnings are the measurement reader's.
            let limits = |w: &[String]| -> Vec<String> {
                w.iter().filter(|w| w.contains("limits")).cloned().collect()
            };
            assert_eq!(limits(&j.warnings), limits(&m.warnings));
        }
    }

    /// Only the joints are required; readings follow the units (deg, and mm for a
    /// prismatic joint); `t`, `temp`, `load` are kept; pose columns are not read,
    /// not even checked (a partial quaternion or a text in `x` is fine); other
    /// columns are ignored and named.
    #[test]
    fn joints_need_only_the_joints() {
        let model = parse_model(
            "name = \"rp\"\nconvention = \"dh\"\nlength_unit = \"mm\"\nangle_unit = \"deg\"\n\
             [[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 0\na = 0\nalpha = 0\n\
             [[joint]]\ntype = \"prismatic\"\ntheta = 0\ns = 0\na = 0\nalpha = 0\n",
            "rp.toml",
        )
        .unwrap();
        let j = parse_joints(
            "\u{feff}# c\nid,q2,q1,load,x,qw,t,temp\n1,250,90,2.5,abc,,0.5,\n\n2,0,-45,,1,1,,21\n",
            "j.csv",
            &model.robot,
            &model.units,
        )
        .unwrap();
        assert_eq!(j.columns_used, ["q2", "q1", "load", "t", "temp"]);
        assert_eq!(j.columns_ignored, ["id", "x", "qw"]);
        assert_eq!(j.len(), 2);
        let (a, b) = (&j.rows[0], &j.rows[1]);
        assert_eq!((a.line, b.line), (3, 5));
        assert!((a.q[0] - core::f64::consts::FRAC_PI_2).abs() <= 4.0 * f64::EPSILON);
        assert_eq!(a.q[1], 0.25);
        assert_eq!((a.t, a.temp, a.load), (Some(0.5), None, Some(2.5)));
        assert_eq!((b.t, b.temp, b.load), (None, Some(21.0), None));
        assert!(
            j.warnings[0].contains("'id', 'x', 'qw'"),
            "{:?}",
            j.warnings
        );
    }

    /// The measurement reader's refusals, from the same code, with the place.
    #[test]
    fn joints_refusals_name_file_line_column() {
        let model = ur5e();
        const JOINTS6: &str = "q1,q2,q3,q4,q5,q6";
        joints_refused(
            &model,
            &format!("{JOINTS6}\n0.1,0.2,three,0.4,0.5,0.6\n"),
            2,
            9,
            &["column 'q3'", "\"three\" is not a finite number"],
        );
        joints_refused(
            &model,
            &format!("{JOINTS6},temp\n0,0,0,0,0,0,1\n0,0,0,0,0,0,inf\n"),
            3,
            13,
            &["column 'temp'", "\"inf\" is not a finite number"],
        );
        joints_refused(
            &model,
            &format!("{JOINTS6},q7\n0,0,0,0,0,0,0\n"),
            1,
            19,
            &["column 'q7'", "the model has 6 joints, the data has 7"],
        );
        joints_refused(
            &model,
            "q1,q2,q3,q4,q5,x,y,z\n0,0,0,0,0,1,2,3\n",
            1,
            1,
            &["missing column 'q6'", "joint-count mismatch"],
        );
        joints_refused(
            &model,
            &format!("{JOINTS6}\n0,0,0,0,0\n"),
            2,
            10,
            &["5 fields, the header has 6"],
        );
        joints_refused(
            &model,
            &format!("{JOINTS6},x,x\n"),
            1,
            21,
            &["column 'x'", "duplicate"],
        );
        joints_refused(
            &model,
            &format!("{JOINTS6}\n# nothing\n"),
            1,
            1,
            &["no data rows", "row of joint readings"],
        );
        joints_refused(&model, "", 1, 1, &["no header line", "expected q1..q6,"]);
    }

    #[test]
    fn load_joints_reads_a_file_and_refuses_a_missing_one() {
        let model = ur5e();
        let e = load_joints("/nonexistent/j.csv", &model.robot, &model.units).unwrap_err();
        assert_eq!((e.file.as_str(), e.line), ("/nonexistent/j.csv", 0));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j.csv");
        std::fs::write(&path, "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n").unwrap();
        let p = path.to_str().unwrap();
        let j = load_joints(p, &model.robot, &model.units).unwrap();
        assert_eq!((j.file.as_str(), j.len()), (p, 1));
    }

    /// Characters that matter to CSV and to this format, to mutate files with.
    const CSV_ALPHABET: &str = ",,,\"\"#\n\r .-+e0123456789qwxyzntaif\u{e9}\u{1f600}";

    /// A reader that gives at most `piece` bytes a read.
    struct Trickle<'a> {
        bytes: &'a [u8],
        piece: usize,
    }

    impl std::io::Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.piece.min(buf.len()).min(self.bytes.len());
            buf[..n].copy_from_slice(&self.bytes[..n]);
            self.bytes = &self.bytes[n..];
            Ok(n)
        }
    }

    /// A quoted cell may span lines: the cells after it are on a later line
    /// than their record's first, and a refusal at one of them names that
    /// line and the column within it (fuzzing found the column counted from
    /// the record's start, beyond the end of its first line). Each named
    /// cell: a point named once, a plane touched twice, a distance to a point
    /// no row names, a coordinate on a constraint row.
    #[test]
    fn a_named_cell_after_a_quoted_line_break_is_placed_on_its_own_line() {
        let model = ur5e();
        let header = "q1,q2,q3,q4,q5,q6,note,x,y,z,point,plane\n";
        let row = |note: &str, point: &str, plane: &str| {
            format!("0.1,0.2,0.3,0.4,0.5,0.6,{note},,,,{point},{plane}\n")
        };
        let split = "\"two\nlines\"";
        // The point cell of line 4's record is on line 5, after `lines",,,,`.
        let at = "lines\",,,,".chars().count() + 1;
        let mut text = format!("{header}{}{}", row("a", "s.0", ""), row("b", "s.0", ""));
        text.push_str(&row(split, "s.1", ""));
        refused(&model, &text, 5, at, &["'s.1' is named by this row only"]);

        let mut text = format!("{header}{}{}", row("a", "s.0", ""), row("b", "s.0", ""));
        text.push_str(&row(split, "", "table"));
        text.push_str(&row("c", "", "table"));
        refused(
            &model,
            &text,
            5,
            at + 1,
            &["plane 'table' is touched by 2 rows"],
        );

        // A point named across a line break (rows on lines 2–3 and 4–5), and a
        // distance from it (lines 6–7) to a point no row names, on line 7.
        let named = "\"s\n.0\"";
        let mut text = format!("{header}{}{}", row("a", named, ""), row("b", named, ""));
        text.push_str(&format!("distance,{named},s.1,0.05\n"));
        refused(
            &model,
            &text,
            7,
            ".0\",".chars().count() + 1,
            &["no row names the point 's.1'"],
        );

        let mut text = format!("{header}{}{}", row("a", "s.0", ""), row("b", "s.0", ""));
        text.push_str("0.1,0.2,0.3,0.4,0.5,0.6,\"x\ny\",1,2,3,,\n");
        refused(
            &model,
            &text,
            5,
            "y\",".chars().count() + 1,
            &["column 'x': this row measures x, y, z"],
        );
    }

    /// A file far longer than the reader keeps (it lets go of what lies
    /// before the record being read): a refusal on its last line is placed
    /// as in the whole text, and every pose keeps its line.
    #[test]
    fn a_long_file_keeps_its_places() {
        let model = ur5e();
        let rows = 40_000;
        let mut text = format!("# a long session\r\n{HEADER6}\r\n");
        for i in 0..rows {
            text.push_str(&format!("{ROW6}\r\n"));
            if i % 1000 == 0 {
                text.push_str("# a comment\r");
            }
        }
        let m = parse_measurements(&text, "data.csv", &model).unwrap();
        assert_eq!(m.len(), rows);
        let expected = crate::io::input_error::line_col(&text, text.len()).0 - 1;
        assert_eq!(*m.lines.last().unwrap(), expected);
        text.push_str("0.1,0.2,0.3,0.4,0.5,0.6,1.0,€x,3.0\r\n");
        let (line, column) = crate::io::input_error::line_col(&text, text.rfind('€').unwrap());
        refused(&model, &text, line, column, &["column 'y'"]);
        assert!(text.len() > 16 << 16, "sixteen times what the reader keeps");
    }

    proptest! {
        /// Random bytes never make the measurement parser panic.
        #[test]
        fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
            let text = String::from_utf8_lossy(&bytes);
            let _ = parse_measurements(&text, "fuzz.csv", &ur5e());
        }

        /// Random bytes never make the joint-readings parser panic.
        #[test]
        fn random_bytes_never_panic_as_joints(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
            let text = String::from_utf8_lossy(&bytes);
            let model = ur5e();
            let _ = parse_joints(&text, "fuzz.csv", &model.robot, &model.units);
        }

        /// Read in pieces of 1 to 7 bytes (as a pipe delivers a file: a CR and
        /// its LF, the bytes of one character, a line split between reads),
        /// a file gives what it gives read whole: the same poses, or the same
        /// refusal at the same place. Edited built-in data sets with CRs,
        /// multi-byte characters and bytes that are not UTF-8 among the edits.
        #[test]
        fn a_file_read_in_pieces_reads_as_a_whole(
            which in 0..DATA.len(),
            edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<usize>()), 0..12),
            invalid in prop::option::of(any::<prop::sample::Index>()),
            piece in 1usize..8,
        ) {
            let d = &DATA[which];
            let model = load_model(d.name).unwrap();
            let text = crate::test_support::mutate(d.text, &edits, CSV_ALPHABET);
            let mut bytes = text.into_bytes();
            if let Some(at) = invalid {
                let at = at.index(bytes.len() + 1);
                bytes.insert(at, 0xff);
            }
            let whole = read_measurements(Source::new(&bytes[..], DATA_FILE), "data.csv", &model);
            let pieces = read_measurements(
                Source::new(Trickle { bytes: &bytes, piece }, DATA_FILE),
                "data.csv",
                &model,
            );
            prop_assert_eq!(whole, pieces);
        }

        /// Random edits of the built-in data sets never make the parser panic, and a
        /// refusal always has a place in the text.
        #[test]
        fn mutated_data_never_panic(
            which in 0..DATA.len(),
            edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<usize>()), 1..12),
        ) {
            let d = &DATA[which];
            let model = load_model(d.name).unwrap();
            let text = crate::test_support::mutate(d.text, &edits, CSV_ALPHABET);
            match parse_measurements(&text, "fuzz.csv", &model) {
                Err(e) => {
                    let lines = crate::io::input_error::line_col(&text, text.len()).0;
                    prop_assert!(e.line >= 1 && e.line <= lines, "{e}");
                    prop_assert!(e.column >= 1, "{e}");
                }
                Ok(m) => {
                    let _ = m.require_poses(&model.robot, usize::MAX);
                }
            }
        }
    }
}
