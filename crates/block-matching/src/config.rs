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

/// The matching method: local block matching or semi-global matching.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Method {
    /// Winner-take-all over window costs (`BlockMatcher`'s fused kernels).
    #[default]
    BlockMatching,
    /// Semi-global matching (Hirschmüller 2008) over the pixel-wise cost of the prefiltered
    /// images summed over a small window (`sgm_block`), aggregated along several paths (see
    /// [`SgmConfig`]).
    Sgm,
}

/// Number of aggregation paths of semi-global matching.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum SgmPaths {
    /// Eight paths (horizontal, vertical, both diagonals, both directions): two passes over the
    /// image, the most accurate.
    Eight,
    /// Five paths in one top-to-bottom pass (left-to-right, right-to-left, down, down-left,
    /// down-right): about 40 % less work than eight.
    #[default]
    Five,
    /// Three paths in one top-to-bottom pass (left-to-right, right-to-left, down): the
    /// directions of OpenCV's `MODE_SGBM_3WAY`, the fastest (about 0.7x the time of five); the
    /// [`MatcherConfig::sgm`] preset's.
    Three,
}

/// Parameters of semi-global matching ([`Method::Sgm`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SgmConfig {
    /// Aggregation paths (default five, one pass; three for OpenCV 3-way's directions).
    pub paths: SgmPaths,
    /// Penalty of a one-pixel disparity change between neighbours along a path, per pixel of
    /// the cost window: the penalty applied is `p1 · block²` (default 8).
    pub p1: u32,
    /// Penalty of a larger disparity jump, per pixel of the window (default 64; ≥ `p1`).
    pub p2: u32,
    /// Intensity-adaptive P2: across an intensity edge of the left image the jump penalty drops
    /// to `max(p1, p2 / (1 + |ΔI| / p2_gamma))` (depth edges follow intensity edges);
    /// `0` keeps P2 constant (default 16 grey levels).
    pub p2_gamma: u32,
    /// Side of the window summed into the per-pixel matching cost (odd, 1..=11; default 5).
    pub block: usize,
    /// Rows of one strip (a parallel task with its own buffers; paths restart at strip
    /// boundaries, `overlap` rows outside); 0 chooses an even number of strips of at most 256
    /// rows (`2 · ⌈height / 512⌉` strips), lowered for
    /// eight paths until the strip's stored sums stay under 48 MiB. Never the thread count: the
    /// map is the same on every machine.
    pub strip_rows: usize,
    /// Rows above (and, with eight paths, below) a strip where its vertical and diagonal paths
    /// start (default 16).
    pub overlap: usize,
    /// Birchfield–Tomasi's sampling-insensitive pixel difference on the prefiltered planes
    /// (OpenCV SGBM's): the distance from each pixel's value to the other image's interval
    /// `[min, max]` of its value and the half-way values to its two row neighbours, the
    /// smaller of the two directions, instead of `|L − R|` (default `false`).
    pub sampling_insensitive: bool,
    /// Adds an intensity term to the pixel cost: `|⌊I_L / 4⌋ − ⌊I_R / 4⌋|` of the raw images in
    /// 8-bit grey levels (16-bit input divided by 257 first), summed over the same window
    /// (OpenCV SGBM adds the raw difference / 4 to its x-Sobel one). It separates candidates
    /// where the x-Sobel plane is flat (default `false`).
    pub intensity_cost: bool,
}

impl Default for SgmConfig {
    fn default() -> Self {
        Self {
            paths: SgmPaths::Five,
            p1: 8,
            p2: 64,
            p2_gamma: 16,
            block: 5,
            strip_rows: 0,
            overlap: 16,
            sampling_insensitive: false,
            intensity_cost: false,
        }
    }
}

