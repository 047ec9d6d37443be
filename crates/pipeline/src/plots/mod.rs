//! The pictures a calibrating engineer looks at, drawn with `plotters`: calibration residuals,
//! per-view errors, coverage, board poses, projection uncertainty and distortion
//! ([`calibration`]); the rectified pair ([`rectification`]); disparity with its colour bar and
//! error image ([`disparity`]); hand-eye residuals and methods ([`handeye`]).
//!
//! Every picture is a [`Figure`]: PNG bytes always, and an SVG text for the vector plots (bars,
//! scatter, arrows, poses). Raster pictures (images, heat maps) are PNG only. A [`Section`]
//! groups the figures of one stage with its notes and warnings; [`Pictures`] writes the files and
//! one self-contained `report.html` with every image inline (base64).
//!
//! The PNG text is drawn with an embedded subset of DejaVu Sans (`assets/`, Bitstream Vera
//! licence) through plotters' `ab_glyph` back-end: no system font and no fontconfig are needed.
//! The SVG text is left to the viewer's fonts.

pub mod calibration;
pub mod disparity;
pub mod handeye;
pub mod rectification;
pub mod rig;
pub mod tune;
pub mod uncertainty;

use std::fmt::Write as _;
use std::path::Path;
use std::sync::Once;

use base64::Engine as _;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::{PipelineError, Result};

/// One picture: its file stem, caption, PNG bytes and (vector plots) SVG text.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// File stem (`calibration-left-residuals`); the files are `<name>.png` and `<name>.svg`.
    pub name: String,
    /// What the picture shows, with its key figures.
    pub caption: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The PNG encoding.
    pub png: Vec<u8>,
    /// The SVG text of vector plots (`None` for raster pictures).
    pub svg: Option<String>,
}

/// A table of a section: header and rows of text cells.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// Caption of the table.
    pub caption: String,
    /// Column names.
    pub header: Vec<String>,
    /// Rows of cells (as many as the header).
    pub rows: Vec<Vec<String>>,
}

/// The pictures of one stage, with the figures the pictures print and their warnings.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Section {
    /// Title (`calibration — left camera`).
    pub title: String,
    /// Key figures in words (maximum uncertainty, flagged views, ...).
    pub notes: Vec<String>,
    /// Warnings (empty regions of the image, outlier views, distortion fold, ...).
    pub warnings: Vec<String>,
    /// Tables (hand-eye methods side by side).
    pub tables: Vec<Table>,
    /// The figures.
    pub figures: Vec<Figure>,
}

/// A set of sections: the files and one self-contained HTML page.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Pictures {
    /// Title of the page.
    pub title: String,
    /// Sections in order.
    pub sections: Vec<Section>,
}

impl Pictures {
    /// An empty set titled `title`.
    pub fn new(title: impl Into<String>) -> Self {
        Self { title: title.into(), sections: Vec::new() }
    }

    /// Writes every figure (`<name>.png`, and `<name>.svg` for vector plots) into `dir` and
    /// `report.html` with the figures inline, as one set; returns the files written.
    pub fn write(&self, dir: &Path) -> Result<Vec<std::path::PathBuf>> {
        let mut set = crate::io::OutputSet::new();
        self.add_to(&mut set, dir)?;
        set.commit()
    }

    /// Stages the figure files and `report.html` of [`Self::write`] in `set`, for a command that
    /// writes them together with its other outputs as one set.
    pub fn add_to(&self, set: &mut crate::io::OutputSet, dir: &Path) -> Result<()> {
        add_figures(set, dir, &self.sections)?;
        let html = format!(
            "{}<h1>{}</h1>{}</body></html>\n",
            html_head(&self.title),
            escape(&self.title),
            sections_html(&self.sections)
        );
        set.add(dir.join("report.html"), html)
    }
}

/// Adds the figure files of `sections` in `dir` to `set`.
pub fn add_figures(set: &mut crate::io::OutputSet, dir: &Path, sections: &[Section]) -> Result<()> {
    for f in sections.iter().flat_map(|s| &s.figures) {
        set.add(dir.join(format!("{}.png", f.name)), &f.png)?;
        if let Some(svg) = &f.svg {
            set.add(dir.join(format!("{}.svg", f.name)), svg)?;
        }
    }
    Ok(())
}

