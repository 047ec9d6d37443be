//! # corner-detection — calibration targets in images
//!
//! - [`harris_response`] / [`detect_corners`]: Harris or Shi–Tomasi corners (structure tensor
//!   from imageproc's Sobel gradients, Gaussian window, threshold, non-maximum suppression,
//!   top-N).
//! - [`refine_corners_subpix`] (gradient orthogonality, as OpenCV's `cornerSubPix`) and
//!   [`refine_saddle`] (saddle of a quadratic fitted to the smoothed image): sub-pixel corners
//!   whose window is chosen from the local corner spacing by default ([`WindowSize`]), so it
//!   never reaches a neighbouring corner.
//! - [`find_chessboard`]: the inner corners of a chessboard in OpenCV's order, or "not found",
//!   at any image size (a 2x2-averaged pyramid is searched coarsest first, so the pixel-scale
//!   settings follow the image; boards in 320x240 to 4000x3000 images are found with the
//!   defaults); [`ChessboardDetector`] keeps its buffers across a session's images.
//! - [`detect_blobs`]: blob targets (Otsu threshold, 8-connected components, shape filters,
//!   sub-pixel centroids); [`weighted_gray`] for colour input.
//! - [`detect_markers`]: ArUco / AprilTag markers of OpenCV's predefined dictionaries, decoded
//!   with error correction; [`detect_single_marker`] refines a lone tag's corners (hand-eye).
//! - [`detect_charuco`] (OpenCV's `CharucoBoard`), [`detect_aprilgrid`] (Kalibr's AprilGrid):
//!   any visible subset of corners, ids in OpenCV's / Kalibr's numbering, saddle-refined;
//!   ChArUco corners are predicted from the decoded markers, so boards printed with outlined
//!   black squares (no saddle beyond the frames) are found too, from the squares' edges.
//! - [`detect_circle_grid`]: symmetric and asymmetric circle grids in `findCirclesGrid`'s order,
//!   centres corrected for perspective bias.
//!
//! Accuracy on the synthetic acceptance sets and on the hard-print / hard-photo set (outlined
//! squares, glare, blur, JPEG, uneven light, …), side by side with OpenCV on the same images:
//! the crate's README and the repository's performance journal, `benches/RESULTS.md`.
//!
//! Pixel convention as OpenCV: `(u, v)`, `u` right, `v` down, `(0, 0)` the centre of the
//! top-left pixel.
//!
//! ```
//! use parallax_corner_detection::{find_chessboard, ChessboardConfig};
//! // A 7x5-square board (6x4 inner corners), 16 px squares, white margin around it.
//! let img = image::GrayImage::from_fn(170, 140, |x, y| {
//!     let (u, v) = (x as i32 - 25, y as i32 - 30);
//!     let on_board = (0..112).contains(&u) && (0..80).contains(&v);
//!     image::Luma([if on_board && (u / 16 + v / 16) % 2 == 0 { 25 } else { 230 }])
//! });
//! let grid = find_chessboard(&img, 6, 4, &ChessboardConfig::default())?.expect("found");
//! assert_eq!((grid.cols, grid.rows, grid.corners.len()), (6, 4, 24));
//! // Row-major, cols along a row: corner (col 1, row 0) is 16 px right of corner 0.
//! assert!((grid.at(1, 0) - grid.at(0, 0) - glam::DVec2::new(16.0, 0.0)).length() < 0.05);
//! # Ok::<(), parallax_corner_detection::CornerError>(())
//! ```

mod aprilgrid;
mod blobs;
mod charuco;
mod chessboard;
mod circles;
mod error;
mod harris;
mod imageops;
mod markers;
mod single_marker;
mod subpix;

pub(crate) use imageops::Isa;

// The crates whose types this crate's public API uses, re-exported so that a caller needs no
// version match with them (`parallax_x::glam::DVec3` is the `DVec3` this crate takes).
pub use glam;
pub use image;
pub use parallax_camera_model;
pub use parallax_least_squares;

pub use aprilgrid::{AprilGridConfig, AprilGridDetection, detect_aprilgrid};
pub use blobs::{
    BT601, Blob, BlobConfig, BlobDetection, BlobPolarity, LOCAL_MIN_CONTRAST, detect_blobs, weighted_gray,
};
pub use charuco::{CharucoConfig, CharucoDetection, detect_charuco};
pub use chessboard::{
    ChessboardConfig, ChessboardDetection, ChessboardDetector, CornerRefinement, chessboard_candidates,
    detect_chessboard, draw_chessboard, draw_points, draw_quads_mut, find_chessboard,
};
pub use circles::{CircleGridConfig, CircleGridDetection, detect_circle_grid};
pub use error::{CornerError, Result};
pub use harris::{Corner, CornerConfig, CornerMeasure, HarrisConfig, detect_corners, harris_response};
pub use imageops::{ImageF32, gaussian_blur, saddle_response, sample_bilinear, to_f32};
pub use markers::{DetectedMarker, MarkerConfig, detect_markers};
pub use single_marker::{detect_single_marker, refine_marker_corners};
pub use subpix::{Refinement, SaddleConfig, SubPixConfig, WindowSize, refine_corners_subpix, refine_saddle};
