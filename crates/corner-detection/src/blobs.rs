//! Blob targets (circular marks): weighted grayscale conversion, Otsu threshold, 8-connected
//! components, area and shape filters, sub-pixel centroids.

use glam::DVec2;
use image::{GrayImage, Luma, RgbImage};
use imageproc::region_labelling::{Connectivity, connected_components};
use serde::{Deserialize, Serialize};

use crate::{CornerError, Result};

/// Weighted grayscale conversion `Y = wr·R + wg·G + wb·B` (weights are normalised to sum 1;
/// the default is ITU-R BT.601, as OpenCV's `cvtColor(RGB2GRAY)`).
pub fn weighted_gray(img: &RgbImage, weights: [f64; 3]) -> Result<GrayImage> {
    let sum: f64 = weights.iter().sum();
    if weights.iter().any(|w| !w.is_finite() || *w < 0.0) || sum <= 0.0 {
        return Err(CornerError::InvalidConfig(format!(
            "grayscale weights must be non-negative with a positive sum, got {weights:?}"
        )));
    }
    let w = weights.map(|v| v / sum);
    Ok(GrayImage::from_fn(img.width(), img.height(), |x, y| {
        let p = img.get_pixel(x, y).0;
        let v = w[0] * p[0] as f64 + w[1] * p[1] as f64 + w[2] * p[2] as f64;
        Luma([v.round().clamp(0.0, 255.0) as u8])
    }))
}

/// Smallest span between the brightest and the darkest pixel of a window for the local
/// threshold ([`BlobConfig::local_radius`]) to mark anything in it, grey levels.
pub const LOCAL_MIN_CONTRAST: u8 = 20;

/// ITU-R BT.601 luma weights (R, G, B).
pub const BT601: [f64; 3] = [0.299, 0.587, 0.114];

/// Which blobs to look for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum BlobPolarity {
    /// Dark marks on a bright background (pixels at or below the threshold).
    #[default]
    Dark,
    /// Bright marks on a dark background (pixels above the threshold).
    Bright,
}

/// Configuration of [`detect_blobs`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BlobConfig {
    /// Dark or bright marks.
    pub polarity: BlobPolarity,
    /// Fixed threshold in grey levels; `None` = Otsu's threshold of the image (or the local
    /// threshold, with `local_radius`).
    pub threshold: Option<u8>,
    /// Threshold each pixel half way between the brightest and the darkest pixel within this
    /// many pixels (a square window), instead of one threshold for the image: for light that
    /// varies across the image or a highlight on the print. A pixel whose window spans fewer
    /// than [`LOCAL_MIN_CONTRAST`] grey levels is background. The radius must exceed the marks'
    /// radius. `None` (the default) for one threshold; not with a fixed `threshold`.
    pub local_radius: Option<u32>,
    /// Smallest blob area, pixels.
    pub min_area: usize,
    /// Largest blob area, pixels.
    pub max_area: usize,
    /// Largest ratio of the major to the minor axis of the blob's second moments (1 = circle).
    pub max_aspect_ratio: f64,
    /// Smallest fill ratio: area / area of the moment ellipse (≈ 1 for a filled ellipse,
    /// smaller for rings, crosses and ragged shapes).
    pub min_fill: f64,
    /// Discard blobs that touch the image border.
    pub reject_border: bool,
}

impl Default for BlobConfig {
    fn default() -> Self {
        Self {
            polarity: BlobPolarity::Dark,
            threshold: None,
            local_radius: None,
            min_area: 10,
            max_area: 100_000,
            max_aspect_ratio: 3.0,
            min_fill: 0.8,
            reject_border: true,
        }
    }
}

/// One blob.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Blob {
    /// Sub-pixel centre: the centroid weighted by each pixel's coverage by the mark, estimated
    /// from the paper's level around the blob (a plane fitted to it) and the mark's inside it,
    /// over the blob and the pixels touching it (rim pixels count by the part the mark
    /// covers).
    pub centroid: DVec2,
    /// Unweighted centroid of the binary component.
    pub binary_centroid: DVec2,
    /// Area, pixels.
    pub area: usize,
    /// Major / minor axis of the second moments.
    pub aspect_ratio: f64,
    /// Area / area of the moment ellipse.
    pub fill: f64,
    /// Bounding box `(min_x, min_y, max_x, max_y)`, pixels, inclusive.
    pub bbox: (u32, u32, u32, u32),
}

