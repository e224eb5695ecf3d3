//! `armcal check`: what armcal read, and how far the nominal model is from the data.
//!
//! Before any identification a calibration engineer wants to see that the files
//! were read as meant: the joints and their parameters in the model's own units,
//! the poses, which columns were used and which ignored, and the error of the
//! nominal model against the measurements. A nominal error of millimetres is
//! normal; metres mean a wrong unit, a wrong base frame or a wrong joint order.
//!
//! Position errors are `|P_measured − P_nominal|` of the tool point in the
//! measurement frame (docs/file-formats.md §1: `base · A_1 ⋯ A_M · tool`); orientation errors
//! are the angle of `R_measured · R_nominalᵀ`. The count of independent geometric
//! parameters a full calibration identifies is `4R + 2P + 6` for full poses and
//! `4R + 2P + 3` for positions only (R revolute, P prismatic joints; Everett,
//! Driels & Mooring, "Kinematic modelling for robot calibration", ICRA 1987): the
//! data must give at least that many equations (3 per position, 6 per pose).

use std::fmt::Write as _;

use armcal_shared::JointType;

use crate::calibration::fit::independent_parameter_count;
use nalgebra::UnitQuaternion;

use crate::calibration::fit::session_registrations;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;
use crate::session::registration::in_session;
use crate::session::registration::{FrameSharing, Registrations};

/// Error statistics of the nominal model over all poses.
#[derive(Clone, Debug, PartialEq)]
pub struct NominalError {
    /// RMS of the tool-point position error, m.
    pub position_rms: f64,
    /// Mean position error, m.
    pub position_mean: f64,
    /// Largest position error, m.
    pub position_max: f64,
    /// The data-file line of the largest position error.
    pub position_max_line: usize,
    /// RMS, mean and max of the orientation error angle, rad, when the data have orientation.
    pub orientation: Option<(f64, f64, f64)>,
    /// The pose of the largest position error (an index into the poses).
    pub position_max_pose: usize,
    /// With several sessions, each session's RMS position error, m.
    pub sessions: Vec<f64>,
}

/// The nominal model's errors against the measurements: with several
/// sessions, the first session's as the model is, each later one's with its
/// own base and tool registered to its rows in closed form (as a fit starts).
pub fn nominal_error(model: &RobotModel, data: &Measurements) -> NominalError {
    let n = data.poses.len().max(1) as f64;
    let (mut sum_sq, mut sum, mut max, mut max_line, mut max_pose) = (0.0, 0.0, 0.0f64, 0, 0);
    let mut angles = Vec::new();
    let count = data.session_count();
    let shape = Registrations::of(&model.robot, count, FrameSharing::default());
    let kinematics: Vec<_> = session_registrations(&model.robot, &data.poses, &shape)
        .robots(&model.robot)
        .iter()
        .map(|r| r.prepare())
        .collect();
    let mut sessions = vec![(0.0, 0usize); count];
    for (i, (pose, &line)) in data.poses.iter().zip(&data.lines).enumerate() {
        // The joint count was checked when the data were read against the model.
        let Ok(frame) = in_session(&kinematics, pose.session).forward(&pose.q) else {
            continue;
        };
        let e = (pose.position.coords - frame.translation.vector).norm();
        sum_sq += e * e;
        sum += e;
        if let Some(s) = sessions.get_mut(pose.session) {
            *s = (s.0 + e * e, s.1 + 1);
        }
        if e > max {
            (max, max_line, max_pose) = (e, line, i);
        }
        if let Some(measured) = pose.orientation {
            let nominal = UnitQuaternion::from_rotation_matrix(&frame.rotation);
            angles.push(measured.angle_to(&nominal));
        }
    }
    let orientation = (!angles.is_empty()).then(|| {
        let k = angles.len() as f64;
        let rms = (angles.iter().map(|a| a * a).sum::<f64>() / k).sqrt();
        let mean = angles.iter().sum::<f64>() / k;
        (rms, mean, angles.iter().cloned().fold(0.0, f64::max))
    });
    NominalError {
        position_rms: (sum_sq / n).sqrt(),
        position_mean: sum / n,
        position_max: max,
        position_max_line: max_line,
        orientation,
        position_max_pose: max_pose,
        sessions: if count > 1 {
            sessions
                .iter()
                .map(|(s, k)| (s / (*k).max(1) as f64).sqrt())
                .collect()
        } else {
            Vec::new()
        },
    }
}

