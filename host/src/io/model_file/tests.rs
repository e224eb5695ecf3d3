//! Tests of the model-file reader: the built-in models, units, and every
//! refusal at its line and column.

use super::*;
use crate::io::builtin::MODELS;
use armcal_shared::units::{AngleUnit, LengthUnit};
use armcal_shared::{Convention, Frame, JointType, Link, MAX_JOINTS};
use nalgebra::Vector3;
use proptest::prelude::*;

/// A small valid model, m/rad; the refusal tests edit one line of it.
const GOOD: &str = r#"name = "arm"
convention = "dh"
length_unit = "m"
angle_unit = "rad"

[[joint]]
type = "revolute"
theta = 0.0
s = 0.1
a = 0.2
alpha = 1.5
"#;

/// `GOOD` with line `line` (1-based) replaced by `new` (which may hold several lines).
fn edit(line: usize, new: &str) -> String {
    let mut lines: Vec<&str> = GOOD.lines().collect();
    lines[line - 1] = new;
    lines.join("\n") + "\n"
}

/// Asserts that `text` is refused at exactly `line`:`column` of "bad.toml",
/// with a message that contains every one of `needles`.
#[track_caller]
fn refused(text: &str, line: usize, column: usize, needles: &[&str]) {
    let e = match parse_model(text, "bad.toml") {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e,
    };
    assert_eq!(e.file, "bad.toml");
    assert_eq!((e.line, e.column), (line, column), "{e}");
    assert!(
        e.to_string()
            .starts_with(&format!("bad.toml:{line}:{column}: ")),
        "{e}"
    );
    for needle in needles {
        assert!(e.message.contains(needle), "{e:?} does not name {needle:?}");
    }
}

