//! Fuzz target `point_list`: see `parallax_composition::fuzz_checks::point_list` for what it checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| parallax_composition::fuzz_checks::point_list(data));
