//! Universal Robots factory calibrations: the D-H deltas a UR controller
//! stores, read as the nominal model of that robot.
//!
//! ## Convention and units
//! UR's kinematics are standard D-H, `A_k = Rot_z(θ_k + q_k) Trans_z(d_k)
//! Trans_x(a_k) Rot_x(α_k)`, from the robot's base frame (z along axis 1) to
//! the flange; m and rad. The factory calibration (`calibration.conf` on the
//! controller, read by the ROS driver's `ur_calibration`) is four lists of six
//! values, `delta_theta`, `delta_a`, `delta_d`, `delta_alpha`, added to the
//! nominal D-H of the type (`--model ur10`, `ur10e`, `ur5e`, or a TOML model
//! named `ur` and a digit with `convention = "dh"` and six revolute joints).
//!
//! ## File
//! YAML: the four keys at the top level, or in a `kinematics:` mapping (as
//! the ROS driver's `calibration_correction` test writes them). Other keys are
//! ignored. Refused, with the file, line and column: YAML syntax, a missing
//! key, a value that is not a list of six, an element that is not a finite
//! number.
//!
//! ## Method: joint frames, then the URDF converter
//! Nearly parallel axes (2, 3, 4 of every UR) put the D-H common normals far
//! away: real calibrations hold `delta_d` of ±446 m and `delta_theta` of 7 rad
//! that cancel between consecutive joints, leaving millimetres at the flange.
//! The model armcal identifies must not carry them. So the nominal + delta
//! D-H is composed once, at zero readings, into the joint frames of a chain
//! (joint `k` at `A_{k−1}(0)` in the previous link, axis z; the flange a fixed
//! link at `A_6(0)`), exactly the form of a URDF chain, and
//! [`Urdf::convert`](crate::io::urdf::Urdf::convert) turns it into the
//! well-conditioned modified D-H with Hayati's tilt between the parallel axes
//! (`docs/urdf.md`). The conversion works from the axis lines, which the huge
//! `d` place to rounding (1e-16 of 446 m ≈ 1e-13 m), so the model's forward
//! kinematics equals the UR D-H's to 1e-12 m while its lengths are those of
//! the arm.
//!
//! Frames: the model's `base` is the nominal model's base composed with the
//! UR base frame (identity for the built-in models); its `tool` is the flange
//! composed with the nominal model's tool. Masses (centre of mass in D-H frame
//! `k`) are carried into the new link frames; limits and gravity are kept.
//!
//! ## Export (`armcal export --format ur-deltas | ur-calibration`)
//! [`export_deltas`]: the standard D-H of a calibrated model from its exact
//! joint-axis lines at zero readings (common normals; `d` as far as the
//! axes put it, as the controller holds it), minus the nominal of the UR
//! model given. UR's chain runs from its base frame (on axis 1) to its
//! flange (on axis 6); armcal's base (the robot in the measurement frame) and
//! tool (the measured frame, a TCP on a UR) are not in it, and are written
//! as comments. [`ur_calibration_yaml`]: the same chain as ur_description's
//! joint origins, link frames kept near the arm.

use armcal_shared::{Convention, Robot};
use armcal_shared::{Frame, JointType, Link, dh::link_transform};
use nalgebra::{Point3, Vector3};
use saphyr::{LoadableYamlNode, MarkedYaml, Scalar, YamlData};

use crate::io::input_error::{MODEL_FILE, read_text};
use crate::io::urdf::{
    ChainSpec, Inertial, JointKind, Pose, Urdf, UrdfJoint, UrdfLink,
    convert::{Converted, to_frame},
};
use crate::session::input_error::InputError;
use crate::session::model::RobotModel;

/// The number of joints of a UR arm.
pub const JOINTS: usize = 6;

/// The keys of a factory calibration, in the order of [`DhDeltas`]'s fields.
pub const KEYS: [&str; 4] = ["delta_theta", "delta_a", "delta_d", "delta_alpha"];

/// A UR factory calibration: what the controller adds to the nominal D-H, m and rad.
/// Where axes are nearly parallel `d` and `θ` are ill-conditioned: two sets far
/// apart can give the same chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DhDeltas {
    /// `delta_theta`, rad.
    pub theta: [f64; JOINTS],
    /// `delta_a`, m.
    pub a: [f64; JOINTS],
    /// `delta_d`, m.
    pub d: [f64; JOINTS],
    /// `delta_alpha`, rad.
    pub alpha: [f64; JOINTS],
}

/// The 1-based line and column where `node` starts.
fn place(node: &MarkedYaml<'_>) -> (usize, usize) {
    (node.span.start.line().max(1), node.span.start.col() + 1)
}

