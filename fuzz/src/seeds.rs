//! The seed inputs of each target: small valid files and streams, written to
//! `corpus/<target>/seed-*` by `cargo test -- --ignored write_seeds`.

use armcal_shared::Calibration;
use armcal_shared::calibration::{HEADER_LEN, MAGIC, OLDEST_VERSION, model_hash};
use armcal_shared::compensation::Task;
use armcal_shared::link::{
    self, Command, Context, Corrected, FrameError, HALT_FRAME, MAX_FRAME, RangeReport, Rejection,
    Request, Response, StatusReport, TickStatus,
};
use armcal_shared::ranges::Outside;
use serde::Serialize;

use crate::calibration_of;
use crate::device::{file_of, load_requests};

/// One seed: its file name and bytes.
pub type Seed = (String, Vec<u8>);

/// The targets, as named in `Cargo.toml` and `corpus/`.
pub const TARGETS: [&str; 7] = [
    "measurements_csv",
    "model_toml",
    "calibration_decode",
    "link_frames",
    "device",
    "rsi_rob",
    "egm_robot",
];

/// The seeds of `target`.
pub fn seeds(target: &str) -> Vec<Seed> {
    match target {
        "measurements_csv" => measurements(),
        "model_toml" => models(),
        "calibration_decode" => calibrations(),
        "link_frames" => frames(),
        "device" => streams(),
        "rsi_rob" => robs(),
        "egm_robot" => egm_robots(),
        _ => panic!("no target {target}"),
    }
}

/// A KUKA controller's `<Rob>` datagrams: one line, and pretty-printed with
/// CR LF as a controller prints it.
fn robs() -> Vec<Seed> {
    let rob = r#"<Rob Type="KUKA"><RIst X="445.0" Y="0.0" Z="890.0" A="0.0" B="90.0" C="0.0"/><RSol X="445.0" Y="0.0" Z="890.0" A="0.0" B="90.0" C="0.0"/><AIPos A1="0.0" A2="-90.0" A3="90.0" A4="0.0" A5="90.0" A6="0.0"/><ASPos A1="0.0" A2="-90.0" A3="90.0" A4="0.0" A5="90.0" A6="0.0"/><Delay D="0"/><IPOC>4208163</IPOC></Rob>"#;
    vec![
        ("seed-rob".into(), rob.as_bytes().to_vec()),
        (
            "seed-rob-pretty".into(),
            rob.replace("><", ">\r\n<").into_bytes(),
        ),
    ]
}

/// An ABB controller's `EgmRobot` messages: header, feedback and planned
/// joints, the states; and a header alone.
fn egm_robots() -> Vec<Seed> {
    use armcal::apply::serve::egm::{EgmHeader, EgmJoints, EgmPlanned, EgmRobot, EgmState};
    use prost::Message;
    let joints = EgmPlanned {
        joints: Some(EgmJoints {
            joints: vec![0.0, -30.0, 30.0, 0.0, 90.0, 0.0],
        }),
        ..EgmPlanned::default()
    };
    let header = EgmHeader {
        seqno: Some(12),
        tm: Some(48),
        mtype: Some(2),
    };
    let full = EgmRobot {
        header: Some(header.clone()),
        feed_back: Some(joints.clone()),
        planned: Some(joints),
        motor_state: Some(EgmState { state: 1 }),
        mci_state: Some(EgmState { state: 3 }),
        mci_convergence_met: Some(true),
        rapid_exec_state: Some(EgmState { state: 2 }),
        utilization_rate: Some(10.0),
        ..EgmRobot::default()
    };
    let bare = EgmRobot {
        header: Some(header),
        ..EgmRobot::default()
    };
    vec![
        ("seed-egm-robot".into(), full.encode_to_vec()),
        ("seed-egm-header".into(), bare.encode_to_vec()),
    ]
}

