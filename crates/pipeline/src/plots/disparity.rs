//! Pictures of a disparity map: false colour with a colour bar in pixels (and in depth when the
//! rectification's `Q` is given), invalid pixels black and counted; with ground truth, an error
//! image whose bad pixels are red.

use parallax_camera_model::DisparityMap;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{DrawResult, FONT, Plot, Section, colour_map, map_colour, render_over};
use crate::Result;

/// Ground truth for the error image.
#[derive(Debug, Clone, Copy)]
pub struct DisparityTruth<'a> {
    /// True disparity (NaN = unknown).
    pub disparity: &'a DisparityMap,
    /// Pixels to evaluate (`false`: occluded), `width · height`, or all.
    pub mask: Option<&'a [bool]>,
    /// A pixel is bad when `|d − truth|` exceeds this, pixels.
    pub bad_threshold_px: f64,
}

/// Counts of the error image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorCounts {
    /// Pixels evaluated (truth known and in the mask).
    pub evaluated: usize,
    /// Evaluated pixels whose error exceeds the threshold (red).
    pub bad: usize,
    /// Evaluated pixels without an estimate (black).
    pub missing: usize,
}

const BAR: u32 = 170;
const TOP: u32 = 34;

/// Depth `Z` of disparity `d` through `Q` (`Z = Q₂₃ / (Q₃₂ d + Q₃₃)`), board units.
pub fn depth(q: &[[f64; 4]; 4], d: f64) -> f64 {
    (q[2][3] / (q[3][2] * d + q[3][3])).abs()
}

/// The disparity section: the false-colour map and, with truth, the error image.
pub fn section(
    map: &DisparityMap,
    q: Option<&[[f64; 4]; 4]>,
    truth: Option<DisparityTruth<'_>>,
) -> Result<(Section, Option<ErrorCounts>)> {
    let mut s = Section { title: "disparity".into(), ..Section::default() };
    let (w, h) = (map.width() as u32, map.height() as u32);
    let valid = map.valid_count();
    let invalid = map.data().len() - valid;
    let (lo, hi) = map
        .data()
        .iter()
        .filter(|d| d.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &d| (a.min(f64::from(d)), b.max(f64::from(d))));
    let (lo, hi) = if lo.is_finite() { (lo, hi.max(lo + 1e-6)) } else { (0.0, 1.0) };
    let (cw, ch) = (w + BAR, h + TOP);
    let mut bg = vec![255u8; (cw * ch * 3) as usize];
    for (i, d) in map.data().iter().enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let c = if d.is_finite() { colour_map((f64::from(*d) - lo) / (hi - lo)) } else { [0, 0, 0] };
        let o = (((y + TOP) * cw + x) * 3) as usize;
        bg[o..o + 3].copy_from_slice(&c);
    }
    s.notes.push(format!(
        "{w}x{h}: {valid} valid pixels ({:.1} %), {invalid} invalid (black); disparity {lo:.1}–{hi:.1} px{}",
        100.0 * valid as f64 / (w * h).max(1) as f64,
        q.map_or(String::new(), |q| format!(", depth {:.1}–{:.1} board units", depth(q, hi), depth(q, lo)))
    ));
    s.figures.push(render_over(
        "disparity-colour-bar",
        format!(
            "disparity in false colour, {invalid} invalid pixels black ({:.1} %); colour bar in pixels{}",
            100.0 * invalid as f64 / (w * h).max(1) as f64,
            if q.is_some() { " and in depth (board units, through Q)" } else { "" }
        ),
        (cw, ch),
        bg,
        &Bar { x0: w, lo, hi, q: q.copied(), title: format!("disparity: {invalid} invalid pixels (black)") },
    )?);
    let mut counts = None;
    if let Some(t) = truth {
        let mut bg = vec![255u8; (cw * ch * 3) as usize];
        let mut c = ErrorCounts { evaluated: 0, bad: 0, missing: 0 };
        let thr = t.bad_threshold_px;
        for (i, (d, g)) in map.data().iter().zip(t.disparity.data()).enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let in_mask = t.mask.is_none_or(|m| m.get(i).copied().unwrap_or(false));
            let col = if !g.is_finite() || !in_mask {
                [70, 70, 90]
            } else {
                c.evaluated += 1;
                if !d.is_finite() {
                    c.missing += 1;
                    [0, 0, 0]
                } else {
                    let e = f64::from((d - g).abs());
                    if e > thr {
                        c.bad += 1;
                        [230, 0, 0]
                    } else {
                        let v = (255.0 - 180.0 * e / thr.max(1e-12)) as u8;
                        [v, v, v]
                    }
                }
            };
            let o = (((y + TOP) * cw + x) * 3) as usize;
            bg[o..o + 3].copy_from_slice(&col);
        }
        let pct = |n: usize| 100.0 * n as f64 / c.evaluated.max(1) as f64;
        s.notes.push(format!(
            "against the truth: {} pixels evaluated, {} bad (> {thr} px, {:.2} %), {} without estimate ({:.2} %)",
            c.evaluated,
            c.bad,
            pct(c.bad),
            c.missing,
            pct(c.missing)
        ));
        s.figures.push(render_over(
            "disparity-error",
            format!(
                "error against the truth: white = exact, grey up to {thr} px, red = bad (> {thr} px, {:.2} %), black = no \
                 estimate ({:.2} %), blue-grey = not evaluated (occluded or unknown)",
                pct(c.bad),
                pct(c.missing)
            ),
            (cw, ch),
            bg,
            &Legend { x0: w, title: format!("error: {} bad of {} evaluated", c.bad, c.evaluated) },
        )?);
        counts = Some(c);
    }
    Ok((s, counts))
}