/// The string of a scalar node, if it is one.
fn as_str<'a>(node: &'a MarkedYaml<'_>) -> Option<&'a str> {
    match &node.data {
        YamlData::Value(Scalar::String(s)) => Some(s),
        YamlData::Representation(s, _, _) => Some(s),
        _ => None,
    }
}

/// The value of `key` in mapping `node`, if `node` is a mapping holding it.
fn get<'a, 'i>(node: &'a MarkedYaml<'i>, key: &str) -> Option<&'a MarkedYaml<'i>> {
    match &node.data {
        YamlData::Mapping(m) => m
            .iter()
            .find(|(k, _)| as_str(k) == Some(key))
            .map(|(_, v)| v),
        _ => None,
    }
}

/// The YAML documents of `text`, refused at the place of a syntax error;
/// `file` names it.
fn load_yaml<'i>(text: &'i str, file: &str) -> Result<Vec<MarkedYaml<'i>>, InputError> {
    MarkedYaml::load_from_str(text).map_err(|e| {
        let m = e.marker();
        InputError::new(
            file,
            m.line().max(1),
            m.col() + 1,
            format!("YAML syntax: {}", e.info()),
        )
    })
}

/// Parses a factory calibration (see the module header); `file` names it in errors.
pub fn parse_deltas(text: &str, file: &str) -> Result<DhDeltas, InputError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let docs = load_yaml(text, file)?;
    let Some(doc) = docs.first() else {
        return Err(InputError::new(
            file,
            1,
            1,
            format!("empty file: expected {}", KEYS.join(", ")),
        ));
    };
    let table = get(doc, "kinematics")
        .filter(|k| matches!(k.data, YamlData::Mapping(_)))
        .unwrap_or(doc);
    if !matches!(table.data, YamlData::Mapping(_)) {
        let (l, c) = place(table);
        return Err(InputError::new(
            file,
            l,
            c,
            format!("expected a mapping with keys {}", KEYS.join(", ")),
        ));
    }
    let mut out = [[0.0; JOINTS]; 4];
    for (key, values) in KEYS.iter().zip(out.iter_mut()) {
        let Some(node) = get(table, key) else {
            let (l, c) = place(table);
            return Err(InputError::new(
                file,
                l,
                c,
                if get(table, UR_DESCRIPTION_JOINTS[0]).is_some() {
                    format!(
                        "missing key '{key}': this looks like ur_calibration's URDF correction \
                         (joint origins for ur_description), not the controller's D-H deltas \
                         ({})",
                        KEYS.join(", ")
                    )
                } else {
                    format!(
                        "missing key '{key}' (a factory calibration has {})",
                        KEYS.join(", ")
                    )
                },
            ));
        };
        let (l, c) = place(node);
        let YamlData::Sequence(items) = &node.data else {
            return Err(InputError::new(
                file,
                l,
                c,
                format!("'{key}': expected a list of {JOINTS} numbers"),
            ));
        };
        if items.len() != JOINTS {
            return Err(InputError::new(
                file,
                l,
                c,
                format!(
                    "'{key}': {} values, expected {JOINTS} (joints 1 to {JOINTS})",
                    items.len()
                ),
            ));
        }
        for (i, (item, v)) in items.iter().zip(values.iter_mut()).enumerate() {
            let x = match &item.data {
                YamlData::Value(Scalar::FloatingPoint(f)) => Some(f.into_inner()),
                YamlData::Value(Scalar::Integer(n)) => Some(*n as f64),
                _ => None,
            };
            match x.filter(|x| x.is_finite()) {
                Some(x) => *v = x,
                None => {
                    let (l, c) = place(item);
                    return Err(InputError::new(
                        file,
                        l,
                        c,
                        format!("'{key}' joint {}: not a finite number", i + 1),
                    ));
                }
            }
        }
    }
    let [theta, a, d, alpha] = out;
    Ok(DhDeltas { theta, a, d, alpha })
}

/// Whether `model` is a Universal Robots arm: named for one (`ur` and a digit
/// in its name: `ur10`, `ur5e`, `my-ur10e`) and of UR's form (standard D-H,
/// six revolute joints, no tilt).
pub fn is_ur_model(model: &RobotModel) -> bool {
    let name = model.name.to_ascii_lowercase();
    let named = name
        .match_indices("ur")
        .any(|(i, _)| name[i + 2..].starts_with(|c: char| c.is_ascii_digit()));
    let robot = &model.robot;
    named
        && robot.convention == Convention::Dh
        && robot.dof() == JOINTS
        && robot
            .links
            .iter()
            .all(|l| l.joint == JointType::Revolute && l.beta == 0.0)
}

