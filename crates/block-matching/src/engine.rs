//! The fast matcher: running box sums over disparity-major column sums, kept per row band in
//! cache, with winner-take-all, uniqueness, sub-pixel and left–right decisions fused per row.

use image::{GrayImage, ImageBuffer, Luma};
use parallax_camera_model::DisparityMap;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::config::{CostFunction, MatcherConfig, Method, Prefilter, Subpixel};
use crate::error::{BlockMatchingError, Result};
use crate::prefilter::{
    TextureRows, TextureSource, box_sum, normalized_response, rank_transform_into, x_sobel_into, x_sobel_u8_into,
};
use crate::speckle::filter_speckles;
use parallax_simd::{Avx2, Avx512};

/// A 16-bit grayscale image (`image` crate buffer).
pub type Gray16Image = ImageBuffer<Luma<u16>, Vec<u16>>;

/// Which instruction set the inner loops run (`parallax_simd`'s level, detected once per
/// process). At [`SimdLevel::Avx512`] block matching's 16-bit kernel (SAD whose window sums fit
/// in 16 bits: the x-Sobel and rank prefilters) has a copy compiled for AVX-512 F/BW/VL: the same
/// 256-bit operations and results, with 32 vector registers instead of 16, so that up to 16
/// chunks of running box sums stay in registers from column to column (8 with AVX2); every other
/// kernel runs its AVX2 code there.
pub use parallax_simd::SimdLevel;

/// Why pixels of the last frame have no disparity, and the resulting density.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct MatchStats {
    /// Pixels in the map.
    pub pixels: usize,
    /// Pixels with a disparity.
    pub valid: usize,
    /// No candidate disparity puts the matching pixel inside the right image.
    pub no_candidate: usize,
    /// Rejected by the texture threshold.
    pub low_texture: usize,
    /// Rejected by the uniqueness ratio.
    pub not_unique: usize,
    /// Rejected by the left–right check (including those filled afterwards).
    pub lr_inconsistent: usize,
    /// Rejected by the confidence threshold (`min_confidence`; including those filled
    /// afterwards).
    pub low_confidence: usize,
    /// Left–right and confidence rejects filled from their background neighbour (`fill`);
    /// counted as valid.
    pub filled: usize,
    /// Removed by the speckle filter.
    pub speckle: usize,
    /// `valid / pixels` in `[0, 1]`.
    pub density: f64,
}

impl MatchStats {
    fn add(&mut self, o: &MatchStats) {
        self.valid += o.valid;
        self.no_candidate += o.no_candidate;
        self.low_texture += o.low_texture;
        self.not_unique += o.not_unique;
        self.lr_inconsistent += o.lr_inconsistent;
        self.low_confidence += o.low_confidence;
        self.filled += o.filled;
    }

    /// `n` pixels in percent of the map.
    pub fn percent(&self, n: usize) -> f64 {
        if self.pixels == 0 { 0.0 } else { 100.0 * n as f64 / self.pixels as f64 }
    }
}

/// The cost-curve part of the confidence: `1 − c*/c₂` in `[0, 1]` from the best cost `c*` and
/// the best cost `c₂` further than one disparity from the winner (`None` when no such
/// candidate exists, which gives 0: nothing to compare with). One f64 division, rounded once
/// to f32 (the naive reference in the tests uses the same expression).
#[inline(always)]
pub(crate) fn curve_ratio(c1: f64, c2: Option<f64>) -> f32 {
    match c2 {
        Some(c2) if c2 > 0.0 => (1.0 - c1 / c2).clamp(0.0, 1.0) as f32,
        _ => 0.0,
    }
}

/// Accumulator of the exact integer window sums.
pub(crate) trait Acc: Cost + Ord + Default {
    fn from_u32(v: u32) -> Self;
    fn wadd(self, o: Self) -> Self;
    fn wsub(self, o: Self) -> Self;
}

impl Acc for u32 {
    #[inline(always)]
    fn from_u32(v: u32) -> Self {
        v
    }
    #[inline(always)]
    fn wadd(self, o: Self) -> Self {
        self.wrapping_add(o)
    }
    #[inline(always)]
    fn wsub(self, o: Self) -> Self {
        self.wrapping_sub(o)
    }
}

impl Acc for u64 {
    #[inline(always)]
    fn from_u32(v: u32) -> Self {
        v as u64
    }
    #[inline(always)]
    fn wadd(self, o: Self) -> Self {
        self.wrapping_add(o)
    }
    #[inline(always)]
    fn wsub(self, o: Self) -> Self {
        self.wrapping_sub(o)
    }
}

/// A cost compared by the decisions: the integer sums themselves or NCC's `1 − ncc`.
pub(crate) trait Cost: Copy + PartialOrd + Send + Sync + 'static {
    const MAX: Self;
    fn min2(self, o: Self) -> Self;
    /// OpenCV's uniqueness threshold `c + c·ratio/100` (integer division for integer costs).
    fn uniq_thresh(self, ratio: u32) -> Self;
    fn to_f64(self) -> f64;
}

