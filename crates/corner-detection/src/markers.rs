//! Square fiducial markers (ArUco / AprilTag families of OpenCV's predefined dictionaries):
//! adaptive threshold, connected dark regions, quadrilateral fit on each region's convex hull,
//! bit sampling through the quad's homography, and decoding with error correction up to the
//! dictionary's `maxCorrectionBits` (in all four rotations).

use glam::{DMat3, DVec2, DVec3};
use image::GrayImage;
use parallax_camera_model::MarkerDictionary;
use serde::{Deserialize, Serialize};

use crate::{CornerError, Result};

/// A decoded marker.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DetectedMarker {
    /// Marker id in the dictionary.
    pub id: u32,
    /// Image corners in the marker's own order (top-left, top-right, bottom-right,
    /// bottom-left of the printed marker, OpenCV's order); outline of the black border from
    /// the thresholded region (about ±0.5 px).
    pub corners: [DVec2; 4],
    /// Bits corrected to match the dictionary code.
    pub corrected_bits: u32,
}

/// Configuration of [`detect_markers`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MarkerConfig {
    /// Side lengths of the adaptive-threshold windows, pixels (odd); every window is tried and
    /// the markers merged. Default `[9, 25]` (OpenCV tries 3, 13, 23).
    pub threshold_windows: Vec<u32>,
    /// A pixel is dark when below its window mean minus this, grey levels (OpenCV's
    /// `adaptiveThreshConstant`, 7).
    pub threshold_offset: f64,
    /// Smallest marker side accepted, pixels.
    pub min_side: f64,
    /// Smallest dark/bright difference between the border and the brightest bit, grey levels.
    pub min_contrast: f64,
    /// Largest fraction of border bits allowed to read white (OpenCV's
    /// `maxErroneousBitsInBorderRate` is 0.35; stricter by default).
    pub max_border_error_rate: f64,
    /// Width of the black border in bits (OpenCV's markers 1, Kalibr's AprilGrid tags 2).
    pub border_bits: usize,
}

impl Default for MarkerConfig {
    fn default() -> Self {
        Self {
            threshold_windows: vec![9, 25],
            threshold_offset: 7.0,
            min_side: 8.0,
            min_contrast: 20.0,
            max_border_error_rate: 0.15,
            border_bits: 1,
        }
    }
}

impl MarkerConfig {
    fn validate(&self) -> Result<()> {
        if self.threshold_windows.is_empty() || self.threshold_windows.iter().any(|&w| w < 3 || w % 2 == 0) {
            return Err(CornerError::InvalidConfig(format!(
                "MarkerConfig::threshold_windows must be odd sizes >= 3, got {:?}",
                self.threshold_windows
            )));
        }
        for (v, name) in [(self.min_side, "min_side"), (self.min_contrast, "min_contrast")] {
            if !(v.is_finite() && v > 0.0) {
                return Err(CornerError::InvalidConfig(format!("MarkerConfig::{name} must be positive, got {v}")));
            }
        }
        if self.border_bits == 0 || self.border_bits > 3 {
            return Err(CornerError::InvalidConfig(format!(
                "MarkerConfig::border_bits must be 1..=3, got {}",
                self.border_bits
            )));
        }
        if !(self.threshold_offset.is_finite() && (0.0..=1.0).contains(&self.max_border_error_rate)) {
            return Err(CornerError::InvalidConfig(
                "MarkerConfig: threshold_offset must be finite and max_border_error_rate in [0, 1]".into(),
            ));
        }
        Ok(())
    }
}

