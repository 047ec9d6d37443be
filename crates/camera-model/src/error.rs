use thiserror::Error;

/// Everything that can go wrong in `camera-model`. Each variant names the offending input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CameraModelError {
    /// A parameter or input value is NaN or infinite.
    #[error("{what} is not finite")]
    NonFinite {
        /// Which input.
        what: &'static str,
    },
    /// A focal length is zero, negative or not finite.
    #[error("focal length must be positive and finite (fx = {fx}, fy = {fy})")]
    InvalidFocalLength {
        /// Horizontal focal length in pixels.
        fx: f64,
        /// Vertical focal length in pixels.
        fy: f64,
    },
    /// Image width or height is zero.
    #[error("image size must be non-zero (got {width}x{height})")]
    InvalidImageSize {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// The point lies on or behind the camera's image plane (z ≤ 0), so it has no projection.
    #[error("point is behind the camera (z = {z})")]
    PointBehindCamera {
        /// Depth of the point in the camera frame.
        z: f64,
    },
    /// Iterative undistortion did not reach its tolerance (typically a pixel outside the
    /// region where the distortion model is invertible).
    #[error("undistortion of pixel ({u}, {v}) did not converge in {iterations} iterations (residual {residual:e})")]
    UndistortionDidNotConverge {
        /// Pixel column.
        u: f64,
        /// Pixel row.
        v: f64,
        /// Iterations spent.
        iterations: usize,
        /// Final residual in normalised image coordinates.
        residual: f64,
    },
    /// A 3x3 matrix is not a proper rotation (orthonormal with determinant +1).
    #[error("{what} is not a rotation matrix (orthonormality error {error:e}, det {det})")]
    NotARotation {
        /// Which input.
        what: &'static str,
        /// max |RᵀR − I|.
        error: f64,
        /// Determinant.
        det: f64,
    },
    /// A quaternion given as a rotation is not of unit norm (beyond rounding).
    #[error(
        "rotation quaternion has norm {norm}, not 1: not a rotation (check the component order x y z w and that no \
         value was scaled; a quaternion rounded to a few digits is accepted and re-normalised)"
    )]
    NotAUnitQuaternion {
        /// Its norm.
        norm: f64,
    },
    /// A chessboard description is unusable.
    #[error("invalid chessboard: {0}")]
    InvalidBoard(String),
    /// Sizes of inputs that must agree do not.
    #[error("size mismatch: {0}")]
    SizeMismatch(String),
    /// A point or pixel lies outside the region where a (wide-angle) lens model is defined and
    /// invertible: beyond its largest field angle, or a pixel no ray maps to.
    #[error("{what} is outside the lens model's valid region: {detail}")]
    OutsideValidRegion {
        /// Which input ("point", "pixel").
        what: &'static str,
        /// Why, with the numbers.
        detail: String,
    },
    /// Lens-model parameters are out of their domain (non-finite, `α ∉ [0, 1]`, `ξ ∉ [−1, 1]`).
    #[error("invalid lens parameters: {0}")]
    InvalidLens(String),
}