/// The integer costs: OpenCV's uniqueness threshold with integer division, saturated, in the
/// narrowest integer that holds `c · ratio` for a validated `ratio ≤ 1000` (the 64-bit products
/// of 16-bit costs had cost ~8 scalar multiplies per 8 pixels in the vector kernels' decisions,
/// callgrind; in the next wider type the compiler vectorises them).
macro_rules! integer_cost {
    ($($t:ty => $wide:ty),*) => {$(
        impl Cost for $t {
            const MAX: Self = <$t>::MAX;
            #[inline(always)]
            fn min2(self, o: Self) -> Self {
                self.min(o)
            }
            #[inline(always)]
            fn uniq_thresh(self, ratio: u32) -> Self {
                let (c, ratio) = (self as $wide, ratio.min(1000) as $wide);
                (c + c * ratio / 100).min(<$t>::MAX as $wide) as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
    )*};
}
integer_cost!(u16 => u32, u32 => u64, u64 => u128);

impl Cost for f64 {
    const MAX: Self = f64::INFINITY;
    #[inline(always)]
    fn min2(self, o: Self) -> Self {
        if o < self { o } else { self }
    }
    #[inline(always)]
    fn uniq_thresh(self, ratio: u32) -> Self {
        self + self * ratio as f64 / 100.0
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}

const K_SAD: u8 = 0;
const K_SSD: u8 = 1;
const K_NCC: u8 = 2;

/// Per-pixel term of the window sum: |a−b|, (a−b)² or a·b (all fit in u32 for u16 inputs).
#[inline(always)]
fn pixel_term<const K: u8>(a: u16, b: u16) -> u32 {
    let (a, b) = (a as i32, b as i32);
    match K {
        K_SAD => (a - b).unsigned_abs(),
        K_SSD => {
            let d = (a - b).unsigned_abs();
            d.wrapping_mul(d)
        }
        _ => (a as u32).wrapping_mul(b as u32),
    }
}

/// NCC cost `1 − ncc` from exact integer sums; `num = n·ΣLR − ΣL·ΣR` is exact in f64 for every
/// supported input (all products stay below 2^53). `inv_l`, `inv_r` are `1/sqrt(n·ΣX² − (ΣX)²)`
/// (0 for a flat window).
#[inline(always)]
pub(crate) fn ncc_cost(n: f64, slr: f64, sl: f64, sr: f64, inv_l: f64, inv_r: f64) -> f64 {
    1.0 - (n * slr - sl * sr) * inv_l * inv_r
}

/// `1/sqrt(n·Σx² − (Σx)²)` from exact integer sums, 0 for a flat window.
pub(crate) fn inv_std(n: u64, s: u64, ss: u64) -> f64 {
    let den = n * ss - s * s;
    if den == 0 { 0.0 } else { 1.0 / (den as f64).sqrt() }
}

/// Per-pixel window statistics of NCC (whole image, clamp-to-edge windows).
#[derive(Default)]
struct NccPlanes {
    sl: Vec<f64>,
    inv_l: Vec<f64>,
    sr: Vec<f64>,
    inv_r: Vec<f64>,
}

/// Read-only inputs shared by all bands.
pub(crate) struct Shared<'a> {
    pub(crate) w: usize,
    pub(crate) h: usize,
    pub(crate) r: usize,
    pub(crate) nd: usize,
    pub(crate) dmin: i64,
    pub(crate) left: &'a [u16],
    pub(crate) right: &'a [u16],
    /// The texture measure's input, when it is on (each band computes its own rows).
    pub(crate) texture: Option<TextureSource<'a>>,
    ncc: &'a NccPlanes,
    n: f64,
    pub(crate) uniq: u32,
    pub(crate) lr: Option<u32>,
    /// Left–right tolerance 0 where the image edge cuts a pixel's search range (semi-global
    /// matching: see [`finish_row`]).
    pub(crate) exact_lr_at_edges: bool,
    /// [`MatcherConfig::lr_subpixel`].
    pub(crate) lr_subpixel: bool,
    /// Uniqueness margin (percent) required where the image edge cuts a pixel's search range
    /// (semi-global matching: [`crate::sgm::EDGE_UNIQUENESS`]; 0 = the configured one only).
    pub(crate) edge_uniq: u32,
    pub(crate) fill: bool,
    /// Compute the confidence (second-best non-adjacent cost) of every pixel.
    pub(crate) conf: bool,
    pub(crate) min_conf: f32,
    pub(crate) subpixel: Subpixel,
    /// Every matched (prefiltered) pixel is below 128: the vector SAD kernels may take the
    /// column-sum update's differences on bytes (see `simd::Scratch::pairs`).
    pub(crate) small_px: bool,
}

/// Buffers of one row band, reused across frames.
#[derive(Default)]
struct Scratch<A> {
    colsum: Vec<A>,
    boxs: Vec<A>,
    costf: Vec<f64>,
    l_in: Vec<u16>,
    l_out: Vec<u16>,
    r_in: Vec<u16>,
    r_out: Vec<u16>,
    rc: Vec<A>,
    rcf: Vec<f64>,
    rk: Vec<u32>,
    /// The right winners at each pixel's match ([`finish_row`]).
    rw: Vec<u32>,
    best: Vec<i32>,
    sub: Vec<f32>,
    ratio: Vec<f32>,
    sr_rev: Vec<f64>,
    ir_rev: Vec<f64>,
    texture: TextureRows,
}

impl<A: Acc> Scratch<A> {
    fn resize(&mut self, w: usize, r: usize, nd: usize) {
        let wp = w + 2 * r;
        self.colsum.resize(wp * nd, A::default());
        self.boxs.resize(nd, A::default());
        self.costf.resize(nd, 0.0);
        self.l_in.resize(wp, 0);
        self.l_out.resize(wp, 0);
        self.r_in.resize(wp + nd - 1, 0);
        self.r_out.resize(wp + nd - 1, 0);
        self.rc.resize(w, A::MAX);
        self.rcf.resize(w, f64::INFINITY);
        self.rk.resize(w, u32::MAX);
        self.rw.resize(w, 0);
        self.best.resize(w, -1);
        self.sub.resize(w, 0.0);
        self.ratio.resize(w, 0.0);
        self.sr_rev.resize(w, 0.0);
        self.ir_rev.resize(w, 0.0);
    }
}

/// Dense block matcher for rectified pairs. Build it once; every [`BlockMatcher::compute`] call
/// reuses its buffers (and its thread pool when `threads > 0`).
///
/// Window semantics (the naive reference in the tests uses the same): both images are extended
/// by clamp-to-edge, every window is the full `block x block`, and a candidate disparity `d` is
/// searched at column `x` only when the matching column `x − d` lies inside the right image, so
/// the left border gets the partial range that fits instead of OpenCV's empty band.
pub struct BlockMatcher {
    config: MatcherConfig,
    pool: Option<rayon::ThreadPool>,
    simd: SimdLevel,
    left: Vec<u16>,
    right: Vec<u16>,
    pre_left: Vec<u16>,
    pre_right: Vec<u16>,
    sobel: Vec<u16>,
    /// Frames computed, which tells the bands' texture rows one frame from the next.
    frame: u64,
    confidence: Vec<f32>,
    ncc: NccPlanes,
    scratch32: Vec<Scratch<u32>>,
    scratch64: Vec<Scratch<u64>>,
    #[cfg(target_arch = "x86_64")]
    simd16: Vec<crate::simd::Scratch<u16>>,
    #[cfg(target_arch = "x86_64")]
    simd32: Vec<crate::simd::Scratch<u32>>,
    sgm: Vec<crate::sgm::Scratch>,
    sgm_planes: crate::sgm::SgmPlanes,
    stats: MatchStats,
}

impl BlockMatcher {
    /// Validates `config` and builds the matcher (and its private thread pool when
    /// `config.threads > 0`).
    pub fn new(config: MatcherConfig) -> Result<Self> {
        config.validate()?;
        let pool = if config.threads > 0 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(config.threads)
                    .build()
                    .map_err(|e| BlockMatchingError::ThreadPool { threads: config.threads, reason: e.to_string() })?,
            )
        } else {
            None
        };
        Ok(Self {
            config,
            pool,
            simd: SimdLevel::detect(),
            left: Vec::new(),
            right: Vec::new(),
            pre_left: Vec::new(),
            pre_right: Vec::new(),
            sobel: Vec::new(),
            frame: 0,
            confidence: Vec::new(),
            ncc: NccPlanes::default(),
            scratch32: Vec::new(),
            scratch64: Vec::new(),
            #[cfg(target_arch = "x86_64")]
            simd16: Vec::new(),
            #[cfg(target_arch = "x86_64")]
            simd32: Vec::new(),
            sgm: Vec::new(),
            sgm_planes: Default::default(),
            stats: MatchStats::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &MatcherConfig {
        &self.config
    }

    /// The instruction set in use.
    pub fn simd(&self) -> SimdLevel {
        self.simd
    }

    /// Restricts the instruction set (never above what the CPU supports); returns the level in
    /// use. Results are identical at every level; this exists for tests and benchmarks.
    pub fn set_simd(&mut self, level: SimdLevel) -> SimdLevel {
        self.simd = level.min(SimdLevel::detect());
        self.simd
    }

    /// Rejection counts and density of the last computed frame.
    pub fn last_stats(&self) -> MatchStats {
        self.stats
    }

    /// The per-pixel confidence of the last frame (row-major, `0..=1`, 0 where the map is
    /// invalid or filled), when `confidence_map` or `min_confidence` is set; `None` otherwise.
    /// See [`MatcherConfig::min_confidence`] for the formula.
    pub fn confidence(&self) -> Option<&[f32]> {
        self.config.needs_confidence().then_some(&self.confidence[..])
    }

    /// Disparity of the left image of a rectified 8-bit pair.
    pub fn compute(&mut self, left: &GrayImage, right: &GrayImage) -> Result<DisparityMap> {
        let mut out = DisparityMap::new_invalid(0, 0);
        self.compute_into(left, right, &mut out)?;
        Ok(out)
    }

    /// As [`BlockMatcher::compute`], writing into `out` (resized as needed) to avoid allocating.
    pub fn compute_into(&mut self, left: &GrayImage, right: &GrayImage, out: &mut DisparityMap) -> Result<()> {
        let (w, h) = check_pair(left.width(), left.height(), right.width(), right.height())?;
        self.run(w, h, Input::U8(left.as_raw(), right.as_raw()), out)
    }

    /// Disparity of the left image of a rectified 16-bit pair.
    pub fn compute_u16(&mut self, left: &Gray16Image, right: &Gray16Image) -> Result<DisparityMap> {
        let mut out = DisparityMap::new_invalid(0, 0);
        self.compute_u16_into(left, right, &mut out)?;
        Ok(out)
    }

    /// As [`BlockMatcher::compute_u16`], writing into `out` (resized as needed).
    pub fn compute_u16_into(&mut self, left: &Gray16Image, right: &Gray16Image, out: &mut DisparityMap) -> Result<()> {
        let (w, h) = check_pair(left.width(), left.height(), right.width(), right.height())?;
        self.run(w, h, Input::U16(left.as_raw(), right.as_raw()), out)
    }

    fn run(&mut self, w: usize, h: usize, input: Input, out: &mut DisparityMap) -> Result<()> {
        // everything parallel (conversion, prefilters, texture, bands) runs on the matcher's own
        // pool if any
        let pool = self.pool.take();
        let res = match &pool {
            Some(p) => p.install(|| self.run_in_pool(w, h, input, out)),
            None => self.run_in_pool(w, h, input, out),
        };
        self.pool = pool;
        res
    }

    fn run_in_pool(&mut self, w: usize, h: usize, input: Input, out: &mut DisparityMap) -> Result<()> {
        let scale: u32 = match input {
            Input::U8(..) => 1,
            Input::U16(..) => 257,
        };
        let cfg = self.config.clone();
        let r = cfg.block_size / 2;
        let use_texture = cfg.texture_threshold > 0;
        // texture from the clipped x-Sobel magnitude of the raw left image (OpenCV's measure);
        // with the default prefilter this is also the prefiltered left image. Each side widens
        // its 8-bit input into the matcher's buffer when the raw planes are read (16-bit input
        // is used as given) and takes its Sobel from the input itself (8-bit in 16-bit lanes);
        // the two sides run side by side (the widening as a step of its own, before them, was
        // ~2 % of a teddy frame on 2 threads); the measure itself is taken by the bands.
        let sobel_is_prefilter = cfg.prefilter == Prefilter::XSobel { cap: 31 };
        let (pre_left, pre_right, sobel) = (&mut self.pre_left, &mut self.pre_right, &mut self.sobel);
        let (buf_left, buf_right) = (&mut self.left, &mut self.right);
        let tcap = 31 * scale;
        // block matching on the x-Sobel reads only the Sobel planes: no widening there (~1.5 %
        // of a teddy frame's samples)
        let need_raw = cfg.method == Method::Sgm || !matches!(cfg.prefilter, Prefilter::XSobel { .. });
        // side `i` (0 left, 1 right), widened into `buf` when needed
        let widen = |i: usize, buf: &mut Vec<u16>| {
            let px = input.side(i);
            if need_raw && let Pixels::U8(p) = px {
                to_u16(p, buf);
            }
            px
        };
        let left_side = || {
            let px = widen(0, buf_left);
            if use_texture {
                px.x_sobel_into(w, h, tcap, if sobel_is_prefilter { &mut *pre_left } else { &mut *sobel });
            }
            if let Prefilter::XSobel { cap } = cfg.prefilter
                && !(use_texture && sobel_is_prefilter)
            {
                px.x_sobel_into(w, h, cap as u32 * scale, pre_left);
            }
        };
        let right_side = || {
            let px = widen(1, buf_right);
            if let Prefilter::XSobel { cap } = cfg.prefilter {
                px.x_sobel_into(w, h, cap as u32 * scale, pre_right);
            }
        };
        rayon::join(left_side, right_side);
        // (empty where nothing reads them)
        let (raw_left, raw_right): (&[u16], &[u16]) = match input {
            _ if !need_raw => (&[], &[]),
            Input::U8(..) => (&self.left, &self.right),
            Input::U16(l, r) => (l, r),
        };
        match cfg.prefilter {
            Prefilter::None | Prefilter::XSobel { .. } => {}
            Prefilter::Rank { size } => {
                let (pre_left, pre_right) = (&mut self.pre_left, &mut self.pre_right);
                rayon::join(
                    || rank_transform_into(raw_left, w, h, size, pre_left),
                    || rank_transform_into(raw_right, w, h, size, pre_right),
                );
            }
            Prefilter::NormalizedResponse { size, cap } => {
                self.pre_left = normalized_response(raw_left, w, h, size, cap as u32 * scale);
                self.pre_right = normalized_response(raw_right, w, h, size, cap as u32 * scale);
            }
        }
        let (left, right) = match cfg.prefilter {
            Prefilter::None => (raw_left, raw_right),
            _ => (&self.pre_left[..], &self.pre_right[..]),
        };
        let n = (cfg.block_size * cfg.block_size) as u64;
        if cfg.cost == CostFunction::Ncc {
            let stats = |img: &[u16]| {
                let s = box_sum(img, w, h, r, |v| v as u64);
                let ss = box_sum(img, w, h, r, |v| v as u64 * v as u64);
                let inv: Vec<f64> = s.iter().zip(&ss).map(|(&s, &ss)| inv_std(n, s, ss)).collect();
                (s.into_iter().map(|v| v as f64).collect::<Vec<f64>>(), inv)
            };
            (self.ncc.sl, self.ncc.inv_l) = stats(left);
            (self.ncc.sr, self.ncc.inv_r) = stats(right);
        }
        let maxv = match cfg.prefilter {
            // the prefilters' output range
            Prefilter::XSobel { cap } | Prefilter::NormalizedResponse { cap, .. } => 2 * cap as u64 * scale as u64,
            Prefilter::Rank { size } => (size * size - 1) as u64,
            Prefilter::None => left.iter().chain(right).copied().max().unwrap_or(0) as u64,
        };
        let max_term = if cfg.cost == CostFunction::Sad { maxv } else { maxv * maxv };
        let wide = n * max_term > u32::MAX as u64;

        if out.width() != w || out.height() != h || out.data().len() != w * h {
            *out = DisparityMap::new_invalid(w, h);
        }
        let threads = rayon::current_num_threads();
        let sgm = cfg.method == Method::Sgm;
        let band_rows = if sgm {
            crate::sgm::strip_rows(&cfg.sgm, w, h, cfg.num_disparities)
        } else {
            // one band per thread: each band re-adds `block` rows before its first, and its
            // buffers are a thread's own; two per thread measured 0.87x the speed on
            // 626x555x96 and the same on 1282x1110x224 (`benches/benches/ceiling.rs`, three
            // interleaved runs of 5 rounds, 2 threads). Bands never change the map.
            let nbands = threads.min(h.div_ceil((4 * cfg.block_size).max(16))).max(1);
            h.div_ceil(nbands)
        };
        let nbands = h.div_ceil(band_rows);
        self.frame = self.frame.wrapping_add(1);
        // the texture measure runs inside the bands, each on its own rows (see `TextureRows`)
        let texture = use_texture.then(|| TextureSource {
            sobel: if sobel_is_prefilter { &self.pre_left[..] } else { &self.sobel[..] },
            w,
            h,
            r,
            cap: tcap,
            threshold: cfg.texture_threshold * scale,
            frame: self.frame,
        });
        let shared = Shared {
            w,
            h,
            // semi-global matching sums its pixel cost over its own (small) window
            r: if sgm { cfg.sgm.block / 2 } else { r },
            nd: cfg.num_disparities,
            dmin: cfg.min_disparity as i64,
            left,
            right,
            texture,
            ncc: &self.ncc,
            n: n as f64,
            uniq: cfg.uniqueness_ratio,
            lr: cfg.lr_max_diff,
            exact_lr_at_edges: sgm,
            lr_subpixel: cfg.lr_subpixel,
            // not in a filled (benchmark) map: there every pixel is returned, guesses included
            edge_uniq: if sgm && !cfg.fill { crate::sgm::EDGE_UNIQUENESS } else { 0 },
            fill: cfg.fill,
            conf: cfg.needs_confidence(),
            min_conf: cfg.min_confidence,
            subpixel: match (sgm, cfg.subpixel) {
                // aggregated costs are smooth: a parabola fits them (as OpenCV's SGBM)
                (true, Subpixel::Auto) => Subpixel::Parabola,
                _ => cfg.effective_subpixel(),
            },
            small_px: maxv < 128,
        };
        let conf_plane: &mut [f32] = if shared.conf {
            self.confidence.resize(w * h, 0.0);
            &mut self.confidence
        } else {
            &mut []
        };
        let simd = self.simd;
        let data = out.data_mut();
        let mut stats = MatchStats::default();
        if sgm {
            let (intensity, iscale) = (raw_left, scale);
            self.sgm_planes.prepare(&cfg.sgm, [left, right], [raw_left, raw_right], scale, w, h);
            let pp = crate::sgm::SgmParams::new(&cfg.sgm, maxv, intensity, iscale, &self.sgm_planes)?;
            let per_band =
                for_each_band(&shared, &mut self.sgm, nbands, band_rows, data, conf_plane, |sc, rows, conf, y0, y1| {
                    crate::sgm::run_strip(&shared, &pp, sc, rows, conf, y0, y1, simd)
                });
            for s in &per_band {
                stats.add(s);
            }
            self.finish_stats(out, stats);
            return Ok(());
        }
        // the vectorised kernels: 16-bit lanes when every SAD window sum is ≤ 65534, 32-bit lanes
        // when every SAD / SSD window sum is ≤ 2^32 − 2 (the lane maximum is the "no candidate"
        // sentinel)
        #[cfg(target_arch = "x86_64")]
        let kernel = {
            let fits = |limit: u64| n.checked_mul(max_term).is_some_and(|s| s < limit);
            let wide = Avx512::at_most(simd);
            match (Avx2::at_most(simd), cfg.cost) {
                (Some(t), CostFunction::Sad) if fits(u16::MAX as u64) => Some(SimdKernel::Lanes16 { t, wide }),
                (Some(t), CostFunction::Sad) if fits(u32::MAX as u64) => {
                    Some(SimdKernel::Lanes32 { t, squared: false })
                }
                (Some(t), CostFunction::Ssd) if fits(u32::MAX as u64) => Some(SimdKernel::Lanes32 { t, squared: true }),
                _ => None,
            }
        };
        let mut job = || -> Vec<MatchStats> {
            // (each kernel chosen above only when every window sum fits below the lane maximum)
            #[cfg(target_arch = "x86_64")]
            match kernel {
                Some(SimdKernel::Lanes16 { t, wide }) => {
                    return for_each_band(
                        &shared,
                        &mut self.simd16,
                        nbands,
                        band_rows,
                        data,
                        conf_plane,
                        |sc, rows, conf, y0, y1| crate::simd::band16(t, wide, &shared, sc, rows, conf, y0, y1),
                    );
                }
                Some(SimdKernel::Lanes32 { t, squared }) => {
                    return for_each_band(
                        &shared,
                        &mut self.simd32,
                        nbands,
                        band_rows,
                        data,
                        conf_plane,
                        |sc, rows, conf, y0, y1| crate::simd::band32(t, squared, &shared, sc, rows, conf, y0, y1),
                    );
                }
                None => {}
            }
            if wide {
                run_bands::<u64>(&shared, &mut self.scratch64, nbands, band_rows, data, conf_plane, cfg.cost, simd)
            } else {
                run_bands::<u32>(&shared, &mut self.scratch32, nbands, band_rows, data, conf_plane, cfg.cost, simd)
            }
        };
        let per_band = job();
        for s in &per_band {
            stats.add(s);
        }
        self.finish_stats(out, stats);
        Ok(())
    }

    /// Speckle filter, confidence of the removed speckles, density.
    fn finish_stats(&mut self, out: &mut DisparityMap, mut stats: MatchStats) {
        let cfg = &self.config;
        let (w, h) = (out.width(), out.height());
        if cfg.speckle_window_size > 0 {
            stats.speckle = filter_speckles(out, cfg.speckle_window_size, cfg.speckle_range);
            if cfg.needs_confidence() {
                // the speckles' confidence goes with their disparity
                for (c, d) in self.confidence.iter_mut().zip(out.data()) {
                    if !d.is_finite() {
                        *c = 0.0;
                    }
                }
            }
        }
        stats.pixels = w * h;
        if stats.speckle > 0 {
            // as `DisparityMap::valid_count`, in parallel (the bands counted before the filter)
            stats.valid = out.data().par_chunks(1 << 14).map(count_finite).sum();
        }
        stats.density = if w * h == 0 { 0.0 } else { stats.valid as f64 / (w * h) as f64 };
        self.stats = stats;
    }
}

/// One side's pixels.
#[derive(Clone, Copy)]
enum Pixels<'a> {
    U8(&'a [u8]),
    U16(&'a [u16]),
}

impl Pixels<'_> {
    /// The x-Sobel at `cap` into `out` (8-bit pixels summed in 16-bit lanes).
    fn x_sobel_into(self, w: usize, h: usize, cap: u32, out: &mut Vec<u16>) {
        match self {
            Pixels::U8(p) => x_sobel_u8_into(p, w, h, cap, out),
            Pixels::U16(p) => x_sobel_into(p, w, h, cap, out),
        }
    }
}

/// The input pair of one frame, before conversion to the matcher's `u16` planes.
#[derive(Clone, Copy)]
enum Input<'a> {
    U8(&'a [u8], &'a [u8]),
    U16(&'a [u16], &'a [u16]),
}

impl<'a> Input<'a> {
    /// The left (0) or right (1) image.
    fn side(self, i: usize) -> Pixels<'a> {
        match self {
            Input::U8(l, r) => Pixels::U8(if i == 0 { l } else { r }),
            Input::U16(l, r) => Pixels::U16(if i == 0 { l } else { r }),
        }
    }
}

/// The finite values of `v` (as `DisparityMap::valid_count`), summed in `u32` lanes a block at a
/// time (twice as many a vector as a `usize` count's).
fn count_finite(v: &[f32]) -> usize {
    v.chunks(1 << 16).map(|c| c.iter().map(|d| d.is_finite() as u32).sum::<u32>() as usize).sum()
}

/// Widens an 8-bit plane into `dst` (resized), rows in parallel.
fn to_u16(src: &[u8], dst: &mut Vec<u16>) {
    dst.resize(src.len(), 0);
    dst.par_chunks_mut(1 << 15).zip(src.par_chunks(1 << 15)).for_each(|(d, s)| {
        for (d, &s) in d.iter_mut().zip(s) {
            *d = s as u16;
        }
    });
}

pub(crate) fn check_pair(lw: u32, lh: u32, rw: u32, rh: u32) -> Result<(usize, usize)> {
    if lw == 0 || lh == 0 {
        return Err(BlockMatchingError::EmptyImage { what: "left image", width: lw as usize, height: lh as usize });
    }
    if (lw, lh) != (rw, rh) {
        return Err(BlockMatchingError::SizeMismatch {
            what: "right image",
            width: lw as usize,
            height: lh as usize,
            got_width: rw as usize,
            got_height: rh as usize,
        });
    }
    Ok((lw as usize, lh as usize))
}

/// Runs `band(scratch, rows, conf_rows, y0, y1)` on every row band in parallel, each with its
/// own scratch (grown to `nbands` entries and kept for the next frame); returns the per-band
/// statistics, each with the band's valid pixels. `conf` is the confidence plane (`w · h`) or
/// empty, and so are its band rows.
pub(crate) fn for_each_band<S: Default + Send>(
    sh: &Shared,
    scratch: &mut Vec<S>,
    nbands: usize,
    band_rows: usize,
    data: &mut [f32],
    conf: &mut [f32],
    band: impl Fn(&mut S, &mut [f32], &mut [f32], usize, usize) -> MatchStats + Sync,
) -> Vec<MatchStats> {
    if scratch.len() < nbands {
        scratch.resize_with(nbands, S::default);
    }
    let conf_rows: Vec<&mut [f32]> = if conf.is_empty() {
        (0..nbands).map(|_| <&mut [f32]>::default()).collect()
    } else {
        conf.chunks_mut(band_rows * sh.w).collect()
    };
    data.par_chunks_mut(band_rows * sh.w)
        .zip(scratch.par_iter_mut())
        .zip(conf_rows.into_par_iter())
        .enumerate()
        .map(|(b, ((rows, sc), conf))| {
            let y0 = b * band_rows;
            let mut st = band(sc, rows, conf, y0, (y0 + band_rows).min(sh.h));
            // the band's valid pixels, while its rows are in its core's cache (a parallel
            // count of its own after the bands was ~2 % of a teddy frame on 2 threads)
            st.valid = count_finite(rows);
            st
        })
        .collect()
}

/// The confidence row of `y` inside a band's confidence rows (empty when off).
#[inline(always)]
pub(crate) fn conf_row<'a>(sh: &Shared, conf: &'a mut [f32], y: usize, y0: usize) -> &'a mut [f32] {
    if sh.conf { &mut conf[(y - y0) * sh.w..][..sh.w] } else { &mut [] }
}

