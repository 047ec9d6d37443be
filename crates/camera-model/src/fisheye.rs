//! Wide-angle and fisheye lens models: Kannala–Brandt (OpenCV's `cv::fisheye`, Kalibr's
//! `pinhole-equi`) and the double sphere model (Usenko, Demmel, Cremers 2018; Kalibr's `ds`),
//! with analytic Jacobians, unprojection with a stated tolerance and explicit valid regions.

use std::f64::consts::PI;

use glam::{DMat3, DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{CameraModel, CameraModelError, Intrinsics, Isometry3, ProjectionJacobians, Result};

/// Convergence tolerance of the Kannala–Brandt unprojection: the distorted angle of the
/// returned ray matches the pixel's to within this many radians (normalised image units; at
/// `fx = 300` that is 3e-11 px). The double sphere unprojection is closed form (rounding only).
pub const FISHEYE_UNPROJECT_TOLERANCE: f64 = 1e-13;
/// Iteration cap of the safeguarded Newton iteration of the Kannala–Brandt unprojection.
pub const FISHEYE_UNPROJECT_MAX_ITERATIONS: usize = 100;

/// The Kannala–Brandt (equidistant polynomial) model exactly as OpenCV's `cv::fisheye`:
///
/// ```text
/// θ   = atan2(√(x² + y²), z)                       (angle from the optical axis, 0..π)
/// θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)
/// (x', y') = θ_d · (x, y) / √(x² + y²)             (normalised, then pixel = K (x', y', 1))
/// ```
///
/// For `z > 0` this is OpenCV's formula (`θ = atan(r)`, `r = √(a² + b²)`, `a = x/z`); written
/// with `atan2` it also images points at and behind the image plane (fields of view of 180°
/// and more). The valid region is `θ < θ_max`, where `θ_max` is the first angle at which
/// `dθ_d/dθ` reaches 0 (the polynomial folds back), capped at π; see [`Self::max_theta`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "KannalaBrandtCoefficients", into = "KannalaBrandtCoefficients")]
pub struct KannalaBrandt {
    k: [f64; 4],
    theta_max: f64,
}

/// The serialised form of [`KannalaBrandt`] (checked on deserialisation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct KannalaBrandtCoefficients {
    /// θ³ coefficient.
    pub k1: f64,
    /// θ⁵ coefficient.
    pub k2: f64,
    /// θ⁷ coefficient.
    pub k3: f64,
    /// θ⁹ coefficient.
    pub k4: f64,
}

impl TryFrom<KannalaBrandtCoefficients> for KannalaBrandt {
    type Error = CameraModelError;
    fn try_from(c: KannalaBrandtCoefficients) -> Result<Self> {
        Self::new(c.k1, c.k2, c.k3, c.k4)
    }
}

impl From<KannalaBrandt> for KannalaBrandtCoefficients {
    fn from(m: KannalaBrandt) -> Self {
        Self { k1: m.k[0], k2: m.k[1], k3: m.k[2], k4: m.k[3] }
    }
}

impl KannalaBrandt {
    /// A checked model: all coefficients finite. The valid region is computed here.
    pub fn new(k1: f64, k2: f64, k3: f64, k4: f64) -> Result<Self> {
        let k = [k1, k2, k3, k4];
        if !k.iter().all(|c| c.is_finite()) {
            return Err(CameraModelError::InvalidLens(format!("Kannala–Brandt coefficients {k:?} are not all finite")));
        }
        Ok(Self { k, theta_max: fold_angle(&k) })
    }

    /// The equidistant lens `θ_d = θ` (all coefficients 0).
    pub fn equidistant() -> Self {
        Self { k: [0.0; 4], theta_max: PI }
    }

    /// From OpenCV's fisheye `D` vector (exactly 4 values `k1, k2, k3, k4`).
    pub fn from_opencv(d: &[f64]) -> Result<Self> {
        match d {
            [k1, k2, k3, k4] => Self::new(*k1, *k2, *k3, *k4),
            _ => Err(CameraModelError::SizeMismatch(format!(
                "OpenCV fisheye distortion has exactly 4 coefficients (k1, k2, k3, k4), got {}",
                d.len()
            ))),
        }
    }

