//! # armcal-firmware: the motion controller's calibration-compensation firmware
//!
//! The controller runs the robot's servo loop; this firmware is the part of it
//! that applies armcal's calibration: it loads the calibration file the
//! calibrator wrote, and on every servo tick corrects the commanded joint values
//! so that the real arm reaches the pose the nominal model was asked for. The
//! kinematics and the protocol are `armcal-shared` ([`armcal_shared::link`],
//! [`armcal_shared::compensation`]) in `f32`: the same code the host tests run.
//!
//! At boot it
//! 1. (the kinematics themselves are checked on the host, against finite
//!    differences and an independent derivation; the chip runs the same code)
//! 2. runs the boot benchmark ([`bench()`]): 200 consecutive corrections of a
//!    UR10e with realistic joint errors and every kind of non-geometric effect,
//!    at 35 °C with a 5 kg payload, each between the markers below: the first
//!    a cold tick, the others warm-started from the previous tick (a smooth
//!    motion, as in service; long enough for the reused factors to age and be
//!    replaced);
//! 3. serves the serial link on USART1 ([`serial`]): postcard frames with COBS,
//!    one response per request (the message table is in [`armcal_shared::link`]).
//!    A calibration arrives in chunks and is validated whole before it replaces
//!    the one in force; it is converted to `f32` once. Each command is corrected
//!    in its context (temperature, payload), with the previous tick's correction
//!    as the change bound and its commands for the approach directions, and the
//!    compensation's workspace (the predicted step, the last factors); its duration, from
//!    the frame's last byte to the encoded response, is measured with SysTick
//!    ([`clock`]) against [`TICK_PERIOD_CYCLES`] and a longer one counted as a
//!    deadline miss. Nothing allocates (there is no allocator) and the work per
//!    command is bounded by the compensation's iteration limit.
//! 4. On [`Request::Halt`] it sends its final status (with the stack high-water
//!    mark, [`stack`]), logs it and exits through semihosting.
//!
//! The correction is bracketed by the marker functions [`bench_start`] and
//! [`bench_end`], between which `firmware/qemu-insn-count.c` counts the
//! instructions under QEMU. Errors, a panic or a hard fault exit with failure.
//!
//! Run it under QEMU with `./qemu-run.sh` (boot, self-check, halt) or
//! `./qemu-link-test.sh` (the link against `armcal stream`).
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use armcal_shared::compensation::{Compensator, Conditions, Limits, Previous, Workspace};
use armcal_shared::effects::one_of_each;
use armcal_shared::link::{self, Device, FrameBuffer, MAX_FRAME, Platform, Request, Response};
use armcal_shared::units::Units;
use armcal_shared::{
    Calibration, Convention, JointType, Link, ModelError, Param, ParamError, Robot,
};
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
// Links the defmt global logger (frames go to the host over semihosting).
use defmt_semihosting as _;

mod clock;
mod serial;
mod stack;

/// The servo tick period, core cycles: 1 ms at the STM32F405's 168 MHz. A
/// command that takes longer is a deadline miss.
pub const TICK_PERIOD_CYCLES: u32 = 168_000;

/// Marks the start of one correction for the instruction counter. `black_box`
/// gives it an effect the optimiser must keep (a call to an empty function is
/// deleted), and a value of its own so that it is not merged with [`bench_end`].
#[inline(never)]
pub fn bench_start() {
    core::hint::black_box(1u32);
}

/// Marks the end of one correction for the instruction counter.
#[inline(never)]
pub fn bench_end() {
    core::hint::black_box(2u32);
}

/// The boot benchmark's robot: the UR10e's nominal D-H model (the maker's
/// table, m and rad) with the joint errors armcal identifies from the FIGAROH
/// UR10e data set (`armcal identify --model figaroh-ur10e-camera --data
/// figaroh-ur10e-camera`), without its base and tool errors: a robot whose base
/// and tool are registered, whose corrections stay within their bounds; with one
/// effect of each kind ([`one_of_each`]), so that the benchmark is a correction
/// with every effect active.
fn bench_calibration() -> Result<Calibration, ModelError> {
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
    let mut cal = Calibration::nominal(robot, true, Units::default());
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
    Ok(cal)
}

/// Ticks of the boot benchmark (`qemu-link-test.sh` counts as many spans).
const BENCH_TICKS: u32 = 200;

/// The boot benchmark: [`BENCH_TICKS`] consecutive 1 kHz ticks of a smooth
/// motion (about 1 mrad per tick per joint) of the UR10e of
/// [`bench_calibration`] at 35 °C with 5 kg, each correction between
/// [`bench_start`] and [`bench_end`], with the previous tick as sent.
/// These are the first spans `qemu-insn-count.c` counts. Returns the worst
/// residual, m, and the most iterations. Not inlined: its 13 KB of locals (a
/// calibration and a compensator) are freed before the link is served.
#[inline(never)]
fn bench() -> Result<(f32, usize), ModelError> {
    let cal = bench_calibration()?;
    let compensator = Compensator::<f32>::from_calibration(&cal, Limits::default());
    let q0 = [1.589f32, 0.578, -1.675, 0.351, 1.784, 2.232];
    let conditions = Conditions {
        temperature: Some(35.0),
        payload: Some(5.0),
    };
    let mut previous: Option<([f32; 6], [f32; 6], [f32; 6])> = None;
    let mut work = Workspace::new();
    let (mut worst, mut iterations) = (0.0f32, 0);
    for t in 0..BENCH_TICKS {
        let mut q = q0;
        for (m, qm) in q.iter_mut().enumerate() {
            *qm += 1e-3 * t as f32 * (1.0 + m as f32 / 6.0);
        }
        let last = previous
            .as_ref()
            .map(|(q_cmd, q, p)| Previous { q_cmd, q, p });
        bench_start();
        let c = compensator.correct_with(&q, last, &conditions, &mut work);
        bench_end();
        let (mut sent, mut p) = ([0.0f32; 6], [0.0f32; 6]);
        sent.copy_from_slice(&c.q);
        p.copy_from_slice(&c.p);
        previous = Some((q, sent, p));
        if c.fault.is_some() {
            defmt::warn!("benchmark tick {=u32}: not corrected to tolerance", t);
        }
        worst = worst.max(c.residual);
        iterations = iterations.max(c.iterations);
    }
    Ok((worst, iterations))
}

