//! Chessboard detection: X-junction candidates from the saddle response of the smoothed image,
//! verified by the alternating dark/bright sectors on a ring around each candidate, linked into
//! a grid by growing a 3x3 seed along the junctions' edge directions (quadratic extrapolation,
//! so barrel/pincushion distortion and strong perspective are followed), verified (exact size,
//! alternating square colours, convex cells), put in OpenCV's order and refined to sub-pixel.
//!
//! Scale: the search runs on a 2x2-averaged pyramid, coarsest level first
//! ([`ChessboardConfig::pyramid_side`]), so `detection_sigma` and `ring_radius` are in pixels of a
//! level of 500–1000 px and boards in 320x240 to 4000x3000 images are found with the defaults;
//! the board is then refined at full resolution on patches around its corners.
//!
//! The detector rejects rather than guesses: a grid that does not have exactly the requested
//! size (in either orientation), whose square colours do not alternate, or whose cells fold is
//! "not found".

use glam::DVec2;
use image::{GrayImage, Rgb, RgbImage};
use parallax_camera_model::CornerGrid;
use serde::{Deserialize, Serialize};

use crate::harris::row_maxima;
use crate::imageops::{
    BlurScratch, ImageF32, gaussian_blur, gaussian_blur_into, halve_f32, halve_u8, saddle_response_into,
    sample_bilinear, to_f32,
};
use crate::subpix::{Refinement, SaddleConfig, SubPixConfig, WindowSize, saddle_one, subpix_one};
use crate::{CornerError, Result};

/// Which sub-pixel method [`find_chessboard`] applies to the grid it found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum CornerRefinement {
    /// Gradient orthogonality ([`crate::refine_corners_subpix`], as OpenCV's `cornerSubPix`),
    /// window from the local corner spacing.
    SubPix,
    /// Saddle-point fit ([`crate::refine_saddle`]), window from the local corner spacing. The
    /// default: on synthetic views (blur 0.8 px, noise 2) its RMS error is about half that of
    /// `SubPix` (0.015 vs 0.03 px), and a calibration of OpenCV's left sample images with it
    /// reaches 0.168 px RMS (0.187 with `SubPix`, 0.198 for OpenCV with a 5x5 window).
    #[default]
    Saddle,
    /// No refinement: the candidates' positions (about ±0.5 px).
    None,
}

/// Configuration of [`find_chessboard`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ChessboardConfig {
    /// Gaussian smoothing before the saddle (Hessian) response, pixels.
    pub detection_sigma: f64,
    /// Radius of the ring on which a candidate's four alternating sectors are checked, pixels.
    /// Must be below half the smallest corner spacing of the boards to be found.
    pub ring_radius: f64,
    /// Minimum dark/bright difference on the ring, grey levels.
    pub min_contrast: f64,
    /// At most this many saddle peaks are examined, strongest first.
    pub max_candidates: usize,
    /// Largest angle between a predicted and a found grid step, radians (when linking the seed).
    pub max_angle_error: f64,
    /// A grown row or column is accepted only when every predicted corner has a candidate
    /// within this fraction of the local corner spacing.
    pub search_fraction: f64,
    /// Sub-pixel method applied to the found grid.
    pub refinement: CornerRefinement,
    /// Settings of the gradient-orthogonality refinement (window from the spacing by default).
    pub subpix: SubPixConfig,
    /// Settings of the saddle-point refinement.
    pub saddle: SaddleConfig,
    /// Scale-free search: the detector starts on the coarsest 2x2-averaged pyramid level whose
    /// longer side is still at least this many pixels and goes down to full resolution until
    /// the board is found, so `detection_sigma` and `ring_radius` are in pixels of a level
    /// whose size is between this and twice this (for images larger than that). 0 searches
    /// full resolution only. Default 500: a 640x480 image is searched as it is, 1600x1200 at
    /// 800x600 then 1600x1200, 4000x3000 at 500x375, 1000x750, 2000x1500, 4000x3000.
    pub pyramid_side: u32,
    /// At most this many halvings. Default 4.
    pub max_pyramid_levels: u32,
}

impl Default for ChessboardConfig {
    fn default() -> Self {
        Self {
            detection_sigma: 1.5,
            ring_radius: 5.0,
            min_contrast: 20.0,
            max_candidates: 1000,
            max_angle_error: 0.3,
            search_fraction: 0.3,
            refinement: CornerRefinement::Saddle,
            subpix: SubPixConfig::default(),
            saddle: SaddleConfig::default(),
            pyramid_side: 500,
            max_pyramid_levels: 4,
        }
    }
}

impl ChessboardConfig {
    fn validate(&self) -> Result<()> {
        let positive = |v: f64, name: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(CornerError::InvalidConfig(format!("ChessboardConfig::{name} must be positive, got {v}")))
            }
        };
        positive(self.detection_sigma, "detection_sigma")?;
        positive(self.ring_radius, "ring_radius")?;
        positive(self.min_contrast, "min_contrast")?;
        positive(self.max_angle_error, "max_angle_error")?;
        if !(self.search_fraction > 0.0 && self.search_fraction < 0.5) {
            return Err(CornerError::InvalidConfig(format!(
                "ChessboardConfig::search_fraction must be in (0, 0.5), got {}",
                self.search_fraction
            )));
        }
        if self.max_candidates == 0 {
            return Err(CornerError::InvalidConfig("ChessboardConfig::max_candidates must be at least 1".into()));
        }
        Ok(())
    }
}

/// A found board with the quality of its corners.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChessboardDetection {
    /// The corners, row-major in OpenCV's order.
    pub grid: CornerGrid,
    /// Per-corner refinement report (same order as the grid; empty with
    /// [`CornerRefinement::None`]).
    pub refinement: Vec<Refinement>,
    /// Smallest distance between neighbouring corners of the grid, pixels.
    pub min_spacing: f64,
    /// Smallest dark/bright contrast measured at a corner of the grid, grey levels.
    pub min_contrast: f64,
    /// Number of X-junction candidates that passed the ring test in the whole image (at the
    /// pyramid level where the board was found).
    pub candidates: usize,
    /// Pyramid level the board was found on (0 = full resolution; level `L` is the image
    /// halved `L` times).
    pub pyramid_level: u32,
}

/// A verified X-junction candidate.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    p: DVec2,
    /// Directions of the two edge lines through the junction, radians mod π.
    lines: [f64; 2],
}

