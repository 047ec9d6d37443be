//! Projection of camera-frame points through the pinhole + distortion model, its analytic
//! Jacobians, and iterative undistortion.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{Camera, CameraModelError, Distortion, Isometry3, Lens, Result};

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
    /// ∂pixel/∂(lens parameters) in the lens model's order: `(k1, k2, p1, p2, k3, k4, k5, k6)`
    /// for Brown–Conrady, `(k1, k2, k3, k4)` or `(ξ, α)` in the first columns for the wide
    /// lenses, the rest 0.
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
    /// Projects a point given in the camera frame to a pixel (OpenCV's `projectPoints`, or
    /// `fisheye::projectPoints` for Kannala–Brandt).
    ///
    /// Errors on a non-finite point, on one with `z ≤ 0` (Brown–Conrady) and outside a wide
    /// lens's valid region ([`Camera::max_field_angle`]; points behind the image plane are
    /// imaged by lenses wider than 180°).
    #[inline]
    pub fn project(&self, point_camera: DVec3) -> Result<DVec2> {
        if let Lens::BrownConrady(d) = &self.lens {
            check_point(point_camera)?;
            let n = DVec2::new(point_camera.x / point_camera.z, point_camera.y / point_camera.z);
            return Ok(self.intrinsics.to_pixel(d.distort(n)));
        }
        let (m, _, _) = self.lens.project_normalized(point_camera)?;
        Ok(self.intrinsics.to_pixel(m))
    }

    /// Projects a point of an object frame seen through `camera_from_object`.
    #[inline]
    pub fn project_from(&self, camera_from_object: &Isometry3, point_object: DVec3) -> Result<DVec2> {
        self.project(camera_from_object.transform_point(point_object))
    }

    /// Projects `point_object` through `camera_from_object` and returns every Jacobian: the
    /// lens's normalised projection and its Jacobians, then one chain rule through `K`, the
    /// point and the pose for every lens.
    pub fn project_with_jacobians(
        &self,
        camera_from_object: &Isometry3,
        point_object: DVec3,
    ) -> Result<ProjectionJacobians> {
        let pc = camera_from_object.transform_point(point_object);
        let (m, dm, dl) = self.lens.project_normalized(pc)?;
        let k = &self.intrinsics;
        let pixel = k.to_pixel(m);
        // ∂pixel/∂m = [[fx, skew], [0, fy]]
        let jk = [[k.fx, k.skew], [0.0, k.fy]];
        let d_pc: [[f64; 3]; 2] =
            std::array::from_fn(|r| std::array::from_fn(|c| jk[r][0] * dm[0][c] + jk[r][1] * dm[1][c]));
        let (d_point, d_pose) = point_and_pose_jacobians(&d_pc, camera_from_object, pc);
        let d_intrinsics = [[m.x, 0.0, 1.0, 0.0, m.y], [0.0, m.y, 0.0, 1.0, 0.0]];
        let d_distortion = std::array::from_fn(|r| std::array::from_fn(|c| jk[r][0] * dl[0][c] + jk[r][1] * dl[1][c]));
        Ok(ProjectionJacobians { pixel, point_camera: pc, d_point, d_pose, d_intrinsics, d_distortion })
    }

    /// Removes the lens from normalised coordinates: the `(X/Z, Y/Z)` of the ray through
    /// them. Brown–Conrady: Newton's method on the distortion model (started at the distorted
    /// point), stopping when the re-distorted estimate is within [`UNDISTORT_TOLERANCE`] of the
    /// input; [`CameraModelError::UndistortionDidNotConverge`] after [`UNDISTORT_MAX_ITERATIONS`]
    /// or when the only root found lies where the lens model folds back (non-positive Jacobian
    /// determinant): a point outside the invertible region. OpenCV's `undistortPoints` uses a
    /// fixed count of fixed-point iterations instead. Wide lenses: the ray of
    /// [`Camera::unproject`], refused when it does not point in front of the camera (`z ≤ 0`).
    pub fn undistort_normalized(&self, distorted: DVec2) -> Result<DVec2> {
        let pixel = || self.intrinsics.to_pixel(distorted);
        match &self.lens {
            Lens::BrownConrady(d) => undistort(d, distorted).map_err(|(iterations, residual)| {
                let pixel = pixel();
                CameraModelError::UndistortionDidNotConverge { u: pixel.x, v: pixel.y, iterations, residual }
            }),
            _ => {
                let ray = self.unproject(pixel())?;
                if ray.z <= 0.0 {
                    return Err(CameraModelError::PointBehindCamera { z: ray.z });
                }
                Ok(ray.truncate() / ray.z)
            }
        }
    }

    /// A ray through a pixel: `(x, y, 1)` with the undistorted normalised coordinates for
    /// Brown–Conrady (the inverse of [`Self::project`] up to depth), the unit ray for a wide
    /// lens (it may point behind the image plane, `z < 0`). Errors where no ray of the valid
    /// region maps to the pixel; the Kannala–Brandt inversion stops at
    /// [`crate::FISHEYE_UNPROJECT_TOLERANCE`].
    pub fn unproject(&self, pixel: DVec2) -> Result<DVec3> {
        if !pixel.is_finite() {
            return Err(CameraModelError::NonFinite { what: "pixel" });
        }
        let n = self.intrinsics.to_normalized(pixel);
        if let Lens::BrownConrady(_) = self.lens {
            return Ok(self.undistort_normalized(n)?.extend(1.0));
        }
        self.lens.unproject_normalized(n).map_err(|e| match e {
            CameraModelError::UndistortionDidNotConverge { iterations, residual, .. } => {
                CameraModelError::UndistortionDidNotConverge { u: pixel.x, v: pixel.y, iterations, residual }
            }
            CameraModelError::OutsideValidRegion { what, detail } => {
                CameraModelError::OutsideValidRegion { what, detail: format!("({}, {}): {detail}", pixel.x, pixel.y) }
            }
            other => other,
        })
    }

    /// The pixel an undistorted pinhole camera with the same `K` would see: removes the lens
    /// from a pixel (OpenCV's `undistortPoints(..., P = K)`).
    pub fn undistort_pixel(&self, pixel: DVec2) -> Result<DVec2> {
        let n = self.undistort_normalized(self.intrinsics.to_normalized(pixel))?;
        Ok(self.intrinsics.to_pixel(n))
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
pub(crate) fn undistort(d: &Distortion, target: DVec2) -> std::result::Result<DVec2, (usize, f64)> {
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