/// Finds and decodes the markers of `dictionary` in `img`. A marker id seen twice at
/// different places is dropped (ambiguous); the same marker found with several threshold
/// windows is reported once.
///
/// ```
/// use parallax_camera_model::MarkerDictionary;
/// use parallax_corner_detection::{MarkerConfig, detect_markers};
/// let dict = MarkerDictionary::predefined("DICT_4X4_50")?;
/// // Marker 7 drawn with 12 px cells (6x6 cells with its border) at (40, 30), white around it.
/// let img = image::GrayImage::from_fn(150, 130, |x, y| {
///     let (cx, cy) = ((x as i32 - 40).div_euclid(12), (y as i32 - 30).div_euclid(12));
///     let inside = (0..6).contains(&cx) && (0..6).contains(&cy);
///     let border = cx == 0 || cy == 0 || cx == 5 || cy == 5;
///     let white = !inside || (!border && dict.bit(7, cy as usize - 1, cx as usize - 1));
///     image::Luma([if white { 220 } else { 30 }])
/// });
/// let found = detect_markers(&img, &dict, &MarkerConfig::default())?;
/// assert_eq!(found.len(), 1);
/// assert_eq!(found[0].id, 7);
/// assert!((found[0].corners[0] - glam::DVec2::new(39.5, 29.5)).length() < 1.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn detect_markers(
    img: &GrayImage,
    dictionary: &MarkerDictionary,
    cfg: &MarkerConfig,
) -> Result<Vec<DetectedMarker>> {
    cfg.validate()?;
    crate::imageops::check_size(img, 16, "detect_markers")?;
    let integral = integral_image(img);
    let mut all: Vec<DetectedMarker> = Vec::new();
    let mut labels = Vec::new();
    for &win in &cfg.threshold_windows {
        let dark = threshold(img, &integral, win as usize, cfg.threshold_offset);
        for quad in quads(&dark, img.width() as usize, img.height() as usize, cfg.min_side, &mut labels) {
            if let Some(m) = decode(img, &quad, dictionary, cfg) {
                all.push(m);
            }
        }
    }
    // Merge: the same id at the same place once; the same id at two places is dropped.
    all.sort_by_key(|m| m.id);
    let mut out: Vec<DetectedMarker> = Vec::new();
    let mut i = 0;
    while i < all.len() {
        let mut j = i + 1;
        while j < all.len() && all[j].id == all[i].id {
            j += 1;
        }
        let group = &all[i..j];
        let c0 = centre(&group[0].corners);
        let side = (group[0].corners[1] - group[0].corners[0]).length();
        if group.iter().all(|m| (centre(&m.corners) - c0).length() < 0.25 * side) {
            // The outline from the smallest window follows the edges most closely.
            out.push(group[0]);
        }
        i = j;
    }
    Ok(out)
}

fn centre(q: &[DVec2; 4]) -> DVec2 {
    (q[0] + q[1] + q[2] + q[3]) * 0.25
}

/// Summed-area table with one row and column of zeros in front.
fn integral_image(img: &GrayImage) -> Vec<u64> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut s = vec![0u64; (w + 1) * (h + 1)];
    let raw = img.as_raw();
    for y in 0..h {
        let mut row = 0u64;
        for x in 0..w {
            row += raw[y * w + x] as u64;
            s[(y + 1) * (w + 1) + x + 1] = s[y * (w + 1) + x + 1] + row;
        }
    }
    s
}

/// Dark mask: pixel below the mean of its `win x win` window (clamped to the image) minus
/// `offset`.
fn threshold(img: &GrayImage, s: &[u64], win: usize, offset: f64) -> Vec<bool> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let r = win / 2;
    let raw = img.as_raw();
    let mut out = vec![false; w * h];
    for y in 0..h {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
            let sum = s[y1 * (w + 1) + x1] + s[y0 * (w + 1) + x0] - s[y0 * (w + 1) + x1] - s[y1 * (w + 1) + x0];
            let n = ((y1 - y0) * (x1 - x0)) as f64;
            out[y * w + x] = (raw[y * w + x] as f64) < sum as f64 / n - offset;
        }
    }
    out
}

