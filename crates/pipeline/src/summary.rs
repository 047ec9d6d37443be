//! Text summaries of the stages' results, as the `cargo xtask` commands print them: a camera
//! with its uncertainties, the `key: value` lines scripts read (the commands' output
//! contracts), a stereo rig, a hand-eye solution, a measurement table. Each function returns
//! the lines joined by `\n`, without a final newline.

use std::fmt::Write;

use parallax_camera_model::{Camera, LensModel};
use parallax_hand_eye::{HandEyeSolution, Method};
use parallax_planar_calibration::{IntrinsicStdDevs, StereoCalibrationResult};
use parallax_triangulation::Measurement;

fn pm(v: f64, s: Option<f64>) -> String {
    match s {
        Some(s) => format!("{v:.6} ± {s:.6}"),
        None => format!("{v:.6} (fixed)"),
    }
}

fn finish(mut s: String) -> String {
    s.truncate(s.trim_end_matches('\n').len());
    s
}

/// A camera's intrinsics and distortion with their standard deviations (`(fixed)` where held).
pub fn camera(name: &str, c: &Camera, s: &IntrinsicStdDevs) -> String {
    let k = c.intrinsics;
    let mut out = match c.lens_model() {
        LensModel::BrownConrady => format!("{name}: {}x{}\n", c.width, c.height),
        wide => format!("{name}: {}x{}, {wide} lens\n", c.width, c.height),
    };
    let _ = writeln!(out, "  fx {}  fy {}", pm(k.fx, s.fx), pm(k.fy, s.fy));
    let _ = writeln!(out, "  cx {}  cy {}", pm(k.cx, s.cx), pm(k.cy, s.cy));
    let Some(d) = c.distortion() else {
        let names = c.lens_model().parameter_names();
        let values: Vec<String> = names.iter().zip(c.lens.parameters()).map(|(n, v)| format!("{n} {v:.8}")).collect();
        let _ = writeln!(out, "  {}", values.join("  "));
        return finish(out);
    };
    let _ = writeln!(out, "  k1 {}  k2 {}  k3 {}", pm(d.k1, s.k1), pm(d.k2, s.k2), pm(d.k3, s.k3));
    let _ = writeln!(out, "  p1 {}  p2 {}", pm(d.p1, s.p1), pm(d.p2, s.p2));
    if d.is_rational() || s.k4.is_some() {
        let _ = writeln!(out, "  k4 {}  k5 {}  k6 {}", pm(d.k4, s.k4), pm(d.k5, s.k5), pm(d.k6, s.k6));
    }
    finish(out)
}

/// The `key: value` lines of a calibrated camera: `{prefix}rms_px`, `fx fy cx cy` (6 decimals),
/// `lens` (`pinhole`, `kannala-brandt`, `double-sphere`), then the lens parameters (8
/// decimals): `k1 k2 p1 p2 k3`, `k1 k2 k3 k4` or `xi alpha`.
pub fn camera_keys(prefix: &str, rms: f64, c: &Camera) -> String {
    let k = c.intrinsics;
    let mut out = format!("{prefix}rms_px: {rms:.6}\n");
    for (name, v) in [("fx", k.fx), ("fy", k.fy), ("cx", k.cx), ("cy", k.cy)] {
        let _ = writeln!(out, "{prefix}{name}: {v:.6}");
    }
    let _ = writeln!(out, "{prefix}lens: {}", c.lens_model());
    let names = c.lens_model().parameter_names();
    // Brown–Conrady: OpenCV's five (the rational terms are in the files)
    for (name, v) in names.iter().zip(c.lens.parameters()).take(5) {
        let _ = writeln!(out, "{prefix}{name}: {v:.8}");
    }
    finish(out)
}

