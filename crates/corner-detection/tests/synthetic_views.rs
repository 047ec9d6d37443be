//! Acceptance tests on views rendered by `synthetic` (issue 4, "Checked by"): 640x480, 9x6
//! board, blur σ = 0.8 px, noise σ = 2 grey levels, 50 random views: found in every view, RMS
//! corner error ≤ 0.03 px against the true projections, no wrong ordering. Plus the negative
//! cases and the error curve over noise σ = 0..8 (printed; run with `--nocapture`).

use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics};
use parallax_corner_detection::{ChessboardConfig, CornerRefinement, find_chessboard};

use glam::DVec2;
use parallax_synthetic::{RenderOptions, ViewSetConfig, calibration_poses, render_chessboard};

fn camera() -> Camera {
    Camera {
        intrinsics: Intrinsics::new(600.0, 600.0, 322.0, 238.0),
        lens: Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0).into(),
        width: 640,
        height: 480,
    }
}

fn board() -> Chessboard {
    Chessboard { cols: 9, rows: 6, square_size: 25.0 }
}

#[derive(Default)]
struct Stats {
    found: usize,
    views: usize,
    sum_sq: f64,
    n: usize,
    worst: f64,
    misordered: usize,
}

impl Stats {
    /// Adds one view's result. A view counts as misordered when any corner is more than
    /// 2 px from its true position (a shifted or rotated order puts every corner a full
    /// square away).
    fn add(&mut self, found: Option<&[DVec2]>, truth: &[DVec2]) {
        self.views += 1;
        let Some(corners) = found else { return };
        self.found += 1;
        let errs: Vec<f64> = corners.iter().zip(truth).map(|(a, t)| (*a - *t).length()).collect();
        if errs.iter().any(|&e| e > 2.0) {
            self.misordered += 1;
            return;
        }
        for e in errs {
            self.sum_sq += e * e;
            self.n += 1;
            self.worst = self.worst.max(e);
        }
    }
}

/// Renders `views` views at the given noise and detects with each refinement method.
fn run(views: usize, noise: f64, seed: u64, methods: &[CornerRefinement]) -> Vec<Stats> {
    let cam = camera();
    let b = board();
    let poses = calibration_poses(&cam, &b, &ViewSetConfig { views, seed, ..Default::default() }).unwrap();
    let mut stats: Vec<Stats> = methods.iter().map(|_| Stats::default()).collect();
    for (k, pose) in poses.iter().enumerate() {
        let opts =
            RenderOptions { blur_sigma: 0.8, noise_sigma: noise, seed: seed * 1000 + k as u64, ..Default::default() };
        let view = render_chessboard(&cam, &b, pose, &opts).unwrap();
        for (m, s) in methods.iter().zip(stats.iter_mut()) {
            let cfg = ChessboardConfig { refinement: *m, ..Default::default() };
            let grid = find_chessboard(&view.image, 9, 6, &cfg).unwrap();
            s.add(grid.as_ref().map(|g| g.corners.as_slice()), &view.corners);
        }
    }
    stats
}

fn rms(s: &Stats) -> f64 {
    (s.sum_sq / s.n.max(1) as f64).sqrt()
}

#[test]
fn fifty_views_blur_08_noise_2_found_exact_and_ordered() {
    let all = run(50, 2.0, 7, &[CornerRefinement::Saddle, CornerRefinement::SubPix]);
    for (name, s) in ["saddle (default)", "subpix"].iter().zip(&all) {
        println!(
            "{name}: 50 views, blur 0.8, noise 2: found {}/{}, misordered {}, RMS {:.4} px, worst {:.4} px",
            s.found,
            s.views,
            s.misordered,
            rms(s),
            s.worst
        );
    }
    let s = &all[0];
    assert_eq!(s.found, 50, "board missed in {} views", 50 - s.found);
    assert_eq!(s.misordered, 0);
    assert!(rms(s) <= 0.03, "RMS corner error {} px", rms(s));
    // The gradient-orthogonality method finds the same boards, within 0.04 px RMS.
    assert_eq!((all[1].found, all[1].misordered), (50, 0));
    assert!(rms(&all[1]) <= 0.04, "subpix RMS {}", rms(&all[1]));
}

#[test]
fn error_curve_over_noise() {
    // Printed for the report (`--nocapture`); asserts every board found in the right order
    // and an RMS that grows no faster than 0.01 px per grey level of noise.
    for noise in [0.0, 1.0, 2.0, 4.0, 6.0, 8.0] {
        let all = run(8, noise, 11, &[CornerRefinement::Saddle, CornerRefinement::SubPix]);
        let (sd, sp) = (&all[0], &all[1]);
        println!(
            "noise σ {noise}: saddle found {}/{} RMS {:.4} worst {:.4} | subpix found {}/{} RMS {:.4} worst {:.4}",
            sd.found,
            sd.views,
            rms(sd),
            sd.worst,
            sp.found,
            sp.views,
            rms(sp),
            sp.worst
        );
        assert_eq!(sp.misordered + sd.misordered, 0);
        assert_eq!(sd.found, 8, "noise {noise}: found only {}/8", sd.found);
        assert!(rms(sd) < 0.02 + 0.01 * noise, "noise {noise}: RMS {}", rms(sd));
    }
}