/// HTML-escapes text.
pub fn escape(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The `<head>` and opening `<body>` shared by the reports.
pub(crate) fn html_head(title: &str) -> String {
    format!(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>{}</title>\
         <style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto}}td,th{{padding:2px 10px;text-align:right}}\
         td:first-child,td:nth-child(2){{text-align:left}}.FAIL{{color:#b00;font-weight:bold}}img{{max-width:100%}}\
         .warn{{color:#a50}}figure{{margin:1em 0}}figcaption{{font-size:90%;color:#333}}</style></head><body>",
        escape(title)
    )
}

/// A data URI of the figure: the SVG when there is one, else the PNG.
pub fn data_uri(f: &Figure) -> String {
    let b64 = base64::engine::general_purpose::STANDARD;
    match &f.svg {
        Some(svg) => format!("data:image/svg+xml;base64,{}", b64.encode(svg.as_bytes())),
        None => format!("data:image/png;base64,{}", b64.encode(&f.png)),
    }
}

/// The HTML of `sections`: notes, warnings, tables and every figure inline.
pub fn sections_html(sections: &[Section]) -> String {
    let mut s = String::new();
    for sec in sections {
        let _ = write!(s, "<h2>{}</h2>", escape(&sec.title));
        if !sec.notes.is_empty() || !sec.warnings.is_empty() {
            s.push_str("<ul>");
            for n in &sec.notes {
                let _ = write!(s, "<li>{}</li>", escape(n));
            }
            for w in &sec.warnings {
                let _ = write!(s, "<li class=\"warn\">warning: {}</li>", escape(w));
            }
            s.push_str("</ul>");
        }
        for t in &sec.tables {
            let _ = write!(s, "<table><caption>{}</caption><tr>", escape(&t.caption));
            for h in &t.header {
                let _ = write!(s, "<th>{}</th>", escape(h));
            }
            s.push_str("</tr>");
            for r in &t.rows {
                s.push_str("<tr>");
                for c in r {
                    let _ = write!(s, "<td>{}</td>", escape(c));
                }
                s.push_str("</tr>");
            }
            s.push_str("</table>");
        }
        for f in &sec.figures {
            let _ = write!(
                s,
                "<figure><img src=\"{}\" alt=\"{}\" width=\"{}\" height=\"{}\"><figcaption>{}</figcaption></figure>",
                data_uri(f),
                escape(&f.name),
                f.width,
                f.height,
                escape(&f.caption)
            );
        }
    }
    s
}

/// The Markdown of `sections` (figures referenced by file name).
pub fn sections_markdown(sections: &[Section]) -> String {
    let mut s = String::new();
    for sec in sections {
        let _ = writeln!(s, "## {}\n", sec.title);
        for n in &sec.notes {
            let _ = writeln!(s, "- {n}");
        }
        for w in &sec.warnings {
            let _ = writeln!(s, "- **warning**: {w}");
        }
        s.push('\n');
        for t in &sec.tables {
            let _ = writeln!(s, "{}\n\n| {} |\n|{}", t.caption, t.header.join(" | "), "---|".repeat(t.header.len()));
            for r in &t.rows {
                let _ = writeln!(s, "| {} |", r.join(" | "));
            }
            s.push('\n');
        }
        for f in &sec.figures {
            let ext = if f.svg.is_some() { "svg" } else { "png" };
            let _ = writeln!(s, "![{0}]({0}.{ext})\n\n*{1}*\n", f.name, f.caption);
        }
    }
    s
}

// ---------------------------------------------------------------------------------------------
// Rendering.

/// The font family the PNG text is drawn with (registered once, embedded).
pub(crate) const FONT: &str = "sans-serif";
static FONT_DATA: &[u8] = include_bytes!("../../assets/DejaVuSans-subset.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The font is embedded and checked by a test: failing here would be a build defect.
        if plotters::style::register_font(FONT, FontStyle::Normal, FONT_DATA).is_err() {
            eprintln!("parallax: the embedded font could not be registered; PNG text will be missing");
        }
    });
}

/// An error of a drawing back-end, as text.
pub(crate) type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;

/// A picture that can be drawn on any plotters back-end.
pub(crate) trait Plot {
    /// Draws on `root` (already sized).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static;
}

fn draw_error(what: &str, e: impl std::fmt::Display) -> PipelineError {
    PipelineError::Input(format!("drawing {what}: {e}"))
}

/// Encodes an RGB8 buffer as PNG.
pub(crate) fn encode_png(w: u32, h: u32, rgb: Vec<u8>) -> Result<Vec<u8>> {
    let img = image::RgbImage::from_raw(w, h, rgb).ok_or_else(|| draw_error("png", "buffer size"))?;
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).map_err(|e| draw_error("png", e))?;
    Ok(out.into_inner())
}

/// Renders `plot` to PNG (and SVG when `vector`).
pub(crate) fn render(
    name: &str,
    caption: String,
    (w, h): (u32, u32),
    vector: bool,
    plot: &impl Plot,
) -> Result<Figure> {
    register_font();
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        plot.draw(&root).map_err(|e| draw_error(name, e))?;
        root.present().map_err(|e| draw_error(name, e))?;
    }
    let png = encode_png(w, h, rgb)?;
    let svg = if vector {
        let mut text = String::new();
        {
            let root = SVGBackend::with_string(&mut text, (w, h)).into_drawing_area();
            plot.draw(&root).map_err(|e| draw_error(name, e))?;
            root.present().map_err(|e| draw_error(name, e))?;
        }
        Some(text)
    } else {
        None
    };
    Ok(Figure { name: name.into(), caption, width: w, height: h, png, svg })
}

