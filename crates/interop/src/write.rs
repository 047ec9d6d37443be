//! Writers: each format's text of a [`Calibration`].

use std::path::{Path, PathBuf};

use parallax_camera_model::{Camera, Isometry3, Lens, LensModel};
use serde::Serialize;

use crate::error::{InteropError, Result};
use crate::model::{
    Calibration, HandEyeRecord, MonoCalibration, MonoRecord, RectificationMatrices, StereoCalibration, StereoRecord,
    distortion_vector, rows3,
};
use crate::opencv::Entry;
use crate::{Format, rectify_default};

fn entries_mono(m: &MonoCalibration) -> Vec<(String, Entry)> {
    let c = &m.camera;
    let mut e = vec![
        ("image_width".to_string(), Entry::Int(i64::from(c.width))),
        ("image_height".to_string(), Entry::Int(i64::from(c.height))),
        ("camera_matrix".to_string(), Entry::matrix(&rows3(&c.intrinsics.matrix()))),
        ("distortion_coefficients".to_string(), Entry::col_vector(&distortion_vector(c))),
    ];
    if let Some(rms) = m.rms_px {
        e.push(("avg_reprojection_error".to_string(), Entry::Real(rms)));
    }
    if !m.per_view_rms_px.is_empty() {
        e.push(("per_view_reprojection_errors".to_string(), Entry::col_vector(&m.per_view_rms_px)));
    }
    e
}

fn entries_stereo(s: &StereoCalibration) -> Vec<(String, Entry)> {
    let rig = &s.rig;
    let mut e = vec![
        ("image_width".to_string(), Entry::Int(i64::from(rig.left.width))),
        ("image_height".to_string(), Entry::Int(i64::from(rig.left.height))),
    ];
    if (rig.right.width, rig.right.height) != (rig.left.width, rig.left.height) {
        e.push(("right_image_width".to_string(), Entry::Int(i64::from(rig.right.width))));
        e.push(("right_image_height".to_string(), Entry::Int(i64::from(rig.right.height))));
    }
    e.extend([
        ("M1".to_string(), Entry::matrix(&rows3(&rig.left.intrinsics.matrix()))),
        ("D1".to_string(), Entry::row_vector(&distortion_vector(&rig.left))),
        ("M2".to_string(), Entry::matrix(&rows3(&rig.right.intrinsics.matrix()))),
        ("D2".to_string(), Entry::row_vector(&distortion_vector(&rig.right))),
        ("R".to_string(), Entry::matrix(&rows3(&rig.right_from_left.rotation_matrix()))),
        ("T".to_string(), Entry::col_vector(&rig.right_from_left.translation.to_array())),
        ("E".to_string(), Entry::matrix(&rows3(&rig.essential()))),
        ("F".to_string(), Entry::matrix(&rows3(&rig.fundamental()))),
    ]);
    if let Some(r) = &s.rectification {
        e.extend(rectification_entries(r));
    }
    if let Some(rms) = s.rms_px {
        e.push(("avg_reprojection_error".to_string(), Entry::Real(rms)));
    }
    if !s.per_view_rms_px.is_empty() {
        e.push(("per_view_reprojection_errors".to_string(), Entry::matrix(&s.per_view_rms_px)));
    }
    e
}

fn entries_hand_eye(h: &crate::HandEyeCalibration) -> Vec<(String, Entry)> {
    let (r, t) = match h.setup {
        parallax_hand_eye::Setup::EyeInHand => ("R_cam2gripper", "t_cam2gripper"),
        parallax_hand_eye::Setup::EyeToHand => ("R_cam2base", "t_cam2base"),
    };
    let mut e = vec![
        (r.to_string(), Entry::matrix(&rows3(&h.transform.rotation_matrix()))),
        (t.to_string(), Entry::col_vector(&h.transform.translation.to_array())),
    ];
    if let Some(m) = &h.method {
        e.push(("method".to_string(), Entry::Text(m.clone())));
    }
    e
}

/// The terms a calibration will estimate, for [`check_model_fits`] before it runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModelTerms {
    /// The lens model.
    pub lens: LensModel,
    /// Whether the skew is estimated.
    pub skew: bool,
    /// Whether Brown–Conrady's `k3` is estimated.
    pub k3: bool,
    /// Whether the rational terms `k4 k5 k6` are estimated.
    pub rational: bool,
}