/// The nominal links of `robot` (of UR's form) with `deltas` added.
pub fn calibrated_dh(robot: &Robot<f64>, deltas: &DhDeltas) -> Vec<Link<f64>> {
    robot
        .links
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let mut l = *l;
            l.theta += deltas.theta[k];
            l.a += deltas.a[k];
            l.s += deltas.d[k];
            l.alpha += deltas.alpha[k];
            l
        })
        .collect()
}

/// A standard D-H chain (base frame to flange) as the joint frames of a URDF
/// chain at zero readings, converted by the URDF converter. `file` names the
/// chain in its errors.
pub fn convert_dh(links: &[Link<f64>], file: &str) -> Result<Converted, InputError> {
    let n = links.len();
    let at_zero: Vec<Pose> = links
        .iter()
        .map(|l| link_transform(Convention::Dh, l, 0.0))
        .collect();
    let mut urdf_links = vec![UrdfLink {
        name: "base".into(),
        offset: 0,
        inertial: None,
    }];
    let mut joints = Vec::with_capacity(n + 1);
    for (k, l) in links.iter().enumerate() {
        urdf_links.push(UrdfLink {
            name: format!("link{}", k + 1),
            offset: 0,
            // D-H frame k is A_k(0) in the child link of joint k.
            inertial: l.mass.map(|m| Inertial {
                mass: m.mass,
                com: (at_zero[k] * Point3::from(m.com)).coords,
            }),
        });
        joints.push(UrdfJoint {
            name: format!("joint{}", k + 1),
            kind: if l.limits.is_some() {
                JointKind::Revolute
            } else {
                JointKind::Continuous
            },
            offset: 0,
            parent: k,
            child: k + 1,
            origin: if k == 0 {
                Pose::identity()
            } else {
                at_zero[k - 1]
            },
            origin_range: None,
            body_start: 0,
            axis: Vector3::z(),
            limits: l.limits,
            mimic: None,
        });
    }
    urdf_links.push(UrdfLink {
        name: "flange".into(),
        offset: 0,
        inertial: None,
    });
    joints.push(UrdfJoint {
        name: "flange".into(),
        kind: JointKind::Fixed,
        offset: 0,
        parent: n,
        child: n + 1,
        origin: at_zero[n - 1],
        origin_range: None,
        body_start: 0,
        axis: Vector3::z(),
        limits: None,
        mimic: None,
    });
    let urdf = Urdf {
        file: file.into(),
        text: String::new(),
        name: "ur".into(),
        links: urdf_links,
        parent_joint: (0..n + 2)
            .map(|l| l.checked_sub(1))
            .collect::<Vec<Option<usize>>>(),
        joints,
        root: 0,
        robot_end: 0,
    };
    urdf.convert(&ChainSpec::default())
}

/// The model of the robot whose nominal model is `model` (of UR's form) and
/// whose factory calibration is `deltas` (see the module header). `file`
/// names the calibration.
pub fn import(model: &RobotModel, deltas: &DhDeltas, file: &str) -> Result<RobotModel, InputError> {
    let nominal = &model.robot;
    let converted = convert_dh(&calibrated_dh(nominal, deltas), file)?;
    let mut robot = converted.robot;
    robot.base = to_frame(&(nominal.base.isometry() * robot.base.isometry()));
    robot.tool = to_frame(&(robot.tool.isometry() * nominal.tool.isometry()));
    robot.gravity = nominal.gravity;
    let tilted: Vec<usize> = (0..JOINTS).filter(|&k| converted.hayati[k]).collect();
    let joints: Vec<String> = tilted.iter().map(|k| (k + 1).to_string()).collect();
    Ok(RobotModel {
        name: model.name.clone(),
        description: format!(
            "{} with the factory calibration {file}, modified D-H with Hayati's tilt on joint(s) {}",
            model.name,
            joints.join(", ")
        ),
        source: format!("{} + {file}", model.source),
        units: model.units,
        robot,
        prior: model.prior,
        tilted,
        // The flange link of the chain, before the nominal model's tool.
        flange: converted.flange,
    })
}

/// `model` (of UR's form, else refused as an error of `--factory-calibration`)
/// with the factory calibration in file `path`.
pub fn load_factory(model: &RobotModel, path: &str) -> Result<RobotModel, InputError> {
    if !is_ur_model(model) {
        return Err(InputError::argument(
            "--factory-calibration",
            format!(
                "applies to a Universal Robots model only (named `ur` and a digit, standard D-H, \
                 six revolute joints: ur5e, ur10, ur10e); {} ({}) is not one",
                model.name, model.source
            ),
        ));
    }
    let text = read_text(path, MODEL_FILE)?;
    let deltas = parse_deltas(&text, path)?;
    import(model, &deltas, path)
}

