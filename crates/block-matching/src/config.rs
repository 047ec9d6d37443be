use serde::{Deserialize, Serialize};

use crate::error::{BlockMatchingError, Result};

/// The matching cost of one window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum CostFunction {
    /// Sum of absolute differences (integer, exact).
    #[default]
    Sad,
    /// Sum of squared differences (integer, exact).
    Ssd,
    /// Zero-mean normalised cross-correlation; the cost is `1 − ncc` in `[0, 2]` (a window of
    /// constant intensity has `ncc = 0`). Invariant to a gain and an offset between the images.
    Ncc,
}

/// Image prefilter applied to both images before the cost is computed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Prefilter {
    /// Raw intensities.
    None,
    /// OpenCV's `PREFILTER_XSOBEL`: 3x3 x-Sobel response clipped to `[−cap, cap]` and shifted by
    /// `cap` (output `0..=2·cap`). `cap` is in 8-bit grey levels (scaled by 257 for 16-bit input).
    XSobel {
        /// Clipping value (OpenCV `preFilterCap`, 1..=63; default 31).
        cap: u16,
    },
    /// OpenCV-like `PREFILTER_NORMALIZED_RESPONSE`: intensity minus the mean of a `size x size`
    /// window, clipped to `[−cap, cap]` and shifted by `cap`.
    NormalizedResponse {
        /// Window of the local mean (odd, 3..=31; OpenCV default 9).
        size: usize,
        /// Clipping value in 8-bit grey levels (scaled by 257 for 16-bit input).
        cap: u16,
    },
    /// Rank transform (Zabih & Woodfill 1994): each pixel becomes the number of pixels of its
    /// `size x size` neighbourhood (clamp-to-edge) darker than it, `0..size² − 1`. Invariant to
    /// any monotonic change of brightness (a gain and an offset between the cameras), and the
    /// small values keep SAD on the 16-bit vectorised path for every window. Middlebury, SAD
    /// 9x9, bad-2 with missing = bad (tsukuba / venus / teddy): 9x9 ranks 7.42 / 3.59 / 7.55,
    /// 5x5 ranks 10.15 / 4.69 / 8.48, against 5.90 / 5.06 / 11.08 with the default x-Sobel.
    Rank {
        /// Neighbourhood of the transform (odd, 3..=15).
        size: usize,
    },
}

impl Default for Prefilter {
    fn default() -> Self {
        Prefilter::XSobel { cap: 31 }
    }
}

/// Sub-pixel refinement of the winning integer disparity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Subpixel {
    /// Integer disparities only.
    None,
    /// Equiangular (V-shaped) fit for SAD, parabola for SSD and NCC.
    #[default]
    Auto,
    /// Parabola through the costs at `d − 1, d, d + 1`.
    Parabola,
    /// Equiangular line fit (the natural model of SAD).
    Equiangular,
}

/// Configuration of a [`crate::BlockMatcher`]. Defaults follow OpenCV's `StereoBM` (x-Sobel cap
/// 31, texture threshold 10, no speckle filter) with its most accurate uniqueness setting (0),
/// plus a left–right check (1 px) whose rejects are filled from the background neighbour: on
/// Middlebury (`examples/middlebury_sweep.rs`) every pure rejection raised bad-2 (missing counts
/// as bad) while check + fill lowered it on all pairs. The defaults give a dense map; for
/// downstream geometry where a wrong disparity is worse than none, start from
/// [`MatcherConfig::filtered`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MatcherConfig {
    /// Cost function (default SAD).
    pub cost: CostFunction,
    /// Window side in pixels: odd, 3..=31 (default 9).
    pub block_size: usize,
    /// Smallest disparity searched, pixels (default 0; may be negative).
    pub min_disparity: i32,
    /// Number of disparities searched: `[min_disparity, min_disparity + num_disparities)`,
    /// 1..=1024 (default 64; unlike OpenCV any count is allowed, not only multiples of 16).
    pub num_disparities: usize,
    /// Prefilter of both images (default clipped x-Sobel, cap 31, as OpenCV).
    pub prefilter: Prefilter,
    /// A pixel is invalid when the window sum of its clipped x-Sobel magnitude (cap 31, 8-bit
    /// units; times 257 for 16-bit input) is below this (OpenCV `textureThreshold`, default 10;
    /// 0 disables).
    pub texture_threshold: u32,
    /// Uniqueness margin in percent: the best cost `c*` wins only if every disparity further than
    /// one pixel from it costs more than `c* + c*·ratio/100` (OpenCV `uniquenessRatio`; default 0 =
    /// off, OpenCV's most accurate StereoBM setting; [`MatcherConfig::filtered`] uses 10).
    pub uniqueness_ratio: u32,
    /// Left–right consistency: a pixel is kept only if the right image's own winner at the
    /// matched pixel is within this many pixels (integer disparities). `None` disables
    /// (default `Some(1)`, as SGBM's `disp12MaxDiff = 1`; rejected pixels are then filled, see
    /// `lr_fill`).
    pub lr_max_diff: Option<u32>,
    /// Fill pixels rejected by the left–right check (occlusions, the fattened side of depth
    /// edges) with the smaller of the nearest valid disparities left and right on the row (the
    /// background side). Filled pixels are counted in [`crate::MatchStats::lr_filled`]. Default
    /// `true`; no effect without `lr_max_diff`.
    pub lr_fill: bool,
    /// Speckle filter: 4-connected regions of at most this many pixels are invalidated (OpenCV
    /// `speckleWindowSize`; default 0 = off as OpenCV; [`MatcherConfig::filtered`] uses 100).
    pub speckle_window_size: usize,
    /// Two neighbours belong to one region when their disparities differ by at most this many
    /// pixels (OpenCV `speckleRange`, here in pixels, not 1/16 px; default 2.0).
    pub speckle_range: f32,
    /// Sub-pixel refinement (default `Auto`: equiangular for SAD, parabola otherwise).
    pub subpixel: Subpixel,
    /// Worker threads: 0 uses rayon's global pool, `n` builds a private pool of `n` threads once.
    pub threads: usize,
}

