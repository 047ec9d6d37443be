//! One marker used alone (an AprilTag as a hand-eye target): decoded with
//! [`crate::detect_markers`], its corners refined by fitting a straight line to sub-pixel edge
//! points along each side of the black square and intersecting neighbouring sides (the corners
//! of a lone marker are L-corners, not X-junctions, so the saddle fit does not apply).
//!
//! Why our own decoder rather than `kornia-apriltag` 0.2.0: on the 30 views of
//! `tests/single_marker.rs` (tag36h11 id 42, 60–200 px, blur 0.8, noise 2) both find every tag
//! with no wrong id, but kornia's corners are 0.092 px RMS from the truth (worst 0.27 px, after
//! removing its half-pixel offset: its pixel (0, 0) is the top-left corner of the first pixel)
//! against 0.038 px (worst 0.12 px) here; and the same decoder serves OpenCV's ArUco
//! dictionaries, ChArUco boards and Kalibr's two-bit-border AprilGrid tags. (Measured with a
//! throwaway program outside the workspace on the `MARKER_DUMP` images.)

use glam::DVec2;
use image::GrayImage;
use parallax_camera_model::{SingleMarker, TargetObservation};

use crate::Result;
use crate::charuco::sample_u8;
use crate::markers::{DetectedMarker, MarkerConfig, detect_markers};
use crate::subpix::{line_intersection, tls_line};

/// Finds `marker` in `img` and returns its four corners (ids 0..3 as [`SingleMarker::point`]
/// numbers them) refined to sub-pixel, or `Ok(None)` when it is not seen (or seen twice).
/// The pose of the marker then follows from the corners and the marker's points with a planar
/// pose solver (`parallax_planar_calibration::solve_pnp_planar_points`).
pub fn detect_single_marker(
    img: &GrayImage,
    marker: &SingleMarker,
    cfg: &MarkerConfig,
) -> Result<Option<TargetObservation>> {
    let found = detect_markers(img, &marker.dictionary(), cfg)?;
    let mut it = found.iter().filter(|m| m.id == marker.id());
    let (Some(m), None) = (it.next(), it.next()) else { return Ok(None) };
    let n = marker.dictionary().marker_size() + 2 * cfg.border_bits;
    let Some(corners) = refine_marker_corners(img, m, n, cfg.border_bits) else { return Ok(None) };
    Ok(Some(TargetObservation::new(vec![0, 1, 2, 3], corners.to_vec()).expect("four finite corners")))
}

/// Sub-pixel corners of a decoded marker of `cells` cells per side (border included) whose
/// black border is `border` cells wide: per side, the 50 % crossing between the black border
/// and the white paper along the side's normal at points spread over the side's middle 80 %;
/// each corner is the intersection of total-least-squares lines through the edge points of
/// the halves of its two sides next to it (a lens bends long sides).
/// `None` when a side yields too few edge points or the result moves a corner by more than a
/// cell.
pub fn refine_marker_corners(img: &GrayImage, m: &DetectedMarker, cells: usize, border: usize) -> Option<[DVec2; 4]> {
    let q = m.corners;
    let centre = (q[0] + q[1] + q[2] + q[3]) * 0.25;
    // Edge points of each side with their position t along it.
    let mut edges: Vec<Vec<(f64, DVec2)>> = Vec::with_capacity(4);
    for s in 0..4 {
        let (a, b) = (q[s], q[(s + 1) % 4]);
        let len = (b - a).length();
        let dir = (b - a) / len;
        let mut normal = dir.perp();
        if normal.dot((a + b) * 0.5 - centre) < 0.0 {
            normal = -normal; // pointing out of the marker
        }
        let cell = len / cells as f64;
        let reach = (0.8 * cell * border as f64).clamp(1.0, 4.0);
        let samples = ((len / 1.5) as usize).clamp(12, 96);
        let mut pts = Vec::with_capacity(samples);
        for k in 0..samples {
            let t = 0.1 + 0.8 * (k as f64 + 0.5) / samples as f64;
            let p = a + (b - a) * t;
            // Profile from inside (black border) to outside (paper), 0.25 px steps.
            let steps = (2.0 * reach / 0.25).round() as i32;
            let prof: Vec<f64> = (0..=steps).map(|i| sample_u8(img, p + normal * (-reach + 0.25 * i as f64))).collect();
            if prof.iter().any(|v| v.is_nan()) {
                continue;
            }
            let (lo, hi) = (prof[0], prof[prof.len() - 1]);
            if hi - lo < 20.0 {
                continue;
            }
            let mid = 0.5 * (lo + hi);
            let Some(i) = (0..prof.len() - 1).find(|&i| prof[i] < mid && prof[i + 1] >= mid) else { continue };
            let f = (mid - prof[i]) / (prof[i + 1] - prof[i]);
            pts.push((t, p + normal * (-reach + 0.25 * (i as f64 + f))));
        }
        edges.push(pts);
    }
    // Total-least-squares line through the edge points of side `s` with t in `range`.
    let fit = |s: usize, range: std::ops::Range<f64>| -> Option<(DVec2, DVec2)> {
        let pts = edges[s].iter().filter(|(t, _)| range.contains(t)).map(|e| e.1);
        if pts.clone().count() < 4 {
            return None;
        }
        tls_line(pts)
    };
    // Each corner from the halves of its two sides next to it (lens distortion bends the
    // sides; the half next to the corner is straighter than the whole side).
    let mut lines = [[(DVec2::ZERO, DVec2::ZERO); 2]; 4];
    for s in 0..4 {
        lines[s] = [fit((s + 3) % 4, 0.5..1.0)?, fit(s, 0.0..0.5)?];
    }
    let mut out = [DVec2::ZERO; 4];
    for s in 0..4 {
        let [a, b] = lines[s];
        out[s] = line_intersection(a, b, 1e-6)?;
        let cell = (q[(s + 1) % 4] - q[s]).length() / cells as f64;
        if !out[s].is_finite() || (out[s] - q[s]).length() > cell.max(1.5) {
            return None;
        }
    }
    Some(out)
}