/// A stereo calibration's rig: `right_from_left` (rotation vector and translation with their
/// standard deviations), the baseline and the RMS errors.
pub fn rig(r: &StereoCalibrationResult) -> String {
    let (e, s) = (r.rig.right_from_left, r.rig_std_devs);
    let rv = e.rvec();
    let mut out = format!(
        "right_from_left: rvec [{:.6}, {:.6}, {:.6}] ± [{:.6}, {:.6}, {:.6}] rad\n",
        rv.x, rv.y, rv.z, s.rotation_rad.x, s.rotation_rad.y, s.rotation_rad.z
    );
    let t = e.translation;
    let _ = writeln!(
        out,
        "                 t [{:.4}, {:.4}, {:.4}] ± [{:.4}, {:.4}, {:.4}]",
        t.x, t.y, t.z, s.translation.x, s.translation.y, s.translation.z
    );
    let _ = writeln!(out, "baseline {:.4} ± {:.4} (square units)", r.rig.baseline(), s.baseline);
    let _ = write!(out, "RMS: both {:.4} px, left {:.4} px, right {:.4} px", r.rms_px, r.left_rms_px, r.right_rms_px);
    out
}

/// One hand-eye solution: the `method:` line (translation, quaternion `x y z w`, residuals,
/// `converged` of the refinement), the ROS `tf` line, the rotation vector, the refinement's
/// summary and standard deviations, warnings and the board spread.
pub fn hand_eye_solution(s: &HandEyeSolution) -> String {
    let t = s.transform.translation;
    let c = s.conventions();
    let [qx, qy, qz, qw] = c.quaternion_xyzw;
    let converged = s.refinement.as_ref().map(|rf| format!(" converged: {}", rf.converged)).unwrap_or_default();
    let mut out = format!(
        "method: {} tx: {:.6} ty: {:.6} tz: {:.6} qx: {:.9} qy: {:.9} qz: {:.9} qw: {:.9} rot_residual_deg: {:.4} \
         trans_residual: {:.6}{converged}\n",
        s.method, t.x, t.y, t.z, qx, qy, qz, qw, s.quality.mean_rotation_deg, s.quality.mean_translation
    );
    let rv = c.rotation_vector;
    let _ = writeln!(out, "    tf (x y z qx qy qz qw): {}", c.tf_line());
    let _ = writeln!(out, "    rotation vector [{:.9}, {:.9}, {:.9}] rad", rv[0], rv[1], rv[2]);
    if let Some(rf) = &s.refinement {
        let _ = writeln!(
            out,
            "    {}; translation noise robot {:.6} camera {:.6} (data unit)",
            rf.convergence_summary(),
            rf.robot_translation_sigma,
            rf.camera_translation_sigma
        );
    }
    for w in &s.warnings {
        let _ = writeln!(out, "    warning: {w}");
    }
    let q = &s.quality;
    let _ = writeln!(
        out,
        "    board spread {:.4}° / {:.6}, table-4 error {:.6}",
        q.board_spread_rotation_deg, q.board_spread_translation, q.mean_matrix_error
    );
    if let Some((rf, sd)) = s.refinement.as_ref().and_then(|rf| rf.std_devs.map(|sd| (rf, sd))) {
        let _ = writeln!(
            out,
            "    std devs: rotation [{:.4}, {:.4}, {:.4}]°, translation [{:.6}, {:.6}, {:.6}]; variance factor {:.3}, \
             from {}",
            sd[0].to_degrees(),
            sd[1].to_degrees(),
            sd[2].to_degrees(),
            sd[3],
            sd[4],
            sd[5],
            rf.variance_factor,
            s.start.map(Method::name).unwrap_or("?")
        );
    }
    finish(out)
}

/// The `key: value` lines of a hand-eye result: `result`, `result_transform` (`what`),
/// `result_tf`, `result_rotation_vector_rad`.
pub fn hand_eye_keys(s: &HandEyeSolution, what: &str) -> String {
    let c = s.conventions();
    let rv = c.rotation_vector;
    format!(
        "result: {}\nresult_transform: {what}\nresult_tf: {}\nresult_rotation_vector_rad: {} {} {}",
        s.method,
        c.tf_line(),
        rv[0],
        rv[1],
        rv[2]
    )
}

