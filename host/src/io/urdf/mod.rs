//! URDF robot descriptions: read a serial chain into the model armcal
//! identifies ([`convert`]), and write a calibration back as URDF ([`export`]).
//!
//! What is read (`docs/urdf.md`): the `<robot>` element's `<link>`s (name, and
//! `<inertial>` with its `<origin>` and `<mass>`) and `<joint>`s (name, type,
//! `<origin xyz rpy>`, `<parent link>`, `<child link>`, `<axis xyz>`, `<limit
//! lower upper>`). Everything else (visuals, collisions, materials,
//! transmissions, `<gazebo>`, dynamics) is not read, and an export keeps it
//! as it is. A `<mimic>` is read only to refuse it on the chain: its joint's
//! reading is another's, not one of its own in the data.
//!
//! Frames and units, as the URDF specification has them: a joint's `<origin>`
//! places the joint frame, which is the child link's frame at zero reading, in
//! the parent link's frame: `Trans(xyz) Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`
//! (the same `R` as armcal's `[base]` and `[tool]`). The child link frame at
//! reading `q` is `origin · Rot(axis, q)` (revolute, continuous) or
//! `origin · Trans(axis · q)` (prismatic), with the axis a vector of the joint
//! frame, normalised as URDF parsers do. Lengths in m, angles in rad, mass in
//! kg; a URDF has no other units.
//!
//! The tree: every joint names one parent and one child link; a link is the
//! child of at most one joint; exactly one link (the root) is nobody's child.
//! The chain is the path from the base link (default: the root) down to the
//! tip link (default: followed down from the base as long as one branch holds
//! the moving joints, see [`ChainSpec`]).
//!
//! Refusals, each an [`InputError`] with the file, line and column of the
//! offending element or attribute: XML syntax, a root element other than
//! `<robot>`, a link or joint without a name or a duplicate name, an attribute
//! that is not the numbers it must be (`xyz="1 2"`), an unknown joint type, a
//! joint whose `<parent>` or `<child>` names no link, a link with two parents,
//! several roots or none, a `floating` or `planar` joint on the chain, a zero
//! axis on a moving joint, `lower > upper`, a moving joint on the chain that
//! mimics another (at its `<mimic>`), a negative mass, a base or tip link
//! that does not exist, a tip not below the base, a tree that branches into
//! several moving branches when no tip is given, a chain without moving joints
//! or with more than [`MAX_JOINTS`].

use core::ops::Range;
use std::collections::HashMap;

use armcal_shared::MAX_JOINTS;
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Unit, Vector3};

use crate::session::input_error::InputError;

pub mod convert;
pub mod export;

/// A rigid transform, m and rad.
pub type Pose = IsometryMatrix3<f64>;

/// The type of a URDF joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// Rotation about the axis, with limits.
    Revolute,
    /// Rotation about the axis, without limits.
    Continuous,
    /// Translation along the axis.
    Prismatic,
    /// No motion.
    Fixed,
    /// Six degrees of freedom: not a joint of a serial arm.
    Floating,
    /// Three degrees of freedom in a plane: not a joint of a serial arm.
    Planar,
}

impl JointKind {
    /// Every type, with its name in the file.
    const ALL: [(&'static str, JointKind); 6] = [
        ("revolute", Self::Revolute),
        ("continuous", Self::Continuous),
        ("prismatic", Self::Prismatic),
        ("fixed", Self::Fixed),
        ("floating", Self::Floating),
        ("planar", Self::Planar),
    ];

    /// The name in the file.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, k)| *k == self)
            .map_or("?", |(n, _)| n)
    }

    /// True for the one-axis joints a serial chain keeps: revolute, continuous, prismatic.
    pub fn moves(self) -> bool {
        matches!(self, Self::Revolute | Self::Continuous | Self::Prismatic)
    }
}

/// The mass properties of one link.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inertial {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in the link's frame, m.
    pub com: Vector3<f64>,
}

/// One `<link>`.
#[derive(Clone, Debug)]
pub struct UrdfLink {
    /// Its name.
    pub name: String,
    /// Byte offset of its element in the text.
    pub offset: usize,
    /// Its `<inertial>`, if any.
    pub inertial: Option<Inertial>,
}