/// A calibrated model in UR's form: the factory calibration against a
/// nominal, and what the D-H chain does not hold.
#[derive(Clone, Debug, PartialEq)]
pub struct UrExport {
    /// The D-H of the calibrated chain minus the nominal's, m and rad.
    pub deltas: DhDeltas,
    /// The UR base frame (z along axis 1) in the calibration's measurement
    /// frame: where the robot stands, for the user, not the controller.
    pub base: Pose,
    /// The measured frame (the calibrated tool) in the UR flange frame: the
    /// TCP on a UR, set apart from the kinematics.
    pub tcp: Pose,
    /// The UR base frame in the model's frame 0.
    pub ur_base: Pose,
    /// The UR flange (D-H frame 6 at zero readings) in the model's frame 0.
    pub flange: Pose,
    /// ur_description's link frames at zero readings, in the model's frame 0:
    /// link `k` on the model's axis `k` where [`joint_frames`] puts it (near
    /// the arm, not at the far D-H foot), x along D-H's common normal `x_k`
    /// as ur_description's nominal frames have it.
    pub links: Vec<Pose>,
}

/// `x − nominal` wrapped into `(−π, π]`.
fn angle_delta(x: f64, nominal: f64) -> f64 {
    let d = (x - nominal).rem_euclid(std::f64::consts::TAU);
    if d > std::f64::consts::PI {
        d - std::f64::consts::TAU
    } else {
        d
    }
}

/// The standard D-H of `robot` (any convention, six revolute joints), as
/// deltas against the UR nominal `nominal` (see [`UrExport`]).
///
/// From the joint-axis lines at zero readings, in the frame of the model's
/// base: the UR base frame is on axis 1 (origin at the foot of the
/// perpendicular from the model's frame 0, x its x made perpendicular); frame
/// `k` (1 ≤ k < 6) is on the common normal of axes `k` and `k+1`, with x
/// along it in the sense that keeps `θ_k` nearest the nominal's (so `a_k`
/// keeps the nominal's sign), and `α_k` turns z onto axis `k+1`. Where two
/// axes are parallel to rounding (`sin γ < 1e-15`) the foot is undefined and
/// `d_k` is 0; otherwise it is the exact foot, however far (hundreds of m for
/// nearly parallel axes, as on the controller). Each frame is composed from
/// the parameters just found before the next axis is expressed in it, so the
/// chain of the written numbers ends on the calibrated axis 6 to rounding.
/// Frame 6 (the flange) is on axis 6 (`a_6 = α_6 = 0` as on every UR): origin
/// at the foot of the perpendicular from the origin of `arm`'s tool, x that
/// tool's x made perpendicular. `arm` is the calibrated chain with its tool
/// at the robot's flange ([`crate::apply::working_tool`]: the measured tool's
/// offset left out), `measured` the same chain with the measured (or working)
/// tool, whose frame in the flange is [`UrExport::tcp`]: the measured point's
/// offset goes to the TCP, never into the arm's links.
pub fn export_deltas(arm: &Robot<f64>, measured: &Robot<f64>, nominal: &Robot<f64>) -> UrExport {
    let base = arm.base.isometry();
    let (joints, tip) = joint_frames(arm);
    let (_, measured) = joint_frames(measured);
    let lines = axis_lines(&Pose::identity(), &joints);
    let ur_base = ur_base_frame(lines[0]);
    let mut at = ur_base;
    let mut out = [[0.0; JOINTS]; 4];
    let mut links = Vec::with_capacity(JOINTS);
    for k in 0..JOINTS {
        let nom = &nominal.links[k];
        let inv = at.inverse();
        let (theta, d, a, alpha) = if k + 1 < JOINTS {
            let p = inv * lines[k + 1].0;
            let u = inv.rotation * lines[k + 1].1;
            let sin_gamma = u.x.hypot(u.y);
            let (t, normal) = if sin_gamma >= 1e-15 {
                let b = u.z;
                let t = (p.z - b * u.dot(&p.coords)) / (1.0 - b * b);
                (t, Vector3::new(-u.y, u.x, 0.0) / sin_gamma)
            } else {
                let r = Vector3::new(p.x, p.y, 0.0);
                let n = if r.norm() > 1e-14 {
                    r.normalize()
                } else {
                    Vector3::x()
                };
                (0.0, n)
            };
            // Choose the sense of x that keeps θ nearest the nominal.
            let th = normal.y.atan2(normal.x);
            let (theta, x) = if angle_delta(th, nom.theta).abs() <= std::f64::consts::FRAC_PI_2 {
                (th, normal)
            } else {
                (angle_delta(th + std::f64::consts::PI, 0.0), -normal)
            };
            // The axis crosses the common normal at x = a.
            let rel = p.coords - Vector3::new(0.0, 0.0, t);
            let a = rel.dot(&x);
            let y = Vector3::z().cross(&x);
            let alpha = (-u.dot(&y)).atan2(u.z);
            (theta, t, a, alpha)
        } else {
            let m = inv * tip;
            let x = m.rotation * Vector3::x();
            let x = if x.x.hypot(x.y) > 1e-6 {
                x
            } else {
                m.rotation * Vector3::y()
            };
            (x.y.atan2(x.x), m.translation.vector.z, 0.0, 0.0)
        };
        // ur_description's link frame k: on the model's axis k, turned about
        // it as D-H's `frame_{k−1} Rot_z(θ_k)` (x along the common normal).
        let turned = at.rotation * nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), theta);
        links.push(Pose::from_parts(joints[k].translation, turned));
        let link = Link::new(JointType::Revolute, theta, d, a, alpha);
        at *= link_transform(Convention::Dh, &link, 0.0);
        out[0][k] = angle_delta(theta, nom.theta);
        out[1][k] = a - nom.a;
        out[2][k] = d - nom.s;
        out[3][k] = angle_delta(alpha, nom.alpha);
    }
    let [theta, a, d, alpha] = out;
    UrExport {
        deltas: DhDeltas { theta, a, d, alpha },
        base: base * ur_base,
        tcp: at.inverse() * measured,
        ur_base,
        flange: at,
        links,
    }
}

