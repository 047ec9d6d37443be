//! View sets, noise helpers and hand-eye trajectories against independent computations.

use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_synthetic::*;

fn camera() -> Camera {
    Camera::new(
        Intrinsics::new(800.0, 790.0, 322.0, 241.0),
        Distortion::new(-0.12, 0.08, 0.001, -0.0005, 0.0),
        640,
        480,
    )
    .unwrap()
}

fn board() -> Chessboard {
    Chessboard::new(9, 6, 25.0).unwrap()
}

/// Pinhole + Brown–Conrady written out independently of camera-model.
fn reference_projection(c: &Camera, p: DVec3) -> DVec2 {
    let (x, y) = (p.x / p.z, p.y / p.z);
    let d = c.distortion().copied().unwrap();
    let r2 = x * x + y * y;
    let radial = 1.0 + d.k1 * r2 + d.k2 * r2 * r2 + d.k3 * r2 * r2 * r2;
    let xd = x * radial + 2.0 * d.p1 * x * y + d.p2 * (r2 + 2.0 * x * x);
    let yd = y * radial + d.p1 * (r2 + 2.0 * y * y) + 2.0 * d.p2 * x * y;
    let k = c.intrinsics;
    DVec2::new(k.fx * xd + k.skew * yd + k.cx, k.fy * yd + k.cy)
}

#[test]
fn rng_is_deterministic_and_seed_dependent() {
    use rand::Rng;
    let a: Vec<u64> = (0..8)
        .map({
            let mut r = rng(7);
            move |_| r.random()
        })
        .collect();
    let b: Vec<u64> = (0..8)
        .map({
            let mut r = rng(7);
            move |_| r.random()
        })
        .collect();
    let c: Vec<u64> = (0..8)
        .map({
            let mut r = rng(8);
            move |_| r.random()
        })
        .collect();
    assert_eq!(a, b);
    assert_ne!(a, c);
}

#[test]
fn pixel_noise_has_the_requested_sigma() {
    let n = 20_000;
    let mut pts = vec![DVec2::new(10.0, -5.0); n];
    add_pixel_noise(&mut pts, 0.5, &mut rng(3));
    let mean = pts.iter().fold(DVec2::ZERO, |a, p| a + *p) / n as f64;
    let var = pts.iter().fold(DVec2::ZERO, |a, p| a + (*p - mean) * (*p - mean)) / (n - 1) as f64;
    // Standard error of the mean: 0.5/sqrt(20000) = 0.0035; of the std: 0.5/sqrt(40000) = 0.0025.
    assert!((mean - DVec2::new(10.0, -5.0)).abs().max_element() < 0.015, "mean {mean}");
    assert!((var.x.sqrt() - 0.5).abs() < 0.012 && (var.y.sqrt() - 0.5).abs() < 0.012, "std {var}");
    let mut same = vec![DVec2::new(1.0, 2.0); 3];
    add_pixel_noise(&mut same, 0.0, &mut rng(3));
    assert_eq!(same, vec![DVec2::new(1.0, 2.0); 3]);
}

#[test]
fn pose_noise_is_right_multiplied_with_the_requested_sigma() {
    let pose = Isometry3::from_rvec_tvec(DVec3::new(0.3, -1.2, 0.4), DVec3::new(0.2, 0.1, 0.8));
    let mut r = rng(11);
    let n = 10_000;
    let (sr, st) = (0.01, 0.002);
    let mut sum_w2 = DVec3::ZERO;
    let mut sum_v2 = DVec3::ZERO;
    for _ in 0..n {
        let noisy = perturb_pose(&pose, sr, st, &mut r);
        // Right-multiplied: pose⁻¹ · noisy = Exp(ω, v), whose translation is v itself.
        let delta = pose.inverse() * noisy;
        sum_w2 += delta.rvec() * delta.rvec();
        sum_v2 += delta.translation * delta.translation;
    }
    let std_w = (sum_w2 / n as f64).to_array().map(f64::sqrt);
    let std_v = (sum_v2 / n as f64).to_array().map(f64::sqrt);
    for k in 0..3 {
        assert!((std_w[k] / sr - 1.0).abs() < 0.04, "rotation std {std_w:?}");
        assert!((std_v[k] / st - 1.0).abs() < 0.04, "translation std {std_v:?}");
    }
    assert_eq!(perturb_pose(&pose, 0.0, 0.0, &mut r), pose);
}

