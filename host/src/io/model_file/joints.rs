//! The `[[joint]]` tables of a model file: each read into a [`Link`] in SI
//! (m or rad per its `type`, its limits in joint units on file, `mass` kg,
//! `com` m).

use armcal_shared::units::Units;
use armcal_shared::{JointType, Link, LinkMass, MAX_JOINTS};
use nalgebra::Vector3;
use toml::de::{DeTable, DeValue};

use super::keys::{JOINT_KEYS, JOINT_TYPES, Value, a_type, quoted_list};
use super::reader::ModelReader;
use crate::session::input_error::InputError;

impl ModelReader<'_> {
    pub(super) fn joints(
        &self,
        doc: &DeTable<'_>,
        units: Units,
    ) -> Result<Vec<Link<f64>>, InputError> {
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

    pub(super) fn joint(
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

        let limits = self.limits(t, joint, units, &ctx)?;
        let mass = self.mass(t, units, &ctx)?;

        let (theta, s) = (units.angle_to_si(theta), units.length_to_si(s));
        let mut link = Link::new(
            joint,
            theta,
            s,
            units.length_to_si(a),
            units.angle_to_si(alpha),
        );
        link.limits = limits;
        link.mass = mass;
        Ok(link)
    }

    /// `limits` of the joint table `t` (joint units on file), SI; `None` when absent.
    fn limits(
        &self,
        t: &DeTable<'_>,
        joint: JointType,
        units: Units,
        ctx: &str,
    ) -> Result<Option<[f64; 2]>, InputError> {
        match t.get("limits") {
            Some(v) => {
                let [lo, hi] =
                    self.numbers::<2>(v, "limits", ctx, "[lower, upper] in joint units")?;
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
                Ok(Some([
                    units.joint_to_si(joint, lo),
                    units.joint_to_si(joint, hi),
                ]))
            }
            None => Ok(None),
        }
    }

    /// `mass` (kg) and `com` (file length unit, SI here) of the joint table
    /// `t`; `None` when it gives no mass.
    fn mass(
        &self,
        t: &DeTable<'_>,
        units: Units,
        ctx: &str,
    ) -> Result<Option<LinkMass<f64>>, InputError> {
        let mass = match t.get("mass") {
            Some(v) => {
                let m = self.number(v, "mass", ctx)?;
                if m < 0.0 {
                    return Err(self.err(v.span(), format!("{ctx}`mass` = {m} kg is negative")));
                }
                Some(m)
            }
            None => None,
        };
        let com = match t.get_key_value("com") {
            Some((k, v)) => {
                let c = self.numbers::<3>(v, "com", ctx, "[x, y, z] in the link frame")?;
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
        Ok(mass.map(|mass| LinkMass { mass, com }))
    }
}