/// The header, comments and first `rows` data rows of a built-in data set.
fn head(name: &str, rows: usize) -> String {
    let (text, _) = armcal::io::builtin::builtin_data(name).expect("a built-in data set");
    let mut out = String::new();
    let mut data = 0;
    let mut header = false;
    for line in text.lines() {
        let is_data = header && !line.starts_with('#') && !line.trim().is_empty();
        header |= !line.starts_with('#') && !line.trim().is_empty();
        if is_data {
            data += 1;
            if data > rows {
                break;
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

fn with_selector(selector: u8, text: &str) -> Vec<u8> {
    let mut bytes = vec![selector];
    bytes.extend_from_slice(text.as_bytes());
    bytes
}

fn measurements() -> Vec<Seed> {
    // The selectors index `crate::models()`.
    let puma = "# PUMA, inches and radians\r\n\r\n\
                id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz,t,temp,load,comment\r\n\
                7,0,0,0,0,0,0,10,20,30,1.0005,0,0,0,0.5,21.5,2.0,\"a, b\"\r\n\
                \r\n\
                8,0.1,-0.2,0.3,-0.4,0.5,-0.6,11,19,31,,,,,,,,\r\n";
    let lift = "q1,x,y,z,temp\n0,350,250,130,20\n200,350,250,330,20.5\n400,350,250,530,\n";
    // A session without a tracker: two sockets 2 in apart, a plate touched
    // three times.
    let sockets = "q1,q2,q3,q4,q5,q6,point,plane\n\
                   0,0,0,0,0,0,s.0,\n\
                   0.1,-0.2,0.3,-0.4,0.5,-0.6,s.0,\n\
                   0.2,0.1,-0.1,0.3,0.2,0.1,s.1,\n\
                   -0.2,0.3,0.2,-0.1,0.4,0.2,s.1,\n\
                   distance,s.0,s.1,7,0.002\n\
                   0.3,0.2,0.1,0,0,0,,plate\n\
                   0.4,0.1,0.2,0.1,0,0,,plate\n\
                   0.5,0,0.3,0.2,0,0,,plate\n";
    vec![
        ("seed-puma-optional-columns".into(), with_selector(0, puma)),
        (
            "seed-talos-time".into(),
            with_selector(1, &head("figaroh-talos-left-arm", 3)),
        ),
        (
            "seed-tiago-prismatic".into(),
            with_selector(2, &head("figaroh-tiago-mocap", 3)),
        ),
        (
            "seed-ur10e-quaternions".into(),
            with_selector(3, &head("figaroh-ur10e-camera", 3)),
        ),
        ("seed-lift-mm-deg".into(), with_selector(4, lift)),
        ("seed-puma-sockets-plate".into(), with_selector(0, sockets)),
    ]
}

fn models() -> Vec<Seed> {
    let mut seeds: Vec<Seed> = armcal::io::builtin::MODELS
        .iter()
        .map(|m| (format!("seed-{}", m.name), m.text.as_bytes().to_vec()))
        .collect();
    seeds.push((
        "seed-lift".into(),
        crate::ONE_JOINT_MODEL.as_bytes().to_vec(),
    ));
    seeds
}

/// `cal` as a file of an older `version`, as older armcal wrote it: version
/// 2 without the frame of the targets and the ranges, version 3 without the
/// ranges.
fn older(cal: &Calibration, version: u16) -> Vec<u8> {
    #[derive(Serialize)]
    struct PayloadV2<'a> {
        nominal: &'a armcal_shared::Robot<f64>,
        errors: &'a [armcal_shared::ParamError],
        orientation: bool,
        units: armcal_shared::units::Units,
        effects: &'a [armcal_shared::effects::Effect<f64>],
    }
    let mut payload = postcard::to_stdvec(&PayloadV2 {
        nominal: &cal.nominal,
        errors: &cal.errors,
        orientation: cal.task == Task::Pose,
        units: cal.units,
        effects: &cal.effects,
    })
    .expect("serialises");
    if version == 3 {
        payload.extend(postcard::to_stdvec(&cal.targets).expect("serialises"));
    }
    let mut file = Vec::with_capacity(HEADER_LEN + payload.len() + 4);
    file.extend_from_slice(&MAGIC);
    file.extend_from_slice(&version.to_le_bytes());
    file.push(cal.nominal.dof() as u8);
    file.push(0);
    file.extend_from_slice(&model_hash(&cal.nominal).to_le_bytes());
    file.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    file.extend_from_slice(&payload);
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&file);
    file.extend_from_slice(&crc.to_le_bytes());
    file
}

fn calibrations() -> Vec<Seed> {
    let puma = calibration_of("puma560", Task::Pose, false);
    let talos = calibration_of("figaroh-talos-left-arm", Task::Position, true);
    let mut lift = Calibration::nominal(
        crate::models()[4].robot.clone(),
        Task::Pose,
        crate::models()[4].units,
    );
    lift.targets = armcal_shared::TargetFrame::Base;
    let v2 = older(&talos, OLDEST_VERSION);
    let v3 = older(&lift, 3);
    assert_eq!(
        Calibration::decode(&v2).map(|c| c.effects),
        Ok(talos.effects.clone()),
        "the version 2 seed reads"
    );
    assert_eq!(
        Calibration::decode(&v3).map(|c| (c.targets, c.ranges)),
        Ok((lift.targets, None)),
        "the version 3 seed reads, its ranges unknown"
    );
    let seed = |mode: u8, file: Vec<u8>| [vec![mode], file].concat();
    vec![
        ("seed-puma".into(), seed(0, file_of(&puma))),
        ("seed-talos-effects-fixup".into(), seed(1, file_of(&talos))),
        ("seed-lift-base-frame".into(), seed(0, file_of(&lift))),
        ("seed-talos-version2-fixup".into(), seed(1, v2)),
        ("seed-lift-version3".into(), seed(0, v3)),
    ]
}

/// The frames of `messages`, one after the other.
fn framed<T: Serialize>(messages: &[T]) -> Vec<u8> {
    let mut bytes = Vec::new();
    for m in messages {
        let mut buf = [0u8; MAX_FRAME];
        bytes.extend_from_slice(link::encode(m, &mut buf).expect("fits a frame"));
    }
    bytes
}

fn command(seq: u32, q: &[f32], context: Option<Context>) -> Request {
    Request::Command(Command {
        seq,
        q: q.iter().copied().collect(),
        context,
    })
}

const Q6: [f32; 6] = [0.3, -1.1, 1.4, -0.6, 1.2, 0.4];
const Q9: [f32; 9] = [0.1, -0.1, -1.2, 1.1, -0.3, -1.7, 0.0, -0.05, -0.1];

fn frames() -> Vec<Seed> {
    let requests = [
        Request::Hello { nonce: 7 },
        Request::Status,
        command(
            1,
            &Q6,
            Some(Context {
                temperature: Some(21.5),
                payload: None,
            }),
        ),
        command(2, &Q9, None),
        load_requests(&file_of(&calibration_of("puma560", Task::Pose, false)))[0].clone(),
        Request::Ranges,
        Request::Halt,
    ];
    let responses = [
        Response::Hello {
            nonce: 7,
            status: StatusReport::default(),
        },
        Response::ChunkReceived { received: 128 },
        Response::CalibrationAccepted {
            joints: 6,
            orientation: true,
            model_hash: 0x0123_4567_89ab_cdef,
        },
        Response::CalibrationRejected {
            reason: Rejection::Crc,
        },
        Response::Corrected(Corrected {
            seq: 1,
            status: TickStatus::Limited,
            q: Q6.iter().copied().collect(),
            iterations: 3,
            residual: 1e-6,
        }),
        Response::Status(StatusReport {
            joints: 6,
            ticks: 100,
            last_rejection: Some(Rejection::ErrorTooLarge),
            ..StatusReport::default()
        }),
        Response::FrameRejected {
            reason: FrameError::Cobs,
        },
        Response::Ranges(RangeReport {
            known: true,
            ticks_outside: 3,
            outside: Outside {
                joints: 0b101,
                temperature: true,
                load: false,
            },
        }),
    ];
    // A lone 0x00 first, as `armcal stream` opens; a too-long frame; a bad one.
    let mut noisy = vec![0u8];
    noisy.extend(std::iter::repeat_n(0x55, MAX_FRAME + 3));
    noisy.push(0);
    noisy.extend_from_slice(&[0x09, 1, 2, 0]);
    noisy.extend_from_slice(&HALT_FRAME);
    vec![
        ("seed-requests".into(), framed(&requests)),
        ("seed-responses".into(), framed(&responses)),
        ("seed-noise".into(), noisy),
    ]
}

fn streams() -> Vec<Seed> {
    // The selectors index the devices of `crate::device`: none, PUMA, TALOS.
    let puma = file_of(&calibration_of("puma560", Task::Pose, false));
    let talos = file_of(&calibration_of(
        "figaroh-talos-left-arm",
        Task::Position,
        true,
    ));
    let warm = Some(Context {
        temperature: Some(35.0),
        payload: Some(2.0),
    });
    let ticks = |q: &[f32], from: u32, n: u32, context: Option<Context>| -> Vec<Request> {
        (0..n)
            .map(|i| {
                let q: Vec<f32> = q.iter().map(|x| x + 0.01 * i as f32).collect();
                command(from + i, &q, context)
            })
            .collect()
    };
    let session = |selector: u8, requests: Vec<Request>| {
        let mut bytes = vec![selector, 0];
        bytes.extend(framed(&requests));
        bytes
    };
    let mut damaged = talos.clone();
    damaged[40] ^= 0x10;
    vec![
        (
            "seed-uncalibrated-then-load".into(),
            session(
                0,
                [
                    vec![Request::Hello { nonce: 1 }],
                    ticks(&Q6, 0, 2, None),
                    load_requests(&puma),
                    ticks(&Q6, 2, 4, None),
                    vec![Request::Status],
                ]
                .concat(),
            ),
        ),
        (
            "seed-puma-ticks".into(),
            session(
                1,
                [
                    vec![Request::Hello { nonce: 2 }],
                    ticks(&Q6, 0, 4, warm),
                    ticks(&Q6[..5], 9, 1, None),
                    vec![Request::Ranges, Request::Halt],
                ]
                .concat(),
            ),
        ),
        (
            "seed-puma-replaced-by-talos".into(),
            session(
                1,
                [
                    load_requests(&talos),
                    ticks(&Q9, 0, 3, warm),
                    vec![Request::Status],
                ]
                .concat(),
            ),
        ),
        (
            "seed-talos-refuses-damaged".into(),
            session(
                2,
                [
                    ticks(&Q9, 0, 2, warm),
                    load_requests(&damaged),
                    ticks(&Q9, 2, 2, warm),
                    vec![Request::Status],
                ]
                .concat(),
            ),
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn corpus(target: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("corpus")
            .join(target)
    }

    /// Runs `target`'s harness on `bytes`.
    fn harness(target: &str, bytes: &[u8]) {
        match target {
            "measurements_csv" => drop(crate::measurements::run(bytes)),
            "model_toml" => drop(crate::model_toml::run(bytes)),
            "calibration_decode" => drop(crate::calibration::run(bytes)),
            "link_frames" => drop(crate::link_frames::run(bytes)),
            "device" => drop(crate::device::run(bytes)),
            "rsi_rob" => drop(crate::rsi_rob::run(bytes)),
            "egm_robot" => drop(crate::egm_robot::run(bytes)),
            _ => panic!("no target {target}"),
        }
    }

    /// Rewrites the seeds of every target (`cargo test -- --ignored write_seeds`).
    #[test]
    #[ignore]
    fn write_seeds() {
        for target in TARGETS {
            let dir = corpus(target);
            std::fs::create_dir_all(&dir).unwrap();
            for (name, bytes) in seeds(target) {
                std::fs::write(dir.join(name), bytes).unwrap();
            }
        }
    }

    /// Every seed passes its harness, and is what it is meant to be: files
    /// that are accepted, frames that decode, streams that load and refuse
    /// calibrations and correct commands.
    #[test]
    fn seeds_pass_and_are_valid() {
        use crate::device::Summary;
        for (name, bytes) in seeds("measurements_csv") {
            assert!(crate::measurements::run(&bytes), "{name} is accepted");
        }
        for (name, bytes) in seeds("model_toml") {
            assert!(crate::model_toml::run(&bytes), "{name} is accepted");
        }
        for (name, bytes) in seeds("calibration_decode") {
            assert!(crate::calibration::run(&bytes), "{name} is accepted");
        }
        for target in ["rsi_rob", "egm_robot"] {
            for (name, bytes) in seeds(target) {
                let read = match target {
                    "rsi_rob" => crate::rsi_rob::run(&bytes),
                    _ => crate::egm_robot::run(&bytes),
                };
                assert!(read, "{name} is read");
            }
        }
        let decoded: Vec<usize> = seeds("link_frames")
            .iter()
            .map(|(_, bytes)| crate::link_frames::run(bytes))
            .collect();
        assert_eq!(decoded, [7, 8, 1]);
        let summaries: Vec<Summary> = seeds("device")
            .iter()
            .map(|(_, bytes)| crate::device::run(bytes))
            .collect();
        let counts: Vec<[usize; 4]> = summaries
            .iter()
            .map(|s| [s.accepted, s.rejected, s.corrected, s.frame_errors])
            .collect();
        assert_eq!(
            counts,
            [[1, 0, 4, 0], [0, 0, 5, 0], [1, 0, 3, 0], [0, 1, 4, 0]]
        );
    }

    /// Every file of every corpus (the seeds, what the fuzzer kept, the
    /// reproducers of past findings) passes its harness.
    #[test]
    fn corpora_pass() {
        for target in TARGETS {
            let Ok(entries) = std::fs::read_dir(corpus(target)) else {
                continue;
            };
            for entry in entries {
                let path = entry.unwrap().path();
                let bytes = std::fs::read(&path).unwrap();
                eprintln!("{}", path.display());
                harness(target, &bytes);
            }
        }
    }
}
