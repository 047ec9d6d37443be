//! From a value tree (any format, parsed) to a [`Calibration`]: the shapes every format uses,
//! found wherever they sit in the document.

use glam::{DMat3, DVec3};
use parallax_camera_model::{
    Camera, Distortion, DoubleSphere, Intrinsics, Isometry3, KannalaBrandt, Lens, ProjectionMatrix, StereoRig,
};
use parallax_hand_eye::Setup;
use serde_json::{Map, Value};

use crate::error::{Result, content, model};
use crate::model::{
    Calibration, HandEyeCalibration, MonoCalibration, RectificationMatrices, StereoCalibration, lens_model_name, mat3,
};

/// A camera of either family, as read from a file.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Cam {
    Pinhole(Camera),
    Fisheye(Camera),
}

/// The model marker of an OpenCV or ROS node: `fisheye_model` (OpenCV's calibration sample
/// `camera_calibration.cpp` writes `fisheye_model: 1` for `cv::fisheye`, `0` otherwise) and
/// `distortion_model` (ROS: `plumb_bob`, `rational_polynomial`, `equidistant`; `fisheye` is taken
/// as `equidistant`). No marker means pinhole: a 4-value `D` alone is OpenCV's `k1 k2 p1 p2`.
fn is_fisheye(o: &Map<String, Value>, what: &str) -> Result<bool> {
    let mut fisheye = None;
    if let Some(v) = o.get("fisheye_model") {
        fisheye = Some(match v {
            Value::Bool(b) => *b,
            Value::Number(n) if n.as_f64() == Some(1.0) => true,
            Value::Number(n) if n.as_f64() == Some(0.0) => false,
            other => return Err(content(what, format!("fisheye_model: {other} (expected 0 or 1)"))),
        });
    }
    if let Some(v) = o.get("distortion_model") {
        let f = match v.as_str() {
            Some("plumb_bob" | "rational_polynomial") => false,
            Some("equidistant" | "fisheye") => true,
            _ => {
                return Err(content(
                    what,
                    format!(
                        "distortion_model: {v} is not supported (plumb_bob, rational_polynomial, or equidistant = \
                         OpenCV's fisheye)"
                    ),
                ));
            }
        };
        if fisheye.is_some_and(|g| g != f) {
            return Err(content(what, format!("fisheye_model and distortion_model: {v} disagree")));
        }
        fisheye = Some(f);
    }
    Ok(fisheye.unwrap_or(false))
}

/// A Kannala–Brandt camera from `K` and `D` (exactly `k1 k2 k3 k4`), with every check.
fn fisheye_camera(k: DMat3, d: &[f64], width: u32, height: u32, key: &str, what: &str) -> Result<Camera> {
    let below = [k.x_axis.y, k.x_axis.z, k.y_axis.z];
    if below.iter().any(|v| *v != 0.0) {
        return Err(content(what, format!("camera matrix is not upper triangular ({below:?} below the diagonal)")));
    }
    if d.len() != 4 {
        return Err(content(
            what,
            format!(
                "{key}: a fisheye (equidistant, cv::fisheye) camera takes exactly 4 coefficients k1 k2 k3 k4, the \
                 file has {}",
                d.len()
            ),
        ));
    }
    Camera::from_opencv_kannala_brandt(k, d, width, height).map_err(model(what))
}

/// A pinhole or (with a marker) Kannala–Brandt camera from `K`, `D` and a size.
fn camera_marked(fisheye: bool, k: DMat3, d: &[f64], w: u32, h: u32, key: &str, what: &str) -> Result<Cam> {
    if fisheye {
        Ok(Cam::Fisheye(fisheye_camera(k, d, w, h, key, what)?))
    } else {
        Ok(Cam::Pinhole(camera(k, d, w, h, what)?))
    }
}

/// The lens of a native `Camera`: serde's tagged form (`{"KannalaBrandt": {k1 ..}}`) or
/// the bare parameters RON's untyped reading leaves (`{k1 k2 k3 k4}` or `{xi alpha}`: the field
/// names tell the model).
fn native_lens(v: &Value, what: &str) -> Result<Lens> {
    let mut v = v;
    loop {
        match v {
            Value::Array(a) if a.len() == 1 => v = &a[0],
            Value::Object(m) if m.len() == 1 && (m.contains_key("KannalaBrandt") || m.contains_key("DoubleSphere")) => {
                v = m.values().next().expect("one entry");
            }
            _ => break,
        }
    }
    let o = v.as_object().ok_or_else(|| content(what, format!("lens: {v} is not a lens (k1..k4 or xi, alpha)")))?;
    let num = |k: &str| o.get(k).and_then(Value::as_f64);
    match (num("k1"), num("k2"), num("k3"), num("k4"), num("xi"), num("alpha")) {
        (Some(k1), Some(k2), Some(k3), Some(k4), None, None) if o.len() == 4 => {
            KannalaBrandt::new(k1, k2, k3, k4).map(Lens::KannalaBrandt).map_err(model(what))
        }
        (None, None, None, None, Some(xi), Some(alpha)) if o.len() == 2 => {
            DoubleSphere::new(xi, alpha).map(Lens::DoubleSphere).map_err(model(what))
        }
        _ => Err(content(
            what,
            format!(
                "lens: keys {:?} are neither Kannala–Brandt (k1 k2 k3 k4) nor double sphere (xi alpha)",
                o.keys().collect::<Vec<_>>()
            ),
        )),
    }
}

fn is_fisheye_camera_shape(o: &Map<String, Value>) -> bool {
    ["intrinsics", "lens", "width", "height"].iter().all(|k| o.contains_key(*k))
}

/// A native `Camera` (`intrinsics`, `lens`, `width`, `height`), checked.
fn native_fisheye(o: &Map<String, Value>, what: &str) -> Result<Camera> {
    let intrinsics: Intrinsics = from_native(&o["intrinsics"], "intrinsics", what)?;
    let lens = native_lens(&o["lens"], what)?;
    let dim = |k: &str| {
        o[k].as_u64()
            .and_then(|n| u32::try_from(n).ok())
            .ok_or_else(|| content(what, format!("{k}: {} is not an image size", o[k])))
    };
    Camera::new(intrinsics, lens, dim("width")?, dim("height")?).map_err(model(what))
}

