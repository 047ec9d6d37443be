//! The fast matcher against a naive reference written from the definitions: direct window sums
//! with clamp-to-edge borders, the full cost volume, first-minimum winner-take-all, OpenCV's
//! uniqueness rule, sub-pixel fits, the left–right check, the confidence (ratio of the best to
//! the best non-adjacent cost, times the left–right agreement) with its threshold, and the fill.
//! Colour pairs: the window cost is the sum of each channel's (each prefiltered), the texture
//! measure the grey conversion's. Property test with a fixed seed.

use image::{GrayImage, Luma, Rgb, RgbImage};
use parallax_block_matching::{BlockMatcher, CostFunction, Gray16Image, MatcherConfig, Prefilter, SimdLevel, Subpixel};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

mod common;
use common::clampi;

fn sobel_naive(src: &[u16], w: usize, h: usize, cap: i64) -> Vec<u16> {
    let p = |x: i64, y: i64| src[clampi(y, h) * w + clampi(x, w)] as i64;
    let mut out = vec![0; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let mut v = 0;
            for (dy, wt) in [(-1, 1), (0, 2), (1, 1)] {
                v += wt * (p(x + 1, y + dy) - p(x - 1, y + dy));
            }
            out[y as usize * w + x as usize] = (v.clamp(-cap, cap) + cap) as u16;
        }
    }
    out
}

fn norm_naive(src: &[u16], w: usize, h: usize, size: usize, cap: i64) -> Vec<u16> {
    let r = (size / 2) as i64;
    let n = (size * size) as f64;
    let mut out = vec![0; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let mut s = 0i64;
            for dy in -r..=r {
                for dx in -r..=r {
                    s += src[clampi(y + dy, h) * w + clampi(x + dx, w)] as i64;
                }
            }
            let v = src[y as usize * w + x as usize] as f64 - s as f64 / n;
            // round half away from zero
            let q = v.signum() * (v.abs() + 0.5).floor();
            out[y as usize * w + x as usize] = ((q as i64).clamp(-cap, cap) + cap) as u16;
        }
    }
    out
}

fn rank_naive(src: &[u16], w: usize, h: usize, size: usize) -> Vec<u16> {
    let r = (size / 2) as i64;
    let mut out = vec![0; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let c = src[y as usize * w + x as usize];
            let mut n = 0;
            for dy in -r..=r {
                for dx in -r..=r {
                    n += (src[clampi(y + dy, h) * w + clampi(x + dx, w)] < c) as u16;
                }
            }
            out[y as usize * w + x as usize] = n;
        }
    }
    out
}

