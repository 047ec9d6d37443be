//! Rendered chessboards against independent computations of coverage and geometry.

use std::time::Instant;

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3};
use parallax_synthetic::*;

fn opts_bw() -> RenderOptions {
    RenderOptions { black: 0, white: 255, background: 128, ..Default::default() }
}

/// Independent colour of a board point given in squares (`None` off the board).
fn colour(x: f64, y: f64, cols: usize, rows: usize, margin: f64, o: &RenderOptions) -> Option<f64> {
    let (xmax, ymax) = (cols as f64 + margin, rows as f64 + margin);
    if x < -1.0 - margin || y < -1.0 - margin || x >= xmax || y >= ymax {
        return None;
    }
    if x < -1.0 || y < -1.0 || x >= cols as f64 || y >= rows as f64 {
        return Some(f64::from(o.white));
    }
    let (i, j) = (x.floor() as i64, y.floor() as i64);
    // An outlined print: only the black squares' frame, `square_outline` wide, is black.
    let (fx, fy) = (x - i as f64, y - j as f64);
    let frame = o.square_outline == 0.0 || fx.min(fy).min(1.0 - fx).min(1.0 - fy) < o.square_outline;
    Some(if (i + j).rem_euclid(2) == 0 && frame { f64::from(o.black) } else { f64::from(o.white) })
}

#[test]
fn fronto_parallel_edges_have_area_weighted_intensities() {
    // 10 px squares, inner corner (0,0) at pixel (100.3, 79.3): edges cross pixels at 0.8 / 0.2.
    let cam = Camera::new(Intrinsics::new(400.0, 400.0, 100.0, 80.0), Distortion::default(), 320, 240).unwrap();
    let board = Chessboard::new(7, 5, 25.0).unwrap();
    let pose = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(0.75, -1.75, 1000.0));
    let o = opts_bw();
    let view = render_chessboard(&cam, &board, &pose, &o).unwrap();
    assert!((view.corners[0] - DVec2::new(100.3, 79.3)).length() < 1e-9);
    let (u0, v0, sq) = (100.3, 79.3, 10.0);
    let mut worst = 0.0f64;
    for v in 0..240 {
        for u in 0..320 {
            // Separable exact integral over the pixel in board squares: breakpoints every square.
            let (xa, xb) = ((u as f64 - 0.5 - u0) / sq, (u as f64 + 0.5 - u0) / sq);
            let (ya, yb) = ((v as f64 - 0.5 - v0) / sq, (v as f64 + 0.5 - v0) / sq);
            let mut sum = 0.0;
            let mut area = 0.0;
            let cuts = |a: f64, b: f64| {
                let mut c = vec![a];
                let mut k = a.floor() + 1.0;
                while k < b {
                    c.push(k);
                    k += 1.0;
                }
                c.push(b);
                c
            };
            let (cx, cy) = (cuts(xa, xb), cuts(ya, yb));
            for i in 0..cx.len() - 1 {
                for j in 0..cy.len() - 1 {
                    let a = (cx[i + 1] - cx[i]) * (cy[j + 1] - cy[j]);
                    let mid = (0.5 * (cx[i] + cx[i + 1]), 0.5 * (cy[j] + cy[j + 1]));
                    let c = colour(mid.0, mid.1, 7, 5, 1.0, &o).unwrap_or(128.0);
                    sum += a * c;
                    area += a;
                }
            }
            let expected = sum / area;
            let got = f64::from(view.image.get_pixel(u, v).0[0]);
            worst = worst.max((got - expected).abs());
        }
    }
    // Only the final rounding to 8 bits may differ.
    assert!(worst <= 0.5 + 1e-6, "worst deviation from the area-weighted value {worst}");
    // The column crossing the vertical edge at u = 100.3: 80 % of square (-1, j), 20 % of (0, j).
    for v in 81..88 {
        let got = f64::from(view.image.get_pixel(100, v).0[0]);
        // Row v in square j = 0 (v ∈ [79.3, 89.3)): square (-1,0) white, (0,0) black.
        assert!((got - 0.8 * 255.0).abs() <= 0.5, "pixel (100, {v}) = {got}");
    }
    // Mean over a square's pixels including its anti-aliased border equals the covered area.
    let mean_row: f64 = (81..88).map(|v| f64::from(view.image.get_pixel(100, v).0[0])).sum::<f64>() / 7.0;
    assert!((mean_row - 204.0).abs() <= 0.5);
}

