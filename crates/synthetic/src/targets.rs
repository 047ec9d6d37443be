//! Rendered views of identified-point targets (ChArUco boards, circle grids) with exact truth,
//! partial views and occluders.

use glam::{DVec2, DVec3};
use image::GrayImage;
use parallax_camera_model::{AprilGrid, Camera, CharucoBoard, CircleGrid, Isometry3, SingleMarker};
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

/// The checks every renderer makes before drawing: the options, the camera, a finite pose
/// (`field` names it in the error).
fn check_inputs(
    opts: &RenderOptions,
    camera: &Camera,
    pose: &Isometry3,
    field: &'static str,
) -> Result<(), SyntheticError> {
    opts.validate()?;
    camera.validate().map_err(SyntheticError::model("camera"))?;
    if !pose.is_finite() {
        return Err(SyntheticError::config(field, "pose is not finite"));
    }
    Ok(())
}

/// Refuses `square_outline` for a target without chessboard squares.
fn solid_only(opts: &RenderOptions, target: &str) -> Result<(), SyntheticError> {
    if opts.square_outline > 0.0 {
        return Err(SyntheticError::config("square_outline", format!("{target} has no chessboard squares to outline")));
    }
    Ok(())
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
    check_inputs(opts, camera, camera_from_board, "camera_from_board")?;
    let (sx, sy) = (board.squares_x(), board.squares_y());
    let sq = board.square_length();
    let dict = board.dictionary();
    let n = dict.marker_size();
    let d = 0.5 * (sq - board.marker_length()) / sq;
    let cell = board.marker_length() / sq / (n + 2) as f64;
    let (m, t) = (opts.margin_squares, opts.square_outline);
    let breaks = |count: usize| {
        let mut b = Vec::new();
        if m > 0.0 {
            b.push(-m);
        }
        for i in 0..count {
            let i = i as f64;
            b.push(i);
            if t > 0.0 {
                b.push(i + t);
            }
            for k in 0..=n + 2 {
                b.push(i + d + k as f64 * cell);
            }
            if t > 0.0 {
                b.push(i + 1.0 - t);
            }
        }
        b.sort_by(f64::total_cmp);
        b.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
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
            let (fx, fy) = (x - i as f64, y - j as f64);
            let frame = t == 0.0 || fx.min(fy).min(1.0 - fx).min(1.0 - fy) < t;
            return if frame { black } else { white };
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
    let image = render_pattern(camera, camera_from_board, sq, &pattern, opts, occluders, &|_, v| v);
    let corners = (0..board.corner_count() as u32).map(|id| board.corner_point(id).expect("id below corner_count"));
    let (points, visible) = truth(camera, camera_from_board, corners, occluders, margin_px);
    Ok(TargetView { image, points, visible, camera_from_target: *camera_from_board })
}

/// Renders a circle grid (see [`CircleGrid`] for the layout): black discs on white paper that
/// extends `opts.margin_squares` grid units beyond the outer circles' edges, `occluders` over
/// it, `opts`' lighting, blur and noise. Coverage of a pixel by a disc is exact on the board
/// plane (area of the pixel's preimage quadrilateral inside the circle, from the signed
/// triangle–disc areas of its edges) divided by the preimage's area: the first-order pixel
/// coverage, whose error is of the order of the homography's curvature over one pixel.
/// Truth: the projection of every circle's centre (not the centre of its elliptical image).
pub fn render_circle_grid(
    camera: &Camera,
    grid: &CircleGrid,
    camera_from_board: &Isometry3,
    opts: &RenderOptions,
    occluders: &[Occluder],
    margin_px: f64,
) -> Result<TargetView, SyntheticError> {
    check_inputs(opts, camera, camera_from_board, "camera_from_board")?;
    solid_only(opts, "a circle grid")?;
    let s = grid.spacing();
    let r = 0.5 * grid.diameter() / s; // in grid units
    let centres: Vec<DVec2> =
        (0..grid.len() as u32).map(|i| grid.point(i).expect("id below len").truncate() / s).collect();
    let (lo, hi) =
        centres.iter().fold((DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)), |(a, b), c| (a.min(*c), b.max(*c)));
    let m = opts.margin_squares + r;
    let (black, white) = (f64::from(opts.black), f64::from(opts.white));
    let pattern = Pattern::from_fn(vec![lo.x - m, hi.x + m], vec![lo.y - m, hi.y + m], |_, _| white);
    let overlay = |quad: Option<[DVec2; 4]>, value: f64| {
        let Some(q) = quad else { return value };
        let qlo = q[0].min(q[1]).min(q[2].min(q[3]));
        let qhi = q[0].max(q[1]).max(q[2].max(q[3]));
        if qhi.x < lo.x - r || qhi.y < lo.y - r || qlo.x > hi.x + r || qlo.y > hi.y + r {
            return value;
        }
        let area = polygon_area(&q);
        if area.is_nan() || area.abs() <= 1e-300 {
            return value;
        }
        let mut cover = 0.0;
        for c in &centres {
            if qhi.x < c.x - r || qlo.x > c.x + r || qhi.y < c.y - r || qlo.y > c.y + r {
                continue;
            }
            cover += disc_polygon_area(*c, r, &q) / area;
        }
        value - cover.clamp(0.0, 1.0) * (white - black)
    };
    let image = render_pattern(camera, camera_from_board, s, &pattern, opts, occluders, &overlay);
    let centres = (0..grid.len() as u32).map(|id| grid.point(id).expect("id below len"));
    let (points, visible) = truth(camera, camera_from_board, centres, occluders, margin_px);
    Ok(TargetView { image, points, visible, camera_from_target: *camera_from_board })
}