/// Which vectorised kernel runs a frame.
#[cfg(target_arch = "x86_64")]
#[derive(Debug, Clone, Copy)]
enum SimdKernel {
    /// 16-bit lanes, with AVX-512's 32 registers when `wide`.
    Lanes16 {
        t: Avx2,
        wide: Option<Avx512>,
    },
    Lanes32 {
        t: Avx2,
        squared: bool,
    },
}

fn run_bands<A: Acc>(
    sh: &Shared,
    scratch: &mut Vec<Scratch<A>>,
    nbands: usize,
    band_rows: usize,
    data: &mut [f32],
    conf: &mut [f32],
    cost: CostFunction,
    simd: SimdLevel,
) -> Vec<MatchStats> {
    for_each_band(sh, scratch, nbands, band_rows, data, conf, |sc, rows, conf, y0, y1| {
        sc.resize(sh.w, sh.r, sh.nd);
        match cost {
            CostFunction::Sad => dispatch::<A, K_SAD>(sh, sc, rows, conf, y0, y1, simd),
            CostFunction::Ssd => dispatch::<A, K_SSD>(sh, sc, rows, conf, y0, y1, simd),
            CostFunction::Ncc => dispatch::<A, K_NCC>(sh, sc, rows, conf, y0, y1, simd),
        }
    })
}

