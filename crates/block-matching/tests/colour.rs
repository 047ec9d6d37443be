//! Colour input: the cost summed over the channels, for semi-global matching (pixel cost) and
//! block matching (window cost).

use parallax_block_matching::image::{GrayImage, Rgb, RgbImage};
use parallax_block_matching::{
    BlockMatcher, BlockMatchingError, CostFunction, MatcherConfig, Prefilter, SgmConfig, SgmPaths, SimdLevel,
};

/// A textured pair with a disparity step, deterministic for a seed.
fn pair(seed: u64, w: u32, h: u32) -> (GrayImage, GrayImage) {
    let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut next = move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 33) as u32
    };
    let tex: Vec<u8> = (0..(w + 40) * h).map(|_| (next() % 256) as u8).collect();
    let left =
        GrayImage::from_fn(w, h, |x, y| parallax_block_matching::image::Luma([tex[(y * (w + 40) + x + 20) as usize]]));
    let right = GrayImage::from_fn(w, h, |x, y| {
        let d = if x > w / 2 { 9 } else { 4 };
        parallax_block_matching::image::Luma([tex[(y * (w + 40) + x + 20 + d) as usize]])
    });
    (left, right)
}

fn grey_to_rgb(g: &GrayImage) -> RgbImage {
    RgbImage::from_fn(g.width(), g.height(), |x, y| {
        let v = g.get_pixel(x, y)[0];
        Rgb([v, v, v])
    })
}

/// Three equal channels cost three times the grey cost: with three times the penalties every
/// decision is the same, so the maps are identical.
#[test]
fn equal_channels_with_tripled_penalties_give_the_grey_map() {
    for (seed, paths, bt, int) in
        [(1, SgmPaths::Three, true, true), (2, SgmPaths::Five, false, false), (3, SgmPaths::Eight, true, false)]
    {
        let (l, r) = pair(seed, 96, 40);
        let sgm = SgmConfig {
            paths,
            block: 3,
            sampling_insensitive: bt,
            intensity_cost: int,
            p2_gamma: 0,
            ..SgmConfig::default()
        };
        let grey = MatcherConfig { num_disparities: 16, sgm, ..MatcherConfig::sgm() };
        let colour = MatcherConfig { sgm: SgmConfig { p1: 3 * sgm.p1, p2: 3 * sgm.p2, ..sgm }, ..grey.clone() };
        let a = BlockMatcher::new(grey).unwrap().compute(&l, &r).unwrap();
        let b = BlockMatcher::new(colour).unwrap().compute_rgb(&grey_to_rgb(&l), &grey_to_rgb(&r)).unwrap();
        let same = a.data().iter().zip(b.data()).filter(|(x, y)| x.to_bits() == y.to_bits()).count();
        assert_eq!(same, a.data().len(), "seed {seed} {paths:?}: {same} of {} equal", a.data().len());
    }
}

/// Block matching: three equal channels cost three times the grey cost in every window, and
/// every decision (winner, OpenCV's integer uniqueness rule, sub-pixel fit, left–right check,
/// confidence ratio) is unchanged by that factor, so the maps and confidences are identical,
/// bit for bit, at every SIMD level: in 16-bit lanes (9x9 on the x-Sobel), where colour needs
/// the 32-bit lanes and grey does not (21x21: 3 · 441 · 62 > 65534), SSD, rank and raw pixels.
#[test]
fn block_matching_equal_channels_give_the_grey_map() {
    let configs = [
        MatcherConfig { num_disparities: 16, confidence_map: true, ..MatcherConfig::default() },
        MatcherConfig { num_disparities: 16, block_size: 21, uniqueness_ratio: 15, ..MatcherConfig::default() },
        MatcherConfig { num_disparities: 24, cost: CostFunction::Ssd, min_confidence: 0.1, ..MatcherConfig::default() },
        MatcherConfig { num_disparities: 16, prefilter: Prefilter::Rank { size: 7 }, ..MatcherConfig::dense() },
        MatcherConfig {
            num_disparities: 16,
            prefilter: Prefilter::None,
            uniqueness_ratio: 10,
            ..MatcherConfig::default()
        },
    ];
    for (i, cfg) in configs.into_iter().enumerate() {
        let (l, r) = pair(10 + i as u64, 96, 40);
        for level in [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512] {
            let mut grey = BlockMatcher::new(cfg.clone()).unwrap();
            let mut colour = BlockMatcher::new(cfg.clone()).unwrap();
            if grey.set_simd(level) != level {
                continue;
            }
            colour.set_simd(level);
            let a = grey.compute(&l, &r).unwrap();
            let b = colour.compute_rgb(&grey_to_rgb(&l), &grey_to_rgb(&r)).unwrap();
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(a.data()), bits(b.data()), "{level:?} {cfg:?}");
            assert_eq!(grey.confidence().map(bits), colour.confidence().map(bits), "{level:?} {cfg:?}");
            assert_eq!(grey.last_stats(), colour.last_stats(), "{level:?} {cfg:?}");
            // (the pair has structure: most pixels matched)
            assert!(a.valid_count() > a.data().len() / 2, "{level:?} {cfg:?}: {} valid", a.valid_count());
        }
    }
}

/// Block matching with NCC on a colour pair is refused, naming the cost; grey NCC and colour
/// SAD run.
#[test]
fn block_matching_refuses_ncc_on_colour() {
    let (l, r) = pair(5, 64, 24);
    let cfg = MatcherConfig { num_disparities: 16, cost: CostFunction::Ncc, ..MatcherConfig::default() };
    let mut m = BlockMatcher::new(cfg.clone()).unwrap();
    match m.compute_rgb(&grey_to_rgb(&l), &grey_to_rgb(&r)) {
        Err(e @ BlockMatchingError::InvalidConfig { field: "cost", .. }) => {
            let text = e.to_string();
            assert!(text.contains("Ncc") && text.contains("colour"), "{text}");
        }
        other => panic!("NCC on colour: {other:?}"),
    }
    assert!(m.compute(&l, &r).is_ok());
    let sad = MatcherConfig { cost: CostFunction::Sad, ..cfg };
    assert!(BlockMatcher::new(sad).unwrap().compute_rgb(&grey_to_rgb(&l), &grey_to_rgb(&r)).is_ok());
}
