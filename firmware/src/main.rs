//! # armcal-firmware: the motion controller's calibration-compensation firmware
//!
//! The controller runs the robot's servo loop; this firmware is the part of it
//! that applies armcal's calibration: it loads the calibration file the
//! calibrator wrote, and on every servo tick corrects the commanded joint values
//! so that the real arm reaches the pose the nominal model was asked for. The
//! kinematics and the protocol are `armcal-shared` ([`armcal_shared::link`],
//! [`armcal_shared::compensation`]) in `f32`: the same code the host tests run.
//! (The kinematics themselves are checked on the host, against finite
//! differences and an independent derivation; the chip runs the same code.)
//!
//! ## Two builds
//!
//! - Production, `cargo build --release`: at boot it serves the link at once.
//! - Benchmark, `cargo build --release --features bench`: the same firmware
//!   that first runs the boot benchmark (`bench.rs`: 200 corrections of a UR10e
//!   with every effect), then serves the link. `budgets.sh` counts its
//!   instructions per tick under QEMU, and checks its static RAM and stack.
//!
//! The benchmark is a cargo feature, not a second binary, because it needs
//! the rest of this file (the markers' [`Board`], [`handle`], the exit and fault
//! handlers): a second binary would need the firmware split into a library.
//! Its ticks are commands to the link's controller (started afresh before the
//! link is served), through [`handle`], the link's code, which is not inlined,
//! and the controller reaches the benchmark and [`serve`] through `black_box`:
//! so both builds compile the correction alike and the benchmark counts the
//! production tick (`qemu-link-test.sh` counts the same instructions per
//! correction on either build). Both builds write
//! `target/thumbv7em-none-eabihf/release/armcal-firmware`; `budgets.sh` and CI
//! keep the benchmark build as `armcal-firmware-bench`.
//!
//! ## The link
//!
//! The firmware serves the serial link on USART1 ([`serial`]): postcard frames
//! with COBS, one response per request (the message table is in
//! [`armcal_shared::link`]). A calibration arrives in chunks and is validated
//! whole before it replaces the one in force; it is converted to `f32` once.
//! Each command is corrected in its context (temperature, payload), with the
//! previous tick's correction as the change bound and its commands for the
//! approach directions, and the compensation's workspace (the predicted step,
//! the last factors); its duration, from the frame's last byte to the encoded
//! response, is measured with SysTick ([`clock`]) against
//! [`TICK_PERIOD_CYCLES`] and a longer one counted as a deadline miss. Nothing
//! allocates (there is no allocator) and the work per command is bounded by the
//! compensation's iteration limit. On [`Request::Halt`] it sends its final
//! status (with the stack high-water mark, [`stack`]), logs it and exits
//! through semihosting.
//!
//! Every correction is bracketed by the marker functions [`bench_start`] and
//! [`bench_end`] (called by [`Board`]), between which
//! `firmware/qemu-insn-count.c` counts the instructions under QEMU. Errors, a
//! panic or a hard fault exit with failure.
//!
//! Run it under QEMU with `./qemu-run.sh` (boot, halt), `./qemu-link-test.sh`
//! (the link against `armcal stream`) or `./budgets.sh` (both builds: flash,
//! static RAM, instructions per tick against their budgets).
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use armcal_shared::link::{self, Device, FrameBuffer, MAX_FRAME, Platform, Request, Response};
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
// Links the defmt global logger (frames go to the host over semihosting).
use defmt_semihosting as _;

#[cfg(feature = "bench")]
mod bench;
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
    // lives in static RAM, not on the stack. The device is written at run time
    // ([`init`]), so that its 11.5 KB sit in .bss (zeroed at reset) instead of
    // .data, whose initial image would take as much flash.
    static mut DEVICE: MaybeUninit<Device> = MaybeUninit::uninit();
    static mut FRAMES: FrameBuffer = FrameBuffer::new();
    defmt::info!("armcal-firmware {=str} booted", env!("CARGO_PKG_VERSION"));
    // The benchmark runs on the link's controller, which is then started
    // afresh: a second controller would take another 11.5 KB of RAM.
    #[cfg(feature = "bench")]
    bench::run(core::hint::black_box(init(DEVICE)));
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
    // The device's address hidden from the optimiser: when it is known (the
    // production build has no other device), LTO propagates it into the
    // correction, which then builds every field's address from the constant:
    // about 1,200 more instructions per correction of qemu-link-test.sh.
    let device = core::hint::black_box(init(DEVICE));
    serve(device, FRAMES, &clock, &mut serial)
}

/// A new controller, with no calibration, written into `slot` (over the one
/// there, if any). Not inlined, so that the controller is built in its slot:
/// `slot` is a `&mut`, which `Device::new` cannot reach otherwise, so the
/// optimiser has `Device::new` write its result there. Built in `main`, whose
/// slot is the static itself, it was built on the stack and copied: 11.5 KB of
/// `main`'s frame, at the bottom of the stack for as long as the firmware runs.
#[inline(never)]
fn init(slot: &mut MaybeUninit<Device>) -> &mut Device {
    slot.write(Device::new(TICK_PERIOD_CYCLES))
}

/// The response to one request, the link's and the boot benchmark's. Not
/// inlined, so that the correction is compiled the same way in both builds:
/// inlined, it would be compiled into [`serve`] in the production build, where
/// it has one caller, and kept apart in the benchmark build, where it has two.
#[inline(never)]
fn handle(device: &mut Device, request: &Request, board: &mut Board) -> Response {
    device.handle(request, board)
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
            Ok(request) => handle(device, request, &mut board),
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
                let ranges = device.range_report();
                defmt::info!(
                    "halt: {=u32} ticks outside the identified ranges (joints {=u16:#b}, temperature {=bool}, payload {=bool})",
                    ranges.ticks_outside,
                    ranges.outside.joints,
                    ranges.outside.temperature,
                    ranges.outside.load
                );
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
