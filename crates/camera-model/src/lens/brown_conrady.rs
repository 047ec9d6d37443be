//! Brown–Conrady distortion (OpenCV's `calibrateCamera` model).

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::NormalizedProjection;
use crate::{CameraModelError, Result};

/// Brown–Conrady lens distortion with OpenCV's coefficient order and formula:
///
/// ```text
/// r² = x² + y²
/// radial = (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)
/// x_d = x·radial + 2 p1 x y + p2 (r² + 2x²)
/// y_d = y·radial + p1 (r² + 2y²) + 2 p2 x y
/// ```
///
/// With `k4 = k5 = k6 = 0` (the default) this is OpenCV's 5-coefficient model; non-zero
/// `k4..k6` give its rational model (`CALIB_RATIONAL_MODEL`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Distortion {
    /// Radial r² coefficient.
    pub k1: f64,
    /// Radial r⁴ coefficient.
    pub k2: f64,
    /// Tangential coefficient 1.
    pub p1: f64,
    /// Tangential coefficient 2.
    pub p2: f64,
    /// Radial r⁶ coefficient.
    pub k3: f64,
    /// Rational denominator r² coefficient.
    #[serde(default)]
    pub k4: f64,
    /// Rational denominator r⁴ coefficient.
    #[serde(default)]
    pub k5: f64,
    /// Rational denominator r⁶ coefficient.
    #[serde(default)]
    pub k6: f64,
}

impl Distortion {
    /// Number of coefficients in [`Self::to_array`].
    pub const LEN: usize = 8;

    /// OpenCV's 5-coefficient model `(k1, k2, p1, p2, k3)`.
    pub fn new(k1: f64, k2: f64, p1: f64, p2: f64, k3: f64) -> Self {
        Self { k1, k2, p1, p2, k3, ..Self::default() }
    }

    /// From OpenCV's coefficient vector: 4, 5 or 8 values `(k1, k2, p1, p2[, k3[, k4, k5, k6]])`.
    pub fn from_opencv(coefficients: &[f64]) -> Result<Self> {
        let mut c = [0.0; 8];
        match coefficients.len() {
            4 | 5 | 8 => c[..coefficients.len()].copy_from_slice(coefficients),
            n => {
                return Err(CameraModelError::SizeMismatch(format!(
                    "distortion coefficients: expected 4, 5 or 8 values, got {n}"
                )));
            }
        }
        Ok(Self::from_array(c))
    }

    /// Coefficients in OpenCV's order `(k1, k2, p1, p2, k3, k4, k5, k6)`.
    pub fn to_array(&self) -> [f64; 8] {
        [self.k1, self.k2, self.p1, self.p2, self.k3, self.k4, self.k5, self.k6]
    }

    /// Inverse of [`Self::to_array`].
    pub fn from_array(c: [f64; 8]) -> Self {
        Self { k1: c[0], k2: c[1], p1: c[2], p2: c[3], k3: c[4], k4: c[5], k5: c[6], k6: c[7] }
    }

    /// True when all coefficients are zero.
    pub fn is_zero(&self) -> bool {
        self.to_array().iter().all(|&c| c == 0.0)
    }

    /// True when the rational terms `k4..k6` are used.
    pub fn is_rational(&self) -> bool {
        self.k4 != 0.0 || self.k5 != 0.0 || self.k6 != 0.0
    }

    /// Checks that every coefficient is finite.
    pub fn validate(&self) -> Result<()> {
        if self.to_array().iter().all(|c| c.is_finite()) {
            Ok(())
        } else {
            Err(CameraModelError::NonFinite { what: "distortion coefficient" })
        }
    }

    /// Radial factor and its derivative with respect to r².
    #[inline]
    pub(crate) fn radial(&self, r2: f64) -> (f64, f64) {
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        let n = 1.0 + self.k1 * r2 + self.k2 * r4 + self.k3 * r6;
        let d = 1.0 + self.k4 * r2 + self.k5 * r4 + self.k6 * r6;
        let dn = self.k1 + 2.0 * self.k2 * r2 + 3.0 * self.k3 * r4;
        let dd = self.k4 + 2.0 * self.k5 * r2 + 3.0 * self.k6 * r4;
        (n / d, (dn * d - n * dd) / (d * d))
    }

    /// Applies the distortion to undistorted normalised coordinates `(X/Z, Y/Z)`.
    #[inline]
    pub fn distort(&self, p: DVec2) -> DVec2 {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let (radial, _) = self.radial(r2);
        DVec2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Distortion and its 2x2 Jacobian `∂distorted/∂undistorted` (rows: x_d, y_d).
    #[inline]
    pub fn distort_with_jacobian(&self, p: DVec2) -> (DVec2, [[f64; 2]; 2]) {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let (r, dr) = self.radial(r2);
        let d = DVec2::new(
            x * r + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * r + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        );
        let j = [
            [
                r + 2.0 * x * x * dr + 2.0 * self.p1 * y + 6.0 * self.p2 * x,
                2.0 * x * y * dr + 2.0 * self.p1 * x + 2.0 * self.p2 * y,
            ],
            [
                2.0 * x * y * dr + 2.0 * self.p1 * x + 2.0 * self.p2 * y,
                r + 2.0 * y * y * dr + 6.0 * self.p1 * y + 2.0 * self.p2 * x,
            ],
        ];
        (d, j)
    }

    /// Jacobian of the distorted point with respect to the coefficients, in the order of
    /// [`Self::to_array`]: `[∂x_d/∂c; ∂y_d/∂c]`.
    pub fn jacobian_coefficients(&self, p: DVec2) -> [[f64; 8]; 2] {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        let n = 1.0 + self.k1 * r2 + self.k2 * r4 + self.k3 * r6;
        let d = 1.0 + self.k4 * r2 + self.k5 * r4 + self.k6 * r6;
        // ∂radial/∂(k1, k2, k3, k4, k5, k6)
        let dk = [r2 / d, r4 / d, r6 / d, -n * r2 / (d * d), -n * r4 / (d * d), -n * r6 / (d * d)];
        let xy2 = 2.0 * x * y;
        [
            [x * dk[0], x * dk[1], xy2, r2 + 2.0 * x * x, x * dk[2], x * dk[3], x * dk[4], x * dk[5]],
            [y * dk[0], y * dk[1], r2 + 2.0 * y * y, xy2, y * dk[2], y * dk[3], y * dk[4], y * dk[5]],
        ]
    }
}

/// Brown–Conrady: `n = (x/z, y/z)`, then OpenCV's distortion; points with `z ≤ 0` are refused.
pub(super) fn project(d: &Distortion, p: DVec3) -> Result<NormalizedProjection> {
    if p.z <= 0.0 {
        return Err(CameraModelError::PointBehindCamera { z: p.z });
    }
    let iz = 1.0 / p.z;
    let n = DVec2::new(p.x * iz, p.y * iz);
    let (nd, jd) = d.distort_with_jacobian(n);
    // ∂n/∂p = [[1/z, 0, −x/z²], [0, 1/z, −y/z²]]
    let jp = [[iz, 0.0, -n.x * iz], [0.0, iz, -n.y * iz]];
    let dm = std::array::from_fn(|r| std::array::from_fn(|c| jd[r][0] * jp[0][c] + jd[r][1] * jp[1][c]));
    Ok((nd, dm, d.jacobian_coefficients(n)))
}
