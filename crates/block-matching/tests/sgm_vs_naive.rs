//! Semi-global matching against a naive reference written from the definition (module docs of
//! `sgm.rs`): the full cost volume by direct window sums, each path aggregated by its own
//! recursion over the strip's domain, the sum, then the same decisions as the block matcher's
//! naive reference. Integer aggregation: the fast path must match exactly, on every strip
//! layout, path count, penalty setting and instruction set.

use image::{GrayImage, Luma};
use parallax_block_matching::prefilter::{rank_transform, texture_mask_into, x_sobel};
use parallax_block_matching::{
    BlockMatcher, MatcherConfig, Method, Prefilter, SgmConfig, SgmPaths, SimdLevel, Subpixel,
};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

mod common;
use common::clampi;

/// The naive SGM: returns the disparity map (NaN invalid) and the confidence (0 where invalid).
/// `scale`: 1 for 8-bit input, 257 for 16-bit (prefilter caps and intensity differences).
fn naive(left: &[u16], right: &[u16], w: usize, h: usize, cfg: &MatcherConfig, scale: i64) -> (Vec<f32>, Vec<f32>) {
    naive_channels(left, &[(left, right)], w, h, cfg, scale)
}

/// [`naive`] with the pixel cost summed over `channels` (left and right planes; colour: the
/// three channels, `left` the left image's grey conversion for the texture and the adaptive P2).
fn naive_channels(
    left: &[u16],
    channels: &[(&[u16], &[u16])],
    w: usize,
    h: usize,
    cfg: &MatcherConfig,
    scale: i64,
) -> (Vec<f32>, Vec<f32>) {
    let g = &cfg.sgm;
    let nd = cfg.num_disparities;
    let dmin = cfg.min_disparity as i64;
    let prefilter = |img: &[u16]| -> (Vec<u16>, i64) {
        match cfg.prefilter {
            Prefilter::XSobel { cap } => {
                let c = cap as u32 * scale as u32;
                (x_sobel(img, w, h, c), 2 * c as i64)
            }
            Prefilter::Rank { size } => (rank_transform(img, w, h, size), (size * size - 1) as i64),
            _ => unreachable!("the test uses x-Sobel and rank"),
        }
    };
    // per channel: the prefiltered left and right planes and the raw ones
    let planes: Vec<_> = channels.iter().map(|&(a, b)| (prefilter(a).0, prefilter(b).0, a, b)).collect();
    let maxv = prefilter(left).1;
    let texture_ok: Vec<bool> = if cfg.texture_threshold > 0 {
        assert_eq!(scale, 1, "the 16-bit cases run without the texture check");
        let s = x_sobel(left, w, h, 31);
        let mut t = Vec::new();
        texture_mask_into(&s, w, h, cfg.block_size / 2, 31, cfg.texture_threshold, &mut t);
        t
    } else {
        vec![true; w * h]
    };
    let r = (g.block / 2) as i64;
    let n = (g.block * g.block) as i64;
    let cmax = n * channels.len() as i64 * (maxv + if g.intensity_cost { 63 } else { 0 });
    // Birchfield–Tomasi: a pixel's interval is the range of its value and the half-way values
    // to its row neighbours (the neighbour index clamped to the image)
    let interval = |img: &[u16], x: usize, y: usize| -> (i64, i64) {
        let v = img[y * w + x] as i64;
        let vl = (v + img[y * w + x.saturating_sub(1)] as i64) / 2;
        let vr = (v + img[y * w + (x + 1).min(w - 1)] as i64) / 2;
        (v.min(vl).min(vr), v.max(vl).max(vr))
    };
    let pixel_cost = |xa: usize, xb: usize, y: usize| -> i64 {
        let mut c = 0;
        for (l, rt, left, right) in &planes {
            let (a, b) = (l[y * w + xa] as i64, rt[y * w + xb] as i64);
            c += if g.sampling_insensitive {
                let ((a0, a1), (b0, b1)) = (interval(l, xa, y), interval(rt, xb, y));
                (a - b1).max(b0 - a).max(0).min((b - a1).max(a0 - b).max(0))
            } else {
                (a - b).abs()
            };
            if g.intensity_cost {
                let q = |v: u16| (v as i64 / scale) >> 2;
                c += (q(left[y * w + xa]) - q(right[y * w + xb])).abs();
            }
        }
        c
    };
    let (p1, p2) = (g.p1 as i64 * n, g.p2 as i64 * n);
    // cost volume
    let mut c = vec![0i64; w * h * nd];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            for k in 0..nd as i64 {
                let u = x - dmin - k;
                let v = if u < 0 || u >= w as i64 {
                    cmax
                } else {
                    let mut s = 0;
                    for dy in -r..=r {
                        for dx in -r..=r {
                            s += pixel_cost(clampi(x + dx, w), clampi(u + dx, w), clampi(y + dy, h));
                        }
                    }
                    s
                };
                c[(y as usize * w + x as usize) * nd + k as usize] = v;
            }
        }
    }
    let p2_between = |a: u16, b: u16| -> i64 {
        if g.p2_gamma == 0 {
            return p2;
        }
        let di = (a as i64 - b as i64).abs() / scale;
        (p2 * g.p2_gamma as i64 / (g.p2_gamma as i64 + di)).max(p1)
    };
    // one path (dx, dy) over rows [ya, yb): predecessor (x − dx, y − dy)
    let path = |dx: i64, dy: i64, ya: usize, yb: usize, s: &mut Vec<i64>| {
        let mut lv = vec![0i64; w * h * nd];
        let rows: Vec<usize> = if dy >= 0 { (ya..yb).collect() } else { (ya..yb).rev().collect() };
        let cols: Vec<usize> = if dx >= 0 { (0..w).collect() } else { (0..w).rev().collect() };
        for &y in &rows {
            for &x in &cols {
                let (qx, qy) = (x as i64 - dx, y as i64 - dy);
                let i = y * w + x;
                let has_prev = qx >= 0 && qx < w as i64 && qy >= ya as i64 && qy < yb as i64;
                for k in 0..nd {
                    let v = if !has_prev {
                        c[i * nd + k]
                    } else {
                        let q = qy as usize * w + qx as usize;
                        let prev = &lv[q * nd..][..nd];
                        let m = *prev.iter().min().unwrap();
                        let pen2 = p2_between(left[i], left[q]);
                        let mut best = prev[k].min(m + pen2);
                        if k > 0 {
                            best = best.min(prev[k - 1] + p1);
                        }
                        if k + 1 < nd {
                            best = best.min(prev[k + 1] + p1);
                        }
                        c[i * nd + k] + best - m
                    };
                    lv[i * nd + k] = v;
                }
            }
        }
        for y in ya..yb {
            for i in y * w * nd..(y + 1) * w * nd {
                s[i] += lv[i];
            }
        }
    };
    // strips
    // the automatic layout: 2 · ⌈h / 512⌉ strips of equal height (the memory cap of eight paths
    // does not bind at these sizes), whatever the thread count
    let strip = if g.strip_rows > 0 { g.strip_rows.min(h) } else { h.div_ceil(2 * h.div_ceil(512)).min(h) };
    let mut s = vec![0i64; w * h * nd];
    let mut y0 = 0;
    while y0 < h {
        let y1 = (y0 + strip).min(h);
        let ys = y0.saturating_sub(g.overlap);
        let mut part = vec![0i64; w * h * nd];
        let from_above: &[(i64, i64)] = if g.paths == SgmPaths::Three {
            &[(1, 0), (-1, 0), (0, 1)]
        } else {
            &[(1, 0), (-1, 0), (0, 1), (1, 1), (-1, 1)]
        };
        for &(dx, dy) in from_above {
            path(dx, dy, ys, y1, &mut part);
        }
        if g.paths == SgmPaths::Eight {
            let ye = (y1 + g.overlap).min(h);
            for (dx, dy) in [(0, -1), (1, -1), (-1, -1)] {
                path(dx, dy, y0, ye, &mut part);
            }
        }
        s[y0 * w * nd..y1 * w * nd].copy_from_slice(&part[y0 * w * nd..y1 * w * nd]);
        y0 = y1;
    }
    // decisions, as the block matcher's naive reference
    let sub = match cfg.subpixel {
        Subpixel::Auto => Subpixel::Parabola,
        s => s,
    };
    let mut out = vec![f32::NAN; w * h];
    let mut confidence = vec![0.0f32; w * h];
    for y in 0..h {
        let mut rejected = vec![false; w];
        let mut rbest = vec![usize::MAX; w];
        for u in 0..w {
            let mut best = i64::MAX;
            for k in 0..nd {
                let x = u as i64 + dmin + k as i64;
                if x < 0 || x >= w as i64 {
                    continue;
                }
                let v = s[(y * w + x as usize) * nd + k];
                if v < best {
                    best = v;
                    rbest[u] = k;
                }
            }
        }
        // the winner of each pixel after the texture and uniqueness rejections, with its range
        let winner = |x: usize| -> Option<(usize, usize, usize)> {
            let cs = &s[(y * w + x) * nd..][..nd];
            let ks: Vec<usize> = (0..nd).filter(|&k| (0..w as i64).contains(&(x as i64 - dmin - k as i64))).collect();
            if ks.is_empty() || !texture_ok[y * w + x] {
                return None;
            }
            let (lo, hi) = (ks[0], *ks.last().unwrap());
            let mut kb = lo;
            for &k in &ks {
                if cs[k] < cs[kb] {
                    kb = k;
                }
            }
            let m = cs[kb];
            // where the image edge cuts the candidates short of 0..nd, a margin of at least 200 %
            // (not in filled maps)
            let cut = (lo > 0 || hi < nd - 1) && !cfg.fill;
            let uniq = if cut { cfg.uniqueness_ratio.max(200) } else { cfg.uniqueness_ratio };
            if uniq > 0 {
                let t = m + m * uniq as i64 / 100;
                let far = |k: &&usize| (**k as i64 - kb as i64).abs() > 1;
                if ks.iter().filter(far).any(|&k| cs[k] <= t) {
                    return None;
                }
                // where the edge cuts the range, a winner without a rival further than one
                // disparity away shows no margin
                if cut && !ks.iter().any(|k| far(&k)) {
                    return None;
                }
            }
            Some((kb, lo, hi))
        };
        if cfg.lr_winners {
            // OpenCV SGBM's right disparities: the winner of the left pixel with the smallest S
            // among those whose winner matches u, the first on a tie
            let mut rcost = vec![i64::MAX; w];
            rbest = vec![usize::MAX; w];
            for x in 0..w {
                if let Some((kb, ..)) = winner(x) {
                    let u = (x as i64 - dmin - kb as i64) as usize;
                    let v = s[(y * w + x) * nd + kb];
                    if v < rcost[u] {
                        (rcost[u], rbest[u]) = (v, kb);
                    }
                }
            }
        }
        for x in 0..w {
            let cs = &s[(y * w + x) * nd..][..nd];
            let ks: Vec<usize> = (0..nd).filter(|&k| (0..w as i64).contains(&(x as i64 - dmin - k as i64))).collect();
            let Some((kb, lo, hi)) = winner(x) else { continue };
            let m = cs[kb];
            let mut off = 0.0;
            if kb > lo && kb < hi && sub != Subpixel::None {
                let (a, b, c) = (cs[kb - 1] as f64, cs[kb] as f64, cs[kb + 1] as f64);
                let den = if sub == Subpixel::Equiangular { a.max(c) - b } else { a - 2.0 * b + c };
                if den > 0.0 {
                    off = ((a - c) / (2.0 * den)).clamp(-0.5, 0.5);
                }
            }
            let mut lr_factor = 1.0f32;
            if let Some(tol) = cfg.lr_max_diff {
                let u = (x as i64 - dmin - kb as i64) as usize;
                // (u is some left pixel's match: x's own)
                let mut diff = (rbest[u] as i64 - kb as i64).abs();
                // where the image cuts the candidates short of 0..nd: an exact match only, and
                // not on the candidate the image cut at (its right pixel is a border column)
                let (cut_lo, cut_hi) = (lo > 0, hi < nd - 1);
                let tol = if cut_lo || cut_hi { 0 } else { tol as i64 };
                // SGBM's rule: the integer on the other side of the sub-pixel disparity counts too
                if cfg.lr_subpixel && !(cut_lo || cut_hi) && diff > tol && off != 0.0 {
                    let k2 = if off > 0.0 { kb + 1 } else { kb - 1 };
                    let u2 = (x as i64 - dmin - k2 as i64) as usize;
                    // a right pixel no left winner matched does not reject (OpenCV SGBM's
                    // `disp2ptr[x_] >= minD`); without the left winners every right pixel
                    // with a candidate has a winner, and one without none
                    diff = diff.min(match rbest[u2] {
                        usize::MAX if cfg.lr_winners => tol,
                        usize::MAX => i64::MAX,
                        r => (r as i64 - k2 as i64).abs(),
                    });
                }
                let on_cut = (cut_lo && kb == lo) || (cut_hi && kb == hi);
                if diff > tol || on_cut {
                    rejected[x] = true;
                    continue;
                }
                lr_factor = 1.0 / (1.0 + diff as f32);
            }
            if cfg.confidence_map || cfg.min_confidence > 0.0 {
                let c2 = ks.iter().filter(|&&k| (k as i64 - kb as i64).abs() > 1).map(|&k| cs[k]).min();
                let ratio = match c2 {
                    Some(c2) if c2 > 0 => (1.0 - m as f64 / c2 as f64).clamp(0.0, 1.0) as f32,
                    _ => 0.0,
                };
                let cf = ratio * lr_factor;
                if cf < cfg.min_confidence {
                    rejected[x] = true;
                    continue;
                }
                confidence[y * w + x] = cf;
            }
            out[y * w + x] = (dmin + kb as i64) as f32 + off as f32;
        }
        if cfg.fill {
            let row: Vec<f32> = out[y * w..][..w].to_vec();
            for x in 0..w {
                if !rejected[x] {
                    continue;
                }
                let left = (0..x).rev().map(|i| row[i]).find(|v| !v.is_nan());
                let right = (x + 1..w).map(|i| row[i]).find(|v| !v.is_nan());
                out[y * w + x] = match (left, right) {
                    (Some(a), Some(b)) => a.min(b),
                    (Some(a), None) | (None, Some(a)) => a,
                    (None, None) => f32::NAN,
                };
            }
        }
    }
    (out, confidence)
}

