//! Sub-pixel corner refinement: the gradient-orthogonality iteration of OpenCV's
//! `cornerSubPix`, and a saddle-point fit on the smoothed image. Both choose their window from
//! the local corner spacing by default, so that a window never reaches a neighbouring corner.

use glam::DVec2;
use image::GrayImage;
use serde::{Deserialize, Serialize};

use crate::imageops::{ImageF32, gaussian_blur, to_f32};
use crate::{CornerError, Result};

/// How the refinement window is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum WindowSize {
    /// A fixed half-size in pixels (OpenCV's `winSize`; the window is `2·n + 1` wide).
    Fixed(u32),
    /// Per corner: `fraction ×` the distance to the nearest other corner of the input slice,
    /// rounded and clamped to `[min, max]` pixels. A single corner gets `max`.
    FromSpacing {
        /// Fraction of the nearest-corner distance (0 < fraction < 0.5).
        fraction: f64,
        /// Smallest half-size, pixels.
        min: u32,
        /// Largest half-size, pixels.
        max: u32,
    },
}

impl Default for WindowSize {
    fn default() -> Self {
        WindowSize::FromSpacing { fraction: 0.3, min: 2, max: 10 }
    }
}

impl WindowSize {
    fn validate(&self) -> Result<()> {
        match *self {
            WindowSize::Fixed(n) if n < 1 => {
                Err(CornerError::InvalidConfig("window half-size must be at least 1 pixel".into()))
            }
            WindowSize::FromSpacing { fraction, min, max } => {
                if !(fraction.is_finite() && fraction > 0.0 && fraction < 0.5) {
                    return Err(CornerError::InvalidConfig(format!(
                        "window fraction of the corner spacing must be in (0, 0.5), got {fraction}"
                    )));
                }
                if min < 1 || max < min {
                    return Err(CornerError::InvalidConfig(format!(
                        "window half-size bounds must satisfy 1 <= min <= max, got {min}..{max}"
                    )));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Half-size for each corner of `corners`.
    pub fn half_sizes(&self, corners: &[DVec2]) -> Vec<u32> {
        match *self {
            WindowSize::Fixed(n) => vec![n; corners.len()],
            WindowSize::FromSpacing { fraction, min, max } => {
                let nn = nearest_distances(corners);
                nn.iter()
                    .map(|d| if d.is_finite() { ((fraction * d).round() as u32).clamp(min, max) } else { max })
                    .collect()
            }
        }
    }
}

/// Distance from each point to its nearest other point (∞ for a single point). Uses a bucket
/// grid, so it is fast for the few hundred corners of a target.
pub(crate) fn nearest_distances(p: &[DVec2]) -> Vec<f64> {
    let n = p.len();
    if n < 2 {
        return vec![f64::INFINITY; n];
    }
    // O(n²) is fine for the sizes used here (targets have < 1000 corners).
    let mut out = vec![f64::INFINITY; n];
    for i in 0..n {
        for j in i + 1..n {
            let d = (p[i] - p[j]).length();
            if d < out[i] {
                out[i] = d;
            }
            if d < out[j] {
                out[j] = d;
            }
        }
    }
    out
}

/// Configuration of [`refine_corners_subpix`] (OpenCV's `cornerSubPix`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SubPixConfig {
    /// Search window; by default derived from the corner spacing (30 % of the distance to
    /// the nearest other corner, 2..=10 px half-size).
    pub window: WindowSize,
    /// Half-size of the central dead zone excluded from the sums, pixels (0 = none, as
    /// OpenCV's `zeroZone = (-1, -1)`).
    pub dead_zone: u32,
    /// Maximum number of iterations (OpenCV's `MAX_ITER`, usually 30).
    pub max_iterations: usize,
    /// Stop when a step is shorter than this, pixels (OpenCV's `EPS`, usually 0.001).
    pub epsilon: f64,
    /// Gaussian smoothing before the gradients, pixels (0 = none, as OpenCV). A little
    /// smoothing reduces the aliasing of very sharp images.
    pub smoothing_sigma: f64,
}

impl Default for SubPixConfig {
    fn default() -> Self {
        Self { window: WindowSize::default(), dead_zone: 0, max_iterations: 30, epsilon: 0.001, smoothing_sigma: 0.5 }
    }
}

/// What the refinement did for one corner.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    /// Half-size of the window used, pixels.
    pub half_window: u32,
    /// Iterations performed.
    pub iterations: usize,
    /// Distance between the input and the refined position, pixels.
    pub shift: f64,
    /// True when the last step was below `epsilon`; false when the iteration hit the
    /// limit, the system was singular, or the estimate left the window (then the corner
    /// keeps its input position, as OpenCV does).
    pub converged: bool,
}

fn check_corners(img: &GrayImage, corners: &[DVec2]) -> Result<()> {
    for (index, c) in corners.iter().enumerate() {
        let inside = c.is_finite()
            && c.x >= -0.5
            && c.y >= -0.5
            && c.x <= img.width() as f64 - 0.5
            && c.y <= img.height() as f64 - 0.5;
        if !inside {
            return Err(CornerError::CornerOutsideImage {
                index,
                u: c.x,
                v: c.y,
                width: img.width(),
                height: img.height(),
            });
        }
    }
    Ok(())
}

/// Refines corners in place by the gradient-orthogonality condition of OpenCV's
/// `cornerSubPix`: the corner `q` is the point for which every image gradient `g(p)` in the
/// window is orthogonal to `p − q`, solved by weighted least squares
/// `(Σ w g gᵀ) q = Σ w g gᵀ p` (Gaussian weights as OpenCV's) and iterated.
///
/// Unbiased for any corner whose edges are straight lines through it (X-junctions of a
/// chessboard under any perspective, L-corners). The window comes from the local corner
/// spacing unless [`WindowSize::Fixed`] is given.
///
/// ```
/// use parallax_corner_detection::{refine_corners_subpix, SubPixConfig, WindowSize};
/// use glam::DVec2;
/// // A blurred X-junction at (20.3, 19.6), edges rotated by 0.3 rad: tanh profiles across
/// // both lines, so opposite sectors share a colour.
/// let (cx, cy, a) = (20.3, 19.6, 0.3f64);
/// let img = image::GrayImage::from_fn(40, 40, |x, y| {
///     let (dx, dy) = (x as f64 - cx, y as f64 - cy);
///     let (d1, d2) = (dx * a.cos() + dy * a.sin(), -dx * a.sin() + dy * a.cos());
///     image::Luma([(125.0 + 95.0 * (d1 / 1.2).tanh() * (d2 / 1.2).tanh()).round() as u8])
/// });
/// let mut corners = [DVec2::new(21.0, 19.0)];
/// let cfg = SubPixConfig { window: WindowSize::Fixed(6), ..Default::default() };
/// refine_corners_subpix(&img, &mut corners, &cfg)?;
/// assert!((corners[0] - DVec2::new(cx, cy)).length() < 0.02);
/// # Ok::<(), parallax_corner_detection::CornerError>(())
/// ```
pub fn refine_corners_subpix(img: &GrayImage, corners: &mut [DVec2], cfg: &SubPixConfig) -> Result<Vec<Refinement>> {
    cfg.window.validate()?;
    crate::imageops::check_size(img, 3, "refine_corners_subpix")?;
    check_corners(img, corners)?;
    if !(cfg.epsilon.is_finite() && cfg.epsilon >= 0.0)
        || cfg.max_iterations == 0
        || !(cfg.smoothing_sigma.is_finite() && cfg.smoothing_sigma >= 0.0)
    {
        return Err(CornerError::InvalidConfig(format!(
            "SubPixConfig needs max_iterations >= 1, epsilon >= 0 and smoothing_sigma >= 0 (got {}, {}, {})",
            cfg.max_iterations, cfg.epsilon, cfg.smoothing_sigma
        )));
    }
    let f = gaussian_blur(&to_f32(img), cfg.smoothing_sigma);
    let halves = cfg.window.half_sizes(corners);
    Ok(corners
        .iter_mut()
        .zip(halves)
        .map(|(c, half)| subpix_one(&f, c, half, cfg.dead_zone, cfg.max_iterations, cfg.epsilon))
        .collect())
}

/// The total-least-squares line through `pts` (the principal axis of their scatter): a point on
/// it (the centroid) and its unit direction; `None` for no point.
pub(crate) fn tls_line(pts: impl Iterator<Item = DVec2> + Clone) -> Option<(DVec2, DVec2)> {
    let n = pts.clone().count();
    if n == 0 {
        return None;
    }
    let c = pts.clone().fold(DVec2::ZERO, |acc, p| acc + p) / n as f64;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in pts {
        let d = p - c;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    Some((c, DVec2::new(angle.cos(), angle.sin())))
}

/// Where two lines (a point and a unit direction each) cross; `None` when the sine of the
/// angle between them is below `min_sin`.
pub(crate) fn line_intersection((p1, d1): (DVec2, DVec2), (p2, d2): (DVec2, DVec2), min_sin: f64) -> Option<DVec2> {
    let den = d1.perp_dot(d2);
    (den.abs() >= min_sin).then(|| p1 + d1 * ((p2 - p1).perp_dot(d2) / den))
}

/// Smooth compact weight `(1 − (d/R)²)²` for `|d| < R`, else 0: continuous with a continuous
/// derivative, so pixels entering or leaving the window as the estimate moves do not bias it.
#[inline]
fn biweight(d: f64, r: f64) -> f64 {
    let t = d / r;
    if t.abs() >= 1.0 { 0.0 } else { (1.0 - t * t) * (1.0 - t * t) }
}

/// The pixels of one saddle-fit iteration: the `f32` image `data` (`width` pixels per row), the
/// inclusive pixel ranges `xs`, `ys` (already clamped to the image), and the biweight window of
/// `radius` centred on `centre`.
pub(crate) struct SaddleWindow<'a> {
    pub(crate) data: &'a [f32],
    pub(crate) width: usize,
    pub(crate) xs: (i64, i64),
    pub(crate) ys: (i64, i64),
    pub(crate) centre: DVec2,
    pub(crate) radius: f64,
}

/// Weighted sums of the saddle fit over `win`: entry `[i][j]` is `Σ (w·r_i)·r_j` in row-major
/// pixel order, with the regressors `r = [x², xy, y², x, y, 1, value, 0]` relative to the
/// window centre, so `[i][j]` for `i ≤ j < 6` is the upper triangle of `AᵀWA` and `[i][6]` is
/// `AᵀWb` (the lower triangle and the padding lane are computed and ignored). Every entry is
/// its own accumulator summed in the order of the scalar loop this replaced, so vectorising
/// across the 8 lanes of a row keeps every sum bit for bit (Rust never fuses the multiply and
/// the add). Compiled once per instruction set ([`crate::Isa`]): our own kernel because it is
/// the inner loop of the refinement (a third of the detection time at 1600x1200 before).
pub(crate) fn saddle_sums(win: &SaddleWindow<'_>, isa: crate::Isa) -> [[f64; 8]; 6] {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn avx2(win: &SaddleWindow<'_>) -> [[f64; 8]; 6] {
        saddle_sums_imp(win)
    }
    match isa {
        // SAFETY: the token proves AVX2.
        #[cfg(target_arch = "x86_64")]
        Some(_) => unsafe { avx2(win) },
        _ => saddle_sums_imp(win),
    }
}

#[inline(always)]
fn saddle_sums_imp(win: &SaddleWindow<'_>) -> [[f64; 8]; 6] {
    let mut acc = [[0.0f64; 8]; 6];
    let (q, radius) = (win.centre, win.radius);
    let (xa, xb) = win.xs;
    if xb < xa {
        return acc;
    }
    // Column weights once per iteration instead of once per pixel (same function, same bits).
    let mut col_w = [0.0f64; 64];
    let mut col_heap = Vec::new();
    let n = (xb - xa + 1) as usize;
    let cw: &mut [f64] = if n <= col_w.len() {
        &mut col_w[..n]
    } else {
        col_heap.resize(n, 0.0);
        &mut col_heap
    };
    for (k, c) in cw.iter_mut().enumerate() {
        *c = biweight((xa + k as i64) as f64 - q.x, radius);
    }
    for y in win.ys.0..=win.ys.1 {
        let dy = y as f64 - q.y;
        let wy = biweight(dy, radius);
        let row = &win.data[y as usize * win.width + xa as usize..][..n];
        for (k, (&v, &wx)) in row.iter().zip(cw.iter()).enumerate() {
            let wt = wy * wx;
            if wt == 0.0 {
                continue;
            }
            let dx = (xa + k as i64) as f64 - q.x;
            let r = [dx * dx, dx * dy, dy * dy, dx, dy, 1.0, v as f64, 0.0];
            for (row, &ri) in acc.iter_mut().zip(&r[..6]) {
                let wr = wt * ri;
                for (a, &rj) in row.iter_mut().zip(&r) {
                    *a += wr * rj;
                }
            }
        }
    }
    acc
}

/// One corner by the gradient-orthogonality condition of `cornerSubPix`; `c` is updated in
/// place. Unlike OpenCV, gradients are taken at the pixel centres (central differences, no
/// bilinear resampling of the window) and the window weight is a smooth compact function
/// centred on the estimate: resampling a sharp image bilinearly biases OpenCV's version by up
/// to ~0.07 px, which this form avoids (measured in the tests below).
pub(crate) fn subpix_one(
    f: &ImageF32,
    c: &mut DVec2,
    half: u32,
    dead_zone: u32,
    max_iterations: usize,
    epsilon: f64,
) -> Refinement {
    let (w, h) = (f.width() as i64, f.height() as i64);
    let data = f.as_raw();
    let radius = half as f64 + 1.0;
    let start = *c;
    let mut q = start;
    let mut iterations = 0;
    let mut converged = false;
    let mut failed = false;
    while iterations < max_iterations {
        iterations += 1;
        let (x0, x1) = ((q.x - radius).ceil() as i64, (q.x + radius).floor() as i64);
        let (y0, y1) = ((q.y - radius).ceil() as i64, (q.y + radius).floor() as i64);
        let (mut a, mut b, mut cc, mut bb1, mut bb2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for y in y0.max(1)..=y1.min(h - 2) {
            let py = y as f64 - q.y;
            let wy = biweight(py, radius);
            for x in x0.max(1)..=x1.min(w - 2) {
                let px = x as f64 - q.x;
                if dead_zone > 0 && px.abs() <= dead_zone as f64 && py.abs() <= dead_zone as f64 {
                    continue;
                }
                let m = wy * biweight(px, radius);
                if m == 0.0 {
                    continue;
                }
                let i = (y * w + x) as usize;
                let gx = 0.5 * (data[i + 1] - data[i - 1]) as f64;
                let gy = 0.5 * (data[i + w as usize] - data[i - w as usize]) as f64;
                let gxx = gx * gx * m;
                let gxy = gx * gy * m;
                let gyy = gy * gy * m;
                a += gxx;
                b += gxy;
                cc += gyy;
                bb1 += gxx * px + gxy * py;
                bb2 += gxy * px + gyy * py;
            }
        }
        let det = a * cc - b * b;
        if !(det.is_finite() && det > 1e-9 * (a * cc).max(1e-30)) {
            failed = true;
            break;
        }
        let step = DVec2::new((cc * bb1 - b * bb2) / det, (a * bb2 - b * bb1) / det);
        q += step;
        if !q.is_finite() || (q - start).abs().max_element() > half as f64 {
            failed = true;
            break;
        }
        if step.length() <= epsilon {
            converged = true;
            break;
        }
    }
    if failed {
        q = start;
        converged = false;
    }
    *c = q;
    Refinement { half_window: half, iterations, shift: (q - start).length(), converged }
}

/// Configuration of [`refine_saddle`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SaddleConfig {
    /// Gaussian smoothing of the image before the fit, pixels.
    pub smoothing_sigma: f64,
    /// Fit window; by default derived from the corner spacing (25 % of the distance to the
    /// nearest other corner, 2..=5 px half-size: the quadratic model only holds near the
    /// junction).
    pub window: WindowSize,
    /// Maximum number of re-centred fits.
    pub max_iterations: usize,
    /// Stop when a step is shorter than this, pixels.
    pub epsilon: f64,
}

impl Default for SaddleConfig {
    fn default() -> Self {
        Self {
            smoothing_sigma: 1.5,
            window: WindowSize::FromSpacing { fraction: 0.25, min: 2, max: 5 },
            max_iterations: 10,
            epsilon: 0.001,
        }
    }
}

/// Refines X-junction corners in place as the saddle point of a quadratic surface
/// `f = a x² + b xy + c y² + d x + e y + g` fitted (Gaussian-weighted least squares) to the
/// smoothed image around each corner, re-centred on the estimate until it moves less than
/// `epsilon`. The saddle of a blurred X-junction lies on the junction by point symmetry, so
/// the fit is unbiased under any perspective. A fit whose surface is not a saddle
/// (`4ac − b² ≥ 0`) or whose estimate leaves the window keeps the input position
/// (`converged = false`).
pub fn refine_saddle(img: &GrayImage, corners: &mut [DVec2], cfg: &SaddleConfig) -> Result<Vec<Refinement>> {
    cfg.window.validate()?;
    crate::imageops::check_size(img, 3, "refine_saddle")?;
    check_corners(img, corners)?;
    if !(cfg.smoothing_sigma.is_finite() && cfg.smoothing_sigma >= 0.0) || cfg.max_iterations == 0 {
        return Err(CornerError::InvalidConfig(format!(
            "SaddleConfig needs smoothing_sigma >= 0 and max_iterations >= 1 (got {}, {})",
            cfg.smoothing_sigma, cfg.max_iterations
        )));
    }
    let smoothed = gaussian_blur(&to_f32(img), cfg.smoothing_sigma);
    let halves = cfg.window.half_sizes(corners);
    Ok(corners
        .iter_mut()
        .zip(halves)
        .map(|(c, half)| saddle_one(&smoothed, c, half, cfg.max_iterations, cfg.epsilon))
        .collect())
}

pub(crate) fn saddle_one(
    smoothed: &ImageF32,
    c: &mut DVec2,
    half: u32,
    max_iterations: usize,
    epsilon: f64,
) -> Refinement {
    use faer::linalg::solvers::Solve;
    let (w, h) = (smoothed.width() as i64, smoothed.height() as i64);
    let data = smoothed.as_raw();
    let radius = half as f64 + 1.0;
    let start = *c;
    let mut q = start;
    let mut iterations = 0;
    let mut converged = false;
    let mut ok = true;
    while iterations < max_iterations {
        iterations += 1;
        // Weighted least squares in coordinates relative to the estimate, on the pixel
        // centres (no resampling): f = a x² + b xy + c y² + d x + e y + g.
        // Normal equations accumulated in fixed-size lanes (`saddle_sums`; faer's checked
        // indexing in this loop took most of the refinement time), solved by faer.
        let (x0, x1) = ((q.x - radius).ceil() as i64, (q.x + radius).floor() as i64);
        let (y0, y1) = ((q.y - radius).ceil() as i64, (q.y + radius).floor() as i64);
        let window = SaddleWindow {
            data,
            width: w as usize,
            xs: (x0.max(0), x1.min(w - 1)),
            ys: (y0.max(0), y1.min(h - 1)),
            centre: q,
            radius,
        };
        let acc = saddle_sums(&window, parallax_simd::Avx2::new());
        let ata = faer::Mat::<f64>::from_fn(6, 6, |i, j| if i <= j { acc[i][j] } else { acc[j][i] });
        let atb = faer::Mat::<f64>::from_fn(6, 1, |i, _| acc[i][6]);
        let Ok(llt) = ata.llt(faer::Side::Lower) else {
            ok = false;
            break;
        };
        let coef = llt.solve(&atb);
        let (a, b, cc, d, e) = (coef[(0, 0)], coef[(1, 0)], coef[(2, 0)], coef[(3, 0)], coef[(4, 0)]);
        let det = 4.0 * a * cc - b * b;
        if det.is_nan() || det >= 0.0 {
            ok = false;
            break;
        }
        // ∇f = 0: [2a b; b 2c] (x, y) = −(d, e)
        let step = DVec2::new((-2.0 * cc * d + b * e) / det, (-2.0 * a * e + b * d) / det);
        q += step;
        if !q.is_finite() || (q - start).abs().max_element() > half as f64 {
            ok = false;
            break;
        }
        if step.length() <= epsilon {
            converged = true;
            break;
        }
    }
    if !ok {
        q = start;
        converged = false;
    }
    *c = q;
    Refinement { half_window: half, iterations, shift: (q - start).length(), converged }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use image::Luma;

    /// The scalar loop `saddle_sums` replaced (per-pixel weights, upper triangle only).
    fn saddle_sums_naive(win: &SaddleWindow<'_>) -> ([[f64; 6]; 6], [f64; 6]) {
        let mut ata = [[0.0f64; 6]; 6];
        let mut atb = [0.0f64; 6];
        let (q, radius) = (win.centre, win.radius);
        for y in win.ys.0..=win.ys.1 {
            let dy = y as f64 - q.y;
            let wy = biweight(dy, radius);
            for x in win.xs.0..=win.xs.1 {
                let dx = x as f64 - q.x;
                let wt = wy * biweight(dx, radius);
                if wt == 0.0 {
                    continue;
                }
                let v = win.data[y as usize * win.width + x as usize] as f64;
                let r = [dx * dx, dx * dy, dy * dy, dx, dy, 1.0];
                for i in 0..6 {
                    let wr = wt * r[i];
                    for j in i..6 {
                        ata[i][j] += wr * r[j];
                    }
                    atb[i] += wr * v;
                }
            }
        }
        (ata, atb)
    }

    #[test]
    fn saddle_sums_equal_the_scalar_loop_bit_for_bit_on_every_instruction_set() {
        // A fixed linear congruential sequence: uniform numbers in [0, 1).
        let mut state = 18u64;
        let mut unif = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (w, h) = (97usize, 61usize);
        let data: Vec<f32> = (0..w * h).map(|_| (255.0 * unif()) as f32).collect();
        let isas = crate::imageops::available_isas();
        // Baseline, and AVX2 where the CPU has it.
        assert!(!isas.is_empty());
        for case in 0..300 {
            let centre = DVec2::new(unif() * (w as f64 + 6.0) - 3.0, unif() * (h as f64 + 6.0) - 3.0);
            // Radii up to 40.5 (wider than the 64-column stack buffer), fractional.
            let radius = if case % 50 == 0 { 40.5 } else { 1.0 + 11.0 * unif() };
            let (x0, x1) = ((centre.x - radius).ceil() as i64, (centre.x + radius).floor() as i64);
            let (y0, y1) = ((centre.y - radius).ceil() as i64, (centre.y + radius).floor() as i64);
            let win = SaddleWindow {
                data: &data,
                width: w,
                xs: (x0.max(0), x1.min(w as i64 - 1)),
                ys: (y0.max(0), y1.min(h as i64 - 1)),
                centre,
                radius,
            };
            let (ata, atb) = saddle_sums_naive(&win);
            for &isa in &isas {
                let acc = saddle_sums(&win, isa);
                for i in 0..6 {
                    for j in i..6 {
                        assert_eq!(acc[i][j].to_bits(), ata[i][j].to_bits(), "{isa:?} case {case} ({i}, {j})");
                    }
                    assert_eq!(acc[i][6].to_bits(), atb[i].to_bits(), "{isa:?} case {case} b{i}");
                }
            }
        }
    }

    /// Blurred X-junction of two lines through `c` with directions `a1`, `a2` (radians):
    /// `mid + A·erf(d1/(σ√2))·erf(d2/(σ√2))` at the pixel centres, `d1, d2` the signed distances
    /// to the lines. Point-symmetric about `c` (as any blurred X-junction), and smooth, so the
    /// test measures the estimator, not a renderer's quantisation.
    pub(crate) fn x_junction(w: u32, h: u32, c: DVec2, a1: f64, a2: f64, dark: f64, bright: f64) -> GrayImage {
        x_junction_blur(w, h, c, a1, a2, dark, bright, 0.8)
    }

    fn erf(x: f64) -> f64 {
        // Abramowitz–Stegun 7.1.26 is too coarse (1.5e-7 is fine, but keep it odd-exact).
        let t = 1.0 / (1.0 + 0.5 * x.abs());
        let y = 1.0
            - t * (-x * x - 1.26551223
                + t * (1.00002368
                    + t * (0.37409196
                        + t * (0.09678418
                            + t * (-0.18628806
                                + t * (0.27886807
                                    + t * (-1.13520398 + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277)))))))))
                .exp();
        if x >= 0.0 { y } else { -y }
    }

    pub(crate) fn x_junction_blur(
        w: u32,
        h: u32,
        c: DVec2,
        a1: f64,
        a2: f64,
        dark: f64,
        bright: f64,
        sigma: f64,
    ) -> GrayImage {
        let n1 = DVec2::new(-a1.sin(), a1.cos());
        let n2 = DVec2::new(-a2.sin(), a2.cos());
        let s = sigma * std::f64::consts::SQRT_2;
        GrayImage::from_fn(w, h, |x, y| {
            let d = DVec2::new(x as f64, y as f64) - c;
            let v = 0.5 * (bright + dark) + 0.5 * (bright - dark) * erf(d.dot(n1) / s) * erf(d.dot(n2) / s);
            Luma([v.round().clamp(0.0, 255.0) as u8])
        })
    }

    #[test]
    fn subpix_is_exact_on_skewed_junctions() {
        for (k, &(a1, a2)) in
            [(0.0, std::f64::consts::FRAC_PI_2), (0.3, 1.2), (-0.4, 0.6), (1.0, 2.6)].iter().enumerate()
        {
            let truth = DVec2::new(30.37 + k as f64 * 0.11, 29.71 - k as f64 * 0.07);
            let img = x_junction(60, 60, truth, a1, a2, 30.0, 220.0);
            let mut c = [truth + DVec2::new(1.2, -0.9)];
            let cfg = SubPixConfig { window: WindowSize::Fixed(7), ..Default::default() };
            let r = refine_corners_subpix(&img, &mut c, &cfg).unwrap();
            assert!(r[0].converged);
            assert!((c[0] - truth).length() < 0.01, "angles {a1},{a2}: error {}", (c[0] - truth).length());
        }
    }

    #[test]
    fn saddle_fit_is_exact_on_skewed_junctions() {
        for (k, &(a1, a2)) in [(0.0, std::f64::consts::FRAC_PI_2), (0.3, 1.2), (-0.4, 0.6)].iter().enumerate() {
            let truth = DVec2::new(30.37 + k as f64 * 0.13, 29.71 - k as f64 * 0.05);
            let img = x_junction(60, 60, truth, a1, a2, 30.0, 220.0);
            let mut c = [truth + DVec2::new(0.8, -0.6)];
            let cfg = SaddleConfig { window: WindowSize::Fixed(4), ..Default::default() };
            let r = refine_saddle(&img, &mut c, &cfg).unwrap();
            assert!(r[0].converged, "{r:?}");
            assert!((c[0] - truth).length() < 0.02, "angles {a1},{a2}: error {}", (c[0] - truth).length());
        }
    }

    #[test]
    fn saddle_fit_rejects_a_blob() {
        let img = GrayImage::from_fn(40, 40, |x, y| {
            let d2 = (x as f64 - 20.0).powi(2) + (y as f64 - 20.0).powi(2);
            Luma([(200.0 * (-d2 / 50.0).exp()) as u8 + 20])
        });
        let mut c = [DVec2::new(20.5, 19.5)];
        let r = refine_saddle(&img, &mut c, &SaddleConfig::default()).unwrap();
        assert!(!r[0].converged);
        assert_eq!(c[0], DVec2::new(20.5, 19.5));
    }

    #[test]
    fn automatic_window_follows_the_spacing() {
        let corners =
            [DVec2::new(10.0, 10.0), DVec2::new(30.0, 10.0), DVec2::new(10.0, 22.0), DVec2::new(100.0, 100.0)];
        let w = WindowSize::FromSpacing { fraction: 0.3, min: 2, max: 10 };
        // nearest distances 12, 20, 12, ~102 -> 3.6→4, 6, 4, 10 (clamped)
        assert_eq!(w.half_sizes(&corners), vec![4, 6, 4, 10]);
        assert_eq!(w.half_sizes(&corners[..1]), vec![10]);
    }

    #[test]
    fn automatic_window_is_not_dragged_by_close_neighbours() {
        // Fine chequerboard with 12 px squares: an 11x11 OpenCV-style window (half 11) reaches
        // the neighbouring corners; the spacing-derived window does not.
        let sq = 12.0;
        let off = DVec2::new(0.3, 0.45);
        let img = GrayImage::from_fn(96, 96, |x, y| {
            let mut s = 0.0f64;
            for i in 0..4 {
                for j in 0..4 {
                    let u = x as f64 - 0.5 + ((i * 4 + j) as f64 + 0.5) / 16.0 - off.x;
                    let v = y as f64 - 0.5 + ((j * 4 + i) as f64 + 0.5) / 16.0 - off.y;
                    let c = ((u / sq).floor() as i64 + (v / sq).floor() as i64).rem_euclid(2);
                    s += if c == 0 { 40.0 } else { 200.0 };
                }
            }
            Luma([(s / 16.0).round() as u8])
        });
        let img = imageproc::filter::gaussian_blur_f32(&img, 0.8);
        let truth: Vec<DVec2> =
            (3..6).flat_map(|r| (3..6).map(move |c| DVec2::new(c as f64 * sq, r as f64 * sq) + off)).collect();
        let mut auto: Vec<DVec2> = truth.iter().map(|t| *t + DVec2::new(0.7, -0.5)).collect();
        let r = refine_corners_subpix(&img, &mut auto, &SubPixConfig::default()).unwrap();
        // 30 % of the 12 px spacing: half-size 4, the window (radius 5) stays clear of the
        // neighbours' edges.
        assert!(r.iter().all(|r| r.half_window == 4 && r.converged), "{r:?}");
        let worst = auto.iter().zip(&truth).map(|(a, t)| (*a - *t).length()).fold(0.0, f64::max);
        // Small windows on a 4x4-supersampled render: the render itself is good to ~0.02 px.
        assert!(worst < 0.08, "auto window error {worst}");
    }

    #[test]
    fn corners_outside_the_image_are_errors() {
        let img = GrayImage::new(20, 20);
        let mut c = [DVec2::new(5.0, 5.0), DVec2::new(f64::NAN, 3.0)];
        let e = refine_corners_subpix(&img, &mut c, &SubPixConfig::default()).unwrap_err();
        assert!(matches!(e, CornerError::CornerOutsideImage { index: 1, .. }));
        let mut c = [DVec2::new(25.0, 5.0)];
        assert!(refine_saddle(&img, &mut c, &SaddleConfig::default()).is_err());
        let bad =
            SubPixConfig { window: WindowSize::FromSpacing { fraction: 0.7, min: 2, max: 5 }, ..Default::default() };
        assert!(matches!(refine_corners_subpix(&img, &mut [], &bad), Err(CornerError::InvalidConfig(_))));
    }
}
