//! DLT calibration from a non-planar target: the 3x4 projection matrix from ≥ 6 3D ↔ 2D
//! points (normalised DLT), decomposed by RQ into `K`, `R`, `t`.

use faer::Mat;
use glam::{DMat3, DVec2, DVec3, DVec4};
use parallax_camera_model::{Intrinsics, Isometry3, ProjectionMatrix};
use parallax_least_squares::null_vector;
use serde::{Deserialize, Serialize};

use crate::homography::{COLLINEAR_RATIO, normalization};
use crate::{CalibrationError, Result};

/// The result of [`calibrate_dlt`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DltCalibration {
    /// `P = K [R | t]`, scaled so that `K[2][2] = 1`.
    pub projection: ProjectionMatrix,
    /// `K` from the RQ decomposition (positive diagonal; skew estimated, not forced to 0).
    pub intrinsics: Intrinsics,
    /// `[R | t]` (`det R = +1`).
    pub camera_from_world: Isometry3,
    /// RMS reprojection error of `P`, pixels (no lens distortion in this model).
    pub rms_px: f64,
}

/// RQ decomposition of a 3x3 matrix with `det M > 0`: `M = K R`, `K` upper triangular with a
/// positive diagonal, `R` a rotation (Gram–Schmidt on the rows, from the last one up).
pub fn rq_decomposition(m: DMat3) -> Result<(DMat3, DMat3)> {
    let row = |i: usize| m.row(i);
    let m3 = row(2);
    let k33 = m3.length();
    if !(k33.is_finite() && k33 > 0.0) {
        return Err(CalibrationError::Degenerate("RQ: the last row of M is zero".into()));
    }
    let r3 = m3 / k33;
    let m2 = row(1);
    let k23 = m2.dot(r3);
    let rem2 = m2 - k23 * r3;
    let k22 = rem2.length();
    let m1 = row(0);
    if k22 <= 1e-12 * m2.length().max(1e-300) {
        return Err(CalibrationError::Degenerate("RQ: M is singular".into()));
    }
    let r2 = rem2 / k22;
    let k13 = m1.dot(r3);
    let k12 = m1.dot(r2);
    let rem1 = m1 - k12 * r2 - k13 * r3;
    let k11 = rem1.length();
    if k11 <= 1e-12 * m1.length().max(1e-300) {
        return Err(CalibrationError::Degenerate("RQ: M is singular".into()));
    }
    let r1 = rem1 / k11;
    let k = DMat3::from_cols(DVec3::new(k11, 0.0, 0.0), DVec3::new(k12, k22, 0.0), DVec3::new(k13, k23, k33));
    let r = DMat3::from_cols(r1, r2, r3).transpose();
    Ok((k, r))
}

/// Calibrates a camera from ≥ 6 points of a non-planar target: normalised DLT for `P`, then
/// RQ for `K`, `R`, `t`. Coplanar (or collinear) object points are
/// [`CalibrationError::Degenerate`]: a plane does not determine `P` (use [`crate::calibrate_camera`]).
pub fn calibrate_dlt(object_points: &[DVec3], image_points: &[DVec2]) -> Result<DltCalibration> {
    if object_points.len() != image_points.len() {
        return Err(CalibrationError::SizeMismatch(format!(
            "DLT: {} object points but {} image points",
            object_points.len(),
            image_points.len()
        )));
    }
    let n = object_points.len();
    if n < 6 {
        return Err(CalibrationError::TooFewPoints { what: "DLT".into(), got: n, needed: 6 });
    }
    if object_points.iter().any(|p| !p.is_finite()) || image_points.iter().any(|p| !p.is_finite()) {
        return Err(CalibrationError::NonFinite("DLT points".into()));
    }
    // 3D normalisation: centroid to 0, mean distance √3; flatness from the singular values.
    let c = object_points.iter().copied().sum::<DVec3>() / n as f64;
    let mean = object_points.iter().map(|p| (*p - c).length()).sum::<f64>() / n as f64;
    let s3 = if mean > 0.0 { 3f64.sqrt() / mean } else { 1.0 };
    let centred = Mat::from_fn(n, 3, |i, j| (object_points[i] - c)[j] * s3);
    let sv = null_vector(centred.as_ref())?.singular_values;
    if sv[2] * sv[2] < COLLINEAR_RATIO * sv[0] * sv[0] {
        return Err(CalibrationError::Degenerate(
            "DLT: the object points are coplanar; the DLT needs a non-planar target".into(),
        ));
    }
    let (ti, ri) = normalization(image_points);
    if ri < COLLINEAR_RATIO {
        return Err(CalibrationError::Degenerate("DLT: the image points are collinear".into()));
    }
    let mut a = Mat::<f64>::zeros(2 * n, 12);
    for (i, (x, q)) in object_points.iter().zip(image_points).enumerate() {
        let xn = ((*x - c) * s3).extend(1.0).to_array();
        let qn = ti * q.extend(1.0);
        for j in 0..4 {
            a[(2 * i, j)] = xn[j];
            a[(2 * i, 8 + j)] = -qn.x * xn[j];
            a[(2 * i + 1, 4 + j)] = xn[j];
            a[(2 * i + 1, 8 + j)] = -qn.y * xn[j];
        }
    }
    let nv = null_vector(a.as_ref())?;
    let sv = &nv.singular_values;
    if sv[10] <= 1e-10 * sv[0] {
        return Err(CalibrationError::Degenerate("DLT: the correspondences do not determine P".into()));
    }
    let p = &nv.vector;
    // P = Ti⁻¹ Pn T3 with T3 = [s3 I, −s3 c; 0 1].
    let pn = [[p[0], p[1], p[2], p[3]], [p[4], p[5], p[6], p[7]], [p[8], p[9], p[10], p[11]]];
    let tinv = ti.inverse();
    let mut pm = [[0.0; 4]; 3];
    for r in 0..3 {
        // row r of Ti⁻¹ Pn
        let mut row = [0.0; 4];
        for k in 0..3 {
            let w = tinv.col(k)[r];
            for j in 0..4 {
                row[j] += w * pn[k][j];
            }
        }
        // times T3
        for j in 0..3 {
            pm[r][j] = row[j] * s3;
        }
        pm[r][3] = row[3] - s3 * (row[0] * c.x + row[1] * c.y + row[2] * c.z);
    }
    let mut m = DMat3::from_cols(
        DVec3::new(pm[0][0], pm[1][0], pm[2][0]),
        DVec3::new(pm[0][1], pm[1][1], pm[2][1]),
        DVec3::new(pm[0][2], pm[1][2], pm[2][2]),
    );
    let mut p4 = DVec3::new(pm[0][3], pm[1][3], pm[2][3]);
    if m.determinant() < 0.0 {
        m = -m;
        p4 = -p4;
    }
    let (k, r) = rq_decomposition(m)?;
    let t = k.inverse() * p4;
    let pose = Isometry3::from_rotation_translation(r, t)?;
    let intrinsics = Intrinsics::from_matrix(k)?;
    let projection = ProjectionMatrix::new(intrinsics.matrix(), &pose);
    let mut s = 0.0;
    for (x, q) in object_points.iter().zip(image_points) {
        let h = projection.apply(DVec4::new(x.x, x.y, x.z, 1.0));
        if h.z <= 0.0 {
            return Err(CalibrationError::EstimationFailed(
                "DLT: points project behind the camera (inconsistent correspondences)".into(),
            ));
        }
        s += (DVec2::new(h.x / h.z, h.y / h.z) - *q).length_squared();
    }
    Ok(DltCalibration { projection, intrinsics, camera_from_world: pose, rms_px: (s / n as f64).sqrt() })
}
