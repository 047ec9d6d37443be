//! Quick timing on Middlebury teddy (../shared): Mde/s of the default SAD 9x9 matcher and of the
//! bare core (no left–right check) on 1 and 2 threads, windows 5 / 9 / 15, and per SIMD level.
//! `cargo run --release -p block-matching --example speed`

use std::time::Instant;

use parallax_block_matching::{BlockMatcher, CostFunction, MatcherConfig, SimdLevel};

const TEDDY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/middlebury/teddy");

fn main() {
    let Ok(l) = image::open(format!("{TEDDY}/imL.png")) else {
        eprintln!("skipped: ../shared not found");
        return;
    };
    let (l, r) = (l.into_luma8(), image::open(format!("{TEDDY}/imR.png")).unwrap().into_luma8());
    let nd = 64;
    let evals = (l.width() * l.height()) as f64 * nd as f64;
    // the best instruction set this CPU has, and the portable one
    let best = SimdLevel::detect();
    for cost in [CostFunction::Sad, CostFunction::Ssd, CostFunction::Ncc] {
        for (label, lr) in [("default", Some(1)), ("no-lr", None)] {
            for block in [5, 9, 15] {
                for threads in [1, 2] {
                    for simd in [best, SimdLevel::Scalar] {
                        if (simd != best) && (block != 9 || threads != 1 || cost != CostFunction::Sad) {
                            continue;
                        }
                        // SPEED_ONLY=1: only SAD, default options, 9x9, 1 thread, best SIMD (for profiling)
                        if std::env::var_os("SPEED_ONLY").is_some()
                            && (cost != CostFunction::Sad || lr.is_none() || block != 9 || threads != 1 || simd != best)
                        {
                            continue;
                        }
                        let cfg = MatcherConfig {
                            cost,
                            block_size: block,
                            num_disparities: nd,
                            threads,
                            lr_max_diff: lr,
                            ..Default::default()
                        };
                        let mut m = BlockMatcher::new(cfg).unwrap();
                        let used = m.set_simd(simd);
                        let mut out = m.compute(&l, &r).unwrap();
                        let mut times = Vec::new();
                        for _ in 0..if std::env::var_os("SPEED_ONLY").is_some() { 200 } else { 15 } {
                            let t = Instant::now();
                            m.compute_into(&l, &r, &mut out).unwrap();
                            times.push(t.elapsed().as_secs_f64());
                        }
                        times.sort_by(f64::total_cmp);
                        let med = times[times.len() / 2];
                        println!(
                            "{cost:?} {label:7} w{block:2} t{threads} {used:?}: {:7.3} ms  {:6.0} Mde/s",
                            med * 1e3,
                            evals / med / 1e6
                        );
                    }
                }
            }
        }
    }
}
