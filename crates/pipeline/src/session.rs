//! A calibration session on files: the target found in a list of image files (any
//! [`TargetDescription`]), the corners file that `cargo xtask corners` writes and
//! `cargo xtask calibrate --corners` reads, the common image size of the views, and the
//! point-level checks of a stereo calibration (rectified `|Δv|`, adjacent-corner distances).

use std::path::{Path, PathBuf};

use parallax_camera_model::{CornerGrid, StereoRig, TargetDescription, TargetObservation};
use parallax_corner_detection::CornerRefinement;
use parallax_stereo_rectify::Rectification;
use parallax_triangulation::{CornerDistance, TriangulationConfig};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{PipelineError, Result};

/// One image of a session: its file, its size, and the target points found in it.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageView {
    /// The image file.
    pub image: PathBuf,
    /// Image size in pixels.
    pub size: (u32, u32),
    /// The corner grid, for a chessboard found whole.
    pub grid: Option<CornerGrid>,
    /// The identified points of any target (a chessboard's whole grid as ids `0..n`); `None`
    /// when the target was not found.
    pub observation: Option<TargetObservation>,
}

impl ImageView {
    /// A view from a detection result: `grid` for a chessboard, `observation` for any target
    /// (derived from the grid when only that is given).
    pub fn new(
        image: PathBuf,
        size: (u32, u32),
        grid: Option<CornerGrid>,
        observation: Option<TargetObservation>,
    ) -> Result<Self> {
        let observation = match (observation, &grid) {
            (Some(o), _) => Some(o),
            (None, Some(g)) => {
                Some(TargetObservation::whole(g.corners.clone()).map_err(|e| PipelineError::Input(e.to_string()))?)
            }
            (None, None) => None,
        };
        Ok(Self { image, size, grid, observation })
    }

    /// True when the target was found in this image.
    pub fn found(&self) -> bool {
        self.observation.is_some()
    }

    /// The image's file name (empty when it has none).
    pub fn file_name(&self) -> String {
        self.image.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned())
    }
}

/// Finds `target` in every image file (read and searched in parallel, returned in order).
/// Chessboards are found whole with `config` (`find_chessboard`); any other target through
/// [`crate::detect_target`] (any part of a ChArUco board or an AprilGrid).
pub fn detect_files(
    paths: &[PathBuf],
    target: &TargetDescription,
    config: &parallax_corner_detection::ChessboardConfig,
) -> Result<Vec<ImageView>> {
    detect_files_with_progress(paths, target, config, &|| {})
}

/// [`detect_files`], calling `done` as each image is searched (from the worker threads), for a
/// progress report. Each image is decoded and searched on one worker, so at most one image per
/// thread is held at a time.
pub fn detect_files_with_progress(
    paths: &[PathBuf],
    target: &TargetDescription,
    config: &parallax_corner_detection::ChessboardConfig,
    done: &(dyn Fn() + Sync),
) -> Result<Vec<ImageView>> {
    paths
        .par_iter()
        .map(|p| {
            let img = crate::io::load_gray(p)?;
            let (grid, observation) = match target {
                TargetDescription::Chessboard(board) => {
                    (parallax_corner_detection::find_chessboard(&img, board.cols, board.rows, config)?, None)
                }
                _ => (None, crate::detect_target(&img, target)?),
            };
            done();
            ImageView::new(p.clone(), img.dimensions(), grid, observation)
        })
        .collect()
}

/// One image's result in a corners file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImageCorners {
    /// Path of the image as given by the glob.
    pub image: String,
    /// Image size in pixels.
    pub width: u32,
    /// Image size in pixels.
    pub height: u32,
    /// A chessboard's corners in OpenCV's order, or `None` when the board was not found (or
    /// the target is no chessboard).
    pub grid: Option<CornerGrid>,
    /// The identified points (ids in the target's numbering) of a target that is no
    /// chessboard; absent for chessboards.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub observation: Option<TargetObservation>,
    /// Detection + refinement time, milliseconds (finite and not negative: checked when read).
    #[serde(deserialize_with = "finite_time_ms")]
    pub time_ms: f64,
}

