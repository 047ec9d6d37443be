//! Pictures of a mono or stereo calibration, one [`Section`] per camera: reprojection residuals
//! over the image (arrows, per-view colour) and as a `(du, dv)` scatter with the 1σ / 3σ ellipse
//! of the fitted noise; per-view RMS bars with the outlier rule; coverage of the image by the
//! detected corners with the empty regions named; the board poses in the camera frame (with the
//! rig's second camera); the projection uncertainty map ([`super::uncertainty`]); the
//! distortion displacement field and where the lens model folds.
//!
//! Residuals and per-view RMS are recomputed here from the inputs (board, grids, camera, poses),
//! so the pictures show what the camera does with the corners, and a test can compare them with
//! the figures of the calibration result.

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, CornerGrid, Isometry3};
use parallax_planar_calibration::{CalibrationConfig, CalibrationResult, StereoCalibrationResult, StereoConfig};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::uncertainty::ProjectionUncertainty;
use super::{DrawResult, FONT, Figure, Plot, Section, colour_bar_scaled, map_colour, render, view_colour};
use crate::{PipelineError, Result, stats};

/// Width of the image border checked for corners, as a fraction of the image size.
pub const COVERAGE_EDGE: f64 = 0.15;

/// One calibrated camera and what it was calibrated from.
#[derive(Debug, Clone, Copy)]
pub struct CameraInputs<'a> {
    /// `camera`, `left` or `right` (names the files and sections).
    pub label: &'a str,
    /// The calibrated camera.
    pub camera: &'a Camera,
    /// The board.
    pub board: &'a Chessboard,
    /// The detected corners of each view.
    pub grids: &'a [CornerGrid],
    /// This camera's `camera_from_board` per view.
    pub camera_from_board: &'a [Isometry3],
    /// A name per view (file names), same length as `grids`.
    pub view_names: &'a [String],
    /// The flags the camera was calibrated with (free parameters, outlier rule).
    pub config: &'a CalibrationConfig,
    /// For the left camera of a rig: `left_from_right`, drawn in the pose view.
    pub other_camera: Option<Isometry3>,
}

/// The figures a camera's pictures show, for the caller and the tests.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSummary {
    /// Per view, per corner: observed − projected, pixels (recomputed).
    pub residuals_px: Vec<Vec<DVec2>>,
    /// Per-view RMS of the residuals (the bars), pixels.
    pub per_view_rms_px: Vec<f64>,
    /// The bar line: views above it are outliers (`max(factor·median, median + 4·1.4826·MAD)`,
    /// the calibration's rule; `None` with fewer than 3 views).
    pub outlier_threshold_px: Option<f64>,
    /// Views above the line.
    pub flagged_views: Vec<usize>,
    /// Regions of the image with no corner (`"right edge"`, `"top-left corner"`, ...).
    pub empty_regions: Vec<String>,
    /// Range (board units) of the point whose projection uncertainty is mapped (NaN when the
    /// covariance could not be computed: a warning of the section says why).
    pub uncertainty_distance: f64,
    /// Largest predicted worst-direction σ over the map, pixels (NaN as above).
    pub max_sigma_px: f64,
    /// Where the largest σ is.
    pub max_sigma_at: DVec2,
    /// Largest distortion displacement over the image, pixels.
    pub max_distortion_px: f64,
    /// Radius (pixels from the principal point) where the radial distortion folds back, if
    /// inside the image.
    pub fold_radius_px: Option<f64>,
}

fn err(e: impl std::fmt::Display) -> PipelineError {
    PipelineError::Input(e.to_string())
}

/// Observed − projected of every corner.
pub fn residuals(c: &CameraInputs<'_>) -> Result<Vec<Vec<DVec2>>> {
    let object = c.board.object_points();
    c.grids
        .iter()
        .zip(c.camera_from_board)
        .map(|(g, pose)| {
            g.corners
                .iter()
                .zip(&object)
                .map(|(q, x)| c.camera.project_from(pose, *x).map(|p| *q - p).map_err(err))
                .collect()
        })
        .collect()
}

/// The outlier line of the per-view RMS bars (the calibration's rule: a view is flagged above
/// both `factor ·` median and median + 4 robust σ).
pub fn outlier_threshold(per_view: &[f64], factor: f64) -> Option<f64> {
    if per_view.len() < 3 {
        return None;
    }
    let med = midpoint_median(per_view.to_vec());
    let mad = 1.4826 * midpoint_median(per_view.iter().map(|r| (r - med).abs()).collect());
    Some((factor * med).max(med + 4.0 * mad))
}

/// The median with the mean of the two middle values for an even count, as the calibration's
/// outlier rule computes it (`stats::median` takes the upper one).
fn midpoint_median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// A test of whether a pixel lies in a region.
type Inside<'a> = dyn Fn(&DVec2) -> bool + 'a;

