//! Noise-free synthetic input: every method recovers the truth; degenerate input errors or
//! is flagged, never NaN.

mod common;

use common::*;
use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, DisparityMap, Distortion, Intrinsics, Isometry3, ProjectionMatrix};
use parallax_triangulation::*;

const METHODS: [Method; 4] = [Method::Linear, Method::Dlt, Method::Midpoint, Method::Optimal];

#[test]
fn every_method_recovers_noise_free_points_on_a_distorted_verged_rig() {
    for rig in [general_rig(), rectified_rig()] {
        let mut rng = rng(1);
        let mut worst = [0.0f64; 4];
        for k in 0..200 {
            let z = 300.0 + 700.0 * (k as f64 / 199.0);
            let truth = random_point(&mut rng, z);
            let (l, r) = project_pair(&rig, truth);
            for (m, method) in METHODS.iter().enumerate() {
                let p = triangulate_stereo(&rig, l, r, &TriangulationConfig::with_method(*method)).unwrap();
                worst[m] = worst[m].max((p.point - truth).length() / truth.length());
                assert!(p.is_reliable());
                assert!(p.rms_reprojection_error < 1e-6, "{method:?}: {}", p.rms_reprojection_error);
            }
        }
        for (m, w) in worst.iter().enumerate() {
            assert!(*w < 1e-9, "{:?}: worst relative error {w:e}", METHODS[m]);
        }
    }
}

#[test]
fn n_view_triangulation_recovers_noise_free_points() {
    let rig = general_rig();
    let third_cam = Camera::new(
        Intrinsics::new(900.0, 900.0, 600.0, 500.0),
        Distortion::new(0.05, -0.02, 0.0, 0.0, 0.0),
        1280,
        960,
    )
    .unwrap();
    // A third camera above the rig looking down 10°.
    let third_from_world =
        Isometry3::from_rvec_tvec(DVec3::new(-10f64.to_radians(), 0.0, 0.0), DVec3::new(-50.0, 80.0, 10.0));
    let views = [stereo_views(&rig)[0], stereo_views(&rig)[1], View::new(third_cam, third_from_world)];
    let mut rng = rng(2);
    for _ in 0..50 {
        let truth = random_point(&mut rng, 600.0);
        let pixels: Vec<DVec2> =
            views.iter().map(|v| v.camera.project(v.camera_from_world.transform_point(truth)).unwrap()).collect();
        for method in METHODS {
            let p = triangulate(&views, &pixels, &TriangulationConfig::with_method(method)).unwrap();
            assert!((p.point - truth).length() / truth.length() < 1e-9, "{method:?}");
            assert_eq!(p.reprojection_errors.len(), 3);
        }
    }
}

#[test]
fn thesis_linear_form_matches_known_projection_matrices() {
    // Two pinhole cameras given by projection matrices only (as a user of OpenCV's P1, P2 would).
    let rig = rectified_rig();
    let (p1, p2) = rig.projection_matrices();
    let truth = DVec3::new(-120.0, 85.0, 730.0);
    let a = p1.project(truth).unwrap();
    let b = p2.project(truth).unwrap();
    let x = linear_from_projections(&[p1, p2], &[a, b]).unwrap();
    assert!((x - truth).length() < 1e-9 * truth.length());
    let x = dlt_from_projections(&[p1, p2], &[a, b]).unwrap();
    assert!((x - truth).length() < 1e-9 * truth.length());
    // Parallax method: d = u_l − u_r, Z = f b / d.
    let d = a.x - b.x;
    let x = parallax_point(a.x, a.y, d, FOCAL, 640.0, 480.0, BASELINE).unwrap();
    assert!((x - truth).length() < 1e-9 * truth.length());
    // Q form from the rectified projection matrices equals the parallax form.
    let q = ReprojectionMatrix::from_projection_matrices(&p1, &p2).unwrap();
    let y = q.reproject(a.x, a.y, d).unwrap();
    assert!((y - truth).length() < 1e-9 * truth.length());
}