/// Right = left shifted by a piecewise-constant disparity (two layers) plus sparse noise.
fn make_pair(seed: u64, w: usize, h: usize) -> (Vec<u16>, Vec<u16>) {
    let mut rnd = common::rng(seed);
    let big = w + 40;
    let tex: Vec<u16> = (0..big * h).map(|_| (rnd() % 256) as u16).collect();
    let (d0, d1) = ((rnd() % 6) as usize, (rnd() % 6) as usize + 2);
    let left: Vec<u16> = (0..w * h).map(|i| tex[(i / w) * big + i % w + 20]).collect();
    let right: Vec<u16> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let d = if x > w / 3 && x < 2 * w / 3 && y > h / 4 { d1 } else { d0 };
            let v = tex[y * big + x + 20 + d];
            if rnd().is_multiple_of(5) { v.saturating_add((rnd() % 9) as u16).min(255) } else { v }
        })
        .collect();
    (left, right)
}

/// Right = left shifted as in [`make_pair`], without noise, of a texture made of constant runs
/// (4–23 columns, bands of 4–9 rows): low-texture pixels inside long runs, texture at the steps.
fn make_flat_pair(seed: u64, w: usize, h: usize) -> (Vec<u16>, Vec<u16>) {
    let mut rnd = common::rng(seed);
    let big = w + 40;
    let mut tex = vec![0u16; big * h];
    let mut y = 0;
    while y < h {
        let bh = 4 + (rnd() % 6) as usize;
        let mut row = vec![0u16; big];
        let mut x = 0;
        while x < big {
            let len = 4 + (rnd() % 20) as usize;
            row[x..(x + len).min(big)].fill((rnd() % 256) as u16);
            x += len;
        }
        for yy in y..(y + bh).min(h) {
            tex[yy * big..][..big].copy_from_slice(&row);
        }
        y += bh;
    }
    let (d0, d1) = ((rnd() % 6) as usize, (rnd() % 6) as usize + 2);
    let left: Vec<u16> = (0..w * h).map(|i| tex[(i / w) * big + i % w + 20]).collect();
    let right: Vec<u16> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let d = if x > w / 3 && x < 2 * w / 3 && y > h / 4 { d1 } else { d0 };
            tex[y * big + x + 20 + d]
        })
        .collect();
    (left, right)
}