/// Configuration of a [`crate::BlockMatcher`]. The defaults are chosen for measurement: a
/// rejected pixel is invalid (NaN), never filled unless `fill` asks for it. 9x9 SAD on the
/// x-Sobel prefilter (cap 31, as OpenCV `StereoBM`), OpenCV's texture threshold 10, no
/// uniqueness margin, the left–right check (1 px) and the speckle filter (100 px, 2 px):
/// chosen on bad-2 with missing = bad where OpenCV's matchers also answer
/// (`examples/middlebury_sweep.rs`; figures in `benches/RESULTS.md`).
/// [`MatcherConfig::dense`] is the benchmark preset that fills the rejected pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MatcherConfig {
    /// Matching method (default block matching).
    pub method: Method,
    /// Cost function (default SAD). Semi-global matching supports SAD only (on any prefilter;
    /// with [`Prefilter::Rank`] it is the rank / census-like cost).
    pub cost: CostFunction,
    /// Window side in pixels: odd, 3..=31 (default 9).
    pub block_size: usize,
    /// Smallest disparity searched, pixels (default 0; may be negative).
    pub min_disparity: i32,
    /// Number of disparities searched: `[min_disparity, min_disparity + num_disparities)`,
    /// 1..=1024 (default 64; unlike OpenCV any count is allowed, not only multiples of 16).
    pub num_disparities: usize,
    /// Prefilter of both images (default the clipped x-Sobel, cap 31, as OpenCV's).
    pub prefilter: Prefilter,
    /// A pixel is invalid when the window sum of its clipped x-Sobel magnitude (cap 31, 8-bit
    /// units; times 257 for 16-bit input) is below this (OpenCV `textureThreshold`, default 10;
    /// 0 disables).
    pub texture_threshold: u32,
    /// Uniqueness margin in percent: the best cost `c*` wins only if every disparity further than
    /// one pixel from it costs more than `c* + c*·ratio/100` (OpenCV `uniquenessRatio`; default
    /// 0 = off; [`MatcherConfig::dense`] and the semi-global presets say theirs).
    pub uniqueness_ratio: u32,
    /// Left–right consistency: a pixel is kept only if the right image's own winner at the
    /// matched pixel is within this many pixels (integer disparities). `None` disables
    /// (default `Some(1)`, as SGBM's `disp12MaxDiff = 1`).
    pub lr_max_diff: Option<u32>,
    /// OpenCV SGBM's left–right rule: the check passes when it holds at either integer next to
    /// the sub-pixel disparity (`⌊d⌋` or `⌈d⌉`, each with the right image's winner at its own
    /// right pixel), not only at the winning integer. Pixels whose search range the image edge
    /// cuts keep the exact check of semi-global matching. Default `false`.
    pub lr_subpixel: bool,
    /// Semi-global matching: the right disparities the left–right check compares with are
    /// OpenCV SGBM's — at each right pixel, the winner of the left pixel with the smallest
    /// aggregated cost among those whose winner matches it — instead of the right image's own
    /// minima of the costs (`false`). Rejects occlusions, where a hidden pixel's match is taken
    /// by a visible one, and fewer correct pixels than the right image's own minima. Block
    /// matching refuses it. Default `false`; [`MatcherConfig::sgm`] sets it.
    pub lr_winners: bool,
    /// Fill pixels rejected by the left–right check or the confidence threshold (occlusions,
    /// the fattened side of depth edges) with the smaller of the nearest valid disparities left
    /// and right on the row (the background side). Filled pixels are guesses: they are counted
    /// in [`crate::MatchStats::filled`] and get confidence 0. Default `false`.
    pub fill: bool,
    /// Pixels whose confidence ([`crate::BlockMatcher::confidence`]) is below this are rejected
    /// (`0..=1`; default 0 = off). The confidence is `(1 − c*/c₂) / (1 + |d_lr − d|)`: `c*` the
    /// best cost, `c₂` the best cost further than one disparity from it, `d_lr − d` the
    /// left–right disagreement (0 or 1 with the default tolerance; the factor is 1 without the
    /// check).
    pub min_confidence: f32,
    /// Keep the per-pixel confidence map of the last frame (computed whenever
    /// `min_confidence > 0` too). Default `false` (it costs a pass over the costs per pixel).
    pub confidence_map: bool,
    /// Speckle filter: 4-connected regions of at most this many pixels are invalidated (OpenCV
    /// `speckleWindowSize`; default 100, 0 = off).
    pub speckle_window_size: usize,
    /// Two neighbours belong to one region when their disparities differ by at most this many
    /// pixels (OpenCV `speckleRange`, here in pixels, not 1/16 px; default 2.0).
    pub speckle_range: f32,
    /// Sub-pixel refinement (default `Auto`: equiangular for SAD, parabola otherwise).
    pub subpixel: Subpixel,
    /// Semi-global matching parameters (used with [`Method::Sgm`]).
    pub sgm: SgmConfig,
    /// Worker threads: 0 uses rayon's global pool, `n` builds a private pool of `n` threads once.
    pub threads: usize,
}