/// Finds a chessboard with `cols x rows` inner corners (OpenCV's `patternSize`: `cols` per
/// row) and returns its corners in OpenCV's order, or `Ok(None)` when no such board is seen.
///
/// Ordering (identical to `cv::findChessboardCorners`, checked against OpenCV 5 on real
/// images under all four 90° rotations): row-major, `corners[row·cols + col]`; the grid is
/// right-handed in the image (`x` along a row, `y` down the columns, `x × y` pointing into the
/// image as seen with `u` right and `v` down); and when `cols + rows` is odd (as 9x6) the
/// first corner is the one whose diagonal square towards the board's interior is **black**, so
/// the order follows the board itself and is the same in every view, under any rotation
/// (left and right images of a stereo pair agree). When `cols + rows` is even the colours
/// cannot tell the two (or four) orientations apart; the one whose `x` axis points most
/// along `+u` and `y` along `+v` is taken.
///
/// Never returns a partial, oversized or wrongly ordered grid: see the module docs.
///
/// ```
/// use parallax_corner_detection::{find_chessboard, ChessboardConfig};
/// // A 5x4-square chessboard (4x3 inner corners) of 20 px squares, drawn with a white margin.
/// let img = image::GrayImage::from_fn(160, 140, |x, y| {
///     let (u, v) = (x as i32 - 30, y as i32 - 30);
///     let inside = (0..100).contains(&u) && (0..80).contains(&v);
///     image::Luma([if inside && (u / 20 + v / 20) % 2 == 0 { 30 } else { 220 }])
/// });
/// let grid = find_chessboard(&img, 4, 3, &ChessboardConfig::default())?.expect("board found");
/// assert_eq!(grid.corners.len(), 12);
/// // First corner: the top-left inner corner (its diagonal square is black), pixel (49.5, 49.5).
/// assert!((grid.corners[0] - glam::DVec2::new(49.5, 49.5)).length() < 0.05);
/// // The wrong size is "not found", never a partial grid.
/// assert!(find_chessboard(&img, 5, 3, &ChessboardConfig::default())?.is_none());
/// # Ok::<(), parallax_corner_detection::CornerError>(())
/// ```
pub fn find_chessboard(
    img: &GrayImage,
    cols: usize,
    rows: usize,
    cfg: &ChessboardConfig,
) -> Result<Option<CornerGrid>> {
    Ok(detect_chessboard(img, cols, rows, cfg)?.map(|d| d.grid))
}

/// As [`find_chessboard`], with the quality of the result (refinement reports, spacing,
/// contrast, candidate count, pyramid level). Uses a per-thread [`ChessboardDetector`], so
/// repeated calls on one thread reuse its buffers.
pub fn detect_chessboard(
    img: &GrayImage,
    cols: usize,
    rows: usize,
    cfg: &ChessboardConfig,
) -> Result<Option<ChessboardDetection>> {
    thread_local! {
        static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
    }
    cfg.validate()?;
    SCRATCH.with(|s| {
        let mut det = ChessboardDetector { cfg: *cfg, scratch: std::mem::take(&mut *s.borrow_mut()), largest: None };
        let out = det.detect(img, cols, rows);
        *s.borrow_mut() = det.scratch;
        out
    })
}

/// A chessboard detector that keeps its buffers (pyramid levels, smoothed image, response,
/// peak lists, refinement patches) from one image to the next: after the first image of a
/// size, detection allocates only its small per-board vectors, so a session of many images
/// does not pay the page faults of fresh megabyte buffers per image.
///
/// ```
/// use parallax_corner_detection::{ChessboardConfig, ChessboardDetector};
/// let img = image::GrayImage::from_fn(160, 140, |x, y| {
///     let (u, v) = (x as i32 - 30, y as i32 - 30);
///     let inside = (0..100).contains(&u) && (0..80).contains(&v);
///     image::Luma([if inside && (u / 20 + v / 20) % 2 == 0 { 30 } else { 220 }])
/// });
/// let mut detector = ChessboardDetector::new(ChessboardConfig::default())?;
/// for _ in 0..3 {
///     let found = detector.detect(&img, 4, 3)?.expect("found");
///     assert_eq!((found.grid.cols, found.grid.rows, found.pyramid_level), (4, 3, 0));
/// }
/// # Ok::<(), parallax_corner_detection::CornerError>(())
/// ```
#[derive(Debug, Clone)]
pub struct ChessboardDetector {
    cfg: ChessboardConfig,
    scratch: Scratch,
    /// The largest grid of linked X-junctions of the last `detect`, (columns, rows).
    largest: Option<(usize, usize)>,
}

/// Buffers reused across images.
#[derive(Debug, Clone, Default)]
struct Scratch {
    /// Pyramid levels 0.. as `f32` (level 0 only filled when it is searched).
    levels: Vec<Vec<f32>>,
    blur: BlurScratch,
    smoothed: Vec<f32>,
    response: Vec<f32>,
    keep: Vec<bool>,
    marks: Vec<bool>,
    peaks: Vec<(f32, u32, u32)>,
    patch: Vec<f32>,
    patch_smoothed: Vec<f32>,
}

impl ChessboardDetector {
    /// A detector with a checked configuration.
    pub fn new(cfg: ChessboardConfig) -> Result<Self> {
        cfg.validate()?;
        Ok(Self { cfg, scratch: Scratch::default(), largest: None })
    }

    /// The configuration.
    pub fn config(&self) -> &ChessboardConfig {
        &self.cfg
    }

    /// The pyramid levels tried on a `width x height` image, coarsest first (level `L` is the
    /// image halved `L` times by 2x2 averaging): from the coarsest level whose longer side is
    /// still at least [`ChessboardConfig::pyramid_side`] pixels (and at most
    /// [`ChessboardConfig::max_pyramid_levels`]) down to 0, full resolution.
    pub fn levels(&self, width: u32, height: u32) -> Vec<u32> {
        let mut top = 0;
        if self.cfg.pyramid_side > 0 {
            while top < self.cfg.max_pyramid_levels
                && (width.max(height) >> (top + 1)) >= self.cfg.pyramid_side
                && (width.min(height) >> (top + 1)) >= 16
            {
                top += 1;
            }
        }
        (0..=top).rev().collect()
    }

    /// [`find_chessboard`]'s search with this detector's configuration and buffers: the
    /// pyramid levels of [`Self::levels`] are searched coarsest first, so `detection_sigma`
    /// and `ring_radius` (pixels of the level) follow the image size; the board found at
    /// level `L` is refined at full resolution with the refinement window's upper bound scaled
    /// by `2^L`.
    pub fn detect(&mut self, img: &GrayImage, cols: usize, rows: usize) -> Result<Option<ChessboardDetection>> {
        if cols < 2 || rows < 2 {
            return Err(CornerError::InvalidBoardSize { cols, rows });
        }
        crate::imageops::check_size(img, 16, "find_chessboard")?;
        self.largest = None;
        let levels = self.levels(img.width(), img.height());
        let top = levels[0] as usize;
        self.build_pyramid(img, top);
        for level in levels {
            if let Some(d) = self.detect_at(img, cols, rows, level)? {
                return Ok(Some(d));
            }
        }
        Ok(None)
    }

    /// After a [`Self::detect`]: the largest grid of X-junctions it linked on any pyramid level,
    /// `(columns, rows)` (oriented as the board asked for when it fits in it, else the larger
    /// count first), whether or not it became the board: what to report when the board was not found ("a 9x5 grid of a
    /// 9x6 board: a row is cut off or hidden"). `None` when no three-by-three grid was linked.
    pub fn largest_grid(&self) -> Option<(usize, usize)> {
        self.largest
    }

