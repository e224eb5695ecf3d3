//! Where a calibration is used outside what it was identified on: the warnings
//! of `armcal predict`, `compensate` and `stream` (and of the Python package).
//!
//! A calibration records the range of each joint, and of the temperature and
//! payload when its session had them ([`armcal_shared::ranges`], file format
//! version 4). A row of joint readings (or nominal commands) beyond those
//! ranges is computed all the same, but there the identified errors and
//! effects are an extrapolation the data never tested, and the calibration
//! can be worse than the nominal model. [`check`] goes once over a joints file
//! and gives one warning per quantity outside: how many rows, how far beyond at
//! worst, the first few rows. It also names a condition the calibration's
//! effects depend on that the file does not give (a `temp` column for thermal
//! expansion; a `load` column for joint compliance identified under payloads),
//! with the value assumed instead. A calibration that does not record its
//! ranges (format versions 2 and 3) gets one note saying so.
//!
//! Convention: the rows are the values as given (readings for `predict`,
//! nominal commands for `compensate` and `stream`; a correction moves a
//! command by the identified errors, milliradians, not what this is about). A
//! value on a bound is inside.
//!
//! Precision: rows given as float32 (the Python package's arrays) are held
//! to the ranges at float32's resolution ([`Resolution`]): a value on a bound,
//! rounded to float32, may lie beyond it by half a float32 step, and is not
//! named for that.
//!
//! Units: the calibration's model units for joints (its angle unit for a
//! revolute joint, its length unit for a prismatic one), °C and kg for the
//! conditions.

use armcal_shared::Calibration;
use armcal_shared::effects::Effect;
use armcal_shared::ranges::Interval;

use crate::session::joints::{JointRow, JointRows};

/// How many rows a warning names before `…`.
pub const ROWS_NAMED: usize = 5;

/// How the rows of a joints input are named in a warning.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowNames {
    /// A CSV file: its rows by line, its conditions as columns.
    FileLines,
    /// numpy arrays (the Python package): rows counted from 0, conditions as
    /// the `temp=` and `load=` arrays.
    ArrayRows,
}

impl RowNames {
    /// `lines 4, 7, 9` or `rows 3, 6, 8`, the first [`ROWS_NAMED`] of `lines`.
    pub fn list(self, lines: &[usize], total: usize) -> String {
        let (word, from) = match self {
            Self::FileLines => ("line", 0),
            Self::ArrayRows => ("row", 1),
        };
        let named: Vec<String> = lines
            .iter()
            .take(ROWS_NAMED)
            .map(|l| (l - from).to_string())
            .collect();
        format!(
            "{word}{} {}{}",
            if total == 1 { "" } else { "s" },
            named.join(", "),
            if total > named.len() { ", …" } else { "" }
        )
    }

    /// What a condition is in this input: a column or an array.
    fn holder(self) -> &'static str {
        match self {
            Self::FileLines => "column",
            Self::ArrayRows => "array",
        }
    }
}

/// The precision the values of a quantity were given in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Resolution {
    /// As they are (a file's decimals, float64 arrays): held to the bounds.
    #[default]
    Exact,
    /// Rounded to float32 in the model's units (float32 arrays): held to the
    /// bounds as rounded to float32 the same way, so that a value given on a
    /// bound is inside.
    Float32,
}

/// The precision of each quantity of a joints input: the joint readings,
/// the temperatures and the payloads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Resolutions {
    /// Of the joint readings.
    pub joints: Resolution,
    /// Of the temperatures.
    pub temp: Resolution,
    /// Of the payloads.
    pub load: Resolution,
}

impl Resolutions {
    /// The resolution of `quantity`'s values.
    fn of(self, quantity: Quantity) -> Resolution {
        match quantity {
            Quantity::Joint(_) => self.joints,
            Quantity::Temperature => self.temp,
            Quantity::Load => self.load,
        }
    }
}

/// A quantity a calibration records the range of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Quantity {
    /// Joint `m`, 0-based.
    Joint(usize),
    /// The row's temperature, °C.
    Temperature,
    /// The row's payload, kg.
    Load,
}