/// Where hand-eye intrinsics came from: `calibration: FILE (FORMATS, KIND)` (and which camera
/// of a stereo calibration), or the ViSP camera's parameters.
pub fn intrinsics(
    path: &std::path::Path,
    intrinsics: &crate::poses::Intrinsics,
    side: parallax_interop::Side,
) -> String {
    match intrinsics {
        crate::poses::Intrinsics::Calibration { calibration, formats, .. } => {
            let formats: Vec<&str> = formats.iter().map(|f| f.name()).collect();
            let mut out = format!("calibration: {} ({}, {})", path.display(), formats.join(" + "), calibration.kind());
            if matches!(**calibration, parallax_interop::Calibration::Stereo(_)) {
                let side = if side == parallax_interop::Side::Left { "left" } else { "right" };
                let _ = write!(out, "\n  intrinsics: the {side} camera of the stereo calibration");
            }
            out
        }
        crate::poses::Intrinsics::Visp(cam) => format!(
            "  ViSP intrinsics {}: px {} py {} u0 {} v0 {} kud {} (→ k1) kdu {}",
            cam.projection.visp_name(),
            cam.px,
            cam.py,
            cam.u0,
            cam.v0,
            cam.kud,
            cam.kdu
        ),
    }
}

/// One station of [`crate::poses::camera_poses_from_images`]: points found and the pose's
/// RMS reprojection error, or that it was skipped.
pub fn station(s: &crate::poses::StationImage<'_>) -> String {
    match s.found {
        Some((n, rms)) => {
            format!("  {}: {n} points of the target found, pose RMS reprojection {rms:.3} px", s.path.display())
        }
        None => format!("  {}: target not found, station skipped", s.path.display()),
    }
}

/// Number of measured points flagged behind a camera, with low parallax or with a reprojection
/// error above the threshold.
pub fn flagged(m: &Measurement) -> usize {
    m.points.iter().filter(|p| p.behind_camera || p.low_parallax || p.high_reprojection).count()
}

/// A measurement as a table: one row per point (pixels, `X, Y, Z` in the left camera frame,
/// their 1σ, reprojection error, parallax, flags), then every distance with its σ.
pub fn measurement_table(m: &Measurement) -> String {
    let mut out = String::from("points (left camera frame; ± = 1σ from pixel noise):\n");
    let _ = writeln!(
        out,
        "{:>3}  {:>18}  {:>18}  {:>28}  {:>26}  {:>8}  {:>8}  flags",
        "#", "left px", "right px", "X, Y, Z", "σX, σY, σZ", "reproj", "parallax"
    );
    for p in &m.points {
        let flags: Vec<&str> = [
            (p.behind_camera, "BEHIND-CAMERA"),
            (p.low_parallax, "LOW-PARALLAX"),
            (p.high_reprojection, "HIGH-REPROJECTION"),
        ]
        .iter()
        .filter(|f| f.0)
        .map(|f| f.1)
        .collect();
        let sd = |f: fn(glam::DVec3) -> f64| p.std_dev.map_or(f64::NAN, f);
        let _ = writeln!(
            out,
            "{:>3}  {:>8.2},{:>8.2}  {:>8.2},{:>8.2}  {:>9.3},{:>9.3},{:>9.3}  {:>8.4},{:>8.4},{:>8.4}  {:>6.3}px  {:>7.3}°  {}",
            p.index,
            p.left.x,
            p.left.y,
            p.right.x,
            p.right.y,
            p.point.x,
            p.point.y,
            p.point.z,
            sd(|s| s.x),
            sd(|s| s.y),
            sd(|s| s.z),
            p.reprojection_error,
            p.parallax_deg,
            flags.join(" ")
        );
    }
    if !m.distances.is_empty() {
        out.push_str("distances:\n");
        for d in &m.distances {
            let _ = match d.std_dev {
                Some(s) => writeln!(out, "  {:>3} – {:<3} {:>12.4} ± {s:.4}", d.from, d.to, d.distance),
                None => writeln!(
                    out,
                    "  {:>3} – {:<3} {:>12.4} ± n/a (no covariance: a point behind a camera?)",
                    d.from, d.to, d.distance
                ),
            };
        }
    }
    finish(out)
}

