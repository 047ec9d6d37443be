//! Rectification of rigs with wide-angle lenses (a [`parallax_camera_model::Camera`] with a
//! Kannala–Brandt or double sphere lens, or any [`CameraModel`]): to a pinhole with a chosen
//! balance / field of view, as OpenCV's
//! `fisheye::estimateNewCameraMatrixForUndistortRectify` and `fisheye::stereoRectify`, and to
//! wide projections that hold more than a pinhole can ([`WideView`]: equirectangular and
//! cylindrical, with the poles on the baseline so epipolar lines stay rows).

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{CameraModel, Isometry3, ProjectionMatrix, StereoRig};
use serde::{Deserialize, Serialize};

use crate::{Rectification, RectifyConfig, RectifyError, RemapTable, Result, Roi};

/// Checks the wide-lens options of `config` (`balance`, `fov_scale`, `new_size`).
fn check(config: &RectifyConfig) -> Result<()> {
    if !(config.balance.is_finite() && (0.0..=1.0).contains(&config.balance)) {
        return Err(RectifyError::Config(format!("balance must be in [0, 1], got {}", config.balance)));
    }
    if !(config.fov_scale.is_finite() && config.fov_scale > 0.0) {
        return Err(RectifyError::Config(format!("fov_scale must be positive, got {}", config.fov_scale)));
    }
    if let Some((w, h)) = config.new_size
        && (w == 0 || h == 0)
    {
        return Err(RectifyError::Config(format!("new_size must be non-zero, got {w}x{h}")));
    }
    Ok(())
}

/// Normalised coordinates of `pixel` after undistortion and the rotation `r`
/// (`cv::fisheye::undistortPoints(…, R)` with converged unprojection).
fn rotated_normalized<C: CameraModel>(camera: &C, r: DMat3, pixel: DVec2) -> Result<DVec2> {
    let ray =
        camera.unproject_ray(pixel).map_err(|source| RectifyError::Camera { what: "fisheye edge point", source })?;
    let q = r * ray;
    if q.z.is_nan() || q.z <= 1e-12 * q.length() {
        return Err(RectifyError::Degenerate(format!(
            "pixel ({}, {}) sees {:.1}° from the rectified axis: a pinhole cannot hold it; use a WideView \
             (equirectangular or cylindrical) instead",
            pixel.x,
            pixel.y,
            (q.z / q.length()).clamp(-1.0, 1.0).acos().to_degrees()
        )));
    }
    Ok(DVec2::new(q.x / q.z, q.y / q.z))
}

