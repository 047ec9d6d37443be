//! Criterion benchmarks of parallax; this library target holds no code of its own.
//!
//! | bench | what it measures |
//! |---|---|
//! | `disparity` | block matching SAD / SSD / NCC at 450x375x64 and 1280x720x128, windows 5 / 9 / 15, 1 and 2 threads |
//! | `corners` | chessboard detection + sub-pixel refinement on a 640x480 image |
//! | `calibration` | mono (14 views x 54 corners) and stereo calibration |
//! | `rectify` | building undistort/rectify maps and remapping a 640x480 pair |
//!
//! Run them with `cargo xtask bench [FILTER] [--quick]` (release build). Figures are reported,
//! never asserted in tests.
