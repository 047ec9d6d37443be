//! # planar-calibration — camera and stereo-rig calibration from planar targets
//!
//! * [`estimate_homography`]: plane ↔ image homography, normalised DLT + geometric refinement.
//! * Zhang's closed form: [`intrinsics_from_homographies`] (`V b = 0`, with or without skew),
//!   [`pose_from_homography`] (`K⁻¹H` + nearest rotation), [`radial_distortion_linear`].
//! * [`calibrate_camera`] / [`calibrate_chessboard`]: one camera of any lens
//!   ([`CalibrationConfig::lens`]: Brown–Conrady, Kannala–Brandt as OpenCV's `fisheye`, double
//!   sphere): a closed-form start (Zhang; for the wide lenses one that needs no focal-length
//!   guess), then Levenberg–Marquardt over intrinsics, lens parameters and every view pose
//!   (analytic Jacobians; `JᵀJ` accumulated block by block), with OpenCV's options, per-view and
//!   per-corner residuals, the standard deviation of every estimated parameter and warnings
//!   ([`CalibrationWarning`]).
//! * [`calibrate_rig`]: any number of cameras of any lens from frames in which any subset of
//!   them saw the target: closed-form starts, a pose graph over shared frames, one joint
//!   refinement (frame poses eliminated by the Schur complement) with the 1σ of every
//!   parameter, and checks that refuse what the data do not determine.
//! * [`calibrate_stereo`]: the two-camera rig in stereo terms: `right_from_left`, `E`, `F`.
//! * [`calibrate_target`] / [`calibrate_stereo_target`]: the same from identified points of any
//!   target (`TargetDescription` + per-view `TargetObservation`): partial ChArUco / AprilGrid
//!   views, stereo pairs matched by id; [`calibrate_rig_target`] for rigs.
//! * [`calibrate_dlt`]: `P` from a non-planar target, RQ into `K`, `R`, `t`.
//! * [`solve_pnp_planar`]: the pose of a calibrated camera from a planar target.
//!
//! Conventions are OpenCV's (see `camera-model`): distortion `(k1, k2, p1, p2, k3[, k4..k6])`
//! or the wide lens's parameters in its order,
//! RMS = `sqrt(Σ‖e‖²/N)` over corners, poses `camera_from_board` in board units.
//!
//! ```
//! use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3};
//! use glam::DVec3;
//! use parallax_planar_calibration::{calibrate_camera, CalibrationConfig};
//!
//! let truth = Camera::new(Intrinsics::new(600.0, 605.0, 318.0, 242.0),
//!                         Distortion::new(-0.2, 0.05, 0.0, 0.0, 0.0), 640, 480)?;
//! let board = Chessboard::new(9, 6, 30.0)?;
//! let rvecs = [(0.3, -0.2, 0.0), (-0.3, 0.25, 0.1), (0.1, 0.35, -0.1), (-0.25, -0.3, 0.05)];
//! let mut object = Vec::new();
//! let mut image = Vec::new();
//! for (i, r) in rvecs.iter().enumerate() {
//!     let rot = Isometry3::from_rvec_tvec(DVec3::new(r.0, r.1, r.2), DVec3::ZERO);
//!     let centre = rot.transform_vector(DVec3::new(120.0, 75.0, 0.0));
//!     let pose = Isometry3::from_rvec_tvec(DVec3::new(r.0, r.1, r.2),
//!                                          DVec3::new(0.0, 0.0, 550.0 + 30.0 * i as f64) - centre);
//!     object.push(board.object_points());
//!     image.push(board.object_points().iter().map(|p| truth.project_from(&pose, *p)).collect::<Result<Vec<_>, _>>()?);
//! }
//! let cfg = CalibrationConfig { fix_k3: true, zero_tangential: true, ..Default::default() };
//! let result = calibrate_camera(&object, &image, 640, 480, &cfg)?;
//! assert!(result.rms_px < 1e-6);
//! assert!((result.camera.intrinsics.fx - 600.0).abs() < 1e-4);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod bundle;
mod calibrate;
mod dlt;
mod error;
mod homography;
mod partial;
mod pnp;
mod rig;
mod stereo;
mod wide;
mod zhang;

// The crates whose types this crate's public API uses, re-exported so that a caller needs no
// version match with them (`parallax_x::glam::DVec3` is the `DVec3` this crate takes).
pub use glam;
pub use parallax_camera_model;
pub use parallax_least_squares;

pub use calibrate::{
    CalibrationConfig, CalibrationResult, CalibrationWarning, DistortionFold, IntrinsicStdDevs, PoseStdDevs,
    calibrate_camera, calibrate_chessboard, distortion_fold,
};
pub use dlt::{DltCalibration, calibrate_dlt, rq_decomposition};
pub use error::{CalibrationError, Result};
pub use homography::{Homography, estimate_homography, homography_dlt};
pub use partial::{calibrate_stereo_target, calibrate_target, common_points, object_points_for};
pub use pnp::{solve_pnp_planar, solve_pnp_planar_points};
pub use rig::{CameraView, RigCalibrationResult, RigConfig, calibrate_rig, calibrate_rig_target};
pub use stereo::{
    RigStdDevs, StereoCalibrationResult, StereoConfig, calibrate_stereo, calibrate_stereo_chessboard, median_rig,
};
pub use zhang::{
    focal_lengths_with_principal_point, intrinsics_from_homographies, pose_from_homography, radial_distortion_linear,
};