/// The axis line (a point, the direction) of each joint frame of `joints`
/// (z along the axis), in the frame `base` puts them in.
fn axis_lines(base: &Pose, joints: &[Pose]) -> Vec<(Point3<f64>, Vector3<f64>)> {
    joints
        .iter()
        .map(|f| {
            let f = base * f;
            (
                Point3::from(f.translation.vector),
                f.rotation * Vector3::z(),
            )
        })
        .collect()
}

/// The UR base frame on axis 1, `(p0, z0)`: its origin at the foot of the
/// perpendicular from the origin, z along the axis, x the frame's x made
/// perpendicular (its y, where x is along the axis).
fn ur_base_frame((p0, z0): (Point3<f64>, Vector3<f64>)) -> Pose {
    let foot = p0 - z0 * p0.coords.dot(&z0);
    let mut x0 = Vector3::x() - z0 * z0.x;
    if x0.norm() < 1e-6 {
        x0 = Vector3::y() - z0 * z0.y;
    }
    let x0 = x0.normalize();
    Pose::from_parts(
        nalgebra::Translation3::from(foot.coords),
        nalgebra::Rotation3::from_basis_unchecked(&[x0, z0.cross(&x0), z0]),
    )
}

/// For each joint of `robot` (of six), a frame on its axis with z along it
/// that moves as `J_k · Rot_z(q_k)`, at zero readings, in the model's frame 0
/// (after its base); and the measured frame there.
pub fn joint_frames(robot: &Robot<f64>) -> (Vec<Pose>, Pose) {
    let mut joints = Vec::with_capacity(JOINTS);
    let mut f = Pose::identity();
    for l in &robot.links {
        if robot.convention == Convention::Dh {
            // A_k(q) = Rot_z(q) A_k(0): frame k−1 turns about its z.
            joints.push(f);
        }
        f *= match robot.convention {
            // Rot_z(θ) Trans_z(s) Trans_x(a) Rot_x(α) Rot_y(β)
            Convention::Dh => {
                link_transform(Convention::Dh, l, 0.0)
                    * nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), l.beta)
            }
            // … Rot_z(θ + q) Trans_z(s) = (… Rot_z(θ) Trans_z(s)) Rot_z(q).
            Convention::Mdh => crate::io::urdf::convert::link_at_zero(l),
        };
        if robot.convention != Convention::Dh {
            joints.push(f);
        }
    }
    (joints, f * robot.tool.isometry())
}