/// Brute force: many point samples per pixel through camera-model's unprojection.
fn brute_force(cam: &Camera, pose: &Isometry3, board: &Chessboard, o: &RenderOptions, u: u32, v: u32, n: usize) -> f64 {
    let inv = pose.inverse();
    let normal = pose.transform_vector(DVec3::Z);
    let mut sum = 0.0;
    for j in 0..n {
        for i in 0..n {
            let px =
                DVec2::new(u as f64 - 0.5 + (i as f64 + 0.5) / n as f64, v as f64 - 0.5 + (j as f64 + 0.5) / n as f64);
            let ray = cam.unproject(px).unwrap();
            let lambda = normal.dot(pose.translation) / normal.dot(ray);
            let p = inv.transform_point(ray * lambda) / board.square_size;
            sum += colour(p.x, p.y, board.cols, board.rows, o.margin_squares, o).unwrap_or(f64::from(o.background));
        }
    }
    sum / (n * n) as f64
}

fn distorted_camera() -> Camera {
    Camera::new(
        Intrinsics::new(620.0, 615.0, 322.5, 236.0),
        Distortion::new(-0.25, 0.12, 0.001, -0.002, -0.02),
        640,
        480,
    )
    .unwrap()
}

#[test]
fn tilted_distorted_view_matches_brute_force_supersampling() {
    let cam = distorted_camera();
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let poses = calibration_poses(&cam, &board, &ViewSetConfig { views: 2, seed: 9, ..Default::default() }).unwrap();
    // Solid squares, and squares printed as outlines (issue 49's hard prints).
    for (pose, outline) in poses.iter().zip([0.0, 0.15]) {
        let o = RenderOptions { square_outline: outline, ..opts_bw() };
        let view = render_chessboard(&cam, &board, pose, &o).unwrap();
        // Every 7th anti-aliased (mixed) pixel: these carry the edge positions.
        let mut diffs = vec![];
        let (mut k, mut outlined_pixels) = (0, 0);
        for (u, v, p) in view.image.enumerate_pixels() {
            let g = p.0[0];
            if g != 0 && g != 255 && g != 128 {
                k += 1;
                if k % 7 == 0 {
                    let bf = brute_force(&cam, pose, &board, &o, u, v, 48);
                    if outline > 0.0 {
                        outlined_pixels += 1;
                    }
                    diffs.push((f64::from(g) - bf).abs());
                }
            }
        }
        assert!(diffs.len() > 200, "too few edge pixels: {}", diffs.len());
        let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
        let max = diffs.iter().cloned().fold(0.0, f64::max);
        // 48x48 point samples resolve coverage to ~1/48 per row: a few grey levels at worst.
        assert!(mean < 0.9 && max < 6.0, "mean {mean} max {max} over {} pixels", diffs.len());
        if outline > 0.0 {
            // The frames' inner edges add edge pixels: about twice as many as solid squares have.
            assert!(outlined_pixels > 400, "{outlined_pixels} edge pixels on the outlined print");
        }
    }
}

#[test]
fn corners_are_the_camera_model_projection() {
    let cam = distorted_camera();
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let pose = calibration_poses(&cam, &board, &ViewSetConfig { views: 1, ..Default::default() }).unwrap()[0];
    let view = render_chessboard(&cam, &board, &pose, &RenderOptions::default()).unwrap();
    assert_eq!(view.camera_from_board, pose);
    for (c, p) in view.corners.iter().zip(board.object_points()) {
        assert!((*c - cam.project_from(&pose, p).unwrap()).length() <= 1e-9);
    }
    // Around each true corner the four quadrants alternate dark/bright (the pattern is where
    // the corners say it is): sample 3 px away along the diagonals through the image.
    let px = |p: DVec2| f64::from(view.image.get_pixel(p.x.round() as u32, p.y.round() as u32).0[0]);
    for r in 0..board.rows {
        for c in 0..board.cols {
            let k = r * board.cols + c;
            let right =
                if c + 1 < board.cols { view.corners[k + 1] } else { 2.0 * view.corners[k] - view.corners[k - 1] };
            let down = if r + 1 < board.rows {
                view.corners[k + board.cols]
            } else {
                2.0 * view.corners[k] - view.corners[k - board.cols]
            };
            let (dx, dy) = ((right - view.corners[k]) * 0.3, (down - view.corners[k]) * 0.3);
            let ctr = view.corners[k];
            // Square (c, r) (lower right of the corner) is black when c + r is even.
            let lower_right = px(ctr + dx + dy);
            let upper_right = px(ctr + dx - dy);
            let (dark, bright) = if (c + r) % 2 == 0 { (lower_right, upper_right) } else { (upper_right, lower_right) };
            assert!(dark < 60.0 && bright > 190.0, "corner ({c},{r}): dark {dark} bright {bright}");
        }
    }
}

