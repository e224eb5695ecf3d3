//! What a run writes, and what it must not: never over an input or another
//! output, all of a run's outputs or none, devices and FIFOs written into and
//! never replaced, links followed; and inputs read only up to their limit.

use armcal_shared::compensation::Task;
use std::os::unix::fs::FileTypeExt as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::{armcal, assert_success, refused, snapshot};

/// The built-in model and data set the tests use (6 joints, 23 full poses).
const SET: &str = "figaroh-ur10e-camera";

/// A folder with a model `m.toml`, its data `d.csv`, joint readings `j.csv`
/// and a calibration `cal.bin` identified from them.
fn session() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let (model, _) = armcal::io::builtin::builtin_model(SET).unwrap();
    let (data, _) = armcal::io::builtin::builtin_data(SET).unwrap();
    std::fs::write(dir.path().join("m.toml"), model).unwrap();
    std::fs::write(dir.path().join("d.csv"), data).unwrap();
    std::fs::write(
        dir.path().join("j.csv"),
        "q1,q2,q3,q4,q5,q6\n0,-1.5,1.5,0,1.5,0\n0.1,-1.4,1.4,0.1,1.4,0.1\n",
    )
    .unwrap();
    let out = armcal(
        &[
            "identify", "--model", "m.toml", "--data", "d.csv", "--out", "cal.bin",
        ],
        dir.path(),
    );
    assert_success(&out);
    dir
}

