//! The vectorised kernels: SAD and SSD with window sums in explicit 256-bit SIMD (AVX2), in
//! 16-bit lanes when every sum fits (`channels · block² · max pixel ≤
//! 65534`: grey SAD with OpenCV's default x-Sobel prefilter, pixels `0..=62`, or the rank
//! prefilter, any window; colour SAD on the default x-Sobel up to 17x17) and in 32-bit lanes otherwise while the sums fit in `u32` (SSD, SAD on raw or
//! 16-bit intensities). The generic engine keeps several passes per pixel; here one fused loop
//! over disparity chunks does, for each pixel `x` of a row:
//!
//! 1. the vertical update of the column sums of the entering column (`+term` of the row that
//!    enters the window, `−term` of the row that leaves it; on a colour pair the first
//!    channel's, the other channels' terms added to the column sums by a pass of their own
//!    before the row: the window cost is the sum of the three channels'),
//! 2. the horizontal running box sum (`+` entering column, `−` leaving column),
//! 3. the left winner-take-all as a per-lane running minimum and arg-minimum (16-bit lanes: the
//!    minimum of `(cost << 16) | d` keys; one horizontal reduction per pixel; ties go to the
//!    smallest disparity),
//! 4. the right image's running minimum for the left–right check, kept per lane and moved up one
//!    lane per column (lane `k` always holds the right pixel `x − dmin − k`; the lane leaving the
//!    top is final), strict `<` in increasing `x`, i.e. first wins, as the generic engine and the
//!    naive reference.
//!
//! Texture, uniqueness and sub-pixel decisions then run once per row. Lanes whose disparity is
//! outside the searchable range (left border, `num_disparities` not a multiple of the lane
//! count) are forced to the sentinel (the lane type's maximum, above every real cost), so they
//! never win and never update the right minimum.
//!
//! Written once over explicit lanes ([`KernelLanes`]: `parallax_simd`'s 16- and 32-bit lanes)
//! and a [`Level`]: each row is compiled for the token's level by its `vectorize`; raw memory is
//! reached only through [`Ptrs`], whose constructor checks the buffers' sizes. The generic loops
//! left to the compiler ran several times slower (`BM_SIMD=scalar` in
//! `benches/benches/disparity.rs`), and a 512-bit copy slower than this 256-bit kernel; with
//! AVX-512 the 16-bit lanes run at `Avx512`, 256-bit operations with its 32 registers. The
//! measurements behind these choices are in the journal, `benches/RESULTS.md`.

use crate::config::Subpixel;
use crate::decide::{Cost, curve_ratio};
use crate::frame::{MatchStats, Shared};
use crate::prefilter::TextureRows;
use parallax_simd::{Avx2, Avx512, CacheAligned, Lanes, Level, U16x16, U32x8};

use crate::decide::{WinnersBy, finish_row};
use crate::frame::{conf_row, load_plane_rows, load_row_pairs, load_rows};

/// A lane type of the kernels: window sums, costs and disparity indices.
pub(crate) trait Lane: Cost + Copy + Default + PartialOrd + Send + Sync + 'static {
    const ZERO: Self;
    /// The float type in which the sub-pixel fit is exact for these costs (`f32` below 2^24).
    type F: Real;
    /// A winner `(cost, d)` packed so that the smaller key is the smaller cost, then the smaller
    /// d: `u32` for 16-bit lanes, `u64` for 32-bit ones.
    type Key: Copy + Default + Send + Sync + 'static;
    fn key_cost(key: Self::Key) -> Self;
    fn key_d(key: Self::Key) -> u32;
    fn from_usize(v: usize) -> Self;
    fn to_u64(self) -> u64;
    /// The cost as the sub-pixel fit's float (exact).
    fn to_real(self) -> Self::F;
}

/// The float arithmetic of the sub-pixel fit.
pub(crate) trait Real:
    Copy
    + PartialOrd
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    const TWO: Self;
    const HALF: Self;
    fn to_f32(self) -> f32;
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const TWO: Self = 2.0;
    const HALF: Self = 0.5;
    fn to_f32(self) -> f32 {
        self
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const TWO: Self = 2.0;
    const HALF: Self = 0.5;
    fn to_f32(self) -> f32 {
        self as f32
    }
}

impl Lane for u16 {
    const ZERO: Self = 0;
    type F = f32;
    type Key = u32;
    fn key_cost(key: u32) -> u16 {
        (key >> 16) as u16
    }
    fn key_d(key: u32) -> u32 {
        key & 0xffff
    }
    fn from_usize(v: usize) -> Self {
        v as u16
    }
    fn to_u64(self) -> u64 {
        self as u64
    }
    fn to_real(self) -> f32 {
        self as f32
    }
}

impl Lane for u32 {
    const ZERO: Self = 0;
    type F = f64;
    type Key = u64;
    fn key_cost(key: u64) -> u32 {
        (key >> 32) as u32
    }
    fn key_d(key: u64) -> u32 {
        key as u32
    }
    fn from_usize(v: usize) -> Self {
        v as u32
    }
    fn to_u64(self) -> u64 {
        self as u64
    }
    fn to_real(self) -> f64 {
        self as f64
    }
}