/// A record's `lens_model` (when present) must name the camera's lens.
fn check_lens_model(o: &Map<String, Value>, cameras: &[&Camera], what: &str) -> Result<()> {
    if let Some(name) = o.get("lens_model") {
        for c in cameras {
            let actual = lens_model_name(&c.lens());
            if name.as_str() != Some(actual) {
                return Err(content(what, format!("lens_model: {name} but the camera's lens is {actual}")));
            }
        }
    }
    Ok(())
}

/// A matrix in any of the written forms: `{rows, cols, data}` (OpenCV, ROS), nested rows
/// (native files, Kalibr) or a flat list (a vector: `1 x n`). Returns `(rows, cols, row-major)`.
pub fn matrix(v: &Value, key: &str, what: &str) -> Result<(usize, usize, Vec<f64>)> {
    let number = |x: &Value| x.as_f64().ok_or_else(|| content(what, format!("{key}: {x} is not a number")));
    match v {
        Value::Object(m) if m.contains_key("data") => {
            let data: Vec<f64> = match &m["data"] {
                Value::Array(a) => a.iter().map(number).collect::<Result<_>>()?,
                other => return Err(content(what, format!("{key}: data is {other}, not a list of numbers"))),
            };
            let dim = |k: &str| m.get(k).and_then(Value::as_u64).map(|n| n as usize);
            let (rows, cols) = match (dim("rows"), dim("cols")) {
                (Some(r), Some(c)) => (r, c),
                _ => return Err(content(what, format!("{key}: a matrix needs integer `rows` and `cols`"))),
            };
            if let Some(dt) = m.get("dt").and_then(Value::as_str).filter(|dt| !matches!(*dt, "d" | "f")) {
                return Err(content(what, format!("{key}: element type dt: {dt} (expected d or f)")));
            }
            if rows * cols != data.len() {
                return Err(content(
                    what,
                    format!("{key}: rows {rows} x cols {cols} = {} but data has {} values", rows * cols, data.len()),
                ));
            }
            Ok((rows, cols, data))
        }
        Value::Array(a) if a.iter().all(Value::is_array) && !a.is_empty() => {
            let rows: Vec<Vec<f64>> = a
                .iter()
                .map(|r| r.as_array().into_iter().flatten().map(number).collect::<Result<Vec<f64>>>())
                .collect::<Result<_>>()?;
            let cols = rows[0].len();
            if rows.iter().any(|r| r.len() != cols) {
                return Err(content(what, format!("{key}: rows of different lengths")));
            }
            Ok((rows.len(), cols, rows.concat()))
        }
        Value::Array(a) => Ok((1, a.len(), a.iter().map(number).collect::<Result<_>>()?)),
        other => Err(content(what, format!("{key}: {other} is not a matrix"))),
    }
}

fn get<'a>(o: &'a Map<String, Value>, key: &str, what: &str) -> Result<&'a Value> {
    o.get(key).ok_or_else(|| content(what, format!("no `{key}`")))
}

/// A 3x3 matrix.
pub fn mat3_of(v: &Value, key: &str, what: &str) -> Result<DMat3> {
    match matrix(v, key, what)? {
        (3, 3, d) => Ok(mat3(&[[d[0], d[1], d[2]], [d[3], d[4], d[5]], [d[6], d[7], d[8]]])),
        (r, c, _) => Err(content(what, format!("{key} is {r}x{c}, expected 3x3"))),
    }
}

fn vector(v: &Value, key: &str, what: &str) -> Result<Vec<f64>> {
    let (r, c, d) = matrix(v, key, what)?;
    if r != 1 && c != 1 {
        return Err(content(what, format!("{key} is {r}x{c}, expected a vector")));
    }
    Ok(d)
}

