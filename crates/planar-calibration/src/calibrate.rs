//! Mono calibration: closed-form initialisation, full maximum-likelihood refinement with
//! OpenCV-like options, uncertainty and diagnostics.

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, CornerGrid, Distortion, Intrinsics, Isometry3, LensModel};
use parallax_least_squares::{LmConfig, LmReport, levenberg_marquardt};
use serde::{Deserialize, Serialize};

use crate::bundle::{Bundle, CameraModelSlots, CameraSlots, N_INTR, Slot, ViewObs, store_pose, theta_of};
use crate::homography::estimate_homography_named;
use crate::zhang::{
    focal_lengths_with_principal_point, intrinsics_from_homographies, pose_from_homography, radial_distortion_linear,
};
use crate::{CalibrationError, Result};

/// Options of [`calibrate_camera`], named after OpenCV's `calibrateCamera` and
/// `fisheye::calibrate` flags. The default is OpenCV's default: a pinhole (Brown–Conrady) lens,
/// estimate `fx, fy, cx, cy, k1, k2, p1, p2, k3`, no skew, no rational terms. With a wide lens
/// (`lens: KannalaBrandt` or `DoubleSphere`) it is `fisheye::calibrate`'s model with
/// `CALIB_FIX_SKEW`: `fx, fy, cx, cy` and every lens parameter estimated. A flag that does not
/// apply to the lens is refused ([`CalibrationConfig::check`]), not ignored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CalibrationConfig {
    /// The lens model to fit.
    pub lens: LensModel,
    /// Hold `cx, cy` (`CALIB_FIX_PRINCIPAL_POINT`): at the guess if one is given, else at the
    /// image centre `((w−1)/2, (h−1)/2)`.
    pub fix_principal_point: bool,
    /// Estimate only `fy`, with `fx = a·fy` (`CALIB_FIX_ASPECT_RATIO`); `a = fx/fy` of the guess,
    /// 1 without one.
    pub fix_aspect_ratio: bool,
    /// Hold `p1 = p2 = 0` (or at the guess) (`CALIB_ZERO_TANGENT_DIST`).
    pub zero_tangential: bool,
    /// Hold `k1` (at the guess, else 0).
    pub fix_k1: bool,
    /// Hold `k2` (at the guess, else 0).
    pub fix_k2: bool,
    /// Hold `k3` (at the guess, else 0): with `zero_tangential` this is the "k1, k2 only" model.
    pub fix_k3: bool,
    /// Hold `k4` (at the guess, else 0): Kannala–Brandt (`cv::fisheye`'s `CALIB_FIX_K4`), or
    /// Brown–Conrady's rational `k4` (`CALIB_FIX_K4`; without `rational_model` it is held anyway).
    pub fix_k4: bool,
    /// Hold Brown–Conrady's rational `k5` (`CALIB_FIX_K5`).
    pub fix_k5: bool,
    /// Hold Brown–Conrady's rational `k6` (`CALIB_FIX_K6`).
    pub fix_k6: bool,
    /// Hold `ξ` (at the guess, else 0): double sphere.
    pub fix_xi: bool,
    /// Hold `α` (at the guess, else ½): double sphere.
    pub fix_alpha: bool,
    /// Also estimate the rational terms `k4, k5, k6` (`CALIB_RATIONAL_MODEL`).
    pub rational_model: bool,
    /// Estimate the skew `K[0][1]` (OpenCV never does; Zhang's model does).
    pub estimate_skew: bool,
    /// Start from these intrinsics and distortion instead of the closed form
    /// (`CALIB_USE_INTRINSIC_GUESS`); fixed parameters keep its values. The image size must match.
    pub intrinsic_guess: Option<Camera>,
    /// Levenberg–Marquardt settings of the refinement.
    pub lm: LmConfig,
    /// A view is an outlier when its RMS exceeds this multiple of the median view RMS (and the
    /// median plus 4 robust standard deviations).
    pub outlier_view_factor: f64,
    /// Views whose board normals all lie within this angle (degrees) of each other are
    /// reported as too similar.
    pub min_view_spread_deg: f64,
    /// Wide lenses: warn when the observed corners reach less than this fraction of the field
    /// angle at the midpoints of the image edges (the model extrapolates beyond). Default 0.8.
    pub min_field_coverage: f64,
    /// A free focal length whose 1σ exceeds this fraction of its value is refused: the views
    /// do not determine it (boards that all face the camera, too few views). For a double
    /// sphere lens the focal length near the axis, `f/(1+ξ)`. Default 0.02.
    pub max_focal_sigma: f64,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        Self {
            lens: LensModel::BrownConrady,
            fix_principal_point: false,
            fix_aspect_ratio: false,
            zero_tangential: false,
            fix_k1: false,
            fix_k2: false,
            fix_k3: false,
            fix_k4: false,
            fix_k5: false,
            fix_k6: false,
            fix_xi: false,
            fix_alpha: false,
            rational_model: false,
            estimate_skew: false,
            intrinsic_guess: None,
            lm: LmConfig {
                max_iterations: 200,
                gradient_tolerance: 1e-10,
                step_tolerance: 1e-12,
                cost_tolerance: 1e-12,
                ..LmConfig::default()
            },
            outlier_view_factor: 2.0,
            min_view_spread_deg: 10.0,
            min_field_coverage: 0.8,
            max_focal_sigma: 0.02,
        }
    }
}