/// Refuses, before any calibration work, a model that `format` cannot hold: a double sphere in
/// OpenCV or ROS files; skew in a Kalibr camchain; `k3` or `k4..k6` in Kalibr's `radtan`. The
/// writers check the values again; this check moves their refusal ahead of the calibration.
pub fn check_model_fits(format: Format, terms: ModelTerms) -> Result<()> {
    match format {
        Format::OpenCvYaml | Format::OpenCvXml if terms.lens == LensModel::DoubleSphere => {
            Err(no_double_sphere("OpenCV"))
        }
        Format::Ros if terms.lens == LensModel::DoubleSphere => Err(no_double_sphere("ROS camera_info")),
        Format::Kalibr if terms.skew => Err(InteropError::Unsupported(
            "Kalibr's camera models have no skew: calibrate without skew to write Kalibr".into(),
        )),
        Format::Kalibr if terms.lens == LensModel::BrownConrady && (terms.k3 || terms.rational) => {
            Err(InteropError::Unsupported(
                "Kalibr's pinhole-radtan model has no k3 or k4..k6: calibrate with --fix-k3 (and without \
                 --rational) to write Kalibr"
                    .into(),
            ))
        }
        _ => Ok(()),
    }
}

/// The refusal to write a double-sphere camera to a format that has no such model.
fn no_double_sphere(format: &str) -> InteropError {
    InteropError::Unsupported(format!(
        "a double-sphere camera has no {format} representation (OpenCV and ROS camera_info know pinhole and \
         Kannala–Brandt/equidistant lenses only): write it as kalibr (camera_model: ds), ron or json"
    ))
}

/// `cv::fisheye`'s `K` and `D = [k1 k2 k3 k4]` of a Kannala–Brandt camera.
fn fisheye_kd(c: &Camera, format: &str) -> Result<(Entry, [f64; 4])> {
    match c.lens() {
        Lens::KannalaBrandt(kb) => Ok((Entry::matrix(&rows3(&c.intrinsics().matrix())), kb.coefficients())),
        Lens::DoubleSphere(_) => Err(no_double_sphere(format)),
        Lens::BrownConrady(_) => Err(InteropError::Unsupported(format!("{format}: not a fisheye camera"))),
    }
}

/// OpenCV's calibration sample (`camera_calibration.cpp`) with its fisheye option: the marker
/// `fisheye_model: 1`, `camera_matrix`, `distortion_coefficients` 4x1 (`k1 k2 k3 k4`).
fn entries_fisheye_mono(m: &MonoCalibration) -> Result<Vec<(String, Entry)>> {
    let c = &m.camera;
    let (k, d) = fisheye_kd(c, "OpenCV")?;
    let mut e = vec![
        ("image_width".to_string(), Entry::Int(i64::from(c.width()))),
        ("image_height".to_string(), Entry::Int(i64::from(c.height()))),
        ("fisheye_model".to_string(), Entry::Int(1)),
        ("camera_matrix".to_string(), k),
        ("distortion_coefficients".to_string(), Entry::col_vector(&d)),
    ];
    if let Some(rms) = m.rms_px {
        e.push(("avg_reprojection_error".to_string(), Entry::Real(rms)));
    }
    if !m.per_view_rms_px.is_empty() {
        e.push(("per_view_reprojection_errors".to_string(), Entry::col_vector(&m.per_view_rms_px)));
    }
    Ok(e)
}

