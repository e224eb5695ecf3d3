//! The serial link between the calibrator (`armcal stream`) and the controller:
//! the wire messages, their framing, and the controller's side of the protocol
//! ([`Device`]), defined once for both ends.
//!
//! # Framing
//!
//! Every message is one [`Request`] (host → controller) or one [`Response`]
//! (controller → host), serialised with postcard, COBS-encoded and terminated by
//! a `0x00` byte ([`encode`]). A frame holds at most [`MAX_FRAME`] bytes with its
//! delimiter. The receiver ([`FrameBuffer`]) splits the byte stream at each `0x00`;
//! an empty frame is ignored, so a sender may open with a lone `0x00` to end any
//! partial frame left on the line. A frame that is too long, is not valid COBS,
//! does not decode as a message, or has bytes left after the message is refused
//! ([`decode`], [`FrameError`]); the controller answers it with
//! [`Response::FrameRejected`].
//!
//! # Protocol
//!
//! Lock-step: the host sends one request and waits for its one response. A
//! session opens with [`Request::Hello`], repeated with a new nonce until the
//! answer with the latest nonce arrives (answers to earlier tries are skipped):
//! a controller that is still booting, or a UART that dropped bytes, costs a
//! retry, and afterwards requests and responses are in step.
//!
//! | request | response | meaning |
//! | --- | --- | --- |
//! | [`Request::Hello`] `{ nonce }` | [`Response::Hello`] `{ nonce, status }` | opens a session |
//! | [`Request::CalibrationChunk`] `{ total, offset, bytes }` | [`Response::ChunkReceived`] `{ received }` | part of a calibration file (the bytes of `armcal identify --out`), in order, at most [`CHUNK_LEN`] bytes each, `offset` 0 starts a new file |
//! | the last chunk (`offset + len = total`) | [`Response::CalibrationAccepted`] `{ joints, orientation, model_hash }` or [`Response::CalibrationRejected`] `{ reason }` | the whole file, validated before use; a refused one leaves the previous calibration (or none) in force |
//! | [`Request::Command`] `{ seq, q, context }` | [`Response::Corrected`] `{ seq, status, q, iterations, residual }` | one servo tick: the nominal joint commands, the corrected ones |
//! | [`Request::Status`] | [`Response::Status`] ([`StatusReport`]) | the calibration in force, tick, fault and deadline counters, the last refusal, the stack used |
//! | [`Request::Halt`] | [`Response::Status`] | the final report; then the controller stops serving (under QEMU it ends the emulation) |
//! | [`Request::Ranges`] | [`Response::Ranges`] ([`RangeReport`]) | the ticks since the calibration was loaded with a joint, the temperature or the payload outside the ranges it was identified on |
//! | a malformed frame | [`Response::FrameRejected`] `{ reason }` | |
//!
//! # Units
//!
//! Joint values are SI in `f32`: rad for revolute joints, m for prismatic ones,
//! in the order of the model's joints. The optional [`Context`] carries the
//! temperature (°C) and the payload mass (kg) of the tick, which the
//! non-geometric effects of a calibration from `armcal diagnose` depend on
//! ([`Conditions`]; none given: the reference temperature and no payload); the
//! approach direction of each joint comes from the commands sent (see
//! [`crate::compensation`]). Durations are in core clock cycles.
//!
//! # The controller's side
//!
//! [`Device`] is the protocol state machine the firmware runs, and the host's
//! tests run the same code: it assembles and validates the calibration
//! ([`Calibration::decode`], then [`check_magnitudes`]), converts it to `f32`
//! once ([`Compensator::<f32>::from_calibration`]), corrects the commands as
//! one servo [`Stream`] (the per-tick change bound, the approach directions,
//! the warm start), and counts ticks, faults, sequence
//! gaps and deadline misses. After each correction it compares the tick's
//! commands and context with the ranges the calibration was identified on
//! ([`crate::ranges`]) and counts the ticks outside them ([`RangeReport`]); it
//! corrects them all the same. With no calibration in force a command passes
//! through unchanged with [`TickStatus::Uncalibrated`]. Its per-command cost is
//! bounded by [`Limits::max_iterations`] and it never allocates.
//!
//! # Compatibility
//!
//! Messages are postcard, which is not self-describing: a message's fields
//! cannot change without both ends changing. New requests and responses are
//! added as new enum variants at the end, which both ends' older builds
//! decode as before: a controller that does not know a request answers
//! [`Response::FrameRejected`] ([`FrameError::Message`]), and the host reads
//! that as "not reported by this controller".