/// Regions within [`COVERAGE_EDGE`] of each image edge and corner that hold no corner.
pub fn empty_regions(width: u32, height: u32, corners: &[DVec2]) -> Vec<String> {
    let (w, h) = (f64::from(width), f64::from(height));
    let (ew, eh) = (COVERAGE_EDGE * w, COVERAGE_EDGE * h);
    // Distances from the pixel edges (pixel (0,0) is the centre of the top-left pixel).
    let left = |p: &DVec2| p.x + 0.5 < ew;
    let right = |p: &DVec2| w - 0.5 - p.x < ew;
    let top = |p: &DVec2| p.y + 0.5 < eh;
    let bottom = |p: &DVec2| h - 0.5 - p.y < eh;
    let none = |f: &dyn Fn(&DVec2) -> bool| !corners.iter().any(f);
    let mut out = Vec::new();
    let edges: [(&str, &Inside<'_>); 4] =
        [("left edge", &left), ("right edge", &right), ("top edge", &top), ("bottom edge", &bottom)];
    for (name, f) in edges {
        if none(f) {
            out.push(name.to_string());
        }
    }
    let quads: [(&str, &Inside<'_>, &str, &str); 4] = [
        ("top-left corner", &|p| left(p) && top(p), "left edge", "top edge"),
        ("top-right corner", &|p| right(p) && top(p), "right edge", "top edge"),
        ("bottom-left corner", &|p| left(p) && bottom(p), "left edge", "bottom edge"),
        ("bottom-right corner", &|p| right(p) && bottom(p), "right edge", "bottom edge"),
    ];
    for (name, f, a, b) in quads {
        // A corner region inside an empty edge strip is already named by the edge.
        if none(f) && !out.iter().any(|o| o == a || o == b) {
            out.push(name.to_string());
        }
    }
    out
}

/// The warning for empty regions, e.g. "no corner within 15 % of the right edge: distortion
/// there is extrapolated".
pub fn coverage_warning(regions: &[String]) -> Option<String> {
    if regions.is_empty() {
        return None;
    }
    Some(format!(
        "no corner within {:.0} % of the {}: distortion there is extrapolated",
        100.0 * COVERAGE_EDGE,
        join_and(regions)
    ))
}

fn join_and(v: &[String]) -> String {
    match v.len() {
        0 => String::new(),
        1 => v[0].clone(),
        n => format!("{} and {}", v[..n - 1].join(", "), v[n - 1]),
    }
}

/// The pictures of one camera, and the figures they show.
pub fn camera_section(c: &CameraInputs<'_>) -> Result<(Section, CameraSummary)> {
    if c.grids.len() != c.camera_from_board.len() || c.grids.len() != c.view_names.len() {
        return Err(PipelineError::Input(format!(
            "calibration pictures: {} grids, {} poses, {} view names",
            c.grids.len(),
            c.camera_from_board.len(),
            c.view_names.len()
        )));
    }
    let cam = c.camera;
    let (w, h) = (cam.width, cam.height);
    let res = residuals(c)?;
    let per_view: Vec<f64> = res.iter().map(|r| stats::rms(r.iter().map(|e| e.length()))).collect();
    let threshold = outlier_threshold(&per_view, c.config.outlier_view_factor);
    let flagged: Vec<usize> =
        threshold.map_or(Vec::new(), |t| (0..per_view.len()).filter(|&i| per_view[i] > t).collect());
    let all_corners: Vec<DVec2> = c.grids.iter().flat_map(|g| g.corners.iter().copied()).collect();
    let regions = empty_regions(w, h, &all_corners);
    let mut section = Section { title: format!("calibration — {} camera", c.label), ..Section::default() };
    let stem = |s: &str| format!("calibration-{}-{s}", c.label);

    // Residual vectors over the image.
    let max_res = res.iter().flatten().map(|e| e.length()).fold(0.0, f64::max);
    let arrow_scale = if max_res > 0.0 { 0.06 * f64::from(w.max(h)) / max_res } else { 1.0 };
    section.figures.push(render(
        &stem("residual-vectors"),
        format!(
            "reprojection residuals (observed − projected) over the {w}x{h} image, arrows ×{arrow_scale:.0} \
             (longest {max_res:.3} px), one colour per view"
        ),
        (900, (900.0 * f64::from(h) / f64::from(w)).round() as u32 + 60),
        true,
        &ResidualVectors { c, res: &res, scale: arrow_scale },
    )?);

    // Scatter with the noise ellipse.
    let flat: Vec<DVec2> = res.iter().flatten().copied().collect();
    let cov = covariance2(&flat);
    let sigma_iso = (flat.iter().map(|e| e.length_squared()).sum::<f64>() / (2 * flat.len()).max(1) as f64).sqrt();
    section.figures.push(render(
        &stem("residual-scatter"),
        format!(
            "residuals (du, dv) of {} corners with the 1σ and 3σ ellipses of their covariance: σu {:.3} px, σv {:.3} px, \
             correlation {:.2} (RMS per coordinate {sigma_iso:.3} px)",
            flat.len(),
            cov[0][0].sqrt(),
            cov[1][1].sqrt(),
            cov[0][1] / (cov[0][0] * cov[1][1]).sqrt().max(1e-300)
        ),
        (620, 600),
        true,
        &Scatter { res: &res, cov },
    )?);

    // Per-view RMS bars.
    let median = midpoint_median(per_view.clone());
    let flagged_names: Vec<String> = flagged.iter().map(|&i| c.view_names[i].clone()).collect();
    section.figures.push(render(
        &stem("per-view-rms"),
        match threshold {
            Some(t) => format!(
                "per-view RMS reprojection error; line: the outlier rule (max of {}×median and median + 4 robust σ) at \
                 {t:.3} px; {}",
                c.config.outlier_view_factor,
                if flagged.is_empty() {
                    "no view flagged".to_string()
                } else {
                    format!("flagged: {}", flagged_names.join(", "))
                }
            ),
            None => "per-view RMS reprojection error (fewer than 3 views: no outlier rule)".into(),
        },
        (900, 460),
        true,
        &Bars { names: c.view_names, values: &per_view, threshold, flagged: &flagged },
    )?);
    if !flagged.is_empty() {
        section.warnings.push(format!(
            "outlier views (RMS above {:.3} px, median {median:.3} px): {}",
            threshold.unwrap_or(f64::NAN),
            flagged
                .iter()
                .map(|&i| format!("{} ({:.3} px)", c.view_names[i], per_view[i]))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }

    // Coverage.
    if let Some(wn) = coverage_warning(&regions) {
        section.warnings.push(wn);
    }
    section.figures.push(render(
        &stem("coverage"),
        format!(
            "where the {} detected corners fall (count per cell); dashed: the {:.0} % border strips{}",
            all_corners.len(),
            100.0 * COVERAGE_EDGE,
            if regions.is_empty() {
                ", every one holds corners".to_string()
            } else {
                format!("; empty: {}", join_and(&regions))
            }
        ),
        (900, (900.0 * f64::from(h) / f64::from(w)).round() as u32 + 60),
        false,
        &Coverage { camera: cam, corners: &all_corners, empty: &regions },
    )?);

    // Board poses.
    section.figures.push(render(
        &stem("board-poses"),
        format!(
            "board poses in the {} camera frame (x right, y down, z forward; board units; seen from behind and above the camera){}",
            c.label,
            if c.other_camera.is_some() { "; grey frustum: the rig's second camera" } else { "" }
        ),
        (900, 700),
        true,
        &Poses { c },
    )?);

    // Projection uncertainty (not drawn, with a warning, when the covariance is singular).
    let (mut distance, mut max_sigma, mut max_at) = (f64::NAN, f64::NAN, DVec2::ZERO);
    match ProjectionUncertainty::new(cam, c.board, c.grids, c.camera_from_board, c.config) {
        Ok(unc) => {
            let fig = uncertainty_figure(c, &unc, &all_corners, &stem("uncertainty"))?;
            distance = unc.mean_distance;
            (max_sigma, max_at) = (fig.1, fig.2);
            section.notes.push(format!(
                "projection uncertainty of a point {distance:.1} board units away (mean board distance): worst-direction \
                 σ up to {max_sigma:.3} px at ({:.0}, {:.0}); corner noise σ {:.3} px",
                max_at.x, max_at.y, unc.sigma_px
            ));
            section.figures.push(fig.0);
        }
        Err(e) => section.warnings.push(format!("projection uncertainty not computed: {e}")),
    }

    // Distortion.
    let fold = parallax_planar_calibration::distortion_fold(cam);
    let field = distortion_field(cam, 24);
    let max_dist = field.iter().filter_map(|f| f.1).map(|d| d.length()).fold(0.0, f64::max);
    let fold_text = match &fold {
        Some(f) => format!(
            "the radial model folds back at {:.0} px from the principal point (image corner at {:.0} px): beyond the \
             circle pixels have no unique ray",
            f.radius_px, f.image_radius_px
        ),
        None => "the radial model is monotonic over the whole image".into(),
    };
    if let Some(f) = &fold {
        section.warnings.push(format!(
            "{} camera: distortion is not monotonic beyond {:.0} px from the principal point (image corner {:.0} px)",
            c.label, f.radius_px, f.image_radius_px
        ));
    }
    section.notes.push(format!("distortion: largest displacement {max_dist:.2} px; {fold_text}"));
    section.figures.push(render(
        &stem("distortion"),
        format!(
            "distortion displacement field (distorted − undistorted pixel, arrows to scale ×{:.1}, colour = length, largest \
             {max_dist:.2} px); {fold_text}",
            distortion_arrow_scale(cam, max_dist)
        ),
        (900, (900.0 * f64::from(h) / f64::from(w)).round() as u32 + 60),
        true,
        &DistortionPlot { camera: cam, field: &field, max: max_dist, fold_radius: fold.map(|f| f.radius_px) },
    )?);

    let summary = CameraSummary {
        residuals_px: res,
        per_view_rms_px: per_view,
        outlier_threshold_px: threshold,
        flagged_views: flagged,
        empty_regions: regions,
        uncertainty_distance: distance,
        max_sigma_px: max_sigma,
        max_sigma_at: max_at,
        max_distortion_px: max_dist,
        fold_radius_px: fold.map(|f| f.radius_px),
    };
    Ok((section, summary))
}

/// The uncertainty map of one camera: the figure, the largest σ and where.
fn uncertainty_figure(
    c: &CameraInputs<'_>,
    unc: &ProjectionUncertainty,
    all_corners: &[DVec2],
    name: &str,
) -> Result<(Figure, f64, DVec2)> {
    let cam = c.camera;
    let (w, h) = (cam.width, cam.height);
    let distance = unc.mean_distance;
    let (nx, ny) = (48usize, ((48.0 * f64::from(h) / f64::from(w)).round() as usize).max(2));
    let mut sigma = vec![f64::NAN; nx * ny];
    let (mut max_sigma, mut max_at) = (0.0f64, DVec2::ZERO);
    for j in 0..ny {
        for i in 0..nx {
            let q = DVec2::new(
                (i as f64 + 0.5) * f64::from(w) / nx as f64 - 0.5,
                (j as f64 + 0.5) * f64::from(h) / ny as f64 - 0.5,
            );
            if let Ok(s) = unc.sigma_at(q, distance) {
                sigma[j * nx + i] = s;
                if s > max_sigma {
                    max_sigma = s;
                    max_at = q;
                }
            }
        }
    }
    let figure = render(
        name,
        format!(
            "projection uncertainty: worst-direction σ (px) of the projection of a point {distance:.1} board units away, \
             propagated from the covariance of intrinsics and poses (σ {:.3} px per corner coordinate), logarithmic colour scale; maximum \
             {max_sigma:.3} px at ({:.0}, {:.0}); dots: detected corners",
            unc.sigma_px, max_at.x, max_at.y
        ),
        (900, (760.0 * f64::from(h) / f64::from(w)).round() as u32 + 70),
        false,
        &Heat {
            camera: cam,
            nx,
            ny,
            values: &sigma,
            corners: all_corners,
            label: "σ (px)",
            title: format!("max σ {max_sigma:.3} px"),
        },
    )?;
    Ok((figure, max_sigma, max_at))
}

/// The pictures of a mono calibration.
pub fn mono(
    board: &Chessboard,
    grids: &[CornerGrid],
    view_names: &[String],
    result: &CalibrationResult,
    config: &CalibrationConfig,
) -> Result<(Section, CameraSummary)> {
    camera_section(&CameraInputs {
        label: "camera",
        camera: &result.camera,
        board,
        grids,
        camera_from_board: &result.camera_from_board,
        view_names,
        config,
        other_camera: None,
    })
}

/// The pictures of a stereo calibration: the left camera (with the right camera in its pose
/// view) and the right camera (poses `right_from_left ∘ left_from_board`).
///
/// Each camera's projection uncertainty is that of a mono calibration of its own corners and
/// poses (its flags in `config`): the rig's coupling of the two cameras is left out, which can
/// only overstate σ slightly; with `fix_intrinsics` it is the uncertainty of the mono
/// calibrations the rig was built on.
pub fn stereo(
    board: &Chessboard,
    left: &[CornerGrid],
    right: &[CornerGrid],
    view_names: &[String],
    result: &StereoCalibrationResult,
    config: &StereoConfig,
) -> Result<[(Section, CameraSummary); 2]> {
    let rig = &result.rig;
    let right_poses: Vec<Isometry3> = result.camera_from_board.iter().map(|p| rig.right_from_left * *p).collect();
    // The two cameras are drawn in parallel.
    let (l, r) = rayon::join(
        || {
            camera_section(&CameraInputs {
                label: "left",
                camera: &rig.left,
                board,
                grids: left,
                camera_from_board: &result.camera_from_board,
                view_names,
                config: &config.left,
                other_camera: Some(rig.right_from_left.inverse()),
            })
        },
        || {
            camera_section(&CameraInputs {
                label: "right",
                camera: &rig.right,
                board,
                grids: right,
                camera_from_board: &right_poses,
                view_names,
                config: &config.right,
                other_camera: None,
            })
        },
    );
    Ok([l?, r?])
}

/// Sample covariance (about zero) of 2D residuals.
fn covariance2(v: &[DVec2]) -> [[f64; 2]; 2] {
    let n = v.len().max(1) as f64;
    let (mut a, mut b, mut d) = (0.0, 0.0, 0.0);
    for e in v {
        a += e.x * e.x;
        b += e.x * e.y;
        d += e.y * e.y;
    }
    [[a / n, b / n], [b / n, d / n]]
}

/// Distorted pixel and its displacement from the undistorted one on a grid of `n` columns
/// (`None` where undistortion fails: beyond the fold).
fn distortion_field(cam: &Camera, n: usize) -> Vec<(DVec2, Option<DVec2>)> {
    let (w, h) = (f64::from(cam.width), f64::from(cam.height));
    let ny = ((n as f64 * h / w).round() as usize).max(2);
    let mut out = Vec::with_capacity(n * ny);
    for j in 0..ny {
        for i in 0..n {
            let q = DVec2::new((i as f64 + 0.5) * w / n as f64 - 0.5, (j as f64 + 0.5) * h / ny as f64 - 0.5);
            out.push((q, cam.undistort_pixel(q).ok().map(|u| q - u)));
        }
    }
    out
}

fn distortion_arrow_scale(cam: &Camera, max: f64) -> f64 {
    let cell = f64::from(cam.width) / 24.0;
    if max > 0.0 { (0.9 * cell / max).min(1.0e3) } else { 1.0 }
}

fn arrow<DB: DrawingBackend>(
    chart: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    from: DVec2,
    to: DVec2,
    colour: RGBColor,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let d = to - from;
    let len = d.length();
    let mut lines = vec![vec![(from.x, from.y), (to.x, to.y)]];
    if len > 0.0 {
        let head = 0.3 * len;
        let dir = d / len;
        let nrm = DVec2::new(-dir.y, dir.x);
        for s in [-1.0, 1.0] {
            let p = to - dir * head + nrm * (0.5 * head * s);
            lines.push(vec![(to.x, to.y), (p.x, p.y)]);
        }
    }
    chart.draw_series(lines.into_iter().map(|l| PathElement::new(l, colour.stroke_width(1))))?;
    Ok(())
}

type Chart2d<'a, DB> =
    ChartContext<'a, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>>;

/// A chart over the image frame (y down).
fn image_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    cam: &Camera,
    title: &str,
) -> std::result::Result<Chart2d<'a, DB>, Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let (w, h) = (f64::from(cam.width), f64::from(cam.height));
    let mut chart = ChartBuilder::on(root)
        .margin(10)
        .caption(title, (FONT, 16))
        .x_label_area_size(30)
        .y_label_area_size(45)
        .build_cartesian_2d(-0.5..w - 0.5, h - 0.5..-0.5)?;
    chart.configure_mesh().disable_mesh().x_desc("u (px)").y_desc("v (px)").label_style((FONT, 12)).draw()?;
    chart.draw_series(std::iter::once(Rectangle::new([(-0.5, -0.5), (w - 0.5, h - 0.5)], BLACK.stroke_width(1))))?;
    Ok(chart)
}

struct ResidualVectors<'a> {
    c: &'a CameraInputs<'a>,
    res: &'a [Vec<DVec2>],
    scale: f64,
}

impl Plot for ResidualVectors<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let mut chart = image_chart(root, self.c.camera, &format!("residuals ×{:.0}", self.scale))?;
        for (v, (g, r)) in self.c.grids.iter().zip(self.res).enumerate() {
            let col = view_colour(v);
            chart.draw_series(g.corners.iter().map(|p| Circle::new((p.x, p.y), 1, col.filled())))?;
            for (p, e) in g.corners.iter().zip(r) {
                arrow(&mut chart, *p, *p + *e * self.scale, col)?;
            }
        }
        Ok(())
    }
}

