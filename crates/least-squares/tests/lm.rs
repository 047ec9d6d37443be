//! Levenberg–Marquardt on textbook problems, and its covariance against closed forms.

use faer::{Mat, MatMut};
use parallax_least_squares::{EvaluationError, LeastSquaresError, LmConfig, Problem, StopReason, levenberg_marquardt};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// Rosenbrock as least squares: r = (10 (y − x²), 1 − x); minimum 0 at (1, 1).
struct Rosenbrock;
impl Problem for Rosenbrock {
    fn num_params(&self) -> usize {
        2
    }
    fn num_residuals(&self) -> usize {
        2
    }
    fn evaluate(&self, p: &[f64], r: &mut [f64], j: Option<MatMut<'_, f64>>) -> Result<(), EvaluationError> {
        r[0] = 10.0 * (p[1] - p[0] * p[0]);
        r[1] = 1.0 - p[0];
        if let Some(mut j) = j {
            j[(0, 0)] = -20.0 * p[0];
            j[(0, 1)] = 10.0;
            j[(1, 0)] = -1.0;
            j[(1, 1)] = 0.0;
        }
        Ok(())
    }
}

#[test]
fn rosenbrock_from_the_classic_start() {
    let fit = levenberg_marquardt(&Rosenbrock, &[-1.2, 1.0], &LmConfig::default()).unwrap();
    assert!((fit.params[0] - 1.0).abs() < 1e-10 && (fit.params[1] - 1.0).abs() < 1e-10, "{:?}", fit.params);
    assert!(fit.cost < 1e-20);
    assert!(fit.stop_reason.converged());
    assert!(fit.iterations < 100);
    assert_eq!(fit.initial_cost, 0.5 * ((10.0f64 * (1.0 - 1.44)).powi(2) + 2.2f64.powi(2)));
}

/// Geometric circle fit: r_i = ‖p_i − c‖ − ρ.
struct Circle {
    pts: Vec<(f64, f64)>,
}
impl Problem for Circle {
    fn num_params(&self) -> usize {
        3
    }
    fn num_residuals(&self) -> usize {
        self.pts.len()
    }
    fn evaluate(&self, p: &[f64], r: &mut [f64], j: Option<MatMut<'_, f64>>) -> Result<(), EvaluationError> {
        let mut j = j;
        for (i, &(x, y)) in self.pts.iter().enumerate() {
            let (dx, dy) = (x - p[0], y - p[1]);
            let d = dx.hypot(dy);
            if d == 0.0 {
                return Err(EvaluationError("centre on a data point".into()));
            }
            r[i] = d - p[2];
            if let Some(j) = j.as_mut() {
                j[(i, 0)] = -dx / d;
                j[(i, 1)] = -dy / d;
                j[(i, 2)] = -1.0;
            }
        }
        Ok(())
    }
}

#[test]
fn circle_fit_on_an_exact_arc() {
    // Exact points on a circle centred (2, -1) with radius 3, over a 120° arc.
    let pts: Vec<_> = (0..12)
        .map(|i| {
            let a = i as f64 * 2.0 * std::f64::consts::PI / 3.0 / 11.0;
            (2.0 + 3.0 * a.cos(), -1.0 + 3.0 * a.sin())
        })
        .collect();
    let fit = levenberg_marquardt(&Circle { pts }, &[0.0, 0.0, 1.0], &LmConfig::default()).unwrap();
    assert!(
        (fit.params[0] - 2.0).abs() < 1e-9 && (fit.params[1] + 1.0).abs() < 1e-9 && (fit.params[2] - 3.0).abs() < 1e-9
    );
}