use heapless::Vec;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::calibration::{MAX_FILE_LEN, model_hash};
use crate::compensation::{Compensator, Conditions, Fault, Limits, Pacing, Stream};
use crate::effects::Effect;
use crate::ranges::{Outside, Ranges};
use crate::{Calibration, CalibrationError, MAX_JOINTS};

/// The most calibration bytes one [`Request::CalibrationChunk`] carries.
pub const CHUNK_LEN: usize = 128;

/// The largest encoded frame, bytes, delimiter included: the largest message
/// (a full chunk, under 140 bytes of postcard) plus COBS' overhead, with room.
pub const MAX_FRAME: usize = 256;

/// The frame of [`Request::Halt`], for scripts that end a controller session
/// without a host program (`firmware/qemu-run.sh`).
pub const HALT_FRAME: [u8; 3] = [0x02, 0x03, 0x00];

/// Identified errors larger than this (rad) are refused by [`check_magnitudes`]:
/// a real robot that far from its nominal model needs a new nominal model, not a
/// correction.
pub const MAX_ERROR_ANGLE: f64 = 0.5;

/// Identified errors larger than this (m) are refused by [`check_magnitudes`].
pub const MAX_ERROR_LENGTH: f64 = 0.5;

/// Effect parameters at or above these are refused by [`check_magnitudes`], as
/// beyond what a real arm shows (a diagnosis that found them found something
/// else): compliance, rad/(N·m) or m/N (also with the proxy torques of a model
/// without masses, a few times 10 N·m); gear-harmonic amplitudes and half the
/// lost motion, rad or m; the thermal coefficient, 1/°C (metals: 1–3 · 10⁻⁵), and
/// its reference temperature, °C; the encoder-scale error, relative.
pub const MAX_COMPLIANCE: f64 = 1e-3;
/// See [`MAX_COMPLIANCE`].
pub const MAX_EFFECT_ANGLE: f64 = 0.05;
/// See [`MAX_COMPLIANCE`].
pub const MAX_EXPANSION: f64 = 1e-3;
/// See [`MAX_COMPLIANCE`].
pub const MAX_REFERENCE_TEMPERATURE: f64 = 200.0;
/// See [`MAX_COMPLIANCE`].
pub const MAX_SCALE_ERROR: f64 = 0.01;

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
/// reason of the link or of [`check_magnitudes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Rejection {
    /// [`CalibrationError::Truncated`].
    Truncated,
    /// [`CalibrationError::TooLong`], or chunks that overrun the announced size or
    /// [`MAX_FILE_LEN`].
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
    /// An identified error above [`MAX_ERROR_ANGLE`] or [`MAX_ERROR_LENGTH`].
    ErrorTooLarge,
    /// A chunk that does not continue the file being received (wrong offset or total).
    ChunkOutOfOrder,
    /// An effect parameter beyond what a real arm shows (see [`check_magnitudes`]).
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
            CalibrationError::HeldOut | CalibrationError::BufferTooSmall => Self::Other,
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

/// Why a frame was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FrameError {
    /// More than [`MAX_FRAME`] bytes before the delimiter.
    TooLong,
    /// Not valid COBS.
    Cobs,
    /// Not a message of the expected type, or bytes left after it.
    Message,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::TooLong => "frame too long",
            Self::Cobs => "frame is not valid COBS",
            Self::Message => "frame does not hold one whole message",
        })
    }
}

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

/// Why a message could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncodeError;

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "message does not fit a frame of {MAX_FRAME} bytes")
    }
}

/// Encodes `message` as a frame into `buf`: postcard, COBS, the `0x00`
/// delimiter. Returns the frame's bytes.
pub fn encode<'a, T: Serialize>(
    message: &T,
    buf: &'a mut [u8],
) -> Result<&'a mut [u8], EncodeError> {
    let n = buf.len().min(MAX_FRAME);
    postcard::to_slice_cobs(message, &mut buf[..n]).map_err(|_| EncodeError)
}

/// Decodes one frame (its bytes before the delimiter, COBS-encoded; decoded in
/// place) as a `T`. Refuses anything but exactly one whole message.
pub fn decode<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
    if frame.len() >= MAX_FRAME {
        return Err(FrameError::TooLong);
    }
    let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
    let (message, rest) =
        postcard::take_from_bytes::<T>(&frame[..n]).map_err(|_| FrameError::Message)?;
    if !rest.is_empty() {
        return Err(FrameError::Message);
    }
    Ok(message)
}

