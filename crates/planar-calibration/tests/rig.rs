//! Rig calibration against ground truth made by our projection (the OpenCV-made sets are in
//! `rig_opencv.rs`): four cameras of three lenses, partial visibility, a camera linked to
//! camera 0 only through another, honest 1σ over 100 noise draws, and the refusals.

use glam::{DVec2, DVec3};
use parallax_camera_model::{
    Camera, Chessboard, Distortion, DoubleSphere, Intrinsics, Isometry3, KannalaBrandt, Lens, LensModel,
};
use parallax_planar_calibration::{CalibrationConfig, CalibrationError, CameraView, RigConfig, calibrate_rig};
use parallax_synthetic::{add_pixel_noise, rng};
use rand::Rng;

struct Scene {
    cameras: Vec<Camera>,
    cam_from_cam0: Vec<Isometry3>,
    board: Chessboard,
    /// Per frame: `cam0_from_board` and which cameras see all of the board.
    frames: Vec<(Isometry3, Vec<bool>)>,
}

fn four_cameras() -> (Vec<Camera>, Vec<Isometry3>) {
    let pinhole = |fx: f64, fy: f64, cx: f64, cy: f64, d: Distortion| {
        Camera::new(Intrinsics::new(fx, fy, cx, cy), d, 1280, 960).unwrap()
    };
    let cameras = vec![
        pinhole(950.0, 948.0, 641.0, 478.5, Distortion::new(-0.25, 0.08, 0.001, -0.0005, -0.01)),
        pinhole(985.0, 983.0, 633.5, 485.0, Distortion::new(-0.22, 0.06, -0.0007, 0.0004, 0.0)),
        Camera::new(
            Intrinsics::new(450.0, 451.0, 645.0, 508.0),
            Lens::KannalaBrandt(KannalaBrandt::new(0.05, -0.01, 0.002, -0.0005).unwrap()),
            1280,
            1024,
        )
        .unwrap(),
        Camera::new(
            Intrinsics::new(350.0, 349.0, 636.0, 515.0),
            Lens::DoubleSphere(DoubleSphere::new(-0.2, 0.6).unwrap()),
            1280,
            1024,
        )
        .unwrap(),
    ];
    // camI_from_cam0: a stereo pair 150 mm apart, a wide camera turned 40°, a second wide
    // camera turned 85° and 430 mm away.
    let extr = vec![
        Isometry3::IDENTITY,
        Isometry3::from_rvec_tvec(DVec3::new(0.01, -0.02, 0.005), DVec3::new(-150.0, 1.5, -2.0)),
        Isometry3::from_rvec_tvec(DVec3::new(0.0, -40f64.to_radians(), 0.01), DVec3::new(-250.0, 5.0, 40.0)),
        Isometry3::from_rvec_tvec(DVec3::new(0.02, -85f64.to_radians(), 0.0), DVec3::new(-400.0, -10.0, 150.0)),
    ];
    (cameras, extr)
}

fn sees(camera: &Camera, pose: &Isometry3, board: &Chessboard) -> bool {
    board.object_points().iter().all(|p| {
        let q = pose.transform_point(*p);
        q.z > 100.0
            && camera.project_from(pose, *p).is_ok_and(|u| {
                u.x >= 10.0 && u.y >= 10.0 && u.x <= camera.width as f64 - 11.0 && u.y <= camera.height as f64 - 11.0
            })
    })
}

