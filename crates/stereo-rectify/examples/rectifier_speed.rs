//! Prints the median time of `Rectifier::new` (rectification and both fixed-point tables, 640x480,
//! OpenCV's stereo chessboard rig) over `N` builds (argument, default 50), and of
//! `Rectifier::rebuild` into the same rectifier (tables reused), and of `rectify_pair` on two
//! 8-bit grey images, for side-by-side runs with OpenCV's `initUndistortRectifyMap` and `remap`
//! (`benches/scripts/rectifier_vs_opencv.py`).

use glam::DVec3;
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_stereo_rectify::{Rectifier, RectifyConfig};

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(50);
    let left = Camera::new(
        Intrinsics::new(536.32, 536.32, 341.84, 235.60),
        Distortion::new(-0.2714, 0.0128, 0.00171, -0.00045, 0.1330),
        640,
        480,
    )
    .expect("left camera");
    let right = Camera::new(
        Intrinsics::new(541.44, 540.84, 327.67, 247.72),
        Distortion::new(-0.2822, 0.1084, -0.00061, 0.00091, -0.0253),
        640,
        480,
    )
    .expect("right camera");
    let pose = Isometry3::from_rvec_tvec(DVec3::new(0.00481, 0.00343, -0.00378), DVec3::new(-100.120, 1.161, 0.074));
    let rig = StereoRig::new(left, right, pose).expect("rig");
    let config = RectifyConfig { alpha: Some(0.0), ..Default::default() };
    let mut times = Vec::with_capacity(n);
    for _ in 0..n {
        let t = std::time::Instant::now();
        let r = Rectifier::new(&rig, &config).expect("maps");
        times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(r);
    }
    times.sort_by(f64::total_cmp);
    println!("new: {:.6}", times[n / 2]);
    let mut r = Rectifier::new(&rig, &config).expect("maps");
    let mut times = Vec::with_capacity(n);
    for _ in 0..n {
        let t = std::time::Instant::now();
        r.rebuild(&rig, &config).expect("maps");
        times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(&r);
    }
    times.sort_by(f64::total_cmp);
    println!("rebuild: {:.6}", times[n / 2]);
    // resampling a pair of 8-bit grey images (bilinear, constant border), the per-frame cost
    let texture = |u: u32, v: u32| image::Luma([((u.wrapping_mul(2654435761) ^ v.wrapping_mul(40503)) >> 9) as u8]);
    let left = image::GrayImage::from_fn(640, 480, texture);
    let right = image::GrayImage::from_fn(640, 480, |u, v| texture(u + 7, v));
    let border = parallax_stereo_rectify::Border::Constant(image::Luma([0u8]));
    let mut times = Vec::with_capacity(n);
    for _ in 0..n {
        let t = std::time::Instant::now();
        std::hint::black_box(r.rectify_pair(&left, &right, border).expect("remap"));
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    println!("remap_pair: {:.6}", times[n / 2]);
}