struct Scatter<'a> {
    res: &'a [Vec<DVec2>],
    cov: [[f64; 2]; 2],
}

impl Plot for Scatter<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let max = self.res.iter().flatten().map(|e| e.x.abs().max(e.y.abs())).fold(0.0, f64::max);
        let s3 = 3.0 * self.cov[0][0].max(self.cov[1][1]).sqrt();
        let lim = (1.1 * max.max(s3)).max(1e-3);
        let mut chart = ChartBuilder::on(root)
            .margin(10)
            .caption("residual scatter", (FONT, 16))
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(-lim..lim, lim..-lim)?;
        chart.configure_mesh().x_desc("du (px)").y_desc("dv (px)").label_style((FONT, 12)).draw()?;
        for (v, r) in self.res.iter().enumerate() {
            let col = view_colour(v);
            chart.draw_series(r.iter().map(|e| Circle::new((e.x, e.y), 2, col.filled())))?;
        }
        // Ellipse: eigen-decomposition of the 2x2 covariance.
        let (a, b, d) = (self.cov[0][0], self.cov[0][1], self.cov[1][1]);
        let tr = 0.5 * (a + d);
        let disc = (0.25 * (a - d) * (a - d) + b * b).sqrt();
        let (l1, l2) = ((tr + disc).max(0.0), (tr - disc).max(0.0));
        let theta = 0.5 * (2.0 * b).atan2(a - d);
        for (k, style) in [(1.0, BLACK.stroke_width(2)), (3.0, RGBColor(200, 0, 0).stroke_width(2))] {
            let pts: Vec<(f64, f64)> = (0..=96)
                .map(|i| {
                    let t = std::f64::consts::TAU * i as f64 / 96.0;
                    let (x, y) = (k * l1.sqrt() * t.cos(), k * l2.sqrt() * t.sin());
                    (x * theta.cos() - y * theta.sin(), x * theta.sin() + y * theta.cos())
                })
                .collect();
            chart
                .draw_series(std::iter::once(PathElement::new(pts, style)))?
                .label(if k == 1.0 { "1σ" } else { "3σ" })
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        }
        chart
            .configure_series_labels()
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    }
}

