//! ChArUco boards (OpenCV's `CharucoBoard`): markers decoded with [`crate::detect_markers`],
//! checked against their neighbours on the board, chessboard corners predicted through the
//! local homographies of the adjacent markers, refined with the saddle fit and verified by
//! the colours of their four squares. Any subset of the board may be visible; corner ids are
//! OpenCV's.

use glam::{DMat3, DVec2};
use image::GrayImage;
use parallax_camera_model::{CharucoBoard, TargetObservation};
use serde::{Deserialize, Serialize};

use crate::imageops::{BlurScratch, ImageF32, gaussian_blur_into, sample_bilinear};
use crate::markers::{DetectedMarker, MarkerConfig, apply, detect_markers, homography_4};
use crate::subpix::{line_intersection, saddle_one, tls_line};
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
    /// Per corner (same order): the refinement's report (for a corner located by the edge
    /// lines: half window 0, one iteration, the shift from the prediction).
    pub refinement: Vec<Refinement>,
    /// The width of the dark frame of the black squares, as a fraction of the square's side,
    /// when the print outlines them (a dark frame around a light interior: the corners are
    /// then located from the squares' edges, not as saddles); `None` for solid squares.
    #[serde(default)]
    pub square_frame: Option<f64>,
    /// The board was found in inverted colours (light squares and markers on dark): no marker
    /// decoded as printed, the board's markers in the negative image.
    #[serde(default)]
    pub inverted: bool,
    /// Ids of decoded markers of this board that sit, as their confirmed neighbours place them,
    /// on or next to the board in a square where the board as described has another marker or
    /// none. Not empty: the description does not match the print (most often the legacy layout
    /// of boards made before OpenCV 4.6, whose markers sit one square over; or the square
    /// counts), and no corner is reported — a shifted board would give every corner a wrong id.
    pub misplaced: Vec<u32>,
}

/// Finds the ChArUco corners of `board` in `img`: any visible subset, ids in OpenCV's
/// numbering. Driven by the markers: each corner is predicted from the decoded markers
/// around it, then located in the image — by the saddle fit on a solid print, by the two
/// board lines fitted to the squares' edges on a print whose black squares are outlines
/// (found from the markers' surroundings, reported in [`CharucoDetection::square_frame`]) or
/// where the saddle fit fails. Returns an empty observation when no corner is found (an
/// image without the board is not an error).
///
/// Each corner needs at least one adjacent marker decoded (and, with `require_neighbour`,
/// confirmed by a neighbouring marker), a fit that stays inside the image and the white gap
/// around the corner (the saddle fit converged; the edge lines with at least six edge points
/// on each side of the corner, 0.5 px RMS from them), and the right colours on its four
/// squares (both black squares darker than both white ones by `min_contrast`, each colour
/// uniform up to a linear trend of the light). A corner of a square that an object partly
/// covers fails the colour test and is left out. A board whose markers decode only in the
/// negative image (a print in inverted colours) is found there ([`CharucoDetection::inverted`]).
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
    let found = detect_charuco_in(img, board, cfg)?;
    if !found.markers.is_empty() || !found.misplaced.is_empty() {
        return Ok(found);
    }
    // No marker of the board: perhaps a print in inverted colours (light markers and squares on
    // dark, as OpenCV's `detectInvertedMarker` reads them), which the image turned negative
    // shows as an ordinary board, corners where they were.
    let mut negative = img.clone();
    image::imageops::invert(&mut negative);
    let inverted = detect_charuco_in(&negative, board, cfg)?;
    if inverted.markers.is_empty() && inverted.misplaced.is_empty() {
        return Ok(found);
    }
    Ok(CharucoDetection { inverted: true, ..inverted })
}

