//! Public-API checks: Zhang's published camera, options, diagnostics, errors, stereo, DLT, PnP.

mod common;

use common::{board, noisy_views, pose_looking_at, tilted_poses, truth_camera};
use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_planar_calibration::*;
use parallax_synthetic::{add_pixel_noise, rng};

/// Zhang (1998/2000): α = 832.5, β = 832.53, γ = 0.2045, u0 = 303.959, v0 = 206.585,
/// k1 = −0.228601, k2 = 0.190353 on 640x480 images.
fn zhang_camera() -> Camera {
    let k = Intrinsics { fx: 832.5, fy: 832.53, cx: 303.959, cy: 206.585, skew: 0.2045 };
    Camera::new(k, Distortion::new(-0.228601, 0.190353, 0.0, 0.0, 0.0), 640, 480).unwrap()
}

/// His model plane: 8x8 squares, 4 corners each = 256 points (pitch 22 mm, square 14 mm).
fn zhang_model() -> Vec<DVec3> {
    let mut pts = Vec::new();
    for r in 0..8 {
        for c in 0..8 {
            let (x, y) = (c as f64 * 22.0, r as f64 * 22.0);
            for (dx, dy) in [(0.0, 0.0), (14.0, 0.0), (14.0, 14.0), (0.0, 14.0)] {
                pts.push(DVec3::new(x + dx, y + dy, 0.0));
            }
        }
    }
    pts
}

fn zhang_views(sigma: f64, seed: u64) -> (Vec<Vec<DVec3>>, Vec<Vec<DVec2>>) {
    let cam = zhang_camera();
    let centre = DVec3::new(85.0, 85.0, 0.0);
    let rv = [
        DVec3::new(0.35, -0.1, 0.05),
        DVec3::new(-0.3, 0.25, -0.1),
        DVec3::new(0.1, 0.4, 0.15),
        DVec3::new(-0.2, -0.35, 0.0),
        DVec3::new(0.3, 0.3, -0.2),
    ];
    let mut r = rng(seed);
    let mut object = Vec::new();
    let mut image = Vec::new();
    for (i, v) in rv.iter().enumerate() {
        let pose = pose_looking_at(*v, centre, DVec3::new(-10.0 + 5.0 * i as f64, -20.0, 520.0 + 30.0 * i as f64));
        let mut px: Vec<DVec2> = zhang_model().iter().map(|p| cam.project_from(&pose, *p).unwrap()).collect();
        assert!(px.iter().all(|p| cam.contains(*p)));
        add_pixel_noise(&mut px, sigma, &mut r);
        object.push(zhang_model());
        image.push(px);
    }
    (object, image)
}

fn zhang_config() -> CalibrationConfig {
    CalibrationConfig { estimate_skew: true, zero_tangential: true, fix_k3: true, ..Default::default() }
}

#[test]
fn zhang_published_camera_is_reproduced_exactly_from_exact_data() {
    let (object, image) = zhang_views(0.0, 1);
    let r = calibrate_camera(&object, &image, 640, 480, &zhang_config()).unwrap();
    let t = zhang_camera();
    let (k, d) = (r.camera.intrinsics, r.camera.distortion().copied().unwrap());
    assert!((k.fx - 832.5).abs() < 1e-6 && (k.fy - 832.53).abs() < 1e-6, "{k:?}");
    assert!((k.cx - 303.959).abs() < 1e-6 && (k.cy - 206.585).abs() < 1e-6);
    assert!((k.skew - 0.2045).abs() < 1e-6);
    assert!(
        (d.k1 - t.distortion().copied().unwrap().k1).abs() < 1e-9
            && (d.k2 - t.distortion().copied().unwrap().k2).abs() < 1e-8,
        "{d:?}"
    );
    assert!(r.rms_px < 1e-8);
}