    /// Fills pyramid levels 1..=top (level 0 is converted lazily in `detect_at`).
    fn build_pyramid(&mut self, img: &GrayImage, top: usize) {
        let lv = &mut self.scratch.levels;
        if lv.len() <= top {
            lv.resize_with(top + 1, Vec::new);
        }
        let (mut w, mut h) = (img.width() as usize, img.height() as usize);
        for l in 1..=top {
            let (prev, rest) = lv.split_at_mut(l);
            if l == 1 {
                halve_u8(img.as_raw(), w, h, &mut rest[0]);
            } else {
                halve_f32(&prev[l - 1], w, h, &mut rest[0]);
            }
            w /= 2;
            h /= 2;
        }
    }

    fn detect_at(
        &mut self,
        img: &GrayImage,
        cols: usize,
        rows: usize,
        level: u32,
    ) -> Result<Option<ChessboardDetection>> {
        let cfg = self.cfg;
        let (w, h) = ((img.width() >> level) as usize, (img.height() >> level) as usize);
        let sc = &mut self.scratch;
        if level == 0 {
            let l0 = &mut sc.levels[0];
            l0.clear();
            l0.extend(img.as_raw().iter().map(|&v| v as f32));
        }
        gaussian_blur_into(&sc.levels[level as usize], w, h, cfg.detection_sigma, &mut sc.blur, &mut sc.smoothed);
        let smoothed = ImageF32::from_raw(w as u32, h as u32, std::mem::take(&mut sc.smoothed)).expect("w x h buffer");
        let cands = candidates_into(&smoothed, &cfg, sc);
        let result = self.link_and_refine(img, &smoothed, &cands, cols, rows, level);
        self.scratch.smoothed = smoothed.into_raw();
        Ok(result)
    }

    fn link_and_refine(
        &mut self,
        img: &GrayImage,
        smoothed: &ImageF32,
        cands: &[Candidate],
        cols: usize,
        rows: usize,
        level: u32,
    ) -> Option<ChessboardDetection> {
        let cfg = self.cfg;
        let n_cands = cands.len();
        // Too few candidates for the board: still linked, for `largest_grid`.
        let possible = n_cands >= cols * rows;
        let mut used = vec![false; n_cands];
        let mut seeds_tried = 0;
        let scale = f64::from(1u32 << level);
        let offset = 0.5 * (scale - 1.0);
        for seed in 0..n_cands {
            if used[seed] {
                continue;
            }
            seeds_tried += 1;
            if seeds_tried > 200 {
                break;
            }
            let Some(grid) = grow(cands, seed, &used, cols.max(rows) + 1, &cfg) else {
                continue;
            };
            for row in &grid {
                for &i in row {
                    used[i] = true;
                }
            }
            let (nr, nc) = (grid.len(), grid[0].len());
            // Oriented as the board asked for when it fits in it.
            let shape = if nc <= cols && nr <= rows {
                (nc, nr)
            } else if nr <= cols && nc <= rows {
                (nr, nc)
            } else {
                (nc.max(nr), nc.min(nr))
            };
            if self.largest.is_none_or(|(c, r)| c * r < nr * nc) {
                self.largest = Some(shape);
            }
            if !possible || !((nr == rows && nc == cols) || (nr == cols && nc == rows)) {
                continue;
            }
            let pos: Vec<Vec<DVec2>> = grid.iter().map(|r| r.iter().map(|&i| cands[i].p).collect()).collect();
            let Some(min_contrast) = check_colours(smoothed, &pos, cfg.min_contrast * 0.5) else {
                continue;
            };
            if !cells_convex(&pos) {
                continue;
            }
            let Some(mut corners) = order_opencv(smoothed, &pos, cols, rows) else {
                continue;
            };
            if level > 0 {
                // Sub-pixel at the detection level first (its smoothed image is at hand), so the
                // full-resolution refinement starts within a fraction of a level pixel.
                let halves = WindowSize::FromSpacing { fraction: 0.25, min: 2, max: 5 }.half_sizes(&corners);
                for (c, h) in corners.iter_mut().zip(halves) {
                    saddle_one(smoothed, c, h, 10, 0.01);
                }
                for c in corners.iter_mut() {
                    *c = *c * scale + DVec2::splat(offset);
                }
            }
            let refinement = self.refine_full(img, &mut corners, scale);
            let grid_rows: Vec<Vec<DVec2>> = corners.chunks(cols).map(|r| r.to_vec()).collect();
            if !cells_convex(&grid_rows) {
                continue;
            }
            let min_spacing = min_neighbour_spacing(&grid_rows);
            if refinement.iter().any(|r: &Refinement| r.shift > 0.25 * min_spacing) {
                continue;
            }
            return Some(ChessboardDetection {
                grid: CornerGrid { cols, rows, corners },
                refinement,
                min_spacing,
                min_contrast,
                candidates: n_cands,
                pyramid_level: level,
            });
        }
        None
    }

    /// Sub-pixel refinement at full resolution on small patches around each corner (so no
    /// full-resolution `f32` copy or smoothed image is needed when the board was found on a
    /// coarser level). The window's upper bound is scaled by `scale` = `2^level`.
    fn refine_full(&mut self, img: &GrayImage, corners: &mut [DVec2], scale: f64) -> Vec<Refinement> {
        let cfg = self.cfg;
        let scaled = |w: WindowSize| match w {
            WindowSize::FromSpacing { fraction, min, max } => {
                WindowSize::FromSpacing { fraction, min, max: ((max as f64) * scale).round() as u32 }
            }
            fixed => fixed,
        };
        let sc = &mut self.scratch;
        match cfg.refinement {
            CornerRefinement::None => Vec::new(),
            CornerRefinement::SubPix => {
                let halves = scaled(cfg.subpix.window).half_sizes(corners);
                corners
                    .iter_mut()
                    .zip(halves)
                    .map(|(c, h)| {
                        let margin = 2 * h as usize + 3;
                        let (patch, origin) = Patch::cut(img, *c, margin, &mut sc.patch);
                        let mut local = *c - origin;
                        let r = subpix_one(
                            &patch,
                            &mut local,
                            h,
                            cfg.subpix.dead_zone,
                            cfg.subpix.max_iterations.max(1),
                            cfg.subpix.epsilon,
                        );
                        sc.patch = patch.into_raw();
                        *c = local + origin;
                        r
                    })
                    .collect()
            }
            CornerRefinement::Saddle => {
                let halves = scaled(cfg.saddle.window).half_sizes(corners);
                let sigma = cfg.saddle.smoothing_sigma;
                corners
                    .iter_mut()
                    .zip(halves)
                    .map(|(c, h)| {
                        let margin = 2 * h as usize + 3 + (3.0 * sigma).ceil() as usize;
                        let (patch, origin) = Patch::cut(img, *c, margin, &mut sc.patch);
                        let (pw, ph) = (patch.width() as usize, patch.height() as usize);
                        gaussian_blur_into(patch.as_raw(), pw, ph, sigma, &mut sc.blur, &mut sc.patch_smoothed);
                        sc.patch = patch.into_raw();
                        let s = ImageF32::from_raw(pw as u32, ph as u32, std::mem::take(&mut sc.patch_smoothed))
                            .expect("patch buffer");
                        let mut local = *c - origin;
                        let r = saddle_one(&s, &mut local, h, cfg.saddle.max_iterations.max(1), cfg.saddle.epsilon);
                        sc.patch_smoothed = s.into_raw();
                        *c = local + origin;
                        r
                    })
                    .collect()
            }
        }
    }
}

