//! Temporary timing.
use camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
use glam::DVec3;
use image::{GrayImage, Luma};
use std::time::Instant;
use stereo_rectify::{Border, RectifyConfig, Rectifier, init_undistort_rectify_map, stereo_rectify};

fn main() {
    let left = Camera::new(Intrinsics::new(536.32, 536.32, 341.84, 235.60), Distortion::new(-0.2714, 0.0128, 0.00171, -0.00045, 0.1330), 640, 480).unwrap();
    let right = Camera::new(Intrinsics::new(541.44, 540.84, 327.67, 247.72), Distortion::new(-0.2822, 0.1084, -0.00061, 0.00091, -0.0253), 640, 480).unwrap();
    let rig = StereoRig::new(left, right, Isometry3::from_rvec_tvec(DVec3::new(0.00481, 0.00343, -0.00378), DVec3::new(-100.120, 1.161, 0.074))).unwrap();
    let rect = stereo_rectify(&rig, &RectifyConfig { alpha: Some(0.0), ..Default::default() }).unwrap();
    let rectifier = Rectifier::from_rectification(&rig, rect).unwrap();
    let l = image::open("/work/shared/data/opencv-stereo-chessboard/left01.jpg").unwrap().into_luma8();
    let r: GrayImage = image::open("/work/shared/data/opencv-stereo-chessboard/right01.jpg").unwrap().into_luma8();
    for _ in 0..3 {
        let mut tm = vec![];
        let mut tr = vec![];
        for _ in 0..30 {
            let t = Instant::now();
            let m = init_undistort_rectify_map(&rig.left, rect.r1, rect.left_camera_matrix(), 640, 480).unwrap();
            tm.push(t.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(m);
            let t = Instant::now();
            let out = rectifier.rectify_pair(&l, &r, Border::Constant(Luma([0]))).unwrap();
            tr.push(t.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(out);
        }
        tm.sort_by(f64::total_cmp);
        tr.sort_by(f64::total_cmp);
        println!("map median {:.3} ms (min {:.3}); remap pair median {:.3} ms (min {:.3})", tm[15], tm[0], tr[15], tr[0]);
    }
}
