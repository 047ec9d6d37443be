//! Projection of camera-frame points through the pinhole + distortion model, its analytic
//! Jacobians, and iterative undistortion.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{Camera, CameraModelError, Distortion, Isometry3, Result};

/// Convergence tolerance of [`Camera::undistort_normalized`]: the distorted estimate must
/// match the input to within this distance in normalised image coordinates (≈ `fx · 1e-12` px).
pub const UNDISTORT_TOLERANCE: f64 = 1e-12;
/// Iteration cap of [`Camera::undistort_normalized`].
pub const UNDISTORT_MAX_ITERATIONS: usize = 50;

/// A projected pixel and its Jacobians (each a 2-row matrix stored row-major, rows `u`, `v`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProjectionJacobians {
    /// The projected pixel.
    pub pixel: DVec2,
    /// The point in the camera frame.
    pub point_camera: DVec3,
    /// ∂pixel/∂(point in the object frame).
    pub d_point: [[f64; 3]; 2],
    /// ∂pixel/∂(ω, v): the pose perturbation of [`Isometry3::retract`]
    /// (`camera_from_object ← Exp(ω, v) ∘ camera_from_object`).
    pub d_pose: [[f64; 6]; 2],
    /// ∂pixel/∂(fx, fy, cx, cy, skew).
    pub d_intrinsics: [[f64; 5]; 2],
    /// ∂pixel/∂(k1, k2, p1, p2, k3, k4, k5, k6) for [`Camera`]; for a [`crate::FisheyeCamera`] the lens
    /// parameters `(k1, k2, k3, k4)` or `(ξ, α)` in the first columns, the rest 0.
    pub d_distortion: [[f64; 8]; 2],
}

/// A pixel's Jacobians with respect to the object point and to the pose perturbation of
/// [`Isometry3::retract`], from its Jacobian `d_pc` with respect to the camera-frame point `pc`
/// (every camera model): `∂pc/∂point = R`, `∂pc/∂ω = −[pc]×`, `∂pc/∂v = I`. Per row `g`:
/// `g R = Rᵀg` (the dot products with `R`'s columns) and `g (−[pc]×) = pc × g`.
pub(crate) fn point_and_pose_jacobians(
    d_pc: &[[f64; 3]; 2],
    camera_from_object: &Isometry3,
    pc: DVec3,
) -> ([[f64; 3]; 2], [[f64; 6]; 2]) {
    let rot = camera_from_object.rotation_matrix();
    let rows = d_pc.map(DVec3::from_array);
    let d_point = rows.map(|g| [rot.x_axis.dot(g), rot.y_axis.dot(g), rot.z_axis.dot(g)]);
    let d_pose = rows.map(|g| {
        let w = pc.cross(g);
        [w.x, w.y, w.z, g.x, g.y, g.z]
    });
    (d_point, d_pose)
}

impl Camera {
    /// Projects a point given in the camera frame to a pixel (OpenCV's `projectPoints`).
    ///
    /// Errors on a non-finite point or one with `z ≤ 0`.
    #[inline]
    pub fn project(&self, point_camera: DVec3) -> Result<DVec2> {
        check_point(point_camera)?;
        let n = DVec2::new(point_camera.x / point_camera.z, point_camera.y / point_camera.z);
        Ok(self.intrinsics.to_pixel(self.distortion.distort(n)))
    }

    /// Projects a point of an object frame seen through `camera_from_object`.
    #[inline]
    pub fn project_from(&self, camera_from_object: &Isometry3, point_object: DVec3) -> Result<DVec2> {
        self.project(camera_from_object.transform_point(point_object))
    }