/// A square cut of an 8-bit image as `f32`, clamped to the image.
struct Patch;

impl Patch {
    /// The pixels within `margin` of `c` (clamped to the image) in `buf`, and the image
    /// position of the patch's pixel (0, 0).
    fn cut(img: &GrayImage, c: DVec2, margin: usize, buf: &mut Vec<f32>) -> (ImageF32, DVec2) {
        let (w, h) = (img.width() as i64, img.height() as i64);
        let m = margin as i64;
        let (cx, cy) = (c.x.round() as i64, c.y.round() as i64);
        let (x0, x1) = ((cx - m).clamp(0, w - 1), (cx + m).clamp(0, w - 1));
        let (y0, y1) = ((cy - m).clamp(0, h - 1), (cy + m).clamp(0, h - 1));
        let (pw, ph) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
        let mut data = std::mem::take(buf);
        data.clear();
        let raw = img.as_raw();
        for y in y0..=y1 {
            let row = (y * w) as usize;
            data.extend(raw[row + x0 as usize..=row + x1 as usize].iter().map(|&v| v as f32));
        }
        (ImageF32::from_raw(pw as u32, ph as u32, data).expect("patch buffer"), DVec2::new(x0 as f64, y0 as f64))
    }
}

/// Saddle peaks that pass the ring test, strongest first (buffers from `sc`).
fn candidates_into(smoothed: &ImageF32, cfg: &ChessboardConfig, sc: &mut Scratch) -> Vec<Candidate> {
    let (w, h) = (smoothed.width() as usize, smoothed.height() as usize);
    saddle_response_into(smoothed.as_raw(), w, h, &mut sc.response);
    // Ideal X-junction of contrast C smoothed by σ: −det H = (C / (π σ²))². Keep peaks of at
    // least half the minimum contrast's response amplitude (a junction whose edges meet at 30°
    // still gives half the response of a square one).
    let s2 = cfg.detection_sigma * cfg.detection_sigma;
    let min_resp = (0.5 * cfg.min_contrast / (std::f64::consts::PI * s2)).powi(2) as f32;
    let border = (cfg.ring_radius + 2.0).ceil() as usize;
    let response = std::mem::take(&mut sc.response);
    collect_peaks(&response, w, h, min_resp, border, cfg.max_candidates, sc);
    let out = sc
        .peaks
        .iter()
        .filter_map(|&(_, x, y)| {
            let p = subpixel_peak(&response, w, x as usize, y as usize);
            ring_test(smoothed, p, cfg.ring_radius, cfg.min_contrast)
        })
        .collect();
    sc.response = response;
    out
}

/// Strongest local maxima of `r` (at least `max(min_abs, 1e-4 · max r)`), none within 2.5 px
/// of a stronger one, at most `max`, into `sc.peaks` as `(response, x, y)`. The same rule as
/// `peaks_above` with buffers reused: suppression marks pixels in a reused mask instead of a
/// bucket grid of vectors.
fn collect_peaks(r: &[f32], w: usize, h: usize, min_abs: f32, border: usize, max: usize, sc: &mut Scratch) {
    sc.peaks.clear();
    let max_r = r.iter().fold(0.0f32, |m, &v| if v > m { v } else { m });
    if max_r <= 0.0 || !max_r.is_finite() {
        return;
    }
    let thr = (1e-4 * max_r).max(min_abs);
    let b = border.max(1);
    if w <= 2 * b || h <= 2 * b {
        return;
    }
    sc.keep.clear();
    sc.keep.resize(w, false);
    for y in b..h - b {
        let rows = (&r[(y - 1) * w..y * w], &r[y * w..(y + 1) * w], &r[(y + 1) * w..(y + 2) * w]);
        row_maxima(rows, thr, &mut sc.keep[b..w - b], b);
        for x in b..w - b {
            if sc.keep[x] {
                sc.peaks.push((r[y * w + x], x as u32, y as u32));
            }
        }
    }
    sc.peaks.sort_by(|a, b| b.0.total_cmp(&a.0));
    // Greedy suppression: distance < 2.5 px means |dx|, |dy| <= 2 and dx² + dy² < 6.25.
    // `sc.marks` is all false between calls (the marks are undone below), so it is cleared
    // only when the image size changes, not with a memset of the whole image per level.
    if sc.marks.len() != w * h {
        sc.marks.clear();
        sc.marks.resize(w * h, false);
    }
    let mark = |marks: &mut [bool], x: usize, y: usize, value: bool| {
        for dy in -2i64..=2 {
            for dx in -2i64..=2 {
                if dx * dx + dy * dy < 7 {
                    let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                    if xx >= 0 && yy >= 0 && (xx as usize) < w && (yy as usize) < h {
                        marks[yy as usize * w + xx as usize] = value;
                    }
                }
            }
        }
    };
    let mut kept = 0;
    for k in 0..sc.peaks.len() {
        let (v, x, y) = sc.peaks[k];
        let (x, y) = (x as usize, y as usize);
        if sc.marks[y * w + x] {
            continue;
        }
        mark(&mut sc.marks, x, y, true);
        sc.peaks[kept] = (v, x as u32, y as u32);
        kept += 1;
        if kept >= max {
            break;
        }
    }
    sc.peaks.truncate(kept);
    for &(_, x, y) in &sc.peaks {
        mark(&mut sc.marks, x as usize, y as usize, false);
    }
}

/// Peak position refined by 1D parabola fits along x and y.
fn subpixel_peak(d: &[f32], w: usize, x: usize, y: usize) -> DVec2 {
    let at = |xx: usize, yy: usize| d[yy * w + xx] as f64;
    let fit = |m: f64, c: f64, p: f64| {
        let den = m - 2.0 * c + p;
        if den < 0.0 { (0.5 * (m - p) / den).clamp(-0.5, 0.5) } else { 0.0 }
    };
    let ox = fit(at(x - 1, y), at(x, y), at(x + 1, y));
    let oy = fit(at(x, y - 1), at(x, y), at(x, y + 1));
    DVec2::new(x as f64 + ox, y as f64 + oy)
}

const RING_SAMPLES: usize = 48;

