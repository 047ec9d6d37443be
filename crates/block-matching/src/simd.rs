//! The vectorised kernels: SAD and SSD with window sums in explicit 256-bit SIMD (AVX2), in
//! 16-bit lanes when every sum fits (`block² · max pixel ≤
//! 65534`: SAD with OpenCV's default x-Sobel prefilter, pixels `0..=62`, or the rank prefilter,
//! any window) and in 32-bit lanes otherwise while the sums fit in `u32` (SSD, SAD on raw or
//! 16-bit intensities). The generic engine keeps several passes per pixel; here one fused loop
//! over disparity chunks does, for each pixel `x` of a row:
//!
//! 1. the vertical update of the column sums of the entering column (`+term` of the row that
//!    enters the window, `−term` of the row that leaves it),
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
//! Written with intrinsics because the generic loops left to the compiler ran about 9x slower
//! (teddy 450x375x64, SAD 9x9, one thread: 23.8 ms with `SimdLevel::Scalar` against 2.6 ms here;
//! `BM_SIMD=scalar` in `benches/benches/disparity.rs`). A 512-bit copy was measured slower than
//! the 256-bit kernel on an AVX-512 machine (3.91 ms against 3.69 ms on teddy, 33.4 ms against
//! 24.1 ms on 1280x720x128, one thread: the per-pixel reduction and mask traffic dominate). The
//! 16-bit kernel has a second instance compiled for AVX-512 F/BW/VL, 256-bit operations with 32
//! registers (`SimdLevel::Avx512`, `avx512_16`).

use crate::config::Subpixel;
use crate::decide::{Cost, curve_ratio};
use crate::frame::{MatchStats, Shared};
use crate::prefilter::TextureRows;
use parallax_simd::{Avx2, Avx512, CacheAligned};

/// A lane type of the kernels: window sums, costs and disparity indices.
pub(crate) trait Lane: Copy + Default + PartialOrd + Send + Sync + 'static {
    const MAX: Self;
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
    const MAX: Self = u16::MAX;
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
    const MAX: Self = u32::MAX;
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
    /// r_in| − |l_out − r_out|` of 16 disparities (five operations on 16-bit lanes). Callgrind,
    /// one thread, bm options of `disparity_vs_opencv.py` (x-Sobel, cap 31): 1.31 → 1.21
    /// instructions per evaluation on 1282x1110x224, 1.91 → 1.84 on 626x555x96.
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
/// the instance compiled for AVX-512 F/BW/VL (32 registers, see `SimdLevel::Avx512`). Every
/// window sum must fit in 16 bits (`block² · max pixel ≤ 65534`), else the costs wrap (wrong,
/// not unsound).
pub(crate) fn band16(
    _t: Avx2,
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
        // SAFETY: the token proves AVX-512 F/BW/VL and AVX2.
        Some(_) => unsafe { avx512_16::band::<false>(sh, sc, out, conf, y0, y1) },
        // SAFETY: the token proves AVX2.
        None => unsafe { avx2_16::band::<false>(sh, sc, out, conf, y0, y1) },
    }
}

/// Runs rows `y0..y1` of one band with 32-bit lanes: SSD when `squared`, else SAD. Every window
/// sum must fit in 32 bits (`block² · max term ≤ 2³² − 2`, max term: the largest pixel, squared
/// for SSD), else the costs wrap (wrong, not unsound).
pub(crate) fn band32(
    _t: Avx2,
    squared: bool,
    sh: &Shared,
    sc: &mut Scratch<u32>,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
) -> MatchStats {
    sc.resize(sh.w, sh.r, sh.nd, 8);
    // SAFETY: the token proves AVX2.
    unsafe {
        if squared {
            avx2_32::band::<true>(sh, sc, out, conf, y0, y1)
        } else {
            avx2_32::band::<false>(sh, sc, out, conf, y0, y1)
        }
    }
}