/// A detection time read from a file: a finite, non-negative number of milliseconds (a NaN
/// would also make a file unequal to itself).
fn finite_time_ms<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(serde::de::Error::custom(format!("time_ms must be a finite, non-negative number of milliseconds, got {v}")))
    }
}

/// A corners file (written by `cargo xtask corners --out`, read back by
/// `cargo xtask calibrate --corners`). A chessboard's file holds `cols`, `rows` and grids; any
/// other target's file holds the `target` and per-image observations with ids (`cols` and
/// `rows` are then 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CornersFile {
    /// Inner corners per row (chessboards; 0 for other targets).
    pub cols: usize,
    /// Inner corners per column (chessboards; 0 for other targets).
    pub rows: usize,
    /// Refinement method used (of the chessboard detector).
    pub refinement: CornerRefinement,
    /// The target, when it is no chessboard.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<TargetDescription>,
    /// One entry per image, in sorted path order.
    pub images: Vec<ImageCorners>,
}

impl CornersFile {
    /// The file of `images` searched for `target` (`cols`, `rows` and grids for a
    /// chessboard; the target and observations otherwise).
    pub fn new(target: &TargetDescription, refinement: CornerRefinement, images: Vec<ImageCorners>) -> Self {
        match target {
            TargetDescription::Chessboard(b) => Self { cols: b.cols, rows: b.rows, refinement, target: None, images },
            t => Self { cols: 0, rows: 0, refinement, target: Some(*t), images },
        }
    }

    /// The views of this file (read from `path`), checked against `target`: a chessboard
    /// file's size must be the board's, another target's description must be `target`.
    pub fn views(self, path: &Path, target: &TargetDescription) -> Result<Vec<ImageView>> {
        let refuse = |m: String| Err(PipelineError::Input(m));
        match (target, &self.target) {
            (TargetDescription::Chessboard(b), None) => {
                if (self.cols, self.rows) != (b.cols, b.rows) {
                    return refuse(format!(
                        "{} holds {}x{} corners but --board is {}x{}",
                        path.display(),
                        self.cols,
                        self.rows,
                        b.cols,
                        b.rows
                    ));
                }
            }
            (t, Some(f)) if t == f => {}
            (t, f) => {
                let held = f.map_or_else(|| format!("chessboard {}x{}", self.cols, self.rows), |f| f.to_string());
                return refuse(format!("{} holds the corners of {held} but --board is {t}", path.display()));
            }
        }
        self.images
            .into_iter()
            .map(|i| ImageView::new(PathBuf::from(i.image), (i.width, i.height), i.grid, i.observation))
            .collect()
    }
}

/// Reads a corners file (RON or JSON) and its views, checked against `target`
/// ([`CornersFile::views`]).
pub fn read_corners_file(path: &Path, target: &TargetDescription) -> Result<Vec<ImageView>> {
    let file: CornersFile = parallax_interop::read_native(path)?;
    file.views(path, target)
}

/// The one image size of the views with the target found; refuses views of different sizes
/// (naming the file) and an empty list.
pub fn common_size(found: &[&ImageView]) -> Result<(u32, u32)> {
    let size = found.first().ok_or_else(|| PipelineError::Input("no image with a detected board".into()))?.size;
    for f in found {
        if f.size != size {
            return Err(PipelineError::Input(format!(
                "{} is {}x{}, the others {}x{}",
                f.image.display(),
                f.size.0,
                f.size.1,
                size.0,
                size.1
            )));
        }
    }
    Ok(size)
}

/// The paths of the views, as given.
pub fn view_names(views: &[&ImageView]) -> Vec<String> {
    views.iter().map(|f| f.image.display().to_string()).collect()
}

/// Refuses a session in which the target was found in no image, naming the target and the
/// accepted target forms.
pub fn require_found(views: &[ImageView], target: &TargetDescription) -> Result<()> {
    if views.iter().any(ImageView::found) { Ok(()) } else { Err(target_absent(target, views.len())) }
}

/// The error for `target` found in none of `images` images: names it and the accepted forms.
pub fn target_absent(target: &TargetDescription, images: usize) -> PipelineError {
    PipelineError::Input(format!(
        "no {target} found in any of the {images} images (searched for {target}); the targets the detector knows: {}",
        parallax_camera_model::ACCEPTED_FORMS
    ))
}

