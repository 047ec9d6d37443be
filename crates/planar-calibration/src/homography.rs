//! Plane-to-image homographies: normalised DLT (Hartley) then geometric refinement.

use faer::{Mat, MatMut};
use glam::{DMat3, DVec2, DVec3};
use parallax_least_squares::{EvaluationError, LmConfig, Problem, levenberg_marquardt, null_vector};
use serde::{Deserialize, Serialize};

use crate::{CalibrationError, Result};

/// A homography `H` mapping plane points `(x, y, 1)` to image points (homogeneous), with the
/// quality of the fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Homography {
    /// The 3x3 matrix (glam, column-major), scaled to unit Frobenius norm.
    pub matrix: DMat3,
    /// RMS of the geometric transfer error `‖H p − q‖` in the image, in image units (pixels).
    pub rms: f64,
}

impl Homography {
    /// Maps a plane point to the image (`None` when it maps to infinity).
    pub fn apply(&self, p: DVec2) -> Option<DVec2> {
        apply(&self.matrix, p)
    }
}

#[inline]
pub(crate) fn apply(h: &DMat3, p: DVec2) -> Option<DVec2> {
    let q = *h * p.extend(1.0);
    (q.z != 0.0 && q.is_finite()).then(|| DVec2::new(q.x / q.z, q.y / q.z))
}

/// Hartley normalisation: `T` moving the centroid to 0 and the mean distance to √2, and the
/// ratio of the smallest to the largest eigenvalue of the normalised points' scatter (0 for
/// collinear points).
pub(crate) fn normalization(points: &[DVec2]) -> (DMat3, f64) {
    let n = points.len() as f64;
    let c = points.iter().copied().sum::<DVec2>() / n;
    let mean_dist = points.iter().map(|p| (*p - c).length()).sum::<f64>() / n;
    let s = if mean_dist > 0.0 { std::f64::consts::SQRT_2 / mean_dist } else { 1.0 };
    let t = DMat3::from_cols(DVec3::new(s, 0.0, 0.0), DVec3::new(0.0, s, 0.0), DVec3::new(-s * c.x, -s * c.y, 1.0));
    // Scatter of the normalised points: eigenvalues of the 2x2 symmetric matrix.
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = (*p - c) * s;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let tr = sxx + syy;
    let disc = ((sxx - syy).powi(2) + 4.0 * sxy * sxy).sqrt();
    let (lmax, lmin) = (0.5 * (tr + disc), 0.5 * (tr - disc));
    let ratio = if lmax > 0.0 { (lmin / lmax).max(0.0) } else { 0.0 };
    (t, ratio)
}

/// Smallest-to-largest scatter eigenvalue ratio below which points count as collinear
/// (a strip thinner than ~0.3 % of its length).
pub(crate) const COLLINEAR_RATIO: f64 = 1e-5;

fn check_inputs(plane: &[DVec2], image: &[DVec2], what: &str) -> Result<()> {
    if plane.len() != image.len() {
        return Err(CalibrationError::SizeMismatch(format!(
            "{what}: {} plane points but {} image points",
            plane.len(),
            image.len()
        )));
    }
    if plane.len() < 4 {
        return Err(CalibrationError::TooFewPoints { what: what.to_string(), got: plane.len(), needed: 4 });
    }
    if plane.iter().chain(image).any(|p| !p.is_finite()) {
        return Err(CalibrationError::NonFinite(format!("{what} points")));
    }
    Ok(())
}

/// The homography from ≥ 4 plane ↔ image correspondences by the normalised DLT only (no
/// refinement). Collinear plane or image points are [`CalibrationError::Degenerate`].
pub fn homography_dlt(plane: &[DVec2], image: &[DVec2]) -> Result<DMat3> {
    homography_dlt_named(plane, image, "homography")
}

pub(crate) fn homography_dlt_named(plane: &[DVec2], image: &[DVec2], what: &str) -> Result<DMat3> {
    check_inputs(plane, image, what)?;
    let (tp, rp) = normalization(plane);
    let (ti, ri) = normalization(image);
    if rp < COLLINEAR_RATIO {
        return Err(CalibrationError::Degenerate(format!("{what}: the plane points are collinear")));
    }
    if ri < COLLINEAR_RATIO {
        return Err(CalibrationError::Degenerate(format!("{what}: the image points are collinear")));
    }
    let n = plane.len();
    let mut a = Mat::<f64>::zeros(2 * n, 9);
    for (i, (p, q)) in plane.iter().zip(image).enumerate() {
        let p = tp * p.extend(1.0);
        let q = ti * q.extend(1.0);
        let (x, y) = (p.x, p.y);
        let (u, v) = (q.x, q.y);
        // rows: [pᵀ 0 −u pᵀ], [0 pᵀ −v pᵀ]  (h row-major)
        let r0 = [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u];
        let r1 = [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, -v];
        for j in 0..9 {
            a[(2 * i, j)] = r0[j];
            a[(2 * i + 1, j)] = r1[j];
        }
    }
    let nv = null_vector(a.as_ref())?;
    let s = &nv.singular_values;
    // A second (near-)null direction means the correspondences do not fix H.
    if s[7] <= 1e-10 * s[0] {
        return Err(CalibrationError::Degenerate(format!(
            "{what}: the correspondences do not determine a homography (three or more points coincide or are collinear)"
        )));
    }
    let h = &nv.vector;
    let hn = DMat3::from_cols(DVec3::new(h[0], h[3], h[6]), DVec3::new(h[1], h[4], h[7]), DVec3::new(h[2], h[5], h[8]));
    let hm = ti.inverse() * hn * tp;
    let norm = hm.to_cols_array().iter().map(|v| v * v).sum::<f64>().sqrt();
    if !(norm.is_finite() && norm > 0.0) {
        return Err(CalibrationError::EstimationFailed(format!("{what}: DLT gave a zero matrix")));
    }
    Ok(hm * (1.0 / norm))
}