/// [`detect_charuco`] on the image as it is.
fn detect_charuco_in(img: &GrayImage, board: &CharucoBoard, cfg: &CharucoConfig) -> Result<CharucoDetection> {
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
        // A marker read only after correcting a bit, that no neighbour confirms, is a misread
        // (blur merging cells): left out, it says nothing about the layout.
        let misread = m.corrected_bits > 0 && !confirmed[k];
        if own != Some((sx, sy)) && !misread {
            misplaced.push(m.id);
        }
    }
    if !misplaced.is_empty() {
        misplaced.sort_unstable();
        misplaced.dedup();
        let observation = TargetObservation::new(Vec::new(), Vec::new()).expect("empty");
        return Ok(CharucoDetection {
            observation,
            markers,
            refinement: Vec::new(),
            square_frame: None,
            inverted: false,
            misplaced,
        });
    }
    let mut ids = Vec::new();
    let mut points = Vec::new();
    let mut refinement = Vec::new();
    let gap = 0.5 * (sq - board.marker_length()) / sq; // white gap, squares
    let frame = outlined_frame(img, board, &by_id);
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
        // A solid print's corner is a saddle; an outlined print's only within its thin
        // frames, whose inner edges make a quadratic a poor model beyond them: there the two
        // board lines are fitted to the outer edges instead. Where the saddle fit fails on a
        // solid print (a blurred or noisy corner), the lines are tried too.
        let saddle = match frame {
            None => refine(img, pred, half, cfg.smoothing_sigma, &mut scratch)
                .filter(|(_, r)| r.converged && r.shift <= 0.5 * gap_px.max(2.0)),
            Some(_) => None,
        };
        let refined = saddle.or_else(|| edge_lines(img, board, &h, b, pred, frame.unwrap_or(0.0), &mut scratch));
        let Some((p, r)) = refined.filter(|(_, r)| r.shift <= 0.5 * gap_px.max(2.0)) else {
            continue;
        };
        // Colours (see `colours_agree`): the white squares 0.35 and 0.7 gap from the corner
        // along the diagonals (inside the white gap before the markers), the black squares at
        // 0.7 gap, 0.3 and 0.5 along the diagonals and at two points off them (near the corner
        // only, on an outlined print).
        let (xi, yi) = (id as usize % n, id as usize / n);
        let offset = |dx: f64, dy: f64, r: f64| apply(&h, b + DVec2::new(dx, dy) * r) - apply(&h, b);
        let mut samples = Vec::with_capacity(14);
        for (dx, dy, sx, sy) in
            [(-1.0, -1.0, xi, yi), (1.0, -1.0, xi + 1, yi), (-1.0, 1.0, xi, yi + 1), (1.0, 1.0, xi + 1, yi + 1)]
        {
            let black = board.square_is_black(sx, sy);
            // (radius along the diagonal, in squares; whether the uniform test reads it)
            let radii: &[(f64, bool)] = match (black, frame) {
                (false, _) => &[(0.7 * gap, true), (0.35 * gap, false)],
                // Only the frame is dark: its corner square, half its width along the diagonal.
                (true, Some(t)) => &[(0.5 * t, true)],
                (true, None) => &[(0.7 * gap, true), (0.5, true), (0.3, false)],
            };
            let mut at = |o: DVec2, uniform: bool| {
                samples.push(Sample { offset: o, black, uniform, value: sample_u8(img, p + o) })
            };
            for &(r, uniform) in radii {
                at(offset(dx, dy, r), uniform);
            }
            if black && frame.is_none() {
                // Off the diagonal too, so that a trend across it shows on both colours.
                at(apply(&h, b + DVec2::new(0.45 * dx, 0.15 * dy)) - apply(&h, b), false);
                at(apply(&h, b + DVec2::new(0.15 * dx, 0.45 * dy)) - apply(&h, b), false);
            }
        }
        if !colours_agree(&samples, cfg.min_contrast) {
            continue;
        }
        ids.push(id);
        points.push(p);
        refinement.push(r);
    }
    let observation = TargetObservation::new(ids, points).expect("ascending unique ids, finite points");
    Ok(CharucoDetection { observation, markers, refinement, square_frame: frame, inverted: false, misplaced })
}

/// One colour sample around a corner: its offset from the corner in the image, pixels, whether
/// it is on a black square, and its grey level (NaN outside the image).
struct Sample {
    offset: DVec2,
    black: bool,
    /// Read by the test without a trend (the others only by the test with one).
    uniform: bool,
    value: f64,
}