/// The summary line and `key: value` lines of a measurement: `points`, `distances`,
/// `distance_I_J` per distance, `worst_reprojection_px`, `flagged`.
pub fn measurement_keys(m: &Measurement) -> String {
    let worst = m.points.iter().map(|p| p.reprojection_error).fold(0.0, f64::max);
    let n = flagged(m);
    let mut out = format!(
        "summary: {} points, {} distances, worst RMS reprojection error {:.3} px, {n} flagged\n",
        m.points.len(),
        m.distances.len(),
        worst
    );
    let _ = writeln!(out, "points: {}\ndistances: {}", m.points.len(), m.distances.len());
    for d in &m.distances {
        let _ = writeln!(out, "distance_{}_{}: {:.6}", d.from, d.to, d.distance);
    }
    let _ = write!(out, "worst_reprojection_px: {worst:.6}\nflagged: {n}");
    out
}

/// The `key: value` lines of a rectification: `focal_px`, the principal points, the rectified
/// baseline, `vertical`, and both valid regions (`roi_left_x` …).
pub fn rectification_keys(rect: &parallax_stereo_rectify::Rectification) -> String {
    let (p1, p2) = (rect.p1.rows, rect.p2.rows);
    let mut out = format!("focal_px: {:.6}\n", rect.focal());
    let _ = writeln!(out, "principal_point_left_u: {:.6}\nprincipal_point_left_v: {:.6}", p1[0][2], p1[1][2]);
    let _ = writeln!(out, "principal_point_right_u: {:.6}\nprincipal_point_right_v: {:.6}", p2[0][2], p2[1][2]);
    let _ = writeln!(out, "rectified_baseline: {:.6}\nvertical: {}", rect.rectified_baseline(), rect.vertical);
    for (name, roi) in [("roi_left", rect.roi1), ("roi_right", rect.roi2)] {
        let _ = writeln!(out, "{name}_x: {}\n{name}_y: {}", roi.x, roi.y);
        let _ = writeln!(out, "{name}_width: {}\n{name}_height: {}", roi.width, roi.height);
    }
    finish(out)
}

/// The block matcher's rejection counts by reason and the returned density, in one line.
pub fn match_stats(stats: &parallax_block_matching::MatchStats) -> String {
    format!(
        "rejected: {} no candidate, {} low texture, {} not unique, {} left-right, {} low confidence, {} speckle; \
         {} filled; returned map density {:.2} %{}",
        stats.no_candidate,
        stats.low_texture,
        stats.not_unique,
        stats.lr_inconsistent,
        stats.low_confidence,
        stats.speckle,
        stats.filled,
        100.0 * stats.density,
        if stats.filled > 0 { " (filled pixels are guesses)" } else { "" }
    )
}

/// The `key: value` lines of a disparity map (the output contract of `disparity`): with an
/// evaluation `evaluated … rms`, `bad1`, `bad2` (missing = bad), `bad2_returned` and `density`
/// over the mask, then `bad2_overlap` (missing = bad) and `density_overlap` over the mask's
/// pixels in the columns where OpenCV's matchers also answer (`overlap`, see
/// [`parallax_block_matching::evaluate_overlap`]; `NaN` when no evaluated pixel lies there);
/// else `density` of the map; then the rejections by reason (`rejected_texture`,
/// `rejected_uniqueness`, `rejected_lr`, `rejected_confidence`, `rejected_speckle`,
/// `rejected_no_candidate`: no candidate disparity inside the right image) and `filled` in
/// percent of the image, `seconds` and `mdes` (million disparity evaluations per second).
pub fn disparity_keys(
    stats: &parallax_block_matching::MatchStats,
    evaluation: Option<&parallax_block_matching::Evaluation>,
    overlap: Option<&parallax_block_matching::Evaluation>,
    seconds: f64,
    mdes: f64,
) -> String {
    let mut out = String::new();
    match evaluation {
        Some(e) => {
            let _ = writeln!(out, "evaluated {} px, rms {:.3} px", e.evaluated, e.rms);
            let _ = writeln!(out, "bad1: {:.2}", e.bad_at(1.0).unwrap_or(f64::NAN));
            let _ = writeln!(out, "bad2: {:.2}", e.bad_at(2.0).unwrap_or(f64::NAN));
            let _ = writeln!(out, "bad2_returned: {:.2}", e.bad_returned_at(2.0).unwrap_or(f64::NAN));
            let _ = writeln!(out, "density: {:.2}", e.density);
            let _ = writeln!(out, "bad2_overlap: {:.2}", overlap.and_then(|o| o.bad_at(2.0)).unwrap_or(f64::NAN));
            let _ = writeln!(out, "density_overlap: {:.2}", overlap.map_or(f64::NAN, |o| o.density));
        }
        None => {
            let _ = writeln!(out, "density: {:.2}", 100.0 * stats.density);
        }
    }
    for (key, n) in [
        ("rejected_texture", stats.low_texture),
        ("rejected_uniqueness", stats.not_unique),
        ("rejected_lr", stats.lr_inconsistent),
        ("rejected_confidence", stats.low_confidence),
        ("rejected_speckle", stats.speckle),
        ("rejected_no_candidate", stats.no_candidate),
        ("filled", stats.filled),
    ] {
        let _ = writeln!(out, "{key}: {:.2}", stats.percent(n));
    }
    let _ = write!(out, "seconds: {seconds:.6}\nmdes: {mdes:.0}");
    out
}

