//! Fuzz target `calibration`: see `parallax_composition::fuzz_checks::calibration` for what it checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| parallax_composition::fuzz_checks::calibration(data));
