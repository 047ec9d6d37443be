//! Triangulation of one point from two or more calibrated views.

use faer::{Col, Mat};
use glam::{DMat3, DVec2, DVec3, DVec4};
use parallax_camera_model::{Camera, Isometry3, ProjectionMatrix, StereoRig};
use serde::{Deserialize, Serialize};

use crate::{Result, TriangulationError};

/// A calibrated view: a camera and its pose `camera_from_world`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct View {
    /// Intrinsics, distortion and image size.
    pub camera: Camera,
    /// Maps world points into this camera's frame.
    pub camera_from_world: Isometry3,
}

impl View {
    /// A view of `camera` placed at `camera_from_world`.
    pub fn new(camera: Camera, camera_from_world: Isometry3) -> Self {
        Self { camera, camera_from_world }
    }

    /// The pinhole projection matrix `K [R | t]` (distortion not included).
    pub fn projection_matrix(&self) -> ProjectionMatrix {
        ProjectionMatrix::new(self.camera.intrinsics.matrix(), &self.camera_from_world)
    }

    /// The optical centre in the world frame, `−Rᵀ t`.
    pub fn center(&self) -> DVec3 {
        self.camera_from_world.inverse().translation
    }

    /// The unit direction, in the world frame, of the ray through a (distorted) pixel.
    pub fn ray_direction(&self, pixel: DVec2) -> Result<DVec3> {
        let ray = self.camera.unproject(pixel)?;
        Ok(self.camera_from_world.rotation().inverse() * ray.normalize())
    }

    /// The pixel a pinhole camera with the same `K` would see (lens distortion removed).
    pub fn undistorted_pixel(&self, pixel: DVec2) -> Result<DVec2> {
        Ok(self.camera.undistort_pixel(pixel)?)
    }
}

/// The two views of a stereo rig; the world frame is the left camera frame.
pub fn stereo_views(rig: &StereoRig) -> [View; 2] {
    [View::new(rig.left, Isometry3::IDENTITY), View::new(rig.right, rig.right_from_left)]
}

/// Triangulation method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Method {
    /// The inhomogeneous linear least-squares form `A X = B` (two equations per view from the
    /// rows of `P`, solved for `X, Y, Z` by QR), on undistorted pixels.
    Linear,
    /// The homogeneous DLT `A X = 0`, `X` the null vector of `A` by SVD (as OpenCV's
    /// `triangulatePoints`), on undistorted pixels, rows scaled to unit norm and the world
    /// normalised (Hartley) so the result does not depend on the length unit.
    Dlt,
    /// The point closest to all rays in the least-squares sense; for two views the midpoint of
    /// the common perpendicular.
    Midpoint,
    /// Minimises the reprojection error in the observed (distorted) pixels over `X` by
    /// Gauss–Newton with Levenberg damping, started from the DLT. The maximum-likelihood
    /// estimate under independent Gaussian pixel noise.
    #[default]
    Optimal,
}

/// Tuning of [`triangulate`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TriangulationConfig {
    /// Which estimator to use.
    pub method: Method,
    /// Standard deviation of the pixel noise per coordinate, pixels; scales the reported
    /// covariance (`σ² (JᵀJ)⁻¹`). Default 0.1 px (good sub-pixel corners).
    pub pixel_sigma: f64,
    /// Points whose largest angle between two viewing rays is below this are flagged
    /// `low_parallax`, degrees. Default 1°.
    pub min_parallax_deg: f64,
    /// Points whose RMS reprojection error is above this are flagged `high_reprojection`,
    /// pixels: their pixels do not lie on corresponding epipolar lines (a wrong match or row, or
    /// the calibration of another rig), and the point is the closest compromise, not a
    /// measurement. Default 1 px (a pixel pair about 2 px off its epipolar line; matched
    /// corners of a good calibration give 0.1–0.3 px).
    pub max_reprojection_px: f64,
    /// Iteration cap of the optimal method. Default 50.
    pub max_iterations: usize,
    /// The optimal method stops when the step is below `tolerance · (‖X‖ + tolerance)`.
    /// Default 1e-14.
    pub tolerance: f64,
    /// Compute the first-order covariance of every point. Default true.
    pub covariance: bool,
}

impl Default for TriangulationConfig {
    fn default() -> Self {
        Self {
            method: Method::Optimal,
            pixel_sigma: 0.1,
            min_parallax_deg: 1.0,
            max_reprojection_px: 1.0,
            max_iterations: 50,
            tolerance: 1e-14,
            covariance: true,
        }
    }
}

