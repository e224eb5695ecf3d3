//! A calibration used outside what it was identified on: `identify --out`
//! records the session's joint, temperature and payload ranges; `predict` on
//! rows beyond them still writes every row and exits 0, and warns once per
//! quantity with the rows, the worst excess in the model's units (degrees
//! here) and the first lines; a version 3 file (no ranges) still reads, with
//! one note that its ranges are unknown.

use crate::{armcal, assert_success};
use armcal_shared::Calibration;
use armcal_shared::calibration::HEADER_LEN;
use armcal_shared::compensation::Task;

/// A UR10e in millimetres and degrees.
const MODEL: &str = "name = \"ur10e_mm_deg\"\nconvention = \"dh\"\nlength_unit = \"mm\"\nangle_unit = \"deg\"\n\
    [[joint]]\ntype = \"revolute\"\ntheta = 0\nd = 180.7\na = 0\nalpha = 90\n\
    [[joint]]\ntype = \"revolute\"\ntheta = 0\nd = 0\na = -612.7\nalpha = 0\n\
    [[joint]]\ntype = \"revolute\"\ntheta = 0\nd = 0\na = -571.55\nalpha = 0\n\
    [[joint]]\ntype = \"revolute\"\ntheta = 0\nd = 174.15\na = 0\nalpha = 90\n\
    [[joint]]\ntype = \"revolute\"\ntheta = 0\nd = 119.85\na = 0\nalpha = -90\n\
    [[joint]]\ntype = \"revolute\"\ntheta = 0\nd = 116.55\na = 0\nalpha = 0\n";

/// The columns of a CSV (after `#` comments) by header name.
fn columns(text: &str) -> std::collections::HashMap<String, Vec<f64>> {
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut out: std::collections::HashMap<String, Vec<f64>> = std::collections::HashMap::new();
    for line in lines {
        for (name, v) in header.iter().zip(line.split(',')) {
            out.entry(name.to_string())
                .or_default()
                .push(v.parse().unwrap());
        }
    }
    out
}

/// The number after `at worst` in the warning line about `quantity`.
fn worst(stderr: &str, quantity: &str) -> f64 {
    let line = stderr
        .lines()
        .find(|l| l.contains(&format!(": {quantity} outside the range")))
        .unwrap_or_else(|| panic!("no warning about {quantity} in {stderr}"));
    let after = line.split("at worst ").nth(1).unwrap();
    after.split(' ').next().unwrap().parse().unwrap()
}

