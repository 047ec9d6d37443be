//! `parallax._parallax`: the Rust side of the Python package. Functions take numpy images and
//! plain sequences of numbers and return dicts and numpy arrays; `parallax/__init__.py` gives
//! them OpenCV's names, argument orders and array shapes. Every computation runs with the GIL
//! released; every error is a `parallax.ParallaxError` (a `ValueError`) carrying our message.

use std::path::PathBuf;
use std::sync::{Arc, Mutex, PoisonError, Weak};

use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use parallax::camera::{Camera, Distortion, Isometry3, Lens, StereoRig};
use parallax::glam::{DMat3, DVec2, DVec3};
use parallax::image::{GrayImage, ImageBuffer, Luma, RgbImage};
use parallax::matching::{BlockMatcher, Gray16Image};
use pyo3::prelude::*;
use pyo3::types::PyDict;

pyo3::create_exception!(
    _parallax,
    ParallaxError,
    pyo3::exceptions::PyValueError,
    "An input parallax refuses or a computation that failed, with parallax's message."
);

/// Any error as a `ParallaxError` with its message and its causes.
fn err(e: impl std::fmt::Display) -> PyErr {
    ParallaxError::new_err(e.to_string())
}

/// Two numpy arrays of one element type (a pair of images or maps).
type ArrayPair<'py, T> = (Bound<'py, PyArrayDyn<T>>, Bound<'py, PyArrayDyn<T>>);

/// An image of the matcher: grey 8-bit, grey 16-bit or colour.
enum Image {
    Grey(GrayImage),
    Grey16(Gray16Image),
    Rgb(RgbImage),
}

/// A numpy image (`H x W` or `H x W x 1` uint8 / uint16, `H x W x 3` uint8 RGB) as an image.
fn image(a: &Bound<'_, PyAny>) -> PyResult<Image> {
    fn dims(shape: &[usize]) -> PyResult<(u32, u32, usize)> {
        let (h, w, c) = match *shape {
            [h, w] => (h, w, 1),
            [h, w, c] => (h, w, c),
            _ => return Err(err(format!("an image must be H x W or H x W x C, got the shape {shape:?}"))),
        };
        if !(c == 1 || c == 3) || h == 0 || w == 0 {
            return Err(err(format!("an image must be grey (1 channel) or RGB (3 channels), got the shape {shape:?}")));
        }
        Ok((u32::try_from(w).map_err(err)?, u32::try_from(h).map_err(err)?, c))
    }
    if let Ok(a) = a.extract::<PyReadonlyArrayDyn<'_, u8>>() {
        let (w, h, c) = dims(a.shape())?;
        // a C-contiguous array is copied at once; any other layout element by element
        let data = a.as_slice().map_or_else(|_| a.as_array().iter().copied().collect(), <[u8]>::to_vec);
        return Ok(if c == 3 {
            Image::Rgb(RgbImage::from_raw(w, h, data).expect("h x w x 3 values"))
        } else {
            Image::Grey(GrayImage::from_raw(w, h, data).expect("h x w values"))
        });
    }
    if let Ok(a) = a.extract::<PyReadonlyArrayDyn<'_, u16>>() {
        let (w, h, c) = dims(a.shape())?;
        if c != 1 {
            return Err(err("16-bit images are matched as grey: give an H x W uint16 array"));
        }
        let data = a.as_slice().map_or_else(|_| a.as_array().iter().copied().collect(), <[u16]>::to_vec);
        return Ok(Image::Grey16(ImageBuffer::<Luma<u16>, Vec<u16>>::from_raw(w, h, data).expect("h x w values")));
    }
    Err(err("an image must be a numpy array of uint8 (grey or RGB) or uint16 (grey)"))
}

/// [`image`] into the memory of `buf` when the array is 8-bit and C-contiguous (a matcher's
/// frames reuse their buffers: no fresh pages per frame).
fn image_reusing(a: &Bound<'_, PyAny>, buf: &mut Vec<u8>) -> PyResult<Image> {
    if let Ok(arr) = a.extract::<PyReadonlyArrayDyn<'_, u8>>()
        && let Ok(slice) = arr.as_slice()
    {
        let shape = arr.shape().to_vec();
        if let ([h, w] | [h, w, 1] | [h, w, 3], true) = (shape.as_slice(), !slice.is_empty()) {
            let (w, h) = (u32::try_from(*w).map_err(err)?, u32::try_from(*h).map_err(err)?);
            let mut data = std::mem::take(buf);
            data.clear();
            data.extend_from_slice(slice);
            return Ok(if shape.len() == 3 && shape[2] == 3 {
                Image::Rgb(RgbImage::from_raw(w, h, data).expect("h x w x 3 values"))
            } else {
                Image::Grey(GrayImage::from_raw(w, h, data).expect("h x w values"))
            });
        }
    }
    image(a)
}

/// The memory of an 8-bit image back for the next frame.
fn give_back(img: Image, buf: &mut Vec<u8>) {
    match img {
        Image::Grey(g) => *buf = g.into_raw(),
        Image::Rgb(c) => *buf = c.into_raw(),
        Image::Grey16(_) => {}
    }
}

/// The memory of the float32 maps `StereoMatcher.compute` returns, kept for the next frames once
/// numpy frees the arrays. Fresh memory for every returned array costs the kernel's zeroing of
/// its pages on first touch, several times the rest of the call (see the journal's overhead
/// entry); arrays made from a buffer of an earlier frame that the caller dropped do not.
#[derive(Default)]
struct ResultPool(Arc<Mutex<Vec<Vec<f32>>>>);

impl ResultPool {
    /// Buffers kept at most (two maps a frame, two frames): a caller who keeps every result gets
    /// fresh memory, as without the pool; one who drops them reuses the same few buffers.
    const KEEP: usize = 4;

