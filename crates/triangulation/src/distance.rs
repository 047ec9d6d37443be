//! Distances between triangulated points with their uncertainty, and the chessboard check.

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{CornerGrid, StereoRig};
use serde::{Deserialize, Serialize};

use crate::point::{TriangulatedPoint, TriangulationConfig, stereo_views, triangulate};
use crate::{Result, TriangulationError};

/// A distance and its first-order standard deviation (length unit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Distance {
    /// `‖b − a‖`.
    pub value: f64,
    /// Standard deviation from the points' covariances (0 when none was given).
    pub std_dev: f64,
    /// Expected second-order excess of `value` over the true distance,
    /// `tr(P⊥ C) / (2 value)` with `P⊥` the projector orthogonal to the segment and `C` the
    /// covariance of `b − a`: noise across the segment always lengthens it. Not subtracted from
    /// `value` (which stays the plain Euclidean distance, as OpenCV users compute it).
    pub bias: f64,
}

/// Distance between two points with independent errors: `σ² = gᵀ (C_a + C_b) g`, `g` the unit
/// vector from `a` to `b`. Points triangulated from different pixels of one calibrated rig have
/// independent pixel noise, so this is the right call for them (calibration error is not part
/// of the covariance).
pub fn distance(a: DVec3, cov_a: &DMat3, b: DVec3, cov_b: &DMat3) -> Result<Distance> {
    distance_with_joint_covariance(a, cov_a, b, cov_b, &DMat3::ZERO)
}

/// Distance between two points whose errors are correlated: `cross = E[δa δbᵀ]`;
/// `σ² = gᵀ (C_a + C_b − cross − crossᵀ) g`. Errors on non-finite input or coincident points
/// (the distance has no gradient there).
pub fn distance_with_joint_covariance(
    a: DVec3,
    cov_a: &DMat3,
    b: DVec3,
    cov_b: &DMat3,
    cross: &DMat3,
) -> Result<Distance> {
    if !(a.is_finite() && b.is_finite()) {
        return Err(TriangulationError::NonFinite { what: "point of a distance".into() });
    }
    if !(cov_a.is_finite() && cov_b.is_finite() && cross.is_finite()) {
        return Err(TriangulationError::NonFinite { what: "covariance of a distance".into() });
    }
    let delta = b - a;
    let value = delta.length();
    if value == 0.0 {
        return Err(TriangulationError::Degenerate("distance between coincident points".into()));
    }
    let g = delta / value;
    let c = *cov_a + *cov_b - *cross - cross.transpose();
    let var = g.dot(c * g);
    let trace = c.x_axis.x + c.y_axis.y + c.z_axis.z;
    let bias = ((trace - var) / (2.0 * value)).max(0.0);
    Ok(Distance { value, std_dev: var.max(0.0).sqrt(), bias })
}

/// Distance between two triangulated points, using their covariances when both have one.
pub fn point_distance(a: &TriangulatedPoint, b: &TriangulatedPoint) -> Result<Distance> {
    match (a.covariance, b.covariance) {
        (Some(ca), Some(cb)) => distance(a.point, &ca, b.point, &cb),
        _ => distance(a.point, &DMat3::ZERO, b.point, &DMat3::ZERO),
    }
}

/// The distance between two adjacent corners of a board seen by a stereo rig.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CornerDistance {
    /// `(col, row)` of the first corner.
    pub from: (usize, usize),
    /// `(col, row)` of the second corner (one to the right or one below).
    pub to: (usize, usize),
    /// Triangulated distance (length unit of the rig).
    pub distance: f64,
    /// Its first-order standard deviation from the configured pixel noise.
    pub std_dev: f64,
    /// Expected second-order excess over the true distance (see [`Distance::bias`]).
    pub bias: f64,
}

