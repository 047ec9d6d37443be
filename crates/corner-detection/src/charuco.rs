//! ChArUco boards (OpenCV's `CharucoBoard`): markers decoded with [`crate::detect_markers`],
//! checked against their neighbours on the board, chessboard corners predicted through the
//! local homographies of the adjacent markers, refined with the saddle fit and verified by
//! the colours of their four squares. Any subset of the board may be visible; corner ids are
//! OpenCV's.

use glam::{DMat3, DVec2};
use image::GrayImage;
use parallax_camera_model::{CharucoBoard, TargetObservation};
use serde::{Deserialize, Serialize};

use crate::imageops::{BlurScratch, ImageF32, gaussian_blur_into};
use crate::markers::{DetectedMarker, MarkerConfig, apply, detect_markers, homography_4};
use crate::subpix::saddle_one;
use crate::{Refinement, Result};

/// Configuration of [`detect_charuco`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CharucoConfig {
    /// Marker detection settings.
    pub markers: MarkerConfig,
    /// Gaussian smoothing before the saddle fit, pixels.
    pub smoothing_sigma: f64,
    /// Largest half-window of the saddle fit, pixels (the window is also kept inside the white
    /// gap between the corner and the markers).
    pub max_half_window: u32,
    /// Smallest dark/bright difference between the corner's black and white squares, grey
    /// levels.
    pub min_contrast: f64,
    /// Require every marker used to agree with at least one detected neighbour marker (its
    /// homography predicts the neighbour's centre within a quarter marker side). Default true:
    /// a single mis-decoded marker can then not produce corners with wrong ids.
    pub require_neighbour: bool,
}

impl Default for CharucoConfig {
    fn default() -> Self {
        Self {
            markers: MarkerConfig::default(),
            smoothing_sigma: 1.0,
            max_half_window: 8,
            min_contrast: 20.0,
            require_neighbour: true,
        }
    }
}

/// ChArUco corners found in one image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CharucoDetection {
    /// Corner ids (OpenCV's numbering, ascending) and their refined image positions.
    pub observation: TargetObservation,
    /// The board's markers that were decoded and confirmed.
    pub markers: Vec<DetectedMarker>,
    /// Per corner (same order): the saddle refinement's report.
    pub refinement: Vec<Refinement>,
    /// Ids of decoded markers of this board that sit, as their confirmed neighbours place them,
    /// on or next to the board in a square where the board as described has another marker or
    /// none. Not empty: the description does not match the print (most often the legacy layout
    /// of boards made before OpenCV 4.6, whose markers sit one square over; or the square
    /// counts), and no corner is reported — a shifted board would give every corner a wrong id.
    pub misplaced: Vec<u32>,
}