#[test]
fn q_matrix_with_different_principal_points_matches_triangulation() {
    // Rectified rig whose right principal point differs (OpenCV without CALIB_ZERO_DISPARITY).
    let k1 = Intrinsics::new(700.0, 700.0, 320.0, 240.0);
    let k2 = Intrinsics::new(700.0, 700.0, 300.0, 240.0);
    let right_from_left = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(-60.0, 0.0, 0.0));
    let p1 = ProjectionMatrix::new(k1.matrix(), &Isometry3::IDENTITY);
    let p2 = ProjectionMatrix::new(k2.matrix(), &right_from_left);
    let q1 = ReprojectionMatrix::from_projection_matrices(&p1, &p2).unwrap();
    let q2 = ReprojectionMatrix::from_rectified(700.0, 320.0, 240.0, 300.0, 60.0).unwrap();
    assert_eq!(q1, q2);
    for truth in [DVec3::new(10.0, 20.0, 400.0), DVec3::new(-150.0, 90.0, 2500.0)] {
        let a = p1.project(truth).unwrap();
        let b = p2.project(truth).unwrap();
        let y = q1.reproject(a.x, a.y, a.x - b.x).unwrap();
        assert!((y - truth).length() < 1e-9 * truth.length(), "{y} vs {truth}");
        // glam form of Q gives the same homogeneous vector.
        let h = q1.matrix() * glam::DVec4::new(a.x, a.y, a.x - b.x, 1.0);
        assert!((h.truncate() / h.w - truth).length() < 1e-9 * truth.length());
    }
}

#[test]
fn zero_disparity_parallel_rays_and_nan_pixels_are_errors() {
    let rig = rectified_rig();
    let px = DVec2::new(700.0, 400.0);
    for method in METHODS {
        let cfg = TriangulationConfig::with_method(method);
        let e = triangulate_stereo(&rig, px, px, &cfg).unwrap_err();
        assert!(matches!(e, TriangulationError::ParallelRays { .. }), "{method:?}: {e}");
        let e = triangulate_stereo(&rig, DVec2::new(f64::NAN, 1.0), px, &cfg).unwrap_err();
        assert!(matches!(e, TriangulationError::NonFinite { .. }), "{method:?}: {e}");
        let e = triangulate_stereo(&rig, px, DVec2::new(3.0, f64::INFINITY), &cfg).unwrap_err();
        assert!(matches!(e, TriangulationError::NonFinite { .. }), "{method:?}: {e}");
    }
    // Low-level forms: identical pixels in a rectified pair give a rank-deficient / infinite system.
    let (p1, p2) = rig.projection_matrices();
    assert!(linear_from_projections(&[p1, p2], &[px, px]).is_err());
    assert!(dlt_from_projections(&[p1, p2], &[px, px]).is_err());
    assert!(midpoint_from_rays(&[DVec3::ZERO, DVec3::X], &[DVec3::Z, DVec3::Z]).is_err());
    assert!(parallax_point(1.0, 2.0, 0.0, FOCAL, 640.0, 480.0, BASELINE).is_err());
    assert!(parallax_point(1.0, 2.0, f64::NAN, FOCAL, 640.0, 480.0, BASELINE).is_err());
    let q = ReprojectionMatrix::from_rectified(FOCAL, 640.0, 480.0, 640.0, BASELINE).unwrap();
    assert!(q.reproject(1.0, 2.0, 0.0).is_err());
    assert!(q.reproject(1.0, 2.0, -3.0).is_err());
    // Wrong counts.
    let v = stereo_views(&rig);
    assert!(matches!(
        triangulate(&v[..1], &[px], &TriangulationConfig::default()),
        Err(TriangulationError::TooFew { .. })
    ));
    assert!(matches!(
        triangulate(&v, &[px], &TriangulationConfig::default()),
        Err(TriangulationError::SizeMismatch(_))
    ));
}

#[test]
fn points_behind_the_rig_and_far_points_are_flagged_not_nan() {
    let rig = rectified_rig();
    // Negative disparity: the rays meet behind the cameras.
    let l = DVec2::new(600.0, 500.0);
    let r = DVec2::new(620.0, 500.0);
    for method in METHODS {
        let p = triangulate_stereo(&rig, l, r, &TriangulationConfig::with_method(method)).unwrap();
        assert!(p.point.is_finite(), "{method:?}");
        assert!(p.behind_camera, "{method:?}: {p:?}");
        assert!(p.point.z < 0.0);
        assert!(p.reprojection_errors.iter().all(|e| !e.is_nan()));
        assert!(p.covariance.is_none());
        assert!(!p.is_reliable());
    }
    // 20 m away on the left optical axis, 100 mm baseline: parallax atan(0.1/20) = 0.29° < 1°.
    let truth = DVec3::new(0.0, 0.0, 20_000.0);
    let (l, r) = project_pair(&rig, truth);
    let p = triangulate_stereo(&rig, l, r, &TriangulationConfig::default()).unwrap();
    assert!((p.parallax_deg - (BASELINE / 20_000.0).atan().to_degrees()).abs() < 1e-6);
    assert!(p.low_parallax && !p.behind_camera);
    assert!((p.point - truth).length() < 1e-9 * truth.length());
}

