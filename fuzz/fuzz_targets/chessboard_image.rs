//! Fuzz target `chessboard_image`: see `parallax_composition::fuzz_checks::chessboard_image` for what it checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| parallax_composition::fuzz_checks::chessboard_image(data));