fn run_case(seed: u64, w: usize, h: usize, cfg: MatcherConfig) {
    let (l, r) = make_pair(seed, w, h);
    run_pair(&l, &r, seed, w, h, &cfg);
}

/// Fast against naive on one pair at every level the CPU has; returns the low-texture rejections
/// of the last level run.
fn run_pair(l: &[u16], r: &[u16], seed: u64, w: usize, h: usize, cfg: &MatcherConfig) -> usize {
    let mut low_texture = 0;
    let (expect, expect_conf) = naive(l, r, w, h, cfg, 1);
    let li = GrayImage::from_fn(w as u32, h as u32, |x, y| Luma([l[y as usize * w + x as usize] as u8]));
    let ri = GrayImage::from_fn(w as u32, h as u32, |x, y| Luma([r[y as usize * w + x as usize] as u8]));
    for level in [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512] {
        // two threads: the strip layout does not depend on them
        let mut m = BlockMatcher::new(MatcherConfig { threads: 2, ..cfg.clone() }).unwrap();
        if m.set_simd(level) != level {
            continue;
        }
        m.compute(&li, &ri).unwrap();
        let got = m.compute(&li, &ri).unwrap();
        let what = format!("{level:?} seed {seed} {w}x{h} {cfg:?}");
        for (i, (a, b)) in got.data().iter().zip(&expect).enumerate() {
            let same = (a.is_nan() && b.is_nan()) || a == b;
            assert!(same, "{what}: pixel ({}, {}) fast {a} naive {b}", i % w, i / w);
        }
        if let Some(c) = m.confidence() {
            for (i, (a, b)) in c.iter().zip(&expect_conf).enumerate() {
                assert!(a == b, "confidence, {what}: pixel ({}, {}) fast {a} naive {b}", i % w, i / w);
            }
        }
        low_texture = m.last_stats().low_texture;
    }
    low_texture
}