/// Geometric refinement of `H`: minimises `Σ ‖H p − q‖²` over the 8 entries other than the
/// largest one of the DLT estimate (which stays fixed and sets the scale).
struct HomographyFit<'a> {
    plane: &'a [DVec2],
    image: &'a [DVec2],
    fixed: usize,
    fixed_value: f64,
}

impl HomographyFit<'_> {
    fn matrix(&self, p: &[f64]) -> [f64; 9] {
        let mut h = [0.0; 9];
        let mut k = 0;
        for (i, hi) in h.iter_mut().enumerate() {
            if i == self.fixed {
                *hi = self.fixed_value;
            } else {
                *hi = p[k];
                k += 1;
            }
        }
        h
    }
}

impl Problem for HomographyFit<'_> {
    fn num_params(&self) -> usize {
        8
    }
    fn num_residuals(&self) -> usize {
        2 * self.plane.len()
    }
    fn evaluate(
        &self,
        params: &[f64],
        residuals: &mut [f64],
        mut jacobian: Option<MatMut<'_, f64>>,
    ) -> std::result::Result<(), EvaluationError> {
        let h = self.matrix(params); // row-major
        for (i, (p, q)) in self.plane.iter().zip(self.image).enumerate() {
            let pt = [p.x, p.y, 1.0];
            let x = h[0] * pt[0] + h[1] * pt[1] + h[2];
            let y = h[3] * pt[0] + h[4] * pt[1] + h[5];
            let w = h[6] * pt[0] + h[7] * pt[1] + h[8];
            if w.abs() < 1e-300 || !w.is_finite() {
                return Err(EvaluationError(format!("point {i} maps to infinity")));
            }
            let (u, v) = (x / w, y / w);
            residuals[2 * i] = u - q.x;
            residuals[2 * i + 1] = v - q.y;
            if let Some(j) = jacobian.as_mut() {
                let mut full = [[0.0; 9]; 2];
                for c in 0..3 {
                    full[0][c] = pt[c] / w;
                    full[1][3 + c] = pt[c] / w;
                    full[0][6 + c] = -u * pt[c] / w;
                    full[1][6 + c] = -v * pt[c] / w;
                }
                let mut k = 0;
                for c in 0..9 {
                    if c == self.fixed {
                        continue;
                    }
                    j[(2 * i, k)] = full[0][c];
                    j[(2 * i + 1, k)] = full[1][c];
                    k += 1;
                }
            }
        }
        Ok(())
    }
}

fn transfer_rms(h: &DMat3, plane: &[DVec2], image: &[DVec2]) -> f64 {
    let s: f64 =
        plane.iter().zip(image).map(|(p, q)| apply(h, *p).map_or(f64::INFINITY, |x| (x - *q).length_squared())).sum();
    (s / plane.len() as f64).sqrt()
}

/// The homography from ≥ 4 plane ↔ image correspondences: normalised DLT (Hartley), then
/// Levenberg–Marquardt on the geometric transfer error in the image. Collinear points (plane
/// or image) are [`CalibrationError::Degenerate`].
///
/// ```
/// use glam::{DMat3, DVec2, DVec3};
/// let h = DMat3::from_cols(DVec3::new(1.0, 0.1, 1e-4), DVec3::new(-0.2, 0.9, 2e-4), DVec3::new(100.0, 50.0, 1.0));
/// let plane: Vec<DVec2> = (0..12).map(|i| DVec2::new((i % 4) as f64 * 30.0, (i / 4) as f64 * 30.0)).collect();
/// let image: Vec<DVec2> = plane.iter().map(|p| { let q = h * p.extend(1.0); DVec2::new(q.x / q.z, q.y / q.z) }).collect();
/// let fit = parallax_planar_calibration::estimate_homography(&plane, &image)?;
/// assert!(fit.rms < 1e-9);
/// # Ok::<(), parallax_planar_calibration::CalibrationError>(())
/// ```
pub fn estimate_homography(plane: &[DVec2], image: &[DVec2]) -> Result<Homography> {
    estimate_homography_named(plane, image, "homography")
}