macro_rules! kernel {
    ($feat:literal) => {
        /// Rows `y0..y1` of one band (`sc` sized for `sh` by its `resize`, else a panic).
        #[target_feature(enable = $feat)]
        pub(super) fn band<const SQ: bool>(
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
                    sc.colsum.fill(0);
                    for j in (y0 as i64 - r as i64)..=(y0 + r) as i64 {
                        load_rows(sh, clamp_y(j), &mut sc.l_in, &mut sc.r_in);
                        add_row::<SQ>(sh, sc);
                    }
                    row_n::<false, SQ, false>(sh, sc, y, orow, crow, &mut st);
                } else {
                    let yi = clamp_y(y as i64 + r as i64);
                    let yo = clamp_y(y as i64 - r as i64 - 1);
                    if yi != yo {
                        if !SQ && sh.small_px {
                            // below 128 (`small_px`)
                            load_row_pairs(sh, yi, yo, &mut sc.l_pairs, &mut sc.pairs);
                            row_n::<true, SQ, true>(sh, sc, y, orow, crow, &mut st);
                        } else {
                            load_rows(sh, yi, &mut sc.l_in, &mut sc.r_in);
                            load_rows(sh, yo, &mut sc.l_out, &mut sc.r_out);
                            row_n::<true, SQ, false>(sh, sc, y, orow, crow, &mut st);
                        }
                    } else {
                        row_n::<false, SQ, false>(sh, sc, y, orow, crow, &mut st);
                    }
                }
            }
            st
        }

        /// [`row`] with the chunk count as a constant for the common ranges (16-lane chunks: up
        /// to 64 disparities, 96, 128, 224 and 256; the box sums then stay in registers, up to
        /// 128 disparities with AVX2's 16, all of these with the AVX-512 level's 32).
        #[target_feature(enable = $feat)]
        fn row_n<const VERT: bool, const SQ: bool, const PAIRS: bool>(
            sh: &Shared,
            sc: &mut Scratch<E>,
            y: usize,
            out: &mut [f32],
            conf: &mut [f32],
            stats: &mut MatchStats,
        ) {
            // Without the left–right check the right image's minima are not tracked at all (`LR =
            // false`: a third fewer vector operations per chunk).
            match (sc.ndp / L, sh.lr.is_some()) {
                (1, true) => row::<VERT, SQ, 1, true, PAIRS>(sh, sc, y, out, conf, stats),
                (2, true) => row::<VERT, SQ, 2, true, PAIRS>(sh, sc, y, out, conf, stats),
                (4, true) => row::<VERT, SQ, 4, true, PAIRS>(sh, sc, y, out, conf, stats),
                (6, true) => row::<VERT, SQ, 6, true, PAIRS>(sh, sc, y, out, conf, stats),
                (8, true) => row::<VERT, SQ, 8, true, PAIRS>(sh, sc, y, out, conf, stats),
                (14, true) => row::<VERT, SQ, 14, true, PAIRS>(sh, sc, y, out, conf, stats),
                (16, true) => row::<VERT, SQ, 16, true, PAIRS>(sh, sc, y, out, conf, stats),
                (_, true) => row::<VERT, SQ, 0, true, PAIRS>(sh, sc, y, out, conf, stats),
                (1, false) => row::<VERT, SQ, 1, false, PAIRS>(sh, sc, y, out, conf, stats),
                (2, false) => row::<VERT, SQ, 2, false, PAIRS>(sh, sc, y, out, conf, stats),
                (4, false) => row::<VERT, SQ, 4, false, PAIRS>(sh, sc, y, out, conf, stats),
                (6, false) => row::<VERT, SQ, 6, false, PAIRS>(sh, sc, y, out, conf, stats),
                (8, false) => row::<VERT, SQ, 8, false, PAIRS>(sh, sc, y, out, conf, stats),
                (14, false) => row::<VERT, SQ, 14, false, PAIRS>(sh, sc, y, out, conf, stats),
                (16, false) => row::<VERT, SQ, 16, false, PAIRS>(sh, sc, y, out, conf, stats),
                (_, false) => row::<VERT, SQ, 0, false, PAIRS>(sh, sc, y, out, conf, stats),
            }
        }

        /// Adds `|L − R|` of the row in `l_in` / `r_in` to every column sum.
        #[target_feature(enable = $feat)]
        fn add_row<const SQ: bool>(sh: &Shared, sc: &mut Scratch<E>) {
            sc.assert_sized(sh, L);
            let wp = sh.w + 2 * sh.r;
            let ndp = sc.ndp;
            let cs = sc.colsum.as_mut_ptr();
            let rin = sc.r_in.as_ptr();
            for xp in 0..wp {
                let li = splat_px(sc.l_in[xp]);
                let base = wp - 1 - xp;
                for c in (0..ndp).step_by(L).take_while(|&c| needed(c, xp, sh.dmin)) {
                    // SAFETY: xp·ndp + c + L ≤ wp·ndp; base + c + L ≤ wp − 1 + ndp.
                    unsafe {
                        let p = cs.add(xp * ndp + c);
                        st(p, add(ld(p), term::<SQ>(li, ld_px(rin.add(base + c)))));
                    }
                }
            }
        }

        /// One row: column-sum update (when `VERT`), box sums, both winners, decisions (`sc` sized
        /// for `sh` by its `resize`, else a panic).
        #[target_feature(enable = $feat)]
        fn row<const VERT: bool, const SQ: bool, const NCH: usize, const LR: bool, const PAIRS: bool>(
            sh: &Shared,
            sc: &mut Scratch<E>,
            y: usize,
            out: &mut [f32],
            conf: &mut [f32],
            stats: &mut MatchStats,
        ) {
            let (w, r, nd, dmin) = (sh.w, sh.r, sh.nd, sh.dmin);
            let wp = w + 2 * r;
            // (a constant when the chunk count is: the ring's slot offsets in `beside!` then need
            // no multiplication by a loaded stride)
            let ndp = if NCH > 0 { NCH * L } else { sc.ndp };
            // (every raw access below relies on these sizes)
            sc.assert_sized(sh, L);
            assert_eq!(ndp, sc.ndp);
            sc.rc.fill(E::MAX);
            sc.rk.fill(E::MAX);
            sc.rkf.fill(E::MAX);
            let p = Ptrs {
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
                dmin,
                nd,
                dv: sc.dvec.as_ptr(),
                tail: sc.tail.as_ptr(),
                ndp,
                wp,
                w,
                r,
            };
            // x = 0: vertical update of padded columns 0..=2r, box sums over them
            for c in (0..ndp).step_by(L) {
                let mut acc = splat(E::ZERO);
                for xp in 0..=2 * r {
                    // SAFETY: as in `add_row`.
                    unsafe {
                        let q = p.cs.add(xp * ndp + c);
                        let mut v = ld(q);
                        if VERT && needed(c, xp, dmin) {
                            let base = wp - 1 - xp;
                            let t = if PAIRS {
                                pair_difference(splat_pair(sc.l_pairs[xp]), p.pairs.add(2 * (base + c)))
                            } else {
                                sub(
                                    term::<SQ>(splat_px(sc.l_in[xp]), ld_px(p.rin.add(base + c))),
                                    term::<SQ>(splat_px(sc.l_out[xp]), ld_px(p.rout.add(base + c))),
                                )
                            };
                            v = add(v, t);
                            st(q, v);
                        }
                        acc = add(acc, v);
                    }
                }
                // SAFETY: c + L ≤ ndp, inside slot 0.
                unsafe { st(p.bx.add(slot_of(0, ndp, L) + c), acc) };
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
            let (keys, cm, cp, c2) = (sc.keys.as_mut_ptr(), sc.cm.as_mut_ptr(), sc.cp.as_mut_ptr(), sc.c2.as_mut_ptr());
            // the costs beside the winner of column `x`, read LAG columns later (see `LAG`)
            macro_rules! beside {
                ($x:expr) => {{
                    let x = $x;
                    // SAFETY: x < w = keys.len() = cm.len() = cp.len(); the slot of x (still
                    // holding x: fewer than RING columns later) has ndp entries and L ≥ 1 of
                    // padding either side, the winner is below ndp (`step`'s indices start at
                    // 0 and are lanes' disparities), so kb − 1 and kb + 1 are inside.
                    unsafe {
                        let kb = E::key_d(*keys.add(x)) as usize;
                        debug_assert!(kb < ndp, "a winner's index is a lane's");
                        let slot = bxp.add(slot_of(x, ndp, L));
                        *cm.add(x) = *slot.add(kb).sub(1);
                        *cp.add(x) = *slot.add(kb + 1);
                    }
                }};
            }
            // the winner's key and the costs beside it for the sub-pixel fit (clamped reads; used
            // only when the winner is inside the range); the uniqueness rule and the confidence
            // need the best non-adjacent cost, one more pass over the box sums
            macro_rules! record {
                ($x:expr, $key:expr) => {{
                    let (x, key) = ($x, $key);
                    let kb = E::key_d(key) as usize;
                    // SAFETY: x < w = keys.len().
                    unsafe { *keys.add(x) = key };
                    if x >= LAG {
                        beside!(x - LAG);
                    }
                    if need_c2 {
                        let (lo, hi) = range(x);
                        let v = if E::key_cost(key) == E::MAX || lo > hi {
                            E::MAX
                        } else {
                            // SAFETY: `p` holds this band's buffers; slot x % RING holds the
                            // box sums of x.
                            unsafe { second(&p, bxp.add(slot_of(x, ndp, L)), kb, lo, hi) }
                        };
                        // SAFETY: x < w = c2.len().
                        unsafe { *c2.add(x) = v };
                    }
                }};
            }
            // With a known chunk count the running box sums live in registers from column to
            // column (`bxr`; still stored to `bx` for the decisions, but never loaded back, so
            // no column waits on a store-to-load forward of the one before it). Every `step`
            // call below: `p` holds this band's buffers, sized by `Scratch16::resize`, and
            // x < w.
            let mut bxr = [splat(E::ZERO); MAX_NCH];
            let (lo, hi) = range(0);
            // SAFETY: see above (x = 0).
            record!(0, unsafe { step::<VERT, SQ, false, true, NCH, LR, PAIRS>(&p, &mut bxr, 0, lo, hi) });
            // left border, full range, right border, in column order; both borders through one
            // call site, so the compiler inlines the step there too (called from two loops it
            // kept it out of line, its box sums passed through memory: ~11 % of a 626x555x96
            // frame)
            let segments = [(1, xa.max(1).min(w)), (xa.max(1), xb), (xb.max(xa).max(1), w)];
            for (i, &(a, b)) in segments.iter().enumerate() {
                if i == 1 {
                    for x in a..b {
                        // SAFETY: see above.
                        record!(x, unsafe {
                            step::<VERT, SQ, true, false, NCH, LR, PAIRS>(&p, &mut bxr, x, 0, nd as i64 - 1)
                        });
                    }
                } else {
                    for x in a..b {
                        let (lo, hi) = range(x);
                        // SAFETY: see above.
                        record!(x, unsafe { step::<VERT, SQ, true, true, NCH, LR, PAIRS>(&p, &mut bxr, x, lo, hi) });
                    }
                }
            }
            for x in w.saturating_sub(LAG)..w {
                beside!(x);
            }
            // compiled with the uniqueness rule and without, so that the branch-free body does
            // not compute the threshold's division for nothing, and for each sub-pixel rule
            // (the rule chosen per pixel was a branch in the vectorised loop: one thread,
            // 626x555x96 4.62 → 4.53 ms, teddy 1.80 → 1.77 ms)
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

        /// The smallest box sum `bx` (the current column's slot) over the searchable range
        /// `[lo, hi]` minus the winner `kb` and its two neighbours (`E::MAX` when none is left).
        ///
        /// # Safety
        /// `p` holds the band's buffers sized by `Scratch::resize`; `bx` is one of its slots.
        #[inline]
        #[target_feature(enable = $feat)]
        unsafe fn second(p: &Ptrs<E>, bx: *const E, kb: usize, lo: i64, hi: i64) -> E {
            let (lov, hiv) = (splat_i(lo), splat_i(hi));
            let (nlo, nhi) = (splat_i(kb as i64 - 1), splat_i(kb as i64 + 1));
            let ones = splat(E::MAX);
            let mut acc = ones;
            for c in (0..p.ndp).step_by(L) {
                // SAFETY: c + L ≤ ndp, the length of the box-sum, index and tail buffers.
                unsafe {
                    let dv = ld(p.dv.add(c));
                    let mut m = outside(dv, lov, hiv);
                    if c + L > p.nd {
                        m = or(m, ld(p.tail.add(c)));
                    }
                    // lanes kb − 1 ..= kb + 1 are not candidates
                    m = or(m, _mm256_andnot_si256(outside(dv, nlo, nhi), ones));
                    acc = umin(acc, or(ld(bx.add(c)), m));
                }
            }
            hmin_lane(acc)
        }

        /// Column `x`: (when `UPD`) the vertical update of the entering column and the box-sum
        /// step, then both running minima over the disparity chunks. Returns the left winner's
        /// key (cost `E::MAX`, the sentinel, when no lane is searchable).
        #[inline]
        #[target_feature(enable = $feat)]
        ///
        /// # Safety
        /// The CPU must support this module's target features, `p` must hold this band's buffers as sized by `resize`, and `x < w`.
        unsafe fn step<
            const VERT: bool,
            const SQ: bool,
            const UPD: bool,
            const BORDER: bool,
            const NCH: usize,
            const LR: bool,
            const PAIRS: bool,
        >(
            p: &Ptrs<E>,
            bxr: &mut [V; MAX_NCH],
            x: usize,
            lo: i64,
            hi: i64,
        ) -> <E as Lane>::Key {
            // a known chunk count lets the compiler unroll the chunk loop
            let ndp = if NCH == 0 { p.ndp } else { NCH * L };
            // the box sums carried in registers from column to column, when they fit (more
            // would spill: then each column reads the previous column's stored sums back)
            let keep = NCH > 0 && NCH <= REGS / 2;
            let (lov, hiv) = (splat_i(lo), splat_i(hi));
            // keys for the left winner where the lane type has them and the box sums stay in
            // registers (see `Win`), up to 8 chunks: with 32 registers (`SimdLevel::Avx512`)
            // the 14 chunks of 1282x1110x224 keep their box sums too, and there the blended
            // index measured faster than keys (StereoBM's options, one thread, 3 interleaved
            // rounds: 34.6–34.8 ms against 35.4–36.4 ms; two threads the same within the noise)
            let keys = KEYS && keep && NCH <= 8;
            // without the right state (whose lane moves carry upwards from chunk to chunk) or
            // keys, chunks are visited from the top down (see `min_update_down`): callgrind, one
            // thread, bm options of `disparity_vs_opencv.py`: 1.33 → 1.31 instructions per
            // evaluation on 1282x1110x224, 1.96 → 1.91 on 626x555x96. Keys take any order, and
            // upwards measured faster (one thread, 626x555x96 4.62 → 4.41 ms, teddy 1.78 → 1.74
            // ms; two threads 2.41 → 2.34 ms and 0.945 → 0.90 ms; 3 interleaved rounds)
            let down = NCH > 0 && !LR && !keys;
            let mut prev_c = splat(E::MAX);
            let mut prev_k = splat(E::MAX);
            let xp = x + 2 * p.r;
            // (with `PAIRS` only the byte pairs hold this row's pixels)
            let (li, lo_, lpair) = if PAIRS {
                // SAFETY: xp < wp = l_pairs.len().
                let lp = splat_pair(unsafe { *p.l_pairs.add(xp) });
                (lp, lp, lp)
            } else {
                // SAFETY: xp < wp.
                let (li, lo_) = unsafe { (splat_px(*p.lin.add(xp)), splat_px(*p.lout.add(xp))) };
                (li, lo_, li)
            };
            let base = p.wp - 1 - xp;
            let mut win = win_new(keys);
            let ramp = ramp();
            // this column's slot of box sums and the one before (see `RING`)
            let (slot, prev_slot) = (slot_of(x, ndp, L), slot_of(x + RING - 1, ndp, L));
            // SAFETY: both slots are inside the RING · ndp box sums.
            let (bx, bx_prev) = unsafe { (p.bx.add(slot), p.bx.add(prev_slot)) };
            // one chunk; called with constant indices when the count is known, so that `bxr`
            // is indexed by constants only and stays in registers
            let mut chunk = |ci: usize| {
                let c = ci * L;
                // SAFETY: column offsets as in `add_row` (xp < wp, x − 1 < wp); box, mask and
                // index and right-state buffers have ndp entries.
                unsafe {
                    if BORDER && UPD && !needed(c, xp, p.dmin) {
                        // no pixel whose window holds column xp searches these disparities (see
                        // `needed`): their column sums stay 0, and so does the running box sum
                        // carried over them (stored for the next column when not in registers),
                        // exact once the chunk is needed. The right state needs no move either:
                        // lane k here is the right pixel x − dmin − k < −2r, and every lane of
                        // this chunk and the ones above holds the sentinel (no such pixel is
                        // ever a candidate), as does the lane that would move in.
                        if !keep {
                            st(bx.add(c), splat(E::ZERO));
                        }
                        return;
                    }
                    let dv = if NCH > 0 { add(ramp, splat(E::from_usize(c))) } else { ld(p.dv.add(c)) };
                    // lanes past num_disparities (only in the last chunk) and, at the borders,
                    // outside the searchable range are forced to the sentinel
                    // (with a known count only the last chunk can have such lanes: a constant
                    // test, so the other chunks' mask folds away)
                    let mut m = splat(E::ZERO);
                    if (NCH == 0 || ci + 1 == NCH) && c + L > p.nd {
                        m = ld(p.tail.add(c));
                    }
                    if BORDER {
                        m = or(m, outside(dv, lov, hiv));
                    }
                    let b = if UPD {
                        let q = p.cs.add(xp * ndp + c);
                        let mut v = ld(q);
                        if VERT {
                            let t = if PAIRS {
                                pair_difference(lpair, p.pairs.add(2 * (base + c)))
                            } else {
                                sub(
                                    term::<SQ>(li, ld_px(p.rin.add(base + c))),
                                    term::<SQ>(lo_, ld_px(p.rout.add(base + c))),
                                )
                            };
                            v = add(v, t);
                            st(q, v);
                        }
                        let prev = if keep { bxr[ci] } else { ld(bx_prev.add(c)) };
                        let b = add(prev, sub(v, ld(p.cs.add((x - 1) * ndp + c))));
                        st(bx.add(c), b);
                        if keep {
                            bxr[ci] = b;
                        }
                        b
                    } else {
                        let b = ld(bx.add(c));
                        if keep {
                            bxr[ci] = b;
                        }
                        b
                    };
                    let bm = or(b, m);
                    if keys && !BORDER && ci == 0 {
                        // the first chunk, always visited here (upwards): its keys are the
                        // winner so far, with no minimum against the initial value
                        win = win_first(bm, dv);
                    } else {
                        win_update(&mut win, bm, dv, down, keys);
                    }
                    if LR {
                        // move the right state up one lane (a new pixel enters at lane 0), then
                        // take this column's costs; loads and stores hit the same addresses, so
                        // they forward (an in-memory shift by one lane would not)
                        let (oc, ok) = (ld(p.rc.add(c)), ld(p.rk.add(c)));
                        let (mut rcv, mut rkv) = (up1(oc, prev_c), up1(ok, prev_k));
                        (prev_c, prev_k) = (oc, ok);
                        min_update(&mut rcv, &mut rkv, bm, dv);
                        st(p.rc.add(c), rcv);
                        st(p.rk.add(c), rkv);
                    }
                }
            };
            if NCH > 0 {
                // every known count unrolled, also past the 8 box sums that stay in AVX2's registers:
                // the loop LLVM kept at 14 chunks paid per chunk its counter, the tail test, the
                // mask `or` and the index vector, and the box sums went through the stack. Unrolled
                // (callgrind, one thread, bm options of `disparity_vs_opencv.py`): 2.19 → 1.44
                // instructions per evaluation on 1282x1110x224, 2.38 → 2.07 on 626x555x96 (the
                // tail test now folds too), 2.82 → 2.64 on teddy; time 0.83x (1 thread) and 0.91x
                // (2 threads) on 1282x1110x224, 9 interleaved pairs at load 1.6–1.8 on the Zen 3
                // machine. The list below covers every chunk count `row_n` gives as a constant.
                const { assert!(NCH <= MAX_NCH && MAX_NCH == 16) };
                if down {
                    unrolled!(chunk, NCH; 15 14 13 12 11 10 9 8 7 6 5 4 3 2 1 0);
                } else {
                    unrolled!(chunk, NCH; 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
                }
            } else {
                for ci in 0..ndp / L {
                    chunk(ci);
                }
            }
            // the lane shifted out of the top is final: pixel u = (x − 1) − dmin − (ndp − 1)
            let u = x as i64 - 1 - p.dmin - (ndp as i64 - 1);
            if LR && (0..p.w as i64).contains(&u) {
                // SAFETY: u < w = rkf.len().
                unsafe { *p.rkf.add(u as usize) = top(prev_k) };
            }
            win_key(win, keys)
        }
    };
}

/// Whether the column sums of the chunk of disparities from `c` (offsets from `dmin`) at padded
/// column `xp` are ever read: the pixels whose windows hold that column, `x ∈ [xp − 2r, xp]`,
/// search offsets up to `x − dmin` (their right match stays at or right of the image's first
/// column), so none reaches the chunk when `c > xp − dmin`. On the left border the kernel
/// leaves those chunks out (their sums stay 0): the triangle of disparities no pixel there can
/// have (OpenCV's StereoBM leaves those columns empty). Callgrind, one thread, the options of
/// `disparity_vs_opencv.py bm`: 1.44 → 1.37 instructions per evaluation on 1282x1110x224, 2.67
/// → 2.54 on teddy.
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
/// other offsets, which do not forward to them (the profile's sample right after those loads
/// carried ~13 % of the kernel's time on teddy; reading them later measured 0.97x the time of
/// a teddy frame on one thread, within the noise on two).
const LAG: usize = RING - 1;

/// The largest chunk count `row_n` gives the kernel as a constant (and the size of the
/// register copy of the box sums).
const MAX_NCH: usize = 16;

/// Raw views of one band's buffers for the kernel's inner step.
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
        let is_none = c0 == <E as Lane>::MAX || lo > hi;
        let is_low = !is_none & check_tex & !tex[x];
        // OpenCV's rule: no candidate further than one disparity from the winner costs at
        // most c0 + c0·uniq/100 (integer division, saturated at the lane maximum)
        let is_nu = UNIQ && {
            let c2 = c2v[x];
            !is_none & !is_low & (c2 != <E as Lane>::MAX) & (c2 <= Cost::uniq_thresh(c0, sh.uniq))
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
            sc.ratio[x] = curve_ratio(c1.to_u64() as f64, (c2 != <E as Lane>::MAX).then_some(c2.to_u64() as f64));
        }
    }
}