#[test]
fn zhang_published_camera_within_reported_uncertainty_under_noise() {
    // Zhang's residual was ≈ 0.33 px per point.
    let (object, image) = zhang_views(0.25, 2);
    let r = calibrate_camera(&object, &image, 640, 480, &zhang_config()).unwrap();
    let t = zhang_camera();
    let (k, d, s) = (r.camera.intrinsics, r.camera.distortion().copied().unwrap(), r.std_devs);
    let checks = [
        ("fx", k.fx, 832.5, s.fx),
        ("fy", k.fy, 832.53, s.fy),
        ("cx", k.cx, 303.959, s.cx),
        ("cy", k.cy, 206.585, s.cy),
        ("skew", k.skew, 0.2045, s.skew),
        ("k1", d.k1, t.distortion().copied().unwrap().k1, s.k1),
        ("k2", d.k2, t.distortion().copied().unwrap().k2, s.k2),
    ];
    for (name, est, truth, sigma) in checks {
        let sigma = sigma.unwrap();
        assert!((est - truth).abs() < 3.5 * sigma, "{name}: {est} vs {truth} (σ {sigma})");
    }
    assert!((k.fx / 832.5 - 1.0).abs() < 5e-3);
    assert!((r.sigma_px - 0.25).abs() < 0.03, "σ {}", r.sigma_px);
    // The closed form alone (Zhang's first step) is already close.
    let hs: Vec<_> = object
        .iter()
        .zip(&image)
        .map(|(o, i)| estimate_homography(&o.iter().map(|p| p.truncate()).collect::<Vec<_>>(), i).unwrap().matrix)
        .collect();
    let k0 = intrinsics_from_homographies(&hs, 640, 480, true).unwrap();
    assert!((k0.fx / 832.5 - 1.0).abs() < 0.05, "{k0:?}");
}

#[test]
fn options_hold_what_they_say() {
    let truth = truth_camera();
    let (_, object, image) = noisy_views(&truth, &board(), 12, 0.1, 5);
    // Fixed principal point: exactly the image centre, no std dev.
    let cfg = CalibrationConfig { fix_principal_point: true, fix_aspect_ratio: true, ..Default::default() };
    let r = calibrate_camera(&object, &image, 640, 480, &cfg).unwrap();
    assert_eq!((r.camera.intrinsics.cx, r.camera.intrinsics.cy), (319.5, 239.5));
    assert!(r.std_devs.cx.is_none() && r.std_devs.cy.is_none());
    assert!((r.camera.intrinsics.fx - r.camera.intrinsics.fy).abs() < 1e-9);
    assert!(r.std_devs.fx.is_some());
    // Zero tangential + fixed k3.
    let cfg = CalibrationConfig { zero_tangential: true, fix_k3: true, ..Default::default() };
    let r = calibrate_camera(&object, &image, 640, 480, &cfg).unwrap();
    let d = r.camera.distortion().copied().unwrap();
    assert_eq!((d.p1, d.p2, d.k3), (0.0, 0.0, 0.0));
    assert!(r.std_devs.p1.is_none() && r.std_devs.k3.is_none());
    assert_eq!(r.dof, 2 * 12 * 54 - (6 + 6 * 12));
    // Intrinsic guess: starts from it, converges to the same answer.
    let cfg2 = CalibrationConfig { intrinsic_guess: Some(truth), ..cfg.clone() };
    let g = calibrate_camera(&object, &image, 640, 480, &cfg2).unwrap();
    assert!((g.camera.intrinsics.fx - r.camera.intrinsics.fx).abs() < 1e-4);
    // Rational model: estimates k4..k6 and fits at least as well.
    let cfg3 = CalibrationConfig { rational_model: true, ..Default::default() };
    let q = calibrate_camera(&object, &image, 640, 480, &cfg3).unwrap();
    assert!(q.std_devs.k4.is_some() && q.std_devs.k6.is_some());
    let full = calibrate_camera(&object, &image, 640, 480, &CalibrationConfig::default()).unwrap();
    assert!(q.rms_px <= full.rms_px + 1e-9);
    // The RON round trip keeps everything.
    let text = ron::to_string(&full).unwrap();
    let back: CalibrationResult = ron::from_str(&text).unwrap();
    assert_eq!(back.per_view_rms_px.len(), 12);
    assert!((back.camera.intrinsics.fx - full.camera.intrinsics.fx).abs() < 1e-9);
}

