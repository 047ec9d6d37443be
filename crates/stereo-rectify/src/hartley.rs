//! Uncalibrated rectification (Hartley), as OpenCV's `stereoRectifyUncalibrated`.

use glam::{DMat3, DVec2, DVec3};
use parallax_least_squares::{dmat3_from_mat, mat_from_dmat3, solve_linear_least_squares};
use serde::{Deserialize, Serialize};

use crate::bouguet::apply_homography;
use crate::{RectifyError, Result};

/// The result of [`stereo_rectify_uncalibrated`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UncalibratedRectification {
    /// Homography rectifying the first (left) image: `p1' ~ H1 p1`.
    pub h1: DMat3,
    /// Homography rectifying the second (right) image: `p2' ~ H2 p2`.
    pub h2: DMat3,
    /// Which matches passed the epipolar-distance threshold and were used.
    pub inliers: Vec<bool>,
    /// Mean `|v1' − v2'|` of the used matches after rectification, pixels (the quality).
    pub mean_abs_dv: f64,
    /// Largest `|v1' − v2'|` of the used matches after rectification, pixels.
    pub max_abs_dv: f64,
}

/// Hartley's rectification from a fundamental matrix `f` (`p2ᵀ F p1 = 0`, undistorted pixels)
/// and point matches, following `cv::stereoRectifyUncalibrated` step by step: `F` is projected
/// to rank 2; `H2` sends the right epipole to infinity along `x` around the image centre;
/// `H1 = Ha H2 M` with `M = [e2]× F + e2 (1 1 1)` and the affine `Ha` fitted by least squares
/// to minimise the horizontal disparity spread of the matches; both are mirrored when the
/// epipole lies on the left. With `threshold = Some(t)` matches farther than `t` pixels from
/// their epipolar line (in either image) are ignored. Lens distortion must be removed first.
/// Errors on mismatched or empty lists, non-finite input, a zero `F` or fewer than 3 usable
/// matches.
pub fn stereo_rectify_uncalibrated(
    points1: &[DVec2],
    points2: &[DVec2],
    f: DMat3,
    width: u32,
    height: u32,
    threshold: Option<f64>,
) -> Result<UncalibratedRectification> {
    if points1.len() != points2.len() {
        return Err(RectifyError::SizeMismatch(format!(
            "{} points in the first image, {} in the second",
            points1.len(),
            points2.len()
        )));
    }
    if points1.is_empty() {
        return Err(RectifyError::Empty("point matches"));
    }
    if !points1.iter().chain(points2).all(|p| p.is_finite()) {
        return Err(RectifyError::NonFinite("point matches"));
    }
    if !f.is_finite() {
        return Err(RectifyError::NonFinite("fundamental matrix"));
    }
    if width == 0 || height == 0 {
        return Err(RectifyError::Config(format!("image size must be non-zero, got {width}x{height}")));
    }
    let svd = mat_from_dmat3(f)
        .svd()
        .map_err(|e| RectifyError::Degenerate(format!("SVD of the fundamental matrix failed: {e:?}")))?;
    let u = dmat3_from_mat(svd.U());
    let v = dmat3_from_mat(svd.V());
    let s = svd.S().column_vector();
    if s[0].is_nan() || s[0] <= 0.0 {
        return Err(RectifyError::Degenerate("the fundamental matrix is zero".into()));
    }
    let f = u * DMat3::from_diagonal(DVec3::new(s[0], s[1], 0.0)) * v.transpose();

    let cx = ((width as f64 - 1.0) * 0.5).round_ties_even();
    let cy = ((height as f64 - 1.0) * 0.5).round_ties_even();

    // Inliers by symmetric epipolar distance.
    let inliers: Vec<bool> = match threshold {
        Some(t) if t > 0.0 => points1
            .iter()
            .zip(points2)
            .map(|(&m1, &m2)| {
                let l2 = normalized_line(f * m1.extend(1.0)); // line in image 2
                let l1 = normalized_line(f.transpose() * m2.extend(1.0)); // line in image 1
                l1.dot(m1.extend(1.0)).abs() <= t && l2.dot(m2.extend(1.0)).abs() <= t
            })
            .collect(),
        _ => vec![true; points1.len()],
    };
    let (m1, m2): (Vec<DVec2>, Vec<DVec2>) =
        points1.iter().zip(points2).zip(&inliers).filter(|(_, ok)| **ok).map(|((a, b), _)| (*a, *b)).unzip();
    if m1.len() < 3 {
        return Err(RectifyError::TooFewMatches { needed: 3, got: m1.len() });
    }

    let mut e2 = u.col(2);
    if e2.z < 0.0 {
        e2 = -e2;
    }
    let mut t = rows([[1.0, 0.0, -cx], [0.0, 1.0, -cy], [0.0, 0.0, 1.0]]);
    let e2t = t * e2;
    let mirror = e2t.x < 0.0;
    let d = (e2t.x * e2t.x + e2t.y * e2t.y).sqrt().max(f64::EPSILON);
    let (alpha, beta) = (e2t.x / d, e2t.y / d);
    let r = rows([[alpha, beta, 0.0], [-beta, alpha, 0.0], [0.0, 0.0, 1.0]]);
    t = r * t;
    let e2r = r * e2t;
    let invf = if e2r.z.abs() < 1e-6 * e2r.x.abs() { 0.0 } else { -e2r.z / e2r.x };
    let k = rows([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [invf, 0.0, 1.0]]);
    let it = rows([[1.0, 0.0, cx], [0.0, 1.0, cy], [0.0, 0.0, 1.0]]);
    let mut h2 = it * (k * t);

    let e2_x = rows([[0.0, -e2.z, e2.y], [e2.z, 0.0, -e2.x], [-e2.y, e2.x, 0.0]]);
    let e2_111 = rows([[e2.x, e2.x, e2.x], [e2.y, e2.y, e2.y], [e2.z, e2.z, e2.z]]);
    let h0 = h2 * (e2_x * f + e2_111);

    let n = m1.len();
    let mut a = faer::Mat::<f64>::zeros(n, 3);
    let mut b = faer::Col::<f64>::zeros(n);
    for i in 0..n {
        let p1 = apply_homography(h0, m1[i]);
        let p2 = apply_homography(h2, m2[i]);
        a[(i, 0)] = p1.x;
        a[(i, 1)] = p1.y;
        a[(i, 2)] = 1.0;
        b[i] = p2.x;
    }
    let x = solve_linear_least_squares(a.as_ref(), b.as_ref())
        .map_err(|e| RectifyError::Degenerate(format!("affine fit of the uncalibrated rectification: {e}")))?;
    let ha = rows([[x[0], x[1], x[2]], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let mut h1 = ha * h0;
    if mirror {
        let mm = rows([[-1.0, 0.0, cx * 2.0], [0.0, -1.0, cy * 2.0], [0.0, 0.0, 1.0]]);
        h1 = mm * h1;
        h2 = mm * h2;
    }
    if !(h1.is_finite() && h2.is_finite()) {
        return Err(RectifyError::Degenerate("uncalibrated rectification produced non-finite homographies".into()));
    }
    let dv: Vec<f64> =
        m1.iter().zip(&m2).map(|(&p, &q)| (apply_homography(h1, p).y - apply_homography(h2, q).y).abs()).collect();
    let mean_abs_dv = dv.iter().sum::<f64>() / n as f64;
    let max_abs_dv = dv.iter().copied().fold(0.0, f64::max);
    Ok(UncalibratedRectification { h1, h2, inliers, mean_abs_dv, max_abs_dv })
}

/// A 3x3 matrix from rows.
fn rows(r: [[f64; 3]; 3]) -> DMat3 {
    DMat3::from_cols_array_2d(&r).transpose()
}

/// Line `(a, b, c)` scaled so `a² + b² = 1` (OpenCV's `computeCorrespondEpilines`).
fn normalized_line(l: DVec3) -> DVec3 {
    let n = (l.x * l.x + l.y * l.y).sqrt();
    if n > 0.0 { l / n } else { l }
}