/// Finds the ChArUco corners of `board` in `img`: any visible subset, ids in OpenCV's
/// numbering, positions refined with the saddle fit. Returns an empty observation when no
/// corner is found (an image without the board is not an error).
///
/// Each corner needs at least one adjacent marker decoded (and, with `require_neighbour`,
/// confirmed by a neighbouring marker), a converged saddle fit whose window stays inside the
/// image and the white gap around the corner, and the right colours on its four squares
/// (both black squares darker than both white ones by `min_contrast`). A corner of a square
/// that an object partly covers fails the colour test and is left out.
pub fn detect_charuco(img: &GrayImage, board: &CharucoBoard, cfg: &CharucoConfig) -> Result<CharucoDetection> {
    if !(cfg.smoothing_sigma.is_finite()
        && cfg.smoothing_sigma >= 0.0
        && cfg.min_contrast > 0.0
        && cfg.max_half_window >= 2)
    {
        return Err(crate::CornerError::InvalidConfig(
            "CharucoConfig needs smoothing_sigma >= 0, min_contrast > 0 and max_half_window >= 2".into(),
        ));
    }
    let dict = board.dictionary();
    let found = detect_markers(img, &dict, &cfg.markers)?;
    let on_board: Vec<DetectedMarker> = found.into_iter().filter(|m| (m.id as usize) < board.marker_count()).collect();
    // Board (in squares) → image homography of each marker from its four corners.
    let sq = board.square_length();
    let homs: Vec<Option<DMat3>> = on_board
        .iter()
        .map(|m| {
            let c = board.marker_corners(m.id).expect("id on the board");
            let src = c.map(|p| DVec2::new(p.x / sq, p.y / sq));
            homography_4(&src, &m.corners)
        })
        .collect();
    let centre = |m: &DetectedMarker| (m.corners[0] + m.corners[1] + m.corners[2] + m.corners[3]) * 0.25;
    let board_centre = |id: u32| {
        let (x, y) = board.marker_square(id).expect("id on the board");
        DVec2::new(x as f64 + 0.5, y as f64 + 0.5)
    };
    let mut confirmed = vec![!cfg.require_neighbour; on_board.len()];
    for i in 0..on_board.len() {
        let Some(h) = homs[i] else {
            confirmed[i] = false;
            continue;
        };
        if confirmed[i] {
            continue;
        }
        let side = (on_board[i].corners[1] - on_board[i].corners[0]).length();
        for j in 0..on_board.len() {
            if i == j || (board_centre(on_board[i].id) - board_centre(on_board[j].id)).length() > 2.9 {
                continue;
            }
            let pred = apply(&h, board_centre(on_board[j].id));
            let side_j = (on_board[j].corners[1] - on_board[j].corners[0]).length();
            if (pred - centre(&on_board[j])).length() < 0.25 * side.min(side_j) {
                confirmed[i] = true;
                break;
            }
        }
    }
    let mut by_id = vec![None; board.marker_count()];
    let mut markers = Vec::new();
    for (k, m) in on_board.iter().enumerate() {
        if confirmed[k] {
            by_id[m.id as usize] = homs[k];
            markers.push(*m);
        }
    }
    // The layout check: each decoded marker mapped into the board by the nearest confirmed other
    // marker (a local homography: lens distortion does not matter over a few squares) must land in
    // its own square. Described with the other layout (legacy vs current, an even row count),
    // most markers still confirm each other one square over, but not all of them.
    let mut misplaced = Vec::new();
    for (k, m) in on_board.iter().enumerate() {
        let c = centre(m);
        let side = (m.corners[1] - m.corners[0]).length();
        let nearest = (0..on_board.len())
            .filter(|&j| j != k && confirmed[j] && homs[j].is_some() && on_board[j].id != m.id)
            .map(|j| ((centre(&on_board[j]) - c).length(), j))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let Some((d, j)) = nearest else { continue };
        let Some(inv) = homs[j].map(|h| h.inverse()) else { continue };
        if d > 4.0 * side {
            continue;
        }
        let q = apply(&inv, c);
        let (sx, sy) = (q.x.floor(), q.y.floor());
        let (nx, ny) = (board.squares_x() as f64, board.squares_y() as f64);
        if !(sx >= -1.0 && sy >= -1.0 && sx <= nx && sy <= ny) {
            continue;
        }
        let own = board.marker_square(m.id).map(|(x, y)| (x as f64, y as f64));
        if own != Some((sx, sy)) {
            misplaced.push(m.id);
        }
    }
    if !misplaced.is_empty() {
        misplaced.sort_unstable();
        misplaced.dedup();
        let observation = TargetObservation::new(Vec::new(), Vec::new()).expect("empty");
        return Ok(CharucoDetection { observation, markers, refinement: Vec::new(), misplaced });
    }
    let mut ids = Vec::new();
    let mut points = Vec::new();
    let mut refinement = Vec::new();
    let gap = 0.5 * (sq - board.marker_length()) / sq; // white gap, squares
    let mut scratch = (Vec::new(), Vec::new(), BlurScratch::default());
    let n = board.squares_x() - 1;
    for id in 0..board.corner_count() as u32 {
        let around: Vec<DMat3> = board.markers_around_corner(id).iter().filter_map(|&m| by_id[m as usize]).collect();
        if around.is_empty() {
            continue;
        }
        let b = DVec2::new((id as usize % n + 1) as f64, (id as usize / n + 1) as f64);
        let pred = around.iter().map(|h| apply(h, b)).fold(DVec2::ZERO, |a, p| a + p) / around.len() as f64;
        let h = around[0];
        // Local scale: image distance of the gap along the board axes and diagonals.
        let gap_px = [DVec2::new(1.0, 1.0), DVec2::new(1.0, -1.0), DVec2::new(-1.0, 1.0), DVec2::new(-1.0, -1.0)]
            .iter()
            .map(|d| (apply(&h, b + *d * gap) - apply(&h, b)).length())
            .fold(f64::MAX, f64::min);
        let half = ((0.6 * gap_px).floor() as u32).min(cfg.max_half_window);
        if half < 2 {
            continue;
        }
        let Some((p, r)) = refine(img, pred, half, cfg.smoothing_sigma, &mut scratch) else {
            continue;
        };
        if !r.converged || r.shift > 0.5 * gap_px.max(2.0) {
            continue;
        }
        // Colours: the white squares 0.7 gap from the corner along the diagonals (inside the
        // white gap before the markers), the black squares there and at their centres. Both
        // colours must be uniform (an occluder or a shadow over part of the corner changes one
        // of the samples) and differ by `min_contrast`.
        let (xi, yi) = (id as usize % n, id as usize / n);
        let at = |dx: f64, dy: f64, r: f64| sample_u8(img, apply(&h, b + DVec2::new(dx, dy) * r) - apply(&h, b) + p);
        let (mut blacks, mut whites) = (Vec::with_capacity(4), Vec::with_capacity(2));
        for (dx, dy, sx, sy) in
            [(-1.0, -1.0, xi, yi), (1.0, -1.0, xi + 1, yi), (-1.0, 1.0, xi, yi + 1), (1.0, 1.0, xi + 1, yi + 1)]
        {
            if board.square_is_black(sx, sy) {
                blacks.push(at(dx, dy, 0.7 * gap));
                blacks.push(at(dx, dy, 0.5));
            } else {
                whites.push(at(dx, dy, 0.7 * gap));
            }
        }
        let span = |v: &[f64]| v.iter().fold(f64::MIN, |m, &x| m.max(x)) - v.iter().fold(f64::MAX, |m, &x| m.min(x));
        let contrast = whites.iter().fold(f64::MAX, |m, &x| m.min(x)) - blacks.iter().fold(f64::MIN, |m, &x| m.max(x));
        if contrast.is_nan()
            || contrast < cfg.min_contrast
            || span(&blacks) > 0.25 * contrast
            || span(&whites) > 0.25 * contrast
        {
            continue;
        }
        ids.push(id);
        points.push(p);
        refinement.push(r);
    }
    let observation = TargetObservation::new(ids, points).expect("ascending unique ids, finite points");
    Ok(CharucoDetection { observation, markers, refinement, misplaced })
}

