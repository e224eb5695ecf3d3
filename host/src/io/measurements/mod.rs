//! Measured poses: the CSV of `docs/file-formats.md` §2, read against a robot model.
//!
//! One row per measured pose, kept in file order. The order of the moves
//! carries information: the direction from which each joint approached a pose is
//! the sign of its last change, held through the poses where it holds. It is
//! taken in row order, or in the order of the times when every row has one and
//! the rows are not in it (a warning then says so).
//! Lines that start with `#` are comments; the first other line is the header;
//! blank lines are skipped; fields are trimmed. Lines end at `\n`, `\r\n` or a
//! lone `\r`.
//!
//! | column | required | unit on file | read into |
//! | --- | --- | --- | --- |
//! | `q1` … `qM` | yes | model angle unit (revolute) or length unit (prismatic) | [`Observation::q`](crate::session::observation::Observation::q), rad or m |
//! | `x`, `y`, `z` | yes | model length unit, measurement frame | [`Observation::position`](crate::session::observation::Observation::position), m |
//! | `qw`, `qx`, `qy`, `qz` | no, all four or none | unit quaternion, scalar first | [`Observation::orientation`](crate::session::observation::Observation::orientation), normalised |
//! | `t` | no | s | [`Measurements::times`] |
//! | `temp` | no | °C | [`Observation::context`](crate::session::observation::Observation::context) |
//! | `load` | no | kg | [`Observation::context`](crate::session::observation::Observation::context) |
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
//! differs from 1 by more than [`QUATERNION_NORM_TOLERANCE`](crate::session::observation::QUATERNION_NORM_TOLERANCE), a `temp` outside
//! [`TEMPERATURE_RANGE`](crate::session::observation::TEMPERATURE_RANGE) or a `load` outside [`PAYLOAD_RANGE`](crate::session::observation::PAYLOAD_RANGE), no data rows, and —
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
//! the record's text for commas outside double quotes. A file is read as a
//! stream, one record at a time, into [`Observation`](crate::session::observation::Observation)s (one copy of each pose,
//! which the identification then reads in place): memory grows with the poses,
//! not with the text. Two threads share the reading: one splits the records
//! and converts the joint readings, the other reads the rest of each row and
//! assembles the poses, in file order; the refusal given is the first in the
//! file, whichever thread meets it.
//!
//! ## Where it is read
//!
//! | module | what |
//! | --- | --- |
//! | this one | the entry points: [`load_measurements`], [`parse_measurements`], [`load_joints`], [`parse_joints`] |
//! | `source` | the bytes on their way to the `csv` crate: mark, line ends, size, UTF-8 |
//! | `csv_reader` | one record at a time, its text and line; the reader's and the parser's threads |
//! | `table` | the header checked, the role of each column; a distance line |
//! | `record` | one data row read cell by cell into SI, then checked whole |
//! | `schema` | the kinds of file, the roles of the columns, what a line is as read, the columns' and limits' warnings |
//! | `assemble` | the rows of a measurement file made a session: constraints named, distances checked |
//!
//! The session's types and its `require_*` checks are [`crate::session`]'s;
//! they are re-exported here.

mod assemble;
mod csv_reader;
mod record;
mod row;
mod schema;
pub use schema::{MAX_JOINT_ROWS, MAX_MEASURED_ROWS};
mod source;
mod table;

use armcal_shared::Robot;
use armcal_shared::units::Units;

use self::assemble::Session;
use self::csv_reader::read_table;
use self::schema::{Item, Kind, Schema};
use self::source::Source;
use crate::io::builtin;
use crate::io::input_error::{DATA_FILE, open_bounded};
use crate::session::input_error::InputError;
use crate::session::model::RobotModel;

use crate::session::joints::{JointRow, JointRows};
use crate::session::measurements::*;

/// Loads measurements: a built-in set if `name_or_path` is the name of one (see
/// [`builtin::DATA`]), otherwise the file at that path, read against `model`.
pub fn load_measurements(
    name_or_path: &str,
    model: &RobotModel,
) -> Result<Measurements, InputError> {
    if let Some((text, label)) = builtin::builtin_data(name_or_path) {
        return parse_measurements(text, label, model);
    }
    let source = open_bounded(name_or_path, DATA_FILE)
        .map_err(builtin::nor_builtin("data set", &builtin::DATA_NAMES))?;
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
    let mut session = Session::new();
    let columns = read_table(source, file, &schema, |item| session.take(item))?;
    session.finish(file, model, &schema, columns)
}

#[cfg(test)]
mod tests;
