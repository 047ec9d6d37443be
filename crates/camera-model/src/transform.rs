//! The one rigid-transform type of parallax.

use glam::{DMat3, DMat4, DQuat, DVec3, DVec4};
use serde::{Deserialize, Serialize};

use crate::{CameraModelError, Result};

/// A rigid transform (rotation + translation), named `a_from_b` where it is used: it maps a
/// point expressed in frame `b` to frame `a`: `p_a = R p_b + t`.
///
/// Composition reads like the names: `a_from_c = a_from_b * b_from_c`.
///
/// ```
/// use parallax_camera_model::Isometry3;
/// use glam::DVec3;
/// let base_from_gripper = Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.3, 0.0, 0.4));
/// let gripper_from_camera = Isometry3::from_rvec_tvec(DVec3::new(0.1, 0.0, 0.0), DVec3::new(0.0, 0.05, 0.1));
/// let base_from_camera = base_from_gripper * gripper_from_camera;
/// let p = DVec3::new(0.01, 0.02, 0.5);
/// let direct = base_from_gripper.transform_point(gripper_from_camera.transform_point(p));
/// assert!((base_from_camera.transform_point(p) - direct).length() < 1e-15);
/// ```
///
/// The rotation is always a unit quaternion: the field is private, every constructor
/// normalises or checks it, and a deserialised transform is checked (`serde(try_from)`): a
/// quaternion whose norm is off 1 by more than [`Isometry3::QUATERNION_NORM_TOLERANCE`] (a
/// mistake, not rounding) or a non-finite value is refused; within it, it is re-normalised.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "IsometryFields")]
pub struct Isometry3 {
    /// Rotation as a unit quaternion (serialised `(x, y, z, w)`).
    rotation: DQuat,
    /// Translation, in the length unit of the scene.
    pub translation: DVec3,
}

/// The serialised form of [`Isometry3`], checked on the way in.
#[derive(Deserialize)]
struct IsometryFields {
    rotation: DQuat,
    translation: DVec3,
}

impl TryFrom<IsometryFields> for Isometry3 {
    type Error = CameraModelError;
    fn try_from(f: IsometryFields) -> Result<Self> {
        Self::new(f.rotation, f.translation)
    }
}

impl Default for Isometry3 {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Isometry3 {
    /// The identity transform.
    pub const IDENTITY: Self = Self { rotation: DQuat::IDENTITY, translation: DVec3::ZERO };

    /// Largest deviation of a quaternion's norm from 1 that [`Isometry3::new`] and
    /// deserialisation accept as rounding (the quaternion is then re-normalised).
    pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

    /// From a unit quaternion and a translation, checked: errors when a value is not finite or
    /// the quaternion's norm is off 1 by more than [`Self::QUATERNION_NORM_TOLERANCE`] (e.g. a
    /// quaternion of norm 2 is a mistake, not a rotation); re-normalises within it.
    pub fn new(rotation: DQuat, translation: DVec3) -> Result<Self> {
        if !rotation.is_finite() {
            return Err(CameraModelError::NonFinite { what: "rotation quaternion" });
        }
        if !translation.is_finite() {
            return Err(CameraModelError::NonFinite { what: "translation" });
        }
        let norm = rotation.length();
        if (norm - 1.0).abs() > Self::QUATERNION_NORM_TOLERANCE {
            return Err(CameraModelError::NotAUnitQuaternion { norm });
        }
        // A quaternion that is unit to rounding is kept bit for bit (so a written transform reads
        // back exactly); any other is re-normalised.
        let rotation = if (norm - 1.0).abs() <= 4.0 * f64::EPSILON { rotation } else { rotation / norm };
        Ok(Self { rotation, translation })
    }

    /// From any non-zero quaternion and a translation: the quaternion is re-normalised,
    /// whatever its norm (use [`Self::new`] to refuse a quaternion that is not close to unit).
    pub fn from_quat_translation(rotation: DQuat, translation: DVec3) -> Self {
        Self { rotation: rotation.normalize(), translation }
    }

    /// The same rotation with another translation.
    #[inline]
    pub fn with_translation(&self, translation: DVec3) -> Self {
        Self { rotation: self.rotation, translation }
    }

    /// The rotation, a unit quaternion.
    #[inline]
    pub fn rotation(&self) -> DQuat {
        self.rotation
    }

    /// From a rotation matrix and a translation; errors unless `r` is a proper rotation to
    /// within 1e-6 (project a noisy matrix first with `parallax_least_squares::nearest_rotation`).
    pub fn from_rotation_translation(r: DMat3, translation: DVec3) -> Result<Self> {
        check_rotation(r, "rotation matrix")?;
        if !translation.is_finite() {
            return Err(CameraModelError::NonFinite { what: "translation" });
        }
        Ok(Self { rotation: DQuat::from_mat3(&r).normalize(), translation })
    }

    /// From OpenCV's `rvec` (axis × angle, radians; Rodrigues) and `tvec`.
    pub fn from_rvec_tvec(rvec: DVec3, tvec: DVec3) -> Self {
        Self { rotation: quat_from_rvec(rvec), translation: tvec }
    }