impl TriangulationConfig {
    /// The default configuration with another method.
    pub fn with_method(method: Method) -> Self {
        Self { method, ..Self::default() }
    }

    fn validate(&self) -> Result<()> {
        if !(self.pixel_sigma.is_finite() && self.pixel_sigma >= 0.0) {
            return Err(TriangulationError::InvalidParameter(format!(
                "pixel_sigma must be finite and non-negative, got {}",
                self.pixel_sigma
            )));
        }
        if !(self.min_parallax_deg.is_finite() && self.min_parallax_deg >= 0.0) {
            return Err(TriangulationError::InvalidParameter(format!(
                "min_parallax_deg must be finite and non-negative, got {}",
                self.min_parallax_deg
            )));
        }
        if self.max_reprojection_px.is_nan() || self.max_reprojection_px <= 0.0 {
            return Err(TriangulationError::InvalidParameter(format!(
                "max_reprojection_px must be positive (infinity: no check), got {}",
                self.max_reprojection_px
            )));
        }
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(TriangulationError::InvalidParameter(format!(
                "tolerance must be finite and non-negative, got {}",
                self.tolerance
            )));
        }
        Ok(())
    }
}

/// A triangulated point and its quality.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TriangulatedPoint {
    /// The point in the world frame (the left camera frame for a rig), in the calibration's
    /// length unit.
    pub point: DVec3,
    /// The method that produced it.
    pub method: Method,
    /// Reprojection error in each view, pixels: distance between the observed pixel and the
    /// projection of `point` through the full camera model. For a point behind a camera the
    /// pinhole projection of `point` is compared with the undistorted pixel instead
    /// (`f64::INFINITY` when the point lies in that camera's focal plane).
    pub reprojection_errors: Vec<f64>,
    /// Root mean square of `reprojection_errors` over the views, pixels.
    pub rms_reprojection_error: f64,
    /// Largest angle between two viewing rays at the point, degrees.
    pub parallax_deg: f64,
    /// The point is on or behind the image plane of at least one camera (`z ≤ 0`).
    pub behind_camera: bool,
    /// `parallax_deg` is below [`TriangulationConfig::min_parallax_deg`]: depth is unreliable.
    pub low_parallax: bool,
    /// `rms_reprojection_error` is above [`TriangulationConfig::max_reprojection_px`]: the
    /// pixels do not correspond.
    #[serde(default)]
    pub high_reprojection: bool,
    /// First-order covariance of `point` from pixel noise of [`TriangulationConfig::pixel_sigma`]
    /// per coordinate, `σ² (JᵀJ)⁻¹` with `J` the Jacobian of all reprojections at `point`
    /// (length unit²). `None` when not asked for or not computable (point behind a camera).
    pub covariance: Option<DMat3>,
    /// Gauss–Newton iterations of the optimal method (0 for the linear methods).
    pub iterations: usize,
}

impl TriangulatedPoint {
    /// Standard deviations of `X, Y, Z` (square roots of the covariance diagonal).
    pub fn std_devs(&self) -> Option<DVec3> {
        self.covariance
            .map(|c| DVec3::new(c.x_axis.x.max(0.0).sqrt(), c.y_axis.y.max(0.0).sqrt(), c.z_axis.z.max(0.0).sqrt()))
    }

    /// True when the point is in front of every camera with enough parallax and its pixels
    /// correspond (reprojection error within the threshold).
    pub fn is_reliable(&self) -> bool {
        !self.behind_camera && !self.low_parallax && !self.high_reprojection
    }
}

fn check_inputs(views: &[View], pixels: &[DVec2]) -> Result<()> {
    if views.len() < 2 {
        return Err(TriangulationError::TooFew { what: "views", needed: 2, got: views.len() });
    }
    if views.len() != pixels.len() {
        return Err(TriangulationError::SizeMismatch(format!("{} views but {} pixels", views.len(), pixels.len())));
    }
    for (i, (v, p)) in views.iter().zip(pixels).enumerate() {
        if !p.is_finite() {
            return Err(TriangulationError::NonFinite { what: format!("pixel of view {i}") });
        }
        v.camera.validate()?;
        if !v.camera_from_world.is_finite() {
            return Err(TriangulationError::NonFinite { what: format!("pose of view {i}") });
        }
    }
    Ok(())
}