/// Renders a raster picture: `background` (RGB8, `w x h`) with `plot` drawn over it.
pub(crate) fn render_over(
    name: &str,
    caption: String,
    (w, h): (u32, u32),
    mut background: Vec<u8>,
    plot: &impl Plot,
) -> Result<Figure> {
    register_font();
    if background.len() != (w * h * 3) as usize {
        return Err(draw_error(name, "background size"));
    }
    {
        let root = BitMapBackend::with_buffer(&mut background, (w, h)).into_drawing_area();
        plot.draw(&root).map_err(|e| draw_error(name, e))?;
        root.present().map_err(|e| draw_error(name, e))?;
    }
    let png = encode_png(w, h, background)?;
    Ok(Figure { name: name.into(), caption, width: w, height: h, png, svg: None })
}

/// A colour per view (distinct hues, cycling).
pub(crate) fn view_colour(i: usize) -> RGBColor {
    const P: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    P[i % P.len()]
}

/// A perceptual colour map (viridis, 9 anchors linearly interpolated) of `t ∈ [0, 1]`.
pub fn colour_map(t: f64) -> [u8; 3] {
    const A: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = t * (A.len() - 1) as f64;
    let i = (x.floor() as usize).min(A.len() - 2);
    let f = x - i as f64;
    std::array::from_fn(|c| (A[i][c] + f * (A[i + 1][c] - A[i][c])).round() as u8)
}

/// `colour_map` as a plotters colour.
pub(crate) fn map_colour(t: f64) -> RGBColor {
    let [r, g, b] = colour_map(t);
    RGBColor(r, g, b)
}

/// Draws a vertical colour bar for values `lo..hi` in `area` with `label` above it and tick
/// labels to its right; `log`: logarithmic scale (both ends positive).
pub(crate) fn colour_bar_scaled<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    lo: f64,
    hi: f64,
    label: &str,
    log: bool,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (lo, hi) =
        if log { (lo.max(1e-12), hi.max(lo.max(1e-12) * 1.001)) } else { (lo, if hi > lo { hi } else { lo + 1.0 }) };
    let (_, h) = area.dim_in_pixel();
    let (x, y0, y1) = (10, 30, h as i32 - 30);
    let n = (y1 - y0).max(1);
    // Position (0 at the bottom, 1 at the top) of a value.
    let pos = |v: f64| if log { (v / lo).ln() / (hi / lo).ln() } else { (v - lo) / (hi - lo) };
    let y_of = |v: f64| y1 - (pos(v) * n as f64).round() as i32;
    area.draw(&Text::new(label.to_string(), (4, 8), (FONT, 13).into_font().color(&BLACK)))?;
    for k in 0..n {
        area.draw(&Rectangle::new(
            [(x, y1 - k - 1), (x + 20, y1 - k)],
            map_colour((k as f64 + 0.5) / n as f64).filled(),
        ))?;
    }
    area.draw(&Rectangle::new([(x, y0), (x + 20, y1)], BLACK.stroke_width(1)))?;
    let mut ticks: Vec<f64> = if log {
        let (a, b) = (lo.log10().ceil() as i32, hi.log10().floor() as i32);
        (a..=b).map(|e| 10f64.powi(e)).collect()
    } else {
        (0..=5).map(|i| lo + (hi - lo) * i as f64 / 5.0).collect()
    };
    if log {
        ticks.push(lo);
        ticks.push(hi);
    }
    let style = (FONT, 11).into_font().color(&BLACK);
    let mut last = i32::MAX;
    ticks.sort_by(f64::total_cmp);
    for v in ticks {
        let y = y_of(v);
        if (last - y).abs() < 12 {
            continue;
        }
        last = y;
        area.draw(&PathElement::new(vec![(x + 20, y), (x + 25, y)], BLACK))?;
        area.draw(&Text::new(tick(v), (x + 28, y - 6), style.clone()))?;
    }
    Ok(())
}

/// A tick label: 3 significant digits.
fn tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else if a >= 0.01 {
        format!("{v:.3}")
    } else {
        format!("{v:.1e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Text;
    impl Plot for Text {
        fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
        where
            DB::ErrorType: 'static,
        {
            root.fill(&WHITE)?;
            root.draw(&plotters::element::Text::new("σ = 0.25 px", (10, 10), (FONT, 30).into_font().color(&BLACK)))?;
            Ok(())
        }
    }

    #[test]
    fn the_embedded_font_draws_text_into_the_png() {
        let f = render("t", "t".into(), (200, 60), true, &Text).unwrap();
        let img = image::load_from_memory(&f.png).unwrap().to_rgb8();
        let dark = img.pixels().filter(|p| p[0] < 128).count();
        // "σ = 0.25 px" at 30 px covers a few hundred pixels; without a font nothing is drawn.
        assert!(dark > 100, "{dark} dark pixels");
        assert!(f.svg.unwrap().contains("0.25 px"));
    }

    #[test]
    fn colour_map_runs_from_dark_purple_to_yellow() {
        assert_eq!(colour_map(0.0), [68, 1, 84]);
        assert_eq!(colour_map(1.0), [253, 231, 37]);
        assert_eq!(colour_map(f64::NAN), [68, 1, 84]);
        let mid = colour_map(0.5);
        assert_eq!(mid, [33, 144, 141]);
    }
}