/// Naive matcher over the channels `planes` (each left and right; one for grey), the texture
/// measured on `grey_left`: returns the disparity map (NaN invalid) and the confidence map (0
/// where invalid or filled), without speckle filtering.
fn naive(
    planes: &[[&[u16]; 2]],
    grey_left: &[u16],
    w: usize,
    h: usize,
    cfg: &MatcherConfig,
    scale: i64,
) -> (Vec<f32>, Vec<f32>) {
    assert!(planes.len() == 1 || cfg.cost != CostFunction::Ncc, "NCC matches one channel");
    let r = (cfg.block_size / 2) as i64;
    let nd = cfg.num_disparities;
    let dmin = cfg.min_disparity as i64;
    let texture_ok: Vec<bool> = if cfg.texture_threshold > 0 {
        let s = sobel_naive(grey_left, w, h, 31 * scale);
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                let mut t = 0i64;
                for dy in -r..=r {
                    for dx in -r..=r {
                        t += (s[clampi(y + dy, h) * w + clampi(x + dx, w)] as i64 - 31 * scale).abs();
                    }
                }
                t >= cfg.texture_threshold as i64 * scale
            })
            .collect()
    } else {
        vec![true; w * h]
    };
    let prefiltered = |img: &[u16]| match cfg.prefilter {
        Prefilter::None => img.to_vec(),
        Prefilter::XSobel { cap } => sobel_naive(img, w, h, cap as i64 * scale),
        Prefilter::NormalizedResponse { size, cap } => norm_naive(img, w, h, size, cap as i64 * scale),
        Prefilter::Rank { size } => rank_naive(img, w, h, size),
    };
    let channels: Vec<[Vec<u16>; 2]> = planes.iter().map(|[l, r]| [prefiltered(l), prefiltered(r)]).collect();
    let n = (cfg.block_size * cfg.block_size) as i64;
    let inv = |s: i64, ss: i64| {
        let den = n * ss - s * s;
        if den == 0 { 0.0 } else { 1.0 / (den as f64).sqrt() }
    };
    // cost volume, f64 (integer costs are exact in f64 here)
    let mut cost = vec![f64::NAN; w * h * nd];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            for k in 0..nd as i64 {
                let u = x - dmin - k;
                if u < 0 || u >= w as i64 {
                    continue;
                }
                let (mut sad, mut ssd, mut sl, mut sr, mut sll, mut srr, mut slr) =
                    (0i64, 0i64, 0i64, 0i64, 0i64, 0i64, 0i64);
                // every channel's window, summed
                for [l, rt] in &channels {
                    let pl = |x: i64, y: i64| l[clampi(y, h) * w + clampi(x, w)] as i64;
                    let pr = |x: i64, y: i64| rt[clampi(y, h) * w + clampi(x, w)] as i64;
                    for dy in -r..=r {
                        for dx in -r..=r {
                            let a = pl(x + dx, y + dy);
                            let b = pr(x + dx - dmin - k, y + dy);
                            sad += (a - b).abs();
                            ssd += (a - b) * (a - b);
                            sl += a;
                            sr += pr(u + dx, y + dy);
                            sll += a * a;
                            srr += pr(u + dx, y + dy) * pr(u + dx, y + dy);
                            slr += a * b;
                        }
                    }
                }
                let c = match cfg.cost {
                    CostFunction::Sad => sad as f64,
                    CostFunction::Ssd => ssd as f64,
                    CostFunction::Ncc => {
                        1.0 - (n as f64 * slr as f64 - sl as f64 * sr as f64) * inv(sl, sll) * inv(sr, srr)
                    }
                };
                cost[(y as usize * w + x as usize) * nd + k as usize] = c;
            }
        }
    }
    let sub = match (cfg.subpixel, cfg.cost) {
        (Subpixel::Auto, CostFunction::Sad) => Subpixel::Equiangular,
        (Subpixel::Auto, _) => Subpixel::Parabola,
        (s, _) => s,
    };
    let mut out = vec![f32::NAN; w * h];
    let mut confidence = vec![0.0f32; w * h];
    for y in 0..h {
        let mut rejected = vec![false; w];
        // right winners
        let mut rbest = vec![usize::MAX; w];
        for u in 0..w {
            let mut best = f64::INFINITY;
            for k in 0..nd {
                let x = u as i64 + dmin + k as i64;
                if x < 0 || x >= w as i64 {
                    continue;
                }
                let c = cost[(y * w + x as usize) * nd + k];
                if c < best {
                    best = c;
                    rbest[u] = k;
                }
            }
        }
        for x in 0..w {
            let cs = &cost[(y * w + x) * nd..][..nd];
            let ks: Vec<usize> = (0..nd).filter(|&k| !cs[k].is_nan()).collect();
            if ks.is_empty() || !texture_ok[y * w + x] {
                continue;
            }
            let (lo, hi) = (ks[0], *ks.last().unwrap());
            let mut kb = lo;
            for &k in &ks {
                if cs[k] < cs[kb] {
                    kb = k;
                }
            }
            let m = cs[kb];
            if cfg.uniqueness_ratio > 0 {
                let t = match cfg.cost {
                    CostFunction::Ncc => m + m * cfg.uniqueness_ratio as f64 / 100.0,
                    _ => (m as u64 + m as u64 * cfg.uniqueness_ratio as u64 / 100) as f64,
                };
                if ks.iter().any(|&k| (k as i64 - kb as i64).abs() > 1 && cs[k] <= t) {
                    continue;
                }
            }
            let mut lr_factor = 1.0f32;
            if let Some(tol) = cfg.lr_max_diff {
                let u = (x as i64 - dmin - kb as i64) as usize;
                let diff = (rbest[u] as i64 - kb as i64).abs();
                if diff > tol as i64 {
                    rejected[x] = true;
                    continue;
                }
                lr_factor = 1.0 / (1.0 + diff as f32);
            }
            if cfg.confidence_map || cfg.min_confidence > 0.0 {
                // best cost further than one disparity from the winner
                let c2 = ks.iter().filter(|&&k| (k as i64 - kb as i64).abs() > 1).map(|&k| cs[k]).reduce(f64::min);
                let ratio = match c2 {
                    Some(c2) if c2 > 0.0 => (1.0 - m / c2).clamp(0.0, 1.0) as f32,
                    _ => 0.0,
                };
                let c = ratio * lr_factor;
                if c < cfg.min_confidence {
                    rejected[x] = true;
                    continue;
                }
                confidence[y * w + x] = c;
            }
            let mut off = 0.0;
            if kb > lo && kb < hi && sub != Subpixel::None {
                let (a, b, c) = (cs[kb - 1], cs[kb], cs[kb + 1]);
                let den = if sub == Subpixel::Equiangular { a.max(c) - b } else { a - 2.0 * b + c };
                if den > 0.0 {
                    off = ((a - c) / (2.0 * den)).clamp(-0.5, 0.5);
                }
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
                let v = match (left, right) {
                    (Some(a), Some(b)) => a.min(b),
                    (Some(a), None) | (None, Some(a)) => a,
                    (None, None) => f32::NAN,
                };
                out[y * w + x] = v;
            }
        }
    }
    (out, confidence)
}