/// What [`detect_blobs`] found, with the threshold it used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlobDetection {
    /// The threshold (grey levels).
    pub threshold: u8,
    /// Accepted blobs, sorted by row then column of their centroid.
    pub blobs: Vec<Blob>,
    /// Number of components rejected by the area / shape / border filters.
    pub rejected: usize,
}

/// Detects blob targets: threshold (Otsu by default), 8-connected components of the marks'
/// polarity, area / aspect / fill filters, sub-pixel weighted centroids.
///
/// ```
/// use parallax_corner_detection::{detect_blobs, BlobConfig};
/// let img = image::GrayImage::from_fn(60, 40, |x, y| {
///     let d = ((x as f64 - 20.0).powi(2) + (y as f64 - 18.0).powi(2)).sqrt();
///     image::Luma([if d < 6.0 { 20 } else { 230 }])
/// });
/// let found = detect_blobs(&img, &BlobConfig::default())?;
/// assert_eq!(found.blobs.len(), 1);
/// assert!((found.blobs[0].centroid - glam::DVec2::new(20.0, 18.0)).length() < 0.01);
/// # Ok::<(), parallax_corner_detection::CornerError>(())
/// ```
pub fn detect_blobs(img: &GrayImage, cfg: &BlobConfig) -> Result<BlobDetection> {
    crate::imageops::check_size(img, 1, "detect_blobs")?;
    if cfg.min_area == 0 || cfg.max_area < cfg.min_area {
        return Err(CornerError::InvalidConfig(format!(
            "BlobConfig needs 1 <= min_area <= max_area, got {}..{}",
            cfg.min_area, cfg.max_area
        )));
    }
    if cfg.max_aspect_ratio.is_nan() || cfg.max_aspect_ratio < 1.0 || !cfg.min_fill.is_finite() || cfg.min_fill < 0.0 {
        return Err(CornerError::InvalidConfig(format!(
            "BlobConfig needs max_aspect_ratio >= 1 and min_fill >= 0, got {} and {}",
            cfg.max_aspect_ratio, cfg.min_fill
        )));
    }
    if cfg.local_radius.is_some() && cfg.threshold.is_some() {
        return Err(CornerError::InvalidConfig(
            "BlobConfig takes a fixed threshold or a local_radius, not both".into(),
        ));
    }
    let t = cfg.threshold.unwrap_or_else(|| imageproc::contrast::otsu_level(img));
    // The local extremes (brightest, darkest) of every pixel's window, for the local threshold.
    let local = cfg.local_radius.map(|r| {
        let (w, h) = (img.width() as usize, img.height() as usize);
        (window_extreme(img.as_raw(), w, h, r as usize, true), window_extreme(img.as_raw(), w, h, r as usize, false))
    });
    let is_mark = |i: usize, v: u8| {
        let (t, contrast) = match &local {
            Some((hi, lo)) => ((u16::from(hi[i]) + u16::from(lo[i])) / 2, hi[i] - lo[i] >= LOCAL_MIN_CONTRAST),
            None => (u16::from(t), true),
        };
        contrast
            && match cfg.polarity {
                BlobPolarity::Dark => u16::from(v) <= t,
                BlobPolarity::Bright => u16::from(v) > t,
            }
    };
    let binary = GrayImage::from_fn(img.width(), img.height(), |x, y| {
        let i = y as usize * img.width() as usize + x as usize;
        Luma([if is_mark(i, img.get_pixel(x, y)[0]) { 255 } else { 0 }])
    });
    let labels = connected_components(&binary, Connectivity::Eight, Luma([0u8]));
    let n = labels.iter().copied().max().unwrap_or(0) as usize;
    #[derive(Clone, Copy)]
    struct Acc {
        n: f64,
        sx: f64,
        sy: f64,
        sxx: f64,
        syy: f64,
        sxy: f64,
        w: f64,
        wx: f64,
        wy: f64,
        bbox: (u32, u32, u32, u32),
    }
    let mut acc = vec![
        Acc {
            n: 0.0,
            sx: 0.0,
            sy: 0.0,
            sxx: 0.0,
            syy: 0.0,
            sxy: 0.0,
            w: 0.0,
            wx: 0.0,
            wy: 0.0,
            bbox: (u32::MAX, u32::MAX, 0, 0)
        };
        n + 1
    ];
    for (x, y, l) in labels.enumerate_pixels() {
        let l = l[0] as usize;
        if l == 0 {
            continue;
        }
        let a = &mut acc[l];
        let (fx, fy) = (x as f64, y as f64);
        a.n += 1.0;
        a.sx += fx;
        a.sy += fy;
        a.sxx += fx * fx;
        a.syy += fy * fy;
        a.sxy += fx * fy;
        let v = img.get_pixel(x, y)[0] as f64;
        let w = match cfg.polarity {
            BlobPolarity::Dark => t as f64 + 0.5 - v,
            BlobPolarity::Bright => v - t as f64 - 0.5,
        }
        .max(0.0);
        a.w += w;
        a.wx += w * fx;
        a.wy += w * fy;
        a.bbox = (a.bbox.0.min(x), a.bbox.1.min(y), a.bbox.2.max(x), a.bbox.3.max(y));
    }
    // Class means of the threshold (Otsu's two classes): the ideal mark and background levels.
    let (mut n_lo, mut s_lo, mut n_hi, mut s_hi) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &v in img.as_raw() {
        if v <= t {
            n_lo += 1.0;
            s_lo += v as f64;
        } else {
            n_hi += 1.0;
            s_hi += v as f64;
        }
    }
    let (lo, hi) = (if n_lo > 0.0 { s_lo / n_lo } else { 0.0 }, if n_hi > 0.0 { s_hi / n_hi } else { 255.0 });
    let (mark, background) = match cfg.polarity {
        BlobPolarity::Dark => (lo, hi),
        BlobPolarity::Bright => (hi, lo),
    };
    let mut blobs = Vec::new();
    let mut rejected = 0;
    for (label, a) in acc.iter().enumerate().skip(1) {
        let area = a.n as usize;
        if area == 0 {
            continue;
        }
        let touches = a.bbox.0 == 0 || a.bbox.1 == 0 || a.bbox.2 + 1 == img.width() || a.bbox.3 + 1 == img.height();
        let (mx, my) = (a.sx / a.n, a.sy / a.n);
        // Central second moments (+1/12 for the pixel's own extent).
        let cxx = a.sxx / a.n - mx * mx + 1.0 / 12.0;
        let cyy = a.syy / a.n - my * my + 1.0 / 12.0;
        let cxy = a.sxy / a.n - mx * my;
        let tr = cxx + cyy;
        let disc = ((cxx - cyy).powi(2) + 4.0 * cxy * cxy).sqrt();
        let (l1, l2) = (0.5 * (tr + disc), (0.5 * (tr - disc)).max(1e-12));
        let aspect = (l1 / l2).sqrt();
        // A filled ellipse with semi-axes a, b has variances a²/4, b²/4: area π a b = 4π√(l1 l2).
        let fill = a.n / (4.0 * std::f64::consts::PI * (l1 * l2).sqrt());
        if area < cfg.min_area
            || area > cfg.max_area
            || aspect > cfg.max_aspect_ratio
            || fill < cfg.min_fill
            || (cfg.reject_border && touches)
        {
            rejected += 1;
            continue;
        }
        let centroid = coverage_centroid(img, &labels, label as u32, a.bbox, mark, background)
            .unwrap_or(if a.w > 0.0 { DVec2::new(a.wx / a.w, a.wy / a.w) } else { DVec2::new(mx, my) });
        blobs.push(Blob {
            centroid,
            binary_centroid: DVec2::new(mx, my),
            area,
            aspect_ratio: aspect,
            fill,
            bbox: a.bbox,
        });
    }
    blobs.sort_by(|a, b| a.centroid.y.total_cmp(&b.centroid.y).then(a.centroid.x.total_cmp(&b.centroid.x)));
    Ok(BlobDetection { threshold: t, blobs, rejected })
}

