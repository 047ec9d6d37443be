//! The one error type of the crate.

use std::path::PathBuf;

/// What went wrong reading or writing a calibration file. Every message names the file (or the
/// value) and, where one exists, the likely mistake.
#[derive(Debug, thiserror::Error)]
pub enum InteropError {
    /// The file could not be read.
    #[error("reading {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The text is not valid in the format it claims (or that was detected).
    #[error("{what}: {message}")]
    Syntax {
        /// The file or value.
        what: String,
        /// What the parser said.
        message: String,
    },
    /// The text parses but does not hold what was asked for, or holds inconsistent values.
    #[error("{what}: {message}")]
    Content {
        /// The file or value.
        what: String,
        /// What is missing or wrong, with a hint.
        message: String,
    },
    /// The format cannot express this result (e.g. a hand-eye transform as ROS `camera_info`).
    #[error("{0}")]
    Unsupported(String),
    /// A camera, rig or transform failed its own checks.
    #[error("{what}: {source}")]
    Model {
        /// The file or value.
        what: String,
        /// The camera model's error.
        source: parallax_camera_model::CameraModelError,
    },
}

/// `Result` with [`InteropError`].
pub type Result<T, E = InteropError> = std::result::Result<T, E>;

pub(crate) fn content(what: &str, message: impl Into<String>) -> InteropError {
    InteropError::Content { what: what.to_string(), message: message.into() }
}

pub(crate) fn syntax(what: &str, message: impl std::fmt::Display) -> InteropError {
    InteropError::Syntax { what: what.to_string(), message: message.to_string() }
}

pub(crate) fn model(what: &str) -> impl FnOnce(parallax_camera_model::CameraModelError) -> InteropError + '_ {
    move |source| InteropError::Model { what: what.to_string(), source }
}