/// One image searched by [`search_corners`]: its corners-file entry, the line that reports it
/// (`NAME: found …` with the detector's figures, or `NAME: not found (… ms)`; marker targets add
/// `; markers: N`), why a target was not found (`why`), and, when asked for, the overlay picture
/// (a chessboard's grid in OpenCV's order or, when no board was found, its X-junction candidates
/// in red; another target's points in green and the markers it decoded outlined in orange, found
/// or not).
#[derive(Debug, Clone)]
pub struct CornerSearch {
    /// The entry of the corners file (with the detection time).
    pub entry: ImageCorners,
    /// The report line.
    pub line: String,
    /// When the target was not found: what the detector saw and why it was not enough.
    pub why: Option<String>,
    /// The overlay, when asked for.
    pub overlay: Option<image::RgbImage>,
}

impl CornerSearch {
    /// True when the target was found.
    pub fn found(&self) -> bool {
        self.entry.grid.is_some() || self.entry.observation.is_some()
    }
}

/// Searches one image file for `target`, timing the detection (and refinement) alone: a
/// chessboard with `config` (its refinement and settings), any other target with its
/// detector's defaults ([`crate::detect_target`]).
pub fn search_corners(
    path: &Path,
    target: &TargetDescription,
    config: &parallax_corner_detection::ChessboardConfig,
    overlay: bool,
) -> Result<CornerSearch> {
    use parallax_corner_detection as cd;
    let img = crate::io::load_gray(path)?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let context = |e: PipelineError| PipelineError::Input(format!("detecting in {}: {e}", path.display()));
    let t0 = std::time::Instant::now();
    let mut entry = ImageCorners {
        image: path.display().to_string(),
        width: img.width(),
        height: img.height(),
        grid: None,
        observation: None,
        time_ms: 0.0,
    };
    let (line, why, drawing) = match target {
        TargetDescription::Chessboard(b) => {
            let det = cd::detect_chessboard(&img, b.cols, b.rows, config).map_err(|e| context(e.into()))?;
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            entry.time_ms = ms;
            let line = match &det {
                Some(d) => {
                    // said only when it happened: "not converged at 0 corners" read like a warning
                    let unconverged = d.refinement.iter().filter(|r| !r.converged).count();
                    let refinement = if unconverged == 0 {
                        "refinement converged at every corner".to_string()
                    } else {
                        format!("refinement did not converge at {unconverged} of {} corners", d.refinement.len())
                    };
                    format!(
                        "{name}: found {}x{} in {ms:.2} ms (min spacing {:.1} px, min contrast {:.0}, {refinement})",
                        b.cols, b.rows, d.min_spacing, d.min_contrast
                    )
                }
                None => format!("{name}: not found ({ms:.2} ms)"),
            };
            // the X-junction candidates, only for a board not found: counted for `why`, drawn in
            // the overlay
            let candidates = match &det {
                Some(_) => Vec::new(),
                None => cd::chessboard_candidates(&img, config).map_err(|e| context(e.into()))?,
            };
            // and the largest grid of them the detector linked (a second search, only for a board
            // not found)
            let largest = match &det {
                Some(_) => None,
                None => {
                    let mut detector = cd::ChessboardDetector::new(*config).map_err(|e| context(e.into()))?;
                    detector.detect(&img, b.cols, b.rows).map_err(|e| context(e.into()))?;
                    detector.largest_grid()
                }
            };
            let why = det.is_none().then(|| {
                let (n, need) = (candidates.len(), b.cols * b.rows);
                let linked = match largest {
                    Some((c, r)) => format!("; the largest grid linked is {c}x{r}"),
                    None => String::new(),
                };
                if n < need {
                    format!(
                        "{n} X-junction candidates for the {need} inner corners of a {}x{} board{linked}: is the whole board in the image, in focus and lit evenly?",
                        b.cols, b.rows
                    )
                } else {
                    format!(
                        "no {}x{} grid among {n} X-junction candidates{linked}: the size counts inner corners (a board of 10x7 squares is 9x6); is all of it in the image?",
                        b.cols, b.rows
                    )
                }
            });
            let drawing = match (&det, overlay) {
                (_, false) => None,
                (Some(d), true) => Some(cd::draw_chessboard(&img, &d.grid)),
                (None, true) => Some(cd::draw_points(&img, &candidates, [255, 0, 0])),
            };
            entry.grid = det.map(|d| d.grid);
            (line, why, drawing)
        }
        t => {
            let search = crate::search_target(&img, t).map_err(context)?;
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            entry.time_ms = ms;
            let obs = search.observation;
            let markers = search.markers.map_or(String::new(), |m| format!("; markers: {m}"));
            let line = match &obs {
                Some(o) => format!("{name}: found {} points of {t} in {ms:.2} ms{markers}", o.len()),
                None => format!("{name}: not found ({ms:.2} ms){markers}"),
            };
            let points = obs.as_ref().map_or(&[][..], |o| o.points());
            // the points found in green, and the markers decoded in orange (also when the target
            // was rejected: what the detector saw)
            let drawing = overlay.then(|| {
                let mut out = cd::draw_points(&img, points, [0, 255, 0]);
                cd::draw_quads_mut(&mut out, &search.outlines, [255, 160, 0]);
                out
            });
            entry.observation = obs;
            (line, search.why, drawing)
        }
    };
    Ok(CornerSearch { entry, line, why, overlay: drawing })
}

