//! Projection uncertainty of a calibrated camera (mrcal's idea): how far the projected pixel of a
//! fixed point moves when the calibration is repeated with new corner noise.
//!
//! The calibration results carry only the standard deviations of the intrinsics; the joint
//! covariance of intrinsics and view poses is rebuilt here from the inputs (board, grids, camera,
//! poses): the Jacobian of every corner's projection with respect to the free intrinsics (the
//! flags of [`CalibrationConfig`], as `planar-calibration` parametrises them) and the six-parameter
//! left perturbation of each view pose, `Σ = σ² (JᵀJ)⁻¹` with `σ² = Σ‖e‖² / (2N − n)`.
//!
//! A point is fixed in the world, not in the camera frame: the camera frame itself is an
//! estimate. As mrcal does, the pixel `q` at range `d` gives the camera-frame point `p`, which is
//! carried into every board frame with the estimated poses; a re-calibration maps it back with
//! its own poses and averages (`p' = (1/N) Σ_v T'_v T_v⁻¹ p`) before projecting with its own
//! intrinsics. To first order `δq = G_i δθ_i + (1/N) A Σ_v δξ_v`, `A = ∂q/∂ξ` at the identity,
//! so `Var q = G_i Σ_ii G_iᵀ + (1/N)(G_i S + (G_i S)ᵀ) + (1/N²) A P Aᵀ` with `S = Σ_v Σ_{i,v}`
//! (`k × 6`) and `P = Σ_{v,w} Σ_{v,w}` (`6 × 6`): each pixel costs a few small products.

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, CornerGrid, Isometry3, LensModel};
use parallax_planar_calibration::CalibrationConfig;

use crate::{PipelineError, Result};

/// The free intrinsic parameters of a calibration: slot in `(fx, fy, cx, cy, skew, l0, …, l7)`
/// (`l` the lens parameters in the model's order: `k1 k2 p1 p2 k3 k4 k5 k6`, `k1..k4` or `ξ α`),
/// its parameter index and the factor tying it to that parameter (`fx = a·fy` under a fixed
/// aspect ratio).
pub fn free_intrinsics(config: &CalibrationConfig, camera: &Camera) -> Vec<(usize, usize, f64)> {
    let mut out = vec![(1, 0, 1.0)];
    let mut n = 1;
    let mut free = |out: &mut Vec<(usize, usize, f64)>, slot: usize| {
        out.push((slot, n, 1.0));
        n += 1;
    };
    if config.fix_aspect_ratio {
        out.push((0, 0, camera.intrinsics.fx / camera.intrinsics.fy));
    } else {
        free(&mut out, 0);
    }
    if !config.fix_principal_point {
        free(&mut out, 2);
        free(&mut out, 3);
    }
    if config.estimate_skew {
        free(&mut out, 4);
    }
    let wide: &[bool] = match config.lens {
        LensModel::BrownConrady => &[],
        LensModel::KannalaBrandt => &[config.fix_k1, config.fix_k2, config.fix_k3, config.fix_k4],
        LensModel::DoubleSphere => &[config.fix_xi, config.fix_alpha],
    };
    if config.lens.is_wide() {
        for (i, hold) in wide.iter().enumerate() {
            if !hold {
                free(&mut out, 5 + i);
            }
        }
        return out;
    }
    for (slot, hold) in [(5, config.fix_k1), (6, config.fix_k2), (9, config.fix_k3)] {
        if !hold {
            free(&mut out, slot);
        }
    }
    if !config.zero_tangential {
        free(&mut out, 7);
        free(&mut out, 8);
    }
    for (slot, hold) in [(10, config.fix_k4), (11, config.fix_k5), (12, config.fix_k6)] {
        if config.rational_model && !hold {
            free(&mut out, slot);
        }
    }
    out
}

