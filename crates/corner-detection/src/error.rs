use thiserror::Error;

/// Everything that can go wrong in `corner-detection`. "No board in this image" is not an
/// error: [`crate::find_chessboard`] returns `Ok(None)` for it.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CornerError {
    /// The image has no pixels, or is smaller than the operation needs.
    #[error("image {width}x{height} is too small: {what} needs at least {min}x{min} pixels")]
    ImageTooSmall {
        /// Image width in pixels.
        width: u32,
        /// Image height in pixels.
        height: u32,
        /// Which operation.
        what: &'static str,
        /// Minimum side length in pixels.
        min: u32,
    },
    /// A configuration value is out of its valid range.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    /// The requested chessboard size is unusable (fewer than 2x2 inner corners).
    #[error("invalid chessboard size {cols}x{rows}: needs at least 2x2 inner corners")]
    InvalidBoardSize {
        /// Requested inner corners per row.
        cols: usize,
        /// Requested inner corners per column.
        rows: usize,
    },
    /// A corner to refine is not finite or lies outside the image.
    #[error("corner {index} at ({u}, {v}) is not finite or lies outside the {width}x{height} image")]
    CornerOutsideImage {
        /// Index of the corner in the input slice.
        index: usize,
        /// Column of the corner.
        u: f64,
        /// Row of the corner.
        v: f64,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
}

/// Result alias of this crate.
pub type Result<T, E = CornerError> = std::result::Result<T, E>;