fn compare(fast: &[f32], slow: &[f32], w: usize, tol: f32, what: &str) {
    for (i, (a, b)) in fast.iter().zip(slow).enumerate() {
        let same = (a.is_nan() && b.is_nan()) || (a - b).abs() <= tol;
        assert!(same, "{what}: pixel ({}, {}) fast {a} naive {b}", i % w, i / w);
    }
}

/// A pair with structure: right = left shifted by a random disparity field plus noise, of `ch`
/// interleaved channels (each its own texture).
fn make_pair(seed: u64, w: usize, h: usize, maxv: u32, ch: usize) -> (Vec<u16>, Vec<u16>) {
    let mut rnd = common::rng(seed);
    let big = w + 40;
    let tex: Vec<u16> = (0..big * h * ch).map(|_| (rnd() % (maxv as u64 + 1)) as u16).collect();
    let shift = (rnd() % 8) as usize;
    let noise = (rnd() % 3) as u16;
    let at = |i: usize, shift: usize| {
        let (p, c) = (i / ch, i % ch);
        tex[((p / w) * big + p % w + 20 + shift) * ch + c]
    };
    let left: Vec<u16> = (0..w * h * ch).map(|i| at(i, 0)).collect();
    let right: Vec<u16> = (0..w * h * ch)
        .map(|i| {
            let v = at(i, shift);
            if noise > 0 && rnd().is_multiple_of(4) {
                v.saturating_add((rnd() % noise as u64) as u16).min(maxv as u16)
            } else {
                v
            }
        })
        .collect();
    (left, right)
}

/// What a case matches: an 8-bit grey pair, a 16-bit grey pair or an 8-bit colour pair.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Input {
    Grey8,
    Grey16,
    Colour,
}

fn run_case(seed: u64, w: usize, h: usize, maxv: u32, input: Input, cfg: MatcherConfig, threads: usize) {
    let sixteen = input == Input::Grey16;
    let ch = if input == Input::Colour { 3 } else { 1 };
    let (l, r) = make_pair(seed, w, h, maxv, ch);
    let scale = if sixteen { 257 } else { 1 };
    let rgb = |v: &[u16]| {
        RgbImage::from_fn(w as u32, h as u32, |x, y| {
            let i = 3 * (y as usize * w + x as usize);
            Rgb([v[i] as u8, v[i + 1] as u8, v[i + 2] as u8])
        })
    };
    let (expect, expect_conf) = if input == Input::Colour {
        let channel = |v: &[u16], c: usize| v.iter().skip(c).step_by(3).copied().collect::<Vec<u16>>();
        let planes: Vec<[Vec<u16>; 2]> = (0..3).map(|c| [channel(&l, c), channel(&r, c)]).collect();
        let planes: Vec<[&[u16]; 2]> = planes.iter().map(|[a, b]| [&a[..], &b[..]]).collect();
        // the texture of the grey conversion, as `compute_rgb` documents
        let grey: Vec<u16> = image::imageops::grayscale(&rgb(&l)).pixels().map(|p| p[0] as u16).collect();
        naive(&planes, &grey, w, h, &cfg, scale)
    } else {
        naive(&[[&l, &r]], &l, w, h, &cfg, scale)
    };
    let tol = if cfg.cost == CostFunction::Ncc { 1e-5 } else { 1e-6 };
    for level in [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512] {
        let mut m = BlockMatcher::new(MatcherConfig { threads, ..cfg.clone() }).unwrap();
        let used = m.set_simd(level);
        if used != level {
            continue;
        }
        let got = if sixteen {
            let li = Gray16Image::from_raw(w as u32, h as u32, l.clone()).unwrap();
            let ri = Gray16Image::from_raw(w as u32, h as u32, r.clone()).unwrap();
            m.compute_u16(&li, &ri).unwrap()
        } else if input == Input::Colour {
            // twice: the second call reuses the buffers
            m.compute_rgb(&rgb(&l), &rgb(&r)).unwrap();
            m.compute_rgb(&rgb(&l), &rgb(&r)).unwrap()
        } else {
            let li = GrayImage::from_fn(w as u32, h as u32, |x, y| Luma([l[y as usize * w + x as usize] as u8]));
            let ri = GrayImage::from_fn(w as u32, h as u32, |x, y| Luma([r[y as usize * w + x as usize] as u8]));
            // twice: the second call reuses the buffers
            m.compute(&li, &ri).unwrap();
            m.compute(&li, &ri).unwrap()
        };
        let what = format!("{level:?} {input:?} seed {seed} {w}x{h} maxv {maxv} {cfg:?}");
        compare(got.data(), &expect, w, tol, &what);
        match m.confidence() {
            Some(c) => compare(c, &expect_conf, w, tol, &format!("confidence, {what}")),
            None => assert!(!cfg.confidence_map && cfg.min_confidence == 0.0, "no confidence map: {what}"),
        }
    }
}

