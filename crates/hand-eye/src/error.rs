use thiserror::Error;

/// Everything that can go wrong in `hand-eye`. Each variant names the offending input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum HandEyeError {
    /// Two lists that must pair up element by element have different lengths.
    #[error("size mismatch: {0}")]
    SizeMismatch(String),
    /// Too few stations (robot poses) or motions for the requested solver.
    #[error("not enough data: {0}")]
    NotEnoughData(String),
    /// An input pose is NaN or infinite.
    #[error("{what} {index} is not finite")]
    NonFinite {
        /// Which list (`base_from_gripper`, `camera_from_board`, …).
        what: &'static str,
        /// Index of the station in that list.
        index: usize,
    },
    /// The motions do not determine the transform: the message names the stations.
    #[error("degenerate motions: {0}")]
    Degenerate(String),
    /// A linear-algebra step failed (rank deficiency, no convergence).
    #[error("numerical failure in {solver}: {message}")]
    Numerical {
        /// Solver or step that failed.
        solver: &'static str,
        /// What failed.
        message: String,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    /// A pre-solve consistency check failed: the inputs contradict `A X = X B` whatever `X`
    /// is. The message names the likely mistake and the override.
    #[error("inconsistent inputs ({kind:?}): {message}")]
    Inconsistent {
        /// Which check failed.
        kind: crate::Inconsistency,
        /// Figures, likely mistake and override.
        message: String,
    },
    /// The solution fails a plausibility check (its rotation fits the motions far worse than
    /// the data allow, or the translations fit no transform). The message gives the figures.
    #[error("implausible {method} solution: {message}")]
    Implausible {
        /// The method whose solution was refused.
        method: &'static str,
        /// Figures, likely cause and override.
        message: String,
    },
    /// The refinement did not converge (and `refine.allow_unconverged` is not set).
    #[error("refinement did not converge: {0}")]
    NotConverged(String),
    /// A pose list could not be parsed; names the line (1-based) or entry.
    #[error("cannot parse {what}: {message}")]
    Parse {
        /// What was being parsed (file name or format).
        what: String,
        /// What was wrong, with the line number.
        message: String,
    },
}

impl HandEyeError {
    pub(crate) fn numerical(solver: &'static str, e: impl std::fmt::Display) -> Self {
        HandEyeError::Numerical { solver, message: e.to_string() }
    }
}
