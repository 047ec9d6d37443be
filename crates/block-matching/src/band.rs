//! The generic band: any cost (SAD, SSD, NCC) in `u32`, `u64` or `f64` sums (SAD and SSD also
//! summed over a colour pair's channels, `Shared::extra`), running box sums
//! over disparity-major column sums, with the shared decisions per row. Runs where the fused
//! vector kernels (`simd.rs`) do not: NCC, sums past `u32`, and the scalar level.

use crate::config::CostFunction;
use crate::decide::{Cost, Decision, WinnersBy, decide, finish_row, right_update};
use crate::frame::{MatchStats, Shared, conf_row, for_each_band, load_plane_rows};
use crate::prefilter::TextureRows;
use parallax_simd::{Avx2, Level, SimdLevel};

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

/// Buffers of one row band, reused across frames.
#[derive(Default)]
pub(crate) struct Scratch<A> {
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

pub(crate) fn run_bands<A: Acc>(
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
        // compiled for AVX2 (the token proves the CPU runs it)
        return t.vectorize(
            #[inline(always)]
            || band::<A, K>(sh, sc, out, conf, y0, y1),
        );
    }
    band::<A, K>(sh, sc, out, conf, y0, y1)
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
                // (each channel's terms added to the same column sums)
                for [left, right] in sh.planes() {
                    load_plane_rows(sh, left, right, clamp_y(j), &mut sc.l_in, &mut sc.r_in);
                    vertical::<A, K>(sc, nd, false);
                }
            }
        } else {
            let yi = clamp_y(y as i64 + r as i64);
            let yo = clamp_y(y as i64 - r as i64 - 1);
            if yi != yo {
                for [left, right] in sh.planes() {
                    load_plane_rows(sh, left, right, yi, &mut sc.l_in, &mut sc.r_in);
                    load_plane_rows(sh, left, right, yo, &mut sc.l_out, &mut sc.r_out);
                    vertical::<A, K>(sc, nd, true);
                }
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
