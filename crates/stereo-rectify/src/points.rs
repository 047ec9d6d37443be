//! Rectifying individual pixels (detected corners, matches) without resampling images.

use glam::{DMat3, DVec2};
use parallax_camera_model::{CameraModel, ProjectionMatrix};

use crate::{RectifyError, Result};

/// Rectifies pixels of one camera of any lens (or any [`CameraModel`]): converged unprojection
/// (`Camera::unproject`: Newton to `parallax_camera_model::UNDISTORT_TOLERANCE` for
/// Brown–Conrady, to `FISHEYE_UNPROJECT_TOLERANCE` for Kannala–Brandt), rotation by `r` (`R1` or `R2`), projection with the
/// left 3x3 block of `p` (`P1` or `P2`). Same convention as OpenCV's `undistortPoints(pts, K,
/// D, R, P)`: the last column of `P` (the baseline term) is not applied, so left and right
/// pixels of one scene point share their row and differ by the disparity (OpenCV iterates only
/// 5 times; this converges). Errors name the first pixel that cannot be undistorted or turns
/// behind the rectified camera.
pub fn rectify_points<C: CameraModel>(
    camera: &C,
    r: DMat3,
    p: &ProjectionMatrix,
    pixels: &[DVec2],
) -> Result<Vec<DVec2>> {
    camera.validate().map_err(|source| RectifyError::Camera { what: "camera of the points", source })?;
    if !r.is_finite() {
        return Err(RectifyError::NonFinite("rectifying rotation"));
    }
    let kr = p.left_block() * r;
    if !kr.is_finite() {
        return Err(RectifyError::NonFinite("projection matrix"));
    }
    crate::wide::map_points(camera, pixels, |ray| {
        let h = kr * ray;
        if h.z.is_nan() || h.z <= 0.0 {
            return Err("it lies behind the rectified camera");
        }
        let out = DVec2::new(h.x / h.z, h.y / h.z);
        if !out.is_finite() {
            return Err("non-finite rectified position");
        }
        Ok(out)
    })
}