/// One `<joint>`.
#[derive(Clone, Debug)]
pub struct UrdfJoint {
    /// Its name.
    pub name: String,
    /// Its type.
    pub kind: JointKind,
    /// Byte offset of its element in the text.
    pub offset: usize,
    /// Index of the parent link in [`Urdf::links`].
    pub parent: usize,
    /// Index of the child link.
    pub child: usize,
    /// The joint frame in the parent link's frame.
    pub origin: Pose,
    /// Bytes of its `<origin>` element, if it has one (an export replaces it).
    pub origin_range: Option<Range<usize>>,
    /// Byte offset just after the joint's start tag (an export inserts an
    /// `<origin>` there when the joint has none).
    pub body_start: usize,
    /// The unit axis in the joint frame (`1 0 0` when not given, as in URDF).
    pub axis: Vector3<f64>,
    /// `[lower, upper]` of a revolute or prismatic joint's `<limit>`, if it
    /// allows motion (`lower < upper`).
    pub limits: Option<[f64; 2]>,
    /// Byte offset of its `<mimic>` element and the joint it names, if it
    /// has one (its reading is then that joint's, scaled and offset).
    pub mimic: Option<(usize, String)>,
}

/// A parsed URDF: its links and joints as a tree, with the places of their
/// elements in the text.
#[derive(Clone, Debug)]
pub struct Urdf {
    /// The file as the user named it.
    pub file: String,
    /// Its text.
    pub text: String,
    /// `<robot name>`.
    pub name: String,
    /// Links in file order.
    pub links: Vec<UrdfLink>,
    /// Joints in file order.
    pub joints: Vec<UrdfJoint>,
    /// For each link, the joint whose child it is (`None` for the root).
    pub parent_joint: Vec<Option<usize>>,
    /// The root link.
    pub root: usize,
    /// Byte offset of the `</robot>` end tag (an export inserts new elements there).
    pub robot_end: usize,
}

/// Which chain of a URDF to read, and the measured point on its tip link.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ChainSpec {
    /// The link the chain starts from; the root when `None`.
    pub base_link: Option<String>,
    /// The link it ends at. When `None`, it is found by walking down from the
    /// base: through a link with one child; through the one child whose subtree
    /// holds a moving joint when there are several (links fixed beside the
    /// chain, sensors and the like, are left aside); stopping at a leaf, or at
    /// a link whose children hold no moving joint. Several children with
    /// moving joints are refused: give the tip.
    pub tip_link: Option<String>,
    /// The measured point in the tip link's frame, m (origin when `None`).
    pub tip_point: Option<Vector3<f64>>,
}

impl ChainSpec {
    /// True when nothing URDF-specific is asked for.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// Whether `name` and `text` look like a URDF rather than a TOML model:
/// a `.urdf` extension, or text starting (after a byte-order mark and white
/// space) with `<`.
pub fn is_urdf(name: &str, text: &str) -> bool {
    name.to_ascii_lowercase().ends_with(".urdf")
        || text
            .trim_start_matches('\u{feff}')
            .trim_start()
            .starts_with('<')
}

/// Parses the text of a URDF file; `file` names it in errors.
pub fn parse(text: &str, file: &str) -> Result<Urdf, InputError> {
    let opts = roxmltree::ParsingOptions {
        allow_dtd: false,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(text, opts).map_err(|e| {
        let pos = e.pos();
        InputError::new(
            file,
            pos.row as usize,
            pos.col as usize,
            format!("XML: {e}"),
        )
    })?;
    Reader { text, file }.urdf(&doc)
}

/// Walks the document; every error is placed by a byte offset of the text.
struct Reader<'a> {
    text: &'a str,
    file: &'a str,
}

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

impl Reader<'_> {
    fn err(&self, offset: usize, message: impl Into<String>) -> InputError {
        InputError::at_offset(self.file, self.text, offset, message)
    }