/// Low-texture pixels whose candidates are all in the image, with the left–right check: a
/// rejected pixel's sums still enter the right image's minima (the vector level's loop over
/// such pixels has its own path for them, which random images never reach).
#[test]
fn sgm_fast_equals_naive_with_low_texture_pixels_and_the_left_right_check() {
    let (w, h) = (96, 20);
    let mut rejected = 0;
    for seed in 0..48u64 {
        let cfg = MatcherConfig {
            method: Method::Sgm,
            num_disparities: [16, 24, 40, 64][seed as usize / 3 % 4],
            min_disparity: [0, -3, 2][seed as usize / 12 % 3],
            uniqueness_ratio: [15, 0][seed as usize % 2],
            lr_max_diff: Some([1, 0][seed as usize / 2 % 2]),
            speckle_window_size: 0,
            sgm: SgmConfig {
                paths: [SgmPaths::Three, SgmPaths::Five, SgmPaths::Eight][seed as usize % 3],
                strip_rows: 7,
                overlap: 3,
                ..SgmConfig::default()
            },
            ..MatcherConfig::default()
        };
        assert!(cfg.texture_threshold > 0);
        let (l, r) = make_flat_pair(seed, w, h);
        rejected += run_pair(&l, &r, seed, w, h, &cfg);
    }
    // the images do reach the rejection (12152 of the cases' 48 · 1920 pixels at the vector
    // level when written)
    assert!(rejected > 1000, "{rejected} low-texture pixels");
}

