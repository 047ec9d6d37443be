//! Partial views (issue 18): calibrating from views of a large target that fill the frame
//! (its points reach the image corners, the rest of the target outside) recovers k1…k3 closer
//! to the truth than the same number of whole-board views of a board that fits in the
//! image; stereo pairs are matched by id.

use glam::{DQuat, DVec2, DVec3};
use parallax_camera_model::{
    Camera, CharucoBoard, Chessboard, Distortion, Intrinsics, Isometry3, MarkerDictionary, StereoRig,
    TargetDescription, TargetObservation,
};
use parallax_planar_calibration::{CalibrationConfig, StereoConfig, calibrate_stereo_target, calibrate_target};
use parallax_synthetic::{ViewSetConfig, add_pixel_noise, calibration_poses, rng};
use rand::Rng;

fn camera() -> Camera {
    Camera {
        intrinsics: Intrinsics::new(700.0, 700.0, 401.0, 298.0),
        lens: Distortion::new(-0.28, 0.11, 0.0004, -0.0003, -0.02).into(),
        width: 800,
        height: 600,
    }
}

/// The pixels of `target`'s points inside the image (2 px margin, on the invertible part of
/// the lens), with noise.
fn observe(
    cam: &Camera,
    target: &TargetDescription,
    pose: &Isometry3,
    noise: f64,
    r: &mut impl Rng,
) -> TargetObservation {
    let (mut ids, mut pts) = (Vec::new(), Vec::new());
    for id in 0..target.point_count() as u32 {
        let p = pose.transform_point(target.point(id).unwrap());
        if p.z <= 0.0 {
            continue;
        }
        let Ok(px) = cam.project(p) else { continue };
        let inside = px.x >= 2.0 && px.y >= 2.0 && px.x <= cam.width as f64 - 3.0 && px.y <= cam.height as f64 - 3.0;
        let back = cam.unproject(px).map(|ray| (ray.truncate() - DVec2::new(p.x / p.z, p.y / p.z)).length() < 1e-6);
        if inside && back == Ok(true) {
            ids.push(id);
            pts.push(px);
        }
    }
    add_pixel_noise(&mut pts, noise, r);
    TargetObservation::new(ids, pts).unwrap()
}

fn k_error(c: &Camera, t: &Camera) -> [f64; 3] {
    [
        c.distortion().copied().unwrap().k1 - t.distortion().copied().unwrap().k1,
        c.distortion().copied().unwrap().k2 - t.distortion().copied().unwrap().k2,
        c.distortion().copied().unwrap().k3 - t.distortion().copied().unwrap().k3,
    ]
}