/// Buffers of one row band, reused across frames.
#[derive(Default)]
pub(crate) struct Scratch<E: Lane> {
    /// Disparities per column, rounded up to the lane count.
    ndp: usize,
    // (the buffers the vectors load and store at multiples of their width start on a cache
    // line: see `CacheAligned`)
    colsum: CacheAligned<E>,
    /// The box sums of the last [`RING`] columns (column `x` in slot `x % RING`), each slot
    /// `ndp` lanes with a vector's lanes of padding either side (see [`slot_of`]): the costs
    /// beside any winner `0 ≤ k < ndp` are read without clamping its neighbours' indices.
    boxs: CacheAligned<E>,
    l_in: Vec<u16>,
    l_out: Vec<u16>,
    r_in: Vec<u16>,
    r_out: Vec<u16>,
    /// What `r_in` and `r_out` would hold, interleaved as bytes (`r_in[j] | r_out[j] << 8`:
    /// read as bytes, `r_in[j]` at `2j` and `r_out[j]` at `2j + 1`, x86 being little-endian),
    /// when every pixel is below 128 (`Shared::small_px`) and rows enter and leave the window
    /// (`load_row_pairs`; `l_in`, `r_in`, `l_out` and `r_out` are then not filled): one load, a
    /// byte difference, its absolute value and one multiply-add by `(1, −1)` give `|l_in −
    /// r_in| − |l_out − r_out|` of 16 disparities (five operations on 16-bit lanes).
    pairs: Vec<u16>,
    /// `l_in` and `l_out` as byte pairs, the same way (`l_in[xp]` the low byte).
    l_pairs: Vec<u16>,
    /// Right running minimum per lane: lane `k` holds the pixel `u = x − dmin − k` of the
    /// current column (the state moves up one lane per column).
    rc: CacheAligned<E>,
    rk: CacheAligned<E>,
    /// The right image's final winners of the row, by pixel `u`.
    rkf: CacheAligned<E>,
    dvec: CacheAligned<E>,
    tail: CacheAligned<E>,
    /// The left winner of every pixel of the row.
    keys: CacheAligned<E::Key>,
    cm: CacheAligned<E>,
    cp: CacheAligned<E>,
    /// The best cost further than one disparity from the winner (`E::MAX`: none), when the
    /// uniqueness rule or the confidence needs it.
    c2: CacheAligned<E>,
    ratio: CacheAligned<f32>,
    /// `w` times `true`: the texture mask when the texture check is off.
    all_true: Vec<bool>,
    /// The texture measure of the band's rows.
    texture: TextureRows,
    best: CacheAligned<i32>,
    sub: CacheAligned<f32>,
    /// The right winners at each pixel's match ([`crate::decide::finish_row`]).
    rw: CacheAligned<u32>,
}

impl<E: Lane> Scratch<E> {
    /// Panics unless the buffers are sized for `sh` at `lanes` lanes as [`Self::resize`] sizes
    /// them: what every raw access of the kernels relies on (checked once per row).
    fn assert_sized(&self, sh: &Shared, lanes: usize) {
        let (w, wp, ndp) = (sh.w, sh.w + 2 * sh.r, self.ndp);
        assert!(ndp > 0 && ndp == sh.nd.div_ceil(lanes) * lanes, "scratch sized for another range");
        assert!(self.colsum.len() >= wp * ndp && self.boxs.len() >= RING * (ndp + 2 * lanes));
        assert!([self.l_in.len(), self.l_out.len(), self.l_pairs.len()].iter().all(|&n| n >= wp));
        assert!([self.r_in.len(), self.r_out.len(), self.pairs.len()].iter().all(|&n| n + 1 >= wp + ndp));
        assert!([self.rc.len(), self.rk.len(), self.dvec.len(), self.tail.len()].iter().all(|&n| n >= ndp));
        assert!([self.rkf.len(), self.keys.len(), self.cm.len(), self.cp.len(), self.c2.len()].iter().all(|&n| n >= w));
    }

    pub(crate) fn resize(&mut self, w: usize, r: usize, nd: usize, lanes: usize) {
        let ndp = nd.div_ceil(lanes) * lanes;
        let wp = w + 2 * r;
        self.ndp = ndp;
        self.colsum.resize(wp * ndp, E::ZERO);
        self.boxs.resize(RING * (ndp + 2 * lanes), E::ZERO);
        self.l_in.resize(wp, 0);
        self.l_out.resize(wp, 0);
        // the reversed right rows are read at (wp − 1 − xp) + d for d < ndp
        self.r_in.resize(wp + ndp - 1, 0);
        self.r_out.resize(wp + ndp - 1, 0);
        self.pairs.resize(wp + ndp - 1, 0);
        self.l_pairs.resize(wp, 0);
        self.rc.resize(ndp, E::MAX);
        self.rk.resize(ndp, E::MAX);
        self.rkf.resize(w, E::MAX);
        self.dvec.resize(ndp, E::ZERO);
        self.dvec.iter_mut().enumerate().for_each(|(d, v)| *v = E::from_usize(d));
        self.tail.resize(ndp, E::ZERO);
        self.tail.iter_mut().enumerate().for_each(|(d, v)| *v = if d < nd { E::ZERO } else { E::MAX });
        self.keys.resize(w, E::Key::default());
        self.cm.resize(w, E::ZERO);
        self.cp.resize(w, E::ZERO);
        self.c2.resize(w, E::MAX);
        self.ratio.resize(w, 0.0);
        self.all_true.resize(w, true);
        self.best.resize(w, -1);
        self.sub.resize(w, 0.0);
        self.rw.resize(w, 0);
    }
}

/// Runs rows `y0..y1` of one band with 16-bit lanes (SAD), compiled for AVX2, or with `wide`
/// for AVX-512 F/BW/VL (32 registers, see `SimdLevel::Avx512`). Every window sum must fit in 16
/// bits (`block² · max pixel ≤ 65534`), else the costs wrap (wrong, not unsound).
pub(crate) fn band16(
    t: Avx2,
    wide: Option<Avx512>,
    sh: &Shared,
    sc: &mut Scratch<u16>,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
) -> MatchStats {
    sc.resize(sh.w, sh.r, sh.nd, 16);
    match wide {
        Some(a) => band::<u16, U16x16, Avx512, false>(a, sh, sc, out, conf, y0, y1),
        None => band::<u16, U16x16, Avx2, false>(t, sh, sc, out, conf, y0, y1),
    }
}

/// Runs rows `y0..y1` of one band with 32-bit lanes: SSD when `squared`, else SAD. Every window
/// sum must fit in 32 bits (`block² · max term ≤ 2³² − 2`, max term: the largest pixel, squared
/// for SSD), else the costs wrap (wrong, not unsound).
pub(crate) fn band32(
    t: Avx2,
    squared: bool,
    sh: &Shared,
    sc: &mut Scratch<u32>,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
) -> MatchStats {
    sc.resize(sh.w, sh.r, sh.nd, 8);
    if squared {
        band::<u32, U32x8, Avx2, true>(t, sh, sc, out, conf, y0, y1)
    } else {
        band::<u32, U32x8, Avx2, false>(t, sh, sc, out, conf, y0, y1)
    }
}