fn sgm_strategy() -> impl Strategy<Value = MatcherConfig> {
    (
        prop_oneof![Just(SgmPaths::Three), Just(SgmPaths::Five), Just(SgmPaths::Eight)],
        prop_oneof![Just(1usize), Just(3), Just(5)],
        (1u32..6, 0u32..40),
        prop_oneof![Just(0u32), Just(4), Just(30)],
        prop_oneof![Just((0usize, 0usize)), Just((3, 2)), Just((5, 0)), Just((4, 9))],
        prop_oneof![Just(Prefilter::XSobel { cap: 31 }), Just(Prefilter::Rank { size: 5 })],
        (-3i32..4, 1usize..40),
        (prop_oneof![Just(0u32), Just(10)], prop_oneof![Just(0u32), Just(20)]),
        (prop_oneof![Just(None), Just(Some(0u32)), Just(Some(1))], any::<bool>()),
        prop_oneof![Just((false, 0.0f32)), Just((true, 0.0)), Just((true, 0.1))],
        (
            prop_oneof![Just(Subpixel::Auto), Just(Subpixel::Equiangular), Just(Subpixel::None)],
            (any::<bool>(), any::<bool>(), any::<bool>()),
            any::<bool>(),
        ),
    )
        .prop_map(
            |(
                paths,
                block,
                (p1, extra),
                p2_gamma,
                (strip_rows, overlap),
                prefilter,
                (min_disparity, num_disparities),
                (texture_threshold, uniqueness_ratio),
                (lr_max_diff, fill),
                (confidence_map, min_confidence),
                (subpixel, (sampling_insensitive, intensity_cost, lr_subpixel), lr_winners),
            )| MatcherConfig {
                method: Method::Sgm,
                sgm: SgmConfig {
                    paths,
                    p1,
                    p2: p1 + extra,
                    p2_gamma,
                    block,
                    strip_rows,
                    overlap,
                    sampling_insensitive,
                    intensity_cost,
                },
                lr_subpixel,
                lr_winners,
                prefilter,
                min_disparity,
                num_disparities,
                texture_threshold,
                uniqueness_ratio,
                lr_max_diff,
                fill,
                confidence_map,
                min_confidence,
                subpixel,
                speckle_window_size: 0,
                ..MatcherConfig::default()
            },
        )
}