/// Straight-line model y = a + b x with Gaussian noise: LM's covariance must equal the
/// closed form σ̂² (XᵀX)⁻¹, σ̂² = RSS / (m − 2), computed independently here.
struct Line {
    x: Vec<f64>,
    y: Vec<f64>,
}
impl Problem for Line {
    fn num_params(&self) -> usize {
        2
    }
    fn num_residuals(&self) -> usize {
        self.x.len()
    }
    fn evaluate(&self, p: &[f64], r: &mut [f64], j: Option<MatMut<'_, f64>>) -> Result<(), EvaluationError> {
        for i in 0..self.x.len() {
            r[i] = p[0] + p[1] * self.x[i] - self.y[i];
        }
        if let Some(mut j) = j {
            for i in 0..self.x.len() {
                j[(i, 0)] = 1.0;
                j[(i, 1)] = self.x[i];
            }
        }
        Ok(())
    }
}

#[test]
fn covariance_matches_the_closed_form_of_linear_regression() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, 0.3).unwrap();
    let x: Vec<f64> = (0..40).map(|i| i as f64 * 0.25).collect();
    let y: Vec<f64> = x.iter().map(|x| 1.5 - 0.7 * x + noise.sample(&mut rng)).collect();
    let m = x.len() as f64;
    // Closed form.
    let (sx, sy) = (x.iter().sum::<f64>(), y.iter().sum::<f64>());
    let sxx = x.iter().map(|v| v * v).sum::<f64>();
    let sxy = x.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>();
    let det = m * sxx - sx * sx;
    let b = (m * sxy - sx * sy) / det;
    let a = (sy - b * sx) / m;
    let rss: f64 = x.iter().zip(&y).map(|(xi, yi)| (a + b * xi - yi).powi(2)).sum();
    let s2 = rss / (m - 2.0);
    let cov = [[s2 * sxx / det, -s2 * sx / det], [-s2 * sx / det, s2 * m / det]];

    let fit = levenberg_marquardt(&Line { x, y }, &[0.0, 0.0], &LmConfig::default()).unwrap();
    assert!((fit.params[0] - a).abs() < 1e-10 && (fit.params[1] - b).abs() < 1e-10);
    assert_eq!(fit.dof, 38);
    assert!((fit.sigma2 - s2).abs() < 1e-12 * s2.max(1.0));
    let c: &Mat<f64> = fit.covariance.as_ref().unwrap();
    for i in 0..2 {
        for j in 0..2 {
            assert!(
                (c[(i, j)] - cov[i][j]).abs() < 1e-10 * cov[i][i].abs(),
                "cov[{i}][{j}] {} vs {}",
                c[(i, j)],
                cov[i][j]
            );
        }
    }
    let sd = fit.std_devs().unwrap();
    assert!((sd[1] - cov[1][1].sqrt()).abs() < 1e-10);
}

#[test]
fn bad_problems_are_errors() {
    assert!(matches!(
        levenberg_marquardt(&Rosenbrock, &[1.0], &LmConfig::default()),
        Err(LeastSquaresError::ShapeMismatch(_))
    ));
    assert!(matches!(
        levenberg_marquardt(&Rosenbrock, &[f64::NAN, 1.0], &LmConfig::default()),
        Err(LeastSquaresError::NonFinite(_))
    ));
    let under = Line { x: vec![1.0], y: vec![2.0] };
    assert!(matches!(
        levenberg_marquardt(&under, &[0.0, 0.0], &LmConfig::default()),
        Err(LeastSquaresError::Underdetermined { residuals: 1, params: 2 })
    ));
    let circle = Circle { pts: vec![(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] };
    assert!(matches!(
        levenberg_marquardt(&circle, &[0.0, 0.0, 1.0], &LmConfig::default()),
        Err(LeastSquaresError::InitialEvaluation(_))
    ));
}

#[test]
fn iteration_cap_is_reported() {
    let cfg = LmConfig { max_iterations: 2, ..LmConfig::default() };
    let fit = levenberg_marquardt(&Rosenbrock, &[-1.2, 1.0], &cfg).unwrap();
    assert_eq!(fit.stop_reason, StopReason::MaxIterations);
    assert_eq!(fit.iterations, 2);
    assert!(fit.cost < fit.initial_cost);
}
