//! Zhang's closed-form calibration: `K` from the homographies (`V b = 0`), poses from `K⁻¹H`
//! with the nearest-rotation fix, and a linear estimate of radial distortion.

use faer::{Col, Mat};
use glam::{DMat3, DVec2, DVec3};
use parallax_least_squares::{nearest_rotation, null_vector, solve_linear_least_squares};

use parallax_camera_model::{Intrinsics, Isometry3};

use crate::{CalibrationError, Result};

/// Preconditioning of the homographies for Zhang's system: pixels are mapped by
/// `N = [1/s 0 −cx/s; 0 1/s −cy/s; 0 0 1]` (image centre, `s` = half the larger side), which
/// keeps `V` well conditioned; `K = N⁻¹ K'` undoes it (skew-free `K'` ⇔ skew-free `K`).
fn preconditioner(width: u32, height: u32) -> DMat3 {
    let s = 0.5 * width.max(height) as f64;
    let (cx, cy) = (0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0));
    DMat3::from_cols(DVec3::new(1.0 / s, 0.0, 0.0), DVec3::new(0.0, 1.0 / s, 0.0), DVec3::new(-cx / s, -cy / s, 1.0))
}

fn unit(h: DMat3) -> DMat3 {
    let n = h.to_cols_array().iter().map(|v| v * v).sum::<f64>().sqrt();
    h * (1.0 / n)
}

fn v_ij(h: &DMat3, i: usize, j: usize) -> [f64; 6] {
    let (a, b) = (h.col(i), h.col(j));
    [a.x * b.x, a.x * b.y + a.y * b.x, a.y * b.y, a.z * b.x + a.x * b.z, a.z * b.y + a.y * b.z, a.z * b.z]
}

/// Smallest ratio `σ₄/σ₁` (second-smallest to largest singular value of the row-normalised
/// `V` without skew) accepted before the views count as parallel. Measured: views tilted by
/// ≥ 10° relative to each other give ≥ 1e-2; exactly parallel views with 0.1–1 px noise ≤ 1e-3.
pub(crate) const PARALLEL_VIEWS_RATIO: f64 = 3e-3;

/// Intrinsics from ≥ 2 (skew-free) or ≥ 3 (with skew) plane-to-image homographies by Zhang's
/// closed form (`V b = 0`, `K` from `B = K⁻ᵀK⁻¹`, his Appendix B). Parallel views (which give
/// the same constraints) are [`CalibrationError::Degenerate`].
pub fn intrinsics_from_homographies(
    homographies: &[DMat3],
    width: u32,
    height: u32,
    estimate_skew: bool,
) -> Result<Intrinsics> {
    let needed = if estimate_skew { 3 } else { 2 };
    if homographies.len() < needed {
        return Err(CalibrationError::TooFewViews {
            got: homographies.len(),
            needed,
            why: if estimate_skew { "Zhang's closed form with skew" } else { "Zhang's closed form" },
        });
    }
    if width == 0 || height == 0 {
        return Err(CalibrationError::InvalidConfig(format!("image size {width}x{height}")));
    }
    let n = preconditioner(width, height);
    let cols: &[usize] = if estimate_skew { &[0, 1, 2, 3, 4, 5] } else { &[0, 2, 3, 4, 5] };
    let m = homographies.len();
    let mut v = Mat::<f64>::zeros(2 * m, cols.len());
    for (k, h) in homographies.iter().enumerate() {
        if !h.is_finite() {
            return Err(CalibrationError::NonFinite(format!("homography of view {k}")));
        }
        let h = unit(n * *h);
        let a = v_ij(&h, 0, 1);
        let b11 = v_ij(&h, 0, 0);
        let b22 = v_ij(&h, 1, 1);
        let b: [f64; 6] = std::array::from_fn(|i| b11[i] - b22[i]);
        let na = cols.iter().map(|&c| a[c] * a[c]).sum::<f64>().sqrt().max(1e-300);
        let nb = cols.iter().map(|&c| b[c] * b[c]).sum::<f64>().sqrt().max(1e-300);
        for (j, &c) in cols.iter().enumerate() {
            v[(2 * k, j)] = a[c] / na;
            v[(2 * k + 1, j)] = b[c] / nb;
        }
    }
    let nv = null_vector(v.as_ref())?;
    let s = &nv.singular_values;
    let k = cols.len();
    if s[k - 2] < PARALLEL_VIEWS_RATIO * s[0] {
        return Err(CalibrationError::Degenerate(format!(
            "the views do not constrain the intrinsics (the boards are parallel or nearly so: \
             singular value ratio {:.1e}); tilt the board differently in each view",
            s[k - 2] / s[0]
        )));
    }
    let mut b = [0.0; 6];
    for (j, &c) in cols.iter().enumerate() {
        b[c] = nv.vector[j];
    }
    let kp = k_from_b(&b)
        .ok_or_else(|| CalibrationError::EstimationFailed("Zhang's closed form: B is not positive definite".into()))?;
    let kmat = n.inverse() * kp;
    let mut intr = Intrinsics::from_matrix(kmat)?;
    if !estimate_skew {
        intr.skew = 0.0;
    }
    Ok(intr)
}

