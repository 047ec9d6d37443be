//! Sweeps the decision options on the Middlebury pairs (../shared/data/middlebury) and prints
//! bad-1 / bad-2 / density for each setting: how the defaults were chosen.
//! `cargo run --release -p block-matching --example middlebury_sweep [sad|ssd|ncc]`

use parallax_block_matching::{BlockMatcher, CostFunction, MatcherConfig, Prefilter, evaluate, from_scaled};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/middlebury");

fn main() {
    let cost = match std::env::args().nth(1).as_deref() {
        Some("ssd") => CostFunction::Ssd,
        Some("ncc") => CostFunction::Ncc,
        _ => CostFunction::Sad,
    };
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
    let prefilters = [
        Prefilter::XSobel { cap: 31 },
        Prefilter::XSobel { cap: 15 },
        Prefilter::XSobel { cap: 63 },
        Prefilter::NormalizedResponse { size: 9, cap: 31 },
        Prefilter::NormalizedResponse { size: 15, cap: 63 },
        Prefilter::None,
    ];
    let extra: Vec<String> = std::env::args().skip(2).collect();
    let pf_list: Vec<Prefilter> =
        if extra.iter().any(|a| a == "pf") { prefilters.to_vec() } else { vec![Prefilter::XSobel { cap: 31 }] };
    for pf in pf_list {
        let pf_only = extra.iter().any(|a| a == "pf");
        let uniqs: &[u32] = if pf_only { &[0] } else { &[0, 5, 10, 15] };
        for &uniq in uniqs {
            let lrs: &[Option<u32>] =
                if pf_only { &[None, Some(0), Some(1)] } else { &[None, Some(0), Some(1), Some(2)] };
            for &lr in lrs {
                let speckles: &[usize] = if pf_only { &[0] } else { &[0, 50, 100, 200] };
                for &speckle in speckles {
                    let texs: &[u32] = if pf_only { &[10] } else { &[0, 10] };
                    for &tex in texs {
                        for fill in [false, true] {
                            let mut line = format!("{pf:?} fill{fill} u{uniq:2} lr{lr:?} sp{speckle:3} tex{tex:2} |");
                            let mut worst = f64::NEG_INFINITY;
                            for (_, nd, l, r, truth, mask) in &data {
                                let cfg = MatcherConfig {
                                    cost,
                                    num_disparities: *nd,
                                    prefilter: pf,
                                    uniqueness_ratio: uniq,
                                    lr_max_diff: lr,
                                    lr_fill: fill,
                                    speckle_window_size: speckle,
                                    texture_threshold: tex,
                                    ..MatcherConfig::default()
                                };
                                let d = BlockMatcher::new(cfg).unwrap().compute(l, r).unwrap();
                                let e = evaluate(&d, truth, Some(mask), &[1.0, 2.0]).unwrap();
                                let b2 = e.bad_at(2.0).unwrap();
                                line += &format!(" {:6.2} {:6.2} {:5.1} |", e.bad_at(1.0).unwrap(), b2, e.density);
                                worst = worst.max(b2);
                            }
                            println!("{line}");
                        }
                    }
                }
            }
        }
    }
}
