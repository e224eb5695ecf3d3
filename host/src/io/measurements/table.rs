//! A data file's header read against the [`Schema`] ([`Table`]): the role of
//! each column, refused with the place of the offending name; then what every
//! data line is read against, a row ([`Table::record`], in `record`) or a
//! distance line of a constraint file ([`Table::distance_line`], m). Built
//! on the reader's thread, it parses on the parser's ([`Table::parse`]).

use std::sync::mpsc::{Receiver, SyncSender};

use super::row::{Batch, Row, trim};
use super::schema::{
    Item, Kind, LimitTally, Place, QUAT, Role, Schema, case_hint, joint_index, role_of,
    torque_index,
};
use crate::session::constraints::{DEFAULT_DISTANCE_STD, DistanceLine};
use crate::session::input_error::InputError;
use crate::session::measurements::POSITION;

/// What the data lines of a file are read against: its name (for
/// refusals), its header and the role of each column, and the schema.
pub(super) struct Table<'a> {
    pub(super) file: &'a str,
    pub(super) header: Row,
    pub(super) roles: Vec<Role>,
    pub(super) schema: &'a Schema<'a>,
    /// Whether the file can name unknown points or planes: only such a file
    /// has distance lines (an old file's rows read as before).
    constraint_file: bool,
}

impl<'a> Table<'a> {
    /// The table of `file` with `header` checked against `schema`.
    pub(super) fn new(
        file: &'a str,
        header: Row,
        schema: &'a Schema<'a>,
    ) -> Result<Self, InputError> {
        let roles = roles(file, &header, schema)?;
        let constraint_file = header.fields().any(|n| n == "point" || n == "plane");
        Ok(Self {
            file,
            header,
            roles,
            schema,
            constraint_file,
        })
    }

    /// Converts the joint readings of `row` on the reader's thread, to share
    /// the work: the parser's, converting the rest and checking and
    /// assembling the row, is the larger ([`Row::numbers`]).
    pub(super) fn convert(&self, row: &mut Row) {
        let numbers = self.roles.iter().zip(&row.fields).map(|(role, cell)| {
            matches!(role, Role::Joint(_))
                .then(|| trim(cell).parse::<f64>().ok())
                .flatten()
        });
        row.numbers.clear();
        row.numbers.extend(numbers);
    }

    /// Reads each batch's records in order, giving each data line to `sink`
    /// and the batch back to the reader: the number of rows and their
    /// joints' tally, or the first line refused.
    pub(super) fn parse(
        &self,
        batches: Receiver<Batch>,
        to_reader: SyncSender<Batch>,
        mut sink: impl FnMut(Item),
    ) -> Result<(usize, LimitTally), InputError> {
        let mut tally = LimitTally::new(self.schema);
        let mut rows = 0;
        for batch in batches {
            for row in batch.rows() {
                if self.constraint_file && row.field(0) == Some("distance") {
                    sink(Item::Distance(self.distance_line(row)?));
                    continue;
                }
                let max = self.schema.kind.max_rows();
                if rows == max {
                    return Err(row.err(
                        self.file,
                        0,
                        format!(
                            "more than {max} data rows: the most a {} holds \
                             (docs/file-formats.md §2); split it",
                            match self.schema.kind {
                                Kind::Measurements => "measurement file",
                                Kind::Joints => "joints file",
                            }
                        ),
                    ));
                }
                let record = self.record(row)?;
                tally.add(&record);
                sink(Item::Row(record));
                rows += 1;
            }
            // The reader makes a new batch when none comes back.
            let _ = to_reader.try_send(batch);
        }
        Ok((rows, tally))
    }

    /// A distance line of a constraint file: `distance,<point>,<point>,<length>[,<std>]`.
    pub(super) fn distance_line(&self, row: &Row) -> Result<DistanceLine, InputError> {
        let schema = self.schema;
        let at = |index: usize, message: String| row.err(self.file, index, message);
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
            Ok((value.to_owned(), row.place(i)))
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
            length_at: row.place(3),
        })
    }
}

/// Checks the header of `file` against the schema; the role of each column.
fn roles(file: &str, header: &Row, schema: &Schema<'_>) -> Result<Vec<Role>, InputError> {
    let m = schema.dof();
    let at = |index: usize, message: String| header.err(file, index, message);
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
    let header_err = |message: String| InputError::new(file, header.line, 1, message);
    if let [only] = names.as_slice()
        && let Some((delimiter, called)) = [(';', "semicolons"), ('\t', "tabs")]
            .into_iter()
            .find(|(c, _)| only.contains(*c))
    {
        return Err(header_err(format!(
            "the header is one field with {called} in it ({:?}): armcal reads comma-separated values; save the file with commas",
            only.split(delimiter)
                .take(3)
                .collect::<Vec<_>>()
                .join(&delimiter.to_string())
        )));
    }
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
    if schema.kind == Kind::Measurements {
        for (i, name) in names.iter().enumerate() {
            if let Some(k) = torque_index(name).filter(|&k| k == 0 || k > m) {
                return Err(at(
                    i,
                    format!(
                        "column '{name}': {} (tau1..tau{m}: one torque per joint of the model)",
                        if k == 0 {
                            "joints are numbered from 1".to_owned()
                        } else {
                            format!("the model has {m} joints")
                        }
                    ),
                ));
            }
        }
        let missing: Vec<String> = (0..m)
            .filter(|j| !roles.contains(&Role::Torque(*j)))
            .map(|j| format!("tau{}", j + 1))
            .collect();
        if !missing.is_empty() && missing.len() < m {
            return Err(header_err(format!(
                "missing column '{}': a measured torque for every joint (tau1..tau{m}) or none",
                missing[0]
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