/// The covariance of a calibrated camera reduced to what projection uncertainty needs.
#[derive(Debug, Clone)]
pub struct ProjectionUncertainty {
    camera: Camera,
    free: Vec<(usize, usize, f64)>,
    k: usize,
    views: usize,
    /// `Σ_ii`, `k × k` row-major.
    cov_ii: Vec<f64>,
    /// `S = Σ_v Σ_{i,v}`, `k × 6`.
    s: Vec<[f64; 6]>,
    /// `P = Σ_{v,w} Σ_{v,w}`.
    p: [[f64; 6]; 6],
    /// Estimated corner noise per coordinate, pixels.
    pub sigma_px: f64,
    /// Mean camera-to-board-origin distance of the views (board units).
    pub mean_distance: f64,
}

fn full_row(j: &parallax_camera_model::ProjectionJacobians, r: usize) -> [f64; 13] {
    let mut a = [0.0; 13];
    a[..5].copy_from_slice(&j.d_intrinsics[r]);
    // `d_distortion` holds the lens parameters in the model's order, the order of slots 5..13.
    a[5..].copy_from_slice(&j.d_distortion[r]);
    a
}

impl ProjectionUncertainty {
    /// Builds the covariance of `camera` calibrated from `grids` seen at `camera_from_board`
    /// with the flags of `config`.
    pub fn new(
        camera: &Camera,
        board: &Chessboard,
        grids: &[CornerGrid],
        camera_from_board: &[Isometry3],
        config: &CalibrationConfig,
    ) -> Result<Self> {
        if grids.len() != camera_from_board.len() || grids.is_empty() {
            return Err(PipelineError::Input(format!(
                "projection uncertainty: {} grids for {} poses",
                grids.len(),
                camera_from_board.len()
            )));
        }
        let free = free_intrinsics(config, camera);
        let k = free.iter().map(|f| f.1).max().map_or(0, |m| m + 1);
        let views = grids.len();
        let n = k + 6 * views;
        let mut jtj = faer::Mat::<f64>::zeros(n, n);
        let object = board.object_points();
        let (mut cost, mut m) = (0.0, 0usize);
        for (v, (g, pose)) in grids.iter().zip(camera_from_board).enumerate() {
            if g.corners.len() != object.len() {
                return Err(PipelineError::Input(format!(
                    "projection uncertainty: view {v} has {} corners, the board {}",
                    g.corners.len(),
                    object.len()
                )));
            }
            for (x, q) in object.iter().zip(&g.corners) {
                let j = camera.project_with_jacobians(pose, *x).map_err(|e| PipelineError::Input(e.to_string()))?;
                let e = *q - j.pixel;
                cost += 0.5 * e.length_squared();
                m += 2;
                for r in 0..2 {
                    let full = full_row(&j, r);
                    let mut row: Vec<(usize, f64)> = Vec::with_capacity(k + 6);
                    let mut intr = vec![0.0; k];
                    for &(slot, idx, scale) in &free {
                        intr[idx] += scale * full[slot];
                    }
                    row.extend(intr.into_iter().enumerate());
                    row.extend((0..6).map(|c| (k + 6 * v + c, j.d_pose[r][c])));
                    for &(a, va) in &row {
                        for &(b, vb) in &row {
                            jtj[(a, b)] += va * vb;
                        }
                    }
                }
            }
        }
        let cov = parallax_least_squares::covariance_from_normal_equations(&jtj, cost, m, n).ok_or_else(|| {
            PipelineError::Input(format!(
                "projection uncertainty: the normal equations of {n} parameters from {m} residuals are singular"
            ))
        })?;
        let cov_ii = (0..k * k).map(|i| cov[(i / k, i % k)]).collect();
        let s = (0..k).map(|i| std::array::from_fn(|c| (0..views).map(|v| cov[(i, k + 6 * v + c)]).sum())).collect();
        let mut p = [[0.0; 6]; 6];
        for v in 0..views {
            for w in 0..views {
                for a in 0..6 {
                    for b in 0..6 {
                        p[a][b] += cov[(k + 6 * v + a, k + 6 * w + b)];
                    }
                }
            }
        }
        let mean_distance = camera_from_board.iter().map(|t| t.translation.length()).sum::<f64>() / views as f64;
        Ok(Self {
            camera: *camera,
            free,
            k,
            views,
            cov_ii,
            s,
            p,
            sigma_px: (2.0 * cost / (m - n) as f64).sqrt(),
            mean_distance,
        })
    }

