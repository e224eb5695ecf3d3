//! `armcal stream` as a user runs it, against a controller on 127.0.0.1 that
//! runs the firmware's protocol code (`armcal_shared::link::Device`, in f32)
//! in a thread of the test: a calibration is loaded and every row comes back
//! corrected, exactly as that device computes it and within 2 µm at the tool
//! point of `armcal compensate`'s f64 commands; a damaged calibration is refused
//! with the controller's reason, exit status 2 and nothing written; the
//! controller in force is left as it was.

use armcal_shared::compensation::Task;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::thread::JoinHandle;

use crate::armcal;
use armcal::io::model_file::load_model;
use armcal_shared::link::{
    self, Command, Device, FrameBuffer, MAX_FRAME, Request, Response, StatusReport,
};
use armcal_shared::{Calibration, Param, ParamError};

/// A controller on a free port of 127.0.0.1 for one connection. The first
/// `drop_first` bytes it receives are lost, as a UART that is not on yet loses
/// them. Returns the address and the thread, which ends with the device's
/// counters when the host closes the link or after `Halt`.
fn controller(drop_first: usize) -> (String, JoinHandle<StatusReport>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let thread = std::thread::spawn(move || {
        let (mut stream, _) = listener.accept().unwrap();
        let mut device = Device::new(168_000);
        let mut frames = FrameBuffer::new();
        let mut dropped = 0;
        let mut buf = [0u8; 256];
        loop {
            let n = match stream.read(&mut buf) {
                Ok(0) | Err(_) => return device.status(&()),
                Ok(n) => n,
            };
            for &byte in &buf[..n] {
                if dropped < drop_first {
                    dropped += 1;
                    continue;
                }
                let Some(frame) = frames.push(byte) else {
                    continue;
                };
                let request = frame.and_then(link::decode::<Request>);
                let response = match &request {
                    Ok(r) => device.handle(r, &mut ()),
                    Err(e) => device.frame_error(*e),
                };
                let mut out = [0u8; MAX_FRAME];
                stream
                    .write_all(link::encode(&response, &mut out).unwrap())
                    .unwrap();
                if matches!(request, Ok(Request::Halt)) {
                    return device.status(&());
                }
            }
        }
    });
    (address, thread)
}

/// The UR10e (m, rad) with joint errors of a few millimetres and milliradians.
pub(crate) fn calibration() -> Calibration {
    let model = load_model("ur10e").unwrap();
    let mut cal = Calibration::nominal(model.robot.clone(), Task::Pose, model.units);
    for (name, error) in [
        ("theta2", -6e-4),
        ("a2", -6e-3),
        ("theta3", 1e-3),
        ("a3", -5e-3),
        ("alpha3", -8e-3),
        ("theta5", 1.5e-3),
        ("alpha5", 2.6e-3),
    ] {
        let param: Param = name.parse().unwrap();
        cal.errors.push(ParamError { param, error }).unwrap();
    }
    cal
}

/// `rows` ticks of a smooth motion, rad.
fn trajectory(rows: usize) -> Vec<[f64; 6]> {
    let q0 = [1.589, 0.578, -1.675, 0.351, 1.784, 2.232];
    (0..rows)
        .map(|t| {
            let mut q = q0;
            for (j, qj) in q.iter_mut().enumerate() {
                *qj += 0.2 * (0.05 * t as f64 + j as f64).sin();
            }
            q
        })
        .collect()
}

fn write_joints(path: &std::path::Path, rows: &[[f64; 6]]) {
    let mut text = String::from("q1,q2,q3,q4,q5,q6,temp\n");
    for q in rows {
        let values: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
        text.push_str(&format!("{},25\n", values.join(",")));
    }
    std::fs::write(path, text).unwrap();
}

/// The joint rows of a commands CSV (a comment line, a header, numbers).
pub(crate) fn read_commands(path: &std::path::Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with("# "));
    assert_eq!(lines.next().unwrap(), "q1,q2,q3,q4,q5,q6");
    lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

/// Runs `armcal stream` in `dir` with `cal.bin` and `j.csv` against the
/// controller at `address`, writing `c.csv`, and halts it.
fn stream_and_halt(dir: &std::path::Path, address: &str) -> std::process::Output {
    stream_and_halt_with(dir, address, &[])
}