/// Bars of a value per named item, a threshold line and flagged items in red.
pub(crate) struct Bars<'a> {
    pub(crate) names: &'a [String],
    pub(crate) values: &'a [f64],
    pub(crate) threshold: Option<f64>,
    pub(crate) flagged: &'a [usize],
}

impl Plot for Bars<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        bars(root, "per-view RMS", "RMS (px)", self)
    }
}

pub(crate) fn bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    y_desc: &str,
    b: &Bars<'_>,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let n = b.values.len();
    let top = b.values.iter().copied().filter(|v| v.is_finite()).fold(0.0, f64::max).max(b.threshold.unwrap_or(0.0));
    let top = if top > 0.0 { 1.15 * top } else { 1.0 };
    let mut chart = ChartBuilder::on(root)
        .margin(10)
        .caption(title, (FONT, 16))
        .x_label_area_size(70)
        .y_label_area_size(55)
        .build_cartesian_2d(-0.5..n as f64 - 0.5, 0.0..top)?;
    let names = b.names.to_vec();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n.min(40))
        .x_label_formatter(&|x: &f64| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                short(&names[i as usize])
            } else {
                String::new()
            }
        })
        .x_label_style((FONT, 11).into_font().transform(FontTransform::Rotate90))
        .y_desc(y_desc)
        .label_style((FONT, 12))
        .draw()?;
    chart.draw_series(b.values.iter().enumerate().map(|(i, v)| {
        let col = if b.flagged.contains(&i) { RGBColor(210, 30, 30) } else { RGBColor(60, 110, 180) };
        Rectangle::new([(i as f64 - 0.35, 0.0), (i as f64 + 0.35, if v.is_finite() { *v } else { 0.0 })], col.filled())
    }))?;
    if let Some(t) = b.threshold {
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(-0.5, t), (n as f64 - 0.5, t)],
                RGBColor(200, 0, 0).stroke_width(2),
            )))?
            .label(format!("outlier line {t:.3}"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(200, 0, 0).stroke_width(2)));
        chart
            .configure_series_labels()
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    Ok(())
}

