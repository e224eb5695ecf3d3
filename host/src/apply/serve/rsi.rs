//! KUKA RSI (RobotSensorInterface) over UDP: the controller's `<Rob>`
//! datagram read, the sensor's `<Sen>` answer written.
//!
//! Source of the format: ROS-Industrial's `kuka_experimental`,
//! `kuka_rsi_hw_interface` (`rsi_state.h` reads the controller's datagram,
//! `rsi_command.h` writes the answer, `krl/KR_C4/ros_rsi_ethernet.xml` is the
//! ETHERNET object's configuration: `DEF_RIst`, `DEF_RSol`, `DEF_AIPos`,
//! `DEF_ASPos`, `DEF_Delay` sent, `AK.A1`…`AK.A6` received, and
//! `ros_rsi.rsi.xml` wires them into an `AXISCORR` object). Every 4 ms
//! (`IPO_FAST`; 12 ms for `IPO`) the controller sends
//!
//! ```text
//! <Rob Type="KUKA">
//!   <RIst X=".." Y=".." Z=".." A=".." B=".." C=".."/>   actual Cartesian pose, mm and deg
//!   <RSol X=".." .. C=".."/>                           set-point Cartesian pose
//!   <AIPos A1=".." .. A6=".."/>                        actual axis positions, deg
//!   <ASPos A1=".." .. A6=".."/>                        set-point axis positions, deg
//!   <Delay D=".."/>                                    late answers counted by the controller
//!   <IPOC>4208163</IPOC>                               the cycle's time stamp, echoed
//! </Rob>
//! ```
//!
//! and the sensor answers within the cycle, as `rsi_command.h` prints it
//! (TinyXML's stream printing: one line, a space before `/>`, values as C++'s
//! `std::to_string(double)`, six decimals):
//!
//! ```text
//! <Sen Type="ImFree"><AK A1="0.012345" A2=".." .. A6=".." /><IPOC>4208163</IPOC></Sen>
//! ```
//!
//! `Type` is the `SENTYPE` of the ETHERNET object's configuration.
//!
//! Convention: `ASPos` is the controller's own interpolated set-point, the
//! nominal command; `AK` is the axis correction `AXISCORR` adds to it, in
//! degrees, absolute (the whole correction each cycle, `RSI_ON(#ABSOLUTE)`)
//! or relative (each cycle's increment, `RSI_ON(#RELATIVE)`). Axes `A1..An`
//! are the calibration's joints 1..n in order, all revolute.
//!
//! Safety of the reader: a datagram is at most [`MAX_DATAGRAM`] bytes
//! (`kuka_rsi_hw_interface` reads 1024); the XML is read by `quick-xml`,
//! which never expands entities or reads a DTD: a `<!DOCTYPE>` (the door of
//! an entity bomb) or an entity reference refuses the datagram, as does any
//! value that is not a finite number, a missing or repeated `ASPos` or
//! `IPOC`, or an axis beyond [`MAX_AXES`].

use std::fmt::Write as _;

use quick_xml::Reader;
use quick_xml::events::{BytesStart, Event};

/// The largest datagram read: 4 KiB, four times what the controller's
/// `<Rob>` with every element of `ros_rsi_ethernet.xml` needs.
pub const MAX_DATAGRAM: usize = 4096;

/// The most axes an `ASPos` may name (`A1`…`A12`; a KUKA robot has 6,
/// external axes are `E1`…`E6` and not corrected here).
pub const MAX_AXES: usize = 12;

/// Decimals of each `AK` value, as `std::to_string(double)` prints them.
pub const DECIMALS: usize = 6;

/// What armcal reads of one `<Rob>` datagram.
#[derive(Clone, Debug, PartialEq)]
pub struct Rob {
    /// The set-point axis positions `ASPos A1..An`, degrees, in axis order.
    pub aspos: Vec<f64>,
    /// The cycle's time stamp, to be echoed.
    pub ipoc: u64,
    /// The controller's count of late answers (`Delay D`), when sent.
    pub delay: Option<u64>,
}

/// Why a datagram is not a `<Rob>` armcal reads.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RobError {
    /// Larger than [`MAX_DATAGRAM`].
    #[error("a datagram of more than {MAX_DATAGRAM} bytes")]
    Oversized,
    /// Not well-formed XML, or text that is not UTF-8.
    #[error("not well-formed XML: {0}")]
    Xml(String),
    /// A `<!DOCTYPE>` or an entity reference: never expanded.
    #[error("a DOCTYPE or an entity reference (never expanded)")]
    Entity,
    /// The root element is not `<Rob>`.
    #[error("the root element is not <Rob>")]
    NotRob,
    /// An element armcal needs is missing or repeated.
    #[error("{0}")]
    Structure(&'static str),
    /// A value that is not a finite number (or an IPOC that is not an integer).
    #[error("{element} {attribute}: {value:?} is not a finite number")]
    Value {
        /// The element.
        element: &'static str,
        /// The attribute (or `text`).
        attribute: String,
        /// The value as sent (its first 32 bytes).
        value: String,
    },
}