/// `stereo_calib.cpp`'s keys for a `cv::fisheye::stereoCalibrate` result, with the marker
/// `fisheye_model: 1`: `M1 D1 M2 D2` (`D` 1x4), `R T E` and `cv::fisheye::stereoRectify`'s
/// `R1 R2 P1 P2 Q` when known. No `F`: pixels of a fisheye image are not related by one.
fn entries_fisheye_stereo(s: &StereoCalibration) -> Result<Vec<(String, Entry)>> {
    let rig = &s.rig;
    let (m1, d1) = fisheye_kd(&rig.left, "OpenCV")?;
    let (m2, d2) = fisheye_kd(&rig.right, "OpenCV")?;
    let mut e = vec![
        ("image_width".to_string(), Entry::Int(i64::from(rig.left.width()))),
        ("image_height".to_string(), Entry::Int(i64::from(rig.left.height()))),
    ];
    if (rig.right.width(), rig.right.height()) != (rig.left.width(), rig.left.height()) {
        e.push(("right_image_width".to_string(), Entry::Int(i64::from(rig.right.width()))));
        e.push(("right_image_height".to_string(), Entry::Int(i64::from(rig.right.height()))));
    }
    e.extend([
        ("fisheye_model".to_string(), Entry::Int(1)),
        ("M1".to_string(), m1),
        ("D1".to_string(), Entry::row_vector(&d1)),
        ("M2".to_string(), m2),
        ("D2".to_string(), Entry::row_vector(&d2)),
        ("R".to_string(), Entry::matrix(&rows3(&rig.right_from_left.rotation_matrix()))),
        ("T".to_string(), Entry::col_vector(&rig.right_from_left.translation.to_array())),
        ("E".to_string(), Entry::matrix(&rows3(&rig.essential()))),
    ]);
    if let Some(r) = &s.rectification {
        e.extend(rectification_entries(r));
    }
    if let Some(rms) = s.rms_px {
        e.push(("avg_reprojection_error".to_string(), Entry::Real(rms)));
    }
    if !s.per_view_rms_px.is_empty() {
        e.push(("per_view_reprojection_errors".to_string(), Entry::matrix(&s.per_view_rms_px)));
    }
    Ok(e)
}

fn rectification_entries(r: &RectificationMatrices) -> [(String, Entry); 5] {
    [
        ("R1".to_string(), Entry::matrix(&rows3(&r.r1))),
        ("R2".to_string(), Entry::matrix(&rows3(&r.r2))),
        ("P1".to_string(), Entry::matrix(&r.p1.rows)),
        ("P2".to_string(), Entry::matrix(&r.p2.rows)),
        ("Q".to_string(), Entry::matrix(&r.q)),
    ]
}

/// Refuses a rig whose two lenses are of different families (Brown–Conrady and a wide lens):
/// the OpenCV and ROS files mark the whole file (or pair) with one model.
fn one_family(s: &StereoCalibration, format: &str) -> Result<bool> {
    let (l, r) = (s.rig.left.lens_model(), s.rig.right.lens_model());
    if l.is_wide() != r.is_wide() {
        return Err(InteropError::Unsupported(format!(
            "{format} marks both cameras of a rig with one lens family, and this rig has a {l} and a {r} lens: \
             write it as ron, json or kalibr"
        )));
    }
    Ok(l.is_wide())
}

/// OpenCV FileStorage entries of `c` (the key names of OpenCV's calibration samples; a
/// Kannala–Brandt camera marked `fisheye_model: 1` as `camera_calibration.cpp` does). A
/// double-sphere camera is refused: OpenCV has no such model.
pub fn opencv_entries(c: &Calibration) -> Result<Vec<(String, Entry)>> {
    Ok(match c {
        Calibration::Mono(m) if m.camera.lens_model().is_wide() => entries_fisheye_mono(m)?,
        Calibration::Mono(m) => entries_mono(m),
        Calibration::Stereo(s) if one_family(s, "OpenCV")? => entries_fisheye_stereo(s)?,
        Calibration::Stereo(s) => entries_stereo(s),
        Calibration::HandEye(h) => entries_hand_eye(h),
    })
}

#[derive(Serialize)]
struct RosMatrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl RosMatrix {
    fn of<const C: usize>(rows: &[[f64; C]]) -> Self {
        Self { rows: rows.len(), cols: C, data: rows.iter().flatten().copied().collect() }
    }
}

/// ROS `sensor_msgs/CameraInfo` calibration YAML (`camera_calibration_parsers`' layout).
#[derive(Serialize)]
struct RosCameraInfo {
    image_width: u32,
    image_height: u32,
    camera_name: String,
    camera_matrix: RosMatrix,
    distortion_model: &'static str,
    distortion_coefficients: RosMatrix,
    rectification_matrix: RosMatrix,
    projection_matrix: RosMatrix,
}

