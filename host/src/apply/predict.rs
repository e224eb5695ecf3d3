//! `armcal predict`: where the calibrated robot puts its tool point, and how it
//! turns its tool frame, for each row of joint readings.
//!
//! What is computed: for each row of a joint-readings file ([`JointRows`], read
//! against the calibration's nominal model), the measured frame of the
//! *calibrated* model, `base · A_1(q_1) ⋯ A_M(q_M) · tool` with every identified
//! parameter error added to its nominal value ([`Calibration::calibrated`] and
//! [`Robot::forward`](armcal_shared::Robot::forward)). Rows keep their file order.
//!
//! Frames: the position is the origin of the tool frame (the measured point of
//! `docs/file-formats.md` §1) and the orientation that of the tool frame, both in the
//! measurement frame (the tracker's or world frame, after the model's `base`), as
//! the measurements of `docs/file-formats.md` §2 are.
//!
//! Units: readings are converted to SI on reading (the calibration's model units,
//! [`Calibration::units`], apply to the joints file as they applied to the model
//! and data it was identified from); the computation is SI; the CSV
//! ([`Predictions::to_csv`]) gives `x, y, z` in the model's length unit and, when
//! the calibration was identified from full poses ([`Calibration::task`] is `Task::Pose`),
//! the unit quaternion `qw, qx, qy, qz`, scalar first, with `qw ≥ 0`. Numbers are
//! written with the shortest decimal that reads back to the same `f64` (Rust's
//! `{}`), so nothing is lost to formatting.
//!
//! Non-geometric effects (`armcal diagnose`) are applied in each row's context:
//! the `temp` and `load` columns, and the approach direction of each joint from
//! row order (row order is motion order, as in `docs/file-formats.md` §2): the sign of its last
//! change, held while the joint holds.

use armcal_shared::compensation::Task;
use core::fmt::Write as _;

use armcal_shared::Calibration;
use armcal_shared::calibration::model_hash;
use armcal_shared::units::Units;
use nalgebra::{Point3, UnitQuaternion};

use crate::session::input_error::InputError;
use armcal_shared::compensation::Conditions;
use armcal_shared::effects::{Approach, Context};

use crate::session::joints::{JointRow, JointRows};

/// The predicted pose of one row.
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    /// 1-based line of the row in the joints file.
    pub line: usize,
    /// The tool point in the measurement frame, m.
    pub position: Point3<f64>,
    /// The tool frame's orientation in the measurement frame, `w ≥ 0`; `None`
    /// unless the calibration has orientation.
    pub orientation: Option<UnitQuaternion<f64>>,
}

/// The predictions for a whole joints file, in its row order.
#[derive(Clone, Debug, PartialEq)]
pub struct Predictions {
    /// What the calibration is (joint count, model hash, identified errors), for
    /// the comment line of the CSV.
    pub calibration: String,
    /// The calibration file as the user named it, if the caller sets it; named
    /// in the comment line of the CSV.
    pub calibration_file: Option<String>,
    /// The joints file as the user named it.
    pub joints_file: String,
    /// Whether the calibration has orientation (the CSV then has `qw..qz`).
    pub orientation: bool,
    /// One prediction per row of the joints file, in its order.
    pub rows: Vec<Prediction>,
}

/// The conditions of a row that effects depend on: its `temp` (°C) and `load`
/// (kg) columns.
pub fn row_conditions(row: &JointRow) -> Conditions<f64> {
    Conditions {
        temperature: row.temp,
        payload: row.load,
    }
}

/// The context of the effects at a row: its conditions ([`row_conditions`]) and
/// the approach direction of each joint from `approach`, which has seen the rows
/// before (row order is motion order, `docs/file-formats.md` §2); the row is added to it.
pub fn row_context(row: &JointRow, approach: &mut Approach) -> Context<f64> {
    let conditions = row_conditions(row);
    Context {
        temperature: conditions.temperature,
        payload: conditions.payload,
        approach: approach.next(&row.q),
    }
}

