//! USART1 of the STM32F405, by direct register access: the controller's end of
//! the serial link (`armcal_shared::link`).
//!
//! QEMU's `netduinoplus2` wires its first `-serial` to USART1 (0x4001_1000; the
//! SoC's USARTs are created in the order USART1, 2, 3, UART4, 5, USART6). Its
//! model keeps one received byte in `DR` and refuses more until `DR` is read
//! (the host's bytes wait in QEMU's character device), so polling `RXNE` loses
//! nothing; a write to `DR` is sent at once. On the chip, PA9 (TX) and PA10 (RX)
//! in alternate function 7 carry the link, 8 data bits, no parity, one stop
//! bit, [`BAUD`] baud from the 16 MHz HSI clock the chip starts on (the firmware
//! does not start the PLL); QEMU ignores the clock and pin setup.
#![allow(unsafe_code)] // Memory-mapped registers: volatile reads and writes.

use core::ptr::{read_volatile, write_volatile};

/// Bits per second on the chip (QEMU ignores it).
pub const BAUD: u32 = 115_200;

/// The clock of USART1 (APB2) after reset, Hz: the 16 MHz HSI.
const PCLK2_HZ: u32 = 16_000_000;

const RCC: usize = 0x4002_3800;
const RCC_AHB1ENR: usize = RCC + 0x30;
const RCC_APB2ENR: usize = RCC + 0x44;
const GPIOA: usize = 0x4002_0000;
const GPIOA_MODER: usize = GPIOA;
const GPIOA_AFRH: usize = GPIOA + 0x24;
const USART1: usize = 0x4001_1000;
const SR: usize = USART1;
const DR: usize = USART1 + 0x04;
const BRR: usize = USART1 + 0x08;
const CR1: usize = USART1 + 0x0C;

const SR_RXNE: u32 = 1 << 5;
const SR_TXE: u32 = 1 << 7;
const SR_ERRORS: u32 = 0b1111; // PE, FE, NE, ORE
const CR1_UE: u32 = 1 << 13;
const CR1_TE: u32 = 1 << 3;
const CR1_RE: u32 = 1 << 2;

fn read(addr: usize) -> u32 {
    // SAFETY: `addr` is one of the STM32F405 register addresses above, aligned,
    // always mapped (by the chip, and by QEMU as a device or an unimplemented
    // region); reading it has no effect beyond the peripheral's own.
    unsafe { read_volatile(addr as *const u32) }
}

fn write(addr: usize, value: u32) {
    // SAFETY: as in `read`; only this module touches these registers, from the
    // single thread of the firmware (no interrupt handler uses them).
    unsafe { write_volatile(addr as *mut u32, value) }
}

/// USART1, configured once.
pub struct Serial(());

impl Serial {
    /// Clocks GPIOA and USART1, puts PA9/PA10 in alternate function 7 and turns
    /// the USART on: 8N1, [`BAUD`], transmitter and receiver enabled.
    pub fn init() -> Self {
        write(RCC_AHB1ENR, read(RCC_AHB1ENR) | 1);
        write(RCC_APB2ENR, read(RCC_APB2ENR) | (1 << 4));
        let moder = read(GPIOA_MODER) & !(0b1111 << 18);
        write(GPIOA_MODER, moder | (0b1010 << 18));
        let afrh = read(GPIOA_AFRH) & !(0xFF << 4);
        write(GPIOA_AFRH, afrh | (0x77 << 4));
        write(BRR, (PCLK2_HZ + BAUD / 2) / BAUD);
        write(CR1, CR1_UE | CR1_TE | CR1_RE);
        Self(())
    }

    /// The next received byte (waits for it). A byte received with a framing,
    /// noise or overrun error is still returned: the frame it belongs to fails
    /// its decoding and is refused as a whole.
    pub fn read_byte(&mut self) -> u8 {
        loop {
            let sr = read(SR);
            if sr & (SR_RXNE | SR_ERRORS) != 0 {
                // Reading SR then DR clears RXNE and the error flags.
                return read(DR) as u8;
            }
        }
    }

    /// Sends `bytes` (waits for room before each).
    pub fn write_all(&mut self, bytes: &[u8]) {
        for &b in bytes {
            while read(SR) & SR_TXE == 0 {}
            write(DR, u32::from(b));
        }
    }
}
