//! Colour input for semi-global matching: the cost summed over the channels.

use parallax_block_matching::image::{GrayImage, Rgb, RgbImage};
use parallax_block_matching::{BlockMatcher, MatcherConfig, SgmConfig, SgmPaths};

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