/// The pose of the calibrated model for each row of `rows`, in row order.
///
/// `rows` must have been read against the calibration's nominal model
/// ([`parse_joints`](crate::io::measurements::parse_joints) with `&cal.nominal` and
/// `&cal.units`); a row with another number of joint values is refused, naming
/// its file and line. Only the joint readings are used (see [the module](self)).
pub fn predict(cal: &Calibration, rows: &JointRows) -> Result<Predictions, InputError> {
    let model = cal.model();
    let mut out = Vec::with_capacity(rows.len());
    let mut approach = Approach::new();
    for row in &rows.rows {
        let ctx = row_context(row, &mut approach);
        let frame = model
            .forward(&row.q, &ctx)
            .map_err(|e| InputError::new(&rows.file, row.line, 1, e.to_string()))?;
        let orientation = (cal.task == Task::Pose).then(|| {
            let q = UnitQuaternion::from_rotation_matrix(&frame.rotation);
            if q.w < 0.0 {
                UnitQuaternion::new_unchecked(-q.into_inner())
            } else {
                q
            }
        });
        out.push(Prediction {
            line: row.line,
            position: Point3::from(frame.translation.vector),
            orientation,
        });
    }
    let n = cal.errors.len();
    let effects: Vec<&str> = cal.effects.iter().map(|e| e.name()).collect();
    Ok(Predictions {
        calibration: format!(
            "{} joints, model hash {:#018x}, {n} identified parameter error{}, effects: {}, {}",
            cal.nominal.dof(),
            model_hash(&cal.nominal),
            if n == 1 { "" } else { "s" },
            if effects.is_empty() {
                "none".to_string()
            } else {
                effects.join(" ")
            },
            if cal.task == Task::Pose {
                "position and orientation"
            } else {
                "position only"
            }
        ),
        calibration_file: None,
        joints_file: rows.file.clone(),
        orientation: cal.task == Task::Pose,
        rows: out,
    })
}

impl Predictions {
    /// The number of rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The CSV of the predictions: a `#` comment line naming the calibration, the
    /// joints file and the units, the header `x,y,z` (and `qw,qx,qy,qz` when the
    /// calibration has orientation), then one line per row, in row order, lengths
    /// in `units` (the calibration's, [`Calibration::units`]), every number the
    /// shortest decimal that reads back to the same `f64`.
    pub fn to_csv(&self, units: &Units) -> String {
        let mut out = String::new();
        let calibration = match &self.calibration_file {
            Some(file) => format!("{} ({})", one_line(file), self.calibration),
            None => self.calibration.clone(),
        };
        let _ = writeln!(
            out,
            "# armcal predict: calibration {calibration}; joints {}; x, y, z in {} in the measurement frame{}; effects applied in each row's context (temp, load, approach from row order)",
            one_line(&self.joints_file),
            units.length,
            if self.orientation {
                "; qw, qx, qy, qz: unit quaternion of the tool frame, scalar first"
            } else {
                ""
            }
        );
        out.push_str(if self.orientation {
            "x,y,z,qw,qx,qy,qz\n"
        } else {
            "x,y,z\n"
        });
        for row in &self.rows {
            let p = row.position.coords.map(|x| units.length_from_si(x));
            let _ = write!(out, "{},{},{}", num(p.x), num(p.y), num(p.z));
            if self.orientation {
                // A row without orientation cannot come from `predict` when the
                // calibration has it; the identity keeps the columns aligned.
                let q = row.orientation.unwrap_or_else(UnitQuaternion::identity);
                let _ = write!(out, ",{},{},{},{}", num(q.w), num(q.i), num(q.j), num(q.k));
            }
            out.push('\n');
        }
        out
    }
}

/// `x` as the shortest decimal that reads back to it, `-0` written as `0`.
fn num(x: f64) -> String {
    format!("{}", x + 0.0)
}