/// Splits a byte stream into frames at each `0x00`.
#[derive(Clone, Debug)]
pub struct FrameBuffer {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflow: bool,
}

impl Default for FrameBuffer {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameBuffer {
    /// An empty buffer.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
        }
    }

    /// Takes one byte. At a delimiter ending a non-empty frame, returns the frame's
    /// bytes (COBS, without the delimiter) for [`decode`], or
    /// [`FrameError::TooLong`] if it overflowed the buffer.
    pub fn push(&mut self, byte: u8) -> Option<Result<&mut [u8], FrameError>> {
        if byte != 0 {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let (len, overflow) = (self.len, self.overflow);
        self.len = 0;
        self.overflow = false;
        if overflow {
            Some(Err(FrameError::TooLong))
        } else if len == 0 {
            None
        } else {
            Some(Ok(&mut self.buf[..len]))
        }
    }
}

/// Refuses a calibration whose identified errors are too large for a
/// correction: above [`MAX_ERROR_ANGLE`] (rad) or [`MAX_ERROR_LENGTH`] (m); or
/// whose effect parameters are beyond their bounds ([`MAX_COMPLIANCE`] and the
/// others). (Its joint count is at most [`MAX_JOINTS`] by construction.)
pub fn check_magnitudes(calibration: &Calibration) -> Result<(), Rejection> {
    let too_large = calibration.errors.iter().any(|e| {
        let max = if e.param.is_angle() {
            MAX_ERROR_ANGLE
        } else {
            MAX_ERROR_LENGTH
        };
        !e.error.is_finite() || e.error.abs() >= max
    });
    if too_large || calibration.nominal.dof() > MAX_JOINTS {
        return Err(Rejection::ErrorTooLarge);
    }
    for e in &calibration.effects {
        // At or beyond the bound, or NaN.
        let beyond =
            |x: f64, max: f64| x.abs().partial_cmp(&max) != Some(core::cmp::Ordering::Less);
        let refused = match *e {
            Effect::JointCompliance { compliance, .. } => beyond(compliance, MAX_COMPLIANCE),
            Effect::GearTransmission { first, second, .. } => first
                .iter()
                .chain(&second)
                .any(|a| beyond(*a, MAX_EFFECT_ANGLE)),
            Effect::Backlash {
                half_lost_motion, ..
            } => beyond(half_lost_motion, MAX_EFFECT_ANGLE),
            Effect::ThermalExpansion {
                coefficient,
                reference,
            } => beyond(coefficient, MAX_EXPANSION) || beyond(reference, MAX_REFERENCE_TEMPERATURE),
            Effect::EncoderScale { scale, .. } => beyond(scale, MAX_SCALE_ERROR),
        };
        if refused {
            return Err(Rejection::EffectTooLarge);
        }
    }
    Ok(())
}

/// What the platform adds to [`Device::handle`]: marks around the correction
/// (the firmware's instruction-count markers) and the stack measurement.
pub trait Platform {
    /// Just before the correction of a command.
    fn before_correct(&mut self) {}
    /// Just after it.
    fn after_correct(&mut self) {}
    /// The most stack used so far, bytes, if measured.
    fn stack_used(&self) -> u32 {
        0
    }
}

/// No markers, no stack measurement (host tests).
impl Platform for () {}

/// The controller's side of the protocol: see [the module](self).
#[derive(Clone, Debug)]
pub struct Device {
    compensator: Option<Compensator<f32>>,
    /// The servo stream: what each tick carries to the next.
    stream: Stream<f32>,
    last_seq: Option<u32>,
    /// The calibration file being received.
    file: Vec<u8, MAX_FILE_LEN>,
    file_total: usize,
    status: StatusReport,
    /// The ranges of the calibration in force, when it records them.
    ranges: Option<Ranges<f32>>,
    range_report: RangeReport,
}

