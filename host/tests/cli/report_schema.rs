//! docs/file-formats.md §6 (and §7 for `plan`) is the JSON reports' schema:
//! every field `identify --json`, `diagnose --json` and `plan --json` write
//! is a row of its verb's table there, and every field of an object the
//! report nests (`residual`, `parameters[]`, `holdout`, …) is named in that
//! row. Run on sessions that write the optional parts too: several sessions
//! with joint torques and an effect, full poses with orientations, a ball in
//! sockets without a tracker, and plans for compliance and for sockets.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use super::{armcal, assert_success};

/// The rows of the table after the line `` `verb`: `` in §6: each field's
/// name (`parameters[]` as `parameters`; a row of several, `a`, `b`, each)
/// and the names in backticks of its description.
fn documented(verb: &str) -> BTreeMap<String, BTreeSet<String>> {
    let doc = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/file-formats.md"),
    )
    .unwrap();
    // `plan`'s table is §7's, after "`--json`"; the others' are §6's, each
    // after "`verb`:".
    let (heading, marker) = if verb == "plan" {
        ("## §7 Plans", "\n`--json` (".to_string())
    } else {
        ("## §6 JSON reports", format!("\n`{verb}`:\n"))
    };
    let section = doc
        .split(heading)
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .unwrap_or_else(|| panic!("{heading} in docs/file-formats.md"));
    let table = section
        .split(&marker)
        .nth(1)
        .unwrap_or_else(|| panic!("no table of `{verb}` in {heading}"));
    let ticked = |text: &str| -> Vec<String> {
        text.split('`')
            .skip(1)
            .step_by(2)
            .map(|t| t.trim_end_matches("[]").to_owned())
            .collect()
    };
    let mut rows = BTreeMap::new();
    let mut descriptions = Vec::new();
    for line in table
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
    {
        let cells: Vec<&str> = line.split(" | ").collect();
        let (fields, what) = (cells[0].trim_start_matches("| "), cells[1..].join(" | "));
        for field in ticked(fields) {
            descriptions.push((field, what.clone()));
        }
        let mut names: BTreeSet<String> = ticked(&what).into_iter().collect();
        // `diagnose`'s row that says "as `identify`'s" names what that row does.
        let same_as_identify = verb != "identify" && what.contains("as `identify`'s");
        for field in ticked(fields) {
            if same_as_identify {
                names.extend(documented("identify").remove(&field).unwrap_or_default());
            }
            rows.entry(field)
                .or_insert_with(BTreeSet::new)
                .extend(names.clone());
        }
    }
    // `plan`'s rows that say "the same figures" (`random`, `compared`,
    // `off_axis`'s `predicted`) name what the plan's own prediction rows do.
    if verb == "plan" {
        let figures: BTreeSet<String> = [
            "predicted_rms_mm",
            "predicted_max_mm",
            "predicted_measured_rms_mm",
            "std",
            "observability",
        ]
        .iter()
        .flat_map(|f| {
            let named = rows.get(*f).cloned().unwrap_or_default();
            named.into_iter().chain([f.to_string()])
        })
        .collect();
        for (field, what) in &descriptions {
            if what.contains("the same figures")
                && let Some(named) = rows.get_mut(field)
            {
                named.extend(figures.iter().cloned());
            }
        }
    }
    assert!(rows.len() > 10, "{verb}: {rows:?}");
    rows
}

/// Every key of the objects in `value` (and in the objects of its arrays,
/// and theirs), with where it was found.
fn nested_keys(value: &serde_json::Value, at: &str, out: &mut Vec<(String, String)>) {
    match value {
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                out.push((k.clone(), format!("{at}.{k}")));
                nested_keys(v, &format!("{at}.{k}"), out);
            }
        }
        serde_json::Value::Array(items) => {
            for item in items {
                nested_keys(item, &format!("{at}[]"), out);
            }
        }
        _ => {}
    }
}

/// The fields of `report` (a verb's JSON) that §6 does not name: a
/// top-level field without a row, or a nested one its row does not name.
fn undocumented(
    report: &serde_json::Value,
    rows: &BTreeMap<String, BTreeSet<String>>,
) -> Vec<String> {
    let mut missing = Vec::new();
    let top = report.as_object().expect("a report is one object");
    for (field, value) in top {
        let Some(named) = rows.get(field) else {
            missing.push(format!("{field}: no row"));
            continue;
        };
        let mut keys = Vec::new();
        nested_keys(value, field, &mut keys);
        for (key, at) in keys {
            // A key named after data (a joint's, a parameter's, a
            // candidate's) is a value: `data_share`'s names, `parameters`
            // of an effect by name.
            let by_name = at.contains(".parameters.") || at.contains(".by_joint.");
            // A row may name a family by its suffix: `_mean_mm`, `_without`.
            let suffix = named
                .iter()
                .any(|n| n.starts_with('_') && key.ends_with(n.as_str()));
            if !named.contains(&key) && !by_name && !suffix {
                missing.push(at);
            }
        }
    }
    missing
}

