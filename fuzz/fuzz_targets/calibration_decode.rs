//! Fuzz target `calibration_decode`: the harness and what it asserts are in
//! [`armcal_fuzz::calibration`] (`src/calibration.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    armcal_fuzz::calibration::run(data);
});