/// 60 frames of a 16x12 board of 26 mm (the 12x9 / 35 mm board's size with 1.9x its corners):
/// each aimed at one camera's field (board 0.45–0.9 m away, 0.3–0.6 m for the wide cameras,
/// tilted 20–50° about a random in-plane axis); camera 3 never sees a frame camera 0 sees (its
/// view is dropped).
fn scene(seed: u64) -> Scene {
    let (cameras, cam_from_cam0) = four_cameras();
    let board = Chessboard::new(16, 12, 26.0).unwrap();
    let centre = DVec3::new(15.0 * 26.0 / 2.0, 11.0 * 26.0 / 2.0, 0.0);
    let mut r = rng(seed);
    let mut frames = Vec::new();
    let mut attempts = 0;
    while frames.len() < 60 {
        attempts += 1;
        assert!(attempts < 100_000, "scene generation stalled");
        let aim = frames.len() % 4;
        let cam = &cameras[aim];
        // A direction within the camera's field: a random pixel, its ray.
        let spread = if aim >= 2 { 0.35 } else { 0.2 };
        let px = DVec2::new(
            r.random_range(0.5 - spread..0.5 + spread) * cam.width as f64,
            r.random_range(0.5 - spread..0.5 + spread) * cam.height as f64,
        );
        let Ok(ray) = cam.unproject(px) else { continue };
        let dist = if aim >= 2 { r.random_range(300.0..600.0) } else { r.random_range(450.0..900.0) };
        let tilt = r.random_range(20f64..50.0).to_radians();
        let phi = r.random_range(0.0..std::f64::consts::TAU);
        let roll = r.random_range(-0.3..0.3);
        // Board facing the camera (its z along the ray), then tilted.
        let facing = Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.0, roll), DVec3::ZERO);
        let tilt_rot = Isometry3::from_rvec_tvec(DVec3::new(phi.cos(), phi.sin(), 0.0) * tilt, DVec3::ZERO);
        let z = ray.normalize();
        let x = DVec3::Y.cross(z).normalize();
        let y = z.cross(x);
        let align = Isometry3::from_rotation_translation(glam::DMat3::from_cols(x, y, z), DVec3::ZERO).unwrap();
        let rot = align * tilt_rot * facing;
        let cam_from_board =
            Isometry3::from_rotation_translation(rot.rotation_matrix(), z * dist - rot.transform_vector(centre))
                .unwrap();
        let cam0_from_board = cam_from_cam0[aim].inverse() * cam_from_board;
        let mut seen: Vec<bool> =
            (0..4).map(|c| sees(&cameras[c], &(cam_from_cam0[c] * cam0_from_board), &board)).collect();
        if seen[0] && seen[3] {
            seen[3] = false;
        }
        if seen[aim] {
            frames.push((cam0_from_board, seen));
        }
    }
    // The wide cameras see most frames: a detector misses some views (drop views of cameras
    // seeing more than 55 % of the frames, never a frame's last view).
    for c in 0..4 {
        while frames.iter().filter(|f| f.1[c]).count() > 33 {
            let f = r.random_range(0..frames.len());
            if frames[f].1[c] && frames[f].1.iter().filter(|&&v| v).count() > 1 {
                frames[f].1[c] = false;
            }
        }
    }
    Scene { cameras, cam_from_cam0, board, frames }
}

fn observe(s: &Scene, sigma: f64, seed: u64) -> Vec<Vec<Option<CameraView>>> {
    let mut r = rng(seed);
    s.frames
        .iter()
        .map(|(pose, seen)| {
            (0..s.cameras.len())
                .map(|c| {
                    seen[c].then(|| {
                        let p = s.cam_from_cam0[c] * *pose;
                        let object = s.board.object_points();
                        let mut image: Vec<DVec2> =
                            object.iter().map(|x| s.cameras[c].project_from(&p, *x).unwrap()).collect();
                        add_pixel_noise(&mut image, sigma, &mut r);
                        CameraView { object, image }
                    })
                })
                .collect()
        })
        .collect()
}

fn config(s: &Scene) -> RigConfig {
    RigConfig {
        cameras: s
            .cameras
            .iter()
            .map(|c| CalibrationConfig { lens: c.lens_model(), ..CalibrationConfig::default() })
            .collect(),
        ..RigConfig::default()
    }
}

fn sizes(s: &Scene) -> Vec<(u32, u32)> {
    s.cameras.iter().map(|c| (c.width, c.height)).collect()
}

/// The scene is the issue's: each camera sees the target in 30–60 % of the frames, camera 3
/// never with camera 0 (it is linked through camera 2).
fn check_scene(s: &Scene) {
    let counts: Vec<usize> = (0..4).map(|c| s.frames.iter().filter(|f| f.1[c]).count()).collect();
    let shared: Vec<Vec<usize>> =
        (0..4).map(|a| (0..4).map(|b| s.frames.iter().filter(|f| f.1[a] && f.1[b]).count()).collect()).collect();
    eprintln!("frames per camera {counts:?}, shared {shared:?}");
    for c in 0..4 {
        let n = s.frames.iter().filter(|f| f.1[c]).count();
        assert!((18..=36).contains(&n), "camera {c} sees {n} of 60 frames");
    }
    assert!(s.frames.iter().all(|f| !(f.1[0] && f.1[3])));
    let shared = |a: usize, b: usize| s.frames.iter().filter(|f| f.1[a] && f.1[b]).count();
    assert!(shared(2, 3) >= 3 && shared(0, 2) + shared(1, 2) >= 3, "cameras 2 and 3 linked");
}

