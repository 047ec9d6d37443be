//! What a calibration file holds, and the row-major records the native (RON / JSON) files use.

use glam::{DMat3, DVec3};
use parallax_camera_model::{Camera, Isometry3, Lens, LensModel, ProjectionMatrix, StereoRig};
use parallax_hand_eye::{PoseConventions, Setup};
use parallax_stereo_rectify::Rectification;
use serde::{Deserialize, Serialize};

use crate::error::{Result, content};

/// A 3x3 matrix as row-major nested arrays, `m[row][col]` (numpy's `np.array(m)`).
pub type Rows3 = [[f64; 3]; 3];

/// The rows of `m`.
pub fn rows3(m: &DMat3) -> Rows3 {
    std::array::from_fn(|r| std::array::from_fn(|c| m.col(c)[r]))
}

/// The matrix of row-major `rows`.
pub fn mat3(rows: &Rows3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(rows[0][0], rows[1][0], rows[2][0]),
        DVec3::new(rows[0][1], rows[1][1], rows[2][1]),
        DVec3::new(rows[0][2], rows[1][2], rows[2][2]),
    )
}

/// A mono camera calibration (any lens).
#[derive(Debug, Clone, PartialEq)]
pub struct MonoCalibration {
    /// The camera (intrinsics, lens, image size).
    pub camera: Camera,
    /// RMS reprojection error over all corners, pixels (OpenCV's `avg_reprojection_error`).
    pub rms_px: Option<f64>,
    /// RMS reprojection error per view, pixels.
    pub per_view_rms_px: Vec<f64>,
}

/// The rectification matrices of a stereo rig, as OpenCV's `stereoRectify` returns them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RectificationMatrices {
    /// `rectified_from_left` rotation.
    pub r1: DMat3,
    /// `rectified_from_right` rotation.
    pub r2: DMat3,
    /// Left rectified projection, 3x4.
    pub p1: ProjectionMatrix,
    /// Right rectified projection, 3x4.
    pub p2: ProjectionMatrix,
    /// Disparity-to-depth matrix, rows.
    pub q: [[f64; 4]; 4],
}

impl From<&Rectification> for RectificationMatrices {
    fn from(r: &Rectification) -> Self {
        Self { r1: r.r1, r2: r.r2, p1: r.p1, p2: r.p2, q: r.q }
    }
}

impl RectificationMatrices {
    /// These matrices as a rectification of `rig` to `size` images, checked against the rig
    /// ([`Rectification::from_matrices`]).
    pub fn to_rectification(
        &self,
        rig: &StereoRig,
        size: (u32, u32),
    ) -> std::result::Result<Rectification, parallax_stereo_rectify::RectifyError> {
        Rectification::from_matrices(rig, self.r1, self.r2, self.p1, self.p2, self.q, size)
    }
}

/// A stereo calibration (any lenses): the rig, optionally its rectification and the fit's errors.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoCalibration {
    /// Both cameras and `right_from_left` (OpenCV's `R`, `T`).
    pub rig: StereoRig,
    /// `R1 R2 P1 P2 Q` (for a wide-lens rig, of its rectification to a pinhole pair,
    /// `cv::fisheye::stereoRectify`), when the file holds them.
    pub rectification: Option<RectificationMatrices>,
    /// RMS reprojection error over both cameras, pixels.
    pub rms_px: Option<f64>,
    /// Per view `[left, right]` RMS, pixels.
    pub per_view_rms_px: Vec<[f64; 2]>,
}

/// The name of a lens model in files and messages: `kannala_brandt` (OpenCV's `fisheye`, ROS's
/// and Kalibr's `equidistant`) or `double_sphere` (Kalibr's `ds`).
pub fn lens_model_name(lens: &Lens) -> &'static str {
    match lens {
        Lens::BrownConrady(_) => "brown_conrady",
        Lens::KannalaBrandt(_) => "kannala_brandt",
        Lens::DoubleSphere(_) => "double_sphere",
    }
}

/// A hand-eye calibration result.
#[derive(Debug, Clone, PartialEq)]
pub struct HandEyeCalibration {
    /// Eye-in-hand (`transform` = `gripper_from_camera`) or eye-to-hand (`base_from_camera`).
    pub setup: Setup,
    /// `gripper_from_camera` (eye-in-hand) or `base_from_camera` (eye-to-hand).
    pub transform: Isometry3,
    /// The method that produced it, when known.
    pub method: Option<String>,
}