    /// Projects `point_object` through `camera_from_object` and returns every Jacobian.
    pub fn project_with_jacobians(
        &self,
        camera_from_object: &Isometry3,
        point_object: DVec3,
    ) -> Result<ProjectionJacobians> {
        let pc = camera_from_object.transform_point(point_object);
        check_point(pc)?;
        let k = &self.intrinsics;
        let iz = 1.0 / pc.z;
        let n = DVec2::new(pc.x * iz, pc.y * iz);
        let (nd, jd) = self.distortion.distort_with_jacobian(n);
        let pixel = k.to_pixel(nd);
        // ∂pixel/∂nd = [[fx, skew], [0, fy]]
        let jk = [[k.fx, k.skew], [0.0, k.fy]];
        // ∂pixel/∂n = jk · jd
        let mut jn = [[0.0; 2]; 2];
        for r in 0..2 {
            for c in 0..2 {
                jn[r][c] = jk[r][0] * jd[0][c] + jk[r][1] * jd[1][c];
            }
        }
        // ∂n/∂pc = [[1/z, 0, -x/z²], [0, 1/z, -y/z²]]
        let jp = [[iz, 0.0, -n.x * iz], [0.0, iz, -n.y * iz]];
        let mut d_pc = [[0.0; 3]; 2];
        for r in 0..2 {
            for c in 0..3 {
                d_pc[r][c] = jn[r][0] * jp[0][c] + jn[r][1] * jp[1][c];
            }
        }
        let (d_point, d_pose) = point_and_pose_jacobians(&d_pc, camera_from_object, pc);
        let d_intrinsics = [[nd.x, 0.0, 1.0, 0.0, nd.y], [0.0, nd.y, 0.0, 1.0, 0.0]];
        let jc = self.distortion.jacobian_coefficients(n);
        let mut d_distortion = [[0.0; 8]; 2];
        for r in 0..2 {
            for c in 0..8 {
                d_distortion[r][c] = jk[r][0] * jc[0][c] + jk[r][1] * jc[1][c];
            }
        }
        Ok(ProjectionJacobians { pixel, point_camera: pc, d_point, d_pose, d_intrinsics, d_distortion })
    }

    /// Removes the distortion from normalised coordinates by Newton's method on the distortion
    /// model (started at the distorted point), stopping when the re-distorted estimate is within
    /// [`UNDISTORT_TOLERANCE`] of the input; [`CameraModelError::UndistortionDidNotConverge`]
    /// after [`UNDISTORT_MAX_ITERATIONS`] or when the only root found lies where the lens model
    /// folds back (non-positive Jacobian determinant): a point outside the invertible region. OpenCV's `undistortPoints` uses a fixed count of fixed-point iterations instead.
    pub fn undistort_normalized(&self, distorted: DVec2) -> Result<DVec2> {
        undistort(&self.distortion, distorted).map_err(|(iterations, residual)| {
            let pixel = self.intrinsics.to_pixel(distorted);
            CameraModelError::UndistortionDidNotConverge { u: pixel.x, v: pixel.y, iterations, residual }
        })
    }

    /// The undistorted normalised coordinates `(X/Z, Y/Z)` of a pixel: the ray through it is
    /// `(x, y, 1)`. Inverse of [`Self::project`] up to depth.
    pub fn unproject(&self, pixel: DVec2) -> Result<DVec3> {
        if !pixel.is_finite() {
            return Err(CameraModelError::NonFinite { what: "pixel" });
        }
        let n = self.undistort_normalized(self.intrinsics.to_normalized(pixel))?;
        Ok(n.extend(1.0))
    }

    /// The pixel an undistorted pinhole camera with the same `K` would see: removes the lens
    /// distortion from a pixel (OpenCV's `undistortPoints(..., P = K)`).
    pub fn undistort_pixel(&self, pixel: DVec2) -> Result<DVec2> {
        let ray = self.unproject(pixel)?;
        Ok(self.intrinsics.to_pixel(ray.truncate()))
    }
}

fn check_point(p: DVec3) -> Result<()> {
    if !p.is_finite() {
        return Err(CameraModelError::NonFinite { what: "point" });
    }
    if p.z <= 0.0 {
        return Err(CameraModelError::PointBehindCamera { z: p.z });
    }
    Ok(())
}

/// Newton iteration; on failure returns (iterations, residual).
fn undistort(d: &Distortion, target: DVec2) -> std::result::Result<DVec2, (usize, f64)> {
    if d.is_zero() {
        return Ok(target);
    }
    let mut p = target;
    let mut residual = f64::INFINITY;
    for _ in 0..UNDISTORT_MAX_ITERATIONS {
        let (f, j) = d.distort_with_jacobian(p);
        let e = f - target;
        residual = e.length();
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if residual <= UNDISTORT_TOLERANCE {
            // A root on the folded-back branch of the lens model (Jacobian not positive, or the
            // ray on the wrong side of the axis) is not the physical ray: report it.
            if det > 0.0 && p.dot(target) >= 0.0 {
                return Ok(p);
            }
            break;
        }
        if !det.is_finite() || det.abs() < 1e-300 {
            break;
        }
        let step = DVec2::new((j[1][1] * e.x - j[0][1] * e.y) / det, (-j[1][0] * e.x + j[0][0] * e.y) / det);
        p -= step;
        if !p.is_finite() {
            break;
        }
    }
    Err((UNDISTORT_MAX_ITERATIONS, residual))
}