impl CalibrationConfig {
    /// Refuses a flag that does not apply to [`Self::lens`] (naming the flag and the lens), an
    /// intrinsic guess of another lens model, and a `min_field_coverage` outside `[0, 1]`.
    pub fn check(&self) -> Result<()> {
        use LensModel::{BrownConrady, DoubleSphere, KannalaBrandt};
        let flags: [(&str, bool, &[LensModel]); 10] = [
            ("zero_tangential", self.zero_tangential, &[BrownConrady]),
            ("rational_model", self.rational_model, &[BrownConrady]),
            ("fix_k1", self.fix_k1, &[BrownConrady, KannalaBrandt]),
            ("fix_k2", self.fix_k2, &[BrownConrady, KannalaBrandt]),
            ("fix_k3", self.fix_k3, &[BrownConrady, KannalaBrandt]),
            ("fix_k4", self.fix_k4, &[BrownConrady, KannalaBrandt]),
            ("fix_k5", self.fix_k5, &[BrownConrady]),
            ("fix_k6", self.fix_k6, &[BrownConrady]),
            ("fix_xi", self.fix_xi, &[DoubleSphere]),
            ("fix_alpha", self.fix_alpha, &[DoubleSphere]),
        ];
        for (flag, on, lenses) in flags {
            if on && !lenses.contains(&self.lens) {
                return Err(CalibrationError::InvalidConfig(format!(
                    "{flag} does not apply to a {} lens (it is a flag of {})",
                    self.lens,
                    lenses.iter().map(|l| l.name()).collect::<Vec<_>>().join(" and ")
                )));
            }
        }
        if let Some(g) = &self.intrinsic_guess {
            g.validate()?;
        }
        if let Some(g) = &self.intrinsic_guess
            && g.lens_model() != self.lens
        {
            return Err(CalibrationError::InvalidConfig(format!(
                "the intrinsic guess has a {} lens but the configuration asks for {}",
                g.lens_model(),
                self.lens
            )));
        }
        if !(self.min_field_coverage.is_finite() && (0.0..=1.0).contains(&self.min_field_coverage)) {
            return Err(CalibrationError::InvalidConfig(format!(
                "min_field_coverage must be in [0, 1], got {}",
                self.min_field_coverage
            )));
        }
        Ok(())
    }
}

/// Standard deviation (1σ) of every intrinsic parameter; `None` for parameters held fixed.
/// A parameter tied to another (`fx = a·fy`) gets the propagated value.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[allow(missing_docs)]
pub struct IntrinsicStdDevs {
    pub fx: Option<f64>,
    pub fy: Option<f64>,
    pub cx: Option<f64>,
    pub cy: Option<f64>,
    pub skew: Option<f64>,
    pub k1: Option<f64>,
    pub k2: Option<f64>,
    pub p1: Option<f64>,
    pub p2: Option<f64>,
    pub k3: Option<f64>,
    pub k4: Option<f64>,
    pub k5: Option<f64>,
    pub k6: Option<f64>,
    /// Double sphere's `ξ` (absent for the other lenses).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub xi: Option<f64>,
    /// Double sphere's `α` (absent for the other lenses).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
}

impl IntrinsicStdDevs {
    /// 1σ of the lens parameters of `model`, in its order (`k1 k2 p1 p2 k3 k4 k5 k6`,
    /// `k1 k2 k3 k4` or `ξ α`).
    pub fn lens(&self, model: LensModel) -> Vec<Option<f64>> {
        match model {
            LensModel::BrownConrady => self.to_array()[5..].to_vec(),
            LensModel::KannalaBrandt => vec![self.k1, self.k2, self.k3, self.k4],
            LensModel::DoubleSphere => vec![self.xi, self.alpha],
        }
    }

    /// In the order `(fx, fy, cx, cy, skew, k1, k2, p1, p2, k3, k4, k5, k6)`.
    pub fn to_array(&self) -> [Option<f64>; 13] {
        [
            self.fx, self.fy, self.cx, self.cy, self.skew, self.k1, self.k2, self.p1, self.p2, self.k3, self.k4,
            self.k5, self.k6,
        ]
    }

    pub(crate) fn from_array(a: [Option<f64>; 13]) -> Self {
        Self {
            fx: a[0],
            fy: a[1],
            cx: a[2],
            cy: a[3],
            skew: a[4],
            k1: a[5],
            k2: a[6],
            p1: a[7],
            p2: a[8],
            k3: a[9],
            k4: a[10],
            k5: a[11],
            k6: a[12],
            xi: None,
            alpha: None,
        }
    }
}

/// Standard deviation of a pose: rotation as the left perturbation `ω` (radians, about the
/// target frame's axes, i.e. the camera's for `camera_from_board`), translation in board units.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStdDevs {
    /// 1σ of the rotation perturbation about x, y, z (radians).
    pub rotation_rad: DVec3,
    /// 1σ of the translation components.
    pub translation: DVec3,
}

/// Where the radial distortion folds back (its radius stops increasing) inside the image.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DistortionFold {
    /// Undistorted normalised radius where `d(r·radial(r))/dr = 0`.
    pub undistorted_radius: f64,
    /// Distance from the principal point (pixels, along x: `fx ·` distorted radius) of the fold.
    pub radius_px: f64,
    /// Distance from the principal point to the farthest image corner (pixels, along x).
    pub image_radius_px: f64,
}