/// Renders Kalibr's AprilGrid (see [`AprilGrid`]: tag36h11 tags with a two-bit black border,
/// black squares in the gaps at the tag corners) with exact area coverage (every bit, border
/// and square is an axis-aligned cell), white paper `opts.margin_squares` tag sizes around
/// it, `occluders`, and `opts`' lighting, blur and noise. `camera_from_target` is in Kalibr's
/// target frame (`y` up on the print; [`AprilGrid::target_from_print`]). Truth: every corner's
/// projection and visibility (`margin_px` from the border and the occluders).
pub fn render_aprilgrid(
    camera: &Camera,
    grid: &AprilGrid,
    camera_from_target: &Isometry3,
    opts: &RenderOptions,
    occluders: &[Occluder],
    margin_px: f64,
) -> Result<TargetView, SyntheticError> {
    check_inputs(opts, camera, camera_from_target, "camera_from_target")?;
    solid_only(opts, "an AprilGrid")?;
    let camera_from_print = *camera_from_target * grid.target_from_print();
    let (cols, rows) = (grid.tag_cols(), grid.tag_rows());
    let g = grid.tag_spacing();
    let pitch = 1.0 + g;
    let dict = grid.dictionary();
    let m = opts.margin_squares;
    let breaks = |count: usize| {
        let mut b = vec![-g - m];
        for i in 0..=count {
            let x0 = i as f64 * pitch;
            b.push(x0 - g);
            b.push(x0);
            if i < count {
                b.extend((0..=10).map(|k| x0 + k as f64 / 10.0));
            }
        }
        b.push(count as f64 * pitch - g + g + m);
        b.sort_by(f64::total_cmp);
        b.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        b
    };
    let (black, white) = (f64::from(opts.black), f64::from(opts.white));
    let pattern = Pattern::from_fn(breaks(cols), breaks(rows), |x, y| {
        let (i, j) = ((x / pitch).floor(), (y / pitch).floor());
        let (fx, fy) = (x - i * pitch, y - j * pitch);
        if i >= 0.0 && j >= 0.0 && (i as usize) < cols && (j as usize) < rows && fx < 1.0 && fy < 1.0 {
            let (cx, cy) = ((fx * 10.0).floor() as usize, (fy * 10.0).floor() as usize);
            if !(2..8).contains(&cx) || !(2..8).contains(&cy) {
                return black;
            }
            let id = ((rows - 1 - j as usize) * cols + i as usize) as u32;
            // Kalibr prints each tag turned 180° from OpenCV's canonical marker image
            // (`kalibr_create_target_pdf`: `np.rot90(codeMatrix, 2)` of the Kaess codes, which
            // are OpenCV's `DICT_APRILTAG_36h11` turned 180°; see [`AprilGrid`]).
            return if dict.bit(id, 7 - cy, 7 - cx) { white } else { black };
        }
        // Corner squares: in the gap before tag column i (i = 0..=cols) and row j.
        let (si, sj) = (((x + g) / pitch).floor(), ((y + g) / pitch).floor());
        let in_x = si >= 0.0 && si <= cols as f64 && x >= si * pitch - g && x < si * pitch;
        let in_y = sj >= 0.0 && sj <= rows as f64 && y >= sj * pitch - g && y < sj * pitch;
        if in_x && in_y { black } else { white }
    });
    let image = render_pattern(camera, &camera_from_print, grid.tag_size(), &pattern, opts, occluders, &|_, v| v);
    let corners = (0..grid.corner_count() as u32).map(|id| grid.point(id).expect("id below corner_count"));
    let (points, visible) = truth(camera, camera_from_target, corners, occluders, margin_px);
    Ok(TargetView { image, points, visible, camera_from_target: *camera_from_target })
}