#[test]
fn project_corners_matches_the_camera_model_to_1e9_px() {
    let cam = camera();
    let b = board();
    let poses = calibration_poses(&cam, &b, &ViewSetConfig::default()).unwrap();
    for pose in &poses {
        let corners = project_corners(&cam, &b, pose).unwrap();
        assert_eq!(corners.len(), b.len());
        for (c, p) in corners.iter().zip(b.object_points()) {
            let r = reference_projection(&cam, pose.transform_point(p));
            assert!((*c - r).length() <= 1e-9, "corner {c} vs reference {r}");
            let m = cam.project_from(pose, p).unwrap();
            assert!((*c - m).length() <= 1e-9);
        }
    }
}

fn tilt_deg(pose: &Isometry3) -> f64 {
    pose.transform_vector(DVec3::Z).z.clamp(-1.0, 1.0).acos().to_degrees()
}

#[test]
fn calibration_views_are_visible_varied_and_reproducible() {
    let cam = camera();
    let b = board();
    let cfg = ViewSetConfig { views: 15, ..Default::default() };
    let poses = calibration_poses(&cam, &b, &cfg).unwrap();
    assert_eq!(poses, calibration_poses(&cam, &b, &cfg).unwrap(), "same seed, same poses");
    assert_ne!(poses, calibration_poses(&cam, &b, &ViewSetConfig { seed: 2, ..cfg.clone() }).unwrap());
    let s = b.square_size;
    let centre = DVec3::new(4.0 * s, 2.5 * s, 0.0);
    let mut tilts = vec![];
    let (mut umin, mut umax) = (f64::MAX, f64::MIN);
    for pose in &poses {
        // Whole board plus its border (1.5 squares) inside by margin_px.
        let outer = [(-1.5, -1.5), (9.5, -1.5), (9.5, 6.5), (-1.5, 6.5)];
        for (x, y) in outer.iter().map(|&(x, y)| (x * s, y * s)) {
            let px = cam.project_from(pose, DVec3::new(x, y, 0.0)).unwrap();
            assert!(px.x >= 4.0 && px.y >= 4.0 && px.x <= 635.0 && px.y <= 475.0, "outer corner {px}");
        }
        let d = pose.transform_point(centre).length();
        assert!((300.0..=600.0).contains(&d), "distance {d}");
        let t = tilt_deg(pose);
        assert!(t <= 50.0 + 1e-9, "tilt {t}");
        tilts.push(t);
        let c = cam.project_from(pose, centre).unwrap();
        umin = umin.min(c.x);
        umax = umax.max(c.x);
    }
    let max_tilt = tilts.iter().cloned().fold(0.0, f64::max);
    assert!(max_tilt > 30.0, "tilts not varied: {tilts:?}");
    assert!(umax - umin > 100.0, "positions not spread: {umin}..{umax}");
}

#[test]
fn partial_views_show_part_of_the_board() {
    let cam = camera();
    let b = board();
    let cfg = ViewSetConfig { views: 6, allow_partial: true, ..Default::default() };
    let poses = calibration_poses(&cam, &b, &cfg).unwrap();
    for (i, pose) in poses.iter().enumerate() {
        let inside = project_corners(&cam, &b, pose).unwrap().iter().filter(|c| cam.contains(**c)).count();
        if i % 3 == 2 {
            assert!(inside < b.len() && inside * 10 >= b.len() * 3, "view {i}: {inside} corners inside");
        } else {
            assert_eq!(inside, b.len());
        }
    }
}