/// Something the user should know about a calibration that nevertheless succeeded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum CalibrationWarning {
    /// A view's reprojection error is far above the others (bad corners, a moved board).
    OutlierView {
        /// View index (camera 0 = left, 1 = right for stereo).
        view: usize,
        /// Camera index (0 for mono and left).
        camera: usize,
        /// The view's RMS error, pixels.
        rms_px: f64,
        /// The median of the per-view RMS errors, pixels.
        median_rms_px: f64,
    },
    /// The radial distortion is not monotonic inside the image: pixels beyond the fold have
    /// two (or no) rays; the model is extrapolating outside the corners' coverage.
    NonMonotonicDistortion {
        /// Camera index.
        camera: usize,
        /// Where it folds.
        fold: DistortionFold,
    },
    /// Fewer views than recommended for the parameters estimated.
    TooFewViews {
        /// Views given.
        views: usize,
        /// Recommended minimum.
        recommended: usize,
    },
    /// All board orientations are within a small angle of each other: focal length and
    /// principal point are poorly determined.
    SimilarViews {
        /// Largest angle between two board normals, degrees.
        max_angle_deg: f64,
        /// The threshold, degrees.
        threshold_deg: f64,
    },
    /// The refinement stopped at its iteration cap.
    NotConverged {
        /// Iterations performed.
        iterations: usize,
    },
    /// The Kannala–Brandt polynomial folds back (`dθ_d/dθ = 0`) inside the image: pixels beyond
    /// that radius have no ray; the fitted polynomial is extrapolating.
    LensFoldsInsideImage {
        /// Camera index (0 mono / left, 1 right).
        camera: usize,
        /// The fold angle, degrees.
        max_field_deg: f64,
        /// Its distance from the principal point, pixels (along x).
        radius_px: f64,
        /// Distance from the principal point to the farthest image corner, pixels (along x).
        image_radius_px: f64,
    },
    /// A parameter the views determine only weakly (its 1σ is a noticeable fraction of it).
    WeaklyDetermined {
        /// Camera index.
        camera: usize,
        /// `fx`, `fy`, or `baseline` (of `camI_from_cam0`).
        parameter: String,
        /// Its value (pixels, or target units).
        value: f64,
        /// Its 1σ.
        std_dev: f64,
    },
    /// A camera is linked to the rig through few frames shared with another camera: its
    /// extrinsic rests on them.
    FewSharedFrames {
        /// Camera index.
        camera: usize,
        /// The camera it is linked through.
        linked_to: usize,
        /// Frames both saw.
        frames: usize,
        /// Recommended minimum.
        recommended: usize,
    },
    /// A wide lens's corners reach a much smaller field angle than the image shows: the lens
    /// model is extrapolated in the periphery (put the board near the image border too).
    ExtrapolatedPeriphery {
        /// Camera index.
        camera: usize,
        /// Largest field angle of an observed corner, degrees.
        observed_deg: f64,
        /// Largest field angle of the midpoints of the image edges, degrees.
        image_deg: f64,
    },
}

impl std::fmt::Display for CalibrationWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::OutlierView { view, camera, rms_px, median_rms_px } => write!(
                f,
                "view {view} (camera {camera}) is an outlier: RMS {rms_px:.3} px vs median {median_rms_px:.3} px"
            ),
            Self::NonMonotonicDistortion { camera, fold } => write!(
                f,
                "camera {camera}: radial distortion folds back {:.0} px from the principal point, inside the image (corner at {:.0} px)",
                fold.radius_px, fold.image_radius_px
            ),
            Self::TooFewViews { views, recommended } => {
                write!(f, "only {views} view(s) for the parameters estimated; at least {recommended} recommended")
            }
            Self::SimilarViews { max_angle_deg, threshold_deg } => write!(
                f,
                "the board orientations differ by at most {max_angle_deg:.1}° (< {threshold_deg}°): tilt the board more"
            ),
            Self::NotConverged { iterations } => write!(f, "refinement did not converge in {iterations} iterations"),
            Self::LensFoldsInsideImage { camera, max_field_deg, radius_px, image_radius_px } => write!(
                f,
                "camera {camera}: the lens polynomial folds back at {max_field_deg:.1}° ({radius_px:.0} px from the \
                 principal point), inside the image (corner at {image_radius_px:.0} px)"
            ),
            Self::WeaklyDetermined { camera, parameter, value, std_dev } => write!(
                f,
                "camera {camera}: {parameter} = {value:.4} is weakly determined (1σ {std_dev:.4}, {:.2} %); tilt the \
                 board more and add frames",
                100.0 * std_dev / value.abs()
            ),
            Self::FewSharedFrames { camera, linked_to, frames, recommended } => write!(
                f,
                "camera {camera} is linked to the rig through {frames} frame(s) shared with camera {linked_to} \
                 (≥ {recommended} recommended): capture more frames both see"
            ),
            Self::ExtrapolatedPeriphery { camera, observed_deg, image_deg } => write!(
                f,
                "camera {camera}: the corners reach {observed_deg:.1}° off axis but the image shows {image_deg:.1}°; \
                 the periphery is extrapolated (show the board near the image border)"
            ),
        }
    }
}

