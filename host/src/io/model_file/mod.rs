//! The robot model file: TOML of `docs/file-formats.md` §1, read into an SI [`Robot`](armcal_shared::Robot).
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
//! to SI (m, rad) for [`Robot`](armcal_shared::Robot), and keeps the [`Units`] so that readings and
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
//! [`MAX_JOINTS`](armcal_shared::MAX_JOINTS) joints. Missing keys of a table are reported at its header
//! (`[[joint]]`), missing top-level keys at line 1, column 1. The parser walks the
//! spanned document of `toml::de::DeTable`, so that every value keeps its place.
//!
//! ## Where it is read
//!
//! | module | what |
//! | --- | --- |
//! | this one | the entry points: [`parse_model`], [`load_model`], [`load_model_with`], [`urdf_model`] |
//! | `reader` | the walk of the TOML document: top level, keys, strings, numbers, frames |
//! | `joints` | the `[[joint]]` tables |
//! | `prior` | the `[prior]` table |
//! | `keys` | the allowed keys and values, and the words of the messages about them |

use armcal_shared::units::Units;
use toml::de::DeTable;

use crate::io::builtin;
use crate::io::input_error::{MODEL_FILE, read_text};
use crate::io::urdf::{self, ChainSpec};
use crate::session::input_error::InputError;
use crate::session::prior::Prior;

use crate::session::model::RobotModel;

mod joints;
mod keys;
mod prior;
mod reader;

use self::reader::ModelReader;

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
    let text = read_text(name_or_path, MODEL_FILE)
        .map_err(builtin::nor_builtin("model", &builtin::MODEL_NAMES))?;
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
        flange: converted.flange,
    }
}

#[cfg(test)]
mod tests;
