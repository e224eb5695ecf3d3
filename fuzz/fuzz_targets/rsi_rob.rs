//! Fuzz target `rsi_rob`: the harness and what it asserts are in
//! [`armcal_fuzz::rsi_rob`] (`src/rsi_rob.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    armcal_fuzz::rsi_rob::run(data);
});
