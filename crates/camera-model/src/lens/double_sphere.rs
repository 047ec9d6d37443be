//! The double sphere model (Usenko, Demmel, Cremers 2018; Kalibr's `ds`).

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::{NormalizedProjection, outside_fov};
use crate::{CameraModelError, Result};

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

pub(super) fn project(m: &DoubleSphere, p: DVec3, d1: f64) -> Result<NormalizedProjection> {
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
        [-mx * dden_dxi * inv, -mx * dden_dalpha * inv, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-my * dden_dxi * inv, -my * dden_dalpha * inv, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ];
    Ok((DVec2::new(mx, my), d, dl))
}

pub(super) fn unproject(m: &DoubleSphere, n: DVec2) -> Result<DVec3> {
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
