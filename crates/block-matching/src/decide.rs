//! The decisions every kernel family shares, once per pixel or row: winner-take-all over a cost
//! curve, uniqueness, the sub-pixel step, the left–right check against the right image's
//! winners, the confidence and the fill of rejected pixels. Depends only on the frame's inputs.

use parallax_camera_model::DisparityMap;

use crate::config::Subpixel;
use crate::frame::{MatchStats, Shared};

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
            // the right image's winner at its own right pixel (not at edge-cut pixels: exact).
            // A right pixel no left winner matched (`u32::MAX`, the left winners' right
            // disparities) does not reject: OpenCV's `disp2ptr[x_] >= minD` condition
            if sh.lr_subpixel & !edge & valid & (diff > tol) & (sub[x] != 0.0) {
                let k2 = if sub[x] > 0.0 { kk + 1 } else { kk - 1 };
                if (0..nd).contains(&k2) {
                    let u2 = (x as i64 - dmin - k2).clamp(0, w - 1) as usize;
                    let r2 = right_winner(u2);
                    diff = diff.min(if r2 == u32::MAX { tol } else { (r2 as i64 - k2).unsigned_abs() });
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
