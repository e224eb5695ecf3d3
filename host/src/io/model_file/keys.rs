//! What a model file may say: the keys of each table, the accepted
//! `convention` and joint `type` values, and, for messages, the name of a
//! value's type and the allowed key closest to a misspelt one.

use armcal_shared::{Convention, JointType};
use toml::Spanned;
use toml::de::{DeString, DeValue};

/// The keys a model file may have at its top level.
pub(super) const TOP_KEYS: [&str; 10] = [
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
pub(super) const PRIOR_KEYS: [&str; 2] = ["length", "angle"];
/// The keys a `[[joint]]` table may have.
pub(super) const JOINT_KEYS: [&str; 9] = [
    "type", "theta", "s", "d", "a", "alpha", "limits", "mass", "com",
];
/// The keys a `[tool]` or `[base]` table may have.
pub(super) const FRAME_KEYS: [&str; 2] = ["xyz", "rpy"];
/// The accepted `convention` values, with what they mean.
pub(super) const CONVENTIONS: [(&str, Convention, &str); 2] = [
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
pub(super) const JOINT_TYPES: [(&str, JointType); 2] = [
    ("revolute", JointType::Revolute),
    ("prismatic", JointType::Prismatic),
];

pub(super) type Value<'i> = Spanned<DeValue<'i>>;
pub(super) type Key<'i> = Spanned<DeString<'i>>;

/// "a string", "an integer", ... for messages.
pub(super) fn a_type(v: &DeValue<'_>) -> &'static str {
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
pub(super) fn quoted_list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names
        .map(|n| format!("\"{n}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The allowed key closest to a misspelt one, if it is within two edits.
pub(super) fn closest<'a>(name: &str, allowed: &[&'a str]) -> Option<&'a str> {
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
