//! Stereo calibration: per-camera calibration, a robust `right_from_left` start (median over
//! views), then joint refinement of both cameras, the rig and the board poses.

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, CornerGrid, Isometry3, StereoRig};
use parallax_least_squares::{LmConfig, LmReport, Problem, levenberg_marquardt};
use serde::{Deserialize, Serialize};

use crate::bundle::{Bundle, CameraModelSlots, CameraSlots, N_INTR, Slot, ViewObs, pose_at, store_pose, theta_of};
use crate::calibrate::{
    CalibrationConfig, CalibrationWarning, IntrinsicStdDevs, board_views, calibrate_camera, diagnostics,
    intrinsic_std_devs, median, model_slots, outlier_views, pose_std_devs, rms_of, validate_views,
};
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

fn camera_and_poses(
    object: &[Vec<DVec3>],
    image: &[Vec<DVec2>],
    size: (u32, u32),
    cfg: &CalibrationConfig,
    fixed: bool,
    which: &str,
) -> Result<(Camera, Vec<Isometry3>)> {
    if fixed && let Some(guess) = &cfg.intrinsic_guess {
        let poses = object
            .iter()
            .zip(image)
            .enumerate()
            .map(|(v, (o, i))| crate::pnp::initial_pose(guess, o, i, &format!("{which} view {v}")))
            .collect::<Result<Vec<_>>>()?;
        return Ok((*guess, poses));
    }
    let r = calibrate_camera(object, image, size.0, size.1, cfg)?;
    Ok((r.camera, r.camera_from_board))
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

/// The joint refinement of a stereo calibration and what every result reports of it.
pub(crate) struct StereoSolution<C = Camera> {
    pub cameras: [C; 2],
    pub right_from_left: Isometry3,
    /// Left camera from board, per view.
    pub poses: Vec<Isometry3>,
    /// Observed − projected, per view and camera.
    pub residuals_px: Vec<[Vec<DVec2>; 2]>,
    pub per_view_rms_px: Vec<[f64; 2]>,
    /// RMS over both cameras, the left one, the right one.
    pub rms_px: [f64; 3],
    pub rig_std_devs: RigStdDevs,
    pub report: LmReport,
    pub num_parameters: usize,
    /// Where the right camera's free parameters start.
    pub right_offset: usize,
}

impl StereoSolution {
    /// The outlier views of both cameras, with each camera's factor.
    pub(crate) fn outlier_views(&self, configs: [&CalibrationConfig; 2]) -> Vec<CalibrationWarning> {
        (0..2)
            .flat_map(|camera| {
                let rms: Vec<f64> = self.per_view_rms_px.iter().map(|r| r[camera]).collect();
                outlier_views(&rms, configs[camera].outlier_view_factor, camera)
            })
            .collect()
    }

    /// The result of any lens: the rig, `E`, `F`, the fit's figures, the cameras' 1σ and the
    /// warnings the caller found.
    pub(crate) fn into_result(
        self,
        std_devs: [IntrinsicStdDevs; 2],
        warnings: Vec<CalibrationWarning>,
    ) -> Result<StereoCalibrationResult> {
        let rig = StereoRig::new(self.cameras[0], self.cameras[1], self.right_from_left)?;
        let [left_std_devs, right_std_devs] = std_devs;
        let report = &self.report;
        Ok(StereoCalibrationResult {
            essential: rig.essential(),
            fundamental: rig.fundamental(),
            rig,
            camera_from_board: self.poses,
            rms_px: self.rms_px[0],
            left_rms_px: self.rms_px[1],
            right_rms_px: self.rms_px[2],
            per_view_rms_px: self.per_view_rms_px,
            residuals_px: self.residuals_px,
            left_std_devs,
            right_std_devs,
            rig_std_devs: self.rig_std_devs,
            sigma_px: report.sigma2.sqrt(),
            dof: report.dof,
            num_parameters: self.num_parameters,
            iterations: report.iterations,
            converged: report.stop_reason.converged(),
            warnings,
        })
    }
}

/// Refines both cameras (parametrised by `slots`, starting at `cameras`), `right_from_left`
/// (from `rig0`) and the left view poses (from `left_poses`) together, for any camera model;
/// `views`: the object points, left and right pixels per view.
pub(crate) fn refine_stereo<S: CameraSlots + Clone>(
    slots: [&S; 2],
    [(left, left_poses), (right, right_poses)]: [(&S::Camera, &[Isometry3]); 2],
    object_points: &[Vec<DVec3>],
    [left_points, right_points]: [&[Vec<DVec2>]; 2],
    lm: &LmConfig,
) -> Result<StereoSolution<S::Camera>> {
    let [ls, rs] = slots;
    let cameras = [left, right];
    let rig0 = &median_rig(left_poses, right_poses)?;
    let views: Vec<ViewObs> = object_points
        .iter()
        .zip(left_points.iter().zip(right_points))
        .map(|(o, (l, r))| ViewObs { object: o, image: [Some(l.as_slice()), Some(r.as_slice())] })
        .collect();
    let bundle = Bundle::new(vec![ls.clone(), rs.clone()], true, views);
    let n = bundle.num_params();
    let mut x0 = vec![0.0; n];
    x0[..ls.num_free()].copy_from_slice(&ls.free_values(cameras[0]));
    let ro = bundle.cam_offsets[1];
    x0[ro..ro + rs.num_free()].copy_from_slice(&rs.free_values(cameras[1]));
    let rig_offset = bundle.rig_offset.expect("stereo bundle");
    store_pose(rig0, &mut x0[rig_offset..rig_offset + 6]);
    for (v, p) in left_poses.iter().enumerate() {
        let o = bundle.view_offset(v);
        store_pose(p, &mut x0[o..o + 6]);
    }
    let report = levenberg_marquardt(&bundle, &x0, &LmConfig { covariance: true, ..*lm })?;
    let estimation = |e: parallax_least_squares::EvaluationError| CalibrationError::EstimationFailed(e.0);
    let [left, right]: [S::Camera; 2] =
        bundle.cameras(&report.params).map_err(estimation)?.try_into().unwrap_or_else(|_| unreachable!("two cameras"));
    let right_from_left = pose_at(&report.params[rig_offset..]);
    let poses: Vec<Isometry3> =
        (0..object_points.len()).map(|v| pose_at(&report.params[bundle.view_offset(v)..])).collect();
    let residuals_px: Vec<[Vec<DVec2>; 2]> = bundle
        .residuals_by_view(&report.params)
        .map_err(estimation)?
        .into_iter()
        .map(|[l, r]| [l.into_iter().map(|e| -e).collect(), r.into_iter().map(|e| -e).collect()])
        .collect();
    let per_view_rms_px: Vec<[f64; 2]> = residuals_px.iter().map(|[l, r]| [rms_of(l), rms_of(r)]).collect();
    let all_l: Vec<DVec2> = residuals_px.iter().flat_map(|[l, _]| l.iter().copied()).collect();
    let all_r: Vec<DVec2> = residuals_px.iter().flat_map(|[_, r]| r.iter().copied()).collect();
    let all: Vec<DVec2> = all_l.iter().chain(&all_r).copied().collect();
    let cov = report.covariance.as_ref();
    let rig_pose_std = pose_std_devs(&right_from_left, rig_offset, cov);
    let baseline = cov.map_or(f64::NAN, |c| {
        let u = right_from_left.translation.normalize();
        let mut s = 0.0;
        for a in 0..3 {
            for b in 0..3 {
                s += u[a] * c[(rig_offset + 3 + a, rig_offset + 3 + b)] * u[b];
            }
        }
        s.max(0.0).sqrt()
    });
    Ok(StereoSolution {
        cameras: [left, right],
        right_from_left,
        poses,
        per_view_rms_px,
        rms_px: [rms_of(&all), rms_of(&all_l), rms_of(&all_r)],
        residuals_px,
        rig_std_devs: RigStdDevs {
            rotation_rad: rig_pose_std.rotation_rad,
            translation: rig_pose_std.translation,
            baseline,
        },
        report,
        num_parameters: n,
        right_offset: ro,
    })
}

/// Calibrates a stereo rig from views of a planar target seen by both cameras:
/// `object_points[v]` (plane `z = 0`), `left_points[v]` and `right_points[v]` in the same order.
/// Each camera is calibrated alone with its flags (or held at its guess with `fix_intrinsics`),
/// `right_from_left` starts at the element-wise median of the per-view relative poses, then one
/// joint refinement of both cameras, the rig and the left view poses (OpenCV's
/// `stereoCalibrate`, or `fisheye::stereoCalibrate` when both lenses are wide).
pub fn calibrate_stereo(
    object_points: &[Vec<DVec3>],
    left_points: &[Vec<DVec2>],
    right_points: &[Vec<DVec2>],
    left_size: (u32, u32),
    right_size: (u32, u32),
    config: &StereoConfig,
) -> Result<StereoCalibrationResult> {
    config.left.check()?;
    config.right.check()?;
    validate_views(object_points, left_points, "left camera")?;
    validate_views(object_points, right_points, "right camera")?;
    match (config.left.lens.is_wide(), config.right.lens.is_wide()) {
        (true, true) => {
            let points = [left_points, right_points];
            return crate::wide::calibrate_wide_stereo(object_points, points, [left_size, right_size], config);
        }
        (false, false) => {}
        _ => {
            return Err(CalibrationError::InvalidConfig(format!(
                "a rig of a {} and a {} lens: both cameras of a stereo calibration take the same lens family \
                 (Brown–Conrady, or the wide lenses) for now",
                config.left.lens, config.right.lens
            )));
        }
    }
    let (lcam, lposes) =
        camera_and_poses(object_points, left_points, left_size, &config.left, config.fix_intrinsics, "left")?;
    let (rcam, rposes) =
        camera_and_poses(object_points, right_points, right_size, &config.right, config.fix_intrinsics, "right")?;
    let slots_of = |cfg: &CalibrationConfig, cam: &Camera| -> CameraModelSlots {
        if config.fix_intrinsics {
            let theta = theta_of(cam);
            CameraModelSlots {
                slots: std::array::from_fn::<Slot, N_INTR, _>(|i| Slot::Fixed(theta[i])),
                num_free: 0,
                width: cam.width,
                height: cam.height,
            }
        } else {
            model_slots(cfg, cam)
        }
    };
    let ls = slots_of(&config.left, &lcam);
    let rs = slots_of(&config.right, &rcam);
    let starts = [(&lcam, lposes.as_slice()), (&rcam, rposes.as_slice())];
    let sol = refine_stereo([&ls, &rs], starts, object_points, [left_points, right_points], &config.lm)?;
    let [left, right] = sol.cameras;
    let (report, cov) = (&sol.report, sol.report.covariance.as_ref());
    let mut warnings = sol.outlier_views([&config.left, &config.right]);
    let fixed_cfg = CalibrationConfig { intrinsic_guess: config.fix_intrinsics.then_some(left), ..config.left.clone() };
    diagnostics(&mut warnings, &left, 0, &sol.poses, &fixed_cfg, report);
    diagnostics(&mut warnings, &right, 1, &sol.poses, &config.right, report);
    let std_devs = [intrinsic_std_devs(&ls, 0, cov), intrinsic_std_devs(&rs, sol.right_offset, cov)];
    sol.into_result(std_devs, warnings)
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