/// The views' chessboard grids and any target's observations (those found).
pub fn points_of(views: &[&ImageView]) -> (Vec<CornerGrid>, Vec<TargetObservation>) {
    let grids = views.iter().filter_map(|v| v.grid.clone()).collect();
    (grids, views.iter().filter_map(|v| v.observation.clone()).collect())
}

/// The stereo pairs of a session that can be calibrated: both cameras saw at least 4 common
/// points of the target (a whole chessboard in both images; for partial targets, matched by id).
pub fn stereo_pairs<'a>(left: &'a [ImageView], right: &'a [ImageView]) -> Vec<(&'a ImageView, &'a ImageView)> {
    let common = |l: &ImageView, r: &ImageView| match (&l.observation, &r.observation) {
        (Some(a), Some(b)) => a.ids().iter().filter(|id| b.get(**id).is_some()).count(),
        _ => 0,
    };
    left.iter().zip(right).filter(|(l, r)| common(l, r) >= 4).collect()
}

/// Mono calibration of the views of any target (the views must have the target found): a
/// chessboard by its grids (`calibrate_chessboard`), any other target from the points each
/// view saw (`calibrate_target`).
pub fn calibrate_views(
    target: &TargetDescription,
    views: &[&ImageView],
    size: (u32, u32),
    config: &parallax_planar_calibration::CalibrationConfig,
) -> Result<parallax_planar_calibration::CalibrationResult> {
    let (grids, observations) = points_of(views);
    Ok(match target {
        TargetDescription::Chessboard(b) => crate::calibrate_mono(b, &grids, size, config)?,
        t => parallax_planar_calibration::calibrate_target(t, &observations, size.0, size.1, config)?,
    })
}

/// Stereo calibration of pairs of any target (as [`stereo_pairs`] keeps them): a chessboard by
/// its grids, any other target from the points both cameras of a pair saw.
pub fn calibrate_stereo_views(
    target: &TargetDescription,
    left: &[&ImageView],
    right: &[&ImageView],
    sizes: [(u32, u32); 2],
    config: &parallax_planar_calibration::StereoConfig,
) -> Result<parallax_planar_calibration::StereoCalibrationResult> {
    let ((lg, lo), (rg, ro)) = (points_of(left), points_of(right));
    Ok(match target {
        TargetDescription::Chessboard(b) => {
            parallax_planar_calibration::calibrate_stereo_chessboard(b, &lg, &rg, sizes[0], sizes[1], config)?
        }
        t => parallax_planar_calibration::calibrate_stereo_target(t, &lo, &ro, sizes[0], sizes[1], config)?,
    })
}

/// The point-level checks of a stereo calibration, from its own corners: the rectification
/// (`rectify`'s default), the corners' `|v_left − v_right|` after it, and the distances between
/// adjacent target points triangulated with the rig against their true length.
#[derive(Debug, Clone)]
pub struct StereoCornerChecks {
    /// The rectification the checks used.
    pub rectification: Rectification,
    /// `|Δv|` of every common point after rectification, pixels.
    pub abs_dv: Vec<f64>,
    /// Mean of `abs_dv` (NaN without points).
    pub mean_abs_dv: f64,
    /// Largest of `abs_dv` (0 without points).
    pub max_abs_dv: f64,
    /// Number of adjacent-point distances measured.
    pub distances: usize,
    /// RMS of (measured − true) over them, in the target's length unit (NaN without any).
    pub distance_rms: f64,
}

