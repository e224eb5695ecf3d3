//! # armcal-firmware: the motion controller's calibration-compensation firmware
//!
//! The controller runs the robot's servo loop; this firmware is the part of it
//! that will apply armcal's calibration: load the parameter blob the calibrator
//! wrote, and on every servo tick correct the commanded joint values so that the
//! real arm reaches the pose the nominal model was asked for. The kinematics it
//! runs is `armcal-shared`, in `f32`: the same code the host tests run in `f64`.
//!
//! Today it proves that the shared math links and runs on the chip (a Cortex-M4F,
//! STM32F405-class, see `../memory.x`). At boot it
//! 1. builds the nominal PUMA of Mirman & Gupta (1992), Table 1, standard D-H,
//!    all joints revolute, lengths converted from inches to metres;
//! 2. evaluates the forward kinematics and the manipulator Jacobian at position 1
//!    of the same table;
//! 3. checks each Jacobian column against a central difference of the forward
//!    kinematics (see [`jacobian_matches_forward`]);
//! 4. logs the measured point with `defmt` and exits through semihosting, with
//!    success, or with failure on an error, a failed check, a panic or a hard fault.
//!
//! Later issues add the calibration loading and the per-tick compensation.
//!
//! Run it under QEMU with `cargo run --release` (the runner is in
//! `.cargo/config.toml`) or `./qemu-run.sh`, which also decodes the log.
#![no_std]
#![no_main]

use core::f32::consts::{FRAC_PI_2, PI};

use armcal_shared::jacobian::at_point;
use armcal_shared::{Convention, JointType, Link, ModelError, Robot};
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
// Links the defmt global logger (frames go to the host over semihosting).
use defmt_semihosting as _;

/// Metres per inch: Mirman & Gupta give the PUMA's lengths in inches.
const INCH: f32 = 0.0254;

/// Joint readings of position 1 of Mirman & Gupta, Table 1, rad, as printed there
/// (rounded to four decimals, so 0.7854 is 45° and -0.5236 is -30°).
#[allow(clippy::approx_constant)]
const POSITION_1: [f32; 6] = [0.7854, -0.5236, -1.2618, 0.2618, -1.6981, -0.3490];

/// Central-difference step of the Jacobian check, rad.
const STEP: f32 = 1.0e-2;

/// Largest accepted difference between a Jacobian column and the central
/// difference of the measured point, m/rad.
///
/// The truncation error of a central difference is `h²/6·|p'''|`, and `|p'''|` is
/// at most the arm's reach (under 1 m): 1.7e-5 m/rad at `h = 1e-2`. Rounding adds
/// about `10 ε |p| / h`, with `ε = 1.2e-7` for `f32` and `|p| < 1 m`: 1.2e-4 m/rad.
const TOLERANCE: f32 = 5.0e-4;

/// The nominal PUMA of Mirman & Gupta (1992), Table 1: standard D-H, six
/// revolute joints, θ offsets zero.
///
/// ```text
/// m        1      2     3      4      5      6
/// s / in   26    -8     0     17      0     -2.25
/// a / in    0    17     0      0      0      0
/// α / rad  π/2    0    π/2    π/2    π/2    π
/// ```
fn nominal_puma() -> Result<Robot<f32>, ModelError> {
    let s = [26.0, -8.0, 0.0, 17.0, 0.0, -2.25];
    let a = [0.0, 17.0, 0.0, 0.0, 0.0, 0.0];
    // The table prints 1.570796 and 3.141593: π/2 and π to six decimals.
    let alpha = [FRAC_PI_2, 0.0, FRAC_PI_2, FRAC_PI_2, FRAC_PI_2, PI];
    let mut links = [Link::new(JointType::Revolute, 0.0, 0.0, 0.0, 0.0); 6];
    for (m, link) in links.iter_mut().enumerate() {
        *link = Link::new(JointType::Revolute, 0.0, s[m] * INCH, a[m] * INCH, alpha[m]);
    }
    Robot::new(Convention::Dh, &links)
}

/// Checks every column of the manipulator Jacobian at `q` against the central
/// difference `(p(q + h e_m) - p(q - h e_m)) / 2h` of the measured point `p`:
/// the column's displacement of the point (Mirman & Gupta eq. 8) must be the
/// point's velocity per unit joint rate. Returns the largest difference, m/rad,
/// or infinity if a column or a difference is not finite.
fn jacobian_matches_forward(robot: &Robot<f32>, q: &[f32; 6]) -> Result<f32, ModelError> {
    let chain = robot.chain(q)?;
    let point = chain.point();
    let jacobian = chain.manipulator_jacobian();
    let mut worst: f32 = 0.0;
    for m in 0..jacobian.ncols() {
        let (mut plus, mut minus) = (*q, *q);
        plus[m] += STEP;
        minus[m] -= STEP;
        let difference =
            (robot.measured_point(&plus)? - robot.measured_point(&minus)?) / (2.0 * STEP);
        let error = at_point(&jacobian.column(m), &point) - difference;
        if error.iter().any(|e| !e.is_finite()) {
            return Ok(f32::INFINITY);
        }
        worst = worst.max(error.amax());
    }
    Ok(worst)
}

/// Builds the model, runs the kinematics once, logs the result.
fn run() -> Result<bool, ModelError> {
    let robot = nominal_puma()?;
    let end = robot.forward(&POSITION_1)?;
    let p = end.translation.vector;
    defmt::info!(
        "nominal PUMA, position 1: measured point [{=f32}, {=f32}, {=f32}] m",
        p.x,
        p.y,
        p.z
    );
    let worst = jacobian_matches_forward(&robot, &POSITION_1)?;
    let ok = worst <= TOLERANCE;
    if ok {
        defmt::info!(
            "manipulator Jacobian matches the forward kinematics: worst column error {=f32} m/rad (tolerance {=f32})",
            worst,
            TOLERANCE
        );
    } else {
        defmt::error!(
            "manipulator Jacobian disagrees with the forward kinematics: worst column error {=f32} m/rad (tolerance {=f32})",
            worst,
            TOLERANCE
        );
    }
    Ok(ok)
}

#[entry]
fn main() -> ! {
    defmt::info!("armcal-firmware {=str} booted", env!("CARGO_PKG_VERSION"));
    let status = match run() {
        Ok(true) => EXIT_SUCCESS,
        Ok(false) => EXIT_FAILURE,
        Err(e) => {
            defmt::error!("kinematics failed: {}", defmt::Display2Format(&e));
            EXIT_FAILURE
        }
    };
    exit(status)
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
    defmt::error!("panic: {}", defmt::Display2Format(info));
    exit(EXIT_FAILURE)
}