fn vec3(v: &Value, key: &str, what: &str) -> Result<DVec3> {
    match vector(v, key, what)?.as_slice() {
        [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
        d => Err(content(what, format!("{key} has {} values, expected 3", d.len()))),
    }
}

fn rows_n<const C: usize, const R: usize>(v: &Value, key: &str, what: &str) -> Result<[[f64; C]; R]> {
    match matrix(v, key, what)? {
        (r, c, d) if r == R && c == C => Ok(std::array::from_fn(|i| std::array::from_fn(|j| d[i * C + j]))),
        (r, c, _) => Err(content(what, format!("{key} is {r}x{c}, expected {R}x{C}"))),
    }
}

/// A rotation given as a 3x3 matrix or a Rodrigues vector (both are accepted by OpenCV).
fn rotation(v: &Value, key: &str, what: &str) -> Result<DMat3> {
    match matrix(v, key, what)? {
        (3, 3, _) => mat3_of(v, key, what),
        (r, c, d) if r * c == 3 => {
            Ok(Isometry3::from_rvec_tvec(DVec3::new(d[0], d[1], d[2]), DVec3::ZERO).rotation_matrix())
        }
        (r, c, _) => Err(content(what, format!("{key} is {r}x{c}: expected a 3x3 rotation or a 3-vector"))),
    }
}

fn size(o: &Map<String, Value>, w: &str, h: &str, what: &str) -> Result<(u32, u32)> {
    let dim = |k: &str| -> Result<u32> {
        o.get(k).and_then(Value::as_u64).and_then(|n| u32::try_from(n).ok()).ok_or_else(|| {
            content(
                what,
                format!(
                    "no image size (`{w}`, `{h}`): the camera model needs the size its parameters belong to; add them"
                ),
            )
        })
    };
    Ok((dim(w)?, dim(h)?))
}

/// A camera from `K`, a distortion vector and a size, with every check.
pub fn camera(k: DMat3, d: &[f64], width: u32, height: u32, what: &str) -> Result<Camera> {
    let below = [k.x_axis.y, k.x_axis.z, k.y_axis.z];
    if below.iter().any(|v| *v != 0.0) {
        return Err(content(what, format!("camera matrix is not upper triangular ({below:?} below the diagonal)")));
    }
    let intrinsics = Intrinsics::from_matrix(k).map_err(model(what))?;
    let mut c = [0.0; 8];
    match d.len() {
        0 => {}
        4 | 5 | 8 => c[..d.len()].copy_from_slice(d),
        n if n > 8 && d[8..].iter().all(|v| *v == 0.0) => c.copy_from_slice(&d[..8]),
        n => {
            return Err(content(
                what,
                format!(
                    "{n} distortion coefficients: this camera model takes k1 k2 p1 p2 [k3 [k4 k5 k6]] \
                     (thin-prism and tilt terms must be zero)"
                ),
            ));
        }
    }
    Camera::new(intrinsics, Distortion::from_array(c), width, height).map_err(model(what))
}

fn rms_of(o: &Map<String, Value>) -> Option<f64> {
    ["avg_reprojection_error", "rms_px", "rms"].iter().find_map(|k| o.get(*k).and_then(Value::as_f64))
}

fn per_view_mono(o: &Map<String, Value>, what: &str) -> Result<Vec<f64>> {
    for key in ["per_view_reprojection_errors", "per_view_rms_px"] {
        if let Some(v) = o.get(key) {
            return vector(v, key, what);
        }
    }
    Ok(Vec::new())
}

fn per_view_stereo(o: &Map<String, Value>, what: &str) -> Result<Vec<[f64; 2]>> {
    for key in ["per_view_reprojection_errors", "per_view_rms_px"] {
        if let Some(v) = o.get(key) {
            // A stereo result without per-view errors (read from an OpenCV file that has none)
            // is written with an empty list: that is no views, not a 1x0 matrix.
            if v.as_array().is_some_and(Vec::is_empty) {
                return Ok(Vec::new());
            }
            return match matrix(v, key, what)? {
                (_, 2, d) => Ok(d.chunks(2).map(|c| [c[0], c[1]]).collect()),
                (r, c, _) => Err(content(what, format!("{key} is {r}x{c}, expected N x 2 (left, right)"))),
            };
        }
    }
    Ok(Vec::new())
}

fn rig(left: Camera, right: Camera, r: DMat3, t: DVec3, what: &str) -> Result<StereoRig> {
    let right_from_left = Isometry3::from_rotation_translation(r, t).map_err(model(what))?;
    StereoRig::new(left, right, right_from_left).map_err(model(what))
}

/// OpenCV's stereo keys (`stereo_calib.cpp`): `M1 D1 M2 D2 R T` and optionally
/// `R1 R2 P1 P2 Q`; the image size from `image_width`/`image_height` (also `imageSize`). With
/// the marker `fisheye_model: 1` the cameras are `cv::fisheye`'s (`D` = `k1 k2 k3 k4`).
fn opencv_stereo(o: &Map<String, Value>, what: &str) -> Result<Calibration> {
    let (w, h) = if let Some(s) = o.get("imageSize").or_else(|| o.get("image_size")) {
        match vector(s, "imageSize", what)?.as_slice() {
            // whole pixels (a fractional size was truncated, as `image_width: 640.7` is refused)
            [w, h] if [w, h].iter().all(|v| **v >= 1.0 && v.fract() == 0.0 && **v <= u32::MAX as f64) => {
                (*w as u32, *h as u32)
            }
            _ => return Err(content(what, "imageSize must be [width, height] in whole pixels")),
        }
    } else {
        size(o, "image_width", "image_height", what)?
    };
    let (rw, rh) = match (o.get("right_image_width"), o.get("right_image_height")) {
        (Some(_), Some(_)) => size(o, "right_image_width", "right_image_height", what)?,
        _ => (w, h),
    };
    let fisheye = is_fisheye(o, what)?;
    let side = |m: &str, d: &str, w: u32, h: u32| -> Result<Cam> {
        let k = mat3_of(get(o, m, what)?, m, what)?;
        camera_marked(fisheye, k, &vector(get(o, d, what)?, d, what)?, w, h, d, what)
    };
    let (left, right) = (side("M1", "D1", w, h)?, side("M2", "D2", rw, rh)?);
    let r = rotation(get(o, "R", what)?, "R", what)?;
    let t = vec3(get(o, "T", what)?, "T", what)?;
    let right_from_left = Isometry3::from_rotation_translation(r, t).map_err(model(what))?;
    let rect_keys = ["R1", "R2", "P1", "P2", "Q"];
    let present: Vec<_> = rect_keys.iter().filter(|k| o.get(**k).is_some_and(|v| !v.is_null())).collect();
    let rectification = if present.is_empty() {
        None
    } else if present.len() < rect_keys.len() {
        return Err(content(what, format!("rectification incomplete: has {present:?} of {rect_keys:?}")));
    } else {
        Some(RectificationMatrices {
            r1: mat3_of(&o["R1"], "R1", what)?,
            r2: mat3_of(&o["R2"], "R2", what)?,
            p1: ProjectionMatrix { rows: rows_n::<4, 3>(&o["P1"], "P1", what)? },
            p2: ProjectionMatrix { rows: rows_n::<4, 3>(&o["P2"], "P2", what)? },
            q: rows_n::<4, 4>(&o["Q"], "Q", what)?,
        })
    };
    let (rms_px, per_view_rms_px) = (rms_of(o), per_view_stereo(o, what)?);
    let (left, right) = match (left, right) {
        (Cam::Fisheye(left), Cam::Fisheye(right)) => {
            let rig = StereoRig::new(left, right, right_from_left).map_err(model(what))?;
            check_up_to_scale(o, "E", rig.essential(), what)?;
            if o.contains_key("F") {
                return Err(content(
                    what,
                    "F in a fisheye (fisheye_model: 1) file: fisheye pixels are not related by a fundamental \
                     matrix; the file mixes a pinhole and a fisheye calibration",
                ));
            }
            return Ok(Calibration::Stereo(StereoCalibration { rig, rectification, rms_px, per_view_rms_px }));
        }
        (Cam::Pinhole(l), Cam::Pinhole(r)) => (l, r),
        _ => unreachable!("both sides use the node's one marker"),
    };
    let rig = StereoRig::new(left, right, right_from_left).map_err(model(what))?;
    check_up_to_scale(o, "E", rig.essential(), what)?;
    check_up_to_scale(o, "F", rig.fundamental(), what)?;
    Ok(Calibration::Stereo(StereoCalibration { rig, rectification, rms_px, per_view_rms_px }))
}

/// A stereo calibration's stored `R1 R2 P1 P2 Q`, when it has them, are a rectification of its
/// rig (`Rectification::from_matrices`: rotations, one focal length, parallel rectified frames, the
/// rig's baseline, `Q` of `P1 P2`): a file whose derived matrices disagree with its `K D R T` is
/// refused here, before any command uses them.
fn check_rectification(c: &Calibration, what: &str) -> Result<()> {
    let Calibration::Stereo(s) = c else { return Ok(()) };
    let Some(m) = &s.rectification else { return Ok(()) };
    m.to_rectification(&s.rig, (s.rig.left.width(), s.rig.left.height())).map(|_| ()).map_err(|e| {
        content(
            what,
            format!("R1 R2 P1 P2 Q do not belong to its M1 D1 M2 D2 R T: {e} (write the file again, or drop them)"),
        )
    })
}

/// `key` (E or F, defined up to scale), when present, agrees with `expected`: the normalised
/// matrices, sign too.
fn check_up_to_scale(o: &Map<String, Value>, key: &str, expected: DMat3, what: &str) -> Result<()> {
    if let Some(v) = o.get(key) {
        let m = mat3_of(v, key, what)?;
        let unit = |m: DMat3| m / m.to_cols_array().iter().map(|x| x * x).sum::<f64>().sqrt();
        let (a, b) = (unit(m), unit(expected));
        let largest = |m: DMat3| m.to_cols_array().iter().fold(0.0f64, |acc, x| acc.max(x.abs()));
        let same = largest(a - b) < 1e-6 || largest(a + b) < 1e-6;
        if !same {
            return Err(content(
                what,
                format!("{key} does not agree with M1 M2 R T (normalised difference {:.3e})", largest(a - b)),
            ));
        }
    }
    Ok(())
}

/// OpenCV's mono keys (`calibration.cpp`, `camera_calibration.cpp`) or ROS `camera_info`:
/// `camera_matrix`, `distortion_coefficients`, `image_width`, `image_height`; a fisheye camera
/// when marked (`fisheye_model: 1`, `distortion_model: equidistant`).
fn opencv_mono(o: &Map<String, Value>, what: &str) -> Result<Calibration> {
    let (w, h) = size(o, "image_width", "image_height", what)?;
    let d = vector(get(o, "distortion_coefficients", what)?, "distortion_coefficients", what)?;
    let fisheye = is_fisheye(o, what)?;
    if let Some(model_name) = o.get("distortion_model").and_then(Value::as_str).filter(|_| !fisheye) {
        let expected = if model_name == "rational_polynomial" { 8 } else { 5 };
        if d.len() != expected && !d.is_empty() {
            return Err(content(what, format!("{model_name} takes {expected} coefficients, the file has {}", d.len())));
        }
    }
    let k = mat3_of(get(o, "camera_matrix", what)?, "camera_matrix", what)?;
    let (rms_px, per_view_rms_px) = (rms_of(o), per_view_mono(o, what)?);
    Ok(match camera_marked(fisheye, k, &d, w, h, "distortion_coefficients", what)? {
        Cam::Pinhole(camera) => Calibration::Mono(MonoCalibration { camera, rms_px, per_view_rms_px }),
        Cam::Fisheye(camera) => Calibration::Mono(MonoCalibration { camera, rms_px, per_view_rms_px }),
    })
}

/// Kalibr's camchain: `cam0` (and `cam1` with `T_cn_cnm1` = `cam1_from_cam0`). Models:
/// `pinhole` with `radtan` (OpenCV's `k1 k2 p1 p2`) or `equidistant` (Kannala–Brandt `k1..k4`),
/// and `ds` (double sphere, intrinsics `[xi alpha fu fv pu pv]`, no distortion).
fn kalibr_camera(o: &Map<String, Value>, name: &str, what: &str) -> Result<Cam> {
    let cam = get(o, name, what)?.as_object().ok_or_else(|| content(what, format!("{name} is not a map")))?;
    let model_name = cam.get("camera_model").and_then(Value::as_str).unwrap_or("pinhole");
    let dist_model = cam.get("distortion_model").and_then(Value::as_str);
    let i = vector(get(cam, "intrinsics", what)?, "intrinsics", what)?;
    let d = match cam.get("distortion_coeffs") {
        Some(v) => vector(v, "distortion_coeffs", what)?,
        None => Vec::new(),
    };
    let r = vector(get(cam, "resolution", what)?, "resolution", what)?;
    let [w, h] = r[..] else { return Err(content(what, format!("{name}: resolution must be [width, height]"))) };
    let (w, h) = (w as u32, h as u32);
    match model_name {
        "pinhole" => {
            let [fu, fv, pu, pv] = i[..] else {
                return Err(content(
                    what,
                    format!("{name}: intrinsics has {} values, expected [fu, fv, pu, pv]", i.len()),
                ));
            };
            let k = Intrinsics::new(fu, fv, pu, pv).matrix();
            match dist_model.unwrap_or("radtan") {
                "radtan" => {
                    if d.len() != 4 {
                        return Err(content(
                            what,
                            format!("{name}: radtan takes 4 distortion_coeffs, got {}", d.len()),
                        ));
                    }
                    Ok(Cam::Pinhole(camera(k, &d, w, h, what)?))
                }
                "equidistant" => {
                    Ok(Cam::Fisheye(fisheye_camera(k, &d, w, h, &format!("{name}.distortion_coeffs"), what)?))
                }
                other => Err(content(
                    what,
                    format!(
                        "{name}: distortion_model {other} is not supported (radtan = OpenCV's k1 k2 p1 p2, \
                         equidistant = Kannala–Brandt k1 k2 k3 k4)"
                    ),
                )),
            }
        }
        "ds" => {
            let [xi, alpha, fu, fv, pu, pv] = i[..] else {
                return Err(content(
                    what,
                    format!("{name}: ds intrinsics has {} values, expected [xi, alpha, fu, fv, pu, pv]", i.len()),
                ));
            };
            if !matches!(dist_model, None | Some("none")) || !d.is_empty() {
                return Err(content(
                    what,
                    format!(
                        "{name}: camera_model ds with distortion_model {} and {} coefficients: the double sphere \
                         model takes no distortion (distortion_model: none)",
                        dist_model.unwrap_or("none"),
                        d.len()
                    ),
                ));
            }
            let lens = Lens::DoubleSphere(DoubleSphere::new(xi, alpha).map_err(model(what))?);
            Ok(Cam::Fisheye(Camera::new(Intrinsics::new(fu, fv, pu, pv), lens, w, h).map_err(model(what))?))
        }
        other => Err(content(
            what,
            format!(
                "{name}: camera_model {other} is not supported (pinhole with radtan or equidistant, ds); omni and \
                 eucm have no parallax model: recalibrate with ds"
            ),
        )),
    }
}

fn kalibr(o: &Map<String, Value>, what: &str) -> Result<Calibration> {
    let left = kalibr_camera(o, "cam0", what)?;
    if !o.contains_key("cam1") {
        return Ok(match left {
            Cam::Pinhole(camera) => {
                Calibration::Mono(MonoCalibration { camera, rms_px: None, per_view_rms_px: Vec::new() })
            }
            Cam::Fisheye(camera) => {
                Calibration::Mono(MonoCalibration { camera, rms_px: None, per_view_rms_px: Vec::new() })
            }
        });
    }
    if o.contains_key("cam2") {
        return Err(content(what, "more than two cameras (cam2): give a camchain with cam0 and cam1"));
    }
    let right = kalibr_camera(o, "cam1", what)?;
    let cam1 = o["cam1"].as_object().expect("checked by kalibr_camera");
    let t = rows_n::<4, 4>(get(cam1, "T_cn_cnm1", what)?, "T_cn_cnm1", what)?;
    if t[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(content(what, format!("cam1.T_cn_cnm1: last row {:?} is not [0, 0, 0, 1]", t[3])));
    }
    let r = mat3(&[[t[0][0], t[0][1], t[0][2]], [t[1][0], t[1][1], t[1][2]], [t[2][0], t[2][1], t[2][2]]]);
    let tv = DVec3::new(t[0][3], t[1][3], t[2][3]);
    match (left, right) {
        (Cam::Pinhole(l), Cam::Pinhole(rc)) => {
            let rig = rig(l, rc, r, tv, what)?;
            Ok(Calibration::Stereo(StereoCalibration {
                rig,
                rectification: None,
                rms_px: None,
                per_view_rms_px: Vec::new(),
            }))
        }
        (Cam::Fisheye(l), Cam::Fisheye(rc)) => {
            let right_from_left = Isometry3::from_rotation_translation(r, tv).map_err(model(what))?;
            let rig = StereoRig::new(l, rc, right_from_left).map_err(model(what))?;
            Ok(Calibration::Stereo(StereoCalibration {
                rig,
                rectification: None,
                rms_px: None,
                per_view_rms_px: Vec::new(),
            }))
        }
        _ => Err(content(
            what,
            "cam0 and cam1 are of different families (a pinhole-radtan and a fisheye camera): parallax rigs have \
             two cameras of one family",
        )),
    }
}

/// Hand-eye keys: OpenCV's `calibrateHandEye` outputs (`R_cam2gripper`, `t_cam2gripper`; eye-to-hand
/// `R_cam2base`, `t_cam2base`).
fn opencv_hand_eye(o: &Map<String, Value>, what: &str) -> Result<Option<HandEyeCalibration>> {
    for (r, t, setup) in
        [("R_cam2gripper", "t_cam2gripper", Setup::EyeInHand), ("R_cam2base", "t_cam2base", Setup::EyeToHand)]
    {
        if let (Some(rv), Some(tv)) = (o.get(r), o.get(t)) {
            let transform = Isometry3::from_rotation_translation(rotation(rv, r, what)?, vec3(tv, t, what)?)
                .map_err(model(what))?;
            let method = o.get("method").and_then(Value::as_str).map(str::to_string);
            return Ok(Some(HandEyeCalibration { setup, transform, method }));
        }
    }
    Ok(None)
}

fn is_camera_shape(o: &Map<String, Value>) -> bool {
    ["intrinsics", "distortion", "width", "height"].iter().all(|k| o.contains_key(*k))
}

fn is_rig_shape(o: &Map<String, Value>) -> bool {
    ["left", "right", "right_from_left"].iter().all(|k| o.contains_key(*k))
}

fn from_native<T: serde::de::DeserializeOwned>(v: &Value, key: &str, what: &str) -> Result<T> {
    serde_json::from_value(v.clone()).map_err(|e| content(what, format!("{key}: {e}")))
}

/// A native file's view of `t` in every convention (`PoseRecord`, at `key`: translation,
/// quaternion, rotation matrix and vector, `tf`) must describe the transform that is read:
/// edited in one place only, it was silently ignored (`measure` kept the old baseline). Each
/// form present is compared (1e-9, relative for the translation); a quaternion of either sign.
fn check_pose_record(o: &Map<String, Value>, key: &str, t: &Isometry3, what: &str) -> Result<()> {
    let Some(Value::Object(r)) = o.get(key) else { return Ok(()) };
    let want = crate::model::PoseRecord::of(t);
    let scale = t.translation.length().max(1.0);
    let close =
        |a: &[f64], b: &[f64], s: f64| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9 * s);
    let q = want.quaternion_xyzw;
    let quat_ok = |v: &[f64]| close(v, &q, 1.0) || close(v, &q.map(|x| -x), 1.0);
    for (form, v) in r {
        let ok = match form.as_str() {
            "translation" => close(&vector(v, form, what)?, &want.translation, scale),
            "quaternion_xyzw" => quat_ok(&vector(v, form, what)?),
            "rotation_matrix" => close(&matrix(v, form, what)?.2, want.rotation_matrix.as_flattened(), 1.0),
            "rotation_vector_rad" => close(&vector(v, form, what)?, &want.rotation_vector_rad, 1.0),
            "tf" => {
                let n: Vec<f64> = v.as_str().unwrap_or("").split_whitespace().filter_map(|x| x.parse().ok()).collect();
                n.len() == 7 && close(&n[..3], &want.translation, scale) && quat_ok(&n[3..])
            }
            _ => true,
        };
        if !ok {
            return Err(content(
                what,
                format!(
                    "`{key}.{form}` does not describe the rig's `right_from_left` (what is read): the file was edited \
                     in one place only; edit `rig.right_from_left` and delete `{key}`, or fix both"
                ),
            ));
        }
    }
    Ok(())
}

