//! The synthetic run: render a scene with known truth, run the chain on the renders, score
//! every stage against the truth and the scene's tolerances.

use std::path::Path;

use glam::{DVec2, DVec3};
use parallax_camera_model::{CameraModel, Chessboard, DisparityMap, Isometry3};
use parallax_hand_eye::Setup;
use parallax_synthetic::{RenderOptions, SceneDescription};
use rayon::prelude::*;

use crate::chain::{ChainInput, ChainOutput, MatchPair, StageResult, Station, run_chain};
use crate::report::Report;
use crate::stats::{median, rms};
use crate::{Result, artifacts};

/// A deliberate corruption of one stage's input, to check that the pipeline notices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Corruption {
    /// Calibrate with a square size 5 % larger than the rendered one.
    SquareSize,
    /// Swap the left and right images of the stereo calibration session.
    SwapStereo,
}

/// Renders a stereo view of the board at `left_from_board` through `left` and `right`
/// (`right_from_left` apart): both images and their true corners.
fn render_stereo_view<C: CameraModel + Sync>(
    (left, right, right_from_left): (&C, &C, &Isometry3),
    board: &Chessboard,
    left_from_board: &Isometry3,
    opts: &RenderOptions,
    seed: u64,
) -> Result<[parallax_synthetic::RenderedView; 2]> {
    let l = parallax_synthetic::render_chessboard(left, board, left_from_board, &RenderOptions { seed, ..*opts })?;
    let r = parallax_synthetic::render_chessboard(
        right,
        board,
        &(*right_from_left * *left_from_board),
        &RenderOptions { seed: seed ^ 0x5eed_0001, ..*opts },
    )?;
    Ok([l, r])
}

/// Renders every pose through the scene's rig (any lens).
fn render_views(
    scene: &SceneDescription,
    poses: &[Isometry3],
    seed_offset: u64,
) -> Result<Vec<[parallax_synthetic::RenderedView; 2]>> {
    poses
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let seed = scene.render.seed.wrapping_add(seed_offset + i as u64);
            render_stereo_view(
                (&scene.rig.left, &scene.rig.right, &scene.rig.right_from_left),
                &scene.board,
                p,
                &scene.render,
                seed,
            )
        })
        .collect()
}

/// What the scene knows that the chain does not.
struct Truth {
    corners: Vec<[Vec<DVec2>; 2]>,
    stereo_disparity: DisparityMap,
    visible: Vec<bool>,
    trajectory: parallax_synthetic::Trajectory,
}

