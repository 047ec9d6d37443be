//! Nonlinear refinement: maximum likelihood over the absolute station poses.
//!
//! Runs on translations divided by the data's length scale `L` (see [`crate::calibrate`]), so
//! every tolerance, step and starting value is unit-free; the result is scaled back.

use faer::MatMut;
use glam::{DMat3, DVec3};
use parallax_camera_model::Isometry3;
use parallax_least_squares::{
    EvaluationError, LmConfig, LmReport, Problem, StopReason, levenberg_marquardt, nearest_rotation,
};
use serde::{Deserialize, Serialize};

use crate::linear::skew;
use crate::motion::{Motion, Setup};
use crate::{HandEyeError, Result};

/// Noise model and options of the refinement.
///
/// The poses are modelled as right-multiplied noise, `G̃ = G · (Exp ω, v)` and `C̃ = C · (Exp ω, v)`
/// with independent zero-mean Gaussian `ω`, `v` per axis. Only the *ratios* of the four sigmas
/// shape the estimate; the reported covariance is rescaled by the fitted variance factor, so a
/// wrong overall level does not make the standard deviations wrong.
///
/// **Units.** Rotation sigmas are in degrees (unit-free). With `estimate_translation_noise`
/// (default) the translation sigmas are *estimated from the data* — by variance-component
/// estimation of the rotation and translation parts of the station residuals, re-run after each
/// pass until it settles — and the two translation fields only give the robot : camera ratio;
/// the result then does not depend on the length unit. With `estimate_translation_noise = false`
/// the translation sigmas are taken as given, **in the length unit of the poses** (1 mm is
/// `0.001` for poses in metres and `1.0` for poses in millimetres).
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
    /// Robot pose translation noise per axis, in the length unit of the poses (used as given
    /// only when `estimate_translation_noise` is false; otherwise only its ratio to
    /// `camera_translation_sigma` matters).
    pub robot_translation_sigma: f64,
    /// Camera pose (`camera_from_board`) rotation noise per axis, degrees.
    pub camera_rotation_sigma_deg: f64,
    /// Camera pose translation noise per axis, length unit of the poses (see
    /// `robot_translation_sigma`).
    pub camera_translation_sigma: f64,
    /// Estimate the translation noise level from the data (default; unit-free). When false, the
    /// translation sigmas are used as given, in the data's length unit.
    pub estimate_translation_noise: bool,
    /// Minimum number of passes: the per-station covariances are re-linearised at the current
    /// estimate after each pass (≥ 1).
    pub passes: usize,
    /// Maximum number of passes while the estimated translation noise still changes by more
    /// than `noise_tolerance` (relative); reaching it leaves the refinement unconverged.
    pub max_passes: usize,
    /// Relative change of the estimated translation sigma below which its estimation has settled.
    pub noise_tolerance: f64,
    /// Return an unconverged refinement (iteration cap, no improvement, or unsettled noise
    /// estimate) with `converged: false` instead of an error.
    pub allow_unconverged: bool,
    /// Levenberg–Marquardt settings (tolerances apply to the normalised, unit-free problem).
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
            estimate_translation_noise: true,
            passes: 2,
            max_passes: 20,
            noise_tolerance: 1e-3,
            allow_unconverged: false,
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
        if self.passes == 0 || self.max_passes < self.passes {
            return Err(HandEyeError::InvalidConfig(format!(
                "refinement passes: need 1 ≤ passes ≤ max_passes, got {} and {}",
                self.passes, self.max_passes
            )));
        }
        if !(self.noise_tolerance.is_finite() && self.noise_tolerance > 0.0) {
            return Err(HandEyeError::InvalidConfig(format!(
                "refinement noise_tolerance must be positive, got {}",
                self.noise_tolerance
            )));
        }
        Ok(())
    }

    /// Sigmas in the normalised problem (radians; lengths divided by `scale`).
    fn initial_sigmas(&self, scale: f64) -> Sigmas {
        let gr = self.robot_rotation_sigma_deg.to_radians();
        let cr = self.camera_rotation_sigma_deg.to_radians();
        if self.estimate_translation_noise {
            // Unit-free start: the rotation noise at the lever arm of the scene (L = 1 here),
            // split between robot and camera in the configured ratio.
            let tau = 0.5 * (gr + cr);
            let total = self.robot_translation_sigma + self.camera_translation_sigma;
            let (fr, fc) = (self.robot_translation_sigma / total, self.camera_translation_sigma / total);
            Sigmas { gr, cr, gt: 2.0 * tau * fr, ct: 2.0 * tau * fc }
        } else {
            Sigmas { gr, cr, gt: self.robot_translation_sigma / scale, ct: self.camera_translation_sigma / scale }
        }
    }
}