/// `text` with line breaks and other control characters replaced, to fit a
/// comment line.
fn one_line(text: &str) -> String {
    text.chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::measurements::parse_joints;
    use crate::io::model_file::{load_model, parse_model};
    use armcal_shared::{Param, ParamError};

    /// Reads the numbers of a predictions CSV: the comment, the header, the rows.
    fn read_back(csv: &str) -> (String, String, Vec<Vec<f64>>) {
        let mut lines = csv.lines();
        let comment = lines.next().unwrap().to_owned();
        let header = lines.next().unwrap().to_owned();
        let rows = lines
            .map(|l| l.split(',').map(|f| f.parse::<f64>().unwrap()).collect())
            .collect();
        (comment, header, rows)
    }

    /// The nominal calibration of a model predicts the nominal forward kinematics,
    /// in the model's length unit, to the last bit of the conversion.
    #[test]
    fn nominal_calibration_predicts_nominal_forward_kinematics() {
        let model = load_model("puma560").unwrap();
        let cal = Calibration::nominal(model.robot.clone(), Task::Position, model.units);
        let text = "# readings\nq1,q2,q3,q4,q5,q6,t\n0,0,0,0,0,0,1\n0.1,-0.2,0.3,-0.4,0.5,-0.6,\n";
        let rows = parse_joints(text, "j.csv", &cal.nominal, &cal.units).unwrap();
        let p = predict(&cal, &rows).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!((p.rows[0].line, p.rows[1].line), (3, 4));
        assert!(p.rows.iter().all(|r| r.orientation.is_none()));
        let (comment, header, values) = read_back(&p.to_csv(&cal.units));
        assert!(comment.starts_with("# armcal predict: calibration 6 joints"));
        assert!(comment.contains("x, y, z in in"), "{comment}");
        assert!(
            comment.contains("0 identified parameter errors, effects: none, position only"),
            "{comment}"
        );
        assert_eq!(header, "x,y,z");
        for (row, v) in rows.rows.iter().zip(&values) {
            let expected = model.robot.measured_point(&row.q).unwrap();
            assert_eq!(v.len(), 3);
            for (got, want) in v.iter().zip(expected.iter()) {
                assert_eq!(*got, want / 0.0254);
            }
        }
    }

    /// Identified errors move the prediction; orientation columns come with a
    /// calibration that has orientation, scalar first and non-negative; lengths
    /// follow the model's unit (mm here), angles of the readings too (deg).
    #[test]
    fn calibrated_model_with_orientation_in_mm_and_degrees() {
        let model = parse_model(
            "name = \"rr\"\nconvention = \"mdh\"\nlength_unit = \"mm\"\nangle_unit = \"deg\"\n\
             [[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 100\na = 0\nalpha = 0\n\
             [[joint]]\ntype = \"prismatic\"\ntheta = 0\ns = 0\na = 300\nalpha = 90\n\
             [tool]\nxyz = [0, 0, 50]\nrpy = [0, 0, 180]\n",
            "rr.toml",
        )
        .unwrap();
        let mut cal = Calibration::nominal(model.robot.clone(), Task::Pose, model.units);
        for (param, error) in [(Param::Theta(0), 1e-3), (Param::A(1), 2e-4)] {
            cal.errors.push(ParamError { param, error }).unwrap();
        }
        let text = "x,q2,q1,y,z,qw,qx,qy,qz\n1,20,90,2,3,1,0,0,0\n1,0,-170,2,3,,,,\n";
        let rows = parse_joints(text, "j.csv", &cal.nominal, &cal.units).unwrap();
        assert_eq!(
            rows.columns_ignored,
            ["x", "y", "z", "qw", "qx", "qy", "qz"]
        );
        let p = predict(&cal, &rows).unwrap();
        let (comment, header, values) = read_back(&p.to_csv(&cal.units));
        assert!(comment.contains("x, y, z in mm"), "{comment}");
        assert!(
            comment.contains("2 identified parameter errors"),
            "{comment}"
        );
        assert_eq!(header, "x,y,z,qw,qx,qy,qz");
        let calibrated = cal.calibrated();
        for (row, v) in rows.rows.iter().zip(&values) {
            let t = calibrated.forward(&row.q).unwrap();
            let nominal = model.robot.measured_point(&row.q).unwrap();
            assert!((nominal.coords - t.translation.vector).norm() > 1e-5);
            for (got, want) in v.iter().zip(t.translation.vector.iter()) {
                assert_eq!(*got, want * 1000.0);
            }
            let q =
                UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(v[3], v[4], v[5], v[6]));
            assert!(v[3] >= 0.0);
            assert!(
                q.rotation_to(&UnitQuaternion::from_rotation_matrix(&t.rotation))
                    .angle()
                    < 1e-12
            );
        }
    }

    /// Rows read against another model are refused, naming file and line.
    #[test]
    fn refuses_rows_of_another_joint_count() {
        let model = load_model("puma560").unwrap();
        let cal = Calibration::nominal(model.robot.clone(), Task::Position, model.units);
        let ur = load_model("ur5e").unwrap();
        let mut rows = parse_joints(
            "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n",
            "j.csv",
            &ur.robot,
            &ur.units,
        )
        .unwrap();
        rows.rows[0].q.pop();
        let e = predict(&cal, &rows).unwrap_err();
        assert_eq!((e.file.as_str(), e.line), ("j.csv", 2), "{e}");
    }

    /// `-0` is written `0`; other numbers read back bit for bit; a file name with
    /// a line break does not break the comment line.
    #[test]
    fn numbers_and_comment_line() {
        for x in [
            0.1,
            -1.0 / 3.0,
            1e-300,
            6.02e23,
            f64::MAX,
            f64::MIN_POSITIVE,
        ] {
            assert_eq!(num(x).parse::<f64>().unwrap(), x);
        }
        assert_eq!(num(-0.0), "0");
        let p = Predictions {
            calibration: "c".into(),
            calibration_file: Some("a\nb".into()),
            joints_file: "j\r.csv".into(),
            orientation: false,
            rows: Vec::new(),
        };
        let csv = p.to_csv(&Units::SI);
        assert_eq!(csv.lines().count(), 2, "{csv}");
        assert!(csv.starts_with("# armcal predict: calibration a?b (c); joints j?.csv;"));
    }
}