/// The new camera matrix of a pinhole view of `camera` rotated by `r`, formula for formula
/// OpenCV's `cv::fisheye::estimateNewCameraMatrixForUndistortRectify(K, D, size, R, P, balance,
/// new_size, fov_scale)`: the midpoints of the four image edges (OpenCV's integer `w/2`, `h/2`,
/// at `x = w`, `y = h`) are undistorted and rotated; the focal length blends the tightest
/// (`balance = 0`) and loosest (`balance = 1`) fit of their extents about their mean, is divided
/// by `fov_scale`, and the principal point centres the mean. Unlike OpenCV, the undistortion is
/// converged and not clipped at θ_d = π/2, so numbers agree with OpenCV wherever its 10 Newton
/// steps converge (edge midpoints within 90° of the axis); an edge midpoint at or beyond 90°
/// from the rotated axis is an error (no pinhole can show it).
///
/// Works for any [`CameraModel`] (double sphere too), `fx/fy` taken from its intrinsics.
pub fn estimate_new_camera_matrix_for_undistort_rectify<C: CameraModel>(
    camera: &C,
    r: DMat3,
    config: &RectifyConfig,
) -> Result<DMat3> {
    check(config)?;
    camera.validate().map_err(|source| RectifyError::Camera { what: "fisheye camera", source })?;
    if !r.is_finite() {
        return Err(RectifyError::NonFinite("rotation"));
    }
    let (w, h) = (camera.width(), camera.height());
    let edge = [
        DVec2::new((w / 2) as f64, 0.0),
        DVec2::new(w as f64, (h / 2) as f64),
        DVec2::new((w / 2) as f64, h as f64),
        DVec2::new(0.0, (h / 2) as f64),
    ];
    let mut pts = [DVec2::ZERO; 4];
    for (p, e) in pts.iter_mut().zip(edge) {
        *p = rotated_normalized(camera, r, e)?;
    }
    let mut cn = pts.iter().copied().sum::<DVec2>() / 4.0;
    let k = camera.intrinsics();
    let aspect = k.fx / k.fy;
    // As OpenCV: the y of the mean and of every point are scaled to a square-pixel frame.
    cn.y *= aspect;
    for p in &mut pts {
        p.y *= aspect;
    }
    let (minx, maxx) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.x), b.max(p.x)));
    let (miny, maxy) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.y), b.max(p.y)));
    let (wf, hf) = (w as f64, h as f64);
    let f = [
        wf * 0.5 / (cn.x - minx),
        wf * 0.5 / (maxx - cn.x),
        hf * 0.5 * aspect / (cn.y - miny),
        hf * 0.5 * aspect / (maxy - cn.y),
    ];
    let fmin = f.iter().copied().fold(f64::MAX, f64::min);
    let fmax = f.iter().copied().fold(f64::MIN, f64::max);
    let focal = (config.balance * fmin + (1.0 - config.balance) * fmax) / config.fov_scale;
    let mut new_f = DVec2::new(focal, focal);
    let mut new_c = -cn * focal + DVec2::new(wf, hf * aspect) * 0.5;
    new_f.y /= aspect;
    new_c.y /= aspect;
    if let Some((nw, nh)) = config.new_size {
        let (rx, ry) = (nw as f64 / wf, nh as f64 / hf);
        new_f *= DVec2::new(rx, ry);
        new_c *= DVec2::new(rx, ry);
    }
    let m = DMat3::from_cols(DVec3::new(new_f.x, 0.0, 0.0), DVec3::new(0.0, new_f.y, 0.0), new_c.extend(1.0));
    if !(m.is_finite() && new_f.x > 0.0 && new_f.y > 0.0) {
        return Err(RectifyError::Degenerate(format!(
            "new camera matrix is not usable (focal {new_f}): the undistorted edge midpoints do not surround their mean"
        )));
    }
    Ok(m)
}