/// Noise sigmas of the normalised problem: radians and scene-scale units.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sigmas {
    gr: f64,
    gt: f64,
    cr: f64,
    ct: f64,
}

/// Result of the refinement.
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
    /// Fitted variance factor `σ̂²` (≈ 1 when the rotation sigmas are right).
    pub variance_factor: f64,
    /// Weighted RMS of the whitened residuals.
    pub rms: f64,
    /// Levenberg–Marquardt iterations over all passes.
    pub iterations: usize,
    /// Passes run (each one Levenberg–Marquardt solve with re-linearised covariances).
    pub passes: usize,
    /// True when the last Levenberg–Marquardt run stopped at a minimum (gradient, step or cost
    /// tolerance, or zero residual) and the translation-noise estimate settled.
    pub converged: bool,
    /// Why the last Levenberg–Marquardt run stopped.
    pub stop_reason: StopReason,
    /// True when the translation noise was given, or its estimate changed by less than
    /// `noise_tolerance` in the last pass.
    pub noise_settled: bool,
    /// Robot translation sigma used in the last pass, length unit of the poses (estimated or given).
    pub robot_translation_sigma: f64,
    /// Camera translation sigma used in the last pass, length unit of the poses.
    pub camera_translation_sigma: f64,
}

impl Refinement {
    /// One line: `converged: true (cost tolerance, 14 iterations in 3 passes)` or why not.
    pub fn convergence_summary(&self) -> String {
        let reason = match self.stop_reason {
            StopReason::GradientTolerance => "gradient tolerance",
            StopReason::StepTolerance => "step tolerance",
            StopReason::CostTolerance => "cost tolerance",
            StopReason::ZeroResidual => "zero residual",
            StopReason::MaxIterations => "iteration cap reached",
            StopReason::NoImprovement => "no step lowered the cost",
        };
        format!(
            "converged: {} ({reason}{}, {} iterations in {} passes)",
            self.converged,
            if self.noise_settled { "" } else { ", translation-noise estimate not settled" },
            self.iterations,
            self.passes
        )
    }

    /// The same refinement with every length multiplied by `s` (translations, covariance,
    /// standard deviations, translation sigmas).
    pub(crate) fn scaled(mut self, s: f64) -> Self {
        self.transform.translation *= s;
        self.board.translation *= s;
        if let Some(c) = self.covariance.as_mut() {
            for (r, row) in c.iter_mut().enumerate() {
                for (k, v) in row.iter_mut().enumerate() {
                    *v *= if r >= 3 { s } else { 1.0 } * if k >= 3 { s } else { 1.0 };
                }
            }
        }
        if let Some(sd) = self.std_devs.as_mut() {
            for v in &mut sd[3..] {
                *v *= s;
            }
        }
        self.robot_translation_sigma *= s;
        self.camera_translation_sigma *= s;
        self
    }
}

