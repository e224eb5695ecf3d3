//! The link's messages: [`Request`] (host → controller), [`Response`]
//! (controller → host) and what they carry, with the reasons a calibration is
//! refused ([`Rejection`]) and the controller's reports ([`StatusReport`],
//! [`RangeReport`]).
//!
//! Wire convention: each message is postcard (not self-describing: fields in
//! declaration order, enum variants by index), framed by [`super::frame`]. A
//! message's fields never change; new requests and responses are new variants
//! at the end of their enum, so that older builds decode the old ones as
//! before (see the link module's "Compatibility").
//!
//! Units: joint values in `f32`, rad (revolute) or m (prismatic), in the
//! model's joint order; temperature °C, payload kg; residuals m; durations
//! core clock cycles; calibration chunks at most [`CHUNK_LEN`] bytes.

use heapless::Vec;
use serde::{Deserialize, Serialize};

use super::frame::FrameError;
use crate::calibration::MagnitudeError;
use crate::compensation::Fault;
use crate::ranges::Outside;
use crate::{CalibrationError, MAX_JOINTS};

/// The most calibration bytes one [`Request::CalibrationChunk`] carries.
pub const CHUNK_LEN: usize = 128;

/// The conditions of a tick that non-geometric effects depend on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Context {
    /// Temperature, °C.
    pub temperature: Option<f32>,
    /// Payload mass, kg.
    pub payload: Option<f32>,
}

/// One servo tick's nominal joint commands.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Command {
    /// Sequence number, one more than the previous command's.
    pub seq: u32,
    /// Joint commands of the nominal model, rad or m.
    pub q: Vec<f32, MAX_JOINTS>,
    /// The tick's conditions, if known.
    pub context: Option<Context>,
}

/// Host → controller.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Request {
    /// A part of a calibration file.
    CalibrationChunk {
        /// Bytes of the whole file.
        total: u16,
        /// Where these bytes start in the file; 0 starts a new file.
        offset: u16,
        /// The bytes.
        bytes: Vec<u8, CHUNK_LEN>,
    },
    /// One tick's commands, to be corrected.
    Command(Command),
    /// Ask for a [`StatusReport`].
    Status,
    /// Stop serving after the final [`StatusReport`].
    Halt,
    /// Open a session: answered by [`Response::Hello`] with the same nonce.
    Hello {
        /// Chosen by the host, new for each try.
        nonce: u32,
    },
    /// Ask for a [`RangeReport`].
    Ranges,
}

/// What a correction is: the status of one tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TickStatus {
    /// Corrected to the tolerance.
    Corrected,
    /// No calibration in force: the commands pass through unchanged.
    Uncalibrated,
    /// A command was not finite, or a value on the way was not: the nominal
    /// commands are returned.
    NonFinite,
    /// Not the calibration's number of joints: the commands are returned unchanged.
    JointCount,
    /// The residual stayed above the tolerance (near a singularity or out of
    /// reach): the best correction found, bounded.
    NotConverged,
    /// The correction was clipped to its size or change-per-tick bound.
    Limited,
}

impl TickStatus {
    /// True if the commands are the calibrated robot's, to the tolerance.
    pub fn is_corrected(self) -> bool {
        self == Self::Corrected
    }
}

impl From<Option<Fault>> for TickStatus {
    fn from(fault: Option<Fault>) -> Self {
        match fault {
            None => Self::Corrected,
            Some(Fault::NonFinite) => Self::NonFinite,
            Some(Fault::JointCount) => Self::JointCount,
            Some(Fault::NotConverged) => Self::NotConverged,
            Some(Fault::Limited) => Self::Limited,
        }
    }
}

/// One tick's corrected commands.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Corrected {
    /// The command's sequence number.
    pub seq: u32,
    /// What the correction is.
    pub status: TickStatus,
    /// The commands to send to the drives, rad or m.
    pub q: Vec<f32, MAX_JOINTS>,
    /// Refinement iterations run.
    pub iterations: u8,
    /// The residual before bounding, m (see [`crate::compensation::Correction`]).
    pub residual: f32,
}