impl Device {
    /// A controller with no calibration, whose ticks last `tick_period_cycles`.
    pub fn new(tick_period_cycles: u32) -> Self {
        Self {
            compensator: None,
            stream: Stream::new(Pacing::Servo),
            last_seq: None,
            file: Vec::new(),
            file_total: 0,
            status: StatusReport {
                joints: 0,
                model_hash: 0,
                ticks: 0,
                faults: 0,
                uncalibrated: 0,
                sequence_gaps: 0,
                deadline_misses: 0,
                worst_tick_cycles: 0,
                tick_period_cycles,
                frame_errors: 0,
                loads: 0,
                last_rejection: None,
                stack_used: 0,
            },
            ranges: None,
            range_report: RangeReport {
                known: false,
                ticks_outside: 0,
                outside: Outside {
                    joints: 0,
                    temperature: false,
                    load: false,
                },
            },
        }
    }

    /// True if a calibration is in force.
    pub fn is_calibrated(&self) -> bool {
        self.compensator.is_some()
    }

    /// The compensation in force, built from the last accepted calibration;
    /// `None` before the first. Read-only: for the tests and fuzz targets that
    /// check that a refused calibration never replaces the one in force.
    pub fn compensator(&self) -> Option<&Compensator<f32>> {
        self.compensator.as_ref()
    }

    /// The counters, with the stack measurement of `platform`.
    pub fn status(&self, platform: &impl Platform) -> StatusReport {
        StatusReport {
            stack_used: platform.stack_used(),
            ..self.status
        }
    }

    /// The response to one request.
    pub fn handle(&mut self, request: &Request, platform: &mut impl Platform) -> Response {
        match request {
            Request::CalibrationChunk {
                total,
                offset,
                bytes,
            } => self.chunk(usize::from(*total), usize::from(*offset), bytes),
            Request::Command(command) => Response::Corrected(self.command(command, platform)),
            Request::Status | Request::Halt => Response::Status(self.status(platform)),
            Request::Hello { nonce } => Response::Hello {
                nonce: *nonce,
                status: self.status(platform),
            },
            Request::Ranges => Response::Ranges(self.range_report),
        }
    }

    /// The ticks outside the identified ranges since the calibration in force
    /// was loaded.
    pub fn range_report(&self) -> RangeReport {
        self.range_report
    }

    /// The response to a frame that [`decode`] or [`FrameBuffer::push`] refused.
    pub fn frame_error(&mut self, reason: FrameError) -> Response {
        self.status.frame_errors = self.status.frame_errors.wrapping_add(1);
        Response::FrameRejected { reason }
    }

    /// Records the duration of the last command, cycles, against the tick period.
    pub fn tick_done(&mut self, cycles: u32) {
        let s = &mut self.status;
        s.worst_tick_cycles = s.worst_tick_cycles.max(cycles);
        if cycles > s.tick_period_cycles {
            s.deadline_misses = s.deadline_misses.wrapping_add(1);
        }
    }

    fn reject(&mut self, reason: Rejection) -> Response {
        self.file.clear();
        self.file_total = 0;
        self.status.last_rejection = Some(reason);
        Response::CalibrationRejected { reason }
    }

    fn chunk(&mut self, total: usize, offset: usize, bytes: &[u8]) -> Response {
        if offset == 0 {
            self.file.clear();
            self.file_total = total;
        } else if offset != self.file.len() || total != self.file_total || total == 0 {
            return self.reject(Rejection::ChunkOutOfOrder);
        }
        if total > MAX_FILE_LEN || self.file.len() + bytes.len() > total {
            return self.reject(Rejection::TooLong);
        }
        // Fits: total ≤ MAX_FILE_LEN, the capacity.
        let _ = self.file.extend_from_slice(bytes);
        if self.file.len() < total {
            return Response::ChunkReceived {
                received: self.file.len() as u16,
            };
        }
        let loaded = Calibration::decode(&self.file)
            .map_err(|e| Rejection::from(&e))
            .and_then(|cal| check_magnitudes(&cal).map(|()| cal));
        match loaded {
            Err(reason) => self.reject(reason),
            Ok(cal) => {
                let compensator = Compensator::<f32>::from_calibration(&cal, Limits::default());
                let joints = compensator.dof() as u8;
                let model_hash = model_hash(&cal.nominal);
                self.compensator = Some(compensator);
                self.ranges = cal.ranges.as_ref().map(Ranges::cast);
                self.range_report = RangeReport {
                    known: self.ranges.is_some(),
                    ..RangeReport::default()
                };
                self.stream.reset();
                self.last_seq = None;
                self.file.clear();
                self.file_total = 0;
                self.status.joints = joints;
                self.status.model_hash = model_hash;
                self.status.loads = self.status.loads.wrapping_add(1);
                Response::CalibrationAccepted {
                    joints,
                    orientation: cal.orientation,
                    model_hash,
                }
            }
        }
    }