impl Quantity {
    /// The column's name in a joints file.
    fn name(self) -> String {
        match self {
            Self::Joint(m) => format!("q{}", m + 1),
            Self::Temperature => "temp".into(),
            Self::Load => "load".into(),
        }
    }

    /// The row's value, SI.
    fn value(self, row: &JointRow) -> Option<f64> {
        match self {
            Self::Joint(m) => row.q.get(m).copied(),
            Self::Temperature => row.temp,
            Self::Load => row.load,
        }
    }

    /// `x` in the calibration's units, SI.
    fn to_si(self, cal: &Calibration, x: f64) -> f64 {
        match self {
            Self::Joint(m) => cal.units.joint_to_si(cal.nominal.links[m].joint, x),
            Self::Temperature | Self::Load => x,
        }
    }

    /// `range` (SI) as values given at `resolution` state it: for float32,
    /// each bound rounded to float32 in the calibration's units where that
    /// widens it. Rounding is monotone, so a value within the range rounds
    /// to within the rounded bounds.
    fn held_to(
        self,
        cal: &Calibration,
        range: &Interval<f64>,
        resolution: Resolution,
    ) -> Interval<f64> {
        match resolution {
            Resolution::Exact => *range,
            Resolution::Float32 => {
                let rounded = |x: f64| {
                    let (in_units, _) = self.in_units(cal, x);
                    self.to_si(cal, f64::from(in_units as f32))
                };
                Interval {
                    min: range.min.min(rounded(range.min)),
                    max: range.max.max(rounded(range.max)),
                }
            }
        }
    }

    /// A value (SI) in the calibration's units, and their name.
    fn in_units(self, cal: &Calibration, x: f64) -> (f64, &'static str) {
        match self {
            Self::Joint(m) => {
                let joint = cal.nominal.links[m].joint;
                let unit = match joint {
                    armcal_shared::JointType::Revolute => cal.units.angle.name(),
                    armcal_shared::JointType::Prismatic => cal.units.length.name(),
                };
                (cal.units.joint_from_si(joint, x), unit)
            }
            Self::Temperature => (x, "°C"),
            Self::Load => (x, "kg"),
        }
    }
}

