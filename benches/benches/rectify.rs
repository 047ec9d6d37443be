//! Stereo rectification speed (issue 6): building the undistort + rectify maps and remapping a
//! 640x480 pair, to compare side by side with OpenCV's `initUndistortRectifyMap` and `remap` of
//! both images (`../shared/reference/peer/calib_stereo.py`; measured beside this bench on the
//! development machine: OpenCV 0.94 ms per 32F map and 0.40 ms per remapped pair, here 0.39 and
//! 0.23 ms).
//! The rig is OpenCV's joint calibration of `opencv-stereo-chessboard`; the images are its
//! first pair when present, else seeded noise.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use image::{GrayImage, Luma};
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_stereo_rectify::{
    Border, Interpolation, Rectifier, RectifyConfig, init_undistort_rectify_map, stereo_rectify,
};
use rand::{Rng, SeedableRng};
use std::hint::black_box;

fn rig() -> StereoRig {
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
    StereoRig::new(left, right, pose).expect("rig")
}

fn images() -> (GrayImage, GrayImage) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/opencv-stereo-chessboard/");
    match (image::open(format!("{dir}left01.jpg")), image::open(format!("{dir}right01.jpg"))) {
        (Ok(l), Ok(r)) => (l.into_luma8(), r.into_luma8()),
        _ => {
            eprintln!("rectify bench: ../shared not found, using noise images");
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
            let mut img = || GrayImage::from_fn(640, 480, |_, _| Luma([rng.random()]));
            (img(), img())
        }
    }
}

fn bench(c: &mut Criterion) {
    let rig = rig();
    let config = RectifyConfig { alpha: Some(0.0), ..Default::default() };
    let rect = stereo_rectify(&rig, &config).expect("rectify");
    let (left, right) = images();
    let rectifier = Rectifier::from_rectification(&rig, rect).expect("maps");

    let mut g = c.benchmark_group("rectify");
    g.bench_function("stereo_rectify", |b| b.iter(|| stereo_rectify(black_box(&rig), &config).expect("rectify")));
    g.bench_function("map_one_camera_640x480", |b| {
        b.iter(|| {
            init_undistort_rectify_map(black_box(&rig.left), rect.r1, rect.left_camera_matrix(), 640, 480).expect("map")
        })
    });
    g.bench_function("rectifier_new_both_maps", |b| b.iter(|| Rectifier::new(black_box(&rig), &config).expect("maps")));
    let border = Border::Constant(Luma([0u8]));
    g.bench_function("remap_pair_640x480_bilinear", |b| {
        b.iter(|| rectifier.rectify_pair(black_box(&left), black_box(&right), border).expect("remap"))
    });
    let nearest = rectifier.clone().with_interpolation(Interpolation::Nearest);
    g.bench_function("remap_pair_640x480_nearest", |b| {
        b.iter(|| nearest.rectify_pair(black_box(&left), black_box(&right), border).expect("remap"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
