//! Calibration files that other tools read and write.
//!
//! One model ([`Calibration`]: a mono camera, a stereo rig with its rectification, or a hand-eye
//! transform; the cameras of any lens — Brown–Conrady, Kannala–Brandt or double sphere) and six
//! formats, each read and written:
//!
//! | [`Format`] | files | holds |
//! |---|---|---|
//! | `Ron` | `.ron` | the project's native records (a `rig`/`camera`/`transform` in the project's own form, plus the same values under OpenCV's names, row-major) |
//! | `Json` | `.json` | the same records as JSON (serde) |
//! | `OpenCvYaml` | `.yml`, `.yaml` | OpenCV `FileStorage` YAML: `%YAML:1.0`, `!!opencv-matrix` (`rows cols dt data`) |
//! | `OpenCvXml` | `.xml` | OpenCV `FileStorage` XML: `<opencv_storage>`, `type_id="opencv-matrix"` |
//! | `Ros` | `--format ros` | ROS `camera_info` YAML, one file per camera (`<stem>_left.yaml`, `<stem>_right.yaml`) |
//! | `Kalibr` | `--format kalibr` | Kalibr camchain YAML (`cam0`, `cam1`, pinhole-radtan, `T_cn_cnm1`) |
//!
//! Key names are OpenCV's calibration samples': mono `camera_matrix`, `distortion_coefficients`,
//! `image_width`, `image_height`, `avg_reprojection_error`, `per_view_reprojection_errors`; stereo
//! `M1 D1 M2 D2 R T E F R1 R2 P1 P2 Q` (one file, or `stereo_calib.cpp`'s `intrinsics.yml` and
//! `extrinsics.yml` given together); hand-eye `R_cam2gripper`/`t_cam2gripper` (eye-to-hand
//! `R_cam2base`/`t_cam2base`), the names of `calibrateHandEye`'s outputs.
//!
//! **Wide-angle lenses** (a [`MonoCalibration`] or [`StereoCalibration`] whose cameras have a
//! Kannala–Brandt or double sphere lens) carry their model in every format that has one, and are
//! refused by the formats that have none:
//!
//! | lens | OpenCV YAML / XML | ROS `camera_info` | Kalibr camchain | RON / JSON |
//! |---|---|---|---|---|
//! | Kannala–Brandt (`cv::fisheye`) | `fisheye_model: 1` (OpenCV's `camera_calibration.cpp`), `camera_matrix`, `distortion_coefficients` 4x1 = `k1 k2 k3 k4`; stereo `M1 D1 M2 D2 R T E` (+ `R1 R2 P1 P2 Q`) | `distortion_model: equidistant`, `D` 1x4 (ROS's `camera_calibration`) | `camera_model: pinhole`, `distortion_model: equidistant`, intrinsics `[fu fv pu pv]`, coefficients `[k1 k2 k3 k4]` | [`MonoRecord`] / [`StereoRecord`]: the camera, `lens_model: kannala_brandt` and the `cv::fisheye` matrices |
//! | double sphere | refused (no such model) | refused | `camera_model: ds`, intrinsics `[xi alpha fu fv pu pv]`, `distortion_model: none` | the same records, `lens_model: double_sphere` |
//!
//! Reading never guesses the lens: an OpenCV or ROS file is fisheye only when marked
//! (`fisheye_model: 1`, or `distortion_model: equidistant` / `fisheye`) and then needs exactly 4
//! coefficients; a 4-value `D` without a marker is OpenCV's pinhole `k1 k2 p1 p2`. Kalibr's
//! `eucm` and `omni` have no parallax model and are refused. OpenCV and ROS mark a whole rig with
//! one lens family: a rig of a Brown–Conrady and a wide lens is written as RON, JSON or Kalibr
//! only. A rig written as ROS without a rectification gets [`rectify_default`]'s.
//!
//! ```
//! use parallax_interop::{Calibration, Format, MonoCalibration, parse, render};
//! use parallax_interop::parallax_camera_model::{DoubleSphere, Camera, Lens, Intrinsics};
//!
//! let ds = Lens::DoubleSphere(DoubleSphere::new(-0.2, 0.6).unwrap());
//! let camera = Camera::new(Intrinsics::new(250.0, 250.0, 319.5, 239.5), ds, 640, 480).unwrap();
//! let mono = Calibration::Mono(MonoCalibration { camera, rms_px: None, per_view_rms_px: vec![] });
//! let kalibr = &render(&mono, Format::Kalibr, "camchain.yaml".as_ref()).unwrap()[0].1;
//! assert!(kalibr.contains("camera_model: ds"));
//! let (back, format) = parse(kalibr, "camchain.yaml").unwrap();
//! assert_eq!((back, format), (mono.clone(), Format::Kalibr));
//! let err = render(&mono, Format::OpenCvYaml, "camera.yml".as_ref()).unwrap_err().to_string();
//! assert!(err.contains("double-sphere") && err.contains("kalibr"));
//! ```
//!
//! Lengths (`T`, `P2`'s baseline column, `T_cn_cnm1`, hand-eye translations) are written in the
//! calibration's own unit (the board square's); ROS and Kalibr expect metres.
//!
//! **Targets** ([`read_target`]): Kalibr's target YAML (`target_type: aprilgrid | checkerboard |
//! circlegrid`, lengths in metres), the project's own `TargetDescription` records, or a text file
//! with one `--board` description line.
//!
//! **Reading detects the format from the content** ([`detect`]), whatever the extension, and
//! finds the calibration wherever it sits in the document ([`read`]): a result file of any
//! `cargo xtask` command, a bare `StereoRig` or `Camera`, OpenCV, ROS or Kalibr keys. A stereo
//! rig is preferred over a camera (a stereo result holds two), the shallowest match wins, and a
//! native file whose `rig` and `opencv` matrices disagree, or whose pose view (`right_from_left`
//! in every convention) does not describe the rig, is refused (it was edited in one place).
//!
//! **One matrix layout**: every matrix in the native records is row-major nested arrays,
//! `m[row][col]` (numpy's `np.array(m)`); rotations are also given as 3x3 matrices
//! ([`PoseRecord`]: translation, quaternion `(x, y, z, w)`, rotation matrix, rotation vector in
//! radians and the ROS `tf` line `x y z qx qy qz qw`).
//!
//! ```
//! use parallax_interop::{Calibration, Format, MonoCalibration, parse, render};
//! use parallax_interop::parallax_camera_model::{Camera, Distortion, Intrinsics};
//!
//! let camera = Camera::new(
//!     Intrinsics::new(600.0, 601.0, 320.5, 240.25),
//!     Distortion::new(-0.12, 0.05, 5e-4, -3e-4, 0.0),
//!     640,
//!     480,
//! )
//! .unwrap();
//! let mono = Calibration::Mono(MonoCalibration { camera, rms_px: Some(0.12), per_view_rms_px: vec![] });
//! for format in [Format::OpenCvYaml, Format::OpenCvXml, Format::Json, Format::Ron, Format::Ros, Format::Kalibr] {
//!     let files = render(&mono, format, "camera.yml".as_ref()).unwrap();
//!     let (back, detected) = parse(&files[0].1, "camera").unwrap();
//!     assert_eq!(detected, format);
//!     // Every format holds the camera exactly (Kalibr and ROS drop the RMS).
//!     assert_eq!(back.camera(Default::default(), "camera").unwrap(), camera);
//! }
//! let yaml = &render(&mono, Format::OpenCvYaml, "camera.yml".as_ref()).unwrap()[0].1;
//! assert!(yaml.starts_with("%YAML:1.0\n---\n") && yaml.contains("camera_matrix: !!opencv-matrix"));
//! ```