#[test]
fn non_monotonic_distortion_is_flagged() {
    // r_d = r (1 − 0.45 r²) peaks at r = 0.861 (r_d = 0.574 → 287 px): inside a 640x480 image
    // of focal length 500 (corner at 400 px).
    let cam =
        Camera::new(Intrinsics::new(500.0, 500.0, 319.5, 239.5), Distortion::new(-0.45, 0.0, 0.0, 0.0, 0.0), 640, 480)
            .unwrap();
    let fold = distortion_fold(&cam).expect("fold inside the image");
    assert!((fold.undistorted_radius - (1.0f64 / 1.35).sqrt()).abs() < 2e-3, "{fold:?}");
    assert!((fold.radius_px - 500.0 * 0.5738).abs() < 1.0, "{fold:?}");
    assert!(distortion_fold(&truth_camera()).is_none());
    // A calibration from boards near the centre recovers that lens and warns.
    let b = parallax_camera_model::Chessboard::new(7, 5, 12.0).unwrap();
    let poses = tilted_poses(
        &Camera { width: 400, height: 300, intrinsics: Intrinsics::new(500.0, 500.0, 199.5, 149.5), ..cam },
        &b,
        12,
        3,
    );
    let shift = Isometry3::IDENTITY;
    let object = vec![b.object_points(); poses.len()];
    let image: Vec<Vec<DVec2>> = poses
        .iter()
        .map(|p| b.object_points().iter().map(|x| cam.project_from(&(shift * *p), *x).unwrap()).collect())
        .collect();
    let cfg = CalibrationConfig { zero_tangential: true, fix_k3: true, fix_k2: true, ..Default::default() };
    let r = calibrate_camera(&object, &image, 640, 480, &cfg).unwrap();
    assert!(
        (r.camera.distortion().copied().unwrap().k1 + 0.45).abs() < 1e-6,
        "{:?}",
        r.camera.distortion().copied().unwrap()
    );
    assert!(
        r.warnings.iter().any(|w| matches!(w, CalibrationWarning::NonMonotonicDistortion { .. })),
        "{:?}",
        r.warnings
    );
}

#[test]
fn bad_input_is_a_clear_error() {
    let truth = truth_camera();
    let (_, object, image) = noisy_views(&truth, &board(), 4, 0.1, 9);
    let cfg = CalibrationConfig::default();
    // Single view.
    let e = calibrate_camera(&object[..1], &image[..1], 640, 480, &cfg).unwrap_err();
    assert!(matches!(e, CalibrationError::TooFewViews { got: 1, .. }), "{e}");
    // Collinear corners in view 2: the error names the view.
    let mut obj = object.clone();
    let mut img = image.clone();
    obj[2] = (0..9).map(|i| DVec3::new(i as f64 * 30.0, 0.0, 0.0)).collect();
    img[2] = image[2][..9].to_vec();
    let e = calibrate_camera(&obj, &img, 640, 480, &cfg).unwrap_err();
    assert!(matches!(&e, CalibrationError::Degenerate(m) if m.contains("view 2")), "{e}");
    // Parallel views: same orientation, different positions.
    let rv = DVec3::new(0.3, 0.2, 0.0);
    let c = DVec3::new(120.0, 75.0, 0.0);
    let mut r = rng(4);
    let par: Vec<Vec<DVec2>> = (0..5)
        .map(|i| {
            let pose = pose_looking_at(
                rv,
                c,
                DVec3::new(-40.0 + 20.0 * i as f64, 10.0 * i as f64 - 20.0, 450.0 + 40.0 * i as f64),
            );
            let mut px: Vec<DVec2> =
                board().object_points().iter().map(|p| truth.project_from(&pose, *p).unwrap()).collect();
            add_pixel_noise(&mut px, 0.1, &mut r);
            px
        })
        .collect();
    let e = calibrate_camera(&vec![board().object_points(); 5], &par, 640, 480, &cfg).unwrap_err();
    assert!(matches!(e, CalibrationError::Degenerate(_)), "{e}");
    // Sizes, NaN, non-planar.
    assert!(matches!(calibrate_camera(&object, &image[..3], 640, 480, &cfg), Err(CalibrationError::SizeMismatch(_))));
    let mut nan = image.clone();
    nan[1][5].x = f64::NAN;
    assert!(matches!(calibrate_camera(&object, &nan, 640, 480, &cfg), Err(CalibrationError::NonFinite(_))));
    let mut bumpy = object.clone();
    bumpy[0][3].z = 5.0;
    assert!(matches!(calibrate_camera(&bumpy, &image, 640, 480, &cfg), Err(CalibrationError::NotPlanar { .. })));
    assert!(matches!(calibrate_camera(&[], &[], 640, 480, &cfg), Err(CalibrationError::Empty(_))));
}