/// The lanes of the kernel, `V` holding `E`s: [`U16x16`] (SAD whose sums fit in 16 bits, the
/// left winner kept as packed keys) and [`U32x8`] (SSD and SAD of larger sums).
pub(crate) trait KernelLanes<E: Lane>: Lanes<Elem = E> {
    /// The left winner is kept as packed keys (see [`KernelLanes::Win`]).
    const KEYS: bool;
    /// The left winner so far. 16-bit lanes with `keys`: each lane's `(cost << 16) | d` as a
    /// 32-bit key ([`U16x16::zip`]): the smallest key is the smallest cost, then the smallest d,
    /// whatever the order of the chunks, two unpacks and two minima a chunk and no byte blend.
    /// Otherwise the running minimum per lane and its disparity ([`min_update`],
    /// [`min_update_down`]). The kernel takes keys up to 8 chunks, where the box sums stay in
    /// registers at both levels (the journal, `benches/RESULTS.md`, has the measurements).
    type Win: Copy;
    /// A 16-bit pixel in every lane.
    fn splat_u16(t: Avx2, v: u16) -> Self;
    /// The cost term of two pixels: `(a − b)²` when `SQ`, else `|a − b|` (16-bit lanes carry
    /// SAD only, of values below 2^15).
    fn term<const SQ: bool>(a: Self, b: Self) -> Self;
    /// No chunk seen: cost `E::MAX` (the sentinel) at index 0, a lane's index, as `beside!`
    /// needs.
    fn win_new(t: Avx2, keys: bool) -> Self::Win;
    /// The winner of the first chunk's costs `c` of the disparities `d` (with keys).
    fn win_first(t: Avx2, c: Self, d: Self) -> Self::Win;
    /// Takes the costs `c` of the disparities `d`: with `keys` in any chunk order, else upwards
    /// (ties keep the old index) or, when `down`, downwards (ties take the new one).
    fn win_update(w: &mut Self::Win, c: Self, d: Self, down: bool, keys: bool);
    /// The smallest `(cost, d)` as a key.
    fn win_key(t: Avx2, w: Self::Win, keys: bool) -> E::Key;
}

impl KernelLanes<u16> for U16x16 {
    const KEYS: bool = true;
    type Win = (U32x8, U32x8);
    #[inline(always)]
    fn splat_u16(t: Avx2, v: u16) -> Self {
        U16x16::splat(t, v)
    }
    #[inline(always)]
    fn term<const SQ: bool>(a: Self, b: Self) -> Self {
        a.abs_diff_small(b)
    }
    #[inline(always)]
    fn win_new(t: Avx2, keys: bool) -> Self::Win {
        if keys {
            let k = U32x8::splat(t, 0xffff_0000);
            (k, k)
        } else {
            // the minimum in the first vector, the index in the second, as 16-bit lanes
            (U16x16::splat(t, u16::MAX).into(), U16x16::splat(t, 0).into())
        }
    }
    #[inline(always)]
    fn win_first(_t: Avx2, c: Self, d: Self) -> Self::Win {
        d.zip(c)
    }
    #[inline(always)]
    fn win_update(w: &mut Self::Win, c: Self, d: Self, down: bool, keys: bool) {
        if keys {
            let (lo, hi) = d.zip(c);
            w.0 = w.0.min(lo);
            w.1 = w.1.min(hi);
        } else {
            let (mut m, mut i) = (U16x16::from(w.0), U16x16::from(w.1));
            blended_update(&mut m, &mut i, c, d, down);
            (w.0, w.1) = (m.into(), i.into());
        }
    }
    #[inline(always)]
    fn win_key(_t: Avx2, w: Self::Win, keys: bool) -> u32 {
        let k = if keys {
            w.0.min(w.1)
        } else {
            let (lo, hi) = U16x16::from(w.1).zip(U16x16::from(w.0));
            lo.min(hi)
        };
        k.horizontal_min()
    }
}

impl KernelLanes<u32> for U32x8 {
    /// (`AVX2` has no unsigned 64-bit minimum for packed keys.)
    const KEYS: bool = false;
    type Win = (U32x8, U32x8);
    #[inline(always)]
    fn splat_u16(t: Avx2, v: u16) -> Self {
        U32x8::splat(t, v as u32)
    }
    #[inline(always)]
    fn term<const SQ: bool>(a: Self, b: Self) -> Self {
        if SQ {
            let d = a.wrapping_sub(b);
            d.wrapping_mul(d)
        } else {
            a.abs_diff_small(b)
        }
    }
    /// (`keys`: the 16-bit lanes' choice; none here. Index 0 is not a sentinel: where no lane
    /// is searchable the key's cost says so, and its index stays a lane's.)
    #[inline(always)]
    fn win_new(t: Avx2, _keys: bool) -> Self::Win {
        (U32x8::splat(t, u32::MAX), U32x8::splat(t, 0))
    }
    /// (Not called: these lanes keep no keys.)
    #[inline(always)]
    fn win_first(t: Avx2, c: Self, d: Self) -> Self::Win {
        let mut w = Self::win_new(t, false);
        Self::win_update(&mut w, c, d, false, false);
        w
    }
    #[inline(always)]
    fn win_update(w: &mut Self::Win, c: Self, d: Self, down: bool, _keys: bool) {
        blended_update(&mut w.0, &mut w.1, c, d, down);
    }
    /// `(min << 32) | idx` of the smallest cost, the smallest index among equal costs.
    #[inline(always)]
    fn win_key(t: Avx2, w: Self::Win, _keys: bool) -> u64 {
        let (min, idx) = w;
        let m = min.min_everywhere();
        let cand = min.eq(m).select(idx, U32x8::splat(t, u32::MAX));
        let k = cand.min_everywhere();
        (m.first() as u64) << 32 | k.first() as u64
    }
}