fn dispatch<A: Acc, const K: u8>(
    sh: &Shared,
    sc: &mut Scratch<A>,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
    simd: SimdLevel,
) -> MatchStats {
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = Avx2::at_most(simd) {
        // SAFETY: the token `t` proves AVX2, FMA, BMI1/2, LZCNT and POPCNT.
        return unsafe { band_avx2::<A, K>(t, sh, sc, out, conf, y0, y1) };
    }
    band::<A, K>(sh, sc, out, conf, y0, y1)
}

/// [`band`] compiled for AVX2 (the token proves the CPU runs it).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
fn band_avx2<A: Acc, const K: u8>(
    _t: Avx2,
    sh: &Shared,
    sc: &mut Scratch<A>,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
) -> MatchStats {
    band::<A, K>(sh, sc, out, conf, y0, y1)
}

/// Fills `l` with left row `y` extended by `r` clamped columns each side, and `rrev` with the
/// right row reversed and extended so that `rrev[(wp − 1 − xp) + k]` is the right pixel matched
/// with padded left column `xp` at candidate `k`.
#[inline(always)]
pub(crate) fn load_rows(sh: &Shared, y: usize, l: &mut [u16], rrev: &mut [u16]) {
    load_plane_rows(sh, sh.left, sh.right, y, l, rrev);
}

