//! The stack's high-water mark.
//!
//! cortex-m-rt's `paint-stack` feature fills all RAM between the end of the
//! static data (`_stack_end`) and the top of the stack (`_stack_start`) with
//! `0xCCCC_CCCC` before `main`. The stack grows down from the top; the lowest
//! word that no longer holds the paint is as deep as it has ever reached.
//! (A word the program happened to write as `0xCCCC_CCCC` at the very bottom
//! would hide up to four bytes.)
#![allow(unsafe_code)] // Reading the painted RAM and the linker's symbols.

use core::ptr::{addr_of, read_volatile};

use cortex_m_rt::STACK_PAINT_VALUE;

unsafe extern "C" {
    /// The lowest address of the stack region (cortex-m-rt's `link.x`).
    static _stack_end: u32;
    /// One past the highest address of the stack (its initial pointer).
    static _stack_start: u32;
}

/// The most stack used since reset, bytes.
pub fn used() -> u32 {
    // Only the addresses of the linker symbols are taken, never their values.
    let (bottom, top) = (addr_of!(_stack_end), addr_of!(_stack_start));
    let (bottom, top) = (bottom as usize, top as usize);
    let mut addr = bottom;
    while addr < top {
        // SAFETY: `addr` is word-aligned (both symbols are) and inside RAM between
        // the static data and the top of the stack, which is always mapped;
        // reading RAM has no side effect, and a word the stack is using is only read.
        let word = unsafe { read_volatile(addr as *const u32) };
        if word != STACK_PAINT_VALUE {
            break;
        }
        addr += 4;
    }
    (top - addr) as u32
}
