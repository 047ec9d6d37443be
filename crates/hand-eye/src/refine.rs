//! Nonlinear refinement: maximum likelihood over the absolute station poses.

use faer::MatMut;
use glam::{DMat3, DVec3};
use parallax_camera_model::Isometry3;
use parallax_least_squares::{EvaluationError, LmConfig, Problem, levenberg_marquardt, nearest_rotation};
use serde::{Deserialize, Serialize};

use crate::linear::skew;
use crate::motion::{Motion, Setup};
use crate::{HandEyeError, Result};

/// Noise model and options of [`refine`].
///
/// The poses are modelled as right-multiplied noise, `G̃ = G · (Exp ω, v)` and `C̃ = C · (Exp ω, v)`
/// with independent zero-mean Gaussian `ω`, `v` per axis. Only the *ratios* of the four sigmas
/// shape the estimate; the reported covariance is rescaled by the fitted variance factor, so a
/// wrong overall level does not make the standard deviations wrong.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RefineConfig {
    /// Estimate the fixed frame (`base_from_board` eye-in-hand, `gripper_from_board`
    /// eye-to-hand) together with `X` and fit the absolute poses (maximum likelihood, default).
    /// When false only `X` is estimated, from the residuals of `A X = X B` over the motions
    /// (a cheaper, approximate weighting: the motions share stations and are correlated).
    pub estimate_board: bool,
    /// Robot pose rotation noise per axis, degrees.
    pub robot_rotation_sigma_deg: f64,
    /// Robot pose translation noise per axis, in the scene length unit (default 0.001: 1 mm in metres).
    pub robot_translation_sigma: f64,
    /// Camera pose (`camera_from_board`) rotation noise per axis, degrees.
    pub camera_rotation_sigma_deg: f64,
    /// Camera pose translation noise per axis, scene length unit.
    pub camera_translation_sigma: f64,
    /// Times the per-station covariances are re-linearised at the current estimate (≥ 1).
    pub passes: usize,
    /// Levenberg–Marquardt settings.
    pub lm: LmConfig,
}

impl Default for RefineConfig {
    fn default() -> Self {
        Self {
            estimate_board: true,
            robot_rotation_sigma_deg: 0.1,
            robot_translation_sigma: 0.001,
            camera_rotation_sigma_deg: 0.1,
            camera_translation_sigma: 0.001,
            passes: 2,
            lm: LmConfig::default(),
        }
    }
}

impl RefineConfig {
    fn validate(&self) -> Result<()> {
        let s = [
            self.robot_rotation_sigma_deg,
            self.robot_translation_sigma,
            self.camera_rotation_sigma_deg,
            self.camera_translation_sigma,
        ];
        if s.iter().any(|v| !(v.is_finite() && *v >= 0.0)) || s[0] + s[2] <= 0.0 || s[1] + s[3] <= 0.0 {
            return Err(HandEyeError::InvalidConfig(format!(
                "refinement sigmas must be finite and non-negative with a positive rotation and translation total, got {s:?}"
            )));
        }
        Ok(())
    }
}

/// Result of [`refine`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    /// The refined `X` (`gripper_from_camera` or `base_from_camera`).
    pub transform: Isometry3,
    /// The fixed frame (`base_from_board` or `gripper_from_board`): estimated when
    /// `estimate_board`, else the chordal mean over the stations.
    pub board: Isometry3,
    /// Covariance of `X`'s error `(ω, δt)`: `R_true = Exp(ω) R`, `t_true = t + δt`
    /// (radians, length unit), row-major 6x6; `None` when not identifiable.
    pub covariance: Option<[[f64; 6]; 6]>,
    /// `√diag(covariance)`: `[ωx, ωy, ωz]` radians then `[tx, ty, tz]`.
    pub std_devs: Option<[f64; 6]>,
    /// Fitted variance factor `σ̂²` (≈ 1 when the noise model's sigmas are right).
    pub variance_factor: f64,
    /// Weighted RMS of the whitened residuals.
    pub rms: f64,
    /// Levenberg–Marquardt iterations over all passes.
    pub iterations: usize,
}

fn pose_to_params(p: &Isometry3, out: &mut [f64]) {
    let r = p.rvec();
    out[..3].copy_from_slice(&r.to_array());
    out[3..6].copy_from_slice(&p.translation.to_array());
}

fn params_to_pose(p: &[f64]) -> Isometry3 {
    Isometry3::from_rvec_tvec(DVec3::new(p[0], p[1], p[2]), DVec3::new(p[3], p[4], p[5]))
}