/// Helpers shared by both instruction sets, 16-bit lanes.
/// The winner updates of a lane type (`lanes16!`, `lanes32!`), from its unsigned minimum `$min`
/// and equality `$eq`: written once for both widths.
macro_rules! min_updates {
    ($feat:literal, $min:ident, $eq:ident) => {
        /// Per lane: if `c < min` (unsigned), then `min = c` and `idx = d`: unsigned minimum,
        /// equality against the old minimum (chunks upwards: a tie keeps the old index), byte
        /// blend of the indices.
        #[inline]
        #[target_feature(enable = $feat)]
        fn min_update(min: &mut V, idx: &mut V, c: V, d: V) {
            let nm = $min(*min, c);
            *idx = _mm256_blendv_epi8(d, *idx, $eq(nm, *min));
            *min = nm;
        }
        /// As `min_update`, for chunks visited from the highest disparities down: a tie takes the
        /// new (smaller) index, so the equality is against the new cost and the new index is the
        /// blend's second operand (a constant index vector is then read from memory by the blend
        /// itself). The new minimum passes through `super::opaque`: seeing `min(m, c) = c`, the
        /// compiler tests `max(m, c) = m` instead, one operation more a chunk (1282x1110x224,
        /// StereoBM's options, one thread, callgrind: 1.159 → 1.118 instructions an evaluation,
        /// 626x555x96 1.711 → 1.699).
        #[inline]
        #[target_feature(enable = $feat)]
        fn min_update_down(min: &mut V, idx: &mut V, c: V, d: V) {
            let nm = super::opaque($min(*min, c));
            *idx = _mm256_blendv_epi8(*idx, d, $eq(nm, c));
            *min = nm;
        }
    };
}

