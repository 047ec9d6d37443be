//! Block matching as a share of this machine's ceiling, measured in interleaved rounds: each
//! round times the vector-add chains on every core (`parallax_benches::ceiling`; the ceiling is
//! the best 16-bit lane rate over the widths this CPU has, divided by
//! `stereo-limits.md`'s 9.5 vector operations per disparity evaluation), then the block matcher
//! on every core with the options of `benches/scripts/disparity_vs_opencv.py bm` (9x9 SAD on the
//! x-Sobel prefilter, texture 10, uniqueness 0, no left–right check, no speckle filter) on
//! 626x555x96 and 1282x1110x224 (Middlebury teddy resized to those sizes when `../shared` is
//! present — bilinear here, cubic in that script; else a generated textured pair). Evaluations are counted as
//! width x height x disparities, the lanes the kernel computes.
//!
//! `cargo bench -p parallax-benches --bench ceiling` (release; `cargo xtask bench` runs it too,
//! unless its filter names another bench); `CEILING_ROUNDS` (default 9).
//! Reports, asserts nothing: run it with the machine otherwise quiet and say the load.

use std::time::Instant;

use image::GrayImage;
use parallax_benches::ceiling::{OPS_PER_EVALUATION, Width, lane_rate};
use parallax_benches::{teddy, textured_pair};
use parallax_block_matching::{BlockMatcher, MatcherConfig, Prefilter};

fn pair(w: u32, h: u32, nd: usize) -> (GrayImage, GrayImage, &'static str) {
    match teddy() {
        Some((l, r)) => {
            let f = image::imageops::FilterType::Triangle;
            (image::imageops::resize(&l, w, h, f), image::imageops::resize(&r, w, h, f), "teddy resized")
        }
        None => {
            let (l, r) = textured_pair(w, h, 0.9 * nd as f64);
            (l, r, "generated")
        }
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

fn main() {
    // `cargo bench` passes `--bench`, and `cargo xtask bench FILTER` criterion's filter: run only
    // when there is none or it names this bench
    if std::env::args().skip(1).any(|a| !a.starts_with('-') && !"ceiling".contains(a.as_str())) {
        return;
    }
    let rounds: usize = std::env::var("CEILING_ROUNDS").ok().and_then(|s| s.parse().ok()).unwrap_or(9).max(1);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let widths: Vec<Width> = Width::ALL.into_iter().filter(|w| w.available()).collect();
    if widths.is_empty() {
        println!("ceiling: no x86-64 vector width on this CPU; nothing to measure");
        return;
    }
    let mut cases = Vec::new();
    for (w, h, nd) in [(626u32, 555u32, 96usize), (1282, 1110, 224)] {
        let (left, right, source) = pair(w, h, nd);
        let cfg = MatcherConfig {
            block_size: 9,
            num_disparities: nd,
            prefilter: Prefilter::XSobel { cap: 31 },
            texture_threshold: 10,
            uniqueness_ratio: 0,
            lr_max_diff: None,
            speckle_window_size: 0,
            threads,
            ..MatcherConfig::default()
        };
        let mut m = BlockMatcher::new(cfg).expect("a valid configuration");
        let out = m.compute(&left, &right).expect("same size");
        println!("{w}x{h}x{nd} ({source}), {threads} threads, simd {:?}", m.simd());
        cases.push((format!("{w}x{h}x{nd}"), left, right, m, out, (w as f64) * (h as f64) * nd as f64));
    }
    // about 60 ms of adds per width and round at this machine's rate
    let chain_rounds = 4_000_000;
    println!("load average before: {}", std::fs::read_to_string("/proc/loadavg").unwrap_or_default().trim());
    let mut ceilings = Vec::new();
    let mut evals: Vec<Vec<f64>> = vec![Vec::new(); cases.len()];
    let mut shares: Vec<Vec<f64>> = vec![Vec::new(); cases.len()];
    for round in 0..rounds {
        let mut line = format!("round {round}:");
        let mut best = 0.0f64;
        for &w in &widths {
            let r = lane_rate(w, threads, chain_rounds).expect("available");
            line += &format!(" {}-bit {:.0} G lanes/s", w.bits(), r / 1e9);
            best = best.max(r);
        }
        let ceiling = best / OPS_PER_EVALUATION;
        line += &format!(" -> ceiling {:.1} G/s;", ceiling / 1e9);
        ceilings.push(ceiling);
        for (i, (name, left, right, m, out, n)) in cases.iter_mut().enumerate() {
            // median of five computes, as `xtask disparity --runs 5`
            let mut t: Vec<f64> = (0..5)
                .map(|_| {
                    let t0 = Instant::now();
                    m.compute_into(left, right, out).expect("same size");
                    t0.elapsed().as_secs_f64()
                })
                .collect();
            let rate = *n / median(&mut t);
            evals[i].push(rate);
            shares[i].push(rate / ceiling);
            line += &format!(" {name} {:.1} G/s = {:.1} %", rate / 1e9, 100.0 * rate / ceiling);
        }
        println!("{line}");
    }
    println!("medians of {rounds} rounds: ceiling {:.1} G evaluations/s", median(&mut ceilings) / 1e9);
    for (i, (name, ..)) in cases.iter().enumerate() {
        let (lo, hi) = shares[i].iter().fold((f64::MAX, 0.0f64), |(a, b), &s| (a.min(s), b.max(s)));
        println!(
            "{name}: {:.1} G evaluations/s, {:.1} % of the ceiling (rounds {:.1}–{:.1} %)",
            median(&mut evals[i]) / 1e9,
            100.0 * median(&mut shares[i]),
            100.0 * lo,
            100.0 * hi
        );
    }
    println!("load average after: {}", std::fs::read_to_string("/proc/loadavg").unwrap_or_default().trim());
}
