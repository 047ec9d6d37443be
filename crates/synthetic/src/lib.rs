//! # synthetic — scenes with exact ground truth
//!
//! Every parallax stage is judged against truth rendered here:
//!
//! - seeded noise helpers ([`rng`], [`add_pixel_noise`], [`perturb_pose`]);
//! - calibration view sets ([`calibration_poses`], [`stereo_calibration_poses`]) and the true
//!   corner positions ([`project_corners`], through `camera-model`'s projection);
//! - rendered chessboard views with exact anti-aliasing ([`render_chessboard`]) through any
//!   `CameraModel`: pinhole or fisheye (Kannala–Brandt, double sphere; fields of view beyond 180°);
//! - wide-angle view sets that cover a fisheye's periphery ([`wide_angle_calibration_poses`],
//!   [`wide_angle_stereo_calibration_poses`]) and a textured room rendered through any lens
//!   ([`TexturedRoom`], [`render_room`]) for wide-angle stereo;
//! - rendered chessboard views with exact anti-aliasing ([`render_chessboard`]), ChArUco
//!   views with per-corner truth, partial views and occluders ([`render_charuco`]), circle grids
//!   with exact disc coverage and the projected centres as truth ([`render_circle_grid`]), Kalibr
//!   AprilGrids ([`render_aprilgrid`]) and single markers ([`render_marker`]);
//! - rectified stereo pairs with exact disparity and occlusion masks ([`render_stereo_scene`]);
//! - 3D stereo worlds (planes at any slant, spheres, cylinders down to sub-pixel wires, height
//!   fields; 1/f, repetitive and uniform textures; camera gain, gamma, vignetting, noise, blur;
//!   grey or colour) ray-cast with the exact disparity and occlusion of both views
//!   ([`StereoWorld`], [`render_world`]), through a calibrated rig with its distortion
//!   ([`render_world_through`]) and with the truth of any rectification of it
//!   ([`world_truth_rectified`]); worlds drawn from a distribution ([`WorldDistribution`]);
//! - robot trajectories for hand-eye calibration ([`hand_eye_trajectory`]);
//! - scene descriptions in RON with the pipeline's tolerances ([`SceneDescription`]).
//!
//! Everything is deterministic for a given seed (ChaCha8).
//!
//! ```
//! use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics};
//! use parallax_synthetic::{ViewSetConfig, calibration_poses, project_corners};
//!
//! let camera = Camera::new(Intrinsics::new(800.0, 800.0, 319.5, 239.5), Distortion::new(-0.1, 0.05, 0.0, 0.0, 0.0), 640, 480)?;
//! let board = Chessboard::new(9, 6, 25.0)?; // millimetres
//! let poses = calibration_poses(&camera, &board, &ViewSetConfig { views: 4, ..Default::default() })?;
//! let corners = project_corners(&camera, &board, &poses[0])?;
//! assert_eq!(corners.len(), 54);
//! assert!(corners.iter().all(|c| camera.contains(*c)));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod noise;
mod render;
mod scene;
mod stereo;
mod targets;
mod trajectory;
mod views;
mod wide;
mod world;

// The crates whose types this crate's public API uses, re-exported so that a caller needs no
// version match with them (`parallax_x::glam::DVec3` is the `DVec3` this crate takes).
pub use glam;
pub use image;
pub use parallax_camera_model;
pub use parallax_least_squares;

pub use error::SyntheticError;
pub use noise::{add_pixel_noise, perturb_pose, rng};
pub use render::{Glare, MAX_KERNEL_PX, RenderOptions, RenderedView, render_chessboard};
pub use scene::{SceneDescription, Tolerances};
pub use stereo::{StereoScene, StereoSceneConfig, render_stereo_scene};
pub use targets::{Occluder, TargetView, render_aprilgrid, render_charuco, render_circle_grid, render_marker};
pub use trajectory::{HandEyeTruth, Trajectory, TrajectoryConfig, hand_eye_trajectory};
pub use views::{ViewSetConfig, calibration_poses, project_corners, stereo_calibration_poses};
pub use wide::{
    TexturedRoom, WideViewSetConfig, render_room, wide_angle_calibration_poses, wide_angle_stereo_calibration_poses,
};
pub use world::{
    ObjectKind, Pattern, Photometry, RectifiedPair, Shape, StereoWorld, Surface, Texture, Vec3, WorldDistribution,
    WorldViews, render_world, render_world_through, world_truth_rectified,
};
