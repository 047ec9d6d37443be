//! The SAD fast path: 16-bit window sums in explicit 256-bit vectors (AVX2, or AVX2 with
//! AVX-512VL mask registers).
//!
//! Used when the cost is SAD and every window sum fits in `u16` with one value to spare
//! (`block² · max pixel ≤ 65534`; OpenCV's default x-Sobel prefilter gives pixels `0..=62`, so
//! every window up to 31x31 qualifies). The generic engine keeps `u32`/`u64` sums and several
//! passes per pixel; here one fused loop over 16-disparity chunks does, for each pixel `x` of a
//! row:
//!
//! 1. the vertical update of the column sums of the entering column (`+|L−R|` of the row that
//!    enters the window, `−|L−R|` of the row that leaves it),
//! 2. the horizontal running box sum (`+` entering column, `−` leaving column),
//! 3. the left winner-take-all as a per-lane running minimum and arg-minimum (one horizontal
//!    reduction per pixel: `(cost << 16) | d` keys, so ties go to the smallest disparity),
//! 4. the right image's running minimum for the left–right check, kept per lane and moved up one
//!    lane per column (lane `k` always holds the right pixel `x − dmin − k`; the lane leaving the
//!    top is final), strict `<` in increasing `x`, i.e. first wins, as the generic engine and the
//!    naive reference.
//!
//! Texture, uniqueness and sub-pixel decisions then run once per row in a branch-free loop the
//! compiler vectorises. Lanes whose disparity is outside the searchable range (left border,
//! `num_disparities` not a multiple of 16) are forced to the sentinel `0xFFFF`, above every real
//! cost, so they never win and never update the right minimum.
//!
//! Written with intrinsics because the generic loops left to the compiler ran about 9x slower
//! (teddy 450x375x64, 9x9, one thread: 23.8 ms with `SimdLevel::Scalar` against 2.6 ms here;
//! `BM_SIMD=scalar` in `benches/benches/disparity.rs`). A 512-bit copy was measured slower than
//! this 256-bit kernel on the project's machine (3.91 ms against 3.69 ms on teddy, 33.4 ms against
//! 24.1 ms on 1280x720x128, one thread: the per-pixel reduction and mask traffic dominate), so
//! `SimdLevel::Avx512` runs the 256-bit kernel with AVX-512VL's masked moves for the arg-min.

use crate::config::Subpixel;
use crate::engine::{MatchStats, Shared};

/// Buffers of one row band, reused across frames.
#[derive(Default)]
pub(crate) struct Scratch16 {
    /// Disparities per column, rounded up to the lane count.
    ndp: usize,
    colsum: Vec<u16>,
    boxs: Vec<u16>,
    l_in: Vec<u16>,
    l_out: Vec<u16>,
    r_in: Vec<u16>,
    r_out: Vec<u16>,
    /// Right running minimum per lane: lane `k` holds the pixel `u = x − dmin − k` of the
    /// current column (the state moves up one lane per column).
    rc: Vec<u16>,
    rk: Vec<u16>,
    /// The right image's final winners of the row, by pixel `u`.
    rkf: Vec<u16>,
    dvec: Vec<u16>,
    tail: Vec<u16>,
    keys: Vec<u32>,
    cm: Vec<u16>,
    cp: Vec<u16>,
    unique: Vec<bool>,
    best: Vec<i32>,
    sub: Vec<f32>,
}

impl Scratch16 {
    pub(crate) fn resize(&mut self, w: usize, r: usize, nd: usize, lanes: usize) {
        let ndp = nd.div_ceil(lanes) * lanes;
        let wp = w + 2 * r;
        self.ndp = ndp;
        self.colsum.resize(wp * ndp, 0);
        self.boxs.resize(ndp, 0);
        self.l_in.resize(wp, 0);
        self.l_out.resize(wp, 0);
        // the reversed right rows are read at (wp − 1 − xp) + d for d < ndp
        self.r_in.resize(wp + ndp - 1, 0);
        self.r_out.resize(wp + ndp - 1, 0);
        // right minima at (w − 1 − x) + d
        self.rc.resize(ndp, u16::MAX);
        self.rk.resize(ndp, u16::MAX);
        self.rkf.resize(w, u16::MAX);
        self.dvec.clear();
        self.dvec.extend((0..ndp).map(|d| d as u16));
        self.tail.clear();
        self.tail.extend((0..ndp).map(|d| if d < nd { 0 } else { u16::MAX }));
        self.keys.resize(w, u32::MAX);
        self.cm.resize(w, 0);
        self.cp.resize(w, 0);
        self.unique.resize(w, true);
        self.best.resize(w, -1);
        self.sub.resize(w, 0.0);
    }
}

