//! Rig calibration: any number of cameras of any lens (mixed lenses too), from frames in which
//! any subset of the cameras saw a planar target. Stereo is the two-camera case of this code
//! ([`crate::calibrate_stereo`] calls [`calibrate_rig`]).
//!
//! 1. **Start**: each camera's closed form from all its views (Zhang, or the focal length with
//!    the principal point at the centre when Zhang's conic is not positive definite, as
//!    OpenCV's `initCameraMatrix2D`; the focal scan for a wide lens), refined alone when that
//!    converges (a closed form has no distortion: off the axis it compresses angles, and on a
//!    ring of cameras the chained extrinsics go astray), else the closed form as it is. Nothing
//!    is decided on this start: a camera's weak views are judged on the joint problem.
//! 2. **Pose graph**: for every two cameras that saw the same frames, `camJ_from_camI` is the
//!    element-wise median over those frames; a maximum spanning tree from camera 0 (edges
//!    weighted by shared frames) chains them into `camI_from_cam0`, so a camera that never
//!    shares a frame with camera 0 is reached through another. Each frame's
//!    `cam0_from_board` comes from the camera that saw most of its points.
//! 3. **One Levenberg–Marquardt** over every free intrinsic, every extrinsic and every frame
//!    pose (the frame poses eliminated by the Schur complement at each step), with the
//!    covariance `σ² (JᵀJ)⁻¹`.
//! 4. **Checks on the joint problem**, on its start and on its solution: parallel views of a
//!    camera, a camera not linked to camera 0, non-convergence and a focal length the data do
//!    not determine are refused with what to capture; weak links (few shared frames) and
//!    weakly determined parameters are warnings with the figure.

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Isometry3, ProjectionJacobians, StereoRig, TargetDescription, TargetObservation};
use parallax_least_squares::{EvaluationError, LmConfig, Problem, levenberg_marquardt};
use serde::{Deserialize, Serialize};

use crate::bundle::{
    Bundle, CameraModelSlots, CameraSlots, N_INTR, Sight, Slot, ViewObs, pose_at, store_pose, theta_of,
};
use crate::calibrate::{
    CalibrationConfig, CalibrationWarning, IntrinsicStdDevs, PARALLEL_VIEWS_DEG, calibrate_camera, check_focal,
    distortion_fold, initial_estimate, intrinsic_std_devs, model_slots, outlier_views, pose_std_devs, rms_of,
    validate_views, view_spread_deg,
};
use crate::stereo::RigStdDevs;
use crate::{CalibrationError, Result};

/// Options of [`calibrate_rig`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RigConfig {
    /// Flags (lens, held parameters, optional guess) per camera, in camera order.
    pub cameras: Vec<CalibrationConfig>,
    /// Hold every camera's intrinsics (OpenCV's `CALIB_FIX_INTRINSIC`): at its
    /// `intrinsic_guess` if given, else at its own mono calibration. Only the extrinsics and
    /// the frame poses are estimated.
    pub fix_intrinsics: bool,
    /// Levenberg–Marquardt settings of the joint refinement.
    pub lm: LmConfig,
    /// A camera linked to the rig through fewer shared frames than this is a warning.
    pub min_shared_frames: usize,
    /// A free focal length, or a baseline, whose 1σ exceeds this fraction of its value is a
    /// warning. Default 0.002.
    pub warn_relative_sigma: f64,
}

impl Default for RigConfig {
    fn default() -> Self {
        let camera = CalibrationConfig::default();
        Self {
            lm: camera.lm,
            cameras: vec![camera.clone(), camera],
            fix_intrinsics: false,
            min_shared_frames: 3,
            warn_relative_sigma: 0.002,
        }
    }
}

impl RigConfig {
    /// `count` cameras with the same flags.
    pub fn uniform(count: usize, camera: CalibrationConfig) -> Self {
        Self { lm: camera.lm, cameras: vec![camera; count], ..Self::default() }
    }
}

/// What one camera saw of the target in one frame: object points (on the plane `z = 0`,
/// target units) and their observed pixels, in the same order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraView {
    /// Target points.
    pub object: Vec<DVec3>,
    /// Their pixels.
    pub image: Vec<DVec2>,
}