/// The file name without directories, cut to 18 characters.
fn short(name: &str) -> String {
    let base = name.rsplit(['/', '\\']).next().unwrap_or(name);
    if base.chars().count() > 18 { base.chars().take(17).chain(std::iter::once('…')).collect() } else { base.into() }
}

struct Coverage<'a> {
    camera: &'a Camera,
    corners: &'a [DVec2],
    empty: &'a [String],
}

impl Plot for Coverage<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let (main, bar) = root.split_horizontally(root.dim_in_pixel().0 - 120);
        let cam = self.camera;
        let (w, h) = (f64::from(cam.width), f64::from(cam.height));
        let (nx, ny) = (32usize, ((32.0 * h / w).round() as usize).max(2));
        let mut count = vec![0usize; nx * ny];
        for p in self.corners {
            let i = (((p.x + 0.5) / w * nx as f64).floor() as isize).clamp(0, nx as isize - 1) as usize;
            let j = (((p.y + 0.5) / h * ny as f64).floor() as isize).clamp(0, ny as isize - 1) as usize;
            count[j * nx + i] += 1;
        }
        let max = count.iter().copied().max().unwrap_or(0).max(1) as f64;
        let mut chart = image_chart(&main, cam, "corner coverage")?;
        chart.draw_series((0..nx * ny).map(|k| {
            let (i, j) = (k % nx, k / nx);
            let x0 = i as f64 * w / nx as f64 - 0.5;
            let y0 = j as f64 * h / ny as f64 - 0.5;
            let c = count[k];
            let col = if c == 0 { RGBColor(235, 235, 235) } else { map_colour(c as f64 / max) };
            Rectangle::new([(x0, y0), (x0 + w / nx as f64, y0 + h / ny as f64)], col.filled())
        }))?;
        // The border strips checked, empty ones in red.
        let (ew, eh) = (COVERAGE_EDGE * w, COVERAGE_EDGE * h);
        let strips = [
            ("left edge", [(-0.5, -0.5), (ew - 0.5, h - 0.5)]),
            ("right edge", [(w - 0.5 - ew, -0.5), (w - 0.5, h - 0.5)]),
            ("top edge", [(-0.5, -0.5), (w - 0.5, eh - 0.5)]),
            ("bottom edge", [(-0.5, h - 0.5 - eh), (w - 0.5, h - 0.5)]),
            ("top-left corner", [(-0.5, -0.5), (ew - 0.5, eh - 0.5)]),
            ("top-right corner", [(w - 0.5 - ew, -0.5), (w - 0.5, eh - 0.5)]),
            ("bottom-left corner", [(-0.5, h - 0.5 - eh), (ew - 0.5, h - 0.5)]),
            ("bottom-right corner", [(w - 0.5 - ew, h - 0.5 - eh), (w - 0.5, h - 0.5)]),
        ];
        for (name, r) in strips {
            let empty = self.empty.iter().any(|e| e == name);
            if empty {
                chart.draw_series(std::iter::once(Rectangle::new(r, RGBColor(220, 0, 0).mix(0.25).filled())))?;
                chart.draw_series(std::iter::once(Rectangle::new(r, RGBColor(200, 0, 0).stroke_width(2))))?;
            } else if !name.contains("corner") {
                chart.draw_series(std::iter::once(dashed_rect(r)))?;
            }
        }
        chart.draw_series(self.corners.iter().map(|p| Circle::new((p.x, p.y), 1, BLACK.filled())))?;
        colour_bar_scaled(&bar, 0.0, max, "corners", false)?;
        Ok(())
    }
}

