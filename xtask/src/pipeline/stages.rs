//! The pipeline's stages, each compared with the scene's ground truth.

use std::path::Path;

use anyhow::Context;
use glam::{DVec2, DVec3};
use parallax_camera_model::{Chessboard, CornerGrid, DisparityMap, Isometry3, StereoRig};
use parallax_synthetic::{RenderOptions, SceneDescription};
use rayon::prelude::*;

use super::Corruption;
use super::report::Report;
use crate::util;

const STEPS: usize = 8;

fn progress(step: usize, what: &str) {
    eprintln!("[{step}/{STEPS}] {what}…");
}

/// Rendered and detected views of the stereo calibration session.
struct Session {
    /// Left and right true corners per view.
    truth: Vec<[Vec<DVec2>; 2]>,
    /// Left and right detections per view.
    found: Vec<[Option<CornerGrid>; 2]>,
    /// The first view's images (for overlays and the rectified pair).
    first: Option<[image::GrayImage; 2]>,
}

fn render_opts(base: &RenderOptions, seed: u64) -> RenderOptions {
    RenderOptions { seed, ..*base }
}

fn detect(img: &image::GrayImage, board: &Chessboard) -> anyhow::Result<Option<CornerGrid>> {
    parallax_corner_detection::find_chessboard(
        img,
        board.cols,
        board.rows,
        &parallax_corner_detection::ChessboardConfig::default(),
    )
    .context("corner detection")
}

/// Renders a stereo view of the board at `left_from_board` and detects it in both images.
fn stereo_view(
    rig: &StereoRig,
    board: &Chessboard,
    left_from_board: &Isometry3,
    opts: &RenderOptions,
    seed: u64,
) -> anyhow::Result<([parallax_synthetic::RenderedView; 2], [Option<CornerGrid>; 2])> {
    let l = parallax_synthetic::render_chessboard(&rig.left, board, left_from_board, &render_opts(opts, seed))?;
    let r = parallax_synthetic::render_chessboard(
        &rig.right,
        board,
        &(rig.right_from_left * *left_from_board),
        &render_opts(opts, seed ^ 0x5eed_0001),
    )?;
    let dl = detect(&l.image, board)?;
    let dr = detect(&r.image, board)?;
    Ok(([l, r], [dl, dr]))
}

fn rms(errors: impl IntoIterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for e in errors {
        s += e * e;
        n += 1;
    }
    if n == 0 { f64::NAN } else { (s / n as f64).sqrt() }
}

