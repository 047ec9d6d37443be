//! Fuzz target `pose_text`: see `parallax_composition::fuzz_checks::pose_text` for what it checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| parallax_composition::fuzz_checks::pose_text(data));