/// Configurations of every option; with `ncc` false, SAD and SSD only (colour pairs).
fn config_strategy(ncc: bool) -> impl Strategy<Value = MatcherConfig> {
    let costs = if ncc {
        prop_oneof![Just(CostFunction::Sad), Just(CostFunction::Ssd), Just(CostFunction::Ncc)].boxed()
    } else {
        prop_oneof![Just(CostFunction::Sad), Just(CostFunction::Ssd)].boxed()
    };
    (
        costs,
        (1usize..=5).prop_map(|k| 2 * k + 1),
        -4i32..6,
        1usize..40,
        prop_oneof![
            Just(Prefilter::None),
            (1u16..40).prop_map(|cap| Prefilter::XSobel { cap }),
            (1usize..=3, 1u16..40).prop_map(|(s, cap)| Prefilter::NormalizedResponse { size: 2 * s + 1, cap }),
            (1usize..=3).prop_map(|s| Prefilter::Rank { size: 2 * s + 1 })
        ],
        prop_oneof![Just(0u32), Just(10), Just(200)],
        prop_oneof![Just(0u32), Just(5), Just(30)],
        prop_oneof![Just(None), Just(Some(0u32)), Just(Some(1))],
        any::<bool>(),
        prop_oneof![Just(Subpixel::None), Just(Subpixel::Auto), Just(Subpixel::Parabola), Just(Subpixel::Equiangular)],
        prop_oneof![Just((false, 0.0f32)), Just((true, 0.0)), Just((false, 0.05)), Just((true, 0.2))],
    )
        .prop_map(
            |(
                cost,
                block_size,
                min_disparity,
                num_disparities,
                prefilter,
                tex,
                uniq,
                lr,
                fill,
                subpixel,
                (confidence_map, min_confidence),
            )| {
                MatcherConfig {
                    cost,
                    block_size,
                    min_disparity,
                    num_disparities,
                    prefilter,
                    texture_threshold: tex,
                    uniqueness_ratio: uniq,
                    lr_max_diff: lr,
                    fill,
                    min_confidence,
                    confidence_map,
                    speckle_window_size: 0,
                    speckle_range: 1.0,
                    subpixel,
                    ..MatcherConfig::default()
                }
            },
        )
}

proptest! {
    #![proptest_config(Config { cases: 48, rng_seed: RngSeed::Fixed(0x5eed_b10c), failure_persistence: None, ..Config::default() })]

    #[test]
    fn fast_equals_naive_on_8_bit_images(
        cfg in config_strategy(true),
        seed in any::<u64>(),
        w in 6usize..40,
        h in 3usize..24,
        maxv in prop_oneof![Just(3u32), Just(40), Just(255)],
        threads in 1usize..=2,
    ) {
        run_case(seed, w, h, maxv, Input::Grey8, cfg, threads);
    }

    #[test]
    fn fast_equals_naive_on_16_bit_images(
        cfg in config_strategy(true),
        seed in any::<u64>(),
        w in 6usize..30,
        h in 3usize..16,
        maxv in prop_oneof![Just(4095u32), Just(65535)],
    ) {
        run_case(seed, w, h, maxv, Input::Grey16, cfg, 2);
    }

    #[test]
    fn fast_equals_naive_on_colour_images(
        cfg in config_strategy(false),
        seed in any::<u64>(),
        w in 6usize..32,
        h in 3usize..20,
        maxv in prop_oneof![Just(3u32), Just(40), Just(255)],
        threads in 1usize..=2,
    ) {
        run_case(seed, w, h, maxv, Input::Colour, cfg, threads);
    }
}