#[test]
fn four_cameras_of_three_lenses_match_the_truth() {
    let s = scene(7);
    check_scene(&s);
    let frames = observe(&s, 0.2, 11);
    let r = calibrate_rig(&frames, &sizes(&s), &config(&s)).unwrap();
    assert!((r.rms_px - 0.2 * 2f64.sqrt()).abs() < 0.03, "rms {}", r.rms_px);
    for c in 0..4 {
        let (got, want) = (r.cameras[c].intrinsics(), s.cameras[c].intrinsics());
        // The focal length the views determine: fx, or fx/(1+ξ) for the double sphere (whose
        // fx alone trades off against ξ: 1σ 0.15 % here).
        let axis_focal = |cam: &Camera, f: f64| match cam.lens() {
            Lens::DoubleSphere(ds) => f / (1.0 + ds.xi()),
            _ => f,
        };
        for (name, g, w) in [("fx", got.fx, want.fx), ("fy", got.fy, want.fy)] {
            let (g, w) = (axis_focal(&r.cameras[c], g), axis_focal(&s.cameras[c], w));
            assert!((g / w - 1.0).abs() < 1e-3, "camera {c}: {name} {g} vs {w}");
        }
        let sd = r.std_devs[c].fx.unwrap();
        assert!((got.fx - want.fx).abs() < 4.0 * sd, "camera {c}: fx {} vs {} (1σ {sd})", got.fx, want.fx);
        assert_eq!(r.cameras[c].lens_model(), s.cameras[c].lens_model());
        if c > 0 {
            let (angle, _) = r.cam_from_cam0[c].distance(&s.cam_from_cam0[c]);
            let (tg, tw) = (r.cam_from_cam0[c].translation, s.cam_from_cam0[c].translation);
            let sd = &r.extrinsic_std_devs[c];
            eprintln!(
                "camera {c}: rotation error {:.4}° (1σ {:.4}°), t error {:.4} (1σ {:.4}, {:.3} % of |t|), fx error \
                 {:.4} % (1σ {:.4} %)",
                angle.to_degrees(),
                sd.angle_rad.to_degrees(),
                (tg - tw).length(),
                sd.translation.length(),
                100.0 * (tg - tw).length() / tw.length(),
                100.0 * (got.fx / want.fx - 1.0),
                100.0 * r.std_devs[c].fx.unwrap() / want.fx
            );
            // Within 4σ of the reported uncertainty, and within the 0.05° / 0.1 % of
            // |t| (with this board, seed 7 below at most 0.019° and 0.089 %; seeds 1–6 at most
            // 0.034° and 0.067 %).
            assert!(
                angle < 4.0 * sd.angle_rad && angle.to_degrees() < 0.05,
                "camera {c}: rotation off by {}°",
                angle.to_degrees()
            );
            assert!((tg - tw).length() < 4.0 * sd.translation.length(), "camera {c}: t {tg} vs {tw}");
            assert!((tg - tw).length() < 1e-3 * tw.length(), "camera {c}: t {tg} vs {tw}");
        }
    }
    // The link of camera 3 goes through camera 2; the visibility matrix is the input's.
    assert_eq!(r.shared_frames[0][3], 0);
    let vis = r.visibility();
    for (f, (_, seen)) in s.frames.iter().enumerate() {
        assert_eq!(&vis[f], seen);
    }
}

/// 1σ is honest: over 100 noise draws on the same geometry, the errors of every focal length
/// (but the double sphere's),
/// every extrinsic translation component and rotation component divided by their reported 1σ
/// have an RMS within 0.7–1.4.
#[test]
fn std_devs_are_honest_over_100_trials() {
    let s = scene(7);
    let cfg = config(&s);
    let mut z2: Vec<(String, f64)> = Vec::new();
    let trials = 100;
    for t in 0..trials {
        let frames = observe(&s, 0.2, 1000 + t);
        let r = calibrate_rig(&frames, &sizes(&s), &cfg).unwrap();
        let mut push = |name: String, z: f64| match z2.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => *v += z * z,
            None => z2.push((name, z * z)),
        };
        for c in 0..4 {
            let k = r.cameras[c].intrinsics();
            // (not the double sphere's fx: in about 1 draw in 100 it settles in the other valley
            // of the fx–ξ trade-off, fx 600 instead of 350 with the same fx/(1+ξ) to 0.2 %)
            if c != 3 {
                push(format!("fx{c}"), (k.fx - s.cameras[c].intrinsics().fx) / r.std_devs[c].fx.unwrap());
            }
            if c > 0 {
                let sd = &r.extrinsic_std_devs[c];
                let dt = r.cam_from_cam0[c].translation - s.cam_from_cam0[c].translation;
                // Left perturbation: est = exp(ω) truth.
                let w = (r.cam_from_cam0[c] * s.cam_from_cam0[c].inverse()).rvec();
                for a in 0..3 {
                    push(format!("t{c}{a}"), dt[a] / sd.translation[a]);
                    push(format!("w{c}{a}"), w[a] / sd.rotation_rad[a]);
                }
            }
        }
    }
    let mut all = 0.0;
    for (name, sum) in &z2 {
        let rms = (sum / trials as f64).sqrt();
        eprintln!("{name}: z-score RMS {rms:.3}");
        // One parameter's RMS of 100 z-scores: ±0.07 (1σ) around 1 when honest.
        assert!((0.7..=1.4).contains(&rms), "{name}: z-score RMS {rms:.2}");
        all += sum;
    }
    let overall = (all / (trials as f64 * z2.len() as f64)).sqrt();
    eprintln!("overall z-score RMS {overall:.3} over {} parameters", z2.len());
    assert!((0.85..=1.15).contains(&overall), "overall z-score RMS {overall:.3}");
}

