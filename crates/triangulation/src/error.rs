use parallax_camera_model::CameraModelError;
use parallax_least_squares::LeastSquaresError;
use thiserror::Error;

/// Everything that can go wrong in `triangulation`. Each variant names the offending input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TriangulationError {
    /// Fewer views (or observations) than the method needs.
    #[error("{what}: need at least {needed}, got {got}")]
    TooFew {
        /// Which input.
        what: &'static str,
        /// Minimum count.
        needed: usize,
        /// Count given.
        got: usize,
    },
    /// Sizes of inputs that must agree do not.
    #[error("size mismatch: {0}")]
    SizeMismatch(String),
    /// An input value is NaN or infinite.
    #[error("{what} is not finite")]
    NonFinite {
        /// Which input (for example "pixel of view 1").
        what: String,
    },
    /// The rays of the observations are parallel (the point is at infinity): no finite point.
    #[error("rays are parallel (largest angle between them {angle_rad:e} rad): the point is at infinity")]
    ParallelRays {
        /// Largest angle between two viewing rays, radians.
        angle_rad: f64,
    },
    /// A linear system has no unique solution (rank-deficient design matrix).
    #[error("degenerate configuration: {0}")]
    Degenerate(String),
    /// A disparity that gives no finite point in front of the rig (zero, negative or NaN).
    #[error("disparity {disparity} at pixel ({u}, {v}) gives no point in front of the rig")]
    InvalidDisparity {
        /// Pixel column.
        u: f64,
        /// Pixel row.
        v: f64,
        /// The disparity, pixels.
        disparity: f64,
    },
    /// A configuration or geometry parameter is out of range.
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// The camera model rejected an input (undistortion failure, invalid camera, ...).
    #[error("camera model: {0}")]
    Camera(#[from] CameraModelError),
    /// The shared numerics failed.
    #[error("least squares: {0}")]
    LeastSquares(#[from] LeastSquaresError),
    /// Reading or writing a file failed.
    #[error("I/O on {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// Serialising a result failed.
    #[error("serialisation: {0}")]
    Serialization(String),
}

/// Result alias of this crate.
pub type Result<T, E = TriangulationError> = std::result::Result<T, E>;
