//! Worked examples, bad input and analytic Jacobians against central finite differences.

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, CameraModelError, Distortion, Intrinsics, Isometry3, StereoRig};

fn pinhole(fx: f64, fy: f64, cx: f64, cy: f64) -> Camera {
    Camera::new(Intrinsics::new(fx, fy, cx, cy), Distortion::default(), 1280, 960).unwrap()
}

/// The course notes' worked examples (values follow from the stated K; see issue 2).
#[test]
fn worked_examples_from_the_course_notes() {
    let cases = [
        (
            pinhole(800.0, 800.0, 512.0, 384.0),
            DVec3::new(0.02, 0.05, 1.2),
            DVec2::new(525.333_333_333, 417.333_333_333),
        ),
        (
            pinhole(800.0, 800.0, 600.0, 400.0),
            DVec3::new(0.02, 0.05, 1.2),
            DVec2::new(613.333_333_333, 433.333_333_333),
        ),
        (
            Camera::new(
                Intrinsics::from_focal_length_and_pixel_pitch(3e-3, 3e-6, 620.0, 410.0),
                Distortion::default(),
                1280,
                960,
            )
            .unwrap(),
            DVec3::new(0.015, 0.02, 2.0),
            DVec2::new(627.5, 420.0),
        ),
    ];
    for (camera, point, expected) in cases {
        let p = camera.project(point).unwrap();
        assert!((p - expected).length() < 1e-6, "{p} vs {expected}");
    }
}

/// Expected pixels computed by OpenCV 5.0.0 `cv2.projectPoints` (opencv-python-headless; script in the file header of `opencv_project_points.in`) for the
/// listed K, distortion, rvec, tvec and object points — independent of this code.
#[test]
fn agrees_with_opencv_project_points() {
    let camera = Camera::new(
        Intrinsics::new(533.0, 533.5, 341.6, 234.3),
        Distortion::new(-0.28, 0.12, 0.0012, -0.0007, -0.03),
        640,
        480,
    )
    .unwrap();
    let camera_from_board = Isometry3::from_rvec_tvec(DVec3::new(0.2, -0.3, 0.1), DVec3::new(-60.0, -40.0, 400.0));
    let rational = Camera::new(
        camera.intrinsics,
        Distortion { k4: 0.05, k5: -0.01, k6: 0.002, ..*camera.distortion().unwrap() },
        640,
        480,
    )
    .unwrap();
    let points = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(150.0, 0.0, 0.0),
        DVec3::new(0.0, 120.0, 0.0),
        DVec3::new(210.0, 150.0, 30.0),
    ];
    let expected = include!("opencv_project_points.in");
    for (i, p) in points.iter().enumerate() {
        let a = camera.project_from(&camera_from_board, *p).unwrap();
        let b = rational.project_from(&camera_from_board, *p).unwrap();
        assert!(
            (a - DVec2::from(expected[0][i])).length() < 1e-6,
            "5-coefficient point {i}: {a} vs {:?}",
            expected[0][i]
        );
        assert!((b - DVec2::from(expected[1][i])).length() < 1e-6, "rational point {i}: {b} vs {:?}", expected[1][i]);
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let bad_focal = Camera::new(Intrinsics::new(0.0, 800.0, 320.0, 240.0), Distortion::default(), 640, 480);
    assert!(matches!(bad_focal, Err(CameraModelError::InvalidFocalLength { .. })));
    let nan = Camera::new(Intrinsics::new(800.0, 800.0, f64::NAN, 240.0), Distortion::default(), 640, 480);
    assert!(matches!(nan, Err(CameraModelError::NonFinite { .. })));
    let nan_dist = Camera::new(
        Intrinsics::new(800.0, 800.0, 320.0, 240.0),
        Distortion::new(f64::INFINITY, 0.0, 0.0, 0.0, 0.0),
        640,
        480,
    );
    assert!(matches!(nan_dist, Err(CameraModelError::NonFinite { .. })));
    assert!(matches!(
        Camera::new(Intrinsics::new(800.0, 800.0, 320.0, 240.0), Distortion::default(), 0, 480),
        Err(CameraModelError::InvalidImageSize { .. })
    ));
    let camera = pinhole(800.0, 800.0, 320.0, 240.0);
    assert!(matches!(camera.project(DVec3::new(0.0, 0.0, -1.0)), Err(CameraModelError::PointBehindCamera { .. })));
    assert!(matches!(camera.project(DVec3::new(0.0, 0.0, 0.0)), Err(CameraModelError::PointBehindCamera { .. })));
    assert!(matches!(camera.project(DVec3::new(f64::NAN, 0.0, 1.0)), Err(CameraModelError::NonFinite { .. })));
    assert!(matches!(camera.unproject(DVec2::new(f64::NAN, 0.0)), Err(CameraModelError::NonFinite { .. })));
    assert!(matches!(
        Isometry3::from_rotation_translation(glam::DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0)), DVec3::ZERO),
        Err(CameraModelError::NotARotation { .. })
    ));
    // Far outside the invertible region of a strongly folding lens: reported, not looped or NaN.
    let folding =
        Camera::new(Intrinsics::new(500.0, 500.0, 320.0, 240.0), Distortion::new(-0.9, 0.0, 0.0, 0.0, 0.0), 640, 480)
            .unwrap();
    assert!(matches!(
        folding.unproject(DVec2::new(320.0 + 500.0 * 3.0, 240.0)),
        Err(CameraModelError::UndistortionDidNotConverge { .. })
    ));
}

