//! Kalibr AprilGrids: tag36h11 tags (two-bit border) decoded with [`crate::detect_markers`],
//! each confirmed by a neighbouring tag, its four corners (X-junctions with the corner
//! squares) refined with the saddle fit and verified by the colours around them. Corner ids
//! are Kalibr's; any subset of the grid may be visible.

use glam::{DMat3, DVec2};
use image::GrayImage;
use parallax_camera_model::{AprilGrid, TargetObservation};
use serde::{Deserialize, Serialize};

use crate::charuco::{refine, sample_u8};
use crate::imageops::BlurScratch;
use crate::markers::{DetectedMarker, MarkerConfig, apply, detect_markers, homography_4};
use crate::{Refinement, Result};

/// Configuration of [`detect_aprilgrid`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AprilGridConfig {
    /// Tag detection (the border is two bits for Kalibr's tags).
    pub markers: MarkerConfig,
    /// Gaussian smoothing before the saddle fit, pixels.
    pub smoothing_sigma: f64,
    /// Largest half-window of the saddle fit, pixels.
    pub max_half_window: u32,
    /// Smallest dark/bright difference around a corner, grey levels.
    pub min_contrast: f64,
    /// Use a tag only when a neighbouring tag confirms it (see [`crate::CharucoConfig`]).
    pub require_neighbour: bool,
}

impl Default for AprilGridConfig {
    fn default() -> Self {
        Self {
            markers: MarkerConfig { border_bits: 2, ..MarkerConfig::default() },
            smoothing_sigma: 1.0,
            max_half_window: 8,
            min_contrast: 20.0,
            require_neighbour: true,
        }
    }
}

/// AprilGrid corners found in one image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AprilGridDetection {
    /// Corner ids (Kalibr's numbering, ascending) and refined image positions.
    pub observation: TargetObservation,
    /// The grid's tags that were decoded and confirmed.
    pub tags: Vec<DetectedMarker>,
    /// Per corner (same order): the saddle refinement's report.
    pub refinement: Vec<Refinement>,
}