/// The human summary that `armcal check` prints.
pub fn report(model: &RobotModel, data: &Measurements) -> String {
    let mut out = String::new();
    write_model(&mut out, model);
    let full_pose = data.poses.iter().all(|p| p.orientation.is_some());
    write_data(&mut out, model, data, full_pose);
    if data.is_constrained() {
        write_constraint_check(&mut out, model, data);
    } else {
        write_nominal_error(&mut out, model, data, full_pose);
    }
    out
}

/// The model: its name, convention and units, the D-H table, base and tool.
fn write_model(out: &mut String, model: &RobotModel) {
    let u = &model.units;
    let robot = &model.robot;
    let _ = writeln!(out, "model   {} ({})", model.name, model.source);
    if !model.description.is_empty() {
        let _ = writeln!(out, "        {}", model.description);
    }
    let _ = writeln!(
        out,
        "        convention {}, {} joints, lengths in {}, angles in {}",
        match robot.convention {
            armcal_shared::Convention::Dh => "dh (Rot_z θ · Trans_z s · Trans_x a · Rot_x α)",
            armcal_shared::Convention::Mdh => "mdh (Rot_x α · Trans_x a · Rot_z θ · Trans_z s)",
        },
        robot.dof(),
        u.length,
        u.angle
    );
    let _ = writeln!(
        out,
        "\n  joint  type       {:>12} {:>12} {:>12} {:>12}   limits",
        format!("theta [{}]", u.angle),
        format!("s [{}]", u.length),
        format!("a [{}]", u.length),
        format!("alpha [{}]", u.angle)
    );
    for (i, l) in robot.links.iter().enumerate() {
        let limits = match l.limits {
            Some([lo, hi]) => format!(
                "[{}, {}]",
                fmt_num(u.joint_from_si(l.joint, lo)),
                fmt_num(u.joint_from_si(l.joint, hi))
            ),
            None => "-".into(),
        };
        let _ = writeln!(
            out,
            "  {:>5}  {:<9}  {:>12} {:>12} {:>12} {:>12}   {}",
            i + 1,
            match l.joint {
                JointType::Revolute => "revolute",
                JointType::Prismatic => "prismatic",
            },
            fmt_num(u.angle_from_si(l.theta)),
            fmt_num(u.length_from_si(l.s)),
            fmt_num(u.length_from_si(l.a)),
            fmt_num(u.angle_from_si(l.alpha)),
            limits
        );
    }
    for (label, frame) in [("base", &robot.base), ("tool", &robot.tool)] {
        let _ = writeln!(
            out,
            "  {label}   xyz [{}] = [{}, {}, {}]   rpy [{}] = [{}, {}, {}]",
            u.length,
            fmt_num(u.length_from_si(frame.xyz.x)),
            fmt_num(u.length_from_si(frame.xyz.y)),
            fmt_num(u.length_from_si(frame.xyz.z)),
            u.angle,
            fmt_num(u.angle_from_si(frame.rpy.x)),
            fmt_num(u.angle_from_si(frame.rpy.y)),
            fmt_num(u.angle_from_si(frame.rpy.z)),
        );
    }
}

/// The data: the file, the poses and what they measure, the columns, the
/// units, the warnings.
fn write_data(out: &mut String, model: &RobotModel, data: &Measurements, full_pose: bool) {
    let u = &model.units;
    let _ = writeln!(out, "\ndata    {}", data.file);
    if data.session_count() > 1 {
        let _ = writeln!(
            out,
            "        {} sessions: {}",
            data.session_count(),
            data.sessions.join(", ")
        );
    }
    let _ = writeln!(
        out,
        "        {} poses, {} ({} equations)",
        data.poses.len(),
        if data.is_constrained() {
            "constraints: rows at unknown points or on unknown planes, known distances"
        } else if full_pose {
            "full poses: position and orientation"
        } else {
            "positions only"
        },
        data.equations()
    );
    let _ = writeln!(
        out,
        "        columns used:    {}",
        data.columns_used.join(", ")
    );
    let ignored = if data.columns_ignored.is_empty() {
        "none".into()
    } else {
        data.columns_ignored.join(", ")
    };
    let _ = writeln!(out, "        columns ignored: {ignored}");
    let _ = writeln!(
        out,
        "        units: joints in {} (revolute) / {} (prismatic), positions in {}{}",
        u.angle,
        u.length,
        u.length,
        [
            ("t", "s"),
            ("temp", "°C"),
            ("load", "kg"),
            ("tau1", "N·m (N for a prismatic joint)")
        ]
        .iter()
        .filter(|(c, _)| data.columns_used.iter().any(|used| used == c))
        .map(|(c, unit)| match *c {
            "tau1" => format!(
                ", tau1..tau{} in {unit}",
                data.columns_used
                    .iter()
                    .filter(|u| u.starts_with("tau"))
                    .count()
            ),
            _ => format!(", {c} in {unit}"),
        })
        .collect::<String>()
    );
    for w in &data.warnings {
        let _ = writeln!(out, "        warning: {w}");
    }
}

