//! The robot model file: TOML of `docs/file-formats.md` §1, read into an SI [`Robot`].
//!
//! A model file gives the nominal kinematics of one serial manipulator as its maker
//! specifies it: `name`, `description`, `convention` (`"dh"`: `A_m = Rot_z(θ)
//! Trans_z(s) Trans_x(a) Rot_x(α)`, Mirman & Gupta eq. 5; `"mdh"`: Craig's
//! `Rot_x(α) Trans_x(a) Rot_z(θ) Trans_z(s)`), `length_unit` (`m`, `mm`, `in`),
//! `angle_unit` (`rad`, `deg`), an optional `gravity`, one `[[joint]]` table per
//! joint (base to tip), optional `[tool]` and `[base]` frames, and an optional
//! `[prior]` (this project's extension): `length` and `angle`, the scale of the
//! D-H parameter errors the robot is built to, in the file's units.
//!
//! Units: every length and angle of the file is in the file's declared units,
//! and so are the joint readings of its data files. [`parse_model`] converts them
//! to SI (m, rad) for [`Robot`], and keeps the [`Units`] so that readings and
//! results can be converted back. Exceptions, as in the format: `mass` is kg and
//! `gravity` is m/s² whatever `length_unit` says; `limits` are in joint units
//! (the angle unit for a revolute joint, the length unit for a prismatic one).
//!
//! Refusals: anything the format does not allow is an [`InputError`] naming the
//! file, the line and column of the offending key or value, and the key — TOML
//! syntax errors, unknown keys (with the allowed ones), missing required keys,
//! values of the wrong type, unknown `convention`/unit/joint `type` (with the
//! accepted values), non-finite numbers, arrays of the wrong length, inverted
//! `limits` or limits that leave no motion, a negative `mass`, `com` without `mass`, both `s` and `d`, more than
//! [`MAX_JOINTS`] joints. Missing keys of a table are reported at its header
//! (`[[joint]]`), missing top-level keys at line 1, column 1. The parser walks the
//! spanned document of `toml::de::DeTable`, so that every value keeps its place.

use core::ops::Range;

pub use armcal_shared::units::{AngleUnit, LengthUnit, Units};
use armcal_shared::{Convention, Frame, JointType, Link, LinkMass, MAX_JOINTS, Robot};
use nalgebra::Vector3;
use toml::Spanned;
use toml::de::{DeString, DeTable, DeValue};

use crate::io::builtin;
use crate::io::input_error::{InputError, MODEL_FILE, read_text};
use crate::io::urdf::{self, ChainSpec};
use crate::session::prior::Prior;

pub use crate::session::model::RobotModel;

/// The keys a model file may have at its top level.
const TOP_KEYS: [&str; 10] = [
    "name",
    "description",
    "convention",
    "length_unit",
    "angle_unit",
    "gravity",
    "joint",
    "tool",
    "base",
    "prior",
];
/// The keys a `[prior]` table may have.
const PRIOR_KEYS: [&str; 2] = ["length", "angle"];
/// The keys a `[[joint]]` table may have.
const JOINT_KEYS: [&str; 9] = [
    "type", "theta", "s", "d", "a", "alpha", "limits", "mass", "com",
];
/// The keys a `[tool]` or `[base]` table may have.
const FRAME_KEYS: [&str; 2] = ["xyz", "rpy"];
/// The accepted `convention` values, with what they mean.
const CONVENTIONS: [(&str, Convention, &str); 2] = [
    (
        "dh",
        Convention::Dh,
        "standard D-H, Rot_z(theta) Trans_z(s) Trans_x(a) Rot_x(alpha)",
    ),
    (
        "mdh",
        Convention::Mdh,
        "Craig's modified D-H, Rot_x(alpha) Trans_x(a) Rot_z(theta) Trans_z(s)",
    ),
];
/// The accepted joint `type` values.
const JOINT_TYPES: [(&str, JointType); 2] = [
    ("revolute", JointType::Revolute),
    ("prismatic", JointType::Prismatic),
];

type Value<'i> = Spanned<DeValue<'i>>;
type Key<'i> = Spanned<DeString<'i>>;

/// Parses the text of a model file (`docs/file-formats.md` §1) into a [`RobotModel`] in SI.
///
/// `file` names the file in error messages and becomes [`RobotModel::source`].
/// Never panics, whatever the text.
pub fn parse_model(text: &str, file: &str) -> Result<RobotModel, InputError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let doc = DeTable::parse(text).map_err(|e| {
        let offset = e.span().map_or(0, |s| s.start);
        InputError::at_offset(
            file,
            text,
            offset,
            format!("TOML syntax: {}", e.message().trim_end()),
        )
    })?;
    ModelReader { text, file }.model(doc.get_ref())
}

/// Loads a model: a built-in one if `name_or_path` is the name of one (see
/// [`builtin::MODELS`]), otherwise the file at that path.
///
/// An unreadable file is an error at line 0 with the OS reason, naming the
/// file and listing the built-in model names.
pub fn load_model(name_or_path: &str) -> Result<RobotModel, InputError> {
    load_model_with(name_or_path, &ChainSpec::default())
}

