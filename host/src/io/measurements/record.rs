//! One data row of a measured-poses or joint-readings file read into a
//! [`Record`] (SI: rad or m per joint, m, a unit quaternion, s, °C, kg): each
//! cell by its column's [`Role`], then the row whole — its quaternion, and,
//! in a file that can name unknown points or planes, whether it measures
//! x, y, z or names one. Refusals name the file, line and column of the cell.

use armcal_shared::JointType;
use nalgebra::{Quaternion, UnitQuaternion};

use super::row::Row;
use super::schema::{Place, QUAT, Record, Role};
use super::table::Table;
use crate::session::constraints::RESERVED;
use crate::session::input_error::InputError;
use crate::session::measurements::{POSITION, plural};
use crate::session::observation::{
    MAX_TORQUE, PAYLOAD_RANGE, QUATERNION_NORM_TOLERANCE, TEMPERATURE_RANGE,
};

impl Table<'_> {
    /// One data row.
    pub(super) fn record(&self, row: &Row) -> Result<Record, InputError> {
        let roles = &self.roles;
        if row.len() != roles.len() {
            let hint = if row.field(0).is_some_and(|f| f.starts_with('#')) {
                " (a comment line must start with '#' in its first column)"
            } else {
                ""
            };
            return Err(row.err(
                self.file,
                roles.len().min(row.len()),
                format!(
                    "row has {}, the header has {}{hint}",
                    plural(row.len(), "field"),
                    roles.len()
                ),
            ));
        }
        let mut reading = RowReading::new(self, row);
        for (i, role) in roles.iter().enumerate() {
            if *role != Role::Ignored {
                reading.cell(i, *role)?;
            }
        }
        let orientation = reading.orientation()?;
        reading.require_one_kind(orientation.is_some())?;
        Ok(reading.into_record(orientation))
    }
}

/// A data row being read: where it comes from (the file's table, the row)
/// and the values its cells gave so far, in SI.
struct RowReading<'a> {
    table: &'a Table<'a>,
    row: &'a Row,
    /// The column of the `point` and of the `plane` name, if the file has one.
    point_index: Option<usize>,
    plane_index: Option<usize>,
    q: Vec<f64>,
    position: [f64; 3],
    /// Position cells as read (a constraint row leaves them empty).
    given: [Option<usize>; 3],
    point: Option<(String, Place)>,
    plane: Option<(String, Place)>,
    quat: [Option<f64>; 4],
    t: Option<f64>,
    temp: Option<f64>,
    load: Option<f64>,
    /// The torque cells, in a file with `tau` columns.
    torque: Option<Vec<f64>>,
}

impl<'a> RowReading<'a> {
    fn new(table: &'a Table<'a>, row: &'a Row) -> Self {
        let (roles, schema) = (&table.roles, table.schema);
        Self {
            table,
            row,
            point_index: roles.iter().position(|r| *r == Role::Point),
            plane_index: roles.iter().position(|r| *r == Role::Plane),
            q: vec![0.0; schema.dof()],
            position: [0.0; 3],
            given: [None; 3],
            point: None,
            plane: None,
            quat: [None; 4],
            t: None,
            temp: None,
            load: None,
            torque: roles
                .iter()
                .any(|r| matches!(r, Role::Torque(_)))
                .then(|| vec![0.0; schema.dof()]),
        }
    }

    /// The refusal `message` at field `index` of the row.
    fn at(&self, index: usize, message: String) -> InputError {
        self.row.err(self.table.file, index, message)
    }

    /// Whether the file names unknown points or planes (its rows may leave
    /// x, y, z empty).
    fn constraint_file(&self) -> bool {
        self.point_index.is_some() || self.plane_index.is_some()
    }

    /// What the row names, if anything: ("point" or "plane", the name).
    fn named(&self) -> Option<(&'static str, &'a str)> {
        let row = self.row;
        let named_cell =
            |ix: Option<usize>| ix.and_then(|i| row.field(i)).filter(|f| !f.is_empty());
        named_cell(self.point_index)
            .map(|n| ("point", n))
            .or_else(|| named_cell(self.plane_index).map(|n| ("plane", n)))
    }

    /// Cell `i` as a finite number (as the reader converted it); `name` is
    /// its column's.
    fn number(&self, i: usize, name: &str, value: &str) -> Result<f64, InputError> {
        let number = match self.row.numbers.get(i) {
            Some(&Some(x)) => Some(x),
            _ => value.parse::<f64>().ok(),
        };
        match number {
            Some(x) if x.is_finite() => Ok(x),
            _ if value.is_empty() => Err(self.at(
                i,
                format!("column '{name}': empty, expected a finite number"),
            )),
            _ => Err(self.at(
                i,
                format!("column '{name}': {value:?} is not a finite number"),
            )),
        }
    }

