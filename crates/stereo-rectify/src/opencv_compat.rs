//! OpenCV's approximate point undistortion and its `f32` rounding, reproduced so that
//! [`crate::ExtentMethod::OpenCv`] gives OpenCV's `P1`, `P2`, `Q` and rectangles number for number.

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::Camera;

/// Iterations of OpenCV's `undistortPoints` default criterion (`TermCriteria(COUNT, 5, 0.01)`).
pub(crate) const OPENCV_UNDISTORT_ITERATIONS: usize = 5;

/// OpenCV's `undistortPoints` without `R`/`P`: the fixed-point iteration
/// `x ← (x0 − Δ(x)) / radial(x)` run [`OPENCV_UNDISTORT_ITERATIONS`] times (not converged on
/// strong distortion: that is the point of reproducing it). Returns normalised coordinates.
pub(crate) fn undistort_point(camera: &Camera, pixel: DVec2) -> DVec2 {
    let k = &camera.intrinsics;
    // (Bouguet runs on Brown–Conrady rigs only: `stereo_rectify` sends wide lenses elsewhere)
    let d = camera.distortion().map_or([0.0; 8], |d| d.to_array());
    let (ifx, ify) = (1.0 / k.fx, 1.0 / k.fy);
    let x0 = (pixel.x - k.cx) * ifx;
    let y0 = (pixel.y - k.cy) * ify;
    let (mut x, mut y) = (x0, y0);
    for _ in 0..OPENCV_UNDISTORT_ITERATIONS {
        let r2 = x * x + y * y;
        let icdist = (1.0 + ((d[7] * r2 + d[6]) * r2 + d[5]) * r2) / (1.0 + ((d[4] * r2 + d[1]) * r2 + d[0]) * r2);
        if icdist < 0.0 {
            return DVec2::new(x0, y0);
        }
        let dx = 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x);
        let dy = d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y;
        x = (x0 - dx) * icdist;
        y = (y0 - dy) * icdist;
    }
    DVec2::new(x, y)
}

/// Step 4 of `cv::stereoRectify`: the mean of the four image corners (stored as `f32`),
/// undistorted (`f32`), rotated by `r` and projected with focal `fc` and no principal point
/// (`f32`).
pub(crate) fn mean_rotated_corners(camera: &Camera, r: DMat3, fc: f64) -> DVec2 {
    let (nx, ny) = (camera.width as f64, camera.height as f64);
    let mut sum = DVec2::ZERO;
    for i in 0..4 {
        let j = if i < 2 { 0.0 } else { 1.0 };
        let corner = DVec2::new(f32r((i % 2) as f64 * (nx - 1.0)), f32r(j * (ny - 1.0)));
        let n = undistort_point(camera, corner);
        let p = r * DVec3::new(f32r(n.x), f32r(n.y), 1.0);
        let iz = if p.z != 0.0 { 1.0 / p.z } else { 1.0 };
        sum += DVec2::new(f32r(fc * (p.x * iz)), f32r(fc * (p.y * iz)));
    }
    sum * 0.25
}

#[inline]
fn f32r(v: f64) -> f64 {
    v as f32 as f64
}
