//! Bouguet's calibrated rectification, as OpenCV's `stereoRectify`.

use glam::{DMat3, DVec2, DVec3, DVec4};
use parallax_camera_model::{Camera, Isometry3, ProjectionMatrix, StereoRig};
use serde::{Deserialize, Serialize};

use crate::opencv_compat;
use crate::{RectifyError, Result};

/// How the image extents that fix the rectified principal points, the scale (`alpha`) and the
/// valid-pixel rectangles are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ExtentMethod {
    /// OpenCV's own procedure, reproduced step by step so `P1`, `P2`, `Q` and the rectangles
    /// agree with `cv::stereoRectify` (OpenCV 4.x / 5.0) to ~1e-9: the four image corners are
    /// undistorted by OpenCV's 5 fixed-point iterations and rounded to `f32` where OpenCV
    /// rounds; the rectangles come from 32 samples of the image border (a 9x9 grid's edge,
    /// corners included), undistorted the same way. The 5 iterations leave up to ~1e-3 px of undistortion error
    /// on strongly distorted lenses, and the sparse border samples can leave a fraction of a
    /// pixel of invalid border inside the `alpha = 0` rectangle.
    #[default]
    OpenCv,
    /// Converged undistortion (Newton, `parallax_camera_model::UNDISTORT_TOLERANCE`) of the corners and
    /// of every pixel of the image border (pixel centres `0..=w-1`, `0..=h-1`, corners
    /// included). Slower (~2·(w+h) undistortions, well under a millisecond) and not
    /// bit-compatible with OpenCV, but `alpha = 0` then leaves no invalid pixel inside the
    /// returned rectangles and `alpha = 1` keeps every source pixel.
    Exact,
}

/// Options of [`stereo_rectify`]: OpenCV's `flags`, `alpha`, `newImageSize` (`stereoRectify`,
/// Brown–Conrady rigs) and `balance`, `fov_scale` (`fisheye::stereoRectify`, rigs with a wide
/// lens). An option of the other lens family than the rig's is refused, not ignored.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RectifyConfig {
    /// Free scaling in `[0, 1]`: 0 zooms so only valid pixels are visible (no black border),
    /// 1 shrinks so every source pixel is kept; values between interpolate the focal length.
    /// `None` is OpenCV's default (`alpha = -1`): no scaling, the rectified focal length is the
    /// mean of the two vertical (horizontal rig) focal lengths.
    pub alpha: Option<f64>,
    /// Size `(width, height)` of the rectified images in pixels; `None` keeps the input size.
    pub new_size: Option<(u32, u32)>,
    /// OpenCV's `CALIB_ZERO_DISPARITY` (its default): both principal points are made equal, so
    /// points at infinity have zero disparity. Without it only the coordinate across the
    /// baseline is shared (`cy` for horizontal rigs, `cx` for vertical ones).
    pub zero_disparity: bool,
    /// How image extents are measured (OpenCV-compatible by default; Brown–Conrady rigs).
    pub extents: ExtentMethod,
    /// Wide lenses: in `[0, 1]`, 0 keeps only valid pixels (the focal length of the tightest
    /// fit of the undistorted edge midpoints), 1 keeps the whole undistorted extent (OpenCV
    /// fisheye's `balance`; default 0).
    pub balance: f64,
    /// Wide lenses: divides the focal length, above 1 widens the field of view (OpenCV
    /// fisheye's `fov_scale`; default 1, must be > 0).
    pub fov_scale: f64,
}

impl Default for RectifyConfig {
    fn default() -> Self {
        Self {
            alpha: None,
            new_size: None,
            zero_disparity: true,
            extents: ExtentMethod::OpenCv,
            balance: 0.0,
            fov_scale: 1.0,
        }
    }
}

/// An integer pixel rectangle (OpenCV's `cv::Rect`), already clipped to the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Roi {
    /// First column.
    pub x: u32,
    /// First row.
    pub y: u32,
    /// Number of columns.
    pub width: u32,
    /// Number of rows.
    pub height: u32,
}

impl Roi {
    /// True when the integer pixel `(u, v)` lies inside.
    pub fn contains(&self, u: u32, v: u32) -> bool {
        u >= self.x && v >= self.y && u < self.x + self.width && v < self.y + self.height
    }

    /// True when the rectangle has no pixel.
    pub fn is_empty(&self) -> bool {
        self.width == 0 || self.height == 0
    }