fn close(a: f64, b: f64) -> bool {
    // One unit conversion (a multiplication or division) each side: a few ulp.
    (a - b).abs() <= 4.0 * f64::EPSILON * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn the_small_model_parses() {
    let m = parse_model(GOOD, "good.toml").unwrap();
    assert_eq!(m.name, "arm");
    assert_eq!(m.description, "");
    assert_eq!(m.source, "good.toml");
    assert_eq!(m.units, Units::SI);
    assert_eq!(m.dof(), 1);
    assert_eq!(m.robot.base, Frame::identity());
    assert_eq!(m.robot.tool, Frame::identity());
    assert_eq!(m.robot.gravity, None);
    assert_eq!(
        m.robot.links[0],
        Link::new(JointType::Revolute, 0.0, 0.1, 0.2, 1.5)
    );
}

/// Every built-in model parses, and `load_model` says it is built in.
#[test]
fn every_builtin_model_parses() {
    for b in MODELS {
        let m = parse_model(b.text, b.file).unwrap_or_else(|e| panic!("{e}"));
        assert!(m.dof() >= 6, "{}", b.name);
        let loaded = load_model(b.name).unwrap();
        assert_eq!(loaded.source, format!("built-in {}", b.name));
        assert_eq!(loaded.robot, m.robot);
    }
}

/// Mirman & Gupta's Table 1 in inches becomes metres (26 in = 0.6604 m), and
/// its radians are kept exactly as printed.
#[test]
// The paper prints 1.570796 and 3.141593, not pi/2 and pi: kept as printed.
#[allow(clippy::approx_constant)]
fn puma_table1_in_si() {
    let m = load_model("puma560").unwrap();
    assert_eq!(m.units.length, LengthUnit::In);
    assert_eq!(m.units.angle, AngleUnit::Rad);
    assert_eq!(m.robot.convention, Convention::Dh);
    let s = [0.6604, -0.2032, 0.0, 0.4318, 0.0, -0.05715];
    let a = [0.0, 0.4318, 0.0, 0.0, 0.0, 0.0];
    let alpha = [1.570796, 0.0, 1.570796, 1.570796, 1.570796, 3.141593];
    for (i, l) in m.robot.links.iter().enumerate() {
        assert_eq!(l.joint, JointType::Revolute);
        assert_eq!(l.theta, 0.0);
        assert!(close(l.s, s[i]), "s{} = {}", i + 1, l.s);
        assert!(close(l.a, a[i]), "a{} = {}", i + 1, l.a);
        assert_eq!(l.alpha, alpha[i]);
    }
}

/// The UR10e of UR's table and the figaroh UR10e model have the same D-H
/// lengths; masses and gravity are read in kg and m/s² unconverted.
#[test]
fn ur10e_matches_the_figaroh_model() {
    let ur = load_model("ur10e").unwrap();
    let fig = load_model("figaroh-ur10e-camera").unwrap();
    for (l, f) in ur.robot.links.iter().zip(&fig.robot.links) {
        assert_eq!((l.s, l.a), (f.s, f.a));
        assert!((l.alpha - f.alpha).abs() < 1e-12);
    }
    assert_eq!(ur.robot.gravity, Some(Vector3::new(0.0, 0.0, -9.81)));
    let m2 = ur.robot.links[1].mass.unwrap();
    assert_eq!(m2.mass, 13.051);
    assert_eq!(m2.com, Vector3::new(0.38, 0.0, 0.158));
    let ur5 = load_model("ur5e").unwrap();
    assert_eq!(ur5.robot.links[3].s, 0.1333);
    assert_eq!(ur5.robot.links[2].a, -0.3922);
}

/// A model written in mm and degrees parses to the same SI robot as its twin in
/// m and rad: every length (s, a, xyz, com, prismatic limits) goes through the
/// length unit, every angle (theta, alpha, rpy, revolute limits) through the
/// angle unit; mass and gravity are not converted.
#[test]
fn mm_deg_twin_equals_m_rad() {
    let m_rad = r#"name = "twin"
convention = "mdh"
length_unit = "m"
angle_unit = "rad"
gravity = [0.0, 0.0, -9.81]
[[joint]]
type = "revolute"
theta = 1.5707963267948966
s = 0.425
a = -0.3922
alpha = -0.5235987755982988
limits = [-3.141592653589793, 0.7853981633974483]
mass = 2.5
com = [0.15, 0.0, 0.0265]
[[joint]]
type = "prismatic"
theta = 0.7853981633974483
d = 0.0125
a = 0.0
alpha = 3.141592653589793
limits = [0.0, 0.35]
[tool]
xyz = [0.001, -0.002, 0.1]
rpy = [0.0, 1.5707963267948966, -0.5235987755982988]
[base]
xyz = [1.5, 0.0, 0.9]
"#;
    let mm_deg = r#"name = "twin"
convention = "mdh"
length_unit = "mm"
angle_unit = "deg"
gravity = [0.0, 0.0, -9.81]
[[joint]]
type = "revolute"
theta = 90
s = 425
a = -392.2
alpha = -30
limits = [-180, 45]
mass = 2.5
com = [150, 0, 26.5]
[[joint]]
type = "prismatic"
theta = 45
d = 12.5
a = 0
alpha = 180
limits = [0, 350]
[tool]
xyz = [1, -2, 100]
rpy = [0, 90, -30]
[base]
xyz = [1500, 0, 900]
"#;
    let a = parse_model(m_rad, "a.toml").unwrap().robot;
    let b = parse_model(mm_deg, "b.toml").unwrap().robot;
    let mut x = Vec::new();
    let mut y = Vec::new();
    for r in [&a, &b] {
        let v = if core::ptr::eq(r, &a) { &mut x } else { &mut y };
        for l in &r.links {
            v.extend([l.theta, l.s, l.a, l.alpha]);
            v.extend(l.limits.unwrap());
            if let Some(m) = l.mass {
                v.push(m.mass);
                v.extend(m.com.iter());
            }
        }
        for f in [&r.tool, &r.base] {
            v.extend(f.xyz.iter().chain(f.rpy.iter()));
        }
        v.extend(r.gravity.unwrap().iter());
    }
    assert_eq!(x.len(), y.len());
    for (i, (p, q)) in x.iter().zip(&y).enumerate() {
        assert!(close(*p, *q), "value {i}: {p} (m, rad) vs {q} (mm, deg)");
    }
    assert_eq!(a.links[1].joint, JointType::Prismatic);
}

/// Unit conversions: to SI and back, and a joint reading in the unit of its type.
#[test]
fn unit_conversions() {
    let u = Units {
        length: LengthUnit::Mm,
        angle: AngleUnit::Deg,
    };
    assert_eq!(u.length_to_si(1500.0), 1.5);
    assert_eq!(u.length_from_si(1.5), 1500.0);
    assert!(close(u.angle_to_si(180.0), core::f64::consts::PI));
    assert!(close(u.angle_from_si(core::f64::consts::FRAC_PI_2), 90.0));
    assert!(close(
        u.joint_to_si(JointType::Revolute, 90.0),
        core::f64::consts::FRAC_PI_2
    ));
    assert_eq!(u.joint_to_si(JointType::Prismatic, 90.0), 0.09);
    assert_eq!(u.joint_from_si(JointType::Prismatic, 0.09), 90.0);
    assert!(close(
        u.joint_from_si(JointType::Revolute, core::f64::consts::PI),
        180.0
    ));
    assert_eq!(u.joint_unit(JointType::Prismatic), "mm");
    assert_eq!(u.joint_unit(JointType::Revolute), "deg");
    assert!(close(LengthUnit::In.to_si(1.0), 0.0254));
    assert!(close(LengthUnit::In.from_si(0.0254), 1.0));
    let names: Vec<String> = LengthUnit::ALL.iter().map(ToString::to_string).collect();
    assert_eq!(names, ["m", "mm", "in"]);
    assert_eq!(AngleUnit::Rad.to_string(), "rad");
    assert_eq!(AngleUnit::Deg.to_string(), "deg");
    assert_eq!(u.to_string(), "mm, deg");
    assert_eq!(LengthUnit::from_name("in"), Some(LengthUnit::In));
    assert_eq!(AngleUnit::from_name("degree"), None);
}

/// A missing file names the file and the built-in models; a file on disk is read
/// and keeps its path as source.
#[test]
fn load_model_from_disk_or_refuses_naming_the_file() {
    let e = load_model("/nonexistent/robot.toml").unwrap_err();
    assert_eq!(e.file, "/nonexistent/robot.toml");
    assert_eq!((e.line, e.column), (0, 0));
    assert!(e.to_string().contains("/nonexistent/robot.toml"));
    assert!(e.message.contains("puma560"));

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("arm.toml");
    std::fs::write(&path, GOOD).unwrap();
    let p = path.to_str().unwrap();
    assert_eq!(load_model(p).unwrap().source, p);
    std::fs::write(&path, edit(10, "a = [0.2]")).unwrap();
    let e = load_model(p).unwrap_err();
    assert_eq!((e.file.as_str(), e.line, e.column), (p, 10, 5));
}

#[test]
fn refuses_toml_syntax_errors_at_their_place() {
    // Unquoted string value: the parser points at the value.
    refused(&edit(3, "length_unit = m"), 3, 15, &["TOML syntax"]);
    // Unterminated table header.
    refused(&edit(6, "[[joint]"), 6, 9, &["TOML syntax"]);
    // A key given twice: the second one.
    refused(
        &edit(9, "s = 0.1\ns = 0.2"),
        10,
        1,
        &["TOML syntax", "duplicate key"],
    );
}

#[test]
fn refuses_unknown_keys_naming_the_allowed_ones() {
    refused(
        &edit(11, "alpah = 1.5"),
        11,
        1,
        &[
            "[[joint]] 1",
            "unknown key `alpah`",
            "did you mean `alpha`",
            "allowed keys: type, theta, s, d, a, alpha",
        ],
    );
    refused(
        &edit(5, "gravty = [0.0, 0.0, -9.81]"),
        5,
        1,
        &[
            "unknown key `gravty`",
            "did you mean `gravity`",
            "allowed keys: name, description",
        ],
    );
    refused(
        &format!("{GOOD}[tool]\nxyz = [0.0, 0.0, 0.1]\n  rpz = [0.0, 0.0, 0.0]\n"),
        14,
        3,
        &["[tool]", "unknown key `rpz`", "allowed keys: xyz, rpy"],
    );
    // A sub-table of a joint is an unknown key of that joint.
    refused(
        &format!("{GOOD}[joint.extra]\nk = 1\n"),
        12,
        8,
        &["unknown key `extra`"],
    );
}

#[test]
fn refuses_missing_required_top_level_keys_at_line_1() {
    for (line, key) in [
        (1, "name"),
        (2, "convention"),
        (3, "length_unit"),
        (4, "angle_unit"),
    ] {
        refused(
            &edit(line, ""),
            1,
            1,
            &[&format!("missing required key `{key}`")],
        );
    }
    let no_joint: String = GOOD.lines().take(4).map(|l| format!("{l}\n")).collect();
    refused(
        &no_joint,
        1,
        1,
        &["missing required key `joint`", "[[joint]]"],
    );
    refused(
        &format!("{no_joint}joint = []\n"),
        5,
        1,
        &["`joint` is empty"],
    );
    refused(
        &format!("{no_joint}[joint]\ntype = \"revolute\"\n"),
        5,
        2,
        &["`joint` must be an array of tables"],
    );
}

#[test]
fn refuses_missing_joint_keys_at_the_joint_header() {
    for (line, key) in [(7, "type"), (8, "theta"), (10, "a"), (11, "alpha")] {
        refused(
            &edit(line, ""),
            6,
            1,
            &["[[joint]] 1", &format!("missing required key `{key}`")],
        );
    }
    refused(
        &edit(9, ""),
        6,
        1,
        &["[[joint]] 1", "missing required key `s` (or `d`)"],
    );
    // The second joint misses alpha: its own header, line 12.
    let two = format!("{GOOD}[[joint]]\ntype = \"revolute\"\ntheta = 0\nd = 0\na = 0\n");
    refused(&two, 12, 1, &["[[joint]] 2", "`alpha`"]);
}

#[test]
fn refuses_both_s_and_d_at_the_second() {
    refused(&edit(9, "s = 0.1\nd = 0.1"), 10, 1, &["both `s` and `d`"]);
    refused(&edit(9, "d = 0.1\n  s = 0.1"), 10, 3, &["both `s` and `d`"]);
}

#[test]
fn refuses_bad_names() {
    refused(
        &edit(1, "name = \"Arm 1\""),
        1,
        8,
        &["`name`", "\"Arm 1\"", "a-z, 0-9"],
    );
    refused(&edit(1, "name = \"\""), 1, 8, &["`name`"]);
    refused(&edit(1, "name = 5"), 1, 8, &["`name` must be a string"]);
}

#[test]
fn refuses_unknown_convention_units_and_joint_types_listing_the_accepted() {
    refused(
        &edit(2, "convention = \"DH\""),
        2,
        14,
        &["convention", "\"DH\"", "\"dh\"", "\"mdh\""],
    );
    refused(
        &edit(3, "length_unit = \"cm\""),
        3,
        15,
        &["length_unit", "\"cm\"", "\"m\", \"mm\", \"in\""],
    );
    refused(
        &edit(4, "angle_unit = \"grad\""),
        4,
        14,
        &["angle_unit", "\"grad\"", "\"rad\", \"deg\""],
    );
    refused(
        &edit(7, "type = \"linear\""),
        7,
        8,
        &[
            "[[joint]] 1",
            "joint type \"linear\"",
            "\"revolute\", \"prismatic\"",
        ],
    );
}

#[test]
fn refuses_non_finite_and_non_numeric_values() {
    refused(
        &edit(10, "a = nan"),
        10,
        5,
        &["`a` = nan is not a finite number"],
    );
    refused(&edit(10, "a = -inf"), 10, 5, &["`a` = -inf"]);
    refused(
        &edit(11, "alpha = 1e999"),
        11,
        9,
        &["`alpha` = 1e999 is not a finite number"],
    );
    refused(
        &edit(8, "theta = \"0\""),
        8,
        9,
        &["`theta` must be a number, found a string"],
    );
    refused(
        &edit(5, "gravity = [0.0, nan, -9.81]"),
        5,
        17,
        &["`gravity[1]` = nan"],
    );
    refused(
        &format!("{GOOD}[base]\nrpy = [0.0, 0.0, +inf]\n"),
        13,
        18,
        &["[base]", "`rpy[2]` = +inf"],
    );
}

#[test]
fn refuses_arrays_of_the_wrong_length() {
    refused(
        &edit(5, "gravity = [0.0, -9.81]"),
        5,
        11,
        &["`gravity` has 2 values, expected 3"],
    );
    refused(
        &format!("{GOOD}[tool]\nxyz = [0.0, 0.1]\n"),
        13,
        7,
        &["[tool]", "`xyz` has 2 values, expected 3"],
    );
    refused(
        &format!("{GOOD}[base]\nrpy = [0, 0, 0, 0]\n"),
        13,
        7,
        &["[base]", "`rpy` has 4 values, expected 3"],
    );
    refused(
        &format!("{GOOD}mass = 1.0\ncom = [0.0, 0.1]\n"),
        13,
        7,
        &["`com` has 2 values, expected 3"],
    );
    refused(
        &format!("{GOOD}limits = [-1, 0, 1]\n"),
        12,
        10,
        &["`limits` has 3 values, expected 2"],
    );
    refused(
        &format!("{GOOD}limits = 1.0\n"),
        12,
        10,
        &["`limits` must be an array of 2 numbers"],
    );
}

#[test]
fn refuses_inverted_limits_negative_mass_and_com_without_mass() {
    refused(
        &format!("{GOOD}limits = [1.0, -1.0]\n"),
        12,
        10,
        &["`limits`", "lower limit is above the upper"],
    );
    refused(
        &format!("{GOOD}mass = -0.5\n"),
        12,
        8,
        &["`mass` = -0.5 kg is negative"],
    );
    refused(
        &format!("{GOOD}com = [0.0, 0.0, 0.1]\n"),
        12,
        1,
        &["`com` given without `mass`"],
    );
    // A joint that cannot move is refused; zero mass is allowed.
    refused(
        &format!("{GOOD}limits = [0.5, 0.5]\n"),
        12,
        10,
        &["`limits` = [0.5, 0.5]", "cannot move"],
    );
    parse_model(&format!("{GOOD}mass = 0\n"), "ok.toml").unwrap();
}

#[test]
fn refuses_more_than_max_joints_at_the_first_extra_joint() {
    let joint = "[[joint]]\ntype = \"revolute\"\ntheta = 0\ns = 0\na = 0.1\nalpha = 0\n";
    let head: String = GOOD.lines().take(4).map(|l| format!("{l}\n")).collect();
    let ok = format!("{head}{}", joint.repeat(MAX_JOINTS));
    assert_eq!(parse_model(&ok, "ok.toml").unwrap().dof(), MAX_JOINTS);
    let too_many = format!("{head}{}", joint.repeat(MAX_JOINTS + 1));
    // Header of joint MAX_JOINTS + 1: after 4 head lines and MAX_JOINTS joints of 6 lines.
    refused(
        &too_many,
        4 + 6 * MAX_JOINTS + 1,
        1,
        &["too many joints (17)", "at most 16"],
    );
}

#[test]
fn description_tool_and_base_are_read() {
    let text = format!(
        "description = \"a test arm\"\n{GOOD}[tool]\nxyz = [0.0, 0.0, 0.1]\n[base]\nrpy = [0.0, 0.0, 1.0]\n"
    );
    let m = parse_model(&text, "t.toml").unwrap();
    assert_eq!(m.description, "a test arm");
    assert_eq!(m.robot.tool.xyz, Vector3::new(0.0, 0.0, 0.1));
    assert_eq!(m.robot.tool.rpy, Vector3::zeros());
    assert_eq!(m.robot.base.rpy, Vector3::new(0.0, 0.0, 1.0));
    assert_eq!(m.robot.base.xyz, Vector3::zeros());
}

/// Deeply nested arrays are refused by the TOML parser's depth limit, not by a
/// stack overflow.
#[test]
fn deep_nesting_is_refused_without_overflow() {
    let text = format!("name = {}", "[".repeat(100_000));
    let e = parse_model(&text, "deep.toml").unwrap_err();
    assert_eq!(e.line, 1);
    assert!(e.message.starts_with("TOML syntax"), "{e}");
}

/// Characters that matter to TOML and to this format, to mutate files with.
const TOML_ALPHABET: &str = "[]{}=\"'#.,-+_ \n\r\t0123456789eEnaifstrdxyzpqvolumjg\u{e9}\u{1f600}";

proptest! {
    /// Random bytes never make the model parser panic.
    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = parse_model(&text, "fuzz.toml");
    }

    /// Random edits of valid model files never make the parser panic, and a
    /// refusal always has a place in the text.
    #[test]
    fn mutated_models_never_panic(
        which in 0..MODELS.len(),
        edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<usize>()), 1..12),
    ) {
        let text = crate::test_support::mutate(MODELS[which].text, &edits, TOML_ALPHABET);
        if let Err(e) = parse_model(&text, "fuzz.toml") {
            let lines = crate::session::input_error::line_col(&text, text.len()).0;
            prop_assert!(e.line >= 1 && e.line <= lines, "{e}");
            prop_assert!(e.column >= 1, "{e}");
        }
    }
}

/// A model whose values are in metres read with `length_unit = "mm"` is a
/// 0.3 mm arm, which data in metres would fit as well as the real one: refused
/// at `length_unit`, naming the unit the values make an arm in; so is the
/// reverse, millimetre values read as metres (a 300 m arm).
#[test]
fn a_model_whose_size_is_not_an_arm_s_is_refused_at_its_unit() {
    refused(
        &edit(3, r#"length_unit = "mm""#),
        3,
        15,
        &["0.3000 mm", "not the size of an arm", "are the values in m"],
    );
    let in_mm = GOOD
        .replace("s = 0.1", "s = 100")
        .replace("a = 0.2", "a = 200");
    refused(
        &in_mm,
        3,
        15,
        &[
            "300.0000 m",
            "are the values in mm while length_unit says \"m\"",
        ],
    );
}