    /// A new `H x W` float32 array holding `values`, on a pooled buffer when one is free.
    fn array<'py>(
        &self,
        py: Python<'py>,
        values: &[f32],
        (h, w): (usize, usize),
    ) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        assert_eq!(values.len(), h * w, "a map of {w} x {h} has {} values", values.len());
        let mut data = self.0.lock().unwrap_or_else(PoisonError::into_inner).pop().unwrap_or_default();
        data.clear();
        data.extend_from_slice(values);
        // Taken before `data` moves into its owner: a pointer from `as_mut_ptr` stays valid
        // across moves of the `Vec` (only reallocation or drop ends it) and may be written through.
        let ptr = data.as_mut_ptr();
        let owner = Bound::new(py, PooledBuffer { data, pool: Arc::downgrade(&self.0) })?;
        // SAFETY: `ptr` points at `h * w` initialised f32 (asserted above), C order, owned by
        // `owner`'s `Vec`, which is never resized or read on the Rust side while it lives and is
        // freed (or pooled) only in `PooledBuffer::drop`. `borrow_from_array` makes `owner` the
        // array's base, so numpy keeps it alive as long as the array or any view of it lives;
        // numpy is then the only user of the memory, reads and writes included.
        let view =
            unsafe { numpy::ndarray::ArrayViewD::from_shape_ptr(numpy::ndarray::IxDyn(&[h, w]), ptr.cast_const()) };
        // SAFETY: as above: the view's memory lives as long as `owner`, the array's base.
        Ok(unsafe { PyArrayDyn::borrow_from_array(&view, owner.into_any()) })
    }
}

/// The owner of a returned map's memory (the numpy array's `base`): gives its buffer back to
/// the matcher's pool when numpy frees it, if the matcher still lives and the pool has room.
#[pyclass(frozen, module = "parallax._parallax")]
struct PooledBuffer {
    data: Vec<f32>,
    pool: Weak<Mutex<Vec<Vec<f32>>>>,
}

impl Drop for PooledBuffer {
    fn drop(&mut self) {
        if let Some(pool) = self.pool.upgrade() {
            let mut pool = pool.lock().unwrap_or_else(PoisonError::into_inner);
            if pool.len() < ResultPool::KEEP {
                pool.push(std::mem::take(&mut self.data));
            }
        }
    }
}

/// Copies `values` into a caller's float32 `H x W` array (checked: its shape, C order).
fn write_into(out: &Bound<'_, PyArrayDyn<f32>>, values: &[f32], (h, w): (usize, usize), what: &str) -> PyResult<()> {
    let mut out = out.try_readwrite().map_err(|e| err(format!("{what}: {e}")))?;
    if out.shape() != [h, w] {
        return Err(err(format!("{what} must be a float32 array of shape ({h}, {w}), got {:?}", out.shape())));
    }
    let dst = out.as_slice_mut().map_err(|_| err(format!("{what} must be C-contiguous")))?;
    dst.copy_from_slice(values);
    Ok(())
}

/// The image as 8-bit grey (RGB by its luma, as the command line reads colour files).
fn grey(img: Image) -> PyResult<GrayImage> {
    match img {
        Image::Grey(g) => Ok(g),
        Image::Rgb(c) => Ok(parallax::image::imageops::grayscale(&c)),
        Image::Grey16(_) => Err(err("this function reads 8-bit images: give a uint8 array")),
    }
}

fn mat3(v: &[f64], what: &str) -> PyResult<DMat3> {
    if v.len() != 9 || v.iter().any(|x| !x.is_finite()) {
        return Err(err(format!("{what} must be 3 x 3 finite numbers, got {} values", v.len())));
    }
    Ok(DMat3::from_cols_array(&[v[0], v[3], v[6], v[1], v[4], v[7], v[2], v[5], v[8]]))
}

fn rows(m: &DMat3) -> Vec<f64> {
    let t = m.transpose().to_cols_array();
    t.to_vec()
}

fn vec3(v: &[f64], what: &str) -> PyResult<DVec3> {
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        return Err(err(format!("{what} must be 3 finite numbers, got {} values", v.len())));
    }
    Ok(DVec3::new(v[0], v[1], v[2]))
}

/// A camera from OpenCV's `K` (row-major), distortion coefficients, lens and image size.
fn camera(k: &[f64], d: &[f64], lens: &str, (w, h): (u32, u32)) -> PyResult<Camera> {
    let k = mat3(k, "a camera matrix")?;
    let lens: Lens = match lens {
        "pinhole" | "brown-conrady" => Distortion::from_opencv(d).map_err(err)?.into(),
        "kannala-brandt" | "fisheye" => parallax::camera::KannalaBrandt::from_opencv(d).map_err(err)?.into(),
        "double-sphere" => match *d {
            [xi, alpha] => parallax::camera::DoubleSphere::new(xi, alpha).map_err(err)?.into(),
            _ => return Err(err(format!("a double-sphere lens has 2 parameters (xi, alpha), got {}", d.len()))),
        },
        other => return Err(err(format!("lens must be pinhole, kannala-brandt or double-sphere, got {other:?}"))),
    };
    let i = parallax::camera::Intrinsics::new(k.x_axis.x, k.y_axis.y, k.z_axis.x, k.z_axis.y);
    let i = parallax::camera::Intrinsics { skew: k.y_axis.x, ..i };
    Camera::new(i, lens, w, h).map_err(err)
}