impl Default for MatcherConfig {
    fn default() -> Self {
        Self {
            method: Method::BlockMatching,
            cost: CostFunction::Sad,
            block_size: 9,
            min_disparity: 0,
            num_disparities: 64,
            prefilter: Prefilter::XSobel { cap: 31 },
            texture_threshold: 10,
            uniqueness_ratio: 0,
            lr_max_diff: Some(1),
            lr_subpixel: false,
            lr_winners: false,
            fill: false,
            min_confidence: 0.0,
            confidence_map: false,
            speckle_window_size: 100,
            speckle_range: 2.0,
            subpixel: Subpixel::Auto,
            sgm: SgmConfig::default(),
            threads: 0,
        }
    }
}

fn invalid(field: &'static str, value: impl ToString, reason: &'static str) -> BlockMatchingError {
    BlockMatchingError::InvalidConfig { field, value: value.to_string(), reason }
}

impl MatcherConfig {
    /// The benchmark preset for evaluations that count a missing pixel as bad: OpenCV
    /// `StereoBM`'s prefilter (x-Sobel, cap 31) and most accurate setting (uniqueness 0, no
    /// speckle filter) plus the left–right check whose rejects are filled from the background
    /// neighbour. Dense (~95–100 %), but the filled pixels are guesses: do not measure with it.
    /// Middlebury SAD 9x9 bad-2 (missing = bad) tsukuba / venus / teddy 5.90 / 5.06 / 11.08.
    pub fn dense() -> Self {
        Self {
            prefilter: Prefilter::XSobel { cap: 31 },
            uniqueness_ratio: 0,
            fill: true,
            speckle_window_size: 0,
            min_confidence: 0.0,
            ..Self::default()
        }
    }

    /// Semi-global matching for measurement (nothing filled), chosen on bad-2 with missing =
    /// bad where OpenCV's matchers also answer (`examples/middlebury_sweep.rs overlap`, figures
    /// in `benches/RESULTS.md`): three paths (OpenCV 3-way's directions), a 3x3 window of
    /// Birchfield–Tomasi's difference on the x-Sobel plane plus the intensity term (SGBM's
    /// pixel cost, see [`SgmConfig::sampling_insensitive`] and [`SgmConfig::intensity_cost`]),
    /// P1 = 20, P2 = 80 per window pixel with the intensity-adaptive P2 (γ = 48), no
    /// uniqueness margin, SGBM's left–right rule ([`MatcherConfig::lr_subpixel`] and
    /// [`MatcherConfig::lr_winners`], with 2 px of tolerance) and the speckle filter (100 px,
    /// 2 px).
    pub fn sgm() -> Self {
        Self {
            method: Method::Sgm,
            prefilter: Prefilter::XSobel { cap: 31 },
            uniqueness_ratio: 0,
            lr_subpixel: true,
            lr_winners: true,
            lr_max_diff: Some(2),
            speckle_window_size: 100,
            sgm: SgmConfig {
                paths: SgmPaths::Three,
                block: 3,
                p1: 20,
                p2: 80,
                p2_gamma: 48,
                sampling_insensitive: true,
                intensity_cost: true,
                ..SgmConfig::default()
            },
            ..Self::default()
        }
    }

