//! Sweeps matcher settings on the Middlebury pairs (../shared/data/middlebury, nonocc mask) and
//! prints, per pair, bad-2 with missing = bad, bad-2 among the returned pixels and the density:
//! how the defaults were chosen.
//!
//! `cargo run --release -p parallax-block-matching --example middlebury_sweep [MODE]`
//!
//! - `bm` (default) / `sgm`: the decision options (prefilter, uniqueness, speckle, confidence)
//!   for block matching or semi-global matching;
//! - `sgm-params 1`: the SGM costs and penalties (prefilter, block, P1, P2, P2 gamma);
//! - `sgm-params 2`: paths and decisions around one choice of those, given by the environment
//!   (`PF`=xsobel|rank5|rank7, `B`, `P1`, `P2`, `G`);
//! - `overlap`: penalties and left–right tolerance around the default SGM preset, scored where
//!   OpenCV also answers (bad-2 with missing = bad and density, x ≥ the disparities searched);
//! - `overlap-colour`: the same score for colour input (the cost summed over the channels).

use parallax_block_matching::{
    BlockMatcher, MatcherConfig, Method, Prefilter, SgmConfig, SgmPaths, evaluate, from_scaled,
};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/middlebury");

fn main() {
    let mode = std::env::args().nth(1).unwrap_or_else(|| "bm".into());
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
        let (lc, rc) = (l.to_rgb8(), image::open(dir.join("imR.png")).unwrap().into_rgb8());
        data.push((nd, l.into_luma8(), r, truth, mask, lc, rc));
    }
    let configs = match mode.as_str() {
        "bm" => decisions(Method::BlockMatching),
        "sgm" => decisions(Method::Sgm),
        "sgm-params" => sgm_params(std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(1)),
        "overlap" => return overlap(&data),
        "overlap-colour" => return overlap_colour(&data),
        other => {
            eprintln!("unknown mode {other:?}: bm, sgm or sgm-params [1|2]");
            std::process::exit(2);
        }
    };
    println!("{:44} | per pair: bad2 (missing = bad) / bad2 returned / density", "config");
    for (label, base) in configs {
        let mut line = format!("{label:44} |");
        for (nd, l, r, truth, mask, ..) in &data {
            let cfg = MatcherConfig { num_disparities: *nd, ..base.clone() };
            let d = BlockMatcher::new(cfg).unwrap().compute(l, r).unwrap();
            let e = evaluate(&d, truth, Some(mask), &[2.0]).unwrap();
            line +=
                &format!(" {:6.2} {:5.2} {:5.1} |", e.bad_at(2.0).unwrap(), e.bad_returned_at(2.0).unwrap(), e.density);
        }
        println!("{line}");
    }
}

/// The decision options (and the dense preset) for one method.
fn decisions(method: Method) -> Vec<(String, MatcherConfig)> {
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
                        method,
                        ..MatcherConfig::default()
                    };
                    configs.push((format!("{pf:?} u{uniq} sp{speckle} c{conf}"), cfg));
                }
            }
        }
    }
    configs
}

/// The SGM parameters: costs and penalties (`stage` 1), or paths and decisions (2).
fn sgm_params(stage: u32) -> Vec<(String, MatcherConfig)> {
    let base =
        MatcherConfig { method: Method::Sgm, speckle_window_size: 0, uniqueness_ratio: 10, ..Default::default() };
    let mut configs: Vec<(String, MatcherConfig)> = Vec::new();
    if stage == 1 {
        for pf in [Prefilter::XSobel { cap: 31 }, Prefilter::Rank { size: 5 }] {
            for block in [5, 7] {
                for p1 in [4, 8, 16] {
                    for k in [4, 8] {
                        for gamma in [16, 48] {
                            let sgm = SgmConfig { block, p1, p2: p1 * k, p2_gamma: gamma, ..SgmConfig::default() };
                            configs.push((
                                format!("{pf:?} b{block} p1 {p1} p2 {} g{gamma}", p1 * k),
                                MatcherConfig { prefilter: pf, sgm, ..base.clone() },
                            ));
                        }
                    }
                }
            }
        }
    } else {
        let pf: Prefilter = match std::env::var("PF").as_deref() {
            Ok("xsobel") => Prefilter::XSobel { cap: 31 },
            Ok("rank7") => Prefilter::Rank { size: 7 },
            _ => Prefilter::Rank { size: 5 },
        };
        let get = |k: &str, d: u32| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
        let sgm = SgmConfig {
            block: get("B", 3) as usize,
            p1: get("P1", 2),
            p2: get("P2", 16),
            p2_gamma: get("G", 16),
            ..SgmConfig::default()
        };
        for paths in [SgmPaths::Five, SgmPaths::Eight] {
            for uniq in [0, 5, 10, 15] {
                for speckle in [0, 100] {
                    for fill in [false, true] {
                        configs.push((
                            format!("{paths:?} u{uniq} sp{speckle} fill {fill}"),
                            MatcherConfig {
                                prefilter: pf,
                                sgm: SgmConfig { paths, ..sgm },
                                uniqueness_ratio: uniq,
                                speckle_window_size: speckle,
                                fill,
                                ..base.clone()
                            },
                        ));
                    }
                }
            }
        }
    }
    configs
}