/// [`load_rows`] from another pair of `w · h` planes (semi-global matching's interval and
/// intensity planes), with the same layout.
#[inline(always)]
pub(crate) fn load_plane_rows(sh: &Shared, left: &[u16], right: &[u16], y: usize, l: &mut [u16], rrev: &mut [u16]) {
    let (w, r) = (sh.w, sh.r);
    let lrow = &left[y * w..][..w];
    let rrow = &right[y * w..][..w];
    // l[xp] = left[clamp(xp − r)]: edge fill, copy, edge fill (l has w + 2r entries)
    l[..r].fill(lrow[0]);
    l[r..r + w].copy_from_slice(lrow);
    l[r + w..].fill(lrow[w - 1]);
    let (a, b, lo) = reversed_segments(sh, rrev.len());
    rrev[..a].fill(rrow[w - 1]);
    for (v, &s) in rrev[a..b].iter_mut().zip(rrow[lo..lo + (b - a)].iter().rev()) {
        *v = s;
    }
    rrev[b..].fill(rrow[0]);
}

/// The segments of a reversed right row of `n` entries (`load_plane_rows`): `rrev[i] =
/// right[clamp(umax − i)]` is the right edge value for `i < a`, the row reversed for `a ≤ i < b`
/// (pixels `lo + (b − a) − 1` down to `lo`), the left edge value from `b` (segment ends clamped:
/// `dmin` may be far outside).
#[inline(always)]
fn reversed_segments(sh: &Shared, n: usize) -> (usize, usize, usize) {
    let (w, r) = (sh.w, sh.r);
    let umax = w as i64 - 1 + r as i64 - sh.dmin;
    let n = n as i64;
    let a = (umax - (w as i64 - 1)).clamp(0, n);
    let b = (umax + 1).clamp(a, n);
    // i in a..b reads u = umax − i, from umax − a down to umax − b + 1 (0 when b = a)
    let lo = if b > a { umax - b + 1 } else { 0 };
    (a as usize, b as usize, lo as usize)
}

/// [`load_rows`] of the rows `yi` (entering the window) and `yo` (leaving it) at once, as byte
/// pairs (`yi`'s pixel the low byte, `yo`'s the high), for images whose pixels are all below
/// 128: `l_pairs[xp]` pairs the two left rows' padded column `xp`, `pairs[i]` the two reversed
/// right rows' entry `i`. Read from the planes directly: the rows are never widened into
/// `u16` copies and then interleaved.
#[inline(always)]
pub(crate) fn load_row_pairs(sh: &Shared, yi: usize, yo: usize, l_pairs: &mut [u16], pairs: &mut [u16]) {
    let (w, r) = (sh.w, sh.r);
    let pair = |a: u16, b: u16| a | b << 8;
    let (li, lo) = (&sh.left[yi * w..][..w], &sh.left[yo * w..][..w]);
    l_pairs[..r].fill(pair(li[0], lo[0]));
    for ((q, &a), &b) in l_pairs[r..r + w].iter_mut().zip(li).zip(lo) {
        *q = pair(a, b);
    }
    l_pairs[r + w..].fill(pair(li[w - 1], lo[w - 1]));
    let (ri, ro) = (&sh.right[yi * w..][..w], &sh.right[yo * w..][..w]);
    let (a, b, lo) = reversed_segments(sh, pairs.len());
    pairs[..a].fill(pair(ri[w - 1], ro[w - 1]));
    let n = b - a;
    for ((q, &x), &y) in pairs[a..b].iter_mut().zip(ri[lo..lo + n].iter().rev()).zip(ro[lo..lo + n].iter().rev()) {
        *q = pair(x, y);
    }
    pairs[b..].fill(pair(ri[0], ro[0]));
}

