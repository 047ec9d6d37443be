use thiserror::Error;

/// Everything that can go wrong in `block-matching`. Each variant names the offending input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BlockMatchingError {
    /// A configuration field is out of its documented range.
    #[error("invalid configuration: {field} = {value} ({reason})")]
    InvalidConfig {
        /// Name of the field.
        field: &'static str,
        /// The offending value, printed.
        value: String,
        /// What is allowed.
        reason: &'static str,
    },
    /// A flat list of values (a mask, scaled disparities, map data) has the wrong length for
    /// the image size it must cover.
    #[error("length mismatch: {what} has {got} values, expected {width}x{height} = {expected}")]
    LengthMismatch {
        /// Which input.
        what: &'static str,
        /// Width it must cover.
        width: usize,
        /// Height it must cover.
        height: usize,
        /// `width · height` (saturated).
        expected: usize,
        /// Number of values given.
        got: usize,
    },
    /// The two images of a pair (or a map and its ground truth / mask) differ in size.
    #[error("size mismatch: {what} is {got_width}x{got_height}, expected {width}x{height}")]
    SizeMismatch {
        /// Which input.
        what: &'static str,
        /// Expected width.
        width: usize,
        /// Expected height.
        height: usize,
        /// Actual width.
        got_width: usize,
        /// Actual height.
        got_height: usize,
    },
    /// An image has no pixels.
    #[error("{what} is empty ({width}x{height})")]
    EmptyImage {
        /// Which input.
        what: &'static str,
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
    },
    /// A file could not be parsed (e.g. a malformed PFM).
    #[error("cannot parse {what}: {reason}")]
    Parse {
        /// Which input.
        what: String,
        /// Why.
        reason: String,
    },
    /// The thread pool could not be built.
    #[error("cannot build a thread pool of {threads} threads: {reason}")]
    ThreadPool {
        /// Requested number of threads.
        threads: usize,
        /// The error of rayon.
        reason: String,
    },
    /// The source of a frame failed (e.g. an image could not be decoded).
    #[error("frame source: {0}")]
    Source(String),
    /// Nothing to evaluate (empty mask or no known ground truth).
    #[error("nothing to evaluate: {0}")]
    NothingToEvaluate(String),
}

/// Result alias of this crate.
pub type Result<T, E = BlockMatchingError> = std::result::Result<T, E>;