fn dashed_rect(r: [(f64, f64); 2]) -> PathElement<(f64, f64)> {
    PathElement::new(vec![r[0], (r[1].0, r[0].1), r[1], (r[0].0, r[1].1), r[0]], RGBColor(90, 90, 90).stroke_width(1))
}

struct Heat<'a> {
    camera: &'a Camera,
    nx: usize,
    ny: usize,
    values: &'a [f64],
    corners: &'a [DVec2],
    label: &'a str,
    title: String,
}

impl Plot for Heat<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let (main, bar) = root.split_horizontally(root.dim_in_pixel().0 - 120);
        let cam = self.camera;
        let (w, h) = (f64::from(cam.width), f64::from(cam.height));
        let finite = self.values.iter().copied().filter(|v| v.is_finite());
        let lo = finite.clone().fold(f64::INFINITY, f64::min);
        let hi = finite.fold(0.0, f64::max);
        let lo = if lo.is_finite() { lo.min(hi) } else { 0.0 };
        // A logarithmic scale: σ grows by orders of magnitude away from the corners.
        let (llo, lhi) = (lo.max(1e-9).ln(), hi.max(1e-9).ln());
        let t = |v: f64| (v.max(1e-9).ln() - llo) / (lhi - llo).max(1e-12);
        let mut chart = image_chart(&main, cam, &self.title)?;
        let (nx, ny) = (self.nx, self.ny);
        chart.draw_series((0..nx * ny).map(|k| {
            let (i, j) = (k % nx, k / nx);
            let x0 = i as f64 * w / nx as f64 - 0.5;
            let y0 = j as f64 * h / ny as f64 - 0.5;
            let v = self.values[k];
            let col = if v.is_finite() { map_colour(t(v)) } else { RGBColor(0, 0, 0) };
            Rectangle::new([(x0, y0), (x0 + w / nx as f64, y0 + h / ny as f64)], col.filled())
        }))?;
        chart.draw_series(self.corners.iter().map(|p| Circle::new((p.x, p.y), 1, WHITE.mix(0.6).filled())))?;
        colour_bar_scaled(&bar, lo, hi, self.label, true)?;
        Ok(())
    }
}