/// Whether the samples around a corner show its two colours: both colours uniform (an occluder
/// or a shadow over part of the corner changes some samples) and apart by `min_contrast`.
/// First as they are: every black sample darker than every white one by `min_contrast`, each
/// colour within 25 % of that. Failing that, up to a linear trend of the light across the
/// corner (a highlight, a light fall-off), when there are samples enough (a solid print's
/// fourteen, the black squares' also off the diagonals, so that a trend along either shows on
/// both colours; the two levels and the two slopes leave ten to check): every sample within 10 % of
/// the contrast of the fitted levels and trend, the contrast at least `min_contrast`. Samples
/// outside the image are left out.
fn colours_agree(samples: &[Sample], min_contrast: f64) -> bool {
    let samples: Vec<&Sample> = samples.iter().filter(|s| s.value.is_finite()).collect();
    let lo_hi = |black: bool| {
        samples
            .iter()
            .filter(|s| s.uniform && s.black == black)
            .fold((f64::MAX, f64::MIN), |(lo, hi), s| (lo.min(s.value), hi.max(s.value)))
    };
    let ((b_lo, b_hi), (w_lo, w_hi)) = (lo_hi(true), lo_hi(false));
    let contrast = w_lo - b_hi;
    if b_lo <= b_hi
        && w_lo <= w_hi
        && contrast >= min_contrast
        && b_hi - b_lo <= 0.25 * contrast
        && w_hi - w_lo <= 0.25 * contrast
    {
        return true;
    }
    if samples.len() < 14 {
        return false;
    }
    // Least squares for [black level, white level, slope along u, slope along v].
    let row = |s: &Sample| {
        glam::DVec4::new(f64::from(u8::from(s.black)), f64::from(u8::from(!s.black)), s.offset.x, s.offset.y)
    };
    let (mut ata, mut atb) = (glam::DMat4::ZERO, glam::DVec4::ZERO);
    for s in &samples {
        let r = row(s);
        ata += glam::DMat4::from_cols(r * r.x, r * r.y, r * r.z, r * r.w);
        atb += r * s.value;
    }
    if ata.determinant().abs() < 1e-9 {
        return false;
    }
    let x = ata.inverse() * atb;
    let contrast = x.y - x.x;
    contrast >= min_contrast && samples.iter().all(|s| (s.value - row(s).dot(x)).abs() <= 0.1 * contrast)
}

/// One edge profile of [`edge_lines`].
#[derive(Clone, Copy)]
struct Probe {
    /// Centre, on the predicted board line.
    at: DVec2,
    /// Unit normal, towards the square the line's `across` direction enters.
    normal: DVec2,
    /// Half-length, in profile steps.
    half: i64,
    /// Whether that square is black.
    black_beyond: bool,
    /// On the side of the corner the line runs to (else before it).
    after: bool,
}