#[test]
fn rendering_is_deterministic_and_effects_have_their_size() {
    let cam = distorted_camera();
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let pose = calibration_poses(&cam, &board, &ViewSetConfig { views: 1, ..Default::default() }).unwrap()[0];
    let o = RenderOptions {
        blur_sigma: 0.8,
        noise_sigma: 2.0,
        salt_fraction: 0.01,
        illumination_gradient: 0.2,
        vignetting: 0.3,
        clutter: true,
        seed: 5,
        ..Default::default()
    };
    let a = render_chessboard(&cam, &board, &pose, &o).unwrap();
    let b = render_chessboard(&cam, &board, &pose, &o).unwrap();
    assert_eq!(a.image.as_raw(), b.image.as_raw(), "same seed, same bytes");
    let c = render_chessboard(&cam, &board, &pose, &RenderOptions { seed: 6, ..o.clone() }).unwrap();
    assert_ne!(a.image.as_raw(), c.image.as_raw());

    // Noise: an empty view (board far behind the image) is a flat background plus N(0, σ²).
    let away = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(1e5, 0.0, 1000.0));
    let flat = RenderOptions { noise_sigma: 3.0, background: 100, ..Default::default() };
    let img = render_chessboard(&cam, &board, &away, &flat).unwrap().image;
    let vals: Vec<f64> = img.as_raw().iter().map(|&p| f64::from(p)).collect();
    let mean = vals.iter().sum::<f64>() / vals.len() as f64;
    let std = (vals.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / vals.len() as f64).sqrt();
    // Rounding adds 1/12 grey² of variance.
    assert!((mean - 100.0).abs() < 0.05 && (std - (9.0f64 + 1.0 / 12.0).sqrt()).abs() < 0.05, "mean {mean} std {std}");

    // Salt: the fraction of 0/255 pixels on a flat background.
    let salt = RenderOptions { salt_fraction: 0.05, background: 100, ..Default::default() };
    let img = render_chessboard(&cam, &board, &away, &salt).unwrap().image;
    let frac = img.as_raw().iter().filter(|&&p| p == 0 || p == 255).count() as f64 / (640.0 * 480.0);
    assert!((frac - 0.05).abs() < 0.003, "salt fraction {frac}");

    // Vignetting: factor 1 − v (r/r_max)²; at the principal point 1, at the farthest corner 1 − v.
    let vig = RenderOptions { vignetting: 0.5, background: 200, ..Default::default() };
    let img = render_chessboard(&cam, &board, &away, &vig).unwrap().image;
    assert_eq!(img.get_pixel(322, 236).0[0], 200);
    let far =
        [(0u32, 0u32), (639, 0), (0, 479), (639, 479)].iter().map(|&(u, v)| img.get_pixel(u, v).0[0]).min().unwrap();
    assert!((f64::from(far) - 100.0).abs() <= 0.5 + 1e-9, "corner {far}");

    // Gradient: brightness runs from 1 − g to 1 + g, so the image mean stays and the extremes are ±g.
    let grad = RenderOptions { illumination_gradient: 0.25, background: 100, seed: 3, ..Default::default() };
    let img = render_chessboard(&cam, &board, &away, &grad).unwrap().image;
    let (mn, mx) = img.as_raw().iter().fold((255u8, 0u8), |(a, b), &p| (a.min(p), b.max(p)));
    assert!(mn >= 75 && mx <= 125 && (mn <= 76 || mx >= 124), "gradient range {mn}..{mx}");
}