    /// Cell `i` as a finite number, `None` if empty.
    fn optional(&self, i: usize, name: &str, value: &str) -> Result<Option<f64>, InputError> {
        if value.is_empty() {
            Ok(None)
        } else {
            self.number(i, name, value).map(Some)
        }
    }

    /// `v`, refused at cell `i` with `why(value, range)` outside `range`.
    fn within(
        &self,
        i: usize,
        v: Option<f64>,
        [lo, hi]: [f64; 2],
        why: impl Fn(f64, [f64; 2]) -> String,
    ) -> Result<Option<f64>, InputError> {
        match v {
            Some(x) if !(lo..=hi).contains(&x) => Err(self.at(i, why(x, [lo, hi]))),
            _ => Ok(v),
        }
    }

    /// Reads cell `i`, of a column of `role`, into the row's values.
    fn cell(&mut self, i: usize, role: Role) -> Result<(), InputError> {
        let (name, value) = (
            self.table.header.field(i).unwrap_or(""),
            self.row.field(i).unwrap_or(""),
        );
        let units = self.table.schema.units;
        match role {
            Role::Joint(j) => {
                let joint = self
                    .table
                    .schema
                    .robot
                    .links
                    .get(j)
                    .map_or(JointType::Revolute, |l| l.joint);
                if j < self.q.len() {
                    self.q[j] = units.joint_to_si(joint, self.number(i, name, value)?);
                }
            }
            Role::Position(c) => {
                if self.constraint_file() && value.is_empty() {
                    return Ok(());
                }
                if c < self.position.len() {
                    self.position[c] = units.length_to_si(self.number(i, name, value)?);
                }
                if let Some(slot) = self.given.get_mut(c) {
                    *slot = Some(i);
                }
            }
            Role::Point | Role::Plane => self.name_cell(i, role, value)?,
            Role::Quat(c) => {
                if c < self.quat.len() {
                    self.quat[c] = self.optional(i, name, value)?;
                }
            }
            Role::T => self.t = self.optional(i, name, value)?,
            Role::Temp => {
                let v = self.optional(i, name, value)?;
                self.temp = self.within(i, v, TEMPERATURE_RANGE, |c, [lo, hi]| {
                    format!(
                        "column '{name}': {c} °C is not the temperature of a working robot \
                         (accepted: {lo} to {hi} °C; a value in K or °F?)"
                    )
                })?;
            }
            Role::Load => {
                let v = self.optional(i, name, value)?;
                self.load = self.within(i, v, PAYLOAD_RANGE, |m, [lo, hi]| {
                    format!(
                        "column '{name}': a payload of {m} kg is impossible \
                         (accepted: {lo} to {hi} kg; a value in g or lb?)"
                    )
                })?;
            }
            Role::Torque(j) => {
                let v = self.number(i, name, value)?;
                if v.abs() > MAX_TORQUE {
                    return Err(self.at(
                        i,
                        format!(
                            "column '{name}': {v} N·m is more than any arm's joint carries \
                             (accepted: up to {MAX_TORQUE} in magnitude; a value in N·mm?)"
                        ),
                    ));
                }
                if let Some(slot) = self.torque.as_mut().and_then(|t| t.get_mut(j)) {
                    *slot = v;
                }
            }
            Role::Ignored => {}
        }
        Ok(())
    }

    /// Cell `i` of the `point` or `plane` column (`role`): the name of the
    /// unknown point or plane the row is held to, if not empty.
    fn name_cell(&mut self, i: usize, role: Role, value: &str) -> Result<(), InputError> {
        if value.is_empty() {
            return Ok(());
        }
        let kind = if role == Role::Point {
            "point"
        } else {
            "plane"
        };
        if RESERVED.contains(&value) || value.parse::<f64>().is_ok() {
            return Err(self.at(
                i,
                format!(
                    "column '{kind}': {value:?} cannot name a {kind} (a number, or a word \
                     that starts a line of its own: {})",
                    RESERVED.join(", ")
                ),
            ));
        }
        let named = Some((value.to_owned(), self.row.place(i)));
        if role == Role::Point {
            self.point = named;
        } else {
            self.plane = named;
        }
        Ok(())
    }

