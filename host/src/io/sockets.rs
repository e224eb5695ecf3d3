//! The sockets file `armcal plan --sockets` reads: where the sockets a ball on
//! the flange will be seated in are, roughly, and the known distances between
//! them (`docs/file-formats.md` §7).
//!
//! ```text
//! # a plate of three sockets on the table, model length unit, base frame
//! point,x,y,z
//! front.0,0.55,-0.10,0.02
//! front.1,0.55,0.10,0.02
//! front.2,0.70,0.00,0.02
//! distance,front.0,front.1,0.2,1e-05
//! ```
//!
//! - A header `point,x,y,z`, optionally `,ax,ay,az`: the direction (base frame)
//!   the ball enters its socket from (the stem from the ball to the flange
//!   keeps within [`APPROACH_CONE_DEG`] of it), default `0,0,1` (from above).
//! - A row per socket: a name (any text but a number or `distance`, each once)
//!   and its centre, in the robot's base frame, in the model's length unit, to
//!   a few millimetres (the plan reaches it with the nominal model).
//! - Distance lines as in a session file (§3): `distance,<point>,<point>,<length>[,<std>]`.
//!
//! Everything returned is SI (m). Refused with file, line and column.

use armcal_shared::units::Units;
use nalgebra::{Point3, Vector3};

use crate::io::input_error::{MODEL_FILE, read_text};
use crate::session::constraints::{DEFAULT_DISTANCE_STD, Distance};
use crate::session::input_error::InputError;

/// The half-angle of the cone about a socket's approach direction the stem
/// from the ball to the flange keeps within, degrees: a plate's socket is
/// entered from its open side.
pub const APPROACH_CONE_DEG: f64 = 60.0;

/// How far a socket's stated centre may be from the true one, m: the file
/// gives it to a few millimetres, and the plan seats the ball there with the
/// nominal model, whose tool point misses by millimetres. A known distance
/// may thus differ from its two centres' by twice this, and by no more: a
/// larger difference is a wrong centre, a wrong name or a length in another
/// unit.
pub const CENTRE_UNCERTAINTY: f64 = 0.01;

/// A socket: its name, its nominal centre (base frame, m) and the unit
/// direction it is entered from.
#[derive(Clone, Debug, PartialEq)]
pub struct Socket {
    /// Its name, as the plan's `point` column writes it.
    pub name: String,
    /// Its centre, base frame, m.
    pub centre: Point3<f64>,
    /// The unit direction (base frame) from the socket towards the flange.
    pub approach: Vector3<f64>,
}

/// The sockets of a plan and the known distances between them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sockets {
    /// The sockets, in file order.
    pub sockets: Vec<Socket>,
    /// The known distances (indices into `sockets`), SI.
    pub distances: Vec<Distance>,
}

/// Reads the sockets file at `path` in the model's `units`.
pub fn load_sockets(path: &str, units: &Units) -> Result<Sockets, InputError> {
    let text = read_text(path, MODEL_FILE)?;
    parse_sockets(&text, path, units)
}

/// Parses the text of a sockets file; `file` names it in errors.
pub fn parse_sockets(text: &str, file: &str, units: &Units) -> Result<Sockets, InputError> {
    let mut out = Sockets::default();
    let mut header: Option<usize> = None;
    let mut distance_lines = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let content = raw.trim_end_matches('\r');
        if content.trim().is_empty() || content.trim_start().starts_with('#') {
            continue;
        }
        let cells = cells(content);
        let at = |k: usize, message: String| InputError::new(file, line, cells[k].0, message);
        let Some(columns) = header else {
            let names: Vec<&str> = cells.iter().map(|c| c.1).collect();
            match names.as_slice() {
                ["point", "x", "y", "z"] => header = Some(4),
                ["point", "x", "y", "z", "ax", "ay", "az"] => header = Some(7),
                _ => {
                    return Err(at(
                        0,
                        "the header must be `point,x,y,z` or `point,x,y,z,ax,ay,az`".into(),
                    ));
                }
            }
            continue;
        };
        if cells[0].1 == "distance" {
            distance_lines.push((line, cells));
            continue;
        }
        if cells.len() != columns {
            return Err(at(
                cells.len().min(columns) - 1,
                format!("{} fields, the header has {columns}", cells.len()),
            ));
        }
        let name = cells[0].1;
        if name.is_empty() || name.parse::<f64>().is_ok() {
            return Err(at(
                0,
                format!("`{name}`: a socket's name is text, not a number"),
            ));
        }
        if out.sockets.iter().any(|s| s.name == name) {
            return Err(at(0, format!("socket `{name}` is given twice")));
        }
        let number = |k: usize| -> Result<f64, InputError> {
            cells[k]
                .1
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| at(k, format!("`{}`: not a number", cells[k].1)))
        };
        let centre = Point3::new(
            units.length_to_si(number(1)?),
            units.length_to_si(number(2)?),
            units.length_to_si(number(3)?),
        );
        let approach = if columns == 7 {
            let a = Vector3::new(number(4)?, number(5)?, number(6)?);
            if a.norm() == 0.0 {
                return Err(at(4, "the approach direction is zero".into()));
            }
            a.normalize()
        } else {
            Vector3::z()
        };
        out.sockets.push(Socket {
            name: name.to_owned(),
            centre,
            approach,
        });
    }
    if header.is_none() || out.sockets.is_empty() {
        return Err(InputError::new(
            file,
            0,
            0,
            "no socket: a header `point,x,y,z` and a row a socket",
        ));
    }
    for (line, cells) in distance_lines {
        out.distances
            .push(distance(file, line, &cells, &out.sockets, units)?);
    }
    Ok(out)
}