mod error;
mod interpret;
mod model;
pub mod opencv;
mod rig;
mod target;
mod unique;
mod write;

use std::path::Path;

pub use glam;
pub use parallax_camera_model;

pub use error::{InteropError, Result};
pub use interpret::{interpret, rig_from_ros_pair};
pub use model::{
    Calibration, HandEyeCalibration, HandEyeRecord, KannalaBrandtMatrices, MonoCalibration, MonoMatrices, MonoRecord,
    OpenCvCamera, PoseRecord, RectificationMatrices, RectificationRows, RectifiedRecord, Rows3, Side,
    StereoCalibration, StereoMatrices, StereoRecord, distortion_vector, lens_model_name, mat3, rows3, setup_from_name,
    setup_name,
};
pub use target::{parse_target, read_target};
pub use write::{
    ModelTerms, RigFile, check_model_fits, native_string, opencv_entries, record_string, render, render_rig,
    ros_pair_paths,
};

use error::{content, syntax};
use serde_json::Value;

/// A file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// RON, the native format.
    Ron,
    /// JSON.
    Json,
    /// OpenCV `FileStorage` YAML.
    OpenCvYaml,
    /// OpenCV `FileStorage` XML.
    OpenCvXml,
    /// ROS `camera_info` YAML.
    Ros,
    /// Kalibr camchain YAML.
    Kalibr,
}

