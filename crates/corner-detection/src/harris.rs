//! Harris / Shi–Tomasi corner response, thresholding, non-maximum suppression and top-N.

use glam::DVec2;
use image::{GrayImage, ImageBuffer};
use serde::{Deserialize, Serialize};

use crate::imageops::{ImageF32, gaussian_blur};
use crate::{CornerError, Result};

/// Which corner measure to compute from the structure tensor `M = [a b; b c]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum CornerMeasure {
    /// Harris & Stephens: `det M − k·(trace M)²`.
    #[default]
    Harris,
    /// Shi–Tomasi: the smaller eigenvalue of `M`.
    ShiTomasi,
}

/// Configuration of [`harris_response`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HarrisConfig {
    /// Standard deviation of the Gaussian window that sums the gradient products, pixels
    /// (1.0 ≈ OpenCV's `blockSize` 3). Must be positive.
    pub window_sigma: f64,
    /// Harris sensitivity `k` (OpenCV's usual 0.04); unused for Shi–Tomasi.
    pub k: f64,
    /// Harris or Shi–Tomasi.
    pub measure: CornerMeasure,
    /// Optional Gaussian pre-smoothing of the image before the Sobel gradients, pixels
    /// (0 = none).
    pub pre_blur_sigma: f64,
}

impl Default for HarrisConfig {
    fn default() -> Self {
        Self { window_sigma: 1.0, k: 0.04, measure: CornerMeasure::Harris, pre_blur_sigma: 0.0 }
    }
}

impl HarrisConfig {
    fn validate(&self) -> Result<()> {
        if !(self.window_sigma.is_finite() && self.window_sigma > 0.0) {
            return Err(CornerError::InvalidConfig(format!(
                "HarrisConfig::window_sigma must be positive, got {}",
                self.window_sigma
            )));
        }
        if !(self.k.is_finite() && (0.0..0.25).contains(&self.k)) {
            return Err(CornerError::InvalidConfig(format!("HarrisConfig::k must be in [0, 0.25), got {}", self.k)));
        }
        if !(self.pre_blur_sigma.is_finite() && self.pre_blur_sigma >= 0.0) {
            return Err(CornerError::InvalidConfig(format!(
                "HarrisConfig::pre_blur_sigma must be >= 0, got {}",
                self.pre_blur_sigma
            )));
        }
        Ok(())
    }
}

/// Corner response map: the structure tensor is built from imageproc's Sobel gradients (scaled
/// to grey levels per pixel), summed with a Gaussian window, then turned into the Harris or
/// Shi–Tomasi measure. Units: (grey levels / pixel)⁴ for Harris, (grey levels / pixel)² for
/// Shi–Tomasi.
///
/// Errors on an image smaller than 3x3 or an invalid configuration.
pub fn harris_response(img: &GrayImage, cfg: &HarrisConfig) -> Result<ImageF32> {
    cfg.validate()?;
    crate::imageops::check_size(img, 3, "harris_response")?;
    let src = if cfg.pre_blur_sigma > 0.0 {
        let f = gaussian_blur(&crate::imageops::to_f32(img), cfg.pre_blur_sigma);
        ImageBuffer::from_raw(
            img.width(),
            img.height(),
            f.as_raw().iter().map(|&v| v.round().clamp(0.0, 255.0) as u8).collect(),
        )
        .expect("same size")
    } else {
        img.clone()
    };
    let gx = imageproc::gradients::horizontal_sobel(&src);
    let gy = imageproc::gradients::vertical_sobel(&src);
    let (w, h) = img.dimensions();
    let n = (w * h) as usize;
    let (mut a, mut b, mut c) = (vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]);
    for (i, (dx, dy)) in gx.as_raw().iter().zip(gy.as_raw()).enumerate() {
        // Sobel's 3x3 kernel has gain 8 for a unit ramp.
        let (dx, dy) = (*dx as f32 / 8.0, *dy as f32 / 8.0);
        a[i] = dx * dx;
        b[i] = dx * dy;
        c[i] = dy * dy;
    }
    let to_img = |v: Vec<f32>| -> ImageF32 { ImageBuffer::from_raw(w, h, v).expect("same size") };
    let a = gaussian_blur(&to_img(a), cfg.window_sigma);
    let b = gaussian_blur(&to_img(b), cfg.window_sigma);
    let c = gaussian_blur(&to_img(c), cfg.window_sigma);
    let k = cfg.k as f32;
    let out: Vec<f32> = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .zip(c.as_raw())
        .map(|((&a, &b), &c)| match cfg.measure {
            CornerMeasure::Harris => a * c - b * b - k * (a + c) * (a + c),
            CornerMeasure::ShiTomasi => 0.5 * (a + c - ((a - c) * (a - c) + 4.0 * b * b).sqrt()),
        })
        .collect();
    Ok(to_img(out))
}

