//! Semi-global matching (Hirschmüller 2008) on the matcher's prefiltered planes, with the block
//! matcher's decisions (texture, uniqueness, left–right check, confidence, fill, sub-pixel).
//!
//! Cost: `C(x, y, d)`, the SAD of the prefiltered images over a `block x block` window
//! (clamp-to-edge, as the block matcher), for every `d` of the range; a candidate whose matching
//! pixel lies outside the right image costs `block² · max pixel` (the largest possible cost).
//! Two options change the pixel difference (OpenCV SGBM's cost): with `sampling_insensitive`,
//! `|L − R|` becomes Birchfield–Tomasi's `min(dist(L, [R⁻, R⁺]), dist(R, [L⁻, L⁺]))`, where
//! `[I⁻, I⁺]` is the range of a pixel's value and the half-way values `⌊(I + I_left) / 2⌋`,
//! `⌊(I + I_right) / 2⌋` to its row neighbours (clamped at the image edge), precomputed as
//! planes; with `intensity_cost`, `|⌊I_L / 4⌋ − ⌊I_R / 4⌋|` of the raw images (8-bit grey
//! levels) is added, and the largest possible cost grows by `block² · 63`. Both kinds of plane
//! are made once per frame, in parallel over rows. The column sums move down a row by adding
//! the entering row's differences and subtracting the leaving row's; at the vector level, when
//! every pixel is below 128 (the x-Sobel and rank prefilters on 8-bit input), both rows are
//! read as byte pairs, one byte operation for both differences, and the intensity term joins
//! the intervals' pass, summed with them in bytes before the widening.
//! Aggregation along each path direction `r`:
//!
//! `L(p, d) = C(p, d) + min(L(p−r, d), L(p−r, d±1) + P1, min_k L(p−r, k) + P2') − min_k L(p−r, k)`
//!
//! with `P1 = p1 · block²`, `P2 = p2 · block²` and the intensity-adaptive
//! `P2' = max(P1, P2 · γ / (γ + |I(p) − I(p−r)|))` on the raw left image (`γ = p2_gamma`,
//! 8-bit grey levels; `γ = 0` keeps `P2`). A path starts (`L = C`) where its predecessor
//! leaves the image or the strip's domain. `S(p, d) = Σ_r L_r(p, d)` is the aggregated cost the
//! decisions run on.
//!
//! Scheduling (bounded memory, parallel): the image is cut into strips of `strip` rows, each run
//! by one rayon task with its own buffers. Paths from above start `overlap` rows above the
//! strip; with eight paths, the three paths from below start `overlap` rows below it; in the
//! overlap only the paths that carry into the strip run. Three paths (left→right, right→left,
//! from the top) and five (adding top-left and top-right) need one pass and `≈ 9 · W · Dq · 2`
//! bytes per task (`Dq`: `D` rounded up to 16 lanes; at the vector level, where the paths
//! rewrite their vectors in place, `≈ (6 · W + strip + overlap) · Dq · 2` for five paths and
//! `≈ 4 · W · Dq · 2` for three); eight paths add a backward pass (bottom, bottom-left,
//! bottom-right) over the strip's stored forward sums: `≈ (strip + 9) · W · Dq · 2` bytes per
//! task, where the strip height is capped so this stays under 48 MiB. Never the `W · H · D`
//! volume.
//!
//! Every step is exact 16-bit integer arithmetic (the run refuses costs whose sums could
//! exceed 16 bits). The path steps, column sums, box sums, winner search and right-image
//! minima are written once over the vector width (module `lanes`) and run on 256-bit vectors
//! when the CPU has AVX2 (module `avx2`); plain loops otherwise. The level is chosen once per
//! strip, and the AVX-512 level (`SimdLevel::Avx512`) runs the AVX2 code: on the Intel Xeon
//! whose AVX-512 it was measured on, 512-bit path steps made the frame slower (three paths, one
//! thread, 3 interleaved rounds: teddy 6.6–6.8 → 7.4–7.8 ms, 1282x1110x224 190–205 → 197–213 ms,
//! same maps), as its 512-bit minima and saturating adds issue one a cycle against two 256-bit
//! ones (the same `u16` lanes a second, 112 G/s, in a microbenchmark of eight chains), and the
//! AVX2 code compiled with AVX-512's 32 registers ran within ±3 %. The naive reference in
//! `tests/sgm_vs_naive.rs` implements the same definition directly on a full cost volume and
//! every level must match it exactly.
//!
//! Stack at opt-level 0 (issue 50): there LLVM gives every local of every body inlined into a
//! function a stack slot of its own, shared with none, and the kernels' vector temporaries
//! (`#[inline(always)]` bodies pasted for each path count, mode and lane count) made frames of
//! 999 KiB (the strip's AVX2 instance, with the any-count row kernels inlined) on top of 498 KiB
//! (`forward_row_avx2`): more than a rayon worker's 2 MiB stack. So the strip calls every row
//! kernel, at every level and lane count, as a function of its own (`per_lane_count!`; the
//! strip inlined the scalar level's and the vector level's any-count ones), and at opt-level 0
//! (`cfg(opt_level_zero)`, from `build.rs`) the lane kernels pasted several times per row
//! ([`paths`], [`vertical`], and in `lanes` `paths`, `vertical`, `box_row`, `wta_in` and
//! `right_update`) are not inlined: the largest frame there 23 KiB, a strip's whole chain under
//! 128 KiB (`tests/debug_build.rs`). Every other opt-level inlines them as before (the same
//! machine code, the strip's aside).

use crate::config::{SgmConfig, SgmPaths, Subpixel};
use crate::decide::{Cost, RightWinners, WinnersBy, curve_ratio, decide, finish_row, gather_from};
use crate::error::{BlockMatchingError, Result};
use crate::frame::{MatchStats, Shared, conf_row, load_plane_rows};
use crate::prefilter::{ROWS_PER_TASK, TextureRows};
use parallax_simd::SimdLevel;
use parallax_simd::{Avx2, Level};
use rayon::prelude::*;

/// Uniqueness margin (percent) a winner needs where the image edge cuts its pixel's candidates
/// short of the range (the left band `x < dmin + D − 1`, or the right one with negative
/// disparities): its best rival further than one disparity away must cost more than three times
/// as much, and a winner without such a rival (a range of two or three candidates) is not
/// unique. Where the true match has left the right image the paths still carry a plausible
/// minimum into the band; the margin the configuration asks for (0 in the SGM presets) lets
/// them through. Not in filled (benchmark) maps, which return every pixel. Figures (pixels
/// returned wrong there, before and after): `benches/RESULTS.md`, 2026-12-06.
pub(crate) const EDGE_UNIQUENESS: u32 = 200;

/// Largest task memory of the eight-path strips, bytes.
const STRIP_BYTES: usize = 48 << 20;

/// Sentinel of the padding lanes `d = −1` and `d ≥ D` (never a minimum).
const PAD: u16 = u16::MAX;

/// `D` rounded up to whole 16-lane chunks.
fn lanes(nd: usize) -> usize {
    nd.div_ceil(16) * 16
}

/// Planes some pixel costs need, made once per frame in buffers the matcher keeps.
#[derive(Default)]
pub(crate) struct SgmPlanes {
    /// Birchfield–Tomasi intervals of the prefiltered images: left `I⁻`, left `I⁺`, right
    /// `I⁻`, right `I⁺` (`w · h` each), of the grey planes and then of each colour channel.
    bt: Vec<[Vec<u16>; 4]>,
    /// `⌊I / 4⌋` of the raw images in 8-bit grey levels: left, right (grey, then each channel).
    quant: Vec<[Vec<u16>; 2]>,
}

/// Intervals of one prefiltered image into `lo`, `hi` (`w · h` each), in parallel over rows
/// (rayon's current pool).
fn bt_planes(img: &[u16], w: usize, h: usize, lo: &mut Vec<u16>, hi: &mut Vec<u16>) {
    lo.resize(w * h, 0);
    hi.resize(w * h, 0);
    let chunk = w.max(1) * ROWS_PER_TASK;
    let rows = img.par_chunks(chunk).zip(lo.par_chunks_mut(chunk));
    rows.zip(hi.par_chunks_mut(chunk)).for_each(|((img, lo), hi)| {
        for ((row, lo), hi) in img.chunks_exact(w).zip(lo.chunks_exact_mut(w)).zip(hi.chunks_exact_mut(w)) {
            bt_row(row, lo, hi);
        }
    });
}

/// One row's intervals: `I⁻ = min(v, (v + left) / 2, (v + right) / 2)` and `I⁺` the max, the
/// neighbours clamped at the row's ends (the interior in a form the compiler vectorises: the
/// floor average without widening, `(a & b) + ((a ^ b) >> 1)`).
fn bt_row(row: &[u16], lo: &mut [u16], hi: &mut [u16]) {
    let avg = |a: u16, b: u16| (a & b) + ((a ^ b) >> 1);
    let one = |v: u16, l: u16, r: u16| {
        let (vl, vr) = (avg(v, l), avg(v, r));
        (v.min(vl).min(vr), v.max(vl).max(vr))
    };
    let w = row.len();
    let last = w - 1;
    (lo[0], hi[0]) = one(row[0], row[0], row[1.min(last)]);
    if w == 1 {
        return;
    }
    (lo[last], hi[last]) = one(row[last], row[last - 1], row[last]);
    let inner = row.windows(3).zip(lo[1..last].iter_mut().zip(&mut hi[1..last]));
    for (p, (lo, hi)) in inner {
        (*lo, *hi) = one(p[1], p[0], p[2]);
    }
}

/// `⌊I / scale⌋ / 4` of a raw plane (`scale` 1 or 257: a constant divisor each, which the compiler
/// turns into a multiplication), in parallel over blocks of rows.
fn quantise(img: &[u16], w: usize, scale: u32, q: &mut Vec<u16>) {
    q.resize(img.len(), 0);
    let chunk = w.max(1) * ROWS_PER_TASK;
    q.par_chunks_mut(chunk).zip(img.par_chunks(chunk)).for_each(|(q, img)| {
        let pairs = q.iter_mut().zip(img);
        match scale {
            1 => pairs.for_each(|(q, &v)| *q = v >> 2),
            257 => pairs.for_each(|(q, &v)| *q = (v / 257) >> 2),
            s => pairs.for_each(|(q, &v)| *q = (v as u32 / s) as u16 >> 2),
        }
    });
}

impl SgmPlanes {
    /// Makes the planes `cfg` asks for from the prefiltered (`pre`) and raw images
    /// (`scale`: 1 for 8-bit input, 257 for 16-bit) of each plane pair the cost reads (the
    /// grey pair, or the colour channels' pairs), in parallel on rayon's current pool.
    pub(crate) fn prepare(
        &mut self,
        cfg: &SgmConfig,
        pre: &[[&[u16]; 2]],
        raw: &[[&[u16]; 2]],
        scale: u32,
        w: usize,
        h: usize,
    ) {
        let n = pre.len();
        self.bt.resize_with(n, Default::default);
        self.quant.resize_with(n, Default::default);
        if cfg.sampling_insensitive {
            for (p, [a, b, c, d]) in pre.iter().zip(&mut self.bt) {
                bt_planes(p[0], w, h, a, b);
                bt_planes(p[1], w, h, c, d);
            }
        }
        if cfg.intensity_cost {
            for (img, q) in raw.iter().zip(&mut self.quant) {
                for (img, q) in img.iter().zip(q) {
                    quantise(img, w, scale, q);
                }
            }
        }
    }
}

/// One pair of planes whose pixel differences the cost sums.
#[derive(Clone, Copy)]
pub(crate) struct Term<'a> {
    l: &'a [u16],
    r: &'a [u16],
    /// Birchfield–Tomasi interval planes ([`SgmPlanes`]) when the difference is sampling-insensitive.
    bt: Option<[&'a [u16]; 4]>,
    /// Every pixel below 128 (the byte-pair column update).
    small: bool,
}

/// Parameters of one run, derived from the configuration and the image.
pub(crate) struct SgmParams<'a> {
    pub(crate) paths: SgmPaths,
    pub(crate) p1: u16,
    pub(crate) p2: u16,
    pub(crate) gamma: u32,
    /// Raw left intensities for the adaptive P2, and the divisor to 8-bit grey levels.
    pub(crate) intensity: &'a [u16],
    pub(crate) intensity_scale: u32,
    /// Cost of a candidate outside the right image (`block² · max pixel`).
    pub(crate) cmax: u16,
    pub(crate) overlap: usize,
    /// `P2'` by intensity difference in 8-bit grey levels, `0..=255` (no division per pixel).
    p2_table: [u16; 256],
    /// The plane pairs the cost sums, the prefiltered ones last (see [`colsum_move`]).
    terms: Vec<Term<'a>>,
    /// Some term is sampling-insensitive.
    bt: bool,
}