#[test]
fn a_camera_linked_to_nothing_is_refused_naming_it() {
    let s = scene(7);
    let mut frames = observe(&s, 0.2, 3);
    // Camera 2 loses every frame it shared: camera 3 (and 2) are then unreachable.
    for f in frames.iter_mut() {
        if f[2].is_some() && (f[0].is_some() || f[1].is_some()) {
            f[2] = None;
        }
        if f[3].is_some() && (f[0].is_some() || f[1].is_some()) {
            f[3] = None;
        }
    }
    let e = calibrate_rig(&frames, &sizes(&s), &config(&s)).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, CalibrationError::Degenerate(_)), "{msg}");
    assert!(msg.contains("[2, 3]") && msg.contains("share no frame"), "{msg}");
}

#[test]
fn a_camera_that_saw_nothing_and_unseen_frames_are_refused() {
    let s = scene(7);
    let mut frames = observe(&s, 0.2, 3);
    for f in frames.iter_mut() {
        f[1] = None;
    }
    let e = calibrate_rig(&frames, &sizes(&s), &config(&s)).unwrap_err().to_string();
    assert!(e.contains("camera 1 saw the target in no frame"), "{e}");
    let mut frames = observe(&s, 0.2, 3);
    frames[5] = vec![None; 4];
    frames[9] = vec![None; 4];
    let e = calibrate_rig(&frames, &sizes(&s), &config(&s)).unwrap_err().to_string();
    assert!(e.contains("[5, 9]") && e.contains("seen by no camera"), "{e}");
}

/// Three pinhole cameras whose every view is within 1° of fronto-parallel: refused (the
/// focal length and the rig's scale are not determined), never a rig with exit 0.
#[test]
fn near_parallel_views_are_refused_for_three_cameras() {
    let cam = Camera::new(
        Intrinsics::new(1000.0, 1000.0, 640.0, 480.0),
        Distortion::new(-0.1, 0.02, 0.0, 0.0, 0.0),
        1280,
        960,
    )
    .unwrap();
    let extr = [
        Isometry3::IDENTITY,
        Isometry3::from_rvec_tvec(DVec3::new(0.0, 0.01, 0.0), DVec3::new(-110.0, 0.0, 0.0)),
        Isometry3::from_rvec_tvec(DVec3::new(0.01, 0.0, 0.0), DVec3::new(0.0, 110.0, 0.0)),
    ];
    let board = Chessboard::new(7, 6, 30.0).unwrap();
    let mut r = rng(5);
    let mut frames = Vec::new();
    while frames.len() < 30 {
        let axis = r.random_range(0.0..std::f64::consts::TAU);
        let tilt = r.random_range(0.0..1.0f64).to_radians();
        let rv = DVec3::new(axis.cos(), axis.sin(), 0.0) * tilt;
        let t = DVec3::new(r.random_range(-250.0..80.0), r.random_range(-200.0..60.0), r.random_range(400.0..1000.0));
        let pose = Isometry3::from_rvec_tvec(rv, t);
        let views: Vec<Option<CameraView>> = extr
            .iter()
            .map(|e| {
                let p = *e * pose;
                sees(&cam, &p, &board).then(|| {
                    let object = board.object_points();
                    let mut image: Vec<DVec2> = object.iter().map(|x| cam.project_from(&p, *x).unwrap()).collect();
                    add_pixel_noise(&mut image, 0.2, &mut r);
                    CameraView { object, image }
                })
            })
            .collect();
        if views.iter().all(Option::is_some) {
            frames.push(views);
        }
    }
    let cfg = RigConfig::uniform(3, CalibrationConfig { lens: LensModel::BrownConrady, ..Default::default() });
    let e = calibrate_rig(&frames, &[(1280, 960); 3], &cfg).unwrap_err().to_string();
    assert!(e.contains("parallel") || e.contains("not determined"), "{e}");
}
