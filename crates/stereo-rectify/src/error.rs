//! The error type of `stereo-rectify`.

use thiserror::Error;

/// Everything that can go wrong in `stereo-rectify`. Each variant names the offending input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RectifyError {
    /// A camera, rig or matrix is invalid (non-finite, non-positive focal length, zero size…).
    #[error("invalid {what}: {source}")]
    Camera {
        /// Which input.
        what: &'static str,
        /// The camera-model error.
        #[source]
        source: parallax_camera_model::CameraModelError,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// The two cameras of the rig share their optical centre (zero baseline).
    #[error("the rig has a zero or non-finite baseline (|t| = {0}); it cannot be rectified")]
    ZeroBaseline(f64),
    /// A computed quantity is not finite or degenerate (names the quantity).
    #[error("degenerate geometry: {0}")]
    Degenerate(String),
    /// Sizes that must agree do not (images vs maps, point lists).
    #[error("size mismatch: {0}")]
    SizeMismatch(String),
    /// An input list is empty.
    #[error("{0} is empty")]
    Empty(&'static str),
    /// A non-finite value in an input.
    #[error("{0} contains a non-finite value")]
    NonFinite(&'static str),
    /// A point could not be rectified (undistortion failed or it is behind the rectified camera).
    #[error("point {index} ({u}, {v}) of {what} cannot be rectified: {reason}")]
    Point {
        /// Which list.
        what: &'static str,
        /// Index in the list.
        index: usize,
        /// Pixel column.
        u: f64,
        /// Pixel row.
        v: f64,
        /// Why.
        reason: String,
    },
    /// Fewer inliers than needed for the uncalibrated rectification.
    #[error("uncalibrated rectification needs at least {needed} consistent matches, got {got}")]
    TooFewMatches {
        /// Minimum number of matches.
        needed: usize,
        /// Number left after the epipolar-distance threshold.
        got: usize,
    },
}

/// Result alias of this crate.
pub type Result<T, E = RectifyError> = std::result::Result<T, E>;