    /// `(k1, k2, k3, k4)`, OpenCV's order.
    pub fn coefficients(&self) -> [f64; 4] {
        self.k
    }

    /// The valid region's bound: directions with `θ < max_theta()` are imaged, one-to-one.
    /// It is the first zero of `dθ_d/dθ` in `(0, π]` (found by a scan of 4096 steps in `θ²` and
    /// bisection to machine precision), or π when the polynomial is increasing up to π.
    pub fn max_theta(&self) -> f64 {
        self.theta_max
    }

    /// `θ_d(θ)`.
    #[inline]
    pub fn distort_theta(&self, theta: f64) -> f64 {
        self.distort_theta_with_derivative(theta).0
    }

    /// `θ_d(θ)` and `dθ_d/dθ`.
    #[inline]
    pub fn distort_theta_with_derivative(&self, theta: f64) -> (f64, f64) {
        let [k1, k2, k3, k4] = self.k;
        let t2 = theta * theta;
        let poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
        let dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
        (theta * poly, dpoly)
    }

    /// The angle `θ ∈ [0, θ_max)` with `θ_d(θ) = theta_d`: Newton's method safeguarded by
    /// bisection on the bracket `[0, θ_max]`, on which `θ_d` is increasing (checked by
    /// construction of `θ_max`), so the root is unique. Stops when `|θ_d(θ) − theta_d| ≤`
    /// [`FISHEYE_UNPROJECT_TOLERANCE`]. Errors for `theta_d` beyond `θ_d(θ_max)`: no ray.
    pub fn undistort_theta(&self, theta_d: f64) -> Result<f64> {
        if !theta_d.is_finite() || theta_d < 0.0 {
            return Err(CameraModelError::NonFinite { what: "distorted angle" });
        }
        if theta_d == 0.0 {
            return Ok(0.0);
        }
        let limit = self.distort_theta(self.theta_max);
        if theta_d >= limit {
            return Err(CameraModelError::OutsideValidRegion {
                what: "pixel",
                detail: format!(
                    "distorted angle {theta_d:.6} rad is at or beyond the lens's largest, θ_d({:.4} rad) = {limit:.6} rad",
                    self.theta_max
                ),
            });
        }
        let (mut lo, mut hi) = (0.0, self.theta_max);
        let mut theta = theta_d.min(0.5 * (lo + hi));
        let mut residual = f64::INFINITY;
        for _ in 0..FISHEYE_UNPROJECT_MAX_ITERATIONS {
            let (f, df) = self.distort_theta_with_derivative(theta);
            let e = f - theta_d;
            residual = e.abs();
            if residual <= FISHEYE_UNPROJECT_TOLERANCE {
                return Ok(theta);
            }
            if e > 0.0 {
                hi = theta;
            } else {
                lo = theta;
            }
            let newton = theta - e / df;
            theta = if df > 0.0 && newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
            if hi - lo <= f64::EPSILON * hi {
                break;
            }
        }
        let (f, _) = self.distort_theta_with_derivative(theta);
        if (f - theta_d).abs() <= FISHEYE_UNPROJECT_TOLERANCE {
            return Ok(theta);
        }
        Err(CameraModelError::UndistortionDidNotConverge {
            u: f64::NAN,
            v: f64::NAN,
            iterations: FISHEYE_UNPROJECT_MAX_ITERATIONS,
            residual,
        })
    }
}