    /// Number of pixels.
    pub fn area(&self) -> u64 {
        self.width as u64 * self.height as u64
    }
}

/// The result of [`stereo_rectify`]: OpenCV's `R1, R2, P1, P2, Q, roi1, roi2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rectification {
    /// Rotation from the left camera frame to the rectified left frame (`rectified_from_left`).
    pub r1: DMat3,
    /// Rotation from the right camera frame to the rectified right frame.
    pub r2: DMat3,
    /// Left rectified projection `[K' | 0]` (points in the rectified left frame).
    pub p1: ProjectionMatrix,
    /// Right rectified projection `[K'_r | K'_r (Tx, 0, 0)]` (`Ty` in row 1 for vertical rigs).
    pub p2: ProjectionMatrix,
    /// Disparity-to-depth matrix, rows: `Q (u, v, d, 1)ᵀ = (X, Y, Z, W)`; the point in the
    /// rectified left frame is `(X, Y, Z) / W` (disparity `d = u_l − u_r`, or `v_l − v_r` for
    /// vertical rigs).
    pub q: [[f64; 4]; 4],
    /// Valid-pixel rectangle of the rectified left image.
    pub roi1: Roi,
    /// Valid-pixel rectangle of the rectified right image.
    pub roi2: Roi,
    /// Width of the rectified images in pixels.
    pub width: u32,
    /// Height of the rectified images in pixels.
    pub height: u32,
    /// True for a vertical rig (baseline mostly along `y`: epipolar lines are columns).
    pub vertical: bool,
    /// The `alpha` scale factor applied to the focal length (1 without `alpha`).
    pub scale: f64,
}

impl Rectification {
    /// The common rectified focal length in pixels.
    pub fn focal(&self) -> f64 {
        self.p1.rows[0][0]
    }

    /// The rectified camera matrix of the left view (`P1`'s left block).
    pub fn left_camera_matrix(&self) -> DMat3 {
        self.p1.left_block()
    }

    /// The rectified camera matrix of the right view (`P2`'s left block).
    pub fn right_camera_matrix(&self) -> DMat3 {
        self.p2.left_block()
    }

    /// Baseline expressed in the rectified frame (`Tx` or `Ty`, signed, rig length unit):
    /// `P2[idx][3] / f`.
    pub fn rectified_baseline(&self) -> f64 {
        let idx = usize::from(self.vertical);
        self.p2.rows[idx][3] / self.focal()
    }

    /// The 3D point (rectified left frame) of a left pixel with disparity `d` through `Q`;
    /// `None` when `W = 0` (a point at infinity) or the result is not finite.
    pub fn reproject(&self, pixel: DVec2, disparity: f64) -> Option<DVec3> {
        let x = DVec4::new(pixel.x, pixel.y, disparity, 1.0);
        let row = |i: usize| DVec4::from_array(self.q[i]).dot(x);
        let w = row(3);
        let p = DVec3::new(row(0), row(1), row(2)) / w;
        (w != 0.0 && p.is_finite()).then_some(p)
    }
}