/// A detected corner.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Corner {
    /// Position in pixels (peak of the response, interpolated to sub-pixel by a parabola fit
    /// in each direction; refine with [`crate::refine_corners_subpix`] for accuracy).
    pub position: DVec2,
    /// Response at the peak (units of [`harris_response`]).
    pub response: f32,
}

/// Configuration of [`detect_corners`] (as OpenCV's `goodFeaturesToTrack`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CornerConfig {
    /// The response map.
    pub harris: HarrisConfig,
    /// Keep peaks whose response is at least this fraction of the strongest one (0..1).
    pub quality_level: f64,
    /// Minimum distance between returned corners, pixels (stronger corners win).
    pub min_distance: f64,
    /// Return at most this many corners, strongest first (0 = no limit).
    pub max_corners: usize,
    /// Ignore peaks closer than this to the image border, pixels.
    pub border: u32,
}

impl Default for CornerConfig {
    fn default() -> Self {
        Self { harris: HarrisConfig::default(), quality_level: 0.01, min_distance: 10.0, max_corners: 1000, border: 3 }
    }
}

/// Harris (or Shi–Tomasi) corners: response map, threshold at `quality_level × max`, 3x3
/// local maxima, greedy minimum-distance suppression (strongest first) and top-N, strongest
/// first. A flat image returns no corner.
///
/// ```
/// use parallax_corner_detection::{detect_corners, CornerConfig};
/// // A bright square on a dark background has four corners.
/// let img = image::GrayImage::from_fn(64, 64, |x, y| {
///     image::Luma([if (16..48).contains(&x) && (16..48).contains(&y) { 200 } else { 20 }])
/// });
/// let corners = detect_corners(&img, &CornerConfig::default())?;
/// assert_eq!(corners.len(), 4);
/// # Ok::<(), parallax_corner_detection::CornerError>(())
/// ```
pub fn detect_corners(img: &GrayImage, cfg: &CornerConfig) -> Result<Vec<Corner>> {
    if !(cfg.quality_level.is_finite() && cfg.quality_level > 0.0 && cfg.quality_level < 1.0) {
        return Err(CornerError::InvalidConfig(format!(
            "CornerConfig::quality_level must be in (0, 1), got {}",
            cfg.quality_level
        )));
    }
    if !(cfg.min_distance.is_finite() && cfg.min_distance >= 0.0) {
        return Err(CornerError::InvalidConfig(format!(
            "CornerConfig::min_distance must be >= 0, got {}",
            cfg.min_distance
        )));
    }
    let r = harris_response(img, &cfg.harris)?;
    Ok(peaks(&r, cfg.quality_level as f32, cfg.min_distance, cfg.max_corners, cfg.border.max(1)))
}

/// Local maxima of a response map above `quality × max`, suppressed to `min_distance`,
/// strongest first, at most `max` (0 = all). Positions are refined by 1D parabola fits.
pub(crate) fn peaks(r: &ImageF32, quality: f32, min_distance: f64, max: usize, border: u32) -> Vec<Corner> {
    peaks_above(r, quality, 0.0, min_distance, max, border)
}