/// Item 3 of the reliability issue: an output that names an input (the model,
/// the data, the joints, the calibration; directly, through a link or by another
/// spelling) or another output is refused, and nothing is written.
#[test]
fn an_output_naming_an_input_or_another_output_is_refused() {
    let dir = session();
    let d = dir.path();
    std::os::unix::fs::symlink("d.csv", d.join("link.csv")).unwrap();
    std::fs::hard_link(d.join("m.toml"), d.join("hard.toml")).unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    let identify = ["identify", "--model", "m.toml", "--data", "d.csv"];
    let with =
        |extra: &[&'static str]| -> Vec<&str> { identify.iter().chain(extra).copied().collect() };

    let e = refused(
        d,
        &with(&["--out", "d.csv"]),
        &["--out d.csv: names the input --data d.csv: refusing to overwrite it"],
    );
    assert!(e.starts_with("armcal: error: "), "{e}");
    refused(
        d,
        &with(&["--out", "m.toml"]),
        &["names the input --model m.toml"],
    );
    refused(
        d,
        &with(&["--json", "./sub/../d.csv"]),
        &["names the input --data"],
    );
    refused(
        d,
        &with(&["--json", "link.csv"]),
        &["names the input --data d.csv"],
    );
    refused(
        d,
        &with(&["--out", "hard.toml"]),
        &["names the input --model m.toml"],
    );
    refused(
        d,
        &with(&["--out", "o.cal", "--json", "o.cal"]),
        &["--json o.cal: names the same file as --out o.cal"],
    );
    refused(
        d,
        &[
            "diagnose", "--model", "m.toml", "--data", "d.csv", "--out", "r.cal", "--html", "d.csv",
        ],
        &["--html d.csv: names the input --data d.csv"],
    );
    for verb in ["predict", "compensate"] {
        refused(
            d,
            &[
                verb,
                "--calibration",
                "cal.bin",
                "--joints",
                "j.csv",
                "--out",
                "j.csv",
            ],
            &["--out j.csv: names the input --joints j.csv"],
        );
        refused(
            d,
            &[
                verb,
                "--calibration",
                "cal.bin",
                "--joints",
                "j.csv",
                "--out",
                "cal.bin",
            ],
            &["--out cal.bin: names the input --calibration cal.bin"],
        );
    }
    refused(
        d,
        &[
            "simulate", "--model", "m.toml", "--poses", "30", "--out", "m.toml",
        ],
        &["--out m.toml: names the input --model m.toml"],
    );
    refused(
        d,
        &[
            "simulate", "--model", SET, "--poses", "30", "--out", "s.csv", "--truth", "s.csv",
        ],
        &["--truth s.csv: names the same file as --out s.csv"],
    );
}

/// Item 4: a run that fails writes none of its outputs and leaves no
/// temporary: an output in a missing directory is refused before anything is
/// written (status 2), and an output that cannot be written (a full device, as
/// a full disk) fails the run (status 1) with the files not written.
#[test]
fn a_failed_run_writes_none_of_its_outputs() {
    let dir = session();
    let d = dir.path();
    refused(
        d,
        &[
            "identify",
            "--model",
            "m.toml",
            "--data",
            "d.csv",
            "--out",
            "a.cal",
            "--json",
            "missing-dir/r.json",
        ],
        &["--json missing-dir/r.json: the directory missing-dir does not exist"],
    );
    refused(
        d,
        &[
            "diagnose",
            "--model",
            SET,
            "--data",
            SET,
            "--out",
            "o.cal",
            "--json",
            "o.json",
            "--html",
            "/nonexistent/r.html",
        ],
        &["the directory /nonexistent does not exist"],
    );
    refused(
        d,
        &[
            "identify", "--model", SET, "--data", SET, "--out", "a.cal", "--json", ".",
        ],
        &["--json .: is a directory"],
    );

    let Some(full) = device(d, "full", (1, 7)) else {
        eprintln!("skipped: no full device");
        return;
    };
    let before = snapshot(d);
    let out = armcal(
        &[
            "identify",
            "--model",
            SET,
            "--data",
            SET,
            "--out",
            "a.cal",
            "--json",
            full.to_str().unwrap(),
        ],
        d,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("the outputs to files were not written"),
        "{stderr}"
    );
    assert_eq!(snapshot(d), before, "a.cal written or a temporary left");
    assert!(
        std::fs::metadata(&full)
            .unwrap()
            .file_type()
            .is_char_device()
    );
}

/// Item 2: a character device and a FIFO are written into and stay what they
/// are; a symbolic link is followed and stays a link; the other outputs are
/// written beside them.
#[test]
fn devices_and_fifos_are_written_into_links_followed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let identify = |json: &str| {
        armcal(
            &[
                "identify", "--model", SET, "--data", SET, "--out", "a.cal", "--json", json,
            ],
            d,
        )
    };

    if let Some(null) = device(d, "null", (1, 3)) {
        let out = identify(null.to_str().unwrap());
        assert_success(&out);
        assert!(
            std::fs::metadata(&null)
                .unwrap()
                .file_type()
                .is_char_device()
        );
        assert!(std::fs::metadata(d.join("a.cal")).unwrap().len() > 0);
        std::fs::remove_file(d.join("a.cal")).unwrap();
    } else {
        eprintln!("skipped /dev/null: root, and no mknod");
    }

    let fifo = d.join("r.fifo");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let mut reader = Command::new("cat")
        .arg(&fifo)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let out = identify("r.fifo");
    let start = Instant::now();
    while reader.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(20) {
            reader.kill().unwrap();
            panic!("the FIFO's reader got no end of file");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let received: Output = reader.wait_with_output().unwrap();
    assert_success(&out);
    let json: serde_json::Value = serde_json::from_slice(&received.stdout).unwrap();
    assert!(
        json["variance_factor"].is_number(),
        "the report came through"
    );
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );
    std::fs::remove_file(d.join("a.cal")).unwrap();

    std::fs::write(d.join("real.json"), "old").unwrap();
    std::os::unix::fs::symlink("real.json", d.join("r.json")).unwrap();
    assert_success(&identify("r.json"));
    assert_eq!(
        std::fs::read_link(d.join("r.json")).unwrap(),
        Path::new("real.json"),
        "still the link"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("real.json")).unwrap()).unwrap();
    assert!(json["variance_factor"].is_number());
    let mut names = crate::files_in(d);
    names.retain(|n| n != "null");
    assert_eq!(names, ["a.cal", "r.fifo", "r.json", "real.json"]);
}