#[test]
fn partial_views_reaching_the_corners_recover_the_distortion_better() {
    let cam = camera();
    let views = 8;
    let noise = 0.2;
    let mut r = rng(5);
    // Whole-board views: a 9x6 board of 30 mm squares, fully inside the image.
    let small = Chessboard { cols: 9, rows: 6, square_size: 30.0 };
    let whole_target = TargetDescription::Chessboard(small);
    let poses = calibration_poses(&cam, &small, &ViewSetConfig { views, seed: 8, ..Default::default() }).unwrap();
    let whole: Vec<TargetObservation> = poses
        .iter()
        .map(|p| {
            let o = observe(&cam, &whole_target, p, noise, &mut r);
            assert_eq!(o.len(), small.len(), "whole-board view");
            o
        })
        .collect();
    // Partial views: a 24x18-square ChArUco board of 30 mm squares, close enough to fill the
    // frame, tilted up to 25°, its centre moved around the image centre.
    let big =
        CharucoBoard::new(24, 18, 30.0, 22.0, MarkerDictionary::predefined("DICT_5X5_250").unwrap(), false).unwrap();
    let big_target = TargetDescription::Charuco(big);
    let centre = DVec3::new(12.0 * 30.0, 9.0 * 30.0, 0.0);
    let mut partial = Vec::new();
    for k in 0..views {
        let axis = DVec3::new((k as f64 * 2.1).cos(), (k as f64 * 2.1).sin(), 0.0);
        let rot = DQuat::from_axis_angle(axis, (12.0 + 13.0 * (k % 2) as f64).to_radians());
        let shift = DVec3::new(r.random_range(-60.0..60.0), r.random_range(-40.0..40.0), 0.0);
        let pose = Isometry3::from_quat_translation(rot, DVec3::new(0.0, 0.0, 520.0) - rot * (centre + shift));
        let o = observe(&cam, &big_target, &pose, noise, &mut r);
        let reach = o.points().iter().map(|p| (*p - DVec2::new(399.5, 299.5)).abs()).fold(DVec2::ZERO, |a, b| a.max(b));
        assert!(o.len() < big.corner_count() && reach.x > 380.0 && reach.y > 280.0, "view {k} reaches {reach}");
        partial.push(o);
    }
    let cfg = CalibrationConfig::default();
    let a = calibrate_target(&whole_target, &whole, 800, 600, &cfg).unwrap();
    let b = calibrate_target(&big_target, &partial, 800, 600, &cfg).unwrap();
    let (ea, eb) = (k_error(&a.camera, &cam), k_error(&b.camera, &cam));
    let norm = |e: [f64; 3]| (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
    println!(
        "{views} whole-board views: k1..k3 errors {:.5} {:.5} {:.5} (RMS {:.3} px); {views} partial views: {:.5} {:.5} {:.5} (RMS {:.3} px)",
        ea[0], ea[1], ea[2], a.rms_px, eb[0], eb[1], eb[2], b.rms_px
    );
    assert!(norm(eb) < norm(ea), "partial {eb:?} vs whole {ea:?}");
    assert!(eb.iter().zip(&ea).all(|(b, a)| b.abs() < a.abs()), "every coefficient: partial {eb:?} vs whole {ea:?}");
    // Both fits are consistent with the noise.
    assert!(a.rms_px < 2.0 * noise && b.rms_px < 2.0 * noise);
}

#[test]
fn stereo_pairs_use_the_points_both_cameras_saw() {
    let left = camera();
    let right = Camera { intrinsics: Intrinsics::new(705.0, 703.0, 396.0, 303.0), ..camera() };
    let right_from_left = Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.02, 0.005), DVec3::new(-120.0, 1.5, 0.8));
    let rig = StereoRig::new(left, right, right_from_left).unwrap();
    let board =
        CharucoBoard::new(14, 10, 30.0, 22.0, MarkerDictionary::predefined("DICT_4X4_250").unwrap(), false).unwrap();
    let target = TargetDescription::Charuco(board);
    let chess = Chessboard { cols: 13, rows: 9, square_size: 30.0 };
    let cfg = ViewSetConfig {
        views: 12,
        seed: 3,
        allow_partial: true,
        min_distance: 500.0,
        max_distance: 900.0,
        ..Default::default()
    };
    let shift = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-30.0, -30.0, 0.0));
    let poses = parallax_synthetic::stereo_calibration_poses(&rig, &chess, &cfg).unwrap();
    let mut r = rng(9);
    let (mut ls, mut rs) = (Vec::new(), Vec::new());
    for p in &poses {
        let pl = *p * shift;
        let l = observe(&left, &target, &pl, 0.1, &mut r);
        let o = observe(&right, &target, &(right_from_left * pl), 0.1, &mut r);
        // Each camera reports its points in its own order (reversed here) and drops some.
        let keep: Vec<usize> = (0..o.len()).rev().filter(|k| k % 7 != 3).collect();
        let o = TargetObservation::new(
            keep.iter().map(|&k| o.ids()[k]).collect(),
            keep.iter().map(|&k| o.points()[k]).collect(),
        )
        .unwrap();
        ls.push(l);
        rs.push(o);
    }
    let res = calibrate_stereo_target(&target, &ls, &rs, (800, 600), (800, 600), &StereoConfig::default()).unwrap();
    let t = res.rig.right_from_left.translation;
    println!("stereo from id-matched partial views: T = {t:?}, RMS {:.3} px", res.rms_px);
    assert!((t - right_from_left.translation).length() < 0.5, "T {t:?}");
    assert!(res.rms_px < 0.2);
    // A pair whose cameras share fewer than 4 points is refused, naming the pair.
    let mut bad = rs.clone();
    bad[2] = TargetObservation::new(vec![], vec![]).unwrap();
    let e = calibrate_stereo_target(&target, &ls, &bad, (800, 600), (800, 600), &StereoConfig::default()).unwrap_err();
    assert!(e.to_string().contains("stereo pair 2"), "{e}");
    // An id that is not on the target is refused, naming the view.
    let wrong = vec![TargetObservation::new(vec![9999, 1, 2, 3], vec![DVec2::ONE; 4]).unwrap(); 3];
    let e = calibrate_target(&target, &wrong, 800, 600, &Default::default()).unwrap_err();
    assert!(e.to_string().contains("view 0: point id 9999"), "{e}");
}
