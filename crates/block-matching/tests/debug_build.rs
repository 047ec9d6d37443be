//! Semi-global matching and block matching in a build at opt-level 0 (a user's default `cargo
//! run`) on rayon worker threads (issue 50: eight-path SGM overflowed their default 2 MiB stacks).
//!
//! Meaningful under the workspace's `debug-o0` profile (opt-level 0 for every crate), which CI
//! runs: `cargo test --profile debug-o0 -p parallax-block-matching --test debug_build`. There LLVM
//! shares no stack slot between the bodies `#[inline(always)]` pastes into a function and keeps no
//! vector in a register, so a function's frame is the sum of every local of everything inlined
//! into it: before the fix `strip_avx2` had a frame of 999 KiB, the scalar `run_strip` one of 996
//! KiB and each `forward_row_avx2` one of 498 KiB, and a strip's call chain needed more than 2 MiB.
//! In the other profiles the frames are small and the tests take a few seconds.
//!
//! Two checks. The case end to end: 1282x1110 with 256 disparities (`Dq` = 256, the
//! largest lane count compiled on its own), eight paths (both passes: 17 strips of 67 rows), and
//! block matching at the same size, at the CPU's SIMD level on rayon's default 2 MiB worker stacks.
//! The frames: a frame's size does not depend on the image, so every SIMD level (the scalar one
//! included, which would take minutes at full size) runs a 320x64 crop with the same range on
//! 256 KiB worker stacks (the whole chain takes less than 128 KiB at opt-level 0 since the fix), its
//! maps equal bit for bit. The full size is what makes the test slow at opt-level 0 (about 170 s of
//! CPU for SGM, almost all of it in the vector kernels' intrinsic calls, and 30 s for block
//! matching); the pairs are a hash per pixel (no rendering), shifted by known disparities, so that
//! the maps are checked, not only computed.

use image::{GrayImage, Luma};
use parallax_block_matching::parallax_camera_model::DisparityMap;
use parallax_block_matching::{BlockMatcher, CostFunction, MatcherConfig, Prefilter, SgmPaths, SimdLevel};

const W: u32 = 1282;
const H: u32 = 1110;
const ND: usize = 256;
/// The disparity of the rows above `H / 2` and of those below: small and near the top of the
/// range.
const SHIFTS: [u32; 2] = [37, 211];
/// Rayon's default worker stack (std's default thread stack), set explicitly so that a
/// `RUST_MIN_STACK` in the environment cannot make the test pass.
const WORKER_STACK: usize = 2 << 20;
/// The worker stack of the crops at every SIMD level: an eighth of the default.
const CROP_STACK: usize = 256 << 10;

/// A texture of `0..16` above a grey level of 96, from a hash of the pixel.
fn texture(x: u32, y: u32) -> u8 {
    let mut v = (x as u64) << 32 | y as u64;
    v = (v ^ (v >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    v = (v ^ (v >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    96 + ((v ^ (v >> 31)) & 15) as u8
}

fn shift(y: u32, h: u32) -> u32 {
    SHIFTS[(y >= h / 2) as usize]
}

/// A pair whose left pixel `(x, y)` is the right pixel `(x − shift(y), y)`.
fn pair(w: u32, h: u32) -> (GrayImage, GrayImage) {
    let left = GrayImage::from_fn(w, h, |x, y| Luma([texture(x, y)]));
    let right = GrayImage::from_fn(w, h, |x, y| Luma([texture(x + shift(y, h), y)]));
    (left, right)
}

/// Runs `f` on a rayon pool of two workers with `stack` bytes of stack each.
fn in_pool<T: Send>(stack: usize, f: impl FnOnce() -> T + Send) -> T {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).stack_size(stack).build().unwrap();
    pool.install(f)
}

/// Checks `map` against the shifts: among the pixels whose match is inside the right image,
/// away from the rows where the shift changes and from the image's edges (where clamp-to-edge
/// windows differ between the images), at least `min_density` of them returned, each within
/// 0.25 px of its disparity.
fn check_shifts(map: &DisparityMap, min_density: f64, what: &str) {
    let (w, h) = (map.width() as u32, map.height() as u32);
    let (mut checked, mut valid) = (0usize, 0usize);
    for y in (0..h).filter(|&y| y.abs_diff(h / 2) > 16) {
        let d = shift(y, h);
        for x in d + 8..w - 8 {
            checked += 1;
            if let Some(v) = map.get(x as usize, y as usize) {
                valid += 1;
                assert!((v - d as f32).abs() < 0.25, "{what}: ({x}, {y}) {v} against {d}");
            }
        }
    }
    let density = valid as f64 / checked as f64;
    assert!(density >= min_density, "{what}: {valid} of {checked} pixels returned");
}

/// The maps of every SIMD level the CPU has on a 320x64 pair with the same range, on
/// [`CROP_STACK`] worker stacks: equal bit for bit, and checked as [`check_shifts`] checks them.
fn check_levels(cfg: &MatcherConfig, min_density: f64, what: &str) {
    let (left, right) = pair(320, 64);
    let maps: Vec<(SimdLevel, DisparityMap)> = in_pool(CROP_STACK, || {
        [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512]
            .into_iter()
            .filter_map(|level| {
                let mut m = BlockMatcher::new(cfg.clone()).unwrap();
                (m.set_simd(level) == level).then(|| (level, m.compute(&left, &right).unwrap()))
            })
            .collect()
    });
    let bits = |m: &DisparityMap| m.data().iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
    let (first, map) = &maps[0];
    check_shifts(map, min_density, &format!("{what}, 320x64, {first:?}"));
    for (level, other) in &maps[1..] {
        assert!(bits(other) == bits(map), "{what}: {level:?} differs from {first:?} on the 320x64 crop");
    }
}

/// Eight-path semi-global matching (the measurement preset otherwise) at 1282x1110x256 on 2 MiB
/// worker stacks, at the CPU's level; every level's map on a 320x64 crop equal to the scalar one.
#[test]
fn sgm_eight_paths_1282x1110x256_fits_rayon_worker_stacks() {
    let mut cfg = MatcherConfig::sgm();
    cfg.num_disparities = ND;
    cfg.sgm.paths = SgmPaths::Eight;
    let (left, right) = pair(W, H);
    let map = in_pool(WORKER_STACK, || BlockMatcher::new(cfg.clone()).unwrap().compute(&left, &right).unwrap());
    check_shifts(&map, 0.98, "sgm");
    check_levels(&cfg, 0.98, "sgm");
}

/// Block matching (the default configuration: 9x9 SAD on the rank transform, the 16-bit lanes'
/// kernel) at 1282x1110x256 on 2 MiB worker stacks, at the CPU's level; every level's map on a
/// 320x64 crop equal to the scalar one, with the default configuration and with SSD on x-Sobel
/// (the 32-bit lanes' kernel).
#[test]
fn block_matching_1282x1110x256_fits_rayon_worker_stacks() {
    let (left, right) = pair(W, H);
    let sad = MatcherConfig { num_disparities: ND, ..MatcherConfig::default() };
    let map = in_pool(WORKER_STACK, || BlockMatcher::new(sad.clone()).unwrap().compute(&left, &right).unwrap());
    check_shifts(&map, 0.95, "block matching");
    check_levels(&sad, 0.95, "block matching, SAD");
    let ssd = MatcherConfig { cost: CostFunction::Ssd, prefilter: Prefilter::XSobel { cap: 31 }, ..sad };
    check_levels(&ssd, 0.95, "block matching, SSD");
}
