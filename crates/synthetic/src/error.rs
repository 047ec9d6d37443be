use thiserror::Error;

/// Everything that can go wrong in `synthetic`. Each variant names the offending input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SyntheticError {
    /// A camera, rig, board or pose from `camera-model` is invalid (or a projection failed).
    #[error("{what}: {source}")]
    Model {
        /// Which input.
        what: &'static str,
        /// The underlying camera-model error.
        source: parallax_camera_model::CameraModelError,
    },
    /// A configuration value is out of range (zero count, negative sigma, NaN, min > max…).
    #[error("invalid configuration `{field}`: {reason}")]
    InvalidConfig {
        /// The offending field.
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// A generator could not satisfy its constraints (e.g. the board cannot be fully visible
    /// at the requested distances).
    #[error("could not generate {what} after {attempts} attempts: {hint}")]
    Infeasible {
        /// What was being generated.
        what: String,
        /// Attempts spent.
        attempts: usize,
        /// Which constraint to relax.
        hint: String,
    },
    /// A RON scene description could not be parsed or is inconsistent.
    #[error("scene description: {0}")]
    Scene(String),
}

impl SyntheticError {
    pub(crate) fn config(field: &'static str, reason: impl Into<String>) -> Self {
        Self::InvalidConfig { field, reason: reason.into() }
    }

    pub(crate) fn model(what: &'static str) -> impl FnOnce(parallax_camera_model::CameraModelError) -> Self {
        move |source| Self::Model { what, source }
    }
}

/// Checks that a value is finite and `>= 0`.
pub(crate) fn non_negative(field: &'static str, v: f64) -> Result<(), SyntheticError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(SyntheticError::config(field, format!("must be finite and >= 0, got {v}")))
    }
}

/// Checks that a value is finite and `> 0`.
pub(crate) fn positive(field: &'static str, v: f64) -> Result<(), SyntheticError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(SyntheticError::config(field, format!("must be finite and > 0, got {v}")))
    }
}
