//! Solves a rig fixture (`tests/data/rig/*.json`, or any file of that format) `REPEATS` times
//! and prints one JSON line: the RMS, the median seconds per solve, and per camera `fx`, `fy`,
//! `t` and `rvec` of `camI_from_cam0`. Used by `benches/scripts/rig_vs_opencv.py`.
//!
//!   cargo build --release -p parallax-planar-calibration --example rig_solve
//!   target/release/examples/rig_solve crates/planar-calibration/tests/data/rig/pinhole4.json 5

#[path = "../tests/common/rig_json.rs"]
mod rig_json;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).expect("usage: rig_solve FILE.json [REPEATS]");
    let repeats: usize = args.get(2).map_or(5, |r| r.parse().expect("REPEATS is a number"));
    let set: rig_json::RigSet = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let (frames, sizes, config) = (set.frames(), set.sizes(), set.config());
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..repeats.max(1) {
        let t = std::time::Instant::now();
        let r = parallax_planar_calibration::calibrate_rig(&frames, &sizes, &config).unwrap();
        times.push(t.elapsed().as_secs_f64());
        last = Some(r);
    }
    times.sort_by(f64::total_cmp);
    let r = last.unwrap();
    let out = serde_json::json!({
        "rms_px": r.rms_px,
        "seconds_per_solve": times[times.len() / 2],
        "fx": r.cameras.iter().map(|c| c.intrinsics.fx).collect::<Vec<_>>(),
        "fy": r.cameras.iter().map(|c| c.intrinsics.fy).collect::<Vec<_>>(),
        "t": r.cam_from_cam0.iter().map(|e| e.translation.to_array()).collect::<Vec<_>>(),
        "rvec": r.cam_from_cam0.iter().map(|e| e.rvec().to_array()).collect::<Vec<_>>(),
        "iterations": r.iterations,
    });
    println!("{out}");
}