/// The wide-lens rule of [`crate::stereo_rectify`] (a rig with a Kannala–Brandt or double
/// sphere camera): Bouguet-style rectification, formula for formula OpenCV's
/// `cv::fisheye::stereoRectify` (half rotations, the baseline turned onto `x`, each camera's
/// new matrix from [`estimate_new_camera_matrix_for_undistort_rectify`], the common focal length
/// the smaller of the two `fy`, principal points averaged). Returns the pinhole rectification
/// (`R1, R2, P1, P2, Q` as OpenCV, `vertical = false` as OpenCV's fisheye version; `scale` 1)
/// with the valid-pixel rectangles measured from 64 samples per image edge.
pub(crate) fn fisheye_stereo_rectify(rig: &StereoRig, config: &RectifyConfig) -> Result<Rectification> {
    check(config)?;
    if (rig.left.width(), rig.left.height()) != (rig.right.width(), rig.right.height()) {
        return Err(RectifyError::SizeMismatch(format!(
            "left camera is {}x{}, right camera {}x{}; rectification needs one image size",
            rig.left.width(),
            rig.left.height(),
            rig.right.width(),
            rig.right.height()
        )));
    }
    let (r1, r2, tnew) = rectifying_rotations(&rig.right_from_left)?;
    let k1 = estimate_new_camera_matrix_for_undistort_rectify(&rig.left, r1, config)?;
    let k2 = estimate_new_camera_matrix_for_undistort_rectify(&rig.right, r2, config)?;
    let fc = k1.y_axis.y.min(k2.y_axis.y);
    let mut cc = [DVec2::new(k1.z_axis.x, k1.z_axis.y), DVec2::new(k2.z_axis.x, k2.z_axis.y)];
    if config.zero_disparity {
        let m = (cc[0] + cc[1]) * 0.5;
        cc = [m, m];
    } else {
        let m = 0.5 * (cc[0].y + cc[1].y);
        cc[0].y = m;
        cc[1].y = m;
    }
    let p1 = [[fc, 0.0, cc[0].x, 0.0], [0.0, fc, cc[0].y, 0.0], [0.0, 0.0, 1.0, 0.0]];
    let p2 = [[fc, 0.0, cc[1].x, tnew.x * fc], [0.0, fc, cc[1].y, 0.0], [0.0, 0.0, 1.0, 0.0]];
    let q = [
        [1.0, 0.0, 0.0, -cc[0].x],
        [0.0, 1.0, 0.0, -cc[0].y],
        [0.0, 0.0, 0.0, fc],
        [0.0, 0.0, -1.0 / tnew.x, (cc[0].x - cc[1].x) / tnew.x],
    ];
    let (width, height) = config.new_size.unwrap_or((rig.left.width(), rig.left.height()));
    let km = |c: DVec2| DMat3::from_cols(DVec3::new(fc, 0.0, 0.0), DVec3::new(0.0, fc, 0.0), c.extend(1.0));
    let roi1 = valid_rect(&rig.left, r1, km(cc[0]), width, height);
    let roi2 = valid_rect(&rig.right, r2, km(cc[1]), width, height);
    Ok(Rectification {
        r1,
        r2,
        p1: ProjectionMatrix { rows: p1 },
        p2: ProjectionMatrix { rows: p2 },
        q,
        roi1,
        roi2,
        width,
        height,
        vertical: false,
        scale: 1.0,
    })
}

/// `R1`, `R2` and the rectified translation of OpenCV's `fisheye::stereoRectify` (the baseline
/// is always turned onto `x`).
pub fn rectifying_rotations(right_from_left: &Isometry3) -> Result<(DMat3, DMat3, DVec3)> {
    if !right_from_left.is_finite() {
        return Err(RectifyError::NonFinite("right_from_left"));
    }
    let tvec = right_from_left.translation;
    let nt = tvec.length();
    if !(nt.is_finite() && nt > 0.0) {
        return Err(RectifyError::ZeroBaseline(nt));
    }
    let rot = |v: DVec3| Isometry3::from_rvec_tvec(v, DVec3::ZERO).rotation_matrix();
    let r_r = rot(right_from_left.rvec() * -0.5);
    let t = r_r * tvec;
    let uu = DVec3::new(if t.x > 0.0 { 1.0 } else { -1.0 }, 0.0, 0.0);
    let mut ww = t.cross(uu);
    let nw = ww.length();
    if nw > 0.0 {
        ww *= (t.x.abs() / t.length()).min(1.0).acos() / nw;
    }
    let wr = rot(ww);
    let r1 = wr * r_r.transpose();
    let r2 = wr * r_r;
    Ok((r1, r2, r2 * tvec))
}

/// The largest rectangle bounded by the innermost mapped samples of each image edge (64 per
/// edge): `x0` the largest mapped `x` of the left edge, and so on, clipped to the output.
/// Edge samples that turn behind the rectified camera do not bound it.
pub(crate) fn valid_rect<C: CameraModel>(camera: &C, r: DMat3, k: DMat3, width: u32, height: u32) -> Roi {
    let (w, h) = (camera.width() as f64 - 1.0, camera.height() as f64 - 1.0);
    let map = |p: DVec2| -> Option<DVec2> {
        let q = r * camera.unproject_ray(p).ok()?;
        (q.z > 0.0).then(|| {
            let m = k * (q / q.z);
            DVec2::new(m.x, m.y)
        })
    };
    let n = 64;
    let (mut x0, mut x1, mut y0, mut y1) = (0.0f64, width as f64 - 1.0, 0.0f64, height as f64 - 1.0);
    for i in 0..=n {
        let t = i as f64 / n as f64;
        if let Some(p) = map(DVec2::new(0.0, t * h)) {
            x0 = x0.max(p.x);
        }
        if let Some(p) = map(DVec2::new(w, t * h)) {
            x1 = x1.min(p.x);
        }
        if let Some(p) = map(DVec2::new(t * w, 0.0)) {
            y0 = y0.max(p.y);
        }
        if let Some(p) = map(DVec2::new(t * w, h)) {
            y1 = y1.min(p.y);
        }
    }
    let (x0, y0) = (x0.ceil().max(0.0), y0.ceil().max(0.0));
    let (x1, y1) = (x1.floor().min(width as f64 - 1.0), y1.floor().min(height as f64 - 1.0));
    if x1 < x0 || y1 < y0 {
        return Roi::default();
    }
    Roi { x: x0 as u32, y: y0 as u32, width: (x1 - x0) as u32 + 1, height: (y1 - y0) as u32 + 1 }
}