/// The result of [`calibrate_rig`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RigCalibrationResult {
    /// The calibrated cameras, in input order.
    pub cameras: Vec<Camera>,
    /// `camI_from_cam0` per camera (the identity for camera 0), target units.
    pub cam_from_cam0: Vec<Isometry3>,
    /// `cam0_from_board` per frame (also for frames camera 0 did not see).
    pub cam0_from_board: Vec<Isometry3>,
    /// RMS reprojection error over every point of every camera, pixels.
    pub rms_px: f64,
    /// RMS per camera, pixels.
    pub camera_rms_px: Vec<f64>,
    /// Per frame, per camera: the RMS of that view (`None`: the camera did not see the frame).
    pub per_view_rms_px: Vec<Vec<Option<f64>>>,
    /// Per frame, per camera, per point: observed − projected, pixels (empty when not seen).
    pub residuals_px: Vec<Vec<Vec<DVec2>>>,
    /// 1σ of every camera's intrinsics (`None` = held).
    pub std_devs: Vec<IntrinsicStdDevs>,
    /// 1σ of every `camI_from_cam0` (zero for camera 0).
    pub extrinsic_std_devs: Vec<RigStdDevs>,
    /// Frames seen by both cameras, per pair of cameras (`shared_frames[i][j]`).
    pub shared_frames: Vec<Vec<usize>>,
    /// Estimated point noise per coordinate, pixels.
    pub sigma_px: f64,
    /// Degrees of freedom (residuals − parameters).
    pub dof: usize,
    /// Estimated parameters.
    pub num_parameters: usize,
    /// LM iterations of the joint refinement.
    pub iterations: usize,
    /// Diagnostics (camera indices in input order).
    pub warnings: Vec<CalibrationWarning>,
}

impl RigCalibrationResult {
    /// Which camera saw which frame (`[frame][camera]`).
    pub fn visibility(&self) -> Vec<Vec<bool>> {
        self.per_view_rms_px.iter().map(|f| f.iter().map(Option::is_some).collect()).collect()
    }

    /// Cameras `i` and `j` as a stereo rig (`j_from_i = camJ_from_cam0 ∘ camI_from_cam0⁻¹`).
    pub fn stereo(&self, i: usize, j: usize) -> Result<StereoRig> {
        let n = self.cameras.len();
        if i >= n || j >= n || i == j {
            return Err(CalibrationError::InvalidConfig(format!(
                "camera pair {i},{j} of a rig of {n} cameras (two different indices 0..{})",
                n - 1
            )));
        }
        let j_from_i = self.cam_from_cam0[j] * self.cam_from_cam0[i].inverse();
        Ok(StereoRig::new(self.cameras[i], self.cameras[j], j_from_i)?)
    }
}

/// One camera's parametrisation, whatever its lens.
#[derive(Debug, Clone)]
enum AnySlots {
    BrownConrady(CameraModelSlots),
    Wide(crate::wide::Slots),
}

impl AnySlots {
    fn new(cfg: &CalibrationConfig, init: &Camera, held: bool) -> Self {
        if init.lens_model().is_wide() {
            return Self::Wide(crate::wide::Slots::new(cfg, init, held));
        }
        if held {
            let theta = theta_of(init);
            return Self::BrownConrady(CameraModelSlots {
                slots: std::array::from_fn::<Slot, N_INTR, _>(|i| Slot::Fixed(theta[i])),
                num_free: 0,
                width: init.width,
                height: init.height,
            });
        }
        Self::BrownConrady(model_slots(cfg, init))
    }

    fn std_devs(&self, offset: usize, cov: Option<&faer::Mat<f64>>) -> IntrinsicStdDevs {
        match self {
            Self::BrownConrady(s) => intrinsic_std_devs(s, offset, cov),
            Self::Wide(s) => s.std_devs(offset, cov),
        }
    }
}

impl CameraSlots for AnySlots {
    type Camera = Camera;
    fn slots(&self) -> &[Slot] {
        match self {
            Self::BrownConrady(s) => CameraSlots::slots(s),
            Self::Wide(s) => CameraSlots::slots(s),
        }
    }
    fn num_free(&self) -> usize {
        match self {
            Self::BrownConrady(s) => CameraSlots::num_free(s),
            Self::Wide(s) => CameraSlots::num_free(s),
        }
    }
    fn camera(&self, free: &[f64]) -> std::result::Result<Camera, EvaluationError> {
        match self {
            Self::BrownConrady(s) => CameraSlots::camera(s, free),
            Self::Wide(s) => CameraSlots::camera(s, free),
        }
    }
    fn free_values(&self, camera: &Camera) -> Vec<f64> {
        match self {
            Self::BrownConrady(s) => CameraSlots::free_values(s, camera),
            Self::Wide(s) => CameraSlots::free_values(s, camera),
        }
    }
    fn project(camera: &Camera, pose: &Isometry3, x: DVec3) -> parallax_camera_model::Result<ProjectionJacobians> {
        camera.project_with_jacobians(pose, x)
    }
}