proptest! {
    #![proptest_config(Config { cases: 40, rng_seed: RngSeed::Fixed(0x5e6_5e6), failure_persistence: None, ..Config::default() })]

    #[test]
    fn sgm_fast_equals_naive(cfg in sgm_strategy(), seed in any::<u64>(), w in 5usize..28, h in 3usize..18) {
        run_case(seed, w, h, cfg);
    }
}

/// A colour pair (three channels from three random pairs) against the naive reference with
/// the cost summed over the channels, at every level the CPU has. Returns whether it ran (false:
/// the configuration's sums do not fit 16 bits with three channels, refused).
fn run_colour_case(seed: u64, w: usize, h: usize, cfg: &MatcherConfig) -> bool {
    use parallax_block_matching::image::{Rgb, RgbImage};
    let chans: Vec<(Vec<u16>, Vec<u16>)> = (0..3).map(|c| make_pair(seed.wrapping_add(c * 7919), w, h)).collect();
    let rgb = |side: usize| {
        RgbImage::from_fn(w as u32, h as u32, |x, y| {
            let i = y as usize * w + x as usize;
            let v = |c: usize| if side == 0 { chans[c].0[i] } else { chans[c].1[i] } as u8;
            Rgb([v(0), v(1), v(2)])
        })
    };
    let (li, ri) = (rgb(0), rgb(1));
    // the grey conversion the matcher documents
    let grey = |im: &RgbImage| -> Vec<u16> {
        parallax_block_matching::image::imageops::grayscale(im).as_raw().iter().map(|&v| v as u16).collect()
    };
    let gl = grey(&li);
    let planes: Vec<(&[u16], &[u16])> = chans.iter().map(|(a, b)| (a.as_slice(), b.as_slice())).collect();
    let mut ran = false;
    for level in [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512] {
        let mut m = BlockMatcher::new(MatcherConfig { threads: 2, ..cfg.clone() }).unwrap();
        if m.set_simd(level) != level {
            continue;
        }
        let got = match m.compute_rgb(&li, &ri) {
            Ok(d) => d,
            Err(e) if e.to_string().contains("16 bits") => return false,
            Err(e) => panic!("{e}"),
        };
        let (expect, _) = naive_channels(&gl, &planes, w, h, cfg, 1);
        let what = format!("colour, {level:?} seed {seed} {w}x{h} {cfg:?}");
        for (i, (a, b)) in got.data().iter().zip(&expect).enumerate() {
            let same = (a.is_nan() && b.is_nan()) || a == b;
            assert!(same, "{what}: pixel ({}, {}) fast {a} naive {b}", i % w, i / w);
        }
        ran = true;
    }
    ran
}

proptest! {
    #![proptest_config(Config { cases: 24, rng_seed: RngSeed::Fixed(0xc0_10a5), failure_persistence: None, ..Config::default() })]

    #[test]
    fn sgm_fast_equals_naive_on_colour_pairs(cfg in sgm_strategy(), seed in any::<u64>(), w in 5usize..28, h in 3usize..18) {
        prop_assume!(run_colour_case(seed, w, h, &cfg));
    }
}

