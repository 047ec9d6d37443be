//! Stereo calibration: the two-camera case of [`crate::calibrate_rig`], in stereo terms
//! (`right_from_left`, `E`, `F`, left/right figures).

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Chessboard, CornerGrid, Isometry3, StereoRig};
use parallax_least_squares::LmConfig;
use serde::{Deserialize, Serialize};

use crate::calibrate::{CalibrationConfig, CalibrationWarning, IntrinsicStdDevs, board_views, median, validate_views};
use crate::rig::{CameraView, RigConfig, calibrate_rig};
use crate::{CalibrationError, Result};

/// Options of [`calibrate_stereo`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StereoConfig {
    /// Hold both cameras' intrinsics and distortion (OpenCV's `CALIB_FIX_INTRINSIC`): at the
    /// `intrinsic_guess` of `left`/`right` if given, else at their mono calibrations. When
    /// false (the default) both cameras are refined jointly with the rig, with the flags of
    /// `left` and `right`.
    pub fix_intrinsics: bool,
    /// Flags (and optional guess) for the left camera.
    pub left: CalibrationConfig,
    /// Flags (and optional guess) for the right camera.
    pub right: CalibrationConfig,
    /// Levenberg–Marquardt settings of the joint refinement.
    pub lm: LmConfig,
}

impl Default for StereoConfig {
    fn default() -> Self {
        let left = CalibrationConfig::default();
        Self { fix_intrinsics: false, lm: left.lm, right: left.clone(), left }
    }
}

/// 1σ of the rig parameters.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RigStdDevs {
    /// Rotation of `right_from_left` as a left perturbation (radians, right-camera axes).
    pub rotation_rad: DVec3,
    /// Translation components of `right_from_left` (board units).
    pub translation: DVec3,
    /// Baseline length `|t|` (board units).
    pub baseline: f64,
    /// Magnitude of the rotation's error, `√(σ²_ωx + σ²_ωy + σ²_ωz)` (radians).
    #[serde(default)]
    pub angle_rad: f64,
}

/// The result of [`calibrate_stereo`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StereoCalibrationResult {
    /// Both cameras and `right_from_left`.
    pub rig: StereoRig,
    /// Per-view left `camera_from_board` (the right one is `right_from_left ∘ this`).
    pub camera_from_board: Vec<Isometry3>,
    /// RMS reprojection error over all corners of both cameras, pixels.
    pub rms_px: f64,
    /// RMS over the left camera's corners, pixels.
    pub left_rms_px: f64,
    /// RMS over the right camera's corners, pixels.
    pub right_rms_px: f64,
    /// Per view `[left, right]` RMS, pixels.
    pub per_view_rms_px: Vec<[f64; 2]>,
    /// Per view `[left, right]`, per corner: observed − projected, pixels.
    pub residuals_px: Vec<[Vec<DVec2>; 2]>,
    /// 1σ of the left intrinsics (`None` = held fixed).
    pub left_std_devs: IntrinsicStdDevs,
    /// 1σ of the right intrinsics (`None` = held fixed).
    pub right_std_devs: IntrinsicStdDevs,
    /// 1σ of the rig parameters.
    pub rig_std_devs: RigStdDevs,
    /// Essential matrix `E = [t]× R` (`x_rᵀ E x_l = 0` for normalised coordinates).
    pub essential: DMat3,
    /// Fundamental matrix `F = K_r⁻ᵀ E K_l⁻¹` (`u_rᵀ F u_l = 0` for undistorted pixels).
    pub fundamental: DMat3,
    /// Estimated corner noise per coordinate, pixels.
    pub sigma_px: f64,
    /// Degrees of freedom (residuals − parameters).
    pub dof: usize,
    /// Estimated parameters.
    pub num_parameters: usize,
    /// LM iterations of the joint refinement.
    pub iterations: usize,
    /// Whether the joint refinement converged.
    pub converged: bool,
    /// Diagnostics (camera 0 = left, 1 = right).
    pub warnings: Vec<CalibrationWarning>,
}

/// Element-wise median of the per-view `right_from_left = right_from_board ∘ left_from_board⁻¹`
/// (rotation vectors and translations), as OpenCV's `stereoCalibrate` starts.
pub fn median_rig(left: &[Isometry3], right: &[Isometry3]) -> Result<Isometry3> {
    if left.is_empty() || left.len() != right.len() {
        return Err(CalibrationError::SizeMismatch(format!("{} left poses, {} right poses", left.len(), right.len())));
    }
    let rel: Vec<Isometry3> = left.iter().zip(right).map(|(l, r)| *r * l.inverse()).collect();
    let comp = |f: &dyn Fn(&Isometry3) -> f64| median(&rel.iter().map(f).collect::<Vec<_>>());
    let rv = DVec3::new(comp(&|p| p.rvec().x), comp(&|p| p.rvec().y), comp(&|p| p.rvec().z));
    let t = DVec3::new(comp(&|p| p.translation.x), comp(&|p| p.translation.y), comp(&|p| p.translation.z));
    Ok(Isometry3::from_rvec_tvec(rv, t))
}

