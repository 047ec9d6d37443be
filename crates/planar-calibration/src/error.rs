use parallax_camera_model::CameraModelError;
use parallax_least_squares::LeastSquaresError;
use thiserror::Error;

/// Everything that can go wrong in `planar-calibration`. Each variant names the offending input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CalibrationError {
    /// No views (or no points) were given.
    #[error("no {0} given")]
    Empty(&'static str),
    /// Fewer views than the requested model needs.
    #[error("{got} view(s) given, at least {needed} needed: {why}")]
    TooFewViews {
        /// Views given.
        got: usize,
        /// Views needed.
        needed: usize,
        /// What needs them.
        why: &'static str,
    },
    /// A view has fewer points than needed.
    #[error("{what}: {got} point(s), at least {needed} needed")]
    TooFewPoints {
        /// Which input (for example "view 3").
        what: String,
        /// Points given.
        got: usize,
        /// Points needed.
        needed: usize,
    },
    /// Sizes of inputs that must agree do not.
    #[error("size mismatch: {0}")]
    SizeMismatch(String),
    /// An input contains NaN or infinity.
    #[error("{0} contains a non-finite value")]
    NonFinite(String),
    /// A degenerate configuration (collinear points, parallel views, ...).
    #[error("degenerate input: {0}")]
    Degenerate(String),
    /// The object points of a planar method are not on the plane z = 0.
    #[error("{what}: object points must lie on the plane z = 0 (largest |z| = {max_abs_z})")]
    NotPlanar {
        /// Which input.
        what: String,
        /// Largest |z| found.
        max_abs_z: f64,
    },
    /// An invalid option or option combination.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    /// The closed-form or iterative estimate failed.
    #[error("estimation failed: {0}")]
    EstimationFailed(String),
    /// An error from `camera-model`.
    #[error(transparent)]
    Camera(#[from] CameraModelError),
    /// An error from `least-squares`.
    #[error(transparent)]
    Numerics(#[from] LeastSquaresError),
}

/// Result alias of this crate.
pub type Result<T, E = CalibrationError> = std::result::Result<T, E>;