#[test]
fn outlier_view_is_flagged() {
    let truth = truth_camera();
    let (_, object, mut image) = noisy_views(&truth, &board(), 10, 0.1, 11);
    let mut r = rng(12);
    add_pixel_noise(&mut image[4], 1.5, &mut r);
    let res = calibrate_camera(&object, &image, 640, 480, &CalibrationConfig::default()).unwrap();
    let flagged: Vec<usize> = res
        .warnings
        .iter()
        .filter_map(|w| if let CalibrationWarning::OutlierView { view, .. } = w { Some(*view) } else { None })
        .collect();
    assert_eq!(flagged, vec![4], "{:?}", res.warnings);
}

fn truth_rig() -> StereoRig {
    let right = Camera::new(
        Intrinsics::new(530.0, 528.0, 318.0, 244.0),
        Distortion::new(-0.28, 0.09, 0.0005, -0.0003, 0.0),
        640,
        480,
    )
    .unwrap();
    let e = Isometry3::from_rvec_tvec(DVec3::new(0.006, 0.0045, -0.0035), DVec3::new(-99.8, 1.12, 0.05));
    StereoRig::new(truth_camera(), right, e).unwrap()
}

#[test]
fn stereo_calibration_recovers_the_rig() {
    let rig = truth_rig();
    let b = board();
    let cfg = parallax_synthetic::ViewSetConfig {
        views: 15,
        seed: 21,
        min_distance: 350.0,
        max_distance: 600.0,
        ..Default::default()
    };
    let poses = parallax_synthetic::stereo_calibration_poses(&rig, &b, &cfg).unwrap();
    let mut r = rng(22);
    let mut proj = |cam: &Camera, pose: &Isometry3| {
        let mut c = parallax_synthetic::project_corners(cam, &b, pose).unwrap();
        add_pixel_noise(&mut c, 0.1, &mut r);
        c
    };
    let left: Vec<Vec<DVec2>> = poses.iter().map(|p| proj(&rig.left, p)).collect();
    let right: Vec<Vec<DVec2>> = poses.iter().map(|p| proj(&rig.right, &(rig.right_from_left * *p))).collect();
    let object = vec![b.object_points(); poses.len()];
    let res = calibrate_stereo(&object, &left, &right, (640, 480), (640, 480), &StereoConfig::default()).unwrap();
    let (da, dt) = res.rig.right_from_left.distance(&rig.right_from_left);
    let s = res.rig_std_devs;
    assert!(
        (res.rig.baseline() - rig.baseline()).abs() < 4.0 * s.baseline + 1e-9,
        "baseline {} σ {}",
        res.rig.baseline(),
        s.baseline
    );
    assert!((res.rig.baseline() - rig.baseline()).abs() < 0.2);
    assert!(da.to_degrees() < 0.05, "rotation error {}°", da.to_degrees());
    assert!(dt < 1.0);
    assert!((res.rig.right.intrinsics.fx / 530.0 - 1.0).abs() < 2e-3);
    assert!((res.left_rms_px - 0.1 * 2f64.sqrt()).abs() < 0.03 && (res.right_rms_px - 0.1 * 2f64.sqrt()).abs() < 0.03);
    // E and F: epipolar constraint on the true (noise-free) undistorted correspondences.
    let p = poses[3];
    for x in b.object_points().iter().take(10) {
        let xl = p.transform_point(*x);
        let xr = rig.right_from_left.transform_point(xl);
        let (nl, nr) = (xl / xl.z, xr / xr.z);
        assert!(nr.dot(res.essential * nl).abs() / res.rig.baseline() < 2e-4);
        let (ul, ur) = (rig.left.intrinsics.matrix() * nl, rig.right.intrinsics.matrix() * nr);
        let line = res.fundamental * ul;
        let dist = ur.dot(line).abs() / (line.x * line.x + line.y * line.y).sqrt();
        assert!(dist < 0.2, "epipolar distance {dist} px");
    }
    // Fixed intrinsics at the truth: only the rig and poses move.
    let fixed = StereoConfig {
        fix_intrinsics: true,
        left: CalibrationConfig { intrinsic_guess: Some(rig.left), ..Default::default() },
        right: CalibrationConfig { intrinsic_guess: Some(rig.right), ..Default::default() },
        ..Default::default()
    };
    let f = calibrate_stereo(&object, &left, &right, (640, 480), (640, 480), &fixed).unwrap();
    assert_eq!(f.rig.left, rig.left);
    assert!(f.left_std_devs.fx.is_none());
    assert_eq!(f.num_parameters, 6 + 6 * poses.len());
    assert!(f.rig.right_from_left.distance(&rig.right_from_left).0.to_degrees() < 0.05);
}