/// [`stream_and_halt`] with the flags `extra` too.
fn stream_and_halt_with(
    dir: &std::path::Path,
    address: &str,
    extra: &[&str],
) -> std::process::Output {
    let mut args = vec![
        "stream",
        "--calibration",
        "cal.bin",
        "--joints",
        "j.csv",
        "--tcp",
        address,
        "--out",
        "c.csv",
        "--halt",
    ];
    args.extend(extra);
    armcal(&args, dir)
}

/// What the firmware's code returns for `rows` after loading `file`.
fn replay(file: &[u8], rows: &[[f64; 6]]) -> Vec<Vec<f64>> {
    let mut device = Device::new(168_000);
    for (i, chunk) in file.chunks(link::CHUNK_LEN).enumerate() {
        device.handle(
            &Request::CalibrationChunk {
                total: file.len() as u16,
                offset: (i * link::CHUNK_LEN) as u16,
                bytes: chunk.iter().copied().collect(),
            },
            &mut (),
        );
    }
    assert!(device.is_calibrated());
    rows.iter()
        .enumerate()
        .map(|(seq, q)| {
            let request = Request::Command(Command {
                seq: seq as u32,
                q: q.iter().map(|&v| v as f32).collect(),
                context: None,
            });
            let Response::Corrected(want) = device.handle(&request, &mut ()) else {
                panic!("not a correction");
            };
            want.q.iter().map(|&v| f64::from(v)).collect()
        })
        .collect()
}

#[test]
fn streams_every_row_through_the_controller() {
    let dir = tempfile::tempdir().unwrap();
    let cal = calibration();
    std::fs::write(dir.path().join("cal.bin"), cal.to_bytes().unwrap()).unwrap();
    let rows = trajectory(40);
    write_joints(&dir.path().join("j.csv"), &rows);
    // The first frame is cut: the session opens on a later Hello.
    let (address, thread) = controller(5);
    let out = stream_and_halt(dir.path(), &address);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("40 commands, 40 corrected to tolerance")
            && stderr.contains("0 deadline misses"),
        "{stderr}"
    );
    let status = thread.join().unwrap();
    assert_eq!((status.loads, status.ticks, status.faults), (1, 40, 0));
    assert!(status.frame_errors <= 1, "only the cut frame: {status:?}");

    // Exactly what the firmware's code computes from the same calibration.
    let got = read_commands(&dir.path().join("c.csv"));
    assert_eq!(got, replay(&cal.to_bytes().unwrap(), &rows));

    // And where armcal compensate's f64 servo ticks put the calibrated tool
    // point, within 2 µm (f32 rounding of a 1.3 m arm: a few tenths of a
    // micrometre).
    let out = armcal(
        &[
            "compensate",
            "--servo",
            "--calibration",
            "cal.bin",
            "--joints",
            "j.csv",
            "--out",
            "h.csv",
        ],
        dir.path(),
    );
    assert!(out.status.success());
    let host = read_commands(&dir.path().join("h.csv"));
    let robot = cal.calibrated();
    for (i, (a, b)) in got.iter().zip(&host).enumerate() {
        let pa = robot.measured_point(a).unwrap();
        let pb = robot.measured_point(b).unwrap();
        let d = (pa - pb).norm();
        assert!(d < 2e-6, "row {i}: {d:e} m apart");
    }
}