#[test]
fn stereo_like_views_of_the_same_board_agree_in_order() {
    // The same pose seen rolled by 180° (camera upside down): the order follows the board,
    // so corner k is the same physical corner in both views.
    let cam = camera();
    let b = board();
    let poses = calibration_poses(&cam, &b, &ViewSetConfig { views: 6, seed: 21, ..Default::default() }).unwrap();
    for (k, pose) in poses.iter().enumerate() {
        let view = render_chessboard(
            &cam,
            &b,
            pose,
            &RenderOptions { blur_sigma: 0.8, noise_sigma: 2.0, seed: k as u64, ..Default::default() },
        )
        .unwrap();
        let grid = find_chessboard(&view.image, 9, 6, &ChessboardConfig::default()).unwrap().expect("found");
        // Rotate the image by 180°: pixel (u, v) → (w−1−u, h−1−v).
        let rotated = image::imageops::rotate180(&view.image);
        let grid_r = find_chessboard(&rotated, 9, 6, &ChessboardConfig::default()).unwrap().expect("found rotated");
        let (w, h) = (cam.width as f64 - 1.0, cam.height as f64 - 1.0);
        for (a, r) in grid.corners.iter().zip(&grid_r.corners) {
            let back = DVec2::new(w - r.x, h - r.y);
            assert!((*a - back).length() < 0.1, "view {k}: corner order differs after rotation");
        }
    }
}

#[test]
fn negative_cases_on_rendered_views() {
    let cam = camera();
    let b = board();
    let poses = calibration_poses(&cam, &b, &ViewSetConfig { views: 4, seed: 5, ..Default::default() }).unwrap();
    let opts = RenderOptions { blur_sigma: 0.8, noise_sigma: 2.0, clutter: true, seed: 9, ..Default::default() };
    let cfg = ChessboardConfig::default();
    for pose in &poses {
        let view = render_chessboard(&cam, &b, pose, &opts).unwrap();
        assert!(find_chessboard(&view.image, 9, 6, &cfg).unwrap().is_some(), "board with clutter missed");
        for (c, r) in [(8, 6), (9, 7), (10, 6), (6, 5)] {
            assert!(find_chessboard(&view.image, c, r, &cfg).unwrap().is_none(), "{c}x{r} reported on a 9x6 board");
        }
        // Half the board hidden: paint the right half of its bounding box with the background.
        let xs: Vec<f64> = view.corners.iter().map(|c| c.x).collect();
        let mid = (xs.iter().cloned().fold(f64::MAX, f64::min) + xs.iter().cloned().fold(f64::MIN, f64::max)) / 2.0;
        let mut cut = view.image.clone();
        for (x, _, p) in cut.enumerate_pixels_mut() {
            if x as f64 > mid {
                p[0] = 128;
            }
        }
        assert!(find_chessboard(&cut, 9, 6, &cfg).unwrap().is_none(), "half board reported as found");
    }
    // Clutter without a board (the board rendered far outside the image).
    let far = parallax_camera_model::Isometry3::from_rvec_tvec(glam::DVec3::ZERO, glam::DVec3::new(5000.0, 0.0, 400.0));
    let empty = render_chessboard(&cam, &b, &far, &opts).unwrap();
    assert!(find_chessboard(&empty.image, 9, 6, &cfg).unwrap().is_none());
    let blank = image::GrayImage::from_pixel(640, 480, image::Luma([200]));
    assert!(find_chessboard(&blank, 9, 6, &cfg).unwrap().is_none());
}

#[test]
fn hard_scene_strong_distortion_tilt_lighting_clutter() {
    // synthetic's "hard" scene: k1 = −0.3 barrel distortion, tilts up to 60°, blur 1 px,
    // noise 3, impulse noise, illumination gradient, vignetting and background clutter.
    let scene = parallax_synthetic::SceneDescription::builtin_hard();
    let poses =
        calibration_poses(&scene.camera, &scene.board, &ViewSetConfig { views: 12, seed: 31, ..scene.views.clone() })
            .unwrap();
    let mut s = Stats::default();
    for (k, pose) in poses.iter().enumerate() {
        let opts = RenderOptions { seed: 500 + k as u64, ..scene.render.clone() };
        let view = render_chessboard(&scene.camera, &scene.board, pose, &opts).unwrap();
        let grid = find_chessboard(&view.image, 9, 6, &ChessboardConfig::default()).unwrap();
        s.add(grid.as_ref().map(|g| g.corners.as_slice()), &view.corners);
    }
    println!(
        "hard scene: found {}/{}, misordered {}, RMS {:.4} px, worst {:.4} px",
        s.found,
        s.views,
        s.misordered,
        rms(&s),
        s.worst
    );
    assert_eq!(s.misordered, 0);
    assert!(s.found >= 11, "found only {}/12", s.found);
    assert!(rms(&s) < 0.08, "RMS {}", rms(&s));
}