/// The rig's output contract: one `camera:` line per camera (`camera: I lens: NAME fx: fy: cx:
/// cy: rms:`), one `extrinsic:` line per camera `I ≥ 1` (`camI_from_cam0`: translation in the
/// target's unit, rotation vector in radians, `sigma_t` the 1σ of the translation's norm,
/// `sigma_r` of the rotation angle in degrees), then the rig's `rms:`.
pub fn rig_keys(r: &parallax_planar_calibration::RigCalibrationResult) -> String {
    let mut out = String::new();
    for (i, (c, rms)) in r.cameras.iter().zip(&r.camera_rms_px).enumerate() {
        let k = c.intrinsics;
        let _ = writeln!(
            out,
            "camera: {i} lens: {} fx: {:.6} fy: {:.6} cx: {:.6} cy: {:.6} rms: {rms:.6}",
            c.lens_model(),
            k.fx,
            k.fy,
            k.cx,
            k.cy
        );
    }
    for (i, (e, s)) in r.cam_from_cam0.iter().zip(&r.extrinsic_std_devs).enumerate().skip(1) {
        let (t, w) = (e.translation, e.rvec());
        let _ = writeln!(
            out,
            "extrinsic: {i} tx: {:.6} ty: {:.6} tz: {:.6} rx: {:.8} ry: {:.8} rz: {:.8} sigma_t: {:.6} sigma_r: {:.6}",
            t.x,
            t.y,
            t.z,
            w.x,
            w.y,
            w.z,
            s.baseline,
            s.angle_rad.to_degrees()
        );
    }
    let _ = writeln!(out, "rms: {:.6}", r.rms_px);
    finish(out)
}

