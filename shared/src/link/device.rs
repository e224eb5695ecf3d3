//! The controller's side of the link: [`Device`], the protocol state machine
//! the firmware runs (and the host's tests, the same code), and
//! [`check_magnitudes`], its use of the calibration's magnitude policy.
//!
//! It assembles a calibration from its chunks, validates it (decoded, then its
//! magnitudes), converts it to `f32` once, corrects each command as one servo
//! [`Stream`] and counts ticks, faults, sequence gaps, deadline misses and the
//! ticks outside the identified ranges. It never allocates; a command's cost is
//! bounded by [`Limits::max_iterations`].
//!
//! Wire convention: one [`Response`] per [`Request`] ([`Device::handle`]), and
//! one for a refused frame ([`Device::frame_error`]). Units: joint values rad or
//! m in `f32`; durations core clock cycles; stack bytes.

use heapless::Vec;

use super::frame::FrameError;
use super::wire::{
    Command, Corrected, RangeReport, Rejection, Request, Response, StatusReport, TickStatus,
};
use crate::Calibration;
use crate::calibration::{MAX_FILE_LEN, model_hash};
use crate::compensation::{Compensator, Conditions, Limits, Pacing, Stream};
use crate::ranges::{Outside, Ranges};

/// Refuses a calibration whose magnitudes are beyond the calibration's policy
/// ([`Calibration::check_magnitudes`]), with the reason it is sent as.
pub fn check_magnitudes(calibration: &Calibration) -> Result<(), Rejection> {
    calibration.check_magnitudes().map_err(Rejection::from)
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

/// The controller's side of the protocol: see [the link module](super).
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

    /// The response to a frame that [`decode`](super::decode) or
    /// [`FrameBuffer::push`](super::FrameBuffer::push) refused.
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
                    orientation: cal.task == crate::compensation::Task::Pose,
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

    use std::vec::Vec as StdVec;

    use super::*;
    use crate::calibration::MAX_REFERENCE_TEMPERATURE;
    use crate::calibration::fixtures::calibration;
    use crate::effects::{Effect, one_of_each};
    use crate::link::wire::tests::command;
    use crate::link::{CHUNK_LEN, Context};

    fn bytes(cal: &Calibration) -> StdVec<u8> {
        let mut buf = [0u8; MAX_FILE_LEN];
        cal.encode(&mut buf).unwrap().to_vec()
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

    /// The link sends the magnitude policy's refusals as their rejections.
    #[test]
    fn magnitudes_are_refused_as_rejections() {
        let mut cal = calibration();
        cal.errors[0].error = 0.5;
        assert_eq!(check_magnitudes(&cal), Err(Rejection::ErrorTooLarge));
        let mut cal = calibration();
        let hot = Effect::ThermalExpansion {
            coefficient: 2.3e-5,
            reference: MAX_REFERENCE_TEMPERATURE,
        };
        cal.effects.push(hot).unwrap();
        assert_eq!(check_magnitudes(&cal), Err(Rejection::EffectTooLarge));
        assert_eq!(check_magnitudes(&calibration()), Ok(()));
    }

    /// The device answers a refused frame with FrameRejected and counts it.
    #[test]
    fn counts_refused_frames() {
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
}