#[test]
fn bad_render_inputs_are_errors() {
    let cam = distorted_camera();
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let pose = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-100.0, -60.0, 500.0));
    let e = |o: RenderOptions| render_chessboard(&cam, &board, &pose, &o).unwrap_err().to_string();
    assert!(e(RenderOptions { blur_sigma: -1.0, ..Default::default() }).contains("blur_sigma"));
    // a blur of 1e6 px rendered for minutes (issue 51): refused at once, naming the bound
    let huge = e(RenderOptions { blur_sigma: 1e6, ..Default::default() });
    assert!(huge.contains("blur_sigma") && huge.contains("above 50 px"), "{huge}");
    assert!(e(RenderOptions { salt_fraction: 1.5, ..Default::default() }).contains("salt_fraction"));
    assert!(e(RenderOptions { noise_sigma: f64::NAN, ..Default::default() }).contains("noise_sigma"));
    assert!(e(RenderOptions { square_outline: 0.5, ..Default::default() }).contains("square_outline"));
    assert!(e(RenderOptions { defocus_radius: 31.0, ..Default::default() }).contains("defocus_radius"));
    assert!(e(RenderOptions { motion_blur: -1.0, ..Default::default() }).contains("motion_blur"));
    assert!(e(RenderOptions { motion_angle: f64::NAN, ..Default::default() }).contains("motion_angle"));
    assert!(e(RenderOptions { jpeg_quality: Some(0), ..Default::default() }).contains("jpeg_quality"));
    let no_radius = Glare { centre: DVec2::ZERO, radius: 0.0, strength: 10.0 };
    assert!(e(RenderOptions { glare: Some(no_radius), ..Default::default() }).contains("glare"));
    // Outlines only for targets with chessboard squares.
    let grid = parallax_camera_model::CircleGrid::new(4, 5, 20.0, 10.0, false).unwrap();
    let o = RenderOptions { square_outline: 0.1, ..Default::default() };
    let err = render_circle_grid(&cam, &grid, &pose, &o, &[], 2.0).unwrap_err().to_string();
    assert!(err.contains("square_outline") && err.contains("circle grid"), "{err}");
    let behind = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(0.0, 0.0, -500.0));
    assert!(render_chessboard(&cam, &board, &behind, &RenderOptions::default()).is_err());
    let nan = Isometry3::from_rvec_tvec(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::new(0.0, 0.0, 500.0));
    assert!(render_chessboard(&cam, &board, &nan, &RenderOptions::default()).is_err());
    let mut bad_cam = cam;
    bad_cam.width = 0;
    assert!(
        render_chessboard(&bad_cam, &board, &pose, &RenderOptions::default())
            .unwrap_err()
            .to_string()
            .contains("camera")
    );
}