/// The flange in the UR base frame at joint readings `q`, as the controller
/// computes it from the nominal D-H of its type and the factory calibration
/// `deltas`: `Π Rot_z(θ_k + δθ_k + q_k) Trans_z(d_k + δd_k) Trans_x(a_k + δa_k)
/// Rot_x(α_k + δα_k)`, written out here apart from armcal's own kinematics.
pub fn dh_flange(nominal: &Robot<f64>, deltas: &DhDeltas, q: &[f64; JOINTS]) -> Pose {
    let mut t = Pose::identity();
    for (k, l) in nominal.links.iter().enumerate().take(JOINTS) {
        let theta = l.theta + deltas.theta[k] + q[k];
        let (d, a, alpha) = (
            l.s + deltas.d[k],
            l.a + deltas.a[k],
            l.alpha + deltas.alpha[k],
        );
        let (st, ct) = theta.sin_cos();
        let (sa, ca) = alpha.sin_cos();
        let m = nalgebra::Matrix3::new(ct, -st * ca, st * sa, st, ct * ca, -ct * sa, 0.0, sa, ca);
        let link = Pose::from_parts(
            nalgebra::Translation3::new(a * ct, a * st, d),
            nalgebra::Rotation3::from_matrix_unchecked(m),
        );
        t *= link;
    }
    t
}

/// The flange (`wrist_3_link`) in `base_link_inertia` at joint readings `q`,
/// as ur_description composes `ur_calibration`'s joint origins:
/// `origin_1 Rot_z(q_1) ⋯ origin_6 Rot_z(q_6)`.
pub fn description_flange(origins: &[Pose; JOINTS], q: &[f64; JOINTS]) -> Pose {
    origins.iter().zip(q).fold(Pose::identity(), |t, (o, &qk)| {
        t * o * nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), qk)
    })
}

/// Parses `ur_calibration`'s URDF-correction YAML (per joint of
/// [`UR_DESCRIPTION_JOINTS`] `x, y, z, roll, pitch, yaw`, m and rad, under
/// `kinematics:`) into the joint origins, as ur_description reads them
/// (`Trans(xyz) Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`); `file` names it in errors.
pub fn parse_ur_description(text: &str, file: &str) -> Result<[Pose; JOINTS], InputError> {
    let docs = load_yaml(text, file)?;
    let refuse = |node: &MarkedYaml<'_>, why: String| {
        let (l, c) = place(node);
        InputError::new(file, l, c, why)
    };
    let Some(doc) = docs.first() else {
        return Err(InputError::new(
            file,
            1,
            1,
            "empty file: expected `kinematics:`",
        ));
    };
    let table = get(doc, "kinematics").unwrap_or(doc);
    let mut origins = [Pose::identity(); JOINTS];
    for (name, origin) in UR_DESCRIPTION_JOINTS.iter().zip(origins.iter_mut()) {
        let joint =
            get(table, name).ok_or_else(|| refuse(table, format!("missing joint '{name}'")))?;
        let mut v = [0.0; 6];
        for (key, x) in ["x", "y", "z", "roll", "pitch", "yaw"]
            .iter()
            .zip(v.iter_mut())
        {
            let node = get(joint, key)
                .ok_or_else(|| refuse(joint, format!("'{name}': missing '{key}'")))?;
            *x = match &node.data {
                YamlData::Value(Scalar::FloatingPoint(f)) => f.into_inner(),
                YamlData::Value(Scalar::Integer(n)) => *n as f64,
                _ => return Err(refuse(node, format!("'{name}.{key}': not a number"))),
            };
        }
        *origin = Frame {
            xyz: Vector3::new(v[0], v[1], v[2]),
            rpy: Vector3::new(v[3], v[4], v[5]),
        }
        .isometry();
    }
    Ok(origins)
}

/// The joints of ur_description, in order, as `ur_calibration` names them.
pub const UR_DESCRIPTION_JOINTS: [&str; JOINTS] = [
    "shoulder",
    "upper_arm",
    "forearm",
    "wrist_1",
    "wrist_2",
    "wrist_3",
];

/// The joint origins of ur_description for the calibrated chain of `export`:
/// joint `k`'s frame in joint `k−1`'s (the first in the UR base frame, which
/// is ur_description's `base_link_inertia`), so that `origin_1 Rot_z(q_1) ⋯
/// origin_6 Rot_z(q_6)` is the flange (`wrist_3_link`). Links 1 to 5 are
/// [`UrExport::links`] (no far common normals; the nominal gives
/// ur_description's default kinematics); link 6 is the UR flange.
pub fn ur_description_origins(export: &UrExport) -> [Pose; JOINTS] {
    let mut prev = export.ur_base;
    std::array::from_fn(|k| {
        let j = if k + 1 < JOINTS {
            export.links[k]
        } else {
            export.flange
        };
        let origin = prev.inverse() * j;
        prev = j;
        origin
    })
}