/// Quadrilaterals fitted to the 4-connected dark regions: the convex hull of each region's
/// pixel squares, reduced to the four hull vertices spanning the largest area; kept when the
/// quad covers at least 90 % of the hull, its sides are at least `min_side` and it does not
/// touch the image border. Corners ordered clockwise on screen (`u` right, `v` down).
fn quads(dark: &[bool], w: usize, h: usize, min_side: f64, labels: &mut Vec<u32>) -> Vec<[DVec2; 4]> {
    // Two-pass labelling with union-find.
    labels.clear();
    labels.resize(w * h, 0);
    let mut parent: Vec<u32> = vec![0];
    fn find(p: &mut [u32], mut a: u32) -> u32 {
        while p[a as usize] != a {
            p[a as usize] = p[p[a as usize] as usize];
            a = p[a as usize];
        }
        a
    }
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !dark[i] {
                continue;
            }
            let left = if x > 0 { labels[i - 1] } else { 0 };
            let up = if y > 0 { labels[i - w] } else { 0 };
            labels[i] = match (left, up) {
                (0, 0) => {
                    let l = parent.len() as u32;
                    parent.push(l);
                    l
                }
                (l, 0) | (0, l) => l,
                (a, b) => {
                    let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                    if ra != rb {
                        parent[ra.max(rb) as usize] = ra.min(rb);
                    }
                    ra.min(rb)
                }
            };
        }
    }
    let n = parent.len();
    for l in 0..n as u32 {
        parent[l as usize] = find(&mut parent, l);
    }
    // Per region: bounding box and per-row extremes.
    let mut bbox = vec![(usize::MAX, usize::MAX, 0usize, 0usize); n];
    for y in 0..h {
        for x in 0..w {
            let l = labels[y * w + x];
            if l != 0 {
                let r = parent[l as usize] as usize;
                labels[y * w + x] = r as u32;
                let b = &mut bbox[r];
                b.0 = b.0.min(x);
                b.1 = b.1.min(y);
                b.2 = b.2.max(x);
                b.3 = b.3.max(y);
            }
        }
    }
    let mut out = Vec::new();
    for (r, &(x0, y0, x1, y1)) in bbox.iter().enumerate() {
        if x0 == usize::MAX || r == 0 {
            continue;
        }
        let (bw, bh) = ((x1 - x0 + 1) as f64, (y1 - y0 + 1) as f64);
        if bw < min_side || bh < min_side || x0 == 0 || y0 == 0 || x1 + 1 >= w || y1 + 1 >= h {
            continue;
        }
        let mut pts = Vec::with_capacity(4 * (y1 - y0 + 1));
        for y in y0..=y1 {
            let row = &labels[y * w + x0..=y * w + x1];
            let (Some(a), Some(b)) =
                (row.iter().position(|&l| l as usize == r), row.iter().rposition(|&l| l as usize == r))
            else {
                continue;
            };
            let (xa, xb, yy) = ((x0 + a) as f64, (x0 + b) as f64, y as f64);
            pts.extend([
                DVec2::new(xa - 0.5, yy - 0.5),
                DVec2::new(xa - 0.5, yy + 0.5),
                DVec2::new(xb + 0.5, yy - 0.5),
                DVec2::new(xb + 0.5, yy + 0.5),
            ]);
        }
        let hull = convex_hull(pts);
        if let Some(q) = best_quad(&hull, min_side) {
            out.push(q);
        }
    }
    out
}

/// Andrew's monotone chain; counter-clockwise in a y-up frame (clockwise on screen).
fn convex_hull(mut p: Vec<DVec2>) -> Vec<DVec2> {
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(p.len() * 2);
    for &q in &p {
        while hull.len() >= 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
            hull.pop();
        }
        hull.push(q);
    }
    let lower = hull.len() + 1;
    for &q in p.iter().rev().skip(1) {
        while hull.len() >= lower && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
            hull.pop();
        }
        hull.push(q);
    }
    hull.pop();
    hull
}

fn poly_area(p: &[DVec2]) -> f64 {
    0.5 * (0..p.len()).map(|k| p[k].perp_dot(p[(k + 1) % p.len()])).sum::<f64>()
}