/// First zero of `dθ_d/dθ = 1 + 3k1θ² + 5k2θ⁴ + 7k3θ⁶ + 9k4θ⁸` in `(0, π]`, or π.
fn fold_angle(k: &[f64; 4]) -> f64 {
    let d = |t2: f64| 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
    let end = PI * PI;
    const STEPS: usize = 4096;
    let mut prev = 0.0;
    for i in 1..=STEPS {
        let s = end * i as f64 / STEPS as f64;
        if d(s) <= 0.0 {
            let (mut lo, mut hi) = (prev, s);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if d(mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return lo.sqrt();
        }
        prev = s;
    }
    PI
}

/// The double sphere model (Usenko, Demmel, Cremers, "The Double Sphere Camera Model", 3DV 2018):
///
/// ```text
/// d1 = √(x² + y² + z²),   d2 = √(x² + y² + (ξ d1 + z)²)
/// (x', y') = (x, y) / (α d2 + (1 − α)(ξ d1 + z))     (then pixel = K (x', y', 1))
/// ```
///
/// with `ξ ∈ [−1, 1]`, `α ∈ [0, 1]`. Valid region (paper, eq. 43): `z > −w2 d1` with
/// `w1 = α/(1−α)` if `α ≤ ½` else `(1−α)/α`, `w2 = (w1 + ξ)/√(2 w1 ξ + ξ² + 1)`. Unprojection is
/// closed form (eq. 47–50), defined for `r² = x'² + y'² ≤ 1/(2α − 1)` when `α > ½`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DoubleSphereParameters", into = "DoubleSphereParameters")]
pub struct DoubleSphere {
    xi: f64,
    alpha: f64,
}

/// The serialised form of [`DoubleSphere`] (checked on deserialisation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DoubleSphereParameters {
    /// Distance between the two sphere centres (in units of the sphere radius), `ξ`.
    pub xi: f64,
    /// Weight of the second sphere against the pinhole, `α`.
    pub alpha: f64,
}

impl TryFrom<DoubleSphereParameters> for DoubleSphere {
    type Error = CameraModelError;
    fn try_from(p: DoubleSphereParameters) -> Result<Self> {
        Self::new(p.xi, p.alpha)
    }
}

impl From<DoubleSphere> for DoubleSphereParameters {
    fn from(m: DoubleSphere) -> Self {
        Self { xi: m.xi, alpha: m.alpha }
    }
}

impl DoubleSphere {
    /// A checked model: `ξ ∈ [−1, 1]`, `α ∈ [0, 1]` (both finite).
    pub fn new(xi: f64, alpha: f64) -> Result<Self> {
        if !(xi.is_finite() && (-1.0..=1.0).contains(&xi)) {
            return Err(CameraModelError::InvalidLens(format!("double sphere ξ must be in [-1, 1], got {xi}")));
        }
        if !(alpha.is_finite() && (0.0..=1.0).contains(&alpha)) {
            return Err(CameraModelError::InvalidLens(format!("double sphere α must be in [0, 1], got {alpha}")));
        }
        Ok(Self { xi, alpha })
    }

    /// `ξ`.
    pub fn xi(&self) -> f64 {
        self.xi
    }

    /// `α`.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// `w2` of the valid region `z > −w2 ‖p‖`.
    pub fn w2(&self) -> f64 {
        let a = self.alpha;
        let w1 = if a <= 0.5 { a / (1.0 - a) } else { (1.0 - a) / a };
        (w1 + self.xi) / (2.0 * w1 * self.xi + self.xi * self.xi + 1.0).sqrt()
    }

    /// The largest angle from the optical axis the model images, `acos(−w2)`.
    pub fn max_theta(&self) -> f64 {
        (-self.w2()).clamp(-1.0, 1.0).acos()
    }
}

/// The lens of a [`FisheyeCamera`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum FisheyeLens {
    /// Kannala–Brandt / OpenCV `fisheye` (4 parameters `k1..k4`).
    KannalaBrandt(KannalaBrandt),
    /// Double sphere (2 parameters `ξ, α`).
    DoubleSphere(DoubleSphere),
}

impl FisheyeLens {
    /// Number of lens parameters: 4 (KB) or 2 (DS).
    pub fn num_parameters(&self) -> usize {
        match self {
            Self::KannalaBrandt(_) => 4,
            Self::DoubleSphere(_) => 2,
        }
    }

    /// The parameters in the model's order: `(k1, k2, k3, k4)` or `(ξ, α)`.
    pub fn parameters(&self) -> Vec<f64> {
        match self {
            Self::KannalaBrandt(m) => m.k.to_vec(),
            Self::DoubleSphere(m) => vec![m.xi, m.alpha],
        }
    }

    /// The same kind of lens with new parameters (in [`Self::parameters`] order), checked.
    pub fn with_parameters(&self, p: &[f64]) -> Result<Self> {
        if p.len() != self.num_parameters() {
            return Err(CameraModelError::SizeMismatch(format!(
                "{} lens parameters for a model with {}",
                p.len(),
                self.num_parameters()
            )));
        }
        Ok(match self {
            Self::KannalaBrandt(_) => Self::KannalaBrandt(KannalaBrandt::new(p[0], p[1], p[2], p[3])?),
            Self::DoubleSphere(_) => Self::DoubleSphere(DoubleSphere::new(p[0], p[1])?),
        })
    }