/// Largest relative difference between two rigs' parameters (for the consistency check of a
/// native file's `rig` against its `opencv` matrices).
fn rig_difference(a: &StereoRig, b: &StereoRig) -> f64 {
    let cam = |c: &Camera| {
        let k = c.intrinsics;
        let mut v = vec![k.fx, k.fy, k.cx, k.cy, k.skew];
        v.extend(c.lens.parameters());
        v
    };
    let mut worst: f64 = 0.0;
    for (x, y) in cam(&a.left).iter().chain(&cam(&a.right)).zip(cam(&b.left).iter().chain(&cam(&b.right))) {
        worst = worst.max((x - y).abs() / x.abs().max(1.0));
    }
    let ra = a.right_from_left.rotation_matrix().to_cols_array();
    let rb = b.right_from_left.rotation_matrix().to_cols_array();
    for (x, y) in ra.iter().zip(&rb) {
        worst = worst.max((x - y).abs());
    }
    let (ta, tb) = (a.right_from_left.translation, b.right_from_left.translation);
    worst.max((ta - tb).length() / ta.length().max(1e-300))
}

/// A native fisheye rig (`left`, `right` with a `lens`, `right_from_left`), checked.
fn native_fisheye_rig(o: &Map<String, Value>, what: &str) -> Result<StereoRig> {
    let side = |k: &str| -> Result<Camera> {
        match o.get(k) {
            Some(Value::Object(c)) if is_fisheye_camera_shape(c) => native_fisheye(c, what),
            _ => Err(content(what, format!("rig.{k} is not a fisheye camera (intrinsics, lens, width, height)"))),
        }
    };
    let right_from_left: Isometry3 = from_native(&o["right_from_left"], "right_from_left", what)?;
    StereoRig::new(side("left")?, side("right")?, right_from_left).map_err(model(what))
}