impl<'a> SgmParams<'a> {
    /// Checks that every sum fits in 16 bits and derives the penalties. `pre`: the prefiltered
    /// plane pairs the cost reads (grey, or the colour channels), whose values are at most
    /// `max_pixel`; `small`: every such value is below 128.
    #[allow(clippy::too_many_arguments)] // the run's planes and their ranges
    pub(crate) fn new(
        cfg: &SgmConfig,
        max_pixel: u64,
        small: bool,
        pre: &[[&'a [u16]; 2]],
        intensity: &'a [u16],
        intensity_scale: u32,
        planes: &'a SgmPlanes,
    ) -> Result<Self> {
        let n = (cfg.block * cfg.block) as u64;
        let k = pre.len() as u64;
        // the intensity term adds at most 255 / 4 per window pixel and plane pair
        let cmax = n * k * (max_pixel + if cfg.intensity_cost { 63 } else { 0 });
        let (p1, p2) = (cfg.p1 as u64 * n, cfg.p2 as u64 * n);
        let npaths = match cfg.paths {
            SgmPaths::Three => 3,
            SgmPaths::Five => 5,
            SgmPaths::Eight => 8,
        };
        // L ≤ C + P2, S ≤ paths · (C + P2); 65535 is the padding sentinel
        if npaths * (cmax + p2) >= PAD as u64 {
            return Err(BlockMatchingError::InvalidConfig {
                field: "sgm",
                value: format!(
                    "block {} · max pixel {max_pixel}{} with p2 {} over {npaths} paths",
                    cfg.block,
                    if k > 1 { format!(" · {k} channels") } else { String::new() },
                    cfg.p2
                ),
                reason: if intensity_scale > 1 {
                    // the x-Sobel and normalised-response outputs grow with the bit depth
                    "aggregated costs must fit in 16 bits: on 16-bit images use the rank prefilter (its values \
                     do not grow with the bit depth), a smaller sgm.block or smaller penalties"
                } else {
                    "aggregated costs must fit in 16 bits: use the rank or x-Sobel prefilter (small pixel \
                     values), a smaller sgm.block, fewer paths or smaller penalties"
                },
            });
        }
        let gamma = cfg.p2_gamma;
        let p2_table = std::array::from_fn(|di| {
            if gamma == 0 { p2 as u16 } else { (p2 as u32 * gamma / (gamma + di as u32)).max(p1 as u32) as u16 }
        });
        let mut terms = Vec::new();
        if cfg.intensity_cost {
            // (quantised to 0..=63: small)
            terms.extend(planes.quant[..pre.len()].iter().map(|[l, r]| Term { l, r, bt: None, small: true }));
        }
        terms.extend(pre.iter().zip(&planes.bt).map(|(&[l, r], [a, b, c, d])| Term {
            l,
            r,
            bt: cfg.sampling_insensitive.then(|| [&a[..], &b[..], &c[..], &d[..]]),
            small,
        }));
        Ok(Self {
            paths: cfg.paths,
            p1: p1 as u16,
            p2: p2 as u16,
            gamma,
            intensity,
            intensity_scale,
            cmax: cmax as u16,
            overlap: cfg.overlap,
            p2_table,
            terms,
            bt: cfg.sampling_insensitive,
        })
    }

    /// `out[i] = P2'` between the left pixels `a[i]` and `b[i]`, the difference in 8-bit grey
    /// levels (16-bit input divided by 257, rounded down), for a whole row before its sweep
    /// (the lookups in the sweep cost registers and branches at every pixel). The scale test
    /// is made once per row: per pixel, with its division, tsukuba's three paths (two rows of
    /// `P2'` a row) ran 26 instructions a pixel more (callgrind).
    #[inline(always)]
    fn p2_row(&self, a: &[u16], b: &[u16], out: &mut [u16]) {
        if self.gamma == 0 {
            out.fill(self.p2);
            return;
        }
        // the difference in 8-bit grey levels is at most 255: 8-bit input is widened (scale 1),
        // 16-bit input divided by 257; the clamp (a difference no input reaches) keeps the
        // lookup without a bounds check or a branch to the formula (which cost ~6 instructions
        // a lookup, two or four rows a row: teddy, three paths, callgrind)
        let (scale, table) = (self.intensity_scale, &self.p2_table);
        let diffs = a.iter().zip(b).map(|(&u, &v)| u.abs_diff(v) as u32);
        if scale == 1 {
            for (o, di) in out.iter_mut().zip(diffs) {
                *o = table[di.min(255) as usize];
            }
        } else {
            for (o, di) in out.iter_mut().zip(diffs) {
                *o = table[(di / scale).min(255) as usize];
            }
        }
    }
}

/// The strip height: independent of the thread count, so a map does not depend on the machine
/// (paths restart at strip boundaries): an even number of strips of at most 256 rows
/// (`2 · ⌈h / 512⌉` strips: every strip costs `overlap` extra rows, and an even count keeps
/// two cores equally busy — measured on teddy, the former `max(128, ⌈h / 8⌉)` rows gave three
/// strips, two of them on one core), and (eight paths) the strip's stored sums under
/// [`STRIP_BYTES`].
pub(crate) fn strip_rows(cfg: &SgmConfig, w: usize, h: usize, nd: usize) -> usize {
    if cfg.strip_rows > 0 {
        return cfg.strip_rows.min(h);
    }
    let mut rows = h.div_ceil(2 * h.div_ceil(512)).max(1);
    if cfg.paths == SgmPaths::Eight {
        let per_row = w * (nd + 2) * 2;
        rows = rows.min((STRIP_BYTES / per_row).saturating_sub(9).max(16));
    }
    rows.min(h)
}

/// Buffers of one strip task, reused across frames.
#[derive(Default)]
pub(crate) struct Scratch {
    colsum: Vec<u16>,
    l_a: Vec<u16>,
    r_a: Vec<u16>,
    l_b: Vec<u16>,
    r_b: Vec<u16>,
    /// `r_a` and `r_b` interleaved as bytes (`r_a` first) and `l_a[xp] | l_b[xp] << 8`, when
    /// every pixel is below 128 (`Shared::small_px`) and both rows' differences are taken;
    /// with the Birchfield–Tomasi intervals, those of the right rows (`I⁻`, `I⁺`) and of the
    /// left rows likewise in the second and third entries; in the fourth, the rows of a term
    /// whose differences the intervals' pass adds (see [`colsum_move`]).
    pairs: [Vec<u8>; 4],
    l_pairs: [Vec<u16>; 4],
    /// The Birchfield–Tomasi intervals of the rows in `l_a`/`r_a` and `l_b`/`r_b`, laid out as
    /// they are: left `I⁻`, left `I⁺`, right `I⁻`, right `I⁺` (sampling-insensitive cost only).
    bt_a: [Vec<u16>; 4],
    bt_b: [Vec<u16>; 4],
    /// `C` of the current row, `W · Dq` (`Dq`: `D` rounded up to 16 lanes).
    cost: Vec<u16>,
    /// `S` of the current row, `W · Dq`.
    acc: Vec<u16>,
    /// Forward sums of the strip's rows (eight paths), `strip · W · Dq`.
    vol: Vec<u16>,
    /// Lanes `d ≥ D` of the last 16-lane chunk: all ones there, zero below (`Dq` entries).
    tail: Vec<u16>,
    /// The horizontal path's previous vector and the new one, `Dq + 2`: slot 0 (`d = −1`) and
    /// slots `D + 1..` are [`PAD`].
    hprev: Vec<u16>,
    hcur: Vec<u16>,
    /// The same for the right→left path (run in the same sweep).
    rprev: Vec<u16>,
    rcur: Vec<u16>,
    /// Start of a path: zeros with padded ends.
    zero: Vec<u16>,
    /// The three vertical/diagonal paths (top, top-left, top-right), previous and current row,
    /// `W · (Dq + 2)` each (bottom, bottom-left, bottom-right in the backward pass). At the vector
    /// level every path rewrites `vp` in place ([`Sweep::new`]) and `vc` is left empty; the
    /// `x − 1` path's vectors then move down one slot a row, in `(W + rows) · (Dq + 2)` lanes
    /// (`rows`: the most rows of one pass, `strip + overlap`), from slot `diag`.
    vp: [Vec<u16>; 3],
    vc: [Vec<u16>; 3],
    /// The slot of the `x − 1` path's vector at pixel 0 of the row before (in place).
    diag: usize,
    /// Their per-pixel minima.
    mp: [Vec<u16>; 3],
    mc: [Vec<u16>; 3],
    /// `P2'` of each pixel of the row towards its predecessors, made once per row
    /// ([`SgmParams::p2_row`]): `p2h[x]` towards `x − 1` on the row; `p2v[i][x]` towards the
    /// row above (below, backward) at `x`, `x − 1` and `x + 1`.
    p2h: Vec<u16>,
    p2v: [Vec<u16>; 3],
    /// The right image's minima of `S` and their candidates (first wins) per right pixel `u`
    /// at `w − 1 − u`, in two copies of `w + Dq` entries ([`decide_row`]), merged into the
    /// first at the row's end.
    rc: Vec<u16>,
    rk: Vec<u16>,
    /// The right winners at each pixel's match ([`finish_row`]).
    rw: Vec<u32>,
    best: Vec<i32>,
    sub: Vec<f32>,
    ratio: Vec<f32>,
    /// The texture measure of the strip's rows.
    texture: TextureRows,
    /// The vector winner search's results per pixel of the row, decided in one pass over the
    /// row afterwards ([`decide_winners`]): the winner (−1: no candidate or rejected before
    /// the search), its `S`, the smallest `S` apart from it and its neighbours, and `S` at the
    /// winner's neighbours (clamped reads, used only inside the range).
    win_k: Vec<i32>,
    win_s: Vec<u16>,
    win_third: Vec<u16>,
    win_m: Vec<u16>,
    win_p: Vec<u16>,
}

impl Scratch {
    /// Sizes the buffers for a strip of `strip` rows with `overlap` rows outside; `in_place`: the
    /// sweeps rewrite the vertical and diagonal paths' vectors in place (the vector level).
    #[allow(clippy::too_many_arguments)] // the strip's shape and the run's kind
    fn resize(&mut self, sh: &Shared, strip: usize, overlap: usize, paths: SgmPaths, bt: bool, in_place: bool) {
        let eight = paths == SgmPaths::Eight;
        let (w, r, nd) = (sh.w, sh.r, sh.nd);
        let ndq = lanes(nd);
        let (wp, ndp) = (w + 2 * r, ndq + 2);
        self.colsum.resize(wp * ndq, 0);
        for v in [&mut self.l_a, &mut self.l_b] {
            v.resize(wp, 0);
        }
        // the reversed right rows are read at (wp − 1 − xp) + d for d < Dq
        for v in [&mut self.r_a, &mut self.r_b] {
            v.resize(wp + ndq - 1, 0);
        }
        for (i, (p, l)) in self.pairs.iter_mut().zip(&mut self.l_pairs).enumerate() {
            // (the intervals' and the second term's pairs only with the intervals)
            let used = i == 0 || bt;
            p.resize(if used { 2 * (wp + ndq - 1) } else { 0 }, 0);
            l.resize(if used { wp } else { 0 }, 0);
        }
        // left intervals as `l_a`, right ones as `r_a`; empty without the cost that reads them
        let bt_len = |i: usize| {
            if !bt {
                0
            } else if i < 2 {
                wp
            } else {
                wp + ndq - 1
            }
        };
        for rows in [&mut self.bt_a, &mut self.bt_b] {
            for (i, v) in rows.iter_mut().enumerate() {
                v.resize(bt_len(i), 0);
            }
        }
        self.cost.resize(w * ndq, 0);
        self.acc.resize(w * ndq, 0);
        if eight {
            self.vol.resize(strip * w * ndq, 0);
        }
        self.tail.clear();
        self.tail.extend((0..ndq).map(|d| if d < nd { 0 } else { u16::MAX }));
        // the padding slots must hold PAD: refilled every frame (the layout may have changed)
        for v in [&mut self.hprev, &mut self.hcur, &mut self.rprev, &mut self.rcur] {
            v.clear();
            v.resize(ndp, PAD);
        }
        self.zero.clear();
        self.zero.resize(ndp, PAD);
        self.zero[1..=nd].fill(0);
        // three paths use the first of the vertical buffers only (the diagonals' stay empty: no
        // fill of `W · (Dq + 2)` lanes per strip for nothing)
        let vertical = if paths == SgmPaths::Three { 1 } else { 3 };
        for (i, v) in self.vp.iter_mut().chain(self.vc.iter_mut()).enumerate() {
            v.clear();
            // (`vc` unused in place; the `x − 1` path's slots shift down one a row there, a
            // pass's first row reading `rows` slots up, its last row writing from slot 0)
            if i % 3 < vertical && (i < 3 || !in_place) {
                let shift = if i == 1 && in_place { strip + overlap } else { 0 };
                v.resize((w + shift) * ndp, PAD);
            }
        }
        for v in self.mp.iter_mut().chain(self.mc.iter_mut()).chain(self.p2v.iter_mut()) {
            v.resize(w, 0);
        }
        self.p2h.resize(w + 1, 0);
        // two copies of `Dq` lanes past the row: the fused winner search and right update
        // writes whole chunks
        self.rc.resize(2 * (w + ndq), u16::MAX);
        self.rk.resize(2 * (w + ndq), u16::MAX);
        self.rw.resize(w, 0);
        self.best.resize(w, -1);
        self.sub.resize(w, 0.0);
        self.ratio.resize(w, 0.0);
        self.win_k.resize(w, -1);
        for v in [&mut self.win_s, &mut self.win_third, &mut self.win_m, &mut self.win_p] {
            v.resize(w, 0);
        }
    }
}

impl Scratch {
    /// Ends a row's vertical and diagonal paths (`vertical` of them): their new vectors and
    /// minima become the next row's predecessors. In place ([`Sweep::new`]) the vectors already
    /// are where the next row reads them, the `x − 1` path's one slot lower.
    fn end_row(&mut self, in_place: bool, vertical: usize) {
        if !in_place {
            std::mem::swap(&mut self.vp, &mut self.vc);
        } else if vertical == 3 {
            self.diag -= 1;
        }
        std::mem::swap(&mut self.mp, &mut self.mc);
    }
}

/// One path step for one pixel: `out[1..=D]` (padded) from the predecessor `prev` (padded,
/// minimum `pmin`) and the cost `c`, added into `acc`; returns the new minimum.
#[inline(always)]
fn step(c: &[u16], prev: &[u16], pmin: u16, p1: u16, p2: u16, out: &mut [u16], acc: &mut [u16]) -> u16 {
    let nd = c.len();
    let (prev, out, acc) = (&prev[..nd + 2], &mut out[1..nd + 1], &mut acc[..nd]);
    let jump = pmin.saturating_add(p2);
    let mut m = u16::MAX;
    for d in 0..nd {
        let best = prev[d + 1].min(prev[d].saturating_add(p1)).min(prev[d + 2].saturating_add(p1)).min(jump);
        let v = c[d] + (best - pmin);
        out[d] = v;
        acc[d] += v;
        m = m.min(v);
    }
    m
}

/// As [`step`] without accumulating (the first path of a row writes `acc` with it).
#[inline(always)]
fn step_set(c: &[u16], prev: &[u16], pmin: u16, p1: u16, p2: u16, out: &mut [u16], acc: &mut [u16]) -> u16 {
    let nd = c.len();
    let (prev, out, acc) = (&prev[..nd + 2], &mut out[1..nd + 1], &mut acc[..nd]);
    let jump = pmin.saturating_add(p2);
    let mut m = u16::MAX;
    for d in 0..nd {
        let best = prev[d + 1].min(prev[d].saturating_add(p1)).min(prev[d + 2].saturating_add(p1)).min(jump);
        let v = c[d] + (best - pmin);
        out[d] = v;
        acc[d] = v;
        m = m.min(v);
    }
    m
}

/// Adds the row held in `l_a`/`r_a` to the column sums (and subtracts `l_b`/`r_b` if `sub`):
/// `|L − R|`, or with `bt` the Birchfield–Tomasi difference on the intervals in
/// `bt_a`/`bt_b`. With `boxed = Some(r)` (window radius, vector levels only) the row's box
/// sums follow each column as soon as its window is complete, into `sc.cost` (the columns they
/// read are still in L1; a second pass read them back from L2 or beyond); returns whether it did.
#[cfg_attr(not(opt_level_zero), inline(always))]
#[allow(clippy::too_many_arguments)] // the pass's kind
fn vertical(
    sc: &mut Scratch,
    nd: usize,
    sub: bool,
    boxed: Option<usize>,
    bt: bool,
    small: bool,
    extra: bool,
    isa: Option<Avx2>,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = isa {
        let pairs = small && sub;
        if pairs {
            // both rows' differences from byte pairs (every pixel below 128): per 16 candidates,
            // three operations instead of seven (teddy, three paths, one thread, callgrind: 11.83 →
            // 11.36 instructions an evaluation); with the intervals, eight instead of fifteen
            let n = if bt { 3 } else { 1 };
            for i in 0..n {
                make_pairs(sc, i);
            }
        }
        // (a second term only in the intervals' byte-pair pass: `avx2::vertical` asserts it)
        let cost = boxed.map(|r| (&mut sc.cost[..], r));
        let rows = (&sc.l_a[..], &sc.r_a[..], &sc.l_b[..], &sc.r_b[..]);
        let bt_rows = bt.then(|| (sc.bt_a.each_ref().map(|v| &v[..]), sc.bt_b.each_ref().map(|v| &v[..])));
        let pairs = pairs.then(|| (sc.pairs.each_ref().map(|v| &v[..]), sc.l_pairs.each_ref().map(|v| &v[..])));
        // (its own function compiled for AVX2; lengths asserted inside)
        t.vectorize(
            #[inline(always)]
            || avx2::vertical(t, &mut sc.colsum, rows, bt_rows, lanes(nd), sub, cost, pairs, extra),
        );
        return boxed.is_some();
    }
    let _ = (isa, boxed, small);
    assert!(!extra, "a second term's pairs only at the vector level");
    // whole 16-lane chunks (`Dq` per column; the lanes past `D` carry ignored values, hence the
    // wrapping arithmetic): fixed-size chunks the compiler vectorises
    let ndq = lanes(nd);
    let wp = sc.l_a.len();
    for (xp, cs) in sc.colsum.chunks_exact_mut(ndq).enumerate().take(wp) {
        let base = wp - 1 - xp;
        let (ra, la) = (&sc.r_a[base..base + ndq], sc.l_a[xp]);
        if bt {
            let [l0, l1, r0, r1] = &sc.bt_a;
            let (u, u0, u1) = (la, l0[xp], l1[xp]);
            let (v0, v1) = (&r0[base..base + ndq], &r1[base..base + ndq]);
            for k in 0..ndq {
                cs[k] = cs[k].wrapping_add(bt_difference(u, u0, u1, ra[k], v0[k], v1[k]));
            }
            if sub {
                let [l0, l1, r0, r1] = &sc.bt_b;
                let (u, u0, u1) = (sc.l_b[xp], l0[xp], l1[xp]);
                let (rb, v0, v1) = (&sc.r_b[base..base + ndq], &r0[base..base + ndq], &r1[base..base + ndq]);
                for k in 0..ndq {
                    cs[k] = cs[k].wrapping_sub(bt_difference(u, u0, u1, rb[k], v0[k], v1[k]));
                }
            }
        } else if sub {
            let (rb, lb) = (&sc.r_b[base..base + ndq], sc.l_b[xp]);
            for ((c, a), b) in cs.chunks_exact_mut(16).zip(ra.chunks_exact(16)).zip(rb.chunks_exact(16)) {
                for k in 0..16 {
                    c[k] = c[k].wrapping_add(la.abs_diff(a[k])).wrapping_sub(lb.abs_diff(b[k]));
                }
            }
        } else {
            for (c, a) in cs.chunks_exact_mut(16).zip(ra.chunks_exact(16)) {
                for k in 0..16 {
                    c[k] = c[k].wrapping_add(la.abs_diff(a[k]));
                }
            }
        }
    }
    false
}

/// Byte pairs `i` of the rows loaded in `a` and `b` ([`Scratch::pairs`]): 0 the values, 1 and 2
/// their intervals' `I⁻` and `I⁺`; the values again as 3 (a second term's, before the
/// intervals' term is loaded over them).
fn make_pairs(sc: &mut Scratch, i: usize) {
    let (right, left) = match i {
        0 | 3 => ((&sc.r_a, &sc.r_b), (&sc.l_a, &sc.l_b)),
        _ => ((&sc.bt_a[i + 1], &sc.bt_b[i + 1]), (&sc.bt_a[i - 1], &sc.bt_b[i - 1])),
    };
    for ((q, &a), &b) in sc.pairs[i].chunks_exact_mut(2).zip(right.0.iter()).zip(right.1.iter()) {
        (q[0], q[1]) = (a as u8, b as u8);
    }
    for ((q, &a), &b) in sc.l_pairs[i].iter_mut().zip(left.0.iter()).zip(left.1.iter()) {
        *q = a | b << 8;
    }
}

/// Birchfield–Tomasi's difference of the left value `u` (interval `[u0, u1]`) and the right
/// value `v` (`[v0, v1]`): the smaller of `u`'s distance to `[v0, v1]` and `v`'s to `[u0, u1]`.
#[inline(always)]
fn bt_difference(u: u16, u0: u16, u1: u16, v: u16, v0: u16, v1: u16) -> u16 {
    u.saturating_sub(v1).max(v0.saturating_sub(u)).min(v.saturating_sub(u1).max(u0.saturating_sub(v)))
}

/// Loads row `y` of the plane pair `t` into the `a` rows (`b = false`) or the `b` rows (and its
/// Birchfield–Tomasi intervals when the term uses them).
#[inline(always)]
fn load(sh: &Shared, t: &Term, sc: &mut Scratch, y: usize, b: bool) {
    let (l, r, bt) =
        if b { (&mut sc.l_b, &mut sc.r_b, &mut sc.bt_b) } else { (&mut sc.l_a, &mut sc.r_a, &mut sc.bt_a) };
    load_plane_rows(sh, t.l, t.r, y, l, r);
    if let Some([l0, l1, r0, r1]) = t.bt {
        let [a, b, c, d] = bt;
        load_plane_rows(sh, l0, r0, y, a, c);
        load_plane_rows(sh, l1, r1, y, b, d);
    }
}

/// The column sums of row `y` from scratch.
#[inline(always)]
fn colsum_init(sh: &Shared, pp: &SgmParams, sc: &mut Scratch, y: usize, isa: Option<Avx2>) {
    let (h, r) = (sh.h as i64, sh.r as i64);
    sc.colsum.fill(0);
    for j in y as i64 - r..=y as i64 + r {
        let j = j.clamp(0, h - 1) as usize;
        for t in &pp.terms {
            load(sh, t, sc, j, false);
            vertical(sc, sh.nd, false, None, t.bt.is_some(), false, false, isa);
        }
    }
}

/// Moves the column sums from row `y` to row `y + 1` (`down`) or `y − 1`; returns whether the
/// new row's box sums were made with them (see [`vertical`]).
#[inline(always)]
fn colsum_move(sh: &Shared, pp: &SgmParams, sc: &mut Scratch, y: usize, down: bool, isa: Option<Avx2>) -> bool {
    let (h, r) = (sh.h as i64, sh.r as i64);
    let clamp = |v: i64| v.clamp(0, h - 1) as usize;
    let (yi, yo) = if down {
        (clamp(y as i64 + 1 + r), clamp(y as i64 - r))
    } else {
        (clamp(y as i64 - 1 - r), clamp(y as i64 + r))
    };
    if yi == yo {
        return false;
    }
    // the last term's pass makes the box sums, which need the complete sums: the others first
    let (last, rest) = pp.terms.split_last().expect("a cost has a plane pair");
    // at the vector level, an intervals' term of small pixels takes the term before it in its
    // own pass when that one's pixels are small too (the default cost: the intensity term,
    // added to the intervals' byte differences before they are widened)
    let extra =
        isa.is_some() && last.small && last.bt.is_some() && rest.last().is_some_and(|t| t.small && t.bt.is_none());
    let rest = if extra { &rest[..rest.len() - 1] } else { rest };
    for t in rest {
        load(sh, t, sc, yi, false);
        load(sh, t, sc, yo, true);
        vertical(sc, sh.nd, true, None, t.bt.is_some(), t.small, false, isa);
    }
    if extra {
        let t = &pp.terms[pp.terms.len() - 2];
        load(sh, t, sc, yi, false);
        load(sh, t, sc, yo, true);
        make_pairs(sc, 3);
    }
    load(sh, last, sc, yi, false);
    load(sh, last, sc, yo, true);
    // with the box sums, in the column pass (measured, three paths, 1 thread, when they took a
    // second pass over each column: 1282x1110x224 0.95x the time, 626x555x96 0.96x, teddy
    // 450x375x64 1.03x; in one pass, teddy 0.95x the median time of the second pass, 12 interleaved
    // rounds at load 1.7, and 10.95 → 10.74 instructions an evaluation)
    vertical(sc, sh.nd, true, Some(sh.r), last.bt.is_some(), last.small, extra, isa)
}

/// `C` of the current row from the column sums: running box sums along the row (unless
/// `boxed`: made with the column sums), then the out-of-image candidates set to `cmax`.
#[inline(always)]
fn cost_row(sh: &Shared, sc: &mut Scratch, cmax: u16, boxed: bool, isa: Option<Avx2>) {
    let (w, r, nd, dmin) = (sh.w, sh.r, sh.nd, sh.dmin);
    let ndq = lanes(nd);
    let (cost, colsum) = (&mut sc.cost, &sc.colsum);
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = isa.filter(|_| !boxed) {
        // (its own function compiled for AVX2; lengths asserted inside)
        t.vectorize(
            #[inline(always)]
            || avx2::box_row(t, cost, colsum, w, r, ndq),
        );
    }
    if isa.is_none() {
        let c0 = &mut cost[..ndq];
        c0.fill(0);
        for xp in 0..=2 * r {
            for (c, &s) in c0.iter_mut().zip(&colsum[xp * ndq..][..ndq]) {
                *c = c.wrapping_add(s);
            }
        }
        for x in 1..w {
            let (prev, cur) = cost[(x - 1) * ndq..(x + 1) * ndq].split_at_mut(ndq);
            let (a, s) = (&colsum[(x + 2 * r) * ndq..][..ndq], &colsum[(x - 1) * ndq..][..ndq]);
            let chunks =
                cur.chunks_exact_mut(16).zip(prev.chunks_exact(16)).zip(a.chunks_exact(16).zip(s.chunks_exact(16)));
            for ((c, p), (a, s)) in chunks {
                for k in 0..16 {
                    c[k] = p[k].wrapping_add(a[k]).wrapping_sub(s[k]);
                }
            }
        }
    }
    // only the edge bands have such candidates: x < dmin + D − 1 (hi < D) and x ≥ w + dmin
    // (lo > 0)
    let left_end = (dmin + nd as i64 - 1).clamp(0, w as i64) as usize;
    let right_start = (w as i64 + dmin).clamp(left_end as i64, w as i64) as usize;
    for x in (0..left_end).chain(right_start..w) {
        let xd = x as i64 - dmin;
        let lo = (xd - (w as i64 - 1)).clamp(0, nd as i64) as usize;
        let hi = (xd + 1).clamp(0, nd as i64) as usize;
        let c = &mut cost[x * ndq..][..nd];
        c[..lo].fill(cmax);
        c[hi.max(lo)..].fill(cmax);
    }
    // the lanes past D: `PAD`, which the paths' saturating addition of `C` keeps (in place of a
    // mask per path and pixel: three paths, one thread, callgrind, tsukuba 17.54 → 17.29
    // instructions an evaluation)
    if ndq > nd {
        for c in cost[..w * ndq].chunks_exact_mut(ndq) {
            c[nd..].fill(PAD);
        }
    }
}

/// The paths of one pixel: for each path `i`, its predecessor vector `prev[i]` (padded),
/// minimum `pmin[i]` and jump penalty `p2[i]`; writes the new vectors to `out[i]` (padded) and
/// returns their minima. `acc` (`Dq` lanes) receives their sum (`set`: replaces it). The first
/// `H` paths are horizontal (their predecessor was stored by the step just before). The cost's
/// lanes `d ≥ D` hold `PAD` ([`cost_row`]), and so do the new vectors' there. With `in_place`
/// (vector level only), a path after the first `H` may write its new vector over its
/// predecessor (`out[i] = prev[i]`: see [`lanes::paths`]).
///
/// # Safety
/// `c` and `acc` address `Dq` lanes, every `prev[i]` and `out[i]` `Dq + 2`; no `out[i]`
/// nor `acc` overlaps another of them or an input, except that with `in_place` a path after
/// the first `H` may have `out[i] = prev[i]` (the same address). With [`Isa::Avx2`] the CPU has
/// AVX2 and the caller is compiled for it (the strip compiled for AVX2 by `run_strip`); the
/// scalar level never runs `in_place`.
#[cfg_attr(not(opt_level_zero), inline(always))]
#[allow(clippy::too_many_arguments)] // the step's inputs and outputs
unsafe fn paths<const N: usize, const H: usize, const NDQ: usize>(
    isa: Option<Avx2>,
    c: *const u16,
    prev: [*const u16; N],
    pmin: [u16; N],
    p2: [u16; N],
    p1: u16,
    out: [*mut u16; N],
    acc: *mut u16,
    nd: usize,
    set: bool,
    in_place: bool,
) -> [u16; N] {
    let ndq = if NDQ > 0 { NDQ } else { lanes(nd) };
    // SAFETY: the lengths and the absence of overlap are the caller's.
    let (c, acc) = unsafe { (std::slice::from_raw_parts(c, ndq), std::slice::from_raw_parts_mut(acc, ndq)) };
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = isa {
        // SAFETY: the caller's (lengths, `in_place`); all lanes 0..Dq.
        return unsafe {
            match (set, in_place) {
                (true, true) => lanes::paths::<N, H, true, true>(t, c, prev, pmin, p2, p1, out, acc),
                (true, false) => lanes::paths::<N, H, true, false>(t, c, prev, pmin, p2, p1, out, acc),
                (false, true) => lanes::paths::<N, H, false, true>(t, c, prev, pmin, p2, p1, out, acc),
                (false, false) => lanes::paths::<N, H, false, false>(t, c, prev, pmin, p2, p1, out, acc),
            }
        };
    }
    let _ = isa;
    assert!(!in_place, "the scalar steps read their predecessors as slices");
    // SAFETY: as above (no `out[i]` overlaps them without `in_place`).
    let prev = prev.map(|p| unsafe { std::slice::from_raw_parts(p, ndq + 2) });
    let mut m = [0u16; N];
    for (i, o) in out.into_iter().enumerate() {
        // SAFETY: the caller's.
        let o = unsafe { std::slice::from_raw_parts_mut(o, ndq + 2) };
        m[i] = if set && i == 0 {
            step_set(&c[..nd], prev[i], pmin[i], p1, p2[i], o, acc)
        } else {
            step(&c[..nd], prev[i], pmin[i], p1, p2[i], o, acc)
        };
    }
    m
}

/// The buffers of one row's sweep as pointers, the lengths checked once per row, and `P2'`
/// of the row's pixels towards the row `other` above (forward) or below (backward) in `p2v`.
/// (Sliced at every pixel, with bounds checks, reloads and buffer swaps: with the winner search
/// inlined as well, the per-pixel code fell from ~915 to ~690 instructions a pixel,
/// 1282x1110x224, three paths, callgrind.)
struct Sweep {
    cost: *const u16,
    acc: *mut u16,
    zero: *const u16,
    vp: [*const u16; 3],
    vc: [*mut u16; 3],
    mp: [*const u16; 3],
    mc: [*mut u16; 3],
    p2v: [*const u16; 3],
}

impl Sweep {
    /// Checks every length the sweep of a row relies on and takes the pointers; `vertical`: the
    /// vertical and diagonal paths in use (1 or 3), `first`: no row before (no `P2'` towards it),
    /// `in_place`: the new vectors are written into the buffers the paths read. The straight
    /// and the `x + 1` paths (top and top-right forward, bottom and bottom-right backward) write
    /// pixel `x`'s into slot `x` (`vc[i] = vp[i]`: pixel `x` reads slots `x` and `x + 1`, and no
    /// later pixel of the row reads slot `x` there). The `x − 1` path, whose predecessor of
    /// pixel `x + 1` is slot `x`, writes pixel `x`'s into the slot it read, one below (`vc[1] =
    /// vp[1] − 1` slot), so its vectors move down one slot a row ([`Scratch::end_row`]): from
    /// slot `rows` at a pass's first row (the buffer's top `W` slots) to slot 0 at its last.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // the row, its neighbour and the sweep's kind
    fn new(
        sh: &Shared,
        sc: &mut Scratch,
        pp: &SgmParams,
        row: &[u16],
        other: &[u16],
        vertical: usize,
        first: bool,
        in_place: bool,
    ) -> Self {
        let w = sh.w;
        let (ndq, ndp) = (lanes(sh.nd), lanes(sh.nd) + 2);
        assert!(row.len() == w && other.len() == w && w > 0);
        assert!(sc.cost.len() >= w * ndq && sc.acc.len() >= w * ndq && sc.zero.len() == ndp);
        let diag = in_place && vertical == 3;
        if diag && first {
            sc.diag = sc.vp[1].len() / ndp - w;
        }
        // each path's slot 0 in `vp`
        let off = |i: usize| if diag && i == 1 { sc.diag * ndp } else { 0 };
        for i in 0..vertical {
            assert!(sc.vp[i].len() >= off(i) + w * ndp && (in_place || sc.vc[i].len() >= w * ndp));
            assert!(sc.mp[i].len() >= w && sc.mc[i].len() >= w && sc.p2v[i].len() >= w);
        }
        // (the `x − 1` path's pixel 0 writes the slot below `diag`: `Scratch::resize` left one
        // for each row of a pass)
        assert!(!diag || sc.diag >= 1);
        if first {
            // no row before: every predecessor is a path start (zeros, minimum 0, `P2`), so
            // the sweep reads the row before without a test at each pixel
            for i in 0..vertical {
                let off = off(i);
                for v in sc.vp[i][off..off + w * ndp].chunks_exact_mut(ndp) {
                    v.copy_from_slice(&sc.zero);
                }
                sc.mp[i][..w].fill(0);
                sc.p2v[i][..w].fill(pp.p2);
            }
        } else {
            let [t, l, r] = &mut sc.p2v;
            pp.p2_row(row, other, &mut t[..w]);
            if vertical == 3 {
                pp.p2_row(&row[1..], &other[..w - 1], &mut l[1..w]);
                pp.p2_row(&row[..w - 1], &other[1..], &mut r[..w - 1]);
            }
        }
        let vp: [*mut u16; 3] = std::array::from_fn(|i| sc.vp[i].as_mut_ptr().wrapping_add(off(i)));
        Self {
            cost: sc.cost.as_ptr(),
            acc: sc.acc.as_mut_ptr(),
            zero: sc.zero.as_ptr(),
            vp: vp.map(|p| p as *const u16),
            vc: {
                let vc = sc.vc.each_mut().map(|v| v.as_mut_ptr());
                if in_place { [vp[0], vp[1].wrapping_sub(ndp), vp[2]] } else { vc }
            },
            mp: sc.mp.each_ref().map(|v| v.as_ptr()),
            mc: sc.mc.each_mut().map(|v| v.as_mut_ptr()),
            p2v: sc.p2v.each_ref().map(|v| v.as_ptr()),
        }
    }

    /// Predecessor `i` (0: straight, 1: from `x − 1`, 2: from `x + 1`) of pixel `x` on the row
    /// before: its vector, minimum and `P2'`, or a path start (zeros, `P2`) where there is none
    /// (on the first row, `new` made the row before all path starts).
    ///
    /// # Safety
    /// `x < w`, `i` among the paths the sweep was made for.
    #[inline(always)]
    unsafe fn before(&self, i: usize, x: usize, w: usize, ndp: usize, p2: u16) -> (*const u16, u16, u16) {
        let none = (i == 1 && x == 0) || (i == 2 && x + 1 == w);
        if none {
            return (self.zero, 0, p2);
        }
        let xs = [x, x.wrapping_sub(1), x + 1][i];
        // SAFETY: xs < w (the ends are path starts) and the lengths checked in `new`.
        unsafe { (self.vp[i].add(xs * ndp), *self.mp[i].add(xs), *self.p2v[i].add(x)) }
    }

    /// Pixel `x`'s vertical and diagonal paths (`vertical`: the straight one, or all three)
    /// without a horizontal one: their sum into `acc` (`set`: replaces it), their minima into
    /// `mc`.
    ///
    /// # Safety
    /// `x < w`, the sweep made for `vertical` paths and `in_place` as `new`'s; `isa` as the
    /// strip's (the lengths were checked in `new`, the outputs as [`paths`] allows).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // the pixel, the range, the penalties and the sweep's kind
    unsafe fn vertical<const NDQ: usize>(
        &self,
        isa: Option<Avx2>,
        x: usize,
        w: usize,
        nd: usize,
        (p1, p2): (u16, u16),
        vertical: usize,
        set: bool,
        in_place: bool,
    ) {
        let ndq = if NDQ > 0 { NDQ } else { lanes(nd) };
        let ndp = ndq + 2;
        // SAFETY: the caller's.
        unsafe {
            let (c, acc) = (self.cost.add(x * ndq), self.acc.add(x * ndq));
            let (t, tm, tp2) = self.before(0, x, w, ndp, p2);
            let out = |i: usize| self.vc[i].add(x * ndp);
            if vertical == 1 {
                let [m] = paths::<1, 0, NDQ>(isa, c, [t], [tm], [tp2], p1, [out(0)], acc, nd, set, in_place);
                *self.mc[0].add(x) = m;
            } else {
                let (l, lm, lp2) = self.before(1, x, w, ndp, p2);
                let (r, rm, rp2) = self.before(2, x, w, ndp, p2);
                let (prev, pmin, p2s) = ([t, l, r], [tm, lm, rm], [tp2, lp2, rp2]);
                let m = paths::<3, 0, NDQ>(isa, c, prev, pmin, p2s, p1, [0, 1, 2].map(out), acc, nd, set, in_place);
                (*self.mc[0].add(x), *self.mc[1].add(x), *self.mc[2].add(x)) = (m[0], m[1], m[2]);
            }
        }
    }
}

/// The forward paths of row `y`: right→left, left→right and, from the row above (unless
/// `first`), top, top-left and top-right. Writes `S` of these paths to `acc`.
///
/// One sweep: step `x` runs the four paths at `x` and the right→left path at `w − 1 − x`. Each
/// horizontal path is a chain (a pixel needs the minimum of its predecessor); run alone, the
/// right→left chain left the vector units idle (measured: ~19 % of a teddy frame for one path of
/// five), interleaved its latency hides behind the other paths' work. Whichever visits a pixel
/// first writes its `acc`, the other adds (exact integer sums: the order does not matter): pixel
/// `p` is visited by the four paths at step `p` and by the right→left path at step `w − 1 − p`,
/// the four paths first when both fall on the same step.
#[inline(always)]
fn forward_row<const NDQ: usize>(
    sh: &Shared,
    sc: &mut Scratch,
    pp: &SgmParams,
    y: usize,
    first: bool,
    isa: Option<Avx2>,
) {
    let (w, nd) = (sh.w, sh.nd);
    let ndq = lanes(nd);
    assert!(NDQ == 0 || NDQ == ndq);
    let ndq = if NDQ > 0 { NDQ } else { ndq };
    let ndp = ndq + 2;
    let row = &pp.intensity[y * w..][..w];
    let above = if first { row } else { &pp.intensity[(y - 1) * w..][..w] };
    let three = pp.paths == SgmPaths::Three;
    // P2' along the row: p2h[x] between x and x − 1 (the right→left path at x reads p2h[x + 1]);
    // at both ends the path starts (`P2`)
    pp.p2_row(&row[1..], &row[..w - 1], &mut sc.p2h[1..w]);
    (sc.p2h[0], sc.p2h[w]) = (pp.p2, pp.p2);
    // at the vector level, the vertical and diagonal paths' vectors rewritten in place (one
    // buffer each, not two written in turn; the top and top-right paths, three paths, 3
    // interleaved rounds: 1282x1110x224 one
    // thread 196–198 → 187–188 ms, two threads 99–104 → 96–99 ms; teddy within ±1 %; five
    // paths, one thread: 1282x1110x224 337–343 → 305–311 ms, teddy 10.32–10.45 → 10.14–10.21 ms)
    let in_place = isa.is_some();
    let s = Sweep::new(sh, sc, pp, row, above, if three { 1 } else { 3 }, first, in_place);
    // both horizontal paths start from the path start (zeros, minimum 0)
    sc.hprev.copy_from_slice(&sc.zero);
    sc.rprev.copy_from_slice(&sc.zero);
    assert!([&sc.hcur, &sc.rcur].iter().all(|v| v.len() == ndp) && sc.p2h.len() > w);
    let p2h = sc.p2h.as_ptr();
    let (mut hp, mut hc) = (sc.hprev.as_mut_ptr(), sc.hcur.as_mut_ptr());
    let (mut rp, mut rc) = (sc.rprev.as_mut_ptr(), sc.rcur.as_mut_ptr());
    let (p1, p2) = (pp.p1, pp.p2);
    let (mut pmin, mut rpmin) = (0, 0);
    // the sweep, pasted for each path count (a test of the count at every pixel was not hoisted)
    // and for the pixels before the middle (the first visit: `set`), the middle one of an odd
    // row and those after it; with the path starts in the buffers (no test of the row's ends
    // or of the first row at each pixel), three paths, one thread, callgrind: tsukuba 26.80 →
    // 25.57, venus 16.44 → 15.90, teddy 10.72 → 10.49 instructions an evaluation
    macro_rules! sweep {
        ($three:expr, $xs:expr, $set:expr) => {
            for x in $xs {
                let xr = w - 1 - x;
                // SAFETY: x, xr < w, so every offset is inside its buffer (lengths checked above and in
                // `Sweep::new`); the outputs (`hc`, row `vc`, `acc`) are other buffers than the inputs,
                // but with `in_place` the top and top-left paths' outputs are their inputs (the
                // same vectors) and the top-right's is pixel x's slot of the buffer it reads at
                // x + 1 (no overlap), as `paths` allows; `isa` as the strip's.
                unsafe {
                    let (c, acc) = (s.cost.add(x * ndq), s.acc.add(x * ndq));
                    let (h, hm, hp2) = (hp as *const u16, pmin, *p2h.add(x));
                    let (t, tm, tp2) = s.before(0, x, w, ndp, p2);
                    let vo = |i: usize| s.vc[i].add(x * ndp);
                    if $three {
                        let m = paths::<2, 1, NDQ>(
                            isa,
                            c,
                            [h, t],
                            [hm, tm],
                            [hp2, tp2],
                            p1,
                            [hc, vo(0)],
                            acc,
                            nd,
                            $set || x == xr,
                            in_place,
                        );
                        pmin = m[0];
                        *s.mc[0].add(x) = m[1];
                    } else {
                        let (l, lm, lp2) = s.before(1, x, w, ndp, p2);
                        let (r, rm, rp2) = s.before(2, x, w, ndp, p2);
                        let m = paths::<4, 1, NDQ>(
                            isa,
                            c,
                            [h, t, l, r],
                            [hm, tm, lm, rm],
                            [hp2, tp2, lp2, rp2],
                            p1,
                            [hc, vo(0), vo(1), vo(2)],
                            acc,
                            nd,
                            $set || x == xr,
                            in_place,
                        );
                        pmin = m[0];
                        (*s.mc[0].add(x), *s.mc[1].add(x), *s.mc[2].add(x)) = (m[1], m[2], m[3]);
                    }
                    std::mem::swap(&mut hp, &mut hc);
                    // right → left at xr
                    let (c, acc) = (s.cost.add(xr * ndq), s.acc.add(xr * ndq));
                    [rpmin] =
                        paths::<1, 1, NDQ>(isa, c, [rp], [rpmin], [*p2h.add(xr + 1)], p1, [rc], acc, nd, $set, false);
                    std::mem::swap(&mut rp, &mut rc);
                }
            }
        };
    }
    let (half, mid) = (w / 2, w.div_ceil(2));
    if three {
        sweep!(true, 0..half, true);
        sweep!(true, half..mid, false);
        sweep!(true, mid..w, false);
    } else {
        sweep!(false, 0..half, true);
        sweep!(false, half..mid, false);
        sweep!(false, mid..w, false);
    }
    sc.end_row(in_place, if three { 1 } else { 3 });
}

/// A row of the overlap above a strip (`first`: its first row), which no decision reads: only
/// the paths the next row continues, top and (five and eight paths) top-left and top-right, whose
/// sum `acc` then holds (the next row's sweep rewrites it). The horizontal paths restart on every
/// row (three paths, 3 interleaved rounds, maps unchanged: 1282x1110x224, five strips below the
/// first, two threads 92.7–93.4 → 89.9–91.5 ms, one thread 180–183 → 177–183 ms; teddy within
/// 1 %). A function of its own, not a branch of [`forward_row`]: as a branch, incidental changes
/// to it (the same maps, the same one-thread times) moved the two-thread time at 626x555x96
/// between 9.5–9.9 and 10.2–10.8 ms (three paths, 3–4 interleaved rounds); as its own function
/// 9.55–9.93 ms, against 9.87–10.18 ms with the whole sweep in the overlap (5 rounds).
#[inline(always)]
fn carry_row<const NDQ: usize>(
    sh: &Shared,
    sc: &mut Scratch,
    pp: &SgmParams,
    y: usize,
    first: bool,
    isa: Option<Avx2>,
) {
    let (w, nd) = (sh.w, sh.nd);
    assert!(NDQ == 0 || NDQ == lanes(nd));
    let row = &pp.intensity[y * w..][..w];
    let above = if first { row } else { &pp.intensity[(y - 1) * w..][..w] };
    let three = pp.paths == SgmPaths::Three;
    let in_place = isa.is_some();
    let vertical = if three { 1 } else { 3 };
    let s = Sweep::new(sh, sc, pp, row, above, vertical, first, in_place);
    for x in 0..w {
        // SAFETY: x < w, the sweep made as `vertical` asks; `acc` is pixel x's entry of the
        // row's sums, which the next row's sweep rewrites before any decision reads it.
        unsafe {
            if three {
                s.vertical::<NDQ>(isa, x, w, nd, (pp.p1, pp.p2), 1, true, in_place)
            } else {
                s.vertical::<NDQ>(isa, x, w, nd, (pp.p1, pp.p2), 3, true, in_place)
            }
        };
    }
    sc.end_row(in_place, vertical);
}

/// Returns `$f::<Dq>(args)` for the lane counts compiled on their own (16 to 256: see
/// [`forward_row_any`]); any other count falls through.
macro_rules! by_lane_count {
    ($dq:expr, $f:ident $args:tt) => {
        by_lane_count!(@ $dq, $f $args; 16, 32, 48, 64, 80, 96, 112, 128, 144, 160, 176, 192, 208, 224, 240, 256)
    };
    (@ $dq:expr, $f:ident $args:tt; $($k:literal),*) => {
        match $dq {
            $($k => return $f::<$k> $args,)*
            _ => {}
        }
    };
}

/// `$any`: `$f` compiled for each lane count up to 256 at the vector level (through `$avx2`,
/// one function per count that enters the AVX2 level through the token's `vectorize`, chosen by
/// [`by_lane_count!`] from `$dq`), and for any count otherwise; `$dq`, the lane count, reads the
/// arguments.
macro_rules! per_lane_count {
    ($(#[$doc:meta])* $any:ident, $avx2:ident, $scalar:ident, $f:ident, $dq:expr, ($($a:ident: $t:ty),*)) => {
        $(#[$doc])*
        #[inline(always)]
        fn $any($($a: $t,)* isa: Option<Avx2>) {
            // (each count in a function of its own: inlined into the strip, seven counts made
            // the crate's build 37 → 206 s, debug profile; as functions, sixteen take 59 s).
            // Every level and count calls a function of its own, none is inlined here: at
            // opt-level 0 the stack slots of every body inlined into a function add up (LLVM
            // shares none), and with the any-count bodies (vector and scalar) inlined the strip's
            // frame was 999 KiB on top of a row kernel's, more than a rayon worker's 2 MiB stack.
            #[cfg(target_arch = "x86_64")]
            if let Some(t) = isa {
                by_lane_count!($dq, $avx2(t, $($a),*));
                return $avx2::<0>(t, $($a),*);
            }
            $scalar($($a),*)
        }

        #[doc = concat!("[`", stringify!($f), "`] at the scalar level.")]
        #[inline(never)]
        fn $scalar($($a: $t),*) {
            $f::<0>($($a,)* None)
        }

        #[doc = concat!("[`", stringify!($f), "`] with `NDQ` lanes at the vector level (compiled for AVX2 by the token's `vectorize`).")]
        #[cfg(target_arch = "x86_64")]
        #[inline(never)]
        fn $avx2<const NDQ: usize>(t: Avx2, $($a: $t),*) {
            t.vectorize(#[inline(always)] || $f::<NDQ>($($a,)* Some(t)))
        }
    };
}

per_lane_count!(
    /// [`forward_row`] at the vector level compiled for each lane count up to 256 (`Dq` = 16, 32,
    /// …, 256; larger ranges and the scalar level run the one for any count): with the count a
    /// constant, the chunk loops unroll, the strides are immediates and fewer values live in
    /// registers across a pixel. With [`decide_row_any`] and the byte pairs' column pass likewise,
    /// one thread, callgrind, instructions an evaluation, three paths: tsukuba 25.57 → 19.09, venus
    /// 15.90 → 11.64, teddy 10.49 → 8.26, 626x555x96 9.28 → 7.24, 1282x1110x224 6.67 → 6.13; teddy
    /// with five paths 14.54 → 11.39, eight 24.78 → 21.37.
    forward_row_any, forward_row_avx2, forward_row_scalar, forward_row, lanes(sh.nd),
    (sh: &Shared, sc: &mut Scratch, pp: &SgmParams, y: usize, first: bool)
);

per_lane_count!(
    /// [`carry_row`] compiled for each lane count up to 256, as [`forward_row_any`].
    carry_row_any, carry_row_avx2, carry_row_scalar, carry_row, lanes(sh.nd),
    (sh: &Shared, sc: &mut Scratch, pp: &SgmParams, y: usize, first: bool)
);

per_lane_count!(
    /// [`backward_row`] compiled for each lane count up to 256, as [`forward_row_any`] (eight
    /// paths, teddy, one thread, callgrind: 21.37 → 19.97 instructions an evaluation).
    backward_row_any, backward_row_avx2, backward_row_scalar, backward_row, lanes(sh.nd),
    (sh: &Shared, sc: &mut Scratch, pp: &SgmParams, y: usize, first: bool)
);

per_lane_count!(
    /// [`decide_row`] compiled for each lane count up to 256, as [`forward_row_any`].
    decide_row_any, decide_row_avx2, decide_row_scalar, decide_row, lanes(sh.nd),
    (sh: &Shared, sc: &mut Scratch, y: usize, out: &mut [f32], conf: &mut [f32], st: &mut MatchStats)
);

/// The backward paths of row `y` (from the row below unless `first`): bottom, bottom-left,
/// bottom-right, added to `acc`.
#[inline(always)]
fn backward_row<const NDQ: usize>(
    sh: &Shared,
    sc: &mut Scratch,
    pp: &SgmParams,
    y: usize,
    first: bool,
    isa: Option<Avx2>,
) {
    let (w, nd) = (sh.w, sh.nd);
    assert!(NDQ == 0 || NDQ == lanes(nd));
    let row = &pp.intensity[y * w..][..w];
    let below = if first { row } else { &pp.intensity[(y + 1) * w..][..w] };
    // the paths rewritten in place, as the forward sweep's (the bottom and bottom-right, eight paths,
    // one thread, 3 interleaved rounds, with the forward sweep's already in place: 1282x1110x224
    // 753–769 → 681–690 ms, teddy 20.35–20.49 → 19.04–19.25 ms)
    let in_place = isa.is_some();
    let s = Sweep::new(sh, sc, pp, row, below, 3, first, in_place);
    for x in 0..w {
        // SAFETY: x < w, the sweep made for three paths; `isa` as the strip's.
        unsafe { s.vertical::<NDQ>(isa, x, w, nd, (pp.p1, pp.p2), 3, false, in_place) };
    }
    sc.end_row(in_place, 3);
}

/// Keeps, per right pixel (reversed index), the smallest `S` and its candidate (first wins).
#[inline(always)]
fn right_update16(c: &[u16], rc: &mut [u16], rk: &mut [u16], lo: usize) {
    for (t, ((&v, rcv), rkv)) in c.iter().zip(rc.iter_mut()).zip(rk.iter_mut()).enumerate() {
        if v < *rcv {
            *rcv = v;
            *rkv = (lo + t) as u16;
        }
    }
}

/// The decisions of row `y` on `S` (in `acc`), as the block matcher's generic path.
#[inline(always)]
fn decide_row<const NDQ: usize>(
    sh: &Shared,
    sc: &mut Scratch,
    y: usize,
    out: &mut [f32],
    conf: &mut [f32],
    st: &mut MatchStats,
    isa: Option<Avx2>,
) {
    let (w, nd, dmin) = (sh.w, sh.nd, sh.dmin);
    let ndq = lanes(nd);
    assert!(NDQ == 0 || NDQ == ndq);
    let ndq = if NDQ > 0 { NDQ } else { ndq };
    sc.rc.fill(u16::MAX);
    sc.rk.fill(u16::MAX);
    // what the vector kernels need, once per row (the winner search's contract: `Dq` a multiple
    // of 16 below 2^15, `tail` of `Dq` lanes; per pixel lo ≤ hi < D ≤ Dq holds by construction)
    assert!(ndq.is_multiple_of(16) && ndq < 1 << 15 && sc.tail.len() == ndq && sc.acc.len() >= w * ndq);
    // the right minima in two copies (`stride` apart): the middle's and the band's pixels
    // alternate between them, so that a pixel's right update does not load the lanes the pixel
    // just before stored, one lane off (a store that is not forwarded, and a load that waits for
    // it to reach the cache: ~40 % of the decisions' samples at tsukuba, perf); the copies are
    // merged at the row's end
    let stride = w + ndq;
    assert!(sc.rc.len() >= 2 * stride && sc.rk.len() >= 2 * stride);
    let (rcp, rkp) = (sc.rc.as_mut_ptr(), sc.rk.as_mut_ptr());
    let texture = sh.texture.as_ref().map(|t| sc.texture.row(t, y));
    // the right image's own minima, for the left–right check unless it reads the left winners
    let minima = sh.lr.is_some() && !sh.lr_winners;
    // one pixel with any range (the edge bands, and every pixel at the scalar level); a macro:
    // pasted before and after the middle's loop (the pixels' order decides the right winners'
    // ties)
    macro_rules! any_range {
        ($x:expr) => {{
            let x = $x;
            let xd = x as i64 - dmin;
            let lo = (xd - (w as i64 - 1)).max(0);
            let hi = xd.min(nd as i64 - 1);
            if lo > hi {
                (sc.best[x], sc.win_k[x]) = (-1, -1);
                st.no_candidate += 1;
                continue;
            }
            let (lo, hi) = (lo as usize, hi as usize);
            let s = &sc.acc[x * ndq..][..ndq];
            let j0 = (w as i64 - 1 - xd + lo as i64) as usize;
            let len = hi - lo + 1;
            let rejected = texture.is_some_and(|t| !t[x]);
            // the right update in the winner search's pass: vector level, the candidates from 0
            // (the left band too: its lanes past `hi` read u16::MAX and leave the right minima
            // unchanged), a winner to search (1282x1110x224, three paths, callgrind: the left
            // band's chunks 38 → 22 instructions)
            let fused = isa.is_some() && minima && lo == 0 && !rejected;
            if minima && !fused {
                // SAFETY: j0 + len ≤ w (the candidates' right pixels), within rc and rk.
                let (rc, rk) = unsafe {
                    (std::slice::from_raw_parts_mut(rcp.add(j0), len), std::slice::from_raw_parts_mut(rkp.add(j0), len))
                };
                let c = &s[lo..=hi];
                #[cfg(target_arch = "x86_64")]
                if let Some(t) = isa {
                    lanes::right_update(t, c, rc, rk, lo);
                }
                if isa.is_none() {
                    right_update16(c, rc, rk, lo);
                }
            }
            if rejected {
                (sc.best[x], sc.win_k[x]) = (-1, -1);
                st.low_texture += 1;
                continue;
            }
            // where the image edge cuts the range, the edge band's margin (it implies the configured
            // one)
            let uniq = if lo > 0 || hi + 1 < nd { sh.uniq.max(sh.edge_uniq) } else { sh.uniq };
            #[cfg(target_arch = "x86_64")]
            if let Some(t) = isa {
                let second = if sh.conf || uniq > 0 { lanes::Second::Min } else { lanes::Second::Skip };
                let right = fused.then(|| (rcp.wrapping_add(j0), rkp.wrapping_add(j0)));
                // SAFETY: `isa` only in the strip's AVX2 instance; `s` and `tail` have Dq lanes,
                // lo ≤ hi < D (asserted above the loop and by the `lo > hi` exit). With `fused`,
                // lo = 0, and rc, rk have Dq lanes from j0 = w − 1 − xd ≤ w − 1 (w + Dq lanes,
                // asserted above the loop).
                let (m, kb, third) = unsafe { lanes::wta_right(t, s, &sc.tail, lo, hi, second, right) };
                // `third`: the smallest S apart from the winner and its neighbours (u16::MAX: none)
                (sc.win_k[x], sc.win_s[x], sc.win_third[x]) = (kb as i32, m, third);
                (sc.win_m[x], sc.win_p[x]) = (s[kb.saturating_sub(1)], s[(kb + 1).min(nd - 1)]);
                continue;
            }
            match decide(&s[..nd], lo, hi, uniq, sh.subpixel, sh.conf) {
                // where the edge cuts the range, a winner without a rival further than one
                // disparity away shows no margin: not unique
                crate::decide::Decision::Best(k, ..)
                    if sh.edge_uniq > 0 && (lo > 0 || hi + 1 < nd) && k as usize <= lo + 1 && k as usize + 1 >= hi =>
                {
                    sc.best[x] = -1;
                    st.not_unique += 1;
                }
                crate::decide::Decision::Best(k, off, ratio) => {
                    sc.best[x] = k;
                    sc.sub[x] = off;
                    sc.ratio[x] = ratio;
                }
                crate::decide::Decision::NotUnique => {
                    sc.best[x] = -1;
                    st.not_unique += 1;
                }
            }
        }};
    }
    // the pixels whose candidates are all in the image (as `cost_row`'s bands): at the vector
    // level, a loop without the range's arithmetic, masks and the uniqueness choice (teddy,
    // three paths, one thread, callgrind: 13.91 → 12.80 instructions an evaluation, and with the
    // search kind and the left–right check hoisted, 12.26 → 11.83)
    let left_end = (dmin + nd as i64 - 1).clamp(0, w as i64) as usize;
    let right_start = (w as i64 + dmin).clamp(left_end as i64, w as i64) as usize;
    // and the left band's pixels with a candidate in the image, from 0 to x − dmin (before
    // the middle: the pixels' order decides the right winners' ties), in a loop of their own
    // when they all have candidate 0 (x − dmin ≤ w − 1), else in `any_range` (teddy, three
    // paths, one thread, callgrind: 7.56 → 7.30 instructions an evaluation, tsukuba 17.28 →
    // 17.05, 1282x1110x224 5.63 → 5.52)
    let (band_start, mid_start, mid_end) = if isa.is_some() {
        let start = dmin.clamp(0, left_end as i64) as usize;
        (if w as i64 + dmin >= left_end as i64 { start } else { left_end }, left_end, right_start)
    } else {
        (w, w, w)
    };
    for x in 0..band_start {
        any_range!(x);
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = isa {
        let (acc, tail) = (&sc.acc[..w * ndq], &sc.tail[..ndq]);
        let (ks, ms, thirds) = (&mut sc.win_k[..w], &mut sc.win_s[..w], &mut sc.win_third[..w]);
        let (cms, cps, best) = (&mut sc.win_m[..w], &mut sc.win_p[..w], &mut sc.best[..w]);
        // the loop pasted for the band and the middle (`$band`), each search (`$second`) and
        // with or without the left–right check (`$lr`): tests of them at every pixel were not
        // hoisted
        // (`nd1`: D − 1 ≤ Dq − 1, so that the neighbours' indices below need no bounds check)
        let nd1 = (nd - 1).min(ndq - 1);
        macro_rules! search {
            ($from:expr, $to:expr, $band:expr, $second:expr, $lr:expr) => {{
                let (from, to) = ($from, $to);
                // (the pixels' sums as chunks: no bounds check per pixel)
                for (x, s) in (from..to).zip(acc[from * ndq..to * ndq].chunks_exact(ndq)) {
                    // the pixel's last candidate: D − 1, or in the band x − dmin < D − 1; the
                    // right pixel of candidate 0, j0 = w − 1 − (x − dmin): candidates 0..=hi
                    // reach j0 + hi ≤ w − 1, and j0 + Dq ≤ w + Dq, within either copy of rc
                    // and rk (the second from `stride`; 2 · stride lanes, asserted above)
                    let xd = x as i64 - dmin;
                    let hi = if $band { xd as usize } else { nd - 1 };
                    let j0 = (w as i64 - 1 - xd) as usize + (x & 1) * stride;
                    if texture.is_some_and(|t| !t[x]) {
                        if $lr {
                            // SAFETY: j0 + hi < w, within rc and rk (as above); `isa` as the
                            // strip's.
                            unsafe {
                                let (rc, rk) = (
                                    std::slice::from_raw_parts_mut(rcp.add(j0), hi + 1),
                                    std::slice::from_raw_parts_mut(rkp.add(j0), hi + 1),
                                );
                                lanes::right_update(t, &s[..=hi], rc, rk, 0);
                            }
                        }
                        (best[x], ks[x]) = (-1, -1);
                        st.low_texture += 1;
                        continue;
                    }
                    let right = $lr.then(|| (rcp.wrapping_add(j0), rkp.wrapping_add(j0)));
                    let (m, kb, third) =
                        // SAFETY: `isa` only in the strip's AVX2 instance; `s` and `tail` have
                        // Dq lanes, lo = 0 ≤ hi < D ≤ Dq, and in the middle (`all`) hi = D − 1
                        // where `tail` marks the lanes past D − 1; with `right`, lo = 0 and rc
                        // and rk have Dq lanes from j0 (as above).
                        unsafe { lanes::wta_in(t, s, tail, 0, hi, !$band, $second, right) };
                    (ks[x], ms[x], thirds[x]) = (kb as i32, m, third);
                    (cms[x], cps[x]) = (s[kb.saturating_sub(1).min(nd1)], s[(kb + 1).min(nd1)]);
                }
            }};
        }
        // the band always searches the rivals: its margin is the edge band's, and without
        // a margin or the confidence the rival is not read
        if minima {
            search!(band_start, mid_start, true, lanes::Second::Min, true);
        } else {
            search!(band_start, mid_start, true, lanes::Second::Min, false);
        }
        match (sh.conf || sh.uniq > 0, minima) {
            (true, true) => search!(mid_start, mid_end, false, lanes::Second::Min, true),
            (true, false) => search!(mid_start, mid_end, false, lanes::Second::Min, false),
            (false, true) => search!(mid_start, mid_end, false, lanes::Second::Skip, true),
            (false, false) => search!(mid_start, mid_end, false, lanes::Second::Skip, false),
        }
    }
    for x in mid_end..w {
        any_range!(x);
    }
    if isa.is_some() {
        decide_winners(sh, sc, st);
    }
    // (at the scalar level every update went to the first copy)
    if minima && isa.is_some() {
        merge_right(&sc.rc, &mut sc.rk, w, stride);
    }
    if sh.lr_winners && sh.lr.is_some() {
        // OpenCV SGBM's right disparities: at right pixel `u` the winner of the left pixel with
        // the smallest `S` among those whose winner matches `u` (the first on a tie)
        left_winners(&sc.best[..w], &sc.acc, ndq, dmin, &mut sc.rc[..w], &mut sc.rk[..w]);
        let rk = &sc.rk[..w];
        let right = WinnersBy(|u: usize| if rk[u] == u16::MAX { u32::MAX } else { rk[u] as u32 });
        finish_row(sh, &sc.best, &mut sc.sub, &sc.ratio, out, conf, st, &mut sc.rw, &right);
        return;
    }
    let right = Reversed::new(&sc.rk, w, isa);
    finish_row(sh, &sc.best, &mut sc.sub, &sc.ratio, out, conf, st, &mut sc.rw, &right);
}

/// The right disparities of OpenCV SGBM's left–right check ([`crate::MatcherConfig::lr_winners`]):
/// for each left pixel `x` with a winner `k = best[x]` (after the uniqueness and texture
/// rejections), its match `u = x − dmin − k` keeps `k` when `S(x, k)` (in `acc`, `ndq` lanes a
/// pixel) is below every earlier one there; `rc[u]`, `rk[u]`: that `S` and `k` (`u16::MAX`: no
/// left winner matches `u`).
#[inline(always)]
fn left_winners(best: &[i32], acc: &[u16], ndq: usize, dmin: i64, rc: &mut [u16], rk: &mut [u16]) {
    let w = rc.len();
    rc.fill(u16::MAX);
    rk.fill(u16::MAX);
    for (x, (&k, s)) in best.iter().zip(acc.chunks_exact(ndq)).enumerate() {
        if k < 0 {
            continue;
        }
        // (a winner's match is inside the right image: 0 ≤ u < w)
        let u = (x as i64 - dmin - k as i64) as usize;
        let v = s[k as usize];
        if u < w && v < rc[u] {
            (rc[u], rk[u]) = (v, k as u16);
        }
    }
}

/// Merges the second copy of the right minima (`stride` on) into the first's candidates for the
/// row's `w` right pixels: the smaller `S`, and at equal `S` the smaller candidate (the one a
/// single copy would have kept: a right pixel's candidates arrive in increasing order). Selects
/// the compiler vectorises.
#[inline(always)]
fn merge_right(rc: &[u16], rk: &mut [u16], w: usize, stride: usize) {
    let (rk, rk2) = rk.split_at_mut(stride);
    let (ca, cb, kb) = (&rc[..w], &rc[stride..][..w], &rk2[..w]);
    for (((k, &a), &b), &k2) in rk[..w].iter_mut().zip(ca).zip(cb).zip(kb) {
        let second = (b < a) | ((b == a) & (k2 < *k));
        *k = if second { k2 } else { *k };
    }
}

/// The right image's winners of a row as the decisions keep them: right pixel `u`'s candidate
/// at `rk[w − 1 − u]` (`u16::MAX`: none).
struct Reversed<'a> {
    /// At least `w + 1` entries (the vector gather reads a 32-bit lane at `w − 1`).
    rk: &'a [u16],
    w: usize,
    /// Gather with AVX2.
    avx2: Option<Avx2>,
}

impl<'a> Reversed<'a> {
    /// `avx2`: gather with AVX2 (the caller at the vector level, compiled for it, so that the
    /// intrinsics are inlined).
    #[inline(always)]
    fn new(rk: &'a [u16], w: usize, avx2: Option<Avx2>) -> Self {
        assert!(rk.len() > w && w < 1 << 30);
        Self { rk, w, avx2 }
    }
}

impl RightWinners for Reversed<'_> {
    #[inline(always)]
    fn at(&self, u: usize) -> u32 {
        // (u < w: the index is below w, inside rk)
        self.rk[self.w - 1 - u] as u32
    }

    /// Eight pixels a step with AVX2 (the scalar gather took 19 instructions a pixel: tsukuba,
    /// three paths, callgrind), the rest lane by lane.
    #[inline(always)]
    fn gather(&self, best: &[i32], dmin: i64, rw: &mut [u32]) {
        let mut from = 0;
        #[cfg(target_arch = "x86_64")]
        if let Some(t) = self.avx2 {
            assert!(best.len() == self.w && rw.len() == self.w);
            // SAFETY: the token proves AVX2; rk has more than w entries and w < 2^30 (`new`),
            // best and rw w (asserted above).
            from = unsafe { gather_reversed_avx2(t, self.rk, best, dmin, rw) };
        }
        gather_from(self, best, dmin, rw, from);
    }
}

/// [`Reversed::gather`] for the first `w / 8 · 8` pixels: per pixel the 32-bit word at the
/// `u16` index `w − 1 − u` (scale 2), its low half kept; returns the pixels done.
///
/// # Safety
/// The token proves AVX2 (which the intrinsics need); `rk.len() > w` (the word at index `w − 1` ends inside), `best.len() =
/// rw.len() = w < 2^30`; `|dmin| ≤ 2^20` and `best[x] < 2^16` (validated ranges), so that
/// `x − dmin − k` fits `i32`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn gather_reversed_avx2(_t: Avx2, rk: &[u16], best: &[i32], dmin: i64, rw: &mut [u32]) -> usize {
    use std::arch::x86_64::*;
    let w = rw.len();
    // SAFETY: x + 8 ≤ w for the loads and stores of best and rw; every gathered index
    // w − 1 − u lies in 0..=w − 1 (u clamped to 0..=w − 1), its word within rk (the caller's).
    unsafe {
        let (zero, wm1) = (_mm256_setzero_si256(), _mm256_set1_epi32(w as i32 - 1));
        let (low, eight) = (_mm256_set1_epi32(0xFFFF), _mm256_set1_epi32(8));
        // x − dmin for the step's eight pixels
        let mut xd = _mm256_sub_epi32(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32(dmin as i32));
        let mut x = 0;
        while x + 8 <= w {
            let k = _mm256_max_epi32(_mm256_loadu_si256(best.as_ptr().add(x).cast()), zero);
            let u = _mm256_min_epi32(_mm256_max_epi32(_mm256_sub_epi32(xd, k), zero), wm1);
            let g = _mm256_i32gather_epi32::<2>(rk.as_ptr().cast(), _mm256_sub_epi32(wm1, u));
            _mm256_storeu_si256(rw.as_mut_ptr().add(x).cast(), _mm256_and_si256(g, low));
            (xd, x) = (_mm256_add_epi32(xd, eight), x + 8);
        }
        x
    }
}

/// The decisions of a row from the vector winner search's results (`Scratch::win_*`), as
/// [`decide`] makes them from the costs: the uniqueness rule (the edge band's margin where
/// the image edge cuts the range), the sub-pixel fit and the confidence ratio. Branch-free
/// selects over the row, which the compiler vectorises (made per pixel after each search, with
/// the fit in `f64`: teddy, three paths, one thread, callgrind, 15.33 → 14.78 instructions an
/// evaluation, 35 a pixel). The fit in `f32` gives the same offsets: numerator and denominator
/// are integers below 2^19 in magnitude, exact in `f32`, and one rounding of their quotient in
/// `f32` equals its rounding in `f64` then to `f32` (such a quotient is never within 2^-53 of
/// an `f32` rounding midpoint without being one, and then it is exact in `f32`).
#[inline(always)]
fn decide_winners(sh: &Shared, sc: &mut Scratch, st: &mut MatchStats) {
    let (w, nd, dmin) = (sh.w, sh.nd as i64, sh.dmin);
    let (equi, fit_on) = (sh.subpixel == Subpixel::Equiangular, sh.subpixel != Subpixel::None);
    let (uniq, edge_uniq) = (sh.uniq, sh.uniq.max(sh.edge_uniq));
    let (ks, ms, thirds) = (&sc.win_k[..w], &sc.win_s[..w], &sc.win_third[..w]);
    let (cms, cps) = (&sc.win_m[..w], &sc.win_p[..w]);
    let (best, sub) = (&mut sc.best[..w], &mut sc.sub[..w]);
    let mut not_unique = 0u32;
    for x in 0..w {
        let xd = x as i64 - dmin;
        let (lo, hi) = ((xd - (w as i64 - 1)).max(0), xd.min(nd - 1));
        let k = ks[x];
        let valid = k >= 0;
        let (m, third) = (ms[x] as u32, thirds[x]);
        let edge = (lo > 0) | (hi + 1 < nd);
        let u = if edge { edge_uniq } else { uniq };
        let t = (m as u16).uniq_thresh(u);
        // where the edge cuts the range, a winner without a rival further than one disparity
        // away (`third` u16::MAX) shows no margin: not unique
        let rival = third != u16::MAX;
        let nu = valid & (u > 0) & ((rival & (third <= t)) | (!rival & edge & (sh.edge_uniq > 0)));
        not_unique += nu as u32;
        best[x] = if valid & !nu { k } else { -1 };
        let (cm, c0, cp) = (cms[x] as f32, m as f32, cps[x] as f32);
        let den = if equi { cm.max(cp) - c0 } else { cm - 2.0 * c0 + cp };
        let fit = fit_on & valid & (k as i64 > lo) & ((k as i64) < hi) & (den > 0.0);
        let q = ((cm - cp) / (2.0 * if fit { den } else { 1.0 })).clamp(-0.5, 0.5);
        // (a pixel without a winner keeps its offset unread)
        sub[x] = if fit { q } else { 0.0 };
    }
    st.not_unique += not_unique as usize;
    if sh.conf {
        for x in 0..w {
            let third = sc.win_third[x];
            sc.ratio[x] = curve_ratio(sc.win_s[x] as f64, (third != u16::MAX).then_some(third as f64));
        }
    }
}

/// Rows `y0..y1` of one strip.
#[inline(always)]
fn strip(
    sh: &Shared,
    pp: &SgmParams,
    sc: &mut Scratch,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
    isa: Option<Avx2>,
) -> MatchStats {
    let (w, h) = (sh.w, sh.h);
    let nd = lanes(sh.nd);
    let eight = pp.paths == SgmPaths::Eight;
    sc.resize(sh, y1 - y0, pp.overlap, pp.paths, pp.bt, isa.is_some());
    let mut st = MatchStats::default();
    let ys = y0.saturating_sub(pp.overlap);
    colsum_init(sh, pp, sc, ys, isa);
    for y in ys..y1 {
        let boxed = y > ys && colsum_move(sh, pp, sc, y - 1, true, isa);
        cost_row(sh, sc, pp.cmax, boxed, isa);
        if y < y0 {
            carry_row_any(sh, sc, pp, y, y == ys, isa);
            continue;
        }
        forward_row_any(sh, sc, pp, y, y == ys, isa);
        if eight {
            sc.vol[(y - y0) * w * nd..][..w * nd].copy_from_slice(&sc.acc);
        } else {
            decide_row_any(sh, sc, y, &mut out[(y - y0) * w..][..w], conf_row(sh, conf, y, y0), &mut st, isa);
        }
    }
    if eight {
        let ye = (y1 + pp.overlap).min(h);
        colsum_init(sh, pp, sc, ye - 1, isa);
        for y in (y0..ye).rev() {
            let boxed = y + 1 < ye && colsum_move(sh, pp, sc, y + 1, false, isa);
            cost_row(sh, sc, pp.cmax, boxed, isa);
            if y < y1 {
                sc.acc.copy_from_slice(&sc.vol[(y - y0) * w * nd..][..w * nd]);
            } else {
                sc.acc.fill(0);
            }
            backward_row_any(sh, sc, pp, y, y + 1 == ye, isa);
            if y < y1 {
                decide_row_any(sh, sc, y, &mut out[(y - y0) * w..][..w], conf_row(sh, conf, y, y0), &mut st, isa);
            }
        }
    }
    st
}

/// Rows `y0..y1` of one strip, compiled for the instruction set of `simd` (the same code; the
/// AVX-512 level runs the AVX2 kernels here, see `SimdLevel::Avx512`).
pub(crate) fn run_strip(
    sh: &Shared,
    pp: &SgmParams,
    sc: &mut Scratch,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
    simd: SimdLevel,
) -> MatchStats {
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = Avx2::at_most(simd) {
        // [`strip`] compiled for AVX2 (the token proves the CPU runs it)
        return t.vectorize(
            #[inline(always)]
            || strip(sh, pp, sc, out, conf, y0, y1, Some(t)),
        );
    }
    strip(sh, pp, sc, out, conf, y0, y1, None)
}

/// The SGM kernels written once over the lanes of `parallax_simd` ([`parallax_simd::U16x16`]: 16
/// lanes of `u16` in 256 bits, made by an [`Avx2`] token) and compiled for AVX2 by the thin
/// `avx2` entry points below. The
/// compiler did not vectorise the scalar path step (measured: teddy 450x375x64, five paths,
/// ~150 ms, the inner loop scalar).
#[cfg(target_arch = "x86_64")]
mod lanes {
    use parallax_simd::{Avx2, U16x16};

    /// Checks the lengths [`vertical`] needs (the entry points assert them before any
    /// unchecked access).
    pub(super) fn vertical_checked(colsum: &[u16], rows: Rows, bt: Option<BtRows>, ndq: usize, sub: bool) {
        let (la, ra, lb, rb) = rows;
        let wp = la.len();
        assert!(ndq.is_multiple_of(16) && colsum.len() >= wp * ndq && ra.len() + 1 >= wp + ndq);
        assert!(!sub || (lb.len() >= wp && rb.len() + 1 >= wp + ndq));
        if let Some((a, b)) = bt {
            for (i, v) in a.iter().chain(if sub { &b[..] } else { &[] }).enumerate() {
                assert!(if i % 4 < 2 { v.len() >= wp } else { v.len() + 1 >= wp + ndq });
            }
        }
    }

    /// The rows `l_a`, `r_a`, `l_b`, `r_b` of [`vertical`].
    pub(super) type Rows<'a> = (&'a [u16], &'a [u16], &'a [u16], &'a [u16]);
    /// Their Birchfield–Tomasi intervals (left `I⁻`, `I⁺`, right `I⁻`, `I⁺`), rows a and b.
    pub(super) type BtRows<'a> = ([&'a [u16]; 4], [&'a [u16]; 4]);
    /// Rows a and b as byte pairs ([`Scratch::pairs`](super::Scratch)): the right rows' (values,
    /// with the intervals `I⁻`, `I⁺`, and a second term's values), the left rows' likewise.
    pub(super) type Pairs<'a> = ([&'a [u8]; 4], [&'a [u16]; 4]);

    /// Checks the lengths [`box_row`] needs (the entry points assert them before any
    /// unchecked access).
    pub(super) fn box_row_checked(cost: &[u16], colsum: &[u16], w: usize, r: usize, ndq: usize) {
        assert!(ndq.is_multiple_of(16) && w > 0 && cost.len() >= w * ndq && colsum.len() >= (w + 2 * r) * ndq);
    }

    /// The vector the kernels are written over: 16 lanes of `u16`, made by an [`Avx2`] token.
    type V = U16x16;
    /// Lanes per vector.
    pub(super) const LANES: usize = 16;

    /// [`super::paths`] on all `Dq` lanes: per chunk of every path, the minimum of `L(d)`,
    /// `L(d ± 1) + P1` (saturating) and `min L + P2'`, minus `min L`, plus `C` (saturating: the
    /// cost's lanes `d ≥ D` hold `PAD`, and so do the new vectors' there, without a mask per
    /// path; below, `C + P2` stays under `PAD`); `acc` replaced with (`SET`) or increased by
    /// the sum of the paths. Returns each path's minimum over the lanes.
    ///
    /// With `IN_PLACE`, a path after the first `H` may write over its predecessor (`out[i] =
    /// prev[i]`): a chunk stores slots `d + 1 ..= d + LANES` after its three loads (slots from
    /// `d`, `d + 1`, `d + 2`), and the next chunk's first load, slot `d + LANES`, is taken before
    /// that store and carried; its other loads start past the store (see `forward_row` for what
    /// writing the new vectors to a second row-sized buffer cost).
    ///
    /// # Safety
    /// `c`, `acc` have `Dq` entries (a positive multiple of `LANES`) and
    /// every `prev[i]` and `out[i]` `Dq + 2` (the callers assert it); no `out[i]` overlaps an
    /// input or another output, but with `IN_PLACE` one after the first `H` may equal `prev[i]`.
    #[cfg_attr(not(opt_level_zero), inline(always))]
    #[allow(clippy::too_many_arguments)] // the step's inputs and outputs
    pub(super) unsafe fn paths<const N: usize, const H: usize, const SET: bool, const IN_PLACE: bool>(
        t: Avx2,
        c: &[u16],
        prev: [*const u16; N],
        pmin: [u16; N],
        p2: [u16; N],
        p1: u16,
        out: [*mut u16; N],
        acc: &mut [u16],
    ) -> [u16; N] {
        // The first `H` paths (horizontal) load each predecessor chunk once, at the offset
        // its own step stored it (slot d + 1: a store the path's next pixel reads at once is
        // forwarded only to a load at its own address); its neighbours d ∓ 1 come from the
        // chunks on either side through lane moves. The other paths' predecessors were stored
        // a row before: they load slots d, d + 1 and d + 2 (three loads instead of one load and
        // four lane moves; callgrind, one thread: accurate preset on teddy 38.6 → 35.4
        // instructions an evaluation, three paths on 1282x1110x224 3.28 → 3.20 G a frame;
        // times: the preset 2–10 % faster against OpenCV's MODE_HH, three paths unchanged).
        // SAFETY: (all loads and stores) d + LANES ≤ Dq, and the padded vectors have Dq + 2
        // entries: slots d + 1 .. d + 1 + LANES are inside; the carried load (`IN_PLACE`) runs
        // when d + LANES < Dq, both multiples of LANES, so its slots end at d + 2 · LANES − 1 <
        // Dq.
        unsafe {
            let ndq = c.len();
            let p1v = t.splat(p1);
            let pad = t.splat(super::PAD);
            let pm: [V; N] = std::array::from_fn(|i| t.splat(pmin[i]));
            // (`min L + P2'` in the vectors: the compiler then keeps the previous pixel's
            // minimum in a vector register from its `hmin`, where the scalar sum cost it a move
            // out, the sum and a broadcast back; three paths, one thread, callgrind, with the
            // search's one-compare key: tsukuba 19.00 → 17.62, venus 11.39 → 10.94, teddy 7.94 →
            // 7.68 instructions an evaluation)
            let jump: [V; N] = std::array::from_fn(|i| V::adds(pm[i], t.splat(p2[i])));
            let mut mv = [t.splat(u16::MAX); N];
            // the lanes just outside 0..Dq: slots 0 and Dq + 1 (PAD)
            let mut before = [pad; N];
            let mut cur: [V; N] = std::array::from_fn(|i| t.load_ptr(prev[i].add(1)));
            // (`IN_PLACE`: each vertical path's next first load, taken before the store)
            let mut carried = [pad; N];
            // one chunk at d with the predecessors' next chunks `next`. A macro, not a closure:
            // a closure is compiled without the caller's instruction set unless inlined.
            macro_rules! chunk {
                ($d:expr, $next:expr) => {{
                    let d = $d;
                    let next: [V; N] = $next;
                    let cv = t.load_ptr(c.as_ptr().add(d));
                    let mut sum = if SET { t.splat(0) } else { t.load_ptr(acc.as_ptr().add(d)) };
                    for i in 0..N {
                        let (a, b, e) = if i < H {
                            (cur[i].up(before[i]), cur[i], cur[i].down(next[i]))
                        } else {
                            let p = prev[i].add(d);
                            let a = if IN_PLACE && d > 0 { carried[i] } else { t.load_ptr(p) };
                            let (b, e) = (t.load_ptr(p.add(1)), t.load_ptr(p.add(2)));
                            if IN_PLACE && d + LANES < ndq {
                                carried[i] = t.load_ptr(p.add(LANES));
                            }
                            (a, b, e)
                        };
                        // min(a + P1, e + P1) = min(a, e) + P1 (saturating addition is monotone)
                        let best = V::min(V::min(b, jump[i]), V::adds(V::min(a, e), p1v));
                        // (best ≥ min L: no wrap)
                        let v = V::adds(cv, V::wrapping_sub(best, pm[i]));
                        t.store_ptr(out[i].add(d + 1), v);
                        mv[i] = V::min(mv[i], v);
                        sum = V::wrapping_add(sum, v);
                        (before[i], cur[i]) = (cur[i], next[i]);
                    }
                    t.store_ptr(acc.as_mut_ptr().add(d), sum);
                }};
            }
            let next = |d: usize| -> [V; N] { std::array::from_fn(|i| t.load_ptr(prev[i].add(d + 1 + LANES))) };
            // the chunks before the last three at a time: the horizontal paths' `before`,
            // `cur` and `next` then come back to the registers they started in, without the
            // moves a loop of one chunk made (three paths, one thread, callgrind: teddy 11.31 → 10.99
            // instructions an evaluation)
            let mut d = 0;
            for _ in 0..(ndq / LANES - 1) / 3 {
                chunk!(d, next(d));
                chunk!(d + LANES, next(d + LANES));
                chunk!(d + 2 * LANES, next(d + 2 * LANES));
                d += 3 * LANES;
            }
            while d + LANES < ndq {
                chunk!(d, next(d));
                d += LANES;
            }
            chunk!(d, [pad; N]);
            std::array::from_fn(|i| mv[i].horizontal_min())
        }
    }

    /// [`super::vertical`] on lanes `from..to` of every column: `colsum[xp] += |l_a[xp] −
    /// r_a[base + d]|` (and, with `SUB`, `−= |l_b[xp] − r_b[base + d]|`), wrapping lanes.
    /// With `PAIRS` (`SUB`, every pixel below 128), both differences at once from the rows as
    /// byte pairs ([`Scratch::pairs`](super::Scratch)): `pairs.0` the right rows' (`r_a` the
    /// low byte), `pairs.1` the left rows' (`l_a[xp] | l_b[xp] << 8`), with `BT` their
    /// intervals' too, and with `EXTRA` (`BT`) a second term's `|L − R|` added in the same pass
    /// from the fourth pairs.
    ///
    /// Lengths are checked once (as `vertical_checked` and `box_row_checked`).
    #[cfg_attr(not(opt_level_zero), inline(always))]
    #[allow(clippy::too_many_arguments)] // both row pairs, the lane count and range
    pub(super) fn vertical<const BT: bool, const SUB: bool, const PAIRS: bool, const EXTRA: bool>(
        t: Avx2,
        colsum: &mut [u16],
        rows: Rows,
        bt: Option<BtRows>,
        pairs: Option<Pairs>,
        ndq: usize,
        cost: Option<(&mut [u16], usize)>,
        (from, to): (usize, usize),
    ) {
        vertical_checked(colsum, rows, bt, ndq, SUB);
        let (la, ra, lb, rb) = rows;
        let wp = la.len();
        assert!(from <= to && to <= ndq && (to - from).is_multiple_of(LANES));
        // the byte pairs only for the differences of both rows (the intervals' too with `BT`)
        assert!(PAIRS == pairs.is_some());
        assert!(!EXTRA || (BT && PAIRS));
        let used: &[usize] = match (BT, EXTRA) {
            (true, true) => &[0, 1, 2, 3],
            (true, false) => &[0, 1, 2],
            _ => &[0],
        };
        assert!(pairs.is_none_or(|(p, l)| {
            SUB && used.iter().all(|&i| p[i].len() + 2 >= 2 * (wp + ndq) && l[i].len() >= wp)
        }));
        let pairs = pairs.map_or(([std::ptr::null(); 4], [std::ptr::null(); 4]), |(p, l)| {
            (p.map(|v| v.as_ptr()), l.map(|v| v.as_ptr()))
        });
        let boxed = cost.map(|(cost, r)| {
            assert!(wp > 2 * r);
            box_row_checked(cost, colsum, wp - 2 * r, r, ndq);
            (cost.as_mut_ptr(), r)
        });
        let cs = colsum.as_mut_ptr();
        let empty: [&[u16]; 4] = [&[]; 4];
        let (bta, btb) = bt.unwrap_or((empty, empty));
        // one row's difference at column xp (left value and interval splatted), lanes d..
        let diff = |u: V, u0: V, u1: V, r: &[u16], bt: &[&[u16]; 4], base: usize| -> V {
            // SAFETY: base + d + LANES ≤ wp − 1 + ndq, within r and the right intervals
            // (asserted on entry).
            unsafe {
                let v = t.load_ptr(r.as_ptr().add(base));
                if BT {
                    let (v0, v1) = (t.load_ptr(bt[2].as_ptr().add(base)), t.load_ptr(bt[3].as_ptr().add(base)));
                    // distance to an interval: at most one of the two saturating differences is
                    // non-zero, so their `or` is their maximum
                    V::min(V::or(V::subs(u, v1), V::subs(v0, u)), V::or(V::subs(v, u1), V::subs(u0, v)))
                } else {
                    V::abs_diff(u, v)
                }
            }
        };
        let splat3 = |l: &[u16], bt: &[&[u16]; 4], xp: usize| {
            if BT {
                (t.splat(l[xp]), t.splat(bt[0][xp]), t.splat(bt[1][xp]))
            } else {
                (t.splat(l[xp]), t.splat(0), t.splat(0))
            }
        };
        // one column's update, then `$after` on each new chunk of sums (`$d`: its first lane,
        // `$v`: the chunk) in the same pass; pasted into the loops with and without the box
        // sums (a macro: a closure called from both loops was not inlined, so lost AVX2), so
        // the column loop keeps no test of `boxed` (and the registers it would hold)
        macro_rules! column {
            ($xp:expr) => {
                column!($xp, |_d, _v| {})
            };
            ($xp:expr, |$d:ident, $v:ident| $after:block) => {{
                let xp = $xp;
                let base = wp - 1 - xp;
                if PAIRS {
                    // SAFETY: xp < wp, within the left pairs; the right pairs' bytes
                    // 2(base + d) .. 2(base + d + LANES) ≤ 2(wp − 1 + ndq), and the column sums
                    // as below; `$after`'s (asserted on entry; the intervals' pairs with `BT`).
                    unsafe {
                        let [lp, lp0, lp1, le] = if BT {
                            let le = if EXTRA { t.splat(*pairs.1[3].add(xp)) } else { t.splat(0) };
                            [t.splat(*pairs.1[0].add(xp)), t.splat(*pairs.1[1].add(xp)), t.splat(*pairs.1[2].add(xp)), le]
                        } else {
                            [t.splat(*pairs.1[0].add(xp)), t.splat(0), t.splat(0), t.splat(0)]
                        };
                        let mut d = from;
                        while d < to {
                            let p = cs.add(xp * ndq + d);
                            let at = |i: usize| pairs.0[i].add(2 * (base + d));
                            let diff = if BT {
                                t.pair_bt_difference(lp, lp0, lp1, at(0), at(1), at(2), EXTRA.then(|| (le, at(3))))
                            } else {
                                t.pair_difference(lp, at(0))
                            };
                            let v = V::wrapping_add(t.load_ptr(p), diff);
                            t.store_ptr(p, v);
                            let ($d, $v) = (d, v);
                            $after
                            d += LANES;
                        }
                    }
                } else {
                    let (ua, ua0, ua1) = splat3(la, &bta, xp);
                    let zero = t.splat(0);
                    let (ub, ub0, ub1) = if SUB { splat3(lb, &btb, xp) } else { (zero, zero, zero) };
                    let mut d = from;
                    while d < to {
                        // SAFETY: xp·ndq + d + LANES ≤ wp·ndq (asserted on entry);
                        // `$after`'s.
                        unsafe {
                            let p = cs.add(xp * ndq + d);
                            let mut v = V::wrapping_add(t.load_ptr(p), diff(ua, ua0, ua1, ra, &bta, base + d));
                            if SUB {
                                v = V::wrapping_sub(v, diff(ub, ub0, ub1, rb, &btb, base + d));
                            }
                            t.store_ptr(p, v);
                            let ($d, $v) = (d, v);
                            $after
                        }
                        d += LANES;
                    }
                }
            }};
        }
        let Some((c, r)) = boxed else {
            for xp in 0..wp {
                column!(xp);
            }
            return;
        };
        for xp in 0..wp {
            if xp > 2 * r {
                // the box sum of pixel x = xp − 2r (its window's last column complete) from
                // x − 1's, with the new column in the register (one pass over the chunks, not
                // two: 1282x1110x224, three paths, one thread, callgrind: 7.03 → 6.67 instructions an
                // evaluation)
                let x = xp - 2 * r;
                // (SAFETY, in `column`'s unsafe block: x·ndq + d + LANES ≤ (wp − 2r)·ndq lanes
                // of cost, and the column sums as above, asserted on entry)
                column!(xp, |d, v| {
                    let run = V::wrapping_add(t.load_ptr(c.add((x - 1) * ndq + d)), v);
                    t.store_ptr(c.add(x * ndq + d), V::wrapping_sub(run, t.load_ptr(cs.add((x - 1) * ndq + d))));
                });
                continue;
            }
            column!(xp);
            if xp < 2 * r {
                continue;
            }
            // pixel 0: its window's 2r + 1 columns
            let mut d = from;
            while d < to {
                // SAFETY: d + LANES ≤ ndq lanes of cost, and the column sums as above (asserted on
                // entry).
                unsafe {
                    let mut acc = t.splat(0);
                    for k in 0..=2 * r {
                        acc = V::wrapping_add(acc, t.load_ptr(cs.add(k * ndq + d)));
                    }
                    t.store_ptr(c.add(d), acc);
                }
                d += LANES;
            }
        }
    }

    /// The box sums of a row on lanes `from..to`: `cost[x] = Σ colsum[x ..= x + 2r]`, running
    /// along the row (lengths checked once, as `box_row_checked`).
    #[cfg_attr(not(opt_level_zero), inline(always))]
    pub(super) fn box_row(
        t: Avx2,
        cost: &mut [u16],
        colsum: &[u16],
        w: usize,
        r: usize,
        ndq: usize,
        (from, to): (usize, usize),
    ) {
        box_row_checked(cost, colsum, w, r, ndq);
        assert!(from <= to && to <= ndq && (to - from).is_multiple_of(LANES));
        let (c, cs) = (cost.as_mut_ptr(), colsum.as_ptr());
        // SAFETY: offsets below (w + 2r)·ndq in colsum and w·ndq in cost (asserted above).
        unsafe {
            let mut d = from;
            while d < to {
                let mut acc = t.splat(0);
                for xp in 0..=2 * r {
                    acc = V::wrapping_add(acc, t.load_ptr(cs.add(xp * ndq + d)));
                }
                t.store_ptr(c.add(d), acc);
                d += LANES;
            }
            for x in 1..w {
                let mut d = from;
                while d < to {
                    let v = V::wrapping_sub(
                        V::wrapping_add(
                            t.load_ptr(c.add((x - 1) * ndq + d)),
                            t.load_ptr(cs.add((x + 2 * r) * ndq + d)),
                        ),
                        t.load_ptr(cs.add((x - 1) * ndq + d)),
                    );
                    t.store_ptr(c.add(x * ndq + d), v);
                    d += LANES;
                }
            }
        }
    }

    /// Lane masks: 32 all-ones lanes, 32 zero lanes, 32 all-ones lanes. Loaded at `32 − n`:
    /// ones in the first `n` lanes; at `64 − n`: ones from lane `n` on (`n ≤ 32`).
    static EDGES: [u16; 96] = {
        let mut t = [0u16; 96];
        let mut k = 0;
        while k < 96 {
            t[k] = if k < 32 || k >= 64 { u16::MAX } else { 0 };
            k += 1;
        }
        t
    };
    /// Lane numbers `0..32`.
    static RAMP: [u16; 32] = {
        let mut t = [0u16; 32];
        let mut k = 0;
        while k < 32 {
            t[k] = k as u16;
            k += 1;
        }
        t
    };

    /// All ones in the lanes of the chunk starting at candidate `d` that lie outside `lo..=hi`
    /// (offsets 32 − below ≥ 16 and 64 − within ≥ 48, plus 16 lanes, inside EDGES' 96).
    #[inline(always)]
    fn outside(t: Avx2, d: usize, lo: usize, hi: usize) -> V {
        let below = lo.saturating_sub(d).min(LANES);
        let within = (hi + 1).saturating_sub(d).min(LANES);
        V::or(t.load(&EDGES[32 - below..]), t.load(&EDGES[64 - within..]))
    }

    /// Checks the lengths [`wta_right`] needs (the tests' entry; `decide_row` asserts them once per
    /// row).
    #[cfg(test)]
    pub(super) fn wta_checked(s: &[u16], tail: &[u16], lo: usize, hi: usize) {
        let n = s.len();
        assert!(LANES <= 32 && n.is_multiple_of(LANES) && tail.len() == n && lo <= hi && hi < n && n < 1 << 15);
    }

    /// What [`wta_right`] finds besides the winner, among the candidates other than the winner and
    /// its two neighbours (its third value).
    #[derive(Clone, Copy)]
    pub(super) enum Second {
        /// Nothing (`0`).
        Skip,
        /// Their smallest `S` (`u16::MAX`: none).
        Min,
    }

    /// The smallest `S` over candidates `lo..=hi`, its first candidate, and what `second`
    /// asks for. Lanes outside `lo..=hi` (and the padding lanes past `D`) read as `u16::MAX`,
    /// which no sum reaches (the run refuses sums that could). `tail`: all ones in the lanes
    /// `d ≥ D`, zero below (the mask of a pixel whose candidates are all in the image).
    ///
    /// With `right = Some((rc, rk))` (and `lo = 0`), also [`right_update`] of the pixel's
    /// candidates `0..=hi` in the same pass over `S` (measured: ~10 instructions a chunk less
    /// than two passes): `rc`, `rk` address the right pixels of candidates `0..Dq` (reversed
    /// index, as `right_update`'s slices start at candidate `lo`); the lanes past `hi` read
    /// `u16::MAX`, so they leave them unchanged.
    ///
    /// # Safety
    /// `s` and `tail` have `Dq` lanes (a multiple of `LANES` below
    /// 2^15) and `lo ≤ hi < Dq` (what the tests' `wta_checked` asserts); with `right`, `lo = 0`
    /// and `rc`, `rk` address `Dq` writable lanes each.
    #[inline(always)]
    pub(super) unsafe fn wta_right(
        t: Avx2,
        s: &[u16],
        tail: &[u16],
        lo: usize,
        hi: usize,
        second: Second,
        right: Option<(*mut u16, *mut u16)>,
    ) -> (u16, usize, u16) {
        // every candidate in the image (most pixels): the lanes past hi are those `tail` marks
        let all = lo == 0 && tail[hi] == 0 && (hi + 1 == tail.len() || tail[hi + 1] != 0);
        // SAFETY: the caller's; `all` as computed.
        unsafe { wta_in(t, s, tail, lo, hi, all, second, right) }
    }

    /// [`wta_right`] told whether every candidate is in the image (`all`: `lo = 0` and the
    /// lanes past `hi` are those `tail` marks), for a caller that knows it for a whole range
    /// of pixels (the test per pixel is two loads and four branches).
    ///
    /// # Safety
    /// [`wta_right`]'s, and `all` true only where the above holds.
    #[cfg_attr(not(opt_level_zero), inline(always))]
    #[allow(clippy::too_many_arguments)] // wta_right's, and what it would compute
    pub(super) unsafe fn wta_in(
        t: Avx2,
        s: &[u16],
        tail: &[u16],
        lo: usize,
        hi: usize,
        all: bool,
        second: Second,
        right: Option<(*mut u16, *mut u16)>,
    ) -> (u16, usize, u16) {
        // (with `all`, 0 and `Dq`: hi = D − 1 is in the last chunk; a constant when the caller's
        // `Dq` is)
        let (c0, c1) = if all { (0, tail.len()) } else { (lo / LANES * LANES, (hi / LANES + 1) * LANES) };
        debug_assert!(all == (lo == 0 && tail[hi] == 0 && (hi + 1 == tail.len() || tail[hi + 1] != 0)));
        debug_assert!(right.is_none() || lo == 0);
        // SAFETY: chunks d .. d + LANES ≤ c1 ≤ s.len() = tail.len() (and within rc, rk: the
        // caller's).
        unsafe {
            // the lanes outside lo..=hi lie in the first and the last chunk only (with `all`, in
            // the last, where `tail` marks them): the chunks between are read without a mask
            // (1282x1110x224, three paths, callgrind: the search's chunk 19 → 17 instructions
            // with the candidate counter below; with the band's fused update, the decisions
            // 1.98 → 1.61 instructions an evaluation)
            let masked = |d: usize| {
                let mask = if all { t.load_ptr(tail.as_ptr().add(d)) } else { outside(t, d, lo, hi) };
                V::or(t.load_ptr(s.as_ptr().add(d)), mask)
            };
            // per lane, the smallest S, its first candidate (strictly smaller replaces) and (for
            // `Second::Min`) the second smallest S (equal to the smallest when it occurs twice);
            // `k`: the chunk's candidates
            let step = t.splat(LANES as u16);
            let (mut mv, mut iv, mut m2) = (t.splat(u16::MAX), t.splat(0), t.splat(u16::MAX));
            let mut k = V::wrapping_add(t.load_ptr(RAMP.as_ptr()), t.splat(c0 as u16));
            let two = matches!(second, Second::Min);
            // one chunk `$v` at `$d` (candidates `k`), and with `$right` the right update; a macro, pasted in the
            // two loops (one loop with the update under a test per chunk measured 4 % more
            // instructions a frame: 1282x1110x224, three paths, callgrind)
            macro_rules! chunk {
                ($d:expr, $v:expr, $right:expr) => {{
                    let v = $v;
                    // v ≥ mv ⟺ min(mv, v) = mv: a compare on the new minimum (`less` is three
                    // operations)
                    let (nm, old) = (V::min(mv, v), mv);
                    iv = V::select(V::eq(nm, old), iv, k);
                    if two {
                        m2 = V::min(m2, V::max(old, v));
                    }
                    mv = nm;
                    if let Some((rc, rk)) = $right {
                        let (rc, rk): (*mut u16, *mut u16) = (rc, rk);
                        // (v ≥ r likewise: the right pixel keeps its candidate; a masked lane,
                        // u16::MAX, leaves it unchanged)
                        let r = t.load_ptr(rc.add($d));
                        let nr = V::min(r, v);
                        t.store_ptr(rc.add($d), nr);
                        t.store_ptr(rk.add($d), V::select(V::eq(nr, r), t.load_ptr(rk.add($d)), k));
                    }
                }};
            }
            macro_rules! search {
                ($right:expr) => {{
                    let mut d = c0;
                    if !all && lo > c0 && d + LANES < c1 {
                        chunk!(d, masked(d), $right);
                        (d, k) = (d + LANES, V::wrapping_add(k, step));
                    }
                    while d + LANES < c1 {
                        chunk!(d, t.load_ptr(s.as_ptr().add(d)), $right);
                        (d, k) = (d + LANES, V::wrapping_add(k, step));
                    }
                    chunk!(d, masked(d), $right);
                }};
            }
            match right {
                None => search!(None::<(*mut u16, *mut u16)>),
                Some(r) => search!(Some(r)),
            }
            let m = mv.horizontal_min();
            // the first candidate holding the minimum: the smallest of the lanes' first
            // candidates among the lanes whose minimum it is (mv = m: one compare, as mv ≥ m in
            // every lane; the others masked to u16::MAX), without a branch on where it is (a
            // data-dependent exit mispredicted)
            let first = iv;
            let key = V::select(V::eq(mv, t.splat(m)), first, t.splat(u16::MAX));
            let kb = key.horizontal_min() as usize;
            match second {
                Second::Skip => (m, kb, 0),
                Second::Min => {
                    // Each lane holds at most one of kb − 1, kb, kb + 1 (consecutive
                    // candidates), and without it its smallest S is its second smallest if it
                    // was the lane's first minimum, else its smallest: one pass (a second pass
                    // over S with masks at kb measured 12 instructions a chunk, plus the
                    // neighbours' scalar tests). Lanes whose first minimum is at kb − 1 ..= kb + 1:
                    // first − (kb − 1) in 0..=2 (wrapping: kb = 0 has no kb − 1).
                    let off = V::wrapping_sub(first, t.splat((kb as u16).wrapping_sub(1)));
                    let near = V::less(off, t.splat(3));
                    (m, kb, V::select(near, m2, mv).horizontal_min())
                }
            }
        }
    }

    /// [`super::right_update16`] in chunks of `LANES` (strictly smaller wins: first wins),
    /// the last partial chunk lane by lane. The three slices have the same length.
    #[cfg_attr(not(opt_level_zero), inline(always))]
    pub(super) fn right_update(t: Avx2, c: &[u16], rc: &mut [u16], rk: &mut [u16], lo: usize) {
        let n = c.len();
        assert!(rc.len() == n && rk.len() == n);
        let mut i = 0;
        // SAFETY: i + LANES ≤ n for all three slices; RAMP has 32 ≥ LANES lanes.
        unsafe {
            let ramp = t.load_ptr(RAMP.as_ptr());
            while i + LANES <= n {
                let v = t.load_ptr(c.as_ptr().add(i));
                let r = t.load_ptr(rc.as_ptr().add(i));
                let k = V::wrapping_add(ramp, t.splat((lo + i) as u16));
                t.store_ptr(rc.as_mut_ptr().add(i), V::min(r, v));
                t.store_ptr(rk.as_mut_ptr().add(i), V::select(V::less(v, r), k, t.load_ptr(rk.as_ptr().add(i))));
                i += LANES;
            }
        }
        super::right_update16(&c[i..], &mut rc[i..], &mut rk[i..], lo + i);
    }
}

/// The kernels at 16 lanes per vector.
#[cfg(target_arch = "x86_64")]
mod avx2 {

    use super::lanes;
    use parallax_simd::Avx2;

    /// [`lanes::vertical`] on every lane (entered through the token's `vectorize`, which
    /// compiles it for AVX2).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // both row pairs, the lane count, the box sums
    pub(super) fn vertical(
        t: Avx2,
        colsum: &mut [u16],
        rows: lanes::Rows,
        bt: Option<lanes::BtRows>,
        ndq: usize,
        sub: bool,
        cost: Option<(&mut [u16], usize)>,
        pairs: Option<lanes::Pairs>,
        extra: bool,
    ) {
        assert!(!extra || (bt.is_some() && sub && pairs.is_some()), "a second term only in the intervals' byte pairs");
        let all = (0, ndq);
        match (bt.is_some(), sub, pairs.is_some()) {
            // (the default cost's prefiltered term; compiled for 64 and 96 lanes too, as the byte
            // pairs below: fewer instructions a frame, benches/RESULTS.md 2026-12-07)
            (true, true, true) => match (extra, ndq) {
                (true, 64) => lanes::vertical::<true, true, true, true>(t, colsum, rows, bt, pairs, 64, cost, (0, 64)),
                (true, 96) => lanes::vertical::<true, true, true, true>(t, colsum, rows, bt, pairs, 96, cost, (0, 96)),
                (true, _) => lanes::vertical::<true, true, true, true>(t, colsum, rows, bt, pairs, ndq, cost, all),
                (false, 64) => {
                    lanes::vertical::<true, true, true, false>(t, colsum, rows, bt, pairs, 64, cost, (0, 64))
                }
                (false, 96) => {
                    lanes::vertical::<true, true, true, false>(t, colsum, rows, bt, pairs, 96, cost, (0, 96))
                }
                (false, _) => lanes::vertical::<true, true, true, false>(t, colsum, rows, bt, pairs, ndq, cost, all),
            },
            (true, true, false) => {
                lanes::vertical::<true, true, false, false>(t, colsum, rows, bt, pairs, ndq, cost, all)
            }
            (true, false, _) => {
                lanes::vertical::<true, false, false, false>(t, colsum, rows, bt, pairs, ndq, cost, all)
            }
            // (the byte pairs, the default cost's case, compiled for 16 to 128 lanes as
            // `forward_row_any`: three paths, tsukuba 19.51 → 19.12, venus
            // 11.99 → 11.70, teddy 8.56 → 8.32 instructions an evaluation)
            (false, true, true) => match ndq {
                16 => lanes::vertical::<false, true, true, false>(t, colsum, rows, bt, pairs, 16, cost, (0, 16)),
                32 => lanes::vertical::<false, true, true, false>(t, colsum, rows, bt, pairs, 32, cost, (0, 32)),
                48 => lanes::vertical::<false, true, true, false>(t, colsum, rows, bt, pairs, 48, cost, (0, 48)),
                64 => lanes::vertical::<false, true, true, false>(t, colsum, rows, bt, pairs, 64, cost, (0, 64)),
                96 => lanes::vertical::<false, true, true, false>(t, colsum, rows, bt, pairs, 96, cost, (0, 96)),
                128 => lanes::vertical::<false, true, true, false>(t, colsum, rows, bt, pairs, 128, cost, (0, 128)),
                _ => lanes::vertical::<false, true, true, false>(t, colsum, rows, bt, pairs, ndq, cost, all),
            },
            (false, true, false) => {
                lanes::vertical::<false, true, false, false>(t, colsum, rows, bt, pairs, ndq, cost, all)
            }
            (false, false, _) => {
                lanes::vertical::<false, false, false, false>(t, colsum, rows, bt, pairs, ndq, cost, all)
            }
        }
    }

    /// [`lanes::box_row`] on every lane (entered through the token's `vectorize`).
    #[inline(always)]
    pub(super) fn box_row(t: Avx2, cost: &mut [u16], colsum: &[u16], w: usize, r: usize, ndq: usize) {
        lanes::box_row(t, cost, colsum, w, r, ndq, (0, ndq))
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use parallax_simd::{Avx2, Level};

    /// A xorshift generator from `seed` (not 0): each call gives a number below its argument.
    fn xorshift(seed: u64) -> impl FnMut(u64) -> u64 {
        let mut r = seed;
        move |n| {
            r ^= r << 13;
            r ^= r >> 7;
            r ^= r << 17;
            r % n
        }
    }

    /// [`lanes::wta_right`] against its definition, on sums drawn from a few values (equal sums in
    /// neighbouring candidates and in the same lane of different chunks), garbage in the
    /// padding lanes, and candidate ranges cut at either end or not at all.
    ///
    #[inline(always)]
    fn check_wta(t: Avx2) {
        use super::lanes::{Second, wta_checked, wta_right};
        let mut rnd = xorshift(0x2545_f491_4f6c_dd1d);
        for case in 0..4000 {
            let nd: usize = [5, 16, 17, 32, 40, 64, 70, 96][case % 8];
            let ndq = nd.div_ceil(16) * 16;
            let values = [300u16, 301, 302, 330, 900, 65534];
            let sums: Vec<u16> =
                (0..ndq).map(|d| if d < nd { values[rnd(6) as usize] } else { rnd(400) as u16 }).collect();
            let tail: Vec<u16> = (0..ndq).map(|d| if d < nd { 0 } else { u16::MAX }).collect();
            let (lo, hi) = match rnd(4) {
                0 => (0, nd - 1),
                // the left band: cut at the top only
                1 => (0, rnd(nd as u64) as usize),
                _ => {
                    let a = rnd(nd as u64) as usize;
                    let b = rnd(nd as u64) as usize;
                    (a.min(b), a.max(b))
                }
            };
            wta_checked(&sums, &tail, lo, hi);
            let within = &sums[lo..=hi];
            let m = *within.iter().min().unwrap();
            let kb = lo + within.iter().position(|&v| v == m).unwrap();
            let rivals = || (lo..=hi).filter(|&d| d.abs_diff(kb) > 1).map(|d| sums[d]);
            for (second, third) in [(Second::Skip, 0), (Second::Min, rivals().min().unwrap_or(u16::MAX))] {
                // SAFETY: lengths checked by `wta_checked`; the instruction set is the caller's.
                let got = unsafe { wta_right(t, &sums, &tail, lo, hi, second, None) };
                assert_eq!(got, (m, kb, third), "{} lanes, D {nd}, {lo}..={hi}, {sums:?}", 16);
                if lo != 0 {
                    continue;
                }
                // fused with the right update: the same result, and the right minima as the
                // scalar update of candidates 0..=hi leaves them (lanes past hi untouched)
                let rc0: Vec<u16> = (0..ndq).map(|_| values[rnd(6) as usize]).collect();
                let rk0: Vec<u16> = (0..ndq).map(|_| rnd(1000) as u16).collect();
                let (mut rc, mut rk) = (rc0.clone(), rk0.clone());
                let (mut rc_want, mut rk_want) = (rc0.clone(), rk0.clone());
                super::right_update16(&sums[..=hi], &mut rc_want[..=hi], &mut rk_want[..=hi], 0);
                // SAFETY: as above; rc and rk have Dq lanes.
                let got =
                    unsafe { wta_right(t, &sums, &tail, lo, hi, second, Some((rc.as_mut_ptr(), rk.as_mut_ptr()))) };
                assert_eq!(got, (m, kb, third), "fused, D {nd}, 0..={hi}, {sums:?}");
                assert_eq!((rc, rk), (rc_want, rk_want), "fused right update, D {nd}, 0..={hi}, {sums:?}");
            }
        }
    }

    /// [`lanes::paths`] for a horizontal and a vertical path, with separate outputs and with the
    /// vertical path's written over its predecessor (`IN_PLACE`), against the scalar step (the
    /// definition) on random predecessors, costs and penalties, one to fourteen chunks.
    ///
    #[inline(always)]
    fn check_paths(t: Avx2) {
        use super::{PAD, lanes::LANES, lanes::paths, step};
        let mut rnd = xorshift(0x9e37_79b9_7f4a_7c15);
        for case in 0..600 {
            let chunks = 1 + case % 14;
            let ndq = chunks * 16;
            let nd = ndq - (rnd(LANES as u64) as usize).min(ndq - 1);
            // predecessors from a few levels (ties between neighbours), padded as the sweep's
            let pred = |rnd: &mut dyn FnMut(u64) -> u64| -> Vec<u16> {
                (0..ndq + 2)
                    .map(|k| {
                        if k == 0 || k > nd { PAD } else { [0u16, 40, 41, 300, 2500][rnd(5) as usize] + rnd(3) as u16 }
                    })
                    .collect()
            };
            let prev = [pred(&mut rnd), pred(&mut rnd)];
            let pmin = prev.each_ref().map(|v| *v[1..=nd].iter().min().unwrap());
            let c: Vec<u16> = (0..ndq).map(|d| if d < nd { rnd(1500) as u16 } else { PAD }).collect();
            let acc0: Vec<u16> = (0..ndq).map(|_| rnd(5000) as u16).collect();
            let (p1, p2) = (rnd(300) as u16 + 1, [rnd(2000) as u16 + 300, rnd(2000) as u16 + 300]);
            // the definition
            let mut want_acc = acc0.clone();
            let mut want = [vec![0u16; ndq + 2], vec![0u16; ndq + 2]];
            let want_min: Vec<u16> =
                (0..2).map(|i| step(&c[..nd], &prev[i], pmin[i], p1, p2[i], &mut want[i], &mut want_acc)).collect();
            for (in_place, set) in [(false, false), (true, false), (false, true), (true, true)] {
                let mut acc = if set { vec![0; ndq] } else { acc0.clone() };
                let mut out_h = vec![0u16; ndq + 2];
                let mut out_v = if in_place { prev[1].clone() } else { vec![PAD; ndq + 2] };
                let mut prev_h = prev[0].clone();
                let prev_v = if in_place { out_v.as_mut_ptr() as *const u16 } else { prev[1].as_ptr() };
                let prevs = [prev_h.as_mut_ptr() as *const u16, prev_v];
                let outs = [out_h.as_mut_ptr(), out_v.as_mut_ptr()];
                // SAFETY: every vector has Dq + 2 lanes, c and acc Dq; the outputs overlap nothing
                // but, in place, the vertical path's predecessor; the instruction set is the
                // caller's.
                let got_min = unsafe {
                    match (in_place, set) {
                        (true, true) => paths::<2, 1, true, true>(t, &c, prevs, pmin, p2, p1, outs, &mut acc),
                        (true, false) => paths::<2, 1, false, true>(t, &c, prevs, pmin, p2, p1, outs, &mut acc),
                        (false, true) => paths::<2, 1, true, false>(t, &c, prevs, pmin, p2, p1, outs, &mut acc),
                        (false, false) => paths::<2, 1, false, false>(t, &c, prevs, pmin, p2, p1, outs, &mut acc),
                    }
                };
                let what = format!("{} lanes, D {nd} of {ndq}, in place {in_place}, set {set}", 16);
                assert_eq!(got_min.to_vec(), want_min, "minima, {what}");
                assert_eq!(out_h[1..=nd], want[0][1..=nd], "horizontal path, {what}");
                assert_eq!(out_v[1..=nd], want[1][1..=nd], "vertical path, {what}");
                // the padding the next row reads: slot 0 and the lanes past D
                assert!(out_v[0] == PAD && out_v[nd + 1..].iter().all(|&v| v == PAD), "padding, {what}");
                // with `set` the sums are the two paths' alone
                let want_sums: Vec<u16> = if set {
                    (0..nd).map(|d| want[0][d + 1].wrapping_add(want[1][d + 1])).collect()
                } else {
                    want_acc[..nd].to_vec()
                };
                assert_eq!(acc[..nd], want_sums[..], "sums, {what}");
            }
        }
    }

    #[test]
    fn lane_kernels_match_their_scalar_definitions() {
        match Avx2::new() {
            Some(t) => t.vectorize(
                #[inline(always)]
                || {
                    check_wta(t);
                    check_paths(t);
                },
            ),
            None => println!("skipped: no AVX2 on this CPU"),
        }
    }

    /// The right winners' vector gather against the scalar one (which clamps each pixel's right
    /// pixel to the row), with winners, no winners and ranges past both ends of the row.
    #[test]
    fn right_winners_gather_matches_the_scalar_gather() {
        use super::{Reversed, RightWinners};
        let Some(t) = Avx2::new() else {
            eprintln!("skipped: no AVX2 on this CPU");
            return;
        };
        for seed in 0..200u64 {
            let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
            let mut next = |m: u64| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                s % m
            };
            let w = 1 + next(70) as usize;
            let nd = 1 + next(40) as i64;
            let dmin = next(2 * w as u64 + 20) as i64 - (w as i64 + 10);
            // every entry distinct (a wrong index reads another value), past w too
            let rk: Vec<u16> = (0..w + 16).map(|i| (i as u16).wrapping_mul(7919) ^ 0x5A5A).collect();
            let best: Vec<i32> = (0..w).map(|_| next(nd as u64 + 1) as i32 - 1).collect();
            let (mut fast, mut slow) = (vec![0u32; w], vec![0u32; w]);
            Reversed::new(&rk, w, Some(t)).gather(&best, dmin, &mut fast);
            Reversed::new(&rk, w, None).gather(&best, dmin, &mut slow);
            assert_eq!(fast, slow, "w {w}, dmin {dmin}, best {best:?}");
        }
    }

    /// The Birchfield–Tomasi intervals of a row against their definition in 32-bit arithmetic
    /// (`min`/`max` of the value and its averages with the clamped neighbours), on rows of every
    /// length from 1 and values over the whole 16-bit range.
    #[test]
    fn bt_rows_match_their_definition() {
        let mut next = xorshift(0x5eed);
        for len in 1..70usize {
            for round in 0..20 {
                // full range, and a few values (equal neighbours, the extremes)
                let row: Vec<u16> = (0..len)
                    .map(|_| if round % 2 == 0 { next(65536) as u16 } else { [0, 1, 65534, 65535][next(4) as usize] })
                    .collect();
                let (mut lo, mut hi) = (vec![0; len], vec![0; len]);
                super::bt_row(&row, &mut lo, &mut hi);
                for x in 0..len {
                    let v = row[x] as u32;
                    let vl = (v + row[x.saturating_sub(1)] as u32) / 2;
                    let vr = (v + row[(x + 1).min(len - 1)] as u32) / 2;
                    assert_eq!(lo[x] as u32, v.min(vl).min(vr), "len {len} x {x}");
                    assert_eq!(hi[x] as u32, v.max(vl).max(vr), "len {len} x {x}");
                }
            }
        }
    }

    /// The quantised intensity plane against `⌊v / scale⌋ / 4` for every 16-bit value, at both
    /// scales the matcher uses and another.
    #[test]
    fn quantised_planes_match_their_definition() {
        let img: Vec<u16> = (0..=u16::MAX).collect();
        for scale in [1u32, 257, 3] {
            let mut q = Vec::new();
            super::quantise(&img, 256, scale, &mut q);
            assert_eq!(q.len(), img.len());
            for (&v, &g) in img.iter().zip(&q) {
                assert_eq!(g as u32, (v as u32 / scale) >> 2, "scale {scale}, v {v}");
            }
        }
    }
}