pub(crate) fn estimate_homography_named(plane: &[DVec2], image: &[DVec2], what: &str) -> Result<Homography> {
    let h0 = homography_dlt_named(plane, image, what)?;
    let rms0 = transfer_rms(&h0, plane, image);
    if plane.len() == 4 || rms0 == 0.0 {
        return Ok(Homography { matrix: h0, rms: rms0 });
    }
    let rm = h0.transpose().to_cols_array(); // row-major entries
    let fixed = (0..9).max_by(|&a, &b| rm[a].abs().total_cmp(&rm[b].abs())).unwrap_or(8);
    let init: Vec<f64> = (0..9).filter(|&i| i != fixed).map(|i| rm[i]).collect();
    let fit = HomographyFit { plane, image, fixed, fixed_value: rm[fixed] };
    let cfg = LmConfig { max_iterations: 50, covariance: false, cost_tolerance: 1e-12, ..LmConfig::default() };
    let report = match levenberg_marquardt(&fit, &init, &cfg) {
        Ok(r) => r,
        Err(_) => return Ok(Homography { matrix: h0, rms: rms0 }),
    };
    let h = fit.matrix(&report.params);
    let hm = DMat3::from_cols_array(&h).transpose();
    let norm = hm.to_cols_array().iter().map(|v| v * v).sum::<f64>().sqrt();
    let hm = hm * (1.0 / norm);
    let rms = transfer_rms(&hm, plane, image);
    if rms.is_finite() && rms <= rms0 {
        Ok(Homography { matrix: hm, rms })
    } else {
        Ok(Homography { matrix: h0, rms: rms0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn truth() -> DMat3 {
        DMat3::from_cols(DVec3::new(2.1, 0.3, 4e-4), DVec3::new(-0.4, 1.9, -3e-4), DVec3::new(320.0, 200.0, 1.0))
    }

    fn grid() -> Vec<DVec2> {
        (0..54).map(|i| DVec2::new((i % 9) as f64 * 30.0, (i / 9) as f64 * 30.0)).collect()
    }

    fn normalized(h: DMat3) -> DMat3 {
        h * (1.0 / h.z_axis.z)
    }

    #[test]
    fn exact_data_recovers_h() {
        let h = truth();
        let plane = grid();
        let image: Vec<DVec2> = plane.iter().map(|p| apply(&h, *p).unwrap()).collect();
        let fit = estimate_homography(&plane, &image).unwrap();
        let d = normalized(fit.matrix) - normalized(h);
        let rel = d
            .to_cols_array()
            .iter()
            .zip(normalized(h).to_cols_array())
            .map(|(a, b)| a.abs() / b.abs().max(1e-3))
            .fold(0.0, f64::max);
        assert!(rel < 1e-9, "relative error {rel}");
        assert!(fit.rms < 1e-9);
    }

    #[test]
    fn refinement_does_not_increase_transfer_error() {
        let h = truth();
        let plane = grid();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.5).unwrap();
        let image: Vec<DVec2> = plane
            .iter()
            .map(|p| apply(&h, *p).unwrap() + DVec2::new(noise.sample(&mut rng), noise.sample(&mut rng)))
            .collect();
        let dlt = homography_dlt(&plane, &image).unwrap();
        let fit = estimate_homography(&plane, &image).unwrap();
        let rms_dlt = transfer_rms(&dlt, &plane, &image);
        assert!(fit.rms <= rms_dlt + 1e-12);
        // Residual RMS of an ML fit ≈ σ·sqrt((2n − 8)/(2n)) per coordinate → ×√2 per point.
        let expected = 0.5 * (2.0f64 * (108.0 - 8.0) / 108.0).sqrt();
        assert!((fit.rms - expected).abs() < 0.15, "rms {} expected ≈ {expected}", fit.rms);
        // The fitted H maps the grid close to the true mapping (σ = 0.5 px per coordinate;
        // the 8 parameters average 54 points, worst at the grid corners).
        let worst =
            plane.iter().map(|p| (fit.apply(*p).unwrap() - apply(&h, *p).unwrap()).length()).fold(0.0, f64::max);
        assert!(worst < 1.0, "worst {worst}");
    }

    #[test]
    fn collinear_and_too_few_points_are_errors() {
        let plane: Vec<DVec2> = (0..10).map(|i| DVec2::new(i as f64, 2.0 * i as f64)).collect();
        let image: Vec<DVec2> = plane.iter().map(|p| *p * 3.0 + DVec2::new(1.0, 0.0)).collect();
        assert!(matches!(estimate_homography(&plane, &image), Err(CalibrationError::Degenerate(_))));
        let plane = grid();
        let image: Vec<DVec2> = plane.iter().map(|p| DVec2::new(p.x, 2.0 * p.x)).collect();
        assert!(matches!(estimate_homography(&plane, &image), Err(CalibrationError::Degenerate(_))));
        let three = &grid()[..3];
        assert!(matches!(estimate_homography(three, three), Err(CalibrationError::TooFewPoints { .. })));
        assert!(matches!(estimate_homography(&grid(), &grid()[..5]), Err(CalibrationError::SizeMismatch(_))));
        let mut bad = grid();
        bad[2].x = f64::NAN;
        assert!(matches!(estimate_homography(&bad, &grid()), Err(CalibrationError::NonFinite(_))));
    }
}