/// OpenCV's distortion vector of a lens: 5 Brown–Conrady coefficients (8 with the rational
/// terms), 4 Kannala–Brandt ones, or `(xi, alpha)`.
fn distortion(lens: &Lens) -> Vec<f64> {
    let p = lens.parameters();
    match lens {
        Lens::BrownConrady(_) if p[5..].iter().all(|&x| x == 0.0) => p[..5].to_vec(),
        _ => p,
    }
}

fn lens_name(lens: &Lens) -> &'static str {
    lens.model().name()
}

fn points2(v: &[[f64; 2]]) -> Vec<DVec2> {
    v.iter().map(|p| DVec2::new(p[0], p[1])).collect()
}

fn points3(v: &[[f64; 3]]) -> Vec<DVec3> {
    v.iter().map(|p| DVec3::new(p[0], p[1], p[2])).collect()
}

fn lens_model(lens: &str) -> PyResult<parallax::camera::LensModel> {
    Ok(match lens {
        "pinhole" | "brown-conrady" => parallax::camera::LensModel::BrownConrady,
        "kannala-brandt" | "fisheye" => parallax::camera::LensModel::KannalaBrandt,
        "double-sphere" => parallax::camera::LensModel::DoubleSphere,
        other => return Err(err(format!("lens must be pinhole, kannala-brandt or double-sphere, got {other:?}"))),
    })
}

/// The package version (the workspace's).
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

/// Inner corners of a `cols x rows` chessboard in OpenCV's order, or `None`.
#[pyfunction]
fn find_chessboard(
    py: Python<'_>,
    image: &Bound<'_, PyAny>,
    cols: usize,
    rows: usize,
) -> PyResult<Option<Vec<[f64; 2]>>> {
    let img = grey(self::image(image)?)?;
    let found = py
        .detach(|| {
            parallax::corners::find_chessboard(&img, cols, rows, &parallax::corners::ChessboardConfig::default())
        })
        .map_err(err)?;
    Ok(found.map(|g| g.corners.iter().map(|c| [c.x, c.y]).collect()))
}

/// The points of any target (`board` as the command line's `--board`: `charuco:7x5:40:30:DICT_5X5_100`,
/// `aprilgrid:6x6:88:0.3`, `circles:4x11:20:10`, `chessboard:9x6:25`, …) found in an image: their
/// ids, pixels and target coordinates; `None` when the target is not found.
#[pyfunction]
#[allow(clippy::type_complexity)] // (ids, pixels, object points): the three arrays of a view
fn detect_target(
    py: Python<'_>,
    image: &Bound<'_, PyAny>,
    board: &str,
) -> PyResult<Option<(Vec<usize>, Vec<[f64; 2]>, Vec<[f64; 3]>)>> {
    let target = parallax::interop::parse_target(board, "the board").map_err(err)?;
    let img = grey(self::image(image)?)?;
    let found = py.detach(|| parallax::pipeline::stages::detect_target(&img, &target)).map_err(err)?;
    let Some(obs) = found else { return Ok(None) };
    let object = parallax::calibration::object_points_for(&target, &obs, 0).map_err(err)?;
    Ok(Some((
        obs.ids().iter().map(|&i| i as usize).collect(),
        obs.points().iter().map(|p| [p.x, p.y]).collect(),
        object.iter().map(|p| [p.x, p.y, p.z]).collect(),
    )))
}

/// Calibrates one camera of any lens from views of a planar target (`calibrateCamera`).
#[pyfunction]
#[pyo3(signature = (object_points, image_points, width, height, lens="pinhole", fix_principal_point=false, fix_aspect_ratio=false, zero_tangential=false, fix_k3=false, rational_model=false))]
#[allow(clippy::too_many_arguments)] // OpenCV's flags, one argument each
fn calibrate_camera<'py>(
    py: Python<'py>,
    object_points: Vec<Vec<[f64; 3]>>,
    image_points: Vec<Vec<[f64; 2]>>,
    width: u32,
    height: u32,
    lens: &str,
    fix_principal_point: bool,
    fix_aspect_ratio: bool,
    zero_tangential: bool,
    fix_k3: bool,
    rational_model: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let config = parallax::calibration::CalibrationConfig {
        lens: lens_model(lens)?,
        fix_principal_point,
        fix_aspect_ratio,
        zero_tangential,
        fix_k3,
        rational_model,
        ..Default::default()
    };
    let objects: Vec<Vec<DVec3>> = object_points.iter().map(|v| points3(v)).collect();
    let images: Vec<Vec<DVec2>> = image_points.iter().map(|v| points2(v)).collect();
    let r = py
        .detach(|| parallax::calibration::calibrate_camera(&objects, &images, width, height, &config))
        .map_err(err)?;
    let out = PyDict::new(py);
    out.set_item("rms", r.rms_px)?;
    out.set_item("K", rows(&r.camera.intrinsics.matrix()))?;
    out.set_item("D", distortion(&r.camera.lens))?;
    out.set_item("lens", lens_name(&r.camera.lens))?;
    out.set_item("rvecs", r.camera_from_board.iter().map(|p| p.rvec().to_array()).collect::<Vec<_>>())?;
    out.set_item("tvecs", r.camera_from_board.iter().map(|p| p.translation.to_array()).collect::<Vec<_>>())?;
    let s = &r.std_devs;
    let lens_std = s.lens(r.camera.lens.model());
    let mut std_intrinsics: Vec<Option<f64>> = vec![s.fx, s.fy, s.cx, s.cy];
    std_intrinsics.extend(lens_std.iter().take(distortion(&r.camera.lens).len()));
    out.set_item("std_intrinsics", std_intrinsics.iter().map(|v| v.unwrap_or(0.0)).collect::<Vec<_>>())?;
    out.set_item(
        "std_extrinsics",
        r.pose_std_devs
            .iter()
            .map(|p| [p.rotation_rad.to_array(), p.translation.to_array()].concat())
            .collect::<Vec<_>>(),
    )?;
    out.set_item("per_view_errors", r.per_view_rms_px.clone())?;
    out.set_item("warnings", r.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>())?;
    Ok(out)
}