fn rig_is_fisheye(o: &Map<String, Value>) -> bool {
    matches!(o.get("left"), Some(Value::Object(c)) if c.contains_key("lens"))
}

/// The `rectification` of a native fisheye record (`R1 R2 P1 P2 Q`, row-major).
fn native_rectification(o: &Map<String, Value>, what: &str) -> Result<Option<RectificationMatrices>> {
    match o.get("rectification") {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Object(r)) => Ok(Some(RectificationMatrices {
            r1: mat3_of(get(r, "R1", what)?, "R1", what)?,
            r2: mat3_of(get(r, "R2", what)?, "R2", what)?,
            p1: ProjectionMatrix { rows: rows_n::<4, 3>(get(r, "P1", what)?, "P1", what)? },
            p2: ProjectionMatrix { rows: rows_n::<4, 3>(get(r, "P2", what)?, "P2", what)? },
            q: rows_n::<4, 4>(get(r, "Q", what)?, "Q", what)?,
        })),
        Some(other) => Err(content(what, format!("rectification: {other} is not R1 R2 P1 P2 Q"))),
    }
}

/// Stereo shapes at one node: `{rig: StereoRig, ...}` (or a fisheye rig), a bare `StereoRig`,
/// OpenCV's `M1 … T`, Kalibr's `cam0` + `cam1`.
fn stereo_at(o: &Map<String, Value>, what: &str) -> Result<Option<Calibration>> {
    if let Some(Value::Object(r)) = o.get("rig")
        && is_rig_shape(r)
        && rig_is_fisheye(r)
    {
        let rig = native_fisheye_rig(r, what)?;
        check_lens_model(o, &[&rig.left, &rig.right], what)?;
        check_pose_record(o, "right_from_left", &rig.right_from_left, what)?;
        return Ok(Some(Calibration::Stereo(StereoCalibration {
            rig,
            rectification: native_rectification(o, what)?,
            rms_px: o.get("rms_px").and_then(Value::as_f64),
            per_view_rms_px: per_view_stereo(o, what)?,
        })));
    }
    if let Some(Value::Object(r)) = o.get("rig")
        && is_rig_shape(r)
    {
        let rig: StereoRig = from_native(&o["rig"], "rig", what)?;
        let rig = StereoRig::new(rig.left, rig.right, rig.right_from_left).map_err(model(what))?;
        check_pose_record(o, "right_from_left", &rig.right_from_left, what)?;
        let mut rectification = None;
        if let Some(Value::Object(m)) = o.get("opencv")
            && m.contains_key("M1")
        {
            let cv = match opencv_stereo(m, what)? {
                Calibration::Stereo(cv) if !cv.rig.left.lens_model().is_wide() => cv,
                _ => return Err(content(what, "`rig` is a pinhole rig but the `opencv` matrices are marked fisheye")),
            };
            let diff = rig_difference(&rig, &cv.rig);
            if diff > 1e-9 {
                return Err(content(
                    what,
                    format!(
                        "`rig` and the `opencv` matrices disagree (largest relative difference {diff:.3e}): the file \
                         was edited in one place only; edit `rig` (what is read) and delete `opencv`, or fix both"
                    ),
                ));
            }
            rectification = cv.rectification;
        }
        let rms_px = o.get("rms_px").and_then(Value::as_f64);
        let per_view_rms_px = per_view_stereo(o, what)?;
        return Ok(Some(Calibration::Stereo(StereoCalibration { rig, rectification, rms_px, per_view_rms_px })));
    }
    if is_rig_shape(o) && rig_is_fisheye(o) {
        let rig = native_fisheye_rig(o, what)?;
        return Ok(Some(Calibration::Stereo(StereoCalibration {
            rig,
            rectification: None,
            rms_px: None,
            per_view_rms_px: Vec::new(),
        })));
    }
    if is_rig_shape(o) {
        let rig: StereoRig = from_native(&Value::Object(o.clone()), "rig", what)?;
        let rig = StereoRig::new(rig.left, rig.right, rig.right_from_left).map_err(model(what))?;
        return Ok(Some(Calibration::Stereo(StereoCalibration {
            rig,
            rectification: None,
            rms_px: None,
            per_view_rms_px: Vec::new(),
        })));
    }
    if ["M1", "D1", "M2", "D2", "R", "T"].iter().all(|k| o.contains_key(*k)) {
        return opencv_stereo(o, what).map(Some);
    }
    if o.contains_key("cam0") && o.contains_key("cam1") {
        return match kalibr(o, what)? {
            c @ Calibration::Stereo(_) => Ok(Some(c)),
            _ => Ok(None),
        };
    }
    Ok(None)
}

