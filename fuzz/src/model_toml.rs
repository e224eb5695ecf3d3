//! `model_toml`: the robot model reader, `parse_model`.
//!
//! The input is the file, as UTF-8 (invalid sequences replaced).
//!
//! Asserts, for every input: no panic ("never panics, whatever the text"); a
//! refusal names a place in the text (as for the measurement reader); an
//! accepted model has 1 to `MAX_JOINTS` joints, finite parameters, limits,
//! masses, frames and gravity, ordered limits (low ≤ high) and non-negative
//! masses; and it can be written as the calibration file of its nominal
//! parameters (what `armcal identify --out` would write for it): the file
//! encodes and decodes to the same calibration.

use armcal::io::model_file::parse_model;
use armcal_shared::compensation::Task;
use armcal_shared::{Calibration, MAX_JOINTS};

/// The harness; see [the module](self). Returns whether the model was
/// accepted (for the tests of the seeds).
pub fn run(data: &[u8]) -> bool {
    let text = String::from_utf8_lossy(data);
    let model = match parse_model(&text, "fuzz.toml") {
        Err(e) => {
            // The reader strips a byte-order mark before it counts places.
            let counted = text.strip_prefix('\u{feff}').unwrap_or(&text);
            crate::measurements::check_place(&e, counted);
            return false;
        }
        Ok(model) => model,
    };
    let robot = &model.robot;
    assert!(
        (1..=MAX_JOINTS).contains(&robot.dof()),
        "{} joints",
        robot.dof()
    );
    let finite = |xs: &[f64]| xs.iter().all(|x| x.is_finite());
    for l in &robot.links {
        assert!(finite(&[l.theta, l.s, l.a, l.alpha]), "{l:?}");
        if let Some([lo, hi]) = l.limits {
            assert!(finite(&[lo, hi]) && lo <= hi, "{l:?}");
        }
        if let Some(m) = l.mass {
            assert!(m.mass.is_finite() && m.mass >= 0.0, "{l:?}");
            assert!(finite(m.com.as_slice()), "{l:?}");
        }
    }
    for f in [&robot.base, &robot.tool] {
        assert!(
            finite(f.xyz.as_slice()) && finite(f.rpy.as_slice()),
            "{f:?}"
        );
    }
    if let Some(g) = &robot.gravity {
        assert!(finite(g.as_slice()), "{g:?}");
    }
    let cal = Calibration::nominal(robot.clone(), Task::Pose, model.units);
    let file = match cal.to_bytes() {
        Ok(file) => file,
        Err(e) => panic!("an accepted model's calibration does not encode: {e}"),
    };
    assert_eq!(Calibration::decode(&file), Ok(cal));
    true
}