/// Calibrates a stereo rig from views of a planar target seen by both cameras (`stereoCalibrate`).
#[pyfunction]
#[pyo3(signature = (object_points, image_points1, image_points2, size1, size2, lens="pinhole"))]
fn stereo_calibrate<'py>(
    py: Python<'py>,
    object_points: Vec<Vec<[f64; 3]>>,
    image_points1: Vec<Vec<[f64; 2]>>,
    image_points2: Vec<Vec<[f64; 2]>>,
    size1: (u32, u32),
    size2: (u32, u32),
    lens: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let model = lens_model(lens)?;
    let mut config = parallax::calibration::StereoConfig::default();
    config.left.lens = model;
    config.right.lens = model;
    let objects: Vec<Vec<DVec3>> = object_points.iter().map(|v| points3(v)).collect();
    let left: Vec<Vec<DVec2>> = image_points1.iter().map(|v| points2(v)).collect();
    let right: Vec<Vec<DVec2>> = image_points2.iter().map(|v| points2(v)).collect();
    let r = py
        .detach(|| parallax::calibration::calibrate_stereo(&objects, &left, &right, size1, size2, &config))
        .map_err(err)?;
    let out = PyDict::new(py);
    out.set_item("rms", r.rms_px)?;
    for (k, c) in [("1", &r.rig.left), ("2", &r.rig.right)] {
        out.set_item(format!("K{k}"), rows(&c.intrinsics.matrix()))?;
        out.set_item(format!("D{k}"), distortion(&c.lens))?;
    }
    out.set_item("R", rows(&r.rig.right_from_left.rotation_matrix()))?;
    out.set_item("T", r.rig.right_from_left.translation.to_array())?;
    out.set_item("E", rows(&r.essential))?;
    out.set_item("F", rows(&r.fundamental))?;
    out.set_item("per_view_errors", r.per_view_rms_px.clone())?;
    out.set_item("lens", lens_name(&r.rig.left.lens))?;
    Ok(out)
}

/// One camera's view of a frame: object points and their pixels (`None`: not seen).
type FrameView = Option<(Vec<[f64; 3]>, Vec<[f64; 2]>)>;

/// Calibrates a rig of N cameras in one joint problem (OpenCV 5's `calibrateMultiview`):
/// `frames[f][c]` what camera `c` saw in frame `f`, or `None`; `lenses` one per camera. Camera 0
/// is the reference: every extrinsic is `camI_from_cam0`.
#[pyfunction]
fn calibrate_rig<'py>(
    py: Python<'py>,
    frames: Vec<Vec<FrameView>>,
    sizes: Vec<(u32, u32)>,
    lenses: Vec<String>,
) -> PyResult<Bound<'py, PyDict>> {
    if lenses.len() != sizes.len() {
        return Err(err(format!("{} lenses for {} cameras", lenses.len(), sizes.len())));
    }
    let cameras = lenses
        .iter()
        .map(|l| Ok(parallax::calibration::CalibrationConfig { lens: lens_model(l)?, ..Default::default() }))
        .collect::<PyResult<Vec<_>>>()?;
    let config = parallax::calibration::RigConfig { cameras, ..Default::default() };
    let frames: Vec<Vec<Option<parallax::calibration::CameraView>>> = frames
        .iter()
        .map(|f| {
            f.iter()
                .map(|v| {
                    v.as_ref().map(|(o, i)| parallax::calibration::CameraView { object: points3(o), image: points2(i) })
                })
                .collect()
        })
        .collect();
    let r = py.detach(|| parallax::calibration::calibrate_rig(&frames, &sizes, &config)).map_err(err)?;
    let out = PyDict::new(py);
    out.set_item("rms", r.rms_px)?;
    out.set_item("K", r.cameras.iter().map(|c| rows(&c.intrinsics.matrix())).collect::<Vec<_>>())?;
    out.set_item("D", r.cameras.iter().map(|c| distortion(&c.lens)).collect::<Vec<_>>())?;
    out.set_item("R", r.cam_from_cam0.iter().map(|p| rows(&p.rotation_matrix())).collect::<Vec<_>>())?;
    out.set_item("T", r.cam_from_cam0.iter().map(|p| p.translation.to_array()).collect::<Vec<_>>())?;
    out.set_item("camera_rms", r.camera_rms_px.clone())?;
    out.set_item("per_view_errors", r.per_view_rms_px.clone())?;
    out.set_item("warnings", r.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>())?;
    Ok(out)
}

/// A rig from OpenCV's matrices.
#[allow(clippy::too_many_arguments)] // both cameras, the size and the pose, as OpenCV takes them
fn rig(
    k1: &[f64],
    d1: &[f64],
    k2: &[f64],
    d2: &[f64],
    lens: &str,
    size: (u32, u32),
    r: &[f64],
    t: &[f64],
) -> PyResult<StereoRig> {
    let pose = Isometry3::from_rotation_translation(mat3(r, "R")?, vec3(t, "T")?).map_err(err)?;
    StereoRig::new(camera(k1, d1, lens, size)?, camera(k2, d2, lens, size)?, pose).map_err(err)
}

