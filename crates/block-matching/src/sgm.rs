//! Semi-global matching (Hirschmüller 2008) on the matcher's prefiltered planes, with the block
//! matcher's decisions (texture, uniqueness, left–right check, confidence, fill, sub-pixel).
//!
//! Cost: `C(x, y, d)`, the SAD of the prefiltered images over a `block x block` window
//! (clamp-to-edge, as the block matcher), for every `d` of the range; a candidate whose matching
//! pixel lies outside the right image costs `block² · max pixel` (the largest possible cost).
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
//! strip; with eight paths, the three paths from below start `overlap` rows below it. Five
//! paths (left→right, right→left, and from the top, top-left and top-right) need one pass and
//! `9 · W · (D + 2) · 2` bytes per task; eight paths add a backward pass (bottom, bottom-left,
//! bottom-right) over the strip's stored forward sums: `(strip + 9) · W · (D + 2) · 2` bytes
//! per task, where the strip height is capped so this stays under 48 MiB.
//!
//! Every step is exact 16-bit integer arithmetic (the run refuses costs whose sums could
//! exceed 16 bits), written as plain loops over the disparities that the compiler vectorises;
//! the band is compiled for AVX2 too and chosen at run time. The naive reference in
//! `tests/sgm_vs_naive.rs` implements the same definition directly on a full cost volume.

use crate::config::{SgmConfig, SgmPaths};
use crate::engine::{MatchStats, Shared, conf_row, decide, finish_row, load_rows, right_update};
use crate::error::{BlockMatchingError, Result};

/// Largest task memory of the eight-path strips, bytes.
const STRIP_BYTES: usize = 48 << 20;

/// Sentinel of the padding lanes `d = −1` and `d = D` (never a minimum).
const PAD: u16 = u16::MAX;

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
}

impl<'a> SgmParams<'a> {
    /// Checks that every sum fits in 16 bits and derives the penalties.
    pub(crate) fn new(cfg: &SgmConfig, max_pixel: u64, intensity: &'a [u16], intensity_scale: u32) -> Result<Self> {
        let n = (cfg.block * cfg.block) as u64;
        let cmax = n * max_pixel;
        let (p1, p2) = (cfg.p1 as u64 * n, cfg.p2 as u64 * n);
        let npaths = match cfg.paths {
            SgmPaths::Five => 5,
            SgmPaths::Eight => 8,
        };
        // L ≤ C + P2, S ≤ paths · (C + P2); 65535 is the padding sentinel
        if npaths * (cmax + p2) >= PAD as u64 {
            return Err(BlockMatchingError::InvalidConfig {
                field: "sgm",
                value: format!("block {} · max pixel {max_pixel} with p2 {} over {npaths} paths", cfg.block, cfg.p2),
                reason: "aggregated costs must fit in 16 bits: use the rank or x-Sobel prefilter (small pixel \
                         values), a smaller sgm.block or smaller penalties",
            });
        }
        Ok(Self {
            paths: cfg.paths,
            p1: p1 as u16,
            p2: p2 as u16,
            gamma: cfg.p2_gamma,
            intensity,
            intensity_scale,
            cmax: cmax as u16,
            overlap: cfg.overlap,
        })
    }

    /// `P2'` between the left pixels `a` and `b`.
    #[inline(always)]
    fn p2_between(&self, a: u16, b: u16) -> u16 {
        if self.gamma == 0 {
            return self.p2;
        }
        let di = (a as i32 - b as i32).unsigned_abs() / self.intensity_scale;
        let v = self.p2 as u32 * self.gamma / (self.gamma + di);
        v.max(self.p1 as u32) as u16
    }
}