/// The result of [`calibrate_camera`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationResult {
    /// The calibrated camera.
    pub camera: Camera,
    /// Per-view `camera_from_board` (board units).
    pub camera_from_board: Vec<Isometry3>,
    /// RMS reprojection error over all corners, `sqrt(Σ‖e‖² / N)` (OpenCV's definition), pixels.
    pub rms_px: f64,
    /// The same per view.
    pub per_view_rms_px: Vec<f64>,
    /// Per view, per corner: observed − projected, pixels.
    pub residuals_px: Vec<Vec<DVec2>>,
    /// 1σ of every intrinsic parameter (`None` = held fixed), from `σ²(JᵀJ)⁻¹` with
    /// `σ² = Σ e² / (2N − n)`.
    pub std_devs: IntrinsicStdDevs,
    /// 1σ of every view pose.
    pub pose_std_devs: Vec<PoseStdDevs>,
    /// Estimated corner noise per coordinate, `σ`, pixels.
    pub sigma_px: f64,
    /// Degrees of freedom `2N − n` (residuals minus estimated parameters).
    pub dof: usize,
    /// Estimated parameters `n` (free intrinsics + 6 per view).
    pub num_parameters: usize,
    /// LM iterations.
    pub iterations: usize,
    /// Whether LM met a convergence criterion.
    pub converged: bool,
    /// Diagnostics.
    pub warnings: Vec<CalibrationWarning>,
}

pub(crate) fn validate_views(object_points: &[Vec<DVec3>], image_points: &[Vec<DVec2>], what: &str) -> Result<()> {
    if object_points.is_empty() {
        return Err(CalibrationError::Empty("views"));
    }
    if object_points.len() != image_points.len() {
        return Err(CalibrationError::SizeMismatch(format!(
            "{what}: {} views of object points but {} views of image points",
            object_points.len(),
            image_points.len()
        )));
    }
    for (v, (o, i)) in object_points.iter().zip(image_points).enumerate() {
        if o.len() != i.len() {
            return Err(CalibrationError::SizeMismatch(format!(
                "{what} view {v}: {} object points but {} image points",
                o.len(),
                i.len()
            )));
        }
        if o.len() < 4 {
            return Err(CalibrationError::TooFewPoints { what: format!("{what} view {v}"), got: o.len(), needed: 4 });
        }
        if o.iter().any(|p| !p.is_finite()) {
            return Err(CalibrationError::NonFinite(format!("{what} view {v} object points")));
        }
        if i.iter().any(|p| !p.is_finite()) {
            return Err(CalibrationError::NonFinite(format!("{what} view {v} image points")));
        }
        let extent = o.iter().map(|p| p.truncate().length()).fold(0.0, f64::max);
        let max_z = o.iter().map(|p| p.z.abs()).fold(0.0, f64::max);
        if max_z > 1e-9 * extent.max(1.0) {
            return Err(CalibrationError::NotPlanar { what: format!("{what} view {v}"), max_abs_z: max_z });
        }
    }
    Ok(())
}

/// The parametrisation implied by the flags.
pub(crate) fn model_slots(cfg: &CalibrationConfig, init: &Camera) -> CameraModelSlots {
    let theta = theta_of(init);
    let mut slots = [Slot::Fixed(0.0); N_INTR];
    let mut n = 0;
    let mut free = |slots: &mut [Slot; N_INTR], i: usize| {
        slots[i] = Slot::Free { index: n, scale: 1.0 };
        n += 1;
    };
    let fixed = |slots: &mut [Slot; N_INTR], i: usize| slots[i] = Slot::Fixed(theta[i]);
    // fy first so fx can be tied to it.
    free(&mut slots, 1);
    if cfg.fix_aspect_ratio {
        let Slot::Free { index, .. } = slots[1] else { unreachable!() };
        slots[0] = Slot::Free { index, scale: theta[0] / theta[1] };
    } else {
        free(&mut slots, 0);
    }
    for i in [2, 3] {
        if cfg.fix_principal_point { fixed(&mut slots, i) } else { free(&mut slots, i) }
    }
    if cfg.estimate_skew {
        free(&mut slots, 4)
    } else {
        fixed(&mut slots, 4)
    }
    for (i, hold) in [(5, cfg.fix_k1), (6, cfg.fix_k2), (9, cfg.fix_k3)] {
        if hold { fixed(&mut slots, i) } else { free(&mut slots, i) }
    }
    for i in [7, 8] {
        if cfg.zero_tangential { fixed(&mut slots, i) } else { free(&mut slots, i) }
    }
    for (i, hold) in [(10, cfg.fix_k4), (11, cfg.fix_k5), (12, cfg.fix_k6)] {
        if cfg.rational_model && !hold { free(&mut slots, i) } else { fixed(&mut slots, i) }
    }
    CameraModelSlots { slots, num_free: n, width: init.width, height: init.height }
}