fn mono_at(o: &Map<String, Value>, what: &str) -> Result<Option<Calibration>> {
    if let Some(Value::Object(c)) = o.get("camera")
        && is_fisheye_camera_shape(c)
    {
        let camera = native_fisheye(c, what)?;
        check_lens_model(o, &[&camera], what)?;
        if let Some(Value::Object(m)) = o.get("opencv")
            && m.contains_key("camera_matrix")
        {
            let same = match opencv_mono(m, what)? {
                Calibration::Mono(cv) if cv.camera.lens_model().is_wide() => {
                    let p = |c: &Camera| {
                        let k = c.intrinsics();
                        let mut v = vec![k.fx, k.fy, k.cx, k.cy, k.skew];
                        v.extend(c.lens().parameters());
                        (v, c.width(), c.height())
                    };
                    p(&cv.camera) == p(&camera)
                }
                _ => false,
            };
            if !same {
                return Err(content(
                    what,
                    "`camera` and the `opencv` matrices (cv::fisheye K, D) disagree: the file was edited in one place \
                     only; edit `camera` (what is read) and delete `opencv`, or fix both",
                ));
            }
        }
        let rms_px = o.get("rms_px").and_then(Value::as_f64);
        return Ok(Some(Calibration::Mono(MonoCalibration {
            camera,
            rms_px,
            per_view_rms_px: per_view_mono(o, what)?,
        })));
    }
    if let Some(Value::Object(c)) = o.get("camera")
        && is_camera_shape(c)
    {
        let camera: Camera = from_native(&o["camera"], "camera", what)?;
        camera.validate().map_err(model(what))?;
        if let Some(Value::Object(m)) = o.get("opencv")
            && m.contains_key("camera_matrix")
        {
            let cv = match opencv_mono(m, what)? {
                Calibration::Mono(cv) if !cv.camera.lens_model().is_wide() => cv,
                _ => {
                    return Err(content(
                        what,
                        "`camera` is a pinhole camera but the `opencv` matrices are marked fisheye",
                    ));
                }
            };
            let same = StereoRig { left: camera, right: camera, right_from_left: Isometry3::IDENTITY };
            let other = StereoRig { left: cv.camera, right: cv.camera, right_from_left: Isometry3::IDENTITY };
            let diff = rig_difference(&same, &other);
            if diff > 1e-9 || (camera.width, camera.height) != (cv.camera.width, cv.camera.height) {
                return Err(content(
                    what,
                    format!("`camera` and the `opencv` matrices disagree (relative difference {diff:.3e})"),
                ));
            }
        }
        let rms_px = o.get("rms_px").and_then(Value::as_f64);
        return Ok(Some(Calibration::Mono(MonoCalibration {
            camera,
            rms_px,
            per_view_rms_px: per_view_mono(o, what)?,
        })));
    }
    if is_fisheye_camera_shape(o) {
        let camera = native_fisheye(o, what)?;
        return Ok(Some(Calibration::Mono(MonoCalibration { camera, rms_px: None, per_view_rms_px: Vec::new() })));
    }
    if is_camera_shape(o) {
        let camera: Camera = from_native(&Value::Object(o.clone()), "camera", what)?;
        camera.validate().map_err(model(what))?;
        return Ok(Some(Calibration::Mono(MonoCalibration { camera, rms_px: None, per_view_rms_px: Vec::new() })));
    }
    if o.contains_key("camera_matrix") && o.contains_key("distortion_coefficients") {
        return opencv_mono(o, what).map(Some);
    }
    if o.contains_key("cam0") {
        return match kalibr(o, what)? {
            c @ Calibration::Mono(_) => Ok(Some(c)),
            _ => Ok(None),
        };
    }
    Ok(None)
}