    /// Largest angle from the optical axis that is imaged (exclusive).
    pub fn max_theta(&self) -> f64 {
        match self {
            Self::KannalaBrandt(m) => m.max_theta(),
            Self::DoubleSphere(m) => m.max_theta(),
        }
    }

    /// Normalised image point of a camera-frame direction, its 2x3 Jacobian with respect to the
    /// direction and its 2xN Jacobian with respect to the lens parameters.
    pub fn project_normalized(&self, p: DVec3) -> Result<NormalizedProjection> {
        if !p.is_finite() {
            return Err(CameraModelError::NonFinite { what: "point" });
        }
        let norm = p.length();
        if norm == 0.0 {
            return Err(CameraModelError::OutsideValidRegion {
                what: "point",
                detail: "it is the optical centre (no direction)".into(),
            });
        }
        match self {
            Self::KannalaBrandt(m) => kb_project(m, p, norm),
            Self::DoubleSphere(m) => ds_project(m, p, norm),
        }
    }

    /// The unit ray of a normalised image point (`K⁻¹` already applied).
    pub fn unproject_normalized(&self, m: DVec2) -> Result<DVec3> {
        if !m.is_finite() {
            return Err(CameraModelError::NonFinite { what: "pixel" });
        }
        match self {
            Self::KannalaBrandt(kb) => {
                let theta_d = m.length();
                let theta = kb.undistort_theta(theta_d)?;
                if theta_d == 0.0 {
                    return Ok(DVec3::Z);
                }
                let (s, c) = theta.sin_cos();
                Ok(DVec3::new(s * m.x / theta_d, s * m.y / theta_d, c))
            }
            Self::DoubleSphere(ds) => ds_unproject(ds, m),
        }
    }
}

/// A normalised image point, its 2x3 Jacobian with respect to the camera-frame point and its
/// Jacobian with respect to the lens parameters (first `num_parameters` columns used).
pub type NormalizedProjection = (DVec2, [[f64; 3]; 2], [[f64; 4]; 2]);

fn outside_fov(theta: f64, max: f64) -> CameraModelError {
    CameraModelError::OutsideValidRegion {
        what: "point",
        detail: format!(
            "{:.3}° from the optical axis, the lens model images up to {:.3}°",
            theta.to_degrees(),
            max.to_degrees()
        ),
    }
}

fn kb_project(m: &KannalaBrandt, p: DVec3, norm: f64) -> Result<NormalizedProjection> {
    let (x, y, z) = (p.x, p.y, p.z);
    let rho = x.hypot(y);
    let theta = rho.atan2(z);
    if theta >= m.theta_max {
        return Err(outside_fov(theta, m.theta_max));
    }
    let (theta_d, dtheta_d) = m.distort_theta_with_derivative(theta);
    if rho <= 1e-30 * norm {
        // On the axis (z > 0 here, as θ < π): the limits s → 1/z, ∂m/∂(x, y) → I/z.
        let iz = 1.0 / z;
        return Ok((DVec2::new(x * iz, y * iz), [[iz, 0.0, -x * iz * iz], [0.0, iz, -y * iz * iz]], [[0.0; 4]; 2]));
    }
    let s = theta_d / rho;
    let r2 = norm * norm;
    // ∂s/∂x = x·A, ∂s/∂y = y·A, ∂s/∂z = −θ_d'/R² (R = ‖p‖).
    let a = dtheta_d * z / (rho * rho * r2) - theta_d / (rho * rho * rho);
    let sz = -dtheta_d / r2;
    let d = [[s + x * x * a, x * y * a, x * sz], [x * y * a, s + y * y * a, y * sz]];
    let (ux, uy) = (x / rho, y / rho);
    let t2 = theta * theta;
    let pw = [theta * t2, theta * t2 * t2, theta * t2 * t2 * t2, theta * t2 * t2 * t2 * t2];
    let dl = [[ux * pw[0], ux * pw[1], ux * pw[2], ux * pw[3]], [uy * pw[0], uy * pw[1], uy * pw[2], uy * pw[3]]];
    Ok((DVec2::new(s * x, s * y), d, dl))
}

