//! Measurements and joint readings given as arrays (the Python package's numpy
//! input) instead of a CSV file.
//!
//! The arrays hold what the columns of `docs/file-formats.md` §2 hold, in the same units
//! (the model's length and angle units, °C, kg): `q` is `N × M` (joints),
//! `xyz` is `N × 3`, `quat` (optional) is `N × 4` (`qw, qx, qy, qz`), `t`,
//! `temp` and `load` (optional) have `N` values. They are refused as the CSV
//! reader refuses its file: a wrong shape, a value that is not finite, a
//! quaternion whose norm is not 1 within [`QUATERNION_NORM_TOLERANCE`], a
//! `temp` outside [`TEMPERATURE_RANGE`], a `load` outside [`PAYLOAD_RANGE`].
//!
//! Rows are numbered from 0, as numpy indexes them: row `i` becomes the pose or
//! joint row of line `i + 1` (line 0 means "no place" in an [`InputError`]),
//! and [`describe`] renders an error of such data with the row instead of a
//! line (`data row 17: column 'q3': NaN is not a finite number`).

use armcal_shared::Robot;
use armcal_shared::effects::Approach;
use armcal_shared::units::Units;
use nalgebra::{Point3, Quaternion, UnitQuaternion};

use crate::session::input_error::InputError;
use crate::session::joints::{JointRow, JointRows};
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::observation::{
    MAX_TORQUE, Observation, PAYLOAD_RANGE, QUATERNION_NORM_TOLERANCE, TEMPERATURE_RANGE,
};

/// The name measurements from arrays carry in place of a file name.
pub const DATA: &str = "data";

/// The name joint readings from arrays carry in place of a file name.
pub const JOINTS: &str = "joints";

/// A 2-D array, row-major, as numpy gives it.
#[derive(Clone, Copy, Debug)]
pub struct Table<'a> {
    /// `rows × cols` values, row after row.
    pub values: &'a [f64],
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
}

impl<'a> Table<'a> {
    /// Row `i`.
    fn row(&self, i: usize) -> &'a [f64] {
        self.values
            .get(i * self.cols..(i + 1) * self.cols)
            .unwrap_or(&[])
    }
}

/// The optional per-row columns: time (s), temperature (°C), payload (kg).
#[derive(Clone, Copy, Debug, Default)]
pub struct Conditions<'a> {
    /// `t`, s.
    pub t: Option<&'a [f64]>,
    /// `temp`, °C.
    pub temp: Option<&'a [f64]>,
    /// `load`, kg.
    pub load: Option<&'a [f64]>,
}

/// Measured poses as arrays (see [the module](self)).
#[derive(Clone, Copy, Debug)]
pub struct PoseArrays<'a> {
    /// Joint readings, `N × M`, model units.
    pub q: Table<'a>,
    /// Measured tool points, `N × 3`, model length unit.
    pub xyz: Table<'a>,
    /// Measured orientations, `N × 4` (`qw, qx, qy, qz`), if any.
    pub quat: Option<Table<'a>>,
    /// The joint torques the robot reported, `N × M` (N·m, N for a
    /// prismatic joint), if any (`tau1..tauM` of a file).
    pub tau: Option<Table<'a>>,
    /// Time, temperature and payload of each pose.
    pub conditions: Conditions<'a>,
}

/// The measurements the arrays give, read against `model` (named [`DATA`]).
pub fn measurements(model: &RobotModel, a: &PoseArrays<'_>) -> Result<Measurements, InputError> {
    let n = a.q.rows;
    let reader = Reader { file: DATA, n };
    reader.shape("q", &a.q, model.dof())?;
    reader.shape("xyz", &a.xyz, 3)?;
    if let Some(quat) = &a.quat {
        reader.shape("quat", quat, 4)?;
    }
    if let Some(tau) = &a.tau {
        reader.shape("tau", tau, model.dof())?;
    }
    let (t, temp, load) = reader.conditions(&a.conditions)?;
    let mut poses = Vec::with_capacity(n);
    let mut approach = Approach::new();
    for i in 0..n {
        let q = reader.joints(i, a.q.row(i), &model.robot, &model.units)?;
        let xyz = reader.finite(i, a.xyz.row(i), &["x", "y", "z"])?;
        let orientation = match &a.quat {
            None => None,
            Some(quat) => Some(reader.quaternion(i, quat.row(i))?),
        };
        let torque = match &a.tau {
            None => None,
            Some(tau) => Some(reader.torques(i, tau.row(i))?.to_vec()),
        };
        poses.push(Observation::of_row(
            q,
            Point3::new(xyz[0], xyz[1], xyz[2]).map(|x| model.units.length_to_si(x)),
            orientation,
            (temp.map(|v| v[i]), load.map(|v| v[i])),
            torque,
            &mut approach,
        ));
    }
    Ok(Measurements {
        file: DATA.to_owned(),
        poses,
        lines: (1..=n).collect(),
        times: (0..n).map(|i| t.map(|v| v[i])).collect(),
        columns_used: a.columns(model.dof()),
        columns_ignored: Vec::new(),
        warnings: Vec::new(),
        constraints: Default::default(),
        sessions: Vec::new(),
    })
}

