//! `cargo xtask pipeline --real`: the same chain on the user's own data, without truth columns.
//!
//! stereo chessboard folder → corners → stereo calibration → rectification (corner |Δv|) →
//! block matching of a rectified pair → point cloud and adjacent-corner distances → (optional)
//! hand-eye from robot poses, one per calibration view, with the left camera's board poses.

use std::path::{Path, PathBuf};

use anyhow::{Context, ensure};
use parallax_camera_model::{Chessboard, CornerGrid};
use rayon::prelude::*;

use super::report::Report;
use crate::util;

/// Inputs of a real-data run.
pub struct RealInputs {
    /// Glob of the left chessboard images.
    pub left: String,
    /// Glob of the right chessboard images (same count and order).
    pub right: String,
    /// The board.
    pub board: Chessboard,
    /// The pair to block-match (left, right); the first calibration pair when absent.
    pub pair: Option<(PathBuf, PathBuf)>,
    /// Disparities to search.
    pub disparities: usize,
    /// Robot `base_from_gripper` poses (file or glob), one per calibration pair, in order.
    pub robot: Option<String>,
}

fn detect(path: &Path, board: &Chessboard) -> anyhow::Result<(image::GrayImage, Option<CornerGrid>)> {
    let img = util::load_gray(path)?;
    let grid = parallax_corner_detection::find_chessboard(&img, board.cols, board.rows, &Default::default())
        .with_context(|| format!("corner detection in {}", path.display()))?;
    Ok((img, grid))
}

