//! The lens models of a [`crate::Camera`]: Brown–Conrady ([`Distortion`], OpenCV's
//! `calibrateCamera`), Kannala–Brandt (OpenCV's `cv::fisheye`, Kalibr's `pinhole-equi`) and the
//! double sphere model (Usenko, Demmel, Cremers 2018; Kalibr's `ds`), each with analytic
//! Jacobians, unprojection with a stated tolerance and an explicit valid region. [`Lens`] is
//! the one type the stages match on; [`LensModel`] names a model without its parameters.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{CameraModelError, Distortion, Result};

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

/// A model of a camera's lens: what maps a camera-frame direction to normalised image
/// coordinates (before `K`). One camera type ([`crate::Camera`]) carries any of them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Lens {
    /// Brown–Conrady (OpenCV's `calibrateCamera`: `k1 k2 p1 p2 k3`, rational `k4 k5 k6`), for
    /// pinhole-like lenses; it images only points in front of the camera (`z > 0`).
    BrownConrady(Distortion),
    /// Kannala–Brandt / OpenCV `fisheye` (4 parameters `k1..k4`).
    KannalaBrandt(KannalaBrandt),
    /// Double sphere (2 parameters `ξ, α`).
    DoubleSphere(DoubleSphere),
}

impl Default for Lens {
    /// A distortion-free pinhole.
    fn default() -> Self {
        Self::BrownConrady(Distortion::default())
    }
}

impl From<Distortion> for Lens {
    fn from(d: Distortion) -> Self {
        Self::BrownConrady(d)
    }
}

impl From<KannalaBrandt> for Lens {
    fn from(m: KannalaBrandt) -> Self {
        Self::KannalaBrandt(m)
    }
}

impl From<DoubleSphere> for Lens {
    fn from(m: DoubleSphere) -> Self {
        Self::DoubleSphere(m)
    }
}

/// The name of a lens model, without its parameters: what a user chooses to calibrate
/// (`--lens pinhole|kannala-brandt|double-sphere`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum LensModel {
    /// Pinhole with Brown–Conrady distortion (OpenCV's `calibrateCamera`).
    #[default]
    BrownConrady,
    /// Kannala–Brandt (OpenCV's `cv::fisheye`).
    KannalaBrandt,
    /// Double sphere (Kalibr's `ds`).
    DoubleSphere,
}

impl LensModel {
    /// Every model, in the order of [`Self::NAMES`].
    pub const ALL: [LensModel; 3] = [Self::BrownConrady, Self::KannalaBrandt, Self::DoubleSphere];
    /// The command-line names: `pinhole`, `kannala-brandt`, `double-sphere`.
    pub const NAMES: [&'static str; 3] = ["pinhole", "kannala-brandt", "double-sphere"];

    /// The command-line name ([`Self::NAMES`]).
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// Number of lens parameters: 8 (`k1 k2 p1 p2 k3 k4 k5 k6`), 4 (`k1..k4`) or 2 (`ξ, α`).
    pub fn num_parameters(self) -> usize {
        match self {
            Self::BrownConrady => 8,
            Self::KannalaBrandt => 4,
            Self::DoubleSphere => 2,
        }
    }

    /// The names of the lens parameters in the model's order.
    pub fn parameter_names(self) -> &'static [&'static str] {
        match self {
            Self::BrownConrady => &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"],
            Self::KannalaBrandt => &["k1", "k2", "k3", "k4"],
            Self::DoubleSphere => &["xi", "alpha"],
        }
    }

    /// The lens of this model with its neutral parameters: no distortion, the equidistant
    /// Kannala–Brandt lens (`θ_d = θ`), or the double sphere `ξ = 0, α = ½` (stereographic).
    pub fn neutral(self) -> Lens {
        match self {
            Self::BrownConrady => Lens::BrownConrady(Distortion::default()),
            Self::KannalaBrandt => Lens::KannalaBrandt(KannalaBrandt::equidistant()),
            Self::DoubleSphere => Lens::DoubleSphere(DoubleSphere { xi: 0.0, alpha: 0.5 }),
        }
    }

    /// True for the wide-angle models (Kannala–Brandt, double sphere), which image directions
    /// at and beyond 90° from the optical axis.
    pub fn is_wide(self) -> bool {
        self != Self::BrownConrady
    }
}