impl StereoCornerChecks {
    fn new(rectification: Rectification, abs_dv: Vec<f64>, distances: usize, distance_rms: f64) -> Self {
        let mean_abs_dv = crate::stats::mean(&abs_dv);
        let max_abs_dv = abs_dv.iter().fold(0.0f64, |a, b| a.max(*b));
        Self { rectification, abs_dv, mean_abs_dv, max_abs_dv, distances, distance_rms }
    }
}

/// [`StereoCornerChecks`] of a chessboard session: the rectification of the detected corners
/// (point-level, no resampling) and the triangulated distances between horizontally and
/// vertically adjacent corners (true length: the square size), with the pixel noise `sigma_px`.
pub fn chessboard_corner_checks(
    rig: &StereoRig,
    board: &parallax_camera_model::Chessboard,
    left: Vec<CornerGrid>,
    right: Vec<CornerGrid>,
    sigma_px: f64,
) -> Result<StereoCornerChecks> {
    let views = crate::StereoViews { index: (0..left.len()).collect(), left, right };
    let rectified = crate::rectify(rig, &views, &Default::default())?;
    let tri = TriangulationConfig { pixel_sigma: sigma_px, ..Default::default() };
    let distances: Vec<CornerDistance> = crate::adjacent_distances(rig, Some(&rectified), &views, &tri)?;
    let rms = parallax_triangulation::distance_rms(&distances, board.square_size).unwrap_or(f64::NAN);
    Ok(StereoCornerChecks::new(rectified.rectification, rectified.abs_dv, distances.len(), rms))
}

/// [`StereoCornerChecks`] of any target: per pair, the points both cameras saw (matched by
/// id); "adjacent" are the pairs of those points whose true distance is the target's
/// smallest point spacing (within 1 %), e.g. neighbouring ChArUco corners.
pub fn target_corner_checks(
    rig: &StereoRig,
    target: &TargetDescription,
    left: &[TargetObservation],
    right: &[TargetObservation],
) -> Result<StereoCornerChecks> {
    let rectification = parallax_stereo_rectify::stereo_rectify(rig, &Default::default())?;
    let points = target.points();
    let spacing = points
        .iter()
        .enumerate()
        .flat_map(|(i, a)| points[i + 1..].iter().map(move |b| (*a - *b).length()))
        .fold(f64::INFINITY, f64::min);
    let (mut dv, mut sq, mut n) = (Vec::new(), 0.0, 0usize);
    let tri = TriangulationConfig { covariance: false, ..Default::default() };
    for (k, (l, r)) in left.iter().zip(right).enumerate() {
        let (object, lp, rp) = parallax_planar_calibration::common_points(target, l, r, k)?;
        let a = parallax_stereo_rectify::rectify_points(&rig.left, rectification.r1, &rectification.p1, &lp)?;
        let b = parallax_stereo_rectify::rectify_points(&rig.right, rectification.r2, &rectification.p2, &rp)?;
        dv.extend(a.iter().zip(&b).map(|(a, b)| (a.y - b.y).abs()));
        let pairs: Vec<_> = lp.iter().copied().zip(rp.iter().copied()).collect();
        if pairs.len() < 2 {
            continue;
        }
        let m = parallax_triangulation::measure_stereo(rig, &pairs, &tri)?;
        for d in &m.distances {
            let truth = (object[d.from] - object[d.to]).length();
            if truth <= 1.01 * spacing {
                sq += (d.distance - truth).powi(2);
                n += 1;
            }
        }
    }
    let rms = if n > 0 { (sq / n as f64).sqrt() } else { f64::NAN };
    Ok(StereoCornerChecks::new(rectification, dv, n, rms))
}