impl Rectification {
    /// A rectification of `rig` given by its matrices, as a file stores them (OpenCV's
    /// `stereo_calib.cpp` writes `R1 R2 P1 P2 Q` of `stereoRectify` into `extrinsics.yml`; ROS
    /// `camera_info` holds `R` and `P`): the rectified images are `width` x `height`. Checked
    /// against the rig before anything uses them, so that a file's matrices of another rig, or
    /// of another calibration of this one, are refused instead of rectifying to wrong images:
    /// `R1`, `R2` rotations; `P1 = [K' | 0]`, `P2 = [K' | K' b]` with one focal length, the
    /// baseline `b` along `x` (or `y`: a vertical rig) and equal to the rig's baseline turned by
    /// `R2`; the two rectified frames parallel (`R2 R R1ᵀ = I`); `Q` the one of `P1`, `P2`
    /// (`stereoRectify`'s formula); the left principal point inside the image. Tolerances are
    /// 1e-6 (relative to the baseline for lengths), far above the 17 digits files carry.
    ///
    /// The valid-pixel rectangles are measured (64 samples per image edge), the scale is the
    /// focal length over the mean focal length across the baseline (`alpha`'s effect; 1 for a
    /// rig with a wide lens).
    pub fn from_matrices(
        rig: &StereoRig,
        r1: DMat3,
        r2: DMat3,
        p1: ProjectionMatrix,
        p2: ProjectionMatrix,
        q: [[f64; 4]; 4],
        (width, height): (u32, u32),
    ) -> Result<Self> {
        const TOL: f64 = 1e-6;
        let bad = |m: String| RectifyError::Degenerate(format!("stored rectification: {m}"));
        let finite = r1.is_finite()
            && r2.is_finite()
            && p1.rows.iter().chain(&p2.rows).flatten().all(|v| v.is_finite())
            && q.iter().flatten().all(|v| v.is_finite());
        if !finite {
            return Err(RectifyError::NonFinite("stored rectification (R1 R2 P1 P2 Q)"));
        }
        if width == 0 || height == 0 {
            return Err(RectifyError::Config(format!("rectified size must be non-zero, got {width}x{height}")));
        }
        for (name, r) in [("R1", r1), ("R2", r2)] {
            let off = max_abs(r.transpose() * r - DMat3::IDENTITY);
            if off > TOL || r.determinant() <= 0.0 {
                return Err(bad(format!(
                    "{name} is not a rotation (|RᵀR − I| = {off:.2e}, det {:.6})",
                    r.determinant()
                )));
            }
        }
        let f = p1.rows[0][0];
        let (c1, c2) = (DVec2::new(p1.rows[0][2], p1.rows[1][2]), DVec2::new(p2.rows[0][2], p2.rows[1][2]));
        let shape = |c: DVec2, last: [f64; 2]| [[f, 0.0, c.x, last[0]], [0.0, f, c.y, last[1]], [0.0, 0.0, 1.0, 0.0]];
        let (tx, ty) = (p2.rows[0][3], p2.rows[1][3]);
        let vertical = tx.abs() < ty.abs();
        let idx = usize::from(vertical);
        let b = if vertical { ty } else { tx };
        let rel = |a: [[f64; 4]; 3], e: [[f64; 4]; 3]| {
            a.iter()
                .flatten()
                .zip(e.iter().flatten())
                .map(|(a, e)| (a - e).abs() / e.abs().max(1.0))
                .fold(0.0, f64::max)
        };
        let p1_dev = rel(p1.rows, shape(c1, [0.0, 0.0]));
        let p2_dev = rel(p2.rows, shape(c2, if vertical { [0.0, ty] } else { [tx, 0.0] }));
        if f <= 0.0 || p1_dev > TOL || p2_dev > TOL || b == 0.0 {
            return Err(bad(format!(
                "P1, P2 are not a rectified pair ([f 0 cx 0; 0 f cy 0; 0 0 1 0] and [f 0 cx' Tx·f; 0 f cy' Ty·f; 0 0 \
                 1 0] with one f and one of Tx, Ty): deviations {p1_dev:.2e}, {p2_dev:.2e}"
            )));
        }
        let rig_r = rig.right_from_left.rotation_matrix();
        let parallel = max_abs(r2 * rig_r * r1.transpose() - DMat3::IDENTITY);
        if parallel > TOL {
            return Err(bad(format!(
                "R2 R R1ᵀ is not the identity ({parallel:.2e}): R1, R2 rectify another rig than this R"
            )));
        }
        let t = r2 * rig.right_from_left.translation;
        let scale_t = t.length();
        let mut expected_t = DVec3::ZERO;
        expected_t[idx] = b / f;
        let t_dev = (t - expected_t).length() / scale_t;
        if t_dev > TOL {
            return Err(bad(format!(
                "P2's baseline {:.6} ({}) is not this rig's, R2·T = ({:.6}, {:.6}, {:.6}) (relative difference {t_dev:.2e})",
                b / f,
                if vertical { "Ty" } else { "Tx" },
                t.x,
                t.y,
                t.z
            )));
        }
        let tb = b / f;
        let dc = if vertical { c1.y - c2.y } else { c1.x - c2.x };
        let q_expected =
            [[1.0, 0.0, 0.0, -c1.x], [0.0, 1.0, 0.0, -c1.y], [0.0, 0.0, 0.0, f], [0.0, 0.0, -1.0 / tb, dc / tb]];
        let q_dev = q
            .iter()
            .flatten()
            .zip(q_expected.iter().flatten())
            .map(|(a, e)| (a - e).abs() / if *e == 0.0 { 1.0 } else { e.abs() })
            .fold(0.0, f64::max);
        if q_dev > TOL {
            return Err(bad(format!("Q is not the one of P1 and P2 (largest relative difference {q_dev:.2e})")));
        }
        if !((0.0..width as f64).contains(&c1.x) && (0.0..height as f64).contains(&c1.y)) {
            return Err(bad(format!(
                "the rectified principal point ({:.1}, {:.1}) lies outside the {width}x{height} image",
                c1.x, c1.y
            )));
        }
        let k1 = p1.left_block();
        let k2 = p2.left_block();
        let scale = if rig.has_wide_lens() {
            1.0
        } else {
            let across = |c: &Camera| if vertical { c.intrinsics.fx } else { c.intrinsics.fy };
            f / (0.5 * (across(&rig.left) + across(&rig.right)))
        };
        Ok(Self {
            r1,
            r2,
            p1,
            p2,
            q,
            roi1: crate::wide::valid_rect(&rig.left, r1, k1, width, height),
            roi2: crate::wide::valid_rect(&rig.right, r2, k2, width, height),
            width,
            height,
            vertical,
            scale,
        })
    }
}