macro_rules! lanes16 {
    ($feat:literal) => {
        type E = u16;
        type V = __m256i;
        const L: usize = 16;
        /// The left winner can be kept as keys (see `Win`).
        const KEYS: bool = true;

        #[inline]
        #[target_feature(enable = $feat)]
        /// # Safety
        /// `p` must point to a full vector of readable lanes, and the CPU must support the module's target features.
        unsafe fn ld(p: *const E) -> V {
            // SAFETY: the caller guarantees L readable lanes at p.
            unsafe { _mm256_loadu_si256(p as *const V) }
        }
        #[inline]
        #[target_feature(enable = $feat)]
        /// # Safety
        /// `p` must point to a full vector of writable lanes, and the CPU must support the module's target features.
        unsafe fn st(p: *mut E, v: V) {
            // SAFETY: the caller guarantees L writable lanes at p.
            unsafe { _mm256_storeu_si256(p as *mut V, v) }
        }
        /// Pixels are already 16-bit lanes.
        #[inline]
        #[target_feature(enable = $feat)]
        ///
        /// # Safety
        /// `p` must point to a full vector of readable 16-bit pixels, and the CPU must support the module's target features.
        unsafe fn ld_px(p: *const u16) -> V {
            // SAFETY: as `ld`.
            unsafe { ld(p) }
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn splat(v: E) -> V {
            _mm256_set1_epi16(v as i16)
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn splat_px(v: u16) -> V {
            splat(v)
        }
        /// The lane indices `0, 1, …, L − 1`.
        #[inline]
        #[target_feature(enable = $feat)]
        fn ramp() -> V {
            _mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)
        }
        /// A range bound as a signed lane (−1 stays −1, large values saturate).
        #[inline]
        #[target_feature(enable = $feat)]
        fn splat_i(v: i64) -> V {
            _mm256_set1_epi16(v.clamp(-1, i16::MAX as i64) as i16)
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn add(a: V, b: V) -> V {
            _mm256_add_epi16(a, b)
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn sub(a: V, b: V) -> V {
            _mm256_sub_epi16(a, b)
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn or(a: V, b: V) -> V {
            _mm256_or_si256(a, b)
        }
        /// `|a − b|` for values below 2^15 (16-bit lanes carry SAD only).
        #[inline]
        #[target_feature(enable = $feat)]
        fn term<const SQ: bool>(a: V, b: V) -> V {
            _mm256_abs_epi16(_mm256_sub_epi16(a, b))
        }
        /// All-ones lanes where `d < lo` or `d > hi` (signed compares; all values < 2^15).
        #[inline]
        #[target_feature(enable = $feat)]
        fn outside(d: V, lo: V, hi: V) -> V {
            _mm256_or_si256(_mm256_cmpgt_epi16(lo, d), _mm256_cmpgt_epi16(d, hi))
        }
        /// `|a − r_in| − |b − r_out|` per lane from the byte pairs `(a, b)` of `ab` and `L`
        /// pairs `(r_in, r_out)` at `p` (every byte below 128: the byte difference does not
        /// wrap, its absolute value is below 128, the multiply-add by `(1, −1)` is exact).
        ///
        /// # Safety
        /// `2L` readable bytes at `p`; the CPU has the module's target features.
        #[inline]
        #[target_feature(enable = $feat)]
        unsafe fn pair_difference(ab: V, p: *const u8) -> V {
            // SAFETY: the caller's.
            let r = unsafe { _mm256_loadu_si256(p as *const V) };
            _mm256_maddubs_epi16(_mm256_abs_epi8(_mm256_sub_epi8(ab, r)), _mm256_set1_epi16(0xff01u16 as i16))
        }
        /// `c` moved up one lane: lane 0 takes the top lane of `prev` (the chunk below).
        #[inline]
        #[target_feature(enable = $feat)]
        fn up1(c: V, prev: V) -> V {
            _mm256_alignr_epi8::<14>(c, _mm256_permute2x128_si256::<0x21>(prev, c))
        }
        /// The top lane.
        #[inline]
        #[target_feature(enable = $feat)]
        fn top(v: V) -> E {
            _mm256_extract_epi16::<15>(v) as E
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn umin(a: V, b: V) -> V {
            _mm256_min_epu16(a, b)
        }
        /// The smallest lane.
        #[inline]
        #[target_feature(enable = $feat)]
        fn hmin_lane(v: V) -> E {
            let m = _mm_min_epu16(_mm256_castsi256_si128(v), _mm256_extracti128_si256::<1>(v));
            (_mm_cvtsi128_si32(_mm_minpos_epu16(m)) & 0xffff) as E
        }
        min_updates!($feat, _mm256_min_epu16, _mm256_cmpeq_epi16);
        /// The left winner so far, with `keys`: each lane's `(cost << 16) | d` as a 32-bit key,
        /// lanes 0–3 and 8–11 of the chunks in the first vector, 4–7 and 12–15 in the second.
        /// The smallest key is the smallest cost, then the smallest d, whatever the order of the
        /// chunks: two unpacks and two minima a chunk, none of them a byte blend (on this Intel
        /// Xeon `vpblendvb` ran one a cycle, `vpunpcklwd` and `vpminud` two). Without `keys`,
        /// the running minimum per lane and its disparity (`min_update`, `min_update_down`).
        /// The kernel takes keys up to 8 chunks, where the box sums stay in registers at both
        /// levels (with AVX2's 16 registers and 14 chunks the two disparity vectors a chunk were
        /// loads and 1282x1110x224 ran 1–2 % slower; with the AVX-512 level's 32, 2–4 %).
        /// Teddy, StereoBM's options, one thread, medians of 61 frames in 3 interleaved
        /// rounds: 1.90 → 1.86 ms; 626x555x96 4.80 → 4.79 ms.
        type Win = (V, V);
        /// No chunk seen: cost `E::MAX` (the sentinel) at index 0, a lane's index, as `beside!`
        /// needs.
        #[inline]
        #[target_feature(enable = $feat)]
        fn win_new(keys: bool) -> Win {
            if keys {
                let k = _mm256_set1_epi32(0xffff_0000u32 as i32);
                (k, k)
            } else {
                (splat(E::MAX), splat(E::ZERO))
            }
        }
        /// The keys of the costs `c` of the disparities `d`: `win_update` of `win_new(true)`
        /// when these are the first chunk's.
        #[inline]
        #[target_feature(enable = $feat)]
        fn win_first(c: V, d: V) -> Win {
            (_mm256_unpacklo_epi16(d, c), _mm256_unpackhi_epi16(d, c))
        }
        /// Takes the costs `c` of the disparities `d`: with `keys` in any chunk order, else
        /// upwards (ties keep the old index) or, when `down`, downwards (ties take the new one).
        #[inline]
        #[target_feature(enable = $feat)]
        fn win_update(w: &mut Win, c: V, d: V, down: bool, keys: bool) {
            if keys {
                w.0 = _mm256_min_epu32(w.0, _mm256_unpacklo_epi16(d, c));
                w.1 = _mm256_min_epu32(w.1, _mm256_unpackhi_epi16(d, c));
            } else {
                blended_update(w, c, d, down);
            }
        }
        /// The smallest `(min << 16) | idx` over the lanes.
        #[inline]
        #[target_feature(enable = $feat)]
        fn win_key(w: Win, keys: bool) -> u32 {
            let k = if keys {
                _mm256_min_epu32(w.0, w.1)
            } else {
                _mm256_min_epu32(_mm256_unpacklo_epi16(w.1, w.0), _mm256_unpackhi_epi16(w.1, w.0))
            };
            let k = _mm_min_epu32(_mm256_castsi256_si128(k), _mm256_extracti128_si256::<1>(k));
            let k = _mm_min_epu32(k, _mm_shuffle_epi32::<0b01_00_11_10>(k));
            let k = _mm_min_epu32(k, _mm_shuffle_epi32::<0b10_11_00_01>(k));
            _mm_cvtsi128_si32(k) as u32
        }
    };
}

/// Helpers shared by both instruction sets, 32-bit lanes.
macro_rules! lanes32 {
    ($feat:literal) => {
        type E = u32;
        type V = __m256i;
        const L: usize = 8;
        /// No keys for the left winner (see `Win`).
        const KEYS: bool = false;

        #[inline]
        #[target_feature(enable = $feat)]
        /// # Safety
        /// `p` must point to a full vector of readable lanes, and the CPU must support the module's target features.
        unsafe fn ld(p: *const E) -> V {
            // SAFETY: the caller guarantees L readable lanes at p.
            unsafe { _mm256_loadu_si256(p as *const V) }
        }
        #[inline]
        #[target_feature(enable = $feat)]
        /// # Safety
        /// `p` must point to a full vector of writable lanes, and the CPU must support the module's target features.
        unsafe fn st(p: *mut E, v: V) {
            // SAFETY: the caller guarantees L writable lanes at p.
            unsafe { _mm256_storeu_si256(p as *mut V, v) }
        }
        /// Eight 16-bit pixels widened to 32-bit lanes.
        #[inline]
        #[target_feature(enable = $feat)]
        ///
        /// # Safety
        /// `p` must point to a full vector of readable 16-bit pixels, and the CPU must support the module's target features.
        unsafe fn ld_px(p: *const u16) -> V {
            // SAFETY: the caller guarantees L readable pixels at p.
            unsafe { _mm256_cvtepu16_epi32(_mm_loadu_si128(p as *const __m128i)) }
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn splat(v: E) -> V {
            _mm256_set1_epi32(v as i32)
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn splat_px(v: u16) -> V {
            _mm256_set1_epi32(v as i32)
        }
        /// The lane indices `0, 1, …, L − 1`.
        #[inline]
        #[target_feature(enable = $feat)]
        fn ramp() -> V {
            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)
        }
        /// A range bound as a signed lane (−1 stays −1, large values saturate).
        #[inline]
        #[target_feature(enable = $feat)]
        fn splat_i(v: i64) -> V {
            _mm256_set1_epi32(v.clamp(-1, i32::MAX as i64) as i32)
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn add(a: V, b: V) -> V {
            _mm256_add_epi32(a, b)
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn sub(a: V, b: V) -> V {
            _mm256_sub_epi32(a, b)
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn or(a: V, b: V) -> V {
            _mm256_or_si256(a, b)
        }
        /// `(a − b)²` when `SQ` (the low 32 bits of the product: exact, as `|a − b| < 2^16`),
        /// else `|a − b|`.
        #[inline]
        #[target_feature(enable = $feat)]
        fn term<const SQ: bool>(a: V, b: V) -> V {
            let d = _mm256_sub_epi32(a, b);
            if SQ { _mm256_mullo_epi32(d, d) } else { _mm256_abs_epi32(d) }
        }
        /// All-ones lanes where `d < lo` or `d > hi` (signed compares; all values < 2^31).
        #[inline]
        #[target_feature(enable = $feat)]
        fn outside(d: V, lo: V, hi: V) -> V {
            _mm256_or_si256(_mm256_cmpgt_epi32(lo, d), _mm256_cmpgt_epi32(d, hi))
        }
        /// `|a − r_in| − |b − r_out|` per lane from the byte pairs `(a, b)` of `ab` and `L`
        /// pairs `(r_in, r_out)` at `p`, as the 16-bit version, widened.
        ///
        /// # Safety
        /// `2L` readable bytes at `p`; the CPU has the module's target features.
        #[inline]
        #[target_feature(enable = $feat)]
        unsafe fn pair_difference(ab: V, p: *const u8) -> V {
            // SAFETY: the caller's.
            let r = unsafe { _mm_loadu_si128(p as *const __m128i) };
            let d = _mm_abs_epi8(_mm_sub_epi8(_mm256_castsi256_si128(ab), r));
            _mm256_cvtepi16_epi32(_mm_maddubs_epi16(d, _mm_set1_epi16(0xff01u16 as i16)))
        }
        /// `c` moved up one lane: lane 0 takes the top lane of `prev` (the chunk below).
        #[inline]
        #[target_feature(enable = $feat)]
        fn up1(c: V, prev: V) -> V {
            _mm256_alignr_epi8::<12>(c, _mm256_permute2x128_si256::<0x21>(prev, c))
        }
        /// The top lane.
        #[inline]
        #[target_feature(enable = $feat)]
        fn top(v: V) -> E {
            _mm256_extract_epi32::<7>(v) as E
        }
        /// The smallest lane of `v` in every lane.
        #[inline]
        #[target_feature(enable = $feat)]
        fn hmin(v: V) -> V {
            let v = _mm256_min_epu32(v, _mm256_permute2x128_si256::<0x01>(v, v));
            let v = _mm256_min_epu32(v, _mm256_shuffle_epi32::<0b01_00_11_10>(v));
            _mm256_min_epu32(v, _mm256_shuffle_epi32::<0b10_11_00_01>(v))
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn umin(a: V, b: V) -> V {
            _mm256_min_epu32(a, b)
        }
        /// The smallest lane.
        #[inline]
        #[target_feature(enable = $feat)]
        fn hmin_lane(v: V) -> E {
            _mm256_extract_epi32::<0>(hmin(v)) as E
        }
        min_updates!($feat, _mm256_min_epu32, _mm256_cmpeq_epi32);
        /// The left winner so far: the running minimum per lane and its disparity (`AVX2` has
        /// no unsigned 64-bit minimum for packed keys).
        type Win = (V, V);
        /// No chunk seen: the sentinel at index 0 (not a sentinel: where no lane is searchable
        /// the key's cost says so, and its index stays a lane's, which `beside!` relies on).
        /// (`keys`: the 16-bit lanes' choice; no keys here.)
        #[inline]
        #[target_feature(enable = $feat)]
        fn win_new(_keys: bool) -> Win {
            (splat(E::MAX), splat(E::ZERO))
        }
        /// Takes the costs `c` of the disparities `d`, chunks visited upwards (ties keep the old
        /// index) or, when `down`, downwards (ties take the new one).
        #[inline]
        #[target_feature(enable = $feat)]
        fn win_update(w: &mut Win, c: V, d: V, down: bool, _keys: bool) {
            blended_update(w, c, d, down);
        }
        /// The first chunk's costs `c` of the disparities `d` (`win_update` of `win_new`; not
        /// called: these lanes keep no keys).
        #[inline]
        #[target_feature(enable = $feat)]
        fn win_first(c: V, d: V) -> Win {
            let mut w = win_new(false);
            win_update(&mut w, c, d, false, false);
            w
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn win_key(w: Win, _keys: bool) -> u64 {
            reduce(w.0, w.1)
        }
        /// `(min << 32) | idx` of the smallest cost, the smallest index among equal costs.
        #[inline]
        #[target_feature(enable = $feat)]
        fn reduce(min: V, idx: V) -> u64 {
            let m = hmin(min);
            let cand = _mm256_blendv_epi8(_mm256_set1_epi32(-1), idx, _mm256_cmpeq_epi32(min, m));
            let k = hmin(cand);
            let (m, k) = (_mm256_extract_epi32::<0>(m) as u32, _mm256_extract_epi32::<0>(k) as u32);
            (m as u64) << 32 | k as u64
        }
    };
}

/// One kernel module: the lane helpers `$lanes!` and the kernel, compiled with `$feat` (`$regs`
/// vector registers).
macro_rules! kernel_module {
    ($name:ident, $lanes:ident, $feat:literal, $regs:literal) => {
        #[cfg(target_arch = "x86_64")]
        mod $name {
            use std::arch::x86_64::*;

            /// Vector registers of the instruction set.
            const REGS: usize = $regs;

            use super::{LAG, Lane, MAX_NCH, Ptrs, RING, Scratch, decide_row, needed, slot_of};
            use crate::decide::{WinnersBy, finish_row};
            use crate::frame::{MatchStats, Shared, conf_row, load_row_pairs, load_rows};

            $lanes!($feat);

            /// A byte pair (`Scratch::l_pairs`) in every 16-bit lane.
            #[inline]
            #[target_feature(enable = $feat)]
            fn splat_pair(ab: u16) -> V {
                _mm256_set1_epi16(ab as i16)
            }

            /// The running minimum per lane and its disparity (the left winner without keys:
            /// `(min, idx)`), chunks visited upwards or, when `down`, downwards.
            #[inline]
            #[target_feature(enable = $feat)]
            fn blended_update(w: &mut (V, V), c: V, d: V, down: bool) {
                if down {
                    min_update_down(&mut w.0, &mut w.1, c, d);
                } else {
                    min_update(&mut w.0, &mut w.1, c, d);
                }
            }

            kernel!($feat);
        }
    };
}

kernel_module!(avx2_16, lanes16, "avx2", 16);
// The 16-bit kernel again for AVX-512 F/BW/VL (`SimdLevel::Avx512`): the same 256-bit
// operations and results, 32 vector registers (the EVEX encodings reach ymm16–31), so the box
// sums of up to 16 chunks stay in registers (`keep`), not 8. StereoBM's options, one thread, 3
// interleaved rounds on the Intel Xeon: 1282x1110x224 38.5–39.3 → 35.2–35.5 ms, 626x555x96
// 4.34–4.52 → 4.09–4.13 ms, teddy 1.78–1.83 → 1.62–1.67 ms; maps byte-identical. (The 32-bit
// kernel and semi-global matching keep their AVX2 code at this level: SGM compiled with the
// same features ran within ±3 % of it, one thread.)
kernel_module!(avx512_16, lanes16, "avx2,avx512f,avx512bw,avx512vl", 32);
kernel_module!(avx2_32, lanes32, "avx2", 16);

/// `v` unchanged, but opaque to the optimiser (an empty `asm!` that takes and gives back its
/// register): no instruction runs.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn opaque(mut v: std::arch::x86_64::__m256i) -> std::arch::x86_64::__m256i {
    // SAFETY: the template is a comment: nothing executes, and only `v`'s register is named
    // (read and written back unchanged).
    unsafe { std::arch::asm!("/* {0} */", inout(ymm_reg) v, options(pure, nomem, nostack, preserves_flags)) };
    v
}