/// The matrices of a rectification as a dict.
fn rectification_dict<'py>(py: Python<'py>, r: &parallax::rectify::Rectification) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item("R1", rows(&r.r1))?;
    out.set_item("R2", rows(&r.r2))?;
    out.set_item("P1", r.p1.rows.concat())?;
    out.set_item("P2", r.p2.rows.concat())?;
    out.set_item("Q", r.q.concat())?;
    out.set_item("roi1", (r.roi1.x, r.roi1.y, r.roi1.width, r.roi1.height))?;
    out.set_item("roi2", (r.roi2.x, r.roi2.y, r.roi2.width, r.roi2.height))?;
    out.set_item("size", (r.width, r.height))?;
    Ok(out)
}

fn rectify_config(alpha: f64, new_size: (u32, u32)) -> parallax::rectify::RectifyConfig {
    parallax::rectify::RectifyConfig {
        alpha: (alpha >= 0.0).then_some(alpha),
        new_size: (new_size != (0, 0)).then_some(new_size),
        ..Default::default()
    }
}

/// Bouguet rectification of a rig (`stereoRectify`).
#[pyfunction]
#[pyo3(signature = (k1, d1, k2, d2, size, r, t, alpha=-1.0, new_size=(0, 0), lens="pinhole"))]
#[allow(clippy::too_many_arguments)] // OpenCV's arguments
fn stereo_rectify<'py>(
    py: Python<'py>,
    k1: Vec<f64>,
    d1: Vec<f64>,
    k2: Vec<f64>,
    d2: Vec<f64>,
    size: (u32, u32),
    r: Vec<f64>,
    t: Vec<f64>,
    alpha: f64,
    new_size: (u32, u32),
    lens: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let rig = rig(&k1, &d1, &k2, &d2, lens, size, &r, &t)?;
    let config = rectify_config(alpha, new_size);
    let rect = py.detach(|| parallax::rectify::stereo_rectify(&rig, &config)).map_err(err)?;
    rectification_dict(py, &rect)
}

/// A rig's rectification with its maps, for pairs of images.
#[pyclass(module = "parallax._parallax")]
struct Rectifier {
    inner: parallax::rectify::Rectifier,
}

#[pymethods]
impl Rectifier {
    #[new]
    #[pyo3(signature = (k1, d1, k2, d2, size, r, t, alpha=-1.0, new_size=(0, 0), lens="pinhole"))]
    #[allow(clippy::too_many_arguments)] // OpenCV's arguments
    fn new(
        py: Python<'_>,
        k1: Vec<f64>,
        d1: Vec<f64>,
        k2: Vec<f64>,
        d2: Vec<f64>,
        size: (u32, u32),
        r: Vec<f64>,
        t: Vec<f64>,
        alpha: f64,
        new_size: (u32, u32),
        lens: &str,
    ) -> PyResult<Self> {
        let rig = rig(&k1, &d1, &k2, &d2, lens, size, &r, &t)?;
        let config = rectify_config(alpha, new_size);
        let inner = py.detach(|| parallax::rectify::Rectifier::new(&rig, &config)).map_err(err)?;
        Ok(Self { inner })
    }

    /// `R1 R2 P1 P2 Q roi1 roi2 size`.
    fn matrices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        rectification_dict(py, self.inner.rectification())
    }

    /// Both images rectified (bilinear, black outside), grey or RGB as given.
    fn remap<'py>(
        &self,
        py: Python<'py>,
        left: &Bound<'py, PyAny>,
        right: &Bound<'py, PyAny>,
    ) -> PyResult<ArrayPair<'py, u8>> {
        use parallax::rectify::Border;
        let (l, r, channels) = match (image(left)?, image(right)?) {
            (Image::Grey(l), Image::Grey(r)) => {
                let (l, r) =
                    py.detach(|| self.inner.rectify_pair(&l, &r, Border::Constant(Luma([0u8])))).map_err(err)?;
                (l.into_raw(), r.into_raw(), 1)
            }
            (Image::Rgb(l), Image::Rgb(r)) => {
                let (l, r) = py
                    .detach(|| self.inner.rectify_pair(&l, &r, Border::Constant(parallax::image::Rgb([0u8; 3]))))
                    .map_err(err)?;
                (l.into_raw(), r.into_raw(), 3)
            }
            _ => return Err(err("remap takes two uint8 images of the same kind (both grey or both RGB)")),
        };
        let (w, h) = (self.inner.rectification().width as usize, self.inner.rectification().height as usize);
        let shape: Vec<usize> = if channels == 1 { vec![h, w] } else { vec![h, w, 3] };
        Ok((PyArray1::from_vec(py, l).reshape(shape.clone())?, PyArray1::from_vec(py, r).reshape(shape)?))
    }
}

/// Dense disparity: block matching or semi-global matching with `disparity`'s options.
#[pyclass(module = "parallax._parallax")]
struct StereoMatcher {
    matcher: BlockMatcher,
    colour: bool,
    /// The last map, its memory reused by the next frame of the same size.
    map: parallax::camera::DisparityMap,
    /// Seconds the last `compute` spent matching (inside Rust, without the conversions).
    last_seconds: f64,
    /// The last frame's image memory, reused.
    bufs: [Vec<u8>; 2],
    /// The memory of returned maps the caller dropped, reused.
    results: ResultPool,
}