struct DistortionPlot<'a> {
    camera: &'a Camera,
    field: &'a [(DVec2, Option<DVec2>)],
    max: f64,
    fold_radius: Option<f64>,
}

impl Plot for DistortionPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let cam = self.camera;
        let scale = distortion_arrow_scale(cam, self.max);
        let mut chart = image_chart(root, cam, &format!("distortion, arrows ×{scale:.1}"))?;
        for (q, d) in self.field {
            match d {
                Some(d) => {
                    let col = map_colour(d.length() / self.max.max(1e-300));
                    arrow(&mut chart, *q - *d * scale, *q, col)?;
                }
                None => {
                    chart.draw_series(std::iter::once(Cross::new(
                        (q.x, q.y),
                        4,
                        RGBColor(200, 0, 0).stroke_width(2),
                    )))?;
                }
            }
        }
        let (cx, cy) = (cam.intrinsics.cx, cam.intrinsics.cy);
        chart.draw_series(std::iter::once(Cross::new((cx, cy), 6, BLACK.stroke_width(2))))?;
        if let Some(r) = self.fold_radius {
            let pts: Vec<(f64, f64)> = (0..=180)
                .map(|i| {
                    let t = std::f64::consts::TAU * i as f64 / 180.0;
                    (cx + r * t.cos(), cy + r * t.sin() * cam.intrinsics.fy / cam.intrinsics.fx)
                })
                .collect();
            chart.draw_series(std::iter::once(PathElement::new(pts, RGBColor(200, 0, 0).stroke_width(2))))?;
        }
        Ok(())
    }
}

struct Poses<'a> {
    c: &'a CameraInputs<'a>,
}

/// Display coordinates of a camera-frame point: a half turn about x (a proper rotation, so the
/// picture is not mirrored): x right, −y up, −z; the axis labels print the camera's y and z.
fn disp(p: DVec3) -> (f64, f64, f64) {
    (p.x, -p.y, -p.z)
}

