//! Benchmarks of parallax (criterion, and the block matcher against this machine's ceiling); the
//! library holds what they share: Middlebury teddy when `../shared` is present, a generated
//! stereo pair and the vector-add chains ([`ceiling`]).
//!
//! | bench | what it measures |
//! |---|---|
//! | `disparity` | block matching SAD / SSD / NCC at 450x375x64 and 1280x720x128, windows 5 / 9 / 15, 1 and 2 threads |
//! | `corners` | chessboard detection + sub-pixel refinement on a 640x480 image |
//! | `calibration` | mono (14 views x 54 corners) and stereo calibration |
//! | `rectify` | building undistort/rectify maps and remapping a 640x480 pair |
//! | `ceiling` | block matching at 626x555x96 and 1282x1110x224 as a share of this machine's ceiling (vector adds on every core, interleaved rounds; not criterion: `cargo bench -p parallax-benches --bench ceiling`) |
//!
//! Run them with `cargo xtask bench [FILTER] [--quick]` (release build). Figures are reported,
//! never asserted in tests.

pub mod ceiling;

/// Middlebury teddy (`../shared/data/middlebury/teddy`, grey), or `None` without `../shared`.
pub fn teddy() -> Option<(GrayImage, GrayImage)> {
    let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/middlebury/teddy"));
    let (l, r) = (image::open(dir.join("imL.png")).ok()?, image::open(dir.join("imR.png")).ok()?);
    Some((l.into_luma8(), r.into_luma8()))
}

use image::{GrayImage, Luma};
use rand::{Rng, SeedableRng};

/// A textured pair `w x h`: noise interpolated along the rows, the right image the left one shifted
/// by a slanted disparity field from `0.2 · max_d` to `0.8 · max_d`.
pub fn textured_pair(w: u32, h: u32, max_d: f64) -> (GrayImage, GrayImage) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
    let big_w = w as usize + max_d as usize + 2;
    let noise: Vec<f64> = (0..big_w * h as usize).map(|_| rng.random_range(0.0..255.0)).collect();
    let tex = |x: f64, y: usize| {
        let x0 = x.floor() as usize;
        let t = x - x0 as f64;
        let a = noise[y * big_w + x0.min(big_w - 2)];
        let b = noise[y * big_w + (x0 + 1).min(big_w - 1)];
        a + t * (b - a)
    };
    let disp = |x: u32, y: u32| 0.2 * max_d + 0.6 * max_d * (x as f64 / w as f64 + y as f64 / h as f64) / 2.0;
    let left = GrayImage::from_fn(w, h, |x, y| Luma([tex(x as f64 + max_d, y as usize) as u8]));
    let right = GrayImage::from_fn(w, h, |x, y| Luma([tex(x as f64 + max_d + disp(x, y), y as usize) as u8]));
    (left, right)
}