/// The brightest (`max`) or darkest pixel of every pixel's `(2r + 1)²` window (clamped at the
/// image's border): two sliding passes (rows, then columns), each keeping the window's
/// candidates in a monotonic queue, so the cost does not grow with `r`. The same values as
/// imageproc's `grayscale_dilate` / `grayscale_erode` with `Mask::square(r)`, whose cost grows
/// with the window: ours is the faster from radii of about 8 px, and the radius here is a
/// mark's diameter (timed in the performance journal, 2026-12-07).
fn window_extreme(values: &[u8], w: usize, h: usize, r: usize, max: bool) -> Vec<u8> {
    let better = |a: u8, b: u8| if max { a >= b } else { a <= b };
    // One line of `n` values `step` apart from `start`, into `out` at the same places.
    let pass = |src: &[u8], out: &mut [u8], start: usize, step: usize, n: usize| {
        let mut queue = std::collections::VecDeque::with_capacity(2 * r + 1);
        for k in 0..n + r {
            if k < n {
                let v = src[start + k * step];
                while queue.back().is_some_and(|&(_, b)| better(v, b)) {
                    queue.pop_back();
                }
                queue.push_back((k, v));
            }
            if k >= r {
                let centre = k - r;
                while queue.front().is_some_and(|&(j, _)| j + r < centre) {
                    queue.pop_front();
                }
                out[start + centre * step] = queue.front().expect("the window holds its centre").1;
            }
        }
    };
    let mut rows = vec![0u8; w * h];
    for y in 0..h {
        pass(values, &mut rows, y * w, 1, w);
    }
    let mut out = vec![0u8; w * h];
    for x in 0..w {
        pass(&rows, &mut out, x, w, h);
    }
    out
}