impl std::fmt::Display for LensModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for LensModel {
    type Err = CameraModelError;
    fn from_str(s: &str) -> Result<Self> {
        Self::NAMES.iter().position(|n| *n == s).map(|i| Self::ALL[i]).ok_or_else(|| {
            CameraModelError::InvalidLens(format!(
                "unknown lens model `{s}`: expected one of {}",
                Self::NAMES.join(", ")
            ))
        })
    }
}

impl Lens {
    /// The model of this lens.
    pub fn model(&self) -> LensModel {
        match self {
            Self::BrownConrady(_) => LensModel::BrownConrady,
            Self::KannalaBrandt(_) => LensModel::KannalaBrandt,
            Self::DoubleSphere(_) => LensModel::DoubleSphere,
        }
    }

    /// Number of lens parameters: 8 (BC), 4 (KB) or 2 (DS).
    pub fn num_parameters(&self) -> usize {
        self.model().num_parameters()
    }

    /// The parameters in the model's order: `(k1, k2, p1, p2, k3, k4, k5, k6)`,
    /// `(k1, k2, k3, k4)` or `(ξ, α)`.
    pub fn parameters(&self) -> Vec<f64> {
        match self {
            Self::BrownConrady(d) => d.to_array().to_vec(),
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
            Self::BrownConrady(_) => {
                let d = Distortion::from_array(std::array::from_fn(|i| p[i]));
                d.validate()?;
                Self::BrownConrady(d)
            }
            Self::KannalaBrandt(_) => Self::KannalaBrandt(KannalaBrandt::new(p[0], p[1], p[2], p[3])?),
            Self::DoubleSphere(_) => Self::DoubleSphere(DoubleSphere::new(p[0], p[1])?),
        })
    }

    /// The Brown–Conrady coefficients, `None` for the wide-angle models.
    pub fn distortion(&self) -> Option<&Distortion> {
        match self {
            Self::BrownConrady(d) => Some(d),
            _ => None,
        }
    }

    /// Checks the parameters (the wide-angle models hold theirs by construction).
    pub fn validate(&self) -> Result<()> {
        match self {
            Self::BrownConrady(d) => d.validate(),
            _ => Ok(()),
        }
    }

    /// Largest angle from the optical axis that is imaged (exclusive): π/2 for Brown–Conrady.
    pub fn max_theta(&self) -> f64 {
        match self {
            Self::BrownConrady(_) => std::f64::consts::FRAC_PI_2,
            Self::KannalaBrandt(m) => m.max_theta(),
            Self::DoubleSphere(m) => m.max_theta(),
        }
    }

    /// Normalised image point of a camera-frame point, its 2x3 Jacobian with respect to the
    /// point and its Jacobian with respect to the lens parameters (model order, first
    /// [`Self::num_parameters`] columns).
    pub fn project_normalized(&self, p: DVec3) -> Result<NormalizedProjection> {
        if !p.is_finite() {
            return Err(CameraModelError::NonFinite { what: "point" });
        }
        if let Self::BrownConrady(d) = self {
            return bc_project(d, p);
        }
        let norm = p.length();
        if norm == 0.0 {
            return Err(CameraModelError::OutsideValidRegion {
                what: "point",
                detail: "it is the optical centre (no direction)".into(),
            });
        }
        match self {
            Self::BrownConrady(_) => unreachable!("handled above"),
            Self::KannalaBrandt(m) => kb_project(m, p, norm),
            Self::DoubleSphere(m) => ds_project(m, p, norm),
        }
    }

    /// A ray of a normalised image point (`K⁻¹` already applied): `(x, y, 1)` with the
    /// undistorted coordinates for Brown–Conrady (its error pixel is reported in normalised
    /// units), a unit ray for the wide-angle models.
    pub fn unproject_normalized(&self, m: DVec2) -> Result<DVec3> {
        if !m.is_finite() {
            return Err(CameraModelError::NonFinite { what: "pixel" });
        }
        match self {
            Self::BrownConrady(d) => {
                crate::projection::undistort(d, m).map(|n| n.extend(1.0)).map_err(|(iterations, residual)| {
                    CameraModelError::UndistortionDidNotConverge { u: m.x, v: m.y, iterations, residual }
                })
            }
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
pub type NormalizedProjection = (DVec2, [[f64; 3]; 2], [[f64; 8]; 2]);

/// Brown–Conrady: `n = (x/z, y/z)`, then OpenCV's distortion; points with `z ≤ 0` are refused.
fn bc_project(d: &Distortion, p: DVec3) -> Result<NormalizedProjection> {
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
        [-mx * dden_dxi * inv, -mx * dden_dalpha * inv, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-my * dden_dxi * inv, -my * dden_dalpha * inv, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
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
