//! A transform in the forms users paste elsewhere: translation, quaternion `(x, y, z, w)`,
//! row-major rotation matrix, rotation vector in radians, and ROS `tf` order.

use parallax_camera_model::Isometry3;
use serde::{Deserialize, Serialize};

use crate::linear::positive_quat;

/// One transform in every common convention (`a_from_b`: maps points of `b` into `a`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseConventions {
    /// Translation `[x, y, z]`, data unit.
    pub translation: [f64; 3],
    /// Unit quaternion `[x, y, z, w]` with `w ≥ 0` (ROS, Eigen's `coeffs()`, scipy's default).
    pub quaternion_xyzw: [f64; 4],
    /// Rotation matrix, row-major: `matrix[r][c]`.
    pub matrix_row_major: [[f64; 3]; 3],
    /// Rotation vector (axis × angle), radians — OpenCV's `rvec`, ViSP's `θu`.
    pub rotation_vector: [f64; 3],
}

impl PoseConventions {
    /// All forms of `t`.
    pub fn of(t: &Isometry3) -> Self {
        let q = positive_quat(t.rotation().normalize());
        let m = t.rotation_matrix();
        Self {
            translation: t.translation.to_array(),
            quaternion_xyzw: [q.x, q.y, q.z, q.w],
            matrix_row_major: std::array::from_fn(|r| std::array::from_fn(|c| m.col(c)[r])),
            rotation_vector: t.rvec().to_array(),
        }
    }

    /// ROS `tf` order, `x y z qx qy qz qw` (what `static_transform_publisher` takes), full precision.
    pub fn tf_line(&self) -> String {
        let [x, y, z] = self.translation;
        let [qx, qy, qz, qw] = self.quaternion_xyzw;
        format!("{x} {y} {z} {qx} {qy} {qz} {qw}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DVec3};

    #[test]
    fn every_form_describes_the_same_transform() {
        let t = Isometry3::from_rvec_tvec(DVec3::new(0.3, -1.2, 2.5), DVec3::new(0.057, -0.034, -0.042));
        let p = PoseConventions::of(&t);
        // Matrix rows against the transform of the basis vectors (columns of R).
        for c in 0..3 {
            let col = t.transform_vector(DVec3::AXES[c]);
            for r in 0..3 {
                assert!((p.matrix_row_major[r][c] - col[r]).abs() < 1e-15);
            }
        }
        // Rotation vector: axis × angle rebuilds the same matrix.
        let rv = DVec3::from_array(p.rotation_vector);
        let m = DMat3::from_axis_angle(rv.normalize(), rv.length());
        assert!((m - t.rotation_matrix()).abs().to_cols_array().iter().all(|v| *v < 1e-14));
        let [x, y, z, w] = p.quaternion_xyzw;
        assert!(w >= 0.0 && ((x * x + y * y + z * z + w * w) - 1.0).abs() < 1e-15);
        let line: Vec<f64> = p.tf_line().split(' ').map(|v| v.parse().unwrap()).collect();
        assert_eq!(line, vec![0.057, -0.034, -0.042, x, y, z, w]);
        // The angle is above π/2 in the quaternion's hemisphere convention check: 2 acos(w).
        assert!((2.0 * w.acos() - rv.length()).abs() < 1e-12);
    }
}
