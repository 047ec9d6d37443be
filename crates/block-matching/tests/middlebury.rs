//! Middlebury 2001/2003 pairs (tsukuba, venus, teddy) with a 9x9 window and the default options:
//! bad-2 over the non-occluded mask (missing = bad) must beat OpenCV StereoBM's best 9x9 setting
//! (uniqueness 0; ../shared/reference/opencv-baseline.md) at density ≥ 85 %, for SAD, SSD and NCC.
//! Skipped with a message when ../shared is absent.

use std::path::{Path, PathBuf};

use parallax_block_matching::{BlockMatcher, CostFunction, MatcherConfig, evaluate, from_scaled};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/middlebury");

/// (pair, GT scale, disparities searched, OpenCV StereoBM 9x9 uniqueness-0 bad-2 %)
const PAIRS: [(&str, f32, usize, f64); 3] =
    [("tsukuba", 16.0, 16, 7.45), ("venus", 8.0, 32, 10.96), ("teddy", 4.0, 64, 22.59)];

fn gray(p: &Path) -> image::GrayImage {
    image::open(p).unwrap_or_else(|e| panic!("reading {}: {e}", p.display())).into_luma8()
}

#[test]
fn middlebury_bad2_beats_opencv_stereobm_9x9() {
    let root = PathBuf::from(DATA);
    if !root.is_dir() {
        eprintln!("skipped: ../shared not found ({DATA})");
        return;
    }
    let mut failures = Vec::new();
    println!("{:8} {:4} {:>7} {:>7} {:>7} {:>7} {:>9}", "pair", "cost", "bad1", "bad2", "density", "rms", "OpenCV b2");
    for (name, scale, nd, opencv_bad2) in PAIRS {
        let dir = root.join(name);
        let (l, r) = (gray(&dir.join("imL.png")), gray(&dir.join("imR.png")));
        let g = gray(&dir.join("groundtruth.png"));
        let gv: Vec<u16> = g.as_raw().iter().map(|&v| v as u16).collect();
        let truth = from_scaled(&gv, g.width() as usize, g.height() as usize, scale).unwrap();
        let mask: Vec<bool> = gray(&dir.join("nonocc.png")).as_raw().iter().map(|&v| v > 128).collect();
        for cost in [CostFunction::Sad, CostFunction::Ssd, CostFunction::Ncc] {
            let cfg = MatcherConfig { cost, block_size: 9, num_disparities: nd, ..MatcherConfig::default() };
            let mut m = BlockMatcher::new(cfg).unwrap();
            let d = m.compute(&l, &r).unwrap();
            let s = m.last_stats();
            let matched = 100.0 * (s.valid - s.lr_filled) as f64 / s.pixels as f64;
            let e = evaluate(&d, &truth, Some(&mask), &[1.0, 2.0]).unwrap();
            let (b1, b2) = (e.bad_at(1.0).unwrap(), e.bad_at(2.0).unwrap());
            println!(
                "{name:8} {cost:4?} {b1:7.2} {b2:7.2} {:7.2} {:7.3} {opencv_bad2:9.2}  (matched before left-right fill: {matched:.1} % of the image)",
                e.density, e.rms
            );
            if b2 >= opencv_bad2 || e.density < 85.0 {
                failures
                    .push(format!("{name} {cost:?}: bad-2 {b2:.2} (OpenCV {opencv_bad2}), density {:.1}", e.density));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