    /// The row's orientation: none if its four quaternion cells are empty,
    /// else all four, of norm 1 within [`QUATERNION_NORM_TOLERANCE`].
    fn orientation(&self) -> Result<Option<UnitQuaternion<f64>>, InputError> {
        let roles = &self.table.roles;
        match self.quat {
            [None, None, None, None] => Ok(None),
            [Some(w), Some(x), Some(y), Some(z)] => {
                let quaternion = Quaternion::new(w, x, y, z);
                let norm = quaternion.norm();
                if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                    let first = roles.iter().position(|r| *r == Role::Quat(0)).unwrap_or(0);
                    return Err(self.at(
                        first,
                        format!(
                            "column 'qw': quaternion (qw, qx, qy, qz) = ({w}, {x}, {y}, {z}) has norm {norm:.6}, \
                             not 1 within {QUATERNION_NORM_TOLERANCE}"
                        ),
                    ));
                }
                Ok(Some(UnitQuaternion::from_quaternion(quaternion)))
            }
            partial => {
                let empty = partial.iter().position(Option::is_none).unwrap_or(0);
                let index = roles
                    .iter()
                    .position(|r| *r == Role::Quat(empty))
                    .unwrap_or(0);
                let name = QUAT.get(empty).copied().unwrap_or("q");
                Err(self.at(
                    index,
                    format!(
                        "column '{name}': partial quaternion: empty while other quaternion cells of the row are given; give all four of qw, qx, qy, qz or none"
                    ),
                ))
            }
        }
    }

    /// In a file with a `point` or `plane` column: the row names one point
    /// or plane, or measures all of x, y, z and names none; a row that names
    /// one has no orientation (`oriented`).
    fn require_one_kind(&self, oriented: bool) -> Result<(), InputError> {
        let (point_index, plane_index) = (self.point_index, self.plane_index);
        if let (Some(p), Some((plane_name, _))) = (&self.point, &self.plane) {
            return Err(self.at(
                plane_index.unwrap_or(0),
                format!(
                    "column 'plane': the row names the point '{}' and the plane '{plane_name}': its \
                     tool point sits at a point or touches a plane; name one",
                    p.0
                ),
            ));
        }
        let Some(first) = point_index.into_iter().chain(plane_index).min() else {
            return Ok(());
        };
        let column = if Some(first) == point_index {
            "point"
        } else {
            "plane"
        };
        let (given, named) = (&self.given, self.named());
        let measured = given.iter().filter(|g| g.is_some()).count();
        if let (Some((kind, n)), 1..=2) = (named, measured) {
            let (i, _) = given
                .iter()
                .enumerate()
                .find_map(|(c, g)| g.map(|i| (i, c)))
                .unwrap_or((first, 0));
            return Err(self.at(
                i,
                format!(
                    "column '{}': a coordinate on a row that names the unknown {kind} '{n}': a row \
                     either measures x, y, z or names the point its tool point sits at or the \
                     plane it touches; leave x, y, z empty here",
                    self.table.header.field(i).unwrap_or("")
                ),
            ));
        }
        if named.is_none() && measured < 3 {
            // At the first empty coordinate, as a file without the column is refused.
            let empty = (0..3).find_map(|c| {
                let i = self
                    .table
                    .roles
                    .iter()
                    .position(|r| *r == Role::Position(c))?;
                given[c].is_none().then_some((i, POSITION[c]))
            });
            return Err(match empty {
                Some((i, name)) => self.at(
                    i,
                    format!(
                        "column '{name}': empty, expected a finite number (or, for a session \
                         without a tracker, name the unknown point in '{column}')"
                    ),
                ),
                None => self.at(
                    first,
                    format!(
                        "column '{column}': empty, and the row does not measure x, y, z either: \
                         name the unknown point its tool point sits at or the plane it touches"
                    ),
                ),
            });
        }
        if let Some((kind, _)) = named
            && oriented
        {
            let first = self
                .table
                .roles
                .iter()
                .position(|r| *r == Role::Quat(0))
                .unwrap_or(0);
            return Err(self.at(
                first,
                format!(
                    "column 'qw': an orientation on a row that names an unknown {kind}: only \
                     positions are constrained; leave qw, qx, qy, qz empty"
                ),
            ));
        }
        Ok(())
    }

    /// The row as read, with its `orientation`.
    fn into_record(self, orientation: Option<UnitQuaternion<f64>>) -> Record {
        let measured = self.given.iter().filter(|g| g.is_some()).count();
        // Asked for only in a file that can name points or planes: in
        // another, no row is a constraint row that a coordinate could clash with.
        let first_measured = (measured == 3 && self.constraint_file())
            .then(|| {
                let (i, c) = self
                    .given
                    .iter()
                    .enumerate()
                    .filter_map(|(c, g)| g.map(|i| (i, c)))
                    .min()?;
                Some((self.row.place(i), POSITION[c]))
            })
            .flatten();
        Record {
            line: self.row.line,
            q: self.q,
            position: self.position,
            orientation,
            t: self.t,
            temp: self.temp,
            load: self.load,
            torque: self.torque,
            point: self.point,
            plane: self.plane,
            measured: first_measured,
        }
    }
}