/// Why a calibration was refused: the [`CalibrationError`] as a code, or a
/// reason of the link or of the magnitude policy
/// ([`check_magnitudes`](super::check_magnitudes)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Rejection {
    /// [`CalibrationError::Truncated`].
    Truncated,
    /// [`CalibrationError::TooLong`], or chunks that overrun the announced size or
    /// [`MAX_FILE_LEN`](crate::calibration::MAX_FILE_LEN).
    TooLong,
    /// [`CalibrationError::BadMagic`]: not a calibration file.
    BadMagic,
    /// [`CalibrationError::NewerVersion`].
    NewerVersion,
    /// [`CalibrationError::BadVersion`].
    BadVersion,
    /// [`CalibrationError::Crc`]: damaged bytes.
    Crc,
    /// [`CalibrationError::Payload`].
    Payload,
    /// [`CalibrationError::JointCount`].
    JointCount,
    /// [`CalibrationError::ModelHash`].
    ModelHash,
    /// [`CalibrationError::NonFinite`].
    NonFinite,
    /// [`CalibrationError::UnknownParam`].
    UnknownParam,
    /// [`CalibrationError::DuplicateParam`].
    DuplicateParam,
    /// An identified error above [`MAX_ERROR_ANGLE`](crate::calibration::MAX_ERROR_ANGLE)
    /// or [`MAX_ERROR_LENGTH`](crate::calibration::MAX_ERROR_LENGTH)
    /// ([`MagnitudeError::ErrorTooLarge`]).
    ErrorTooLarge,
    /// A chunk that does not continue the file being received (wrong offset or total).
    ChunkOutOfOrder,
    /// An effect parameter beyond what a real arm shows
    /// ([`MagnitudeError::EffectTooLarge`]).
    EffectTooLarge,
    /// Any other reason.
    Other,
    /// [`CalibrationError::Ranges`].
    Ranges,
}

impl From<&CalibrationError> for Rejection {
    fn from(e: &CalibrationError) -> Self {
        match e {
            CalibrationError::Truncated { .. } => Self::Truncated,
            CalibrationError::TooLong { .. } => Self::TooLong,
            CalibrationError::BadMagic => Self::BadMagic,
            CalibrationError::NewerVersion { .. } => Self::NewerVersion,
            CalibrationError::BadVersion { .. } => Self::BadVersion,
            CalibrationError::Crc { .. } => Self::Crc,
            CalibrationError::Payload => Self::Payload,
            CalibrationError::JointCount { .. } => Self::JointCount,
            CalibrationError::ModelHash { .. } => Self::ModelHash,
            CalibrationError::NonFinite => Self::NonFinite,
            CalibrationError::UnknownParam { .. } => Self::UnknownParam,
            CalibrationError::DuplicateParam { .. } => Self::DuplicateParam,
            CalibrationError::EffectJoint => Self::UnknownParam,
            CalibrationError::Ranges => Self::Ranges,
            CalibrationError::HeldOut
            | CalibrationError::NegativeMass { .. }
            | CalibrationError::BufferTooSmall => Self::Other,
        }
    }
}

impl From<MagnitudeError> for Rejection {
    fn from(e: MagnitudeError) -> Self {
        match e {
            MagnitudeError::ErrorTooLarge => Self::ErrorTooLarge,
            MagnitudeError::EffectTooLarge => Self::EffectTooLarge,
        }
    }
}