#[test]
fn sgm_fast_equals_naive_with_the_defaults_and_eight_paths() {
    for paths in [SgmPaths::Three, SgmPaths::Five, SgmPaths::Eight] {
        let cfg = MatcherConfig {
            method: Method::Sgm,
            num_disparities: 24,
            speckle_window_size: 0,
            confidence_map: true,
            sgm: SgmConfig { paths, strip_rows: 13, overlap: 5, ..SgmConfig::default() },
            ..MatcherConfig::default()
        };
        run_case(11, 48, 40, cfg);
    }
}

#[test]
fn sgm_fast_equals_naive_with_the_accurate_preset_and_each_of_its_options() {
    // the preset (Birchfield–Tomasi, the intensity term, SGBM's left–right rule, eight paths),
    // each option alone on three paths, and the preset on rows wide enough for the fused box
    // sums (600 x 96 lanes x 2 bytes > 96 KiB)
    let accurate = MatcherConfig::sgm_accurate();
    let small = |sgm: SgmConfig, lr_subpixel| MatcherConfig {
        num_disparities: 24,
        lr_subpixel,
        confidence_map: true,
        speckle_window_size: 0,
        sgm: SgmConfig { strip_rows: 13, overlap: 5, ..sgm },
        ..accurate.clone()
    };
    let three = SgmConfig { paths: SgmPaths::Three, ..SgmConfig::default() };
    for (seed, cfg) in [
        (51, small(accurate.sgm, true)),
        (52, small(SgmConfig { sampling_insensitive: true, ..three }, false)),
        (53, small(SgmConfig { intensity_cost: true, ..three }, false)),
        (54, small(three, true)),
    ] {
        run_case(seed, 48, 40, cfg);
    }
    let wide = MatcherConfig {
        num_disparities: 90,
        speckle_window_size: 0,
        sgm: SgmConfig { strip_rows: 4, overlap: 2, ..accurate.sgm },
        ..accurate.clone()
    };
    run_case(55, 600, 9, wide);
}

#[test]
fn sgm_fast_equals_naive_with_several_vectors_of_disparities() {
    // 64 and 96 candidates: whole 32-lane chunks (two and three; the 32-lane decisions), 70: two
    // and a 16-lane one; negative minimum disparity: candidates cut at both ends of the row.
    // With and without the confidence map: the uniqueness check takes the smallest rival sum
    // with it and counts the rivals within the ratio without it.
    for ((seed, paths, nd, dmin), confidence_map) in [
        (31, SgmPaths::Three, 64, 0),
        (32, SgmPaths::Five, 96, -5),
        (33, SgmPaths::Eight, 70, 2),
        (34, SgmPaths::Three, 70, -9),
    ]
    .into_iter()
    .flat_map(|case| [(case, true), (case, false)])
    {
        let cfg = MatcherConfig {
            method: Method::Sgm,
            num_disparities: nd,
            min_disparity: dmin,
            speckle_window_size: 0,
            confidence_map,
            sgm: SgmConfig { paths, strip_rows: 7, overlap: 3, ..SgmConfig::default() },
            ..MatcherConfig::default()
        };
        run_case(seed, 130, 16, cfg);
    }
}

#[test]
fn sgm_fast_equals_naive_at_each_compiled_lane_count() {
    // one range for each of the lane counts the vector level compiles on its own (16 to 256),
    // each with lanes past the range (D = Dq − 5), over the path counts
    for k in 1..=16usize {
        let paths = [SgmPaths::Three, SgmPaths::Five, SgmPaths::Eight][k % 3];
        let cfg = MatcherConfig {
            method: Method::Sgm,
            num_disparities: 16 * k - 5,
            min_disparity: k as i32 % 3 - 1,
            speckle_window_size: 0,
            confidence_map: k % 2 == 0,
            sgm: SgmConfig { paths, strip_rows: 5, overlap: 2, ..SgmConfig::default() },
            ..MatcherConfig::default()
        };
        run_case(50 + k as u64, 280, 9, cfg);
    }
}

