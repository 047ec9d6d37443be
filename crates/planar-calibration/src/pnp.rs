//! Pose of a known camera from a planar target: homography on undistorted points, then
//! Levenberg–Marquardt on the reprojection error (the pose-only bundle).

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, Intrinsics, Isometry3};
use parallax_least_squares::{LmConfig, levenberg_marquardt};

use crate::bundle::{Bundle, CameraModelSlots, N_INTR, Slot, ViewObs, pose_at, store_pose, theta_of};
use crate::calibrate::rms_of;
use crate::homography::estimate_homography_named;
use crate::zhang::pose_from_homography;
use crate::{CalibrationError, Result};

/// Closed-form pose: undistort the pixels (falling back to the raw pixels if the lens model
/// cannot be inverted there), fit the plane → normalised-image homography, decompose with `K = I`.
pub(crate) fn initial_pose(camera: &Camera, object: &[DVec3], image: &[DVec2], what: &str) -> Result<Isometry3> {
    let plane: Vec<DVec2> = object.iter().map(|p| p.truncate()).collect();
    let normalized: Option<Vec<DVec2>> =
        image.iter().map(|q| camera.unproject(*q).ok().map(|r| r.truncate())).collect();
    let (pts, k) = match normalized {
        Some(n) => (n, Intrinsics::new(1.0, 1.0, 0.0, 0.0)),
        None => (image.to_vec(), camera.intrinsics),
    };
    let h = estimate_homography_named(&plane, &pts, what)?;
    pose_from_homography(&k, &h.matrix)
}

/// Pose of a calibrated camera from a planar target: `object` on the plane `z = 0` (board
/// units), `image` the observed pixels. Returns `camera_from_board` and the RMS reprojection
/// error in pixels. Needs ≥ 4 non-collinear points.
pub fn solve_pnp_planar_points(camera: &Camera, object: &[DVec3], image: &[DVec2]) -> Result<(Isometry3, f64)> {
    camera.validate()?;
    crate::calibrate::validate_views(&[object.to_vec()], &[image.to_vec()], "pose")?;
    if camera.lens_model().is_wide() {
        return crate::wide::solve_pnp_wide(camera, object, image);
    }
    let init = initial_pose(camera, object, image, "pose")?;
    let theta = theta_of(camera);
    let slots = CameraModelSlots {
        slots: std::array::from_fn::<Slot, N_INTR, _>(|i| Slot::Fixed(theta[i])),
        num_free: 0,
        width: camera.width,
        height: camera.height,
    };
    let bundle = Bundle::new(vec![slots], vec![ViewObs::mono(object, image)]);
    let mut x0 = vec![0.0; 6];
    store_pose(&init, &mut x0);
    let cfg = LmConfig { max_iterations: 50, covariance: false, cost_tolerance: 1e-14, ..LmConfig::default() };
    let report = levenberg_marquardt(&bundle, &x0, &cfg)?;
    let pose = pose_at(&report.params);
    let residuals = bundle.residuals_by_view(&report.params).map_err(|e| CalibrationError::EstimationFailed(e.0))?;
    Ok((pose, rms_of(&residuals[0][0])))
}

/// [`solve_pnp_planar_points`] for a chessboard: `corners` in OpenCV order (row-major, `cols`
/// per row), as many as the board has inner corners.
///
/// ```
/// use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3};
/// use glam::DVec3;
/// let camera = Camera::new(Intrinsics::new(600.0, 600.0, 320.0, 240.0), Distortion::new(-0.1, 0.0, 0.0, 0.0, 0.0), 640, 480)?;
/// let board = Chessboard::new(9, 6, 30.0)?;
/// let truth = Isometry3::from_rvec_tvec(DVec3::new(0.2, -0.1, 0.05), DVec3::new(-120.0, -80.0, 600.0));
/// let corners: Vec<_> = board.object_points().iter().map(|p| camera.project_from(&truth, *p).unwrap()).collect();
/// let (pose, rms) = parallax_planar_calibration::solve_pnp_planar(&camera, &board, &corners)?;
/// assert!(rms < 1e-8 && pose.distance(&truth).1 < 1e-6);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn solve_pnp_planar(camera: &Camera, board: &Chessboard, corners: &[DVec2]) -> Result<(Isometry3, f64)> {
    board.validate()?;
    if corners.len() != board.len() {
        return Err(CalibrationError::SizeMismatch(format!(
            "pose: {} corners for a {}x{} board",
            corners.len(),
            board.cols,
            board.rows
        )));
    }
    solve_pnp_planar_points(camera, &board.object_points(), corners)
}
