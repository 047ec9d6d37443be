//! Scale-free chessboard detection (issue 18): boards rendered by `synthetic` at 320x240,
//! 1600x1200 (12x12 inner corners) and 4000x3000 are all found with the default configuration,
//! in OpenCV's order and within a stated RMS of the true corners. The large images are blurred
//! as real high-resolution cameras are (optical blur σ = 4.5 px at 1600x1200, 8 px at
//! 4000x3000): with the search at full resolution only (`pyramid_side: 0`, the fixed-pixel
//! detector before issue 18) none of these boards was found (0/4 and 0/2, measured when the
//! test was written); with the default pyramid all are.

use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics};
use parallax_corner_detection::{ChessboardConfig, ChessboardDetector};
use parallax_synthetic::{RenderOptions, ViewSetConfig, calibration_poses, render_chessboard};

fn camera(w: u32, h: u32, f: f64) -> Camera {
    Camera {
        intrinsics: Intrinsics::new(f, f, (w as f64 - 1.0) / 2.0 + 3.0, (h as f64 - 1.0) / 2.0 - 2.0),
        lens: Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0).into(),
        width: w,
        height: h,
    }
}

/// Renders `views` views and runs one detector over them; returns (found, worst corner error,
/// RMS over all corners).
fn run(cam: &Camera, board: &Chessboard, views: usize, dist: (f64, f64), blur: f64, seed: u64) -> (usize, f64, f64) {
    let cfg = ViewSetConfig { views, seed, min_distance: dist.0, max_distance: dist.1, ..Default::default() };
    let poses = calibration_poses(cam, board, &cfg).unwrap();
    let mut det = ChessboardDetector::new(ChessboardConfig::default()).unwrap();
    let (mut found, mut worst, mut sum, mut n) = (0, 0.0f64, 0.0, 0usize);
    for (k, pose) in poses.iter().enumerate() {
        let opts =
            RenderOptions { blur_sigma: blur, noise_sigma: 2.0, seed: seed * 100 + k as u64, ..Default::default() };
        let view = render_chessboard(cam, board, pose, &opts).unwrap();
        let Some(d) = det.detect(&view.image, board.cols, board.rows).unwrap() else {
            println!("view {k}: not found");
            continue;
        };
        found += 1;
        for (a, t) in d.grid.corners.iter().zip(&view.corners) {
            let e = (*a - *t).length();
            worst = worst.max(e);
            sum += e * e;
            n += 1;
        }
    }
    let rms = (sum / n.max(1) as f64).sqrt();
    println!(
        "{}x{} {}x{} board: found {found}/{views}, RMS {rms:.4} px, worst {worst:.4} px",
        cam.width, cam.height, board.cols, board.rows
    );
    (found, worst, rms)
}

#[test]
fn twelve_by_twelve_at_1600x1200_found_with_defaults() {
    let cam = camera(1600, 1200, 1400.0);
    let board = Chessboard { cols: 12, rows: 12, square_size: 25.0 };
    let (found, worst, rms) = run(&cam, &board, 4, (500.0, 900.0), 4.5, 3);
    assert_eq!(found, 4);
    // Every corner within 0.5 px (a misordered grid is a whole square, ≥ 30 px, off).
    assert!(worst < 0.5 && rms < 0.05, "worst {worst}, RMS {rms}");
}

#[test]
fn board_at_4000x3000_found_with_defaults() {
    let cam = camera(4000, 3000, 3300.0);
    let board = Chessboard { cols: 9, rows: 6, square_size: 25.0 };
    let (found, worst, rms) = run(&cam, &board, 2, (500.0, 900.0), 8.0, 5);
    assert_eq!(found, 2);
    assert!(worst < 0.5 && rms < 0.08, "worst {worst}, RMS {rms}");
}

#[test]
fn small_image_320x240_found_with_defaults() {
    let cam = camera(320, 240, 300.0);
    let board = Chessboard { cols: 9, rows: 6, square_size: 25.0 };
    let (found, worst, rms) = run(&cam, &board, 4, (400.0, 600.0), 0.8, 7);
    assert_eq!(found, 4);
    assert!(worst < 0.3 && rms < 0.05, "worst {worst}, RMS {rms}");
}