impl Rejection {
    /// What is wrong, and what to do, in a few words.
    pub fn message(self) -> &'static str {
        match self {
            Self::Truncated => "truncated: fewer bytes than the file declares",
            Self::TooLong => "too long: more bytes than the file declares or the controller holds",
            Self::BadMagic => "not an armcal calibration file (wrong magic bytes)",
            Self::NewerVersion => "written in a newer format version than the firmware reads",
            Self::BadVersion => "a format version that does not exist",
            Self::Crc => "damaged: the CRC does not match",
            Self::Payload => "damaged: the payload does not decode",
            Self::JointCount => "the header's joint count is not the model's",
            Self::ModelHash => "the header's model hash is not the model's",
            Self::NonFinite => "a value is not a finite number",
            Self::UnknownParam => "an identified parameter the model does not have",
            Self::DuplicateParam => "a parameter identified twice",
            Self::ErrorTooLarge => {
                "an identified error above 0.5 rad or 0.5 m: fix the nominal model instead"
            }
            Self::ChunkOutOfOrder => "chunks out of order: send the file again from offset 0",
            Self::EffectTooLarge => {
                "an effect parameter beyond what a real arm shows: check the diagnosis"
            }
            Self::Other => "refused",
            Self::Ranges => "the identified ranges are not one finite interval per joint",
        }
    }
}

impl core::fmt::Display for Rejection {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message())
    }
}

impl core::error::Error for Rejection {}

/// The controller's counters and state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StatusReport {
    /// Joints of the calibration in force; 0 when there is none.
    pub joints: u8,
    /// The model hash of the calibration in force (0 when there is none).
    pub model_hash: u64,
    /// Commands handled since boot.
    pub ticks: u32,
    /// Commands whose status was neither corrected nor uncalibrated.
    pub faults: u32,
    /// Commands passed through for want of a calibration.
    pub uncalibrated: u32,
    /// Commands whose sequence number did not follow the previous one.
    pub sequence_gaps: u32,
    /// Commands that took longer than the tick period.
    pub deadline_misses: u32,
    /// The longest command, cycles (0 if not measured).
    pub worst_tick_cycles: u32,
    /// The tick period the durations are checked against, cycles.
    pub tick_period_cycles: u32,
    /// Frames refused since boot.
    pub frame_errors: u32,
    /// Calibrations accepted since boot.
    pub loads: u32,
    /// Why the last refused calibration was refused.
    pub last_rejection: Option<Rejection>,
    /// The most stack used since boot, bytes (0 if not measured).
    pub stack_used: u32,
}

/// The ticks outside the ranges the calibration in force was identified on
/// ([`crate::ranges`]), counted since it was loaded. They are corrected all
/// the same: the count says where the correction extrapolates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RangeReport {
    /// True if the calibration in force records its ranges; false with none in
    /// force, or one written before the ranges were recorded (format version 3
    /// and older), whose ticks are not judged.
    pub known: bool,
    /// Ticks with a joint, or the temperature or payload of their context,
    /// outside the ranges.
    pub ticks_outside: u32,
    /// Which of them were outside, over those ticks.
    pub outside: Outside,
}

/// Controller → host.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Response {
    /// A chunk was stored; `received` bytes of the file so far.
    ChunkReceived {
        /// Bytes received so far.
        received: u16,
    },
    /// The whole calibration was validated and is now in force.
    CalibrationAccepted {
        /// Its joint count.
        joints: u8,
        /// True if it corrects the orientation too.
        orientation: bool,
        /// Its model hash.
        model_hash: u64,
    },
    /// The calibration was refused; the previous one (or none) stays in force.
    CalibrationRejected {
        /// Why.
        reason: Rejection,
    },
    /// One tick's corrected commands.
    Corrected(Corrected),
    /// The counters.
    Status(StatusReport),
    /// A frame that was not a request.
    FrameRejected {
        /// Why.
        reason: FrameError,
    },
    /// The answer to [`Request::Hello`].
    Hello {
        /// The request's nonce.
        nonce: u32,
        /// The counters.
        status: StatusReport,
    },
    /// The answer to [`Request::Ranges`].
    Ranges(RangeReport),
}

#[cfg(test)]
pub(super) mod tests {
    use serde::Serialize;
    use serde::de::DeserializeOwned;

    use super::*;
    use crate::calibration::MAX_FILE_LEN;
    use crate::link::{FrameBuffer, HALT_FRAME, MAX_FRAME, decode, encode};