#[test]
fn stereo_views_are_visible_in_both_cameras() {
    let left = camera();
    let right =
        Camera::new(Intrinsics::new(805.0, 795.0, 318.0, 243.0), Distortion::new(-0.1, 0.05, 0.0, 0.0, 0.0), 640, 480)
            .unwrap();
    let right_from_left = Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.02, 0.005), DVec3::new(-60.0, 0.5, 0.3));
    let rig = StereoRig::new(left, right, right_from_left).unwrap();
    let b = board();
    let poses = stereo_calibration_poses(&rig, &b, &ViewSetConfig { views: 8, ..Default::default() }).unwrap();
    assert_eq!(poses.len(), 8);
    for pose in &poses {
        for c in project_corners(&rig.left, &b, pose).unwrap() {
            assert!(rig.left.contains(c));
        }
        for c in project_corners(&rig.right, &b, &(right_from_left * *pose)).unwrap() {
            assert!(rig.right.contains(c));
        }
    }
}

#[test]
fn bad_view_set_inputs_are_errors() {
    let cam = camera();
    let b = board();
    let bad = |cfg: ViewSetConfig| calibration_poses(&cam, &b, &cfg).unwrap_err().to_string();
    assert!(bad(ViewSetConfig { views: 0, ..Default::default() }).contains("views"));
    assert!(bad(ViewSetConfig { min_distance: 700.0, ..Default::default() }).contains("min_distance"));
    assert!(bad(ViewSetConfig { max_tilt_deg: f64::NAN, ..Default::default() }).contains("max_tilt_deg"));
    // A board in metres with distances in millimetres: far too small is fine, far too large is not.
    let huge = Chessboard::new(9, 6, 250.0).unwrap();
    let e = calibration_poses(&cam, &huge, &ViewSetConfig::default()).unwrap_err();
    assert!(matches!(e, SyntheticError::Infeasible { .. }), "{e}");
    let mut broken = cam;
    broken.intrinsics.fx = -1.0;
    assert!(calibration_poses(&broken, &b, &ViewSetConfig::default()).unwrap_err().to_string().contains("camera"));
    let bad_board = Chessboard { cols: 1, rows: 6, square_size: 25.0 };
    assert!(project_corners(&cam, &bad_board, &Isometry3::IDENTITY).is_err());
    let behind = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(0.0, 0.0, -100.0));
    assert!(project_corners(&cam, &b, &behind).is_err());
    let nan = Isometry3::from_rvec_tvec(DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 100.0));
    assert!(project_corners(&cam, &b, &nan).is_err());
}

fn max_err(a: &Isometry3, b: &Isometry3) -> f64 {
    let (r, t) = a.distance(b);
    r.max(t)
}

#[test]
fn eye_in_hand_trajectory_closes_the_chain() {
    let cfg = TrajectoryConfig { rot_noise_rad: 0.0, trans_noise: 0.0, ..Default::default() };
    let t = hand_eye_trajectory(&cfg).unwrap();
    assert_eq!(t.base_from_gripper.len(), 10);
    assert!(t.eye_in_hand);
    let x = t.truth.gripper_from_camera;
    for (g, c) in t.base_from_gripper.iter().zip(&t.camera_from_board) {
        let w = *g * x * *c;
        assert!(max_err(&w, &t.truth.base_from_board) < 1e-12, "{w:?}");
        let depth = c.translation.z;
        assert!((0.4..=0.7).contains(&depth), "depth {depth}");
        assert!(tilt_deg(c) <= 45.0 + 1e-9, "view angle {}", tilt_deg(c));
        assert!(x.translation.abs().max_element() <= 0.1);
    }
    // The unused pair is the station-0 value, consistent with the chain.
    assert!(max_err(&(t.base_from_gripper[0] * x), &t.truth.base_from_camera) < 1e-12);
    assert!(max_err(&(x * t.camera_from_board[0]), &t.truth.gripper_from_board) < 1e-12);
}

#[test]
fn eye_to_hand_trajectory_closes_the_chain() {
    let cfg =
        TrajectoryConfig { eye_in_hand: false, rot_noise_rad: 0.0, trans_noise: 0.0, seed: 5, ..Default::default() };
    let t = hand_eye_trajectory(&cfg).unwrap();
    assert!(!t.eye_in_hand);
    for (g, c) in t.base_from_gripper.iter().zip(&t.camera_from_board) {
        let lhs = t.truth.base_from_camera * *c;
        let rhs = *g * t.truth.gripper_from_board;
        assert!(max_err(&lhs, &rhs) < 1e-12);
    }
    assert!(max_err(&(t.truth.gripper_from_camera * t.camera_from_board[0]), &t.truth.gripper_from_board) < 1e-12);
}