/// Closed-form start: intrinsics (Zhang, or focal lengths with a fixed principal point),
/// per-view poses from `K⁻¹H`, and Zhang's linear `k1, k2` when those are estimated.
pub(crate) fn initial_estimate(
    object_points: &[Vec<DVec3>],
    image_points: &[Vec<DVec2>],
    width: u32,
    height: u32,
    cfg: &CalibrationConfig,
) -> Result<(Camera, Vec<Isometry3>)> {
    if let Some(guess) = &cfg.intrinsic_guess {
        let poses = object_points
            .iter()
            .zip(image_points)
            .enumerate()
            .map(|(v, (o, i))| crate::pnp::initial_pose(guess, o, i, &format!("view {v}")))
            .collect::<Result<Vec<_>>>()?;
        return Ok((*guess, poses));
    }
    let homographies = object_points
        .iter()
        .zip(image_points)
        .enumerate()
        .map(|(v, (o, i))| {
            let plane: Vec<DVec2> = o.iter().map(|p| p.truncate()).collect();
            estimate_homography_named(&plane, i, &format!("view {v}")).map(|h| h.matrix)
        })
        .collect::<Result<Vec<DMat3>>>()?;
    let centre = (0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0));
    let mut k = if cfg.fix_principal_point {
        let (fx, fy) = focal_lengths_with_principal_point(&homographies, centre.0, centre.1)?;
        Intrinsics::new(fx, fy, centre.0, centre.1)
    } else {
        match intrinsics_from_homographies(&homographies, width, height, cfg.estimate_skew) {
            Ok(k) if k.cx.is_finite() && k.cx.abs() < 4.0 * width as f64 && k.cy.abs() < 4.0 * height as f64 => k,
            // B not positive definite (noise, few views): OpenCV's start.
            Ok(_) | Err(CalibrationError::EstimationFailed(_)) => {
                let (fx, fy) = focal_lengths_with_principal_point(&homographies, centre.0, centre.1)?;
                Intrinsics::new(fx, fy, centre.0, centre.1)
            }
            Err(e) => return Err(e),
        }
    };
    if cfg.fix_aspect_ratio {
        k.fx = k.fy;
    }
    let poses = homographies
        .iter()
        .enumerate()
        .map(|(v, h)| {
            pose_from_homography(&k, h)
                .map_err(|e| CalibrationError::EstimationFailed(format!("initial pose of view {v}: {e}")))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut camera = Camera::new(k, Distortion::default(), width, height)?;
    if !cfg.fix_k1
        && !cfg.fix_k2
        && let Ok((k1, k2)) = radial_distortion_linear(&k, &poses, object_points, image_points)
    {
        // Keep the linear estimate only when it is plausible and lowers the error.
        let with = Camera { lens: Distortion::new(k1, k2, 0.0, 0.0, 0.0).into(), ..camera };
        if k1.abs() < 2.0
            && k2.abs() < 5.0
            && rms(&with, &poses, object_points, image_points) < rms(&camera, &poses, object_points, image_points)
        {
            camera = with;
        }
    }
    Ok((camera, poses))
}

fn rms(camera: &Camera, poses: &[Isometry3], object_points: &[Vec<DVec3>], image_points: &[Vec<DVec2>]) -> f64 {
    let mut s = 0.0;
    let mut n = 0usize;
    for ((p, o), i) in poses.iter().zip(object_points).zip(image_points) {
        for (x, q) in o.iter().zip(i) {
            s += camera.project_from(p, *x).map_or(1e12, |u| (u - *q).length_squared());
            n += 1;
        }
    }
    (s / n.max(1) as f64).sqrt()
}

/// Intrinsic std devs of camera `slots` whose free parameters start at `offset` in `cov`.
pub(crate) fn intrinsic_std_devs(
    slots: &CameraModelSlots,
    offset: usize,
    cov: Option<&faer::Mat<f64>>,
) -> IntrinsicStdDevs {
    let a: [Option<f64>; 13] = std::array::from_fn(|i| match slots.slots[i] {
        Slot::Fixed(_) => None,
        Slot::Free { index, scale } => {
            Some(cov.map_or(f64::NAN, |c| scale.abs() * c[(offset + index, offset + index)].max(0.0).sqrt()))
        }
    });
    IntrinsicStdDevs::from_array(a)
}

/// Std devs of a pose stored at `offset` (rvec, t) with left-perturbation covariance.
pub(crate) fn pose_std_devs(pose: &Isometry3, offset: usize, cov: Option<&faer::Mat<f64>>) -> PoseStdDevs {
    let Some(c) = cov else {
        return PoseStdDevs { rotation_rad: DVec3::splat(f64::NAN), translation: DVec3::splat(f64::NAN) };
    };
    let rot =
        DVec3::new(c[(offset, offset)], c[(offset + 1, offset + 1)], c[(offset + 2, offset + 2)]).max(DVec3::ZERO);
    // t' = t − [t]× ω + v  ⇒  J = [−[t]×, I].
    let t = pose.translation;
    let tx = [[0.0, -t.z, t.y], [t.z, 0.0, -t.x], [-t.y, t.x, 0.0]];
    let mut j = [[0.0; 6]; 3];
    for r in 0..3 {
        for k in 0..3 {
            j[r][k] = -tx[r][k];
        }
        j[r][3 + r] = 1.0;
    }
    let mut var = [0.0; 3];
    for r in 0..3 {
        let mut s = 0.0;
        for a in 0..6 {
            for b in 0..6 {
                s += j[r][a] * c[(offset + a, offset + b)] * j[r][b];
            }
        }
        var[r] = s.max(0.0);
    }
    PoseStdDevs { rotation_rad: rot.map(f64::sqrt), translation: DVec3::from_array(var).map(f64::sqrt) }
}

/// Where the radial part of the distortion stops being monotonic, if that happens inside the
/// image. Scans the undistorted radius in steps of 1e-3 (normalised) until the distorted
/// radius reaches the farthest image corner; tangential terms are ignored.
pub fn distortion_fold(camera: &Camera) -> Option<DistortionFold> {
    let k = &camera.intrinsics;
    let corners = [
        DVec2::new(-0.5, -0.5),
        DVec2::new(camera.width as f64 - 0.5, -0.5),
        DVec2::new(-0.5, camera.height as f64 - 0.5),
        DVec2::new(camera.width as f64 - 0.5, camera.height as f64 - 0.5),
    ];
    let rho_max = corners.iter().map(|c| k.to_normalized(*c).length()).fold(0.0, f64::max);
    let d = Distortion { p1: 0.0, p2: 0.0, ..*camera.distortion()? };
    let g = |r: f64| d.distort(DVec2::new(r, 0.0)).x;
    let step = 1e-3;
    let mut r = 0.0;
    let mut prev = 0.0;
    while r < 20.0 {
        r += step;
        let cur = g(r);
        if !cur.is_finite() || cur <= prev {
            // Fold between r − step and r: the maximum reached is `prev`.
            return (prev < rho_max).then_some(DistortionFold {
                undistorted_radius: r - step,
                radius_px: prev * k.fx,
                image_radius_px: rho_max * k.fx,
            });
        }
        if cur >= rho_max {
            return None;
        }
        prev = cur;
    }
    None
}

/// The focal lengths the views must determine, with their 1σ (free ones only): `fx`, `fy`;
/// for a double sphere lens `fx/(1+ξ)`, `fy/(1+ξ)`, the focal length near the axis (`fx` and
/// `ξ` alone trade off against each other: a large σ of `fx` there is the model's, not the
/// data's).
pub(crate) fn focal_std_devs(
    s: &[Slot],
    camera: &Camera,
    offset: usize,
    cov: &faer::Mat<f64>,
) -> Vec<(&'static str, f64, f64)> {
    // The covariance of full parameters `a`, `b` (slot order), 0 for a held one.
    let covariance = |a: usize, b: usize| match (s[a], s[b]) {
        (Slot::Free { index: i, scale: si }, Slot::Free { index: j, scale: sj }) => {
            si * sj * cov[(offset + i, offset + j)]
        }
        _ => 0.0,
    };
    let free = |a: usize| matches!(s[a], Slot::Free { .. });
    let k = camera.intrinsics();
    let mut out = Vec::new();
    match camera.lens() {
        parallax_camera_model::Lens::DoubleSphere(ds) => {
            let d = 1.0 + ds.xi();
            for (name, f, a) in [("fx/(1+ξ)", k.fx, 0), ("fy/(1+ξ)", k.fy, 1)] {
                if !free(a) {
                    continue;
                }
                // ∂(f/d)/∂f = 1/d, ∂(f/d)/∂ξ = −f/d².
                let g = [1.0 / d, -f / (d * d)];
                let var = g[0] * g[0] * covariance(a, a)
                    + 2.0 * g[0] * g[1] * covariance(a, 5)
                    + g[1] * g[1] * covariance(5, 5);
                out.push((name, f / d, var.max(0.0).sqrt()));
            }
        }
        _ => {
            for (name, f, a) in [("fx", k.fx, 0), ("fy", k.fy, 1)] {
                if free(a) {
                    out.push((name, f, covariance(a, a).max(0.0).sqrt()));
                }
            }
        }
    }
    out
}

/// Refuses a free focal length the views do not determine (1σ above
/// `config.max_focal_sigma` of its value, or not finite: parallel boards, too few views);
/// returns every free focal length with its 1σ for the caller's warnings.
pub(crate) fn check_focal(
    slots: &[Slot],
    camera: &Camera,
    offset: usize,
    cov: &faer::Mat<f64>,
    config: &CalibrationConfig,
) -> Result<Vec<(&'static str, f64, f64)>> {
    let focal = focal_std_devs(slots, camera, offset, cov);
    for &(name, value, sigma) in &focal {
        let relative = sigma / value.abs();
        if relative.is_nan() || relative > config.max_focal_sigma {
            return Err(CalibrationError::Degenerate(format!(
                "{name} = {value:.1} px is not determined by the views (1σ {sigma:.1} px, {:.2} % > {:.2} %): tilt \
                 the board more and in different directions, fill the image, add views",
                100.0 * relative,
                100.0 * config.max_focal_sigma
            )));
        }
    }
    Ok(focal)
}

pub(crate) fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 { s[n / 2] } else { 0.5 * (s[n / 2 - 1] + s[n / 2]) }
}