    fn urdf(&self, doc: &roxmltree::Document<'_>) -> Result<Urdf, InputError> {
        let robot = doc.root_element();
        if robot.tag_name().name() != "robot" {
            return Err(self.err(
                robot.range().start,
                format!(
                    "the root element is <{}>: a URDF has <robot>",
                    robot.tag_name().name()
                ),
            ));
        }
        let name = robot.attribute("name").unwrap_or("").to_owned();
        let mut links: Vec<UrdfLink> = Vec::new();
        let mut index: HashMap<String, usize> = HashMap::new();
        for node in robot.children().filter(|n| n.has_tag_name("link")) {
            let name = self.name(node, "link")?;
            if let Some(&other) = index.get(&name) {
                return Err(self.err(
                    node.range().start,
                    format!(
                        "a second link named {name:?} (the first is at line {})",
                        self.line(links[other].offset)
                    ),
                ));
            }
            index.insert(name.clone(), links.len());
            links.push(UrdfLink {
                name,
                offset: node.range().start,
                inertial: self.inertial(node)?,
            });
        }
        let mut joints: Vec<UrdfJoint> = Vec::new();
        let mut joint_names: HashMap<String, usize> = HashMap::new();
        let mut parent_joint = vec![None; links.len()];
        for node in robot.children().filter(|n| n.has_tag_name("joint")) {
            let joint = self.joint(node, &index)?;
            if let Some(&other) = joint_names.get(&joint.name) {
                return Err(self.err(
                    node.range().start,
                    format!(
                        "a second joint named {:?} (the first is at line {})",
                        joint.name,
                        self.line(joints[other].offset)
                    ),
                ));
            }
            if let Some(other) = parent_joint[joint.child] {
                let other: &UrdfJoint = &joints[other];
                return Err(self.err(
                    joint.offset,
                    format!(
                        "link {:?} is the child of joint {:?} (line {}) and of joint {:?}: a URDF is a tree, each link has one parent",
                        links[joint.child].name,
                        other.name,
                        self.line(other.offset),
                        joint.name
                    ),
                ));
            }
            parent_joint[joint.child] = Some(joints.len());
            joint_names.insert(joint.name.clone(), joints.len());
            joints.push(joint);
        }
        let roots: Vec<usize> = (0..links.len())
            .filter(|&l| parent_joint[l].is_none())
            .collect();
        let root = match roots.as_slice() {
            [root] => *root,
            [] if links.is_empty() => {
                return Err(self.err(robot.range().start, "the robot has no <link>"));
            }
            [] => {
                return Err(self.err(
                    robot.range().start,
                    "every link is the child of a joint: the joints form a loop, a URDF is a tree with one root link",
                ));
            }
            [first, second, ..] => {
                return Err(self.err(
                    links[*second].offset,
                    format!(
                        "link {:?} is nobody's child, and so is link {:?} (line {}): a URDF is one tree with one root link",
                        links[*second].name,
                        links[*first].name,
                        self.line(links[*first].offset)
                    ),
                ));
            }
        };
        // A loop away from the root leaves its links unreachable from it.
        let mut reached = vec![false; links.len()];
        let mut stack = vec![root];
        while let Some(l) = stack.pop() {
            reached[l] = true;
            stack.extend(joints.iter().filter(|j| j.parent == l).map(|j| j.child));
        }
        if let Some(l) = reached.iter().position(|r| !r) {
            let j = &joints[parent_joint[l].unwrap_or(0)];
            return Err(self.err(
                j.offset,
                format!(
                    "joint {:?} is part of a loop of joints that the root link {:?} does not reach: a URDF is a tree",
                    j.name, links[root].name
                ),
            ));
        }
        let robot_end = self.text[..robot.range().end]
            .rfind("</")
            .unwrap_or(robot.range().end);
        Ok(Urdf {
            file: self.file.to_owned(),
            text: self.text.to_owned(),
            name,
            links,
            joints,
            parent_joint,
            root,
            robot_end,
        })
    }

    fn line(&self, offset: usize) -> usize {
        crate::session::input_error::line_col(self.text, offset).0
    }

    /// The `name` attribute of an element, required.
    fn name(&self, node: Node<'_, '_>, what: &str) -> Result<String, InputError> {
        match node.attribute("name") {
            Some(n) if !n.trim().is_empty() => Ok(n.to_owned()),
            _ => Err(self.err(
                node.range().start,
                format!("<{what}> without a name: every {what} needs name=\"...\""),
            )),
        }
    }

    /// The first child element `tag` of `node`.
    fn child<'a, 'i>(node: Node<'a, 'i>, tag: &str) -> Option<Node<'a, 'i>> {
        node.children().find(|n| n.has_tag_name(tag))
    }