/// The strip height: at least two strips per thread for balance, and (eight paths) the strip's
/// stored sums under [`STRIP_BYTES`].
pub(crate) fn strip_rows(cfg: &SgmConfig, w: usize, h: usize, nd: usize, threads: usize) -> usize {
    if cfg.strip_rows > 0 {
        return cfg.strip_rows.min(h);
    }
    let mut rows = h.div_ceil(threads.max(1)).max(1);
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
    /// `C` of the current row, `W · D`.
    cost: Vec<u16>,
    /// `S` of the current row, `W · D`.
    acc: Vec<u16>,
    /// Forward sums of the strip's rows (eight paths), `strip · W · D`.
    vol: Vec<u16>,
    /// The horizontal path's previous vector and the new one, `D + 2` (padded).
    hprev: Vec<u16>,
    hcur: Vec<u16>,
    /// Start of a path: zeros with padded ends.
    zero: Vec<u16>,
    /// The three vertical/diagonal paths, previous and current row, `W · (D + 2)` each.
    vp: [Vec<u16>; 3],
    vc: [Vec<u16>; 3],
    /// Their per-pixel minima.
    mp: [Vec<u16>; 3],
    mc: [Vec<u16>; 3],
    rc: Vec<u16>,
    rk: Vec<u32>,
    best: Vec<i32>,
    sub: Vec<f32>,
    ratio: Vec<f32>,
}

