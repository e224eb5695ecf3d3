//! How armcal's reports are written, whatever they report: numbers as the
//! summaries give them ([`self::format`]), the HTML pages' head, style and escaping
//! ([`html`]), the scatter plots they draw as inline SVG ([`svg`]), and the
//! units every JSON report states ([`units`]).
//!
//! Nothing here knows a calibration: [`crate::calibration`] and
//! [`crate::apply`] both write with it, so it stands under both (the
//! test `layers::no_import_runs_back_up` keeps it so).

pub mod format;
pub mod html;
pub mod svg;
pub mod units;

/// A report (a verb's `#[derive(Serialize)]` outcome) as the JSON value
/// `--json` writes: its keys in alphabetical order, a float that is not
/// finite `null`.
pub fn to_json(report: &impl serde::Serialize) -> serde_json::Value {
    serde_json::to_value(report).expect("a report of numbers, strings and lists serialises")
}
