//! Observability: warnings (not errors) when the data determine `X` poorly.
//!
//! Two figures: the spread of the motions' rotation axes before solving (rotations about
//! nearly one axis leave the rotation about it, and the translation along it, weakly
//! determined), and the refined standard deviations after.

use std::fmt;

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

use crate::motion::Motion;

/// Thresholds of the weak-geometry warnings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ObservabilityConfig {
    /// Warn when the spread of the rotation axes ([`axis_spread_deg`]) is below this, degrees.
    pub min_axis_spread_deg: f64,
    /// Warn when a refined rotation standard deviation exceeds this, degrees.
    pub max_rotation_sigma_deg: f64,
    /// Warn when a refined translation standard deviation exceeds this fraction of the scene
    /// scale (the RMS translation of the input poses, [`crate::HandEyeSolution::length_scale`]):
    /// unit-free; 0.01 is 5 mm for poses half a metre away.
    pub max_translation_sigma_rel: f64,
    /// A solution whose rotation leaves the motions' axes (median angle) more than this many
    /// degrees plus three times the best common rotation's figure apart
    /// ([`crate::ConsistencyReport::axis_mismatch_deg`]) is refused
    /// as implausible: its solver failed on these data (Daniilidis and Li, which solve rotation
    /// and translation in one system, when the translations are noise). Correct synthetic sets
    /// with 0.3° / 5 mm noise measured at most 0.85° above that figure for those solvers, 2.45°
    /// for the Rodrigues-axis method.
    pub max_rotation_excess_deg: f64,
    /// Warn when the mean translation residual of the motions exceeds this fraction of the
    /// scene scale (the real 8-station session and its subsets measured at most 0.019; synthetic
    /// sets with 5 mm noise at most 0.045).
    pub warn_translation_fit_rel: f64,
    /// Refuse a solution whose mean translation residual of the motions exceeds this fraction of
    /// the scene scale: the translations fit no `X` (synthetic sets with 5 cm noise reached 0.42
    /// and a translation 0.07–0.31 m off; with 0.5 m noise 0.79–2.2 and every method 0.7–3 m off).
    pub max_translation_fit_rel: f64,
    /// A station whose implied board frame (`G_i X C_i`) is turned from the other stations' by
    /// a median angle above this factor times the median station's (and above
    /// [`crate::ConsistencyConfig::min_station_mismatch_deg`]) does not fit: refused as
    /// [`crate::Inconsistency::MismatchedStations`] unless `allow_rotation_mismatch`. 6000
    /// correct synthetic sets (4–15 stations, 0.1°–0.5° noise) measured at most 3.95× (99.9 %
    /// under 3.1×); the swapped pairs of a real 8-station session 16.8× or more, but for two
    /// that the motions' angles refuse before solving (1.0×, 1.2×).
    pub station_factor: f64,
    /// Return solutions that fail the two fit checks above (with a warning) — CLI `--allow-poor-fit`.
    pub allow_poor_fit: bool,
}

impl Default for ObservabilityConfig {
    fn default() -> Self {
        Self {
            min_axis_spread_deg: 10.0,
            max_rotation_sigma_deg: 0.5,
            max_translation_sigma_rel: 0.01,
            max_rotation_excess_deg: 2.0,
            warn_translation_fit_rel: 0.05,
            max_translation_fit_rel: 0.25,
            station_factor: 6.0,
            allow_poor_fit: false,
        }
    }
}