/// Runs every stage; returns the report (a stage that cannot run records a failing row and the
/// stages that depend on it are skipped with a note).
pub fn run_all(
    name: &str,
    scene: &SceneDescription,
    out: &Path,
    corrupt: Option<Corruption>,
) -> anyhow::Result<Report> {
    let mut report = Report { scene: name.to_string(), ..Report::default() };
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let tol = &scene.tolerances;
    let rig_true = scene.rig;
    let board = scene.board;
    let unit = "mm";

    // 1. Render the stereo calibration session.
    progress(1, "rendering and detecting the stereo calibration session");
    let poses = scene.stereo_poses()?;
    let rendered: Vec<_> = poses
        .par_iter()
        .enumerate()
        .map(|(i, p)| stereo_view(&rig_true, &board, p, &scene.render, scene.render.seed.wrapping_add(1000 + i as u64)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut session = Session { truth: Vec::new(), found: Vec::new(), first: None };
    for (i, (views, found)) in rendered.into_iter().enumerate() {
        session.truth.push([views[0].corners.clone(), views[1].corners.clone()]);
        session.found.push(found);
        if i == 0 {
            let [l, r] = views;
            session.first = Some([l.image, r.image]);
        }
    }
    if corrupt == Some(Corruption::SwapStereo) {
        for f in &mut session.found {
            f.swap(0, 1);
        }
        report.note("corruption", "left and right images of the calibration session swapped");
    }

    // 2. Corners against truth.
    progress(2, "checking corners against truth");
    let total = 2 * session.found.len();
    let found = session.found.iter().flatten().filter(|g| g.is_some()).count();
    report.at_least("corners", "boards found", found as f64, total as f64, "images");
    let corner_errors: Vec<f64> = session
        .found
        .iter()
        .zip(&session.truth)
        .flat_map(|(f, t)| {
            (0..2).flat_map(move |k| match &f[k] {
                Some(g) => g.corners.iter().zip(&t[k]).map(|(a, b)| (*a - *b).length()).collect::<Vec<_>>(),
                None => Vec::new(),
            })
        })
        .collect();
    report.at_most("corners", "corner RMS error", rms(corner_errors.iter().copied()), tol.corner_rms_px, "px");
    if let (Some([l, _]), Some(g)) = (&session.first, &session.found[0][0]) {
        util::save_png(&out.join("corners-left-0.png"), &parallax_corner_detection::draw_chessboard(l, g))?;
        report.images.push(("corners-left-0.png".into(), "detected corners, left view 0".into()));
    }

    // 3. Stereo calibration.
    progress(3, "calibrating both cameras and the rig");
    let board_cal = match corrupt {
        Some(Corruption::SquareSize) => {
            report.note("corruption", "calibration given a square size 5 % larger than the rendered one");
            Chessboard { square_size: board.square_size * 1.05, ..board }
        }
        _ => board,
    };
    let pairs: Vec<(CornerGrid, CornerGrid)> =
        session.found.iter().filter_map(|[l, r]| Some((l.clone()?, r.clone()?))).collect();
    let (lgrids, rgrids): (Vec<_>, Vec<_>) = pairs.into_iter().unzip();
    let size = (rig_true.left.width, rig_true.left.height);
    let stereo = match parallax_planar_calibration::calibrate_stereo_chessboard(
        &board_cal,
        &lgrids,
        &rgrids,
        size,
        (rig_true.right.width, rig_true.right.height),
        &parallax_planar_calibration::StereoConfig::default(),
    ) {
        Ok(s) => s,
        Err(e) => {
            report.at_most("calibration", &format!("stereo calibration failed: {e}"), f64::NAN, 0.0, "");
            return Ok(report);
        }
    };
    util::write_ron(&out.join("calibration.ron"), &stereo)?;
    let rig = stereo.rig;
    let focal_err = [
        (rig.left.intrinsics.fx, rig_true.left.intrinsics.fx),
        (rig.left.intrinsics.fy, rig_true.left.intrinsics.fy),
        (rig.right.intrinsics.fx, rig_true.right.intrinsics.fx),
        (rig.right.intrinsics.fy, rig_true.right.intrinsics.fy),
    ]
    .iter()
    .map(|(e, t)| 100.0 * (e - t).abs() / t)
    .fold(0.0, f64::max);
    report.at_most("calibration", "focal length error (worst of 4)", focal_err, tol.focal_error_pct, "%");
    let pp_err = [(rig.left, rig_true.left), (rig.right, rig_true.right)]
        .iter()
        .map(|(e, t)| DVec2::new(e.intrinsics.cx - t.intrinsics.cx, e.intrinsics.cy - t.intrinsics.cy).length())
        .fold(0.0, f64::max);
    report.at_most("calibration", "principal point error (worst)", pp_err, tol.principal_point_px, "px");
    report.at_most("calibration", "stereo RMS reprojection error", stereo.rms_px, tol.reprojection_rms_px, "px");
    let baseline_err = (rig.right_from_left.translation - rig_true.right_from_left.translation).length();
    report.at_most("calibration", "baseline vector error", baseline_err, tol.baseline_error, unit);
    let (rot_err, _) = rig.right_from_left.distance(&rig_true.right_from_left);
    report.at_most("calibration", "rig rotation error", rot_err.to_degrees(), tol.rig_rotation_deg, "deg");
    report.note(
        "calibration",
        format!(
            "{} stereo views; left fx {:.3} (true {:.3}), right fx {:.3} (true {:.3}); baseline {:.4} {unit} ± {:.4} (true {:.4})",
            lgrids.len(),
            rig.left.intrinsics.fx,
            rig_true.left.intrinsics.fx,
            rig.right.intrinsics.fx,
            rig_true.right.intrinsics.fx,
            rig.baseline(),
            stereo.rig_std_devs.baseline,
            rig_true.baseline()
        ),
    );

    // 4. Rectification.
    progress(4, "rectifying");
    let rect_cfg = parallax_stereo_rectify::RectifyConfig::default();
    let rect = parallax_stereo_rectify::stereo_rectify(&rig, &rect_cfg)?;
    let rect_true = parallax_stereo_rectify::stereo_rectify(&rig_true, &rect_cfg)?;
    util::write_ron(&out.join("rectification.ron"), &rect)?;
    let dv = util::rectified_abs_dv(&rig, &rect, &lgrids, &rgrids)?;
    let mean_dv = if dv.is_empty() { f64::NAN } else { dv.iter().sum::<f64>() / dv.len() as f64 };
    report.at_most("rectification", "mean |Δv| of detected corners", mean_dv, tol.rectification_dv_px, "px");
    if let Some([l, r]) = &session.first {
        let rectifier = parallax_stereo_rectify::Rectifier::from_rectification(&rig, rect)?;
        let (rl, rr) = rectifier.rectify_pair(l, r, parallax_stereo_rectify::Border::Constant(image::Luma([0u8])))?;
        util::save_png(&out.join("rectified-pair.png"), &side_by_side(&rl, &rr))?;
        report.images.push(("rectified-pair.png".into(), "rectified calibration view 0 (lines every 40 px)".into()));
    }

    // 5. Block matching on the rendered stereo scene (seen by the rectified rig).
    progress(5, "block matching the rendered stereo scene");
    let stereo_scene = parallax_synthetic::render_stereo_scene(&scene.stereo_scene)?;
    let matcher_cfg = parallax_block_matching::MatcherConfig {
        num_disparities: (scene.stereo_scene.max_disparity.ceil() as usize + 16) & !15,
        ..parallax_block_matching::MatcherConfig::default()
    };
    let mut matcher = parallax_block_matching::BlockMatcher::new(matcher_cfg)?;
    let disparity = matcher.compute(&stereo_scene.left, &stereo_scene.right)?;
    let visible: Vec<bool> = stereo_scene.occluded.iter().map(|o| !o).collect();
    let eval = parallax_block_matching::evaluate(&disparity, &stereo_scene.disparity, Some(&visible), &[1.0, 2.0])?;
    let bad2 = eval.bad_at(2.0).unwrap_or(f64::NAN);
    report.at_most("disparity", "bad-2 (non-occluded, missing = bad)", bad2, tol.disparity_bad2_pct, "%");
    report.at_least("disparity", "density (non-occluded)", eval.density, tol.disparity_density_pct, "%");
    util::write_atomic(&out.join("disparity.pfm"), &parallax_block_matching::to_pfm(&disparity))?;
    util::save_png(&out.join("disparity.png"), &parallax_block_matching::false_colour(&disparity, None))?;
    util::save_png(&out.join("left-scene.png"), &stereo_scene.left)?;
    report.images.push(("left-scene.png".into(), "rendered stereo scene, left".into()));
    report.images.push(("disparity.png".into(), "disparity (false colour, black = invalid)".into()));

    // 6. Triangulation of the disparity map with the estimated rectification, against the
    // same map of true disparities through the true rectification.
    progress(6, "triangulating the disparity map");
    let q_est = parallax_triangulation::ReprojectionMatrix::new(rect.q)?;
    let q_true = parallax_triangulation::ReprojectionMatrix::new(rect_true.q)?;
    let cloud = parallax_triangulation::disparity_to_point_cloud(
        &disparity,
        &q_est,
        &parallax_triangulation::CloudConfig::default(),
        Some(parallax_triangulation::PixelColors::Grey(stereo_scene.left.as_raw())),
    )?;
    parallax_triangulation::write_ply(
        &out.join("cloud.ply"),
        &cloud,
        parallax_triangulation::PlyFormat::BinaryLittleEndian,
    )?;
    let rel_depth = relative_depth_errors(&disparity, &stereo_scene.disparity, &visible, &q_est, &q_true);
    report.at_most(
        "triangulation",
        "median relative depth error of the cloud",
        median(rel_depth),
        tol.cloud_depth_error_pct,
        "%",
    );
    report.note(
        "triangulation",
        format!("{} points written to cloud.ply ({} invalid pixels skipped)", cloud.len(), cloud.skipped_invalid),
    );

    // 7. Four target points measured by the rig (Table 3), then hand-eye.
    progress(7, "measuring four targets and calibrating hand-eye");
    let traj_cfg = parallax_synthetic::TrajectoryConfig { rot_noise_rad: 0.0, trans_noise: 0.0, ..scene.trajectory };
    let traj = parallax_synthetic::hand_eye_trajectory(&traj_cfg)?;
    let mut noise = parallax_synthetic::rng(scene.trajectory.seed ^ 0xa11ce);
    let robot: Vec<Isometry3> = traj
        .base_from_gripper
        .iter()
        .map(|p| {
            parallax_synthetic::perturb_pose(
                p,
                scene.trajectory.rot_noise_rad,
                scene.trajectory.trans_noise,
                &mut noise,
            )
        })
        .collect();
    // Camera poses from the project's own corners and calibration (left camera).
    let station_views: Vec<_> = traj
        .camera_from_board
        .par_iter()
        .enumerate()
        .map(|(i, p)| stereo_view(&rig_true, &board, p, &scene.render, scene.render.seed.wrapping_add(5000 + i as u64)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut bfg = Vec::new();
    let mut cfb = Vec::new();
    let (mut pose_rot_err, mut pose_trans_err) = (0.0f64, 0.0f64);
    for (i, (_, found)) in station_views.iter().enumerate() {
        if let Some(g) = &found[0] {
            let (pose, _) = parallax_planar_calibration::solve_pnp_planar(&rig.left, &board_cal, &g.corners)?;
            let (r, t) = pose.distance(&traj.camera_from_board[i]);
            pose_rot_err = pose_rot_err.max(r.to_degrees());
            pose_trans_err = pose_trans_err.max(t);
            bfg.push(robot[i]);
            cfb.push(pose);
        }
    }
    report.at_least(
        "hand-eye",
        "stations with the board found",
        cfb.len() as f64,
        traj.base_from_gripper.len() as f64,
        "stations",
    );
    report.note(
        "hand-eye",
        format!(
            "camera_from_board by PnP: worst error {pose_rot_err:.4} deg, {pose_trans_err:.4} {unit} over {} stations",
            cfb.len()
        ),
    );
    let setup =
        if traj.eye_in_hand { parallax_hand_eye::Setup::EyeInHand } else { parallax_hand_eye::Setup::EyeToHand };
    // Noise model of the refinement in the scene's units: the robot's from the scene, the camera
    // poses (from PnP on detected corners) taken as no better than the robot's.
    let sigma_deg = scene.trajectory.rot_noise_rad.to_degrees().max(1e-3);
    let sigma_t = scene.trajectory.trans_noise.max(1e-3 * board.square_size);
    let refine = parallax_hand_eye::RefineConfig {
        robot_rotation_sigma_deg: sigma_deg,
        robot_translation_sigma: sigma_t,
        camera_rotation_sigma_deg: sigma_deg,
        camera_translation_sigma: sigma_t,
        ..parallax_hand_eye::RefineConfig::default()
    };
    let he_cfg = parallax_hand_eye::HandEyeConfig { setup, refine, ..parallax_hand_eye::HandEyeConfig::default() };
    let solution = parallax_hand_eye::calibrate(&bfg, &cfb, parallax_hand_eye::Method::Refined, &he_cfg)?;
    util::write_ron(&out.join("handeye.ron"), &solution)?;
    let truth_x = if traj.eye_in_hand { traj.truth.gripper_from_camera } else { traj.truth.base_from_camera };
    let (he_rot, he_trans) = solution.transform.distance(&truth_x);
    report.at_most("hand-eye", "rotation error", he_rot.to_degrees(), tol.handeye_rot_deg, "deg");
    report.at_most("hand-eye", "translation error", he_trans, tol.handeye_trans, unit);

    // The measurement station: the first one whose board both cameras saw.
    let targets = [(0, 0), (board.cols - 1, 0), (board.cols - 1, board.rows - 1), (0, board.rows - 1)];
    let station = station_views.iter().position(|(_, f)| f[0].is_some() && f[1].is_some());
    let Some(k) = station else {
        report.at_least("measurement", "a station with the board in both cameras", 0.0, 1.0, "stations");
        return Ok(report);
    };
    let [Some(gl), Some(gr)] = &station_views[k].1 else { unreachable!("checked above") };
    let pairs: Vec<(DVec2, DVec2)> = targets.iter().map(|&(c, r)| (gl.at(c, r), gr.at(c, r))).collect();
    let tri_cfg = parallax_triangulation::TriangulationConfig { pixel_sigma: stereo.sigma_px, ..Default::default() };
    let measurement = parallax_triangulation::measure_stereo(&rig, &pairs, &tri_cfg)?;
    util::write_ron(&out.join("measurement.ron"), &measurement)?;
    let true_cam: Vec<DVec3> =
        targets.iter().map(|&(c, r)| traj.camera_from_board[k].transform_point(board.point(c, r))).collect();
    let point_err = measurement.points.iter().zip(&true_cam).map(|(m, t)| (m.point - *t).length()).fold(0.0, f64::max);
    report.at_most("measurement", "target 3D error (worst of 4, camera frame)", point_err, tol.point_error, unit);
    let dist_err = measurement
        .distances
        .iter()
        .map(|d| {
            let (a, b) = (targets[d.from], targets[d.to]);
            let truth = (board.point(a.0, a.1) - board.point(b.0, b.1)).length();
            (d.distance - truth).abs()
        })
        .fold(0.0, f64::max);
    report.at_most("measurement", "target distance error (worst of 6)", dist_err, tol.distance_error, unit);
    for d in &measurement.distances {
        report.note(
            "measurement",
            format!("target {} – {}: {:.3} ± {:.3} {unit}", d.from + 1, d.to + 1, d.distance, d.std_dev),
        );
    }

    // 8. The targets in the robot base frame.
    progress(8, "expressing the targets in the robot base frame");
    let measured_cam: Vec<DVec3> = measurement.points.iter().map(|m| m.point).collect();
    let (est_base, true_base): (Vec<DVec3>, Vec<DVec3>) = if traj.eye_in_hand {
        (
            parallax_hand_eye::points_to_base(&robot[k], &solution.transform, &measured_cam),
            parallax_hand_eye::points_to_base(&traj.base_from_gripper[k], &traj.truth.gripper_from_camera, &true_cam),
        )
    } else {
        (
            measured_cam.iter().map(|p| solution.transform.transform_point(*p)).collect(),
            true_cam.iter().map(|p| traj.truth.base_from_camera.transform_point(*p)).collect(),
        )
    };
    let base_err = est_base.iter().zip(&true_base).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    report.at_most("robot frame", "target error in the base frame (worst of 4)", base_err, tol.base_point_error, unit);
    for (i, p) in est_base.iter().enumerate() {
        report.note("robot frame", format!("target {} in base: ({:.2}, {:.2}, {:.2}) {unit}", i + 1, p.x, p.y, p.z));
    }
    Ok(report)
}

/// |Z_est − Z_true| / Z_true in percent over the visible pixels that have both disparities.
fn relative_depth_errors(
    est: &DisparityMap,
    truth: &DisparityMap,
    visible: &[bool],
    q_est: &parallax_triangulation::ReprojectionMatrix,
    q_true: &parallax_triangulation::ReprojectionMatrix,
) -> Vec<f64> {
    let mut out = Vec::new();
    for v in 0..est.height {
        for u in 0..est.width {
            if !visible[v * est.width + u] {
                continue;
            }
            let (Some(de), Some(dt)) = (est.get(u, v), truth.get(u, v)) else { continue };
            let (Ok(pe), Ok(pt)) = (
                q_est.reproject(u as f64, v as f64, f64::from(de)),
                q_true.reproject(u as f64, v as f64, f64::from(dt)),
            ) else {
                continue;
            };
            out.push(100.0 * (pe.z - pt.z).abs() / pt.z);
        }
    }
    out
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Two images side by side with horizontal lines every 40 px, so alignment can be judged by eye.
fn side_by_side(l: &image::GrayImage, r: &image::GrayImage) -> image::RgbImage {
    let (w, h) = (l.width() + r.width(), l.height().max(r.height()));
    let mut img = image::RgbImage::new(w, h);
    for (x, y, p) in l.enumerate_pixels() {
        img.put_pixel(x, y, image::Rgb([p[0]; 3]));
    }
    for (x, y, p) in r.enumerate_pixels() {
        img.put_pixel(x + l.width(), y, image::Rgb([p[0]; 3]));
    }
    for y in (20..h).step_by(40) {
        for x in 0..w {
            img.put_pixel(x, y, image::Rgb([0, 200, 0]));
        }
    }
    img
}
