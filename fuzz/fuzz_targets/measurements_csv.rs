//! Fuzz target `measurements_csv`: the harness and what it asserts are in
//! [`armcal_fuzz::measurements`] (`src/measurements.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    armcal_fuzz::measurements::run(data);
});
