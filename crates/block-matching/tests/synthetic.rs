//! Synthetic stereo scenes with known disparity (`parallax_synthetic::render_stereo_scene`):
//! sub-pixel accuracy on fronto-parallel textured planes, and NCC's invariance to a gain and
//! offset of the right image.

use parallax_block_matching::{BlockMatcher, CostFunction, MatcherConfig, Prefilter, evaluate};
use parallax_camera_model::DisparityMap;
use parallax_synthetic::{StereoSceneConfig, render_stereo_scene};

fn scene(gain: f64, offset: f64) -> parallax_synthetic::StereoScene {
    let cfg = StereoSceneConfig {
        width: 320,
        height: 240,
        max_disparity: 32.0,
        noise_sigma: 1.0,
        right_gain: gain,
        right_offset: offset,
        seed: 7,
        ..StereoSceneConfig::default()
    };
    render_stereo_scene(&cfg).expect("valid scene")
}

/// Pixels whose whole `(2m+1)²` neighbourhood is fronto-parallel, textured, visible and at one
/// true disparity (so a window there sees a single plane).
fn interior_mask(s: &parallax_synthetic::StereoScene, m: usize) -> Vec<bool> {
    let (w, h) = (s.disparity.width(), s.disparity.height());
    let ok = |i: usize| s.fronto_parallel[i] && !s.occluded[i] && !s.low_texture[i];
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if x < m || y < m || x + m >= w || y + m >= h {
                return false;
            }
            let d0 = s.disparity.data()[i];
            (y - m..=y + m).all(|yy| (x - m..=x + m).all(|xx| ok(yy * w + xx) && s.disparity.data()[yy * w + xx] == d0))
        })
        .collect()
}

fn run(s: &parallax_synthetic::StereoScene, cfg: MatcherConfig) -> DisparityMap {
    BlockMatcher::new(cfg).unwrap().compute(&s.left, &s.right).unwrap()
}

#[test]
fn subpixel_rms_on_fronto_parallel_planes_is_below_a_tenth_of_a_pixel() {
    let s = scene(1.0, 0.0);
    let mask = interior_mask(&s, 5);
    let n = mask.iter().filter(|&&m| m).count();
    assert!(n > 5000, "too few interior fronto-parallel pixels ({n})");
    for cost in [CostFunction::Sad, CostFunction::Ssd, CostFunction::Ncc] {
        let d = run(&s, MatcherConfig { cost, num_disparities: 32, ..MatcherConfig::default() });
        let e = evaluate(&d, &s.disparity, Some(&mask), &[0.5, 1.0]).unwrap();
        println!(
            "{cost:?}: rms {:.4} px, bad-0.5 {:.2} %, density {:.2} % over {n} px",
            e.rms,
            e.bad_at(0.5).unwrap(),
            e.density
        );
        assert!(e.rms <= 0.1, "{cost:?}: sub-pixel RMS {:.4} px > 0.1", e.rms);
        assert!(e.density > 99.0, "{cost:?}: density {:.2} %", e.density);
    }
}

/// Bad-1 (non-occluded pixels) of `cfg` on the plain scene and on the scene whose right image
/// has a gain of 1.3 and an offset of +20.
/// The two scenes are rendered once for all the tests.
fn bad1_plain_and_lit(cfg: &MatcherConfig) -> (f64, f64) {
    static SCENES: std::sync::OnceLock<(parallax_synthetic::StereoScene, parallax_synthetic::StereoScene)> =
        std::sync::OnceLock::new();
    let (plain, lit) = SCENES.get_or_init(|| (scene(1.0, 0.0), scene(1.3, 20.0)));
    let mask: Vec<bool> = plain.occluded.iter().map(|&o| !o).collect();
    let bad1 = |s: &parallax_synthetic::StereoScene| {
        let d = run(s, cfg.clone());
        evaluate(&d, &s.disparity, Some(&mask), &[1.0]).unwrap().bad_at(1.0).unwrap()
    };
    (bad1(plain), bad1(lit))
}

#[test]
fn ncc_is_invariant_to_right_gain_and_offset_while_sad_is_not() {
    // raw intensities: the cost alone must absorb the photometric change
    let base = MatcherConfig { num_disparities: 32, prefilter: Prefilter::None, ..MatcherConfig::default() };
    let ncc = MatcherConfig { cost: CostFunction::Ncc, ..base.clone() };
    let sad = MatcherConfig { cost: CostFunction::Sad, ..base.clone() };
    let (n0, n1) = bad1_plain_and_lit(&ncc);
    let (s0, s1) = bad1_plain_and_lit(&sad);
    // and with the default prefilter (clipped x-Sobel removes the offset but clips the gain)
    let nccd = MatcherConfig { cost: CostFunction::Ncc, num_disparities: 32, ..MatcherConfig::default() };
    let (d0, d1) = bad1_plain_and_lit(&nccd);
    println!(
        "bad-1 plain → gain 1.3 offset +20: NCC raw {n0:.2} → {n1:.2}, SAD raw {s0:.2} → {s1:.2}, NCC x-Sobel {d0:.2} → {d1:.2}"
    );
    assert!((n1 - n0).abs() < 1.0, "NCC bad-1 changed by {:.2} points", n1 - n0);
    assert!(s1 - s0 > 5.0, "SAD on raw intensities should suffer from the gain: {s0:.2} → {s1:.2}");
}

#[test]
fn rank_prefilter_makes_sad_invariant_to_right_gain_and_offset() {
    // the rank transform depends only on the order of intensities, which a gain and an offset
    // keep (up to rounding and the 255 clip): SAD on ranks behaves like NCC here, at SAD's speed
    let rank =
        MatcherConfig { num_disparities: 32, prefilter: Prefilter::Rank { size: 5 }, ..MatcherConfig::default() };
    let (r0, r1) = bad1_plain_and_lit(&rank);
    println!("bad-1 plain → gain 1.3 offset +20: SAD on 5x5 ranks {r0:.2} → {r1:.2}");
    assert!((r1 - r0).abs() < 1.0, "rank SAD bad-1 changed by {:.2} points", r1 - r0);
    assert!(r0 < 15.0, "rank SAD bad-1 {r0:.2} % on the plain scene");
}
