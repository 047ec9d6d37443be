//! Dense disparity for rectified stereo pairs by block matching: SAD, SSD and zero-mean NCC over
//! square windows (3..=31), on 8- or 16-bit images, with OpenCV-style prefilters or a rank
//! transform (gain- and offset-invariant matching at SAD's speed), winner-take-all
//! over `[min_disparity, min_disparity + num_disparities)`, sub-pixel refinement (equiangular for
//! SAD, parabola otherwise), texture threshold, uniqueness ratio, left–right check, confidence
//! threshold and speckle filter. Invalid pixels are NaN in the
//! [`parallax_camera_model::DisparityMap`] (never a silent 0).
//!
//! Validity: by default a pixel any check rejects stays invalid; filling the left–right and
//! confidence rejects from the background neighbour is an explicit option
//! ([`MatcherConfig::fill`], preset [`MatcherConfig::dense`] for benchmarks that count missing
//! pixels as bad). [`MatchStats`] counts the rejections by reason, [`BlockMatcher::confidence`]
//! gives a per-pixel confidence (best against second-best non-adjacent cost, times the
//! left–right agreement), [`BlockMatcher::check_swap`] says whether the pair looks swapped, and
//! [`evaluate`] reports bad-N both with missing = bad and among the returned pixels.
//! Defaults: 9x9 SAD on the x-Sobel prefilter (cap 31), no uniqueness margin, left–right 1 px,
//! speckle 100 px. Colour pairs: [`BlockMatcher::compute_rgb`] (block matching's SAD or SSD
//! window cost and the semi-global pixel cost summed over the three channels, each prefiltered;
//! NCC refused on colour).
//!
//! Semi-global matching ([`Method::Sgm`], presets [`MatcherConfig::sgm`] (the default: three
//! paths, OpenCV SGBM's pixel cost and left–right rule), [`MatcherConfig::sgm_accurate`] and
//! [`MatcherConfig::sgm_dense`]): Hirschmüller's path-wise aggregation over three or five paths
//! (one pass; three are OpenCV 3-way's directions) or eight (two passes), P1/P2 with an
//! intensity-adaptive P2, on the SAD (or Birchfield–Tomasi difference) of the prefiltered
//! images (x-Sobel or rank) over a small window, with the same decisions and sub-pixel step as
//! block matching. Memory is bounded: strips of rows run as
//! parallel tasks with `≈ 9 · W · Dq · 2` bytes each (five paths; `Dq`: `D` rounded up to
//! 16) or `≈ (strip + 9) · W · Dq · 2` bytes (eight paths, strips capped at 48 MiB), paths
//! starting `overlap` rows outside the strip. Exact 16-bit integer aggregation in AVX2
//! intrinsics, checked against a naive reference. [`MatcherConfig::sgm_accurate`] uses SGBM's
//! own ingredients (Birchfield–Tomasi and intensity cost, its left–right rule, eight paths).
//!
//! Many frames: [`BlockMatcher::frames`] matches an iterator of pairs (any source; no file I/O
//! here) with the next pair pulled on a prefetch thread.
//!
//! Speed: window sums are running box sums over disparity-major column sums kept per row band in
//! cache (the cost volume is never materialised), exact integer arithmetic, row bands in parallel
//! with rayon, prefilter and texture passes parallel too. The cost does not grow with the window.
//! SAD and SSD run a fused kernel in explicit 256-bit SIMD chosen at run time (AVX2; the 16-bit
//! kernel also compiled for AVX-512 F/BW/VL, `SimdLevel::Avx512`: the same operations with 32
//! registers), in 16-bit lanes when the window sums fit (SAD with the default x-Sobel or the rank prefilter, any
//! window) and in 32-bit lanes otherwise; NCC (and sums beyond 32 bits) runs generic
//! `u32`/`u64`/`f64` loops compiled for the baseline and AVX2 and chosen at run time. All paths give identical results (tested against a naive reference).
//! Accuracy on Middlebury and speed against OpenCV's `StereoBM` / `StereoSGBM` (interleaved, same
//! images and options) are recorded in the repository's performance journal,
//! `benches/RESULTS.md`.
//!
//! ```
//! use parallax_block_matching::{BlockMatcher, MatcherConfig, evaluate};
//! use parallax_camera_model::DisparityMap;
//! use image::GrayImage;
//!
//! // a textured pair shifted by 7 px
//! let tex = |x: i64, y: i64| (((x * 7919 + y * 104_729) ^ (x * y)) % 251) as u8;
//! let left = GrayImage::from_fn(96, 48, |x, y| image::Luma([tex(x as i64, y as i64)]));
//! let right = GrayImage::from_fn(96, 48, |x, y| image::Luma([tex(x as i64 + 7, y as i64)]));
//! let mut matcher = BlockMatcher::new(MatcherConfig { num_disparities: 16, ..Default::default() })?;
//! let disparity = matcher.compute(&left, &right)?;
//! assert!((disparity.get(50, 20).unwrap() - 7.0).abs() < 0.05);
//! let truth = DisparityMap::from_data(96, 48, vec![7.0; 96 * 48]).unwrap();
//! let e = evaluate(&disparity, &truth, None, &[0.5])?;
//! // missing = bad, then among the returned pixels
//! assert!(e.bad_at(0.5).unwrap() < 15.0 && e.density > 85.0);
//! assert!(e.bad_returned_at(0.5).unwrap() < 1.0);
//! // the pair as given matches; the other way round it would not
//! assert!(!matcher.check_swap(&left, &right)?.looks_swapped);
//! # Ok::<(), parallax_block_matching::BlockMatchingError>(())
//! ```

mod band;
mod config;
mod decide;
mod engine;
mod error;
mod eval;
mod frame;
mod io;
pub mod prefilter;
mod sgm;
#[cfg(target_arch = "x86_64")]
mod simd;
mod speckle;
mod stream;
mod swap;

// The crates whose types this crate's public API uses, re-exported so that a caller needs no
// version match with them (`parallax_x::glam::DVec3` is the `DVec3` this crate takes).
pub use glam;
pub use image;
pub use parallax_camera_model;
pub use parallax_least_squares;

pub use config::{CostFunction, MatcherConfig, Method, Prefilter, SgmConfig, SgmPaths, Subpixel};
pub use engine::{BlockMatcher, SimdLevel};
pub use error::{BlockMatchingError, Result};
pub use eval::{Evaluation, evaluate, evaluate_overlap, overlap_columns};
pub use frame::{Gray16Image, MatchStats};
pub use io::{false_colour, from_pfm, from_scaled, to_pfm, to_png16};
pub use speckle::filter_speckles;
pub use stream::{Frame, Frames, MAX_PREFETCH, StereoPair};
pub use swap::{SwapCheck, SwapChecker};