#[test]
fn disparity_map_to_point_cloud_skips_and_counts_invalid_pixels() {
    let (w, h) = (64usize, 48usize);
    let q = ReprojectionMatrix::from_rectified(FOCAL, 31.5, 23.5, 29.0, BASELINE).unwrap();
    let mut map = DisparityMap::new_invalid(w, h);
    let mut expect_valid = 0;
    for v in 0..h {
        for u in 0..w {
            let d = match (u + 3 * v) % 7 {
                0 => None,          // invalid
                1 => Some(0.0f32),  // zero disparity (+ offset cx − cx' = 2.5 px: W < 0)
                2 => Some(-4.0f32), // negative
                _ => {
                    expect_valid += 1;
                    Some(10.0 + (u as f32) * 0.25 + (v as f32) * 0.1)
                }
            };
            map.set(u, v, d);
        }
    }
    let grey: Vec<u8> = (0..w * h).map(|i| (i % 251) as u8).collect();
    let cfg = CloudConfig::default();
    let cloud = disparity_to_point_cloud(&map, &q, &cfg, Some(PixelColors::Grey(&grey))).unwrap();
    assert_eq!(cloud.len(), expect_valid);
    assert_eq!(cloud.len() + cloud.skipped_invalid + cloud.skipped_non_positive + cloud.skipped_far, w * h);
    assert_eq!(cloud.skipped_invalid, map.data().len() - map.valid_count());
    assert!(cloud.points.iter().all(|p| p.is_finite() && p.z > 0.0));
    let PointColors::Grey(g) = &cloud.colors else { panic!("grey expected") };
    for ((p, px), c) in cloud.points.iter().zip(&cloud.pixels).zip(g) {
        let (u, v) = (px[0] as usize, px[1] as usize);
        let d = map.get(u, v).unwrap() as f64;
        // Q with cx − cx' = 2.5 px: the parallax form with d − 2.5.
        let e = parallax_point(u as f64, v as f64, d - 2.5, FOCAL, 31.5, 23.5, BASELINE).unwrap();
        assert!((*p - e).length() < 1e-9 * e.length());
        assert_eq!(*c, grey[v * w + u]);
    }
    // Depth cap.
    let near = disparity_to_point_cloud(&map, &q, &CloudConfig { max_depth: 5000.0, ..cfg }, None).unwrap();
    assert!(near.skipped_far > 0 && near.points.iter().all(|p| p.z <= 5000.0));
    assert_eq!(near.len() + near.skipped_far, cloud.len());
    // Size mismatch of the colour image is an error.
    assert!(disparity_to_point_cloud(&map, &q, &cfg, Some(PixelColors::Grey(&grey[1..]))).is_err());
}

#[test]
fn covariance_matches_the_rectified_closed_form() {
    // Rectified rig: σ_Z = Z² σ_d / (f b) with σ_d = √2 σ, and the full parallax covariance.
    let rig = rectified_rig();
    let cfg = TriangulationConfig { pixel_sigma: 0.1, ..Default::default() };
    for z in [300.0, 500.0, 1000.0] {
        let truth = DVec3::new(40.0, -30.0, z);
        let (l, r) = project_pair(&rig, truth);
        let p = triangulate_stereo(&rig, l, r, &cfg).unwrap();
        let sz = p.std_devs().unwrap().z;
        let expect = depth_std_dev(z, FOCAL, BASELINE, 2f64.sqrt() * 0.1);
        assert!((sz / expect - 1.0).abs() < 1e-6, "z = {z}: {sz} vs {expect}");
        // Closed form: the left pixel (u, v) and the disparity; the right v is a second
        // measurement of v, so use the exact 4-observation covariance from the point Jacobian.
        let c = point_covariance(&stereo_views(&rig), truth, 0.1).unwrap();
        assert!((c - p.covariance.unwrap()).abs().to_cols_array().iter().all(|v| *v < 1e-12));
    }
    // The figures: 0.16 mm at 0.3 m, 0.44 mm at 0.5 m, 1.8 mm at 1 m.
    let s = |z: f64| depth_std_dev(z, FOCAL, BASELINE, 2f64.sqrt() * 0.1);
    assert!((s(300.0) - 0.159).abs() < 0.001 && (s(500.0) - 0.442).abs() < 0.001 && (s(1000.0) - 1.768).abs() < 0.001);
}