/// The four hull vertices spanning the largest quadrilateral (coordinate ascent from the
/// diameter), when it covers at least 90 % of the hull and every side is at least `min_side`.
fn best_quad(hull: &[DVec2], min_side: f64) -> Option<[DVec2; 4]> {
    let n = hull.len();
    if n < 4 {
        return None;
    }
    let hull_area = poly_area(hull);
    if hull_area <= 0.0 {
        return None;
    }
    // Start: the farthest pair, then the farthest point from that chord on each side.
    let (mut a, mut c) = (0, 0);
    let mut best = 0.0;
    for i in 0..n {
        for j in i + 1..n {
            let d = (hull[i] - hull[j]).length_squared();
            if d > best {
                best = d;
                (a, c) = (i, j);
            }
        }
    }
    let dist = |k: usize, i: usize, j: usize| (hull[j] - hull[i]).perp_dot(hull[k] - hull[i]);
    let b = (a + 1..c).max_by(|&x, &y| dist(x, a, c).abs().total_cmp(&dist(y, a, c).abs()))?;
    let d = (c + 1..n + a).map(|k| k % n).max_by(|&x, &y| dist(x, a, c).abs().total_cmp(&dist(y, a, c).abs()))?;
    let mut idx = [a, b, c, d];
    let area = |q: &[usize; 4]| poly_area(&[hull[q[0]], hull[q[1]], hull[q[2]], hull[q[3]]]);
    for _ in 0..4 {
        let mut changed = false;
        for s in 0..4 {
            let (prev, next) = (idx[(s + 3) % 4], idx[(s + 1) % 4]);
            let mut k = (prev + 1) % n;
            while k != next {
                let mut trial = idx;
                trial[s] = k;
                if area(&trial) > area(&idx) + 1e-9 {
                    idx = trial;
                    changed = true;
                }
                k = (k + 1) % n;
            }
        }
        if !changed {
            break;
        }
    }
    // Blur and thresholding round a small marker's corners, so the hull vertices cut them:
    // fit a line to the hull edges along each side (those within 25° of the side's chord) and
    // intersect neighbouring sides.
    let mut lines = [(DVec2::ZERO, DVec2::ZERO); 4];
    for s in 0..4 {
        let (i0, i1) = (idx[s], idx[(s + 1) % 4]);
        let chord = (hull[i1] - hull[i0]).normalize_or_zero();
        let (mut sw, mut centroid) = (0.0, DVec2::ZERO);
        let mut edges = Vec::new();
        let mut k = i0;
        while k != i1 {
            let (a, b) = (hull[k], hull[(k + 1) % n]);
            let e = b - a;
            let len = e.length();
            if len > 0.0 && (e / len).perp_dot(chord).abs() < 0.42 {
                sw += len;
                centroid += (a + b) * 0.5 * len;
                edges.push((a, b, len));
            }
            k = (k + 1) % n;
        }
        if sw == 0.0 {
            lines[s] = (hull[i0], chord);
            continue;
        }
        centroid /= sw;
        // Direction: principal axis of the selected edges (each as its two endpoints).
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for &(a, b, len) in &edges {
            for p in [a, b] {
                let d = p - centroid;
                sxx += len * d.x * d.x;
                sxy += len * d.x * d.y;
                syy += len * d.y * d.y;
            }
        }
        let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let mut dir = DVec2::new(angle.cos(), angle.sin());
        if dir.dot(chord) < 0.0 {
            dir = -dir;
        }
        lines[s] = (centroid, dir);
    }
    let mut q = [DVec2::ZERO; 4];
    for s in 0..4 {
        let (p1, d1) = lines[(s + 3) % 4];
        let (p2, d2) = lines[s];
        let den = d1.perp_dot(d2);
        if den.abs() < 1e-6 {
            return None;
        }
        let t = (p2 - p1).perp_dot(d2) / den;
        q[s] = p1 + d1 * t;
        let side = (hull[idx[(s + 1) % 4]] - hull[idx[s]]).length();
        if (q[s] - hull[idx[s]]).length() > 0.25 * side {
            return None;
        }
    }
    let quad_area = poly_area(&q);
    if quad_area.is_nan() || quad_area <= 0.0 || hull_area < 0.9 * quad_area || hull_area > 1.05 * quad_area {
        return None;
    }
    if (0..4).any(|k| {
        (q[(k + 1) % 4] - q[k]).length() < min_side
            || (q[(k + 1) % 4] - q[k]).perp_dot(q[(k + 2) % 4] - q[(k + 1) % 4]) <= 0.0
    }) {
        return None;
    }
    Some(q)
}

/// Homography taking the unit square's corners (0,0), (1,0), (1,1), (0,1) to `q`.
pub(crate) fn square_to_quad(q: &[DVec2; 4]) -> Option<DMat3> {
    homography_4(&[DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)], q)
}

/// Exact homography from four point pairs (8x8 linear system, `h33 = 1`).
pub(crate) fn homography_4(src: &[DVec2; 4], dst: &[DVec2; 4]) -> Option<DMat3> {
    let mut a = [[0.0f64; 9]; 8];
    for k in 0..4 {
        let (x, y, u, v) = (src[k].x, src[k].y, dst[k].x, dst[k].y);
        a[2 * k] = [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, u];
        a[2 * k + 1] = [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, v];
    }
    // Gaussian elimination with partial pivoting.
    for col in 0..8 {
        let piv = (col..8).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, piv);
        for r in 0..8 {
            if r != col {
                let f = a[r][col] / a[col][col];
                for c in col..9 {
                    a[r][c] -= f * a[col][c];
                }
            }
        }
    }
    let h: Vec<f64> = (0..8).map(|i| a[i][8] / a[i][i]).collect();
    let m = DMat3::from_cols(DVec3::new(h[0], h[3], h[6]), DVec3::new(h[1], h[4], h[7]), DVec3::new(h[2], h[5], 1.0));
    m.is_finite().then_some(m)
}