    /// The 2x2 covariance (pixels²) of the projection of the world point seen at pixel `q` at
    /// range `distance` (board units).
    pub fn covariance_at(&self, q: DVec2, distance: f64) -> Result<[[f64; 2]; 2]> {
        let ray = self.camera.unproject(q).map_err(|e| PipelineError::Input(e.to_string()))?;
        let p: DVec3 = ray.normalize() * distance;
        let j = self
            .camera
            .project_with_jacobians(&Isometry3::IDENTITY, p)
            .map_err(|e| PipelineError::Input(e.to_string()))?;
        let k = self.k;
        let mut g = [vec![0.0; k], vec![0.0; k]];
        for r in 0..2 {
            let full = full_row(&j, r);
            for &(slot, idx, scale) in &self.free {
                g[r][idx] += scale * full[slot];
            }
        }
        let a = j.d_pose;
        let nv = self.views as f64;
        let mut c = [[0.0; 2]; 2];
        for r in 0..2 {
            for t in 0..2 {
                let mut ii = 0.0;
                for x in 0..k {
                    for y in 0..k {
                        ii += g[r][x] * self.cov_ii[x * k + y] * g[t][y];
                    }
                }
                // G_i S Aᵀ and its transpose.
                let (mut ip, mut pi) = (0.0, 0.0);
                for x in 0..k {
                    for b in 0..6 {
                        ip += g[r][x] * self.s[x][b] * a[t][b];
                        pi += g[t][x] * self.s[x][b] * a[r][b];
                    }
                }
                let mut pp = 0.0;
                for x in 0..6 {
                    for y in 0..6 {
                        pp += a[r][x] * self.p[x][y] * a[t][y];
                    }
                }
                c[r][t] = ii + (ip + pi) / nv + pp / (nv * nv);
            }
        }
        Ok(c)
    }

    /// The worst-direction σ (square root of the larger eigenvalue of the 2x2 covariance),
    /// pixels.
    pub fn sigma_at(&self, q: DVec2, distance: f64) -> Result<f64> {
        Ok(worst_sigma(&self.covariance_at(q, distance)?))
    }

    /// 1σ of every intrinsic parameter from this covariance, in the slot order `(fx, fy, cx, cy,
    /// skew, k1, k2, p1, p2, k3, k4, k5, k6)` (`None` = held fixed; a tied `fx` gets the
    /// propagated value) — what the calibration reports, for comparison.
    pub fn intrinsic_std_devs(&self) -> [Option<f64>; 13] {
        let mut out = [None; 13];
        for &(slot, idx, scale) in &self.free {
            out[slot] = Some(scale.abs() * self.cov_ii[idx * self.k + idx].max(0.0).sqrt());
        }
        out
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }
}

/// Square root of the larger eigenvalue of a symmetric 2x2 matrix.
pub fn worst_sigma(c: &[[f64; 2]; 2]) -> f64 {
    let (a, b, d) = (c[0][0], 0.5 * (c[0][1] + c[1][0]), c[1][1]);
    let half_tr = 0.5 * (a + d);
    let disc = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    (half_tr + disc).max(0.0).sqrt()
}

/// The projection of the world point at pixel `q`, range `distance` of a reference calibration
/// (`camera_ref`, poses `ref_poses`) through another calibration of the same views (`camera`,
/// `poses`): the point is carried into each board frame by the reference poses, back by the
/// other poses, averaged, and projected. This is the quantity whose spread
/// [`ProjectionUncertainty::sigma_at`] predicts.
pub fn reprojected(
    camera_ref: &Camera,
    ref_poses: &[Isometry3],
    camera: &Camera,
    poses: &[Isometry3],
    q: DVec2,
    distance: f64,
) -> Result<DVec2> {
    let p = camera_ref.unproject(q).map_err(|e| PipelineError::Input(e.to_string()))?.normalize() * distance;
    let mean =
        ref_poses.iter().zip(poses).map(|(r, t)| t.transform_point(r.inverse().transform_point(p))).sum::<DVec3>()
            / poses.len() as f64;
    camera.project(mean).map_err(|e| PipelineError::Input(e.to_string()))
}