/// `(sin, cos)` of the ring's sample angles `k · 2π / RING_SAMPLES`.
static RING_UNIT: std::sync::LazyLock<[(f64, f64); RING_SAMPLES]> = std::sync::LazyLock::new(|| {
    std::array::from_fn(|k| (k as f64 * std::f64::consts::TAU / RING_SAMPLES as f64).sin_cos())
});

/// Checks for exactly four alternating sectors on a ring around `p` whose boundaries form two
/// lines through `p`; returns the candidate with its line directions.
fn ring_test(img: &ImageF32, p: DVec2, radius: f64, min_contrast: f64) -> Option<Candidate> {
    let mut v = [0.0f64; RING_SAMPLES];
    let step = std::f64::consts::TAU / RING_SAMPLES as f64;
    for (k, s) in v.iter_mut().enumerate() {
        let (sin, cos) = RING_UNIT[k];
        *s = sample_bilinear(img, p.x + radius * cos, p.y + radius * sin) as f64;
    }
    let (lo, hi) = v.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
    if hi - lo < min_contrast {
        return None;
    }
    let t = 0.5 * (lo + hi);
    let mut trans = Vec::with_capacity(4);
    let mut last = 0;
    let mut runs = Vec::with_capacity(4);
    for k in 0..RING_SAMPLES {
        let (a, b) = (v[k], v[(k + 1) % RING_SAMPLES]);
        if (a > t) != (b > t) {
            if trans.len() == 4 {
                return None;
            }
            trans.push((k as f64 + (t - a) / (b - a)) * step);
            runs.push(k - last);
            last = k;
        }
    }
    if trans.len() != 4 {
        return None;
    }
    // Run lengths between transitions (the first one wraps around).
    runs[0] += RING_SAMPLES - last;
    if runs.iter().any(|&r| r < 2) {
        return None;
    }
    let wrap = |a: f64| (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    let pi = std::f64::consts::PI;
    if wrap(trans[2] - trans[0] - pi).abs() > 0.45 || wrap(trans[3] - trans[1] - pi).abs() > 0.45 {
        return None;
    }
    let line = |a: f64, b: f64| {
        let (s, c) = ((2.0 * a).sin() + (2.0 * b).sin(), (2.0 * a).cos() + (2.0 * b).cos());
        (0.5 * s.atan2(c)).rem_euclid(pi)
    };
    let l1 = line(trans[0], trans[2]);
    let l2 = line(trans[1], trans[3]);
    let diff = (l1 - l2).rem_euclid(pi);
    if diff.min(pi - diff) < 0.25 {
        return None;
    }
    Some(Candidate { p, lines: [l1, l2] })
}

/// Angle between direction `d` (any length) and the nearer line of `c`, radians.
fn line_misfit(c: &Candidate, d: DVec2) -> f64 {
    let pi = std::f64::consts::PI;
    let a = d.y.atan2(d.x).rem_euclid(pi);
    c.lines
        .iter()
        .map(|&l| {
            let e = (a - l).rem_euclid(pi);
            e.min(pi - e)
        })
        .fold(f64::MAX, f64::min)
}

/// Nearest candidate from `from` roughly along `dir` (unit), whose own lines agree.
fn find_along(cands: &[Candidate], used: &[bool], from: usize, dir: DVec2, cfg: &ChessboardConfig) -> Option<usize> {
    let c = cands[from].p;
    let cos_max = cfg.max_angle_error.cos();
    let mut best: Option<(f64, usize)> = None;
    for (i, q) in cands.iter().enumerate() {
        if i == from || used[i] {
            continue;
        }
        let d = q.p - c;
        let len = d.length();
        if len < cfg.ring_radius || d.dot(dir) < cos_max * len {
            continue;
        }
        if line_misfit(q, d) > cfg.max_angle_error {
            continue;
        }
        if best.is_none_or(|(b, _)| len < b) {
            best = Some((len, i));
        }
    }
    best.map(|(_, i)| i)
}

/// Nearest unused candidate within `radius` of `p` that is not already in `taken`.
fn find_near(cands: &[Candidate], used: &[bool], taken: &[usize], p: DVec2, radius: f64) -> Option<usize> {
    let mut best: Option<(f64, usize)> = None;
    for (i, q) in cands.iter().enumerate() {
        if used[i] {
            continue;
        }
        let d = (q.p - p).length_squared();
        if d <= radius * radius && best.is_none_or(|(b, _)| d < b) && !taken.contains(&i) {
            best = Some((d, i));
        }
    }
    best.map(|(_, i)| i)
}

/// Grows a full rectangular grid from a 3x3 seed around candidate `seed`. Returns rows of
/// candidate indices, or `None` when no seed forms. Stops when a side exceeds `max_side`.
fn grow(
    cands: &[Candidate],
    seed: usize,
    used: &[bool],
    max_side: usize,
    cfg: &ChessboardConfig,
) -> Option<Vec<Vec<usize>>> {
    let c = &cands[seed];
    let e1 = DVec2::new(c.lines[0].cos(), c.lines[0].sin());
    let e2 = DVec2::new(c.lines[1].cos(), c.lines[1].sin());
    let right = find_along(cands, used, seed, e1, cfg)?;
    let left = find_along(cands, used, seed, -e1, cfg)?;
    let down = find_along(cands, used, seed, e2, cfg)?;
    let up = find_along(cands, used, seed, -e2, cfg)?;
    let p = |i: usize| cands[i].p;
    let ratio_ok = |a: f64, b: f64| a > 0.5 * b && b > 0.5 * a;
    let (dr, dl, dd, du) =
        ((p(right) - c.p).length(), (p(left) - c.p).length(), (p(down) - c.p).length(), (p(up) - c.p).length());
    if !ratio_ok(dr, dl) || !ratio_ok(dd, du) {
        return None;
    }
    let spacing = dr.min(dl).min(dd).min(du);
    let radius = cfg.search_fraction * spacing;
    let mut taken = vec![seed, right, left, down, up];
    let corner = |a: usize, b: usize, taken: &mut Vec<usize>| -> Option<usize> {
        let i = find_near(cands, used, taken, p(a) + p(b) - c.p, radius)?;
        taken.push(i);
        Some(i)
    };
    let ul = corner(up, left, &mut taken)?;
    let ur = corner(up, right, &mut taken)?;
    let dl_ = corner(down, left, &mut taken)?;
    let dr_ = corner(down, right, &mut taken)?;
    let mut grid = vec![vec![ul, up, ur], vec![left, seed, right], vec![dl_, down, dr_]];
    let mut in_grid = taken;
    loop {
        let mut grew = false;
        for side in 0..4 {
            if grid.len() > max_side || grid[0].len() > max_side {
                return Some(grid);
            }
            if let Some(new) = extend(cands, used, &in_grid, &grid, side, cfg) {
                in_grid.extend(&new);
                match side {
                    0 => grid.insert(0, new),
                    1 => grid.push(new),
                    2 => grid.iter_mut().zip(new).for_each(|(r, i)| r.insert(0, i)),
                    _ => grid.iter_mut().zip(new).for_each(|(r, i)| r.push(i)),
                }
                grew = true;
            }
        }
        if !grew {
            return Some(grid);
        }
    }
}

/// Tries to add a full line of corners on one side (0 top, 1 bottom, 2 left, 3 right).
fn extend(
    cands: &[Candidate],
    used: &[bool],
    in_grid: &[usize],
    grid: &[Vec<usize>],
    side: usize,
    cfg: &ChessboardConfig,
) -> Option<Vec<usize>> {
    let (nr, nc) = (grid.len(), grid[0].len());
    // Line k (along the side) and its inward neighbours at depth 1 and 2.
    let at = |k: usize, depth: usize| -> DVec2 {
        let i = match side {
            0 => grid[depth][k],
            1 => grid[nr - 1 - depth][k],
            2 => grid[k][depth],
            _ => grid[k][nc - 1 - depth],
        };
        cands[i].p
    };
    let (len, depth_avail) = if side < 2 { (nc, nr) } else { (nr, nc) };
    let mut new = Vec::with_capacity(len);
    let mut taken: Vec<usize> = in_grid.to_vec();
    for k in 0..len {
        let p0 = at(k, 0);
        let p1 = at(k, 1);
        let d1 = p0 - p1;
        let pred = if depth_avail >= 3 { p0 + 2.0 * d1 - (p1 - at(k, 2)) } else { p0 + d1 };
        // Local spacing: the step inwards and the steps along the side.
        let mut spacing = d1.length();
        if k > 0 {
            spacing = spacing.min((p0 - at(k - 1, 0)).length());
        }
        if k + 1 < len {
            spacing = spacing.min((p0 - at(k + 1, 0)).length());
        }
        let i = find_near(cands, used, &taken, pred, cfg.search_fraction * spacing)?;
        let d = cands[i].p - p0;
        // The new step must continue the line: similar length, and along one of its edges.
        let l = d.length();
        if l < 0.5 * d1.length() || l > 2.0 * d1.length() || line_misfit(&cands[i], d) > cfg.max_angle_error {
            return None;
        }
        taken.push(i);
        new.push(i);
    }
    Some(new)
}

/// Colour test: at every corner the sum of the two diagonal quadrants along `a + b` minus the
/// two along `a − b` must alternate in sign from corner to corner (the squares alternate)
/// and exceed `min` in magnitude. Returns the smallest half-magnitude (a contrast in grey
/// levels) when it passes.
fn check_colours(img: &ImageF32, pos: &[Vec<DVec2>], min: f64) -> Option<f64> {
    let mut sign0 = 0.0;
    let mut min_seen = f64::MAX;
    for r in 0..pos.len() {
        for c in 0..pos[0].len() {
            let s = quadrant_contrast(img, pos, r, c);
            if s.abs() * 0.5 < min {
                return None;
            }
            let expect = if (r + c) % 2 == 0 { 1.0 } else { -1.0 };
            if sign0 == 0.0 {
                sign0 = s.signum() * expect;
            } else if s.signum() * expect != sign0 {
                return None;
            }
            min_seen = min_seen.min(s.abs() * 0.5);
        }
    }
    Some(min_seen)
}

/// Grid steps at `(r, c)` along the rows (`a`) and down the columns (`b`), taken forwards or,
/// on the last row/column, backwards so that they still point to increasing indices.
fn steps(pos: &[Vec<DVec2>], r: usize, c: usize) -> (DVec2, DVec2) {
    let (nr, nc) = (pos.len(), pos[0].len());
    let a = if c + 1 < nc { pos[r][c + 1] - pos[r][c] } else { pos[r][c] - pos[r][c - 1] };
    let b = if r + 1 < nr { pos[r + 1][c] - pos[r][c] } else { pos[r][c] - pos[r - 1][c] };
    (a, b)
}

/// `I(p ± (a+b)/4) − I(p ± (a−b)/4)`: positive when the squares along the `a + b` diagonal are
/// bright.
fn quadrant_contrast(img: &ImageF32, pos: &[Vec<DVec2>], r: usize, c: usize) -> f64 {
    let (a, b) = steps(pos, r, c);
    let p = pos[r][c];
    let s = |q: DVec2| sample_bilinear(img, q.x, q.y) as f64;
    let d1 = 0.25 * (a + b);
    let d2 = 0.25 * (a - b);
    s(p + d1) + s(p - d1) - s(p + d2) - s(p - d2)
}

/// True when every cell is a convex quadrilateral and all cells have the same orientation.
fn cells_convex(pos: &[Vec<DVec2>]) -> bool {
    let mut sign = 0.0;
    for r in 0..pos.len() - 1 {
        for c in 0..pos[0].len() - 1 {
            let q = [pos[r][c], pos[r][c + 1], pos[r + 1][c + 1], pos[r + 1][c]];
            for k in 0..4 {
                let e1 = q[(k + 1) % 4] - q[k];
                let e2 = q[(k + 2) % 4] - q[(k + 1) % 4];
                let cr = e1.perp_dot(e2);
                if cr == 0.0 || !cr.is_finite() {
                    return false;
                }
                if sign == 0.0 {
                    sign = cr.signum();
                } else if cr.signum() != sign {
                    return false;
                }
            }
        }
    }
    true
}

fn min_neighbour_spacing(pos: &[Vec<DVec2>]) -> f64 {
    let mut m = f64::MAX;
    for r in 0..pos.len() {
        for c in 0..pos[0].len() {
            if c + 1 < pos[0].len() {
                m = m.min((pos[r][c + 1] - pos[r][c]).length());
            }
            if r + 1 < pos.len() {
                m = m.min((pos[r + 1][c] - pos[r][c]).length());
            }
        }
    }
    m
}

/// Puts a verified grid (any of its 8 symmetries) in OpenCV's order; see [`find_chessboard`].
fn order_opencv(img: &ImageF32, pos: &[Vec<DVec2>], cols: usize, rows: usize) -> Option<Vec<DVec2>> {
    let (nr, nc) = (pos.len(), pos[0].len());
    let mut options: Vec<(Vec<Vec<DVec2>>, bool, f64)> = Vec::new();
    for transpose in [false, true] {
        let (tr, tc) = if transpose { (nc, nr) } else { (nr, nc) };
        if (tr, tc) != (rows, cols) {
            continue;
        }
        for flip_r in [false, true] {
            for flip_c in [false, true] {
                let g: Vec<Vec<DVec2>> = (0..tr)
                    .map(|r| {
                        (0..tc)
                            .map(|c| {
                                let r = if flip_r { tr - 1 - r } else { r };
                                let c = if flip_c { tc - 1 - c } else { c };
                                if transpose { pos[c][r] } else { pos[r][c] }
                            })
                            .collect()
                    })
                    .collect();
                let x = g[0][tc - 1] - g[0][0];
                let y = g[tr - 1][0] - g[0][0];
                if x.perp_dot(y) <= 0.0 {
                    continue;
                }
                // Square between corners (0,0) and (1,1): dark when the a+b diagonal is dark.
                let dark = quadrant_contrast(img, &g, 0, 0) < 0.0;
                let score = x.normalize().x + y.normalize().y;
                options.push((g, dark, score));
            }
        }
    }
    if options.is_empty() {
        return None;
    }
    let any_dark = options.iter().any(|o| o.1);
    let any_bright = options.iter().any(|o| !o.1);
    let decisive = (cols + rows) % 2 == 1;
    if decisive && !(any_dark && any_bright) {
        // Colours must tell the two orientations apart on such a board.
        return None;
    }
    options
        .into_iter()
        .filter(|o| !decisive || o.1)
        .max_by(|a, b| a.2.total_cmp(&b.2))
        .map(|(g, _, _)| g.into_iter().flatten().collect())
}

/// Draws a found grid over the image as OpenCV's `drawChessboardCorners` does: each row in its
/// own colour, rows joined in order, a circle on every corner and a larger one on the first.
pub fn draw_chessboard(img: &GrayImage, grid: &CornerGrid) -> RgbImage {
    let mut out = RgbImage::from_fn(img.width(), img.height(), |x, y| {
        let v = img.get_pixel(x, y)[0];
        Rgb([v, v, v])
    });
    const COLOURS: [[u8; 3]; 6] =
        [[255, 0, 0], [255, 128, 0], [200, 200, 0], [0, 200, 0], [0, 160, 255], [160, 0, 255]];
    let mut prev: Option<DVec2> = None;
    for (k, c) in grid.corners.iter().enumerate() {
        let colour = Rgb(COLOURS[(k / grid.cols.max(1)) % COLOURS.len()]);
        if let Some(p) = prev {
            imageproc::drawing::draw_line_segment_mut(
                &mut out,
                (p.x as f32, p.y as f32),
                (c.x as f32, c.y as f32),
                colour,
            );
        }
        let centre = (c.x.round() as i32, c.y.round() as i32);
        imageproc::drawing::draw_hollow_circle_mut(&mut out, centre, if k == 0 { 7 } else { 4 }, colour);
        prev = Some(*c);
    }
    out
}

/// Draws a cross on each of `points` (e.g. the corners of a board that was not found, or
/// [`crate::detect_corners`] output).
pub fn draw_points(img: &GrayImage, points: &[DVec2], colour: [u8; 3]) -> RgbImage {
    let mut out = RgbImage::from_fn(img.width(), img.height(), |x, y| {
        let v = img.get_pixel(x, y)[0];
        Rgb([v, v, v])
    });
    for p in points {
        imageproc::drawing::draw_cross_mut(&mut out, Rgb(colour), p.x.round() as i32, p.y.round() as i32);
    }
    out
}

/// Draws the outline of each quadrilateral of `quads` (e.g. the markers a detector decoded) onto
/// `out`.
pub fn draw_quads_mut(out: &mut RgbImage, quads: &[[DVec2; 4]], colour: [u8; 3]) {
    for q in quads {
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            imageproc::drawing::draw_line_segment_mut(
                out,
                (a.x as f32, a.y as f32),
                (b.x as f32, b.y as f32),
                Rgb(colour),
            );
        }
    }
}

