//! Repeated configurations as a user brings them: a configuration measured
//! again adds no geometry, so the counts, folds and figures are of distinct
//! configurations.

use crate::{refused, succeeds};

/// The first `n` data rows of `text`, each `times` over, in turn (as a
/// session that goes round its poses again).
fn repeated(text: &str, n: usize, times: usize) -> String {
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.take(n).collect();
    let mut out = format!("{header}\n");
    for _ in 0..times {
        for r in &rows {
            out.push_str(r);
            out.push('\n');
        }
    }
    out
}

/// Twelve poses of a simulated UR5e session (±1 mm / ±1 mrad, σ = 20 µm),
/// copied five times: diagnosed as twelve configurations, it names no effect
/// (none is there), and the held-out figure it prints is not beaten by what
/// its calibration delivers on the session's 100 poses (the poses it never
/// saw, as every program point is); copied rows are said to show no
/// instrument noise. Six poses copied ten times, and one copied 51 times,
/// give fewer equations than the model's unknowns: refused, nothing written.
#[test]
fn copies_of_a_few_poses_are_those_poses() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    succeeds(
        d,
        &[
            "simulate", "--model", "ur5e", "--out", "s.csv", "--poses", "100", "--seed", "2",
        ],
    );
    let session = std::fs::read_to_string(d.join("s.csv")).unwrap();
    std::fs::write(d.join("rep.csv"), repeated(&session, 12, 5)).unwrap();
    let out = succeeds(d, &["diagnose", "--model", "ur5e", "--data", "rep.csv"]);
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        summary.contains("60 rows in 12 distinct configurations"),
        "{summary}"
    );
    assert!(
        summary.contains("identical (copies of one reading"),
        "{summary}"
    );
    assert!(summary.contains("nothing beyond geometry"), "{summary}");
    succeeds(
        d,
        &[
            "diagnose", "--model", "ur5e", "--data", "rep.csv", "--out", "r.cal", "--json",
            "r.json",
        ],
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(report["replicates"]["configurations"], 12);
    let claimed = report["holdout"]["extended_rms_mm"].as_f64().unwrap();
    succeeds(
        d,
        &[
            "predict",
            "--calibration",
            "r.cal",
            "--joints",
            "s.csv",
            "--out",
            "p.csv",
        ],
    );
    let predicted = std::fs::read_to_string(d.join("p.csv")).unwrap();
    let xyz = |text: &str, skip_q: usize| -> Vec<[f64; 3]> {
        text.lines()
            .filter(|l| !l.starts_with('#'))
            .skip(1)
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
                [v[skip_q], v[skip_q + 1], v[skip_q + 2]]
            })
            .collect()
    };
    let (measured, predicted) = (xyz(&session, 6), xyz(&predicted, 0));
    let delivered = (measured
        .iter()
        .zip(&predicted)
        .map(|(m, p)| (0..3).map(|k| (m[k] - p[k]).powi(2)).sum::<f64>())
        .sum::<f64>()
        / measured.len() as f64)
        .sqrt()
        * 1e3;
    // Twelve configurations cross-validated leave a figure of few degrees of
    // freedom; what is printed must not claim better than the calibration
    // delivers beyond that sampling error (a factor 1.5).
    assert!(
        delivered < 1.5 * claimed,
        "printed {claimed} mm held out, delivered {delivered} mm on the session"
    );
    std::fs::write(d.join("rep6.csv"), repeated(&session, 6, 10)).unwrap();
    refused(
        d,
        &[
            "diagnose", "--model", "ur5e", "--data", "rep6.csv", "--out", "r6.cal",
        ],
        &[
            "rep6.csv:61:1",
            "60 rows in 6 distinct configurations",
            "18 equations",
        ],
    );
    std::fs::write(d.join("one.csv"), repeated(&session, 1, 51)).unwrap();
    refused(
        d,
        &[
            "identify", "--model", "ur5e", "--data", "one.csv", "--out", "one.cal",
        ],
        &[
            "one.csv:52:1",
            "51 rows in 1 distinct configuration",
            "3 equations",
        ],
    );
}
