//! Validity on synthetic scenes with exact disparity (`parallax_synthetic`): rejected pixels
//! are invalid unless filling is asked for, the rejection counts add up, the confidence ranks
//! right pixels above wrong ones, and a swapped pair is detected.

use parallax_block_matching::{BlockMatcher, MatcherConfig, Method, Prefilter, evaluate};
use parallax_synthetic::{StereoScene, StereoSceneConfig, render_stereo_scene};

fn scene(seed: u64) -> StereoScene {
    let cfg = StereoSceneConfig {
        width: 320,
        height: 240,
        max_disparity: 32.0,
        noise_sigma: 1.5,
        seed,
        ..StereoSceneConfig::default()
    };
    render_stereo_scene(&cfg).expect("valid scene")
}

fn cfg(base: MatcherConfig) -> MatcherConfig {
    MatcherConfig { num_disparities: 32, ..base }
}

#[test]
fn defaults_leave_rejected_pixels_invalid_and_counts_add_up() {
    for seed in [1, 2] {
        let s = scene(seed);
        let mut m = BlockMatcher::new(cfg(MatcherConfig::default())).unwrap();
        let d = m.compute(&s.left, &s.right).unwrap();
        let st = m.last_stats();
        let rejected = st.no_candidate + st.low_texture + st.not_unique + st.lr_inconsistent + st.speckle;
        assert_eq!(st.filled, 0);
        assert_eq!(st.valid, d.valid_count());
        assert_eq!(st.valid + rejected, st.pixels, "{st:?}");
        // occluded pixels have no match: most of them must come back invalid, not guessed
        let occ: Vec<usize> = (0..s.occluded.len()).filter(|&i| s.occluded[i]).collect();
        let occ_invalid = occ.iter().filter(|&&i| !d.data()[i].is_finite()).count();
        let share = occ_invalid as f64 / occ.len() as f64;
        println!("seed {seed}: {st:?}; occluded pixels left invalid {:.1} %", 100.0 * share);
        assert!(share > 0.6, "only {:.1} % of the occluded pixels are invalid", 100.0 * share);
        // among the returned visible pixels, few are wrong by more than 2 px; the dense preset
        // fills the rejects and is worse among what it returns
        let visible: Vec<bool> = s.occluded.iter().map(|o| !o).collect();
        let e = evaluate(&d, &s.disparity, Some(&visible), &[2.0]).unwrap();
        let dense = BlockMatcher::new(cfg(MatcherConfig::dense())).unwrap().compute(&s.left, &s.right).unwrap();
        let ed = evaluate(&dense, &s.disparity, None, &[2.0]).unwrap();
        let e_all = evaluate(&d, &s.disparity, None, &[2.0]).unwrap();
        println!(
            "seed {seed}: visible bad-2 returned {:.2} % density {:.1} %; all pixels: defaults {:.2} % returned, \
             dense {:.2} % returned at density {:.1} %",
            e.bad_returned_at(2.0).unwrap(),
            e.density,
            e_all.bad_returned_at(2.0).unwrap(),
            ed.bad_returned_at(2.0).unwrap(),
            ed.density
        );
        assert!(e.bad_returned_at(2.0).unwrap() < 2.0 && e.density > 80.0);
        assert!(ed.density > 99.0 && ed.bad_returned_at(2.0).unwrap() > e_all.bad_returned_at(2.0).unwrap());
    }
}