/// Adds the row held in `l_in/r_in` to the column sums (and subtracts `l_out/r_out` if `sub`).
#[inline(always)]
fn vertical<A: Acc, const K: u8>(sc: &mut Scratch<A>, nd: usize, sub: bool) {
    let wp = sc.l_in.len();
    let (colsum, l_in, r_in, l_out, r_out) = (&mut sc.colsum, &sc.l_in, &sc.r_in, &sc.l_out, &sc.r_out);
    for (xp, cs) in colsum.chunks_exact_mut(nd).enumerate().take(wp) {
        let base = wp - 1 - xp;
        let ri = &r_in[base..base + nd];
        let li = l_in[xp];
        if sub {
            let ro = &r_out[base..base + nd];
            let lo = l_out[xp];
            vert_add_sub::<A, K>(cs, ri, ro, li, lo);
        } else {
            vert_add::<A, K>(cs, ri, li);
        }
    }
}

#[inline(always)]
fn vert_add_sub<A: Acc, const K: u8>(cs: &mut [A], ri: &[u16], ro: &[u16], li: u16, lo: u16) {
    let n = cs.len().min(ri.len()).min(ro.len());
    let (cs, ri, ro) = (&mut cs[..n], &ri[..n], &ro[..n]);
    for k in 0..n {
        cs[k] = cs[k].wadd(A::from_u32(pixel_term::<K>(li, ri[k]))).wsub(A::from_u32(pixel_term::<K>(lo, ro[k])));
    }
}

#[inline(always)]
fn vert_add<A: Acc, const K: u8>(cs: &mut [A], ri: &[u16], li: u16) {
    let n = cs.len().min(ri.len());
    let (cs, ri) = (&mut cs[..n], &ri[..n]);
    for k in 0..n {
        cs[k] = cs[k].wadd(A::from_u32(pixel_term::<K>(li, ri[k])));
    }
}

/// Left winner of one pixel from its candidate costs `c[lo..=hi]`: disparity index, sub-pixel
/// offset and cost-curve confidence (0 unless asked for).
pub(crate) enum Decision {
    Best(i32, f32, f32),
    NotUnique,
}

/// The smallest cost of `c[lo..=hi]` further than one index from `kb` (`None` if there is none).
#[inline(always)]
pub(crate) fn second_cost<C: Cost>(c: &[C], lo: usize, hi: usize, kb: usize) -> Option<f64> {
    let a = c[lo..kb.saturating_sub(1).max(lo)].iter();
    let b = c.get((kb + 2).max(lo)..=hi).unwrap_or(&[]).iter();
    a.chain(b).fold(None, |m: Option<C>, &v| Some(m.map_or(v, |m| m.min2(v)))).map(C::to_f64)
}

#[inline(always)]
pub(crate) fn decide<C: Cost>(c: &[C], lo: usize, hi: usize, uniq: u32, subpixel: Subpixel, conf: bool) -> Decision {
    let s = &c[lo..=hi];
    // minimum over 8 interleaved accumulators: the order does not change a minimum of non-NaN
    // costs, and it breaks the sequential dependency (which bound NCC's f64 costs to one
    // compare per 4 cycles) so the loop vectorises
    let mut acc = [C::MAX; 8];
    let chunks = s.chunks_exact(8);
    let rest = chunks.remainder();
    for c in chunks {
        for (a, &v) in acc.iter_mut().zip(c) {
            *a = a.min2(v);
        }
    }
    let m = rest.iter().chain(&acc).fold(C::MAX, |a, &v| a.min2(v));
    let kb = lo + s.iter().zip(0u32..).map(|(&v, i)| if v == m { i } else { u32::MAX }).min().unwrap_or(0) as usize;
    if uniq > 0 && !unique(c, lo, hi, kb, uniq) {
        return Decision::NotUnique;
    }
    let ratio = if conf { curve_ratio(c[kb].to_f64(), second_cost(c, lo, hi, kb)) } else { 0.0 };
    Decision::Best(kb as i32, subpixel_offset(c, lo, hi, kb, subpixel), ratio)
}

/// OpenCV's uniqueness rule for the winner `kb` of `c[lo..=hi]`: no candidate further than one
/// disparity from it may cost at most `c[kb] + c[kb]·uniq/100`.
#[inline(always)]
pub(crate) fn unique<C: Cost>(c: &[C], lo: usize, hi: usize, kb: usize, uniq: u32) -> bool {
    let t = c[kb].uniq_thresh(uniq);
    let all: u32 = c[lo..=hi].iter().map(|&v| (v <= t) as u32).sum();
    let near: u32 = (kb.saturating_sub(1).max(lo)..=(kb + 1).min(hi)).map(|k| (c[k] <= t) as u32).sum();
    all <= near
}

/// Sub-pixel offset in `[−0.5, 0.5]` of the winner `kb` of `c[lo..=hi]` (0 at the range ends).
#[inline(always)]
pub(crate) fn subpixel_offset<C: Cost>(c: &[C], lo: usize, hi: usize, kb: usize, subpixel: Subpixel) -> f32 {
    let mut off = 0.0f64;
    if kb > lo && kb < hi && subpixel != Subpixel::None {
        let (cm, c0, cp) = (c[kb - 1].to_f64(), c[kb].to_f64(), c[kb + 1].to_f64());
        off = match subpixel {
            Subpixel::Equiangular => {
                let den = cm.max(cp) - c0;
                if den > 0.0 { (cm - cp) / (2.0 * den) } else { 0.0 }
            }
            _ => {
                let den = cm - 2.0 * c0 + cp;
                if den > 0.0 { (cm - cp) / (2.0 * den) } else { 0.0 }
            }
        };
        off = off.clamp(-0.5, 0.5);
    }
    off as f32
}

/// Keeps, per right pixel (reversed index `j`), the smallest cost and its candidate (first wins).
#[inline(always)]
pub(crate) fn right_update<C: Cost>(c: &[C], rc: &mut [C], rk: &mut [u32], lo: usize) {
    for (t, ((&v, rcv), rkv)) in c.iter().zip(rc.iter_mut()).zip(rk.iter_mut()).enumerate() {
        let better = v < *rcv;
        *rcv = if better { v } else { *rcv };
        *rkv = if better { (lo + t) as u32 } else { *rkv };
    }
}

#[inline(always)]
fn band<A: Acc, const K: u8>(
    sh: &Shared,
    sc: &mut Scratch<A>,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
) -> MatchStats {
    let (w, h, r, nd) = (sh.w, sh.h, sh.r, sh.nd);
    let clamp_y = |y: i64| y.clamp(0, h as i64 - 1) as usize;
    let mut st = MatchStats::default();
    for y in y0..y1 {
        if y == y0 {
            sc.colsum.fill(A::default());
            for j in (y0 as i64 - r as i64)..=(y0 + r) as i64 {
                load_rows(sh, clamp_y(j), &mut sc.l_in, &mut sc.r_in);
                vertical::<A, K>(sc, nd, false);
            }
        } else {
            let yi = clamp_y(y as i64 + r as i64);
            let yo = clamp_y(y as i64 - r as i64 - 1);
            if yi != yo {
                load_rows(sh, yi, &mut sc.l_in, &mut sc.r_in);
                load_rows(sh, yo, &mut sc.l_out, &mut sc.r_out);
                vertical::<A, K>(sc, nd, true);
            }
        }
        row_decisions::<A, K>(sh, sc, y, &mut out[(y - y0) * w..][..w], conf_row(sh, conf, y, y0), &mut st);
    }
    st
}