/// [`load_model`], also of a URDF ([`crate::io::urdf`]): a file named `*.urdf`, or
/// whose text starts with `<`, is read as one, its chain chosen by `spec`.
/// A `spec` other than the default is refused for a TOML or built-in model
/// (as an error of `--base-link`, `--tip-link` or `--tip-point`).
pub fn load_model_with(name_or_path: &str, spec: &ChainSpec) -> Result<RobotModel, InputError> {
    let not_urdf = |what: &str| {
        let flag = if spec.base_link.is_some() {
            "--base-link"
        } else if spec.tip_link.is_some() {
            "--tip-link"
        } else {
            "--tip-point"
        };
        InputError::argument(
            flag,
            format!("applies to a URDF model only; {name_or_path} is {what}"),
        )
    };
    if let Some((text, label)) = builtin::builtin_model(name_or_path) {
        if !spec.is_default() {
            return Err(not_urdf("a built-in model"));
        }
        let mut model = parse_model(text, label)?;
        model.source = format!("built-in {name_or_path}");
        return Ok(model);
    }
    let text = read_text(name_or_path, MODEL_FILE).map_err(|mut e| {
        if e.line == 0 {
            e.message = format!(
                "{} (and it is not a built-in model: {})",
                e.message,
                builtin::MODEL_NAMES.join(", ")
            );
        }
        e
    })?;
    if urdf::is_urdf(name_or_path, &text) {
        let (urdf, converted) = urdf_chain(&text, name_or_path, spec)?;
        return Ok(urdf_model(&urdf, converted));
    }
    if !spec.is_default() {
        return Err(not_urdf("a TOML model"));
    }
    parse_model(&text, name_or_path)
}

/// The URDF text of file `file` parsed, and the chain `spec` names converted.
pub fn urdf_chain(
    text: &str,
    file: &str,
    spec: &ChainSpec,
) -> Result<(urdf::Urdf, urdf::convert::Converted), InputError> {
    let urdf = urdf::parse(text, file)?;
    let converted = urdf.convert(spec)?;
    Ok((urdf, converted))
}