#[test]
fn report_render_time_640x480() {
    let cam = distorted_camera();
    let board = Chessboard::new(9, 6, 25.0).unwrap();
    let pose = calibration_poses(&cam, &board, &ViewSetConfig { views: 1, ..Default::default() }).unwrap()[0];
    let o = RenderOptions { blur_sigma: 0.7, noise_sigma: 2.0, clutter: true, ..Default::default() };
    let _ = render_chessboard(&cam, &board, &pose, &o).unwrap();
    let t = Instant::now();
    let n = 5;
    for _ in 0..n {
        let _ = render_chessboard(&cam, &board, &pose, &o).unwrap();
    }
    println!(
        "render_chessboard 640x480 (distortion, clutter, blur, noise): {:.1} ms per view",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
}

/// Issue 49's hard-photo effects against independent computations: on a fronto-parallel board
/// with 20 px squares, the row through the middle of a square row crosses a vertical
/// black-to-white edge at u = 340.4 with no other edge within 9 px. Its rendered profile under
/// defocus (a disc of radius 3) and motion blur (6 px along u) equals the step integrated over
/// each pixel and the disc's or the segment's points (brute-force sums here) within 2 grey
/// levels; motion along v, parallel to the edge, leaves the row as it was. Glare adds
/// `strength · exp(−d²/2r²)`; a JPEG round trip changes the image by compression-sized amounts.
#[test]
fn hard_photo_effects_have_their_size() {
    let cam = Camera::new(Intrinsics::new(800.0, 800.0, 320.0, 240.0), Distortion::default(), 640, 480).unwrap();
    let board = Chessboard::new(7, 5, 25.0).unwrap();
    let pose = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(0.5, 0.5, 1000.0));
    let row = |o: &RenderOptions| {
        let img = render_chessboard(&cam, &board, &pose, o).unwrap().image;
        (334..348).map(|u| f64::from(img.get_pixel(u, 250).0[0])).collect::<Vec<f64>>()
    };
    // The step (square (0, 0) black left of the edge, (1, 0) white right of it), integrated over
    // each pixel (100 samples) and the kernel's points.
    let expected = |kernel: &[f64]| -> Vec<f64> {
        (334..348)
            .map(|u| {
                let mut sum = 0.0;
                for s in 0..100 {
                    let x = u as f64 - 0.5 + (s as f64 + 0.5) / 100.0;
                    sum += kernel.iter().map(|q| if x + q < 340.4 { 0.0 } else { 255.0 }).sum::<f64>()
                        / kernel.len() as f64;
                }
                sum / 100.0
            })
            .collect()
    };
    let close = |got: &[f64], want: &[f64], what: &str| {
        let worst = got.iter().zip(want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst <= 2.0, "{what}: worst {worst} grey levels\n got  {got:?}\n want {want:?}");
    };
    // The disc's points' u offsets (a 100x100 grid over the disc).
    let disc: Vec<f64> = (0..100 * 100)
        .map(|k| (-3.0 + 6.0 * ((k % 100) as f64 + 0.5) / 100.0, -3.0 + 6.0 * ((k / 100) as f64 + 0.5) / 100.0))
        .filter(|(x, y)| x * x + y * y <= 9.0)
        .map(|(x, _)| x)
        .collect();
    let sharp = row(&opts_bw());
    close(&sharp, &expected(&[0.0]), "no blur");
    close(&row(&RenderOptions { defocus_radius: 3.0, ..opts_bw() }), &expected(&disc), "defocus 3 px");
    let segment: Vec<f64> = (0..600).map(|k| 6.0 * ((k as f64 + 0.5) / 600.0 - 0.5)).collect();
    close(&row(&RenderOptions { motion_blur: 6.0, ..opts_bw() }), &expected(&segment), "motion 6 px along u");
    let along_v = RenderOptions { motion_blur: 6.0, motion_angle: std::f64::consts::FRAC_PI_2, ..opts_bw() };
    close(&row(&along_v), &sharp, "motion 6 px along v");

    // Glare on a flat background: 100 + 50·exp(−d²/(2·30²)) at distance d from its centre.
    let away = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(1e5, 0.0, 1000.0));
    let glare = Glare { centre: DVec2::new(300.0, 200.0), radius: 30.0, strength: 50.0 };
    let o = RenderOptions { background: 100, glare: Some(glare), ..Default::default() };
    let img = render_chessboard(&cam, &board, &away, &o).unwrap().image;
    for (u, v) in [(300u32, 200u32), (330, 200), (300, 260), (345, 245), (500, 400)] {
        let d2 = (f64::from(u) - 300.0).powi(2) + (f64::from(v) - 200.0).powi(2);
        let want = 100.0 + 50.0 * (-0.5 * d2 / 900.0).exp();
        let got = f64::from(img.get_pixel(u, v).0[0]);
        assert!((got - want).abs() <= 0.5 + 1e-9, "glare at ({u}, {v}): {got} vs {want}");
    }

    // JPEG: quality 30 moves pixels (mostly along the edges), quality 100 ten times less.
    let plain = render_chessboard(&cam, &board, &pose, &opts_bw()).unwrap().image;
    let mean_diff = |q: u8| {
        let j = render_chessboard(&cam, &board, &pose, &RenderOptions { jpeg_quality: Some(q), ..opts_bw() }).unwrap();
        let sum: f64 =
            j.image.as_raw().iter().zip(plain.as_raw()).map(|(a, b)| (f64::from(*a) - f64::from(*b)).abs()).sum();
        sum / plain.as_raw().len() as f64
    };
    let (low, high) = (mean_diff(30), mean_diff(100));
    assert!(low > 0.1 && low < 8.0 && high < 0.1 * low, "JPEG mean differences: q30 {low}, q100 {high}");
}
