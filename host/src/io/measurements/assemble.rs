//! A measurement file's data lines assembled into a [`Measurements`] session
//! as they are read ([`Session`]): the poses in file order, with their lines
//! and times (s); in a file without a tracker, the unknown points and planes
//! its rows name and the known distances (m) between points, each checked
//! against what the rows and the nominal model can carry (the session's
//! checks, [`require_plausible_distance`] among them).

use armcal_shared::JointType;
use armcal_shared::effects::Approach;
use nalgebra::Point3;

use super::schema::{Columns, Item, Place, Schema, ignored_warning};
use crate::session::constraints::{
    Constraints, Distance, DistanceLine, MIN_PLANE_TOUCHES, Named, merge_named,
};
use crate::session::input_error::InputError;
use crate::session::measurements::{
    Measurements, nominal_point_means, plural, reach, require_plausible_distance,
};
use crate::session::model::RobotModel;
use crate::session::observation::{Contact, Observation};

// What a row says beside its joints: its line, where it measures x, y, z
// (the column of its first coordinate), and the point and plane it names.
// Kept for the constraint rows (x, y, z not measured, a point or plane
// named), with their pose's index, and for the first row measuring x, y,
// z: a file of coordinates keeps nothing per row.
type NameCell = Option<(String, Place)>;
type Tag = (usize, Option<(Place, &'static str)>, NameCell, NameCell);

/// A measurement file's data lines as read so far.
pub(super) struct Session {
    poses: Vec<Observation>,
    lines: Vec<usize>,
    times: Vec<Option<f64>>,
    approach: Approach,
    distance_lines: Vec<DistanceLine>,
    constraint_rows: Vec<(usize, Tag)>,
    first_measured: Option<Tag>,
}

impl Session {
    pub(super) fn new() -> Self {
        Self {
            poses: Vec::new(),
            lines: Vec::new(),
            times: Vec::new(),
            approach: Approach::new(),
            distance_lines: Vec::new(),
            constraint_rows: Vec::new(),
            first_measured: None,
        }
    }

    /// Takes the next data line of the file.
    pub(super) fn take(&mut self, item: Item) {
        let r = match item {
            Item::Row(r) => r,
            Item::Distance(d) => return self.distance_lines.push(d),
        };
        let tag = (r.line, r.measured, r.point, r.plane);
        if tag.1.is_some() {
            self.first_measured.get_or_insert(tag);
        } else if tag.2.is_some() || tag.3.is_some() {
            self.constraint_rows.push((self.poses.len(), tag));
        }
        self.poses.push(Observation::of_row(
            r.q,
            Point3::from(r.position),
            r.orientation,
            (r.temp, r.load),
            r.torque,
            &mut self.approach,
        ));
        self.lines.push(r.line);
        self.times.push(r.t);
    }

    /// The session the file `file` (its `columns` as read) gives against
    /// `model`, once every line is read.
    pub(super) fn finish(
        mut self,
        file: &str,
        model: &RobotModel,
        schema: &Schema<'_>,
        mut columns: Columns,
    ) -> Result<Measurements, InputError> {
        // A file whose every row measures x, y, z is a file of coordinates, read
        // as without the extension: a `point` or `plane` column is then an id,
        // kept out of the computation.
        let Some((_, first_constraint)) = self.constraint_rows.first() else {
            if let Some(d) = self.distance_lines.first() {
                return Err(InputError::new(
                    file,
                    d.line,
                    1,
                    "a distance line in a file whose every row measures x, y, z: distances tie \
                     unknown points (rows naming a point, x, y, z empty)",
                ));
            }
            ignore_name_columns(file, schema, &mut columns);
            return Ok(self.into_measurements(file, columns, Constraints::default()));
        };
        refuse_measured_beside(file, &self.first_measured, first_constraint.0)?;
        let mut constraints = self.name_contacts();
        require_enough_rows(file, &constraints)?;
        let distance_lines = std::mem::take(&mut self.distance_lines);
        // The nominal tool point of every row held to a point, for the distances'
        // check; computed only when there is a distance.
        let nominal_points = (!distance_lines.is_empty())
            .then(|| nominal_point_means(&model.robot, &self.poses, constraints.points.len()));
        for d in distance_lines {
            let distance =
                self.distance(file, model, &constraints, nominal_points.as_deref(), d)?;
            constraints.distances.push(distance);
        }
        let prismatic = model
            .robot
            .links
            .iter()
            .any(|l| l.joint == JointType::Prismatic);
        if !constraints.is_empty() && constraints.distances.is_empty() && !prismatic {
            columns.warnings.push(
                "no known distance (no `distance` line): nothing in this file fixes the arm's scale \
                 (a larger arm reaching larger points or planes fits these rows as well), so only the \
                 prior on the lengths holds it; give the distance between two of its points (a \
                 plate's socket spacing, a ball-bar's length)"
                    .to_owned(),
            );
        }
        Ok(self.into_measurements(file, columns, constraints))
    }

    /// The unknown points and planes the constraint rows name, each pose's
    /// contact set to its own.
    fn name_contacts(&mut self) -> Constraints {
        let mut constraints = Constraints::default();
        for (index, (_, _, point, plane)) in std::mem::take(&mut self.constraint_rows) {
            let pose = &mut self.poses[index];
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
        constraints
    }

    /// The distance line `d` between two of the `constraints`' points,
    /// refused if it names another or contradicts the nominal model
    /// (`nominal_points`, the mean nominal tool point of each point's rows).
    fn distance(
        &self,
        file: &str,
        model: &RobotModel,
        constraints: &Constraints,
        nominal_points: Option<&[Option<Point3<f64>>]>,
        d: DistanceLine,
    ) -> Result<Distance, InputError> {
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
        if let Some(means) = nominal_points {
            let reach = reach(&model.robot, self.poses.iter().map(|p| p.q.as_slice()));
            if let (Some(a), Some(b)) = (means[ends[0]], means[ends[1]]) {
                require_plausible_distance(file, &d, (a - b).norm(), reach, &model.units)?;
            }
        }
        Ok(Distance {
            points: ends,
            length: d.length,
            std: d.std,
            line: d.line,
        })
    }

    fn into_measurements(
        mut self,
        file: &str,
        mut columns: Columns,
        constraints: Constraints,
    ) -> Measurements {
        if self.approach_in_time_order() {
            columns.warnings.push(format!(
                "{file}: the rows are not in the order of their times (`t`): each joint's approach \
                 direction (backlash) is taken in the order of the times, the order the robot moved in"
            ));
        }
        Measurements {
            file: file.to_owned(),
            poses: self.poses,
            lines: self.lines,
            times: self.times,
            columns_used: columns.used,
            columns_ignored: columns.ignored,
            warnings: columns.warnings,
            constraints,
            sessions: Vec::new(),
        }
    }
}

impl Session {
    /// When every row has a time and the rows are not in its order, each
    /// pose's approach directions set again in the order of the times (rows of
    /// equal times in file order): the direction a joint approached a pose from
    /// is that of its move to it, and a file written sorted by configuration or
    /// merged from several logs is not in the order the robot moved. Whether
    /// they were set again.
    fn approach_in_time_order(&mut self) -> bool {
        let Some(times) = self.times.iter().copied().collect::<Option<Vec<f64>>>() else {
            return false;
        };
        if times.is_sorted() {
            return false;
        }
        let mut order: Vec<usize> = (0..times.len()).collect();
        order.sort_by(|&a, &b| times[a].total_cmp(&times[b]));
        let mut approach = Approach::new();
        for i in order {
            let pose = &mut self.poses[i];
            pose.context.approach = approach.next(&pose.q);
        }
        true
    }
}

/// In a file of coordinates, its `point` and `plane` columns are kept out of
/// the computation: moved from the columns used to those ignored, and the
/// warning naming the ignored columns said again.
fn ignore_name_columns(file: &str, schema: &Schema<'_>, columns: &mut Columns) {
    let (line, header) = &columns.header;
    if header.iter().any(|n| n == "point" || n == "plane") {
        let old = ignored_warning(file, *line, &columns.ignored, schema);
        columns.used.retain(|n| n != "point" && n != "plane");
        columns.ignored = header
            .iter()
            .filter(|n| !columns.used.contains(n))
            .cloned()
            .collect();
        let new = ignored_warning(file, *line, &columns.ignored, schema);
        match (old, new) {
            (Some(_), Some(w)) => columns.warnings[0] = w,
            (None, Some(w)) => columns.warnings.insert(0, w),
            _ => {}
        }
    }
}

/// Refuses a file with a row measuring x, y, z (`first_measured`, the first
/// such) beside rows naming unknown points or planes (the first on line
/// `first_constraint`).
fn refuse_measured_beside(
    file: &str,
    first_measured: &Option<Tag>,
    first_constraint: usize,
) -> Result<(), InputError> {
    if let Some((_, Some(((line, column), coordinate)), point, plane)) = first_measured {
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
                "column '{coordinate}': this row measures x, y, z while line {first_constraint} names an unknown point or plane: a \
                 file holds either measured coordinates or constraints (unknown points, planes, \
                 distances), not both"
            ),
        };
        return Err(InputError::new(file, *line, *column, message));
    }
    Ok(())
}

/// Refuses an unknown point named by one row only, or a plane touched by
/// fewer than [`MIN_PLANE_TOUCHES`] rows.
fn require_enough_rows(file: &str, constraints: &Constraints) -> Result<(), InputError> {
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
    Ok(())
}
