//! Fixtures shared by the integration tests: a distorted rig and board views with true corners.
#![allow(dead_code)]

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3, StereoRig};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A horizontal rig with OpenCV-like strong distortion, a small vertical offset (2 mm on a
/// 100 mm baseline) and a small relative rotation (≈ 1.4°). Lengths in mm.
pub fn horizontal_rig() -> StereoRig {
    let left = Camera::new(
        Intrinsics::new(536.3, 536.9, 341.8, 235.6),
        Distortion::new(-0.2714, 0.0128, 0.00171, -0.00045, 0.1330),
        640,
        480,
    )
    .unwrap();
    let right = Camera::new(
        Intrinsics::new(541.4, 540.8, 327.7, 247.7),
        Distortion::new(-0.2822, 0.1084, -0.00061, 0.00091, -0.0253),
        640,
        480,
    )
    .unwrap();
    StereoRig::new(
        left,
        right,
        Isometry3::from_rvec_tvec(DVec3::new(0.012, -0.018, 0.009), DVec3::new(-100.0, 2.0, 1.5)),
    )
    .unwrap()
}

/// A vertical rig (right camera 80 mm below the left one), moderate distortion.
pub fn vertical_rig() -> StereoRig {
    let cam = |fx: f64, cx: f64, k1: f64| {
        Camera::new(
            Intrinsics::new(fx, fx * 1.001, cx, 241.0),
            Distortion::new(k1, 0.03, 0.0005, -0.0004, 0.0),
            640,
            480,
        )
        .unwrap()
    };
    StereoRig::new(
        cam(600.0, 322.0, -0.15),
        cam(604.0, 317.0, -0.12),
        Isometry3::from_rvec_tvec(DVec3::new(-0.01, 0.015, -0.02), DVec3::new(1.5, -80.0, 2.0)),
    )
    .unwrap()
}

/// The 9x6 board of the OpenCV sample set, 30 mm squares.
pub fn board() -> Chessboard {
    Chessboard::new(9, 6, 30.0).unwrap()
}

/// Seeded board poses (`left_camera_from_board`) 450–900 mm away, tilted up to ~35°, with
/// every corner inside both images (5 px margin). Returns the true corners of each view.
pub fn board_views(rig: &StereoRig, views: usize, seed: u64) -> Vec<(Vec<DVec2>, Vec<DVec2>)> {
    let board = board();
    let points = board.object_points();
    let centre = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    let mut attempts = 0;
    while out.len() < views {
        attempts += 1;
        assert!(attempts < 100_000, "could not place {views} board views");
        let z = rng.random_range(450.0..900.0);
        let rvec = DVec3::new(rng.random_range(-0.6..0.6), rng.random_range(-0.6..0.6), rng.random_range(-0.5..0.5));
        // Board centre somewhere in the overlap of both fields of view.
        let target = DVec3::new(rng.random_range(-0.35..0.25) * z, rng.random_range(-0.3..0.3) * z, z);
        let rot = Isometry3::from_rvec_tvec(rvec, DVec3::ZERO);
        let pose = Isometry3::from_rvec_tvec(rvec, target - rot.transform_point(centre));
        let mut left = Vec::new();
        let mut right = Vec::new();
        let mut ok = true;
        for p in &points {
            let xl = pose.transform_point(*p);
            let xr = rig.right_from_left.transform_point(xl);
            match (rig.left.project(xl), rig.right.project(xr)) {
                (Ok(a), Ok(b)) if inside(&rig.left, a) && inside(&rig.right, b) => {
                    left.push(a);
                    right.push(b);
                }
                _ => {
                    ok = false;
                    break;
                }
            }
        }
        if ok {
            out.push((left, right));
        }
    }
    out
}

fn inside(camera: &Camera, p: DVec2) -> bool {
    p.x >= 5.0 && p.y >= 5.0 && p.x <= camera.width as f64 - 6.0 && p.y <= camera.height as f64 - 6.0
}

/// Random points in front of both cameras (left frame), depth 300–3000 mm.
pub fn scene_points(n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let z = rng.random_range(300.0..3000.0);
            DVec3::new(rng.random_range(-0.4..0.4) * z, rng.random_range(-0.3..0.3) * z, z)
        })
        .collect()
}