/// The `--format` names and extensions, for messages.
pub const FORMATS: &str =
    "ron (.ron), json (.json), opencv (.yml, .yaml, .xml), ros (camera_info .yaml), kalibr (camchain .yaml)";

impl Format {
    /// The `--format` name (`opencv` for both OpenCV forms).
    pub fn name(self) -> &'static str {
        match self {
            Self::Ron => "ron",
            Self::Json => "json",
            Self::OpenCvYaml => "opencv",
            Self::OpenCvXml => "opencv (xml)",
            Self::Ros => "ros",
            Self::Kalibr => "kalibr",
        }
    }

    /// The output format of `path`: `explicit` (`ron`, `json`, `opencv`, `ros`, `kalibr`; `opencv`
    /// is XML for a `.xml` path, YAML otherwise) or the extension (`.ron`, `.json`,
    /// `.yml`/`.yaml`/`.xml` = OpenCV). Anything else is refused with the list of formats.
    pub fn for_output(path: &Path, explicit: Option<&str>) -> Result<Self> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        let refuse = |what: String| {
            InteropError::Unsupported(format!(
                "{what}: the formats are {FORMATS}; choose with the extension or --format"
            ))
        };
        match explicit.map(str::to_ascii_lowercase).as_deref() {
            Some("ron") => Ok(Self::Ron),
            Some("json") => Ok(Self::Json),
            Some("opencv") if ext.as_deref() == Some("xml") => Ok(Self::OpenCvXml),
            Some("opencv") => Ok(Self::OpenCvYaml),
            Some("ros") => Ok(Self::Ros),
            Some("kalibr") => Ok(Self::Kalibr),
            Some(other) => Err(refuse(format!("unknown format {other:?}"))),
            None => match ext.as_deref() {
                Some("ron") => Ok(Self::Ron),
                Some("json") => Ok(Self::Json),
                Some("yml" | "yaml") => Ok(Self::OpenCvYaml),
                Some("xml") => Ok(Self::OpenCvXml),
                Some(e) => Err(refuse(format!("{}: unknown extension .{e}", path.display()))),
                None => Err(refuse(format!("{}: no extension", path.display()))),
            },
        }
    }
}

/// RON as a value tree (struct names dropped, fields as map keys).
fn ron_value(text: &str, what: &str) -> Result<Value> {
    let v: ron::Value = ron::from_str(text).map_err(|e| syntax(what, format!("RON: {e}")))?;
    ron::from_str::<unique::UniqueKeys>(text).map_err(|e| syntax(what, format!("RON: {e}")))?;
    serde_json::to_value(v).map_err(|e| syntax(what, format!("RON value: {e}")))
}

/// Kalibr (`cam0`) or ROS (`distortion_model`, `projection_matrix`) by their keys.
fn yaml_kind(v: &Value) -> Option<Format> {
    let o = v.as_object()?;
    if o.contains_key("cam0") {
        Some(Format::Kalibr)
    } else if o.contains_key("distortion_model") || o.contains_key("projection_matrix") {
        Some(Format::Ros)
    } else {
        None
    }
}

