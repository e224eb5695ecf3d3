//! The boot benchmark, built only with the `bench` feature
//! (`cargo build --release --features bench`; see the header of `main.rs`).
//!
//! [`BENCH_TICKS`] compensation ticks of a UR10e with realistic joint errors and
//! every kind of non-geometric effect, at 35 °C with a 5 kg payload, each
//! between the markers [`crate::bench_start`] and [`crate::bench_end`]: the
//! first a cold tick, the others warm-started from the previous tick (a smooth
//! motion, as in service; long enough for the reused factors to age and be
//! replaced). `budgets.sh` counts their instructions under QEMU and fails when
//! the median or the worst tick exceeds its budget.

use armcal_shared::calibration::MAX_FILE_LEN;
use armcal_shared::compensation::Task;
use armcal_shared::effects::one_of_each;
use armcal_shared::link::{CHUNK_LEN, Command, Context, Device, Request, Response, TickStatus};
use armcal_shared::ranges::Ranges;
use armcal_shared::units::Units;
use armcal_shared::{
    Calibration, Convention, JointType, Link, ModelError, Param, ParamError, Robot,
};
use cortex_m_semihosting::debug::EXIT_FAILURE;
use heapless::Vec;

use crate::{Board, exit, handle};

/// The boot benchmark's robot: the UR10e's nominal D-H model (the maker's
/// table, m and rad) with the joint errors armcal identifies from the FIGAROH
/// UR10e data set (`armcal identify --model figaroh-ur10e-camera --data
/// figaroh-ur10e-camera`), without its base and tool errors: a robot whose base
/// and tool are registered, whose corrections stay within their bounds; with one
/// effect of each kind ([`one_of_each`]), so that the benchmark is a correction
/// with every effect active; identified within 0.5 rad of the motion's start on
/// every joint, at 20–40 °C and 0–5 kg, so that every tick is compared with
/// the ranges (and lies inside them, as in service).
fn calibration() -> Result<Calibration, ModelError> {
    use core::f64::consts::FRAC_PI_2;
    let rows = [
        (0.1807, 0.0, FRAC_PI_2),
        (0.0, -0.6127, 0.0),
        (0.0, -0.57155, 0.0),
        (0.17415, 0.0, FRAC_PI_2),
        (0.11985, 0.0, -FRAC_PI_2),
        (0.11655, 0.0, 0.0),
    ];
    let mut links = [Link::new(JointType::Revolute, 0.0, 0.0, 0.0, 0.0); 6];
    for (link, (s, a, alpha)) in links.iter_mut().zip(rows) {
        *link = Link::new(JointType::Revolute, 0.0, s, a, alpha);
    }
    let robot = Robot::new(Convention::Dh, &links)?;
    let mut cal = Calibration::nominal(robot, Task::Pose, Units::default());
    let errors = [
        (Param::A(0), -1.79e-5),
        (Param::Alpha(0), 1.031e-3),
        (Param::Theta(1), -6.23e-4),
        (Param::S(1), 1.511e-3),
        (Param::A(1), -6.03e-3),
        (Param::Theta(2), 9.79e-4),
        (Param::A(2), -5.337e-3),
        (Param::Alpha(2), -8.031e-3),
        (Param::Theta(3), -6.43e-4),
        (Param::A(3), -1.98e-4),
        (Param::Theta(4), 1.514e-3),
        (Param::A(4), 2.55e-4),
        (Param::Alpha(4), 2.613e-3),
    ];
    for (param, error) in errors {
        // 13 of MAX_PARAMS: always room.
        let _ = cal.errors.push(ParamError { param, error });
    }
    for effect in one_of_each() {
        // 5 of MAX_EFFECTS: always room.
        let _ = cal.effects.push(effect);
    }
    let (lo, hi) = (
        Q0.map(|q| f64::from(q) - 0.5),
        Q0.map(|q| f64::from(q) + 0.5),
    );
    cal.ranges = Some(Ranges::of([
        (&lo[..], Some(20.0), Some(0.0)),
        (&hi[..], Some(40.0), Some(5.0)),
    ]));
    Ok(cal)
}

/// The joint commands of the benchmark's first tick, rad.
const Q0: [f32; 6] = [1.589, 0.578, -1.675, 0.351, 1.784, 2.232];