#[test]
fn fast_equals_naive_on_colour_in_16_and_32_bit_lanes() {
    // the window cost of a colour pair sums three channels: SAD runs in 16-bit lanes while
    // 3 · block² · (2 · cap) ≤ 65534 and in 32-bit lanes past it, where the same window on grey
    // still fits 16 bits (a 16-bit kernel chosen there would wrap the sums and lose the match);
    // cap 31 (the default x-Sobel) and 63 (pixels up to 126: both below 128, the byte-pair
    // column update), 1 to 4 chunks, with and without the left–right check; SSD (32-bit lanes)
    // on the same windows
    let mut case = 0;
    // (windows far past the bound, 31x31 and 21x21 at cap 63, give most candidates sums past
    // 65535: there wrapped sums would change the winners and the sub-pixel fits)
    let windows =
        [(31u16, 9usize, true), (31, 17, true), (31, 19, false), (31, 31, false), (63, 13, true), (63, 21, false)];
    for (cap, block, sixteen) in windows {
        let sum = |channels: usize| channels * block * block * 2 * cap as usize;
        assert_eq!(sum(3) <= 65534, sixteen, "cap {cap} block {block}");
        assert!(sum(1) <= 65534, "cap {cap} block {block}: grey fits 16 bits");
        for (nd, lr, uniq) in [(16, Some(1), 0), (40, None, 10), (64, Some(0), 5)] {
            for cost in [CostFunction::Sad, CostFunction::Ssd] {
                let cfg = MatcherConfig {
                    cost,
                    block_size: block,
                    num_disparities: nd,
                    prefilter: Prefilter::XSobel { cap },
                    uniqueness_ratio: uniq,
                    lr_max_diff: lr,
                    confidence_map: case % 2 == 0,
                    speckle_window_size: 0,
                    ..MatcherConfig::default()
                };
                run_case(500 + case, 80, 26, 255, Input::Colour, cfg, 2);
                case += 1;
            }
        }
    }
}

#[test]
fn fast_equals_naive_on_colour_with_several_bands_and_prefilters() {
    // many bands (one per thread: 4), the default option set and the dense preset, each
    // prefilter (raw channels: 32-bit lanes)
    for prefilter in [
        Prefilter::default(),
        Prefilter::Rank { size: 5 },
        Prefilter::NormalizedResponse { size: 7, cap: 20 },
        Prefilter::None,
    ] {
        for preset in [MatcherConfig { confidence_map: true, ..MatcherConfig::default() }, MatcherConfig::dense()] {
            let cfg = MatcherConfig { prefilter, num_disparities: 24, speckle_window_size: 0, ..preset };
            run_case(9, 64, 120, 255, Input::Colour, cfg, 4);
        }
    }
}

#[test]
fn fast_equals_naive_on_a_larger_image_with_many_bands() {
    // enough rows for several bands (one per thread: 4), the full default option set minus speckle
    // (with the confidence map), the dense preset (fill) and a confidence threshold with fill,
    // and the rank prefilter
    let presets = [
        MatcherConfig { confidence_map: true, ..MatcherConfig::default() },
        MatcherConfig::dense(),
        MatcherConfig { min_confidence: 0.1, fill: true, ..MatcherConfig::default() },
    ];
    for cost in [CostFunction::Sad, CostFunction::Ssd, CostFunction::Ncc] {
        for prefilter in [Prefilter::default(), Prefilter::Rank { size: 5 }] {
            for preset in &presets {
                let cfg =
                    MatcherConfig { cost, prefilter, num_disparities: 24, speckle_window_size: 0, ..preset.clone() };
                run_case(7, 64, 160, 255, Input::Grey8, cfg, 4);
            }
        }
    }
}