/// Marks the strict local maxima of row `cur` among its 8 neighbours (ties go to the first pixel
/// in raster order, so a pixel must beat its earlier neighbours and tie-or-beat the later ones)
/// that are at least `thr` and positive: `keep[i]` is column `x0 + i`. Branch-free so it
/// vectorises; run through an AVX2 copy when the CPU has it.
pub(crate) fn row_maxima((prev, cur, next): (&[f32], &[f32], &[f32]), thr: f32, keep: &mut [bool], x0: usize) {
    #[inline(always)]
    fn imp((prev, cur, next): (&[f32], &[f32], &[f32]), thr: f32, keep: &mut [bool], x0: usize) {
        let n = keep.len();
        let (pl, pc, pr) = (&prev[x0 - 1..x0 - 1 + n], &prev[x0..x0 + n], &prev[x0 + 1..x0 + 1 + n]);
        let (cl, cc, cr) = (&cur[x0 - 1..x0 - 1 + n], &cur[x0..x0 + n], &cur[x0 + 1..x0 + 1 + n]);
        let (nl, nc, nr) = (&next[x0 - 1..x0 - 1 + n], &next[x0..x0 + n], &next[x0 + 1..x0 + 1 + n]);
        for i in 0..n {
            let v = cc[i];
            keep[i] = (v >= thr)
                & (v > 0.0)
                & (v > pl[i])
                & (v > pc[i])
                & (v > pr[i])
                & (v > cl[i])
                & (v >= cr[i])
                & (v >= nl[i])
                & (v >= nc[i])
                & (v >= nr[i]);
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn avx2(rows: (&[f32], &[f32], &[f32]), thr: f32, keep: &mut [bool], x0: usize) {
        imp(rows, thr, keep, x0)
    }
    #[cfg(target_arch = "x86_64")]
    if parallax_simd::Avx2::new().is_some() {
        // SAFETY: the token proves AVX2.
        return unsafe { avx2((prev, cur, next), thr, keep, x0) };
    }
    imp((prev, cur, next), thr, keep, x0)
}

/// As [`peaks`], with an absolute floor `min_abs` on the response as well.
pub(crate) fn peaks_above(
    r: &ImageF32,
    quality: f32,
    min_abs: f32,
    min_distance: f64,
    max: usize,
    border: u32,
) -> Vec<Corner> {
    let (w, h) = (r.width() as usize, r.height() as usize);
    let d = r.as_raw();
    // maximum over 8 interleaved lanes (vectorises; the sequential `f32::max` fold does not)
    let mut lanes = [0.0f32; 8];
    let chunks = d.chunks_exact(8);
    let rest = chunks.remainder();
    for c in chunks {
        for (m, &v) in lanes.iter_mut().zip(c) {
            *m = if v > *m { v } else { *m };
        }
    }
    let max_r = rest.iter().chain(&lanes).fold(0.0f32, |m, &v| if v > m { v } else { m });
    if max_r <= 0.0 || !max_r.is_finite() {
        return Vec::new();
    }
    let thr = (quality * max_r).max(min_abs);
    // at least one pixel of border: every candidate has its 8 neighbours
    let b = (border as usize).max(1);
    let mut cand: Vec<(f32, usize, usize)> = Vec::new();
    if w > 2 * b && h > 2 * b {
        let mut keep = vec![false; w];
        for y in b..h - b {
            let rows = (&d[(y - 1) * w..y * w], &d[y * w..(y + 1) * w], &d[(y + 1) * w..(y + 2) * w]);
            row_maxima(rows, thr, &mut keep[b..w - b], b);
            for x in b..w - b {
                if keep[x] {
                    cand.push((d[y * w + x], x, y));
                }
            }
        }
    }
    cand.sort_by(|a, b| b.0.total_cmp(&a.0));
    // Greedy minimum distance with a bucket grid (as goodFeaturesToTrack).
    let cell = min_distance.max(1.0);
    let gw = (w as f64 / cell).ceil() as usize + 1;
    let gh = (h as f64 / cell).ceil() as usize + 1;
    let mut grid: Vec<Vec<DVec2>> = vec![Vec::new(); gw * gh];
    let mut out = Vec::new();
    for (v, x, y) in cand {
        let p = DVec2::new(x as f64, y as f64);
        if min_distance > 0.0 {
            let (cx, cy) = ((p.x / cell) as usize, (p.y / cell) as usize);
            let mut ok = true;
            'g: for gy in cy.saturating_sub(1)..=(cy + 1).min(gh - 1) {
                for gx in cx.saturating_sub(1)..=(cx + 1).min(gw - 1) {
                    if grid[gy * gw + gx].iter().any(|q| (*q - p).length_squared() < min_distance * min_distance) {
                        ok = false;
                        break 'g;
                    }
                }
            }
            if !ok {
                continue;
            }
            grid[cy * gw + cx].push(p);
        }
        let at = |xx: usize, yy: usize| d[yy * w + xx] as f64;
        let fit = |m: f64, c: f64, p: f64| {
            let den = m - 2.0 * c + p;
            if den < 0.0 { (0.5 * (m - p) / den).clamp(-0.5, 0.5) } else { 0.0 }
        };
        let ox = fit(at(x - 1, y), at(x, y), at(x + 1, y));
        let oy = fit(at(x, y - 1), at(x, y), at(x, y + 1));
        out.push(Corner { position: DVec2::new(x as f64 + ox, y as f64 + oy), response: v });
        if max > 0 && out.len() >= max {
            break;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Luma;

    fn square_image() -> GrayImage {
        GrayImage::from_fn(80, 60, |x, y| Luma([if (20..50).contains(&x) && (15..40).contains(&y) { 220 } else { 30 }]))
    }

    #[test]
    fn harris_and_shi_tomasi_find_the_four_corners_of_a_rectangle() {
        // True corners of the bright rectangle lie on the pixel boundaries: (19.5, 14.5) etc.
        let truth = [DVec2::new(19.5, 14.5), DVec2::new(49.5, 14.5), DVec2::new(19.5, 39.5), DVec2::new(49.5, 39.5)];
        for measure in [CornerMeasure::Harris, CornerMeasure::ShiTomasi] {
            let cfg = CornerConfig { harris: HarrisConfig { measure, ..Default::default() }, ..Default::default() };
            let corners = detect_corners(&square_image(), &cfg).unwrap();
            assert_eq!(corners.len(), 4, "{measure:?}: {corners:?}");
            for t in truth {
                let best = corners.iter().map(|c| (c.position - t).length()).fold(f64::MAX, f64::min);
                // The response peak of an L-corner sits inside the bright region by about one
                // window sigma; sub-pixel refinement fixes that.
                assert!(best < 2.0, "{measure:?}: corner {t} missed by {best}");
            }
        }
    }

    #[test]
    fn edges_and_flat_regions_have_no_corner_response() {
        let img = GrayImage::from_fn(40, 40, |x, _| Luma([if x < 20 { 10 } else { 240 }]));
        let r = harris_response(&img, &HarrisConfig::default()).unwrap();
        // Along a straight edge Harris is negative (one large eigenvalue), away from it zero.
        assert!(r.get_pixel(20, 20)[0] < 0.0);
        assert_eq!(r.get_pixel(5, 20)[0], 0.0);
        assert!(detect_corners(&img, &CornerConfig::default()).unwrap().is_empty());
        let flat = GrayImage::from_pixel(30, 30, Luma([128]));
        assert!(detect_corners(&flat, &CornerConfig::default()).unwrap().is_empty());
    }

    #[test]
    fn shi_tomasi_equals_min_eigenvalue_of_a_hand_built_tensor() {
        // One bright pixel: the gradient products are known in closed form only via the
        // filter, so compare the measure against an independent eigen-decomposition at a pixel.
        let mut img = GrayImage::from_pixel(21, 21, Luma([0]));
        for y in 8..13 {
            for x in 8..13 {
                img.put_pixel(x, y, Luma([200]));
            }
        }
        let cfg_h = HarrisConfig { k: 0.0, ..Default::default() };
        let cfg_s = HarrisConfig { measure: CornerMeasure::ShiTomasi, ..Default::default() };
        let det = harris_response(&img, &cfg_h).unwrap();
        let lmin = harris_response(&img, &cfg_s).unwrap();
        // With k = 0 Harris is det M = λ1 λ2; Shi–Tomasi is λmin ≤ sqrt(det).
        for (d, l) in det.as_raw().iter().zip(lmin.as_raw()) {
            assert!(*l >= -1e-3);
            assert!(*l <= d.max(0.0).sqrt() + 1e-2, "λmin {l} > sqrt(det) {}", d.sqrt());
        }
    }

    #[test]
    fn top_n_and_min_distance_are_respected() {
        // A small chequer pattern has many corners; ask for 3 at least 12 px apart.
        let img = GrayImage::from_fn(96, 96, |x, y| Luma([if ((x / 16) + (y / 16)) % 2 == 0 { 40 } else { 210 }]));
        let cfg = CornerConfig { max_corners: 3, min_distance: 12.0, ..Default::default() };
        let c = detect_corners(&img, &cfg).unwrap();
        assert_eq!(c.len(), 3);
        for i in 0..3 {
            for j in 0..i {
                assert!((c[i].position - c[j].position).length() >= 12.0);
            }
            if i > 0 {
                assert!(c[i].response <= c[i - 1].response);
            }
        }
    }

    #[test]
    fn invalid_configs_and_tiny_images_are_errors() {
        let img = square_image();
        let bad = CornerConfig { quality_level: 1.5, ..Default::default() };
        assert!(matches!(detect_corners(&img, &bad), Err(CornerError::InvalidConfig(_))));
        let bad = HarrisConfig { window_sigma: 0.0, ..Default::default() };
        assert!(harris_response(&img, &bad).is_err());
        let tiny = GrayImage::new(2, 2);
        assert!(matches!(harris_response(&tiny, &HarrisConfig::default()), Err(CornerError::ImageTooSmall { .. })));
    }
}