/// X-junction candidates of an image (positions only), as used by [`find_chessboard`]: useful
/// for drawing what the detector saw when no board was found.
pub fn chessboard_candidates(img: &GrayImage, cfg: &ChessboardConfig) -> Result<Vec<DVec2>> {
    cfg.validate()?;
    crate::imageops::check_size(img, 16, "chessboard_candidates")?;
    let smoothed = gaussian_blur(&to_f32(img), cfg.detection_sigma);
    let mut sc = Scratch::default();
    Ok(candidates_into(&smoothed, cfg, &mut sc).into_iter().map(|c| c.p).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;
    use image::Luma;

    /// Renders a chessboard of `cols x rows` inner corners (squares of 1 unit, a one-square
    /// white margin) through the homography `h` (board units → pixels), 64 samples per pixel.
    /// Returns the image and the true inner corners in OpenCV's order (square (0,0) black).
    fn render(w: u32, h: u32, cols: usize, rows: usize, hom: DMat3, bg: u8) -> (GrayImage, Vec<DVec2>) {
        let inv = hom.inverse();
        let img = GrayImage::from_fn(w, h, |x, y| {
            let mut s = 0.0f64;
            // 8x8 n-rooks samples (64 distinct x and y offsets).
            for i in 0..8 {
                for j in 0..8 {
                    let u = x as f64 - 0.5 + ((i * 8 + j) as f64 + 0.5) / 64.0;
                    let v = y as f64 - 0.5 + ((j * 8 + i) as f64 + 0.5) / 64.0;
                    let b = inv * glam::DVec3::new(u, v, 1.0);
                    let (bx, by) = (b.x / b.z, b.y / b.z);
                    // Board squares span [-1, cols] x [-1, rows]; margin one more square.
                    let on_squares = bx >= -1.0 && by >= -1.0 && bx < cols as f64 && by < rows as f64;
                    let on_paper = bx >= -2.0 && by >= -2.0 && bx < cols as f64 + 1.0 && by < rows as f64 + 1.0;
                    s += if on_squares {
                        if ((bx + 1.0).floor() as i64 + (by + 1.0).floor() as i64) % 2 == 0 { 30.0 } else { 220.0 }
                    } else if on_paper {
                        220.0
                    } else {
                        bg as f64
                    };
                }
            }
            Luma([(s / 64.0).round() as u8])
        });
        // Optical blur as every real (and the synthetic crate's) image has.
        let img = imageproc::filter::gaussian_blur_f32(&img, 0.8);
        let corners = (0..rows)
            .flat_map(|r| (0..cols).map(move |c| (c, r)))
            .map(|(c, r)| {
                let p = hom * glam::DVec3::new(c as f64, r as f64, 1.0);
                DVec2::new(p.x / p.z, p.y / p.z)
            })
            .collect();
        (img, corners)
    }

    /// Homography: square size `s` px, rotation `angle`, perspective `px, py`, centred at `c`.
    fn homography(s: f64, angle: f64, px: f64, py: f64, c: DVec2, cols: usize, rows: usize) -> DMat3 {
        let centre = DMat3::from_translation(-DVec2::new((cols - 1) as f64 / 2.0, (rows - 1) as f64 / 2.0));
        let rot = DMat3::from_angle(angle) * DMat3::from_scale(DVec2::splat(s));
        let persp = DMat3::from_cols(glam::DVec3::new(1.0, 0.0, px), glam::DVec3::new(0.0, 1.0, py), glam::DVec3::Z);
        DMat3::from_translation(c) * persp * rot * centre
    }

    fn rms(a: &[DVec2], b: &[DVec2]) -> f64 {
        (a.iter().zip(b).map(|(p, q)| (*p - *q).length_squared()).sum::<f64>() / a.len() as f64).sqrt()
    }

    #[test]
    fn finds_boards_under_rotation_and_perspective_in_opencv_order() {
        let cfg = ChessboardConfig::default();
        for (k, angle) in [0.0f64, 0.4, 1.4, 2.0, 3.3, 4.4, 5.9].iter().enumerate() {
            let px = [0.0, 0.0008, -0.0006, 0.0004][k % 4];
            let py = [0.0, -0.0005, 0.0007, 0.0][k % 4];
            let hom = homography(28.0, *angle, px, py, DVec2::new(320.3, 240.7), 9, 6);
            let (img, truth) = render(640, 480, 9, 6, hom, 128);
            let grid = find_chessboard(&img, 9, 6, &cfg).unwrap().unwrap_or_else(|| panic!("angle {angle}: not found"));
            assert_eq!((grid.cols, grid.rows), (9, 6));
            let e = rms(&grid.corners, &truth);
            assert!(e < 0.05, "angle {angle}: RMS {e} px (ordering or accuracy)");
        }
    }

    #[test]
    fn transposed_request_and_even_boards_are_ordered() {
        let cfg = ChessboardConfig::default();
        // A 9x6 board asked as 6x9 is a different board: OpenCV's order for patternSize (6, 9)
        // runs 6 corners per row. The grid is still found, right-handed and consistent.
        let hom = homography(26.0, 0.2, 0.0, 0.0, DVec2::new(320.0, 240.0), 9, 6);
        let (img, _) = render(640, 480, 9, 6, hom, 128);
        let g = find_chessboard(&img, 6, 9, &cfg).unwrap().expect("found as 6x9");
        let x = g.at(5, 0) - g.at(0, 0);
        let y = g.at(0, 8) - g.at(0, 0);
        assert!(x.perp_dot(y) > 0.0);
        // 8x6 (both even): the colours cannot decide; x points along +u, y along +v.
        for angle in [0.1f64, 3.2] {
            let hom = homography(30.0, angle, 0.0, 0.0, DVec2::new(320.0, 240.0), 8, 6);
            let (img, _) = render(640, 480, 8, 6, hom, 128);
            let g = find_chessboard(&img, 8, 6, &cfg).unwrap().expect("8x6 found");
            assert!((g.at(7, 0) - g.at(0, 0)).x > 0.0 && (g.at(0, 5) - g.at(0, 0)).y > 0.0, "angle {angle}");
        }
    }

    /// A 9x6 board asked for with a row or a column too many is not found, and the detector says
    /// what it linked: the whole 9x6 grid, oriented as the request; asked for a smaller board, the
    /// grid it linked is larger than the board (growth stops one past the requested side).
    #[test]
    fn the_largest_grid_linked_is_reported() {
        let hom = homography(30.0, 0.3, 0.0003, 0.0, DVec2::new(320.0, 240.0), 9, 6);
        let (img, _) = render(640, 480, 9, 6, hom, 90);
        let mut det = ChessboardDetector::new(ChessboardConfig::default()).unwrap();
        for (c, r, want) in [(9, 7, (9, 6)), (10, 6, (9, 6)), (7, 10, (6, 9))] {
            assert!(det.detect(&img, c, r).unwrap().is_none(), "{c}x{r}");
            assert_eq!(det.largest_grid(), Some(want), "asked for {c}x{r}");
        }
        assert!(det.detect(&img, 9, 6).unwrap().is_some());
        let blank = GrayImage::from_pixel(320, 240, Luma([128]));
        assert!(det.detect(&blank, 9, 6).unwrap().is_none());
        assert_eq!(det.largest_grid(), None, "nothing linked on a blank image");
    }

    #[test]
    fn negative_cases_never_return_a_grid() {
        let cfg = ChessboardConfig::default();
        let hom = homography(30.0, 0.3, 0.0003, 0.0, DVec2::new(320.0, 240.0), 9, 6);
        let (img, _) = render(640, 480, 9, 6, hom, 90);
        // Wrong sizes.
        for (c, r) in [(8, 6), (9, 5), (10, 6), (9, 7), (7, 5)] {
            assert!(find_chessboard(&img, c, r, &cfg).unwrap().is_none(), "{c}x{r} reported on a 9x6 board");
        }
        // Half the board cut off by the image border.
        let hom = homography(30.0, 0.0, 0.0, 0.0, DVec2::new(600.0, 240.0), 9, 6);
        let (cut, _) = render(640, 480, 9, 6, hom, 90);
        assert!(find_chessboard(&cut, 9, 6, &cfg).unwrap().is_none());
        // Blank and noise-only images.
        let blank = GrayImage::from_pixel(640, 480, Luma([128]));
        assert!(find_chessboard(&blank, 9, 6, &cfg).unwrap().is_none());
        let mut state = 12345u64;
        let noise = GrayImage::from_fn(320, 240, |_, _| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            Luma([(state >> 56) as u8])
        });
        assert!(find_chessboard(&noise, 9, 6, &cfg).unwrap().is_none());
        // Bad arguments are errors, not "not found".
        assert!(matches!(find_chessboard(&img, 1, 6, &cfg), Err(CornerError::InvalidBoardSize { .. })));
        assert!(find_chessboard(&GrayImage::new(8, 8), 9, 6, &cfg).is_err());
        let bad = ChessboardConfig { search_fraction: 0.9, ..Default::default() };
        assert!(matches!(find_chessboard(&img, 9, 6, &bad), Err(CornerError::InvalidConfig(_))));
    }

    #[test]
    fn refinement_methods_agree_with_truth() {
        let hom = homography(25.0, 0.7, 0.0005, -0.0004, DVec2::new(321.1, 238.4), 9, 6);
        let (img, truth) = render(640, 480, 9, 6, hom, 128);
        for (method, tol) in
            [(CornerRefinement::SubPix, 0.03), (CornerRefinement::Saddle, 0.05), (CornerRefinement::None, 0.8)]
        {
            let cfg = ChessboardConfig { refinement: method, ..Default::default() };
            let d = detect_chessboard(&img, 9, 6, &cfg).unwrap().expect("found");
            let e = rms(&d.grid.corners, &truth);
            assert!(e < tol, "{method:?}: RMS {e}");
            assert!(d.min_spacing > 15.0 && d.min_contrast > 50.0, "{d:?}");
        }
    }

    #[test]
    fn overlay_marks_the_corners() {
        let hom = homography(30.0, 0.0, 0.0, 0.0, DVec2::new(160.0, 120.0), 4, 3);
        let (img, _) = render(320, 240, 4, 3, hom, 128);
        let grid = find_chessboard(&img, 4, 3, &ChessboardConfig::default()).unwrap().unwrap();
        let out = draw_chessboard(&img, &grid);
        let coloured = out.pixels().filter(|p| p[0] != p[1] || p[1] != p[2]).count();
        assert!(coloured > 12 * 20, "only {coloured} coloured pixels");
    }
}