/// Rows `y0..y1` of one band (`sc` sized for `sh` by its `resize`, else a panic), at level `A`.
fn band<E: Lane, V: KernelLanes<E>, A: Level, const SQ: bool>(
    a: A,
    sh: &Shared,
    sc: &mut Scratch<E>,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
) -> MatchStats {
    let (w, h, r) = (sh.w, sh.h, sh.r);
    let clamp_y = |y: i64| y.clamp(0, h as i64 - 1) as usize;
    let mut st = MatchStats::default();
    for y in y0..y1 {
        let orow = &mut out[(y - y0) * w..][..w];
        let crow = conf_row(sh, conf, y, y0);
        if y == y0 {
            sc.colsum.fill(E::ZERO);
            for j in (y0 as i64 - r as i64)..=(y0 + r) as i64 {
                // (each channel's terms added to the same column sums)
                for [left, right] in sh.planes() {
                    load_plane_rows(sh, left, right, clamp_y(j), &mut sc.l_in, &mut sc.r_in);
                    a.vectorize(
                        #[inline(always)]
                        || add_row::<E, V, SQ, false>(a.avx2(), sh, sc),
                    );
                }
            }
            row_n::<E, V, A, false, SQ, false>(a, sh, sc, y, orow, crow, &mut st);
        } else {
            let yi = clamp_y(y as i64 + r as i64);
            let yo = clamp_y(y as i64 - r as i64 - 1);
            if yi != yo {
                // a colour pair's other channels update the column sums first, each in a pass
                // of its own; the fused row below adds the first channel's (the sums are exact
                // once the row's last term is in, whatever the order, and each column's sums are
                // read only after the fused step has updated it)
                for &[left, right] in sh.extra {
                    load_plane_rows(sh, left, right, yi, &mut sc.l_in, &mut sc.r_in);
                    load_plane_rows(sh, left, right, yo, &mut sc.l_out, &mut sc.r_out);
                    a.vectorize(
                        #[inline(always)]
                        || add_row::<E, V, SQ, true>(a.avx2(), sh, sc),
                    );
                }
                if !SQ && sh.small_px {
                    // below 128 (`small_px`)
                    load_row_pairs(sh, yi, yo, &mut sc.l_pairs, &mut sc.pairs);
                    row_n::<E, V, A, true, SQ, true>(a, sh, sc, y, orow, crow, &mut st);
                } else {
                    load_rows(sh, yi, &mut sc.l_in, &mut sc.r_in);
                    load_rows(sh, yo, &mut sc.l_out, &mut sc.r_out);
                    row_n::<E, V, A, true, SQ, false>(a, sh, sc, y, orow, crow, &mut st);
                }
            } else {
                row_n::<E, V, A, false, SQ, false>(a, sh, sc, y, orow, crow, &mut st);
            }
        }
    }
    st
}

/// [`row`] compiled for the level `A`, with the chunk count as a constant for the common ranges
/// (16-lane chunks: up to 64 disparities, 96, 128, 224 and 256; the box sums then stay in
/// registers, up to 128 disparities with AVX2's 16, all of these with the AVX-512 level's 32).
/// Without the left–right check the right image's minima are not tracked at all (`LR = false`:
/// a third fewer vector operations per chunk).
fn row_n<E: Lane, V: KernelLanes<E>, A: Level, const VERT: bool, const SQ: bool, const PAIRS: bool>(
    a: A,
    sh: &Shared,
    sc: &mut Scratch<E>,
    y: usize,
    out: &mut [f32],
    conf: &mut [f32],
    stats: &mut MatchStats,
) {
    let t = a.avx2();
    macro_rules! at {
        ($nch:literal, $lr:literal) => {
            a.vectorize(
                #[inline(always)]
                || row::<E, V, A, VERT, SQ, $nch, $lr, PAIRS>(t, sh, sc, y, out, conf, stats),
            )
        };
    }
    match (sc.ndp / V::LANES, sh.lr.is_some()) {
        (1, true) => at!(1, true),
        (2, true) => at!(2, true),
        (4, true) => at!(4, true),
        (6, true) => at!(6, true),
        (8, true) => at!(8, true),
        (14, true) => at!(14, true),
        (16, true) => at!(16, true),
        (_, true) => at!(0, true),
        (1, false) => at!(1, false),
        (2, false) => at!(2, false),
        (4, false) => at!(4, false),
        (6, false) => at!(6, false),
        (8, false) => at!(8, false),
        (14, false) => at!(14, false),
        (16, false) => at!(16, false),
        (_, false) => at!(0, false),
    }
}

/// Adds the cost terms of the row in `l_in` / `r_in` to every column sum, and when `OUT`
/// subtracts those of the row in `l_out` / `r_out` (the chunks no pixel reads, see [`needed`],
/// stay 0 as the fused step leaves them).
#[cfg_attr(not(opt_level_zero), inline(always))]
fn add_row<E: Lane, V: KernelLanes<E>, const SQ: bool, const OUT: bool>(t: Avx2, sh: &Shared, sc: &mut Scratch<E>) {
    sc.assert_sized(sh, V::LANES);
    let wp = sh.w + 2 * sh.r;
    let ndp = sc.ndp;
    let cs = sc.colsum.as_mut_ptr();
    let (rin, rout) = (sc.r_in.as_ptr(), sc.r_out.as_ptr());
    for xp in 0..wp {
        let li = V::splat_u16(t, sc.l_in[xp]);
        let lo = if OUT { V::splat_u16(t, sc.l_out[xp]) } else { li };
        let base = wp - 1 - xp;
        for c in (0..ndp).step_by(V::LANES).take_while(|&c| needed(c, xp, sh.dmin)) {
            // SAFETY: xp·ndp + c + L ≤ wp·ndp column sums; base + c + L ≤ wp − 1 + ndp right
            // pixels, in both reversed rows (`assert_sized`).
            unsafe {
                let p = cs.add(xp * ndp + c);
                let mut v = V::load_ptr(t, p).wrapping_add(V::term::<SQ>(li, V::load_u16_ptr(t, rin.add(base + c))));
                if OUT {
                    v = v.wrapping_sub(V::term::<SQ>(lo, V::load_u16_ptr(t, rout.add(base + c))));
                }
                v.store_ptr(p);
            }
        }
    }
}

/// One row: column-sum update (when `VERT`), box sums, both winners, decisions (`sc` sized for
/// `sh` by its `resize`, else a panic).
#[cfg_attr(not(opt_level_zero), inline(always))]
fn row<
    E: Lane,
    V: KernelLanes<E>,
    A: Level,
    const VERT: bool,
    const SQ: bool,
    const NCH: usize,
    const LR: bool,
    const PAIRS: bool,