    /// Attribute `attr` of `node` as `N` finite numbers separated by white
    /// space; `default` when it is missing.
    fn numbers<const N: usize>(
        &self,
        node: Node<'_, '_>,
        attr: &str,
        default: Option<[f64; N]>,
        what: &str,
    ) -> Result<[f64; N], InputError> {
        let Some(a) = node.attribute_node(attr) else {
            return default.ok_or_else(|| {
                self.err(
                    node.range().start,
                    format!(
                        "<{}> without {attr}=\"...\": {what}",
                        node.tag_name().name()
                    ),
                )
            });
        };
        let bad = |message: String| self.err(a.range_value().start, message);
        let words: Vec<&str> = a.value().split_whitespace().collect();
        if words.len() != N {
            return Err(bad(format!(
                "{attr}=\"{}\": {} number{}, expected {N} ({what})",
                a.value(),
                words.len(),
                if words.len() == 1 { "" } else { "s" }
            )));
        }
        let mut out = [0.0; N];
        for (slot, word) in out.iter_mut().zip(&words) {
            *slot = match word.parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => {
                    return Err(bad(format!(
                        "{attr}=\"{}\": {word:?} is not a finite number",
                        a.value()
                    )));
                }
            };
        }
        Ok(out)
    }

    /// An `<origin xyz rpy>` child of `node` (identity if absent), and its bytes.
    fn origin(&self, node: Node<'_, '_>) -> Result<(Pose, Option<Range<usize>>), InputError> {
        let Some(o) = Self::child(node, "origin") else {
            return Ok((Pose::identity(), None));
        };
        let xyz = self.numbers::<3>(o, "xyz", Some([0.0; 3]), "x y z in m")?;
        let rpy = self.numbers::<3>(o, "rpy", Some([0.0; 3]), "roll pitch yaw in rad")?;
        Ok((pose(xyz, rpy), Some(o.range())))
    }

    fn inertial(&self, link: Node<'_, '_>) -> Result<Option<Inertial>, InputError> {
        let Some(node) = Self::child(link, "inertial") else {
            return Ok(None);
        };
        let (origin, _) = self.origin(node)?;
        let Some(m) = Self::child(node, "mass") else {
            return Err(self.err(
                node.range().start,
                "<inertial> without <mass value=\"...\"/>",
            ));
        };
        let [mass] = self.numbers::<1>(m, "value", None, "the mass in kg")?;
        if mass < 0.0 {
            return Err(self.err(m.range().start, format!("mass {mass} kg is negative")));
        }
        Ok(Some(Inertial {
            mass,
            com: origin.translation.vector,
        }))
    }

    fn joint(
        &self,
        node: Node<'_, '_>,
        index: &HashMap<String, usize>,
    ) -> Result<UrdfJoint, InputError> {
        let name = self.name(node, "joint")?;
        let ctx = format!("joint {name:?}: ");
        let kind = match node.attribute_node("type") {
            None => {
                return Err(self.err(
                    node.range().start,
                    format!("{ctx}no type=\"...\" (revolute, continuous, prismatic, fixed, floating or planar)"),
                ));
            }
            Some(a) => JointKind::ALL
                .iter()
                .find(|(n, _)| *n == a.value())
                .map(|(_, k)| *k)
                .ok_or_else(|| {
                    self.err(
                        a.range_value().start,
                        format!(
                            "{ctx}unknown joint type {:?}; accepted: revolute, continuous, prismatic, fixed, floating, planar",
                            a.value()
                        ),
                    )
                })?,
        };
        let link = |tag: &str| -> Result<usize, InputError> {
            let Some(n) = Self::child(node, tag) else {
                return Err(self.err(node.range().start, format!("{ctx}no <{tag} link=\"...\"/>")));
            };
            let Some(a) = n.attribute_node("link") else {
                return Err(self.err(
                    n.range().start,
                    format!("{ctx}<{tag}> without link=\"...\""),
                ));
            };
            index.get(a.value()).copied().ok_or_else(|| {
                self.err(
                    a.range_value().start,
                    format!(
                        "{ctx}{tag} link {:?} is not a <link> of this robot",
                        a.value()
                    ),
                )
            })
        };
        let parent = link("parent")?;
        let child = link("child")?;
        let (origin, origin_range) = self.origin(node)?;
        let body_start = node
            .first_child()
            .map_or(node.range().end, |c| c.range().start);
        let mut axis = Vector3::x();
        if let Some(a) = Self::child(node, "axis") {
            let v = Vector3::from(self.numbers::<3>(
                a,
                "xyz",
                Some([1.0, 0.0, 0.0]),
                "the axis x y z",
            )?);
            if kind.moves() {
                let n = v.norm();
                if n.is_finite() && n > 1e-12 {
                    axis = v / n;
                } else {
                    return Err(self.err(
                        a.range().start,
                        format!("{ctx}the axis of a {} joint is zero", kind.name()),
                    ));
                }
            }
        }
        let mut limits = None;
        if let (Some(l), JointKind::Revolute | JointKind::Prismatic) =
            (Self::child(node, "limit"), kind)
        {
            let [lower] = self.numbers::<1>(l, "lower", Some([0.0]), "the lower limit")?;
            let [upper] = self.numbers::<1>(l, "upper", Some([0.0]), "the upper limit")?;
            if lower > upper {
                return Err(self.err(
                    l.range().start,
                    format!("{ctx}limit lower=\"{lower}\" is above upper=\"{upper}\""),
                ));
            }
            limits = (lower < upper).then_some([lower, upper]);
        }
        let mimic = Self::child(node, "mimic").map(|m| {
            (
                m.range().start,
                m.attribute("joint").unwrap_or_default().to_string(),
            )
        });
        Ok(UrdfJoint {
            name,
            kind,
            offset: node.range().start,
            parent,
            child,
            origin,
            origin_range,
            body_start,
            axis,
            limits,
            mimic,
        })
    }
}