/// `K` (normalised) from `b = (B11, B12, B22, B13, B23, B33)`, Zhang's Appendix B.
fn k_from_b(b: &[f64; 6]) -> Option<DMat3> {
    let sign = if b[0] < 0.0 { -1.0 } else { 1.0 };
    let [b11, b12, b22, b13, b23, b33] = b.map(|x| x * sign);
    let den = b11 * b22 - b12 * b12;
    if b11 <= 0.0 || den <= 0.0 {
        return None;
    }
    let v0 = (b12 * b13 - b11 * b23) / den;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    if lambda / b11 <= 0.0 {
        return None;
    }
    let alpha = (lambda / b11).sqrt();
    let beta = (lambda * b11 / den).sqrt();
    let gamma = -b12 * alpha * alpha * beta / lambda;
    let u0 = gamma * v0 / beta - b13 * alpha * alpha / lambda;
    let k = DMat3::from_cols(DVec3::new(alpha, 0.0, 0.0), DVec3::new(gamma, beta, 0.0), DVec3::new(u0, v0, 1.0));
    k.is_finite().then_some(k)
}

/// Focal lengths `(fx, fy)` from homographies with a known principal point (OpenCV's
/// `initIntrinsicParams2D`: orthogonality of the vanishing points, least squares in `1/f²`).
pub fn focal_lengths_with_principal_point(homographies: &[DMat3], cx: f64, cy: f64) -> Result<(f64, f64)> {
    if homographies.is_empty() {
        return Err(CalibrationError::Empty("homographies"));
    }
    let shift = DMat3::from_cols(DVec3::X, DVec3::Y, DVec3::new(-cx, -cy, 1.0));
    let m = homographies.len();
    let mut a = Mat::<f64>::zeros(2 * m, 2);
    let mut rhs = Col::<f64>::zeros(2 * m);
    for (k, h) in homographies.iter().enumerate() {
        let h = unit(shift * *h);
        let (h1, h2) = (h.col(0), h.col(1));
        // h1ᵀ B h2 = 0 and h1ᵀ B h1 = h2ᵀ B h2 with B = diag(a, b, 1).
        let r0 = [h1.x * h2.x, h1.y * h2.y, -h1.z * h2.z];
        let r1 = [h1.x * h1.x - h2.x * h2.x, h1.y * h1.y - h2.y * h2.y, -(h1.z * h1.z - h2.z * h2.z)];
        let n0 = (r0[0].powi(2) + r0[1].powi(2)).sqrt().max(1e-300);
        let n1 = (r1[0].powi(2) + r1[1].powi(2)).sqrt().max(1e-300);
        a[(2 * k, 0)] = r0[0] / n0;
        a[(2 * k, 1)] = r0[1] / n0;
        rhs[2 * k] = r0[2] / n0;
        a[(2 * k + 1, 0)] = r1[0] / n1;
        a[(2 * k + 1, 1)] = r1[1] / n1;
        rhs[2 * k + 1] = r1[2] / n1;
    }
    let x = solve_linear_least_squares(a.as_ref(), rhs.as_ref()).map_err(|_| {
        CalibrationError::Degenerate("the views do not constrain the focal length (fronto-parallel boards)".into())
    })?;
    if !(x[0] > 0.0 && x[1] > 0.0) {
        return Err(CalibrationError::Degenerate(
            "the views do not constrain the focal length (boards nearly fronto-parallel)".into(),
        ));
    }
    Ok((1.0 / x[0].sqrt(), 1.0 / x[1].sqrt()))
}

