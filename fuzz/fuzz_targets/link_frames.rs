//! Fuzz target `link_frames`: the harness and what it asserts are in
//! [`armcal_fuzz::link_frames`] (`src/link_frames.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    armcal_fuzz::link_frames::run(data);
});
