//! Fuzz target `model_toml`: the harness and what it asserts are in
//! [`armcal_fuzz::model_toml`] (`src/model_toml.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    armcal_fuzz::model_toml::run(data);
});