/// Renders one marker ([`SingleMarker`]: one-bit black border, data bits, white paper
/// `opts.margin_squares` marker sizes around it) with exact area coverage, `occluders`, and
/// `opts`' lighting, blur and noise. `camera_from_marker` is in the marker's frame (centre
/// origin, `y` up on the print). Truth: the four corners' projections (`points[k]` for corner
/// `k`) and visibility.
pub fn render_marker(
    camera: &Camera,
    marker: &SingleMarker,
    camera_from_marker: &Isometry3,
    opts: &RenderOptions,
    occluders: &[Occluder],
    margin_px: f64,
) -> Result<TargetView, SyntheticError> {
    check_inputs(opts, camera, camera_from_marker, "camera_from_marker")?;
    solid_only(opts, "a single marker")?;
    let s = marker.size();
    let marker_from_print = Isometry3::from_quat_translation(
        glam::DQuat::from_rotation_x(std::f64::consts::PI),
        DVec3::new(-0.5 * s, 0.5 * s, 0.0),
    );
    let camera_from_print = *camera_from_marker * marker_from_print;
    let dict = marker.dictionary();
    let n = dict.marker_size();
    let cells = (n + 2) as f64;
    let m = opts.margin_squares;
    let mut b = vec![-m];
    b.extend((0..=n + 2).map(|k| k as f64 / cells));
    b.push(1.0 + m);
    let (black, white) = (f64::from(opts.black), f64::from(opts.white));
    let pattern = Pattern::from_fn(b.clone(), b, |x, y| {
        if !(0.0..1.0).contains(&x) || !(0.0..1.0).contains(&y) {
            return white;
        }
        let (cx, cy) = ((x * cells).floor() as usize, (y * cells).floor() as usize);
        if cx == 0 || cy == 0 || cx == n + 1 || cy == n + 1 {
            return black;
        }
        if dict.bit(marker.id(), cy - 1, cx - 1) { white } else { black }
    });
    let image = render_pattern(camera, &camera_from_print, s, &pattern, opts, occluders, &|_, v| v);
    let corners = (0..4).map(|k| marker.point(k).expect("four corners"));
    let (points, visible) = truth(camera, camera_from_marker, corners, occluders, margin_px);
    Ok(TargetView { image, points, visible, camera_from_target: *camera_from_marker })
}

/// The truth of a rendered target: each point's projection (`None` where it does not project)
/// and whether it is visible — in the image by `margin_px` ([`crate::views::visible`]) and at
/// least `margin_px` clear of every occluder.
fn truth(
    camera: &Camera,
    camera_from_target: &Isometry3,
    points: impl Iterator<Item = DVec3>,
    occluders: &[Occluder],
    margin_px: f64,
) -> (Vec<Option<DVec2>>, Vec<bool>) {
    points
        .map(|p| {
            let ok = crate::views::visible(camera, camera_from_target, p, margin_px);
            let px = camera.project_from(camera_from_target, p).ok().filter(|q| q.is_finite());
            let clear = px.is_some_and(|q| occluders.iter().all(|o| o.signed_distance(q) >= margin_px));
            (px, ok && clear)
        })
        .unzip()
}

