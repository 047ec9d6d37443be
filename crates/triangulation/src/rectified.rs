//! Rectified rigs: the parallax formula, OpenCV's `Q` matrix and disparity maps to point clouds.

use glam::{DMat4, DVec2, DVec3, DVec4};
use parallax_camera_model::{DisparityMap, ProjectionMatrix};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{Result, TriangulationError};

/// The point of a rectified rig for pixel `(u, v)` of the left image with disparity
/// `d = u_left − u_right` (parallax method): `Z = f b / d`, `X = (u − cx) Z / f`,
/// `Y = (v − cy) Z / f`, in the unit of `baseline`.
///
/// Errors when `d ≤ 0` or anything is non-finite (a point at infinity or behind the rig).
pub fn parallax_point(u: f64, v: f64, disparity: f64, focal: f64, cx: f64, cy: f64, baseline: f64) -> Result<DVec3> {
    if !(focal.is_finite() && focal > 0.0 && baseline.is_finite() && baseline > 0.0 && cx.is_finite() && cy.is_finite())
    {
        return Err(TriangulationError::InvalidParameter(format!(
            "rectified geometry needs positive finite focal and baseline (f = {focal}, b = {baseline}, cx = {cx}, cy = {cy})"
        )));
    }
    if !(u.is_finite() && v.is_finite()) {
        return Err(TriangulationError::NonFinite { what: "pixel".into() });
    }
    if !(disparity.is_finite() && disparity > 0.0) {
        return Err(TriangulationError::InvalidDisparity { u, v, disparity });
    }
    let z = focal * baseline / disparity;
    Ok(DVec3::new((u - cx) * z / focal, (v - cy) * z / focal, z))
}

/// OpenCV's 4x4 disparity-to-depth matrix `Q` (`stereoRectify`, `reprojectImageTo3D`):
/// `[X Y Z W]ᵀ = Q [u v d 1]ᵀ`, the point is `(X/W, Y/W, Z/W)`.
///
/// For a horizontal rectified rig with focal `f`, principal points `(cx, cy)` (left) and
/// `cx'` (right) and `Tx = −b` (the right camera's `P2[0][3] / f`):
///
/// ```text
///     [ 1  0    0       −cx          ]
/// Q = [ 0  1    0       −cy          ]
///     [ 0  0    0        f           ]
///     [ 0  0  −1/Tx   (cx − cx')/Tx  ]
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReprojectionMatrix {
    /// Rows of `Q` (`rows[r][c]`).
    pub rows: [[f64; 4]; 4],
}

impl ReprojectionMatrix {
    /// A `Q` from its rows; errors on non-finite entries.
    pub fn new(rows: [[f64; 4]; 4]) -> Result<Self> {
        if rows.iter().flatten().any(|v| !v.is_finite()) {
            return Err(TriangulationError::NonFinite { what: "Q matrix".into() });
        }
        Ok(Self { rows })
    }

    /// `Q` of a horizontal rectified rig: focal `f` (px), left principal point `(cx, cy)`,
    /// right principal point column `cx_right`, baseline `b > 0` (length unit of the output).
    pub fn from_rectified(focal: f64, cx: f64, cy: f64, cx_right: f64, baseline: f64) -> Result<Self> {
        if !(focal.is_finite() && focal > 0.0 && baseline.is_finite() && baseline > 0.0) {
            return Err(TriangulationError::InvalidParameter(format!(
                "Q needs positive finite focal and baseline (f = {focal}, b = {baseline})"
            )));
        }
        let tx = -baseline;
        Self::new([
            [1.0, 0.0, 0.0, -cx],
            [0.0, 1.0, 0.0, -cy],
            [0.0, 0.0, 0.0, focal],
            [0.0, 0.0, -1.0 / tx, (cx - cx_right) / tx],
        ])
    }

    /// `Q` from the rectified projection matrices `P1 = K' [I | 0]` and `P2 = K' [I | (Tx, 0, 0)]`
    /// of a horizontal rig (OpenCV's `stereoRectify` outputs): `f = P1[0][0]`,
    /// `Tx = P2[0][3] / P2[0][0]`.
    pub fn from_projection_matrices(p1: &ProjectionMatrix, p2: &ProjectionMatrix) -> Result<Self> {
        let f = p1.rows[0][0];
        if !(f.is_finite() && f > 0.0 && p2.rows[0][0].is_finite() && p2.rows[0][0] > 0.0) {
            return Err(TriangulationError::InvalidParameter(format!("P1[0][0] = {f} is not a focal length")));
        }
        let tx = p2.rows[0][3] / p2.rows[0][0];
        if !(tx.is_finite() && tx != 0.0) {
            return Err(TriangulationError::InvalidParameter(format!(
                "P2[0][3] = {} gives no horizontal baseline",
                p2.rows[0][3]
            )));
        }
        let (cx, cy, cx2) = (p1.rows[0][2], p1.rows[1][2], p2.rows[0][2]);
        Self::new([
            [1.0, 0.0, 0.0, -cx],
            [0.0, 1.0, 0.0, -cy],
            [0.0, 0.0, 0.0, f],
            [0.0, 0.0, -1.0 / tx, (cx - cx2) / tx],
        ])
    }