#[test]
fn trajectory_noise_matches_the_configuration() {
    // Noise on both poses: the chain residual per station has rotation ≈ sqrt(2)·σ·sqrt(3)…,
    // so check the mean closure error against its expectation from the same generator.
    let sig = 0.1f64.to_radians();
    let cfg = TrajectoryConfig { stations: 400, rot_noise_rad: sig, trans_noise: 0.0, ..Default::default() };
    let clean = hand_eye_trajectory(&TrajectoryConfig { rot_noise_rad: 0.0, ..cfg.clone() }).unwrap();
    let noisy = hand_eye_trajectory(&cfg).unwrap();
    assert_eq!(clean.truth, noisy.truth, "noise must not change the truth");
    // Camera pose noise alone: clean⁻¹·noisy = Exp(ω, 0) with ω ~ N(0, σ²) per axis.
    let mut sum = 0.0;
    for (c0, c1) in clean.camera_from_board.iter().zip(&noisy.camera_from_board) {
        let d = c0.inverse() * *c1;
        sum += d.rvec().length_squared();
        assert!(d.translation.length() < 1e-12);
    }
    let rms_axis = (sum / (3.0 * 400.0)).sqrt();
    assert!((rms_axis / sig - 1.0).abs() < 0.08, "rotation noise per axis {rms_axis} vs {sig}");
}

#[test]
fn bad_trajectory_inputs_are_errors() {
    let e = |cfg: TrajectoryConfig| hand_eye_trajectory(&cfg).unwrap_err().to_string();
    assert!(e(TrajectoryConfig { stations: 1, ..Default::default() }).contains("stations"));
    assert!(e(TrajectoryConfig { min_distance: 1.0, ..Default::default() }).contains("min_distance"));
    assert!(e(TrajectoryConfig { trans_noise: -1.0, ..Default::default() }).contains("trans_noise"));
    assert!(e(TrajectoryConfig { rot_noise_rad: f64::NAN, ..Default::default() }).contains("rot_noise_rad"));
}

#[test]
fn view_set_configurations_refuse_their_invalid_fields() {
    // the pinhole view sets allow tilts below 80°, the wide-angle ones below 75°; both share
    // the other checks (one function)
    let ok = ViewSetConfig::default();
    assert!(ok.validate().is_ok());
    let wide = WideViewSetConfig::default();
    assert!(wide.validate().is_ok());
    let tilt = |t: f64| ViewSetConfig { max_tilt_deg: t, ..ok.clone() }.validate();
    let wide_tilt = |t: f64| WideViewSetConfig { max_tilt_deg: t, ..wide.clone() }.validate();
    assert!(tilt(79.9).is_ok() && wide_tilt(74.9).is_ok());
    let e = tilt(80.0).unwrap_err().to_string();
    assert!(e.contains("max_tilt_deg") && e.contains("below 80"), "{e}");
    let e = wide_tilt(75.0).unwrap_err().to_string();
    assert!(e.contains("max_tilt_deg") && e.contains("below 75"), "{e}");
    for bad in [
        ViewSetConfig { views: 0, ..ok.clone() },
        ViewSetConfig { max_tilt_deg: -1.0, ..ok.clone() },
        ViewSetConfig { max_roll_deg: f64::NAN, ..ok.clone() },
        ViewSetConfig { min_distance: 0.0, ..ok.clone() },
        ViewSetConfig { min_distance: 700.0, max_distance: 600.0, ..ok.clone() },
        ViewSetConfig { border_squares: -0.5, ..ok.clone() },
        ViewSetConfig { margin_px: f64::INFINITY, ..ok.clone() },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
    for bad in [
        WideViewSetConfig { views: 0, ..wide.clone() },
        WideViewSetConfig { max_distance: -1.0, ..wide.clone() },
        WideViewSetConfig { min_distance: 500.0, max_distance: 450.0, ..wide.clone() },
        WideViewSetConfig { max_field_angle_deg: 0.0, ..wide.clone() },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
}