/// The `ur_calibration` URDF-correction YAML (`kinematics:` with x, y, z,
/// roll, pitch, yaw per joint, m and rad) of `export`.
pub fn ur_calibration_yaml(export: &UrExport, label: &str) -> String {
    let mut s = format!(
        "# ur_description kinematics (joint origins, m and rad) written by armcal from {label}\n\
         # UR base frame (base_link_inertia) in the measurement frame: {}\n\
         # measured frame (TCP) in the flange (wrist_3_link): {}\n\
         kinematics:\n",
        pose_text(&export.base),
        pose_text(&export.tcp)
    );
    for (name, origin) in UR_DESCRIPTION_JOINTS
        .iter()
        .zip(ur_description_origins(export))
    {
        let f = to_frame(&origin);
        s += &format!(
            "  {name}:\n    x: {:?}\n    y: {:?}\n    z: {:?}\n    roll: {:?}\n    pitch: {:?}\n    yaw: {:?}\n",
            f.xyz.x, f.xyz.y, f.xyz.z, f.rpy.x, f.rpy.y, f.rpy.z
        );
    }
    s + "  hash: calib_armcal\n"
}

/// `p` as `xyz [..] m, rpy [..] rad`.
fn pose_text(p: &Pose) -> String {
    let f = to_frame(p);
    format!(
        "xyz [{:?}, {:?}, {:?}] m, rpy [{:?}, {:?}, {:?}] rad",
        f.xyz.x, f.xyz.y, f.xyz.z, f.rpy.x, f.rpy.y, f.rpy.z
    )
}

/// `export` as the factory-calibration YAML (`kinematics:` with the four
/// lists, numbers in Rust's shortest round-trip form), the base and TCP as
/// comments.
pub fn deltas_yaml(export: &UrExport, label: &str) -> String {
    let list = |v: &[f64; JOINTS]| {
        let items: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
        format!("[{}]", items.join(", "))
    };
    let d = &export.deltas;
    format!(
        "# UR factory calibration (D-H deltas, m and rad) written by armcal from {label}\n\
         # UR base frame in the measurement frame: {}\n\
         # measured frame (TCP) in the flange: {}\n\
         kinematics:\n  delta_theta: {}\n  delta_a: {}\n  delta_d: {}\n  delta_alpha: {}\n",
        pose_text(&export.base),
        pose_text(&export.tcp),
        list(&d.theta),
        list(&d.a),
        list(&d.d),
        list(&d.alpha)
    )
}

/// How far a D-H length of a calibration's nominal model may be from the UR
/// type's and still be that nominal, m: far below any real calibration delta
/// (tens of µm and more: above a tracker's noise) and far above the rounding
/// of a unit conversion (1e-16 of the value) or of π/2 written to seven
/// digits (3e-7).
pub const SAME_LENGTH: f64 = 1e-6;

/// The same for a D-H angle, rad.
pub const SAME_ANGLE: f64 = 1e-6;

/// How far a joint axis of a calibration's nominal may pass from the UR
/// type's joint origin when that nominal is not in UR's form (a UR model
/// read with `--factory-calibration`, converted to modified D-H with
/// tilts), m: a factory calibration moves an axis by a few mm (the three
/// real sets of `data/ur`, on the UR10 or the UR10e: 4.3 mm at most, at
/// axis 6), while two UR types differ by more (the UR10's and the UR10e's shoulder
/// height `d1` by 53 mm; the UR5e's and the UR10e's `a2` by 188 mm).
pub const FACTORY_LENGTH: f64 = 0.02;

/// The angle a joint axis may turn from the type's, rad: a factory
/// calibration turns one by tens of mrad (the real sets: 20.5 mrad at most,
/// axis 4 of set 1, its twists `α2 + α3`); another arm's axes are at right
/// angles to UR's.
pub const FACTORY_ANGLE: f64 = 0.05;