pub(crate) fn apply(h: &DMat3, p: DVec2) -> DVec2 {
    let r = *h * p.extend(1.0);
    DVec2::new(r.x / r.z, r.y / r.z)
}

fn sample_u8(img: &GrayImage, p: DVec2) -> f64 {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let x = p.x.clamp(0.0, (w - 1) as f64);
    let y = p.y.clamp(0.0, (h - 1) as f64);
    let (x0, y0) = ((x as i64).min(w - 2), (y as i64).min(h - 2));
    let (fx, fy) = (x - x0 as f64, y - y0 as f64);
    let g = |xx: i64, yy: i64| img.as_raw()[(yy * w + xx) as usize] as f64;
    let top = g(x0, y0) * (1.0 - fx) + g(x0 + 1, y0) * fx;
    let bot = g(x0, y0 + 1) * (1.0 - fx) + g(x0 + 1, y0 + 1) * fx;
    top * (1.0 - fy) + bot * fy
}

/// Reads the `(n + 2·border)²` cells of the quad, checks the black border and decodes the data bits
/// in the four rotations against the dictionary.
fn decode(img: &GrayImage, q: &[DVec2; 4], dict: &MarkerDictionary, cfg: &MarkerConfig) -> Option<DetectedMarker> {
    let n = dict.marker_size();
    let bb = cfg.border_bits;
    let cells = n + 2 * bb;
    let hm = square_to_quad(q)?;
    // Mean of 3x3 samples in the central half of each cell.
    let mut v = vec![0.0f64; cells * cells];
    for r in 0..cells {
        for c in 0..cells {
            let mut s = 0.0;
            for i in 0..3 {
                for j in 0..3 {
                    let u = (c as f64 + 0.25 + 0.25 * i as f64) / cells as f64;
                    let w = (r as f64 + 0.25 + 0.25 * j as f64) / cells as f64;
                    s += sample_u8(img, apply(&hm, DVec2::new(u, w)));
                }
            }
            v[r * cells + c] = s / 9.0;
        }
    }
    let in_border = |r: usize, c: usize| r < bb || c < bb || r >= n + bb || c >= n + bb;
    let border: Vec<f64> = (0..cells * cells).filter(|&k| in_border(k / cells, k % cells)).map(|k| v[k]).collect();
    let mut sorted = border.clone();
    sorted.sort_by(f64::total_cmp);
    let black = sorted[sorted.len() / 2];
    // White reference: just outside the quad (the paper around a marker), 0.5 cell out.
    let mut outside = Vec::with_capacity(4 * cells);
    for k in 0..cells {
        let t = (k as f64 + 0.5) / cells as f64;
        let e = 0.5 / cells as f64;
        for p in [DVec2::new(t, -e), DVec2::new(1.0 + e, t), DVec2::new(t, 1.0 + e), DVec2::new(-e, t)] {
            outside.push(sample_u8(img, apply(&hm, p)));
        }
    }
    outside.sort_by(f64::total_cmp);
    let white = outside[outside.len() / 2];
    if white - black < cfg.min_contrast {
        return None;
    }
    let t = 0.5 * (white + black);
    let border_errors = border.iter().filter(|&&b| b > t).count();
    if border_errors as f64 > cfg.max_border_error_rate * border.len() as f64 {
        return None;
    }
    // Data bits; bit (r, c) of rotation k.
    let bit = |r: usize, c: usize| v[(r + bb) * cells + c + bb] > t;
    let mut best: Option<(u32, u32, usize)> = None; // (distance, id, rotation)
    for rot in 0..4 {
        let mut code = 0u64;
        for r in 0..n {
            for c in 0..n {
                // The marker's cell (r, c) in quad cells when quad corner `rot` is the marker's
                // top-left corner: rotate (r, c) `rot` times by (r, c) -> (c, n-1-r).
                let (mut rr, mut cc) = (r, c);
                for _ in 0..rot {
                    (rr, cc) = (cc, n - 1 - rr);
                }
                code = (code << 1) | bit(rr, cc) as u64;
            }
        }
        for id in 0..dict.len() as u32 {
            let d = (dict.code(id).expect("id below len") ^ code).count_ones();
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, id, rot));
            }
        }
    }
    let (d, id, rot) = best?;
    if d > dict.max_correction_bits() {
        return None;
    }
    let corners = [q[rot % 4], q[(rot + 1) % 4], q[(rot + 2) % 4], q[(rot + 3) % 4]];
    Some(DetectedMarker { id, corners, corrected_bits: d })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Marker `id` drawn with `cell` px cells at `(x0, y0)`, rotated by `rot` quarter turns
    /// (clockwise on screen) inside a white image.
    fn draw(dict: &MarkerDictionary, id: u32, cell: i32, x0: i32, y0: i32, rot: usize) -> GrayImage {
        let n = dict.marker_size() as i32 + 2;
        GrayImage::from_fn(200, 200, |x, y| {
            let (mut cx, mut cy) = ((x as i32 - x0).div_euclid(cell), (y as i32 - y0).div_euclid(cell));
            if !((0..n).contains(&cx) && (0..n).contains(&cy)) {
                return image::Luma([215]);
            }
            // Undo the screen rotation to find the marker cell shown at (cx, cy).
            for _ in 0..rot {
                (cx, cy) = (cy, n - 1 - cx);
            }
            let border = cx == 0 || cy == 0 || cx == n - 1 || cy == n - 1;
            let white = !border && dict.bit(id, cy as usize - 1, cx as usize - 1);
            image::Luma([if white { 215 } else { 35 }])
        })
    }

    #[test]
    fn markers_decode_in_every_rotation_with_corner_zero_at_the_marker_top_left() {
        for name in ["DICT_4X4_50", "DICT_6X6_250", "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_36h11"] {
            let dict = MarkerDictionary::predefined(name).unwrap();
            let n = dict.marker_size() as i32 + 2;
            for rot in 0..4 {
                let id = 3 + rot as u32 * 5;
                let img = draw(&dict, id, 12, 30, 40, rot);
                let found = detect_markers(&img, &dict, &MarkerConfig::default()).unwrap();
                assert_eq!(found.len(), 1, "{name} rotation {rot}");
                assert_eq!(found[0].id, id, "{name} rotation {rot}");
                // The marker's top-left corner lands on the screen corner given by the rotation.
                let s = (n * 12) as f64;
                let screen = [
                    DVec2::new(29.5, 39.5),
                    DVec2::new(29.5 + s, 39.5),
                    DVec2::new(29.5 + s, 39.5 + s),
                    DVec2::new(29.5, 39.5 + s),
                ];
                let expect = screen[rot];
                assert!((found[0].corners[0] - expect).length() < 1.0, "{name} rotation {rot}: {:?}", found[0].corners);
            }
        }
    }

    #[test]
    fn bit_errors_are_corrected_up_to_the_dictionary_limit_only() {
        let dict = MarkerDictionary::predefined("DICT_5X5_50").unwrap(); // maxCorrectionBits 3
        let mut img = draw(&dict, 11, 14, 20, 20, 0);
        let flip = |img: &mut GrayImage, r: u32, c: u32| {
            for y in 0..14 {
                for x in 0..14 {
                    let p = img.get_pixel_mut(20 + 14 * (c + 1) + x, 20 + 14 * (r + 1) + y);
                    p[0] = 250 - p[0];
                }
            }
        };
        flip(&mut img, 0, 0);
        flip(&mut img, 2, 3);
        let found = detect_markers(&img, &dict, &MarkerConfig::default()).unwrap();
        assert_eq!((found.len(), found[0].id, found[0].corrected_bits), (1, 11, 2));
        // Beyond the limit (4 wrong bits) the marker is not reported as itself.
        let mut bad = img.clone();
        for (r, c) in [(4, 4), (1, 2)] {
            flip(&mut bad, r, c);
        }
        let found = detect_markers(&bad, &dict, &MarkerConfig::default()).unwrap();
        assert!(found.iter().all(|m| m.id != 11), "{found:?}");
    }

    #[test]
    fn exact_homography_maps_the_four_points() {
        let src = [DVec2::new(0.0, 0.0), DVec2::new(3.0, 0.2), DVec2::new(2.7, 2.5), DVec2::new(-0.3, 2.0)];
        let dst = [DVec2::new(10.0, 11.0), DVec2::new(40.0, 9.0), DVec2::new(45.0, 50.0), DVec2::new(8.0, 41.0)];
        let h = homography_4(&src, &dst).unwrap();
        for k in 0..4 {
            assert!((apply(&h, src[k]) - dst[k]).length() < 1e-9);
        }
    }
}