/// `Trans(xyz) Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`.
pub fn pose(xyz: [f64; 3], [roll, pitch, yaw]: [f64; 3]) -> Pose {
    Pose::from_parts(
        Translation3::from(Vector3::from(xyz)),
        Rotation3::from_euler_angles(roll, pitch, yaw),
    )
}

/// The roll, pitch and yaw of `r = Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`, with
/// `pitch` in `[-π/2, π/2]`, accurate to a few ulp of `r` everywhere, also at
/// and near `pitch = ±π/2`: the pitch from `atan2(−r₂₀, hypot(r₀₀, r₁₀))`, the
/// yaw from the first column (any value where that column is along z), and
/// the roll from what is left, `Rot_y(−pitch) Rot_z(−yaw) r`, so that the three
/// reproduce `r` even where yaw and roll are not separately determined.
pub fn rpy(r: &Rotation3<f64>) -> [f64; 3] {
    let m = r.matrix();
    let pitch = (-m[(2, 0)]).atan2(m[(0, 0)].hypot(m[(1, 0)]));
    let yaw = if m[(1, 0)] == 0.0 && m[(0, 0)] == 0.0 {
        0.0
    } else {
        m[(1, 0)].atan2(m[(0, 0)])
    };
    let rest = Rotation3::from_axis_angle(&Vector3::y_axis(), -pitch)
        * Rotation3::from_axis_angle(&Vector3::z_axis(), -yaw)
        * r;
    let roll = rest[(2, 1)].atan2(rest[(1, 1)]);
    [roll, pitch, yaw]
}

/// The rotation `angle` about the unit vector `axis`, or the translation
/// `axis · q` of a prismatic joint: the motion of a joint at reading `q` in its
/// joint frame.
pub fn joint_motion(kind: JointKind, axis: &Vector3<f64>, q: f64) -> Pose {
    match kind {
        JointKind::Prismatic => {
            Pose::from_parts(Translation3::from(axis * q), Rotation3::identity())
        }
        _ => Pose::from_parts(
            Translation3::identity(),
            Rotation3::from_axis_angle(&Unit::new_unchecked(*axis), q),
        ),
    }
}

/// The serial chain of a URDF between two links.
#[derive(Clone, Debug)]
pub struct UrdfChain {
    /// The base link.
    pub base: usize,
    /// The tip link.
    pub tip: usize,
    /// The joints from base to tip (fixed ones included), in order.
    pub path: Vec<usize>,
    /// The moving joints of the path, in order.
    pub moving: Vec<usize>,
}

impl Urdf {
    /// The index of the link named `name`.
    pub fn link(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }

    /// The joints whose parent is link `l`, in file order.
    pub fn children(&self, l: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.joints.len()).filter(move |&j| self.joints[j].parent == l)
    }

    /// Whether the subtree below joint `j` (its child link and below) or `j`
    /// itself has a moving joint.
    fn has_motion(&self, j: usize) -> bool {
        self.joints[j].kind.moves()
            || self
                .children(self.joints[j].child)
                .any(|c| self.has_motion(c))
    }

    fn err(&self, offset: usize, message: impl Into<String>) -> InputError {
        InputError::at_offset(&self.file, &self.text, offset, message)
    }

    fn line(&self, offset: usize) -> usize {
        crate::session::input_error::line_col(&self.text, offset).0
    }

    /// The chain that `spec` names, checked: moving joints only revolute,
    /// continuous or prismatic, from 1 to [`MAX_JOINTS`] of them.
    pub fn chain(&self, spec: &ChainSpec) -> Result<UrdfChain, InputError> {
        let find = |flag: &str, name: &str| {
            self.link(name).ok_or_else(|| {
                let names: Vec<&str> = self.links.iter().map(|l| l.name.as_str()).collect();
                InputError::argument(
                    flag,
                    format!(
                        "{name:?}: {} has no such link; its links: {}",
                        self.file,
                        names.join(", ")
                    ),
                )
            })
        };
        let base = match &spec.base_link {
            Some(name) => find("--base-link", name)?,
            None => self.root,
        };
        let tip = match &spec.tip_link {
            Some(name) => find("--tip-link", name)?,
            None => self.default_tip(base)?,
        };
        // Up from the tip to the base.
        let mut path = Vec::new();
        let mut at = tip;
        while at != base {
            let Some(j) = self.parent_joint[at] else {
                return Err(self.err(
                    self.links[tip].offset,
                    format!(
                        "the tip link {:?} is not below the base link {:?} (line {}): no chain of joints leads from the base to it",
                        self.links[tip].name,
                        self.links[base].name,
                        self.line(self.links[base].offset)
                    ),
                ));
            };
            path.push(j);
            at = self.joints[j].parent;
        }
        path.reverse();
        for &j in &path {
            let joint = &self.joints[j];
            if matches!(joint.kind, JointKind::Floating | JointKind::Planar) {
                return Err(self.err(
                    joint.offset,
                    format!(
                        "joint {:?} on the chain from {:?} to {:?} is {}: armcal models serial arms of revolute and prismatic joints (choose --base-link below it)",
                        joint.name,
                        self.links[base].name,
                        self.links[tip].name,
                        joint.kind.name()
                    ),
                ));
            }
            if let (Some((at, leader)), true) = (&joint.mimic, joint.kind.moves()) {
                return Err(self.err(
                    *at,
                    format!(
                        "joint {:?} on the chain from {:?} to {:?} mimics joint {leader:?}: its reading is not a joint reading of its own, and armcal reads one per moving joint of the chain (choose a chain without it, or make it a joint of its own)",
                        joint.name,
                        self.links[base].name,
                        self.links[tip].name,
                    ),
                ));
            }
        }
        let moving: Vec<usize> = path
            .iter()
            .copied()
            .filter(|&j| self.joints[j].kind.moves())
            .collect();
        if moving.is_empty() {
            return Err(self.err(
                self.links[tip].offset,
                format!(
                    "no revolute, continuous or prismatic joint between the base link {:?} and the tip link {:?}: nothing to calibrate",
                    self.links[base].name, self.links[tip].name
                ),
            ));
        }
        if moving.len() > MAX_JOINTS {
            return Err(self.err(
                self.joints[moving[MAX_JOINTS]].offset,
                format!(
                    "{} moving joints between {:?} and {:?}: armcal supports at most {MAX_JOINTS}",
                    moving.len(),
                    self.links[base].name,
                    self.links[tip].name
                ),
            ));
        }
        Ok(UrdfChain {
            base,
            tip,
            path,
            moving,
        })
    }

    /// The tip found from `base` (see [`ChainSpec::tip_link`]).
    fn default_tip(&self, base: usize) -> Result<usize, InputError> {
        let mut at = base;
        loop {
            let children: Vec<usize> = self.children(at).collect();
            let next = match children.as_slice() {
                [] => return Ok(at),
                [one] => *one,
                many => {
                    let moving: Vec<usize> = many
                        .iter()
                        .copied()
                        .filter(|&j| self.has_motion(j))
                        .collect();
                    match moving.as_slice() {
                        [] => return Ok(at),
                        [one] => *one,
                        several => {
                            let names: Vec<String> = several
                                .iter()
                                .map(|&j| format!("{:?}", self.links[self.joints[j].child].name))
                                .collect();
                            return Err(self.err(
                                self.links[at].offset,
                                format!(
                                    "the tree branches at link {:?} into {} branches with moving joints (towards {}): not one serial chain; give --tip-link (and --base-link) to choose the chain",
                                    self.links[at].name,
                                    several.len(),
                                    names.join(", ")
                                ),
                            ));
                        }
                    }
                }
            };
            at = self.joints[next].child;
        }
    }
}
