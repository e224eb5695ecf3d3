//! `armcal export --format urdf`: a calibration as a URDF, for
//! `robot_state_publisher`, MoveIt and anything else that reads one.
//!
//! ## From the URDF the model was read from
//! The file is kept as it is (links, inertials, visuals, comments, every other
//! element and joint) except the `<origin>` of each moving joint of the chain,
//! which is rewritten (or added) so that the URDF's forward kinematics is the
//! calibrated model's. With MDH frame `k` at the constant pose `D_k` in the
//! child link of joint `k` ([`Converted::dh_in_link`]; `D_0` is the model's
//! nominal `base` in the base link), `F_k` the fixed joints kept between the
//! previous moving joint and joint `k`, and `A'_k(0)` the calibrated link
//! transform at zero reading, joint `k`'s new origin is
//! `F_k⁻¹ · D_{k−1} · A'_k(0) · D_k⁻¹`. Its `<axis>` stays: `D_k` keeps the
//! axis where it was in the child link, and `D_k⁻¹ Rot_z(q) D_k` is the URDF
//! rotation about it.
//!
//! ## Generated
//! From a calibration of any model: links `base_link`, `link1` … `linkM`,
//! joints `joint1` … `jointM` with axis z. Writing `A_k(q) = P_k · Z(q) · N_k`
//! (`Z` the joint's rotation about or travel along z; standard D-H: `P_k = I`,
//! `N_k = Rot_z(θ) Trans_z(s) Trans_x(a) Rot_x(α) Rot_y(β)`; modified D-H:
//! `P_k = Rot_x(α) Trans_x(a) Rot_y(β) Rot_z(θ) Trans_z(s)`, `N_k = I`), joint
//! `k`'s origin is `N_{k−1} · P_k` (`D_0 · P_1` for the first, `D_0` the nominal
//! base). Limits are written with `effort="0" velocity="0"` (unknown to armcal);
//! a revolute joint without limits is `continuous`. A link with mass properties
//! gets an `<inertial>` with its mass and centre of mass and a zero inertia
//! tensor (unknown to armcal).
//!
//! ## Base and measured point
//! Two links are added (names made unique with `_2`, `_3` … if taken):
//! - `armcal_measured_point`, fixed to the tip link (generated: to `linkM`) at
//!   the calibrated measured frame: `(D_M⁻¹ · tip)⁻¹ · tool'`. The tip link keeps
//!   its nominal place on the last axis; what the tool parameters identified
//!   (the measured point, which the data cannot tell from the flange) is here.
//! - `armcal_measurement_frame`, fixed to the base link at the measurement frame
//!   of the calibration: `D_0 · base'⁻¹`. The base link stays the robot's own
//!   base; the identified base (the robot in the measurement frame) is here.
//!
//! So the pose of `armcal_measured_point` in `armcal_measurement_frame` is what
//! `armcal predict` gives, and the arm's joint origins are the calibrated ones.
//!
//! Numbers are written with Rust's shortest round-trip decimal (`{}`): every
//! `f64` reads back exactly. Lengths in m, angles in rad.
//!
//! Not in a URDF: the non-geometric effects of `armcal diagnose` (compliance,
//! backlash, thermal expansion, ...). Only the geometry of the calibration
//! given is written; the caller gives the geometry refitted without the
//! effects when the calibration has one, and says what is left out
//! ([`crate::apply::export`]).

use core::fmt::Write as _;

use armcal_shared::calibration::model_hash;
use armcal_shared::{Calibration, Convention, JointType, Link, Robot};
use nalgebra::{Rotation3, Translation3, Vector3};

use super::convert::{Converted, link_at_zero, pre_joint};
use super::{Pose, Urdf, rpy};
use crate::session::input_error::InputError;

/// The link added at the calibrated measured frame.
pub const MEASURED_POINT: &str = "armcal_measured_point";
/// The link added at the calibration's measurement frame.
pub const MEASUREMENT_FRAME: &str = "armcal_measurement_frame";

/// An exported URDF and what it had to leave out.
#[derive(Clone, Debug)]
pub struct Exported {
    /// The URDF text.
    pub text: String,
    /// What could not be expressed, for standard error.
    pub warnings: Vec<String>,
    /// The chain's base link, the names given to the link added at the
    /// measured point and to the one at the measurement frame: where a
    /// reader of the file finds the calibration.
    pub links: ExportedLinks,
}

