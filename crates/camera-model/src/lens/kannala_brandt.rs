//! The Kannala–Brandt model (OpenCV's `cv::fisheye`, Kalibr's `pinhole-equi`).

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::{NormalizedProjection, outside_fov};
use crate::{CameraModelError, Result};

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

/// The unit ray of a normalised image point: `θ` from `θ_d = |m|`, the direction of `m`.
pub(super) fn unproject(kb: &KannalaBrandt, m: DVec2) -> Result<DVec3> {
    let theta_d = m.length();
    let theta = kb.undistort_theta(theta_d)?;
    if theta_d == 0.0 {
        return Ok(DVec3::Z);
    }
    let (s, c) = theta.sin_cos();
    Ok(DVec3::new(s * m.x / theta_d, s * m.y / theta_d, c))
}

pub(super) fn project(m: &KannalaBrandt, p: DVec3, norm: f64) -> Result<NormalizedProjection> {
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
        return Ok((DVec2::new(x * iz, y * iz), [[iz, 0.0, -x * iz * iz], [0.0, iz, -y * iz * iz]], [[0.0; 8]; 2]));
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
    let dl = [
        [ux * pw[0], ux * pw[1], ux * pw[2], ux * pw[3], 0.0, 0.0, 0.0, 0.0],
        [uy * pw[0], uy * pw[1], uy * pw[2], uy * pw[3], 0.0, 0.0, 0.0, 0.0],
    ];
    Ok((DVec2::new(s * x, s * y), d, dl))
}