fn rel_err(analytic: f64, numeric: f64, scale: f64) -> f64 {
    (analytic - numeric).abs() / scale.max(1e-300)
}

/// Every analytic Jacobian against central differences; relative error (to the largest entry of
/// the Jacobian row) ≤ 1e-6.
#[test]
fn analytic_jacobians_match_central_differences() {
    let cameras = [
        Camera::new(
            Intrinsics { fx: 812.0, fy: 806.0, cx: 330.0, cy: 250.0, skew: 1.5 },
            Distortion::new(-0.31, 0.12, 0.002, -0.001, -0.02),
            640,
            480,
        )
        .unwrap(),
        Camera::new(
            Intrinsics::new(600.0, 600.0, 320.0, 240.0),
            Distortion { k1: 0.4, k2: -0.1, p1: -0.003, p2: 0.004, k3: 0.02, k4: 0.3, k5: -0.05, k6: 0.01 },
            640,
            480,
        )
        .unwrap(),
    ];
    let pose = Isometry3::from_rvec_tvec(DVec3::new(0.3, -0.2, 0.15), DVec3::new(-0.05, 0.04, 0.6));
    let points = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.12, -0.07, 0.05), DVec3::new(-0.1, 0.09, -0.02)];
    let h = 1e-6;
    for camera in &cameras {
        for &p in &points {
            let j = camera.project_with_jacobians(&pose, p).unwrap();
            let check = |label: &str, analytic: [f64; 2], f: &dyn Fn(f64) -> DVec2, row_scale: [f64; 2]| {
                let num = (f(h) - f(-h)) / (2.0 * h);
                for r in 0..2 {
                    let e = rel_err(analytic[r], num[r], row_scale[r]);
                    assert!(e <= 1e-6, "{label} row {r}: analytic {} numeric {} (rel {e:e})", analytic[r], num[r]);
                }
            };
            let scale = |rows: &[&[f64]; 2]| [0, 1].map(|r| rows[r].iter().fold(0.0f64, |a, v| a.max(v.abs())));
            // point
            let s = scale(&[&j.d_point[0], &j.d_point[1]]);
            for c in 0..3 {
                let f = |e: f64| {
                    let mut q = p;
                    q[c] += e;
                    camera.project_from(&pose, q).unwrap()
                };
                check("d_point", [j.d_point[0][c], j.d_point[1][c]], &f, s);
            }
            // pose (left perturbation of Isometry3::retract)
            let s = scale(&[&j.d_pose[0], &j.d_pose[1]]);
            for c in 0..6 {
                let f = |e: f64| {
                    let mut d = [0.0; 6];
                    d[c] = e;
                    camera.project_from(&pose.retract(&d), p).unwrap()
                };
                check("d_pose", [j.d_pose[0][c], j.d_pose[1][c]], &f, s);
            }
            // intrinsics (fx, fy, cx, cy, skew)
            let s = scale(&[&j.d_intrinsics[0], &j.d_intrinsics[1]]);
            for c in 0..5 {
                let f = |e: f64| {
                    let mut cam = *camera;
                    let k = &mut cam.intrinsics;
                    match c {
                        0 => k.fx += e,
                        1 => k.fy += e,
                        2 => k.cx += e,
                        3 => k.cy += e,
                        _ => k.skew += e,
                    }
                    cam.project_from(&pose, p).unwrap()
                };
                check("d_intrinsics", [j.d_intrinsics[0][c], j.d_intrinsics[1][c]], &f, s);
            }
            // distortion (k1, k2, p1, p2, k3, k4, k5, k6)
            let s = scale(&[&j.d_distortion[0], &j.d_distortion[1]]);
            for c in 0..8 {
                let f = |e: f64| {
                    let mut cam = *camera;
                    let mut a = cam.distortion().unwrap().to_array();
                    a[c] += e;
                    cam.lens = Distortion::from_array(a).into();
                    cam.project_from(&pose, p).unwrap()
                };
                check("d_distortion", [j.d_distortion[0][c], j.d_distortion[1][c]], &f, s);
            }
        }
    }
}

