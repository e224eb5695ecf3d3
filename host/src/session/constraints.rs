//! Measurements without coordinates: unknown fixed points and known distances.
//!
//! A session without a tracker measures no coordinate. It says instead "these
//! poses put the tool point at the same unknown point" (a ball on the flange in
//! a socket) and "these two points are 50 mm apart" (two sockets of a plate).
//! Such a session is written in the measurement CSV of `docs/file-formats.md` §2 with one
//! more column and one more kind of line (armcal's extension; a file without a
//! `point` column reads exactly as before):
//!
//! - a `point` column: a row whose `point` cell names a point (`front.0`) has its
//!   `x`, `y`, `z` cells empty (or no such columns): its tool point sits at that
//!   named, unknown fixed point. Every point must be named by at least two rows.
//! - a `plane` column: a row whose `plane` cell names a plane (`table`) has its
//!   `x`, `y`, `z` cells empty: its tool point touches that named, unknown plane.
//!   Every plane must be touched by at least three rows.
//! - a distance line, anywhere after the header: `distance,<point>,<point>,<length>[,<std>]`,
//!   the known distance between two named points in the model's length unit and,
//!   optionally, its standard uncertainty (default [`DEFAULT_DISTANCE_STD`]).
//!
//! A file holds either measured coordinates or constraints, not both. The
//! points are in the robot's base frame, estimated with the robot's parameters;
//! the base itself is then not observable and is held at nominal.
//!
//! Everything here is SI (m) once read.

/// The standard uncertainty of a known distance when the line gives none, m
/// (0.01 mm: a machined or printed part checked with a caliper).
pub const DEFAULT_DISTANCE_STD: f64 = 1e-5;

/// Words that start a line of their own kind, not point names.
pub const RESERVED: [&str; 1] = ["distance"];

/// A distance line of a constraint file, as read: the names of its two
/// points, before they are found among the points the rows name.
#[derive(Clone, Debug, PartialEq)]
pub struct DistanceLine {
    /// The line of the file.
    pub line: usize,
    /// The two point names and the place (line, character column) of each.
    pub points: [(String, (usize, usize)); 2],
    /// The length, m.
    pub length: f64,
    /// Its standard uncertainty, m.
    pub std: f64,
    /// The place of the length's cell.
    pub length_at: (usize, usize),
}

/// An unknown fixed point or plane named in the file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Named {
    /// Its name as written (`front.0`, `table`).
    pub name: String,
    /// The line and character column of the first row naming it.
    pub first: (usize, usize),
    /// How many rows name it.
    pub rows: usize,
}

/// An unknown fixed point: the tool point of every row naming it sits at it.
pub type FixedPoint = Named;

/// An unknown plane: the tool point of every row naming it touches it.
pub type TouchedPlane = Named;

/// Adds the names of `part` to `into` (a name already there counts the rows
/// of both): the index in `into` of each of `part`'s.
pub fn merge_named(into: &mut Vec<Named>, part: &[Named]) -> Vec<usize> {
    part.iter()
        .map(|p| match into.iter().position(|q| q.name == p.name) {
            Some(k) => {
                into[k].rows += p.rows;
                k
            }
            None => {
                into.push(p.clone());
                into.len() - 1
            }
        })
        .collect()
}

/// A known distance between two named points.
#[derive(Clone, Debug, PartialEq)]
pub struct Distance {
    /// The two points, indices into [`Constraints::points`].
    pub points: [usize; 2],
    /// The distance, m.
    pub length: f64,
    /// Its standard uncertainty, m.
    pub std: f64,
    /// The line of the file that gives it.
    pub line: usize,
}

/// The least touches that say anything of a plane beyond its own three unknowns.
pub const MIN_PLANE_TOUCHES: usize = 3;

/// The constraints of a file: its named points, the distances between them and
/// its named planes (all empty for a file of measured coordinates).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Constraints {
    /// The points, in the order they are first named.
    pub points: Vec<FixedPoint>,
    /// The planes, in the order they are first named.
    pub planes: Vec<TouchedPlane>,
    /// The known distances, in file order.
    pub distances: Vec<Distance>,
}

impl Constraints {
    /// Whether the file has no constraints (it measures coordinates).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty() && self.planes.is_empty()
    }

    /// The index of the point named `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| p.name == name)
    }

    /// The scalar equations the distances give.
    pub fn equations(&self) -> usize {
        self.distances.len()
    }
}