#[pymethods]
impl StereoMatcher {
    #[new]
    #[pyo3(signature = (method="bm", num_disparities=64, min_disparity=0, block_size=None, cost="sad", prefilter=None, uniqueness=None, texture=None, lr_max_diff=None, speckle_window=None, min_confidence=None, fill=false, accurate=false, colour=false, sgm_cost=None, sgm_paths=None, lr_rule=None, threads=0, config=None))]
    #[allow(clippy::too_many_arguments)] // the command's options, one keyword each
    fn new(
        method: &str,
        num_disparities: usize,
        min_disparity: i32,
        block_size: Option<usize>,
        cost: &str,
        prefilter: Option<String>,
        uniqueness: Option<u32>,
        texture: Option<u32>,
        lr_max_diff: Option<i32>,
        speckle_window: Option<usize>,
        min_confidence: Option<f32>,
        fill: bool,
        accurate: bool,
        colour: bool,
        sgm_cost: Option<String>,
        sgm_paths: Option<u32>,
        lr_rule: Option<String>,
        threads: usize,
        config: Option<PathBuf>,
    ) -> PyResult<Self> {
        let (cfg, colour) = match config {
            // tune's file: its options, colour input in colour when it says so
            Some(path) => {
                let file = parallax::pipeline::tune::DisparityConfig::read(&path).map_err(err)?;
                let c = file.matcher_for(file.colour() && colour, (min_disparity, num_disparities), threads);
                (c, file.colour() && colour)
            }
            None => {
                let options = parallax::pipeline::disparity::MatcherOptions {
                    method: method.into(),
                    cost: cost.into(),
                    block: block_size,
                    disparities: num_disparities,
                    min_disparity,
                    prefilter,
                    uniqueness,
                    texture,
                    lr_max_diff,
                    speckle_window,
                    min_confidence,
                    confidence: true,
                    fill,
                    accurate,
                    colour,
                    sgm_cost,
                    sgm_paths,
                    lr_rule,
                    threads,
                };
                (options.config().map_err(err)?, colour)
            }
        };
        let cfg = parallax::matching::MatcherConfig { confidence_map: true, ..cfg };
        let map = parallax::camera::DisparityMap::new_invalid(0, 0);
        Ok(Self {
            matcher: BlockMatcher::new(cfg).map_err(err)?,
            colour,
            map,
            last_seconds: 0.0,
            bufs: Default::default(),
            results: ResultPool::default(),
        })
    }

    /// The disparity (float32, NaN where no disparity is returned) and the confidence (0 where
    /// invalid) of a rectified pair: uint8 grey, uint16 grey, or uint8 RGB (matched in colour
    /// when the matcher was made with `colour=True`, else by its grey conversion). With
    /// `disparity` and `confidence` (float32 `H x W` arrays, OpenCV's output arguments) the
    /// results are written into them and they are returned: no new memory per frame. Without
    /// them, new arrays are returned whose memory is that of earlier results you no longer hold
    /// (the matcher keeps up to four such buffers), when there are any.
    #[pyo3(signature = (left, right, disparity=None, confidence=None))]
    fn compute<'py>(
        &mut self,
        py: Python<'py>,
        left: &Bound<'py, PyAny>,
        right: &Bound<'py, PyAny>,
        disparity: Option<Bound<'py, PyArrayDyn<f32>>>,
        confidence: Option<Bound<'py, PyArrayDyn<f32>>>,
    ) -> PyResult<ArrayPair<'py, f32>> {
        let [mut lb, mut rb] = std::mem::take(&mut self.bufs);
        let (l, r) = (image_reusing(left, &mut lb)?, image_reusing(right, &mut rb)?);
        let colour = self.colour;
        let (matcher, map) = (&mut self.matcher, &mut self.map);
        let (l, r, result) = py.detach(|| {
            let started = std::time::Instant::now();
            let result = match (&l, &r) {
                (Image::Grey(a), Image::Grey(b)) => matcher.compute_into(a, b, map),
                (Image::Grey16(a), Image::Grey16(b)) => matcher.compute_u16_into(a, b, map),
                (Image::Rgb(a), Image::Rgb(b)) if colour => matcher.compute_rgb_into(a, b, map),
                (Image::Rgb(a), Image::Rgb(b)) => matcher.compute_into(
                    &parallax::image::imageops::grayscale(a),
                    &parallax::image::imageops::grayscale(b),
                    map,
                ),
                _ => Err(parallax::matching::BlockMatchingError::InvalidConfig {
                    field: "images",
                    value: "left and right of different kinds".into(),
                    reason: "give two images of the same dtype and channels",
                }),
            };
            (l, r, result.map(|()| started.elapsed().as_secs_f64()))
        });
        give_back(l, &mut lb);
        give_back(r, &mut rb);
        self.bufs = [lb, rb];
        self.last_seconds = result.map_err(err)?;
        let map = &self.map;
        let (w, h) = (map.width(), map.height());
        let zeros;
        let conf = match self.matcher.confidence() {
            Some(c) if c.len() == w * h => c,
            _ => {
                zeros = vec![0.0; w * h];
                &zeros
            }
        };
        let disparity = match disparity {
            Some(out) => {
                write_into(&out, map.data(), (h, w), "disparity")?;
                out
            }
            None => self.results.array(py, map.data(), (h, w))?,
        };
        let confidence = match confidence {
            Some(out) => {
                write_into(&out, conf, (h, w), "confidence")?;
                out
            }
            None => self.results.array(py, conf, (h, w))?,
        };
        Ok((disparity, confidence))
    }

    /// Seconds the last `compute` spent matching inside Rust (the rest of its time is the call:
    /// the conversions of the arrays and the GIL).
    #[getter]
    fn last_seconds(&self) -> f64 {
        self.last_seconds
    }

    /// The SIMD level the matcher runs.
    fn simd(&self) -> String {
        format!("{:?}", self.matcher.simd())
    }
}

