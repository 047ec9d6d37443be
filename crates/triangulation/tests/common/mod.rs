//! Test fixtures: synthetic rigs in millimetres, projection of true points, seeded noise.
#![allow(dead_code)]

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

pub const FOCAL: f64 = 800.0;
pub const BASELINE: f64 = 100.0;

/// An ideal rectified rig: f = 800 px, 1280x960, baseline 100 mm, no distortion.
pub fn rectified_rig() -> StereoRig {
    let cam = Camera::new(Intrinsics::new(FOCAL, FOCAL, 640.0, 480.0), Distortion::default(), 1280, 960).unwrap();
    StereoRig::new(cam, cam, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-BASELINE, 0.0, 0.0))).unwrap()
}

/// A general rig: f ≈ 800 px, different intrinsics per camera, Brown–Conrady distortion,
/// 3° vergence plus small tilts, baseline ≈ 100 mm.
pub fn general_rig() -> StereoRig {
    let left = Camera::new(
        Intrinsics::new(800.0, 801.0, 645.0, 475.0),
        Distortion::new(-0.12, 0.05, 0.0008, -0.0005, -0.01),
        1280,
        960,
    )
    .unwrap();
    let right = Camera::new(
        Intrinsics::new(805.0, 804.0, 632.0, 486.0),
        Distortion::new(-0.10, 0.03, -0.0004, 0.0006, 0.0),
        1280,
        960,
    )
    .unwrap();
    let right_from_left =
        Isometry3::from_rvec_tvec(DVec3::new(0.004, -3f64.to_radians(), 0.002), DVec3::new(-99.8, 1.2, 0.5));
    StereoRig::new(left, right, right_from_left).unwrap()
}

/// Raw (distorted) pixels of a left-frame point in both cameras.
pub fn project_pair(rig: &StereoRig, p: DVec3) -> (DVec2, DVec2) {
    let l = rig.left.project(p).unwrap();
    let r = rig.right.project(rig.right_from_left.transform_point(p)).unwrap();
    (l, r)
}

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// A point at depth `z` (mm) seen by both cameras of the rigs above: lateral position drawn
/// inside the overlapping field of view (|x| ≤ 0.25 z around the rig's middle, |y| ≤ 0.25 z).
pub fn random_point(rng: &mut ChaCha8Rng, z: f64) -> DVec3 {
    use rand::Rng;
    let x = rng.random_range(-0.25..0.25) * z + 50.0;
    let y = rng.random_range(-0.25..0.25) * z;
    DVec3::new(x, y, z)
}

pub fn add_noise(p: DVec2, sigma: f64, rng: &mut ChaCha8Rng) -> DVec2 {
    let n = Normal::new(0.0, sigma).unwrap();
    DVec2::new(p.x + n.sample(rng), p.y + n.sample(rng))
}
