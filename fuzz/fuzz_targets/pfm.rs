//! Fuzz target `pfm`: see `parallax_composition::fuzz_checks::pfm` for what it checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| parallax_composition::fuzz_checks::pfm(data));
