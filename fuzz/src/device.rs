//! `device`: the controller's protocol state machine, `Device`, fed an
//! arbitrary byte stream exactly as the firmware's loop feeds it (`FrameBuffer`
//! → `decode::<Request>` → `Device::handle` or `Device::frame_error` →
//! `encode` of the response → `tick_done` after a command).
//!
//! The input's first byte chooses the device's state before the stream: no
//! calibration; a PUMA 560 calibration (errors of every kind of parameter,
//! full pose); or a 9-joint TALOS calibration with one effect of each kind
//! (position only). The calibrations are written by the project's own encoder
//! and loaded through the link, in chunks, as `armcal stream` loads them.
//!
//! Asserts, after every frame: no panic; and
//! - bounded memory: the receiver, the device and the response encoder make
//!   no heap allocation (all their buffers are fixed-size), every response
//!   fits a frame (`encode` into `MAX_FRAME` bytes: the firmware stops on
//!   one that does not), `ChunkReceived` never counts more than
//!   `MAX_FILE_LEN` bytes, the joint count in force is at most `MAX_JOINTS`;
//! - the calibration in force changes only on `CalibrationAccepted`: after
//!   `CalibrationRejected` (and after any other response, and at the end of
//!   the stream) the compensator in force is the previous one, field for
//!   field (compared by its `Debug` text, every `f32` to the bit), and the
//!   status' joints, model hash and load count are unchanged, its last
//!   rejection is the refusal's reason; after an acceptance the status
//!   reports the accepted joints and model hash and one more load;
//! - a command is answered with as many joint values as it had; uncalibrated
//!   exactly when no calibration is in force (the commands then unchanged);
//!   every status but `NonFinite` (and a command that was not finite) comes
//!   with finite commands; the counters count each command once.

use armcal_shared::compensation::Task;
use std::sync::OnceLock;

use armcal_shared::calibration::MAX_FILE_LEN;
use armcal_shared::link::{
    self, CHUNK_LEN, Device, FrameBuffer, MAX_FRAME, Request, Response, StatusReport, TickStatus,
};
use armcal_shared::{Calibration, MAX_JOINTS};

/// The tick period of the fuzzed device, cycles; every command is recorded
/// as taking [`TICK_CYCLES`].
const TICK_PERIOD: u32 = 1000;
const TICK_CYCLES: u32 = 500;

/// The requests that load `file` in chunks of [`CHUNK_LEN`] bytes.
pub fn load_requests(file: &[u8]) -> Vec<Request> {
    file.chunks(CHUNK_LEN)
        .enumerate()
        .map(|(i, part)| Request::CalibrationChunk {
            total: file.len() as u16,
            offset: (i * CHUNK_LEN) as u16,
            bytes: part.iter().copied().collect(),
        })
        .collect()
}

/// The file of `cal`, by the project's encoder.
pub fn file_of(cal: &Calibration) -> Vec<u8> {
    cal.to_bytes().expect("the calibration encodes")
}

/// The devices a stream starts from; see [the module](self).
fn devices() -> &'static [Device; 3] {
    static DEVICES: OnceLock<[Device; 3]> = OnceLock::new();
    DEVICES.get_or_init(|| {
        let loaded = |cal: Calibration| {
            let mut device = Device::new(TICK_PERIOD);
            let mut last = None;
            for request in load_requests(&file_of(&cal)) {
                last = Some(device.handle(&request, &mut ()));
            }
            assert!(
                matches!(last, Some(Response::CalibrationAccepted { .. })),
                "the reference calibration loads: {last:?}"
            );
            device
        };
        [
            Device::new(TICK_PERIOD),
            loaded(crate::calibration_of("puma560", Task::Pose, false)),
            loaded(crate::calibration_of(
                "figaroh-talos-left-arm",
                Task::Position,
                true,
            )),
        ]
    })
}

/// The identity of the calibration in force: the compensator's every field.
fn in_force(device: &Device) -> Option<String> {
    device.compensator().map(|c| format!("{c:?}"))
}

/// What a stream did, for the tests of the seeds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Calibrations accepted.
    pub accepted: usize,
    /// Calibrations refused.
    pub rejected: usize,
    /// Commands corrected by a calibration (any status but `Uncalibrated`).
    pub corrected: usize,
    /// Frames refused.
    pub frame_errors: usize,
}