#[test]
fn confidence_ranks_right_pixels_above_wrong_ones_and_its_threshold_trades_density_for_accuracy() {
    let s = scene(3);
    // no uniqueness margin, no speckle filter: the confidence alone separates
    let base =
        MatcherConfig { uniqueness_ratio: 0, speckle_window_size: 0, confidence_map: true, ..cfg(Default::default()) };
    let mut m = BlockMatcher::new(base.clone()).unwrap();
    let d = m.compute(&s.left, &s.right).unwrap();
    let conf = m.confidence().expect("confidence map requested").to_vec();
    let (mut right, mut wrong) = (Vec::new(), Vec::new());
    for i in 0..conf.len() {
        let v = d.data()[i];
        if !v.is_finite() {
            assert_eq!(conf[i], 0.0, "invalid pixel {i} with confidence {}", conf[i]);
            continue;
        }
        assert!((0.0..=1.0).contains(&conf[i]));
        if (v - s.disparity.data()[i]).abs() > 2.0 { wrong.push(conf[i]) } else { right.push(conf[i]) }
    }
    let mean = |v: &[f32]| v.iter().map(|&c| c as f64).sum::<f64>() / v.len().max(1) as f64;
    println!(
        "mean confidence: right {:.3} ({} px), wrong {:.3} ({} px)",
        mean(&right),
        right.len(),
        mean(&wrong),
        wrong.len()
    );
    assert!(wrong.len() > 20, "the scene should produce some wrong matches");
    assert!(mean(&right) > 2.0 * mean(&wrong));
    let e0 = evaluate(&d, &s.disparity, None, &[2.0]).unwrap();
    let mut mt = BlockMatcher::new(MatcherConfig { min_confidence: 0.15, ..base }).unwrap();
    let dt = mt.compute(&s.left, &s.right).unwrap();
    let e1 = evaluate(&dt, &s.disparity, None, &[2.0]).unwrap();
    println!(
        "threshold 0.15: bad-2 returned {:.2} → {:.2} %, density {:.1} → {:.1} %, {} low-confidence rejects",
        e0.bad_returned_at(2.0).unwrap(),
        e1.bad_returned_at(2.0).unwrap(),
        e0.density,
        e1.density,
        mt.last_stats().low_confidence
    );
    assert!(e1.bad_returned_at(2.0).unwrap() < 0.6 * e0.bad_returned_at(2.0).unwrap());
    assert!(e1.density < e0.density && e1.density > 0.5 * e0.density);
    // exactly the pixels below the threshold went (the maps agree elsewhere)
    for i in 0..conf.len() {
        if d.data()[i].is_finite() && conf[i] >= 0.15 {
            assert_eq!(dt.data()[i].to_bits(), d.data()[i].to_bits(), "pixel {i}");
        } else {
            assert!(!dt.data()[i].is_finite(), "pixel {i} conf {}", conf[i]);
        }
    }
}

#[test]
fn a_swapped_pair_is_detected_and_a_right_one_is_not() {
    for seed in [4, 5, 6] {
        let s = scene(seed);
        let m = BlockMatcher::new(cfg(MatcherConfig::default())).unwrap();
        let right_way = m.check_swap(&s.left, &s.right).unwrap();
        let swapped = m.check_swap(&s.right, &s.left).unwrap();
        println!("seed {seed}: as given {right_way:?}; swapped {swapped:?}");
        assert!(!right_way.looks_swapped);
        assert!(swapped.looks_swapped);
        // the two runs are the same two matches in the other order
        assert_eq!(right_way.forward_density, swapped.reverse_density);
        // a swapped pair matched as given loses most pixels to the checks
        let mut ms = BlockMatcher::new(cfg(MatcherConfig::default())).unwrap();
        ms.compute(&s.right, &s.left).unwrap();
        assert!(ms.last_stats().density < 0.5, "{:?}", ms.last_stats());
    }
}

#[test]
fn sgm_matches_synthetic_scenes_with_few_errors_and_fills_low_texture_better_than_bm() {
    use parallax_block_matching::{SgmConfig, SgmPaths};
    for seed in [7, 8] {
        let s = scene(seed);
        let visible: Vec<bool> = s.occluded.iter().map(|o| !o).collect();
        let patch: Vec<bool> = (0..visible.len()).map(|i| visible[i] && s.low_texture[i]).collect();
        let textured: Vec<bool> = (0..visible.len()).map(|i| visible[i] && !s.low_texture[i]).collect();
        let bm = BlockMatcher::new(cfg(MatcherConfig::default())).unwrap().compute(&s.left, &s.right).unwrap();
        let eb = evaluate(&bm, &s.disparity, Some(&patch), &[2.0]).unwrap();
        for paths in [SgmPaths::Three, SgmPaths::Five, SgmPaths::Eight] {
            let c = cfg(MatcherConfig { sgm: SgmConfig { paths, ..MatcherConfig::sgm().sgm }, ..MatcherConfig::sgm() });
            let d = BlockMatcher::new(c).unwrap().compute(&s.left, &s.right).unwrap();
            let e = evaluate(&d, &s.disparity, Some(&textured), &[1.0, 2.0]).unwrap();
            let ep = evaluate(&d, &s.disparity, Some(&patch), &[2.0]).unwrap();
            println!(
                "seed {seed} {paths:?}: visible textured bad-1 returned {:.2} %, bad-2 returned {:.2} %, density {:.1} %, rms {:.3}; \
                 low-texture patch bad-2 (missing = bad) SGM {:.1} % vs BM {:.1} %",
                e.bad_returned_at(1.0).unwrap(),
                e.bad_returned_at(2.0).unwrap(),
                e.density,
                e.rms,
                ep.bad_at(2.0).unwrap(),
                eb.bad_at(2.0).unwrap()
            );
            assert!(e.bad_returned_at(2.0).unwrap() < 2.0 && e.density > 90.0);
            // the patch filled better than block matching by the default three paths and by five
            // (with this preset's penalties eight paths leave more of it missing or wrong:
            // measured 89–91 % against block matching's 87–91 %; the eight-path preset below)
            if paths != SgmPaths::Eight {
                assert!(ep.bad_at(2.0).unwrap() < eb.bad_at(2.0).unwrap());
            }
        }
        let d = BlockMatcher::new(cfg(MatcherConfig::sgm_accurate())).unwrap().compute(&s.left, &s.right).unwrap();
        let ep = evaluate(&d, &s.disparity, Some(&patch), &[2.0]).unwrap();
        println!("seed {seed} accurate (eight paths): low-texture patch bad-2 {:.1} %", ep.bad_at(2.0).unwrap());
        assert!(ep.bad_at(2.0).unwrap() < eb.bad_at(2.0).unwrap());
    }
}