/// The corner at board point `b` (in squares) as the intersection of the two board lines
/// through it, each fitted to the edge points between the white squares and the dark frames
/// of the black squares on both sides of the corner (from beyond the frames' own corner to
/// 0.45 square from it). Each edge point is the white-to-dark step across the line on a
/// profile of the lightly smoothed image, sampled along the line's normal (bilinear, 0.25 px
/// apart) within 0.9 of the white gap of the line `h` predicts moved to `pred` (the marker's
/// border beyond the gap steps the other way): the
/// centroid of the derivative's lobe around its extremum. On either side of the corner the
/// frame lies on the other side of the line, so what a blurred thin frame does to its edge
/// cancels in the fit.
fn edge_lines(
    img: &GrayImage,
    board: &CharucoBoard,
    h: &DMat3,
    b: DVec2,
    pred: DVec2,
    frame: f64,
    scratch: &mut (Vec<f32>, Vec<f32>, BlurScratch),
) -> Option<(DVec2, Refinement)> {
    let gap = 0.5 * (board.square_length() - board.marker_length()) / board.square_length();
    const STEP: f64 = 0.25; // profile spacing, pixels
    // Light smoothing against noise: on the rendered outlined set (blur 0.8 px, noise 2) the
    // corner RMS was 0.025–0.050 px with it, 0.027–0.046 px without and 0.030–0.053 px at 0.7 px.
    const SIGMA: f64 = 0.5;
    let map = |q: DVec2| apply(h, q) - apply(h, b) + pred;
    let mut probes: [Vec<Probe>; 2] = [Vec::new(), Vec::new()];
    let start = frame.max(0.05) + 0.02;
    if start > 0.35 {
        return None; // frames this wide leave no edge to fit beyond them
    }
    const STEPS: usize = 24;
    for (probes, axis) in probes.iter_mut().zip([DVec2::Y, DVec2::X]) {
        let across = axis.perp().abs();
        for side in [-1.0, 1.0] {
            for k in 0..=STEPS {
                let s = side * (start + (0.45 - start) * k as f64 / STEPS as f64);
                let on = b + axis * s;
                let q = map(on);
                let mut normal = (map(on + axis * 0.01) - map(on - axis * 0.01)).normalize().perp();
                if (map(on + across * 0.01) - q).dot(normal) < 0.0 {
                    normal = -normal;
                }
                // The square the line enters along `across`: (column, row) in squares.
                let beyond = (on + across * 0.5).floor();
                let black = beyond.min_element() >= 0.0 && board.square_is_black(beyond.x as usize, beyond.y as usize);
                let n = (0.9 * (map(on + across * gap) - q).length() / STEP).floor() as i64;
                if n < 2 {
                    return None;
                }
                probes.push(Probe { at: q, normal, half: n, black_beyond: black, after: side > 0.0 });
            }
        }
    }
    // One smoothed patch covering every profile.
    let (mut lo, mut hi) = (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN));
    for &Probe { at: q, normal, half: n, .. } in probes.iter().flatten() {
        for e in [q + normal * (n as f64 * STEP), q - normal * (n as f64 * STEP)] {
            (lo, hi) = (lo.min(e), hi.max(e));
        }
    }
    let margin = 2.0 + (3.0 * SIGMA).ceil();
    let (x0, y0) = ((lo.x - margin).floor() as i64, (lo.y - margin).floor() as i64);
    let (x1, y1) = ((hi.x + margin).ceil() as i64, (hi.y + margin).ceil() as i64);
    let (w, hgt) = (img.width() as i64, img.height() as i64);
    if !(lo.is_finite() && hi.is_finite()) || x0 < 0 || y0 < 0 || x1 >= w || y1 >= hgt {
        return None;
    }
    let f = smoothed_patch(img, (x0, y0), (x1, y1), SIGMA, scratch);
    let origin = DVec2::new(x0 as f64, y0 as f64);
    let mut lines = Vec::with_capacity(2);
    for probes in &probes {
        let mut pts: Vec<(DVec2, bool)> = Vec::with_capacity(probes.len());
        for &Probe { at: q, normal, half: n, black_beyond: black, after } in probes {
            // The derivative along the normal, signed so that white to dark is negative.
            let at = |i: i64| {
                let p = q + normal * (i as f64 * STEP) - origin;
                f64::from(sample_bilinear(&f, p.x, p.y))
            };
            let sign = if black { 1.0 } else { -1.0 };
            let d: Vec<f64> = (-n + 1..n).map(|i| sign * 0.5 * (at(i + 1) - at(i - 1))).collect();
            let Some((m, &best)) = d.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)) else { continue };
            if best > -2.0 * STEP || m == 0 || m + 1 == d.len() {
                continue;
            }
            // Centroid of the lobe: the run around the extremum below half of it.
            let (mut first, mut last) = (m, m);
            while first > 0 && d[first - 1] < 0.5 * best {
                first -= 1;
            }
            while last + 1 < d.len() && d[last + 1] < 0.5 * best {
                last += 1;
            }
            let (sw, su) = (first..=last).fold((0.0, 0.0), |(sw, su), i| (sw + d[i], su + d[i] * i as f64));
            let u = (su / sw + 1.0 - n as f64) * STEP;
            pts.push((q + normal * u, after));
        }
        let line = fit_line(&pts);
        let Some(line) = line else {
            scratch.1 = f.into_raw();
            return None;
        };
        lines.push(line);
    }
    scratch.1 = f.into_raw();
    let p = line_intersection(lines[0], lines[1], 0.1)?;
    let r = Refinement { half_window: 0, iterations: 1, shift: (p - pred).length(), converged: true };
    Some((p, r))
}

/// A line through edge points (each with the side of the corner it is on), robustly: fitted
/// by total least squares, points further than 3.5 robust σ (and 0.2 px) dropped, fitted
/// again. `None` when fewer than 6 points remain on either side of the corner or the points
/// stray from the line by more than 0.5 px RMS (an occluder, a shadow edge or a fold across
/// it).
fn fit_line(pts: &[(DVec2, bool)]) -> Option<(DVec2, DVec2)> {
    let tls = |pts: &[(DVec2, bool)]| tls_line(pts.iter().map(|p| p.0)).expect("enough points");
    let enough = |pts: &[(DVec2, bool)]| {
        let near = pts.iter().filter(|p| p.1).count();
        near >= 6 && pts.len() - near >= 6
    };
    if !enough(pts) {
        return None;
    }
    let (c, d) = tls(pts);
    let dist = |p: &(DVec2, bool)| (p.0 - c).perp_dot(d).abs();
    let mut r: Vec<f64> = pts.iter().map(dist).collect();
    r.sort_by(f64::total_cmp);
    let cut = (3.5 * 1.4826 * r[r.len() / 2]).max(0.2);
    let kept: Vec<(DVec2, bool)> = pts.iter().filter(|p| dist(p) <= cut).copied().collect();
    if !enough(&kept) {
        return None;
    }
    let (c, d) = tls(&kept);
    let rms = (kept.iter().map(|p| (p.0 - c).perp_dot(d).powi(2)).sum::<f64>() / kept.len() as f64).sqrt();
    (rms <= 0.5).then_some((c, d))
}