impl HandEyeCalibration {
    /// The name of `transform` for this setup.
    pub fn transform_name(&self) -> &'static str {
        match self.setup {
            Setup::EyeInHand => "gripper_from_camera",
            Setup::EyeToHand => "base_from_camera",
        }
    }
}

/// Any calibration-like result a file can hold.
// One value per file read: the size difference between the variants costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum Calibration {
    /// One camera (any lens).
    Mono(MonoCalibration),
    /// A stereo rig (any lenses).
    Stereo(StereoCalibration),
    /// A hand-eye transform.
    HandEye(HandEyeCalibration),
}

/// Which camera of a stereo calibration to take where one camera is needed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Side {
    /// The left (reference) camera: OpenCV's `M1 D1`, Kalibr's `cam0`.
    #[default]
    Left,
    /// The right camera: `M2 D2`, `cam1`.
    Right,
}

impl Calibration {
    /// `"mono camera calibration"`, `"stereo calibration"` or `"hand-eye transform"` (for
    /// messages).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Mono(_) => "mono camera calibration",
            Self::Stereo(_) => "stereo calibration",
            Self::HandEye(_) => "hand-eye transform",
        }
    }

    /// The lens model of the (left) camera; `None` for hand-eye.
    pub fn lens_model(&self) -> Option<LensModel> {
        match self {
            Self::Mono(m) => Some(m.camera.lens_model()),
            Self::Stereo(s) => Some(s.rig.left.lens_model()),
            Self::HandEye(_) => None,
        }
    }

    /// The stereo calibration, or an error naming what the file holds instead.
    pub fn into_stereo(self, what: &str) -> Result<StereoCalibration> {
        match self {
            Self::Stereo(s) => Ok(s),
            other => Err(content(
                what,
                format!(
                    "holds a {}, not a stereo rig: give the output of `calibrate --right ...` (or two ROS \
                     camera_info files, left then right, or OpenCV's intrinsics.yml and extrinsics.yml)",
                    other.kind()
                ),
            )),
        }
    }

    /// One camera: the mono calibration's, or the chosen side of a stereo rig.
    pub fn camera(&self, side: Side, what: &str) -> Result<Camera> {
        match (self, side) {
            (Self::Mono(m), _) => Ok(m.camera),
            (Self::Stereo(s), Side::Left) => Ok(s.rig.left),
            (Self::Stereo(s), Side::Right) => Ok(s.rig.right),
            (Self::HandEye(_), _) => {
                Err(content(what, "holds a hand-eye transform, not camera intrinsics: give a calibrate result"))
            }
        }
    }
}

/// A rigid transform in every common convention, for the native files: translation,
/// quaternion `(x, y, z, w)` with `w ≥ 0`, row-major rotation matrix, rotation vector in radians
/// (OpenCV's `rvec`) and the ROS `tf` order `x y z qx qy qz qw`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseRecord {
    /// `[x, y, z]`, the data's length unit.
    pub translation: [f64; 3],
    /// Unit quaternion `[x, y, z, w]`, `w ≥ 0`.
    pub quaternion_xyzw: [f64; 4],
    /// Rotation matrix, row-major.
    pub rotation_matrix: Rows3,
    /// Rotation vector (axis × angle), radians.
    pub rotation_vector_rad: [f64; 3],
    /// ROS `tf` order: `x y z qx qy qz qw` (what `static_transform_publisher` takes).
    pub tf: String,
}

impl PoseRecord {
    /// Every form of `t`.
    pub fn of(t: &Isometry3) -> Self {
        let c = PoseConventions::of(t);
        Self {
            translation: c.translation,
            quaternion_xyzw: c.quaternion_xyzw,
            rotation_matrix: c.matrix_row_major,
            rotation_vector_rad: c.rotation_vector,
            tf: c.tf_line(),
        }
    }
}

/// The OpenCV-named matrices of one camera, row-major, in the native files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MonoMatrices {
    /// `K`, 3x3.
    pub camera_matrix: Rows3,
    /// `k1 k2 p1 p2 k3` (plus `k4 k5 k6` for the rational model).
    pub distortion_coefficients: Vec<f64>,
    /// Image width, pixels.
    pub image_width: u32,
    /// Image height, pixels.
    pub image_height: u32,
}