/// Outlier views by per-view RMS.
pub(crate) fn outlier_views(per_view: &[f64], factor: f64, camera: usize) -> Vec<CalibrationWarning> {
    if per_view.len() < 3 {
        return Vec::new();
    }
    let med = median(per_view);
    let dev: Vec<f64> = per_view.iter().map(|r| (r - med).abs()).collect();
    let mad = 1.4826 * median(&dev);
    per_view
        .iter()
        .enumerate()
        .filter(|&(_, &r)| r > factor * med && r > med + 4.0 * mad)
        .map(|(view, &r)| CalibrationWarning::OutlierView { view, camera, rms_px: r, median_rms_px: med })
        .collect()
}

/// Largest angle (degrees) between the board normals of the views.
pub(crate) fn view_spread_deg(poses: &[Isometry3]) -> f64 {
    let normals: Vec<DVec3> = poses.iter().map(|p| p.transform_vector(DVec3::Z)).collect();
    let mut best: f64 = 0.0;
    for i in 0..normals.len() {
        for j in (i + 1)..normals.len() {
            best = best.max(normals[i].angle_between(normals[j]).to_degrees());
        }
    }
    best
}

/// Board normals all within this angle (degrees): the views count as parallel (an error
/// unless the principal point is fixed or an intrinsic guess is given).
pub(crate) const PARALLEL_VIEWS_DEG: f64 = 2.0;