/// `camera_from_board` from `K⁻¹H = λ[r1 r2 t]`: `λ` from the mean norm of the first two
/// columns, sign so the board is in front of the camera, and the rotation projected onto SO(3)
/// (`parallax_least_squares::nearest_rotation`).
pub fn pose_from_homography(k: &Intrinsics, h: &DMat3) -> Result<Isometry3> {
    let m = k.matrix().inverse() * *h;
    let (a, b, c) = (m.col(0), m.col(1), m.col(2));
    let s = 0.5 * (a.length() + b.length());
    if !(s.is_finite() && s > 0.0) {
        return Err(CalibrationError::EstimationFailed("pose from a degenerate homography".into()));
    }
    let mut lambda = 1.0 / s;
    if c.z * lambda < 0.0 {
        lambda = -lambda;
    }
    let (r1, r2, t) = (a * lambda, b * lambda, c * lambda);
    let r = nearest_rotation(DMat3::from_cols(r1, r2, r1.cross(r2)))?;
    Ok(Isometry3::from_rotation_translation(r, t)?)
}

/// Zhang's linear estimate of `(k1, k2)` (his §3.3): with `K` and the poses fixed, the
/// observed minus ideal pixel offsets are linear in `k1, k2`.
pub fn radial_distortion_linear(
    k: &Intrinsics,
    camera_from_board: &[Isometry3],
    object_points: &[Vec<DVec3>],
    image_points: &[Vec<DVec2>],
) -> Result<(f64, f64)> {
    let total: usize = object_points.iter().map(|v| v.len()).sum();
    if total < 2 || camera_from_board.len() != object_points.len() || image_points.len() != object_points.len() {
        return Err(CalibrationError::SizeMismatch("radial distortion: views, poses and points".into()));
    }
    let mut a = Mat::<f64>::zeros(2 * total, 2);
    let mut rhs = Col::<f64>::zeros(2 * total);
    let mut row = 0;
    for ((pose, obj), img) in camera_from_board.iter().zip(object_points).zip(image_points) {
        for (x, q) in obj.iter().zip(img) {
            let pc = pose.transform_point(*x);
            let n = DVec2::new(pc.x / pc.z, pc.y / pc.z);
            let ideal = k.to_pixel(n);
            let r2 = n.length_squared();
            let du = k.fx * n.x + k.skew * n.y;
            let dv = k.fy * n.y;
            a[(row, 0)] = du * r2;
            a[(row, 1)] = du * r2 * r2;
            rhs[row] = q.x - ideal.x;
            a[(row + 1, 0)] = dv * r2;
            a[(row + 1, 1)] = dv * r2 * r2;
            rhs[row + 1] = q.y - ideal.y;
            row += 2;
        }
    }
    let x = solve_linear_least_squares(a.as_ref(), rhs.as_ref())?;
    Ok((x[0], x[1]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use parallax_camera_model::{Camera, Distortion};

    pub(crate) fn views() -> Vec<Isometry3> {
        let rv = [
            DVec3::new(0.3, -0.2, 0.05),
            DVec3::new(-0.25, 0.3, -0.1),
            DVec3::new(0.1, 0.35, 0.2),
            DVec3::new(-0.35, -0.1, 0.0),
        ];
        rv.iter()
            .enumerate()
            .map(|(i, r)| {
                let pose = Isometry3::from_rvec_tvec(*r, DVec3::ZERO);
                // Put the board centre (120, 75) on the optical axis at depth 500 + 40 i.
                let c = pose.transform_vector(DVec3::new(120.0, 75.0, 0.0));
                Isometry3::from_rvec_tvec(*r, DVec3::new(0.0, 0.0, 500.0 + 40.0 * i as f64) - c)
            })
            .collect()
    }

    fn h_of(k: &Intrinsics, p: &Isometry3) -> DMat3 {
        let r = p.rotation_matrix();
        k.matrix() * DMat3::from_cols(r.col(0), r.col(1), p.translation)
    }

    #[test]
    fn closed_form_recovers_k_and_poses_from_exact_homographies() {
        for skew in [false, true] {
            let k = Intrinsics { fx: 800.0, fy: 780.0, cx: 330.0, cy: 230.0, skew: if skew { 1.5 } else { 0.0 } };
            let poses = views();
            let hs: Vec<DMat3> = poses.iter().map(|p| h_of(&k, p) * 0.37).collect();
            let est = intrinsics_from_homographies(&hs, 640, 480, skew).unwrap();
            assert!((est.fx - k.fx).abs() < 1e-6 && (est.fy - k.fy).abs() < 1e-6, "{est:?}");
            assert!((est.cx - k.cx).abs() < 1e-6 && (est.cy - k.cy).abs() < 1e-6);
            assert!((est.skew - k.skew).abs() < 1e-6);
            for (p, h) in poses.iter().zip(&hs) {
                let e = pose_from_homography(&est, &(-*h)).unwrap();
                let (da, dt) = e.distance(p);
                assert!(da < 1e-9 && dt < 1e-6, "{da} {dt}");
            }
            let (fx, fy) = focal_lengths_with_principal_point(&hs, k.cx, k.cy).unwrap();
            if !skew {
                assert!((fx - k.fx).abs() < 1e-6 && (fy - k.fy).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn parallel_views_are_degenerate() {
        let k = Intrinsics::new(800.0, 800.0, 320.0, 240.0);
        let r = DVec3::new(0.3, 0.1, 0.0);
        let hs: Vec<DMat3> = (0..5)
            .map(|i| {
                h_of(
                    &k,
                    &Isometry3::from_rvec_tvec(r, DVec3::new(-100.0 + 20.0 * i as f64, -50.0, 600.0 + 50.0 * i as f64)),
                )
            })
            .collect();
        let e = intrinsics_from_homographies(&hs, 640, 480, false).unwrap_err();
        assert!(matches!(e, CalibrationError::Degenerate(_)), "{e}");
        assert!(matches!(
            intrinsics_from_homographies(&hs[..1], 640, 480, false),
            Err(CalibrationError::TooFewViews { .. })
        ));
    }

    #[test]
    fn linear_radial_estimate_is_exact_for_radial_only_data() {
        let k = Intrinsics::new(700.0, 700.0, 320.0, 240.0);
        let cam = Camera::new(k, Distortion::new(-0.2, 0.05, 0.0, 0.0, 0.0), 640, 480).unwrap();
        let poses = views();
        let obj: Vec<Vec<DVec3>> = poses
            .iter()
            .map(|_| (0..40).map(|i| DVec3::new((i % 8) as f64 * 30.0, (i / 8) as f64 * 30.0, 0.0)).collect())
            .collect();
        let img: Vec<Vec<DVec2>> =
            poses.iter().zip(&obj).map(|(p, o)| o.iter().map(|x| cam.project_from(p, *x).unwrap()).collect()).collect();
        let (k1, k2) = radial_distortion_linear(&k, &poses, &obj, &img).unwrap();
        assert!((k1 + 0.2).abs() < 1e-9 && (k2 - 0.05).abs() < 1e-8, "{k1} {k2}");
    }
}
