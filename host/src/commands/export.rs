//! `export`: a calibration written in a format another tool reads — a URDF
//! (into the URDF its model was read from, or generated), Universal Robots'
//! D-H deltas or `ur_calibration`'s YAML — with the geometry refitted without
//! the effects the format cannot carry ([`crate::apply::export`]).
//!
//! Lengths on file in m, angles in rad, as each format defines them
//! (docs/urdf.md, docs/ur.md).

use armcal_shared::{Calibration, Frame, JointType};

use super::tool::Tool;
use super::{Argument, Front};
use crate::apply::export::{GeometryExport, geometry_only};
use crate::apply::read_back;
use crate::apply::working_tool::{ToolChange, WorkingTool};
use crate::io::calibration_file::load_calibration;
use crate::io::input_error::{MODEL_FILE, read_text};
use crate::io::model_file::{load_model_with, urdf_chain};
use crate::io::ur;
use crate::io::urdf::{self, ChainSpec};
use crate::session::input_error::InputError;

/// The format written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// URDF (ROS robot description).
    Urdf,
    /// Universal Robots factory calibration: D-H deltas against the UR model.
    UrDeltas,
    /// Universal Robots: `ur_calibration`'s URDF-correction YAML.
    UrCalibration,
}

impl Format {
    /// What the format is called in a note: `a URDF`, …
    fn called(self) -> &'static str {
        match self {
            Self::Urdf => "a URDF",
            Self::UrDeltas => "a UR deltas file",
            Self::UrCalibration => "a ur_calibration file",
        }
    }
}

/// What `export` is asked.
#[derive(Clone, Debug)]
pub struct Request {
    /// The format written.
    pub format: Format,
    /// A URDF: the URDF the calibration's model was read from (written
    /// into), or `None` to generate one; Universal Robots: the UR model the
    /// deltas are against (required).
    pub model: Option<String>,
    /// The chain of a URDF model.
    pub chain: ChainSpec,
    /// The working tool that replaces the measured one, if any: the
    /// measured tool's offset is then not written.
    pub tool: Option<Tool>,
}

/// What `export` writes.
#[derive(Clone, Debug)]
pub struct Exported {
    /// The text of the file.
    pub text: String,
    /// The calibration written and what it is expected to deliver (its
    /// note, for the user).
    pub held: GeometryExport,
    /// What the format's writer says of the export.
    pub warnings: Vec<String>,
    /// The working tool's change of the calibration, when one was given
    /// (its note, for the user).
    pub tool: Option<ToolChange>,
}

impl Request {
    /// The model this request needs, before anything is read: a UR format
    /// names its UR model, a chain is named only with the URDF it is of.
    pub fn check(&self, front: Front) -> Result<(), InputError> {
        match (self.format, &self.model) {
            (Format::UrDeltas | Format::UrCalibration, None) => Err(Argument::Model.refused(
                front,
                "--format ur-deltas and ur-calibration: give the UR model (ur5e, ur10, ur10e; the deltas are against its nominal)",
            )),
            (Format::Urdf, None) if !self.chain.is_default() => Err(Argument::Model.refused(
                front,
                "--base-link, --tip-link and --tip-point name a chain of the URDF given with --model: give it",
            )),
            _ => Ok(()),
        }
    }
}

/// Exports the calibration file `calibration` as `request` asks.
pub fn run(front: Front, calibration: &str, request: &Request) -> anyhow::Result<Exported> {
    request.check(front)?;
    match (request.format, &request.model) {
        (Format::Urdf, model) => urdf_export(front, calibration, model.as_deref(), request),
        (format, Some(model)) => ur_export(front, calibration, model, format, request),
        (_, None) => unreachable!("checked: a UR format names its model"),
    }
}

/// The calibration file `calibration` with the request's working tool, if
/// any, and that tool's change.
fn load_with_tool(
    front: Front,
    calibration: &str,
    request: &Request,
) -> anyhow::Result<(Calibration, Option<ToolChange>)> {
    let loaded = load_calibration(calibration)?;
    Ok(match &request.tool {
        None => (loaded, None),
        Some(tool) => {
            let change = tool.apply(front, &loaded)?;
            (change.calibration.clone(), Some(change))
        }
    })
}

