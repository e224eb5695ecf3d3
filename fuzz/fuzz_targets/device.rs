//! Fuzz target `device`: the harness and what it asserts are in
//! [`armcal_fuzz::device`] (`src/device.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    armcal_fuzz::device::run(data);
});