impl Scratch {
    fn resize(&mut self, sh: &Shared, strip: usize, eight: bool) {
        let (w, r, nd) = (sh.w, sh.r, sh.nd);
        let (wp, ndp) = (w + 2 * r, nd + 2);
        self.colsum.resize(wp * nd, 0);
        for v in [&mut self.l_a, &mut self.l_b] {
            v.resize(wp, 0);
        }
        for v in [&mut self.r_a, &mut self.r_b] {
            v.resize(wp + nd - 1, 0);
        }
        self.cost.resize(w * nd, 0);
        self.acc.resize(w * nd, 0);
        if eight {
            self.vol.resize(strip * w * nd, 0);
        }
        for v in [&mut self.hprev, &mut self.hcur] {
            v.resize(ndp, PAD);
        }
        self.zero.clear();
        self.zero.resize(ndp, 0);
        self.zero[0] = PAD;
        self.zero[ndp - 1] = PAD;
        for v in self.vp.iter_mut().chain(self.vc.iter_mut()) {
            v.resize(w * ndp, PAD);
        }
        for v in self.mp.iter_mut().chain(self.mc.iter_mut()) {
            v.resize(w, 0);
        }
        self.rc.resize(w, u16::MAX);
        self.rk.resize(w, u32::MAX);
        self.best.resize(w, -1);
        self.sub.resize(w, 0.0);
        self.ratio.resize(w, 0.0);
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

/// Adds (or, with `sub`, replaces row `b` by row `a` in) the column sums: `|L − R|` of the rows
/// loaded in `l_a/r_a` (and `l_b/r_b`).
#[inline(always)]
fn vertical(sc: &mut Scratch, nd: usize, sub: bool) {
    let wp = sc.l_a.len();
    for (xp, cs) in sc.colsum.chunks_exact_mut(nd).enumerate().take(wp) {
        let base = wp - 1 - xp;
        let (ra, la) = (&sc.r_a[base..base + nd], sc.l_a[xp]);
        if sub {
            let (rb, lb) = (&sc.r_b[base..base + nd], sc.l_b[xp]);
            for k in 0..nd {
                cs[k] = cs[k] + la.abs_diff(ra[k]) - lb.abs_diff(rb[k]);
            }
        } else {
            for k in 0..nd {
                cs[k] += la.abs_diff(ra[k]);
            }
        }
    }
}

/// The column sums of row `y` from scratch.
fn colsum_init(sh: &Shared, sc: &mut Scratch, y: usize) {
    let (h, r) = (sh.h as i64, sh.r as i64);
    sc.colsum.fill(0);
    for j in y as i64 - r..=y as i64 + r {
        load_rows(sh, j.clamp(0, h - 1) as usize, &mut sc.l_a, &mut sc.r_a);
        vertical(sc, sh.nd, false);
    }
}

/// Moves the column sums from row `y` to row `y + 1` (`down`) or `y − 1`.
fn colsum_move(sh: &Shared, sc: &mut Scratch, y: usize, down: bool) {
    let (h, r) = (sh.h as i64, sh.r as i64);
    let clamp = |v: i64| v.clamp(0, h - 1) as usize;
    let (yi, yo) = if down {
        (clamp(y as i64 + 1 + r), clamp(y as i64 - r))
    } else {
        (clamp(y as i64 - 1 - r), clamp(y as i64 + r))
    };
    if yi != yo {
        load_rows(sh, yi, &mut sc.l_a, &mut sc.r_a);
        load_rows(sh, yo, &mut sc.l_b, &mut sc.r_b);
        vertical(sc, sh.nd, true);
    }
}

/// `C` of the current row from the column sums: running box sums along the row, then the
/// out-of-image candidates set to `cmax`.
fn cost_row(sh: &Shared, sc: &mut Scratch, cmax: u16) {
    let (w, r, nd, dmin) = (sh.w, sh.r, sh.nd, sh.dmin);
    let (cost, colsum) = (&mut sc.cost, &sc.colsum);
    {
        let c0 = &mut cost[..nd];
        c0.fill(0);
        for xp in 0..=2 * r {
            for (c, &s) in c0.iter_mut().zip(&colsum[xp * nd..][..nd]) {
                *c += s;
            }
        }
    }
    for x in 1..w {
        let (prev, cur) = cost[(x - 1) * nd..(x + 1) * nd].split_at_mut(nd);
        let (a, s) = (&colsum[(x + 2 * r) * nd..][..nd], &colsum[(x - 1) * nd..][..nd]);
        for k in 0..nd {
            cur[k] = prev[k] + a[k] - s[k];
        }
    }
    for x in 0..w {
        let xd = x as i64 - dmin;
        let lo = (xd - (w as i64 - 1)).clamp(0, nd as i64) as usize;
        let hi = (xd + 1).clamp(0, nd as i64) as usize;
        let c = &mut cost[x * nd..][..nd];
        c[..lo].fill(cmax);
        c[hi.max(lo)..].fill(cmax);
    }
}

/// The forward paths of row `y`: right→left, left→right and, from the row above (unless
/// `first`), top, top-left and top-right. Writes `S` of these paths to `acc`.
fn forward_row(sh: &Shared, sc: &mut Scratch, pp: &SgmParams, y: usize, first: bool) {
    let (w, nd) = (sh.w, sh.nd);
    let ndp = nd + 2;
    let row = &pp.intensity[y * w..][..w];
    let above = if first { row } else { &pp.intensity[(y - 1) * w..][..w] };
    // right → left
    let mut pmin = 0;
    sc.hprev.copy_from_slice(&sc.zero);
    for x in (0..w).rev() {
        let p2 = if x + 1 < w { pp.p2_between(row[x], row[x + 1]) } else { pp.p2 };
        let prev = if x + 1 < w { &sc.hprev } else { &sc.zero };
        pmin = step_set(&sc.cost[x * nd..][..nd], prev, pmin, pp.p1, p2, &mut sc.hcur, &mut sc.acc[x * nd..][..nd]);
        std::mem::swap(&mut sc.hprev, &mut sc.hcur);
    }
    // left → right, top, top-left, top-right
    let (vp, vc, mp, mc) = (&sc.vp, &mut sc.vc, &sc.mp, &mut sc.mc);
    let [vc0, vc1, vc2] = vc;
    let [mc0, mc1, mc2] = mc;
    for x in 0..w {
        let c = &sc.cost[x * nd..][..nd];
        let acc = &mut sc.acc[x * nd..][..nd];
        let (prev, p2) = if x > 0 { (&sc.hprev, pp.p2_between(row[x], row[x - 1])) } else { (&sc.zero, pp.p2) };
        pmin = step(c, prev, if x > 0 { pmin } else { 0 }, pp.p1, p2, &mut sc.hcur, acc);
        std::mem::swap(&mut sc.hprev, &mut sc.hcur);
        // from (x, y − 1)
        let (prev, m, p2) = if first {
            (&sc.zero[..], 0, pp.p2)
        } else {
            (&vp[0][x * ndp..][..ndp], mp[0][x], pp.p2_between(row[x], above[x]))
        };
        mc0[x] = step(c, prev, m, pp.p1, p2, &mut vc0[x * ndp..][..ndp], acc);
        // from (x − 1, y − 1)
        let (prev, m, p2) = if first || x == 0 {
            (&sc.zero[..], 0, pp.p2)
        } else {
            (&vp[1][(x - 1) * ndp..][..ndp], mp[1][x - 1], pp.p2_between(row[x], above[x - 1]))
        };
        mc1[x] = step(c, prev, m, pp.p1, p2, &mut vc1[x * ndp..][..ndp], acc);
        // from (x + 1, y − 1)
        let (prev, m, p2) = if first || x + 1 == w {
            (&sc.zero[..], 0, pp.p2)
        } else {
            (&vp[2][(x + 1) * ndp..][..ndp], mp[2][x + 1], pp.p2_between(row[x], above[x + 1]))
        };
        mc2[x] = step(c, prev, m, pp.p1, p2, &mut vc2[x * ndp..][..ndp], acc);
    }
    std::mem::swap(&mut sc.vp, &mut sc.vc);
    std::mem::swap(&mut sc.mp, &mut sc.mc);
}

/// The backward paths of row `y` (from the row below unless `first`): bottom, bottom-left,
/// bottom-right, added to `acc`.
fn backward_row(sh: &Shared, sc: &mut Scratch, pp: &SgmParams, y: usize, first: bool) {
    let (w, nd) = (sh.w, sh.nd);
    let ndp = nd + 2;
    let row = &pp.intensity[y * w..][..w];
    let below = if first { row } else { &pp.intensity[(y + 1) * w..][..w] };
    let (vp, vc, mp, mc) = (&sc.vp, &mut sc.vc, &sc.mp, &mut sc.mc);
    let [vc0, vc1, vc2] = vc;
    let [mc0, mc1, mc2] = mc;
    for x in 0..w {
        let c = &sc.cost[x * nd..][..nd];
        let acc = &mut sc.acc[x * nd..][..nd];
        let (prev, m, p2) = if first {
            (&sc.zero[..], 0, pp.p2)
        } else {
            (&vp[0][x * ndp..][..ndp], mp[0][x], pp.p2_between(row[x], below[x]))
        };
        mc0[x] = step(c, prev, m, pp.p1, p2, &mut vc0[x * ndp..][..ndp], acc);
        let (prev, m, p2) = if first || x == 0 {
            (&sc.zero[..], 0, pp.p2)
        } else {
            (&vp[1][(x - 1) * ndp..][..ndp], mp[1][x - 1], pp.p2_between(row[x], below[x - 1]))
        };
        mc1[x] = step(c, prev, m, pp.p1, p2, &mut vc1[x * ndp..][..ndp], acc);
        let (prev, m, p2) = if first || x + 1 == w {
            (&sc.zero[..], 0, pp.p2)
        } else {
            (&vp[2][(x + 1) * ndp..][..ndp], mp[2][x + 1], pp.p2_between(row[x], below[x + 1]))
        };
        mc2[x] = step(c, prev, m, pp.p1, p2, &mut vc2[x * ndp..][..ndp], acc);
    }
    std::mem::swap(&mut sc.vp, &mut sc.vc);
    std::mem::swap(&mut sc.mp, &mut sc.mc);
}

/// The decisions of row `y` on `S` (in `acc`), as the block matcher's generic path.
fn decide_row(sh: &Shared, sc: &mut Scratch, y: usize, out: &mut [f32], conf: &mut [f32], st: &mut MatchStats) {
    let (w, nd, dmin) = (sh.w, sh.nd, sh.dmin);
    sc.rc.fill(u16::MAX);
    sc.rk.fill(u32::MAX);
    for x in 0..w {
        let xd = x as i64 - dmin;
        let lo = (xd - (w as i64 - 1)).max(0);
        let hi = xd.min(nd as i64 - 1);
        if lo > hi {
            sc.best[x] = -1;
            st.no_candidate += 1;
            continue;
        }
        let (lo, hi) = (lo as usize, hi as usize);
        let s = &sc.acc[x * nd..][..nd];
        let j0 = (w as i64 - 1 - xd + lo as i64) as usize;
        let len = hi - lo + 1;
        right_update(&s[lo..=hi], &mut sc.rc[j0..][..len], &mut sc.rk[j0..][..len], lo);
        if sh.texture_ok.is_some_and(|t| !t[y * w + x]) {
            sc.best[x] = -1;
            st.low_texture += 1;
            continue;
        }
        match decide(s, lo, hi, sh.uniq, sh.subpixel, sh.conf) {
            crate::engine::Decision::Best(k, off, ratio) => {
                sc.best[x] = k;
                sc.sub[x] = off;
                sc.ratio[x] = ratio;
            }
            crate::engine::Decision::NotUnique => {
                sc.best[x] = -1;
                st.not_unique += 1;
            }
        }
    }
    let rk = &sc.rk;
    finish_row(sh, &sc.best, &mut sc.sub, &sc.ratio, out, conf, st, |x, k| {
        rk[w - 1 - (x as i64 - dmin - k as i64) as usize]
    });
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
) -> MatchStats {
    let (w, h, nd) = (sh.w, sh.h, sh.nd);
    let eight = pp.paths == SgmPaths::Eight;
    sc.resize(sh, y1 - y0, eight);
    let mut st = MatchStats::default();
    let ys = y0.saturating_sub(pp.overlap);
    colsum_init(sh, sc, ys);
    for y in ys..y1 {
        if y > ys {
            colsum_move(sh, sc, y - 1, true);
        }
        cost_row(sh, sc, pp.cmax);
        forward_row(sh, sc, pp, y, y == ys);
        if y < y0 {
            continue;
        }
        if eight {
            sc.vol[(y - y0) * w * nd..][..w * nd].copy_from_slice(&sc.acc);
        } else {
            decide_row(sh, sc, y, &mut out[(y - y0) * w..][..w], conf_row(sh, conf, y, y0), &mut st);
        }
    }
    if eight {
        let ye = (y1 + pp.overlap).min(h);
        colsum_init(sh, sc, ye - 1);
        for y in (y0..ye).rev() {
            if y + 1 < ye {
                colsum_move(sh, sc, y + 1, false);
            }
            cost_row(sh, sc, pp.cmax);
            if y < y1 {
                sc.acc.copy_from_slice(&sc.vol[(y - y0) * w * nd..][..w * nd]);
            } else {
                sc.acc.fill(0);
            }
            backward_row(sh, sc, pp, y, y + 1 == ye);
            if y < y1 {
                decide_row(sh, sc, y, &mut out[(y - y0) * w..][..w], conf_row(sh, conf, y, y0), &mut st);
            }
        }
    }
    st
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn strip_avx2(
    sh: &Shared,
    pp: &SgmParams,
    sc: &mut Scratch,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
) -> MatchStats {
    strip(sh, pp, sc, out, conf, y0, y1)
}

/// Rows `y0..y1` of one strip, compiled for AVX2 when `avx2` (the same code).
pub(crate) fn run_strip(
    sh: &Shared,
    pp: &SgmParams,
    sc: &mut Scratch,
    out: &mut [f32],
    conf: &mut [f32],
    y0: usize,
    y1: usize,
    avx2: bool,
) -> MatchStats {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: the caller passes `avx2` only when `SimdLevel::detect()` found AVX2.
        return unsafe { strip_avx2(sh, pp, sc, out, conf, y0, y1) };
    }
    let _ = avx2;
    strip(sh, pp, sc, out, conf, y0, y1)
}