struct Bar {
    x0: u32,
    lo: f64,
    hi: f64,
    q: Option<[[f64; 4]; 4]>,
    title: String,
}

impl Plot for Bar {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let (_, h) = root.dim_in_pixel();
        let style = (FONT, 14).into_font().color(&BLACK);
        root.draw(&Text::new(self.title.clone(), (6, 8), style.clone()))?;
        let (x, y0, y1) = (self.x0 as i32 + 60, TOP as i32 + 10, h as i32 - 10);
        let n = (y1 - y0).max(1);
        for k in 0..n {
            let t = 1.0 - k as f64 / n as f64;
            root.draw(&Rectangle::new([(x, y0 + k), (x + 20, y0 + k + 1)], map_colour(t).filled()))?;
        }
        root.draw(&Rectangle::new([(x, y0), (x + 20, y1)], BLACK.stroke_width(1)))?;
        root.draw(&Text::new("px", (x - 40, y0 - 16), (FONT, 12).into_font().color(&BLACK)))?;
        if self.q.is_some() {
            root.draw(&Text::new("depth", (x + 26, y0 - 16), (FONT, 12).into_font().color(&BLACK)))?;
        }
        for i in 0..=5 {
            let t = i as f64 / 5.0;
            let d = self.lo + t * (self.hi - self.lo);
            let y = y1 - (t * (y1 - y0) as f64).round() as i32;
            let small = (FONT, 12).into_font().color(&BLACK);
            root.draw(&PathElement::new(vec![(x - 4, y), (x, y)], BLACK))?;
            root.draw(&Text::new(format!("{d:.1}"), (x - 52, y - 6), small.clone()))?;
            if let Some(q) = &self.q {
                let z = depth(q, d);
                root.draw(&PathElement::new(vec![(x + 20, y), (x + 24, y)], BLACK))?;
                root.draw(&Text::new(format!("{z:.0}"), (x + 27, y - 6), small))?;
            }
        }
        Ok(())
    }
}

struct Legend {
    x0: u32,
    title: String,
}

impl Plot for Legend {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.draw(&Text::new(self.title.clone(), (6, 8), (FONT, 14).into_font().color(&BLACK)))?;
        let x = self.x0 as i32 + 10;
        let items = [
            (RGBColor(255, 255, 255), "exact"),
            (RGBColor(75, 75, 75), "at threshold"),
            (RGBColor(230, 0, 0), "bad"),
            (RGBColor(0, 0, 0), "no estimate"),
            (RGBColor(70, 70, 90), "not evaluated"),
        ];
        for (i, (c, t)) in items.iter().enumerate() {
            let y = TOP as i32 + 10 + 24 * i as i32;
            root.draw(&Rectangle::new([(x, y), (x + 16, y + 16)], c.filled()))?;
            root.draw(&Rectangle::new([(x, y), (x + 16, y + 16)], BLACK.stroke_width(1)))?;
            root.draw(&Text::new(*t, (x + 22, y + 2), (FONT, 12).into_font().color(&BLACK)))?;
        }
        Ok(())
    }
}