>(
    t: Avx2,
    sh: &Shared,
    sc: &mut Scratch<E>,
    y: usize,
    out: &mut [f32],
    conf: &mut [f32],
    stats: &mut MatchStats,
) {
    let (w, r, nd, dmin) = (sh.w, sh.r, sh.nd, sh.dmin);
    assert!(w > 0, "a row has pixels");
    let wp = w + 2 * r;
    let l = V::LANES;
    // (a constant when the chunk count is: the ring's slot offsets in `beside!` then need no
    // multiplication by a loaded stride)
    let ndp = if NCH > 0 { NCH * l } else { sc.ndp };
    sc.rc.fill(E::MAX);
    sc.rk.fill(E::MAX);
    sc.rkf.fill(E::MAX);
    let p = Ptrs::new(sh, sc, l);
    // (`assert!`, not `assert_eq!`, whose failure path takes the field's address: `p` would stay
    // in memory, and every store through its pointers would reload them)
    assert!(ndp == p.ndp, "the chunk count is the scratch's");
    // x = 0: vertical update of padded columns 0..=2r, box sums over them
    for c in (0..ndp).step_by(l) {
        let mut acc = V::splat(t, E::ZERO);
        for xp in 0..=2 * r {
            let base = wp - 1 - xp;
            // SAFETY: column sums xp·ndp + c + L ≤ wp·ndp, right pixels and byte pairs
            // base + c + L ≤ wp − 1 + ndp (`Ptrs::new`).
            unsafe {
                let q = p.cs.add(xp * ndp + c);
                let mut v = V::load_ptr(t, q);
                if VERT && needed(c, xp, dmin) {
                    let d = if PAIRS {
                        V::pair_difference(V::splat_pair(t, sc.l_pairs[xp]), p.pairs.add(2 * (base + c)))
                    } else {
                        V::term::<SQ>(V::splat_u16(t, sc.l_in[xp]), V::load_u16_ptr(t, p.rin.add(base + c)))
                            .wrapping_sub(V::term::<SQ>(
                                V::splat_u16(t, sc.l_out[xp]),
                                V::load_u16_ptr(t, p.rout.add(base + c)),
                            ))
                    };
                    v = v.wrapping_add(d);
                    v.store_ptr(q);
                }
                acc = acc.wrapping_add(v);
            }
        }
        // SAFETY: c + L ≤ ndp, inside slot 0 (`Ptrs::new`).
        unsafe { acc.store_ptr(p.bx.add(slot_of(0, ndp, l) + c)) };
    }
    // columns whose full range [0, nd) is searchable need no per-lane range mask
    let range = |x: usize| {
        let xd = x as i64 - dmin;
        ((xd - (w as i64 - 1)).max(0), xd.min(nd as i64 - 1))
    };
    let xa = (dmin + nd as i64 - 1).max(1);
    let xb = (w as i64 - 1 + dmin).min(w as i64 - 1);
    let (xa, xb) = if xa <= xb { (xa as usize, xb as usize + 1) } else { (w, w) };
    let need_c2 = sh.uniq > 0 || sh.conf;
    let bxp = p.bx as *const E;
    let (keys, cm, cp, c2) = (&mut sc.keys[..w], &mut sc.cm[..w], &mut sc.cp[..w], &mut sc.c2[..w]);
    // the costs beside the winner of column `x`, read LAG columns later (see `LAG`)
    macro_rules! beside {
        ($x:expr) => {{
            let x = $x;
            let kb = E::key_d(keys[x]) as usize;
            assert!(kb < ndp, "a winner's index is a lane's");
            let slot = bxp.wrapping_add(slot_of(x, ndp, l) + kb);
            // SAFETY: the slot of x (still holding x: fewer than RING columns later) has ndp
            // entries and L ≥ 1 of padding either side (`Ptrs::new`), and kb < ndp.
            (cm[x], cp[x]) = unsafe { (*slot.sub(1), *slot.add(1)) };
        }};
    }
    // the winner's key and the costs beside it for the sub-pixel fit (clamped reads; used only
    // when the winner is inside the range); the uniqueness rule and the confidence need the
    // best non-adjacent cost, one more pass over the box sums
    macro_rules! record {
        ($x:expr, $key:expr) => {{
            let (x, key) = ($x, $key);
            keys[x] = key;
            if x >= LAG {
                beside!(x - LAG);
            }
            if need_c2 {
                let (lo, hi) = range(x);
                c2[x] = if E::key_cost(key) == E::MAX || lo > hi {
                    E::MAX
                } else {
                    second::<E, V>(t, &p, x, E::key_d(key) as usize, lo, hi)
                };
            }
        }};
    }
    // With a known chunk count the running box sums live in registers from column to column
    // (`bxr`; still stored to `bx` for the decisions, but never loaded back, so no column waits
    // on a store-to-load forward of the one before it).
    let mut bxr = [V::splat(t, E::ZERO); MAX_NCH];
    let (lo, hi) = range(0);
    // SAFETY: 0 < w (asserted above).
    record!(0, unsafe { step::<E, V, A, VERT, SQ, false, true, NCH, LR, PAIRS>(t, &p, &mut bxr, 0, lo, hi) });
    // left border, full range, right border, in column order; both borders through one call
    // site, so the compiler inlines the step there too (called from two loops it kept it out of
    // line, its box sums passed through memory)
    let segments = [(1, xa.max(1).min(w)), (xa.max(1), xb), (xb.max(xa).max(1), w)];
    for (i, &(a, b)) in segments.iter().enumerate() {
        // (so that the compiler sees x < w in the loops below: no bounds check per column on
        // the row buffers, nor `step`'s)
        assert!(b <= w);
        if i == 1 {
            for x in a..b {
                // SAFETY: x < b ≤ w.
                record!(x, unsafe {
                    step::<E, V, A, VERT, SQ, true, false, NCH, LR, PAIRS>(t, &p, &mut bxr, x, 0, nd as i64 - 1)
                });
            }
        } else {
            for x in a..b {
                let (lo, hi) = range(x);
                // SAFETY: x < b ≤ w.
                record!(x, unsafe {
                    step::<E, V, A, VERT, SQ, true, true, NCH, LR, PAIRS>(t, &p, &mut bxr, x, lo, hi)
                });
            }
        }
    }
    for x in w.saturating_sub(LAG)..w {
        beside!(x);
    }
    // compiled with the uniqueness rule and without, so that the branch-free body does not
    // compute the threshold's division for nothing, and for each sub-pixel rule (the rule chosen
    // per pixel was a branch in the vectorised loop)
    match (sh.uniq > 0, sh.subpixel == crate::config::Subpixel::Equiangular) {
        (true, true) => decide_row::<E, true, true>(sh, sc, y, stats),
        (true, false) => decide_row::<E, true, false>(sh, sc, y, stats),
        (false, true) => decide_row::<E, false, true>(sh, sc, y, stats),
        (false, false) => decide_row::<E, false, false>(sh, sc, y, stats),
    }
    // the lanes still held are final: lane k is the pixel u = w − 1 − dmin − k
    for k in 0..ndp {
        let u = w as i64 - 1 - dmin - k as i64;
        if (0..w as i64).contains(&u) {
            sc.rkf[u as usize] = sc.rk[k];
        }
    }
    let rkf = &sc.rkf;
    let right = WinnersBy(|u: usize| {
        let v = rkf[u];
        if v == E::MAX { u32::MAX } else { v.to_u64() as u32 }
    });
    finish_row(sh, &sc.best, &mut sc.sub, &sc.ratio, out, conf, stats, &mut sc.rw, &right);
}