#[test]
fn epipolar_constraint_holds_for_essential_and_fundamental() {
    let left = Camera::new(Intrinsics::new(700.0, 705.0, 320.0, 240.0), Distortion::default(), 640, 480).unwrap();
    let right = Camera::new(Intrinsics::new(690.0, 688.0, 330.0, 235.0), Distortion::default(), 640, 480).unwrap();
    let rig = StereoRig::new(
        left,
        right,
        Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.05, 0.02), DVec3::new(-0.12, 0.003, 0.001)),
    )
    .unwrap();
    assert!((rig.baseline() - (0.12f64 * 0.12 + 0.003 * 0.003 + 0.001 * 0.001).sqrt()).abs() < 1e-15);
    let (p1, p2) = rig.projection_matrices();
    for x in [DVec3::new(0.1, 0.2, 1.5), DVec3::new(-0.3, 0.05, 2.5), DVec3::new(0.0, -0.1, 0.8)] {
        let xl = x / x.z;
        let xr_cam = rig.right_from_left.transform_point(x);
        let xr = xr_cam / xr_cam.z;
        assert!(xr.dot(rig.essential() * xl).abs() < 1e-12);
        let pl = left.project(x).unwrap().extend(1.0);
        let pr = right.project(xr_cam).unwrap().extend(1.0);
        assert!(pr.dot(rig.fundamental() * pl).abs() < 1e-9);
        // P = K [R | t] reproduces the camera projection.
        assert!((p1.project(x).unwrap() - pl.truncate()).length() < 1e-9);
        assert!((p2.project(x).unwrap() - pr.truncate()).length() < 1e-9);
    }
}

#[test]
fn serde_round_trip_of_a_rig() {
    let cam = Camera::new(
        Intrinsics::new(700.0, 705.0, 320.0, 240.0),
        Distortion::new(-0.2, 0.05, 0.001, 0.0, 0.0),
        640,
        480,
    )
    .unwrap();
    let rig =
        StereoRig::new(cam, cam, Isometry3::from_rvec_tvec(DVec3::new(0.01, 0.02, 0.03), DVec3::new(-0.1, 0.0, 0.0)))
            .unwrap();
    let text = ron::to_string(&rig).unwrap();
    let back: StereoRig = ron::from_str(&text).unwrap();
    assert_eq!(rig, back);
}