impl PoseArrays<'_> {
    /// The names of the columns given, in the order of `docs/file-formats.md` §2.
    fn columns(&self, dof: usize) -> Vec<String> {
        let mut names: Vec<String> = (1..=dof).map(|j| format!("q{j}")).collect();
        names.extend(["x", "y", "z"].map(String::from));
        if self.quat.is_some() {
            names.extend(["qw", "qx", "qy", "qz"].map(String::from));
        }
        names.extend(self.conditions.names());
        if self.tau.is_some() {
            names.extend((1..=dof).map(|j| format!("tau{j}")));
        }
        names
    }
}

impl Conditions<'_> {
    /// The names of the columns given.
    fn names(&self) -> Vec<String> {
        [("t", self.t), ("temp", self.temp), ("load", self.load)]
            .into_iter()
            .filter(|(_, v)| v.is_some())
            .map(|(name, _)| name.to_owned())
            .collect()
    }
}

/// The joint readings the array `q` (`N × M`, model units) gives, read against
/// `robot` in `units` (named [`JOINTS`]), with their conditions.
pub fn joints(
    robot: &Robot<f64>,
    units: &Units,
    q: &Table<'_>,
    conditions: &Conditions<'_>,
) -> Result<JointRows, InputError> {
    let reader = Reader {
        file: JOINTS,
        n: q.rows,
    };
    reader.shape("q", q, robot.dof())?;
    let (t, temp, load) = reader.conditions(conditions)?;
    let rows = (0..q.rows)
        .map(|i| {
            Ok(JointRow {
                line: i + 1,
                q: reader.joints(i, q.row(i), robot, units)?,
                t: t.map(|v| v[i]),
                temp: temp.map(|v| v[i]),
                load: load.map(|v| v[i]),
            })
        })
        .collect::<Result<Vec<_>, InputError>>()?;
    let mut columns_used: Vec<String> = (1..=robot.dof()).map(|j| format!("q{j}")).collect();
    columns_used.extend(conditions.names());
    Ok(JointRows {
        file: JOINTS.to_owned(),
        rows,
        columns_used,
        columns_ignored: Vec::new(),
        warnings: Vec::new(),
    })
}

/// An error of data read from arrays (named `file`, [`DATA`] or [`JOINTS`]) as
/// the user should read it: `data row 17: message` for the row of line 18,
/// `data: message` when the error has no row.
pub fn describe(e: &InputError) -> String {
    if e.line == 0 {
        format!("{}: {}", e.file, e.message)
    } else {
        format!("{} row {}: {}", e.file, e.line - 1, e.message)
    }
}

/// The checks of one set of arrays of `n` rows.
struct Reader<'f> {
    file: &'f str,
    n: usize,
}

type Column<'a> = Option<&'a [f64]>;