    /// Semi-global matching at OpenCV SGBM's density with fewer wrong pixels: eight paths, the
    /// cost of SGBM (Birchfield–Tomasi on the x-Sobel plane plus the intensity term, see
    /// [`SgmConfig::sampling_insensitive`] and [`SgmConfig::intensity_cost`]), no uniqueness
    /// margin, SGBM's sub-pixel left–right rule ([`MatcherConfig::lr_subpixel`], 1 px) and the
    /// speckle filter (100 px). Middlebury nonocc, bad-2 among the returned pixels / density:
    /// tsukuba 2.33 % / 98.77 %, venus 0.67 % / 98.53 %, teddy 4.36 % / 95.40 % (OpenCV SGBM
    /// 3-way: 2.40 / 98.51, 0.74 / 94.89, 5.46 / 89.92; its eight-direction `MODE_HH`: 2.34 /
    /// 98.80, 0.93 / 94.86, 5.67 / 88.83). Speed on a 2-core Zen 4 against OpenCV 5.1 (2
    /// threads, interleaved): 1.1–4.0x `MODE_HH`'s, about `MODE_SGBM`'s (0.85–1.23x), half of
    /// 3-way's (eight paths take a second pass).
    pub fn sgm_accurate() -> Self {
        Self {
            method: Method::Sgm,
            prefilter: Prefilter::XSobel { cap: 31 },
            uniqueness_ratio: 0,
            lr_subpixel: true,
            speckle_window_size: 100,
            sgm: SgmConfig {
                paths: SgmPaths::Eight,
                sampling_insensitive: true,
                intensity_cost: true,
                ..SgmConfig::default()
            },
            ..Self::default()
        }
    }

    /// Semi-global matching as a benchmark preset for evaluations that count a missing pixel as
    /// bad: [`SgmConfig::default`] (five paths, 5x5 SAD on the x-Sobel plane), no uniqueness
    /// margin, no speckle filter, left–right rejects filled (`tests/middlebury.rs` holds it
    /// below OpenCV SGBM 3-way's bad-2 on the full masks).
    pub fn sgm_dense() -> Self {
        Self {
            method: Method::Sgm,
            prefilter: Prefilter::XSobel { cap: 31 },
            uniqueness_ratio: 0,
            speckle_window_size: 0,
            fill: true,
            ..Self::default()
        }
    }

    /// Whether the matcher needs the second-best non-adjacent cost of every pixel.
    pub(crate) fn needs_confidence(&self) -> bool {
        self.confidence_map || self.min_confidence > 0.0
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
        if !(0.0..=1.0).contains(&self.min_confidence) {
            return Err(invalid("min_confidence", self.min_confidence, "must be in 0..=1"));
        }
        if self.method == Method::Sgm {
            if self.cost != CostFunction::Sad {
                return Err(invalid("cost", format!("{:?}", self.cost), "semi-global matching supports SAD only"));
            }
            let g = &self.sgm;
            if g.block.is_multiple_of(2) || !(1..=11).contains(&g.block) {
                return Err(invalid("sgm.block", g.block, "must be odd, 1..=11"));
            }
            if g.p1 == 0 || g.p2 < g.p1 || g.p2 > 4096 {
                return Err(invalid("sgm.p2", format!("p1 {} p2 {}", g.p1, g.p2), "need 1 ≤ p1 ≤ p2 ≤ 4096"));
            }
            if g.overlap > 4096 {
                return Err(invalid("sgm.overlap", g.overlap, "must be 0..=4096"));
            }
            if g.p2_gamma > 4096 {
                return Err(invalid("sgm.p2_gamma", g.p2_gamma, "must be 0..=4096"));
            }
        }
        if self.lr_winners && self.method != Method::Sgm {
            return Err(invalid(
                "lr_winners",
                true,
                "the left winners' right disparities are semi-global matching's (block matching checks against the right image's own winners)",
            ));
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