#[test]
fn fast_equals_naive_with_several_disparity_chunks() {
    // the vectorised SAD path works on 16 or 32 disparities per chunk: ranges that span several
    // chunks, end inside one, and start off zero, with and without the decision options
    let mut case = 0;
    // (the last five search ranges lie mostly or wholly outside the 112-pixel rows; 90, 220
    // and 250 disparities make 6, 14 and 16 chunks of 16 lanes, counts with their own kernel
    // instances, unrolled)
    for (nd, dmin, block) in [
        (16, 0, 9),
        (33, -3, 5),
        (64, 5, 9),
        (47, 0, 15),
        (70, -20, 3),
        (40, -130, 5),
        (20, 105, 3),
        (90, 0, 5),
        (220, -100, 7),
        (250, -120, 5),
    ] {
        for (uniq, lr, subpixel, min_confidence) in [
            (0, Some(1), Subpixel::Auto, 0.0),
            (10, None, Subpixel::Parabola, 0.0),
            (0, Some(0), Subpixel::None, 0.0),
            (5, Some(1), Subpixel::Auto, 0.15),
        ] {
            for cost in [CostFunction::Sad, CostFunction::Ssd] {
                let cfg = MatcherConfig {
                    cost,
                    block_size: block,
                    min_disparity: dmin,
                    num_disparities: nd,
                    uniqueness_ratio: uniq,
                    lr_max_diff: lr,
                    subpixel,
                    min_confidence,
                    fill: case % 3 == 0,
                    speckle_window_size: 0,
                    ..MatcherConfig::default()
                };
                run_case(100 + case, 112, 20, 255, Input::Grey8, cfg, 2);
                case += 1;
            }
        }
    }
}

#[test]
fn fast_equals_naive_on_ties_across_chunks() {
    // images of two or four grey levels and small windows: many disparities tie at the minimum,
    // in the same lane of different chunks too, so the winner must be the first (smallest)
    // disparity whichever way the kernel visits its chunks (without the left–right check it
    // visits them downwards); 16- (SAD) and 32-bit lanes (SSD), chunk counts with their own
    // kernel instances, rows wider than the range so that most columns search all of it
    let mut case = 0;
    for nd in [32, 64, 96, 128, 224] {
        for (maxv, cost) in [(1, CostFunction::Sad), (3, CostFunction::Sad), (3, CostFunction::Ssd)] {
            for (lr, subpixel) in [(None, Subpixel::Auto), (Some(1), Subpixel::None)] {
                let cfg = MatcherConfig {
                    cost,
                    block_size: 3,
                    num_disparities: nd,
                    prefilter: Prefilter::None,
                    texture_threshold: 0,
                    uniqueness_ratio: 0,
                    lr_max_diff: lr,
                    subpixel,
                    speckle_window_size: 0,
                    ..MatcherConfig::default()
                };
                run_case(300 + case, nd + 40, 12, maxv, Input::Grey8, cfg, 1);
                case += 1;
            }
        }
    }
}

#[test]
fn fast_equals_naive_with_32_bit_sums_of_small_pixels() {
    // a 25x25 window of x-Sobel responses up to 126: the SAD sums pass 65534, so the 32-bit
    // lanes run, and every pixel is below 128, so their column update works on byte pairs (as
    // the 16-bit lanes' does in the tests above); 1, 2, 3 and 4 chunks of 8 lanes
    for (case, nd) in [8, 16, 24, 32].into_iter().enumerate() {
        for lr in [None, Some(1)] {
            let cfg = MatcherConfig {
                block_size: 25,
                num_disparities: nd,
                prefilter: Prefilter::XSobel { cap: 63 },
                uniqueness_ratio: 10,
                lr_max_diff: lr,
                speckle_window_size: 0,
                ..MatcherConfig::default()
            };
            run_case(400 + case as u64, 60, 30, 255, Input::Grey8, cfg, 2);
        }
    }
}

/// Which instruction-set levels the kernel tests above ran on this machine (each test runs
/// every level the CPU has, from the portable one up). CI prints this with `--nocapture`.
#[test]
fn simd_levels_run_on_this_machine() {
    let levels: Vec<SimdLevel> = [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512]
        .into_iter()
        .filter(|&l| BlockMatcher::new(MatcherConfig::default()).unwrap().set_simd(l) == l)
        .collect();
    println!("block-matching SIMD levels tested on this machine: {levels:?} (detected {:?})", SimdLevel::detect());
    assert_eq!(levels.first(), Some(&SimdLevel::Scalar));
    assert_eq!(levels.last(), Some(&SimdLevel::detect()));
}