/// A URDF: written into `model`, or generated.
fn urdf_export(
    front: Front,
    calibration: &str,
    model: Option<&str>,
    request: &Request,
) -> anyhow::Result<Exported> {
    let (loaded, tool) = load_with_tool(front, calibration, request)?;
    // The geometry refitted without the effects a URDF cannot carry, when the
    // calibration has one.
    let held = geometry_only(&loaded, Format::Urdf.called());
    let cal = &held.calibration;
    let exported = match model {
        Some(m) => {
            let text = read_text(m, MODEL_FILE)?;
            if !urdf::is_urdf(m, &text) {
                return Err(Argument::Model
                    .refused(
                        front,
                        format!("{m} is not a URDF: export writes into the URDF the model was read from; leave out --model to generate a URDF from the calibration"),
                    )
                    .into());
            }
            let (parsed, mut converted) = urdf_chain(&text, m, &request.chain)?;
            if tool.is_some() {
                // The chain is the calibration's whatever tool it works with.
                converted.robot.tool = cal.nominal.tool;
            }
            urdf::export::into_urdf(cal, &parsed, &converted)?
        }
        None => {
            // A URDF's masses are the calibration's: never a negative one
            // (what a URDF reader refuses).
            if let Some(k) = cal
                .nominal
                .links
                .iter()
                .position(|l| l.mass.is_some_and(|m| m.mass < 0.0))
            {
                return Err(InputError::new(
                    calibration,
                    0,
                    0,
                    format!(
                        "link {} has a negative mass: no URDF is written with it",
                        k + 1
                    ),
                )
                .into());
            }
            urdf::export::generate(cal, calibration)
        }
    };
    read_back::check_urdf(&exported, cal).map_err(|e| anyhow::anyhow!("{calibration}: {e}"))?;
    Ok(Exported {
        text: exported.text,
        held,
        warnings: exported.warnings,
        tool,
    })
}

/// Universal Robots' deltas against the UR model `model`, in `format`.
fn ur_export(
    front: Front,
    calibration: &str,
    model: &str,
    format: Format,
    request: &Request,
) -> anyhow::Result<Exported> {
    let nominal = load_model_with(model, &request.chain)?;
    if !ur::is_ur_model(&nominal) {
        return Err(Argument::Model
            .refused(
                front,
                format!("--format ur-deltas and ur-calibration: {model} is not a Universal Robots model (named `ur` and a digit, standard D-H, six revolute joints)"),
            )
            .into());
    }
    let (loaded, tool) = load_with_tool(front, calibration, request)?;
    let held = geometry_only(&loaded, format.called());
    let cal = &held.calibration;
    let robot = cal.calibrated();
    if robot.dof() != ur::JOINTS || robot.links.iter().any(|l| l.joint != JointType::Revolute) {
        return Err(Argument::Calibration
            .refused(
                front,
                format!("--format ur-deltas and ur-calibration: {calibration} is not of a six-joint revolute arm"),
            )
            .into());
    }
    ur::require_same_type(&cal.nominal, &nominal, calibration)?;
    // The arm to the robot's flange: the measured (or working) tool's offset
    // goes to the TCP the file states, never into the arm's links.
    let arm = WorkingTool {
        frame: Frame::identity(),
    }
    .apply(cal)
    .calibration
    .calibrated();
    let exported = ur::export_deltas(&arm, &robot, &nominal.robot);
    let text = match format {
        Format::UrDeltas => ur::deltas_yaml(&exported, calibration),
        _ => ur::ur_calibration_yaml(&exported, calibration),
    };
    let read = match format {
        Format::UrDeltas => read_back::check(
            &exported,
            &arm,
            &robot,
            read_back::deltas_reader(&text, &nominal.robot)?,
        ),
        _ => read_back::check(
            &exported,
            &arm,
            &robot,
            read_back::description_reader(&text)?,
        ),
    };
    read.map_err(|why| anyhow::anyhow!("{calibration}: {why}; nothing written"))?;
    Ok(Exported {
        text,
        held,
        warnings: Vec::new(),
        tool,
    })
}