fn ds_project(m: &DoubleSphere, p: DVec3, d1: f64) -> Result<NormalizedProjection> {
    let (x, y, z) = (p.x, p.y, p.z);
    let (xi, alpha) = (m.xi, m.alpha);
    let w2 = m.w2();
    if z <= -w2 * d1 {
        return Err(outside_fov((z / d1).clamp(-1.0, 1.0).acos(), m.max_theta()));
    }
    let k = xi * d1 + z;
    let d2 = (x * x + y * y + k * k).sqrt();
    let den = alpha * d2 + (1.0 - alpha) * k;
    if den.is_nan() || den <= 0.0 {
        return Err(outside_fov((z / d1).clamp(-1.0, 1.0).acos(), m.max_theta()));
    }
    let mx = x / den;
    let my = y / den;
    // ∂d1/∂p = p/d1; ∂k/∂p = ξ p/d1 + e_z; ∂d2/∂p = (x + k ∂k/∂x, y + k ∂k/∂y, k ∂k/∂z)/d2.
    let dk = [xi * x / d1, xi * y / d1, xi * z / d1 + 1.0];
    let dd2 = [(x + k * dk[0]) / d2, (y + k * dk[1]) / d2, k * dk[2] / d2];
    let dden: [f64; 3] = std::array::from_fn(|i| alpha * dd2[i] + (1.0 - alpha) * dk[i]);
    let inv = 1.0 / den;
    let d = [
        [(1.0 - mx * dden[0]) * inv, -mx * dden[1] * inv, -mx * dden[2] * inv],
        [-my * dden[0] * inv, (1.0 - my * dden[1]) * inv, -my * dden[2] * inv],
    ];
    let dden_dxi = alpha * k * d1 / d2 + (1.0 - alpha) * d1;
    let dden_dalpha = d2 - k;
    let dl = [
        [-mx * dden_dxi * inv, -mx * dden_dalpha * inv, 0.0, 0.0],
        [-my * dden_dxi * inv, -my * dden_dalpha * inv, 0.0, 0.0],
    ];
    Ok((DVec2::new(mx, my), d, dl))
}

fn ds_unproject(m: &DoubleSphere, n: DVec2) -> Result<DVec3> {
    let (xi, alpha) = (m.xi, m.alpha);
    let r2 = n.length_squared();
    if alpha > 0.5 && r2 > 1.0 / (2.0 * alpha - 1.0) {
        return Err(CameraModelError::OutsideValidRegion {
            what: "pixel",
            detail: format!(
                "normalised radius² {r2:.6} exceeds the double sphere bound 1/(2α − 1) = {:.6}",
                1.0 / (2.0 * alpha - 1.0)
            ),
        });
    }
    let mz = (1.0 - alpha * alpha * r2) / (alpha * (1.0 - (2.0 * alpha - 1.0) * r2).max(0.0).sqrt() + 1.0 - alpha);
    let disc = mz * mz + (1.0 - xi * xi) * r2;
    if disc.is_nan() || disc < 0.0 || mz * mz + r2 == 0.0 {
        return Err(CameraModelError::OutsideValidRegion {
            what: "pixel",
            detail: format!("no ray of the double sphere (ξ = {xi}, α = {alpha}) maps to normalised radius² {r2:.6}"),
        });
    }
    let factor = (mz * xi + disc.sqrt()) / (mz * mz + r2);
    let ray = DVec3::new(factor * n.x, factor * n.y, factor * mz - xi);
    let len = ray.length();
    if !(len > 0.0 && ray.is_finite()) || ray.z <= -m.w2() * len {
        return Err(CameraModelError::OutsideValidRegion {
            what: "pixel",
            detail: format!("its ray lies outside the double sphere's valid region (normalised radius² {r2:.6})"),
        });
    }
    Ok(ray / len)
}

/// A wide-angle camera: pinhole intrinsics `K` (OpenCV fisheye's `K`, with `skew = K[0][1]`,
/// i.e. OpenCV's `alpha · fx`), a [`FisheyeLens`] and the image size. Fields are private and
/// checked by [`FisheyeCamera::new`] (and on deserialisation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "FisheyeCameraParameters", into = "FisheyeCameraParameters")]
pub struct FisheyeCamera {
    intrinsics: Intrinsics,
    lens: FisheyeLens,
    width: u32,
    height: u32,
}