    fn command(&mut self, command: &Command, platform: &mut impl Platform) -> Corrected {
        let s = &mut self.status;
        s.ticks = s.ticks.wrapping_add(1);
        if self
            .last_seq
            .is_some_and(|last| command.seq != last.wrapping_add(1))
        {
            s.sequence_gaps = s.sequence_gaps.wrapping_add(1);
        }
        self.last_seq = Some(command.seq);
        let Some(compensator) = &self.compensator else {
            s.uncalibrated = s.uncalibrated.wrapping_add(1);
            return Corrected {
                seq: command.seq,
                status: TickStatus::Uncalibrated,
                q: command.q.clone(),
                iterations: 0,
                residual: 0.0,
            };
        };
        platform.before_correct();
        let context = command.context.unwrap_or_default();
        let conditions = Conditions {
            temperature: context.temperature,
            payload: context.payload,
        };
        let c = self.stream.tick(compensator, &command.q, &conditions);
        platform.after_correct();
        // Outside the benchmarked correction: a few comparisons per joint.
        if let Some(ranges) = &self.ranges {
            let outside = ranges.outside(&command.q, context.temperature, context.payload);
            if outside.any() {
                let r = &mut self.range_report;
                r.ticks_outside = r.ticks_outside.wrapping_add(1);
                r.outside = r.outside.union(outside);
            }
        }
        let status = TickStatus::from(c.fault);
        if !matches!(status, TickStatus::Corrected) {
            s.faults = s.faults.wrapping_add(1);
        }
        Corrected {
            seq: command.seq,
            status,
            q: c.q,
            iterations: c.iterations.min(usize::from(u8::MAX)) as u8,
            residual: c.residual,
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::compensation::Compensator;
    use crate::effects::one_of_each;
    use crate::units::Units;
    use crate::{Convention, JointType, Link, Param, ParamError, Robot};
    use std::vec;
    use std::vec::Vec as StdVec;

    /// A six-axis arm like a UR10e (standard D-H), with a few identified errors.
    fn calibration() -> Calibration {
        let pi2 = core::f64::consts::FRAC_PI_2;
        let rows = [
            (0.1807, 0.0, pi2),
            (0.0, -0.6127, 0.0),
            (0.0, -0.57155, 0.0),
            (0.17415, 0.0, pi2),
            (0.11985, 0.0, -pi2),
            (0.11655, 0.0, 0.0),
        ];
        let links: StdVec<Link<f64>> = rows
            .iter()
            .map(|&(s, a, alpha)| Link::new(JointType::Revolute, 0.0, s, a, alpha))
            .collect();
        let robot = Robot::new(Convention::Dh, &links).unwrap();
        let mut cal = Calibration::nominal(robot, true, Units::default());
        for (param, error) in [
            (Param::Theta(1), 1e-3),
            (Param::A(2), -2e-3),
            (Param::Alpha(3), 5e-4),
            (Param::S(4), 1e-3),
        ] {
            cal.errors.push(ParamError { param, error }).unwrap();
        }
        cal
    }

    fn bytes(cal: &Calibration) -> StdVec<u8> {
        let mut buf = [0u8; MAX_FILE_LEN];
        cal.encode(&mut buf).unwrap().to_vec()
    }

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

    fn command(seq: u32, q: &[f32]) -> Command {
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

    /// A calibration identified on joints within 0.2 rad of `Q` and at 20–30 °C
    /// counts the ticks beyond those ranges, naming which, and corrects them
    /// all the same; a new calibration starts the count again, and one
    /// without recorded ranges (format version 3) judges nothing.
    #[test]
    fn counts_ticks_outside_the_identified_ranges() {
        let mut cal = calibration();
        let lo: StdVec<f64> = Q.iter().map(|&q| f64::from(q) - 0.2).collect();
        let hi: StdVec<f64> = Q.iter().map(|&q| f64::from(q) + 0.2).collect();
        cal.ranges = Some(Ranges::of([
            (&lo[..], Some(20.0), None),
            (&hi[..], Some(30.0), None),
        ]));
        let mut device = Device::new(1000);
        assert!(!device.range_report().known);
        load(&mut device, &bytes(&cal), CHUNK_LEN);
        let report = |device: &mut Device| match device.handle(&Request::Ranges, &mut ()) {
            Response::Ranges(r) => r,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            report(&mut device),
            RangeReport {
                known: true,
                ..RangeReport::default()
            }
        );
        // Inside (21.5 °C, `command`'s context), then joint 3 at 0.5 rad beyond
        // its range, then at 140 °C.
        let mut beyond = Q;
        beyond[2] += 0.7;
        let mut seq = 0;
        for q in [Q, beyond, Q] {
            let c = tick(&mut device, seq, &q);
            assert_ne!(c.status, TickStatus::Uncalibrated);
            assert!(c.q.iter().zip(&q).any(|(a, b)| a != b), "it corrects");
            seq += 1;
        }
        let mut hot = command(seq, &Q);
        hot.context = Some(Context {
            temperature: Some(140.0),
            payload: Some(4000.0),
        });
        assert!(matches!(
            device.handle(&Request::Command(hot), &mut ()),
            Response::Corrected(_)
        ));
        let r = report(&mut device);
        assert_eq!(r.ticks_outside, 2, "{r:?}");
        assert_eq!(
            r.outside,
            Outside {
                joints: 1 << 2,
                temperature: true,
                // The session had no payload: a tick's payload is not judged.
                load: false
            }
        );
        // A calibration without ranges: nothing judged, the count starts again.
        cal.ranges = None;
        load(&mut device, &bytes(&cal), CHUNK_LEN);
        tick(&mut device, 0, &beyond);
        assert_eq!(report(&mut device), RangeReport::default());
    }

    /// Malformed frames are refused with their reason, never decoded as something else.
    #[test]
    fn malformed_frames_are_refused() {
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode(&Request::Command(command(3, &[0.1; 6])), &mut buf).unwrap();
        let body = frame[..frame.len() - 1].to_vec();
        // Truncated: the message ends early.
        let mut cut = body[..body.len() - 3].to_vec();
        assert!(decode::<Request>(&mut cut).is_err());
        // A COBS code byte pointing past the end.
        let mut bad = vec![0x09, 1, 2];
        assert_eq!(decode::<Request>(&mut bad), Err(FrameError::Cobs));
        // An unknown message tag.
        let mut unknown = vec![0x02, 0x63];
        assert_eq!(decode::<Request>(&mut unknown), Err(FrameError::Message));
        // A whole message with a byte after it.
        let mut plain = [0u8; 64];
        let n = postcard::to_slice(&Request::Status, &mut plain)
            .unwrap()
            .len();
        let mut extra = [0u8; 66];
        let extended = [&plain[..n], &[7u8]].concat();
        let m = cobs::encode(&extended, &mut extra);
        assert_eq!(decode::<Request>(&mut extra[..m]), Err(FrameError::Message));
        // A joint vector longer than MAX_JOINTS (postcard: tag, seq, length,
        // the values, no context), beside the same with MAX_JOINTS values.
        let command_of = |n: usize| {
            let mut raw = vec![1u8, 0, n as u8];
            raw.extend(vec![0u8; 4 * n]);
            raw.push(0);
            let mut enc = [0u8; MAX_FRAME];
            let m = cobs::encode(&raw, &mut enc);
            decode::<Request>(&mut enc[..m])
        };
        assert!(command_of(MAX_JOINTS).is_ok());
        assert_eq!(command_of(MAX_JOINTS + 1), Err(FrameError::Message));
        // A frame that overflows the receiver: refused at its delimiter, and the
        // next frame is read normally.
        let mut rx = FrameBuffer::new();
        for _ in 0..MAX_FRAME + 10 {
            assert!(rx.push(0x55).is_none());
        }
        assert_eq!(
            rx.push(0).map(|r| r.map(|_| ())),
            Some(Err(FrameError::TooLong))
        );
        assert!(rx.push(0).is_none(), "an empty frame is ignored");
        let mut got = None;
        for &b in frame.iter() {
            if let Some(f) = rx.push(b) {
                got = Some(decode::<Request>(f.unwrap()));
            }
        }
        assert_eq!(got, Some(Ok(Request::Command(command(3, &[0.1; 6])))));
        // The device answers each with FrameRejected and counts it.
        let mut device = Device::new(1000);
        assert_eq!(
            device.frame_error(FrameError::Cobs),
            Response::FrameRejected {
                reason: FrameError::Cobs
            }
        );
        assert_eq!(device.status(&()).frame_errors, 1);
    }

    /// Sends `file` in chunks of `chunk` bytes; returns the last response.
    fn load(device: &mut Device, file: &[u8], chunk: usize) -> Response {
        let mut last = None;
        for (i, part) in file.chunks(chunk).enumerate() {
            let r = device.handle(
                &Request::CalibrationChunk {
                    total: file.len() as u16,
                    offset: (i * chunk) as u16,
                    bytes: part.iter().copied().collect(),
                },
                &mut (),
            );
            if i + 1 < file.len().div_ceil(chunk) {
                assert_eq!(
                    r,
                    Response::ChunkReceived {
                        received: ((i + 1) * chunk) as u16
                    }
                );
            }
            last = Some(r);
        }
        last.unwrap()
    }

    fn tick(device: &mut Device, seq: u32, q: &[f32]) -> Corrected {
        match device.handle(&Request::Command(command(seq, q)), &mut ()) {
            Response::Corrected(c) => c,
            other => panic!("{other:?}"),
        }
    }

    const Q: [f32; 6] = [0.3, -1.1, 1.4, -0.6, 1.2, 0.4];

    /// Without a calibration commands pass through; a calibration sent in chunks
    /// is accepted and then corrects exactly as `Compensator<f32>` does, tick
    /// after tick with the previous correction.
    #[test]
    fn loads_in_chunks_and_corrects_like_the_compensator() {
        let cal = calibration();
        let file = bytes(&cal);
        let mut device = Device::new(1000);
        let c = tick(&mut device, 0, &Q);
        assert_eq!(
            (c.status, c.q.as_slice()),
            (TickStatus::Uncalibrated, &Q[..])
        );
        assert_eq!(
            load(&mut device, &file, 50),
            Response::CalibrationAccepted {
                joints: 6,
                orientation: true,
                model_hash: model_hash(&cal.nominal)
            }
        );
        let compensator = Compensator::<f32>::from_calibration(&cal, Limits::default());
        // The context of `command`.
        let conditions = Conditions {
            temperature: Some(21.5),
            payload: None,
        };
        let mut stream = Stream::new(Pacing::Servo);
        for seq in 1..20u32 {
            let q: StdVec<f32> = Q.iter().map(|q| q + 0.01 * seq as f32).collect();
            let got = tick(&mut device, seq, &q);
            let want = stream.tick(&compensator, &q, &conditions);
            assert_eq!(got.q, want.q);
            assert_eq!(got.status, TickStatus::from(want.fault));
            assert_eq!(got.status, TickStatus::Corrected);
            assert!(got.q.iter().zip(&q).any(|(a, b)| a != b), "it corrects");
        }
        let s = device.status(&());
        assert_eq!(
            (s.ticks, s.uncalibrated, s.faults, s.sequence_gaps, s.loads),
            (20, 1, 0, 0, 1)
        );
        tick(&mut device, 40, &Q);
        assert_eq!(device.status(&()).sequence_gaps, 1);
        let c = tick(&mut device, 41, &Q[..5]);
        assert_eq!(
            (c.status, c.q.as_slice()),
            (TickStatus::JointCount, &Q[..5])
        );
        let c = tick(&mut device, 42, &[f32::NAN; 6]);
        assert_eq!(c.status, TickStatus::NonFinite);
        assert_eq!(device.status(&()).faults, 2);
    }

    /// A damaged, truncated, foreign, oversized or out-of-order calibration is
    /// refused with its reason, and the calibration in force stays in force.
    #[test]
    fn refuses_bad_calibrations_and_keeps_the_last_good_one() {
        let good = bytes(&calibration());
        let mut device = Device::new(1000);
        assert!(matches!(
            load(&mut device, &good, CHUNK_LEN),
            Response::CalibrationAccepted { .. }
        ));
        let before = tick(&mut device, 0, &Q);
        let mut damaged = good.clone();
        damaged[40] ^= 0x10;
        let mut foreign = good.clone();
        foreign[1] = b'X';
        let mut huge = calibration();
        huge.errors[1].error = 0.6;
        let cases: [(StdVec<u8>, Rejection); 4] = [
            (damaged, Rejection::Crc),
            (good[..good.len() - 1].to_vec(), Rejection::Truncated),
            (foreign, Rejection::BadMagic),
            (bytes(&huge), Rejection::ErrorTooLarge),
        ];
        for (file, reason) in cases {
            assert_eq!(
                load(&mut device, &file, CHUNK_LEN),
                Response::CalibrationRejected { reason }
            );
            assert_eq!(device.status(&()).last_rejection, Some(reason));
            assert!(device.is_calibrated());
        }
        // Chunks out of order, and more bytes than announced.
        let part = |offset: u16, total: u16, n: usize| Request::CalibrationChunk {
            total,
            offset,
            bytes: good[..n].iter().copied().collect(),
        };
        device.handle(&part(0, good.len() as u16, 100), &mut ());
        assert_eq!(
            device.handle(&part(120, good.len() as u16, 10), &mut ()),
            Response::CalibrationRejected {
                reason: Rejection::ChunkOutOfOrder
            }
        );
        assert_eq!(
            device.handle(&part(0, 50, 100), &mut ()),
            Response::CalibrationRejected {
                reason: Rejection::TooLong
            }
        );
        assert_eq!(
            device.handle(&part(0, MAX_FILE_LEN as u16 + 1, 100), &mut ()),
            Response::CalibrationRejected {
                reason: Rejection::TooLong
            }
        );
        // Still the same calibration, continuing its ticks.
        let after = tick(&mut device, 1, &Q);
        assert_eq!(after.status, TickStatus::Corrected);
        assert!((after.q[0] - before.q[0]).abs() < 1e-5);
        assert_eq!(device.status(&()).loads, 1);
    }

    /// Ticks longer than the period are counted as deadline misses.
    #[test]
    fn counts_deadline_misses() {
        let mut device = Device::new(1000);
        for cycles in [10, 999, 1000, 1001, 5000] {
            device.tick_done(cycles);
        }
        let s = device.status(&());
        assert_eq!((s.deadline_misses, s.worst_tick_cycles), (2, 5000));
    }

    /// A calibration with every kind of effect is accepted, and its commands are
    /// corrected in the tick's context exactly as `Compensator<f32>` does.
    #[test]
    fn accepts_effects_and_corrects_in_context() {
        let mut cal = calibration();
        for e in one_of_each() {
            cal.effects.push(e).unwrap();
        }
        let mut device = Device::new(1000);
        assert!(matches!(
            load(&mut device, &bytes(&cal), CHUNK_LEN),
            Response::CalibrationAccepted { .. }
        ));
        let c = tick(&mut device, 0, &Q);
        let want = Compensator::<f32>::from_calibration(&cal, Limits::default()).correct(
            &Q,
            &Conditions {
                temperature: Some(21.5),
                payload: None,
            },
        );
        assert_eq!((c.status, c.q), (TickStatus::Corrected, want.q));
    }

    /// Effect parameters at their bounds (or not finite) are refused, below them accepted.
    #[test]
    fn effect_magnitude_bounds() {
        let mut cal = calibration();
        for e in one_of_each() {
            cal.effects.push(e).unwrap();
        }
        assert_eq!(check_magnitudes(&cal), Ok(()));
        let bounds = [
            MAX_COMPLIANCE,
            MAX_EFFECT_ANGLE,
            MAX_EFFECT_ANGLE,
            MAX_EXPANSION,
            MAX_SCALE_ERROR,
        ];
        for (i, max) in bounds.into_iter().enumerate() {
            for (value, ok) in [(0.99 * max, true), (-max, false), (f64::NAN, false)] {
                let mut bad = cal.clone();
                *bad.effects[i].parameter_mut(0).unwrap() = value;
                let want = if ok {
                    Ok(())
                } else {
                    Err(Rejection::EffectTooLarge)
                };
                assert_eq!(check_magnitudes(&bad), want, "{:?}", bad.effects[i]);
            }
        }
        let mut bad = cal.clone();
        bad.effects[3] = Effect::ThermalExpansion {
            coefficient: 2.3e-5,
            reference: MAX_REFERENCE_TEMPERATURE,
        };
        assert_eq!(check_magnitudes(&bad), Err(Rejection::EffectTooLarge));
    }

    /// Identified errors at the bounds are refused, just below them accepted.
    #[test]
    fn magnitude_bounds() {
        let mut cal = calibration();
        cal.errors[0].error = 0.499;
        cal.errors[1].error = -0.499;
        assert_eq!(check_magnitudes(&cal), Ok(()));
        cal.errors[0].error = -0.5;
        assert_eq!(check_magnitudes(&cal), Err(Rejection::ErrorTooLarge));
        cal.errors[0].error = f64::NAN;
        assert_eq!(check_magnitudes(&cal), Err(Rejection::ErrorTooLarge));
    }
}