pub(crate) fn recommended_views(cfg: &CalibrationConfig) -> usize {
    if cfg.fix_principal_point {
        2
    } else if cfg.estimate_skew {
        4
    } else {
        3
    }
}

/// Calibrates one camera of any lens from views of a planar target: Zhang's method +
/// maximum-likelihood refinement for Brown–Conrady; for the wide lenses an initialisation that
/// needs no focal-length guess (see the `wide` module) and the same refinement. `object_points[v]` are the target points of view `v` (on the plane `z = 0`,
/// board units), `image_points[v]` their observed pixels in the same order.
///
/// Errors: fewer than 2 views, fewer than 4 points in a view, mismatched sizes, non-finite
/// values, non-planar targets, collinear points (naming the view), parallel views.
pub fn calibrate_camera(
    object_points: &[Vec<DVec3>],
    image_points: &[Vec<DVec2>],
    width: u32,
    height: u32,
    config: &CalibrationConfig,
) -> Result<CalibrationResult> {
    config.check()?;
    validate_views(object_points, image_points, "calibration")?;
    if width == 0 || height == 0 {
        return Err(CalibrationError::InvalidConfig(format!("image size {width}x{height}")));
    }
    let needed = if config.intrinsic_guess.is_some() && config.fix_principal_point { 1 } else { 2 };
    if object_points.len() < needed {
        return Err(CalibrationError::TooFewViews {
            got: object_points.len(),
            needed,
            why: "a planar target fixes only 2 of the intrinsics per view (give more views, or an intrinsic guess with a fixed principal point)",
        });
    }
    if let Some(guess) = &config.intrinsic_guess
        && (guess.width, guess.height) != (width, height)
    {
        return Err(CalibrationError::InvalidConfig(format!(
            "intrinsic guess is for {}x{} images, the views are {width}x{height}",
            guess.width, guess.height
        )));
    }
    if config.lens.is_wide() {
        return crate::wide::calibrate_wide((object_points, image_points), (width, height), config);
    }
    let (init_camera, init_poses) = initial_estimate(object_points, image_points, width, height, config)?;
    let slots = model_slots(config, &init_camera);
    let (bundle, report) = refine_mono(&slots, (&init_camera, &init_poses), object_points, image_points, &config.lm)?;
    let n = parallax_least_squares::Problem::num_params(&bundle);
    let solution = mono_solution(&bundle, &report, config.intrinsic_guess.is_none() && !config.fix_principal_point)?;
    let camera = slots.camera(&report.params[..slots.num_free]);
    camera.validate().map_err(|e| CalibrationError::EstimationFailed(format!("refined camera is invalid: {e}")))?;
    if let Some(cov) = report.covariance.as_ref() {
        check_focal(&slots.slots, &camera, 0, cov, config)?;
    }
    let std_devs = intrinsic_std_devs(&slots, 0, report.covariance.as_ref());
    let mut warnings = outlier_views(&solution.per_view_rms_px, config.outlier_view_factor, 0);
    diagnostics(&mut warnings, &camera, 0, &solution.poses, config, &report);
    Ok(solution.into_result(camera, std_devs, n, &report, warnings))
}

/// One mono refinement of any camera model from a start (camera and view poses): the bundle of
/// `slots` over the views, Levenberg–Marquardt with covariance. Refuses views with no more
/// residuals than parameters.
pub(crate) fn refine_mono<'a, S: CameraSlots + Clone>(
    slots: &S,
    (camera, poses): (&S::Camera, &[Isometry3]),
    object_points: &'a [Vec<DVec3>],
    image_points: &'a [Vec<DVec2>],
    lm: &LmConfig,
) -> Result<(Bundle<'a, S>, LmReport)> {
    let views: Vec<ViewObs> = object_points.iter().zip(image_points).map(|(o, i)| ViewObs::mono(o, i)).collect();
    let bundle = Bundle::new(vec![slots.clone()], views);
    let n = parallax_least_squares::Problem::num_params(&bundle);
    if bundle.num_residuals <= n {
        return Err(CalibrationError::TooFewPoints {
            what: "calibration (all views)".into(),
            got: bundle.num_residuals / 2,
            needed: n / 2 + 1,
        });
    }
    let mut x0 = vec![0.0; n];
    x0[..slots.num_free()].copy_from_slice(&slots.free_values(camera));
    for (v, p) in poses.iter().enumerate() {
        let o = bundle.view_offset(v);
        store_pose(p, &mut x0[o..o + 6]);
    }
    let report = levenberg_marquardt(&bundle, &x0, &LmConfig { covariance: true, ..*lm })?;
    Ok((bundle, report))
}

/// What a mono calibration reports of its bundle's solution, for any camera model.
pub(crate) struct MonoSolution {
    /// Camera from board, per view.
    pub poses: Vec<Isometry3>,
    /// Observed − projected, per view.
    pub residuals_px: Vec<Vec<DVec2>>,
    pub per_view_rms_px: Vec<f64>,
    pub rms_px: f64,
    pub pose_std_devs: Vec<PoseStdDevs>,
}