/// The instruction sets this path exists for. An AVX-512 copy (32 lanes, mask-register blends)
/// was measured slower on this project's machine (Sapphire Rapids, teddy 450x375x64 9x9:
/// 3.91 ms against 3.69 ms; 1280x720x128: 33.4 ms against 24.1 ms, one thread) and removed:
/// AVX-512 CPUs run the AVX2 kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    Avx2,
    /// The AVX2 kernel at 256 bits with AVX-512VL's mask registers for the arg-min updates.
    Avx512Vl,
}

impl Isa {
    pub(crate) fn lanes(self) -> usize {
        match self {
            Isa::Avx2 | Isa::Avx512Vl => 16,
        }
    }
}

/// Runs rows `y0..y1` of one band.
///
/// # Safety
/// The CPU must support `isa` (checked by `SimdLevel::detect`), `sc` must have been resized for
/// this frame with `isa.lanes()`, and every pixel of `sh.left` / `sh.right` must be at most
/// `65534 / block²`.
pub(crate) unsafe fn band(
    isa: Isa,
    sh: &Shared,
    sc: &mut Scratch16,
    out: &mut [f32],
    y0: usize,
    y1: usize,
) -> MatchStats {
    // SAFETY: forwarded from the caller.
    unsafe {
        match isa {
            Isa::Avx2 => avx2::band(sh, sc, out, y0, y1),
            Isa::Avx512Vl => avx512vl::band(sh, sc, out, y0, y1),
        }
    }
}