/// A camera as ROS knows it: size, `K`, the distortion model's name and its coefficients.
struct RosLens {
    width: u32,
    height: u32,
    k: glam::DMat3,
    model: &'static str,
    d: Vec<f64>,
}

impl RosLens {
    /// ROS's `plumb_bob` / `rational_polynomial` for Brown–Conrady, `equidistant` for
    /// Kannala–Brandt (what `camera_calibration` writes for a fisheye: OpenCV's `cv::fisheye`,
    /// `D = [k1 k2 k3 k4]`); a double sphere is refused.
    fn of(c: &Camera) -> Result<Self> {
        match c.lens() {
            Lens::KannalaBrandt(kb) => Ok(Self {
                width: c.width(),
                height: c.height(),
                k: c.intrinsics().matrix(),
                model: "equidistant",
                d: kb.coefficients().to_vec(),
            }),
            Lens::DoubleSphere(_) => Err(no_double_sphere("ROS camera_info")),
            Lens::BrownConrady(_) => {
                let d = distortion_vector(c);
                let model = if d.len() == 8 { "rational_polynomial" } else { "plumb_bob" };
                Ok(Self { width: c.width, height: c.height, k: c.intrinsics.matrix(), model, d })
            }
        }
    }
}

fn ros_camera(name: &str, camera: &RosLens, r: glam::DMat3, p: [[f64; 4]; 3]) -> Result<String> {
    let d = camera.d.clone();
    let info = RosCameraInfo {
        image_width: camera.width,
        image_height: camera.height,
        camera_name: name.to_string(),
        camera_matrix: RosMatrix::of(&rows3(&camera.k)),
        distortion_model: camera.model,
        distortion_coefficients: RosMatrix { rows: 1, cols: d.len(), data: d },
        rectification_matrix: RosMatrix::of(&rows3(&r)),
        projection_matrix: RosMatrix::of(&p),
    };
    serde_yaml_ng::to_string(&info).map_err(|e| InteropError::Unsupported(format!("ROS camera_info: {e}")))
}

/// The ROS file names of a stereo pair written to `path`: `<stem>_left.yaml`, `<stem>_right.yaml`.
pub fn ros_pair_paths(path: &Path) -> [PathBuf; 2] {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "camera".into());
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "yaml".into());
    [path.with_file_name(format!("{stem}_left.{ext}")), path.with_file_name(format!("{stem}_right.{ext}"))]
}

/// One camera_info of a mono camera: `R = I`, `P = [K | 0]`.
fn ros_mono(path: &Path, lens: RosLens) -> Result<Vec<(PathBuf, String)>> {
    let kr = rows3(&lens.k);
    let p =
        [[kr[0][0], kr[0][1], kr[0][2], 0.0], [kr[1][0], kr[1][1], kr[1][2], 0.0], [kr[2][0], kr[2][1], kr[2][2], 0.0]];
    Ok(vec![(path.to_path_buf(), ros_camera("camera", &lens, glam::DMat3::IDENTITY, p)?)])
}

fn ros_pair(path: &Path, left: RosLens, right: RosLens, r: &RectificationMatrices) -> Result<Vec<(PathBuf, String)>> {
    let [lp, rp] = ros_pair_paths(path);
    Ok(vec![(lp, ros_camera("left", &left, r.r1, r.p1.rows)?), (rp, ros_camera("right", &right, r.r2, r.p2.rows)?)])
}

fn ros(c: &Calibration, path: &Path) -> Result<Vec<(PathBuf, String)>> {
    match c {
        Calibration::Mono(m) => ros_mono(path, RosLens::of(&m.camera)?),
        Calibration::Stereo(s) => {
            one_family(s, "ROS camera_info")?;
            let (left, right) = (RosLens::of(&s.rig.left)?, RosLens::of(&s.rig.right)?);
            let r = match s.rectification {
                Some(r) => r,
                None => rectify_default(&s.rig)?,
            };
            ros_pair(path, left, right, &r)
        }
        Calibration::HandEye(_) => Err(InteropError::Unsupported(
            "ROS camera_info holds camera intrinsics, not a hand-eye transform: write it as ron, json or opencv \
             (the tf line is printed and in the ron/json record)"
                .into(),
        )),
    }
}