/// Calibrates a stereo rig from views of a planar target seen by both cameras:
/// `object_points[v]` (plane `z = 0`), `left_points[v]` and `right_points[v]` in the same order.
/// The two-camera case of [`crate::calibrate_rig`] (any lens per camera): closed-form starts,
/// `right_from_left` from the element-wise median of the per-view relative poses (as OpenCV's
/// `stereoCalibrate`), one joint refinement of both cameras, the rig and the view poses, and
/// the rig's checks (parallel views, non-convergence, an undetermined focal length are refused).
pub fn calibrate_stereo(
    object_points: &[Vec<DVec3>],
    left_points: &[Vec<DVec2>],
    right_points: &[Vec<DVec2>],
    left_size: (u32, u32),
    right_size: (u32, u32),
    config: &StereoConfig,
) -> Result<StereoCalibrationResult> {
    validate_views(object_points, left_points, "left camera")?;
    validate_views(object_points, right_points, "right camera")?;
    let frames: Vec<Vec<Option<CameraView>>> = object_points
        .iter()
        .zip(left_points.iter().zip(right_points))
        .map(|(o, (l, r))| {
            vec![
                Some(CameraView { object: o.clone(), image: l.clone() }),
                Some(CameraView { object: o.clone(), image: r.clone() }),
            ]
        })
        .collect();
    let rig_config = RigConfig {
        cameras: vec![config.left.clone(), config.right.clone()],
        fix_intrinsics: config.fix_intrinsics,
        lm: config.lm,
        ..RigConfig::default()
    };
    let r = calibrate_rig(&frames, &[left_size, right_size], &rig_config).map_err(name_cameras)?;
    let rig = StereoRig::new(r.cameras[0], r.cameras[1], r.cam_from_cam0[1])?;
    let view_rms = |f: &Vec<Option<f64>>| [f[0].unwrap_or(0.0), f[1].unwrap_or(0.0)];
    let mut residuals = r.residuals_px;
    Ok(StereoCalibrationResult {
        essential: rig.essential(),
        fundamental: rig.fundamental(),
        rig,
        camera_from_board: r.cam0_from_board,
        rms_px: r.rms_px,
        left_rms_px: r.camera_rms_px[0],
        right_rms_px: r.camera_rms_px[1],
        per_view_rms_px: r.per_view_rms_px.iter().map(view_rms).collect(),
        residuals_px: residuals.iter_mut().map(|f| [std::mem::take(&mut f[0]), std::mem::take(&mut f[1])]).collect(),
        left_std_devs: r.std_devs[0],
        right_std_devs: r.std_devs[1],
        rig_std_devs: r.extrinsic_std_devs[1],
        sigma_px: r.sigma_px,
        dof: r.dof,
        num_parameters: r.num_parameters,
        iterations: r.iterations,
        converged: true,
        warnings: r.warnings,
    })
}

/// A rig error in stereo terms: camera 0 is the left camera, camera 1 the right one.
fn name_cameras(e: CalibrationError) -> CalibrationError {
    let rename = |s: String| s.replace("camera 0", "camera 0 (left)").replace("camera 1", "camera 1 (right)");
    match e {
        CalibrationError::Degenerate(s) => CalibrationError::Degenerate(rename(s)),
        CalibrationError::EstimationFailed(s) => CalibrationError::EstimationFailed(rename(s)),
        CalibrationError::InvalidConfig(s) => CalibrationError::InvalidConfig(rename(s)),
        other => other,
    }
}

/// [`calibrate_stereo`] for chessboard corner grids seen by both cameras (pairs in order).
pub fn calibrate_stereo_chessboard(
    board: &Chessboard,
    left: &[CornerGrid],
    right: &[CornerGrid],
    left_size: (u32, u32),
    right_size: (u32, u32),
    config: &StereoConfig,
) -> Result<StereoCalibrationResult> {
    if left.len() != right.len() {
        return Err(CalibrationError::SizeMismatch(format!("{} left views, {} right views", left.len(), right.len())));
    }
    let object = board_views(board, left, "left camera")?;
    board_views(board, right, "right camera")?;
    let l: Vec<Vec<DVec2>> = left.iter().map(|g| g.corners.clone()).collect();
    let r: Vec<Vec<DVec2>> = right.iter().map(|g| g.corners.clone()).collect();
    calibrate_stereo(&object, &l, &r, left_size, right_size, config)
}
