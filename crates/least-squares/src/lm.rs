//! Dense Levenberg–Marquardt with Marquardt's diagonal scaling and Nielsen's damping update.

use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{Col, Mat, MatMut, Side};
use serde::{Deserialize, Serialize};

use crate::{LeastSquaresError, Result};

/// The residual function could not be evaluated at these parameters (for example a point
/// moved behind a camera). During the iteration such a step is rejected like a bad step.
#[derive(Debug, Clone, PartialEq)]
pub struct EvaluationError(pub String);

/// A nonlinear least-squares problem `min ½ Σ rᵢ(x)²`.
pub trait Problem {
    /// Number of parameters `n` (length of the step `δ`).
    fn num_params(&self) -> usize;
    /// Number of residuals `m`.
    fn num_residuals(&self) -> usize;
    /// Writes the residuals at `params` into `residuals` and, when asked, the `m x n` Jacobian
    /// `∂r/∂δ` (with respect to the step of [`Problem::retract`]).
    fn evaluate(
        &self,
        params: &[f64],
        residuals: &mut [f64],
        jacobian: Option<MatMut<'_, f64>>,
    ) -> std::result::Result<(), EvaluationError>;
    /// Applies a step: `out = params ⊕ delta`. The default is `params + delta`; override it for
    /// parameters on a manifold (rotations).
    fn retract(&self, params: &[f64], delta: &[f64], out: &mut [f64]) {
        for ((o, p), d) in out.iter_mut().zip(params).zip(delta) {
            *o = p + d;
        }
    }
    /// The normal equations `JᵀJ`, `Jᵀr` and the residuals at `params`. The default forms the
    /// dense Jacobian; override it to exploit structure (block-sparse bundle problems).
    fn normal_equations(
        &self,
        params: &[f64],
        jtj: &mut Mat<f64>,
        jtr: &mut Col<f64>,
        residuals: &mut [f64],
    ) -> std::result::Result<(), EvaluationError> {
        let mut j = Mat::<f64>::zeros(self.num_residuals(), self.num_params());
        self.evaluate(params, residuals, Some(j.as_mut()))?;
        *jtj = j.transpose() * &j;
        let r = Col::from_fn(residuals.len(), |i| residuals[i]);
        *jtr = j.transpose() * &r;
        Ok(())
    }
    /// The structure of `JᵀJ`, when it has one the solver can use: `Some((g, b))` says the
    /// parameters after the first `g` form independent blocks of `b` (no entry of `JᵀJ`
    /// couples two blocks, as the per-view poses of a bundle problem). Each step then
    /// eliminates the blocks (Schur complement) and solves a `g x g` system; the covariance is
    /// assembled from the same blocks. The default, `None`, solves the dense system.
    fn block_diagonal_tail(&self) -> Option<(usize, usize)> {
        None
    }
}

/// The structure of [`Problem::block_diagonal_tail`], checked against the problem's size.
fn tail_blocks<P: Problem + ?Sized>(problem: &P, n: usize) -> Option<(usize, usize)> {
    problem.block_diagonal_tail().filter(|&(g, b)| b > 0 && g < n && (n - g).is_multiple_of(b))
}