/// A pair of random texture (smoothed, so the sub-pixel fit has a slope) whose right image is
/// the left one shifted: `right(x) = left(x + shift)`, so every left pixel's disparity is
/// `shift`, and the left pixels with `x − shift` outside `0..w` have no match in the right image.
fn shifted_pair(seed: u64, w: u32, h: u32, shift: i32) -> (image::GrayImage, image::GrayImage) {
    let wide = w as usize + 64;
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut noise = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 56) as u32
    };
    let raw: Vec<u32> = (0..wide * h as usize).map(|_| noise()).collect();
    // 2x2 box: values 0..=255
    let at = |x: usize, y: usize| {
        let y1 = (y + 1).min(h as usize - 1);
        (raw[y * wide + x] + raw[y * wide + x + 1] + raw[y1 * wide + x] + raw[y1 * wide + x + 1]) / 4
    };
    let left = image::GrayImage::from_fn(w, h, |x, y| image::Luma([at(x as usize + 32, y as usize) as u8]));
    let right = image::GrayImage::from_fn(w, h, |x, y| {
        image::Luma([at((x as i64 + 32 + shift as i64) as usize, y as usize) as u8])
    });
    (left, right)
}

/// Semi-global matching where the image edge cuts the search range: a left pixel whose match
/// lies outside the right image is never returned with a disparity, while the pixels of the
/// cut band that do have a match keep it. Both edges: positive disparities cut at the left,
/// negative ones at the right. (Before the exact left–right check there, 0–6 of the 1152 such
/// pixels came back on this texture; on Middlebury teddy 785 of 12107, more than 2 px off.)
#[test]
fn sgm_returns_no_disparity_where_the_match_left_the_right_image() {
    use parallax_block_matching::{SgmConfig, SgmPaths};
    let (w, h, nd) = (160u32, 96u32, 32usize);
    for (shift, dmin) in [(12, 0), (-12, -24)] {
        for seed in [1, 2, 3] {
            let (l, r) = shifted_pair(seed, w, h, shift);
            // the measurement preset on each path count, and the accurate one (no uniqueness margin
            // of its own, SGBM's sub-pixel left–right rule). Random texture under one shift has no
            // ambiguous match in the band: the edge band's uniqueness margin is checked on
            // Middlebury (`tests/middlebury.rs`) and against the naive reference.
            let presets = [SgmPaths::Three, SgmPaths::Five, SgmPaths::Eight].map(|paths| {
                (
                    format!("{paths:?}"),
                    MatcherConfig { sgm: SgmConfig { paths, ..MatcherConfig::sgm().sgm }, ..MatcherConfig::sgm() },
                )
            });
            let accurate = ("accurate".to_string(), MatcherConfig::sgm_accurate());
            for (paths, base) in presets.into_iter().chain([accurate]) {
                let c = MatcherConfig { num_disparities: nd, min_disparity: dmin, ..base };
                let d = BlockMatcher::new(c).unwrap().compute(&l, &r).unwrap();
                let (mut outside_returned, mut cut, mut cut_right) = (0, 0, 0);
                for y in 0..h as usize {
                    for x in 0..w as usize {
                        let v = d.data()[y * w as usize + x];
                        let u = x as i64 - shift as i64;
                        // where the range [dmin, dmin + nd) is cut by an image edge
                        let xd = x as i64 - dmin as i64;
                        let is_cut = xd < nd as i64 - 1 || xd > w as i64 - 1;
                        if !(0..w as i64).contains(&u) {
                            outside_returned += v.is_finite() as usize;
                        } else if is_cut {
                            cut += 1;
                            cut_right += (v.is_finite() && (v - shift as f32).abs() <= 1.0) as usize;
                        }
                    }
                }
                let kept = cut_right as f64 / cut as f64;
                println!(
                    "shift {shift} seed {seed} {paths}: outside returned {outside_returned}, cut band kept {kept:.3}"
                );
                assert_eq!(outside_returned, 0, "shift {shift} seed {seed} {paths}");
                assert!(kept > 0.85, "shift {shift} seed {seed} {paths}: {kept}");
            }
        }
    }
}