/// The links of an exported URDF that hold the calibration.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportedLinks {
    /// The robot's base link.
    pub base: String,
    /// The link at the calibrated measured point ([`MEASURED_POINT`] or a
    /// unique variant).
    pub measured_point: String,
    /// The link at the measurement frame ([`MEASUREMENT_FRAME`] or a unique
    /// variant), fixed to the base link.
    pub measurement_frame: String,
}

/// `<origin xyz=".." rpy=".."/>` of `pose`, every number exact.
fn origin(pose: &Pose) -> String {
    let t = pose.translation.vector;
    let [r, p, y] = rpy(&pose.rotation);
    format!(
        "<origin xyz=\"{} {} {}\" rpy=\"{r} {p} {y}\"/>",
        t.x, t.y, t.z
    )
}

/// `name`, or `name_2`, `name_3` … whichever `taken` does not hold.
fn unique(name: &str, taken: &dyn Fn(&str) -> bool) -> String {
    if !taken(name) {
        return name.to_owned();
    }
    (2..)
        .map(|i| format!("{name}_{i}"))
        .find(|n| !taken(n))
        .unwrap_or_default()
}

/// The two added links and their fixed joints, indented for inside `<robot>`.
fn added_links(
    tip: &str,
    point: &Pose,
    base: &str,
    frame: &Pose,
    taken: &dyn Fn(&str) -> bool,
) -> (String, ExportedLinks) {
    let mut out = String::new();
    let mut names = Vec::new();
    for (name, parent, pose, what) in [
        (
            MEASURED_POINT,
            tip,
            point,
            "the calibrated measured point and frame (armcal's tool)",
        ),
        (
            MEASUREMENT_FRAME,
            base,
            frame,
            "the measurement frame of the calibration (armcal's base)",
        ),
    ] {
        let name = unique(name, taken);
        names.push(name.clone());
        let _ = write!(
            out,
            "  <!-- armcal: {what} -->\n  <link name=\"{name}\"/>\n  <joint name=\"{name}_joint\" type=\"fixed\">\n    <parent link=\"{parent}\"/>\n    <child link=\"{name}\"/>\n    {}\n  </joint>\n",
            origin(pose)
        );
    }
    let [measured_point, measurement_frame]: [String; 2] =
        names.try_into().expect("two links added");
    (
        out,
        ExportedLinks {
            base: base.to_owned(),
            measured_point,
            measurement_frame,
        },
    )
}

/// The calibration `cal` written into the URDF `urdf` its model was read from
/// (`converted`, the chain as read again now). Refused, naming `urdf`, when the
/// model read now is not the calibration's nominal model.
pub fn into_urdf(
    cal: &Calibration,
    urdf: &Urdf,
    converted: &Converted,
) -> Result<Exported, InputError> {
    // The masses are not the chain's: a calibration from measured joint
    // torques carries the masses fitted to them, and the URDF keeps its own
    // inertials.
    let mut nominal = cal.nominal.clone();
    for (l, c) in nominal.links.iter_mut().zip(&converted.robot.links) {
        l.mass = c.mass;
    }
    let (ours, theirs) = (model_hash(&converted.robot), model_hash(&nominal));
    if ours != theirs {
        return Err(InputError::new(
            &urdf.file,
            0,
            0,
            format!(
                "the calibration was not identified with this model: its model hash is {theirs:#018x}, this URDF's chain from {:?} to {:?} gives {ours:#018x}; give the URDF, --base-link, --tip-link and --tip-point it was identified with, or leave out --model to generate a URDF from the calibration",
                urdf.links[converted.chain.base].name, urdf.links[converted.chain.tip].name
            ),
        ));
    }
    let calibrated = cal.calibrated();
    let frame0 = cal.nominal.base.isometry();
    let mut edits: Vec<(core::ops::Range<usize>, String)> = Vec::new();
    let mut before = frame0;
    for (k, &j) in converted.chain.moving.iter().enumerate() {
        let joint = &urdf.joints[j];
        let d = converted.dh_in_link[k];
        let new = converted.fixed_before[k].inverse()
            * before
            * link_at_zero(&calibrated.links[k])
            * d.inverse();
        before = d;
        match &joint.origin_range {
            Some(r) => edits.push((r.clone(), origin(&new))),
            None => edits.push((
                joint.body_start..joint.body_start,
                format!("\n    {}", origin(&new)),
            )),
        }
    }
    let tip_in_dh = before.inverse() * converted.tip_in_last;
    let taken = |n: &str| urdf.link(n).is_some();
    let (added, links) = added_links(
        &urdf.links[converted.chain.tip].name,
        &(tip_in_dh.inverse() * calibrated.tool.isometry()),
        &urdf.links[converted.chain.base].name,
        &(frame0 * calibrated.base.isometry().inverse()),
        &taken,
    );
    edits.push((urdf.robot_end..urdf.robot_end, added));
    edits.sort_by_key(|(r, _)| r.start);
    let mut text = String::with_capacity(urdf.text.len() + 1024);
    let mut at = 0;
    for (range, new) in edits {
        text.push_str(&urdf.text[at..range.start]);
        text.push_str(&new);
        at = range.end;
    }
    text.push_str(&urdf.text[at..]);
    Ok(Exported {
        text,
        warnings: Vec::new(),
        links,
    })
}