/// Solves `A x = rhs` for a symmetric positive definite `A` whose parameters after the first
/// `g` form independent `b x b` blocks: eliminates every block (`S = A_gg − Σ B_k D_k⁻¹ B_kᵀ`),
/// solves `S` by Cholesky, then each block. `None` when a block or `S` is not positive
/// definite.
pub(crate) fn solve_block_tail(a: &Mat<f64>, rhs: &Col<f64>, g: usize, b: usize) -> Option<Col<f64>> {
    let n = a.nrows();
    let blocks = (n - g) / b;
    let mut s = a.submatrix(0, 0, g, g).to_owned();
    let mut y = Col::from_fn(g, |i| rhs[i]);
    let mut solved = Vec::with_capacity(blocks);
    for k in 0..blocks {
        let o = g + k * b;
        let d = a.submatrix(o, o, b, b).to_owned().llt(Side::Lower).ok()?;
        // X = D⁻¹ B_kᵀ (b x g), z = D⁻¹ r_k.
        let r_k = Col::from_fn(b, |i| rhs[o + i]);
        let x = d.solve(a.submatrix(o, 0, b, g));
        let z = d.solve(&r_k);
        s -= a.submatrix(0, o, g, b) * &x;
        y -= x.transpose() * &r_k;
        solved.push((x, z));
    }
    let dg = if g > 0 { s.llt(Side::Lower).ok()?.solve(&y) } else { Col::zeros(0) };
    let mut out = Col::zeros(n);
    for i in 0..g {
        out[i] = dg[i];
    }
    for (k, (x, z)) in solved.iter().enumerate() {
        // d_k = D⁻¹ (r_k − B_kᵀ dg) = z − X dg.
        let dk = z - x * &dg;
        for i in 0..b {
            out[g + k * b + i] = dk[i];
        }
    }
    Some(out)
}

/// `(JᵀJ)⁻¹` of a matrix with [`Problem::block_diagonal_tail`] structure, by the same blocks:
/// with `E_k = B_k D_k⁻¹`, the global block is `S⁻¹`, the coupling `−S⁻¹ E_k`, and the block
/// pair `(k, l)` is `δ_kl D_k⁻¹ + E_kᵀ S⁻¹ E_l`. Costs `O(g²·n + n²·g)` instead of `O(n³)`.
fn inverse_block_tail(a: &Mat<f64>, g: usize, b: usize) -> Option<Mat<f64>> {
    let n = a.nrows();
    let blocks = (n - g) / b;
    let mut s = a.submatrix(0, 0, g, g).to_owned();
    // E = [E_1 … E_K] (g x (n − g)), and the D_k⁻¹.
    let mut e = Mat::<f64>::zeros(g, n - g);
    let mut d_inv = Vec::with_capacity(blocks);
    for k in 0..blocks {
        let o = g + k * b;
        let d = a.submatrix(o, o, b, b).to_owned().llt(Side::Lower).ok()?;
        let x = d.solve(a.submatrix(o, 0, b, g)); // D⁻¹ B_kᵀ = E_kᵀ
        s -= a.submatrix(0, o, g, b) * &x;
        e.submatrix_mut(0, k * b, g, b).copy_from(x.transpose());
        d_inv.push(d.inverse());
    }
    let s_inv = if g > 0 { s.llt(Side::Lower).ok()?.inverse() } else { Mat::zeros(0, 0) };
    let f = &s_inv * &e; // S⁻¹ E
    let mut out = Mat::<f64>::zeros(n, n);
    out.submatrix_mut(0, 0, g, g).copy_from(&s_inv);
    let neg_f = &f * faer::Scale(-1.0);
    out.submatrix_mut(0, g, g, n - g).copy_from(&neg_f);
    out.submatrix_mut(g, 0, n - g, g).copy_from(neg_f.transpose());
    let tail = e.transpose() * &f;
    out.submatrix_mut(g, g, n - g, n - g).copy_from(&tail);
    for (k, di) in d_inv.iter().enumerate() {
        let o = g + k * b;
        let mut blk = out.submatrix_mut(o, o, b, b);
        blk += di;
    }
    Some(out)
}