/// Like-for-like sweep: bad-2 (missing = bad) and density over the mask in the columns where
/// OpenCV answers, per pair, for the SGM settings around the accurate cost.
type Pair = (
    usize,
    image::GrayImage,
    image::GrayImage,
    parallax_block_matching::parallax_camera_model::DisparityMap,
    Vec<bool>,
    image::RgbImage,
    image::RgbImage,
);

fn overlap_colour(data: &[Pair]) {
    use parallax_block_matching::evaluate_overlap;
    let mut configs = Vec::new();
    for paths in [SgmPaths::Three, SgmPaths::Five] {
        for (bt, int) in [(true, true), (true, false)] {
            for sp in [100, 0] {
                for p1 in [18, 24, 36] {
                    for p2 in [192, 288, 384] {
                        for gamma in [0, 16, 48] {
                            let sgm = SgmConfig {
                                paths,
                                block: 3,
                                p1,
                                p2,
                                p2_gamma: gamma,
                                sampling_insensitive: bt,
                                intensity_cost: int,
                                ..SgmConfig::default()
                            };
                            configs.push((
                                format!("{paths:?} bt{bt} int{int} sp{sp} p1 {p1} p2 {p2} g{gamma}"),
                                MatcherConfig {
                                    uniqueness_ratio: 0,
                                    lr_subpixel: true,
                                    lr_winners: true,
                                    speckle_window_size: sp,
                                    sgm,
                                    ..MatcherConfig::sgm()
                                },
                            ));
                        }
                    }
                }
            }
        }
    }
    for (label, base) in configs {
        let mut line = format!("{label:44} |");
        for (nd, _, _, truth, mask, l, r) in data {
            let cfg = MatcherConfig { num_disparities: *nd, ..base.clone() };
            let d = BlockMatcher::new(cfg).unwrap().compute_rgb(l, r).unwrap();
            let e = evaluate_overlap(&d, truth, Some(mask), (0, *nd), &[2.0]).unwrap();
            line += &format!(" {:6.2} {:5.2} |", e.bad_at(2.0).unwrap(), e.density);
        }
        println!("{line}");
    }
}

fn overlap(data: &[Pair]) {
    use parallax_block_matching::evaluate_overlap;
    // around the default SGM preset: penalties, the adaptive P2 and the left–right tolerance
    let base = MatcherConfig::sgm();
    let mut configs = Vec::new();
    for p1 in [20, 24, 28, 32] {
        for p2 in [80, 96, 128] {
            for gamma in [32, 48, 64] {
                for lr in [1, 2] {
                    let sgm = SgmConfig { p1, p2, p2_gamma: gamma, ..base.sgm };
                    configs.push((
                        format!("p1 {p1} p2 {p2} g{gamma} lr {lr}"),
                        MatcherConfig { lr_max_diff: Some(lr), sgm, ..base.clone() },
                    ));
                }
            }
        }
    }
    for (label, base) in configs {
        let mut line = format!("{label:44} |");
        for (nd, l, r, truth, mask, ..) in data {
            let cfg = MatcherConfig { num_disparities: *nd, ..base.clone() };
            let d = BlockMatcher::new(cfg).unwrap().compute(l, r).unwrap();
            let e = evaluate_overlap(&d, truth, Some(mask), (0, *nd), &[2.0]).unwrap();
            line += &format!(" {:6.2} {:5.2} |", e.bad_at(2.0).unwrap(), e.density);
        }
        println!("{line}");
    }
}