fn hand_eye_at(o: &Map<String, Value>, what: &str) -> Result<Option<HandEyeCalibration>> {
    if let (Some(t), Some(s)) = (o.get("transform"), o.get("setup"))
        && t.is_object()
    {
        let transform: Isometry3 = from_native(t, "transform", what)?;
        let setup = s
            .as_str()
            .and_then(crate::model::setup_from_name)
            .ok_or_else(|| content(what, format!("setup: {s} is not eye_in_hand or eye_to_hand")))?;
        let method = o.get("method").and_then(|m| m.as_str().map(str::to_string));
        return Ok(Some(HandEyeCalibration { setup, transform, method }));
    }
    opencv_hand_eye(o, what)
}

/// Every object of the tree, breadth-first (the shallowest match wins).
fn objects(root: &Value) -> Vec<&Map<String, Value>> {
    let mut out = Vec::new();
    let mut queue = std::collections::VecDeque::from([root]);
    while let Some(v) = queue.pop_front() {
        match v {
            Value::Object(m) => {
                out.push(m);
                queue.extend(m.values());
            }
            Value::Array(a) => queue.extend(a.iter()),
            _ => {}
        }
    }
    out
}

/// The calibration a document holds: a stereo rig first (a stereo result also holds cameras),
/// then a camera, then a hand-eye transform; the shallowest one of each kind.
pub fn interpret(root: &Value, what: &str) -> Result<Calibration> {
    let nodes = objects(root);
    for o in &nodes {
        if let Some(s) = stereo_at(o, what)? {
            check_rectification(&s, what)?;
            return Ok(s);
        }
    }
    for o in &nodes {
        if let Some(m) = mono_at(o, what)? {
            return Ok(m);
        }
    }
    for o in &nodes {
        if let Some(h) = hand_eye_at(o, what)? {
            return Ok(Calibration::HandEye(h));
        }
    }
    let keys: Vec<&String> = match root {
        Value::Object(m) => m.keys().take(12).collect(),
        _ => Vec::new(),
    };
    Err(content(
        what,
        format!(
            "no calibration found (top-level keys {keys:?}): expected a result of `calibrate` or `handeye`, a \
             parallax StereoRig or Camera, OpenCV FileStorage keys (camera_matrix/distortion_coefficients or \
             M1 D1 M2 D2 R T), a ROS camera_info or a Kalibr camchain"
        ),
    ))
}