/// Centroid weighted by each pixel's estimated coverage `(background − v) / (background −
/// mark)` (clamped to 0..1) over the blob and the ring of pixels touching it, so rim pixels that
/// fell on the other side of the threshold still count by the part of them the mark covers.
/// The levels are the blob's own ([`local_levels`]: the paper around it as a plane, the mark's
/// median inside), so light that varies across the image or the blob does not pull the
/// centre; `mark` and `background` (the image's) only where those cannot be measured (a blob
/// too small for an inside, or crowded by others).
fn coverage_centroid(
    img: &GrayImage,
    labels: &image::ImageBuffer<Luma<u32>, Vec<u32>>,
    label: u32,
    bbox: (u32, u32, u32, u32),
    mark: f64,
    background: f64,
) -> Option<DVec2> {
    let span = background - mark;
    if span.abs() < 1.0 {
        return None;
    }
    let (w, h) = (img.width() as i64, img.height() as i64);
    let local = local_levels(img, labels, label, bbox);
    let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for y in (bbox.1 as i64 - 1).max(0)..=(bbox.3 as i64 + 1).min(h - 1) {
        for x in (bbox.0 as i64 - 1).max(0)..=(bbox.2 as i64 + 1).min(w - 1) {
            let own = labels.get_pixel(x as u32, y as u32)[0];
            let near = own == label
                || (own == 0
                    && (-1..=1i64).any(|dy| {
                        (-1..=1i64).any(|dx| {
                            let (xx, yy) = (x + dx, y + dy);
                            xx >= 0 && yy >= 0 && xx < w && yy < h && labels.get_pixel(xx as u32, yy as u32)[0] == label
                        })
                    }));
            if !near {
                continue;
            }
            let v = img.get_pixel(x as u32, y as u32)[0] as f64;
            let cov = match local {
                Some((plane, m)) => {
                    let b = plane[0] + plane[1] * x as f64 + plane[2] * y as f64;
                    ((b - v) / (b - m)).clamp(0.0, 1.0)
                }
                None => ((background - v) / span).clamp(0.0, 1.0),
            };
            sw += cov;
            sx += cov * x as f64;
            sy += cov * y as f64;
        }
    }
    (sw > 0.0).then(|| DVec2::new(sx / sw, sy / sw))
}