/// A projection of the rectified frame for views wider than a pinhole can hold. Both put the
/// poles on the rectified `x` axis (the baseline after [`rectifying_rotations`]): a row is one
/// epipolar plane (the angle `ψ = atan2(y, z)` about the baseline), so the rows of a rectified
/// pair still match and the block matcher runs on them unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum WideProjection {
    /// `u = cx + f·α`, `v = cy + f·ψ` with `α = atan2(x, √(y² + z²))` (angle from the plane
    /// perpendicular to the baseline): up to 180° in both directions. Disparity is an angle
    /// difference (`f·(α_l − α_r)`).
    Equirectangular,
    /// `u = cx + f·x/√(y² + z²)`, `v = cy + f·ψ`: a cylinder around the baseline. Up to 180°
    /// (and more) around the baseline, less than 180° along it; disparity `d = f·B/ρ` with `ρ`
    /// the distance from the baseline, exactly as a pinhole's `f·B/Z`.
    Cylindrical,
}

/// A wide output view of the rectified frame: projection, focal length `f` (pixels per radian
/// for angles, pixels per unit for the cylinder's axis), centre and size.
///
/// ```
/// use glam::DVec3;
/// use parallax_stereo_rectify::{WideProjection, WideView};
///
/// let view = WideView::with_field_of_view(WideProjection::Cylindrical, 120.0, 200.0, 640, 480)?;
/// // A point beside and behind the rig (z < 0) and the same point seen 60 units along the baseline.
/// let left = DVec3::new(50.0, 300.0, -100.0);
/// let right = left - DVec3::new(60.0, 0.0, 0.0);
/// let (l, r) = (view.pixel(left).unwrap(), view.pixel(right).unwrap());
/// assert!((l.y - r.y).abs() < 1e-9); // same row
/// let back = view.reproject(l, l.x - r.x, 60.0).unwrap();
/// assert!((back - left).length() < 1e-9);
/// # Ok::<(), parallax_stereo_rectify::RectifyError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WideView {
    projection: WideProjection,
    focal: f64,
    cx: f64,
    cy: f64,
    width: u32,
    height: u32,
}

impl WideView {
    /// A checked view (positive finite focal length, finite centre, non-zero size).
    pub fn new(projection: WideProjection, focal: f64, cx: f64, cy: f64, width: u32, height: u32) -> Result<Self> {
        if !(focal.is_finite() && focal > 0.0) {
            return Err(RectifyError::Config(format!("wide view focal length must be positive, got {focal}")));
        }
        if !(cx.is_finite() && cy.is_finite()) {
            return Err(RectifyError::NonFinite("wide view centre"));
        }
        if width == 0 || height == 0 {
            return Err(RectifyError::Config(format!("wide view size must be non-zero, got {width}x{height}")));
        }
        Ok(Self { projection, focal, cx, cy, width, height })
    }