/// Angle between two vectors in radians, accurate for tiny and near-π angles (0 for a zero vector).
fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

fn max_pairwise_angle(dirs: &[DVec3]) -> f64 {
    let mut best = 0.0f64;
    for i in 0..dirs.len() {
        for j in i + 1..dirs.len() {
            best = best.max(angle_between(dirs[i], dirs[j]));
        }
    }
    best
}

/// Rays whose directions differ by less than this (radians) are treated as parallel.
const PARALLEL_RAYS_RAD: f64 = 1e-12;

/// Triangulates one point seen in `views` at (distorted) `pixels` with the configured method.
///
/// Undistorts the pixels first (through [`Camera::unproject`]) for the linear methods; the
/// optimal method works on the observed pixels through the full camera model. Errors on fewer
/// than two views, mismatched lengths, non-finite input, pixels that cannot be undistorted and
/// parallel rays ([`TriangulationError::ParallelRays`]); never returns a non-finite point.
pub fn triangulate(views: &[View], pixels: &[DVec2], config: &TriangulationConfig) -> Result<TriangulatedPoint> {
    check_inputs(views, pixels)?;
    config.validate()?;
    let dirs = views.iter().zip(pixels).map(|(v, p)| v.ray_direction(*p)).collect::<Result<Vec<_>>>()?;
    let ray_angle = max_pairwise_angle(&dirs);
    if ray_angle < PARALLEL_RAYS_RAD {
        return Err(TriangulationError::ParallelRays { angle_rad: ray_angle });
    }
    let centers: Vec<DVec3> = views.iter().map(View::center).collect();
    let (point, iterations) = match config.method {
        Method::Linear | Method::Dlt => {
            let projections: Vec<ProjectionMatrix> = views.iter().map(View::projection_matrix).collect();
            let undistorted =
                views.iter().zip(pixels).map(|(v, p)| v.undistorted_pixel(*p)).collect::<Result<Vec<_>>>()?;
            let x = if config.method == Method::Linear {
                linear_from_projections(&projections, &undistorted)?
            } else {
                dlt_from_projections(&projections, &undistorted)?
            };
            (x, 0)
        }
        Method::Midpoint => (midpoint_from_rays(&centers, &dirs)?, 0),
        Method::Optimal => {
            let projections: Vec<ProjectionMatrix> = views.iter().map(View::projection_matrix).collect();
            let undistorted =
                views.iter().zip(pixels).map(|(v, p)| v.undistorted_pixel(*p)).collect::<Result<Vec<_>>>()?;
            let init =
                dlt_from_projections(&projections, &undistorted).or_else(|_| midpoint_from_rays(&centers, &dirs))?;
            refine(views, pixels, init, config)
        }
    };
    if !point.is_finite() {
        return Err(TriangulationError::Degenerate("the solution is not finite".into()));
    }
    Ok(assess(views, pixels, point, config, iterations))
}

/// Triangulates a left/right pixel pair of a stereo rig (world frame = left camera frame).
pub fn triangulate_stereo(
    rig: &StereoRig,
    left: DVec2,
    right: DVec2,
    config: &TriangulationConfig,
) -> Result<TriangulatedPoint> {
    triangulate(&stereo_views(rig), &[left, right], config)
}

/// Triangulates many left/right pairs of a stereo rig in parallel (rayon); one result per pair,
/// in input order.
pub fn triangulate_stereo_batch(
    rig: &StereoRig,
    pairs: &[(DVec2, DVec2)],
    config: &TriangulationConfig,
) -> Vec<Result<TriangulatedPoint>> {
    use rayon::prelude::*;
    let views = stereo_views(rig);
    pairs.par_iter().map(|(l, r)| triangulate(&views, &[*l, *r], config)).collect()
}

