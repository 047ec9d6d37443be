//! Sweeps the decision options on the Middlebury pairs (../shared/data/middlebury) and prints,
//! per pair, bad-2 with missing = bad, bad-2 among the returned pixels and the density (nonocc
//! mask): how the defaults were chosen.
//! `cargo run --release -p parallax-block-matching --example middlebury_sweep [bm|sgm]`

use parallax_block_matching::{BlockMatcher, MatcherConfig, Method, Prefilter, evaluate, from_scaled};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/middlebury");

fn main() {
    let sgm = std::env::args().nth(1).as_deref() == Some("sgm");
    let pairs = [("tsukuba", 16.0, 16), ("venus", 8.0, 32), ("teddy", 4.0, 64)];
    let mut data = Vec::new();
    for (name, scale, nd) in pairs {
        let dir = std::path::Path::new(DATA).join(name);
        let Ok(l) = image::open(dir.join("imL.png")) else {
            eprintln!("skipped: ../shared not found");
            return;
        };
        let r = image::open(dir.join("imR.png")).unwrap().into_luma8();
        let g = image::open(dir.join("groundtruth.png")).unwrap().into_luma8();
        let gv: Vec<u16> = g.as_raw().iter().map(|&v| v as u16).collect();
        let truth = from_scaled(&gv, g.width() as usize, g.height() as usize, scale).unwrap();
        let mask: Vec<bool> =
            image::open(dir.join("nonocc.png")).unwrap().into_luma8().as_raw().iter().map(|&v| v > 128).collect();
        data.push((name, nd, l.into_luma8(), r, truth, mask));
    }
    let mut configs: Vec<(String, MatcherConfig)> = vec![("dense".into(), MatcherConfig::dense())];
    let prefilters = [Prefilter::XSobel { cap: 31 }, Prefilter::Rank { size: 9 }, Prefilter::Rank { size: 7 }];
    for pf in prefilters {
        for uniq in [0, 10, 15, 25] {
            for speckle in [0, 100, 200] {
                for conf in [0.0f32, 0.1, 0.2] {
                    let cfg = MatcherConfig {
                        prefilter: pf,
                        uniqueness_ratio: uniq,
                        speckle_window_size: speckle,
                        min_confidence: conf,
                        method: if sgm { Method::Sgm } else { Method::BlockMatching },
                        ..MatcherConfig::default()
                    };
                    configs.push((format!("{pf:?} u{uniq} sp{speckle} c{conf}"), cfg));
                }
            }
        }
    }
    println!("{:44} | per pair: bad2 (missing = bad) / bad2 returned / density", "config");
    for (label, base) in configs {
        let mut line = format!("{label:44} |");
        for (_, nd, l, r, truth, mask) in &data {
            let cfg = MatcherConfig { num_disparities: *nd, ..base.clone() };
            let d = BlockMatcher::new(cfg).unwrap().compute(l, r).unwrap();
            let e = evaluate(&d, truth, Some(mask), &[2.0]).unwrap();
            line +=
                &format!(" {:6.2} {:5.2} {:5.1} |", e.bad_at(2.0).unwrap(), e.bad_returned_at(2.0).unwrap(), e.density);
        }
        println!("{line}");
    }
}