/// True for the stop reasons that mean a minimum was reached.
fn at_minimum(r: StopReason) -> bool {
    matches!(
        r,
        StopReason::GradientTolerance
            | StopReason::StepTolerance
            | StopReason::CostTolerance
            | StopReason::ZeroResidual
    )
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

/// The two parts of the covariance of the station error `Log(C̃⁻¹ X⁻¹ G̃⁻¹ W)` to first order,
/// `Σ = Q_rot + Q_trans`: the rotation-noise part and the translation-noise part of
/// `Σ_c + J Σ_g Jᵀ`, with `J = [[Rᵀ, 0], [−Rᵀ[t]×, Rᵀ]]` of `M = gripper_from_board` (the
/// robot's gripper-frame noise seen from the board frame).
fn station_covariance_parts(m: &Isometry3, s: &Sigmas) -> ([[f64; 6]; 6], [[f64; 6]; 6]) {
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
    let (gr, gt, cr, ct) = (s.gr * s.gr, s.gt * s.gt, s.cr * s.cr, s.ct * s.ct);
    let part = |d: [f64; 6], cam: [f64; 6]| {
        let mut q = [[0.0; 6]; 6];
        for r in 0..6 {
            for c in 0..6 {
                q[r][c] = (0..6).map(|k| j[r][k] * d[k] * j[c][k]).sum::<f64>();
            }
            q[r][r] += cam[r];
        }
        q
    };
    (
        part([gr, gr, gr, 0.0, 0.0, 0.0], [cr, cr, cr, 0.0, 0.0, 0.0]),
        part([0.0, 0.0, 0.0, gt, gt, gt], [0.0, 0.0, 0.0, ct, ct, ct]),
    )
}

fn add6(a: &[[f64; 6]; 6], b: &[[f64; 6]; 6]) -> [[f64; 6]; 6] {
    std::array::from_fn(|r| std::array::from_fn(|c| a[r][c] + b[r][c]))
}

/// The fixed-frame-side pose `M` whose lever arm carries the robot noise into the station error.
fn lever(setup: Setup, x: &Isometry3, c: &Isometry3, w: &Isometry3) -> Isometry3 {
    match setup {
        Setup::EyeInHand => *x * *c,
        Setup::EyeToHand => *w,
    }
}

/// Per station: whitening `S`, rotation-noise part `Q_rot`, translation-noise part `Q_trans`.
type StationNoise = ([[f64; 6]; 6], [[f64; 6]; 6], [[f64; 6]; 6]);

fn whitenings(
    camera_from_board: &[Isometry3],
    setup: Setup,
    x: &Isometry3,
    w: &Isometry3,
    s: &Sigmas,
) -> Result<Vec<StationNoise>> {
    camera_from_board
        .iter()
        .enumerate()
        .map(|(k, ci)| {
            let (qr, qt) = station_covariance_parts(&lever(setup, x, ci, w), s);
            let sw = whitening(&add6(&qr, &qt)).ok_or_else(|| {
                HandEyeError::numerical(
                    "refinement",
                    format!("noise covariance of station {k} is not positive definite"),
                )
            })?;
            Ok((sw, qr, qt))
        })
        .collect()
}

/// Whitened noise blocks of one station (or motion): `T_k = S Q_k Sᵀ` for the rotation-noise
/// and translation-noise parts, with `S` the whitening (`T_rot + T_trans = I`).
type Blocks = ([[f64; 6]; 6], [[f64; 6]; 6]);

fn whitened_blocks(s: &[[f64; 6]; 6], qr: &[[f64; 6]; 6], qt: &[[f64; 6]; 6]) -> Blocks {
    let t = |q: &[[f64; 6]; 6]| -> [[f64; 6]; 6] {
        std::array::from_fn(|a| {
            std::array::from_fn(|b| (0..=a).map(|k| (0..=b).map(|l| s[a][k] * q[k][l] * s[b][l]).sum::<f64>()).sum())
        })
    };
    (t(qr), t(qt))
}

/// One variance-component step (Helmert / Förstner) for the two noise groups: with whitened
/// residuals `r`, whitened Jacobian `J`, `N = JᵀJ` and the whitened group blocks `T_k`,
/// `f_k = rᵀ T_k r / (tr T_k − tr(N⁻¹ Jᵀ T_k J))` — the denominator is the group's share of the
/// redundancy, so the group the parameters absorb more of is not under-estimated. Returns
/// `√(f_trans / f_rot)`, the factor for the translation sigmas, or `None` when the residuals are
/// at round-off level (noise-free data: nothing to estimate) or the step is not defined.
fn translation_noise_factor<P: Problem>(problem: &P, params: &[f64], blocks: &[Blocks]) -> Option<f64> {
    let (m, n) = (problem.num_residuals(), problem.num_params());
    let mut r = vec![0.0; m];
    let mut j = faer::Mat::<f64>::zeros(m, n);
    problem.evaluate(params, &mut r, Some(j.as_mut())).ok()?;
    let nmat = j.transpose() * &j;
    let ninv = faer::linalg::solvers::DenseSolveCore::inverse(&nmat.llt(faer::Side::Lower).ok()?);
    let (mut num, mut den) = ([0.0f64; 2], [0.0f64; 2]);
    let mut max_r = 0.0f64;
    for (i, (tr_, tt)) in blocks.iter().enumerate() {
        let ri: [f64; 6] = std::array::from_fn(|a| r[6 * i + a]);
        max_r = ri.iter().fold(max_r, |acc, v| acc.max(v.abs()));
        for (g, t) in [tr_, tt].into_iter().enumerate() {
            num[g] += (0..6).map(|a| (0..6).map(|b| ri[a] * t[a][b] * ri[b]).sum::<f64>()).sum::<f64>();
            den[g] += (0..6).map(|a| t[a][a]).sum::<f64>();
            // − tr(N⁻¹ J_iᵀ T J_i) = − Σ_pq N⁻¹[p][q] (J_iᵀ T J_i)[q][p]
            let mut jtj = vec![0.0; n * n];
            for q in 0..n {
                for p in 0..n {
                    let mut v = 0.0;
                    for a in 0..6 {
                        for b in 0..6 {
                            v += j[(6 * i + a, q)] * t[a][b] * j[(6 * i + b, p)];
                        }
                    }
                    jtj[q * n + p] = v;
                }
            }
            den[g] -= (0..n).map(|p| (0..n).map(|q| ninv[(p, q)] * jtj[q * n + p]).sum::<f64>()).sum::<f64>();
        }
    }
    // Whitened residuals of noise-free data are round-off (≲ 1e-6 of a sigma).
    if max_r < 1e-7 || den[0] <= 0.0 || den[1] <= 0.0 {
        return None;
    }
    let f = ((num[1] / den[1]) / (num[0] / den[0])).sqrt();
    (f.is_finite() && f > 0.0).then_some(f)
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

/// Refines `X` from an initial estimate by Levenberg–Marquardt, on normalised data (lengths in
/// units of the scene scale `scale`, which only converts given translation sigmas).
///
/// `robot` are the robot poses in the form `G_i X C_i = W` (`base_from_gripper` eye-in-hand,
/// `gripper_from_base` eye-to-hand: see [`crate::Setup`]), `camera_from_board` the camera
/// poses, `motions` the relative motions (used when `estimate_board` is false).
///
/// With `estimate_board` (default), the unknowns are `X` and `W` and every station contributes
/// `Log(C̃_i⁻¹ X⁻¹ G̃_i⁻¹ W)`, whitened by its first-order covariance under the noise model of
/// [`RefineConfig`] (robot noise is carried through the lever arm of the board): maximum
/// likelihood to first order. The covariance is `σ̂² (JᵀJ)⁻¹`. The result is in the
/// normalised unit; the caller scales it back ([`Refinement::scaled`]).
pub(crate) fn refine(
    robot: &[Isometry3],
    camera_from_board: &[Isometry3],
    motions: &[Motion],
    setup: Setup,
    initial: &Isometry3,
    cfg: &RefineConfig,
    scale: f64,
) -> Result<Refinement> {
    cfg.validate()?;
    let mut x = *initial;
    let mut w = mean_board(robot, camera_from_board, &x)?;
    let mut sig = cfg.initial_sigmas(scale);
    let mut iterations = 0;
    let mut passes = 0;
    let mut settled = !cfg.estimate_translation_noise;
    let mut report: Option<LmReport> = None;
    let mut used = sig;
    let mut last_vce: Option<(f64, f64)> = None;
    let lm_err = |e| HandEyeError::numerical("refinement", e);
    let g_inv: Vec<Isometry3> = robot.iter().map(Isometry3::inverse).collect();
    let c_inv: Vec<Isometry3> = camera_from_board.iter().map(Isometry3::inverse).collect();
    while passes < cfg.max_passes {
        passes += 1;
        used = sig;
        let factor = if cfg.estimate_board {
            let parts = whitenings(camera_from_board, setup, &x, &w, &sig)?;
            let problem = AbsoluteProblem {
                g_inv: g_inv.clone(),
                c_inv: c_inv.clone(),
                whiten: parts.iter().map(|p| p.0).collect(),
            };
            let blocks: Vec<Blocks> = parts.iter().map(|(s, qr, qt)| whitened_blocks(s, qr, qt)).collect();
            let mut p0 = [0.0; 12];
            pose_to_params(&x, &mut p0[..6]);
            pose_to_params(&w, &mut p0[6..]);
            let rep = levenberg_marquardt(&problem, &p0, &cfg.lm).map_err(lm_err)?;
            x = params_to_pose(&rep.params[..6]);
            w = params_to_pose(&rep.params[6..12]);
            iterations += rep.iterations;
            let f = if settled { None } else { translation_noise_factor(&problem, &rep.params, &blocks) };
            report = Some(rep);
            f
        } else {
            let sr = (sig.gr * sig.gr + sig.cr * sig.cr).sqrt() * std::f64::consts::SQRT_2;
            let st = (sig.gt * sig.gt + sig.ct * sig.ct).sqrt() * std::f64::consts::SQRT_2;
            let problem = RelativeProblem { motions, scale: [sr, sr, sr, st, st, st] };
            let mut p0 = [0.0; 6];
            pose_to_params(&x, &mut p0);
            let rep = levenberg_marquardt(&problem, &p0, &cfg.lm).map_err(lm_err)?;
            x = params_to_pose(&rep.params);
            w = mean_board(robot, camera_from_board, &x)?;
            iterations += rep.iterations;
            let mut rot = [[0.0; 6]; 6];
            let mut tra = [[0.0; 6]; 6];
            for i in 0..3 {
                rot[i][i] = 1.0;
                tra[3 + i][3 + i] = 1.0;
            }
            let blocks = vec![(rot, tra); motions.len()];
            let f = if settled { None } else { translation_noise_factor(&problem, &rep.params, &blocks) };
            report = Some(rep);
            f
        };
        if !settled {
            match factor {
                None => settled = true,
                Some(f) => {
                    // Fixed point in log space: ln σ_t such that f(σ_t) = 1. The plain
                    // variance-component step (ln σ += ln f) converges linearly and slowly when
                    // the groups are correlated; a secant step on (ln σ, ln f) is used when the
                    // previous pass gives a slope of the right sign, bounded to a factor 10.
                    let (x, y) = (sig.ct.ln(), f.ln());
                    if y.abs() <= cfg.noise_tolerance {
                        settled = true;
                    } else {
                        let plain = x + y;
                        let next = match last_vce {
                            Some((x0, y0)) if x != x0 && (y - y0) / (x - x0) < 0.0 => x - y * (x - x0) / (y - y0),
                            _ => plain,
                        };
                        let next = next.clamp(x - std::f64::consts::LN_10, x + std::f64::consts::LN_10);
                        last_vce = Some((x, y));
                        // Keep the estimate within [1e-6, 1] scene scales.
                        let ct = next.exp().clamp(1e-6, 1.0);
                        sig.gt *= ct / sig.ct;
                        sig.ct = ct;
                    }
                }
            }
        }
        if passes >= cfg.passes && settled {
            break;
        }
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
        passes,
        converged: at_minimum(rep.stop_reason) && settled,
        stop_reason: rep.stop_reason,
        noise_settled: settled,
        robot_translation_sigma: used.gt,
        camera_translation_sigma: used.ct,
    })
}

/// The refinement cost `½‖r‖²` at `x` under the starting noise model (used to pick the best
/// linear start; normalised data).
pub(crate) fn initial_cost(
    robot: &[Isometry3],
    camera_from_board: &[Isometry3],
    setup: Setup,
    x: &Isometry3,
    cfg: &RefineConfig,
    scale: f64,
) -> Result<f64> {
    let w = mean_board(robot, camera_from_board, x)?;
    let sig = cfg.initial_sigmas(scale);
    let parts = whitenings(camera_from_board, setup, x, &w, &sig)?;
    let mut cost = 0.0;
    for ((gi, ci), (s, _, _)) in robot.iter().zip(camera_from_board).zip(&parts) {
        let e = error_vector(&(ci.inverse() * x.inverse() * gi.inverse() * w));
        for row in 0..6 {
            let v: f64 = (0..=row).map(|c| s[row][c] * e[c]).sum();
            cost += 0.5 * v * v;
        }
    }
    Ok(cost)
}