/// The largest absolute element of `m`.
fn max_abs(m: DMat3) -> f64 {
    m.to_cols_array().iter().fold(0.0, |a, v| a.max(v.abs()))
}

/// A rectangle with real coordinates (OpenCV's `Rect_<double>`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RectF {
    pub x: f64,
    pub y: f64,
    pub width: f64,
    pub height: f64,
}

/// Bouguet rectification of a calibrated rig, following `cv::stereoRectify` formula by formula:
///
/// 1. each camera turns by half of the relative rotation (`R1 = R^½`, `R2 = R^-½` as Rodrigues
///    vectors `±rvec/2`) so both look the same way;
/// 2. a common rotation aligns the baseline with the `x` axis (or `y` when `|t_y| ≥ |t_x|`
///    after step 1: a vertical rig);
/// 3. the common focal length is the mean of the two focal lengths across the baseline
///    (`fy` for a horizontal rig), scaled by the new image size;
/// 4. each principal point centres the undistorted image corners; with `zero_disparity` both
///    are averaged, otherwise only the coordinate across the baseline;
/// 5. `alpha` interpolates the focal length between the inscribed (`alpha = 0`) and the
///    circumscribed (`alpha = 1`) rectangles of both undistorted, rotated images.
///
/// A rig with a wide lens (Kannala–Brandt or double sphere, either camera) is rectified to a
/// pinhole pair by OpenCV's `fisheye::stereoRectify` rule instead (`balance`, `fov_scale`).
///
/// Errors on an invalid rig, a zero baseline, cameras of different image sizes, `alpha`
/// outside `[0, 1]`, a zero new size, or an option of the other lens family.
pub fn stereo_rectify(rig: &StereoRig, config: &RectifyConfig) -> Result<Rectification> {
    if rig.has_wide_lens() {
        if let Some(a) = config.alpha {
            return Err(RectifyError::Config(format!(
                "alpha {a} applies to Brown–Conrady rigs; this rig has a {} lens: use balance (0 = only valid \
                 pixels, 1 = the whole image) and fov_scale",
                wide_model(rig)
            )));
        }
        if config.extents != ExtentMethod::OpenCv {
            return Err(RectifyError::Config(
                "the extent method applies to Brown–Conrady rigs; a wide-lens rig's extents are converged".into(),
            ));
        }
        return crate::wide::fisheye_stereo_rectify(rig, config);
    }
    if config.balance != 0.0 || config.fov_scale != 1.0 {
        return Err(RectifyError::Config(format!(
            "balance {} and fov_scale {} apply to rigs with a wide lens (Kannala–Brandt, double sphere); this \
             Brown–Conrady rig takes alpha",
            config.balance, config.fov_scale
        )));
    }
    rig.left.validate().map_err(|source| RectifyError::Camera { what: "left camera", source })?;
    rig.right.validate().map_err(|source| RectifyError::Camera { what: "right camera", source })?;
    if !rig.right_from_left.is_finite() {
        return Err(RectifyError::NonFinite("right_from_left"));
    }
    if (rig.left.width, rig.left.height) != (rig.right.width, rig.right.height) {
        return Err(RectifyError::SizeMismatch(format!(
            "left camera is {}x{}, right camera {}x{}; Bouguet rectification needs one image size",
            rig.left.width, rig.left.height, rig.right.width, rig.right.height
        )));
    }
    if let Some(a) = config.alpha
        && !(0.0..=1.0).contains(&a)
    {
        return Err(RectifyError::Config(format!("alpha must be in [0, 1] (or None), got {a}")));
    }
    let (width, height) = (rig.left.width, rig.left.height);
    let (new_w, new_h) = config.new_size.unwrap_or((width, height));
    if new_w == 0 || new_h == 0 {
        return Err(RectifyError::Config(format!("new_size must be non-zero, got {new_w}x{new_h}")));
    }
    let translation = rig.right_from_left.translation;
    let nt0 = translation.length();
    if !(nt0.is_finite() && nt0 > 0.0) {
        return Err(RectifyError::ZeroBaseline(nt0));
    }

    // 1. half rotations.
    let om = rig.right_from_left.rvec() * -0.5;
    let r_r = rotation_from_rvec(om);
    let t = r_r * translation;

    // 2. align the baseline with x (or y).
    let idx = usize::from(t.x.abs() <= t.y.abs());
    let c = t[idx];
    let nt = t.length();
    let mut uu = DVec3::ZERO;
    uu[idx] = if c > 0.0 { 1.0 } else { -1.0 };
    let mut ww = t.cross(uu);
    let nw = ww.length();
    if nw > 0.0 {
        ww *= (c.abs() / nt).min(1.0).acos() / nw;
    }
    let w_r = rotation_from_rvec(ww);
    let r1 = w_r * r_r.transpose();
    let r2 = w_r * r_r;
    let t = r2 * translation;

    // 3. common focal length.
    let ratio_x = new_w as f64 / width as f64 / 2.0;
    let ratio_y = new_h as f64 / height as f64 / 2.0;
    let ratio = if idx == 1 { ratio_x } else { ratio_y };
    let focal_across = |camera: &Camera| if idx == 0 { camera.intrinsics.fy } else { camera.intrinsics.fx };
    let mut fc_new = (focal_across(&rig.left) + focal_across(&rig.right)) * ratio;

    // 4. principal points from the undistorted corners.
    let (nx, ny) = (width as f64, height as f64);
    let mut cc = [DVec2::ZERO; 2];
    for (k, (camera, r)) in [(&rig.left, r1), (&rig.right, r2)].into_iter().enumerate() {
        let avg = match config.extents {
            ExtentMethod::OpenCv => opencv_compat::mean_rotated_corners(camera, r, fc_new),
            ExtentMethod::Exact => {
                exact_mean_rotated_corners(camera, r, fc_new, if k == 0 { "left" } else { "right" })?
            }
        };
        cc[k] = DVec2::new((nx - 1.0) / 2.0 - avg.x, (ny - 1.0) / 2.0 - avg.y);
    }
    if config.zero_disparity {
        let m = (cc[0] + cc[1]) * 0.5;
        cc = [m, m];
    } else if idx == 0 {
        let m = (cc[0].y + cc[1].y) * 0.5;
        cc[0].y = m;
        cc[1].y = m;
    } else {
        let m = (cc[0].x + cc[1].x) * 0.5;
        cc[0].x = m;
        cc[1].x = m;
    }
    let t_idx = t[idx];

    // 5. alpha scaling from the inscribed / circumscribed rectangles.
    let k_new = |c: DVec2| DMat3::from_cols(DVec3::new(fc_new, 0.0, 0.0), DVec3::new(0.0, fc_new, 0.0), c.extend(1.0));
    let (inner1, outer1) = rectangles(&rig.left, r1, k_new(cc[0]), config.extents, "left")?;
    let (inner2, outer2) = rectangles(&rig.right, r2, k_new(cc[1]), config.extents, "right")?;
    let (nw_f, nh_f) = (new_w as f64, new_h as f64);
    let c0 = cc;
    let c1 =
        [DVec2::new(nw_f * c0[0].x / nx, nh_f * c0[0].y / ny), DVec2::new(nw_f * c0[1].x / nx, nh_f * c0[1].y / ny)];
    let mut s = 1.0;
    if let Some(alpha) = config.alpha {
        let fits = |inner: &RectF, c_0: DVec2, c_1: DVec2| {
            [
                c_1.x / (c_0.x - inner.x),
                c_1.y / (c_0.y - inner.y),
                (nw_f - 1.0 - c_1.x) / (inner.x + inner.width - c_0.x),
                (nh_f - 1.0 - c_1.y) / (inner.y + inner.height - c_0.y),
            ]
        };
        let s0 = fits(&inner1, c0[0], c1[0]).into_iter().chain(fits(&inner2, c0[1], c1[1])).fold(f64::MIN, f64::max);
        let s1 = fits(&outer1, c0[0], c1[0]).into_iter().chain(fits(&outer2, c0[1], c1[1])).fold(f64::MAX, f64::min);
        s = s0 * (1.0 - alpha) + s1 * alpha;
        if !(s.is_finite() && s > 0.0) {
            return Err(RectifyError::Degenerate(format!(
                "alpha scale {s:.3e} (inscribed {s0:.3e}, circumscribed {s1:.3e}): the undistorted image extents are \
                 unusable"
            )));
        }
    }
    fc_new *= s;
    let mut p1 = [[0.0; 4]; 3];
    p1[0][0] = fc_new;
    p1[1][1] = fc_new;
    p1[0][2] = c1[0].x;
    p1[1][2] = c1[0].y;
    p1[2][2] = 1.0;
    let mut p2 = p1;
    p2[0][2] = c1[1].x;
    p2[1][2] = c1[1].y;
    p2[idx][3] = t_idx * fc_new;
    let roi = |inner: &RectF, c_0: DVec2, c_1: DVec2| {
        clip_rect(
            ((inner.x - c_0.x) * s + c_1.x).ceil(),
            ((inner.y - c_0.y) * s + c_1.y).ceil(),
            (inner.width * s).floor(),
            (inner.height * s).floor(),
            new_w,
            new_h,
        )
    };
    let roi1 = roi(&inner1, c0[0], c1[0]);
    let roi2 = roi(&inner2, c0[1], c1[1]);
    let dc = if idx == 0 { c1[0].x - c1[1].x } else { c1[0].y - c1[1].y };
    let q = [
        [1.0, 0.0, 0.0, -c1[0].x],
        [0.0, 1.0, 0.0, -c1[0].y],
        [0.0, 0.0, 0.0, fc_new],
        [0.0, 0.0, -1.0 / t_idx, dc / t_idx],
    ];
    let out = Rectification {
        r1,
        r2,
        p1: ProjectionMatrix { rows: p1 },
        p2: ProjectionMatrix { rows: p2 },
        q,
        roi1,
        roi2,
        width: new_w,
        height: new_h,
        vertical: idx == 1,
        scale: s,
    };
    let finite = out.r1.is_finite()
        && out.r2.is_finite()
        && p2.iter().flatten().all(|v| v.is_finite())
        && q.iter().flatten().all(|v| v.is_finite());
    if !finite {
        return Err(RectifyError::Degenerate("rectification produced non-finite matrices".into()));
    }
    Ok(out)
}

