//! The lens models of a [`crate::Camera`], one file each: Brown–Conrady ([`Distortion`],
//! OpenCV's `calibrateCamera`), Kannala–Brandt (OpenCV's `cv::fisheye`, Kalibr's
//! `pinhole-equi`) and the double sphere model (Usenko, Demmel, Cremers 2018; Kalibr's `ds`),
//! each with analytic Jacobians, unprojection with a stated tolerance and an explicit valid
//! region. [`Lens`] is the one type the stages match on; [`LensModel`] names a model without its
//! parameters.

mod brown_conrady;
mod double_sphere;
mod kannala_brandt;

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{CameraModelError, Result};

pub use brown_conrady::Distortion;
pub use double_sphere::{DoubleSphere, DoubleSphereParameters};
pub use kannala_brandt::{
    FISHEYE_UNPROJECT_MAX_ITERATIONS, FISHEYE_UNPROJECT_TOLERANCE, KannalaBrandt, KannalaBrandtCoefficients,
};

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
            Self::DoubleSphere => {
                Lens::DoubleSphere(DoubleSphere::new(0.0, 0.5).expect("ξ = 0, α = ½ is in the domain"))
            }
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
            Self::KannalaBrandt(m) => m.coefficients().to_vec(),
            Self::DoubleSphere(m) => vec![m.xi(), m.alpha()],
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
        // The wide models take the point's direction: the optical centre has none.
        let norm = || match p.length() {
            0.0 => Err(CameraModelError::OutsideValidRegion {
                what: "point",
                detail: "it is the optical centre (no direction)".into(),
            }),
            n => Ok(n),
        };
        match self {
            Self::BrownConrady(d) => brown_conrady::project(d, p),
            Self::KannalaBrandt(m) => kannala_brandt::project(m, p, norm()?),
            Self::DoubleSphere(m) => double_sphere::project(m, p, norm()?),
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
            Self::KannalaBrandt(kb) => kannala_brandt::unproject(kb, m),
            Self::DoubleSphere(ds) => double_sphere::unproject(ds, m),
        }
    }
}

/// A normalised image point, its 2x3 Jacobian with respect to the camera-frame point and its
/// Jacobian with respect to the lens parameters (first `num_parameters` columns used).
pub type NormalizedProjection = (DVec2, [[f64; 3]; 2], [[f64; 8]; 2]);

/// The refusal of a direction beyond a lens's field of view.
pub(crate) fn outside_fov(theta: f64, max: f64) -> CameraModelError {
    CameraModelError::OutsideValidRegion {
        what: "point",
        detail: format!(
            "{:.3}° from the optical axis, the lens model images up to {:.3}°",
            theta.to_degrees(),
            max.to_degrees()
        ),
    }
}