/// The frames × cameras visibility matrix (`x` = the camera saw the target in that frame),
/// one line per frame with its name.
pub fn visibility(names: &[String], r: &parallax_planar_calibration::RigCalibrationResult) -> String {
    let n = r.cameras.len();
    let width = names.iter().map(String::len).max().unwrap_or(5).max(5);
    let mut out = format!("{:<width$} {}\n", "frame", (0..n).map(|i| format!("{i:>3}")).collect::<String>());
    for (name, row) in names.iter().zip(r.visibility()) {
        let marks: String = row.iter().map(|&v| if v { "  x" } else { "  ." }).collect();
        let _ = writeln!(out, "{name:<width$} {marks}");
    }
    finish(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};
    use parallax_camera_model::{Distortion, Intrinsics, Isometry3, StereoRig};

    fn cam() -> Camera {
        Camera::new(
            Intrinsics::new(800.0, 801.5, 320.25, 240.0),
            Distortion::new(-0.1, 0.02, 0.001, 0.0, 0.0),
            640,
            480,
        )
        .unwrap()
    }

    #[test]
    fn camera_lines_carry_the_values_and_their_deviations() {
        let s = IntrinsicStdDevs { fx: Some(0.5), ..Default::default() };
        let text = camera("left", &cam(), &s);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "left: 640x480");
        assert_eq!(lines[1], "  fx 800.000000 ± 0.500000  fy 801.500000 (fixed)");
        assert_eq!(lines.len(), 5, "no k4..k6 line for a plain model: {text}");
        let keys = camera_keys("right_", 0.25, &cam());
        assert!(keys.starts_with("right_rms_px: 0.250000\nright_fx: 800.000000\n"), "{keys}");
        assert!(keys.ends_with("right_p1: 0.00100000\nright_p2: 0.00000000\nright_k3: 0.00000000"), "{keys}");
    }

    #[test]
    fn a_measurement_table_lists_points_and_the_distance_between_them() {
        let c = cam();
        let rig = StereoRig::new(c, c, Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-100.0, 0.0, 0.0))).unwrap();
        let (a, b) = (DVec3::new(0.0, 0.0, 1000.0), DVec3::new(50.0, 0.0, 1000.0));
        let pix = |p: DVec3| -> (DVec2, DVec2) {
            (rig.left.project(p).unwrap(), rig.right.project(rig.right_from_left.transform_point(p)).unwrap())
        };
        let m = crate::measure(&rig, None, &[pix(a), pix(b)], &Default::default()).unwrap();
        let table = measurement_table(&m);
        assert_eq!(table.lines().count(), 2 + 2 + 2, "{table}");
        let keys = measurement_keys(&m);
        assert!(keys.contains("points: 2\ndistances: 1\ndistance_0_1: 50.000000\n"), "{keys}");
        assert!(keys.ends_with("flagged: 0"), "{keys}");
        assert_eq!(flagged(&m), 0);
    }

    #[test]
    fn disparity_keys_follow_the_output_contract() {
        let stats = parallax_block_matching::MatchStats {
            pixels: 200,
            low_texture: 20,
            speckle: 10,
            filled: 0,
            density: 0.85,
            ..Default::default()
        };
        let keys = disparity_keys(&stats, None, None, 0.0125, 2345.6);
        let lines: Vec<&str> = keys.lines().collect();
        assert_eq!(lines[0], "density: 85.00");
        assert_eq!(lines[1], "rejected_texture: 10.00");
        assert_eq!(lines[5], "rejected_speckle: 5.00");
        assert_eq!(lines[6], "rejected_no_candidate: 0.00");
        assert_eq!(&lines[7..], ["filled: 0.00", "seconds: 0.012500", "mdes: 2346"]);
        assert!(match_stats(&stats).ends_with("returned map density 85.00 %"), "{}", match_stats(&stats));
    }

    #[test]
    fn the_evaluation_keys_keep_their_lines_and_add_the_overlap_ones() {
        let stats = parallax_block_matching::MatchStats { pixels: 12, no_candidate: 3, ..Default::default() };
        let e = parallax_block_matching::Evaluation {
            evaluated: 10,
            bad: vec![(1.0, 60.0), (2.0, 50.0)],
            bad_returned: vec![(1.0, 50.0), (2.0, 37.5)],
            density: 80.0,
            rms: 2.5,
        };
        let o = parallax_block_matching::Evaluation { bad: vec![(2.0, 50.0)], density: 500.0 / 6.0, ..e.clone() };
        let keys = disparity_keys(&stats, Some(&e), Some(&o), 1.0, 1.0);
        let lines: Vec<&str> = keys.lines().collect();
        assert_eq!(
            &lines[..7],
            [
                "evaluated 10 px, rms 2.500 px",
                "bad1: 60.00",
                "bad2: 50.00",
                "bad2_returned: 37.50",
                "density: 80.00",
                "bad2_overlap: 50.00",
                "density_overlap: 83.33"
            ]
        );
        assert!(keys.contains("\nrejected_no_candidate: 25.00\n"), "{keys}");
        // no pixel to compare in the overlap: NaN, never 0
        let keys = disparity_keys(&stats, Some(&e), None, 1.0, 1.0);
        assert!(keys.contains("\nbad2_overlap: NaN\ndensity_overlap: NaN\n"), "{keys}");
    }
}
