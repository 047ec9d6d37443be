//! Hartley's uncalibrated rectification on a synthetic pinhole rig with the true F.

mod common;

use glam::{DMat3, DVec2, DVec3};
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_stereo_rectify::{RectifyError, stereo_rectify_uncalibrated};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn pinhole_rig(t: DVec3) -> StereoRig {
    let cam = |f: f64, cx: f64| Camera::new(Intrinsics::new(f, f, cx, 245.0), Distortion::default(), 640, 480).unwrap();
    StereoRig::new(cam(600.0, 318.0), cam(610.0, 325.0), Isometry3::from_rvec_tvec(DVec3::new(0.02, -0.05, 0.01), t))
        .unwrap()
}

fn matches(rig: &StereoRig, n: usize, seed: u64) -> (Vec<DVec2>, Vec<DVec2>) {
    common::scene_points(n, seed)
        .into_iter()
        .filter_map(|x| {
            let a = rig.left.project(x).ok()?;
            let b = rig.right.project(rig.right_from_left.transform_point(x)).ok()?;
            (rig.left.contains(a) && rig.right.contains(b)).then_some((a, b))
        })
        .unzip()
}

fn h(m: DMat3, p: DVec2) -> DVec2 {
    let q = m * p.extend(1.0);
    DVec2::new(q.x / q.z, q.y / q.z)
}

#[test]
fn exact_matches_share_rows_after_hartley_rectification() {
    // right camera to the right (epipole on the left: mirrored) and to the left
    for t in [DVec3::new(-100.0, 3.0, 5.0), DVec3::new(100.0, -4.0, 2.0)] {
        let rig = pinhole_rig(t);
        let (p1, p2) = matches(&rig, 300, 1);
        assert!(p1.len() > 100);
        let f = rig.fundamental() * 1e3; // scale of F is irrelevant
        let out = stereo_rectify_uncalibrated(&p1, &p2, f, 640, 480, None).unwrap();
        assert!(out.inliers.iter().all(|&b| b));
        let worst = p1.iter().zip(&p2).map(|(&a, &b)| (h(out.h1, a).y - h(out.h2, b).y).abs()).fold(0.0, f64::max);
        println!("t = {t}: mean |dv| {:.2e} px, max {:.2e} px", out.mean_abs_dv, out.max_abs_dv);
        assert!(worst < 1e-6 && (out.max_abs_dv - worst).abs() < 1e-12, "{worst}");
        // Disparities keep their sign convention (u_left ≥ u_right for the left-right order
        // of the cameras is not guaranteed by Hartley; check the images are not mirrored
        // vertically: rows keep their order).
        let a = h(out.h1, DVec2::new(320.0, 10.0));
        let b = h(out.h1, DVec2::new(320.0, 470.0));
        assert!(b.y > a.y);
    }
}

#[test]
fn threshold_rejects_outliers() {
    let rig = pinhole_rig(DVec3::new(-100.0, 3.0, 5.0));
    let (p1, mut p2) = matches(&rig, 300, 2);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let bad: Vec<usize> = (0..10).map(|i| i * 17).collect();
    for &i in &bad {
        p2[i].y += rng.random_range(15.0..40.0);
    }
    let out = stereo_rectify_uncalibrated(&p1, &p2, rig.fundamental(), 640, 480, Some(2.0)).unwrap();
    for (i, &ok) in out.inliers.iter().enumerate() {
        assert_eq!(ok, !bad.contains(&i), "match {i}");
    }
    assert!(out.max_abs_dv < 1e-6, "{}", out.max_abs_dv);
}

#[test]
fn uncalibrated_bad_input() {
    let rig = pinhole_rig(DVec3::new(-100.0, 3.0, 5.0));
    let (p1, p2) = matches(&rig, 50, 4);
    let f = rig.fundamental();
    assert!(matches!(
        stereo_rectify_uncalibrated(&p1, &p2[1..], f, 640, 480, None),
        Err(RectifyError::SizeMismatch(_))
    ));
    assert!(matches!(stereo_rectify_uncalibrated(&[], &[], f, 640, 480, None), Err(RectifyError::Empty(_))));
    assert!(matches!(
        stereo_rectify_uncalibrated(&p1[..2], &p2[..2], f, 640, 480, None),
        Err(RectifyError::TooFewMatches { needed: 3, got: 2 })
    ));
    assert!(matches!(
        stereo_rectify_uncalibrated(&p1, &p2, DMat3::ZERO, 640, 480, None),
        Err(RectifyError::Degenerate(_))
    ));
    let mut nan = p1.clone();
    nan[3].x = f64::NAN;
    assert!(matches!(stereo_rectify_uncalibrated(&nan, &p2, f, 640, 480, None), Err(RectifyError::NonFinite(_))));
}