/// Reprojection errors, flags and covariance of a point.
fn assess(
    views: &[View],
    pixels: &[DVec2],
    point: DVec3,
    config: &TriangulationConfig,
    iterations: usize,
) -> TriangulatedPoint {
    let mut behind = false;
    let mut errors = Vec::with_capacity(views.len());
    for (v, p) in views.iter().zip(pixels) {
        let pc = v.camera_from_world.transform_point(point);
        if pc.z > 0.0 {
            match v.camera.project(pc) {
                Ok(q) => errors.push((q - *p).length()),
                Err(_) => errors.push(f64::INFINITY),
            }
        } else {
            behind = true;
            let h = v.projection_matrix().apply(point.extend(1.0));
            let e = match v.undistorted_pixel(*p) {
                Ok(u) if h.z != 0.0 => (DVec2::new(h.x / h.z, h.y / h.z) - u).length(),
                _ => f64::INFINITY,
            };
            errors.push(if e.is_finite() { e } else { f64::INFINITY });
        }
    }
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let at_point: Vec<DVec3> = views.iter().map(|v| point - v.center()).collect();
    let parallax_deg = max_pairwise_angle(&at_point).to_degrees();
    let covariance =
        if config.covariance && !behind { point_covariance(views, point, config.pixel_sigma).ok() } else { None };
    TriangulatedPoint {
        point,
        method: config.method,
        reprojection_errors: errors,
        rms_reprojection_error: rms,
        parallax_deg,
        behind_camera: behind,
        low_parallax: parallax_deg < config.min_parallax_deg,
        high_reprojection: rms.is_nan() || rms > config.max_reprojection_px,
        covariance,
        iterations,
    }
}