/// Rotation matrix of a Rodrigues vector.
pub(crate) fn rotation_from_rvec(rvec: DVec3) -> DMat3 {
    Isometry3::from_rvec_tvec(rvec, DVec3::ZERO).rotation_matrix()
}

/// OpenCV's `Rect & Rect(0, 0, w, h)` on a rectangle with integer-valued coordinates.
fn clip_rect(x: f64, y: f64, w: f64, h: f64, width: u32, height: u32) -> Roi {
    let x0 = x.max(0.0);
    let y0 = y.max(0.0);
    let x1 = (x + w).min(width as f64);
    let y1 = (y + h).min(height as f64);
    if !(x1 > x0 && y1 > y0) {
        return Roi::default();
    }
    Roi { x: x0 as u32, y: y0 as u32, width: (x1 - x0) as u32, height: (y1 - y0) as u32 }
}

fn exact_mean_rotated_corners(camera: &Camera, r: DMat3, fc: f64, which: &'static str) -> Result<DVec2> {
    let (nx, ny) = (camera.width as f64, camera.height as f64);
    let mut sum = DVec2::ZERO;
    for corner in
        [DVec2::new(0.0, 0.0), DVec2::new(nx - 1.0, 0.0), DVec2::new(0.0, ny - 1.0), DVec2::new(nx - 1.0, ny - 1.0)]
    {
        let ray =
            camera.unproject(corner).map_err(|source| RectifyError::Camera { what: camera_what(which), source })?;
        let p = r * ray;
        if p.z <= 0.0 {
            return Err(RectifyError::Degenerate(format!(
                "a corner of the {which} image turns behind the rectified camera"
            )));
        }
        sum += DVec2::new(fc * p.x / p.z, fc * p.y / p.z);
    }
    Ok(sum / 4.0)
}