/// OpenCV's distortion vector of `camera`: 5 values, or 8 with the rational model.
pub fn distortion_vector(camera: &Camera) -> Vec<f64> {
    match camera.distortion() {
        Some(d) if d.is_rational() => d.to_array().to_vec(),
        Some(d) => d.to_array()[..5].to_vec(),
        // (`Calibration::camera` hands pinhole stages Brown–Conrady cameras only)
        None => camera.lens.parameters(),
    }
}

impl MonoMatrices {
    /// The matrices of `camera`.
    pub fn of(camera: &Camera) -> Self {
        Self {
            camera_matrix: rows3(&camera.intrinsics.matrix()),
            distortion_coefficients: distortion_vector(camera),
            image_width: camera.width,
            image_height: camera.height,
        }
    }
}

/// A stereo rig and its rectification under OpenCV's names, row-major (`stereo_calib.cpp`'s
/// `M1 D1 M2 D2` and `R T E F R1 R2 P1 P2 Q`), in the native files.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StereoMatrices {
    /// Image width, pixels (both cameras).
    pub image_width: u32,
    /// Image height, pixels.
    pub image_height: u32,
    /// Left `K`.
    pub M1: Rows3,
    /// Left distortion.
    pub D1: Vec<f64>,
    /// Right `K`.
    pub M2: Rows3,
    /// Right distortion.
    pub D2: Vec<f64>,
    /// `right_from_left` rotation.
    pub R: Rows3,
    /// `right_from_left` translation.
    pub T: [f64; 3],
    /// Essential matrix `[T]× R`.
    pub E: Rows3,
    /// Fundamental matrix `M2⁻ᵀ E M1⁻¹`.
    pub F: Rows3,
    /// `rectified_from_left`.
    pub R1: Option<Rows3>,
    /// `rectified_from_right`.
    pub R2: Option<Rows3>,
    /// Left rectified projection.
    pub P1: Option<[[f64; 4]; 3]>,
    /// Right rectified projection.
    pub P2: Option<[[f64; 4]; 3]>,
    /// Disparity-to-depth.
    pub Q: Option<[[f64; 4]; 4]>,
}

impl StereoMatrices {
    /// The matrices of `s`.
    pub fn of(s: &StereoCalibration) -> Self {
        let rig = &s.rig;
        let r = s.rectification.as_ref();
        Self {
            image_width: rig.left.width,
            image_height: rig.left.height,
            M1: rows3(&rig.left.intrinsics.matrix()),
            D1: distortion_vector(&rig.left),
            M2: rows3(&rig.right.intrinsics.matrix()),
            D2: distortion_vector(&rig.right),
            R: rows3(&rig.right_from_left.rotation_matrix()),
            T: rig.right_from_left.translation.to_array(),
            E: rows3(&rig.essential()),
            F: rows3(&rig.fundamental()),
            R1: r.map(|r| rows3(&r.r1)),
            R2: r.map(|r| rows3(&r.r2)),
            P1: r.map(|r| r.p1.rows),
            P2: r.map(|r| r.p2.rows),
            Q: r.map(|r| r.q),
        }
    }
}

/// The OpenCV matrices of a camera in a native record: `calibrateCamera`'s (`K`, `D` of 5 or 8
/// Brown–Conrady coefficients), or `cv::fisheye`'s for Kannala–Brandt (`None` for a lens OpenCV
/// has no model of: double sphere).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum OpenCvCamera {
    /// `camera_matrix`, `distortion_coefficients` (Brown–Conrady).
    CalibrateCamera(MonoMatrices),
    /// `cv::fisheye`'s `K` and `D` with the marker `fisheye_model: 1`, or `None`.
    Fisheye(Option<KannalaBrandtMatrices>),
}

impl OpenCvCamera {
    /// The matrices of `camera`, by its lens.
    pub fn of(camera: &Camera) -> Self {
        match camera.lens_model() {
            LensModel::BrownConrady => Self::CalibrateCamera(MonoMatrices::of(camera)),
            _ => Self::Fisheye(KannalaBrandtMatrices::of(camera)),
        }
    }
}