/// One camera's views: the frames it saw, with their points.
struct CameraViews {
    frames: Vec<usize>,
    object: Vec<Vec<DVec3>>,
    image: Vec<Vec<DVec2>>,
}

fn camera_views(frames: &[Vec<Option<CameraView>>], c: usize) -> CameraViews {
    let mut out = CameraViews { frames: Vec::new(), object: Vec::new(), image: Vec::new() };
    for (f, frame) in frames.iter().enumerate() {
        if let Some(v) = &frame[c] {
            out.frames.push(f);
            out.object.push(v.object.clone());
            out.image.push(v.image.clone());
        }
    }
    out
}

/// The start of one camera from its views (see the module docs): its closed form refined
/// alone when that refinement succeeds and converges, else the closed form itself. With the
/// intrinsics held and no guess, its mono calibration (refused if it fails).
/// Returns the camera, its view poses, and why it was not refined alone (if it was not).
fn initial_camera(
    views: &CameraViews,
    size: (u32, u32),
    cfg: &CalibrationConfig,
    held: bool,
) -> Result<(Camera, Vec<Isometry3>, Option<String>)> {
    if held && cfg.intrinsic_guess.is_some() {
        // held at the guess: only its view poses
        return if cfg.lens.is_wide() {
            crate::wide::initial_camera((&views.object, &views.image), size, cfg)
        } else {
            initial_estimate(&views.object, &views.image, size.0, size.1, cfg)
        }
        .map(|(c, p)| (c, p, None));
    }
    let why = match calibrate_camera(&views.object, &views.image, size.0, size.1, cfg) {
        Ok(r) if r.converged => return Ok((r.camera, r.camera_from_board, None)),
        Ok(r) => format!("its refinement alone did not converge in {} iterations", r.iterations),
        Err(e) => e.to_string(),
    };
    if held && cfg.intrinsic_guess.is_none() {
        return Err(CalibrationError::EstimationFailed(format!("its mono calibration, to hold: {why}")));
    }
    let (camera, poses) = if cfg.lens.is_wide() {
        crate::wide::initial_camera((&views.object, &views.image), size, cfg)?
    } else {
        initial_estimate(&views.object, &views.image, size.0, size.1, cfg)?
    };
    Ok((camera, poses, Some(why)))
}

/// Per camera, the camera it is linked to the rig through and the frames they share (`None`
/// for camera 0).
type Links = Vec<Option<(usize, usize)>>;

/// `camI_from_cam0` for every camera from the per-camera poses: medians over shared frames,
/// chained along a maximum spanning tree from camera 0. Refuses a camera no chain reaches;
/// returns the extrinsics and the links.
fn pose_graph(
    views: &[CameraViews],
    poses: &[Vec<Isometry3>],
    shared: &[Vec<usize>],
) -> Result<(Vec<Isometry3>, Links)> {
    let n = views.len();
    let mut extrinsic: Vec<Option<Isometry3>> = vec![None; n];
    let mut link = vec![None; n];
    extrinsic[0] = Some(Isometry3::IDENTITY);
    // Prim: repeatedly add the unreached camera with the most frames shared with a reached one.
    loop {
        let best = (0..n)
            .filter(|&i| extrinsic[i].is_some())
            .flat_map(|i| (0..n).filter(|&j| extrinsic[j].is_none()).map(move |j| (i, j)))
            .filter(|&(i, j)| shared[i][j] > 0)
            .max_by_key(|&(i, j)| (shared[i][j], std::cmp::Reverse(j)));
        let Some((i, j)) = best else { break };
        let (mut pi, mut pj) = (Vec::new(), Vec::new());
        for (a, f) in views[i].frames.iter().enumerate() {
            if let Some(b) = views[j].frames.iter().position(|g| g == f) {
                pi.push(poses[i][a]);
                pj.push(poses[j][b]);
            }
        }
        let j_from_i = crate::stereo::median_rig(&pi, &pj)?;
        extrinsic[j] = Some(j_from_i * extrinsic[i].expect("reached"));
        link[j] = Some((i, shared[i][j]));
    }
    let unreached: Vec<usize> = (0..n).filter(|&j| extrinsic[j].is_none()).collect();
    if !unreached.is_empty() {
        let reached: Vec<usize> = (0..n).filter(|&j| extrinsic[j].is_some()).collect();
        return Err(CalibrationError::Degenerate(format!(
            "camera(s) {unreached:?} share no frame with camera 0 or with any camera linked to it (linked: \
             {reached:?}): their position in the rig is unknown; capture frames in which the target is seen by \
             one of them and one linked camera at once"
        )));
    }
    Ok((extrinsic.into_iter().map(|e| e.expect("every camera reached")).collect(), link))
}