/// Item 5: a calibration is read up to its 5 KiB limit and one byte, so
/// `/dev/zero` is refused at once; a larger file, a model larger than 1 MiB,
/// likewise, naming the limit; nothing is written.
#[test]
fn inputs_are_read_only_up_to_their_limit() {
    let dir = session();
    let d = dir.path();
    let start = Instant::now();
    let e = refused(
        d,
        &[
            "predict",
            "--calibration",
            "/dev/zero",
            "--joints",
            "j.csv",
            "--out",
            "p.csv",
        ],
        &["/dev/zero: the file is larger than 5 KiB, the most a calibration file may have"],
    );
    assert!(start.elapsed() < Duration::from_secs(10), "{e}");

    std::fs::write(d.join("zeros.bin"), vec![0u8; 6 * 1024]).unwrap();
    for verb in ["predict", "compensate"] {
        refused(
            d,
            &[
                verb,
                "--calibration",
                "zeros.bin",
                "--joints",
                "j.csv",
                "--out",
                "p.csv",
            ],
            &["zeros.bin: the file is larger than 5 KiB"],
        );
    }
    refused(
        d,
        &[
            "stream",
            "--calibration",
            "zeros.bin",
            "--joints",
            "j.csv",
            "--tcp",
            "127.0.0.1:9",
            "--out",
            "p.csv",
        ],
        &["zeros.bin: the file is larger than 5 KiB"],
    );

    let mut model = std::fs::read_to_string(d.join("m.toml")).unwrap();
    model.push_str(&format!("# {}\n", "x".repeat(1 << 20)));
    std::fs::write(d.join("big.toml"), model).unwrap();
    refused(
        d,
        &[
            "identify", "--model", "big.toml", "--data", "d.csv", "--out", "a.cal",
        ],
        &["big.toml: the file is larger than 1 MiB, the most a robot model file may have"],
    );
    refused(
        d,
        &[
            "identify",
            "--model",
            "/dev/zero",
            "--data",
            "d.csv",
            "--out",
            "a.cal",
        ],
        &["/dev/zero: the file is larger than 1 MiB"],
    );
}

/// A character device `(major, minor)` to write into without risk to the
/// machine's own: as root (who could replace `/dev/NAME`), a node made in `dir`
/// by `mknod` (`None` if not allowed); otherwise `/dev/NAME`, which a user
/// cannot replace.
fn device(dir: &Path, name: &str, (major, minor): (u32, u32)) -> Option<PathBuf> {
    use std::os::unix::fs::MetadataExt as _;
    let probe = dir.join(".owner-probe");
    std::fs::write(&probe, b"").ok()?;
    let root = std::fs::metadata(&probe).ok()?.uid() == 0;
    std::fs::remove_file(&probe).ok()?;
    if !root {
        return Some(Path::new("/dev").join(name));
    }
    let node = dir.join(name);
    let made = Command::new("mknod")
        .arg(&node)
        .args(["c", &major.to_string(), &minor.to_string()])
        .status()
        .is_ok_and(|s| s.success());
    made.then_some(node)
}

/// An interrupt ends a run with the shell's status for its signal (130 for
/// Ctrl-C's SIGINT, 143 for SIGTERM) and writes none of its outputs.
#[test]
fn an_interrupted_run_exits_with_its_signals_status_and_writes_nothing() {
    for (signal, status) in [("-INT", 130), ("-TERM", 143)] {
        let dir = tempfile::tempdir().unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_armcal"))
            .args(["sweep", "--cases", "100000", "--json", "r.json"])
            .current_dir(dir.path())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Long enough for the handler to be in place; far from the end.
        std::thread::sleep(Duration::from_millis(500));
        let sent = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        let exit = child.wait().unwrap();
        assert_eq!(exit.code(), Some(status), "{signal}");
        assert_eq!(
            snapshot(dir.path()),
            Vec::new(),
            "{signal}: something was written"
        );
    }
}

