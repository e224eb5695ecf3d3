//! What an export that cannot carry effects (`armcal export --format urdf`,
//! `ur-deltas`, `ur-calibration`) receives, and what it says of it.
//!
//! A calibration of `armcal diagnose` may hold effects (compliance, encoder
//! scale, backlash, …) identified together with the geometry. Its geometry
//! alone is not the best geometry: what the effects explained, the geometry
//! fitted with them did not have to, and without them it predicts worse than a
//! geometry fitted alone. So such an export writes:
//!
//! - with effects and a geometric fallback ([`Calibration::geometric`], format
//!   version 5): the fallback, the geometric model refitted without any
//!   effect, and says so with its expected held-out error and the
//!   calibration's with its effects;
//! - with effects and no fallback (a file before version 5): the geometry
//!   fitted with the effects, with a warning that the effects are left out and
//!   that `armcal diagnose` run again gives the fallback;
//! - without effects: the calibration, and its expected held-out error when
//!   the file knows it ([`Calibration::held_out`]).
//!
//! Figures in the model's length unit, with mm beside when the unit is not mm.

use armcal_shared::Calibration;
use armcal_shared::effects::Effect;
use armcal_shared::units::{LengthUnit, Units};

use crate::report::format::significant;

/// The calibration a format without effects holds, and what to say of it.
#[derive(Clone, Debug, PartialEq)]
pub struct GeometryExport {
    /// The calibration to write: without effects, or (a file before version
    /// 5) with the effects the format will leave out.
    pub calibration: Calibration,
    /// A line for standard error: what the export holds and what it is
    /// expected to deliver held out; `None` when nothing is known to say.
    pub note: Option<String>,
    /// Whether the note is a warning (effects left out with the geometry
    /// fitted with them).
    pub warning: bool,
}

/// `x` m in the length unit of `units`, with mm beside when that is not mm:
/// `0.3300 mm`, `0.0003300 m (0.3300 mm)`.
pub fn length(units: &Units, x: f64) -> String {
    let unit = units.length;
    let here = format!("{} {}", significant(unit.from_si(x)), unit.name());
    if unit == LengthUnit::Mm {
        here
    } else {
        format!("{here} ({} mm)", significant(x * 1e3))
    }
}

/// `encoder scale of joint 2, thermal expansion`: effects as a sentence names them.
pub fn effect_names(effects: &[Effect<f64>]) -> String {
    effects
        .iter()
        .map(|e| {
            let name = e.name().replace('_', " ");
            match e.joint() {
                Some(j) => format!("{name} of joint {}", j + 1),
                None => name,
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// What `format` (`a URDF`, `UR deltas`, …: the subject of the note) holds
/// of `cal` (see the module header).
pub fn geometry_only(cal: &Calibration, format: &str) -> GeometryExport {
    let units = &cal.units;
    let expected = |h: Option<f64>| {
        h.map(|h| format!(", expected held-out error {}", length(units, h)))
            .unwrap_or_default()
    };
    if cal.effects.is_empty() {
        return GeometryExport {
            calibration: cal.clone(),
            note: cal.held_out.map(|h| {
                format!(
                    "{format} holds the calibration, expected held-out error {}",
                    length(units, h)
                )
            }),
            warning: false,
        };
    }
    let names = effect_names(&cal.effects);
    match cal.geometric_only() {
        Some(geometric) => {
            let with = cal
                .held_out
                .map(|h| format!("; the calibration with its effects: {}", length(units, h)))
                .unwrap_or_default();
            GeometryExport {
                note: Some(format!(
                    "{format} cannot carry the effects ({names}): it holds the geometry refitted without them{}{with}",
                    expected(geometric.held_out)
                )),
                calibration: geometric,
                warning: false,
            }
        }
        None => GeometryExport {
            calibration: cal.clone(),
            note: Some(format!(
                "{format} cannot carry the effects ({names}): they are left out, and it holds the geometry fitted together with them, which predicts worse without them than a geometry fitted alone; this calibration file (format version 4 or older) has no geometry fitted without them: run `armcal diagnose --out` again to get one"
            )),
            warning: true,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use armcal_shared::calibration::ParamError;
    use armcal_shared::compensation::Task;
    use armcal_shared::units::AngleUnit;
    use armcal_shared::{GeometricCalibration, Param};

    fn calibration(length: LengthUnit) -> Calibration {
        let robot = crate::io::model_file::load_model("ur5e")
            .expect("built-in")
            .robot;
        let units = Units {
            length,
            angle: AngleUnit::Rad,
        };
        let mut cal = Calibration::nominal(robot, Task::Position, units);
        cal.errors
            .push(ParamError {
                param: Param::Theta(1),
                error: 1e-3,
            })
            .unwrap();
        cal.held_out = Some(3.7e-4);
        cal
    }

    /// Each case: what is written and the note.
    #[test]
    fn the_fallback_is_written_with_its_figure() {
        let mut cal = calibration(LengthUnit::M);
        let plain = geometry_only(&cal, "a URDF");
        assert_eq!(plain.calibration, cal);
        assert_eq!(
            plain.note.as_deref(),
            Some("a URDF holds the calibration, expected held-out error 0.0003700 m (0.3700 mm)")
        );
        cal.effects
            .push(Effect::EncoderScale {
                joint: 1,
                scale: 1e-4,
            })
            .unwrap();
        let old = geometry_only(&cal, "a URDF");
        assert!(old.warning);
        assert_eq!(old.calibration, cal);
        assert!(old.note.unwrap().starts_with(
            "a URDF cannot carry the effects (encoder scale of joint 2): they are left out"
        ));
        let mut errors = cal.errors.clone();
        errors[0].error = 2e-3;
        cal.geometric = Some(GeometricCalibration {
            errors,
            held_out: Some(3.3e-4),
        });
        cal.units.length = LengthUnit::Mm;
        let new = geometry_only(&cal, "a URDF");
        assert!(!new.warning);
        assert!(new.calibration.effects.is_empty());
        assert_eq!(new.calibration.errors[0].error, 2e-3);
        assert_eq!(
            new.note.as_deref(),
            Some(
                "a URDF cannot carry the effects (encoder scale of joint 2): it holds the geometry refitted without them, expected held-out error 0.3300 mm; the calibration with its effects: 0.3700 mm"
            )
        );
        cal.held_out = None;
        cal.geometric = None;
        cal.effects.clear();
        assert_eq!(geometry_only(&cal, "a URDF").note, None);
    }
}