    /// [`Self::from_rvec_tvec`] for values read from outside, checked: errors naming the
    /// translation when `tvec` is not finite, and the rotation vector when it is not finite or
    /// its length overflows (components like `1e308` would give a NaN quaternion).
    pub fn try_from_rvec_tvec(rvec: DVec3, tvec: DVec3) -> Result<Self> {
        if !rvec.is_finite() {
            return Err(CameraModelError::NonFinite { what: "rotation vector" });
        }
        if !rvec.length().is_finite() {
            return Err(CameraModelError::NonFinite { what: "rotation vector length (components too large)" });
        }
        if !tvec.is_finite() {
            return Err(CameraModelError::NonFinite { what: "translation" });
        }
        Ok(Self::from_rvec_tvec(rvec, tvec))
    }

    /// From a 4x4 homogeneous matrix `[R t; 0 1]`.
    pub fn from_mat4(m: DMat4) -> Result<Self> {
        if !m.is_finite() {
            return Err(CameraModelError::NonFinite { what: "4x4 transform" });
        }
        if (m.row(3) - DVec4::new(0.0, 0.0, 0.0, 1.0)).abs().max_element() > 1e-9 {
            return Err(CameraModelError::NotARotation {
                what: "4x4 transform (last row is not 0 0 0 1)",
                error: 0.0,
                det: 0.0,
            });
        }
        let r = DMat3::from_cols(m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
        Self::from_rotation_translation(r, m.w_axis.truncate())
    }

    /// The 4x4 homogeneous matrix `[R t; 0 1]`.
    pub fn to_mat4(&self) -> DMat4 {
        DMat4::from_rotation_translation(self.rotation, self.translation)
    }

    /// The rotation matrix `R`.
    pub fn rotation_matrix(&self) -> DMat3 {
        DMat3::from_quat(self.rotation)
    }

    /// OpenCV's `rvec` (axis × angle, angle in `[0, π]`), accurate near 0 and near π.
    pub fn rvec(&self) -> DVec3 {
        rvec_from_quat(self.rotation)
    }

    /// Rotation angle in radians, in `[0, π]`.
    pub fn angle(&self) -> f64 {
        let q = self.rotation;
        2.0 * q.xyz().length().atan2(q.w.abs())
    }

    /// `p_a = R p_b + t`.
    #[inline]
    pub fn transform_point(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }

    /// Rotates a direction (no translation).
    #[inline]
    pub fn transform_vector(&self, v: DVec3) -> DVec3 {
        self.rotation * v
    }

    /// The inverse transform (`b_from_a` for an `a_from_b`).
    pub fn inverse(&self) -> Self {
        let r = self.rotation.inverse();
        Self { rotation: r, translation: -(r * self.translation) }
    }

    /// Applies a small perturbation on the left, `Exp(ω, v) ∘ self`:
    /// `R ← exp([ω]×) R`, `t ← exp([ω]×) t + v`. `delta = [ωx, ωy, ωz, vx, vy, vz]`. This is the
    /// pose parametrisation of the Jacobians in [`crate::ProjectionJacobians`].
    pub fn retract(&self, delta: &[f64; 6]) -> Self {
        let q = quat_from_rvec(DVec3::new(delta[0], delta[1], delta[2]));
        Self {
            rotation: (q * self.rotation).normalize(),
            translation: q * self.translation + DVec3::new(delta[3], delta[4], delta[5]),
        }
    }

    /// Rotation angle (radians) and translation distance between two transforms:
    /// the angle of `self⁻¹ ∘ other` and `|t_self − t_other|`.
    pub fn distance(&self, other: &Self) -> (f64, f64) {
        let rel = self.rotation.inverse() * other.rotation;
        let angle = 2.0 * rel.xyz().length().atan2(rel.w.abs());
        (angle, (self.translation - other.translation).length())
    }

    /// True when rotation and translation are finite.
    pub fn is_finite(&self) -> bool {
        self.rotation.is_finite() && self.translation.is_finite()
    }
}

impl std::ops::Mul for Isometry3 {
    type Output = Isometry3;
    /// `a_from_c = a_from_b * b_from_c`.
    fn mul(self, rhs: Isometry3) -> Isometry3 {
        Isometry3 {
            rotation: (self.rotation * rhs.rotation).normalize(),
            translation: self.rotation * rhs.translation + self.translation,
        }
    }
}

/// Unit quaternion of a rotation vector (exact for every angle).
pub(crate) fn quat_from_rvec(v: DVec3) -> DQuat {
    let angle = v.length();
    if angle == 0.0 {
        return DQuat::IDENTITY;
    }
    let half = 0.5 * angle;
    let s = half.sin() / angle;
    DQuat::from_xyzw(v.x * s, v.y * s, v.z * s, half.cos())
}

/// Rotation vector of a unit quaternion; `atan2` keeps full precision near 0 and near π.
pub(crate) fn rvec_from_quat(q: DQuat) -> DVec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let n = q.xyz().length();
    if n < 1e-8 {
        // angle = 2 atan2(n, w) = 2n/w (1 + O(n²)): relative error below 1e-16.
        return q.xyz() * (2.0 / q.w);
    }
    q.xyz() * (2.0 * n.atan2(q.w) / n)
}

fn check_rotation(r: DMat3, what: &'static str) -> Result<()> {
    if !r.is_finite() {
        return Err(CameraModelError::NonFinite { what });
    }
    let e = r.transpose() * r - DMat3::IDENTITY;
    let err = e.x_axis.abs().max_element().max(e.y_axis.abs().max_element()).max(e.z_axis.abs().max_element());
    let det = r.determinant();
    if err > 1e-6 || det <= 0.0 {
        return Err(CameraModelError::NotARotation { what, error: err, det });
    }
    Ok(())
}