/// The serialised form of [`FisheyeCamera`] (checked on deserialisation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FisheyeCameraParameters {
    /// Pinhole intrinsics.
    pub intrinsics: Intrinsics,
    /// Lens model.
    pub lens: FisheyeLens,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl TryFrom<FisheyeCameraParameters> for FisheyeCamera {
    type Error = CameraModelError;
    fn try_from(p: FisheyeCameraParameters) -> Result<Self> {
        Self::new(p.intrinsics, p.lens, p.width, p.height)
    }
}

impl From<FisheyeCamera> for FisheyeCameraParameters {
    fn from(c: FisheyeCamera) -> Self {
        Self { intrinsics: c.intrinsics, lens: c.lens, width: c.width, height: c.height }
    }
}

impl FisheyeCamera {
    /// A checked camera: finite intrinsics with positive focal lengths, non-zero image size.
    pub fn new(intrinsics: Intrinsics, lens: FisheyeLens, width: u32, height: u32) -> Result<Self> {
        intrinsics.validate()?;
        if width == 0 || height == 0 {
            return Err(CameraModelError::InvalidImageSize { width, height });
        }
        Ok(Self { intrinsics, lens, width, height })
    }

    /// A Kannala–Brandt camera from OpenCV fisheye's `K` (3x3) and `D` (4 values).
    pub fn from_opencv(k: DMat3, d: &[f64], width: u32, height: u32) -> Result<Self> {
        Self::new(
            Intrinsics::from_matrix(k)?,
            FisheyeLens::KannalaBrandt(KannalaBrandt::from_opencv(d)?),
            width,
            height,
        )
    }

    /// The pinhole part.
    pub fn intrinsics(&self) -> Intrinsics {
        self.intrinsics
    }

