use faer::linalg::solvers::SolveLstsq;
use faer::{Col, ColRef, Mat, MatRef};
use glam::{DMat3, DVec3};

use crate::{LeastSquaresError, Result};

/// The null vector of a matrix and the evidence of its rank.
#[derive(Debug, Clone)]
pub struct NullVector {
    /// Unit vector `x` minimising `‖A x‖` (sign arbitrary).
    pub vector: Col<f64>,
    /// Singular values of `A`, non-increasing (length = number of columns; missing rows of a
    /// wide matrix count as zero singular values).
    pub singular_values: Vec<f64>,
}

impl NullVector {
    /// `σ_min / σ_second-smallest`: near 0 for a well-defined one-dimensional null space, near 1
    /// when the null space has two or more dimensions (a degenerate configuration).
    pub fn degeneracy_ratio(&self) -> f64 {
        let n = self.singular_values.len();
        if n < 2 {
            return 0.0;
        }
        let (a, b) = (self.singular_values[n - 1], self.singular_values[n - 2]);
        if b == 0.0 { 1.0 } else { a / b }
    }
}

fn check_finite(a: MatRef<'_, f64>, what: &'static str) -> Result<()> {
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            if !a[(i, j)].is_finite() {
                return Err(LeastSquaresError::NonFinite(what));
            }
        }
    }
    Ok(())
}

/// The unit vector minimising `‖A x‖`: the right singular vector of the smallest singular value
/// (thin SVD; a wide matrix is padded with zero rows so its null space is complete).
pub fn null_vector(a: MatRef<'_, f64>) -> Result<NullVector> {
    if a.nrows() == 0 || a.ncols() == 0 {
        return Err(LeastSquaresError::Empty("matrix"));
    }
    check_finite(a, "matrix")?;
    let n = a.ncols();
    let padded;
    let a = if a.nrows() < n {
        let mut p = Mat::<f64>::zeros(n, n);
        p.as_mut().submatrix_mut(0, 0, a.nrows(), n).copy_from(a);
        padded = p;
        padded.as_ref()
    } else {
        a
    };
    let svd = a.thin_svd().map_err(|e| LeastSquaresError::Numerical(format!("SVD: {e:?}")))?;
    let s = svd.S().column_vector();
    let singular_values: Vec<f64> = (0..n).map(|i| s[i]).collect();
    let vector = svd.V().col(n - 1).to_owned();
    Ok(NullVector { vector, singular_values })
}

/// Solves `min ‖A x − b‖₂` by Householder QR. Needs `rows ≥ cols` and full column rank
/// (a rank-deficient `A` is reported as [`LeastSquaresError::Numerical`]).
pub fn solve_linear_least_squares(a: MatRef<'_, f64>, b: ColRef<'_, f64>) -> Result<Col<f64>> {
    if a.nrows() == 0 || a.ncols() == 0 {
        return Err(LeastSquaresError::Empty("matrix"));
    }
    if a.nrows() != b.nrows() {
        return Err(LeastSquaresError::ShapeMismatch(format!("A has {} rows but b has {}", a.nrows(), b.nrows())));
    }
    if a.nrows() < a.ncols() {
        return Err(LeastSquaresError::Underdetermined { residuals: a.nrows(), params: a.ncols() });
    }
    check_finite(a, "matrix")?;
    if b.iter().any(|v| !v.is_finite()) {
        return Err(LeastSquaresError::NonFinite("right-hand side"));
    }
    let qr = a.qr();
    // Rank check on R's diagonal relative to its largest entry.
    let r = qr.R();
    let diag: Vec<f64> = (0..a.ncols()).map(|i| r[(i, i)].abs()).collect();
    let max = diag.iter().cloned().fold(0.0, f64::max);
    if max == 0.0 || diag.iter().any(|&d| d <= max * 1e-13) {
        return Err(LeastSquaresError::Numerical("matrix is rank deficient".into()));
    }
    Ok(qr.solve_lstsq(b))
}

/// glam (column-major) 3x3 to faer.
pub fn mat_from_dmat3(m: DMat3) -> Mat<f64> {
    Mat::from_fn(3, 3, |i, j| m.col(j)[i])
}

/// faer 3x3 to glam; the caller guarantees the shape (checked in debug builds).
pub fn dmat3_from_mat(m: MatRef<'_, f64>) -> DMat3 {
    debug_assert!(m.nrows() == 3 && m.ncols() == 3);
    DMat3::from_cols(
        DVec3::new(m[(0, 0)], m[(1, 0)], m[(2, 0)]),
        DVec3::new(m[(0, 1)], m[(1, 1)], m[(2, 1)]),
        DVec3::new(m[(0, 2)], m[(1, 2)], m[(2, 2)]),
    )
}

