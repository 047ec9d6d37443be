//! The driver: `BlockMatcher` prepares a frame (conversion, prefilter, NCC statistics), chooses
//! the kernel family (the fused vector kernels of `simd.rs`, semi-global matching in `sgm.rs` or
//! the generic band of `band.rs`), runs its row bands in parallel (`frame::for_each_band`), then
//! the frame-wide steps (speckle filter, statistics). Nothing below it imports it back.

use image::{GrayImage, RgbImage};
use parallax_camera_model::DisparityMap;
use rayon::prelude::*;

use crate::band::{Scratch, inv_std, run_bands};
use crate::config::{CostFunction, MatcherConfig, Method, Prefilter, Subpixel};
use crate::error::{BlockMatchingError, Result};
use crate::frame::{Gray16Image, MatchStats, NccPlanes, Shared, check_pair, count_finite, for_each_band};
use crate::prefilter::{
    TextureSource, box_sum, normalized_response, rank_transform_into, x_sobel_into, x_sobel_u8_into,
};
use crate::speckle::filter_speckles;
/// Which instruction set the inner loops run (`parallax_simd`'s level, detected once per
/// process). At [`SimdLevel::Avx512`] block matching's 16-bit kernel (SAD whose window sums fit
/// in 16 bits: the x-Sobel and rank prefilters) has a copy compiled for AVX-512 F/BW/VL: the same
/// 256-bit operations and results, with 32 vector registers instead of 16, so that up to 16
/// chunks of running box sums stay in registers from column to column (8 with AVX2); every other
/// kernel runs its AVX2 code there.
pub use parallax_simd::SimdLevel;
use parallax_simd::{Avx2, Avx512};

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
    /// Colour input: each channel's raw (widened) and prefiltered planes, left and right.
    channels: Vec<[Vec<u16>; 4]>,
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
            channels: Vec::new(),
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
        self.run(w, h, Input::U8(left.as_raw(), right.as_raw()), None, out)
    }

    /// Disparity of the left image of a rectified 8-bit colour pair. The cost is summed over the
    /// three channels, each prefiltered as the configuration says: semi-global matching's pixel
    /// cost, block matching's window cost (SAD or SSD: each channel's window sum, added; the
    /// sums' range is three times the grey one's, so a window whose grey sums fit the 16-bit
    /// kernel may run the 32-bit one). Every grey-level measure (texture, adaptive P2) reads the
    /// grey conversion (`image::imageops::grayscale`).
    ///
    /// Block matching with [`CostFunction::Ncc`] on a colour pair is refused
    /// ([`BlockMatchingError::InvalidConfig`] naming the cost): the correlation of a sum over
    /// channels is not defined here; match the grey pair with [`BlockMatcher::compute`].
    pub fn compute_rgb(&mut self, left: &RgbImage, right: &RgbImage) -> Result<DisparityMap> {
        let mut out = DisparityMap::new_invalid(0, 0);
        self.compute_rgb_into(left, right, &mut out)?;
        Ok(out)
    }

    /// As [`BlockMatcher::compute_rgb`], writing into `out` (resized as needed).
    pub fn compute_rgb_into(&mut self, left: &RgbImage, right: &RgbImage, out: &mut DisparityMap) -> Result<()> {
        if self.config.method == Method::BlockMatching && self.config.cost == CostFunction::Ncc {
            return Err(BlockMatchingError::InvalidConfig {
                field: "cost",
                value: "Ncc".into(),
                reason: "colour block matching sums SAD or SSD over the channels; NCC matches grey pairs only",
            });
        }
        let (w, h) = check_pair(left.width(), left.height(), right.width(), right.height())?;
        let (gl, gr) = (image::imageops::grayscale(left), image::imageops::grayscale(right));
        let colour = Some([left.as_raw().as_slice(), right.as_raw()]);
        self.run(w, h, Input::U8(gl.as_raw(), gr.as_raw()), colour, out)
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
        self.run(w, h, Input::U16(left.as_raw(), right.as_raw()), None, out)
    }

    fn run(
        &mut self,
        w: usize,
        h: usize,
        input: Input,
        colour: Option<[&[u8]; 2]>,
        out: &mut DisparityMap,
    ) -> Result<()> {
        // everything parallel (conversion, prefilters, texture, bands) runs on the matcher's own
        // pool if any
        let pool = self.pool.take();
        let res = match &pool {
            Some(p) => p.install(|| self.run_in_pool(w, h, input, colour, out)),
            None => self.run_in_pool(w, h, input, colour, out),
        };
        self.pool = pool;
        res
    }

    fn run_in_pool(
        &mut self,
        w: usize,
        h: usize,
        input: Input,
        colour: Option<[&[u8]; 2]>,
        out: &mut DisparityMap,
    ) -> Result<()> {
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
        // (the x-Sobel planes were made with the texture above)
        if matches!(cfg.prefilter, Prefilter::Rank { .. } | Prefilter::NormalizedResponse { .. }) {
            let (pre_left, pre_right) = (&mut self.pre_left, &mut self.pre_right);
            rayon::join(
                || prefilter_plane(cfg.prefilter, raw_left, w, h, scale, pre_left),
                || prefilter_plane(cfg.prefilter, raw_right, w, h, scale, pre_right),
            );
        }
        let (left, right) = match cfg.prefilter {
            Prefilter::None => (raw_left, raw_right),
            _ => (&self.pre_left[..], &self.pre_right[..]),
        };
        if let Some(rgb) = colour {
            // each channel widened and prefiltered as the grey planes
            self.channels.resize_with(3, Default::default);
            self.channels.par_iter_mut().enumerate().for_each(|(c, [rl, rr, pl, pr])| {
                for (src, raw, pre) in [(rgb[0], &mut *rl, &mut *pl), (rgb[1], &mut *rr, &mut *pr)] {
                    raw.clear();
                    raw.extend(src.iter().skip(c).step_by(3).map(|&v| v as u16));
                    prefilter_plane(cfg.prefilter, raw, w, h, scale, pre);
                }
            });
        }
        // per channel the left and right planes: prefiltered, and as read
        let ch = |i: usize| self.channels.iter().map(move |c| [&c[i][..], &c[i + 1][..]]);
        let (pre, raw): (Vec<_>, Vec<_>) = if colour.is_some() {
            (ch(2).collect(), ch(0).collect())
        } else {
            (vec![[left, right]], vec![[raw_left, raw_right]])
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
            // (raw channels may exceed the grey planes' largest value)
            Prefilter::None => pre.iter().flatten().flat_map(|p| p.iter()).copied().max().unwrap_or(0) as u64,
        };
        // a window's cost sums its terms over every channel
        let max_term = pre.len() as u64 * if cfg.cost == CostFunction::Sad { maxv } else { maxv * maxv };
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
        // block matching's planes (semi-global matching reads its own, prepared below)
        let (left, right, extra) = match &pre[..] {
            [[left, right], extra @ ..] if !sgm => (*left, *right, extra),
            _ => (left, right, &[][..]),
        };
        let shared = Shared {
            w,
            h,
            // semi-global matching sums its pixel cost over its own (small) window
            r: if sgm { cfg.sgm.block / 2 } else { r },
            nd: cfg.num_disparities,
            dmin: cfg.min_disparity as i64,
            left,
            right,
            extra,
            texture,
            ncc: &self.ncc,
            n: n as f64,
            uniq: cfg.uniqueness_ratio,
            lr: cfg.lr_max_diff,
            exact_lr_at_edges: sgm,
            lr_subpixel: cfg.lr_subpixel,
            lr_winners: cfg.lr_winners,
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
            self.sgm_planes.prepare(&cfg.sgm, &pre, &raw, scale, w, h);
            let pp = crate::sgm::SgmParams::new(&cfg.sgm, maxv, maxv < 128, &pre, intensity, iscale, &self.sgm_planes)?;
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

/// `raw` prefiltered by `pf` into `out` (`raw` itself for [`Prefilter::None`]).
fn prefilter_plane(pf: Prefilter, raw: &[u16], w: usize, h: usize, scale: u32, out: &mut Vec<u16>) {
    match pf {
        Prefilter::None => {
            out.clear();
            out.extend_from_slice(raw);
        }
        Prefilter::XSobel { cap } => x_sobel_into(raw, w, h, cap as u32 * scale, out),
        Prefilter::Rank { size } => rank_transform_into(raw, w, h, size, out),
        Prefilter::NormalizedResponse { size, cap } => *out = normalized_response(raw, w, h, size, cap as u32 * scale),
    }
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