/// The native (RON / JSON) record of a mono calibration: the camera in the project's own form
/// (what is read back), for a wide lens the model's name, and its OpenCV-named matrices,
/// row-major (checked against it on reading).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MonoRecord {
    /// The camera.
    pub camera: Camera,
    /// A wide lens's model, `kannala_brandt` or `double_sphere` (absent for Brown–Conrady).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lens_model: Option<&'static str>,
    /// The same camera as OpenCV's matrices.
    pub opencv: OpenCvCamera,
    /// RMS reprojection error, pixels.
    pub rms_px: Option<f64>,
    /// Per-view RMS, pixels.
    pub per_view_rms_px: Vec<f64>,
}

impl MonoRecord {
    /// The record of `m`.
    pub fn of(m: &MonoCalibration) -> Self {
        let wide = m.camera.lens_model().is_wide();
        Self {
            camera: m.camera,
            lens_model: wide.then(|| lens_model_name(&m.camera.lens())),
            opencv: OpenCvCamera::of(&m.camera),
            rms_px: m.rms_px,
            per_view_rms_px: m.per_view_rms_px.clone(),
        }
    }
}

/// Writes a field that is present (`Some`) as its value (RON's `Some(…)` would change the
/// file's form); absent fields are skipped.
fn present<T: Serialize, S: serde::Serializer>(v: &Option<T>, s: S) -> std::result::Result<S::Ok, S::Error> {
    match v {
        Some(v) => v.serialize(s),
        None => s.serialize_none(),
    }
}

/// The native record of a stereo calibration: the rig in the project's own form (what is read
/// back; rotation as a quaternion), for wide lenses the model's name, `right_from_left` in every
/// convention, and for Brown–Conrady rigs the OpenCV-named matrices, row-major (checked against
/// the rig on reading), for wide rigs `R1 R2 P1 P2 Q` of the pinhole rectification when known.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StereoRecord {
    /// The rig.
    pub rig: StereoRig,
    /// A wide-lens rig's model, `kannala_brandt` or `double_sphere` (absent for Brown–Conrady).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lens_model: Option<&'static str>,
    /// `right_from_left` as translation, quaternion, matrix, rotation vector and tf line.
    pub right_from_left: PoseRecord,
    /// A Brown–Conrady rig and its rectification under OpenCV's names.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "present")]
    pub opencv: Option<StereoMatrices>,
    /// A wide-lens rig: `R1 R2 P1 P2 Q` of its rectification to a pinhole pair, when known.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "present")]
    pub rectification: Option<Option<RectificationRows>>,
    /// RMS reprojection error over both cameras, pixels.
    pub rms_px: Option<f64>,
    /// Per view `[left, right]` RMS, pixels.
    pub per_view_rms_px: Vec<[f64; 2]>,
}

impl StereoRecord {
    /// The record of `s`.
    pub fn of(s: &StereoCalibration) -> Self {
        let wide = s.rig.has_wide_lens();
        Self {
            rig: s.rig,
            lens_model: wide.then(|| lens_model_name(&s.rig.left.lens())),
            right_from_left: PoseRecord::of(&s.rig.right_from_left),
            opencv: (!wide).then(|| StereoMatrices::of(s)),
            rectification: wide.then(|| s.rectification.as_ref().map(RectificationRows::from)),
            rms_px: s.rms_px,
            per_view_rms_px: s.per_view_rms_px.clone(),
        }
    }
}

/// `"eye_in_hand"` or `"eye_to_hand"` (a string: RON's unit variants do not survive a
/// format-independent reading).
pub fn setup_name(setup: Setup) -> &'static str {
    match setup {
        Setup::EyeInHand => "eye_in_hand",
        Setup::EyeToHand => "eye_to_hand",
    }
}

/// The setup of a name: `eye_in_hand` / `eye_to_hand` (also `-` for `_`, and serde's
/// `EyeInHand` / `EyeToHand`).
pub fn setup_from_name(name: &str) -> Option<Setup> {
    match name.to_ascii_lowercase().replace(['-', '_'], "").as_str() {
        "eyeinhand" => Some(Setup::EyeInHand),
        "eyetohand" => Some(Setup::EyeToHand),
        _ => None,
    }
}