/// The simulated session (300 poses, 20–30 °C, 0 and 5 kg) identified with
/// `identify --out`: the file records each joint's range, to the rounding of
/// degrees to radians, and the conditions'. `predict` with a row inside, a row
/// with q3 20° beyond the largest q3 identified on, and a row at 140 °C and
/// 4,000 kg: three rows written, exit 0, one warning each for q3, temp and
/// load with the excess, to the message's four significant figures, and the
/// row's line.
#[test]
fn predict_names_the_rows_beyond_the_identified_ranges() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("arm.toml"), MODEL).unwrap();
    let run = |args: &[&str]| {
        let out = armcal(args, dir.path());
        assert_success(&out);
        out
    };
    run(&[
        "simulate", "--model", "arm.toml", "--poses", "300", "--out", "d.csv",
    ]);
    run(&[
        "identify", "--model", "arm.toml", "--data", "d.csv", "--out", "cal.bin",
    ]);
    let data = columns(&std::fs::read_to_string(dir.path().join("d.csv")).unwrap());
    let lo = |c: &str| data[c].iter().copied().fold(f64::INFINITY, f64::min);
    let hi = |c: &str| data[c].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let cal = Calibration::decode(&std::fs::read(dir.path().join("cal.bin")).unwrap()).unwrap();
    let ranges = cal.ranges.as_ref().expect("identify records the ranges");
    for (m, r) in ranges.joints.iter().enumerate() {
        let (min, max) = (lo(&format!("q{}", m + 1)), hi(&format!("q{}", m + 1)));
        assert!(
            (r.min - min.to_radians()).abs() < 1e-12,
            "q{}: {r:?} {min}",
            m + 1
        );
        assert!(
            (r.max - max.to_radians()).abs() < 1e-12,
            "q{}: {r:?} {max}",
            m + 1
        );
    }
    let temperature = ranges.temperature.unwrap();
    assert_eq!((temperature.min, temperature.max), (lo("temp"), hi("temp")));
    let load = ranges.load.unwrap();
    assert_eq!((load.min, load.max), (lo("load"), hi("load")));

    let inside: Vec<f64> = (1..=6).map(|m| data[&format!("q{m}")][0]).collect();
    let row = |q: &[f64], temp: f64, load: f64| {
        let v: Vec<String> = q.iter().map(|x| format!("{x}")).collect();
        format!("{},{temp},{load}\n", v.join(","))
    };
    let mut beyond = inside.clone();
    beyond[2] = hi("q3") + 20.0;
    let text = format!(
        "q1,q2,q3,q4,q5,q6,temp,load\n{}{}{}",
        row(&inside, 25.0, 2.0),
        row(&beyond, 25.0, 2.0),
        row(&inside, 140.0, 4000.0)
    );
    std::fs::write(dir.path().join("j.csv"), text).unwrap();
    let out = run(&[
        "predict",
        "--calibration",
        "cal.bin",
        "--joints",
        "j.csv",
        "--out",
        "p.csv",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let written = std::fs::read_to_string(dir.path().join("p.csv")).unwrap();
    assert_eq!(
        written.lines().count(),
        2 + 3,
        "every row written: {written}"
    );
    assert_eq!(
        stderr.lines().count(),
        3,
        "one warning per quantity: {stderr}"
    );
    for (quantity, excess, line) in [
        ("q3", 20.0, 3),
        ("temp", 140.0 - hi("temp"), 4),
        ("load", 4000.0 - hi("load"), 4),
    ] {
        let got = worst(&stderr, quantity);
        assert!(
            (got - excess).abs() <= 5e-4 * excess,
            "{quantity}: {got} for {excess}: {stderr}"
        );
        let needle = format!("on 1 of 3 rows, at worst {got} ");
        assert!(
            stderr.contains(&needle) && stderr.contains(&format!("(line {line})")),
            "{stderr}"
        );
    }
    assert!(
        stderr.contains("deg beyond (line 3)"),
        "degrees, the model's unit: {stderr}"
    );
}

/// CRC-32/ISO-HDLC, to reseal an edited file.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A version 3 file (as armcal wrote before it recorded ranges: the version 4
/// payload of a calibration without ranges is the version 3 payload and the
/// `None` byte) is read by `predict`, which writes its rows, exits 0 and says
/// once that the ranges are unknown, however far the rows lie.
#[test]
fn a_version_3_calibration_still_predicts_with_one_note() {
    let dir = tempfile::tempdir().unwrap();
    let model = armcal::io::model_file::load_model("ur10e").unwrap();
    let cal = Calibration::nominal(model.robot, Task::Position, model.units);
    let v6 = cal.to_bytes().unwrap();
    let payload = u32::from_le_bytes(v6[20..24].try_into().unwrap()) as usize;
    // Version 3 is the version 6 payload without its last four fields: the
    // ranges, held-out error and fallback (`None`, a byte each) and the
    // flange (the identity: six `f64` zeros).
    let added = 3 + 6 * 8;
    assert_eq!(
        v6[HEADER_LEN + payload - added..HEADER_LEN + payload],
        [0; 3 + 6 * 8],
        "ranges, held-out error and fallback: None; the flange at the last link's frame"
    );
    let mut v3 = v6[..HEADER_LEN + payload - added].to_vec();
    v3[8..10].copy_from_slice(&3u16.to_le_bytes());
    v3[20..24].copy_from_slice(&((payload - added) as u32).to_le_bytes());
    let crc = crc32(&v3);
    v3.extend_from_slice(&crc.to_le_bytes());
    std::fs::write(dir.path().join("v3.bin"), &v3).unwrap();
    std::fs::write(
        dir.path().join("j.csv"),
        "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n9,9,9,9,9,9\n",
    )
    .unwrap();
    let out = armcal(
        &[
            "predict",
            "--calibration",
            "v3.bin",
            "--joints",
            "j.csv",
            "--out",
            "p.csv",
        ],
        dir.path(),
    );
    assert_success(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        stderr,
        "armcal: warning: j.csv: the calibration does not record the ranges it was identified on (a file written before format version 4): the rows are not checked against them\n"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("p.csv"))
            .unwrap()
            .lines()
            .count(),
        4
    );
}
