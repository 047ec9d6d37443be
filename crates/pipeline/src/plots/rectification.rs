//! The rectified pair side by side: epipolar lines (image rows) through the board rows, the
//! detected corners coloured by their `|Δv|` after rectification, and the valid regions.

use glam::DVec2;
use parallax_camera_model::{CornerGrid, StereoRig};
use parallax_stereo_rectify::Rectification;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{DrawResult, FONT, Plot, Section, map_colour, render_over};
use crate::{PipelineError, Result, stats};

const TOP: u32 = 34;
const BAR: u32 = 110;

/// The rectification section for one view: `left`/`right` are the rectified images, `grids`
/// the detected corners of that view (raw pixels), `all_abs_dv` the corners' `|Δv|` over every
/// view (for the note).
pub fn section(
    rig: &StereoRig,
    rect: &Rectification,
    left: &image::GrayImage,
    right: &image::GrayImage,
    grids: Option<(&CornerGrid, &CornerGrid)>,
    view_name: &str,
    all_abs_dv: &[f64],
) -> Result<Section> {
    let mut s = Section { title: "rectification".into(), ..Section::default() };
    let (w, h) = (left.width(), left.height().max(right.height()));
    let (cw, ch) = (w + right.width() + BAR, h + TOP);
    let mut bg = vec![255u8; (cw * ch * 3) as usize];
    for (img, x0) in [(left, 0), (right, w)] {
        for (x, y, p) in img.enumerate_pixels() {
            let o = (((y + TOP) * cw + x + x0) * 3) as usize;
            bg[o..o + 3].copy_from_slice(&[p[0]; 3]);
        }
    }
    let mut pts = Vec::new();
    if let Some((gl, gr)) = grids {
        let e = |e: parallax_stereo_rectify::RectifyError| PipelineError::Input(e.to_string());
        let lp = parallax_stereo_rectify::rectify_points(&rig.left, rect.r1, &rect.p1, &gl.corners).map_err(e)?;
        let rp = parallax_stereo_rectify::rectify_points(&rig.right, rect.r2, &rect.p2, &gr.corners).map_err(e)?;
        pts = lp.into_iter().zip(rp).collect::<Vec<(DVec2, DVec2)>>();
    }
    let dv: Vec<f64> = pts.iter().map(|(a, b)| (a.y - b.y).abs()).collect();
    let max_dv = dv.iter().copied().fold(0.0, f64::max);
    let all_max = all_abs_dv.iter().copied().fold(0.0, f64::max);
    s.notes.push(format!(
        "corners after rectification: mean |Δv| {:.3} px, max {all_max:.3} px over {} corners of every view; view {view_name}: \
         mean {:.3} px, max {max_dv:.3} px",
        stats::mean(all_abs_dv),
        all_abs_dv.len(),
        stats::mean(&dv),
    ));
    let roi = |r: &parallax_stereo_rectify::Roi| format!("{}x{} at ({}, {})", r.width, r.height, r.x, r.y);
    s.notes.push(format!("valid regions: left {}, right {}", roi(&rect.roi1), roi(&rect.roi2)));
    let bar_max = max_dv.max(0.05);
    s.figures.push(render_over(
        "rectified-pair-epipolar",
        format!(
            "rectified view {view_name}: epipolar lines (green, one per board row through the left corner) must pass through \
             the same corner on the right; corners coloured by |Δv| (0–{bar_max:.2} px); yellow: valid regions (ROI)"
        ),
        (cw, ch),
        bg,
        &Overlay { w, pts: &pts, bar_max, rect, cols: grids.map_or(0, |g| g.0.cols) },
    )?);
    Ok(s)
}

struct Overlay<'a> {
    w: u32,
    pts: &'a [(DVec2, DVec2)],
    bar_max: f64,
    rect: &'a Rectification,
    cols: usize,
}

impl Plot for Overlay<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let (cw, ch) = root.dim_in_pixel();
        let top = TOP as i32;
        let w = self.w as i32;
        root.draw(&Text::new("rectified pair: left | right", (6, 8), (FONT, 14).into_font().color(&BLACK)))?;
        let right_edge = cw as i32 - BAR as i32;
        for (k, (l, _)) in self.pts.iter().enumerate() {
            if self.cols > 0 && k % self.cols == 0 {
                let y = top + l.y.round() as i32;
                root.draw(&PathElement::new(vec![(0, y), (right_edge, y)], RGBColor(0, 220, 0).stroke_width(1)))?;
            }
        }
        for (l, r) in self.pts {
            let c = map_colour((l.y - r.y).abs() / self.bar_max);
            for (p, x0) in [(l, 0), (r, w)] {
                let at = (x0 + p.x.round() as i32, top + p.y.round() as i32);
                root.draw(&Circle::new(at, 3, c.filled()))?;
                root.draw(&Circle::new(at, 3, BLACK.stroke_width(1)))?;
            }
        }
        for (roi, x0) in [(&self.rect.roi1, 0), (&self.rect.roi2, w)] {
            let a = (x0 + roi.x as i32, top + roi.y as i32);
            let b = (a.0 + roi.width as i32 - 1, a.1 + roi.height as i32 - 1);
            root.draw(&Rectangle::new([a, b], RGBColor(255, 210, 0).stroke_width(2)))?;
        }
        // |Δv| colour bar.
        let (x, y0, y1) = (right_edge + 40, top + 20, ch as i32 - 10);
        let n = (y1 - y0).max(1);
        for k in 0..n {
            let t = 1.0 - k as f64 / n as f64;
            root.draw(&Rectangle::new([(x, y0 + k), (x + 18, y0 + k + 1)], map_colour(t).filled()))?;
        }
        root.draw(&Text::new("|Δv| px", (x - 30, y0 - 18), (FONT, 12).into_font().color(&BLACK)))?;
        for i in 0..=4 {
            let t = i as f64 / 4.0;
            let y = y1 - (t * (y1 - y0) as f64).round() as i32;
            root.draw(&Text::new(
                format!("{:.2}", t * self.bar_max),
                (x - 38, y - 6),
                (FONT, 11).into_font().color(&BLACK),
            ))?;
        }
        Ok(())
    }
}