/// The cells of a line, each with its 1-based character column, trimmed.
fn cells(line: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut column = 1;
    for cell in line.split(',') {
        out.push((column, cell.trim()));
        column += cell.chars().count() + 1;
    }
    out
}

/// A distance line `distance,<a>,<b>,<length>[,<std>]` between two of `sockets`.
fn distance(
    file: &str,
    line: usize,
    cells: &[(usize, &str)],
    sockets: &[Socket],
    units: &Units,
) -> Result<Distance, InputError> {
    let at = |k: usize, message: String| InputError::new(file, line, cells[k].0, message);
    if !(4..=5).contains(&cells.len()) {
        return Err(at(
            0,
            format!(
                "a distance line has 4 or 5 fields (distance,<point>,<point>,<length>[,<std>]), not {}",
                cells.len()
            ),
        ));
    }
    let socket = |k: usize| {
        sockets
            .iter()
            .position(|s| s.name == cells[k].1)
            .ok_or_else(|| at(k, format!("`{}`: no socket of that name", cells[k].1)))
    };
    let (a, b) = (socket(1)?, socket(2)?);
    if a == b {
        return Err(at(2, "a distance from a socket to itself".into()));
    }
    let positive = |k: usize| {
        cells[k]
            .1
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v > 0.0)
            .map(|v| units.length_to_si(v))
            .ok_or_else(|| at(k, format!("`{}`: must be a positive number", cells[k].1)))
    };
    let length = positive(3)?;
    let centres = (sockets[a].centre - sockets[b].centre).norm();
    if (length - centres).abs() > 2.0 * CENTRE_UNCERTAINTY {
        let unit = units.length;
        return Err(at(
            3,
            format!(
                "{} {} stated between `{}` and `{}`, whose centres are {:.4} {} apart: a \
                 distance may differ from its sockets' centres by {} {} at most (each centre to \
                 {} {}); check the centres, the names and the unit",
                cells[3].1,
                unit.name(),
                cells[1].1,
                cells[2].1,
                unit.from_si(centres),
                unit.name(),
                unit.from_si(2.0 * CENTRE_UNCERTAINTY),
                unit.name(),
                unit.from_si(CENTRE_UNCERTAINTY),
                unit.name(),
            ),
        ));
    }
    Ok(Distance {
        points: [a, b],
        length,
        std: if cells.len() == 5 {
            positive(4)?
        } else {
            DEFAULT_DISTANCE_STD
        },
        line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mm() -> Units {
        Units {
            length: armcal_shared::units::LengthUnit::Mm,
            ..Units::default()
        }
    }

    /// A file in mm reads as SI, the approach defaults to from above, and a
    /// distance's default uncertainty is a session file's.
    #[test]
    fn a_sockets_file_reads_in_si() {
        let text = "# plate\npoint,x,y,z\na,550,-100,20\nb,550,100,20\ndistance,a,b,200\n";
        let s = parse_sockets(text, "s.csv", &mm()).unwrap();
        assert_eq!(s.sockets.len(), 2);
        assert!((s.sockets[1].centre - Point3::new(0.55, 0.1, 0.02)).norm() < 1e-15);
        assert_eq!(s.sockets[0].approach, Vector3::z());
        assert_eq!(s.distances[0].points, [0, 1]);
        assert!((s.distances[0].length - 0.2).abs() < 1e-15);
        assert_eq!(s.distances[0].std, DEFAULT_DISTANCE_STD);
    }

    /// Each refusal names its line and column.
    #[test]
    fn a_bad_sockets_file_is_refused_at_its_cell() {
        let cases = [
            ("point,x,y\n", 1, 1),
            ("point,x,y,z\na,1,2,zz\n", 2, 7),
            ("point,x,y,z\na,1,2,3\na,1,2,3\n", 3, 1),
            ("point,x,y,z\na,1,2,3\nb,1,2,4\ndistance,a,c,5\n", 4, 12),
            ("point,x,y,z\na,1,2,3\nb,1,2,4\ndistance,a,b,-5\n", 4, 14),
            ("point,x,y,z\na,1,2,3\nb,1,2,4\ndistance,a,a,5\n", 4, 12),
            ("point,x,y,z,ax,ay,az\na,1,2,3,0,0,0\n", 2, 9),
            ("point,x,y,z\n3,1,2,3\n", 2, 1),
            // Centres 300 mm apart, a distance of 900 mm: contradicts them.
            ("point,x,y,z\na,0,0,0\nb,300,0,0\ndistance,a,b,900\n", 4, 14),
        ];
        for (text, line, column) in cases {
            let e = parse_sockets(text, "s.csv", &mm()).unwrap_err();
            assert_eq!((e.line, e.column), (line, column), "{text:?}: {e}");
        }
        assert_eq!(
            parse_sockets("point,x,y,z\n", "s.csv", &mm())
                .unwrap_err()
                .line,
            0
        );
    }

    /// A known distance within twice a centre's uncertainty of its sockets'
    /// centres is taken (the centres are given to a few millimetres); just
    /// beyond it, refused.
    #[test]
    fn a_distance_is_checked_against_its_centres() {
        let file = |d: f64| format!("point,x,y,z\na,0,0,0\nb,300,0,0\ndistance,a,b,{d}\n");
        let within = 300.0 + 2e3 * CENTRE_UNCERTAINTY * 0.99;
        let beyond = 300.0 - 2e3 * CENTRE_UNCERTAINTY * 1.01;
        assert!(parse_sockets(&file(within), "s.csv", &mm()).is_ok());
        let e = parse_sockets(&file(beyond), "s.csv", &mm()).unwrap_err();
        assert!(e.message.contains("centres are 300.0000 mm apart"), "{e}");
    }
}
