//! Rendered views of identified-point targets (ChArUco boards) with exact truth, partial views
//! and occluders.

use glam::{DVec2, DVec3};
use image::GrayImage;
use parallax_camera_model::{Camera, CharucoBoard, Isometry3};
use serde::{Deserialize, Serialize};

use crate::SyntheticError;
use crate::render::{Pattern, RenderOptions, render_pattern};

/// A convex polygon in pixel coordinates painted in one grey level over the target (an object
/// between the camera and the target), before blur and noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Occluder {
    /// Vertices in pixels, in either winding; the polygon must be convex.
    pub polygon: Vec<DVec2>,
    /// Grey level.
    pub grey: u8,
}

impl Occluder {
    /// Signed distance from `p` to the polygon's boundary, pixels: negative inside.
    pub fn signed_distance(&self, p: DVec2) -> f64 {
        let n = self.polygon.len();
        let area2: f64 = (0..n).map(|k| self.polygon[k].perp_dot(self.polygon[(k + 1) % n])).sum();
        let orient = area2.signum();
        let mut inside = true;
        let mut dist = f64::MAX;
        for k in 0..n {
            let (a, b) = (self.polygon[k], self.polygon[(k + 1) % n]);
            let ab = b - a;
            if orient * ab.perp_dot(p - a) < 0.0 {
                inside = false;
            }
            let t = ((p - a).dot(ab) / ab.length_squared().max(1e-300)).clamp(0.0, 1.0);
            dist = dist.min((a + ab * t - p).length());
        }
        if inside { -dist } else { dist }
    }

    /// Paints the polygon into a `w x h` radiance buffer (8x8 samples per edge pixel).
    pub(crate) fn paint(&self, radiance: &mut [f32], w: usize, h: usize) {
        if self.polygon.len() < 3 {
            return;
        }
        let lo = self.polygon.iter().fold(DVec2::splat(f64::MAX), |m, p| m.min(*p));
        let hi = self.polygon.iter().fold(DVec2::splat(f64::MIN), |m, p| m.max(*p));
        let (u0, u1) = ((lo.x - 1.0).floor().max(0.0) as usize, ((hi.x + 1.0).ceil().max(0.0) as usize).min(w));
        let (v0, v1) = ((lo.y - 1.0).floor().max(0.0) as usize, ((hi.y + 1.0).ceil().max(0.0) as usize).min(h));
        let grey = f32::from(self.grey);
        for v in v0..v1 {
            for u in u0..u1 {
                let p = DVec2::new(u as f64, v as f64);
                let d = self.signed_distance(p);
                let cover = if d < -0.75 {
                    1.0
                } else if d > 0.75 {
                    0.0
                } else {
                    let mut hits = 0;
                    for s in 0..64 {
                        let q = p + DVec2::new(((s % 8) as f64 + 0.5) / 8.0 - 0.5, ((s / 8) as f64 + 0.5) / 8.0 - 0.5);
                        if self.signed_distance(q) < 0.0 {
                            hits += 1;
                        }
                    }
                    hits as f32 / 64.0
                };
                let r = &mut radiance[v * w + u];
                *r = *r * (1.0 - cover) + grey * cover;
            }
        }
    }
}

/// A rendered view of a target with numbered points and its ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetView {
    /// The 8-bit image.
    pub image: GrayImage,
    /// True image positions of every target point, index = point id (ChArUco corner id),
    /// projected through the camera model; `None` when the point has no valid projection
    /// (behind the camera or where the lens model folds back).
    pub points: Vec<Option<DVec2>>,
    /// Per point: projected inside the image by at least `margin_px` and at least `margin_px`
    /// away from every occluder (the points a detector can be asked to find).
    pub visible: Vec<bool>,
    /// The pose the view was rendered from (target frame as the target type defines it).
    pub camera_from_target: Isometry3,
}

impl TargetView {
    /// Fraction of the target's points that are visible.
    pub fn visible_fraction(&self) -> f64 {
        self.visible.iter().filter(|&&v| v).count() as f64 / self.visible.len().max(1) as f64
    }
}

/// Renders a ChArUco board (OpenCV's layout, see [`CharucoBoard`]) with exact area coverage
/// (as [`crate::render_chessboard`]: every square, marker border and marker bit is an
/// axis-aligned cell of the board plane), a white margin of `opts.margin_squares` squares,
/// `occluders` over it, and `opts`' lighting, blur and noise. Black and white are
/// `opts.black` / `opts.white`. Truth: every ChArUco corner's projection and visibility
/// (`margin_px` from the image border and from the occluders).
///
/// Errors on an invalid option or a non-finite pose.
pub fn render_charuco(
    camera: &Camera,
    board: &CharucoBoard,
    camera_from_board: &Isometry3,
    opts: &RenderOptions,
    occluders: &[Occluder],
    margin_px: f64,
) -> Result<TargetView, SyntheticError> {
    opts.validate()?;
    camera.validate().map_err(SyntheticError::model("camera"))?;
    if !camera_from_board.is_finite() {
        return Err(SyntheticError::config("camera_from_board", "pose is not finite"));
    }
    let (sx, sy) = (board.squares_x(), board.squares_y());
    let sq = board.square_length();
    let dict = board.dictionary();
    let n = dict.marker_size();
    let d = 0.5 * (sq - board.marker_length()) / sq;
    let cell = board.marker_length() / sq / (n + 2) as f64;
    let m = opts.margin_squares;
    let breaks = |count: usize| {
        let mut b = Vec::new();
        if m > 0.0 {
            b.push(-m);
        }
        for i in 0..count {
            let i = i as f64;
            b.push(i);
            for k in 0..=n + 2 {
                b.push(i + d + k as f64 * cell);
            }
        }
        b.push(count as f64);
        if m > 0.0 {
            b.push(count as f64 + m);
        }
        b
    };
    let (black, white) = (f64::from(opts.black), f64::from(opts.white));
    let pattern = Pattern::from_fn(breaks(sx), breaks(sy), |x, y| {
        if x < 0.0 || y < 0.0 || x >= sx as f64 || y >= sy as f64 {
            return white;
        }
        let (i, j) = (x.floor() as usize, y.floor() as usize);
        if board.square_is_black(i, j) {
            return black;
        }
        let (cx, cy) = ((x - i as f64 - d) / cell, (y - j as f64 - d) / cell);
        if cx < 0.0 || cy < 0.0 || cx >= (n + 2) as f64 || cy >= (n + 2) as f64 {
            return white;
        }
        let (bx, by) = (cx.floor() as usize, cy.floor() as usize);
        if bx == 0 || by == 0 || bx == n + 1 || by == n + 1 {
            return black;
        }
        let id = board.marker_at(i, j).expect("white square has a marker");
        if dict.bit(id, by - 1, bx - 1) { white } else { black }
    });
    let image = render_pattern(camera, camera_from_board, sq, &pattern, opts, occluders);
    let mut points = Vec::with_capacity(board.corner_count());
    let mut visible = Vec::with_capacity(board.corner_count());
    for id in 0..board.corner_count() as u32 {
        let p: DVec3 = board.corner_point(id).expect("id below corner_count");
        let ok = crate::views::visible(camera, camera_from_board, p, margin_px);
        let px = camera.project_from(camera_from_board, p).ok().filter(|q| q.is_finite());
        let clear = px.is_some_and(|q| occluders.iter().all(|o| o.signed_distance(q) >= margin_px));
        points.push(if ok || px.is_some() { px } else { None });
        visible.push(ok && clear);
    }
    Ok(TargetView { image, points, visible, camera_from_target: *camera_from_board })
}