    /// The centred view of `width x height` pixels with square pixels that holds
    /// `along_deg` along the baseline and `around_deg` about it (the tighter of the two sets `f`):
    /// equirectangular up to 180° each way; cylindrical below 180° along the baseline.
    pub fn with_field_of_view(
        projection: WideProjection,
        along_deg: f64,
        around_deg: f64,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        let limit_along = if projection == WideProjection::Cylindrical { 179.0 } else { 180.0 };
        if !(along_deg > 0.0 && along_deg <= limit_along && around_deg > 0.0 && around_deg <= 360.0) {
            return Err(RectifyError::Config(format!(
                "{projection:?} view: field of view {along_deg}° along the baseline (≤ {limit_along}°) and \
                 {around_deg}° about it (≤ 360°)"
            )));
        }
        let (a, b) = (along_deg.to_radians(), around_deg.to_radians());
        let along_extent = match projection {
            WideProjection::Equirectangular => a,
            WideProjection::Cylindrical => 2.0 * (0.5 * a).tan(),
        };
        let focal = ((width as f64 - 1.0) / along_extent).min((height as f64 - 1.0) / b);
        Self::new(projection, focal, 0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0), width, height)
    }

    /// The projection.
    pub fn projection(&self) -> WideProjection {
        self.projection
    }
    /// Focal length in pixels (per radian, or per unit along the cylinder's axis).
    pub fn focal(&self) -> f64 {
        self.focal
    }
    /// Centre column.
    pub fn cx(&self) -> f64 {
        self.cx
    }
    /// Centre row.
    pub fn cy(&self) -> f64 {
        self.cy
    }
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The ray (rectified frame, not unit) of an output pixel.
    pub fn ray(&self, pixel: DVec2) -> DVec3 {
        let a = (pixel.x - self.cx) / self.focal;
        let psi = (pixel.y - self.cy) / self.focal;
        let (s, c) = psi.sin_cos();
        match self.projection {
            WideProjection::Equirectangular => DVec3::new(a.sin(), a.cos() * s, a.cos() * c),
            WideProjection::Cylindrical => DVec3::new(a, s, c),
        }
    }

    /// The output pixel of a direction (rectified frame); `None` on the baseline axis itself
    /// (and, for the cylinder, at or behind 90° along it).
    pub fn pixel(&self, ray: DVec3) -> Option<DVec2> {
        let rho = ray.y.hypot(ray.z);
        if !(rho > 0.0 && ray.is_finite()) {
            return None;
        }
        let psi = ray.y.atan2(ray.z);
        let a = match self.projection {
            WideProjection::Equirectangular => ray.x.atan2(rho),
            WideProjection::Cylindrical => ray.x / rho,
        };
        Some(DVec2::new(self.cx + self.focal * a, self.cy + self.focal * psi))
    }

    /// The 3D point (rectified left frame) of a left pixel with disparity `d = u_l − u_r`
    /// (pixels) for a rig whose rectified baseline is `baseline` (the length of `T`, board
    /// units); `None` for a non-positive disparity.
    pub fn reproject(&self, pixel: DVec2, disparity: f64, baseline: f64) -> Option<DVec3> {
        if !(disparity > 0.0 && baseline.is_finite() && baseline > 0.0) {
            return None;
        }
        let psi = (pixel.y - self.cy) / self.focal;
        let (s, c) = psi.sin_cos();
        let (rho, x) = match self.projection {
            WideProjection::Cylindrical => {
                let rho = self.focal * baseline / disparity;
                (rho, (pixel.x - self.cx) / self.focal * rho)
            }
            WideProjection::Equirectangular => {
                // In the epipolar plane: the left ray at angle α_l, the right at α_r from the
                // normal to the baseline; distance along the left ray by the law of sines.
                let al = (pixel.x - self.cx) / self.focal;
                let ar = al - disparity / self.focal;
                let dist = baseline * ar.cos() / (al - ar).sin();
                (dist * al.cos(), dist * al.sin())
            }
        };
        let p = DVec3::new(x, rho * s, rho * c);
        p.is_finite().then_some(p)
    }
}