impl Reader<'_> {
    /// An error at row `i`, column `j` (0-based).
    fn at(&self, i: usize, j: usize, message: String) -> InputError {
        InputError::new(self.file, i + 1, j + 1, message)
    }

    /// Refuses `table` unless it is `n × cols` (and `n` is at least 1).
    fn shape(&self, name: &str, table: &Table<'_>, cols: usize) -> Result<(), InputError> {
        let wrong = |message: String| Err(InputError::new(self.file, 0, 0, message));
        if self.n == 0 {
            return wrong(format!("'{name}' has no rows: at least one row is needed"));
        }
        if table.cols != cols || table.rows != self.n || table.values.len() != self.n * cols {
            let why = if name == "q" {
                format!("the model has {cols} joints")
            } else {
                format!("{cols} columns, one row per row of 'q'")
            };
            return wrong(format!(
                "'{name}' has shape ({}, {}), expected ({}, {cols}): {why}",
                table.rows, table.cols, self.n
            ));
        }
        Ok(())
    }

    /// `t`, `temp` and `load`, each refused unless it has `n` finite values in
    /// its range.
    fn conditions<'a>(
        &self,
        c: &Conditions<'a>,
    ) -> Result<(Column<'a>, Column<'a>, Column<'a>), InputError> {
        let t = self.column("t", c.t, None)?;
        let temp = self.column("temp", c.temp, Some((TEMPERATURE_RANGE, "°C")))?;
        let load = self.column("load", c.load, Some((PAYLOAD_RANGE, "kg")))?;
        Ok((t, temp, load))
    }

    fn column<'a>(
        &self,
        name: &str,
        values: Column<'a>,
        range: Option<([f64; 2], &str)>,
    ) -> Result<Column<'a>, InputError> {
        let Some(values) = values else {
            return Ok(None);
        };
        if values.len() != self.n {
            return Err(InputError::new(
                self.file,
                0,
                0,
                format!(
                    "'{name}' has {} values, expected {}: one per row of 'q'",
                    values.len(),
                    self.n
                ),
            ));
        }
        for (i, &v) in values.iter().enumerate() {
            self.finite(i, &[v], &[name])?;
            if let Some(([lo, hi], unit)) = range
                && !(lo..=hi).contains(&v)
            {
                return Err(self.at(
                    i,
                    0,
                    format!("column '{name}': {v} {unit} is outside {lo} to {hi} {unit}"),
                ));
            }
        }
        Ok(Some(values))
    }

    /// The values of row `i`, refused unless every one is finite.
    fn finite<'v>(
        &self,
        i: usize,
        values: &'v [f64],
        names: &[&str],
    ) -> Result<&'v [f64], InputError> {
        match values.iter().position(|v| !v.is_finite()) {
            None => Ok(values),
            Some(j) => Err(self.at(
                i,
                j,
                format!(
                    "column '{}': {} is not a finite number",
                    names.get(j).copied().unwrap_or("?"),
                    values[j]
                ),
            )),
        }
    }

    /// Row `i` of the joint torques: finite, and none beyond [`MAX_TORQUE`].
    fn torques<'v>(&self, i: usize, values: &'v [f64]) -> Result<&'v [f64], InputError> {
        let names: Vec<String> = (1..=values.len()).map(|k| format!("tau{k}")).collect();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let values = self.finite(i, values, &names)?;
        match values.iter().position(|v| v.abs() > MAX_TORQUE) {
            None => Ok(values),
            Some(j) => Err(self.at(
                i,
                j,
                format!(
                    "column 'tau{}': {} N·m is more than any arm's joint carries (accepted: up to {MAX_TORQUE} in magnitude; a value in N·mm?)",
                    j + 1,
                    values[j]
                ),
            )),
        }
    }

    /// Row `i` of the joint readings, SI.
    fn joints(
        &self,
        i: usize,
        q: &[f64],
        robot: &Robot<f64>,
        units: &Units,
    ) -> Result<Vec<f64>, InputError> {
        let names: Vec<String> = (1..=q.len()).map(|j| format!("q{j}")).collect();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let q = self.finite(i, q, &names)?;
        Ok(q.iter()
            .zip(&robot.links)
            .map(|(&v, link)| units.joint_to_si(link.joint, v))
            .collect())
    }

    /// Row `i` of the quaternions, normalised; refused unless its norm is 1
    /// within [`QUATERNION_NORM_TOLERANCE`].
    fn quaternion(&self, i: usize, v: &[f64]) -> Result<UnitQuaternion<f64>, InputError> {
        let v = self.finite(i, v, &["qw", "qx", "qy", "qz"])?;
        let quaternion = Quaternion::new(v[0], v[1], v[2], v[3]);
        let norm = quaternion.norm();
        if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
            return Err(self.at(
                i,
                0,
                format!(
                    "column 'qw': quaternion (qw, qx, qy, qz) = ({}, {}, {}, {}) has norm {norm:.6}, \
                     not 1 within {QUATERNION_NORM_TOLERANCE}",
                    v[0], v[1], v[2], v[3]
                ),
            ));
        }
        Ok(UnitQuaternion::from_quaternion(quaternion))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::measurements::parse_measurements;
    use crate::io::model_file::parse_model;

    /// A two-joint arm in mm and degrees, the second joint prismatic.
    fn model() -> RobotModel {
        parse_model(
            "name = \"t\"\nconvention = \"dh\"\nlength_unit = \"mm\"\nangle_unit = \"deg\"\n\
             [[joint]]\ntype = \"revolute\"\ntheta = 0.0\ns = 100.0\na = 50.0\nalpha = 90.0\n\
             [[joint]]\ntype = \"prismatic\"\ntheta = 0.0\ns = 0.0\na = 20.0\nalpha = 0.0\n",
            "t.toml",
        )
        .expect("model")
    }

    fn table(values: &[f64], cols: usize) -> Table<'_> {
        Table {
            values,
            rows: values.len() / cols,
            cols,
        }
    }

    #[test]
    fn arrays_read_as_the_csv_reader_reads_the_same_values() {
        let model = model();
        let q = [10.0, 5.0, -20.0, 7.5];
        let xyz = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let quat = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0];
        let temp = [20.0, 21.0];
        let arrays = PoseArrays {
            q: table(&q, 2),
            xyz: table(&xyz, 3),
            quat: Some(table(&quat, 4)),
            tau: None,
            conditions: Conditions {
                temp: Some(&temp),
                ..Default::default()
            },
        };
        let from_arrays = measurements(&model, &arrays).expect("arrays");
        let csv = "q1,q2,x,y,z,qw,qx,qy,qz,temp\n10,5,1,2,3,1,0,0,0,20\n-20,7.5,4,5,6,0,1,0,0,21\n";
        let from_csv = parse_measurements(csv, "d.csv", &model).expect("csv");
        assert_eq!(from_arrays.columns_used, from_csv.columns_used);
        assert_eq!(from_arrays.lines, [1, 2], "row i is line i + 1");
        // The same poses, contexts (conditions, approach directions) included.
        assert_eq!(from_arrays.poses, from_csv.poses);
        assert_eq!(from_arrays.times, from_csv.times);
    }

    #[test]
    fn a_non_finite_value_is_refused_naming_its_row_and_column() {
        let model = model();
        let q = [0.0, 0.0, 1.0, f64::NAN];
        let xyz = [0.0; 6];
        let arrays = PoseArrays {
            q: table(&q, 2),
            xyz: table(&xyz, 3),
            quat: None,
            tau: None,
            conditions: Conditions::default(),
        };
        let e = measurements(&model, &arrays).expect_err("NaN");
        assert_eq!(
            describe(&e),
            "data row 1: column 'q2': NaN is not a finite number"
        );
        let rows = joints(
            &model.robot,
            &model.units,
            &table(&q, 2),
            &Conditions::default(),
        );
        let e = rows.expect_err("NaN");
        assert_eq!(
            describe(&e),
            "joints row 1: column 'q2': NaN is not a finite number"
        );
    }

    #[test]
    fn wrong_shapes_and_out_of_range_conditions_are_refused() {
        let model = model();
        let q = [0.0; 6];
        let e = joints(
            &model.robot,
            &model.units,
            &table(&q, 3),
            &Conditions::default(),
        )
        .expect_err("3 joints");
        assert_eq!(
            describe(&e),
            "joints: 'q' has shape (2, 3), expected (2, 2): the model has 2 joints"
        );
        let q = [0.0; 4];
        let load = [1.0, -1.0];
        let conditions = Conditions {
            load: Some(&load),
            ..Default::default()
        };
        let e = joints(&model.robot, &model.units, &table(&q, 2), &conditions)
            .expect_err("negative load");
        assert_eq!(
            describe(&e),
            "joints row 1: column 'load': -1 kg is outside 0 to 5000 kg"
        );
        let e = joints(
            &model.robot,
            &model.units,
            &table(&[], 2),
            &Conditions::default(),
        )
        .expect_err("no rows");
        assert_eq!(
            describe(&e),
            "joints: 'q' has no rows: at least one row is needed"
        );
        let xyz = [0.0; 3];
        let arrays = PoseArrays {
            q: table(&q, 2),
            xyz: table(&xyz, 3),
            quat: None,
            tau: None,
            conditions: Conditions::default(),
        };
        let e = measurements(&model, &arrays).expect_err("1 row of xyz");
        assert_eq!(
            describe(&e),
            "data: 'xyz' has shape (1, 3), expected (2, 3): 3 columns, one row per row of 'q'"
        );
    }
}