/// With `--tool`, the controller is loaded with the calibration working
/// with that tool: the measured tool's offset (and the flange parameter
/// rigid with it) is not in what it computes.
#[test]
fn streams_with_a_working_tool() {
    use armcal::apply::working_tool::WorkingTool;
    use armcal_shared::{Frame, FrameAxis};
    let dir = tempfile::tempdir().unwrap();
    let mut cal = calibration();
    for (param, error) in [
        (Param::Tool(FrameAxis::X), 3e-3),
        (Param::Tool(FrameAxis::Z), -2e-3),
        (Param::Theta(5), 2e-3),
    ] {
        cal.errors.push(ParamError { param, error }).unwrap();
    }
    std::fs::write(dir.path().join("cal.bin"), cal.to_bytes().unwrap()).unwrap();
    let rows = trajectory(10);
    write_joints(&dir.path().join("j.csv"), &rows);
    let (address, thread) = controller(0);
    let out = stream_and_halt_with(dir.path(), &address, &["--tool", "0,0,0.25"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("tool.x, tool.z, theta6; 0.0036 m of position) is not applied"),
        "{stderr}"
    );
    assert_eq!(thread.join().unwrap().loads, 1);
    let frame = Frame {
        xyz: nalgebra::Vector3::new(0.0, 0.0, 0.25),
        rpy: nalgebra::Vector3::zeros(),
    };
    let working = WorkingTool { frame }.apply(&cal).calibration;
    let got = read_commands(&dir.path().join("c.csv"));
    assert_eq!(got, replay(&working.to_bytes().unwrap(), &rows));
    assert_ne!(got, replay(&cal.to_bytes().unwrap(), &rows));
}

#[test]
fn a_damaged_calibration_is_refused_with_the_controllers_reason() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = calibration().to_bytes().unwrap();
    bytes[60] ^= 0x01;
    std::fs::write(dir.path().join("cal.bin"), &bytes).unwrap();
    write_joints(&dir.path().join("j.csv"), &trajectory(3));
    let (address, thread) = controller(0);
    let out = armcal(
        &[
            "stream",
            "--calibration",
            "cal.bin",
            "--joints",
            "j.csv",
            "--tcp",
            &address,
            "--out",
            "c.csv",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(
            "cal.bin: the controller refused the calibration: damaged: the CRC does not match"
        ),
        "{stderr}"
    );
    assert!(!dir.path().join("c.csv").exists(), "nothing written");
    let status = thread.join().unwrap();
    assert_eq!(status.loads, 0);
    assert_eq!(status.ticks, 0, "no command was sent");
    assert_eq!(
        status.last_rejection,
        Some(armcal_shared::link::Rejection::Crc)
    );
}

#[test]
fn no_controller_is_an_error_not_a_hang() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("cal.bin"),
        calibration().to_bytes().unwrap(),
    )
    .unwrap();
    write_joints(&dir.path().join("j.csv"), &trajectory(3));
    // A port that was just free: nothing listens there.
    let port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let address = format!("127.0.0.1:{port}");
    let out = armcal(
        &[
            "stream",
            "--calibration",
            "cal.bin",
            "--joints",
            "j.csv",
            "--tcp",
            &address,
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("cannot connect to"), "{stderr}");
}

/// A calibration identified on the first 20 ticks of the motion (and at
/// 25 °C) streams 40: the controller corrects every one and counts those with
/// a joint beyond the first 20's ranges, as `Ranges::outside` says in f32;
/// `armcal stream` prints that count with the joints in its summary, warns
/// of the same rows from the file, and exits 0.
#[test]
fn the_controller_counts_the_ticks_outside_the_identified_ranges() {
    use armcal_shared::ranges::Ranges;
    let dir = tempfile::tempdir().unwrap();
    let rows = trajectory(40);
    let mut cal = calibration();
    let ranges = Ranges::of(rows[..20].iter().map(|q| (&q[..], Some(25.0), None)));
    cal.ranges = Some(ranges.clone());
    std::fs::write(dir.path().join("cal.bin"), cal.to_bytes().unwrap()).unwrap();
    write_joints(&dir.path().join("j.csv"), &rows);
    // What the controller sees: f32 commands against f32 ranges.
    let narrow = ranges.cast::<f32>();
    let verdicts: Vec<_> = rows
        .iter()
        .map(|q| {
            let q: Vec<f32> = q.iter().map(|&v| v as f32).collect();
            narrow.outside(&q, Some(25.0), None)
        })
        .collect();
    let outside = verdicts.iter().filter(|o| o.any()).count();
    assert!(
        outside >= 5,
        "the motion leaves the first 20 ticks' ranges: {outside}"
    );
    let joints: Vec<String> = (0..6)
        .filter(|&m| verdicts.iter().any(|o| o.joint(m)))
        .map(|m| format!("q{}", m + 1))
        .collect();
    let (address, thread) = controller(0);
    let out = stream_and_halt(dir.path(), &address);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "{outside} ticks outside the identified ranges ({})",
            joints.join(", ")
        )),
        "{stderr}"
    );
    for q in &joints {
        assert!(
            stderr.contains(&format!(
                "j.csv: {q} outside the range the calibration was identified on"
            )),
            "{q}: {stderr}"
        );
    }
    assert_eq!(read_commands(&dir.path().join("c.csv")).len(), 40);
    let status = thread.join().unwrap();
    assert_eq!((status.ticks, status.faults), (40, 0));
}