/// Renders `scene`, runs the chain, writes the artifacts and the report into `out`, and
/// returns the report scored against the truth.
pub fn run_scene(name: &str, scene: &SceneDescription, out: &Path, corrupt: Option<Corruption>) -> Result<Report> {
    let mut report = Report::new(name, &scene.unit);
    std::fs::create_dir_all(out).map_err(|source| crate::PipelineError::Io {
        what: "creating directory",
        path: out.to_path_buf(),
        source,
    })?;

    eprintln!("[0/8] rendering the calibration session, the stereo scene and the robot stations…");
    let session_poses = scene.stereo_poses()?;
    let session = render_views(scene, &session_poses, 1000)?;
    let rectify_config = parallax_stereo_rectify::RectifyConfig::default();
    let stereo = stereo_truth(scene, &rectify_config)?;
    let traj_cfg = parallax_synthetic::TrajectoryConfig { rot_noise_rad: 0.0, trans_noise: 0.0, ..scene.trajectory };
    let trajectory = parallax_synthetic::hand_eye_trajectory(&traj_cfg)?;
    let mut noise = parallax_synthetic::rng(scene.trajectory.seed ^ 0xa11ce);
    let robot: Vec<Isometry3> = trajectory
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
    let station_views = render_views(scene, &trajectory.camera_from_board, 5000)?;

    let board = match corrupt {
        Some(Corruption::SquareSize) => {
            report.note("corruption", "calibration given a square size 5 % larger than the rendered one");
            Chessboard { square_size: scene.board.square_size * 1.05, ..scene.board }
        }
        _ => scene.board,
    };
    let truth = Truth {
        corners: session.iter().map(|[l, r]| [l.corners.clone(), r.corners.clone()]).collect(),
        visible: stereo.visible,
        stereo_disparity: stereo.disparity,
        trajectory,
    };
    let mut calibration: Vec<[image::GrayImage; 2]> = session.into_iter().map(|[l, r]| [l.image, r.image]).collect();
    if corrupt == Some(Corruption::SwapStereo) {
        calibration.iter_mut().for_each(|v| v.swap(0, 1));
        report.note("corruption", "left and right images of the calibration session swapped");
    }
    let mut input = ChainInput::new(board, calibration);
    input.match_pair = Some(stereo.pair);
    input.rectify = rectify_config;
    input.stations = station_views
        .into_iter()
        .zip(&robot)
        .map(|([l, r], p)| Station { robot: Some(*p), left: l.image, right: Some(r.image) })
        .collect();
    input.setup = if truth.trajectory.eye_in_hand { Setup::EyeInHand } else { Setup::EyeToHand };
    // The lens models the scene was rendered through are the ones calibrated.
    input.stereo.left.lens = scene.rig.left.lens_model();
    input.stereo.right.lens = scene.rig.right.lens_model();
    input.matcher =
        parallax_block_matching::MatcherConfig { num_disparities: stereo.disparities, ..Default::default() };
    // Noise model of the refinement in the scene's units: the robot's from the scene (known here,
    // so not estimated), the camera poses (from PnP on detected corners) taken as no better than
    // the robot's.
    let sigma_deg = scene.trajectory.rot_noise_rad.to_degrees().max(1e-3);
    let sigma_t = scene.trajectory.trans_noise.max(1e-3 * scene.board.square_size);
    input.hand_eye = parallax_hand_eye::HandEyeConfig {
        setup: input.setup,
        refine: parallax_hand_eye::RefineConfig {
            robot_rotation_sigma_deg: sigma_deg,
            robot_translation_sigma: sigma_t,
            camera_rotation_sigma_deg: sigma_deg,
            camera_translation_sigma: sigma_t,
            estimate_translation_noise: false,
            ..Default::default()
        },
        ..Default::default()
    };

    let output = run_chain(&input)?;
    score(&mut report, scene, &truth, &output, &input);
    let mut files = crate::io::OutputSet::new();
    report.images = artifacts::add_artifacts(&mut files, out, &input, &output)?;
    let truth_disparity = crate::plots::disparity::DisparityTruth {
        disparity: &truth.stereo_disparity,
        mask: Some(&truth.visible),
        bad_threshold_px: 2.0,
    };
    report.sections = artifacts::pictures(&input, &output, None, Some(truth_disparity), &scene.unit);
    report.add_to(&mut files, out)?;
    files.commit()?;
    Ok(report)
}

/// A rig's rectification as the pair [`parallax_synthetic::world_truth_rectified`] takes.
pub fn rectified_pair(
    rig: &parallax_camera_model::StereoRig,
    rect: &parallax_stereo_rectify::Rectification,
) -> parallax_synthetic::RectifiedPair {
    parallax_synthetic::RectifiedPair {
        width: rect.width,
        height: rect.height,
        p1: rect.p1.rows,
        p2: rect.p2.rows,
        r1: rect.r1,
        right_centre: rig.right_from_left.inverse().translation,
    }
}

/// The pair the disparity stage matches and its truth.
struct StereoTruth {
    pair: MatchPair,
    disparity: DisparityMap,
    /// Pixels scored: not occluded (and, for a world, seen by the left camera).
    visible: Vec<bool>,
    /// Disparities searched: the largest true one rounded up past a multiple of 16.
    disparities: usize,
}

