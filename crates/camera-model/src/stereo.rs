//! Stereo rigs, projection matrices, essential and fundamental matrices.

use glam::{DMat3, DVec2, DVec3, DVec4};
use serde::{Deserialize, Serialize};

use crate::{Camera, Isometry3, Result};

/// The cross-product matrix `[v]×` (so `[v]× w = v × w`).
pub fn skew_symmetric(v: DVec3) -> DMat3 {
    DMat3::from_cols(DVec3::new(0.0, v.z, -v.y), DVec3::new(-v.z, 0.0, v.x), DVec3::new(v.y, -v.x, 0.0))
}

/// A 3x4 projection matrix `P = K [R | t]`, stored row-major (`rows[r][c]`), as OpenCV's `P1`/`P2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProjectionMatrix {
    /// Rows of `P`.
    pub rows: [[f64; 4]; 3],
}

impl ProjectionMatrix {
    /// `P = K [R | t]` of a camera with matrix `k` and pose `camera_from_world`.
    pub fn new(k: DMat3, camera_from_world: &Isometry3) -> Self {
        let r = camera_from_world.rotation_matrix();
        let t = camera_from_world.translation;
        let kr = k * r;
        let kt = k * t;
        let mut rows = [[0.0; 4]; 3];
        for i in 0..3 {
            for j in 0..3 {
                rows[i][j] = kr.col(j)[i];
            }
            rows[i][3] = kt[i];
        }
        Self { rows }
    }

    /// `P X` for a homogeneous point.
    pub fn apply(&self, x: DVec4) -> DVec3 {
        let r = |i: usize| DVec4::from_array(self.rows[i]).dot(x);
        DVec3::new(r(0), r(1), r(2))
    }

    /// The pixel of a Euclidean world point, `None` when it is at infinity or behind the camera
    /// (`w ≤ 0`).
    pub fn project(&self, x: DVec3) -> Option<DVec2> {
        let h = self.apply(x.extend(1.0));
        (h.z > 0.0 && h.is_finite()).then(|| DVec2::new(h.x / h.z, h.y / h.z))
    }

    /// The left 3x3 block `K R`.
    pub fn left_block(&self) -> DMat3 {
        DMat3::from_cols(
            DVec3::new(self.rows[0][0], self.rows[1][0], self.rows[2][0]),
            DVec3::new(self.rows[0][1], self.rows[1][1], self.rows[2][1]),
            DVec3::new(self.rows[0][2], self.rows[1][2], self.rows[2][2]),
        )
    }

    /// The last column `K t`.
    pub fn last_column(&self) -> DVec3 {
        DVec3::new(self.rows[0][3], self.rows[1][3], self.rows[2][3])
    }
}

/// Two calibrated cameras (any lenses) and the pose of the right one relative to the left one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StereoRig {
    /// The left (reference) camera; the rig's world frame is the left camera frame.
    pub left: Camera,
    /// The right camera.
    pub right: Camera,
    /// Maps points from the left camera frame to the right camera frame (OpenCV's `R`, `T`).
    pub right_from_left: Isometry3,
}

impl StereoRig {
    /// A validated rig.
    pub fn new(left: Camera, right: Camera, right_from_left: Isometry3) -> Result<Self> {
        left.validate()?;
        right.validate()?;
        if !right_from_left.is_finite() {
            return Err(crate::CameraModelError::NonFinite { what: "right_from_left" });
        }
        Ok(Self { left, right, right_from_left })
    }

    /// True when either camera has a wide lens (Kannala–Brandt, double sphere): the rig is then
    /// rectified by OpenCV's `fisheye::stereoRectify` rule and its later stages work on the
    /// rectified pair.
    pub fn has_wide_lens(&self) -> bool {
        self.left.lens_model().is_wide() || self.right.lens_model().is_wide()
    }

    /// Distance between the two optical centres, in the rig's length unit.
    pub fn baseline(&self) -> f64 {
        self.right_from_left.translation.length()
    }

    /// Essential matrix `E = [t]× R` with `r_rᵀ E r_l = 0` for the rays of a match (any lens).
    pub fn essential(&self) -> DMat3 {
        skew_symmetric(self.right_from_left.translation) * self.right_from_left.rotation_matrix()
    }

    /// Fundamental matrix `F = K_r⁻ᵀ E K_l⁻¹` with `p_rᵀ F p_l = 0` for undistorted pixels
    /// (pinhole pixels `K (x/z, y/z, 1)`; for a wide lens it relates only rays in front of both
    /// cameras), scaled as OpenCV's `stereoCalibrate` scales it: `F[2][2] = 1` (unscaled when
    /// that element is zero).
    pub fn fundamental(&self) -> DMat3 {
        let kl = self.left.intrinsics.matrix().inverse();
        let kr = self.right.intrinsics.matrix().inverse();
        let f = kr.transpose() * self.essential() * kl;
        if f.z_axis.z != 0.0 { f / f.z_axis.z } else { f }
    }

    /// Projection matrices `(K_l [I | 0], K_r [R | t])` of the unrectified rig (pinhole part only).
    pub fn projection_matrices(&self) -> (ProjectionMatrix, ProjectionMatrix) {
        (
            ProjectionMatrix::new(self.left.intrinsics.matrix(), &Isometry3::IDENTITY),
            ProjectionMatrix::new(self.right.intrinsics.matrix(), &self.right_from_left),
        )
    }
}