/// `(rvec, t)` of a transform close to identity (the error vector of the noise model).
fn error_vector(e: &Isometry3) -> [f64; 6] {
    let r = e.rvec();
    [r.x, r.y, r.z, e.translation.x, e.translation.y, e.translation.z]
}

/// Lower Cholesky factor of a symmetric positive definite 6x6 matrix, inverted:
/// returns `S = L⁻¹` so that `Sᵀ S = Σ⁻¹` (the whitening matrix).
fn whitening(sigma: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
    let mut l = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..=i {
            let s = sigma[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i == j {
                if s.is_nan() || s <= 0.0 {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    // Forward substitution for L S = I.
    let mut inv = [[0.0; 6]; 6];
    for c in 0..6 {
        for i in 0..6 {
            let mut s = if i == c { 1.0 } else { 0.0 };
            for k in 0..i {
                s -= l[i][k] * inv[k][c];
            }
            inv[i][c] = s / l[i][i];
        }
    }
    Some(inv)
}

/// Covariance of the station error `Log(C̃⁻¹ X⁻¹ G̃⁻¹ W)` to first order:
/// `Σ_c + J Σ_g Jᵀ`, with `J = [[Rᵀ, 0], [−Rᵀ[t]×, Rᵀ]]` of `M = gripper_from_board` (the
/// robot's gripper-frame noise seen from the board frame).
fn station_covariance(m: &Isometry3, cfg: &RefineConfig) -> [[f64; 6]; 6] {
    let (gr, gt) = (cfg.robot_rotation_sigma_deg.to_radians().powi(2), cfg.robot_translation_sigma.powi(2));
    let (cr, ct) = (cfg.camera_rotation_sigma_deg.to_radians().powi(2), cfg.camera_translation_sigma.powi(2));
    let rt = m.rotation_matrix().transpose();
    let b = -(rt * skew(m.translation));
    let mut j = [[0.0; 6]; 6];
    for r in 0..3 {
        for c in 0..3 {
            j[r][c] = rt.col(c)[r];
            j[3 + r][c] = b.col(c)[r];
            j[3 + r][3 + c] = rt.col(c)[r];
        }
    }
    let d = [gr, gr, gr, gt, gt, gt];
    let mut s = [[0.0; 6]; 6];
    for r in 0..6 {
        for c in 0..6 {
            s[r][c] = (0..6).map(|k| j[r][k] * d[k] * j[c][k]).sum::<f64>();
        }
        s[r][r] += if r < 3 { cr } else { ct };
    }
    s
}

/// Chordal mean of `G_i X C_i` (the fixed frame implied by every station).
pub(crate) fn mean_board(g: &[Isometry3], c: &[Isometry3], x: &Isometry3) -> Result<Isometry3> {
    let mut rs = DMat3::ZERO;
    let mut t = DVec3::ZERO;
    for (gi, ci) in g.iter().zip(c) {
        let w = *gi * *x * *ci;
        rs += w.rotation_matrix();
        t += w.translation;
    }
    let r = nearest_rotation(rs).map_err(|e| HandEyeError::numerical("board mean", e))?;
    Isometry3::from_rotation_translation(r, t / g.len() as f64).map_err(|e| HandEyeError::numerical("board mean", e))
}

/// Absolute-pose problem: parameters `[X (rvec, t), W (rvec, t)]`, one whitened 6-residual per station.
struct AbsoluteProblem {
    g_inv: Vec<Isometry3>,
    c_inv: Vec<Isometry3>,
    whiten: Vec<[[f64; 6]; 6]>,
}

/// Relative-motion problem: parameters `X`, one 6-residual per motion.
struct RelativeProblem<'a> {
    motions: &'a [Motion],
    scale: [f64; 6],
}

fn retract_poses(params: &[f64], delta: &[f64], out: &mut [f64]) {
    for k in 0..params.len() / 6 {
        let p = params_to_pose(&params[6 * k..6 * k + 6]);
        let d: [f64; 6] = std::array::from_fn(|i| delta[6 * k + i]);
        pose_to_params(&p.retract(&d), &mut out[6 * k..6 * k + 6]);
    }
}

/// Central-difference Jacobian with respect to the retraction step. Written out numerically on
/// purpose: at most 12 parameters, each residual a few pose products, and the step 1e-6 keeps
/// the derivative exact to ~1e-10 relative, well below the noise.
fn numeric_jacobian<P: Problem + ?Sized>(
    p: &P,
    params: &[f64],
    residual: impl Fn(&[f64], &mut [f64]),
    mut jac: MatMut<'_, f64>,
) {
    let n = params.len();
    let m = p.num_residuals();
    let h = 1e-6;
    let mut plus = vec![0.0; n];
    let mut minus = vec![0.0; n];
    let mut rp = vec![0.0; m];
    let mut rm = vec![0.0; m];
    for k in 0..n {
        let mut d = vec![0.0; n];
        d[k] = h;
        p.retract(params, &d, &mut plus);
        d[k] = -h;
        p.retract(params, &d, &mut minus);
        residual(&plus, &mut rp);
        residual(&minus, &mut rm);
        for i in 0..m {
            jac[(i, k)] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
}

impl AbsoluteProblem {
    fn residual(&self, params: &[f64], r: &mut [f64]) {
        let x_inv = params_to_pose(&params[..6]).inverse();
        let w = params_to_pose(&params[6..12]);
        for (k, (gi, ci)) in self.g_inv.iter().zip(&self.c_inv).enumerate() {
            let e = error_vector(&(*ci * x_inv * *gi * w));
            let s = &self.whiten[k];
            for row in 0..6 {
                r[6 * k + row] = (0..=row).map(|c| s[row][c] * e[c]).sum();
            }
        }
    }
}

impl Problem for AbsoluteProblem {
    fn num_params(&self) -> usize {
        12
    }
    fn num_residuals(&self) -> usize {
        6 * self.g_inv.len()
    }
    fn evaluate(
        &self,
        params: &[f64],
        r: &mut [f64],
        jac: Option<MatMut<'_, f64>>,
    ) -> std::result::Result<(), EvaluationError> {
        self.residual(params, r);
        if let Some(j) = jac {
            numeric_jacobian(self, params, |p, out| self.residual(p, out), j);
        }
        Ok(())
    }
    fn retract(&self, params: &[f64], delta: &[f64], out: &mut [f64]) {
        retract_poses(params, delta, out);
    }
}

impl RelativeProblem<'_> {
    fn residual(&self, params: &[f64], r: &mut [f64]) {
        let x = params_to_pose(&params[..6]);
        let x_inv = x.inverse();
        for (k, m) in self.motions.iter().enumerate() {
            let e = error_vector(&(m.b.inverse() * x_inv * m.a * x));
            for i in 0..6 {
                r[6 * k + i] = e[i] / self.scale[i];
            }
        }
    }
}

impl Problem for RelativeProblem<'_> {
    fn num_params(&self) -> usize {
        6
    }
    fn num_residuals(&self) -> usize {
        6 * self.motions.len()
    }
    fn evaluate(
        &self,
        params: &[f64],
        r: &mut [f64],
        jac: Option<MatMut<'_, f64>>,
    ) -> std::result::Result<(), EvaluationError> {
        self.residual(params, r);
        if let Some(j) = jac {
            numeric_jacobian(self, params, |p, out| self.residual(p, out), j);
        }
        Ok(())
    }
    fn retract(&self, params: &[f64], delta: &[f64], out: &mut [f64]) {
        retract_poses(params, delta, out);
    }
}

/// Converts the covariance of `X`'s left-perturbation step `(ω, v)` (`t ← Exp(ω) t + v`) into
/// the covariance of `(ω, δt)`: `δt = −[t]× ω + v`.
fn covariance_of_x(cov: &faer::Mat<f64>, t: DVec3) -> [[f64; 6]; 6] {
    let mut j = [[0.0; 6]; 6];
    let b = -skew(t);
    for r in 0..3 {
        j[r][r] = 1.0;
        j[3 + r][3 + r] = 1.0;
        for c in 0..3 {
            j[3 + r][c] = b.col(c)[r];
        }
    }
    let mut out = [[0.0; 6]; 6];
    for r in 0..6 {
        for c in 0..6 {
            let mut s = 0.0;
            for k in 0..6 {
                for l in 0..6 {
                    s += j[r][k] * cov[(k, l)] * j[c][l];
                }
            }
            out[r][c] = s;
        }
    }
    out
}

/// Refines `X` from an initial estimate by Levenberg–Marquardt.
///
/// `robot` are the robot poses in the form `G_i X C_i = W` (`base_from_gripper` eye-in-hand,
/// `gripper_from_base` eye-to-hand: see [`crate::Setup`]), `camera_from_board` the camera
/// poses, `motions` the relative motions (used when `estimate_board` is false).
///
/// With `estimate_board` (default), the unknowns are `X` and `W` and every station contributes
/// `Log(C̃_i⁻¹ X⁻¹ G̃_i⁻¹ W)`, whitened by its first-order covariance under the noise model of
/// [`RefineConfig`] (robot noise is carried through the lever arm of the board): maximum
/// likelihood to first order. The covariance is `σ̂² (JᵀJ)⁻¹`.
pub(crate) fn refine(
    robot: &[Isometry3],
    camera_from_board: &[Isometry3],
    motions: &[Motion],
    setup: Setup,
    initial: &Isometry3,
    cfg: &RefineConfig,
) -> Result<Refinement> {
    cfg.validate()?;
    let mut x = *initial;
    let mut w = mean_board(robot, camera_from_board, &x)?;
    let passes = cfg.passes.max(1);
    let mut iterations = 0;
    let mut report = None;
    let lm_err = |e| HandEyeError::numerical("refinement", e);
    if cfg.estimate_board {
        for _ in 0..passes {
            let mut whiten = Vec::with_capacity(robot.len());
            for (k, ci) in camera_from_board.iter().enumerate() {
                let m = match setup {
                    Setup::EyeInHand => x * *ci,
                    Setup::EyeToHand => w,
                };
                let s = whitening(&station_covariance(&m, cfg)).ok_or_else(|| {
                    HandEyeError::numerical(
                        "refinement",
                        format!("noise covariance of station {k} is not positive definite"),
                    )
                })?;
                whiten.push(s);
            }
            let problem = AbsoluteProblem {
                g_inv: robot.iter().map(Isometry3::inverse).collect(),
                c_inv: camera_from_board.iter().map(Isometry3::inverse).collect(),
                whiten,
            };
            let mut p0 = [0.0; 12];
            pose_to_params(&x, &mut p0[..6]);
            pose_to_params(&w, &mut p0[6..]);
            let rep = levenberg_marquardt(&problem, &p0, &cfg.lm).map_err(lm_err)?;
            x = params_to_pose(&rep.params[..6]);
            w = params_to_pose(&rep.params[6..12]);
            iterations += rep.iterations;
            report = Some(rep);
        }
    } else {
        let (gr, gt) = (cfg.robot_rotation_sigma_deg.to_radians(), cfg.robot_translation_sigma);
        let (cr, ct) = (cfg.camera_rotation_sigma_deg.to_radians(), cfg.camera_translation_sigma);
        let sr = (2.0 * (gr * gr + cr * cr)).sqrt();
        let st = (2.0 * (gt * gt + ct * ct)).sqrt();
        let problem = RelativeProblem { motions, scale: [sr, sr, sr, st, st, st] };
        let mut p0 = [0.0; 6];
        pose_to_params(&x, &mut p0);
        let rep = levenberg_marquardt(&problem, &p0, &cfg.lm).map_err(lm_err)?;
        x = params_to_pose(&rep.params);
        w = mean_board(robot, camera_from_board, &x)?;
        iterations += rep.iterations;
        report = Some(rep);
    }
    let rep = report.expect("at least one pass");
    let covariance = rep.covariance.as_ref().map(|c| covariance_of_x(c, x.translation));
    let std_devs = covariance.map(|c| std::array::from_fn(|i| c[i][i].max(0.0).sqrt()));
    if !x.is_finite() || !w.is_finite() {
        return Err(HandEyeError::numerical("refinement", "diverged to a non-finite pose"));
    }
    Ok(Refinement {
        transform: x,
        board: w,
        covariance,
        std_devs,
        variance_factor: rep.sigma2,
        rms: rep.rms(),
        iterations,
    })
}

/// The refinement cost `½‖r‖²` at `x` (used to pick the best linear start).
pub(crate) fn initial_cost(
    robot: &[Isometry3],
    camera_from_board: &[Isometry3],
    setup: Setup,
    x: &Isometry3,
    cfg: &RefineConfig,
) -> Result<f64> {
    let w = mean_board(robot, camera_from_board, x)?;
    let mut cost = 0.0;
    for (gi, ci) in robot.iter().zip(camera_from_board) {
        let m = match setup {
            Setup::EyeInHand => *x * *ci,
            Setup::EyeToHand => w,
        };
        let s = whitening(&station_covariance(&m, cfg))
            .ok_or_else(|| HandEyeError::numerical("refinement", "noise covariance is not positive definite"))?;
        let e = error_vector(&(ci.inverse() * x.inverse() * gi.inverse() * w));
        for row in 0..6 {
            let v: f64 = (0..=row).map(|c| s[row][c] * e[c]).sum();
            cost += 0.5 * v * v;
        }
    }
    Ok(cost)
}
