//! parallax: machine-vision measurement in Rust — the one crate to add.
//!
//! Each stage is its own crate, re-exported here under a module, with the `glam` and `image`
//! versions their APIs use ([`glam`], [`image`]): a program that depends on `parallax` alone
//! calls every stage, whatever other `glam` version its own dependency tree holds.
//!
//! | module | crate | what it does |
//! |---|---|---|
//! | [`camera`] | `parallax-camera-model` | cameras, distortion, `Isometry3` (`a_from_b`), rigs, boards, disparity maps |
//! | [`least_squares`] | `parallax-least-squares` | SVD null vectors, linear least squares, Levenberg–Marquardt |
//! | [`corners`] | `parallax-corner-detection` | chessboard corners in OpenCV's order, sub-pixel refinement |
//! | [`calibration`] | `parallax-planar-calibration` | Zhang's method, stereo calibration, PnP, DLT |
//! | [`rectify`] | `parallax-stereo-rectify` | Bouguet rectification, undistort/rectify maps, remap |
//! | [`matching`] | `parallax-block-matching` | dense disparity (SAD / SSD / NCC), Middlebury evaluation |
//! | [`triangulation`] | `parallax-triangulation` | 3D points, clouds, distances with σ, PLY |
//! | [`hand_eye`] | `parallax-hand-eye` | `AX = XB` (Tsai, Park, Horaud, Andreff, Daniilidis, refined) |
//! | [`synthetic`] | `parallax-synthetic` | rendered scenes with exact ground truth |
//! | [`pipeline`] | `parallax-composition` | one function per stage, the whole chain, reports |
//! | [`interop`] | `parallax-interop` | calibration files: OpenCV YAML/XML, ROS camera_info, Kalibr, JSON, RON |
//!
//! The whole path — detect → calibrate → undistort → save — on six rendered views of a 9x6
//! board with 25 mm squares (the fixture set `fixtures/mono` of the repository):
//!
//! ```
//! use parallax::prelude::*;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/mono");
//! let board = Chessboard::new(9, 6, 25.0)?; // inner corners, square size (the length unit)
//!
//! // Detect: one CornerGrid per image, in OpenCV's corner order.
//! let mut images = Vec::new();
//! let mut grids = Vec::new();
//! for i in 0..6 {
//!     let img = image::open(dir.join(format!("view_{i:02}.png")))?.into_luma8();
//!     let grid = find_chessboard(&img, board.cols, board.rows, &ChessboardConfig::default())?
//!         .ok_or("board not found")?;
//!     grids.push(grid);
//!     images.push(img);
//! }
//!
//! // Calibrate: Zhang's method with OpenCV's distortion model, with standard deviations.
//! let (w, h) = images[0].dimensions();
//! let result = calibrate_chessboard(&board, &grids, w, h, &CalibrationConfig::default())?;
//! let k = result.camera.intrinsics;
//! println!("fx {:.2} ± {:.2} px, RMS {:.3} px", k.fx, result.std_devs.fx.unwrap_or(f64::NAN), result.rms_px);
//! assert!(result.rms_px < 0.1);
//! assert!((k.fx / 600.0 - 1.0).abs() < 0.01); // the renders' true focal length is 600 px
//!
//! // Undistort: a map to the same camera matrix without distortion, then remap.
//! let map = parallax::rectify::init_undistort_map(&result.camera, result.camera.intrinsics.matrix(), w, h)?;
//! let undistorted = parallax::rectify::remap(&images[0], &map, Interpolation::Bilinear, Border::Constant(image::Luma([0u8])))?;
//!
//! // Save: the image and the calibration (RON, the native format; and as OpenCV FileStorage
//! // YAML, which `cv2.FileStorage` reads, through the interop module).
//! let out = std::env::temp_dir().join(format!("parallax-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&out)?;
//! undistorted.save(out.join("undistorted.png"))?;
//! parallax::pipeline::io::write_ron(&out.join("calibration.ron"), &result)?;
//! let mono = parallax::interop::MonoCalibration {
//!     camera: result.camera,
//!     rms_px: Some(result.rms_px),
//!     per_view_rms_px: result.per_view_rms_px.clone(),
//! };
//! let calibration = parallax::interop::Calibration::Mono(mono);
//! let yml = out.join("calibration.yml");
//! for (path, text) in parallax::interop::render(&calibration, parallax::interop::Format::OpenCvYaml, &yml)? {
//!     std::fs::write(path, text)?;
//! }
//! assert_eq!(parallax::interop::read(&[&yml])?.0, calibration);
//! # std::fs::remove_dir_all(&out)?;
//! # Ok(())
//! # }
//! ```

pub use glam;
pub use image;

pub use parallax_block_matching as matching;
pub use parallax_camera_model as camera;
pub use parallax_composition as pipeline;
pub use parallax_corner_detection as corners;
pub use parallax_hand_eye as hand_eye;
pub use parallax_interop as interop;
pub use parallax_least_squares as least_squares;
pub use parallax_planar_calibration as calibration;
pub use parallax_stereo_rectify as rectify;
pub use parallax_synthetic as synthetic;
pub use parallax_triangulation as triangulation;

/// The error of every stage, and of a program's own `image` calls: each stage's error converts
/// into it with `?` (it is the composition layer's `PipelineError`).
pub use parallax_composition::PipelineError as Error;

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The names most programs use: `use parallax::prelude::*;`.
pub mod prelude {
    pub use crate::{glam, image};
    pub use glam::{DMat3, DQuat, DVec2, DVec3};
    pub use parallax_block_matching::{BlockMatcher, CostFunction, MatcherConfig};
    pub use parallax_camera_model::{
        Camera, Chessboard, CornerGrid, DisparityMap, Distortion, Intrinsics, Isometry3, StereoRig,
    };
    pub use parallax_composition::{ChainInput, Report, run_chain};
    pub use parallax_corner_detection::{ChessboardConfig, find_chessboard};
    pub use parallax_hand_eye::{HandEyeConfig, HandEyeSolution, Method as HandEyeMethod, Setup};
    pub use parallax_planar_calibration::{
        CalibrationConfig, CalibrationResult, StereoCalibrationResult, StereoConfig, calibrate_chessboard,
        calibrate_stereo_chessboard,
    };
    pub use parallax_stereo_rectify::{Border, Interpolation, Rectification, Rectifier, RectifyConfig, stereo_rectify};
    pub use parallax_triangulation::{
        CloudConfig, ReprojectionMatrix, TriangulationConfig, disparity_to_point_cloud, measure_stereo,
        triangulate_stereo,
    };
}