/// Checks the inputs and returns each camera's views.
fn check_inputs(
    frames: &[Vec<Option<CameraView>>],
    sizes: &[(u32, u32)],
    config: &RigConfig,
) -> Result<Vec<CameraViews>> {
    let n = sizes.len();
    if n == 0 {
        return Err(CalibrationError::Empty("cameras"));
    }
    if config.cameras.len() != n {
        return Err(CalibrationError::SizeMismatch(format!(
            "{} camera configurations for {n} cameras (give one per camera)",
            config.cameras.len()
        )));
    }
    if frames.is_empty() {
        return Err(CalibrationError::Empty("frames"));
    }
    for (c, cfg) in config.cameras.iter().enumerate() {
        cfg.check().map_err(|e| CalibrationError::InvalidConfig(format!("camera {c}: {e}")))?;
        let (w, h) = sizes[c];
        if w == 0 || h == 0 {
            return Err(CalibrationError::InvalidConfig(format!("camera {c}: image size {w}x{h}")));
        }
        if let Some(g) = &cfg.intrinsic_guess
            && (g.width, g.height) != (w, h)
        {
            return Err(CalibrationError::InvalidConfig(format!(
                "camera {c}: intrinsic guess is for {}x{} images, the views are {w}x{h}",
                g.width, g.height
            )));
        }
    }
    for (f, frame) in frames.iter().enumerate() {
        if frame.len() != n {
            return Err(CalibrationError::SizeMismatch(format!(
                "frame {f} has {} camera entries, the rig {n} cameras",
                frame.len()
            )));
        }
    }
    let unseen: Vec<usize> = (0..frames.len()).filter(|&f| frames[f].iter().all(Option::is_none)).collect();
    if !unseen.is_empty() {
        return Err(CalibrationError::SizeMismatch(format!("frame(s) {unseen:?} were seen by no camera: drop them")));
    }
    let mut all = Vec::with_capacity(n);
    for c in 0..n {
        let views = camera_views(frames, c);
        if views.frames.is_empty() {
            return Err(CalibrationError::Degenerate(format!(
                "camera {c} saw the target in no frame (no target found in its images, or its files match no frame)"
            )));
        }
        validate_views(&views.object, &views.image, &format!("camera {c}"))?;
        let cfg = &config.cameras[c];
        let needed =
            if cfg.intrinsic_guess.is_some() && (config.fix_intrinsics || cfg.fix_principal_point) { 1 } else { 2 };
        if views.frames.len() < needed {
            return Err(CalibrationError::Degenerate(format!(
                "camera {c} saw the target in {} frame(s), at least {needed} needed to determine its intrinsics \
                 (or hold them with an intrinsic guess)",
                views.frames.len()
            )));
        }
        all.push(views);
    }
    Ok(all)
}

/// Whether camera `c`'s views must tilt: its focal length and principal point are estimated.
fn needs_spread(cfg: &CalibrationConfig, held: bool) -> bool {
    !held && cfg.intrinsic_guess.is_none() && !cfg.fix_principal_point
}

fn parallel_views(c: usize, count: usize, spread: f64, when: &str) -> CalibrationError {
    CalibrationError::Degenerate(format!(
        "camera {c}: all {count} board views {when} are parallel (normals within {spread:.2}°): they do not \
         determine its focal length and principal point, and the rig's scale with them; tilt the board by \
         20–40° in different directions across the frames"
    ))
}