/// The rotation `R` minimising `‖R − M‖_F`: `U diag(1, 1, det(U Vᵀ)) Vᵀ` from the SVD of `M`.
pub fn nearest_rotation(m: DMat3) -> Result<DMat3> {
    if !m.is_finite() {
        return Err(LeastSquaresError::NonFinite("3x3 matrix"));
    }
    let a = mat_from_dmat3(m);
    let svd = a.svd().map_err(|e| LeastSquaresError::Numerical(format!("SVD: {e:?}")))?;
    let u = dmat3_from_mat(svd.U());
    let v = dmat3_from_mat(svd.V());
    let d = (u * v.transpose()).determinant().signum();
    let fix = DMat3::from_diagonal(DVec3::new(1.0, 1.0, d));
    Ok(u * fix * v.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn null_vector_of_rank_deficient_matrix() {
        // Rows orthogonal to x = (1, -2, 1)/√6.
        let a = faer::mat![[1.0, 1.0, 1.0], [2.0, 1.0, 0.0], [3.0, 2.0, 1.0], [0.0, 1.0, 2.0]];
        let nv = null_vector(a.as_ref()).unwrap();
        let x = &nv.vector;
        let s = x[0].signum();
        let expect = [1.0, -2.0, 1.0].map(|v: f64| v / 6f64.sqrt());
        for i in 0..3 {
            assert!((s * x[i] - expect[i]).abs() < 1e-12);
        }
        assert!(nv.degeneracy_ratio() < 1e-12);
    }

    #[test]
    fn null_vector_of_wide_matrix() {
        // 2x3: null space is the cross product of the rows.
        let a = faer::mat![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let nv = null_vector(a.as_ref()).unwrap();
        assert!((nv.vector[2].abs() - 1.0).abs() < 1e-12);
        // A 1x3 matrix has a two-dimensional null space: the ratio says so.
        let a = faer::mat![[1.0, 0.0, 0.0]];
        assert!((null_vector(a.as_ref()).unwrap().degeneracy_ratio() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn null_vector_rejects_bad_input() {
        let a = Mat::<f64>::zeros(0, 3);
        assert_eq!(null_vector(a.as_ref()).unwrap_err(), LeastSquaresError::Empty("matrix"));
        let a = faer::mat![[1.0, f64::NAN]];
        assert!(matches!(null_vector(a.as_ref()), Err(LeastSquaresError::NonFinite(_))));
    }

    #[test]
    fn linear_least_squares_line_fit() {
        // y = 2x + 1 sampled with residuals ±0.1 alternating: exact fit of the symmetric data.
        let xs = [0.0, 1.0, 2.0, 3.0];
        let ys = [1.1, 2.9, 5.1, 6.9];
        let a = Mat::from_fn(4, 2, |i, j| if j == 0 { xs[i] } else { 1.0 });
        let b = Col::from_fn(4, |i| ys[i]);
        let x = solve_linear_least_squares(a.as_ref(), b.as_ref()).unwrap();
        // Closed form: slope = Σ(x-x̄)(y-ȳ)/Σ(x-x̄)², x̄ = 1.5, ȳ = 4.0.
        let slope = ((-1.5) * (-2.9) + (-0.5) * (-1.1) + 0.5 * 1.1 + 1.5 * 2.9) / 5.0;
        assert!((x[0] - slope).abs() < 1e-12);
        assert!((x[1] - (4.0 - slope * 1.5)).abs() < 1e-12);
    }

    #[test]
    fn linear_least_squares_rejects_rank_deficiency_and_shapes() {
        let a = faer::mat![[1.0, 2.0], [2.0, 4.0], [3.0, 6.0]];
        let b = Col::from_fn(3, |i| i as f64);
        assert!(matches!(solve_linear_least_squares(a.as_ref(), b.as_ref()), Err(LeastSquaresError::Numerical(_))));
        let b2 = Col::from_fn(2, |i| i as f64);
        assert!(matches!(
            solve_linear_least_squares(a.as_ref(), b2.as_ref()),
            Err(LeastSquaresError::ShapeMismatch(_))
        ));
    }

    #[test]
    fn nearest_rotation_recovers_rotation_and_fixes_reflection() {
        let r = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let noisy = r + DMat3::from_cols_array(&[1e-3, -2e-3, 0.5e-3, 0.0, 1e-3, 0.0, -1e-3, 0.0, 2e-3]);
        let fixed = nearest_rotation(noisy).unwrap();
        let e = fixed.transpose() * fixed - DMat3::IDENTITY;
        assert!(e.abs().to_cols_array().iter().all(|v| *v < 1e-12));
        assert!((fixed.determinant() - 1.0).abs() < 1e-12);
        assert!((fixed - r).abs().to_cols_array().iter().all(|v| *v < 3e-3));
        // A reflection maps to a proper rotation.
        let reflection = DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0));
        assert!((nearest_rotation(reflection).unwrap().determinant() - 1.0).abs() < 1e-12);
        // Exact rotation is a fixed point.
        assert!((nearest_rotation(r).unwrap() - r).abs().to_cols_array().iter().all(|v| *v < 1e-14));
    }
}