/// Runs `armcal` in `dir`, asserting success.
fn run(dir: &Path, args: &[&str]) {
    assert_success(&armcal(args, dir));
}

/// The JSON file `name` in `dir`.
fn read(dir: &Path, name: &str) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join(name)).unwrap()).unwrap()
}

#[test]
fn every_field_of_the_json_reports_is_documented() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    // Two sessions of a UR10e with joint torques and a compliance of joint 2.
    run(
        dir,
        &[
            "simulate",
            "--model",
            "ur10e",
            "--out",
            "t.csv",
            "--poses",
            "160",
            "--sessions",
            "2",
            "--torque-noise",
            "0.5",
            "--effect",
            "joint_compliance:2",
            "--seed",
            "4",
        ],
    );
    // Full poses, orientations measured.
    run(
        dir,
        &[
            "simulate",
            "--model",
            "puma560",
            "--out",
            "p.csv",
            "--poses",
            "80",
            "--orientation-noise",
            "0.001",
            "--seed",
            "2",
        ],
    );
    let mut reports = Vec::new();
    for (verb, data) in [
        ("identify", vec!["t-1.csv", "t-2.csv"]),
        ("diagnose", vec!["t-1.csv", "t-2.csv"]),
        ("identify", vec!["p.csv"]),
        ("diagnose", vec!["p.csv"]),
    ] {
        let model = if data[0].starts_with('t') {
            "ur10e"
        } else {
            "puma560"
        };
        let mut args = vec![verb, "--model", model, "--json", "r.json", "--data"];
        args.extend(&data);
        run(dir, &args);
        reports.push((verb, read(dir, "r.json")));
    }
    // A ball in two sockets on a Franka Panda (the bundled MUKCA session).
    let urdf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/mukca-ball-socket/original/urdf/panda.urdf");
    let front =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/mukca-ball-socket/panda_6/front.csv");
    for verb in ["identify", "diagnose"] {
        run(
            dir,
            &[
                verb,
                "--model",
                urdf.to_str().unwrap(),
                "--tip-link",
                "ball_link",
                "--data",
                front.to_str().unwrap(),
                "--json",
                "r.json",
            ],
        );
        reports.push((verb, read(dir, "r.json")));
    }
    // Plans: a tracker's with compliance (and the off-axis suggestion of a
    // tool point on the flange's axis), and a ball's in sockets.
    std::fs::write(
        dir.join("s.csv"),
        "point,x,y,z\ns0,0.45,-0.15,0.05\ns1,0.45,0.15,0.05\ns2,0.6,0,0.05\n",
    )
    .unwrap();
    for extra in [&["--effects", "compliance"][..], &["--sockets", "s.csv"]] {
        let mut args = vec![
            "plan", "--model", "ur10e", "--poses", "24", "--out", "plan.csv", "--json", "r.json",
            "--seed", "3",
        ];
        args.extend(extra);
        run(dir, &args);
        reports.push(("plan", read(dir, "r.json")));
    }
    // The runs write the optional parts the module header names.
    let written: BTreeSet<&str> = reports
        .iter()
        .flat_map(|(_, r)| r.as_object().unwrap().keys().map(String::as_str))
        .collect();
    for part in [
        "gravity",
        "sessions",
        "orientation_weight",
        "points",
        "effects",
        "off_axis",
        "compliance_held",
        "socket_of",
        "near_singular",
    ] {
        assert!(
            written.contains(part),
            "no report wrote {part}: {written:?}"
        );
    }
    let mut missing = BTreeSet::new();
    for (verb, report) in &reports {
        for m in undocumented(report, &documented(verb)) {
            missing.insert(format!("{verb}: {m}"));
        }
    }
    assert!(
        missing.is_empty(),
        "fields the reports write that docs/file-formats.md §6 (§7 for plan) does not name:\n{}",
        missing.into_iter().collect::<Vec<_>>().join("\n")
    );
}
