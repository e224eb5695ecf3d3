//! The walk of a model file's spanned TOML document ([`ModelReader`]): the
//! top level into a [`RobotModel`] in SI (m, rad, kg, m/s²), its keys
//! checked, its strings and numbers read with their places, and the `[tool]`
//! and `[base]` frames. The joints and the prior are read in their own
//! modules.

use core::ops::Range;

use armcal_shared::units::{AngleUnit, LengthUnit, Units};
use armcal_shared::{Frame, JointType, Robot};
use nalgebra::Vector3;
use toml::de::{DeTable, DeValue};

use super::keys::{CONVENTIONS, FRAME_KEYS, Key, TOP_KEYS, Value, a_type, closest, quoted_list};
use crate::session::input_error::InputError;
use crate::session::model::RobotModel;

/// Walks the spanned TOML document; every error is placed by a span of `text`.
/// The sizes a serial arm's links and tool add up to, m: from a desktop
/// arm's few centimetres to a gantry's tens of metres.
pub const ARM_SIZE: [f64; 2] = [0.02, 50.0];

pub(super) struct ModelReader<'a> {
    pub(super) text: &'a str,
    pub(super) file: &'a str,
}

impl ModelReader<'_> {
    pub(super) fn err(&self, span: Range<usize>, message: impl Into<String>) -> InputError {
        InputError::at_offset(self.file, self.text, span.start, message)
    }

    /// An error with no better place than the start of the file.
    pub(super) fn err_top(&self, message: impl Into<String>) -> InputError {
        InputError::new(self.file, 1, 1, message)
    }

    /// The source text of a span, for messages.
    pub(super) fn raw(&self, span: Range<usize>) -> &str {
        self.text.get(span).unwrap_or("?")
    }

    pub(super) fn model(&self, doc: &DeTable<'_>) -> Result<RobotModel, InputError> {
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
        let length_unit_span = v.span();
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
        self.require_arm_size(&robot, units, length_unit_span)?;
        let prior = self.prior(doc, units)?;
        Ok(RobotModel {
            name: name.to_owned(),
            description,
            source: self.file.to_owned(),
            units,
            robot,
            prior,
            tilted: Vec::new(),
            flange: Frame::identity(),
        })
    }

    /// Refuses a model whose size is not an arm's in its `length_unit`: its
    /// links' lengths (`|s|`, `|a|`, each prismatic joint's farthest limit) and
    /// the tool's offset adding up to less than [`ARM_SIZE`]'s least or more
    /// than its most, as the values of a model in metres read as millimetres
    /// do (a 1.8 mm robot, which data in metres then fit as well as the real
    /// one). Placed at `length_unit` (`span`), naming the unit the values
    /// would make an arm in.
    fn require_arm_size(
        &self,
        robot: &Robot<f64>,
        units: Units,
        span: Range<usize>,
    ) -> Result<(), InputError> {
        let size = robot
            .links
            .iter()
            .map(|l| {
                let stroke = match (l.joint, l.limits) {
                    (JointType::Prismatic, Some([lo, hi])) => lo.abs().max(hi.abs()),
                    _ => 0.0,
                };
                l.s.abs() + l.a.abs() + stroke
            })
            .sum::<f64>()
            + robot.tool.xyz.norm();
        let [least, most] = ARM_SIZE;
        if size == 0.0 || (least..=most).contains(&size) {
            return Ok(());
        }
        let given = units.length.name();
        let would = LengthUnit::ALL.iter().find(|u| {
            let as_u = units.length.from_si(size);
            (least..=most).contains(&u.to_si(as_u))
        });
        let hint = would.map_or(String::new(), |u| {
            format!(
                ": are the values in {} while length_unit says {given:?}?",
                u.name()
            )
        });
        Err(self.err(
            span,
            format!(
                "the links' lengths and the tool's offset add up to {:.4} {given}, not the size of \
                 an arm (from {least} to {most} m){hint}",
                units.length.from_si(size),
            ),
        ))
    }

    /// Refuses the first key of `table` (in file order) that is not in `allowed`.
    pub(super) fn check_keys(
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

    pub(super) fn required_top<'t, 'i>(
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

    pub(super) fn string<'v>(
        &self,
        v: &'v Value<'_>,
        key: &str,
        ctx: &str,
    ) -> Result<&'v str, InputError> {
        match v.get_ref() {
            DeValue::String(s) => Ok(s),
            other => Err(self.err(
                v.span(),
                format!("{ctx}`{key}` must be a string, found {}", a_type(other)),
            )),
        }
    }

    /// A finite number (a TOML float or integer).
    pub(super) fn number(&self, v: &Value<'_>, key: &str, ctx: &str) -> Result<f64, InputError> {
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
    pub(super) fn numbers<const N: usize>(
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

    /// `[tool]` or `[base]`: identity when absent; `xyz` and `rpy` each default to zero.
    pub(super) fn frame(
        &self,
        doc: &DeTable<'_>,
        key: &str,
        units: Units,
    ) -> Result<Frame<f64>, InputError> {
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