/// `(P_k, N_k)` of a link: `A_k(q) = P_k · Z(q) · N_k` (see the module header).
fn split(convention: Convention, l: &Link<f64>) -> (Pose, Pose) {
    match convention {
        Convention::Mdh => (link_at_zero(l), Pose::identity()),
        Convention::Dh => (
            Pose::identity(),
            Pose::from_parts(
                Translation3::new(0.0, 0.0, l.s),
                Rotation3::from_axis_angle(&Vector3::z_axis(), l.theta),
            ) * Pose::from_parts(
                Translation3::new(l.a, 0.0, 0.0),
                Rotation3::from_axis_angle(&Vector3::x_axis(), l.alpha),
            ) * pre_joint(0.0, 0.0, l.beta),
        ),
    }
}

/// A URDF generated from the calibrated model of `cal` (see the module header);
/// `label` says where the calibration came from, in a comment.
pub fn generate(cal: &Calibration, label: &str) -> Exported {
    let robot: Robot<f64> = cal.calibrated();
    let frame0 = cal.nominal.base.isometry();
    let mut out = String::new();
    let _ = write!(
        out,
        "<?xml version=\"1.0\"?>\n<!-- written by armcal export from {}: the calibrated {} model, {} joints; lengths in m, angles in rad -->\n<robot name=\"armcal_calibrated\">\n  <link name=\"base_link\"/>\n",
        label.replace("--", "- -"),
        match robot.convention {
            Convention::Dh => "D-H",
            Convention::Mdh => "modified D-H",
        },
        robot.dof()
    );
    let mut after = frame0;
    let mut warnings = Vec::new();
    for (k, l) in robot.links.iter().enumerate() {
        let (pre, post) = split(robot.convention, l);
        let parent = if k == 0 {
            "base_link".to_owned()
        } else {
            format!("link{k}")
        };
        let (kind, limit) = match (l.joint, l.limits) {
            (JointType::Revolute, None) => ("continuous", String::new()),
            (JointType::Revolute, Some([lo, hi])) => (
                "revolute",
                format!("\n    <limit lower=\"{lo}\" upper=\"{hi}\" effort=\"0\" velocity=\"0\"/>"),
            ),
            (JointType::Prismatic, limits) => {
                let [lo, hi] = limits.unwrap_or([0.0, 0.0]);
                (
                    "prismatic",
                    format!(
                        "\n    <limit lower=\"{lo}\" upper=\"{hi}\" effort=\"0\" velocity=\"0\"/>"
                    ),
                )
            }
        };
        let _ = write!(
            out,
            "  <joint name=\"joint{n}\" type=\"{kind}\">\n    <parent link=\"{parent}\"/>\n    <child link=\"link{n}\"/>\n    {}\n    <axis xyz=\"0 0 1\"/>{limit}\n  </joint>\n",
            origin(&(after * pre)),
            n = k + 1
        );
        match l.mass {
            None => {
                let _ = writeln!(out, "  <link name=\"link{}\"/>", k + 1);
            }
            Some(m) => {
                let c = post * nalgebra::Point3::from(m.com);
                let _ = write!(
                    out,
                    "  <link name=\"link{}\">\n    <inertial>\n      <origin xyz=\"{} {} {}\"/>\n      <mass value=\"{}\"/>\n      <inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/>\n    </inertial>\n  </link>\n",
                    k + 1,
                    c.x,
                    c.y,
                    c.z,
                    m.mass
                );
            }
        }
        after = post;
    }
    if robot.links.iter().any(|l| l.mass.is_some()) {
        warnings.push(
            "the links' inertia tensors are not in an armcal model: written as zero (mass and centre of mass are the model's)".into(),
        );
    }
    let last = format!("link{}", robot.dof());
    let (added, links) = added_links(
        &last,
        &(after * robot.tool.isometry()),
        "base_link",
        &(frame0 * robot.base.isometry().inverse()),
        &|_| false,
    );
    out.push_str(&added);
    out.push_str("</robot>\n");
    Exported {
        text: out,
        warnings,
        links,
    }
}