/// Runs the chain; every figure goes to the report's notes (no truth, no tolerance).
pub fn run_real(inputs: &RealInputs, out: &Path) -> anyhow::Result<Report> {
    let mut report = Report { scene: "real".into(), ..Report::default() };
    let board = &inputs.board;
    let lp = util::expand_glob(&inputs.left)?;
    let rp = util::expand_glob(&inputs.right)?;
    ensure!(lp.len() == rp.len(), "{} left images but {} right images", lp.len(), rp.len());

    eprintln!("[1/6] detecting corners in {} pairs…", lp.len());
    let detected: Vec<_> = lp
        .par_iter()
        .zip(&rp)
        .map(|(l, r)| Ok((detect(l, board)?, detect(r, board)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let size = detected[0].0.0.dimensions();
    let mut kept = Vec::new();
    for (i, ((_, l), (_, r))) in detected.iter().enumerate() {
        match (l, r) {
            (Some(l), Some(r)) => kept.push((i, l.clone(), r.clone())),
            _ => report.note("corners", format!("board not found in both images of pair {}", lp[i].display())),
        }
    }
    report.note("corners", format!("board found in both images of {}/{} pairs", kept.len(), lp.len()));
    ensure!(kept.len() >= 3, "corners: only {} pairs with the board in both images (need 3)", kept.len());
    let lg: Vec<CornerGrid> = kept.iter().map(|k| k.1.clone()).collect();
    let rg: Vec<CornerGrid> = kept.iter().map(|k| k.2.clone()).collect();

    eprintln!("[2/6] calibrating the rig…");
    let stereo = parallax_planar_calibration::calibrate_stereo_chessboard(
        board,
        &lg,
        &rg,
        size,
        detected[0].1.0.dimensions(),
        &parallax_planar_calibration::StereoConfig::default(),
    )
    .context("stereo calibration")?;
    util::write_ron(&out.join("calibration.ron"), &stereo)?;
    let rig = stereo.rig;
    report.note(
        "calibration",
        format!(
            "RMS {:.4} px (left {:.4}, right {:.4}); left fx {:.3}, right fx {:.3}; baseline {:.4} ± {:.4}",
            stereo.rms_px,
            stereo.left_rms_px,
            stereo.right_rms_px,
            rig.left.intrinsics.fx,
            rig.right.intrinsics.fx,
            rig.baseline(),
            stereo.rig_std_devs.baseline
        ),
    );
    for w in &stereo.warnings {
        report.note("calibration", format!("warning: {w}"));
    }

    eprintln!("[3/6] rectifying…");
    let rect = parallax_stereo_rectify::stereo_rectify(&rig, &parallax_stereo_rectify::RectifyConfig::default())?;
    let dv = util::rectified_abs_dv(&rig, &rect, &lg, &rg)?;
    report.note(
        "rectification",
        format!("mean |Δv| of {} detected corners {:.4} px", dv.len(), dv.iter().sum::<f64>() / dv.len() as f64),
    );
    let (pl, pr) = match &inputs.pair {
        Some((l, r)) => (util::load_gray(l)?, util::load_gray(r)?),
        None => (detected[kept[0].0].0.0.clone(), detected[kept[0].0].1.0.clone()),
    };
    let rectifier = parallax_stereo_rectify::Rectifier::from_rectification(&rig, rect)?;
    let (rl, rr) = rectifier.rectify_pair(&pl, &pr, parallax_stereo_rectify::Border::Constant(image::Luma([0u8])))?;
    util::save_png(&out.join("rectified-left.png"), &rl)?;
    util::save_png(&out.join("rectified-right.png"), &rr)?;
    report.images.push(("rectified-left.png".into(), "rectified left image of the matched pair".into()));

    eprintln!("[4/6] block matching the rectified pair…");
    let cfg = parallax_block_matching::MatcherConfig { num_disparities: inputs.disparities, ..Default::default() };
    let mut matcher = parallax_block_matching::BlockMatcher::new(cfg)?;
    let t = std::time::Instant::now();
    let disparity = matcher.compute(&rl, &rr)?;
    let secs = t.elapsed().as_secs_f64();
    util::write_atomic(&out.join("disparity.pfm"), &parallax_block_matching::to_pfm(&disparity))?;
    util::save_png(&out.join("disparity.png"), &parallax_block_matching::false_colour(&disparity, None))?;
    report.images.push(("disparity.png".into(), "disparity (false colour, black = invalid)".into()));
    report.note("disparity", format!("density {:.1} %, {:.1} ms", 100.0 * disparity.density(), 1e3 * secs));

    eprintln!("[5/6] triangulating…");
    let q = parallax_triangulation::ReprojectionMatrix::new(rect.q)?;
    let cloud = parallax_triangulation::disparity_to_point_cloud(
        &disparity,
        &q,
        &parallax_triangulation::CloudConfig::default(),
        Some(parallax_triangulation::PixelColors::Grey(rl.as_raw())),
    )?;
    parallax_triangulation::write_ply(
        &out.join("cloud.ply"),
        &cloud,
        parallax_triangulation::PlyFormat::BinaryLittleEndian,
    )?;
    let tri = parallax_triangulation::TriangulationConfig { pixel_sigma: stereo.sigma_px, ..Default::default() };
    let mut distances = Vec::new();
    for (l, r) in lg.iter().zip(&rg) {
        distances.extend(parallax_triangulation::adjacent_corner_distances(&rig, l, r, &tri)?);
    }
    let rms = parallax_triangulation::distance_rms(&distances, board.square_size).unwrap_or(f64::NAN);
    report.note("triangulation", format!("{} points in cloud.ply", cloud.len()));
    report.note(
        "triangulation",
        format!(
            "adjacent-corner distances: RMS error {rms:.4} over {} distances (square {})",
            distances.len(),
            board.square_size
        ),
    );

    if let Some(spec) = &inputs.robot {
        eprintln!("[6/6] hand-eye…");
        let robot = crate::handeye::read_poses(spec, crate::handeye::PoseFormat::Auto)?;
        ensure!(robot.len() == lp.len(), "hand-eye: {} robot poses for {} image pairs", robot.len(), lp.len());
        let bfg: Vec<_> = kept.iter().map(|k| robot[k.0]).collect();
        let solution = parallax_hand_eye::calibrate(
            &bfg,
            &stereo.camera_from_board,
            parallax_hand_eye::Method::Refined,
            &parallax_hand_eye::HandEyeConfig::default(),
        )
        .context("hand-eye")?;
        util::write_ron(&out.join("handeye.ron"), &solution)?;
        let t = solution.transform.translation;
        report.note(
            "hand-eye",
            format!(
                "gripper_from_camera t ({:.4}, {:.4}, {:.4}), rvec {:?} rad; residual {:.3} deg / {:.4}",
                t.x,
                t.y,
                t.z,
                solution.transform.rvec().to_array(),
                solution.quality.mean_rotation_deg,
                solution.quality.mean_translation
            ),
        );
    } else {
        eprintln!("[6/6] hand-eye skipped (no --robot)");
    }
    Ok(report)
}