/// One camera of a Kalibr camchain, its keys in the order Kalibr's `kalibr_calibrate_cameras`
/// writes them (`T_cn_cnm1` from the second camera on, `cam_overlaps`, …, `rostopic`): Kalibr's
/// own tools (`kalibr_calibrate_imu_camera`, the camchain parser) read `rostopic` and
/// `cam_overlaps`.
#[derive(Serialize)]
#[allow(non_snake_case)]
struct KalibrCamera {
    #[serde(skip_serializing_if = "Option::is_none")]
    T_cn_cnm1: Option<[[f64; 4]; 4]>,
    cam_overlaps: Vec<usize>,
    camera_model: &'static str,
    distortion_coeffs: Vec<f64>,
    distortion_model: &'static str,
    intrinsics: Vec<f64>,
    resolution: [u32; 2],
    rostopic: String,
}

/// `camN` of a camchain of `count` cameras that all see one another (a calibrated rig):
/// `cam_overlaps` the others, `rostopic` Kalibr's default `/camN/image_raw`.
fn kalibr_chain_entry(mut camera: KalibrCamera, n: usize, count: usize) -> (String, KalibrCamera) {
    camera.cam_overlaps = (0..count).filter(|&k| k != n).collect();
    camera.rostopic = format!("/cam{n}/image_raw");
    (format!("cam{n}"), camera)
}

fn kalibr_camera(c: &Camera, name: &str, t: Option<&Isometry3>) -> Result<KalibrCamera> {
    let k = c.intrinsics;
    let Some(&d) = c.distortion() else { return kalibr_fisheye(c, name, t) };
    if k.skew != 0.0 || d.k3 != 0.0 || d.is_rational() {
        return Err(InteropError::Unsupported(format!(
            "{name}: Kalibr's pinhole-radtan model has no skew, k3 or k4..k6 (this camera has skew {}, k3 {}, k4..k6 \
             {:?}); calibrate with --fix-k3 (and without --rational) to write Kalibr",
            k.skew,
            d.k3,
            [d.k4, d.k5, d.k6]
        )));
    }
    Ok(KalibrCamera {
        camera_model: "pinhole",
        intrinsics: vec![k.fx, k.fy, k.cx, k.cy],
        distortion_model: "radtan",
        distortion_coeffs: vec![d.k1, d.k2, d.p1, d.p2],
        resolution: [c.width, c.height],
        T_cn_cnm1: t.map(kalibr_transform),
        cam_overlaps: Vec::new(),
        rostopic: String::new(),
    })
}

