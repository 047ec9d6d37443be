//! Fuzz target `visp_camera`: see `parallax_composition::fuzz_checks::visp_camera` for what it checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| parallax_composition::fuzz_checks::visp_camera(data));
