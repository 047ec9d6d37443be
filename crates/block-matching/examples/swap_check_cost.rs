//! The cost of the swapped-pair check per frame against matching that frame: the median time
//! of [`SwapChecker::check`] (built once, as a sequence uses it) and of
//! [`BlockMatcher::compute_into`], interleaved, for block matching and semi-global matching
//! (the CLI's defaults and `--accurate`) on Middlebury teddy from ../shared (64 disparities).
//!
//! `cargo run --release -p parallax-block-matching --example swap_check_cost [RUNS] [THREADS]`
//! (defaults 21 runs, 0 threads = all cores).

use std::time::Instant;

use parallax_block_matching::{BlockMatcher, MatcherConfig, SwapChecker};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/middlebury/teddy");

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let runs: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(21);
    let threads: usize = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let dir = std::path::Path::new(DATA);
    let Ok(l) = image::open(dir.join("imL.png")) else {
        eprintln!("skipped: ../shared/data/middlebury/teddy not found");
        return;
    };
    let (l, r) = (l.into_luma8(), image::open(dir.join("imR.png")).unwrap().into_luma8());
    println!("teddy {}x{}x64, {runs} runs, threads {threads}", l.width(), l.height());
    for (name, preset) in [
        ("bm (default)", MatcherConfig::default()),
        ("sgm", MatcherConfig::sgm()),
        ("sgm --accurate", MatcherConfig::sgm_accurate()),
    ] {
        let mut m = BlockMatcher::new(MatcherConfig { num_disparities: 64, threads, ..preset }).unwrap();
        let mut checker = SwapChecker::new(&m).unwrap();
        let mut out = m.compute(&l, &r).unwrap();
        assert!(!checker.check(&l, &r).unwrap().looks_swapped);
        assert!(checker.check(&r, &l).unwrap().looks_swapped);
        let (mut tm, mut tc) = (Vec::new(), Vec::new());
        for _ in 0..runs {
            let t = Instant::now();
            m.compute_into(&l, &r, &mut out).unwrap();
            tm.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            std::hint::black_box(checker.check(&l, &r).unwrap());
            tc.push(t.elapsed().as_secs_f64());
        }
        let (a, b) = (median(tm), median(tc));
        println!("{name:16} match {:7.2} ms  check {:6.2} ms  check/match {:.3}", 1e3 * a, 1e3 * b, b / a);
    }
}