/// The native record of a hand-eye result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HandEyeRecord {
    /// `eye_in_hand` or `eye_to_hand`.
    pub setup: &'static str,
    /// `gripper_from_camera` or `base_from_camera`.
    pub name: String,
    /// The method.
    pub method: Option<String>,
    /// The transform in the project's own form (what is read back).
    pub transform: Isometry3,
    /// The transform in every convention.
    pub pose: PoseRecord,
}

impl HandEyeRecord {
    /// The record of `h`.
    pub fn of(h: &HandEyeCalibration) -> Self {
        Self {
            setup: setup_name(h.setup),
            name: h.transform_name().to_string(),
            method: h.method.clone(),
            transform: h.transform,
            pose: PoseRecord::of(&h.transform),
        }
    }
}

/// The native record of a rectification (what `cargo xtask rectify` writes): the calibration
/// with `R1 R2 P1 P2 Q` (row-major, under `calibration.opencv`) and the rectified geometry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RectifiedRecord {
    /// The rig, its OpenCV matrices and the rectification.
    pub calibration: StereoRecord,
    /// Size of the rectified images, pixels.
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// Valid-pixel rectangle of the rectified left image.
    pub roi_left: parallax_stereo_rectify::Roi,
    /// Valid-pixel rectangle of the rectified right image.
    pub roi_right: parallax_stereo_rectify::Roi,
    /// Baseline along `y` (images stacked) instead of `x`.
    pub vertical: bool,
    /// Rectified focal length, pixels.
    pub focal_px: f64,
    /// Baseline in the rectified frame (`Tx`, or `Ty` when vertical), the rig's length unit.
    pub rectified_baseline: f64,
    /// The focal scale `alpha` applied (1 without `alpha`).
    pub scale: f64,
}

impl RectifiedRecord {
    /// The record of `calibration` rectified as `rect` (its `rectification` is replaced by `rect`'s).
    pub fn of(calibration: &StereoCalibration, rect: &Rectification) -> Self {
        let c = StereoCalibration { rectification: Some(RectificationMatrices::from(rect)), ..calibration.clone() };
        Self {
            calibration: StereoRecord::of(&c),
            width: rect.width,
            height: rect.height,
            roi_left: rect.roi1,
            roi_right: rect.roi2,
            vertical: rect.vertical,
            focal_px: rect.focal(),
            rectified_baseline: rect.rectified_baseline(),
            scale: rect.scale,
        }
    }
}

/// OpenCV's `cv::fisheye` matrices of a Kannala–Brandt camera, row-major, in the native files:
/// `K` and `D = [k1 k2 k3 k4]`, with the marker `fisheye_model: 1` of OpenCV's calibration
/// sample (`camera_calibration.cpp`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KannalaBrandtMatrices {
    /// `1`: `distortion_coefficients` are `cv::fisheye`'s `k1 k2 k3 k4`.
    pub fisheye_model: u8,
    /// `K`, 3x3.
    pub camera_matrix: Rows3,
    /// `k1 k2 k3 k4`.
    pub distortion_coefficients: Vec<f64>,
    /// Image width, pixels.
    pub image_width: u32,
    /// Image height, pixels.
    pub image_height: u32,
}

impl KannalaBrandtMatrices {
    /// The matrices of `camera`, or `None` for a lens `cv::fisheye` has no model of.
    pub fn of(camera: &Camera) -> Option<Self> {
        let Lens::KannalaBrandt(kb) = camera.lens() else { return None };
        Some(Self {
            fisheye_model: 1,
            camera_matrix: rows3(&camera.intrinsics().matrix()),
            distortion_coefficients: kb.coefficients().to_vec(),
            image_width: camera.width(),
            image_height: camera.height(),
        })
    }
}

/// `R1 R2 P1 P2 Q`, row-major, under OpenCV's names.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RectificationRows {
    /// `rectified_from_left`.
    pub R1: Rows3,
    /// `rectified_from_right`.
    pub R2: Rows3,
    /// Left rectified projection.
    pub P1: [[f64; 4]; 3],
    /// Right rectified projection.
    pub P2: [[f64; 4]; 3],
    /// Disparity-to-depth.
    pub Q: [[f64; 4]; 4],
}

impl From<&RectificationMatrices> for RectificationRows {
    fn from(r: &RectificationMatrices) -> Self {
        Self { R1: rows3(&r.r1), R2: rows3(&r.r2), P1: r.p1.rows, P2: r.p2.rows, Q: r.q }
    }
}
