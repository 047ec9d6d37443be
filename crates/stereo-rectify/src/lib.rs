//! # stereo-rectify — row-aligned stereo pairs
//!
//! * [`stereo_rectify`]: one entry point for a rig of any lenses. Brown–Conrady rigs: Bouguet's
//!   calibrated rectification, formula for formula OpenCV's `stereoRectify` (`R1`, `R2`, `P1`,
//!   `P2`, `Q`, valid-pixel rectangles, `alpha`, new image size, `CALIB_ZERO_DISPARITY`,
//!   vertical rigs); with the default [`ExtentMethod::OpenCv`] the matrices agree with OpenCV
//!   5.0 to ~1e-9 (checked against OpenCV's output in the tests). Rigs with a wide lens
//!   (Kannala–Brandt, double sphere): OpenCV's `fisheye::stereoRectify` rule (`balance`,
//!   `fov_scale`) to a pinhole pair.
//! * [`init_undistort_rectify_map`], [`init_undistort_map`], [`init_homography_map`]: per-pixel
//!   lookup tables ([`RemapTable`], `f32`, as `initUndistortRectifyMap` and
//!   `fisheye::initUndistortRectifyMap`), built row-parallel, for any lens.
//! * [`remap`]: bilinear or nearest resampling with constant or replicated border, for any
//!   `image` pixel with `u8` / `u16` channels (`Luma<u8>`, `Luma<u16>`, `Rgb<u8>`), rayon rows.
//! * [`Rectifier`]: build once (rectification + both fixed-point tables; the `f32` maps on
//!   first use), then [`Rectifier::rectify_pair`];
//!   [`Rectifier::rebuild`] re-rectifies a changed rig into the same tables (no allocation).
//! * [`rectify_points`]: undistort → rotate → project single pixels (detected corners), no
//!   image resampling.
//! * [`stereo_rectify_uncalibrated`]: Hartley's rectification from a fundamental matrix and
//!   matches (OpenCV's `stereoRectifyUncalibrated`).
//!
//! * Wide-angle views: [`estimate_new_camera_matrix_for_undistort_rectify`] (OpenCV's
//!   `fisheye::` function, number for number where OpenCV's undistortion converges), and
//!   [`WideView`] / [`wide_rectify`] to an equirectangular or cylindrical view whose rows are
//!   epipolar planes, for fields of view a pinhole cannot hold.
//!
//! Frames and names follow `camera-model`: the rig's `right_from_left` is OpenCV's `(R, T)`;
//! `r1` maps the left camera frame to the rectified left frame.
//!
//! ```
//! use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
//! use glam::{DVec2, DVec3};
//! use parallax_stereo_rectify::{rectify_points, stereo_rectify, RectifyConfig};
//!
//! let camera = |fx: f64, cx: f64| {
//!     Camera::new(Intrinsics::new(fx, fx, cx, 240.0), Distortion::new(-0.2, 0.05, 0.0, 0.0, 0.0), 640, 480)
//! };
//! let rig = StereoRig::new(
//!     camera(540.0, 330.0)?,
//!     camera(545.0, 318.0)?,
//!     Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.02, 0.005), DVec3::new(-100.0, 2.0, 1.0)),
//! )?;
//! let rect = stereo_rectify(&rig, &RectifyConfig { alpha: Some(0.0), ..Default::default() })?;
//!
//! // A scene point seen by both cameras lands on the same rectified row.
//! let x_left = DVec3::new(40.0, -30.0, 900.0);
//! let pl = rig.left.project(x_left)?;
//! let pr = rig.right.project(rig.right_from_left.transform_point(x_left))?;
//! let l = rectify_points(&rig.left, rect.r1, &rect.p1, &[pl])?[0];
//! let r = rectify_points(&rig.right, rect.r2, &rect.p2, &[pr])?[0];
//! assert!((l.y - r.y).abs() < 1e-6);
//! // and Q turns its disparity back into the point (rectified left frame).
//! let x = rect.reproject(l, l.x - r.x).unwrap();
//! assert!((x - rect.r1 * x_left).length() < 1e-6 * x_left.length());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod bouguet;
mod error;
mod hartley;
mod maps;
mod opencv_compat;
mod points;
mod rectifier;
mod remap;
mod wide;

// The crates whose types this crate's public API uses, re-exported so that a caller needs no
// version match with them (`parallax_x::glam::DVec3` is the `DVec3` this crate takes).
pub use glam;
pub use image;
pub use parallax_camera_model;
pub use parallax_least_squares;

pub use bouguet::{ExtentMethod, Rectification, RectifyConfig, Roi, stereo_rectify};
pub use error::{RectifyError, Result};
pub use hartley::{UncalibratedRectification, stereo_rectify_uncalibrated};
pub use maps::{RemapTable, init_homography_map, init_undistort_map, init_undistort_rectify_map};
pub use points::rectify_points;
pub use rectifier::Rectifier;
pub use remap::{Border, Image, Interpolation, Sample, remap};
pub use wide::{
    WideProjection, WideRectification, WideView, estimate_new_camera_matrix_for_undistort_rectify, init_wide_view_map,
    rectify_points_wide, rectifying_rotations, wide_rectify,
};
