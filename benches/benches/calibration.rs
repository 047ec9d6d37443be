//! Calibration speed: 14 views of a 9x6 board (756 corners), as OpenCV's `calibrateCamera`
//! (~18 ms on this machine for the real 14-view set), the 14-pair stereo calibration, and a
//! rig of 8 cameras × 200 frames (`calibrate_rig`; the goal: under 10 s).

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{DVec2, DVec3};
use parallax_camera_model::{Camera, Chessboard, Distortion, Intrinsics, Isometry3, StereoRig};
use parallax_planar_calibration::{
    CalibrationConfig, CameraView, RigConfig, StereoConfig, calibrate_camera, calibrate_rig, calibrate_stereo,
};
use parallax_synthetic::{ViewSetConfig, add_pixel_noise, project_corners, rng, stereo_calibration_poses};

/// Object points and the left and right corners of every view.
type Views = (Vec<Vec<DVec3>>, Vec<Vec<DVec2>>, Vec<Vec<DVec2>>);

fn setup() -> Views {
    let left = Camera::new(
        Intrinsics::new(533.0, 533.0, 341.6, 234.3),
        Distortion::new(-0.28, 0.05, 0.001, 0.0, 0.1),
        640,
        480,
    )
    .unwrap();
    let right = Camera::new(
        Intrinsics::new(537.0, 536.6, 326.5, 249.3),
        Distortion::new(-0.29, 0.13, 0.0, 0.0, -0.04),
        640,
        480,
    )
    .unwrap();
    let rig = StereoRig::new(
        left,
        right,
        Isometry3::from_rvec_tvec(DVec3::new(0.0067, 0.0045, -0.0035), DVec3::new(-99.8, 1.12, 0.05)),
    )
    .unwrap();
    let board = Chessboard::new(9, 6, 30.0).unwrap();
    let cfg =
        ViewSetConfig { views: 14, seed: 5, min_distance: 350.0, max_distance: 600.0, ..ViewSetConfig::default() };
    let poses = stereo_calibration_poses(&rig, &board, &cfg).unwrap();
    let mut r = rng(6);
    let mut proj = |cam: &Camera, p: &Isometry3| {
        let mut c = project_corners(cam, &board, p).unwrap();
        add_pixel_noise(&mut c, 0.15, &mut r);
        c
    };
    let l: Vec<Vec<DVec2>> = poses.iter().map(|p| proj(&rig.left, p)).collect();
    let rr: Vec<Vec<DVec2>> = poses.iter().map(|p| proj(&rig.right, &(rig.right_from_left * *p))).collect();
    (vec![board.object_points(); poses.len()], l, rr)
}

/// Eight pinhole cameras on a ring of radius 150 looking outwards 45° apart (fx 400 on 1280
/// px: neighbours' fields overlap by ~70°), 200 frames of a 9x6 board of 40 mm squares placed
/// around the ring (600–1000 from its centre, facing it, tilted 15–40°), seen by every camera
/// that has all its corners in view (σ = 0.2 px).
fn ring_rig() -> Vec<Vec<Option<CameraView>>> {
    use rand::Rng;
    let cam =
        Camera::new(Intrinsics::new(400.0, 400.0, 640.0, 480.0), Distortion::new(-0.1, 0.01, 0.0, 0.0, 0.0), 1280, 960)
            .unwrap();
    let board = Chessboard::new(9, 6, 40.0).unwrap();
    let centre = DVec3::new(160.0, 100.0, 0.0);
    // world_from_camI: turned by 45°·I about y, on the ring; camI_from_world.
    let from_world: Vec<Isometry3> = (0..8)
        .map(|i| {
            let yaw = (45.0 * i as f64).to_radians();
            Isometry3::from_rvec_tvec(DVec3::new(0.0, yaw, 0.0), DVec3::new(150.0 * yaw.sin(), 0.0, 150.0 * yaw.cos()))
                .inverse()
        })
        .collect();
    let mut r = rng(17);
    let mut frames = Vec::new();
    while frames.len() < 200 {
        let yaw = r.random_range(0.0..std::f64::consts::TAU);
        let tilt = r.random_range(15f64..40.0).to_radians();
        let phi = r.random_range(0.0..std::f64::consts::TAU);
        // Board frame: z towards the ring centre (then tilted), centred at `at`.
        let rv = DVec3::new(0.0, yaw + std::f64::consts::PI, 0.0);
        let facing = Isometry3::from_rvec_tvec(rv, DVec3::ZERO)
            * Isometry3::from_rvec_tvec(DVec3::new(phi.cos(), phi.sin(), 0.0) * tilt, DVec3::ZERO);
        let dist = r.random_range(600.0..1000.0);
        let at = DVec3::new(dist * yaw.sin(), r.random_range(-150.0..150.0), dist * yaw.cos());
        let world_from_board =
            Isometry3::from_rotation_translation(facing.rotation_matrix(), at - facing.transform_vector(centre))
                .unwrap();
        let views: Vec<Option<CameraView>> = from_world
            .iter()
            .map(|e| {
                let p = *e * world_from_board;
                let px: Option<Vec<DVec2>> = board
                    .object_points()
                    .iter()
                    .map(|x| {
                        (p.transform_point(*x).z > 100.0)
                            .then(|| cam.project_from(&p, *x).ok())
                            .flatten()
                            .filter(|u| u.x > 10.0 && u.y > 10.0 && u.x < 1269.0 && u.y < 949.0)
                    })
                    .collect();
                px.map(|mut image| {
                    add_pixel_noise(&mut image, 0.2, &mut r);
                    CameraView { object: board.object_points(), image }
                })
            })
            .collect();
        if views.iter().filter(|v| v.is_some()).count() >= 1 {
            frames.push(views);
        }
    }
    frames
}

fn bench_rig(c: &mut Criterion) {
    let (frames, sizes) = (ring_rig(), vec![(1280, 960); 8]);
    let seen: usize = frames.iter().map(|f| f.iter().flatten().count()).sum();
    let shared: usize = frames.iter().filter(|f| f.iter().flatten().count() >= 2).count();
    eprintln!("rig: 8 cameras x {} frames, {seen} views, {shared} frames seen by two cameras or more", frames.len());
    let r = calibrate_rig(&frames, &sizes, &RigConfig::uniform(8, CalibrationConfig::default())).unwrap();
    eprintln!("rig: RMS {:.4} px, {} iterations, {} parameters", r.rms_px, r.iterations, r.num_parameters);
    let cfg = RigConfig::uniform(8, CalibrationConfig::default());
    c.bench_function("calibrate_rig 8 cameras x 200 frames", |b| {
        b.iter(|| calibrate_rig(&frames, &sizes, &cfg).unwrap())
    });
}

fn bench(c: &mut Criterion) {
    let (object, left, right) = setup();
    let cfg = CalibrationConfig::default();
    c.bench_function("calibrate_camera 14 views x 54 corners", |b| {
        b.iter(|| calibrate_camera(&object, &left, 640, 480, &cfg).unwrap())
    });
    let scfg = StereoConfig::default();
    c.bench_function("calibrate_stereo 14 pairs x 54 corners", |b| {
        b.iter(|| calibrate_stereo(&object, &left, &right, (640, 480), (640, 480), &scfg).unwrap())
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_group! {
    name = rig;
    config = Criterion::default().sample_size(10);
    targets = bench_rig
}
criterion_main!(benches, rig);