/// The width of the dark frame of the board's black squares (a fraction of the square) when
/// they are printed as outlines around a light interior, as the decoded markers show it: `None`
/// for solid squares (or when no black square next to a decoded marker is in the image).
///
/// Along the line from each marker's centre through the black square beside it, the profile
/// inward from that square's edge is sampled; the median profile is compared with the
/// markers' black border and the white gap around them (print and light as the camera sees
/// them): the square is outlined when its centre is nearer the paper than the border.
fn outlined_frame(img: &GrayImage, board: &CharucoBoard, by_id: &[Option<DMat3>]) -> Option<f64> {
    const STEPS: usize = 100; // profile samples over the half square, 0.005 square apart
    let gap = 0.5 * (board.square_length() - board.marker_length()) / board.square_length();
    let cell = board.marker_length() / board.square_length() / (board.dictionary().marker_size() + 2) as f64;
    // From each marker's centre towards its four sides: its border cell, the white gap, and the
    // black square beyond (when on the board), as (homography, centre, direction).
    let (mut borders, mut paper, mut beyond) = (Vec::new(), Vec::new(), Vec::new());
    for (id, h) in by_id.iter().enumerate() {
        let (Some(h), Some((x, y))) = (h, board.marker_square(id as u32)) else { continue };
        let centre = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
        for dir in [DVec2::X, DVec2::NEG_X, DVec2::Y, DVec2::NEG_Y] {
            borders.push(sample_u8(img, apply(h, centre + dir * (0.5 - gap - 0.5 * cell))));
            paper.push(sample_u8(img, apply(h, centre + dir * (0.5 - 0.5 * gap))));
            let n = centre + dir;
            if n.x > 0.0 && n.y > 0.0 && n.x < board.squares_x() as f64 && n.y < board.squares_y() as f64 {
                beyond.push((h, centre, dir));
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    // The black square's profile inward from its edge, at `k` steps (`STEPS` = its centre).
    let at = |k: usize| {
        let mut v: Vec<f64> = beyond
            .iter()
            .map(|&(h, centre, dir)| sample_u8(img, apply(h, centre + dir * (0.5 + 0.5 * k as f64 / STEPS as f64))))
            .collect();
        median(&mut v)
    };
    let (dark, light) = (median(&mut borders)?, median(&mut paper)?);
    // Solid squares (the common case) are told by their centres alone.
    if at(STEPS)? <= 0.5 * (dark + light) {
        return None;
    }
    let profile: Vec<f64> = (0..=STEPS).map(at).collect::<Option<_>>()?;
    // The frame's inner edge: where the profile, past its darkest point, is back half way
    // from there to the paper (a thin frame, blurred, never reaches the border's black).
    let (low, darkest) = profile.iter().enumerate().fold((0, f64::MAX), |m, (k, &v)| if v < m.1 { (k, v) } else { m });
    let k = (low..=STEPS).find(|&k| profile[k] > 0.5 * (darkest + light))?;
    Some(0.5 * k as f64 / STEPS as f64)
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
    let s = smoothed_patch(img, (cx - margin, cy - margin), (cx + margin, cy + margin), sigma, scratch);
    let origin = DVec2::new((cx - margin) as f64, (cy - margin) as f64);
    let mut local = p - origin;
    let r = saddle_one(&s, &mut local, half, 20, 0.001);
    scratch.1 = s.into_raw();
    Some((local + origin, r))
}

/// The image's pixels `from..=to` (inclusive corners, inside the image) smoothed by `sigma`,
/// in the scratch buffers; the caller hands the result's buffer back to `scratch.1`.
fn smoothed_patch(
    img: &GrayImage,
    from: (i64, i64),
    to: (i64, i64),
    sigma: f64,
    scratch: &mut (Vec<f32>, Vec<f32>, BlurScratch),
) -> ImageF32 {
    let (w, h) = ((to.0 - from.0 + 1) as usize, (to.1 - from.1 + 1) as usize);
    let (patch, smoothed, blur) = scratch;
    patch.clear();
    for y in from.1..=to.1 {
        let row = y as usize * img.width() as usize;
        patch.extend(img.as_raw()[row + from.0 as usize..=row + to.0 as usize].iter().map(|&v| f32::from(v)));
    }
    gaussian_blur_into(patch, w, h, sigma, blur, smoothed);
    ImageF32::from_raw(w as u32, h as u32, std::mem::take(smoothed)).expect("patch buffer")
}