/// The format of `text` (from the content, not the name) and its value tree.
pub fn detect(text: &str, what: &str) -> Result<(Format, Value)> {
    check_nesting(text, what)?;
    if opencv::is_opencv_xml(text) {
        return Ok((Format::OpenCvXml, opencv::parse_xml(text, what)?));
    }
    if text.trim_start().starts_with('<') {
        return Err(syntax(
            what,
            "XML without <opencv_storage>: not an OpenCV FileStorage file (a ViSP camera file is read by \
             `handeye --intrinsics` only)",
        ));
    }
    if opencv::is_opencv_yaml(text) {
        let v = opencv::parse_yaml(text, what)?;
        // A `%YAML` directive alone does not make a file OpenCV's: ROS and Kalibr files may
        // carry one too.
        let format = yaml_kind(&v).unwrap_or(Format::OpenCvYaml);
        return Ok((format, v));
    }
    if let Ok(v) = serde_json::from_str::<Value>(text) {
        serde_json::from_str::<unique::UniqueKeys>(text).map_err(|e| syntax(what, format!("JSON: {e}")))?;
        return Ok((Format::Json, v));
    }
    let ron_result = ron_value(text, what);
    if let Ok(v) = ron_result {
        return Ok((Format::Ron, v));
    }
    match opencv::parse_yaml(text, what) {
        Ok(v @ Value::Object(_)) => {
            let format = yaml_kind(&v).unwrap_or(Format::OpenCvYaml);
            Ok((format, v))
        }
        _ => Err(syntax(
            what,
            format!(
                "not a calibration file in any known format ({FORMATS}); as RON: {}",
                ron_result.err().map(|e| e.to_string()).unwrap_or_default()
            ),
        )),
    }
}

/// The calibration in `text` and the detected format (`what` names it in errors).
pub fn parse(text: &str, what: &str) -> Result<(Calibration, Format)> {
    let (format, value) = detect(text, what)?;
    Ok((interpret(&value, what)?, format))
}

/// Largest text file read as a calibration, target, pose or result file: 64 MiB (calibration
/// files are kilobytes; a corners file of thousands of images a few megabytes).
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

/// Deepest nesting of brackets (`[`, `{`, `(`) accepted in a text file, as the JSON and RON
/// parsers' own limit: checked in one linear pass before any parser runs, so a nesting bomb is
/// refused at once instead of parsed in quadratic time or overflowing the stack.
pub const MAX_NESTING: usize = 128;

/// The bytes of `path`, refused beyond `limit` before they are read: a regular file by its size,
/// anything else (a pipe, `/dev/zero`) once `limit + 1` bytes have come. The error
/// (`ErrorKind::FileTooLarge`) gives both figures.
pub fn read_bounded(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let too_large = |size: String| {
        std::io::Error::new(
            std::io::ErrorKind::FileTooLarge,
            format!("{size} bytes, more than the {limit} bytes this input may hold"),
        )
    };
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if meta.is_file() && meta.len() > limit {
        return Err(too_large(meta.len().to_string()));
    }
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(format!("over {limit}")));
    }
    Ok(bytes)
}

/// The UTF-8 text of `path`, at most [`MAX_TEXT_BYTES`].
pub fn read_text_file(path: &Path) -> std::io::Result<String> {
    String::from_utf8(read_bounded(path, MAX_TEXT_BYTES)?)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidData, "not UTF-8 text"))
}

/// Refuses text nested deeper than [`MAX_NESTING`] brackets (outside double-quoted strings).
pub fn check_nesting(text: &str, what: &str) -> Result<()> {
    let (mut depth, mut in_string, mut escaped) = (0usize, false, false);
    for c in text.chars() {
        if in_string {
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, '\\') => escaped = true,
                (false, '"') => in_string = false,
                _ => {}
            }
            continue;
        }
        match c {
            '"' => in_string = true,
            '[' | '{' | '(' => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(syntax(what, format!("nested more than {MAX_NESTING} levels deep: not a calibration")));
                }
            }
            ']' | '}' | ')' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    Ok(())
}

