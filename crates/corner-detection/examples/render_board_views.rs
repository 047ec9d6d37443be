//! Writes synthetic chessboard views (PNG) for side-by-side timing against OpenCV:
//! `cargo run --release -p parallax-corner-detection --example render_board_views -- DIR [W H COLS ROWS VIEWS BLUR]`
//! (defaults: 1600 1200 12 12 6 4.5; noise σ 2, the lens of `tests/scale_free.rs`).
//! Time both with `scripts/chessboard_vs_opencv.py DIR COLSxROWS`.

use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics};
use parallax_synthetic::{RenderOptions, ViewSetConfig, calibration_poses, render_chessboard};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = std::path::PathBuf::from(args.first().expect("usage: render_board_views DIR [W H COLS ROWS VIEWS BLUR]"));
    let num = |i: usize, d: f64| args.get(i).map(|v| v.parse::<f64>().expect("a number")).unwrap_or(d);
    let (w, h) = (num(1, 1600.0) as u32, num(2, 1200.0) as u32);
    let (cols, rows, views, blur) = (num(3, 12.0) as usize, num(4, 12.0) as usize, num(5, 6.0) as usize, num(6, 4.5));
    let f = 0.875 * w as f64;
    let cam = Camera {
        intrinsics: Intrinsics::new(f, f, (w as f64 - 1.0) / 2.0 + 3.0, (h as f64 - 1.0) / 2.0 - 2.0),
        lens: Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0).into(),
        width: w,
        height: h,
    };
    let board = Chessboard { cols, rows, square_size: 25.0 };
    let poses = calibration_poses(
        &cam,
        &board,
        &ViewSetConfig { views, seed: 3, min_distance: 500.0, max_distance: 900.0, ..Default::default() },
    )
    .expect("poses");
    std::fs::create_dir_all(&dir).expect("output directory");
    for (k, pose) in poses.iter().enumerate() {
        let opts = RenderOptions { blur_sigma: blur, noise_sigma: 2.0, seed: 300 + k as u64, ..Default::default() };
        let view = render_chessboard(&cam, &board, pose, &opts).expect("render");
        let path = dir.join(format!("view{k:02}.png"));
        view.image.save(&path).expect("PNG written");
        println!("{}", path.display());
    }
}