/// The smallest box sum of column `x` (its slot of the ring) over the searchable range `[lo,
/// hi]` minus the winner `kb` and its two neighbours (`E::MAX` when none is left). `hi < D`, so
/// the lanes past `D` (index `d ≥ D > hi`) are outside the range: no tail mask.
#[cfg_attr(not(opt_level_zero), inline(always))]
fn second<E: Lane, V: KernelLanes<E>>(t: Avx2, p: &Ptrs<E>, x: usize, kb: usize, lo: i64, hi: i64) -> E {
    debug_assert!(hi < p.nd as i64, "the searchable range ends below D");
    let bx = p.bx.wrapping_add(slot_of(x, p.ndp, V::LANES)) as *const E;
    let (lov, hiv) = (V::splat_bound(t, lo), V::splat_bound(t, hi));
    let (nlo, nhi) = (V::splat_bound(t, kb as i64 - 1), V::splat_bound(t, kb as i64 + 1));
    let ones = V::splat(t, E::MAX);
    let mut acc = ones;
    for c in (0..p.ndp).step_by(V::LANES) {
        // SAFETY: c + L ≤ ndp, the length of a slot and of the index buffer (`Ptrs::new`).
        let (dv, b) = unsafe { (V::load_ptr(t, p.dv.add(c)), V::load_ptr(t, bx.add(c))) };
        let mut m = outside(dv, lov, hiv);
        // lanes kb − 1 ..= kb + 1 are not candidates
        m = m.or(outside(dv, nlo, nhi).and_not(ones));
        acc = acc.min(b.or(m));
    }
    acc.horizontal_min()
}

/// All-ones lanes where `d < lo` or `d > hi` (signed compares).
#[inline(always)]
fn outside<V: Lanes>(d: V, lo: V, hi: V) -> V {
    lo.greater_signed(d).or(d.greater_signed(hi))
}

/// Per lane: if `c < min` (unsigned), then `min = c` and `idx = d`: unsigned minimum, equality
/// against the old minimum (chunks upwards: a tie keeps the old index), byte blend of the
/// indices.
#[inline(always)]
fn min_update<V: Lanes>(min: &mut V, idx: &mut V, c: V, d: V) {
    let nm = min.min(c);
    *idx = nm.eq(*min).select(*idx, d);
    *min = nm;
}

/// As [`min_update`], for chunks visited from the highest disparities down: a tie takes the new
/// (smaller) index, so the equality is against the new cost and the new index is the blend's
/// second operand. The new minimum is made opaque ([`Lanes::opaque`]): seeing `min(m, c) = c`,
/// the compiler would test `max(m, c) = m` instead, one operation more a chunk.
#[inline(always)]
fn min_update_down<V: Lanes>(min: &mut V, idx: &mut V, c: V, d: V) {
    let nm = min.min(c).opaque();
    *idx = nm.eq(c).select(d, *idx);
    *min = nm;
}

/// The running minimum per lane and its disparity (the left winner without keys), chunks
/// visited upwards or, when `down`, downwards.
#[inline(always)]
fn blended_update<V: Lanes>(min: &mut V, idx: &mut V, c: V, d: V, down: bool) {
    if down {
        min_update_down(min, idx, c, d);
    } else {
        min_update(min, idx, c, d);
    }
    // (the index passes through `Lanes::opaque`, whose empty `asm!` blocks keep their order, so
    // that each chunk's blend stays with its chunk: fewer instructions of the 32-bit kernel,
    // see the journal, `benches/RESULTS.md`)
    *idx = idx.opaque();
}

/// Column `x`: (when `UPD`) the vertical update of the entering column and the box-sum step,
/// then both running minima over the disparity chunks. Returns the left winner's key (cost
/// `E::MAX`, the sentinel, when no lane is searchable).
///
/// # Safety
/// `x < p.w` (the row's loops guarantee it once per segment; a check here, per column, cost
/// instructions of the kernel).
#[cfg_attr(not(opt_level_zero), inline(always))]
unsafe fn step<
    E: Lane,
    V: KernelLanes<E>,
    A: Level,
    const VERT: bool,
    const SQ: bool,
    const UPD: bool,
    const BORDER: bool,
    const NCH: usize,
    const LR: bool,
    const PAIRS: bool,