/// The map from a camera to a [`WideView`] of its rectified frame (`r` = `R1` or `R2`):
/// output pixel ← the ray `Rᵀ · view.ray(pixel)` projected through the camera model; NaN where
/// the ray lies outside the model's valid region.
pub fn init_wide_view_map<C: CameraModel + Sync>(camera: &C, r: DMat3, view: &WideView) -> Result<RemapTable> {
    camera.validate().map_err(|source| RectifyError::Camera { what: "camera of the map", source })?;
    if !r.is_finite() {
        return Err(RectifyError::NonFinite("rotation"));
    }
    let rt = r.transpose();
    RemapTable::from_fn(view.width, view.height, |u, v| {
        camera.project(rt * view.ray(DVec2::new(u as f64, v as f64))).ok()
    })
}

/// A wide-angle rig rectified onto one [`WideView`]: rows of the two maps' outputs are the same
/// epipolar planes.
#[derive(Debug, Clone, PartialEq)]
pub struct WideRectification {
    /// The output view shared by both images.
    pub view: WideView,
    /// Rotation from the left camera frame to the rectified frame (`R1` of [`rectifying_rotations`]).
    pub r1: DMat3,
    /// Rotation from the right camera frame to the rectified right frame (`R2`).
    pub r2: DMat3,
    /// `|T|` after rectification (the baseline along the rectified `x` axis), rig units.
    pub baseline: f64,
    /// Map of the left image.
    pub left_map: RemapTable,
    /// Map of the right image.
    pub right_map: RemapTable,
}

/// Rectifies a wide-angle rig onto `view`: OpenCV's fisheye rotations ([`rectifying_rotations`])
/// and both maps ([`init_wide_view_map`], built in parallel). The right camera must lie on the
/// rectified `+x` side of the left one, i.e. OpenCV's usual `T_x < 0` (then disparities `u_l − u_r` are positive);
/// a rig with `T_x > 0` is an error naming the fix (swap the cameras).
pub fn wide_rectify(rig: &StereoRig, view: &WideView) -> Result<WideRectification> {
    let (r1, r2, t) = rectifying_rotations(&rig.right_from_left)?;
    if t.x >= 0.0 {
        return Err(RectifyError::Config(format!(
            "the rectified baseline T_x = {} is not negative: the 'right' camera is on the left; swap the cameras",
            t.x
        )));
    }
    let (l, r) = rayon::join(|| init_wide_view_map(&rig.left, r1, view), || init_wide_view_map(&rig.right, r2, view));
    Ok(WideRectification { view: *view, r1, r2, baseline: -t.x, left_map: l?, right_map: r? })
}

/// Rectifies pixels of a wide-angle (or any) camera onto a [`WideView`] of its rectified frame
/// (`r` = `R1` or `R2`): the row of a scene point is the same in both images and the column
/// difference is the view's disparity ([`WideView::reproject`]).
pub fn rectify_points_wide<C: CameraModel>(
    camera: &C,
    r: DMat3,
    view: &WideView,
    pixels: &[DVec2],
) -> Result<Vec<DVec2>> {
    if !r.is_finite() {
        return Err(RectifyError::NonFinite("rotation"));
    }
    map_points(camera, pixels, |ray| {
        view.pixel(r * ray).filter(|q| q.is_finite()).ok_or("its ray has no rectified position")
    })
}

/// Each pixel's ray (the camera's unprojection) through `f`, or an error naming the first pixel
/// without a ray or whose ray `f` refuses (with `f`'s reason).
pub(crate) fn map_points<C: CameraModel>(
    camera: &C,
    pixels: &[DVec2],
    f: impl Fn(DVec3) -> std::result::Result<DVec2, &'static str>,
) -> Result<Vec<DVec2>> {
    camera.validate().map_err(|source| RectifyError::Camera { what: "camera of the points", source })?;
    pixels
        .iter()
        .enumerate()
        .map(|(index, &pixel)| {
            let fail = |reason: String| RectifyError::Point { what: "pixels", index, u: pixel.x, v: pixel.y, reason };
            let ray = camera.unproject_ray(pixel).map_err(|e| fail(e.to_string()))?;
            f(ray).map_err(|reason| fail(reason.into()))
        })
        .collect()
}