/// Calibrates a rig of any number of cameras (any lens per camera) from frames of a planar
/// target: `frames[f][c]` is what camera `c` saw in frame `f` (`None`: it did not see the
/// target), `sizes[c]` its image size, `config.cameras[c]` its flags. See the module docs for
/// the method and the checks.
///
/// Errors: a camera that saw no frame (or too few to determine its intrinsics), a frame no
/// camera saw, a camera not linked to camera 0 through shared frames, parallel views of a
/// camera whose focal length is estimated, a refinement that does not converge, a focal
/// length the data do not determine (1σ above [`CalibrationConfig::max_focal_sigma`]), and
/// everything a view may be refused for (too few points, non-finite values, non-planar
/// object points).
pub fn calibrate_rig(
    frames: &[Vec<Option<CameraView>>],
    sizes: &[(u32, u32)],
    config: &RigConfig,
) -> Result<RigCalibrationResult> {
    let views = check_inputs(frames, sizes, config)?;
    let n = sizes.len();
    let held = config.fix_intrinsics;
    // 1. Each camera's start.
    let mut cameras = Vec::with_capacity(n);
    let mut poses = Vec::with_capacity(n);
    let mut alone = Vec::new();
    for c in 0..n {
        let cfg = &config.cameras[c];
        let (camera, p, why) = initial_camera(&views[c], sizes[c], cfg, held)
            .map_err(|e| CalibrationError::EstimationFailed(format!("camera {c}: initial estimate: {e}")))?;
        if needs_spread(cfg, held) && p.len() >= 2 {
            let spread = view_spread_deg(&p);
            if spread < PARALLEL_VIEWS_DEG {
                return Err(parallel_views(c, p.len(), spread, "(at the start)"));
            }
        }
        if let Some(why) = why {
            alone.push(format!("camera {c} alone: {why}"));
        }
        cameras.push(camera);
        poses.push(p);
    }
    // 2. The pose graph.
    let shared: Vec<Vec<usize>> = (0..n)
        .map(|i| (0..n).map(|j| frames.iter().filter(|f| i != j && f[i].is_some() && f[j].is_some()).count()).collect())
        .collect();
    let (extrinsics, links) = pose_graph(&views, &poses, &shared)?;
    let frame_poses: Vec<Isometry3> = (0..frames.len())
        .map(|f| {
            let c = (0..n)
                .filter(|&c| frames[f][c].is_some())
                .max_by_key(|&c| (frames[f][c].as_ref().map_or(0, |v| v.image.len()), std::cmp::Reverse(c)))
                .expect("every frame was seen");
            let k = views[c].frames.iter().position(|&g| g == f).expect("camera saw the frame");
            extrinsics[c].inverse() * poses[c][k]
        })
        .collect();
    // 3. The joint refinement.
    let slots: Vec<AnySlots> = (0..n).map(|c| AnySlots::new(&config.cameras[c], &cameras[c], held)).collect();
    let obs: Vec<ViewObs> = frames
        .iter()
        .map(|f| ViewObs {
            sights: f.iter().map(|v| v.as_ref().map(|v| Sight { object: &v.object, image: &v.image })).collect(),
        })
        .collect();
    let bundle = Bundle::new(slots, obs);
    let np = bundle.num_params();
    if bundle.num_residuals <= np {
        return Err(CalibrationError::TooFewPoints {
            what: "rig calibration (all frames and cameras)".into(),
            got: bundle.num_residuals / 2,
            needed: np / 2 + 1,
        });
    }
    let mut x0 = vec![0.0; np];
    for c in 0..n {
        let o = bundle.cam_offsets[c];
        x0[o..o + bundle.cams[c].num_free()].copy_from_slice(&bundle.cams[c].free_values(&cameras[c]));
        if let Some(o) = bundle.rig_offsets[c] {
            store_pose(&extrinsics[c], &mut x0[o..o + 6]);
        }
    }
    for (f, p) in frame_poses.iter().enumerate() {
        let o = bundle.view_offset(f);
        store_pose(p, &mut x0[o..o + 6]);
    }
    let report = levenberg_marquardt(&bundle, &x0, &LmConfig { covariance: true, ..config.lm }).map_err(|e| {
        // The start puts a board behind a camera, or similar: the starts found no consistent
        // geometry, which weak views cause; say what each camera alone showed.
        let alone = if alone.is_empty() { String::new() } else { format!(" ({})", alone.join("; ")) };
        CalibrationError::Degenerate(format!(
            "the rig's start is inconsistent ({e}): the views do not determine the cameras{alone} — typically \
             boards that all face the cameras (nearly parallel views) or too few frames; tilt the board by 20–40° \
             in different directions across the frames and fill the images"
        ))
    })?;
    let estimation = |e: EvaluationError| CalibrationError::EstimationFailed(e.0);
    if !report.stop_reason.converged() {
        return Err(CalibrationError::EstimationFailed(format!(
            "the joint refinement did not converge in {} iterations (RMS {:.3} px): the data are too weak or \
             inconsistent; check that the frames match across the cameras (images of the same moment; stereo \
             pairs in the same order), check the corners (per-view errors), give more frames with the target \
             tilted, or raise the iteration cap",
            report.iterations,
            report.rms()
        )));
    }
    let cameras = bundle.cameras(&report.params).map_err(estimation)?;
    for (c, cam) in cameras.iter().enumerate() {
        cam.validate()
            .map_err(|e| CalibrationError::EstimationFailed(format!("camera {c} refined is invalid: {e}")))?;
    }
    let cam_from_cam0 = bundle.extrinsics(&report.params);
    let cam0_from_board: Vec<Isometry3> =
        (0..frames.len()).map(|f| pose_at(&report.params[bundle.view_offset(f)..])).collect();
    // 4. Checks on the solution.
    let camera_poses = |c: usize| -> Vec<Isometry3> {
        views[c].frames.iter().map(|&f| cam_from_cam0[c] * cam0_from_board[f]).collect()
    };
    let mut min_spread = f64::INFINITY;
    for c in 0..n {
        let p = camera_poses(c);
        if p.len() < 2 {
            continue;
        }
        let spread = view_spread_deg(&p);
        if needs_spread(&config.cameras[c], held) {
            min_spread = min_spread.min(spread);
            if spread < PARALLEL_VIEWS_DEG {
                return Err(parallel_views(c, p.len(), spread, "(refined)"));
            }
        }
    }
    let cov = report.covariance.as_ref().ok_or_else(|| {
        CalibrationError::Degenerate(
            "the joint problem's information matrix is singular: some parameter is not determined by the views \
             (parallel boards, a camera seeing too few frames, a held parameter left free); tilt the board and \
             capture more frames"
                .into(),
        )
    })?;
    let std_devs: Vec<IntrinsicStdDevs> =
        (0..n).map(|c| bundle.cams[c].std_devs(bundle.cam_offsets[c], Some(cov))).collect();
    let mut warnings = Vec::new();
    for c in 0..n {
        let focal = check_focal(bundle.cams[c].slots(), &cameras[c], bundle.cam_offsets[c], cov, &config.cameras[c])
            .map_err(|e| match e {
                CalibrationError::Degenerate(m) => CalibrationError::Degenerate(format!("camera {c}: {m}")),
                other => other,
            })?;
        for (name, value, sigma) in focal {
            if sigma > config.warn_relative_sigma * value.abs() {
                warnings.push(CalibrationWarning::WeaklyDetermined {
                    camera: c,
                    parameter: name.to_string(),
                    value,
                    std_dev: sigma,
                });
            }
        }
    }
    let extrinsic_std_devs: Vec<RigStdDevs> = (0..n)
        .map(|c| match bundle.rig_offsets[c] {
            None => RigStdDevs::default(),
            Some(o) => extrinsic_std_dev(&cam_from_cam0[c], o, cov),
        })
        .collect();
    for c in 1..n {
        let b = cam_from_cam0[c].translation.length();
        let s = extrinsic_std_devs[c].baseline;
        if b > 0.0 && s > config.warn_relative_sigma * b {
            warnings.push(CalibrationWarning::WeaklyDetermined {
                camera: c,
                parameter: "baseline".into(),
                value: b,
                std_dev: s,
            });
        }
        if let Some((parent, count)) = links[c]
            && count < config.min_shared_frames
        {
            warnings.push(CalibrationWarning::FewSharedFrames {
                camera: c,
                linked_to: parent,
                frames: count,
                recommended: config.min_shared_frames,
            });
        }
    }
    // Residuals (observed − projected) and per-view figures.
    let by_view = bundle.residuals_by_view(&report.params).map_err(estimation)?;
    let residuals_px: Vec<Vec<Vec<DVec2>>> =
        by_view.into_iter().map(|f| f.into_iter().map(|r| r.into_iter().map(|e| -e).collect()).collect()).collect();
    let per_view_rms_px: Vec<Vec<Option<f64>>> = residuals_px
        .iter()
        .enumerate()
        .map(|(f, cams)| cams.iter().enumerate().map(|(c, r)| frames[f][c].as_ref().map(|_| rms_of(r))).collect())
        .collect();
    let camera_rms_px: Vec<f64> =
        (0..n).map(|c| rms_of(&residuals_px.iter().flat_map(|f| f[c].iter().copied()).collect::<Vec<_>>())).collect();
    let all: Vec<DVec2> = residuals_px.iter().flatten().flatten().copied().collect();
    for c in 0..n {
        let rms: Vec<f64> = per_view_rms_px.iter().filter_map(|f| f[c]).collect();
        for w in outlier_views(&rms, config.cameras[c].outlier_view_factor, c) {
            // Per-camera view index → frame index.
            warnings.push(match w {
                CalibrationWarning::OutlierView { view, camera, rms_px, median_rms_px } => {
                    CalibrationWarning::OutlierView { view: views[c].frames[view], camera, rms_px, median_rms_px }
                }
                other => other,
            });
        }
        let cam = &cameras[c];
        if cam.lens_model().is_wide() {
            crate::wide::lens_warnings(&mut warnings, cam, c, &camera_poses(c), &views[c].object, &config.cameras[c]);
        } else if let Some(fold) = distortion_fold(cam) {
            warnings.push(CalibrationWarning::NonMonotonicDistortion { camera: c, fold });
        }
    }
    let threshold = config.cameras.iter().map(|c| c.min_view_spread_deg).fold(0.0, f64::max);
    if min_spread.is_finite() && min_spread < threshold {
        warnings.push(CalibrationWarning::SimilarViews { max_angle_deg: min_spread, threshold_deg: threshold });
    }
    Ok(RigCalibrationResult {
        cameras,
        cam_from_cam0,
        cam0_from_board,
        rms_px: rms_of(&all),
        camera_rms_px,
        per_view_rms_px,
        residuals_px,
        std_devs,
        extrinsic_std_devs,
        shared_frames: shared,
        sigma_px: report.sigma2.sqrt(),
        dof: report.dof,
        num_parameters: np,
        iterations: report.iterations,
        warnings,
    })
}

