//! Times `filter_speckles` on a disparity map (PFM), for `benches/scripts/speckle_vs_opencv.py`:
//! `speckle_speed MAP.pfm [window 100] [range 2.0] [runs 21]` prints the median `seconds:` and the
//! number of pixels removed.

use std::time::Instant;

use parallax_block_matching::{filter_speckles, from_pfm};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: speckle_speed MAP.pfm [window] [range] [runs]");
        std::process::exit(2);
    };
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or(default.into());
    let (window, range, runs): (usize, f32, usize) =
        (arg(2, "100").parse().unwrap(), arg(3, "2.0").parse().unwrap(), arg(4, "21").parse().unwrap());
    let map = from_pfm(&std::fs::read(path).unwrap(), path).unwrap();
    let mut times = Vec::new();
    let mut removed = 0;
    for _ in 0..runs {
        let mut m = map.clone();
        let t = Instant::now();
        removed = filter_speckles(&mut m, window, range);
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    println!("removed: {removed}");
    println!("seconds: {}", times[times.len() / 2]);
}
