//! Timing server for `scripts/chessboard_vs_opencv.py`: decodes the images given on the command
//! line once, prints `ready`, then for every line `INDEX` read from stdin (`ready` is followed by the same four counters) detects the board in
//! that image with one reused [`ChessboardDetector`] and prints
//! `ms found utime_ticks stime_ticks minor_faults major_faults` (the last four cumulative for
//! this process, from `/proc/self/stat`, so the script can split user and system time).
//! Usage: `time_chessboards COLSxROWS IMAGES...` (release build).

use parallax_corner_detection::{ChessboardConfig, ChessboardDetector};
use std::io::{BufRead, Write};

/// `(utime, stime, minflt, majflt)` of this process (clock ticks and counts); zeros where
/// `/proc` is missing.
fn proc_times() -> (u64, u64, u64, u64) {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return (0, 0, 0, 0);
    };
    // Fields after the parenthesised command name: state is field 3; minflt 10, majflt 12,
    // utime 14, stime 15 (1-based, see proc(5)).
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<u64> = rest.split_whitespace().skip(1).map(|v| v.parse().unwrap_or(0)).collect();
    let at = |field: usize| f.get(field - 4).copied().unwrap_or(0);
    (at(14), at(15), at(10), at(12))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: time_chessboards COLSxROWS IMAGES...");
        std::process::exit(2);
    }
    let (c, r) = args[0].split_once('x').expect("COLSxROWS");
    let (cols, rows): (usize, usize) = (c.parse().expect("cols"), r.parse().expect("rows"));
    let images: Vec<image::GrayImage> =
        args[1..].iter().map(|p| image::open(p).unwrap_or_else(|e| panic!("{p}: {e}")).into_luma8()).collect();
    let mut detector = ChessboardDetector::new(ChessboardConfig::default()).expect("default configuration");
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let (u, s, minf, majf) = proc_times();
    writeln!(out, "ready {u} {s} {minf} {majf}").expect("stdout");
    out.flush().expect("stdout");
    for line in std::io::stdin().lock().lines() {
        let line = line.expect("stdin");
        let k: usize = line.trim().parse().expect("an image index");
        let t0 = std::time::Instant::now();
        let found = detector.detect(&images[k], cols, rows).expect("valid input").is_some();
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let (u, s, minf, majf) = proc_times();
        writeln!(out, "{ms:.4} {} {u} {s} {minf} {majf}", u8::from(found)).expect("stdout");
        out.flush().expect("stdout");
    }
}