    /// The lens model.
    pub fn lens(&self) -> FisheyeLens {
        self.lens
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Projects a camera-frame point (any direction within the lens's field of view, also
    /// behind the image plane) to a pixel. Errors at the optical centre, on non-finite input and
    /// outside the valid region ([`FisheyeLens::max_theta`]).
    pub fn project(&self, point_camera: DVec3) -> Result<DVec2> {
        let (m, _, _) = self.lens.project_normalized(point_camera)?;
        Ok(self.intrinsics.to_pixel(m))
    }

    /// Projects a point of an object frame seen through `camera_from_object`.
    pub fn project_from(&self, camera_from_object: &Isometry3, point_object: DVec3) -> Result<DVec2> {
        self.project(camera_from_object.transform_point(point_object))
    }

    /// Projects with every analytic Jacobian (see [`CameraModel::project_with_jacobians`]);
    /// `d_distortion` holds `(k1, k2, k3, k4)` or `(ξ, α)` in its first columns.
    pub fn project_with_jacobians(
        &self,
        camera_from_object: &Isometry3,
        point_object: DVec3,
    ) -> Result<ProjectionJacobians> {
        let pc = camera_from_object.transform_point(point_object);
        let (m, dm, dl) = self.lens.project_normalized(pc)?;
        let k = &self.intrinsics;
        let pixel = k.to_pixel(m);
        let jk = [[k.fx, k.skew], [0.0, k.fy]];
        let mut d_pc = [[0.0; 3]; 2];
        for r in 0..2 {
            for c in 0..3 {
                d_pc[r][c] = jk[r][0] * dm[0][c] + jk[r][1] * dm[1][c];
            }
        }
        // the same chain rule to the point and the pose as the pinhole model
        let (d_point, d_pose) = crate::projection::point_and_pose_jacobians(&d_pc, camera_from_object, pc);
        let d_intrinsics = [[m.x, 0.0, 1.0, 0.0, m.y], [0.0, m.y, 0.0, 1.0, 0.0]];
        let mut d_distortion = [[0.0; 8]; 2];
        for r in 0..2 {
            for c in 0..4 {
                d_distortion[r][c] = jk[r][0] * dl[0][c] + jk[r][1] * dl[1][c];
            }
        }
        Ok(ProjectionJacobians { pixel, point_camera: pc, d_point, d_pose, d_intrinsics, d_distortion })
    }

    /// The unit ray imaged at `pixel` (it may point behind the image plane, `z < 0`). Errors
    /// where no ray of the valid region maps to the pixel; the Kannala–Brandt inversion stops
    /// at [`FISHEYE_UNPROJECT_TOLERANCE`].
    pub fn unproject(&self, pixel: DVec2) -> Result<DVec3> {
        if !pixel.is_finite() {
            return Err(CameraModelError::NonFinite { what: "pixel" });
        }
        self.lens.unproject_normalized(self.intrinsics.to_normalized(pixel)).map_err(|e| match e {
            CameraModelError::UndistortionDidNotConverge { iterations, residual, .. } => {
                CameraModelError::UndistortionDidNotConverge { u: pixel.x, v: pixel.y, iterations, residual }
            }
            CameraModelError::OutsideValidRegion { what, detail } => {
                CameraModelError::OutsideValidRegion { what, detail: format!("({}, {}): {detail}", pixel.x, pixel.y) }
            }
            other => other,
        })
    }

    /// Largest angle from the optical axis that is imaged (exclusive), radians.
    pub fn max_field_angle(&self) -> f64 {
        self.lens.max_theta()
    }

    /// True when the pixel lies inside the image (half a pixel of border on each side).
    pub fn contains(&self, pixel: DVec2) -> bool {
        pixel.x >= -0.5 && pixel.y >= -0.5 && pixel.x <= self.width as f64 - 0.5 && pixel.y <= self.height as f64 - 0.5
    }

    /// The same lens and size with other intrinsics (checked).
    pub fn with_intrinsics(&self, intrinsics: Intrinsics) -> Result<Self> {
        Self::new(intrinsics, self.lens, self.width, self.height)
    }

    /// The same intrinsics and size with another lens.
    pub fn with_lens(&self, lens: FisheyeLens) -> Self {
        Self { lens, ..*self }
    }
}

impl CameraModel for FisheyeCamera {
    fn intrinsics(&self) -> Intrinsics {
        self.intrinsics
    }
    fn width(&self) -> u32 {
        self.width
    }
    fn height(&self) -> u32 {
        self.height
    }
    fn validate(&self) -> Result<()> {
        Ok(())
    }
    fn project(&self, point_camera: DVec3) -> Result<DVec2> {
        FisheyeCamera::project(self, point_camera)
    }
    fn project_with_jacobians(
        &self,
        camera_from_object: &Isometry3,
        point_object: DVec3,
    ) -> Result<ProjectionJacobians> {
        FisheyeCamera::project_with_jacobians(self, camera_from_object, point_object)
    }
    fn unproject_ray(&self, pixel: DVec2) -> Result<DVec3> {
        FisheyeCamera::unproject(self, pixel)
    }
    fn max_field_angle(&self) -> f64 {
        self.lens.max_theta()
    }
    fn num_lens_parameters(&self) -> usize {
        self.lens.num_parameters()
    }
    fn contains(&self, pixel: DVec2) -> bool {
        FisheyeCamera::contains(self, pixel)
    }
}

/// Two wide-angle cameras and the pose of the right one relative to the left one (the
/// fisheye counterpart of [`crate::StereoRig`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FisheyeStereoRig {
    /// The left (reference) camera.
    pub left: FisheyeCamera,
    /// The right camera.
    pub right: FisheyeCamera,
    /// Maps points from the left camera frame to the right camera frame (OpenCV's `R`, `T`).
    pub right_from_left: Isometry3,
}

impl FisheyeStereoRig {
    /// A rig with a finite `right_from_left` (the cameras are valid by construction).
    pub fn new(left: FisheyeCamera, right: FisheyeCamera, right_from_left: Isometry3) -> Result<Self> {
        if !right_from_left.is_finite() {
            return Err(CameraModelError::NonFinite { what: "right_from_left" });
        }
        Ok(Self { left, right, right_from_left })
    }

    /// Distance between the optical centres.
    pub fn baseline(&self) -> f64 {
        self.right_from_left.translation.length()
    }

    /// Essential matrix `E = [t]× R` (`r_rᵀ E r_l = 0` for the rays of a match).
    pub fn essential(&self) -> DMat3 {
        crate::skew_symmetric(self.right_from_left.translation) * self.right_from_left.rotation_matrix()
    }
}