/// The kernel, instantiated once per instruction set inside a module that defines `V`, `L` and
/// the vector helpers `ld`, `st`, `splat`, `add`, `sub`, `or`, `absdiff`, `outside`,
/// `min_update` and `reduce`, all compiled with `$feat`.
macro_rules! kernel {
    ($feat:literal) => {
        /// # Safety
        /// See [`super::band`].
        #[target_feature(enable = $feat)]
        pub(super) unsafe fn band(
            sh: &Shared,
            sc: &mut Scratch16,
            out: &mut [f32],
            y0: usize,
            y1: usize,
        ) -> MatchStats {
            let (w, h, r) = (sh.w, sh.h, sh.r);
            let clamp_y = |y: i64| y.clamp(0, h as i64 - 1) as usize;
            let mut st = MatchStats::default();
            for y in y0..y1 {
                let orow = &mut out[(y - y0) * w..][..w];
                if y == y0 {
                    sc.colsum.fill(0);
                    for j in (y0 as i64 - r as i64)..=(y0 + r) as i64 {
                        load_rows(sh, clamp_y(j), &mut sc.l_in, &mut sc.r_in);
                        // SAFETY: buffers sized by `Scratch16::resize`.
                        unsafe { add_row(sh, sc) };
                    }
                    // SAFETY: as above.
                    unsafe { row_n::<false>(sh, sc, y, orow, &mut st) };
                } else {
                    let yi = clamp_y(y as i64 + r as i64);
                    let yo = clamp_y(y as i64 - r as i64 - 1);
                    if yi != yo {
                        load_rows(sh, yi, &mut sc.l_in, &mut sc.r_in);
                        load_rows(sh, yo, &mut sc.l_out, &mut sc.r_out);
                        // SAFETY: as above.
                        unsafe { row_n::<true>(sh, sc, y, orow, &mut st) };
                    } else {
                        // SAFETY: as above.
                        unsafe { row_n::<false>(sh, sc, y, orow, &mut st) };
                    }
                }
            }
            st
        }

        /// [`row`] with the chunk count as a constant for the common ranges (up to 64 and 128
        /// disparities).
        #[target_feature(enable = $feat)]
        unsafe fn row_n<const VERT: bool>(
            sh: &Shared,
            sc: &mut Scratch16,
            y: usize,
            out: &mut [f32],
            stats: &mut MatchStats,
        ) {
            // SAFETY: forwarded.
            unsafe {
                match sc.ndp / L {
                    1 => row::<VERT, 1>(sh, sc, y, out, stats),
                    2 => row::<VERT, 2>(sh, sc, y, out, stats),
                    3 => row::<VERT, 3>(sh, sc, y, out, stats),
                    4 => row::<VERT, 4>(sh, sc, y, out, stats),
                    8 => row::<VERT, 8>(sh, sc, y, out, stats),
                    _ => row::<VERT, 0>(sh, sc, y, out, stats),
                }
            }
        }

        /// Adds `|L − R|` of the row in `l_in` / `r_in` to every column sum.
        #[target_feature(enable = $feat)]
        unsafe fn add_row(sh: &Shared, sc: &mut Scratch16) {
            let wp = sh.w + 2 * sh.r;
            let ndp = sc.ndp;
            let cs = sc.colsum.as_mut_ptr();
            let rin = sc.r_in.as_ptr();
            for xp in 0..wp {
                let li = splat(sc.l_in[xp]);
                let base = wp - 1 - xp;
                for c in (0..ndp).step_by(L) {
                    // SAFETY: xp·ndp + c + L ≤ wp·ndp; base + c + L ≤ wp − 1 + ndp.
                    unsafe {
                        let p = cs.add(xp * ndp + c);
                        st(p, add(ld(p), absdiff(li, ld(rin.add(base + c)))));
                    }
                }
            }
        }

        /// One row: column-sum update (when `VERT`), box sums, both winners, decisions.
        #[target_feature(enable = $feat)]
        unsafe fn row<const VERT: bool, const NCH: usize>(
            sh: &Shared,
            sc: &mut Scratch16,
            y: usize,
            out: &mut [f32],
            stats: &mut MatchStats,
        ) {
            let (w, r, nd, dmin) = (sh.w, sh.r, sh.nd, sh.dmin);
            let wp = w + 2 * r;
            let ndp = sc.ndp;
            sc.rc.fill(u16::MAX);
            sc.rk.fill(u16::MAX);
            sc.rkf.fill(u16::MAX);
            let p = Ptrs {
                cs: sc.colsum.as_mut_ptr(),
                bx: sc.boxs.as_mut_ptr(),
                rin: sc.r_in.as_ptr(),
                rout: sc.r_out.as_ptr(),
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
                let mut acc = splat(0);
                for xp in 0..=2 * r {
                    // SAFETY: as in `add_row`.
                    unsafe {
                        let q = p.cs.add(xp * ndp + c);
                        let mut v = ld(q);
                        if VERT {
                            let base = wp - 1 - xp;
                            let t = sub(
                                absdiff(splat(sc.l_in[xp]), ld(p.rin.add(base + c))),
                                absdiff(splat(sc.l_out[xp]), ld(p.rout.add(base + c))),
                            );
                            v = add(v, t);
                            st(q, v);
                        }
                        acc = add(acc, v);
                    }
                }
                // SAFETY: c + L ≤ ndp.
                unsafe { st(p.bx.add(c), acc) };
            }
            // columns whose full range [0, nd) is searchable need no per-lane range mask
            let range = |x: usize| {
                let xd = x as i64 - dmin;
                ((xd - (w as i64 - 1)).max(0), xd.min(nd as i64 - 1))
            };
            let xa = (dmin + nd as i64 - 1).max(1);
            let xb = (w as i64 - 1 + dmin).min(w as i64 - 1);
            let (xa, xb) = if xa <= xb { (xa as usize, xb as usize + 1) } else { (w, w) };
            let uniq = sh.uniq;
            let bxp = p.bx as *const u16;
            let (keys, cm, cp) = (sc.keys.as_mut_ptr(), sc.cm.as_mut_ptr(), sc.cp.as_mut_ptr());
            // the winner's key and the costs beside it for the sub-pixel fit (clamped reads; used
            // only when the winner is inside the range); the uniqueness rule needs every cost
            macro_rules! record {
                ($x:expr, $key:expr) => {{
                    let (x, key) = ($x, $key);
                    let kb = (key & 0xffff) as usize;
                    // SAFETY: x < w = keys.len() = cm.len() = cp.len(); indices clamped to ndp.
                    unsafe {
                        *keys.add(x) = key;
                        *cm.add(x) = *bxp.add(kb.wrapping_sub(1).min(ndp - 1));
                        *cp.add(x) = *bxp.add((kb + 1).min(ndp - 1));
                    }
                    if uniq > 0 {
                        let (lo, hi) = range(x);
                        // SAFETY: the box sums are written only inside `step`, not while this
                        // view is alive.
                        let bxs = unsafe { std::slice::from_raw_parts(bxp, ndp) };
                        sc.unique[x] =
                            (key >> 16) == 0xffff || lo > hi || unique(bxs, lo as usize, hi as usize, kb, uniq);
                    }
                }};
            }
            // SAFETY (all `step` calls): `p` holds this band's buffers, sized by
            // `Scratch16::resize`; x < w.
            let (lo, hi) = range(0);
            record!(0, unsafe { step::<VERT, false, true, NCH>(&p, 0, lo, hi) });
            for x in 1..xa.max(1).min(w) {
                let (lo, hi) = range(x);
                record!(x, unsafe { step::<VERT, true, true, NCH>(&p, x, lo, hi) });
            }
            for x in xa.max(1)..xb {
                record!(x, unsafe { step::<VERT, true, false, NCH>(&p, x, 0, nd as i64 - 1) });
            }
            for x in xb.max(xa).max(1)..w {
                let (lo, hi) = range(x);
                record!(x, unsafe { step::<VERT, true, true, NCH>(&p, x, lo, hi) });
            }
            decide_row(sh, sc, y, stats);
            // the lanes still held are final: lane k is the pixel u = w − 1 − dmin − k
            for k in 0..ndp {
                let u = w as i64 - 1 - dmin - k as i64;
                if (0..w as i64).contains(&u) {
                    sc.rkf[u as usize] = sc.rk[k];
                }
            }
            let rkf = &sc.rkf;
            finish_row(sh, &sc.best, &mut sc.sub, out, stats, |x, k| {
                let v = rkf[(x as i64 - dmin - k as i64) as usize];
                if v == u16::MAX { u32::MAX } else { v as u32 }
            });
        }

        /// Column `x`: (when `UPD`) the vertical update of the entering column and the box-sum
        /// step, then both running minima over the disparity chunks. Returns the left winner's
        /// `(cost << 16) | d`, `0xFFFF_FFFF`-like sentinel keys when no lane is searchable.
        #[inline]
        #[target_feature(enable = $feat)]
        unsafe fn step<const VERT: bool, const UPD: bool, const BORDER: bool, const NCH: usize>(
            p: &Ptrs,
            x: usize,
            lo: i64,
            hi: i64,
        ) -> u32 {
            // a known chunk count lets the compiler unroll the chunk loop
            let ndp = if NCH == 0 { p.ndp } else { NCH * L };
            let (lov, hiv) = (splat(lo.min(0x7fff) as u16), splat(hi.clamp(-1, 0x7fff) as u16));
            let mut prev_c = splat(u16::MAX);
            let mut prev_k = splat(u16::MAX);
            let xp = x + 2 * p.r;
            // SAFETY: xp < wp.
            let (li, lo_) = unsafe { (splat(*p.lin.add(xp)), splat(*p.lout.add(xp))) };
            let base = p.wp - 1 - xp;
            let mut minv = splat(u16::MAX);
            let mut idxv = splat(u16::MAX);
            for ci in 0..ndp / L {
                let c = ci * L;
                // SAFETY: column offsets as in `add_row` (xp < wp, x − 1 < wp); box, mask and
                // index and right-state buffers have ndp entries.
                unsafe {
                    let dv = ld(p.dv.add(c));
                    // lanes past num_disparities (only in the last chunk) and, at the borders,
                    // outside the searchable range are forced to the sentinel
                    let mut m = splat(0);
                    if c + L > p.nd {
                        m = ld(p.tail.add(c));
                    }
                    if BORDER {
                        m = or(m, outside(dv, lov, hiv));
                    }
                    let b = if UPD {
                        let q = p.cs.add(xp * ndp + c);
                        let mut v = ld(q);
                        if VERT {
                            let t = sub(absdiff(li, ld(p.rin.add(base + c))), absdiff(lo_, ld(p.rout.add(base + c))));
                            v = add(v, t);
                            st(q, v);
                        }
                        let b = add(ld(p.bx.add(c)), sub(v, ld(p.cs.add((x - 1) * ndp + c))));
                        st(p.bx.add(c), b);
                        b
                    } else {
                        ld(p.bx.add(c))
                    };
                    let bm = or(b, m);
                    min_update(&mut minv, &mut idxv, bm, dv);
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
            // the lane shifted out of the top is final: pixel u = (x − 1) − dmin − (ndp − 1)
            let u = x as i64 - 1 - p.dmin - (ndp as i64 - 1);
            if (0..p.w as i64).contains(&u) {
                // SAFETY: u < w = rkf.len().
                unsafe { *p.rkf.add(u as usize) = top(prev_k) };
            }
            reduce(minv, idxv)
        }
    };
}

/// Raw views of one band's buffers for the kernel's inner step.
struct Ptrs {
    cs: *mut u16,
    bx: *mut u16,
    rin: *const u16,
    rout: *const u16,
    lin: *const u16,
    lout: *const u16,
    rc: *mut u16,
    rk: *mut u16,
    rkf: *mut u16,
    dmin: i64,
    nd: usize,
    dv: *const u16,
    tail: *const u16,
    ndp: usize,
    wp: usize,
    w: usize,
    r: usize,
}

/// The decisions of one row from the winners' keys: range, texture, uniqueness (only when it
/// is on: it needs every cost, so it was checked per pixel into `unique`), sub-pixel offset.
/// Branch-free, so the compiler vectorises it (it is inlined into the AVX2 kernel).
#[inline(always)]
fn decide_row(sh: &Shared, sc: &mut Scratch16, y: usize, stats: &mut MatchStats) {
    let w = sh.w;
    // i32 is enough: validated disparities are within ±2^20 and images narrower than 2^31
    let (nd, dmin, wm1) = (sh.nd as i32, sh.dmin as i32, w as i32 - 1);
    let (check_tex, tex) = match sh.texture_ok {
        Some(t) => (true, &t[y * w..][..w]),
        None => (false, &sc.unique[..w]),
    };
    let check_uniq = sh.uniq > 0;
    let (equi, fit_on) = (sh.subpixel == Subpixel::Equiangular, sh.subpixel != Subpixel::None);
    let (mut none, mut low, mut not_unique) = (0u32, 0u32, 0u32);
    let (keys, cm, cp, uq, tex) = (&sc.keys[..w], &sc.cm[..w], &sc.cp[..w], &sc.unique[..w], &tex[..w]);
    let (bestv, subv) = (&mut sc.best[..w], &mut sc.sub[..w]);
    for x in 0..w {
        let xd = x as i32 - dmin;
        let (lo, hi) = ((xd - wm1).max(0), xd.min(nd - 1));
        let key = keys[x];
        let c0 = key >> 16;
        let kb = (key & 0xffff) as i32;
        let is_none = c0 == 0xffff || lo > hi;
        let is_low = !is_none & check_tex & !tex[x];
        let is_nu = !is_none & !is_low & check_uniq & !uq[x];
        none += is_none as u32;
        low += is_low as u32;
        not_unique += is_nu as u32;
        bestv[x] = if is_none | is_low | is_nu { -1 } else { kb };
        // exact integers in f32 (< 2^24); one rounding of the quotient
        let (m, c, p) = (cm[x] as f32, c0 as f32, cp[x] as f32);
        let den = if equi { (if m > p { m } else { p }) - c } else { m - 2.0 * c + p };
        let fit = fit_on & (kb > lo) & (kb < hi) & (den > 0.0);
        let q = (m - p) / (2.0 * if fit { den } else { 1.0 });
        let q = q.clamp(-0.5, 0.5);
        subv[x] = if fit { q } else { 0.0 };
    }
    stats.no_candidate += none as usize;
    stats.low_texture += low as usize;
    stats.not_unique += not_unique as usize;
}

/// The 256-bit helpers both kernels share (AVX2 instructions), compiled with `$feat`.
macro_rules! ymm_helpers {
    ($feat:literal) => {
        type V = __m256i;
        const L: usize = 16;

        #[inline]
        #[target_feature(enable = $feat)]
        unsafe fn ld(p: *const u16) -> V {
            // SAFETY: the caller guarantees 16 readable u16 at p.
            unsafe { _mm256_loadu_si256(p as *const V) }
        }
        #[inline]
        #[target_feature(enable = $feat)]
        unsafe fn st(p: *mut u16, v: V) {
            // SAFETY: the caller guarantees 16 writable u16 at p.
            unsafe { _mm256_storeu_si256(p as *mut V, v) }
        }
        #[inline]
        #[target_feature(enable = $feat)]
        fn splat(v: u16) -> V {
            _mm256_set1_epi16(v as i16)
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
        /// `|a − b|` for values below 2^15.
        #[inline]
        #[target_feature(enable = $feat)]
        fn absdiff(a: V, b: V) -> V {
            _mm256_abs_epi16(_mm256_sub_epi16(a, b))
        }
        /// All-ones lanes where `d < lo` or `d > hi` (signed 16-bit compares; all values < 2^15).
        #[inline]
        #[target_feature(enable = $feat)]
        fn outside(d: V, lo: V, hi: V) -> V {
            _mm256_or_si256(_mm256_cmpgt_epi16(lo, d), _mm256_cmpgt_epi16(d, hi))
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
        fn top(v: V) -> u16 {
            _mm256_extract_epi16::<15>(v) as u16
        }
        /// The smallest `(min << 16) | idx` over the lanes.
        #[inline]
        #[target_feature(enable = $feat)]
        fn reduce(min: V, idx: V) -> u32 {
            let k = _mm256_min_epu32(_mm256_unpacklo_epi16(idx, min), _mm256_unpackhi_epi16(idx, min));
            let k = _mm_min_epu32(_mm256_castsi256_si128(k), _mm256_extracti128_si256::<1>(k));
            let k = _mm_min_epu32(k, _mm_shuffle_epi32::<0b01_00_11_10>(k));
            let k = _mm_min_epu32(k, _mm_shuffle_epi32::<0b10_11_00_01>(k));
            _mm_cvtsi128_si32(k) as u32
        }
    };
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{Ptrs, Scratch16, decide_row};
    use crate::engine::{MatchStats, Shared, finish_row, load_rows, unique};

    ymm_helpers!("avx2");

    /// Per lane: if `c < min` (unsigned) then `min = c`, `idx = d`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn min_update(min: &mut V, idx: &mut V, c: V, d: V) {
        let nm = _mm256_min_epu16(*min, c);
        let keep = _mm256_cmpeq_epi16(nm, *min);
        *idx = _mm256_blendv_epi8(d, *idx, keep);
        *min = nm;
    }

    kernel!("avx2");
}

#[cfg(target_arch = "x86_64")]
mod avx512vl {
    use std::arch::x86_64::*;

    use super::{Ptrs, Scratch16, decide_row};
    use crate::engine::{MatchStats, Shared, finish_row, load_rows, unique};

    ymm_helpers!("avx2,avx512f,avx512bw,avx512vl");

    /// Per lane: if `c < min` (unsigned) then `min = c`, `idx = d` (one compare into a mask
    /// register and a masked move instead of AVX2's compare + byte blend).
    #[inline]
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl")]
    fn min_update(min: &mut V, idx: &mut V, c: V, d: V) {
        let better = _mm256_cmplt_epu16_mask(c, *min);
        *idx = _mm256_mask_mov_epi16(*idx, better, d);
        *min = _mm256_min_epu16(*min, c);
    }

    kernel!("avx2,avx512f,avx512bw,avx512vl");
}
