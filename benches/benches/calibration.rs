//! Calibration speed: 14 views of a 9x6 board (756 corners), as OpenCV's `calibrateCamera`
//! (~18 ms on this machine for the real 14-view set), plus the 14-pair stereo calibration.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_planar_calibration::{CalibrationConfig, StereoConfig, calibrate_camera, calibrate_stereo};
use parallax_synthetic::{ViewSetConfig, add_pixel_noise, project_corners, rng, stereo_calibration_poses};

/// Object points and the left and right corners of every view.
type Views = (Vec<Vec<DVec3>>, Vec<Vec<DVec2>>, Vec<Vec<DVec2>>);

fn setup() -> Views {
    let left = Camera::new(
        Intrinsics::new(533.0, 533.0, 341.6, 234.3),
        Distortion::new(-0.28, 0.05, 0.001, 0.0, 0.1),
        640,
        480,
    )
    .unwrap();
    let right = Camera::new(
        Intrinsics::new(537.0, 536.6, 326.5, 249.3),
        Distortion::new(-0.29, 0.13, 0.0, 0.0, -0.04),
        640,
        480,
    )
    .unwrap();
    let rig = StereoRig::new(
        left,
        right,
        Isometry3::from_rvec_tvec(DVec3::new(0.0067, 0.0045, -0.0035), DVec3::new(-99.8, 1.12, 0.05)),
    )
    .unwrap();
    let board = Chessboard::new(9, 6, 30.0).unwrap();
    let cfg =
        ViewSetConfig { views: 14, seed: 5, min_distance: 350.0, max_distance: 600.0, ..ViewSetConfig::default() };
    let poses = stereo_calibration_poses(&rig, &board, &cfg).unwrap();
    let mut r = rng(6);
    let mut proj = |cam: &Camera, p: &Isometry3| {
        let mut c = project_corners(cam, &board, p).unwrap();
        add_pixel_noise(&mut c, 0.15, &mut r);
        c
    };
    let l: Vec<Vec<DVec2>> = poses.iter().map(|p| proj(&rig.left, p)).collect();
    let rr: Vec<Vec<DVec2>> = poses.iter().map(|p| proj(&rig.right, &(rig.right_from_left * *p))).collect();
    (vec![board.object_points(); poses.len()], l, rr)
}

fn bench(c: &mut Criterion) {
    let (object, left, right) = setup();
    let cfg = CalibrationConfig::default();
    c.bench_function("calibrate_camera 14 views x 54 corners", |b| {
        b.iter(|| calibrate_camera(&object, &left, 640, 480, &cfg).unwrap())
    });
    let scfg = StereoConfig::default();
    c.bench_function("calibrate_stereo 14 pairs x 54 corners", |b| {
        b.iter(|| calibrate_stereo(&object, &left, &right, (640, 480), (640, 480), &scfg).unwrap())
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