#[inline(always)]
fn row_decisions<A: Acc, const K: u8>(
    sh: &Shared,
    sc: &mut Scratch<A>,
    y: usize,
    out: &mut [f32],
    conf: &mut [f32],
    st: &mut MatchStats,
) {
    let (w, r, nd, dmin) = (sh.w, sh.r, sh.nd, sh.dmin);
    let ncc = K == K_NCC;
    let texture = sh.texture.as_ref().map(|t| sc.texture.row(t, y));
    // box sums of x = 0: padded columns 0..=2r
    sc.boxs.fill(A::default());
    for xp in 0..=2 * r {
        let cs = &sc.colsum[xp * nd..][..nd];
        for (b, &c) in sc.boxs.iter_mut().zip(cs) {
            *b = b.wadd(c);
        }
    }
    if ncc {
        sc.rcf.fill(f64::INFINITY);
        for j in 0..w {
            sc.sr_rev[j] = sh.ncc.sr[y * w + w - 1 - j];
            sc.ir_rev[j] = sh.ncc.inv_r[y * w + w - 1 - j];
        }
    } else {
        sc.rc.fill(A::MAX);
    }
    sc.rk.fill(u32::MAX);
    for x in 0..w {
        if x > 0 {
            let (a, s) = (&sc.colsum[(x + 2 * r) * nd..][..nd], &sc.colsum[(x - 1) * nd..][..nd]);
            for ((b, &ai), &si) in sc.boxs.iter_mut().zip(a).zip(s) {
                *b = b.wadd(ai).wsub(si);
            }
        }
        let xd = x as i64 - dmin;
        let lo = (xd - (w as i64 - 1)).max(0);
        let hi = xd.min(nd as i64 - 1);
        if lo > hi {
            sc.best[x] = -1;
            st.no_candidate += 1;
            continue;
        }
        let (lo, hi) = (lo as usize, hi as usize);
        // right pixels u = xd − k map to reversed index j = w − 1 − u, contiguous in k
        let j0 = (w as i64 - 1 - xd + lo as i64) as usize;
        let len = hi - lo + 1;
        let dec = if ncc {
            let (sl, il) = (sh.ncc.sl[y * w + x], sh.ncc.inv_l[y * w + x]);
            let n = sh.n;
            let srs = &sc.sr_rev[j0..][..len];
            let irs = &sc.ir_rev[j0..][..len];
            // zipped slices (no index checks) so the conversion and arithmetic vectorise
            let costs = sc.costf[lo..=hi].iter_mut().zip(&sc.boxs[lo..=hi]).zip(srs.iter().zip(irs));
            for ((cf, &b), (&sr, &ir)) in costs {
                *cf = ncc_cost(n, b.to_f64(), sl, sr, il, ir);
            }
            right_update(&sc.costf[lo..=hi], &mut sc.rcf[j0..][..len], &mut sc.rk[j0..][..len], lo);
            decide(&sc.costf, lo, hi, sh.uniq, sh.subpixel, sh.conf)
        } else {
            right_update::<A>(&sc.boxs[lo..=hi], &mut sc.rc[j0..][..len], &mut sc.rk[j0..][..len], lo);
            decide::<A>(&sc.boxs, lo, hi, sh.uniq, sh.subpixel, sh.conf)
        };
        if texture.is_some_and(|t| !t[x]) {
            sc.best[x] = -1;
            st.low_texture += 1;
            continue;
        }
        match dec {
            Decision::Best(k, off, ratio) => {
                sc.best[x] = k;
                sc.sub[x] = off;
                sc.ratio[x] = ratio;
            }
            Decision::NotUnique => {
                sc.best[x] = -1;
                st.not_unique += 1;
            }
        }
    }
    let rk = &sc.rk;
    finish_row(sh, &sc.best, &mut sc.sub, &sc.ratio, out, conf, st, &mut sc.rw, &WinnersBy(|u| rk[w - 1 - u]));
}

/// The right image's own winners of a row, as [`finish_row`]'s left–right check reads them.
pub(crate) trait RightWinners {
    /// The winner at right pixel `u` (`u < w`).
    fn at(&self, u: usize) -> u32;

    /// `rw[x] = at(clamp(x − dmin − max(best[x], 0), 0, w − 1))` for every pixel `x` of the
    /// row (`w = rw.len() = best.len()`): the winner at each pixel's match, read at a clamped
    /// position for a pixel without a winner (read and ignored).
    #[inline(always)]
    fn gather(&self, best: &[i32], dmin: i64, rw: &mut [u32]) {
        gather_from(self, best, dmin, rw, 0);
    }
}

/// [`RightWinners::gather`] lane by lane from pixel `from` on.
#[inline(always)]
pub(crate) fn gather_from<R: RightWinners + ?Sized>(right: &R, best: &[i32], dmin: i64, rw: &mut [u32], from: usize) {
    let w = rw.len() as i64;
    for (x, (r, &k)) in rw.iter_mut().zip(best).enumerate().skip(from) {
        *r = right.at((x as i64 - dmin - k.max(0) as i64).clamp(0, w - 1) as usize);
    }
}

/// A closure `u ↦ winner` as [`RightWinners`].
pub(crate) struct WinnersBy<F>(pub(crate) F);

impl<F: Fn(usize) -> u32> RightWinners for WinnersBy<F> {
    #[inline(always)]
    fn at(&self, u: usize) -> u32 {
        (self.0)(u)
    }
}

/// Writes the row's disparities from the winners `best` (−1 = none) and sub-pixel offsets `sub`,
/// applying the left–right check (`right.at(u)` is the right image's own winner at right
/// pixel `u`, `0 ≤ u < w`; `x` at candidate `k` is matched with `u = x − dmin − k`), the
/// confidence (from the cost-curve `ratio`, when `sh.conf`; written to `conf`, else empty) and
/// its threshold, and the fill of the rejects. `sub` is reused as scratch by the fill, `rw`
/// (`w` entries) by the left–right check.
#[inline(always)]
pub(crate) fn finish_row(
    sh: &Shared,
    best: &[i32],
    sub: &mut [f32],
    ratio: &[f32],
    out: &mut [f32],
    conf: &mut [f32],
    st: &mut MatchStats,
    rw: &mut [u32],
    right: &impl RightWinners,
) {
    let dmin = sh.dmin;
    if sh.lr.is_none() && !sh.conf {
        // nothing rejected here: a select the compiler vectorises (see below for the sum)
        let dm = dmin as f32;
        for ((o, &k), &s) in out.iter_mut().zip(&best[..sh.w]).zip(&sub[..sh.w]) {
            *o = if k < 0 { DisparityMap::INVALID } else { (dm + k as f32) + s };
        }
        return;
    }
    // a left–right or confidence reject is marked +inf until it is filled or invalidated.
    // Branch-free per pixel (selects and counts of booleans; which pixels are rejected is
    // data, and branches on it mispredicted): the right winner is read for every pixel, at a
    // clamped position for those without a winner (read and ignored).
    //
    // With `exact_lr_at_edges`, a pixel whose search range the image edge cuts (its true match
    // may lie outside the right image) passes the left–right check only with an exact match,
    // and not with a winner on the border column: semi-global matching's paths carry a
    // plausible disparity into the band where the match left the image. Middlebury teddy
    // (nonocc-independent: pixels with x < true disparity), pixels returned there more than
    // 2 px off, three / five / eight paths: 785 / 825 / 941 of 12107 before, 178 / 140 / 521
    // after; the band's matchable pixels kept: 10476 → 10235 (three paths); venus 341 / 455 /
    // 395 → 169 / 187 / 177 of 4055.
    if let (Some(tol), false) = (sh.lr, sh.lr_subpixel) {
        // the integer rule: the right winners gathered first, then the checks as selects over
        // the row, which the compiler vectorises (in one loop with the gather, ~92 instructions
        // a pixel of a teddy SGM frame, callgrind)
        let rw = &mut rw[..sh.w];
        right.gather(&best[..sh.w], dmin, rw);
        if sh.conf {
            lr_checks::<true>(sh, tol, best, sub, ratio, rw, out, conf, st);
        } else {
            lr_checks::<false>(sh, tol, best, sub, ratio, rw, out, conf, st);
        }
    } else {
        lr_and_confidence(sh, best, sub, ratio, out, conf, st, |u| right.at(u));
    }
    if sh.fill {
        fill_rejected(out, sub, st);
    } else {
        for v in out.iter_mut() {
            if *v == f32::INFINITY {
                *v = DisparityMap::INVALID;
            }
        }
    }
}