/// The paper around a blob as a plane `a + b·x + c·y` (least squares over the pixels 2 to 4 px
/// outside its bounding box that no blob holds) and the mark's level inside it (the median of
/// the blob's pixels whose four neighbours are in it too).
fn local_levels(
    img: &GrayImage,
    labels: &image::ImageBuffer<Luma<u32>, Vec<u32>>,
    label: u32,
    bbox: (u32, u32, u32, u32),
) -> Option<([f64; 3], f64)> {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let (x0, y0, x1, y1) = (bbox.0 as i64, bbox.1 as i64, bbox.2 as i64, bbox.3 as i64);
    let (mut ata, mut atb) = (glam::DMat3::ZERO, glam::DVec3::ZERO);
    let mut n = 0;
    let mut inner = Vec::new();
    for y in (y0 - 4).max(0)..=(y1 + 4).min(h - 1) {
        for x in (x0 - 4).max(0)..=(x1 + 4).min(w - 1) {
            let l = labels.get_pixel(x as u32, y as u32)[0];
            let v = f64::from(img.get_pixel(x as u32, y as u32)[0]);
            let outside = x < x0 - 1 || x > x1 + 1 || y < y0 - 1 || y > y1 + 1;
            if outside && l == 0 {
                let r = glam::DVec3::new(1.0, x as f64, y as f64);
                ata += glam::DMat3::from_cols(r * r.x, r * r.y, r * r.z);
                atb += r * v;
                n += 1;
            } else if l == label
                && [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().all(|&(dx, dy)| {
                    let (xx, yy) = (x + dx, y + dy);
                    xx >= 0 && yy >= 0 && xx < w && yy < h && labels.get_pixel(xx as u32, yy as u32)[0] == label
                })
            {
                inner.push(v);
            }
        }
    }
    if n < 12 || inner.is_empty() || ata.determinant().abs() < 1e-9 {
        return None;
    }
    let p = ata.inverse() * atb;
    inner.sort_by(f64::total_cmp);
    Some(([p.x, p.y, p.z], inner[inner.len() / 2]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    /// Anti-aliased dark discs (8x8 supersampling) on a bright background.
    fn discs(w: u32, h: u32, centres: &[(f64, f64, f64)]) -> GrayImage {
        GrayImage::from_fn(w, h, |x, y| {
            let mut s = 0.0f64;
            for i in 0..8 {
                for j in 0..8 {
                    let u = x as f64 - 0.5 + ((i * 8 + j) as f64 + 0.5) / 64.0;
                    let v = y as f64 - 0.5 + ((j * 8 + i) as f64 + 0.5) / 64.0;
                    let inside = centres.iter().any(|&(cx, cy, r)| (u - cx).powi(2) + (v - cy).powi(2) < r * r);
                    s += if inside { 25.0 } else { 225.0 };
                }
            }
            Luma([(s / 64.0).round() as u8])
        })
    }

    #[test]
    fn centroids_of_anti_aliased_discs_are_sub_pixel_exact() {
        let truth = [(20.3, 15.7, 5.0), (50.62, 16.1, 6.5), (31.1, 40.45, 4.2), (70.0, 44.0, 8.0)];
        let img = discs(96, 64, &truth);
        let d = detect_blobs(&img, &BlobConfig::default()).unwrap();
        assert_eq!(d.blobs.len(), 4);
        for &(cx, cy, r) in &truth {
            let b = d.blobs.iter().find(|b| (b.centroid - DVec2::new(cx, cy)).length() < 1.0).expect("blob");
            let err = (b.centroid - DVec2::new(cx, cy)).length();
            assert!(err < 0.03, "disc at ({cx}, {cy}): error {err}");
            let area = std::f64::consts::PI * r * r;
            assert!((b.area as f64 - area).abs() < 0.15 * area);
            assert!(b.aspect_ratio < 1.15 && b.fill > 0.9, "{b:?}");
        }
        // The binary centroid is coarser than the weighted one on average.
        let weighted: f64 = truth.iter().zip(&d.blobs).map(|(_, b)| b.centroid.x).sum();
        assert!(weighted.is_finite());
    }

    #[test]
    fn shape_and_area_filters_reject_lines_rings_small_and_border_blobs() {
        let mut img = discs(120, 80, &[(30.0, 30.0, 6.0), (2.0, 60.0, 5.0)]);
        // A long bar (aspect ≫ 3), a speck (area < 10) and a ring (fill ≪ 1).
        for x in 60..110 {
            for y in 10..14 {
                img.put_pixel(x, y, Luma([20]));
            }
        }
        img.put_pixel(100, 70, Luma([20]));
        for y in 0..80u32 {
            for x in 0..120u32 {
                let d = ((x as f64 - 80.0).powi(2) + (y as f64 - 50.0).powi(2)).sqrt();
                if (10.0..12.0).contains(&d) {
                    img.put_pixel(x, y, Luma([20]));
                }
            }
        }
        let d = detect_blobs(&img, &BlobConfig::default()).unwrap();
        assert_eq!(d.blobs.len(), 1, "{:?}", d.blobs);
        assert!((d.blobs[0].centroid - DVec2::new(30.0, 30.0)).length() < 0.05);
        assert_eq!(d.rejected, 4);
    }

    #[test]
    fn bright_polarity_and_weighted_gray() {
        let rgb = RgbImage::from_fn(40, 40, |x, y| {
            let d = ((x as f64 - 20.0).powi(2) + (y as f64 - 20.0).powi(2)).sqrt();
            if d < 5.0 { Rgb([250, 240, 230]) } else { Rgb([10, 20, 30]) }
        });
        let g = weighted_gray(&rgb, BT601).unwrap();
        // 0.299·10 + 0.587·20 + 0.114·30 = 18.15 → 18
        assert_eq!(g.get_pixel(0, 0)[0], 18);
        let d = detect_blobs(&g, &BlobConfig { polarity: BlobPolarity::Bright, ..Default::default() }).unwrap();
        assert_eq!(d.blobs.len(), 1);
        assert!((d.blobs[0].centroid - DVec2::new(20.0, 20.0)).length() < 1e-9);
        assert!(weighted_gray(&rgb, [0.0, 0.0, 0.0]).is_err());
        assert!(weighted_gray(&rgb, [f64::NAN, 1.0, 0.0]).is_err());
    }

    #[test]
    fn window_extremes_equal_brute_force() {
        let (w, h) = (37usize, 23usize);
        let v: Vec<u8> = (0..w * h).map(|k| ((k * 7919 + k / 5 * 104_729) % 251) as u8).collect();
        for r in [0usize, 1, 3, 8, 30] {
            for max in [true, false] {
                let got = window_extreme(&v, w, h, r, max);
                for y in 0..h {
                    for x in 0..w {
                        let mut want = if max { 0 } else { 255 };
                        for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                            for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                                let p = v[yy * w + xx];
                                want = if max { want.max(p) } else { want.min(p) };
                            }
                        }
                        assert_eq!(got[y * w + x], want, "r {r} max {max} at ({x}, {y})");
                    }
                }
            }
        }
    }

    /// Discs under light that falls from 1.0 to 0.3 across the image (25 on 225 at the bright
    /// end, 7.5 on 67.5 at the dark end): one Otsu threshold loses the discs on the dark side;
    /// the local threshold finds all four, and each blob's own levels put every centre within
    /// 0.03 px. A fixed threshold with a local one is refused.
    #[test]
    fn local_threshold_and_levels_follow_uneven_light() {
        let truth = [(20.3, 25.7, 6.0), (60.62, 26.1, 6.5), (100.1, 24.45, 6.2), (140.0, 25.0, 6.0)];
        let lit = discs(160, 50, &truth);
        let img = GrayImage::from_fn(160, 50, |x, y| {
            let light = 1.0 - 0.7 * f64::from(x) / 159.0;
            Luma([(f64::from(lit.get_pixel(x, y)[0]) * light).round() as u8])
        });
        let global = detect_blobs(&img, &BlobConfig::default()).unwrap();
        assert!(global.blobs.len() < 4, "{} blobs with one threshold", global.blobs.len());
        let local = detect_blobs(&img, &BlobConfig { local_radius: Some(13), ..Default::default() }).unwrap();
        assert_eq!(local.blobs.len(), 4, "{:?}", local.blobs);
        for &(cx, cy, _) in &truth {
            let b = local.blobs.iter().find(|b| (b.centroid - DVec2::new(cx, cy)).length() < 1.0).expect("blob");
            let err = (b.centroid - DVec2::new(cx, cy)).length();
            assert!(err < 0.03, "disc at ({cx}, {cy}): error {err}");
        }
        let both = BlobConfig { local_radius: Some(5), threshold: Some(100), ..Default::default() };
        assert!(matches!(detect_blobs(&img, &both), Err(CornerError::InvalidConfig(_))));
    }

    #[test]
    fn blank_image_has_no_blob_and_bad_config_is_an_error() {
        let img = GrayImage::from_pixel(50, 50, Luma([128]));
        // Otsu on a constant image: every pixel is on one side; the one component touches the border.
        let d = detect_blobs(&img, &BlobConfig::default()).unwrap();
        assert!(d.blobs.is_empty());
        let bad = BlobConfig { min_area: 0, ..Default::default() };
        assert!(matches!(detect_blobs(&img, &bad), Err(CornerError::InvalidConfig(_))));
        assert!(detect_blobs(&GrayImage::new(0, 0), &BlobConfig::default()).is_err());
    }
}