/// Finds the corners of the AprilGrid `grid` in `img` (any visible subset; an image without
/// the grid gives an empty observation). A corner is reported when its tag is decoded and
/// confirmed, the saddle fit converges within the clean neighbourhood of the X-junction
/// (the tag's two-bit border on one side, the corner square on the other) and both black and
/// both white quadrants are uniform and differ by `min_contrast`.
pub fn detect_aprilgrid(img: &GrayImage, grid: &AprilGrid, cfg: &AprilGridConfig) -> Result<AprilGridDetection> {
    if !(cfg.smoothing_sigma.is_finite()
        && cfg.smoothing_sigma >= 0.0
        && cfg.min_contrast > 0.0
        && cfg.max_half_window >= 2)
    {
        return Err(crate::CornerError::InvalidConfig(
            "AprilGridConfig needs smoothing_sigma >= 0, min_contrast > 0 and max_half_window >= 2".into(),
        ));
    }
    let (cols, rows) = (grid.tag_cols(), grid.tag_rows());
    let found = detect_markers(img, &grid.dictionary(), &cfg.markers)?;
    let tags: Vec<DetectedMarker> = found.into_iter().filter(|m| (m.id as usize) < cols * rows).collect();
    let pitch = 1.0 + grid.tag_spacing();
    // Tag t's top-left corner on the print, in tag sizes (print frame: y down).
    let origin = |t: u32| {
        let (c, r) = (t as usize % cols, rows - 1 - t as usize / cols);
        DVec2::new(c as f64 * pitch, r as f64 * pitch)
    };
    // Where each decoded marker corner (OpenCV's order: the canonical marker's top-left,
    // top-right, bottom-right, bottom-left) lies on the tag, print frame, tag sizes: Kalibr
    // prints every tag turned 180° from OpenCV's canonical image, so marker corner 0 is the
    // tag's bottom-right on the print (the owner's definition, checked on a board drawn as
    // `kalibr_create_target_pdf` draws it: `tests/data/kalibr-aprilgrid/`).
    let unit = [DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0), DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0)];
    let homs: Vec<Option<DMat3>> =
        tags.iter().map(|m| homography_4(&unit.map(|u| u + origin(m.id)), &m.corners)).collect();
    let centre = |m: &DetectedMarker| (m.corners[0] + m.corners[1] + m.corners[2] + m.corners[3]) * 0.25;
    let mut confirmed = vec![!cfg.require_neighbour; tags.len()];
    for i in 0..tags.len() {
        let Some(h) = homs[i] else {
            confirmed[i] = false;
            continue;
        };
        if confirmed[i] {
            continue;
        }
        let side = (tags[i].corners[1] - tags[i].corners[0]).length();
        for j in 0..tags.len() {
            let cj = origin(tags[j].id) + DVec2::splat(0.5);
            if i == j || (origin(tags[i].id) - origin(tags[j].id)).length() > 1.5 * pitch {
                continue;
            }
            let side_j = (tags[j].corners[1] - tags[j].corners[0]).length();
            if (apply(&h, cj) - centre(&tags[j])).length() < 0.25 * side.min(side_j) {
                confirmed[i] = true;
                break;
            }
        }
    }
    let clean = grid.tag_spacing().min(0.2); // clean X-junction radius, tag sizes
    let mut pts: Vec<(u32, DVec2, Refinement)> = Vec::new();
    let mut used = Vec::new();
    let mut scratch = (Vec::new(), Vec::new(), BlurScratch::default());
    for (k, m) in tags.iter().enumerate() {
        let (true, Some(h)) = (confirmed[k], homs[k]) else { continue };
        used.push(*m);
        let ids = grid.tag_corner_ids(m.id).expect("tag on the grid");
        // Kalibr's order (bottom-left, bottom-right, top-right, top-left of the tag on the
        // print, `y` up) against the marker corners (`unit` above): marker corner 1 is the
        // tag's bottom-left, 0 its bottom-right, 3 its top-right, 2 its top-left.
        for (kalibr, marker) in [(0usize, 1usize), (1, 0), (2, 3), (3, 2)] {
            let b = unit[marker] + origin(m.id);
            let inward = (origin(m.id) + DVec2::splat(0.5) - b).signum();
            let scale = [inward, -inward, DVec2::new(inward.x, -inward.y), DVec2::new(-inward.x, inward.y)]
                .iter()
                .map(|d| (apply(&h, b + *d * clean) - apply(&h, b)).length())
                .fold(f64::MAX, f64::min);
            let half = ((0.6 * scale).floor() as u32).min(cfg.max_half_window);
            if half < 2 {
                continue;
            }
            let Some((p, r)) = refine(img, m.corners[marker], half, cfg.smoothing_sigma, &mut scratch) else {
                continue;
            };
            if !r.converged || r.shift > 0.5 * scale.max(2.0) {
                continue;
            }
            let at = |d: DVec2| sample_u8(img, apply(&h, b + d * 0.7 * clean) - apply(&h, b) + p);
            let blacks = [at(inward), at(-inward)];
            let whites = [at(DVec2::new(inward.x, -inward.y)), at(DVec2::new(-inward.x, inward.y))];
            if blacks.iter().chain(&whites).any(|v| v.is_nan()) {
                continue;
            }
            let contrast = whites[0].min(whites[1]) - blacks[0].max(blacks[1]);
            if contrast < cfg.min_contrast
                || (blacks[0] - blacks[1]).abs() > 0.25 * contrast
                || (whites[0] - whites[1]).abs() > 0.25 * contrast
            {
                continue;
            }
            pts.push((ids[kalibr], p, r));
        }
    }
    pts.sort_by_key(|p| p.0);
    let observation = TargetObservation::new(pts.iter().map(|p| p.0).collect(), pts.iter().map(|p| p.1).collect())
        .expect("unique ids (one tag per id), finite points");
    Ok(AprilGridDetection { observation, tags: used, refinement: pts.iter().map(|p| p.2).collect() })
}