/// A warning attached to a solution: the result is returned, but it is weak.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum HandEyeWarning {
    /// The motions rotate about nearly one axis.
    WeakRotationAxes {
        /// Spread of the rotation axes ([`axis_spread_deg`]), degrees.
        spread_deg: f64,
        /// The configured threshold, degrees.
        threshold_deg: f64,
    },
    /// The refined rotation is uncertain.
    LargeRotationSigma {
        /// Largest standard deviation of the three rotation components, degrees.
        sigma_deg: f64,
        /// The configured threshold, degrees.
        threshold_deg: f64,
    },
    /// The refined translation is uncertain.
    LargeTranslationSigma {
        /// Largest standard deviation of the three translation components, data unit.
        sigma: f64,
        /// The threshold in the data unit (`max_translation_sigma_rel` × scene scale).
        threshold: f64,
    },
    /// Robot and camera lengths agree in unit but not exactly: a square size or focal length
    /// off by this factor (the translation of `X` absorbs it).
    ScaleDisagreement {
        /// Robot : camera ratio of the length invariants.
        ratio: f64,
        /// Their correlation.
        correlation: f64,
    },
    /// Robot and camera lengths differ by more than the unit limit, but by less than its
    /// uncertainty allows to decide: the motions carry too little translation signal for these
    /// stations' pose noise.
    ScaleUncertain {
        /// Robot : camera ratio of the length invariants.
        ratio: f64,
        /// Relative standard deviation of the ratio ([`crate::ConsistencyReport::scale_sigma`]).
        sigma: f64,
        /// The configured limit (`max_scale_ratio`).
        limit: f64,
    },
    /// The motions' translations fit the solution poorly (mean translation residual over the
    /// scene scale above `warn_translation_fit_rel`): noisy translations, or a poor fit let
    /// through with `allow_poor_fit`.
    PoorTranslationFit {
        /// Mean `|t(A X) − t(X B)|` over the scene scale.
        relative_residual: f64,
        /// The mean residual in the data unit.
        residual: f64,
    },
    /// The solution's rotation fits the motions' axes worse than the data allow (let through
    /// with `allow_poor_fit`).
    PoorRotationFit {
        /// Median axis misfit of the solution, degrees.
        misfit_deg: f64,
        /// The lower bound over every `X`, degrees.
        bound_deg: f64,
    },
    /// The length units of robot and camera could not be compared: the motions carry too little
    /// translation (rotations about nearly one point).
    ScaleUnchecked {
        /// Correlation of the robot and camera length invariants (below the configured minimum).
        correlation: f64,
    },
}

impl fmt::Display for HandEyeWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HandEyeWarning::WeakRotationAxes { spread_deg, threshold_deg } => write!(
                f,
                "weak geometry: the motions' rotation axes spread only {spread_deg:.2}° (< {threshold_deg}°); the \
                 rotation about their common axis and the translation along it are poorly determined — add \
                 stations that tilt the gripper about other axes"
            ),
            HandEyeWarning::LargeRotationSigma { sigma_deg, threshold_deg } => {
                write!(f, "weak geometry: refined rotation σ {sigma_deg:.3}° (> {threshold_deg}°)")
            }
            HandEyeWarning::LargeTranslationSigma { sigma, threshold } => {
                write!(f, "weak geometry: refined translation σ {sigma:.6} (> {threshold:.6}, data unit)")
            }
            HandEyeWarning::ScaleDisagreement { ratio, correlation } => write!(
                f,
                "robot and camera lengths differ by ×{ratio:.4} (screw invariants of the paired motions, correlation \
                 {correlation:.4}): check the board's square size, the camera's focal length and the robot's unit — \
                 the translation of the result absorbs such an error"
            ),
            HandEyeWarning::ScaleUncertain { ratio, sigma, limit } => write!(
                f,
                "weak geometry: robot and camera lengths differ by ×{ratio:.4} ± {:.1} % (1σ from the pose noise), \
                 beyond the ×{limit} unit limit but not by 3σ: these motions cannot tell a unit or square-size \
                 error from noise — add stations with larger translations along the rotation axes, and check the \
                 square size and the robot's unit",
                100.0 * sigma
            ),
            HandEyeWarning::PoorTranslationFit { relative_residual, residual } => write!(
                f,
                "the translations fit poorly: mean |t(AX) − t(XB)| {residual:.6} (data unit) is {:.1} % of the scene \
                 scale — noisy robot or camera positions; the translation of the result is uncertain by about as much",
                100.0 * relative_residual
            ),
            HandEyeWarning::PoorRotationFit { misfit_deg, bound_deg } => write!(
                f,
                "the rotation fits the motions' axes {misfit_deg:.2}° apart where the data allow {bound_deg:.2}°: this \
                 solver failed on these data — prefer another method"
            ),
            HandEyeWarning::ScaleUnchecked { correlation } => write!(
                f,
                "length units of robot and camera not checked: the motions rotate about nearly one point \
                 (invariant correlation {correlation:.3}); make sure both are in the same unit"
            ),
        }
    }
}