/// Rig calibration of any target from frames matched across cameras: `frames[f][c]` is camera
/// `c`'s view of frame `f` (`None`: no such image, or the target not found in it); `sizes[c]`
/// its image size. Whole chessboards and partial ChArUco / AprilGrid views alike (each camera
/// uses the points it saw).
pub fn calibrate_rig_views(
    target: &TargetDescription,
    frames: &[Vec<Option<&ImageView>>],
    sizes: &[(u32, u32)],
    config: &parallax_planar_calibration::RigConfig,
) -> Result<parallax_planar_calibration::RigCalibrationResult> {
    let observations: Vec<Vec<Option<TargetObservation>>> =
        frames.iter().map(|f| f.iter().map(|v| v.and_then(|v| v.observation.clone())).collect()).collect();
    Ok(parallax_planar_calibration::calibrate_rig_target(target, &observations, sizes, config)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;
    use parallax_camera_model::Chessboard;

    fn view(name: &str, size: (u32, u32)) -> ImageView {
        let grid = CornerGrid::new(2, 2, vec![DVec2::ZERO, DVec2::X, DVec2::Y, DVec2::ONE]).unwrap();
        ImageView::new(PathBuf::from(name), size, Some(grid), None).unwrap()
    }

    #[test]
    fn common_size_names_the_odd_image_and_an_empty_session() {
        let (a, b) = (view("a.png", (640, 480)), view("b.png", (800, 600)));
        assert_eq!(common_size(&[&a, &a]).unwrap(), (640, 480));
        let err = common_size(&[&a, &b]).unwrap_err().to_string();
        assert!(err.contains("b.png is 800x600, the others 640x480"), "{err}");
        assert!(common_size(&[]).unwrap_err().to_string().contains("no image"));
        assert_eq!(a.observation.as_ref().unwrap().ids(), &[0, 1, 2, 3]);
        assert_eq!(view_names(&[&a, &b]), ["a.png", "b.png"]);
    }

    #[test]
    fn corners_files_are_checked_against_the_target() {
        let board = TargetDescription::Chessboard(Chessboard::new(2, 2, 1.0).unwrap());
        let img = ImageCorners {
            image: "a.png".into(),
            width: 8,
            height: 6,
            grid: view("a.png", (8, 6)).grid,
            observation: None,
            time_ms: 1.0,
        };
        let file = CornersFile::new(&board, CornerRefinement::Saddle, vec![img]);
        let text = crate::io::to_ron(&file).unwrap();
        assert!(!text.contains("target") && !text.contains("observation"), "chessboard files keep their form: {text}");
        let views = file.clone().views(Path::new("c.ron"), &board).unwrap();
        assert_eq!((views.len(), views[0].size, views[0].observation.as_ref().unwrap().len()), (1, (8, 6), 4));
        let other = TargetDescription::Chessboard(Chessboard::new(9, 6, 1.0).unwrap());
        let err = file.clone().views(Path::new("c.ron"), &other).unwrap_err().to_string();
        assert!(err.contains("holds 2x2 corners but --board is 9x6"), "{err}");
        let charuco: TargetDescription = "charuco:5x4:40:30:DICT_4X4_50".parse().unwrap();
        let err = file.views(Path::new("c.ron"), &charuco).unwrap_err().to_string();
        assert!(err.contains("chessboard 2x2") && err.contains("charuco:5x4"), "{err}");
        let err = require_found(&[ImageView::new("x.png".into(), (8, 6), None, None).unwrap()], &charuco)
            .unwrap_err()
            .to_string();
        assert!(err.contains("no charuco:5x4") && err.contains("aprilgrid:"), "{err}");
    }

    #[test]
    fn a_corners_file_with_a_time_that_is_no_time_is_refused() {
        // found by the corners_file fuzz target: `time_ms: NaN` parsed, and the file was then
        // unequal to itself read back
        let entry = |t: &str| {
            format!(
                "(cols: 2, rows: 2, refinement: Saddle, images: [(image: \"a.png\", width: 8, height: 6, grid: None, time_ms: {t})])"
            )
        };
        assert_eq!(ron::from_str::<CornersFile>(&entry("3.5")).unwrap().images[0].time_ms, 3.5);
        for bad in ["NaN", "inf", "-1.0"] {
            let err = ron::from_str::<CornersFile>(&entry(bad)).unwrap_err().to_string();
            assert!(err.contains("time_ms must be a finite, non-negative number"), "{bad}: {err}");
        }
    }
}
