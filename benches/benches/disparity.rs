//! Criterion benches of the block-matching core: SAD / SSD / NCC at 450x375x64 (Middlebury teddy
//! when ../shared is present, else a generated textured pair of that size) and 1280x720x128
//! (generated), windows 5, 9, 15, on 1 and 2 threads, with the default options (prefilter,
//! texture, uniqueness, left–right check, sub-pixel, speckle filter). Throughput is reported in
//! elements = width x height x disparities, so criterion's "elem/s" reads as disparity
//! evaluations per second. `BM_QUICK=1` keeps only SAD at 450x375 (for side-by-side runs with
//! OpenCV's peer/stereo_bm.py). `BM_SIMD=scalar|avx2|avx512` caps the instruction set (to measure
//! what the explicit SIMD paths buy). `disparity-sgm/…` benches semi-global matching (the
//! measurement preset, five and eight paths) on the same inputs.

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use image::GrayImage;
use parallax_benches::{teddy, textured_pair};
use parallax_block_matching::{BlockMatcher, CostFunction, MatcherConfig, SgmConfig, SgmPaths, SimdLevel};

fn teddy_or_generated() -> (GrayImage, GrayImage, &'static str) {
    match teddy() {
        Some((l, r)) => (l, r, "teddy"),
        None => {
            let (l, r) = textured_pair(450, 375, 60.0);
            (l, r, "gen450")
        }
    }
}

fn bench(c: &mut Criterion) {
    let quick = std::env::var_os("BM_QUICK").is_some();
    let (tl, tr, tname) = teddy_or_generated();
    let mut inputs = vec![(tname.to_string(), tl, tr, 64usize)];
    if !quick {
        let (l, r) = textured_pair(1280, 720, 120.0);
        inputs.push(("gen1280x720".to_string(), l, r, 128));
    }
    let costs: &[CostFunction] =
        if quick { &[CostFunction::Sad] } else { &[CostFunction::Sad, CostFunction::Ssd, CostFunction::Ncc] };
    for (name, left, right, nd) in &inputs {
        let mut group = c.benchmark_group(format!("disparity/{name}x{nd}"));
        group.sample_size(20).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
        group.throughput(Throughput::Elements(left.width() as u64 * left.height() as u64 * *nd as u64));
        for &cost in costs {
            for block in [5usize, 9, 15] {
                for threads in [1usize, 2] {
                    let cfg =
                        MatcherConfig { cost, block_size: block, num_disparities: *nd, threads, ..Default::default() };
                    let mut m = BlockMatcher::new(cfg).expect("valid config");
                    match std::env::var("BM_SIMD").as_deref() {
                        Ok("scalar") => m.set_simd(SimdLevel::Scalar),
                        Ok("avx2") => m.set_simd(SimdLevel::Avx2),
                        Ok("avx512") => m.set_simd(SimdLevel::Avx512),
                        _ => m.simd(),
                    };
                    let mut out = m.compute(left, right).expect("same size");
                    let id = BenchmarkId::new(format!("{cost:?}/w{block}"), format!("t{threads}"));
                    group.bench_function(id, |b| b.iter(|| m.compute_into(left, right, &mut out).expect("same size")));
                }
            }
        }
        group.finish();
        let mut group = c.benchmark_group(format!("disparity-sgm/{name}x{nd}"));
        group.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
        group.throughput(Throughput::Elements(left.width() as u64 * left.height() as u64 * *nd as u64));
        for paths in [SgmPaths::Five, SgmPaths::Eight] {
            let sgm = SgmConfig { paths, ..SgmConfig::default() };
            let cfg = MatcherConfig { num_disparities: *nd, sgm, ..MatcherConfig::sgm() };
            let mut m = BlockMatcher::new(cfg).expect("valid config");
            let mut out = m.compute(left, right).expect("same size");
            group.bench_function(format!("{paths:?}"), |b| {
                b.iter(|| m.compute_into(left, right, &mut out).expect("same size"))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