pub(crate) fn sample_u8(img: &GrayImage, p: DVec2) -> f64 {
    let (w, h) = (img.width() as f64, img.height() as f64);
    if !(p.x >= 0.0 && p.y >= 0.0 && p.x <= w - 1.0 && p.y <= h - 1.0) {
        return f64::NAN;
    }
    let (x0, y0) = ((p.x as u32).min(img.width() - 2), (p.y as u32).min(img.height() - 2));
    let (fx, fy) = (p.x - x0 as f64, p.y - y0 as f64);
    let g = |x: u32, y: u32| img.get_pixel(x, y)[0] as f64;
    let top = g(x0, y0) * (1.0 - fx) + g(x0 + 1, y0) * fx;
    let bot = g(x0, y0 + 1) * (1.0 - fx) + g(x0 + 1, y0 + 1) * fx;
    top * (1.0 - fy) + bot * fy
}

/// Saddle fit on a smoothed patch around `p`; `None` when the patch (fit window, its moves and
/// the smoothing support) does not fit inside the image.
pub(crate) fn refine(
    img: &GrayImage,
    p: DVec2,
    half: u32,
    sigma: f64,
    scratch: &mut (Vec<f32>, Vec<f32>, BlurScratch),
) -> Option<(DVec2, Refinement)> {
    let margin = (2 * half + 2) as i64 + (3.0 * sigma).ceil() as i64;
    let (cx, cy) = (p.x.round() as i64, p.y.round() as i64);
    let (w, h) = (img.width() as i64, img.height() as i64);
    if !p.is_finite() || cx - margin < 0 || cy - margin < 0 || cx + margin >= w || cy + margin >= h {
        return None;
    }
    let side = (2 * margin + 1) as usize;
    let (patch, smoothed, blur) = scratch;
    patch.clear();
    for y in cy - margin..=cy + margin {
        let row = (y * w) as usize;
        patch.extend(
            img.as_raw()[row + (cx - margin) as usize..=row + (cx + margin) as usize].iter().map(|&v| v as f32),
        );
    }
    gaussian_blur_into(patch, side, side, sigma, blur, smoothed);
    let s = ImageF32::from_raw(side as u32, side as u32, std::mem::take(smoothed)).expect("patch buffer");
    let origin = DVec2::new((cx - margin) as f64, (cy - margin) as f64);
    let mut local = p - origin;
    let r = saddle_one(&s, &mut local, half, 20, 0.001);
    *smoothed = s.into_raw();
    Some((local + origin, r))
}