/// 1σ of an extrinsic stored at `offset` (left perturbation): per-axis rotation and
/// translation, the translation's norm, and the rotation's magnitude `√tr Σ_ω`.
fn extrinsic_std_dev(pose: &Isometry3, offset: usize, cov: &faer::Mat<f64>) -> RigStdDevs {
    let p = pose_std_devs(pose, offset, Some(cov));
    // t' = t − [t]× ω + v: the norm's gradient is uᵀ[−[t]×, I] = [0, uᵀ] (u ∥ t).
    let u = pose.translation.normalize_or_zero();
    let mut s = 0.0;
    for a in 0..3 {
        for b in 0..3 {
            s += u[a] * cov[(offset + 3 + a, offset + 3 + b)] * u[b];
        }
    }
    let angle = (0..3).map(|a| cov[(offset + a, offset + a)]).sum::<f64>().max(0.0).sqrt();
    RigStdDevs {
        rotation_rad: p.rotation_rad,
        translation: p.translation,
        baseline: s.max(0.0).sqrt(),
        angle_rad: angle,
    }
}

/// [`calibrate_rig`] from identified points: `frames[f][c]` is what camera `c` saw of `target`
/// in frame `f` (any subset of its points: partial ChArUco / AprilGrid views).
pub fn calibrate_rig_target(
    target: &TargetDescription,
    frames: &[Vec<Option<TargetObservation>>],
    sizes: &[(u32, u32)],
    config: &RigConfig,
) -> Result<RigCalibrationResult> {
    let views = frames
        .iter()
        .enumerate()
        .map(|(f, frame)| {
            frame
                .iter()
                .map(|o| {
                    o.as_ref()
                        .map(|o| {
                            Ok(CameraView {
                                object: crate::object_points_for(target, o, f)?,
                                image: o.points().to_vec(),
                            })
                        })
                        .transpose()
                })
                .collect::<Result<Vec<_>>>()
        })
        .collect::<Result<Vec<_>>>()?;
    calibrate_rig(&views, sizes, config)
}
