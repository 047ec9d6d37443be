//! What a frame's row bands share: the read-only inputs (`Shared`), the statistics
//! (`MatchStats`), the split into bands run in parallel (`for_each_band`) and the row loaders
//! every kernel family reads its rows with. Depends on no kernel.

use image::{ImageBuffer, Luma};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::config::Subpixel;
use crate::error::{BlockMatchingError, Result};
use crate::prefilter::TextureSource;

/// A 16-bit grayscale image (`image` crate buffer).
pub type Gray16Image = ImageBuffer<Luma<u16>, Vec<u16>>;

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
    pub(crate) fn add(&mut self, o: &MatchStats) {
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

/// Per-pixel window statistics of NCC (whole image, clamp-to-edge windows).
#[derive(Default)]
pub(crate) struct NccPlanes {
    pub(crate) sl: Vec<f64>,
    pub(crate) inv_l: Vec<f64>,
    pub(crate) sr: Vec<f64>,
    pub(crate) inv_r: Vec<f64>,
}

/// Read-only inputs shared by all bands.
pub(crate) struct Shared<'a> {
    pub(crate) w: usize,
    pub(crate) h: usize,
    pub(crate) r: usize,
    pub(crate) nd: usize,
    pub(crate) dmin: i64,
    /// The matched planes (prefiltered), left and right: the grey ones, or a colour pair's first
    /// channel.
    pub(crate) left: &'a [u16],
    pub(crate) right: &'a [u16],
    /// Block matching on a colour pair: the other channels' planes (prefiltered as `left` and
    /// `right`), each left and right; the window cost is the sum of every channel's. Empty for
    /// grey (and for semi-global matching, whose planes are its own).
    pub(crate) extra: &'a [[&'a [u16]; 2]],
    /// The texture measure's input, when it is on (each band computes its own rows).
    pub(crate) texture: Option<TextureSource<'a>>,
    pub(crate) ncc: &'a NccPlanes,
    pub(crate) n: f64,
    pub(crate) uniq: u32,
    pub(crate) lr: Option<u32>,
    /// Left–right tolerance 0 where the image edge cuts a pixel's search range (semi-global
    /// matching: see [`finish_row`]).
    pub(crate) exact_lr_at_edges: bool,
    /// [`MatcherConfig::lr_subpixel`].
    pub(crate) lr_subpixel: bool,
    pub(crate) lr_winners: bool,
    /// Uniqueness margin (percent) required where the image edge cuts a pixel's search range
    /// (semi-global matching: `sgm::EDGE_UNIQUENESS`; 0 = the configured one only).
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

impl<'a> Shared<'a> {
    /// Every channel's planes, left and right: `left` and `right`, then [`Shared::extra`].
    pub(crate) fn planes(&self) -> impl Iterator<Item = [&'a [u16]; 2]> + '_ {
        std::iter::once([self.left, self.right]).chain(self.extra.iter().copied())
    }
}

/// The finite values of `v` (as `DisparityMap::valid_count`), summed in `u32` lanes a block at a
/// time (twice as many a vector as a `usize` count's).
pub(crate) fn count_finite(v: &[f32]) -> usize {
    v.chunks(1 << 16).map(|c| c.iter().map(|d| d.is_finite() as u32).sum::<u32>() as usize).sum()
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