fn read_text(path: &Path) -> Result<String> {
    read_text_file(path).map_err(|source| InteropError::Io { path: path.to_path_buf(), source })
}

/// The calibration in one file, or in two read together: OpenCV's `intrinsics.yml` +
/// `extrinsics.yml` (their keys merged), or two ROS `camera_info` files, left then right
/// (the rig from their rectification and projection matrices). Returns the formats found.
pub fn read<P: AsRef<Path>>(paths: &[P]) -> Result<(Calibration, Vec<Format>)> {
    read_inner(paths, None).map(|(c, f, _)| (c, f))
}

/// [`read`] for a command that holds the calibrated images: an OpenCV file without an image
/// size (`stereo_calib.cpp` writes `M1 D1 M2 D2` and `R T R1 R2 P1 P2 Q` without one) takes
/// `image_size`, the images'. The flag says whether it did, for the caller to say so. A file
/// with a size keeps it (and a caller compares it with its images).
pub fn read_with_image_size<P: AsRef<Path>>(
    paths: &[P],
    image_size: (u32, u32),
) -> Result<(Calibration, Vec<Format>, bool)> {
    read_inner(paths, Some(image_size))
}

/// Adds `image_width` / `image_height` to an OpenCV camera map (`M1` or `camera_matrix`) that
/// has no image size at all; returns whether it did.
fn add_missing_size(value: &mut Value, size: Option<(u32, u32)>) -> bool {
    let (Some((w, h)), Value::Object(o)) = (size, value) else { return false };
    let size_keys = ["image_width", "image_height", "imageSize", "image_size", "width", "height"];
    let opencv_camera = o.contains_key("M1") || o.contains_key("camera_matrix");
    if !opencv_camera || size_keys.iter().any(|k| o.contains_key(*k)) {
        return false;
    }
    o.insert("image_width".into(), Value::from(w));
    o.insert("image_height".into(), Value::from(h));
    true
}

fn read_inner<P: AsRef<Path>>(paths: &[P], size: Option<(u32, u32)>) -> Result<(Calibration, Vec<Format>, bool)> {
    match paths {
        [one] => {
            let p = one.as_ref();
            let what = p.display().to_string();
            let (f, mut v) = detect(&read_text(p)?, &what)?;
            if rig::is_rig(&v) {
                return Err(content(
                    &what,
                    "a rig of several cameras: choose two of them (`rectify --pair I,J`, camera I left)",
                ));
            }
            let sized = add_missing_size(&mut v, size);
            Ok((interpret(&v, &what)?, vec![f], sized))
        }
        [a, b] => {
            let (a, b) = (a.as_ref(), b.as_ref());
            let what = format!("{} + {}", a.display(), b.display());
            let (fa, va) = detect(&read_text(a)?, &a.display().to_string())?;
            let (fb, vb) = detect(&read_text(b)?, &b.display().to_string())?;
            if fa == Format::Ros && fb == Format::Ros {
                return Ok((rig_from_ros_pair(&va, &vb, &what)?, vec![fa, fb], false));
            }
            let (Value::Object(mut merged), Value::Object(second)) = (va, vb) else {
                return Err(content(&what, "two files are read together only when both are key-value maps"));
            };
            for (k, v) in second {
                match merged.get(&k) {
                    Some(old) if *old != v => {
                        return Err(content(&what, format!("both files define `{k}`, with different values")));
                    }
                    _ => {
                        merged.insert(k, v);
                    }
                }
            }
            let mut merged = Value::Object(merged);
            let sized = add_missing_size(&mut merged, size);
            Ok((interpret(&merged, &what)?, vec![fa, fb], sized))
        }
        _ => Err(InteropError::Unsupported(format!(
            "{} calibration files given: give one, or two read together (OpenCV intrinsics + extrinsics, or ROS \
             camera_info left + right)",
            paths.len()
        ))),
    }
}