/// The harness; see [the module](self).
pub fn run(data: &[u8]) -> Summary {
    let mut summary = Summary::default();
    let Some((&selector, stream)) = data.split_first() else {
        return summary;
    };
    let devices = devices();
    let mut device = devices[usize::from(selector) % devices.len()].clone();
    let mut frames = FrameBuffer::new();
    let mut out = [0u8; MAX_FRAME];
    let mut identity = in_force(&device);
    let mut before: StatusReport = device.status(&());
    for &byte in stream {
        let allocations = crate::allocations();
        let Some(frame) = frames.push(byte) else {
            continue;
        };
        let request = frame.and_then(link::decode::<Request>);
        let response = match &request {
            Ok(request) => device.handle(request, &mut ()),
            Err(e) => device.frame_error(*e),
        };
        let encoded = link::encode(&response, &mut out).is_ok();
        if matches!(request, Ok(Request::Command(_))) {
            device.tick_done(TICK_CYCLES);
        }
        assert_eq!(
            crate::allocations(),
            allocations,
            "the device allocated (request {request:?}, response {response:?})"
        );
        assert!(encoded, "the response does not fit a frame: {response:?}");
        let now = device.status(&());
        assert!(usize::from(now.joints) <= MAX_JOINTS);
        assert_eq!(now.joints == 0, !device.is_calibrated());
        match &response {
            Response::CalibrationAccepted {
                joints, model_hash, ..
            } => {
                assert!(device.is_calibrated());
                assert_eq!(
                    (now.joints, now.model_hash, now.loads),
                    (*joints, *model_hash, before.loads + 1)
                );
                identity = in_force(&device);
                summary.accepted += 1;
            }
            other => {
                if let Response::CalibrationRejected { reason } = other {
                    assert_eq!(now.last_rejection, Some(*reason));
                    summary.rejected += 1;
                }
                assert_eq!(
                    (now.joints, now.model_hash, now.loads),
                    (before.joints, before.model_hash, before.loads),
                    "the calibration in force changed without an acceptance: {other:?}"
                );
                if matches!(other, Response::CalibrationRejected { .. }) {
                    assert!(
                        in_force(&device) == identity,
                        "a refused calibration replaced the one in force"
                    );
                }
            }
        }
        match (&request, &response) {
            (Ok(Request::Command(command)), Response::Corrected(c)) => {
                assert_eq!(c.seq, command.seq);
                assert_eq!(c.q.len(), command.q.len());
                assert_eq!(now.ticks, before.ticks + 1);
                let uncalibrated = c.status == TickStatus::Uncalibrated;
                summary.corrected += usize::from(!uncalibrated);
                assert_eq!(uncalibrated, !device.is_calibrated());
                if uncalibrated || c.status == TickStatus::JointCount {
                    assert_eq!(
                        c.q.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                        command.q.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                        "commands passed through unchanged"
                    );
                }
                let finite_in = command.q.iter().all(|x| x.is_finite());
                if c.status != TickStatus::NonFinite && finite_in {
                    assert!(
                        c.q.iter().all(|x| x.is_finite()),
                        "non-finite commands with status {:?}: {command:?} -> {c:?}",
                        c.status
                    );
                }
                assert_eq!(
                    now.faults - before.faults,
                    u32::from(!uncalibrated && !c.status.is_corrected())
                );
                assert_eq!(
                    now.uncalibrated - before.uncalibrated,
                    u32::from(uncalibrated)
                );
            }
            (Ok(Request::Command(_)), other) => panic!("a command answered with {other:?}"),
            (Ok(Request::Ranges), Response::Ranges(r)) => {
                assert!(
                    !r.known || device.is_calibrated(),
                    "ranges without a calibration"
                );
                assert!(
                    r.ticks_outside <= now.ticks,
                    "more ticks outside than ticks"
                );
                assert!(
                    r.known || r.ticks_outside == 0,
                    "ticks judged without ranges"
                );
            }
            (Ok(Request::Ranges), other) => panic!("Ranges answered with {other:?}"),
            (_, Response::ChunkReceived { received }) => {
                assert!(usize::from(*received) <= MAX_FILE_LEN);
            }
            (Err(_), other) => {
                assert!(matches!(other, Response::FrameRejected { .. }));
                assert_eq!(now.frame_errors, before.frame_errors + 1);
                summary.frame_errors += 1;
            }
            _ => {}
        }
        before = now;
    }
    assert!(
        in_force(&device) == identity,
        "the calibration in force changed without an acceptance"
    );
    summary
}