    /// The matrix as glam (column-major).
    pub fn matrix(&self) -> DMat4 {
        DMat4::from_cols_array_2d(&self.rows).transpose()
    }

    /// The point of pixel `(u, v)` with disparity `d`; errors when `W ≤ 0` (zero disparity: a
    /// point at infinity; negative: behind the rig) or on non-finite input.
    pub fn reproject(&self, u: f64, v: f64, disparity: f64) -> Result<DVec3> {
        if !(u.is_finite() && v.is_finite()) {
            return Err(TriangulationError::NonFinite { what: "pixel".into() });
        }
        self.reproject_unchecked(u, v, disparity).ok_or(TriangulationError::InvalidDisparity { u, v, disparity })
    }

    /// The homogeneous `Q [u v d 1]ᵀ`.
    pub fn apply(&self, u: f64, v: f64, disparity: f64) -> DVec4 {
        let x = DVec4::new(u, v, disparity, 1.0);
        let r = |i: usize| DVec4::from_array(self.rows[i]).dot(x);
        DVec4::new(r(0), r(1), r(2), r(3))
    }

    #[inline]
    fn reproject_unchecked(&self, u: f64, v: f64, disparity: f64) -> Option<DVec3> {
        if !disparity.is_finite() {
            return None;
        }
        let h = self.apply(u, v, disparity);
        // W > 0 for a point in front of the rig (the sign convention of OpenCV's Q with Tx < 0).
        if h.w.is_nan() || h.w <= 0.0 {
            return None;
        }
        let p = h.truncate() / h.w;
        p.is_finite().then_some(p)
    }
}

/// Where the colours of a point cloud come from: an image of the disparity map's size,
/// row-major.
#[derive(Debug, Clone, Copy)]
pub enum PixelColors<'a> {
    /// One grey byte per pixel.
    Grey(&'a [u8]),
    /// Three bytes (R, G, B) per pixel.
    Rgb(&'a [u8]),
}

/// Colours attached to the points of a [`PointCloud`].
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub enum PointColors {
    /// No colour.
    #[default]
    None,
    /// One grey level per point.
    Grey(Vec<u8>),
    /// One RGB triple per point.
    Rgb(Vec<[u8; 3]>),
}

/// Tuning of [`disparity_to_point_cloud`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CloudConfig {
    /// Pixels with a disparity at or below this are skipped, pixels. Default 0 (only positive
    /// disparities give points in front of the rig).
    pub min_disparity: f64,
    /// Points farther than this (`Z`, length unit) are skipped. Default infinity (keep all).
    pub max_depth: f64,
}

impl Default for CloudConfig {
    fn default() -> Self {
        Self { min_disparity: 0.0, max_depth: f64::INFINITY }
    }
}

/// A point cloud with the pixel each point came from and how many pixels were skipped.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PointCloud {
    /// Points in the rectified left camera frame.
    pub points: Vec<DVec3>,
    /// Source pixel `(u, v)` of every point (empty when the cloud was not built from an image).
    pub pixels: Vec<[u32; 2]>,
    /// Optional colours, one per point.
    pub colors: PointColors,
    /// Pixels skipped because their disparity was invalid (NaN / marked invalid).
    pub skipped_invalid: usize,
    /// Pixels skipped because their disparity gave no finite point in front of the rig
    /// (zero or negative disparity, `≤ min_disparity`).
    pub skipped_non_positive: usize,
    /// Pixels skipped because the point was beyond `max_depth`.
    pub skipped_far: usize,
}