#[test]
fn measure_stereo_reports_points_and_all_pairwise_distances() {
    // The thesis's ranging experiment: four targets, the lengths between them.
    let rig = general_rig();
    let targets = [
        DVec3::new(0.0, 0.0, 600.0),
        DVec3::new(120.0, 0.0, 610.0),
        DVec3::new(120.0, 90.0, 620.0),
        DVec3::new(0.0, 90.0, 630.0),
    ];
    let pairs: Vec<(DVec2, DVec2)> = targets.iter().map(|t| project_pair(&rig, *t)).collect();
    let m = measure_stereo(&rig, &pairs, &TriangulationConfig::default()).unwrap();
    assert_eq!(m.points.len(), 4);
    assert_eq!(m.distances.len(), 6);
    for p in &m.points {
        assert!((p.point - targets[p.index]).length() < 1e-9 * 600.0);
        let sz = p.std_dev.expect("a point in front of both cameras has a covariance").z;
        assert!(sz > 0.0 && sz < 1.0);
    }
    for d in &m.distances {
        let expect = (targets[d.to] - targets[d.from]).length();
        assert!((d.distance - expect).abs() < 1e-8, "{d:?} vs {expect}");
        let sd = d.std_dev.expect("distinct points in front of the cameras have a σ");
        assert!(sd > 0.0 && sd < 1.0);
    }
    // No σ is invented: without covariances every σ is absent, the distances are unchanged.
    let bare = measure_stereo(&rig, &pairs, &TriangulationConfig { covariance: false, ..Default::default() }).unwrap();
    assert!(bare.points.iter().all(|p| p.std_dev.is_none()) && bare.distances.iter().all(|d| d.std_dev.is_none()));
    for (a, b) in bare.distances.iter().zip(&m.distances) {
        assert!((a.distance - b.distance).abs() < 1e-9);
    }
    // The batch form gives the same points as one call per pair.
    let batch = triangulate_stereo_batch(&rig, &pairs, &TriangulationConfig::default());
    for (b, p) in batch.iter().zip(&m.points) {
        assert_eq!(b.as_ref().unwrap().point, p.point);
    }
    // Bad input names the pair.
    let mut bad = pairs.clone();
    bad[2].1.x = f64::NAN;
    let e = measure_stereo(&rig, &bad, &TriangulationConfig::default()).unwrap_err().to_string();
    assert!(e.contains("pair 2"), "{e}");
    assert!(measure_stereo(&rig, &[], &TriangulationConfig::default()).is_err());
}

#[test]
fn pixels_off_their_epipolar_lines_are_flagged_with_the_reprojection_error_that_shows_it() {
    // a right pixel on the wrong row used to give a confident point (and distances) with no
    // flag: the reprojection error of the compromise is the only sign
    let rig = general_rig();
    let truth = DVec3::new(40.0, -30.0, 700.0);
    let (l, r) = project_pair(&rig, truth);
    let cfg = TriangulationConfig::default();
    let ok = triangulate_stereo(&rig, l, r, &cfg).unwrap();
    assert!(!ok.high_reprojection && ok.is_reliable() && ok.rms_reprojection_error < 1e-6);
    for (dv, flagged) in [(0.5, false), (1.5, false), (3.0, true), (50.0, true)] {
        // moved along v: ~dv px off the epipolar line (the rig is near-horizontal)
        let p = triangulate_stereo(&rig, l, r + DVec2::new(0.0, dv), &cfg).unwrap();
        assert_eq!(p.high_reprojection, flagged, "dv {dv}: rms {}", p.rms_reprojection_error);
        assert_eq!(p.high_reprojection, p.rms_reprojection_error > cfg.max_reprojection_px);
        assert_eq!(p.is_reliable(), !flagged);
    }
    // the flag reaches the measurement, its CSV, and can be turned off
    let far = (l, r + DVec2::new(0.0, 50.0));
    let m = measure_stereo(&rig, &[(l, r), far], &cfg).unwrap();
    assert_eq!(m.points.iter().map(|p| p.high_reprojection).collect::<Vec<_>>(), [false, true]);
    let csv = m.points_csv();
    assert!(csv.lines().next().unwrap().ends_with(",high_reprojection"), "{csv}");
    assert!(csv.lines().nth(2).unwrap().ends_with(",true"), "{csv}");
    let off = TriangulationConfig { max_reprojection_px: f64::INFINITY, ..cfg };
    assert!(!measure_stereo(&rig, &[far], &off).unwrap().points[0].high_reprojection);
    for bad in [0.0, -1.0, f64::NAN] {
        let c = TriangulationConfig { max_reprojection_px: bad, ..cfg };
        assert!(triangulate_stereo(&rig, l, r, &c).is_err(), "{bad}");
    }
}