/// Cameras `i` (left) and `j` (right) of a rig file (a Kalibr camchain of any number of
/// cameras, OpenCV FileStorage in `calibrateMultiview`'s terms, or `calibrate --camera`'s
/// record) as a stereo calibration, checked as any stereo file is.
pub fn read_rig_pair(path: &Path, pair: (usize, usize)) -> Result<Calibration> {
    let what = path.display().to_string();
    parse_rig_pair(&read_text(path)?, pair, &what)
}

/// [`read_rig_pair`] on text already in memory; `what` names it in errors.
pub fn parse_rig_pair(text: &str, pair: (usize, usize), what: &str) -> Result<Calibration> {
    let (_, v) = detect(text, what)?;
    rig::rig_pair(&v, pair, what)
}

/// A native result file (RON or JSON, detected from the content) deserialised as `T`: for the
/// commands' own files that are not calibrations (corner lists, measurements).
pub fn read_native<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let what = path.display().to_string();
    let text = read_text(path)?;
    match detect(&text, &what)? {
        (Format::Json, _) => serde_json::from_str(&text).map_err(|e| content(&what, format!("JSON: {e}"))),
        (Format::Ron, _) => ron::from_str(&text).map_err(|e| content(&what, format!("RON: {e}"))),
        (other, _) => Err(content(&what, format!("a {} file; this input is read from ron or json", other.name()))),
    }
}

/// A stereo calibration from [`read`], or an error naming what the files hold instead.
pub fn read_stereo<P: AsRef<Path>>(paths: &[P]) -> Result<StereoCalibration> {
    let names: Vec<String> = paths.iter().map(|p| p.as_ref().display().to_string()).collect();
    read(paths)?.0.into_stereo(&names.join(" + "))
}

/// The rectification written into calibration files when none is given, and `cargo xtask
/// rectify`'s default: OpenCV's `stereoRectify` with `alpha = 0` (only valid pixels) and
/// `CALIB_ZERO_DISPARITY`, OpenCV's extents — one setting, so that every file's `R1 R2 P1 P2 Q`
/// matches the images `rectify` produces by default.
pub fn default_rectify_config() -> parallax_stereo_rectify::RectifyConfig {
    parallax_stereo_rectify::RectifyConfig {
        alpha: Some(0.0),
        new_size: None,
        zero_disparity: true,
        extents: parallax_stereo_rectify::ExtentMethod::OpenCv,
        ..Default::default()
    }
}

/// `R1 R2 P1 P2 Q` of `rig`, written into files that need them when none are given: with
/// [`default_rectify_config`] for a Brown–Conrady rig; for a rig with a wide lens
/// `cv::fisheye::stereoRectify` with OpenCV's defaults (`balance = 0`, `fov_scale = 1`, the input
/// size, `CALIB_ZERO_DISPARITY`). A wide rig whose image edges lie 90° or more from the rectified
/// axis has no pinhole rectification: that is an error (rectify it with a chosen `fov_scale` and
/// write the result).
pub fn rectify_default(rig: &parallax_camera_model::StereoRig) -> Result<RectificationMatrices> {
    if !(rig.has_wide_lens()) {
        let r = parallax_stereo_rectify::stereo_rectify(rig, &default_rectify_config())
            .map_err(|e| InteropError::Unsupported(format!("rectifying the rig: {e}")))?;
        return Ok(RectificationMatrices::from(&r));
    }
    let r = parallax_stereo_rectify::stereo_rectify(rig, &parallax_stereo_rectify::RectifyConfig::default()).map_err(
        |e| {
            InteropError::Unsupported(format!(
                "rectifying the fisheye rig to a pinhole pair (ROS camera_info needs R and P): {e}; rectify it with \
                 a field of view that fits (fov_scale) and write the calibration with that rectification"
            ))
        },
    )?;
    Ok(RectificationMatrices::from(&r))
}