impl Default for MatcherConfig {
    fn default() -> Self {
        Self {
            cost: CostFunction::Sad,
            block_size: 9,
            min_disparity: 0,
            num_disparities: 64,
            prefilter: Prefilter::default(),
            texture_threshold: 10,
            uniqueness_ratio: 0,
            lr_max_diff: Some(1),
            lr_fill: true,
            speckle_window_size: 0,
            speckle_range: 2.0,
            subpixel: Subpixel::Auto,
            threads: 0,
        }
    }
}

fn invalid(field: &'static str, value: impl ToString, reason: &'static str) -> BlockMatchingError {
    BlockMatchingError::InvalidConfig { field, value: value.to_string(), reason }
}

impl MatcherConfig {
    /// Defaults plus the reliability filters and no filling: uniqueness 10 %, left–right
    /// tolerance 1 px without fill, speckle filter of 100 px (range 2 px). Fewer pixels, fewer
    /// gross errors (Middlebury teddy, SAD 9x9: density 84.5 %, bad-2 18.96 % counting missing
    /// pixels as bad, i.e. about 5 % of the kept pixels off by more than 2 px).
    pub fn filtered() -> Self {
        Self { uniqueness_ratio: 10, lr_max_diff: Some(1), lr_fill: false, speckle_window_size: 100, ..Self::default() }
    }

    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<()> {
        if self.block_size.is_multiple_of(2) || !(3..=31).contains(&self.block_size) {
            return Err(invalid("block_size", self.block_size, "must be odd, 3..=31"));
        }
        if !(1..=1024).contains(&self.num_disparities) {
            return Err(invalid("num_disparities", self.num_disparities, "must be 1..=1024"));
        }
        if self.min_disparity.unsigned_abs() > 1 << 20 {
            return Err(invalid("min_disparity", self.min_disparity, "must be within ±2^20"));
        }
        match self.prefilter {
            Prefilter::None => {}
            Prefilter::XSobel { cap } => {
                if !(1..=63).contains(&cap) {
                    return Err(invalid("prefilter.cap", cap, "must be 1..=63"));
                }
            }
            Prefilter::NormalizedResponse { size, cap } => {
                if !(1..=63).contains(&cap) {
                    return Err(invalid("prefilter.cap", cap, "must be 1..=63"));
                }
                if size.is_multiple_of(2) || !(3..=31).contains(&size) {
                    return Err(invalid("prefilter.size", size, "must be odd, 3..=31"));
                }
            }
            Prefilter::Rank { size } => {
                if size.is_multiple_of(2) || !(3..=15).contains(&size) {
                    return Err(invalid("prefilter.size", size, "must be odd, 3..=15"));
                }
            }
        }
        if self.uniqueness_ratio > 1000 {
            return Err(invalid("uniqueness_ratio", self.uniqueness_ratio, "must be 0..=1000 percent"));
        }
        if !(self.speckle_range.is_finite() && self.speckle_range >= 0.0) {
            return Err(invalid("speckle_range", self.speckle_range, "must be finite and ≥ 0"));
        }
        if self.threads > 1024 {
            return Err(invalid("threads", self.threads, "must be 0..=1024"));
        }
        Ok(())
    }

    /// The sub-pixel method actually used for this cost function (resolves `Auto`).
    pub fn effective_subpixel(&self) -> Subpixel {
        match (self.subpixel, self.cost) {
            (Subpixel::Auto, CostFunction::Sad) => Subpixel::Equiangular,
            (Subpixel::Auto, _) => Subpixel::Parabola,
            (s, _) => s,
        }
    }
}
