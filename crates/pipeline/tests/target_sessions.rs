//! Calibration sessions on files with partial-view targets (issue 18 item 5): ChArUco views
//! rendered by `parallax-synthetic` (partial views, blur 0.8 px, noise σ 2 grey levels) are
//! written as PNG files, found by `session::detect_files`, and calibrated from the points each
//! view saw; the intrinsics are checked against the renderer's camera.

use std::path::PathBuf;

use glam::DVec3;
use parallax_camera_model::{
    Camera, CharucoBoard, Chessboard, Distortion, Intrinsics, Isometry3, StereoRig, TargetDescription,
};
use parallax_composition::session;
use parallax_synthetic::{RenderOptions, ViewSetConfig, calibration_poses, render_charuco};

/// The renderer's camera: 800x600, fx 760, fy 758, centre (402, 297), barrel distortion.
fn camera() -> Camera {
    let k = Intrinsics::new(760.0, 758.0, 402.0, 297.0);
    Camera::new(k, Distortion::new(-0.12, 0.05, 0.0005, -0.0003, 0.0), 800, 600).unwrap()
}

/// OpenCV's 9x7-square ChArUco board, 25 mm squares, 18 mm markers of DICT_4X4_50.
fn board() -> CharucoBoard {
    match "charuco:9x7:25:18:DICT_4X4_50".parse() {
        Ok(TargetDescription::Charuco(b)) => b,
        other => panic!("{other:?}"),
    }
}