/// Spread of the rotation axes of the motions whose robot rotation is at least
/// `min_rotation_deg`, in degrees: with `λ₂` the second eigenvalue of the mean of `u uᵀ` over
/// the unit axes `u`, `2·asin(√λ₂)` — exactly the angle between the axes when there are two
/// directions equally often, 0 when all axes are parallel. `None` with fewer than two such
/// motions.
pub fn axis_spread_deg(motions: &[Motion], min_rotation_deg: f64) -> Option<f64> {
    let axes: Vec<DVec3> = motions
        .iter()
        .filter(|m| m.a.angle().to_degrees() >= min_rotation_deg)
        .map(|m| m.a.rvec().normalize())
        .collect();
    if axes.len() < 2 {
        return None;
    }
    let mut m = DMat3::ZERO;
    for u in &axes {
        m += DMat3::from_cols(*u * u.x, *u * u.y, *u * u.z);
    }
    m *= 1.0 / axes.len() as f64;
    let mut ev = symmetric_eigenvalues(m);
    ev.sort_by(|a, b| b.total_cmp(a));
    Some(2.0 * ev[1].clamp(0.0, 1.0).sqrt().asin().to_degrees())
}

/// Eigenvalues of a symmetric 3x3 matrix (closed form, trigonometric).
fn symmetric_eigenvalues(a: DMat3) -> [f64; 3] {
    let (a00, a11, a22) = (a.x_axis.x, a.y_axis.y, a.z_axis.z);
    let (a01, a02, a12) = (a.y_axis.x, a.z_axis.x, a.z_axis.y);
    let p1 = a01 * a01 + a02 * a02 + a12 * a12;
    if p1 <= 1e-30 {
        return [a00, a11, a22];
    }
    let q = (a00 + a11 + a22) / 3.0;
    let p2 = (a00 - q).powi(2) + (a11 - q).powi(2) + (a22 - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let b = (a - DMat3::from_diagonal(DVec3::splat(q))) * (1.0 / p);
    let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let e1 = q + 2.0 * p * phi.cos();
    let e3 = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    [e1, 3.0 * q - e1 - e3, e3]
}

#[cfg(test)]
mod tests {
    use super::*;
    use parallax_camera_model::Isometry3;

    #[test]
    fn eigenvalues_match_a_diagonalised_matrix() {
        let r = Isometry3::from_rvec_tvec(DVec3::new(0.3, -0.5, 0.8), DVec3::ZERO).rotation_matrix();
        let a = r * DMat3::from_diagonal(DVec3::new(3.0, -1.0, 0.5)) * r.transpose();
        let mut ev = symmetric_eigenvalues(a);
        ev.sort_by(f64::total_cmp);
        for (e, t) in ev.iter().zip([-1.0, 0.5, 3.0]) {
            assert!((e - t).abs() < 1e-12, "{ev:?}");
        }
    }

    #[test]
    fn spread_of_two_axes_is_their_angle() {
        let mk = |axis: DVec3| Motion {
            i: 0,
            j: 1,
            a: Isometry3::from_rvec_tvec(axis.normalize() * 0.5, DVec3::ZERO),
            b: Isometry3::IDENTITY,
        };
        let phi = 3f64.to_radians();
        let ms = [
            mk(DVec3::Z),
            mk(DVec3::new(phi.sin(), 0.0, phi.cos())),
            mk(-DVec3::Z),
            mk(DVec3::new(-phi.sin(), 0.0, -phi.cos())),
        ];
        assert!((axis_spread_deg(&ms, 1.0).unwrap() - 3.0).abs() < 1e-9);
        assert!(axis_spread_deg(&ms[..1], 1.0).is_none());
        assert!(axis_spread_deg(&[ms[0], ms[2]], 1.0).unwrap() < 1e-6);
    }
}
