//! The tick clock: SysTick counting core clock cycles, extended past its 24 bits
//! by counting its wraps, to time each command against the tick period.
//!
//! On the chip the count is real core cycles. Under QEMU it is not: SysTick
//! follows QEMU's virtual clock. `firmware/qemu-link-test.sh` runs QEMU with
//! `-icount shift=3`, which makes every guest instruction last 8 ns of virtual
//! time, so a duration is the instruction count × 1.344 cycles at 168 MHz:
//! deterministic, but blind to flash wait states, pipeline stalls and FPU
//! latencies. Without `-icount` it follows the host's wall clock.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::exception;

/// The SysTick reload: the counter runs through all 24 bits.
const RELOAD: u32 = 0x00FF_FFFF;

/// Wraps of the SysTick counter since [`Clock::start`].
static WRAPS: AtomicU32 = AtomicU32::new(0);

/// The running cycle counter.
pub struct Clock(());

impl Clock {
    /// Starts SysTick on the core clock, counting down from [`RELOAD`], with its
    /// wrap interrupt.
    pub fn start(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        Self(())
    }

    /// Core cycles since [`Clock::start`].
    pub fn now(&self) -> u64 {
        loop {
            let before = WRAPS.load(Ordering::SeqCst);
            let value = SYST::get_current();
            // A wrap between the two loads (its interrupt is taken at once) makes
            // `value` ambiguous: read again.
            if WRAPS.load(Ordering::SeqCst) == before {
                return (u64::from(before) << 24) | u64::from(RELOAD - value);
            }
        }
    }
}

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::SeqCst);
}
