//! Times the stages of the chessboard detector on one image (release build):
//! `cargo run --release -p corner-detection --example profile_stages -- IMAGE`.

use parallax_corner_detection::{
    ChessboardConfig, chessboard_candidates, find_chessboard, gaussian_blur, saddle_response, to_f32,
};
use std::time::Instant;

fn main() {
    let path = std::env::args().nth(1).expect("usage: profile_stages IMAGE");
    let img = image::open(&path).expect("readable image").into_luma8();
    let cfg = ChessboardConfig::default();
    let n = 20;
    let time = |label: &str, f: &mut dyn FnMut()| {
        let t0 = Instant::now();
        for _ in 0..n {
            f();
        }
        println!("{label}: {:.3} ms", t0.elapsed().as_secs_f64() * 1e3 / n as f64);
    };
    let f = to_f32(&img);
    time("to_f32", &mut || drop(to_f32(&img)));
    time("gaussian_blur 1.5", &mut || drop(gaussian_blur(&f, 1.5)));
    let s = gaussian_blur(&f, 1.5);
    time("saddle_response", &mut || drop(saddle_response(&s)));
    time("candidates (blur+response+peaks+ring)", &mut || drop(chessboard_candidates(&img, &cfg).unwrap()));
    time("find_chessboard", &mut || drop(find_chessboard(&img, 9, 6, &cfg).unwrap()));
    println!("candidates: {}", chessboard_candidates(&img, &cfg).unwrap().len());
    let strict = ChessboardConfig { max_candidates: 300, ..cfg };
    time("candidates, max 300 peaks", &mut || drop(chessboard_candidates(&img, &strict).unwrap()));
}