/// Reads a `<Rob>` datagram (see [the module](self)).
pub fn parse(datagram: &[u8]) -> Result<Rob, RobError> {
    if datagram.len() > MAX_DATAGRAM {
        return Err(RobError::Oversized);
    }
    let mut reader = Reader::from_reader(datagram);
    let config = reader.config_mut();
    config.check_end_names = true;
    config.trim_text(true);
    let mut depth = 0usize;
    let mut root = false;
    let mut in_ipoc = false;
    let (mut aspos, mut ipoc, mut delay) = (None, None, None);
    loop {
        let event = reader
            .read_event()
            .map_err(|e| RobError::Xml(e.to_string()))?;
        match event {
            Event::Start(e) if depth == 0 => {
                if root || e.name().as_ref() != "Rob" {
                    return Err(RobError::NotRob);
                }
                root = true;
                depth = 1;
            }
            Event::Empty(_) if depth == 0 => return Err(RobError::NotRob),
            Event::Start(e) => {
                depth += 1;
                if depth == 2 {
                    in_ipoc = element(&e, &mut aspos, &mut delay, &mut ipoc)?;
                }
            }
            Event::Empty(e) if depth == 1 => {
                element(&e, &mut aspos, &mut delay, &mut ipoc)?;
            }
            Event::End(_) => {
                depth = depth.saturating_sub(1);
                in_ipoc = false;
            }
            Event::Text(t) if in_ipoc && depth == 2 => {
                if ipoc.is_some() {
                    return Err(RobError::Structure("two IPOC"));
                }
                ipoc = Some(integer("IPOC", "text", &t)?);
            }
            Event::Text(t) if depth == 0 && !t.is_empty() => {
                return Err(RobError::Xml("text outside <Rob>".into()));
            }
            Event::DocType(_) | Event::GeneralRef(_) => return Err(RobError::Entity),
            Event::Eof if depth > 0 => {
                return Err(RobError::Xml("truncated: <Rob> not closed".into()));
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if !root {
        return Err(RobError::NotRob);
    }
    let aspos = aspos.ok_or(RobError::Structure("no ASPos"))?;
    let ipoc = ipoc.ok_or(RobError::Structure("no IPOC"))?;
    Ok(Rob { aspos, ipoc, delay })
}

/// Reads one child of `<Rob>`: `ASPos` (its axes), `Delay` (its `D`); for
/// `IPOC` returns true (its text follows). Others are skipped.
fn element(
    e: &BytesStart<'_>,
    aspos: &mut Option<Vec<f64>>,
    delay: &mut Option<u64>,
    ipoc: &mut Option<u64>,
) -> Result<bool, RobError> {
    match e.name().as_ref() {
        "ASPos" => {
            if aspos.is_some() {
                return Err(RobError::Structure("two ASPos"));
            }
            *aspos = Some(axes(e)?);
            Ok(false)
        }
        "Delay" => {
            for a in e.attributes() {
                let a = a.map_err(|e| RobError::Xml(e.to_string()))?;
                if a.key.as_ref() == "D" {
                    *delay = Some(integer("Delay", "D", &a.value)?);
                }
            }
            Ok(false)
        }
        "IPOC" => Ok(ipoc.is_none()),
        _ => Ok(false),
    }
}

/// The axes `A1..An` of an `ASPos`, in order: every one from `A1` up to the
/// last present, each once.
fn axes(e: &BytesStart<'_>) -> Result<Vec<f64>, RobError> {
    let mut values = [None; MAX_AXES];
    for a in e.attributes() {
        let a = a.map_err(|e| RobError::Xml(e.to_string()))?;
        let key = a.key.as_ref();
        let Some(index) = key.strip_prefix('A') else {
            continue;
        };
        let m = index
            .parse::<usize>()
            .ok()
            .filter(|m| (1..=MAX_AXES).contains(m))
            .ok_or(RobError::Structure("an ASPos axis beyond A12"))?;
        let attribute = key.to_owned();
        values[m - 1] = Some(number("ASPos", attribute, &a.value)?);
    }
    let n = values
        .iter()
        .rposition(Option::is_some)
        .map_or(0, |i| i + 1);
    if n == 0 {
        return Err(RobError::Structure("an ASPos without axes"));
    }
    values[..n]
        .iter()
        .map(|v| v.ok_or(RobError::Structure("an ASPos with an axis missing")))
        .collect()
}

fn shown(raw: &str) -> String {
    raw.chars().take(32).collect()
}

/// A finite number in decimal notation (`nan`, `inf` refused).
fn number(element: &'static str, attribute: String, raw: &str) -> Result<f64, RobError> {
    raw.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| RobError::Value {
            element,
            attribute,
            value: shown(raw),
        })
}

/// A non-negative integer.
fn integer(element: &'static str, attribute: &str, raw: &str) -> Result<u64, RobError> {
    raw.trim()
        .parse::<u64>()
        .ok()
        .ok_or_else(|| RobError::Value {
            element,
            attribute: attribute.to_owned(),
            value: shown(raw),
        })
}

/// The IPOC of a datagram [`parse`] refused, when one can be read: the
/// digits of the first `<IPOC>…</IPOC>` in its bytes (a linear scan, no
/// XML), so that a truncated or damaged datagram is still answered.
pub fn scan_ipoc(datagram: &[u8]) -> Option<u64> {
    let open = memchr::memmem::find(datagram, b"<IPOC>")? + b"<IPOC>".len();
    let len = memchr::memmem::find(&datagram[open..], b"</IPOC>")?;
    let text = std::str::from_utf8(&datagram[open..open + len]).ok()?;
    integer("IPOC", "text", text).ok()
}

/// The `<Sen>` answer: `Type` `sen_type`, the corrections `ak` (degrees,
/// axes `A1..An`) printed with [`DECIMALS`] decimals, the `ipoc` echoed;
/// written into `out` (cleared first).
pub fn write_sen(out: &mut String, sen_type: &str, ak: &[f64], ipoc: u64) {
    out.clear();
    let _ = write!(out, "<Sen Type=\"{sen_type}\"><AK");
    for (m, v) in ak.iter().enumerate() {
        let _ = write!(out, " A{}=\"{v:.DECIMALS$}\"", m + 1);
    }
    let _ = write!(out, " /><IPOC>{ipoc}</IPOC></Sen>");
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROB: &str = r#"<Rob Type="KUKA"><RIst X="445.0" Y="0.0" Z="890.0" A="0.0" B="90.0" C="0.0"/><RSol X="445.0" Y="0.0" Z="890.0" A="0.0" B="90.0" C="0.0"/><AIPos A1="0.0" A2="-90.0" A3="90.0" A4="0.0" A5="90.0" A6="0.0"/><ASPos A1="1.5" A2="-90.25" A3="90.0" A4="0.0" A5="90.0" A6="-3.125"/><Delay D="2"/><IPOC>4208163</IPOC></Rob>"#;

    /// The datagram kuka_rsi_hw_interface's controller sends is read: the
    /// set-point axes in order, the IPOC and the Delay.
    #[test]
    fn reads_the_controllers_datagram() {
        let rob = parse(ROB.as_bytes()).unwrap();
        assert_eq!(rob.aspos, vec![1.5, -90.25, 90.0, 0.0, 90.0, -3.125]);
        assert_eq!(rob.ipoc, 4_208_163);
        assert_eq!(rob.delay, Some(2));
        // Whitespace and line breaks between elements, as a pretty printer
        // writes them, read alike.
        let pretty = ROB.replace("><", ">\n  <");
        assert_eq!(parse(pretty.as_bytes()).unwrap(), rob);
    }

    /// The answer is rsi_command.h's, byte for byte in its layout.
    #[test]
    fn writes_the_answer_as_rsi_command_h() {
        let mut out = String::new();
        write_sen(
            &mut out,
            "ImFree",
            &[0.0123456, -1.0, 0.0, 2.5, 1e-9, -0.0000004],
            42,
        );
        assert_eq!(
            out,
            r#"<Sen Type="ImFree"><AK A1="0.012346" A2="-1.000000" A3="0.000000" A4="2.500000" A5="0.000000" A6="-0.000000" /><IPOC>42</IPOC></Sen>"#
        );
    }

    /// Each damaged datagram is refused, never read as something else, and
    /// its IPOC read where it still can be.
    #[test]
    fn refuses_damaged_datagrams() {
        let bomb = r#"<?xml version="1.0"?><!DOCTYPE Rob [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]><Rob><ASPos A1="&b;"/><IPOC>7</IPOC></Rob>"#;
        let cases: Vec<(String, RobError)> = vec![
            (bomb.into(), RobError::Entity),
            (
                ROB.replace("<IPOC>4208163</IPOC>", ""),
                RobError::Structure("no IPOC"),
            ),
            (ROB.replace("A6=\"-3.125\"", "A6=\"nan\""), {
                RobError::Value {
                    element: "ASPos",
                    attribute: "A6".into(),
                    value: "nan".into(),
                }
            }),
            (
                ROB.replace(
                    "A3=\"90.0\" A4=\"0.0\" A5=\"90.0\" A6=\"-3.125\"",
                    "A6=\"1\"",
                ),
                RobError::Structure("an ASPos with an axis missing"),
            ),
            (ROB.replace("Rob", "Sen"), RobError::NotRob),
            (
                ROB.replace("<Delay D=\"2\"/>", "<ASPos A1=\"1\"/>"),
                RobError::Structure("two ASPos"),
            ),
            (" ".repeat(MAX_DATAGRAM + 1), RobError::Oversized),
        ];
        for (text, want) in cases {
            assert_eq!(parse(text.as_bytes()), Err(want), "{text}");
        }
        // Truncated: not well-formed, its IPOC gone; cut after the IPOC: read.
        let cut = &ROB.as_bytes()[..ROB.len() - 10];
        assert!(matches!(parse(cut), Err(RobError::Xml(_))));
        assert_eq!(scan_ipoc(cut), None);
        let cut = &ROB.as_bytes()[..ROB.len() - 6];
        assert!(matches!(parse(cut), Err(RobError::Xml(_))));
        assert_eq!(scan_ipoc(cut), Some(4_208_163));
    }
}
