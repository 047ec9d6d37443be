//! A `ChessboardDetector` reused over images of different sizes (its pyramid, blur, response
//! and peak buffers grown, shrunk and left with the previous image's values) returns exactly
//! what a fresh detector returns on each image alone, and what the one-shot `detect_chessboard`
//! returns: the same corners bit for bit, the same refinement reports, pyramid level and
//! candidate count; and a board is still found, in OpenCV's order, near the rendered truth.

use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics};
use parallax_corner_detection::{ChessboardConfig, ChessboardDetection, ChessboardDetector, detect_chessboard};
use parallax_synthetic::{RenderOptions, ViewSetConfig, calibration_poses, render_chessboard};

/// One rendered view: the image and its true corners.
fn view(w: u32, h: u32, cols: usize, rows: usize, blur: f64, seed: u64) -> (image::GrayImage, Vec<glam::DVec2>) {
    let f = 0.875 * w as f64;
    let cam = Camera {
        intrinsics: Intrinsics::new(f, f, (w as f64 - 1.0) / 2.0 + 3.0, (h as f64 - 1.0) / 2.0 - 2.0),
        lens: Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0).into(),
        width: w,
        height: h,
    };
    let board = Chessboard { cols, rows, square_size: 25.0 };
    let cfg = ViewSetConfig { views: 1, seed, min_distance: 450.0, max_distance: 800.0, ..Default::default() };
    let pose = calibration_poses(&cam, &board, &cfg).unwrap()[0];
    let opts = RenderOptions { blur_sigma: blur, noise_sigma: 2.0, seed: seed + 7, ..Default::default() };
    let v = render_chessboard(&cam, &board, &pose, &opts).unwrap();
    (v.image, v.corners)
}

fn same(a: &ChessboardDetection, b: &ChessboardDetection) -> bool {
    a.grid.corners.len() == b.grid.corners.len()
        && a.grid
            .corners
            .iter()
            .zip(&b.grid.corners)
            .all(|(p, q)| p.x.to_bits() == q.x.to_bits() && p.y.to_bits() == q.y.to_bits())
        && a.refinement == b.refinement
        && a.min_spacing.to_bits() == b.min_spacing.to_bits()
        && a.min_contrast.to_bits() == b.min_contrast.to_bits()
        && (a.candidates, a.pyramid_level) == (b.candidates, b.pyramid_level)
}

#[test]
fn reused_detector_equals_fresh_detectors_bit_for_bit_across_image_sizes() {
    // Sizes with different pyramid depths (1600x1200: levels 1, 0; 800x600 and 1000x750: 0 and
    // 1; 640x480 and 320x240: 0 only), a repeat of the first size after smaller ones, and an
    // image without a board in between.
    let blank = image::GrayImage::from_pixel(1000, 750, image::Luma([128]));
    let views = [
        view(1600, 1200, 12, 12, 4.5, 3),
        view(320, 240, 9, 6, 0.8, 7),
        view(1000, 750, 9, 6, 1.5, 11),
        (blank, Vec::new()),
        view(640, 480, 9, 6, 0.8, 13),
        view(1600, 1200, 12, 12, 1.2, 17),
        view(320, 240, 9, 6, 0.8, 19),
    ];
    let cfg = ChessboardConfig::default();
    let mut reused = ChessboardDetector::new(cfg).unwrap();
    let mut found = 0;
    for (k, (img, truth)) in views.iter().enumerate() {
        let (cols, rows) = if img.width() == 1600 { (12, 12) } else { (9, 6) };
        let a = reused.detect(img, cols, rows).unwrap();
        let b = ChessboardDetector::new(cfg).unwrap().detect(img, cols, rows).unwrap();
        let c = detect_chessboard(img, cols, rows, &cfg).unwrap();
        match (&a, &b, &c) {
            (None, None, None) => assert!(truth.is_empty(), "view {k}: board not found"),
            (Some(a), Some(b), Some(c)) => {
                assert!(same(a, b), "view {k}: reused detector differs from a fresh one");
                assert!(same(a, c), "view {k}: reused detector differs from detect_chessboard");
                // Found and right: every corner within 0.3 px of the truth (a misordered grid is
                // a whole square, > 10 px, off).
                assert_eq!(a.grid.corners.len(), truth.len(), "view {k}");
                let worst = a.grid.corners.iter().zip(truth).map(|(p, t)| (*p - *t).length()).fold(0.0, f64::max);
                assert!(worst < 0.3, "view {k}: worst corner error {worst} px");
                found += 1;
            }
            _ => panic!(
                "view {k}: found by one API and not the other ({}, {}, {})",
                a.is_some(),
                b.is_some(),
                c.is_some()
            ),
        }
    }
    assert_eq!(found, views.len() - 1);
}