fn camera_what(which: &'static str) -> &'static str {
    if which == "left" { "left camera (corner undistortion)" } else { "right camera (corner undistortion)" }
}

/// Inscribed and circumscribed rectangles of the undistorted, rotated image border in the
/// rectified image of camera matrix `k_new` (OpenCV's `getUndistortRectangles`).
pub(crate) fn rectangles(
    camera: &Camera,
    r: DMat3,
    k_new: DMat3,
    method: ExtentMethod,
    which: &'static str,
) -> Result<(RectF, RectF)> {
    let rr = k_new * r;
    let (w, h) = (camera.width, camera.height);
    // (edge, pixel): edge 0 = left (x = 0), 1 = right, 2 = top, 3 = bottom; corners belong to two edges.
    let mut samples: Vec<([bool; 4], DVec2)> = Vec::new();
    match method {
        ExtentMethod::OpenCv => {
            const N: u32 = 9;
            let step_x = (w as f64 - 1.0) / (N - 1) as f64;
            let step_y = (h as f64 - 1.0) / (N - 1) as f64;
            for y in 0..N {
                for x in 0..N {
                    if x == 0 || x == N - 1 || y == 0 || y == N - 1 {
                        let p =
                            opencv_compat::undistort_point(camera, DVec2::new(x as f64 * step_x, y as f64 * step_y));
                        samples.push(([x == 0, x == N - 1, y == 0, y == N - 1], apply_homography(rr, p)));
                    }
                }
            }
        }
        ExtentMethod::Exact => {
            let (wf, hf) = ((w - 1) as f64, (h - 1) as f64);
            let mut push = |pixel: DVec2| -> Result<()> {
                let ray = camera
                    .unproject(pixel)
                    .map_err(|source| RectifyError::Camera { what: camera_what(which), source })?;
                let edges = [pixel.x == 0.0, pixel.x == wf, pixel.y == 0.0, pixel.y == hf];
                samples.push((edges, apply_homography(rr, ray.truncate())));
                Ok(())
            };
            for u in 0..w {
                push(DVec2::new(u as f64, 0.0))?;
                push(DVec2::new(u as f64, hf))?;
            }
            for v in 1..h.saturating_sub(1) {
                push(DVec2::new(0.0, v as f64))?;
                push(DVec2::new(wf, v as f64))?;
            }
        }
    }
    let (mut ix0, mut ix1, mut iy0, mut iy1) = (f64::MIN, f64::MAX, f64::MIN, f64::MAX);
    let (mut ox0, mut ox1, mut oy0, mut oy1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (edges, p) in &samples {
        if !p.is_finite() {
            return Err(RectifyError::Degenerate(format!(
                "the border of the {which} image maps to a non-finite rectified point"
            )));
        }
        ox0 = ox0.min(p.x);
        ox1 = ox1.max(p.x);
        oy0 = oy0.min(p.y);
        oy1 = oy1.max(p.y);
        if edges[0] {
            ix0 = ix0.max(p.x);
        }
        if edges[1] {
            ix1 = ix1.min(p.x);
        }
        if edges[2] {
            iy0 = iy0.max(p.y);
        }
        if edges[3] {
            iy1 = iy1.min(p.y);
        }
    }
    Ok((
        RectF { x: ix0, y: iy0, width: ix1 - ix0, height: iy1 - iy0 },
        RectF { x: ox0, y: oy0, width: ox1 - ox0, height: oy1 - oy0 },
    ))
}

/// `H (x, y, 1)` dehomogenised, as OpenCV (`1/w` then multiply).
#[inline]
pub(crate) fn apply_homography(h: DMat3, p: DVec2) -> DVec2 {
    let q = h * p.extend(1.0);
    let iw = 1.0 / q.z;
    DVec2::new(q.x * iw, q.y * iw)
}

/// The wide lens model of a rig (for messages).
fn wide_model(rig: &StereoRig) -> parallax_camera_model::LensModel {
    [rig.left.lens_model(), rig.right.lens_model()].into_iter().find(|m| m.is_wide()).unwrap_or_default()
}