/// A session without coordinates: how well the nominal model keeps the rows
/// of each point together and the known distances.
fn write_constraint_check(out: &mut String, model: &RobotModel, data: &Measurements) {
    let robot = &model.robot;
    // No coordinate to compare with: how well the nominal model keeps the
    // rows of each point together and the known distances.
    let c = crate::calibration::validation::contact_check::contact_check(
        &crate::calibration::validation::contact_check::geometric(robot),
        data,
    );
    let _ = writeln!(
        out,
        "\nnominal model against the constraints ({} points, {} planes, {} distances)",
        data.constraints.points.len(),
        data.constraints.planes.len(),
        data.constraints.distances.len()
    );
    let points = c.points.iter().map(|p| {
        let what = "rows, spread (RMS distance to their mean)";
        ("point", &p.name, p.rows, what, p.spread)
    });
    let planes = c.planes.iter().map(|p| {
        let what = "touches, flatness (RMS distance to their least-squares plane)";
        ("plane", &p.name, p.rows, what, p.flatness)
    });
    for (kind, name, rows, what, figure) in points.chain(planes) {
        let _ = writeln!(
            out,
            "        {kind} {name:<12} {rows} {what} {:.3} mm",
            figure * 1e3
        );
    }
    for d in &c.distances {
        let _ = writeln!(
            out,
            "        distance {} – {}: stated {:.3} mm, predicted minus stated {:+.3} mm",
            d.points[0],
            d.points[1],
            d.stated * 1e3,
            d.error * 1e3
        );
    }
}

/// The nominal model's position (and orientation) error against the data,
/// and the count of independent parameters a full calibration identifies.
fn write_nominal_error(out: &mut String, model: &RobotModel, data: &Measurements, full_pose: bool) {
    let u = &model.units;
    let robot = &model.robot;
    let e = nominal_error(model, data);
    let mm = |x: f64| x * 1e3;
    let _ = writeln!(out, "\nnominal model against the data");
    let _ = writeln!(
        out,
        "        position error  rms {} {len}  mean {} {len}  max {} {len} (line {}{})   = rms {:.3} mm, max {:.3} mm",
        fmt_num(u.length_from_si(e.position_rms)),
        fmt_num(u.length_from_si(e.position_mean)),
        fmt_num(u.length_from_si(e.position_max)),
        e.position_max_line,
        if e.sessions.is_empty() {
            String::new()
        } else {
            format!(" of {}", data.file_of(e.position_max_pose))
        },
        mm(e.position_rms),
        mm(e.position_max),
        len = u.length,
    );
    for (k, rms) in e.sessions.iter().enumerate() {
        let _ = writeln!(
            out,
            "        session {} {}: rms {} {}{}",
            k + 1,
            data.sessions.get(k).map_or("?", String::as_str),
            fmt_num(u.length_from_si(*rms)),
            u.length,
            if k == 0 {
                " (the model's base and tool)"
            } else {
                " (its own base and tool, registered to its rows)"
            }
        );
    }
    if let Some((rms, mean, max)) = e.orientation {
        let _ = writeln!(
            out,
            "        orientation error  rms {:.4}°  mean {:.4}°  max {:.4}°",
            rms.to_degrees(),
            mean.to_degrees(),
            max.to_degrees()
        );
    }
    let unknowns = independent_parameter_count(robot, full_pose);
    let _ = writeln!(
        out,
        "        a full geometric calibration identifies {unknowns} independent parameters (4R + 2P + {})",
        if full_pose { 6 } else { 3 }
    );
}

/// A number with up to 6 significant decimals, without trailing zeros.
fn fmt_num(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameter_count_follows_4r_2p_6() {
        let model = crate::io::model_file::load_model("puma560").unwrap();
        assert_eq!(independent_parameter_count(&model.robot, true), 30);
        assert_eq!(independent_parameter_count(&model.robot, false), 27);
        // TIAGo: one prismatic lift and seven revolute joints, positions only.
        let tiago = crate::io::model_file::load_model("figaroh-tiago-mocap").unwrap();
        assert_eq!(
            independent_parameter_count(&tiago.robot, false),
            4 * 7 + 2 + 3
        );
    }

    #[test]
    fn numbers_print_without_noise() {
        assert_eq!(fmt_num(1.234567), "1.234567");
        assert_eq!(fmt_num(26.0), "26");
        assert_eq!(fmt_num(-0.0000001), "0");
        assert_eq!(fmt_num(-2.25), "-2.25");
    }
}
