//! Numbers as armcal's summaries and reports print them: four significant
//! digits in fixed notation, lengths in the model's unit and in mm. SI in
//! (m), text out.

use armcal_shared::units::Units;

/// `x` to four significant digits, in fixed notation (`0.02000` mm, `0.0001081` m).
pub fn significant(x: f64) -> String {
    let decimals = if x.is_normal() {
        (3 - x.abs().log10().floor() as i32).max(0) as usize
    } else {
        4
    };
    format!("{x:.decimals$}")
}

/// A length `x` (m) as the summaries give it: in the model's unit, then in mm.
pub fn length_and_mm(u: &Units, x: f64) -> String {
    length_and_mm_of(u.length_from_si(x), &u.length.to_string(), x * 1e3)
}

/// A length as the summaries give it, from a report's two figures: `x` in
/// the model's `unit`, then `mm`.
pub fn length_and_mm_of(x: f64, unit: &str, mm: f64) -> String {
    format!("{x:.6} {unit} ({mm:.4} mm)")
}
