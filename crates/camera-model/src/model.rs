//! The projection interface of a camera: [`Camera`] with any [`crate::Lens`] implements it.
//! Stages that only project, unproject and differentiate can be generic over [`CameraModel`]
//! (and so take a user's own camera type too).

use glam::{DVec2, DVec3};

use crate::{Camera, Intrinsics, Isometry3, ProjectionJacobians, Result};

/// A calibrated camera: projection with analytic Jacobians, unprojection to a ray, and the
/// region of directions the model can image.
///
/// Conventions are OpenCV's (camera `x` right, `y` down, `z` forward; pixel `(0, 0)` the centre
/// of the top-left pixel). The lens parameters of [`ProjectionJacobians::d_distortion`] are the
/// model's own, in its order (see [`CameraModel::num_lens_parameters`]); unused columns are 0.
///
/// ```
/// use parallax_camera_model::{Camera, CameraModel, Intrinsics, KannalaBrandt};
/// use glam::DVec3;
///
/// fn ray_round_trip<C: CameraModel>(camera: &C, p: DVec3) -> f64 {
///     let ray = camera.unproject_ray(camera.project(p).unwrap()).unwrap();
///     (ray.normalize() - p.normalize()).length()
/// }
/// let lens = KannalaBrandt::new(0.02, -0.005, 0.001, -0.0002)?;
/// let fisheye = Camera::new(Intrinsics::new(300.0, 300.0, 511.5, 383.5), lens, 1024, 768)?;
/// // 100° from the optical axis: behind the image plane, still imaged by a 200° lens.
/// let p = DVec3::new(100f64.to_radians().sin(), 0.0, 100f64.to_radians().cos());
/// assert!(ray_round_trip(&fisheye, p) < 1e-12);
/// # Ok::<(), parallax_camera_model::CameraModelError>(())
/// ```
pub trait CameraModel {
    /// The pinhole part `K` (focal lengths, principal point, skew), pixels.
    fn intrinsics(&self) -> Intrinsics;
    /// Image width in pixels.
    fn width(&self) -> u32;
    /// Image height in pixels.
    fn height(&self) -> u32;
    /// Checks the model's invariants (types with private fields hold them by construction).
    fn validate(&self) -> Result<()>;
    /// Projects a point given in the camera frame to a pixel; errors outside the valid region.
    fn project(&self, point_camera: DVec3) -> Result<DVec2>;
    /// Projects a point of an object frame seen through `camera_from_object`.
    fn project_from(&self, camera_from_object: &Isometry3, point_object: DVec3) -> Result<DVec2> {
        self.project(camera_from_object.transform_point(point_object))
    }
    /// Projects `point_object` through `camera_from_object` with every analytic Jacobian:
    /// point, pose (the left perturbation of [`Isometry3::retract`]), intrinsics
    /// `(fx, fy, cx, cy, skew)` and the lens parameters in the model's order.
    fn project_with_jacobians(
        &self,
        camera_from_object: &Isometry3,
        point_object: DVec3,
    ) -> Result<ProjectionJacobians>;
    /// A direction (camera frame, positive scale, not necessarily unit length) of the ray imaged
    /// at `pixel`; errors where the model cannot be inverted.
    fn unproject_ray(&self, pixel: DVec2) -> Result<DVec3>;
    /// The largest angle (radians) between the optical axis and a direction the model projects;
    /// directions at or beyond it are refused.
    fn max_field_angle(&self) -> f64;
    /// True when the model projects this direction (camera frame).
    fn is_valid_direction(&self, direction: DVec3) -> bool {
        let r = direction.length();
        direction.is_finite() && r > 0.0 && (direction.z / r).clamp(-1.0, 1.0).acos() < self.max_field_angle()
    }
    /// Number of lens parameters (columns of `d_distortion` that are used).
    fn num_lens_parameters(&self) -> usize;
    /// True when the pixel lies inside the image (half a pixel of border on each side).
    fn contains(&self, pixel: DVec2) -> bool {
        pixel.x >= -0.5
            && pixel.y >= -0.5
            && pixel.x <= self.width() as f64 - 0.5
            && pixel.y <= self.height() as f64 - 0.5
    }
}

impl CameraModel for Camera {
    fn intrinsics(&self) -> Intrinsics {
        self.intrinsics
    }
    fn width(&self) -> u32 {
        self.width
    }
    fn height(&self) -> u32 {
        self.height
    }
    fn validate(&self) -> Result<()> {
        Camera::validate(self)
    }
    fn project(&self, point_camera: DVec3) -> Result<DVec2> {
        Camera::project(self, point_camera)
    }
    fn project_from(&self, camera_from_object: &Isometry3, point_object: DVec3) -> Result<DVec2> {
        Camera::project_from(self, camera_from_object, point_object)
    }
    fn project_with_jacobians(
        &self,
        camera_from_object: &Isometry3,
        point_object: DVec3,
    ) -> Result<ProjectionJacobians> {
        Camera::project_with_jacobians(self, camera_from_object, point_object)
    }
    /// [`Camera::unproject`]: `(x, y, 1)` for Brown–Conrady, a unit ray for a wide lens.
    fn unproject_ray(&self, pixel: DVec2) -> Result<DVec3> {
        Camera::unproject(self, pixel)
    }
    /// π/2 for Brown–Conrady (it images only points in front of it, `z > 0`), the lens's
    /// bound otherwise.
    fn max_field_angle(&self) -> f64 {
        self.lens.max_theta()
    }
    /// 8 `(k1, k2, p1, p2, k3, k4, k5, k6)`, 4 `(k1..k4)` or 2 `(ξ, α)`.
    fn num_lens_parameters(&self) -> usize {
        self.lens.num_parameters()
    }
    fn contains(&self, pixel: DVec2) -> bool {
        Camera::contains(self, pixel)
    }
}