/// Ticks of the boot benchmark: the first spans `qemu-insn-count.c` counts,
/// which `budgets.sh` reads (it takes this number from this line).
pub const BENCH_TICKS: u32 = 200;

/// Why the benchmark could not run.
enum Failure {
    /// Its model is not valid.
    Model,
    /// Its calibration could not be written, or its controller did not accept
    /// it or did not answer a command with a correction.
    Controller,
}

/// The benchmark's calibration file ([`calibration`] as `armcal identify`
/// writes it), in `buf`. Not inlined: the calibration (5.9 KB of `f64`) is
/// off the stack before the file is loaded, where the benchmark's stack is
/// deepest (the controller decoding the file).
#[inline(never)]
fn file(buf: &mut [u8; MAX_FILE_LEN]) -> Result<&[u8], Failure> {
    let cal = calibration().map_err(|_| Failure::Model)?;
    let file = cal.encode(buf).map_err(|_| Failure::Controller)?;
    Ok(file)
}

/// The boot benchmark: [`BENCH_TICKS`] consecutive 1 kHz ticks of a smooth
/// motion (about 1 mrad per tick per joint) of the UR10e of [`calibration`] at
/// 35 °C with 5 kg. They go through the link's own code, [`crate::handle`],
/// to `device` (the firmware's controller, which `main` then starts afresh for
/// the link): its calibration as the file `armcal identify` writes, in chunks,
/// then one [`Request::Command`] per tick, so that each correction runs between
/// [`crate::bench_start`] and [`crate::bench_end`] in the code that serves the
/// link (the production build compiles it the same way), with the previous
/// tick as sent. Returns the worst residual, m, and the most iterations. Not
/// inlined: its locals (the file and the requests) are freed before the link
/// is served.
#[inline(never)]
fn ticks(device: &mut Device) -> Result<(f32, u8), Failure> {
    let mut buf = [0u8; MAX_FILE_LEN];
    let file = file(&mut buf)?;
    let mut board = Board;
    let total = u16::try_from(file.len()).map_err(|_| Failure::Controller)?;
    let (mut offset, mut accepted) = (0u16, false);
    for chunk in file.chunks(CHUNK_LEN) {
        let bytes = Vec::from_slice(chunk).map_err(|_| Failure::Controller)?;
        let request = Request::CalibrationChunk {
            total,
            offset,
            bytes,
        };
        accepted = match handle(device, &request, &mut board) {
            Response::ChunkReceived { .. } => false,
            Response::CalibrationAccepted { .. } => true,
            _ => return Err(Failure::Controller),
        };
        // At most MAX_FILE_LEN in all: within u16.
        offset += chunk.len() as u16;
    }
    if !accepted {
        return Err(Failure::Controller);
    }
    let context = Some(Context {
        temperature: Some(35.0),
        payload: Some(5.0),
    });
    let (mut worst, mut iterations) = (0.0f32, 0);
    for t in 0..BENCH_TICKS {
        let q = Q0
            .iter()
            .enumerate()
            .map(|(m, q0)| q0 + 1e-3 * t as f32 * (1.0 + m as f32 / 6.0))
            .collect();
        let request = Request::Command(Command { seq: t, q, context });
        let Response::Corrected(c) = handle(device, &request, &mut board) else {
            return Err(Failure::Controller);
        };
        if c.status != TickStatus::Corrected {
            defmt::warn!("benchmark tick {=u32}: not corrected to tolerance", t);
        }
        worst = worst.max(c.residual);
        iterations = iterations.max(c.iterations);
    }
    if device.range_report().ticks_outside != 0 {
        defmt::warn!("benchmark: ticks outside the ranges it was identified on");
    }
    Ok((worst, iterations))
}

/// Runs the benchmark on `device` and logs its result; exits with failure if
/// it could not run.
pub fn run(device: &mut Device) {
    match ticks(device) {
        Ok((residual, iterations)) => defmt::info!(
            "benchmark: {=u32} corrections of a 6-axis UR10e, worst residual {=f32} m, at most {=u8} iterations",
            BENCH_TICKS,
            residual,
            iterations
        ),
        Err(Failure::Model) => {
            defmt::error!("benchmark failed: its model is not valid");
            exit(EXIT_FAILURE)
        }
        Err(Failure::Controller) => {
            defmt::error!("benchmark failed: its controller refused its calibration or a command");
            exit(EXIT_FAILURE)
        }
    }
}