/// `T_cn_cnm1`: the 4x4 matrix of `cam1_from_cam0`.
fn kalibr_transform(t: &Isometry3) -> [[f64; 4]; 4] {
    let m = rows3(&t.rotation_matrix());
    let p = t.translation;
    [
        [m[0][0], m[0][1], m[0][2], p.x],
        [m[1][0], m[1][1], m[1][2], p.y],
        [m[2][0], m[2][1], m[2][2], p.z],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Kalibr's `pinhole-equi` (`camera_model: pinhole`, `distortion_model: equidistant`,
/// intrinsics `[fu fv pu pv]`, coefficients `[k1 k2 k3 k4]`) or `ds` (intrinsics
/// `[xi alpha fu fv pu pv]`, `distortion_model: none`, no coefficients).
fn kalibr_fisheye(c: &Camera, name: &str, t: Option<&Isometry3>) -> Result<KalibrCamera> {
    let k = c.intrinsics();
    if k.skew != 0.0 {
        return Err(InteropError::Unsupported(format!(
            "{name}: Kalibr's camera models have no skew (this camera has {}); calibrate without skew to write \
             Kalibr",
            k.skew
        )));
    }
    let (camera_model, intrinsics, distortion_model, distortion_coeffs) = match c.lens() {
        Lens::KannalaBrandt(kb) => ("pinhole", vec![k.fx, k.fy, k.cx, k.cy], "equidistant", kb.coefficients().to_vec()),
        Lens::DoubleSphere(ds) => ("ds", vec![ds.xi(), ds.alpha(), k.fx, k.fy, k.cx, k.cy], "none", vec![]),
        Lens::BrownConrady(_) => return kalibr_camera(c, name, t),
    };
    Ok(KalibrCamera {
        camera_model,
        intrinsics,
        distortion_model,
        distortion_coeffs,
        resolution: [c.width(), c.height()],
        T_cn_cnm1: t.map(kalibr_transform),
        cam_overlaps: Vec::new(),
        rostopic: String::new(),
    })
}

fn kalibr(c: &Calibration) -> Result<String> {
    let mut chain = std::collections::BTreeMap::new();
    match c {
        Calibration::Mono(m) => {
            chain.extend([kalibr_chain_entry(kalibr_camera(&m.camera, "cam0", None)?, 0, 1)]);
        }
        Calibration::Stereo(s) => {
            chain.extend([
                kalibr_chain_entry(kalibr_camera(&s.rig.left, "cam0", None)?, 0, 2),
                kalibr_chain_entry(kalibr_camera(&s.rig.right, "cam1", Some(&s.rig.right_from_left))?, 1, 2),
            ]);
        }
        Calibration::HandEye(_) => {
            return Err(InteropError::Unsupported(
                "a Kalibr camchain holds cameras, not a hand-eye transform: write it as ron, json or opencv".into(),
            ));
        }
    }
    serde_yaml_ng::to_string(&chain).map_err(|e| InteropError::Unsupported(format!("Kalibr camchain: {e}")))
}

/// Pretty RON or JSON of any serialisable record (the commands' own result files).
pub fn native_string<T: Serialize>(value: &T, format: Format) -> Result<String> {
    match format {
        Format::Ron => ron::ser::to_string_pretty(value, ron::ser::PrettyConfig::default())
            .map_err(|e| InteropError::Unsupported(format!("RON: {e}"))),
        Format::Json => serde_json::to_string_pretty(value)
            .map(|mut s| {
                s.push('\n');
                s
            })
            .map_err(|e| InteropError::Unsupported(format!("JSON: {e}"))),
        other => Err(InteropError::Unsupported(format!(
            "{} is a calibration format; this result is written as ron or json",
            other.name()
        ))),
    }
}

/// The native record of a calibration (what [`native_string`] writes for it).
pub fn record_string(c: &Calibration, format: Format) -> Result<String> {
    match c {
        Calibration::Mono(m) => native_string(&MonoRecord::of(m), format),
        Calibration::Stereo(s) => native_string(&StereoRecord::of(s), format),
        Calibration::HandEye(h) => native_string(&HandEyeRecord::of(h), format),
    }
}

/// The files (path, text) that hold `c` in `format` at `path`: one file, except ROS for a
/// stereo rig (one `camera_info` per camera: `<stem>_left.yaml`, `<stem>_right.yaml`).
pub fn render(c: &Calibration, format: Format, path: &Path) -> Result<Vec<(PathBuf, String)>> {
    let one = |text: String| Ok(vec![(path.to_path_buf(), text)]);
    match format {
        Format::Ron | Format::Json => one(record_string(c, format)?),
        Format::OpenCvYaml => one(crate::opencv::to_yaml(&opencv_entries(c)?)?),
        Format::OpenCvXml => one(crate::opencv::to_xml(&opencv_entries(c)?)?),
        Format::Ros => ros(c, path),
        Format::Kalibr => one(kalibr(c)?),
    }
}

/// A calibrated rig of any number of cameras, as the rig files hold it.
#[derive(Debug, Clone, Copy)]
pub struct RigFile<'a> {
    /// The cameras, in rig order.
    pub cameras: &'a [Camera],
    /// `camI_from_cam0` per camera (the identity for camera 0).
    pub cam_from_cam0: &'a [Isometry3],
    /// Frames seen by both cameras, per pair (`shared_frames[i][j]`): Kalibr's `cam_overlaps`.
    pub shared_frames: &'a [Vec<usize>],
    /// RMS reprojection error over every point, pixels.
    pub rms_px: f64,
}

/// A Kalibr camchain of the rig: `cam0 … camN-1`, `T_cn_cnm1 = camN_from_camN-1` from the
/// second camera on, `cam_overlaps` the cameras that shared frames with it.
fn kalibr_rig(r: &RigFile) -> Result<String> {
    let mut chain = std::collections::BTreeMap::new();
    let n = r.cameras.len();
    for (i, c) in r.cameras.iter().enumerate() {
        let name = format!("cam{i}");
        let t = (i > 0).then(|| r.cam_from_cam0[i] * r.cam_from_cam0[i - 1].inverse());
        let (key, mut camera) = kalibr_chain_entry(kalibr_camera(c, &name, t.as_ref())?, i, n);
        camera.cam_overlaps = (0..n).filter(|&k| k != i && r.shared_frames[i][k] > 0).collect();
        chain.insert(key, camera);
    }
    serde_yaml_ng::to_string(&chain).map_err(|e| InteropError::Unsupported(format!("Kalibr camchain: {e}")))
}

/// OpenCV FileStorage of the rig in `calibrateMultiview`'s terms: `nb_cameras`, then per
/// camera `I` its `camera_matrix_I`, `distortion_coefficients_I` (a Kannala–Brandt camera's 1x4
/// with `fisheye_model_I: 1`, as `calibrateMultiview`'s `isFisheye`), `image_width_I`,
/// `image_height_I`, and `R_I` (3x3), `T_I` (3x1) of `camI_from_cam0`. A double sphere camera is
/// refused: OpenCV has no such model.
fn opencv_rig_entries(r: &RigFile) -> Result<Vec<(String, Entry)>> {
    let mut e = vec![("nb_cameras".to_string(), Entry::Int(r.cameras.len() as i64))];
    for (i, c) in r.cameras.iter().enumerate() {
        let (k, d, fisheye) = match c.lens() {
            Lens::KannalaBrandt(_) => {
                let (k, d) = fisheye_kd(c, "OpenCV")?;
                (k, d.to_vec(), 1)
            }
            Lens::DoubleSphere(_) => return Err(no_double_sphere("OpenCV (calibrateMultiview)")),
            Lens::BrownConrady(_) => (Entry::matrix(&rows3(&c.intrinsics.matrix())), distortion_vector(c), 0),
        };
        let pose = &r.cam_from_cam0[i];
        e.extend([
            (format!("image_width_{i}"), Entry::Int(i64::from(c.width()))),
            (format!("image_height_{i}"), Entry::Int(i64::from(c.height()))),
            (format!("fisheye_model_{i}"), Entry::Int(fisheye)),
            (format!("camera_matrix_{i}"), k),
            (format!("distortion_coefficients_{i}"), Entry::row_vector(&d)),
            (format!("R_{i}"), Entry::matrix(&rows3(&pose.rotation_matrix()))),
            (format!("T_{i}"), Entry::col_vector(&pose.translation.to_array())),
        ]);
    }
    e.push(("avg_reprojection_error".to_string(), Entry::Real(r.rms_px)));
    Ok(e)
}

/// The file that holds a rig in `format` at `path`: a Kalibr camchain, OpenCV FileStorage
/// (YAML / XML) in `calibrateMultiview`'s terms. ROS `camera_info` holds one camera per file
/// and no extrinsics: refused; RON / JSON are the commands' own records (`native_string`).
pub fn render_rig(r: &RigFile, format: Format, path: &Path) -> Result<Vec<(PathBuf, String)>> {
    let n = r.cameras.len();
    if r.cam_from_cam0.len() != n || r.shared_frames.len() != n || r.shared_frames.iter().any(|s| s.len() != n) {
        return Err(InteropError::Unsupported(format!(
            "a rig of {n} cameras with {} extrinsics and a {}-row overlap table",
            r.cam_from_cam0.len(),
            r.shared_frames.len()
        )));
    }
    let text = match format {
        Format::Kalibr => kalibr_rig(r)?,
        Format::OpenCvYaml => crate::opencv::to_yaml(&opencv_rig_entries(r)?)?,
        Format::OpenCvXml => crate::opencv::to_xml(&opencv_rig_entries(r)?)?,
        Format::Ros => {
            return Err(InteropError::Unsupported(
                "ROS camera_info holds one camera and no extrinsics: write a rig as kalibr, opencv, ron or json".into(),
            ));
        }
        Format::Ron | Format::Json => {
            return Err(InteropError::Unsupported("a rig's RON / JSON record is written by the command".into()));
        }
    };
    Ok(vec![(path.to_path_buf(), text)])
}