>(
    t: Avx2,
    p: &Ptrs<E>,
    bxr: &mut [V; MAX_NCH],
    x: usize,
    lo: i64,
    hi: i64,
) -> E::Key {
    debug_assert!(x < p.w);
    let l = V::LANES;
    // a known chunk count lets the compiler unroll the chunk loop
    let ndp = if NCH == 0 { p.ndp } else { NCH * l };
    // the box sums carried in registers from column to column, when they fit (more would
    // spill: then each column reads the previous column's stored sums back)
    let keep = NCH > 0 && NCH <= A::REGISTERS / 2;
    let (lov, hiv) = (V::splat_bound(t, lo), V::splat_bound(t, hi));
    // keys for the left winner where the lane type has them and the box sums stay in registers
    // (see `KernelLanes::Win`), up to 8 chunks: with 32 registers (`SimdLevel::Avx512`) the 14
    // chunks of 1282x1110x224 keep their box sums too, and there the blended index measured
    // faster than keys
    let keys = V::KEYS && keep && NCH <= 8;
    // without the right state (whose lane moves carry upwards from chunk to chunk) or keys,
    // chunks are visited from the top down (see `min_update_down`); keys take any order, and
    // upwards measured faster
    let down = NCH > 0 && !LR && !keys;
    let mut prev_c = V::splat(t, E::MAX);
    let mut prev_k = V::splat(t, E::MAX);
    let xp = x + 2 * p.r;
    // (with `PAIRS` only the byte pairs hold this row's pixels)
    // SAFETY: xp < wp, the length of the left rows and pairs (`Ptrs::new`).
    let (li, lo_, lpair) = unsafe {
        if PAIRS {
            let lp = V::splat_pair(t, *p.l_pairs.add(xp));
            (lp, lp, lp)
        } else {
            let li = V::splat_u16(t, *p.lin.add(xp));
            (li, V::splat_u16(t, *p.lout.add(xp)), li)
        }
    };
    let base = p.wp - 1 - xp;
    let mut win = V::win_new(t, keys);
    let ramp = V::ramp(t);
    // this column's slot of box sums and the one before (see `RING`)
    // (in-bounds pointer arithmetic, which the compiler folds into the addressing of every
    // chunk's load and store; `wrapping_add` here cost instructions, see the journal)
    // SAFETY: both slots are inside the ring (`Ptrs::new`).
    let (bx, bx_prev) = unsafe { (p.bx.add(slot_of(x, ndp, l)), p.bx.add(slot_of(x + RING - 1, ndp, l))) };
    // one chunk; called with constant indices when the count is known, so that `bxr` is
    // indexed by constants only and stays in registers
    for_chunks::<NCH>(
        down,
        ndp / l,
        #[cfg_attr(not(opt_level_zero), inline(always))]
        |ci: usize| {
            let c = ci * l;
            if BORDER && UPD && !needed(c, xp, p.dmin) {
                // no pixel whose window holds column xp searches these disparities (see `needed`):
                // their column sums stay 0, and so does the running box sum carried over them
                // (stored for the next column when not in registers), exact once the chunk is
                // needed. The right state needs no move either: lane k here is the right pixel
                // x − dmin − k < −2r, and every lane of this chunk and the ones above holds the
                // sentinel (no such pixel is ever a candidate), as does the lane that would move in.
                if !keep {
                    // SAFETY: c + L ≤ ndp, inside the slot (`Ptrs::new`).
                    unsafe { V::splat(t, E::ZERO).store_ptr(bx.add(c)) };
                }
                return;
            }
            // SAFETY: column sums (xp or x − 1 < wp) · ndp + c + L ≤ wp · ndp, right pixels and
            // byte pairs base + c + L ≤ wp − 1 + ndp; box slots, index, tail and right-state
            // buffers have ndp entries, c + L ≤ ndp (`Ptrs::new`).
            unsafe {
                let dv = if NCH > 0 {
                    ramp.wrapping_add(V::splat(t, E::from_usize(c)))
                } else {
                    V::load_ptr(t, p.dv.add(c))
                };
                // lanes past num_disparities (only in the last chunk) and, at the borders, outside
                // the searchable range are forced to the sentinel (with a known count only the last
                // chunk can have such lanes: a constant test, so the other chunks' mask folds away)
                let mut m = V::splat(t, E::ZERO);
                if (NCH == 0 || ci + 1 == NCH) && c + l > p.nd {
                    m = V::load_ptr(t, p.tail.add(c));
                }
                if BORDER {
                    m = m.or(outside(dv, lov, hiv));
                }
                let b = if UPD {
                    let q = p.cs.add(xp * ndp + c);
                    let mut v = V::load_ptr(t, q);
                    if VERT {
                        let d = if PAIRS {
                            V::pair_difference(lpair, p.pairs.add(2 * (base + c)))
                        } else {
                            V::term::<SQ>(li, V::load_u16_ptr(t, p.rin.add(base + c)))
                                .wrapping_sub(V::term::<SQ>(lo_, V::load_u16_ptr(t, p.rout.add(base + c))))
                        };
                        v = v.wrapping_add(d);
                        v.store_ptr(q);
                    }
                    let prev = if keep { bxr[ci] } else { V::load_ptr(t, bx_prev.add(c)) };
                    let b = prev.wrapping_add(v.wrapping_sub(V::load_ptr(t, p.cs.add((x - 1) * ndp + c))));
                    b.store_ptr(bx.add(c));
                    if keep {
                        bxr[ci] = b;
                    }
                    b
                } else {
                    let b = V::load_ptr(t, bx.add(c));
                    if keep {
                        bxr[ci] = b;
                    }
                    b
                };
                let bm = b.or(m);
                if keys && !BORDER && ci == 0 {
                    // the first chunk, always visited here (upwards): its keys are the winner so
                    // far, with no minimum against the initial value
                    win = V::win_first(t, bm, dv);
                } else {
                    V::win_update(&mut win, bm, dv, down, keys);
                }
                if LR {
                    // move the right state up one lane (a new pixel enters at lane 0), then take
                    // this column's costs; loads and stores hit the same addresses, so they forward
                    // (an in-memory shift by one lane would not)
                    let (oc, ok) = (V::load_ptr(t, p.rc.add(c)), V::load_ptr(t, p.rk.add(c)));
                    let (mut rcv, mut rkv) = (oc.up(prev_c), ok.up(prev_k));
                    (prev_c, prev_k) = (oc, ok);
                    min_update(&mut rcv, &mut rkv, bm, dv);
                    rcv.store_ptr(p.rc.add(c));
                    rkv.store_ptr(p.rk.add(c));
                }
            }
        },
    );
    // the lane shifted out of the top is final: pixel u = (x − 1) − dmin − (ndp − 1)
    let u = x as i64 - 1 - p.dmin - (ndp as i64 - 1);
    if LR && (0..p.w as i64).contains(&u) {
        // SAFETY: u < w, the length of the right winners (`Ptrs::new`).
        unsafe { *p.rkf.add(u as usize) = prev_k.last() };
    }
    V::win_key(t, win, keys)
}

/// Whether the column sums of the chunk of disparities from `c` (offsets from `dmin`) at padded
/// column `xp` are ever read: the pixels whose windows hold that column, `x ∈ [xp − 2r, xp]`,
/// search offsets up to `x − dmin` (their right match stays at or right of the image's first
/// column), so none reaches the chunk when `c > xp − dmin`. On the left border the kernel
/// leaves those chunks out (their sums stay 0): the triangle of disparities no pixel there can
/// have (OpenCV's StereoBM leaves those columns empty).
#[inline(always)]
fn needed(c: usize, xp: usize, dmin: i64) -> bool {
    c as i64 <= xp as i64 - dmin
}

/// Calls `f(i)` for each listed constant `i < n` (`n` a constant: the other calls fold away).
macro_rules! unrolled {
    ($f:ident, $n:expr; $($i:literal)*) => {
        $(
            if $i < $n {
                $f($i);
            }
        )*
    };
}

/// Columns of box sums kept (see [`LAG`]).
const RING: usize = 8;

/// Where the box sums of column `x` start in the ring: slot `x % RING` of `ndp + 2 · lanes`
/// entries, the sums after `lanes` of padding.
#[inline(always)]
fn slot_of(x: usize, ndp: usize, lanes: usize) -> usize {
    (x % RING) * (ndp + 2 * lanes) + lanes
}
/// How many columns later the costs beside a column's winner (for its sub-pixel fit) are read
/// from the box sums: read at once, the two narrow loads hit the vector stores just made at
/// other offsets, which do not forward to them (see the journal).
const LAG: usize = RING - 1;

/// The largest chunk count `row_n` gives the kernel as a constant (and the size of the
/// register copy of the box sums).
const MAX_NCH: usize = 16;