/// Triangulates every corner of a board seen in both cameras of `rig` (left/right grids of the
/// same board, same corner order) and returns the distances between horizontally adjacent
/// corners (row-major: `(c, r)–(c+1, r)`) followed by vertically adjacent ones
/// (`(c, r)–(c, r+1)`). Pixels are the raw (distorted) corners; the configured method handles
/// undistortion. On a correct calibration every distance equals the square size.
pub fn adjacent_corner_distances(
    rig: &StereoRig,
    left: &CornerGrid,
    right: &CornerGrid,
    config: &TriangulationConfig,
) -> Result<Vec<CornerDistance>> {
    if left.cols != right.cols || left.rows != right.rows {
        return Err(TriangulationError::SizeMismatch(format!(
            "left grid is {}x{}, right grid {}x{}",
            left.cols, left.rows, right.cols, right.rows
        )));
    }
    for (name, g) in [("left", left), ("right", right)] {
        if g.corners.len() != g.cols * g.rows {
            return Err(TriangulationError::SizeMismatch(format!(
                "{name} grid {}x{} holds {} corners",
                g.cols,
                g.rows,
                g.corners.len()
            )));
        }
    }
    if left.cols * left.rows < 2 {
        return Err(TriangulationError::TooFew { what: "corners", needed: 2, got: left.cols * left.rows });
    }
    let views = stereo_views(rig);
    let points = left
        .corners
        .iter()
        .zip(&right.corners)
        .enumerate()
        .map(|(i, (l, r))| {
            triangulate(&views, &[*l, *r], config).map_err(|e| match e {
                TriangulationError::NonFinite { what } => {
                    TriangulationError::NonFinite { what: format!("corner {i}: {what}") }
                }
                other => other,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let (cols, rows) = (left.cols, left.rows);
    let mut out = Vec::with_capacity((cols - 1) * rows + cols * (rows - 1));
    let mut push = |a: (usize, usize), b: (usize, usize)| -> Result<()> {
        let d = point_distance(&points[a.1 * cols + a.0], &points[b.1 * cols + b.0])?;
        out.push(CornerDistance { from: a, to: b, distance: d.value, std_dev: d.std_dev, bias: d.bias });
        Ok(())
    };
    for r in 0..rows {
        for c in 0..cols.saturating_sub(1) {
            push((c, r), (c + 1, r))?;
        }
    }
    for r in 0..rows.saturating_sub(1) {
        for c in 0..cols {
            push((c, r), (c, r + 1))?;
        }
    }
    Ok(out)
}

/// RMS of `|distance − expected|` over `distances` (the output contract's
/// `adjacent_corner_distance_rms` with `expected` = square size); `None` for an empty list.
pub fn distance_rms(distances: &[CornerDistance], expected: f64) -> Option<f64> {
    if distances.is_empty() {
        return None;
    }
    let s: f64 = distances.iter().map(|d| (d.distance - expected).powi(2)).sum();
    Some((s / distances.len() as f64).sqrt())
}

/// One measured point of a [`Measurement`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasuredPoint {
    /// Index in the input list.
    pub index: usize,
    /// Observed left pixel.
    pub left: DVec2,
    /// Observed right pixel.
    pub right: DVec2,
    /// The point in the left camera frame (length unit of the calibration).
    pub point: DVec3,
    /// Standard deviations of `X, Y, Z`; `None` when no covariance exists (a point on or behind
    /// a camera, or covariance not requested) — never a σ of zero that was not computed.
    pub std_dev: Option<DVec3>,
    /// RMS reprojection error over both views, pixels.
    pub reprojection_error: f64,
    /// Angle between the two viewing rays at the point, degrees.
    pub parallax_deg: f64,
    /// On or behind a camera's image plane.
    pub behind_camera: bool,
    /// Parallax below the configured threshold.
    pub low_parallax: bool,
    /// Reprojection error above the configured threshold: the pixels do not correspond.
    #[serde(default)]
    pub high_reprojection: bool,
}

/// A measured distance between two points of a [`Measurement`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeasuredDistance {
    /// Index of the first point.
    pub from: usize,
    /// Index of the second point.
    pub to: usize,
    /// Distance (length unit of the calibration).
    pub distance: f64,
    /// First-order standard deviation; `None` when either point has no covariance or the two
    /// points coincide (no gradient), never a zero that was not computed.
    pub std_dev: Option<f64>,
}

/// Points measured with a stereo rig and all pairwise distances between them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// The triangulation settings used.
    pub config: TriangulationConfig,
    /// The points, in input order.
    pub points: Vec<MeasuredPoint>,
    /// Distances between every pair `i < j`.
    pub distances: Vec<MeasuredDistance>,
}

/// Triangulates left/right pixel pairs (raw, distorted pixels) with `rig` and measures all
/// pairwise distances with their standard deviations.
pub fn measure_stereo(rig: &StereoRig, pairs: &[(DVec2, DVec2)], config: &TriangulationConfig) -> Result<Measurement> {
    if pairs.is_empty() {
        return Err(TriangulationError::TooFew { what: "point pairs", needed: 1, got: 0 });
    }
    let views = stereo_views(rig);
    let tri = pairs
        .iter()
        .enumerate()
        .map(|(i, (l, r))| {
            triangulate(&views, &[*l, *r], config).map_err(|e| match e {
                TriangulationError::NonFinite { what } => {
                    TriangulationError::NonFinite { what: format!("pair {i}: {what}") }
                }
                TriangulationError::ParallelRays { angle_rad } => TriangulationError::Degenerate(format!(
                    "pair {i}: rays are parallel ({angle_rad:e} rad), the point is at infinity"
                )),
                other => other,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let points = tri
        .iter()
        .zip(pairs)
        .enumerate()
        .map(|(index, (t, (l, r)))| MeasuredPoint {
            index,
            left: *l,
            right: *r,
            point: t.point,
            std_dev: if t.behind_camera { None } else { t.std_devs() },
            reprojection_error: t.rms_reprojection_error,
            parallax_deg: t.parallax_deg,
            behind_camera: t.behind_camera,
            low_parallax: t.low_parallax,
            high_reprojection: t.high_reprojection,
        })
        .collect();
    let mut distances = Vec::new();
    for i in 0..tri.len() {
        for j in i + 1..tri.len() {
            let (a, b) = (&tri[i], &tri[j]);
            let distance = (a.point - b.point).length();
            // σ only where both covariances exist (not behind a camera) and the distance has a
            // gradient (distinct points).
            let std_dev = match (a.covariance, b.covariance) {
                (Some(ca), Some(cb)) if !a.behind_camera && !b.behind_camera => {
                    self::distance(a.point, &ca, b.point, &cb).ok().map(|d| d.std_dev)
                }
                _ => None,
            };
            distances.push(MeasuredDistance { from: i, to: j, distance, std_dev });
        }
    }
    Ok(Measurement { config: *config, points, distances })
}
