//! The composition layer of parallax: where the stage crates meet.
//!
//! * [`stages`]: one function per stage — [`detect_boards`], [`calibrate_mono`],
//!   [`calibrate_stereo`], [`rectify`], [`match_pair`], [`point_cloud`], [`measure`],
//!   [`board_poses`], [`hand_eye`], [`to_robot_frame`] — taking plain inputs and returning typed
//!   results.
//! * [`chain`]: the whole chain once ([`run_chain`]); a failing stage is recorded and every
//!   stage that does not depend on it still runs.
//! * [`scene`]: the synthetic run — render a scene with truth, run the chain, score each stage
//!   against the truth and the scene's tolerances ([`run_scene`]).
//! * [`real`]: the real run — the same chain on the user's images, scored by the checks that need
//!   no truth ([`run_real`], [`RealChecks`]).
//! * [`report`]: rows, verdict and the Markdown / HTML / RON report (self-contained HTML: every
//!   image inline); [`io`]: atomic output, RON, images, globs; [`stats`]: mean, RMS, median.
//! * Files, for programs that work on image folders as the `cargo xtask` commands do:
//!   [`session`] (a target found in image files, corners files, common image size, a stereo
//!   calibration's point-level checks), [`records`] (the RON / JSON result files of a mono,
//!   stereo or hand-eye calibration), [`disparity`] (pairs at their bit depth, ground truth,
//!   image sequences matched in a batch, depth through `Q`), [`poses`] (robot and camera pose
//!   files, intrinsics, camera poses from target images), [`measurement`] (pixel pairs given
//!   as text), [`images`] (rectified pairs at their pixel type, the side-by-side picture) and
//!   [`fixtures`] (the committed fixtures, written and checked).
//! * [`plots`]: the pictures of each stage — calibration residuals, per-view errors, coverage,
//!   board poses, projection uncertainty and distortion; the rectified pair; disparity with its
//!   colour bar and error image; hand-eye residuals and methods.
//!
//! The whole chain on the repository's five rendered stereo pairs (`fixtures/stereo`: a 9x6
//! board of 25 mm squares, a rig 60 mm wide):
//!
//! ```
//! use parallax_composition::{ChainInput, run_chain};
//! use parallax_camera_model::Chessboard;
//!
//! let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/stereo");
//! let load = |side: &str, i: usize| parallax_composition::io::load_gray(&dir.join(format!("{side}_{i:02}.png")));
//! let pairs = (0..5).map(|i| Ok([load("left", i)?, load("right", i)?])).collect::<parallax_composition::Result<_>>()?;
//! let out = run_chain(&ChainInput::new(Chessboard::new(9, 6, 25.0)?, pairs))?;
//! let c = out.calibration.as_ref().expect("the rig is calibrated");
//! println!("stereo RMS {:.3} px, baseline {:.2} mm", c.rms_px, c.rig.baseline());
//! assert!((c.rig.baseline() - 60.0).abs() < 0.5);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod artifacts;
pub mod chain;
pub mod disparity;
mod error;
pub mod fixtures;
pub mod fuzz_checks;
pub mod images;
pub mod io;
mod jpeg_scan;
pub mod measurement;
pub mod plots;
pub mod poses;
pub mod real;
pub mod records;
pub mod report;
pub mod scene;
pub mod session;
pub mod stages;
pub mod stats;
pub mod summary;
pub mod tune;

pub use chain::{ChainInput, ChainOutput, MatchPair, StageFailure, StageResult, Station, run_chain};
pub use error::{PipelineError, Result};
pub use real::{RealChecks, RealInputs, run_real};
pub use report::{Bound, Report, Row};
pub use scene::{Corruption, run_scene};
pub use stages::{
    MIN_VALID_RECTIFIED_FRACTION, RectifiedRig, StereoChecks, StereoViews, TargetSearch, adjacent_distances,
    board_poses, calibrate_mono, calibrate_stereo, check_stereo, detect_boards, detect_target, hand_eye, match_blobs,
    match_pair, measure, point_cloud, rectified_abs_dv, rectify, rectify_images, refuse_collapsed, search_target,
    target_pose, to_robot_frame,
};