/// Renders the scene's stereo pair: the planar stereo scene, rectified as given; or the stereo
/// world through the scene's rig (raw images the chain rectifies with its own calibration), its
/// truth in the true rig's rectification under `rectify`.
fn stereo_truth(scene: &SceneDescription, rectify: &parallax_stereo_rectify::RectifyConfig) -> Result<StereoTruth> {
    let round_up = |max: f64| (max.ceil() as usize + 16) & !15;
    let Some(world) = &scene.stereo_world else {
        let s = parallax_synthetic::render_stereo_scene(&scene.stereo_scene)?;
        return Ok(StereoTruth {
            pair: MatchPair::Rectified(s.left, s.right),
            disparity: s.disparity,
            visible: s.occluded.iter().map(|o| !o).collect(),
            disparities: round_up(scene.stereo_scene.max_disparity),
        });
    };
    let rig = &scene.rig;
    let world = world.scaled(rig.baseline() / world.baseline);
    let (left, right) = parallax_synthetic::render_world_through(&world, rig)?;
    let rect = parallax_stereo_rectify::stereo_rectify(rig, rectify)?;
    let (disparity, occluded) = parallax_synthetic::world_truth_rectified(&world, &rectified_pair(rig, &rect))?;
    // a rectified pixel whose source lies outside either raw image is black, not scored
    let white = |c: &parallax_camera_model::Camera| image::GrayImage::from_pixel(c.width, c.height, image::Luma([255]));
    let (inside_left, inside_right) = crate::stages::rectify_images(rig, &rect, &white(&rig.left), &white(&rig.right))?;
    let w = rect.width as usize;
    let visible: Vec<bool> = (0..disparity.data().len())
        .map(|i| {
            let d = disparity.data()[i];
            let (u, v) = ((i % w) as f64, (i / w) as u32);
            let u_right = (u - f64::from(d)).round();
            d.is_finite()
                && !occluded[i]
                && inside_left.as_raw()[i] == 255
                && u_right >= 0.0
                && inside_right.get_pixel(u_right as u32, v).0[0] == 255
        })
        .collect();
    let largest = disparity.data().iter().copied().filter(|d| d.is_finite()).fold(0f32, f32::max);
    if largest <= 0.0 || disparity.data().iter().any(|d| d.is_finite() && *d <= 0.0) {
        return Err(crate::PipelineError::Input(format!(
            "the stereo world seen through the rig has disparities outside (0, {largest:.1}] px: every surface must lie \
             in front of both cameras"
        )));
    }
    Ok(StereoTruth {
        pair: MatchPair::Raw(left.to_luma8(), right.to_luma8()),
        disparity,
        visible,
        disparities: round_up(f64::from(largest)),
    })
}

/// Adds one failing row per figure of a stage that has no result, and a note saying why.
fn missing<T>(report: &mut Report, stage: &str, result: &StageResult<T>, figures: &[(&str, f64, &str, bool)]) {
    if let Err(e) = result {
        report.note(stage, e.to_string());
        for &(figure, tolerance, unit, at_most) in figures {
            if at_most {
                report.at_most(stage, figure, f64::NAN, tolerance, unit);
            } else {
                report.at_least(stage, figure, f64::NAN, tolerance, unit);
            }
        }
    }
}