/// A rig from two ROS `camera_info` documents (left, then right): `R = R2ᵀ R1`,
/// `T = R2ᵀ (t2 − t1)` with `tᵢ = K'⁻¹ Pᵢ[:, 3]` (the rectified right camera sits at `t2 − t1` in
/// the rectified left frame). Both `plumb_bob`/`rational_polynomial` (a pinhole rig) or both
/// `equidistant` (a fisheye rig).
pub fn rig_from_ros_pair(left: &Value, right: &Value, what: &str) -> Result<Calibration> {
    let part = |v: &Value, side: &str| -> Result<(Calibration, DMat3, [[f64; 4]; 3])> {
        let o = v.as_object().ok_or_else(|| content(what, format!("{side}: not a camera_info map")))?;
        let m = opencv_mono(o, what)?;
        let r = mat3_of(get(o, "rectification_matrix", what)?, "rectification_matrix", what)?;
        let p = rows_n::<4, 3>(get(o, "projection_matrix", what)?, "projection_matrix", what)?;
        Ok((m, r, p))
    };
    let (lc, r1, p1) = part(left, "left")?;
    let (rc, r2, p2) = part(right, "right")?;
    let t = |p: &[[f64; 4]; 3]| -> Result<DVec3> {
        let k = mat3(&[[p[0][0], p[0][1], p[0][2]], [p[1][0], p[1][1], p[1][2]], [p[2][0], p[2][1], p[2][2]]]);
        if k.determinant().abs() < 1e-12 {
            return Err(content(what, "projection_matrix: singular left 3x3 block"));
        }
        Ok(k.inverse() * DVec3::new(p[0][3], p[1][3], p[2][3]))
    };
    let (t1, t2) = (t(&p1)?, t(&p2)?);
    if t2.length() == 0.0 && t1.length() > 0.0 {
        return Err(content(
            what,
            "the first camera_info has the baseline in its projection matrix and the second none: give the left \
             camera's file first",
        ));
    }
    if (t2 - t1).length() == 0.0 {
        return Err(content(
            what,
            "both projection matrices have zero baseline: these are not a rectified stereo pair",
        ));
    }
    let r = r2.transpose() * r1;
    let translation = r2.transpose() * (t2 - t1);
    let rectification = Some(RectificationMatrices {
        r1,
        r2,
        p1: ProjectionMatrix { rows: p1 },
        p2: ProjectionMatrix { rows: p2 },
        q: q_from(&p1, &p2),
    });
    match (lc, rc) {
        (Calibration::Mono(l), Calibration::Mono(rc))
            if !l.camera.lens_model().is_wide() && !rc.camera.lens_model().is_wide() =>
        {
            Ok(Calibration::Stereo(StereoCalibration {
                rig: rig(l.camera, rc.camera, r, translation, what)?,
                rectification,
                rms_px: None,
                per_view_rms_px: Vec::new(),
            }))
        }
        (Calibration::Mono(l), Calibration::Mono(rc))
            if l.camera.lens_model().is_wide() && rc.camera.lens_model().is_wide() =>
        {
            let right_from_left = Isometry3::from_rotation_translation(r, translation).map_err(model(what))?;
            Ok(Calibration::Stereo(StereoCalibration {
                rig: StereoRig::new(l.camera, rc.camera, right_from_left).map_err(model(what))?,
                rectification,
                rms_px: None,
                per_view_rms_px: Vec::new(),
            }))
        }
        _ => Err(content(
            what,
            "one camera_info is equidistant (fisheye) and the other plumb_bob/rational_polynomial: a rig has two \
             cameras of one family",
        )),
    }
}

/// OpenCV's `Q` of a horizontal rectified pair from `P1`, `P2` (`stereoRectify`'s formula).
fn q_from(p1: &[[f64; 4]; 3], p2: &[[f64; 4]; 3]) -> [[f64; 4]; 4] {
    let f = p1[0][0];
    let (cx1, cy, cx2) = (p1[0][2], p1[1][2], p2[0][2]);
    let tx = p2[0][3] / p2[0][0];
    [[1.0, 0.0, 0.0, -cx1], [0.0, 1.0, 0.0, -cy], [0.0, 0.0, 0.0, f], [0.0, 0.0, -1.0 / tx, (cx1 - cx2) / tx]]
}
