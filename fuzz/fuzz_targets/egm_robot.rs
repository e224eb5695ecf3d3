//! Fuzz target `egm_robot`: the harness and what it asserts are in
//! [`armcal_fuzz::egm_robot`] (`src/egm_robot.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    armcal_fuzz::egm_robot::run(data);
});
