//! The composition layer's error: a stage's error, or a file that could not be read or written.

use std::path::PathBuf;

/// Everything that can go wrong in the composition layer. Each variant names the input.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// Camera model (geometry, board, disparity map) rejected an input.
    #[error(transparent)]
    Camera(#[from] parallax_camera_model::CameraModelError),
    /// Corner detection rejected an input.
    #[error("corner detection: {0}")]
    Corners(#[from] parallax_corner_detection::CornerError),
    /// Calibration failed or rejected its input.
    #[error("calibration: {0}")]
    Calibration(#[from] parallax_planar_calibration::CalibrationError),
    /// Rectification failed or rejected its input.
    #[error("rectification: {0}")]
    Rectify(#[from] parallax_stereo_rectify::RectifyError),
    /// Block matching failed or rejected its input.
    #[error("block matching: {0}")]
    Matching(#[from] parallax_block_matching::BlockMatchingError),
    /// Triangulation failed or rejected its input.
    #[error("triangulation: {0}")]
    Triangulation(#[from] parallax_triangulation::TriangulationError),
    /// Hand-eye calibration failed or rejected its input.
    #[error("hand-eye: {0}")]
    HandEye(#[from] parallax_hand_eye::HandEyeError),
    /// A calibration or result file could not be read, written or converted.
    #[error(transparent)]
    Interop(#[from] parallax_interop::InteropError),
    /// Least squares rejected an input (a program's own call; the stages report theirs).
    #[error("least squares: {0}")]
    LeastSquares(#[from] parallax_least_squares::LeastSquaresError),
    /// An image could not be decoded or encoded in a program's own `image` call (files read
    /// through [`crate::io`] carry their path in [`Self::Image`]).
    #[error("image: {0}")]
    ImageData(#[from] image::ImageError),
    /// Rendering a synthetic scene failed.
    #[error("synthetic scene: {0}")]
    Synthetic(#[from] parallax_synthetic::SyntheticError),
    /// A file could not be read, written or renamed.
    #[error("{what} {}: {source}", path.display())]
    Io {
        /// What was being done (`reading`, `writing`, ...).
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// An image could not be decoded or encoded.
    #[error("image {}: {source}", path.display())]
    Image {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: image::ImageError,
    },
    /// A RON file could not be parsed or a value serialised.
    #[error("{}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the position when the parser gives one.
        message: String,
    },
    /// The inputs do not fit together (counts, sizes, a missing file).
    #[error("{0}")]
    Input(String),
    /// A frame of an image sequence looks swapped (left and right exchanged): the run stopped
    /// there and wrote nothing ([`crate::disparity::run_sequence`]).
    #[error(
        "frame {index} ({left} and {right}) looks swapped (left and right exchanged): {:.1} % of the pixels pass \
         the checks as given, {:.1} % with the images exchanged (half resolution); nothing was written",
        100.0 * check.forward_density,
        100.0 * check.reverse_density,
        left = left.display(),
        right = right.display()
    )]
    SwappedFrame {
        /// Position of the frame in the sequence (0-based).
        index: usize,
        /// Its left image.
        left: PathBuf,
        /// Its right image.
        right: PathBuf,
        /// What the check found.
        check: parallax_block_matching::SwapCheck,
    },
}

/// `Result` with [`PipelineError`].
pub type Result<T, E = PipelineError> = std::result::Result<T, E>;