/// `JᵀJ` and `Jᵀr` of the reprojection residuals at `x`; `None` when `x` is behind a camera.
fn normal_equations(views: &[View], pixels: &[DVec2], x: DVec3) -> Option<(DMat3, DVec3, f64)> {
    let mut h = DMat3::ZERO;
    let mut g = DVec3::ZERO;
    let mut cost = 0.0;
    for (v, p) in views.iter().zip(pixels) {
        let pj = v.camera.project_with_jacobians(&v.camera_from_world, x).ok()?;
        let r = pj.pixel - *p;
        let j0 = DVec3::from_array(pj.d_point[0]);
        let j1 = DVec3::from_array(pj.d_point[1]);
        h += outer(j0, j0) + outer(j1, j1);
        g += j0 * r.x + j1 * r.y;
        cost += r.length_squared();
    }
    (cost.is_finite() && h.is_finite()).then_some((h, g, cost))
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Solves the symmetric 3x3 system `h x = b`; `None` when `h` is (numerically) singular.
fn solve3(h: DMat3, b: DVec3) -> Option<DVec3> {
    let det = h.determinant();
    let scale = h.x_axis.length() * h.y_axis.length() * h.z_axis.length();
    if !det.is_finite() || scale == 0.0 || det.abs() <= 1e-14 * scale {
        return None;
    }
    let x = h.inverse() * b;
    x.is_finite().then_some(x)
}

/// Gauss–Newton with Levenberg damping on the reprojection error; returns the point and the
/// iteration count. A start behind a camera is returned unchanged (it is flagged later).
fn refine(views: &[View], pixels: &[DVec2], init: DVec3, config: &TriangulationConfig) -> (DVec3, usize) {
    let Some((mut h, mut g, mut cost)) = normal_equations(views, pixels, init) else {
        return (init, 0);
    };
    let mut x = init;
    let mut lambda = 0.0f64;
    let mut iterations = 0;
    let mut rejections = 0;
    while iterations < config.max_iterations && cost > 0.0 && rejections < 40 {
        iterations += 1;
        let diag = DVec3::new(h.x_axis.x, h.y_axis.y, h.z_axis.z);
        let damped = h + DMat3::from_diagonal(diag * lambda);
        let Some(step) = solve3(damped, -g) else {
            lambda = if lambda == 0.0 { 1e-6 } else { lambda * 10.0 };
            rejections += 1;
            continue;
        };
        let small = step.length() <= config.tolerance * (x.length() + config.tolerance);
        let candidate = x + step;
        match normal_equations(views, pixels, candidate) {
            Some((h2, g2, c2)) if c2 <= cost => {
                x = candidate;
                h = h2;
                g = g2;
                cost = c2;
                lambda = if lambda <= 1e-6 { 0.0 } else { lambda * 0.1 };
                rejections = 0;
                if small {
                    break;
                }
            }
            _ => {
                if small {
                    break;
                }
                lambda = if lambda == 0.0 { 1e-6 } else { lambda * 10.0 };
                rejections += 1;
            }
        }
    }
    (x, iterations)
}

/// First-order covariance of a point triangulated from `pixels` with independent noise of
/// `pixel_sigma` per coordinate: `σ² (JᵀJ)⁻¹`, `J` the `2N x 3` Jacobian of the projections
/// (full camera model) at `point`. This is the covariance of the optimal (maximum-likelihood)
/// estimator to first order.
pub fn point_covariance(views: &[View], point: DVec3, pixel_sigma: f64) -> Result<DMat3> {
    if !point.is_finite() {
        return Err(TriangulationError::NonFinite { what: "point".into() });
    }
    if !(pixel_sigma.is_finite() && pixel_sigma >= 0.0) {
        return Err(TriangulationError::InvalidParameter(format!("pixel_sigma must be ≥ 0, got {pixel_sigma}")));
    }
    let dummy: Vec<DVec2> = vec![DVec2::ZERO; views.len()];
    let (h, _, _) = normal_equations(views, &dummy, point)
        .ok_or_else(|| TriangulationError::Degenerate("point is behind a camera: no covariance".into()))?;
    let det = h.determinant();
    let scale = h.x_axis.length() * h.y_axis.length() * h.z_axis.length();
    if !det.is_finite() || det.abs() <= 1e-14 * scale {
        return Err(TriangulationError::Degenerate("JᵀJ is singular (rays nearly parallel)".into()));
    }
    let c = h.inverse() * (pixel_sigma * pixel_sigma);
    // Symmetrise against rounding.
    Ok((c + c.transpose()) * 0.5)
}

/// The thesis's linear least-squares triangulation (eq. 3.5–3.6): for every view with
/// projection matrix `M` (rows `m1, m2, m3`) and pinhole pixel `(u, v)`,
///
/// ```text
/// (u m31 − m11) X + (u m32 − m12) Y + (u m33 − m13) Z = m14 − u m34
/// (v m31 − m21) X + (v m32 − m22) Y + (v m33 − m23) Z = m24 − v m34
/// ```
///
/// stacked into `A X = B` and solved in the least-squares sense (by QR, which gives the same
/// solution as `(AᵀA)⁻¹AᵀB` with better rounding). Pixels must be undistorted.
pub fn linear_from_projections(projections: &[ProjectionMatrix], pixels: &[DVec2]) -> Result<DVec3> {
    check_projections(projections, pixels)?;
    let n = projections.len();
    let mut a = Mat::<f64>::zeros(2 * n, 3);
    let mut b = Col::<f64>::zeros(2 * n);
    for (k, (p, px)) in projections.iter().zip(pixels).enumerate() {
        let m = &p.rows;
        for (row, coord) in [(0usize, px.x), (1usize, px.y)] {
            let i = 2 * k + row;
            for c in 0..3 {
                a[(i, c)] = coord * m[2][c] - m[row][c];
            }
            b[i] = m[row][3] - coord * m[2][3];
        }
    }
    let x = parallax_least_squares::solve_linear_least_squares(a.as_ref(), b.as_ref()).map_err(|e| match e {
        parallax_least_squares::LeastSquaresError::Numerical(_) => {
            TriangulationError::Degenerate("A X = B is rank deficient (rays parallel or through both centres)".into())
        }
        other => other.into(),
    })?;
    let x = DVec3::new(x[0], x[1], x[2]);
    if !x.is_finite() {
        return Err(TriangulationError::Degenerate("linear solution is not finite".into()));
    }
    Ok(x)
}

/// Homogeneous DLT: rows `u p3 − p1`, `v p3 − p2` of every view stacked into `A`, each row
/// scaled to unit norm, `X` the right singular vector of the smallest singular value
/// ([`parallax_least_squares::null_vector`]). Pixels must be undistorted. Errors when the solution is
/// at infinity (`W ≈ 0`).
///
/// The unit-norm constraint of the homogeneous method is not invariant to the world's units
/// (in millimetres `‖X‖ ≈ |Z|` swamps `W = 1` and the estimate degrades badly with noise), so
/// the world is first normalised as Hartley recommends: origin at the centroid of the camera
/// centres, unit length = distance from there to the inhomogeneous linear estimate. Without
/// noise the result is the same as the raw DLT.
pub fn dlt_from_projections(projections: &[ProjectionMatrix], pixels: &[DVec2]) -> Result<DVec3> {
    check_projections(projections, pixels)?;
    let n = projections.len();
    // World normalisation X = c + s X'.
    let mut centroid = DVec3::ZERO;
    for p in projections {
        let m = p.left_block();
        let det = m.determinant();
        if det == 0.0 || !det.is_finite() {
            return Err(TriangulationError::Degenerate("a projection matrix has a singular left 3x3 block".into()));
        }
        centroid += -(m.inverse() * p.last_column());
    }
    centroid /= n as f64;
    let scale = linear_from_projections(projections, pixels)
        .ok()
        .map(|x| (x - centroid).length())
        .filter(|s| s.is_finite() && *s > 0.0)
        .unwrap_or(1.0);
    let mut a = Mat::<f64>::zeros(2 * n, 4);
    for (k, (p, px)) in projections.iter().zip(pixels).enumerate() {
        let m = &p.rows;
        for (row, coord) in [(0usize, px.x), (1usize, px.y)] {
            let i = 2 * k + row;
            let r: [f64; 4] = std::array::from_fn(|c| coord * m[2][c] - m[row][c]);
            // r · [c + s X'; 1] = (s r₀₋₂) · X' + (r₀₋₂ · c + r₃)
            let r3 = DVec3::new(r[0], r[1], r[2]);
            let t: [f64; 4] = [r[0] * scale, r[1] * scale, r[2] * scale, r3.dot(centroid) + r[3]];
            let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt();
            let s = if norm > 0.0 { 1.0 / norm } else { 1.0 };
            for c in 0..4 {
                a[(i, c)] = t[c] * s;
            }
        }
    }
    let nv = parallax_least_squares::null_vector(a.as_ref())?;
    let h = DVec4::new(nv.vector[0], nv.vector[1], nv.vector[2], nv.vector[3]);
    let xyz = h.truncate();
    if !h.is_finite() || h.w.abs() <= 1e-12 * xyz.length() {
        return Err(TriangulationError::Degenerate(format!(
            "DLT solution is at infinity (W = {:e}, |XYZ| = {:e})",
            h.w,
            xyz.length()
        )));
    }
    Ok(centroid + xyz / h.w * scale)
}

/// The point minimising the sum of squared distances to the rays `centers[i] + t·directions[i]`:
/// `Σ (I − d dᵀ) X = Σ (I − d dᵀ) C`. For two rays this is the midpoint of their common
/// perpendicular. Errors on parallel rays.
pub fn midpoint_from_rays(centers: &[DVec3], directions: &[DVec3]) -> Result<DVec3> {
    if centers.len() < 2 {
        return Err(TriangulationError::TooFew { what: "rays", needed: 2, got: centers.len() });
    }
    if centers.len() != directions.len() {
        return Err(TriangulationError::SizeMismatch(format!(
            "{} centres but {} directions",
            centers.len(),
            directions.len()
        )));
    }
    let mut a = DMat3::ZERO;
    let mut b = DVec3::ZERO;
    for (i, (c, d)) in centers.iter().zip(directions).enumerate() {
        if !c.is_finite() || !d.is_finite() || d.length_squared() == 0.0 {
            return Err(TriangulationError::NonFinite { what: format!("ray {i}") });
        }
        let d = d.normalize();
        let m = DMat3::IDENTITY - outer(d, d);
        a += m;
        b += m * *c;
    }
    let angle = max_pairwise_angle(directions);
    if angle < PARALLEL_RAYS_RAD {
        return Err(TriangulationError::ParallelRays { angle_rad: angle });
    }
    let fa = parallax_least_squares::mat_from_dmat3(a);
    let fb = Col::from_fn(3, |i| b[i]);
    let x = parallax_least_squares::solve_linear_least_squares(fa.as_ref(), fb.as_ref())
        .map_err(|_| TriangulationError::ParallelRays { angle_rad: angle })?;
    let x = DVec3::new(x[0], x[1], x[2]);
    if !x.is_finite() {
        return Err(TriangulationError::ParallelRays { angle_rad: angle });
    }
    Ok(x)
}

fn check_projections(projections: &[ProjectionMatrix], pixels: &[DVec2]) -> Result<()> {
    if projections.len() < 2 {
        return Err(TriangulationError::TooFew { what: "projection matrices", needed: 2, got: projections.len() });
    }
    if projections.len() != pixels.len() {
        return Err(TriangulationError::SizeMismatch(format!(
            "{} projection matrices but {} pixels",
            projections.len(),
            pixels.len()
        )));
    }
    for (i, (p, px)) in projections.iter().zip(pixels).enumerate() {
        if !px.is_finite() {
            return Err(TriangulationError::NonFinite { what: format!("pixel of view {i}") });
        }
        if p.rows.iter().flatten().any(|v| !v.is_finite()) {
            return Err(TriangulationError::NonFinite { what: format!("projection matrix {i}") });
        }
    }
    Ok(())
}
