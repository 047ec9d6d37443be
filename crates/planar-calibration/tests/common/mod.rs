//! Shared fixtures of the integration tests: generated here, except `rig_json`, which reads
//! the committed rig point sets OpenCV made (`tests/data/rig/`, with their generator).
#![allow(dead_code)]

pub mod rig_json;

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3};
use parallax_synthetic::{ViewSetConfig, add_pixel_noise, calibration_poses, project_corners, rng};

/// The synthetic camera: 640x480, k1 = −0.3, k2 = 0.1.
pub fn truth_camera() -> Camera {
    Camera::new(Intrinsics::new(520.0, 523.0, 322.5, 236.0), Distortion::new(-0.3, 0.1, 0.0, 0.0, 0.0), 640, 480)
        .unwrap()
}

pub fn board() -> Chessboard {
    Chessboard::new(9, 6, 30.0).unwrap()
}

/// `views` seeded views with every corner visible, corners with N(0, σ²) noise per coordinate.
pub fn noisy_views(
    camera: &Camera,
    board: &Chessboard,
    views: usize,
    sigma: f64,
    seed: u64,
) -> (Vec<Isometry3>, Vec<Vec<DVec3>>, Vec<Vec<DVec2>>) {
    let poses = tilted_poses(camera, board, views, seed);
    let mut r = rng(seed ^ 0x5eed);
    let image: Vec<Vec<DVec2>> = poses
        .iter()
        .map(|p| {
            let mut c = project_corners(camera, board, p).unwrap();
            add_pixel_noise(&mut c, sigma, &mut r);
            c
        })
        .collect();
    (poses, vec![board.object_points(); views], image)
}

/// Hand-made poses: the board centre `centre` (board units) placed at `(x, y, z)` in the
/// camera frame after rotating by `rvec`.
pub fn pose_looking_at(rvec: DVec3, centre: DVec3, at: DVec3) -> Isometry3 {
    let rot = Isometry3::from_rvec_tvec(rvec, DVec3::ZERO);
    Isometry3::from_rvec_tvec(rvec, at - rot.transform_vector(centre))
}

/// Calibration-style poses with every view clearly tilted (25°–55° about a random in-plane
/// axis, roll ±20°), distance 280–480 board units, every corner ≥ 10 px inside the image.
pub fn tilted_poses(camera: &Camera, board: &Chessboard, views: usize, seed: u64) -> Vec<Isometry3> {
    use rand::Rng;
    let mut r = rng(seed);
    let centre = DVec3::new(
        (board.cols - 1) as f64 * board.square_size * 0.5,
        (board.rows - 1) as f64 * board.square_size * 0.5,
        0.0,
    );
    let mut out = Vec::new();
    while out.len() < views {
        let tilt = r.random_range(25f64..55.0).to_radians();
        let axis_angle = r.random_range(0.0..std::f64::consts::TAU);
        let roll = r.random_range(-20f64..20.0).to_radians();
        let axis = DVec3::new(axis_angle.cos(), axis_angle.sin(), 0.0);
        let rot = glam::DQuat::from_axis_angle(axis, tilt) * glam::DQuat::from_rotation_z(roll);
        let z = r.random_range(280.0..480.0);
        let x = r.random_range(-0.25..0.25) * z;
        let y = r.random_range(-0.2..0.2) * z;
        let rot_iso = Isometry3::from_quat_translation(rot, DVec3::ZERO);
        let pose = Isometry3::from_quat_translation(rot, DVec3::new(x, y, z) - rot_iso.transform_vector(centre));
        let ok = board.object_points().iter().all(|p| {
            camera.project_from(&pose, *p).is_ok_and(|q| {
                q.x > 10.0 && q.y > 10.0 && q.x < camera.width as f64 - 10.0 && q.y < camera.height as f64 - 10.0
            })
        });
        if ok {
            out.push(pose);
        }
    }
    out
}

/// Seeded views from the `synthetic` crate's generator (default spread).
pub fn synthetic_views(camera: &Camera, board: &Chessboard, views: usize, seed: u64) -> Vec<Isometry3> {
    calibration_poses(camera, board, &ViewSetConfig { views, seed, ..ViewSetConfig::default() }).unwrap()
}