/// Calls `chunk(ci)` for the chunks `ci < n` in order, or from the top down when `down`; with a
/// known count `NCH > 0` (then `n = NCH`) unrolled with constant indices, also past the 8 box
/// sums that stay in AVX2's registers: a loop paid per chunk its counter, the tail test, the
/// mask `or` and the index vector, and the box sums went through the stack. The list covers
/// every chunk count `row_n` gives as a constant.
#[cfg_attr(not(opt_level_zero), inline(always))]
fn for_chunks<const NCH: usize>(down: bool, n: usize, mut chunk: impl FnMut(usize)) {
    if NCH > 0 {
        const { assert!(NCH <= MAX_NCH && MAX_NCH == 16) };
        if down {
            unrolled!(chunk, NCH; 15 14 13 12 11 10 9 8 7 6 5 4 3 2 1 0);
        } else {
            unrolled!(chunk, NCH; 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
        }
    } else {
        for ci in 0..n {
            chunk(ci);
        }
    }
}

/// Raw views of one band's buffers for the kernel's inner step, made only by [`Ptrs::new`],
/// which checks the sizes every raw access of the kernel relies on.
struct Ptrs<E> {
    cs: *mut E,
    bx: *mut E,
    rin: *const u16,
    rout: *const u16,
    /// [`Scratch::pairs`].
    pairs: *const u8,
    l_pairs: *const u16,
    lin: *const u16,
    lout: *const u16,
    rc: *mut E,
    rk: *mut E,
    rkf: *mut E,
    dmin: i64,
    nd: usize,
    dv: *const E,
    tail: *const E,
    ndp: usize,
    wp: usize,
    w: usize,
    r: usize,
}

impl<E: Lane> Ptrs<E> {
    /// The buffers of `sc`, after checking (a panic otherwise) that they are sized for `sh` at
    /// `lanes` lanes as [`Scratch::resize`] sizes them. (Inlined, so that the kernel's copy
    /// of the pointers never has its address taken: in memory, every store through them would
    /// reload them.)
    #[inline(always)]
    fn new(sh: &Shared, sc: &mut Scratch<E>, lanes: usize) -> Self {
        sc.assert_sized(sh, lanes);
        Ptrs {
            cs: sc.colsum.as_mut_ptr(),
            bx: sc.boxs.as_mut_ptr(),
            rin: sc.r_in.as_ptr(),
            rout: sc.r_out.as_ptr(),
            pairs: sc.pairs.as_ptr() as *const u8,
            l_pairs: sc.l_pairs.as_ptr(),
            lin: sc.l_in.as_ptr(),
            lout: sc.l_out.as_ptr(),
            rc: sc.rc.as_mut_ptr(),
            rk: sc.rk.as_mut_ptr(),
            rkf: sc.rkf.as_mut_ptr(),
            dmin: sh.dmin,
            nd: sh.nd,
            dv: sc.dvec.as_ptr(),
            tail: sc.tail.as_ptr(),
            ndp: sc.ndp,
            wp: sh.w + 2 * sh.r,
            w: sh.w,
            r: sh.r,
        }
    }
}

/// The decisions of one row from the winners' keys: range, texture, uniqueness (only when it
/// is on: it needs every cost, so it was checked per pixel into `unique`), sub-pixel offset
/// (in `f32` for 16-bit costs, `f64` for 32-bit ones: exact inputs either way). Branch-free, so the compiler vectorises it (it is inlined
/// into the kernels).
#[inline(always)]
fn decide_row<E: Lane + Cost, const UNIQ: bool, const EQUI: bool>(
    sh: &Shared,
    sc: &mut Scratch<E>,
    y: usize,
    stats: &mut MatchStats,
) {
    let w = sh.w;
    // i32 is enough: validated disparities are within ±2^20 and images narrower than 2^31
    let (nd, dmin, wm1) = (sh.nd as i32, sh.dmin as i32, w as i32 - 1);
    let (check_tex, tex) = match &sh.texture {
        Some(t) => (true, sc.texture.row(t, y)),
        None => (false, &sc.all_true[..w]),
    };
    debug_assert_eq!(EQUI, sh.subpixel == Subpixel::Equiangular);
    let fit_on = sh.subpixel != Subpixel::None;
    let (mut none, mut low, mut not_unique) = (0u32, 0u32, 0u32);
    let (keys, cm, cp, c2v, tex) = (&sc.keys[..w], &sc.cm[..w], &sc.cp[..w], &sc.c2[..w], &tex[..w]);
    let (bestv, subv) = (&mut sc.best[..w], &mut sc.sub[..w]);
    for x in 0..w {
        let xd = x as i32 - dmin;
        let (lo, hi) = ((xd - wm1).max(0), xd.min(nd - 1));
        let key = keys[x];
        let c0 = E::key_cost(key);
        let kb = E::key_d(key) as i32;
        let is_none = c0 == E::MAX || lo > hi;
        let is_low = !is_none & check_tex & !tex[x];
        // OpenCV's rule: no candidate further than one disparity from the winner costs at
        // most c0 + c0·uniq/100 (integer division, saturated at the lane maximum)
        let is_nu = UNIQ && {
            let c2 = c2v[x];
            !is_none & !is_low & (c2 != E::MAX) & (c2 <= Cost::uniq_thresh(c0, sh.uniq))
        };
        none += is_none as u32;
        low += is_low as u32;
        not_unique += is_nu as u32;
        bestv[x] = if is_none | is_low | is_nu { -1 } else { kb };
        // exact integers in E::F; one rounding of the quotient
        let (m, c, p) = (cm[x].to_real(), c0.to_real(), cp[x].to_real());
        let den = if EQUI { (if m > p { m } else { p }) - c } else { m - E::F::TWO * c + p };
        let fit = fit_on & (kb > lo) & (kb < hi) & (den > E::F::ZERO);
        let q = (m - p) / (E::F::TWO * if fit { den } else { E::F::ONE });
        let q = if q < E::F::ZERO - E::F::HALF {
            E::F::ZERO - E::F::HALF
        } else if q > E::F::HALF {
            E::F::HALF
        } else {
            q
        };
        subv[x] = if fit { q.to_f32() } else { 0.0 };
    }
    stats.no_candidate += none as usize;
    stats.low_texture += low as usize;
    stats.not_unique += not_unique as usize;
    if sh.conf {
        for x in 0..w {
            let (c1, c2) = (E::key_cost(keys[x]), c2v[x]);
            sc.ratio[x] = curve_ratio(c1.to_u64() as f64, (c2 != E::MAX).then_some(c2.to_u64() as f64));
        }
    }
}