    fn round_trip<T: Serialize + DeserializeOwned + PartialEq + core::fmt::Debug>(message: &T) {
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode(message, &mut buf).unwrap();
        assert_eq!(frame.last(), Some(&0), "ends with the delimiter");
        assert!(
            frame[..frame.len() - 1].iter().all(|&b| b != 0),
            "no 0x00 inside a frame"
        );
        // Through the stream splitter, as the receiver sees it.
        let mut rx = FrameBuffer::new();
        let mut got = None;
        for &b in frame.iter() {
            if let Some(f) = rx.push(b) {
                got = Some(decode::<T>(f.unwrap()).unwrap());
            }
        }
        assert_eq!(got.as_ref(), Some(message));
    }

    pub(in crate::link) fn command(seq: u32, q: &[f32]) -> Command {
        Command {
            seq,
            q: q.iter().copied().collect(),
            context: Some(Context {
                temperature: Some(21.5),
                payload: None,
            }),
        }
    }

    /// Every message survives encode → split → decode unchanged, and the largest
    /// ones fit a frame.
    #[test]
    fn every_message_round_trips() {
        let full: Vec<u8, CHUNK_LEN> = (0..CHUNK_LEN).map(|i| (i % 7) as u8).collect();
        round_trip(&Request::CalibrationChunk {
            total: MAX_FILE_LEN as u16,
            offset: (MAX_FILE_LEN - CHUNK_LEN) as u16,
            bytes: full,
        });
        round_trip(&Request::Command(command(
            u32::MAX,
            &[f32::MAX; MAX_JOINTS],
        )));
        round_trip(&Request::Command(Command {
            seq: 0,
            q: Vec::new(),
            context: None,
        }));
        round_trip(&Request::Status);
        round_trip(&Request::Halt);
        round_trip(&Request::Hello { nonce: u32::MAX });
        round_trip(&Response::Hello {
            nonce: 9,
            status: StatusReport::default(),
        });
        let mut buf = [0u8; MAX_FRAME];
        assert_eq!(encode(&Request::Halt, &mut buf).unwrap(), &HALT_FRAME[..]);
        round_trip(&Response::ChunkReceived { received: 128 });
        round_trip(&Response::CalibrationAccepted {
            joints: 6,
            orientation: true,
            model_hash: u64::MAX,
        });
        round_trip(&Response::CalibrationRejected {
            reason: Rejection::Crc,
        });
        round_trip(&Response::Corrected(Corrected {
            seq: 7,
            status: TickStatus::Limited,
            q: [-1.5f32; MAX_JOINTS].iter().copied().collect(),
            iterations: 4,
            residual: 1e-7,
        }));
        round_trip(&Response::Status(StatusReport {
            last_rejection: Some(Rejection::ErrorTooLarge),
            ticks: u32::MAX,
            model_hash: u64::MAX,
            ..StatusReport::default()
        }));
        round_trip(&Response::FrameRejected {
            reason: FrameError::Cobs,
        });
        round_trip(&Request::Ranges);
        round_trip(&Response::Ranges(RangeReport {
            known: true,
            ticks_outside: u32::MAX,
            outside: Outside {
                joints: u16::MAX,
                temperature: true,
                load: true,
            },
        }));
        round_trip(&Response::CalibrationRejected {
            reason: Rejection::Ranges,
        });
    }

    /// The messages before [`Request::Ranges`] keep their bytes: an older
    /// controller or host reads them as before, and answers the new request
    /// it does not know as a frame that is not a request.
    #[test]
    fn new_messages_leave_the_old_ones_unchanged() {
        let mut buf = [0u8; MAX_FRAME];
        let bytes = |m: &Request, buf: &mut [u8; MAX_FRAME]| encode(m, buf).unwrap().to_vec();
        // The variant indices of postcard: Status 2, Halt 3, Hello 4, Ranges 5.
        assert_eq!(bytes(&Request::Status, &mut buf), [0x02, 0x02, 0x00]);
        assert_eq!(bytes(&Request::Halt, &mut buf), HALT_FRAME);
        assert_eq!(bytes(&Request::Ranges, &mut buf), [0x02, 0x05, 0x00]);
    }
}
