//! Fuzz target `target_file`: see `parallax_composition::fuzz_checks::target_file` for what it checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| parallax_composition::fuzz_checks::target_file(data));
