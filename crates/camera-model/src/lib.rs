//! # camera-model — the shared vocabulary of parallax
//!
//! Cameras ([`Intrinsics`] and a [`Lens`] — Brown–Conrady [`Distortion`], [`KannalaBrandt`] or
//! [`DoubleSphere`] — in one [`Camera`] type), rigid transforms ([`Isometry3`],
//! named `a_from_b`), stereo rigs ([`StereoRig`]), calibration targets ([`Chessboard`],
//! [`CornerGrid`]) and the dense [`DisparityMap`] hand-off type. Projection follows OpenCV's
//! pinhole + Brown–Conrady model (and `cv::fisheye` for Kannala–Brandt) number for number, with
//! analytic Jacobians with respect to the point, the pose, the intrinsics and the lens
//! parameters.
//!
//! Conventions (as OpenCV): pixel `(u, v)` with `u` right and `v` down, `(0, 0)` the centre of
//! the top-left pixel; camera frame `x` right, `y` down, `z` forward. This crate has no pixel
//! loops and no I/O; every type is `f64` and derives `serde`.
//!
//! ```
//! use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3};
//! use glam::DVec3;
//!
//! let camera = Camera::new(
//!     Intrinsics::new(800.0, 800.0, 512.0, 384.0),
//!     Distortion::default(),
//!     1024,
//!     768,
//! )?;
//! let pixel = camera.project(DVec3::new(0.02, 0.05, 1.2))?;
//! assert!((pixel.x - 525.333_333).abs() < 1e-3 && (pixel.y - 417.333_333).abs() < 1e-3);
//!
//! // a_from_b names: the board seen from the camera, then a point of the board in the camera frame.
//! let camera_from_board = Isometry3::from_rvec_tvec(DVec3::new(0.1, -0.2, 0.05), DVec3::new(0.0, 0.0, 1.0));
//! let corner_in_camera = camera_from_board.transform_point(DVec3::new(0.03, 0.0, 0.0));
//! let back = camera.unproject(camera.project(corner_in_camera)?)?;
//! assert!((back - corner_in_camera / corner_in_camera.z).length() < 1e-12);
//! # Ok::<(), parallax_camera_model::CameraModelError>(())
//! ```

mod camera;
mod disparity;
mod error;
mod lens;
mod marker_dictionaries;
mod model;
mod projection;
mod stereo;
mod target;
mod targets;
mod transform;

pub use camera::{Camera, Intrinsics};
pub use disparity::DisparityMap;
pub use error::CameraModelError;
pub use lens::{
    Distortion, DoubleSphere, DoubleSphereParameters, FISHEYE_UNPROJECT_MAX_ITERATIONS, FISHEYE_UNPROJECT_TOLERANCE,
    KannalaBrandt, KannalaBrandtCoefficients, Lens, LensModel, NormalizedProjection,
};
pub use model::CameraModel;
pub use projection::{ProjectionJacobians, UNDISTORT_MAX_ITERATIONS, UNDISTORT_TOLERANCE};
pub use stereo::{ProjectionMatrix, StereoRig, skew_symmetric};
pub use target::{Chessboard, CornerGrid, MAX_TARGET_POINTS};
pub use targets::{
    ACCEPTED_FORMS, AprilGrid, CharucoBoard, CircleGrid, MarkerDictionary, SingleMarker, TargetDescription,
    TargetError, TargetObservation, dictionary_names,
};
pub use transform::Isometry3;

/// Result alias of this crate.
pub type Result<T, E = CameraModelError> = std::result::Result<T, E>;