/// A pair of image files loaded as `disparity` loads them: 16-bit grey when either has 16-bit
/// channels, 8-bit colour with `colour`, else 8-bit grey.
#[pyfunction]
#[pyo3(signature = (left, right, colour=false))]
fn load_pair<'py>(
    py: Python<'py>,
    left: PathBuf,
    right: PathBuf,
    colour: bool,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    use parallax::pipeline::disparity::StereoImages;
    let pair = py.detach(|| parallax::pipeline::disparity::load_pair(&left, &right, colour)).map_err(err)?;
    fn arr<'py, T: numpy::Element>(py: Python<'py>, data: Vec<T>, shape: Vec<usize>) -> PyResult<Bound<'py, PyAny>> {
        Ok(PyArray1::from_vec(py, data).reshape(shape)?.into_any())
    }
    let (w, h) = pair.dimensions();
    let (w, h) = (w as usize, h as usize);
    Ok(match pair {
        StereoImages::U8(l, r) => (arr(py, l.into_raw(), vec![h, w])?, arr(py, r.into_raw(), vec![h, w])?),
        StereoImages::U16(l, r) => (arr(py, l.into_raw(), vec![h, w])?, arr(py, r.into_raw(), vec![h, w])?),
        StereoImages::Rgb(l, r) => (arr(py, l.into_raw(), vec![h, w, 3])?, arr(py, r.into_raw(), vec![h, w, 3])?),
    })
}

/// Triangulates matched pixels of a rig's two cameras (optimal triangulation): one point per
/// pair, in the left camera's frame.
#[pyfunction]
#[pyo3(signature = (k1, d1, k2, d2, size, r, t, points1, points2, lens="pinhole"))]
#[allow(clippy::too_many_arguments)] // the rig as OpenCV gives it, then the points
fn triangulate(
    py: Python<'_>,
    k1: Vec<f64>,
    d1: Vec<f64>,
    k2: Vec<f64>,
    d2: Vec<f64>,
    size: (u32, u32),
    r: Vec<f64>,
    t: Vec<f64>,
    points1: Vec<[f64; 2]>,
    points2: Vec<[f64; 2]>,
    lens: &str,
) -> PyResult<Vec<[f64; 3]>> {
    if points1.len() != points2.len() {
        return Err(err(format!("{} left points and {} right points", points1.len(), points2.len())));
    }
    let rig = rig(&k1, &d1, &k2, &d2, lens, size, &r, &t)?;
    let pairs: Vec<(DVec2, DVec2)> =
        points1.iter().zip(&points2).map(|(a, b)| (DVec2::new(a[0], a[1]), DVec2::new(b[0], b[1]))).collect();
    let config = parallax::triangulation::TriangulationConfig::default();
    py.detach(|| {
        pairs
            .iter()
            .map(|&(a, b)| parallax::triangulation::triangulate_stereo(&rig, a, b, &config).map(|p| p.point.to_array()))
            .collect::<Result<Vec<_>, _>>()
    })
    .map_err(err)
}

/// Hand-eye calibration (`calibrateHandEye`): `base_from_gripper` and `camera_from_board`
/// poses as `(R row-major, t)`; returns `gripper_from_camera` (eye-in-hand) or `base_from_camera`
/// (eye-to-hand) as `(R, t)`.
#[pyfunction]
#[pyo3(signature = (base_from_gripper, camera_from_board, method="refined", setup="eye-in-hand"))]
#[allow(clippy::type_complexity)] // (R, t) pairs as OpenCV gives them
fn calibrate_hand_eye(
    py: Python<'_>,
    base_from_gripper: Vec<(Vec<f64>, Vec<f64>)>,
    camera_from_board: Vec<(Vec<f64>, Vec<f64>)>,
    method: &str,
    setup: &str,
) -> PyResult<(Vec<f64>, [f64; 3])> {
    use parallax::hand_eye::{HandEyeConfig, Method, Setup};
    let poses = |v: &[(Vec<f64>, Vec<f64>)], what: &str| -> PyResult<Vec<Isometry3>> {
        v.iter()
            .map(|(r, t)| Isometry3::from_rotation_translation(mat3(r, what)?, vec3(t, what)?).map_err(err))
            .collect()
    };
    let (g, c) = (poses(&base_from_gripper, "a robot pose")?, poses(&camera_from_board, "a camera pose")?);
    let method = match method {
        "tsai" => Method::Tsai,
        "park" => Method::Park,
        "horaud" => Method::Horaud,
        "andreff" => Method::Andreff,
        "daniilidis" => Method::Daniilidis,
        "rodrigues" => Method::Rodrigues,
        "refined" => Method::Refined,
        other => {
            return Err(err(format!(
                "method must be tsai, park, horaud, andreff, daniilidis, rodrigues or refined, got {other:?}"
            )));
        }
    };
    let setup = match setup {
        "eye-in-hand" => Setup::EyeInHand,
        "eye-to-hand" => Setup::EyeToHand,
        other => return Err(err(format!("setup must be eye-in-hand or eye-to-hand, got {other:?}"))),
    };
    let config = HandEyeConfig { setup, ..Default::default() };
    let s = py.detach(|| parallax::hand_eye::calibrate(&g, &c, method, &config)).map_err(err)?;
    Ok((rows(&s.transform.rotation_matrix()), s.transform.translation.to_array()))
}