#[test]
fn sgm_fast_equals_naive_with_more_lanes_than_the_compiled_counts() {
    // the vector level runs a sweep and decisions compiled for each lane count up to 256 and
    // one for any count above: 272 and 264 candidates (17 chunks) reach the latter, with each
    // path count
    for (seed, paths, nd, dmin) in
        [(41, SgmPaths::Three, 272, 0), (42, SgmPaths::Five, 264, -3), (43, SgmPaths::Eight, 272, 2)]
    {
        let cfg = MatcherConfig {
            method: Method::Sgm,
            num_disparities: nd,
            min_disparity: dmin,
            speckle_window_size: 0,
            confidence_map: true,
            sgm: SgmConfig { paths, strip_rows: 7, overlap: 3, ..SgmConfig::default() },
            ..MatcherConfig::default()
        };
        run_case(seed, 300, 12, cfg);
    }
}

#[test]
fn sgm_fast_equals_naive_on_rows_wide_enough_for_the_fused_box_sums() {
    // 600 pixels x 96 lanes x 2 bytes = 112.5 KiB a row: over `FUSED_BOX_BYTES` (96 KiB), so the
    // box sums are made with the column sums (the narrower tests take the separate pass)
    for (seed, paths) in [(41, SgmPaths::Three), (42, SgmPaths::Eight)] {
        let cfg = MatcherConfig {
            method: Method::Sgm,
            num_disparities: 90,
            speckle_window_size: 0,
            sgm: SgmConfig { paths, strip_rows: 4, overlap: 2, ..SgmConfig::default() },
            ..MatcherConfig::default()
        };
        run_case(seed, 600, 9, cfg);
    }
}

#[test]
fn sgm_fast_equals_naive_on_16_bit_images() {
    use parallax_block_matching::Gray16Image;
    // 8-bit structure times 256 plus low bits: the adaptive P2 in 16-bit units (rank prefilter;
    // x-Sobel is refused there, its sums do not fit 16 bits)
    for (seed, paths, gamma) in
        [(21, SgmPaths::Five, 16), (22, SgmPaths::Eight, 4), (23, SgmPaths::Five, 0), (24, SgmPaths::Three, 16)]
    {
        let (w, h) = (26, 15);
        let (l8, r8) = make_pair(seed, w, h);
        let widen = |v: &[u16]| {
            v.iter().enumerate().map(|(i, &p)| p * 256 + (i as u16).wrapping_mul(37) % 256).collect::<Vec<u16>>()
        };
        let (l, r) = (widen(&l8), widen(&r8));
        let cfg = MatcherConfig {
            method: Method::Sgm,
            prefilter: Prefilter::Rank { size: 5 },
            num_disparities: 12,
            texture_threshold: 0,
            speckle_window_size: 0,
            confidence_map: true,
            // the intensity term in 8-bit grey levels (16-bit values / 257, then / 4)
            sgm: SgmConfig {
                paths,
                p2_gamma: gamma,
                strip_rows: 6,
                overlap: 3,
                intensity_cost: seed % 2 == 0,
                sampling_insensitive: seed == 22,
                ..SgmConfig::default()
            },
            ..MatcherConfig::default()
        };
        let (expect, expect_conf) = naive(&l, &r, w, h, &cfg, 257);
        let li = Gray16Image::from_raw(w as u32, h as u32, l.clone()).unwrap();
        let ri = Gray16Image::from_raw(w as u32, h as u32, r.clone()).unwrap();
        for level in [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512] {
            let mut m = BlockMatcher::new(MatcherConfig { threads: 2, ..cfg.clone() }).unwrap();
            if m.set_simd(level) != level {
                continue;
            }
            let got = m.compute_u16(&li, &ri).unwrap();
            for (i, (a, b)) in got.data().iter().zip(&expect).enumerate() {
                assert!((a.is_nan() && b.is_nan()) || a == b, "{level:?} seed {seed}: pixel {i} fast {a} naive {b}");
            }
            assert_eq!(m.confidence().unwrap(), &expect_conf[..]);
        }
        // the x-Sobel prefilter on 16-bit input would overflow the 16-bit sums: refused
        let xs = MatcherConfig { prefilter: Prefilter::XSobel { cap: 31 }, ..cfg.clone() };
        assert!(BlockMatcher::new(xs).unwrap().compute_u16(&li, &ri).is_err());
    }
}
