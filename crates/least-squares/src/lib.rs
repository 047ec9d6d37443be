//! # least-squares — the shared numerics of parallax, on faer
//!
//! * [`null_vector`]: the right singular vector of the smallest singular value (DLT problems:
//!   homographies, projection matrices, Zhang's `V b = 0`, Kronecker hand-eye), with the
//!   singular values so callers can judge the rank.
//! * [`solve_linear_least_squares`]: `min ‖A x − b‖` by QR.
//! * [`nearest_rotation`]: the rotation closest to a 3x3 matrix in the Frobenius norm (SVD
//!   with the determinant fix).
//! * [`levenberg_marquardt`]: a dense Levenberg–Marquardt solver over a user-supplied residual
//!   and Jacobian ([`Problem`]), returning the solution, costs, iterations, why it stopped and
//!   the parameter covariance `σ² (JᵀJ)⁻¹`.
//!
//! This crate knows nothing about cameras. No maintained crate offers Levenberg–Marquardt on
//! faer 0.24 without a second linear-algebra stack (see `../shared/reference/rust-deps.md`), so
//! the solver is written here; it is about 200 lines.
//!
//! ```
//! use parallax_least_squares::{levenberg_marquardt, LmConfig, Problem, EvaluationError};
//! use faer::MatMut;
//!
//! /// Fit y = a·exp(b·x) to exact samples.
//! struct ExpFit { x: Vec<f64>, y: Vec<f64> }
//! impl Problem for ExpFit {
//!     fn num_params(&self) -> usize { 2 }
//!     fn num_residuals(&self) -> usize { self.x.len() }
//!     fn evaluate(&self, p: &[f64], r: &mut [f64], j: Option<MatMut<'_, f64>>) -> Result<(), EvaluationError> {
//!         for (i, (&x, &y)) in self.x.iter().zip(&self.y).enumerate() { r[i] = p[0] * (p[1] * x).exp() - y; }
//!         if let Some(mut j) = j {
//!             for (i, &x) in self.x.iter().enumerate() {
//!                 j[(i, 0)] = (p[1] * x).exp();
//!                 j[(i, 1)] = p[0] * x * (p[1] * x).exp();
//!             }
//!         }
//!         Ok(())
//!     }
//! }
//! let x: Vec<f64> = (0..10).map(|i| i as f64 * 0.1).collect();
//! let y = x.iter().map(|x| 2.0 * (0.5 * x).exp()).collect();
//! let fit = levenberg_marquardt(&ExpFit { x, y }, &[1.0, 0.0], &LmConfig::default())?;
//! assert!((fit.params[0] - 2.0).abs() < 1e-9 && (fit.params[1] - 0.5).abs() < 1e-9);
//! # Ok::<(), parallax_least_squares::LeastSquaresError>(())
//! ```

mod linear;
mod lm;

pub use linear::{
    NullVector, dmat3_from_mat, mat_from_dmat3, nearest_rotation, null_vector, solve_linear_least_squares,
};
pub use lm::{
    EvaluationError, LmConfig, LmReport, Problem, StopReason, covariance_from_normal_equations, levenberg_marquardt,
};

use thiserror::Error;

/// Everything that can go wrong in `least-squares`.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LeastSquaresError {
    /// The input matrix or vector has no rows or no columns.
    #[error("{0} is empty")]
    Empty(&'static str),
    /// Shapes that must agree do not.
    #[error("shape mismatch: {0}")]
    ShapeMismatch(String),
    /// The input contains NaN or infinity.
    #[error("{0} contains a non-finite value")]
    NonFinite(&'static str),
    /// A factorisation did not converge or the system is singular.
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// The residual function could not be evaluated at the initial parameters.
    #[error("the problem cannot be evaluated at the initial parameters: {0}")]
    InitialEvaluation(String),
    /// Fewer residuals than parameters.
    #[error("underdetermined: {residuals} residuals for {params} parameters")]
    Underdetermined {
        /// Number of residuals.
        residuals: usize,
        /// Number of parameters.
        params: usize,
    },
}

/// Result alias of this crate.
pub type Result<T, E = LeastSquaresError> = std::result::Result<T, E>;