/// `x` to four significant figures, without trailing zeros.
fn figure(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let decimals = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let s = format!("{x:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" { "0".into() } else { s }
}

/// The rows of `rows` whose `quantity` lies outside `range`: a warning naming
/// their count, the worst excess and the first rows; `None` when every row is
/// inside.
fn beyond(
    cal: &Calibration,
    rows: &JointRows,
    names: RowNames,
    quantity: Quantity,
    range: &Interval<f64>,
    resolution: Resolution,
) -> Option<String> {
    let held = quantity.held_to(cal, range, resolution);
    let mut lines = Vec::new();
    let mut worst = 0.0f64;
    for row in &rows.rows {
        if let Some(x) = quantity.value(row)
            && held.excludes(x)
        {
            lines.push(row.line);
            worst = worst.max(held.excess(x));
        }
    }
    if lines.is_empty() {
        return None;
    }
    // The excess in the model's units: a length or angle difference converts
    // as the values do (no offsets in these units).
    let (excess, unit) = quantity.in_units(cal, worst);
    let (min, _) = quantity.in_units(cal, range.min);
    let (max, _) = quantity.in_units(cal, range.max);
    Some(format!(
        "{}: {} outside the range the calibration was identified on ({} to {} {unit}) on {} of {} rows, at worst {} {unit} beyond ({}): the calibration extrapolates there",
        rows.file,
        quantity.name(),
        figure(min),
        figure(max),
        lines.len(),
        rows.rows.len(),
        figure(excess),
        names.list(&lines, lines.len()),
    ))
}

/// A condition the calibration's effects depend on that some rows do not
/// give: which effect, what is assumed instead, and the range identified.
fn missing(
    cal: &Calibration,
    rows: &JointRows,
    names: RowNames,
    quantity: Quantity,
) -> Option<String> {
    let (effect, assumed, identified) = match quantity {
        Quantity::Temperature => {
            let (_, reference) = cal.effects.iter().find_map(Effect::thermal_expansion)?;
            let identified = cal.ranges.as_ref().and_then(|r| r.temperature);
            ("thermal expansion", reference, identified)
        }
        Quantity::Load => {
            cal.effects
                .iter()
                .find(|e| matches!(e, Effect::JointCompliance { .. }))?;
            let identified = cal.ranges.as_ref().and_then(|r| r.load);
            // A compliance identified without payloads was identified at 0 kg,
            // what a row without one assumes: nothing to say.
            if cal.ranges.is_some() && identified.is_none() {
                return None;
            }
            ("joint compliance", 0.0, identified)
        }
        Quantity::Joint(_) => return None,
    };
    let lines: Vec<usize> = rows
        .rows
        .iter()
        .filter(|r| quantity.value(r).is_none())
        .map(|r| r.line)
        .collect();
    if lines.is_empty() {
        return None;
    }
    let name = quantity.name();
    let (_, unit) = quantity.in_units(cal, 0.0);
    let given = rows.columns_used.contains(&name);
    let whom = if given {
        format!(
            "`{name}` empty on {} of {} rows ({}): {} {unit} assumed there",
            lines.len(),
            rows.rows.len(),
            names.list(&lines, lines.len()),
            figure(assumed)
        )
    } else {
        format!(
            "no `{name}` {}: {} {unit} assumed for every row",
            names.holder(),
            figure(assumed)
        )
    };
    let range = identified
        .map(|r| {
            format!(
                " (identified at {} to {} {unit})",
                figure(r.min),
                figure(r.max)
            )
        })
        .unwrap_or_default();
    Some(format!(
        "{}: {whom}, the calibration's {effect} needs it{range}",
        rows.file
    ))
}

/// The warnings of using `cal` on `rows` (see [the module](self)): one per
/// quantity outside the identified ranges, one per condition an effect needs
/// that rows lack, or one note that the calibration does not record its
/// ranges. Empty when the rows lie within what the calibration was
/// identified on.
pub fn check(cal: &Calibration, rows: &JointRows, names: RowNames) -> Vec<String> {
    check_at(cal, rows, names, Resolutions::default())
}

/// [`check`] of rows whose quantities were given at `resolutions`.
pub fn check_at(
    cal: &Calibration,
    rows: &JointRows,
    names: RowNames,
    resolutions: Resolutions,
) -> Vec<String> {
    let mut out = Vec::new();
    match &cal.ranges {
        Some(ranges) => {
            let joints = ranges
                .joints
                .iter()
                .enumerate()
                .map(|(m, r)| (Quantity::Joint(m), r));
            let conditions = [
                (Quantity::Temperature, &ranges.temperature),
                (Quantity::Load, &ranges.load),
            ];
            let conditions = conditions
                .iter()
                .filter_map(|(q, r)| r.as_ref().map(|r| (*q, r)));
            out.extend(
                joints
                    .chain(conditions)
                    .filter_map(|(q, r)| beyond(cal, rows, names, q, r, resolutions.of(q))),
            );
        }
        None if !rows.rows.is_empty() => out.push(format!(
            "{}: the calibration does not record the ranges it was identified on (a file written before format version 4): the rows are not checked against them",
            rows.file
        )),
        None => {}
    }
    out.extend(
        [Quantity::Temperature, Quantity::Load]
            .into_iter()
            .filter_map(|q| missing(cal, rows, names, q)),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::measurements::parse_joints;
    use crate::io::model_file::parse_model;
    use armcal_shared::compensation::Task;
    use armcal_shared::ranges::Ranges;

    /// A two-joint arm in mm and degrees (a revolute joint and a prismatic
    /// one), identified on joint 1 within ±30° and joint 2 within 0–200 mm,
    /// at 20–30 °C and 0–5 kg, with a thermal expansion (reference 25 °C) and
    /// a joint compliance.
    fn calibration() -> Calibration {
        let model = parse_model(
            "name = \"rp\"\nconvention = \"mdh\"\nlength_unit = \"mm\"\nangle_unit = \"deg\"\n\
             [[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 100\na = 0\nalpha = 0\n\
             [[joint]]\ntype = \"prismatic\"\ntheta = 0\ns = 0\na = 300\nalpha = 90\n",
            "rp.toml",
        )
        .unwrap();
        let mut cal = Calibration::nominal(model.robot, Task::Position, model.units);
        let deg = 30f64.to_radians();
        cal.ranges = Some(Ranges::of([
            (&[-deg, 0.0][..], Some(20.0), Some(0.0)),
            (&[deg, 0.2][..], Some(30.0), Some(5.0)),
        ]));
        cal.effects
            .push(Effect::ThermalExpansion {
                coefficient: 2.3e-5,
                reference: 25.0,
            })
            .unwrap();
        cal.effects
            .push(Effect::JointCompliance {
                joint: 0,
                compliance: 1e-5,
            })
            .unwrap();
        cal
    }

    fn rows(cal: &Calibration, text: &str) -> JointRows {
        parse_joints(text, "j.csv", &cal.nominal, &cal.units).unwrap()
    }

    /// Rows within the ranges, with their conditions: nothing to say.
    #[test]
    fn rows_inside_the_ranges_are_not_named() {
        let cal = calibration();
        let r = rows(
            &cal,
            "q1,q2,temp,load\n-30,0,20,0\n30,200,30,5\n0,100,25,2\n",
        );
        assert_eq!(check(&cal, &r, RowNames::FileLines), Vec::<String>::new());
    }

    /// Joint 1 beyond ±30° by 1 rad (57.3°) at worst, joint 2 beyond 200 mm,
    /// 140 °C and 4,000 kg: one warning each, with the count, the worst
    /// excess in the model's units and the first lines.
    #[test]
    fn rows_beyond_the_ranges_are_named_with_the_excess() {
        let cal = calibration();
        let worst = 30.0 + 1f64.to_degrees();
        let text = format!(
            "q1,q2,temp,load\n0,100,25,1\n{worst},100,25,1\n-40,250,140,4000\n31,100,25,1\n"
        );
        let w = check(&cal, &rows(&cal, &text), RowNames::FileLines);
        assert_eq!(w.len(), 4, "{w:#?}");
        assert_eq!(
            w[0],
            "j.csv: q1 outside the range the calibration was identified on (-30 to 30 deg) on 3 of 4 rows, at worst 57.3 deg beyond (lines 3, 4, 5): the calibration extrapolates there"
        );
        assert!(
            w[1].contains("q2 outside")
                && w[1].contains("(0 to 200 mm) on 1 of 4 rows, at worst 50 mm beyond (line 4)"),
            "{}",
            w[1]
        );
        assert!(
            w[2].contains("temp outside")
                && w[2].contains("(20 to 30 °C)")
                && w[2].contains("at worst 110 °C beyond"),
            "{}",
            w[2]
        );
        assert!(
            w[3].contains("load outside") && w[3].contains("at worst 3995 kg beyond"),
            "{}",
            w[3]
        );
        // As numpy rows: counted from 0.
        let w = check(&cal, &rows(&cal, &text), RowNames::ArrayRows);
        assert!(w[0].contains("(rows 2, 3, 4)"), "{}", w[0]);
    }

    /// Joint 1 identified up to 10.1° and the temperature up to 30.1 °C,
    /// values float32 rounds up (10.1000004°, 30.1000004 °C): rows at those
    /// bounds given as float32 are named when held to the exact bounds, not
    /// at float32's resolution; a float32 step beyond is named at either.
    #[test]
    fn float32_values_on_a_bound_are_inside_at_float32_resolution() {
        let mut cal = calibration();
        let (q1, temp) = (10.1f64, 30.1f64);
        cal.ranges = Some(Ranges::of([
            (&[-q1.to_radians(), 0.0][..], Some(20.0), Some(0.0)),
            (&[q1.to_radians(), 0.2][..], Some(temp), Some(5.0)),
        ]));
        let as_float32 = |x: f64| f64::from(x as f32);
        let step_beyond = |x: f64| f64::from(f32::from_bits((x as f32).to_bits() + 1));
        assert!(as_float32(q1) > q1 && as_float32(temp) > temp);
        let float32 = Resolutions {
            joints: Resolution::Float32,
            temp: Resolution::Float32,
            load: Resolution::Exact,
        };
        let on_bounds = rows(
            &cal,
            &format!(
                "q1,q2,temp,load\n{},100,{},1\n",
                as_float32(q1),
                as_float32(temp)
            ),
        );
        let exact = check(&cal, &on_bounds, RowNames::ArrayRows);
        assert_eq!(exact.len(), 2, "{exact:#?}");
        let w = check_at(&cal, &on_bounds, RowNames::ArrayRows, float32);
        assert_eq!(w, Vec::<String>::new());
        let beyond = rows(
            &cal,
            &format!(
                "q1,q2,temp,load\n{},100,{},1\n",
                step_beyond(q1),
                step_beyond(temp)
            ),
        );
        let w = check_at(&cal, &beyond, RowNames::ArrayRows, float32);
        assert_eq!(w.len(), 2, "{w:#?}");
        assert!(w[0].starts_with("j.csv: q1 outside"), "{}", w[0]);
        assert!(w[1].starts_with("j.csv: temp outside"), "{}", w[1]);
    }

    /// More rows outside than are named: the first five, then `…`.
    #[test]
    fn many_rows_outside_name_the_first_five() {
        let cal = calibration();
        let mut text = "q1,q2,temp,load\n".to_string();
        for i in 0..8 {
            text.push_str(&format!("{},100,25,1\n", 31 + i));
        }
        let w = check(&cal, &rows(&cal, &text), RowNames::FileLines);
        assert!(
            w[0].contains("on 8 of 8 rows, at worst 8 deg beyond (lines 2, 3, 4, 5, 6, …)"),
            "{}",
            w[0]
        );
    }

    /// No `temp` column with a thermal expansion: its reference temperature
    /// assumed, said once; a `load` column with empty cells under a
    /// compliance identified under payloads: those rows named.
    #[test]
    fn missing_conditions_are_named_with_the_value_assumed() {
        let cal = calibration();
        let w = check(
            &cal,
            &rows(&cal, "q1,q2,load\n0,100,1\n0,100,\n"),
            RowNames::FileLines,
        );
        assert_eq!(
            w,
            [
                "j.csv: no `temp` column: 25 °C assumed for every row, the calibration's thermal expansion needs it (identified at 20 to 30 °C)",
                "j.csv: `load` empty on 1 of 2 rows (line 3): 0 kg assumed there, the calibration's joint compliance needs it (identified at 0 to 5 kg)"
            ]
        );
        // A compliance identified without payloads: 0 kg, as there.
        let mut without = calibration();
        without.ranges.as_mut().unwrap().load = None;
        without.effects.clear();
        without
            .effects
            .push(Effect::JointCompliance {
                joint: 0,
                compliance: 1e-5,
            })
            .unwrap();
        let w = check(
            &without,
            &rows(&without, "q1,q2\n0,100\n"),
            RowNames::ArrayRows,
        );
        assert_eq!(w, Vec::<String>::new());
    }

    /// A calibration without ranges (format versions 2 and 3): one note.
    #[test]
    fn unknown_ranges_are_said_once() {
        let mut cal = calibration();
        cal.ranges = None;
        cal.effects.clear();
        let w = check(
            &cal,
            &rows(&cal, "q1,q2\n500,100\n600,100\n"),
            RowNames::FileLines,
        );
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("does not record the ranges"), "{}", w[0]);
    }

    #[test]
    fn figures_have_four_significant_digits() {
        assert_eq!(figure(57.295_779_5), "57.3");
        assert_eq!(figure(0.001_234_56), "0.001235");
        assert_eq!(figure(3995.0), "3995");
        assert_eq!(figure(-30.0), "-30");
        assert_eq!(figure(0.0), "0");
    }
}