#[test]
fn the_valid_count_is_the_maps_in_every_mode() {
    // the bands count their own valid pixels (recounted after a speckle filter): with and
    // without the filter, filled, block matching and semi-global, one to three threads (one
    // band per thread), 8- and 16-bit input
    let s = scene(3);
    let l16 = parallax_block_matching::Gray16Image::from_fn(s.left.width(), s.left.height(), |x, y| {
        image::Luma([s.left.get_pixel(x, y)[0] as u16 * 257])
    });
    let r16 = parallax_block_matching::Gray16Image::from_fn(s.right.width(), s.right.height(), |x, y| {
        image::Luma([s.right.get_pixel(x, y)[0] as u16 * 257])
    });
    for method in [Method::BlockMatching, Method::Sgm] {
        for (speckle, fill) in [(0, false), (100, false), (0, true)] {
            for threads in 1..=3 {
                // the rank prefilter: its values do not grow with the bit depth, so semi-global
                // matching's 16-bit sums hold on 16-bit images
                let prefilter = Prefilter::Rank { size: 9 };
                let base = MatcherConfig {
                    method,
                    prefilter,
                    speckle_window_size: speckle,
                    fill,
                    threads,
                    ..MatcherConfig::default()
                };
                let mut m = BlockMatcher::new(cfg(base)).unwrap();
                for sixteen in [false, true] {
                    let d = if sixteen { m.compute_u16(&l16, &r16) } else { m.compute(&s.left, &s.right) }.unwrap();
                    let st = m.last_stats();
                    assert_eq!(st.valid, d.valid_count(), "{method:?} speckle {speckle} fill {fill} threads {threads}");
                    assert!(st.valid > st.pixels / 2 && st.valid < st.pixels || fill, "{st:?}");
                    assert_eq!(st.density, d.density());
                }
            }
        }
    }
}

#[test]
fn every_presets_rejections_add_up_to_its_missing_pixels() {
    // what `disparity` prints as `rejected_*` (no candidate, texture, uniqueness, left–right,
    // confidence, speckle) and `filled` must account for every pixel without a disparity: a
    // reason without a count would leave part of the map unexplained. A smallest disparity
    // above 0 gives pixels without a candidate (x < min_disparity); a confidence threshold
    // adds its rejects.
    let s = scene(4);
    let presets = [
        ("default", MatcherConfig::default()),
        ("dense", MatcherConfig::dense()),
        ("sgm", MatcherConfig::sgm()),
        ("sgm_accurate", MatcherConfig::sgm_accurate()),
        ("sgm_dense", MatcherConfig::sgm_dense()),
    ];
    for (name, preset) in presets {
        for (min_disparity, min_confidence) in [(0, 0.0), (6, 0.0), (6, 0.3)] {
            let c = MatcherConfig { min_disparity, num_disparities: 32, min_confidence, ..preset.clone() };
            let mut m = BlockMatcher::new(c).unwrap();
            let d = m.compute(&s.left, &s.right).unwrap();
            let st = m.last_stats();
            let missing = st.pixels - d.valid_count();
            let explained =
                st.no_candidate + st.low_texture + st.not_unique + st.lr_inconsistent + st.low_confidence + st.speckle
                    - st.filled;
            assert_eq!(explained, missing, "{name} min {min_disparity} confidence {min_confidence}: {st:?}");
            // x < min_disparity has no candidate in any preset: 6 columns of every row
            let h = s.left.height() as usize;
            assert_eq!(st.no_candidate, if min_disparity > 0 { 6 * h } else { 0 }, "{name}: {st:?}");
        }
    }
}

#[test]
fn the_accurate_preset_keeps_a_uniqueness_margin_in_the_left_band_only() {
    // `--accurate` has no uniqueness margin, yet its help says it still rejects by uniqueness
    // where the image edge cuts the candidates (x < min_disparity + disparities − 1): those
    // rejections exist and all fit in that band; a filled (benchmark) map has none
    let s = scene(5);
    let h = s.left.height() as usize;
    for (min_disparity, nd) in [(0, 32usize), (4, 24)] {
        let c = MatcherConfig { min_disparity, num_disparities: nd, ..MatcherConfig::sgm_accurate() };
        assert_eq!(c.uniqueness_ratio, 0);
        let mut m = BlockMatcher::new(c).unwrap();
        m.compute(&s.left, &s.right).unwrap();
        let st = m.last_stats();
        // columns min_disparity ..< min_disparity + nd − 1 (left of them: no candidate at all)
        let band = (nd - 1) * h;
        assert!(st.not_unique > 0 && st.not_unique <= band, "min {min_disparity}: {st:?}, band {band} px");
        let c = MatcherConfig { min_disparity, num_disparities: nd, ..MatcherConfig::sgm_dense() };
        let mut m = BlockMatcher::new(c).unwrap();
        m.compute(&s.left, &s.right).unwrap();
        assert_eq!(m.last_stats().not_unique, 0, "{:?}", m.last_stats());
    }
}