impl PointCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there is no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// Turns a disparity map into a point cloud through `Q` (OpenCV's `reprojectImageTo3D`
/// semantics), skipping and counting invalid pixels instead of writing placeholder points.
/// Rows are processed in parallel (rayon); the output is in row-major pixel order.
pub fn disparity_to_point_cloud(
    map: &DisparityMap,
    q: &ReprojectionMatrix,
    config: &CloudConfig,
    colors: Option<PixelColors<'_>>,
) -> Result<PointCloud> {
    let (w, h) = (map.width(), map.height());
    if map.data().len() != w * h {
        return Err(TriangulationError::SizeMismatch(format!(
            "disparity map {w}x{h} holds {} values",
            map.data().len()
        )));
    }
    match colors {
        Some(PixelColors::Grey(g)) if g.len() != w * h => {
            return Err(TriangulationError::SizeMismatch(format!(
                "grey image has {} pixels, disparity map {w}x{h}",
                g.len()
            )));
        }
        Some(PixelColors::Rgb(c)) if c.len() != 3 * w * h => {
            return Err(TriangulationError::SizeMismatch(format!(
                "RGB image has {} bytes, disparity map {w}x{h} needs {}",
                c.len(),
                3 * w * h
            )));
        }
        _ => {}
    }
    if config.min_disparity.is_nan() || config.max_depth.is_nan() {
        return Err(TriangulationError::InvalidParameter("cloud config holds NaN".into()));
    }
    struct Row {
        points: Vec<DVec3>,
        pixels: Vec<[u32; 2]>,
        colors: Vec<[u8; 3]>,
        invalid: usize,
        non_positive: usize,
        far: usize,
    }
    let rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map(|v| {
            let mut row = Row {
                points: Vec::with_capacity(w),
                pixels: Vec::with_capacity(w),
                colors: Vec::with_capacity(if colors.is_some() { w } else { 0 }),
                invalid: 0,
                non_positive: 0,
                far: 0,
            };
            for u in 0..w {
                let i = v * w + u;
                let d = map.data()[i];
                if !d.is_finite() {
                    row.invalid += 1;
                    continue;
                }
                let d = d as f64;
                if d <= config.min_disparity {
                    row.non_positive += 1;
                    continue;
                }
                let Some(p) = q.reproject_unchecked(u as f64, v as f64, d) else {
                    row.non_positive += 1;
                    continue;
                };
                if p.z > config.max_depth {
                    row.far += 1;
                    continue;
                }
                row.points.push(p);
                row.pixels.push([u as u32, v as u32]);
                match colors {
                    Some(PixelColors::Grey(g)) => row.colors.push([g[i]; 3]),
                    Some(PixelColors::Rgb(c)) => row.colors.push([c[3 * i], c[3 * i + 1], c[3 * i + 2]]),
                    None => {}
                }
            }
            row
        })
        .collect();
    let total: usize = rows.iter().map(|r| r.points.len()).sum();
    let mut cloud =
        PointCloud { points: Vec::with_capacity(total), pixels: Vec::with_capacity(total), ..Default::default() };
    let mut cols = Vec::with_capacity(if colors.is_some() { total } else { 0 });
    for r in rows {
        cloud.points.extend(r.points);
        cloud.pixels.extend(r.pixels);
        cols.extend(r.colors);
        cloud.skipped_invalid += r.invalid;
        cloud.skipped_non_positive += r.non_positive;
        cloud.skipped_far += r.far;
    }
    cloud.colors = match colors {
        None => PointColors::None,
        Some(PixelColors::Grey(_)) => PointColors::Grey(cols.iter().map(|c| c[0]).collect()),
        Some(PixelColors::Rgb(_)) => PointColors::Rgb(cols),
    };
    Ok(cloud)
}

/// Depth standard deviation of a rectified rig for a disparity standard deviation `σ_d`
/// (first order): `σ_Z = Z² σ_d / (f b)`.
pub fn depth_std_dev(z: f64, focal: f64, baseline: f64, disparity_sigma: f64) -> f64 {
    z * z * disparity_sigma / (focal * baseline)
}

/// First-order covariance of the parallax point of `(u, v, d)` when `u`, `v` and `d` have
/// independent errors of standard deviation `sigma_uv` (each of `u`, `v`) and `sigma_d`
/// (the disparity), pixels. Errors as [`parallax_point`].
pub fn parallax_covariance(
    pixel: DVec2,
    disparity: f64,
    focal: f64,
    cx: f64,
    cy: f64,
    baseline: f64,
    sigma_uv: f64,
    sigma_d: f64,
) -> Result<glam::DMat3> {
    let p = parallax_point(pixel.x, pixel.y, disparity, focal, cx, cy, baseline)?;
    let z = p.z;
    // ∂(X, Y, Z)/∂(u, v, d)
    let ju = DVec3::new(z / focal, 0.0, 0.0);
    let jv = DVec3::new(0.0, z / focal, 0.0);
    let jd = -p / disparity;
    let outer = |a: DVec3, b: DVec3| glam::DMat3::from_cols(a * b.x, a * b.y, a * b.z);
    Ok(outer(ju, ju) * (sigma_uv * sigma_uv)
        + outer(jv, jv) * (sigma_uv * sigma_uv)
        + outer(jd, jd) * (sigma_d * sigma_d))
}