fn score(report: &mut Report, scene: &SceneDescription, truth: &Truth, out: &ChainOutput, input: &ChainInput) {
    let tol = &scene.tolerances;
    let unit = scene.unit.clone();
    let unit = unit.as_str();
    let rig_true = scene.rig;
    let board = scene.board;

    // Corners.
    let total = 2 * out.detections.len();
    let found = out.detections.iter().flatten().filter(|g| g.is_some()).count();
    report.at_least("corners", "boards found", found as f64, total as f64, "images");
    let corner_errors = out.detections.iter().zip(&truth.corners).flat_map(|(f, t)| {
        (0..2).flat_map(move |k| match &f[k] {
            Some(g) => g.corners.iter().zip(&t[k]).map(|(a, b)| (*a - *b).length()).collect::<Vec<_>>(),
            None => Vec::new(),
        })
    });
    report.at_most("corners", "corner RMS error", rms(corner_errors), tol.corner_rms_px, "px");

    // Calibration.
    let calibration_figures = [
        ("focal length error (worst of 4)", tol.focal_error_pct, "%", true),
        ("principal point error (worst)", tol.principal_point_px, "px", true),
        ("stereo RMS reprojection error", tol.reprojection_rms_px, "px", true),
        ("baseline vector error", tol.baseline_error, unit, true),
        ("rig rotation error", tol.rig_rotation_deg, "deg", true),
    ];
    missing(report, "calibration", &out.calibration, &calibration_figures);
    // (fx, fy, cx, cy) of left and right, estimated and true; the rig's pose and baseline σ.
    let estimated = out.calibration.as_ref().ok().map(|c| {
        ([c.rig.left.intrinsics, c.rig.right.intrinsics], c.rig.right_from_left, c.rms_px, c.rig_std_devs.baseline)
    });
    let (true_k, true_pose) = ([rig_true.left.intrinsics, rig_true.right.intrinsics], rig_true.right_from_left);
    if let Some((k, pose, rms_px, baseline_sigma)) = estimated {
        let focal_err =
            [(k[0].fx, true_k[0].fx), (k[0].fy, true_k[0].fy), (k[1].fx, true_k[1].fx), (k[1].fy, true_k[1].fy)]
                .iter()
                .map(|(e, t)| 100.0 * (e - t).abs() / t)
                .fold(0.0, f64::max);
        report.at_most("calibration", "focal length error (worst of 4)", focal_err, tol.focal_error_pct, "%");
        let pp_err =
            k.iter().zip(&true_k).map(|(e, t)| DVec2::new(e.cx - t.cx, e.cy - t.cy).length()).fold(0.0, f64::max);
        report.at_most("calibration", "principal point error (worst)", pp_err, tol.principal_point_px, "px");
        report.at_most("calibration", "stereo RMS reprojection error", rms_px, tol.reprojection_rms_px, "px");
        let baseline_err = (pose.translation - true_pose.translation).length();
        report.at_most("calibration", "baseline vector error", baseline_err, tol.baseline_error, unit);
        let (rot_err, _) = pose.distance(&true_pose);
        report.at_most("calibration", "rig rotation error", rot_err.to_degrees(), tol.rig_rotation_deg, "deg");
        report.note(
            "calibration",
            format!(
                "{} stereo views; left fx {:.3} (true {:.3}), right fx {:.3} (true {:.3}); baseline {:.4} {unit} ± {:.4} (true {:.4})",
                out.views.len(),
                k[0].fx,
                true_k[0].fx,
                k[1].fx,
                true_k[1].fx,
                pose.translation.length(),
                baseline_sigma,
                true_pose.translation.length()
            ),
        );
    }
    if let Some(c) = out.calibration.as_ref().ok().filter(|c| c.rig.left.lens_model().is_wide()) {
        for (side, est, tru) in [("left", &c.rig.left, &rig_true.left), ("right", &c.rig.right, &rig_true.right)] {
            report.note(
                "calibration",
                format!(
                    "{side} lens ({}): {:.6?} (true {:.6?})",
                    parallax_interop::lens_model_name(&est.lens()),
                    est.lens().parameters(),
                    tru.lens().parameters()
                ),
            );
        }
    }

    // Rectification.
    let dv_figure = "mean |Δv| of detected corners";
    missing(report, "rectification", &out.rectified, &[(dv_figure, tol.rectification_dv_px, "px", true)]);
    if let Ok(r) = &out.rectified {
        report.at_most("rectification", dv_figure, r.mean_abs_dv(), tol.rectification_dv_px, "px");
    }

    // Disparity.
    let (bad_figure, density_figure) = ("bad-2 (non-occluded, missing = bad)", "density (non-occluded)");
    missing(
        report,
        "disparity",
        &out.matched,
        &[(bad_figure, tol.disparity_bad2_pct, "%", true), (density_figure, tol.disparity_density_pct, "%", false)],
    );
    if let Ok(m) = &out.matched {
        match parallax_block_matching::evaluate(
            &m.disparity,
            &truth.stereo_disparity,
            Some(&truth.visible),
            &[1.0, 2.0],
        ) {
            Ok(eval) => {
                let bad2 = eval.bad_at(2.0).unwrap_or(f64::NAN);
                report.at_most("disparity", bad_figure, bad2, tol.disparity_bad2_pct, "%");
                report.at_least("disparity", density_figure, eval.density, tol.disparity_density_pct, "%");
            }
            Err(e) => {
                report.note("disparity", format!("evaluation failed: {e}"));
                report.at_most("disparity", bad_figure, f64::NAN, tol.disparity_bad2_pct, "%");
                report.at_least("disparity", density_figure, f64::NAN, tol.disparity_density_pct, "%");
            }
        }
    }

    // Triangulation: the cloud through the estimated rectification against the true disparities
    // through the true rectification.
    let depth_figure = "median relative depth error of the cloud";
    missing(report, "triangulation", &out.cloud, &[(depth_figure, tol.cloud_depth_error_pct, "%", true)]);
    if let (Ok(cloud), Ok(m), Ok(r)) = (&out.cloud, &out.matched, &out.rectified) {
        let rect_true = parallax_stereo_rectify::stereo_rectify(&rig_true, &input.rectify);
        let errors = match rect_true {
            Ok(rt) => {
                relative_depth_errors(&m.disparity, &truth.stereo_disparity, &truth.visible, r.rectification.q, rt.q)
            }
            Err(_) => Vec::new(),
        };
        report.at_most("triangulation", depth_figure, median(errors), tol.cloud_depth_error_pct, "%");
        report.note(
            "triangulation",
            format!("{} points written to cloud.ply ({} invalid pixels skipped)", cloud.len(), cloud.skipped_invalid),
        );
    }

    // Hand-eye.
    let traj = &truth.trajectory;
    let stations_found = out.station_detections.iter().filter(|d| d[0].is_some()).count();
    report.at_least(
        "hand-eye",
        "stations with the board found",
        stations_found as f64,
        traj.base_from_gripper.len() as f64,
        "stations",
    );
    if let Ok(poses) = &out.station_poses {
        let (mut rot, mut trans, mut n) = (0.0f64, 0.0f64, 0);
        for (pose, t) in poses.iter().zip(&traj.camera_from_board) {
            if let Some(p) = pose {
                let (r, tr) = p.distance(t);
                rot = rot.max(r.to_degrees());
                trans = trans.max(tr);
                n += 1;
            }
        }
        report.note(
            "hand-eye",
            format!("camera_from_board by PnP: worst error {rot:.4} deg, {trans:.4} {unit} over {n} stations"),
        );
    }
    missing(
        report,
        "hand-eye",
        &out.hand_eye,
        &[("rotation error", tol.handeye_rot_deg, "deg", true), ("translation error", tol.handeye_trans, unit, true)],
    );
    let truth_x = if traj.eye_in_hand { traj.truth.gripper_from_camera } else { traj.truth.base_from_camera };
    if let Ok(he) = &out.hand_eye {
        let (r, t) = he.solution.transform.distance(&truth_x);
        report.at_most("hand-eye", "rotation error", r.to_degrees(), tol.handeye_rot_deg, "deg");
        report.at_most("hand-eye", "translation error", t, tol.handeye_trans, unit);
    }

    // Measurement of the four board corners at the first station seen by both cameras.
    let (point_figure, dist_figure) =
        ("target 3D error (worst of 4, camera frame)", "target distance error (worst of 6)");
    missing(
        report,
        "measurement",
        &out.measurement,
        &[(point_figure, tol.point_error, unit, true), (dist_figure, tol.distance_error, unit, true)],
    );
    let mut true_cam = Vec::new();
    if let Ok(m) = &out.measurement {
        true_cam = m
            .targets
            .iter()
            .map(|&(c, r)| traj.camera_from_board[m.station].transform_point(board.point(c, r)))
            .collect::<Vec<DVec3>>();
        let point_err =
            m.measurement.points.iter().zip(&true_cam).map(|(p, t)| (p.point - *t).length()).fold(0.0, f64::max);
        report.at_most("measurement", point_figure, point_err, tol.point_error, unit);
        let dist_err = m
            .measurement
            .distances
            .iter()
            .map(|d| {
                let (a, b) = (m.targets[d.from], m.targets[d.to]);
                (d.distance - (board.point(a.0, a.1) - board.point(b.0, b.1)).length()).abs()
            })
            .fold(0.0, f64::max);
        report.at_most("measurement", dist_figure, dist_err, tol.distance_error, unit);
        for d in &m.measurement.distances {
            report.note(
                "measurement",
                format!(
                    "target {} – {}: {:.3} ± {} {unit}",
                    d.from + 1,
                    d.to + 1,
                    d.distance,
                    d.std_dev.map_or_else(|| "n/a".to_string(), |s| format!("{s:.3}"))
                ),
            );
        }
    }

    // The measured corners in the robot base frame.
    let base_figure = "target error in the base frame (worst of 4)";
    missing(report, "robot frame", &out.robot_frame, &[(base_figure, tol.base_point_error, unit, true)]);
    if let (Ok(est), Ok(m)) = (&out.robot_frame, &out.measurement) {
        let k = m.station;
        let true_base: Vec<DVec3> = if traj.eye_in_hand {
            parallax_hand_eye::points_to_base(&traj.base_from_gripper[k], &traj.truth.gripper_from_camera, &true_cam)
        } else {
            true_cam.iter().map(|p| traj.truth.base_from_camera.transform_point(*p)).collect()
        };
        let err = est.iter().zip(&true_base).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        report.at_most("robot frame", base_figure, err, tol.base_point_error, unit);
        for (i, p) in est.iter().enumerate() {
            report
                .note("robot frame", format!("target {} in base: ({:.2}, {:.2}, {:.2}) {unit}", i + 1, p.x, p.y, p.z));
        }
    }
}

/// |Z_est − Z_true| / Z_true in percent over the visible pixels that have both disparities.
fn relative_depth_errors(
    est: &DisparityMap,
    truth: &DisparityMap,
    visible: &[bool],
    q_est: [[f64; 4]; 4],
    q_true: [[f64; 4]; 4],
) -> Vec<f64> {
    let (Ok(q_est), Ok(q_true)) = (
        parallax_triangulation::ReprojectionMatrix::new(q_est),
        parallax_triangulation::ReprojectionMatrix::new(q_true),
    ) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for v in 0..est.height() {
        for u in 0..est.width() {
            if !visible[v * est.width() + u] {
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