impl Plot for Poses<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let b = self.c.board;
        let outline = [
            b.point(0, 0),
            b.point(b.cols - 1, 0),
            b.point(b.cols - 1, b.rows - 1),
            b.point(0, b.rows - 1),
            b.point(0, 0),
        ];
        let boards: Vec<Vec<DVec3>> =
            self.c.camera_from_board.iter().map(|t| outline.iter().map(|p| t.transform_point(*p)).collect()).collect();
        let depth = self.c.camera_from_board.iter().map(|t| t.translation.z).fold(0.0, f64::max).max(1e-9);
        let cam = self.c.camera;
        let frustum = |pose: &Isometry3, scale: f64| -> Vec<Vec<DVec3>> {
            let corners: Vec<DVec3> =
                [(0.0, 0.0), (cam.width as f64, 0.0), (cam.width as f64, cam.height as f64), (0.0, cam.height as f64)]
                    .iter()
                    .map(|&(u, v)| {
                        let n = cam.intrinsics.to_normalized(DVec2::new(u - 0.5, v - 0.5));
                        pose.transform_point(n.extend(1.0) * scale)
                    })
                    .collect();
            let o = pose.transform_point(DVec3::ZERO);
            let mut lines: Vec<Vec<DVec3>> = corners.iter().map(|c| vec![o, *c]).collect();
            let mut rim = corners.clone();
            rim.push(corners[0]);
            lines.push(rim);
            lines
        };
        let mut all: Vec<DVec3> = boards.iter().flatten().copied().collect();
        all.push(DVec3::ZERO);
        if let Some(o) = self.c.other_camera {
            all.push(o.translation);
        }
        let lo = all.iter().fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
        let hi = all.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
        let pad = 0.05 * (hi - lo).max_element().max(1e-9);
        let (lo, hi) = (lo - DVec3::splat(pad), hi + DVec3::splat(pad));
        let mut chart = ChartBuilder::on(root)
            .margin(10)
            .caption(format!("board poses, {} camera frame", self.c.label), (FONT, 16))
            .build_cartesian_3d(lo.x..hi.x, -hi.y..-lo.y, -hi.z..-lo.z)?;
        chart.with_projection(|mut p| {
            p.pitch = 0.35;
            p.yaw = 0.6;
            p.scale = 0.8;
            p.into_matrix()
        });
        let neg = |v: &f64| format!("{:.0}", 0.0 - v);
        chart.configure_axes().y_formatter(&neg).z_formatter(&neg).label_style((FONT, 11)).draw()?;
        for (v, poly) in boards.iter().enumerate() {
            let col = view_colour(v);
            chart.draw_series(std::iter::once(Polygon::new(
                poly.iter().map(|p| disp(*p)).collect::<Vec<_>>(),
                col.mix(0.35).filled(),
            )))?;
            chart.draw_series(std::iter::once(PathElement::new(
                poly.iter().map(|p| disp(*p)).collect::<Vec<_>>(),
                col.stroke_width(2),
            )))?;
            let c = (poly[0] + poly[2]) * 0.5;
            chart.draw_series(std::iter::once(Text::new(
                format!("{v}"),
                disp(c),
                (FONT, 12).into_font().color(&BLACK),
            )))?;
        }
        for l in frustum(&Isometry3::IDENTITY, 0.15 * depth) {
            chart.draw_series(std::iter::once(PathElement::new(
                l.iter().map(|p| disp(*p)).collect::<Vec<_>>(),
                BLACK.stroke_width(2),
            )))?;
        }
        if let Some(o) = self.c.other_camera {
            for l in frustum(&o, 0.15 * depth) {
                chart.draw_series(std::iter::once(PathElement::new(
                    l.iter().map(|p| disp(*p)).collect::<Vec<_>>(),
                    RGBColor(120, 120, 120).stroke_width(2),
                )))?;
            }
        }
        Ok(())
    }
}

/// Stages the pictures of a mono calibration in `set` under `dir` (PNG/SVG files and a
/// self-contained `report.html`; `view_names` names the views), to be committed with the
/// command's other outputs: all of them land, or none.
pub fn add_mono_report(
    set: &mut crate::io::OutputSet,
    dir: &std::path::Path,
    board: &Chessboard,
    grids: &[CornerGrid],
    view_names: &[String],
    result: &CalibrationResult,
    config: &CalibrationConfig,
) -> Result<()> {
    let (section, _) = mono(board, grids, view_names, result, config)?;
    let mut pictures = super::Pictures::new("parallax calibration — mono");
    pictures.sections.push(section);
    pictures.add_to(set, dir)
}

/// Stages the pictures of a stereo calibration (both cameras, the rig in the left camera's pose
/// view) in `set` under `dir`, as [`add_mono_report`].
pub fn add_stereo_report(
    set: &mut crate::io::OutputSet,
    dir: &std::path::Path,
    board: &Chessboard,
    left: &[CornerGrid],
    right: &[CornerGrid],
    view_names: &[String],
    result: &StereoCalibrationResult,
    config: &StereoConfig,
) -> Result<()> {
    let [l, r] = stereo(board, left, right, view_names, result, config)?;
    let mut pictures = super::Pictures::new("parallax calibration — stereo");
    pictures.sections = vec![l.0, r.0];
    pictures.add_to(set, dir)
}