#[test]
fn dlt_recovers_k_r_t_from_a_non_planar_target() {
    let k = Intrinsics { fx: 800.0, fy: 790.0, cx: 330.0, cy: 250.0, skew: 0.5 };
    let pose = Isometry3::from_rvec_tvec(DVec3::new(0.2, -0.4, 0.1), DVec3::new(-100.0, -60.0, 700.0));
    let cam = Camera::new(k, Distortion::default(), 640, 480).unwrap();
    // Two orthogonal planes of a calibration box (the course notes' target).
    let mut obj = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            obj.push(DVec3::new(i as f64 * 40.0, j as f64 * 40.0, 0.0));
            obj.push(DVec3::new(0.0, j as f64 * 40.0, 40.0 + i as f64 * 40.0));
        }
    }
    let img: Vec<DVec2> = obj.iter().map(|x| cam.project_from(&pose, *x).unwrap()).collect();
    let d = calibrate_dlt(&obj, &img).unwrap();
    let e = d.intrinsics;
    assert!((e.fx - 800.0).abs() < 1e-6 && (e.fy - 790.0).abs() < 1e-6 && (e.skew - 0.5).abs() < 1e-6, "{e:?}");
    assert!((e.cx - 330.0).abs() < 1e-6 && (e.cy - 250.0).abs() < 1e-6);
    let (da, dt) = d.camera_from_world.distance(&pose);
    assert!(da < 1e-9 && dt < 1e-6);
    assert!(d.rms_px < 1e-8);
    // With noise: still close.
    let mut noisy = img.clone();
    add_pixel_noise(&mut noisy, 0.2, &mut rng(3));
    let d = calibrate_dlt(&obj, &noisy).unwrap();
    assert!((d.intrinsics.fx / 800.0 - 1.0).abs() < 0.01, "{:?}", d.intrinsics);
    assert!((d.rms_px - 0.2 * 2f64.sqrt()).abs() < 0.1);
    // Coplanar points and too few points are errors.
    let plane: Vec<DVec3> = obj.iter().copied().filter(|p| p.z == 0.0).collect();
    let pimg: Vec<DVec2> = plane.iter().map(|x| cam.project_from(&pose, *x).unwrap()).collect();
    assert!(matches!(calibrate_dlt(&plane, &pimg), Err(CalibrationError::Degenerate(_))));
    assert!(matches!(calibrate_dlt(&obj[..5], &img[..5]), Err(CalibrationError::TooFewPoints { .. })));
    // RQ of a known product.
    let r = Isometry3::from_rvec_tvec(DVec3::new(0.3, 0.1, -0.2), DVec3::ZERO).rotation_matrix();
    let (kk, rr) = rq_decomposition(k.matrix() * r).unwrap();
    assert!((kk - k.matrix()).abs_diff_eq(glam::DMat3::ZERO, 1e-9) && (rr - r).abs_diff_eq(glam::DMat3::ZERO, 1e-12));
}

#[test]
fn pnp_recovers_the_pose_with_distortion_and_noise() {
    let cam = truth_camera();
    let b = board();
    for (seed, pose) in tilted_poses(&cam, &b, 5, 77).iter().enumerate() {
        let mut px: Vec<DVec2> = b.object_points().iter().map(|x| cam.project_from(pose, *x).unwrap()).collect();
        let (exact, rms) = solve_pnp_planar(&cam, &b, &px).unwrap();
        let (da, dt) = exact.distance(pose);
        assert!(da < 1e-9 && dt < 1e-6 && rms < 1e-8, "{da} {dt} {rms}");
        add_pixel_noise(&mut px, 0.2, &mut rng(seed as u64));
        let (est, rms) = solve_pnp_planar(&cam, &b, &px).unwrap();
        let (da, dt) = est.distance(pose);
        assert!(da < 3e-3 && dt < 2.0, "{da} {dt}");
        assert!((rms - 0.2 * 2f64.sqrt()).abs() < 0.08, "rms {rms}");
    }
    assert!(matches!(solve_pnp_planar(&cam, &b, &[DVec2::ZERO; 5]), Err(CalibrationError::SizeMismatch(_))));
}