/// Refuses (as an error of `--calibration` and `--model`) a calibration whose
/// nominal model `ours` is not the nominal of the UR type `model`: in UR's
/// form (standard D-H, six revolute joints), every `θ`, `d`, `a`, `α` within
/// [`SAME_LENGTH`] and [`SAME_ANGLE`]; otherwise (a model read with a factory
/// calibration) every joint axis at zero readings within [`FACTORY_LENGTH`]
/// of the type's joint origin and [`FACTORY_ANGLE`] of its direction. The
/// deltas written against `model` would otherwise turn one robot into
/// another. `calibration` names the file in the message; base and tool are
/// not compared (UR's chain holds neither).
pub fn require_same_type(
    ours: &Robot<f64>,
    model: &RobotModel,
    calibration: &str,
) -> Result<(), InputError> {
    let theirs = &model.robot;
    let refuse = |what: String| {
        InputError::argument(
            "--calibration",
            format!(
                "{calibration} is not a calibration of the --model {}: {what}; export it with \
                 the UR model it was identified with",
                model.name
            ),
        )
    };
    if ours.dof() != JOINTS {
        return Err(refuse(format!(
            "its nominal has {} joints, a UR {JOINTS}",
            ours.dof()
        )));
    }
    let ur_form = ours.convention == Convention::Dh
        && ours
            .links
            .iter()
            .all(|l| l.joint == JointType::Revolute && l.beta == 0.0);
    if ur_form {
        let mut differ = Vec::new();
        for (k, (a, b)) in ours.links.iter().zip(&theirs.links).enumerate() {
            let params = [
                ("theta", a.theta, b.theta, SAME_ANGLE, "rad"),
                ("d", a.s, b.s, SAME_LENGTH, "m"),
                ("a", a.a, b.a, SAME_LENGTH, "m"),
                ("alpha", a.alpha, b.alpha, SAME_ANGLE, "rad"),
            ];
            for (name, x, y, _, unit) in params
                .into_iter()
                .filter(|(_, x, y, tol, _)| (x - y).abs() > *tol)
            {
                differ.push(format!(
                    "{name}{} is {x:.6} {unit} in the calibration's nominal, {y:.6} {unit} in {}'s",
                    k + 1,
                    model.name
                ));
            }
        }
        if differ.is_empty() {
            return Ok(());
        }
        return Err(refuse(differ.join(", ")));
    }
    // Not in UR's form: each joint axis at zero readings, in the UR base
    // frame each model puts on its axis 1 (origin at the foot of the
    // perpendicular from its measurement frame's origin, x that frame's x
    // made perpendicular). Its D-H would not do: between nearly parallel
    // axes the common normals lie far away, where `d`, `a` and `θ` are
    // ill-conditioned; the axes near the arm are not.
    let axes = |robot: &Robot<f64>| {
        let lines = axis_lines(&robot.base.isometry(), &joint_frames(robot).0);
        let to_ur = ur_base_frame(lines[0]).inverse();
        lines
            .into_iter()
            .map(|(p, z)| (to_ur * p, to_ur * z))
            .collect::<Vec<_>>()
    };
    let (ours, theirs) = (axes(ours), axes(theirs));
    // The first joint whose axis is off, how far and how much turned.
    let first_off = |ours: &[(Point3<f64>, Vector3<f64>)]| {
        ours.iter()
            .zip(&theirs)
            .enumerate()
            .map(|(k, ((p, z), (q, w)))| (k, (q - p).cross(z).norm(), z.angle(w)))
            .find(|&(_, off, turn)| off > FACTORY_LENGTH || turn > FACTORY_ANGLE)
    };
    let Some((k, off, turn)) = first_off(&ours) else {
        return Ok(());
    };
    // A chain read from another base link than UR's base frame (a URDF's
    // `world` or `base_link`: turned about axis 1 from `base_link_inertia`,
    // or raised along it) has every axis where the type has it once moved
    // along and turned about axis 1 (axis 2 is across axis 1 on every UR:
    // its direction gives the turn, its height the shift). Only a turn
    // beyond what a factory calibration makes tells that apart from another
    // type (the UR10's and UR10e's shoulders differ by a shift alone).
    let ((p2, z2), (q2, w2)) = (ours[1], theirs[1]);
    let about = w2.y.atan2(w2.x) - z2.y.atan2(z2.x);
    let turned = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), about);
    let along = q2.z - (turned * p2).z;
    let realigned: Vec<_> = ours
        .iter()
        .map(|(p, z)| (turned * p + Vector3::z() * along, turned * z))
        .collect();
    if angle_delta(about, 0.0).abs() > FACTORY_ANGLE && first_off(&realigned).is_none() {
        return Err(refuse(format!(
            "its chain starts {along:.4} m along axis 1 from UR's base frame and turned \
             {:.4} rad about it (joint {}'s axis is {off:.4} m from {}'s joint origin): a \
             URDF chain must start at UR's base frame, ur_description's `base_link_inertia`: \
             identify with `--base-link base_link_inertia`",
            angle_delta(about, 0.0),
            k + 1,
            model.name,
        )));
    }
    Err(refuse(format!(
        "its nominal (not in UR's D-H form: a URDF or a factory-calibrated model) has joint \
         {}'s axis {off:.4} m from {}'s joint origin and turned {turn:.4} rad from its axis (a \
         factory calibration moves an axis by a few mm and tens of mrad at most)",
        k + 1,
        model.name,
    )))
}
