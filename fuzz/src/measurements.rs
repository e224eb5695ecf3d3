//! `measurements_csv`: the measurement CSV reader, `parse_measurements`, and
//! the joint-readings reader on the same code, `parse_joints`.
//!
//! The input's first byte chooses the model the text is read against
//! ([`crate::models`]: PUMA 560 in inches, 9-joint TALOS, TIAGo with a
//! prismatic lift, a one-joint prismatic model in mm and degrees); the rest is
//! the file, as UTF-8 (invalid sequences replaced, as a reader of the bytes
//! would have refused them).
//!
//! Asserts, for every input: no panic (both readers promise "never panics,
//! whatever the text"); a refusal names a place in the text (a line of the
//! text, or the line after the last, and a character column at most one past
//! the end of that line), or line 0 and column 0; an accepted file has at
//! least one row, rows in increasing line order within the text, exactly one
//! joint value per model joint, finite values everywhere, and each measured
//! orientation a unit quaternion. An accepted session without a tracker
//! (`point`, `plane` columns, distance lines) keeps its promises too: every
//! row names a point or plane that exists, every point is named by at least
//! two rows and every plane by at least three (the counts the constraints
//! state are the rows'), and every distance joins two different points with a
//! finite positive length and uncertainty.

use armcal::io::measurements::{parse_joints, parse_measurements};
use armcal::session::constraints::MIN_PLANE_TOUCHES;
use armcal::session::input_error::{InputError, ends_line};
use armcal::session::measurements::Measurements;
use armcal::session::observation::Contact;

/// The harness; see [the module](self). Returns whether both readers
/// accepted the file (for the tests of the seeds).
pub fn run(data: &[u8]) -> bool {
    let Some((&selector, text)) = data.split_first() else {
        return false;
    };
    let models = crate::models();
    let model = &models[usize::from(selector) % models.len()];
    let text = String::from_utf8_lossy(text);
    let lines = lines(&text).len();
    let dof = model.dof();
    let mut accepted = true;
    match parse_measurements(&text, "fuzz.csv", model) {
        Err(e) => {
            check_place(&e, &text);
            accepted = false;
        }
        Ok(m) => {
            assert!(!m.poses.is_empty(), "accepted without a pose");
            assert_eq!(
                (m.lines.len(), m.times.len()),
                (m.poses.len(), m.poses.len())
            );
            let mut last_line = 0;
            for ((p, &line), t) in m.poses.iter().zip(&m.lines).zip(&m.times) {
                assert!(line > last_line && line <= lines, "line {line}");
                last_line = line;
                assert_eq!(p.q.len(), dof);
                assert!(p.q.iter().all(|x| x.is_finite()), "{p:?}");
                assert!(p.position.iter().all(|x| x.is_finite()), "{p:?}");
                if let Some(o) = &p.orientation {
                    let n = o.as_ref().norm();
                    assert!((n - 1.0).abs() < 1e-9, "orientation of norm {n}: {p:?}");
                }
                let c = &p.context;
                for v in [*t, c.temperature, c.payload].into_iter().flatten() {
                    assert!(v.is_finite(), "{p:?}");
                }
            }
            check_constraints(&m);
        }
    }
    match parse_joints(&text, "fuzz.csv", &model.robot, &model.units) {
        Err(e) => {
            check_place(&e, &text);
            accepted = false;
        }
        Ok(rows) => {
            assert!(!rows.rows.is_empty(), "accepted without a row");
            let mut last_line = 0;
            for r in &rows.rows {
                assert!(r.line > last_line && r.line <= lines, "line {}", r.line);
                last_line = r.line;
                assert_eq!(r.q.len(), dof);
                assert!(r.q.iter().all(|x| x.is_finite()), "{r:?}");
                for v in [r.t, r.temp, r.load].into_iter().flatten() {
                    assert!(v.is_finite(), "{r:?}");
                }
            }
        }
    }
    accepted
}

/// An accepted session's points, planes and distances are consistent with
/// its rows: see [the module](self).
fn check_constraints(m: &Measurements) {
    let c = &m.constraints;
    let mut point_rows = vec![0; c.points.len()];
    let mut plane_rows = vec![0; c.planes.len()];
    for p in &m.poses {
        match p.contact {
            Contact::Measured => assert!(c.is_empty(), "a measured row in a constraint file"),
            Contact::Point(k) => point_rows[k] += 1,
            Contact::Plane(k) => plane_rows[k] += 1,
        }
    }
    for (named, rows) in c.points.iter().zip(&point_rows) {
        assert_eq!(named.rows, *rows, "{named:?}");
        assert!(*rows >= 2, "a point named by {rows} row(s): {named:?}");
    }
    for (named, rows) in c.planes.iter().zip(&plane_rows) {
        assert_eq!(named.rows, *rows, "{named:?}");
        assert!(
            *rows >= MIN_PLANE_TOUCHES,
            "a plane touched {rows} time(s): {named:?}"
        );
    }
    for d in &c.distances {
        let [a, b] = d.points;
        assert!(a != b && a < c.points.len() && b < c.points.len(), "{d:?}");
        assert!(d.length.is_finite() && d.length > 0.0, "{d:?}");
        assert!(d.std.is_finite() && d.std > 0.0, "{d:?}");
    }
}

/// A refusal names a place in `text`: see [the module](self).
pub fn check_place(e: &InputError, text: &str) {
    if e.line == 0 {
        assert_eq!(e.column, 0, "{e}");
        return;
    }
    let lines = lines(text);
    assert!(
        e.line <= lines.len() + 1,
        "{e}: beyond the text's {} lines",
        lines.len()
    );
    assert!(e.column >= 1, "{e}");
    let width = lines.get(e.line - 1).map_or(0, |l| l.chars().count());
    assert!(
        e.column <= width + 1,
        "{e}: column beyond the {width} characters of line {}",
        e.line
    );
}

/// The lines of `text`, without their ends, as the readers count them
/// (`armcal::session::input_error::ends_line`: at `\n`, or at a `\r` that no `\n`
/// follows).
pub fn lines(text: &str) -> Vec<&str> {
    let bytes = text.as_bytes();
    let mut lines = Vec::new();
    let mut start = 0;
    for i in 0..bytes.len() {
        if ends_line(bytes, i) {
            // The `\r` of `\r\n` is the last character of its line.
            lines.push(&text[start..i]);
            start = i + 1;
        }
    }
    lines.push(&text[start..]);
    lines
}