/// What the chip adds to the protocol: the markers and the stack measurement.
struct Board;

impl Platform for Board {
    fn before_correct(&mut self) {
        bench_start();
    }

    fn after_correct(&mut self) {
        bench_end();
    }

    fn stack_used(&self) -> u32 {
        stack::used()
    }
}

#[entry]
fn main() -> ! {
    // cortex-m-rt turns these into `&'static mut` without `unsafe`: the state
    // lives in static RAM, not on the stack. The device is written at run time,
    // so that its 7 KB sit in .bss (zeroed at reset) instead of .data, whose
    // initial image would take as much flash.
    static mut DEVICE: MaybeUninit<Device> = MaybeUninit::uninit();
    static mut FRAMES: FrameBuffer = FrameBuffer::new();
    defmt::info!("armcal-firmware {=str} booted", env!("CARGO_PKG_VERSION"));
    match bench() {
        Ok((residual, iterations)) => defmt::info!(
            "benchmark: {=u32} corrections of a 6-axis UR10e, worst residual {=f32} m, at most {=usize} iterations",
            BENCH_TICKS,
            residual,
            iterations
        ),
        Err(_) => {
            defmt::error!("benchmark failed: its model is not valid");
            exit(EXIT_FAILURE)
        }
    }
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        defmt::error!("core peripherals already taken");
        exit(EXIT_FAILURE)
    };
    let clock = clock::Clock::start(peripherals.SYST);
    let mut serial = serial::Serial::init();
    defmt::info!(
        "serving the link on USART1; tick period {=u32} cycles",
        TICK_PERIOD_CYCLES
    );
    let device = DEVICE.write(Device::new(TICK_PERIOD_CYCLES));
    serve(device, FRAMES, &clock, &mut serial)
}

/// The link's loop: one response per frame, until [`Request::Halt`].
fn serve(
    device: &mut Device,
    frames: &mut FrameBuffer,
    clock: &clock::Clock,
    serial: &mut serial::Serial,
) -> ! {
    let mut out = [0u8; MAX_FRAME];
    let mut board = Board;
    loop {
        let Some(frame) = frames.push(serial.read_byte()) else {
            continue;
        };
        let started = clock.now();
        let request = frame.and_then(link::decode::<Request>);
        let response = match &request {
            Ok(request) => device.handle(request, &mut board),
            Err(e) => device.frame_error(*e),
        };
        let Ok(bytes) = link::encode(&response, &mut out) else {
            // Every response fits a frame (tested on the host): unreachable.
            defmt::error!("response does not fit a frame");
            exit(EXIT_FAILURE)
        };
        if matches!(request, Ok(Request::Command(_))) {
            let cycles = clock.now().saturating_sub(started);
            device.tick_done(u32::try_from(cycles).unwrap_or(u32::MAX));
        }
        serial.write_all(bytes);
        match (&request, &response) {
            (_, Response::CalibrationAccepted { joints, .. }) => {
                defmt::info!("calibration accepted: {=u8} joints", joints);
            }
            (_, Response::CalibrationRejected { reason }) => {
                defmt::warn!("calibration refused: {=str}", reason.message());
            }
            (Ok(Request::Halt), Response::Status(s)) => {
                defmt::info!(
                    "halt: {=u32} ticks, {=u32} faults, {=u32} deadline misses (worst {=u32} cycles of {=u32}), {=u32} frame errors, stack used {=u32} bytes",
                    s.ticks,
                    s.faults,
                    s.deadline_misses,
                    s.worst_tick_cycles,
                    s.tick_period_cycles,
                    s.frame_errors,
                    s.stack_used
                );
                exit(EXIT_SUCCESS)
            }
            _ => {}
        }
    }
}

/// Ends the program: under QEMU or a debugger with semihosting, with `status` as
/// the exit code; on a bare chip, by waiting for a reset.
fn exit(status: debug::ExitStatus) -> ! {
    debug::exit(status);
    loop {
        cortex_m::asm::bkpt();
    }
}

#[exception]
#[allow(unsafe_code)] // cortex-m-rt requires the HardFault handler to be an `unsafe fn`.
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!(
        "hard fault at pc {=u32:#010x}, lr {=u32:#010x}, xpsr {=u32:#010x}",
        frame.pc(),
        frame.lr(),
        frame.xpsr()
    );
    exit(EXIT_FAILURE)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // The place only: formatting the message would link core::fmt (about 5 KB).
    match info.location() {
        Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
        None => defmt::error!("panic"),
    }
    exit(EXIT_FAILURE)
}