/// [`finish_row`]'s integer left–right check (and the confidence when `CONF`) with the right
/// winners `rw[x]` at each pixel's match gathered: the same decisions as
/// [`lr_and_confidence`], in `i32` (validated disparities are within ±2^20, images narrower
/// than 2^31, winners below 2^16 or `u32::MAX`).
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the row's inputs and outputs
fn lr_checks<const CONF: bool>(
    sh: &Shared,
    tol: u32,
    best: &[i32],
    sub: &[f32],
    ratio: &[f32],
    rw: &[u32],
    out: &mut [f32],
    conf: &mut [f32],
    st: &mut MatchStats,
) {
    let w = sh.w;
    let (dmin, wm1, nd, dm) = (sh.dmin as i32, w as i32 - 1, sh.nd as i32, sh.dmin as f32);
    let (best, sub, rw, out) = (&best[..w], &sub[..w], &rw[..w], &mut out[..w]);
    let (mut inconsistent, mut low_conf) = (0u32, 0u32);
    for x in 0..w {
        let k = best[x];
        let valid = k >= 0;
        let kk = k.max(0);
        let diff = rw[x].abs_diff(kk as u32);
        let xd = x as i32 - dmin;
        let (cut_hi, cut_lo) = (xd < nd - 1, xd - wm1 > 0);
        let edge = sh.exact_lr_at_edges & (cut_hi | cut_lo);
        let t = if edge { 0 } else { tol };
        let border = edge & ((cut_hi & (kk == xd)) | (cut_lo & (kk == xd - wm1)));
        let mut reject = valid & ((diff > t) | border);
        inconsistent += reject as u32;
        if CONF {
            let low;
            (low, conf[x]) = confidence_of(sh, valid, reject, ratio[x] * (1.0 / (1.0 + diff as f32)));
            low_conf += low as u32;
            reject |= low;
        }
        out[x] = pixel_value(valid, reject, dm, kk as f32, sub[x]);
    }
    st.lr_inconsistent += inconsistent as usize;
    st.low_confidence += low_conf as usize;
}

/// [`finish_row`]'s left–right check with any rule, and the confidence, per pixel.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the row's inputs and outputs
fn lr_and_confidence(
    sh: &Shared,
    best: &[i32],
    sub: &[f32],
    ratio: &[f32],
    out: &mut [f32],
    conf: &mut [f32],
    st: &mut MatchStats,
    right_winner: impl Fn(usize) -> u32,
) {
    let (dmin, w, dm) = (sh.dmin, sh.w as i64, sh.dmin as f32);
    let nd = sh.nd as i64;
    for x in 0..sh.w {
        let k = best[x];
        let valid = k >= 0;
        let kk = k.max(0) as i64;
        let mut reject = false;
        let mut lr_factor = 1.0f32;
        if let Some(tol) = sh.lr {
            let u = (x as i64 - dmin - kk).clamp(0, w - 1) as usize;
            let mut diff = (right_winner(u) as i64 - kk).unsigned_abs();
            // the candidates d with 0 ≤ x − dmin − d ≤ w − 1 do not cover 0..nd
            let xd = x as i64 - dmin;
            let (cut_hi, cut_lo) = (xd < nd - 1, xd - (w - 1) > 0);
            let edge = sh.exact_lr_at_edges & (cut_hi | cut_lo);
            let tol = if edge { 0 } else { tol as u64 };
            // SGBM's rule: also the integer on the other side of the sub-pixel disparity, with
            // the right image's winner at its own right pixel (not at edge-cut pixels: exact)
            if sh.lr_subpixel & !edge & valid & (diff > tol) & (sub[x] != 0.0) {
                let k2 = if sub[x] > 0.0 { kk + 1 } else { kk - 1 };
                if (0..nd).contains(&k2) {
                    let u2 = (x as i64 - dmin - k2).clamp(0, w - 1) as usize;
                    diff = diff.min((right_winner(u2) as i64 - k2).unsigned_abs());
                }
            }
            // a winner on the image's border column at such a pixel: the minimum may lie
            // beyond it
            let border = edge & ((cut_hi & (kk == xd)) | (cut_lo & (kk == xd - (w - 1))));
            let bad = valid & ((diff > tol) | border);
            st.lr_inconsistent += bad as usize;
            reject = bad;
            lr_factor = 1.0 / (1.0 + diff as f32);
        }
        if sh.conf {
            let low;
            (low, conf[x]) = confidence_of(sh, valid, reject, ratio[x] * lr_factor);
            st.low_confidence += low as usize;
            reject |= low;
        }
        out[x] = pixel_value(valid, reject, dm, kk as f32, sub[x]);
    }
}

/// The confidence threshold on a pixel's confidence `c`: whether it rejects the pixel, and the
/// value of the confidence map (0 where the pixel is not returned).
#[inline(always)]
fn confidence_of(sh: &Shared, valid: bool, reject: bool, c: f32) -> (bool, f32) {
    let low = valid & !reject & (c < sh.min_conf);
    (low, if valid & !(reject | low) { c } else { 0.0 })
}

/// A pixel's output: invalid without a winner, `+inf` when a check rejected it (filled or
/// invalidated after the row), else `dmin + k + sub`. `dmin + k` is an integer below 2^21 in
/// magnitude (|dmin| ≤ 2^20, k < 1024), exact in f32: one f32 addition rounds the sum as an f64
/// sum rounded to f32 would.
#[inline(always)]
fn pixel_value(valid: bool, reject: bool, dm: f32, k: f32, sub: f32) -> f32 {
    if !valid {
        DisparityMap::INVALID
    } else if reject {
        f32::INFINITY
    } else {
        (dm + k) + sub
    }
}

/// Fills rejected pixels (marked `+inf`; occlusions and the fattened side of depth edges) with
/// the smaller — background — of the nearest valid disparities to the left and right on the
/// same row, or invalidates them when the row has none. `tmp` is scratch of the row's length.
#[inline(always)]
pub(crate) fn fill_rejected(out: &mut [f32], tmp: &mut [f32], st: &mut MatchStats) {
    let w = out.len();
    // nearest valid value to the left of each pixel (NaN if none)
    let mut last = f32::NAN;
    for x in 0..w {
        tmp[x] = last;
        if out[x].is_finite() {
            last = out[x];
        }
    }
    let mut next = f32::NAN;
    for x in (0..w).rev() {
        if out[x] == f32::INFINITY {
            let (a, b) = (tmp[x], next);
            let v = if a.is_nan() {
                b
            } else if b.is_nan() {
                a
            } else {
                a.min(b)
            };
            out[x] = v;
            if v.is_finite() {
                st.filled += 1;
            }
        } else if out[x].is_finite() {
            next = out[x];
        }
    }
}