/// Reads a calibration file of any format (OpenCV YAML/XML, ROS, Kalibr, JSON, RON): a dict
/// with `kind` (`mono`, `stereo`, `hand-eye`) and OpenCV's matrices.
#[pyfunction]
fn read_calibration<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    use parallax::interop::Calibration;
    let (c, _) = py.detach(|| parallax::interop::read(&[&path])).map_err(err)?;
    let out = PyDict::new(py);
    let put_camera = |out: &Bound<'py, PyDict>, suffix: &str, cam: &Camera| -> PyResult<()> {
        out.set_item(format!("K{suffix}"), rows(&cam.intrinsics.matrix()))?;
        out.set_item(format!("D{suffix}"), distortion(&cam.lens))?;
        out.set_item("lens", lens_name(&cam.lens))?;
        out.set_item("size", (cam.width, cam.height))
    };
    match c {
        Calibration::Mono(m) => {
            out.set_item("kind", "mono")?;
            put_camera(&out, "", &m.camera)?;
            out.set_item("rms", m.rms_px)?;
        }
        Calibration::Stereo(s) => {
            out.set_item("kind", "stereo")?;
            put_camera(&out, "1", &s.rig.left)?;
            put_camera(&out, "2", &s.rig.right)?;
            out.set_item("R", rows(&s.rig.right_from_left.rotation_matrix()))?;
            out.set_item("T", s.rig.right_from_left.translation.to_array())?;
            out.set_item("rms", s.rms_px)?;
        }
        Calibration::HandEye(h) => {
            out.set_item("kind", "hand-eye")?;
            out.set_item("setup", parallax::interop::setup_name(h.setup))?;
            out.set_item("R", rows(&h.transform.rotation_matrix()))?;
            out.set_item("t", h.transform.translation.to_array())?;
        }
    }
    Ok(out)
}

/// Writes a stereo or mono calibration (the dict `read_calibration` returns) in a format by
/// name or by the path's extension (`opencv-yaml`, `opencv-xml`, `ros`, `kalibr`, `json`,
/// `ron`); nothing is written when a check fails.
#[pyfunction]
#[pyo3(signature = (path, calibration, format=None))]
fn write_calibration(
    py: Python<'_>,
    path: PathBuf,
    calibration: &Bound<'_, PyDict>,
    format: Option<String>,
) -> PyResult<Vec<PathBuf>> {
    use parallax::interop::{Calibration, MonoCalibration, StereoCalibration};
    let get = |k: &str| -> PyResult<Bound<'_, PyAny>> {
        calibration.get_item(k)?.ok_or_else(|| err(format!("the calibration has no {k:?}")))
    };
    let kind: String = get("kind")?.extract()?;
    let lens: String = get("lens")?.extract()?;
    let size: (u32, u32) = get("size")?.extract()?;
    let lens = if lens == "brown-conrady" { "pinhole".to_string() } else { lens };
    let cal = match kind.as_str() {
        "mono" => Calibration::Mono(MonoCalibration {
            camera: camera(&get("K")?.extract::<Vec<f64>>()?, &get("D")?.extract::<Vec<f64>>()?, &lens, size)?,
            rms_px: get("rms").ok().and_then(|v| v.extract().ok()),
            per_view_rms_px: Vec::new(),
        }),
        "stereo" => Calibration::Stereo(StereoCalibration {
            rig: rig(
                &get("K1")?.extract::<Vec<f64>>()?,
                &get("D1")?.extract::<Vec<f64>>()?,
                &get("K2")?.extract::<Vec<f64>>()?,
                &get("D2")?.extract::<Vec<f64>>()?,
                &lens,
                size,
                &get("R")?.extract::<Vec<f64>>()?,
                &get("T")?.extract::<Vec<f64>>()?,
            )?,
            rectification: None,
            rms_px: get("rms").ok().and_then(|v| v.extract().ok()),
            per_view_rms_px: Vec::new(),
        }),
        other => return Err(err(format!("kind must be mono or stereo, got {other:?}"))),
    };
    let format = parallax::interop::Format::for_output(&path, format.as_deref()).map_err(err)?;
    py.detach(|| -> parallax::Result<Vec<PathBuf>> {
        let mut set = parallax::pipeline::io::OutputSet::new();
        for (p, text) in parallax::interop::render(&cal, format, &path)? {
            set.add(p, text)?;
        }
        set.commit()
    })
    .map_err(err)
}

/// Scores a matcher configuration file on one world (RON): bad-2 (missing = bad), bad-2 where
/// OpenCV also answers, density, milliseconds — as `tune` scores it.
#[pyfunction]
#[pyo3(signature = (world, config, threads=1, runs=1))]
fn score_world<'py>(
    py: Python<'py>,
    world: PathBuf,
    config: PathBuf,
    threads: usize,
    runs: usize,
) -> PyResult<Bound<'py, PyDict>> {
    use parallax::pipeline::tune;
    let s = py
        .detach(|| -> parallax::Result<tune::Score> {
            let scenes = tune::scenes_from_worlds(std::slice::from_ref(&world))?;
            let c = tune::DisparityConfig::read(&config)?;
            tune::score(&c, &scenes, threads, runs)
        })
        .map_err(err)?;
    let out = PyDict::new(py);
    out.set_item("bad2", s.bad2)?;
    out.set_item("bad2_overlap", s.bad2_overlap)?;
    out.set_item("density", s.density)?;
    out.set_item("ms", s.ms)?;
    Ok(out)
}

#[pymodule]
fn _parallax(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", version())?;
    m.add("ParallaxError", m.py().get_type::<ParallaxError>())?;
    m.add_class::<StereoMatcher>()?;
    m.add_class::<Rectifier>()?;
    for f in [
        wrap_pyfunction!(version, m)?,
        wrap_pyfunction!(find_chessboard, m)?,
        wrap_pyfunction!(detect_target, m)?,
        wrap_pyfunction!(calibrate_camera, m)?,
        wrap_pyfunction!(stereo_calibrate, m)?,
        wrap_pyfunction!(calibrate_rig, m)?,
        wrap_pyfunction!(stereo_rectify, m)?,
        wrap_pyfunction!(load_pair, m)?,
        wrap_pyfunction!(triangulate, m)?,
        wrap_pyfunction!(calibrate_hand_eye, m)?,
        wrap_pyfunction!(read_calibration, m)?,
        wrap_pyfunction!(write_calibration, m)?,
        wrap_pyfunction!(score_world, m)?,
    ] {
        m.add_function(f)?;
    }
    Ok(())
}