impl MonoSolution {
    /// The result of any lens: the camera, the solution's figures, the camera's 1σ and the
    /// warnings the caller found.
    pub(crate) fn into_result(
        self,
        camera: Camera,
        std_devs: IntrinsicStdDevs,
        num_parameters: usize,
        report: &LmReport,
        warnings: Vec<CalibrationWarning>,
    ) -> CalibrationResult {
        CalibrationResult {
            camera,
            camera_from_board: self.poses,
            rms_px: self.rms_px,
            per_view_rms_px: self.per_view_rms_px,
            residuals_px: self.residuals_px,
            std_devs,
            pose_std_devs: self.pose_std_devs,
            sigma_px: report.sigma2.sqrt(),
            dof: report.dof,
            num_parameters,
            iterations: report.iterations,
            converged: report.stop_reason.converged(),
            warnings,
        }
    }
}

/// The poses, residuals and pose 1σ of a mono `bundle` at `report`'s solution; with
/// `need_spread` (no intrinsic guess, principal point free) an error when the views are
/// parallel: they do not determine the focal length and principal point.
pub(crate) fn mono_solution<S: CameraSlots>(
    bundle: &Bundle<S>,
    report: &LmReport,
    need_spread: bool,
) -> Result<MonoSolution> {
    let poses: Vec<Isometry3> =
        (0..bundle.views.len()).map(|v| crate::bundle::pose_at(&report.params[bundle.view_offset(v)..])).collect();
    let spread = view_spread_deg(&poses);
    if need_spread && spread < PARALLEL_VIEWS_DEG {
        return Err(CalibrationError::Degenerate(format!(
            "all {} board views are parallel (normals within {spread:.2}°): they do not determine the focal \
             length and principal point; tilt the board differently in each view",
            poses.len()
        )));
    }
    let by_view = bundle.residuals_by_view(&report.params).map_err(|e| CalibrationError::EstimationFailed(e.0))?;
    let residuals_px: Vec<Vec<DVec2>> =
        by_view.into_iter().map(|mut r| r.swap_remove(0).into_iter().map(|e| -e).collect()).collect();
    let per_view_rms_px: Vec<f64> = residuals_px.iter().map(|r| rms_of(r)).collect();
    let all: Vec<DVec2> = residuals_px.iter().flatten().copied().collect();
    let cov = report.covariance.as_ref();
    let pose_std_devs = poses.iter().enumerate().map(|(v, p)| pose_std_devs(p, bundle.view_offset(v), cov)).collect();
    Ok(MonoSolution { poses, residuals_px, per_view_rms_px, rms_px: rms_of(&all), pose_std_devs })
}

pub(crate) fn diagnostics(
    warnings: &mut Vec<CalibrationWarning>,
    camera: &Camera,
    index: usize,
    poses: &[Isometry3],
    config: &CalibrationConfig,
    report: &LmReport,
) {
    if let Some(fold) = distortion_fold(camera) {
        warnings.push(CalibrationWarning::NonMonotonicDistortion { camera: index, fold });
    }
    if index == 0 {
        let recommended = recommended_views(config);
        if poses.len() < recommended {
            warnings.push(CalibrationWarning::TooFewViews { views: poses.len(), recommended });
        }
        let spread = view_spread_deg(poses);
        if config.intrinsic_guess.is_none() && spread < config.min_view_spread_deg {
            warnings.push(CalibrationWarning::SimilarViews {
                max_angle_deg: spread,
                threshold_deg: config.min_view_spread_deg,
            });
        }
        if !report.stop_reason.converged() {
            warnings.push(CalibrationWarning::NotConverged { iterations: report.iterations });
        }
    }
}

pub(crate) fn rms_of(r: &[DVec2]) -> f64 {
    if r.is_empty() {
        return 0.0;
    }
    (r.iter().map(|e| e.length_squared()).sum::<f64>() / r.len() as f64).sqrt()
}

/// Object points of a chessboard (row-major, OpenCV order, `z = 0`), once per view.
pub(crate) fn board_views(board: &Chessboard, grids: &[CornerGrid], what: &str) -> Result<Vec<Vec<DVec3>>> {
    board.validate()?;
    for (v, g) in grids.iter().enumerate() {
        if g.cols != board.cols || g.rows != board.rows || g.corners.len() != board.len() {
            return Err(CalibrationError::SizeMismatch(format!(
                "{what} view {v}: corner grid {}x{} ({} corners) but board {}x{}",
                g.cols,
                g.rows,
                g.corners.len(),
                board.cols,
                board.rows
            )));
        }
    }
    Ok(vec![board.object_points(); grids.len()])
}

/// [`calibrate_camera`] for chessboard corner grids (`CornerGrid` in OpenCV order).
pub fn calibrate_chessboard(
    board: &Chessboard,
    grids: &[CornerGrid],
    width: u32,
    height: u32,
    config: &CalibrationConfig,
) -> Result<CalibrationResult> {
    let object = board_views(board, grids, "calibration")?;
    let image: Vec<Vec<DVec2>> = grids.iter().map(|g| g.corners.clone()).collect();
    calibrate_camera(&object, &image, width, height, config)
}
