//! The serial link between the calibrator (`armcal stream`) and the controller:
//! the wire messages, their framing, and the controller's side of the protocol
//! ([`Device`]), defined once for both ends.
//!
//! Three parts, each its own file, every item re-exported here
//! (`armcal_shared::link::X` is the one path to each):
//!
//! - `wire`: the messages ([`Request`], [`Response`] and what they carry),
//!   their units and how they may grow;
//! - `frame`: their framing on the byte stream ([`encode`], [`decode`],
//!   [`FrameBuffer`]): postcard, COBS, a `0x00` delimiter;
//! - `device`: the controller's protocol state machine ([`Device`]), which
//!   validates a calibration with the calibration's magnitude policy
//!   ([`check_magnitudes`], [`Calibration::check_magnitudes`](crate::Calibration::check_magnitudes))
//!   and corrects the commands.
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
//! # Units
//!
//! Joint values are SI in `f32`: rad for revolute joints, m for prismatic ones,
//! in the order of the model's joints. The optional [`Context`] carries the
//! temperature (°C) and the payload mass (kg) of the tick, which the
//! non-geometric effects of a calibration from `armcal diagnose` depend on
//! ([`Conditions`](crate::compensation::Conditions); none given: the
//! reference temperature and no payload); the approach direction of each joint
//! comes from the commands sent (see [`crate::compensation`]). Durations are in
//! core clock cycles.
//!
//! # The controller's side
//!
//! [`Device`] is the protocol state machine the firmware runs, and the host's
//! tests run the same code: it assembles and validates the calibration
//! ([`Calibration::decode`](crate::Calibration::decode), then
//! [`check_magnitudes`]), converts it to `f32` once
//! ([`Compensator::<f32>::from_calibration`](crate::compensation::Compensator::from_calibration)),
//! corrects the commands as one servo [`Stream`](crate::compensation::Stream)
//! (the per-tick change bound, the approach directions, the warm start), and
//! counts ticks, faults, sequence gaps and deadline misses. After each
//! correction it compares the tick's commands and context with the ranges the
//! calibration was identified on ([`crate::ranges`]) and counts the ticks
//! outside them ([`RangeReport`]); it corrects them all the same. With no
//! calibration in force a command passes through unchanged with
//! [`TickStatus::Uncalibrated`]. Its per-command cost is bounded by
//! [`Limits::max_iterations`](crate::compensation::Limits::max_iterations) and
//! it never allocates.
//!
//! # Compatibility
//!
//! Messages are postcard, which is not self-describing: a message's fields
//! cannot change without both ends changing. New requests and responses are
//! added as new enum variants at the end, which both ends' older builds
//! decode as before: a controller that does not know a request answers
//! [`Response::FrameRejected`] ([`FrameError::Message`]), and the host reads
//! that as "not reported by this controller".

mod device;
mod frame;
mod wire;

pub use crate::calibration::{
    MAX_COMPLIANCE, MAX_EFFECT_ANGLE, MAX_ERROR_ANGLE, MAX_ERROR_LENGTH, MAX_EXPANSION,
    MAX_REFERENCE_TEMPERATURE, MAX_SCALE_ERROR,
};
pub use device::{Device, Platform, check_magnitudes};
pub use frame::{EncodeError, FrameBuffer, FrameError, HALT_FRAME, MAX_FRAME, decode, encode};
pub use wire::{
    CHUNK_LEN, Command, Context, Corrected, RangeReport, Rejection, Request, Response,
    StatusReport, TickStatus,
};