/// The model of a converted URDF chain: named after `<robot name>` (lower
/// case, other characters than a-z, 0-9, '_' and '-' as '_'), SI units, the
/// default prior.
pub fn urdf_model(urdf: &urdf::Urdf, converted: urdf::convert::Converted) -> RobotModel {
    let mut name: String = urdf
        .name
        .to_ascii_lowercase()
        .chars()
        .map(|c| {
            if c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if name.is_empty() {
        name = "urdf".into();
    }
    let chain = &converted.chain;
    let joints: Vec<&str> = chain
        .moving
        .iter()
        .map(|&j| urdf.joints[j].name.as_str())
        .collect();
    let tilted: Vec<usize> = (0..joints.len()).filter(|&k| converted.hayati[k]).collect();
    let hayati: Vec<String> = tilted.iter().map(|k| (k + 1).to_string()).collect();
    RobotModel {
        name,
        description: format!(
            "URDF chain {} -> {} ({}), modified D-H{}",
            urdf.links[chain.base].name,
            urdf.links[chain.tip].name,
            joints.join(", "),
            if hayati.is_empty() {
                String::new()
            } else {
                format!(" with Hayati's tilt on joint(s) {}", hayati.join(", "))
            }
        ),
        source: urdf.file.clone(),
        units: Units::SI,
        robot: converted.robot,
        prior: Prior::default(),
        tilted,
    }
}

/// Walks the spanned TOML document; every error is placed by a span of `text`.
struct ModelReader<'a> {
    text: &'a str,
    file: &'a str,
}

impl ModelReader<'_> {
    fn err(&self, span: Range<usize>, message: impl Into<String>) -> InputError {
        InputError::at_offset(self.file, self.text, span.start, message)
    }

    /// An error with no better place than the start of the file.
    fn err_top(&self, message: impl Into<String>) -> InputError {
        InputError::new(self.file, 1, 1, message)
    }

    /// The source text of a span, for messages.
    fn raw(&self, span: Range<usize>) -> &str {
        self.text.get(span).unwrap_or("?")
    }

    fn model(&self, doc: &DeTable<'_>) -> Result<RobotModel, InputError> {
        self.check_keys(doc, &TOP_KEYS, "")?;

        let name_value = self.required_top(doc, "name")?;
        let name = self.string(name_value, "name", "")?;
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == '-')
        {
            return Err(self.err(
                name_value.span(),
                format!(
                    "`name` = {:?}: a name may only use a-z, 0-9, '_' and '-' (at least one character)",
                    name
                ),
            ));
        }
        let description = match doc.get("description") {
            Some(v) => self.string(v, "description", "")?.to_owned(),
            None => String::new(),
        };

        let v = self.required_top(doc, "convention")?;
        let s = self.string(v, "convention", "")?;
        let convention = CONVENTIONS
            .iter()
            .find(|(n, _, _)| *n == s)
            .map(|(_, c, _)| *c)
            .ok_or_else(|| {
                let accepted: Vec<String> = CONVENTIONS
                    .iter()
                    .map(|(n, _, what)| format!("\"{n}\" ({what})"))
                    .collect();
                self.err(
                    v.span(),
                    format!(
                        "unknown convention {s:?}; accepted: {}",
                        accepted.join(", ")
                    ),
                )
            })?;

        let v = self.required_top(doc, "length_unit")?;
        let s = self.string(v, "length_unit", "")?;
        let length = LengthUnit::from_name(s).ok_or_else(|| {
            self.err(
                v.span(),
                format!(
                    "unknown length_unit {s:?}; accepted: {}",
                    quoted_list(LengthUnit::ALL.iter().map(|u| u.name()))
                ),
            )
        })?;
        let v = self.required_top(doc, "angle_unit")?;
        let s = self.string(v, "angle_unit", "")?;
        let angle = AngleUnit::from_name(s).ok_or_else(|| {
            self.err(
                v.span(),
                format!(
                    "unknown angle_unit {s:?}; accepted: {}",
                    quoted_list(AngleUnit::ALL.iter().map(|u| u.name()))
                ),
            )
        })?;
        let units = Units { length, angle };

        let gravity = match doc.get("gravity") {
            Some(v) => Some(Vector3::from(self.numbers::<3>(
                v,
                "gravity",
                "",
                "[gx, gy, gz] in m/s^2",
            )?)),
            None => None,
        };

        let links = self.joints(doc, units)?;
        let tool = self.frame(doc, "tool", units)?;
        let base = self.frame(doc, "base", units)?;

        let mut robot = Robot::new(convention, &links)
            .map_err(|e| self.err_top(format!("cannot build the robot: {e}")))?;
        robot.tool = tool;
        robot.base = base;
        robot.gravity = gravity;
        let prior = self.prior(doc, units)?;
        Ok(RobotModel {
            name: name.to_owned(),
            description,
            source: self.file.to_owned(),
            units,
            robot,
            prior,
            tilted: Vec::new(),
        })
    }

    /// Refuses the first key of `table` (in file order) that is not in `allowed`.
    fn check_keys(
        &self,
        table: &DeTable<'_>,
        allowed: &[&str],
        ctx: &str,
    ) -> Result<(), InputError> {
        let mut keys: Vec<&Key<'_>> = table.keys().collect();
        keys.sort_by_key(|k| k.span().start);
        for key in keys {
            let name: &str = key.get_ref();
            if !allowed.contains(&name) {
                let hint = closest(name, allowed)
                    .map(|c| format!(" (did you mean `{c}`?)"))
                    .unwrap_or_default();
                return Err(self.err(
                    key.span(),
                    format!(
                        "{ctx}unknown key `{name}`{hint}; allowed keys: {}",
                        allowed.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    fn required_top<'t, 'i>(
        &self,
        doc: &'t DeTable<'i>,
        key: &str,
    ) -> Result<&'t Value<'i>, InputError> {
        doc.get(key).ok_or_else(|| {
            self.err_top(format!(
                "missing required key `{key}` (required at the top level: name, convention, length_unit, angle_unit, and at least one [[joint]])"
            ))
        })
    }

    fn string<'v>(&self, v: &'v Value<'_>, key: &str, ctx: &str) -> Result<&'v str, InputError> {
        match v.get_ref() {
            DeValue::String(s) => Ok(s),
            other => Err(self.err(
                v.span(),
                format!("{ctx}`{key}` must be a string, found {}", a_type(other)),
            )),
        }
    }

    /// A finite number (a TOML float or integer).
    fn number(&self, v: &Value<'_>, key: &str, ctx: &str) -> Result<f64, InputError> {
        let x = match v.get_ref() {
            DeValue::Float(f) => f.as_str().parse::<f64>().ok(),
            DeValue::Integer(i) => match i64::from_str_radix(i.as_str(), i.radix()) {
                Ok(n) => Some(n as f64),
                Err(_) if i.radix() == 10 => i.as_str().parse::<f64>().ok(),
                Err(_) => None,
            },
            other => {
                return Err(self.err(
                    v.span(),
                    format!("{ctx}`{key}` must be a number, found {}", a_type(other)),
                ));
            }
        };
        match x {
            Some(x) if x.is_finite() => Ok(x),
            _ => Err(self.err(
                v.span(),
                format!(
                    "{ctx}`{key}` = {} is not a finite number",
                    self.raw(v.span())
                ),
            )),
        }
    }

    /// An array of exactly `N` finite numbers; `what` says what they are.
    fn numbers<const N: usize>(
        &self,
        v: &Value<'_>,
        key: &str,
        ctx: &str,
        what: &str,
    ) -> Result<[f64; N], InputError> {
        let items = match v.get_ref() {
            DeValue::Array(a) => a,
            other => {
                return Err(self.err(
                    v.span(),
                    format!(
                        "{ctx}`{key}` must be an array of {N} numbers, {what}; found {}",
                        a_type(other)
                    ),
                ));
            }
        };
        if items.len() != N {
            return Err(self.err(
                v.span(),
                format!(
                    "{ctx}`{key}` has {} values, expected {N}: {what}",
                    items.len()
                ),
            ));
        }
        let mut out = [0.0; N];
        for (i, (slot, item)) in out.iter_mut().zip(items.iter()).enumerate() {
            *slot = self.number(item, &format!("{key}[{i}]"), ctx)?;
        }
        Ok(out)
    }

    fn joints(&self, doc: &DeTable<'_>, units: Units) -> Result<Vec<Link<f64>>, InputError> {
        let Some((key, value)) = doc.get_key_value("joint") else {
            return Err(self.err_top(
                "missing required key `joint`: the model needs at least one [[joint]] table",
            ));
        };
        let tables = match value.get_ref() {
            DeValue::Array(a) => a,
            other => {
                return Err(self.err(
                    key.span(),
                    format!(
                        "`joint` must be an array of tables, one [[joint]] per joint; found {}",
                        a_type(other)
                    ),
                ));
            }
        };
        if tables.is_empty() {
            return Err(self.err(
                key.span(),
                "`joint` is empty: the model needs at least one [[joint]] table",
            ));
        }
        let mut links = Vec::with_capacity(tables.len().min(MAX_JOINTS));
        for (i, item) in tables.iter().enumerate() {
            if i >= MAX_JOINTS {
                return Err(self.err(
                    item.span(),
                    format!(
                        "[[joint]] {}: too many joints ({}): armcal supports at most {MAX_JOINTS}",
                        i + 1,
                        tables.len()
                    ),
                ));
            }
            links.push(self.joint(item, i + 1, units)?);
        }
        Ok(links)
    }

    fn joint(
        &self,
        item: &Value<'_>,
        number: usize,
        units: Units,
    ) -> Result<Link<f64>, InputError> {
        let ctx = format!("[[joint]] {number}: ");
        let DeValue::Table(t) = item.get_ref() else {
            return Err(self.err(
                item.span(),
                format!(
                    "{ctx}each joint must be a table, found {}",
                    a_type(item.get_ref())
                ),
            ));
        };
        self.check_keys(t, &JOINT_KEYS, &ctx)?;
        // `key` as it should read in the message, e.g. "`alpha`".
        let missing = |key: &str| {
            self.err(
                item.span(),
                format!(
                    "{ctx}missing required key {key} (each [[joint]] needs type, theta, s (or d), a and alpha)"
                ),
            )
        };

        let v = t.get("type").ok_or_else(|| missing("`type`"))?;
        let s = self.string(v, "type", &ctx)?;
        let joint = JOINT_TYPES
            .iter()
            .find(|(n, _)| *n == s)
            .map(|(_, j)| *j)
            .ok_or_else(|| {
                self.err(
                    v.span(),
                    format!(
                        "{ctx}unknown joint type {s:?}; accepted: {}",
                        quoted_list(JOINT_TYPES.iter().map(|(n, _)| *n))
                    ),
                )
            })?;

        let theta = self.number(
            t.get("theta").ok_or_else(|| missing("`theta`"))?,
            "theta",
            &ctx,
        )?;
        let s = match (t.get_key_value("s"), t.get_key_value("d")) {
            (Some((ks, _)), Some((kd, _))) => {
                let later = if ks.span().start > kd.span().start {
                    ks
                } else {
                    kd
                };
                return Err(self.err(
                    later.span(),
                    format!("{ctx}both `s` and `d` given: they are the same parameter, give one"),
                ));
            }
            (Some((_, v)), None) => self.number(v, "s", &ctx)?,
            (None, Some((_, v))) => self.number(v, "d", &ctx)?,
            (None, None) => return Err(missing("`s` (or `d`)")),
        };
        let a = self.number(t.get("a").ok_or_else(|| missing("`a`"))?, "a", &ctx)?;
        let alpha = self.number(
            t.get("alpha").ok_or_else(|| missing("`alpha`"))?,
            "alpha",
            &ctx,
        )?;

        let limits = match t.get("limits") {
            Some(v) => {
                let [lo, hi] =
                    self.numbers::<2>(v, "limits", &ctx, "[lower, upper] in joint units")?;
                if lo > hi {
                    return Err(self.err(
                        v.span(),
                        format!(
                            "{ctx}`limits` = [{lo}, {hi}]: the lower limit is above the upper one"
                        ),
                    ));
                }
                if lo == hi {
                    return Err(self.err(
                        v.span(),
                        format!(
                            "{ctx}`limits` = [{lo}, {hi}]: the joint cannot move, so nothing of it \
                             can be calibrated; give its range, or fold a locked joint into the \
                             next link's constant parameters"
                        ),
                    ));
                }
                Some([units.joint_to_si(joint, lo), units.joint_to_si(joint, hi)])
            }
            None => None,
        };
        let mass = match t.get("mass") {
            Some(v) => {
                let m = self.number(v, "mass", &ctx)?;
                if m < 0.0 {
                    return Err(self.err(v.span(), format!("{ctx}`mass` = {m} kg is negative")));
                }
                Some(m)
            }
            None => None,
        };
        let com = match t.get_key_value("com") {
            Some((k, v)) => {
                let c = self.numbers::<3>(v, "com", &ctx, "[x, y, z] in the link frame")?;
                if mass.is_none() {
                    return Err(self.err(
                        k.span(),
                        format!(
                            "{ctx}`com` given without `mass`: a centre of mass needs the mass (kg)"
                        ),
                    ));
                }
                Vector3::from(c.map(|x| units.length_to_si(x)))
            }
            None => Vector3::zeros(),
        };

        let (theta, s) = (units.angle_to_si(theta), units.length_to_si(s));
        let mut link = Link::new(
            joint,
            theta,
            s,
            units.length_to_si(a),
            units.angle_to_si(alpha),
        );
        link.limits = limits;
        link.mass = mass.map(|mass| LinkMass { mass, com });
        Ok(link)
    }

    /// `[prior]`: the scale of a D-H length and angle error (one standard
    /// deviation, positive, in the file's units); each defaults to the
    /// [`Prior::default`] (1 mm, 1 mrad).
    fn prior(&self, doc: &DeTable<'_>, units: Units) -> Result<Prior, InputError> {
        let mut prior = Prior::default();
        let Some((k, v)) = doc.get_key_value("prior") else {
            return Ok(prior);
        };
        let ctx = "[prior]: ";
        let DeValue::Table(t) = v.get_ref() else {
            return Err(self.err(
                k.span(),
                format!(
                    "`prior` must be a table ([prior] with length and angle), found {}",
                    a_type(v.get_ref())
                ),
            ));
        };
        self.check_keys(t, &PRIOR_KEYS, ctx)?;
        for (key, slot, to_si) in [
            (
                "length",
                &mut prior.length,
                Units::length_to_si as fn(&Units, f64) -> f64,
            ),
            ("angle", &mut prior.angle, Units::angle_to_si),
        ] {
            if let Some(v) = t.get(key) {
                let x = self.number(v, key, ctx)?;
                if x <= 0.0 {
                    return Err(self.err(
                        v.span(),
                        format!("{ctx}`{key}` = {x}: the scale of an error must be positive"),
                    ));
                }
                *slot = to_si(&units, x);
            }
        }
        Ok(prior)
    }

    /// `[tool]` or `[base]`: identity when absent; `xyz` and `rpy` each default to zero.
    fn frame(&self, doc: &DeTable<'_>, key: &str, units: Units) -> Result<Frame<f64>, InputError> {
        let Some((k, v)) = doc.get_key_value(key) else {
            return Ok(Frame::identity());
        };
        let ctx = format!("[{key}]: ");
        let DeValue::Table(t) = v.get_ref() else {
            return Err(self.err(
                k.span(),
                format!(
                    "`{key}` must be a table ([{key}] with xyz and rpy), found {}",
                    a_type(v.get_ref())
                ),
            ));
        };
        self.check_keys(t, &FRAME_KEYS, &ctx)?;
        let mut frame = Frame::identity();
        if let Some(v) = t.get("xyz") {
            let xyz = self.numbers::<3>(v, "xyz", &ctx, "[x, y, z]")?;
            frame.xyz = Vector3::from(xyz.map(|x| units.length_to_si(x)));
        }
        if let Some(v) = t.get("rpy") {
            let rpy = self.numbers::<3>(v, "rpy", &ctx, "[roll, pitch, yaw]")?;
            frame.rpy = Vector3::from(rpy.map(|x| units.angle_to_si(x)));
        }
        Ok(frame)
    }
}

/// "a string", "an integer", ... for messages.
fn a_type(v: &DeValue<'_>) -> &'static str {
    match v {
        DeValue::String(_) => "a string",
        DeValue::Integer(_) => "an integer",
        DeValue::Float(_) => "a float",
        DeValue::Boolean(_) => "a boolean",
        DeValue::Datetime(_) => "a date-time",
        DeValue::Array(_) => "an array",
        DeValue::Table(_) => "a table",
    }
}

/// `"a", "b", "c"`.
fn quoted_list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names
        .map(|n| format!("\"{n}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The allowed key closest to a misspelt one, if it is within two edits.
fn closest<'a>(name: &str, allowed: &[&'a str]) -> Option<&'a str> {
    if name.chars().count() > 40 {
        return None; // no allowed key is anywhere near that long
    }
    allowed
        .iter()
        .map(|a| (edit_distance(name, a), *a))
        .filter(|(d, _)| *d <= 2 && *d < name.chars().count())
        .min_by_key(|(d, _)| *d)
        .map(|(_, a)| a)
}

/// Levenshtein distance, counting an adjacent transposition as one edit.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    // Rows i-2, i-1, i of the dynamic-programming table.
    let mut prev2: Vec<usize> = vec![0; b.len() + 1];
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur: Vec<usize> = vec![0; b.len() + 1];
    for i in 1..=a.len() {
        cur[0] = i;
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut d = (prev[j] + 1).min(cur[j - 1] + 1).min(prev[j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d = d.min(prev2[j - 2] + 1);
            }
            cur[j] = d;
        }
        core::mem::swap(&mut prev2, &mut prev);
        core::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::builtin::MODELS;
    use proptest::prelude::*;

    /// A small valid model, m/rad; the refusal tests edit one line of it.
    const GOOD: &str = r#"name = "arm"
convention = "dh"
length_unit = "m"
angle_unit = "rad"

[[joint]]
type = "revolute"
theta = 0.0
s = 0.1
a = 0.2
alpha = 1.5
"#;

    /// `GOOD` with line `line` (1-based) replaced by `new` (which may hold several lines).
    fn edit(line: usize, new: &str) -> String {
        let mut lines: Vec<&str> = GOOD.lines().collect();
        lines[line - 1] = new;
        lines.join("\n") + "\n"
    }

    /// Asserts that `text` is refused at exactly `line`:`column` of "bad.toml",
    /// with a message that contains every one of `needles`.
    #[track_caller]
    fn refused(text: &str, line: usize, column: usize, needles: &[&str]) {
        let e = match parse_model(text, "bad.toml") {
            Ok(_) => panic!("accepted:\n{text}"),
            Err(e) => e,
        };
        assert_eq!(e.file, "bad.toml");
        assert_eq!((e.line, e.column), (line, column), "{e}");
        assert!(
            e.to_string()
                .starts_with(&format!("bad.toml:{line}:{column}: ")),
            "{e}"
        );
        for needle in needles {
            assert!(e.message.contains(needle), "{e:?} does not name {needle:?}");
        }
    }

    fn close(a: f64, b: f64) -> bool {
        // One unit conversion (a multiplication or division) each side: a few ulp.
        (a - b).abs() <= 4.0 * f64::EPSILON * a.abs().max(b.abs()).max(1e-300)
    }

    #[test]
    fn the_small_model_parses() {
        let m = parse_model(GOOD, "good.toml").unwrap();
        assert_eq!(m.name, "arm");
        assert_eq!(m.description, "");
        assert_eq!(m.source, "good.toml");
        assert_eq!(m.units, Units::SI);
        assert_eq!(m.dof(), 1);
        assert_eq!(m.robot.base, Frame::identity());
        assert_eq!(m.robot.tool, Frame::identity());
        assert_eq!(m.robot.gravity, None);
        assert_eq!(
            m.robot.links[0],
            Link::new(JointType::Revolute, 0.0, 0.1, 0.2, 1.5)
        );
    }

    /// Every built-in model parses, and `load_model` says it is built in.
    #[test]
    fn every_builtin_model_parses() {
        for b in MODELS {
            let m = parse_model(b.text, b.file).unwrap_or_else(|e| panic!("{e}"));
            assert!(m.dof() >= 6, "{}", b.name);
            let loaded = load_model(b.name).unwrap();
            assert_eq!(loaded.source, format!("built-in {}", b.name));
            assert_eq!(loaded.robot, m.robot);
        }
    }

    /// Mirman & Gupta's Table 1 in inches becomes metres (26 in = 0.6604 m), and
    /// its radians are kept exactly as printed.
    #[test]
    // The paper prints 1.570796 and 3.141593, not pi/2 and pi: kept as printed.
    #[allow(clippy::approx_constant)]
    fn puma_table1_in_si() {
        let m = load_model("puma560").unwrap();
        assert_eq!(m.units.length, LengthUnit::In);
        assert_eq!(m.units.angle, AngleUnit::Rad);
        assert_eq!(m.robot.convention, Convention::Dh);
        let s = [0.6604, -0.2032, 0.0, 0.4318, 0.0, -0.05715];
        let a = [0.0, 0.4318, 0.0, 0.0, 0.0, 0.0];
        let alpha = [1.570796, 0.0, 1.570796, 1.570796, 1.570796, 3.141593];
        for (i, l) in m.robot.links.iter().enumerate() {
            assert_eq!(l.joint, JointType::Revolute);
            assert_eq!(l.theta, 0.0);
            assert!(close(l.s, s[i]), "s{} = {}", i + 1, l.s);
            assert!(close(l.a, a[i]), "a{} = {}", i + 1, l.a);
            assert_eq!(l.alpha, alpha[i]);
        }
    }

    /// The UR10e of UR's table and the figaroh UR10e model have the same D-H
    /// lengths; masses and gravity are read in kg and m/s² unconverted.
    #[test]
    fn ur10e_matches_the_figaroh_model() {
        let ur = load_model("ur10e").unwrap();
        let fig = load_model("figaroh-ur10e-camera").unwrap();
        for (l, f) in ur.robot.links.iter().zip(&fig.robot.links) {
            assert_eq!((l.s, l.a), (f.s, f.a));
            assert!((l.alpha - f.alpha).abs() < 1e-12);
        }
        assert_eq!(ur.robot.gravity, Some(Vector3::new(0.0, 0.0, -9.81)));
        let m2 = ur.robot.links[1].mass.unwrap();
        assert_eq!(m2.mass, 13.051);
        assert_eq!(m2.com, Vector3::new(0.38, 0.0, 0.158));
        let ur5 = load_model("ur5e").unwrap();
        assert_eq!(ur5.robot.links[3].s, 0.1333);
        assert_eq!(ur5.robot.links[2].a, -0.3922);
    }

    /// A model written in mm and degrees parses to the same SI robot as its twin in
    /// m and rad: every length (s, a, xyz, com, prismatic limits) goes through the
    /// length unit, every angle (theta, alpha, rpy, revolute limits) through the
    /// angle unit; mass and gravity are not converted.
    #[test]
    fn mm_deg_twin_equals_m_rad() {
        let m_rad = r#"name = "twin"
convention = "mdh"
length_unit = "m"
angle_unit = "rad"
gravity = [0.0, 0.0, -9.81]
[[joint]]
type = "revolute"
theta = 1.5707963267948966
s = 0.425
a = -0.3922
alpha = -0.5235987755982988
limits = [-3.141592653589793, 0.7853981633974483]
mass = 2.5
com = [0.15, 0.0, 0.0265]
[[joint]]
type = "prismatic"
theta = 0.7853981633974483
d = 0.0125
a = 0.0
alpha = 3.141592653589793
limits = [0.0, 0.35]
[tool]
xyz = [0.001, -0.002, 0.1]
rpy = [0.0, 1.5707963267948966, -0.5235987755982988]
[base]
xyz = [1.5, 0.0, 0.9]
"#;
        let mm_deg = r#"name = "twin"
convention = "mdh"
length_unit = "mm"
angle_unit = "deg"
gravity = [0.0, 0.0, -9.81]
[[joint]]
type = "revolute"
theta = 90
s = 425
a = -392.2
alpha = -30
limits = [-180, 45]
mass = 2.5
com = [150, 0, 26.5]
[[joint]]
type = "prismatic"
theta = 45
d = 12.5
a = 0
alpha = 180
limits = [0, 350]
[tool]
xyz = [1, -2, 100]
rpy = [0, 90, -30]
[base]
xyz = [1500, 0, 900]
"#;
        let a = parse_model(m_rad, "a.toml").unwrap().robot;
        let b = parse_model(mm_deg, "b.toml").unwrap().robot;
        let mut x = Vec::new();
        let mut y = Vec::new();
        for r in [&a, &b] {
            let v = if core::ptr::eq(r, &a) { &mut x } else { &mut y };
            for l in &r.links {
                v.extend([l.theta, l.s, l.a, l.alpha]);
                v.extend(l.limits.unwrap());
                if let Some(m) = l.mass {
                    v.push(m.mass);
                    v.extend(m.com.iter());
                }
            }
            for f in [&r.tool, &r.base] {
                v.extend(f.xyz.iter().chain(f.rpy.iter()));
            }
            v.extend(r.gravity.unwrap().iter());
        }
        assert_eq!(x.len(), y.len());
        for (i, (p, q)) in x.iter().zip(&y).enumerate() {
            assert!(close(*p, *q), "value {i}: {p} (m, rad) vs {q} (mm, deg)");
        }
        assert_eq!(a.links[1].joint, JointType::Prismatic);
    }

    /// Unit conversions: to SI and back, and a joint reading in the unit of its type.
    #[test]
    fn unit_conversions() {
        let u = Units {
            length: LengthUnit::Mm,
            angle: AngleUnit::Deg,
        };
        assert_eq!(u.length_to_si(1500.0), 1.5);
        assert_eq!(u.length_from_si(1.5), 1500.0);
        assert!(close(u.angle_to_si(180.0), core::f64::consts::PI));
        assert!(close(u.angle_from_si(core::f64::consts::FRAC_PI_2), 90.0));
        assert!(close(
            u.joint_to_si(JointType::Revolute, 90.0),
            core::f64::consts::FRAC_PI_2
        ));
        assert_eq!(u.joint_to_si(JointType::Prismatic, 90.0), 0.09);
        assert_eq!(u.joint_from_si(JointType::Prismatic, 0.09), 90.0);
        assert!(close(
            u.joint_from_si(JointType::Revolute, core::f64::consts::PI),
            180.0
        ));
        assert_eq!(u.joint_unit(JointType::Prismatic), "mm");
        assert_eq!(u.joint_unit(JointType::Revolute), "deg");
        assert!(close(LengthUnit::In.to_si(1.0), 0.0254));
        assert!(close(LengthUnit::In.from_si(0.0254), 1.0));
        let names: Vec<String> = LengthUnit::ALL.iter().map(ToString::to_string).collect();
        assert_eq!(names, ["m", "mm", "in"]);
        assert_eq!(AngleUnit::Rad.to_string(), "rad");
        assert_eq!(AngleUnit::Deg.to_string(), "deg");
        assert_eq!(u.to_string(), "mm, deg");
        assert_eq!(LengthUnit::from_name("in"), Some(LengthUnit::In));
        assert_eq!(AngleUnit::from_name("degree"), None);
    }

    /// A missing file names the file and the built-in models; a file on disk is read
    /// and keeps its path as source.
    #[test]
    fn load_model_from_disk_or_refuses_naming_the_file() {
        let e = load_model("/nonexistent/robot.toml").unwrap_err();
        assert_eq!(e.file, "/nonexistent/robot.toml");
        assert_eq!((e.line, e.column), (0, 0));
        assert!(e.to_string().contains("/nonexistent/robot.toml"));
        assert!(e.message.contains("puma560"));

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("arm.toml");
        std::fs::write(&path, GOOD).unwrap();
        let p = path.to_str().unwrap();
        assert_eq!(load_model(p).unwrap().source, p);
        std::fs::write(&path, edit(10, "a = [0.2]")).unwrap();
        let e = load_model(p).unwrap_err();
        assert_eq!((e.file.as_str(), e.line, e.column), (p, 10, 5));
    }

    #[test]
    fn refuses_toml_syntax_errors_at_their_place() {
        // Unquoted string value: the parser points at the value.
        refused(&edit(3, "length_unit = m"), 3, 15, &["TOML syntax"]);
        // Unterminated table header.
        refused(&edit(6, "[[joint]"), 6, 9, &["TOML syntax"]);
        // A key given twice: the second one.
        refused(
            &edit(9, "s = 0.1\ns = 0.2"),
            10,
            1,
            &["TOML syntax", "duplicate key"],
        );
    }

    #[test]
    fn refuses_unknown_keys_naming_the_allowed_ones() {
        refused(
            &edit(11, "alpah = 1.5"),
            11,
            1,
            &[
                "[[joint]] 1",
                "unknown key `alpah`",
                "did you mean `alpha`",
                "allowed keys: type, theta, s, d, a, alpha",
            ],
        );
        refused(
            &edit(5, "gravty = [0.0, 0.0, -9.81]"),
            5,
            1,
            &[
                "unknown key `gravty`",
                "did you mean `gravity`",
                "allowed keys: name, description",
            ],
        );
        refused(
            &format!("{GOOD}[tool]\nxyz = [0.0, 0.0, 0.1]\n  rpz = [0.0, 0.0, 0.0]\n"),
            14,
            3,
            &["[tool]", "unknown key `rpz`", "allowed keys: xyz, rpy"],
        );
        // A sub-table of a joint is an unknown key of that joint.
        refused(
            &format!("{GOOD}[joint.extra]\nk = 1\n"),
            12,
            8,
            &["unknown key `extra`"],
        );
    }

    #[test]
    fn refuses_missing_required_top_level_keys_at_line_1() {
        for (line, key) in [
            (1, "name"),
            (2, "convention"),
            (3, "length_unit"),
            (4, "angle_unit"),
        ] {
            refused(
                &edit(line, ""),
                1,
                1,
                &[&format!("missing required key `{key}`")],
            );
        }
        let no_joint: String = GOOD.lines().take(4).map(|l| format!("{l}\n")).collect();
        refused(
            &no_joint,
            1,
            1,
            &["missing required key `joint`", "[[joint]]"],
        );
        refused(
            &format!("{no_joint}joint = []\n"),
            5,
            1,
            &["`joint` is empty"],
        );
        refused(
            &format!("{no_joint}[joint]\ntype = \"revolute\"\n"),
            5,
            2,
            &["`joint` must be an array of tables"],
        );
    }

    #[test]
    fn refuses_missing_joint_keys_at_the_joint_header() {
        for (line, key) in [(7, "type"), (8, "theta"), (10, "a"), (11, "alpha")] {
            refused(
                &edit(line, ""),
                6,
                1,
                &["[[joint]] 1", &format!("missing required key `{key}`")],
            );
        }
        refused(
            &edit(9, ""),
            6,
            1,
            &["[[joint]] 1", "missing required key `s` (or `d`)"],
        );
        // The second joint misses alpha: its own header, line 12.
        let two = format!("{GOOD}[[joint]]\ntype = \"revolute\"\ntheta = 0\nd = 0\na = 0\n");
        refused(&two, 12, 1, &["[[joint]] 2", "`alpha`"]);
    }

    #[test]
    fn refuses_both_s_and_d_at_the_second() {
        refused(&edit(9, "s = 0.1\nd = 0.1"), 10, 1, &["both `s` and `d`"]);
        refused(&edit(9, "d = 0.1\n  s = 0.1"), 10, 3, &["both `s` and `d`"]);
    }

    #[test]
    fn refuses_bad_names() {
        refused(
            &edit(1, "name = \"Arm 1\""),
            1,
            8,
            &["`name`", "\"Arm 1\"", "a-z, 0-9"],
        );
        refused(&edit(1, "name = \"\""), 1, 8, &["`name`"]);
        refused(&edit(1, "name = 5"), 1, 8, &["`name` must be a string"]);
    }

    #[test]
    fn refuses_unknown_convention_units_and_joint_types_listing_the_accepted() {
        refused(
            &edit(2, "convention = \"DH\""),
            2,
            14,
            &["convention", "\"DH\"", "\"dh\"", "\"mdh\""],
        );
        refused(
            &edit(3, "length_unit = \"cm\""),
            3,
            15,
            &["length_unit", "\"cm\"", "\"m\", \"mm\", \"in\""],
        );
        refused(
            &edit(4, "angle_unit = \"grad\""),
            4,
            14,
            &["angle_unit", "\"grad\"", "\"rad\", \"deg\""],
        );
        refused(
            &edit(7, "type = \"linear\""),
            7,
            8,
            &[
                "[[joint]] 1",
                "joint type \"linear\"",
                "\"revolute\", \"prismatic\"",
            ],
        );
    }

    #[test]
    fn refuses_non_finite_and_non_numeric_values() {
        refused(
            &edit(10, "a = nan"),
            10,
            5,
            &["`a` = nan is not a finite number"],
        );
        refused(&edit(10, "a = -inf"), 10, 5, &["`a` = -inf"]);
        refused(
            &edit(11, "alpha = 1e999"),
            11,
            9,
            &["`alpha` = 1e999 is not a finite number"],
        );
        refused(
            &edit(8, "theta = \"0\""),
            8,
            9,
            &["`theta` must be a number, found a string"],
        );
        refused(
            &edit(5, "gravity = [0.0, nan, -9.81]"),
            5,
            17,
            &["`gravity[1]` = nan"],
        );
        refused(
            &format!("{GOOD}[base]\nrpy = [0.0, 0.0, +inf]\n"),
            13,
            18,
            &["[base]", "`rpy[2]` = +inf"],
        );
    }

    #[test]
    fn refuses_arrays_of_the_wrong_length() {
        refused(
            &edit(5, "gravity = [0.0, -9.81]"),
            5,
            11,
            &["`gravity` has 2 values, expected 3"],
        );
        refused(
            &format!("{GOOD}[tool]\nxyz = [0.0, 0.1]\n"),
            13,
            7,
            &["[tool]", "`xyz` has 2 values, expected 3"],
        );
        refused(
            &format!("{GOOD}[base]\nrpy = [0, 0, 0, 0]\n"),
            13,
            7,
            &["[base]", "`rpy` has 4 values, expected 3"],
        );
        refused(
            &format!("{GOOD}mass = 1.0\ncom = [0.0, 0.1]\n"),
            13,
            7,
            &["`com` has 2 values, expected 3"],
        );
        refused(
            &format!("{GOOD}limits = [-1, 0, 1]\n"),
            12,
            10,
            &["`limits` has 3 values, expected 2"],
        );
        refused(
            &format!("{GOOD}limits = 1.0\n"),
            12,
            10,
            &["`limits` must be an array of 2 numbers"],
        );
    }

    #[test]
    fn refuses_inverted_limits_negative_mass_and_com_without_mass() {
        refused(
            &format!("{GOOD}limits = [1.0, -1.0]\n"),
            12,
            10,
            &["`limits`", "lower limit is above the upper"],
        );
        refused(
            &format!("{GOOD}mass = -0.5\n"),
            12,
            8,
            &["`mass` = -0.5 kg is negative"],
        );
        refused(
            &format!("{GOOD}com = [0.0, 0.0, 0.1]\n"),
            12,
            1,
            &["`com` given without `mass`"],
        );
        // A joint that cannot move is refused; zero mass is allowed.
        refused(
            &format!("{GOOD}limits = [0.5, 0.5]\n"),
            12,
            10,
            &["`limits` = [0.5, 0.5]", "cannot move"],
        );
        parse_model(&format!("{GOOD}mass = 0\n"), "ok.toml").unwrap();
    }

    #[test]
    fn refuses_more_than_max_joints_at_the_first_extra_joint() {
        let joint = "[[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 0\na = 0.1\nalpha = 0\n";
        let head: String = GOOD.lines().take(4).map(|l| format!("{l}\n")).collect();
        let ok = format!("{head}{}", joint.repeat(MAX_JOINTS));
        assert_eq!(parse_model(&ok, "ok.toml").unwrap().dof(), MAX_JOINTS);
        let too_many = format!("{head}{}", joint.repeat(MAX_JOINTS + 1));
        // Header of joint MAX_JOINTS + 1: after 4 head lines and MAX_JOINTS joints of 6 lines.
        refused(
            &too_many,
            4 + 6 * MAX_JOINTS + 1,
            1,
            &["too many joints (17)", "at most 16"],
        );
    }

    #[test]
    fn description_tool_and_base_are_read() {
        let text = format!(
            "description = \"a test arm\"\n{GOOD}[tool]\nxyz = [0.0, 0.0, 0.1]\n[base]\nrpy = [0.0, 0.0, 1.0]\n"
        );
        let m = parse_model(&text, "t.toml").unwrap();
        assert_eq!(m.description, "a test arm");
        assert_eq!(m.robot.tool.xyz, Vector3::new(0.0, 0.0, 0.1));
        assert_eq!(m.robot.tool.rpy, Vector3::zeros());
        assert_eq!(m.robot.base.rpy, Vector3::new(0.0, 0.0, 1.0));
        assert_eq!(m.robot.base.xyz, Vector3::zeros());
    }

    /// Deeply nested arrays are refused by the TOML parser's depth limit, not by a
    /// stack overflow.
    #[test]
    fn deep_nesting_is_refused_without_overflow() {
        let text = format!("name = {}", "[".repeat(100_000));
        let e = parse_model(&text, "deep.toml").unwrap_err();
        assert_eq!(e.line, 1);
        assert!(e.message.starts_with("TOML syntax"), "{e}");
    }

    /// Characters that matter to TOML and to this format, to mutate files with.
    const TOML_ALPHABET: &str =
        "[]{}=\"'#.,-+_ \n\r\t0123456789eEnaifstrdxyzpqvolumjg\u{e9}\u{1f600}";

    proptest! {
        /// Random bytes never make the model parser panic.
        #[test]
        fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
            let text = String::from_utf8_lossy(&bytes);
            let _ = parse_model(&text, "fuzz.toml");
        }

        /// Random edits of valid model files never make the parser panic, and a
        /// refusal always has a place in the text.
        #[test]
        fn mutated_models_never_panic(
            which in 0..MODELS.len(),
            edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<usize>()), 1..12),
        ) {
            let text = crate::test_support::mutate(MODELS[which].text, &edits, TOML_ALPHABET);
            if let Err(e) = parse_model(&text, "fuzz.toml") {
                let lines = crate::io::input_error::line_col(&text, text.len()).0;
                prop_assert!(e.line >= 1 && e.line <= lines, "{e}");
                prop_assert!(e.column >= 1, "{e}");
            }
        }
    }
}
