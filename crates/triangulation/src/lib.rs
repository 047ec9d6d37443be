//! # triangulation — metric 3D from calibrated views, point clouds and distances
//!
//! * Points from two or more calibrated [`View`]s ([`triangulate`], [`triangulate_stereo`]):
//!   the linear least-squares form `A X = B` ([`Method::Linear`], [`linear_from_projections`]),
//!   the homogeneous DLT by SVD ([`Method::Dlt`], [`dlt_from_projections`]), the midpoint of
//!   the common perpendicular ([`Method::Midpoint`], [`midpoint_from_rays`]) and the optimal
//!   method minimising the reprojection error through the full camera model with distortion
//!   ([`Method::Optimal`], the default). Every point carries its reprojection errors, parallax
//!   angle, behind-camera / low-parallax flags and its first-order covariance.
//! * Rectified rigs: the parallax formula ([`parallax_point`]), OpenCV's `Q` matrix
//!   ([`ReprojectionMatrix`]) and whole disparity maps to point clouds in parallel
//!   ([`disparity_to_point_cloud`]), invalid pixels skipped and counted.
//! * Uncertainty: [`depth_std_dev`] (`σ_Z = Z² σ_d / (f b)`), [`point_covariance`],
//!   distances with their standard deviation ([`distance`], [`adjacent_corner_distances`]).
//! * Files: PLY (ASCII / binary, optional colour), RON and CSV measurement lists, written
//!   atomically.
//!
//! Lengths are in the unit of the calibration (the board's square-size unit); the world frame
//! of a rig is its left camera frame.
//!
//! ```
//! use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
//! use glam::DVec3;
//! use parallax_triangulation::{Method, TriangulationConfig, triangulate_stereo};
//!
//! let cam = Camera::new(Intrinsics::new(800.0, 800.0, 640.0, 480.0), Distortion::default(), 1280, 960)?;
//! // Right camera 100 mm to the right of the left one.
//! let rig = StereoRig::new(cam, cam, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-100.0, 0.0, 0.0)))?;
//! let truth = DVec3::new(30.0, -20.0, 500.0);
//! let left = rig.left.project(truth)?;
//! let right = rig.right.project(rig.right_from_left.transform_point(truth))?;
//! let p = triangulate_stereo(&rig, left, right, &TriangulationConfig::default())?;
//! assert!((p.point - truth).length() < 1e-9);
//! // 0.1 px noise per coordinate → σ_Z = Z² σ_d / (f b) with σ_d = √2 · 0.1 px ≈ 0.44 mm.
//! let sz = p.std_devs().unwrap().z;
//! assert!((sz - 0.442).abs() < 0.01);
//! let lin = triangulate_stereo(&rig, left, right, &TriangulationConfig::with_method(Method::Linear))?;
//! assert!((lin.point - truth).length() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod distance;
mod error;
mod output;
mod point;
mod rectified;

// The crates whose types this crate's public API uses, re-exported so that a caller needs no
// version match with them (`parallax_x::glam::DVec3` is the `DVec3` this crate takes).
pub use glam;
pub use parallax_camera_model;
pub use parallax_least_squares;

pub use distance::{
    CornerDistance, Distance, MeasuredDistance, MeasuredPoint, Measurement, adjacent_corner_distances, distance,
    distance_rms, distance_with_joint_covariance, measure_stereo, point_distance,
};
pub use error::{Result, TriangulationError};
pub use output::{PlyFormat, ply_bytes, write_atomic, write_ply};
pub use point::{
    Method, TriangulatedPoint, TriangulationConfig, View, dlt_from_projections, linear_from_projections,
    midpoint_from_rays, point_covariance, stereo_views, triangulate, triangulate_stereo, triangulate_stereo_batch,
};
pub use rectified::{
    CloudConfig, PixelColors, PointCloud, PointColors, ReprojectionMatrix, depth_std_dev, disparity_to_point_cloud,
    parallax_covariance, parallax_point,
};