fn polygon_area(p: &[DVec2]) -> f64 {
    0.5 * (0..p.len()).map(|k| p[k].perp_dot(p[(k + 1) % p.len()])).sum::<f64>()
}

/// Signed area of the intersection of the disc (`c`, `r`) with the polygon `p` (signed as the
/// polygon's winding): the sum over the edges of the signed area of triangle (c, a, b) ∩ disc.
pub(crate) fn disc_polygon_area(c: DVec2, r: f64, p: &[DVec2]) -> f64 {
    (0..p.len()).map(|k| triangle_disc_area(p[k] - c, p[(k + 1) % p.len()] - c, r)).sum()
}

/// Signed area of triangle (0, a, b) ∩ disc(0, r).
fn triangle_disc_area(a: DVec2, b: DVec2, r: f64) -> f64 {
    let d = b - a;
    let (qa, qb, qc) = (d.length_squared(), 2.0 * a.dot(d), a.length_squared() - r * r);
    let mut ts = vec![0.0];
    if qa > 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc > 0.0 {
            let sq = disc.sqrt();
            for t in [(-qb - sq) / (2.0 * qa), (-qb + sq) / (2.0 * qa)] {
                if t > 0.0 && t < 1.0 {
                    ts.push(t);
                }
            }
        }
    }
    ts.push(1.0);
    let mut area = 0.0;
    for w in ts.windows(2) {
        let (p, q) = (a + d * w[0], a + d * w[1]);
        let mid = (p + q) * 0.5;
        if mid.length_squared() <= r * r {
            area += 0.5 * p.perp_dot(q);
        } else {
            area += 0.5 * r * r * p.perp_dot(q).atan2(p.dot(q));
        }
    }
    area
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_polygon_area_is_exact() {
        let sq = [DVec2::new(-1.0, -1.0), DVec2::new(1.0, -1.0), DVec2::new(1.0, 1.0), DVec2::new(-1.0, 1.0)];
        // Disc inside the square, square inside the disc, and a half-covered disc.
        assert!((disc_polygon_area(DVec2::ZERO, 0.5, &sq) - std::f64::consts::PI * 0.25).abs() < 1e-12);
        assert!((disc_polygon_area(DVec2::ZERO, 2.0, &sq) - 4.0).abs() < 1e-12);
        assert!((disc_polygon_area(DVec2::new(1.0, 0.0), 0.5, &sq) - std::f64::consts::PI * 0.125).abs() < 1e-12);
        // A disc over a square corner: a quarter disc.
        assert!((disc_polygon_area(DVec2::new(1.0, 1.0), 0.3, &sq) - std::f64::consts::PI * 0.09 / 4.0).abs() < 1e-12);
        // Against a fine point sampling for an arbitrary triangle.
        let tri = [DVec2::new(0.1, -0.7), DVec2::new(1.3, 0.4), DVec2::new(-0.5, 0.9)];
        let (c, r) = (DVec2::new(0.3, 0.2), 0.6);
        let n = 2000;
        let mut hits = 0usize;
        for i in 0..n {
            for j in 0..n {
                let p = DVec2::new(-0.6 + 2.0 * (i as f64 + 0.5) / n as f64, -0.8 + 2.0 * (j as f64 + 0.5) / n as f64);
                let inside_tri = (0..3).all(|k| (tri[(k + 1) % 3] - tri[k]).perp_dot(p - tri[k]) >= 0.0);
                if inside_tri && (p - c).length() <= r {
                    hits += 1;
                }
            }
        }
        let sampled = hits as f64 * 4.0 / (n * n) as f64;
        assert!(
            (disc_polygon_area(c, r, &tri) - sampled).abs() < 2e-4,
            "{} vs {sampled}",
            disc_polygon_area(c, r, &tri)
        );
    }
}