/// `camera_from_board` poses of the view generator (partial views allowed), moved from its
/// chessboard frame (first inner corner) to the ChArUco frame (outer corner).
fn poses(cam: &Camera, b: &CharucoBoard, views: usize, seed: u64) -> Vec<Isometry3> {
    let chess = Chessboard::new(b.squares_x() - 1, b.squares_y() - 1, b.square_length()).unwrap();
    let (min_distance, max_distance) = (380.0, 620.0);
    let cfg = ViewSetConfig { views, seed, allow_partial: true, min_distance, max_distance, ..Default::default() };
    let shift = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-b.square_length(), -b.square_length(), 0.0));
    calibration_poses(cam, &chess, &cfg).unwrap().into_iter().map(|p| p * shift).collect()
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("parallax-target-sessions-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Renders `pose` seen by `cam` into `path` (noise seed `seed`).
fn render(cam: &Camera, pose: &Isometry3, seed: u64, path: &std::path::Path) {
    let opts = RenderOptions { blur_sigma: 0.8, noise_sigma: 2.0, seed, ..Default::default() };
    render_charuco(cam, &board(), pose, &opts, &[], 4.0).unwrap().image.save(path).unwrap();
}

/// 16 ChArUco views, some partial: fx, fy, cx, cy within 2 px of the renderer's camera (the
/// calibration's own 1σ here is a few tenths of a pixel; 2 px holds for any draw of the views).
#[test]
fn mono_calibration_from_charuco_files_recovers_the_intrinsics() {
    let (cam, dir) = (camera(), temp("mono"));
    let target = TargetDescription::Charuco(board());
    let mut paths = Vec::new();
    for (k, pose) in poses(&cam, &board(), 16, 5).iter().enumerate() {
        paths.push(dir.join(format!("view{k:02}.png")));
        render(&cam, pose, 300 + k as u64, &paths[k]);
    }
    let views = session::detect_files(&paths, &target, &Default::default()).unwrap();
    let found: Vec<_> = views.iter().filter(|v| v.found()).collect();
    assert!(found.len() >= 14, "ChArUco found in {} of 16 views", found.len());
    assert!(found.iter().all(|v| v.grid.is_none()), "a ChArUco view has ids, no whole grid");
    let partial = found.iter().filter(|v| v.observation.as_ref().unwrap().len() < board().corner_count()).count();
    let size = session::common_size(&found).unwrap();
    let obs: Vec<_> = found.iter().map(|v| v.observation.clone().unwrap()).collect();
    let r = parallax_planar_calibration::calibrate_target(&target, &obs, size.0, size.1, &Default::default()).unwrap();
    let (k, t) = (r.camera.intrinsics, cam.intrinsics);
    println!(
        "charuco mono: {} views ({partial} partial), RMS {:.3} px, fx {:.3} fy {:.3} cx {:.3} cy {:.3} (truth 760 758 402 297)",
        found.len(),
        r.rms_px,
        k.fx,
        k.fy,
        k.cx,
        k.cy
    );
    for (name, got, truth) in [("fx", k.fx, t.fx), ("fy", k.fy, t.fy), ("cx", k.cx, t.cx), ("cy", k.cy, t.cy)] {
        assert!((got - truth).abs() < 2.0, "{name} {got:.3} vs truth {truth}");
    }
    assert!(r.rms_px < 0.2, "RMS {} px", r.rms_px);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A stereo rig of two such cameras 120 mm apart, 12 ChArUco pairs: each pair uses the corners
/// both cameras saw; intrinsics within 2 px, baseline within 0.5 mm of the truth, and the
/// point-level checks of the session (rectified |Δv| under 0.1 px, adjacent-corner distances
/// within 0.1 mm RMS of the 25 mm squares).
#[test]
fn stereo_calibration_from_charuco_files_uses_the_common_corners() {
    let (cam, dir) = (camera(), temp("stereo"));
    let right_from_left = Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.02, 0.0), DVec3::new(-120.0, 0.0, 0.0));
    let rig = StereoRig::new(cam, cam, right_from_left).unwrap();
    let target = TargetDescription::Charuco(board());
    let (mut lp, mut rp) = (Vec::new(), Vec::new());
    // Poses for the left camera, with the board shifted towards the rig's middle.
    let mid = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(60.0, 0.0, 0.0));
    for (k, pose) in poses(&cam, &board(), 12, 9).iter().enumerate() {
        let left_pose = mid * *pose;
        lp.push(dir.join(format!("left{k:02}.png")));
        rp.push(dir.join(format!("right{k:02}.png")));
        render(&cam, &left_pose, 500 + k as u64, &lp[k]);
        render(&cam, &(right_from_left * left_pose), 700 + k as u64, &rp[k]);
    }
    let (left, right) = (
        session::detect_files(&lp, &target, &Default::default()).unwrap(),
        session::detect_files(&rp, &target, &Default::default()).unwrap(),
    );
    let pairs: Vec<_> = left.iter().zip(&right).filter(|(l, r)| l.found() && r.found()).collect();
    assert!(pairs.len() >= 8, "{} pairs with the board in both images", pairs.len());
    let lo: Vec<_> = pairs.iter().map(|p| p.0.observation.clone().unwrap()).collect();
    let ro: Vec<_> = pairs.iter().map(|p| p.1.observation.clone().unwrap()).collect();
    let r = parallax_planar_calibration::calibrate_stereo_target(
        &target,
        &lo,
        &ro,
        (800, 600),
        (800, 600),
        &Default::default(),
    )
    .unwrap();
    let checks = session::target_corner_checks(&r.rig, &target, &lo, &ro).unwrap();
    println!(
        "charuco stereo: {} pairs, RMS {:.3} px, baseline {:.3} mm (truth {:.3}), left fx {:.3} cx {:.3}, mean |dv| {:.4} px, \
         {} adjacent distances RMS {:.4} mm",
        pairs.len(),
        r.rms_px,
        r.rig.baseline(),
        rig.baseline(),
        r.rig.left.intrinsics.fx,
        r.rig.left.intrinsics.cx,
        checks.mean_abs_dv,
        checks.distances,
        checks.distance_rms
    );
    for (side, c) in [("left", r.rig.left), ("right", r.rig.right)] {
        let (k, t) = (c.intrinsics, cam.intrinsics);
        for (name, got, truth) in [("fx", k.fx, t.fx), ("fy", k.fy, t.fy), ("cx", k.cx, t.cx), ("cy", k.cy, t.cy)] {
            assert!((got - truth).abs() < 2.0, "{side} {name} {got:.3} vs truth {truth}");
        }
    }
    assert!((r.rig.baseline() - rig.baseline()).abs() < 0.5, "baseline {}", r.rig.baseline());
    assert!(checks.mean_abs_dv < 0.1, "mean |dv| {}", checks.mean_abs_dv);
    assert!(
        checks.distances > 100 && checks.distance_rms < 0.1,
        "{} distances, RMS {}",
        checks.distances,
        checks.distance_rms
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