/// Tuning of [`levenberg_marquardt`]. The iteration stops at the first rule that holds:
///
/// 1. `‖Jᵀr‖∞ ≤ gradient_tolerance` — [`StopReason::GradientTolerance`];
/// 2. `‖δ‖ ≤ step_tolerance · (‖x‖ + step_tolerance)` for an accepted step — [`StopReason::StepTolerance`];
/// 3. `(cost_old − cost_new) ≤ cost_tolerance · cost_old` for an accepted step — [`StopReason::CostTolerance`];
/// 4. the cost reaches 0 — [`StopReason::ZeroResidual`];
/// 5. `max_iterations` iterations — [`StopReason::MaxIterations`];
/// 6. `max_rejections` steps in a row fail to lower the cost — [`StopReason::NoImprovement`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LmConfig {
    /// Iteration cap (each iteration is one linear solve).
    pub max_iterations: usize,
    /// Stop when the largest gradient component is at most this.
    pub gradient_tolerance: f64,
    /// Stop when the relative step is at most this.
    pub step_tolerance: f64,
    /// Stop when the relative cost decrease is at most this.
    pub cost_tolerance: f64,
    /// Initial damping relative to the largest diagonal entry of `JᵀJ`.
    pub initial_damping: f64,
    /// Consecutive rejected steps before giving up.
    pub max_rejections: usize,
    /// Compute the covariance `σ² (JᵀJ)⁻¹` at the solution.
    pub covariance: bool,
}

impl Default for LmConfig {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            gradient_tolerance: 1e-12,
            step_tolerance: 1e-12,
            cost_tolerance: 1e-15,
            initial_damping: 1e-4,
            max_rejections: 30,
            covariance: true,
        }
    }
}

/// Why [`levenberg_marquardt`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum StopReason {
    /// The gradient is below tolerance: a (local) minimum.
    GradientTolerance,
    /// The step became negligible.
    StepTolerance,
    /// The cost stopped decreasing.
    CostTolerance,
    /// The residuals are exactly zero.
    ZeroResidual,
    /// The iteration cap was reached (the result may not be a minimum).
    MaxIterations,
    /// No step lowered the cost even with heavy damping.
    NoImprovement,
}

impl StopReason {
    /// True for the reasons that indicate convergence.
    pub fn converged(self) -> bool {
        !matches!(self, StopReason::MaxIterations)
    }
}

/// Result of [`levenberg_marquardt`].
#[derive(Debug, Clone)]
pub struct LmReport {
    /// The solution.
    pub params: Vec<f64>,
    /// Residuals at the solution.
    pub residuals: Vec<f64>,
    /// `½‖r‖²` at the start.
    pub initial_cost: f64,
    /// `½‖r‖²` at the solution.
    pub cost: f64,
    /// Iterations (linear solves) performed.
    pub iterations: usize,
    /// Why the iteration stopped.
    pub stop_reason: StopReason,
    /// Degrees of freedom `m − n`.
    pub dof: usize,
    /// Residual variance estimate `σ² = ‖r‖² / (m − n)` (NaN when `m = n`).
    pub sigma2: f64,
    /// `JᵀJ` at the solution.
    pub information: Mat<f64>,
    /// `σ² (JᵀJ)⁻¹`, when asked for and `JᵀJ` is positive definite with `m > n`.
    pub covariance: Option<Mat<f64>>,
}

impl LmReport {
    /// Standard deviation of every parameter (`√diag(covariance)`), if the covariance exists.
    pub fn std_devs(&self) -> Option<Vec<f64>> {
        self.covariance.as_ref().map(|c| (0..c.nrows()).map(|i| c[(i, i)].max(0.0).sqrt()).collect())
    }

    /// Root mean square of the residuals.
    pub fn rms(&self) -> f64 {
        if self.residuals.is_empty() { 0.0 } else { (2.0 * self.cost / self.residuals.len() as f64).sqrt() }
    }
}

/// `σ² (JᵀJ)⁻¹` with `σ² = 2·cost / (m − n)`; `None` when `m ≤ n` or `JᵀJ` is not positive definite.
pub fn covariance_from_normal_equations(
    jtj: &Mat<f64>,
    cost: f64,
    num_residuals: usize,
    num_params: usize,
) -> Option<Mat<f64>> {
    if num_residuals <= num_params {
        return None;
    }
    let sigma2 = 2.0 * cost / (num_residuals - num_params) as f64;
    let inv = jtj.llt(Side::Lower).ok()?.inverse();
    let cov = inv * faer::Scale(sigma2);
    (0..cov.nrows()).all(|i| cov[(i, i)].is_finite() && cov[(i, i)] >= 0.0).then_some(cov)
}

