//! Fuzz target `visp_pose`: see `parallax_composition::fuzz_checks::visp_pose` for what it checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| parallax_composition::fuzz_checks::visp_pose(data));