/// A simulated session's and a plan's first line is the command that made
/// them, every option as typed and the seed made explicit: run again, it
/// writes the same bytes (options the header once left out — the torques'
/// noise, the effects a plan serves — make a different file without them).
#[test]
fn a_file_s_header_is_the_command_that_makes_it_again() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        &[
            "simulate",
            "--model",
            "puma560",
            "--poses",
            "40",
            "--torque-noise",
            "0.1",
            "--payloads",
            "0,2",
            "--effect",
            "backlash:2",
            "--out",
            "s.csv",
        ][..],
        &[
            "plan",
            "--model",
            "ur10e",
            "--poses",
            "12",
            "--effects",
            "backlash",
            "--candidates",
            "2000",
            "--out",
            "s.csv",
        ][..],
    ] {
        assert_success(&armcal(args, dir.path()));
        let first = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
        let header = first.lines().next().unwrap();
        let line = header.strip_prefix("# armcal ").unwrap();
        let line = line.split(": ").next().unwrap();
        assert!(line.contains("--seed 1"), "{header}");
        std::fs::remove_file(dir.path().join("s.csv")).unwrap();
        let again: Vec<&str> = line.split_whitespace().collect();
        assert_success(&armcal(&again, dir.path()));
        let second = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
        assert!(first == second, "{header}");
    }
}

/// Feeds `header` then `row` repeated, on standard input of `armcal args`
/// run in `dir`, until it stops reading or twice `cap` rows are sent; asserts
/// the run refused the first row past `cap` (exit 2, naming its line) and
/// stopped reading there.
fn refused_past_the_cap(args: &[&str], dir: &Path, (header, row): (&str, &str), cap: usize) {
    use std::io::Write as _;
    let mut child = Command::new(env!("CARGO_BIN_EXE_armcal"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let (mut block, row) = (header.to_string(), row.to_string());
    let feeder = std::thread::spawn(move || {
        let mut sent = 0;
        // Twice the cap at most; armcal stops reading at the cap.
        while sent < 2 * cap {
            block.push_str(&row.repeat(10_000));
            if stdin.write_all(block.as_bytes()).is_err() {
                return sent;
            }
            block.clear();
            sent += 10_000;
        }
        sent
    });
    let out = child.wait_with_output().unwrap();
    let sent = feeder.join().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains(&format!(
            "/dev/stdin:{}:1: more than {cap} data rows",
            cap + 2
        )),
        "{stderr}"
    );
    assert!(sent < 2 * cap, "read to the end: {sent} rows");
}

/// A stream of measurement rows on standard input, shorter than any real
/// row (so that the 1 GiB cap would let some forty million in, held as poses
/// of a few hundred bytes each), is refused at the first row past three
/// million, as it is read: the rows, not only the bytes, bound the memory.
#[test]
fn a_stream_of_rows_is_refused_past_the_row_cap() {
    let dir = tempfile::tempdir().unwrap();
    refused_past_the_cap(
        &["check", "--model", "ur5e", "--data", "/dev/stdin"],
        dir.path(),
        (
            "q1,q2,q3,q4,q5,q6,x,y,z\n",
            "0.1,0.2,0.3,0.4,0.5,0.6,0.1,0.2,0.3\n",
        ),
        armcal::io::measurements::MAX_MEASURED_ROWS,
    );
}

/// A stream of joint rows on standard input to `predict` (12 bytes a row:
/// the 1 GiB cap would let some ninety million in, 48 B of joints each and
/// their prediction) is refused at the first row past ten million, as it is
/// read.
#[test]
fn a_stream_of_joint_rows_is_refused_past_the_row_cap() {
    let dir = tempfile::tempdir().unwrap();
    let model = armcal::io::model_file::load_model("ur5e").unwrap();
    let cal = armcal_shared::Calibration::nominal(model.robot.clone(), Task::Position, model.units);
    std::fs::write(dir.path().join("nominal.cal"), cal.to_bytes().unwrap()).unwrap();
    refused_past_the_cap(
        &[
            "predict",
            "--calibration",
            "nominal.cal",
            "--joints",
            "/dev/stdin",
            "--out",
            "p.csv",
        ],
        dir.path(),
        ("q1,q2,q3,q4,q5,q6\n", "0,0,0,0,0,0\n"),
        armcal::io::measurements::MAX_JOINT_ROWS,
    );
    assert!(!dir.path().join("p.csv").exists(), "nothing written");
}