fn half_norm2(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

/// Minimises `½‖r(x)‖²` from `initial` by Levenberg–Marquardt.
///
/// Each iteration solves `(JᵀJ + λ D) δ = −Jᵀr` with `D = diag(JᵀJ)` (Marquardt's scaling,
/// floored at 1e-12 of its largest entry) by Cholesky, accepts the step when the cost drops
/// (gain ratio ρ > 0) and updates `λ` by Nielsen's rule (`λ·max(1/3, 1 − (2ρ − 1)³)` on success,
/// `λ·ν, ν ← 2ν` on failure). See [`LmConfig`] for the stopping rules.
pub fn levenberg_marquardt<P: Problem + ?Sized>(problem: &P, initial: &[f64], config: &LmConfig) -> Result<LmReport> {
    let n = problem.num_params();
    let m = problem.num_residuals();
    if initial.len() != n {
        return Err(LeastSquaresError::ShapeMismatch(format!(
            "initial guess has {} parameters, the problem {n}",
            initial.len()
        )));
    }
    if n == 0 {
        return Err(LeastSquaresError::Empty("parameter vector"));
    }
    if m < n {
        return Err(LeastSquaresError::Underdetermined { residuals: m, params: n });
    }
    if initial.iter().any(|v| !v.is_finite()) {
        return Err(LeastSquaresError::NonFinite("initial guess"));
    }
    let mut x = initial.to_vec();
    let mut r = vec![0.0; m];
    let mut jtj = Mat::<f64>::zeros(n, n);
    let mut jtr = Col::<f64>::zeros(n);
    problem.normal_equations(&x, &mut jtj, &mut jtr, &mut r).map_err(|e| LeastSquaresError::InitialEvaluation(e.0))?;
    if r.iter().any(|v| !v.is_finite()) {
        return Err(LeastSquaresError::InitialEvaluation("non-finite residual".into()));
    }
    let initial_cost = half_norm2(&r);
    let mut cost = initial_cost;
    let max_diag = (0..n).map(|i| jtj[(i, i)]).fold(0.0, f64::max);
    let mut lambda = config.initial_damping * max_diag.max(1e-300);
    let mut nu = 2.0;
    let mut iterations = 0;
    let mut rejections = 0;
    let mut x_new = vec![0.0; n];
    let mut r_new = vec![0.0; m];
    let mut jtj_new = Mat::<f64>::zeros(n, n);
    let mut jtr_new = Col::<f64>::zeros(n);
    let structure = tail_blocks(problem, n);

    let stop_reason = loop {
        if cost == 0.0 {
            break StopReason::ZeroResidual;
        }
        if jtr.iter().fold(0.0f64, |a, v| a.max(v.abs())) <= config.gradient_tolerance {
            break StopReason::GradientTolerance;
        }
        if iterations >= config.max_iterations {
            break StopReason::MaxIterations;
        }
        if rejections >= config.max_rejections {
            break StopReason::NoImprovement;
        }
        iterations += 1;
        let dmax = (0..n).map(|i| jtj[(i, i)]).fold(0.0, f64::max);
        let mut a = jtj.clone();
        for i in 0..n {
            a[(i, i)] += lambda * jtj[(i, i)].max(dmax * 1e-12).max(1e-300);
        }
        let neg_g = Col::from_fn(n, |i| -jtr[i]);
        let solved = match structure {
            Some((g, b)) => solve_block_tail(&a, &neg_g, g, b),
            None => a.llt(Side::Lower).ok().map(|llt| llt.solve(&neg_g)),
        };
        let delta = match solved {
            Some(delta) => delta,
            None => {
                lambda *= nu;
                nu *= 2.0;
                rejections += 1;
                continue;
            }
        };
        let delta: Vec<f64> = delta.iter().copied().collect();
        if delta.iter().any(|v| !v.is_finite()) {
            lambda *= nu;
            nu *= 2.0;
            rejections += 1;
            continue;
        }
        let step_norm = delta.iter().map(|v| v * v).sum::<f64>().sqrt();
        let x_norm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
        problem.retract(&x, &delta, &mut x_new);
        let evaluated = problem.normal_equations(&x_new, &mut jtj_new, &mut jtr_new, &mut r_new);
        let new_cost =
            if evaluated.is_ok() && r_new.iter().all(|v| v.is_finite()) { half_norm2(&r_new) } else { f64::INFINITY };
        // Predicted decrease of the quadratic model: ½ δᵀ(λ D δ − Jᵀr).
        let predicted: f64 = (0..n)
            .map(|i| 0.5 * delta[i] * (lambda * jtj[(i, i)].max(dmax * 1e-12).max(1e-300) * delta[i] - jtr[i]))
            .sum();
        let actual = cost - new_cost;
        if actual > 0.0 && new_cost.is_finite() {
            let rho = if predicted > 0.0 { actual / predicted } else { 1.0 };
            lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            nu = 2.0;
            rejections = 0;
            let old_cost = cost;
            std::mem::swap(&mut x, &mut x_new);
            std::mem::swap(&mut r, &mut r_new);
            std::mem::swap(&mut jtj, &mut jtj_new);
            std::mem::swap(&mut jtr, &mut jtr_new);
            cost = new_cost;
            if step_norm <= config.step_tolerance * (x_norm + config.step_tolerance) {
                break StopReason::StepTolerance;
            }
            if actual <= config.cost_tolerance * old_cost {
                break StopReason::CostTolerance;
            }
        } else {
            if step_norm <= config.step_tolerance * (x_norm + config.step_tolerance) {
                break StopReason::StepTolerance;
            }
            lambda *= nu;
            nu *= 2.0;
            rejections += 1;
        }
    };
    let dof = m - n;
    let sigma2 = if dof > 0 { 2.0 * cost / dof as f64 } else { f64::NAN };
    let covariance = match (config.covariance, tail_blocks(problem, n)) {
        (false, _) => None,
        (true, None) => covariance_from_normal_equations(&jtj, cost, m, n),
        (true, Some((g, b))) => (m > n)
            .then(|| inverse_block_tail(&jtj, g, b))
            .flatten()
            .map(|inv| inv * faer::Scale(2.0 * cost / (m - n) as f64))
            .filter(|c| (0..n).all(|i| c[(i, i)].is_finite() && c[(i, i)] >= 0.0)),
    };
    Ok(LmReport {
        params: x,
        residuals: r,
        initial_cost,
        cost,
        iterations,
        stop_reason,
        dof,
        sigma2,
        information: jtj,
        covariance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A symmetric positive definite matrix whose parameters after the first `g` form
    /// independent `b x b` blocks, from a seeded sparse "Jacobian" (`JᵀJ + I`).
    fn block_tail_matrix(g: usize, b: usize, blocks: usize, seed: u64) -> Mat<f64> {
        let n = g + b * blocks;
        let mut state = seed;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let mut a = Mat::<f64>::identity(n, n);
        for k in 0..blocks {
            // Rows that touch the globals and block k only.
            for _ in 0..(2 * b + g) {
                let mut row = vec![0.0; n];
                for v in row.iter_mut().take(g) {
                    *v = next();
                }
                for i in 0..b {
                    row[g + k * b + i] = next();
                }
                for i in 0..n {
                    for j in 0..n {
                        a[(i, j)] += row[i] * row[j];
                    }
                }
            }
        }
        a
    }

    /// The block elimination solves and inverts exactly as the dense Cholesky does.
    #[test]
    fn block_tail_solve_and_inverse_equal_the_dense_ones() {
        for (g, b, blocks, seed) in [(5, 6, 7, 1), (0, 3, 4, 2), (9, 6, 1, 3), (1, 2, 10, 4)] {
            let a = block_tail_matrix(g, b, blocks, seed);
            let n = a.nrows();
            let rhs = Col::from_fn(n, |i| (i as f64 * 0.7).sin());
            let dense = a.llt(Side::Lower).unwrap().solve(&rhs);
            let blockwise = solve_block_tail(&a, &rhs, g, b).unwrap();
            let scale = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for i in 0..n {
                assert!((dense[i] - blockwise[i]).abs() <= 1e-10 * scale, "g {g} b {b}: x[{i}]");
            }
            let inv = a.llt(Side::Lower).unwrap().inverse();
            let inv_b = inverse_block_tail(&a, g, b).unwrap();
            let scale = (0..n).map(|i| inv[(i, i)]).fold(0.0f64, f64::max);
            for i in 0..n {
                for j in 0..n {
                    assert!((inv[(i, j)] - inv_b[(i, j)]).abs() <= 1e-10 * scale, "g {g} b {b}: inv[{i}][{j}]");
                }
            }
        }
    }

    /// A problem that declares its block structure reaches the same solution and covariance
    /// as the dense path (circle centres sharing one radius: global r, one (x, y) block each).
    #[test]
    fn levenberg_marquardt_with_block_structure_equals_the_dense_path() {
        struct Circles {
            points: Vec<Vec<(f64, f64)>>,
            blocks: bool,
        }
        impl Problem for Circles {
            fn num_params(&self) -> usize {
                1 + 2 * self.points.len()
            }
            fn num_residuals(&self) -> usize {
                self.points.iter().map(Vec::len).sum()
            }
            fn evaluate(
                &self,
                p: &[f64],
                r: &mut [f64],
                mut j: Option<MatMut<'_, f64>>,
            ) -> std::result::Result<(), EvaluationError> {
                let mut row = 0;
                for (k, pts) in self.points.iter().enumerate() {
                    let (cx, cy) = (p[1 + 2 * k], p[2 + 2 * k]);
                    for &(x, y) in pts {
                        let d = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
                        r[row] = d - p[0];
                        if let Some(j) = j.as_mut() {
                            j[(row, 0)] = -1.0;
                            j[(row, 1 + 2 * k)] = (cx - x) / d;
                            j[(row, 2 + 2 * k)] = (cy - y) / d;
                        }
                        row += 1;
                    }
                }
                Ok(())
            }
            fn block_diagonal_tail(&self) -> Option<(usize, usize)> {
                self.blocks.then_some((1, 2))
            }
        }
        let points: Vec<Vec<(f64, f64)>> = (0..6)
            .map(|k| {
                let (cx, cy) = (k as f64 * 3.0, -(k as f64));
                (0..9)
                    .map(|i| {
                        let a = i as f64 * 0.7 + k as f64;
                        let noise = 0.01 * ((i * 7 + k * 3) as f64).sin();
                        (cx + (2.0 + noise) * a.cos(), cy + (2.0 + noise) * a.sin())
                    })
                    .collect()
            })
            .collect();
        let x0: Vec<f64> =
            std::iter::once(1.5).chain((0..6).flat_map(|k| [k as f64 * 3.0 + 0.3, -(k as f64) - 0.2])).collect();
        let dense =
            levenberg_marquardt(&Circles { points: points.clone(), blocks: false }, &x0, &LmConfig::default()).unwrap();
        let blocks = levenberg_marquardt(&Circles { points, blocks: true }, &x0, &LmConfig::default()).unwrap();
        assert!((dense.params[0] - 2.0).abs() < 0.01);
        for (a, b) in dense.params.iter().zip(&blocks.params) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        let (cd, cb) = (dense.covariance.unwrap(), blocks.covariance.unwrap());
        for i in 0..cd.nrows() {
            for j in 0..cd.ncols() {
                assert!((cd[(i, j)] - cb[(i, j)]).abs() <= 1e-9 * cd[(i, i)].max(cd[(j, j)]));
            }
        }
    }
}
